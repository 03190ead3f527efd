"""Simulation outputs: HDF5 time series, synthetic log, VTU snapshots."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from datetime import datetime

import numpy as np
import pytest

from xlotkit.interpret.io import read_log
from xlotkit.logfile import write_log
from xlotkit.record import Event, PressureReference, Record
from xlotkit.sim.output import (
    OutputError,
    Snapshot,
    add_gauge_noise,
    check_rows,
    read_timeseries,
    resample_record,
    synthetic_log,
    write_pvd,
    write_snapshot,
    write_timeseries,
)


def _record(n: int = 61, dt: float = 1.0) -> Record:
    t = np.arange(n) * dt
    q = np.where(t < 30, 0.5 / 60, 0.0)
    return Record(
        t=t, pressure=20e6 + 1e5 * np.minimum(t, 30.0),
        reference=PressureReference(kind="bottomhole", depth_m=2000.0),
        start_time=datetime(2026, 1, 1, 8), rate=q, volume=np.cumsum(q) * dt,
        return_rate=np.zeros(n), return_volume=np.zeros(n), density=np.full(n, 1200.0),
        channels={"surface_pressure": 1e5 * np.minimum(t, 30.0),
                  "fracture_length": np.zeros(n)},
        events=(Event(t=0.0, text="cycle 1: pump"),), meta={"source": "test"})


def test_hdf5_round_trip(tmp_path):
    rec = _record()
    rows = {"t": rec.t, "bottomhole_pressure": rec.pressure, "pump_rate": rec.rate,
            "mass_balance_error": np.r_[np.nan, np.full(rec.n - 1, 1e-12)]}
    truth = {"fbp": 38e6, "isip": {1: 31e6}, "phases": [{"cycle": 1, "kind": "pump"}],
             "t": rec.t, "closure_times": [12.5], "reopening_model": "wellbore",
             "initiation_time": None}
    imposed = {"sigma_h": 30e6, "sigma_H": 35e6, "tensile_strength": 3e6,
               "pore_pressure": 20e6}
    realised = {**imposed, "tensile_strength": 2.9e6}
    path = write_timeseries(tmp_path / "ts.h5", rows, record=rec, truth=truth,
                            imposed=imposed, realised=realised,
                            attrs={"model": "lumped", "scene": "title = 'x'\n", "seed": 4})
    out = read_timeseries(path)
    assert set(out.series) == set(rows)          # absent columns stay absent
    for k, v in rows.items():
        assert np.array_equal(out.series[k], v, equal_nan=True)
    assert out.attrs["model"] == "lumped" and out.attrs["seed"] == 4
    assert out.attrs["scene"] == "title = 'x'\n" and "xlotkit_version" in out.attrs
    assert out.imposed == imposed and out.realised == realised
    assert out.truth["fbp"] == 38e6 and out.truth["isip"] == {"1": 31e6}
    assert out.truth["phases"] == [{"cycle": 1, "kind": "pump"}]
    assert out.truth["closure_times"] == [12.5] and out.truth["initiation_time"] is None
    assert np.array_equal(out.truth["t"], rec.t)
    r = out.record
    assert r.reference == rec.reference and r.start_time == rec.start_time
    for k in ("pressure", "rate", "volume", "return_rate", "density"):
        assert np.array_equal(getattr(r, k), getattr(rec, k))
    assert np.array_equal(r.channels["surface_pressure"], rec.channels["surface_pressure"])
    assert [(e.t, e.text) for e in r.events] == [(0.0, "cycle 1: pump")]


def test_rows_are_checked():
    with pytest.raises(OutputError, match="fracture_width"):
        check_rows({"t": [0.0, 1.0], "fracture_width": [0.0, 1.0]})
    with pytest.raises(OutputError, match="rows"):
        check_rows({"t": [0.0, 1.0], "bottomhole_pressure": [1.0]})
    with pytest.raises(OutputError, match="'t'"):
        check_rows({"bottomhole_pressure": [1.0]})


def test_gauge_noise_is_seeded_and_quantised():
    rec = _record()
    a = add_gauge_noise(rec, noise=2e4, resolution=1e3, seed=3)
    b = add_gauge_noise(rec, noise=2e4, resolution=1e3, seed=3)
    c = add_gauge_noise(rec, noise=2e4, resolution=1e3, seed=4)
    assert np.array_equal(a.pressure, b.pressure) and not np.array_equal(a.pressure, c.pressure)
    assert np.allclose(a.pressure / 1e3, np.round(a.pressure / 1e3), atol=1e-6)
    assert np.std(a.pressure - rec.pressure) == pytest.approx(2e4, rel=0.3)
    assert a.meta["seed"] == 3 and a.meta["noise"] == 2e4
    # no noise, no resolution: unchanged values
    z = add_gauge_noise(rec, noise=0.0, resolution=0.0, seed=0)
    assert np.array_equal(z.pressure, rec.pressure)


def test_resample_keeps_rates_as_steps():
    rec = _record(n=121, dt=0.5)
    r = resample_record(rec, 2.0)
    assert np.array_equal(r.t, np.arange(31) * 2.0)
    assert np.allclose(r.pressure, 20e6 + 1e5 * np.minimum(r.t, 30.0))
    assert np.array_equal(r.rate, np.where(r.t < 30, 0.5 / 60, 0.0))
    assert resample_record(r, 2.0) is r


def test_synthetic_log_round_trips_through_read_log(tmp_path):
    rec = _record()
    log = synthetic_log(rec, interval=2.0, noise=1e3, resolution=100.0, seed=1)
    assert "fracture_length" not in log.channels and "surface_pressure" in log.channels
    path = write_log(log, tmp_path / "log.csv")
    back = read_log(path)
    assert back.n == log.n and back.reference.kind == "bottomhole"
    assert np.allclose(back.pressure, log.pressure, rtol=1e-11, atol=1e-6)
    assert np.allclose(back.rate, log.rate, rtol=1e-11)
    assert np.allclose(back.channels["surface_pressure"], log.channels["surface_pressure"],
                       rtol=1e-11, atol=1e-6)
    assert back.start_time == rec.start_time


def test_vtu_snapshots_and_pvd(tmp_path):
    import meshio

    from xlotkit.sim.mesh import rectangle_mesh

    m = rectangle_mesh(2.0, 1.0, 4, 2)
    ntri = len(m.triangles)
    entries = []
    for k, t in enumerate((0.0, 10.0)):
        snap = Snapshot(time=t, points=m.nodes, triangles=m.triangles,
                        point_data={"displacement": np.zeros((len(m.nodes), 2)) + k},
                        cell_data={"pressure": np.full(ntri, 1e6 * (k + 1))})
        name = f"fields_{k}.vtu"
        write_snapshot(tmp_path / name, snap)
        entries.append((t, name))
    write_pvd(tmp_path / "fields.pvd", entries)
    back = meshio.read(tmp_path / "fields_1.vtu")
    assert back.cells_dict["triangle"].shape == (ntri, 3)
    assert np.array_equal(back.cell_data["pressure"][0], np.full(ntri, 2e6))
    assert np.array_equal(back.points[:, :2], m.nodes)
    ds = ET.parse(tmp_path / "fields.pvd").getroot().findall("./Collection/DataSet")
    assert [(float(d.get("timestep")), d.get("file")) for d in ds] == entries
