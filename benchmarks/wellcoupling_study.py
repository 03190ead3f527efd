r"""The unit-segment well-coupling study (SPEC §5, thesis 4.5; benchmarks/bench_wellcoupling.py).

The 2D simulator models a slab of the open hole of **unit height**; the real test is run in a
well whose fluid volume is hundreds of times larger. The partitioned schemes that couple the
two (:mod:`xlotkit.sim.coupling.schemes`) are studied here on a lumped stand-in for the 2D
segment (:class:`LumpedUnitSegment`) with fixed steps (:func:`run_well_coupling`), where
each scheme can be measured against the monolithic coupling at little cost; the 2D engine
runs the same schemes on the coupled model (:mod:`xlotkit.sim.coupling.partitioned`). No
engine imports this module: it is the study behind the benchmark and
docs/well-coupling.md. The schemes:

``monolithic``
    The well is storage on the wall pressure ``p_w`` inside the segment's implicit step: one
    scalar system per step, well and segment pressure equal by construction.
``wfd``
    Thesis Well Flow Decompression model (Eq. 4.8–4.18): per step, guess the segment's loss
    rate ``Q_LO*``, predict the common BHP from the well's storage, inject the Eq. 4.16 rate
    into the segment, compare, and iterate under a convergence module until the relative BHP
    error (Eq. 4.17a) is below tolerance.
``wfc``
    Thesis gain controller (Eq. 4.19–4.22): no iterations; the rate into the segment is
    updated each step by gain on the BHP mismatch (the sum of the per-step errors), with
    damping.
``wfdmod``
    ``wfd`` while pumping; during shut-in, flowback and bleed the hybrid of Eq. 4.23 (WFD
    prediction with a loss rate that follows the last step, corrected by gain on the
    mismatch), one segment solve per step plus one calibration solve when the error is too
    large (App. B.5).

Results of all four on the standard scene: docs/well-coupling.md
(``benchmarks/bench_wellcoupling.py``); on the 2D segment: docs/coupling.md, "Well coupling
on the 2D segment" (``benchmarks/bench_wellcoupling2d.py``).

SI units, gauge pressures. Everything the segment exchanges with the well is **per unit height**
of open hole (m^3/s per m, m^3/Pa per m); the driver scales with the effective height ``H``.

Scaling (thesis 4.5.1)
----------------------
The unit segment stands for the whole open hole of height ``H`` (default: the completion's
open-hole length). A surface rate ``Q`` [m^3/s] becomes ``Q/H`` per unit height; the well's
compliance becomes ``c_w = (C_total - c_s H) / H`` with ``C_total`` =
:func:`~xlotkit.sim.well.well_compliance` (which already counts the open-hole fluid) and
``c_s = c_f pi r_oh^2`` the segment's own fluid storage per unit height, so
``c_w + c_s = C_total / H`` and pressurisation runs at ``dp/dt = Q / C_total``. Segment volumes
(fracture, leak-off) are multiplied by ``H`` to give well-scale volumes; a KGD fracture of unit
height in the segment is a KGD fracture of height ``H`` in the well.

Unit segment (:class:`LumpedUnitSegment`)
-----------------------------------------
Per unit height, with wall pressure ``p``, half-length ``L`` and ``E' = E/(1-nu^2)``::

    fluid storage         c_s (p' - p)
    fracture volume       V_f(p, L) = 2 pi L^2 max(p - sigma_h, 0) / E'        (Sneddon, KGD)
    stress intensity      K_I = (p - sigma_h) sqrt(pi L)  <=  K_Ic              (LEFM)
    leak-off (Darcy)      q_L = (J_w + 4 L lambda) (p - p_0)

``J_w`` is the radial Darcy index of the hole wall (:func:`~xlotkit.formulas.wall_leak_index`
with unit length), ``lambda`` a linear leak conductance per unit face area of the four fracture
faces (two wings, two faces; the faces are taken to stay hydraulically connected after
mechanical closure, which keeps ``q_L`` continuous in ``p``). The intact segment breaks down
when ``p`` reaches ``P_b`` (Hubbert–Willis, Eq. C.11): a flaw of half-length ``L_0`` becomes a
fracture, which then grows quasi-statically at ``K_I = K_Ic`` and never shrinks. A closed
fracture (``p <= sigma_h``) holds no volume and reopens at ``sigma_h``.

One step of length ``dt`` with a prescribed inflow ``q`` (and, for ``monolithic``, the well's
storage ``c_ext`` and surface outflow ``q_out(p)`` attached) solves, backward Euler::

    R(p', L') = (c_s + c_ext)(p' - p) + V_f(p', L') - V_f + dt q_L(p', L') + dt q_out(p')
                - dt q = 0                                                       (S1)

first at ``L' = L`` (elastic; piecewise linear, solved exactly when there is no outflow) and,
if that leaves ``K_I > K_Ic``, on the growth branch ``p' = sigma_h + K_Ic/sqrt(pi L')`` for
``ln L'`` (Brent). A breakdown inside the step restarts it from the flaw, so an unstable
fracture jumps within the step to the length where (S1) holds: the breakdown pressure drop.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import brentq

from xlotkit import formulas
from xlotkit.checks import check_range as _check
from xlotkit.errors import InputError
from xlotkit.sim.coupling.schemes import (
    STRATEGIES,
    ControllerMemory,
    SegmentError,
    SegmentModel,
    SegmentState,
    SegmentStep,
    SegmentStepFailed,
    Strategy,
    WellCoupledStep,
    WellLoad,
    WellSide,
    _Ctl,
    _STEPPERS,
    solve_increasing,
    well_coupled_step,
)
from xlotkit.sim.scene.sections import CouplingOptions
from xlotkit.sim.schedule import Flowback, Pump, Schedule, ShutIn
from xlotkit.sim.well import (
    Column,
    Completion,
    PhaseDrive,
    WellDrive,
    hydrostatic_bottomhole,
    well_compliance,
)

__all__ = [
    "STRATEGIES",
    "ControllerMemory",
    "CouplingOptions",
    "LumpedUnitSegment",
    "SegmentError",
    "SegmentModel",
    "SegmentState",
    "SegmentStep",
    "SegmentStepFailed",
    "Strategy",
    "WellCoupledStep",
    "WellCouplingResult",
    "WellCouplingScene",
    "WellLoad",
    "WellSide",
    "run_well_coupling",
    "standard_well_coupling_scene",
    "well_coupled_step",
]

#: Brent tolerances of the lumped segment: 1e-7 Pa on ~3e7 Pa is a few ulp, so the residual
#: of (S1) left by the root finder is ~c * 1e-7 Pa, i.e. round-off in the volume balance.
_RTOL = 4.0 * np.finfo(float).eps


# =========================================================================== lumped segment
@dataclass(frozen=True)
class LumpedUnitSegment:
    """Lumped unit-height open-hole segment: storage + KGD LEFM fracture + Darcy leak-off.

    Implements :class:`SegmentModel`; equations (S1) and the branch logic are in the module
    docstring.

    Parameters
    ----------
    radius : float
        Open-hole radius [m].
    compressibility : float
        Fluid compressibility c_f [1/Pa].
    sigma_h : float
        Minimum horizontal stress [Pa] (fracture closure / opening pressure).
    breakdown_pressure : float
        Wall pressure at which the intact segment fractures [Pa] (Eq. C.11).
    e_prime : float
        Plane-strain modulus E/(1 - nu^2) [Pa].
    toughness : float
        K_Ic [Pa m^0.5].
    initial_flaw : float
        Half-length L_0 of the fracture created at breakdown [m].
    pore_pressure : float
        p_0 [Pa], the far pressure of the Darcy leak-off.
    wall_leak : float
        Radial Darcy index of the hole wall per unit height J_w [m^3/(s Pa) per m].
    face_leak : float
        Leak conductance per unit fracture face area lambda [m/(s Pa)].
    """

    radius: float
    compressibility: float
    sigma_h: float
    breakdown_pressure: float
    e_prime: float
    toughness: float
    initial_flaw: float
    pore_pressure: float
    wall_leak: float = 0.0
    face_leak: float = 0.0

    @property
    def storage(self) -> float:
        """``c_s = c_f pi r^2`` [m^3/Pa per m]."""
        return self.compressibility * math.pi * self.radius**2

    def initial_state(self, pressure: float) -> SegmentState:
        """Intact segment at ``pressure`` [Pa]."""
        return SegmentState(pressure=float(pressure))

    # ------------------------------------------------------------------ physics
    def fracture_volume(self, p: float, L: float) -> float:
        """``2 pi L^2 max(p - sigma_h, 0) / E'`` [m^3 per m]."""
        dp = p - self.sigma_h
        return formulas.kgd_volume(dp, L, 1.0, self.e_prime) if (dp > 0.0 and L > 0.0) else 0.0

    def critical_pressure(self, L: float) -> float:
        """Wall pressure at which ``K_I = K_Ic`` for half-length ``L`` [Pa]."""
        return self.sigma_h + formulas.kgd_critical_net_pressure(L, self.toughness)

    def leak_index(self, L: float) -> float:
        """``J_w + 4 L lambda`` [m^3/(s Pa) per m]."""
        return self.wall_leak + 4.0 * L * self.face_leak

    def _fracture_compliance(self, L: float) -> float:
        """``dV_f/dp = 2 pi L^2 / E'`` of the open fracture [m^3/Pa per m]."""
        return formulas.kgd_volume(1.0, L, 1.0, self.e_prime)

    def _compliance(self, p: float, L: float, dt: float) -> float:
        cf = self._fracture_compliance(L) if (L > 0.0 and p > self.sigma_h) else 0.0
        return self.storage + cf + dt * self.leak_index(L)

    # ------------------------------------------------------------------ step
    def step(self, state: SegmentState, dt: float, *, inflow: float | None = None,
             pressure: float | None = None, well: WellLoad | None = None) -> SegmentStep:
        """One implicit step; see :class:`SegmentModel` and Eq. (S1).

        Raises
        ------
        SegmentError
            With a prescribed ``pressure`` that would drive an open fracture beyond
            ``K_Ic`` (KGD growth under fixed pressure is unstable: prescribe the inflow).
        """
        if (inflow is None) == (pressure is None):
            raise InputError("give exactly one of inflow and pressure", key="segment.step")
        if pressure is not None:
            if well is not None:
                raise InputError("a prescribed pressure cannot carry a well load",
                                 key="segment.step")
            return self._step_pressure(state, dt, float(pressure))
        return self._step_inflow(state, dt, float(inflow), well)

    def _finish(self, state: SegmentState, dt: float, p: float, L: float, broken: bool,
                solves: int) -> SegmentStep:
        vf = self.fracture_volume(p, L) if broken else 0.0
        dv_leak = dt * self.leak_index(L) * (p - self.pore_pressure)
        vol = self.storage * (p - state.pressure) + vf - state.fracture_volume + dv_leak
        new = SegmentState(pressure=p, half_length=L, broken=broken, fracture_volume=vf,
                           leaked=state.leaked + dv_leak, injected=state.injected + vol)
        return SegmentStep(state=new, pressure=p, volume=vol, leak_volume=dv_leak,
                           solves=solves, compliance=self._compliance(p, L, dt))

    def _step_pressure(self, state: SegmentState, dt: float, p: float) -> SegmentStep:
        broken, L = state.broken, state.half_length
        if not broken and p >= self.breakdown_pressure:
            broken, L = True, self.initial_flaw
        if broken and p > self.critical_pressure(L) * (1.0 + 1e-12):
            raise SegmentError(
                f"prescribed pressure {p:.6g} Pa exceeds the propagation pressure "
                f"{self.critical_pressure(L):.6g} Pa of the fracture (L = {L:.4g} m); "
                "KGD growth at fixed pressure is unstable", key="segment.pressure",
                expected="a prescribed inflow while the fracture propagates")
        return self._finish(state, dt, p, L, broken, 1)

    def _step_inflow(self, state: SegmentState, dt: float, q: float,
                     well: WellLoad | None) -> SegmentStep:
        c_ext = 0.0 if well is None else well.storage
        out = None if well is None else well.outflow
        counter = [0]
        p0 = state.pressure
        target = dt * q

        def resid(p: float, L: float, broken: bool) -> float:
            counter[0] += 1
            vf = self.fracture_volume(p, L) if broken else 0.0
            r = ((self.storage + c_ext) * (p - p0) + vf - state.fracture_volume
                 + dt * self.leak_index(L) * (p - self.pore_pressure) - target)
            if out is not None:
                r += dt * out(p)
            return r

        def solve_elastic(L: float, broken: bool) -> float:
            if out is None:
                return self._solve_linear(state, dt, c_ext, target, L, broken, counter)
            return solve_increasing(lambda p: resid(p, L, broken), p0,
                                     self.storage + c_ext + dt * self.leak_index(L))

        broken, L = state.broken, state.half_length
        p = solve_elastic(L, broken)
        if not broken and p >= self.breakdown_pressure:
            broken, L = True, self.initial_flaw          # breakdown inside the step
            p = solve_elastic(L, True)
        if broken and p > self.critical_pressure(L):
            # Growth branch: unknown x = ln L' >= ln L with p' = p_c(L').
            def g(x: float) -> float:
                Lx = math.exp(x)
                return resid(self.critical_pressure(Lx), Lx, True)

            lo = math.log(L)
            hi = lo + 0.5
            while g(hi) <= 0.0:
                lo, hi = hi, hi + 0.5 + (hi - lo)
                if hi > lo + 50.0:
                    raise SegmentError("fracture growth has no bounded solution",
                                       key="segment.inflow")
            x = brentq(g, lo, hi, xtol=1e-15, rtol=_RTOL, maxiter=200)
            L = math.exp(x)
            p = self.critical_pressure(L)
        return self._finish(state, dt, p, L, broken, counter[0])

    def _solve_linear(self, state: SegmentState, dt: float, c_ext: float, target: float,
                      L: float, broken: bool, counter: list[int]) -> float:
        """Exact solution of (S1) without outflow: piecewise linear in ``p'`` (kink at
        ``sigma_h`` where an open fracture adds ``2 pi L^2 / E'``); one linear solve per
        piece tried."""
        p0 = state.pressure
        a = self.storage + c_ext + dt * self.leak_index(L)
        b = target + state.fracture_volume + (self.storage + c_ext) * p0 + (
            dt * self.leak_index(L) * self.pore_pressure)
        counter[0] += 1
        p = b / a                                        # fracture closed / absent
        if broken and L > 0.0 and p > self.sigma_h:
            cf = self._fracture_compliance(L)
            counter[0] += 1
            p = (b + cf * self.sigma_h) / (a + cf)       # fracture open
        return p


