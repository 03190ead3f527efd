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
``p = sigma_h``; it reopens at ``sigma_h`` in later cycles and propagates again at
``sigma_h + dp_c(L)``.

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
        + dV_Carter - dV_in = 0

for one scalar: ``p'`` on the elastic branch (``L' = L``), or ``ln L'`` on the critical
branch. Both are monotone, solved with Brent's method to round-off, so the volume balance
closes to ~1e-12 relative every step (reported in ``truth["mass_balance_error"]``). The step
is adaptive (pressure change per step <= ``dp_max``), never longer than the output interval,
and ends exactly on every output sample. Events are located to 1e-9 s: breakdown,
closure/reopening at ``sigma_h``, and phase ends on pressure or volume; phase durations and
rate steps are step boundaries.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any, Literal

import numpy as np
from scipy.optimize import brentq

from xlotkit.errors import InputError
from xlotkit.record import Event, PressureReference, Record
from xlotkit.sim.schedule import Bleed, Flowback, Pump, Schedule, ShutIn
from xlotkit.sim.well import (
    Column,
    Completion,
    _check,
    calibrate_choke,
    choke_surface_pressure,
    hydrostatic_bottomhole,
    surface_from_bottomhole,
    well_compliance,
)

__all__ = [
    "LumpedResult",
    "LumpedScene",
    "breakdown_pressure",
    "critical_net_pressure",
    "fracture_compliance",
    "fracture_face_area",
    "fracture_volume",
    "simulate_lumped",
    "stable_length",
    "standard_lumped_scene",
    "stress_intensity",
    "wall_leak_index",
]

Geometry = Literal["kgd", "penny"]


# =========================================================================== physics
def breakdown_pressure(sigma_h: float, sigma_H: float, pore_pressure: float,
                       tensile_strength: float) -> float:
    """Hubbert–Willis breakdown pressure ``3 sigma_h - sigma_H - p0 + T0`` [Pa] (Eq. C.11)."""
    return 3.0 * sigma_h - sigma_H - pore_pressure + tensile_strength


def fracture_volume(net_pressure: float, size: float, geometry: Geometry, e_prime: float,
                    height: float = 1.0) -> float:
    """Sneddon opening volume [m^3]; 0 for a closed fracture (``net_pressure <= 0``).

    KGD: ``2 pi h L^2 dp / E'`` (``size`` = half-length L); penny: ``16 R^3 dp / (3 E')``.
    """
    if net_pressure <= 0.0:
        return 0.0
    if geometry == "kgd":
        return 2.0 * math.pi * height * size * size * net_pressure / e_prime
    return 16.0 * size**3 * net_pressure / (3.0 * e_prime)


def fracture_compliance(size: float, geometry: Geometry, e_prime: float,
                        height: float = 1.0) -> float:
    """``dV_f/dp`` of an open fracture at fixed size [m^3/Pa] (inverse of Eq. C.3 for penny)."""
    return fracture_volume(1.0, size, geometry, e_prime, height)


def stress_intensity(net_pressure: float, size: float, geometry: Geometry) -> float:
    """Mode-I stress intensity [Pa m^0.5]: ``dp sqrt(pi L)`` (KGD), ``(2/pi) dp sqrt(pi R)``."""
    k = net_pressure * math.sqrt(math.pi * size)
    return k if geometry == "kgd" else 2.0 / math.pi * k


def critical_net_pressure(size: float, geometry: Geometry, toughness: float) -> float:
    """Net pressure at which ``K_I = K_Ic`` [Pa] for a fracture of ``size`` [m]."""
    dp = toughness / math.sqrt(math.pi * size)
    return dp if geometry == "kgd" else 0.5 * math.pi * dp


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


