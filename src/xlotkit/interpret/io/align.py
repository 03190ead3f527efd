"""Clock alignment of a surface and a downhole record, and their merge onto one time base.

A cementing unit and a memory gauge log the same test on two clocks that can differ by an
hour and more. :func:`estimate_clock_offset` finds the offset from the pressure signals
themselves; :func:`merge_surface_downhole` puts both records on the downhole samples, on the
surface clock.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

import numpy as np

from xlotkit.errors import InputError
from xlotkit.record import Event, Record

__all__ = ["ClockOffset", "estimate_clock_offset", "merge_surface_downhole"]


@dataclass(frozen=True)
class ClockOffset:
    """Clock offset between a surface and a downhole logger.

    Attributes
    ----------
    offset_s : float
        Seconds to add to a downhole-clock time to get the surface-clock time of the same
        instant [s].
    correlation : float
        Normalised cross-correlation of the two pressure-rate signals at ``offset_s``
        (1 = identical shape); NaN when the offset was given, not estimated.
    uncertainty_s : float
        One-sigma uncertainty of ``offset_s`` [s]: scatter of the offsets found in separate
        parts of the overlap combined with the grid quantisation.
    method : str
        How the offset was obtained.
    second_peak : float
        Highest correlation at a lag more than ``exclusion_s`` from the best one; close to
        ``correlation`` means an ambiguous match.
    exclusion_s : float
        Half-width of the lag window around the best peak excluded for ``second_peak`` [s].
    overlap_s : float
        Length of the overlap of the two records at ``offset_s`` [s].
    """

    offset_s: float
    correlation: float
    uncertainty_s: float
    method: str
    second_peak: float = float("nan")
    exclusion_s: float = float("nan")
    overlap_s: float = float("nan")


def _clock_axis(rec: Record, origin: datetime | None) -> np.ndarray:
    """Sample times [s] relative to ``origin`` on the record's own clock."""
    if rec.start_time is None or origin is None:
        return rec.t.copy()
    return rec.t + (rec.start_time - origin).total_seconds()


def _bin_signal(x: np.ndarray, y: np.ndarray, x0: float, dt: float, n: int) -> tuple[np.ndarray,
                                                                                     np.ndarray]:
    """Bin-average ``y(x)`` onto the grid ``x0 + dt*k``; returns values and a valid mask.

    Averaging (not point sampling) keeps the faster logger from aliasing; grid cells
    without samples are filled linearly but marked invalid when the gap exceeds 3 cells.
    """
    k = np.floor((x - x0) / dt).astype(np.int64)
    ok = (k >= 0) & (k < n) & np.isfinite(y)
    s = np.bincount(k[ok], weights=y[ok], minlength=n)
    c = np.bincount(k[ok], minlength=n)
    have = c > 0
    out = np.zeros(n)
    out[have] = s[have] / c[have]
    valid = have.copy()
    if have.sum() >= 2:
        idx = np.flatnonzero(have)
        out[~have] = np.interp(np.flatnonzero(~have), idx, out[have])
        gaps = np.diff(idx)
        for a, g in zip(idx[:-1], gaps):
            if 1 < g <= 4:
                valid[a + 1:a + g] = True
        valid[: idx[0]] = False
        valid[idx[-1] + 1:] = False
    return out, valid


