"""One test per convention the reader handles (issue 15), on the fixtures of tests/data/logs.

The expected values come from ``tests/data/logs/make_fixtures.py``: the numbers it wrote
times unit factors typed in from their definitions (not pint, which the reader uses).
"""

from __future__ import annotations

import importlib.util
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from xlotkit.errors import InputError
from xlotkit.interpret.io import read_log, read_logs

FIX = Path(__file__).resolve().parents[1] / "data" / "logs"

_spec = importlib.util.spec_from_file_location("make_fixtures", FIX / "make_fixtures.py")
mk = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mk)


@pytest.fixture(scope="module")
def truth(tmp_path_factory):
    """Regenerate every fixture in a temporary folder: the expected values, and a check
    that the committed text fixtures are exactly what the script writes."""
    out = tmp_path_factory.mktemp("fixtures")
    mk.OUT = out
    mk.build()
    for f in out.iterdir():
        if f.suffix in (".xlsx", ".ods"):
            continue
        assert (FIX / f.name).read_bytes() == f.read_bytes(), f.name
    return dict(mk.TRUTH)


def _close(a, b, rtol=1e-12):
    np.testing.assert_allclose(np.asarray(a, float), np.asarray(b, float), rtol=rtol, atol=0,
                               equal_nan=True)


# ---------------------------------------------------------------------------- preambles
def test_dfit_save_file_preamble_and_analysis_block(truth):
    tr = truth["dfit_save_file.txt"]
    r = read_log(FIX / "dfit_save_file.txt")
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])
    _close(r.rate, tr["rate"])
    # "BH Pressure" -> downhole, at the preamble's gauge depth
    assert r.reference.kind == "downhole" and r.reference.depth_m == tr["depth_m"]
    pre = r.meta["preamble"]
    assert pre["tinj"] == "520" and pre["Well"] == "X-1" and pre["Program"].startswith("Closure")
    assert any("version 4.2.1" in c for c in r.meta["comments"])
    # the GFunction / tClosure block after the data is not data
    assert r.n == tr["t"].size
    assert any("tClosure 522" in x for x in r.meta["trailer"])


# ---------------------------------------------------------------------------- headers
@pytest.mark.parametrize("name", ["quoted_comma_header.csv", "name_comma_unit.tsv",
                                  "units_row_kgf.tsv", "german_semicolon.csv"])
def test_header_unit_spellings(truth, name):
    tr = truth[name]
    r = read_log(FIX / name)
    for k in ("t", "pressure", "rate", "volume", "temperature"):
        if k in tr:
            _close(r.series(k) if k != "t" else r.t, tr[k])


def test_name_space_unit_whitespace_columns_annulus(truth):
    tr = truth["name_space_unit.txt"]
    r = read_log(FIX / "name_space_unit.txt")
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])
    _close(r.channels["annulus_pressure"], tr["annulus_pressure"])
    _close(r.rate, tr["rate"])
    assert r.reference.kind == "surface" and r.reference.absolute is False   # psig


@pytest.mark.parametrize("name", ["single_space_titles.txt", "unquoted_comma_titles.csv"])
def test_titles_split_at_the_separator_regrouped_at_their_units(truth, name):
    tr = truth[name]
    r = read_log(FIX / name)
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])
    if "rate" in tr:
        _close(r.rate, tr["rate"])
    assert r.reference.absolute is tr["absolute"]


def test_no_units_refused_with_the_flag_then_supplied(truth):
    tr = truth["no_units.csv"]
    # every unitless column the record uses is named at once, with the flags for all
    with pytest.raises(InputError) as exc:
        read_log(FIX / "no_units.csv")
    assert str(exc.value).endswith("no_units.csv:1: columns 'time', 'p', 'q' have no unit: "
                                   "pass --unit time=s --unit pressure=psi --unit rate=bpm")
    with pytest.raises(InputError) as exc:
        read_log(FIX / "no_units.csv", units={"time": "s", "rate": "l/min"})
    assert str(exc.value).endswith("no_units.csv:1: column 'p' has no unit: pass --unit "
                                   "pressure=psi")
    r = read_log(FIX / "no_units.csv", units=["time=s", "pressure=bar", "rate=l/min"])
    _close(r.pressure, tr["pressure_if_bar"])
    _close(r.rate, tr["rate_if_lpm"])
    col = {c.name: c for c in r.columns}["p"]
    assert col.unit == "bar" and col.unit_source == "--unit"
    assert col.resolution == pytest.approx(1e5)          # 1 bar steps written


