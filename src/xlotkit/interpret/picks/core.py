"""Run every pick on every cycle of a record and combine them.

:func:`pick_record` is the one call of an interpretation: it segments the record (unless a
:class:`~xlotkit.interpret.phases.Segmentation` is given), runs :func:`pick_cycle` on every
cycle and summarises the record (:class:`RecordPicks`): FCP consistency across cycles, the
tensile strength ``T0 = FBP - Pr`` and the trend of the pressurisation stiffness.

What is picked where
--------------------
The picks are keyed on what a cycle has, not on its kind, except that cycles that open no
fracture (:data:`NON_FRACTURE_KINDS`: line and casing tests, ``other``) get no fracture
picks; every other kind is a *test cycle* (:func:`is_test_cycle`: LOT, XLOT, DFIT,
step-rate test, stimulation ...).

* ``ISIP``: every cycle with a pump stop followed by a shut-in, whatever its kind (for a line
  or casing test it is the pressure the system held).
* The first test cycle of each test (:func:`separate_tests`: a test cycle after the well
  stood idle longer than the test before it lasted opens a new one): ``LOP`` and ``FBP``
  (the breakdown event; the pick reports "not found" when the pressure never fell at an
  unchanged rate). Later test cycles: ``Pr`` (reopening). Every test cycle: ``FPP``; a ``step_rate`` cycle also ``FEP``, the
  fracture-extension pressure (:mod:`~xlotkit.interpret.picks.steprate`), and no ``LOP`` /
  ``Pr`` (:data:`NO_DEPARTURE_KINDS`: its pressure bends at every rate step, so a departure
  from the first line is no leak-off).
* Fracture closure (``FCP``) in test cycles: every shut-in method of
  :data:`xlotkit.interpret.picks.shutin.SHUTIN_METHODS` when the cycle has a pump stop
  followed by a shut-in, both flowback methods (:mod:`~xlotkit.interpret.picks.flowback`)
  when it has a ``flowback`` phase.
* Every cycle: the pressurisation stiffness (a useful check of the well compliance).

Every method is an entry of :data:`METHODS` (:class:`MethodEntry`: pick name, method name,
the phase it reads, and a callable of the one :class:`PickMethod` signature), built from
explicit imports of :mod:`~xlotkit.interpret.picks.pressurisation`,
:mod:`~xlotkit.interpret.picks.shutin` and :mod:`~xlotkit.interpret.picks.flowback`. A
method that raises gives a "not found" pick whose message is the error's one line, never an
invented value (:func:`_run` is the one place that catches).

Consensus FCP
-------------
:func:`consensus_fcp` combines the FCP picks of a cycle into one pick with method
``"consensus"``:

1. **Flowback first.** The system stiffness approach measures closure directly (no
   leak-off model), so a flowback pick of quality ``good`` is taken as is --
   ``flowback_sqrt_p`` before ``flowback_p_v`` (the choke-law plot does not need the
   returned-volume series, whose resolution is usually the weaker one). The interval is that
   pick's interval, widened to cover the other flowback pick if it is ``good`` too.
   The methods' disagreement is added: the interval covers every flowback value found.
2. **Otherwise the shut-in methods.** The found shut-in picks of quality ``good`` or ``fair``
   (falling back to ``poor`` ones, then to ``fair``/``poor`` flowback picks, when there is
   nothing better) are combined by their **median**: the methods have different, partly
   systematic biases (tangents read high on a gradual closure, G-function low with
   height recession), so an inverse-variance mean would follow the most confident rather than
   the most representative. The interval covers every combined pick's interval (min of the
   lows, max of the highs). Quality: ``good`` with >= 3 methods whose values lie within 5 % of
   the median, ``fair`` with >= 2 methods, ``poor`` with one method or only poor inputs.
3. Nothing found: not found, with each method's reason in ``message``.

One fracture state between shut-in and flowback
-----------------------------------------------
A cycle's shut-in and the flowback that follows it (no pumping between) are one monotonic
decline, so the fracture closes in at most one of them. When both find a closure and the
flowback's lies entirely below the shut-in's, they contradict each other: the flowback's
break says the fracture was still open when the shut-in ended, the shut-in's says it had
closed. :func:`reconcile_closures` keeps the side with the stronger closure evidence and
turns the other side's contradicting picks into "not found" with the reason (their values
and details stay in :class:`~xlotkit.interpret.picks.details.RejectedDetails`):

* the flowback's evidence is its stiffness contrast (closed / open slope, ``slope_ratio`` or
  ``stiffness_ratio``: the fracture's compliance leaving the system);
* the shut-in's is the stiffening of its slope break (``slope_ratio`` of a ``"stiffening"``
  break, the same compliance leaving). A *flattening* break carries none: it is how
  leak-off dropping at closure looks, but also how a crack that grows on after shut-in
  looks once the growth slows (the well pressure falls as fluid runs into new crack), so
  it cannot outweigh a measured stiffness rise;
* a flowback break that the other flowback method, run on the same flowback, does not see
  (one straight line) is uncorroborated and counts as no evidence.

With equal evidence (none on either side) both sides are kept and a note says so.

Before the contrasts are weighed, the flowback's *open-side* stiffness is set against the
closed system's, measured independently in the same cycle: the pressurisation line's
dp/dV before leak-off or reopening (:attr:`CyclePicks.stiffness`). Leak-off biases the two
in opposite directions (while pumping it takes fluid from the well and lowers dp/dV of the
pumped volume; while flowing back it drains the well too and raises dp/dV of the returned
volume), so the pressurisation stiffness is a lower bound of the closed system's and the
flowback's open-side stiffness an upper bound of the system's at the flowback start:

* open side significantly softer than the pressurisation line (by more than twice the
  combined standard error): the system still carried the fracture's compliance when the
  flowback began, so the fracture had not closed in the shut-in; the shut-in picks above
  the flowback's closure are rejected, however strong their break (a crack that turned
  at an interface closes its inclined pieces first, at their higher normal stress, with a
  sharp stiffening that is not the closure of the plane normal to sigma_h);
* open side at least as stiff as the pressurisation line: the flowback started on the
  closed system's stiffness, so its break is not the fracture's compliance leaving (it is
  a change of leak-off or of the near-well flow); the flowback picks below the shut-in's
  closure are rejected;
* otherwise (in between, or no stiffness on one side) the contrasts decide as above.

A shut-in break at the phase boundary (where the valve opens for the flowback) carries no
evidence either: the shut-in methods reject such candidates themselves
(:mod:`~xlotkit.interpret.picks.shutin`, "Closure candidates at a boundary"), so they never
reach this rule and can never overrule a flowback break.

Across cycles
-------------
:class:`Consistency` holds the record's closure from the cycles that agree
(:func:`~xlotkit.interpret.picks.agreement.agree_closures`: the largest group of cycles
whose closure intervals share a pressure, its median, the union of its intervals) and names
every other cycle as an outlier with its reason.

Picks whose window or tangents the user fixed are never rejected (a note records the
contradiction).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

import numpy as np

from xlotkit.interpret.phases import Cycle, Phase, Segmentation, segment
from xlotkit.interpret.picks import pressurisation, shutin
from xlotkit.interpret.picks.agreement import ClosureAgreement, agree_closures
from xlotkit.interpret.picks.details import (
    ConsensusDetails,
    FlowbackDetails,
    PressurisationDetails,
    RejectedDetails,
    SlopeBreakDetails,
    T0Details,
)
from xlotkit.interpret.picks.flowback import FLOWBACK_METHODS, pick_fcp_flowback
from xlotkit.interpret.picks.models import fit_line
from xlotkit.interpret.picks.steprate import pick_fep_entry
from xlotkit.interpret.picks.types import Pick
from xlotkit.quiet import captured
from xlotkit.record import Record

__all__ = [
    "FCP_METHODS",
    "METHODS",
    "NO_DEPARTURE_KINDS",
    "PICK_NAMES",
    "SHUTIN_METHOD_NAMES",
    "Consistency",
    "CyclePicks",
    "MethodEntry",
    "PickMethod",
    "PickOptions",
    "RecordPicks",
    "breakdown_and_reopening",
    "consensus_fcp",
    "consensus_rule",
    "is_test_cycle",
    "pick_cycle",
    "pick_record",
    "reconcile_closures",
    "separate_tests",
]

#: Shut-in closure methods (the keys of :data:`xlotkit.interpret.picks.shutin.SHUTIN_METHODS`).
SHUTIN_METHOD_NAMES = tuple(shutin.SHUTIN_METHODS)
#: Every FCP method, shut-in then flowback.
FCP_METHODS = SHUTIN_METHOD_NAMES + FLOWBACK_METHODS
#: Methods that accept fixed tangents (two time windows).
TANGENT_METHODS = ("tangent",) + FLOWBACK_METHODS
#: Cycle kinds that open no fracture (surface lines against a closed valve, a casing held
#: at pressure, a pressurisation that neither departed from its line nor held): they get no
#: closure picks. Every other kind -- LOT, XLOT, DFIT / mini-frac, step-rate test,
#: stimulation, and kinds the segmentation adds later -- is a test cycle.
NON_FRACTURE_KINDS = ("line_test", "casing_test", "other")
#: Test-cycle kinds whose pressurisation has no leak-off departure to find: a step-rate
#: test's pressure bends at every rate step (its pick is the FEP), so no LOP / Pr.
NO_DEPARTURE_KINDS = ("step_rate",)


def is_test_cycle(cycle: Cycle) -> bool:
    """Whether the cycle is a test that may open a fracture (pressure and closure picks)."""
    return cycle.kind not in NON_FRACTURE_KINDS

_Window = tuple[float, float]


# --------------------------------------------------------------------------- methods
class PickMethod(Protocol):
    """The one call signature of a pick method in :data:`METHODS`.

    Parameters
    ----------
    record : Record
    cycle : Cycle
    window : (float, float) or None
        User time window [s], or None for the automatic one (only passed to methods whose
        entry has ``takes_window``).
    tangents : ((float, float), (float, float)) or None
        User-fixed lines before and after the break [s] (only with ``takes_tangents``).
    isip : Pick or None
        The cycle's ISIP when found (used by the shut-in methods).

    Returns
    -------
    Pick
    """

    def __call__(self, record: Record, cycle: Cycle, *, window: _Window | None,
                 tangents: tuple[_Window, _Window] | None, isip: Pick | None) -> Pick: ...


@dataclass(frozen=True)
class MethodEntry:
    """One pick method.

    Attributes
    ----------
    pick : str
        The pick it makes: ``"LOP"``, ``"FBP"``, ``"Pr"``, ``"FPP"``, ``"ISIP"`` or ``"FCP"``.
    method : str
        Its method name (``"auto"`` for the pressurisation picks, the FCP method otherwise).
    phase : {"pump", "shut_in", "flowback"}
        The phase kind it reads; an FCP method runs only when the cycle has that phase.
    run : PickMethod
    takes_window, takes_tangents : bool
        Whether a user window / fixed tangents reach the method (else a note says they were
        ignored).
    """

    pick: str
    method: str
    phase: Literal["pump", "shut_in", "flowback"]
    run: PickMethod
    takes_window: bool = True
    takes_tangents: bool = False


def _lop(record, cycle, *, window, tangents, isip):
    return pressurisation.pick_lop(record, cycle, window=window)


def _fbp(record, cycle, *, window, tangents, isip):
    return pressurisation.pick_fbp(record, cycle)


def _reopening(record, cycle, *, window, tangents, isip):
    return pressurisation.pick_reopening(record, cycle, window=window)


def _fpp(record, cycle, *, window, tangents, isip):
    return pressurisation.pick_fpp(record, cycle, window=window)


def _isip(record, cycle, *, window, tangents, isip):
    return pressurisation.pick_isip(record, cycle, window=window)


def _fcp_tangent(record, cycle, *, window, tangents, isip):
    return shutin.pick_fcp_tangent(record, cycle, window=window, isip=isip, lines=tangents)


def _fcp_sqrt_t(record, cycle, *, window, tangents, isip):
    return shutin.pick_fcp_sqrt_t(record, cycle, window=window, isip=isip)


def _fcp_g_function(record, cycle, *, window, tangents, isip):
    return shutin.pick_fcp_g_function(record, cycle, window=window, isip=isip)


def _fcp_bilinear(record, cycle, *, window, tangents, isip):
    return shutin.pick_fcp_bilinear(record, cycle, window=window, isip=isip)


def _fcp_compliance(record, cycle, *, window, tangents, isip):
    return shutin.pick_fcp_compliance(record, cycle, window=window, isip=isip)


def _flowback(fb_method: str) -> PickMethod:
    # One method per call so that each can have its own window / tangents.
    def run(record, cycle, *, window, tangents, isip):
        picks = pick_fcp_flowback(record, cycle, window=window, tangents=tangents,
                                  methods=(fb_method,))
        return picks[FLOWBACK_METHODS.index(fb_method)]
    return run


#: Every pick method: the pressurisation picks, then the shut-in and flowback FCP methods.
METHODS: tuple[MethodEntry, ...] = (
    MethodEntry("LOP", "auto", "pump", _lop),
    MethodEntry("FBP", "auto", "pump", _fbp, takes_window=False),
    MethodEntry("Pr", "auto", "pump", _reopening),
    MethodEntry("FPP", "auto", "pump", _fpp),
    MethodEntry("ISIP", "auto", "shut_in", _isip),
    MethodEntry("FEP", "two_line", "pump", pick_fep_entry),
    MethodEntry("FCP", "tangent", "shut_in", _fcp_tangent, takes_tangents=True),
    MethodEntry("FCP", "sqrt_t", "shut_in", _fcp_sqrt_t),
    MethodEntry("FCP", "g_function", "shut_in", _fcp_g_function),
    MethodEntry("FCP", "bilinear", "shut_in", _fcp_bilinear),
    MethodEntry("FCP", "compliance", "shut_in", _fcp_compliance),
    *(MethodEntry("FCP", m, "flowback", _flowback(m), takes_tangents=True)
      for m in FLOWBACK_METHODS),
)
#: Non-closure picks (names of the pressurisation entries of :data:`METHODS`).
PICK_NAMES = tuple(e.pick for e in METHODS if e.pick != "FCP")
_BY_PICK = {e.pick: e for e in METHODS if e.pick != "FCP"}
_BY_FCP = {e.method: e for e in METHODS if e.pick == "FCP"}


# --------------------------------------------------------------------------- options
def _norm_key(key: Any, what: str) -> tuple[int | None, str]:
    """``"tangent"`` -> ``(None, "tangent")``; ``(2, "tangent")`` unchanged; validated."""
    if isinstance(key, str):
        cyc, name = None, key
    elif isinstance(key, tuple) and len(key) == 2:
        cyc, name = key
    else:
        raise ValueError(f"{what} key {key!r}: expected 'name' or (cycle_index, 'name')")
    if cyc is not None and (isinstance(cyc, bool) or not isinstance(cyc, (int, np.integer))
                            or cyc < 1):
        raise ValueError(f"{what} key {key!r}: cycle index must be a positive int or None")
    return (None if cyc is None else int(cyc)), str(name)


def _check_window(w: Any, where: str) -> _Window:
    try:
        a, b = (float(v) for v in w)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: window must be (t_start, t_end) in s, got {w!r}") from None
    if not (np.isfinite(a) and np.isfinite(b) and b > a):
        raise ValueError(f"{where}: window needs finite t_end > t_start, got {w!r}")
    return a, b


@dataclass(frozen=True)
class PickOptions:
    """What to pick and where (all optional; the default is fully automatic).

    Parameters
    ----------
    methods : sequence of str
        FCP methods to run, a subset of :data:`FCP_METHODS` (default all).
    windows : mapping
        Time windows [s] overriding the automatic ones. Keys are a pick or method name --
        ``"LOP"``, ``"FBP"``, ``"Pr"``, ``"FPP"``, ``"ISIP"`` or an FCP method -- for every
        cycle, or ``(cycle_index, name)`` for one cycle (which wins over the all-cycles
        entry). Values ``(t_start, t_end)``.
    tangents : mapping
        Fixed tangents for the two-line methods (:data:`TANGENT_METHODS`): same keys, values
        two windows ``((t0, t1), (t2, t3))`` [s] -- the line before and after the break.

    Raises
    ------
    ValueError
        Unknown method or name, malformed key, or an empty/reversed window.
    """

    methods: tuple[str, ...] = FCP_METHODS
    windows: Mapping[Any, _Window] = field(default_factory=dict)
    tangents: Mapping[Any, tuple[_Window, _Window]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        methods = (self.methods,) if isinstance(self.methods, str) else tuple(self.methods)
        for m in methods:
            if m not in FCP_METHODS:
                raise ValueError(f"unknown FCP method {m!r}; expected one of {FCP_METHODS}")
        object.__setattr__(self, "methods", methods)
        wins: dict[tuple[int | None, str], _Window] = {}
        for k, w in dict(self.windows).items():
            key = _norm_key(k, "windows")
            if key[1] not in PICK_NAMES and key[1] not in FCP_METHODS:
                raise ValueError(f"windows key {k!r}: unknown name {key[1]!r}; expected one of "
                                 f"{tuple(PICK_NAMES) + FCP_METHODS}")
            wins[key] = _check_window(w, f"windows[{k!r}]")
        tans: dict[tuple[int | None, str], tuple[_Window, _Window]] = {}
        for k, w in dict(self.tangents).items():
            key = _norm_key(k, "tangents")
            if key[1] not in TANGENT_METHODS:
                raise ValueError(f"tangents key {k!r}: fixed tangents apply to "
                                 f"{TANGENT_METHODS} only")
            try:
                w1, w2 = w
            except (TypeError, ValueError):
                raise ValueError(f"tangents[{k!r}]: expected two windows") from None
            tans[key] = (_check_window(w1, f"tangents[{k!r}][0]"),
                         _check_window(w2, f"tangents[{k!r}][1]"))
        object.__setattr__(self, "windows", wins)
        object.__setattr__(self, "tangents", tans)

    def window(self, cycle_index: int, name: str) -> _Window | None:
        """The window for ``name`` in cycle ``cycle_index`` (cycle-specific first), or None."""
        return self.windows.get((cycle_index, name), self.windows.get((None, name)))

    def tangent(self, cycle_index: int, name: str) -> tuple[_Window, _Window] | None:
        """Fixed tangents for ``name`` in cycle ``cycle_index``, or None."""
        return self.tangents.get((cycle_index, name), self.tangents.get((None, name)))


# --------------------------------------------------------------------------- consensus
_QUALITY_RANK = {"good": 0, "fair": 1, "poor": 2, "none": 3}


def consensus_fcp(picks: Sequence[Pick]) -> Pick:
    """One FCP from a cycle's FCP picks (rule in the module docstring).

    Parameters
    ----------
    picks : sequence of Pick
        Any picks; only those named ``"FCP"`` (and not already ``"consensus"``) are used.

    Returns
    -------
    Pick
        ``name="FCP"``, ``method="consensus"``; ``details`` (:class:`~xlotkit.interpret.
        picks.details.ConsensusDetails`): ``rule``, the branch of the rule that applied, and
        ``methods``, the picks combined.
    """
    fcps = [p for p in picks if p.name == "FCP" and p.method != "consensus"]
    found = [p for p in fcps if p.found]
    if not found:
        reasons = "; ".join(f"{p.method}: {p.message}" for p in fcps) or "no FCP method was run"
        return Pick.not_found("FCP", "consensus", f"no method found closure ({reasons})",
                              details=ConsensusDetails(rule="none"))
    flow = {p.method: p for p in found if p.method in FLOWBACK_METHODS}
    good_flow = [flow[m] for m in FLOWBACK_METHODS if m in flow and flow[m].quality == "good"]
    if good_flow:
        chosen = good_flow[0]
        low = min(p.low if p.low is not None else p.value for p in good_flow)
        high = max(p.high if p.high is not None else p.value for p in good_flow)
        # The methods' disagreement: every flowback value found, good or not.
        fvals = [p.value for p in flow.values()]
        low, high = min(low, *fvals), max(high, *fvals)
        return Pick("FCP", "consensus", chosen.value, low=low, high=high, t=chosen.t,
                    window=chosen.window, quality="good",
                    message=f"system stiffness on flowback ({chosen.method})",
                    details=ConsensusDetails(rule="flowback",
                                             methods=tuple(p.method for p in good_flow),
                                             chosen=chosen.method,
                                             spread=float(max(fvals) - min(fvals))),
                    level=_common_level(good_flow))
    shut = [p for p in found if p.method not in FLOWBACK_METHODS]
    pool = [p for p in shut if p.quality in ("good", "fair")]
    rule = "shut-in median"
    if not pool:
        pool = [p for p in found if p.quality in ("good", "fair")] or found
        rule = "median of best available"
    values = np.array([p.value for p in pool], float)
    med = float(np.median(values))
    low = min(p.low if p.low is not None else p.value for p in pool)
    high = max(p.high if p.high is not None else p.value for p in pool)
    low, high = min(low, med), max(high, med)
    worst = max(_QUALITY_RANK[p.quality] for p in pool)
    agree = bool(np.all(np.abs(values - med) <= 0.05 * abs(med)))
    if len(pool) >= 3 and agree and worst <= 1:
        q = "good"
    elif len(pool) >= 2 and worst <= 1:
        q = "fair"
    else:
        q = "poor"
    names = tuple(p.method for p in pool)
    # The time of the pick closest to the median, for marking on plots.
    closest = pool[int(np.argmin(np.abs(values - med)))]
    return Pick("FCP", "consensus", med, low=low, high=high, t=closest.t, quality=q,
                message=f"median of {', '.join(names)}",
                details=ConsensusDetails(rule=rule, methods=names,
                                         spread=float(values.max() - values.min())),
                level=_common_level(pool))


def consensus_rule(pick: Pick) -> str:
    """The rule a consensus FCP was formed by (``"flowback"``, ``"shut-in median"``, ...),
    ``""`` for any other pick."""
    return pick.details.rule if isinstance(pick.details, ConsensusDetails) else ""


def _common_level(picks: Sequence[Pick]) -> float | None:
    """The nominal level of a union of intervals: the lowest of theirs (each covers the
    truth at least that often), None when one states none."""
    levels = [p.level for p in picks]
    return None if any(v is None for v in levels) else min(levels)


# --------------------------------------------------------------------------- reconcile
def _contrast(p: Pick) -> float:
    """A found closure pick's evidence of the fracture's compliance leaving the system: the
    closed/open slope ratio of a flowback pick or of a stiffening shut-in break; 0 for a
    flattening break or a method that reports no signature."""
    d = p.details
    if isinstance(d, FlowbackDetails):
        r = d.contrast
    elif isinstance(d, SlopeBreakDetails) and d.closure_signature == "stiffening":
        r = d.slope_ratio
    else:
        r = None
    return float(r) if r is not None and np.isfinite(r) else 0.0


def _adjacent_shutin_flowback(cycle: Cycle) -> bool:
    """Whether the cycle's flowback follows its shut-in with no pumping in between."""
    sh, fb = cycle.phase("shut_in"), cycle.phase("flowback")
    if sh is None or fb is None or fb.t_start < sh.t_end - 1e-9:
        return False
    return not any(ph.kind == "pump" and sh.t_end - 1e-9 <= ph.t_start < fb.t_start
                   for ph in cycle.phases)