# =========================================================================== scene
@dataclass(frozen=True, kw_only=True)
class WellCouplingScene:
    """A well–segment coupling scene (SI, gauge pressures).

    Attributes
    ----------
    schedule : Schedule
        Test program (rates at surface).
    completion : Completion
        Well geometry; gives ``C_total`` (:func:`well_compliance`), the column, ``r_oh``.
    effective_height : float or None
        Height ``H`` the unit segment stands for [m]; None: ``completion.open_hole_length``.
    density, viscosity : float
        Fluid density at surface [kg/m^3], viscosity [Pa s].
    pipe_friction : bool
        Charge pipe friction in the surface <-> bottom-hole conversion.
    sigma_h, sigma_H, pore_pressure, tensile_strength : float
        Stresses, p_0 and T_0 [Pa]; ``P_b = 3 sigma_h - sigma_H - p_0 + T_0``.
    youngs_modulus, poisson_ratio : float
        E [Pa], nu [-].
    toughness : float
        K_Ic [Pa m^0.5].
    initial_flaw : float
        Flaw half-length at breakdown [m].
    permeability : float
        Formation permeability [m^2] for the wall's radial Darcy index (r_e = 10 r_w).
    face_leak : float
        Fracture-face leak conductance lambda [m/(s Pa)].
    dt : float
        Time step [s], shared by all strategies (cut only to meet phase durations, rate steps
        and pumped/bled volumes exactly).
    max_phase_duration : float
        Safety limit for a phase whose end condition is never met [s].
    coupling : {"monolithic", "wfd", "wfc", "wfdmod"}
        Coupling strategy of this scene (default ``monolithic``);
        :func:`run_well_coupling` may override it.
    coupling_options : CouplingOptions
        Tolerances, gains and damping of the partitioned strategies.
    """

    schedule: Schedule
    completion: Completion = field(default_factory=Completion)
    effective_height: float | None = None
    density: float = 1200.0
    viscosity: float = 0.01
    pipe_friction: bool = False
    sigma_h: float = 30e6
    sigma_H: float = 35e6
    pore_pressure: float = 20e6
    tensile_strength: float = 3e6
    youngs_modulus: float = 6e9
    poisson_ratio: float = 0.25
    toughness: float = 3e6
    initial_flaw: float = 0.15
    permeability: float = 1e-20
    face_leak: float = 2e-14
    dt: float = 1.0
    max_phase_duration: float = 3 * 3600.0
    coupling: Strategy = "monolithic"
    coupling_options: CouplingOptions = field(default_factory=CouplingOptions)

    def __post_init__(self) -> None:
        if self.coupling not in STRATEGIES:
            raise InputError(f"unknown coupling strategy {self.coupling!r}", key="coupling",
                             expected=", ".join(STRATEGIES))
        if not isinstance(self.coupling_options, CouplingOptions):
            raise InputError(f"not CouplingOptions: {self.coupling_options!r}",
                             key="coupling_options",
                             expected="a xlotkit.sim.wellcoupling.CouplingOptions")
        if not isinstance(self.schedule, Schedule):
            raise InputError(f"not a Schedule: {self.schedule!r}", key="schedule",
                             expected="a xlotkit.sim.schedule.Schedule")
        if not isinstance(self.completion, Completion):
            raise InputError(f"not a Completion: {self.completion!r}", key="completion",
                             expected="a xlotkit.sim.well.Completion")
        _check("effective_height", self.effective_height, lo=0.0, hi=1000.0, lo_open=True,
               allow_none=True)
        _check("density", self.density, lo=100.0, hi=5000.0)
        _check("viscosity", self.viscosity, lo=0.0, hi=100.0, lo_open=True)
        _check("sigma_h", self.sigma_h, lo=0.0, hi=500e6, lo_open=True)
        _check("sigma_H", self.sigma_H, lo=self.sigma_h, hi=500e6)
        _check("pore_pressure", self.pore_pressure, lo=0.0, hi=self.sigma_h, hi_open=True)
        _check("tensile_strength", self.tensile_strength, lo=0.0, hi=100e6)
        _check("youngs_modulus", self.youngs_modulus, lo=1e8, hi=500e9)
        _check("poisson_ratio", self.poisson_ratio, lo=0.0, hi=0.5, hi_open=True)
        _check("toughness", self.toughness, lo=0.0, hi=100e6, lo_open=True)
        _check("initial_flaw", self.initial_flaw, lo=0.0, hi=10.0, lo_open=True)
        _check("permeability", self.permeability, lo=0.0, hi=1e-10)
        _check("face_leak", self.face_leak, lo=0.0, hi=1e-9)
        _check("dt", self.dt, lo=1e-4, hi=600.0)
        _check("max_phase_duration", self.max_phase_duration, lo=1.0, hi=30 * 86400.0)
        if self.breakdown_pressure <= self.sigma_h:
            raise InputError("breakdown pressure 3 sigma_h - sigma_H - p0 + T0 is not above "
                             "sigma_h", key="tensile_strength",
                             expected="a breakdown pressure above sigma_h")
        if self.initial_pressure >= self.breakdown_pressure:
            raise InputError("the static well is already at the breakdown pressure",
                             key="density", expected="a lighter fluid or a stronger rock")

    @property
    def height(self) -> float:
        """Effective height H [m]."""
        return float(self.completion.open_hole_length if self.effective_height is None
                     else self.effective_height)

    @property
    def breakdown_pressure(self) -> float:
        """Hubbert–Willis P_b [Pa] (Eq. C.11)."""
        return formulas.hubbert_willis(self.sigma_h, self.sigma_H, self.pore_pressure,
                                       self.tensile_strength)

    @property
    def column(self) -> Column:
        """Fluid column surface -> open hole."""
        col = self.completion.column(density=self.density, viscosity=self.viscosity)
        return dataclasses.replace(col, friction=bool(self.pipe_friction))

    @property
    def initial_pressure(self) -> float:
        """Static bottom-hole pressure at t = 0, 0 at surface [Pa]."""
        return hydrostatic_bottomhole(self.column)

    @property
    def total_compliance(self) -> float:
        """``C_total`` of well + open hole [m^3/Pa]."""
        return well_compliance(self.completion)

    def segment(self) -> LumpedUnitSegment:
        """The lumped unit segment of this scene."""
        comp = self.completion
        return LumpedUnitSegment(
            radius=comp.open_hole_radius, compressibility=comp.compressibility,
            sigma_h=self.sigma_h, breakdown_pressure=self.breakdown_pressure,
            e_prime=formulas.plane_strain_modulus(self.youngs_modulus, self.poisson_ratio),
            toughness=self.toughness, initial_flaw=self.initial_flaw,
            pore_pressure=self.pore_pressure,
            wall_leak=formulas.wall_leak_index(self.permeability, self.viscosity, 1.0,
                                      comp.open_hole_radius) if self.permeability > 0 else 0.0,
            face_leak=self.face_leak)

    def replace(self, **changes: Any) -> WellCouplingScene:
        """A validated copy with some fields changed; unknown names raise InputError."""
        names = {f.name for f in dataclasses.fields(self)}
        for k in changes:
            if k not in names:
                raise InputError(f"unknown scene key {k!r}", key=k,
                                 expected=", ".join(sorted(names)))
        return dataclasses.replace(self, **changes)


