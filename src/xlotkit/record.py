"""The canonical XLOT record shared by the readers, the simulators and the interpreter.

A :class:`Record` is plain data: NumPy arrays in SI units on one time base, plus metadata
about where each series came from. Field logs are read into it by :mod:`xlotkit.interpret.io`;
the simulators produce it directly. Records are immutable: every change returns a new one
(:meth:`Record.replace`, :meth:`Record.select`).

Conventions
-----------
* ``t`` is elapsed time in s from ``start_time`` (the first sample of the record's own clock),
  strictly increasing.
* ``pressure`` is in Pa, measured where :attr:`Record.reference` says. Whether it is absolute
  or gauge is part of the reference; :meth:`Record.gauge_pressure` always returns gauge.
* ``rate`` is the pump rate into the well [m^3/s] (>= 0), ``volume`` the cumulative pumped
  volume [m^3] made continuous across totaliser resets; ``return_rate`` / ``return_volume``
  the same for fluid coming back out of the well (flowback, bleed-off).
* ``density`` in kg/m^3, ``temperature`` in K.
* Other series (e.g. ``surface_pressure`` on a merged record, ``return_pressure``) live in
  :attr:`Record.channels`, also SI.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime, timedelta
from typing import Any, Literal

import numpy as np

__all__ = ["ATMOSPHERE_PA", "ColumnInfo", "Event", "PressureReference", "Record"]

#: Standard atmosphere [Pa], used to turn absolute gauge readings into gauge pressure.
ATMOSPHERE_PA = 101_325.0

_SERIES = ("rate", "volume", "return_rate", "return_volume", "density", "temperature")


@dataclass(frozen=True)
class PressureReference:
    """Where and how a pressure series was measured.

    Attributes
    ----------
    kind : {"surface", "downhole", "bottomhole"}
        ``surface``: cementing unit / standpipe; ``downhole``: a gauge at ``depth_m``;
        ``bottomhole``: at the open-hole segment itself (e.g. simulated).
    depth_m : float or None
        Measured depth of the gauge [m] where known.
    absolute : bool
        True when readings include atmospheric pressure (psia gauges).
    """

    kind: Literal["surface", "downhole", "bottomhole"] = "surface"
    depth_m: float | None = None
    absolute: bool = False

    def describe(self) -> str:
        """Short human-readable label, e.g. ``"downhole gauge at 1383 m MD (absolute)"``."""
        if self.kind == "downhole":
            s = "downhole gauge"
            if self.depth_m is not None:
                s += f" at {self.depth_m:g} m MD"
        elif self.kind == "bottomhole":
            s = "bottom hole"
        else:
            s = "surface"
        return s + (" (absolute)" if self.absolute else " (gauge)")


@dataclass(frozen=True)
class ColumnInfo:
    """Provenance of one column of a log file.

    Attributes
    ----------
    name : str
        Column name as written in the file.
    unit : str
        Unit as written in the file (or given by the user); ``""`` if none.
    field : str
        Record field or channel it was mapped to (``"pressure"``, ``"rate"``, ...), or
        ``""`` when the column was not used.
    source : str
        File it came from.
    unit_source : str
        Where the unit came from: ``"header line 1"``, ``"units row line 2"``, ``"--unit"``,
        ``"layout"`` (the file family fixes it) or ``""``.
    resolution : float or None
        Smallest step between two different recorded values, in SI units of the field
        (the logger's quantisation, e.g. 1e5 Pa for a surface gauge reading whole bars);
        None when the column has fewer than two distinct values or was not used.
    n_missing : int
        Data rows whose cell was blank, a not-recorded marker (``-``, ``N/A``, ...), or a
        pressure written as 0 where it was not recorded (see the reader); NaN in the series.
    dropped : tuple of (int, str, str)
        Single impossible cells set to NaN: ``(line, cell text, reason)``.
    """

    name: str
    unit: str
    field: str
    source: str = ""
    unit_source: str = ""
    resolution: float | None = None
    n_missing: int = 0
    dropped: tuple[tuple[int, str, str], ...] = ()


@dataclass(frozen=True)
class Event:
    """A timestamped free-text remark from a log (``"flush lines"``, ``"start test 2"``).

    Attributes
    ----------
    t : float
        Elapsed time on the record's time base [s].
    text : str
        The remark, stripped.
    timestamp : datetime or None
        Absolute time on the clock of the file it came from.
    source : str
        File name.
    line : int
        1-based line number in that file.
    """

    t: float
    text: str
    timestamp: datetime | None = None
    source: str = ""
    line: int = 0


def _as_series(name: str, value: Any, n: int) -> np.ndarray | None:
    if value is None:
        return None
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n,):
        raise ValueError(f"Record.{name} must have shape ({n},), got {arr.shape}")
    return arr


@dataclass(frozen=True)
class Record:
    """One pressure test record on a single time base, SI units.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Elapsed time [s], strictly increasing.
    pressure : ndarray, shape (n,)
        Pressure [Pa] at :attr:`reference`.
    reference : PressureReference
        Where the pressure was measured and whether it is absolute.
    start_time : datetime or None
        Clock time of ``t = 0`` (naive, the logger's own clock).
    rate, volume, return_rate, return_volume, density, temperature : ndarray or None
        Optional series, shape (n,): m^3/s, m^3, m^3/s, m^3, kg/m^3, K.
    channels : Mapping[str, ndarray]
        Further SI series, shape (n,) each.
    events : tuple of Event
        Remarks, sorted by time.
    columns : tuple of ColumnInfo
        Provenance of the columns read.
    sources : tuple of str
        Files the record was read from (empty for simulated records).
    meta : Mapping[str, Any]
        Free metadata (well name, test name, gauge serial, clock offset applied, ...).
    """

    t: np.ndarray
    pressure: np.ndarray
    reference: PressureReference = field(default_factory=PressureReference)
    start_time: datetime | None = None
    rate: np.ndarray | None = None
    volume: np.ndarray | None = None
    return_rate: np.ndarray | None = None
    return_volume: np.ndarray | None = None
    density: np.ndarray | None = None
    temperature: np.ndarray | None = None
    channels: Mapping[str, np.ndarray] = field(default_factory=dict)
    events: tuple[Event, ...] = ()
    columns: tuple[ColumnInfo, ...] = ()
    sources: tuple[str, ...] = ()
    meta: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1:
            raise ValueError("Record.t must be one-dimensional")
        n = t.size
        if n > 1 and not np.all(np.diff(t) > 0):
            raise ValueError("Record.t must be strictly increasing")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "pressure", _as_series("pressure", self.pressure, n))
        for name in _SERIES:
            object.__setattr__(self, name, _as_series(name, getattr(self, name), n))
        chans = {k: _as_series(f"channels[{k!r}]", v, n) for k, v in dict(self.channels).items()}
        object.__setattr__(self, "channels", chans)
        object.__setattr__(self, "events", tuple(sorted(self.events, key=lambda e: e.t)))
        object.__setattr__(self, "columns", tuple(self.columns))
        object.__setattr__(self, "sources", tuple(self.sources))
        object.__setattr__(self, "meta", dict(self.meta))

    # ------------------------------------------------------------------ basic views
    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def duration(self) -> float:
        """Record length [s]."""
        return float(self.t[-1] - self.t[0]) if self.n else 0.0

    @property
    def timestamps(self) -> np.ndarray | None:
        """Absolute times as ``datetime64[ms]``, or None without ``start_time``."""
        if self.start_time is None:
            return None
        t0 = np.datetime64(self.start_time, "ms")
        return t0 + np.round(self.t * 1000.0).astype("timedelta64[ms]")

    def time_at(self, t: float) -> datetime | None:
        """Clock time of elapsed time ``t`` [s], or None without ``start_time``."""
        if self.start_time is None:
            return None
        return self.start_time + timedelta(seconds=float(t))

    def gauge_pressure(self) -> np.ndarray:
        """Pressure relative to atmosphere [Pa], shape (n,)."""
        if self.reference.absolute:
            return self.pressure - ATMOSPHERE_PA
        return self.pressure

    def series(self, name: str) -> np.ndarray | None:
        """A named series: a record field (``"rate"``, ...) or a channel; None if absent."""
        if name in ("t", "pressure", *_SERIES):
            return getattr(self, name)
        return self.channels.get(name)

    # ------------------------------------------------------------------ new records
    def replace(self, **changes: Any) -> Record:
        """A new record with some fields replaced (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def select(self, index: slice | np.ndarray) -> Record:
        """A new record holding the samples picked by ``index`` (slice or boolean mask).

        Time keeps its origin (``t`` is not shifted); events outside the kept time span
        are dropped.
        """
        idx = index if isinstance(index, slice) else np.asarray(index)
        t = self.t[idx]
        kw: dict[str, Any] = {"t": t, "pressure": self.pressure[idx]}
        for name in _SERIES:
            arr = getattr(self, name)
            kw[name] = None if arr is None else arr[idx]
        kw["channels"] = {k: v[idx] for k, v in self.channels.items()}
        if t.size:
            kw["events"] = tuple(e for e in self.events if t[0] <= e.t <= t[-1])
        else:
            kw["events"] = ()
        return dataclasses.replace(self, **kw)

    def window(self, t_start: float, t_end: float) -> Record:
        """Samples with ``t_start <= t <= t_end`` [s]."""
        return self.select((self.t >= t_start) & (self.t <= t_end))

    def to_dataframe(self):
        """All series as a :class:`pandas.DataFrame` indexed by elapsed time [s] (SI columns)."""
        import pandas as pd

        data: dict[str, np.ndarray] = {"pressure": self.pressure}
        for name in _SERIES:
            arr = getattr(self, name)
            if arr is not None:
                data[name] = arr
        data.update(self.channels)
        return pd.DataFrame(data, index=pd.Index(self.t, name="t"))