def _feature(p: np.ndarray, valid: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Pressure-change signal used for matching: robust-scaled, soft-clipped dp/dt.

    Differencing removes the hydrostatic head and the absolute/gauge offset between the
    gauges; scaling by the median absolute change and a tanh clip keeps a few pump starts
    or spikes from dominating the correlation.
    """
    # difference over +-w cells (~10 s): the surface gauge reads whole bars, so one-step
    # differences are mostly quantisation noise
    w = max(1, int(round(5.0 / dt)))
    d = np.zeros(p.size - 1)
    v = np.zeros(p.size - 1, dtype=bool)
    d[w - 1: p.size - 1 - w + 1] = (p[2 * w - 1:] - p[: p.size - 2 * w + 1]) / (dt * (2 * w - 1))
    vv = np.convolve(valid.astype(float), np.ones(2 * w), mode="valid") == 2 * w
    v[w - 1: w - 1 + vv.size] = vv
    d = np.where(v, d, 0.0)
    scale = np.median(np.abs(d[v])) if v.any() else 1.0
    hi = np.percentile(np.abs(d[v]), 99.0) if v.any() else 1.0
    scale = max(scale, hi / 50.0, 1e-12)
    f = np.tanh(d / (20.0 * scale))
    f = np.where(v, f, 0.0)
    return f, v


def _ncc(a: np.ndarray, va: np.ndarray, b: np.ndarray, vb: np.ndarray,
         max_lag: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Masked normalised cross-correlation ``c[L] = corr(a[k], b[k - L])`` for |L| <= max_lag.

    Returns ``(lags, c, n_overlap)``; each lag's value is the Pearson correlation over the
    cells valid in both signals.
    """
    from scipy.signal import fftconvolve

    a = np.where(va, a, 0.0)
    b = np.where(vb, b, 0.0)
    ma, mb = va.astype(float), vb.astype(float)

    def xc(x, y):
        # full cross-correlation sum_k x[k] y[k-L]; index L + len(y) - 1
        return fftconvolve(x, y[::-1], mode="full")

    n_ab = xc(ma, mb)
    s_ab = xc(a, b)
    s_a = xc(a, mb)
    s_b = xc(ma, b)
    s_aa = xc(a * a, mb)
    s_bb = xc(ma, b * b)
    lags = np.arange(-(b.size - 1), a.size)
    sel = np.abs(lags) <= max_lag
    lags, n_ab, s_ab, s_a, s_b, s_aa, s_bb = (x[sel] for x in (lags, n_ab, s_ab, s_a, s_b,
                                                                 s_aa, s_bb))
    n = np.round(n_ab)
    with np.errstate(invalid="ignore", divide="ignore"):
        cov = s_ab - s_a * s_b / n
        va_ = s_aa - s_a ** 2 / n
        vb_ = s_bb - s_b ** 2 / n
        c = cov / np.sqrt(va_ * vb_)
    c[~np.isfinite(c) | (n < 3)] = np.nan
    return lags, c, n


def _best_lag(lags: np.ndarray, c: np.ndarray, ok: np.ndarray) -> tuple[float, float, int]:
    """Highest correlation among ``ok`` lags, refined by a parabola through 3 points."""
    cc = np.where(ok, c, -np.inf)
    i = int(np.argmax(cc))
    best = float(cc[i])
    frac = 0.0
    if 0 < i < cc.size - 1 and np.isfinite(cc[i - 1]) and np.isfinite(cc[i + 1]):
        den = cc[i - 1] - 2 * cc[i] + cc[i + 1]
        if den < 0:
            frac = float(np.clip(0.5 * (cc[i - 1] - cc[i + 1]) / den, -0.5, 0.5))
    return float(lags[i]) + frac, best, i


def estimate_clock_offset(surface: Record, downhole: Record, *, max_offset_s: float = 4 * 3600.0,
                          dt: float = 3.0, min_overlap_s: float = 1800.0) -> ClockOffset:
    """Estimate the clock offset between a surface and a downhole pressure record.

    Both pressures are bin-averaged onto a common ``dt`` grid (times relative to the surface
    ``start_time``, each record on its own clock), differenced, robust-scaled and clipped,
    then cross-correlated (masked, normalised) over lags up to ``max_offset_s``. The best lag
    is refined by a parabola; the search is then repeated on a 1 s grid around it, and on
    separate quarters of the overlap to estimate the uncertainty.

    Parameters
    ----------
    surface, downhole : Record
        Records of the same test; ``start_time`` of each on its own clock (if either lacks
        one, their ``t`` axes are compared directly).
    max_offset_s : float
        Largest offset searched [s].
    dt : float
        Coarse grid step [s] (the downhole gauge samples every 3 s in AMS-01).
    min_overlap_s : float
        Lags with a shorter overlap of valid samples are not considered [s] (capped at 80 %
        of the shorter record).

    Returns
    -------
    ClockOffset
        ``surface clock = downhole clock + offset_s``.

    Raises
    ------
    InputError
        If the records do not overlap at any lag within ``max_offset_s``.
    """
    origin = surface.start_time if (surface.start_time and downhole.start_time) else None
    xs = _clock_axis(surface, origin)
    xd = _clock_axis(downhole, origin)
    ps = surface.gauge_pressure()
    pd_ = downhole.gauge_pressure()

    def correlate(step: float, center: float, half: float, xs_, ps_, xd_, pd_v):
        # grid covering both (downhole shifted by `center`), lags within +-half around it
        lo = min(xs_[0], xd_[0] + center)
        hi = max(xs_[-1], xd_[-1] + center)
        n = int(np.ceil((hi - lo) / step)) + 2
        a, va = _bin_signal(xs_, ps_, lo, step, n)
        b, vb = _bin_signal(xd_ + center, pd_v, lo, step, n)
        fa, fva = _feature(a, va, step)
        fb, fvb = _feature(b, vb, step)
        lags, c, nn = _ncc(fa, fva, fb, fvb, int(np.ceil(half / step)))
        return lags * step + center, c, nn * step

    span = min(surface.duration, downhole.duration)
    need = min(min_overlap_s, 0.8 * span)
    lags, c, ov = correlate(dt, 0.0, max_offset_s, xs, ps, xd, pd_)
    ok = np.isfinite(c) & (ov >= need)
    if not ok.any():
        raise InputError("the surface and downhole records do not overlap within "
                         f"{max_offset_s:g} s of clock offset", key="max_offset_s",
                         expected="records of the same test (or a larger max_offset_s)")
    lag0, peak0, i0 = _best_lag(lags, c, ok)
    # ambiguity: best correlation outside the main peak (+- 10 min or 5 % of the span)
    excl = max(600.0, 0.05 * span)
    far = ok & (np.abs(lags - lags[i0]) > excl)
    second = float(np.nanmax(np.where(far, c, np.nan))) if far.any() else float("nan")
    # refine on a 1 s grid around the coarse peak
    fine = min(1.0, dt)
    lags1, c1, ov1 = correlate(fine, lags[i0], 3 * dt, xs, ps, xd, pd_)
    ok1 = np.isfinite(c1) & (ov1 >= need)
    lag, peak, _ = _best_lag(lags1, c1, ok1) if ok1.any() else (lag0, peak0, i0)
    # uncertainty: repeat in quarters of the overlap
    t0 = max(xs[0], xd[0] + lag)
    t1 = min(xs[-1], xd[-1] + lag)
    sub = []
    if t1 - t0 > 4 * 600.0:
        edges = np.linspace(t0, t1, 5)
        for a0, a1 in zip(edges[:-1], edges[1:]):
            ms = (xs >= a0) & (xs <= a1)
            md = (xd + lag >= a0 - 30 * dt) & (xd + lag <= a1 + 30 * dt)
            if ms.sum() < 20 or md.sum() < 20:
                continue
            try:
                l_, c_, o_ = correlate(fine, lag, 10 * dt, xs[ms], ps[ms], xd[md], pd_[md])
            except (ValueError, IndexError):
                continue
            okq = np.isfinite(c_) & (o_ >= 0.5 * (a1 - a0))
            if okq.any():
                lq, cq, _ = _best_lag(l_, c_, okq)
                if cq > 0.3:    # quarters without pressure changes carry no timing
                    sub.append(lq)
    quant = max(fine, float(np.median(np.diff(downhole.t))) if downhole.n > 1 else fine)
    unc = quant / math.sqrt(12.0)
    if len(sub) >= 2:
        unc = math.hypot(unc, float(np.std(sub, ddof=1)) / math.sqrt(len(sub)))
    return ClockOffset(offset_s=float(lag), correlation=float(peak), uncertainty_s=float(unc),
                       method=f"masked cross-correlation of scaled dp/dt, {dt:g} s grid refined "
                              f"on {fine:g} s, {len(sub)} sub-windows",
                       second_peak=second, exclusion_s=excl, overlap_s=float(t1 - t0))


def merge_surface_downhole(surface: Record, downhole: Record, *,
                           max_offset_s: float = 4 * 3600.0,
                           offset_s: float | None = None) -> tuple[Record, ClockOffset]:
    """Put a surface (cementing unit) and a downhole gauge record on one time base.

    Parameters
    ----------
    surface : Record
        Cementing-unit record: surface pressure, rate, volume, returns, density.
    downhole : Record
        Downhole gauge record: pressure at depth, temperature.
    max_offset_s : float
        Largest clock offset searched [s].
    offset_s : float, optional
        Known offset (surface clock = downhole clock + ``offset_s``) [s]; skips estimation.

    Returns
    -------
    merged : Record
        On the downhole samples that fall inside the surface record's span, times on the
        surface clock (``start_time`` = surface-clock time of the first kept sample).
        ``pressure`` and ``reference`` from the downhole gauge, ``temperature`` from the
        gauge; ``rate``, ``volume``, ``return_rate``, ``return_volume``, ``density`` and the
        surface channels linearly interpolated from the surface record; surface pressure in
        ``channels["surface_pressure"]``. Events of both files shifted onto the new base.
        ``meta["clock_offset_s"]`` and friends record the alignment.
    offset : ClockOffset
        The offset applied.

    Raises
    ------
    InputError
        If the records do not overlap once aligned.
    """
    if offset_s is None:
        off = estimate_clock_offset(surface, downhole, max_offset_s=max_offset_s)
    else:
        off = ClockOffset(float(offset_s), float("nan"), 0.0, "given")
    origin = surface.start_time if (surface.start_time and downhole.start_time) else None
    xs = _clock_axis(surface, origin)
    xd = _clock_axis(downhole, origin) + off.offset_s
    keep = (xd >= xs[0]) & (xd <= xs[-1])
    if keep.sum() < 2:
        raise InputError(f"the records do not overlap with a clock offset of {off.offset_s:g} s",
                         key="offset_s", expected="an offset that overlaps the two records")
    x = xd[keep]
    x0 = float(x[0])
    t = x - x0
    start = None if origin is None else origin + _td(x0)

    def on(y):
        return None if y is None else np.interp(x, xs, y)

    channels: dict[str, np.ndarray] = {"surface_pressure": np.interp(x, xs,
                                                                     surface.gauge_pressure())}
    for k, v in surface.channels.items():
        channels[k if k not in channels else "surface_" + k] = np.interp(x, xs, v)
    for k, v in downhole.channels.items():
        channels[k if k not in channels else "downhole_" + k] = v[keep]
    temperature = downhole.temperature[keep] if downhole.temperature is not None else None
    if temperature is None and surface.temperature is not None:
        temperature = on(surface.temperature)
    shift_s = (0.0 if origin is None else (surface.start_time - origin).total_seconds()) - x0
    shift_d = (0.0 if origin is None else (downhole.start_time - origin).total_seconds()) \
        + off.offset_s - x0
    events = [Event(e.t + shift_s, e.text, e.timestamp, e.source, e.line) for e in surface.events]
    events += [Event(e.t + shift_d, e.text, e.timestamp, e.source, e.line)
               for e in downhole.events]
    # provenance: the surface pressure column now feeds channel surface_pressure
    cols = [dataclasses.replace(c, field="channel:surface_pressure") if c.field == "pressure"
            else c for c in surface.columns]
    cols += list(downhole.columns)
    gaps = np.diff(xs)
    big = np.flatnonzero(gaps > 30.0)
    meta: dict[str, Any] = {
        "kind": "merged",
        "clock": "surface (cementing unit) clock",
        "clock_offset_s": off.offset_s,
        "clock_offset_correlation": off.correlation,
        "clock_offset_uncertainty_s": off.uncertainty_s,
        "clock_offset_second_peak": off.second_peak,
        "clock_offset_method": off.method,
        "surface_gaps_interpolated": [(float(xs[i] - x0), float(gaps[i])) for i in big],
        "surface": dict(surface.meta),
        "downhole": dict(downhole.meta),
    }
    for k in ("well", "test", "gauge_serial", "gauge_depth_m"):
        for m in (downhole.meta, surface.meta):
            if k in m:
                meta.setdefault(k, m[k])
    merged = Record(t=t, pressure=downhole.pressure[keep], reference=downhole.reference,
                    start_time=start, rate=on(surface.rate), volume=on(surface.volume),
                    return_rate=on(surface.return_rate), return_volume=on(surface.return_volume),
                    density=on(surface.density), temperature=temperature, channels=channels,
                    events=tuple(events), columns=tuple(cols),
                    sources=tuple(surface.sources) + tuple(downhole.sources), meta=meta)
    return merged, off


def _td(seconds: float) -> timedelta:
    return timedelta(seconds=float(seconds))
