r"""Lumped XLOT model: well storage + an LEFM fracture + Carter leak-off + a surface choke.

A quick what-if tool and the test bed for the pick algorithms: one bottom-hole pressure
``p(t)`` for the whole well (hydraulic equilibrium, thesis 4.5.1), one fracture size ``L(t)``.
SI units; all pressures are gauge.

Physics
-------
*Volume balance.* With all volumes at reference density (mass / rho0), the well stores
``C_w (p - p_init)`` and the fracture ``V_f``; fluid is pumped in (``Q_in``), returned at
surface (``Q_ret``) and leaks off (``Q_leak``)::

    C_w dp/dt + dV_f/dt = Q_in - Q_ret - Q_leak                                  (1)

*Breakdown.* No fracture until ``p`` reaches the Hubbert–Willis pressure (thesis Eq. C.11)::

    P_b = 3 sigma_h - sigma_H - p_0 + T_0                                         (2)

Then a flaw of size ``L_0`` (default: the hole radius) becomes a fracture against
``sigma_h``; the tensile strength is spent and never comes back.

*Fracture (Sneddon, LEFM).* Net pressure ``dp = max(p - sigma_h, 0)``, plane-strain modulus
``E' = E / (1 - nu^2)``:

=========  ================================  ==================================
geometry   opening volume V_f                 stress intensity K_I
=========  ================================  ==================================
``kgd``    ``2 pi h L^2 dp / E'``              ``dp sqrt(pi L)``
``penny``  ``16 R^3 dp / (3 E')``              ``(2/pi) dp sqrt(pi R)``
=========  ================================  ==================================

``L`` is the KGD half-length (height ``h``), ``R`` the penny radius. (Sneddon's plane-strain
volume for half-length ``L`` is ``2 pi h L^2 dp / E'``; the penny stiffness
``dp/dV = 3E'/(16R^3)`` is thesis Eq. C.3.) Growth is quasi-static:
``K_I <= K_Ic`` always, ``L`` grows only while ``K_I = K_Ic``, and never shrinks. On the
growth (critical) branch ``dp = dp_c(L)`` with ``dp_c = K_Ic / sqrt(pi L)`` (KGD) or
``(K_Ic/2) sqrt(pi/R)`` (penny). Below ``sigma_h`` the fracture is mechanically closed
(``V_f = 0``), so the system compliance drops from ``C_w + dV_f/dp`` to ``C_w`` exactly at
``p_f = sigma_h``; it propagates again at ``sigma_h + dp_c(L)`` once reopened.

*Reopening.* ``reopening="wellbore"`` (default): the mouth of a closed fracture lies in the
borehole wall, whose hoop stress holds it shut until the well pressure reaches (thesis
Eq. C.13, no tensile strength left)::

    P_r = max(sigma_h, 3 sigma_h - sigma_H - p_0)                                 (3)

Between closure and ``P_r`` the fracture is *sealed*: no fracture compliance, and no Carter
leak from its faces (a closed fracture holds no fluid to leak; the open-hole wall leak ``J``
goes on). At ``P_r`` it reopens at its old size under net pressure ``P_r - sigma_h``; the
well's excess fills it at constant stored volume (the breakdown jump's zero-time step: at
fixed ``L`` if ``K_I <= K_Ic``, else growing to ``W(L_j) = W``): a reopening peak, then a
drop towards propagation, and ``FBP - P_r = T_0``. ``reopening="sigma_h"``: reopens as
soon as ``p_f`` exceeds ``sigma_h`` (no peak).

*Entry loss.* A near-wellbore (tortuosity) loss between well and fracture while the
fracture takes fluid at ``Q_f`` (``nwb_coefficient`` ``k``)::

    p = p_f + k max(Q_f, 0)^2,      Q_f = dV_f/dt + Q_Carter                      (4)

``p`` (well, bottom hole) drives the well storage, the choke and the wall leak; ``p_f``
(fracture mouth) drives ``V_f``, ``K_I`` and closure. At shut-in the well drains the loss
into the fracture in about ``2 C_w k Q_f`` (a few seconds): the ISIP lies ``k Q_f^2`` below
the last pumping pressure. Returning flow (``Q_f < 0``) is taken as unrestricted, so
flowback stiffness and closure are unaffected. Instantaneous jumps (breakdown, reopening)
are taken without the loss (they are equilibrium jumps of the whole system).

*Stability and the breakdown drop.* Along the critical branch the stored volume
``W(L) = C_w (sigma_h + dp_c(L)) + V_f(dp_c(L), L)`` falls with ``L`` while
``L < L_s`` and rises beyond, with ``L_s^2 = C_w E' / (6 pi h)`` (KGD) and
``L_s^3 = 3 C_w E' / 80`` (penny). A fracture shorter than ``L_s`` that reaches ``K_Ic``
cannot be held by the well: it jumps, at constant ``W`` (no time passes), to the length
``L_j > L_s`` with ``W(L_j) = W`` before the jump. That is formation breakdown: FBP, an
instantaneous pressure drop, then stable propagation (FPP slowly falling as ``L`` grows),
all from Eq. (1)–(2).

*Leak-off.* Carter leak-off from both faces of the area opened so far (area per face
``2 L h`` KGD, ``pi R^2`` penny); an element opened at ``tau`` leaks
``C_L / sqrt(t - tau)`` per unit area. The opening time of every area increment is kept
(the area is taken to grow linearly over a step, which makes the per-step integrals exact:
``(4/3) C_L dA sqrt(dt)`` for the new area). Leak-off only acts while the fracture is
open (``p > sigma_h``); the exposure clock keeps running while it is closed. An optional
wall leak ``Q_w = J (p - p_0)`` stands for a small constant-permeability open-hole wall
(see :func:`wall_leak_index`).

*Surface.* ``p_s`` follows from ``p`` through the fluid column with ``rho(p)`` and optional
pipe friction (:mod:`xlotkit.sim.well`). Flowback through a fixed choke returns
``Q_ret = zeta sqrt(p_s)`` (thesis Eq. 4.24), with ``p_s`` solved together with the friction
of the returning flow.

Numerics
--------
Each step solves Eq. (1) in integrated form (backward for the state, trapezoidal for the
choke and wall-leak rates, exact for the pump and Carter terms)::

    C_w (p' - p) + V_f' - V_f + dt (Q_ret + Q_ret')/2 + dt (Q_w + Q_w')/2
        + dV_Carter - dV_in = 0,        p' = p_f' + k (x/dt)^2,  x = V_f' - V_f + dV_Carter

for one scalar: ``p_f'`` on the elastic branch (``L' = L``), or ``ln L'`` on the critical
branch. With the entry loss on, ``p_f'`` and ``ln L'`` are ill-conditioned over short
(event) steps, so the unknown is then ``p'`` on the elastic branch (``x`` follows from the
quadratic ``k x^2/dt^2 + x/C_f = p' - sigma_h - (V_f - dV_Carter)/C_f``) and ``x`` on the
critical branch (``L'`` from the volume by Newton). All residuals are monotone, solved with
Brent's method to round-off, so the volume balance
closes to ~1e-12 relative every step (reported in ``truth["mass_balance_error"]``). The step
is adaptive (well and fracture pressure change per step <= ``dp_max``), never longer than
the output interval, and ends exactly on every output sample. Events are located to 1e-9 s:
breakdown, closure at ``sigma_h`` (on ``p_f``), reopening (``p`` at ``P_r``, or ``p_f`` at
``sigma_h``), and phase ends on pressure or volume; phase durations and rate steps are step
boundaries.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import time as _time
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any, Literal

import numpy as np
from scipy.optimize import brentq

from xlotkit import formulas
from xlotkit.errors import InputError
from xlotkit.record import Event, PressureReference, Record
from xlotkit.checks import check_range as _check
from xlotkit.sim.schedule import (
    _NUM_UNIT,
    Flowback,
    Pump,
    Schedule,
    ShutIn,
    parse_quantity,
)
from xlotkit.sim.well import (
    Column,
    Completion,
    PhaseDrive,
    WellDrive,
    hydrostatic_bottomhole,
    phase_place,
    well_compliance,
)

__all__ = [
    "LumpedEngine",
    "LumpedResult",
    "LumpedScene",
    "breakdown_pressure",
    "critical_net_pressure",
    "fracture_compliance",
    "fracture_face_area",
    "fracture_volume",
    "load_lumped_scene",
    "reopening_pressure",
    "simulate_lumped",
    "stable_length",
    "standard_lumped_scene",
    "StepOutcome",
    "stress_intensity",
    "wall_leak_index",
]

Geometry = Literal["kgd", "penny"]
Reopening = Literal["wellbore", "sigma_h"]

#: Default near-wellbore entry-loss coefficient [Pa/(m^3/s)^2]: 3 bar at 500 l/min.
NWB_DEFAULT = 3e5 / (0.5 / 60.0) ** 2


# =========================================================================== physics
def breakdown_pressure(sigma_h: float, sigma_H: float, pore_pressure: float,
                       tensile_strength: float) -> float:
    """Hubbert–Willis breakdown pressure ``3 sigma_h - sigma_H - p0 + T0`` [Pa] (Eq. C.11;
    :func:`xlotkit.formulas.hubbert_willis`)."""
    return formulas.hubbert_willis(sigma_h, sigma_H, pore_pressure, tensile_strength)


def reopening_pressure(sigma_h: float, sigma_H: float, pore_pressure: float,
                       model: Reopening = "wellbore") -> float:
    """Well pressure that reopens a closed fracture [Pa].

    ``"wellbore"``: the fracture mouth sits in the borehole wall, whose hoop stress must be
    overcome again, now without tensile strength (thesis Eq. C.13,
    :func:`xlotkit.formulas.reopening_pressure`)::

        P_r = max(sigma_h, 3 sigma_h - sigma_H - p_0)

    (the ``max``: where the wall's hoop stress is below ``sigma_h``, i.e.
    ``sigma_H > 2 sigma_h - p_0``, the far field still holds the faces shut up to
    ``sigma_h``). ``"sigma_h"``: ``P_r = sigma_h`` (a fracture open to the well all along).
    """
    if model == "sigma_h":
        return sigma_h
    return max(sigma_h, formulas.reopening_pressure(sigma_h, sigma_H, pore_pressure))


def fracture_volume(net_pressure: float, size: float, geometry: Geometry, e_prime: float,
                    height: float = 1.0) -> float:
    """Sneddon opening volume [m^3]; 0 for a closed fracture (``net_pressure <= 0``).

    KGD: ``2 pi h L^2 dp / E'`` (``size`` = half-length L); penny: ``16 R^3 dp / (3 E')``
    (:func:`xlotkit.formulas.kgd_volume`, :func:`~xlotkit.formulas.penny_volume`).
    """
    if net_pressure <= 0.0:
        return 0.0
    if geometry == "kgd":
        return formulas.kgd_volume(net_pressure, size, height, e_prime)
    return formulas.penny_volume(net_pressure, size, e_prime)


def fracture_compliance(size: float, geometry: Geometry, e_prime: float,
                        height: float = 1.0) -> float:
    """``dV_f/dp`` of an open fracture at fixed size [m^3/Pa] (inverse of Eq. C.3 for penny)."""
    return fracture_volume(1.0, size, geometry, e_prime, height)


def stress_intensity(net_pressure: float, size: float, geometry: Geometry) -> float:
    """Mode-I stress intensity [Pa m^0.5]: ``dp sqrt(pi L)`` (KGD), ``(2/pi) dp sqrt(pi R)``."""
    if geometry == "kgd":
        return formulas.kgd_stress_intensity(net_pressure, size)
    return formulas.penny_stress_intensity(net_pressure, size)


def critical_net_pressure(size: float, geometry: Geometry, toughness: float) -> float:
    """Net pressure at which ``K_I = K_Ic`` [Pa] for a fracture of ``size`` [m]."""
    if geometry == "kgd":
        return formulas.kgd_critical_net_pressure(size, toughness)
    return formulas.penny_critical_net_pressure(size, toughness)


def fracture_face_area(size: float, geometry: Geometry, height: float = 1.0) -> float:
    """Area of one fracture face [m^2]: ``2 L h`` (KGD, both wings) or ``pi R^2``."""
    return 2.0 * size * height if geometry == "kgd" else math.pi * size * size


def stable_length(well_compliance: float, geometry: Geometry, e_prime: float,
                  height: float = 1.0) -> float:
    """Smallest fracture size [m] that can propagate stably against well storage ``C_w``.

    KGD: ``sqrt(C_w E' / (6 pi h))``; penny: ``(3 C_w E' / 80)^(1/3)`` (see module docs).
    """
    if geometry == "kgd":
        return math.sqrt(well_compliance * e_prime / (6.0 * math.pi * height))
    return (3.0 * well_compliance * e_prime / 80.0) ** (1.0 / 3.0)


#: Steady radial productivity of the open-hole wall (:func:`xlotkit.formulas.wall_leak_index`).
wall_leak_index = formulas.wall_leak_index


# =========================================================================== scene
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
        return breakdown_pressure(self.sigma_h, self.sigma_H, self.pore_pressure,
                                  self.tensile_strength)

    @property
    def reopening_pressure(self) -> float:
        """Reopening pressure P_r of a closed fracture [Pa] (see :func:`reopening_pressure`)."""
        return reopening_pressure(self.sigma_h, self.sigma_H, self.pore_pressure,
                                  self.reopening)

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
        return _scene_from_dict(data, file=file)

    def replace(self, **changes: Any) -> LumpedScene:
        """A validated copy with some fields changed; unknown names raise InputError."""
        names = {f.name for f in dataclasses.fields(self)}
        for k in changes:
            if k not in names:
                raise InputError(f"unknown scene key {k!r}", key=k,
                                 expected=", ".join(sorted(names)))
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class LumpedResult:
    """Outcome of :func:`simulate_lumped`.

    Attributes
    ----------
    status : {"ok", "stopped"}
        ``stopped`` when a phase hit ``max_phase_duration`` without meeting its end condition.
    message : str
        Human-readable summary.
    record : Record
        The synthetic log: bottom-hole gauge pressure and rates on the output grid.
    truth : dict
        What the model imposed and realised (see :func:`simulate_lumped`).
    """

    status: Literal["ok", "stopped"]
    message: str
    record: Record
    truth: dict[str, Any] = field(default_factory=dict)


# =========================================================================== solver
@dataclass
class _State:
    t: float
    p: float                  # well (bottom-hole) pressure
    L: float = 0.0            # fracture size (0 while intact)
    broken: bool = False
    pf: float = math.nan      # fracture(-mouth) pressure; = p when no fluid enters it
    sealed: bool = False      # closed, mouth held shut by the wall until p reaches P_r
    vf: float = 0.0           # fracture volume
    v_in: float = 0.0
    v_ret: float = 0.0
    v_carter: float = 0.0
    v_wall: float = 0.0
    ps: float = 0.0           # surface pressure
    q_in: float = 0.0         # pump rate in the step that ended here
    q_ret: float = 0.0        # return rate at this state
    margin: float = math.inf  # elastic-branch residual at K_I = K_Ic (< 0: must grow)


@dataclass
class _Step:
    """Result of one trial step."""

    dt: float
    p: float
    pf: float
    L: float
    vf: float
    dv_in: float
    dv_ret: float
    dv_carter: float
    dv_wall: float
    q_ret: float
    ps: float
    dA: float
    resid: float
    scale: float
    jump: bool
    margin: float


class _Sim:
    HIST_KEYS = ("t", "p", "pf", "L", "vf", "v_in", "v_ret", "v_carter", "v_wall", "ps",
                 "q_in", "q_ret")

    def __init__(self, scene: LumpedScene):
        self.sc = scene
        self.cw = scene.c_well
        self.col = scene.column
        self.geo = scene.geometry
        self.ep = scene.e_prime
        self.h = scene.fracture_height
        self.K = scene.toughness
        self.sh = scene.sigma_h
        self.pb = scene.breakdown_pressure
        self.pr = scene.reopening_pressure
        self.k_nwb = scene.nwb_coefficient
        self.J = scene.wall_leak_index
        self.p0 = scene.pore_pressure
        self.CL = scene.leakoff_coefficient
        self.L_stab = stable_length(self.cw, self.geo, self.ep, self.h)
        self.tol_p = 1e-3  # [Pa] band around sigma_h treated as "at closure"
        # Seal closed fractures only when P_r is measurably above sigma_h; otherwise the
        # wellbore model is the sigma_h model.
        self.seal = self.pr > self.sh + self.tol_p
        # Carter increments: area dA created linearly over [a, b].
        self._ca = np.zeros(64)
        self._cb = np.zeros(64)
        self._cdA = np.zeros(64)
        self._cn = 0
        self._cache: dict[tuple[float, int], float] = {}
        # History of accepted states.
        self.hist: dict[str, list[float]] = {k: [] for k in self.HIST_KEYS}
        self.mb_err: list[float] = []
        self.mb_t: list[float] = []
        self.n_steps = 0
        self.n_rejected = 0
        self.n_events = 0

    # ------------------------------------------------------------------ small physics
    def vol(self, dp: float, L: float) -> float:
        return fracture_volume(dp, L, self.geo, self.ep, self.h)

    def dpc(self, L: float) -> float:
        return critical_net_pressure(L, self.geo, self.K)

    def area(self, L: float) -> float:
        return fracture_face_area(L, self.geo, self.h) if L > 0 else 0.0

    def carter_old(self, t0: float, t1: float) -> float:
        """Leak volume over [t0, t1] from both faces of all area opened before t0."""
        n = self._cn
        if n == 0 or self.CL == 0.0:
            return 0.0
        return 2.0 * self.CL * (self._carter_sum(t1) - self._carter_sum(t0))

    def _carter_sum(self, t: float) -> float:
        """Sum over increments of dA * unit leak by time t (cached: event searches and the
        next step reuse the same times)."""
        key = (t, self._cn)
        v = self._cache.get(key)
        if v is None:
            n = self._cn
            v = float(np.dot(self._cdA[:n], _carter_unit(t, self._ca[:n], self._cb[:n])))
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = v
        return v

    def add_area(self, a: float, b: float, dA: float) -> None:
        if dA <= 0.0:
            return
        if self._cn == self._ca.size:
            for name in ("_ca", "_cb", "_cdA"):
                arr = getattr(self, name)
                setattr(self, name, np.concatenate([arr, np.zeros(arr.size)]))
        self._ca[self._cn], self._cb[self._cn], self._cdA[self._cn] = a, b, dA
        self._cn += 1

    # ------------------------------------------------------------------ one step
    def solve(self, s: _State, dt: float, drive: PhaseDrive, q_pump: float,
              force_jump: bool = False) -> _Step:
        """One trial step of ``dt`` from ``s`` under the phase in force (``drive``) with the
        pump rate ``q_pump`` of the step."""
        cw, sh, k = self.cw, self.sh, self.k_nwb
        # The fracture exchanges fluid with the well only when it exists and its mouth is
        # not sealed by the borehole wall (wellbore reopening model).
        linked = s.broken and not s.sealed
        pf0 = s.pf if linked else s.p
        is_open = linked and pf0 > sh + self.tol_p
        dv_in = q_pump * dt
        dv_c_old = self.carter_old(s.t, s.t + dt) if (is_open and dt > 0) else 0.0
        c_new = (2.0 * 4.0 / 3.0 * self.CL * math.sqrt(dt)) if is_open else 0.0
        q_ret_n = s.q_ret if dt > 0 else 0.0
        wall_n = self.J * (s.p - self.p0)
        A_n = self.area(s.L)
        half = 0.5 * dt
        # returns at a fixed rate (bleed; 0 pumping or shut in) or through the choke
        fixed_return = not drive.phase.through_choke
        # Entry loss acts on time-resolved inflow only: zero-duration steps are the
        # instantaneous equilibrium jumps (breakdown, reopening), taken without it.
        throttle = k > 0.0 and dt > 0.0 and linked

        def parts(pf: float, dp: float, L: float, p: float | None = None,
                  vf: float | None = None):
            if vf is None:
                vf = self.vol(dp, L) if linked else 0.0
            dA = self.area(L) - A_n if linked else 0.0
            dv_c = dv_c_old + c_new * dA
            x = (vf - s.vf) + dv_c            # volume that entered the fracture
            if p is None:
                # Well pressure: fracture pressure + k Q_f^2 while the fracture takes
                # fluid (backward Euler: Q_f = x / dt, the step-mean inflow).
                p = pf + k * (x / dt) ** 2 if (throttle and x > 0.0) else pf
            if fixed_return:
                q_ret = drive.phase.fixed_return_rate
                dv_ret = q_ret * dt
                ps = None
            else:
                ps, q_ret = drive.choke(p)
                dv_ret = half * (q_ret_n + q_ret)
            dv_w = half * (wall_n + self.J * (p - self.p0))
            r = cw * (p - s.p) + x + dv_ret + dv_w - dv_in
            return r, vf, dv_ret, dv_w, dv_c, q_ret, ps, dA, p

        def r_el(pf: float) -> float:
            return parts(pf, pf - sh, s.L)[0]

        def r_cr(lam: float) -> float:
            L = Ls * math.exp(lam)
            dp = self.dpc(L)
            return parts(sh + dp, dp, L)[0]

        jump = False
        margin = math.inf
        p_w: float | None = None
        vf_w: float | None = None
        if throttle:
            res = self._solve_throttled(s, dt, parts, dv_c_old, c_new, A_n, force_jump)
            if res is None:         # an unstable jump: instantaneous, taken without loss
                throttle = False
            else:
                pf, dp, L, p_w, vf_w, jump, margin = res
        if throttle:
            pass
        elif not linked:
            pf = _solve_monotone(r_el, pf0)
            L, dp = s.L, pf - sh
        else:
            p_star = sh + self.dpc(s.L)
            margin = r_el(p_star)
            if margin >= 0.0 and not force_jump:
                pf = _solve_monotone(r_el, min(pf0, p_star), hi=p_star)
                L, dp = s.L, pf - sh
            else:
                Ls = max(s.L, self.L_stab)
                jump = Ls > s.L
                if r_cr(0.0) >= 0.0:   # pathological: settles right at L_s
                    lam = 0.0
                else:
                    hi = 1.0
                    while r_cr(hi) < 0.0:
                        hi *= 2.0
                        if hi > 60.0:
                            raise RuntimeError("fracture growth did not bracket")
                    lam = brentq(r_cr, 0.0, hi, xtol=1e-15, rtol=1e-15, maxiter=200)
                L = Ls * math.exp(lam)
                dp = self.dpc(L)
                pf = sh + dp
        r, vf, dv_ret, dv_w, dv_c, q_ret, ps, dA, p = parts(pf, dp, L, p_w, vf_w)
        if ps is None:
            ps = drive.surface(p, q_pump)[0]
        # Relative to the step's volume turnover; for sub-millisecond (event) steps the
        # turnover is at the round-off level of the stored volume, so floor the scale at
        # 1e-6 of it (C_w p + V_f).
        scale = max(abs(dv_in) + abs(dv_ret) + abs(dv_w) + abs(dv_c) + cw * abs(p - s.p)
                    + abs(vf - s.vf), 1e-6 * (cw * abs(p) + vf), 1e-300)
        return _Step(dt, p, pf if linked else p, L, vf, dv_in, dv_ret, dv_c, dv_w, q_ret, ps,
                     dA, r, scale, jump, margin)

    def _solve_throttled(self, s: _State, dt: float, parts, dv_c_old: float, c_new: float,
                         A_n: float, force_jump: bool):
        """One step of a linked fracture with the entry loss on (``dt > 0``).

        The fracture pressure is nearly fixed over a short step while the well pressure
        moves by ``k (x/dt)^2``, so ``p_f`` (or ``ln L``) is an ill-conditioned unknown
        for sub-millisecond event steps. Instead the unknown is the well pressure ``p`` on
        the elastic branch, where the inflow follows in closed form, and the inflow
        volume ``x`` on the critical branch; both residuals are increasing.
        """
        sh, k = self.sh, self.k_nwb
        cf = fracture_compliance(s.L, self.geo, self.ep, self.h)
        base = s.vf - dv_c_old          # fracture volume left if nothing flowed in
        inv_dt2 = 1.0 / (dt * dt)

        def el(p: float) -> tuple[float, float]:
            """(p_f, V_f) at fixed L for well pressure p: the inflow x > 0 solves
            ``k x^2/dt^2 + x/C_f = p - sh - base/C_f`` (stable root form)."""
            d = p - sh - base / cf
            if d > 0.0:
                x = 2.0 * d / (1.0 / cf + math.sqrt(1.0 / cf**2 + 4.0 * k * d * inv_dt2))
                vf = max(base + x, 0.0)
                return p - k * x * x * inv_dt2, vf
            return p, cf * max(p - sh, 0.0)

        def r_el(p: float) -> float:
            pf, vf = el(p)
            return parts(pf, pf - sh, s.L, p, vf)[0]

        p_star = sh + self.dpc(s.L)
        x_star = cf * (p_star - sh) - base
        pw_star = p_star + (k * x_star * x_star * inv_dt2 if x_star > 0.0 else 0.0)
        # Over a very short step, reaching K_Ic would take an absurd well pressure; cap it
        # (far above any valid scene pressure) so the fluid column stays finite. The
        # margin keeps its sign and stays continuous in dt.
        pw_star = min(pw_star, _P_CAP)
        margin = r_el(pw_star)
        if margin < 0.0 and pw_star == _P_CAP:
            raise RuntimeError("entry loss needs a well pressure above 1 GPa")
        if margin >= 0.0 and not force_jump:
            p = _solve_monotone(r_el, min(s.p, pw_star), hi=pw_star)
            pf, vf = el(p)
            return pf, pf - sh, s.L, p, vf, False, margin
        if force_jump:
            return None
        if s.L < self.L_stab:
            # K_I > K_Ic at a size that cannot hold: the "unstable" event cuts the step
            # where the margin crosses 0 and jumps (at dt = 0). Meanwhile keep the trial
            # on the elastic branch past K_Ic, so the margin stays continuous in dt.
            p = _solve_monotone(r_el, s.p)
            pf, vf = el(p)
            return pf, pf - sh, s.L, p, vf, False, margin
        # Critical branch: the inflow x fixes L (volume + new-area leak), L fixes p_f.
        Ls = s.L
        m_v, m_a = (2.5, 2.0) if self.geo == "penny" else (1.5, 1.0)

        def size(x: float) -> float:
            target = base + x
            v1 = self.vol(self.dpc(Ls), Ls)
            a1 = self.area(Ls)
            # start right of the root (the no-leak solution); Newton on a convex
            # increasing function then converges monotonically
            lam = max(0.0, math.log(max(target, 1e-300) / v1) / m_v)
            for _ in range(60):
                ev, ea = v1 * math.exp(m_v * lam), a1 * math.exp(m_a * lam)
                g = ev + c_new * (ea - A_n) - target
                step = g / (m_v * ev + m_a * c_new * ea)
                lam_new = max(lam - step, 0.0)
                if abs(lam_new - lam) <= 1e-15 * max(1.0, lam):
                    lam = lam_new
                    break
                lam = lam_new
            return Ls * math.exp(lam)

        def r_x(x: float) -> float:
            L = size(x)
            dp = self.dpc(L)
            return parts(sh + dp, dp, L, sh + dp + k * x * x * inv_dt2)[0]

        x_lo = self.vol(self.dpc(Ls), Ls) + c_new * (self.area(Ls) - A_n) - base
        x_lo = max(x_lo, 0.0)
        if r_x(x_lo) >= 0.0:
            x = x_lo
        else:
            hi = max(2.0 * x_lo, 1e-9)
            while r_x(hi) < 0.0:
                hi *= 2.0
                if hi > 1e6:
                    raise RuntimeError("fracture growth did not bracket")
            x = brentq(r_x, x_lo, hi, xtol=1e-300, rtol=1e-15, maxiter=300)
        L = size(x)
        dp = self.dpc(L)
        return sh + dp, dp, L, sh + dp + k * x * x * inv_dt2, None, False, margin

    def accept(self, s: _State, st: _Step, q_pump: float) -> _State:
        if st.dA > 0.0:
            self.add_area(s.t, s.t + st.dt, st.dA)
        new = _State(t=s.t + st.dt, p=st.p, L=st.L, broken=s.broken, vf=st.vf, pf=st.pf,
                     sealed=s.sealed,
                     v_in=s.v_in + st.dv_in, v_ret=s.v_ret + st.dv_ret,
                     v_carter=s.v_carter + st.dv_carter, v_wall=s.v_wall + st.dv_wall,
                     ps=st.ps, q_in=q_pump, q_ret=st.q_ret)
        self.mb_err.append(abs(st.resid) / st.scale)
        self.mb_t.append(new.t)
        self.n_steps += 1
        self.push(new)
        return new

    def push(self, s: _State) -> None:
        h = self.hist
        for k in h:
            h[k].append(getattr(s, k))


_P_CAP = 1e9   # [Pa] ceiling of trial well pressures in the entry-loss solve


def _carter_unit(t: float, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Leaked volume per face and per unit C_L by time t from unit area opened linearly over
    [a, b] (or at once when b == a): ``(4/3) [(t-a)^1.5 - (t-b)^1.5] / (b-a)``."""
    ta = np.maximum(t - a, 0.0)
    tb = np.maximum(t - b, 0.0)
    w = b - a
    inst = w <= 0.0
    w = np.where(inst, 1.0, w)
    sa = np.sqrt(ta)
    lin = (4.0 / 3.0) * (ta * sa - tb * np.sqrt(tb)) / w
    return np.where(inst, 2.0 * sa, lin)


