"""Implicit time stepping of the flow model: Newton per step, adaptive dt, mass balance.

Each step solves ``R(x_{n+1}) = 0`` (:meth:`FlowModel.residual_and_jacobian`) by Newton's
method with the analytic Jacobian and a SciPy sparse direct solve (SuperLU). Convergence is
judged on mass, the conserved quantity: the step converges when

    sum_i |R_i| <= newton_rtol * throughput + atol

with ``throughput`` the sum of the step's absolute mass rates (injection, outflow, each
cell's storage change) and ``atol = 1e-18 * (fluid mass in the model) / dt`` (only
matters when nothing moves). Pressures (~1e7 Pa) are only represented to ``eps |p|``, so
a pure relative tolerance cannot always be met: if Newton stagnates at round-off (an update
of a few ulps, or the residual no longer halving) the step is accepted when the mass
residual is below ``stagnation_rtol`` (1e-8) of the throughput. This matters only where
highly conductive cells (a fracture, k/k_matrix ~ 1e6) carry little net flow: their fluxes
``lambda T (p_j - p_i)`` are then resolved only to ``lambda T ulp(p)``. Typical steps reach
~1e-11. With a prescribed well pressure the well row must also hold to
``1e-6 Pa``.

Time-step control: a step is rejected (and retried with a smaller ``dt``) when Newton fails
(no convergence in ``max_newton`` iterations, a singular or non-finite solve) or when any
pressure changes by more than ``dp_max`` in the step. After an accepted step ``dt`` grows by
``growth`` if Newton needed at most ``easy_iterations`` and the pressure change was below
half the limit. Steps end exactly on ``t_end`` and on any requested stop times (rate changes,
output times).

Mass balance is checked after every accepted step::

    error = m_in - (Delta M_cells + Delta M_well) - m_out       [kg]

with ``m_in = rho0 Q dt`` (or the diagnosed injection under pressure control) and
``m_out`` the mass through fixed-pressure outer edges. The relative error divides by the
step's mass throughput.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import scipy.sparse.linalg as spla

from xlotkit.errors import InputError
from xlotkit.sim.flow.model import FlowModel, FlowState

__all__ = ["FlowCounters", "FlowResult", "FlowStepper", "StepControl", "StepResult"]


@dataclass(frozen=True)
class StepControl:
    """Time-step and Newton settings.

    Attributes
    ----------
    dt_initial : float
        First step [s].
    dt_min, dt_max : float
        Bounds of the step [s]; the run fails if a step below ``dt_min`` is needed.
    growth : float
        Factor applied after an easy step (> 1).
    cut : float
        Factor applied after a rejected step (in (0, 1)).
    dp_max : float
        Largest pressure change of any unknown in one step [Pa].
    easy_iterations : int
        A step with at most this many Newton iterations lets ``dt`` grow.
    max_newton : int
        Newton iterations before the step is declared failed.
    newton_rtol : float
        Relative mass-residual tolerance (see module notes).
    stagnation_rtol : float
        Mass-residual level (relative to the throughput) accepted when Newton stagnates at
        round-off (see module notes).
    reuse_contraction : float
        The LU factors of the Jacobian are reused for the next iteration (chord Newton)
        while each iteration shrinks the mass residual by at least this factor; 0 gives
        a fresh factorisation every iteration.
    """

    dt_initial: float = 1.0
    dt_min: float = 1e-6
    dt_max: float = 1e4
    growth: float = 1.5
    cut: float = 0.25
    dp_max: float = 1e6
    easy_iterations: int = 3
    max_newton: int = 12
    newton_rtol: float = 1e-11
    reuse_contraction: float = 0.01
    stagnation_rtol: float = 1e-8

    def __post_init__(self) -> None:
        for key, lo in (("dt_initial", 0.0), ("dt_min", 0.0), ("dt_max", 0.0),
                        ("dp_max", 0.0), ("newton_rtol", 0.0)):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > lo):
                raise InputError(f"must be a number > {lo}, got {v!r}", key=f"step.{key}")
        if self.dt_min > self.dt_max:
            raise InputError("dt_min must not exceed dt_max", key="step.dt_min")
        if not (self.growth >= 1.0):
            raise InputError("must be >= 1", key="step.growth")
        if not (0.0 < self.cut < 1.0):
            raise InputError("must be in (0, 1)", key="step.cut")
        if int(self.max_newton) < 1 or int(self.easy_iterations) < 0:
            raise InputError("must be >= 1", key="step.max_newton")


@dataclass
class FlowCounters:
    """Work counters of a :class:`FlowStepper` (cumulative)."""

    steps: int = 0
    cuts: int = 0
    newton_iterations: int = 0
    linear_solves: int = 0
    factorizations: int = 0
    residual_evaluations: int = 0


@dataclass(frozen=True)
class StepResult:
    """Outcome of one attempted step.

    Attributes
    ----------
    success : bool
    reason : str
        ``"converged"``, ``"newton: no convergence"``, ``"newton: singular"``,
        ``"newton: non-finite"`` or ``"dp limit"``.
    newton_iterations : int
    linear_solves : int
    dt : float
        Attempted step [s].
    t : float
        Time after the step (unchanged on failure) [s].
    max_dp : float
        Largest pressure change of the step [Pa] (``nan`` if Newton failed).
    injected_mass : float
        Mass pumped into the well in the step [kg].
    outflow_mass : float
        Mass out through fixed-pressure outer edges [kg].
    stored_mass_change : float
        Change of the fluid mass in cells and well [kg].
    mass_balance_error : float
        ``injected - stored change - outflow`` [kg].
    relative_mass_balance_error : float
        ``|mass_balance_error|`` over the step's mass throughput.
    well_rate : float
        Injection rate into the well [m^3/s at rho0] (diagnosed under pressure control).
    formation_rate : float
        Rate from the well into the formation [m^3/s at rho0].
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
    well_rate: float = float("nan")
    formation_rate: float = float("nan")