def _open_side_test(flow: Sequence[Pick], closed_stiffness: float | None,
                    closed_stderr: float | None) -> tuple[str, str]:
    """Where the flowback started, from its open-side stiffness against the cycle's
    pressurisation stiffness (module docstring): ``("open" | "closed" | "", why)``."""
    if closed_stiffness is None or not np.isfinite(closed_stiffness) or closed_stiffness <= 0:
        return "", ""
    for p in flow:
        d = p.details
        if not isinstance(d, FlowbackDetails) or d.stiffness_open is None:
            continue
        k_open = float(d.stiffness_open)
        if not np.isfinite(k_open) or k_open <= 0:
            continue
        se = np.hypot(d.stiffness_open_stderr or 0.0, closed_stderr or 0.0)
        margin = 2.0 * float(se)        # two combined standard errors
        said = (f"{p.method}'s open-side stiffness {k_open / 1e5:.4g} bar/m3 against the "
                f"pressurisation line's {closed_stiffness / 1e5:.4g} bar/m3")
        if k_open + margin < closed_stiffness:
            return "open", said
        if k_open >= closed_stiffness:
            # at or above the lower bound of the closed system's stiffness: no fracture
            # compliance left to lose (between the two tests the contrasts decide)
            return "closed", said
    return "", ""


