"""Read field logs of leak-off tests into :class:`~xlotkit.record.Record`, merge surface and
downhole records, and write the canonical CSV layout.

Three families of files are understood (``kind=``):

``cementing_unit``
    Cementing-unit exports: tab separated, a header row, a units row whose first field is
    ``mm:dd:yyyy:hh:mm:ss``, a row of underscores, then rows ``mm:dd:yyyy:hh:mm:ss<TAB>v1...``.
    Rows holding free text in the first value column (``flush lines``, ``Reset Total, Vol =
    1.56  m3``) are remarks and become :class:`~xlotkit.record.Event` s. Header blocks may
    repeat inside the data.
``downhole_gauge``
    Memory-gauge exports: a preamble (``Well:``, ``Gauge:``, ``Test:``, ``Position: gauge
    depth ... m MD``, ``No Points: n``), a header row, a units row (``Hours``, ``psi
    absolute``, ``°C``), then rows ``[point no] dd-mm-yyyy hh:mm:ss  hours  p  T`` with either
    decimal points or decimal commas.
``csv``
    Ordinary delimited text (comma, semicolon, tab or ``|``, sniffed), a header row with
    units in it (``Pressure (psi)``, ``Pressure [bar]``) and/or a units row, elapsed time or a
    timestamp column. The canonical layout written by :func:`write_log` is a special case.

Everything returned is SI (Pa, m^3/s, m^3, kg/m^3, K, s); all unit conversion goes through
:mod:`xlotkit.units`. Problems in a file raise one :class:`~xlotkit.errors.InputError` naming
the file, the line and the column.

Time handling (documented choices)
----------------------------------
* Loggers stamp whole seconds. When several data rows carry the same whole-second stamp
  (the AMS-01 cementing unit does this after a skipped second, i.e. its stamps jitter) the
  rows are kept and spread evenly inside that second (``k/m`` s for the k-th of m rows):
  each was taken somewhere inside that second, so this moves no sample outside its stamp's
  true interval and keeps ``t`` strictly increasing. Remarks keep their stamp.
* Time that goes backwards cannot be repaired and raises :class:`InputError`.
* Totaliser resets (a cumulative volume falling by more than three times its resolution to
  less than half its previous value) are removed by adding the value before the reset to
  everything after it, so that ``volume`` and ``return_volume`` never fall because of a
  reset; the raw column is then kept as channel ``volume_raw`` / ``return_volume_raw``.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np

from xlotkit.errors import InputError
from xlotkit.logfile import CANON_COLUMNS, CANON_MAGIC, write_log
from xlotkit.record import ColumnInfo, Event, PressureReference, Record
from xlotkit.units import ParsedUnit, parse_unit, to_si

__all__ = [
    "ClockOffset",
    "estimate_clock_offset",
    "merge_surface_downhole",
    "read_log",
    "read_logs",
    "write_log",
]

#: Record fields a column can be mapped to, and the kind of unit each needs.
_FIELD_KIND = {
    "pressure": "pressure",
    "rate": "rate",
    "volume": "volume",
    "return_rate": "rate",
    "return_volume": "volume",
    "density": "density",
    "temperature": "temperature",
    "time": "time",
}

#: Column names understood without a ``column_map`` (normalised: lower case, words only).
_KNOWN_NAMES = {
    **dict.fromkeys(
        ["pressure", "treating pressure", "treating press", "pump pressure", "surface pressure",
         "standpipe pressure", "spp", "downhole pressure", "bottomhole pressure", "bhp", "p",
         "press", "tubing pressure", "injection pressure", "wellhead pressure", "whp"],
        "pressure"),
    **dict.fromkeys(
        ["rate", "flow rate", "flowrate", "pump rate", "injection rate", "q", "slurry rate",
         "rate in", "flow"], "rate"),
    **dict.fromkeys(
        ["volume", "pumped volume", "total volume", "cumulative volume", "vol", "pump volume",
         "injected volume", "volume pumped"], "volume"),
    **dict.fromkeys(
        ["return rate", "cmt return rate", "flowback rate", "return flow rate", "return flow",
         "returns rate"], "return_rate"),
    **dict.fromkeys(
        ["return volume", "return vol", "cmt return volume", "cmt return vol", "returned volume",
         "flowback volume", "returns volume", "bleed volume"], "return_volume"),
    **dict.fromkeys(["density", "fluid density", "mud density", "dens"], "density"),
    **dict.fromkeys(["temperature", "temp", "gauge temperature"], "temperature"),
    **dict.fromkeys(
        ["time", "elapsed", "elapsed time", "delta time", "t", "time elapsed", "runtime",
         "time since start", "tijd"], "time"),
    **dict.fromkeys(
        ["timestamp", "time stamp", "date time", "datetime", "date and time", "clock time",
         "date time stamp"], "timestamp"),
    "date": "date",
    **dict.fromkeys(["cmt return press", "cmt return pressure", "return pressure",
                     "return press"], "channel:return_pressure"),
    **dict.fromkeys(["cmt return dens", "cmt return density", "return density"],
                    "channel:return_density"),
}

# mm:dd:yyyy:hh:mm:ss (cementing unit) at the start of a line
_CU_TS = re.compile(r"^\s*\d{1,2}:\d{1,2}:\d{4}:\d{1,2}:\d{1,2}:\d{1,2}\s*$")
# Any of the date-time spellings accepted in a cell; groups a/b/c are the date parts.
_DT_RE = (r"^\s*(?P<a>\d{1,4})[/.\-:](?P<b>\d{1,2})[/.\-:](?P<c>\d{1,4})(?:[ T:]+|\s*,\s*)"
          r"(?P<H>\d{1,2}):(?P<M>\d{1,2})(?::(?P<S>\d{1,2}(?:[.,]\d+)?))?\s*$")
_DT_RX = re.compile(_DT_RE)
_TIME_OF_DAY = re.compile(r"^\s*\d{1,2}:\d{2}(:\d{2}([.,]\d+)?)?\s*$")
_NUM_POINT = re.compile(r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*$")
_NUM_COMMA = re.compile(r"^\s*[-+]?\d+,\d+([eE][-+]?\d+)?\s*$")
_UNIT_IN_NAME = re.compile(r"^(?P<name>.*?)\s*[\(\[](?P<unit>[^\)\]]*)[\)\]]\s*$")


# ====================================================================== small helpers
def _norm_name(name: str) -> str:
    """Lower case, punctuation to spaces, single spaces: ``"CMT Return-Press."`` -> ``"cmt return press"``."""
    return " ".join(re.sub(r"[^0-9a-z]+", " ", name.lower()).split())


def _sanitize(name: str) -> str:
    """Channel name from a column title: ``"RDA2 IN1"`` -> ``"rda2_in1"``."""
    s = re.sub(r"[^0-9a-z]+", "_", name.lower()).strip("_")
    return s or "column"


def _is_number(s: str, decimal: str = ".") -> bool:
    return bool((_NUM_COMMA if decimal == "," else _NUM_POINT).match(s))


def _blank_unit(u: str | None) -> bool:
    return u is None or u.strip().strip("[]()").strip() == ""


def _fix_mojibake(text: str) -> str:
    # UTF-8 "°" read as Latin-1 elsewhere in the chain shows up as "Â°".
    return text.replace("Â°", "°").replace("Âº", "º")


def _read_text(path: Path) -> list[str]:
    """Decode a log file (UTF-8 with or without BOM, else Windows-1252/Latin-1) into lines."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError("file not found", file=path) from None
    except OSError as exc:
        raise InputError(f"cannot read file ({exc.strerror})", file=path) from None
    if not raw.strip():
        raise InputError("file is empty", file=path, line=1,
                         expected="a header row followed by data rows")
    for enc in ("utf-8-sig", "cp1252", "latin-1"):
        try:
            text = raw.decode(enc)
            break
        except UnicodeDecodeError:
            continue
    return _fix_mojibake(text).splitlines()


