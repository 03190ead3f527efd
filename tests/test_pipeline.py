"""End-to-end jobs: simulated log -> reader -> picks -> stress -> report, and the CLI on them."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from xlotkit import InputError
from xlotkit.cli import main
from xlotkit.interpret.io import read_log, write_log
from xlotkit.pipeline import StressInputs, interpret_record, new_output_dir
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


def test_demo_runs_end_to_end(tmp_path):
    r = CliRunner().invoke(main, ["demo", "--out", str(tmp_path / "demo")])
    assert r.exit_code == 0, r.output
    d = tmp_path / "demo"
    summary = json.loads((d / "summary.json").read_text())
    err = summary["fcp_error_percent"]["cycle 1"]["flowback_sqrt_p"]
    assert err is not None and abs(err) < 2.0
    assert (d / "report.md").is_file() and (d / "interpretation" / "overview.png").is_file()
    assert np.isfinite(summary["stress"]["sigma_h_bar"])