def reconcile_closures(picks: Sequence[Pick], cycle: Cycle, *, fixed: set[str] | None = None,
                       closed_stiffness: float | None = None,
                       closed_stiffness_stderr: float | None = None
                       ) -> tuple[list[Pick], list[str]]:
    """Make the shut-in and flowback closure picks of a cycle agree on one closure.

    Rule in the module docstring ("One fracture state between shut-in and flowback").

    Parameters
    ----------
    picks : sequence of Pick
        A cycle's picks (any names; only found FCP picks take part).
    cycle : Cycle
    fixed : set of str, optional
        Methods whose window or tangents the user fixed: never rejected.
    closed_stiffness, closed_stiffness_stderr : float, optional
        The cycle's pressurisation stiffness dp/dV and its standard error [Pa/m^3]: the
        closed system's, against which the flowback's open side is judged (None: the
        contrasts alone decide).

    Returns
    -------
    picks : list of Pick
        The picks, the contradicting side's FCP picks replaced by not-found picks.
    notes : list of str
        What was rejected and why (empty when nothing was).
    """
    fixed = fixed or set()
    picks = list(picks)
    if not _adjacent_shutin_flowback(cycle):
        return picks, []
    shut = [p for p in picks if p.name == "FCP" and p.found and p.method in SHUTIN_METHOD_NAMES]
    flow = [p for p in picks if p.name == "FCP" and p.found and p.method in FLOWBACK_METHODS]
    if not shut or not flow:
        return picks, []

    def lo(p: Pick) -> float:
        return p.low if p.low is not None else p.value

    def hi(p: Pick) -> float:
        return p.high if p.high is not None else p.value

    # Top of the flowback's closure interval, and the shut-in picks entirely above it
    f_hi = max(hi(p) for p in flow)
    above = [lo(p) for p in shut if lo(p) > f_hi]
    if not above:
        return picks, []              # the two sides overlap: no contradiction
    s_lo = min(above)
    # A flowback method that ran and saw one straight line contradicts the other's break:
    # uncorroborated, the break cannot overrule the shut-in (e.g. a choke or surface-line
    # effect on the sqrt(p) plot that the returned volume does not show).
    contradicted = any(p.name == "FCP" and not p.found and p.method in FLOWBACK_METHODS
                       and isinstance(p.details, FlowbackDetails) and p.details.single_line
                       for p in picks)
    c_flow = 0.0 if contradicted else max(_contrast(p) for p in flow)
    c_shut = max(_contrast(p) for p in shut)
    start, measured = ("", "") if contradicted else _open_side_test(
        flow, closed_stiffness, closed_stiffness_stderr)
    if start == "open":
        losers = {p.method for p in shut if lo(p) > f_hi}
        why = (f"the flowback that follows finds closure at {f_hi / 1e5:.1f} bar or below and "
               f"started softer than the closed system ({measured}), so the fracture was "
               "still open when the shut-in ended")
    elif start == "closed":
        losers = {p.method for p in flow if hi(p) < s_lo}
        why = (f"the flowback started on the closed system's stiffness ({measured}), so "
               f"its break is not the fracture closing; the shut-in closed it at "
               f"{s_lo / 1e5:.1f} bar or above")
    elif c_flow == c_shut:
        return picks, [f"the shut-in finds closure at {s_lo / 1e5:.1f} bar or above and the "
                       f"flowback after it at {f_hi / 1e5:.1f} bar or below; neither has the "
                       "stronger evidence of the fracture's compliance leaving, both kept"]
    elif c_flow > c_shut:
        # The flowback saw the fracture open below these: no closure in the shut-in.
        losers = {p.method for p in shut if lo(p) > f_hi}
        why = (f"the flowback that follows finds closure at {f_hi / 1e5:.1f} bar or below "
               f"(system stiffness x{c_flow:.3g}), so the fracture was still open when the "
               "shut-in ended")
        if c_shut == 0.0:
            why += ("; the shut-in's break shows no stiffening (a flattening break is "
                    "continued growth or a change of leak-off, not the fracture's compliance "
                    "leaving)")
    else:
        losers = {p.method for p in flow if hi(p) < s_lo}
        why = (f"the shut-in before it closed the fracture at {s_lo / 1e5:.1f} bar or above "
               f"(stiffening x{c_shut:.3g}, stronger than this break's x{c_flow:.3g}), so the "
               "flowback started with the fracture closed")
    out, notes = [], []
    for p in picks:
        if p.name == "FCP" and p.found and p.method in losers:
            if p.method in fixed:
                notes.append(f"{p.method}: kept (window/tangents fixed by the user) although "
                             f"{why}")
                out.append(p)
                continue
            notes.append(f"{p.method}: closure at {p.value / 1e5:.1f} bar rejected: {why}")
            out.append(Pick.not_found(
                "FCP", p.method, f"closure at {p.value / 1e5:.1f} bar rejected: {why}",
                window=p.window, details=RejectedDetails(
                    original=p.details, rejected_value=p.value, rejected_low=p.low,
                    rejected_high=p.high, reason=why)))
        else:
            out.append(p)
    return out, notes


