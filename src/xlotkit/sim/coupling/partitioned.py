r"""The 2D MDEM engine with the well coupled by the thesis's partitioned schemes (SPEC §5).

A scene with ``coupling = "wfd"``, ``"wfc"`` or ``"wfdmod"`` runs here
(:class:`PartitionedMDEMEngine`, chosen by :mod:`xlotkit.sim.run`). The 2D coupled model is
the open-hole segment (:class:`~xlotkit.sim.coupling.segment.CoupledSegment`: the borehole
with only its own storage), the rest of the well is a separate storage with its own
pressure, and each step the two are coupled by one of the schemes of
:mod:`xlotkit.sim.coupling.schemes` (WFD iterative BHP matching, Eq. 4.8–4.18; WFC gain
controller, Eq. 4.19–4.22; WFDmod, Eq. 4.23 after pumping), exactly as on the lumped unit
segment. ``monolithic`` stays :class:`~xlotkit.sim.coupling.engine.MDEMEngine`.

What is reused
--------------
:class:`PartitionedMDEMEngine` is an :class:`MDEMEngine` whose stepper is replaced by
:class:`WellCoupledStepper`, which answers the engine's calls like a
:class:`~xlotkit.sim.coupling.CoupledStepper` (``step(dt, max_new_failures=...,
continuation=...)``, ``state``, ``counters``). Everything else is the engine's: the phases
and their ends (event location), the failure-count step control (``numerics.n1``/``n2``,
``dt_min``, ``dt_max``, ``dp_max``), the rows, record, snapshots and checkpoints, and the
schedule's rate ``Q(t, p)`` (pump, choke through the surface pressure of the column, bleed),
here applied to the well's BHP. The engine sees the **well's** BHP as ``p_w`` (the gauge
pressure of the log, phase ends, the choke); the segment's borehole pressure is written as
``segment_pressure``. A segment call that fails inside the coupling loop (Newton, more than
``n2`` new failures) rejects the whole step, which the engine then cuts, as the thesis's
MDEM cut the step inside the coupling loop; it is counted and named in the outcome, and only
a failure at ``dt_min`` ends the run (as for the monolithic engine).

One rule is the partitioned engine's own (:meth:`PartitionedMDEMEngine._reject_step`): a
step that drives the segment's pressure away from the well's is rejected and repeated
shorter (``numerics.dp_max`` is the tolerance; above the floor only, as the engine's other
rules). An explicit scheme (WFC, WFDmod after pumping) sets its rate from the last step's
compliance and mismatch; when the segment changes within the step (a crack that closes
under a withdrawal, a closed crack pressed by a rate set for an open one) the rate moves it
past the well and on, tens of MPa in a step, and the next steps' Newton solves start from
pressures far off (and under the pore pressure). A shorter step sends proportionally less
(the WFC gain of a shortened step is spread over the planned one,
:func:`xlotkit.sim.coupling.schemes._step_wfc`), so repeating it shorter resolves the change as
the engine resolves a crack's opening or closing. WFD, which matches the pressures to its
tolerance, meets the rule only where it could not converge.

The well side (:class:`WellSide2D`)
-----------------------------------
Per unit height of the slab (``H = h``, the segment height: the slab is the open hole, as in
the monolithic engine), with ``c_w = C_total/h - c_s`` the whole well's compliance less the
borehole's own ``c_s`` (the engine's ``CoupledModel.well_compliance``). Its storage is the
flow model's: mass ``C rho(p)/c_f``, i.e. reference-density volume
``c_w exp(c_f (p - p_ref)) ...`` (:func:`~xlotkit.sim.coupling.segment.fluid_storage`), so
that a partitioned step that matches the pressures is the monolithic step: with
``p_w = p_s`` the well row of the monolithic system is the sum of the two sides' balances.
The step's surface rate is the schedule's ``Q(t_mid, p_w')`` at the well's end pressure
(implicit, as in the monolithic step).

Mass balance of a step: the well side closes to round-off by construction (it stores what
it receives less what it sends); the segment's own balance is the coupled stepper's
(relative error <= 1e-8 or the step is rejected). The step's reported relative error is the
larger of the two.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from xlotkit.errors import InputError, XlotkitError
from xlotkit.sim.coupling.engine import MDEMEngine
from xlotkit.sim.coupling.model import CoupledState
from xlotkit.sim.coupling.segment import (
    CoupledSegment,
    CoupledSegmentState,
    CoupledSegmentStep,
    fluid_storage,
)
from xlotkit.sim.coupling.stepper import CoupledCounters, CoupledStepper, StepResult
from xlotkit.sim.run.contract import EngineResult, series_rows
from xlotkit.sim.scene import PARTITIONED_COUPLINGS, Scene
from xlotkit.sim.well import PhaseDrive
from xlotkit.sim.coupling.schemes import (
    ControllerMemory,
    CouplingOptions,
    SegmentStepFailed,
    solve_increasing,
    well_coupled_step,
)

__all__ = [
    "PARTITIONED",
    "CouplingCounters",
    "PartitionedMDEMEngine",
    "WellCoupledState",
    "WellCoupledStepper",
    "WellSide2D",
    "check_partitioned_scene",
]

#: The scene couplings this engine runs.
PARTITIONED: tuple[str, ...] = PARTITIONED_COUPLINGS


# =========================================================================== state
@dataclass(frozen=True, eq=False)
class WellCoupledState(CoupledState):
    """The segment's coupled state plus the well side: what the engine steps.

    It is a :class:`CoupledState` of the segment (displacements, cell pressures, the
    borehole's ``flow.p_w``), except that :attr:`p_w` is the **well's** BHP, the pressure
    the engine logs, ends phases on and gives the choke. Solver code must use
    :meth:`coupled` (the plain segment state).

    Attributes
    ----------
    well_pressure : float
        The well's bottom-hole pressure [Pa].
    memory : ControllerMemory
        The partitioned scheme's memory for the next step.
    segment : CoupledSegmentState or None
        The same segment state as the segment sees it (None: rebuilt on demand).
    """

    well_pressure: float = math.nan
    memory: ControllerMemory = field(default_factory=ControllerMemory)
    segment: CoupledSegmentState | None = None

    @property
    def p_w(self) -> float:
        """The well's BHP [Pa] (the segment's borehole pressure is ``flow.p_w``)."""
        return self.well_pressure

    @property
    def segment_pressure(self) -> float:
        """The segment's borehole pressure [Pa]."""
        return self.flow.p_w

    def coupled(self) -> CoupledState:
        """The plain segment state (borehole pressure as ``p_w``)."""
        return CoupledState(self.displacement, self.flow, self.applied_load,
                            mechanics=self.mechanics, volume_offset=self.volume_offset,
                            failure_time=self.failure_time,
                            failure_volume=self.failure_volume)

    @classmethod
    def of(cls, seg: CoupledSegmentState, well_pressure: float,
           memory: ControllerMemory) -> WellCoupledState:
        """The engine's view of a segment state and the well side."""
        s = seg.coupled
        return cls(s.displacement, s.flow, s.applied_load, mechanics=s.mechanics,
                   volume_offset=s.volume_offset, failure_time=s.failure_time,
                   failure_volume=s.failure_volume, well_pressure=float(well_pressure),
                   memory=memory, segment=seg)


