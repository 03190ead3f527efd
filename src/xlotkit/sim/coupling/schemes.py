r"""The partitioned well–segment coupling schemes (SPEC §5, thesis 4.5), for every driver.

The 2D model is the open-hole segment; the rest of the well is a separate storage. Each
step the two are coupled by one of the thesis's schemes, behind two protocols:
:class:`SegmentModel` (the segment solves its own implicit step under a prescribed inflow,
or a prescribed pressure, or with the well attached as a :class:`WellLoad`) and
:class:`WellSide` (the well's storage equation). :func:`well_coupled_step` runs one step of

``monolithic``
    the well as storage on the segment's wall pressure inside the segment's step;
``wfd``
    Well Flow Decompression (Eq. 4.8–4.18): guess the loss rate, predict the common BHP,
    inject Eq. 4.16's rate, iterate under a convergence module to the BHP tolerance;
``wfc``
    the gain controller (Eq. 4.19–4.22): no iterations, the rate into the segment follows
    the BHP mismatch, with damping;
``wfdmod``
    WFD while pumping, the hybrid of Eq. 4.23 otherwise (App. B.5).

Used by the 2D engine's partitioned coupling (:mod:`xlotkit.sim.coupling.partitioned`, on
:class:`~xlotkit.sim.coupling.segment.CoupledSegment`) and by the unit-segment study
(the unit-segment study ``benchmarks/wellcoupling_study.py``, on its lumped stand-in). Their tuning is
:class:`~xlotkit.sim.scene.CouplingOptions`. Everything is per unit height of the segment
(m^3/s per m, m^3/Pa per m), SI, gauge pressures.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np
from scipy.optimize import brentq

from xlotkit.errors import InputError, XlotkitError
from xlotkit.sim.scene.sections import CouplingOptions

__all__ = [
    "STRATEGIES",
    "ControllerMemory",
    "CouplingOptions",
    "SegmentError",
    "SegmentModel",
    "SegmentState",
    "SegmentStep",
    "SegmentStepFailed",
    "Strategy",
    "WellCoupledStep",
    "WellLoad",
    "WellSide",
    "solve_increasing",
    "well_coupled_step",
]

Strategy = Literal["monolithic", "wfd", "wfc", "wfdmod"]
STRATEGIES: tuple[str, ...] = ("monolithic", "wfd", "wfc", "wfdmod")

#: Brent tolerance on pressure [Pa]: 1e-7 Pa on ~3e7 Pa is a few ulp, so the residual of a
#: storage balance left by the root finder is ~c * 1e-7 Pa, i.e. round-off.
_XTOL_P = 1e-7
_RTOL = 4.0 * np.finfo(float).eps


@dataclass(frozen=True)
class SegmentState:
    """State of the unit segment (per unit height, SI, gauge).

    Attributes
    ----------
    pressure : float
        Wall (segment) pressure [Pa].
    half_length : float
        Fracture half-length [m]; 0 while intact.
    broken : bool
        The segment has broken down (a fracture exists, open or closed).
    fracture_volume : float
        Fracture volume [m^3 per m].
    leaked : float
        Cumulative leak-off to the formation [m^3 per m].
    injected : float
        Cumulative volume taken by the segment from the well [m^3 per m].
    """

    pressure: float
    half_length: float = 0.0
    broken: bool = False
    fracture_volume: float = 0.0
    leaked: float = 0.0
    injected: float = 0.0


@dataclass(frozen=True)
class SegmentStep:
    """Outcome of one segment step.

    Attributes
    ----------
    state : SegmentState
        The state at the end of the step.
    pressure : float
        Segment pressure at the end of the step [Pa] (= ``state.pressure``).
    volume : float
        Volume taken from the well over the step [m^3 per m]: fluid compression + fracture
        growth + leak-off. With a :class:`WellLoad` attached it is still the segment's share.
    leak_volume : float
        Leak-off over the step [m^3 per m].
    solves : int
        Residual evaluations / linear solves the step cost (the segment's work unit).
    compliance : float
        Pump-in compliance at the new state at fixed fracture size (thesis Eq. 4.11 analogue),
        ``c_s + dV_f/dp + dt dq_L/dp`` [m^3/Pa per m]; used by the controllers to scale
        gains when the secant ``volume / dp`` of the step is not usable. NaN when the
        segment computes it only on demand: then a subclass offers ``tangent()``
        (:class:`xlotkit.sim.coupling.segment.CoupledSegmentStep`).
    """

    state: SegmentState
    pressure: float
    volume: float
    leak_volume: float
    solves: int
    compliance: float


@dataclass(frozen=True)
class WellLoad:
    """The well attached to the segment's wall pressure (``monolithic`` coupling).

    Attributes
    ----------
    storage : float
        Well storage per unit height ``c_w`` [m^3/Pa per m], acting on ``p' - p``.
    outflow : callable or None
        ``q_out(p)`` [m^3/s per m], surface returns as a non-decreasing function of the
        bottom-hole pressure (choke or bleed), taken at the end of the step; None: none.
    """

    storage: float
    outflow: Callable[[float], float] | None = None


@runtime_checkable
class SegmentModel(Protocol):
    """The open-hole segment of unit height as a black box for the well coupling.

    A segment solves its own implicit step with the given boundary condition on the
    borehole: a prescribed volume rate into the borehole, or a prescribed borehole pressure,
    or (``monolithic``) a rate into a borehole that carries the well's storage and outflow
    as an extra term on ``p_w``. Implementations: :class:`LumpedUnitSegment` and the 2D
    coupled model, :class:`xlotkit.sim.coupling.segment.CoupledSegment`. A step that does
    not converge raises :class:`SegmentStepFailed` (nothing changed; a shorter step may
    succeed); a boundary condition without a solution raises :class:`SegmentError`.
    """

    @property
    def storage(self) -> float:
        """Fluid storage of the borehole itself, ``c_s`` [m^3/Pa per m]."""
        ...

    def initial_state(self, pressure: float) -> SegmentState:
        """The intact segment at wall pressure ``pressure`` [Pa]."""
        ...

    def step(self, state: SegmentState, dt: float, *, inflow: float | None = None,
             pressure: float | None = None, well: WellLoad | None = None) -> SegmentStep:
        """Advance by ``dt`` [s] with ``inflow`` [m^3/s per m] or end ``pressure`` [Pa]."""
        ...


class SegmentError(InputError):
    """A segment step that has no solution under the given boundary condition."""


class SegmentStepFailed(XlotkitError):
    """A segment step that did not converge (2D: Newton, too many cluster failures in the
    step, mass balance); the state is unchanged and a shorter step may succeed.

    Parameters
    ----------
    reason : str
        Why (the coupled stepper's ``StepResult.reason``).
    detail : object, optional
        The segment's own record of the failed attempt (2D: the ``StepResult`` and the
        work counters), kept for the caller's statistics.
    """

    def __init__(self, reason: str, detail: Any = None) -> None:
        super().__init__(f"segment step failed: {reason}")
        self.reason = reason
        self.detail = detail


def solve_increasing(f: Callable[[float], float], x0: float, slope_min: float) -> float:
    """Root of a continuous increasing ``f`` with ``f' >= slope_min > 0`` (Brent).

    Because the slope is at least ``slope_min``, the root lies between ``x0`` and
    ``x0 - f(x0) / slope_min``: two evaluations bracket it (an expanding search is kept as a
    fallback against round-off at the far end)."""
    f0 = f(x0)
    if f0 == 0.0:
        return x0
    x1 = x0 - f0 / slope_min
    d = x1 - x0
    for _ in range(200):
        f1 = f(x1)
        if f1 == 0.0:
            return x1
        if (f1 > 0.0) != (f0 > 0.0):
            lo, hi = (x0, x1) if x0 < x1 else (x1, x0)
            return brentq(f, lo, hi, xtol=_XTOL_P, rtol=_RTOL, maxiter=200)
        x0, f0 = x1, f1
        d *= 2.0
        x1 = x0 + d
    raise SegmentError("no root found", key="segment.inflow")


# =========================================================================== controller memory
@dataclass
class _Ctl:
    """Controller memory of the partitioned schemes (per unit height)."""

    q_lo: float = 0.0          # last actual loss rate of the segment (Q_LO)
    q_t2: float | None = None  # WFC: last rate into the segment
    c_seg: float = 0.0         # segment pump-in compliance for the gains (Eq. 4.11)
    c_rate: float = 0.0        # WFC: the c_seg q_t2 was set with (0: not known)
    dt_rate: float = 0.0       # WFC: the step q_t2 was set for (0: not known)

    def report(self, s: SegmentState, r: SegmentStep) -> None:
        """Calibrate the segment compliance from the step just taken, Eq. 4.11:
        ``c_seg = dV / dp`` over the step (falls back to the reported tangent when the
        pressure hardly moved or the ratio is not positive). Measured over the step, it is
        the stiff value when the step crossed fracture closure or reopening, where the
        tangent of the open fracture would overshoot by ~C_f / c_s."""
        dp = r.pressure - s.pressure
        c = r.volume / dp if abs(dp) > 1.0 else math.nan
        if not (math.isfinite(c) and c > 0.0):
            c = r.compliance
            if not (math.isfinite(c) and c > 0.0):
                # a segment whose tangent costs a solve (2D) gives it on demand only
                tangent = getattr(r, "tangent", None)
                c = tangent() if tangent is not None else math.nan
        if math.isfinite(c) and c > 0.0:
            self.c_seg = c


def _c_eff(c_w: float, c_seg: float) -> float:
    return c_w * c_seg / (c_w + c_seg)


# =========================================================================== one step, public
@dataclass(frozen=True)
class ControllerMemory:
    """What the partitioned schemes carry from one step to the next (per unit height).

    Attributes
    ----------
    loss_rate : float
        ``Q_LO`` of the last step [m^3/s per m] (WFD's first guess, WFDmod's trend).
    segment_rate : float or None
        WFC: the last rate into the segment ``Q_T2`` [m^3/s per m]; None before the first
        step (the base rate of Eq. 4.9/4.10 is used then).
    segment_compliance : float
        ``c_seg`` calibrated from the last step (Eq. 4.11) [m^3/Pa per m], which scales
        the gains.
    rate_compliance : float
        WFC: the ``c_seg`` that ``segment_rate`` was set with [m^3/Pa per m] (0: not
        known, e.g. a checkpoint written before it was kept; the carried rate is then not
        rescaled, see :func:`_step_wfc`).
    rate_step : float
        WFC: the step ``segment_rate`` was set for [s] (0: not known; the gain is then
        spread over the present step, as on fixed steps).
    """

    loss_rate: float = 0.0
    segment_rate: float | None = None
    segment_compliance: float = 0.0
    rate_compliance: float = 0.0
    rate_step: float = 0.0


@dataclass(frozen=True)
class WellCoupledStep:
    """Outcome of :func:`well_coupled_step` (per unit height).

    Attributes
    ----------
    well_pressure : float
        The well's BHP at the end of the step [Pa].
    state : object
        The segment's state at the end of the step (the kept iterate for WFD).
    volume : float
        Volume the well sent into the segment over the step [m^3 per m].
    calls, solves : int
        Segment calls and their residual evaluations / linear solves.
    memory : ControllerMemory
        Controller memory for the next step.
    """

    well_pressure: float
    state: Any
    volume: float
    calls: int
    solves: int
    memory: ControllerMemory


@runtime_checkable
class WellSide(Protocol):
    """The well of a partitioned coupling, per unit height of the segment.

    ``c_w`` [m^3/Pa per m] is the well's storage without the segment, ``c_s`` the
    segment's own borehole storage and ``c_tot = c_w + c_s``; :meth:`advance` is the
    well's implicit storage equation, :meth:`seg_store` the volume the segment's own
    borehole fluid takes between two pressures, :meth:`outflow` the surface returns as a
    function of the BHP (None while pumping or shut in).
    """

    c_w: float
    c_s: float
    c_tot: float

    def advance(self, p_w: float, dt: float, q_surf: float, q_seg: float,
                extra_storage: float = 0.0, p_extra: float = 0.0) -> float: ...

    def seg_store(self, p_new: float, p_old: float) -> float: ...

    def outflow(self) -> Callable[[float], float] | None: ...


def well_coupled_step(strategy: Strategy, well: WellSide, segment: SegmentModel, state: Any,
                      p_w: float, dt: float, q_surf: float, memory: ControllerMemory,
                      options: CouplingOptions, pumping: bool) -> WellCoupledStep:
    """One step of the well coupled to a segment by ``strategy`` (the steppers behind
    :func:`run_well_coupling`, for drivers with their own time stepping).

    Parameters
    ----------
    strategy : {"monolithic", "wfd", "wfc", "wfdmod"}
    well : WellSide
    segment : SegmentModel
    state : SegmentState-like
        The segment's state at the start of the step.
    p_w : float
        The well's BHP at the start of the step [Pa].
    dt : float
        Step [s].
    q_surf : float
        Surface pump rate per unit height [m^3/s per m] (returns are ``well.outflow()``).
    memory : ControllerMemory
    options : CouplingOptions
    pumping : bool
        The phase is a pump phase (WFDmod iterates only then).

    Returns
    -------
    WellCoupledStep

    Raises
    ------
    SegmentStepFailed
        From a segment call that did not converge; nothing has changed (the memory is
        the caller's, the states are immutable): the caller may retry with a shorter step.
    """
    if strategy not in STRATEGIES:
        raise InputError(f"unknown coupling strategy {strategy!r}", key="strategy",
                         expected=", ".join(STRATEGIES))
    ctl = _Ctl(q_lo=memory.loss_rate, q_t2=memory.segment_rate,
               c_seg=memory.segment_compliance, c_rate=memory.rate_compliance,
               dt_rate=memory.rate_step)
    p_new, s_new, vol, calls, solves = _STEPPERS[strategy](
        well, segment, state, p_w, dt, q_surf, ctl, options, pumping)
    return WellCoupledStep(p_new, s_new, vol, calls, solves,
                           ControllerMemory(ctl.q_lo, ctl.q_t2, ctl.c_seg, ctl.c_rate,
                                            ctl.dt_rate))


# --------------------------------------------------------------------------- strategies
# Each stepper returns (p_w', segment state', volume into the segment per unit height,
# segment calls, segment solves).
def _step_monolithic(well: WellSide, seg: SegmentModel, s: SegmentState, p_w: float, dt: float,
                     q_surf: float, ctl: _Ctl, opt: CouplingOptions, pumping: bool):
    r = seg.step(s, dt, inflow=q_surf, well=WellLoad(storage=well.c_w,
                                                      outflow=well.outflow()))
    return r.pressure, r.state, r.volume, 1, r.solves


def _wfd_predict(well: WellSide, s: SegmentState, p_w: float, dt: float, q_surf: float,
                 q_lo: float) -> tuple[float, float]:
    """Eq. 4.12 and 4.16: predicted BHP with loss guess ``q_lo`` and the rate into the
    segment that compresses its fluid by the same amount."""
    p_star = well.advance(p_w, dt, q_surf, q_lo, extra_storage=well.c_s, p_extra=s.pressure)
    q_t2 = q_lo + well.seg_store(p_star, s.pressure) / dt
    return p_star, q_t2


def _rel(a: float, b: float, floor: float) -> float:
    """Relative difference ``(a - b) / ((a + b)/2)`` (Eq. 4.17), guarded near zero."""
    m = 0.5 * (abs(a) + abs(b))
    return (a - b) / max(m, floor)


def _step_wfd(well: WellSide, seg: SegmentModel, s: SegmentState, p_w: float, dt: float,
              q_surf: float, ctl: _Ctl, opt: CouplingOptions, pumping: bool):
    """WFD with a convergence module (thesis 4.5.2, App. B.2/B.9, in our own form).

    The unknown is the loss-rate guess ``Q_LO*``; the BHP error ``e = BHP* - p_seg`` goes
    from positive (too little sent to the segment) to negative as ``Q_LO*`` grows, whatever
    the fracture does in between. Iteration 1 uses the last actual loss rate. If its error
    is too large, the first update is a damped calibration on the reported loss rate (the
    thesis's first iteration); later updates are secant steps on ``e``. A step that would
    move against the sign of ``e`` is replaced by an expanding step in the right direction
    (the thesis module's larger update factors while the error keeps its sign); once two
    iterates bracket the root, Illinois false position takes over (where the thesis module
    shrinks its update factor after a change of sign). After ``wfd_max_iterations``
    segment solves the iterate with the least |e| is kept (the thesis reloads that one). Converged when ``|eps_BHP|`` (Eq. 4.17a) is
    within ``wfd_tolerance`` and, on the first iteration only, ``|eps_LO|`` (Eq. 4.17b)
    within ``wfd_rate_tolerance`` (Eq. 4.18)."""
    q_scale = max(abs(q_surf), abs(ctl.q_lo), 1e-12)
    q = ctl.q_lo
    n_calls = solves = 0
    small = big = None        # iterates with e > 0 (q* too small) / e < 0 (q* too big)
    last_side = 0
    n_expand = 0
    prev = None
    best = None
    for k in range(opt.wfd_max_iterations):
        p_star, q_t2 = _wfd_predict(well, s, p_w, dt, q_surf, q)
        r = seg.step(s, dt, inflow=q_t2)
        n_calls += 1
        solves += r.solves
        q_act = q_t2 - well.seg_store(r.pressure, s.pressure) / dt
        err = p_star - r.pressure
        if best is None or abs(err) < abs(best[0]):
            best = (err, r, p_star)
        eps_bhp = _rel(p_star, r.pressure, 1.0)
        eps_lo = _rel(q_act, q, 1e-9 * q_scale)
        if abs(eps_bhp) <= opt.wfd_tolerance and (
                k > 0 or abs(eps_lo) <= opt.wfd_rate_tolerance):
            best = (err, r, p_star)
            break
        if err > 0.0:
            if last_side == 1 and big is not None:
                big = (big[0], 0.5 * big[1])
            small, last_side = (q, err), 1
        else:
            if last_side == -1 and small is not None:
                small = (small[0], 0.5 * small[1])
            big, last_side = (q, err), -1
        if small is not None and big is not None:
            (qa, ea), (qb, eb) = small, big
            q_new = qa - ea * (qb - qa) / (eb - ea)
        else:
            if prev is None:
                q_new = q + opt.wfd_calibration * (q_act - q)
            else:
                q1, e1 = prev
                q_new = q - err * (q - q1) / (err - e1) if err != e1 else math.nan
            up = err > 0.0
            if not (math.isfinite(q_new) and ((q_new > q) if up else (q_new < q))):
                dq = max(abs(err) * well.c_tot / dt, 1e-9 * q_scale) * 2.0**n_expand
                n_expand += 1
                q_new = q + dq if up else q - dq
        prev = (q, err)
        q = q_new
    assert best is not None
    _, r, p_star = best
    ctl.q_lo = (r.volume - well.seg_store(r.pressure, s.pressure)) / dt
    ctl.report(s, r)
    return p_star, r.state, r.volume, n_calls, solves


def _step_wfc(well: WellSide, seg: SegmentModel, s: SegmentState, p_w: float, dt: float,
              q_surf: float, ctl: _Ctl, opt: CouplingOptions, pumping: bool):
    """WFC gain controller with damping (Eq. 4.19–4.22; damping as in App. B.7).

    The thesis's per-step error ``BHP*_k - BHP_k`` is measured from the segment pressure at
    the start of step k, so its sum since the start is the present mismatch ``p_w - p_s``;
    the controller therefore reads (rates per unit height, normalised gain ``G``)::

        Q_T2' = Q_T2 / (1 + gamma) + G c_eff (p_w - p_s) / dt

    with ``c_eff = c_w c_seg / (c_w + c_seg)`` the series compliance of well and segment
    (``c_seg`` calibrated by Eq. 4.11, see :meth:`_Ctl.report`), which makes ``G``
    dimensionless. On a linear plant the mismatch then obeys
    ``z^2 - (1 + a - G) z + a = 0`` with ``a = 1/(1 + gamma)``: without damping (``a = 1``)
    the roots lie on the unit circle for ``0 < G < 4`` and the rate oscillates for ever
    (thesis Fig. A.6); with damping they shrink to ``|z| = sqrt(a)``, at the price of a
    steady mismatch ``gamma Q_T2 dt / ((1 + gamma) G c_eff)``. The first step uses the base
    rate of Eq. 4.9/4.10; the well then follows Eq. 4.20/4.21.

    That analysis holds for a fixed step on a fixed compliance. A driver with adaptive
    steps (the 2D engine, :mod:`xlotkit.sim.coupling.partitioned`) breaks the first, a
    crack that closes the second; two readings keep the controller what it is there:

    * **The gain is spread over the step it was planned for.** The carried ``Q_T2`` was
      set for a step ``dt_r`` (the memory's ``rate_step``); a shorter step (a cut after a
      rejected trial, a step repeated shorter, one shortened to land on a phase end or an
      event) is a part of that step, so the gain term divides by ``max(dt, dt_r)``, not by
      ``dt``. Otherwise the correction ``G c_eff (p_w - p_s)`` is made whole in however
      short a step: the rate grows as ``1/dt`` (at a 1e-4 s floor step, thousands of
      times the pump rate), a shortened step does not do less than the long one, and the
      engine's rules that cut a step to resolve an event cannot resolve anything. On
      fixed or growing steps ``max(dt, dt_r) = dt``: Eq. 4.19 as it stands.
    * **A rate set for a softer segment is scaled to the stiffer one.** The carried rate
      moved the segment by ``Q_T2 dt / c_eff`` for the ``c_seg`` it was set with (the
      memory's ``rate_compliance``); when the last step calibrated a stiffer segment (a
      crack that closed: ``c_seg`` falls from the crack's to the borehole's own storage,
      two to three orders of magnitude in 2D) the same rate would move it that many times
      further, draining the closed segment far below the well (tens of MPa per step,
      below the pore pressure). The carried rate is multiplied by
      ``min(1, c_eff(c_seg) / c_eff(c_rate))``: its pressure effect is kept. A softer
      segment (a crack that opened) keeps the rate: that only lags, and the gain term
      makes it up. With a fixed compliance the factor is 1."""
    if ctl.q_t2 is None:
        q_t2 = q_surf * well.c_s / well.c_tot                    # Eq. 4.9/4.10
    else:
        c_eff = _c_eff(well.c_w, ctl.c_seg)
        carried = ctl.q_t2
        if ctl.c_rate > 0.0:
            # keep the carried rate's pressure effect when the segment stiffened
            carried *= min(1.0, c_eff / _c_eff(well.c_w, ctl.c_rate))
        # a step shorter than the one the rate was set for gets the planned rate
        tau = max(dt, ctl.dt_rate)
        q_t2 = (carried / (1.0 + opt.wfc_damping)
                + opt.wfc_gain * c_eff * (p_w - s.pressure) / tau)
    p_new = well.advance(p_w, dt, q_surf, q_t2)                  # Eq. 4.20/4.21
    r = seg.step(s, dt, inflow=q_t2)
    ctl.q_t2 = q_t2
    ctl.c_rate = ctl.c_seg          # what the rate was set with, before recalibrating
    ctl.dt_rate = dt
    ctl.report(s, r)
    return p_new, r.state, r.volume, 1, r.solves


def _step_wfdmod(well: WellSide, seg: SegmentModel, s: SegmentState, p_w: float, dt: float,
                 q_surf: float, ctl: _Ctl, opt: CouplingOptions, pumping: bool):
    """WFD while pumping; otherwise Eq. 4.23 then Eq. 4.16 without an iteration loop::

        Q_LO* = Q_LO / (1 + gamma) + G c_eff (p_w - p_s) / dt

    ``Q_LO`` is the loss rate of the last step (:func:`_loss_trend`: the linearised trend the
    thesis relies on once the fracture no longer grows), the gain term acts on the present
    mismatch (the sum of the thesis's per-step errors, see :func:`_step_wfc`) with ``c_eff``
    built on the segment's *stiff* compliance (fluid storage and leak-off only), so that it
    cannot overshoot when the fracture closes. Damping divides by ``1 + gamma`` as App. B.4/
    B.5 do (the printed Eq. 4.23 divides by ``1 - gamma``, which would amplify the rate).
    As in App. B.5, a step whose BHP error (Eq. 4.17a) exceeds ``wfd_tolerance`` is run once
    more with the loss rate the segment just reported (a calibration solve; at most two
    segment calls per step); the one with the smaller error is kept."""
    if pumping:
        return _step_wfd(well, seg, s, p_w, dt, q_surf, ctl, opt, pumping)
    q_lo = (ctl.q_lo / (1.0 + opt.wfdmod_damping)
            + opt.wfdmod_gain * _c_eff(well.c_w, ctl.c_seg) * (p_w - s.pressure) / dt)
    p_star, q_t2 = _wfd_predict(well, s, p_w, dt, q_surf, q_lo)
    r = seg.step(s, dt, inflow=q_t2)
    calls, solves = 1, r.solves
    if abs(_rel(p_star, r.pressure, 1.0)) > opt.wfd_tolerance:
        q_act = q_t2 - well.seg_store(r.pressure, s.pressure) / dt
        p2, q2 = _wfd_predict(well, s, p_w, dt, q_surf, q_act)
        r2 = seg.step(s, dt, inflow=q2)
        calls, solves = 2, solves + r2.solves
        if abs(p2 - r2.pressure) < abs(p_star - r.pressure):
            p_star, r = p2, r2
    ctl.q_lo = _loss_trend(s, r, dt)
    ctl.report(s, r)
    return p_star, r.state, r.volume, calls, solves


def _loss_trend(s: SegmentState, r: SegmentStep, dt: float) -> float:
    """Loss rate to carry into the next step: the step's leak-off rate plus its fracture
    volume rate, the latter only while the fracture is still open at the end of the step
    (a fracture that closed in the step gives nothing more: carrying its last rate over
    would drain the stiff closed segment by ``Q dt / c_s``)."""
    q = r.leak_volume / dt
    if r.state.fracture_volume > 0.0:
        q += (r.state.fracture_volume - s.fracture_volume) / dt
    return q


_STEPPERS = {"monolithic": _step_monolithic, "wfd": _step_wfd, "wfc": _step_wfc,
             "wfdmod": _step_wfdmod}
