"""What a simulation writes: HDF5 time series, VTU field snapshots, the synthetic field log.

* :func:`write_timeseries` / :func:`read_timeseries` — one HDF5 file (h5py)::

      /                      attrs: xlotkit_version, model, coupling, seed, scene (the scene
                             file's text), scene_resolved (every key, SI), scene_file,
                             status, message, n_steps
      /timeseries/<column>   one dataset per column the engine has (see SERIES_COLUMNS;
                             absent columns are absent, never zero), attrs unit, description
      /record/<series>       the clean record on the log grid (t, pressure, rate, ...,
                             channel.<name>)
      /truth                 attrs imposed_<q> and realised_<q> for q in sigma_h, sigma_H,
                             tensile_strength, pore_pressure
      /truth/model           the engine's own truth: scalars as attrs, arrays as datasets,
                             anything else as a JSON attr

* :func:`write_snapshot` / :func:`write_pvd` — field snapshots of engines with a mesh as
  VTU files (meshio) and a ParaView ``.pvd`` collection listing them with their times.
* :func:`synthetic_log` — the record a field logger would have produced (bottom-hole
  gauge pressure, surface pressure, pump and return rates and volumes, density) at a chosen
  sample interval, with seeded Gaussian gauge noise and a resolution; written by
  :func:`xlotkit.logfile.write_log` in the CSV layout ``xlotkit inspect`` / ``pick``
  read.

All values SI (Pa, m, s, m^3, m^3/s).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

from xlotkit import __version__
from xlotkit.atomic import atomic_write, atomic_write_text
from xlotkit.errors import InputError, XlotkitError
from xlotkit.record import PressureReference, Record

__all__ = [
    "SERIES_COLUMNS",
    "TRUTH_QUANTITIES",
    "SimulationOutput",
    "Snapshot",
    "add_gauge_noise",
    "read_timeseries",
    "resample_record",
    "surface_gauge_record",
    "synthetic_log",
    "write_pvd",
    "write_snapshot",
    "write_timeseries",
]

#: Time-series columns an engine may produce: name -> (SI unit, meaning).
SERIES_COLUMNS: dict[str, tuple[str, str]] = {
    "t": ("s", "simulated time"),
    "surface_pressure": ("Pa", "gauge pressure at surface (pump / choke)"),
    "bottomhole_pressure": ("Pa", "gauge pressure at the open hole"),
    "well_pressure": ("Pa", "pressure of the well's storage (2D: the borehole unknown p_w)"),
    "segment_pressure": ("Pa", "pressure in the open-hole segment of the 2D model"),
    "fracture_pressure": ("Pa", "pressure at the fracture mouth"),
    "pump_rate": ("m^3/s", "pump rate (surface, reference density)"),
    "return_rate": ("m^3/s", "return rate at surface"),
    "pumped_volume": ("m^3", "cumulative pumped volume"),
    "returned_volume": ("m^3", "cumulative returned volume"),
    "leakoff_volume": ("m^3", "cumulative volume leaked into the formation"),
    "fracture_length": ("m", "fracture half-length (KGD, 2D) or radius (penny)"),
    "fracture_volume": ("m^3", "fracture volume"),
    "failed_clusters": ("-", "number of failed MDEM clusters"),
    "mass_balance_error": ("-", "relative mass-balance residual of the step ending here"),
}

#: Quantities stored as imposed and realised truth.
TRUTH_QUANTITIES = ("sigma_h", "sigma_H", "tensile_strength", "pore_pressure")

_RECORD_SERIES = ("pressure", "rate", "volume", "return_rate", "return_volume", "density",
                  "temperature")


class OutputError(XlotkitError):
    """An engine produced output that does not follow :data:`SERIES_COLUMNS`."""


def check_rows(rows: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Validate an engine's time-series rows: known names, ``t`` present, equal lengths.

    Raises
    ------
    OutputError
        Naming the offending column.
    """
    if "t" not in rows:
        raise OutputError("engine time series has no 't' column")
    out: dict[str, np.ndarray] = {}
    n = None
    for k, v in rows.items():
        if k not in SERIES_COLUMNS:
            raise OutputError(f"engine time series column {k!r} is not one of "
                              + ", ".join(SERIES_COLUMNS))
        a = np.asarray(v, dtype=float)
        if a.ndim != 1:
            raise OutputError(f"engine time series column {k!r} is not one-dimensional")
        if n is None:
            n = a.size
        elif a.size != n:
            raise OutputError(f"engine time series column {k!r} has {a.size} rows, "
                              f"expected {n}")
        out[k] = a
    return out


