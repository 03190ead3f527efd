"""Annotated plots of an XLOT record and its picks, for an engineer to read at a glance.

Every function returns a :class:`matplotlib.figure.Figure` built directly (no pyplot, so no
global state and no GUI backend); save it with ``fig.savefig(path)``. Field units: pressure in
bar, rate in l/min, time in minutes (shut-in and flowback plots in seconds since the event,
where the square root is taken).

Conventions of every plot:

* each pick is marked and labelled with its value and its interval at the stated level
  (``FCP 261.9 bar, 90 %: 261.5-262.6``); labels are placed clear of each other and of the
  curves (:mod:`~xlotkit.interpret.plots.labels`);
* the interval of the plot's pick is drawn as a band, the data window the method used as a
  shaded span;
* legends name things in words (``line before closure``, ``closed-fracture line``), never
  by internal keys.

The fitted lines drawn are read from each pick's typed ``details``
(:mod:`~xlotkit.interpret.picks.details`: slopes and intercepts in SI, on the plot's own
abscissa); derivatives shown (dP/d sqrt(t), dP/dG, G dP/dG, dp/dt) are
local least-squares slopes over a sliding window, not raw differences, so that pressure
quantised to 0.1-1 bar still gives a readable curve.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

from xlotkit.interpret.picks.core import CyclePicks, RecordPicks
from xlotkit.interpret.picks.details import (
    BilinearDetails,
    FlowbackDetails,
    LineDetails,
    PressurisationDetails,
    ShutinDepartureDetails,
    ShutinDetails,
    SlopeBreakDetails,
)
from xlotkit.interpret.picks.types import Pick
from xlotkit.interpret.plots.labels import LabelPlacer
from xlotkit.record import Record

__all__ = [
    "METHOD_WORDS",
    "g_function",
    "interval_text",
    "pick_figures",
    "plot_bilinear",
    "plot_flowback_p_v",
    "plot_flowback_sqrt_p",
    "plot_g_function",
    "plot_overview",
    "plot_p_v",
    "plot_sqrt_t",
]

_BAR = 1e5
_LPM = 60_000.0  # m^3/s -> l/min
_COLORS = {"LOP": "tab:orange", "Pr": "tab:orange", "FBP": "tab:red", "FPP": "tab:purple",
           "ISIP": "tab:brown", "FCP": "tab:green", "T0": "k"}
_METHOD_COLORS = {"tangent": "tab:olive", "sqrt_t": "tab:cyan", "g_function": "tab:blue",
                  "bilinear": "tab:pink", "compliance": "tab:gray",
                  "flowback_sqrt_p": "tab:green", "flowback_p_v": "darkgreen",
                  "consensus": "k"}
#: FCP methods in words (legends and labels).
METHOD_WORDS = {"tangent": "tangents on p-t", "sqrt_t": "square-root-of-time",
                "g_function": "G-function", "bilinear": "bilinear dp/dt-p",
                "compliance": "compliance (stiffness rise)",
                "flowback_sqrt_p": "flowback sqrt(p)-t", "flowback_p_v": "flowback p-V",
                "consensus": "consensus"}
_NAMES = {"LOP": "LOP", "FBP": "FBP", "Pr": "reopening Pr", "FPP": "FPP", "ISIP": "ISIP",
          "FCP": "FCP"}
_WINDOW = dict(color="gold", alpha=0.18, lw=0)
_BAND = dict(alpha=0.14, lw=0)


# --------------------------------------------------------------------------- helpers
def _fig(nrows: int = 1, figsize=(8.5, 5.2)) -> tuple[Figure, Any]:
    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(nrows, 1, sharex=nrows > 1)
    return fig, axes


def interval_text(pk: Pick, name: str | None = None, unit_scale: float = _BAR) -> str:
    """``"FCP 261.9 bar, 90 %: 261.5-262.6"`` (no level: ``range 261.5-262.6``)."""
    name = _NAMES.get(pk.name, pk.name) if name is None else name
    s = f"{name} {pk.value / unit_scale:.1f} bar"
    if pk.low is not None and pk.high is not None:
        lv = f"{100 * pk.level:.0f} %" if pk.level is not None else "range"
        s += f", {lv}: {pk.low / unit_scale:.1f}-{pk.high / unit_scale:.1f}"
    return s


def _band_label(pk: Pick, what: str = "interval") -> str:
    lv = f"{100 * pk.level:.0f} % " if pk.level is not None else ""
    return f"{_NAMES.get(pk.name, pk.name)} {lv}{what}"


def _hband(ax, pk: Pick | None, color: str, fy=lambda p: p / _BAR, label: str | None = None):
    """The pick's interval as a horizontal band (``fy`` maps Pa to the plot's y)."""
    if pk is None or not pk.found or pk.low is None or pk.high is None:
        return
    ax.axhspan(fy(pk.low), fy(pk.high), color=color, **_BAND,
               label=label or _band_label(pk))


def _vband(ax, a: float | None, b: float | None, color: str, label: str):
    if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)):
        return
    ax.axvspan(min(a, b), max(a, b), color=color, **_BAND, label=label)


def _window(ax, a: float | None, b: float | None, label: str = "data window used"):
    if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)) or a == b:
        return
    ax.axvspan(min(a, b), max(a, b), **_WINDOW, label=label, zorder=0)


def _phase(cp: CyclePicks, kind: str):
    return cp.cycle.phase(kind)


def _shutin_time(record: Record, cp: CyclePicks) -> float | None:
    """When the pumps stopped [s]: end of the last pump phase before the shut-in."""
    sh = _phase(cp, "shut_in")
    if sh is None:
        return None
    pumps = [p for p in cp.cycle.phases if p.kind == "pump" and p.i1 <= sh.i0 + 1]
    if pumps and pumps[-1].i1 - 1 < sh.i0:
        return 0.5 * float(record.t[pumps[-1].i1 - 1] + record.t[sh.i0])
    return float(record.t[sh.i0])


def _line_xy(ln: LineDetails, x_range=None, pad: float = 0.15, n: int = 40):
    s, c = float(ln.slope), float(ln.intercept)
    xr = x_range if x_range is not None else ln.x_range
    if xr is None or not (np.isfinite(s) and np.isfinite(c)):
        return None, None
    span = xr[1] - xr[0]
    xx = np.linspace(xr[0] - pad * span, xr[1] + pad * span, n)
    return xx, s * xx + c


def _draw_line(ax, ln, label: str, color: str, *, xscale=1.0, yscale=1.0, x_range=None,
               pad=0.15, xshift=0.0):
    xx, yy = _line_xy(ln, x_range, pad)
    if xx is None:
        return
    ax.plot((xx - xshift) * xscale, yy * yscale, "--", color=color, lw=1.4, zorder=4,
            label=label)


def _shutin_lines(pk: Pick) -> tuple[LineDetails | None, LineDetails | None]:
    """The lines before and after closure of a sqrt(t) / G-function pick (on its own
    abscissa): the two sides of the slope break, or the user's straight stretch."""
    d = pk.details
    if isinstance(d, SlopeBreakDetails):
        return d.line_before, d.line_after
    if isinstance(d, ShutinDepartureDetails) and d.departure is not None:
        return d.departure.line, None
    return None, None


