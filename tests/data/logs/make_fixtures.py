"""Write the reader's fixtures, one per convention, with the values each must read to.

Usage: ``python tests/data/logs/make_fixtures.py`` (re)writes every fixture beside this
script; the text files come out byte for byte the same every time (the test suite checks
it), the workbooks hold the same cells. ``tests/interpret/test_io_conventions.py`` reads each
fixture and compares with :data:`TRUTH`, which is computed here from the numbers written and
unit factors typed in from their definitions (not through pint, which the reader uses), so
the reader is checked against something it did not produce.

The five older fixtures (``cu_repeated_header.txt``, ``psi_bpm.csv``,
``semicolon_decimal_comma.csv``, ``timestamps.csv``, ``units_row.tsv``) were written by hand
and are tested in ``tests/interpret/test_io.py``.
"""

from __future__ import annotations

import sys
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
#: Where the fixtures are written (the tests point it at a temporary folder).
OUT = HERE

# unit factors to SI, from their definitions
PSI = 0.45359237 * 9.80665 / 0.0254 ** 2      # lbf/in^2 = 6894.757293168361 Pa
BAR = 1e5
KPA = 1e3
MPA = 1e6
ATM = 101325.0
AT = 98066.5                                   # technical atmosphere = kgf/cm2
BBL = 42 * 231 * 0.0254 ** 3                   # oil barrel = 0.158987294928 m3
GAL = 231 * 0.0254 ** 3                        # US gallon
MIN = 60.0
HOUR = 3600.0

#: name -> dict of SI arrays (and scalars) each fixture must read to
TRUTH: dict[str, dict] = {}


def _base(n: int = 24):
    """A pump / shut-in sequence: (pressure in bar, rate in l/min), rounded as written."""
    k = np.arange(n)
    p = np.where(k < 10, 20 + 15 * k, 155 - 4 * (k - 10)).astype(float)
    q = np.where((k >= 1) & (k < 10), 300.0, 0.0)
    return k, np.round(p, 3), q


def _write(name: str, text: str, encoding: str = "utf-8") -> None:
    (OUT / name).write_bytes(text.encode(encoding))


def dfit_save_file() -> None:
    """A DFIT program's save file: banner box, comments of every kind, program/version and
    key-value lines, a header with units in brackets, and an analysis block after the data."""
    k, p_bar, q = _base()
    t_min = k * 0.5
    p_psi = np.round(p_bar * BAR / PSI, 1)
    q_bpm = np.round(q / 1000 / BBL, 2)
    lines = [
        "*" * 50,
        "* DFIT analysis program   version 4.2.1          *",
        "* saved 2024-03-01 10:15                          *",
        "*" * 50,
        "# exported for well X-1",
        "; comment in another style",
        "// and another",
        "Program: ClosurePro 4.2.1",
        "Well: X-1",
        "tinj 520",
        "Gauge depth: 2450 m",
        "",
        "Time [min]\tBH Pressure [psi]\tRate [bpm]",
    ]
    for a, b, c in zip(t_min, p_psi, q_bpm):
        lines.append(f"{a:.1f}\t{b:.1f}\t{c:.2f}")
    lines += ["", "GFunction", "G\tP", "0.10\t2100.5", "0.52\t2080.1", "tClosure 522",
              "Pclosure 2011.3", "END"]
    _write("dfit_save_file.txt", "\n".join(lines) + "\n")
    TRUTH["dfit_save_file.txt"] = {"t": t_min * MIN, "pressure": p_psi * PSI,
                                   "rate": q_bpm * BBL / MIN, "reference": "downhole",
                                   "depth_m": 2450.0}


def quoted_comma_header() -> None:
    """Comma CSV whose titles are ``"Name, unit"`` in quotes; MPa and m3/min."""
    k, p_bar, q = _base()
    t = k * 0.25
    p_mpa = np.round(p_bar / 10.0, 4)
    q_m3 = np.round(q / 1000.0, 3)
    lines = ['"Time, min","Pressure, MPa","Rate, m3/min"']
    lines += [f"{a:.2f},{b:.4f},{c:.3f}" for a, b, c in zip(t, p_mpa, q_m3)]
    _write("quoted_comma_header.csv", "\r\n".join(lines) + "\r\n")
    TRUTH["quoted_comma_header.csv"] = {"t": t * MIN, "pressure": p_mpa * MPA,
                                        "rate": q_m3 / MIN}


