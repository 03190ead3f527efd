"""Split a record into phases (pump, shut-in, flowback, bleed, idle) and group them into cycles.

Data types are fixed here so that the picks, reports and CLI can rely on them.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field, fields, replace
from typing import Literal

import numpy as np

from xlotkit.errors import InputError
from xlotkit.record import Record

__all__ = ["ReleaseEvidence", "Cycle", "CycleKind", "Phase", "PhaseKind", "SegmentOptions", "Segmentation", "segment"]

PhaseKind = Literal["pump", "shut_in", "flowback", "bleed", "idle"]
CycleKind = Literal["line_test", "casing_test", "lot", "xlot", "other"]


class ReleaseEvidence(enum.Enum):
    """What shows that a fall of pressure is a bleed or flowback rather than leak-off.

    ``RETURN_FLOW``: a return rate or return/pumped volume column shows fluid coming back.
    ``REMARK``: an operator remark near the fall mentions a bleed, flowback or opened valve.
    ``UNEXPLAINED_DECLINE``: the fall accelerates well past the decline the same shut-in
    showed before it (leak-off only slows down), or releases the pressure to base much faster
    than the record's own pump-off decline.
    ``PRESSURE_ONLY``: no rate is logged at all; a fast release to base is the only sign.
    """

    RETURN_FLOW = "return_flow"
    REMARK = "remark"
    UNEXPLAINED_DECLINE = "unexplained_decline"
    PRESSURE_ONLY = "pressure_only"


@dataclass(frozen=True)
class Phase:
    """A contiguous stretch of a record with one operating state.

    Attributes
    ----------
    kind : PhaseKind
        ``pump`` (fluid pumped in), ``shut_in`` (well closed, no flow), ``flowback`` (fluid
        returned through a choke: return rate or falling volume), ``bleed`` (pressure released
        quickly / at a controlled rate), ``idle`` (no test: well open, pressure at base level).
    i0, i1 : int
        Sample indices into the record, half-open ``[i0, i1)``.
    t_start, t_end : float
        Elapsed times of the first and last sample [s].
    pumped_m3, returned_m3 : float
        Volume pumped in and returned during the phase [m^3].
    peak_pressure : float
        Highest pressure in the phase [Pa], on the record's reference.
    mean_rate : float
        Mean pump rate (negative for returns) [m^3/s].
    evidence : tuple of ReleaseEvidence
        For ``bleed`` and ``flowback`` phases: what the release was declared from (empty for
        other kinds).
    """

    kind: PhaseKind
    i0: int
    i1: int
    t_start: float
    t_end: float
    pumped_m3: float = 0.0
    returned_m3: float = 0.0
    peak_pressure: float = 0.0
    mean_rate: float = 0.0
    evidence: tuple[ReleaseEvidence, ...] = ()

    @property
    def duration(self) -> float:
        """Phase length [s]."""
        return self.t_end - self.t_start


@dataclass(frozen=True)
class Cycle:
    """One pressurisation and what follows it until the next one.

    Attributes
    ----------
    index : int
        1-based cycle number in the record.
    kind : CycleKind
        ``line_test`` (surface lines against a closed valve), ``casing_test`` (casing held at
        pressure, no leak-off), ``lot`` (pumping stopped at/soon after leak-off), ``xlot``
        (pumped past leak-off into breakdown/propagation), ``other``.
    phases : tuple of Phase
        The phases, in time order; the first is the pressurising ``pump`` phase.
    t_start, t_end : float
        Elapsed times [s].
    peak_pressure : float
        Highest pressure in the cycle [Pa].
    pumped_m3, returned_m3 : float
        Volumes pumped and returned in the cycle [m^3].
    reason : str
        Why it was classified as it was (for reports).
    """

    index: int
    kind: CycleKind
    phases: tuple[Phase, ...]
    t_start: float
    t_end: float
    peak_pressure: float
    pumped_m3: float
    returned_m3: float
    reason: str = ""

    @property
    def duration(self) -> float:
        """Cycle length [s]."""
        return self.t_end - self.t_start

    def phase(self, kind: PhaseKind) -> Phase | None:
        """The first phase of ``kind`` in the cycle, or None."""
        for p in self.phases:
            if p.kind == kind:
                return p
        return None


@dataclass(frozen=True)
class Segmentation:
    """Phases and cycles found in a record.

    Attributes
    ----------
    phases : tuple of Phase
        All phases covering the record, in order.
    cycles : tuple of Cycle
        Cycles (each a sub-sequence of ``phases``).
    used_rate : bool
        Whether the pump rate drove the split (False: pressure alone).
    notes : tuple of str
        Remarks about the segmentation (thresholds used, ambiguities).
    """

    phases: tuple[Phase, ...]
    cycles: tuple[Cycle, ...]
    used_rate: bool
    notes: tuple[str, ...] = field(default_factory=tuple)


# ====================================================================== segmentation options
_BAR = 1.0e5  # Pa
_LPM = 1.0e-3 / 60.0  # m^3/s per l/min


@dataclass(frozen=True)
class SegmentOptions:
    """Thresholds of :func:`segment`, SI units (the defaults in field units in brackets).

    Attributes
    ----------
    pump_rate_on, pump_rate_off : float
        Pump rate [m^3/s] above which pumping starts and below which it stops (hysteresis)
        [10 and 5 l/min].
    return_rate_on, return_rate_off : float
        Same for the return (flowback) rate [m^3/s] [10 and 5 l/min].
    return_volume_rate : float
        Growth of the return volume (or fall of the pumped volume while not pumping) [m^3/s]
        that counts as flowback when no return rate is logged [5 l/min].
    rate_filter_s : float
        Running-median window applied to the rates [s] so one-sample spikes and dropouts do
        not start or stop a phase [5 s].
    rate_gap_s : float
        Pauses in pumping or returns shorter than this are bridged [s] [10 s].
    min_pump_s : float
        Shortest pump phase kept [s] [10 s].
    min_phase_s : float
        Shortest shut-in / flowback / idle phase kept; shorter ones join a neighbour [s] [15 s].
    smooth_s : float
        Running-median window for the pressure [s] [10 s].
    slope_s : float
        Half-width of the centred difference giving dp/dt [s] [10 s].
    idle_band : float
        Pressure above the base level below which the well counts as idle [Pa] [5 bar].
    min_cycle_pressure : float
        Pressure gain a pump phase must make (from its start and above the base) to open a
        cycle [Pa] [10 bar]; smaller ones are top-ups or line flushes.
    topup_max_volume : float
        A pump phase starting from a pressurised, shut-in well that pumps less than this is a
        top-up, not a new cycle [m^3] [0.05 m^3 = 50 l].
    bleed_rate : float
        Pressure fall rate marking a bleed (valve opened) [Pa/s] [20 bar/min].
    bleed_fraction : float
        A fast fall is a bleed only if it releases at least this fraction of the pressure
        above base [-] [0.6]; smaller fast falls (the step at pump stop) stay shut-in.
    bleed_gap_s : float
        Fast falls closer than this are one staged bleed [s] [60 s].
    rise_rate : float
        Pressure rise rate taken as pumping when no rate is logged (or the pump is not
        metered, e.g. a line test pump) [Pa/s] [10 bar/min].
    unmetered_rise_rate : float
        A rise with no metered rate (no rate logged at all, or the line-test pump that is
        not metered) counts as pumping only if it is this steep at its steepest [Pa/s]
        [60 bar/min]: slower rises with the pump off are a shut-in well recovering after a
        bleed (fluid coming back from the fracture), which can rise at 30-40 bar/min.
    rise_linearity : float
        Pumping at constant rate raises pressure about linearly in time, a shut-in well
        recovering after a bleed rises fast first and then levels off. A rise counts as
        pumping only if it takes at least this fraction of its duration to make half its
        gain [-] [0.3].
    flowback_rate : float
        Without return data: a sustained fall faster than this that brings the pressure
        most of the way back to base is a flowback [Pa/s] [3 bar/min].
    step_drop : float
        Without rate: smallest sudden fall that marks the pump stop at the end of a
        propagation plateau [Pa] [3 bar]; at least 5 % of the pressure above base.
    line_test_stiffness : float
        Pressurisation stiffness dp/dV above which a cycle is a line test (surface lines
        against a closed valve) [Pa/m^3] [1 bar/l = 1e11 Pa/m^3].
    line_test_max_volume : float
        A cycle pressurised with less than this volume is a line test [m^3] [0.02 m^3 = 20 l].
    departure_tolerance : float
        Fall below the early linear p-V trend, as a fraction of the pressure gain, that
        counts as a departure from linearity (leak-off) [-] [0.05].
    xlot_fall : float
        Fall of pressure while still pumping, as a fraction of the gain, that marks a
        breakdown / propagation (XLOT) [-] [0.05].
    xlot_past_ratio : float
        Volume pumped past the departure, relative to the volume up to it, beyond which a
        cycle is an XLOT rather than a LOT [-] [0.5].
    hold_window_s : float
        Length of the hold assessed after pumping stops [s] [600 s].
    min_hold_s : float
        Shortest hold that can make a pressure test [s] [60 s].
    hold_max_drop : float
        Largest fall over the hold, as a fraction of the pressure above base, for a test to
        count as held [-] [0.1].
    base_dwell_fraction : float
        The base pressure is the lowest level where the record dwells at least this fraction
        of its length [-] [0.05].
    """

    pump_rate_on: float = 10.0 * _LPM
    pump_rate_off: float = 5.0 * _LPM
    return_rate_on: float = 10.0 * _LPM
    return_rate_off: float = 5.0 * _LPM
    return_volume_rate: float = 5.0 * _LPM
    rate_filter_s: float = 5.0
    rate_gap_s: float = 10.0
    min_pump_s: float = 10.0
    min_phase_s: float = 15.0
    smooth_s: float = 10.0
    slope_s: float = 10.0
    idle_band: float = 5.0 * _BAR
    min_cycle_pressure: float = 10.0 * _BAR
    topup_max_volume: float = 0.05
    bleed_rate: float = 20.0 * _BAR / 60.0
    bleed_fraction: float = 0.6
    bleed_gap_s: float = 60.0
    rise_rate: float = 10.0 * _BAR / 60.0
    unmetered_rise_rate: float = 60.0 * _BAR / 60.0
    rise_linearity: float = 0.3
    flowback_rate: float = 3.0 * _BAR / 60.0
    step_drop: float = 3.0 * _BAR
    line_test_stiffness: float = 1.0e11
    line_test_max_volume: float = 0.02
    departure_tolerance: float = 0.05
    xlot_fall: float = 0.05
    xlot_past_ratio: float = 0.5
    hold_window_s: float = 600.0
    min_hold_s: float = 60.0
    hold_max_drop: float = 0.1
    base_dwell_fraction: float = 0.05

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"must be a finite number, got {v!r}", key=f.name)
            if v < 0:
                raise InputError(f"must be >= 0, got {v!r}", key=f.name)
        for name in ("bleed_fraction", "rise_linearity", "departure_tolerance", "xlot_fall",
                     "hold_max_drop", "base_dwell_fraction"):
            if not 0.0 < getattr(self, name) < 1.0:
                raise InputError(f"must be between 0 and 1, got {getattr(self, name)!r}",
                                 key=name)
        for on, off in (("pump_rate_on", "pump_rate_off"), ("return_rate_on", "return_rate_off")):
            if getattr(self, off) > getattr(self, on):
                raise InputError(f"must not exceed {on} ({getattr(self, on)!r})", key=off)
        for name in ("pump_rate_on", "return_rate_on", "smooth_s", "slope_s", "rise_rate",
                     "bleed_rate", "min_cycle_pressure", "idle_band"):
            if getattr(self, name) <= 0:
                raise InputError("must be > 0", key=name)


# ====================================================================== small helpers
def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges ``[i0, i1)`` of the True runs of ``mask``."""
    m = np.concatenate(([False], np.asarray(mask, bool), [False]))
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(d[::2], d[1::2])]


