"""The lumped model's configuration: :class:`LumpedScene` and its own file layout.

The lumped model (:mod:`xlotkit.sim.lumped`) runs a :class:`LumpedScene`: the validated,
flat configuration of one lumped simulation (SI, gauge pressures), which
:meth:`xlotkit.sim.scene.Scene.to_lumped` builds from a scene. The older lumped file layout
(sections ``[stress]``, ``[rock]``, ``[fracture]``, ``[well]``, ``[fluid]``, ``[schedule]``,
``[output]``) is read by :func:`load_lumped_scene` / :meth:`LumpedScene.from_dict`;
:func:`standard_lumped_scene` is the textbook two-cycle XLOT.
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any, Literal

import numpy as np

from xlotkit import formulas
from xlotkit.checks import check_range as _check
from xlotkit.errors import InputError
from xlotkit.sim.scene.quantities import convert as _convert
from xlotkit.sim.schedule import Flowback, Pump, Schedule, ShutIn
from xlotkit.sim.well import Column, Completion, hydrostatic_bottomhole, well_compliance

__all__ = ["NWB_DEFAULT", "LumpedScene", "load_lumped_scene", "lumped_scene_from_dict",
           "standard_lumped_scene"]

Geometry = Literal["kgd", "penny"]
Reopening = Literal["wellbore", "sigma_h"]

#: Default near-wellbore entry-loss coefficient [Pa/(m^3/s)^2]: 3 bar at 500 l/min.
NWB_DEFAULT = 3e5 / (0.5 / 60.0) ** 2


@dataclass(frozen=True, kw_only=True)
class LumpedScene:
    """Validated configuration of a lumped XLOT simulation (SI, gauge pressures).

    Attributes
    ----------
    schedule : Schedule
        The test program.
    sigma_h, sigma_H : float
        Minimum and maximum horizontal total stress [Pa] (``sigma_H >= sigma_h``).
    pore_pressure : float
        Formation pore pressure p0 [Pa].
    tensile_strength : float
        T0 [Pa], spent at breakdown.
    youngs_modulus, poisson_ratio : float
        E [Pa], nu [-].
    toughness : float
        K_Ic [Pa m^0.5] (a field-scale, apparent value).
    geometry : {"kgd", "penny"}
        Fracture geometry.
    fracture_height : float
        KGD height h [m] (ignored for penny).
    initial_flaw : float
        Flaw size that starts the fracture at breakdown [m] (default: the hole radius).
    reopening : {"wellbore", "sigma_h"}
        Where a closed fracture reopens: ``"wellbore"`` (default) at
        ``max(sigma_h, 3 sigma_h - sigma_H - p0)`` (thesis Eq. C.13; the mouth is sealed by
        the wall's hoop stress until then), ``"sigma_h"`` as soon as the well pressure
        exceeds ``sigma_h`` again.
    nwb_coefficient : float
        Near-wellbore (tortuosity) entry loss ``k_nwb`` [Pa/(m^3/s)^2]: the well pressure
        exceeds the fracture pressure by ``k_nwb Q_f^2`` while the fracture takes fluid at
        ``Q_f``. Default 4.32e9 (3 bar at 500 l/min); 0 switches it off.
    leakoff_coefficient : float
        Carter C_L [m s^-0.5].
    wall_leak_index : float
        J [m^3/(s Pa)] of the open-hole wall (see :func:`wall_leak_index`).
    completion : Completion or None
        Well geometry; gives the well compliance and the fluid column. The thesis's
        2000 m well when neither ``completion`` nor ``well_compliance`` is given.
    well_compliance : float or None
        C_w [m^3/Pa], overrides the completion's.
    fluid_compressibility : float or None
        c_f [1/Pa]; None takes the completion's (water, 1/2.34 GPa by default). Must agree
        with the completion's when both are given.
    density : float
        Fluid density at surface [kg/m^3].
    viscosity : float
        Fluid viscosity [Pa s] (pipe friction).
    tvd : float or None
        TVD of the open hole [m]; None takes the completion's.
    pipe_friction : bool
        Charge pipe friction between surface and bottom hole.
    initial_pressure : float or None
        Bottom-hole pressure at t = 0 [Pa]; None: static column with 0 at surface.
    dt : float
        Output sample interval [s].
    noise : float
        Standard deviation of Gaussian gauge noise [Pa] on the pressure series.
    resolution : float
        Gauge resolution [Pa]; readings are rounded to it (0: none).
    seed : int
        Seed of the noise generator.
    start_time : datetime or None
        Clock time of t = 0 in the record.
    max_phase_duration : float
        Safety limit for a phase whose end condition is never met [s].
    dp_max : float
        Largest pressure change per internal step [Pa] (accuracy control).
    """

    schedule: Schedule
    sigma_h: float = 30e6
    sigma_H: float = 35e6
    pore_pressure: float = 20e6
    tensile_strength: float = 3e6
    youngs_modulus: float = 10e9
    poisson_ratio: float = 0.25
    toughness: float = 2e6
    geometry: Geometry = "penny"
    fracture_height: float = 10.0
    initial_flaw: float = 0.15
    reopening: Reopening = "wellbore"
    nwb_coefficient: float = NWB_DEFAULT
    leakoff_coefficient: float = 0.0
    wall_leak_index: float = 0.0
    completion: Completion | None = None
    well_compliance: float | None = None
    fluid_compressibility: float | None = None
    density: float = 1200.0
    viscosity: float = 0.01
    tvd: float | None = None
    pipe_friction: bool = False
    initial_pressure: float | None = None
    dt: float = 1.0
    noise: float = 0.0
    resolution: float = 0.0
    seed: int = 0
    start_time: datetime | None = None
    max_phase_duration: float = 6 * 3600.0
    dp_max: float = 0.2e6

    def __post_init__(self) -> None:
        if not isinstance(self.schedule, Schedule):
            raise InputError(f"not a Schedule: {self.schedule!r}", key="schedule",
                             expected="a xlotkit.sim.schedule.Schedule")
        _check("sigma_h", self.sigma_h, lo=0.0, hi=500e6, lo_open=True)
        _check("sigma_H", self.sigma_H, lo=self.sigma_h, hi=500e6)
        _check("pore_pressure", self.pore_pressure, lo=0.0, hi=self.sigma_h, hi_open=True)
        _check("tensile_strength", self.tensile_strength, lo=0.0, hi=100e6)
        _check("youngs_modulus", self.youngs_modulus, lo=1e8, hi=500e9)
        _check("poisson_ratio", self.poisson_ratio, lo=0.0, hi=0.5, hi_open=True)
        _check("toughness", self.toughness, lo=0.0, hi=100e6, lo_open=True)
        if self.geometry not in ("kgd", "penny"):
            raise InputError(f"unknown geometry {self.geometry!r}", key="geometry",
                             expected="'kgd' or 'penny'")
        _check("fracture_height", self.fracture_height, lo=0.0, hi=1000.0, lo_open=True)
        _check("initial_flaw", self.initial_flaw, lo=0.0, hi=10.0, lo_open=True)
        if self.reopening not in ("wellbore", "sigma_h"):
            raise InputError(f"unknown reopening model {self.reopening!r}", key="reopening",
                             expected="'wellbore' or 'sigma_h'")
        # 1e13 Pa/(m^3/s)^2 is ~700 bar at 500 l/min: beyond any plausible entry loss.
        _check("nwb_coefficient", self.nwb_coefficient, lo=0.0, hi=1e13)
        _check("leakoff_coefficient", self.leakoff_coefficient, lo=0.0, hi=1e-2)
        _check("wall_leak_index", self.wall_leak_index, lo=0.0, hi=1e-6)
        if self.completion is not None and not isinstance(self.completion, Completion):
            raise InputError(f"not a Completion: {self.completion!r}", key="completion",
                             expected="a xlotkit.sim.well.Completion")
        _check("well_compliance", self.well_compliance, lo=0.0, hi=1e-3, lo_open=True,
               allow_none=True)
        _check("fluid_compressibility", self.fluid_compressibility, lo=0.0, hi=1e-6,
               allow_none=True)
        if (self.completion is not None and self.fluid_compressibility is not None
                and not math.isclose(self.fluid_compressibility,
                                     self.completion.compressibility, rel_tol=1e-12)):
            raise InputError("differs from completion.compressibility",
                             key="fluid_compressibility",
                             expected=f"{self.completion.compressibility:g} 1/Pa or None")
        _check("density", self.density, lo=100.0, hi=5000.0)
        _check("viscosity", self.viscosity, lo=0.0, hi=100.0, lo_open=True)
        _check("tvd", self.tvd, lo=0.0, hi=20000.0, allow_none=True)
        if self.completion is not None and self.tvd is not None and self.tvd > (
                self.completion.length_md):
            raise InputError("deeper than completion.length_md", key="tvd",
                             expected=f"<= {self.completion.length_md:g} m")
        _check("initial_pressure", self.initial_pressure, lo=0.0, hi=500e6, allow_none=True)
        _check("dt", self.dt, lo=1e-3, hi=3600.0)
        _check("noise", self.noise, lo=0.0, hi=10e6)
        _check("resolution", self.resolution, lo=0.0, hi=10e6)
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)):
            raise InputError(f"must be an integer, got {self.seed!r}", key="seed",
                             expected="an integer")
        _check("max_phase_duration", self.max_phase_duration, lo=1.0, hi=30 * 86400.0)
        _check("dp_max", self.dp_max, lo=1e3, hi=10e6)
        p_init = self.p_initial
        if p_init >= self.breakdown_pressure:
            raise InputError(f"initial bottom-hole pressure {p_init / 1e6:.3f} MPa is at or "
                             f"above the breakdown pressure "
                             f"{self.breakdown_pressure / 1e6:.3f} MPa",
                             key="initial_pressure" if self.initial_pressure is not None
                             else "density",
                             expected="a well that starts below breakdown")

    # ------------------------------------------------------------------ derived values
    @property
    def completion_used(self) -> Completion:
        """The completion in effect (the thesis's well when none is given)."""
        if self.completion is not None:
            return self.completion
        c = Completion()
        if self.fluid_compressibility is not None:
            c = dataclasses.replace(c, compressibility=self.fluid_compressibility)
        if self.tvd is not None and self.tvd > c.length_md:
            c = dataclasses.replace(c, length_md=self.tvd)
        return c

    @property
    def compressibility(self) -> float:
        """c_f in effect [1/Pa]."""
        return self.completion_used.compressibility

    @property
    def c_well(self) -> float:
        """Well compliance C_w in effect [m^3/Pa]."""
        if self.well_compliance is not None:
            return float(self.well_compliance)
        return well_compliance(self.completion_used)

    @property
    def column(self) -> Column:
        """Fluid column between surface and the open hole."""
        comp = self.completion_used
        col = comp.column(density=self.density, viscosity=self.viscosity)
        tvd = comp.tvd if self.tvd is None else float(self.tvd)
        return dataclasses.replace(col, tvd=tvd, length_md=max(col.length_md, tvd),
                                   friction=bool(self.pipe_friction))

    @property
    def e_prime(self) -> float:
        """Plane-strain modulus E/(1 - nu^2) [Pa]."""
        return formulas.plane_strain_modulus(self.youngs_modulus, self.poisson_ratio)

    @property
    def breakdown_pressure(self) -> float:
        """Hubbert–Willis breakdown pressure P_b [Pa]."""
        return formulas.hubbert_willis(self.sigma_h, self.sigma_H, self.pore_pressure,
                                       self.tensile_strength)

    @property
    def reopening_pressure(self) -> float:
        """Reopening pressure P_r of a closed fracture [Pa] (see :func:`reopening_pressure`)."""
        if self.reopening == "sigma_h":
            return self.sigma_h
        return formulas.wellbore_reopening_pressure(self.sigma_h, self.sigma_H,
                                                    self.pore_pressure)

    @property
    def p_initial(self) -> float:
        """Bottom-hole pressure at t = 0 [Pa]."""
        if self.initial_pressure is not None:
            return float(self.initial_pressure)
        return hydrostatic_bottomhole(self.column)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, file: str | None = None) -> LumpedScene:
        """Build a scene from a mapping laid out like a TOML scene file.

        Sections and keys (numbers are SI; strings may carry units, ``"30 MPa"``,
        ``"500 l/min"``, ``"12.715 in"``, ``"1.2 sg"``, ``"10 cP"``)::

            title = "..."                      # optional, ignored
            [stress]    sigma_h, sigma_H, pore_pressure
            [rock]      tensile_strength, youngs_modulus, poisson_ratio, toughness,
                        leakoff_coefficient, wall_leak_index
            [fracture]  geometry, fracture_height, initial_flaw, reopening, nwb_coefficient
            [well]      casing_id, casing_od, pipe_od, pipe_id, length_md, depth_tvd,
                        open_hole_length, open_hole_radius, expansion, steel_modulus,
                        steel_poisson, roughness (-> a Completion; the thesis well's
                        values where absent), well_compliance, tvd, pipe_friction,
                        initial_pressure
            [fluid]     density, viscosity, compressibility
            [schedule]  see :meth:`xlotkit.sim.schedule.Schedule.from_dict`
            [output]    dt, noise, resolution, seed, start_time, max_phase_duration, dp_max

        Without a ``[well]`` table the scene has no completion (the thesis well is used).

        Raises
        ------
        InputError
            For an unknown section or key, a value of the wrong type or unit, or one out
            of range; ``key`` is the dotted path (``stress.sigma_H``) and ``expected``
            the allowed range.
        """
        return lumped_scene_from_dict(data, file=file)

    def replace(self, **changes: Any) -> LumpedScene:
        """A validated copy with some fields changed; unknown names raise InputError."""
        names = {f.name for f in dataclasses.fields(self)}
        for k in changes:
            if k not in names:
                raise InputError(f"unknown scene key {k!r}", key=k,
                                 expected=", ".join(sorted(names)))
        return dataclasses.replace(self, **changes)


# section -> scene field -> dimension (a parse_quantity kind, a pint unit giving the
# dimension, or a Python type for non-numeric values)
_SCENE_KEYS: dict[str, dict[str, Any]] = {
    "stress": {"sigma_h": "pressure", "sigma_H": "pressure", "pore_pressure": "pressure"},
    "rock": {"tensile_strength": "pressure", "youngs_modulus": "pressure",
             "poisson_ratio": "dimensionless", "toughness": "Pa*m**0.5",
             "leakoff_coefficient": "m/s**0.5", "wall_leak_index": "m**3/s/Pa"},
    "fracture": {"geometry": str, "fracture_height": "length", "initial_flaw": "length",
                 "reopening": str, "nwb_coefficient": "Pa*s**2/m**6"},
    "well": {"well_compliance": "m**3/Pa", "tvd": "length", "pipe_friction": bool,
             "initial_pressure": "pressure"},
    "fluid": {"density": "density", "viscosity": "Pa*s", "compressibility": "1/Pa"},
    "output": {"dt": "time", "noise": "pressure", "resolution": "pressure", "seed": int,
               "start_time": datetime, "max_phase_duration": "time", "dp_max": "pressure"},
}
_COMPLETION_KEYS: dict[str, Any] = {
    "casing_id": "length", "casing_od": "length", "pipe_od": "length", "pipe_id": "length",
    "length_md": "length", "depth_tvd": "length", "open_hole_length": "length",
    "open_hole_radius": "length", "expansion": bool, "steel_modulus": "pressure",
    "steel_poisson": "dimensionless", "roughness": "length"}


def lumped_scene_from_dict(data: Mapping[str, Any], *, file: str | None = None) -> LumpedScene:
    def err(exc: InputError, key: str | None = None) -> InputError:
        return InputError(exc.message, file=file, line=exc.line,
                          key=exc.key if key is None else key, expected=exc.expected)

    if not isinstance(data, Mapping):
        raise InputError("a scene must be a table", file=file, key="scene",
                         expected="a mapping of sections")
    sections = [*_SCENE_KEYS, "schedule"]
    kw: dict[str, Any] = {}
    where: dict[str, str] = {}        # scene field -> dotted key in the file
    comp_kw: dict[str, Any] = {}
    compressibility: float | None = None
    try:
        for sec, body in data.items():
            if sec == "title":
                continue
            if sec not in sections:
                raise InputError(f"unknown section {sec!r}", key=sec,
                                 expected=", ".join(sections + ["title"]))
            if sec == "schedule":
                kw["schedule"] = Schedule.from_dict(body, key="schedule")
                continue
            if not isinstance(body, Mapping):
                raise InputError("must be a table", key=sec, expected=f"a [{sec}] table")
            allowed = dict(_SCENE_KEYS[sec])
            if sec == "well":
                allowed.update(_COMPLETION_KEYS)
            for k, v in body.items():
                key = f"{sec}.{k}"
                if k not in allowed:
                    raise InputError(f"unknown key {k!r}", key=key,
                                     expected=", ".join(sorted(allowed)))
                val = _convert(v, allowed[k], key)
                if sec == "well" and k in _COMPLETION_KEYS:
                    comp_kw[k] = val
                elif sec == "fluid" and k == "compressibility":
                    compressibility = val
                else:
                    kw[k] = val
                    where[k] = key
            if sec == "well":
                kw["completion"] = None   # built below, once the fluid is known
        if "schedule" not in kw:
            raise InputError("missing [schedule]", key="schedule",
                             expected="a [schedule] table with [[schedule.phase]] entries")
        if "completion" in kw:
            if compressibility is not None:
                comp_kw["compressibility"] = compressibility
            try:
                kw["completion"] = Completion(**comp_kw)
            except InputError as exc:
                k = exc.key or ""
                if k.startswith("completion."):
                    k = "well." + k[len("completion."):]
                if k == "well.compressibility":
                    k = "fluid.compressibility"
                raise err(exc, k) from None
        elif compressibility is not None:
            kw["fluid_compressibility"] = compressibility
            where["fluid_compressibility"] = "fluid.compressibility"
        try:
            return LumpedScene(**kw)
        except InputError as exc:
            raise err(exc, where.get(exc.key or "", exc.key)) from None
    except InputError as exc:
        if exc.file is None and file is not None:
            raise err(exc) from None
        raise


def load_lumped_scene(path: str | Path) -> LumpedScene:
    """Read a lumped scene from a TOML file (layout: :meth:`LumpedScene.from_dict`).

    Raises
    ------
    InputError
        If the file cannot be read or parsed (with the line of a TOML syntax error), or
        a key is unknown or out of range.
    """
    p = Path(path)
    try:
        with p.open("rb") as fh:
            data = tomllib.load(fh)
    except OSError as exc:
        raise InputError(f"cannot read scene file: {exc.strerror}", file=str(p)) from None
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        raise InputError(f"not valid TOML: {exc}", file=str(p),
                         line=int(m.group(1)) if m else None) from None
    return lumped_scene_from_dict(data, file=str(p))


def standard_lumped_scene(**overrides: Any) -> LumpedScene:
    """A textbook two-cycle XLOT in the thesis's 2000 m well (override any field by name).

    Well: 2000 m vertical, 13-3/8" casing (ID 12.715"), 5" drill pipe (ID 4.276"), 10 m of
    open hole, water-like compressibility 1/2.34 GPa (C_w ~ 67 l/MPa), mud 1.2 sg.
    Rock: sigma_h 30 MPa, sigma_H 35 MPa, p0 20 MPa, T0 3 MPa (P_b = 38 MPa), E 6 GPa,
    nu 0.25, apparent K_Ic 3 MPa m^0.5 (so the 0.15 m flaw is unstable at P_b: FBP = P_b),
    penny fracture, Carter C_L 3e-5 m/s^0.5 and a wall leak J = 2e-11 m^3/(s Pa)
    (1.2 l/min per MPa overbalance: a gentle LOP curvature and a visible post-closure
    decline); reopening at the wall, P_r = 35 MPa (so FBP - P_r = T0), and a 3 bar entry
    loss at 500 l/min (ISIP below the last pumping pressure). The same scene as a file:
    ``examples/lumped_standard.toml``.

    Program (rates at surface):

    1. pump 500 l/min until 2.0 m^3 pumped (pressurisation, breakdown, propagation);
       shut in 3 min; flow back through a choke opened at 300 l/min until the bottom hole
       is 3 MPa below sigma_h; shut in 3 min.
    2. pump 500 l/min for 1.5 m^3 (reopening, propagation); shut in until the decline passes
       closure (bottom hole 0.3 MPa below sigma_h, at most 40 min); flow back at 300 l/min
       until the surface pressure is below 2 MPa.
    """
    sh = float(overrides.get("sigma_h", 30e6))
    sched = Schedule((
        Pump(0.5 / 60.0, volume=2.0, name="pump"),
        ShutIn(duration=180.0, name="shut-in"),
        Flowback(initial_rate=0.3 / 60.0, pressure_below=sh - 3e6, name="flowback"),
        ShutIn(duration=180.0, name="shut-in"),
        Pump(0.5 / 60.0, volume=1.5, name="pump"),
        ShutIn(pressure_below=sh - 0.3e6, duration=2400.0, name="shut-in"),
        Flowback(initial_rate=0.3 / 60.0, pressure_below=2e6, pressure_at="surface",
                 name="flowback"),
    ))
    kw: dict[str, Any] = dict(
        schedule=sched, sigma_h=sh, sigma_H=35e6, pore_pressure=20e6, tensile_strength=3e6,
        youngs_modulus=6e9, poisson_ratio=0.25, toughness=3e6, geometry="penny",
        initial_flaw=0.15, leakoff_coefficient=3e-5, wall_leak_index=2e-11,
        completion=Completion(), density=1200.0, viscosity=0.01, dt=1.0)
    names = {f.name for f in dataclasses.fields(LumpedScene)}
    for k in overrides:
        if k not in names:
            raise InputError(f"unknown scene key {k!r}", key=k,
                             expected=", ".join(sorted(names)))
    kw.update(overrides)
    return LumpedScene(**kw)
