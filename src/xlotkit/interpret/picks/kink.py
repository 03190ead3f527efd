"""A kink of the decline against a smooth curve: closure the local break scan cannot resolve.

The break scan of :mod:`~xlotkit.interpret.picks.shutin` compares the slopes of short
windows (3-12 % of the decline's G range). On a whole-bar gauge with a small net pressure
those windows hold a few steps of the staircase, and on a decline curved by
pressure-dependent leak-off or height recession the slope trend between adjacent windows
is as large as the jump at closure: the scan then finds nothing although the change of
slope at closure is many standard errors when it is measured over the whole stretch of
decline on each side. This module measures it that way.

At a trial closure ``G*`` a window of half-width ``W`` (15, 25 and 35 % of the G range) is
fitted with a cubic in ``x = (G - G*) / W`` plus a hinge ``h max(x, 0)``:

* the cubic takes the smooth curvature an open-fracture decline has anyway (a
  pressure-dependent leak-off hump, height recession, a wall leak), so only a change of
  slope *at* ``G*`` is left to the hinge; the hinge's t-statistic ``|h| / se(h)`` must be at
  least :data:`KINK_Z`, its standard error from the residuals of the fit (floored at the
  quantisation error ``q / sqrt(12)``) inflated for their lag-1 autocorrelation
  (:func:`~xlotkit.interpret.picks.intervals.correlation_inflation`: the staircase of a
  whole-bar gauge along a slow decline, or a curve the model misses, is correlated);
* a kink must describe the data better than a smooth curve with as many parameters: the
  cubic-plus-hinge must lower the residual sum of squares of a quartic on the same window
  by at least :data:`KINK_LR` noise variances. A decline that bends smoothly and strongly
  (a wall leak's exponential approach to the reservoir pressure, the tail of the pump-off
  drop) is fitted by the quartic as well as by a hinge, and is no kink;
* the change is a closure's: at least :data:`~xlotkit.interpret.picks.shutin.
  MIN_SLOPE_CHANGE` of the slope before, and the decline falls on both sides;
* the window lies inside the analysed decline on both sides (at least
  :data:`MIN_SIDE_POINTS` samples each): the new slope is seen to last over ``W``.

Of the candidates the one whose kink is the best supported against the smooth curve (the
largest reduction of the quartic's residuals) is taken, over all positions and scales.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from xlotkit.interpret.picks.intervals import correlation_inflation

__all__ = ["KINK_LR", "KINK_SCALES", "KINK_Z", "Kink", "find_kink"]

#: Half-widths of the fitted window, as fractions of the decline's G range (wider than the
#: break scan's windows: the kink is judged against the stretch on each side).
KINK_SCALES = (0.15, 0.25, 0.35)

#: Smallest t-statistic of the hinge. The scan tries about a hundred positions per scale,
#: strongly correlated (neighbouring windows share most samples); at 4 standard errors a
#: white-noise decline passes one of a few tens of independent trials with probability
#: below 0.2 % (two-sided normal tail 6e-5 per trial).
KINK_Z = 4.0

#: Smallest reduction of the residual sum of squares, in noise variances, of the
#: cubic-plus-hinge below a quartic (the same number of parameters, smooth): the kink must
#: explain the data better than one more degree of smooth curvature by the chi-square(1)
#: value of three standard errors.
KINK_LR = 9.0

#: Fewest samples on each side of a trial kink inside its window.
MIN_SIDE_POINTS = 12

#: Trial positions per scale (evenly spread over the admissible samples).
_N_TRIALS = 120


@dataclass(frozen=True)
class Kink:
    """A kink of ``p(G)``: sample index ``i``, the window half-width ``w`` [G], the
    slopes ``s_before``/``s_after`` [Pa per unit G] either side, the hinge's t-statistic
    ``z`` and the residual reduction ``lr`` against the quartic [noise variances]."""

    i: int
    w: float
    s_before: float
    s_after: float
    z: float
    lr: float


def _design(x: np.ndarray, degree: int, hinge: bool) -> np.ndarray:
    cols = [x**k for k in range(degree + 1)]
    if hinge:
        cols.append(np.maximum(x, 0.0))
    return np.column_stack(cols)


def find_kink(G: np.ndarray, p: np.ndarray, q: float = 0.0, *,
              min_change: float = 0.1) -> Kink | None:
    """The best-supported kink of a declining ``p(G)`` (module docstring), or None.

    Parameters
    ----------
    G : ndarray, shape (n,)
        Nolte's G of the samples, increasing.
    p : ndarray, shape (n,)
        Pressures [Pa].
    q : float
        Quantisation step of ``p`` [Pa] (0: none).
    min_change : float
        Smallest ``|s_after - s_before| / |s_before|``.

    Returns
    -------
    Kink or None
    """
    G = np.asarray(G, float)
    p = np.asarray(p, float)
    n = G.size
    if n < 2 * MIN_SIDE_POINTS + 1:
        return None
    span = float(G[-1] - G[0])
    if not span > 0:
        return None
    floor = max(q / np.sqrt(12.0), 1e-7 * float(np.max(np.abs(p))))
    best: Kink | None = None
    for f in KINK_SCALES:
        W = f * span
        lo = int(np.searchsorted(G, G[0] + W))
        hi = int(np.searchsorted(G, G[-1] - W, "right"))
        if hi <= lo:
            continue
        for i in np.unique(np.linspace(lo, hi - 1, min(_N_TRIALS, hi - lo)).astype(int)):
            a = int(np.searchsorted(G, G[i] - W))
            b = int(np.searchsorted(G, G[i] + W, "right"))
            if i - a < MIN_SIDE_POINTS or b - i < MIN_SIDE_POINTS:
                continue
            x = (G[a:b] - G[i]) / W
            y = p[a:b]
            X = _design(x, 3, True)
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            h, sb = float(coef[-1]), float(coef[1])
            # A decline on both sides, changing its slope by enough to be closure.
            if not (sb < 0 and sb + h < 0 and abs(h) >= min_change * abs(sb)):
                continue
            r = y - X @ coef
            dof = max(y.size - X.shape[1], 1)
            s = max(float(np.sqrt(r @ r / dof)), floor) * correlation_inflation(r)
            se_h = s * float(np.sqrt(np.linalg.pinv(X.T @ X)[-1, -1]))
            z = abs(h) / se_h
            if z < KINK_Z:
                continue
            Xq = _design(x, 4, False)
            cq, *_ = np.linalg.lstsq(Xq, y, rcond=None)
            rq = y - Xq @ cq
            lr = (float(rq @ rq) - float(r @ r)) / s**2
            if lr < KINK_LR:
                continue
            if best is None or lr > best.lr:
                best = Kink(int(i), W, sb / W, (sb + h) / W, z, lr)
    return best