def _floats(tokens: Sequence[str], lines: Sequence[int], *, path: Path, key: str,
            decimal: str = ".", allow_blank: bool = True) -> np.ndarray:
    """Convert one column of cells to floats, naming the first bad cell's line on failure."""
    toks = [t.strip() for t in tokens]
    if decimal == ",":
        toks = [t.replace(",", ".") for t in toks]
    if allow_blank:
        toks = [t if t else "nan" for t in toks]
    try:
        arr = np.array(toks, dtype=float)
    except ValueError:
        arr = None
    if arr is not None and not np.any(np.isinf(arr)):
        if not allow_blank and np.any(np.isnan(arr)):
            i = int(np.flatnonzero(np.isnan(arr))[0])
            raise InputError(f"value {tokens[i]!r} is not a number", file=path, line=lines[i],
                             key=key, expected="a number")
        return arr
    num = _NUM_COMMA if decimal == "," else _NUM_POINT
    for i, t in enumerate(tokens):
        s = t.strip()
        if not (num.match(s) or (allow_blank and s == "")):
            raise InputError(f"value {t!r} is not a number", file=path, line=lines[i], key=key,
                             expected="a number" + (" with a decimal comma" if decimal == "," else ""))
    raise InputError("values are not finite numbers", file=path, line=lines[0], key=key,
                     expected="finite numbers")  # pragma: no cover - inf spelled as number


def _parse_datetimes(cells: Sequence[str], lines: Sequence[int], *, path: Path, key: str,
                     dayfirst: bool | None) -> np.ndarray:
    """Parse date-time cells (several spellings) into ``datetime64[ms]``.

    Accepted: ``yyyy-mm-dd hh:mm[:ss[.fff]]`` (also ``/``, ``.``, ``T``), ``dd-mm-yyyy ...`` or
    ``mm-dd-yyyy ...`` (decided by ``dayfirst``, else by any day > 12 in the data, else an
    error), and the cementing unit's ``mm:dd:yyyy:hh:mm:ss`` (pass ``dayfirst=False``).
    """
    import pandas as pd

    ser = pd.Series(list(cells), dtype=object).astype(str)
    parts = ser.str.extract(_DT_RE)
    bad = parts["a"].isna().to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{cells[i]!r} is not a date and time", file=path, line=lines[i],
                         key=key, expected="a timestamp like 2023-12-10 14:42:58, "
                                           "10-12-2023 14:42:58 or 12:10:2023:14:42:58")
    a = parts["a"].to_numpy(dtype=str)
    la = np.char.str_len(a)
    b = parts["b"].astype(int).to_numpy()
    c = parts["c"].to_numpy(dtype=str)
    ai = a.astype(int)
    ci = c.astype(int)
    if np.all(la == 4):
        year, month, day = ai, b, ci
    elif np.all(np.char.str_len(c) == 4):
        if dayfirst is None:
            if np.any(ai > 12):
                dayfirst = True
            elif np.any(b > 12):
                dayfirst = False
            else:
                raise InputError("dates are ambiguous (day and month both <= 12 everywhere)",
                                 file=path, line=lines[0], key=key,
                                 expected="dayfirst=True or dayfirst=False")
        year = ci
        day, month = (ai, b) if dayfirst else (b, ai)
    else:
        i = int(np.flatnonzero((la != 4) & (np.char.str_len(c) != 4))[0]) if np.any(
            (la != 4) & (np.char.str_len(c) != 4)) else 0
        raise InputError(f"{cells[i]!r}: mixed or two-digit year date formats", file=path,
                         line=lines[i], key=key, expected="a four-digit year, one date format")
    sec = parts["S"].fillna("0").str.replace(",", ".", regex=False).astype(float).to_numpy()
    frame = pd.DataFrame({"year": year, "month": month, "day": day,
                          "hour": parts["H"].astype(int).to_numpy(),
                          "minute": parts["M"].astype(int).to_numpy(),
                          "second": np.floor(sec).astype(int)})
    ts = pd.to_datetime(frame, errors="coerce")
    nat = ts.isna().to_numpy()
    if nat.any():
        i = int(np.flatnonzero(nat)[0])
        raise InputError(f"{cells[i]!r} is not a valid date and time", file=path, line=lines[i],
                         key=key, expected="a real calendar date" +
                         (" (day first)" if dayfirst else " (month first)" if dayfirst is False else ""))
    out = ts.to_numpy().astype("datetime64[ms]")
    frac = np.round((sec - np.floor(sec)) * 1000.0).astype("int64").astype("timedelta64[ms]")
    return out + frac


def _elapsed_from_stamps(stamps: np.ndarray, lines: Sequence[int], *, path: Path,
                         key: str) -> tuple[np.ndarray, datetime, int]:
    """Elapsed seconds from timestamps; same-second rows spread inside their second.

    Returns ``(t, start_time, n_spread)``.
    """
    ms = (stamps - stamps[0]).astype("timedelta64[ms]").astype(np.int64)
    d = np.diff(ms)
    if np.any(d < 0):
        i = int(np.flatnonzero(d < 0)[0]) + 1
        raise InputError("time goes backwards", file=path, line=lines[i], key=key,
                         expected="timestamps that never decrease")
    t = ms.astype(float) / 1000.0
    n_spread = 0
    if np.any(d == 0):
        if np.any(ms % 1000):
            i = int(np.flatnonzero(d == 0)[0]) + 1
            raise InputError("repeated sub-second timestamp", file=path, line=lines[i], key=key,
                             expected="strictly increasing time")
        # rows sharing a whole-second stamp: spread k/m s inside that second
        start = np.r_[True, d != 0]
        group = np.cumsum(start) - 1
        first = np.flatnonzero(start)
        counts = np.bincount(group)
        k = np.arange(t.size) - first[group]
        t = t + k / counts[group]
        n_spread = int(np.sum(counts[counts > 1]))
    start_time = stamps[0].astype("datetime64[ms]").astype(datetime)
    return t, start_time, n_spread


