"""Where a decline stops being the decline: the boundary zone before the next phase.

A shut-in decline ends where something is done to the well -- a valve opened for a bleed or
a flowback, the pumps restarting, the end of the record. The segmentation places that
boundary from filtered rates, so the operation often starts a few samples before it, and its
onset (a sharp, lasting change of slope) looks like closure. :func:`boundary_zone` finds
the stretch at the end of a decline where the next phase already acts, from the record's
own rates, noise and sampling; the closure methods of :mod:`~xlotkit.interpret.picks.shutin`
leave it out and reject candidates that need it.
"""

from __future__ import annotations

import numpy as np

from xlotkit.interpret.picks.decline import Decline
from xlotkit.interpret.picks.details import BoundaryZone
from xlotkit.interpret.picks.models import fit_line, intersect
from xlotkit.interpret.picks.pressurisation import MIN_LINE_POINTS, local_fit, quantum
from xlotkit.record import Record

__all__ = ["BOUNDARY_MARGIN_SAMPLES", "boundary_zone", "release_onset", "window_slopes"]

#: Samples before the end of a decline that always count as its boundary zone: the phase
#: boundary is placed from filtered rates, so the last sample or two may already belong to
#: what follows.
BOUNDARY_MARGIN_SAMPLES = 2


def window_slopes(x: np.ndarray, y: np.ndarray, lo: np.ndarray, hi: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares slope of ``y(x)`` over samples ``[lo, hi)`` for every pair (O(n) sums).

    Returns
    -------
    slope, n, sxx : ndarray
        Slope (NaN for a degenerate window), number of samples and centred sum of squares of
        x (the slope's variance is ``sigma^2 / sxx``).
    """
    xc, yc = x - x.mean(), y - y.mean()
    z = np.zeros(1)
    c1 = np.concatenate([z, np.cumsum(np.ones(x.size))])
    cx, cy = np.concatenate([z, np.cumsum(xc)]), np.concatenate([z, np.cumsum(yc)])
    cxx = np.concatenate([z, np.cumsum(xc * xc)])
    cxy = np.concatenate([z, np.cumsum(xc * yc)])
    n = c1[hi] - c1[lo]
    sx, sy = cx[hi] - cx[lo], cy[hi] - cy[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        sxx = (cxx[hi] - cxx[lo]) - sx * sx / n
        slope = np.where(sxx > 0, ((cxy[hi] - cxy[lo]) - sx * sy / n) / sxx, np.nan)
    return slope, n, np.where(sxx > 0, sxx, np.nan)


def _seg_fits(x: np.ndarray, y: np.ndarray, lo: np.ndarray, hi: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares slope and residual sum of squares of ``y(x)`` over ``[lo, hi)``."""
    slope, n, sxx = window_slopes(x, y, lo, hi)
    yc = y - y.mean()
    z = np.zeros(1)
    cy = np.concatenate([z, np.cumsum(yc)])
    cyy = np.concatenate([z, np.cumsum(yc * yc)])
    with np.errstate(invalid="ignore", divide="ignore"):
        syy = (cyy[hi] - cyy[lo]) - (cy[hi] - cy[lo]) ** 2 / n
        sse = syy - np.nan_to_num(slope) ** 2 * np.nan_to_num(sxx)
    return slope, np.maximum(sse, 0.0)


def release_onset(record: Record, t: np.ndarray, p: np.ndarray, j0: int,
                   dec: Decline) -> int | None:
    """First sample of the final stretch of a decline that already moves at the next
    phase's rate, or None.

    The rates are the record's own: ``r_shut`` the decline's (median absolute local slope
    over its second half), ``r_next`` the next phase's over its first samples (a line
    through ``2 MIN_LINE_POINTS`` of them). A stretch is the next phase's when its slope, in
    the next phase's direction, is at least their geometric mean -- closer, on a log scale,
    to the next phase than to the decline. The stretch is where a two-segment fit splits
    the end of the decline best (the line before it over ``2 MIN_LINE_POINTS`` samples,
    slower than that; the line after it to the end, at least that fast), moved back over
    the samples just before it that already move at least that fast (the onset of a valve
    opened gradually). None at the end of the record, or when the next phase moves no
    faster than four times the decline.
    """
    n = t.size
    w = 2 * MIN_LINE_POINTS
    if dec.next_phase == "end of record" or dec.i1 + 3 > record.n or n - j0 < 2 * w:
        return None
    tn = record.t[dec.i1:dec.i1 + w]
    pn = record.pressure[dec.i1:dec.i1 + w]
    if tn.size < 3 or not np.all(np.isfinite(pn)) or np.ptp(tn) <= 0:
        return None
    r_next = float(fit_line(tn - tn[0], pn).slope)
    x = t - t[0]
    rates, _ = local_fit(x, p, 2.5, u=np.arange(n, dtype=float), min_points=5)
    half = rates[j0 + (n - j0) // 2:]
    half = half[np.isfinite(half)]
    if half.size == 0:
        return None
    r_shut = float(np.median(np.abs(half)))
    if not abs(r_next) > 4.0 * r_shut:
        return None
    gm = float(np.sqrt(max(r_shut, 1e-300) * abs(r_next)))
    sgn = np.sign(r_next)
    k = np.arange(j0 + w, n - 1)
    if k.size == 0:
        return None
    s_b, sse_b = _seg_fits(x, p, k - w, k)
    s_a, sse_a = _seg_fits(x, p, k, np.full(k.size, n))
    ok = np.isfinite(s_a) & np.isfinite(s_b) & (sgn * s_a >= gm) & (sgn * s_b < gm)
    if not ok.any():
        return None
    cost = np.where(ok, sse_a + sse_b, np.inf)
    j = int(k[int(np.argmin(cost))])
    # the split sits where the new line fits best; the change starts where the samples
    # first move at that rate (a valve opened gradually accelerates the fall)
    while j - 2 >= j0 and sgn * (p[j - 1] - p[j - 2]) / (t[j - 1] - t[j - 2]) >= gm:
        j -= 1
    return j


def boundary_zone(record: Record, t: np.ndarray, p: np.ndarray, j0: int, dec: Decline,
                   sigma: float) -> BoundaryZone:
    """The end of a decline where the operation that ends it already acts.

    At least the last :data:`BOUNDARY_MARGIN_SAMPLES` samples. Further back when an
    operation -- a valve opened for a bleed or flowback, the pumps restarting -- starts
    before the phase boundary, which the segmentation places from filtered rates: from
    where the decline already moves at the next phase's rate (:func:`release_onset`), or
    where the pressure **jumps** off its decline and never comes back to it. The zone is
    then as long as the operation's own onset in this record, whatever its sampling or
    pressure scale.

    A jump at sample ``k``, against the line through the samples before it (scatter
    ``s``): ``p[k]`` leaves the line by more than ``5 s`` (and two quantisation steps) and
    every later sample stays off it on the same side by more than ``3 s``. A change of
    slope -- which is how closure looks -- does that too, so a jump must also not be a
    kink: the lines before and after ``k`` must not cross within the sample interval of the
    jump (one interval either side, three standard errors of the crossing). Where the line
    after is too uncertain to tell (its crossing's error exceeds a sample interval), the
    samples after must scatter about it by more than ``5 s``: the water hammer of a valve
    operation, which a closure does not make. Only the first of a run of fast samples is
    looked at, and only when the samples before it lie on a straight line (within three
    times the record's noise).
    """
    n = t.size
    k_zone = max(j0 + 1, n - BOUNDARY_MARGIN_SAMPLES)
    onset = "sample margin"
    q = quantum(p[j0:])
    if n - j0 >= 3 * MIN_LINE_POINTS:
        d = np.diff(p[j0:])
        c = float(np.median(d))
        s_d = 1.4826 * float(np.median(np.abs(d - c)))
        pre = 4.0 * max(s_d, np.sqrt(2.0) * sigma, q)
        # candidates: jumps well beyond the sample-to-sample scatter (checked on local lines)
        cand = j0 + 1 + np.flatnonzero(np.abs(d - c) > pre)
        # only the first of a run of such samples can be the jump
        cand = cand[np.r_[True, np.diff(cand) > 1]] if cand.size else cand
        dt = t - t[0]
        floor = max(sigma, q / np.sqrt(12.0))
        for k in cand:
            if k - j0 < 2 * MIN_LINE_POINTS or k >= k_zone:
                continue
            a = max(j0, k - max(2 * MIN_LINE_POINTS, (k - j0) // 4))
            f = fit_line(dt[a:k], p[a:k])
            if float(f.residual_std) > 3.0 * floor:
                continue                # the samples before are no straight decline
            scat = max(sigma, float(f.residual_std), 0.5 * q)
            r = p[k:] - f(dt[k:])
            if not (abs(r[0]) > max(5.0 * scat, 2.0 * q)
                    and np.all(np.sign(r) == np.sign(r[0])) and np.all(np.abs(r) > 3.0 * scat)):
                continue
            b = min(n, k + 2 * MIN_LINE_POINTS)
            if b - k >= 3:
                g = fit_line(dt[k:b], p[k:b])
                xs, sxs, _, _ = intersect(f, g)
                step_dt = float(dt[k] - dt[k - 1])
                sxs = float(sxs) if np.isfinite(sxs) else np.inf
                kink = np.isfinite(xs) and (dt[k - 1] - step_dt - 3 * sxs <= xs
                                            <= dt[k] + step_dt + 3 * sxs)
                if kink and (sxs <= step_dt or float(g.residual_std) <= 5.0 * scat):
                    continue
            k_zone = int(k)
            onset = "pressure step"
            break
    k_rel = release_onset(record, t, p, j0, dec)
    if k_rel is not None and k_rel < k_zone:
        k_zone = max(k_rel, j0 + 1)
        onset = f"{dec.next_phase.replace('_', '-')} rate"
    return BoundaryZone(t_start=float(t[k_zone]), t_end=float(t[-1]), next_phase=dec.next_phase,
                        t_boundary=float(dec.t_next), onset=onset, samples=int(n - k_zone))
