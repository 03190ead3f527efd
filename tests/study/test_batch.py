"""Batch interpretation (xlotkit.study.batch, `xlotkit pick --batch`): grouping of surface
and downhole logs by their clocks, the AMS-01 archive, failures as rows, resuming."""

from __future__ import annotations

import shutil
from datetime import datetime, timedelta
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from xlotkit.cli import main
from xlotkit.errors import InputError
from xlotkit.study.batch import BatchSpec, LogInfo, expand_inputs, group_logs, run_batch
from xlotkit.study.executors import InProcess
from xlotkit.study.table import same_table

FIELD = Path(__file__).resolve().parents[3] / "shared" / "data" / "field" / "AMS-01"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
T0 = datetime(2023, 12, 10, 8, 0, 0)


def info(path, kind, start_h, hours, error=""):
    s = T0 + timedelta(hours=start_h)
    return LogInfo(path, "x", kind, s, s + timedelta(hours=hours), error)


def test_surface_and_downhole_logs_pair_by_their_clocks():
    logs = [
        info("a/s1.txt", "surface", 0, 3),
        info("a/d1.txt", "downhole", -10, 30),       # holds s1's span
        info("a/s2.txt", "surface", 50, 3),
        info("a/d2.txt", "downhole", 53.5, 5),       # 0.5 h after s2 ends: a clock offset
        info("a/d3.txt", "downhole", 100, 2),        # no surface log near it
        info("b/s3.txt", "surface", 0, 3),           # overlaps d1, but in another folder
        info("a/bad.txt", None, 0, 0, error="cannot read"),
    ]
    groups = [g.files for g in group_logs(logs)]
    assert groups == [("a/bad.txt",), ("a/s1.txt", "a/d1.txt"), ("a/s2.txt", "a/d2.txt"),
                      ("a/d3.txt",), ("b/s3.txt",)]
    # a gap longer than the largest clock offset is not the same test
    assert [g.files for g in group_logs(logs[2:4], max_offset_s=0.4 * 3600)] == [
        ("a/d2.txt",), ("a/s2.txt",)]
    # of two candidates the longer overlap wins; each log is in one pair at most
    two = [info("a/s.txt", "surface", 0, 4), info("a/d_short.txt", "downhole", 3, 2),
           info("a/d_long.txt", "downhole", -1, 6)]
    # (groups in the order of their first file by name)
    assert [g.files for g in group_logs(two)] == [("a/s.txt", "a/d_long.txt"),
                                                 ("a/d_short.txt",)]


def test_inputs_expand_to_files(tmp_path):
    (tmp_path / "x").mkdir()
    for n in ("a.txt", "b.csv", ".hidden"):
        (tmp_path / "x" / n).write_text("1")
    (tmp_path / "x" / "sub").mkdir()
    (tmp_path / "x" / "sub" / "c.txt").write_text("1")
    folder = expand_inputs([str(tmp_path / "x")])
    assert [p.name for p in folder] == ["a.txt", "b.csv"]
    deep = expand_inputs([str(tmp_path / "x" / "**" / "*.txt"), str(tmp_path / "x" / "a.txt")])
    assert [p.name for p in deep] == ["a.txt", "c.txt"]
    with pytest.raises(InputError) as e:
        expand_inputs([str(tmp_path / "nothing*")])
    assert e.value.key == "--batch"


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    """The AMS-01 records and one file that is no log."""
    if not FIELD.is_dir():
        pytest.skip("the AMS-01 field records are not beside the repository")
    d = tmp_path_factory.mktemp("archive")
    for f in FIELD.glob("*Data*"):
        shutil.copy(f, d / f.name)
    (d / "notes.txt").write_text("not a log\n")
    return d


@pytest.fixture(scope="module")
def field_batch(archive, tmp_path_factory):
    out = tmp_path_factory.mktemp("batch") / "b"
    return out, run_batch(BatchSpec((str(archive),)), out, executor=InProcess())


def test_the_archive_gives_one_row_per_test_cycle(archive, field_batch):
    from xlotkit.interpret.io import read_logs
    from xlotkit.pipeline import interpret_record

    out, res = field_batch
    t = res.table
    groups = t.drop_duplicates("log")
    assert len(groups) == 3 and list(groups["index"]) == [0, 1, 2]
    bad = groups[groups["status"] == "failed"]
    assert list(bad["files"]) == [str(archive / "notes.txt")]
    assert bad["message"].iloc[0].startswith("read: ")
    for test in ("XLOT 1", "XLOT 2"):
        pair = sorted(archive.glob(f"{test}*"))
        rows = t[t["files"].str.contains(test, regex=False)]
        # the pair was merged: both files in one group, the downhole gauge as reference
        assert rows["files"].iloc[0].count(" + ") == 1
        assert rows["reference"].iloc[0].startswith("downhole gauge")
        # the same picks as the interpretation of the pair on its own
        direct = interpret_record(read_logs(pair))
        cycles = direct.picks.test_cycles
        assert list(rows["cycle"]) == [c.index for c in cycles]
        for (_, r), c in zip(rows.iterrows(), cycles):
            if c.fcp.found:
                assert r["fcp_bar"] == pytest.approx(c.fcp.value / 1e5, rel=1e-12)
            else:
                assert pd.isna(r["fcp_bar"])
            assert r["fcp_quality"] == c.fcp.quality
            isip = c.get("ISIP")
            if isip.found:
                assert r["ISIP_bar"] == pytest.approx(isip.value / 1e5, rel=1e-12)
            else:
                assert pd.isna(r["ISIP_bar"]) and r["ISIP_quality"] == "none"
        assert rows["sigma_h_bar"].iloc[0] == pytest.approx(direct.stress.sigma_h / 1e5)
        folder = out / "logs" / rows["log"].iloc[0]
        assert (folder / "picks.csv").is_file() and (folder / "group.log").is_file()
    assert not list((out / "logs").glob(".*.partial"))
    assert same_table(pd.read_parquet(out / "results.parquet"), t, ignore=())[0]


