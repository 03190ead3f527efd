"""The 2D MDEM hydro-mechanical model as a stepwise XLOT engine (``model = "mdem"``).

:class:`MDEMEngine` runs a :class:`~xlotkit.sim.scene.Scene` with the monolithic coupled
model (:class:`~xlotkit.sim.coupling.CoupledModel`): nodal displacements, cell pressures and
the borehole pressure ``p_w`` solved together each step, the whole well as storage on
``p_w``, and the schedule (pump, shut-in, choke flowback, bleed) as the well's rate
``Q(t, p_w)``. It follows the engine protocol of :mod:`xlotkit.sim.run`.

Scene -> model (what is assembled; SPEC §2-§6)
----------------------------------------------
* mesh: ``[mesh]`` (graded borehole mesh; a fracture band along sigma_H when asked; a mesh
  file read by meshio instead), domain ``geometry.domain_size``, hole ``geometry.hole_radius``.
* rock: E, nu, Biot alpha, T0, S0, phi, k; ``effects.heterogeneity`` (uniform +-
  ``rock.heterogeneity`` on the strengths, seeded), ``effects.strength_scaling`` (crack-tip
  size scaling, ``(A_ref / A)^m``; ``rock.toughness`` sets ``A_ref`` from ``K_IC``),
  ``[[effects.interface]]`` planes of weakness, ``effects.fracture_plane`` (failed clusters
  of the fracture band open and close as a smooth joint along sigma_H, with
  ``rock.fracture_friction_angle``; :class:`~xlotkit.sim.mechanics.FracturePlane`).
* stresses: sigma_H along ``sigma_H_azimuth``, sigma_h across it (the 2D far field gets the
  rotated components), pore pressure p0; the borehole starts at the static mud column
  (``completion.initial_pressure`` or the hydrostatic column of the fluid), in equilibrium.
* ``effects.poroelastic``: when off (default) the intact rock's skeleton is decoupled from its
  pore fluid (Biot alpha = 0 for intact clusters, no grain compressibility), as in the
  classical hydraulic-fracture models: the coupled Jacobian has no pressure-coupling
  entries for intact clusters (:mod:`xlotkit.sim.coupling.assembly`); failed clusters
  always carry the fluid pressure with coefficient 1 and store the crack volume. When on,
  alpha = ``rock.biot`` with the grain term of the pore compressibility (docs/coupling.md).
* well storage: ``effects.well_storage`` adds the whole well's compliance (completion and
  fluid, :func:`xlotkit.sim.well.well_compliance`, or ``completion.well_compliance``) on
  top of the segment's own hole volume; the segment is ``geometry.segment_height`` tall, so
  the 2D model *is* the open-hole segment (rates are not scaled).
* surface pressure: the fluid column (hydrostatic with rho(p); with
  ``effects.pipe_friction`` also Haaland friction) from the bottom-hole pressure and rate;
  the choke of a flowback sees the surface pressure, ``Q = zeta sqrt(p_s)``, inside the
  implicit step.

Steps: each :meth:`MDEMEngine.step` is one trial of :meth:`CoupledStepper.attempt` with the
thesis's failure-count control (cut when more than ``numerics.n2`` clusters fail, grow when
fewer than ``numerics.n1``), the stepper's rules for a crack running into the well's storage
(the failure limit follows the crack's size; a floor step is solved by continuation in its
length and, failing that, stepped over by longer steps; a failed solve is tried again from
the solution of a longer step; clusters fail in a chain within a step no farther than the
Rayleigh-wave speed allows), the Newton and well-pressure-change (``numerics.dp_max``)
rules, a floor ``dt_min`` and a ceiling ``dt_max``. A step that reverses a crack's
open/closed change of the previous step is repeated shorter (docs/coupling.md, "Hard
cases"). A subclass may add a rule of its own (:meth:`MDEMEngine._reject_step`; the
partitioned engine's coupling rule). Phase ends on time
and on volume at a known rate are landed on exactly; pressure ends and flowback volumes are
located by repeating the step shorter (secant on the crossing) until within 10 kPa (or 0.1 %
of the volume). Every accepted step has its relative mass-balance error checked by the
stepper (<= 1e-8).

Truth: besides the scene's inputs, :meth:`MDEMEngine.result` reports what the model
realised (``truth["realised"]``): the stresses normal to and along the crack's plane in the
in-situ state over the crack (what the crack closes against, and the far-field stress along
it), the strength of the wall where it started, the wall's hoop stress (see
:func:`xlotkit.sim.coupling.results.realised_truth`).
"""

from __future__ import annotations