def _solve_monotone(f: Callable[[float], float], x0: float, hi: float | None = None) -> float:
    """Root of an increasing function near x0 (bracket by doubling), optional upper bound."""
    span = 1e5
    lo = x0 - span
    while f(lo) > 0.0:
        span *= 2.0
        lo = x0 - span
        if span > 1e10:
            raise RuntimeError("pressure did not bracket (below)")
    if hi is None:
        span = 1e5
        hi = x0 + span
        while f(hi) < 0.0:
            span *= 2.0
            hi = x0 + span
            if span > 1e10:
                raise RuntimeError("pressure did not bracket (above)")
    elif f(hi) <= 0.0:
        return hi
    return brentq(f, lo, hi, xtol=1e-9, rtol=1e-15, maxiter=200)


# =========================================================================== driver
def simulate_lumped(scene: LumpedScene, *,
                    progress: Callable[[float], None] | None = None) -> LumpedResult:
    """Run the lumped XLOT model (equations in the module docstring).

    A thin wrapper around :class:`LumpedEngine`: start it, step it to the end, return its
    result. :func:`xlotkit.sim.run.simulate` drives the same engine with checkpoints and
    file output.

    Parameters
    ----------
    scene : LumpedScene
    progress : callable, optional
        Called with the fraction of the program done (0..1, non-decreasing, last call 1.0);
        nothing is printed or logged.

    Returns
    -------
    LumpedResult
        ``record``: bottom-hole gauge pressure ``pressure`` [Pa], ``rate``/``volume`` (pump),
        ``return_rate``/``return_volume``, ``density`` (surface, constant), channels
        ``surface_pressure`` [Pa], ``fracture_pressure`` [Pa] (``p_f``, Eq. 4; equal to
        ``pressure`` when no fluid enters the fracture), ``fracture_length`` [m] (KGD
        half-length or penny radius), ``fracture_volume`` [m^3], ``leakoff_volume`` [m^3]; sampled every
        ``scene.dt`` with the scene's noise and resolution on the pressures.
        ``truth``: ``sigma_h``, ``sigma_H``, ``pore_pressure``, ``tensile_strength``,
        ``breakdown_pressure_model`` (Eq. 2), ``initiation_pressure`` / ``initiation_time``
        (when P_b was reached), ``fbp`` and ``breakdown_time`` (pressure and time of the
        first unstable jump; = P_b when ``K_I(P_b, L_0) > K_Ic``),
        ``closure_times`` / ``reopening_times`` [s], ``reopening_pressures`` (well
        pressure at each reopening), ``reopening_pressure_model`` (Eq. 3) and
        ``reopening_model``, ``phases`` (cycle, kind, t_start, t_end, end reason),
        ``isip`` per cycle (fracture pressure at shut-in: the well pressure once the entry
        loss has drained), ``last_pump_pressure`` per cycle (well pressure at shut-in),
        ``nwb_coefficient``, ``well_compliance``, ``stable_length``,
        the internal history ``t``, ``pressure`` (clean), ``fracture_pressure``,
        ``surface_pressure``,
        ``fracture_length``, ``fracture_volume``, ``mass_balance_error`` (relative residual
        of Eq. 1 per step) with ``mass_balance_t``, ``mass_balance_cumulative`` (relative
        error of the total balance at the end), counters ``n_steps``, ``n_rejected``,
        ``n_events`` and ``wall_time``.
    """
    engine = LumpedEngine(scene)
    engine.start()
    last = -1.0

    def report(frac: float) -> None:
        nonlocal last
        if progress is not None:
            progress(frac)
        last = frac

    report(engine.progress())
    while not engine.is_done():
        engine.step()
        f = engine.progress()
        if f - last >= 1e-3 and f < 1.0:
            report(f)
    report(1.0)
    return engine.result()