def name_comma_unit_tab() -> None:
    """Tab file with ``Name, unit`` titles (no quotes), hours and kPa, gal/min."""
    k, p_bar, q = _base()
    t = k / 60.0
    p_kpa = np.round(p_bar * 100.0, 1)
    q_gpm = np.round(q / 1000.0 / GAL, 2)
    lines = ["Time, h\tTreating Pressure, kPa\tRate, gal/min"]
    lines += [f"{a:.6f}\t{b:.1f}\t{c:.2f}" for a, b, c in zip(t, p_kpa, q_gpm)]
    _write("name_comma_unit.tsv", "\n".join(lines) + "\n")
    TRUTH["name_comma_unit.tsv"] = {"t": np.round(t, 6) * HOUR, "pressure": p_kpa * KPA,
                                    "rate": q_gpm * GAL / MIN}


def name_space_unit() -> None:
    """Whitespace-separated columns, titles ``Name unit`` (``WHP psig``, ``Rate_in bpm``),
    and an ``Annulus`` column."""
    k, p_bar, q = _base()
    p_psi = np.round(p_bar * BAR / PSI, 1)
    ann = np.round(np.full(k.size, 150.0) + k, 1)
    q_bpm = np.round(q / 1000 / BBL, 2)
    lines = ["Seconds    WHP psig    Annulus psig    Rate bpm"]
    lines += [f"{a:>7d}    {b:>8.1f}    {c:>8.1f}    {d:>6.2f}"
              for a, b, c, d in zip(k * 10, p_psi, ann, q_bpm)]
    _write("name_space_unit.txt", "\n".join(lines) + "\n")
    TRUTH["name_space_unit.txt"] = {"t": k * 10.0, "pressure": p_psi * PSI,
                                    "annulus_pressure": ann * PSI, "rate": q_bpm * BBL / MIN,
                                    "absolute": False}


def single_space_titles() -> None:
    """Titles and units separated by the same single space as the columns
    (``Time s Pressure psi g Rate l/min``), and an unquoted comma CSV whose titles carry
    their unit after a comma (``Time, min,Pressure, bar a``): the titles are regrouped at
    the units."""
    k, p_bar, q = _base()
    p_psi = np.round(p_bar * BAR / PSI, 1)
    lines = ["Time s Pressure psi g Rate l/min"]
    lines += [f"{a} {b:.1f} {c:.1f}" for a, b, c in zip(k * 10, p_psi, q)]
    _write("single_space_titles.txt", "\n".join(lines) + "\n")
    TRUTH["single_space_titles.txt"] = {"t": k * 10.0, "pressure": p_psi * PSI,
                                        "rate": q / 1000 / MIN, "absolute": False}
    lines = ["Time, min,Pressure, bar a"]
    lines += [f"{a * 0.5:.1f},{b + 1.0:.3f}" for a, b in zip(k, p_bar)]
    _write("unquoted_comma_titles.csv", "\n".join(lines) + "\n")
    TRUTH["unquoted_comma_titles.csv"] = {"t": k * 30.0, "pressure": (p_bar + 1.0) * BAR,
                                          "absolute": True}


def units_row_and_no_units() -> None:
    """A units row under the header (kgf/cm2, m3/h) and a file with no units at all."""
    k, p_bar, q = _base()
    p_at = np.round(p_bar * BAR / AT, 3)
    q_m3h = np.round(q * 60 / 1000.0, 2)
    lines = ["Time\tPressure\tRate in\tVolume", "s\tkgf/cm2\tm3/h\tm3"]
    vol = np.round(np.cumsum(q_m3h / 3600 * 5.0), 4)
    lines += [f"{a * 5}\t{b:.3f}\t{c:.2f}\t{d:.4f}" for a, b, c, d in zip(k, p_at, q_m3h, vol)]
    _write("units_row_kgf.tsv", "\n".join(lines) + "\n")
    TRUTH["units_row_kgf.tsv"] = {"t": k * 5.0, "pressure": p_at * AT,
                                  "rate": q_m3h / HOUR, "volume": vol}
    lines = ["time,p,q"]
    lines += [f"{a * 5},{b:.1f},{c:.1f}" for a, b, c in zip(k, p_bar, q)]
    _write("no_units.csv", "\n".join(lines) + "\n")
    TRUTH["no_units.csv"] = {"t": k * 5.0, "pressure_if_bar": p_bar * BAR,
                             "rate_if_lpm": q / 1000 / MIN}