# --------------------------------------------------------------------------- cycle picks
@dataclass(frozen=True)
class CyclePicks:
    """Everything picked in one cycle.

    Attributes
    ----------
    cycle : Cycle
    picks : tuple of Pick
        Every pick run, found or not (one per name and method).
    reference : str
        Where the pressure was measured (:meth:`PressureReference.describe`).
    stiffness : float or None
        Pressurisation system stiffness dp/dV [Pa/m^3] (slope of pressure against pumped
        volume before leak-off).
    stiffness_stderr : float or None
        Its standard error [Pa/m^3].
    stiffness_source : str
        ``"LOP details"`` when taken from the pressurisation pick, else how it was fitted.
    fcp : Pick
        Consensus FCP (:func:`consensus_fcp`); computed from ``picks`` when not given.
    notes : tuple of str
        Remarks (skipped picks, failures).
    """

    cycle: Cycle
    picks: tuple[Pick, ...]
    reference: str = ""
    stiffness: float | None = None
    stiffness_stderr: float | None = None
    stiffness_source: str = ""
    fcp: Pick | None = None
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "picks", tuple(self.picks))
        object.__setattr__(self, "notes", tuple(self.notes))
        if self.fcp is None:
            if is_test_cycle(self.cycle):
                fcp = consensus_fcp(self.picks)
            else:
                fcp = Pick.not_found("FCP", "consensus",
                                     f"{self.cycle.kind} cycle: no closure picked")
            object.__setattr__(self, "fcp", fcp)

    @property
    def index(self) -> int:
        """The cycle's 1-based index."""
        return self.cycle.index

    @property
    def kind(self) -> str:
        """The cycle's kind."""
        return self.cycle.kind

    def get(self, name: str, method: str | None = None) -> Pick | None:
        """The pick ``name`` (by ``method`` if given), or None if it was not run.

        ``get("FCP")`` and ``get("FCP", "consensus")`` return the consensus :attr:`fcp`.
        """
        if name == "FCP" and method in (None, "consensus"):
            return self.fcp
        for p in self.picks:
            if p.name == name and (method is None or p.method == method):
                return p
        return None

    def fcp_methods(self) -> dict[str, Pick]:
        """FCP picks by method name (without the consensus)."""
        return {p.method: p for p in self.picks if p.name == "FCP"}


