"""Annotated plots of an XLOT record and its picks.

Every function returns a :class:`matplotlib.figure.Figure` built directly (no pyplot, so no
global state and no GUI backend); save it with ``fig.savefig(path)``. Field units: pressure in
bar, rate in l/min, time in minutes (shut-in and flowback plots in seconds since the event,
where the square root is taken).

The fitted lines drawn are read from each pick's ``details`` (slopes and intercepts in SI, on
the plot's own abscissa); derivatives shown for reading the plots (dP/d sqrt(t), dP/dG,
G dP/dG, dp/dt) are local least-squares slopes over a sliding window, not raw differences,
so that pressure quantised to 0.1-1 bar still gives a readable curve.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from xlotkit.interpret.picks.core import CyclePicks, RecordPicks
from xlotkit.interpret.picks.types import Pick
from xlotkit.record import Record

__all__ = [
    "g_function",
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
_SHORT = {"tangent": "tan", "sqrt_t": "√t", "g_function": "G", "bilinear": "bil",
          "compliance": "comp", "flowback_sqrt_p": "fb√p", "flowback_p_v": "fbpV",
          "consensus": ""}


# --------------------------------------------------------------------------- helpers
def _fig(nrows: int = 1, figsize=(8.0, 5.0)) -> tuple[Figure, Any]:
    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(nrows, 1, sharex=nrows > 1)
    return fig, axes


def _local_slope(x: np.ndarray, y: np.ndarray, n: int | None = None) -> np.ndarray:
    """dy/dx by least squares over a centred window of ``n`` samples (default ~4 % of data)."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    m = x.size
    if m < 3:
        return np.full(m, np.nan)
    n = n or max(5, int(0.04 * m))
    h = n // 2
    out = np.full(m, np.nan)
    # Cumulative sums make every window O(1).
    cx, cy = np.concatenate([[0], np.cumsum(x)]), np.concatenate([[0], np.cumsum(y)])
    cxx, cxy = np.concatenate([[0], np.cumsum(x * x)]), np.concatenate([[0], np.cumsum(x * y)])
    lo = np.clip(np.arange(m) - h, 0, m)
    hi = np.clip(np.arange(m) + h + 1, 0, m)
    k = hi - lo
    sx, sy = cx[hi] - cx[lo], cy[hi] - cy[lo]
    sxx, sxy = cxx[hi] - cxx[lo], cxy[hi] - cxy[lo]
    den = k * sxx - sx * sx
    ok = (k >= 3) & (np.abs(den) > 1e-300)
    out[ok] = (k[ok] * sxy[ok] - sx[ok] * sy[ok]) / den[ok]
    return out


def _label_pick(ax, t_min: float, p_bar: float, text: str, color: str, *, k: int = 0) -> None:
    ax.plot([t_min], [p_bar], "o", ms=6, mfc="none", mec=color, mew=1.5, zorder=5)
    ax.annotate(text, (t_min, p_bar), xytext=(6, 6 + 9 * (k % 4)), textcoords="offset points",
                fontsize=7, color=color)


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


def _pump_time(record: Record, cp: CyclePicks, t_s: float) -> float:
    pumps = [p for p in cp.cycle.phases if p.kind == "pump"]
    t0 = pumps[0].t_start if pumps else cp.cycle.t_start
    return max(t_s - t0, 1e-9)


def _lines(details: Mapping[str, Any]) -> list[tuple[str, dict]]:
    """Straight lines stored in a pick's details: every mapping with slope and intercept
    (``line_open``, ``line_closed``, ``line_1`` ...), and the top-level one if any."""
    out = []
    if "slope" in details and "intercept" in details:
        out.append(("line", dict(details)))
    for k, v in details.items():
        if isinstance(v, Mapping) and "slope" in v and "intercept" in v:
            out.append((k, dict(v)))
    return out


def _draw_lines(ax, details: Mapping[str, Any], x_plot_range, *, xscale=1.0, yscale=1.0,
                color="k", extend=0.15) -> None:
    """Draw the lines of ``details`` (SI, in the plot's abscissa before ``xscale``)."""
    for name, ln in _lines(details):
        s, c = float(ln["slope"]), float(ln["intercept"])
        if not (np.isfinite(s) and np.isfinite(c)):
            continue
        xr = None
        for key, val in ln.items():
            if key.endswith("_range") and isinstance(val, (tuple, list)) and len(val) == 2:
                xr = (float(val[0]), float(val[1]))
                break
        if xr is None:
            xr = x_plot_range
        span = xr[1] - xr[0]
        xx = np.linspace(xr[0] - extend * span, xr[1] + extend * span, 50)
        ax.plot(xx * xscale, (s * xx + c) * yscale, "--", color=color, lw=1.4, zorder=4,
                label=f"{name}" if name != "line" else "fitted line")