def synonyms_pair() -> None:
    """Bottom-hole and surface pressures in one file (``BH Pressure``, ``WHP``), an
    ``Annulus`` and a ``Rate in`` column, date-time stamps."""
    k, p_bar, q = _base()
    t0 = datetime(2024, 3, 13, 22, 0, 0)
    bh = np.round(p_bar + 240.0, 2)
    lines = ["Date/Time,BH Pressure (bar),WHP (bar),Annulus (bar),Rate in (l/min)"]
    for i in k:
        ts = t0 + timedelta(seconds=int(i) * 2)
        lines.append(f"{ts:%Y-%m-%d %H:%M:%S},{bh[i]:.2f},{p_bar[i]:.3f},5.0,{q[i]:.1f}")
    _write("synonyms_bh_whp.csv", "\n".join(lines) + "\n")
    TRUTH["synonyms_bh_whp.csv"] = {"t": k * 2.0, "pressure": bh * BAR,
                                    "surface_pressure": p_bar * BAR, "rate": q / 1000 / MIN,
                                    "start_time": t0, "reference": "downhole"}


def non_english() -> None:
    """German titles, semicolons and decimal commas: ``Zeit [min];Druck [bar];Durchfluss``."""
    k, p_bar, q = _base()
    t = k * 0.5
    lines = ["Zeit [min];Druck [bar];Durchfluss [l/min];Temperatur [°C]"]
    for a, b, c in zip(t, p_bar, q):
        lines.append(f"{a:.1f};{b:.3f};{c:.1f};21,5".replace(".", ","))
    _write("german_semicolon.csv", "\n".join(lines) + "\n", encoding="cp1252")
    TRUTH["german_semicolon.csv"] = {"t": t * MIN, "pressure": p_bar * BAR,
                                     "rate": q / 1000 / MIN,
                                     "temperature": np.full(k.size, 21.5 + 273.15)}


def clock_midnight() -> None:
    """Clock time without a date, crossing midnight; and the same with a preamble date."""
    k, p_bar, q = _base()
    t0 = datetime(2024, 3, 1, 23, 59, 40)
    stamps = [t0 + timedelta(seconds=int(i) * 2) for i in k]
    body = [f"{s:%H:%M:%S}\t{b:.3f}\t{c:.1f}" for s, b, c in zip(stamps, p_bar, q)]
    _write("clock_midnight.txt", "\n".join(["Time\tPressure (bar)\tRate (l/min)"] + body) + "\n")
    TRUTH["clock_midnight.txt"] = {"t": k * 2.0, "pressure": p_bar * BAR,
                                   "start_clock": "23:59:40"}
    _write("clock_with_date.txt", "\n".join(["Date: 1 March 2024", "Job: mini-frac", "",
                                             "Time\tPressure (bar)\tRate (l/min)"] + body)
           + "\n")
    TRUTH["clock_with_date.txt"] = {"t": k * 2.0, "pressure": p_bar * BAR, "start_time": t0}