def _make_continuous(v: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """Remove totaliser resets from a cumulative series.

    A reset is a fall by more than three times the column's resolution (its smallest
    non-zero step) to less than half the previous value; jitter of a few counts is left
    alone. Everything after a reset gets the value before the reset added.

    Returns ``(continuous, reset_indices)``.
    """
    if v.size < 2:
        return v, []
    d = np.diff(v)
    steps = np.abs(d[np.isfinite(d) & (d != 0)])
    res = float(steps.min()) if steps.size else 0.0
    prev, cur = v[:-1], v[1:]
    is_reset = (d < -3.0 * res) & (cur < 0.5 * prev) & np.isfinite(d)
    idx = np.flatnonzero(is_reset) + 1
    if idx.size == 0:
        return v, []
    add = np.zeros_like(v)
    for i in idx:
        add[i:] += v[i - 1]
    return v + add, [int(i) for i in idx]


# ====================================================================== column mapping
@dataclass
class _RawTable:
    """What a format parser hands to :func:`_assemble`: cells as text plus provenance."""

    path: Path
    names: list[str]
    units: list[str]
    cells: list[list[str]]           # per column, the cell text of every data row
    lines: list[int]                 # file line of every data row
    header_line: int
    decimal: str = "."
    events: list[tuple[int, str, str]] | None = None   # (line, time cell, text)
    meta: dict[str, Any] | None = None
    reference: PressureReference | None = None
    dayfirst: bool | None = None
    timestamp_col: int | None = None  # column known to hold timestamps
    canonical: bool = False
    make_continuous: bool = True


def _user_lookup(mapping: Mapping[str, str] | None, name: str) -> str | None:
    if not mapping:
        return None
    if name in mapping:
        return mapping[name]
    n = _norm_name(name)
    for k, v in mapping.items():
        if _norm_name(k) == n:
            return v
    return None


def _check_field_name(field: str, path: Path, key: str) -> None:
    ok = field in _FIELD_KIND or field in ("timestamp", "date", "") or (
        field.startswith("channel:") and len(field) > len("channel:"))
    if not ok:
        raise InputError(f"column_map maps to unknown field {field!r}", file=path, key=key,
                         expected="pressure, rate, volume, return_rate, return_volume, density, "
                                  "temperature, time, timestamp, channel:NAME or ''")


def _assemble(tab: _RawTable, *, column_map: Mapping[str, str] | None,
              units: Mapping[str, str] | None, reference: PressureReference | None,
              dayfirst: bool | None) -> Record:
    """Map columns to fields, convert units, build the time base and the record."""
    path = tab.path
    src = path.name
    ncol = len(tab.names)
    if not tab.lines:
        raise InputError("no data rows", file=path, line=tab.header_line,
                         expected="data rows after the header")
    if user_units := units:
        for k in user_units:
            if not any(k == n or _norm_name(k) == _norm_name(n) for n in tab.names):
                raise InputError(f"units= names a column {k!r} that is not in the file",
                                 file=path, key=k, expected=f"one of {tab.names}")
    if column_map:
        for k in column_map:
            if not any(k == n or _norm_name(k) == _norm_name(n) for n in tab.names):
                raise InputError(f"column_map names a column {k!r} that is not in the file",
                                 file=path, key=k, expected=f"one of {tab.names}")

    # ---- decide the field of each column
    fields: list[str] = []
    unit_txt: list[str] = []
    for j, name in enumerate(tab.names):
        u_user = _user_lookup(user_units, name)
        u = u_user if u_user is not None else tab.units[j]
        unit_txt.append((u or "").strip())
        explicit = _user_lookup(column_map, name)
        if explicit is not None:
            _check_field_name(explicit, path, name)
            fields.append(explicit)
        elif tab.canonical:
            canon = {title: f for f, title, _ in CANON_COLUMNS}
            fields.append("time" if name == "time" else canon.get(name, "channel:" + name))
        else:
            fields.append(_KNOWN_NAMES.get(_norm_name(name), "?"))
    if tab.timestamp_col is not None and fields[tab.timestamp_col] in ("?", "time"):
        fields[tab.timestamp_col] = "timestamp"

    # a "time" column whose cells are dates is a timestamp column
    for j, f in enumerate(fields):
        if f == "time":
            sample = [c for c in tab.cells[j][:20] if c.strip()]
            if sample and all(_DT_RX.match(c) for c in sample):
                fields[j] = "timestamp"
            elif sample and all(_TIME_OF_DAY.match(c) for c in sample) and "date" in fields:
                fields[j] = "timeofday"
    # no time column named: a first column of dates is the timestamp
    if not any(f in ("time", "timestamp") for f in fields):
        sample = [c for c in tab.cells[0][:20] if c.strip()] if ncol else []
        if sample and all(_DT_RX.match(c) for c in sample) and fields[0] in ("?", "date"):
            fields[0] = "timestamp"

    # first column claiming a field wins; later ones become channels
    taken: set[str] = set()
    final: list[str] = []
    for j, f in enumerate(fields):
        if f in _FIELD_KIND or f == "timestamp":
            if f in taken:
                f = "channel:" + _sanitize(tab.names[j])
            taken.add(f)
        final.append(f)
    if "time" in taken and "timestamp" in taken:
        # the timestamp gives the clock; an elapsed column beside it is redundant
        final = ["" if f == "time" else f for f in final]
        taken.discard("time")

    # ---- time base
    meta = dict(tab.meta or {})
    keep = np.ones(len(tab.lines), dtype=bool)
    start_time: datetime | None = None
    if "timestamp" in taken or "timeofday" in final:
        if "timeofday" in final:
            jd, jt = final.index("date"), final.index("timeofday")
            cells = [f"{a.strip()} {b.strip()}" for a, b in zip(tab.cells[jd], tab.cells[jt])]
            key = f"{tab.names[jd]} + {tab.names[jt]}"
            final[jd], final[jt] = "timestamp", "timestamp"
        else:
            jt = final.index("timestamp")
            cells, key = tab.cells[jt], tab.names[jt]
        stamps = _parse_datetimes(cells, tab.lines, path=path, key=key,
                                  dayfirst=tab.dayfirst if dayfirst is None else dayfirst)
        t, start_time, n_spread = _elapsed_from_stamps(stamps, tab.lines, path=path, key=key)
        if n_spread:
            meta["same_second_rows_spread"] = n_spread
    elif "time" in taken:
        jt = final.index("time")
        key = tab.names[jt]
        if _blank_unit(unit_txt[jt]):
            raise InputError("the time column has no unit", file=path, line=tab.header_line,
                             key=key, expected="e.g. 'time (s)' in the header or units={%r: 's'}"
                                               % key)
        pu = _unit(unit_txt[jt], "time", path, tab.header_line, key)
        raw_t = _floats(tab.cells[jt], tab.lines, path=path, key=key, decimal=tab.decimal,
                        allow_blank=False)
        t = to_si(raw_t, pu)
        d = np.diff(t)
        if np.any(d < 0):
            i = int(np.flatnonzero(d < 0)[0]) + 1
            raise InputError("time goes backwards", file=path, line=tab.lines[i], key=key,
                             expected="increasing elapsed time")
        if np.any(d == 0):
            # repeated time: identical rows are dropped, conflicting ones are an error
            for i in np.flatnonzero(d == 0) + 1:
                same = all(tab.cells[j][i].strip() == tab.cells[j][i - 1].strip()
                           for j in range(ncol))
                if not same:
                    raise InputError("two different rows have the same time", file=path,
                                     line=tab.lines[i], key=key,
                                     expected="strictly increasing time")
                keep[i] = False
            meta["duplicate_rows_dropped"] = int((~keep).sum())
        if "start_time" in meta:
            start_time = meta.pop("start_time")
    else:
        raise InputError(f"no time column among {tab.names}", file=path, line=tab.header_line,
                         key="time", expected="a column named like 'time (s)' or a timestamp "
                                              "column, or column_map={...: 'time'}")

    # ---- values
    if "pressure" not in taken:
        raise InputError(f"no pressure column among {tab.names}", file=path,
                         line=tab.header_line, key="pressure",
                         expected="a column named like 'Pressure' or column_map={NAME: "
                                  "'pressure'}")
    series: dict[str, np.ndarray] = {}
    channels: dict[str, np.ndarray] = {}
    columns: list[ColumnInfo] = []
    absolute: bool | None = None
    for j, (name, f) in enumerate(zip(tab.names, final)):
        u = unit_txt[j]
        if f in ("timestamp", "time", "date", "timeofday"):
            columns.append(ColumnInfo(name, u, "time" if f in ("time",) else "timestamp"
                                      if f != "date" else "timestamp", src))
            continue
        if f == "":
            columns.append(ColumnInfo(name, u, "", src))
            continue
        if f == "?":
            # not a known name: keep as a channel if the unit says what it is
            if _blank_unit(u):
                columns.append(ColumnInfo(name, u, "", src))
                continue
            try:
                pu = _unit(u, None, path, tab.header_line, name)
            except InputError:
                columns.append(ColumnInfo(name, u, "", src))
                continue
            f = "channel:" + _sanitize(name)
        kind = _FIELD_KIND.get(f)
        if _blank_unit(u):
            if kind is None:
                # an explicitly mapped channel without unit: keep the numbers as they are
                pu = None
            else:
                raise InputError(f"column mapped to {f} has no unit", file=path,
                                 line=tab.header_line, key=name,
                                 expected=f"a {kind} unit in the header or units={{{name!r}: ...}}")
        else:
            pu = _unit(u, kind, path, tab.header_line, name)
        vals = _floats(tab.cells[j], tab.lines, path=path, key=name, decimal=tab.decimal,
                       allow_blank=(f != "pressure"))
        si = (vals if pu is None else _convert(vals, pu)) + 0.0   # + 0.0 turns "-0" into 0
        if f == "pressure" and pu is not None and pu.absolute is not None:
            absolute = pu.absolute
        if f.startswith("channel:"):
            cname = f[len("channel:"):]
            base, k = cname, 2
            while cname in channels:
                cname, k = f"{base}_{k}", k + 1
            channels[cname] = si
            f = "channel:" + cname
        else:
            series[f] = si
        columns.append(ColumnInfo(name, u, f, src))

    # ---- apply row filter (dropped duplicates)
    if not keep.all():
        t = t[keep]
        series = {k: v[keep] for k, v in series.items()}
        channels = {k: v[keep] for k, v in channels.items()}
    lines_kept = np.asarray(tab.lines)[keep]

    # ---- totaliser resets
    if tab.make_continuous:
        for f in ("volume", "return_volume"):
            if f in series:
                cont, resets = _make_continuous(series[f])
                if resets:
                    channels.setdefault(f + "_raw", series[f])
                    series[f] = cont
                    meta[f + "_resets_at_lines"] = [int(lines_kept[i]) for i in resets]

    # ---- reference
    ref = tab.reference or PressureReference("surface")
    if absolute is not None and not tab.canonical:
        ref = PressureReference(ref.kind, ref.depth_m, absolute)
    if reference is not None:
        ref = reference

    # ---- events
    events: list[Event] = []
    for line, cell, text in tab.events or []:
        if isinstance(cell, (int, float)):
            events.append(Event(float(cell), text, None, src, line))
            continue
        ts = _parse_datetimes([cell], [line], path=path, key="remark time",
                              dayfirst=tab.dayfirst if dayfirst is None else dayfirst)[0]
        et = float((ts - np.datetime64(start_time, "ms")).astype("timedelta64[ms]")
                   .astype(np.int64)) / 1000.0 if start_time is not None else float("nan")
        events.append(Event(et, text, ts.astype(datetime), src, line))
    events.extend(meta.pop("_events", []))

    meta.setdefault("kind", "csv")
    return Record(t=t, pressure=series.pop("pressure"), reference=ref, start_time=start_time,
                  rate=series.get("rate"), volume=series.get("volume"),
                  return_rate=series.get("return_rate"),
                  return_volume=series.get("return_volume"), density=series.get("density"),
                  temperature=series.get("temperature"), channels=channels,
                  events=tuple(events), columns=tuple(columns), sources=(str(path),),
                  meta=meta)


def _unit(text: str, kind: str | None, path: Path, line: int, key: str) -> ParsedUnit | None:
    """Parse a unit and check it measures ``kind``; ``"SI"`` means values are already SI."""
    if text.strip().upper() == "SI":
        return None
    pu = parse_unit(text, file=str(path), line=line, key=key)
    if kind is not None and not pu.is_a(kind):
        raise InputError(f"unit {text!r} is not a {kind} unit", file=path, line=line, key=key,
                         expected={"pressure": "bar, psi, kPa, MPa", "rate": "l/min, bpm, m3/s",
                                   "volume": "m3, l, bbl", "density": "sg, kg/m3, ppg",
                                   "temperature": "°C, °F, K", "time": "s, min, h"}[kind])
    return pu


def _convert(values: np.ndarray, pu: ParsedUnit | None) -> np.ndarray:
    return values if pu is None else to_si(values, pu)


# ====================================================================== format parsers
def _split_fields(line: str, sep: str) -> list[str]:
    f = [x.strip() for x in line.split(sep)]
    while f and f[-1] == "":
        f.pop()
    return f


def _parse_cementing(path: Path, lines: list[str]) -> _RawTable:
    header: list[str] | None = None
    units: list[str] = []
    header_line = 0
    perm: list[int] | None = None      # block column order -> first-header order
    awaiting_units = False
    rows: list[list[str]] = []
    row_lines: list[int] = []
    stamps: list[str] = []
    events: list[tuple[int, str, str]] = []
    blocks = 0
    for i, raw in enumerate(lines, 1):
        if not raw.strip():
            continue
        f = _split_fields(raw, "\t")
        first = f[0]
        if _CU_TS.match(first):
            if header is None:
                raise InputError("data before the header row", file=path, line=i,
                                 expected="a header row 'Time<TAB>Treating Pressure...'")
            awaiting_units = False
            vals = f[1:]
            if not vals:
                continue  # a bare timestamp carries nothing
            if not _is_number(vals[0]):
                if len(vals) == 1:
                    events.append((i, first, vals[0]))
                    continue
                raise InputError(f"value {vals[0]!r} is not a number", file=path, line=i,
                                 key=header[1], expected="a number, or a remark alone on its row")
            if len(vals) != len(header) - 1:
                raise InputError(f"row has {len(vals)} values, the header has {len(header) - 1}",
                                 file=path, line=i, expected=f"{len(header) - 1} values")
            if perm is not None:
                vals = [vals[k] for k in perm]
            rows.append(vals)
            row_lines.append(i)
            stamps.append(first)
        elif first.lower().startswith("mm:dd") or (awaiting_units and not _is_number(first)
                                                   and not set(raw.strip()) <= set("_-=\t ")):
            if not awaiting_units:
                raise InputError("units row without a header row above it", file=path, line=i)
            new_units = f + [""] * (len(hdr_block) - len(f))
            if perm is None and blocks == 1:
                units = new_units
            awaiting_units = False
        elif set(raw.strip()) <= set("_-=\t "):
            continue
        elif header is None:
            header, header_line, hdr_block = f, i, f
            blocks = 1
            awaiting_units = True
        else:
            # a repeated header block: same columns, possibly reordered
            if set(f) != set(header) or len(f) != len(header):
                raise InputError(f"header changes the columns mid-file: {f}", file=path, line=i,
                                 expected=f"the columns of line {header_line}: {header}")
            hdr_block = f
            perm = None if f == header else [f.index(h) - 1 for h in header[1:]]
            blocks += 1
            awaiting_units = True
    if header is None:
        raise InputError("no header row", file=path, line=1,
                         expected="'Time<TAB>Treating Pressure<TAB>...' then a units row")
    if len(units) < len(header):
        units = units + [""] * (len(header) - len(units))
    ncol = len(header)
    cells = [stamps] + [[r[j] for r in rows] for j in range(ncol - 1)]
    meta = {"kind": "cementing_unit", "header_blocks": blocks}
    return _RawTable(path, list(header), ["" if j == 0 else units[j] for j in range(ncol)],
                     cells, row_lines, header_line, ".", events, meta,
                     PressureReference("surface", None, False), dayfirst=False, timestamp_col=0)


def _number_with_separators(text: str, decimal: str) -> float:
    """``"1.383"`` with a decimal comma file is 1383; ``"1,383.5"`` in a point file 1383.5."""
    s = text.strip()
    if decimal == ",":
        s = s.replace(".", "").replace(",", ".")
    else:
        s = s.replace(",", "")
    return float(s)


def _parse_gauge(path: Path, lines: list[str]) -> _RawTable:
    meta: dict[str, Any] = {"kind": "downhole_gauge"}
    preamble: dict[str, str] = {}
    hdr_i = None
    for i, raw in enumerate(lines[:60]):
        f = [x.strip() for x in raw.split("\t") if x.strip()]
        if not f:
            continue
        low = [x.lower() for x in f]
        if any(x.startswith("pressure") for x in low) and any("time" in x for x in low):
            hdr_i = i
            break
        k = 0
        while k < len(f):
            x = f[k]
            if x.endswith(":") and k + 1 < len(f) and not f[k + 1].endswith(":"):
                preamble[x[:-1].strip()] = f[k + 1]
                k += 2
                continue
            if ":" in x:
                a, b = x.split(":", 1)
                preamble[a.strip()] = b.strip()
            k += 1
    if hdr_i is None:
        raise InputError("no header row with Time and Pressure in the first 60 lines",
                         file=path, line=1, expected="'Time ... Pressure Temperature'")
    names = [x.strip() for x in lines[hdr_i].split("\t") if x.strip()]
    unit_i = hdr_i + 1
    unit_tokens = [x.strip() for x in lines[unit_i].split("\t") if x.strip()] \
        if unit_i < len(lines) else []
    if unit_tokens and any(_is_number(x) or _is_number(x, ",") for x in unit_tokens):
        unit_tokens, unit_i = [], hdr_i   # no units row
    # Units stand under the value columns, which are the last ones (timestamp and point
    # number have none); the export pads with empty cells, so align from the right.
    units = [""] * (len(names) - len(unit_tokens)) + unit_tokens
    if len(units) != len(names):
        raise InputError(f"units row has more entries than the header ({unit_tokens})",
                         file=path, line=unit_i + 1, expected=f"units for {names}")
    ts_col = next((j for j, n in enumerate(names) if _norm_name(n) in ("time", "date time",
                                                                        "timestamp")), None)
    rows, row_lines = [], []
    for i in range(unit_i + 1, len(lines)):
        raw = lines[i]
        if not raw.strip():
            continue
        f = [x.strip() for x in raw.split("\t") if x.strip()]
        if len(f) == len(names) + 1 and ts_col is not None and ts_col + 1 < len(f) \
                and _TIME_OF_DAY.match(f[ts_col + 1]):
            f[ts_col:ts_col + 2] = [f[ts_col] + " " + f[ts_col + 1]]   # date<TAB>time
        if len(f) != len(names):
            raise InputError(f"row has {len(f)} values, the header has {len(names)}",
                             file=path, line=i + 1, expected=f"values for {names}")
        rows.append(f)
        row_lines.append(i + 1)
    # decimal comma or point: judged from the value cells
    sample = [c for r in rows[:50] for j, c in enumerate(r) if j != ts_col]
    decimal = "," if any(_NUM_COMMA.match(c) for c in sample) and not any(
        re.match(r"^\s*-?\d+\.\d+\s*$", c) for c in sample) else "."
    cells = [[r[j] for r in rows] for j in range(len(names))]
    # preamble -> meta and reference
    for k, v in preamble.items():
        kl = k.lower()
        if kl == "well":
            meta["well"] = v
        elif kl == "gauge":
            meta["gauge_serial"] = v
        elif kl == "test":
            meta["test"] = v
        elif kl == "date":
            meta["date"] = v
        elif kl == "time":
            meta["start_clock"] = v
        elif kl == "position":
            meta["position"] = v
        elif kl == "no points":
            meta["declared_points"] = v
    meta["preamble"] = preamble
    depth = None
    pos = preamble.get("Position", "")
    m = re.search(r"depth\s*([\d.,]+)\s*(m|ft|feet)\b", pos, re.IGNORECASE)
    if m:
        depth = float(to_si([_number_with_separators(m.group(1), decimal)],
                            "ft" if m.group(2).lower() in ("ft", "feet") else "m")[0])
        meta["gauge_depth_m"] = depth
    if "declared_points" in meta:
        try:
            n_decl = int(re.sub(r"\D", "", meta["declared_points"]))
        except ValueError:
            n_decl = None
        if n_decl is not None and n_decl != len(rows):
            raise InputError(f"preamble declares {n_decl} points but the file has {len(rows)}"
                             " data rows (truncated or corrupted export?)", file=path,
                             line=row_lines[-1] if row_lines else hdr_i + 1, key="No Points",
                             expected=f"{n_decl} data rows")
        meta["declared_points"] = n_decl
    absolute = any("abs" in u.lower() for u in units)
    return _RawTable(path, names, units, cells, row_lines, hdr_i + 1, decimal, [], meta,
                     PressureReference("downhole", depth, absolute), dayfirst=True,
                     timestamp_col=ts_col, make_continuous=False)


def _sniff_delimiter(lines: Sequence[str], path: Path, first_line: int) -> str:
    for sep in ("\t", ";", ",", "|"):
        counts = [len(_split_fields(x, sep)) for x in lines if x.strip()]
        if counts and counts[0] > 1 and all(c == counts[0] for c in counts[: min(len(counts), 6)]):
            return sep
    # header and data may disagree (e.g. trailing columns left blank): take the commonest
    for sep in ("\t", ";", ","):
        if all(len(_split_fields(x, sep)) > 1 for x in lines[:6] if x.strip()):
            return sep
    raise InputError("cannot tell the column separator", file=path, line=first_line,
                     expected="comma, semicolon, tab or '|' separated columns")


def _parse_csv(path: Path, lines: list[str]) -> _RawTable:
    meta: dict[str, Any] = {"kind": "csv"}
    events_canon: list[Event] = []
    canonical = False
    ref = None
    body: list[tuple[int, str]] = []
    for i, raw in enumerate(lines, 1):
        s = raw.strip()
        if not s:
            continue
        if s.startswith("#"):
            m = re.match(r"#\s*([A-Za-z_][\w.\-]*)\s*:\s?(.*)$", s)
            if m:
                k, v = m.group(1), m.group(2).strip()
                if k == CANON_MAGIC:
                    canonical = True
                    meta["canonical_version"] = v
                elif canonical:
                    ref = _canon_key(path, i, k, v, meta, events_canon, ref)
                else:
                    meta.setdefault("comments", {})[k] = v
            continue
        body.append((i, raw))
    if not body:
        raise InputError("file has no header row or data", file=path, line=len(lines) or 1,
                         expected="a header row followed by data rows")
    sample = [x for _, x in body[:8]]
    sep = _sniff_delimiter(sample, path, body[0][0])
    header_line, header = body[0][0], _split_fields(body[0][1], sep)
    names, units = [], []
    for h in header:
        m = _UNIT_IN_NAME.match(h)
        if m and m.group("name"):
            names.append(m.group("name").strip())
            units.append(m.group("unit").strip())
        else:
            names.append(h)
            units.append("")
    if any(n == "" for n in names):
        j = names.index("")
        raise InputError(f"header column {j + 1} has no name", file=path, line=header_line,
                         expected="a name for every column")
    ncol = len(names)
    k = 1
    # optional units row: no cell is a number or a date; then optional underscore row
    if k < len(body):
        f = _split_fields(body[k][1], sep)
        if f and not any(_is_number(c) or _is_number(c, ",") or _DT_RX.match(c)
                         or _TIME_OF_DAY.match(c) for c in f if c) \
                and not set(body[k][1].strip()) <= set("_-=\t ;,|"):
            for j, u in enumerate(f[:ncol]):
                if u:
                    units[j] = u
            k += 1
    if k < len(body) and set(body[k][1].strip()) <= set("_-=\t ;,|"):
        k += 1
    data = body[k:]
    # decimal comma: only possible when the separator is not a comma
    decimal = "."
    if sep != ",":
        sample_cells = [c for _, x in data[:50] for c in _split_fields(x, sep)]
        if any(_NUM_COMMA.match(c) for c in sample_cells) and not any(
                re.match(r"^\s*-?\d+\.\d+\s*$", c) for c in sample_cells):
            decimal = ","
    rows, row_lines, events = [], [], []
    # the first value column (after a leading time column) may hold a remark
    for i, raw in data:
        f = _split_fields(raw, sep)
        if len(f) > ncol:
            raise InputError(f"row has {len(f)} values, the header has {ncol}", file=path,
                             line=i, expected=f"{ncol} values")
        if len(f) >= 2 and not _is_number(f[1], decimal) and f[1] and all(
                c == "" for c in f[2:]) and ncol > 2 and not canonical:
            events.append((i, f[0], f[1]))
            continue
        if len(f) < ncol:
            raise InputError(f"row has {len(f)} values, the header has {ncol}", file=path,
                             line=i, expected=f"{ncol} values")
        rows.append(f)
        row_lines.append(i)
    cells = [[r[j] for r in rows] for j in range(ncol)]
    tab = _RawTable(path, names, units, cells, row_lines, header_line, decimal, [], meta, ref,
                    canonical=canonical, make_continuous=not canonical)
    # remark times: elapsed numbers or timestamps, resolved after the time base is known
    tab.events = [(ln, c, txt) for ln, c, txt in events if _DT_RX.match(c)]
    elapsed_events = [(ln, c, txt) for ln, c, txt in events if not _DT_RX.match(c)]
    if elapsed_events:
        meta["_elapsed_events"] = elapsed_events
    if events_canon:
        meta["_events"] = events_canon
    return tab


def _canon_key(path: Path, line: int, k: str, v: str, meta: dict[str, Any],
               events: list[Event], ref: PressureReference | None) -> PressureReference | None:
    """Interpret one ``# key: value`` line of the canonical layout."""
    ref = ref or PressureReference()
    try:
        if k == "reference":
            return PressureReference(v, ref.depth_m, ref.absolute)  # type: ignore[arg-type]
        if k == "depth_m":
            return PressureReference(ref.kind, None if v in ("", "none") else float(v),
                                     ref.absolute)
        if k == "absolute":
            return PressureReference(ref.kind, ref.depth_m, v.lower() == "true")
        if k == "start_time":
            meta["start_time"] = None if v in ("", "none") else datetime.fromisoformat(v)
        elif k == "source":
            meta.setdefault("derived_from", []).append(v)
        elif k == "event":
            d = json.loads(v)
            ts = d.get("timestamp")
            events.append(Event(float(d["t"]), str(d["text"]),
                                datetime.fromisoformat(ts) if ts else None,
                                str(d.get("source", "")), int(d.get("line", 0))))
        elif k.startswith("meta."):
            meta[k[5:]] = json.loads(v)
        else:
            meta.setdefault("comments", {})[k] = v
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"bad value {v!r} ({exc})", file=path, line=line, key=k,
                         expected="the value written by write_log") from None
    return ref