def test_synonyms_bottomhole_and_surface_pair(truth):
    tr = truth["synonyms_bh_whp.csv"]
    r = read_log(FIX / "synonyms_bh_whp.csv")
    assert r.reference.kind == "downhole"
    _close(r.pressure, tr["pressure"])
    _close(r.channels["surface_pressure"], tr["surface_pressure"])
    assert "annulus_pressure" in r.channels
    _close(r.rate, tr["rate"])
    assert r.start_time == tr["start_time"]
    # --column swaps the roles
    r2 = read_log(FIX / "synonyms_bh_whp.csv", columns={"pressure": "WHP",
                                                         "surface_pressure": "BH Pressure"})
    _close(r2.pressure, tr["surface_pressure"])
    _close(r2.channels["surface_pressure"], tr["pressure"])
    # a column by number
    r3 = read_log(FIX / "synonyms_bh_whp.csv", columns=["pressure=3"])
    _close(r3.pressure, tr["surface_pressure"])
    with pytest.raises(InputError, match="--column pressure=Nope: no such column"):
        read_log(FIX / "synonyms_bh_whp.csv", columns={"pressure": "Nope"})


def test_header_and_units_row_disagree_refused_naming_both(tmp_path):
    p = tmp_path / "conflict.tsv"
    p.write_text("Time (s)\tPressure (psi)\ns\tbar\n0\t1\n1\t2\n")
    with pytest.raises(InputError) as exc:
        read_log(p)
    msg = str(exc.value)
    assert "conflict.tsv:2" in msg and "line 1" in msg and "'psi'" in msg and "'bar'" in msg
    # agreeing spellings are fine
    p.write_text("Time (s)\tPressure (psi)\ns\tpsia\n0\t1\n1\t2\n")
    assert read_log(p).reference.absolute is True


# ---------------------------------------------------------------------------- time
def test_clock_time_crossing_midnight(truth):
    tr = truth["clock_midnight.txt"]
    r = read_log(FIX / "clock_midnight.txt")
    _close(r.t, tr["t"])
    assert r.start_time is None and r.meta["start_clock"] == tr["start_clock"]
    r2 = read_log(FIX / "clock_with_date.txt")
    _close(r2.t, truth["clock_with_date.txt"]["t"])
    assert r2.start_time == truth["clock_with_date.txt"]["start_time"]


@pytest.mark.parametrize("name", ["iso_zones.csv", "dmy_dots.csv", "mdy_ampm.csv",
                                  "date_time_columns.tsv"])
def test_date_orders_separators_zones(truth, name):
    tr = truth[name]
    r = read_log(FIX / name)
    _close(r.t, tr["t"])
    assert r.start_time == tr["start_time"]
    if "pressure" in tr:
        _close(r.pressure, tr["pressure"])
    if "utc_offset" in tr:
        assert r.meta["utc_offset"] == tr["utc_offset"]


def test_ambiguous_day_month_asked_for(truth):
    tr = truth["ambiguous_dates.csv"]
    with pytest.raises(InputError) as exc:
        read_log(FIX / "ambiguous_dates.csv")
    assert "ambiguous_dates.csv:2" in str(exc.value) and "--date-order DMY" in str(exc.value)
    assert read_log(FIX / "ambiguous_dates.csv", date_order="DMY").start_time == \
        tr["start_time_dmy"]
    assert read_log(FIX / "ambiguous_dates.csv", date_order="MDY").start_time == \
        tr["start_time_mdy"]


def test_day_month_decided_by_a_month_long_gap(tmp_path):
    p = tmp_path / "gap.csv"
    # 10 and 11 December read day first; month first they would be 12 Oct and 12 Nov
    p.write_text("Timestamp,Pressure (bar),Rate (l/min)\n10/12/2023 23:59:58,1,0\n"
                 "11/12/2023 00:00:01,2,0\n")
    r = read_log(p)
    assert r.start_time == datetime(2023, 12, 10, 23, 59, 58)
    assert any("DMY" in n for n in r.meta["notes"])