@dataclass
class CouplingCounters:
    """Work of the partitioned coupling (cumulative; the segment's Newton work is in the
    stepper's :class:`CoupledCounters`).

    Attributes
    ----------
    steps : int
        Accepted coupled steps.
    rejected_steps : int
        Coupled steps rejected because a segment call failed in them.
    segment_calls : int
        Segment steps run (accepted steps' iterations and the calls of rejected steps).
    failed_segment_calls : int
        Segment calls that did not converge (each rejected its coupled step).
    extra_iterations : int
        Segment calls beyond the first in accepted steps (WFD iterations, WFDmod
        calibration solves).
    tangent_solves : int
        Linear solves for the segment's tangent compliance (controller gains).
    driven_away_steps : int
        Coupled steps the engine rejected because they drove the segment's pressure away
        from the well's (:meth:`PartitionedMDEMEngine._reject_step`; counted in
        ``steps`` too: the segment call itself converged).
    """

    steps: int = 0
    rejected_steps: int = 0
    segment_calls: int = 0
    failed_segment_calls: int = 0
    extra_iterations: int = 0
    tangent_solves: int = 0
    driven_away_steps: int = 0


# =========================================================================== well side
class WellSide2D:
    """The well without the open hole, per unit height of the 2D slab (SI; see the
    module docstring). Implements :class:`xlotkit.sim.coupling.schemes.WellSide`.

    Parameters
    ----------
    c_w : float
        Well storage ``C_total/h - c_s`` [m^3/Pa per m], > 0.
    c_s : float
        The segment borehole's own storage [m^3/Pa per m].
    compressibility, reference_pressure : float
        ``c_f`` [1/Pa] and ``p_ref`` [Pa] of the fluid's density.
    """

    def __init__(self, c_w: float, c_s: float, compressibility: float,
                 reference_pressure: float) -> None:
        if not c_w > 0.0:
            raise InputError("no well storage to couple", key="effects.well_storage",
                             expected="the whole well's compliance above the open hole's")
        self.c_w = float(c_w)
        self.c_s = float(c_s)
        self.c_tot = self.c_w + self.c_s
        self.compressibility = float(compressibility)
        self.reference_pressure = float(reference_pressure)
        self._out: Callable[[float], float] | None = None

    def set_outflow(self, out: Callable[[float], float] | None) -> None:
        """Surface returns ``q_out(p)`` [m^3/s per m] for the coming step (None: none)."""
        self._out = out

    def outflow(self) -> Callable[[float], float] | None:
        """Surface returns of the step as a function of the BHP, or None."""
        return self._out

    def store(self, c: float, p_new: float, p_old: float) -> float:
        """Reference-density volume a compliance ``c`` takes from ``p_old`` to ``p_new``."""
        return fluid_storage(c, self.compressibility, self.reference_pressure, p_new, p_old)

    def seg_store(self, p_new: float, p_old: float) -> float:
        """What the segment borehole's own fluid takes from ``p_old`` to ``p_new``."""
        return self.store(self.c_s, p_new, p_old)

    def advance(self, p_w: float, dt: float, q_surf: float, q_seg: float,
                extra_storage: float = 0.0, p_extra: float = 0.0) -> float:
        """End BHP [Pa] of the well's implicit balance::

            S(c_w; p', p_w) + S(c_x; p', p_x) + dt q_out(p') = dt (q_surf - q_seg)

        with ``S`` the fluid storage (:meth:`store`) and the optional extra storage ``c_x``
        at ``p_x`` (the segment's own, for the WFD prediction Eq. 4.12)."""
        rhs = dt * (q_surf - q_seg)
        cf, pr = self.compressibility, self.reference_pressure
        cx = float(extra_storage)
        a = self.c_w + cx
        out = self._out
        if out is None:
            # closed form: c_w e^{cf(p' - p_w)} + c_x e^{cf(p' - p_x)} ... (log of the sum)
            if cf == 0.0:
                return p_w + (rhs + cx * (p_extra - p_w)) / a
            y = (rhs * cf / math.exp(cf * (p_w - pr)) + cx * math.expm1(cf * (p_extra - p_w))) / a
            if not y > -1.0:
                raise XlotkitError(f"the well cannot deliver {-rhs:.6g} m^3 per m: more "
                                   "than its fluid mass")
            return p_w + math.log1p(y) / cf
        slope = a * math.exp(cf * (min(p_w, p_extra if cx else p_w) - pr))
        return solve_increasing(
            lambda p: self.store(self.c_w, p, p_w) + self.store(cx, p, p_extra)
            + dt * out(p) - rhs, p_w, slope)


