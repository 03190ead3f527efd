"""Regenerate the figures and the table of docs/field/segmentation.md.

Run from the repository root with the shared data beside it::

    .venv/bin/python docs/field/make_segmentation.py [DATA_FOLDER]

(``DATA_FOLDER`` defaults to ``../shared/data/field/AMS-01`` beside the repository.)

It segments each AMS-01 downhole-gauge file alone (pressure only, as ``xlotkit inspect FILE``
does), plots the XLOT part of each with its phases and cycles, marks on the same clock when
the cementing unit's metered pump ran (the independent record of the pumping), and writes the
comparison table to ``docs/field/segmentation/gauge_vs_metered.md``.
"""

from __future__ import annotations

import sys
from datetime import timedelta
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / ".." / "shared" / "data" / "field" / "AMS-01"
OUT = ROOT / "docs" / "field" / "segmentation"

#: (title, gauge file, cementing-unit file, plotted window on the gauge's clock [h])
CASES = (
    ("XLOT 1 (Main Claystone), downhole gauge alone",
     "XLOT 1 - Main Claystone_Downhole Gauge_Data.TXT",
     "XLOT 1 - Main Claystone_Cementing Unit_Data.txt", (5.4, 19.3), "ams01_xlot1_gauge"),
    ("XLOT 2 (Vlieland Claystone), downhole gauge alone",
     "XLOT 2 - Vlieland Claystone_Downhole Gauge_Data.TXT",
     "XLOT 2 - Vlieland Claystone_Cementing Unit_Data.TXT", (12.45, 15.3),
     "ams01_xlot2_gauge"),
)


def main(argv: list[str]) -> int:
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from xlotkit.atomic import save_figure
    from xlotkit.interpret.io import read_log, read_logs
    from xlotkit.interpret.phases import segment
    from xlotkit.interpret.plots.record import plot_record

    data = Path(argv[0]) if argv else DATA
    OUT.mkdir(parents=True, exist_ok=True)
    rows = ["| test | cycle (gauge) | kind | peak [bar abs] | pump start, gauge − metered [s] "
            "| pump stop, gauge − metered [s] | pumping, gauge / metered [min] |",
            "|---|---|---|---:|---:|---:|---:|"]
    for title, gauge, unit, (h0, h1), tag in CASES:
        grec = read_log(str(data / gauge))
        crec = read_log(str(data / unit))
        off = read_logs([str(data / unit), str(data / gauge)]).meta["clock_offset_s"]
        gseg = segment(grec)
        cseg = segment(crec)
        fig = Figure(figsize=(13, 5.8), layout="constrained")
        ax = fig.add_subplot(1, 1, 1)
        plot_record(grec, gseg, ax=ax)
        t0 = grec.time_at(h0 * 3600.0)
        t1 = grec.time_at(h1 * 3600.0)
        ax.set_xlim(t0, t1)
        lo = min(c.peak_pressure for c in gseg.cycles) / 1e5
        ax.set_ylim(bottom=min(ax.get_ylim()[0], lo - 80.0))
        y = ax.get_ylim()[0] + 0.03 * (ax.get_ylim()[1] - ax.get_ylim()[0])
        for c in cseg.cycles:
            for ph in c.phases:
                if ph.kind != "pump" or c.kind == "line_test":
                    continue
                a = crec.time_at(ph.t_start) - timedelta(seconds=off)
                b = crec.time_at(ph.t_end) - timedelta(seconds=off)
                ax.plot([a, b], [y, y], color="tab:red", lw=5, solid_capstyle="butt")
        # the record plot's legend (phases) below the axes, with the metered pumping added
        handles = list(ax.get_legend().legend_handles) + [
            Line2D([], [], color="tab:red", lw=5, label="metered pumping (cementing unit)")]
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12),
                  fontsize=7, ncol=min(len(handles), 7), framealpha=0.85)
        ax.set_title(title + " — phases from the pressure alone", fontsize=10)
        save_figure(fig, OUT / f"{tag}.png", dpi=110)
        for cc in [c for c in cseg.cycles if c.kind == "xlot"]:
            pc = cc.phases[0]
            a = crec.time_at(pc.t_start).timestamp() - off
            b = crec.time_at(pc.t_end).timestamp() - off
            gc = min(gseg.cycles, key=lambda c: abs(grec.time_at(c.t_start).timestamp() - a))
            pg = gc.phases[0]
            rows.append(f"| {title.split(' (')[0]} | {gc.index} | {gc.kind} | "
                        f"{gc.peak_pressure / 1e5:.0f} | "
                        f"{grec.time_at(pg.t_start).timestamp() - a:+.0f} | "
                        f"{grec.time_at(pg.t_end).timestamp() - b:+.0f} | "
                        f"{pg.duration / 60:.1f} / {pc.duration / 60:.1f} |")
        cyc = "; ".join(f"#{c.index} {c.kind} {c.peak_pressure / 1e5:.0f} bar at "
                        f"{c.t_start / 3600:.2f} h" for c in gseg.cycles)
        print(f"{gauge}: {cyc}")
        print("  " + gseg.notes[0])
    (OUT / "gauge_vs_metered.md").write_text("\n".join(rows) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