def test_elapsed_time_as_hhmmss(truth):
    r = read_log(FIX / "elapsed_hhmmss.txt")
    _close(r.t, truth["elapsed_hhmmss.txt"]["t"])
    assert r.start_time is None and "start_clock" not in r.meta


# ---------------------------------------------------------------------------- numbers
def test_thousands_separators_decided_from_the_column(truth):
    tr = truth["thousands_tab.txt"]
    r = read_log(FIX / "thousands_tab.txt")
    _close(r.pressure, tr["pressure"])          # 3,431 psi is 3431 psi
    _close(r.volume, tr["volume"])
    _close(r.rate, tr["rate"])
    assert any("thousands" in n for n in r.meta["notes"])


def test_stimulation_logs_units_row_clock_thousands(truth):
    tr = truth["stim_units_row.txt"]
    r = read_log(FIX / "stim_units_row.txt")
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])
    _close(r.volume, tr["volume"])
    _close(r.rate, tr["rate"])
    assert r.meta["start_clock"] == tr["start_clock"] and r.start_time is None
    assert r.meta["preamble"]["Company"] == "ACME Frac"
    assert "Stage 3 treatment log" in r.meta["comments"]
    tr = truth["stim_quoted.csv"]
    r = read_log(FIX / "stim_quoted.csv")
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])                 # the bottom-hole one
    _close(r.channels["surface_pressure"], tr["surface_pressure"])
    assert r.start_time == tr["start_time"] and r.reference.kind == "downhole"


def test_three_digit_commas_alone_are_asked_for(tmp_path):
    p = tmp_path / "amb.txt"
    p.write_text("Time (s)\tPressure (psi)\n0\t3,431\n1\t3,502\n")
    with pytest.raises(InputError, match="--decimal"):
        read_log(p)
    assert read_log(p, decimal=".").pressure[0] == pytest.approx(3431 * mk.PSI)
    assert read_log(p, decimal=",").pressure[0] == pytest.approx(3.431 * mk.PSI)


def test_blank_cells_markers_trailing_rows_and_zero_not_recorded(truth):
    tr = truth["blanks_trailing.csv"]
    r = read_log(FIX / "blanks_trailing.csv")
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])
    _close(r.rate, tr["rate"])
    cols = {c.name: c for c in r.columns}
    assert cols["Pressure"].n_missing == 5 and cols["Rate"].n_missing == 1
    assert r.n == tr["t"].size                     # the trailing rows of empty cells are no data
    # the surface gauge at rest reads 0 bar: a recorded zero stays zero
    p = FIX.parent.parent / "data" / "logs" / "cu_repeated_header.txt"
    assert read_log(p).pressure[-1] == 0.0


def test_impossible_cell_dropped_and_reported(truth):
    tr = truth["impossible_cell.csv"]
    r = read_log(FIX / "impossible_cell.csv")
    _close(r.pressure, tr["pressure"])
    col = {c.name: c for c in r.columns}["Pressure"]
    assert [d[0] for d in col.dropped] == [tr["dropped_line"]]
    assert float(col.dropped[0][1]) == 1e30
    assert any("line 9" in n and "dropped" in n for n in r.meta["notes"])


def test_values_impossible_for_their_unit_refused(tmp_path):
    p = tmp_path / "pa_as_bar.csv"
    p.write_text("time (s),Pressure (bar)\n" + "".join(f"{i},{2e7 + i}\n" for i in range(50)))
    with pytest.raises(InputError) as exc:
        read_log(p)
    msg = str(exc.value)
    assert "pa_as_bar.csv:2" in msg and "impossible" in msg and "--unit pressure=" in msg
    assert read_log(p, units={"pressure": "Pa"}).pressure[0] == pytest.approx(2e7)
    q = tmp_path / "neg_abs.csv"
    q.write_text("time (s),Pressure (psia)\n" + "".join(f"{i},{-5 - i}\n" for i in range(50)))
    with pytest.raises(InputError, match="negative absolute"):
        read_log(q)


