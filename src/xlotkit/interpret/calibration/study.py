"""How often the picks' nominal intervals contain the truth, on constructed records.

:func:`run_study` draws records with :func:`~xlotkit.interpret.calibration.records.draw_spec`,
builds them (:func:`~xlotkit.interpret.calibration.records.construct_record`), picks them
with :func:`~xlotkit.interpret.picks.core.pick_record` on the phases as constructed (so the
intervals are tested, not the segmentation) and compares every pick with the truth:

* ``FCP`` by every method that found a value and the consensus, against ``sigma_h``
  (every found closure pick is compared: a closure reported where the record has none is a
  miss, whatever its interval);
* ``ISIP`` of both cycles, ``LOP`` and ``FBP`` of cycle 1, ``Pr`` of cycle 2,
  ``T0 = FBP - Pr``.

A pick *covers* when ``low <= truth <= high``.

Cases
-----
A **case** is a truth the record's data hold, so that a pick can be asked of it. For the
closure it is a cycle whose recorded decline holds the closure on both sides: at least
:data:`~xlotkit.interpret.calibration.records.CASE_SAMPLES` samples above and below the
closure transition in the phase that crosses it (:attr:`Truth.closure_in_data`; a shut-in
that ends above closure is no case), and for a method the phase it reads (shut-in methods
on shut-in closures, flowback methods on flowback closures; the consensus on every
closure). ISIP, FBP, LOP, Pr and T0 are cases wherever the constructed record has them.
A closure pick made where the cycle holds no closure is no case; it is still compared
with ``sigma_h`` (a closure reported where there is none is a miss, whatever its interval).

The summary gives per quantity and method:

* ``cases``, ``found`` (picks made on cases) and the **found rate** ``found / cases``;
* the **coverage of the found picks** (covered / all picks made, cases or not): how often
  an interval the toolkit states contains the truth;
* the **coverage over all cases** (covered picks on cases / cases): a case without a pick
  counts as a miss, so this is coverage times found rate, the chance that the toolkit both
  answers and is right;
* the median interval width (absolute and relative to the truth's scale: ``sigma_h`` for
  pressures, ``T0`` for T0) and the median absolute error of the found picks.

:meth:`StudyResult.found_rate_by` breaks the found rate of a quantity down by a factor of
the records (gauge, leak-off model, closure contrast...).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from xlotkit.interpret.calibration.records import (
    ConstructedRecord,
    construct_record,
    draw_spec,
)

__all__ = ["Outcome", "StudyResult", "SummaryRow", "evaluate_record", "run_study"]

_BAR = 1e5


@dataclass(frozen=True)
class Outcome:
    """One pick against its truth.

    Attributes
    ----------
    record : int
        Index of the record in the study.
    cycle : int or None
        Cycle (None for T0).
    quantity : str
        ``"FCP"``, ``"ISIP"``, ``"LOP"``, ``"FBP"``, ``"Pr"`` or ``"T0"``.
    method : str
        The pick's method (``"consensus"`` for the consensus FCP).
    truth : float
        [Pa].
    value, low, high : float or None
        The pick [Pa] (None when not found).
    level : float or None
        The pick's stated nominal level.
    scale : float
        Scale for relative widths [Pa] (``sigma_h`` or the true T0).
    factors : dict
        The record's factors (gauge, leak-off model, transition, dt, closure phase,
        closure contrast).
    case : bool
        Whether the truth is a case (module docstring).
    """

    record: int
    cycle: int | None
    quantity: str
    method: str
    truth: float
    value: float | None
    low: float | None
    high: float | None
    level: float | None
    scale: float
    factors: dict = field(default_factory=dict)
    case: bool = True

    @property
    def found(self) -> bool:
        """Whether the pick has a value."""
        return self.value is not None

    @property
    def covered(self) -> bool:
        """Whether the interval contains the truth (False when not found)."""
        if not self.found:
            return False
        lo = self.low if self.low is not None else self.value
        hi = self.high if self.high is not None else self.value
        return lo <= self.truth <= hi

    @property
    def width(self) -> float:
        """Interval width [Pa] (NaN when not found)."""
        if not self.found:
            return math.nan
        lo = self.low if self.low is not None else self.value
        hi = self.high if self.high is not None else self.value
        return hi - lo

    @property
    def error(self) -> float:
        """``value - truth`` [Pa] (NaN when not found)."""
        return self.value - self.truth if self.found else math.nan


@dataclass(frozen=True)
class SummaryRow:
    """Coverage of one quantity/method over the study (module docstring).

    ``n_cases``: truths the data hold; ``n_found``: picks made on them; ``n_extra``: picks
    made where the data hold no case; ``n_covered``: covered picks among all picks made;
    ``n_covered_cases``: covered picks among the cases.
    """

    quantity: str
    method: str
    n_cases: int
    n_found: int
    n_extra: int
    n_covered: int
    n_covered_cases: int
    level: float | None
    median_width: float
    median_relative_width: float
    median_abs_error: float

    @property
    def coverage(self) -> float:
        """Covered / picks made (cases or not); NaN without picks."""
        made = self.n_found + self.n_extra
        return self.n_covered / made if made else math.nan

    @property
    def found_rate(self) -> float:
        """Picks made on cases / cases (NaN without cases)."""
        return self.n_found / self.n_cases if self.n_cases else math.nan

    @property
    def coverage_all(self) -> float:
        """Covered picks on cases / cases: a case without a pick is a miss."""
        return self.n_covered_cases / self.n_cases if self.n_cases else math.nan


@dataclass(frozen=True)
class StudyResult:
    """Outcomes of a study and its summary."""

    n_records: int
    seed: int
    outcomes: tuple[Outcome, ...]

    def select(self, quantity: str, method: str | None = None) -> list[Outcome]:
        """Outcomes of ``quantity`` (and ``method``)."""
        return [o for o in self.outcomes if o.quantity == quantity
                and (method is None or o.method == method)]

    def summary(self) -> list[SummaryRow]:
        """One row per quantity and method, in a fixed order."""
        keys: list[tuple[str, str]] = []
        for o in self.outcomes:
            k = (o.quantity, o.method)
            if k not in keys:
                keys.append(k)
        order = {"FCP": 0, "ISIP": 1, "LOP": 2, "FBP": 3, "Pr": 4, "T0": 5}
        keys.sort(key=lambda k: (order.get(k[0], 9), k[1] != "consensus", k[1]))
        rows = []
        for q, m in keys:
            sel = self.select(q, m)
            made = [o for o in sel if o.found]
            cases = [o for o in sel if o.case]
            levels = {o.level for o in made}
            w = np.array([o.width for o in made])
            rw = np.array([o.width / o.scale for o in made])
            err = np.array([abs(o.error) for o in made])
            rows.append(SummaryRow(
                q, m, len(cases), sum(o.found for o in cases),
                sum(o.found and not o.case for o in sel), sum(o.covered for o in made),
                sum(o.covered for o in cases),
                levels.pop() if len(levels) == 1 else None,
                float(np.median(w)) if w.size else math.nan,
                float(np.median(rw)) if rw.size else math.nan,
                float(np.median(err)) if err.size else math.nan))
        return rows

    def found_rate_by(self, quantity: str, method: str, factor: str,
                      bins: Sequence[float] | None = None) -> list[tuple[str, int, int, int]]:
        """Found rate of ``quantity``/``method`` on its cases, by ``factor``.

        Parameters
        ----------
        factor : str
            A key of :attr:`Outcome.factors`.
        bins : sequence of float, optional
            Edges for a numeric factor (values outside fall in the end bins); default: one
            row per distinct value.

        Returns
        -------
        list of (label, cases, found, covered)
        """
        cases = [o for o in self.select(quantity, method) if o.case]
        groups: dict[tuple, list[Outcome]] = {}
        for o in cases:
            v = o.factors.get(factor)
            if bins is None:
                key = (0, v if isinstance(v, (int, float)) else 0, str(v))
            elif v is None or not np.isfinite(v):
                key = (1, 0, "not measurable")
            else:
                k = int(np.searchsorted(bins, v, side="right"))
                lab = (f"below {bins[0]:g}" if k == 0 else
                       f"{bins[-1]:g} and above" if k == len(bins) else
                       f"{bins[k - 1]:g} to {bins[k]:g}")
                key = (0, k, lab)
            groups.setdefault(key, []).append(o)
        return [(key[2], len(g), sum(o.found for o in g), sum(o.covered for o in g))
                for key, g in sorted(groups.items(), key=lambda kv: kv[0])]

    def to_markdown(self) -> str:
        """The summary as a markdown table (widths in bar and % of the scale)."""
        lines = ["| quantity | method | cases | found | found rate | found outside cases | "
                 "nominal level | coverage of found picks | coverage over all cases | "
                 "median width [bar] | median width [% of scale] | median abs. error [bar] |",
                 "|---|---|---|---|---|---|---|---|---|---|---|---|"]

        def pct(x):
            return f"{100 * x:.1f} %" if np.isfinite(x) else "–"

        for r in self.summary():
            lv = f"{100 * r.level:.0f} %" if r.level is not None else "–"
            lines.append(f"| {r.quantity} | {r.method} | {r.n_cases} | {r.n_found} | "
                         f"{pct(r.found_rate)} | {r.n_extra} | {lv} | {pct(r.coverage)} | "
                         f"{pct(r.coverage_all)} | {r.median_width / _BAR:.2f} | "
                         f"{100 * r.median_relative_width:.2f} | "
                         f"{r.median_abs_error / _BAR:.2f} |")
        return "\n".join(lines)


def _factors(cr: ConstructedRecord, cycle: int | None) -> dict:
    sp = cr.spec
    f = {"gauge": sp.gauge, "leakoff": sp.leakoff, "transition": sp.transition,
         "dt": sp.dt, "noise_bar": sp.noise / _BAR, "resolution_bar": sp.resolution / _BAR}
    if cycle is not None:
        f["closure_phase"] = cr.truth.closure_phase[cycle - 1]
        f["closure_contrast"] = cr.truth.closure_contrast[cycle - 1]
        f["closure_in_data"] = cr.truth.closure_in_data[cycle - 1]
    return f


def evaluate_record(cr: ConstructedRecord, index: int = 0) -> list[Outcome]:
    """Pick one constructed record and compare every pick with its truth."""
    from xlotkit.interpret.picks.core import pick_record

    rp = pick_record(cr.record, cr.segmentation)
    tr = cr.truth
    out: list[Outcome] = []

    def add(cycle, quantity, pick, truth, scale, method=None, case=True):
        out.append(Outcome(index, cycle, quantity, method or pick.method, float(truth),
                           pick.value if pick.found else None,
                           pick.low if pick.found else None,
                           pick.high if pick.found else None,
                           getattr(pick, "level", None), float(scale),
                           _factors(cr, cycle), case))

    sh = tr.sigma_h
    scale = cr.spec.sigma_h
    for c in rp.test_cycles:
        k = c.index
        if k > 2:
            continue
        phase = tr.closure_phase[k - 1]
        in_data = tr.closure_in_data[k - 1]
        for m, p in c.fcp_methods().items():
            expected = (m.startswith("flowback") if phase == "flowback"
                        else not m.startswith("flowback"))
            if p.found or expected:
                add(k, "FCP", p, sh, scale, case=expected and in_data)
        add(k, "FCP", c.fcp, sh, scale, "consensus", case=in_data)
        isip = c.get("ISIP")
        if isip is not None:
            add(k, "ISIP", isip, tr.isip[k - 1], scale)
        if k == 1 and c.get("FBP") is not None:
            add(k, "FBP", c.get("FBP"), tr.fbp, scale)
        if k == 1 and c.get("LOP") is not None:
            add(k, "LOP", c.get("LOP"), tr.lop, scale)
        if k == 2 and c.get("Pr") is not None:
            add(k, "Pr", c.get("Pr"), tr.reopening, scale)
    add(None, "T0", rp.t0, tr.t0, tr.t0)
    return out


def run_study(n: int, *, seed: int = 2024, progress: Callable[[int, int], None] | None = None,
              draw_kw: dict | None = None) -> StudyResult:
    """Draw, build, pick and evaluate ``n`` records.

    Parameters
    ----------
    n : int
        Number of records.
    seed : int
        Seed of the draw (the same seed gives the same records and numbers).
    progress : callable, optional
        ``progress(done, n)`` after each record.
    draw_kw : dict, optional
        Keywords fixing factors of :func:`draw_spec` (e.g. ``{"gauge": "surface"}``).

    Returns
    -------
    StudyResult
    """
    rng = np.random.default_rng(seed)
    outcomes: list[Outcome] = []
    for i in range(n):
        sp = draw_spec(rng, **(draw_kw or {}))
        outcomes.extend(evaluate_record(construct_record(sp), i))
        if progress is not None:
            progress(i + 1, n)
    return StudyResult(n, seed, tuple(outcomes))


def coverage_table(results: Sequence[StudyResult]) -> str:
    """Markdown of several studies' summaries one after the other."""
    return "\n\n".join(r.to_markdown() for r in results)
