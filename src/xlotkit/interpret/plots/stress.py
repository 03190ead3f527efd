"""Plots of stress estimates: the stress polygon and the hoop stress around the hole.

Figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot state), so they are
safe in scripts, threads and the Agg backend. Stresses are drawn in MPa; the inputs are SI.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from xlotkit.atomic import save_figure
from xlotkit.errors import InputError
from xlotkit.interpret.stress import (
    SigmaHEstimate,
    SigmaHEstimates,
    Uncertain,
    as_uncertain,
    hoop_stress_at_wall,
    kirsch_stresses,
    stress_polygon,
)

__all__ = ["plot_hoop_stress", "plot_stress_polygon"]

_MPA = 1e-6
_REGION_STYLE = {
    "normal": ("#9ecae1", "NF"),
    "strike-slip": ("#a1d99b", "SS"),
    "reverse": ("#fdae6b", "RF"),
}
_EQ_STYLE = {"C.18": ("tab:red", "s"), "C.19": ("tab:purple", "o")}


def _save(fig: Figure, path: str | Path | None) -> None:
    if path is not None:
        save_figure(fig, path, dpi=150)


def _estimate_points(estimate: Any
                     ) -> tuple[Uncertain, list[tuple[str, Uncertain | SigmaHEstimate]]]:
    """Normalise the ``estimate`` argument of :func:`plot_stress_polygon`."""
    if isinstance(estimate, SigmaHEstimates):
        return estimate.sigma_h, list(estimate.items())
    if isinstance(estimate, tuple) and len(estimate) == 2:
        sh = as_uncertain(estimate[0], "estimate[0]")
        sH = estimate[1]
        if isinstance(sH, SigmaHEstimates):
            return sh, list(sH.items())
        if isinstance(sH, SigmaHEstimate):
            return sh, [(sH.equation, sH)]
        return sh, [("estimate", as_uncertain(sH, "estimate[1]"))]
    raise InputError(f"cannot plot estimate {estimate!r}", key="estimate",
                     expected="SigmaHEstimates from sigma_H_estimates, or (sigma_h, sigma_H)")


def _label_spot(v: np.ndarray, marks: np.ndarray) -> np.ndarray:
    """Where to write a region's name: its centroid, or, when estimates are drawn, whichever
    of the centroid and three points pulled towards the corners is farthest from them."""
    cands = [v.mean(axis=0)] + [0.6 * v[i] + 0.2 * (v.sum(axis=0) - v[i]) for i in range(3)]
    if marks.size == 0:
        return cands[0]
    return max(cands, key=lambda c: float(np.nanmin(np.hypot(*(marks - c).T))))


def plot_stress_polygon(sv: float, p0: float, mu: float, estimate: Any = None, *, ax=None,
                        path: str | Path | None = None) -> Figure:
    """Draw the stress polygon in (sigma_h, sigma_H) with the regimes and an estimate.

    Parameters
    ----------
    sv, p0 : float
        Vertical stress and pore pressure [Pa].
    mu : float
        Friction coefficient (see :func:`xlotkit.interpret.stress.stress_polygon`).
    estimate : SigmaHEstimates or tuple, optional
        The result of :func:`~xlotkit.interpret.stress.sigma_H_estimates` (sigma_h with its
        interval, one point per equation with its percentile interval), or a pair
        ``(sigma_h, sigma_H)`` of numbers, :class:`~xlotkit.interpret.stress.Uncertain`
        values or a :class:`~xlotkit.interpret.stress.SigmaHEstimate`.
    ax : matplotlib.axes.Axes, optional
        Draw into these axes instead of a new figure.
    path : str or Path, optional
        Save the figure there (format from the extension).

    Returns
    -------
    matplotlib.figure.Figure
    """
    poly = stress_polygon(sv, p0, mu)
    if ax is None:
        fig = Figure(figsize=(6.4, 6.0), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure

    sh_est, points = _estimate_points(estimate) if estimate is not None else (None, [])
    marks = np.array([[sh_est.value, (p.value if p.value is not None else np.nan)]
                      for _, p in points]) * _MPA if points else np.empty((0, 2))
    for name, verts in poly.regions.items():
        color, label = _REGION_STYLE[name]
        v = verts * _MPA
        ax.fill(v[:, 0], v[:, 1], color=color, alpha=0.55, lw=0, label=f"{label} ({name})")
        ax.annotate(label, _label_spot(v, marks), ha="center", va="center", fontsize=12,
                    weight="bold", color="0.25", zorder=2)
    outline = np.vstack([poly.vertices, poly.vertices[:1]]) * _MPA
    ax.plot(outline[:, 0], outline[:, 1], color="k", lw=1.5)
    s = poly.sv * _MPA
    ax.plot([s, s], [s, poly.sigma_H_max * _MPA], color="0.4", lw=0.8, ls=":")
    ax.plot([poly.sigma_h_min * _MPA, s], [s, s], color="0.4", lw=0.8, ls=":")
    ax.plot([s], [s], marker="o", mfc="white", mec="k", ms=6, ls="none",
            label=r"$\sigma_h = \sigma_H = \sigma_v$")

    hi = poly.sigma_H_max * _MPA
    lo = poly.p0 * _MPA
    pad = 0.05 * (hi - lo)
    xmax = hi + pad

    if sh_est is not None:
        sh = sh_est
        shv = sh.value * _MPA
        shlo, shhi = (v * _MPA for v in sh.interval)
        for name, pt in points:
            color, marker = _EQ_STYLE.get(name, ("tab:blue", "D"))
            if isinstance(pt, SigmaHEstimate):
                y, ylo, yhi = pt.value, pt.low, pt.high
                label = (rf"Eq. {name}: $\sigma_H$ = {pt.value * _MPA:.1f} MPa "
                         rf"(P{pt.percentiles[0]:g}-P{pt.percentiles[1]:g} "
                         rf"{pt.low * _MPA:.1f}-{pt.high * _MPA:.1f})")
            else:
                y = pt.value
                ylo, yhi = pt.interval
                label = rf"$\sigma_H$ = {y * _MPA:.1f} MPa"
            y, ylo, yhi = y * _MPA, ylo * _MPA, yhi * _MPA
            ax.errorbar([shv], [y], xerr=[[shv - shlo], [shhi - shv]],
                        yerr=[[max(y - ylo, 0.0)], [max(yhi - y, 0.0)]], fmt=marker, color=color,
                        ms=7, capsize=4, lw=1.5, label=label, zorder=5)
            xmax = max(xmax, shhi + pad, yhi + pad)
        ax.axvline(shv, color="0.5", lw=0.6, ls="--", zorder=1)

    # The sigma_h = sigma_H line bounds the physically labelled half-plane.
    ax.plot([lo, xmax], [lo, xmax], color="k", lw=0.8, ls="--", label=r"$\sigma_h = \sigma_H$")
    ax.set_xlim(lo, xmax)
    ax.set_ylim(lo, xmax)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel(r"$\sigma_h$ [MPa]")
    ax.set_ylabel(r"$\sigma_H$ [MPa]")
    ax.set_title(rf"Stress polygon: $\sigma_v$ = {s:.1f} MPa, $p_0$ = {lo:.1f} MPa, "
                 rf"$\mu$ = {poly.mu:g}", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.6)
    # Below the sigma_h = sigma_H line nothing is drawn: room for the legend.
    ax.legend(loc="lower right", fontsize=8, framealpha=0.9)
    _save(fig, path)
    return fig


def plot_hoop_stress(sigma_H: float, sigma_h: float, p_w: float | Sequence[float], *,
                     p0: float | None = None, T0: float | None = None, a: float = 0.108,
                     r_max: float = 6.0, ax=None, path: str | Path | None = None) -> Figure:
    """Kirsch stresses around the hole (Eq. C.7 / C.8) for one or more well pressures.

    Left panel: hoop stress on the wall against azimuth from sigma_H (Eq. C.8b). With ``p0``
    and ``T0`` the tensile-failure level ``sigma_tt = p0 - T0`` (Eq. C.9) is drawn; a curve
    touching it means breakdown. Right panel: hoop and radial stress along the sigma_H azimuth
    (``theta = 0``, where fractures start) against ``r / a`` (Eq. C.7a/b).

    Parameters
    ----------
    sigma_H, sigma_h : float
        Far-field maximum and minimum horizontal stress [Pa].
    p_w : float or sequence of float
        Well pressure(s) [Pa]; one curve each.
    p0, T0 : float, optional
        Pore pressure and tensile strength [Pa] for the failure line.
    a : float, default 0.108
        Hole radius [m] (8 1/2 in bit); only sets the r axis.
    r_max : float, default 6
        Right panel extends to ``r = r_max * a``.
    ax : pair of Axes, optional
        Draw into these (wall panel, radial panel) instead of a new figure.
    path : str or Path, optional
        Save the figure there.

    Returns
    -------
    matplotlib.figure.Figure
    """
    pws = np.atleast_1d(np.asarray(p_w, dtype=float))
    if r_max <= 1:
        raise InputError(f"r_max = {r_max!r}", key="r_max", expected="r_max > 1 (in hole radii)")
    if ax is None:
        fig = Figure(figsize=(11.0, 4.6), layout="constrained")
        ax_w, ax_r = fig.subplots(1, 2)
    else:
        try:
            ax_w, ax_r = ax
        except (TypeError, ValueError):
            raise InputError("ax must be a pair of Axes", key="ax",
                             expected="(wall_axes, radial_axes)") from None
        fig = ax_w.figure

    theta = np.linspace(0.0, 2.0 * np.pi, 361)
    rho = np.linspace(1.0, r_max, 300)
    colors = [f"C{i}" for i in range(10)]
    for i, pw in enumerate(pws):
        c = colors[i % 10]
        lab = f"$P_w$ = {pw * _MPA:.1f} MPa"
        ax_w.plot(np.degrees(theta), hoop_stress_at_wall(theta, sigma_H, sigma_h, pw) * _MPA,
                  color=c, label=lab)
        srr, stt, _ = kirsch_stresses(rho * a, 0.0, a, sigma_H, sigma_h, pw)
        ax_r.plot(rho, np.asarray(stt) * _MPA, color=c, label=rf"$\sigma_{{\theta\theta}}$, {lab}")
        ax_r.plot(rho, np.asarray(srr) * _MPA, color=c, ls="--",
                  label=rf"$\sigma_{{rr}}$, {lab}")
    if p0 is not None and T0 is not None:
        level = (p0 - T0) * _MPA
        ax_w.axhline(level, color="k", lw=1.0, ls="-.",
                     label=rf"tensile failure $p_0 - T_0$ = {level:.1f} MPa")
    ax_r.axhline(sigma_h * _MPA, color="0.4", lw=0.8, ls=":",
                 label=rf"far field $\sigma_h$ = {sigma_h * _MPA:.1f} MPa")
    ax_r.axhline(sigma_H * _MPA, color="0.6", lw=0.8, ls=":",
                 label=rf"far field $\sigma_H$ = {sigma_H * _MPA:.1f} MPa")

    ax_w.set_xlim(0, 360)
    ax_w.set_xticks(np.arange(0, 361, 45))
    ax_w.set_xlabel(r"azimuth from $\sigma_H$, $\theta$ [deg]")
    ax_w.set_ylabel(r"hoop stress at the wall $\sigma_{\theta\theta}$ [MPa]")
    ax_w.set_title("Wall (Eq. C.8b), compression positive", fontsize=10)
    ax_r.set_xlim(1.0, r_max)
    ax_r.set_xlabel(r"$r / a$")
    ax_r.set_ylabel("stress [MPa]")
    ax_r.set_title(r"Along the $\sigma_H$ azimuth, $\theta = 0$ (Eq. C.7)", fontsize=10)
    for axx in (ax_w, ax_r):
        axx.grid(True, lw=0.3, alpha=0.6)
        # Curves fill the panels; legends go underneath.
        axx.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2,
                   frameon=False)
    _save(fig, path)
    return fig