#: The scalar fields of the solver state saved in a checkpoint.
_STATE_FIELDS = tuple(f.name for f in dataclasses.fields(_State))


@dataclass(frozen=True)
class StepOutcome:
    """What one call of an engine's ``step()`` did.

    Attributes
    ----------
    ok : bool
        True when the step advanced the simulation (an accepted step, a phase change);
        False when it was rejected and will be retried shorter (nothing advanced).
    t : float
        Simulated time after the call [s].
    reason : str
        Why the step was rejected, or what it did (``"accepted"``, ``"phase end: volume"``).
    """

    ok: bool
    t: float
    reason: str


class LumpedEngine:
    """The lumped model as a stepwise engine (the :class:`xlotkit.sim.run.Engine` protocol).

    ``start()``, then ``step()`` until ``is_done()``, then ``result()``. One step is one
    pass of the adaptive loop: an accepted time step (with its events), a rejected trial
    (the step is halved), or the start/end of a schedule phase. ``state()`` captures
    everything the remaining steps depend on as NumPy arrays and scalars, so
    ``restore(state)`` followed by the remaining steps gives bit-identical results.

    Parameters
    ----------
    scene : LumpedScene
    """

    model = "lumped"

    def __init__(self, scene: LumpedScene) -> None:
        if not isinstance(scene, LumpedScene):
            raise InputError(f"not a LumpedScene: {scene!r}", key="scene",
                             expected="a xlotkit.sim.lumped.LumpedScene")
        self.sc = scene
        self._plan = scene.schedule.expanded()
        self._started = False

    # ------------------------------------------------------------------ protocol
    def start(self) -> None:
        """Set up the state at t = 0 (the well at its initial pressure, no fracture)."""
        sc = self.sc
        self._wall0 = _time.perf_counter()
        self._wall_before = 0.0
        self.sim = sim = _Sim(sc)
        self._well = WellDrive(sim.col)
        self._p_init = sc.p_initial
        ps0 = self._well.idle().surface(self._p_init)[0]
        self.s = _State(t=0.0, p=self._p_init, ps=ps0, pf=self._p_init)
        sim.push(self.s)
        self._i_ph = 0
        self._in_phase = False
        self.phases_out: list[dict[str, Any]] = []
        self.events: list[Event] = []
        self.closure_times: list[float] = []
        self.reopening_times: list[float] = []
        self.reopening_ps: list[float] = []
        self.last_pump_p: dict[int, float] = {}
        self.isip: dict[int, float] = {}
        self.breakdown_time: float | None = None
        self.initiation_time: float | None = None
        self.initiation_p: float | None = None
        self.fbp: float | None = None
        self.status: Literal["ok", "stopped"] = "ok"
        self.messages: list[str] = []
        # phase context (set by _begin_phase)
        self._t0 = self._v_in0 = self._v_ret0 = 0.0
        self._reason = ""
        self._dt_adapt = float(sc.dt)
        self._n_loop = 0
        self._drive = self._well.idle()
        self._q_pump = 0.0
        self._started = True

    def is_done(self) -> bool:
        """True once every phase of the schedule has ended."""
        return self._started and self._i_ph >= len(self._plan)

    def progress(self) -> float:
        """Fraction of the program done, 0..1 (non-decreasing over the run)."""
        n_ph = len(self._plan)
        if not self._started:
            return 0.0
        if self._i_ph >= n_ph:
            return 1.0
        if not self._in_phase:
            return self._i_ph / n_ph
        max_d = self._plan[self._i_ph][1].max_duration
        tot = 0.0 if max_d is None else (self.s.t - self._t0) / max(self._limit, 1e-12)
        return (self._i_ph + min(tot, 1.0)) / n_ph

    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return self.s.t

    def step(self) -> StepOutcome:
        """Advance by one pass of the adaptive loop (see the class docstring)."""
        if not self._started:
            raise RuntimeError("LumpedEngine.step() before start()")
        if self.is_done():
            return StepOutcome(False, self.s.t, "done")
        if not self._in_phase:
            self._begin_phase()
            if self._reason:
                self._end_phase()
                return StepOutcome(True, self.s.t, "phase end at start: " + self._reason)
            return StepOutcome(True, self.s.t, "phase start")
        accepted = self._iterate()
        if not accepted:
            return StepOutcome(False, self.s.t, "rejected: pressure change above dp_max")
        if self._reason:
            reason = self._reason
            self._end_phase()
            return StepOutcome(True, self.s.t, "phase end: " + reason)
        return StepOutcome(True, self.s.t, "accepted")

    def rows(self) -> dict[str, np.ndarray]:
        """The time series so far, one row per accepted internal state (SI).

        Columns (names of :data:`xlotkit.sim.output.SERIES_COLUMNS`): ``t``,
        ``bottomhole_pressure``, ``fracture_pressure``, ``surface_pressure``,
        ``pump_rate``, ``return_rate``, ``pumped_volume``, ``returned_volume``,
        ``leakoff_volume``, ``fracture_length``, ``fracture_volume`` and
        ``mass_balance_error`` (relative residual of the step that ended at the row; NaN
        on the initial row).
        """
        h = {k: np.asarray(v, dtype=float) for k, v in self.sim.hist.items()}
        mb = np.concatenate([[math.nan], np.asarray(self.sim.mb_err, dtype=float)])
        return {
            "t": h["t"], "bottomhole_pressure": h["p"], "fracture_pressure": h["pf"],
            "surface_pressure": h["ps"], "pump_rate": h["q_in"], "return_rate": h["q_ret"],
            "pumped_volume": h["v_in"], "returned_volume": h["v_ret"],
            "leakoff_volume": h["v_carter"] + h["v_wall"], "fracture_length": h["L"],
            "fracture_volume": h["vf"], "mass_balance_error": mb,
        }

    def state(self) -> dict[str, Any]:
        """Everything the remaining steps depend on: NumPy arrays and scalars.

        Floats are stored exactly (arrays of float64, or in the ``"json"`` entry written
        with ``repr`` precision), so :meth:`restore` resumes bit-identically.
        """
        if not self._started:
            raise RuntimeError("LumpedEngine.state() before start()")
        sim = self.sim
        out: dict[str, Any] = {f"hist.{k}": np.asarray(v, dtype=float)
                               for k, v in sim.hist.items()}
        out["mb_err"] = np.asarray(sim.mb_err, dtype=float)
        out["mb_t"] = np.asarray(sim.mb_t, dtype=float)
        out["carter_a"] = sim._ca.copy()
        out["carter_b"] = sim._cb.copy()
        out["carter_dA"] = sim._cdA.copy()
        scal = {
            "state": {k: getattr(self.s, k) for k in _STATE_FIELDS},
            "carter_n": sim._cn, "n_steps": sim.n_steps, "n_rejected": sim.n_rejected,
            "n_events": sim.n_events,
            "i_ph": self._i_ph, "in_phase": self._in_phase, "t0": self._t0,
            "v_in0": self._v_in0, "v_ret0": self._v_ret0, "reason": self._reason,
            "dt_adapt": self._dt_adapt, "n_loop": self._n_loop,
            "ctx": {"q_pump": self._q_pump, "zeta": self._drive.zeta,
                    "q_bleed": self._drive.phase.fixed_return_rate},
            "phases_out": self.phases_out,
            "events": [[e.t, e.text] for e in self.events],
            "closure_times": self.closure_times, "reopening_times": self.reopening_times,
            "reopening_ps": self.reopening_ps,
            "last_pump_p": [[k, v] for k, v in self.last_pump_p.items()],
            "isip": [[k, v] for k, v in self.isip.items()],
            "breakdown_time": self.breakdown_time, "initiation_time": self.initiation_time,
            "initiation_p": self.initiation_p, "fbp": self.fbp, "status": self.status,
            "messages": self.messages,
            "wall_time": self._wall_before + (_time.perf_counter() - self._wall0),
        }
        out["json"] = json.dumps(scal)
        out["model"] = self.model
        return out

    def restore(self, state: Mapping[str, Any]) -> None:
        """Continue from a :meth:`state` dict (instead of :meth:`start`)."""
        try:
            scal = json.loads(str(_scalar(state["json"])))
            hist = {k: np.asarray(state[f"hist.{k}"], dtype=float).tolist()
                    for k in _Sim.HIST_KEYS}
            arrays = {k: np.asarray(state[k], dtype=float) for k in (
                "mb_err", "mb_t", "carter_a", "carter_b", "carter_dA")}
        except (KeyError, ValueError, TypeError) as exc:
            raise InputError(f"not a lumped-engine checkpoint ({exc})", key="checkpoint",
                             expected="a checkpoint written by LumpedEngine.state()") from None
        self.start()
        sim = self.sim
        sim.hist = hist
        sim.mb_err = arrays["mb_err"].tolist()
        sim.mb_t = arrays["mb_t"].tolist()
        sim._ca, sim._cb, sim._cdA = arrays["carter_a"], arrays["carter_b"], arrays["carter_dA"]
        sim._cn = int(scal["carter_n"])
        sim.n_steps, sim.n_rejected = int(scal["n_steps"]), int(scal["n_rejected"])
        sim.n_events = int(scal["n_events"])
        self.s = _State(**scal["state"])
        self._i_ph, self._in_phase = int(scal["i_ph"]), bool(scal["in_phase"])
        self._t0, self._v_in0, self._v_ret0 = scal["t0"], scal["v_in0"], scal["v_ret0"]
        self._reason, self._dt_adapt = scal["reason"], scal["dt_adapt"]
        self._n_loop = int(scal["n_loop"])
        self.phases_out = scal["phases_out"]
        self.events = [Event(t=t, text=x) for t, x in scal["events"]]
        self.closure_times = scal["closure_times"]
        self.reopening_times = scal["reopening_times"]
        self.reopening_ps = scal["reopening_ps"]
        self.last_pump_p = {int(k): v for k, v in scal["last_pump_p"]}
        self.isip = {int(k): v for k, v in scal["isip"]}
        self.breakdown_time = scal["breakdown_time"]
        self.initiation_time = scal["initiation_time"]
        self.initiation_p = scal["initiation_p"]
        self.fbp = scal["fbp"]
        self.status, self.messages = scal["status"], scal["messages"]
        self._wall_before = float(scal["wall_time"])
        if self._in_phase:
            c = scal["ctx"]
            self._setup_phase_context(zeta=c["zeta"])
            self._q_pump = c["q_pump"]

    def snapshot(self) -> None:
        """The lumped model has no mesh: no field snapshots."""
        return None

    # ------------------------------------------------------------------ phases
    def _setup_phase_context(self, zeta: float | None = None) -> None:
        """Phase-dependent objects that follow from ``_i_ph``, ``_t0``, ``_v_in0``,
        ``_v_ret0`` and the state: the drive (its choke calibrated at the present pressure
        unless ``zeta`` is given, from a checkpoint), the time limits and the end tests."""
        sc = self.sc
        cyc, ph = self._plan[self._i_ph]
        self._drive = self._well.begin(
            ph, t0=self._t0, p_bh=self.s.p, v_in=self._v_in0, v_ret=self._v_ret0, zeta=zeta,
            where=phase_place(self._i_ph, cyc, len(sc.schedule.phases)))
        self._q_pump = ph.pump_rate(0.0)
        max_d = ph.max_duration
        self._max_d = max_d
        self._limit = sc.max_phase_duration if max_d is None else min(
            max_d, sc.max_phase_duration)
        self._t_end = self._t0 + self._limit
        self._rate_breaks = [self._t0 + b for b in ph.breakpoints()]
        self._ends = {name: (lambda st, ps, f=f: f(st.p, ps, st.v_in, st.v_ret))
                      for name, f in self._drive.end_tests().items()}

    def _begin_phase(self) -> None:
        sc, s = self.sc, self.s
        i_ph = self._i_ph
        cyc, ph = self._plan[i_ph]
        self._t0 = s.t
        self._v_in0, self._v_ret0 = s.v_in, s.v_ret
        self._setup_phase_context()
        # The state's return rate belongs to the previous phase; restate it for this one
        # so the trapezoidal choke flux starts from the right value.
        s.ps, s.q_ret = self._drive.surface(s.p, self._q_pump)
        self.events.append(Event(t=self._t0, text=f"cycle {cyc}: {ph.label}"))
        reason = ""
        # Already satisfied at the start?
        for name, fn in self._ends.items():
            if fn(s, s.ps) <= 0.0:
                reason = name
                break
        self._reason = reason
        self._dt_adapt = float(sc.dt)
        self._n_loop = 0
        self._in_phase = True

    def _end_phase(self) -> None:
        sc, s = self.sc, self.s
        i_ph, reason = self._i_ph, self._reason
        cyc, ph = self._plan[i_ph]
        n_ph = len(self._plan)
        if reason == "limit":
            self.status = "stopped"
            self.messages.append(f"phase {i_ph + 1} ({ph.label}, cycle {cyc}) hit "
                                 f"max_phase_duration {sc.max_phase_duration:g} s before its "
                                 f"end condition")
        if ph.pumps and i_ph + 1 < n_ph and not self._plan[i_ph + 1][1].pumps:
            # ISIP: the well pressure once the entry loss has gone, i.e. the fracture
            # pressure at shut-in (= the well pressure without entry loss or fracture).
            self.isip[cyc] = s.pf if (s.broken and not s.sealed) else s.p
            self.last_pump_p[cyc] = s.p
        self.phases_out.append({"cycle": cyc, "kind": ph.kind, "name": ph.label,
                                "t_start": self._t0, "t_end": s.t, "end": reason})
        self._i_ph += 1
        self._in_phase = False
        self._reason = ""

    # ------------------------------------------------------------------ one loop pass
    def _iterate(self) -> bool:
        """One pass of the adaptive loop; False if the trial step was rejected."""
        sc, sim, drive = self.sc, self.sim, self._drive
        s = self.s
        t_end = self._t_end
        dt_out = float(sc.dt)
        self._n_loop += 1
        self._q_pump = q_pump = drive.pump_rate(s.t)
        k_next = math.floor(s.t / dt_out + 1e-9) + 1
        if k_next * dt_out - s.t < 1e-6 * dt_out:
            k_next += 1     # no round-off-sized steps after an event near a sample
        t_break = min([k_next * dt_out, t_end]
                      + [b for b in self._rate_breaks if b > s.t + 1e-12])
        dt = min(self._dt_adapt, t_break - s.t)
        if dt <= 0.0:
            dt = t_break - s.t
        st = sim.solve(s, dt, drive, q_pump)
        if (not st.jump and max(abs(st.p - s.p), abs(st.pf - s.pf)) > sc.dp_max
                and dt > 1e-3):
            self._dt_adapt = 0.5 * dt
            sim.n_rejected += 1
            return False
        # ---- events in this step: armed at the start, fired at the end
        armed: dict[str, Callable[[_State, float], float]] = {}
        for name, fn in self._ends.items():
            armed[name] = fn
        if not s.broken:
            armed["breakdown"] = lambda x, ps: sim.pb - x.p
        elif s.sealed:
            # closed and held shut at the wall: reopens when the WELL reaches P_r
            if s.p < sim.pr - sim.tol_p:
                armed["reopening_wall"] = lambda x, ps: sim.pr - x.p
        else:
            if s.L < sim.L_stab:
                armed["unstable"] = lambda x, ps: x.margin
            # closure and reopening at sigma_h are on the FRACTURE pressure
            if s.pf > sim.sh + sim.tol_p:
                armed["closure"] = lambda x, ps: x.pf - sim.sh
            elif s.pf < sim.sh - sim.tol_p:
                armed["reopening"] = lambda x, ps: sim.sh - x.pf
        fired = [n for n, fn in armed.items() if fn(_view(s, st), st.ps) <= 0.0]
        hit: list[str] = []
        if fired:
            best_dt = dt
            for name in fired:
                dt_e = _locate(lambda d, fn=armed[name]: _g(sim, s, drive, q_pump, fn, d),
                               dt)
                best_dt = min(best_dt, dt_e)
            if best_dt < dt:
                st = sim.solve(s, best_dt, drive, q_pump)
            hit = [n for n, fn in armed.items() if fn(_view(s, st), st.ps) <= 0.0]
            sim.n_events += len(hit)
        if st.jump and self.fbp is None:   # an unstable jump not caught as an event
            self.fbp, self.breakdown_time = s.p, s.t
        s = sim.accept(s, st, q_pump)
        self._dt_adapt = min(dt_out, 2.0 * self._dt_adapt)
        reason = self._reason
        for name in hit:
            if name == "closure":
                # With the entry loss and reopening at sigma_h, a well a few Pa above
                # sigma_h can refill a just-closed fracture for an instant; count one
                # closure until a reopening has been recorded.
                if len(self.closure_times) <= len(self.reopening_times):
                    self.closure_times.append(s.t)
                if sim.seal:
                    # The faces are in contact; the mouth now needs P_r to reopen.
                    s.sealed = True
                    s.pf = s.p
            elif name == "reopening":
                self.reopening_times.append(s.t)
                self.reopening_ps.append(s.p)
            elif name == "reopening_wall":
                # The wall lets go: the fracture, at its old size, meets net pressure
                # P_r - sigma_h. A zero-length step redistributes the well's volume
                # into it (at fixed L, or growing if K_I > K_Ic) -- the same
                # volume-conserving jump as at breakdown.
                self.reopening_times.append(s.t)
                self.reopening_ps.append(s.p)
                s.sealed = False
                s.pf = s.p
                s = sim.accept(s, sim.solve(s, 0.0, drive, q_pump), q_pump)
            elif name == "breakdown":
                # Hubbert-Willis initiation: the flaw becomes a fracture; it jumps at
                # once if K_I(P_b, L_0) > K_Ic, else later ("unstable").
                self.initiation_time, self.initiation_p = s.t, s.p
                s.broken = True
                s.L = sc.initial_flaw
                st0 = sim.solve(s, 0.0, drive, q_pump)
                if st0.jump and self.fbp is None:
                    self.fbp, self.breakdown_time = s.p, s.t
                s = sim.accept(s, st0, q_pump)
            elif name == "unstable":
                if self.fbp is None:
                    self.fbp, self.breakdown_time = s.p, s.t
                s = sim.accept(s, sim.solve(s, 0.0, drive, q_pump, force_jump=True), q_pump)
            elif not reason:
                reason = name
        if not reason and s.t >= t_end - 1e-9:
            max_d = self._max_d
            reason = "duration" if (max_d is not None and self._limit == max_d) else "limit"
        self.s = s
        self._reason = reason
        return True

    # ------------------------------------------------------------------ result
    def result(self) -> LumpedResult:
        """The outcome once :meth:`is_done` (record on the output grid, truth)."""
        if not self.is_done():
            raise RuntimeError("LumpedEngine.result() before the run is done")
        sc, sim = self.sc, self.sim
        p_init = self._p_init
        status = self.status
        hist = {k: np.asarray(v, dtype=float) for k, v in sim.hist.items()}
        record = _make_record(sc, sim, hist, self.events)
        v_leak = hist["v_carter"] + hist["v_wall"]
        resid_cum = (hist["v_in"] - hist["v_ret"] - sim.cw * (hist["p"] - p_init)
                     - hist["vf"] - v_leak)
        denom = max(float(np.max(hist["v_in"] + hist["v_ret"])), 1e-300)
        mb = np.asarray(sim.mb_err)
        if status == "ok":
            msg = (f"{sc.schedule.n_cycles} cycle(s), {sim.n_steps} steps, "
                   f"max step mass-balance error {mb.max() if mb.size else 0.0:.2e}")
        else:
            msg = "; ".join(self.messages)
        truth: dict[str, Any] = {
            "sigma_h": sc.sigma_h, "sigma_H": sc.sigma_H, "pore_pressure": sc.pore_pressure,
            "tensile_strength": sc.tensile_strength,
            "breakdown_pressure_model": sc.breakdown_pressure,
            "fbp": self.fbp, "breakdown_time": self.breakdown_time,
            "initiation_pressure": self.initiation_p, "initiation_time": self.initiation_time,
            "reopening_pressure_model": sim.pr, "reopening_model": sc.reopening,
            "closure_times": list(self.closure_times),
            "reopening_times": list(self.reopening_times),
            "reopening_pressures": list(self.reopening_ps),
            "isip": dict(self.isip), "last_pump_pressure": dict(self.last_pump_p),
            "nwb_coefficient": sc.nwb_coefficient, "phases": list(self.phases_out),
            "well_compliance": sim.cw, "stable_length": sim.L_stab,
            "initial_pressure": p_init,
            "t": hist["t"], "pressure": hist["p"], "fracture_pressure": hist["pf"],
            "surface_pressure": hist["ps"],
            "fracture_length": hist["L"], "fracture_volume": hist["vf"],
            "pumped_volume": hist["v_in"], "returned_volume": hist["v_ret"],
            "leakoff_volume": v_leak,
            "mass_balance_error": mb, "mass_balance_t": np.asarray(sim.mb_t),
            "mass_balance_cumulative": resid_cum / denom,
            "n_steps": sim.n_steps, "n_rejected": sim.n_rejected, "n_events": sim.n_events,
            "wall_time": self._wall_before + (_time.perf_counter() - self._wall0),
        }
        return LumpedResult(status=status, message=msg, record=record, truth=truth)


