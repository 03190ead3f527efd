"""Typed, validated configuration of the MDEM mechanics.

Sign convention of the public API: **stresses and pressures are positive in compression**
(as in rock mechanics and the thesis). Inside the solver the usual continuum convention
(tension positive) is used; the conversion happens only where results are returned.

All values are SI: Pa, m, radians unless a field name says ``_deg``.
Every impossible value raises :class:`xlotkit.errors.InputError` naming the key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from xlotkit.errors import InputError

__all__ = [
    "BoundaryConditions",
    "CrackPlanes",
    "InSituStress",
    "InterfacePlane",
    "RockProperties",
    "SolverOptions",
    "StrengthScaling",
]


def _num(obj: object, name: str, prefix: str) -> float:
    v = getattr(obj, name)
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise InputError(f"must be a number, got {v!r}", key=f"{prefix}.{name}") from None
    if not math.isfinite(v):
        raise InputError(f"must be finite, got {v!r}", key=f"{prefix}.{name}")
    object.__setattr__(obj, name, v)
    return v


def _range(obj: object, name: str, prefix: str, lo: float | None, hi: float | None,
           lo_open: bool = False, hi_open: bool = False) -> None:
    v = _num(obj, name, prefix)
    bad = ((lo is not None and (v < lo or (lo_open and v == lo)))
           or (hi is not None and (v > hi or (hi_open and v == hi))))
    if bad:
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        exp = f"{lb}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{rb}"
        raise InputError(f"value {v!r} out of range", key=f"{prefix}.{name}", expected=exp)


@dataclass(frozen=True)
class StrengthScaling:
    """Triangle-size scaling of cluster strengths.

    ``T_i = T * (reference_area / A_i) ** exponent`` and the same factor on the cohesion.
    The default exponent 1/4 follows from fracture-energy (LEFM) consistency: a cluster of
    size ``l ~ sqrt(A)`` that fails in tension at stress ``T`` releases elastic energy
    ``~ T^2 l^2 / E'`` per unit thickness and creates ``~ l`` of crack, so a mesh-independent
    fracture energy ``G_c ~ T^2 l / E'`` requires ``T ~ l^(-1/2) ~ A^(-1/4)``
    (see docs/mechanics.md).

    Parameters
    ----------
    enabled : bool
        Switch; when False the factor is 1 everywhere.
    reference_area : float
        Area [m^2] of a cluster whose strength is the nominal ``T`` (a material length
        squared, e.g. ``(K_IC / T)^2``-sized; see docs).
    exponent : float
        Power ``m`` of the area ratio, in [0, 1].
    mode : {"crack_tip", "all"}
        Where the factor applies. ``"crack_tip"`` (default): only to intact clusters that
        touch (share a node with) a failed cluster, i.e. clusters at a crack tip, where the
        singular field gives failure a length scale; intact clusters in a smooth field
        keep the nominal strength, because initiation at a smooth wall is strength
        controlled and has no length scale. ``"all"``: every cluster (the thesis's
        approach; makes initiation mesh dependent, see docs/mechanics.md).
    toughness : float or None
        Fracture toughness ``K_IC`` [Pa m^0.5] to give the crack-tip clusters instead of a
        reference area. If set, the reference area is derived from it and the rock's
        tensile strength, ``A_ref = (K_IC / (c T))^4`` with the measured tip factor ``c``
        of :data:`xlotkit.sim.mechanics.failure.TIP_TOUGHNESS_FACTOR`, and
        ``reference_area`` is ignored; needs ``exponent = 1/4`` (the only exponent for
        which the tip criterion is a toughness) and ``T > 0``. See
        :func:`xlotkit.sim.mechanics.failure.crack_tip_toughness` for the validity range.
    wall : {"critical_distance", "cluster"}
        Tensile initiation at the hole wall when the crack tips have a toughness (mode
        ``"crack_tip"``, exponent 1/4). ``"critical_distance"`` (default): the point method
        with the material length ``L = (K_IC / T)^2 / pi`` of that same toughness, the
        effective stress recovered at ``L/2`` from the wall
        (:mod:`xlotkit.sim.mechanics.wall`), so initiation and propagation share one
        length and initiation does not depend on the wall clusters' size. ``"cluster"``:
        the cluster-average stress of the wall clusters (the former criterion; its
        initiation pressure falls as the wall is refined). Without a toughness the
        wall keeps the cluster average whatever this says.
    """

    enabled: bool = False
    reference_area: float = 1e-4
    exponent: float = 0.25
    mode: Literal["crack_tip", "all"] = "crack_tip"
    toughness: float | None = None
    wall: Literal["critical_distance", "cluster"] = "critical_distance"

    def __post_init__(self) -> None:
        _range(self, "reference_area", "strength_scaling", 0.0, None, lo_open=True)
        _range(self, "exponent", "strength_scaling", 0.0, 1.0)
        if self.toughness is not None:
            _range(self, "toughness", "strength_scaling", 0.0, None, lo_open=True)
            if self.exponent != 0.25:
                raise InputError("a toughness needs the LEFM exponent 1/4",
                                 key="strength_scaling.exponent", expected="0.25")
        if self.mode not in ("crack_tip", "all"):
            raise InputError(f"unknown scaling mode {self.mode!r}", key="strength_scaling.mode",
                             expected="'crack_tip' or 'all'")
        if self.wall not in ("critical_distance", "cluster"):
            raise InputError(f"unknown wall criterion {self.wall!r}",
                             key="strength_scaling.wall",
                             expected="'critical_distance' or 'cluster'")


@dataclass(frozen=True)
class RockProperties:
    """Elastic and strength properties of the rock (uniform, before heterogeneity).

    Parameters
    ----------
    young : float
        Young's modulus E [Pa], > 0.
    poisson : float
        Poisson's ratio nu, in [0, 0.5).
    biot : float
        Biot coefficient alpha in [0, 1] for the deformation of intact rock
        (``sigma' = sigma - alpha p I``); 0: the intact skeleton is decoupled from its
        pore fluid (the pore pressure neither loads it nor is changed by its strain).
        Failure criteria and failed clusters use the Terzaghi effective stress (coefficient 1), as in the Hubbert-Willis criterion.
    tensile_strength : float
        T [Pa], >= 0.
    cohesion : float
        Mohr-Coulomb cohesion S0 [Pa], >= 0.
    friction_angle_deg : float
        Internal friction angle phi [deg], in [0, 89]; also the friction of failed contacts.
    shear_stiffness_ratio : float
        ``k_s / k_n`` of failed-cluster contacts, > 0.
    heterogeneity : float
        Half-width of the uniform strength perturbation (0.25 = +-25 %), in [0, 1).
    seed : int
        Seed of the heterogeneity draw.
    scaling : StrengthScaling
        Triangle-size strength scaling.
    """

    young: float = 10e9
    poisson: float = 0.25
    biot: float = 1.0
    tensile_strength: float = 5e6
    cohesion: float = 10e6
    friction_angle_deg: float = 30.0
    shear_stiffness_ratio: float = 0.5
    heterogeneity: float = 0.0
    seed: int = 0
    scaling: StrengthScaling = field(default_factory=StrengthScaling)

    def __post_init__(self) -> None:
        p = "rock"
        _range(self, "young", p, 0.0, None, lo_open=True)
        _range(self, "poisson", p, 0.0, 0.5, hi_open=True)
        _range(self, "biot", p, 0.0, 1.0)
        _range(self, "tensile_strength", p, 0.0, None)
        _range(self, "cohesion", p, 0.0, None)
        _range(self, "friction_angle_deg", p, 0.0, 89.0)
        _range(self, "shear_stiffness_ratio", p, 0.0, None, lo_open=True)
        _range(self, "heterogeneity", p, 0.0, 1.0, hi_open=True)
        if not isinstance(self.seed, int):
            raise InputError(f"must be an integer, got {self.seed!r}", key="rock.seed")
        if not isinstance(self.scaling, StrengthScaling):
            raise InputError("must be a StrengthScaling", key="rock.scaling")
        if self.scaling.toughness is not None and self.tensile_strength == 0.0:
            # A_ref = (K_IC / (c T))^4 has no finite value for T = 0
            raise InputError("a toughness needs a positive tensile strength",
                             key="rock.tensile_strength", expected="> 0")

    @property
    def friction_angle(self) -> float:
        """Friction angle [rad]."""
        return math.radians(self.friction_angle_deg)


@dataclass(frozen=True)
class InSituStress:
    """Far-field total stresses and initial pressures (compression positive) [Pa].

    Parameters
    ----------
    sigma_x, sigma_y, sigma_xy : float
        Far-field total stress components (compression positive).
    pore_pressure : float
        Initial pore pressure p0 [Pa], >= 0.
    wall_pressure : float, optional
        Borehole pressure of the initial state [Pa] (mud weight before the test);
        default ``pore_pressure``.
    """

    sigma_x: float = 35e6
    sigma_y: float = 30e6
    sigma_xy: float = 0.0
    pore_pressure: float = 20e6
    wall_pressure: float | None = None

    def __post_init__(self) -> None:
        p = "stress"
        for k in ("sigma_x", "sigma_y", "sigma_xy"):
            _num(self, k, p)
        _range(self, "pore_pressure", p, 0.0, None)
        if self.wall_pressure is None:
            object.__setattr__(self, "wall_pressure", self.pore_pressure)
        _range(self, "wall_pressure", p, 0.0, None)


@dataclass(frozen=True)
class BoundaryConditions:
    """Outer boundary conditions.

    Parameters
    ----------
    kind : {"rollers", "tractions"}
        ``rollers``: ``u_x = 0`` on the left side, ``u_y = 0`` on the bottom side, far-field
        tractions on the others (needs ``sigma_xy = 0``). ``tractions``: far-field tractions
        on every outer edge, rigid-body motion removed by pinning three displacement
        components (their reactions are zero to round-off because the far field is in
        equilibrium).
    """

    kind: Literal["rollers", "tractions"] = "rollers"

    def __post_init__(self) -> None:
        if self.kind not in ("rollers", "tractions"):
            raise InputError(f"unknown boundary kind {self.kind!r}", key="boundary.kind",
                             expected="'rollers' or 'tractions'")


@dataclass(frozen=True)
class InterfacePlane:
    """A pre-defined plane of weakness (fault, natural fracture) as a segment.

    Clusters cut by the segment are in the *interface* state: their contacts crossing the
    plane measure normal/shear relative displacement with respect to the plane's normal
    (smooth-joint model); they carry no tension and slip by Coulomb friction.

    Parameters
    ----------
    start, end : tuple of float
        End points of the segment [m].
    friction_angle_deg : float
        Friction angle of the plane [deg], in [0, 89].
    """

    start: tuple[float, float]
    end: tuple[float, float]
    friction_angle_deg: float = 30.0

    def __post_init__(self) -> None:
        try:
            s = tuple(float(v) for v in self.start)
            e = tuple(float(v) for v in self.end)
        except (TypeError, ValueError):
            raise InputError("start/end must be pairs of numbers", key="interface") from None
        if len(s) != 2 or len(e) != 2 or not all(map(math.isfinite, s + e)):
            raise InputError("start/end must be finite (x, y) pairs", key="interface")
        if s == e:
            raise InputError("start and end coincide", key="interface.end")
        object.__setattr__(self, "start", s)
        object.__setattr__(self, "end", e)
        _range(self, "friction_angle_deg", "interface", 0.0, 89.0)


@dataclass(frozen=True)
class FracturePlane:
    """Clusters that, once failed, open and close as a smooth joint along a direction.

    Meant for the generator's fracture band (triangles with marker ``marker``, along the
    expected fracture, sigma_H): the clusters keep the rock's strength while intact; when
    one fails, its contacts that cross the line through its centroid along ``azimuth``
    measure opening and sliding with respect to that line (smooth-joint model, as an
    :class:`InterfacePlane`), and all three of its contacts slide with
    ``friction_angle_deg``.

    Why: a crack through a strip of failed triangles whose contacts follow the triangle
    edges opens through oblique contacts that also slide; with Coulomb friction the slip
    accumulated while the crack opens locks it open when the pressure falls, so the crack
    closes only gradually, well below the stress normal to it (measured, docs/coupling.md
    "A crack that closes at the minimum stress"). A mode-I crack along the plane opens
    normal to it and, frictionless, closes reversibly at the normal stress.

    Parameters
    ----------
    azimuth : float
        Direction of the plane [rad], counter-clockwise from +x.
    friction_angle_deg : float
        Friction angle of the failed clusters' contacts [deg], in [0, 89].
    marker : int
        Triangle marker of the clusters (the generator marks its fracture band 1).
    """

    azimuth: float
    friction_angle_deg: float = 0.0
    marker: int = 1

    def __post_init__(self) -> None:
        if not math.isfinite(float(self.azimuth)):
            raise InputError("must be finite", key="fracture_plane.azimuth")
        _range(self, "friction_angle_deg", "fracture_plane", 0.0, 89.0)


@dataclass(frozen=True)
class CrackPlanes:
    """Every cluster that fails carries its own crack plane (the free path).

    When a cluster fails, its crack plane is set from its stress at that moment
    (:mod:`xlotkit.sim.mechanics.planes`: normal to ``sigma'_min`` in tension, the
    Mohr-Coulomb plane in shear) and kept; its contacts that cross the plane (through the
    centroid) measure opening and sliding against the plane's normal (smooth joint, as
    :class:`FracturePlane` does along a preset direction), and all three contacts slide
    with ``friction_angle_deg`` (a tensile crack) or the rock's friction angle (a cluster
    failed in shear, on its Mohr-Coulomb plane). Clusters of a :class:`FracturePlane` band and of
    :class:`InterfacePlane` segments keep their own planes.

    Without it (the former free path) a failed cluster's contacts keep the triangle's
    sub-edge directions and the rock's friction angle: a crack then opens through oblique
    contacts that also slide, and friction locks it open as the pressure falls
    (docs/coupling.md, "A crack that closes at the minimum stress").

    Parameters
    ----------
    friction_angle_deg : float
        Friction angle of the faces of tensile cracks [deg], in [0, 89].
    """

    friction_angle_deg: float = 0.0

    def __post_init__(self) -> None:
        _range(self, "friction_angle_deg", "crack_planes", 0.0, 89.0)


@dataclass(frozen=True)
class SolverOptions:
    """Numerical options of the quasi-static solve.

    Parameters
    ----------
    max_newton : int
        Cap on active-set (semi-smooth Newton) iterations per equilibrium solve.
    rtol : float
        Residual tolerance relative to the load scale.
    max_failure_rounds : int
        Cap on failure/re-equilibrate rounds within one step.
    max_new_failures : int or None
        Clusters allowed to fail per round (the most overstressed first); None = all.
    """

    max_newton: int = 200
    rtol: float = 1e-9
    max_failure_rounds: int = 500
    max_new_failures: int | None = None

    def __post_init__(self) -> None:
        if int(self.max_newton) < 1:
            raise InputError("must be >= 1", key="solver.max_newton")
        _range(self, "rtol", "solver", 0.0, 1.0, lo_open=True)
        if int(self.max_failure_rounds) < 1:
            raise InputError("must be >= 1", key="solver.max_failure_rounds")
        if self.max_new_failures is not None and int(self.max_new_failures) < 1:
            raise InputError("must be >= 1 or None", key="solver.max_new_failures")
