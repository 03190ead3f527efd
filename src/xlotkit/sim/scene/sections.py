"""The sections of a scene: one frozen, validated dataclass per TOML table (SI inside)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from typing import ClassVar, Literal

from xlotkit.checks import check_range as _check
from xlotkit.errors import InputError
from xlotkit.sim.scene.keys import _spec, _validate
from xlotkit.sim.scene.lumped import NWB_DEFAULT
from xlotkit.sim.well import INCH, WATER_COMPRESSIBILITY, Completion

__all__ = [
    "CompletionOptions",
    "CouplingOptions",
    "Effects",
    "Fluid",
    "Geometry",
    "Interface",
    "LumpedOptions",
    "MeshOptions",
    "Numerics",
    "OutputOptions",
    "Rock",
    "Stresses",
    "WellCouplingOptions",
]


@dataclass(frozen=True, kw_only=True)
class CouplingOptions:
    """Tuning of the partitioned schemes (ignored by ``monolithic``).

    Attributes
    ----------
    wfd_tolerance : float
        ``eps_BHP,max``: relative BHP error (Eq. 4.17a) accepted by WFD. Default 9e-4, the
        thesis script's value (27 kPa at 30 MPa).
    wfd_rate_tolerance : float
        ``eps_LO,max``: relative leak-rate change (Eq. 4.17b) checked on the first iteration
        of a step (thesis script: 1e-3).
    wfd_max_iterations : int
        Segment calls per step before WFD gives up and keeps the least-error iterate
        (thesis script: 3; 10 here, enough for the breakdown step at the default tolerance).
    wfd_calibration : float
        Damping of the first (calibration) update ``Q* <- Q* + d (Q_LO - Q*)``.
    wfc_gain : float
        Normalised WFC gain ``G`` [-]: each step the rate into the segment changes by
        ``G c_eff (p_w - p_s) / dt`` (the sum of the thesis's per-step errors is the present
        mismatch; ``c_eff`` the series compliance of well and segment), i.e. ``G`` times the
        volume that would equalise the two pressures, spread over one step (with adaptive
        steps, over the step the carried rate was set for when the present one is shorter:
        :func:`xlotkit.sim.coupling.schemes._step_wfc`).
    wfc_damping : float
        WFC damping ``gamma`` (Eq. 4.22; thesis example 0.05).
    wfdmod_gain, wfdmod_damping : float
        Gain and damping of Eq. 4.23 (same normalisation as ``wfc_gain``).
    """

    wfd_tolerance: float = 9e-4
    wfd_rate_tolerance: float = 1e-3
    wfd_max_iterations: int = 10
    wfd_calibration: float = 1.0
    wfc_gain: float = 0.25
    wfc_damping: float = 0.05
    wfdmod_gain: float = 0.5
    wfdmod_damping: float = 0.1

    def __post_init__(self) -> None:
        _check("wfd_tolerance", self.wfd_tolerance, lo=0.0, hi=1.0, lo_open=True)
        _check("wfd_rate_tolerance", self.wfd_rate_tolerance, lo=0.0, hi=10.0, lo_open=True)
        if isinstance(self.wfd_max_iterations, bool) or not isinstance(
                self.wfd_max_iterations, int) or not 1 <= self.wfd_max_iterations <= 1000:
            raise InputError(f"value {self.wfd_max_iterations!r} is out of range",
                             key="wfd_max_iterations", expected="an integer in [1, 1000]")
        _check("wfd_calibration", self.wfd_calibration, lo=0.0, hi=10.0, lo_open=True)
        _check("wfc_gain", self.wfc_gain, lo=0.0, hi=10.0)
        _check("wfc_damping", self.wfc_damping, lo=0.0, hi=1.0, hi_open=True)
        _check("wfdmod_gain", self.wfdmod_gain, lo=0.0, hi=10.0)
        _check("wfdmod_damping", self.wfdmod_damping, lo=0.0, hi=1.0, hi_open=True)


_WC = CouplingOptions()

#: The 2D domain's side is at least this many hole radii (see :class:`Geometry`).
DOMAIN_PER_RADIUS = 20.0
#: Finest wall the mesh generator is asked for: 2 pi r / 2048 (beyond, a 2D run of a
#: leak-off test is all wall and no rock).
MAX_WALL_SEGMENTS = 2048


@dataclass(frozen=True, kw_only=True)
class Geometry:
    """``[geometry]``: the 2D section through the open hole (SI)."""

    section: ClassVar[str] = "geometry"
    domain_size: float = 100.0
    hole_radius: float = 0.15
    segment_height: float = 10.0

    def __post_init__(self) -> None:
        _validate(self, self.section)
        # the hole's disturbance of the far field decays as (a / r)^2 (Kirsch): at the
        # domain's edge, 10 hole diameters away, it is 1 % of the far field
        if self.hole_radius * DOMAIN_PER_RADIUS > self.domain_size * (1.0 + 1e-12):
            raise InputError(f"value {self.hole_radius!r} m is too large for the domain",
                             key="geometry.hole_radius",
                             expected=f"a radius <= domain_size / {DOMAIN_PER_RADIUS:g} = "
                                      f"{self.domain_size / DOMAIN_PER_RADIUS:g} m (or a "
                                      f"larger geometry.domain_size)")


@dataclass(frozen=True, kw_only=True)
class MeshOptions:
    """``[mesh]``: the graded borehole mesh of the 2D model (see :func:`borehole_mesh`)."""

    section: ClassVar[str] = "mesh"
    growth: float = 1.2
    wall_element_size: float | None = None
    max_element_size: float | None = None
    fracture_band: bool = False
    band_width: float = 1.0
    band_element_size: float | None = None
    band_length: float | None = None
    band_strip: bool = False
    band_centred_wall: bool = False
    jitter: float = 0.0
    seed: int | None = None
    file: str | None = None

    def __post_init__(self) -> None:
        _validate(self, self.section)
        if self.band_centred_wall and not self.fracture_band:
            raise InputError("mesh.band_centred_wall places the wall by the fracture band, "
                             "which is off", key="mesh.band_centred_wall",
                             expected="mesh.fracture_band = true, or no band_centred_wall")


@dataclass(frozen=True, kw_only=True)
class Rock:
    """``[rock]``: elastic, hydraulic and strength properties (SI; angles in degrees)."""

    section: ClassVar[str] = "rock"
    youngs_modulus: float = 10e9
    poisson_ratio: float = 0.25
    biot: float = 1.0
    porosity: float = 0.1
    permeability: float = 1e-18
    tensile_strength: float = 3e6
    cohesion: float = 10e6
    friction_angle: float = 30.0
    heterogeneity: float = 0.25
    strength_scaling_exponent: float = 0.25
    strength_scaling_reference_area: float = 1e-4
    toughness: float | None = None
    wall_criterion: Literal["critical_distance", "cluster"] = "critical_distance"
    fracture_friction_angle: float = 0.0
    crack_plane: str = "stress"
    closure_law: str = "smooth"
    joint_normal_stiffness: float | None = None
    joint_max_closure: float | None = None
    joint_reference_stress: float | None = None
    sealed_aperture: float | None = None
    dilation_angle: float | None = None
    seed: int | None = None

    def __post_init__(self) -> None:
        _validate(self, self.section)
        need = {"smooth": (), "barton_bandis": ("joint_normal_stiffness", "joint_max_closure"),
                "exponential": ("joint_reference_stress", "joint_max_closure")}[self.closure_law]
        for name in ("joint_normal_stiffness", "joint_max_closure", "joint_reference_stress",
                     "sealed_aperture"):
            given = getattr(self, name) is not None
            if name in need and not given:
                raise InputError(f"closure_law = {self.closure_law!r} needs rock.{name}",
                                 key=f"rock.{name}", expected=_spec(self.section, name)
                                 .range_text())
            if given and name not in need and (name != "sealed_aperture"
                                               or self.closure_law == "smooth"):
                raise InputError(f"rock.{name} is not used by closure_law = "
                                 f"{self.closure_law!r}", key=f"rock.{name}",
                                 expected="no value, or a closure_law that uses it")
        if self.toughness is not None and self.strength_scaling_exponent != 0.25:
            raise InputError("a toughness needs the LEFM exponent 0.25",
                             key="rock.strength_scaling_exponent", expected="0.25")
        if self.toughness is not None and self.tensile_strength == 0.0:
            raise InputError("a toughness needs a positive tensile strength",
                             key="rock.tensile_strength", expected="> 0 with rock.toughness")


@dataclass(frozen=True, kw_only=True)
class Stresses:
    """``[stresses]``: far-field stresses and pore pressure (Pa; azimuth in degrees)."""

    section: ClassVar[str] = "stresses"
    sigma_H: float = 35e6
    sigma_h: float = 30e6
    sigma_H_azimuth: float = 0.0
    pore_pressure: float = 20e6

    def __post_init__(self) -> None:
        _validate(self, self.section)
        if self.sigma_H < self.sigma_h:
            raise InputError(f"value {self.sigma_H!r} is below sigma_h", key="stresses.sigma_H",
                             expected=f"a number in [{self.sigma_h:g}, 5e+08] Pa (>= sigma_h)")
        if self.pore_pressure >= self.sigma_h:
            raise InputError(f"value {self.pore_pressure!r} is not below sigma_h",
                             key="stresses.pore_pressure",
                             expected=f"a number in [0, {self.sigma_h:g}) Pa (< sigma_h)")


@dataclass(frozen=True, kw_only=True)
class Fluid:
    """``[fluid]``: the well fluid (also the pore fluid)."""

    section: ClassVar[str] = "fluid"
    density: float = 1200.0
    compressibility: float = WATER_COMPRESSIBILITY
    viscosity: float = 0.01

    def __post_init__(self) -> None:
        _validate(self, self.section)


@dataclass(frozen=True, kw_only=True)
class CompletionOptions:
    """``[completion]``: the well above the open hole (the thesis's 2000 m well by default).

    :meth:`completion` builds the :class:`xlotkit.sim.well.Completion` (open-hole radius
    from ``[geometry]``, compressibility from ``[fluid]``).
    """

    section: ClassVar[str] = "completion"
    depth: float = 2000.0
    tvd: float | None = None
    casing_id: float = 12.715 * INCH
    casing_od: float | None = None
    pipe_od: float = 5.0 * INCH
    pipe_id: float = 4.276 * INCH
    open_hole_length: float = 10.0
    expansion: bool = False
    steel_modulus: float = 200e9
    steel_poisson: float = 0.3
    roughness: float = 4.6e-5
    well_compliance: float | None = None
    initial_pressure: float | None = None

    def __post_init__(self) -> None:
        _validate(self, self.section)
        self.completion(Geometry(), Fluid())    # cross-checks (pipe in casing, ...)

    _RENAME: ClassVar[dict[str, str]] = {"length_md": "depth", "depth_tvd": "tvd"}

    def completion(self, geometry: Geometry, fluid: Fluid) -> Completion:
        """The :class:`~xlotkit.sim.well.Completion` this section describes."""
        try:
            return Completion(
                casing_id=self.casing_id, casing_od=self.casing_od, pipe_od=self.pipe_od,
                pipe_id=self.pipe_id, length_md=self.depth, depth_tvd=self.tvd,
                open_hole_length=self.open_hole_length,
                open_hole_radius=geometry.hole_radius, compressibility=fluid.compressibility,
                expansion=self.expansion, steel_modulus=self.steel_modulus,
                steel_poisson=self.steel_poisson, roughness=self.roughness)
        except InputError as exc:
            k = (exc.key or "").removeprefix("completion.")
            key = {"open_hole_radius": "geometry.hole_radius",
                   "compressibility": "fluid.compressibility"}.get(
                k, "completion." + self._RENAME.get(k, k))
            raise InputError(exc.message, key=key, expected=exc.expected) from None


@dataclass(frozen=True, kw_only=True)
class Numerics:
    """``[numerics]``: time stepping, Newton and checkpoints."""

    section: ClassVar[str] = "numerics"
    dt_min: float = 1e-6
    dt_max: float = 1.0
    n1: int = 2
    n2: int = 10
    max_newton: int = 50
    checkpoint_steps: int = 1000
    checkpoint_seconds: float = 10.0
    max_phase_duration: float = 6 * 3600.0
    dp_max: float = 0.2e6

    def __post_init__(self) -> None:
        _validate(self, self.section)
        if self.dt_min > self.dt_max:
            raise InputError(f"value {self.dt_min!r} is above dt_max", key="numerics.dt_min",
                             expected=f"a number in (0, {self.dt_max:g}] s (<= dt_max)")
        if self.n1 > self.n2:
            raise InputError(f"value {self.n1!r} is above n2", key="numerics.n1",
                             expected=f"an integer in [0, {self.n2}] (<= n2)")


@dataclass(frozen=True)
class Interface:
    """A plane of weakness (``[[effects.interface]]``): a segment in the 2D section.

    Attributes
    ----------
    start, end : tuple of float
        End points [m] (hole centre at the origin).
    friction_angle : float
        Friction angle of the plane [deg], in [0, 89].
    """

    start: tuple[float, float]
    end: tuple[float, float]
    friction_angle: float = 30.0

    def __post_init__(self) -> None:
        for name in ("start", "end"):
            v = getattr(self, name)
            try:
                pt = tuple(float(x) for x in v)
            except (TypeError, ValueError):
                pt = ()
            if len(pt) != 2 or not all(map(math.isfinite, pt)):
                raise InputError(f"value {v!r} is not a point", key=f"interface.{name}",
                                 expected="[x, y] in m")
            object.__setattr__(self, name, pt)
        if self.start == self.end:
            raise InputError("start and end coincide", key="interface.end",
                             expected="a segment of positive length")
        if not (0.0 <= float(self.friction_angle) <= 89.0):
            raise InputError(f"value {self.friction_angle!r} is out of range",
                             key="interface.friction_angle", expected="a number in [0, 89] deg")


@dataclass(frozen=True, kw_only=True)
class Effects:
    """``[effects]``: the physics the scene asks for (the engine assembles only these)."""

    section: ClassVar[str] = "effects"
    well_storage: bool = True
    pipe_friction: bool = False
    poroelastic: bool = False
    heterogeneity: bool = False
    strength_scaling: bool = False
    shear_dilation: bool = False
    fracture_plane: bool = False
    interface: tuple[Interface, ...] = ()

    def __post_init__(self) -> None:
        _validate(self, self.section)
        object.__setattr__(self, "interface", tuple(self.interface))
        for i, p in enumerate(self.interface):
            if not isinstance(p, Interface):
                raise InputError(f"not an Interface: {p!r}", key=f"effects.interface[{i}]",
                                 expected="a table with start, end, friction_angle")


@dataclass(frozen=True, kw_only=True)
class OutputOptions:
    """``[output]``: synthetic log sampling, gauge noise and field snapshots."""

    section: ClassVar[str] = "output"
    log_interval: float = 1.0
    noise: float = 0.0
    resolution: float = 0.0
    seed: int | None = None
    snapshot_interval: float | None = None
    start_time: datetime | None = None
    gauge: Literal["bottomhole", "surface"] = "bottomhole"

    def __post_init__(self) -> None:
        _validate(self, self.section)


@dataclass(frozen=True, kw_only=True)
class LumpedOptions:
    """``[lumped]``: parameters only the lumped model uses."""

    section: ClassVar[str] = "lumped"
    fracture_geometry: Literal["penny", "kgd"] = "penny"
    toughness: float = 2e6
    initial_flaw: float | None = None
    reopening: Literal["wellbore", "sigma_h"] = "wellbore"
    nwb_coefficient: float = NWB_DEFAULT
    leakoff_coefficient: float | None = None
    wall_leak_index: float | None = None

    def __post_init__(self) -> None:
        _validate(self, self.section)


@dataclass(frozen=True, kw_only=True)
class WellCouplingOptions:
    """``[well_coupling]``: tolerances, gains and damping of the partitioned couplings
    (``coupling = "wfd" | "wfc" | "wfdmod"``; :class:`xlotkit.sim.scene.
    CouplingOptions`, docs/well-coupling.md). Ignored by ``monolithic``."""

    section: ClassVar[str] = "well_coupling"
    tolerance: float = _WC.wfd_tolerance
    rate_tolerance: float = _WC.wfd_rate_tolerance
    max_iterations: int = _WC.wfd_max_iterations
    calibration: float = _WC.wfd_calibration
    wfc_gain: float = _WC.wfc_gain
    wfc_damping: float = _WC.wfc_damping
    wfdmod_gain: float = _WC.wfdmod_gain
    wfdmod_damping: float = _WC.wfdmod_damping

    def __post_init__(self) -> None:
        _validate(self, self.section)

    def options(self) -> CouplingOptions:
        """The :class:`CouplingOptions` of this section."""
        return CouplingOptions(
            wfd_tolerance=self.tolerance, wfd_rate_tolerance=self.rate_tolerance,
            wfd_max_iterations=self.max_iterations, wfd_calibration=self.calibration,
            wfc_gain=self.wfc_gain, wfc_damping=self.wfc_damping,
            wfdmod_gain=self.wfdmod_gain, wfdmod_damping=self.wfdmod_damping)


_SECTION_TYPES: dict[str, type] = {
    "geometry": Geometry, "mesh": MeshOptions, "rock": Rock, "stresses": Stresses,
    "fluid": Fluid, "completion": CompletionOptions, "numerics": Numerics,
    "effects": Effects, "output": OutputOptions, "lumped": LumpedOptions,
    "well_coupling": WellCouplingOptions,
}