def datetime_orders() -> None:
    """Date orders and separators: ISO with zones (a change to summer time inside), day
    first with dots, US month first with AM/PM, separate date and time columns, and an
    ambiguous day/month file that the column cannot decide."""
    k, p_bar, q = _base()
    # ISO 8601 with offsets: 01:59:50+01:00 ... then +02:00 (the clock jumps an hour)
    t0 = datetime(2024, 3, 31, 0, 59, 50)               # UTC
    lines = ["timestamp,Pressure (MPa),Rate (m3/min)"]
    for i in k:
        utc = t0 + timedelta(seconds=int(i) * 3)
        off = 1 if utc < datetime(2024, 3, 31, 1, 0, 0) else 2
        loc = utc + timedelta(hours=off)
        lines.append(f"{loc:%Y-%m-%dT%H:%M:%S}+0{off}:00,{p_bar[i] / 10:.4f},{q[i] / 1000:.3f}")
    _write("iso_zones.csv", "\n".join(lines) + "\n")
    TRUTH["iso_zones.csv"] = {"t": k * 3.0, "pressure": np.round(p_bar / 10, 4) * MPA,
                              "start_time": t0 + timedelta(hours=1), "utc_offset": "+01:00"}
    # day first, dots, crossing into the 13th (decides the order)
    t1 = datetime(2024, 3, 12, 23, 59, 30)
    lines = ["Datum Zeit;Druck (bar);Rate (l/min)"]
    for i in k:
        ts = t1 + timedelta(seconds=int(i) * 5)
        lines.append(f"{ts:%d.%m.%Y %H:%M:%S};{p_bar[i]:.3f};{q[i]:.1f}")
    _write("dmy_dots.csv", "\n".join(lines) + "\n")
    TRUTH["dmy_dots.csv"] = {"t": k * 5.0, "pressure": p_bar * BAR, "start_time": t1}
    # US: month first, 12-hour clock
    t2 = datetime(2024, 7, 14, 11, 59, 30)
    lines = ["Date Time,Treating Pressure (psi),Slurry Rate (bpm)"]
    p_psi = np.round(p_bar * BAR / PSI, 1)
    for i in k:
        ts = t2 + timedelta(seconds=int(i) * 5)
        lines.append(f"{ts:%m/%d/%Y %I:%M:%S %p},{p_psi[i]:.1f},{q[i] / 1000 / BBL:.2f}")
    _write("mdy_ampm.csv", "\n".join(lines) + "\n")
    TRUTH["mdy_ampm.csv"] = {"t": k * 5.0, "pressure": p_psi * PSI, "start_time": t2}
    # date and time in two columns
    t3 = datetime(2023, 11, 30, 23, 59, 50)
    lines = ["Date\tTime\tPressure (bar)\tRate (l/min)"]
    for i in k:
        ts = t3 + timedelta(seconds=int(i))
        lines.append(f"{ts:%Y-%m-%d}\t{ts:%H:%M:%S}\t{p_bar[i]:.3f}\t{q[i]:.1f}")
    _write("date_time_columns.tsv", "\n".join(lines) + "\n")
    TRUTH["date_time_columns.tsv"] = {"t": k * 1.0, "pressure": p_bar * BAR, "start_time": t3}
    # ambiguous: 01/02 .. 02/02 could be 1-2 Feb or Jan 2 - Feb 2; both one day apart?
    # no: read month first the gap is a month, so the reader decides day first. A truly
    # ambiguous one stays on one day: 05/06/2024 all day.
    t4 = datetime(2024, 6, 5, 10, 0, 0)
    lines = ["Timestamp;Pressure [bar];Rate [l/min]"]
    for i in k:
        ts = t4 + timedelta(seconds=int(i) * 10)
        lines.append(f"{ts:%d/%m/%Y %H:%M:%S};{p_bar[i]:.3f};{q[i]:.1f}")
    _write("ambiguous_dates.csv", "\n".join(lines) + "\n")
    TRUTH["ambiguous_dates.csv"] = {"t": k * 10.0, "start_time_dmy": t4,
                                    "start_time_mdy": datetime(2024, 5, 6, 10, 0, 0)}
    # elapsed time written as hh:mm:ss
    lines = ["Elapsed Time\tPressure (bar)\tRate (l/min)"]
    for i in k:
        s = int(i) * 300
        lines.append(f"{s // 3600:02d}:{s % 3600 // 60:02d}:{s % 60:02d}\t{p_bar[i]:.3f}\t{q[i]:.1f}")
    _write("elapsed_hhmmss.txt", "\n".join(lines) + "\n")
    TRUTH["elapsed_hhmmss.txt"] = {"t": k * 300.0, "pressure": p_bar * BAR}


def thousands_tab() -> None:
    """A stimulation log: tab separated, thousands separators in pressure and volume."""
    k, p_bar, q = _base()
    p_psi = np.round(p_bar * BAR / PSI * 1.7 + 1200.0)
    vol = np.round(1000.0 + 37.5 * k, 1)
    q_bpm = np.round(q / 1000 / BBL * 10, 1)
    lines = ["Job Time (min)\tTreating Pressure (psi)\tSlurry Rate (bpm)\tClean Volume (bbl)"]
    for a, b, c, d in zip(k, p_psi, q_bpm, vol):
        lines.append(f"{a}\t{int(b):,}\t{c:.1f}\t{d:,.1f}")
    _write("thousands_tab.txt", "\n".join(lines) + "\n")
    TRUTH["thousands_tab.txt"] = {"t": k * MIN, "pressure": p_psi * PSI,
                                  "rate": q_bpm * BBL / MIN, "volume": vol * BBL}