def _detect_kind(lines: Sequence[str]) -> str:
    head = [x for x in lines[:40] if x.strip()]
    for x in head:
        s = x.strip()
        if s.startswith(("Well:", "No Points", "Gauge:")) or "psi absolute" in s.lower() \
                or s.startswith("Point No."):
            return "downhole_gauge"
    for x in head:
        first = x.split("\t")[0].strip()
        if first.lower().startswith("mm:dd:yyyy") or (_CU_TS.match(first) and "\t" in x):
            return "cementing_unit"
    return "csv"


# ====================================================================== public readers
def read_log(path: str | os.PathLike, *, kind: str = "auto",
             column_map: Mapping[str, str] | None = None, units: Mapping[str, str] | None = None,
             reference: PressureReference | None = None,
             dayfirst: bool | None = None) -> Record:
    """Read one field log into a :class:`~xlotkit.record.Record` (SI units).

    Parameters
    ----------
    path : str or path-like
        The log file.
    kind : {"auto", "cementing_unit", "downhole_gauge", "csv"}
        File family; ``"auto"`` recognises it from the content.
    column_map : mapping of str to str, optional
        Original column name -> ``"pressure"``, ``"rate"``, ``"volume"``, ``"return_rate"``,
        ``"return_volume"``, ``"density"``, ``"temperature"``, ``"time"``, ``"timestamp"``,
        ``"channel:NAME"`` or ``""`` (ignore). Needed only for names not understood
        automatically (``"Treating Pressure"``, ``"Flow Rate"``, ``"RETURN VOL"`` ... are).
    units : mapping of str to str, optional
        Column name -> unit spelling (``"bar"``, ``"psi absolute"``, ``"bpm"``); fills in or
        overrides the units found in the file.
    reference : PressureReference, optional
        Where the pressure was measured; overrides what is inferred (cementing unit: surface,
        gauge pressure; downhole gauge: downhole at the preamble depth, absolute for ``psi
        absolute``; CSV: surface, absolute if the unit says so).
    dayfirst : bool, optional
        For ambiguous ``nn/nn/yyyy`` dates in CSV files; inferred when some day is > 12.

    Returns
    -------
    Record
        ``t`` [s] from the first sample, ``start_time`` when the file has clock times,
        ``pressure`` [Pa], optional ``rate`` [m^3/s], ``volume`` [m^3] (continuous across
        totaliser resets), ``return_rate``, ``return_volume``, ``density`` [kg/m^3],
        ``temperature`` [K]; other understood columns in ``channels``; remarks in ``events``;
        every column's provenance in ``columns``; preamble items in ``meta``.

    Raises
    ------
    InputError
        For an empty or malformed file, a missing pressure or time column, a unit that is
        not understood or not of the column's kind, or time that goes backwards; the message
        names the file, the line and the column.
    """
    p = Path(path)
    if kind not in ("auto", "cementing_unit", "downhole_gauge", "csv"):
        raise InputError(f"unknown kind {kind!r}", file=p, key="kind",
                         expected="auto, cementing_unit, downhole_gauge or csv")
    lines = _read_text(p)
    k = _detect_kind(lines) if kind == "auto" else kind
    if k == "cementing_unit":
        tab = _parse_cementing(p, lines)
    elif k == "downhole_gauge":
        tab = _parse_gauge(p, lines)
    else:
        tab = _parse_csv(p, lines)
    elapsed_events = (tab.meta or {}).pop("_elapsed_events", [])
    rec = _assemble(tab, column_map=column_map, units=units, reference=reference,
                    dayfirst=dayfirst)
    if elapsed_events:
        rec = _add_elapsed_events(rec, tab, elapsed_events, units)
    return rec