def _span(t: np.ndarray, i0: int, i1: int) -> float:
    """Duration covered by samples ``[i0, i1)`` including one sample interval [s]."""
    if i1 <= i0:
        return 0.0
    dt = float(t[1] - t[0]) if t.size > 1 else 0.0
    if i1 < t.size:
        return float(t[i1] - t[i0])
    return float(t[-1] - t[i0]) + dt


def _bridge(mask: np.ndarray, t: np.ndarray, gap_s: float) -> np.ndarray:
    """Fill interior False gaps shorter than ``gap_s`` [s]."""
    out = mask.copy()
    for a, b in _runs(~mask):
        if a > 0 and b < mask.size and _span(t, a, b) < gap_s:
            out[a:b] = True
    return out


def _drop_short(mask: np.ndarray, t: np.ndarray, min_s: float) -> np.ndarray:
    """Remove True runs shorter than ``min_s`` [s]."""
    out = mask.copy()
    for a, b in _runs(mask):
        if _span(t, a, b) < min_s:
            out[a:b] = False
    return out


def _hysteresis(x: np.ndarray, on: float, off: float) -> np.ndarray:
    """True from where ``x`` exceeds ``on`` until it falls below ``off``."""
    out = np.zeros(x.size, bool)
    state = False
    for i, v in enumerate(x):
        if state:
            state = v >= off
        else:
            state = v > on
        out[i] = state
    return out


