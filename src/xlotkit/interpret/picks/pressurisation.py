"""Picks on the pumping part of a cycle and at pump stop: LOP, FBP, Pr, FPP and ISIP.

Every function takes the whole :class:`~xlotkit.record.Record` and one
:class:`~xlotkit.interpret.phases.Cycle` and returns a :class:`~xlotkit.interpret.picks.types.Pick`
with an interval, the window of data it was made from and a quality flag.

Shared machinery
----------------
Most picks are "first departure from a straight line" (LOP and Pr on pressure vs pumped volume,
the ISIP tangent, closure on sqrt(t) and G plots). The steps, implemented once here and reused by
:mod:`xlotkit.interpret.picks.shutin`, are:

1. a robust local slope ``dy/dx`` from ordinary least squares over a sliding window
   (:func:`local_fit`) -- never ``np.gradient`` of raw samples, which is useless on pressure
   quantised to 1 bar;
2. the straight stretch is the longest run of samples whose local slope stays within a relative
   tolerance ``tol`` of a common value (:func:`linear_stretch`); an initial toe (lines filling, air
   compressing) or an early transient has a different slope and is left out automatically;
3. a line is fitted to the stretch (:func:`~xlotkit.interpret.picks.models.fit_line`); the noise
   level ``sigma`` is the larger of the fit's residual scatter and the record's own noise
   (:func:`noise_level`, floored by the quantisation step ``q / sqrt(12)``);
4. departure is the first run of ``m`` consecutive samples whose residual exceeds ``k sigma``
   (:func:`first_departure`); the pick is the last sample before it still within ``1 sigma`` of
   the line, valued on the line;
5. the interval combines the line's covariance at the pick with the spread of the pick over
   automatically perturbed settings (stretch tolerance, threshold ``k``, trimmed stretch).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import lmfit
import numpy as np

from xlotkit.interpret.phases import Cycle
from xlotkit.interpret.picks.decline import (
    decline,
    pump_phases,
    shutin_phase,
    shutin_time,
    stop_pump,
    user_stretch,
)
from xlotkit.interpret.picks.details import (
    BreakdownDetails,
    BreakdownEvent,
    DepartureDetails,
    IsipDetails,
    LineDetails,
    PlateauDetails,
    PressurisationDetails,
)
from xlotkit.interpret.picks.intervals import (
    budget,
    correlation_inflation,
    onset_profile,
)
from xlotkit.interpret.picks.models import LineFit, fit_hinge, fit_line
from xlotkit.interpret.picks.types import Pick, PickQuality
from xlotkit.record import Record

__all__ = [
    "no_shutin_reason",
    "pick_fbp",
    "pick_fpp",
    "pick_isip",
    "pick_lop",
    "pick_reopening",
    "pump_phases",
    "shutin_phase",
    "shutin_time",
    "stop_pump",
]

#: Fewest samples a line fit is allowed to use.
MIN_LINE_POINTS = 6


# ===================================================================== phase helpers
# The pump stop and the decline after it live in xlotkit.interpret.picks.decline;
# pump_phases, shutin_phase, shutin_time and stop_pump are re-exported here (__all__), where
# the shut-in and diagnostics modules have always found them.


def pumped_volume(record: Record, i0: int, i1: int) -> np.ndarray | None:
    """Pumped volume since sample ``i0`` for samples ``[i0, i1)`` [m^3], or None.

    Uses ``record.volume`` when present (made relative to its first sample), else the
    trapezoidal integral of ``record.rate``: ``V(t) = int_{t0}^{t} q dt``.
    """
    if record.volume is not None and np.all(np.isfinite(record.volume[i0:i1])):
        v = record.volume[i0:i1]
        if np.ptp(v) > 0:
            return v - v[0]
    if record.rate is not None:
        q = np.clip(np.nan_to_num(record.rate[i0:i1]), 0.0, None)
        t = record.t[i0:i1]
        return np.concatenate([[0.0], np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(t))])
    return None


# ===================================================================== numeric helpers
def quantum(y: np.ndarray) -> float:
    """Quantisation step of a series (0 when the series is not visibly quantised).

    The smallest non-zero absolute difference is taken as the step when at least 90 % of the
    non-zero differences are integer multiples of it (cementing units log whole bar).
    """
    d = np.abs(np.diff(np.asarray(y, float)))
    d = d[d > 0]
    if d.size < 5:
        return 0.0
    q = float(np.min(d))
    ratio = d / q
    if np.mean(np.abs(ratio - np.round(ratio)) < 1e-6 * max(1.0, ratio.max())) >= 0.9:
        return q
    return 0.0


def noise_level(y: np.ndarray) -> float:
    """Robust one-sigma noise of a series [same units as y].

    From the median absolute second difference, ``sigma = 1.4826 MAD(d2) / sqrt(6)`` (a smooth
    trend cancels in ``d2``), floored by the quantisation error ``q / sqrt(12)``.
    """
    y = np.asarray(y, float)
    s = 0.0
    if y.size >= 5:
        d2 = np.diff(y, 2)
        s = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6.0)
    return max(s, quantum(y) / np.sqrt(12.0))


def local_fit(x, y, half_width: float, *, u=None, min_points: int = 3):
    """Sliding least-squares line: local slope and smoothed value at every sample.

    For sample ``i`` the line is fitted to all samples with ``|u_j - u_i| <= half_width``
    (``u`` defaults to ``x``; pass ``u = ln x`` for a Bourdet-style window of constant width in
    log time, or ``u = arange(n)`` for a fixed number of samples), widened to at least
    ``min_points`` samples. Cumulative sums make it O(n).

    Returns
    -------
    slope, value : ndarray
        ``dy/dx`` and the fitted ``y`` at ``x_i`` (NaN where the window is degenerate).
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    u = x if u is None else np.asarray(u, float)
    n = x.size
    idx = np.arange(n)
    lo = np.searchsorted(u, u - half_width, side="left")
    hi = np.searchsorted(u, u + half_width, side="right")
    k = max(min_points, 2) // 2
    lo = np.clip(np.minimum(lo, idx - k), 0, n)
    hi = np.clip(np.maximum(hi, idx + k + 1), 0, n)
    xm, ym = x.mean() if n else 0.0, y.mean() if n else 0.0
    xc, yc = x - xm, y - ym
    z = np.zeros(1)
    c1 = np.concatenate([z, np.cumsum(np.ones(n))])
    cx = np.concatenate([z, np.cumsum(xc)])
    cy = np.concatenate([z, np.cumsum(yc)])
    cxx = np.concatenate([z, np.cumsum(xc * xc)])
    cxy = np.concatenate([z, np.cumsum(xc * yc)])
    nn = c1[hi] - c1[lo]
    sx, sy = cx[hi] - cx[lo], cy[hi] - cy[lo]
    sxx, sxy = cxx[hi] - cxx[lo], cxy[hi] - cxy[lo]
    den = nn * sxx - sx * sx
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.where(den > 0, (nn * sxy - sx * sy) / den, np.nan)
        value = sy / nn + slope * (xc - sx / nn) + ym
    return slope, value


