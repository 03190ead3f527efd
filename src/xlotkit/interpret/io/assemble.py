"""From a table of cells to a :class:`~xlotkit.record.Record`: roles, units, time, checks.

Documented choices
------------------
* Roles: ``--column ROLE=NAME`` first, then the Python API's ``column_map``, then the
  synonyms table (:mod:`.names`), then words in the title (``pressure``, ``rate``, ``vol``
  ...). The first column claiming a role wins; later ones become channels. When the file
  holds a bottom-hole and a surface pressure, the bottom-hole one is the record's pressure
  (reference downhole) and the surface one the channel ``surface_pressure``.
* Units: ``--unit ROLE=UNIT`` (or ``units=``) first, else the unit in the title and the one
  in the units row, which must agree (else the file is refused, naming both lines). A
  column playing a role without any unit is refused with the flag that supplies one.
* Numbers: blank cells and not-recorded markers (``-``, ``N/A``, ``*****`` ...) are missing
  (NaN, counted in :attr:`ColumnInfo.n_missing`). A pressure written as exactly 0 where it
  was not recorded is missing too: every 0 of an absolute pressure, and a run of zeros that
  ends in a jump to a recorded value of more than a quarter of the column's range while the
  pump runs (half the range when the record has no rate).
* Impossible values for their unit, in the columns that play a role (|p| > 5000 bar, a negative absolute pressure, a gauge
  pressure below vacuum, |q| > 2 m3/s, |V| > 1e5 m3, T outside 150-700 K, density outside
  0-5000 kg/m3, infinities): at most one cell in a thousand (and at most 10), each alone
  among plausible neighbours, is dropped (NaN, listed in :attr:`ColumnInfo.dropped` and in
  ``meta["notes"]``); more than that and the file is refused, naming the first cell and the
  unit flag.
* Remarks: a row whose first value cell holds text and whose other value cells are empty is
  an operator remark (an :class:`~xlotkit.record.Event` at the row's time), not data; so
  are the cells of a text column titled like ``Comment`` / ``Remarks``.
* Totaliser resets (a cumulative volume falling by more than three times its resolution to
  less than half its previous value) are removed by adding the value before the reset to
  everything after it; the raw column is kept as channel ``volume_raw`` /
  ``return_volume_raw``.
* Elapsed time is kept as written (``t`` starts where the file starts); two rows with the
  same elapsed time are dropped if identical and refused otherwise.
"""

from __future__ import annotations

import json
import re
from datetime import datetime, timedelta
from typing import Any

import numpy as np
import pandas as pd

from xlotkit.errors import InputError
from xlotkit.logfile import CANON_COLUMNS, CANON_MAGIC
from xlotkit.record import ATMOSPHERE_PA, ColumnInfo, Event, PressureReference, Record
from xlotkit.units import ParsedUnit, parse_unit, same_unit, to_si

from .cells import MISSING_MARKERS, cell_kind, numbers
from .names import ROLE_KIND, ReadOptions, norm_name, sanitize, synonym
from .table import Table
from .timebase import elapsed_from_stamps, parse_clock, parse_datetimes, preamble_date

__all__ = ["assemble", "column_roles"]

_BAR = 1e5
#: Plausible magnitudes by kind (SI): beyond these a value cannot be what its unit says.
_LIMITS = {"pressure": 5.0e8, "rate": 2.0, "volume": 1.0e5, "time": 1.0e9}
_TEMP_RANGE = (150.0, 700.0)
_DENSITY_RANGE = (0.0, 5000.0)
_TIME_KINDS = ("time", "timestamp", "date", "clock")
_IMPLIED_TIME_UNIT = {"seconds": "s", "elapsed seconds": "s", "minutes": "min", "hours": "h",
                      "sec": "s", "secs": "s", "min": "min", "mins": "min", "hrs": "h"}
# anything a number could be written as (remarks are the cells that are none of these)
_NUMBER_LIKE = (r"^\s*[-+]?(\d[\d.,']*|[.,]\d+)([eE][-+]?\d+)?\s*$|^\s*[-+]?(inf|infinity|nan)\s*$")
_REMARK_NAMES = {"comment", "comments", "remark", "remarks", "note", "notes", "event",
                 "events", "bemerkung", "opmerking", "description", "activity", "stage",
                 "operation", "status", "message"}


# ====================================================================== roles
def _fuzzy(name: str) -> str | None:
    words = set(norm_name(name).split())
    if not words:
        return None
    if words & {"pressure", "press", "pres", "druck", "druk", "pression", "presion"}:
        if words & {"return", "returns"}:
            return "channel:return_pressure"
        if words & {"annulus", "ann", "casing", "csg", "backside"}:
            return "channel:annulus_pressure"
        if words & {"bh", "bottomhole", "downhole", "dh", "bottom", "bhp", "gauge", "bohrloch",
                    "sohle", "fond", "fondo", "forage", "bunnhull", "gat", "zabojnoe"}:
            return "pressure@downhole"
        return "pressure"
    if words & {"rate", "flow", "flowrate", "debiet", "debit", "caudal"}:
        if words & {"return", "returns", "out", "flowback"}:
            return "return_rate"
        return "rate"
    if words & {"volume", "vol", "volumen"}:
        if words & {"return", "returns", "out", "flowback", "bled"}:
            return "return_volume"
        return "volume"
    if words & {"temperature", "temp"}:
        return "temperature"
    if words & {"density", "dens"}:
        return "density"
    if words & {"timestamp", "datetime"}:
        return "timestamp"
    if words & {"elapsed", "time", "tijd", "zeit"}:
        return "time"
    if words & _REMARK_NAMES:
        return "remarks"
    return None


