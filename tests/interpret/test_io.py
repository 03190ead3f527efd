"""Reading field logs (AMS-01 and CSV fixtures), merging surface/downhole, writing."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from xlotkit.errors import InputError
from xlotkit.interpret.io import (
    ClockOffset,
    estimate_clock_offset,
    merge_surface_downhole,
    read_log,
    read_logs,
    write_log,
)
from xlotkit.record import PressureReference, Record

HERE = Path(__file__).resolve()
FIX = HERE.parents[1] / "data" / "logs"
AMS = HERE.parents[2] / ".." / "shared" / "data" / "field" / "AMS-01"
CU1 = AMS / "XLOT 1 - Main Claystone_Cementing Unit_Data.txt"
DH1 = AMS / "XLOT 1 - Main Claystone_Downhole Gauge_Data.TXT"
CU2 = AMS / "XLOT 2 - Vlieland Claystone_Cementing Unit_Data.TXT"
DH2 = AMS / "XLOT 2 - Vlieland Claystone_Downhole Gauge_Data.TXT"

needs_ams = pytest.mark.skipif(not all(p.exists() for p in (CU1, DH1, CU2, DH2)),
                               reason=f"AMS-01 field data not found under {AMS}")

PSI = 6894.757293168361
BAR = 1e5


def _index_at(rec: Record, stamp: str) -> int:
    ts = rec.timestamps
    hit = np.flatnonzero(ts == np.datetime64(stamp, "ms"))
    assert hit.size == 1, stamp
    return int(hit[0])


@pytest.fixture(scope="module")
def ams():
    if not all(p.exists() for p in (CU1, DH1, CU2, DH2)):
        pytest.skip(f"AMS-01 field data not found under {AMS}")
    return {key: read_log(p) for key, p in (("cu1", CU1), ("dh1", DH1), ("cu2", CU2),
                                            ("dh2", DH2))}


# ---------------------------------------------------------------------------- AMS-01
@needs_ams
def test_cementing_unit_xlot1_samples_values_units(ams):
    r = ams["cu1"]
    # 10233 lines - 3 header lines - 9 remark rows = 10221 data rows, none dropped
    assert r.n == 10221
    assert r.meta["kind"] == "cementing_unit"
    assert r.reference == PressureReference("surface", None, False)
    assert r.start_time == datetime(2023, 12, 10, 14, 42, 58)     # line 4, mm:dd:yyyy
    assert r.pressure[0] == pytest.approx(3 * BAR)                 # 3 bars
    assert r.density[0] == pytest.approx(1090.0)                   # 1.09 sgu
    # line 2408: 12:10:2023:15:22:57  175 bar  270 l/min  Volume 0.95 m3 (after a reset
    # at line 1841 from 0.36 m3)
    i = _index_at(r, "2023-12-10T15:22:57")
    assert r.pressure[i] == pytest.approx(175 * BAR)
    assert r.rate[i] == pytest.approx(270e-3 / 60.0)
    assert r.channels["volume_raw"][i] == pytest.approx(0.95)
    assert r.volume[i] == pytest.approx(0.36 + 0.95)
    assert r.channels["tot_vol_nrd"][i] == pytest.approx(0.954)
    assert r.meta["volume_resets_at_lines"] == [1841, 7245, 8340]
    # column mapping decisions documented in the report
    fields = {c.name: c.field for c in r.columns}
    assert fields == {"Time": "timestamp", "Treating Pressure": "pressure", "Flow Rate": "rate",
                      "Density": "density", "Volume": "volume",
                      "TOT vol nrd": "channel:tot_vol_nrd", "NRD VOLUME": "channel:nrd_volume",
                      "RETURN VOL": "return_volume", "total bla": "channel:total_bla",
                      "RDA2 IN1": "channel:rda2_in1"}
    assert np.all(np.diff(r.t) > 0)
    # 8 pairs of rows share a whole second (after a 2 s step): spread inside the second
    assert r.meta["same_second_rows_spread"] == 16


@needs_ams
def test_cementing_unit_events_have_lines_and_text(ams):
    ev = {(e.line, e.text) for e in ams["cu1"].events}
    assert (6, "flush lines") in ev
    assert (7243, "Reset Total, Vol = 1.56  m3") in ev
    assert (7250, "start test 2") in ev
    assert len(ams["cu1"].events) == 9
    e = next(e for e in ams["cu1"].events if e.line == 6)
    assert e.timestamp == datetime(2023, 12, 10, 14, 43, 0) and e.t == pytest.approx(2.0)
    assert e.source == CU1.name
    ev2 = [(e.line, e.text) for e in ams["cu2"].events]
    assert (2056, "Start first XLOT test") in ev2 and (4841, "XLOT#3") in ev2
    assert len(ev2) == 12


@needs_ams
def test_volume_continuous_across_resets_and_monotone_while_pumping(ams):
    for key in ("cu1", "cu2"):
        r = ams[key]
        raw = r.channels["volume_raw"]
        assert raw.min() == pytest.approx(0.0) and np.any(np.diff(raw) < -0.1)   # resets in raw
        dv = np.diff(r.volume)
        assert dv.min() > -0.01          # only a count of totaliser jitter, never a reset
        pumping = r.rate[1:] > 50e-3 / 60.0
        # XLOT 2's raw volume column steps back by up to 9 l for one row at the logger's
        # skipped seconds (e.g. 1.109, 1.118, 1.109 m3 at 14:59:53-55): a glitch of the
        # export, left as it is; never more, and rarely
        assert np.all(dv[pumping] >= -0.0095)
        assert np.mean(dv[pumping] < 0) < 0.05
        assert np.sum(dv[pumping]) > 1.0
        assert r.volume[-1] >= raw.max()
        assert np.diff(r.return_volume).min() > -1e-9
    r2 = ams["cu2"]
    # line 5033: 12:12:2023:15:40:36  91 bar 491.3 l/min 2.817 m3 (+0.200 before the reset at
    # line 1786); return volume 0.032 (+0.008 before its reset at line 1764)
    i = _index_at(r2, "2023-12-12T15:40:36")
    assert r2.pressure[i] == pytest.approx(91 * BAR)
    assert r2.rate[i] == pytest.approx(491.3e-3 / 60.0)
    assert r2.volume[i] == pytest.approx(2.817 + 0.200)
    assert r2.return_volume[i] == pytest.approx(0.032 + 0.008)
    assert r2.channels["return_pressure"][i] == pytest.approx(89 * BAR)
    assert r2.channels["return_density"][i] == pytest.approx(1040.0)
    assert r2.n == 10342


@needs_ams
def test_downhole_gauges_decimal_comma_and_point(ams):
    r1, r2 = ams["dh1"], ams["dh2"]
    assert r1.n == 33792 and r2.n == 27264            # = "No Points" of the preamble
    assert r1.reference == PressureReference("downhole", 1383.0, True)   # "1.383 m MD"
    assert r2.reference == PressureReference("downhole", 910.0, True)
    assert r1.meta["gauge_depth_m"] == 1383.0 and r2.meta["gauge_depth_m"] == 910.0
    assert r1.meta["well"] == "Amstelland" and r1.meta["gauge_serial"] == "9380"
    assert r1.meta["test"] == "XLOT_9dec" and r2.meta["test"] == "XLOT2"
    # line 8 of each file (dd-mm-yyyy): psi absolute -> Pa, °C -> K
    assert r1.start_time == datetime(2023, 12, 9, 21, 24, 9)
    assert r1.pressure[0] == pytest.approx(64.782 * PSI)
    assert r1.temperature[0] == pytest.approx(12.9 + 273.15)
    assert r1.pressure[-1] == pytest.approx(9.307 * PSI)
    # line 20000 = sample 19992: 16.66 h, 2156.505 psi, 51.6 °C
    assert r1.t[19992] == pytest.approx(16.66 * 3600)
    assert r1.pressure[19992] == pytest.approx(2156.505 * PSI)
    assert r1.temperature[19992] == pytest.approx(51.6 + 273.15)
    assert r2.start_time == datetime(2023, 12, 12, 1, 20, 12)
    assert r2.pressure[0] == pytest.approx(61.933 * PSI)
    assert r2.pressure[-1] == pytest.approx(37.143 * PSI)
    assert r2.temperature[-1] == pytest.approx(20.3 + 273.15)
    assert r2.t[-1] == pytest.approx(22.71916667 * 3600, abs=1e-3)
    assert np.allclose(np.diff(r1.t), 3.0) and np.allclose(np.diff(r2.t), 3.0)
    # gauge pressure removes one atmosphere
    assert r1.gauge_pressure()[0] == pytest.approx(64.782 * PSI - 101325.0)
    units = {c.name: c.unit for c in r1.columns}
    assert units["Temperature"] == "°C" and units["Pressure"] == "psi absolute"


@needs_ams
@pytest.mark.parametrize("pair,expected", [(("cu1", "dh1"), 3690.5), (("cu2", "dh2"), 3586.0)])
def test_merge_finds_about_one_hour_clock_offset(ams, pair, expected):
    s, d = ams[pair[0]], ams[pair[1]]
    merged, off = merge_surface_downhole(s, d)
    print(f"{pair}: offset {off.offset_s:.2f} s +- {off.uncertainty_s:.2f}, "
          f"correlation {off.correlation:.3f}, second peak {off.second_peak:.3f}")
    assert isinstance(off, ClockOffset)
    # the gauge clock runs about an hour (3600 s) behind the cementing unit, plus 1-2 min;
    # measured 3690.5 s (XLOT 1) and 3586.0 s (XLOT 2). Tolerance: 2 downhole samples.
    assert off.offset_s == pytest.approx(expected, abs=6.0)
    assert 3300 < off.offset_s < 3900
    assert off.correlation > 0.5 and off.second_peak < 0.5 * off.correlation
    assert 0 < off.uncertainty_s < 3.0
    # merged record: downhole pressure and reference, surface series interpolated
    assert merged.reference == d.reference
    assert merged.meta["clock_offset_s"] == off.offset_s
    assert merged.rate is not None and merged.volume is not None
    assert "surface_pressure" in merged.channels and merged.temperature is not None
    assert merged.duration <= s.duration + 1e-6
    assert np.allclose(np.diff(merged.t), 3.0)
    # when aligned, downhole - surface pressure at rest is the hydrostatic head of the
    # well fluid over the gauge depth (about rho g h), steady within ~1 bar
    head = merged.gauge_pressure() - merged.channels["surface_pressure"]
    rho = np.median(s.density)
    assert np.median(head) == pytest.approx(rho * 9.81 * d.reference.depth_m, rel=0.03)
    # events from the surface file are kept, at the surface clock time of their stamp
    e = next(e for e in merged.events if e.text.lower().startswith("start"))
    assert abs((merged.start_time - e.timestamp).total_seconds() + e.t) < 1e-3
    assert len(merged.events) == len(s.events) + len(d.events)


@needs_ams
def test_read_logs_merges_pair_and_offset_override(ams):
    merged = read_logs([DH2, CU2])
    assert merged.reference.kind == "downhole" and merged.meta["kind"] == "merged"
    assert merged.meta["clock_offset_s"] == pytest.approx(3586.0, abs=6.0)
    given = read_logs([CU2, DH2], offset_s=3600.0)
    assert given.meta["clock_offset_s"] == 3600.0
    assert read_logs([CU2]).n == ams["cu2"].n


def _synthetic(shift: float, seed: int = 1):
    rng = np.random.default_rng(seed)
    # surface: 1 s samples, integer bar readings of a pump/shut-in/bleed sequence
    ts = np.arange(0.0, 9000.0, 1.0)

    def p_true(t):
        p = np.zeros_like(t)
        for t0, dur, top in ((600, 400, 80), (2500, 700, 120), (5200, 300, 60), (7000, 900, 150)):
            up = np.clip((t - t0) / dur, 0, 1) * top
            decay = np.where(t > t0 + dur, np.exp(-(t - t0 - dur) / 500.0), 1.0)
            p += np.where(t >= t0, up * decay, 0.0)
        return p * 1e5

    ps = np.round((p_true(ts) + rng.normal(0, 0.3e5, ts.size)) / 1e5) * 1e5
    # downhole: 3 s samples on a clock `shift` s behind, + hydrostatic + atmosphere
    td = np.arange(-2000.0, 12000.0, 3.0)
    pd_ = p_true(td + shift - shift) + 150e5 + 101325.0 + rng.normal(0, 0.05e5, td.size)
    start_s = datetime(2023, 12, 10, 14, 0, 0)
    from datetime import timedelta
    start_d = start_s - timedelta(seconds=shift) + timedelta(seconds=-2000.0)
    s = Record(t=ts, pressure=ps, start_time=start_s, rate=np.zeros(ts.size))
    d = Record(t=td - td[0], pressure=pd_, start_time=start_d,
               reference=PressureReference("downhole", 1383.0, True))
    return s, d


def test_estimator_recovers_synthetic_shift_within_one_sample():
    s, d = _synthetic(3717.0)
    off = estimate_clock_offset(s, d)
    assert off.offset_s == pytest.approx(3717.0, abs=3.0)   # one downhole sample
    assert off.correlation > 0.8
    merged, off2 = merge_surface_downhole(s, d)
    assert off2.offset_s == pytest.approx(off.offset_s)
    # after alignment surface and downhole pressures differ by the constant head
    diff = merged.gauge_pressure() - merged.channels["surface_pressure"]
    assert np.std(diff) < 1e5


def test_estimator_negative_shift_and_no_overlap():
    s, d = _synthetic(-1234.0, seed=3)
    assert estimate_clock_offset(s, d).offset_s == pytest.approx(-1234.0, abs=3.0)
    far = d.replace(start_time=datetime(2024, 1, 1))
    with pytest.raises(InputError, match="overlap"):
        estimate_clock_offset(s, far)


# ---------------------------------------------------------------------------- fixtures
def test_cementing_fixture_repeated_header_duplicates_reset():
    r = read_log(FIX / "cu_repeated_header.txt")
    assert r.meta["header_blocks"] == 2
    assert r.n == 9
    # two data rows stamped 10:00:02 are spread inside that second
    assert np.allclose(r.t, [0, 1, 2, 2.5, 3, 4, 5, 6, 7])
    # second block lists Volume before Density: values are taken by name
    assert np.allclose(r.density, [1050] * 7 + [1060] * 2)
    assert np.allclose(r.volume, [0.5, 0.5, 0.51, 0.51, 0.52, 0.53, 0.53, 0.54, 0.55])
    assert np.allclose(r.channels["volume_raw"][-4:], [0.53, 0.0, 0.01, 0.02])
    assert r.meta["volume_resets_at_lines"] == [16]
    assert [(e.line, e.text, e.t) for e in r.events] == [
        (6, "pump start", 2.0), (14, "Reset Total, Vol = 0.53  m3", 4.0)]
    assert r.pressure[-1] == 0.0 and not np.signbit(r.pressure[-1])   # "-0"
    assert r.return_volume[-1] == pytest.approx(0.004)


def test_csv_psi_bpm_header_units():
    r = read_log(FIX / "psi_bpm.csv")
    assert r.n == 4 and r.start_time is None
    assert np.allclose(r.t, [0, 10, 20, 30])
    assert r.pressure[1] == pytest.approx(150.5 * PSI)
    assert r.rate[1] == pytest.approx(0.5 * 0.158987294928 / 60.0)
    assert [(c.name, c.unit, c.field) for c in r.columns] == [
        ("time", "s", "time"), ("Pressure", "psi", "pressure"), ("Rate", "bpm", "rate")]


def test_csv_semicolon_decimal_comma():
    r = read_log(FIX / "semicolon_decimal_comma.csv")
    assert np.allclose(r.t, [0, 30, 60, 90])                  # minutes -> s
    assert np.allclose(r.pressure, [1.5e5, 2.25e5, 3e5, 2.5e5])
    assert r.rate[1] == pytest.approx(100e-3 / 60)
    assert r.temperature[-1] == pytest.approx(293.75)


def test_tsv_with_units_row_and_remark():
    r = read_log(FIX / "units_row.tsv")
    assert np.allclose(r.t, [0, 1800, 3600])                  # hours
    assert np.allclose(r.pressure, [0.1e6, 1.1e6, 2.1e6])
    assert r.rate[1] == pytest.approx(0.1 / 60)
    assert [(e.line, e.text, e.t) for e in r.events] == [(5, "shut in", 2700.0)]


def test_csv_timestamp_column_dayfirst_inferred_and_unknown_channel():
    r = read_log(FIX / "timestamps.csv")
    assert r.start_time == datetime(2023, 12, 13, 23, 59, 58)   # 13/12: day first
    assert np.allclose(r.t, [0, 1, 2, 3.5])
    assert r.pressure[0] == pytest.approx(1e5)
    assert r.rate[1] == pytest.approx(20e-3 / 60)
    assert "note" in r.channels                                  # unknown name, unit m


def test_ambiguous_dates_need_dayfirst(tmp_path):
    p = tmp_path / "amb.csv"
    p.write_text("Timestamp;Pressure [bar]\n01/02/2024 10:00:00;1\n01/02/2024 10:00:05;2\n")
    with pytest.raises(InputError) as exc:
        read_log(p)
    assert "amb.csv:2" in str(exc.value) and "--date-order" in str(exc.value)
    assert read_log(p, dayfirst=True).start_time == datetime(2024, 2, 1, 10)
    assert read_log(p, dayfirst=False).start_time == datetime(2024, 1, 2, 10)
    q = tmp_path / "iso.csv"
    q.write_text("time,P (MPa)\r\n2024-01-02T10:00:00,1\r\n2024-01-02T10:00:01.250,2\r\n")
    r = read_log(q, column_map={"P": "pressure"})
    assert np.allclose(r.t, [0, 1.25]) and r.pressure[1] == pytest.approx(2e6)


def test_column_map_units_and_reference_overrides(tmp_path):
    p = tmp_path / "odd.csv"
    p.write_text("secs,Druk,Debiet,Mystery\n0,10,0,1\n1,11,5,2\n")
    r = read_log(p, column_map={"secs": "time", "Druk": "pressure", "Debiet": "rate"},
                 units={"secs": "s", "Druk": "psia", "Debiet": "bpm"},
                 reference=PressureReference("downhole", 500.0, True))
    assert r.pressure[1] == pytest.approx(11 * PSI)
    assert r.reference.depth_m == 500.0
    cols = {c.name: c.field for c in r.columns}
    assert cols["Mystery"] == ""                     # no unit: listed, not used
    assert "mystery" not in r.channels
    # "Debiet" (Dutch for rate) is in the synonyms table: a rate without a unit is refused
    with pytest.raises(InputError, match="Debiet.*--unit rate="):
        read_log(p, column_map={"secs": "time", "Druk": "pressure"},
                 units={"secs": "s", "Druk": "bar"})
    r2 = read_log(p, column_map={"secs": "time", "Druk": "pressure", "Mystery": "channel:m"},
                  units={"secs": "s", "Druk": "bar", "Debiet": "l/min"})
    assert np.allclose(r2.channels["m"], [1, 2])
    assert read_log(p, column_map={"secs": "time", "Druk": "pressure", "Debiet": ""},
                    units={"secs": "s", "Druk": "psia"}).reference.absolute is True


# ---------------------------------------------------------------------------- writing
def test_round_trip_write_read(tmp_path):
    r = read_log(FIX / "cu_repeated_header.txt")
    out = write_log(r, tmp_path / "x.csv")
    text = out.read_text()
    assert "time (s),Pressure (bar),Rate (l/min)" in text and "# reference: surface" in text
    back = read_log(out)
    assert back.n == r.n and back.start_time == r.start_time
    assert back.reference == r.reference
    np.testing.assert_allclose(back.t, r.t, rtol=0, atol=1e-12)
    for name in ("pressure", "rate", "volume", "return_volume", "density"):
        np.testing.assert_allclose(back.series(name), r.series(name), rtol=1e-11, atol=0)
    assert set(back.channels) == set(r.channels)
    np.testing.assert_allclose(back.channels["volume_raw"], r.channels["volume_raw"], rtol=1e-11)
    assert [(e.t, e.text, e.line, e.source, e.timestamp) for e in back.events] == \
        [(e.t, e.text, e.line, e.source, e.timestamp) for e in r.events]
    assert back.meta["volume_resets_at_lines"] == [16]


@needs_ams
def test_round_trip_merged_field_record(tmp_path, ams):
    merged, _ = merge_surface_downhole(ams["cu2"], ams["dh2"])
    out = write_log(merged, tmp_path / "m.csv")
    back = read_log(out)
    assert back.reference == merged.reference == PressureReference("downhole", 910.0, True)
    np.testing.assert_allclose(back.pressure, merged.pressure, rtol=1e-11)
    np.testing.assert_allclose(back.temperature, merged.temperature, rtol=1e-11)
    for k, v in merged.channels.items():
        np.testing.assert_allclose(back.channels[k], v, rtol=1e-11, atol=1e-300)
    assert back.meta["clock_offset_s"] == merged.meta["clock_offset_s"]
    assert len(back.events) == len(merged.events)


def test_write_refuses_overwrite_and_is_atomic(tmp_path):
    r = read_log(FIX / "psi_bpm.csv")
    p = write_log(r, tmp_path / "a.csv")
    before = p.read_text()
    with pytest.raises(InputError) as exc:
        write_log(r.replace(pressure=r.pressure * 2), p)
    assert "a.csv" in str(exc.value) and "overwrite" in str(exc.value)
    assert p.read_text() == before
    write_log(r.replace(pressure=r.pressure * 2), p, overwrite=True)
    assert read_log(p).pressure[1] == pytest.approx(2 * 150.5 * PSI)
    assert [x.name for x in tmp_path.iterdir()] == ["a.csv"]     # no temp files left


# ---------------------------------------------------------------------------- errors
def _err(tmp_path, name, content, **kw) -> str:
    p = tmp_path / name
    p.write_bytes(content.encode("utf-8") if isinstance(content, str) else content)
    with pytest.raises(InputError) as exc:
        read_log(p, **kw)
    return str(exc.value)


def test_error_empty_file(tmp_path):
    msg = _err(tmp_path, "empty.csv", "")
    assert "empty.csv:1" in msg and "empty" in msg
    msg = _err(tmp_path, "blank.txt", "\n \r\n")
    assert "blank.txt" in msg


def test_error_missing_pressure_column(tmp_path):
    msg = _err(tmp_path, "nop.csv", "time (s),Rate (bpm)\n0,1\n1,2\n")
    assert "nop.csv:1" in msg and "pressure" in msg and "expected" in msg


def test_error_unit_not_understood_and_wrong_dimension(tmp_path):
    msg = _err(tmp_path, "u1.csv", "time (s),Pressure (bananas)\n0,1\n")
    assert "u1.csv:1" in msg and "Pressure" in msg and "bananas" in msg
    msg = _err(tmp_path, "u2.csv", "time (s),Pressure (l/min)\n0,1\n")
    assert "u2.csv:1" in msg and "Pressure" in msg and "not a pressure unit" in msg
    msg = _err(tmp_path, "u3.csv", "time,Pressure (bar)\n0,1\n")
    assert "u3.csv:1" in msg and "time" in msg and "unit" in msg


def test_error_malformed_line_names_line_and_column(tmp_path):
    msg = _err(tmp_path, "bad.csv", "time (s),Pressure (bar),Rate (l/min)\n0,1,2\n1,x7,3\n2,3,4\n")
    assert "bad.csv:3" in msg and "Pressure" in msg and "x7" in msg
    # a short row is a row whose last cells are blank: missing, not an error
    short = tmp_path / "short.csv"
    short.write_text("time (s),Pressure (bar),Rate (l/min)\n0,1,2\n1,2\n2,3,4\n")
    r = read_log(short)
    assert np.isnan(r.rate[1]) and r.pressure[1] == pytest.approx(2e5)
    assert {c.name: c.n_missing for c in r.columns}["Rate"] == 1
    msg = _err(tmp_path, "long.csv", "time (s),Pressure (bar),Rate (l/min)\n0,1,2\n1,2,3,4\n2,3,4\n")
    assert "long.csv:3" in msg and "values" in msg
    cu = ("Time\tTreating Pressure\tFlow Rate\nmm:dd:yyyy:hh:mm:ss\tbars\tl/min\n____\t___\t___\n"
          "12:10:2023:14:42:58\t3\t0\n12:10:2023:14:42:59\t3\t0\t7\n")
    msg = _err(tmp_path, "cu_bad.txt", cu)
    assert "cu_bad.txt:5" in msg and "values" in msg
    cu2 = cu.replace("\t3\t0\t7\n", "\t3\tabc\n")
    msg = _err(tmp_path, "cu_bad2.txt", cu2)
    assert "cu_bad2.txt:5" in msg and "Flow Rate" in msg and "abc" in msg


def test_error_time_backwards(tmp_path):
    msg = _err(tmp_path, "back.csv", "time (s),Pressure (bar)\n0,1\n5,2\n3,3\n")
    assert "back.csv:4" in msg and "backwards" in msg
    msg = _err(tmp_path, "dup.csv", "time (s),Pressure (bar)\n0,1\n5,2\n5,3\n")
    assert "dup.csv:4" in msg
    ok = tmp_path / "dup_ok.csv"
    ok.write_text("time (s),Pressure (bar)\n0,1\n5,2\n5,2\n")
    assert read_log(ok).n == 2                         # an exact duplicate row is dropped
    cu = ("Time\tTreating Pressure\nmm:dd:yyyy:hh:mm:ss\tbars\n____\t___\n"
          "12:10:2023:14:42:58\t3\n12:10:2023:14:42:57\t3\n")
    msg = _err(tmp_path, "cu_back.txt", cu)
    assert "cu_back.txt:5" in msg and "backwards" in msg


def test_error_truncated_gauge_file(tmp_path):
    text = ("Well:\tX\tGauge:\t1\nTest:\tT\tPosition: gauge depth 910 m MD\n\nNo Points: 3\n"
            "Time\t\t\tDelta Time\tPressure\tTemperature\n\t\t\tHours\t\tpsi absolute\t°C\n"
            "12-12-2023 01:20:12\t0.0\t  61.9\t 13.6\n12-12-2023 01:20:15\t0.00083333\t  62.0\t 13.6\n")
    msg = _err(tmp_path, "gauge.TXT", text.encode("latin-1"))
    assert "gauge.TXT:8" in msg and "No Points" in msg
    ok = tmp_path / "gauge_ok.TXT"
    ok.write_bytes(text.replace("No Points: 3", "No Points: 2").encode("latin-1"))
    r = read_log(ok)                                        # latin-1 "°C" understood
    assert r.temperature[0] == pytest.approx(286.75) and r.reference.depth_m == 910.0


def test_error_unknown_column_in_options(tmp_path):
    msg = _err(tmp_path, "opt.csv", "time (s),Pressure (bar)\n0,1\n", units={"Nope": "bar"})
    assert "opt.csv" in msg and "Nope" in msg
