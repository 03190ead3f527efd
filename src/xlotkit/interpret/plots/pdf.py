"""One multi-page PDF report of an interpretation.

Pages, in order: the overview; every diagnostic plot (per cycle: pressure vs volume,
square-root-of-time, G-function, bilinear, log-log, after-closure, flowback); any further
figures (the stress polygon); the table of picks with their intervals and levels; the
stress estimate with every assumption, and the diagnostics in words.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

__all__ = ["report_pages", "write_report_pdf"]

_BAR = 1e5


def _fmt(x, nd: int = 1) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:.{nd}f}"


def _table_pages(record_picks) -> list[Figure]:
    """The picks table, 34 rows a page."""
    rows = []
    for cp in record_picks.test_cycles:
        for pk in (*cp.picks, cp.fcp):
            if pk is None:
                continue
            if pk.found:
                lv = f"{100 * pk.level:.0f} %" if pk.level is not None else "no level"
                rows.append([str(cp.index), pk.name, pk.method.replace("_", " "),
                             _fmt(pk.value / _BAR),
                             _fmt(pk.low / _BAR if pk.low is not None else None),
                             _fmt(pk.high / _BAR if pk.high is not None else None), lv,
                             pk.quality])
            else:
                rows.append([str(cp.index), pk.name, pk.method.replace("_", " "), "–", "–",
                             "–", "–", textwrap.shorten(pk.message, 48)])
    t0 = record_picks.t0
    if t0.found:
        rows.append(["–", "T0", "FBP − Pr", _fmt(t0.value / _BAR), _fmt(t0.low / _BAR),
                     _fmt(t0.high / _BAR),
                     f"{100 * t0.level:.0f} %" if t0.level else "no level", t0.quality])
    cols = ["cycle", "pick", "method", "value [bar]", "low [bar]", "high [bar]", "level",
            "quality / why not found"]
    pages = []
    per = 34
    for k in range(0, max(len(rows), 1), per):
        fig = Figure(figsize=(11.69, 8.27))
        ax = fig.add_axes((0.03, 0.03, 0.94, 0.88))
        ax.set_axis_off()
        chunk = rows[k:k + per] or [["–"] * len(cols)]
        tab = ax.table(cellText=chunk, colLabels=cols, loc="upper center", cellLoc="left",
                       colWidths=[0.05, 0.05, 0.16, 0.08, 0.08, 0.08, 0.07, 0.43])
        tab.auto_set_font_size(False)
        tab.set_fontsize(7)
        tab.scale(1.0, 1.25)
        src = " + ".join(Path(s).name for s in record_picks.record.sources) or "the record"
        fig.suptitle(f"Picks of {src}\n({record_picks.record.reference.describe()}); "
                     "intervals at the level stated", fontsize=9)
        pages.append(fig)
    return pages


def _text_page(title: str, lines: list[str]) -> Figure:
    fig = Figure(figsize=(11.69, 8.27))
    ax = fig.add_axes((0.05, 0.04, 0.9, 0.88))
    ax.set_axis_off()
    wrapped: list[str] = []
    for ln in lines:
        wrapped.extend(textwrap.wrap(ln, 150, subsequent_indent="    ") or [""])
    ax.text(0.0, 1.0, "\n".join(wrapped[:62]), va="top", ha="left", fontsize=8,
            family="monospace", transform=ax.transAxes)
    fig.suptitle(title, fontsize=11)
    return fig


def _stress_lines(stress: Mapping[str, Any] | None, diagnostics) -> list[str]:
    out: list[str] = []
    if stress is None:
        out.append("No stress estimate was requested.")
    elif not stress.get("available"):
        out.append(f"No stress estimate: {stress.get('message', '')}")
    else:
        s = stress
        cyc = s.get("source_cycles") or [s["source_cycle"]]
        out.append(f"Target depth {s['target_tvd_m']:g} m TVD; sigma_h from the consensus "
                   f"closure of cycle{'s' if len(cyc) > 1 else ''} "
                   f"{', '.join(str(c) for c in cyc)}.")
        for o in s.get("outlier_cycles") or []:
            out.append(f"Outlier: {o['reason']}")
        out.append(f"sigma_h = {_fmt(s['sigma_h_bar'])} bar [{_fmt(s['sigma_h_low_bar'])} - "
                   f"{_fmt(s['sigma_h_high_bar'])}] (90 % interval of the closure pick), "
                   f"{_fmt(s['sigma_h_emw_sg'], 3)} sg EMW")
        if s.get("t0_bar") is not None:
            out.append(f"T0 = FBP - Pr = {_fmt(s['t0_bar'])} bar [{_fmt(s['t0_low_bar'])} - "
                       f"{_fmt(s['t0_high_bar'])}]")
        for eq, v in s.get("sigma_H", {}).items():
            out.append(f"sigma_H (Eq. {eq}) = {_fmt(v['value_bar'])} bar "
                       f"[{_fmt(v['low_bar'])} - {_fmt(v['high_bar'])}] (Monte-Carlo 5-95 %) "
                       f"{v['message']}")
        pp = f"pore pressure {_fmt(s['pore_pressure_bar'])} bar"
        if s.get("pore_pressure_low_bar") is not None:
            pp += f" [{_fmt(s['pore_pressure_low_bar'])} - {_fmt(s['pore_pressure_high_bar'])}]"
        out.append(f"{pp} ({s.get('pore_pressure_source', 'default')}); sv "
                   f"{_fmt(s['sv_bar'])} bar; friction coefficient {s['mu']}")
        if s.get("regime"):
            out.append(f"Faulting regime in the stress polygon: {s['regime']}")
        out.append("")
        out.append("Assumptions:")
        out.extend(f"  * {a}" for a in s.get("assumptions", []))
        if s.get("omitted"):
            out.append("")
            out.append("Not estimated, and why:")
            out.extend(f"  * {o}" for o in s["omitted"])
    if diagnostics is not None:
        out.append("")
        out.append("Shut-in diagnostics:")
        for c in diagnostics.cycles:
            out.append(f"  * {c.report()}")
    return out


def report_pages(record_picks, figures: Mapping[str, Figure], *, stress=None,
                 diagnostics=None, extra: Mapping[str, Figure] | None = None) -> list[Figure]:
    """The report's pages (module docstring)."""
    pages = [figures[k] for k in figures]
    pages += list((extra or {}).values())
    pages += _table_pages(record_picks)
    pages.append(_text_page("Stress estimate, its assumptions, and the diagnostics",
                            _stress_lines(stress, diagnostics)))
    return pages


def write_report_pdf(path: str | Path, record_picks, figures: Mapping[str, Figure], *,
                     stress=None, diagnostics=None,
                     extra: Mapping[str, Figure] | None = None) -> Path:
    """Write the report's pages into one PDF at ``path`` (written as given: the caller
    chooses a fresh folder)."""
    path = Path(path)
    with PdfPages(path) as pdf:
        for fig in report_pages(record_picks, figures, stress=stress, diagnostics=diagnostics,
                                extra=extra):
            pdf.savefig(fig)
    return path