def _content(series: pd.Series) -> str:
    """What a column's first cells hold: ``num``, ``datetime``, ``clock``, ``date``,
    ``text`` or ``empty``."""
    if series.dtype.kind in "fiub":
        return "num" if series.notna().any() else "empty"
    sample = [str(x).strip() for x in series.head(400) if isinstance(x, str) and x.strip()
              and x.strip().lower() not in MISSING_MARKERS]
    if not sample:
        return "empty" if not series.notna().any() else "num"
    kinds = [cell_kind(x) for x in sample[:60]]
    for k in ("datetime", "clock", "date"):
        if kinds.count(k) >= 0.6 * len(kinds):
            return k
    if sum(k in ("num", "numc") for k in kinds) >= 0.5 * len(kinds):
        return "num"
    return "text"


def column_roles(tab: Table, opts: ReadOptions) -> list[str]:
    """The field each column of ``tab`` plays (before its cells are looked at in detail).

    ``"time"``, ``"timestamp"``, ``"date"``, ``"clock"``, ``"pressure"``,
    ``"surface_pressure"``, ``"rate"``, ... , ``"channel:NAME"``, ``"remarks"``,
    ``"index"``, ``""`` (ignored) or ``"?"`` (unknown: a channel if it has a unit).
    """
    n = len(tab.names)
    fields: list[str | None] = [None] * n
    user_roles: set[str] = set()
    for ch in opts.columns:
        hits = [j for j in range(n) if ch.matches(tab.names[j], j + 1)
                or ch.matches(tab.titles[j] if j < len(tab.titles) else "", j + 1)]
        if not hits:
            continue
        j = hits[0]
        fields[j] = ch.role
        user_roles.add(ch.role)
    for k, v in opts.column_fields.items():
        for j in range(n):
            if fields[j] is None and (k == tab.names[j] or norm_name(k) == norm_name(tab.names[j])):
                fields[j] = v or ""
                if v in ROLE_KIND:
                    user_roles.add(v)
    canon = {title: f for f, title, _ in CANON_COLUMNS}
    guess: list[str] = []
    for j in range(n):
        if fields[j] is not None:
            guess.append(fields[j])      # type: ignore[arg-type]
            continue
        name = tab.names[j]
        if tab.canonical:
            g = "time" if name == "time" else canon.get(name, "channel:" + name)
        else:
            g = synonym(name) or _fuzzy(name) or "?"
        guess.append(g)
    # pressures: a bottom-hole one is the record's pressure when the user did not choose
    main = None
    if "pressure" in user_roles:
        main = guess.index("pressure") if "pressure" in guess else None
    out: list[str] = []
    dh = [j for j, g in enumerate(guess) if g == "pressure@downhole" and fields[j] is None]
    sf = [j for j, g in enumerate(guess) if g == "pressure" and fields[j] is None]
    if main is None:
        main = dh[0] if dh else (sf[0] if sf else None)
    second = None
    if "surface_pressure" not in user_roles and main is not None and (
            synonym(tab.names[main]) == "pressure@downhole"
            or _fuzzy(tab.names[main]) == "pressure@downhole"):
        second = next((j for j in sf if j != main), None)
    taken: set[str] = set()
    for j, g in enumerate(guess):
        if fields[j] is not None:
            f = g
        elif g in ("pressure", "pressure@downhole"):
            f = "pressure" if j == main else "surface_pressure" if j == second else (
                "channel:downhole_pressure" if g == "pressure@downhole" else
                "channel:" + sanitize(tab.names[j]))
        else:
            f = g
        if (f in ROLE_KIND and f != "time") or f == "timestamp":
            if f in taken:
                f = "channel:" + sanitize(tab.names[j])
            taken.add(f)
        out.append(f)
    return out


# ====================================================================== units
def _unit_of(tab: Table, j: int, field: str, opts: ReadOptions) -> tuple[str, str]:
    """``(unit text, where it came from)`` for column ``j`` playing ``field``."""
    name = tab.names[j]
    role = field if field in ROLE_KIND else None
    if role is not None and role in opts.role_units:
        return opts.role_units[role], "--unit"
    for k, v in opts.column_units.items():
        if k == name or norm_name(k) == norm_name(name):
            return v, "--unit"
    hu = tab.header_units[j] if j < len(tab.header_units) else ""
    ru = (tab.row_units[j] if tab.row_units and j < len(tab.row_units) else "") or ""
    if re.match(r"^(?=.*(hh|mm|ss|yy|dd))[hmsdy:/.\- T]+$", ru, re.IGNORECASE):
        ru = ""                                      # a date/time format spec, not a unit
    if ru.strip("[]() ") == "":
        ru = ""
    if hu and ru:
        try:
            a, b = parse_unit(hu), parse_unit(ru)
            agree = same_unit(a, b)
        except InputError:
            agree = hu.strip().lower() == ru.strip().lower()
        if agree and a.absolute is None and b.absolute is not None:
            return ru, f"units row line {tab.units_line}"   # the one that says abs/gauge
        if not agree:
            raise InputError(
                f"column {name!r}: the header (line {tab.header_line}) says {hu!r} but the "
                f"units row (line {tab.units_line}) says {ru!r}: correct the file, or pass "
                f"--unit {role or 'ROLE'}=UNIT to say which", file=tab.label,
                line=tab.units_line)
        return hu, f"header line {tab.header_line}"
    if hu:
        return hu, f"header line {tab.header_line}"
    if ru:
        return ru, f"units row line {tab.units_line}"
    if field == "time":
        implied = _IMPLIED_TIME_UNIT.get(norm_name(name))
        if implied:
            return implied, "title"
    return "", ""


_UNIT_EXAMPLE = {"pressure": "psi", "surface_pressure": "psi", "rate": "bpm", "volume": "bbl",
                 "return_rate": "bpm", "return_volume": "bbl", "density": "sg",
                 "temperature": "degC", "time": "s"}


