"""Fit models for picks, in lmfit's style: model functions, models with ``guess``, results
that carry uncertainties.

Every straight-line method of XLOT interpretation (the pressurisation line, tangents on a
decline, sqrt(t) and G-function lines, the two flowback lines) reduces to one of two fits:

* a straight line, :class:`LineModel`: ``y = slope * x + intercept``;
* two straight lines meeting at a breakpoint, :class:`HingeModel`:
  ``y = y0 + s1 (x - x0)`` for ``x < x0`` and ``y = y0 + s2 (x - x0)`` for ``x >= x0``.

The breakpoint of a hinge fit (or the intersection of two independently fitted lines,
:func:`intersect`) is where the physics changes (leak-off, closure). Its standard error comes
from the fit covariance; pick functions add the spread over nearby windows on top
(:func:`window_spread`).
"""

from __future__ import annotations

from dataclasses import dataclass

import lmfit
import numpy as np

__all__ = [
    "HingeFit",
    "HingeModel",
    "LineFit",
    "LineModel",
    "fit_hinge",
    "fit_line",
    "hinge",
    "intersect",
    "line",
    "window_spread",
]


def line(x, slope=1.0, intercept=0.0):
    """Straight line ``y = slope * x + intercept``."""
    return slope * np.asarray(x, dtype=float) + intercept


def hinge(x, x0=0.0, y0=0.0, s1=1.0, s2=0.0):
    """Two lines joined at ``(x0, y0)``: slope ``s1`` left of ``x0``, ``s2`` right of it."""
    x = np.asarray(x, dtype=float)
    dx = x - x0
    return y0 + np.where(dx < 0.0, s1 * dx, s2 * dx)


class LineModel(lmfit.Model):
    """lmfit model of a straight line with a least-squares ``guess``."""

    def __init__(self, **kwargs):
        super().__init__(line, **kwargs)

    def guess(self, data, x, **kwargs):
        """Parameters from an ordinary least-squares line through ``(x, data)``."""
        slope, intercept = np.polyfit(np.asarray(x, float), np.asarray(data, float), 1)
        return self.make_params(slope=slope, intercept=intercept)


def _two_segment_sse(x: np.ndarray, y: np.ndarray, k: int) -> float:
    """Sum of squared residuals of independent lines through x[:k] and x[k:]."""
    sse = 0.0
    for xs, ys in ((x[:k], y[:k]), (x[k:], y[k:])):
        a = np.vstack([xs, np.ones_like(xs)]).T
        _, res, _, _ = np.linalg.lstsq(a, ys, rcond=None)
        sse += float(res[0]) if res.size else 0.0
    return sse


class HingeModel(lmfit.Model):
    """lmfit model of two lines meeting at a breakpoint, with a grid-search ``guess``.

    The guess scans every admissible split of the data (each side keeps at least
    ``min_points``), fits two independent lines and starts from the best split; the
    nonlinear fit then refines the breakpoint continuously.
    """

    def __init__(self, min_points: int = 3, **kwargs):
        self.min_points = int(min_points)
        super().__init__(hinge, **kwargs)

    def guess(self, data, x, **kwargs):
        """Parameters from the best two-segment split of ``(x, data)``."""
        x = np.asarray(x, float)
        y = np.asarray(data, float)
        order = np.argsort(x)
        x, y = x[order], y[order]
        m = self.min_points
        n = x.size
        if n < 2 * m:
            raise ValueError(f"hinge fit needs at least {2 * m} points, got {n}")
        # Coarse scan first so long windows stay cheap, then refine around the best split.
        ks = np.unique(np.linspace(m, n - m, min(n - 2 * m + 1, 200)).astype(int))
        sse = np.array([_two_segment_sse(x, y, k) for k in ks])
        kbest = int(ks[np.argmin(sse)])
        lo, hi = max(m, kbest - 5), min(n - m, kbest + 5)
        fine = np.arange(lo, hi + 1)
        kbest = int(fine[np.argmin([_two_segment_sse(x, y, k) for k in fine])])
        s1, c1 = np.polyfit(x[:kbest], y[:kbest], 1)
        s2, c2 = np.polyfit(x[kbest:], y[kbest:], 1)
        if not np.isclose(s1, s2):
            x0 = (c2 - c1) / (s1 - s2)
        else:
            x0 = 0.5 * (x[kbest - 1] + x[kbest])
        if not (x[0] < x0 < x[-1]):
            x0 = 0.5 * (x[kbest - 1] + x[kbest])
        params = self.make_params(x0=x0, y0=s1 * x0 + c1, s1=s1, s2=s2)
        params["x0"].set(min=float(x[m - 1]), max=float(x[n - m]))
        return params


@dataclass(frozen=True)
class LineFit:
    """A fitted straight line with its uncertainty.

    Attributes
    ----------
    slope, intercept : float
        Best fit.
    slope_stderr, intercept_stderr : float
        One-sigma standard errors.
    covariance : ndarray, shape (2, 2)
        Covariance of (slope, intercept).
    r2 : float
        Coefficient of determination.
    residual_std : float
        Standard deviation of the residuals (same units as y).
    n : int
        Number of points.
    x_range : tuple of float
        Smallest and largest x fitted.
    """

    slope: float
    intercept: float
    slope_stderr: float
    intercept_stderr: float
    covariance: np.ndarray
    r2: float
    residual_std: float
    n: int
    x_range: tuple[float, float]

    def __call__(self, x):
        """Evaluate the line at ``x``."""
        return line(x, self.slope, self.intercept)

    def report(self) -> str:
        """One-line text report."""
        return (f"line: slope={self.slope:.6g}±{self.slope_stderr:.2g}, "
                f"intercept={self.intercept:.6g}±{self.intercept_stderr:.2g}, "
                f"R²={self.r2:.5f}, n={self.n}")


