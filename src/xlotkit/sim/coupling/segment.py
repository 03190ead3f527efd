r"""The 2D coupled model as the open-hole segment of the well coupling (SPEC §5).

:class:`CoupledSegment` implements :class:`xlotkit.sim.coupling.schemes.SegmentModel` for a
:class:`~xlotkit.sim.coupling.CoupledModel`: the borehole of the 2D section with only its own
storage, stepped by the coupled stepper (Newton on ``(u, p, p_w)``, failure rounds, optional
continuation in the step length) under one of three borehole conditions:

``inflow=q``
    a prescribed rate into the borehole (the partitioned schemes' ``Q_T2``);
``pressure=p``
    a prescribed borehole pressure at the end of the step (the flow's pressure-controlled
    :class:`~xlotkit.sim.flow.WellCondition`; the rate is then an output);
``inflow=q, well=WellLoad(c_w, q_out)``
    the well's storage and surface returns on ``p_w`` inside the same implicit step
    (``monolithic``; the same equations as :class:`~xlotkit.sim.coupling.engine.MDEMEngine`).

Scaling (docs/well-coupling.md, "Scaling to the well")
------------------------------------------------------
The 2D model is a slab of height ``h`` (``model.height``, the scene's
``geometry.segment_height``): every volume it computes is a volume of the whole slab. The
protocol speaks *per unit height*, so the segment divides what it reports by ``h`` and
multiplies the rates it is given by ``h``:

* ``inflow`` q [m^3/s per m] -> ``Q = q h`` into the borehole;
* ``storage`` -> the borehole's own compliance ``c_f pi r^2`` (the flow's ``well_storage``
  over ``h``);
* ``volume``, ``leak_volume``, ``fracture_volume``, ``leaked``, ``injected``, ``compliance``
  -> the slab's values over ``h``.

The driver (:mod:`xlotkit.sim.coupling.partitioned`) uses ``H = h``: the slab *is* the open
hole, as in the monolithic 2D engine, so the round trip is the identity and the partitioned
and monolithic runs of a scene model the same well and the same open hole.

Volumes are fluid masses over the fluid's reference density (the surface volumes pumps
meter, like the rates of the flow model); fracture volume is the geometric pore volume the
failed clusters opened since they failed (:func:`~xlotkit.sim.coupling.fracture_summary`).
``leak_volume`` is the fluid that went into intact rock and out of the outer edges, as the
engine's ``leakoff_volume``.

A step that the coupled stepper rejects (Newton, more than ``max_new_failures`` new failed
clusters, mass balance) raises :class:`~xlotkit.sim.coupling.schemes.SegmentStepFailed`; the
model and the given state are unchanged, so the caller may retry with a shorter step.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from collections.abc import Callable
from typing import Any

import numpy as np

from xlotkit.errors import InputError
from xlotkit.sim.coupling.geometry import fracture_summary
from xlotkit.sim.coupling.model import CoupledModel, CoupledState
from xlotkit.sim.coupling.newton import equilibrated_solve
from xlotkit.sim.coupling.schemes import SegmentStep, SegmentStepFailed, WellLoad
from xlotkit.sim.coupling.stepper import (
    CoupledControl,
    CoupledCounters,
    CoupledStepper,
    StepResult,
)
from xlotkit.sim.mechanics import INTACT

__all__ = ["CoupledSegment", "CoupledSegmentState", "CoupledSegmentStep", "fluid_storage"]

#: Relative pressure step of the finite-difference slope of a ``WellLoad.outflow``.
_DQ_REL = 1e-7


def fluid_storage(compliance: float, compressibility: float, reference_pressure: float,
                  p_new: float, p_old: float) -> float:
    """Reference-density volume a storage ``compliance`` takes from ``p_old`` to ``p_new``.

    The flow model stores ``C rho(p) / c_f`` of mass in a compliance ``C`` with
    ``rho = rho0 exp(c_f (p - p_ref))`` (:meth:`FlowModel.residual_and_jacobian`, the well
    row); over ``rho0`` that is ``C exp(c_f (p_old - p_ref)) expm1(c_f dp) / c_f``, and
    ``C dp`` for an incompressible fluid.

    Parameters
    ----------
    compliance : float
        ``C`` [m^3/Pa] (or per unit height).
    compressibility : float
        ``c_f`` [1/Pa].
    reference_pressure : float
        ``p_ref`` [Pa] of ``rho0``.
    p_new, p_old : float
        Pressures [Pa].

    Returns
    -------
    float
        [m^3] (or per unit height), at the reference density.
    """
    dp = p_new - p_old
    x = compressibility * dp
    if abs(x) < 1e-8:
        f = 1.0 + 0.5 * x
    else:
        f = math.expm1(x) / x
    return compliance * math.exp(compressibility * (p_old - reference_pressure)) * dp * f


@dataclass(frozen=True, eq=False)
class CoupledSegmentState:
    """State of the 2D segment, with the fields the well coupling reads (per unit height).

    Attributes
    ----------
    coupled : CoupledState
        The coupled model's state (slab of height ``h``).
    pressure : float
        Borehole pressure ``p_w`` of the model [Pa].
    half_length : float
        Half of the crack's tip-to-tip length [m] (0 without a crack).
    broken : bool
        Some cluster has failed.
    fracture_volume : float
        Pore volume opened by the failed clusters since they failed [m^3 per m].
    leaked : float
        Cumulative fluid into intact rock and out of the outer edges [m^3 per m]
        (mass change of the intact cells plus boundary outflow, over ``rho0``).
    injected : float
        Cumulative volume taken from the well [m^3 per m].
    boundary_outflow : float
        Cumulative outflow through the fixed-pressure outer edges [m^3 per m].
    """

    coupled: CoupledState
    pressure: float
    half_length: float
    broken: bool
    fracture_volume: float
    leaked: float = 0.0
    injected: float = 0.0
    boundary_outflow: float = 0.0


@dataclass(frozen=True, eq=False)
class CoupledSegmentStep(SegmentStep):
    """:class:`~xlotkit.sim.coupling.schemes.SegmentStep` of the 2D segment, with the coupled
    stepper's record of the step.

    Attributes
    ----------
    result : StepResult
        The coupled stepper's outcome (Newton iterations, failures, mass balance).
    counters : CoupledCounters
        The work of the call (Newton iterations, linear solves, their time, ...).
    tangent : callable ``() -> float``
        The tangent compliance [m^3/Pa per m] of the step (:meth:`CoupledSegment.tangent`,
        one linear solve); ``compliance`` is NaN when the secant is not usable and the
        controllers then call this.
    """

    result: StepResult | None = None
    counters: CoupledCounters | None = None
    tangent: Callable[[], float] | None = None


class CoupledSegment:
    """The 2D open-hole segment behind the :class:`~xlotkit.sim.coupling.schemes.SegmentModel`
    protocol (see the module docstring for the scaling).

    Parameters
    ----------
    model : CoupledModel
        The coupled model. Its reference state (``model.initial_state``) must be set, or
        is set by :meth:`initial_state`. Each :meth:`step` sets the model's well terms
        (``well_storage``, ``well_rate``, ``flow.well``) for the call and restores them,
        so the same model may serve an engine's output routines in between.
    control : CoupledControl, optional
        Newton and failure settings of every step.

    Notes
    -----
    ``compliance`` of a step (the controllers' gain scale, thesis Eq. 4.11) is the secant
    ``volume / dp`` over the step when that is positive and the pressure moved by more than
    1 Pa (what the controllers use first); otherwise NaN, and the step's ``tangent()``
    gives the tangent at fixed structure, ``dt / (dp_w/dQ)``, from one extra linear solve
    with the converged step's Jacobian, only when a controller asks for it (only the
    kept call of a WFD step is asked; counted in :attr:`tangent_solves`).

    Attributes
    ----------
    tangent_solves : int
        Tangent compliances computed so far.
    """

    def __init__(self, model: CoupledModel, control: CoupledControl | None = None) -> None:
        if not isinstance(model, CoupledModel):
            raise InputError("expected a CoupledModel", key="segment.model")
        if not model.flow.has_well:
            raise InputError("the model has no borehole", key="segment.model",
                             expected="a mesh with a hole (borehole_mesh)")
        if model.flow.well.pressure_controlled:
            raise InputError("the model's well is pressure controlled", key="segment.model",
                             expected="a rate-controlled WellCondition (the segment sets the "
                                      "borehole condition per step)")
        self.model = model
        self.control = control or CoupledControl()
        self.height = float(model.height)
        fl = model.flow.fluid
        self.compressibility = float(fl.compressibility)
        self.reference_pressure = float(fl.reference_pressure)
        self.rho0 = float(fl.density)
        self._own_storage = float(model.flow.well_storage)       # C_s of the slab [m^3/Pa]
        self._m0: np.ndarray | None = None
        self.tangent_solves = 0

    # ------------------------------------------------------------------ protocol
    @property
    def storage(self) -> float:
        """``c_s``: the borehole's own fluid compliance per unit height [m^3/Pa per m]."""
        return self._own_storage / self.height

    def initial_state(self, pressure: float) -> CoupledSegmentState:
        """The in-situ state with the borehole at ``pressure`` [Pa] (sets the model's
        reference state, :meth:`CoupledModel.initial_state`)."""
        st = self.model.initial_state(p_w=float(pressure))
        return self.wrap(st)

    def wrap(self, state: CoupledState, *, leaked: float = 0.0, injected: float = 0.0,
             boundary_outflow: float = 0.0) -> CoupledSegmentState:
        """A :class:`CoupledSegmentState` of a coupled state (e.g. an engine's initial
        state; the intact cells' masses of the first state wrapped are the reference of
        ``leaked``)."""
        if self._m0 is None:
            self._m0 = np.asarray(self.model.flow.cell_mass(state.flow), dtype=float).copy()
        fs = fracture_summary(self.model, state)
        return CoupledSegmentState(
            coupled=state, pressure=float(state.p_w), half_length=0.5 * float(fs.length),
            broken=state.n_failed > 0, fracture_volume=float(fs.volume) / self.height,
            leaked=float(leaked), injected=float(injected),
            boundary_outflow=float(boundary_outflow))

    def step(self, state: CoupledSegmentState, dt: float, *, inflow: float | None = None,
             pressure: float | None = None, well: WellLoad | None = None,
             max_new_failures: int | None = None,
             continuation: bool = False) -> CoupledSegmentStep:
        """One implicit coupled step of ``dt`` [s] from ``state``.

        Parameters
        ----------
        state : CoupledSegmentState
        dt : float
        inflow : float, optional
            Rate into the borehole [m^3/s per m, reference density].
        pressure : float, optional
            Borehole pressure at the end of the step [Pa] (exclusive with ``inflow``).
        well : WellLoad, optional
            With ``inflow``: the well's storage [m^3/Pa per m] and surface returns
            ``q_out(p)`` [m^3/s per m] on the borehole pressure (monolithic).
        max_new_failures : int, optional
            Reject the step when more clusters would fail in it (thesis ``N2``).
        continuation : bool
            Retry a failed solve by continuation in the step length.

        Returns
        -------
        CoupledSegmentStep

        Raises
        ------
        SegmentStepFailed
            The coupled step was rejected (its ``detail`` is ``(StepResult,
            CoupledCounters)``); nothing changed.
        InputError
            Neither or both of ``inflow`` and ``pressure``; ``well`` with ``pressure``.
        """
        if (inflow is None) == (pressure is None):
            raise InputError("give exactly one of inflow and pressure", key="segment.step")
        if well is not None and pressure is not None:
            raise InputError("a prescribed pressure cannot carry a well load",
                             key="segment.step")
        if not (math.isfinite(dt) and dt > 0):
            raise InputError(f"time step must be > 0, got {dt!r}", key="segment.dt")
        if not isinstance(state, CoupledSegmentState):
            raise InputError("not a CoupledSegmentState", key="segment.state",
                             expected="a state from CoupledSegment.initial_state/wrap/step")
        model, h = self.model, self.height
        flow = model.flow
        saved = (model.well_storage, model.well_rate, flow.well)
        old = state.coupled
        c_ext = 0.0
        try:
            model.well_storage = self._own_storage
            if pressure is not None:
                model.well_rate = None
                flow.well = dataclasses.replace(saved[2], pressure=float(pressure))
            else:
                q = float(inflow) * h
                if well is None:
                    model.well_rate = lambda t, p, _q=q: (_q, 0.0)
                else:
                    c_ext = float(well.storage) * h
                    model.well_storage = self._own_storage + c_ext
                    model.well_rate = _loaded_rate(q, well.outflow, h)
            stp = CoupledStepper(model, old, self.control)
            r = stp.step(float(dt), max_new_failures=max_new_failures,
                         continuation=bool(continuation))
            if not r.success:
                raise SegmentStepFailed(r.reason, (r, stp.counters))
            new = stp.state
            solves = int(stp.counters.linear_solves)
            # volumes of the step [m^3 of the slab, reference density]
            v_in = r.injected_mass / self.rho0
            if c_ext:
                # the segment's share: what came from surface less what the well stored
                v_in -= fluid_storage(c_ext, self.compressibility, self.reference_pressure,
                                      new.p_w, old.p_w)
            intact = np.asarray(new.cluster_state) == INTACT
            dm = (np.asarray(flow.cell_mass(new.flow)) - np.asarray(flow.cell_mass(old.flow)))
            v_out = r.outflow_mass / self.rho0
            v_leak = float(np.sum(dm[intact])) / self.rho0 + v_out
            dp = new.p_w - old.p_w
            comp = v_in / dp if abs(dp) > 1.0 else math.nan
            if not (math.isfinite(comp) and comp > 0.0):
                comp = math.nan                 # the tangent, on demand (one solve)
        finally:
            model.well_storage, model.well_rate, flow.well = saved
        out = self.wrap(new, leaked=state.leaked + v_leak / h,
                        injected=state.injected + v_in / h,
                        boundary_outflow=state.boundary_outflow + v_out / h)
        return CoupledSegmentStep(state=out, pressure=out.pressure, volume=v_in / h,
                                  leak_volume=v_leak / h, solves=solves,
                                  compliance=comp / h, result=r, counters=stp.counters,
                                  tangent=lambda: self.tangent(new, old, float(dt)))

    def tangent(self, new: CoupledState, old: CoupledState, dt: float) -> float:
        """Pump-in compliance of the step from ``old`` to ``new`` at fixed cluster
        structure and contact statuses, borehole storage only [m^3/Pa per m]:
        ``dt / (dp_w/dQ)`` from one linear solve with the step's Jacobian at ``new``
        (counted in :attr:`tangent_solves`)."""
        model = self.model
        flow = model.flow
        saved = (model.well_storage, model.well_rate, flow.well)
        try:
            model.well_storage = self._own_storage
            model.well_rate = lambda t, p: (0.0, 0.0)
            flow.well = dataclasses.replace(flow.well, pressure=None)
            res = model.residual_and_jacobian(model.x_of(new), old, dt,
                                              structure=model.structure_of(new))
            rhs = np.zeros(res.residual.size)
            rhs[-1] = self.rho0                  # dR_w/dQ = -rho0: J dx/dQ = rho0 e_w
            dpdq = float(equilibrated_solve(res.jacobian, rhs)[-1])
        finally:
            model.well_storage, model.well_rate, flow.well = saved
        self.tangent_solves += 1
        c = dt / dpdq if dpdq > 0.0 else self._own_storage
        return c / self.height


def _loaded_rate(q: float, outflow: Any, h: float):
    """``(Q, dQ/dp_w)`` of the slab with a pump rate ``q h`` and returns ``h q_out(p)``
    (the slope of the returns by a central difference: the choke's own derivative is not
    part of :class:`WellLoad`)."""
    if outflow is None:
        return lambda t, p: (q, 0.0)

    def rate(t: float, p: float) -> tuple[float, float]:
        d = max(abs(p), 1e5) * _DQ_REL
        slope = (float(outflow(p + d)) - float(outflow(p - d))) / (2.0 * d)
        return q - h * float(outflow(p)), -h * slope

    return rate