def _all_units_given(tab: Table, fields: list[str], opts: ReadOptions, label: str) -> None:
    """Refuse, in one error, every column the record uses that states no unit.

    A file without units names all its unitless columns at once, so one rerun with the
    ``--unit`` flags suffices.
    """
    missing = []
    for j, f in enumerate(fields):
        if f in ROLE_KIND or f == "time":
            if not _unit_of(tab, j, f, opts)[0]:
                missing.append((tab.names[j], f))
    if not missing:
        return
    names = ", ".join(repr(n) for n, _ in missing)
    flags = " ".join(f"--unit {r}={_UNIT_EXAMPLE[r]}" for _, r in missing)
    raise InputError(f"column{'s' if len(missing) > 1 else ''} {names} "
                     f"{'have' if len(missing) > 1 else 'has'} no unit: pass {flags}",
                     file=label, line=tab.header_line)


def _parse_kind(text: str, kind: str | None, label: str, line: int | None, name: str,
                role: str | None) -> ParsedUnit | None:
    if text.strip().upper() == "SI":
        return None
    flag = f" (pass --unit {role}=UNIT)" if role else ""
    try:
        pu = parse_unit(text, file=label, line=line, key=name)
    except InputError as exc:
        raise InputError(f"column {name!r}: unit {text!r} is not understood{flag}",
                         file=label, line=line,
                         expected=exc.expected) from None
    if kind is not None and not pu.is_a(kind):
        raise InputError(f"column {name!r}: unit {text!r} is not a {kind} unit{flag}",
                         file=label, line=line,
                         expected={"pressure": "bar, psi, kPa, MPa, atm, kgf/cm2",
                                   "rate": "l/min, bpm, m3/min, m3/h, gal/min",
                                   "volume": "m3, l, bbl, gal", "density": "sg, kg/m3, ppg",
                                   "temperature": "°C, °F, K",
                                   "time": "s, min, h"}[kind])
    return pu


def _kind_of(field: str, pu: ParsedUnit | None) -> str | None:
    if field in ROLE_KIND:
        return ROLE_KIND[field]
    if pu is None:
        return None
    for k in ("pressure", "rate", "volume", "density", "temperature", "time"):
        if pu.is_a(k):
            return k
    return None


# ====================================================================== checks
def _impossible(si: np.ndarray, kind: str | None, field: str, absolute: bool | None
                ) -> tuple[np.ndarray, str]:
    """Mask of values impossible for their kind, and why."""
    if si.size:
        # fast path: the extremes (NaN ignored) tell whether any cell can be out of range
        lo, hi = float(np.fmin.reduce(si)), float(np.fmax.reduce(si))
        floor = {"pressure": (-0.05 * _BAR if absolute else -ATMOSPHERE_PA - 0.5 * _BAR)
                 if field in ("pressure", "surface_pressure") else -_LIMITS["pressure"],
                 "temperature": _TEMP_RANGE[0], "density": _DENSITY_RANGE[0]}.get(
            kind, -_LIMITS.get(kind, np.inf))
        ceil = {"temperature": _TEMP_RANGE[1], "density": _DENSITY_RANGE[1]}.get(
            kind, _LIMITS.get(kind, np.inf))
        if (np.isnan(lo) or (lo >= floor and hi <= ceil)) and np.isfinite(lo if not
                                                                            np.isnan(lo) else 0) \
                and np.isfinite(hi if not np.isnan(hi) else 0):
            return np.zeros(si.size, bool), ""
    bad = np.isinf(si)
    why = "not finite"
    with np.errstate(invalid="ignore"):
        if kind in _LIMITS:
            bad |= np.abs(si) > _LIMITS[kind]
            why = {"pressure": "beyond 5000 bar", "rate": "beyond 2 m3/s",
                   "volume": "beyond 1e5 m3", "time": "beyond 30 years"}[kind]
        if kind == "pressure" and field in ("pressure", "surface_pressure"):
            if absolute:
                neg = si < -0.05 * _BAR
                why = why + " or a negative absolute pressure" if neg.any() else why
                bad |= neg
            else:
                vac = si < -ATMOSPHERE_PA - 0.5 * _BAR
                why = why + " or below vacuum" if vac.any() else why
                bad |= vac
        if kind == "temperature":
            bad |= (si < _TEMP_RANGE[0]) | (si > _TEMP_RANGE[1])
            why = "outside 150-700 K"
        if kind == "density":
            bad |= (si < _DENSITY_RANGE[0]) | (si > _DENSITY_RANGE[1])
            why = "outside 0-5000 kg/m3"
    return bad, why


