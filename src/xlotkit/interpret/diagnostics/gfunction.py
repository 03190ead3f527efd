r"""G-function diagnostics: G dP/dG, its line through the origin, and the leak-off diagnosis.

With Carter leak-off from a fracture of constant area the shut-in pressure falls linearly in
Nolte's G (:func:`~xlotkit.interpret.picks.shutin.g_function`), ``p = ISIP - m G``, so the
superposition derivative ``G dP/dG`` (here as the positive ``-G dP/dG``) lies on the
straight line ``m G`` through the origin until closure, where it leaves the line. How it
departs from that line *before* closure tells how the fluid leaves the fracture (the
signatures of Barree et al. 2009, "Holistic fracture diagnostics"):

``normal``
    ``G dP/dG`` on the line through the origin: ``|dP/dG|`` constant (Carter leak-off,
    constant fracture area).
``pressure_dependent_leakoff``
    ``G dP/dG`` humps above the line early and then comes back onto it: ``|dP/dG|`` falls
    early (leak-off faster at high net pressure: fissures that open with pressure) and is
    constant over the later part before closure.
``tip_extension``
    ``G dP/dG`` is a straight line whose extension does *not* pass through the origin
    but above it: ``|dP/dG| = a / G + b`` keeps falling to closure (the fracture still grows
    after pump stop, fluid moving to the tip).
``height_recession``
    ``G dP/dG`` lies below the line through the origin tangent to it at closure (concave
    upward): ``|dP/dG|`` rises as the decline goes on (the fracture recedes from layers it
    had entered, the system stiffening gradually; a constant-permeability wall leak looks
    the same).
``undetermined``
    Too short a decline before closure, no closure, or ``|dP/dG|`` not resolved above the
    gauge's noise and resolution (the shape cannot be read from it).

Rules, with ``m`` the median ``|dP/dG|`` over the pre-closure span from 60 % of it to
just before closure (out of reach of the derivative's window: the line through the origin
tangent at closure, ``m G``), ``r_e`` the median ``|dP/dG|`` over its first third divided
by ``m``, and ``a + b G`` a straight line fitted to ``G |dP/dG|`` over the later half of the
span (``a_rel = a / (m G_c)``, its intercept as a fraction of ``G dP/dG`` at closure):

* either median ``|dP/dG|`` (early third; before closure) below :data:`RESOLVED` standard
  errors of the derivative (:func:`derivative_stderr`, over the independent windows of the
  span): undetermined, the derivative is not resolved;
* ``|r_e - 1| <= 0.1``: normal;
* ``r_e > 1.1``: tip extension when ``a_rel > 0.14`` (the later half still lies on a line
  above the origin), else pressure-dependent leak-off (the later half on the line through
  the origin);
* ``r_e < 0.9``: height recession.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from xlotkit.interpret.picks.models import LineFit, fit_line
from xlotkit.interpret.picks.pressurisation import noise_level
from xlotkit.interpret.picks.shutin import DERIVATIVE_L

__all__ = ["DIAGNOSES", "RESOLVED", "GFunctionDiagnosis", "derivative_stderr",
           "diagnose_curves", "diagnose_g_function"]

#: Standard errors by which ``|dP/dG|`` must exceed zero to be read (a 3-sigma detection:
#: noise alone makes a derivative that large with probability 0.3 %).
RESOLVED = 3.0

#: The diagnoses (module docstring).
DIAGNOSES = ("normal", "pressure_dependent_leakoff", "tip_extension", "height_recession",
             "undetermined")

_WORDS = {"normal": "normal leak-off",
          "pressure_dependent_leakoff": "pressure-dependent leak-off",
          "tip_extension": "fracture tip extension",
          "height_recession": "fracture height recession",
          "undetermined": "undetermined"}


@dataclass(frozen=True)
class GFunctionDiagnosis:
    """The G-function plot of one shut-in and what its shape says.

    Attributes
    ----------
    G : ndarray, shape (n,)
        Nolte's G of the post-drop shut-in samples.
    p : ndarray, shape (n,)
        Pressure [Pa].
    g_dpdg : ndarray, shape (n,)
        ``-G dP/dG`` [Pa] (log-G-windowed local slope).
    dpdg : ndarray, shape (n,)
        ``-dP/dG`` [Pa].
    diagnosis : str
        One of :data:`DIAGNOSES`.
    reason : str
        Why, in words (the numbers of the rule).
    g_closure : float or None
        G at closure (the departure from the line), None without a closure.
    p_closure : float or None
        Closure pressure [Pa] used.
    m : float or None
        ``|dP/dG|`` at closure [Pa]: the line ``m G`` through the origin.
    early_ratio : float or None
        ``r_e`` of the rule.
    late_line : LineFit or None
        ``G |dP/dG| = a + b G`` over the later half before closure.
    intercept_ratio : float or None
        ``a / (m G_c)``: the intercept of the late line as a fraction of ``G dP/dG`` at
        closure.
    window : (float, float) or None
        G range the diagnosis read (post-drop start to closure).
    t : ndarray, shape (n,)
        Sample times [s].
    """

    G: np.ndarray
    p: np.ndarray
    g_dpdg: np.ndarray
    dpdg: np.ndarray
    diagnosis: str
    reason: str
    g_closure: float | None = None
    p_closure: float | None = None
    m: float | None = None
    early_ratio: float | None = None
    late_line: LineFit | None = None
    intercept_ratio: float | None = None
    window: tuple[float, float] | None = None
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def words(self) -> str:
        """The diagnosis in words (for plots and reports)."""
        return _WORDS[self.diagnosis]

    def report(self) -> str:
        """One paragraph in field units."""
        s = f"G-function diagnosis: {self.words} ({self.reason})"
        if self.g_closure is not None and self.p_closure is not None:
            s += f"; closure at G = {self.g_closure:.3g}, {self.p_closure / 1e5:.1f} bar"
            if self.m is not None:
                s += f", |dP/dG| = {self.m / 1e5:.3g} bar"
        return s + "."


def derivative_stderr(G: np.ndarray, p: np.ndarray, L: float = DERIVATIVE_L,
                      min_points: int = 5) -> np.ndarray:
    """Standard error [Pa] of the local slope ``dP/dG`` at every sample.

    The slope is the least-squares line over the window ``|ln G_j - ln G_i| <= L``
    (widened to ``min_points`` samples), as
    :func:`~xlotkit.interpret.picks.pressurisation.local_fit` takes it, so its error is
    ``sigma / sqrt(S_GG)`` with ``S_GG`` the window's sum of squared deviations of G and
    ``sigma`` the pressure's noise (floored by the quantisation error ``q / sqrt(12)``).

    Parameters
    ----------
    G, p : ndarray, shape (n,)
        Nolte's G (increasing) and pressure [Pa].
    """
    G = np.asarray(G, float)
    n = G.size
    u = np.log(np.maximum(G, 1e-12))
    idx = np.arange(n)
    lo = np.searchsorted(u, u - L, side="left")
    hi = np.searchsorted(u, u + L, side="right")
    k = max(min_points, 2) // 2
    lo = np.clip(np.minimum(lo, idx - k), 0, n)
    hi = np.clip(np.maximum(hi, idx + k + 1), 0, n)
    gc = G - G.mean() if n else G
    z = np.zeros(1)
    c1 = np.concatenate([z, np.cumsum(np.ones(n))])
    cx = np.concatenate([z, np.cumsum(gc)])
    cxx = np.concatenate([z, np.cumsum(gc * gc)])
    nn = c1[hi] - c1[lo]
    sx = cx[hi] - cx[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        sgg = (cxx[hi] - cxx[lo]) - sx * sx / nn
        return noise_level(np.asarray(p, float)) / np.sqrt(np.where(sgg > 0, sgg, np.nan))


def _span_error(g: np.ndarray, se: np.ndarray) -> float:
    """Error of a span's median local slope: the median error over the independent
    windows (each ``2 L`` wide in ln G) the span holds."""
    n_ind = max(1.0, math.log(g[-1] / max(g[0], 1e-12)) / (2.0 * DERIVATIVE_L))
    return float(np.nanmedian(se)) / math.sqrt(n_ind)


def diagnose_curves(G: np.ndarray, dpdg_abs: np.ndarray, g_closure: float | None,
                    p: np.ndarray | None = None
                    ) -> tuple[str, str, float | None, float | None, LineFit | None,
                               float | None]:
    """The rule of the module docstring on ``|dP/dG|(G)`` before ``g_closure``.

    Parameters
    ----------
    G, dpdg_abs : ndarray, shape (n,)
        Nolte's G and ``|dP/dG|`` [Pa] (local slopes over the window ``DERIVATIVE_L``).
    g_closure : float or None
    p : ndarray, shape (n,), optional
        Pressure [Pa]: when given, the derivative must be resolved above the gauge's noise
        and resolution (:func:`derivative_stderr`) before a shape is read from it.

    Returns
    -------
    diagnosis, reason, m, early_ratio, late_line, intercept_ratio
    """
    if g_closure is None or not np.isfinite(g_closure):
        return "undetermined", "no closure on the G plot", None, None, None, None
    G = np.asarray(G, float)
    d = np.asarray(dpdg_abs, float)
    pre = (G <= g_closure) & np.isfinite(d) & (G > 0)
    if pre.sum() < 15:
        return ("undetermined", f"too short a decline before closure ({int(pre.sum())} "
                "samples)", None, None, None, None)
    g, dd = G[pre], d[pre]
    g0 = float(g[0])
    span = g_closure - g0
    # |dP/dG| just before closure, out of reach of the derivative's window (+-DERIVATIVE_L
    # in ln G), which would otherwise mix the after-closure slope in.
    g_hi = g_closure * math.exp(-1.5 * DERIVATIVE_L)
    sel = (g >= g0 + 0.6 * span) & (g <= g_hi)
    if sel.sum() < 3:
        sel = g >= g0 + 0.85 * span
    m = float(np.median(dd[sel]))
    if not m > 0:
        return "undetermined", "pressure not falling before closure", None, None, None, None
    in_early = g <= g0 + span / 3.0
    early = dd[in_early]
    if early.size < 5:
        return "undetermined", "too few samples early in the decline", m, None, None, None
    e_med = float(np.median(early))
    if p is not None:
        se = derivative_stderr(G, p)[pre]
        err_e = _span_error(g[in_early], se[in_early])
        err_c = _span_error(g[sel], se[sel])
        if not (e_med >= RESOLVED * err_e and m >= RESOLVED * err_c):
            return ("undetermined", f"|dP/dG| is not resolved above the gauge's noise and "
                    f"resolution: {e_med / 1e5:.2f} ± {err_e / 1e5:.2f} bar early in the "
                    f"decline, {m / 1e5:.2f} ± {err_c / 1e5:.2f} bar before closure "
                    f"({RESOLVED:.0f} standard errors needed to read its shape)",
                    m, None, None, None)
    r_e = e_med / m
    late = (g >= g0 + 0.5 * span) & (g <= g_hi)
    line = fit_line(g[late], g[late] * dd[late]) if late.sum() >= 5 else None
    a_rel = line.intercept / (m * g_closure) if line is not None else None
    if abs(r_e - 1.0) <= 0.1:
        return ("normal", f"|dP/dG| early {r_e:.2f} of its value at closure: G dP/dG on "
                "the line through the origin", m, r_e, line, a_rel)
    if r_e > 1.1:
        if a_rel is not None and a_rel > 0.14:
            return ("tip_extension", f"|dP/dG| falls to closure ({r_e:.2f} times its "
                    "value at closure early on); G dP/dG is a straight line whose extension "
                    f"meets G = 0 above the origin, at {a_rel:.2f} of its value at closure",
                    m, r_e, line, a_rel)
        return ("pressure_dependent_leakoff", f"G dP/dG humps above the line early "
                f"(|dP/dG| {r_e:.2f} of its value at closure) and returns to the line "
                "through the origin", m, r_e, line, a_rel)
    return ("height_recession", f"G dP/dG below the line through the origin (|dP/dG| early "
            f"{r_e:.2f} of its value at closure, rising as the decline goes on)", m, r_e,
            line, a_rel)


def diagnose_g_function(record, cycle, closure=None, *, alpha: float = 1.0
                        ) -> GFunctionDiagnosis | None:
    """G-function plot and leak-off diagnosis of a cycle's shut-in.

    Parameters
    ----------
    record : Record
    cycle : Cycle
    closure : Pick, optional
        The closure pick whose time marks the departure (default: none, diagnosis
        ``undetermined``). A pick whose time lies outside the shut-in is ignored.
    alpha : {1, 0.5}
        Area-growth exponent of the G-function.

    Returns
    -------
    GFunctionDiagnosis or None
        None when the cycle has no usable shut-in.
    """
    from xlotkit.interpret.picks.shutin import shutin_curves

    c = shutin_curves(record, cycle, alpha=alpha)
    if c is None or c["t"].size < 10:
        return None
    G, p, t = c["G"], c["p"], c["t"]
    dpdg = -c["dp_dG"]
    gc = pc = None
    if closure is not None and getattr(closure, "found", False) and closure.t is not None \
            and t[0] <= closure.t <= t[-1]:
        gc = float(np.interp(closure.t, t, G))
        pc = float(closure.value)
    diag, why, m, r_e, line, a_rel = diagnose_curves(G, dpdg, gc, p)
    win = (float(G[0]), gc) if gc is not None else None
    return GFunctionDiagnosis(G, p, c["G_dp_dG"], dpdg, diag, why, gc, pc, m, r_e, line,
                              a_rel, win, t)