def linear_stretch(slopes: np.ndarray, *, tol: float, min_len: int, sign: int = 0,
                   start: int = 0, stop: int | None = None, x: np.ndarray | None = None,
                   prefer_early: bool | float = False) -> tuple[int, int] | None:
    """Longest run of samples whose local slope stays within ``tol`` of a common value.

    "Longest" is measured along ``x`` when given (so that densely sampled late times do not
    outweigh a sparsely sampled early straight line), else in samples. With
    ``prefer_early`` the earliest run at least half as long as the longest one wins (on a
    shut-in the straight line of interest is the first one after the drop); a float gives that
    fraction instead of one half.

    Candidate reference slopes are quantiles of the local slopes (of sign ``sign`` when not 0);
    for each, the samples with ``|s - s_ref| <= tol |s_ref|`` are marked and the longest
    contiguous run kept. Only ``[start, stop)`` is searched.

    Returns
    -------
    (a, b) : tuple of int or None
        Inclusive indices of the run; None when no run has ``min_len`` samples.
    """
    s = np.asarray(slopes, float)
    stop = s.size if stop is None else stop
    seg = s[start:stop]
    fin = seg[np.isfinite(seg)]
    if sign:
        fin = fin[np.sign(fin) == sign]
    if fin.size < min_len:
        return None
    runs: list[tuple[float, int, int]] = []
    for c in np.quantile(fin, np.linspace(0.02, 0.98, 49)):
        if c == 0:
            continue
        ok = np.isfinite(seg) & (np.abs(seg - c) <= tol * abs(c))
        d = np.diff(np.concatenate([[0], ok.astype(int), [0]]))
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        if starts.size == 0:
            continue
        counts = ends - starts
        keep = counts >= min_len
        if not keep.any():
            continue
        starts, ends, counts = starts[keep], ends[keep], counts[keep]
        if x is not None:
            xs = np.asarray(x, float)[start:stop]
            lengths = xs[ends - 1] - xs[starts]
        else:
            lengths = counts.astype(float)
        runs.extend(zip(lengths.tolist(), (start + starts).tolist(), (start + ends - 1).tolist()))
    if not runs:
        return None
    longest = max(r[0] for r in runs)
    if prefer_early:
        frac = 0.5 if prefer_early is True else float(prefer_early)
        ok = [r for r in runs if r[0] >= frac * longest]
        r = min(ok, key=lambda r: (r[1], -r[0]))
    else:
        r = max(runs, key=lambda r: r[0])
    return int(r[1]), int(r[2])


def first_departure(r: np.ndarray, sigma: float, *, start: int, k: float, m: int,
                    sign: int = 0) -> int | None:
    """Index of the first of ``m`` consecutive residuals beyond ``k sigma`` at or after ``start``.

    ``sign`` -1 looks only below the line, +1 only above, 0 either side (all ``m`` on the same
    side).
    """
    r = np.asarray(r, float)
    if r.size - start < m:
        return None
    for sgn in ((sign,) if sign else (-1, 1)):
        bad = (sgn * r) > k * sigma
        bad[:start] = False
        run = np.convolve(bad.astype(int), np.ones(m, int), mode="valid") == m
        hits = np.flatnonzero(run)
        if hits.size:
            j = int(hits[0])
            if sign == 0:
                # Keep the earlier of the two sides.
                other = (-sgn * r) > k * sigma
                other[:start] = False
                run2 = np.convolve(other.astype(int), np.ones(m, int), mode="valid") == m
                h2 = np.flatnonzero(run2)
                if h2.size and h2[0] < j:
                    return int(h2[0])
            return j
    return None


def quality(r2: float, value: float, low: float | None, high: float | None, n: int,
            *, scale: float | None = None) -> PickQuality:
    """Quality flag from the fit's R^2, the relative interval width and the number of points.

    good: R^2 >= 0.98, width <= 2 % of ``scale`` (default the value), n >= 20;
    fair: R^2 >= 0.9, width <= 6 %, n >= 8; poor otherwise.
    """
    scale = abs(value) if scale is None else abs(scale)
    width = (high - low) if (low is not None and high is not None) else np.inf
    rel = width / scale if scale > 0 else np.inf
    if r2 >= 0.98 and rel <= 0.02 and n >= 20:
        return "good"
    if r2 >= 0.9 and rel <= 0.06 and n >= 8:
        return "fair"
    return "poor"


def line_stderr_at(fit: LineFit, x: float) -> float:
    """One-sigma error of a fitted line evaluated at ``x``: ``sqrt(g C g^T)``, ``g = (x, 1)``."""
    g = np.array([x, 1.0])
    v = float(g @ np.nan_to_num(fit.covariance) @ g)
    return float(np.sqrt(max(v, 0.0)))


def bend(x, x0=0.0, slope=1.0, intercept=0.0, amp=0.0, power=2.0, side=-1.0):
    """A line that bends away at ``x0``: ``y = slope x + intercept + side amp (x - x0)_+^power``.

    ``power`` 1 is a kink (sudden change of slope), 2 a gradual, parabolic departure; ``side``
    (fixed, -1 or +1) says whether the curve leaves below or above the line.
    """
    x = np.asarray(x, float)
    dx = np.clip(x - x0, 0.0, None)
    return slope * x + intercept + side * amp * dx**power


def fit_bend(x: np.ndarray, y: np.ndarray, *, x0: float, slope: float, intercept: float,
             side: int) -> tuple[float, float] | None:
    """Fit :func:`bend` and return the departure point ``(x0, x0_stderr)``, or None.

    The start of the departure is estimated from the shape of the departing curve rather than
    from where it first exceeds the noise, which removes most of the detection delay of a
    gradual bend.
    """
    if x.size < 8:
        return None
    model = lmfit.Model(bend)
    span = float(x[-1] - x[0]) or 1.0
    params = model.make_params(x0=x0, slope=slope, intercept=intercept, amp=0.0, power=1.5,
                               side=float(side))
    params["side"].set(vary=False)
    params["x0"].set(min=float(x[0]), max=float(x[-1]))
    params["power"].set(min=1.0, max=3.0)
    resid = np.abs(y - (slope * x + intercept))
    ext = float(np.max(resid)) if resid.size else 0.0
    params["amp"].set(value=ext / max((x[-1] - x0) ** 1.5, 1e-30), min=0.0)
    try:
        res = model.fit(y, params, x=x)
    except (ValueError, TypeError):
        return None
    if not res.success:
        return None
    p = res.params
    se = p["x0"].stderr
    x0f = float(p["x0"].value)
    if not np.isfinite(x0f) or x0f <= x[0] + 1e-9 * span or x0f >= x[-1] - 1e-9 * span:
        return None
    return x0f, (float(se) if se is not None and np.isfinite(se) else np.nan)


