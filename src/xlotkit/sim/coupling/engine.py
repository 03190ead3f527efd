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
  pore fluid (Biot alpha taken as 1e-3 for intact clusters, no grain compressibility), as in
  the classical hydraulic-fracture models; failed clusters always carry the fluid pressure
  with coefficient 1 and store the crack volume. When on, alpha = ``rock.biot`` with the
  grain term of the pore compressibility (docs/coupling.md).
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
:meth:`MDEMEngine._realised`).
"""

from __future__ import annotations

import json
import math
import time as _time
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from xlotkit import formulas
from xlotkit.errors import InputError, XlotkitError
from xlotkit.record import Event, PressureReference, Record
from xlotkit.sim.coupling.geometry import fracture_summary
from xlotkit.sim.coupling.model import (
    CoupledModel,
    CoupledState,
    grain_pore_compressibility,
)
from xlotkit.sim.coupling.stepper import (
    CoupledControl,
    CoupledCounters,
    CoupledStepper,
    TimeStepControl,
)
from xlotkit.sim.flow import (
    FlowModel,
    FlowState,
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    WellCondition,
)
from xlotkit.sim.mechanics import (
    FAILED_SHEAR,
    FAILED_TENSILE,
    PRESET,
    FracturePlane,
    InSituStress,
    InterfacePlane,
    MechanicsModel,
    MechanicsState,
    RockProperties,
    StrengthScaling,
)
from xlotkit.sim.mechanics.breakdown import crack_geometry
from xlotkit.sim.mesh import FractureBand, Mesh, borehole_mesh, read_mesh
from xlotkit.sim.output import Snapshot
from xlotkit.sim.run.contract import EngineResult, StepCounters, StepOutcome, series_rows
from xlotkit.sim.scene import Scene
from xlotkit.sim.well import (
    Column,
    PhaseDrive,
    WellDrive,
    hydrostatic_bottomhole,
    phase_place,
    surface_from_bottomhole,
    well_compliance,
)

__all__ = ["MDEMEngine", "MDEMResult", "MDEMStepOutcome", "build_model"]

#: Biot coefficient of intact clusters when ``effects.poroelastic`` is off.
DECOUPLED_BIOT = 1e-3
#: Tolerance [Pa] of a located pressure end of a phase.
PRESSURE_EVENT_TOL = 1e4
#: Relative tolerance of a located flowback/bleed volume end.
VOLUME_EVENT_RTOL = 1e-3
#: Crack residual (closed) hydraulic aperture [m].
RESIDUAL_APERTURE = 1e-5
#: Rock bulk density [kg/m^3] for the crack-speed limit only (the model is quasi-static
#: and has no other use for it); a typical sedimentary rock.
ROCK_DENSITY = 2500.0


_MECH_FIELDS = ("displacement", "pore_pressure", "stress", "effective_stress",
                "cluster_state", "contact_status", "normal_force", "shear_force", "gap",
                "slip", "ref_normal", "ref_shear")
_ROW_KEYS = ("t", "bottomhole_pressure", "well_pressure", "surface_pressure",
             "fracture_pressure", "pump_rate", "return_rate", "pumped_volume",
             "returned_volume", "leakoff_volume", "fracture_length", "fracture_volume",
             "failed_clusters", "mass_balance_error")


#: The step and result types of the 2D engine: the engine contract's (one for every engine).
MDEMStepOutcome = StepOutcome
MDEMResult = EngineResult


# =========================================================================== model
def _scene_mesh(scene: Scene) -> Mesh:
    mo, geo = scene.mesh, scene.geometry
    if mo.file is not None:
        path = Path(mo.file)
        if not path.is_absolute() and scene.source_file:
            path = Path(scene.source_file).parent / path
        return read_mesh(path)
    band = None
    h_wall = mo.wall_element_size
    if mo.fracture_band:
        h_band = mo.band_element_size or h_wall or 2 * math.pi * geo.hole_radius / 64
        band = FractureBand(math.radians(scene.stresses.sigma_H_azimuth), mo.band_width,
                            h_band, mo.band_length, strip=bool(mo.band_strip))
    try:
        return borehole_mesh(size=geo.domain_size, radius=geo.hole_radius, growth=mo.growth,
                             h_wall=h_wall, h_max=mo.max_element_size, fracture_band=band,
                             jitter=mo.jitter, seed=scene.mesh_seed)
    except InputError as exc:
        key = {"h_wall": "mesh.wall_element_size", "h_max": "mesh.max_element_size",
               "fracture_band.h": "mesh.band_element_size", "radius": "geometry.hole_radius",
               "size": "geometry.domain_size"}.get(exc.key or "", f"mesh.{exc.key}")
        raise InputError(exc.message, key=key, file=scene.source_file,
                         expected=exc.expected) from None


def _far_field(scene: Scene) -> tuple[float, float, float]:
    """Far-field (sigma_x, sigma_y, sigma_xy) [Pa] with sigma_H along its azimuth."""
    st = scene.stresses
    th = math.radians(st.sigma_H_azimuth)
    c, s = math.cos(th), math.sin(th)
    sx = st.sigma_H * c * c + st.sigma_h * s * s
    sy = st.sigma_H * s * s + st.sigma_h * c * c
    sxy = (st.sigma_H - st.sigma_h) * s * c
    # round-off of the rotation must not create a shear the roller boundaries cannot carry
    if abs(sxy) < 1e-9 * max(st.sigma_H, 1.0):
        sxy = 0.0
    return sx, sy, sxy


def well_column(scene: Scene) -> Column:
    """The fluid column surface -> open hole (friction only with ``effects.pipe_friction``)."""
    comp = scene.completion_model()
    col = comp.column(density=scene.fluid.density, viscosity=scene.fluid.viscosity)
    if not scene.effects.pipe_friction:
        col = replace(col, friction=False)
    return col


def total_well_compliance(scene: Scene) -> float:
    """Whole-well compliance C_w [m^3/Pa] the scene asks for (0 without well storage)."""
    if not scene.effects.well_storage:
        return 0.0
    if scene.completion.well_compliance is not None:
        return float(scene.completion.well_compliance)
    return well_compliance(scene.completion_model())


def build_model(scene: Scene) -> tuple[CoupledModel, float]:
    """The coupled model of a scene and the initial borehole pressure [Pa].

    See the module docstring for what each scene key becomes.
    """
    if not isinstance(scene, Scene):
        raise InputError(f"not a Scene: {scene!r}", key="scene")
    mesh = _scene_mesh(scene)
    rk, fl, eff, geo = scene.rock, scene.fluid, scene.effects, scene.geometry
    sx, sy, sxy = _far_field(scene)
    p0 = scene.stresses.pore_pressure
    col = well_column(scene)
    pw0 = (float(scene.completion.initial_pressure)
           if scene.completion.initial_pressure is not None else hydrostatic_bottomhole(col))
    if pw0 < p0 * (1.0 - 1e-12):
        raise InputError(
            f"initial borehole pressure {pw0 / 1e6:.3f} MPa is below the pore pressure "
            f"{p0 / 1e6:.3f} MPa (an underbalanced hole is not a leak-off test)",
            key="completion.initial_pressure", file=scene.source_file,
            expected=f">= stresses.pore_pressure ({p0:g} Pa)")
    if sxy != 0.0:
        # rollers need a diagonal far field; the mechanics pins rigid modes otherwise
        from xlotkit.sim.mechanics import BoundaryConditions

        boundary = BoundaryConditions("tractions")
    else:
        boundary = None
    biot = float(rk.biot) if eff.poroelastic else DECOUPLED_BIOT
    scaling = StrengthScaling(enabled=bool(eff.strength_scaling),
                              reference_area=rk.strength_scaling_reference_area,
                              exponent=rk.strength_scaling_exponent,
                              toughness=rk.toughness)
    rock = RockProperties(young=rk.youngs_modulus, poisson=rk.poisson_ratio, biot=biot,
                          tensile_strength=rk.tensile_strength, cohesion=rk.cohesion,
                          friction_angle_deg=rk.friction_angle,
                          heterogeneity=rk.heterogeneity if eff.heterogeneity else 0.0,
                          seed=int(scene.rock_seed) % (2**63), scaling=scaling)
    planes = tuple(InterfacePlane(p.start, p.end, p.friction_angle) for p in eff.interface)
    fplane = None
    if eff.fracture_plane:
        fplane = FracturePlane(math.radians(scene.stresses.sigma_H_azimuth),
                               friction_angle_deg=rk.fracture_friction_angle)
    mech = MechanicsModel(mesh, rock, InSituStress(sx, sy, sxy, p0, pw0), boundary=boundary,
                          interfaces=planes, fracture_plane=fplane)
    cr = (float(np.min(grain_pore_compressibility(biot, rk.porosity, rk.youngs_modulus,
                                                  rk.poisson_ratio)))
          if eff.poroelastic else 0.0)
    fluid = FluidProperties(density=fl.density, compressibility=fl.compressibility,
                            viscosity=fl.viscosity, reference_pressure=0.0)
    flow = FlowModel(mesh, fluid, RockFlowProperties(rk.permeability, rk.porosity, cr, p0),
                     WellCondition(rate=0.0), OuterBoundary.fixed_pressure(p0),
                     height=geo.segment_height)
    h = geo.segment_height
    extra = max(total_well_compliance(scene) - float(flow.well_storage), 0.0) / h
    model = CoupledModel(mech, flow, residual_aperture=RESIDUAL_APERTURE,
                         well_compliance=extra, check_storage=eff.poroelastic)
    return model, pw0


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
                f"coupling {scene.coupling!r} runs on the unit-segment well model "
                "(xlotkit.sim.wellcoupling, benchmarks/bench_wellcoupling.py); the 2D "
                "engine couples the well monolithically", key="coupling",
                file=scene.source_file, expected="'monolithic' for the 2D engine")
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
        num = sc.numerics
        self.control = CoupledControl(max_newton=int(num.max_newton),
                                      crack_speed=formulas.rayleigh_speed(
                                          sc.rock.youngs_modulus, sc.rock.poisson_ratio,
                                          ROCK_DENSITY))
        self.tsc = TimeStepControl(dt_initial=min(1.0, num.dt_max), dt_min=num.dt_min,
                                   dt_max=num.dt_max, n1=int(num.n1), n2=int(num.n2),
                                   dp_max=float(num.dp_max))
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
        # total stress of the in-situ state (for the realised sigma_h, see _realised)
        self._stress0 = self.cm.stress(st)
        self.stepper = CoupledStepper(self.cm, st, self.control)
        self._m_intact0 = self.cm.flow.cell_mass(st.flow)
        self._h = min(1.0, self.scene.numerics.dt_max)
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
        (:meth:`xlotkit.sim.well.PhaseDrive.rate`)."""
        return self._drive.rate(t, p_w)

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
        self._h = min(max(self._h, 1e-3), self.scene.numerics.dt_max)
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
        return self._trial()

    def _trial(self) -> StepOutcome:
        num = self.scene.numerics
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
        if (r.success and not at_floor and r.new_failures == 0
                and abs(r.dp_w) > float(num.dp_max)):
            # the pressure-change rule bounds the smooth change of p_w per step; a jump at
            # a cluster failure does not shrink with the step and is not cut for
            stp.state = old
            self._h = max(h_try * 0.5 * float(num.dp_max) / abs(r.dp_w), num.dt_min)
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
            tol = (PRESSURE_EVENT_TOL if name != "volume" else VOLUME_EVENT_RTOL * vt)
            tries = 0 if self._retry is None else self._retry["tries"]
            if -g_new > tol and tries < 8 and g_old > 0:
                frac = g_old / (g_old - g_new)
                h_new = max(h_try * min(max(frac, 0.05), 0.95) * (1 + 1e-3), num.dt_min)
                stp.state = old                      # undo; repeat the step shorter
                self._retry = {"h": h_new, "tries": tries + 1}
                return self._outcome(False, t, f"locating {name}")
        self._retry = None
        # a crack that reverses the open/closed change of the last step (opened then
        # closes, or the reverse) is resolved in time: the step is repeated shorter
        is_open = self._crack_open(new)
        if self._open_hist is not None and h_try > num.dt_min * (1.0 + 1e-9):
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
        _, _, wn, _ = self.cm.crack_permeability(cs, np.asarray(st.mechanics.gap))
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
        failed state (triangles)."""
        st = self.stepper.state
        cm = self.cm
        ms = st.mechanics
        gap = np.zeros((cm.n_cells, 3)) if ms is None else np.asarray(ms.gap)
        k, _, wn, _ = cm.crack_permeability(st.cluster_state, gap)
        u = np.asarray(st.displacement) - cm.u0.reshape(-1, 2)
        return Snapshot(time=st.t, points=cm.mesh.nodes, triangles=cm.mesh.triangles,
                        point_data={"displacement": u},
                        cell_data={"pressure": np.asarray(st.p),
                                   "permeability": np.asarray(k, dtype=float),
                                   "aperture": np.asarray(wn, dtype=float),
                                   "stress": cm.stress(st),
                                   "failed": np.asarray(st.cluster_state, dtype=np.int64)})

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
        record = _make_record(sc, rows, self.events, self.column)
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
        realised = self._realised()
        if realised:
            truth["realised"] = realised
        return EngineResult(status=self.status, message=msg, record=record, truth=truth)

    def _realised(self) -> dict[str, float]:
        """What the model realised, where it differs from the scene's input.

        All from the in-situ state (the drilled hole at the mud column, before pumping: far
        field, Kirsch concentration as the mesh resolves it, finite domain) over the
        clusters of the hole-connected crack at the end of the run, with the crack's
        principal axis (:func:`~xlotkit.sim.coupling.geometry.fracture_summary`) as its
        plane:

        * ``sigma_h``, ``sigma_h_min``, ``sigma_h_max`` [Pa]: the total stress normal to the
          crack's plane, area-weighted mean (and range) over the crack's clusters. This is
          the stress the crack closes against; a closure pick is compared with it.
        * ``sigma_H`` [Pa]: the total stress along the crack's plane, area-weighted over the
          same clusters: the far-field stress parallel to the crack where the crack is (the
          largest horizontal stress when the crack runs along sigma_H), with the hole's
          radial-stress dip near the wall and the finite domain's disturbance. What
          Eq. C.18/C.19 estimates is compared with it.
        * ``tensile_strength`` [Pa]: the mean tensile strength of the crack's clusters at
          the wall, where it started (the nominal strength, or the heterogeneous draw; the
          crack-tip size scaling does not apply at the smooth wall). What T0 = FBP - Pr
          estimates.
        * ``wall_hoop_stress`` [Pa]: the total stress normal to the crack's plane in the
          crack's wall clusters (mean), at the mud column ``initial_pressure``; the ideal
          (Kirsch) wall value is ``3 sigma_h - sigma_H - p_mud``. A coarse wall resolves the
          concentration only in a cluster average, which sets where the wall breaks down.
        * ``fracture_azimuth_deg``, ``fracture_half_length`` [deg, m]: the crack's axis and
          half its tip-to-tip length.
        """
        st = self.stepper.state
        cs = st.cluster_state
        cracked = (cs == FAILED_TENSILE) | (cs == FAILED_SHEAR)
        out: dict[str, float] = {}
        if not cracked.any():
            return out
        connected, _, _ = crack_geometry(self.cm.mechanics, cs)
        fs = fracture_summary(self.cm, st)
        if connected.any() and math.isfinite(fs.azimuth_deg):
            az = math.radians(fs.azimuth_deg)
            tx, ty = math.cos(az), math.sin(az)
            nx, ny = -ty, tx
            s0 = self._stress0
            sn = s0[:, 0] * nx * nx + s0[:, 1] * ny * ny + 2.0 * s0[:, 2] * nx * ny
            sp = s0[:, 0] * tx * tx + s0[:, 1] * ty * ty + 2.0 * s0[:, 2] * tx * ty
            w = np.asarray(self.cm.mesh.areas)[connected]
            out["sigma_h"] = float(np.sum(w * sn[connected]) / np.sum(w))
            out["sigma_h_min"] = float(np.min(sn[connected]))
            out["sigma_h_max"] = float(np.max(sn[connected]))
            out["sigma_H"] = float(np.sum(w * sp[connected]) / np.sum(w))
            wall = connected & self._at_wall
            if wall.any():
                out["wall_hoop_stress"] = float(np.mean(sn[wall]))
            out["fracture_azimuth_deg"] = float(fs.azimuth_deg)
            out["fracture_half_length"] = 0.5 * float(fs.length)
        sel = cracked & self._at_wall
        if sel.any():
            out["tensile_strength"] = float(np.mean(
                np.asarray(self.cm.mechanics.tensile_strength)[sel]))
        return out


def _scalar(v: Any) -> Any:
    return v.item() if isinstance(v, np.ndarray) else v


def _make_record(sc: Scene, rows: dict[str, np.ndarray], events, column: Column) -> Record:
    """The clean record on the log grid: bottom-hole gauge pressure (latest state at or
    before each sample, interpolated between steps), rates (of the step the sample falls
    in), volumes, density, and surface/fracture pressure channels."""
    dt = sc.output.log_interval
    t_int = rows["t"]
    n = int(math.floor(float(t_int[-1]) / dt + 1e-9)) + 1
    t = np.arange(n) * dt
    # rate of the step each sample lies in (a step's rate is constant over it)
    j = np.clip(np.searchsorted(t_int, t, side="right"), 1, t_int.size - 1)

    def at(name: str) -> np.ndarray:
        return np.interp(t, t_int, rows[name])

    rate = rows["pump_rate"][j] if t_int.size > 1 else np.zeros(n)
    ret = rows["return_rate"][j] if t_int.size > 1 else np.zeros(n)
    comp = sc.completion_model()
    meta = {
        "source": "xlotkit.sim.coupling.engine", "simulated": True, "model": "mdem",
        "sigma_h": sc.stresses.sigma_h, "sigma_H": sc.stresses.sigma_H,
        "pore_pressure": sc.stresses.pore_pressure,
        "tensile_strength": sc.rock.tensile_strength,
        "youngs_modulus": sc.rock.youngs_modulus, "poisson_ratio": sc.rock.poisson_ratio,
        "tvd": column.tvd, "density": sc.fluid.density, "dt": dt,
    }
    return Record(
        t=t, pressure=at("bottomhole_pressure"),
        reference=PressureReference(kind="bottomhole", depth_m=comp.length_md, absolute=False),
        start_time=sc.output.start_time, rate=rate, volume=at("pumped_volume"),
        return_rate=ret, return_volume=at("returned_volume"),
        density=np.full(n, float(sc.fluid.density)),
        channels={"surface_pressure": at("surface_pressure"),
                  "fracture_pressure": at("fracture_pressure"),
                  "fracture_length": at("fracture_length"),
                  "fracture_volume": at("fracture_volume"),
                  "leakoff_volume": at("leakoff_volume")},
        events=tuple(Event(t=float(te), text=str(x)) for te, x in events), meta=meta)