def _extended_line(line: Mapping[str, Any], pad: float = 0.3, n: int = 30
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Points of a fitted line ``y = slope x + intercept`` over its fit range widened by
    ``pad`` of the range on each side (so the eye sees where the two lines cross)."""
    a, b = line["x_range"]
    span = b - a
    xx = np.linspace(a - pad * span, b + pad * span, n)
    return xx, line["slope"] * xx + line["intercept"]


def _finish(ax, xlabel: str, ylabel: str, title: str) -> None:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)


def _no_data(ax, text: str) -> None:
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", fontsize=9)


# --------------------------------------------------------------------------- overview
def plot_overview(record_picks: RecordPicks) -> Figure:
    """Pressure and rate against time with every pick marked and labelled."""
    rec = record_picks.record
    fig, (ax, axr) = _fig(2, figsize=(10.0, 6.5))
    tm = rec.t / 60.0
    ax.plot(tm, rec.pressure / _BAR, lw=0.9, color="tab:blue", label="pressure")
    surf = rec.channels.get("surface_pressure")
    if surf is not None:
        ax.plot(tm, surf / _BAR, lw=0.7, color="tab:gray", label="surface pressure")
    for cp in record_picks.cycles:
        ax.axvspan(cp.cycle.t_start / 60, cp.cycle.t_end / 60, color="0.9" if cp.index % 2
                   else "0.95", lw=0, zorder=0)
        ax.annotate(f"{cp.index}: {cp.kind}", (cp.cycle.t_start / 60, 1.0),
                    xycoords=("data", "axes fraction"), va="top", fontsize=7)
        k = 0
        km = 0
        for pk in (*cp.picks, cp.fcp):
            if not pk.found or pk.t is None:
                continue
            if pk.name == "FCP" and pk.method != "consensus":
                col = _METHOD_COLORS.get(pk.method, "tab:green")
                ax.plot([pk.t / 60], [pk.value / _BAR], "x", color=col, ms=5)
                # Stagger the method labels: several methods often land on one point.
                ax.annotate(_SHORT.get(pk.method, pk.method), (pk.t / 60, pk.value / _BAR),
                            xytext=(4, -9 - 8 * (km % 3)), textcoords="offset points", fontsize=6,
                            color=col)
                km += 1
                continue
            label = pk.name if pk.method != "consensus" else "FCP"
            _label_pick(ax, pk.t / 60, pk.value / _BAR, f"{label} {pk.value / _BAR:.1f}",
                        _COLORS.get(pk.name, "k"), k=k)
            k += 1
    ax.set_ylabel(f"pressure [bar] ({rec.reference.describe()})")
    ax.legend(loc="upper right", fontsize=8)
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
        axr.legend(loc="upper right", fontsize=8)
    axr.set_ylabel("rate [l/min]")
    axr.set_xlabel("time [min]")
    axr.grid(alpha=0.3)
    src = ", ".join(rec.sources) if rec.sources else "record"
    fig.suptitle(f"{src}: pressure and rate", fontsize=10)
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
    p = record.pressure[i0:i1]
    ax.plot(v * 1000, p / _BAR, ".", ms=2, color="tab:blue", label="pump-in")
    key = "LOP" if cp.get("LOP") is not None else "Pr"
    pk = cp.get(key)
    if pk is not None and "slope" in pk.details:
        d = {"line": {"slope": pk.details["slope"], "intercept": pk.details["intercept"],
                      "x_range": pk.details.get("V_range", (float(v.min()), float(v.max())))}}
        _draw_lines(ax, d, (float(v.min()), float(v.max())), xscale=1000, yscale=1 / _BAR,
                    color="tab:orange")
    elif cp.stiffness is not None:
        # Line with the cycle's stiffness through the median of the lower half.
        sel = p <= np.median(p)
        c = float(np.median(p[sel] - cp.stiffness * v[sel]))
        xx = np.linspace(0, float(v.max()), 20)
        ax.plot(xx * 1000, (cp.stiffness * xx + c) / _BAR, "--", color="tab:orange", lw=1)
    if pk is not None and pk.found and pk.t is not None:
        vp = float(np.interp(pk.t, record.t[i0:i1], v))
        _label_pick(ax, vp * 1000, pk.value / _BAR, f"{key} {pk.value / _BAR:.1f} bar",
                    _COLORS[key])
    if cp.stiffness is not None:
        ax.text(0.98, 0.04, f"stiffness {cp.stiffness / _BAR:.4g} bar/m³",
                transform=ax.transAxes, ha="right", fontsize=8)
    ax.set_xlabel("pumped volume [l]")
    ax.set_ylabel("pressure [bar]")
    ax.set_title(f"cycle {cp.index}: pressure vs pumped volume", fontsize=10)
    ax.grid(alpha=0.3)
    return fig


# --------------------------------------------------------------------------- shut-in plots
def _curves(record: Record, cp: CyclePicks) -> dict[str, np.ndarray] | None:
    """Post-drop shut-in curves: from the shut-in module when available (so the plots use
    exactly the abscissae and derivatives of the picks), else computed here."""
    try:
        from xlotkit.interpret.picks.shutin import shutin_curves
    except ImportError:
        shutin_curves = None
    if shutin_curves is not None:
        try:
            c = shutin_curves(record, cp.cycle)
        except Exception:  # noqa: BLE001 -- fall back to the local curves below
            c = None
        if c is not None:
            return c
    sh = _phase(cp, "shut_in")
    t_s = _shutin_time(record, cp)
    if sh is None or t_s is None or sh.i1 - sh.i0 < 5:
        return None
    t = record.t[sh.i0:sh.i1]
    p = record.pressure[sh.i0:sh.i1]
    ok = t > t_s
    t, p = t[ok], p[ok]
    dt = t - t_s
    G = g_function(dt / _pump_time(record, cp, t_s))
    st = np.sqrt(dt)
    d_g = _local_slope(G, p)
    return {"t": t, "dt": dt, "p": p, "sqrt_t": st, "dp_dsqrt_t": _local_slope(st, p),
            "G": G, "dp_dG": d_g, "G_dp_dG": -G * d_g, "dp_dt": _local_slope(dt, p)}


def g_function(dt_d: np.ndarray) -> np.ndarray:
    """Nolte's G-function for ``alpha = 1`` (used only when the shut-in module is missing):

    .. math:: G = \\frac{4}{\\pi}\\left(g(\\Delta t_D) - g(0)\\right),\\quad
              g(\\delta) = \\tfrac43\\left((1+\\delta)^{3/2} - \\delta^{3/2}\\right),

    with :math:`\\Delta t_D = (t - t_s)/t_p` (shut-in time over pumping time).
    """
    d = np.clip(np.asarray(dt_d, float), 0.0, None)
    g = 4.0 / 3.0 * ((1.0 + d) ** 1.5 - d ** 1.5)
    return 4.0 / np.pi * (g - 4.0 / 3.0)


def _mark_closure_x(ax, cp: CyclePicks, method: str, x_of: Any, label_y=None) -> None:
    pk = cp.get("FCP", method)
    if pk is None or not pk.found:
        return
    x = x_of(pk)
    if x is None or not np.isfinite(x):
        return
    col = _METHOD_COLORS.get(method, "tab:green")
    ax.axvline(x, color=col, ls=":", lw=1)
    y = pk.value / _BAR if label_y is None else label_y
    _label_pick(ax, x, y, f"FCP {method} {pk.value / _BAR:.1f} bar", col)


def _consensus_line(ax, cp: CyclePicks) -> None:
    if cp.fcp is not None and cp.fcp.found:
        ax.axhline(cp.fcp.value / _BAR, color="k", lw=0.6, ls="-.",
                   label=f"consensus FCP {cp.fcp.value / _BAR:.1f} bar")


def plot_sqrt_t(record: Record, cp: CyclePicks) -> Figure:
    """Shut-in pressure and dP/d sqrt(dt) against sqrt(dt), the fitted line, closure."""
    fig, ax = _fig()
    c = _curves(record, cp)
    if c is None or c["t"].size < 5:
        _no_data(ax, "no usable shut-in")
        return fig
    x, p = c["sqrt_t"], c["p"]
    ax.plot(x, p / _BAR, ".", ms=2, color="tab:blue", label="pressure")
    pk = cp.get("FCP", "sqrt_t")
    if pk is not None:
        _draw_lines(ax, pk.details, (float(x.min()), float(x.max())), yscale=1 / _BAR,
                    color="k")
    t_s = float(c["t"][0] - c["dt"][0])
    _mark_closure_x(ax, cp, "sqrt_t", lambda k: k.details.get(
        "sqrt_t_pick", np.sqrt(max(k.t - t_s, 0.0)) if k.t is not None else None))
    _consensus_line(ax, cp)
    ax2 = ax.twinx()
    ax2.plot(x, -c["dp_dsqrt_t"] / _BAR, color="tab:red", lw=0.8, label="−dP/d√t")
    ax2.set_ylabel("−dP/d√t [bar/√s]", color="tab:red")
    ax.set_xlabel("√(t − t_shut-in) [√s]")
    ax.set_ylabel("pressure [bar]")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title(f"cycle {cp.index}: square-root-of-time plot", fontsize=10)
    ax.grid(alpha=0.3)
    return fig


def plot_g_function(record: Record, cp: CyclePicks) -> Figure:
    """G-function plot: p, dP/dG and G dP/dG against G, the line through the origin, closure
    (G-function and compliance picks)."""
    fig, ax = _fig()
    c = _curves(record, cp)
    if c is None or c["t"].size < 5:
        _no_data(ax, "no usable shut-in")
        return fig
    G, p = c["G"], c["p"]
    ax.plot(G, p / _BAR, ".", ms=2, color="tab:blue", label="pressure")
    ax.set_ylabel("pressure [bar]")
    ax2 = ax.twinx()
    ax2.plot(G, -c["dp_dG"] / _BAR, color="tab:orange", lw=0.8, label="−dP/dG")
    ax2.plot(G, c["G_dp_dG"] / _BAR, color="tab:red", lw=1.0, label="−G·dP/dG")
    pk = cp.get("FCP", "g_function")
    if pk is not None and "slope" in pk.details:
        # p = p1 - m G on the straight stretch, hence G dP/dG = m G through the origin.
        m = -float(pk.details["slope"])
        _draw_lines(ax, pk.details, (float(G.min()), float(G.max())), yscale=1 / _BAR,
                    color="k")
        gg = np.linspace(0, float(np.nanmax(G)), 20)
        ax2.plot(gg, m * gg / _BAR, "--", color="k", lw=0.8, label="m·G (through origin)")
    t_s = float(c["t"][0] - c["dt"][0])

    def g_at(k: Pick):
        if "G_pick" in k.details:
            return float(k.details["G_pick"])
        return float(np.interp(k.t - t_s, c["dt"], G)) if k.t is not None else None

    _mark_closure_x(ax, cp, "g_function", g_at)
    _mark_closure_x(ax, cp, "compliance", g_at)
    if pk is not None and "diagnosis" in pk.details:
        ax.text(0.02, 0.03, f"decline: {str(pk.details['diagnosis']).replace('_', ' ')}",
                transform=ax.transAxes, fontsize=8)
    ax2.set_ylabel("derivatives [bar]")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax2.legend(h1 + h2, l1 + l2, fontsize=8, loc="center right")
    ax.set_xlabel("G-function")
    ax.set_title(f"cycle {cp.index}: G-function plot", fontsize=10)
    ax.grid(alpha=0.3)
    return fig


def plot_bilinear(record: Record, cp: CyclePicks) -> Figure:
    """Haimson's bilinear plot: pressure decay rate dp/dt against p, both lines, closure."""
    fig, ax = _fig()
    c = _curves(record, cp)
    if c is None or c["t"].size < 5:
        _no_data(ax, "no usable shut-in")
        return fig
    p, dpdt = c["p"], c["dp_dt"]
    ax.plot(p / _BAR, dpdt / _BAR * 60, ".", ms=2, color="tab:blue", label="dp/dt")
    pk = cp.get("FCP", "bilinear")
    d = pk.details if pk is not None else {}
    if pk is not None and pk.found and {"s_closed", "s_open", "dpdt_at_closure"} <= set(d):
        # Hinge y = y0 + s (p - x0): s_closed below the break, s_open above it.
        x0, y0 = float(pk.value), float(d["dpdt_at_closure"])
        for s, (a, b), col, lab in ((d["s_closed"], (p.min(), x0), "tab:red", "closed"),
                                    (d["s_open"], (x0, p.max()), "tab:orange", "open")):
            xx = np.linspace(a, b, 20)
            ax.plot(xx / _BAR, (y0 + s * (xx - x0)) / _BAR * 60, "--", color=col, lw=1.2,
                    label=lab)
    if pk is not None and pk.found:
        ax.axvline(pk.value / _BAR, color="tab:green", ls=":", lw=1)
        ax.annotate(f"FCP {pk.value / _BAR:.1f} bar", (pk.value / _BAR, 0.95),
                    xycoords=("data", "axes fraction"), fontsize=8, color="tab:green")
    _finish(ax, "pressure [bar]", "dp/dt [bar/min]",
            f"cycle {cp.index}: bilinear pressure-decay-rate plot")
    return fig


# --------------------------------------------------------------------------- flowback
def plot_flowback_sqrt_p(record: Record, cp: CyclePicks) -> Figure:
    """sqrt(choke pressure) against time in the flowback, both tangents and closure."""
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
    if pk is not None and "line_open" in pk.details:
        # Lines are y = s t + c in absolute time; shift to time since flowback start.
        for name, col in (("line_open", "tab:orange"), ("line_closed", "tab:red")):
            xx, yy = _extended_line(pk.details[name])
            ok = yy >= 0
            ax.plot(xx[ok] - t0, yy[ok] / np.sqrt(_BAR), "--", color=col, lw=1.2,
                    label=("open fracture (compliant)" if name == "line_open"
                           else "closed fracture (stiff)"))
    if pk is not None and pk.found:
        tc = pk.details["t_closure"] - t0
        yc = pk.details["sqrt_p_closure"] / np.sqrt(_BAR)
        ax.axvline(tc, color="tab:green", ls=":", lw=1)
        _label_pick(ax, tc, yc, f"closure: FCP {pk.value / _BAR:.1f} bar "
                    f"({record.reference.kind})", "tab:green")
    elif pk is not None:
        _no_data(ax, pk.message[:90])
    _finish(ax, "time since flowback start [s]", "√(p_choke − p_atm) [√bar]",
            f"cycle {cp.index}: flowback through fixed choke")
    return fig


def plot_flowback_p_v(record: Record, cp: CyclePicks) -> Figure:
    """Pressure against returned volume in the flowback, both stiffness lines and closure."""
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
    ax.plot(v * 1000, p / _BAR, ".", ms=2, color="tab:blue", label=f"flowback ({src})")
    pk = cp.get("FCP", "flowback_p_v")
    if pk is not None and "line_open" in pk.details:
        for name, col, key in (("line_open", "tab:orange", "stiffness_open"),
                               ("line_closed", "tab:red", "stiffness_closed")):
            xx, yy = _extended_line(pk.details[name])
            ax.plot(xx * 1000, yy / _BAR, "--", color=col,
                    lw=1.2, label=f"{name.split('_')[1]}: S = "
                    f"{pk.details[key] / _BAR:.4g} bar/m³")
    if pk is not None and pk.found:
        vc = pk.details["volume_closure"] * 1000
        _label_pick(ax, vc, pk.value / _BAR, f"FCP {pk.value / _BAR:.1f} bar", "tab:green")
    elif pk is not None:
        _no_data(ax, pk.message[:90])
    _finish(ax, "returned volume [l]", f"pressure [bar] ({record.reference.kind})",
            f"cycle {cp.index}: pressure vs returned volume")
    return fig


# --------------------------------------------------------------------------- all
def pick_figures(record_picks: RecordPicks) -> dict[str, Figure]:
    """Every plot of a record's picks, keyed by a file-name stem.

    ``overview``; for each LOT/XLOT cycle ``cycle<i>_p_v``, and where the cycle has the phase
    ``cycle<i>_sqrt_t``, ``cycle<i>_g_function``, ``cycle<i>_bilinear`` (shut-in) and
    ``cycle<i>_flowback_sqrt_p``, ``cycle<i>_flowback_p_v`` (flowback).
    """
    rec = record_picks.record
    figs: dict[str, Figure] = {"overview": plot_overview(record_picks)}
    for cp in record_picks.test_cycles:
        i = cp.index
        figs[f"cycle{i}_p_v"] = plot_p_v(rec, cp)
        if _phase(cp, "shut_in") is not None:
            figs[f"cycle{i}_sqrt_t"] = plot_sqrt_t(rec, cp)
            figs[f"cycle{i}_g_function"] = plot_g_function(rec, cp)
            figs[f"cycle{i}_bilinear"] = plot_bilinear(rec, cp)
        if _phase(cp, "flowback") is not None:
            figs[f"cycle{i}_flowback_sqrt_p"] = plot_flowback_sqrt_p(rec, cp)
            figs[f"cycle{i}_flowback_p_v"] = plot_flowback_p_v(rec, cp)
    return figs
