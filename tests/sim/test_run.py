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
