"""The typed details of a pick: one frozen dataclass per method family.

Every :class:`~xlotkit.interpret.picks.types.Pick` carries the numbers its method fitted in
``details`` (SI units), as one of the classes below; code reads them as attributes, never by
string keys. :meth:`Details.to_dict` gives the flat, JSON-ready mapping with the key names the
reports have always used (``"slope"``, ``"G_range"``, ``"rejected_value"`` ...; ``None``
values left out).

Families
--------
:class:`LineDetails`
    One fitted straight line (a part of the others).
:class:`DepartureDetails`, :class:`PressurisationDetails`
    First departure from a straight line (LOP, Pr; a user window on the sqrt(t) and G plots).
:class:`BreakdownDetails`, :class:`PlateauDetails`, :class:`IsipDetails`
    FBP (the breakdown event), FPP (the propagation plateau), ISIP (the early-decline tangent).
:class:`ShutinDetails` and its subclasses :class:`SlopeBreakDetails`,
:class:`ShutinDepartureDetails`, :class:`TangentDetails`, :class:`BilinearDetails`,
:class:`ComplianceDetails`
    The shut-in closure methods: the decline analysed (ISIP, shut-in time, the samples
    skipped as the pump-off drop, the boundary zone before the next phase) and the closure
    candidates rejected there (:class:`RejectedCandidate`).
:class:`FlowbackDetails`
    The two flowback (system stiffness) methods.
:class:`StepRateDetails` (with :class:`RateStepPoint`)
    The fracture-extension pressure of a step-rate test: the two lines through the
    stabilised points.
:class:`ConsensusDetails`, :class:`T0Details`, :class:`RejectedDetails`, :class:`AtDepthDetails`
    A cycle's consensus closure, the tensile strength, a pick rejected by
    :func:`~xlotkit.interpret.picks.core.reconcile_closures` (its original details kept), a
    pick moved to the target depth.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from xlotkit.interpret.picks.intervals import IntervalBudget

__all__ = [
    "AtDepthDetails",
    "BilinearDetails",
    "BoundaryZone",
    "BreakdownDetails",
    "BreakdownEvent",
    "ComplianceDetails",
    "ConsensusDetails",
    "DepartureDetails",
    "Details",
    "FlowbackDetails",
    "IsipDetails",
    "LineDetails",
    "PlateauDetails",
    "PressurisationDetails",
    "RateStepPoint",
    "RejectedCandidate",
    "RejectedDetails",
    "ShutinDepartureDetails",
    "ShutinDetails",
    "SlopeBreakDetails",
    "StepRateDetails",
    "T0Details",
    "TangentDetails",
]

_Range = tuple[float, float]


def _plain(v: Any) -> Any:
    if isinstance(v, Details):
        return v.to_dict()
    if isinstance(v, IntervalBudget):
        return v.to_dict()
    if isinstance(v, tuple) and v and all(isinstance(x, Details) for x in v):
        return [x.to_dict() for x in v]
    return v


@dataclass(frozen=True, kw_only=True)
class Details:
    """Base of every pick's details.

    ``to_dict`` lists the fields by name, nested details as mappings; subclasses with an
    abscissa name (``x_name``) write their ``x_*`` fields as ``<x_name>_*`` (``G_range``,
    ``sqrt_t_pick``, ``V_range``), the keys the reports use.
    """

    #: Fields written as ``<x_name>_<rest>`` by :meth:`to_dict`.
    _X_FIELDS: ClassVar[tuple[str, ...]] = ()
    #: Nested details flattened into this level by :meth:`to_dict`.
    _FLATTEN: ClassVar[tuple[str, ...]] = ()

    def to_dict(self) -> dict[str, Any]:
        """Flat JSON-ready mapping (SI units); None values left out."""
        out: dict[str, Any] = {}
        x_name = getattr(self, "x_name", None)
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is None:
                continue
            if f.name in self._FLATTEN and isinstance(v, Details):
                for k, vv in v.to_dict().items():
                    out.setdefault(k, vv)
                continue
            key = f.name
            if key in self._X_FIELDS and x_name:
                key = f"{x_name}_{key[2:]}"
            out[key] = _plain(v)
        return out


# ===================================================================== lines
@dataclass(frozen=True, kw_only=True)
class LineDetails(Details):
    """A fitted straight line ``y = slope x + intercept`` on ``x_range`` (SI)."""

    slope: float
    intercept: float
    slope_stderr: float | None = None
    intercept_stderr: float | None = None
    r2: float | None = None
    n: int | None = None
    x_range: _Range | None = None

    @classmethod
    def of(cls, fit: Any) -> LineDetails:
        """From a :class:`~xlotkit.interpret.picks.models.LineFit`."""
        return cls(slope=float(fit.slope), intercept=float(fit.intercept),
                   slope_stderr=float(fit.slope_stderr),
                   intercept_stderr=float(fit.intercept_stderr), r2=float(fit.r2),
                   n=int(fit.n), x_range=tuple(float(v) for v in fit.x_range))

    def __call__(self, x):
        return self.slope * np.asarray(x, float) + self.intercept


# ===================================================================== departures
@dataclass(frozen=True, kw_only=True)
class DepartureDetails(Details):
    """First departure from a straight line of ``y(x)``.

    Attributes
    ----------
    x_name : str
        The abscissa: ``"V"`` (pumped volume [m^3]), ``"t"`` [s], ``"sqrt_t"``, ``"G"``.
    line : LineDetails
        The straight stretch's line (``x_range`` its extent).
    sigma : float
        Noise level used for the threshold [Pa].
    x_pick, x_departure_detected, x_first_deviation : float
        Abscissa of the pick, of the first sample of the departure run and of the last
        sample on the line.
    departure : {"below", "above"}
    t_departure_detected : float
        [s].
    trial_values : tuple of float
        The pick over the perturbed settings [Pa].
    line_stderr_at_pick, first_deviation_value : float
        [Pa].
    interval : IntervalBudget
    """

    _X_FIELDS: ClassVar[tuple[str, ...]] = ("x_range", "x_pick", "x_departure_detected",
                                            "x_first_deviation")

    x_name: str
    line: LineDetails
    sigma: float
    x_range: _Range | None = None
    x_pick: float | None = None
    departure: str | None = None
    x_departure_detected: float | None = None
    t_departure_detected: float | None = None
    trial_values: tuple[float, ...] | None = None
    line_stderr_at_pick: float | None = None
    x_first_deviation: float | None = None
    first_deviation_value: float | None = None
    interval: IntervalBudget | None = None

    @property
    def slope(self) -> float:
        """Slope of the straight stretch."""
        return self.line.slope

    @property
    def intercept(self) -> float:
        """Intercept of the straight stretch."""
        return self.line.intercept

    def to_dict(self) -> dict[str, Any]:
        d = self.line.to_dict()
        d.pop("x_range", None)
        d.update(super().to_dict())
        d.pop("line", None)
        return d


@dataclass(frozen=True, kw_only=True)
class PressurisationDetails(Details):
    """LOP / reopening: the departure from the pressurisation line and the stiffness.

    ``stiffness`` [Pa/m^3] when the abscissa is pumped volume, else ``pressurisation_rate``
    [Pa/s]; ``hinge_x`` / ``hinge_pressure`` / ``hinge_stderr``: a two-line fit around the
    departure as an independent check.
    """

    _FLATTEN: ClassVar[tuple[str, ...]] = ("departure",)

    departure: DepartureDetails
    stiffness: float | None = None
    stiffness_stderr: float | None = None
    pressurisation_rate: float | None = None
    pressurisation_rate_stderr: float | None = None
    hinge_x: float | None = None
    hinge_pressure: float | None = None
    hinge_stderr: float | None = None

    @property
    def x_name(self) -> str:
        """Abscissa of the pressurisation line (``"V"`` or ``"t"``)."""
        return self.departure.x_name

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        if "hinge_x" in d:
            d[f"hinge_{self.x_name}"] = d.pop("hinge_x")
        return d


# ===================================================================== pumping picks
@dataclass(frozen=True, kw_only=True)
class BreakdownEvent:
    """A peak of pumping pressure followed by a fall (one FBP candidate).

    Attributes
    ----------
    t, pressure : float
        Time [s] and pressure [Pa] of the peak (3-sample running median).
    drop : float
        Fall of pressure after the peak while the rate held (not cut) [Pa]; for a rejected
        event the fall with the rate cut.
    rate : float or None
        Pump rate at the peak [m^3/s] (None without a rate log).
    accepted : bool
        Whether the fall counts as a breakdown.
    reason : str
        Why (not).
    """

    t: float
    pressure: float
    drop: float
    rate: float | None
    accepted: bool
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True, kw_only=True)
class BreakdownDetails(Details):
    """FBP: the breakdown event and the candidates looked at.

    ``drop_after_peak`` the fall after the chosen peak while the rate held [Pa],
    ``drop_threshold`` the fall that counts [Pa], ``rate_tolerance`` the change of rate
    that counts as a change [m^3/s] (None without a rate), ``highest_pumping_pressure``
    the largest pumping pressure of the cycle [Pa] (not the FBP when a rate step, not a
    breakdown, made it), ``events`` every peak examined.
    """

    drop_after_peak: float
    drop_threshold: float
    sigma: float
    quantum: float
    raw_max: float
    highest_pumping_pressure: float
    rate_at_peak: float | None = None
    rate_tolerance: float | None = None
    rise_rate: float | None = None
    events: tuple[BreakdownEvent, ...] = ()
    interval: IntervalBudget | None = None

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        d["events"] = [e.to_dict() for e in self.events]
        return d


@dataclass(frozen=True, kw_only=True)
class PlateauDetails(Details):
    """FPP: the plateau's sample count, trend [Pa/s], scatter [Pa], the medians of its
    thirds [Pa] and the variation of the pump rate on it."""

    n: int
    trend: float
    trend_stderr: float
    std: float
    thirds: tuple[float, ...]
    rate_cv: float | None = None


@dataclass(frozen=True, kw_only=True)
class IsipDetails(Details):
    """ISIP: the early-decline line after the pump-off drop and what it was made from.

    ``slope`` [Pa/s], ``friction_drop`` = last pumping pressure - ISIP [Pa],
    ``skipped_samples`` the samples of the pump-off drop left out, ``t_shut_in`` the pump
    stop [s], ``pump_window`` the pump phase whose stop it is, ``data_window`` the decline
    samples looked at [s] (the shut-in phase, or further when a user window crossed its
    boundary).
    """

    slope: float
    slope_stderr: float
    intercept_stderr: float
    r2: float
    n: int
    sigma: float
    t_shut_in: float
    last_pumping_pressure: float
    friction_drop: float
    trial_values: tuple[float, ...]
    skipped_samples: int
    interval: IntervalBudget | None = None
    pump_window: _Range | None = None
    data_window: _Range | None = None


# ===================================================================== shut-in closure
@dataclass(frozen=True, kw_only=True)
class BoundaryZone:
    """The end of an analysed decline where the next phase already acts.

    Attributes
    ----------
    t_start, t_end : float
        The zone [s]: from where the decline can no longer be told from the operation that
        ends it, to the last analysed sample.
    next_phase : str
        What ends the decline: a phase kind (``"flowback"``, ``"bleed"``, ``"pump"``,
        ``"idle"``) or ``"end of record"``.
    t_boundary : float
        Start of the next phase [s] (the last sample for the end of the record).
    onset : str
        What marks the zone's start: ``"valve operation"`` (a pressure step the decline
        does not explain, lasting into the next phase) or ``"sample margin"``.
    samples : int
        Samples in the zone.
    """

    t_start: float
    t_end: float
    next_phase: str
    t_boundary: float
    onset: str
    samples: int

    def describe(self) -> str:
        """One line: ``"the flowback at t = 3561 s (valve operation from t = 3540 s)"``."""
        what = ("the end of the record" if self.next_phase == "end of record"
                else f"the {self.next_phase} at t = {self.t_boundary:.0f} s")
        return f"{what} ({self.onset} from t = {self.t_start:.0f} s, {self.samples} samples)"

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True, kw_only=True)
class RejectedCandidate:
    """A closure candidate that was found and rejected, with the reason.

    ``where`` is ``"phase boundary"`` or ``"pump-off drop"``; ``slope_ratio`` the candidate's
    dP/dG after / before.
    """

    t: float
    pressure: float
    where: str
    reason: str
    slope_ratio: float | None = None

    def describe(self) -> str:
        r = f" (dP/dG x{self.slope_ratio:.3g})" if self.slope_ratio is not None else ""
        return (f"slope break at {self.pressure / 1e5:.1f} bar, t = {self.t:.0f} s{r}: "
                f"{self.reason}")

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True, kw_only=True)
class ShutinDetails(Details):
    """What every shut-in closure method analysed.

    Attributes
    ----------
    isip : float
        ISIP [Pa] (the cycle's pick, else the early-decline intercept).
    t_shut_in, t_pump : float
        Pump stop [s] and pumping time [s] (G-function time base).
    drop_samples_skipped : int
        Samples of the pump-off drop left out.
    data_window : (float, float)
        The decline analysed [s].
    boundary : BoundaryZone or None
        The zone before the next phase (None when a user window overrode the boundary).
    rejected : tuple of RejectedCandidate
        Candidates rejected at the boundary or in the pump-off drop.
    """

    isip: float | None = None
    t_shut_in: float | None = None
    t_pump: float | None = None
    drop_samples_skipped: int | None = None
    data_window: _Range | None = None
    boundary: BoundaryZone | None = None
    rejected: tuple[RejectedCandidate, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        d["rejected"] = [r.to_dict() for r in self.rejected]
        if self.boundary is not None:
            d["boundary"] = self.boundary.to_dict()
        return d


@dataclass(frozen=True, kw_only=True)
class SlopeBreakDetails(ShutinDetails):
    """sqrt(t) and G-function: the two lines either side of the slope break on p(x).

    ``line_before`` is the line before closure (on the G plot ``m G`` through the origin is
    then the tangent to ``G dP/dG`` at closure), ``line_after`` the line after;
    ``closure_signature`` ``"stiffening"`` or ``"flattening"``, ``slope_ratio`` dP/dG
    after / before, ``diagnosis`` and ``alpha`` for the G-function only.
    """

    _X_FIELDS: ClassVar[tuple[str, ...]] = ("x_range", "x_pick", "x_pick_stderr")

    x_name: str
    line_before: LineDetails | None = None
    line_after: LineDetails | None = None
    x_range: _Range | None = None
    x_pick: float | None = None
    x_pick_stderr: float | None = None
    closure_signature: str | None = None
    slope_ratio: float | None = None
    break_score: float | None = None
    r2: float | None = None
    n: int | None = None
    trial_values: tuple[float, ...] | None = None
    breakpoint_stderr: float | None = None
    sampling_resolution: float | None = None
    interval: IntervalBudget | None = None
    diagnosis: str | None = None
    alpha: float | None = None

    @property
    def slope(self) -> float | None:
        """Slope before closure (dP/dx)."""
        return None if self.line_before is None else self.line_before.slope

    @property
    def intercept(self) -> float | None:
        """Intercept of the line before closure."""
        return None if self.line_before is None else self.line_before.intercept

    @property
    def slope_after(self) -> float | None:
        """Slope after closure (dP/dx)."""
        return None if self.line_after is None else self.line_after.slope

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        for key, ln in (("line_before", self.line_before), ("line_after", self.line_after)):
            d.pop(key, None)
            if ln is None:
                continue
            if key == "line_before":
                d.update({"slope": ln.slope, "slope_stderr": ln.slope_stderr,
                          "intercept": ln.intercept})
            else:
                d["slope_after"] = ln.slope
                d["line_after"] = {"slope": ln.slope, "intercept": ln.intercept,
                                   f"{self.x_name}_range": ln.x_range}
        return d


@dataclass(frozen=True, kw_only=True)
class ShutinDepartureDetails(ShutinDetails):
    """sqrt(t) / G-function with a user window: the departure from the user's line."""

    departure: DepartureDetails | None = None
    diagnosis: str | None = None
    alpha: float | None = None

    _FLATTEN: ClassVar[tuple[str, ...]] = ("departure",)

    @property
    def x_name(self) -> str | None:
        """Abscissa of the user's line."""
        return None if self.departure is None else self.departure.x_name

    @property
    def slope(self) -> float | None:
        return None if self.departure is None else self.departure.slope

    @property
    def intercept(self) -> float | None:
        return None if self.departure is None else self.departure.intercept

    @property
    def x_range(self) -> _Range | None:
        return None if self.departure is None else self.departure.line.x_range

    @property
    def interval(self) -> IntervalBudget | None:
        return None if self.departure is None else self.departure.interval


@dataclass(frozen=True, kw_only=True)
class TangentDetails(ShutinDetails):
    """Tangents on p vs t: the early and late lines (x = time since pump stop [s]), their
    windows [s] and intersection."""

    early: LineDetails | None = None
    late: LineDetails | None = None
    early_window: _Range | None = None
    late_window: _Range | None = None
    closure_signature: str | None = None
    sampling_resolution: float | None = None
    t_intersection: float | None = None
    t_intersection_stderr: float | None = None
    pressure_on_curve: float | None = None
    trial_values: tuple[float, ...] | None = None
    intersection_stderr: float | None = None
    interval: IntervalBudget | None = None

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        for key, ln in (("early", self.early), ("late", self.late)):
            d.pop(key, None)
            if ln is not None:
                d.update({f"{key}_slope": ln.slope, f"{key}_slope_stderr": ln.slope_stderr,
                          f"r2_{key}": ln.r2})
        return d


@dataclass(frozen=True, kw_only=True)
class BilinearDetails(ShutinDetails):
    """Haimson's bilinear dp/dt vs p: the closed- and open-fracture slopes [1/s] and dp/dt
    at closure [Pa/s]."""

    s_closed: float | None = None
    s_open: float | None = None
    s_closed_stderr: float | None = None
    s_open_stderr: float | None = None
    dpdt_at_closure: float | None = None
    r2: float | None = None
    n: int | None = None
    trial_values: tuple[float, ...] | None = None
    x0_stderr: float | None = None
    interval: IntervalBudget | None = None


@dataclass(frozen=True, kw_only=True)
class ComplianceDetails(ShutinDetails):
    """McClure's compliance method: G at closure, |dP/dG| there [Pa] and the hinge slopes
    of |dP/dG| before and after."""

    G_pick: float | None = None
    G_pick_stderr: float | None = None
    dPdG_at_closure: float | None = None
    s_before: float | None = None
    s_after: float | None = None
    r2: float | None = None
    n: int | None = None
    alpha: float | None = None
    trial_values: tuple[float, ...] | None = None
    interval: IntervalBudget | None = None


# ===================================================================== flowback
@dataclass(frozen=True, kw_only=True)
class FlowbackDetails(Details):
    """The flowback methods: the open- and closed-fracture lines and their crossing.

    ``flowback_sqrt_p``: lines of sqrt(choke pressure) [Pa^0.5] against t [s]
    (``sqrt_p_closure``, ``choke_pressure_closure``, ``slope_ratio``); ``flowback_p_v``:
    pressure [Pa] against returned volume [m^3] (``stiffness_open`` / ``stiffness_closed``
    [Pa/m^3], ``stiffness_ratio``, ``volume_closure``). ``single_line`` when the method ran
    and saw one straight line.
    """

    choke_pressure: str | None = None
    choke_source: str | None = None
    flowing_samples: str | None = None
    volume_source: str | None = None
    single_line: bool | None = None
    x: str | None = None
    y: str | None = None
    line_open: LineDetails | None = None
    line_closed: LineDetails | None = None
    t_closure: float | None = None
    t_closure_stderr: float | None = None
    t_closure_range: _Range | None = None
    sqrt_p_closure: float | None = None
    sqrt_p_closure_stderr: float | None = None
    choke_pressure_closure: float | None = None
    base_pressure: float | None = None
    slope_ratio: float | None = None
    stiffness_open: float | None = None
    stiffness_open_stderr: float | None = None
    stiffness_closed: float | None = None
    stiffness_closed_stderr: float | None = None
    stiffness_ratio: float | None = None
    volume_closure: float | None = None
    volume_closure_stderr: float | None = None
    pressure_closure_stderr: float | None = None
    n_trials: int | None = None
    window_open: _Range | None = None
    window_closed: _Range | None = None
    interval: IntervalBudget | None = None

    @property
    def contrast(self) -> float | None:
        """Closed / open stiffness ratio of either method."""
        return self.slope_ratio if self.slope_ratio is not None else self.stiffness_ratio


# ===================================================================== step-rate
@dataclass(frozen=True, kw_only=True)
class RateStepPoint(Details):
    """One stabilised point of a step-rate test: the step's median rate [m^3/s], its
    pressure at the end of the step [Pa] and whether it had stabilised (left out of the fit
    if not)."""

    rate: float
    pressure: float
    stable: bool = True


@dataclass(frozen=True, kw_only=True)
class StepRateDetails(Details):
    """The fracture-extension pressure (FEP) of a step-rate test
    (:func:`~xlotkit.interpret.picks.steprate.pick_fep`).

    ``steps``: the stabilised points used; ``line_lower`` / ``line_upper``: the lines of
    pressure [Pa] against rate [m^3/s] through the first ``points_lower`` and the last
    ``points_upper`` of them; ``q_fep`` [m^3/s] the rate where they meet; ``slope_ratio``
    upper / lower slope; ``bootstrap`` the breakpoint bootstrap's central range [Pa] and
    ``bootstrap_found`` the fraction of redraws that found a break. Without a break only
    ``steps`` is set.
    """

    steps: tuple[RateStepPoint, ...] = ()
    line_lower: LineDetails | None = None
    line_upper: LineDetails | None = None
    points_lower: int | None = None
    points_upper: int | None = None
    q_fep: float | None = None
    slope_ratio: float | None = None
    bootstrap: _Range | None = None
    bootstrap_found: float | None = None
    interval: IntervalBudget | None = None


# ===================================================================== combinations
@dataclass(frozen=True, kw_only=True)
class ConsensusDetails(Details):
    """A cycle's consensus closure: which ``rule`` applied (``"flowback"``,
    ``"shut-in median"``, ``"median of best available"``, ``"none"``), the ``methods``
    combined, the flowback method ``chosen`` and the ``spread`` of their values [Pa]."""

    rule: str
    methods: tuple[str, ...] = ()
    chosen: str | None = None
    spread: float | None = None


@dataclass(frozen=True, kw_only=True)
class T0Details(Details):
    """The tensile strength's parts: FBP and reopening pressure [Pa]."""

    fbp: float
    pr: float

    def to_dict(self) -> dict[str, Any]:
        return {"FBP": self.fbp, "Pr": self.pr}


@dataclass(frozen=True, kw_only=True)
class RejectedDetails(Details):
    """A closure pick rejected by :func:`~xlotkit.interpret.picks.core.reconcile_closures`:
    the value, interval and details it had and why it went."""

    _FLATTEN: ClassVar[tuple[str, ...]] = ("original",)

    original: Details | None
    rejected_value: float
    rejected_low: float | None
    rejected_high: float | None
    reason: str


@dataclass(frozen=True, kw_only=True)
class AtDepthDetails(Details):
    """A pick moved to the target depth: the shift [Pa] and the depth [m]."""

    _FLATTEN: ClassVar[tuple[str, ...]] = ("original",)

    original: Details | None
    depth_shift: float
    target_tvd: float