def standard_well_coupling_scene(**overrides: Any) -> WellCouplingScene:
    """Two-cycle XLOT in the thesis's 2000 m well on a 10 m open hole (KGD, unit segment).

    Well: 2000 m vertical, 13-3/8" casing, 5" drill pipe, 10 m open hole of radius 0.15 m,
    c_f = 1/2.34 GPa (C_total ~ 67 l/MPa), 1.2 sg fluid. Rock: sigma_h 30, sigma_H 35,
    p_0 20, T_0 3 MPa (P_b = 38 MPa), E 6 GPa, nu 0.25, K_Ic 3 MPa m^0.5 (the 0.15 m flaw is
    unstable at P_b: breakdown drop), k = 1e-20 m^2, face leak 2e-14 m/(s Pa). Program:

    1. pump 500 l/min for 1.5 m^3 (pressurise, break down, propagate); shut in 120 s; flow
       back through a choke opened at 300 l/min until the BHP is 2 MPa below sigma_h;
    2. pump 500 l/min for 1.0 m^3 (reopen, propagate); flow back at 300 l/min until the
       surface pressure is below 1 MPa.
    """
    sh = float(overrides.get("sigma_h", 30e6))
    sched = Schedule((
        Pump(0.5 / 60.0, volume=1.5, name="pump"),
        ShutIn(duration=120.0, name="shut-in"),
        Flowback(initial_rate=0.3 / 60.0, pressure_below=sh - 2e6, name="flowback"),
        Pump(0.5 / 60.0, volume=1.0, name="pump"),
        Flowback(initial_rate=0.3 / 60.0, pressure_below=1e6, pressure_at="surface",
                 name="flowback"),
    ))
    kw: dict[str, Any] = {"schedule": sched}
    names = {f.name for f in dataclasses.fields(WellCouplingScene)}
    for k in overrides:
        if k not in names:
            raise InputError(f"unknown scene key {k!r}", key=k,
                             expected=", ".join(sorted(names)))
    kw.update(overrides)
    return WellCouplingScene(**kw)


