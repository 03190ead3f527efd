"""Time columns: elapsed time, clock time without a date, date and time with or without a zone.

Dates are parsed column-wide with one explicit format (pandas' C parser) decided from the
cells; where day and month could be swapped, the order is decided from the whole column (a
day above 12, the date in the file's preamble, or one order putting a month between two
consecutive samples) and otherwise asked for (``--date-order``), never guessed.

Documented choices
------------------
* Loggers stamp whole seconds. Rows sharing one whole-second stamp (the AMS-01 cementing
  unit does this after a skipped second) are kept and spread evenly inside that second
  (``k/m`` s for the k-th of m rows): each was taken somewhere inside it, so no sample moves
  outside its stamp's true interval and ``t`` stays strictly increasing.
* Clock time without a date that falls by more than 12 h from one row to the next has
  crossed midnight: a day is added.
* Stamps with a zone (``Z``, ``+01:00``, ``UTC``) are put on the clock of the first stamp's
  zone (so a change to summer time inside the record does not move samples);
  ``meta["utc_offset"]`` records that zone.
* Time that goes backwards cannot be repaired and raises :class:`InputError`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from datetime import datetime

import numpy as np
import pandas as pd

from xlotkit.errors import InputError

from .cells import DATE_TIME, DATE_TIME_COLONS

__all__ = ["DateParse", "elapsed_from_stamps", "parse_clock", "parse_datetimes",
           "preamble_date"]

_MONTHS = {m: i + 1 for i, m in enumerate(
    ["jan", "feb", "mar", "apr", "may", "jun", "jul", "aug", "sep", "oct", "nov", "dec"])}
_MONTHS.update({"mrt": 3, "mai": 5, "mei": 5, "okt": 10, "dez": 12, "dic": 12, "ene": 1,
                "abr": 4, "ago": 8, "set": 9, "fev": 2, "avr": 4, "juil": 7, "aou": 8,
                "déc": 12, "dec.": 12, "maa": 3, "des": 12})
_ORDERS = ("DMY", "MDY", "YMD")


@dataclass
class DateParse:
    """Result of parsing a date-time column.

    Attributes
    ----------
    stamps : ndarray of datetime64[ms]
        Naive clock times (on the first stamp's zone when the cells carry one); NaT where a
        cell is blank.
    order : str
        ``"DMY"``, ``"MDY"`` or ``"YMD"``.
    utc_offset : str or None
        The zone of the first stamp (``"+01:00"``) when the cells carry zones.
    notes : list of str
        How an ambiguous order was decided.
    """

    stamps: np.ndarray
    order: str
    utc_offset: str | None = None
    notes: list[str] = field(default_factory=list)


def preamble_date(text: str) -> datetime | None:
    """A date written in a preamble: ``"Saturday, 9 December 2023"``, ``"2023-12-09"``."""
    s = text.strip()
    m = re.search(r"(\d{1,2})\.?\s+([A-Za-z]{3,9})\.?,?\s+(\d{4})", s)
    if m and m.group(2)[:3].lower() in _MONTHS:
        try:
            return datetime(int(m.group(3)), _MONTHS[m.group(2)[:3].lower()], int(m.group(1)))
        except ValueError:
            return None
    m = re.search(r"([A-Za-z]{3,9})\.?\s+(\d{1,2}),?\s+(\d{4})", s)
    if m and m.group(1)[:3].lower() in _MONTHS:
        try:
            return datetime(int(m.group(3)), _MONTHS[m.group(1)[:3].lower()], int(m.group(2)))
        except ValueError:
            return None
    m = re.search(r"\b(\d{4})-(\d{1,2})-(\d{1,2})\b", s)
    if m:
        try:
            return datetime(int(m.group(1)), int(m.group(2)), int(m.group(3)))
        except ValueError:
            return None
    return None


def _components(txt: pd.Series, order: str) -> pd.Series:
    """General path: regex components -> datetime64 (NaT where a cell does not parse)."""
    parts = txt.str.extract(DATE_TIME.pattern)
    ok = parts["a"].notna()
    a, b, c = parts["a"], parts["b"], parts["c"]
    bnum = pd.to_numeric(b, errors="coerce")
    bname = b.str[:3].str.lower().map(_MONTHS)
    if order == "YMD":
        y, mo, d = a, bnum, c
    elif order == "DMY":
        y, mo, d = c, bnum.where(bnum.notna(), bname), a
    else:
        y, mo, d = c, a, bnum
    y = pd.to_numeric(y, errors="coerce")
    y = y.where(y >= 100, y + 2000)
    hour = pd.to_numeric(parts["H"], errors="coerce")
    ampm = parts["ampm"].str.lower()
    hour = hour.where(~((ampm == "pm") & (hour < 12)), hour + 12)
    hour = hour.where(~((ampm == "am") & (hour == 12)), 0)
    sec = pd.to_numeric(parts["S"], errors="coerce").fillna(0)
    frac = pd.to_numeric(parts["F"].str.replace(",", ".", regex=False), errors="coerce").fillna(0)
    frame = pd.DataFrame({"year": y, "month": pd.to_numeric(mo, errors="coerce"),
                          "day": pd.to_numeric(d, errors="coerce"), "hour": hour,
                          "minute": pd.to_numeric(parts["M"], errors="coerce"),
                          "second": sec})
    good = ok & frame.notna().all(axis=1)
    out = pd.Series(pd.NaT, index=txt.index, dtype="datetime64[ns]")
    if good.any():
        ts = pd.to_datetime(frame[good].astype("int64"), errors="coerce")
        ts = ts + pd.to_timedelta(np.round(frac[good].to_numpy() * 1000.0), unit="ms")
        out[good] = ts
    # zones: shift to the first zone's clock
    z = parts["Z"]
    if z.notna().any():
        off = z.map(_offset_minutes)
        first = off[off.notna()].iloc[0]
        out = out - pd.to_timedelta(off.fillna(first) - first, unit="min")
    return out


def _offset_minutes(z: str | float) -> float:
    if not isinstance(z, str):
        return float("nan")
    if z in ("Z", "UTC", "GMT"):
        return 0.0
    sign = -1.0 if z[0] == "-" else 1.0
    digits = z[1:].replace(":", "")
    return sign * (int(digits[:2]) * 60 + int(digits[2:4]))


def _fmt(first: re.Match, order: str) -> str | None:
    """An explicit strptime format for cells shaped like ``first``, or None."""
    g = first.groupdict()
    if g["ampm"] or g["Z"] or not g["b"].isdigit():
        return None
    s1 = g["s1"]
    ylen = "%Y" if len(g["c"] if order != "YMD" else g["a"]) == 4 else "%y"
    date = {"YMD": f"%Y{s1}%m{s1}%d", "DMY": f"%d{s1}%m{s1}{ylen}",
            "MDY": f"%m{s1}%d{s1}{ylen}"}[order]
    sep = g["sep"]
    if sep.strip() == ",":
        return None
    if g["F"] and g["F"][0] == ",":
        return None          # decimal-comma seconds: the components path reads them
    tm = "%H:%M" + (":%S" if g["S"] else "") + (".%f" if g["F"] else "")
    return date + sep + tm


def _parse_order(txt: pd.Series, order: str, first: re.Match | None) -> pd.Series:
    """Parse with one day/month order: explicit format first, regex components otherwise."""
    if first is not None:
        fmt = _fmt(first, order)
        if fmt is not None:
            ts = pd.to_datetime(txt, format=fmt, errors="coerce")
            if ts.notna().sum() == (txt != "").sum():
                return ts
    return _components(txt, order)


def parse_datetimes(cells: pd.Series, lines: np.ndarray, *, label: str, key: str,
                    order: str | None = None, hint: str | None = None,
                    ref_date: datetime | None = None) -> DateParse:
    """Parse a column of date-time cells.

    Parameters
    ----------
    cells : pandas.Series of str
        One cell per row; ``""`` where blank.
    lines : ndarray of int
        File line of every row.
    label, key : str
        File label and column title for errors.
    order : {"DMY", "MDY", "YMD"}, optional
        The user's ``--date-order``: used where the cells allow more than one order.
    hint : {"DMY", "MDY", "YMD"}, optional
        Order the file family fixes (the cementing unit's ``mm:dd:yyyy`` units row).
    ref_date : datetime, optional
        A date the file states elsewhere (preamble): the order that puts the first stamp on
        it wins.

    Raises
    ------
    InputError
        For a cell that is no date, or day and month that the column does not decide.
    """
    txt = cells.astype(str).str.strip()
    present = (txt != "").to_numpy()
    if not present.any():
        raise InputError(f"column {key!r} holds no dates", file=label, key=key)
    i0 = int(np.flatnonzero(present)[0])
    c0 = txt.iloc[i0]
    if DATE_TIME_COLONS.match(c0):
        ts = pd.to_datetime(txt, format="%m:%d:%Y:%H:%M:%S", errors="coerce")
        res = {"MDY": ts}
    else:
        first = DATE_TIME.match(c0)
        if first is None:
            raise InputError(f"{c0!r} is not a date and time", file=label, line=int(lines[i0]),
                             key=key, expected="a timestamp like 2023-12-10 14:42:58, "
                                               "10/12/2023 14:42:58 or 12:10:2023:14:42:58")
        if len(first.group("a")) == 4:
            cands = ["YMD"]
        elif not first.group("b").isdigit():
            cands = ["DMY"]
        else:
            cands = ["DMY", "MDY"]
        res = {o: _parse_order(txt, o, first) for o in cands}
    n_present = int(present.sum())
    full = {o: ts for o, ts in res.items() if int(ts.notna().sum()) == n_present}
    if not full:
        # report the first cell that no order reads
        best = max(res.values(), key=lambda s: int(s.notna().sum()))
        bad = present & best.isna().to_numpy()
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{txt.iloc[i]!r} is not a valid date and time", file=label,
                         line=int(lines[i]), key=key,
                         expected=f"a date and time like {c0!r} in every row")
    notes: list[str] = []
    if len(full) == 1:
        chosen = next(iter(full))
    else:
        a, b = full["DMY"], full["MDY"]
        if a.equals(b):
            chosen = "DMY"      # day == month in every row: both orders read the same
        elif order in full:
            chosen = order
            notes.append(f"date order {order} from --date-order")
        elif hint in full:
            chosen = hint
            notes.append(f"date order {hint} fixed by the file's layout")
        else:
            chosen = None
            if ref_date is not None:
                hits = [o for o, ts in full.items()
                        if ts.iloc[i0].normalize() == pd.Timestamp(ref_date).normalize()]
                if len(hits) == 1:
                    chosen = hits[0]
                    notes.append(f"date order {chosen}: the first stamp is on the date the "
                                 f"preamble gives ({ref_date:%Y-%m-%d})")
            if chosen is None:
                gaps = {o: float(np.nanmax(np.abs(np.diff(ts.dropna().to_numpy()
                                                          .astype("datetime64[s]")
                                                          .astype(np.int64)))))
                        if ts.notna().sum() > 1 else 0.0 for o, ts in full.items()}
                plaus = [o for o, g in gaps.items() if g <= 2 * 86400.0]
                if len(plaus) == 1 and max(gaps.values()) >= 20 * 86400.0:
                    chosen = plaus[0]
                    other = "MDY" if chosen == "DMY" else "DMY"
                    notes.append(f"date order {chosen}: {other} would put "
                                 f"{gaps[other] / 86400.0:.0f} days between two samples")
            if chosen is None:
                raise InputError(
                    f"column {key!r}: dates such as {c0!r} read both as day/month and as "
                    "month/day, and the column does not decide: pass --date-order DMY or "
                    "--date-order MDY (Python: date_order=...)", file=label,
                    line=int(lines[i0]))
    ts = full[chosen]
    offset = None
    m = DATE_TIME.match(c0)
    if m is not None and m.group("Z"):
        mins = _offset_minutes(m.group("Z"))
        offset = "+" if mins >= 0 else "-"
        offset += f"{int(abs(mins)) // 60:02d}:{int(abs(mins)) % 60:02d}"
    return DateParse(ts.to_numpy().astype("datetime64[ms]"), chosen, offset, notes)


def parse_clock(cells: pd.Series, lines: np.ndarray, *, label: str, key: str) -> np.ndarray:
    """Clock times without a date (``08:50:05``) -> seconds since the first row's midnight.

    A fall of more than 12 h from one row to the next is a midnight crossing (a day is
    added); NaN where a cell is blank.
    """
    txt = cells.astype(str).str.strip()
    present = (txt != "").to_numpy()
    norm = txt.str.replace(",", ".", regex=False)
    short = norm.str.match(r"^\d{1,2}:\d{2}$")
    if short.any():
        norm = norm.where(~short, norm + ":00")
    ampm = norm.str.contains(r"[AaPp][Mm]$", regex=True)
    if ampm.any():
        ts = pd.to_datetime(norm.where(ampm, None), format="%I:%M:%S %p", errors="coerce")
        td_ampm = ts - ts.dt.normalize()
        norm = norm.where(~ampm, "")
    td = pd.to_timedelta(norm.where(norm != "", None), errors="coerce")
    if ampm.any():
        td = td.where(~ampm, td_ampm)
    sec = td.dt.total_seconds().to_numpy()
    bad = present & np.isnan(sec)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{txt.iloc[i]!r} is not a clock time", file=label, line=int(lines[i]),
                         key=key, expected="hh:mm:ss in every row")
    ok = np.flatnonzero(~np.isnan(sec))
    if ok.size > 1:
        s = sec[ok]
        wrap = np.diff(s) < -43200.0
        if wrap.any():
            s = s + 86400.0 * np.concatenate([[0], np.cumsum(wrap)])
            sec = sec.copy()
            sec[ok] = s
    return sec


def elapsed_from_stamps(stamps: np.ndarray, lines: np.ndarray, *, label: str,
                        key: str) -> tuple[np.ndarray, datetime, int]:
    """Elapsed seconds from ``datetime64[ms]`` stamps; same-second rows spread in their second.

    Returns ``(t, start_time, n_spread)``.
    """
    ms = (stamps - stamps[0]).astype("timedelta64[ms]").astype(np.int64)
    d = np.diff(ms)
    if np.any(d < 0):
        i = int(np.flatnonzero(d < 0)[0]) + 1
        raise InputError("time goes backwards", file=label, line=int(lines[i]), key=key,
                         expected="timestamps that never decrease")
    t = ms.astype(float) / 1000.0
    n_spread = 0
    if np.any(d == 0):
        if np.any(ms % 1000):
            i = int(np.flatnonzero(d == 0)[0]) + 1
            raise InputError("repeated sub-second timestamp", file=label, line=int(lines[i]),
                             key=key, expected="strictly increasing time")
        start = np.r_[True, d != 0]
        group = np.cumsum(start) - 1
        first = np.flatnonzero(start)
        counts = np.bincount(group)
        k = np.arange(t.size) - first[group]
        t = t + k / counts[group]
        n_spread = int(np.sum(counts[counts > 1]))
    start_time = stamps[0].astype("datetime64[ms]").astype(datetime)
    return t, start_time, n_spread

