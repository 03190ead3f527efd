"""One closure stress from the cycles of a record that agree, and the cycles that do not.

Each test cycle gives one consensus closure with a (90 %) interval
(:func:`~xlotkit.interpret.picks.core.consensus_fcp`). The record's closure -- the sigma_h
estimate before the move to depth -- comes from the cycles that agree:

1. **The largest group of cycles whose intervals share a common pressure.** Cycles whose
   intervals overlap at one value are consistent with one closure stress within their own
   stated uncertainty. In one dimension intervals that overlap pairwise share a common
   point, so the largest such group is the set of intervals covering the best-covered
   pressure (found exactly by sweeping the interval ends). With several groups of the same
   size the one whose closures rest on more methods (a closure two flowback methods or
   several shut-in methods agree on is better founded than one method's), then more
   closures seen on flowback (system stiffness, no leak-off model), then the better
   qualities, then the later cycles (a grown fracture closes more cleanly than the first,
   near-wellbore one).
2. **Value: the median of the group's values; interval: the union of their intervals.**
   The median is not pulled by one member at the edge of the group; the union covers each
   member's own closure, and the scatter from cycle to cycle is part of what the closure
   stress is uncertain about.
3. **Every other cycle is an outlier, named with its reason**: its value, how far it lies
   from the group and that its interval does not reach the group's common pressure, and
   what its closure rests on.

Why intervals and not a MAD rule: a record has 2 to 6 cycles, too few for the median
absolute deviation to estimate a scale (with 3 cycles the MAD is one of two differences),
while each cycle's interval already states how far its own closure can be from the truth.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from xlotkit.interpret.picks.details import ConsensusDetails
from xlotkit.interpret.picks.types import Pick

__all__ = ["ClosureAgreement", "agree_closures"]

_BAR = 1e5
_QUALITY_RANK = {"good": 0, "fair": 1, "poor": 2, "none": 3}


@dataclass(frozen=True)
class ClosureAgreement:
    """The record's closure from the cycles that agree.

    Attributes
    ----------
    value, low, high : float or None
        Median of the agreeing cycles' closures and the union of their intervals [Pa].
    cycles : tuple of int
        The agreeing cycles.
    outliers : tuple of (int, str)
        Every other cycle with a closure, and why it is left out.
    representative : int or None
        The agreeing cycle whose closure is nearest the median (for plots and reports that
        name one cycle).
    level : float or None
        The lowest stated level of the agreeing intervals (None when one states none).
    message : str
        How the value was formed, in words.
    """

    value: float | None
    low: float | None
    high: float | None
    cycles: tuple[int, ...]
    outliers: tuple[tuple[int, str], ...]
    representative: int | None
    level: float | None
    message: str

    @property
    def found(self) -> bool:
        """Whether any cycle gave a closure."""
        return self.value is not None


def _from_flowback(p: Pick) -> bool:
    d = p.details
    methods = d.methods if isinstance(d, ConsensusDetails) else ()
    return any(str(m).startswith("flowback") for m in methods)


def _n_methods(p: Pick) -> int:
    d = p.details
    return max(len(d.methods), 1) if isinstance(d, ConsensusDetails) else 1


def _basis(p: Pick) -> str:
    return p.message or p.method


def agree_closures(closures: Sequence[tuple[int, Pick]]) -> ClosureAgreement:
    """The record's closure from per-cycle consensus closures (module docstring).

    Parameters
    ----------
    closures : sequence of (int, Pick)
        Cycle index and that cycle's consensus FCP; picks without a value are ignored.

    Returns
    -------
    ClosureAgreement
    """
    found = [(i, p) for i, p in closures if p is not None and p.found]
    if not found:
        return ClosureAgreement(None, None, None, (), (), None, None,
                                "no closure was picked in any test cycle")
    lo = np.array([p.low if p.low is not None else p.value for _, p in found], float)
    hi = np.array([p.high if p.high is not None else p.value for _, p in found], float)
    val = np.array([p.value for _, p in found], float)
    lo, hi = np.minimum(lo, val), np.maximum(hi, val)
    # every group of mutually overlapping intervals is the set covering one of the ends
    groups = {tuple(np.flatnonzero((lo <= x) & (x <= hi)).tolist()) for x in np.r_[lo, hi]}

    def rank(g: tuple[int, ...]):
        picks = [found[k][1] for k in g]
        return (len(g), sum(_n_methods(p) for p in picks),
                sum(_from_flowback(p) for p in picks),
                -sum(_QUALITY_RANK.get(p.quality, 3) for p in picks),
                sorted((found[k][0] for k in g), reverse=True))

    best = max(groups, key=rank)
    members = [found[k] for k in best]
    vals = np.array([p.value for _, p in members])
    value = float(np.median(vals))
    low, high = float(lo[list(best)].min()), float(hi[list(best)].max())
    rep = members[int(np.argmin(np.abs(vals - value)))][0]
    levels = [p.level for _, p in members]
    level = None if any(v is None for v in levels) else float(min(levels))
    common_lo, common_hi = float(lo[list(best)].max()), float(hi[list(best)].min())
    names = ", ".join(str(i) for i, _ in members)
    outliers = []
    for k, (i, p) in enumerate(found):
        if k in best:
            continue
        side = "below" if p.value < value else "above"
        gap = (common_lo - hi[k]) if p.value < value else (lo[k] - common_hi)
        outliers.append((i, (
            f"cycle {i}: closure {p.value / _BAR:.1f} bar [{lo[k] / _BAR:.1f}-"
            f"{hi[k] / _BAR:.1f}] lies {abs(p.value - value) / _BAR:.1f} bar {side} the "
            f"{'cycle' if len(members) == 1 else 'cycles'} {names} "
            f"({value / _BAR:.1f} bar); its interval misses the pressure they share by "
            f"{max(gap, 0.0) / _BAR:.1f} bar; it rests on: {_basis(p)}")))
    if len(members) == 1 and len(found) > 1:
        msg = (f"no two cycles' closure intervals overlap; the closure rests on cycle "
               f"{members[0][0]} (flowback before shut-in, then quality, then the later cycle)")
    elif len(members) == 1:
        msg = f"one cycle with a closure (cycle {members[0][0]})"
    else:
        msg = (f"median of cycles {names}, whose closure intervals share "
               f"{common_lo / _BAR:.1f}-{common_hi / _BAR:.1f} bar; interval: their union")
    if outliers:
        msg += "; outliers: cycle " + ", ".join(str(i) for i, _ in outliers)
    return ClosureAgreement(value, low, high, tuple(i for i, _ in members), tuple(outliers),
                            rep, level, msg)
