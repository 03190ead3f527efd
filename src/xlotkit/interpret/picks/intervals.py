r"""Intervals that state their level: what a pick's ``[low, high]`` is made of.

Every pick of a characteristic pressure comes with an interval meant to contain the true
value with a stated nominal probability, :data:`LEVEL` (90 %). The regression error of
the lines a method draws is only one part of that; the interval is the union of

* **the statistical error** of the fit, ``z sigma`` with ``z`` the two-sided normal
  quantile of the level (1.645 for 90 %), the standard error inflated for residuals that
  are correlated from sample to sample (a smooth misfit, a pressure staircase from a
  quantised gauge): the effective number of independent samples is
  ``n (1 - rho) / (1 + rho)`` for a lag-1 autocorrelation ``rho`` of the residuals
  (:func:`correlation_inflation`);
* **the spread over admissible windows**: the same method with shorter and longer fits,
  margins and starting points (every variant the method itself would accept);
* **the transition**: where a physical change (closure, leak-off, reopening) is gradual,
  the span of pressure over which the data departs from *both* fitted lines by more than
  the noise (:func:`transition_span`, :func:`find_transition`) -- the change happens
  somewhere in there, and the lines' intersection only marks its middle on clean data;
  and, where the noise would hide such a span, the range of the corner over every bend
  width the data cannot rule out (:func:`corner_profile`);
* **the gauge's resolution**: half the quantisation step of the recorded pressure (the
  value of a sample is known to no better than that; for a pick read from one or two
  samples it is the limit), and where the pick is a point in time, the pressure change
  over half a sample interval.

The statistical part and the resolution add in quadrature (independent, random); the
window spread and the transition are ranges (systematic: the truth lies somewhere in them)
and are covered whole. :class:`IntervalBudget` keeps each part so reports can say what
made an interval wide. The level is checked, not assumed: ``benchmarks/
interval_calibration.py`` measures the coverage on hundreds of constructed records with a
known truth (``docs/intervals.md``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

__all__ = [
    "LEVEL",
    "TRACE_FRACTION",
    "IntervalBudget",
    "budget",
    "corner_profile",
    "correlation_inflation",
    "find_transition",
    "onset_profile",
    "transition_span",
    "z_value",
]

#: Nominal level of every calibrated pick interval.
LEVEL = 0.90


def z_value(level: float = LEVEL) -> float:
    """Two-sided normal quantile of ``level`` (1.645 for 0.90)."""
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    return float(norm.ppf(0.5 + 0.5 * level))


def correlation_inflation(resid, max_rho: float = 0.95) -> float:
    """Factor by which serially correlated residuals inflate a least-squares standard error.

    With lag-1 autocorrelation ``rho`` (AR(1) residuals) the effective number of
    independent samples is ``n (1 - rho) / (1 + rho)``, so the standard error grows by
    ``sqrt((1 + rho) / (1 - rho))``. Negative ``rho`` (anticorrelated noise) gives 1: the
    nominal error is kept rather than shrunk.

    Parameters
    ----------
    resid : array_like
        Residuals of a fit, in sample order.
    max_rho : float
        Cap on ``rho`` (a residual that is one smooth curve would give infinity).

    Returns
    -------
    float
        >= 1.
    """
    r = np.asarray(resid, float)
    r = r[np.isfinite(r)]
    if r.size < 4:
        return 1.0
    r = r - r.mean()
    den = float(np.dot(r, r))
    if den <= 0:
        return 1.0
    rho = float(np.dot(r[1:], r[:-1])) / den
    rho = min(max(rho, 0.0), max_rho)
    return math.sqrt((1.0 + rho) / (1.0 - rho))


#: Where a departure run found at three noise levels ends, as a fraction of the detection
#: threshold: the run is traced out while the departure stays above one noise level of the
#: average (:func:`transition_span`).
TRACE_FRACTION = 1.0 / 3.0


def transition_span(pressure, res_a, res_b, i_break: int, threshold: float, *,
                    smooth: int = 5, bounds: tuple[int, int] | None = None,
                    correlation: float = 1.0,
                    trace: float = TRACE_FRACTION) -> tuple[float, float, int, int] | None:
    """Pressure span where the data leaves both fitted lines: a gradual change's extent.

    Parameters
    ----------
    pressure : array_like, shape (n,)
        Pressures [Pa] of the samples, in time order.
    res_a, res_b : array_like, shape (n,)
        Residuals of the samples against the line before and the line after the change (in
        the units of the plot the lines live on).
    i_break : int
        Index of the sample nearest the lines' intersection.
    threshold : float
        One noise level of the residuals (same units); a sample departs from a line when
        its residual, averaged over ``smooth`` neighbours, exceeds
        ``3 threshold c / sqrt(smooth)`` -- three times the noise of the average (white
        noise alone does so at 0.3 % of the samples), with ``c`` the correlation inflation
        (``correlation``), at most ``3 threshold``.
    smooth : int
        Samples in the centred running mean applied to the residuals.
    correlation : float
        :func:`correlation_inflation` of the residuals: averaging correlated noise (a
        quantised staircase) reduces it less than ``sqrt(smooth)``.
    bounds : (int, int), optional
        Inclusive index range the run may occupy: the gap the method leaves between the
        windows of its two lines (with ``smooth`` samples into each). Beyond it a departure
        from a line is the curvature of the decline that the line's own window holds, not
        the change between the lines.
    trace : float
        Fraction of the detection threshold down to which a run, once found, is traced out
        (hysteresis thresholding): three noise levels decide that a gradual change exists,
        but a departure that grows from zero crosses them only some way into the change, so
        its ends lie where the departure falls back to one noise level of the average
        (``trace = 1/3``). 0 keeps the run at the detection threshold.

    Returns
    -------
    (p_low, p_high, i0, i1) or None
        The lowest and highest pressure of the contiguous run of samples departing from
        both lines around ``i_break`` (inclusive indices ``i0..i1``, the run of the averaged
        residuals trimmed by the average's half-length); None when no sample near the
        break departs from both (a sharp change, or one hidden in the noise).
    """
    p = np.asarray(pressure, float)
    ra, rb = np.asarray(res_a, float), np.asarray(res_b, float)
    n = p.size
    if n < 3 or not (0 <= i_break < n) or not threshold > 0:
        return None
    k = max(1, int(smooth))
    ker = np.ones(k) / k
    sa = np.abs(np.convolve(ra, ker, mode="same"))
    sb = np.abs(np.convolve(rb, ker, mode="same"))
    thr = 3.0 * threshold * min(max(correlation, 1.0) / math.sqrt(k), 1.0)
    both = (sa > thr) & (sb > thr)
    if bounds is not None:
        b0, b1 = max(int(bounds[0]) - k, 0), min(int(bounds[1]) + k, n - 1)
        both[:b0] = False
        both[b1 + 1:] = False
    if not both.any():
        return None
    # The run containing the break, or the nearest one within `smooth` samples of it.
    idx = np.flatnonzero(both)
    j = int(idx[np.argmin(np.abs(idx - i_break))])
    if abs(j - i_break) > k:
        return None
    i0 = j
    while i0 > 0 and both[i0 - 1]:
        i0 -= 1
    i1 = j
    while i1 < n - 1 and both[i1 + 1]:
        i1 += 1
    if trace > 0:
        # Traced out while the samples still leave both lines by one noise level: the
        # detection threshold places the ends of a gradual departure inside the change.
        low = (sa > thr * trace) & (sb > thr * trace)
        if bounds is not None:
            low[:b0] = False
            low[b1 + 1:] = False
        while i0 > 0 and low[i0 - 1]:
            i0 -= 1
        while i1 < n - 1 and low[i1 + 1]:
            i1 += 1
    # The running mean spreads a departure by (smooth - 1) / 2 samples each way: a sharp
    # kink leaves a run of fewer than `smooth` samples (the average straddling it), a gradual
    # change a longer one, trimmed back to where the samples themselves depart.
    h = (k - 1) // 2
    if i1 - i0 + 1 < k:
        return None
    i0, i1 = i0 + h, i1 - h
    seg = p[i0:i1 + 1]
    return float(np.min(seg)), float(np.max(seg)), i0, i1


def _line(x, y):
    if x.size < 3 or np.ptp(x) <= 0:
        return None
    a, b = np.polyfit(x, y, 1)
    return a, b


def find_transition(u, x, y, pressure, u0: float, left: float, right: float, *,
                    noise: float, smooth: int = 5, gap: float = 0.05, window: float = 0.3,
                    max_gap: float = 0.35) -> tuple[float, float, float, float] | None:
    """The extent of a gradual change around a break, found self-consistently.

    Two tangents are fitted close to the break -- on ``y(x)`` over the ``window`` fraction
    of each side next to a gap left around it -- and the samples that leave both by more
    than the noise are found (:func:`transition_span`, restricted to the gap). When that
    run reaches the gap's edge, the change is wider than the gap: the gap is widened to
    the run and the tangents refitted outside it, until the run stays inside the gap or the
    gap reaches ``max_gap`` of a side. So the lines are never fitted on the change they
    bracket, and a curvature of the decline far from the break is not taken for it.

    Parameters
    ----------
    u : array_like, shape (n,)
        Ordering variable (time, increasing) in which the sides are measured.
    x, y : array_like, shape (n,)
        The plot the method draws its two lines on.
    pressure : array_like, shape (n,)
        Pressure of each sample [Pa] (what the span is reported in).
    u0 : float
        The break, in ``u``.
    left, right : float
        Lengths in ``u`` of the data the method uses before and after the break.
    noise : float
        One noise level of ``y`` (floored by the tangents' residual scatter in their
        windows).

    Returns
    -------
    (p_low, p_high, u_start, u_end) or None
        Pressure span and where it lies in ``u``; None when no sample near the break leaves
        both tangents (a sharp change, or one hidden in the noise).
    """
    u = np.asarray(u, float)
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    p = np.asarray(pressure, float)
    if u.size < 8 or not (left > 0 and right > 0) or not noise > 0:
        return None
    gl, gr = gap * left, gap * right
    found = None
    for _ in range(6):
        ma = (u >= u0 - gl - window * left) & (u < u0 - gl)
        mb = (u > u0 + gr) & (u <= u0 + gr + window * right)
        la, lb = _line(x[ma], y[ma]), _line(x[mb], y[mb])
        if la is None or lb is None:
            break
        ra = y - (la[0] * x + la[1])
        rb = y - (lb[0] * x + lb[1])
        # A departure smaller than the tangents' own misfit in their windows (the curvature
        # of the decline there) is not beyond the noise.
        nz = max(noise, float(np.std(ra[ma])), float(np.std(rb[mb])))
        inside = np.flatnonzero((u >= u0 - gl) & (u <= u0 + gr))
        if inside.size == 0:
            i_b = int(np.argmin(np.abs(u - u0)))
            bounds = (i_b, i_b)
        else:
            i_b = int(inside[np.argmin(np.abs(u[inside] - u0))])
            bounds = (int(inside[0]), int(inside[-1]))
        corr = max(correlation_inflation(ra[ma]), correlation_inflation(rb[mb]))
        span = transition_span(p, ra, rb, i_b, nz, smooth=smooth, bounds=bounds,
                               correlation=corr)
        if span is None:
            return found
        found = (span[0], span[1], float(u[span[2]]), float(u[span[3]]))
        reach_l = span[2] <= bounds[0]
        reach_r = span[3] >= bounds[1]
        if not (reach_l or reach_r):
            return found
        grew = False
        if reach_l and gl < max_gap * left:
            gl = min(max(u0 - float(u[span[2]]), gl) * 1.5, max_gap * left)
            grew = True
        if reach_r and gr < max_gap * right:
            gr = min(max(float(u[span[3]]) - u0, gr) * 1.5, max_gap * right)
            grew = True
        if not grew:
            return found
    return found


def corner_profile(x, y, x0: float, half_width: float, *, level: float = LEVEL,
                   inflation: float = 1.0, n_x0: int = 41, n_c: int = 14,
                   max_bend: float = 0.5) -> tuple[float, float, float, float] | None:
    """Profile-likelihood interval of the corner of two lines joined by a smooth bend.

    The data near a break are fitted with the smooth hinge
    ``y = a + b (x - x0) + d sqrt((x - x0)^2 + c^2)``: two asymptotes
    ``y = a + (b -/+ d)(x - x0)`` that meet at ``(x0, a)``, joined by a bend of width
    ``~2c`` (``c = 0`` is the sharp hinge). For fixed ``(x0, c)`` the model is linear in
    ``(a, b, d)``; over a grid of ``x0`` (``x0 -/+ half_width``) and ``c`` (0 and up to
    ``max_bend half_width``: at least part of each side of the window lies on its
    asymptote, else the lines are not measured at all) the residual sum of squares
    ``SSE(x0, c)`` and the least-squares
    corner ``a(x0, c)`` with its unit variance ``v = [(X^T X)^-1]_aa`` are computed. The
    interval is every corner value ``a`` with
    ``min over (x0, c) of SSE(x0, c, a) <= SSE_min + chi2_1(level) s^2``, i.e. the union of
    ``a(x0, c) -/+ sqrt(v (SSE_lim - SSE(x0, c)))``, with ``s^2 = SSE_min / (n - 5)``
    inflated by ``inflation^2`` for correlated residuals.

    So the interval of the corner accounts for not knowing how gradual the change is: a
    bend the data cannot resolve leaves many ``(x0, c)`` inside the limit and the interval
    wide; a sharp, well-sampled corner leaves it at the fit's error.

    Parameters
    ----------
    x, y : array_like
        Data around the break (the window the method fits).
    x0 : float
        The method's break.
    half_width : float
        Search range of the corner and largest bend half-width ``c`` (units of ``x``).
    level : float
        Nominal level.
    inflation : float
        Correlation inflation of the residual standard error.

    Returns
    -------
    (low, high, c_best, c_max) or None
        The corner's interval (units of ``y``), the best bend half-width and the largest one
        inside the limit; None with fewer than 8 points.
    """
    from scipy.stats import chi2

    x = np.asarray(x, float)
    y = np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    n = x.size
    if n < 8 or not half_width > 0:
        return None
    # Scale for conditioning.
    xs = max(abs(half_width), 1e-300)
    u = (x - x0) / xs
    ym = float(np.mean(y))
    yy = y - ym
    g0 = np.linspace(-1.0, 1.0, n_x0)
    gc = np.concatenate([[0.0], np.geomspace(0.01, 1.0, n_c - 1)]) * max_bend
    res = []
    for a0 in g0:
        du = u - a0
        for c in gc:
            X = np.column_stack([np.ones(n), du, np.sqrt(du * du + c * c)])
            XtX = X.T @ X
            try:
                inv = np.linalg.inv(XtX)
            except np.linalg.LinAlgError:
                continue
            coef = inv @ (X.T @ yy)
            r = yy - X @ coef
            res.append((float(r @ r), float(coef[0]), float(inv[0, 0]), c))
    if not res:
        return None
    arr = np.array(res)
    sse_min = float(arr[:, 0].min())
    s2 = sse_min / max(n - 5, 1) * max(inflation, 1.0) ** 2
    if not s2 > 0:
        s2 = 1e-30 * max(float(np.var(y)), 1e-300)
    lim = sse_min + float(chi2.ppf(level, 1)) * s2
    inside = arr[:, 0] <= lim
    half = np.sqrt(np.clip((lim - arr[inside, 0]) * arr[inside, 2], 0.0, None))
    a = arr[inside, 1]
    best = int(np.argmin(arr[:, 0]))
    return (float(np.min(a - half)) + ym, float(np.max(a + half)) + ym,
            float(arr[best, 3]) * xs, float(np.max(arr[inside, 3])) * xs)


def onset_profile(x, y, side: int, *, level: float = LEVEL, inflation: float = 1.0,
                  powers=(1.0, 1.5, 2.0, 3.0), n_x0: int = 60
                  ) -> tuple[float, float, float, float] | None:
    """Profile-likelihood interval of where a curve starts to leave a straight line.

    The data (a straight stretch followed by the departure) are fitted with
    ``y = c0 + c1 x + side c2 (x - x0)_+^k``, ``c2 >= 0``: a line, and from ``x0`` on a
    departure growing as a power ``k`` (1 a kink, 2 a gradual, parabolic bend). For each
    ``x0`` on a grid over the data and each ``k`` the model is linear in ``(c0, c1, c2)``.
    Every onset whose best misfit stays within ``SSE_min + chi2_1(level) s^2`` (``s^2``
    from ``SSE_min``, inflated for correlated residuals) is admissible, and the interval
    is the range of the line's value ``c0 + c1 x0`` at those onsets. A first departure
    that grows slowly is detected late; this interval reaches back to where it may have
    begun.

    Parameters
    ----------
    x, y : array_like
        The stretch and the departure, ``x`` increasing.
    side : {-1, +1}
        Whether the curve leaves below (-1) or above (+1) the line.

    Returns
    -------
    (value_low, value_high, x0_low, x0_high) or None
    """
    from scipy.stats import chi2

    x = np.asarray(x, float)
    y = np.asarray(y, float)
    n = x.size
    if n < 8 or np.ptp(x) <= 0:
        return None
    xm, xs = float(x.mean()), float(np.ptp(x))
    u = (x - xm) / xs
    ym = float(y.mean())
    yy = y - ym
    grid = np.linspace(u[2], u[-3], n_x0)
    rows = []
    for k in powers:
        for u0 in grid:
            f = side * np.clip(u - u0, 0.0, None) ** k
            X = np.column_stack([np.ones(n), u, f])
            coef, *_ = np.linalg.lstsq(X, yy, rcond=None)
            if coef[2] < 0:
                coef, *_ = np.linalg.lstsq(X[:, :2], yy, rcond=None)
                coef = np.array([coef[0], coef[1], 0.0])
            r = yy - X @ coef
            rows.append((float(r @ r), float(coef[0] + coef[1] * u0) + ym, u0))
    arr = np.array(rows)
    sse_min = float(arr[:, 0].min())
    s2 = max(sse_min / max(n - 4, 1), 1e-300) * max(inflation, 1.0) ** 2
    inside = arr[:, 0] <= sse_min + float(chi2.ppf(level, 1)) * s2
    v, u0 = arr[inside, 1], arr[inside, 2]
    # The grid resolves the onset to one step: widen by a step along the line.
    step = float(grid[1] - grid[0])
    i_lo, i_hi = int(np.argmin(u0)), int(np.argmax(u0))
    dv = 0.0
    if u0[i_hi] > u0[i_lo]:
        dv = abs(float(v[i_hi] - v[i_lo]) / float(u0[i_hi] - u0[i_lo])) * step
    else:
        c = np.polyfit(u, yy, 1)
        dv = abs(float(c[0])) * step
    return (float(v.min()) - dv, float(v.max()) + dv,
            float((u0.min() - step) * xs + xm), float((u0.max() + step) * xs + xm))


@dataclass(frozen=True)
class IntervalBudget:
    """What a pick's interval is made of (all [Pa]).

    Attributes
    ----------
    level : float
        Nominal coverage of ``[low, high]``.
    value : float
        The pick.
    statistical : float
        Half-width of the statistical part at ``level`` (``z`` times the inflated
        standard error).
    windows : tuple of float
        Lowest and highest value over the admissible windows (``value`` included).
    transition : tuple of float or None
        Pressure span of a gradual change (:func:`transition_span`), or None.
    resolution : float
        Half-width from the gauge's resolution and the sampling.
    extra : tuple of (str, float, float)
        Further ranges covered whole, each named (e.g. the methods' disagreement of a
        consensus), as (name, low, high).
    low, high : float
        The interval.
    """

    level: float
    value: float
    statistical: float
    windows: tuple[float, float]
    transition: tuple[float, float] | None
    resolution: float
    extra: tuple[tuple[str, float, float], ...]
    low: float
    high: float

    def describe(self) -> str:
        """One line, in bar: what made the interval."""
        b = 1e5
        parts = [f"{100 * self.level:.0f} % interval {self.low / b:.2f}-{self.high / b:.2f} bar:",
                 f"fit ±{self.statistical / b:.2f}",
                 f"windows {self.windows[0] / b:.2f}-{self.windows[1] / b:.2f}"]
        if self.transition is not None:
            parts.append(f"transition {self.transition[0] / b:.2f}-{self.transition[1] / b:.2f}")
        parts.append(f"resolution ±{self.resolution / b:.2f}")
        for name, lo, hi in self.extra:
            parts.append(f"{name} {lo / b:.2f}-{hi / b:.2f}")
        return " ".join(parts[:1]) + " " + ", ".join(parts[1:])

    def to_dict(self) -> dict:
        """Plain numbers [Pa] for JSON."""
        return {"level": self.level, "value": self.value, "statistical": self.statistical,
                "windows": list(self.windows),
                "transition": None if self.transition is None else list(self.transition),
                "resolution": self.resolution,
                "extra": [{"name": n, "low": lo, "high": hi} for n, lo, hi in self.extra],
                "low": self.low, "high": self.high}


def budget(value: float, *, stderr: float = 0.0, inflation: float = 1.0,
           trials: Iterable[float] = (), transition: tuple[float, float] | None = None,
           resolution: float = 0.0, extra: Iterable[tuple[str, float, float]] = (),
           level: float = LEVEL) -> IntervalBudget:
    """Combine the parts of an interval (module docstring).

    Parameters
    ----------
    value : float
        The pick [Pa].
    stderr : float
        One-sigma standard error of the value from the fit [Pa] (NaN counts as 0).
    inflation : float
        Correlation inflation of the standard error (:func:`correlation_inflation`).
    trials : iterable of float
        The value over the admissible windows (non-finite entries ignored).
    transition : (float, float), optional
        Pressure span of a gradual change.
    resolution : float
        Half-width from the gauge resolution and sampling [Pa].
    extra : iterable of (name, low, high)
        Further ranges to cover whole.
    level : float
        Nominal level.

    Returns
    -------
    IntervalBudget
    """
    se = float(stderr) if stderr is not None and math.isfinite(stderr) else 0.0
    stat = z_value(level) * abs(se) * max(float(inflation), 1.0)
    vals = [float(value)] + [float(v) for v in trials if v is not None and math.isfinite(v)]
    w = (min(vals), max(vals))
    lo, hi = w
    if transition is not None:
        lo, hi = min(lo, transition[0]), max(hi, transition[1])
    ex = tuple((str(n), float(a), float(b)) for n, a, b in extra)
    for _, a, b in ex:
        lo, hi = min(lo, a), max(hi, b)
    e = math.hypot(stat, float(resolution))
    return IntervalBudget(level, float(value), stat, w, transition, float(resolution), ex,
                          lo - e, hi + e)
