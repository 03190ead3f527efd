"""End-to-end jobs: simulated log -> reader -> picks -> stress -> report, and the CLI on them."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from xlotkit import InputError
from xlotkit.cli import main
from xlotkit.interpret.io import read_log
from xlotkit.logfile import write_log
from xlotkit.interpret.estimate import StressInputs
from xlotkit.pipeline import interpret_record, new_output_dir
from xlotkit.sim.lumped import simulate_lumped, standard_lumped_scene

FIELD = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "field" / "AMS-01"


@pytest.fixture(scope="module")
def lumped_log(tmp_path_factory):
    """The standard two-cycle lumped XLOT with 0.05 bar gauge noise, as a CSV field log."""
    res = simulate_lumped(standard_lumped_scene(noise=5e3, resolution=1e3, seed=3))
    path = tmp_path_factory.mktemp("log") / "xlot.csv"
    write_log(res.record, path)
    return path, res.truth


def test_simulated_log_through_the_field_path_recovers_sigma_h(lumped_log):
    path, truth = lumped_log
    interp = interpret_record(read_log(path))
    s = interp.stress
    assert s.available
    # The flowback of cycle 1 goes through closure, so sigma_h must come from the system
    # stiffness pick; issue 3 asks for 2 % on flowback picks.
    assert s.source_cycle == 1
    assert abs(s.sigma_h - truth["sigma_h"]) / truth["sigma_h"] < 0.02
    assert s.sigma_h_low <= s.sigma_h <= s.sigma_h_high
    # Defaults used for missing inputs are declared, never silent.
    assert any("pore pressure" in a for a in s.assumptions)


def test_stress_inputs_reject_impossible_values():
    with pytest.raises(InputError, match="mu"):
        StressInputs(mu=-0.1)
    with pytest.raises(InputError, match="target_tvd"):
        StressInputs(target_tvd=float("nan"))


def test_surface_record_without_depth_gives_no_stress_but_says_why(lumped_log):
    path, _ = lumped_log
    rec = read_log(path)
    surf = rec.replace(pressure=rec.channels["surface_pressure"],
                       reference=rec.reference.__class__("surface", None, False))
    interp = interpret_record(surf)
    if interp.picks.test_cycles and any(c.fcp.found for c in interp.picks.test_cycles):
        assert not interp.stress.available and "--tvd" in interp.stress.message


def test_new_output_dir_never_reuses_a_folder_with_results(tmp_path):
    a = new_output_dir(tmp_path / "out")
    (a / "picks.json").write_text("{}")
    b = new_output_dir(tmp_path / "out")
    assert a != b and b.name == "out-2" and (a / "picks.json").read_text() == "{}"


def test_cli_pick_json_schema_and_report_folder(lumped_log, tmp_path):
    path, truth = lumped_log
    out = tmp_path / "rep"
    r = CliRunner().invoke(main, ["pick", str(path), "--json", "--out", str(out)])
    assert r.exit_code == 0, r.output
    obj = json.loads(r.stdout)
    c1 = obj["cycles"][0]
    for key in ("index", "kind", "reference", "fbp_bar", "reopening_bar", "fpp_bar", "isip_bar",
                "fcp_bar", "fcp_low_bar", "fcp_high_bar", "methods"):
        assert key in c1
    assert c1["methods"]["flowback_sqrt_p"]["fcp_bar"] == pytest.approx(
        truth["sigma_h"] / 1e5, rel=0.02)
    assert obj["stress"]["sigma_h_bar"] == pytest.approx(truth["sigma_h"] / 1e5, rel=0.02)
    assert (out / "picks.json").is_file() and (out / "overview.png").is_file()
    # One multi-page PDF report: overview, every diagnostic plot, the table and the stress
    # page (a PDF with one page object per figure).
    pdf = (out / "report.pdf").read_bytes()
    assert pdf[:5] == b"%PDF-"
    n_png = len(list(out.glob("*.png"))) - 1          # record.png is not in the report
    assert pdf.count(b"/Type /Page\n") + pdf.count(b"/Type /Page ") >= n_png + 2
    assert c1["fcp_level"] == 0.9 and obj["diagnostics"] is not None
    # A second run must not touch the first report.
    before = (out / "picks.csv").read_bytes()
    r2 = CliRunner().invoke(main, ["pick", str(path), "--out", str(out), "--method", "sqrt_t"])
    assert r2.exit_code == 0, r2.output
    assert (out / "picks.csv").read_bytes() == before
    assert (tmp_path / "rep-2" / "picks.csv").is_file()


def test_cli_pick_bad_window_is_one_line_error(lumped_log):
    path, _ = lumped_log
    r = CliRunner().invoke(main, ["pick", str(path), "--window", "ISIP=abc"])
    assert r.exit_code == 2
    assert "--window" in r.output and "Traceback" not in r.output


@pytest.mark.skipif(not FIELD.is_dir(), reason="shared AMS-01 field data not present")
def test_cli_pick_runs_on_field_pair_without_hand_settings():
    files = sorted(str(p) for p in FIELD.glob("XLOT 2*"))
    r = CliRunner().invoke(main, ["pick", *files, "--json"])
    assert r.exit_code == 0, r.output
    obj = json.loads(r.stdout)
    xlots = [c for c in obj["cycles"] if c["kind"] == "xlot"]
    assert len(xlots) >= 3
    # Closure on the downhole gauge (absolute) must lie between the hydrostatic level and the
    # breakdown peak of the cycle -- a physical bracket, not a tuned number.
    found = [c for c in xlots if c["fcp_bar"] is not None]
    assert found
    for c in found:
        assert 96.0 < c["fcp_bar"] < 215.0


def test_lumped_demo_runs_end_to_end(tmp_path):
    r = CliRunner().invoke(main, ["demo", "--model", "lumped", "--out", str(tmp_path / "demo")])
    assert r.exit_code == 0, r.output
    d = tmp_path / "demo"
    summary = json.loads((d / "summary.json").read_text())
    assert summary["model"] == "lumped" and summary["fcp_reference"] == "sigma_h"
    err = summary["fcp_error_percent"]["cycle 1"]["flowback_sqrt_p"]
    assert err is not None and abs(err) < 2.0
    assert (d / "report.md").is_file() and (d / "interpretation" / "overview.png").is_file()
    assert "lumped model" in (d / "report.md").read_text()
    assert np.isfinite(summary["stress"]["sigma_h_bar"])


def _short_2d_scene():
    """The demo's 2D path on a small intact section (4 m, 1e-21 m^2, T0 50 MPa): the
    well's storage only, pumped 30 s, shut in, flowed back; seconds instead of a minute."""
    from xlotkit.sim.scene import scene_from_dict

    return scene_from_dict({
        "title": "short 2D demo", "model": "mdem",
        "geometry": {"domain_size": "4 m"},
        "mesh": {"growth": 1.4, "wall_element_size": "0.06 m"},
        "rock": {"tensile_strength": "50 MPa", "cohesion": "100 MPa",
                 "permeability": 1e-21},
        "fluid": {"density": "1.2 sg"},
        "numerics": {"dt_max": "1 s", "dp_max": "1 MPa"},
        "schedule": {"phase": [
            {"kind": "shut_in", "duration": "20 s"},
            {"kind": "pump", "rate": "500 l/min", "duration": "30 s"},
            {"kind": "shut_in", "duration": "10 s"},
            {"kind": "flowback", "initial_rate": "300 l/min", "pressure_below": "24.5 MPa"},
        ]},
    })