# =========================================================================== stepper
RateFunction = Callable[[float, float], Any]


class WellCoupledStepper:
    """One partitioned well–segment step at a time, with the call signature of
    :class:`~xlotkit.sim.coupling.CoupledStepper` that :class:`MDEMEngine` uses.

    Parameters
    ----------
    segment : CoupledSegment
    well : WellSide2D
    strategy : {"wfd", "wfc", "wfdmod"}
    options : CouplingOptions
    state : WellCoupledState
        Start.
    rate : callable ``(t, p_w) -> Q`` or ``-> (Q, dQ/dp_w)``
        The schedule's net surface rate into the well [m^3/s at the reference density,
        whole slab] as a function of time and the well's BHP (the engine's well rate).
    drive : callable ``() -> PhaseDrive``
        The phase in force (:class:`xlotkit.sim.well.PhaseDrive`): while it pumps the rate
        is the well's inflow, while it returns (choke or bleed) the rate is its outflow.

    Attributes
    ----------
    state : WellCoupledState
        Last accepted state (setting a plain :class:`CoupledState` wraps it with the
        well at the segment's pressure and a fresh controller memory).
    counters : CoupledCounters
        The segment's Newton work over all calls (accepted, iterated and failed).
    coupling : CouplingCounters
    history : list of StepResult
        Accepted and rejected coupled steps, in order.
    call_log : list of tuple
        Per coupled step (accepted or rejected), ``(t, dt, segment calls, accepted,
        p_w', p_s')`` (diagnostics of this session; not checkpointed).
    """

    def __init__(self, segment: CoupledSegment, well: WellSide2D, strategy: str,
                 options: CouplingOptions, state: WellCoupledState, rate: RateFunction,
                 drive: Callable[[], PhaseDrive]) -> None:
        if strategy not in PARTITIONED:
            raise InputError(f"unknown partitioned coupling {strategy!r}", key="coupling",
                             expected=", ".join(PARTITIONED))
        self.segment = segment
        self.well = well
        self.strategy = strategy
        self.options = options
        self.rate = rate
        self.drive = drive
        self.counters = CoupledCounters()
        self.coupling = CouplingCounters()
        self.history: list[StepResult] = []
        self.call_log: list[tuple] = []
        self._state = state

    # the adaptive rules of a trial (failure limit of a running crack, continuation and
    # jumps at the floor) only need ``step`` and ``state.n_failed``, which this stepper
    # has with the same meaning
    attempt = CoupledStepper.attempt

    def memory(self) -> dict[str, np.ndarray]:
        """What a checkpoint keeps beyond the state: nothing (every segment step starts a
        Newton of its own, with no predictor or solver memory carried between steps; the
        controller's memory is part of :class:`WellCoupledState`)."""
        return {}

    def restore_memory(self, memory: Mapping[str, np.ndarray]) -> None:
        """Take back :meth:`memory`: a checkpoint of this stepper holds none."""
        if memory:
            raise InputError("the checkpoint holds a monolithic stepper's memory "
                             f"({', '.join(sorted(memory))[:80]}), not a partitioned run's",
                             key="checkpoint", expected="a checkpoint of the same coupling")

    @property
    def state(self) -> WellCoupledState:
        return self._state

    @state.setter
    def state(self, st: CoupledState) -> None:
        if not isinstance(st, WellCoupledState):
            seg = self.segment.wrap(st)
            st = WellCoupledState.of(seg, st.p_w,
                                     ControllerMemory(segment_compliance=self.segment.storage))
        self._state = st

    def segment_state(self, st: WellCoupledState) -> CoupledSegmentState:
        """The segment's view of an engine state."""
        return st.segment if st.segment is not None else self.segment.wrap(st.coupled())

    def _q(self, t: float, p: float) -> float:
        q = self.rate(t, p)
        return float(q if np.ndim(q) == 0 else q[0])

    def _add_work(self, c: CoupledCounters | None) -> None:
        if c is None:
            return
        k = self.counters
        k.newton_iterations += c.newton_iterations
        k.linear_solves += c.linear_solves
        k.residual_evaluations += c.residual_evaluations
        k.failure_rounds += c.failure_rounds
        k.linear_solve_time += c.linear_solve_time

    def step(self, dt: float, max_new_failures: int | None = None,
             max_dp_w: float | None = None, continuation: bool = False) -> StepResult:
        """One coupled step of ``dt`` [s] (see :meth:`CoupledStepper.step` for the
        arguments; each segment call of the step gets ``max_new_failures`` and
        ``continuation``).

        ``newton_iterations`` and ``linear_solves`` of the returned result are those of
        the kept segment call (so that the engine's step-growth rule sees what one
        segment step cost, as in the monolithic run); the work of all calls is in
        :attr:`counters` and :attr:`coupling`.
        """
        old = self._state
        h = self.segment.height
        t_mid = old.t + 0.5 * dt
        drive = self.drive()
        pumping = drive.pumps
        q_surf = self._q(t_mid, old.well_pressure) / h if pumping else 0.0
        if drive.returns:
            self.well.set_outflow(lambda p: -self._q(t_mid, p) / h)
        else:
            self.well.set_outflow(None)
        calls: list[CoupledSegmentStep] = []
        seg = self.segment
        tangents0 = seg.tangent_solves

        class _Bound:
            """The segment with this step's failure limit and continuation."""

            storage = seg.storage

            @staticmethod
            def step(s, dt_, **kw):
                r = seg.step(s, dt_, max_new_failures=max_new_failures,
                             continuation=continuation, **kw)
                calls.append(r)
                return r

        try:
            out = well_coupled_step(self.strategy, self.well, _Bound, self.segment_state(old),
                                    old.well_pressure, dt, q_surf, old.memory, self.options,
                                    pumping)
        except SegmentStepFailed as exc:
            for c in calls:
                self._add_work(c.counters)
            r_f, c_f = exc.detail if isinstance(exc.detail, tuple) else (None, None)
            self._add_work(c_f)
            self.coupling.tangent_solves += seg.tangent_solves - tangents0
            self.coupling.segment_calls += len(calls) + 1
            self.coupling.failed_segment_calls += 1
            self.coupling.rejected_steps += 1
            self.counters.failed_steps += 1
            res = StepResult(False, f"{self.strategy} segment call {len(calls) + 1}: "
                             f"{exc.reason}",
                             0 if r_f is None else r_f.newton_iterations,
                             0 if r_f is None else r_f.linear_solves, dt, old.t,
                             new_failures=0 if r_f is None else r_f.new_failures,
                             n_failed=old.n_failed)
            self.history.append(res)
            self.call_log.append((old.t, dt, len(calls) + 1, False, math.nan, math.nan))
            return res
        kept = next(c for c in calls if c.state is out.state)
        for c in calls:
            self._add_work(c.counters)
        self.coupling.tangent_solves += seg.tangent_solves - tangents0
        self.coupling.segment_calls += len(calls)
        self.coupling.extra_iterations += len(calls) - 1
        self.coupling.steps += 1
        r = kept.result
        new = WellCoupledState.of(out.state, out.well_pressure, out.memory)
        # whole-system balance of the step [kg]: surface net injection against the well's
        # storage, the segment's storage and its boundary outflow
        rho0 = seg.rho0
        q_net = q_surf * h if pumping else self._q(t_mid, out.well_pressure)
        injected = rho0 * q_net * dt
        well_stored = rho0 * h * self.well.store(self.well.c_w, out.well_pressure,
                                                 old.well_pressure)
        stored = well_stored + r.stored_mass_change
        err = injected - stored - r.outflow_mass
        # the well side alone: what came from surface = what it stored + what it sent;
        # relative to the step's exchange, or (when nothing moves, a shut-in) to the
        # round-off of the well's stored mass, 16 eps C_w rho |p_w|, counted as 1e-9 as
        # in the coupled stepper's balance
        well_err = abs(injected - well_stored - rho0 * h * out.volume)
        floor = 16.0 * np.finfo(float).eps * rho0 * h * self.well.c_w * max(
            abs(out.well_pressure), abs(old.well_pressure))
        scale = max(abs(injected) + abs(well_stored) + rho0 * h * abs(out.volume),
                    1e9 * floor, 1e-300)
        rel_well = well_err / scale
        dpw = out.well_pressure - old.well_pressure
        res = StepResult(True, r.reason, r.newton_iterations, r.linear_solves, dt, new.t,
                         max_dp=max(r.max_dp, abs(dpw)), injected_mass=injected,
                         outflow_mass=r.outflow_mass, stored_mass_change=stored,
                         mass_balance_error=err,
                         relative_mass_balance_error=max(r.relative_mass_balance_error,
                                                         rel_well),
                         force_residual=r.force_residual, new_failures=r.new_failures,
                         failure_rounds=r.failure_rounds, dp_w=dpw, n_failed=new.n_failed,
                         continuation_levels=r.continuation_levels,
                         # before a failure round the segment's borehole pressure moves
                         # with the well's (the coupling's tolerance): its smooth part
                         dp_w_smooth=dpw if r.new_failures == 0 else r.dp_w_smooth)
        self.counters.steps += 1
        self.counters.failed_clusters += r.new_failures
        self.history.append(res)
        self.call_log.append((old.t, dt, len(calls), True, new.well_pressure,
                              new.segment_pressure))
        self._state = new
        return res