def wall_leak_index(permeability: float, viscosity: float, length: float, radius: float,
                    drainage_radius: float | None = None) -> float:
    """Steady radial productivity ``J = 2 pi k H / (mu ln(r_e / r_w))`` [m^3/(s Pa)].

    A constant-permeability open-hole wall leaking ``J (p - p0)``; ``r_e`` defaults to
    ``10 r_w`` (a short-time radius of investigation, a modelling choice).
    """
    r_e = 10.0 * radius if drainage_radius is None else drainage_radius
    return 2.0 * math.pi * permeability * length / (viscosity * math.log(r_e / radius))


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
        return self.youngs_modulus / (1.0 - self.poisson_ratio**2)

    @property
    def breakdown_pressure(self) -> float:
        """Hubbert–Willis breakdown pressure P_b [Pa]."""
        return breakdown_pressure(self.sigma_h, self.sigma_H, self.pore_pressure,
                                  self.tensile_strength)

    @property
    def p_initial(self) -> float:
        """Bottom-hole pressure at t = 0 [Pa]."""
        if self.initial_pressure is not None:
            return float(self.initial_pressure)
        return hydrostatic_bottomhole(self.column)

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
    p: float
    L: float = 0.0            # fracture size (0 while intact)
    broken: bool = False
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


class _Ctx:
    """What the current phase does at the surface."""

    def __init__(self, phase, q_pump: float = 0.0, zeta: float = 0.0, q_bleed: float = 0.0):
        self.phase = phase
        self.q_pump = q_pump
        self.zeta = zeta
        self.q_bleed = q_bleed