def test_huge_pressure_cell_does_not_exhaust_memory(tmp_path):
    from xlotkit.interpret.phases import segment

    p = tmp_path / "huge.csv"
    rows = [f"{i},{100 + (i % 7)}" for i in range(3000)]
    rows[1500] = "1500,1e12"
    p.write_text("time (s),Pressure (bar)\n" + "\n".join(rows) + "\n")
    r = read_log(p)                    # one absurd cell: dropped
    assert np.isnan(r.pressure[1500])
    # and the segmentation bounds its histogram by the record, whatever it is given
    seg = segment(r.replace(pressure=np.where(np.isnan(r.pressure), 1e17, r.pressure)))
    assert seg is not None


# ---------------------------------------------------------------------------- remarks
def test_remarks_column_and_remark_rows_become_events(truth):
    tr = truth["remarks_column.tsv"]
    r = read_log(FIX / "remarks_column.tsv")
    _close(r.t, tr["t"])
    assert [(e.t, e.text) for e in r.events] == tr["events"]


# ---------------------------------------------------------------------------- workbooks
def test_minifrac_workbook_default_sheet_no_pressure_while_pumping(truth):
    tr = truth["minifrac_workbook.xlsx"]
    r = read_log(FIX / "minifrac_workbook.xlsx")
    assert r.meta["sheet"] == tr["sheet"]
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])        # blank and 0 while pumping: NaN
    _close(r.rate, tr["rate"])
    assert r.start_time == tr["start_time"]
    assert [e.text for e in r.events] == ["shut in"]
    assert any("ISIP" in x for x in r.meta["trailer"])
    # by name and by number
    assert read_log(FIX / "minifrac_workbook.xlsx", sheet="Job data").n == r.n
    assert read_log(FIX / "minifrac_workbook.xlsx", sheet="2").n == r.n
    with pytest.raises(InputError, match="no such sheet"):
        read_log(FIX / "minifrac_workbook.xlsx", sheet="Nope")
    with pytest.raises(InputError, match="sheets"):
        read_log(FIX / "minifrac_workbook.xlsx", sheet="7")


def test_workbook_date_times_across_midnight(truth):
    tr = truth["workbook_midnight.xlsx"]
    r = read_log(FIX / "workbook_midnight.xlsx")
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])
    _close(r.rate, tr["rate"])
    assert r.start_time == tr["start_time"]


def test_ods_sheet(truth):
    tr = truth["sheet.ods"]
    r = read_log(FIX / "sheet.ods")
    _close(r.t, tr["t"])
    _close(r.pressure, tr["pressure"])
    _close(r.rate, tr["rate"])


# ---------------------------------------------------------------------------- read_logs
def test_read_logs_column_choice_needs_to_fit_one_file(truth):
    a = FIX / "synonyms_bh_whp.csv"
    b = FIX / "dfit_save_file.txt"
    # WHP makes the first file a surface record: a surface + downhole pair, merged if
    # the clocks overlap (they do not here, which is said in one error)
    with pytest.raises(InputError, match="overlap"):
        read_logs([a, b], columns={"pressure": "WHP"})
    with pytest.raises(InputError, match="no such column in any"):
        read_logs([a, b], columns={"pressure": "Nope"})


# ---------------------------------------------------------------------------- speed helpers
def test_running_median_is_scipys_median_filter():
    # the running median went from scipy.ndimage to pandas' rolling median for the reader's
    # speed target (issue 15); the numbers must not change
    from scipy.ndimage import median_filter

    from xlotkit.interpret.phases.signal import running_median as _median

    rng = np.random.default_rng(0)
    for n in (1, 3, 5, 31, 61):
        for size in (1, 2, 5, 50, 5000):
            x = np.round(rng.normal(0, 1, size) * 1e5) / 7
            np.testing.assert_array_equal(_median(x, n), median_filter(x, size=n,
                                                                       mode="nearest"))


def test_impossible_time_named_as_written(tmp_path):
    # the error quotes the cell as the file has it, never a numpy repr
    f = tmp_path / "t.csv"
    f.write_text("Time (s),Pressure (bar)\n0,100\n1,110\n2,120\n1e30,130\n")
    with pytest.raises(InputError) as exc:
        read_log(f)
    msg = str(exc.value)
    assert "t.csv:5:" in msg and "'1e+30'" in msg and "np." not in msg
