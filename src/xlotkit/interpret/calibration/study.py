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

A pick *covers* when ``low <= truth <= high``. The summary gives per quantity and method
the number of records where the truth exists, how many picks were found, the coverage of
the found ones and the median interval width (absolute and relative to the truth's scale:
``sigma_h`` for pressures, ``T0`` for T0).
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
        The record's factors (gauge, leak-off model, transition, dt, closure phase).
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
    """Coverage of one quantity/method over the study."""

    quantity: str
    method: str
    n_truth: int
    n_found: int
    n_covered: int
    level: float | None
    median_width: float
    median_relative_width: float
    median_abs_error: float

    @property
    def coverage(self) -> float:
        """Covered / found (NaN without found picks)."""
        return self.n_covered / self.n_found if self.n_found else math.nan


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
            found = [o for o in sel if o.found]
            levels = {o.level for o in found}
            w = np.array([o.width for o in found])
            rw = np.array([o.width / o.scale for o in found])
            err = np.array([abs(o.error) for o in found])
            rows.append(SummaryRow(
                q, m, len([o for o in sel if o.truth is not None]), len(found),
                sum(o.covered for o in found),
                levels.pop() if len(levels) == 1 else None,
                float(np.median(w)) if w.size else math.nan,
                float(np.median(rw)) if rw.size else math.nan,
                float(np.median(err)) if err.size else math.nan))
        return rows

    def to_markdown(self) -> str:
        """The summary as a markdown table (widths in bar and % of the scale)."""
        lines = ["| quantity | method | records | found | nominal level | coverage | "
                 "median width [bar] | median width [% of scale] | median abs. error [bar] |",
                 "|---|---|---|---|---|---|---|---|---|"]
        for r in self.summary():
            lv = f"{100 * r.level:.0f} %" if r.level is not None else "–"
            cov = f"{100 * r.coverage:.1f} %" if r.n_found else "–"
            lines.append(f"| {r.quantity} | {r.method} | {r.n_truth} | {r.n_found} | {lv} | "
                         f"{cov} | {r.median_width / _BAR:.2f} | "
                         f"{100 * r.median_relative_width:.2f} | "
                         f"{r.median_abs_error / _BAR:.2f} |")
        return "\n".join(lines)


def _factors(cr: ConstructedRecord, cycle: int | None) -> dict:
    sp = cr.spec
    f = {"gauge": sp.gauge, "leakoff": sp.leakoff, "transition": sp.transition,
         "dt": sp.dt, "noise_bar": sp.noise / _BAR, "resolution_bar": sp.resolution / _BAR}
    if cycle is not None:
        f["closure_phase"] = cr.truth.closure_phase[cycle - 1]
    return f


def evaluate_record(cr: ConstructedRecord, index: int = 0) -> list[Outcome]:
    """Pick one constructed record and compare every pick with its truth."""
    from xlotkit.interpret.picks.core import pick_record

    rp = pick_record(cr.record, cr.segmentation)
    tr = cr.truth
    out: list[Outcome] = []

    def add(cycle, quantity, pick, truth, scale, method=None):
        out.append(Outcome(index, cycle, quantity, method or pick.method, float(truth),
                           pick.value if pick.found else None,
                           pick.low if pick.found else None,
                           pick.high if pick.found else None,
                           getattr(pick, "level", None), float(scale),
                           _factors(cr, cycle)))

    sh = tr.sigma_h
    scale = cr.spec.sigma_h
    for c in rp.test_cycles:
        k = c.index
        if k > 2:
            continue
        phase = tr.closure_phase[k - 1]
        for m, p in c.fcp_methods().items():
            expected = (m.startswith("flowback") if phase == "flowback"
                        else not m.startswith("flowback"))
            if p.found or expected:
                add(k, "FCP", p, sh, scale)
        add(k, "FCP", c.fcp, sh, scale, "consensus")
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