def test_2d_demo_path_simulates_reads_picks_and_reports(tmp_path):
    from xlotkit.pipeline import run_demo

    res = run_demo(tmp_path / "demo", model="2d", scene=_short_2d_scene(), seed=1)
    summary = json.loads(res.paths["summary_json"].read_text())
    assert summary["model"] == "2d"
    # the log the picks read is the one the 2D simulation wrote
    assert res.log_path == res.out_dir / "simulation" / "synthetic_log.csv"
    assert (res.out_dir / "simulation" / "timeseries.h5").is_file()
    # 2 %: issue 6's criterion; pumps meter surface volume, so the slope is Q rho0 /
    # (rho C_total), about 1 % below Q / C_total (tests/sim/test_engine2d.py)
    assert abs(summary["pressurisation"]["error_percent"]) < 2.0
    text = res.paths["report"].read_text()
    assert "2D MDEM model" in text and "Pressurisation" in text
    # no crack, so nothing realised: closure picks would be checked against the input
    assert summary["fcp_reference"] == "sigma_h"
    with pytest.raises(InputError, match="model"):
        run_demo(tmp_path / "x", model="3d")


@pytest.mark.slow
def test_standard_2d_demo_recovers_the_realised_sigma_h(tmp_path):
    """`xlotkit demo` (the standard 2D scene, on the free path: every failed cluster its
    own crack plane, no strip, no preset plane): the XLOT signature and the closure picks.
    Measured: 40 s wall on the shared 2-core machine with the engine of issue 20 (396-741 s
    before it; docs/coupling.md, "The free path")."""
    r = CliRunner().invoke(main, ["demo", "--out", str(tmp_path / "demo")])
    assert r.exit_code == 0, r.output
    d = tmp_path / "demo"
    summary = json.loads((d / "summary.json").read_text())
    assert summary["model"] == "2d" and summary["fcp_reference"] == "sigma_h_realised"
    truth = summary["truth_bar"]
    # the realised sigma_h is the in-situ normal stress over the crack: the far field plus
    # the hole's Kirsch concentration near the wall (measured 300.30 bar)
    assert truth["sigma_h"] < truth["sigma_h_realised"] < truth["sigma_h"] * 1.01
    # issue 6: pressurisation slope within 2 % of Q / C_total (measured -1.2 %)
    assert abs(summary["pressurisation"]["error_percent"]) < 2.0
    # issue 17: on the free path the flowback (system stiffness) FCP within 1 % of the
    # realised sigma_h in both cycles (measured with the engine of issue 20: -1.006 % /
    # -0.939 % and -1.271 % / -1.204 %; cycle 1's sqrt(p)-t misses the 1 % limit, as it
    # did on main before issue 20's engine change)
    for cyc in ("cycle 1", "cycle 2"):
        for m in ("flowback_sqrt_p", "flowback_p_v"):
            err = summary["fcp_error_percent"][cyc][m]
            assert err is not None and abs(err) < 1.0, (cyc, m, err)
    st = summary["stress"]
    assert abs(st["sigma_h_bar"] - truth["sigma_h_realised"]) < 0.01 * truth["sigma_h_realised"]
    # the XLOT signature in cycle 1: the crack starts (the model's first failure, measured
    # 331.78 bar, Hubbert-Willis 330) and grows stably to the breakdown at the peak of the
    # record (measured 338.81 bar; the model's FBP 334.60 bar), above the shut-in pressure,
    # which stays above closure
    picks = json.loads((d / "interpretation" / "picks.json").read_text())
    c1 = picks["cycles"][0]
    log = read_log(d / "simulation" / "synthetic_log.csv")
    in_c1 = (log.t >= c1["t_start_s"]) & (log.t <= c1["t_end_s"])
    # (the pick is on the smoothed record: measured 0.51 bar below the raw maximum)
    assert c1["fbp_bar"] == pytest.approx(float(log.pressure[in_c1].max()) / 1e5, abs=1.5)
    assert c1["fbp_bar"] > truth["fbp"] and c1["lop_bar"] < truth["fbp"] + 2.0
    assert c1["fbp_bar"] > c1["isip_bar"] > truth["sigma_h_realised"]


def test_a_redirected_demo_names_its_folder_when_it_starts(tmp_path):
    out = tmp_path / "demo"
    out.mkdir()
    (out / "earlier.txt").write_text("kept")
    seen = []
    from xlotkit.pipeline import run_demo

    res = run_demo(out, model="lumped", started=seen.append)
    assert seen == [res.out_dir] and res.out_dir != out and (out / "earlier.txt").exists()
    r = CliRunner().invoke(main, ["demo", "--model", "lumped", "--out", str(out)])
    assert r.exit_code == 0, r.output
    text = r.output + (r.stderr if hasattr(r, "stderr") and r.stderr_bytes is not None else "")
    assert f"{out} holds earlier results; the demo writes to {out}-" in text