def blanks_trailing() -> None:
    """Blank cells, a not-recorded marker, trailing rows of empty cells, pressure 0 where the
    gauge was not recording while the pump ran."""
    k, p_bar, q = _base()
    p = p_bar.copy()
    rows = []
    for i in k:
        pc = f"{p[i]:.3f}"
        if 2 <= i <= 5:
            pc = "0"                      # gauge not recording while pumping
        if i == 15:
            pc = ""                       # blank
        qc = "N/A" if i == 18 else f"{q[i]:.1f}"
        rows.append(f"{i * 4},{pc},{qc},")
    rows += [",,,", ",,,", ""]
    _write("blanks_trailing.csv", "\n".join(["time (s),Pressure (bar),Rate (l/min),Note"]
                                            + rows) + "\n")
    pt = p * BAR
    pt[2:6] = np.nan
    pt[15] = np.nan
    qt = q / 1000 / MIN
    qt[18] = np.nan
    TRUTH["blanks_trailing.csv"] = {"t": k * 4.0, "pressure": pt, "rate": qt}


def impossible_cell() -> None:
    """One absurd cell (1e30 bar) among plausible ones: reported and dropped."""
    k, p_bar, q = _base()
    lines = ["time (s),Pressure (bar),Rate (l/min)"]
    for i in k:
        pc = "1e30" if i == 7 else f"{p_bar[i]:.3f}"
        lines.append(f"{i},{pc},{q[i]:.1f}")
    _write("impossible_cell.csv", "\n".join(lines) + "\n")
    pt = p_bar * BAR
    pt[7] = np.nan
    TRUTH["impossible_cell.csv"] = {"t": k * 1.0, "pressure": pt, "dropped_line": 9}


def remarks_column() -> None:
    """Operator remarks in a text column and as a row of their own."""
    k, p_bar, q = _base()
    lines = ["Elapsed (s)\tPressure (bar)\tRate (l/min)\tComment"]
    for i in k:
        c = {1: "start pump", 10: "shut in"}.get(int(i), "")
        lines.append(f"{i * 6}\t{p_bar[i]:.3f}\t{q[i]:.1f}\t{c}")
        if i == 20:
            lines.append(f"{i * 6 + 3}\tbleed off planned")
    _write("remarks_column.tsv", "\n".join(lines) + "\n")
    TRUTH["remarks_column.tsv"] = {"t": k * 6.0, "pressure": p_bar * BAR,
                                   "events": [(6.0, "start pump"), (60.0, "shut in"),
                                              (123.0, "bleed off planned")]}


def workbooks() -> None:
    """A mini-frac workbook (.xlsx, openpyxl): a notes sheet first, then a data sheet with a
    title block, a header and a units row, date-time cells, and no pressure (blank or 0)
    while pumping; the same data as an OpenDocument sheet (.ods, odfpy via pandas)."""
    import openpyxl
    import pandas as pd

    k, p_bar, q = _base()
    t0 = datetime(2024, 5, 2, 14, 0, 0)
    p_psi = np.round(p_bar * BAR / PSI, 1)
    q_bpm = np.round(q / 1000 / BBL, 2)
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Notes"
    ws.append(["Mini-frac, well X-2"])
    ws.append(["Operator notes only"])
    ws2 = wb.create_sheet("Job data")
    ws2.append(["Mini-frac treatment report"])
    ws2.append(["Well", "X-2"])
    ws2.append([])
    ws2.append(["Date Time", "Tubing Pressure", "Slurry Rate", "Remarks"])
    ws2.append(["", "psi", "bpm", ""])
    pt = p_psi * PSI
    for i in k:
        ts = t0 + timedelta(seconds=int(i) * 30)
        if 1 <= i <= 4:
            pv = None                         # no pressure while pumping: blank ...
            pt[i] = np.nan
        elif 5 <= i <= 8:
            pv = 0                            # ... or written as 0
            pt[i] = np.nan
        else:
            pv = float(p_psi[i])
        ws2.append([ts, pv, float(q_bpm[i]), "shut in" if i == 10 else None])
    ws2.append([])
    ws2.append(["ISIP", 2350])
    wb.properties.created = datetime(2024, 5, 2)
    wb.properties.modified = datetime(2024, 5, 2)
    wb.save(OUT / "minifrac_workbook.xlsx")
    TRUTH["minifrac_workbook.xlsx"] = {"t": k * 30.0, "pressure": pt,
                                       "rate": q_bpm * BBL / MIN, "start_time": t0,
                                       "sheet": "Job data"}
    df = pd.DataFrame({"Time (min)": k * 0.5, "Pressure (MPa)": np.round(p_bar / 10, 4),
                       "Rate (m3/min)": q / 1000})
    df.to_excel(OUT / "sheet.ods", engine="odf", index=False, sheet_name="Data")
    TRUTH["sheet.ods"] = {"t": k * 30.0, "pressure": np.round(p_bar / 10, 4) * MPA,
                          "rate": q / 1000 / MIN}
    # a log across midnight in date-time cells: the cell at exactly 00:00:00 comes out of
    # the workbook reader as a bare date and must still read as that midnight
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Log"
    ws.append(["Date/Time", "Pressure (bar)", "Rate (l/min)"])
    t0 = datetime(2024, 3, 5, 23, 58, 0)
    for i in k:
        ws.append([t0 + timedelta(seconds=int(i) * 10), float(p_bar[i]), float(q[i])])
    wb.properties.created = datetime(2024, 3, 5)
    wb.properties.modified = datetime(2024, 3, 5)
    wb.save(OUT / "workbook_midnight.xlsx")
    TRUTH["workbook_midnight.xlsx"] = {"t": k * 10.0, "pressure": p_bar * BAR,
                                       "rate": q / 1000 / MIN, "start_time": t0}