def _window(t: np.ndarray, seconds: float) -> int:
    """Number of samples spanning ``seconds`` (odd, >= 1)."""
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    n = max(1, int(round(seconds / dt)))
    return n if n % 2 else n + 1


def _median(x: np.ndarray, n: int) -> np.ndarray:
    """Running median over ``n`` samples (odd), edges padded with the end values.

    The same numbers as ``scipy.ndimage.median_filter(x, size=n, mode="nearest")``
    (``tests/interpret/test_io_conventions.py`` checks it), through pandas' rolling median,
    which is already imported by the reader; importing ``scipy.ndimage`` alone costs about a
    third of a second per command.
    """
    if n <= 1:
        return x.copy()
    import pandas as pd

    h = n // 2
    padded = np.concatenate([np.full(h, x[0]), x, np.full(h, x[-1])])
    med = pd.Series(padded).rolling(n, center=True, min_periods=1).median().to_numpy()
    return med[h:h + x.size]


def _slope(t: np.ndarray, y: np.ndarray, half: int) -> np.ndarray:
    """Centred difference ``dy/dt`` over ``±half`` samples (one-sided at the ends)."""
    n = y.size
    if n < 2:
        return np.zeros(n)
    half = max(1, half)
    i = np.arange(n)
    lo = np.clip(i - half, 0, n - 1)
    hi = np.clip(i + half, 0, n - 1)
    dt = t[hi] - t[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        s = (y[hi] - y[lo]) / dt
    return np.where(dt > 0, s, 0.0)


def _cum_positive(x: np.ndarray) -> np.ndarray:
    """Running sum of the positive increments of ``x`` (totaliser resets contribute 0)."""
    d = np.diff(np.nan_to_num(x), prepend=np.nan_to_num(x[:1]))
    return np.cumsum(np.clip(d, 0.0, None))


def _cum_rate(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Cumulative trapezoidal integral of a rate [m^3/s] -> [m^3]."""
    q = np.clip(np.nan_to_num(q), 0.0, None)
    out = np.zeros(q.size)
    if q.size > 1:
        out[1:] = np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(t))
    return out


def _base_pressure(t: np.ndarray, p: np.ndarray, opt: SegmentOptions) -> float:
    """Lowest pressure level where the record dwells long enough [Pa].

    The surface base is ~0 bar gauge; a downhole gauge's base is the hydrostatic head. A
    histogram of time spent per ``idle_band / 2`` bin is scanned from the bottom; brief
    excursions below it (gauge run in or pulled out) do not count.
    """
    ok = np.isfinite(p)
    if not ok.all():
        t, p = t[ok], p[ok]
    if p.size < 3:
        return float(np.min(p)) if p.size else 0.0
    width = opt.idle_band / 2.0
    lo, hi = float(np.min(p)), float(np.max(p))
    if hi - lo < width:
        return float(np.median(p))
    # Never more bins than the record could fill: a wild value (a 1e12 bar cell) must not
    # make the histogram allocate terabytes; bins then widen relative to the record.
    n_max = 20 * p.size + 1000
    if (hi - lo) / width > n_max:
        width = (hi - lo) / n_max
    edges = np.arange(lo, hi + width, width)
    w = np.diff(t, append=t[-1] + (t[-1] - t[-2]))
    dwell, _ = np.histogram(p, bins=edges, weights=w)
    total = float(np.sum(w))
    ok = np.flatnonzero(dwell >= opt.base_dwell_fraction * total)
    if ok.size == 0:
        return float(np.percentile(p, 5))
    k = int(ok[0])
    sel = (p >= edges[k]) & (p <= edges[k + 1])
    return float(np.median(p[sel]))


# ====================================================================== detectors
def _pump_like_rises(t, ps, dpdt, allowed, base, opt, min_peak_slope=0.0
                     ) -> list[tuple[int, int]]:
    """Stretches of ``allowed`` samples where the pressure rises like pumping does.

    A candidate is a run with dp/dt above ``rise_rate`` (short gaps bridged), widened while
    the pressure keeps rising; it must gain at least ``idle_band`` and be about linear in
    time (``rise_linearity``), which rejects the fast-then-levelling recovery of a shut-in
    well after a bleed.
    """
    cand = _bridge((dpdt > opt.rise_rate) & allowed, t, opt.rate_gap_s) & allowed
    out = []
    for a, b in _runs(cand):
        smax = float(np.max(dpdt[a:b]))
        if smax < min_peak_slope:
            continue
        floor = 0.1 * smax
        while a > 0 and allowed[a - 1] and dpdt[a - 1] > floor:
            a -= 1
        while b < t.size and allowed[b] and dpdt[b] > floor:
            b += 1
        seg = ps[a:b]
        if seg.size < 3:
            continue
        k = int(np.argmax(seg))
        j0 = int(np.argmin(seg[: k + 1]))
        gain = float(seg[k] - seg[j0])
        if gain < opt.idle_band:
            continue
        a, b = a + j0, a + k + 1
        half = ps[a] + 0.5 * gain
        ih = a + int(np.argmax(ps[a:b] >= half))
        dur = t[b - 1] - t[a]
        if dur <= 0 or (t[ih] - t[a]) / dur < opt.rise_linearity:
            continue
        out.append((a, b))
    return out


def _sharp_drops(t, ps, base, i0, i1, opt) -> list[int]:
    """Sample indices in ``[i0, i1)`` where a sudden, lasting pressure fall starts."""
    w = _window(t, 20.0)
    persist = _window(t, 60.0)
    starts = []
    i = i0
    while i < i1 - 1:
        j = min(i + w, i1 - 1)
        step = max(opt.step_drop, 0.05 * max(ps[i] - base, 0.0))
        if ps[i] - ps[j] >= step:
            later = ps[j: min(j + persist, i1)]
            if later.size == 0 or float(np.max(later)) < ps[i] - 0.5 * step:
                # the fall starts where the pressure leaves its level, not 20 s before
                k = i + int(np.argmax(ps[i:j + 1] < ps[i] - 0.25 * step))
                starts.append(max(i, k - 1))
                i = j
                continue
        i += 1
    return starts


def _fall_runs(t, ps, dpdt, allowed, base, rate, fraction, gap_s, min_s) -> list[tuple[int, int]]:
    """Runs falling faster than ``rate`` [Pa/s] that release ``fraction`` of the excess."""
    cand = _bridge((dpdt < -rate) & allowed, t, gap_s) & allowed
    out = []
    for a, b in _runs(cand):
        while a > 0 and allowed[a - 1] and dpdt[a - 1] < -0.25 * rate:
            a -= 1
        while b < t.size and allowed[b] and dpdt[b] < -0.25 * rate:
            b += 1
        # the run ends at its lowest point
        k = a + int(np.argmin(ps[a:b]))
        b = k + 1
        j = a + int(np.argmax(ps[a:b]))
        a = j
        if b - a < 2 or _span(t, a, b) < min_s:
            continue
        excess = ps[a] - base
        drop = ps[a] - ps[b - 1]
        if excess > 0 and drop >= fraction * excess:
            out.append((a, b))
    return out


_EVIDENCE: tuple[ReleaseEvidence | None, ...] = (None, *ReleaseEvidence)
_RELEASE_WORDS = ("bleed", "bled", "flow back", "flowback", "flow-back", "open", "release",
                  "vent", "choke")
# leak-off decline only slows down with time; a fall this many times faster than the decline
# just before it needs the well to have been opened
_ACCELERATION = 3.0
# leak-off after a pump phase takes a time comparable to the pumping; a release to near base
# in less than this fraction of the pump time is not leak-off
_FAST_RELEASE = 0.1


def _release_evidence(record, t, ps, dpdt, pump, base, a, b, opt) -> ReleaseEvidence | None:
    """Evidence that the fall over samples ``[a, b)`` is a release (see ReleaseEvidence)."""
    t0, t1 = float(t[a]) - 60.0, float(t[b - 1])
    for e in record.events:
        if t0 <= e.t <= t1 and any(w in e.text.lower() for w in _RELEASE_WORDS):
            return ReleaseEvidence.REMARK
    before = np.flatnonzero(pump[:a])
    pe = int(before[-1]) + 1 if before.size else 0
    fall = float(np.max(-dpdt[a:b]))
    excess = float(ps[a] - base)
    if excess <= 0:
        return None
    settle = _window(t, 2.0 * opt.slope_s)
    if a - pe > 2 * settle:
        # the most recent decline of the shut-in before the fall (last third of it)
        ref = float(np.median(-dpdt[a - max(settle, (a - pe) // 3): a - settle // 2]))
        # floor: a flat shut-in would make any fall look infinitely faster
        ref = max(ref, 1e-4 * excess / max(opt.slope_s, 1e-9))
        if fall >= _ACCELERATION * ref:
            return ReleaseEvidence.UNEXPLAINED_DECLINE
        return None
    # the fall starts at pump stop: compare its speed with the pumping time
    if before.size:
        runs = [r for r in _runs(pump[:a]) if r[1] == pe]
        tp = _span(t, runs[0][0], runs[0][1]) if runs else 0.0
        near_base = ps[b - 1] - base <= 0.2 * excess
        if tp > 0 and near_base and _span(t, a, b) < _FAST_RELEASE * tp:
            return ReleaseEvidence.UNEXPLAINED_DECLINE
    return None


def _with_evidence(ph: Phase, evidence: np.ndarray) -> Phase:
    """``ph`` with the release evidence found on its samples (bleed/flowback only)."""
    if ph.kind not in ("bleed", "flowback"):
        return replace(ph, evidence=())
    codes = sorted({int(c) for c in np.unique(evidence[ph.i0:ph.i1]) if c})
    return replace(ph, evidence=tuple(_EVIDENCE[c] for c in codes))


# ====================================================================== segment
_CODES = {"idle": 0, "shut_in": 1, "pump": 2, "flowback": 3, "bleed": 4}
_KINDS = {v: k for k, v in _CODES.items()}


def segment(record: Record, *, options: SegmentOptions | None = None) -> Segmentation:
    """Split ``record`` into phases and group them into cycles.

    Algorithm
    ---------
    1. Pressure (gauge, Pa) is median-smoothed (``smooth_s``) and differentiated
       (``slope_s``); the base level is the lowest pressure the record dwells at.
    2. Pumping: from the pump rate when there is one (running median, hysteresis
       ``pump_rate_on``/``off``, pauses < ``rate_gap_s`` bridged, runs < ``min_pump_s``
       dropped), plus pump-like pressure rises while no rate is metered (a line-test pump);
       without a rate, from pump-like rises alone, each extended to the last sudden fall
       (the pump-stop step) before the pressure is released.
    3. Not pumping: ``bleed`` where the pressure falls fast (``bleed_rate``) and releases most
       of it (``bleed_fraction``); ``flowback`` where returns are logged (return rate,
       growing return volume, falling pumped volume) or, without them, a sustained fall
       (``flowback_rate``) back towards base; ``shut_in`` above ``base + idle_band``;
       ``idle`` otherwise. Shorter phases than ``min_phase_s`` join their neighbours.
    4. A pump phase opens a cycle when it raises the pressure by ``min_cycle_pressure``
       above both its start and the base, unless it is a top-up (starts from a pressurised
       shut-in and pumps < ``topup_max_volume``). Pump phases that do not (flushes at base
       pressure) become ``idle``. A cycle runs to the next one; trailing idle is cut off.
    5. Each cycle is classified from the p-V curve of its first pump phase (see
       :func:`_classify`).

    Parameters
    ----------
    record : Record
        The record; ``pressure`` is required, ``rate``/``volume``/``return_*`` are used when
        present.
    options : SegmentOptions, optional
        Thresholds (defaults: :class:`SegmentOptions`).

    Returns
    -------
    Segmentation
    """
    opt = options or SegmentOptions()
    n = record.n
    if n == 0:
        return Segmentation(phases=(), cycles=(), used_rate=False, notes=("empty record",))
    t = record.t
    p = np.asarray(record.gauge_pressure(), float)
    if np.any(~np.isfinite(p)):
        # gaps in a pressure series: carry the last reading (the segmentation is coarse)
        p = p.copy()
        good = np.isfinite(p)
        if not good.any():
            raise InputError("the record has no finite pressure values", key="pressure")
        idx = np.where(good, np.arange(n), 0)
        np.maximum.accumulate(idx, out=idx)
        p = p[idx]
        p[: int(np.argmax(good))] = p[int(np.argmax(good))]
    ps = _median(p, _window(t, opt.smooth_s))
    dpdt = _slope(t, ps, _window(t, opt.slope_s) // 2 + 1)
    base = _base_pressure(t, ps, opt)
    rate = record.rate
    used_rate = rate is not None and bool(np.nanmax(np.abs(np.nan_to_num(rate))) > 0)
    notes = [f"base pressure {base / _BAR:.1f} bar (gauge)"]

    # ---------------------------------------------------------------- pumping
    if used_rate:
        q = _median(np.nan_to_num(rate), _window(t, opt.rate_filter_s))
        pump = _hysteresis(q, opt.pump_rate_on, opt.pump_rate_off)
        pump = _drop_short(_bridge(pump, t, opt.rate_gap_s), t, opt.min_pump_s)
        unmetered = _pump_like_rises(t, ps, dpdt, ~pump, base, opt, opt.unmetered_rise_rate)
        for a, b in unmetered:
            pump[a:b] = True
        if unmetered:
            notes.append(f"{len(unmetered)} pressurisation(s) without metered rate taken "
                         "as pumping")
    else:
        pump = np.zeros(n, bool)
        notes.append("no pump rate: phases from pressure alone")

    # ---------------------------------------------------------------- releases
    free = ~pump
    bleed = np.zeros(n, bool)
    for a, b in _fall_runs(t, ps, dpdt, free, base, opt.bleed_rate, opt.bleed_fraction,
                           opt.bleed_gap_s, 0.0):
        bleed[a:b] = True

    if not used_rate:
        rises = _pump_like_rises(t, ps, dpdt, ~bleed, base, opt, opt.unmetered_rise_rate)
        for k, (a, b) in enumerate(rises):
            # the pump keeps running through a propagation plateau; it stops at the last
            # sudden fall before the pressure is bled off, flowed back or pumped up again
            nxt = rises[k + 1][0] if k + 1 < len(rises) else n
            rel = np.flatnonzero(bleed[b:nxt])
            stop = b + int(rel[0]) if rel.size else nxt
            low = np.flatnonzero(ps[b:stop] - base < opt.idle_band)
            if low.size:
                stop = b + int(low[0])
            drops = _sharp_drops(t, ps, base, b, stop, opt)
            end = b
            if drops:
                d = drops[-1]
                # a fall that is itself the release to base is not a pump stop
                after = ps[min(d + _window(t, 60.0), n - 1)]
                if after - base >= 0.3 * (ps[d] - base):
                    end = d
            pump[a:end] = True
        free = ~pump
        bleed &= free

    returns = np.zeros(n, bool)
    have_returns = False
    half = _window(t, 30.0) // 2 + 1
    if record.return_rate is not None:
        have_returns = True
        rq = _median(np.nan_to_num(record.return_rate), _window(t, opt.rate_filter_s))
        returns |= _hysteresis(rq, opt.return_rate_on, opt.return_rate_off)
    if record.return_volume is not None:
        have_returns = True
        cv = _cum_positive(record.return_volume)
        returns |= _slope(t, cv, half) > opt.return_volume_rate
    if record.volume is not None:
        v = np.nan_to_num(record.volume)
        dv = np.diff(v, prepend=v[:1])
        small_fall = np.where((dv < 0) & (dv > -0.05), dv, 0.0)
        falling = _slope(t, np.cumsum(small_fall), half) < -opt.return_volume_rate
        returns |= falling & free
    # a flowback is a deliberate operation: seconds-long return blips (a valve cycled) are not
    returns = _drop_short(_bridge(returns & free, t, 3 * opt.rate_gap_s), t,
                          2 * opt.min_phase_s)
    returns &= free
    # measured returns make a release a flowback, unless the valve was simply opened: a
    # very fast release (three times ``bleed_rate``) stays a bleed
    for a, b in _runs(bleed):
        dur = _span(t, a, b)
        fast = dur <= 0 or (ps[a] - ps[b - 1]) / dur >= 3.0 * opt.bleed_rate
        if not fast and np.mean(returns[a:b]) >= 0.5:
            bleed[a:b] = False
    returns &= ~bleed
    # a fast fall with a metered zero rate is a shut-in (leak-off) unless something shows
    # the well was opened: a remark or a decline the shut-in's own leak-off cannot explain
    evidence = np.zeros(n, np.int8)  # index into _EVIDENCE, 0 = none
    for a, b in _runs(bleed):
        ev = _release_evidence(record, t, ps, dpdt, pump, base, a, b, opt)
        if not ev and not used_rate:
            ev = ReleaseEvidence.PRESSURE_ONLY
        if ev is None:
            bleed[a:b] = False
            continue
        evidence[a:b] = _EVIDENCE.index(ev)
    evidence[returns] = _EVIDENCE.index(ReleaseEvidence.RETURN_FLOW)

    flowback = returns
    if not have_returns and not used_rate:
        flowback = flowback.copy()
        for a, b in _fall_runs(t, ps, dpdt, free & ~bleed, base, opt.flowback_rate, 0.7,
                               30.0, 60.0):
            flowback[a:b] = True
            evidence[a:b] = _EVIDENCE.index(ReleaseEvidence.PRESSURE_ONLY)

    # ---------------------------------------------------------------- labels
    lab = np.where(ps - base >= opt.idle_band, _CODES["shut_in"], _CODES["idle"])
    lab[flowback] = _CODES["flowback"]
    lab[bleed] = _CODES["bleed"]
    lab[pump] = _CODES["pump"]
    runs = _label_runs(lab)
    runs = _merge_short(runs, t, opt)

    # ---------------------------------------------------------------- volumes
    if record.volume is not None:
        cum_in = _cum_positive(record.volume)
    elif rate is not None:
        cum_in = _cum_rate(t, rate)
    else:
        cum_in = None
    if record.return_volume is not None:
        cum_out = _cum_positive(record.return_volume)
    elif record.return_rate is not None:
        cum_out = _cum_rate(t, record.return_rate)
    elif record.volume is not None:
        v = np.nan_to_num(record.volume)
        dv = np.diff(v, prepend=v[:1])
        cum_out = np.cumsum(np.where((dv < 0) & (dv > -0.05) & free, -dv, 0.0))
    else:
        cum_out = None
    # the p-V curve wants the finest volume resolution: the integrated rate beats a
    # totaliser that counts in 0.1 m^3 steps
    pv_volume = _cum_rate(t, rate) if used_rate else cum_in

    phases = [_make_phase(record, kind, a, b, cum_in, cum_out) for kind, a, b in runs]
    phases = [_with_evidence(ph, evidence) for ph in phases]

    # ---------------------------------------------------------------- cycles
    start_samples: set[int] = set()
    for k, ph in enumerate(phases):
        if ph.kind != "pump":
            continue
        # the level the pump started from: the lowest pressure in the 30 s before it (the
        # filtered rate may lag the first pressure response by a few samples)
        p_start = float(np.min(ps[max(0, ph.i0 - _window(t, 30.0)): ph.i0 + 1]))
        peak = float(np.max(ps[ph.i0:ph.i1]))
        gain = peak - p_start
        if peak - base < opt.min_cycle_pressure:
            # pumping without building pressure: a line flush or circulation
            phases[k] = replace(ph, kind="idle")
            continue
        # from a pressurised well, only a real pressurisation opens a cycle: it must pump
        # more than a top-up (or, without volumes, at least double the pressure above base);
        # unmetered stages of a line test and top-ups stay in the cycle they belong to
        elevated = p_start - base >= opt.idle_band
        if cum_in is not None:
            real = ph.pumped_m3 >= opt.topup_max_volume
        else:
            real = gain >= 0.5 * (peak - base)
        if gain >= opt.min_cycle_pressure and (not elevated or real):
            start_samples.add(ph.i0)
    phases = [_with_evidence(ph, evidence) for ph in _merge_same(phases, record, cum_in, cum_out)]
    cycles = _group_cycles(record, phases, ps, base, pv_volume, start_samples, opt)
    notes.append(f"{len(cycles)} cycle(s): "
                 + ", ".join(c.kind for c in cycles) if cycles else "no cycles found")
    return Segmentation(phases=tuple(phases), cycles=tuple(cycles), used_rate=used_rate,
                        notes=tuple(notes))


# ====================================================================== phase building
def _label_runs(lab: np.ndarray) -> list[tuple[str, int, int]]:
    """Runs of equal label as ``(kind, i0, i1)``."""
    if lab.size == 0:
        return []
    cut = np.flatnonzero(np.diff(lab)) + 1
    edges = np.concatenate(([0], cut, [lab.size]))
    return [(_KINDS[int(lab[a])], int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def _merge_short(runs, t, opt) -> list[tuple[str, int, int]]:
    """Fold shut-in / flowback / idle runs shorter than ``min_phase_s`` into a neighbour.

    Pump and bleed runs were already filtered by their own rules (a bleed can take seconds).
    The short run joins the neighbour it resembles most: the previous one unless that is a
    pump/bleed and the next one is not.
    """
    runs = list(runs)
    changed = True
    while changed and len(runs) > 1:
        changed = False
        for k, (kind, a, b) in enumerate(runs):
            if kind in ("pump", "bleed") or _span(t, a, b) >= opt.min_phase_s:
                continue
            prev = runs[k - 1] if k > 0 else None
            nxt = runs[k + 1] if k + 1 < len(runs) else None
            soft = ("idle", "shut_in", "flowback")
            if prev is not None and (prev[0] in soft or nxt is None or nxt[0] not in soft):
                target = k - 1
            elif nxt is not None:
                target = k + 1
            else:
                continue
            tk, ta, tb = runs[target]
            if tk in ("pump", "bleed"):
                # between two hard phases: keep it, relabelled as the quieter state
                continue
            runs[target] = (tk, min(a, ta), max(b, tb))
            del runs[k]
            changed = True
            break
    # neighbours of the same kind
    out: list[tuple[str, int, int]] = []
    for kind, a, b in runs:
        if out and out[-1][0] == kind:
            out[-1] = (kind, out[-1][1], b)
        else:
            out.append((kind, a, b))
    return out


def _make_phase(record: Record, kind: str, i0: int, i1: int, cum_in, cum_out) -> Phase:
    """A :class:`Phase` over samples ``[i0, i1)`` with volumes, peak and mean rate."""
    t = record.t
    j = min(i1, record.n - 1)  # volumes are counted up to the first sample of the next phase
    pumped = float(cum_in[j] - cum_in[i0]) if cum_in is not None else 0.0
    returned = float(cum_out[j] - cum_out[i0]) if cum_out is not None else 0.0
    dur = float(t[j] - t[i0])
    if record.rate is not None and kind == "pump":
        mean_rate = float(np.nanmean(record.rate[i0:i1]))
    elif dur > 0:
        mean_rate = (pumped - returned) / dur
    else:
        mean_rate = 0.0
    return Phase(kind=kind, i0=i0, i1=i1, t_start=float(t[i0]), t_end=float(t[i1 - 1]),
                 pumped_m3=pumped, returned_m3=returned,
                 peak_pressure=float(np.nanmax(record.pressure[i0:i1])), mean_rate=mean_rate)


def _merge_same(phases: list[Phase], record: Record, cum_in, cum_out) -> list[Phase]:
    """Join neighbouring phases of the same kind (after flushes became idle)."""
    out: list[Phase] = []
    for ph in phases:
        if out and out[-1].kind == ph.kind and ph.kind != "pump":
            out[-1] = _make_phase(record, ph.kind, out[-1].i0, ph.i1, cum_in, cum_out)
        else:
            out.append(ph)
    return out


# ====================================================================== cycles
def _group_cycles(record, phases, ps, base, pv_volume, start_samples, opt) -> list[Cycle]:
    """Cycles from the phases that open them; trailing idle phases are left out."""
    first = [k for k, ph in enumerate(phases) if ph.kind == "pump" and ph.i0 in start_samples]
    cycles = []
    for c, k0 in enumerate(first):
        k1 = first[c + 1] if c + 1 < len(first) else len(phases)
        while k1 - 1 > k0 and phases[k1 - 1].kind == "idle":
            k1 -= 1
        members = tuple(phases[k0:k1])
        kind, reason = _classify(record, members, ps, base, pv_volume, opt)
        cycles.append(Cycle(
            index=c + 1, kind=kind, phases=members,
            t_start=members[0].t_start, t_end=members[-1].t_end,
            peak_pressure=max(ph.peak_pressure for ph in members),
            pumped_m3=float(sum(ph.pumped_m3 for ph in members)),
            returned_m3=float(sum(ph.returned_m3 for ph in members)),
            reason=reason))
    return cycles


def _main_pump(members) -> int:
    """Index (in ``members``) of the pump phase that reaches the cycle's highest pressure."""
    pumps = [k for k, ph in enumerate(members) if ph.kind == "pump"]
    return max(pumps, key=lambda k: (members[k].peak_pressure, -k))


def _hold(record, members, kmain, ps, base, opt) -> tuple[float, float]:
    """Duration [s] and fractional fall of the shut-in after the main pump phase.

    The hold runs over the shut-in (and top-up) phases that follow; the fall is measured
    over its first ``hold_window_s`` after skipping 30 s (the step at pump stop is friction
    and compliance, not a leak), relative to the pressure above base.
    """
    t = record.t
    i0 = members[kmain].i1
    i1 = i0
    for ph in members[kmain + 1:]:
        if ph.kind == "shut_in" or (ph.kind == "pump" and ph.pumped_m3 < opt.topup_max_volume):
            i1 = ph.i1
        else:
            break
    if i1 <= i0 + 1:
        return 0.0, 1.0
    s = i0 + int(np.searchsorted(t[i0:i1], t[i0] + 30.0))
    s = min(s, i1 - 1)
    e = i0 + int(np.searchsorted(t[i0:i1], t[s] + opt.hold_window_s))
    e = min(max(e, s + 1), i1 - 1)
    excess = ps[s] - base
    if excess <= 0:
        return float(t[i1 - 1] - t[i0]), 1.0
    fall = float((ps[s] - np.min(ps[s:e + 1])) / excess)
    return float(t[i1 - 1] - t[i0]), max(fall, 0.0)


def _classify(record, members, ps, base, pv_volume, opt) -> tuple[str, str]:
    """Kind and reason of one cycle.

    The pressurisation is every pumping sample from the cycle start to the end of the pump
    phase reaching the cycle's highest pressure (stages and unmetered line-test pumping
    included). Its p-V curve (p against pumping time when no volume is known, i.e. assuming
    a constant rate) gives the stiffness dp/dV as the slope of a straight line fitted
    between 15 % and 60 % of the pressure gain, and the departure as the first lasting fall
    below that line by more than ``departure_tolerance`` of the gain (or the peak, if the
    pressure falls while pumping).

    * ``line_test``: less than ``line_test_max_volume`` pumped to the peak, or stiffness
      >= ``line_test_stiffness`` (surface lines against a closed valve);
    * ``xlot``: pumped more than ``xlot_past_ratio`` times the volume to departure past it,
      or at least 0.15 times while the pressure flattened or fell (it gained less than 30 %
      of what the linear trend gives for that volume): breakdown / propagation;
    * ``lot``: departed, but pumping stopped soon after, the pressure still building;
    * ``casing_test``: no departure; held within ``hold_max_drop`` for >= ``min_hold_s``;
    * ``other``: pressurised without departure and not held.
    """
    t = record.t
    kmain = _main_pump(members)
    idx = np.concatenate([np.arange(ph.i0, ph.i1) for ph in members[: kmain + 1]
                          if ph.kind == "pump"])
    p = ps[idx]
    nstart = max(1, min(members[0].i1 - members[0].i0, _window(t, 30.0)))
    p0 = float(np.min(p[:nstart]))
    k = int(np.argmax(p))
    pk = float(p[k])
    gain = pk - p0
    have_v = pv_volume is not None
    if have_v:
        x = np.cumsum(np.diff(pv_volume[idx], prepend=pv_volume[idx[0]]))
    else:
        # pumping time; steps between separate pump phases are not counted
        dt = np.diff(t[idx], prepend=t[idx[0]])
        dt[1:][np.diff(idx) > 1] = 0.0
        x = np.cumsum(dt)
    xu = "m3" if have_v else "s of pumping"
    hold_s, hold_fall = _hold(record, members, kmain, ps, base, opt)
    held = hold_s >= opt.min_hold_s and hold_fall <= opt.hold_max_drop
    held_txt = (f"held {hold_s / 60:.0f} min, fell {100 * hold_fall:.0f} % of the pressure"
                if hold_s > 0 else "not held")
    hint = _event_hint(record, members)
    pumped = float(sum(ph.pumped_m3 for ph in members[: kmain + 1] if ph.kind == "pump"))
    head = f"+{gain / _BAR:.0f} bar to {pk / _BAR:.0f} bar gauge"
    if have_v:
        head = f"{pumped:.3g} m3 pumped, " + head

    # ------------------------------------------------------------ line test: tiny volume
    if have_v:
        vpk = max(float(x[k]), 0.0)
        if vpk < opt.line_test_max_volume or gain / max(vpk, 1e-12) >= opt.line_test_stiffness:
            stiff = (f"stiffness {gain / vpk / _BAR / 1000.0:.2g} bar/l" if vpk > 0
                     else "no metered volume")
            return "line_test", (f"line_test: {head}; {stiff}: lines against a closed "
                                 f"valve; {held_txt}{hint}")

    # ------------------------------------------------------------ p-V linearity
    lo, hi = p0 + 0.15 * gain, p0 + 0.6 * gain
    sel = np.flatnonzero((p[: k + 1] >= lo) & (p[: k + 1] <= hi))
    slope = None
    dep = None
    if sel.size >= 3 and np.ptp(x[sel]) > 0:
        slope, icpt = np.polyfit(x[sel], p[sel], 1)
        if slope > 0:
            tol = opt.departure_tolerance * gain
            below = (icpt + slope * x[: k + 1] - p[: k + 1]) > tol
            below[: sel[-1] + 1] = False
            # lasting: the rest of the way to the peak stays mostly below the line
            for j in np.flatnonzero(below):
                if np.mean(below[j: k + 1]) >= 0.8:
                    dep = int(j)
                    break
        else:
            slope = None
    fall = float((pk - np.min(p[k:])) / gain) if gain > 0 else 0.0
    x_total = float(x[-1])
    stiff_txt = ""
    if slope is not None:
        stiff_txt = (f"; linear p-V at {slope / _BAR:.3g} bar/m3" if have_v
                     else f"; linear rise at {slope / _BAR * 60:.3g} bar/min")
    fell_txt = (f"; pressure fell {100 * fall:.0f} % while pumping"
                if fall >= opt.xlot_fall else "")
    if dep is None and fall >= opt.xlot_fall:
        dep = k  # breakdown straight off the linear trend
    if dep is not None:
        x_dep = max(float(x[dep]), 1e-9)
        past = (x_total - x_dep) / x_dep
        dep_txt = (f"; departs from linear at {p[dep] / _BAR:.0f} bar after {x_dep:.3g} {xu}, "
                   f"{x_total - x_dep:.3g} {xu} pumped past it ({past:.1f}x)")
        # how much of the pressure the linear trend promised for the volume pumped past the
        # departure was actually gained: ~0 when the pressure flattened or fell (the
        # fracture took the fluid), ~1 when the curve had only just begun to bend
        promised = (slope if slope is not None else gain / max(float(x[k]), 1e-9)) * (
            x_total - x_dep)
        built = (pk - float(p[dep])) / promised if promised > 0 else 1.0
        flattened = past >= 0.15 and built <= 0.3
        if flattened:
            dep_txt += f", gaining {100 * built:.0f} % of the linear trend"
        if past >= opt.xlot_past_ratio or flattened:
            return "xlot", (f"xlot: {head}{stiff_txt}{dep_txt}{fell_txt}: pumped well past "
                            f"leak-off (breakdown/propagation); {held_txt}{hint}")
        return "lot", (f"lot: {head}{stiff_txt}{dep_txt}{fell_txt}: pumping stopped soon "
                       f"after leak-off; {held_txt}{hint}")
    if held:
        return "casing_test", (f"casing_test: {head}{stiff_txt}; no departure from linear; "
                               f"{held_txt}{hint}")
    return "other", f"other: {head}{stiff_txt}; no departure, {held_txt}{hint}"


_HINT_WORDS = ("test", "xlot", "lot", "line", "casing", "fit", "flush", "bleed", "flow")


def _event_hint(record: Record, members) -> str:
    """Remarks logged around the cycle's pump phase, as supporting text."""
    t0 = members[0].t_start - 300.0
    t1 = members[0].t_end
    texts = [e.text for e in record.events
             if t0 <= e.t <= t1 and any(w in e.text.lower() for w in _HINT_WORDS)]
    return ("; remarks: " + ", ".join(repr(s) for s in texts)) if texts else ""