def _scalar(v: Any) -> Any:
    """A Python scalar from a 0-d array or a scalar."""
    return v.item() if isinstance(v, np.ndarray) else v


def _view(s: _State, st: _Step) -> _State:
    """The state a trial step would lead to (for event functions)."""
    return _State(t=s.t + st.dt, p=st.p, L=st.L, broken=s.broken, vf=st.vf, pf=st.pf,
                  sealed=s.sealed,
                  v_in=s.v_in + st.dv_in, v_ret=s.v_ret + st.dv_ret, ps=st.ps,
                  margin=st.margin)


def _g(sim: _Sim, s: _State, drive: PhaseDrive, q_pump: float, fn, d: float) -> float:
    st = sim.solve(s, d, drive, q_pump)
    return fn(_view(s, st), st.ps)


def _locate(g: Callable[[float], float], dt: float) -> float:
    """Smallest sub-step in (0, dt] after which the event function g is <= 0 (g(dt) <= 0)."""
    if g(0.0) <= 0.0:
        return 0.0
    r = brentq(g, 0.0, dt, xtol=1e-10, rtol=1e-14, maxiter=200)
    # Make sure the event has fired in the returned state (brentq may stop just before).
    step = max(1e-10, 1e-14 * r)
    while g(r) > 0.0 and r < dt:
        r = min(dt, r + step)
        step *= 2.0
    return r