def stimulation_logs() -> None:
    """Two stimulation-log shapes: a tab file with a title line, a units row that also holds
    a unit the reader does not use (``ppa``), clock times crossing midnight and thousands
    separators; and a quoted comma CSV with ``M/D/YYYY`` dates and times in two columns, a
    units row, quoted thousands, and a bottom-hole beside the treating pressure."""
    k = np.arange(30)
    whp = 5000 + 37 * k
    vol = np.round(1000 + 1.3 * k, 1)
    lines = ["Stage 3 treatment log", "Company: ACME Frac", "",
             "Time\tWHP\tRate\tProp Conc\tTotal Volume", "hh:mm:ss\tpsi\tbpm\tppa\tbbl"]
    for i in k:
        s_ = (23 * 3600 + 59 * 60 + 10 + int(i) * 4) % 86400
        lines.append(f"{s_ // 3600:02d}:{s_ % 3600 // 60:02d}:{s_ % 60:02d}\t{whp[i]:,}\t40.5\t"
                     f"0.50\t{vol[i]:,.1f}")
    _write("stim_units_row.txt", "\n".join(lines) + "\n")
    TRUTH["stim_units_row.txt"] = {"t": k * 4.0, "pressure": whp * PSI, "volume": vol * BBL,
                                   "rate": np.full(k.size, 40.5 * BBL / MIN),
                                   "start_clock": "23:59:10"}
    t0 = datetime(2022, 4, 5, 23, 59, 0)
    tp = 3000 + 3 * k
    lines = ['"Date","Time","Treating Pressure","Slurry Rate","Bottomhole Pressure"',
             '"","","psi","bpm","psi"']
    for i in k:
        ts = t0 + timedelta(seconds=int(i) * 5)
        lines.append(f'"{ts.month}/{ts.day}/{ts.year}","{ts.hour}:{ts:%M:%S}","{tp[i]:,}",'
                     f'"12.5","{tp[i] + 4500:,}"')
    _write("stim_quoted.csv", "\n".join(lines) + "\n")
    TRUTH["stim_quoted.csv"] = {"t": k * 5.0, "pressure": (tp + 4500) * PSI,
                                "surface_pressure": tp * PSI, "start_time": t0}


ALL = (dfit_save_file, quoted_comma_header, name_comma_unit_tab, name_space_unit,
       single_space_titles, units_row_and_no_units, synonyms_pair, non_english, clock_midnight, datetime_orders,
       thousands_tab, stimulation_logs, blanks_trailing, impossible_cell, remarks_column, workbooks)


def build(only_text: bool = False) -> None:
    """Write the fixtures (and fill :data:`TRUTH`); ``only_text`` skips the workbooks."""
    for f in ALL:
        if only_text and f is workbooks:
            continue
        f()


if __name__ == "__main__":
    build()
    sys.exit(0)