import json
import math
import time as _time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from xlotkit import formulas
from xlotkit.errors import InputError, XlotkitError
from xlotkit.sim.coupling.build import (
    RESIDUAL_APERTURE,
    build_model,
    total_well_compliance,
    well_column,
)
from xlotkit.sim.coupling.geometry import fracture_summary
from xlotkit.sim.coupling.model import CoupledState
from xlotkit.sim.coupling.results import make_record, realised_truth
from xlotkit.sim.coupling.stepper import (
    CoupledControl,
    CoupledCounters,
    CoupledStepper,
    TimeStepControl,
)
from xlotkit.sim.flow import FlowState
from xlotkit.sim.mechanics import FAILED_SHEAR, FAILED_TENSILE, PRESET, MechanicsState
from xlotkit.sim.output import Snapshot
from xlotkit.sim.run.contract import EngineResult, StepCounters, StepOutcome, series_rows
from xlotkit.sim.scene import Scene
from xlotkit.sim.well import (
    ColumnBlowUp,
    PhaseDrive,
    WellDrive,
    phase_place,
    surface_from_bottomhole,
)

__all__ = ["RESIDUAL_APERTURE", "EventControl", "MDEMEngine", "MDEMResult",
           "MDEMStepOutcome", "Stepping", "build_model", "total_well_compliance",
           "well_column"]

#: Rock bulk density [kg/m^3] for the crack-speed limit only (the model is quasi-static
#: and has no other use for it); a typical sedimentary rock.
ROCK_DENSITY = 2500.0


@dataclass(frozen=True)
class EventControl:
    """The 2D engine's own step rules, on top of the stepper's (:class:`TimeStepControl`).

    Attributes
    ----------
    first_step : float
        The run's first step [s] is ``min(first_step, numerics.dt_max)``.
    phase_start_step : float
        A phase starts with a step of at least this [s] (the last phase may have ended on
        a floor step).
    pressure_tol : float
        A pressure end of a phase is located to within this [Pa] (10 kPa) by repeating the
        step shorter.
    volume_rtol : float
        A flowback's volume end likewise, relative to the volume.
    locate_tries : int
        Shorter repeats per located end before the step is taken as it is.
    locate_clamp : (float, float)
        The secant's fraction of the step is kept within these bounds.
    locate_overshoot : float
        The repeat is that fraction times ``1 + locate_overshoot`` (lands just past the
        end, not just before it).
    dp_fraction : float
        A step rejected by the pressure-change rule (``numerics.dp_max`` on a step without
        failures) is repeated scaled to ``dp_fraction * dp_max`` of change.
    resolve_crack_reversals : bool
        Repeat shorter a step in which a crack reverses the open/closed change of the step
        before (docs/coupling.md, "Hard cases").
    """

    first_step: float = 1.0
    phase_start_step: float = 1e-3
    pressure_tol: float = 1e4
    volume_rtol: float = 1e-3
    locate_tries: int = 8
    locate_clamp: tuple[float, float] = (0.05, 0.95)
    locate_overshoot: float = 1e-3
    dp_fraction: float = 0.5
    resolve_crack_reversals: bool = True


@dataclass(frozen=True)
class Stepping:
    """All step-control knobs of a 2D run, grouped: the Newton and failure settings of one
    step (:class:`CoupledControl`), the adaptive time stepping (:class:`TimeStepControl`:
    the thesis's failure-count rule, floor and ceiling, pressure change, continuation and
    jumps at the floor) and the engine's event rules (:class:`EventControl`).
    :meth:`from_scene` sets them from ``[numerics]``."""

    newton: CoupledControl
    time: TimeStepControl
    events: EventControl = EventControl()

    @classmethod
    def from_scene(cls, scene: Scene) -> Stepping:
        """``numerics.max_newton``, ``dt_min``, ``dt_max``, ``n1``, ``n2``, ``dp_max``; the
        crack-speed limit is the rock's Rayleigh-wave speed."""
        num = scene.numerics
        ev = EventControl()
        newton = CoupledControl(max_newton=int(num.max_newton),
                                crack_speed=formulas.rayleigh_speed(
                                    scene.rock.youngs_modulus, scene.rock.poisson_ratio,
                                    ROCK_DENSITY))
        time = TimeStepControl(dt_initial=min(ev.first_step, num.dt_max), dt_min=num.dt_min,
                               dt_max=num.dt_max, n1=int(num.n1), n2=int(num.n2),
                               dp_max=float(num.dp_max))
        return cls(newton, time, ev)


_MECH_FIELDS = ("displacement", "pore_pressure", "stress", "effective_stress",
                "cluster_state", "contact_status", "normal_force", "shear_force", "gap",
                "slip", "ref_normal", "ref_shear", "crack_normal")