def _add_elapsed_events(rec: Record, tab: _RawTable, events: list[tuple[int, str, str]],
                        units: Mapping[str, str] | None) -> Record:
    """Remarks in a CSV with an elapsed-time column: their time cell is in the time unit."""
    tcol = next((c for c in rec.columns if c.field == "time"), None)
    if tcol is None:
        raise InputError("remark row in a file without an elapsed time column", file=tab.path,
                         line=events[0][0], expected="numbers in every column")
    out = list(rec.events)
    for line, cell, text in events:
        v = _floats([cell], [line], path=tab.path, key=tcol.name, decimal=tab.decimal,
                    allow_blank=False)
        out.append(Event(float(to_si(v, tcol.unit)[0]), text, None, tab.path.name, line))
    return rec.replace(events=tuple(out))


def read_logs(paths: Iterable[str | os.PathLike], *, offset_s: float | None = None,
              max_offset_s: float = 4 * 3600.0, **kw: Any) -> Record:
    """Read several logs of one test; a surface + downhole pair is merged.

    Parameters
    ----------
    paths : iterable of path-like
        One file, or a cementing-unit (surface) file and a downhole-gauge file.
    offset_s : float, optional
        Clock offset [s] to apply instead of estimating it (see
        :func:`merge_surface_downhole`).
    max_offset_s : float
        Largest clock offset searched [s].
    **kw
        Passed to :func:`read_log` for every file.

    Returns
    -------
    Record
        The single record, or the merged one.
    """
    recs = [read_log(p, **kw) for p in paths]
    if len(recs) == 1:
        return recs[0]
    if len(recs) == 2:
        kinds = [r.reference.kind for r in recs]
        if sorted(kinds) == ["downhole", "surface"]:
            s, d = (recs[0], recs[1]) if kinds[0] == "surface" else (recs[1], recs[0])
            return merge_surface_downhole(s, d, max_offset_s=max_offset_s, offset_s=offset_s)[0]
    raise InputError(f"cannot combine {len(recs)} records with references "
                     f"{[r.reference.kind for r in recs]}", key="paths",
                     expected="one file, or one surface and one downhole file of the same test")


