"""When the pump runs: from the metered rate, and from the pressure alone.

With a pump rate logged, pumping is where the rate exceeds a fraction of the record's own
rate scale (hysteresis), plus steep, about linear rises while no rate is metered (the
line-test pump of a cementing unit is often not metered). Without a rate, pumping is read
from the pressure: a pump start is a sustained, about linear rise (a leg of the record that
reverses by more than its noise and a fraction of its span, steep compared with the record's
other rises), and the pump stop the sharp break from rise (or propagation plateau) to fall.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from xlotkit.interpret.phases.options import SegmentOptions
from xlotkit.interpret.phases.signal import (
    bridge,
    drop_short,
    hysteresis,
    running_median,
    runs,
    step_drops,
    zigzag,
)

__all__ = ["Rise", "join_short", "metered_pumping", "pressure_pumping", "pressure_rises", "rises",
           "unmetered_rises"]


@dataclass(frozen=True)
class Rise:
    """A pump-like rise of the pressure, samples ``[a, b)`` (lowest to highest point).

    Attributes
    ----------
    a, b : int
        First (lowest) and one past the last (highest) sample.
    gain : float
        Pressure gained [Pa].
    max_slope : float
        Steepest dp/dt on the rise [Pa/s].
    mean_slope : float
        Mean dp/dt between 10 % and 90 % of the gain [Pa/s].
    """

    a: int
    b: int
    gain: float
    max_slope: float
    mean_slope: float


def metered_pumping(q: np.ndarray, opt: SegmentOptions
                    ) -> tuple[np.ndarray, np.ndarray, float]:
    """Pumping mask from the metered rate, the short runs it left out, and the rate scale.

    The rate scale is the highest value of the running-median rate (a one-sample spike does
    not set it) [m^3/s]. Pumping starts above ``pump_on`` and stops below ``pump_off`` of it;
    pauses of up to ``gap_samples`` are bridged and runs shorter than ``min_pump_samples``
    left out (returned separately: :func:`join_short` keeps those that lead into other
    pumping).
    """
    qf = running_median(np.nan_to_num(q), opt.rate_filter_samples)
    scale = float(np.max(qf)) if qf.size else 0.0
    if scale <= 0:
        return np.zeros(q.size, bool), np.zeros(q.size, bool), 0.0
    raw = bridge(hysteresis(qf, opt.pump_on * scale, opt.pump_off * scale), opt.gap_samples)
    pump = drop_short(raw, opt.min_pump_samples)
    return pump, raw & ~pump, scale


def join_short(pump: np.ndarray, short: np.ndarray, gap: int) -> np.ndarray:
    """``pump`` with the short metered runs that lie within ``gap`` samples of it (a pump
    kicking in for a few seconds at the start of a line test), pauses of ``gap`` bridged."""
    out = pump.copy()
    for a, b in runs(short):
        if out[max(a - gap, 0):b + gap].any():
            out[a:b] = True
    return bridge(out, gap)


def rises(t: np.ndarray, ps: np.ndarray, dpdt: np.ndarray, allowed: np.ndarray,
          threshold: float, opt: SegmentOptions) -> list[Rise]:
    """Pump-like rises of ``ps`` inside ``allowed`` samples.

    The record's rising legs (:func:`~xlotkit.interpret.phases.signal.zigzag` with
    ``threshold``) are split where their slope falls below a tenth of the leg's steepest
    (stages of a staged pressure-up are separate rises); each part, from its lowest to its
    highest point, must gain ``threshold`` and be about linear in time: it takes at least
    ``rise_linearity`` of its duration to make half its gain, and end abruptly: its slope
    falls from half its maximum to a tenth within ``rise_levelling`` of the rise (or within
    the smoothing windows). A shut-in well recovering after a release rises fast first and
    then levels off gradually.
    """
    out: list[Rise] = []
    n = ps.size
    piv = zigzag(ps, threshold)
    for a0, b0 in zip(piv[:-1], piv[1:]):
        if ps[b0] - ps[a0] < threshold:
            continue
        leg = slice(a0, b0 + 1)
        smax = float(np.max(dpdt[leg]))
        if smax <= 0:
            continue
        m = (dpdt[leg] > 0.1 * smax) & allowed[leg]
        for ra, rb in runs(bridge(m, opt.slope_half) & allowed[leg]):
            a, b = a0 + ra, a0 + rb
            seg = ps[a:b]
            if seg.size < 3:
                continue
            k = int(np.argmax(seg))
            j0 = int(np.argmin(seg[: k + 1]))
            gain = float(seg[k] - seg[j0])
            if gain < threshold:
                continue
            a, b = a + j0, a + k + 1
            dur = float(t[b - 1] - t[a])
            if dur <= 0:
                continue
            # a well recovers only towards a pressure it had before (a release came first):
            # a rise to above anything earlier in the record is pumping whatever its shape
            # (a step-rate test's steps approach their levels exponentially)
            if a > 0 and float(np.max(ps[:a])) < float(ps[b - 1]) - threshold:
                out.append(_rise(t, ps, dpdt, a, b, gain))
                continue
            half = a + int(np.argmax(ps[a:b] >= ps[a] + 0.5 * gain))
            if (t[half] - t[a]) / dur < opt.rise_linearity:
                continue
            # a pump stops, a recovery levels off: the slope's fall from half its maximum
            # to a tenth takes a small part of the rise (or no longer than the smoothing)
            top = float(np.max(dpdt[a:b]))
            i50 = a + int(np.flatnonzero(dpdt[a:b] >= 0.5 * top)[-1])
            low = np.flatnonzero(dpdt[i50:] < 0.1 * top)
            e10 = i50 + int(low[0]) if low.size else n - 1
            smooth = opt.smooth_samples + 2 * opt.slope_half
            allow = max(opt.rise_levelling * float(t[e10] - t[a]),
                        float(t[min(i50 + smooth, n - 1)] - t[i50]))
            if float(t[e10] - t[i50]) > allow:
                continue
            out.append(_rise(t, ps, dpdt, a, b, gain))
    return out


def _rise(t, ps, dpdt, a: int, b: int, gain: float) -> Rise:
    n = ps.size
    i10 = a + int(np.argmax(ps[a:b] >= ps[a] + 0.1 * gain))
    i90 = a + int(np.argmax(ps[a:b] >= ps[a] + 0.9 * gain))
    span_t = max(float(t[i90] - t[i10]), float(t[min(a + 1, n - 1)] - t[a]), 1e-300)
    return Rise(a, b, gain, float(np.max(dpdt[a:b])), 0.8 * gain / span_t)


def unmetered_rises(t, ps, dpdt, pump, threshold, opt: SegmentOptions) -> list[Rise]:
    """Rises while no rate is metered that are pumping (a line-test pump).

    At their steepest they rise at least ``unmetered_steepness`` times as fast as the
    steepest rise of the record's metered pumping (of any rise when there is none): the
    well recovering after a release is fed by the fracture and the formation, far slower
    than a pump.
    """
    everywhere = rises(t, ps, dpdt, np.ones(ps.size, bool), threshold, opt)
    if not everywhere:
        return []
    metered = [r.max_slope for r in everywhere if np.mean(pump[r.a:r.b]) >= 0.5]
    steepest = max(metered) if metered else max(r.max_slope for r in everywhere)
    return [r for r in rises(t, ps, dpdt, ~pump, threshold, opt)
            if r.max_slope >= opt.unmetered_steepness * steepest]


def pressure_rises(t, ps, dpdt, allowed, threshold, significant, opt) -> list[Rise]:
    """Rises that are pumping when no rate is logged: their mean slope is at least
    ``rise_steepness`` of the steepest significant rise (gain >= ``significant`` [Pa])."""
    found = rises(t, ps, dpdt, allowed, threshold, opt)
    big = [r.mean_slope for r in found if r.gain >= significant]
    if not big:
        return found
    ref = max(big)
    return [r for r in found if r.mean_slope >= opt.rise_steepness * ref]


def _pulsing(p: np.ndarray, a: int, b: int, level: float) -> bool:
    """Whether the raw pressure ``p`` pulses over ``[a, b)``: the median absolute second
    difference, scaled to a noise level (:func:`~xlotkit.interpret.phases.signal.
    roughness`), exceeds ``level``."""
    seg = p[max(a - 1, 0):b + 1]
    if seg.size < 5:
        return False
    d2 = np.abs(seg[2:] - 2.0 * seg[1:-1] + seg[:-2])
    return float(np.median(d2)) / (0.6745 * np.sqrt(6.0)) > level


def _stop_after_breakdown(ps, raw, s1: int, stop_at: int, tol: float, noise: float,
                          base: float, rough_level: float,
                          opt: SegmentOptions) -> int | None:
    """End of pumping [sample index, exclusive] after a breakdown fall ending at ``s1``, or
    None.

    Pumping goes on after a breakdown at a propagation pressure about constant or rising in
    time; after a pump stop the pressure declines. The pump stop is the last sudden fall
    (:func:`~xlotkit.interpret.phases.signal.step_drops`, ``noise_multiple`` noise and
    ``step_contrast``) after ``s1`` before which the pressure has not declined by more than
    ``tol`` below the level the breakdown fell to, and after which it holds above base and
    goes quiet. None when there is no such fall: the first fall was the pump stop.
    """
    n = ps.size
    level = float(ps[s1])
    flat = np.flatnonzero(ps[s1:stop_at] < level - tol)
    reach = s1 + int(flat[0]) if flat.size else stop_at
    if reach - s1 < 3:
        return None
    size = np.full(n, opt.noise_multiple * noise)
    w = 2 * opt.settle_samples
    best = None
    for a, b in step_drops(ps, s1 + 1, min(reach + 1, stop_at), size,
                           contrast=opt.step_contrast):
        later = ps[min(b + opt.settle_samples, n - 1)]
        if later - base < 0.3 * (ps[a] - base):
            continue  # a release, not a pump stop
        if _pulsing(raw, b + 1, min(b + 1 + w, stop_at), rough_level):
            continue
        if b < stop_at and float(np.max(ps[b:stop_at])) > ps[b] + tol:
            continue  # pumping went on after it
        best = a + 1
    return best


def pressure_pumping(t, ps, found: list[Rise], base: float, noise: float,
                     opt: SegmentOptions, p: np.ndarray | None = None,
                     rough_level: float = np.inf) -> np.ndarray:
    """Pumping mask of a record without rate: each rise, extended to its pump stop.

    The pump keeps running through a breakdown and a propagation plateau and stops at a
    sudden fall (:func:`~xlotkit.interpret.phases.signal.step_drops`; at least
    ``step_fraction`` of the pressure above base and ``noise_multiple`` noise) before the
    next rise or the release of the pressure: the first such fall after which the pressure
    holds (the fall is not the release itself), never rises again (a breakdown while pumping
    is followed by more pumping) and goes quiet (a running pump makes the raw pressure ``p``
    pulse above ``rough_level``; a closed well is quiet). No such fall: the pump stops
    where the rise ends, or, if the pressure pulses on after it, where the pulsing ends.
    Pauses of up to ``2 min_phase_samples`` at more than half the height of the pumping
    before them are bridged.
    """
    n = ps.size
    pump = np.zeros(n, bool)
    raw = ps if p is None else p
    w = 2 * opt.settle_samples
    size = np.maximum(opt.noise_multiple * noise, opt.step_fraction * np.maximum(ps - base, 0.0))
    for k, r in enumerate(found):
        end = r.b
        nxt = found[k + 1].a if k + 1 < len(found) else n
        excess = float(np.max(ps[r.a:r.b])) - base
        low = np.flatnonzero(ps[r.b:nxt] - base <= 0.2 * excess)
        stop_at = r.b + int(low[0]) if low.size else nxt
        tol = max(opt.noise_multiple * noise, opt.step_fraction * excess)
        stopped = False
        for s0, s1 in step_drops(ps, max(r.b - 1, r.a), stop_at, size,
                                 contrast=opt.step_contrast):
            later = ps[min(s1 + opt.settle_samples, n - 1)]
            if later - base < 0.3 * (ps[s0] - base):
                continue  # the fall is the release to base, not a pump stop
            if s1 < stop_at and float(np.max(ps[s1:stop_at])) > ps[s1] + tol:
                # pumping went on after it: a breakdown; the pump stops at a later fall
                later_stop = _stop_after_breakdown(ps, raw, s1, stop_at, tol, noise, base,
                                                   rough_level, opt)
                if later_stop is None:
                    continue
                end, stopped = later_stop, True
                break
            if _pulsing(raw, s1 + 1, min(s1 + 1 + w, stop_at), rough_level):
                continue  # the pump still runs after it
            end = s0 + 1
            stopped = True
            # a fall after which the pressure climbs back (beyond the noise) is a breakdown
            # with the pump still running -- a shut-in well only declines: the pump stop is
            # then a later, smaller sudden fall (friction and entry loss vanishing)
            w_up = ps[s1:min(s1 + w, stop_at)]
            if w_up.size and float(np.max(w_up)) > ps[s1] + opt.noise_multiple * noise:
                end = _stop_after_breakdown(ps, raw, s1, stop_at, tol, noise, base,
                                            rough_level, opt) or end
            break
        if not stopped and _pulsing(raw, end, min(end + w, stop_at), rough_level):
            # pulsing after the rise: the pump runs on until the pressure goes quiet
            j = end
            while j < stop_at and _pulsing(raw, j, min(j + w, stop_at), rough_level):
                j += max(w // 4, 1)
            k0 = max(j - w, end)
            quiet = [m for m in range(k0, min(j + w, stop_at))
                     if not _pulsing(raw, m, min(m + w // 2, stop_at), rough_level)]
            end = max(end, min(quiet[0] if quiet else j, stop_at))
        pump[r.a:end] = True
    # a pause of up to 2 min_phase_samples between two pump runs, the pressure held above
    # half its height over base, is one pumping (a breakdown trough, a pump restarted)
    rr = runs(pump)
    for (a0, b0), (a1, b1) in zip(rr[:-1], rr[1:]):
        if a1 - b0 <= 2 * opt.min_phase_samples:
            half = base + 0.5 * (float(np.max(ps[a0:b0])) - base)
            if float(np.min(ps[b0:a1])) >= half:
                pump[b0:a1] = True
    return pump
