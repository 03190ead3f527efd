"""Releases of pressure (bleed, flowback) and the evidence they are declared from.

A fall of pressure while the pump is off is leak-off (a shut-in) unless something shows the
well was opened: returns logged (return rate, growing return volume, a pumped-volume
totaliser running back), an operator remark, or a decline the shut-in's own leak-off cannot
explain. Leak-off only slows down with time, so a fall that is ``acceleration`` times faster
than the decline just before it, and takes away most of the pressure above base, is a release
unless it dies away like leak-off (or is still going when the record ends: a valve or choke
runs the well down and stops, leak-off sped up by a closing fracture goes on for as long as
the falloff does); so is a fall that starts at pump stop and reaches base in a small fraction of the pumping
time. A smaller fall (a valve opened and shut again, a bleed stopped early) is a partial
release when the decline jumps at once -- within the slope's own window -- to ``acceleration``
times the shut-in's and the fall ends abruptly. No fall rate in bar/min is fixed: the
reference is always the same record's decline.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from xlotkit.interpret.phases.options import SegmentOptions
from xlotkit.interpret.phases.signal import (
    bridge,
    cum_positive,
    drop_short,
    hysteresis,
    running_median,
    runs,
    slope,
)
from xlotkit.interpret.phases.types import ReleaseEvidence
from xlotkit.record import Record

__all__ = ["Release", "departure", "find_releases", "return_flow"]

_RELEASE_WORDS = ("bleed", "bled", "flow back", "flowback", "flow-back", "open", "release",
                  "vent", "choke")


@dataclass(frozen=True)
class Release:
    """A release over samples ``[a, b)`` (from its highest to its lowest point).

    ``fraction`` is the part of the pressure above base it takes away; ``acceleration``
    how many times faster its steepest fall is than the shut-in's decline just before it
    (None when that was not measured: a release at pump stop, or on a remark alone).
    """

    a: int
    b: int
    evidence: tuple[ReleaseEvidence, ...]
    fraction: float = 1.0
    acceleration: float | None = None

    @property
    def partial(self) -> bool:
        """Whether the release left most of the pressure in the well (a valve opened and
        shut again, or a bleed stopped early)."""
        return self.fraction < 0.5

    def describe(self, t: np.ndarray) -> str:
        """One line for the segmentation's notes: where, how much and on what evidence."""
        out = (f"release at t = {t[self.a]:.0f} s ({', '.join(e.value for e in self.evidence)}): "
               f"takes {100 * self.fraction:.0f} % of the pressure above base")
        if self.acceleration is not None and np.isfinite(self.acceleration):
            out += (f", falling {self.acceleration:.3g} times faster than the shut-in's own "
                    "decline before it")
        elif self.acceleration is not None:
            out += ", falling from a shut-in that held its pressure before it"
        return out


def return_flow(record: Record, free: np.ndarray, rate_scale: float | None,
                opt: SegmentOptions) -> tuple[np.ndarray, bool]:
    """Samples where fluid comes back, and whether the record logs returns at all.

    From the return rate (hysteresis at ``return_on``/``return_off`` of the pump rate
    scale, or of the return rate's own scale when no pump rate is logged), else a growing
    return volume, or a pumped-volume totaliser that runs back while the pump is off (one
    sample's fall larger than twice what the pump moves in one sample at its rate scale is a
    totaliser reset). Returns shorter than ``min_return_samples`` are a valve cycled, not a
    flowback.
    """
    t = record.t
    n = record.n
    returns = np.zeros(n, bool)
    have = False
    half = opt.settle_samples // 2 + 1
    scale = rate_scale
    if record.return_rate is not None:
        rq = running_median(np.nan_to_num(record.return_rate), opt.rate_filter_samples)
        if not scale:
            scale = float(np.max(rq)) if rq.size else 0.0
        have = True
        if scale and scale > 0:
            returns |= hysteresis(rq, opt.return_on * scale, opt.return_off * scale)
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0]) if n > 1 else 1.0)
    if record.return_volume is not None and record.return_rate is None:
        # (a logged return rate is the better record: a volume read through a slope window
        # starts a return run half that window early)
        have = True
        cv = cum_positive(record.return_volume)
        if not scale:
            scale = float(np.max(running_median(np.clip(slope(t, cv, half), 0, None),
                                                opt.rate_filter_samples)))
        if scale and scale > 0:
            returns |= slope(t, cv, half) > opt.return_on * scale
    if record.volume is not None and scale and scale > 0:
        v = np.nan_to_num(record.volume)
        dv = np.diff(v, prepend=v[:1])
        small_fall = np.where((dv < 0) & (-dv <= 2.0 * scale * dt), dv, 0.0)
        falling = slope(t, np.cumsum(small_fall), half) < -opt.return_on * scale
        returns |= falling & free
    returns = drop_short(bridge(returns & free, 3 * opt.gap_samples),
                         opt.min_return_samples)
    return returns & free, have


