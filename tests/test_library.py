"""The synthetic-library machinery (xlotkit.library, `xlotkit library`) on a one-scene
library of the lumped standard XLOT, built in a temporary folder."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from xlotkit.cli import main
from xlotkit.errors import InputError
from xlotkit.library import (
    build,
    compare,
    entries,
    evaluate,
    evaluation_markdown,
    scenes_markdown,
)

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    root = tmp_path_factory.mktemp("lib")
    (root / "std").mkdir()
    shutil.copy(EXAMPLES / "scene_standard.toml", root / "std" / "scene.toml")
    out = build(root)
    assert [o.action for o in out] == ["simulated"]
    return root


def test_build_stores_log_and_truth_with_the_command(lib):
    e = entries(lib)[0]
    assert e.log_file.is_file()
    truth = e.truth()
    assert truth["status"] == "ok" and truth["model"] == "lumped"
    assert truth["command"] == f"xlotkit simulate {e.scene_file.as_posix()} --out DIR"
    assert truth["realised_bar"]["sigma_h"] == pytest.approx(300.0)
    # no temporary build folders are left behind
    assert sorted(p.name for p in e.folder.iterdir()) == ["log.csv", "scene.toml",
                                                          "truth.json"]


def test_build_keeps_what_exists_unless_replace(lib):
    e = entries(lib)[0]
    before = e.log_file.stat().st_mtime_ns
    assert [o.action for o in build(lib)] == ["kept"]
    assert e.log_file.stat().st_mtime_ns == before


def test_regenerated_log_is_the_stored_one(lib):
    (c,) = compare(lib)
    # deterministic: the same scene and seed give the same samples to the log's resolution
    assert c.same and c.max_pressure_difference == 0.0, c.message


def test_picks_against_the_realised_stress(lib):
    ev = evaluate(entries(lib)[0])
    assert ev.passed, (ev.failures, [c.failures for c in ev.cycles])
    c1, c2 = ev.cycles
    # cycle 1 flows back through closure, cycle 2's shut-in ends 0.9 % below sigma_h
    # (inside the 1 % margin: not judged)
    assert c1.flowback_closure and c1.closure_in_shutin is False
    assert abs(c1.errors["flowback_sqrt_p"]) <= 0.03
    assert c2.closure_in_shutin is None
    table = evaluation_markdown([ev])
    assert "| std | lumped | 1 |" in table and "T0 = FBP − Pr" in table


def test_a_wrong_truth_is_caught(lib, tmp_path):
    """A stored sigma_h 5 % low makes the flowback picks miss: the check is not vacuous."""
    root = tmp_path / "lib"
    shutil.copytree(lib, root)
    tf = root / "std" / "truth.json"
    truth = json.loads(tf.read_text())
    truth["realised_bar"]["sigma_h"] *= 0.95
    tf.write_text(json.dumps(truth))
    ev = evaluate(entries(root)[0])
    assert not ev.passed
    assert any("flowback_sqrt_p" in f for c in ev.cycles for f in c.failures)
    r = CliRunner().invoke(main, ["library", "check", str(root)])
    assert r.exit_code == 1 and "MISS std" in r.output


def test_cli_check_and_bad_input(lib, tmp_path):
    r = CliRunner().invoke(main, ["library", "check", str(lib), "--markdown",
                                  str(tmp_path / "t.md")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "t.md").read_text().startswith("| scene |")
    # results are never written over
    r = CliRunner().invoke(main, ["library", "check", str(lib), "--markdown",
                                  str(tmp_path / "t.md")])
    assert r.exit_code == 2 and "exists already" in r.output
    r = CliRunner().invoke(main, ["library", "check", str(lib), "--only", "nope"])
    assert r.exit_code == 2 and "no scene 'nope'" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(main, ["library", "check", str(tmp_path / "missing")])
    assert r.exit_code == 2 and "no such library folder" in r.output
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no scenes"):
        entries(tmp_path / "empty")
    (tmp_path / "new" / "a").mkdir(parents=True)
    (tmp_path / "new" / "a" / "scene.toml").write_text("")
    with pytest.raises(InputError, match="not been simulated"):
        evaluate(entries(tmp_path / "new")[0])


def test_surface_gauge_picks_are_taken_to_depth(lib, tmp_path):
    """A cementing-unit (surface) log of the same test: the evaluation takes its picks to
    depth with the interpreter's own column (the offset it used for sigma_h) and judges
    closure there, so the flowback check passes as on the bottom-hole log."""
    root = tmp_path / "lib"
    (root / "surf").mkdir(parents=True)
    text = (EXAMPLES / "scene_standard.toml").read_text()
    (root / "surf" / "scene.toml").write_text(
        text.replace("[output]\n", '[output]\ngauge = "surface"\n', 1))
    build(root)
    ev = evaluate(entries(root)[0])
    ref = evaluate(entries(lib)[0])
    assert ev.passed, (ev.failures, [c.failures for c in ev.cycles])
    # the offset is the interpreter's static column: 1.2 sg over 2000 m TVD
    assert ev.depth_offset == pytest.approx(1200 * 9.80665 * 2000, rel=1e-6)
    assert ref.depth_offset == 0.0
    c1, r1 = ev.cycles[0], ref.cycles[0]
    assert c1.flowback_closure and r1.flowback_closure
    # closure picked on the two gauges agrees to 1 %: the lumped model's column is
    # compressible (heavier at depth than 1.2 sg) and the flowing column loses friction
    assert c1.errors["flowback_sqrt_p"] == pytest.approx(r1.errors["flowback_sqrt_p"], abs=0.01)
    # FBP and Pr are reported at depth
    assert ev.fbp == pytest.approx(ref.fbp, rel=0.01)


def test_scenes_table_and_cli_list(lib, tmp_path):
    table = scenes_markdown(entries(lib))
    truth = entries(lib)[0].truth()
    assert table.startswith("| scene | title | status |")
    row = table.splitlines()[2]
    assert row.startswith("| std | ") and "| ok |" in row
    assert f"{truth['realised_bar']['sigma_h']:.1f}" in row
    r = CliRunner().invoke(main, ["library", "list", str(lib), "--markdown",
                                  str(tmp_path / "s.md")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "s.md").read_text() == table
