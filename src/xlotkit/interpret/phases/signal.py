"""Signal helpers of the segmentation: runs of a mask, running medians, slopes, noise.

Every window here is counted in samples, never in seconds: the record's own clock
resolution is the unit, so a log whose time axis is rescaled (the same samples, another
unit or a faster test) is processed identically.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "bridge",
    "cum_positive",
    "cum_rate",
    "drop_short",
    "hysteresis",
    "noise_level",
    "odd",
    "roughness",
    "running_median",
    "runs",
    "slope",
    "step_drops",
    "zigzag",
]


def odd(n: float) -> int:
    """``n`` rounded to an odd integer >= 1."""
    k = max(1, int(round(n)))
    return k if k % 2 else k + 1


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges ``[i0, i1)`` of the True runs of ``mask``."""
    m = np.concatenate(([False], np.asarray(mask, bool), [False]))
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(d[::2], d[1::2])]


def bridge(mask: np.ndarray, gap: int) -> np.ndarray:
    """Fill interior False gaps of at most ``gap`` samples."""
    out = np.asarray(mask, bool).copy()
    for a, b in runs(~out):
        if a > 0 and b < out.size and b - a <= gap:
            out[a:b] = True
    return out


def drop_short(mask: np.ndarray, shortest: int) -> np.ndarray:
    """Remove True runs of fewer than ``shortest`` samples."""
    out = np.asarray(mask, bool).copy()
    for a, b in runs(out):
        if b - a < shortest:
            out[a:b] = False
    return out


def hysteresis(x: np.ndarray, on: float, off: float) -> np.ndarray:
    """True from where ``x`` exceeds ``on`` until it falls below ``off``."""
    out = np.zeros(x.size, bool)
    state = False
    for i, v in enumerate(x):
        state = v >= off if state else v > on
        out[i] = state
    return out


def running_median(x: np.ndarray, n: int) -> np.ndarray:
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


def slope(t: np.ndarray, y: np.ndarray, half: int) -> np.ndarray:
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


def cum_positive(x: np.ndarray) -> np.ndarray:
    """Running sum of the positive increments of ``x`` (totaliser resets contribute 0)."""
    x = np.nan_to_num(np.asarray(x, float))
    d = np.diff(x, prepend=x[:1])
    return np.cumsum(np.clip(d, 0.0, None))


