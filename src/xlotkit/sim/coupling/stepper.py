"""Implicit monolithic steps with cluster failure, adaptive time stepping and runs.

One :meth:`CoupledStepper.step` solves the (u, p, p_w) system by a semi-smooth Newton
(the contact statuses open/stick/slip of failed clusters are re-evaluated at every iterate;
contacts that keep switching are held on one branch of their law and the branch is settled
by an active-set update once the rest has converged), then checks every intact cluster with
:meth:`MechanicsModel.failure_margins`; overstressed clusters fail (most overstressed first,
at most ``failures_per_round`` per round) and the *same* step is solved again, until no
cluster is overstressed. The mass balance of the converged step is checked. A step that
fails (Newton, too many new failures, too large a well-pressure change, mass balance) leaves
the state unchanged and says why; :meth:`CoupledStepper.run` adapts the step (thesis 4.5.2:
cut when more than ``N2`` clusters fail in a step, grow when fewer than ``N1`` fail, plus
Newton-iteration and pressure-change rules, a floor and a ceiling; while the crack runs
into a falling well pressure the failure limit follows the crack size; at the floor a step
is solved by continuation in its length and, if that fails, stepped over by a longer one).
See docs/coupling.md, "Breakdown into a large well storage".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from xlotkit.errors import InputError
from xlotkit.sim.coupling.linear import LinearSolver
from xlotkit.sim.coupling.model import CoupledModel, CoupledResidual, CoupledState, Structure
from xlotkit.sim.coupling.newton import newton, scaled_norms
from xlotkit.sim.mechanics import FAILED_SHEAR, FAILED_TENSILE, INTACT

#: Largest ratio of the step to the last one the predictor extrapolates over.
PREDICTOR_MAX_RATIO = 2.0

__all__ = [
    "CoupledControl",
    "CoupledCounters",
    "CoupledRunResult",
    "CoupledStepper",
    "StepResult",
    "TimeStepControl",
]


@dataclass(frozen=True)
class CoupledControl:
    """Newton and failure settings of one coupled step.

    Attributes
    ----------
    max_newton : int
        Newton iterations per solve (one solve per failure round).
    force_rtol : float
        ``max |R_u| <= force_rtol * force_scale``.
    mass_rtol : float
        ``sum |R_f| <= mass_rtol * mass_scale`` (mass rates).
    stagnation_rtol : float
        Mass residual accepted when Newton stagnates at round-off.
    mass_balance_tol : float
        A converged step whose relative mass-balance error exceeds this is rejected.
    line_search_after : int
        Newton iterations (since the last change of the held contact branches or of the
        Jacobian) after which a backtracking line search on the scaled residual norm is
        used (only with the full Jacobian: a lagged one gives no descent direction).
    chatter_flips : int
        Status changes after which a contact counts as chattering.
    chatter : str
        What is done with a chattering contact: ``"freeze"`` (default) holds it on its
        present branch of the contact law (open, stick or slip with a fixed sign: the law
        is linear there) until the rest has converged, then checks the branch against the
        exact law and moves the contacts on a wrong branch, one at a time in a fixed order
        (all at once when more than two are wrong), never returning to a branch set
        already tried; the step converges only on the exact law. ``"soft"`` (the former
        behaviour) linearises it with its stick stiffness after ``line_search_after``
        iterations.
    check_failure : bool
        Apply the failure criteria after each converged solve.
    failures_per_round : int
        Most overstressed clusters failed per round before re-solving.
    max_failure_rounds : int
        Failure rounds per step before the step is rejected.
    round_rtol, round_margin : float
        Intermediate failure rounds: a solve of a step whose iterate is within
        ``round_rtol`` of convergence (``max |R_u| <= round_rtol * force_scale`` and
        ``sum |R_f| <= round_rtol * mass_scale``) checks the failure criteria there; when
        clusters are overstressed and none is a close call (every intact cluster's
        severity, its margin over its strength, at least ``round_margin`` away from 0,
        and the clusters failed in the round ``round_margin`` more severe than the first
        one left), they fail from that iterate and the step is solved again, without
        converging the round in full. A round with a close call is converged in full and
        checked there; one with no cluster within ``round_margin`` of failing is
        converged in full and not checked again (none fails at the converged iterate
        either, by the same error bound). The step's last round is always converged in
        full. ``round_rtol = 0``: every round converged in full and checked there.
        On the standard scene the severities at the first iterate within 1e-2 differ
        from the converged ones by at most 1.5e-2 of the strength (median 2e-5; 315
        solves, none with another set of candidates), hence the margin 0.05; at 0.1 they
        differed by up to 9 (a crack-tip toughness margin before the contacts settled),
        which no margin covers. The default cuts the standard scene from 5.80 to 5.2
        Newton iterations per step with the same FBP and sigma_h to 1e-8
        (docs/benchmarks.md, issue 20). The failed clusters' contact references are set
        at the iterate they fail at, so the step's result depends on the Newton path to
        ~``round_rtol`` of the increment there; the partitioned engine's segment, whose
        response to the inflow its schemes iterate, runs with 0.
    lagged_permeability_rtol : float
        While the mass residual is above this fraction of the mass scale, the Jacobian
        leaves out the aperture dependence of the crack permeability (Picard on ``k``);
        below it the full Jacobian is used. ``0`` always lags, ``1`` never (see docs:
        Newton started from a freshly failed, open but unfilled cluster follows the
        ``w -> 0`` root of the cubic-law flux otherwise). With ``0 < rtol < 1`` Picard is
        also left, for the rest of the solve, once it has stopped converging (the mass
        residual not halved over three iterations, from the sixth on). The default 0.03
        leaves Picard once the contact statuses have settled and the fill of the crack
        is under way (a few per cent of the step's mass); at 1e-3 it took one more
        Picard iteration in most cracked solves (standard scene: 6.6 Newton iterations
        per step at 1e-3, 5.5 at 0.03, 5.7-6.0 between 0.01 and 0.3, the same FBP and
        sigma_h; docs/benchmarks.md, issue 20).
    stall_iterations : int
        A solve is abandoned (``"newton: stalled"``) when, at least this many iterations
        after the held branches last changed, none of the last half of them has brought
        the scaled residual norm below half its value before them: a local minimum of the
        residual norm (a turning point of the step's equations), which the time step, not
        more iterations, has to get past. ``0``: only ``max_newton``.
    continuation_levels, continuation_cut, continuation_newton :
        Continuation in the step length (used by :meth:`CoupledStepper.step` with
        ``continuation=True``, which :meth:`CoupledStepper.run` does at the floor): when
        the solve of a step of ``dt`` fails, the same equations (backward Euler from the
        same state) are solved for a shorter ``h`` (``h_ok + continuation_cut (h -
        h_ok)``, ``h_ok`` the longest one solved) and then for rising ``h`` (each
        increment twice the last, from the secant extrapolation of the last two
        solutions), with the failure rounds at every level, up to ``dt``; the result is
        the step of ``dt``. At most ``continuation_levels`` back-offs, each solve at most
        ``continuation_newton`` iterations (the last one ``max_newton``).
    nonfinite_backoffs : int
        A Newton update whose residual is not finite (e.g. ``rho(p)`` overflowing at a
        wild pressure) is shortened by a factor 4 up to this many times before the solve
        fails with ``"newton: non-finite"``.
    contact_gap_rtol : float
        Gap tolerance of the contact law, as a fraction of the model's residual aperture
        ``w_res``: a solve converged with contacts held on branches of their law is
        accepted when every contact on a wrong branch misses the exact law's switch point
        by at most ``contact_gap_rtol * w_res`` (:func:`~xlotkit.sim.coupling.newton.branch_violation`:
        overlap of a contact held open, opening of one held closed, shear displacement
        past or short of the friction limit). A contact whose exact solution lies at the
        corner of its law (zero force and zero gap) can have no solution on either
        branch next to it (the piecewise-linear system folds there); holding it closed
        gives a small opening, holding it open a small overlap, and moving it cycles. The
        tolerance accepts the closure point to within a fraction of the closed crack's
        hydraulic aperture; the hydraulic aperture itself is the geometric gap whatever
        the branch, so the flow is unaffected. ``0``: the exact law only.
    fold_factors : tuple of float
        When a solve fails, the same structure is solved for steps ``k h`` (``k`` in
        turn) from the same start and, once one converges, the step of ``h`` again from
        that solution (:meth:`CoupledStepper._fold_predictor`: the filled branch of a
        crack cell beyond a fold of the step's equations). ``()``: off.
    crack_speed : float
        Largest crack-tip speed [m/s] (a quasi-static model has no inertia to bound it;
        a real crack runs at most at the Rayleigh-wave speed). Within one step of ``h``
        the clusters that fail in a chain from this step's failures reach no farther
        than ``crack_speed h`` (plus the cluster's own size) from the damage at the
        step's start (failed clusters and clusters at the hole wall); overstressed
        clusters beyond are left for the next step (``StepResult.deferred_failures``).
        ``inf``: no limit (every overstressed cluster fails in the step).
    """

    max_newton: int = 60
    force_rtol: float = 1e-10
    mass_rtol: float = 1e-11
    stagnation_rtol: float = 1e-8
    mass_balance_tol: float = 1e-8
    line_search_after: int = 8
    chatter_flips: int = 3
    check_failure: bool = True
    failures_per_round: int = 4
    max_failure_rounds: int = 200
    round_rtol: float = 1e-2
    round_margin: float = 0.05
    lagged_permeability_rtol: float = 0.03
    chatter: str = "freeze"
    stall_iterations: int = 12
    continuation_levels: int = 12
    continuation_cut: float = 0.25
    continuation_newton: int = 25
    nonfinite_backoffs: int = 8
    contact_gap_rtol: float = 0.25
    fold_factors: tuple = (4.0, 16.0)
    crack_speed: float = math.inf

    def __post_init__(self) -> None:
        for k in ("max_newton", "failures_per_round", "max_failure_rounds", "chatter_flips",
                  "continuation_newton"):
            if int(getattr(self, k)) < 1:
                raise InputError("must be >= 1", key=f"coupling.{k}")
        for k in ("line_search_after", "stall_iterations", "continuation_levels",
                  "nonfinite_backoffs"):
            if int(getattr(self, k)) < 0:
                raise InputError("must be >= 0", key=f"coupling.{k}")
        if self.chatter not in ("freeze", "soft"):
            raise InputError(f"must be 'freeze' or 'soft', got {self.chatter!r}",
                             key="coupling.chatter")
        if not self.crack_speed > 0:
            raise InputError("must be > 0", key="coupling.crack_speed")
        if not all(isinstance(k, (int, float)) and k > 1 for k in self.fold_factors):
            raise InputError("must be numbers > 1", key="coupling.fold_factors")
        for k in ("round_rtol", "round_margin"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and 0 <= v < 1):
                raise InputError(f"must be in [0, 1), got {v!r}", key=f"coupling.{k}")
        if not (math.isfinite(self.contact_gap_rtol) and self.contact_gap_rtol >= 0):
            raise InputError("must be >= 0", key="coupling.contact_gap_rtol")
        if not 0 < self.continuation_cut < 1:
            raise InputError("must be in (0, 1)", key="coupling.continuation_cut")
        for k in ("force_rtol", "mass_rtol", "stagnation_rtol", "mass_balance_tol"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and 0 < v < 1):
                raise InputError(f"must be in (0, 1), got {v!r}", key=f"coupling.{k}")


@dataclass(frozen=True)
class TimeStepControl:
    """Adaptive time stepping of :meth:`CoupledStepper.run`.

    Attributes
    ----------
    dt_initial : float
        First step [s].
    dt_min, dt_max : float
        Floor and ceiling [s]. At the floor the failure-count and pressure-change rules are
        waived (the step is taken with however many failures it needs) and the step is
        solved with continuation in its length (``continuation``); if it still fails,
        longer steps (``jump``) are tried; a run ends only when those fail too.
    growth : float
        Factor after an easy step (fewer than ``n1`` new failures, at most
        ``newton_easy`` Newton iterations, well-pressure change below half ``dp_max``).
    cut : float
        Factor after a rejected step.
    n1, n2 : int
        Thesis 4.5.2: grow only when fewer than ``n1`` clusters failed in the step; reject
        and cut when more than ``n2`` would fail.
    newton_easy : int
        Newton iterations (all rounds of the step) that still count as easy.
    dp_max : float
        Largest well-pressure change per step [Pa]; larger steps are rejected.
    crack_growth : float
        While the crack runs (the last step failed clusters and the well pressure fell:
        breakdown into the well storage), a step may fail up to
        ``max(n2, crack_growth * n_failed)`` clusters: the crack must grow by many clusters
        while the stored well fluid flows in, and a fixed count would force the floor.
        ``0``: the plain ``n2`` rule.
    jump, jump_tries : float, int
        After a failure at the floor, steps of ``dt_min * jump^k`` (``k = 1 ..
        jump_tries``, capped by ``dt_max`` and the next mark) with all rules waived; the
        first that converges is taken. A cluster structure can lose its solution over a
        short step (a turning point of the step's equations, e.g. an unfilled crack-tip
        cell); a longer step lands beyond it. ``jump_tries = 0``: end the run instead.
    continuation : bool
        Solve floor steps with continuation in the step length
        (:class:`CoupledControl`).
    """

    dt_initial: float = 1.0
    dt_min: float = 1e-4
    dt_max: float = math.inf
    growth: float = 1.5
    cut: float = 0.25
    n1: int = 2
    n2: int = 8
    newton_easy: int = 10
    dp_max: float = math.inf
    crack_growth: float = 0.5
    jump: float = 4.0
    jump_tries: int = 4
    continuation: bool = True

    def __post_init__(self) -> None:
        if not (self.dt_initial > 0 and self.dt_min > 0 and self.dt_max >= self.dt_min):
            raise InputError("need dt_initial > 0, 0 < dt_min <= dt_max", key="time_step")
        if not self.growth >= 1.0:
            raise InputError("must be >= 1", key="time_step.growth")
        if not 0 < self.cut < 1:
            raise InputError("must be in (0, 1)", key="time_step.cut")
        if not (0 <= int(self.n1) <= int(self.n2)):
            raise InputError("need 0 <= n1 <= n2", key="time_step.n1")
        if not self.dp_max > 0:
            raise InputError("must be > 0", key="time_step.dp_max")
        if not self.crack_growth >= 0:
            raise InputError("must be >= 0", key="time_step.crack_growth")
        if not self.jump > 1:
            raise InputError("must be > 1", key="time_step.jump")
        if int(self.jump_tries) < 0:
            raise InputError("must be >= 0", key="time_step.jump_tries")


@dataclass
class CoupledCounters:
    """Cumulative work counters of a :class:`CoupledStepper`.

    Attributes
    ----------
    steps : int
        Accepted steps.
    failed_steps : int
        Rejected (cut) steps.
    newton_iterations, linear_solves, residual_evaluations : int
    failure_rounds : int
        Re-solves after new failures (over accepted and rejected steps).
    failed_clusters : int
        Clusters failed in accepted steps.
    linear_solve_time : float
        Wall time in the sparse LU factorisations and solves [s].
    contact_tolerance_steps : int
        Solves accepted on held contact branches within ``CoupledControl.contact_gap_rtol``.
    """

    steps: int = 0
    failed_steps: int = 0
    newton_iterations: int = 0
    linear_solves: int = 0
    residual_evaluations: int = 0
    failure_rounds: int = 0
    failed_clusters: int = 0
    linear_solve_time: float = 0.0
    contact_tolerance_steps: int = 0


@dataclass(frozen=True)
class StepResult:
    """Outcome of one attempted coupled step.

    Attributes
    ----------
    success : bool
    reason : str
        ``"converged"``, ``"newton: no convergence"``, ``"newton: stalled"``,
        ``"newton: active set cycles"``, ``"newton: singular"``, ``"newton: non-finite"``,
        ``"too many failures"``, ``"too many failure rounds"``, ``"pressure change"`` or
        ``"mass balance"``.
    newton_iterations, linear_solves : int
        Over all failure rounds of the step.
    dt : float
        Step [s] (0 for an undrained step).
    t : float
        Time after the step (unchanged on failure).
    max_dp : float
        Largest change of a cell or well pressure [Pa].
    injected_mass, outflow_mass, stored_mass_change : float [kg]
    mass_balance_error : float
        ``injected - stored change - outflow`` [kg].
    relative_mass_balance_error : float
        ``|error|`` over the step's gross mass scale.
    force_residual : float
        ``max |R_u|`` over the force scale at the end.
    new_failures : int
        Clusters failed in the step (for a rejected step: the count that made it fail).
    failure_rounds : int
        Solves of the step (1 + rounds with new failures).
    dp_w : float
        Well-pressure change [Pa].
    dp_w_smooth : float
        Well-pressure change [Pa] of the step's last converged solve before its first
        failure round: the smooth part of the change, which shrinks with the step (equal
        to ``dp_w`` in a step without failures).
    n_failed : int
        Failed clusters after the step.
    continuation_levels : int
        Back-offs of the continuation in the step length (0: solved directly).
    deferred_failures : int
        Overstressed clusters left intact at the end of the step by the crack-speed
        limit (``CoupledControl.crack_speed``); they fail in a later step.
    """

    success: bool
    reason: str
    newton_iterations: int
    linear_solves: int
    dt: float
    t: float
    max_dp: float = float("nan")
    injected_mass: float = float("nan")
    outflow_mass: float = float("nan")
    stored_mass_change: float = float("nan")
    mass_balance_error: float = float("nan")
    relative_mass_balance_error: float = float("nan")
    force_residual: float = float("nan")
    new_failures: int = 0
    failure_rounds: int = 0
    dp_w: float = float("nan")
    n_failed: int = 0
    continuation_levels: int = 0
    deferred_failures: int = 0
    dp_w_smooth: float = float("nan")


@dataclass(frozen=True)
class CoupledRunResult:
    """Outcome of :meth:`CoupledStepper.run`.

    Attributes
    ----------
    status : str
        ``"completed"`` (reached ``t_end``), ``"stopped"`` (the ``stop`` predicate) or
        ``"failed"``.
    message : str
    t : float
        Time reached [s].
    steps : list of StepResult
        Accepted steps of this run.
    rejected : int
        Rejected steps of this run.
    max_relative_mass_balance_error : float
    min_dt : float
        Smallest accepted step [s].
    """

    status: str
    message: str
    t: float
    steps: list = field(default_factory=list)
    rejected: int = 0
    max_relative_mass_balance_error: float = 0.0
    min_dt: float = math.inf

    @property
    def success(self) -> bool:
        """True unless the run failed."""
        return self.status != "failed"


class CoupledStepper:
    """Implicit (backward-Euler) monolithic steps of a :class:`CoupledModel`.

    Parameters
    ----------
    model : CoupledModel
    state : CoupledState, optional
        Start; default ``model.initial_state()``.
    control : CoupledControl, optional

    Attributes
    ----------
    state : CoupledState
        Last accepted state.
    counters : CoupledCounters
    history : list of StepResult
        Accepted and failed steps, in order.
    """

    def __init__(self, model: CoupledModel, state: CoupledState | None = None,
                 control: CoupledControl | None = None) -> None:
        self.model = model
        self.state = model.initial_state() if state is None else state
        self.control = control or CoupledControl()
        self.counters = CoupledCounters()
        self.history: list[StepResult] = []
        # (iteration, max|R_u|/force scale, sum|R_f|/mass scale) of the last Newton solve
        self.last_newton_trace: list[tuple[int, float, float]] = []
        self._adjacency: tuple[np.ndarray, np.ndarray] | None = None
        # the Newton's linear solver: orderings kept per pattern, the last factor reused
        # (its memory is part of a checkpoint: LinearSolver.state)
        self.linear_solver = LinearSolver()
        # the last accepted transitions (t_prev, x_prev, state): the predictor of a step
        # from `state` extrapolates from (t_prev, x_prev)
        self._transitions: list[tuple[float, np.ndarray, CoupledState]] = []

    # ---------------------------------------------------------------- failure
    def _fail(self, st: Structure, cand: np.ndarray, tensile: np.ndarray,
              res: CoupledResidual, t_new: float, effective_stress: np.ndarray) -> Structure:
        """Switch clusters ``cand`` to failed at the iterate of ``res`` (crack planes from
        their ``effective_stress`` there, :meth:`MechanicsModel.set_crack_planes`; forces
        continuous; the pore volume as ``CoupledModel.failure_dilatation`` says)."""
        model = self.model
        mech = model.mechanics
        u = np.asarray(res.state.displacement)
        p = np.asarray(res.state.p)
        cn = mech.set_crack_planes(cand, tensile[cand], effective_stress,
                                   np.asarray(st.cluster_state), np.asarray(st.crack_normal))
        ref_n, ref_s = mech._contact_refs(cand, u, p, np.array(st.ref_normal),
                                          np.array(st.ref_shear))
        cs = np.array(st.cluster_state)
        cs[cand] = np.where(tensile[cand], FAILED_TENSILE, FAILED_SHEAR)
        voff = np.array(st.volume_offset)
        if model.failure_dilatation == "continuous":
            du = (u.reshape(-1) - model.u0)[mech.dofs[cand]]
            gdu = np.einsum("ci,ci->c", model._g[cand], du)      # A eps_vol [m^2]
            voff[cand] += (model.biot - 1.0) * model.height * gdu
        ft = np.array(st.failure_time)
        ft[cand] = t_new
        fv = np.array(st.failure_volume)
        fv[cand] = np.asarray(res.state.flow.extra_pore_volume)[cand]
        return Structure(cs, ref_n, ref_s, st.slip, voff, ft, fv, cn)

    # ---------------------------------------------------------------- steps
    def step(self, dt: float, max_new_failures: int | None = None,
             max_dp_w: float | None = None, continuation: bool = False) -> StepResult:
        """Advance by ``dt`` [s] with failure updates (load at the step end, well rate at
        the midpoint).

        Parameters
        ----------
        dt : float
        max_new_failures : int, optional
            Reject the step (``"too many failures"``) as soon as more clusters than this
            would fail in it (thesis ``N2``); None: no limit.
        max_dp_w : float, optional
            Reject the step (``"pressure change"``) if the well pressure changes by more
            [Pa].
        continuation : bool
            If the solve fails, solve the same step by continuation in its length
            (``CoupledControl.continuation_*``) before giving up.
        """
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise InputError(f"time step must be > 0, got {dt!r}", key="dt")
        return self._solve(float(dt), False, max_new_failures, max_dp_w, bool(continuation))

    def step_undrained(self) -> StepResult:
        """Instantaneous (undrained) response to the load at the current time: no flow
        anywhere, no failure check, ``t`` unchanged. Use it to apply a load step at
        ``t = 0``."""
        return self._solve(1.0, True, None, None)

    def _reject(self, reason, its, solves, dt, old, rounds, new=0, levels=0,
                **kw) -> StepResult:
        self.counters.failed_steps += 1
        r = StepResult(False, reason, its, solves, dt, old.t, new_failures=new,
                       failure_rounds=rounds, n_failed=old.n_failed,
                       continuation_levels=levels, **kw)
        self.history.append(r)
        return r

    @property
    def predictor_history(self) -> tuple[float, np.ndarray] | None:
        """``(t_prev, x_prev)``: the state the present one was reached from (what the
        next step's predictor extrapolates from), or None. A checkpoint keeps it so that a
        resumed run predicts as the uninterrupted one does."""
        for t_prev, x_prev, succ in self._transitions:
            if succ is self.state:
                return t_prev, x_prev
        return None

    @predictor_history.setter
    def predictor_history(self, value: tuple[float, np.ndarray] | None) -> None:
        self._transitions = [] if value is None else [
            (float(value[0]), np.array(value[1], dtype=float), self.state)]

    def memory(self) -> dict[str, np.ndarray]:
        """What the next steps depend on beyond the state, for a checkpoint: the predictor's
        last transition (``pred.t``, ``pred.x``) and the linear solver's orderings and
        factor (``linear.*``). :meth:`restore_memory` takes it back."""
        out: dict[str, np.ndarray] = {}
        pred = self.predictor_history
        if pred is not None:
            out["pred.t"], out["pred.x"] = np.array(pred[0]), pred[1]
        for k, v in self.linear_solver.state().items():
            out[f"linear.{k}"] = v
        return out

    def restore_memory(self, memory: Mapping[str, np.ndarray]) -> None:
        """Continue with the :meth:`memory` of a checkpoint (after setting :attr:`state`)."""
        if "pred.x" in memory:
            self.predictor_history = (float(memory["pred.t"]), memory["pred.x"])
        lin = {k[len("linear."):]: v for k, v in memory.items() if k.startswith("linear.")}
        if lin:
            self.linear_solver.restore(lin, self.model.layout.pattern)

    def _extrapolate(self, x: np.ndarray, old: CoupledState, dt: float,
                     st: Structure) -> np.ndarray:
        """Start of the Newton of a step of ``dt`` from ``old``: the linear extrapolation
        of the last accepted step (``x_n + dt (x_n - x_{n-1}) / dt_{n-1}``, the ratio
        capped at :data:`PREDICTOR_MAX_RATIO`) when its residual is smaller than that of
        ``x_n`` itself, else ``x_n``.

        Along a smooth path the extrapolation is second-order accurate, and it carries
        the contact statuses the step is heading to (a crack opening as the pressure
        rises), which the Newton from ``x_n`` finds only after an iteration or two. At a
        change of the schedule (pump to shut-in) or after a cluster failure the residual
        comparison keeps ``x_n``."""
        hist = None
        for t_prev, x_prev, succ in self._transitions:
            if succ is old:
                hist = (t_prev, x_prev)
        if hist is None or not old.t > hist[0]:
            return x
        ratio = min(dt / (old.t - hist[0]), PREDICTOR_MAX_RATIO)
        xp = x + ratio * (x - hist[1])
        model = self.model
        r0 = model.residual(x, old, dt, structure=st)
        r1 = model.residual(xp, old, dt, structure=st)
        self.counters.residual_evaluations += 2
        if not np.all(np.isfinite(r1.residual)):
            return x
        return xp if scaled_norms(model, r1)[2] < scaled_norms(model, r0)[2] else x

    @staticmethod
    def _predict(h, h_done, x_done, h_prev, x_prev):
        """Secant predictor of the level-``h`` solution from the last two levels."""
        if h_prev is None or h_done <= h_prev:
            return x_done
        return x_done + (h - h_done) / (h_done - h_prev) * (x_done - x_prev)

    def _within_reach(self, cand: np.ndarray, old: CoupledState, st: Structure,
                      reach: float) -> np.ndarray:
        """Which candidates may fail in this step under the crack-speed limit.

        A candidate that shares an edge with a cluster failed earlier in this step
        extends a crack within the step; it may fail only if one of its nodes lies within
        ``reach`` of the damage at the step's start (the nodes of the clusters failed then
        and of the hole wall): a cluster touching the old crack always may, the next one
        out only if the crack may run that far in the step. Other candidates (initiations,
        extensions of the old crack) are not limited.
        """
        model = self.model
        mesh = model.mesh
        if self._adjacency is None:
            _, owners = mesh.edges()
            inner = owners[:, 1] >= 0
            self._adjacency = (owners[inner, 0], owners[inner, 1])
        a, b = self._adjacency
        failed_old = np.asarray(old.cluster_state) != INTACT
        new = (np.asarray(st.cluster_state) != INTACT) & ~failed_old
        ext = np.zeros(model.n_cells, dtype=bool)
        ext[a[new[b]]] = True
        ext[b[new[a]]] = True
        keep = ~ext[cand]
        if keep.all():
            return keep
        ref = np.zeros(mesh.n_nodes, dtype=bool)
        ref[mesh.hole_nodes] = True
        ref[mesh.triangles[failed_old].ravel()] = True
        if not ref.any():
            return keep
        far = cand[~keep]
        xn = mesh.nodes
        pts = xn[mesh.triangles[far].ravel()]
        d = np.min(np.hypot(pts[:, None, 0] - xn[None, ref, 0],
                            pts[:, None, 1] - xn[None, ref, 1]), axis=1)
        keep[~keep] = d.reshape(-1, 3).min(axis=1) <= reach
        return keep

    def _candidates(self, res: CoupledResidual, st: Structure, old: CoupledState, h: float):
        """The intact clusters that fail at the iterate of ``res`` (structure ``st``, a
        step of ``h`` from ``old``).

        Returns ``(cand, tensile, severity, trial, deferred)``: the overstressed intact
        clusters within the crack-speed reach (:meth:`_within_reach`), the tensile mask,
        every cluster's severity (largest margin over its strength; >= 0 fails), the
        mechanics state at the iterate and the count of overstressed clusters left for a
        later step."""
        model, ctl = self.model, self.control
        mech = model.mechanics
        trial = model.finish_state(res, st).mechanics
        mt, ms = mech.failure_margins(trial)
        cs = np.asarray(st.cluster_state)
        intact = cs == INTACT
        tens = intact & (mt >= 0.0)
        shear = intact & ~tens & (ms >= 0.0)
        cand = np.flatnonzero(tens | shear)
        deferred = 0
        if cand.size and math.isfinite(ctl.crack_speed):
            keep = self._within_reach(cand, old, st, ctl.crack_speed * h)
            deferred = int(np.sum(~keep))
            cand = cand[keep]
        T_c, S_c = mech.strengths(cs)
        sev = np.maximum(mt / np.maximum(T_c, 1.0), ms / np.maximum(S_c, 1.0))
        return cand, tens, sev, trial, deferred

    def _round_probe(self, found: dict, st: Structure, old: CoupledState, h: float):
        """The Newton probe of an intermediate failure round (``CoupledControl.round_rtol``).

        At an iterate within the loose tolerance it checks the failure criteria; when
        some intact clusters are overstressed and the decision is clear (no intact
        cluster's severity within ``round_margin`` of failure, and the last one failed
        this round more severe than the first one left by ``round_margin``), the
        candidates are stored in ``found["found"]`` and the solve stops: they fail and
        the step is solved again. With no candidate and no close call the verdict is
        stored in ``found["none"]`` (the stepper does not check again at convergence);
        with a close call the solve goes on to full convergence and the criteria are
        checked there, as without the probe.
        """
        ctl = self.control
        margin = float(ctl.round_margin)
        k = int(ctl.failures_per_round)

        def probe(res: CoupledResidual) -> bool:
            cand, tens, sev, trial, deferred = self._candidates(res, st, old, h)
            intact = np.asarray(st.cluster_state) == INTACT
            if np.any(intact & (np.abs(sev) < margin)):
                return False
            if cand.size == 0:
                found["none"] = (cand, tens, sev, trial, deferred)
                return False
            if cand.size > k:
                s = np.sort(sev[cand])[::-1]
                if s[k - 1] - s[k] < margin:
                    return False
            found["found"] = (cand, tens, sev, trial, deferred)
            return True

        return probe

    def _fold_predictor(self, x_start, old, h, st):
        """Solve the step of ``h`` again from the solution of a longer step.

        (See docs/coupling.md, "Hard cases".) A freshly failed, unfilled crack cell fills
        with a positive feedback (its inflow grows with its opening, its opening with its
        pressure); backward Euler's solution branch that starts at the old state (the cell
        still unfilled) then ends at a fold ``h*`` of the step length, and a step just
        beyond it has only the filled solution, far from the old state. The filled
        solution of a longer step of the same structure is found from the old state; it
        is the start for the step of ``h``.

        Returns ``(ok, x, res, iterations, solves)``.
        """
        ctl = self.control
        its = solves = 0
        res = None
        for k in ctl.fold_factors:
            long = newton(self, x_start, old, h * k, False, st,
                          min(ctl.continuation_newton, ctl.max_newton))
            its += long.iterations
            solves += long.solves
            if not long.ok:
                continue
            n = newton(self, long.x, old, h, False, st, None)
            its += n.iterations
            solves += n.solves
            res = n.residual
            if n.ok:
                return True, n.x, res, its, solves
        return False, x_start, res, its, solves

    def _solve(self, dt: float, undrained: bool, max_new: int | None,
               max_dp_w: float | None, continuation: bool = False) -> StepResult:
        model, ctl = self.model, self.control
        mech = model.mechanics
        old = self.state
        st = model.structure_of(old)
        # the contact rows of failed clusters follow the state's crack planes (a restored
        # or retried state may carry others than the last ones built)
        mech.sync_planes(st.cluster_state, st.crack_normal)
        x = model.x_of(old)
        if not undrained:
            x = self._extrapolate(x, old, dt, st)
        t_new = old.t if undrained else old.t + dt
        step_dt = 0.0 if undrained else dt
        its = solves = rounds = new_total = 0
        # continuation in the step length: on a failed solve the step's equations
        # (backward Euler over h from the old state) are solved for a shorter h, then for
        # rising h, each level from the extrapolation of the last two, with the failure
        # rounds at every level; the last level is h = dt, the step itself
        h, h_done, x_done, h_prev, x_prev = dt, 0.0, x, None, None
        levels = 0
        deferred = 0
        dpw_smooth = math.nan
        while True:
            backoff = continuation and not undrained and levels < ctl.continuation_levels
            x_start = x
            early: dict = {}
            probe = None
            if not undrained and ctl.check_failure and ctl.round_rtol > 0:
                probe = self._round_probe(early, st, old, h)
            n = newton(self, x, old, h, undrained, st,
                       ctl.continuation_newton if backoff else None, probe)
            ok, reason, x, res = n.ok, n.reason, n.x, n.residual
            its += n.iterations
            solves += n.solves
            if not ok and not undrained:
                ok2, x2, res2, i, s = self._fold_predictor(x_start, old, h, st)
                its += i
                solves += s
                if ok2:
                    ok, reason, x, res = True, "converged", x2, res2
            rounds += 1
            if not ok:
                if not backoff:
                    return self._reject(reason, its, solves, step_dt, old, rounds, new_total,
                                        levels)
                h = h_done + ctl.continuation_cut * (h - h_done)
                x = self._predict(h, h_done, x_done, h_prev, x_prev)
                levels += 1
                continue
            if new_total == 0:
                dpw_smooth = float(res.state.p_w - old.p_w)
            cand = np.zeros(0, dtype=np.int64)
            if n.early and "found" in early:
                cand, tens, sev, trial, deferred = early.pop("found")
            elif not n.early and "none" in early and n.ok:
                # the probe found no cluster within round_margin of failing at the loose
                # iterate: none fails at the converged one either (the same error bound
                # as a positive decision), so the check is not repeated
                cand, tens, sev, trial, deferred = early.pop("none")
            elif not undrained and ctl.check_failure:
                cand, tens, sev, trial, deferred = self._candidates(res, st, old, h)
            if cand.size == 0:
                if h >= dt:
                    break
                # this level settled: the next increment twice the last
                h_prev, x_prev, h_done, x_done = h_done, x_done, h, x
                h = min(dt, h + 2.0 * (h - h_prev))
                if dt - h <= 1e-9 * dt:
                    h = dt
                x = self._predict(h, h_done, x_done, h_prev, x_prev)
                continue
            if max_new is not None and new_total + cand.size > max_new:
                return self._reject("too many failures", its, solves, step_dt, old, rounds,
                                    new_total + int(cand.size), levels)
            if rounds > ctl.max_failure_rounds:
                return self._reject("too many failure rounds", its, solves, step_dt, old,
                                    rounds, new_total + int(cand.size), levels)
            cand = cand[np.argsort(-sev[cand], kind="stable")][: int(ctl.failures_per_round)]
            st = self._fail(st, cand, tens, res, old.t + h,
                            np.asarray(trial.effective_stress))
            new_total += int(cand.size)
            self.counters.failure_rounds += 1
        fr = res.flow
        injected = fr.injection_rate * dt
        stored = (float(np.sum(fr.storage_rate_cells)) + fr.storage_rate_well) * dt
        out = fr.boundary_rate * dt
        err = injected - stored - out
        # relative to the step's gross mass exchange; when almost nothing moves (a shut-in
        # on tight rock) that scale vanishes and the error is the round-off of the stored
        # masses (16 eps of the cell masses and of the well's C_w rho p_w), which is then
        # the scale (an error at the round-off floor counts as 1e-9)
        floor = 16 * np.finfo(float).eps * (
            float(np.sum(model.flow.cell_mass(res.state.flow)))
            + model.well_storage * abs(res.state.p_w) * float(model.flow.fluid.density))
        rel = abs(err) / max(res.mass_scale * dt, 1e9 * floor, 1e-300)
        new = res.state
        dpw = new.p_w - old.p_w
        max_dp = float(np.max(np.abs(np.append(new.p - old.p, dpw))))
        ru = float(np.max(np.abs(res.residual[:model.n_u]), initial=0.0)) / res.force_scale
        diag = dict(max_dp=max_dp, injected_mass=injected, outflow_mass=out,
                    stored_mass_change=stored, mass_balance_error=err,
                    relative_mass_balance_error=rel, force_residual=ru, dp_w=dpw)
        if rel > ctl.mass_balance_tol:
            return self._reject("mass balance", its, solves, step_dt, old, rounds, new_total,
                                levels, **diag)
        if max_dp_w is not None and abs(dpw) > max_dp_w:
            return self._reject("pressure change", its, solves, step_dt, old, rounds,
                                new_total, levels, **diag)
        # commit the frictional slip of the converged step
        ref_s, slip = mech._commit_slip(res.response, np.array(st.ref_shear),
                                        np.array(st.slip), np.asarray(st.cluster_state))
        st = replace(st, ref_shear=ref_s, slip=slip)
        self.state = model.finish_state(res, st)
        self._transitions = ([tp for tp in self._transitions if tp[2] is old][-1:]
                             + [(old.t, model.x_of(old), self.state)])
        self.counters.steps += 1
        self.counters.failed_clusters += new_total
        r = StepResult(True, reason, its, solves, step_dt, t_new, new_failures=new_total,
                       failure_rounds=rounds, n_failed=self.state.n_failed,
                       continuation_levels=levels, deferred_failures=deferred,
                       dp_w_smooth=dpw_smooth, **diag)
        self.history.append(r)
        return r

    # ---------------------------------------------------------------- runs
    def run(self, t_end: float, control: TimeStepControl | None = None, *,
            stop: Callable[[CoupledState], bool] | None = None,
            callback: Callable[[StepResult, CoupledState], None] | None = None,
            stop_times=()) -> CoupledRunResult:
        """Step adaptively to ``t_end`` [s] (or until ``stop(state)`` is true).

        Parameters
        ----------
        t_end : float
        control : TimeStepControl, optional
        stop : callable ``state -> bool``, optional
            Checked after every accepted step; True ends the run (``status="stopped"``).
        callback : callable ``(StepResult, CoupledState) -> None``, optional
            Called after every accepted step (progress reporting; nothing is printed).
        stop_times : sequence of float
            Times the steps must land on exactly (schedule changes).

        Returns
        -------
        CoupledRunResult
        """
        c = control or TimeStepControl()
        marks = sorted(float(v) for v in stop_times if self.state.t < v < t_end)
        h = min(float(c.dt_initial), c.dt_max)
        acc: list[StepResult] = []
        rejected = 0
        max_rel = 0.0
        min_dt = math.inf
        running = False   # last step failed clusters into a falling well pressure
        while self.state.t < t_end * (1.0 - 1e-14) - 1e-300:
            t = self.state.t
            target = next((v for v in marks if v > t * (1 + 1e-14)), t_end)
            h_try = min(h, target - t)
            at_floor = h_try <= c.dt_min * (1.0 + 1e-9)
            # land on the target instead of leaving a sliver
            if target - t - h_try < c.dt_min:
                h_try = target - t
            n_hist = len(self.history)
            r, h_try = self.attempt(h_try, c, running=running, limit=target - t,
                                    max_dp_w=None if math.isinf(c.dp_max) else c.dp_max,
                                    at_floor=at_floor)
            rejected += sum(1 for x in self.history[n_hist:] if not x.success)
            if not r.success:
                if not at_floor:
                    h = max(h_try * c.cut, c.dt_min)
                    continue
                return CoupledRunResult(
                    "failed", f"step of {h_try:g} s at t = {t:g} s failed at the dt "
                    f"floor: {r.reason}", self.state.t, acc, rejected, max_rel, min_dt)
            running = r.new_failures > 0 and r.dp_w < 0.0
            acc.append(r)
            max_rel = max(max_rel, r.relative_mass_balance_error)
            min_dt = min(min_dt, r.dt)
            factor = c.growth if self.easy(r, c) else 1.0
            # a step shortened to land on a mark does not shrink the next one
            h = min(max(h if h_try < h else h_try * factor, c.dt_min), c.dt_max)
            if callback is not None:
                callback(r, self.state)
            if stop is not None and stop(self.state):
                return CoupledRunResult("stopped", "stop condition met", self.state.t, acc,
                                        rejected, max_rel, min_dt)
        return CoupledRunResult("completed", f"reached t = {self.state.t:g} s", self.state.t,
                                acc, rejected, max_rel, min_dt)

    @staticmethod
    def easy(r: StepResult, c: TimeStepControl) -> bool:
        """Whether an accepted step lets the next one grow by ``c.growth``: fewer than
        ``n1`` failures, at most ``newton_easy`` Newton iterations, and a well-pressure
        change below half ``dp_max``."""
        return (r.new_failures < c.n1 and r.newton_iterations <= c.newton_easy
                and (math.isinf(c.dp_max) or abs(r.dp_w) <= 0.5 * c.dp_max))

    def attempt(self, h: float, control: TimeStepControl, *, running: bool = False,
                limit: float = math.inf, max_dp_w: float | None = None,
                at_floor: bool | None = None) -> tuple[StepResult, float]:
        """One trial of the adaptive stepping of :meth:`run` (its rules in one place, for
        drivers with their own loop such as the 2D engine).

        Above the floor: a step of ``h`` with the failure limit ``n2`` (while the crack
        runs, ``max(n2, crack_growth * n_failed)``) and the pressure-change limit
        ``max_dp_w``. At the floor (``h <= dt_min``) no limits and continuation in the step
        length; if that fails, steps of ``dt_min * jump^k`` (capped by ``dt_max`` and
        ``limit``) with all rules waived, the first that converges is taken.

        Parameters
        ----------
        h : float
            Step to try [s].
        control : TimeStepControl
        running : bool
            The last accepted step failed clusters while the well pressure fell.
        limit : float
            Longest step a jump over a floor failure may take [s] (the next mark).
        max_dp_w : float, optional
            Pressure-change limit above the floor [Pa].
        at_floor : bool, optional
            Whether this is a floor step; default ``h <= dt_min``. (A floor step
            lengthened to land on a mark, by less than ``dt_min``, is still one.)

        Returns
        -------
        (StepResult, float)
            The last trial (accepted or not) and its step length [s]. A failure with a
            step above ``dt_min`` is to be cut and retried; at the floor it is final.
        """
        c = control
        if at_floor is None:
            at_floor = h <= c.dt_min * (1.0 + 1e-9)
        max_new = None if at_floor else int(c.n2)
        if max_new is not None and running and c.crack_growth > 0:
            # the crack runs into the well storage: limit its growth, not the count
            max_new = max(max_new, int(math.ceil(c.crack_growth * self.state.n_failed)))
        r = self.step(h, max_new_failures=max_new,
                      max_dp_w=None if at_floor else max_dp_w,
                      continuation=at_floor and c.continuation)
        if r.success or not at_floor:
            return r, h
        # failed at the floor: step over it with longer steps, all rules waived
        hj = h
        for _ in range(int(c.jump_tries)):
            h_next = min(hj * c.jump, c.dt_max, limit)
            if h_next <= hj * (1.0 + 1e-9):
                break
            hj = h_next
            r = self.step(hj, continuation=c.continuation)
            if r.success:
                return r, hj
        return r, h

    def run_to(self, t_end: float, dt: float, growth: float = 1.0,
               dt_max: float = math.inf, cut: float = 0.25, dt_min: float = 1e-9
               ) -> list[StepResult]:
        """Step to exactly ``t_end`` starting with ``dt``, growing by ``growth`` after each
        accepted step (capped at ``dt_max``), cutting by ``cut`` after a failed one; no
        failure-count control (see :meth:`run`).

        Returns the accepted steps. Raises RuntimeError below ``dt_min``.
        """
        out: list[StepResult] = []
        h = float(dt)
        while self.state.t < t_end * (1.0 - 1e-14):
            h_try = min(h, t_end - self.state.t)
            r = self.step(h_try)
            if r.success:
                out.append(r)
                h = min(h * growth, dt_max)
            else:
                h = h_try * cut
                if h < dt_min:
                    raise RuntimeError(f"coupled step failed at t = {self.state.t:g} s: "
                                       f"{r.reason}")
        return out