def _flowback_details(pk: Pick | None) -> FlowbackDetails | None:
    return pk.details if pk is not None and isinstance(pk.details, FlowbackDetails) else None


def _finish(ax, xlabel: str, ylabel: str, title: str, placer: LabelPlacer | None = None,
            prefer: str = "upper right", handles=None, labels=None, legend_ax=None) -> None:
    """Axis labels, title, grid, and the legend queued on ``placer`` (placed clear of the
    curves of every axes, ``legend_ax`` the one it is drawn on: the top twin)."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    if placer is not None:
        if handles is None:
            handles, labels = ax.get_legend_handles_labels()
        placer.legend(legend_ax if legend_ax is not None else ax, handles, labels,
                      prefer=prefer)
    ax.grid(alpha=0.3)


def _no_data(ax, text: str) -> None:
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", fontsize=9,
            wrap=True)


def _margin(ax, frac: float = 0.08) -> None:
    """Room above and below the data for labels."""
    lo, hi = ax.get_ylim()
    d = hi - lo
    ax.set_ylim(lo - frac * d, hi + frac * d)


# --------------------------------------------------------------------------- overview
def plot_overview(record_picks: RecordPicks) -> Figure:
    """Pressure and rate against time; every pick of every test cycle labelled with its
    interval, each closure method a marker named in the legend."""
    rec = record_picks.record
    fig, (ax, axr) = _fig(2, figsize=(12.5, 7.0))
    fig.get_layout_engine().set(h_pad=0.02)
    tm = rec.t / 60.0
    ax.plot(tm, rec.pressure / _BAR, lw=0.9, color="tab:blue", label="pressure")
    surf = rec.channels.get("surface_pressure")
    if surf is not None:
        ax.plot(tm, surf / _BAR, lw=0.7, color="tab:gray", label="surface pressure")
    placer = LabelPlacer()
    seen: set[str] = set()
    for cp in record_picks.cycles:
        ax.axvspan(cp.cycle.t_start / 60, cp.cycle.t_end / 60,
                   color="0.9" if cp.index % 2 else "0.96", lw=0, zorder=0)
        # Named at the top edge where the cycle starts, placed clear of the curves.
        placer.add(ax, cp.cycle.t_start / 60, 1.0, f"cycle {cp.index}: {cp.kind}", "k",
                   fontsize=7, xycoords=("data", "axes fraction"),
                   directions=(-20, -45, -70, 0))
        for pk in cp.picks:
            if not pk.found or pk.t is None:
                continue
            if pk.name == "FCP":
                col = _METHOD_COLORS.get(pk.method, "tab:green")
                lab = f"FCP by {METHOD_WORDS.get(pk.method, pk.method)}"
                ax.plot([pk.t / 60], [pk.value / _BAR], "x", color=col, ms=6, mew=1.3,
                        zorder=5, label=None if lab in seen else lab)
                seen.add(lab)
                continue
            placer.add(ax, pk.t / 60, pk.value / _BAR, interval_text(pk),
                       _COLORS.get(pk.name, "k"))
        rejected = {(r.t, r.pressure): r for pk in cp.picks if isinstance(pk.details, ShutinDetails)
                    for r in pk.details.rejected}
        for r in rejected.values():
            lab = "closure candidate rejected (phase boundary / pump-off drop)"
            ax.plot([r.t / 60], [r.pressure / _BAR], "X", color="0.4", ms=6, mew=0.5,
                    mec="k", zorder=5, label=None if lab in seen else lab)
            seen.add(lab)
        f = cp.fcp
        if f is not None and f.found and f.t is not None:
            if f.low is not None and f.high is not None:
                ax.errorbar([f.t / 60], [f.value / _BAR],
                            yerr=[[(f.value - f.low) / _BAR], [(f.high - f.value) / _BAR]],
                            color="k", capsize=3, lw=1.2, zorder=6,
                            label=None if "c" in seen else "consensus FCP and its interval")
                seen.add("c")
            placer.add(ax, f.t / 60, f.value / _BAR, interval_text(f, "FCP (consensus)"),
                       "k")
    _margin(ax, 0.12)
    ax.set_ylabel(f"pressure [bar]\n{rec.reference.describe()}", fontsize=9)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, framealpha=0.85)
    ax.grid(alpha=0.3)
    if rec.rate is not None:
        axr.plot(tm, rec.rate * _LPM, color="tab:red", lw=0.9, label="pump rate")
    if rec.return_rate is not None:
        axr.plot(tm, -rec.return_rate * _LPM, color="tab:green", lw=0.9,
                 label="return rate (negative)")
    elif rec.return_volume is not None and rec.n > 2:
        axr.plot(tm, -np.gradient(rec.return_volume, rec.t) * _LPM, color="tab:green",
                 lw=0.9, label="return rate from volume (negative)")
    if rec.rate is None and rec.return_rate is None and rec.return_volume is None:
        _no_data(axr, "no rate recorded")
    else:
        axr.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    axr.set_ylabel("rate [l/min]")
    axr.set_xlabel("time [min]")
    axr.grid(alpha=0.3)
    from pathlib import PurePath

    src = " + ".join(PurePath(s).name for s in rec.sources) if rec.sources else "record"
    fig.suptitle(f"{src}\npressure and rate, every pick with its interval", fontsize=9)
    placer.place(fig)
    return fig


# --------------------------------------------------------------------------- p vs V
def plot_p_v(record: Record, cp: CyclePicks) -> Figure:
    """Pressure against pumped volume of the cycle, the pressurisation line and LOP / Pr."""
    fig, ax = _fig()
    pumps = [p for p in cp.cycle.phases if p.kind == "pump"]
    if not pumps:
        _no_data(ax, "no pump phase")
        return fig
    i0 = pumps[0].i0
    i1 = max(p.i1 for p in pumps)
    if record.volume is not None:
        v = record.volume[i0:i1] - record.volume[i0]
    elif record.rate is not None:
        t, q = record.t[i0:i1], record.rate[i0:i1]
        v = np.concatenate([[0.0], np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(t))])
    else:
        _no_data(ax, "no pumped volume or rate")
        return fig
    tt = record.t[i0:i1]
    p = record.pressure[i0:i1]
    ax.plot(v * 1000, p / _BAR, ".", ms=2, color="tab:blue", label="pumping")
    key = "LOP" if cp.get("LOP") is not None else "Pr"
    pk = cp.get(key)
    placer = LabelPlacer()
    d = pk.details if pk is not None else None
    if isinstance(d, PressurisationDetails) and d.x_name == "V":
        stiff = d.stiffness
        lab = "pressurisation line" + (f" ({stiff / _BAR:.4g} bar/m³)" if stiff else "")
        _draw_line(ax, d.departure.line, lab, "tab:orange", xscale=1000, yscale=1 / _BAR,
                   pad=0.3)
    if pk is not None and pk.window is not None:
        _window(ax, *(np.interp(pk.window, tt, v) * 1000), label="straight stretch used")
    if pk is not None and pk.found and pk.t is not None:
        vp = float(np.interp(pk.t, tt, v))
        _hband(ax, pk, _COLORS[key])
        placer.add(ax, vp * 1000, pk.value / _BAR, interval_text(pk), _COLORS[key])
    fbp = cp.get("FBP")
    if fbp is not None and fbp.found and fbp.t is not None:
        placer.add(ax, float(np.interp(fbp.t, tt, v)) * 1000, fbp.value / _BAR,
                   interval_text(fbp), _COLORS["FBP"])
    _margin(ax)
    _finish(ax, "pumped volume [l]", "pressure [bar]",
            f"cycle {cp.index}: pressure vs pumped volume", placer, "lower right")
    placer.place(fig)
    return fig


# --------------------------------------------------------------------------- shut-in plots
def _curves(record: Record, cp: CyclePicks) -> dict[str, np.ndarray] | None:
    """Post-drop shut-in curves of the shut-in module (the picks' own abscissae)."""
    from xlotkit.interpret.picks.shutin import shutin_curves

    return shutin_curves(record, cp.cycle)


def g_function(dt_d: np.ndarray) -> np.ndarray:
    """Nolte's G-function for ``alpha = 1`` of dimensionless shut-in time (see
    :func:`xlotkit.interpret.picks.shutin.g_function`)."""
    from xlotkit.interpret.picks.shutin import nolte_g

    return 4.0 / np.pi * (nolte_g(dt_d) - 4.0 / 3.0)


def _x_of_t(c, x, tt):
    return float(np.interp(tt, c["t"], x)) if tt is not None else None


def _closure_marks(ax, placer, cp, c, x, methods, y_of=None):
    """Vertical line and label of each closure method found (x from its time)."""
    for m in methods:
        pk = cp.get("FCP", m)
        if pk is None or not pk.found or pk.t is None:
            continue
        xm = _x_of_t(c, x, pk.t)
        col = _METHOD_COLORS.get(m, "tab:green")
        ax.axvline(xm, color=col, ls=":", lw=1)
        placer.add(ax, xm, pk.value / _BAR if y_of is None else y_of(pk),
                   interval_text(pk, f"FCP by {METHOD_WORDS[m]}"), col)


def _boundary_marks(ax, record: Record, pk: Pick | None, x_of) -> None:
    """The boundary zone left out of the closure fits (its samples in grey) and the
    candidates rejected there or in the pump-off drop (crosses), on the plot's abscissa
    ``x_of(dt, details)`` of the time since pump stop."""
    d = pk.details if pk is not None else None
    if not isinstance(d, ShutinDetails) or d.t_shut_in is None or d.t_pump is None:
        return
    z = d.boundary
    if z is not None:
        sel = (record.t >= z.t_start) & (record.t <= z.t_end)
        if sel.any():
            ax.plot(x_of(record.t[sel] - d.t_shut_in, d), record.pressure[sel] / _BAR, ".",
                    ms=3, color="0.55", zorder=3,
                    label=f"boundary zone, left out ({z.onset}, before the "
                          f"{z.next_phase.replace('_', '-')})")
    for k, r in enumerate(d.rejected):
        ax.plot([x_of(np.array([r.t - d.t_shut_in]), d)[0]], [r.pressure / _BAR], "X",
                color="tab:red", ms=8, mec="k", mew=0.6, zorder=6,
                label=None if k else f"closure candidate rejected ({r.where})")


def _consensus_band(ax, cp: CyclePicks) -> None:
    f = cp.fcp
    if f is not None and f.found:
        ax.axhline(f.value / _BAR, color="k", lw=0.7, ls="-.",
                   label=f"consensus FCP {f.value / _BAR:.1f} bar")


def plot_sqrt_t(record: Record, cp: CyclePicks) -> Figure:
    """Shut-in pressure and dP/d sqrt(dt) against sqrt(dt): the lines before and after
    closure, the window, the closure and its interval."""
    fig, ax = _fig()
    c = _curves(record, cp)
    if c is None or c["t"].size < 5:
        _no_data(ax, "no usable shut-in")
        return fig
    x, p = c["sqrt_t"], c["p"]
    ax.plot(x, p / _BAR, ".", ms=2, color="tab:blue", label="shut-in pressure")
    pk = cp.get("FCP", "sqrt_t")
    placer = LabelPlacer()
    if pk is not None and pk.found:
        before, after = _shutin_lines(pk)
        if before is not None:
            _draw_line(ax, before, "line before closure", "k", yscale=1 / _BAR)
        if after is not None:
            _draw_line(ax, after, "line after closure", "tab:red", yscale=1 / _BAR)
        if pk.window is not None:
            _window(ax, _x_of_t(c, x, pk.window[0]), _x_of_t(c, x, pk.window[1]))
        _hband(ax, pk, _METHOD_COLORS["sqrt_t"])
    _closure_marks(ax, placer, cp, c, x, ("sqrt_t",))
    _boundary_marks(ax, record, pk, lambda d, sh: np.sqrt(np.maximum(d, 0.0)))
    _consensus_band(ax, cp)
    ax2 = ax.twinx()
    ax2.plot(x, -c["dp_dsqrt_t"] / _BAR, color="tab:red", lw=0.7, alpha=0.7,
             label="pressure derivative −dP/d√t (right axis)")
    ax2.set_ylabel("−dP/d√t [bar/√s]", color="tab:red")
    _margin(ax)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    _finish(ax, "√(time since pump stop) [√s]", "pressure [bar]",
            f"cycle {cp.index}: square-root-of-time plot", placer, "upper right",
            h1 + h2, l1 + l2, legend_ax=ax2)
    placer.place(fig)
    return fig


def plot_g_function(record: Record, cp: CyclePicks, diagnosis=None) -> Figure:
    """G-function plot: p, dP/dG and G dP/dG against G, the straight line through the
    origin, closure at the departure (G-function and compliance picks) with its interval,
    and the leak-off diagnosis in words."""
    from xlotkit.interpret.diagnostics.gfunction import diagnose_g_function

    fig, ax = _fig()
    c = _curves(record, cp)
    if c is None or c["t"].size < 5:
        _no_data(ax, "no usable shut-in")
        return fig
    G, p = c["G"], c["p"]
    pk = cp.get("FCP", "g_function")
    diag = diagnosis
    if diag is None:
        closure = pk if pk is not None and pk.found else None
        diag = diagnose_g_function(record, cp.cycle, closure)
    ax.plot(G, p / _BAR, ".", ms=2, color="tab:blue", label="shut-in pressure (left axis)")
    placer = LabelPlacer()
    if pk is not None and pk.found:
        before, _ = _shutin_lines(pk)
        if before is not None:
            _draw_line(ax, before, "pressure line before closure", "k", yscale=1 / _BAR)
        if pk.window is not None:
            _window(ax, _x_of_t(c, G, pk.window[0]), _x_of_t(c, G, pk.window[1]))
        _hband(ax, pk, _METHOD_COLORS["g_function"])
    _closure_marks(ax, placer, cp, c, G, ("g_function", "compliance"))
    _boundary_marks(ax, record, pk, lambda d, sh: g_function(d / sh.t_pump))
    ax2 = ax.twinx()
    ax2.plot(G, c["G_dp_dG"] / _BAR, color="tab:red", lw=1.1, label="G·dP/dG (right axis)")
    ax2.plot(G, -c["dp_dG"] / _BAR, color="tab:orange", lw=0.8, alpha=0.8,
             label="dP/dG (right axis)")
    if diag is not None and diag.m is not None:
        gg = np.linspace(0.0, float(np.nanmax(G)), 30)
        ax2.plot(gg, diag.m * gg / _BAR, "--", color="k", lw=0.9,
                 label="line through the origin, tangent at closure")
    ax2.set_ylabel("G·dP/dG and dP/dG [bar]")
    lo, hi = ax2.get_ylim()
    ax2.set_ylim(0.0, hi)
    if diag is not None:
        placer.note(ax2, f"leak-off diagnosis: {diag.words}\n{diag.reason}",
                    prefer="lower right")
    _margin(ax, 0.18)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    _finish(ax, "G-function (Nolte, α = 1)", "pressure [bar]",
            f"cycle {cp.index}: G-function plot", placer, "upper right", h1 + h2, l1 + l2,
            legend_ax=ax2)
    placer.place(fig)
    return fig


def plot_bilinear(record: Record, cp: CyclePicks) -> Figure:
    """Haimson's bilinear plot: decay rate dp/dt against p, both lines, closure and its
    interval."""
    fig, ax = _fig()
    c = _curves(record, cp)
    if c is None or c["t"].size < 5:
        _no_data(ax, "no usable shut-in")
        return fig
    p, dpdt = c["p"], c["dp_dt"]
    ax.plot(p / _BAR, dpdt / _BAR * 60, ".", ms=2, color="tab:blue", label="decay rate dp/dt")
    pk = cp.get("FCP", "bilinear")
    placer = LabelPlacer()
    d = pk.details if pk is not None else None
    if pk is not None and pk.found and isinstance(d, BilinearDetails) \
            and None not in (d.s_closed, d.s_open, d.dpdt_at_closure):
        x0, y0 = float(pk.value), float(d.dpdt_at_closure)
        for s, (a, b), col, lab in ((d.s_closed, (p.min(), x0), "tab:red",
                                     "closed-fracture line"),
                                    (d.s_open, (x0, p.max()), "tab:orange",
                                     "open-fracture line")):
            xx = np.linspace(a, b, 20)
            ax.plot(xx / _BAR, (y0 + s * (xx - x0)) / _BAR * 60, "--", color=col, lw=1.2,
                    label=lab)
        _vband(ax, pk.low / _BAR, pk.high / _BAR, _METHOD_COLORS["bilinear"],
               _band_label(pk))
        placer.add(ax, x0 / _BAR, y0 / _BAR * 60, interval_text(pk, "FCP by bilinear dp/dt-p"),
                   _METHOD_COLORS["bilinear"])
    _margin(ax)
    _finish(ax, "pressure [bar]", "dp/dt [bar/min]",
            f"cycle {cp.index}: bilinear pressure-decay-rate plot", placer)
    placer.place(fig)
    return fig


# --------------------------------------------------------------------------- flowback
def plot_flowback_sqrt_p(record: Record, cp: CyclePicks) -> Figure:
    """sqrt(choke pressure) against time in the flowback: both lines and their windows,
    closure and its interval."""
    from xlotkit.interpret.picks.flowback import choke_pressure

    fig, ax = _fig()
    fb = _phase(cp, "flowback")
    if fb is None:
        _no_data(ax, "no flowback")
        return fig
    try:
        pc = choke_pressure(record, fb).p[fb.i0:fb.i1]
    except ValueError as exc:
        _no_data(ax, str(exc))
        return fig
    t = record.t[fb.i0:fb.i1]
    t0 = float(t[0])
    y = np.sqrt(np.clip(pc, 0, None))
    ax.plot(t - t0, y / np.sqrt(_BAR), ".", ms=2, color="tab:blue",
            label="√(choke pressure)")
    pk = cp.get("FCP", "flowback_sqrt_p")
    placer = LabelPlacer()
    d = _flowback_details(pk)
    if d is not None and d.line_open is not None and d.line_closed is not None:
        for ln, w, col, lab in (
                (d.line_open, d.window_open, "tab:orange", "open-fracture line (compliant)"),
                (d.line_closed, d.window_closed, "tab:red", "closed-fracture line (stiff)")):
            _draw_line(ax, ln, lab, col, yscale=1 / np.sqrt(_BAR), xshift=t0, pad=0.3)
            if w is not None:
                ax.axvspan(w[0] - t0, w[1] - t0, color=col, alpha=0.07, lw=0,
                           label=f"window of the {lab.split(' (')[0]}")
    if pk is not None and pk.found and d is not None and d.sqrt_p_closure is not None:
        tc = d.t_closure - t0
        yc = d.sqrt_p_closure / np.sqrt(_BAR)
        off = pk.value - d.sqrt_p_closure ** 2

        def fy(pp):
            return np.sqrt(max(pp - off, 0.0)) / np.sqrt(_BAR)

        _hband(ax, pk, "tab:green", fy)
        ax.axvline(tc, color="tab:green", ls=":", lw=1)
        placer.add(ax, tc, yc, interval_text(pk, f"FCP ({record.reference.kind})"),
                   "tab:green")
    elif pk is not None:
        placer.note(ax, f"closure not found: {pk.message[:200]}")
    _margin(ax)
    _finish(ax, "time since flowback start [s]", "√(choke pressure) [√bar]",
            f"cycle {cp.index}: flowback through a fixed choke", placer)
    placer.place(fig)
    return fig


def plot_flowback_p_v(record: Record, cp: CyclePicks) -> Figure:
    """Pressure against returned volume in the flowback: both stiffness lines and their
    windows, closure and its interval."""
    from xlotkit.interpret.picks.flowback import returned_volume

    fig, ax = _fig()
    fb = _phase(cp, "flowback")
    if fb is None:
        _no_data(ax, "no flowback")
        return fig
    v, src = returned_volume(record, fb)
    if v is None:
        _no_data(ax, "no returned volume recorded")
        return fig
    p = record.pressure[fb.i0:fb.i1]
    t = record.t[fb.i0:fb.i1]
    ax.plot(v * 1000, p / _BAR, ".", ms=2, color="tab:blue", label=f"flowback ({src})")
    pk = cp.get("FCP", "flowback_p_v")
    placer = LabelPlacer()
    d = _flowback_details(pk)
    if d is not None and d.line_open is not None and d.line_closed is not None:
        vm = np.maximum.accumulate(v)
        for ln, stiff, w, col, lab in (
                (d.line_open, d.stiffness_open, d.window_open, "tab:orange", "open fracture"),
                (d.line_closed, d.stiffness_closed, d.window_closed, "tab:red",
                 "closed fracture")):
            _draw_line(ax, ln, f"{lab}: stiffness {stiff / _BAR:.4g} bar/m³", col,
                       xscale=1000, yscale=1 / _BAR, pad=0.3)
            if w is not None:
                ax.axvspan(*(np.interp(w, t, vm) * 1000), color=col, alpha=0.07, lw=0,
                           label=f"window of the {lab} line")
    if pk is not None and pk.found and d is not None and d.volume_closure is not None:
        _hband(ax, pk, "tab:green")
        placer.add(ax, d.volume_closure * 1000, pk.value / _BAR, interval_text(pk),
                   "tab:green")
    elif pk is not None:
        placer.note(ax, f"closure not found: {pk.message[:200]}")
    _margin(ax)
    _finish(ax, "returned volume [l]", f"pressure [bar] ({record.reference.kind})",
            f"cycle {cp.index}: pressure vs returned volume", placer)
    placer.place(fig)
    return fig


# --------------------------------------------------------------------------- all
def pick_figures(record_picks: RecordPicks, diagnostics=None) -> dict[str, Figure]:
    """Every plot of a record's picks, keyed by a file-name stem.

    ``overview``; for each LOT/XLOT cycle ``cycle<i>_p_v``, and where the cycle has the phase
    ``cycle<i>_sqrt_t``, ``cycle<i>_g_function``, ``cycle<i>_bilinear``,
    ``cycle<i>_loglog``, ``cycle<i>_after_closure`` (shut-in) and
    ``cycle<i>_flowback_sqrt_p``, ``cycle<i>_flowback_p_v`` (flowback).

    Parameters
    ----------
    record_picks : RecordPicks
    diagnostics : RecordDiagnostics, optional
        The shut-in diagnostics (computed when not given).
    """
    from xlotkit.interpret.diagnostics import diagnose_record
    from xlotkit.interpret.plots.diagnostics import plot_after_closure, plot_loglog

    rec = record_picks.record
    if diagnostics is None:
        diagnostics = diagnose_record(record_picks)
    figs: dict[str, Figure] = {"overview": plot_overview(record_picks)}
    for cp in record_picks.test_cycles:
        i = cp.index
        figs[f"cycle{i}_p_v"] = plot_p_v(rec, cp)
        if _phase(cp, "shut_in") is not None:
            cd = diagnostics.cycle(i)
            figs[f"cycle{i}_sqrt_t"] = plot_sqrt_t(rec, cp)
            figs[f"cycle{i}_g_function"] = plot_g_function(
                rec, cp, cd.g_function if cd is not None else None)
            figs[f"cycle{i}_bilinear"] = plot_bilinear(rec, cp)
            if cd is not None:
                figs[f"cycle{i}_loglog"] = plot_loglog(cp, cd)
                figs[f"cycle{i}_after_closure"] = plot_after_closure(cp, cd)
        if _phase(cp, "flowback") is not None:
            figs[f"cycle{i}_flowback_sqrt_p"] = plot_flowback_sqrt_p(rec, cp)
            figs[f"cycle{i}_flowback_p_v"] = plot_flowback_p_v(rec, cp)
    return figs
