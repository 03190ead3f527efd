"""Plots of the DFIT diagnostics: the log-log flow-regime plot and the after-closure plot.

Built on :class:`matplotlib.figure.Figure` directly (no pyplot state). Field units: bar and
seconds.
"""

from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.figure import Figure

from xlotkit.interpret.diagnostics.loglog import REGIMES
from xlotkit.interpret.plots.labels import LabelPlacer
from xlotkit.interpret.plots.picks import interval_text

__all__ = ["plot_after_closure", "plot_loglog"]

_BAR = 1e5
_SLOPE_TEXT = {1.0: "1", 0.75: "¾", 0.5: "½", 0.25: "¼", 0.0: "0", -0.5: "−½", -1.0: "−1"}
_WINDOW = dict(color="gold", alpha=0.25, lw=0, zorder=0)
_FIT_NAME = {"linear": "after-closure linear-flow line", "radial":
             "after-closure radial-flow line", "exponential": "after-closure exponential"}
_REGIME_COLORS = {1.0: "0.6", 0.75: "tab:purple", 0.5: "tab:blue", 0.25: "tab:cyan",
                  0.0: "tab:green", -0.5: "tab:orange", -1.0: "tab:red"}


def _fig(figsize=(8.5, 5.4)):
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.subplots()


def plot_loglog(cp, cd) -> Figure:
    """dp = ISIP - p and its Bourdet derivative against dt, log-log: the flow-regime slopes
    (1 storage, ¾ and ¼ fracture-dominated, ½ linear, 0 radial, −½ and −1 after-closure
    linear and radial) drawn as reference lines through the derivative, every regime found
    shaded and named, closure marked with its interval in time."""
    fig, ax = _fig()
    ll = cd.loglog
    if ll is None:
        ax.text(0.5, 0.5, "no usable shut-in", transform=ax.transAxes, ha="center")
        return fig
    ax.loglog(ll.dt, ll.dp / _BAR, ".", ms=2, color="tab:blue",
              label="Δp = ISIP − p")
    ax.loglog(ll.dt, ll.derivative / _BAR, ".", ms=2, color="tab:red",
              label="Bourdet derivative Δt·dΔp/dΔt")
    placer = LabelPlacer()
    # Reference slopes: short lines through the derivative, the positive ones early, the
    # after-closure (negative) ones late.
    lx = np.log10(ll.dt)
    slope_marks = []
    for frac in (0.15, 0.85):
        k = int(np.argmin(np.abs(lx - (lx[0] + frac * (lx[-1] - lx[0])))))
        x0, y0 = ll.dt[k], ll.derivative[k] / _BAR
        for s, _ in REGIMES:
            if (frac < 0.5) == (s < 0):
                continue
            # (inside the data's range, so that the slope's name lies in the plot)
            xx = np.clip(x0 * 10 ** np.array([-0.3, 0.3]), ll.dt[0], ll.dt[-1])
            ax.loglog(xx, y0 * (xx / x0) ** s, "-", color=_REGIME_COLORS[s], lw=0.8,
                      alpha=0.7)
            slope_marks.append((float(xx[1]), float(y0 * (xx[1] / x0) ** s),
                                _SLOPE_TEXT[s], _REGIME_COLORS[s]))
    used = set()
    for r in ll.regimes:
        ax.axvspan(r.dt_start, r.dt_end, color=_REGIME_COLORS[r.slope], alpha=0.12, lw=0,
                   label=None if r.name in used else
                   f"{r.name} (slope {_SLOPE_TEXT[r.slope]})")
        used.add(r.name)
    ac = cd.after_closure
    if ac.reached and ac.window is not None and ll.t_stop is not None:
        ax.axvspan(ac.window[0] - ll.t_stop, ac.window[1] - ll.t_stop, **_WINDOW,
                   label=f"data window used: {_FIT_NAME[ac.regime]}")
    cl = cd.closure
    if ll.dt_closure is not None and cl is not None:
        ax.axvline(ll.dt_closure, color="k", ls=":", lw=1, label="closure")
        t_s = cl.t - ll.dt_closure
        lo, hi = _times_of_interval(cd, cl)
        if lo is not None:
            ax.axvspan(lo - t_s, hi - t_s, color="k", alpha=0.08, lw=0,
                       label=f"closure {100 * cl.level:.0f} % interval" if cl.level
                       else "closure range")
        y = float(np.interp(ll.dt_closure, ll.dt, ll.derivative)) / _BAR
        placer.add(ax, ll.dt_closure, y, interval_text(cl, "closure"), "k")
    # (after the closure label: the slopes' names may move, the pick's should not)
    for x, y, text, col in slope_marks:
        placer.add(ax, x, y, text, col, fontsize=7, marker=False)
    ax.set_xlim(ll.dt[0] * 0.8, ll.dt[-1] * 1.25)
    lo_y = np.nanmin(ll.derivative[ll.derivative > 0]) / _BAR
    hi_y = np.nanmax(ll.dp) / _BAR
    ax.set_ylim(lo_y / 3, hi_y * 3)
    ax.set_xlabel("time since pump stop Δt [s]")
    ax.set_ylabel("Δp and derivative [bar]")
    ax.set_title(f"cycle {cp.index}: log-log diagnostic plot with flow-regime slopes",
                 fontsize=10)
    ax.grid(alpha=0.3, which="both")
    placer.legend(ax, prefer="upper left", fontsize=7)
    placer.place(fig)
    return fig