# =========================================================================== synthetic log
def add_gauge_noise(record: Record, *, noise: float, resolution: float, seed: int) -> Record:
    """Gauge noise and resolution on the pressures of a record.

    Draws ``N(0, noise)`` for ``pressure`` and then for the ``surface_pressure`` channel
    (if any) from ``numpy.random.default_rng(seed)``, then rounds both to ``resolution``
    (the same draws as :func:`xlotkit.sim.lumped.simulate_lumped`'s own noise).

    Parameters
    ----------
    record : Record
    noise : float
        Standard deviation [Pa] (0: none).
    resolution : float
        Gauge resolution [Pa] (0: none).
    seed : int

    Returns
    -------
    Record
        A new record; ``meta`` gets ``noise``, ``resolution`` and ``seed``.
    """
    p = record.pressure.copy()
    ps = record.channels.get("surface_pressure")
    ps = None if ps is None else ps.copy()
    rng = np.random.default_rng(seed)
    if noise > 0.0:
        p = p + rng.normal(0.0, noise, size=p.size)
        if ps is not None:
            ps = ps + rng.normal(0.0, noise, size=ps.size)
    if resolution > 0.0:
        p = np.round(p / resolution) * resolution
        if ps is not None:
            ps = np.round(ps / resolution) * resolution
    chans = dict(record.channels)
    if ps is not None:
        chans["surface_pressure"] = ps
    meta = {**record.meta, "noise": float(noise), "resolution": float(resolution),
            "seed": int(seed)}
    return record.replace(pressure=p, channels=chans, meta=meta)


def resample_record(record: Record, interval: float) -> Record:
    """The record on the grid ``0, interval, 2 interval, ...`` (itself if already on it).

    Pressures, volumes, density and channels are interpolated linearly; rates are taken
    from the latest sample at or before each new time (they are step functions).
    """
    t = record.t
    if t.size > 1 and np.allclose(np.diff(t), interval, rtol=0.0, atol=1e-9 * interval) \
            and abs(t[0]) <= 1e-9 * interval:
        return record
    n = int(math.floor(float(t[-1]) / interval + 1e-9)) + 1
    tn = np.arange(n) * interval
    idx = np.clip(np.searchsorted(t, tn + 1e-9 * interval, side="right") - 1, 0, t.size - 1)

    def lin(a):
        return None if a is None else np.interp(tn, t, a)

    def prev(a):
        return None if a is None else a[idx]

    return Record(
        t=tn, pressure=lin(record.pressure), reference=record.reference,
        start_time=record.start_time, rate=prev(record.rate), volume=lin(record.volume),
        return_rate=prev(record.return_rate), return_volume=lin(record.return_volume),
        density=lin(record.density), temperature=lin(record.temperature),
        channels={k: lin(v) for k, v in record.channels.items()},
        events=record.events, sources=record.sources,
        meta={**record.meta, "dt": float(interval)})


def synthetic_log(record: Record, *, interval: float, noise: float = 0.0,
                  resolution: float = 0.0, seed: int = 0,
                  channels: Sequence[str] = ("surface_pressure",)) -> Record:
    """The field log a logger would have recorded from a simulated (clean) record.

    Parameters
    ----------
    record : Record
        The engine's clean record (bottom-hole pressure, rates, volumes, channels).
    interval : float
        Sample interval [s].
    noise, resolution : float
        Gauge noise standard deviation and resolution [Pa].
    seed : int
        Seed of the noise.
    channels : sequence of str
        Channels kept (what a logger measures; model quantities such as the fracture
        length stay in the HDF5 file).

    Returns
    -------
    Record
        Ready for :func:`xlotkit.logfile.write_log`.
    """
    rec = resample_record(record, interval)
    rec = rec.replace(channels={k: v for k, v in rec.channels.items() if k in channels})
    return add_gauge_noise(rec, noise=noise, resolution=resolution, seed=seed)


