r"""The semi-smooth Newton solve of one coupled step for fixed cluster states.

:class:`NewtonSolve` is what :meth:`xlotkit.sim.coupling.CoupledStepper.step` runs for each
failure round: Newton on the coupled residual ``R(u, p, p_w)`` of a
:class:`~xlotkit.sim.coupling.CoupledModel` with the contact statuses (open / stick / slip)
of the failed clusters re-evaluated at every iterate. The solve is a small state machine;
each pass of :meth:`NewtonSolve.run` goes through named states (:class:`State`):

``EVALUATE``
    The residual and Jacobian at the iterate (or the line search's accepted point). A
    non-finite residual backs off along the last update (``nonfinite_backoffs`` times),
    else the solve fails (``"newton: non-finite"``).
``CHECK``
    Convergence: forces (relative, or at the rows' round-off floor) and mass (relative,
    or, while stagnating, at the round-off floor of the flow rows).
``SETTLE``
    Converged with contacts *held* on a branch of their law: accepted when the exact law
    agrees (or misses only at the law's corners, within ``contact_gap_rtol``); else the
    contacts on a wrong branch are moved (one at a time in a fixed order, all at once first
    when more than two are wrong; a branch set already tried is skipped: ``"newton:
    active set cycles"`` when none is left), and the solve goes on.
``STOP``
    ``max_newton`` iterations, or a stall (no iterate of the last half of
    ``stall_iterations`` brought the scaled norm below half its earlier value).
``LINEARISE``
    Picard on the crack permeability while far (then the full Jacobian for the rest of the
    solve), contacts that keep switching held on their branch (``chatter = "freeze"``) or
    softened (``"soft"``).
``UPDATE``
    The linear solve (row/column-equilibrated sparse LU), a backtracking line search on the
    scaled norm after ``line_search_after`` iterations with the full Jacobian, the step.

The outcome is a :class:`NewtonResult` (``ok``, ``reason``, the iterate, its residual and
the work). The helpers of the checks (:func:`scaled_norms`, :func:`forces_converged`,
:func:`mass_floor`, :func:`law_status`, :func:`branch_violation`) are module functions.
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from numba import njit

from xlotkit.sim.coupling.linear import LinearSolver
from xlotkit.sim.coupling.model import CoupledResidual, Structure
from xlotkit.sim.mechanics import OPEN, SLIP, STICK

__all__ = ["NewtonResult", "NewtonSolve", "State", "branch_violation", "equilibrated_solve",
           "forces_converged", "law_status", "mass_floor", "scaled_norms"]


#: Forcing term of the inexact Newton: a Krylov solve reduces the (equilibrated) linearised
#: residual to this fraction of the square root of the present merit...
KRYLOV_FORCING = 1e-2
#: ... and at least to this (the direct solve's 1e-10 is the floor).
KRYLOV_RTOL_MAX = 1e-6


class State(enum.Enum):
    """The states of one pass of :meth:`NewtonSolve.run` (module docstring)."""

    EVALUATE = "evaluate"
    CHECK = "check"
    SETTLE = "settle"
    STOP = "stop"
    LINEARISE = "linearise"
    UPDATE = "update"
    DONE = "done"


@dataclass(frozen=True)
class NewtonResult:
    """Outcome of a :class:`NewtonSolve`.

    Attributes
    ----------
    ok : bool
        Converged.
    reason : str
        ``"converged"``, ``"newton: no convergence"``, ``"newton: stalled"``,
        ``"newton: active set cycles"``, ``"newton: singular"`` or ``"newton: non-finite"``.
    x : ndarray
        The last iterate.
    residual : CoupledResidual
        Its residual (the exact law's when converged on held branches).
    iterations, solves : int
        Newton iterations and linear solves.
    early : bool
        Stopped before full convergence because the solve's ``probe`` accepted the
        iterate (an intermediate failure round: the iterate decides which clusters fail
        next, the step's last solve is converged in full); ``ok`` is then True.
    """

    ok: bool
    reason: str
    x: np.ndarray
    residual: CoupledResidual
    iterations: int
    solves: int
    early: bool = False


# =========================================================================== checks
def scaled_norms(model, res: CoupledResidual) -> tuple[float, float, float]:
    """``(max |R_u| / force scale, sum |R_f|, merit)`` with the merit the scaled norm
    ``|R_u|^2 / force_scale^2 + (sum |R_f| / mass_scale)^2``."""
    nu = model.n_u
    R = res.residual
    ru = float(np.max(np.abs(R[:nu]), initial=0.0)) / res.force_scale
    rf = float(np.sum(np.abs(R[nu:])))
    return ru, rf, float(np.linalg.norm(R[:nu]) / res.force_scale) ** 2 + (
        rf / max(res.mass_scale, 1e-300)) ** 2


@njit(cache=True)
def _abs_row_products_kernel(indptr, indices, data, x, lo, out):  # pragma: no cover - compiled
    # each row summed from 0 in the order of its stored entries (what np.bincount over
    # the rows did: the same sums to the bit)
    for i in range(out.shape[0]):
        s = 0.0
        for k in range(indptr[lo + i], indptr[lo + i + 1]):
            s += abs(data[k]) * abs(x[np.uint64(indices[k])])
        out[i] = s


def _abs_row_products(J, x: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """``|J[lo:hi]| @ |x|`` of a CSR matrix, on its arrays (no sub-matrix built)."""
    J = J if J.format == "csr" else J.tocsr()
    x = np.ascontiguousarray(x, dtype=np.float64)
    if not (0 <= lo <= hi <= J.shape[0]) or x.shape != (J.shape[1],):
        raise ValueError(f"rows {lo}:{hi} or x {x.shape} do not fit J {J.shape}")
    out = np.empty(hi - lo)
    _abs_row_products_kernel(J.indptr, J.indices, np.ascontiguousarray(J.data, np.float64),
                             x, lo, out)
    return out


def mass_floor(model, res: CoupledResidual, x: np.ndarray) -> float:
    """Round-off floor of ``sum |R_f|`` at the iterate ``x`` [kg/s]."""
    nu = model.n_u
    J = res.jacobian
    return 4.0 * np.finfo(float).eps * float(np.sum(_abs_row_products(J, x, nu, J.shape[0])))


def forces_converged(model, control, res: CoupledResidual, x: np.ndarray, ru: float) -> bool:
    """Force rows converged: ``max |R_u| <= force_rtol * force_scale``, or each row
    at its round-off floor ``4 eps sum_j |dR_u,i/dx_j| |x_j|``.

    The residual is incremental (``u - u_0``, ``p - p_0``) and the force scale is the
    size of the increments' forces; when almost nothing moves (a shut-in of intact rock)
    that scale shrinks to the rounding of ``x - x_0`` itself and the relative test
    cannot be met. The floor test is per row and needs no cap on ``ru``: with the intact
    rock decoupled from its pore fluid (Biot alpha = 0) the force scale of a shut-in has
    no pore-pressure forces in it, and ``ru`` at the rows' floor exceeded the former
    1e-6 cap (a well at rest stalled).
    """
    if ru <= control.force_rtol:
        return True
    nu = model.n_u
    Ru = np.abs(res.residual[:nu])
    floor = 4.0 * np.finfo(float).eps * _abs_row_products(res.jacobian, x, 0, nu)
    return bool(np.all(Ru <= np.maximum(control.force_rtol * res.force_scale, floor)))


def law_status(model, res: CoupledResidual, st: Structure):
    """Status (open/stick/slip) and shear sign of every contact under the exact law at
    the iterate of ``res``."""
    mech = model.mechanics
    Un, Us = res.response[3], res.response[4]
    trial_n = mech.normal_force(Un - np.asarray(st.ref_normal))
    trial_s = mech.ks * (Us - np.asarray(st.ref_shear))
    cap = mech.mu * np.maximum(-trial_n, 0.0)
    # (at the friction limit the slip branch, as the contact law's kernel says)
    law = np.where(trial_n > 0.0, OPEN, np.where(np.abs(trial_s) >= cap, SLIP, STICK))
    return law, np.sign(trial_s)


def branch_violation(model, res: CoupledResidual, st: Structure, fstat: np.ndarray,
                     fsgn: np.ndarray) -> np.ndarray:
    """How far [m] each contact's iterate lies beyond the switch point of the exact law
    when held on branch ``fstat`` (sign ``fsgn``): the overlap of a contact held open,
    the opening of one held closed, the shear displacement past the friction limit of
    one held in stick, or short of it (in its sign) of one held slipping; 0 where the
    held branch is the exact law's."""
    mech = model.mechanics
    Un, Us = res.response[3], res.response[4]
    gap = Un - np.asarray(st.ref_normal)
    trial_n = mech.normal_force(gap)
    trial_s = mech.ks * (Us - np.asarray(st.ref_shear))
    cap = mech.mu * np.maximum(-trial_n, 0.0)
    v_open = np.maximum(-gap, 0.0)
    v_closed = np.maximum(gap, 0.0)
    v_stick = np.maximum(np.abs(trial_s) - cap, 0.0) / mech.ks
    v_slip = np.maximum(cap - fsgn * trial_s, 0.0) / mech.ks
    return np.where(fstat == OPEN, v_open,
                    np.maximum(v_closed, np.where(fstat == SLIP, v_slip, v_stick)))


def equilibrated_solve(J: sp.spmatrix, rhs: np.ndarray) -> np.ndarray:
    """Solve ``J x = rhs`` with row then column scaling by the largest entries: a fresh
    sparse LU (minimum-degree ordering of ``A + A^T``, diagonal pivots preferred; SuperLU's
    default ordering with partial pivoting when those pivots are poor), nothing reused
    (:class:`~xlotkit.sim.coupling.linear.LinearSolver` without a pattern).

    Raises
    ------
    RuntimeError
        If the matrix is singular.
    """
    return LinearSolver(krylov_iterations=0).solve(J, rhs)


# =========================================================================== the solve
class NewtonSolve:
    """One Newton solve of a coupled step (module docstring).

    Parameters
    ----------
    model : CoupledModel
    control : CoupledControl
    counters : CoupledCounters
        Incremented in place (residual evaluations, iterations, solves, solve time,
        steps accepted on held branches).
    x : ndarray
        Start iterate.
    old : CoupledState
        State at the start of the step.
    dt : float
        Step [s].
    undrained : bool
        Instantaneous (no flow) step.
    structure : Structure
        The cluster states of the solve.
    max_it : int, optional
        Iteration limit (default ``control.max_newton``).
    solver : LinearSolver, optional
        The linear solver (its ordering and factor reused across the iterations while
        the pattern and the contact statuses hold); default a fresh one.
    probe : callable ``CoupledResidual -> bool``, optional
        Asked once per solve, at the first iterate that is not converged but within the
        loose tolerance ``control.round_rtol`` (forces and mass, relative to their
        scales) with no contacts held on a branch; True stops the solve there
        (``early``). The stepper passes one that checks the failure criteria (an
        intermediate failure round).

    Attributes
    ----------
    trace : list of (iteration, max|R_u|/force scale, sum|R_f|/mass scale)
        Every evaluated iterate.
    """

    def __init__(self, model, control, counters, x: np.ndarray, old, dt: float,
                 undrained: bool, structure: Structure, max_it: int | None = None,
                 solver: LinearSolver | None = None, probe=None) -> None:
        self.model, self.control, self.counters = model, control, counters
        self.probe = probe
        self.early = False
        self.solver = LinearSolver() if solver is None else solver
        self.old, self.dt, self.undrained, self.st = old, dt, undrained, structure
        self.max_newton = control.max_newton if max_it is None else int(max_it)
        self.x = x
        self.trace: list[tuple[int, float, float]] = []
        self.its = self.solves = 0
        self.prev = math.inf            # mass residual of the last iteration
        self.reason = "newton: no convergence"
        self.ok = False
        self.prev_status = None
        self.flips = None
        self.soft = None
        self.full_k = control.lagged_permeability_rtol >= 1.0
        self.freeze = control.chatter == "freeze"
        nc = model.n_cells
        # held contacts: mask, branch (OPEN/STICK/SLIP) and slip sign
        self.fmask = np.zeros((nc, 3), dtype=bool)
        self.fstat = np.zeros((nc, 3), dtype=np.int64)
        self.fsgn = np.zeros((nc, 3))
        self.frz = None
        self.seen: set = set()          # branch sets tried
        self.since = 0                  # iterations since the held branches (or J) changed
        self.merits: list = []          # scaled residual norms since then
        self.merit0 = math.inf
        self.pending = None             # residual of the accepted line-search point
        self.rfs: list = []             # mass residuals of the iterations
        self.x_from = self.step_dx = None   # the last Newton update, to back off along it
        self.backoffs = 0
        self.res: CoupledResidual | None = None
        # the residual vector the update solves for: the iterate's, or after holding new
        # contacts the re-evaluated one (a Jacobian changed for the permeability derivative
        # or softened contacts keeps the iterate's)
        self.R: np.ndarray | None = None
        # the present iterate's norms
        self.ru = self.rf = self.merit = math.nan
        self.atol = 0.0

    # ------------------------------------------------------------------ run
    def run(self) -> NewtonResult:
        """Iterate to convergence or failure."""
        state = State.EVALUATE
        handlers = {State.EVALUATE: self._evaluate_state, State.CHECK: self._check_state,
                    State.SETTLE: self._settle_state, State.STOP: self._stop_state,
                    State.LINEARISE: self._linearise_state, State.UPDATE: self._update_state}
        while state is not State.DONE:
            state = handlers[state]()
        self.counters.newton_iterations += self.its
        self.counters.linear_solves += self.solves
        return NewtonResult(self.ok, self.reason, self.x, self.res, self.its, self.solves,
                            self.early)

    def _evaluate(self, xx, frozen):
        self.counters.residual_evaluations += 1
        return self.model.residual_and_jacobian(
            xx, self.old, self.dt, undrained=self.undrained, structure=self.st,
            soft=self.soft, permeability_derivative=self.full_k, frozen=frozen)

    def _residual(self, xx, frozen):
        """The residual alone (a line-search trial point)."""
        self.counters.residual_evaluations += 1
        return self.model.residual(xx, self.old, self.dt, undrained=self.undrained,
                                   structure=self.st, soft=self.soft, frozen=frozen)

    def _fail(self, reason: str) -> State:
        self.reason = reason
        return State.DONE

    def _converged(self) -> State:
        self.ok, self.reason = True, "converged"
        return State.DONE

    # ------------------------------------------------------------------ states
    def _evaluate_state(self) -> State:
        res = self.pending
        if res is None or res.jacobian is None:
            # (an accepted line-search point was evaluated without its Jacobian)
            res = self._evaluate(self.x, self.frz)
        self.pending = None
        self.res = res
        self.R = res.residual
        if not np.all(np.isfinite(self.R)):
            # a wild update (a cell pressure so far out that rho(p) = exp(c_f p)
            # overflows): back off along it before giving up; the solution of the step
            # need not be far, only the linearisation was poor there
            if self.step_dx is not None and self.backoffs < self.control.nonfinite_backoffs:
                self.backoffs += 1
                self.step_dx = 0.25 * self.step_dx
                self.x = self.x_from + self.step_dx
                return State.EVALUATE
            return self._fail("newton: non-finite")
        self.backoffs = 0
        self.ru, self.rf, self.merit = scaled_norms(self.model, res)
        self.trace.append((self.its, self.ru, self.rf / max(res.mass_scale, 1e-300)))
        if self.since == 0:
            self.merits = []
        self.merits.append(self.merit)
        return State.CHECK

    def _check_state(self) -> State:
        model, ctl, res, x = self.model, self.control, self.res, self.x
        rf = self.rf
        atol = 1e-18 * float(np.sum(model.flow.cell_mass(res.state.flow))) / self.dt
        # the well row's storage C_w rho (p_w - p_w^n)/dt carries the round-off of
        # p_w itself (eps |p_w|): with a whole well's compliance and nothing moving
        # (a shut-in on tight rock) that is the whole residual
        atol += 16 * np.finfo(float).eps * model.well_storage * abs(
            res.state.p_w) * float(model.flow.fluid.density) / self.dt
        self.atol = atol
        u_ok = forces_converged(model, ctl, res, x, self.ru)
        conv = u_ok and rf <= ctl.mass_rtol * res.mass_scale + atol
        if not conv and u_ok and rf <= ctl.stagnation_rtol * res.mass_scale + atol:
            # at the residual's round-off floor (below): no iteration can lower it, so
            # it is accepted without waiting to see it stagnate (capped by the
            # stagnation tolerance, which keeps the step's mass balance; accepting at a
            # floor above it broke the mass balance of a consolidation step,
            # tests/verification/test_consolidation.py)
            conv = rf <= ctl.mass_rtol * res.mass_scale + atol + mass_floor(model, res, x)
        if not conv and self.its > 0 and u_ok and rf > 0.5 * self.prev:
            # stagnating: accepted below stagnation_rtol or at the residual's
            # round-off floor, eps sum_ij |dR_i/dx_j| |x_j| over the flow rows (each
            # term's share of the rounding of x_j: a wide open crack's transmissibility
            # times |p| makes this floor, not the mass scale, the limit)
            conv = rf <= ctl.stagnation_rtol * res.mass_scale + atol + mass_floor(model, res, x)
        if conv and self.frz is not None:
            return State.SETTLE
        if conv:
            return self._converged()
        loose = ctl.round_rtol
        if (self.probe is not None and loose > 0 and self.frz is None
                and self.ru <= loose and rf <= loose * res.mass_scale + atol):
            # an intermediate failure round: the iterate is close enough to decide which
            # clusters fail next (the probe's judgement); the step's last round is
            # converged in full. Asked once per solve (a failure check costs about a
            # third of an iteration; asking at every loose iterate made 497 checks on
            # the standard scene for the same decisions)
            probe, self.probe = self.probe, None
            if probe(res):
                self.early = True
                return self._converged()
        return State.STOP

    def _settle_state(self) -> State:
        """Converged with contacts held on branches: done if the exact law agrees (on its
        own branch the held law is the exact one), else move the contacts that sit on a
        wrong branch."""
        model, ctl, x, st = self.model, self.control, self.x, self.st
        exact = self._evaluate(x, None)
        eru, erf, _ = scaled_norms(model, exact)
        if (forces_converged(model, ctl, exact, x, eru)
                and erf <= ctl.stagnation_rtol * exact.mass_scale
                + self.atol + mass_floor(model, exact, x)):
            self.res = exact
            return self._converged()
        law, lsg = law_status(model, exact, st)
        fmask, fstat, fsgn = self.fmask, self.fstat, self.fsgn
        wrong = fmask & ((law != fstat) | ((law == SLIP) & (lsg != fsgn)))
        tol = ctl.contact_gap_rtol * model.residual_aperture
        if wrong.any() and tol > 0 and np.all(
                branch_violation(model, exact, st, fstat, fsgn)[wrong] <= tol):
            # the held branches miss the exact law only at the corners of the law,
            # by less than the gap tolerance (a contact whose solution sits at the
            # corner, where the branches on either side have no solution of their
            # own: moving it only cycles); accepted on the held branches
            self.counters.contact_tolerance_steps += 1
            return self._converged()
        if not wrong.any():
            # (only at round-off: the exact law is then the held one) release all
            fmask[:] = False
            self.frz = None
            self.flips[:] = 0
            self.prev = math.inf
            self.since = 0
            return State.EVALUATE
        # one contact at a time in a fixed order (least index, as in Murty's
        # pivoting rule: moving two coupled contacts at the corner of the law at
        # once can cycle), all at once first when more than two are wrong; a
        # branch set already tried is skipped
        cand = [(c, k) for c, k in zip(*np.nonzero(wrong))]
        trials = [[ck] for ck in cand] + [cand]
        if len(cand) > 2:
            trials = [cand] + trials
        for sel in trials:
            ts_, tg_ = fstat.copy(), fsgn.copy()
            for c, k in sel:
                ts_[c, k] = law[c, k]
                tg_[c, k] = lsg[c, k] if law[c, k] == SLIP else 0.0
            key = (fmask.tobytes(), ts_[fmask].tobytes(), tg_[fmask].tobytes())
            if key not in self.seen:
                break
        else:
            return self._fail("newton: active set cycles")
        self.seen.add(key)
        self.fstat, self.fsgn = ts_, tg_
        self.frz = (fmask.copy(), self.fstat, self.fsgn)
        self.prev = math.inf
        self.since = 0
        return State.EVALUATE

    def _stop_state(self) -> State:
        if self.its >= self.max_newton:
            return State.DONE
        w = int(self.control.stall_iterations)
        hw = w // 2
        merits = self.merits
        if w > 0 and len(merits) >= w and min(merits[-hw:]) > 0.5 * merits[-hw - 1]:
            return self._fail("newton: stalled")
        return State.LINEARISE

    def _linearise_state(self) -> State:
        """Picard on the crack permeability while far from the solution, Newton once close,
        or once Picard has stopped converging (it is only linear: mass residual not halved
        over three iterations, from the sixth on); no return to Picard within the solve
        (switching at the threshold back and forth changes the Jacobian every iteration).
        Then the chattering contacts."""
        ctl, res, rf = self.control, self.res, self.rf
        self.rfs.append(rf)
        lag = ctl.lagged_permeability_rtol
        if not self.full_k and (rf <= lag * res.mass_scale
                                or (lag > 0 and self.its >= 6 and rf > 0.5 * self.rfs[-4])):
            self.full_k = True
            self.since = 0
            # the same iterate and residual; its Jacobian gains the crack block
            if not self.undrained:      # (undrained: no flow, no crack block)
                res = self.res = self.model.with_permeability_derivative(res, self.st)
        status = res.response[2]
        if self.prev_status is not None:
            self.flips = self.flips + (status != self.prev_status)
        else:
            self.flips = np.zeros(status.shape, dtype=np.int64)
        self.prev_status = status
        self.prev = rf
        if self.its == 0:
            self.merit0 = self.merit
        if self.freeze:
            # chattering contacts are held on their present branch; only at iterates
            # no worse than the start (the statuses of a wild iterate say nothing)
            new = (self.flips >= ctl.chatter_flips) & ~self.fmask
            if self.merit <= self.merit0 and new.any():
                fmask, fstat, fsgn = self.fmask, self.fstat, self.fsgn
                fmask |= new
                fstat[new] = status[new]
                fsgn[new] = np.where(status[new] == SLIP,
                                     law_status(self.model, res, self.st)[1][new], 0.0)
                self.frz = (fmask.copy(), fstat.copy(), fsgn.copy())
                self.seen.add((fmask.tobytes(), fstat[fmask].tobytes(),
                               fsgn[fmask].tobytes()))
                self.since = 0
                res = self.res = self._evaluate(self.x, self.frz)
                self.R = res.residual
                self.ru, self.rf, self.merit = scaled_norms(self.model, res)
        elif self.its >= ctl.line_search_after:
            new_soft = self.flips >= ctl.chatter_flips
            if new_soft.any() and (self.soft is None or not np.array_equal(new_soft, self.soft)):
                self.soft = new_soft
                self.res = self._evaluate(self.x, self.frz)
        return State.UPDATE

    def _update_state(self) -> State:
        ctl, res = self.control, self.res
        t0 = time.perf_counter()
        # the factor is reused while the pattern holds and the contact statuses the
        # Jacobian was linearised with are (nearly) the same (softened contacts alike)
        # inexact Newton: a Krylov solve need reduce the linearised residual only to a
        # fraction of the present scaled residual (KRYLOV_FORCING of it, at most
        # KRYLOV_RTOL_MAX), which keeps the convergence quadratic
        rtol = (min(KRYLOV_FORCING * math.sqrt(self.merit), KRYLOV_RTOL_MAX)
                if math.isfinite(self.merit) else None)
        try:
            dx = self.solver.solve(res.jacobian, -self.R, pattern=res.pattern,
                                   status=res.status,
                                   variant=None if self.soft is None else self.soft.tobytes(),
                                   rtol=rtol)
        except RuntimeError:
            self.counters.linear_solve_time += time.perf_counter() - t0
            return self._fail("newton: singular")
        self.counters.linear_solve_time += time.perf_counter() - t0
        self.solves += 1
        if not np.all(np.isfinite(dx)):
            return self._fail("newton: non-finite")
        step = 1.0
        if self.since >= ctl.line_search_after and self.full_k:
            # backtracking on the scaled residual norm (the full step is tried first:
            # with the right active set it terminates; at corners of the contact law
            # the statuses can cycle and the line search restores descent); not with
            # the lagged Jacobian, whose direction need not descend
            for _ in range(8):
                trial = self._residual(self.x + step * dx, self.frz)
                if np.all(np.isfinite(trial.residual)) and scaled_norms(
                        self.model, trial)[2] < self.merit:
                    self.pending = trial
                    break
                step *= 0.5
        self.x_from, self.step_dx = self.x, step * dx
        self.x = self.x + self.step_dx
        self.its += 1
        self.since += 1
        return State.EVALUATE


def newton(stepper: Any, x, old, dt, undrained, st, max_it=None, probe=None):
    """A :class:`NewtonSolve` with the stepper's model, control, counters and linear solver
    (its trace kept as ``stepper.last_newton_trace``)."""
    solve = NewtonSolve(stepper.model, stepper.control, stepper.counters, x, old, dt,
                        undrained, st, max_it, stepper.linear_solver, probe)
    stepper.last_newton_trace = solve.trace
    return solve.run()