def _remark(record: Record, t0: float, t1: float) -> bool:
    return any(t0 <= e.t <= t1 and any(w in e.text.lower() for w in _RELEASE_WORDS)
               for e in record.events)


def _levels_off(t: np.ndarray, f: np.ndarray, a: int, b: int, opt: SegmentOptions,
                h: int) -> bool:
    """Whether the fall rate ``f`` over ``[a, b)`` dies away like leak-off's.

    Leak-off that sped up when the fracture closed decays exponentially towards the
    formation's pressure: its rate falls from half its maximum to a tenth over 0.70 of the
    time from the fall's start to that tenth (``ln 5 / ln 10``). Flow out through a choke
    (``Q ~ sqrt(dp)``) loses its rate linearly, over 0.44 of it; an opened valve empties the
    well until it is shut or at base and ends abruptly. The fall levels off like leak-off
    when that fraction exceeds ``release_levelling`` (and the smoothing windows).
    """
    seg = f[a:b]
    top = float(np.max(seg))
    if top <= 0:
        return True
    n = t.size
    i50 = a + int(np.flatnonzero(seg >= 0.5 * top)[-1])
    # (the slope's last window is cut short by the record's end: not a reading of the fall)
    end = max(n - h - opt.smooth_samples // 2, i50 + 1)
    low = np.flatnonzero(f[i50:end] < 0.1 * top)
    if not low.size:
        # the fall never dies down before the record ends: a release runs the well down and
        # stops (valve shut, well at base); a falloff that sped up when the fracture closed
        # goes on (a DFIT past closure)
        return True
    e10 = min(i50 + int(low[0]), n - 1)
    smooth = opt.smooth_samples + 2 * h
    allow = max(opt.release_levelling * float(t[e10] - t[a]),
                float(t[min(i50 + smooth, n - 1)] - t[i50]))
    return float(t[e10] - t[i50]) > allow


def find_releases(record: Record, ps: np.ndarray, dpdt: np.ndarray, pump: np.ndarray,
                  base: float, noise: float, opt: SegmentOptions, *,
                  pressure_only: bool, returns: np.ndarray | None = None) -> list[Release]:
    """Releases of pressure while the pump is off (module docstring).

    A candidate starts where the fall rate exceeds ``acceleration`` times the median fall
    rate of the ``3 settle_samples`` before it (pumping samples excluded) and
    ``noise_multiple`` times the noise of the slope (read over ``±slope_half`` samples, and
    again over ``±settle_samples / 2`` for slow, controlled bleeds); it runs to the lowest
    point of the fall that follows. It is a release when it takes away ``bleed_fraction`` of the pressure above base, does not die away like
    leak-off (:func:`_levels_off`: leak-off that sped up when the fracture closed and
    stiffened the system decays exponentially towards the formation's pressure), and has
    evidence: a remark; a decline ``acceleration`` times faster than the shut-in's before
    it; or, right at pump stop, a fall to within a fifth of the pressure above base in less
    than ``fast_release`` of the pumping time. A fall that dies away
    like leak-off is a release only on a remark.

    ``returns``: the samples with returns, when the record logs them (None: it logs none).
    A fall taking less than ``bleed_fraction`` (but at least ``partial_release_fraction``)
    of the pressure above base is a **partial** release only when, in a record that logs
    returns, they come back over most of it, and the shut-in's decline
    jumped at once to ``acceleration`` times its rate before (:func:`_abrupt`) and the fall
    ends abruptly (the valve shut again); a remark does not replace that shape. A candidate
    that runs from pump stop through the shut-in is first cut where its fall rate, having
    slowed, speeds up again (:func:`_reaccelerations`), so that a valve opened before the
    leak-off has slowed to the noise is judged against the decline just before it.
    """
    t = record.t
    pump_runs = runs(pump)
    out = _scan(record, ps, -dpdt, opt.slope_half, pump, pump_runs, base, noise, opt,
                pressure_only, returns)
    # a slow, controlled bleed hides in the noise of the short slope on a quantised gauge:
    # the same search on the slope over settle_samples, whose noise is smaller
    hl = max(opt.slope_half, opt.settle_samples // 2)
    if hl > opt.slope_half:
        for r in _scan(record, ps, -slope(t, ps, hl), hl, pump, pump_runs, base, noise, opt,
                       pressure_only, returns):
            if not any(r.a < o.b and o.a < r.b for o in out):
                out.append(r)
        out.sort(key=lambda r: r.a)
    return out


def departure(t, ps, pump, i: int, h: int, noise: float, drop: float,
              opt: SegmentOptions) -> int | None:
    """Last sample on the decline before a fall seen at sample ``i``, or None.

    The decline over the ``settle_samples`` before ``i - h`` (no pumping) is fitted with a
    line; the fall starts where the pressure leaves it by ``noise_multiple`` noise and 0.2 %
    of the fall ``drop``, searched from ``i - h - settle_samples`` on."""
    hi = max(i - h, 0)
    lo = max(hi - opt.settle_samples, 0)
    pumped = np.flatnonzero(pump[lo:hi])
    if pumped.size:
        lo += int(pumped[-1]) + 1
    if hi - lo < 3 or np.ptp(t[lo:hi]) <= 0:
        return None
    s, c = np.polyfit(t[lo:hi], ps[lo:hi], 1)
    end = min(i + h + 1, ps.size)
    dev = (c + s * t[hi:end]) - ps[hi:end]
    over = np.flatnonzero(dev > max(opt.noise_multiple * noise, 0.002 * drop))
    return max(hi + int(over[0]) - 1, lo) if over.size else None


def _onset(t, ps, f, pump, a: int, b: int, c0: int, h: int, noise: float,
           opt: SegmentOptions) -> int:
    """First sample of the release found over ``[a, b)`` from a candidate starting at
    ``c0``: the last sample on the decline before it.

    The slope's window blurs the onset by up to ``h`` samples, and on a slowly declining
    shut-in the highest point near it is the earliest one; so the decline of the
    ``settle_samples`` before the candidate (outside the window) is fitted with a line and
    the release starts where the pressure leaves it by ``noise_multiple`` noise and 0.2 %
    of the fall. Without such a stretch: where the pressure has lost a twentieth of
    the fall.
    """
    steep = a + int(np.argmax(f[a:b]))
    drop = float(ps[a] - ps[b - 1])
    hi = max(c0 - h, 0)
    lo = max(hi - opt.settle_samples, 0)
    pumped = np.flatnonzero(pump[lo:hi])
    if pumped.size:
        # right after pump stop the pressure still falls through the pump-off drop: the
        # line is fitted to the later half of a short shut-in, whose decline goes on
        lo += int(pumped[-1]) + 1
        lo += min(opt.settle_samples, (hi - lo) // 2)
    if hi - lo >= 3 and np.ptp(t[lo:hi]) > 0:
        s, c = np.polyfit(t[lo:hi], ps[lo:hi], 1)
        i0 = max(lo, min(hi, a))
        dev = (c + s * t[i0:steep + 1]) - ps[i0:steep + 1]
        over = np.flatnonzero(dev > max(opt.noise_multiple * noise, 0.002 * drop))
        if over.size:
            return max(i0 + int(over[0]) - 1, lo)
    left = np.flatnonzero(ps[a:steep + 1] >= ps[a] - 0.05 * drop)
    return a + int(left[-1]) if left.size else a


def _scan(record, ps, f, h, pump, pump_runs, base, noise, opt: SegmentOptions,
          pressure_only: bool, returns: np.ndarray | None) -> list[Release]:
    """The release search of :func:`find_releases` on the fall rate ``f`` (a slope over
    ``±h`` samples); the start of each release from :func:`_onset`. ``returns``: where the
    record logs fluid coming back (None: it logs no returns)."""
    import pandas as pd

    t = record.t
    n = ps.size
    free = ~pump
    i = np.arange(n)
    span_t = t[np.clip(i + h, 0, n - 1)] - t[np.clip(i - h, 0, n - 1)]
    with np.errstate(divide="ignore", invalid="ignore"):
        floor = np.where(span_t > 0, opt.noise_multiple * noise * np.sqrt(2.0) / span_t, np.inf)
    w = 3 * opt.settle_samples
    g = 2 * h + 1
    quiet = np.where(free, f, np.nan)
    ref = pd.Series(quiet).rolling(w, min_periods=max(3, w // 4)).median().to_numpy()
    ref = np.concatenate([np.full(g, np.nan), ref[:-g]]) if n > g else np.full(n, np.nan)
    ref = np.where(np.isfinite(ref), np.maximum(ref, 0.0), 0.0)
    cand = free & (f > floor) & (f >= opt.acceleration * ref)
    out: list[Release] = []
    pieces = []
    for a_run, b_run in runs(bridge(cand, opt.gap_samples) & free):
        # a run that starts at pump stop has no shut-in decline before it to be judged
        # against: it is cut where the fall speeds up again. Later in a shut-in the run is
        # one fall (a valve's first step and the flow it lets go are one release)
        after_pump = bool(pump[max(a_run - opt.settle_samples, 0):a_run].any())
        cuts = _reaccelerations(f, floor, a_run, b_run, opt.acceleration) if after_pump \
            else []
        edges = [a_run, *cuts, b_run]
        pieces += [(x, y, y == b_run) for x, y in pairwise(edges)]
    for a, b, last in pieces:
        if out and a < out[-1].b:
            continue  # a second candidate inside the release just found
        c0 = a
        fmax = float(np.max(f[a:b]))
        # the fall ends where its rate drops to a tenth of its top so far (a piece cut off
        # before a renewed acceleration ends at the cut)
        while last and b < n and free[b] and f[b] > max(floor[b], 0.1 * fmax):
            fmax = max(fmax, float(f[b]))
            b += 1
        k = a + int(np.argmax(ps[a:b]))
        a0 = max(k - 2 * h, 0)
        while a0 < k and not free[a0]:
            a0 += 1
        a = a0 + int(np.argmax(ps[a0:k + 1]))
        b = a + int(np.argmin(ps[a:b])) + 1
        if b - a < 2:
            continue
        a = _onset(t, ps, f, pump, a, b, c0, h, noise, opt)
        excess = float(ps[a] - base)
        drop = float(ps[a] - ps[b - 1])
        if excess <= 0 or drop < max(opt.partial_release_fraction * excess,
                                     opt.noise_multiple * noise):
            continue
        # a fall that leaves most of the pressure in the well is a release only when a
        # valve plainly opened and shut again (below)
        partial = drop < opt.bleed_fraction * excess
        fraction = min(drop / excess, 1.0)
        if partial and returns is not None and np.mean(returns[a:b]) < 0.5:
            # a record that logs returns shows a valve opened as returns; a short fall
            # without them is the well's own (a burst of crack growth in the shut-in)
            continue
        ev: list[ReleaseEvidence] = []
        before = [r for r in pump_runs if r[1] <= a]
        tp = float(t[before[-1][1] - 1] - t[before[-1][0]]) if before else 0.0
        fast = tp > 0 and float(t[b - 1] - t[a]) < opt.fast_release * tp
        if _levels_off(t, f, a, b, opt, h):
            # leak-off that sped up (the fracture closing stiffens the system) decays
            # towards the formation's pressure; an opened valve empties the well until it
            # is shut or at base: its fall ends abruptly. A partial release is a valve
            # opened and shut again: without that abrupt end it is none, remark or not
            if partial:
                continue
            if _remark(record, float(t[max(a - opt.settle_samples, 0)]), float(t[b - 1])):
                out.append(Release(a, b, (ReleaseEvidence.REMARK,)
                                   + ((ReleaseEvidence.PRESSURE_ONLY,) if pressure_only
                                      else ()), fraction=fraction))
            continue
        if _remark(record, float(t[max(a - opt.settle_samples, 0)]), float(t[b - 1])):
            ev.append(ReleaseEvidence.REMARK)
        pe = before[-1][1] if before else 0
        s0 = min(opt.settle_samples, (a - pe) // 2)
        accel = None
        sudden = False
        if a - g // 2 - max(pe + s0, a - w) >= 3:
            # accelerated past the decline the shut-in had just before the fall (its first
            # settle_samples, or half of a shorter shut-in, skipped: the pump-stop step).
            # Leak-off only slows down (linear in sqrt(t) or G-time at best), so the
            # median rate over that stretch is more than its extrapolation to the fall
            ref_a = max(float(np.median(f[max(pe + s0, a - w): a - g // 2])), 0.0)
            top = float(np.max(f[a:b]))
            if top > float(floor[a]) and top >= opt.acceleration * ref_a:
                ev.append(ReleaseEvidence.UNEXPLAINED_DECLINE)
                accel = top / ref_a if ref_a > 0 else float("inf")
                sudden = _abrupt(f, a, b, ref_a, float(floor[a]), opt.acceleration, h)
        elif before and not partial and fast and ps[b - 1] - base <= 0.2 * excess:
            ev.append(ReleaseEvidence.UNEXPLAINED_DECLINE)
        if not ev:
            continue
        if partial and not (sudden and _sustained(ps, a, b, opt)):
            # a fall that leaves most of the pressure in the well is a release only when
            # the shut-in's decline jumped at once to a rate its leak-off cannot explain (a
            # valve opened) and the flow went on; one that speeds up gradually is leak-off
            # changing its course, one over within the slope's window a step in the well
            continue
        if pressure_only:
            ev.append(ReleaseEvidence.PRESSURE_ONLY)
        out.append(Release(a, b, tuple(ev), fraction=fraction, acceleration=accel))
    return out


def _reaccelerations(f: np.ndarray, floor: np.ndarray, a: int, b: int,
                     acc: float) -> list[int]:
    """Samples inside the candidate run ``[a, b)`` where the fall speeds up again.

    A run that starts at pump stop (no shut-in decline before it to compare with) takes in
    the pump-off fall, the shut-in's slowing leak-off after it and, if a valve is opened
    before the fall rate drops below the noise, the release too. Leak-off only slows down:
    where the fall rate has slowed ``acc`` times below an earlier top and then rises
    ``acc`` times above that low (and above the slope's noise ``floor``), the run is cut at
    the low, so that the release is judged on its own against the decline before it.
    """
    cuts: list[int] = []
    top = -np.inf
    low, low_i = np.inf, -1
    for k in range(a, b):
        v = float(f[k])
        if low_i >= 0:
            if v < low:
                low, low_i = v, k
            elif v >= acc * max(low, float(floor[k])):
                cuts.append(low_i)
                top, low, low_i = v, np.inf, -1
            continue
        if v > top:
            top = v
        elif top > float(floor[k]) and v <= top / acc:
            low, low_i = v, k
    return cuts


def _abrupt(f: np.ndarray, a: int, b: int, ref: float, floor: float, acc: float,
            h: int) -> bool:
    """Whether the fall rate ``f`` jumps from the shut-in's decline ``ref`` to ``acc``
    times it at once: from below ``sqrt(acc) ref`` (the geometric middle) to at least
    ``acc ref`` (and the slope's noise ``floor``) within the slope's own window,
    ``2 h + 1`` samples, around the release's onset ``a``.

    An opened valve or choke takes its flow at once, so the slope over ``±h`` samples
    spreads the jump over its window; leak-off sped up by a closing fracture builds up as
    the fracture's compliance leaves the system, over more than the slope can resolve (the
    onset, read where the pressure leaves the decline by the noise, can lag such a gradual
    speed-up: the jump is timed on the rate itself, from before the onset).
    """
    hi_level = max(acc * ref, floor)
    hit = np.flatnonzero(f[a:b] >= hi_level)
    if not hit.size:
        return False
    k_hi = a + int(hit[0])
    lo0 = max(k_hi - 6 * (2 * h + 1), 0)
    low = np.flatnonzero(f[lo0:k_hi] <= np.sqrt(acc) * ref)
    if not low.size:
        return False
    return k_hi - (lo0 + int(low[-1])) <= 2 * h + 1


def _sustained(ps: np.ndarray, a: int, b: int, opt: SegmentOptions) -> bool:
    """Whether the fall over ``[a, b)`` is a flow sustained for longer than the slope's
    window: its 10-90 % takes more than ``2 slope_half + 1`` samples.

    Flow out through an opened valve lasts as long as the valve is held open; a fall over
    within the slope's own window is a step -- an event in the well (a burst of crack
    growth in the shut-in, the pump-off drop of a pump stop read late), or a valve cycled
    too briefly to tell from one.
    """
    seg = ps[a:b]
    drop = float(seg[0] - np.min(seg))
    if drop <= 0:
        return False
    f10 = int(np.argmax(seg <= seg[0] - 0.1 * drop))
    f90 = int(np.argmax(seg <= seg[0] - 0.9 * drop))
    return f90 - f10 > 2 * opt.slope_half + 1