def surface_gauge_record(record: Record) -> Record:
    """The record as the surface (cementing-unit) gauge measures it.

    The pressure is the engine's ``surface_pressure`` channel (the bottom-hole pressure
    carried up the fluid column with the rate of the moment, so pipe friction is in it when
    the scene charges friction), the reference ``surface`` at 0 m; the channel itself is
    dropped (it is now the pressure). Rates, volumes, density, events and metadata are
    unchanged.

    Raises
    ------
    InputError
        If the record has no ``surface_pressure`` channel.
    """
    ps = record.channels.get("surface_pressure")
    if ps is None:
        raise InputError("the engine's record has no surface pressure", key="output.gauge",
                         expected="'bottomhole'")
    channels = {k: v for k, v in record.channels.items() if k != "surface_pressure"}
    return record.replace(pressure=np.asarray(ps, dtype=float), channels=channels,
                          reference=PressureReference(kind="surface", depth_m=0.0,
                                                      absolute=False))


# =========================================================================== HDF5
@dataclass(frozen=True)
class SimulationOutput:
    """The content of a time-series HDF5 file (:func:`read_timeseries`).

    Attributes
    ----------
    series : dict of str to ndarray
        The time-series columns present.
    attrs : dict
        Root attributes (version, model, scene text, seed, status, ...).
    record : Record
        The clean record on the log grid.
    imposed, realised : dict of str to float
        Truth (:data:`TRUTH_QUANTITIES`) put into the simulation and realised in it.
    truth : dict
        The engine's own truth.
    """

    series: dict[str, np.ndarray]
    attrs: dict[str, Any]
    record: Record
    imposed: dict[str, float]
    realised: dict[str, float]
    truth: dict[str, Any] = field(default_factory=dict)


def _attr_value(v: Any) -> Any:
    """An HDF5-storable attribute value, or None (then stored as JSON)."""
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)):
        return np.bool_(v)
    if isinstance(v, (int, float, np.integer, np.floating, str)):
        return v
    return None


def write_timeseries(path: str | Path, rows: Mapping[str, Any], *, record: Record,
                     truth: Mapping[str, Any], imposed: Mapping[str, float],
                     realised: Mapping[str, float], attrs: Mapping[str, Any]) -> Path:
    """Write the HDF5 file (layout in the module docstring), atomically.

    Parameters
    ----------
    path : path-like
        Destination (replaced atomically if it exists).
    rows : mapping
        Engine time series (:func:`check_rows` applies).
    record : Record
        The clean record on the log grid.
    truth : mapping
        The engine's own truth (arrays become datasets, scalars attrs, the rest JSON).
    imposed, realised : mapping
        Truth quantities [Pa].
    attrs : mapping
        Root attributes (scalars and strings).

    Returns
    -------
    Path
    """
    import h5py

    cols = check_rows(rows)

    def write(tmp: Path) -> None:
        with h5py.File(tmp, "w") as f:
            f.attrs["xlotkit_version"] = __version__
            for k, v in attrs.items():
                if v is not None:
                    f.attrs[k] = v
            g = f.create_group("timeseries")
            for k, a in cols.items():
                d = g.create_dataset(k, data=a)
                d.attrs["unit"], d.attrs["description"] = SERIES_COLUMNS[k]
            r = f.create_group("record")
            r.create_dataset("t", data=record.t)
            for k in _RECORD_SERIES:
                a = getattr(record, k)
                if a is not None:
                    r.create_dataset(k, data=a)
            for k, a in record.channels.items():
                r.create_dataset(f"channel.{k}", data=a)
            r.attrs["reference"] = json.dumps({"kind": record.reference.kind,
                                               "depth_m": record.reference.depth_m,
                                               "absolute": record.reference.absolute})
            if record.start_time is not None:
                r.attrs["start_time"] = record.start_time.isoformat()
            r.attrs["events"] = json.dumps([[e.t, e.text] for e in record.events])
            tg = f.create_group("truth")
            for q in TRUTH_QUANTITIES:
                for kind, src in (("imposed", imposed), ("realised", realised)):
                    if src.get(q) is not None:
                        tg.attrs[f"{kind}_{q}"] = float(src[q])
            mg = tg.create_group("model")
            for k, v in truth.items():
                if isinstance(v, np.ndarray):
                    mg.create_dataset(k, data=v)
                    continue
                a = _attr_value(v)
                if a is not None:
                    mg.attrs[k] = a
                else:
                    mg.attrs[f"{k}.json"] = json.dumps(v, default=_json_default)

    return atomic_write(path, write)