def test_a_rerun_interprets_nothing_again(archive, field_batch):
    out, res = field_batch
    again = run_batch(BatchSpec((str(archive),)), out, executor=InProcess())
    assert set(again.skipped) == set(res.table["log"]) and not again.computed
    assert same_table(res.table, again.table, ignore=())[0]


@pytest.fixture(scope="module")
def synthetic_log(tmp_path_factory):
    """The lumped standard scene's synthetic log (two test cycles)."""
    from xlotkit.sim.run import simulate
    from xlotkit.sim.scene import load_scene

    d = tmp_path_factory.mktemp("sim")
    return simulate(load_scene(EXAMPLES / "scene_standard.toml"), d / "sim").paths["log"]


def test_other_reader_flags_read_the_logs_again(synthetic_log, tmp_path):
    from xlotkit.interpret.io import read_options

    out = tmp_path / "b"
    first = run_batch(BatchSpec((str(synthetic_log),)), out, executor=InProcess())
    # the same files with a unit the user now states are another batch: never taken for
    # the finished one (results read the old way kept), nor written over it
    spec = BatchSpec((str(synthetic_log),),
                     read_options=read_options(units={"pressure": "bar"}))
    with pytest.raises(InputError) as e:
        run_batch(spec, out, executor=InProcess())
    assert e.value.key == "--out" and "another study" in str(e.value)
    again = run_batch(spec, tmp_path / "c", executor=InProcess())
    assert again.computed and not again.skipped
    assert set(again.computed).isdisjoint(first.computed)


def test_the_batch_on_a_dask_cluster_gives_the_in_process_table(synthetic_log, tmp_path):
    from distributed import Client, LocalCluster

    from xlotkit.study.executors import DaskCluster

    ref = run_batch(BatchSpec((str(synthetic_log),)), tmp_path / "ref", executor=InProcess())
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        dask = run_batch(BatchSpec((str(synthetic_log),)), tmp_path / "dask",
                         executor=DaskCluster(client=client))
    assert dask.executor.startswith("the Dask cluster")
    assert len(ref.table) == 2
    same, why = same_table(ref.table, dask.table)
    assert same, why


def test_a_half_written_log_folder_is_done_again(tmp_path):
    """A log folder stopped while being written stays `.ID.partial` and is redone."""
    from xlotkit.sim.run import simulate
    from xlotkit.sim.scene import load_scene

    sim = simulate(load_scene(EXAMPLES / "scene_standard.toml"), tmp_path / "sim")
    log = sim.paths["log"]
    out = tmp_path / "b"

    def stop(frac, msg):
        if "finished earlier" in msg:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_batch(BatchSpec((str(log),)), out, executor=InProcess(), progress=stop)
    (gid,) = __import__("json").loads((out / "study.json").read_text())["cases"]
    partial = out / "logs" / f".{gid}.partial"
    partial.mkdir()
    (partial / "picks.csv").write_text("half")
    res = run_batch(BatchSpec((str(log),)), out, executor=InProcess())
    assert res.computed == (gid,) and not partial.exists()
    assert (out / "logs" / gid / "picks.csv").read_text() != "half"
    # the synthetic log's two test cycles: the first closes on its flowback, the second in
    # its shut-in (the scene's schedule), both near the scene's sigma_h of 300 bar within
    # the library's tolerances (3 % flowback, 5 % shut-in)
    t = res.table
    assert list(t["cycle_kind"]) == ["xlot", "xlot"]
    assert t["fcp_flowback_sqrt_p_bar"][0] == pytest.approx(300, rel=0.03)
    assert t["fcp_bar"][1] == pytest.approx(300, rel=0.05)


def test_cli_batch_on_a_pool(tmp_path):
    from xlotkit.sim.run import simulate
    from xlotkit.sim.scene import load_scene

    sim = simulate(load_scene(EXAMPLES / "scene_standard.toml"), tmp_path / "sim")
    (tmp_path / "logs").mkdir()
    shutil.copy(sim.paths["log"], tmp_path / "logs" / "a.csv")
    (tmp_path / "logs" / "b.csv").write_text("time,pressure\nx,y\n")
    r = CliRunner()
    args = ["pick", "--batch", str(tmp_path / "logs" / "*.csv"), "--out",
            str(tmp_path / "out"), "--workers", "2"]
    res = r.invoke(main, args)
    assert res.exit_code == 0, res.output
    assert "2 log groups (0 finished earlier, 2 run now on a local pool of 2 processes)" \
        in res.output
    assert "rows: 2 ok, 1 failed" in res.output
    t = pd.read_csv(tmp_path / "out" / "results.csv")
    assert list(t["status"]) == ["ok", "ok", "failed"]
    # the batch options are refused where they would be ignored
    for extra, key in ((["--json"], "--json"), ([], "--out")):
        a = ["pick", "--batch", str(tmp_path / "logs" / "a.csv"), *extra]
        if key != "--out":
            a += ["--out", str(tmp_path / "o2")]
        res = r.invoke(main, a)
        assert res.exit_code == 2 and "error:" in res.output
    res = r.invoke(main, ["pick", str(tmp_path / "logs" / "a.csv"), "--workers", "2"])
    assert res.exit_code == 2 and "--workers" in res.output and "--batch" in res.output