# ====================================================================== clock alignment
@dataclass(frozen=True)
class ClockOffset:
    """Clock offset between a surface and a downhole logger.

    Attributes
    ----------
    offset_s : float
        Seconds to add to a downhole-clock time to get the surface-clock time of the same
        instant [s].
    correlation : float
        Normalised cross-correlation of the two pressure-rate signals at ``offset_s``
        (1 = identical shape); NaN when the offset was given, not estimated.
    uncertainty_s : float
        One-sigma uncertainty of ``offset_s`` [s]: scatter of the offsets found in separate
        parts of the overlap combined with the grid quantisation.
    method : str
        How the offset was obtained.
    second_peak : float
        Highest correlation at a lag more than ``exclusion_s`` from the best one; close to
        ``correlation`` means an ambiguous match.
    exclusion_s : float
        Half-width of the lag window around the best peak excluded for ``second_peak`` [s].
    overlap_s : float
        Length of the overlap of the two records at ``offset_s`` [s].
    """

    offset_s: float
    correlation: float
    uncertainty_s: float
    method: str
    second_peak: float = float("nan")
    exclusion_s: float = float("nan")
    overlap_s: float = float("nan")


def _clock_axis(rec: Record, origin: datetime | None) -> np.ndarray:
    """Sample times [s] relative to ``origin`` on the record's own clock."""
    if rec.start_time is None or origin is None:
        return rec.t.copy()
    return rec.t + (rec.start_time - origin).total_seconds()