def _make_record(sc: LumpedScene, sim: _Sim, hist: dict[str, np.ndarray],
                 events: list[Event]) -> Record:
    t_int = hist["t"]
    t_end = float(t_int[-1])
    n = int(math.floor(t_end / sc.dt + 1e-9)) + 1
    t = np.arange(n) * sc.dt
    # Latest internal state at or before each sample time (post-jump at a shared time).
    idx = np.searchsorted(t_int, t + 1e-9, side="right") - 1
    idx = np.clip(idx, 0, t_int.size - 1)
    exact = np.abs(t_int[idx] - t) <= 1e-9

    def at(name: str) -> np.ndarray:
        v = hist[name]
        out = np.interp(t, t_int, v)
        out[exact] = v[idx[exact]]
        return out

    p = at("p")
    ps = at("ps")
    rate = hist["q_in"][idx].copy()
    if rate.size and hist["q_in"].size > 1:
        rate[0] = hist["q_in"][1]
    ret = hist["q_ret"][idx]
    rng = np.random.default_rng(sc.seed)
    if sc.noise > 0.0:
        p = p + rng.normal(0.0, sc.noise, size=p.size)
        ps = ps + rng.normal(0.0, sc.noise, size=ps.size)
    if sc.resolution > 0.0:
        p = np.round(p / sc.resolution) * sc.resolution
        ps = np.round(ps / sc.resolution) * sc.resolution
    comp = sc.completion_used
    meta = {
        "source": "xlotkit.sim.lumped", "simulated": True,
        "sigma_h": sc.sigma_h, "sigma_H": sc.sigma_H, "pore_pressure": sc.pore_pressure,
        "tensile_strength": sc.tensile_strength,
        "breakdown_pressure_model": sc.breakdown_pressure,
        "reopening": sc.reopening, "reopening_pressure_model": sc.reopening_pressure,
        "nwb_coefficient": sc.nwb_coefficient,
        "youngs_modulus": sc.youngs_modulus, "poisson_ratio": sc.poisson_ratio,
        "toughness": sc.toughness, "geometry": sc.geometry,
        "leakoff_coefficient": sc.leakoff_coefficient, "well_compliance": sim.cw,
        "tvd": sim.col.tvd, "density": sc.density, "noise": sc.noise,
        "resolution": sc.resolution, "seed": int(sc.seed), "dt": sc.dt,
    }
    return Record(
        t=t, pressure=p,
        reference=PressureReference(kind="bottomhole", depth_m=comp.length_md, absolute=False),
        start_time=sc.start_time, rate=rate, volume=at("v_in"), return_rate=ret,
        return_volume=at("v_ret"), density=np.full(t.size, float(sc.density)),
        channels={"surface_pressure": ps, "fracture_pressure": at("pf"),
                  "fracture_length": at("L"),
                  "fracture_volume": at("vf"),
                  "leakoff_volume": at("v_carter") + at("v_wall")},
        events=tuple(events), meta=meta)