def cum_rate(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Cumulative trapezoidal integral of a rate [m^3/s] -> [m^3] (negative rates as 0)."""
    q = np.clip(np.nan_to_num(q), 0.0, None)
    out = np.zeros(q.size)
    if q.size > 1:
        out[1:] = np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(t))
    return out


def noise_level(p: np.ndarray) -> float:
    """Standard deviation of the sample-to-sample noise of ``p`` [same unit].

    From the median absolute deviation of the first differences (white noise of standard
    deviation ``s`` gives differences of standard deviation ``s sqrt(2)``; the MAD of a
    normal variable is 0.6745 of its standard deviation), so steps, ramps and the few
    samples of a pump stop do not count. A quantised gauge that reads the same value most of
    the time has a MAD of 0: its noise is then the rounding noise of its resolution (the
    smallest non-zero step), ``q / sqrt(12)``. 0 only for a constant record.
    """
    d = np.diff(np.asarray(p, float))
    d = d[np.isfinite(d)]
    if d.size == 0:
        return 0.0
    mad = float(np.median(np.abs(d - np.median(d))))
    if mad > 0:
        return mad / 0.6745 / np.sqrt(2.0)
    nz = np.abs(d[d != 0])
    return float(np.min(nz)) / np.sqrt(12.0) if nz.size else 0.0


def zigzag(y: np.ndarray, threshold: float) -> list[int]:
    """Turning points of ``y`` that reverse by at least ``threshold``.

    Scanning from the start, a running extreme becomes a turning point once ``y`` has moved
    ``threshold`` back from it (on a flat top or bottom, its last sample). Returns the
    indices of the turning points, alternating valleys and peaks, with the first and last
    sample added: consecutive entries bound the legs of the record, each monotone at the
    scale of ``threshold``.
    """
    n = y.size
    if n == 0:
        return []
    piv: list[int] = []
    lo = hi = ext = 0
    direction = 0  # +1 on a rising leg, -1 on a falling one, 0 before the first leg
    for i in range(1, n):
        v = y[i]
        if direction == 0:
            if v > y[hi]:
                hi = i
            if v < y[lo]:
                lo = i
            if y[hi] - y[lo] >= threshold:
                if lo < hi:
                    piv.append(lo)
                    direction, ext = 1, hi
                else:
                    piv.append(hi)
                    direction, ext = -1, lo
        elif direction > 0:
            if v >= y[ext]:
                ext = i
            elif y[ext] - v >= threshold:
                piv.append(ext)
                direction, ext = -1, i
        else:
            if v <= y[ext]:
                ext = i
            elif v - y[ext] >= threshold:
                piv.append(ext)
                direction, ext = 1, i
    if direction:
        piv.append(ext)
    out: list[int] = []
    for k in [0, *piv, n - 1]:
        if not out or k != out[-1]:
            out.append(int(k))
    return out


def step_drops(y: np.ndarray, i0: int, i1: int, size: np.ndarray, *, scales=(1, 2, 4, 8),
               contrast: float = 3.0) -> list[tuple[int, int]]:
    """Sudden falls of ``y`` inside ``[i0, i1)``: ``(start, end)`` sample pairs.

    A fall over ``k`` samples (one of ``scales``) is sudden when it is at least ``size`` at
    its start and ``contrast`` times the fall over the ``k`` samples before it and over the
    ``k`` samples after it (a rise counts as no fall): a step, not a stretch of a smooth
    decline however steep. The scales stop at 8 samples: a pump-stop drop (friction and
    near-wellbore losses vanishing) takes a few samples, while an exponential decay with a
    time constant of ``tau`` samples loses only ``exp(k / tau)`` times as much over ``k``
    samples as over the next ``k`` (below 3 for ``k <= tau``). The smallest scale that sees a step wins; overlapping
    detections are merged into one.
    """
    found: list[tuple[int, int]] = []
    i1 = min(i1, y.size)
    for k in scales:
        if i1 - i0 < k + 1:
            break
        idx = np.arange(i0, i1 - k)
        drop = y[idx] - y[idx + k]
        before = np.where(idx - k >= 0, y[np.clip(idx - k, 0, None)] - y[idx], 0.0)
        aft_end = np.clip(idx + 2 * k, 0, y.size - 1)
        after = y[idx + k] - y[aft_end]
        ok = ((drop >= size[idx]) & (drop >= contrast * np.clip(before, 0.0, None))
              & (drop >= contrast * np.clip(after, 0.0, None)))
        for j in idx[ok]:
            a, b = int(j), int(j + k)
            if any(a < fb and b > fa for fa, fb in found):
                continue
            found.append((a, b))
    found.sort()
    merged: list[tuple[int, int]] = []
    for a, b in found:
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(b, merged[-1][1]))
        else:
            merged.append((a, b))
    return merged


def roughness(p: np.ndarray, window: int) -> np.ndarray:
    """Local noise of ``p`` over a centred ``window`` of samples [same unit].

    The running median of the absolute second differences, scaled so that white noise of
    standard deviation ``s`` gives ``s`` (a second difference of white noise has standard
    deviation ``s sqrt(6)``, its absolute value a median of 0.6745 times that). A steady rise
    or decline has no second difference; a running pump makes the pressure pulse.
    """
    x = np.nan_to_num(np.asarray(p, float))
    d2 = np.zeros(x.size)
    if x.size >= 3:
        d2[1:-1] = np.abs(x[2:] - 2.0 * x[1:-1] + x[:-2])
    return running_median(d2, odd(window)) / (0.6745 * np.sqrt(6.0))