# =========================================================================== result
@dataclass(frozen=True, eq=False)
class WellCouplingResult:
    """Outcome of :func:`run_well_coupling`; series are on the accepted step ends (t[0] = 0).

    Volumes and rates are well-scale (segment values times ``H``); pressures gauge [Pa].

    Attributes
    ----------
    strategy, status, message : str
        ``status`` is ``"ok"``, ``"stopped"`` (a phase hit ``max_phase_duration``) or
        ``"failed"`` (a segment step raised :class:`SegmentStepFailed`; this driver's
        fixed step cannot be cut, so the run ends there).
    t : ndarray
        Time [s].
    well_pressure, segment_pressure, surface_pressure : ndarray
        BHP from the well side, pressure of the segment, surface pressure (from the well BHP).
    pump_rate, return_rate, segment_rate : ndarray
        Surface pump rate, surface return rate, rate into the segment over the step [m^3/s].
    half_length, fracture_volume : ndarray
        Fracture half-length [m] and volume [m^3].
    pumped_volume, returned_volume, leakoff_volume, well_stored, segment_stored : ndarray
        Cumulative volumes [m^3]; ``well_stored = c_w H (p_w - p_w0)``, ``segment_stored``
        the segment fluid compression ``c_s H (p_s - p_s0)``.
    iterations, solves : ndarray of int
        Segment calls (WFD iterations) and segment solves per step (0 at t = 0).
    well_compliance : float
        Well-side storage ``c_w H`` [m^3/Pa] (cased well, without the open hole).
    phases : tuple of dict
        Per phase: cycle, kind, name, t_start, t_end, end reason.
    wall_time : float
        Wall-clock seconds of the run.
    """

    strategy: str
    status: str
    message: str
    t: np.ndarray
    well_pressure: np.ndarray
    segment_pressure: np.ndarray
    surface_pressure: np.ndarray
    pump_rate: np.ndarray
    return_rate: np.ndarray
    segment_rate: np.ndarray
    half_length: np.ndarray
    fracture_volume: np.ndarray
    pumped_volume: np.ndarray
    returned_volume: np.ndarray
    leakoff_volume: np.ndarray
    well_stored: np.ndarray
    segment_stored: np.ndarray
    iterations: np.ndarray
    solves: np.ndarray
    well_compliance: float
    phases: tuple[dict[str, Any], ...]
    wall_time: float

    @property
    def mismatch(self) -> np.ndarray:
        """BHP mismatch ``p_w - p_s`` [Pa] at every step end."""
        return self.well_pressure - self.segment_pressure

    @property
    def mismatch_max(self) -> float:
        """Largest |p_w - p_s| [Pa]."""
        return float(np.max(np.abs(self.mismatch)))

    @property
    def mismatch_rms(self) -> float:
        """RMS of p_w - p_s over the step ends [Pa]."""
        return float(np.sqrt(np.mean(self.mismatch**2)))

    @property
    def volume_error(self) -> float:
        """Largest misplaced volume ``c_w H |p_w - p_s|`` [m^3]: fluid the well still holds
        (or lacks) because the segment's pressure differs from the well's (thesis 4.5.2)."""
        return self.well_compliance * self.mismatch_max

    @property
    def balance_error(self) -> np.ndarray:
        """Volume balance residual [m^3]: pumped - returned - well stored - segment stored
        - fracture - leak-off (round-off for every strategy: each side conserves volume)."""
        return (self.pumped_volume - self.returned_volume - self.well_stored
                - self.segment_stored - self.fracture_volume - self.leakoff_volume)

    @property
    def segment_calls(self) -> int:
        """Segment steps run (the thesis's TOUGH2 runs)."""
        return int(self.iterations.sum())

    @property
    def segment_solves(self) -> int:
        """Segment residual evaluations / linear solves in total."""
        return int(self.solves.sum())

    @property
    def n_steps(self) -> int:
        """Accepted time steps."""
        return int(self.t.size - 1)