_ROW_KEYS = ("t", "bottomhole_pressure", "well_pressure", "surface_pressure",
             "fracture_pressure", "pump_rate", "return_rate", "pumped_volume",
             "returned_volume", "leakoff_volume", "fracture_length", "fracture_volume",
             "failed_clusters", "mass_balance_error")


#: The step and result types of the 2D engine: the engine contract's (one for every engine).
MDEMStepOutcome = StepOutcome
MDEMResult = EngineResult


# =========================================================================== engine
class MDEMEngine:
    """The 2D coupled MDEM model as a stepwise engine (protocol of :mod:`xlotkit.sim.run`).

    Parameters
    ----------
    scene : Scene
        A scene whose resolved model is ``mdem`` (or any scene: the 2D model runs it).
    callback : callable ``(engine) -> None``, optional
        Called after every accepted step (library progress reporting).
    """

    model = "mdem"

    def __init__(self, scene: Scene, callback=None) -> None:
        if not isinstance(scene, Scene):
            raise InputError(f"not a Scene: {scene!r}", key="scene")
        if scene.coupling != "monolithic":
            raise InputError(
                f"coupling {scene.coupling!r} runs on the partitioned 2D engine "
                "(xlotkit.sim.coupling.partitioned, chosen by xlotkit.sim.run.make_engine); "
                "MDEMEngine couples the well monolithically", key="coupling",
                file=scene.source_file, expected="'monolithic' for MDEMEngine")
        self.scene = scene
        self._plan = scene.schedule.expanded()
        self._callback = callback
        self._started = False

    # ------------------------------------------------------------------ set-up
    def _build(self) -> None:
        sc = self.scene
        self.cm, self.pw0 = build_model(sc)
        self.cm.well_rate = self._well_rate
        self.column = well_column(sc)
        # the well head: rates, surface pressure and phase ends of the phase in force
        self._well = WellDrive(self.column)
        self.stepping = Stepping.from_scene(sc)
        self.control = self.stepping.newton       # Newton and failure rules of a step
        self.tsc = self.stepping.time             # adaptive time stepping
        self.rho0 = float(self.cm.flow.fluid.density)
        mesh = self.cm.mesh
        wall = np.zeros(mesh.n_nodes, dtype=bool)
        wall[mesh.hole_nodes] = True
        self._at_wall = wall[mesh.triangles].any(axis=1)      # clusters touching the hole
        self._wall0 = _time.perf_counter()

    def _fresh_state(self) -> CoupledState:
        return self.cm.initial_state(p_w=self.pw0)

    def start(self) -> None:
        """The in-situ equilibrium at t = 0: drilled hole at the mud column, no fracture."""
        self._build()
        st = self._fresh_state()
        # total stress of the in-situ state (for the realised sigma_h, see results.realised_truth)
        self._stress0 = self.cm.stress(st)
        self.stepper = CoupledStepper(self.cm, st, self.control)
        self._m_intact0 = self.cm.flow.cell_mass(st.flow)
        self._h = min(self.stepping.events.first_step, self.scene.numerics.dt_max)
        self._i_ph = 0
        self._in_phase = False
        self._drive: PhaseDrive = self._well.idle()
        # time targets of the phase in force [s]: its end (duration, or a volume at a known
        # rate), the safety limit and the rate steps
        self._targets: dict[str, Any] = {}
        self._v_in = self._v_ret = self._v_out = 0.0
        self._retry: dict[str, Any] | None = None
        self._running = False      # the last step failed clusters into a falling p_w
        self._open_hist: tuple[np.ndarray, np.ndarray] | None = None
        self._rows: dict[str, list[float]] = {k: [] for k in _ROW_KEYS}
        self.phases_out: list[dict[str, Any]] = []
        self.events: list[tuple[float, str]] = []
        self.status: Literal["ok", "stopped"] = "ok"
        self.messages: list[str] = []
        self.truth_events: dict[str, Any] = {"fbp": None, "breakdown_time": None,
                                             "initiation_time": None,
                                             "initiation_pressure": None,
                                             "isip": {}, "last_pump_pressure": {}}
        self._wall_before = 0.0
        self._started = True
        self._push_row(st, q=0.0, mb=math.nan)

    # ------------------------------------------------------------------ well rate
    def _well_rate(self, t: float, p_w: float):
        """``(Q, dQ/dp_w)`` of the phase in force [m^3/s at surface density, per segment]
        (:meth:`xlotkit.sim.well.PhaseDrive.rate`). A Newton iterate at a borehole
        pressure no fluid column can stand under (the column's density blows up) or at
        which the choke's column overflows gets a non-finite rate, which the Newton treats
        as a wild update (it backs off, or the step is cut), not a failure of the run."""
        try:
            return self._drive.rate(t, p_w)
        except (ColumnBlowUp, OverflowError):
            return math.nan, math.nan

    def _surface(self, p_bh: float, rate: float) -> float:
        """Surface gauge pressure [Pa] from the bottom-hole pressure and the rate."""
        return surface_from_bottomhole(p_bh, rate, self.column)

    # ------------------------------------------------------------------ protocol
    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return self.stepper.state.t

    def is_done(self) -> bool:
        """True once every phase of the schedule has ended."""
        return self._started and self._i_ph >= len(self._plan)

    def progress(self) -> float:
        """Fraction of the schedule done, 0..1 (non-decreasing)."""
        n = len(self._plan)
        if not self._started:
            return 0.0
        if self._i_ph >= n:
            return 1.0
        if not self._in_phase:
            return self._i_ph / n
        return (self._i_ph + min(max(self._phase_fraction(), 0.0), 0.999)) / n

    def _phase_fraction(self) -> float:
        _, ph = self._plan[self._i_ph]
        tau = self.time - self._drive.t0
        fr = 0.0
        if ph.max_duration:
            fr = max(fr, tau / ph.max_duration)
        vt = ph.volume_target
        if vt:
            fr = max(fr, self._drive.volume_done(self._v_in, self._v_ret) / vt)
        return fr

    def _begin_phase(self) -> str:
        """Set up the phase's drive and time targets; returns an end reason if already met."""
        cyc, ph = self._plan[self._i_ph]
        st = self.stepper.state
        t0 = st.t
        try:
            self._drive = self._well.begin(
                ph, t0=t0, p_bh=st.p_w, v_in=self._v_in, v_ret=self._v_ret,
                where=phase_place(self._i_ph, cyc, len(self.scene.schedule.phases)))
        except InputError as exc:
            raise InputError(exc.message, key=exc.key, file=self.scene.source_file,
                             expected=exc.expected) from None
        self._targets = self._phase_targets(ph, t0)
        self._in_phase = True
        self._h = min(max(self._h, self.stepping.events.phase_start_step),
                      self.scene.numerics.dt_max)
        self.events.append((t0, f"cycle {cyc}: {ph.label}"))
        for name, val in self._end_margins(st.p_w, self._v_in, self._v_ret).items():
            if val <= 0.0:
                return name
        return ""

    def _phase_targets(self, ph, t0: float) -> dict[str, Any]:
        """The phase's time targets from its start ``t0``: ``t_end`` (duration, and a volume
        at a known rate), ``limit`` (``numerics.max_phase_duration``) and the rate steps."""
        t_end = math.inf if ph.max_duration is None else t0 + ph.max_duration
        vt = ph.volume_target
        tv = None if vt is None else ph.time_to_volume(vt)
        if tv is not None:
            t_end = min(t_end, t0 + tv)
        return {"t_end": t_end, "limit": t0 + self.scene.numerics.max_phase_duration,
                "breaks": [t0 + b for b in ph.breakpoints()]}

    def _end_margins(self, p_w: float, v_in: float, v_ret: float) -> dict[str, float]:
        """The phase's end tests located as events (``<= 0``: met) at well pressure ``p_w``
        and volumes ``v_in``/``v_ret``: pressure ends (at the surface: the column at the
        rate of the phase at the present time), a bleed's dead well, and a volume that is
        not a time target (a flowback's)."""
        d = self._drive
        ph = d.phase
        ps = d.surface_at(self.time, p_w) if d.needs_surface else math.nan
        out = d.end_margins(p_w, ps, v_in, v_ret)
        vt = ph.volume_target
        if "volume" in out and ph.time_to_volume(vt) is not None:
            del out["volume"]              # landed on as a time target
        return out

    def _end_phase(self, reason: str) -> None:
        cyc, ph = self._plan[self._i_ph]
        st = self.stepper.state
        if reason == "limit":
            self.status = "stopped"
            self.messages.append(f"phase {self._i_ph + 1} ({ph.label}, cycle {cyc}) hit "
                                 f"max_phase_duration {self.scene.numerics.max_phase_duration:g}"
                                 " s before its end condition")
        if ph.pumps:
            self.truth_events["last_pump_pressure"][str(cyc)] = st.p_w
        self.phases_out.append({"cycle": cyc, "kind": ph.kind, "name": ph.label,
                                "t_start": self._drive.t0, "t_end": st.t, "end": reason})
        self._i_ph += 1
        self._in_phase = False
        self._drive = self._well.idle(st.t, self._v_in, self._v_ret)
        self._targets = {}

    def _outcome(self, success: bool, t: float, reason: str) -> StepOutcome:
        c = self.stepper.counters
        return StepOutcome(success, t, reason, StepCounters(
            accepted=c.steps, rejected=c.failed_steps,
            newton_iterations=c.newton_iterations, linear_solves=c.linear_solves))

    def step(self) -> StepOutcome:
        """One pass: a phase start, an accepted step (maybe ending the phase) or a rejected
        trial (retried shorter)."""
        if not self._started:
            raise RuntimeError("MDEMEngine.step() before start()")
        if self.is_done():
            return self._outcome(False, self.time, "done")
        if not self._in_phase:
            why = self._begin_phase()
            if why:
                self._end_phase(why)
                return self._outcome(True, self.time, "phase end at start: " + why)
            return self._outcome(True, self.time, "phase start")
        # a wild Newton iterate may overflow rho(p) = exp(c_f p) or the column: the Newton
        # checks every residual for finite values and backs off, so numpy's warnings of
        # those trials are noise on the user's terminal
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return self._trial()

    def _trial(self) -> StepOutcome:
        num = self.scene.numerics
        ev = self.stepping.events
        stp = self.stepper
        ctx = self._targets
        _, ph = self._plan[self._i_ph]
        old = stp.state
        t = old.t
        target = min(ctx["t_end"], ctx["limit"])
        for b in ctx["breaks"]:
            if b > t * (1 + 1e-14) + 1e-12:
                target = min(target, b)
                break
        h = min(self._h, num.dt_max)
        if self._retry is not None:
            h = min(h, self._retry["h"])
        h_try = min(h, target - t)
        at_floor = h_try <= num.dt_min * (1.0 + 1e-9)
        if target - t - h_try < num.dt_min:
            h_try = target - t
        h_try = max(h_try, 1e-12)
        # the stepper's adaptive rules (docs/coupling.md, "Breakdown into a large well
        # storage"): while the crack runs the failure limit follows its size; at the floor
        # continuation in the step length, then longer steps over a turning point
        r, h_try = stp.attempt(h_try, self.tsc, running=self._running, limit=target - t,
                               at_floor=at_floor)
        dp_smooth = r.dp_w if r.new_failures == 0 else r.dp_w_smooth
        if (r.success and not at_floor and (r.new_failures == 0 or not self._running)
                and abs(dp_smooth) > float(num.dp_max)):
            # the pressure-change rule bounds the smooth change of p_w per step; a jump at
            # a cluster failure does not shrink with the step and is not cut for, but the
            # pressurisation before the first failure of a crack does: a long step that
            # pumps through the initiation pressure would put the breakdown up to its
            # whole pressure rise late (while the crack runs its own limits govern)
            stp.state = old
            self._h = max(h_try * ev.dp_fraction * float(num.dp_max) / abs(dp_smooth),
                          num.dt_min)
            return self._outcome(False, t, "rejected: pressure change")
        why = self._reject_step(old, stp.state) if r.success and not at_floor else None
        if why:
            # a rule of a subclass (the partitioned engine's coupling rule); at the floor
            # every rule is waived, so a run cannot end on it
            stp.state = old
            self._h = max(h_try * self.tsc.cut, num.dt_min)
            return self._outcome(False, t, "rejected: " + why)
        if not r.success:
            if at_floor:
                raise XlotkitError(
                    f"2D step of {h_try:g} s at t = {t:g} s failed at the floor "
                    f"numerics.dt_min = {num.dt_min:g} s and could not be stepped over: "
                    f"{r.reason}")
            self._h = max(h_try * self.tsc.cut, num.dt_min)
            return self._outcome(False, t, "rejected: " + r.reason)
        new = stp.state
        # event location: pressure ends and a flowback's volume
        vt = ph.volume_target
        dv_ret = -r.injected_mass / self.rho0 if r.injected_mass < 0 else 0.0
        ends = self._end_margins(new.p_w, self._v_in, self._v_ret + dv_ret)
        hit = {k: v for k, v in ends.items() if v <= 0.0}
        if hit and h_try > num.dt_min * (1.0 + 1e-9):
            name, g_new = min(hit.items(), key=lambda kv: kv[1])
            g_old = self._end_margins(old.p_w, self._v_in, self._v_ret)[name]
            tol = (ev.pressure_tol if name != "volume" else ev.volume_rtol * vt)
            tries = 0 if self._retry is None else self._retry["tries"]
            if -g_new > tol and tries < ev.locate_tries and g_old > 0:
                frac = g_old / (g_old - g_new)
                lo, hi = ev.locate_clamp
                h_new = max(h_try * min(max(frac, lo), hi) * (1 + ev.locate_overshoot),
                            num.dt_min)
                stp.state = old                      # undo; repeat the step shorter
                self._retry = {"h": h_new, "tries": tries + 1}
                return self._outcome(False, t, f"locating {name}")
        self._retry = None
        # a crack that reverses the open/closed change of the last step (opened then
        # closes, or the reverse) is resolved in time: the step is repeated shorter
        is_open = self._crack_open(new)
        if (ev.resolve_crack_reversals and self._open_hist is not None
                and h_try > num.dt_min * (1.0 + 1e-9)):
            o1, d1 = self._open_hist
            d2 = is_open - o1
            if np.any((d1 != 0) & (d2 == -d1) & (o1 >= 0) & (new.cluster_state != 0)):
                stp.state = old
                self._h = max(h_try * self.tsc.cut, num.dt_min)
                return self._outcome(False, t, "rejected: crack reversal")
        prev = self._open_hist[0] if self._open_hist is not None else np.full_like(is_open, -1)
        self._open_hist = (is_open, np.where((prev >= 0) & (is_open >= 0), is_open - prev, 0))
        # accepted
        q_in = r.injected_mass / (self.rho0 * r.dt) if r.dt > 0 else 0.0
        if q_in >= 0:
            self._v_in += q_in * r.dt
        else:
            self._v_ret += -q_in * r.dt
        self._v_out += r.outflow_mass / self.rho0
        self._push_row(new, q=q_in, mb=r.relative_mass_balance_error)
        self._track_events(ph, old, new, r)
        self._running = r.new_failures > 0 and r.dp_w < 0.0
        easy = CoupledStepper.easy(r, self.tsc)
        self._h = min(max(h_try if h_try < h else h_try * (self.tsc.growth if easy else 1.0),
                          num.dt_min), num.dt_max)
        if self._callback is not None:
            self._callback(self)
        reason = ""
        if hit:
            reason = min(hit.items(), key=lambda kv: kv[1])[0]
        elif new.t >= ctx["t_end"] * (1 - 1e-13) - 1e-12:
            reason = "volume" if (ph.volume_target is not None and (
                ph.max_duration is None
                or ctx["t_end"] < self._drive.t0 + ph.max_duration - 1e-9)) else "duration"
        elif new.t >= ctx["limit"] * (1 - 1e-13) - 1e-12:
            reason = "limit"
        if reason:
            self._end_phase(reason)
            return self._outcome(True, new.t, "phase end: " + reason)
        return self._outcome(True, new.t, "accepted")

    def _reject_step(self, old: CoupledState, new: CoupledState) -> str | None:
        """A further rule on an accepted trial from ``old`` to ``new`` (above the floor):
        the reason to reject it and repeat it shorter (cut by ``TimeStepControl.cut``), or
        None to keep it. The monolithic engine has none; see
        :meth:`xlotkit.sim.coupling.partitioned.PartitionedMDEMEngine._reject_step`."""
        return None

    def _crack_open(self, st: CoupledState) -> np.ndarray:
        """Per cluster: 1 open crack, 0 closed crack, -1 intact."""
        cs = st.cluster_state
        _, _, wn, _ = self.cm.crack_permeability(cs, np.asarray(st.mechanics.gap),
                                                 st.mechanics.slip)
        return np.where(cs != 0, (wn > 0).astype(np.int64), -1)

    def _track_events(self, ph, old: CoupledState, new: CoupledState, r) -> None:
        te = self.truth_events
        if te["initiation_time"] is None and new.n_failed > 0:
            te["initiation_time"] = new.t
            te["initiation_pressure"] = new.p_w
        if ph.pumps and te["breakdown_time"] is None and new.n_failed > 0:
            # breakdown: the first drop of the well pressure while pumping with a crack
            if new.p_w < old.p_w:
                te["fbp"] = old.p_w
                te["breakdown_time"] = old.t

    # ------------------------------------------------------------------ rows
    def _push_row(self, st: CoupledState, *, q: float, mb: float) -> None:
        fs = fracture_summary(self.cm, st)
        cs = st.cluster_state
        cracked = (cs == FAILED_TENSILE) | (cs == FAILED_SHEAR) | (cs == PRESET)
        p = np.asarray(st.p)
        mouth = cracked & self._at_wall
        pf = float(np.mean(p[mouth])) if mouth.any() else st.p_w
        m = self.cm.flow.cell_mass(st.flow)
        intact = ~cracked
        leak = (float(np.sum((m - self._m_intact0)[intact])) / self.rho0 + self._v_out)
        row = self._rows
        row["t"].append(st.t)
        row["bottomhole_pressure"].append(st.p_w)
        row["well_pressure"].append(st.p_w)
        row["surface_pressure"].append(self._surface(st.p_w, q))
        row["fracture_pressure"].append(pf)
        row["pump_rate"].append(max(q, 0.0))
        row["return_rate"].append(max(-q, 0.0))
        row["pumped_volume"].append(self._v_in)
        row["returned_volume"].append(self._v_ret)
        row["leakoff_volume"].append(leak)
        row["fracture_length"].append(0.5 * fs.length)
        row["fracture_volume"].append(fs.volume)
        row["failed_clusters"].append(float(fs.n_failed))
        row["mass_balance_error"].append(mb)

    def rows(self) -> dict[str, np.ndarray]:
        """The time series so far, one row per accepted step (SI; see
        :data:`xlotkit.sim.output.SERIES_COLUMNS`)."""
        return series_rows(self._rows)

    # ------------------------------------------------------------------ fields
    def snapshot(self) -> Snapshot:
        """Fields now: displacement (nodes); pressure, permeability, aperture, stress,
        failed state, crack plane (unit normal ``crack_normal`` and direction
        ``crack_azimuth`` [deg from x], nan where a cluster has none) (triangles)."""
        st = self.stepper.state
        cm = self.cm
        ms = st.mechanics
        k, _, wn, _ = cm.crack_permeability(st.cluster_state, cm.contact_gap(st),
                                            None if ms is None else ms.slip)
        u = np.asarray(st.displacement) - cm.u0.reshape(-1, 2)
        cn = (np.zeros((cm.n_cells, 2)) if ms is None
              else np.asarray(ms.crack_normal, dtype=float))
        return Snapshot(time=st.t, points=cm.mesh.nodes, triangles=cm.mesh.triangles,
                        point_data={"displacement": u},
                        cell_data={"pressure": np.asarray(st.p),
                                   "permeability": np.asarray(k, dtype=float),
                                   "aperture": np.asarray(wn, dtype=float),
                                   "stress": cm.stress(st),
                                   "failed": np.asarray(st.cluster_state, dtype=np.int64),
                                   "crack_normal": cn,
                                   "crack_azimuth": cm.mechanics.plane_azimuth(cn)})

    # ------------------------------------------------------------------ checkpoint
    def state(self) -> dict[str, Any]:
        """Everything the remaining steps depend on (arrays and exact scalars)."""
        if not self._started:
            raise RuntimeError("MDEMEngine.state() before start()")
        st = self.stepper.state
        out: dict[str, Any] = {
            "model": self.model,
            "displacement": np.asarray(st.displacement), "applied_load": st.applied_load,
            "flow.p": np.asarray(st.flow.p),
            "flow.extra_pore_volume": np.asarray(st.flow.extra_pore_volume),
            "volume_offset": st.volume_offset, "failure_time": st.failure_time,
            "failure_volume": st.failure_volume, "m_intact0": self._m_intact0,
        }
        ms = st.mechanics
        for f in _MECH_FIELDS:
            out[f"mech.{f}"] = np.asarray(getattr(ms, f))
        for k, v in self._rows.items():
            out[f"row.{k}"] = np.asarray(v, dtype=float)
        if self._open_hist is not None:
            out["open_hist.open"], out["open_hist.change"] = self._open_hist
        # what the next steps depend on beyond the state (the predictor's last transition,
        # the linear solver's orderings and factor)
        out.update(self.stepper.memory())
        scal = {
            "t": st.flow.t, "p_w": st.flow.p_w, "well_extra_volume": st.flow.well_extra_volume,
            "mech_wall_pressure": float(ms.wall_pressure),
            "h": self._h, "i_ph": self._i_ph, "in_phase": self._in_phase,
            # json writes inf as Infinity and reads it back
            "ctx": {"t0": self._drive.t0, "zeta": self._drive.zeta, **self._targets},
            "v_in": self._v_in, "v_ret": self._v_ret, "v_out": self._v_out,
            "phase_v0": [self._drive.v_in0, self._drive.v_ret0], "retry": self._retry,
            "running": self._running,
            "phases_out": self.phases_out, "events": self.events, "status": self.status,
            "messages": self.messages, "truth_events": self.truth_events,
            "counters": self.stepper.counters.__dict__,
            "wall_time": self._wall_before + (_time.perf_counter() - self._wall0),
        }
        out["json"] = json.dumps(scal)
        return out

    def restore(self, state: Mapping[str, Any]) -> None:
        """Continue from a :meth:`state` dict (instead of :meth:`start`)."""
        try:
            scal = json.loads(str(_scalar(state["json"])))
            arr = {k: np.asarray(v) for k, v in state.items() if k != "json"}
            mech = MechanicsState(wall_pressure=scal["mech_wall_pressure"],
                                  **{f: arr[f"mech.{f}"] for f in _MECH_FIELDS})
            flow = FlowState(scal["t"], arr["flow.p"], scal["p_w"],
                             arr["flow.extra_pore_volume"], scal["well_extra_volume"])
        except (KeyError, ValueError, TypeError) as exc:
            raise InputError(f"not a 2D-engine checkpoint ({exc})", key="checkpoint",
                             expected="a checkpoint written by MDEMEngine.state()") from None
        self.start()
        st = CoupledState(arr["displacement"], flow, arr["applied_load"], mechanics=mech,
                          volume_offset=arr["volume_offset"], failure_time=arr["failure_time"],
                          failure_volume=arr["failure_volume"])
        self.stepper.state = st
        self.stepper.restore_memory({k: v for k, v in arr.items()
                                     if k.startswith(("pred.", "linear."))})
        self.stepper.counters = CoupledCounters(**scal["counters"])
        self._m_intact0 = arr["m_intact0"]
        self._rows = {k: arr[f"row.{k}"].astype(float).tolist() for k in _ROW_KEYS}
        self._h = float(scal["h"])
        self._i_ph, self._in_phase = int(scal["i_ph"]), bool(scal["in_phase"])
        ctx = dict(scal["ctx"])
        self._v_in, self._v_ret, self._v_out = scal["v_in"], scal["v_ret"], scal["v_out"]
        v_in0, v_ret0 = scal["phase_v0"]
        if self._in_phase:
            _, ph = self._plan[self._i_ph]
            self._drive = self._well.begin(ph, t0=ctx["t0"], p_bh=st.p_w, v_in=v_in0,
                                           v_ret=v_ret0, zeta=ctx["zeta"])
            self._targets = {k: ctx[k] for k in ("t_end", "limit", "breaks")}
        else:
            self._drive = self._well.idle(ctx["t0"], v_in0, v_ret0)
            self._targets = {}
        self._retry = scal["retry"]
        self._running = bool(scal.get("running", False))
        self._open_hist = ((arr["open_hist.open"].astype(np.int64),
                            arr["open_hist.change"].astype(np.int64))
                           if "open_hist.open" in arr else None)
        self.phases_out = scal["phases_out"]
        self.events = [tuple(e) for e in scal["events"]]
        self.status, self.messages = scal["status"], scal["messages"]
        self.truth_events = scal["truth_events"]
        self._wall_before = float(scal["wall_time"])

    # ------------------------------------------------------------------ result
    def result(self) -> EngineResult:
        """The outcome once :meth:`is_done`: record on the log grid and truth."""
        if not self.is_done():
            raise RuntimeError("MDEMEngine.result() before the run is done")
        sc = self.scene
        rows = self.rows()
        record = make_record(sc, rows, self.events, self.column)
        c = self.stepper.counters
        mb = rows["mass_balance_error"][1:]
        msg = (f"{sc.schedule.n_cycles} cycle(s), {c.steps} steps ({c.failed_steps} cut), "
               f"{c.newton_iterations} Newton iterations, {int(rows['failed_clusters'][-1])} "
               f"failed clusters, max step mass-balance error "
               f"{float(np.max(mb)) if mb.size else 0.0:.1e}")
        if self.status != "ok":
            msg = "; ".join(self.messages) + "; " + msg
        te = self.truth_events
        truth: dict[str, Any] = {
            "sigma_h": sc.stresses.sigma_h, "sigma_H": sc.stresses.sigma_H,
            "pore_pressure": sc.stresses.pore_pressure,
            "tensile_strength": sc.rock.tensile_strength,
            "fbp": te["fbp"], "breakdown_time": te["breakdown_time"],
            "initiation_time": te["initiation_time"],
            "initiation_pressure": te["initiation_pressure"],
            "last_pump_pressure": dict(te["last_pump_pressure"]),
            "phases": list(self.phases_out),
            "well_compliance": float(self.cm.well_storage),
            "initial_pressure": self.pw0,
            "n_triangles": int(self.cm.mesh.n_triangles),
            "steps": c.steps, "cut_steps": c.failed_steps,
            "newton_iterations": c.newton_iterations, "linear_solves": c.linear_solves,
            "linear_solve_time": c.linear_solve_time,
            "wall_time": self._wall_before + (_time.perf_counter() - self._wall0),
        }
        realised = realised_truth(self.cm, self.stepper.state, self._stress0, self._at_wall)
        if realised:
            truth["realised"] = realised
        return EngineResult(status=self.status, message=msg, record=record, truth=truth)

def _scalar(v: Any) -> Any:
    return v.item() if isinstance(v, np.ndarray) else v