class _Sim:
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
        self.J = scene.wall_leak_index
        self.p0 = scene.pore_pressure
        self.CL = scene.leakoff_coefficient
        self.L_stab = stable_length(self.cw, self.geo, self.ep, self.h)
        self.tol_p = 1e-3  # [Pa] band around sigma_h treated as "at closure"
        # Carter increments: area dA created linearly over [a, b].
        self._ca = np.zeros(64)
        self._cb = np.zeros(64)
        self._cdA = np.zeros(64)
        self._cn = 0
        self._cache: dict[tuple[float, int], float] = {}
        # History of accepted states.
        self.hist: dict[str, list[float]] = {k: [] for k in (
            "t", "p", "L", "vf", "v_in", "v_ret", "v_carter", "v_wall", "ps", "q_in", "q_ret")}
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

    def surface(self, p: float, ctx: _Ctx) -> tuple[float, float]:
        """(surface pressure, return rate) at bottom-hole pressure p in phase ctx."""
        if isinstance(ctx.phase, Flowback):
            return choke_surface_pressure(p, ctx.zeta, self.col)
        if isinstance(ctx.phase, Bleed):
            return surface_from_bottomhole(p, -ctx.q_bleed, self.col), ctx.q_bleed
        if isinstance(ctx.phase, Pump):
            return surface_from_bottomhole(p, ctx.q_pump, self.col), 0.0
        return surface_from_bottomhole(p, 0.0, self.col), 0.0

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
    def solve(self, s: _State, dt: float, ctx: _Ctx, force_jump: bool = False) -> _Step:
        cw, sh = self.cw, self.sh
        is_open = s.broken and s.p > sh + self.tol_p
        dv_in = ctx.q_pump * dt
        dv_c_old = self.carter_old(s.t, s.t + dt) if (is_open and dt > 0) else 0.0
        c_new = (2.0 * 4.0 / 3.0 * self.CL * math.sqrt(dt)) if is_open else 0.0
        q_ret_n = s.q_ret if dt > 0 else 0.0
        wall_n = self.J * (s.p - self.p0)
        A_n = self.area(s.L)
        half = 0.5 * dt
        bleed_like = not isinstance(ctx.phase, Flowback)

        def parts(p: float, dp: float, L: float):
            vf = self.vol(dp, L) if s.broken else 0.0
            if bleed_like:
                q_ret = ctx.q_bleed
                dv_ret = q_ret * dt
                ps = None
            else:
                ps, q_ret = choke_surface_pressure(p, ctx.zeta, self.col)
                dv_ret = half * (q_ret_n + q_ret)
            dv_w = half * (wall_n + self.J * (p - self.p0))
            dA = self.area(L) - A_n if s.broken else 0.0
            dv_c = dv_c_old + c_new * dA
            r = cw * (p - s.p) + (vf - s.vf) + dv_ret + dv_w + dv_c - dv_in
            return r, vf, dv_ret, dv_w, dv_c, q_ret, ps, dA

        def r_el(p: float) -> float:
            return parts(p, p - sh, s.L)[0]

        def r_cr(lam: float) -> float:
            L = Ls * math.exp(lam)
            dp = self.dpc(L)
            return parts(sh + dp, dp, L)[0]

        jump = False
        margin = math.inf
        if not s.broken:
            p = _solve_monotone(r_el, s.p)
            L, dp = 0.0, p - sh
        else:
            p_star = sh + self.dpc(s.L)
            margin = r_el(p_star)
            if margin >= 0.0 and not force_jump:
                p = _solve_monotone(r_el, min(s.p, p_star), hi=p_star)
                L, dp = s.L, p - sh
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
                p = sh + dp
        r, vf, dv_ret, dv_w, dv_c, q_ret, ps, dA = parts(p, dp, L)
        if ps is None:
            ps = self.surface(p, ctx)[0]
        # Relative to the step's volume turnover; for sub-millisecond (event) steps the
        # turnover is at the round-off level of the stored volume, so floor the scale at
        # 1e-6 of it (C_w p + V_f).
        scale = max(abs(dv_in) + abs(dv_ret) + abs(dv_w) + abs(dv_c) + cw * abs(p - s.p)
                    + abs(vf - s.vf), 1e-6 * (cw * abs(p) + vf), 1e-300)
        return _Step(dt, p, L, vf, dv_in, dv_ret, dv_c, dv_w, q_ret, ps, dA, r, scale, jump,
                     margin)

    def accept(self, s: _State, st: _Step, ctx: _Ctx) -> _State:
        if st.dA > 0.0:
            self.add_area(s.t, s.t + st.dt, st.dA)
        new = _State(t=s.t + st.dt, p=st.p, L=st.L, broken=s.broken, vf=st.vf,
                     v_in=s.v_in + st.dv_in, v_ret=s.v_ret + st.dv_ret,
                     v_carter=s.v_carter + st.dv_carter, v_wall=s.v_wall + st.dv_wall,
                     ps=st.ps, q_in=ctx.q_pump, q_ret=st.q_ret)
        self.mb_err.append(abs(st.resid) / st.scale)
        self.mb_t.append(new.t)
        self.n_steps += 1
        self.push(new)
        return new

    def push(self, s: _State) -> None:
        h = self.hist
        for k in h:
            h[k].append(getattr(s, k))


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

    Parameters
    ----------
    scene : LumpedScene
    progress : callable, optional
        Called with the fraction of the program done (0..1); nothing is printed or logged.

    Returns
    -------
    LumpedResult
        ``record``: bottom-hole gauge pressure ``pressure`` [Pa], ``rate``/``volume`` (pump),
        ``return_rate``/``return_volume``, ``density`` (surface, constant), channels
        ``surface_pressure`` [Pa], ``fracture_length`` [m] (KGD half-length or penny
        radius), ``fracture_volume`` [m^3], ``leakoff_volume`` [m^3]; sampled every
        ``scene.dt`` with the scene's noise and resolution on the pressures.
        ``truth``: ``sigma_h``, ``sigma_H``, ``pore_pressure``, ``tensile_strength``,
        ``breakdown_pressure_model`` (Eq. 2), ``initiation_pressure`` / ``initiation_time``
        (when P_b was reached), ``fbp`` and ``breakdown_time`` (pressure and time of the
        first unstable jump; = P_b when ``K_I(P_b, L_0) > K_Ic``),
        ``closure_times`` / ``reopening_times`` [s], ``phases`` (cycle, kind, t_start,
        t_end, end reason), ``isip`` per cycle, ``well_compliance``, ``stable_length``,
        the internal history ``t``, ``pressure`` (clean), ``surface_pressure``,
        ``fracture_length``, ``fracture_volume``, ``mass_balance_error`` (relative residual
        of Eq. 1 per step) with ``mass_balance_t``, ``mass_balance_cumulative`` (relative
        error of the total balance at the end), counters ``n_steps``, ``n_rejected``,
        ``n_events`` and ``wall_time``.
    """
    wall0 = _time.perf_counter()
    sim = _Sim(scene)
    sc = scene
    dt_out = float(sc.dt)
    p_init = sc.p_initial
    ctx0 = _Ctx(ShutIn(duration=1.0))
    ps0 = sim.surface(p_init, ctx0)[0]
    s = _State(t=0.0, p=p_init, ps=ps0)
    sim.push(s)
    plan = sc.schedule.expanded()
    n_ph = len(plan)
    phases_out: list[dict[str, Any]] = []
    events: list[Event] = []
    closure_times: list[float] = []
    reopening_times: list[float] = []
    breakdown_time: float | None = None
    initiation_time: float | None = None
    initiation_p: float | None = None
    fbp: float | None = None
    isip: dict[int, float] = {}
    status: Literal["ok", "stopped"] = "ok"
    messages: list[str] = []

    def report(frac: float) -> None:
        if progress is not None:
            progress(min(max(frac, 0.0), 1.0))

    for i_ph, (cyc, ph) in enumerate(plan):
        report(i_ph / n_ph)
        t0 = s.t
        v_in0, v_ret0 = s.v_in, s.v_ret
        if isinstance(ph, Pump):
            ctx = _Ctx(ph, q_pump=ph.rate_at(0.0))
        elif isinstance(ph, Flowback):
            if ph.zeta is not None:
                zeta = float(ph.zeta)
            else:
                ps_static = surface_from_bottomhole(s.p, 0.0, sim.col)
                try:
                    zeta = calibrate_choke(float(ph.initial_rate), ps_static)
                except InputError:
                    raise InputError(
                        f"phase {i_ph + 1} (cycle {cyc}) starts with surface pressure "
                        f"{ps_static / 1e6:.3f} MPa; cannot calibrate the choke from "
                        f"initial_rate", key=f"schedule.phases[{i_ph % len(sc.schedule.phases)}]"
                        ".initial_rate", expected="flowback from a pressured well") from None
            ctx = _Ctx(ph, zeta=zeta)
        elif isinstance(ph, Bleed):
            ctx = _Ctx(ph, q_bleed=float(ph.rate))
        else:
            ctx = _Ctx(ph)
        # The state's return rate belongs to the previous phase; restate it for this one
        # so the trapezoidal choke flux starts from the right value.
        s.ps, s.q_ret = sim.surface(s.p, ctx)
        events.append(Event(t=t0, text=f"cycle {cyc}: {ph.label}"))
        max_d = ph.max_duration
        limit = sc.max_phase_duration if max_d is None else min(max_d, sc.max_phase_duration)
        t_end = t0 + limit
        rate_breaks = [t0 + b for b in ph.breakpoints()] if isinstance(ph, Pump) else []

        def end_fns():
            fns: dict[str, Callable[[_State, float], float]] = {}
            pa = ph.pressure_at
            def px(st, ps):  # noqa: E306
                return st.p if pa == "bottomhole" else ps
            if ph.pressure_above is not None:
                thr = float(ph.pressure_above)
                fns["pressure_above"] = lambda st, ps: thr - px(st, ps)
            if ph.pressure_below is not None:
                thr2 = float(ph.pressure_below)
                fns["pressure_below"] = lambda st, ps: px(st, ps) - thr2
            vt = ph.volume_target
            if vt is not None:
                if isinstance(ph, Pump):
                    fns["volume"] = lambda st, ps: (v_in0 + vt) - st.v_in
                else:
                    fns["volume"] = lambda st, ps: (v_ret0 + vt) - st.v_ret
            if isinstance(ph, Bleed):
                fns["well_dead"] = lambda st, ps: ps
            return fns

        ends = end_fns()
        reason = ""
        # Already satisfied at the start?
        for name, fn in ends.items():
            if fn(s, s.ps) <= 0.0:
                reason = name
                break
        dt_adapt = dt_out
        n_loop = 0
        while not reason:
            n_loop += 1
            if isinstance(ph, Pump):
                ctx.q_pump = ph.rate_at(s.t - t0)
            k_next = math.floor(s.t / dt_out + 1e-9) + 1
            if k_next * dt_out - s.t < 1e-6 * dt_out:
                k_next += 1     # no round-off-sized steps after an event near a sample
            t_break = min([k_next * dt_out, t_end] + [b for b in rate_breaks if b > s.t + 1e-12])
            dt = min(dt_adapt, t_break - s.t)
            if dt <= 0.0:
                dt = t_break - s.t
            st = sim.solve(s, dt, ctx)
            if (not st.jump and abs(st.p - s.p) > sc.dp_max and dt > 1e-3):
                dt_adapt = 0.5 * dt
                sim.n_rejected += 1
                continue
            # ---- events in this step: armed at the start, fired at the end
            armed: dict[str, Callable[[_State, float], float]] = {}
            for name, fn in ends.items():
                armed[name] = fn
            if not s.broken:
                armed["breakdown"] = lambda x, ps: sim.pb - x.p
            else:
                if s.L < sim.L_stab:
                    armed["unstable"] = lambda x, ps: x.margin
                if s.p > sim.sh + sim.tol_p:
                    armed["closure"] = lambda x, ps: x.p - sim.sh
                elif s.p < sim.sh - sim.tol_p:
                    armed["reopening"] = lambda x, ps: sim.sh - x.p
            fired = [n for n, fn in armed.items() if fn(_view(s, st), st.ps) <= 0.0]
            hit: list[str] = []
            if fired:
                best_dt = dt
                for name in fired:
                    dt_e = _locate(lambda d, fn=armed[name]: _g(sim, s, ctx, fn, d), dt)
                    best_dt = min(best_dt, dt_e)
                if best_dt < dt:
                    st = sim.solve(s, best_dt, ctx)
                hit = [n for n, fn in armed.items() if fn(_view(s, st), st.ps) <= 0.0]
                sim.n_events += len(hit)
            if st.jump and fbp is None:   # an unstable jump not caught as an event
                fbp, breakdown_time = s.p, s.t
            s = sim.accept(s, st, ctx)
            dt_adapt = min(dt_out, 2.0 * dt_adapt)
            for name in hit:
                if name == "closure":
                    closure_times.append(s.t)
                elif name == "reopening":
                    reopening_times.append(s.t)
                elif name == "breakdown":
                    # Hubbert-Willis initiation: the flaw becomes a fracture; it jumps at
                    # once if K_I(P_b, L_0) > K_Ic, else later ("unstable").
                    initiation_time, initiation_p = s.t, s.p
                    s.broken = True
                    s.L = sc.initial_flaw
                    st0 = sim.solve(s, 0.0, ctx)
                    if st0.jump and fbp is None:
                        fbp, breakdown_time = s.p, s.t
                    s = sim.accept(s, st0, ctx)
                elif name == "unstable":
                    if fbp is None:
                        fbp, breakdown_time = s.p, s.t
                    s = sim.accept(s, sim.solve(s, 0.0, ctx, force_jump=True), ctx)
                elif not reason:
                    reason = name
            if not reason and s.t >= t_end - 1e-9:
                reason = "duration" if (max_d is not None and limit == max_d) else "limit"
            if n_loop % 200 == 0:
                tot = 0.0 if max_d is None else (s.t - t0) / max(limit, 1e-12)
                report((i_ph + min(tot, 1.0)) / n_ph)
        if reason == "limit":
            status = "stopped"
            messages.append(f"phase {i_ph + 1} ({ph.label}, cycle {cyc}) hit max_phase_duration "
                            f"{sc.max_phase_duration:g} s before its end condition")
        if isinstance(ph, Pump) and i_ph + 1 < n_ph and not isinstance(plan[i_ph + 1][1], Pump):
            isip[cyc] = s.p
        phases_out.append({"cycle": cyc, "kind": ph.kind, "name": ph.label, "t_start": t0,
                           "t_end": s.t, "end": reason})
    report(1.0)

    hist = {k: np.asarray(v, dtype=float) for k, v in sim.hist.items()}
    record = _make_record(sc, sim, hist, events)
    v_leak = hist["v_carter"] + hist["v_wall"]
    resid_cum = (hist["v_in"] - hist["v_ret"] - sim.cw * (hist["p"] - p_init) - hist["vf"]
                 - v_leak)
    denom = max(float(np.max(hist["v_in"] + hist["v_ret"])), 1e-300)
    mb = np.asarray(sim.mb_err)
    if status == "ok":
        msg = (f"{sc.schedule.n_cycles} cycle(s), {sim.n_steps} steps, "
               f"max step mass-balance error {mb.max() if mb.size else 0.0:.2e}")
    else:
        msg = "; ".join(messages)
    truth: dict[str, Any] = {
        "sigma_h": sc.sigma_h, "sigma_H": sc.sigma_H, "pore_pressure": sc.pore_pressure,
        "tensile_strength": sc.tensile_strength,
        "breakdown_pressure_model": sc.breakdown_pressure,
        "fbp": fbp, "breakdown_time": breakdown_time,
        "initiation_pressure": initiation_p, "initiation_time": initiation_time,
        "closure_times": closure_times, "reopening_times": reopening_times,
        "isip": isip, "phases": phases_out,
        "well_compliance": sim.cw, "stable_length": sim.L_stab,
        "initial_pressure": p_init,
        "t": hist["t"], "pressure": hist["p"], "surface_pressure": hist["ps"],
        "fracture_length": hist["L"], "fracture_volume": hist["vf"],
        "pumped_volume": hist["v_in"], "returned_volume": hist["v_ret"],
        "leakoff_volume": v_leak,
        "mass_balance_error": mb, "mass_balance_t": np.asarray(sim.mb_t),
        "mass_balance_cumulative": resid_cum / denom,
        "n_steps": sim.n_steps, "n_rejected": sim.n_rejected, "n_events": sim.n_events,
        "wall_time": _time.perf_counter() - wall0,
    }
    return LumpedResult(status=status, message=msg, record=record, truth=truth)


def _view(s: _State, st: _Step) -> _State:
    """The state a trial step would lead to (for event functions)."""
    return _State(t=s.t + st.dt, p=st.p, L=st.L, broken=s.broken, vf=st.vf,
                  v_in=s.v_in + st.dv_in, v_ret=s.v_ret + st.dv_ret, ps=st.ps,
                  margin=st.margin)


def _g(sim: _Sim, s: _State, ctx: _Ctx, fn, d: float) -> float:
    st = sim.solve(s, d, ctx)
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
        channels={"surface_pressure": ps, "fracture_length": at("L"),
                  "fracture_volume": at("vf"),
                  "leakoff_volume": at("v_carter") + at("v_wall")},
        events=tuple(events), meta=meta)


# =========================================================================== standard scene
def standard_lumped_scene(**overrides: Any) -> LumpedScene:
    """A textbook two-cycle XLOT in the thesis's 2000 m well (override any field by name).

    Well: 2000 m vertical, 13-3/8" casing (ID 12.715"), 5" drill pipe (ID 4.276"), 10 m of
    open hole, water-like compressibility 1/2.34 GPa (C_w ~ 67 l/MPa), mud 1.2 sg.
    Rock: sigma_h 30 MPa, sigma_H 35 MPa, p0 20 MPa, T0 3 MPa (P_b = 38 MPa), E 6 GPa,
    nu 0.25, apparent K_Ic 3 MPa m^0.5 (so the 0.15 m flaw is unstable at P_b: FBP = P_b),
    penny fracture, Carter C_L 3e-5 m/s^0.5 and a wall leak J = 2e-11 m^3/(s Pa)
    (1.2 l/min per MPa overbalance: a gentle LOP curvature and a visible post-closure
    decline).

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
