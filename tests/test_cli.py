"""The ``xlotkit inspect`` command (click's CliRunner, no subprocess)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from xlotkit.cli import main

DATA = Path("/work/shared/data/field/AMS-01")
if not DATA.is_dir():
    DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "field" / "AMS-01"
CU2 = DATA / "XLOT 2 - Vlieland Claystone_Cementing Unit_Data.TXT"
DH2 = DATA / "XLOT 2 - Vlieland Claystone_Downhole Gauge_Data.TXT"

field = pytest.mark.skipif(not CU2.exists(), reason="AMS-01 field data not available")

# a small cementing-unit log in the AMS-01 layout: idle, a pump-in to ~120 bar with breakdown
# and propagation, shut-in, bleed
_HEAD = ("Time\tTreating Pressure\tFlow Rate\tDensity\tVolume\n"
         "mm:dd:yyyy:hh:mm:ss\tbars\tl/min\tsgu\tm3\n"
         "____\t______\t______\t______\t______\n")


def _small_log(path: Path) -> Path:
    import datetime as dt

    rows = []
    t0 = dt.datetime(2024, 3, 1, 10, 0, 0)
    vol = 0.0
    p = 0.0
    for i in range(1500):
        q = 100.0 if 200 <= i < 500 else 0.0
        if 200 <= i < 500:
            k = i - 200
            p = min(1.5 * k, 120.0) if k < 80 else 100.0 + 20.0 * 0.9 ** (k - 80)
        elif 500 <= i < 1100:
            p = 90.0 - 0.01 * (i - 500)
        elif 1100 <= i < 1110:
            p = max(p - 9.0, 0.0)
        elif i >= 1110:
            p = 0.0
        vol += q / 60000.0
        ts = (t0 + dt.timedelta(seconds=i)).strftime("%m:%d:%Y:%H:%M:%S")
        rows.append(f"{ts}\t{p:.0f}\t{q:.0f}\t1.05\t{vol:.3f}\n")
        if i == 190:
            rows.append(f"{ts}\tstart test 1\n")
    path.write_text(_HEAD + "".join(rows))
    return path


@pytest.fixture()
def runner():
    return CliRunner()


def test_inspect_table(runner, tmp_path):
    log = _small_log(tmp_path / "small.txt")
    res = runner.invoke(main, ["inspect", str(log)])
    assert res.exit_code == 0, res.output
    out = res.output
    assert "pressure reference: surface (gauge)" in out
    assert "peak bar" in out and "pumped m3" in out
    assert " 1 xlot" in out
    assert "10:03:20" in out  # cycle start, clock time
    assert "- pump" in out and "- shut_in" in out and "- bleed" in out


def test_inspect_json_schema(runner, tmp_path):
    log = _small_log(tmp_path / "small.txt")
    res = runner.invoke(main, ["inspect", str(log), "--json"])
    assert res.exit_code == 0, res.output
    obj = json.loads(res.output)
    assert obj["files"] == [str(log)]
    assert obj["reference"].startswith("surface")
    (c,) = obj["cycles"]
    for key in ("index", "kind", "start_s", "end_s", "peak_pressure_bar", "pumped_m3",
                "returned_m3", "reason", "phases"):
        assert key in c
    assert c["kind"] == "xlot" and c["index"] == 1
    assert c["pumped_m3"] == pytest.approx(0.5, abs=0.01)
    assert c["peak_pressure_bar"] == pytest.approx(120, abs=1)
    for ph in c["phases"]:
        assert set(ph) == {"kind", "start_s", "end_s", "duration_s", "pumped_m3",
                           "returned_m3", "peak_pressure_bar", "evidence"}
    assert [ph["kind"] for ph in c["phases"]] == ["pump", "shut_in", "bleed"]


def test_inspect_reports_what_the_reader_dropped(runner):
    # a single impossible cell is dropped and the user is told which line, in the table and
    # in the JSON (the fixture's line 9 holds 1e12 bar)
    log = Path(__file__).resolve().parent / "data" / "logs" / "impossible_cell.csv"
    res = runner.invoke(main, ["inspect", str(log), "--json"])
    assert res.exit_code == 0, res.output
    notes = json.loads(res.output)["reading_notes"]
    assert any(n.startswith("line 9:") and "dropped" in n for n in notes), notes
    res = runner.invoke(main, ["inspect", str(log)])
    assert res.exit_code == 0, res.output
    assert "read: line 9:" in res.output


def test_inspect_several_independent_logs_json(runner, tmp_path):
    a = _small_log(tmp_path / "a.txt")
    b = _small_log(tmp_path / "b.txt")
    res = runner.invoke(main, ["inspect", str(a), str(b), "--json"])
    assert res.exit_code == 0, res.output
    obj = json.loads(res.output)
    assert [len(o["cycles"]) for o in obj["logs"]] == [1, 1]


def test_inspect_plot_writes_png_never_overwrites_refuses_unknown_suffix(runner, tmp_path):
    import os
    import stat

    log = _small_log(tmp_path / "small.txt")
    png = tmp_path / "overview.png"
    res = runner.invoke(main, ["inspect", str(log), "--plot", str(png)])
    assert res.exit_code == 0, res.output
    first = png.read_bytes()
    assert first[:8] == b"\x89PNG\r\n\x1a\n"
    # the user's umask, not the temporary file's private 0600
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(png.stat().st_mode) == 0o666 & ~mask
    res = runner.invoke(main, ["inspect", str(log), "--plot", str(png)])
    assert res.exit_code == 2 and "exists" in res.output and str(png) in res.output
    assert png.read_bytes() == first
    res = runner.invoke(main, ["inspect", str(log), "--plot", str(tmp_path / "o.txt")])
    lines = res.output.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1 and "'.txt'" in lines[0]
    assert "Traceback" not in res.output and not (tmp_path / "o.txt").exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_inspect_missing_file_is_one_line(runner, tmp_path):
    res = runner.invoke(main, ["inspect", str(tmp_path / "nope.txt")])
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "nope.txt" in lines[0]
    assert "Traceback" not in res.output


@pytest.mark.parametrize("content", [
    "this is not a log\nat all\n",
    _HEAD + "03:01:2024:10:00:00\tabc\tdef\t1\t2\n03:01:2024:10:00:01\t1\n",
    "",
    "\x00\x01\x02binary",
])
def test_inspect_malformed_file_is_one_line(runner, tmp_path, content):
    bad = tmp_path / "bad.txt"
    bad.write_text(content)
    res = runner.invoke(main, ["inspect", str(bad)])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), res.output
    assert "Traceback" not in res.output


@field
def test_inspect_merged_pair(runner):
    res = runner.invoke(main, ["inspect", str(CU2), str(DH2), "--json"])
    assert res.exit_code == 0, res.output
    obj = json.loads(res.output)
    assert "cycles" in obj and obj["reference"].startswith("downhole gauge at 910 m")
    assert abs(obj["clock_offset_s"]) > 0
    assert [c["kind"] for c in obj["cycles"]] == ["xlot"] * 5


# ====================================================================== simulate
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_simulate_happy_path_and_fresh_folder(runner, tmp_path):
    out = tmp_path / "sim"
    res = runner.invoke(main, ["simulate", str(EXAMPLES / "scene_standard.toml"),
                               "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "lumped model: ok" in res.output and f"results in {out}" in res.output
    assert "sigma_h 300.0 bar" in res.output
    for name in ("timeseries.h5", "synthetic_log.csv", "summary.json", "scene.toml"):
        assert (out / name).is_file(), name
    first = (out / "synthetic_log.csv").read_bytes()
    # the log goes straight into `pick`
    res_pick = runner.invoke(main, ["pick", str(out / "synthetic_log.csv"), "--json"])
    assert res_pick.exit_code == 0, res_pick.output
    sh = json.loads(res_pick.output[res_pick.output.index("{"):])
    assert sh["cycles"]
    # a second run with another seed never touches the first
    res2 = runner.invoke(main, ["simulate", str(EXAMPLES / "scene_standard.toml"),
                                "--out", str(out), "--seed", "5"])
    assert res2.exit_code == 0, res2.output
    assert f"results in {out}-2" in res2.output
    assert (out / "synthetic_log.csv").read_bytes() == first
    assert (tmp_path / "sim-2" / "synthetic_log.csv").read_bytes() != first
    # nothing left to resume in a finished run
    res3 = runner.invoke(main, ["simulate", str(EXAMPLES / "scene_standard.toml"),
                                "--out", str(out), "--resume"])
    assert res3.exit_code == 2 and "finished" in res3.output


@pytest.mark.slow
def test_simulate_the_standard_2d_scene(runner, tmp_path):
    """`xlotkit simulate examples/scene_2d_standard.toml` (the demo's scene; ~50 s)."""
    out = tmp_path / "sim2d"
    res = runner.invoke(main, ["simulate", str(EXAMPLES / "scene_2d_standard.toml"),
                               "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "mdem model: ok" in res.output
    summary = json.loads((out / "summary.json").read_text())
    # the realised sigma_h is reported beside the imposed one (measured 300.28 bar)
    assert summary["realised_bar"]["sigma_h"] != summary["imposed_bar"]["sigma_h"]
    assert summary["max_mass_balance_error"] <= 1e-8
    for name in ("timeseries.h5", "synthetic_log.csv", "scene.toml"):
        assert (out / name).is_file(), name


def test_simulate_lumped_format_scene(runner, tmp_path):
    res = runner.invoke(main, ["simulate", str(EXAMPLES / "lumped_standard.toml"),
                               "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output


def test_simulate_bad_scene_is_one_line_and_exit_2(runner, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[rock]\npermeability = "5000 darcy"\n[schedule]\n[[schedule.phase]]\n'
                   'kind = "pump"\nrate = "500 l/min"\nvolume = "1 m3"\n')
    res = runner.invoke(main, ["simulate", str(bad), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"error: {bad}: rock.permeability: value '5000 darcy'")
    assert "[0, 1e-09] m^2" in lines[0]
    assert not (tmp_path / "o").exists()
    res = runner.invoke(main, ["simulate", str(tmp_path / "missing.toml"), "--out",
                               str(tmp_path / "o")])
    assert res.exit_code == 2 and res.output.startswith("error: ")


def test_simulate_2d_scene_says_the_engine_is_missing(runner, tmp_path, monkeypatch):
    from xlotkit.sim import run as run_mod

    monkeypatch.delitem(run_mod.ENGINES, "mdem")
    res = runner.invoke(main, ["simulate", str(EXAMPLES / "scene_2d_heterogeneous.toml"),
                               "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert res.output.startswith("error: ") and "MDEM" in res.output
    assert len(res.output.strip().splitlines()) == 1
