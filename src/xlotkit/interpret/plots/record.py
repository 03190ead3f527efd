"""Overview plot of a record: pressure and rates against time, phases shaded, cycles named.

Figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot state), so the
module is safe in servers, tests and the CLI whatever backend is configured.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from xlotkit.atomic import save_figure
from xlotkit.interpret.phases import Segmentation
from xlotkit.record import Record
from xlotkit.units import from_si

__all__ = ["PHASE_COLORS", "plot_record"]

#: Shading colour of each phase kind.
PHASE_COLORS = {
    "pump": "#f4a582",
    "shut_in": "#92c5de",
    "flowback": "#b8e186",
    "bleed": "#c2a5cf",
    "idle": "#f0f0f0",
}

_PHASE_LABELS = {
    "pump": "pump",
    "shut_in": "shut-in",
    "flowback": "flowback",
    "bleed": "bleed",
    "idle": "idle",
}


def _time_axis(record: Record):
    """x values and axis label: clock time when ``start_time`` is known, else minutes."""
    if record.start_time is not None:
        return record.timestamps.astype("datetime64[ms]").astype(object), "clock time"
    return record.t / 60.0, "elapsed time [min]"


def _x_at(record: Record, t: float):
    if record.start_time is not None:
        return record.time_at(t)
    return t / 60.0


def plot_record(record: Record, segmentation: Segmentation | None = None, *, ax=None,
                path: str | Path | None = None):
    """Plot pressure [bar] and pump/return rate [l/min] against time.

    Parameters
    ----------
    record : Record
        The record (SI); pressure is shown on its own reference, converted to bar.
    segmentation : Segmentation, optional
        Phases are shaded by kind (legend) and cycles labelled ``"#index kind"`` above the
        pressure curve.
    ax : matplotlib.axes.Axes, optional
        Axes to draw the pressure into (the rates go on a twin axis). A new figure is made
        when omitted.
    path : str or Path, optional
        Write the figure there (format from the suffix, e.g. ``.png``, ``.pdf``). The file
        is written to a temporary name first and then renamed, so a reader never sees a
        half-written plot; an existing file of that name is replaced.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    if ax is None:
        fig = Figure(figsize=(12, 5.5), layout="constrained")
        ax = fig.add_subplot(1, 1, 1)
    else:
        fig = ax.figure
    x, xlabel = _time_axis(record)
    p_bar = from_si(record.pressure, "bar")
    ref = record.reference
    where = ref.describe()
    handles = []
    (hp,) = ax.plot(x, p_bar, color="k", lw=1.0, label=f"pressure ({where})", zorder=3)
    handles.append(hp)
    surface = record.channels.get("surface_pressure")
    if surface is not None:
        (hs,) = ax.plot(x, from_si(surface, "bar"), color="0.45", lw=0.8,
                        label="surface pressure", zorder=3)
        handles.append(hs)
    ax.set_ylabel("pressure [bar" + (" abs" if ref.absolute else "") + "]")
    ax.set_xlabel(xlabel)

    rate_ax = None
    if record.rate is not None or record.return_rate is not None:
        rate_ax = ax.twinx()
        if record.rate is not None:
            (hr,) = rate_ax.plot(x, from_si(record.rate, "l/min"), color="tab:red", lw=0.8,
                                 alpha=0.8, label="pump rate")
            handles.append(hr)
        if record.return_rate is not None:
            (hq,) = rate_ax.plot(x, from_si(record.return_rate, "l/min"), color="tab:green",
                                 lw=0.8, alpha=0.8, label="return rate")
            handles.append(hq)
        rate_ax.set_ylabel("rate [l/min]")
        lo, hi = rate_ax.get_ylim()
        # keep the rates in the lower part so they do not hide the pressure
        rate_ax.set_ylim(min(lo, 0.0), max(hi, 1.0) * 2.2)

    if segmentation is not None:
        seen = set()
        for ph in segmentation.phases:
            if ph.kind == "idle":
                continue
            x0, x1 = _x_at(record, ph.t_start), _x_at(record, ph.t_end)
            ax.axvspan(x0, x1, color=PHASE_COLORS[ph.kind], alpha=0.6, lw=0, zorder=0)
            seen.add(ph.kind)
        for kind in PHASE_COLORS:
            if kind in seen:
                handles.append(Patch(color=PHASE_COLORS[kind], alpha=0.6,
                                     label=_PHASE_LABELS[kind]))
        top = float(np.nanmax(p_bar)) if p_bar.size else 1.0
        ax.set_ylim(top=top * 1.15 + 1.0)
        for c in segmentation.cycles:
            xc = _x_at(record, c.t_start)
            ax.axvline(xc, color="0.3", lw=0.6, ls="--", zorder=1)
            ax.annotate(f"#{c.index} {c.kind.replace('_', ' ')}", xy=(xc, 1.0),
                        xycoords=("data", "axes fraction"), xytext=(2, -2),
                        textcoords="offset points", va="top", ha="left", fontsize=8,
                        rotation=90, zorder=4)

    if record.events:
        ev_t = np.array([e.t for e in record.events])
        ev_p = np.interp(ev_t, record.t, p_bar)
        ev_x = [_x_at(record, t) for t in ev_t]
        (he,) = ax.plot(ev_x, ev_p, ls="none", marker="v", ms=5, color="tab:purple",
                        label="remark", zorder=5)
        handles.append(he)

    if record.start_time is not None:
        import matplotlib.dates as mdates

        loc = mdates.AutoDateLocator()
        ax.xaxis.set_major_locator(loc)
        ax.xaxis.set_major_formatter(mdates.DateFormatter("%H:%M"))
    ax.grid(True, lw=0.3, alpha=0.6)
    title = record.meta.get("test") or ", ".join(Path(s).name for s in record.sources)
    if title:
        ax.set_title(str(title), fontsize=10)
    # below the axes, so it never hides the cycle labels or the curves
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=7,
              ncol=min(len(handles), 6), framealpha=0.85)

    if path is not None:
        save_figure(fig, path, dpi=120)
    return fig
