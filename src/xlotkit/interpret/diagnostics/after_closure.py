r"""After-closure analysis: the reservoir pressure from the flow regimes after closure.

After the fracture has closed the well pressure falls towards the reservoir pressure
``p_r`` as the leaked-off fluid spreads into the formation. Nolte's after-closure time
functions (Nolte 1997; Talley et al. 1999) make each regime a straight line whose
intercept is ``p_r``, with ``t`` the time since pumping started and ``t_c`` that of closure:

*linear flow* (the leaked fluid still moves normal to the fracture faces)::

    p - p_r = m_L F_L,     F_L(t) = (2/pi) arcsin(sqrt(t_c / t))             (F_L(t_c) = 1)

*radial flow* (pseudo-radial, late)::

    p - p_r = m_R F_R,     F_R(t) = (1/4) ln(1 + chi t_c / (t - t_c)),  chi = 16 / pi^2

At late time ``F_L ~ (2/pi) sqrt(t_c/t)`` and ``F_R ~ chi t_c / (4 t)``: the derivative
``|dp / d ln t|`` has log-log slope -1/2 in linear and -1 in radial flow, whatever ``p_r``.
A third regime closes the list: a small closed system leaking through a constant
productivity (a permeable open-hole wall, the lumped model's wall leak), whose pressure
decays exponentially, ``p - p_r = A exp(-(t - t_c) / tau)`` (:class:`ExponentialDeclineModel`);
there the local decay time ``-(dp/dt) / (d^2p/dt^2)`` is constant.

Procedure (:func:`after_closure_analysis`): on the shut-in samples after closure,

1. radial flow: a late stretch where ``dp/dF_R`` (the ratio of the slopes of p and of
   ``F_R`` against ``ln(t - t_c)``, over windows of constant width in it) stays
   within 10 % of its median over at least a factor 2 in ``t - t_c`` and the derivative's
   log-log slope is within 0.2 of -1;
2. else linear flow: the same with ``F_L`` and slope -1/2;
3. else the exponential: the fit of :class:`ExponentialDeclineModel` to all after-closure
   data leaves residuals at the noise level and the record spans at least one decay time;
4. else "after-closure flow not reached", with why (the record's length after closure
   and the slope the derivative shows, and any fit rejected below).

A fit is used only if it describes an after-closure *decline* (:func:`admissible`): the
pressure falls over the window fitted (the fall from its first to its last twentieth
exceeds three noise levels, the noise floored by the gauge's quantisation), the fitted decline falls
(a positive slope against F, a positive amplitude of the exponential), and the reservoir
pressure lies below the closure pressure and below the ISIP. A pressure that rises after
"closure" (a leaking valve, thermal expansion, a closure picked too early) would otherwise
give an asymptote above closure that then replaces the pore pressure.

The regime's line (or the exponential) is fitted, ``p_r`` is its intercept (asymptote),
and its interval has the stated level (:mod:`~xlotkit.interpret.picks.intervals`): the
fit's standard error inflated for correlated residuals, the spread over the first and last
two thirds of the stretch and over the closure time (the time functions refitted with
``t_c`` 20 % earlier and later and at the closure pick's interval), and half the gauge's
quantisation step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import lmfit
import numpy as np

from xlotkit.interpret.picks.intervals import IntervalBudget, budget, correlation_inflation
from xlotkit.interpret.picks.models import LineFit, fit_line
from xlotkit.interpret.picks.pressurisation import local_fit, noise_level, quantum

__all__ = [
    "CHI",
    "AfterClosureResult",
    "ExponentialDeclineModel",
    "after_closure_analysis",
    "exponential_decline",
    "nolte_linear",
    "nolte_radial",
]

#: Nolte's constant of the radial time function, 16 / pi^2.
CHI = 16.0 / math.pi ** 2


def nolte_linear(t, t_c):
    """Nolte's linear-flow time function ``F_L = (2/pi) arcsin(sqrt(t_c / t))``, ``t >= t_c``
    (times since pumping started, [s])."""
    t = np.asarray(t, float)
    return 2.0 / math.pi * np.arcsin(np.sqrt(np.clip(t_c / t, 0.0, 1.0)))


def nolte_radial(t, t_c):
    """Nolte's radial-flow time function ``F_R = (1/4) ln(1 + chi t_c / (t - t_c))``,
    ``t > t_c``."""
    t = np.asarray(t, float)
    return 0.25 * np.log1p(CHI * t_c / np.maximum(t - t_c, 1e-9 * t_c))


def exponential_decline(t, p_r=0.0, amplitude=1.0, tau=1.0):
    """``p = p_r + amplitude exp(-t / tau)`` (``t`` since closure)."""
    return p_r + amplitude * np.exp(-np.asarray(t, float) / tau)


class ExponentialDeclineModel(lmfit.Model):
    """lmfit model of an exponential approach to the reservoir pressure, with ``guess``."""

    def __init__(self, **kwargs):
        super().__init__(exponential_decline, **kwargs)

    def guess(self, data, t, **kwargs):
        """Start from three points: the decay time from the ratio of successive drops."""
        t = np.asarray(t, float)
        y = np.asarray(data, float)
        n = y.size
        i1, i2 = n // 2, n - 1
        d1, d2 = y[0] - y[i1], y[i1] - y[i2]
        if d1 > 0 and d2 > 0 and d2 < d1:
            tau = (t[i1] - t[0]) / math.log(d1 / d2)
        else:
            tau = max(t[-1] - t[0], 1.0)
        amp = (y[0] - y[-1]) / max(1.0 - math.exp(-(t[-1] - t[0]) / tau), 1e-6)
        pr = y[0] - amp
        params = self.make_params(p_r=pr, amplitude=amp, tau=tau)
        params["tau"].set(min=1e-3 * tau, max=1e3 * tau)
        return params


@dataclass(frozen=True)
class AfterClosureResult:
    """The after-closure analysis of one shut-in.

    Attributes
    ----------
    reached : bool
        Whether an after-closure flow regime was identified.
    regime : str or None
        ``"radial"``, ``"linear"`` or ``"exponential"``.
    message : str
        What was found, or why the regime was not reached.
    reservoir_pressure, low, high : float or None
        ``p_r`` and its interval [Pa] on the record's reference.
    level : float or None
        Nominal level of the interval.
    interval : IntervalBudget or None
    t_closure : float or None
        Closure [s, record time].
    t_pump_start : float or None
        Start of pumping [s] (origin of Nolte's ``t``).
    window : (float, float) or None
        Record-time window of the regime's fit [s].
    line : LineFit or None
        ``p`` against ``F`` over the window (linear/radial).
    slope : float or None
        ``m_L`` or ``m_R`` [Pa]; for the exponential its decay time [s].
    t, p : ndarray
        After-closure samples [s, Pa] (for plots).
    f_linear, f_radial : ndarray
        ``F_L`` and ``F_R`` of those samples.
    derivative_slope : float or None
        Log-log slope of ``|dp / d ln(t - t_c)|`` over the last third (why not reached).
    fit_report : str
        lmfit's report of the exponential fit, when made.
    """

    reached: bool
    regime: str | None
    message: str
    reservoir_pressure: float | None = None
    low: float | None = None
    high: float | None = None
    level: float | None = None
    interval: IntervalBudget | None = None
    t_closure: float | None = None
    t_pump_start: float | None = None
    window: tuple[float, float] | None = None
    line: LineFit | None = None
    slope: float | None = None
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    p: np.ndarray = field(default_factory=lambda: np.zeros(0))
    f_linear: np.ndarray = field(default_factory=lambda: np.zeros(0))
    f_radial: np.ndarray = field(default_factory=lambda: np.zeros(0))
    derivative_slope: float | None = None
    fit_report: str = ""

    def report(self) -> str:
        """One line in field units."""
        if not self.reached or self.reservoir_pressure is None:
            return f"after-closure analysis: {self.message}"
        name = "exponential decline" if self.regime == "exponential" else f"{self.regime} flow"
        return (f"after-closure analysis: {name}, reservoir pressure "
                f"{self.reservoir_pressure / 1e5:.2f} bar "
                f"[{self.low / 1e5:.2f} - {self.high / 1e5:.2f}] "
                f"({100 * self.level:.0f} % interval); {self.message}")


def _stable_stretch(tt: np.ndarray, d: np.ndarray, *, rel: float = 0.1,
                    min_factor: float = 2.0) -> tuple[int, int] | None:
    """Latest stretch where ``d`` stays within ``rel`` of a common value over at least a
    factor ``min_factor`` in ``tt``: the value is the median of the last 10, 20 or 40 % of
    the samples, and the stretch runs back from the last sample while ``d`` stays within
    the band (the longest of the three)."""
    n = tt.size
    ok = np.isfinite(d) & (d > 0)
    idx = np.flatnonzero(ok)
    if idx.size < 8:
        return None
    b = int(idx[-1])
    best = None
    for frac in (0.1, 0.2, 0.4):
        tail = d[idx[-max(5, int(frac * idx.size)):]]
        med = float(np.median(tail))
        inband = ok & (np.abs(d - med) <= rel * med)
        if not inband[b]:
            continue
        out = np.flatnonzero(~inband[:b + 1])
        a = int(out[-1]) + 1 if out.size else 0
        if tt[b] / max(tt[a], 1e-12) >= min_factor and b - a >= 8:
            if best is None or (b - a) > (best[1] - best[0]):
                best = (a, b)
    return best


def _line_budget(F: np.ndarray, p: np.ndarray, a: int, b: int, q: float,
                 F_alt=()) -> tuple[LineFit, IntervalBudget]:
    f = fit_line(F[a:b + 1], p[a:b + 1])
    n = b - a + 1
    trials = []
    for lo, hi in ((a, a + 2 * n // 3), (b - 2 * n // 3, b + 1)):
        if hi - lo >= 5:
            trials.append(fit_line(F[lo:hi], p[lo:hi]).intercept)
    for Fa in F_alt:
        trials.append(fit_line(Fa[a:b + 1], p[a:b + 1]).intercept)
    infl = correlation_inflation(p[a:b + 1] - f(F[a:b + 1]))
    return f, budget(f.intercept, stderr=f.intercept_stderr, inflation=infl, trials=trials,
                     resolution=0.5 * q)


def admissible(t: np.ndarray, p: np.ndarray, p_r: float, falls: bool, closure: float,
               isip: float | None, noise: float) -> str | None:
    """Why a fit over the window ``(t, p)`` is not an after-closure decline, or None.

    Parameters
    ----------
    t, p : ndarray
        The window's samples [s, Pa].
    p_r : float
        The fit's reservoir pressure [Pa].
    falls : bool
        Whether the fitted curve falls with time (slope against F, amplitude).
    closure, isip : float
        Closure pressure and ISIP [Pa] (ISIP None when not picked).
    noise : float
        One-sigma noise of the pressure [Pa], floored by the quantisation error.
    """
    # Ends of the window: a twentieth of it (3 samples at least), so that a decline that
    # has levelled off over most of a long window still shows its fall.
    k = max(3, p.size // 20)
    first, last = float(np.median(p[:k])), float(np.median(p[-k:]))
    if not first - last > 3.0 * noise:
        verb = "rises" if last > first + 3.0 * noise else "does not fall"
        return (f"the pressure {verb} over the window fitted ({first / 1e5:.1f} -> "
                f"{last / 1e5:.1f} bar from {t[0]:.0f} s to {t[-1]:.0f} s, noise "
                f"{noise / 1e5:.2f} bar): not an after-closure decline")
    if not falls:
        return "the fitted curve rises with time: not an after-closure decline"
    if not p_r < closure:
        return (f"its reservoir pressure {p_r / 1e5:.1f} bar is not below the closure "
                f"pressure {closure / 1e5:.1f} bar")
    if isip is not None and not p_r < isip:
        return (f"its reservoir pressure {p_r / 1e5:.1f} bar is not below the ISIP "
                f"{isip / 1e5:.1f} bar")
    return None


def _interval_times(closure, t: np.ndarray, p: np.ndarray, t0: float) -> list[float]:
    """Times (since pumping started) at which the decline crosses the closure pick's
    interval bounds."""
    out = []
    for level in (closure.low, closure.high):
        if level is None:
            continue
        below = np.flatnonzero(p <= level)
        if below.size:
            out.append(float(t[below[0]]) - t0)
    return out


def after_closure_analysis(record, cycle, closure, isip=None) -> AfterClosureResult:
    """The after-closure analysis of a cycle's shut-in (procedure in the module docstring).

    Parameters
    ----------
    record : Record
    cycle : Cycle
    closure : Pick or None
        The cycle's closure; it must lie inside the shut-in.
    isip : Pick or float, optional
        The cycle's ISIP [Pa]: a reservoir pressure must lie below it.

    Returns
    -------
    AfterClosureResult
    """
    from xlotkit.interpret.picks.pressurisation import pump_phases, shutin_phase

    if closure is None or not getattr(closure, "found", False) or closure.t is None:
        return AfterClosureResult(False, None, "after-closure flow not reached: no closure "
                                  "was picked, so there is no after-closure period")
    shut = shutin_phase(cycle)
    pumps = pump_phases(cycle)
    if shut is None or not pumps:
        return AfterClosureResult(False, None, "after-closure flow not reached: the cycle has "
                                  "no shut-in after pumping")
    t_all = record.t[shut.i0:shut.i1]
    p_all = record.pressure[shut.i0:shut.i1]
    t_c = float(closure.t)
    if not (t_all[0] <= t_c < t_all[-1]):
        return AfterClosureResult(False, None, "after-closure flow not reached: closure came "
                                  "outside the shut-in (e.g. in the flowback), so the "
                                  "shut-in holds no after-closure decline")
    t0 = float(pumps[0].t_start)
    after = t_all > t_c
    t, p = t_all[after], p_all[after]
    base = {"t_closure": t_c, "t_pump_start": t0, "t": t, "p": p}
    if t.size < 20:
        return AfterClosureResult(False, None, f"after-closure flow not reached: only "
                                  f"{t.size} samples after closure", **base)
    tt, tc = t - t0, t_c - t0
    FL, FR = nolte_linear(tt, tc), nolte_radial(tt, tc)
    base.update(f_linear=FL, f_radial=FR)
    q = quantum(p)
    sig = noise_level(p)
    dta = t - t_c
    # Log-log slope of the after-closure derivative (regime check and the why-not).
    der, _ = local_fit(np.log(dta), p, 0.15, min_points=5)   # dp / d ln(t - t_c)
    absd = np.abs(der)
    okd = absd > 0
    dslope = None
    if okd.sum() >= 10:
        s, _ = local_fit(np.log(dta[okd]), np.log(absd[okd]), 0.3, min_points=5)
        late = s[-max(5, s.size // 3):]
        dslope = float(np.nanmedian(late))
    base["derivative_slope"] = dslope
    span = (t[-1] - t0) / max(t_c - t0, 1e-9)
    lnd = np.log(dta)
    p_isip = getattr(isip, "value", isip)
    p_isip = float(p_isip) if p_isip is not None else None
    noise = max(sig, q / math.sqrt(12.0))
    rejected: list[str] = []
    for regime, F, ref in (("radial", FR, -1.0), ("linear", FL, -0.5)):
        # dp/dF as the ratio of log-time-windowed slopes (F is steep near closure).
        dF, _ = local_fit(lnd, F, 0.15, min_points=5)
        with np.errstate(invalid="ignore", divide="ignore"):
            dpdF = der / dF
        st = _stable_stretch(dta, dpdF)
        if st is None:
            continue
        a, b = st
        if okd.sum() >= 10:
            s_all, _ = local_fit(np.log(dta[okd]), np.log(absd[okd]), 0.3, min_points=5)
            full = np.full(dta.size, np.nan)
            full[okd] = s_all
            if not abs(float(np.nanmedian(full[a:b + 1])) - ref) <= 0.2:
                continue
        # The time functions depend on t_c, which the closure pick fixes only to its
        # interval, and a gradual closure starts the regime from an effective closure the
        # picks do not see: the line is refitted with t_c 20 % earlier and later (in time
        # since pumping started) and at the times of the pick's interval.
        fn = nolte_radial if regime == "radial" else nolte_linear
        tcs = [tc * 0.8, tc * 1.2] + _interval_times(closure, t_all, p_all, t0)
        alts = [fn(tt, x) for x in tcs if 0 < x < tt[a]]
        line, bud = _line_budget(F, p, a, b, q, alts)
        why_not = admissible(t[a:b + 1], p[a:b + 1], bud.value, line.slope > 0,
                             float(closure.value), p_isip, noise)
        if why_not is not None:
            rejected.append(f"a {regime}-flow line was rejected: {why_not}")
            continue
        return AfterClosureResult(
            True, regime, f"p against F_{regime[0].upper()} is straight from "
            f"{dta[a]:.0f} s to {dta[b]:.0f} s after closure (derivative slope "
            f"{ref:+.1f}); p_r is its intercept", bud.value, bud.low, bud.high, bud.level,
            bud, window=(float(t[a]), float(t[b])), line=line, slope=line.slope, **base)
    # Exponential approach (constant-productivity leak of a closed system).
    model = ExponentialDeclineModel()
    try:
        res = model.fit(p, model.guess(p, dta), t=dta)
        tau = float(res.params["tau"].value)
        pr = float(res.params["p_r"].value)
        se = res.params["p_r"].stderr
        resid = p - res.best_fit
        good = (res.success and float(np.std(resid)) <= 2.0 * max(sig, q / math.sqrt(12))
                and dta[-1] >= tau and se is not None and np.isfinite(se))
    except (ValueError, TypeError, RuntimeError):
        good, res = False, None
    if good:
        why_not = admissible(t, p, pr, float(res.params["amplitude"].value) > 0,
                             float(closure.value), p_isip, noise)
        if why_not is not None:
            rejected.append(f"an exponential approach was rejected: {why_not}")
            good = False
    if good:
        trials = []
        n = p.size
        for lo, hi in ((0, 2 * n // 3), (n // 3, n)):
            try:
                r2 = model.fit(p[lo:hi], model.guess(p[lo:hi], dta[lo:hi]), t=dta[lo:hi])
                trials.append(float(r2.params["p_r"].value))
            except (ValueError, TypeError, RuntimeError):
                pass
        bud = budget(pr, stderr=float(se), inflation=correlation_inflation(resid),
                     trials=trials, resolution=0.5 * q)
        return AfterClosureResult(
            True, "exponential", f"the pressure approaches p_r exponentially (decay time "
            f"{tau:.0f} s, {dta[-1] / tau:.1f} decay times recorded): a closed system leaking "
            "through a constant productivity", bud.value, bud.low, bud.high, bud.level, bud,
            window=(float(t[0]), float(t[-1])), slope=tau, fit_report=res.fit_report(),
            **base)
    why = (f"after-closure flow not reached: the record ends {dta[-1]:.0f} s after closure "
           f"(t/t_c = {span:.2f})")
    if dslope is not None:
        why += (f"; the derivative's log-log slope is {dslope:+.2f} at the end, neither -1/2 "
                "(linear) nor -1 (radial flow)")
        if not rejected:
            why += ", and no exponential approach fits"
    if rejected:
        why += "; " + "; ".join(rejected)
    return AfterClosureResult(False, None, why, **base)
