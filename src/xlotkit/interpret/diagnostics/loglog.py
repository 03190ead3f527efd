r"""Log-log diagnostics of a shut-in: ``dp`` and its Bourdet derivative against ``dt``.

``dp = ISIP - p(dt)`` is the pressure fallen since pump stop and
``dp' = d(dp) / d ln(dt) = dt d(dp)/d(dt)`` its Bourdet derivative, computed as a
least-squares slope over a window of constant width in ``ln(dt)`` (Bourdet's smoothing,
:func:`~xlotkit.interpret.picks.pressurisation.local_fit`). For a power law
``dp ~ dt^n`` both curves are straight with slope ``n`` on log-log axes, so the slope of the
derivative names the flow regime:

====== ==========================================================
slope  regime
====== ==========================================================
1      storage (well or fracture): ``dp`` proportional to ``dt``
3/4    fracture-dominated (3/4 slope)
1/2    linear flow (formation linear flow from the fracture faces)
1/4    bilinear / fracture-dominated (1/4 slope)
0      radial flow (derivative flat)
-1/2   after-closure linear flow (``p - p_r ~ t^-1/2``)
-1     after-closure radial flow (``p - p_r ~ 1/t``)
====== ==========================================================

A regime is reported where the derivative's own log-log slope stays within
:data:`SLOPE_TOLERANCE` of one of these over at least :data:`MIN_DECADES` of ``dt``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from xlotkit.interpret.picks.pressurisation import local_fit

__all__ = ["MIN_DECADES", "REGIMES", "SLOPE_TOLERANCE", "FlowRegime", "LogLogDiagnostics",
           "find_regimes", "loglog_diagnostics"]

#: Reference slopes and their names.
REGIMES = ((1.0, "storage"), (0.75, "fracture-dominated (3/4)"), (0.5, "linear flow"),
           (0.25, "bilinear / fracture-dominated (1/4)"), (0.0, "radial flow"),
           (-0.5, "after-closure linear flow"), (-1.0, "after-closure radial flow"))
#: Largest distance of the measured slope from a reference slope.
SLOPE_TOLERANCE = 0.08
#: Shortest stretch of a regime, in decades of dt.
MIN_DECADES = 0.2


@dataclass(frozen=True)
class FlowRegime:
    """A stretch of the derivative with one reference slope.

    Attributes
    ----------
    name : str
    slope : float
        Reference slope.
    measured : float
        Median measured slope over the stretch.
    dt_start, dt_end : float
        The stretch [s since pump stop].
    """

    name: str
    slope: float
    measured: float
    dt_start: float
    dt_end: float

    @property
    def decades(self) -> float:
        """Length of the stretch in decades of dt."""
        return float(np.log10(self.dt_end / self.dt_start))


@dataclass(frozen=True)
class LogLogDiagnostics:
    """``dp`` and its Bourdet derivative against ``dt`` with the flow regimes found.

    Attributes
    ----------
    dt, dp, derivative : ndarray, shape (n,)
        [s], [Pa], [Pa] (positive samples only).
    slope : ndarray, shape (n,)
        Log-log slope of the derivative.
    regimes : tuple of FlowRegime
    isip : float
        Reference pressure of ``dp`` [Pa].
    dt_closure : float or None
        Closure [s since pump stop], if picked inside the shut-in.
    t_stop : float or None
        Pump stop [s, record time]: the origin of ``dt``.
    """

    dt: np.ndarray
    dp: np.ndarray
    derivative: np.ndarray
    slope: np.ndarray
    regimes: tuple[FlowRegime, ...] = field(default_factory=tuple)
    isip: float = 0.0
    dt_closure: float | None = None
    t_stop: float | None = None

    def report(self) -> str:
        """The regimes in words."""
        if not self.regimes:
            return "log-log: no flow regime with a reference slope held over 0.2 decades"
        parts = [f"{r.name} (slope {r.measured:+.2f}, {r.dt_start:.0f}-{r.dt_end:.0f} s)"
                 for r in self.regimes]
        return "log-log regimes: " + "; ".join(parts)


def find_regimes(dt: np.ndarray, slope: np.ndarray, *, tolerance: float = SLOPE_TOLERANCE,
                 min_decades: float = MIN_DECADES) -> tuple[FlowRegime, ...]:
    """Stretches where ``slope`` stays within ``tolerance`` of a reference slope."""
    dt = np.asarray(dt, float)
    slope = np.asarray(slope, float)
    out: list[FlowRegime] = []
    for ref, name in REGIMES:
        ok = np.isfinite(slope) & (np.abs(slope - ref) <= tolerance)
        d = np.diff(np.concatenate([[0], ok.astype(int), [0]]))
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            if b - a >= 5 and np.log10(dt[b - 1] / dt[a]) >= min_decades:
                out.append(FlowRegime(name, ref, float(np.median(slope[a:b])),
                                      float(dt[a]), float(dt[b - 1])))
    out.sort(key=lambda r: r.dt_start)
    return tuple(out)


def loglog_diagnostics(record, cycle, *, isip=None, closure=None, L: float = 0.15
                       ) -> LogLogDiagnostics | None:
    """Log-log plot data and flow regimes of a cycle's shut-in.

    Parameters
    ----------
    record, cycle
    isip : Pick or float, optional
        Reference pressure of ``dp`` (default: the first post-drop pressure).
    closure : Pick, optional
        Marks closure on the plot (when its time lies in the shut-in).
    L : float
        Half-width of the Bourdet window in ``ln(dt)``.

    Returns
    -------
    LogLogDiagnostics or None
        None without a usable shut-in.
    """
    from xlotkit.interpret.picks.shutin import shutin_curves

    c = shutin_curves(record, cycle)
    if c is None or c["t"].size < 10:
        return None
    dt, p = c["dt"], c["p"]
    ref = getattr(isip, "value", isip) if isip is not None else None
    ref = float(ref) if ref is not None else float(p[0])
    dp = ref - p
    u = np.log(dt)
    slope_t, _ = local_fit(u, dp, L, min_points=5)   # d(dp)/d ln dt
    der = slope_t
    ok = (dp > 0) & (der > 0) & np.isfinite(der)
    dt, dp, der = dt[ok], dp[ok], der[ok]
    if dt.size < 10:
        return None
    s, _ = local_fit(np.log(dt), np.log(der), 2 * L, min_points=5)
    dtc = None
    t_s = float(c["t"][0] - c["dt"][0])
    if (closure is not None and getattr(closure, "found", False) and closure.t is not None
            and c["t"][0] <= closure.t <= c["t"][-1]):
        dtc = float(closure.t - t_s)
    return LogLogDiagnostics(dt, dp, der, s, find_regimes(dt, s), ref, dtc, t_s)