# =========================================================================== scene files
_STD_KINDS = ("pressure", "rate", "volume", "density", "time", "length", "dimensionless")

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


def _quantity(value: Any, dim: str, key: str) -> float:
    """SI value of a number or ``"value unit"`` string of dimension ``dim``."""
    if dim in _STD_KINDS:
        return parse_quantity(value, dim, key=key)
    from xlotkit.units import parse_unit, registry, to_si

    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise InputError(f"must be a number or a 'value unit' string, got {value!r}",
                         key=key, expected=f"a number in SI ({dim}) or e.g. '1 {dim}'")
    if not isinstance(value, str):
        return float(value)
    m = _NUM_UNIT.match(value)
    if not m:
        raise InputError(f"cannot read {value!r}", key=key, expected=f"e.g. '1 {dim}'")
    num, unit = float(m.group(1)), m.group(2)
    if not unit:
        return num
    pu = parse_unit(unit, key=key)
    if pu.dimensionality != registry().Unit(dim).dimensionality:
        raise InputError(f"unit {unit!r} has the wrong dimension", key=key,
                         expected=f"a unit of the dimension of {dim}")
    return float(to_si([num], pu)[0])


def _convert(value: Any, kind: Any, key: str) -> Any:
    if kind is str:
        if not isinstance(value, str):
            raise InputError(f"must be a string, got {value!r}", key=key, expected="a string")
        return value.strip().lower()
    if kind is bool:
        if not isinstance(value, bool):
            raise InputError(f"must be true or false, got {value!r}", key=key,
                             expected="true or false")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"must be an integer, got {value!r}", key=key,
                             expected="an integer")
        return value
    if kind is datetime:
        if isinstance(value, datetime):
            return value
        try:
            return datetime.fromisoformat(str(value))
        except ValueError:
            raise InputError(f"cannot read {value!r} as a date-time", key=key,
                             expected="an ISO 8601 date-time, e.g. 2014-03-01T08:00:00") \
                from None
    return _quantity(value, kind, key)


def _scene_from_dict(data: Mapping[str, Any], *, file: str | None = None) -> LumpedScene:
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
    return _scene_from_dict(data, file=str(p))


# =========================================================================== standard scene
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