# --------------------------------------------------------------------------- running
def _run(entry: MethodEntry, record: Record, cycle: Cycle, *, window: _Window | None,
         tangents: tuple[_Window, _Window] | None, isip: Pick | None) -> Pick:
    """Call one method; the one place a failing method becomes a not-found pick."""
    name, method = entry.pick, entry.method
    # numpy/LAPACK warnings (RankWarning, DLASCL) never reach the terminal: they become a
    # note on this pick, and a "good" pick made despite them is only "fair"
    with captured() as said:
        try:
            out = entry.run(record, cycle, window=window, tangents=tangents, isip=isip)
        except Exception as exc:
            line = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
            return Pick.not_found(name, method,
                                  f"{method} failed: {type(exc).__name__}: {line}".rstrip(": "))
    if out.found and not np.isfinite(out.value):
        # missing samples (NaN pressure where the file recorded none) reached the fit
        return Pick.not_found(name, method, f"{method} gave no finite value (missing samples "
                                            "in its window?)")
    notes = said.notes()
    if notes:
        msg = (out.message + "; " if out.message else "") + "numerical warnings: " + \
            "; ".join(notes[:3])
        out = dataclasses.replace(out, message=msg, quality="fair" if out.quality == "good"
                                  else out.quality)
    return out


# --------------------------------------------------------------------------- stiffness
def _pumped_volume(record: Record, i0: int, i1: int) -> np.ndarray | None:
    if record.volume is not None:
        v = record.volume[i0:i1]
        return v - v[0]
    if record.rate is not None:
        t, q = record.t[i0:i1], record.rate[i0:i1]
        return np.concatenate([[0.0], np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(t))])
    return None