@dataclass(frozen=True, eq=False)
class FlowResult:
    """Result of :meth:`FlowStepper.run` (like ``scipy.integrate.solve_ivp``'s).

    Attributes
    ----------
    status : int
        0: reached ``t_end``; -1: a step failed below ``dt_min``; 1: stopped by ``max_steps``.
    message : str
    success : bool
        ``status == 0``.
    times : ndarray, shape (k + 1,)
        Start time and the end of each accepted step [s].
    p_w : ndarray, shape (k + 1,)
        Well pressure [Pa].
    well_rate : ndarray, shape (k + 1,)
        Injection rate over the step ending at ``times`` [m^3/s]; first entry ``nan``.
    formation_rate : ndarray, shape (k + 1,)
        Well -> formation rate [m^3/s]; first entry ``nan``.
    injected_volume : ndarray, shape (k + 1,)
        Cumulative injected mass / rho0 [m^3].
    formation_volume : ndarray, shape (k + 1,)
        Cumulative mass that left the well into the formation / rho0 [m^3].
    mass_balance_error : ndarray, shape (k + 1,)
        Relative mass-balance error of each step (first entry 0).
    cumulative_mass_error : float
        ``|sum of step errors|`` over the cumulative throughput.
    state : FlowState
        Final state.
    snapshots : dict float -> FlowState
        States at the requested ``snapshot_times`` that were reached.
    counters : FlowCounters
        Work done during this run.
    wall_time : float
        [s].
    """

    status: int
    message: str
    times: np.ndarray
    p_w: np.ndarray
    well_rate: np.ndarray
    formation_rate: np.ndarray
    injected_volume: np.ndarray
    formation_volume: np.ndarray
    mass_balance_error: np.ndarray
    cumulative_mass_error: float
    state: FlowState
    snapshots: dict = field(default_factory=dict)
    counters: FlowCounters = field(default_factory=FlowCounters)
    wall_time: float = 0.0

    @property
    def success(self) -> bool:
        """True if the run reached its end time."""
        return self.status == 0