# ===================================================================== departure machinery
@dataclass(frozen=True)
class Departure:
    """Result of one straight-line + departure search (indices into the arrays searched).

    Attributes
    ----------
    fit : LineFit
        Line through the straight stretch.
    a, b : int
        Inclusive indices of the stretch.
    j_dep : int or None
        First sample of the significant departure run.
    j_pick : int or None
        Last sample before ``j_dep`` still within one sigma of the line (the pick).
    sigma : float
        Noise level used for the threshold.
    direction : int
        -1 departure below the line, +1 above, 0 none.
    """

    fit: LineFit
    a: int
    b: int
    j_dep: int | None
    j_pick: int | None
    sigma: float
    direction: int


def find_departure(x: np.ndarray, y: np.ndarray, *, sign: int = 0, slope_sign: int = 0,
                   tol: float = 0.1, k: float = 3.0, m: int | None = None,
                   w: int | None = None, stretch: tuple[int, int] | None = None,
                   start: int = 0, noise: float | None = None,
                   prefer_early: bool | float = False) -> Departure | None:
    """Straight stretch of ``y(x)`` and the first significant departure after it.

    Parameters
    ----------
    x, y : ndarray
        Data, ``x`` non-decreasing.
    sign : int
        Side of the line the departure must be on (-1 below, +1 above, 0 either).
    slope_sign : int
        Required sign of the stretch's slope (0: any).
    tol : float
        Relative slope tolerance of the stretch.
    k, m : float, int
        Departure threshold (``k`` sigma) and run length (default ~2 % of the samples, 3..10).
    w : int
        Fewest samples in the local-slope window (default: enough for the pressure to change
        by ~10 noise levels across it, at least 2 % of the samples and 5, at most a quarter);
        the window is +-4 % of the range of ``x``.
    stretch : (int, int), optional
        Fixed inclusive stretch (a user window) instead of the automatic one.
    start : int
        First index searched for the stretch.
    noise : float, optional
        Noise level of ``y``; estimated when omitted.
    """
    n = x.size
    if n - start < 2 * MIN_LINE_POINTS:
        return None
    if m is None:
        m = int(np.clip(round(0.02 * (n - start)), 3, 10))
    if stretch is None:
        # Windows of fixed width in x (4 % of its range each side), at least w samples.
        if w is None:
            # Enough samples that the change across a window is ~10 noise levels (quantised
            # data need long windows for a usable slope).
            nz = noise if noise is not None else noise_level(y[start:])
            span = float(np.ptp(y[start:])) or 1.0
            w = int(np.clip(10.0 * nz / span * (n - start), 5, max(5, (n - start) // 4)))
            w = max(w, int(round(0.02 * (n - start))))
        half = 0.04 * float(x[-1] - x[start])
        slopes, _ = local_fit(x, y, half, min_points=w)
        slopes[: start] = np.nan
        st = linear_stretch(slopes, tol=tol, min_len=MIN_LINE_POINTS, sign=slope_sign,
                            start=start, x=x, prefer_early=prefer_early)
        if st is None:
            return None
        a, b = st
    else:
        a, b = stretch
    if b - a + 1 < MIN_LINE_POINTS:
        return None
    fit = fit_line(x[a:b + 1], y[a:b + 1])
    sig = max(fit.residual_std, noise if noise is not None else noise_level(y[a:b + 1]))
    sig = max(sig, 1e-12 * max(1.0, float(np.max(np.abs(y)))))
    r = y - fit(x)
    j = first_departure(r, sig, start=a, k=k, m=m, sign=sign)
    if j is None:
        return Departure(fit, a, b, None, None, sig, 0)
    direction = int(np.sign(r[j])) or -1
    # Walk back to the last sample still on the line (within 1 sigma on the departure side).
    jp = j
    while jp > a and direction * r[jp] > sig:
        jp -= 1
    return Departure(fit, a, b, j, jp, sig, direction)


def _refined_x0(x: np.ndarray, y: np.ndarray, d: Departure) -> tuple[float, float] | None:
    """Start of the departure from a :func:`fit_bend` fit between the stretch and ~10 sigma off."""
    r = d.direction * (y - d.fit(x))
    far = np.flatnonzero(r[d.j_dep:] > 10 * d.sigma)
    m = 3
    j_end = d.j_dep + (int(far[0]) if far.size else 2 * (d.j_dep - d.j_pick) + 3 * m)
    j_end = min(x.size, max(j_end, d.j_dep + 3 * m) + 1)
    res = fit_bend(x[d.a:j_end], y[d.a:j_end], x0=float(x[d.j_pick]), slope=d.fit.slope,
                   intercept=d.fit.intercept, side=d.direction)
    if res is None or not (x[d.a] < res[0] <= x[d.j_dep]):
        return None
    return res


@dataclass
class _Trial:
    value: float
    x: float
    t: float


def departure_pick(name: str, method: str, x: np.ndarray, y: np.ndarray, t: np.ndarray, *,
                   sign: int = 0, slope_sign: int = 0, start: int = 0,
                   stretch: tuple[int, int] | None = None, noise: float | None = None,
                   not_found_msg: str = "no departure from the straight line",
                   x_name: str = "x", prefer_early: bool | float = False) -> Pick:
    """A :class:`Pick` at the first departure from a straight line of ``y(x)``.

    The base search (:func:`find_departure`) is repeated with the slope tolerance at 0.06 and
    0.15, the threshold ``k`` at 2.5 and 4, and the stretch trimmed by 15 % at either end; the
    interval is ``[min - s, max + s]`` over these trials, ``s`` the line's one-sigma error at
    the pick (from the fit covariance).
    """
    base = find_departure(x, y, sign=sign, slope_sign=slope_sign, start=start,
                          stretch=stretch, noise=noise, prefer_early=prefer_early)
    if base is None:
        return Pick.not_found(name, method, f"{not_found_msg}: no straight stretch found "
                              f"({x.size - start} samples)")
    details = DepartureDetails(x_name=x_name, line=LineDetails.of(base.fit),
                               sigma=float(base.sigma),
                               x_range=tuple(float(v) for v in base.fit.x_range))
    win = (float(t[base.a]), float(t[base.b]))
    if base.j_pick is None:
        return Pick.not_found(
            name, method, f"{not_found_msg}: the line fitted on t = {win[0]:.0f}-{win[1]:.0f} s "
            f"holds to the end of the data within {3:g} sigma", window=win, details=details)

    def value_of(d: Departure | None, refine: bool = True) -> _Trial | None:
        if d is None or d.j_pick is None:
            return None
        xp = float(x[d.j_pick])
        if refine:
            xb = _refined_x0(x, y, d)
            if xb is not None:
                xp = xb[0]
        return _Trial(float(d.fit(xp)), xp, float(np.interp(xp, x, t)))

    best = value_of(base)
    assert best is not None
    walk = value_of(base, refine=False)
    trials: list[_Trial] = [best, walk]
    jd = base.j_dep
    variants: list[dict[str, Any]] = []
    if stretch is None:
        variants += [{"tol": 0.06}, {"tol": 0.15}]
    variants += [{"k": 2.5, "stretch": (base.a, base.b)}, {"k": 4.0, "stretch": (base.a, base.b)}]
    L = base.b - base.a
    trim = max(1, int(0.15 * L))
    if L - trim >= MIN_LINE_POINTS:
        variants += [{"stretch": (base.a + trim, base.b)}, {"stretch": (base.a, base.b - trim)}]
    for kw in variants:
        kw2 = {"sign": sign, "slope_sign": slope_sign, "start": start, "noise": noise,
               "prefer_early": prefer_early, **kw}
        tr = value_of(find_departure(x, y, **kw2))
        if tr is not None:
            trials.append(tr)
    vals = np.array([tr.value for tr in trials])
    s = line_stderr_at(base.fit, best.x)
    if not np.isfinite(s) or s > 0.5 * (float(np.ptp(y)) or 1.0):
        # Degenerate covariance (e.g. x barely changing on the stretch): the spread over the
        # trials is all we have.
        s = 0.0
    low, high = float(vals.min() - s), float(vals.max() + s)
    # The onset of a gradual departure can lie before it is detected: the profile of the
    # bend model over the stretch and the departure gives the admissible onsets.
    r_dep = base.direction * (y - base.fit(x))
    far = np.flatnonzero(r_dep[jd:] > 10 * base.sigma)
    j_end = min(x.size, jd + (int(far[0]) if far.size else max(3 * (jd - base.a) // 2, 10)) + 1)
    prof = onset_profile(x[base.a:j_end], y[base.a:j_end], base.direction or -1,
                         inflation=correlation_inflation(y[base.a:base.b + 1]
                                                         - base.fit(x[base.a:base.b + 1])))
    extra = [] if prof is None else [("onset", prof[0], prof[1])]
    q_y = quantum(y)
    bud = budget(best.value, stderr=s, trials=vals.tolist(), resolution=0.5 * q_y,
                 extra=extra)
    details = replace(
        details, interval=bud, x_pick=float(best.x),
        departure="below" if base.direction < 0 else "above",
        x_departure_detected=float(x[jd]), t_departure_detected=float(t[jd]),
        trial_values=tuple(float(v) for v in vals), line_stderr_at_pick=float(s),
        x_first_deviation=float(walk.x), first_deviation_value=float(walk.value))
    q = quality(base.fit.r2, best.value, low, high, base.fit.n)
    return Pick(name=name, method=method, value=best.value, low=bud.low, high=bud.high,
                t=best.t, window=(win[0], float(t[jd])), quality=q, details=details,
                level=bud.level)


#: Inclusive index range of the samples in a user window (``decline.user_stretch``).
_user_stretch = user_stretch


# ===================================================================== LOP / Pr
def _pressurisation_pick(name: str, record: Record, cycle: Cycle,
                         window: tuple[float, float] | None) -> Pick:
    pumps = pump_phases(cycle)
    if not pumps:
        return Pick.not_found(name, "departure", "the cycle has no pump phase")
    ph = pumps[0]
    i0, i1 = ph.i0, ph.i1
    t = record.t[i0:i1]
    p = record.pressure[i0:i1]
    if t.size < 2 * MIN_LINE_POINTS:
        return Pick.not_found(name, "departure", f"pump phase too short ({t.size} samples)")
    v = pumped_volume(record, i0, i1)
    use_volume = v is not None and np.ptp(v) > 0
    x = v if use_volume else t - t[0]
    x_name = "V" if use_volume else "t"
    # Only the rising part matters: up to a little past the highest pressure (the departure
    # of a brittle breakdown is the drop right after the peak).
    ipk = int(np.argmax(p))
    stop = min(t.size, ipk + max(10, int(0.1 * ipk)) + 1)
    x, p_, t_ = x[:stop], p[:stop], t[:stop]
    stretch = _user_stretch(t_, window)
    pick = departure_pick(name, "departure", x, p_, t_, sign=-1, slope_sign=1,
                          stretch=stretch, x_name=x_name, prefer_early=0.15,
                          not_found_msg="no departure from the pressurisation line")
    if not pick.found and pick.window is None:
        return pick
    dep = pick.details
    slope, se = dep.line.slope, dep.line.slope_stderr
    if use_volume:
        d = PressurisationDetails(departure=dep, stiffness=slope, stiffness_stderr=se)
    else:
        d = PressurisationDetails(departure=dep, pressurisation_rate=slope,
                                  pressurisation_rate_stderr=se)
    msg = pick.message
    if not use_volume:
        msg = (msg + "; " if msg else "") + "no volume or rate: pressure vs time used"
    if pick.found:
        # Hinge fit as an independent check of where the slope changes.
        jd = int(np.searchsorted(t_, dep.t_departure_detected))
        a = int(np.searchsorted(t_, pick.window[0]))
        hi = min(x.size, jd + max(MIN_LINE_POINTS, (jd - a) // 3))
        try:
            h = fit_hinge(x[a:hi], p_[a:hi], min_points=MIN_LINE_POINTS)
            d = replace(d, hinge_x=float(h.x0), hinge_pressure=float(h.y0),
                        hinge_stderr=float(h.y0_stderr))
        except (ValueError, TypeError):
            pass
        if abs(pick.value - float(np.max(p))) <= 3 * dep.sigma:
            msg = (msg + "; " if msg else "") + "departure at the peak (brittle breakdown)"
    # The reopening pressure's interval holds its 90 % level in the calibration study
    # (docs/intervals.md); the LOP's does not (its departure is often detected early on a
    # bend that ends in breakdown), so the LOP states no level.
    level = pick.level if name == "Pr" else None
    return Pick(name=pick.name, method=pick.method, value=pick.value, low=pick.low,
                high=pick.high, t=pick.t, window=pick.window, quality=pick.quality,
                message=msg, details=d, level=level)


def pick_lop(record: Record, cycle: Cycle, *, window: tuple[float, float] | None = None) -> Pick:
    """Leak-off pressure: first departure below the linear pressurisation line, p vs V.

    While the well is a closed elastic vessel the pressure rises linearly with pumped volume,
    ``p = p0 + K V`` with the system stiffness ``K = dp/dV`` [Pa/m^3]. The LOP is the first
    sample where the pressure falls significantly below that line (see the module docstring
    for the statistics). ``V`` is ``record.volume`` or the integral of ``record.rate``; without
    either, time is used (constant rate assumed) and no stiffness is reported.

    Parameters
    ----------
    record : Record
    cycle : Cycle
        The pressurisation is the cycle's first pump phase.
    window : (t0, t1), optional
        Elapsed-time window [s] of the straight stretch, overriding the automatic choice
        (longest stretch of stable slope, which skips the initial toe).

    Returns
    -------
    Pick
        ``name="LOP"``, ``method="departure"``; details (:class:`~xlotkit.interpret.picks.
        details.PressurisationDetails`): ``stiffness`` [Pa/m^3] with ``stiffness_stderr``,
        the hinge-fit check ``hinge_pressure``.
    """
    return _pressurisation_pick("LOP", record, cycle, window)


def pick_reopening(record: Record, cycle: Cycle, *,
                   window: tuple[float, float] | None = None) -> Pick:
    """Reopening pressure Pr of a later cycle: departure from its linear pressurisation line.

    Same method as :func:`pick_lop` (``name="Pr"``): with a fracture already there, the pressure
    leaves the stiffness line where the fracture starts to take fluid again.
    """
    return _pressurisation_pick("Pr", record, cycle, window)


# ===================================================================== FBP / FPP
def _pump_samples(record: Record, cycle: Cycle) -> np.ndarray:
    pumps = pump_phases(cycle)
    if not pumps:
        return np.zeros(0, int)
    return np.concatenate([np.arange(p.i0, p.i1) for p in pumps])


#: How far the pump rate may change (relative to its rate at the peak) and still count as
#: unchanged: a few percent is the steadiness of a cementing or frac pump at a set rate; the
#: rate's own noise (4 sigma) widens it on a noisy flowmeter.
RATE_STEADY_FRACTION = 0.05


def _rate_tol(q_peak: float | None, noise_tol: float) -> float:
    """Change of rate [m^3/s] that counts as a change at a peak pumped at ``q_peak``."""
    return max(RATE_STEADY_FRACTION * abs(q_peak or 0.0), noise_tol)


def _fbp_events(pm: np.ndarray, t: np.ndarray, q: np.ndarray | None, gap: np.ndarray,
                thresh: float, q_noise: float
                ) -> list[tuple[int, int, float, BreakdownEvent]]:
    """Every local peak of the smoothed pumping pressure and the fall after it.

    For a peak at ``i`` the fall is followed until the pressure comes back above the peak
    or pumping pauses, and counted only while the rate holds: a cut of the rate (below the
    peak's by more than :func:`_rate_tol`) ends it, since less friction explains a fall
    from there on; a higher rate does not (more fluid and less pressure is breakdown
    itself). A peak whose pressure falls only with a rate cut is kept as a rejected event.

    Returns
    -------
    list of (i_peak, i_min, drop, BreakdownEvent)
        ``drop`` is the fall while the rate held [Pa].
    """
    n = pm.size
    out: list[tuple[int, int, float, BreakdownEvent]] = []
    if n < 3:
        return out
    left = np.concatenate([[-np.inf], pm[:-1]])
    right = np.concatenate([pm[1:], [-np.inf]])
    peaks = np.flatnonzero((pm >= left) & (pm > right))
    # where pumping resumes after a pause (a fall across a pause is not "while pumping")
    starts = np.flatnonzero(gap)
    for i in peaks:
        k = int(np.searchsorted(starts, i, side="right"))
        end = int(starts[k]) if k < starts.size else n
        seg = pm[i + 1:end]
        if seg.size == 0:
            continue
        above = np.flatnonzero(seg > pm[i])
        stop = int(above[0]) if above.size else seg.size
        if stop == 0:
            continue
        fall = pm[i] - seg[:stop]
        drop_any = float(np.max(fall))
        if drop_any < thresh:
            continue
        qi = None
        held = stop
        if q is not None:
            qi = float(q[i])
            cut = np.flatnonzero(q[i + 1:i + 1 + stop] < qi - _rate_tol(qi, q_noise))
            held = int(cut[0]) if cut.size else stop
        drop = float(np.max(fall[:held])) if held > 0 else 0.0
        if drop >= thresh:
            i_min = i + 1 + int(np.argmax(fall[:held]))
            why = ("fell at an unchanged or higher pump rate" if q is not None
                   else "fell while pumping (no rate logged)")
            out.append((int(i), i_min, drop, BreakdownEvent(
                t=float(t[i]), pressure=float(pm[i]), drop=drop, rate=qi, accepted=True,
                reason=why)))
        else:
            t_cut = float(t[i + 1 + held]) if i + 1 + held < t.size else float(t[-1])
            out.append((int(i), i + 1 + int(np.argmax(fall)), drop, BreakdownEvent(
                t=float(t[i]), pressure=float(pm[i]), drop=drop_any, rate=qi,
                accepted=False,
                reason=f"the pressure fell {drop_any / 1e5:.1f} bar only with a cut of the "
                       f"pump rate (at t = {t_cut:.0f} s): less friction, not breakdown")))
    return out


def pick_fbp(record: Record, cycle: Cycle) -> Pick:
    """Formation breakdown pressure: the peak before the pressure falls at unchanged rate.

    Breakdown is an event, not the largest pumping pressure: the formation gives way and the
    pressure falls while the pumps keep running at the same rate (or a higher one: more
    fluid and less pressure is breakdown itself). At a raised rate the pumping pressure can
    climb above the breakdown peak by friction alone, and at a cut rate it falls by friction
    alone; neither is breakdown. The pumping samples of the cycle (every pump phase) are
    smoothed by a 3-sample running median (a single spike does not count) and every local
    peak is followed (:func:`_fbp_events`) until the pressure is back above it or pumping
    pauses; its fall counts while the rate holds -- not below the peak's rate by more than
    ``max(RATE_STEADY_FRACTION, 4 sigma_q / q_peak)`` of it -- and must exceed
    ``max(5 sigma, 2 q, 0.5 % of the peak)`` (``sigma`` the noise, ``q`` the quantisation
    step). The FBP is the peak with the largest such fall (the breakdown; later falls are
    smaller propagation steps); a peak whose pressure falls only once the rate is cut is
    reported as rejected. Without a rate log every fall while pumping counts.

    The interval spans the running-median peak and the raw maximum near it, ``± q/2``, and the
    rise the pressure could still make within one sample interval.

    Returns
    -------
    Pick
        ``name="FBP"``, ``method="max"``; not found when the pressure never fell while pumping
        at an unchanged rate. Details: :class:`~xlotkit.interpret.picks.details.
        BreakdownDetails` (every peak examined in ``events``).
    """
    idx = _pump_samples(record, cycle)
    if idx.size < 5:
        return Pick.not_found("FBP", "max", "the cycle has no pumping data")
    p = record.pressure[idx]
    t = record.t[idx]
    pm = _running_median(p, 3)
    sig = noise_level(p)
    q = quantum(p)
    gap = np.concatenate([[False], np.diff(idx) > 1])
    rate = None
    if record.rate is not None and np.any(np.isfinite(record.rate[idx])):
        rate = _running_median(np.nan_to_num(record.rate[idx]), 3)
    top = float(np.max(pm))
    thresh = max(5 * sig, 2 * q, 0.005 * abs(top))
    q_noise = 4.0 * noise_level(rate) if rate is not None else 0.0
    events = _fbp_events(pm, t, rate, gap, thresh, q_noise)
    i_top = int(np.argmax(pm))
    accepted = [e for e in events if e[3].accepted]
    details = BreakdownDetails(
        drop_after_peak=0.0, drop_threshold=thresh, sigma=sig, quantum=q,
        raw_max=float(p.max()), highest_pumping_pressure=top,
        rate_tolerance=None, events=tuple(e[3] for e in events))
    if not accepted:
        rejected = [e for e in events if not e[3].accepted]
        why = "no breakdown: the pressure never fell while pumping"
        if rate is not None:
            why += " with the pump rate held"
        if rejected:
            big = max(rejected, key=lambda e: e[2])
            why += (f" (the largest fall, {big[2] / 1e5:.1f} bar after {big[3].pressure / 1e5:.1f}"
                    f" bar at t = {big[3].t:.0f} s: {big[3].reason})")
        else:
            tail = float(pm[i_top] - np.min(pm[i_top:]))
            why += f" (fall after the highest pressure {tail / 1e5:.2f} bar)"
        return Pick.not_found("FBP", "max", why, details=details)
    ipk, _, drop, ev = max(accepted, key=lambda e: (e[2], -e[0]))
    value = float(pm[ipk])
    # The peak lies between samples: the pressure can have risen further, for up to one
    # sample interval, at the rate it was rising before the highest sample (a brittle
    # breakdown turns over within a sample), and the running median trims a one-sample
    # peak to its neighbours.
    lo_i, hi_i = max(0, ipk - 2), min(p.size, ipk + 3)
    i_raw = lo_i + int(np.argmax(p[lo_i:hi_i]))
    k0 = max(0, i_raw - 5)
    rise = 0.0
    if i_raw - k0 >= 2:
        rise = max(float(np.polyfit(t[k0:i_raw + 1], p[k0:i_raw + 1], 1)[0]), 0.0)
    dt_s = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    peak_top = max(value, float(p[i_raw]))
    bud = budget(value, stderr=sig, trials=[float(p[i_raw])], resolution=0.5 * q,
                 extra=[("between samples", peak_top, peak_top + rise * dt_s)])
    details = replace(details, drop_after_peak=drop, rise_rate=rise, interval=bud,
                      raw_max=float(p[i_raw]), rate_at_peak=ev.rate,
                      rate_tolerance=None if rate is None else _rate_tol(ev.rate, q_noise))
    qual: PickQuality = "good" if drop > 3 * thresh else "fair"
    msg = f"pressure fell {drop / 1e5:.1f} bar after the peak"
    if rate is not None:
        msg += f" at an unchanged or higher pump rate ({ev.rate * 6e4:.0f} l/min at the peak)"
    else:
        msg += " while pumping (no rate logged: a rate change cannot be ruled out)"
        if qual == "good":
            qual = "fair"
    if top - value > thresh:
        msg += (f"; the highest pumping pressure, {top / 1e5:.1f} bar at t = {t[i_top]:.0f} s,"
                " is not a breakdown (no fall at an unchanged rate after it)")
    return Pick("FBP", "max", value, bud.low, bud.high, t=float(t[ipk]),
                window=(float(t[0]), float(t[-1])), quality=qual, message=msg,
                details=details, level=bud.level)


def _running_median(y: np.ndarray, w: int) -> np.ndarray:
    """Centred running median over ``w`` samples (edges use the available samples)."""
    y = np.asarray(y, float)
    h = w // 2
    pad = np.pad(y, h, mode="edge")
    win = np.lib.stride_tricks.sliding_window_view(pad, 2 * h + 1)
    return np.median(win, axis=1)


def pick_fpp(record: Record, cycle: Cycle, *, window: tuple[float, float] | None = None) -> Pick:
    """Fracture propagation pressure: the stabilised plateau while pumping after breakdown.

    Working back from the pump stop, the plateau is the longest final stretch of pumping
    after the peak whose running median stays within a band ``max(3 sigma, 1.5 q, 1 %)`` of the
    median of its last quarter. The value is the plateau's median; the interval spans the
    medians of its first and last thirds (trend) widened by the standard error of the median,
    ``1.25 sigma_p / sqrt(n)``.

    Parameters
    ----------
    window : (t0, t1), optional
        Elapsed-time window [s] of the plateau, overriding the automatic choice.

    Returns
    -------
    Pick
        ``name="FPP"``, ``method="plateau"``; details: trend [Pa/s], rate variation.
    """
    idx = _pump_samples(record, cycle)
    if idx.size < 10:
        return Pick.not_found("FPP", "plateau", "the cycle has no pumping data")
    p_all = record.pressure[idx]
    t_all = record.t[idx]
    if window is not None:
        sel = (t_all >= window[0]) & (t_all <= window[1])
        if sel.sum() < 3:
            raise ValueError(f"window {window} holds fewer than 3 pumping samples")
        p, t = p_all[sel], t_all[sel]
    else:
        ipk = int(np.argmax(_running_median(p_all, 3)))
        p, t = p_all[ipk:], t_all[ipk:]
        if p.size < 10:
            return Pick.not_found("FPP", "plateau", "no plateau: the pressure was still rising "
                                  "at pump stop")
        sig = noise_level(p)
        pm = _running_median(p, 5)
        ref = float(np.median(pm[-max(5, pm.size // 4):]))
        band = max(3 * sig, 1.5 * quantum(p), 0.01 * abs(ref))
        out = np.flatnonzero(np.abs(pm - ref) > band)
        j0 = int(out[-1]) + 1 if out.size else 0
        p, t = p[j0:], t[j0:]
        min_n = max(10, int(np.ceil(20.0 / max(np.median(np.diff(t_all)), 1e-9))))
        if p.size < min_n:
            return Pick.not_found("FPP", "plateau", f"no stable plateau after the peak "
                                  f"({p.size} samples within the band)")
    n = p.size
    value = float(np.median(p))
    sig = noise_level(p)
    thirds = [float(np.median(c)) for c in np.array_split(p, 3)]
    se = 1.25 * max(float(np.std(p)), sig) / np.sqrt(n)
    low, high = min(thirds + [value]) - se, max(thirds + [value]) + se
    trend = fit_line(t, p) if n >= 3 else None
    msg = ""
    cv = None
    if record.rate is not None:
        r = record.rate[(record.t >= t[0]) & (record.t <= t[-1])]
        cv = float(np.std(r) / np.mean(r)) if np.mean(r) > 0 else np.inf
        if cv > 0.1:
            msg = f"pump rate not constant on the plateau (variation {100 * cv:.0f} %)"
    details = PlateauDetails(n=int(n), trend=float(trend.slope) if trend else np.nan,
                             trend_stderr=float(trend.slope_stderr) if trend else np.nan,
                             std=float(np.std(p)), thirds=tuple(thirds), rate_cv=cv)
    rel = (high - low) / abs(value) if value else np.inf
    q: PickQuality = "good" if rel < 0.01 and n >= 30 else ("fair" if rel < 0.04 else "poor")
    if msg and q == "good":
        q = "fair"
    return Pick("FPP", "plateau", value, low, high, t=float(0.5 * (t[0] + t[-1])),
                window=(float(t[0]), float(t[-1])), quality=q, message=msg, details=details)


# ===================================================================== ISIP
@dataclass(frozen=True)
class EarlyDecline:
    """The early shut-in decline line (after the friction / water-hammer drop).

    Attributes
    ----------
    t_s : float
        Shut-in time [s].
    j0, j1 : int
        Inclusive indices (into the shut-in arrays) of the early-decline window.
    fit : LineFit
        Line ``p = slope (t - t_s) + intercept`` on that window; ``intercept`` is the ISIP.
    sigma : float
        Noise level of the shut-in pressure.
    """

    t_s: float
    j0: int
    j1: int
    fit: LineFit
    sigma: float
    trials: list[float] = field(default_factory=list)


def _early_length(p: np.ndarray, d: int, sigma: float, q: float) -> int:
    """Samples in an early-decline window starting at ``d``.

    The pressure change across the window must be well above the noise: at least 8 samples,
    grown until the running median has fallen by ``max(8 sigma, 5 q)`` (``q`` the quantisation
    step), at most a quarter of the shut-in.
    """
    need = max(8 * sigma, 5 * q)
    n = p.size
    cap = max(8, n // 4)
    below = np.flatnonzero(p[d:] <= p[d] - need)
    L = int(below[0]) + 1 if below.size else cap
    return int(min(max(L, 8), cap))


def early_decline(t: np.ndarray, p: np.ndarray, t_s: float, *,
                  window: tuple[float, float] | None = None) -> EarlyDecline | None:
    """Find the early shut-in decline after the rapid drop and fit a line to it.

    Lines of ``L`` samples (:func:`_early_length`) are fitted starting ``d = 0, 1, 2, ...``
    samples after shut-in; the rapid drop is over at the first ``d`` whose line has no
    curvature: residual scatter ``<= 2 sigma`` and the sample just before the window (if any)
    lies no more than ``3 sigma`` above the line's extrapolation ... or, equivalently, the
    first window not bent by the drop. Searched over the first third of the shut-in.

    Parameters
    ----------
    t, p : ndarray
        Shut-in samples (times [s], pressures [Pa]).
    t_s : float
        Shut-in time [s].
    window : (t0, t1), optional
        User window [s] of the early decline.
    """
    dt = t - t_s
    n = t.size
    if n < 2 * MIN_LINE_POINTS:
        return None
    sig = noise_level(p)
    if window is not None:
        a, b = _user_stretch(t, window)
        fit = fit_line(dt[a:b + 1], p[a:b + 1])
        return EarlyDecline(t_s, a, b, fit, sig)
    q = quantum(p)
    pm = _running_median(p, 5)
    best = None
    for d in range(max(1, n // 3)):
        L = _early_length(pm, d, sig, q)
        if d + L > n:
            break
        xw = dt[d:d + L] - dt[d:d + L].mean()
        yw = p[d:d + L]
        c1 = np.polyfit(xw, yw, 1)
        rstd = float(np.std(yw - np.polyval(c1, xw), ddof=2))
        # Curvature test: mid-window sag of a quadratic fit.
        c2 = np.polyfit(xw, yw, 2)[0]
        span = dt[d + L - 1] - dt[d]
        bend = abs(c2) * span**2 / 8.0
        # Misfit allowed: the noise, or 2 % of the pressure change across the window (a smooth
        # decline is never exactly straight).
        tol = max(2.0 * sig, 0.02 * abs(c1[0]) * span)
        # A decaying transient leaves its misfit at the window's first samples.
        head = float(np.max(np.abs(yw[:3] - np.polyval(c1, xw[:3]))))
        if rstd <= tol and bend <= tol and head <= 2.5 * tol and c1[0] <= 0.0:
            best = (d, L)
            break
    if best is None:
        return None
    d, L = best
    # The tail of a decaying transient hides in the noise a little before it is gone: keep a
    # margin of a quarter of the samples skipped.
    d = min(d + int(np.ceil(0.25 * d)), max(0, n - L))
    fit = fit_line(dt[d:d + L], p[d:d + L])
    return EarlyDecline(t_s, d, d + L - 1, fit, sig)


def pick_isip(record: Record, cycle: Cycle, *, window: tuple[float, float] | None = None) -> Pick:
    """Instantaneous shut-in pressure: the early decline line extrapolated to pump stop.

    After the pumps stop the pressure drops quickly (pipe friction, water hammer) and then
    declines smoothly. The ISIP is the intercept at shut-in time ``t_s`` of the straight line
    ``p = ISIP + s (t - t_s)`` fitted to the first stretch of smooth decline
    (:func:`early_decline`), i.e. where the record first departs from that tangent when
    going back in time -- not a single sample.

    The interval combines the intercept's standard error with the spread of the intercept when
    the window is shifted by -/+ a quarter of the skipped samples and shortened/lengthened by a
    third.

    Every cycle with a pump stop followed by a shut-in gets one, whatever its kind (XLOT,
    LOT, DFIT, step-rate test, stimulation, line or casing test): the stop is that of the
    injection, not of a later top-up (:func:`~xlotkit.interpret.picks.decline.stop_pump`).

    Parameters
    ----------
    window : (t0, t1), optional
        Elapsed-time window [s] of the early decline, overriding the automatic choice; it may
        reach past the end of the shut-in phase (the phases it crosses join the decline,
        :func:`~xlotkit.interpret.picks.decline.decline`).

    Returns
    -------
    Pick
        ``name="ISIP"``, ``method="tangent"``; details (:class:`~xlotkit.interpret.picks.
        details.IsipDetails`): slope [Pa/s], the drop from the last pumping pressure to the
        ISIP (``friction_drop``) [Pa].
    """
    dec = decline(record, cycle, window)
    if dec is None:
        return Pick.not_found("ISIP", "tangent", no_shutin_reason(cycle))
    t = record.t[dec.i0:dec.i1]
    p = record.pressure[dec.i0:dec.i1]
    t_s = dec.t_stop
    ed = early_decline(t, p, t_s, window=window)
    if ed is None:
        return Pick.not_found("ISIP", "tangent",
                              f"shut-in too short or too irregular ({t.size} samples)")
    dt = t - t_s
    value = ed.fit.intercept
    vals = [value]
    L = ed.j1 - ed.j0 + 1
    sh1 = max(1, ed.j0 // 4)
    # Admissible windows: shifted by a quarter of the skipped samples, shorter and longer,
    # and starting a third and two thirds of a window later (the tail of the pump-off drop
    # hides in the noise of the first window and lifts its intercept).
    for d0, LL in ((-sh1, L), (sh1, L), (0, max(MIN_LINE_POINTS, int(L * 2 / 3))),
                   (0, int(L * 4 / 3)), (max(1, L // 3), L), (max(2, 2 * L // 3), L)):
        a, b = max(0, ed.j0 + d0), max(0, ed.j0 + d0) + LL
        if b <= t.size and b - a >= 3:
            vals.append(fit_line(dt[a:b], p[a:b]).intercept)
    s = ed.fit.intercept_stderr if np.isfinite(ed.fit.intercept_stderr) else 0.0
    low, high = min(vals) - s, max(vals) + s
    # The decline is not straight back to pump stop (it curves as leak-off slows): a
    # parabola through the window, extrapolated, is the other admissible reading.
    a, b = ed.j0, ed.j1 + 1
    extra = []
    if b - a >= 8:
        c2 = np.polyfit(dt[a:b] - dt[a], p[a:b], 2)
        extra.append(("curvature", *sorted((value, float(np.polyval(c2, -dt[a]))))))
    # With Carter leak-off the decline is straight in Nolte's G rather than in time (it
    # is convex in time from pump stop on): the G line through the same window is the
    # third reading (G for alpha = 1, as the shut-in picks use).
    pumps_ = pump_phases(cycle)
    t_pump = max(t_s - pumps_[0].t_start, 1.0)
    if t_pump > 0 and b - a >= 3:
        d = np.clip(dt[a:b], 0.0, None) / t_pump
        G = 4.0 / np.pi * (4.0 / 3.0 * ((1.0 + d) ** 1.5 - d ** 1.5) - 4.0 / 3.0)
        if np.ptp(G) > 0:
            g_int = float(np.polyfit(G, p[a:b], 1)[1])
            extra.append(("G-function line", *sorted((value, g_int))))
    # A decline convex in G as well (leak-off faster at high pressure) falls fastest right
    # after pump stop, closer to linear in sqrt(time) there: that line bounds it from above.
    # Only a reading the window's data cannot reject counts: its misfit may exceed the time
    # line's by no more than the chi-square(1) 90 % quantile of the noise.
    if b - a >= 3 and np.ptp(dt[a:b]) > 0:
        st_ = np.sqrt(np.clip(dt[a:b], 0.0, None))
        cs = np.polyfit(st_, p[a:b], 1)
        sse_s = float(np.sum((p[a:b] - np.polyval(cs, st_)) ** 2))
        sse_l = float(np.sum((p[a:b] - ed.fit(dt[a:b])) ** 2))
        sig2 = max(ed.sigma ** 2, sse_l / max(b - a - 2, 1))
        if sse_s <= sse_l + 2.71 * sig2 * correlation_inflation(p[a:b] - ed.fit(dt[a:b])) ** 2:
            extra.append(("sqrt-time line", *sorted((value, float(cs[1])))))
    seg = p[a:b]
    bud = budget(value, stderr=s, inflation=correlation_inflation(seg - ed.fit(dt[a:b])),
                 trials=vals, resolution=0.5 * quantum(p), extra=extra)
    pump = dec.pump
    last_p = float(np.median(record.pressure[max(pump.i1 - 3, pump.i0):pump.i1]))
    details = IsipDetails(
        slope=float(ed.fit.slope), slope_stderr=float(ed.fit.slope_stderr),
        intercept_stderr=float(s), r2=float(ed.fit.r2), n=int(ed.fit.n), sigma=float(ed.sigma),
        t_shut_in=float(t_s), last_pumping_pressure=last_p, friction_drop=last_p - value,
        trial_values=tuple(float(v) for v in vals), skipped_samples=int(ed.j0),
        interval=bud, pump_window=(float(pump.t_start), float(pump.t_end)),
        data_window=(float(t[0]), float(t[-1])))
    msg = "; ".join(dec.notes)
    pumps = pump_phases(cycle)
    if pump is not pumps[-1]:
        later = [ph for ph in pumps if ph.t_start > pump.t_start]
        msg = "; ".join(x for x in (msg, f"at the stop of the injection at t = {t_s:.0f} s "
                                    f"(the {len(later)} later, smaller pump phase"
                                    f"{'s' if len(later) > 1 else ''} are top-ups)") if x)
    r2 = ed.fit.r2 if ed.fit.n >= 3 else 0.0
    q = quality(max(r2, 0.98 if ed.fit.residual_std <= 2 * ed.sigma else r2), value, low, high,
                ed.fit.n)
    return Pick("ISIP", "tangent", float(value), bud.low, bud.high, t=t_s,
                window=(float(t[ed.j0]), float(t[ed.j1])), quality=q, message=msg,
                details=details, level=bud.level)


def no_shutin_reason(cycle: Cycle) -> str:
    """Why a cycle has no pump stop followed by a shut-in, in words."""
    pumps = pump_phases(cycle)
    if not pumps:
        return "the cycle has no pump phase"
    kinds = [ph.kind for ph in cycle.phases]
    after = []
    for ph in pumps:
        k = next(j for j, q in enumerate(cycle.phases) if q is ph)
        after.append(kinds[k + 1] if k + 1 < len(kinds) else "the end of the cycle")
    what = ", ".join(sorted(set(a.replace("_", "-") for a in after)))
    return f"no shut-in after pumping: the pumps stopped into {what}"