def _stiffness(record: Record, cycle: Cycle, picks: Sequence[Pick]
               ) -> tuple[float | None, float | None, str]:
    """Pressurisation system stiffness dp/dV [Pa/m^3] of the cycle's first pump phase.

    A straight line through pressure against pumped volume between 15 % and 60 % of the
    pressure rise (capped at the LOP / Pr when one was picked): low enough to stay below
    leak-off or reopening, high enough to be past the initial take-up of slack (air, line
    expansion). It is fitted here rather than taken from the LOP/Pr line because that line
    is chosen to find a departure (the longest straight stretch), which in a later cycle can
    be the open-fracture stretch above reopening. When the LOP/Pr details carry a stiffness
    that differs by more than 20 %, the source string says so.
    """
    pump = cycle.phase("pump")
    if pump is None or pump.i1 - pump.i0 < 5:
        return None, None, "no pump phase"
    v = _pumped_volume(record, pump.i0, pump.i1)
    if v is None:
        return None, None, "no pumped volume"
    p = record.pressure[pump.i0:pump.i1]
    p0 = float(np.min(p[: max(3, p.size // 20)]))
    top = float(np.max(p))
    lop = next((pk.value for pk in picks if pk.name in ("LOP", "Pr") and pk.found), None)
    upper = p0 + 0.6 * (top - p0)
    if lop is not None and p0 + 0.3 * (top - p0) < lop < upper:
        upper = lop
    # Only the rising part before the peak: after breakdown the pressure revisits this range.
    ipk = int(np.argmax(p))
    m = np.zeros(p.size, bool)
    m[: ipk + 1] = True
    m &= (p >= p0 + 0.15 * (top - p0)) & (p <= upper)
    if m.sum() < 5 or np.ptp(v[m]) <= 0:
        return None, None, "too few pressurisation samples"
    with captured() as said:
        f = fit_line(v[m], p[m])
    if not f.slope > 0:
        return None, None, "pressure did not rise with pumped volume"
    src = "line through p vs pumped volume (15-60 % of the pressure rise)"
    if said.notes():
        src += "; numerical warnings: " + "; ".join(said.notes()[:3])
    for pk in picks:
        if pk.name in ("LOP", "Pr") and isinstance(pk.details, PressurisationDetails):
            s = pk.details.stiffness
            if s is not None and np.isfinite(s) and s > 0 and abs(s / f.slope - 1.0) > 0.2:
                src += f"; the {pk.name} line has {s / 1e5:.4g} bar/m3"
    se = float(f.slope_stderr) if np.isfinite(f.slope_stderr) else None
    return float(f.slope), se, src


# --------------------------------------------------------------------------- pick_cycle
def pick_cycle(record: Record, cycle: Cycle, *, previous: CyclePicks | None = None,
               options: PickOptions | None = None, after: Sequence[Phase] = ()) -> CyclePicks:
    """Run every applicable pick on one cycle (module docstring, "What is picked where").

    Parameters
    ----------
    record : Record
    cycle : Cycle
    previous : CyclePicks, optional
        Picks of the previous *test* cycle; None marks this as the first test cycle (LOP and
        FBP are picked there, reopening in later ones).
    options : PickOptions, optional
    after : sequence of Phase, optional
        The idle phases that follow the cycle in the record before the next cycle starts: a
        user window may reach into them (it overrides the phase boundaries it crosses).

    Returns
    -------
    CyclePicks
    """
    options = options or PickOptions()
    ref = record.reference.describe()
    notes: list[str] = []
    ci = cycle.index
    trailing = tuple(ph for ph in after if ph.kind == "idle" and ph.t_start >= cycle.t_end)
    view = dataclasses.replace(cycle, phases=tuple(cycle.phases) + trailing) if trailing \
        else cycle

    def press(name: str) -> Pick:
        entry = _BY_PICK[name]
        win = options.window(ci, name)
        if win is not None and not entry.takes_window:
            notes.append(f"{name}: the pick takes no window, override ignored")
            win = None
        return _run(entry, record, view, window=win, tangents=None, isip=None)

    if not is_test_cycle(cycle):
        isip = press("ISIP")
        s, se, src = _stiffness(record, cycle, ())
        return CyclePicks(cycle, (isip,), ref, s, se, src,
                          notes=(f"{cycle.kind} cycle: no fracture picks, only the ISIP and "
                                 "the stiffness",))
    picks: list[Pick] = []
    departure = "Pr" if previous is not None else "LOP"
    if cycle.kind in NO_DEPARTURE_KINDS:
        # the pressure bends at every rate step: a departure from the first line is the
        # next step, not leak-off; the stabilised p-q line's break (FEP) is the pick
        notes.append(f"{cycle.kind} cycle: no {departure} (the pressure bends at every rate "
                     "step; the fracture-extension pressure FEP is the pick)")
    else:
        picks.append(press(departure))
    if previous is None:
        picks.append(press("FBP"))
    picks.append(press("FPP"))
    if cycle.kind == "step_rate":
        picks.append(press("FEP"))
    isip = press("ISIP")
    picks.append(isip)

    wanted = set(options.methods)
    for phase, what in (("shut_in", "shut-in"), ("flowback", "flowback")):
        entries = [e for e in METHODS if e.pick == "FCP" and e.phase == phase
                   and e.method in wanted]
        if cycle.phase(phase) is None:
            if entries:
                notes.append(f"no {what} phase: {what} closure methods not run")
            continue
        for e in entries:
            tan = options.tangent(ci, e.method)
            if tan is not None and not e.takes_tangents:
                notes.append(f"{e.method}: fixed tangents not supported by the method, ignored")
                tan = None
            picks.append(_run(e, record, view, window=options.window(ci, e.method),
                              tangents=tan, isip=isip if isip.found else None))
    fixed = {m for m in FCP_METHODS
             if options.window(ci, m) is not None or options.tangent(ci, m) is not None}
    # the closed system's stiffness (LOP/Pr picked above; the closure picks do not enter it)
    s, se, src = _stiffness(record, cycle, picks)
    picks, why = reconcile_closures(picks, cycle, fixed=fixed, closed_stiffness=s,
                                    closed_stiffness_stderr=se)
    notes.extend(why)
    return CyclePicks(cycle, tuple(picks), ref, s, se, src, notes=tuple(notes))


# --------------------------------------------------------------------------- record
@dataclass(frozen=True)
class Consistency:
    """How the cycles of a record agree.

    Attributes
    ----------
    fcp : tuple of (int, float)
        Consensus FCP [Pa] per test cycle where found.
    fcp_mean, fcp_spread : float or None
        Mean and max - min of those [Pa].
    fcp_relative_spread : float or None
        ``fcp_spread / fcp_mean``.
    t0 : Pick
        Tensile strength ``T0 = FBP - Pr`` (FBP of a test's first cycle, Pr of the next cycle
        of the same test that has one: :func:`breakdown_and_reopening`) [Pa]; interval ``[FBP.low - Pr.high, FBP.high - Pr.low]``.
    stiffness : tuple of (int, float)
        Pressurisation stiffness [Pa/m^3] per cycle where found (all cycle kinds).
    stiffness_slope, stiffness_slope_stderr : float or None
        Least-squares trend of the stiffness with cycle index [Pa/m^3 per cycle] (>= 3
        cycles for a standard error). A falling stiffness means growing compliance: a fracture
        that stays open or a leaking shoe.
    stiffness_relative_change : float or None
        Last / first stiffness - 1.
    closure : ClosureAgreement
        The record's closure from the cycles that agree, and the outlier cycles with their
        reasons (:func:`~xlotkit.interpret.picks.agreement.agree_closures`).
    """

    fcp: tuple[tuple[int, float], ...]
    fcp_mean: float | None
    fcp_spread: float | None
    fcp_relative_spread: float | None
    t0: Pick
    stiffness: tuple[tuple[int, float], ...]
    stiffness_slope: float | None
    stiffness_slope_stderr: float | None
    stiffness_relative_change: float | None
    closure: ClosureAgreement | None = None


def separate_tests(cycles: Sequence[Cycle]) -> list[list[int]]:
    """The record's tests: runs of test cycles (indices into ``cycles``) on one fracture.

    A test cycle after the well stood idle for longer than the test before it lasted (from
    its first cycle's start to its last one's end) opens a new test -- hours between them
    is another operation (a casing test or FIT before the XLOT, on a gauge left in the
    hole), not the reopening of the same fracture: its first cycle gets LOP and FBP again.
    """
    out: list[list[int]] = []
    for k, c in enumerate(cycles):
        if not is_test_cycle(c):
            continue
        if out:
            first, last = cycles[out[-1][0]], cycles[out[-1][-1]]
            if c.t_start - last.t_end <= max(last.t_end - first.t_start, 0.0):
                out[-1].append(k)
                continue
        out.append([k])
    return out


def breakdown_and_reopening(cycles: Sequence[CyclePicks]) -> tuple[Pick | None, Pick | None]:
    """FBP and Pr of one test (:func:`separate_tests`): the first test whose first cycle has
    a breakdown and a later cycle a reopening pressure (else the first test's FBP, no Pr)."""
    seqs = separate_tests([c.cycle for c in cycles])
    first_fbp = None
    for seq in seqs:
        fbp = cycles[seq[0]].get("FBP")
        if fbp is None or not fbp.found:
            continue
        first_fbp = first_fbp or fbp
        pr = next((cycles[k].get("Pr") for k in seq[1:] if cycles[k].get("Pr") is not None
                   and cycles[k].get("Pr").found), None)
        if pr is not None:
            return fbp, pr
    return first_fbp, None


def _t0(cycles: Sequence[CyclePicks]) -> Pick:
    fbp, pr = breakdown_and_reopening(cycles)
    if fbp is None:
        return Pick.not_found("T0", "FBP-Pr", "no breakdown pressure in the first test cycle "
                                              "of any test")
    if pr is None:
        return Pick.not_found("T0", "FBP-Pr", "no reopening pressure in a later cycle of the "
                                              "same test")
    value = fbp.value - pr.value
    lo = (fbp.low if fbp.low is not None else fbp.value) - (
        pr.high if pr.high is not None else pr.value)
    hi = (fbp.high if fbp.high is not None else fbp.value) - (
        pr.low if pr.low is not None else pr.value)
    q = max((fbp.quality, pr.quality), key=lambda k: _QUALITY_RANK[k])
    msg = "T0 = FBP - Pr"
    if value < 0:
        msg += " is negative: reopening above breakdown, check the picks"
        q = "poor"
    # Differences of two intervals of level L cover the difference at least when both
    # cover, and usually more (their errors partly cancel); the study measures it.
    lvl = _common_level((fbp, pr))
    return Pick("T0", "FBP-Pr", value, low=min(lo, value), high=max(hi, value), quality=q,
                message=msg, details=T0Details(fbp=fbp.value, pr=pr.value), level=lvl)


def _consistency(cycles: Sequence[CyclePicks]) -> Consistency:
    tests = [c for c in cycles if is_test_cycle(c.cycle)]
    fcp = tuple((c.index, float(c.fcp.value)) for c in tests
                if c.fcp is not None and c.fcp.found)
    if fcp:
        v = np.array([x for _, x in fcp])
        mean, spread = float(v.mean()), float(np.ptp(v))
        rel = spread / mean if mean else None
    else:
        mean = spread = rel = None
    st = tuple((c.index, float(c.stiffness)) for c in cycles if c.stiffness is not None)
    slope = slope_se = change = None
    if len(st) >= 2:
        i = np.array([k for k, _ in st], float)
        s = np.array([x for _, x in st])
        if len(st) >= 3:
            f = fit_line(i, s)
            slope, slope_se = f.slope, f.slope_stderr
        else:
            slope = float((s[1] - s[0]) / (i[1] - i[0]))
        change = float(s[-1] / s[0] - 1.0)
    closure = agree_closures([(c.index, c.fcp) for c in tests])
    return Consistency(fcp, mean, spread, rel, _t0(cycles), st, slope, slope_se, change,
                       closure)


@dataclass(frozen=True)
class RecordPicks:
    """Picks of a whole record.

    Attributes
    ----------
    record : Record
    segmentation : Segmentation
    cycles : tuple of CyclePicks
        One per cycle of the segmentation, in order.
    options : PickOptions
    consistency : Consistency
        Computed from ``cycles`` when not given.
    """

    record: Record
    segmentation: Segmentation
    cycles: tuple[CyclePicks, ...]
    options: PickOptions = field(default_factory=PickOptions)
    consistency: Consistency | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "cycles", tuple(self.cycles))
        if self.consistency is None:
            object.__setattr__(self, "consistency", _consistency(self.cycles))

    @property
    def t0(self) -> Pick:
        """Tensile strength ``FBP - Pr`` [Pa] (see :class:`Consistency`)."""
        return self.consistency.t0

    def cycle(self, index: int) -> CyclePicks:
        """Picks of the cycle with 1-based ``index``."""
        for c in self.cycles:
            if c.index == index:
                return c
        raise KeyError(f"no cycle {index}")

    @property
    def test_cycles(self) -> tuple[CyclePicks, ...]:
        """The test cycles (:func:`is_test_cycle`: every kind that may open a fracture)."""
        return tuple(c for c in self.cycles if is_test_cycle(c.cycle))


def pick_record(record: Record, segmentation: Segmentation | None = None, *,
                options: PickOptions | None = None) -> RecordPicks:
    """Pick every cycle of a record.

    Parameters
    ----------
    record : Record
    segmentation : Segmentation, optional
        Default: :func:`xlotkit.interpret.phases.segment` of the record.
    options : PickOptions, optional

    Returns
    -------
    RecordPicks
    """
    options = options or PickOptions()
    if segmentation is None:
        segmentation = segment(record)
    out: list[CyclePicks] = []
    previous: CyclePicks | None = None
    cycles = segmentation.cycles
    opens = {seq[0] for seq in separate_tests(cycles)}
    for k, cyc in enumerate(cycles):
        t_next = cycles[k + 1].t_start if k + 1 < len(cycles) else np.inf
        after = tuple(ph for ph in segmentation.phases
                      if ph.kind == "idle" and cyc.t_end <= ph.t_start < t_next)
        if k in opens:
            previous = None  # a new test: LOP and FBP again
        cp = pick_cycle(record, cyc, previous=previous, options=options, after=after)
        out.append(cp)
        if is_test_cycle(cyc):
            previous = cp
    return RecordPicks(record, segmentation, tuple(out), options)