# =========================================================================== driver
class _Well:
    """Well side per unit height: storage c_w; rates and surface pressure from the drive."""

    def __init__(self, scene: WellCouplingScene, seg: SegmentModel):
        self.H = scene.height
        self.col = scene.column
        self.c_s = seg.storage
        self.c_w = scene.total_compliance / self.H - self.c_s
        if not self.c_w > 0.0:
            raise InputError("effective height leaves no well storage", key="effective_height",
                             expected="H with c_s H < C_total")
        self.c_tot = self.c_w + self.c_s
        self._head = WellDrive(self.col)
        self.drive: PhaseDrive = self._head.idle()

    def set_phase(self, phase: Any, p_bh: float, t0: float = 0.0, v_in: float = 0.0,
                  v_ret: float = 0.0) -> None:
        self.drive = self._head.begin(phase, t0=t0, p_bh=p_bh, v_in=v_in, v_ret=v_ret)

    def return_rate(self, p: float) -> float:
        """Surface returns [m^3/s] at bottom-hole pressure p."""
        return self.drive.return_rate(p)

    def outflow(self) -> Callable[[float], float] | None:
        """Per-unit-height outflow function, None when there is none."""
        if self.drive.returns:
            return lambda p: self.return_rate(p) / self.H
        return None

    def seg_store(self, p_new: float, p_old: float) -> float:
        """Fluid the segment's own borehole storage takes from ``p_old`` to ``p_new``
        [m^3 per m]: ``c_s (p_new - p_old)`` (the well side of the 2D segment uses the
        fluid's exponential density instead, :mod:`xlotkit.sim.coupling.partitioned`)."""
        return self.c_s * (p_new - p_old)

    def surface(self, p: float, q_pump: float) -> float:
        """Surface pressure [Pa] at bottom-hole pressure p and pump rate q_pump."""
        return self.drive.surface(p, q_pump)[0]

    def advance(self, p_w: float, dt: float, q_surf: float, q_seg: float,
                extra_storage: float = 0.0, p_extra: float = 0.0) -> float:
        """End BHP of the well storage equation (backward Euler, returns implicit)::

            c_w (p' - p_w) + c_x (p' - p_x) + dt q_out(p') = dt (q_surf - q_seg)

        (per unit height; ``c_x``/``p_x`` optionally add the segment's storage, as in the
        WFD prediction Eq. 4.12)."""
        out = self.outflow()
        rhs = dt * (q_surf - q_seg)
        a = self.c_w + extra_storage
        if out is None:
            return (rhs + self.c_w * p_w + extra_storage * p_extra) / a
        return solve_increasing(
            lambda p: self.c_w * (p - p_w) + extra_storage * (p - p_extra) + dt * out(p) - rhs,
            p_w, a)


