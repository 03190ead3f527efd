"""The canonical xlotkit log file: its layout and its writer.

Both halves use this file format: the simulator writes its synthetic logs in it and the
interpreter (:func:`xlotkit.interpret.io.read_log`) reads it back like any field log. It lives
on the ground floor so that :mod:`xlotkit.sim` never imports :mod:`xlotkit.interpret`.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from xlotkit.atomic import atomic_write
from xlotkit.errors import InputError
from xlotkit.record import Record
from xlotkit.units import from_si, parse_unit

__all__ = ["CANON_COLUMNS", "CANON_MAGIC", "CANON_VERSION", "CHANNEL_UNITS", "write_log"]

#: Canonical layout: column titles and the units they are written in.
CANON_COLUMNS = (
    ("pressure", "Pressure", "bar"),
    ("rate", "Rate", "l/min"),
    ("volume", "Volume", "m3"),
    ("return_rate", "Return Rate", "l/min"),
    ("return_volume", "Return Volume", "m3"),
    ("density", "Density", "sg"),
    ("temperature", "Temperature", "degC"),
)
CANON_MAGIC = "xlotkit-log"
CANON_VERSION = "1"

#: Units channels are written in, by the kind of quantity.
CHANNEL_UNITS = (("pressure", "bar"), ("rate", "l/min"), ("volume", "m3"),
                  ("density", "sg"), ("temperature", "degC"), ("time", "s"),
                  ("length", "m"), ("dimensionless", "-"))


def _blank_unit(u: str | None) -> bool:
    return u is None or u.strip().strip("[]()").strip() == ""


def _channel_unit(rec: Record, name: str) -> str:
    """Unit to write a channel in: by the kind of its source column, else SI as is."""
    for c in rec.columns:
        if c.field == "channel:" + name and not _blank_unit(c.unit) and c.unit.upper() != "SI":
            try:
                pu = parse_unit(c.unit)
            except InputError:
                break
            for kind, unit in CHANNEL_UNITS:
                if pu.is_a(kind):
                    return unit
            break
    return "SI"


def _fmt(x: float, digits: int) -> str:
    if not np.isfinite(x):
        return ""
    s = f"{x:.{digits}g}"
    return "0" if s == "-0" else s


def write_log(record: Record, path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """Write a record in the canonical CSV layout that :func:`xlotkit.interpret.io.read_log` reads back.

    The file starts with ``# key: value`` lines (``xlotkit-log``, ``reference``,
    ``depth_m``, ``absolute``, ``start_time``, ``source``, ``meta.KEY`` as JSON, one
    ``event`` per remark as JSON), then a comma-separated header ``time (s),Pressure
    (bar),Rate (l/min),Volume (m3),Return Rate (l/min),Return Volume (m3),Density (sg),
    Temperature (degC),<channel> (unit)...`` and one row per sample (15 significant digits
    for time, 12 for values). Absolute pressures are written as they are, with
    ``absolute: true``.

    Parameters
    ----------
    record : Record
        What to write.
    path : path-like
        Destination; written atomically (temporary file in the same directory, then
        ``os.replace``).
    overwrite : bool
        Replace an existing file; otherwise an existing file raises :class:`InputError`.

    Returns
    -------
    Path
        The file written.
    """
    p = Path(path)
    if p.exists() and not overwrite:
        raise InputError("file exists; pass overwrite=True to replace it", file=p,
                         key="overwrite", expected="a new file name or overwrite=True")
    ref = record.reference
    head = [f"# {CANON_MAGIC}: {CANON_VERSION}",
            f"# reference: {ref.kind}",
            f"# depth_m: {'none' if ref.depth_m is None else repr(float(ref.depth_m))}",
            f"# absolute: {'true' if ref.absolute else 'false'}",
            f"# start_time: {'none' if record.start_time is None else record.start_time.isoformat()}"]
    head += [f"# source: {s}" for s in record.sources]
    for k, v in record.meta.items():
        if str(k).startswith("_"):
            continue
        head.append(f"# meta.{k}: {json.dumps(v, default=str, ensure_ascii=False)}")
    for e in record.events:
        d = {"t": e.t, "text": e.text, "line": e.line, "source": e.source,
             "timestamp": None if e.timestamp is None else e.timestamp.isoformat()}
        head.append(f"# event: {json.dumps(d, ensure_ascii=False)}")
    cols: list[tuple[str, np.ndarray, int]] = [("time (s)", record.t, 15)]
    for field, title, unit in CANON_COLUMNS:
        arr = record.series(field)
        if arr is not None:
            cols.append((f"{title} ({unit})", from_si(arr, unit), 12))
    canon_titles = {title for _, title, _ in CANON_COLUMNS} | {"time"}
    for name, arr in record.channels.items():
        if name in canon_titles or "," in name or "(" in name:
            raise InputError(f"channel name {name!r} cannot be written", file=p, key=name,
                             expected="a channel name without commas or parentheses")
        unit = _channel_unit(record, name)
        vals = arr if unit == "SI" else from_si(arr, unit)
        cols.append((f"{name} ({unit})", vals, 12))
    out = [",".join(c[0] for c in cols)]
    mats = [[_fmt(float(v), d) for v in arr] for _, arr, d in cols]
    out += [",".join(row) for row in zip(*mats)]
    text = "\n".join(head + out) + "\n"
    p.parent.mkdir(parents=True, exist_ok=True)
    def refuse_if_appeared() -> None:
        if p.exists() and not overwrite:   # appeared meanwhile
            raise InputError("file exists; pass overwrite=True to replace it", file=p,
                             key="overwrite", expected="a new file name or overwrite=True")

    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)

    atomic_write(p, write, before_replace=refuse_if_appeared)
    return p