def _json_default(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return str(v)


def read_timeseries(path: str | Path) -> SimulationOutput:
    """Read a file written by :func:`write_timeseries`."""
    from datetime import datetime

    import h5py

    from xlotkit.record import Event, PressureReference

    with h5py.File(path, "r") as f:
        attrs = {k: _plain(v) for k, v in f.attrs.items()}
        series = {k: np.asarray(d[()]) for k, d in f["timeseries"].items()}
        r = f["record"]
        ref = json.loads(r.attrs["reference"])
        kw = {k: np.asarray(r[k][()]) for k in _RECORD_SERIES if k in r}
        chans = {k[len("channel."):]: np.asarray(d[()]) for k, d in r.items()
                 if k.startswith("channel.")}
        st = r.attrs.get("start_time")
        record = Record(
            t=np.asarray(r["t"][()]), reference=PressureReference(**ref),
            start_time=None if st is None else datetime.fromisoformat(_plain(st)),
            channels=chans, events=tuple(Event(t=t, text=x)
                                         for t, x in json.loads(r.attrs["events"])), **kw)
        tg = f["truth"]
        imposed = {k[len("imposed_"):]: float(v) for k, v in tg.attrs.items()
                   if k.startswith("imposed_")}
        realised = {k[len("realised_"):]: float(v) for k, v in tg.attrs.items()
                    if k.startswith("realised_")}
        truth: dict[str, Any] = {}
        mg = tg["model"]
        for k, v in mg.attrs.items():
            if k.endswith(".json"):
                truth[k[:-5]] = json.loads(_plain(v))
            else:
                truth[k] = _plain(v)
        for k, d in mg.items():
            truth[k] = np.asarray(d[()])
    return SimulationOutput(series=series, attrs=attrs, record=record, imposed=imposed,
                            realised=realised, truth=truth)


def _plain(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.generic):
        return v.item()
    return v


# =========================================================================== snapshots
@dataclass(frozen=True)
class Snapshot:
    """Fields on a triangle mesh at one time (from an engine with a mesh).

    Attributes
    ----------
    time : float
        Simulated time [s].
    points : ndarray, shape (n, 2) or (n, 3)
        Node coordinates [m].
    triangles : ndarray of int, shape (m, 3)
    point_data : dict of str to ndarray
        Per-node fields, e.g. ``displacement`` (n, 2).
    cell_data : dict of str to ndarray
        Per-triangle fields, e.g. ``pressure``, ``permeability``, ``aperture``,
        ``stress`` (m, 3), ``failed``.
    """

    time: float
    points: np.ndarray
    triangles: np.ndarray
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    cell_data: dict[str, np.ndarray] = field(default_factory=dict)


def write_snapshot(path: str | Path, snap: Snapshot) -> Path:
    """Write one snapshot as a VTU file (meshio), atomically."""
    import meshio

    pts = np.asarray(snap.points, dtype=float)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    mesh = meshio.Mesh(
        pts, [("triangle", np.asarray(snap.triangles, dtype=np.int64))],
        point_data={k: np.asarray(v) for k, v in snap.point_data.items()},
        cell_data={k: [np.asarray(v)] for k, v in snap.cell_data.items()})
    return atomic_write(path, lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))


def write_pvd(path: str | Path, entries: Sequence[tuple[float, str]]) -> Path:
    """Write a ParaView collection (``.pvd``) of ``(time, relative VTU path)`` entries."""
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    for t, name in entries:
        lines.append(f'    <DataSet timestep="{float(t)!r}" group="" part="0" '
                     f"file={quoteattr(name)}/>")
    lines += ["  </Collection>", "</VTKFile>", ""]
    return atomic_write_text(path, "\n".join(lines))