class FlowStepper:
    """Adaptive backward-Euler integration of a :class:`FlowModel`.

    Parameters
    ----------
    model : FlowModel
    state : FlowState
        Initial state.
    control : StepControl, optional

    Attributes
    ----------
    state : FlowState
        Current (last accepted) state.
    dt : float
        Step to try next [s].
    counters : FlowCounters
    """

    def __init__(self, model: FlowModel, state: FlowState,
                 control: StepControl | None = None) -> None:
        if state.p.shape != (model.n_cells,):
            raise InputError(f"state has {state.p.shape[0]} cells, model {model.n_cells}",
                             key="state")
        self.model = model
        self.state = state
        self.control = control if control is not None else StepControl()
        self.dt = float(self.control.dt_initial)
        self.counters = FlowCounters()

    # ------------------------------------------------------------------ one step
    def _newton(self, dt: float, extra_pore_volume=None, permeability=None):
        """Solve one step; return (status, iterate, last residual, iterations, solves)."""
        ctl = self.control
        model = self.model
        old = self.state
        vx = old.extra_pore_volume if extra_pore_volume is None else extra_pore_volume
        it = FlowState(old.t + dt, old.p, old.p_w, vx)
        if model.well.pressure_controlled:
            # start from the prescribed value: the well row is then satisfied exactly
            it = FlowState(it.t, it.p, model.well.pressure_at(it.t), vx)
        mass = float(np.sum(model.cell_mass(old)))
        atol = 1e-18 * mass / dt
        pc = model.well.pressure_controlled and model.has_well
        iters = solves = 0
        lu = None
        last = np.inf
        tiny_update = False
        while True:
            res = model.residual_and_jacobian(it, old, dt, permeability=permeability)
            self.counters.residual_evaluations += 1
            R = res.residual
            if not np.all(np.isfinite(R)):
                return "newton: non-finite", it, res, iters, solves
            mass_res = float(np.sum(np.abs(R[:-1] if pc else R)))
            ok = mass_res <= ctl.newton_rtol * res.throughput + atol
            if not ok and (tiny_update or mass_res >= 0.5 * last):
                # stagnation (the last update moved x by a few ulps, or the residual no
                # longer halves): round-off level; accept if far inside the requirement
                ok = mass_res <= ctl.stagnation_rtol * res.throughput + atol
            if pc:
                ok = ok and abs(R[-1]) <= 1e-6 * res.jacobian[-1, -1]
            if ok:
                return "converged", it, res, iters, solves
            if iters >= ctl.max_newton:
                return "newton: no convergence", it, res, iters, solves
            # chord iteration: keep the LU factors while the residual falls fast (the
            # problem is nearly linear: the Jacobian changes by ~c_f dp per iteration)
            if lu is None or not (mass_res < ctl.reuse_contraction * last):
                try:
                    lu = spla.splu(res.jacobian.tocsc())
                except RuntimeError:  # "Factor is exactly singular"
                    return "newton: singular", it, res, iters, solves
                self.counters.factorizations += 1
            last = mass_res
            dx = lu.solve(-R)
            solves += 1
            iters += 1
            if not np.all(np.isfinite(dx)):
                return "newton: non-finite", it, res, iters, solves
            x = it.x
            tiny_update = bool(np.max(np.abs(dx)) <= 8.0 * np.finfo(float).eps
                               * np.max(np.abs(x)))
            it = it.with_x(x + dx)

    def step(self, dt: float | None = None, *, extra_pore_volume=None,
             permeability=None) -> StepResult:
        """Try one step of size ``dt`` (default ``self.dt``); accept it if it succeeds.

        On success the state advances and ``self.dt`` is grown or kept for the next step;
        on failure the state is unchanged and ``self.dt`` is cut. ``dt`` itself is used
        as given (no internal retry; :meth:`run` does the retrying).

        Parameters
        ----------
        dt : float, optional
            Step [s].
        extra_pore_volume : ndarray, shape (m,), optional
            Pore volume from the skeleton at the end of the step [m^3] (a staggered
            hydro-mechanical scheme passes the mechanics' crack / strain volume here; its
            change from the current state is the ``dV_pore/dt`` term, mass-conservative).
            Default: unchanged.
        permeability : ndarray, shape (m,), optional
            Cell permeability for this step [m^2] (e.g. aperture-dependent, Eq. 4.3).
            Default: the rock's.

        Returns
        -------
        StepResult
        """
        dt = float(self.dt if dt is None else dt)
        if not (dt > 0 and np.isfinite(dt)):
            raise InputError(f"time step must be > 0, got {dt!r}", key="dt")
        ctl = self.control
        model = self.model
        old = self.state
        if extra_pore_volume is not None:
            extra_pore_volume = np.asarray(extra_pore_volume, dtype=float)
            if extra_pore_volume.shape != (model.n_cells,):
                raise InputError(f"needs shape ({model.n_cells},)", key="extra_pore_volume")
        status, new, res, iters, solves = self._newton(dt, extra_pore_volume, permeability)
        self.counters.newton_iterations += iters
        self.counters.linear_solves += solves
        if status != "converged":
            self.counters.cuts += 1
            self.dt = max(dt * ctl.cut, 0.0)
            return StepResult(False, status, iters, solves, dt, old.t)
        max_dp = float(np.max(np.abs(new.x - old.x)))
        if max_dp > ctl.dp_max:
            self.counters.cuts += 1
            self.dt = dt * min(ctl.cut if iters > ctl.easy_iterations else 0.9,
                               0.8 * ctl.dp_max / max_dp)
            return StepResult(False, "dp limit", iters, solves, dt, old.t, max_dp=max_dp)
        rho0 = model.fluid.density
        m_in = res.injection_rate * dt
        m_out = res.boundary_rate * dt
        d_stored = (float(np.sum(res.storage_rate_cells)) + res.storage_rate_well) * dt
        err = m_in - d_stored - m_out
        scale = res.throughput * dt
        rel = abs(err) / scale if scale > 0 else (0.0 if err == 0 else np.inf)
        self.state = new
        self.counters.steps += 1
        if iters <= ctl.easy_iterations and max_dp <= 0.5 * ctl.dp_max:
            self.dt = min(dt * ctl.growth, ctl.dt_max)
        else:
            self.dt = min(dt, ctl.dt_max)
        return StepResult(True, "converged", iters, solves, dt, new.t, max_dp=max_dp,
                          injected_mass=m_in, outflow_mass=m_out, stored_mass_change=d_stored,
                          mass_balance_error=err, relative_mass_balance_error=rel,
                          well_rate=res.injection_rate / rho0,
                          formation_rate=res.formation_rate / rho0)

    # ------------------------------------------------------------------ many steps
    def run(self, t_end: float, progress: Callable[[float, float], None] | None = None, *,
            stop_times: Sequence[float] = (), snapshot_times: Sequence[float] = (),
            max_steps: int = 1_000_000) -> FlowResult:
        """Integrate from the current time to ``t_end``.

        Parameters
        ----------
        t_end : float
            End time [s] (>= current time).
        progress : callable(t, t_end), optional
            Called after every accepted step.
        stop_times : sequence of float, optional
            Times the steps must end on exactly (rate changes of a schedule).
        snapshot_times : sequence of float, optional
            Times at which to keep the state (also step ends).
        max_steps : int
            Stop (status 1) after this many accepted steps.

        Returns
        -------
        FlowResult
        """
        t0_wall = _time.perf_counter()
        start = FlowCounters(**vars(self.counters))
        ctl = self.control
        t_end = float(t_end)
        if not (t_end >= self.state.t):
            raise InputError(f"t_end {t_end} is before the current time {self.state.t}",
                             key="t_end")
        marks = sorted({float(t) for t in (*stop_times, *snapshot_times)
                        if self.state.t < float(t) < t_end} | {t_end})
        snaps_wanted = {float(t) for t in snapshot_times}
        times = [self.state.t]
        pw = [self.state.p_w]
        q = [np.nan]
        qf = [np.nan]
        vol = [0.0]
        fvol = [0.0]
        rel = [0.0]
        snapshots: dict[float, FlowState] = {}
        if self.state.t in snaps_wanted:
            snapshots[self.state.t] = self.state
        err_sum = 0.0
        thr_sum = 0.0
        status, message = 0, "reached t_end"
        rho0 = self.model.fluid.density
        mi = 0
        n_acc = 0
        while self.state.t < t_end:
            while marks[mi] <= self.state.t:
                mi += 1
            target = marks[mi]
            dt = min(self.dt, ctl.dt_max)
            remaining = target - self.state.t
            landing = dt >= remaining * (1.0 - 1e-12)
            if landing:
                dt = remaining
            elif dt > 0.5 * remaining:
                dt = 0.5 * remaining  # avoid a sliver step before the mark
            if dt < ctl.dt_min and not landing:
                status, message = -1, f"step size {dt:.3g} s below dt_min at t = " \
                                       f"{self.state.t:.6g} s"
                break
            res = self.step(dt)
            if not res.success:
                if dt <= ctl.dt_min:
                    status, message = -1, (f"{res.reason} at t = {self.state.t:.6g} s with "
                                           f"dt = {dt:.3g} s <= dt_min")
                    break
                continue
            if landing:
                # snap exactly onto the mark (avoid round-off drift of t)
                self.state = FlowState(target, self.state.p, self.state.p_w,
                                       self.state.extra_pore_volume)
            n_acc += 1
            times.append(self.state.t)
            pw.append(self.state.p_w)
            q.append(res.well_rate)
            qf.append(res.formation_rate)
            vol.append(vol[-1] + res.injected_mass / rho0)
            fvol.append(fvol[-1] + res.formation_rate * res.dt)
            rel.append(res.relative_mass_balance_error)
            err_sum += res.mass_balance_error
            thr_sum += abs(res.injected_mass) + abs(res.outflow_mass) + abs(
                res.stored_mass_change)
            if self.state.t in snaps_wanted:
                snapshots[self.state.t] = self.state
            if progress is not None:
                progress(self.state.t, t_end)
            if n_acc >= max_steps and self.state.t < t_end:
                status, message = 1, f"stopped after max_steps = {max_steps}"
                break
        used = FlowCounters(**{k: v - getattr(start, k) for k, v in vars(self.counters).items()})
        return FlowResult(
            status=status, message=message, times=np.array(times), p_w=np.array(pw),
            well_rate=np.array(q), formation_rate=np.array(qf),
            injected_volume=np.array(vol), formation_volume=np.array(fvol),
            mass_balance_error=np.array(rel),
            cumulative_mass_error=abs(err_sum) / thr_sum if thr_sum > 0 else 0.0,
            state=self.state, snapshots=snapshots, counters=used,
            wall_time=_time.perf_counter() - t0_wall)