def _bin_signal(x: np.ndarray, y: np.ndarray, x0: float, dt: float, n: int) -> tuple[np.ndarray,
                                                                                     np.ndarray]:
    """Bin-average ``y(x)`` onto the grid ``x0 + dt*k``; returns values and a valid mask.

    Averaging (not point sampling) keeps the faster logger from aliasing; grid cells
    without samples are filled linearly but marked invalid when the gap exceeds 3 cells.
    """
    k = np.floor((x - x0) / dt).astype(np.int64)
    ok = (k >= 0) & (k < n) & np.isfinite(y)
    s = np.bincount(k[ok], weights=y[ok], minlength=n)
    c = np.bincount(k[ok], minlength=n)
    have = c > 0
    out = np.zeros(n)
    out[have] = s[have] / c[have]
    valid = have.copy()
    if have.sum() >= 2:
        idx = np.flatnonzero(have)
        out[~have] = np.interp(np.flatnonzero(~have), idx, out[have])
        gaps = np.diff(idx)
        for a, g in zip(idx[:-1], gaps):
            if 1 < g <= 4:
                valid[a + 1:a + g] = True
        valid[: idx[0]] = False
        valid[idx[-1] + 1:] = False
    return out, valid


def _feature(p: np.ndarray, valid: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Pressure-change signal used for matching: robust-scaled, soft-clipped dp/dt.

    Differencing removes the hydrostatic head and the absolute/gauge offset between the
    gauges; scaling by the median absolute change and a tanh clip keeps a few pump starts
    or spikes from dominating the correlation.
    """
    # difference over +-w cells (~10 s): the surface gauge reads whole bars, so one-step
    # differences are mostly quantisation noise
    w = max(1, int(round(5.0 / dt)))
    d = np.zeros(p.size - 1)
    v = np.zeros(p.size - 1, dtype=bool)
    d[w - 1: p.size - 1 - w + 1] = (p[2 * w - 1:] - p[: p.size - 2 * w + 1]) / (dt * (2 * w - 1))
    vv = np.convolve(valid.astype(float), np.ones(2 * w), mode="valid") == 2 * w
    v[w - 1: w - 1 + vv.size] = vv
    d = np.where(v, d, 0.0)
    scale = np.median(np.abs(d[v])) if v.any() else 1.0
    hi = np.percentile(np.abs(d[v]), 99.0) if v.any() else 1.0
    scale = max(scale, hi / 50.0, 1e-12)
    f = np.tanh(d / (20.0 * scale))
    f = np.where(v, f, 0.0)
    return f, v


def _ncc(a: np.ndarray, va: np.ndarray, b: np.ndarray, vb: np.ndarray,
         max_lag: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Masked normalised cross-correlation ``c[L] = corr(a[k], b[k - L])`` for |L| <= max_lag.

    Returns ``(lags, c, n_overlap)``; each lag's value is the Pearson correlation over the
    cells valid in both signals.
    """
    from scipy.signal import fftconvolve

    a = np.where(va, a, 0.0)
    b = np.where(vb, b, 0.0)
    ma, mb = va.astype(float), vb.astype(float)

    def xc(x, y):
        # full cross-correlation sum_k x[k] y[k-L]; index L + len(y) - 1
        return fftconvolve(x, y[::-1], mode="full")

    n_ab = xc(ma, mb)
    s_ab = xc(a, b)
    s_a = xc(a, mb)
    s_b = xc(ma, b)
    s_aa = xc(a * a, mb)
    s_bb = xc(ma, b * b)
    lags = np.arange(-(b.size - 1), a.size)
    sel = np.abs(lags) <= max_lag
    lags, n_ab, s_ab, s_a, s_b, s_aa, s_bb = (x[sel] for x in (lags, n_ab, s_ab, s_a, s_b,
                                                                 s_aa, s_bb))
    n = np.round(n_ab)
    with np.errstate(invalid="ignore", divide="ignore"):
        cov = s_ab - s_a * s_b / n
        va_ = s_aa - s_a ** 2 / n
        vb_ = s_bb - s_b ** 2 / n
        c = cov / np.sqrt(va_ * vb_)
    c[~np.isfinite(c) | (n < 3)] = np.nan
    return lags, c, n


def _best_lag(lags: np.ndarray, c: np.ndarray, ok: np.ndarray) -> tuple[float, float, int]:
    """Highest correlation among ``ok`` lags, refined by a parabola through 3 points."""
    cc = np.where(ok, c, -np.inf)
    i = int(np.argmax(cc))
    best = float(cc[i])
    frac = 0.0
    if 0 < i < cc.size - 1 and np.isfinite(cc[i - 1]) and np.isfinite(cc[i + 1]):
        den = cc[i - 1] - 2 * cc[i] + cc[i + 1]
        if den < 0:
            frac = float(np.clip(0.5 * (cc[i - 1] - cc[i + 1]) / den, -0.5, 0.5))
    return float(lags[i]) + frac, best, i


def estimate_clock_offset(surface: Record, downhole: Record, *, max_offset_s: float = 4 * 3600.0,
                          dt: float = 3.0, min_overlap_s: float = 1800.0) -> ClockOffset:
    """Estimate the clock offset between a surface and a downhole pressure record.

    Both pressures are bin-averaged onto a common ``dt`` grid (times relative to the surface
    ``start_time``, each record on its own clock), differenced, robust-scaled and clipped,
    then cross-correlated (masked, normalised) over lags up to ``max_offset_s``. The best lag
    is refined by a parabola; the search is then repeated on a 1 s grid around it, and on
    separate quarters of the overlap to estimate the uncertainty.

    Parameters
    ----------
    surface, downhole : Record
        Records of the same test; ``start_time`` of each on its own clock (if either lacks
        one, their ``t`` axes are compared directly).
    max_offset_s : float
        Largest offset searched [s].
    dt : float
        Coarse grid step [s] (the downhole gauge samples every 3 s in AMS-01).
    min_overlap_s : float
        Lags with a shorter overlap of valid samples are not considered [s] (capped at 80 %
        of the shorter record).

    Returns
    -------
    ClockOffset
        ``surface clock = downhole clock + offset_s``.

    Raises
    ------
    InputError
        If the records do not overlap at any lag within ``max_offset_s``.
    """
    origin = surface.start_time if (surface.start_time and downhole.start_time) else None
    xs = _clock_axis(surface, origin)
    xd = _clock_axis(downhole, origin)
    ps = surface.gauge_pressure()
    pd_ = downhole.gauge_pressure()

    def correlate(step: float, center: float, half: float, xs_, ps_, xd_, pd_v):
        # grid covering both (downhole shifted by `center`), lags within +-half around it
        lo = min(xs_[0], xd_[0] + center)
        hi = max(xs_[-1], xd_[-1] + center)
        n = int(np.ceil((hi - lo) / step)) + 2
        a, va = _bin_signal(xs_, ps_, lo, step, n)
        b, vb = _bin_signal(xd_ + center, pd_v, lo, step, n)
        fa, fva = _feature(a, va, step)
        fb, fvb = _feature(b, vb, step)
        lags, c, nn = _ncc(fa, fva, fb, fvb, int(np.ceil(half / step)))
        return lags * step + center, c, nn * step

    span = min(surface.duration, downhole.duration)
    need = min(min_overlap_s, 0.8 * span)
    lags, c, ov = correlate(dt, 0.0, max_offset_s, xs, ps, xd, pd_)
    ok = np.isfinite(c) & (ov >= need)
    if not ok.any():
        raise InputError("the surface and downhole records do not overlap within "
                         f"{max_offset_s:g} s of clock offset", key="max_offset_s",
                         expected="records of the same test (or a larger max_offset_s)")
    lag0, peak0, i0 = _best_lag(lags, c, ok)
    # ambiguity: best correlation outside the main peak (+- 10 min or 5 % of the span)
    excl = max(600.0, 0.05 * span)
    far = ok & (np.abs(lags - lags[i0]) > excl)
    second = float(np.nanmax(np.where(far, c, np.nan))) if far.any() else float("nan")
    # refine on a 1 s grid around the coarse peak
    fine = min(1.0, dt)
    lags1, c1, ov1 = correlate(fine, lags[i0], 3 * dt, xs, ps, xd, pd_)
    ok1 = np.isfinite(c1) & (ov1 >= need)
    lag, peak, _ = _best_lag(lags1, c1, ok1) if ok1.any() else (lag0, peak0, i0)
    # uncertainty: repeat in quarters of the overlap
    t0 = max(xs[0], xd[0] + lag)
    t1 = min(xs[-1], xd[-1] + lag)
    sub = []
    if t1 - t0 > 4 * 600.0:
        edges = np.linspace(t0, t1, 5)
        for a0, a1 in zip(edges[:-1], edges[1:]):
            ms = (xs >= a0) & (xs <= a1)
            md = (xd + lag >= a0 - 30 * dt) & (xd + lag <= a1 + 30 * dt)
            if ms.sum() < 20 or md.sum() < 20:
                continue
            try:
                l_, c_, o_ = correlate(fine, lag, 10 * dt, xs[ms], ps[ms], xd[md], pd_[md])
            except (ValueError, IndexError):
                continue
            okq = np.isfinite(c_) & (o_ >= 0.5 * (a1 - a0))
            if okq.any():
                lq, cq, _ = _best_lag(l_, c_, okq)
                if cq > 0.3:    # quarters without pressure changes carry no timing
                    sub.append(lq)
    quant = max(fine, float(np.median(np.diff(downhole.t))) if downhole.n > 1 else fine)
    unc = quant / math.sqrt(12.0)
    if len(sub) >= 2:
        unc = math.hypot(unc, float(np.std(sub, ddof=1)) / math.sqrt(len(sub)))
    return ClockOffset(offset_s=float(lag), correlation=float(peak), uncertainty_s=float(unc),
                       method=f"masked cross-correlation of scaled dp/dt, {dt:g} s grid refined "
                              f"on {fine:g} s, {len(sub)} sub-windows",
                       second_peak=second, exclusion_s=excl, overlap_s=float(t1 - t0))


def merge_surface_downhole(surface: Record, downhole: Record, *,
                           max_offset_s: float = 4 * 3600.0,
                           offset_s: float | None = None) -> tuple[Record, ClockOffset]:
    """Put a surface (cementing unit) and a downhole gauge record on one time base.

    Parameters
    ----------
    surface : Record
        Cementing-unit record: surface pressure, rate, volume, returns, density.
    downhole : Record
        Downhole gauge record: pressure at depth, temperature.
    max_offset_s : float
        Largest clock offset searched [s].
    offset_s : float, optional
        Known offset (surface clock = downhole clock + ``offset_s``) [s]; skips estimation.

    Returns
    -------
    merged : Record
        On the downhole samples that fall inside the surface record's span, times on the
        surface clock (``start_time`` = surface-clock time of the first kept sample).
        ``pressure`` and ``reference`` from the downhole gauge, ``temperature`` from the
        gauge; ``rate``, ``volume``, ``return_rate``, ``return_volume``, ``density`` and the
        surface channels linearly interpolated from the surface record; surface pressure in
        ``channels["surface_pressure"]``. Events of both files shifted onto the new base.
        ``meta["clock_offset_s"]`` and friends record the alignment.
    offset : ClockOffset
        The offset applied.

    Raises
    ------
    InputError
        If the records do not overlap once aligned.
    """
    if offset_s is None:
        off = estimate_clock_offset(surface, downhole, max_offset_s=max_offset_s)
    else:
        off = ClockOffset(float(offset_s), float("nan"), 0.0, "given")
    origin = surface.start_time if (surface.start_time and downhole.start_time) else None
    xs = _clock_axis(surface, origin)
    xd = _clock_axis(downhole, origin) + off.offset_s
    keep = (xd >= xs[0]) & (xd <= xs[-1])
    if keep.sum() < 2:
        raise InputError(f"the records do not overlap with a clock offset of {off.offset_s:g} s",
                         key="offset_s", expected="an offset that overlaps the two records")
    x = xd[keep]
    x0 = float(x[0])
    t = x - x0
    start = None if origin is None else origin + _td(x0)

    def on(y):
        return None if y is None else np.interp(x, xs, y)

    channels: dict[str, np.ndarray] = {"surface_pressure": np.interp(x, xs,
                                                                     surface.gauge_pressure())}
    for k, v in surface.channels.items():
        channels[k if k not in channels else "surface_" + k] = np.interp(x, xs, v)
    for k, v in downhole.channels.items():
        channels[k if k not in channels else "downhole_" + k] = v[keep]
    temperature = downhole.temperature[keep] if downhole.temperature is not None else None
    if temperature is None and surface.temperature is not None:
        temperature = on(surface.temperature)
    shift_s = (0.0 if origin is None else (surface.start_time - origin).total_seconds()) - x0
    shift_d = (0.0 if origin is None else (downhole.start_time - origin).total_seconds()) \
        + off.offset_s - x0
    events = [Event(e.t + shift_s, e.text, e.timestamp, e.source, e.line) for e in surface.events]
    events += [Event(e.t + shift_d, e.text, e.timestamp, e.source, e.line)
               for e in downhole.events]
    # provenance: the surface pressure column now feeds channel surface_pressure
    cols = [ColumnInfo(c.name, c.unit, "channel:surface_pressure" if c.field == "pressure"
                       else c.field, c.source) for c in surface.columns]
    cols += list(downhole.columns)
    gaps = np.diff(xs)
    big = np.flatnonzero(gaps > 30.0)
    meta: dict[str, Any] = {
        "kind": "merged",
        "clock": "surface (cementing unit) clock",
        "clock_offset_s": off.offset_s,
        "clock_offset_correlation": off.correlation,
        "clock_offset_uncertainty_s": off.uncertainty_s,
        "clock_offset_second_peak": off.second_peak,
        "clock_offset_method": off.method,
        "surface_gaps_interpolated": [(float(xs[i] - x0), float(gaps[i])) for i in big],
        "surface": dict(surface.meta),
        "downhole": dict(downhole.meta),
    }
    for k in ("well", "test", "gauge_serial", "gauge_depth_m"):
        for m in (downhole.meta, surface.meta):
            if k in m:
                meta.setdefault(k, m[k])
    merged = Record(t=t, pressure=downhole.pressure[keep], reference=downhole.reference,
                    start_time=start, rate=on(surface.rate), volume=on(surface.volume),
                    return_rate=on(surface.return_rate), return_volume=on(surface.return_volume),
                    density=on(surface.density), temperature=temperature, channels=channels,
                    events=tuple(events), columns=tuple(cols),
                    sources=tuple(surface.sources) + tuple(downhole.sources), meta=meta)
    return merged, off


def _td(seconds: float) -> timedelta:
    return timedelta(seconds=float(seconds))