@dataclass(frozen=True)
class HingeFit:
    """A fitted two-line (hinge) model with its uncertainty.

    Attributes
    ----------
    x0, y0 : float
        Breakpoint.
    s1, s2 : float
        Slopes before and after the breakpoint.
    x0_stderr, y0_stderr, s1_stderr, s2_stderr : float
        One-sigma standard errors (NaN when the covariance could not be estimated).
    r2 : float
        Coefficient of determination.
    residual_std : float
        Standard deviation of the residuals.
    n : int
        Number of points.
    result : lmfit.model.ModelResult
        The underlying lmfit result (``result.fit_report()`` for the full report).
    """

    x0: float
    y0: float
    s1: float
    s2: float
    x0_stderr: float
    y0_stderr: float
    s1_stderr: float
    s2_stderr: float
    r2: float
    residual_std: float
    n: int
    result: object

    def __call__(self, x):
        """Evaluate the fitted hinge at ``x``."""
        return hinge(x, self.x0, self.y0, self.s1, self.s2)

    def report(self) -> str:
        """The lmfit fit report."""
        return self.result.fit_report()


def _r2(y: np.ndarray, resid: np.ndarray) -> float:
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    return 1.0 - float(np.sum(resid**2)) / ss_tot if ss_tot > 0 else 1.0


def fit_line(x, y, weights=None) -> LineFit:
    """Least-squares straight line through ``(x, y)``.

    Parameters
    ----------
    x, y : array_like, shape (n,)
        Data, n >= 3.
    weights : array_like, shape (n,), optional
        Weights (1/sigma).

    Returns
    -------
    LineFit
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.size < 3:
        raise ValueError(f"line fit needs at least 3 points, got {x.size}")
    model = LineModel()
    res = model.fit(y, model.guess(y, x), x=x, weights=weights)
    cov = res.covar if res.covar is not None else np.full((2, 2), np.nan)
    resid = y - res.best_fit
    p = res.params
    return LineFit(
        slope=float(p["slope"].value),
        intercept=float(p["intercept"].value),
        slope_stderr=float(p["slope"].stderr) if p["slope"].stderr is not None else np.nan,
        intercept_stderr=(float(p["intercept"].stderr)
                          if p["intercept"].stderr is not None else np.nan),
        covariance=np.asarray(cov, float),
        r2=_r2(y, resid),
        residual_std=float(np.std(resid, ddof=2)) if x.size > 2 else 0.0,
        n=int(x.size),
        x_range=(float(x.min()), float(x.max())),
    )


def fit_hinge(x, y, *, min_points: int = 3, weights=None) -> HingeFit:
    """Fit two lines meeting at a breakpoint (continuous piecewise-linear).

    Parameters
    ----------
    x, y : array_like, shape (n,)
        Data, n >= 2 * min_points.
    min_points : int
        Fewest points allowed on each side of the breakpoint.
    weights : array_like, optional
        Weights (1/sigma).

    Returns
    -------
    HingeFit
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    model = HingeModel(min_points=min_points)
    params = model.guess(y, x)
    res = model.fit(y, params, x=x, weights=weights)
    p = res.params

    def se(name: str) -> float:
        v = p[name].stderr
        return float(v) if v is not None else np.nan

    resid = y - res.best_fit
    return HingeFit(
        x0=float(p["x0"].value), y0=float(p["y0"].value),
        s1=float(p["s1"].value), s2=float(p["s2"].value),
        x0_stderr=se("x0"), y0_stderr=se("y0"), s1_stderr=se("s1"), s2_stderr=se("s2"),
        r2=_r2(y, resid),
        residual_std=float(np.std(resid, ddof=4)) if x.size > 4 else 0.0,
        n=int(x.size), result=res,
    )


def intersect(a: LineFit, b: LineFit) -> tuple[float, float, float, float]:
    """Intersection of two independently fitted lines, with propagated standard errors.

    The lines ``y = s_a x + c_a`` and ``y = s_b x + c_b`` meet at
    ``x* = (c_b - c_a) / (s_a - s_b)``, ``y* = s_a x* + c_a``. Errors are propagated to first
    order from each fit's covariance (the two fits are independent).

    Returns
    -------
    x, x_stderr, y, y_stderr : float
        NaN where the lines are parallel.
    """
    ds = a.slope - b.slope
    if ds == 0 or not np.isfinite(ds):
        return np.nan, np.nan, np.nan, np.nan
    x = (b.intercept - a.intercept) / ds
    y = a.slope * x + a.intercept
    # Gradients of x* and y* with respect to (s_a, c_a) and (s_b, c_b).
    dx_a = np.array([-x / ds, -1.0 / ds])
    dx_b = np.array([x / ds, 1.0 / ds])
    dy_a = a.slope * dx_a + np.array([x, 1.0])
    dy_b = a.slope * dx_b
    ca = np.nan_to_num(a.covariance)
    cb = np.nan_to_num(b.covariance)
    vx = dx_a @ ca @ dx_a + dx_b @ cb @ dx_b
    vy = dy_a @ ca @ dy_a + dy_b @ cb @ dy_b
    return float(x), float(np.sqrt(max(vx, 0.0))), float(y), float(np.sqrt(max(vy, 0.0)))


def window_spread(values) -> tuple[float, float]:
    """Lowest and highest finite value of a pick repeated over nearby windows.

    Parameters
    ----------
    values : array_like
        The pick's value for each trial window (NaN for windows where it failed).

    Returns
    -------
    low, high : float
        NaN, NaN when no window gave a value.
    """
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return np.nan, np.nan
    return float(v.min()), float(v.max())