def _zeros_not_recorded(raw: np.ndarray, si: np.ndarray, rate: np.ndarray | None,
                        absolute: bool | None) -> np.ndarray:
    """Mask of pressure cells written as 0 where nothing was recorded (see module doc)."""
    zero = raw == 0.0
    if not zero.any():
        return zero
    if absolute:
        return zero
    rec = np.isfinite(si) & ~zero
    if rec.sum() < 2:
        return np.zeros_like(zero)
    rng = float(np.nanmax(si[rec]) - min(0.0, float(np.nanmin(si[rec]))))
    if rng <= 0:
        return np.zeros_like(zero)
    out = np.zeros_like(zero)
    z = zero.astype(np.int8)
    d = np.diff(np.concatenate([[0], z, [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    if starts.size > 100_000:
        return out
    rec_idx = np.flatnonzero(rec)
    for a, b in zip(starts, ends):
        k = np.searchsorted(rec_idx, b)
        if k >= rec_idx.size:
            continue                           # zeros to the end: bled off, or unknown
        nxt = si[rec_idx[k]]
        if rate is not None and np.isfinite(rate[a:b]).any():
            pumping = np.nanmean(rate[a:b] > 0) >= 0.5
            if pumping and nxt >= 0.25 * rng:
                out[a:b] = True
        elif nxt >= 0.5 * rng:
            out[a:b] = True
    return out


def _resolution(si: np.ndarray) -> float | None:
    v = si[np.isfinite(si)]
    if v.size < 2:
        return None
    u = np.unique(v)
    if u.size < 2:
        return None
    step = np.diff(u)
    step = step[step > 1e-12 * max(1.0, float(np.max(np.abs(u))))]
    return float(step.min()) if step.size else None


def _make_continuous(v: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """Remove totaliser resets from a cumulative series; returns (continuous, reset rows)."""
    if v.size < 2:
        return v, []
    d = np.diff(v)
    if not float(np.fmin.reduce(d)) < 0:      # never falls (or all NaN): nothing to do
        return v, []
    steps = np.abs(d[np.isfinite(d) & (d != 0)])
    res = float(steps.min()) if steps.size else 0.0
    prev, cur = v[:-1], v[1:]
    with np.errstate(invalid="ignore"):
        is_reset = (d < -3.0 * res) & (cur < 0.5 * prev) & np.isfinite(d)
    idx = np.flatnonzero(is_reset) + 1
    if idx.size == 0:
        return v, []
    if idx.size > 10_000:
        return v, []                           # not a totaliser: leave it alone
    add = np.zeros_like(v)
    for i in idx:
        add[i:] += v[i - 1]
    return v + add, [int(i) for i in idx]


# ====================================================================== helpers
def _text(series: pd.Series) -> pd.Series:
    """The cells as stripped text, ``""`` where blank."""
    if series.dtype.kind in "fiub":
        return series.astype(object).where(series.notna(), "").astype(str)
    s = series.fillna("")
    if s.dtype == object:
        s = s.astype(str)
    return s.str.strip()


def _empty(series: pd.Series) -> np.ndarray:
    if series.dtype.kind in "fiub":
        return series.isna().to_numpy()
    return (series.isna() | (_text(series) == "")).to_numpy()


def _repeated_headers(tab: Table) -> int:
    """Drop header blocks repeated inside the data (reordering columns after a reordered
    one); returns the number of header blocks."""
    if all(s.dtype.kind in "fiub" for s in tab.data) or not tab.titles:
        return 1
    if tab.data[0].dtype.kind in "fiub":
        return 1
    titles = [norm_name(t) for t in tab.titles]
    tset = sorted(titles)
    # a repeated header writes its titles as the first one did
    raw = {t.strip() for t in tab.titles} | {t.strip().lower() for t in tab.titles}
    c0 = _text(tab.data[0])
    cand = np.flatnonzero((c0.isin(raw) | c0.str.lower().isin(raw)).to_numpy())
    if cand.size == 0:
        return 1
    n = len(tab.lines)
    ncol = len(tab.data)
    cells = [_text(s) for s in tab.data]
    drop = np.zeros(n, bool)
    perm_from = []                             # (row, permutation)
    blocks = 1
    for i in cand:
        row = [norm_name(cells[j].iloc[i]) for j in range(ncol)]
        row_set = sorted(x for x in row if x)
        if row_set != tset:
            if len(row_set) >= 2 and all(x in titles for x in row_set):
                raise InputError(f"header changes the columns mid-file: "
                                 f"{[cells[j].iloc[i] for j in range(ncol)]}", file=tab.label,
                                 line=int(tab.lines[i]),
                                 expected=f"the columns of line {tab.header_line}: "
                                          f"{tab.titles}")
            continue
        blocks += 1
        drop[i] = True
        # units rows / separator rows right after
        k = i + 1
        while k < n:
            c0 = cells[0].iloc[k]
            if cell_kind(c0) in ("num", "numc", "datetime", "clock", "date"):
                break
            drop[k] = True
            k += 1
        perm = [row.index(titles[j]) for j in range(ncol)]
        perm_from.append((k, perm))
    for b, (start, perm) in enumerate(perm_from):
        end = perm_from[b + 1][0] if b + 1 < len(perm_from) else n
        if perm != list(range(ncol)):
            block = [tab.data[perm[j]].iloc[start:end].to_numpy() for j in range(ncol)]
            for j in range(ncol):
                col = tab.data[j].astype(object).copy()
                col.iloc[start:end] = block[j]
                tab.data[j] = col
    keep = ~drop
    tab.data = [s[keep].reset_index(drop=True) for s in tab.data]
    tab.lines = tab.lines[keep]
    # columns that were text only because of the header rows become numbers again
    for j, s in enumerate(tab.data):
        if s.dtype.kind not in "fiub":
            num = pd.to_numeric(s, errors="coerce")
            if num.notna().sum() == s.notna().sum():
                tab.data[j] = num.astype(float)
    return blocks


def _canon_key(label: str, line: int, k: str, v: str, meta: dict[str, Any],
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
        raise InputError(f"bad value {v!r} ({exc})", file=label, line=line, key=k,
                         expected="the value written by write_log") from None
    return ref


def _canonical_head(tab: Table) -> tuple[dict[str, Any], list[Event], PressureReference | None]:
    meta: dict[str, Any] = {}
    events: list[Event] = []
    ref = None
    for i, raw in enumerate(tab.raw_head, 1):
        m = re.match(r"#\s*([A-Za-z_][\w.\-]*)\s*:\s?(.*)$", raw.strip())
        if not m:
            continue
        k, v = m.group(1), m.group(2).strip()
        if k == CANON_MAGIC:
            meta["canonical_version"] = v
            continue
        ref = _canon_key(tab.label, i, k, v, meta, events, ref)
    return meta, events, ref


def _gauge_meta(tab: Table, pre: dict[str, str], meta: dict[str, Any], decimal: str
                ) -> float | None:
    """The memory-gauge preamble (well, gauge, test, depth, declared points)."""
    for k, v in pre.items():
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
    return _depth_from(pre, decimal, meta)


def _depth_from(pre: dict[str, str], decimal: str, meta: dict[str, Any]) -> float | None:
    """Gauge depth from a preamble (``Position: gauge depth 1.383 m MD``, ``Depth: 910 m``)."""
    for k, v in pre.items():
        text = f"{k} {v}"
        if "depth" not in text.lower():
            continue
        m = re.search(r"depth\D*?([\d.,]+)\s*(m|ft|feet)\b", text, re.IGNORECASE)
        if m:
            s = m.group(1)
            s = s.replace(".", "").replace(",", ".") if decimal == "," else s.replace(",", "")
            try:
                val = float(s)
            except ValueError:
                continue
            depth = float(to_si([val], "ft" if m.group(2).lower() in ("ft", "feet")
                                else "m")[0])
            meta["gauge_depth_m"] = depth
            return depth
    return None


# ====================================================================== assemble
def assemble(tab: Table, opts: ReadOptions, *, reference: PressureReference | None = None
             ) -> Record:
    """Map columns to fields, convert units, build the time base, check, return the record."""
    label, src = tab.label, tab.source
    notes: list[str] = []
    meta: dict[str, Any] = {"kind": tab.family}
    blocks = _repeated_headers(tab)
    if tab.family == "cementing_unit":
        meta["header_blocks"] = blocks
    # rows with nothing in them (blank lines, trailing rows of empty cells)
    if len(tab.lines):
        empty = np.logical_and.reduce([_empty(s) for s in tab.data])
        if empty.any():
            keep = ~empty
            tab.data = [s[keep].reset_index(drop=True) for s in tab.data]
            tab.lines = tab.lines[keep]
            meta["empty_rows_skipped"] = int(empty.sum())
    if not len(tab.lines):
        raise InputError("no data rows", file=label, line=tab.header_line or 1,
                         expected="data rows after the header")
    for ch in opts.columns:
        if not any(ch.matches(nm, j + 1) or (j < len(tab.titles) and ch.matches(tab.titles[j],
                                                                                   j + 1))
                   for j, nm in enumerate(tab.names)):
            if opts.strict:
                raise InputError(f"--column {ch.role}={ch.name}: no such column", file=label,
                                 line=tab.header_line, expected=f"one of {tab.names}")
    for what, mapping in (("units=", opts.column_units), ("column_map", opts.column_fields)):
        for k in mapping:
            if not any(k == nm or norm_name(k) == norm_name(nm) for nm in tab.names):
                raise InputError(f"{what} names a column {k!r} that is not in the file",
                                 file=label, key=k, expected=f"one of {tab.names}")
    fields = column_roles(tab, opts)
    n_all = len(tab.lines)
    lines_all = tab.lines
    content = [_content(s) for s in tab.data]

    # ---- canonical head
    canon_meta, canon_events, canon_ref = ({}, [], None)
    if tab.canonical:
        canon_meta, canon_events, canon_ref = _canonical_head(tab)
        meta["kind"] = "csv"
        meta.update(canon_meta)

    # ---- which columns make the time base
    for j, f in enumerate(fields):
        if f == "time" and content[j] == "datetime":
            fields[j] = "timestamp"
        elif f == "time" and content[j] == "clock":
            fields[j] = "clock"
        elif f == "timestamp" and content[j] == "clock":
            fields[j] = "clock"
        elif f in ("clock", "date") and content[j] == "datetime":
            fields[j] = "timestamp"
        elif f == "remarks" and content[j] == "num":
            fields[j] = "?"
    if not any(f in _TIME_KINDS for f in fields):
        for j, f in enumerate(fields):
            if f in ("?", "index", "") and content[j] == "datetime":
                fields[j] = "timestamp"
                break
            if f in ("?", "") and content[j] == "clock":
                fields[j] = "clock"
                break
    if "date" in fields and "clock" not in fields and "timestamp" not in fields:
        # "Date" + "Time" where the time column holds clock times
        for j, f in enumerate(fields):
            if f == "time" and content[j] == "clock":
                fields[j] = "clock"
    has_ts = "timestamp" in fields or ("date" in fields and "clock" in fields)
    if has_ts or "clock" in fields:
        # a clock gives the time base; an elapsed column beside it is redundant
        fields = ["" if f == "time" else f for f in fields]
    elapsed = [j for j, f in enumerate(fields) if f == "time"]
    for j in elapsed[1:]:
        fields[j] = ""                       # a second elapsed-time column is redundant
    if not any(f in ("time", "timestamp", "clock") for f in fields):
        raise InputError(f"no time column among {tab.names}: pass --column time=NAME",
                         file=label, line=tab.header_line,
                         expected="a column named like 'Time (s)', or a date-time column")
    if "pressure" not in fields:
        raise InputError(f"no pressure column among {tab.names}: pass --column "
                         "pressure=NAME", file=label, line=tab.header_line,
                         expected="a column named like 'Pressure'")

    _all_units_given(tab, fields, opts, label)

    # ---- remark rows (time + free text in the first value column, the rest empty)
    remark = np.zeros(n_all, bool)
    remark_text = None
    value_cols = [j for j, f in enumerate(fields) if f not in _TIME_KINDS and f != "index"]
    if not tab.canonical and value_cols and tab.data[value_cols[0]].dtype.kind not in "fiub":
        j0 = value_cols[0]
        txt = _text(tab.data[j0])
        low = txt.str.lower()
        numeric = txt.str.match(_NUMBER_LIKE)
        is_text = ((txt != "") & ~numeric & ~low.isin(MISSING_MARKERS)).to_numpy()
        if is_text.any() and len(value_cols) >= 2:
            rest = [_empty(tab.data[j]) for j in value_cols[1:] if fields[j] != "remarks"]
            others_empty = np.logical_and.reduce(rest) if rest else np.ones(n_all, bool)
            remark = is_text & others_empty
            remark_text = txt
    # text column of remarks
    remark_cols = [j for j, f in enumerate(fields) if f == "remarks"]

    # ---- time base (every row, remarks included)
    start_time: datetime | None = None
    tcols = {f: j for j, f in reversed(list(enumerate(fields))) if f in _TIME_KINDS}
    t_all: np.ndarray
    stamps = None
    time_info: dict[int, tuple[str, str]] = {}
    if "timestamp" in tcols or ("date" in tcols and "clock" in tcols):
        if "timestamp" in tcols:
            jt = tcols["timestamp"]
            cells = _text(tab.data[jt])
            key = tab.names[jt]
            if "clock" in tcols and content[jt] == "date":
                jc = tcols["clock"]
                cells = cells + " " + _text(tab.data[jc])
        else:
            jd, jc = tcols["date"], tcols["clock"]
            cells = _text(tab.data[jd]) + " " + _text(tab.data[jc])
            key = f"{tab.names[jd]} + {tab.names[jc]}"
            for j in (jd, jc):
                fields[j] = "timestamp"
        ref_date = None
        pre = tab.meta.get("preamble", {})
        for k, v in pre.items():
            if k.lower() in ("date", "test date", "job date", "datum"):
                ref_date = preamble_date(v)
        dp = parse_datetimes(cells, lines_all, label=label, key=key, order=opts.date_order,
                             hint=tab.date_hint, ref_date=ref_date)
        notes += dp.notes
        if dp.utc_offset:
            meta["utc_offset"] = dp.utc_offset
        stamps = dp.stamps
        data_rows = ~remark
        if np.isnat(stamps[data_rows]).any():
            i = int(np.flatnonzero(data_rows & np.isnat(stamps))[0])
            raise InputError("row without a time", file=label, line=int(lines_all[i]), key=key,
                             expected="a date and time in every data row")
        t_data, start_time, n_spread = elapsed_from_stamps(stamps[data_rows],
                                                          lines_all[data_rows], label=label,
                                                          key=key)
        if n_spread:
            meta["same_second_rows_spread"] = n_spread
        t_all = np.full(n_all, np.nan)
        t_all[data_rows] = t_data
        time_kind = "timestamp"
    elif "clock" in tcols:
        jc = tcols["clock"]
        key = tab.names[jc]
        sec = parse_clock(_text(tab.data[jc]), lines_all, label=label, key=key)
        data_rows = ~remark
        if np.isnan(sec[data_rows]).any():
            i = int(np.flatnonzero(data_rows & np.isnan(sec))[0])
            raise InputError("row without a time", file=label, line=int(lines_all[i]), key=key,
                             expected="a clock time in every data row")
        pre = tab.meta.get("preamble", {})
        day = None
        for k, v in pre.items():
            if k.lower() in ("date", "test date", "job date", "datum", "start date"):
                day = preamble_date(v)
        elapsed_title = bool(set(norm_name(key).split()) & {"elapsed", "delta", "duration",
                                                            "run", "test", "job"})
        first = _text(tab.data[jc]).iloc[int(np.flatnonzero(data_rows)[0])]
        if day is not None and not elapsed_title:
            base = np.datetime64(day, "ms")
            st = base + np.round(sec * 1000.0).astype("int64").astype("timedelta64[ms]")
            t_data, start_time, n_spread = elapsed_from_stamps(st[data_rows],
                                                              lines_all[data_rows],
                                                              label=label, key=key)
            notes.append(f"clock times on the date of the preamble ({day:%Y-%m-%d})")
        else:
            base = np.datetime64("2000-01-01T00:00:00", "ms")
            st = base + np.round(sec * 1000.0).astype("int64").astype("timedelta64[ms]")
            t_data, _, n_spread = elapsed_from_stamps(st[data_rows], lines_all[data_rows],
                                                      label=label, key=key)
            if not elapsed_title:
                meta["start_clock"] = first
        if n_spread:
            meta["same_second_rows_spread"] = n_spread
        t_all = np.full(n_all, np.nan)
        t_all[data_rows] = t_data
        time_kind = "clock"
        stamps = None
    else:
        jt = tcols["time"]
        key = tab.names[jt]
        utext, usrc = _unit_of(tab, jt, "time", opts)
        if not utext:
            raise InputError(f"column {key!r} has no unit: pass --unit time=s (or min, h)",
                             file=label, line=tab.header_line)
        pu = _parse_kind(utext, "time", label, tab.header_line, key, "time")
        nc = numbers(tab.data[jt], lines=lines_all, label=label, name=key,
                     decimal=opts.decimal or tab.decimal)
        t_all = nc.values if pu is None else to_si(nc.values, pu)
        time_info[jt] = (utext, usrc)
        data_rows = ~remark
        if np.isnan(t_all[data_rows]).any():
            i = int(np.flatnonzero(data_rows & np.isnan(t_all))[0])
            raise InputError("row without a time", file=label, line=int(lines_all[i]), key=key,
                             expected="a time in every data row")
        bad, why = _impossible(t_all, "time", "time", None)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            cell = str(tab.data[jt].iloc[i]).strip()
            raise InputError(f"column {key!r}: time {cell!r} {utext} is {why}"
                             f": pass --unit time=UNIT", file=label, line=int(lines_all[i]))
        time_kind = "time"
        if "start_time" in meta:
            start_time = meta.pop("start_time")

    # ---- drop remark rows from the data
    data_rows = ~remark
    lines = lines_all[data_rows]
    t = t_all[data_rows]
    d = np.diff(t)
    keep = np.ones(t.size, bool)
    if time_kind == "time":
        if np.any(d < 0):
            i = int(np.flatnonzero(d < 0)[0]) + 1
            raise InputError("time goes backwards", file=label, line=int(lines[i]), key=key,
                             expected="increasing elapsed time")
        if np.any(d == 0):
            cells_txt = [_text(s)[data_rows].to_numpy() for s in tab.data]
            for i in np.flatnonzero(d == 0) + 1:
                same = all(c[i] == c[i - 1] for c in cells_txt)
                if not same:
                    raise InputError("two different rows have the same time", file=label,
                                     line=int(lines[i]), key=key,
                                     expected="strictly increasing time")
                keep[i] = False
            meta["duplicate_rows_dropped"] = int((~keep).sum())

    # ---- values
    series: dict[str, np.ndarray] = {}
    channels: dict[str, np.ndarray] = {}
    columns: list[ColumnInfo] = []
    absolute: bool | None = None
    pressure_raw: dict[str, np.ndarray] = {}
    for j, (name, f) in enumerate(zip(tab.names, fields)):
        if f in _TIME_KINDS:
            u = time_info.get(j, ("", ""))
            columns.append(ColumnInfo(name, u[0], "time" if f == "time" else "timestamp", src,
                                      u[1]))
            continue
        if f in ("", "index"):
            hu = tab.header_units[j] if j < len(tab.header_units) else ""
            ru = (tab.row_units[j] if tab.row_units and j < len(tab.row_units) else "") or ""
            columns.append(ColumnInfo(name, hu or ru, "", src))
            continue
        if f == "remarks":
            columns.append(ColumnInfo(name, "", "events", src))
            continue
        utext, usrc = _unit_of(tab, j, f, opts)
        role = f if f in ROLE_KIND else None
        if f == "?":
            if not utext:
                columns.append(ColumnInfo(name, "", "", src))
                continue
            try:
                pu = _parse_kind(utext, None, label, tab.header_line, name, None)
            except InputError:
                columns.append(ColumnInfo(name, utext, "", src, usrc))
                continue
            f = "channel:" + sanitize(name)
        elif not utext:
            if role is None:
                pu = None                      # a mapped channel without a unit: as written
            else:
                raise InputError(f"column {name!r} has no unit: pass --unit "
                                 f"{role}={_UNIT_EXAMPLE[role]}",
                                 file=label, line=tab.header_line)
        else:
            pu = _parse_kind(utext, ROLE_KIND.get(f), label, tab.header_line, name, role)
        col = tab.data[j][data_rows].reset_index(drop=True)
        try:
            nc = numbers(col, lines=lines, label=label, name=name,
                         decimal=opts.decimal or tab.decimal)
        except InputError:
            if f.startswith("channel:") and fields[j] == "?":
                columns.append(ColumnInfo(name, utext, "", src, usrc))
                notes.append(f"column {name!r} holds text: not read")
                continue
            raise
        if nc.separators == "thousands":
            notes.append(f"column {name!r}: commas read as thousands separators")
        si = (nc.values if pu is None else to_si(nc.values, pu)) + 0.0
        kind = _kind_of(f, pu)
        if kind == "pressure" and pu is not None and pu.absolute is not None and f == "pressure":
            absolute = pu.absolute
        ab = pu.absolute if (pu is not None and kind == "pressure") else None
        if f == "pressure" and ab is None and tab.family == "downhole_gauge":
            ab = absolute
        # only the series the interpretation uses are checked; other channels as written
        bad, why = _impossible(si, kind, f, ab) if f in ROLE_KIND else (np.zeros(si.size, bool), "")
        dropped: list[tuple[int, str, str]] = []
        if bad.any():
            nb = int(bad.sum())
            good = np.isfinite(si) & ~bad
            isolated = True
            if nb <= 10:
                idx = np.flatnonzero(bad)
                isolated = not np.any(np.diff(idx) == 1)
            if nb <= max(1, min(10, si.size // 1000)) and isolated and good.sum() >= 2:
                for i in np.flatnonzero(bad):
                    dropped.append((int(lines[i]), str(col.iloc[i]).strip(), why))
                    notes.append(f"line {int(lines[i])}: {name} {str(col.iloc[i]).strip()!r} "
                                 f"{utext} is {why}: dropped")
                si = si.copy()
                si[bad] = np.nan
            else:
                i = int(np.flatnonzero(bad)[0])
                hint = f"--unit {role}=UNIT" if role else "--unit"
                raise InputError(
                    f"column {name!r}: {nb} values impossible for {utext!r} ({why}), the "
                    f"first {str(col.iloc[i]).strip()!r}: is the unit right? pass {hint}",
                    file=label, line=int(lines[i]))
        missing = nc.missing.copy()
        if f in ("pressure", "surface_pressure"):
            pressure_raw[f] = nc.values
        if f.startswith("channel:"):
            cname = f[len("channel:"):]
            base, k = cname, 2
            while cname in channels:
                cname, k = f"{base}_{k}", k + 1
            channels[cname] = si
            f = "channel:" + cname
        else:
            series[f] = si
        columns.append(ColumnInfo(name, utext, f, src, usrc, None, int(missing.sum()),
                                  tuple(dropped)))

    # ---- pressures written as 0 where not recorded
    rate = series.get("rate")
    ref_abs = absolute
    if tab.family == "downhole_gauge" and ref_abs is None:
        ref_abs = any("abs" in u.lower() for u in (tab.row_units or []) + tab.header_units)
    for f, raw in pressure_raw.items():
        zmask = _zeros_not_recorded(raw, series[f], rate, ref_abs if f == "pressure" else None)
        if zmask.any():
            series[f] = np.where(zmask, np.nan, series[f])
            notes.append(f"{int(zmask.sum())} {f} cells written as 0 taken as not recorded "
                         f"(lines {int(lines[np.flatnonzero(zmask)[0]])}-"
                         f"{int(lines[np.flatnonzero(zmask)[-1]])})")
            for c_i, c in enumerate(columns):
                if c.field == f:
                    columns[c_i] = ColumnInfo(c.name, c.unit, c.field, c.source, c.unit_source,
                                              c.resolution, c.n_missing + int(zmask.sum()),
                                              c.dropped)

    # ---- apply the row filter (dropped duplicates)
    if not keep.all():
        t = t[keep]
        series = {k: v[keep] for k, v in series.items()}
        channels = {k: v[keep] for k, v in channels.items()}
        lines = lines[keep]

    # ---- totaliser resets
    if not tab.canonical and tab.family != "downhole_gauge":
        for f in ("volume", "return_volume"):
            if f in series:
                cont, resets = _make_continuous(series[f])
                if resets:
                    channels.setdefault(f + "_raw", series[f])
                    series[f] = cont
                    meta[f + "_resets_at_lines"] = [int(lines[i]) for i in resets]

    # ---- resolution of every used column
    for c_i, c in enumerate(columns):
        arr = series.get(c.field) if c.field in series else channels.get(
            c.field[len("channel:"):]) if c.field.startswith("channel:") else None
        if arr is not None:
            columns[c_i] = ColumnInfo(c.name, c.unit, c.field, c.source, c.unit_source,
                                      _resolution(arr), c.n_missing, c.dropped)

    # ---- reference
    pre = dict(tab.meta.get("preamble", {}))
    if tab.family == "cementing_unit":
        ref = PressureReference("surface", None, False)
    elif tab.family == "downhole_gauge":
        depth = _gauge_meta(tab, pre, meta, tab.decimal or ".")
        meta["preamble"] = pre
        ref = PressureReference("downhole", depth, bool(ref_abs))
    elif tab.canonical:
        ref = canon_ref or PressureReference("surface")
    else:
        jp = fields.index("pressure")
        pname = tab.names[jp]
        downhole = (synonym(pname) == "pressure@downhole" or _fuzzy(pname) == "pressure@downhole")
        depth = _depth_from(pre, tab.decimal or ".", meta) if downhole else None
        ref = PressureReference("downhole" if downhole else "surface", depth, False)
        if pre:
            meta["preamble"] = pre
    if absolute is not None and not tab.canonical:
        ref = PressureReference(ref.kind, ref.depth_m, absolute)
    if reference is not None:
        ref = reference

    # ---- declared points (gauge)
    if "declared_points" in meta:
        try:
            n_decl = int(re.sub(r"\D", "", str(meta["declared_points"])))
        except ValueError:
            n_decl = None
        if n_decl is not None and n_decl != t.size:
            raise InputError(f"preamble declares {n_decl} points but the file has {t.size}"
                             " data rows (truncated or corrupted export?)", file=label,
                             line=int(lines[-1]) if lines.size else tab.header_line,
                             key="No Points", expected=f"{n_decl} data rows")
        meta["declared_points"] = n_decl

    # ---- events
    events: list[Event] = []
    if remark.any():
        idx = np.flatnonzero(remark)
        for i in idx:
            text = remark_text.iloc[i]
            et, ts = _event_time(i, stamps, start_time, t_all, tab, fields, opts, lines_all,
                                 time_kind)
            events.append(Event(et, text, ts, src, int(lines_all[i])))
    for j in remark_cols:
        txt = _text(tab.data[j])[data_rows].to_numpy()
        for i in np.flatnonzero(txt != ""):
            ts = None
            if stamps is not None:
                ts = stamps[data_rows][i].astype(datetime)
            events.append(Event(float(t_all[data_rows][i]), str(txt[i]), ts, src,
                                int(lines[i]) if i < lines.size else 0))
    events.extend(canon_events)
    events.extend(tab.events)

    for k in ("comments", "trailer"):
        if k in tab.meta:
            meta[k] = tab.meta[k]
    for k, v in tab.meta.items():
        if k not in ("preamble", "comments", "trailer"):
            meta.setdefault(k, v)
    if notes:
        meta["notes"] = notes
    return Record(t=t, pressure=series.pop("pressure"), reference=ref, start_time=start_time,
                  rate=series.get("rate"), volume=series.get("volume"),
                  return_rate=series.get("return_rate"),
                  return_volume=series.get("return_volume"), density=series.get("density"),
                  temperature=series.get("temperature"),
                  channels={**({"surface_pressure": series["surface_pressure"]}
                               if "surface_pressure" in series else {}), **channels},
                  events=tuple(events), columns=tuple(columns), sources=(str(tab.path),),
                  meta=meta)


def _event_time(i, stamps, start_time, t_all, tab, fields, opts, lines_all, time_kind):
    """Elapsed time (and clock time) of remark row ``i``."""
    if time_kind == "timestamp" and stamps is not None:
        if np.isnat(stamps[i]):
            return float("nan"), None
        ts = stamps[i]
        et = float((ts - np.datetime64(start_time, "ms")).astype("timedelta64[ms]")
                   .astype(np.int64)) / 1000.0
        return et, ts.astype(datetime)
    if time_kind == "clock":
        # remarks keep the clock of their row relative to the first data row
        jc = fields.index("clock") if "clock" in fields else None
        if jc is None:
            return float("nan"), None
        sec = parse_clock(_text(tab.data[jc]), lines_all, label=tab.label, key=tab.names[jc])
        first = int(np.flatnonzero(np.isfinite(t_all))[0])
        et = float(sec[i] - sec[first])
        return et, (start_time + timedelta(seconds=et)) if start_time else None
    return float(t_all[i]), None
