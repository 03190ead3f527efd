"""The simulate driver: outputs, checkpoints and resume, determinism, engine registry."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from xlotkit import InputError
from xlotkit.interpret.io import read_log
from xlotkit.pipeline import interpret_record
from xlotkit.record import PressureReference, Record
from xlotkit.sim import run as run_mod
from xlotkit.sim.lumped import LumpedEngine, StepOutcome, simulate_lumped
from xlotkit.sim.output import SERIES_COLUMNS, Snapshot, read_timeseries
from xlotkit.sim.run import Engine, EngineNotAvailable, SimulationInterrupted, simulate
from xlotkit.sim.scene import Scene, load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[2]
STANDARD = ROOT / "examples" / "scene_standard.toml"


def _with(scene: Scene, section: str, **kw) -> Scene:
    return dataclasses.replace(scene, **{section: dataclasses.replace(
        getattr(scene, section), **kw)})


@pytest.fixture(scope="module")
def standard():
    return load_scene(STANDARD)


@pytest.fixture(scope="module")
def standard_run(standard, tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "std"
    return simulate(standard, out)


def test_outputs_exist_and_log_matches_the_lumped_model(standard, standard_run):
    r = standard_run
    assert r.status == "ok" and r.model == "lumped" and not r.resumed
    for k in ("scene", "scene_resolved", "timeseries", "log", "summary"):
        assert r.paths[k].is_file(), k
    assert not (r.paths["dir"] / "checkpoint.npz").exists()
    assert r.paths["scene"].read_text() == STANDARD.read_text()
    # the driver's noisy log is exactly what simulate_lumped makes of the same scene
    ref = simulate_lumped(standard.to_lumped()).record
    assert np.array_equal(r.record.t, ref.t)
    assert np.array_equal(r.record.pressure, ref.pressure)
    assert np.array_equal(r.record.channels["surface_pressure"],
                          ref.channels["surface_pressure"])
    assert np.array_equal(r.record.rate, ref.rate)
    summary = json.loads(r.paths["summary"].read_text())
    assert summary["status"] == "ok" and summary["steps"] == r.n_steps
    assert summary["max_mass_balance_error"] < 1e-8


def test_hdf5_content(standard, standard_run):
    out = read_timeseries(standard_run.paths["timeseries"])
    assert set(out.series) <= set(SERIES_COLUMNS)
    # the lumped model has no 2D segment and no clusters: absent, not zero
    assert "failed_clusters" not in out.series and "segment_pressure" not in out.series
    t = out.series["t"]
    assert np.all(np.diff(t) >= 0) and t[-1] == pytest.approx(standard_run.record.t[-1], abs=1)
    mb = out.series["mass_balance_error"]
    assert math.isnan(mb[0]) and np.nanmax(mb) < 1e-8
    assert out.series["pumped_volume"][-1] == pytest.approx(3.5, rel=1e-9)
    assert out.attrs["model"] == "lumped" and out.attrs["seed"] == 0
    assert out.attrs["scene"] == STANDARD.read_text()
    assert load_scene(STANDARD) == scene_from_dict(
        __import__("tomllib").loads(out.attrs["scene"]), file=str(STANDARD),
        text=out.attrs["scene"])
    assert out.imposed == {"sigma_h": 30e6, "sigma_H": 35e6, "tensile_strength": 3e6,
                           "pore_pressure": 20e6}
    assert out.realised == out.imposed
    assert out.truth["fbp"] == pytest.approx(standard_run.truth["fbp"])
    # the clean record in the file is the engine's record before gauge noise
    assert np.array_equal(out.record.pressure, standard_run.clean_record.pressure)
    assert not np.array_equal(out.record.pressure, standard_run.record.pressure)


def test_synthetic_log_is_read_and_picked_sigma_h_within_3_percent(standard_run):
    rec = read_log(standard_run.paths["log"])
    assert rec.reference.kind == "bottomhole" and rec.n == standard_run.record.n
    assert np.allclose(rec.pressure, standard_run.record.pressure, rtol=1e-11, atol=1e-3)
    s = interpret_record(rec).stress
    assert s.available
    assert abs(s.sigma_h - 30e6) / 30e6 < 0.03


def test_fresh_folder_never_overwrites(standard, standard_run, tmp_path):
    d = standard_run.paths["dir"]
    before = d.joinpath("timeseries.h5").read_bytes()
    r2 = simulate(standard, d)
    assert r2.paths["dir"] == d.with_name(d.name + "-2")
    assert d.joinpath("timeseries.h5").read_bytes() == before


def test_same_scene_and_seed_give_the_same_numbers(standard, standard_run, tmp_path):
    again = simulate(standard, tmp_path / "a")
    assert np.array_equal(again.record.pressure, standard_run.record.pressure)
    a = read_timeseries(again.paths["timeseries"]).series
    b = read_timeseries(standard_run.paths["timeseries"]).series
    assert all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
    other = simulate(standard.with_seed(1), tmp_path / "b")
    assert not np.array_equal(other.record.pressure, standard_run.record.pressure)
    assert np.array_equal(other.clean_record.pressure, standard_run.clean_record.pressure)


def test_resume_after_interruption_is_bit_identical(standard, standard_run, tmp_path):
    sc = _with(standard, "numerics", checkpoint_steps=300)
    out = tmp_path / "run"
    seen = {"n": 0}

    def stop_after_1000(frac: float, msg: str) -> None:
        seen["n"] += 1
        if seen["n"] == 1000:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt) as ei:
        simulate(sc, out, progress=stop_after_1000)
    assert isinstance(ei.value, SimulationInterrupted) and ei.value.out_dir == out
    assert ei.value.has_checkpoint
    assert (out / "checkpoint.npz").is_file() and not (out / "timeseries.h5").exists()
    fracs = []
    r = simulate(sc, out, resume=True, progress=lambda f, m: fracs.append(f))
    assert r.resumed and r.paths["dir"] == out
    assert len(fracs) < r.n_steps - 800          # it did not start over
    assert not (out / "checkpoint.npz").exists()
    for name in ("t", "pressure", "rate", "volume", "return_rate", "return_volume"):
        assert np.array_equal(getattr(r.record, name), getattr(standard_run.record, name))
    assert np.array_equal(r.clean_record.channels["fracture_length"],
                          standard_run.clean_record.channels["fracture_length"])
    a = read_timeseries(r.paths["timeseries"]).series
    b = read_timeseries(standard_run.paths["timeseries"]).series
    assert set(a) == set(b) and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
    assert r.truth["fbp"] == standard_run.truth["fbp"]
    assert r.truth["closure_times"] == standard_run.truth["closure_times"]


def test_resume_refuses_what_it_cannot_continue(standard, standard_run, tmp_path):
    with pytest.raises(InputError, match="finished"):
        simulate(standard, standard_run.paths["dir"], resume=True)
    with pytest.raises(InputError, match="no such"):
        simulate(standard, tmp_path / "nothing", resume=True)
    sc = _with(standard, "numerics", checkpoint_steps=50)
    out = tmp_path / "r"

    def stop(frac, msg):
        if frac > 0.2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulate(sc, out, progress=stop)
    with pytest.raises(InputError, match="differs"):
        simulate(sc.with_seed(3), out, resume=True)


def test_engine_state_restores_bit_identically(standard):
    ls = standard.to_lumped()
    ref = simulate_lumped(ls).record
    e = LumpedEngine(ls)
    e.start()
    outcomes = [e.step() for _ in range(777)]
    assert all(isinstance(o, StepOutcome) for o in outcomes)
    assert [o.t for o in outcomes if o.ok] == sorted(o.t for o in outcomes if o.ok)
    assert e.progress() > 0.0 and not e.is_done()
    state = {k: (np.asarray(v) if not isinstance(v, str) else v) for k, v in e.state().items()}
    e2 = LumpedEngine(ls)
    e2.restore(state)
    while not e2.is_done():
        e2.step()
    assert np.array_equal(e2.result().record.pressure, ref.pressure)
    assert isinstance(e2, Engine)


def test_mdem_needs_a_registered_engine(tmp_path, monkeypatch):
    sc = load_scene(ROOT / "examples" / "scene_2d_heterogeneous.toml")
    assert sc.resolved_model == "mdem"
    assert "mdem" in run_mod.ENGINES                 # the 2D engine is built in
    monkeypatch.delitem(run_mod.ENGINES, "mdem")
    with pytest.raises(EngineNotAvailable, match="mdem"):
        simulate(sc, tmp_path / "x")
    assert not (tmp_path / "x").exists()


class _StorageEngine:
    """Test engine: well storage on a small mesh, p = p0 + Q t / C, to exercise the driver's
    registry, snapshots and realised truth (the real 2D engine plugs in the same way)."""

    model = "mdem"

    def __init__(self, scene: Scene):
        from xlotkit.sim.mesh import rectangle_mesh

        self.mesh = rectangle_mesh(2.0, 2.0, 2, 2)
        self.dt, self.n_end, self.c, self.q = 1.0, 40, 1e-10, 1e-4

    def start(self):
        self.k = 0

    @property
    def time(self):
        return self.k * self.dt

    def step(self):
        self.k += 1
        return StepOutcome(True, self.time, "accepted")

    def is_done(self):
        return self.k >= self.n_end

    def progress(self):
        return self.k / self.n_end

    def state(self):
        return {"k": self.k}

    def restore(self, state):
        self.k = int(state["k"])

    def _p(self, t):
        return 1e6 + self.q * np.asarray(t) / self.c

    def rows(self):
        t = np.arange(self.k + 1) * self.dt
        return {"t": t, "well_pressure": self._p(t), "failed_clusters": np.zeros(t.size)}

    def snapshot(self):
        m = self.mesh
        return Snapshot(time=self.time, points=m.nodes, triangles=m.triangles,
                        cell_data={"pressure": np.full(len(m.triangles), self._p(self.time))})

    def result(self):
        t = np.arange(self.k + 1) * self.dt
        rec = Record(t=t, pressure=self._p(t), rate=np.full(t.size, self.q),
                     reference=PressureReference(kind="bottomhole", depth_m=2000.0),
                     channels={"surface_pressure": self._p(t) - 2e7})
        return type("R", (), {"status": "ok", "message": "storage only", "record": rec,
                              "truth": {"realised": {"tensile_strength": 2.5e6}}})()


def test_registered_engine_gets_snapshots_and_realised_truth(tmp_path, monkeypatch):
    monkeypatch.setitem(run_mod.ENGINES, "mdem", _StorageEngine)
    sc = load_scene(ROOT / "examples" / "scene_2d_heterogeneous.toml")
    sc = _with(sc, "output", snapshot_interval=10.0, log_interval=2.0)
    r = simulate(sc, tmp_path / "m")
    assert r.model == "mdem" and r.status == "ok"
    vtus = sorted((r.paths["dir"] / "snapshots").glob("*.vtu"))
    assert len(vtus) == 5                                   # t = 0, 10, 20, 30, 40
    assert r.paths["pvd"].is_file()
    out = read_timeseries(r.paths["timeseries"])
    assert set(out.series) == {"t", "well_pressure", "failed_clusters"}
    assert out.realised["tensile_strength"] == 2.5e6 and out.imposed["tensile_strength"] == 3e6
    assert np.array_equal(r.record.t, np.arange(21) * 2.0)   # resampled to log_interval


def test_killed_process_resumes_to_the_same_result(tmp_path):
    """A real kill (SIGKILL) of `xlotkit simulate` mid-run, then --resume."""
    text = STANDARD.read_text().replace('log_interval = "1 s"', 'log_interval = "0.4 s"')
    text = text.replace("checkpoint_steps = 1000", "checkpoint_steps = 500")
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(text)
    exe = [str(Path(sys.executable).with_name("xlotkit"))]
    out = tmp_path / "killed"
    proc = subprocess.Popen(exe + ["simulate", str(scene_file), "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ck = out / "checkpoint.npz"
    t0 = time.monotonic()
    while not ck.exists() and proc.poll() is None and time.monotonic() - t0 < 60:
        time.sleep(0.01)
    if proc.poll() is not None:
        pytest.skip("the run finished before it could be killed")
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert ck.exists() and not (out / "summary.json").exists()
    res = subprocess.run(exe + ["simulate", str(scene_file), "--out", str(out), "--resume"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert "(resumed)" in res.stdout
    ref = simulate(load_scene(scene_file), tmp_path / "ref")
    a = read_timeseries(out / "timeseries.h5")
    b = read_timeseries(ref.paths["timeseries"])
    assert all(np.array_equal(a.series[k], b.series[k], equal_nan=True) for k in b.series)
    assert np.array_equal(read_log(out / "synthetic_log.csv").pressure,
                          read_log(ref.paths["log"]).pressure)


def test_ctrl_c_tells_how_to_resume(tmp_path):
    text = STANDARD.read_text().replace('log_interval = "1 s"', 'log_interval = "0.4 s"')
    text = text.replace("checkpoint_steps = 1000", "checkpoint_steps = 300")
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(text)
    out = tmp_path / "run"
    proc = subprocess.Popen([str(Path(sys.executable).with_name("xlotkit")), "simulate",
                             str(scene_file), "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while not (out / "checkpoint.npz").exists() and proc.poll() is None \
            and time.monotonic() - t0 < 60:
        time.sleep(0.01)
    if proc.poll() is not None:
        pytest.skip("the run finished before it could be interrupted")
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert f"--out {out} --resume" in err and "Traceback" not in err
    assert (out / "checkpoint.npz").exists()


def test_surface_gauge_log(standard, standard_run, tmp_path):
    """``output.gauge = "surface"``: the log is what a cementing unit records, the surface
    pressure channel of the same run with the same noise draw, referenced to surface; the
    interpreter given the TVD takes its closure back to depth."""
    sc = _with(standard, "output", gauge="surface")
    r = simulate(sc, tmp_path / "surface")
    ref = standard_run
    assert r.record.reference == PressureReference(kind="surface", depth_m=0.0, absolute=False)
    assert "surface_pressure" not in r.record.channels
    # same engine run (same clean record), same noise seed: the gauge's pressure is the
    # bottom-hole log's surface channel plus the same noise (to the gauge resolution)
    assert np.array_equal(r.clean_record.pressure, ref.clean_record.pressure)
    noise = ref.record.pressure - ref.clean_record.pressure
    res = max(sc.output.resolution, 1.0)
    assert np.allclose(r.record.pressure - noise, ref.clean_record.channels["surface_pressure"],
                       rtol=0, atol=res)
    log = read_log(r.paths["log"])
    assert log.reference.kind == "surface"
    # the bottom-hole gauge sits a fluid column below: about rho0 g TVD apart at rest
    hyd = sc.fluid.density * 9.80665 * 2000.0
    d0 = float(ref.record.pressure[0] - r.record.pressure[0])
    assert d0 == pytest.approx(hyd, rel=0.01)
    with pytest.raises(InputError, match="output.gauge"):
        scene_from_dict({"output": {"gauge": "pump"}, "schedule": {"phase": [
            {"kind": "pump", "rate": "500 l/min", "duration": "30 s"}]}})


# ----------------------------------------------------------------------------- issue 17
def _count_checkpoints(monkeypatch):
    saves = []
    real = run_mod.driver._save_checkpoint

    def counting(path, engine, drv):
        saves.append(engine.time)
        real(path, engine, drv)

    monkeypatch.setattr(run_mod.driver, "_save_checkpoint", counting)
    return saves


def test_checkpoints_at_the_start_and_at_every_phase_end(standard, tmp_path, monkeypatch):
    """Besides every checkpoint_steps steps and checkpoint_seconds of wall time (default
    10 s), the driver checkpoints when the run starts and when a phase ends."""
    from xlotkit.sim.scene import Numerics

    assert Numerics().checkpoint_seconds == 10.0
    saves = _count_checkpoints(monkeypatch)
    sc = _with(standard, "numerics", checkpoint_steps=10**9, checkpoint_seconds=86400.0)
    simulate(sc, tmp_path / "ck")
    assert saves[0] == 0.0 and len(saves) == 1 + sc.schedule.n_phases
    assert saves == sorted(set(saves))                 # one per phase end, in order


def test_an_interruption_leaves_a_checkpoint_of_its_last_step(standard, standard_run, tmp_path):
    """Ctrl-C (here: the progress callback) writes a checkpoint of the state after the last
    whole step, so the resume takes up exactly there, and the result is the same."""
    sc = _with(standard, "numerics", checkpoint_steps=10**9, checkpoint_seconds=86400.0)
    out = tmp_path / "r"
    seen = {"n": 0}

    def stop(frac, msg):
        seen["n"] += 1
        if seen["n"] == 5:              # before any phase has ended: only the start's
            raise KeyboardInterrupt

    with pytest.raises(SimulationInterrupted) as ei:
        simulate(sc, out, progress=stop)
    assert ei.value.has_checkpoint
    r = simulate(sc, out, resume=True)
    assert r.resumed and r.n_steps == standard_run.n_steps
    assert np.array_equal(r.record.pressure, standard_run.record.pressure)


def _storage_scene():
    sc = load_scene(ROOT / "examples" / "scene_2d_heterogeneous.toml")
    return _with(sc, "output", snapshot_interval=5.0, log_interval=2.0)


def _series(folder: Path) -> tuple[list[str], str]:
    return (sorted(p.name for p in (folder / "snapshots").glob("*.vtu")),
            (folder / "fields.pvd").read_text())


def test_resume_with_snapshots_continues_the_series(tmp_path, monkeypatch):
    """A run with snapshots killed after its last checkpoint (snapshots written since) and
    one killed before any: --resume continues both to the series of an uninterrupted run,
    without duplicates (before issue 17 the folder's snapshots/ made the resume refuse)."""
    monkeypatch.setitem(run_mod.ENGINES, "mdem", _StorageEngine)
    sc = _with(_storage_scene(), "numerics", checkpoint_steps=10)
    ref = simulate(sc, tmp_path / "ref")
    want = _series(ref.paths["dir"])
    assert len(want[0]) == 9                          # t = 0, 5, ..., 40

    class Killed(BaseException):
        """Not a KeyboardInterrupt: the driver writes nothing more (as under SIGKILL)."""

    def kill_at(n):
        seen = {"n": 0}

        def progress(frac, msg):
            seen["n"] += 1
            if seen["n"] == n:
                raise Killed
        return progress

    out = tmp_path / "killed"
    with pytest.raises(Killed):
        simulate(sc, out, progress=kill_at(27))       # checkpoint at step 20, snaps to 25
    assert len(list((out / "snapshots").glob("*.vtu"))) == 6
    r = simulate(sc, out, resume=True)
    assert r.resumed and _series(out) == want
    assert np.array_equal(r.record.pressure, ref.record.pressure)

    out2 = tmp_path / "early"
    with pytest.raises(Killed):
        simulate(sc, out2, progress=kill_at(12))
    (out2 / "checkpoint.npz").unlink()                # killed before its first checkpoint
    assert (out2 / "snapshots").is_dir() and (out2 / "fields.pvd").is_file()
    r2 = simulate(sc, out2, resume=True)
    assert not r2.resumed and r2.paths["dir"] == out2 and _series(out2) == want
    with pytest.raises(InputError, match="differs"):  # another scene's folder: refused
        out3 = tmp_path / "other"
        with pytest.raises(Killed):
            simulate(sc, out3, progress=kill_at(3))
        (out3 / "checkpoint.npz").unlink()
        simulate(_with(sc, "rock", tensile_strength=4e6), out3, resume=True)


def test_a_redirected_run_names_its_folder_when_it_starts(standard, standard_run, tmp_path):
    calls = []
    full = standard_run.paths["dir"]

    def started(folder, redirected):
        calls.append((folder, redirected, (folder / "summary.json").exists()))

    r = simulate(standard, full, started=started)
    assert calls == [(r.paths["dir"], True, False)] and r.paths["dir"] != full
    assert r.paths["dir"].name.startswith(full.name + "-")
    calls.clear()
    simulate(standard, tmp_path / "new", started=started)
    assert calls == [(tmp_path / "new", False, False)]


def test_cli_names_the_redirected_folder(tmp_path):
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(STANDARD.read_text())
    out = tmp_path / "res"
    out.mkdir()
    (out / "earlier.txt").write_text("results of another run")
    exe = str(Path(sys.executable).with_name("xlotkit"))
    res = subprocess.run([exe, "simulate", str(scene_file), "--out", str(out)],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert f"{out} holds earlier results; this run writes to {out}-2" in res.stderr
    assert (out / "earlier.txt").read_text() == "results of another run"


class _FailingEngine(_StorageEngine):
    """Fails at its 25th step (phase 2 of the scene below) with ``error``."""

    error: Exception = RuntimeError("x")

    def step(self):
        if self.k == 24:
            raise type(self).error
        super().step()
        reason = {1: "phase start", 20: "phase end: duration", 21: "phase start"}.get(
            self.k, "accepted")
        return StepOutcome(True, self.time, reason)


def _failing_scene():
    sc = _storage_scene()
    from xlotkit.sim.schedule import Pump, Schedule, ShutIn

    return dataclasses.replace(sc, schedule=Schedule((Pump(rate=1e-3, duration=20.0),
                                                      ShutIn(duration=20.0))))


@pytest.mark.parametrize("error, key", [
    (run_mod.driver.XlotkitError("2D step of 1e-05 s at t = 24 s failed at the floor "
                                 "numerics.dt_min = 1e-05 s"), "numerics.dt_min"),
    (run_mod.driver.InputError("fluid column has no finite solution", key="column"),
     "fluid.compressibility"),
    (RuntimeError("pressure did not bracket"), "numerics.dt_max"),
])
def test_a_run_failing_part_way_names_time_phase_and_key(tmp_path, monkeypatch, error, key):
    monkeypatch.setitem(run_mod.ENGINES, "mdem", _FailingEngine)
    monkeypatch.setattr(_FailingEngine, "error", error)
    sc = _failing_scene()
    with pytest.raises(InputError) as ei:
        simulate(sc, tmp_path / "f")
    e = ei.value
    assert e.key == key and e.file == sc.source_file
    assert "the run failed at t = 24.000 s, in phase 2 (cycle 1, shut_in" in e.message
    assert str(error).split(":")[-1].strip() in e.message
