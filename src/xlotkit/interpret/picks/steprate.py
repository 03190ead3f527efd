r"""Fracture-extension pressure (FEP) of a step-rate test: the break in the stabilised p-q line.

A step-rate test pumps at several increasing rates, each held until the pressure
stabilises. Below fracture extension the formation takes the fluid by matrix flow and the
stabilised pressure rises steeply with rate (Darcy: ``p = p_res + q / J``); once a fracture
extends, the fracture takes any extra rate at little extra pressure and the line flattens.
The FEP is the pressure where the two straight lines through the stabilised points meet.

Method
------
1. The rate steps of the cycle's pumping
   (:func:`xlotkit.interpret.phases.kinds.rate_steps`): per step the median rate and the
   pressure at its end (median over its last third). Steps whose pressure had not
   stabilised are left out of the fit (named in the message).
2. Every split of the ``n >= 4`` points into a lower line (the first ``k``) and an upper line
   (the rest), at least two points on each, is fitted by least squares. The split with the
   smallest total squared residual wins when the upper line is flatter than the lower; the
   FEP is the pressure where the two lines intersect. There is a break only if the two
   lines fit significantly better than one straight line at the stated level (chi-square
   with the points' errors, or an F test when the points scatter more than their errors).
3. Interval at the stated level (:data:`xlotkit.interpret.picks.intervals.LEVEL`,
   :mod:`~xlotkit.interpret.picks.intervals`): the statistical part from the lines'
   covariance (first-order propagation to the intersection, :func:`~xlotkit.interpret.
   picks.models.intersect`); the breakpoint's own uncertainty by a parametric bootstrap
   (each stabilised pressure redrawn with its own error, the whole profile over the split
   refitted; the central ``LEVEL`` range of the refitted FEP, covered whole); the gauge's
   resolution. The error of a stabilised pressure is the larger of its scatter over the
   last third of the step (as a standard error of the median) plus half its residual drift,
   and the scatter of the points about the fitted lines.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.stats import chi2
from scipy.stats import f as f_dist

from xlotkit.interpret.phases import Cycle, RateStep, rate_steps
from xlotkit.interpret.picks.details import LineDetails, RateStepPoint, StepRateDetails
from xlotkit.interpret.picks.intervals import LEVEL, budget
from xlotkit.interpret.picks.models import LineFit, intersect
from xlotkit.interpret.picks.pressurisation import noise_level, quantum
from xlotkit.interpret.picks.types import Pick
from xlotkit.record import Record

__all__ = ["fep_two_lines", "pick_fep", "pick_fep_entry"]

_BAR = 1.0e5
#: Bootstrap redraws of the stabilised points (fixed seed: deterministic).
N_BOOT = 400
_SEED = 20240601


def _line(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[LineFit, float]:
    """Weighted least-squares line with its covariance from the points' errors ``1/w``;
    returns the fit and its weighted squared residual."""
    A = np.column_stack([x, np.ones_like(x)])
    Aw = A * w[:, None]
    yw = y * w
    coef, *_ = np.linalg.lstsq(Aw, yw, rcond=None)
    resid = y - A @ coef
    cov = np.linalg.pinv(Aw.T @ Aw)
    sse = float(np.sum((resid * w) ** 2))
    s, c = float(coef[0]), float(coef[1])
    return LineFit(slope=s, intercept=c, slope_stderr=float(np.sqrt(max(cov[0, 0], 0.0))),
                   intercept_stderr=float(np.sqrt(max(cov[1, 1], 0.0))), covariance=cov,
                   r2=np.nan, residual_std=float(np.std(resid)), n=int(x.size),
                   x_range=(float(x.min()), float(x.max()))), sse


def fep_two_lines(q: Sequence[float], p: Sequence[float], sigma: Sequence[float] | None = None
                  ) -> tuple[int, LineFit, LineFit, float, float, float] | None:
    """The best two-line split of stabilised points ``(q, p)`` (module docstring, step 2).

    Parameters
    ----------
    q, p : sequence of float, shape (n,)
        Rates [m^3/s] in increasing order and stabilised pressures [Pa], n >= 4.
    sigma : sequence of float, optional
        One-sigma errors of ``p`` [Pa] (default: equal weights).

    Returns
    -------
    (k, lower, upper, q_fep, p_fep, p_fep_stderr) or None
        ``k`` points on the lower line; the intersection rate [m^3/s] and pressure [Pa] with
        its propagated standard error. None when no split gives a flatter upper line meeting
        the lower one inside the range of the points.
    """
    q = np.asarray(q, float)
    p = np.asarray(p, float)
    n = q.size
    if n < 4:
        return None
    s = np.ones(n) if sigma is None else np.maximum(np.asarray(sigma, float), 1e-300)
    w = 1.0 / s
    best = None
    for k in range(2, n - 1):
        lo, sse_lo = _line(q[:k], p[:k], w[:k])
        hi, sse_hi = _line(q[k:], p[k:], w[k:])
        if not (lo.slope > 0 and hi.slope < lo.slope):
            continue
        xq, _, yp, ye = intersect(lo, hi)
        # the lines must meet between the first and the last point
        if not (np.isfinite(xq) and q[0] <= xq <= q[-1]):
            continue
        total = sse_lo + sse_hi
        if best is None or total < best[0]:
            best = (total, k, lo, hi, xq, yp, ye)
    if best is None:
        return None
    _, k, lo, hi, xq, yp, ye = best
    return k, lo, hi, float(xq), float(yp), float(ye)


def _wls(x: np.ndarray, Y: np.ndarray, w2: np.ndarray):
    """Weighted least-squares lines through ``(x, Y[b])`` for every row ``b`` of ``Y``
    (weights ``w2 = 1/sigma^2``): slopes, intercepts and weighted squared residuals."""
    S, Sx, Sxx = w2.sum(), (w2 * x).sum(), (w2 * x * x).sum()
    Sy = Y @ w2
    Sxy = Y @ (w2 * x)
    det = S * Sxx - Sx * Sx
    slope = (S * Sxy - Sx * Sy) / det
    icpt = (Sxx * Sy - Sx * Sxy) / det
    r = Y - (slope[:, None] * x[None, :] + icpt[:, None])
    return slope, icpt, (r * r) @ w2


def _batch_fep(q: np.ndarray, P: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """:func:`fep_two_lines` for every row of ``P`` at once: the FEP [Pa] per row (NaN where
    no split gives a flatter upper line meeting the lower one between the points)."""
    n = q.size
    w2 = 1.0 / np.maximum(sigma, 1e-300) ** 2
    best = np.full(P.shape[0], np.inf)
    out = np.full(P.shape[0], np.nan)
    for k in range(2, n - 1):
        s1, c1, e1 = _wls(q[:k], P[:, :k], w2[:k])
        s2, c2, e2 = _wls(q[k:], P[:, k:], w2[k:])
        with np.errstate(divide="ignore", invalid="ignore"):
            xq = (c2 - c1) / (s1 - s2)
        ok = (s1 > 0) & (s2 < s1) & np.isfinite(xq) & (xq >= q[0]) & (xq <= q[-1])
        total = e1 + e2
        take = ok & (total < best)
        best[take] = total[take]
        out[take] = (s1 * xq + c1)[take]
    return out


def _point_errors(record: Record, steps: Sequence[RateStep], noise: float) -> np.ndarray:
    """One-sigma error of each stabilised pressure [Pa] (module docstring, step 3)."""
    out = []
    p = np.asarray(record.pressure, float)
    for st in steps:
        third = max(3, (st.i1 - st.i0) // 3)
        seg = p[st.i1 - third: st.i1]
        seg = seg[np.isfinite(seg)]
        # standard error of a median of n samples ~ 1.25 sigma / sqrt(n)
        se = 1.25 * max(float(np.std(seg)) if seg.size > 1 else 0.0, noise) / np.sqrt(
            max(seg.size, 1))
        out.append(se + 0.5 * abs(st.drift))
    return np.asarray(out)


def pick_fep(record: Record, cycle: Cycle, *, window: tuple[float, float] | None = None
             ) -> Pick:
    """Fracture-extension pressure of a step-rate cycle (module docstring).

    Parameters
    ----------
    record : Record
    cycle : Cycle
        A cycle with metered pumping in rate steps (``step_rate``).
    window : (float, float), optional
        Time window [s]: only rate steps that end inside it are used.

    Returns
    -------
    Pick
        ``name="FEP"``, ``method="two_line"``; ``t`` is the end of the last step on the
        lower line. ``details``: ``steps`` (rate [m^3/s], pressure [Pa], stable) per step
        used, ``lower``/``upper`` (slope [Pa s/m^3], intercept [Pa], points), ``q_fep``
        [m^3/s], ``bootstrap`` (low, high) [Pa], ``interval``.
    """
    name, method = "FEP", "two_line"
    if record.rate is None:
        return Pick.not_found(name, method, "no pump rate logged: a step-rate test needs it")
    pumps = [ph for ph in cycle.phases if ph.kind == "pump"]
    steps = list(rate_steps(record, pumps))
    if window is not None:
        steps = [s for s in steps if window[0] <= record.t[s.i1 - 1] <= window[1]]
    left_out = [s for s in steps if not s.stable]
    steps = [s for s in steps if s.stable]
    msg_out = (f"; {len(left_out)} step(s) not stabilised left out ("
               + ", ".join(f"{s.rate * 6e4:.4g} l/min" for s in left_out) + ")"
               if left_out else "")
    # one point per rate, in increasing rate
    steps.sort(key=lambda s: s.rate)
    if len(steps) < 4:
        return Pick.not_found(name, method, f"{len(steps)} stabilised rate step(s): two lines "
                              f"need at least 4{msg_out}")
    q = np.array([s.rate for s in steps])
    p = np.array([s.pressure for s in steps])
    pp = np.asarray(record.pressure, float)
    i0, i1 = steps[0].i0, max(s.i1 for s in steps)
    noise = noise_level(pp[i0:i1][np.isfinite(pp[i0:i1])])
    sig = _point_errors(record, steps, noise)
    fit = fep_two_lines(q, p, sig)
    if fit is None:
        return Pick.not_found(name, method, "no break in the stabilised p-q line: no split "
                              "gives a flatter upper line meeting the lower one" + msg_out)
    k, lo, hi, qx, value, se = fit
    # the points' scatter about the lines, when larger than their own errors, is the error
    resid = np.concatenate([p[:k] - (lo.slope * q[:k] + lo.intercept),
                            p[k:] - (hi.slope * q[k:] + hi.intercept)])
    dof = q.size - 4
    scatter = float(np.sqrt(np.sum(resid ** 2) / dof)) if dof > 0 else 0.0
    sig_eff = np.maximum(sig, scatter)
    if scatter > float(np.median(sig)):
        fit2 = fep_two_lines(q, p, sig_eff)
        if fit2 is not None:
            k, lo, hi, qx, value, se = fit2
    # is there a break at all? two lines must fit significantly better than one
    chi_one = _line(q, p, 1.0 / sig_eff)[1]
    chi_two = (_line(q[:k], p[:k], 1.0 / sig_eff[:k])[1]
               + _line(q[k:], p[k:], 1.0 / sig_eff[k:])[1])
    gain = chi_one - chi_two
    if dof > 0 and scatter > float(np.median(sig)):
        stat, crit = gain / 2.0 / max(chi_two / dof, 1e-300), float(f_dist.ppf(LEVEL, 2, dof))
    else:
        stat, crit = gain, float(chi2.ppf(LEVEL, 2))
    if stat < crit:
        return Pick.not_found(name, method, "no break in the stabilised p-q line: two lines "
                              f"fit no better than one (test statistic {stat:.3g} below "
                              f"{crit:.3g} at the {100 * LEVEL:.0f} % level){msg_out}",
                              details=StepRateDetails(steps=_points(steps)))
    rng = np.random.default_rng(_SEED)
    draws = p[None, :] + rng.normal(0.0, 1.0, (N_BOOT, q.size)) * sig_eff[None, :]
    boot_arr = _batch_fep(q, draws, sig_eff)
    boot_arr = boot_arr[np.isfinite(boot_arr)]
    extra = []
    found_frac = boot_arr.size / N_BOOT
    if boot_arr.size >= 20:
        a = 0.5 * (1.0 - LEVEL)
        extra.append(("breakpoint bootstrap", float(np.quantile(boot_arr, a)),
                      float(np.quantile(boot_arr, 1.0 - a))))
    bud = budget(value, stderr=se, resolution=0.5 * quantum(pp[i0:i1][np.isfinite(pp[i0:i1])]),
                 extra=extra)
    ratio = hi.slope / lo.slope
    if q.size >= 6 and found_frac >= 0.9 and ratio < 0.5:
        quality = "good"
    elif found_frac >= 0.5:
        quality = "fair"
    else:
        quality = "poor"
    details = StepRateDetails(
        steps=_points(steps),
        line_lower=LineDetails.of(lo), line_upper=LineDetails.of(hi),
        points_lower=int(k), points_upper=int(q.size - k), q_fep=float(qx),
        slope_ratio=float(ratio),
        bootstrap=(float(extra[0][1]), float(extra[0][2])) if extra else None,
        bootstrap_found=float(found_frac), interval=bud)
    msg = (f"two lines through {q.size} stabilised steps meet at {qx * 6e4:.4g} l/min; "
           f"slope ratio {ratio:.2f}{msg_out}")
    return Pick(name, method, value, bud.low, bud.high, t=float(record.t[steps[k - 1].i1 - 1]),
                window=(float(record.t[steps[0].i0]), float(record.t[steps[-1].i1 - 1])),
                quality=quality, message=msg, details=details, level=bud.level)


def _points(steps: Sequence[RateStep]) -> tuple[RateStepPoint, ...]:
    return tuple(RateStepPoint(rate=float(s.rate), pressure=float(s.pressure),
                               stable=bool(s.stable)) for s in steps)


def pick_fep_entry(record, cycle, *, window, tangents, isip) -> Pick:
    """:func:`pick_fep` with the signature of :class:`xlotkit.interpret.picks.core.
    PickMethod` (tangents and ISIP are not used by the method)."""
    return pick_fep(record, cycle, window=window)