def _times_of_interval(cd, pick):
    """Record times at which the decline crossed the pick's interval bounds."""
    g = cd.g_function
    if g is None or pick.low is None or pick.high is None:
        return None, None
    t, p = g.t, g.p
    out = []
    for level in (pick.high, pick.low):
        idx = np.flatnonzero(p <= level)
        out.append(float(t[idx[0]]) if idx.size else float(t[-1]))
    return out[0], out[1]


def plot_after_closure(cp, cd) -> Figure:
    """After-closure plot: pressure against Nolte's time function of the regime found (time
    since closure for the exponential), the data window fitted as a band, the line (or
    exponential) extrapolated to the reservoir pressure with its interval as a band; or why
    the after-closure flow was not reached."""
    fig, ax = _fig()
    ac = cd.after_closure
    if ac.t.size == 0:
        ax.text(0.5, 0.5, "\n".join(textwrap.wrap(ac.message, 90)), transform=ax.transAxes,
                ha="center", va="center", fontsize=8)
        ax.set_title(f"cycle {cp.index}: after-closure analysis", fontsize=10)
        ax.set_axis_off()
        return fig
    placer = LabelPlacer()
    if ac.regime == "exponential":
        x = ac.t - ac.t_closure
        ax.plot(x, ac.p / _BAR, ".", ms=2, color="tab:blue", label="after-closure pressure")
        if ac.window is not None:
            ax.axvspan(ac.window[0] - ac.t_closure, ac.window[1] - ac.t_closure, **_WINDOW,
                       label="data window used: exponential fitted")
        tau = ac.slope
        pr = ac.reservoir_pressure
        a = ac.p[0] - pr
        xx = np.linspace(0, x[-1] * 1.3, 100)
        ax.plot(xx, (pr + a * np.exp(-xx / tau)) / _BAR, "--", color="k",
                label=f"exponential approach (decay time {tau:.0f} s)")
        xlabel = "time since closure [s]"
        x_pr = xx[-1]
    else:
        F = ac.f_radial if ac.regime == "radial" else ac.f_linear
        name = "F_R (radial)" if ac.regime == "radial" else "F_L (linear)"
        if ac.regime is None:
            F, name = ac.f_linear, "F_L (linear)"
        if F.size != ac.p.size:      # too few samples for the time functions
            F, name = ac.t - ac.t_closure, None
        ax.plot(F, ac.p / _BAR, ".", ms=2, color="tab:blue", label="after-closure pressure")
        if ac.window is not None and ac.line is not None:
            w = (ac.t >= ac.window[0]) & (ac.t <= ac.window[1])
            ax.axvspan(float(F[w].min()), float(F[w].max()), **_WINDOW,
                       label=f"data window used: {ac.regime}-flow line fitted")
            xx = np.linspace(0.0, float(F[w].max()) * 1.1, 50)
            ax.plot(xx, ac.line(xx) / _BAR, "--", color="k",
                    label=f"{ac.regime}-flow line extrapolated to F = 0")
        xlabel = (f"Nolte's after-closure time function {name}" if name is not None
                  else "time since closure [s]")
        x_pr = 0.0
    if ac.reached and ac.reservoir_pressure is not None:
        ax.axhspan(ac.low / _BAR, ac.high / _BAR, color="tab:green", alpha=0.18, lw=0,
                   label=f"reservoir pressure {100 * ac.level:.0f} % interval")
        txt = (f"reservoir pressure {ac.reservoir_pressure / _BAR:.1f} bar, "
               f"{100 * ac.level:.0f} %: {ac.low / _BAR:.1f}-{ac.high / _BAR:.1f}")
        placer.add(ax, x_pr, ac.reservoir_pressure / _BAR, txt, "tab:green")
        if ac.regime != "exponential":
            ax.set_xlim(left=-0.02 * max(float(np.nanmax(ax.get_xlim())), 1e-9))
    else:
        placer.note(ax, ac.message, prefer="lower left")
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo - 0.08 * (hi - lo), hi + 0.08 * (hi - lo))
    ax.set_xlabel(xlabel)
    ax.set_ylabel("pressure [bar]")
    ax.set_title(f"cycle {cp.index}: after-closure analysis", fontsize=10)
    ax.grid(alpha=0.3)
    placer.legend(ax, prefer="upper left" if ac.regime != "exponential" else "upper right")
    placer.place(fig)
    return fig
