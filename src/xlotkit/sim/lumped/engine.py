"""The lumped model as a stepwise engine (:class:`LumpedEngine`) and :func:`simulate_lumped`."""

from __future__ import annotations

import dataclasses
import json
import math
import time as _time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from xlotkit.errors import InputError
from xlotkit.record import Event
from xlotkit.sim.lumped.results import RunLog, make_record
from xlotkit.sim.lumped.solver import State, StepSolver, _event_value, _view, locate
from xlotkit.sim.run.contract import EngineResult, StepCounters, StepOutcome, series_rows
from xlotkit.sim.scene.lumped import LumpedScene
from xlotkit.sim.well import WellDrive, phase_place

__all__ = ["LumpedEngine", "LumpedResult", "LumpedStepControl", "StepOutcome",
           "simulate_lumped"]

#: What a finished lumped run returns: the one result type of every engine.
LumpedResult = EngineResult


def simulate_lumped(scene: LumpedScene, *,
                    progress: Callable[[float], None] | None = None) -> EngineResult:
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
_STATE_FIELDS = tuple(f.name for f in dataclasses.fields(State))


@dataclass(frozen=True)
class LumpedStepControl:
    """The lumped engine's step rules (the accuracy control itself is the scene's
    ``dp_max``; steps never pass a log sample, a rate step or a phase end).

    Attributes
    ----------
    cut : float
        A trial whose well or fracture pressure changes by more than ``dp_max`` is repeated
        ``cut`` times as long ...
    min_cut_step : float
        ... unless it is already this short [s] (then it is taken).
    growth : float
        After an accepted step the next may be ``growth`` times as long (up to the log
        interval).
    closure_band : float
        Band [Pa] around ``sigma_h`` (and ``P_r``) taken as "at closure" / "at reopening"
        when events are armed; also decides whether the wellbore reopening model seals a
        closed fracture (``P_r`` measurably above ``sigma_h``).
    """

    cut: float = 0.5
    min_cut_step: float = 1e-3
    growth: float = 2.0
    closure_band: float = 1e-3


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

    def __init__(self, scene: LumpedScene, control: LumpedStepControl | None = None) -> None:
        if not isinstance(scene, LumpedScene):
            raise InputError(f"not a LumpedScene: {scene!r}", key="scene",
                             expected="a xlotkit.sim.lumped.LumpedScene")
        self.sc = scene
        self.control = LumpedStepControl() if control is None else control
        self._plan = scene.schedule.expanded()
        self._started = False

    # ------------------------------------------------------------------ protocol
    def start(self) -> None:
        """Set up the state at t = 0 (the well at its initial pressure, no fracture)."""
        sc = self.sc
        self._wall0 = _time.perf_counter()
        self._wall_before = 0.0
        self.sim = sim = StepSolver(sc, closure_band=self.control.closure_band)
        self._well = WellDrive(sim.col)
        self._p_init = sc.p_initial
        ps0 = self._well.idle().surface(self._p_init)[0]
        self.s = State(t=0.0, p=self._p_init, ps=ps0, pf=self._p_init)
        sim.push(self.s)
        self._i_ph = 0
        self._in_phase = False
        # what the run has met so far (the truth's events)
        self.log = RunLog()
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
            return self._outcome(False, "done")
        if not self._in_phase:
            self._begin_phase()
            if self._reason:
                reason = self._reason
                self._end_phase()
                return self._outcome(True, "phase end at start: " + reason)
            return self._outcome(True, "phase start")
        accepted = self._iterate()
        if not accepted:
            return self._outcome(False, "rejected: pressure change above dp_max")
        if self._reason:
            reason = self._reason
            self._end_phase()
            return self._outcome(True, "phase end: " + reason)
        return self._outcome(True, "accepted")

    def _outcome(self, success: bool, reason: str) -> StepOutcome:
        sim = self.sim
        return StepOutcome(success, self.s.t, reason,
                           StepCounters(accepted=sim.n_steps, rejected=sim.n_rejected,
                                        events=sim.n_events))

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
        return series_rows({
            "t": h["t"], "bottomhole_pressure": h["p"], "fracture_pressure": h["pf"],
            "surface_pressure": h["ps"], "pump_rate": h["q_in"], "return_rate": h["q_ret"],
            "pumped_volume": h["v_in"], "returned_volume": h["v_ret"],
            "leakoff_volume": h["v_carter"] + h["v_wall"], "fracture_length": h["L"],
            "fracture_volume": h["vf"], "mass_balance_error": mb,
        })

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
            "phases_out": self.log.phases_out,
            "events": [[e.t, e.text] for e in self.log.events],
            "closure_times": self.log.closure_times, "reopening_times": self.log.reopening_times,
            "reopening_ps": self.log.reopening_ps,
            "last_pump_p": [[k, v] for k, v in self.log.last_pump_p.items()],
            "isip": [[k, v] for k, v in self.log.isip.items()],
            "breakdown_time": self.log.breakdown_time, "initiation_time": self.log.initiation_time,
            "initiation_p": self.log.initiation_p, "fbp": self.log.fbp, "status": self.log.status,
            "messages": self.log.messages,
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
                    for k in StepSolver.HIST_KEYS}
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
        self.s = State(**scal["state"])
        self._i_ph, self._in_phase = int(scal["i_ph"]), bool(scal["in_phase"])
        self._t0, self._v_in0, self._v_ret0 = scal["t0"], scal["v_in0"], scal["v_ret0"]
        self._reason, self._dt_adapt = scal["reason"], scal["dt_adapt"]
        self._n_loop = int(scal["n_loop"])
        self.log.phases_out = scal["phases_out"]
        self.log.events = [Event(t=t, text=x) for t, x in scal["events"]]
        self.log.closure_times = scal["closure_times"]
        self.log.reopening_times = scal["reopening_times"]
        self.log.reopening_ps = scal["reopening_ps"]
        self.log.last_pump_p = {int(k): v for k, v in scal["last_pump_p"]}
        self.log.isip = {int(k): v for k, v in scal["isip"]}
        self.log.breakdown_time = scal["breakdown_time"]
        self.log.initiation_time = scal["initiation_time"]
        self.log.initiation_p = scal["initiation_p"]
        self.log.fbp = scal["fbp"]
        self.log.status, self.log.messages = scal["status"], scal["messages"]
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
        self.log.events.append(Event(t=self._t0, text=f"cycle {cyc}: {ph.label}"))
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
            self.log.status = "stopped"
            self.log.messages.append(f"phase {i_ph + 1} ({ph.label}, cycle {cyc}) hit "
                                 f"max_phase_duration {sc.max_phase_duration:g} s before its "
                                 f"end condition")
        if ph.pumps and i_ph + 1 < n_ph and not self._plan[i_ph + 1][1].pumps:
            # ISIP: the well pressure once the entry loss has gone, i.e. the fracture
            # pressure at shut-in (= the well pressure without entry loss or fracture).
            self.log.isip[cyc] = s.pf if (s.broken and not s.sealed) else s.p
            self.log.last_pump_p[cyc] = s.p
        self.log.phases_out.append({"cycle": cyc, "kind": ph.kind, "name": ph.label,
                                "t_start": self._t0, "t_end": s.t, "end": reason})
        self._i_ph += 1
        self._in_phase = False
        self._reason = ""

    # ------------------------------------------------------------------ one loop pass
    def _iterate(self) -> bool:
        """One pass of the adaptive loop; False if the trial step was rejected."""
        sc, sim, drive = self.sc, self.sim, self._drive
        ctl = self.control
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
                and dt > ctl.min_cut_step):
            self._dt_adapt = ctl.cut * dt
            sim.n_rejected += 1
            return False
        # ---- events in this step: armed at the start, fired at the end
        armed: dict[str, Callable[[State, float], float]] = {}
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
                dt_e = locate(lambda d, fn=armed[name]: _event_value(sim, s, drive, q_pump, fn, d),
                               dt)
                best_dt = min(best_dt, dt_e)
            if best_dt < dt:
                st = sim.solve(s, best_dt, drive, q_pump)
            hit = [n for n, fn in armed.items() if fn(_view(s, st), st.ps) <= 0.0]
            sim.n_events += len(hit)
        if st.jump and self.log.fbp is None:   # an unstable jump not caught as an event
            self.log.fbp, self.log.breakdown_time = s.p, s.t
        s = sim.accept(s, st, q_pump)
        self._dt_adapt = min(dt_out, ctl.growth * self._dt_adapt)
        reason = self._reason
        for name in hit:
            if name == "closure":
                # With the entry loss and reopening at sigma_h, a well a few Pa above
                # sigma_h can refill a just-closed fracture for an instant; count one
                # closure until a reopening has been recorded.
                if len(self.log.closure_times) <= len(self.log.reopening_times):
                    self.log.closure_times.append(s.t)
                if sim.seal:
                    # The faces are in contact; the mouth now needs P_r to reopen.
                    s.sealed = True
                    s.pf = s.p
            elif name == "reopening":
                self.log.reopening_times.append(s.t)
                self.log.reopening_ps.append(s.p)
            elif name == "reopening_wall":
                # The wall lets go: the fracture, at its old size, meets net pressure
                # P_r - sigma_h. A zero-length step redistributes the well's volume
                # into it (at fixed L, or growing if K_I > K_Ic) -- the same
                # volume-conserving jump as at breakdown.
                self.log.reopening_times.append(s.t)
                self.log.reopening_ps.append(s.p)
                s.sealed = False
                s.pf = s.p
                s = sim.accept(s, sim.solve(s, 0.0, drive, q_pump), q_pump)
            elif name == "breakdown":
                # Hubbert-Willis initiation: the flaw becomes a fracture; it jumps at
                # once if K_I(P_b, L_0) > K_Ic, else later ("unstable").
                self.log.initiation_time, self.log.initiation_p = s.t, s.p
                s.broken = True
                s.L = sc.initial_flaw
                st0 = sim.solve(s, 0.0, drive, q_pump)
                if st0.jump and self.log.fbp is None:
                    self.log.fbp, self.log.breakdown_time = s.p, s.t
                s = sim.accept(s, st0, q_pump)
            elif name == "unstable":
                if self.log.fbp is None:
                    self.log.fbp, self.log.breakdown_time = s.p, s.t
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
    def result(self) -> EngineResult:
        """The outcome once :meth:`is_done` (record on the output grid, truth)."""
        if not self.is_done():
            raise RuntimeError("LumpedEngine.result() before the run is done")
        sc, sim = self.sc, self.sim
        p_init = self._p_init
        status = self.log.status
        hist = {k: np.asarray(v, dtype=float) for k, v in sim.hist.items()}
        record = make_record(sc, sim.cw, sim.col.tvd, hist, self.log.events)
        v_leak = hist["v_carter"] + hist["v_wall"]
        resid_cum = (hist["v_in"] - hist["v_ret"] - sim.cw * (hist["p"] - p_init)
                     - hist["vf"] - v_leak)
        denom = max(float(np.max(hist["v_in"] + hist["v_ret"])), 1e-300)
        mb = np.asarray(sim.mb_err)
        if status == "ok":
            msg = (f"{sc.schedule.n_cycles} cycle(s), {sim.n_steps} steps, "
                   f"max step mass-balance error {mb.max() if mb.size else 0.0:.2e}")
        else:
            msg = "; ".join(self.log.messages)
        truth: dict[str, Any] = {
            "sigma_h": sc.sigma_h, "sigma_H": sc.sigma_H, "pore_pressure": sc.pore_pressure,
            "tensile_strength": sc.tensile_strength,
            "breakdown_pressure_model": sc.breakdown_pressure,
            "fbp": self.log.fbp, "breakdown_time": self.log.breakdown_time,
            "initiation_pressure": self.log.initiation_p, "initiation_time": self.log.initiation_time,
            "reopening_pressure_model": sim.pr, "reopening_model": sc.reopening,
            "closure_times": list(self.log.closure_times),
            "reopening_times": list(self.log.reopening_times),
            "reopening_pressures": list(self.log.reopening_ps),
            "isip": dict(self.log.isip), "last_pump_pressure": dict(self.log.last_pump_p),
            "nwb_coefficient": sc.nwb_coefficient, "phases": list(self.log.phases_out),
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
        return EngineResult(status=status, message=msg, record=record, truth=truth)


def _scalar(v: Any) -> Any:
    """A Python scalar from a 0-d array or a scalar."""
    return v.item() if isinstance(v, np.ndarray) else v