# =========================================================================== scene checks
def check_partitioned_scene(scene: Scene) -> None:
    """Refuse a scene this engine cannot run, naming the key (the scene itself has
    already checked that there is a well storage to couple to, ``Scene._check_partitioned``).
    """
    if scene.coupling not in PARTITIONED:
        raise InputError(f"coupling {scene.coupling!r} is not a partitioned scheme",
                         key="coupling", file=scene.source_file,
                         expected=", ".join(repr(c) for c in PARTITIONED)
                         + " (monolithic runs on MDEMEngine)")
    if scene.resolved_model != "mdem":
        raise InputError(f"coupling {scene.coupling!r} couples the 2D model",
                         key="model", file=scene.source_file, expected="'mdem' or 'auto'")


# =========================================================================== engine
class PartitionedMDEMEngine(MDEMEngine):
    """:class:`MDEMEngine` with the well coupled by ``scene.coupling`` (``wfd``, ``wfc`` or
    ``wfdmod``) instead of monolithically; same protocol and outputs, plus the column
    ``segment_pressure`` and coupling statistics in the truth.

    Parameters
    ----------
    scene : Scene
        ``coupling`` one of :data:`PARTITIONED` (see :func:`check_partitioned_scene`).
    callback : callable ``(engine) -> None``, optional
    options : CouplingOptions, optional
        Tolerances, gains and damping; default from the scene's ``[well_coupling]``.
    """

    def __init__(self, scene: Scene, callback=None,
                 options: CouplingOptions | None = None) -> None:
        if not isinstance(scene, Scene):
            raise InputError(f"not a Scene: {scene!r}", key="scene")
        check_partitioned_scene(scene)
        # the base class runs monolithic scenes only; everything but the stepper is shared
        super().__init__(scene.as_monolithic(), callback)
        self.scene = scene
        self.strategy = scene.coupling
        self.options = scene.well_coupling.options() if options is None else options
        if not isinstance(self.options, CouplingOptions):
            raise InputError(f"not CouplingOptions: {self.options!r}", key="options")

    def start(self) -> None:
        """The in-situ state; the well and the segment at the mud column."""
        self._seg_rows: list[float] = []
        super().start()
        plain = self.stepper.state
        cm = self.cm
        # every failure round of the segment converged in full (round_rtol = 0): the
        # schemes iterate the segment's step under changing inflows and need its response
        # to be a smooth function of the inflow; a round decided at a loose iterate sets
        # the failed clusters' contact references at a point that depends on the Newton
        # path (WFD then missed its 1e-5 tolerance by 2.9e-3 at a failure step,
        # test_wfd_matches_to_its_tolerance_every_step)
        seg = CoupledSegment(cm, dataclasses.replace(self.control, round_rtol=0.0))
        fl = cm.flow.fluid
        well = WellSide2D(cm.well_compliance, seg.storage, fl.compressibility,
                          fl.reference_pressure)
        s0 = seg.wrap(plain)
        mem = ControllerMemory(segment_compliance=seg.storage)
        self.stepper = WellCoupledStepper(
            seg, well, self.strategy, self.options, WellCoupledState.of(s0, plain.p_w, mem),
            rate=self._well_rate, drive=lambda: self._drive)

    def _reject_step(self, old: CoupledState, new: CoupledState) -> str | None:
        """The coupling rule: reject a step that drove the segment away from the well.

        With ``e = p_w - p_s`` (well BHP less the segment's borehole pressure) at the start
        (``e0``) and end (``e1``) of the step, ``dp_s`` the segment's pressure change and
        ``V`` the volume the well sent it, the step is rejected when all of

        * ``|e1| > max(|e0|, numerics.dp_max)``: the mismatch grew, beyond the largest
          pressure change a step may make;
        * ``dp_s e1 < 0``: the segment's pressure moved away from the well's (down and
          ends below it, or up and ends above it);
        * ``V dp_s > 0``: it moved the way the coupling's volume pushed it. A segment that
          breaks down drops while it is being filled: that is the model's answer to the
          rate, the crack's, not the coupling's overshoot, and a shorter step would not
          make it smaller.

        Failed clusters do not exempt a step, unlike the engine's pressure-change rule: a
        drained borehole fails clusters around it, which must not let the drain through.

        Parameters
        ----------
        old, new : WellCoupledState
            The states before and after the step.

        Returns
        -------
        str or None
            ``"segment driven away from the well"``, or None to keep the step.
        """
        stp = self.stepper
        e0 = old.p_w - float(old.segment_pressure)
        e1 = new.p_w - float(new.segment_pressure)
        dps = float(new.segment_pressure) - float(old.segment_pressure)
        vol = stp.segment_state(new).injected - stp.segment_state(old).injected
        if (abs(e1) > max(abs(e0), float(self.scene.numerics.dp_max)) and dps * e1 < 0.0
                and vol * dps > 0.0):
            stp.coupling.driven_away_steps += 1
            return "segment driven away from the well"
        return None

    def _push_row(self, st: CoupledState, *, q: float, mb: float) -> None:
        super()._push_row(st, q=q, mb=mb)
        self._seg_rows.append(float(st.flow.p_w))

    def rows(self) -> dict[str, np.ndarray]:
        """The engine's rows plus ``segment_pressure`` (``bottomhole_pressure`` and
        ``well_pressure`` are the well's BHP)."""
        return series_rows({**super().rows(), "segment_pressure": self._seg_rows})

    def state(self) -> dict[str, Any]:
        """The engine's checkpoint plus the well side and the coupling's memory."""
        out = super().state()
        st = self.stepper.state
        m = st.memory
        seg = self.stepper.segment_state(st)
        out["wc.segment_pressure"] = np.asarray(self._seg_rows, dtype=float)
        out["wc.json"] = json.dumps({
            "well_pressure": st.well_pressure, "loss_rate": m.loss_rate,
            "segment_rate": m.segment_rate, "segment_compliance": m.segment_compliance,
            "rate_compliance": m.rate_compliance, "rate_step": m.rate_step,
            "leaked": seg.leaked, "injected": seg.injected,
            "boundary_outflow": seg.boundary_outflow,
            "coupling": dataclasses.asdict(self.stepper.coupling)})
        return out

    def restore(self, state: Mapping[str, Any]) -> None:
        """Continue from a :meth:`state` dict."""
        try:
            raw = state["wc.json"]
            w = json.loads(str(raw.item() if isinstance(raw, np.ndarray) else raw))
            seg_rows = np.asarray(state["wc.segment_pressure"], dtype=float).tolist()
        except (KeyError, ValueError, TypeError) as exc:
            raise InputError(f"not a partitioned 2D-engine checkpoint ({exc})",
                             key="checkpoint",
                             expected="a checkpoint written by PartitionedMDEMEngine") from None
        super().restore(state)
        stp = self.stepper
        plain = stp.state.coupled()
        seg = stp.segment.wrap(plain, leaked=w["leaked"], injected=w["injected"],
                               boundary_outflow=w["boundary_outflow"])
        # rate_compliance / rate_step: 0 (not known) in checkpoints written before they
        # were kept
        mem = ControllerMemory(w["loss_rate"], w["segment_rate"], w["segment_compliance"],
                               w.get("rate_compliance", 0.0), w.get("rate_step", 0.0))
        stp.state = WellCoupledState.of(seg, w["well_pressure"], mem)
        stp.coupling = CouplingCounters(**w["coupling"])
        self._seg_rows = seg_rows

    def result(self) -> EngineResult:
        """The engine's result; the record gets a ``segment_pressure`` channel and the
        truth the coupling's statistics (``coupling``: strategy, options, counters,
        ``mismatch_max``/``mismatch_rms`` of ``p_w - p_s`` over the rows [Pa] and
        ``volume_error`` = whole-well storage times ``mismatch_max`` [m^3])."""
        res = super().result()
        rows = self.rows()
        mis = rows["well_pressure"] - rows["segment_pressure"]
        rec = res.record
        seg_p = np.interp(rec.t, rows["t"], rows["segment_pressure"])
        rec = rec.replace(channels={**rec.channels, "segment_pressure": seg_p},
                          meta={**rec.meta, "coupling": self.strategy})
        c_w = self.stepper.well.c_w * self.stepper.segment.height
        truth = dict(res.truth)
        truth["coupling"] = {
            "strategy": self.strategy, "options": dataclasses.asdict(self.options),
            **dataclasses.asdict(self.stepper.coupling),
            "mismatch_max": float(np.max(np.abs(mis))),
            "mismatch_rms": float(np.sqrt(np.mean(mis**2))),
            "volume_error": float(c_w * np.max(np.abs(mis))),
            "well_compliance_without_segment": float(c_w)}
        msg = (f"{self.strategy}: {res.message}; {self.stepper.coupling.segment_calls} "
               f"segment calls ({self.stepper.coupling.failed_segment_calls} failed), "
               f"max |p_w - p_s| {truth['coupling']['mismatch_max'] / 1e6:.3g} MPa")
        return dataclasses.replace(res, record=rec, truth=truth, message=msg)