def run_well_coupling(scene: WellCouplingScene, strategy: Strategy | None = None,
                      options: CouplingOptions | None = None,
                      segment: SegmentModel | None = None) -> WellCouplingResult:
    """Run the scene's schedule with the well coupled to the unit segment by ``strategy``.

    Parameters
    ----------
    scene : WellCouplingScene
    strategy : {"monolithic", "wfd", "wfc", "wfdmod"}, optional
        See the module docstring and docs/well-coupling.md; default ``scene.coupling``.
    options : CouplingOptions, optional
        Tolerances, gains and damping of the partitioned schemes; default
        ``scene.coupling_options``.
    segment : SegmentModel, optional
        The segment; default :meth:`WellCouplingScene.segment`.

    Returns
    -------
    WellCouplingResult
    """
    if strategy is None:
        strategy = scene.coupling
    if strategy not in STRATEGIES:
        raise InputError(f"unknown coupling strategy {strategy!r}", key="strategy",
                         expected=", ".join(STRATEGIES))
    opt = scene.coupling_options if options is None else options
    wall0 = _time.perf_counter()
    seg = scene.segment() if segment is None else segment
    well = _Well(scene, seg)
    H = well.H
    p_init = scene.initial_pressure
    s = seg.initial_state(p_init)
    p_w = p_init
    ctl = _Ctl(c_seg=seg.storage)

    hist: dict[str, list[float]] = {k: [] for k in (
        "t", "pw", "ps", "psurf", "qp", "qr", "qs", "L", "vf", "vin", "vret", "vleak", "it",
        "sol")}
    v_in = v_ret = 0.0
    t = 0.0

    def record(q_pump: float, q_ret: float, q_seg: float, it: int, sol: int) -> None:
        hist["t"].append(t)
        hist["pw"].append(p_w)
        hist["ps"].append(s.pressure)
        hist["psurf"].append(well.surface(p_w, q_pump))
        hist["qp"].append(q_pump)
        hist["qr"].append(q_ret)
        hist["qs"].append(q_seg)
        hist["L"].append(s.half_length)
        hist["vf"].append(s.fracture_volume * H)
        hist["vin"].append(v_in)
        hist["vret"].append(v_ret)
        hist["vleak"].append(s.leaked * H)
        hist["it"].append(it)
        hist["sol"].append(sol)

    well.set_phase(ShutIn(duration=1.0), p_w)
    record(0.0, 0.0, 0.0, 0, 0)
    phases_out: list[dict[str, Any]] = []
    status, msg = "ok", f"{strategy}: schedule completed"

    for cycle, phase in scene.schedule.expanded():
        well.set_phase(phase, p_w, t, v_in, v_ret)
        drive = well.drive
        t0 = t
        limit = phase.max_duration
        limit = scene.max_phase_duration if limit is None else min(limit,
                                                                   scene.max_phase_duration)
        breaks = sorted(phase.breakpoints())
        end = None
        while end is None:
            tau = t - t0
            dt = min(scene.dt, limit - tau)
            for b in breaks:
                if tau < b - 1e-9:
                    dt = min(dt, b - tau)
                    break
            q_pump = phase.pump_rate(tau)
            vt = phase.volume_target
            # land a volume end metered at a known rate (pumped, or bled)
            q_meter = q_pump if phase.pumps else phase.fixed_return_rate
            if vt is not None and q_meter > 0:
                dt = min(dt, (vt - drive.volume_done(v_in, v_ret)) / q_meter)
            if dt <= 1e-12:
                end = "duration" if tau >= limit - 1e-9 else "volume"
                break
            q_surf = q_pump / H
            try:
                p_w, s, q_seg_vol, it, sol = _STEPPERS[strategy](
                    well, seg, s, p_w, dt, q_surf, ctl, opt, phase.pumps)
            except SegmentStepFailed as exc:
                # fixed steps: nothing to cut; report it and keep what was computed
                status = "failed"
                msg = (f"{strategy}: segment step of {dt:g} s at t = {t:g} s in phase "
                       f"{phase.label!r} (cycle {cycle}) failed: {exc.reason}")
                end = "failed"
                break
            q_ret = well.return_rate(p_w)
            t += dt
            v_in += q_pump * dt
            v_ret += q_ret * dt
            record(q_pump, q_ret, q_seg_vol * H / dt, it, sol)
            end = _phase_end(drive, t - t0, limit, v_in, v_ret, p_w, hist["psurf"][-1])
        if end == "limit":
            status = "stopped"
            msg = (f"{strategy}: phase {phase.label!r} (cycle {cycle}) hit "
                   f"max_phase_duration without meeting its end condition")
        phases_out.append({"cycle": cycle, "kind": phase.kind, "name": phase.label,
                           "t_start": t0, "t_end": t, "end": end})
        if status != "ok":
            break

    a = {k: np.asarray(v, dtype=float) for k, v in hist.items()}
    pw, ps = a["pw"], a["ps"]
    return WellCouplingResult(
        strategy=strategy, status=status, message=msg, t=a["t"], well_pressure=pw,
        segment_pressure=ps, surface_pressure=a["psurf"], pump_rate=a["qp"],
        return_rate=a["qr"], segment_rate=a["qs"], half_length=a["L"],
        fracture_volume=a["vf"], pumped_volume=a["vin"], returned_volume=a["vret"],
        leakoff_volume=a["vleak"], well_stored=well.c_w * H * (pw - p_init),
        segment_stored=well.c_s * H * (ps - p_init),
        iterations=a["it"].astype(int), solves=a["sol"].astype(int),
        well_compliance=well.c_w * H, phases=tuple(phases_out),
        wall_time=_time.perf_counter() - wall0)


def _phase_end(drive: PhaseDrive, tau: float, limit: float, v_in: float, v_ret: float,
               p_bh: float, p_surf: float) -> str | None:
    """The end reason of the phase after a step (None: it goes on): the drive's end tests
    (a volume within 1e-12 of its target counts, the fixed steps land on it to round-off),
    then the duration or the safety limit."""
    phase = drive.phase
    vt = phase.volume_target
    for name, g in drive.end_tests().items():
        if name == "volume":
            if drive.volume_done(v_in, v_ret) >= vt * (1.0 - 1e-12):
                return name
        elif g(p_bh, p_surf, v_in, v_ret) <= 0.0:
            return name
    if tau >= limit - 1e-9:
        if phase.max_duration is not None and tau >= phase.max_duration - 1e-9:
            return "duration"
        return "limit"
    return None


