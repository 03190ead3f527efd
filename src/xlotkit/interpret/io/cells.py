"""Cells: what a cell looks like (number, date, clock time, text) and columns of numbers.

The layout sniffer classifies the cells of the first lines with these patterns; the body is
parsed by pandas and only columns pandas could not turn into numbers come back here, where
the decimal and thousands separators are decided from the whole column, never cell by cell.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import pandas as pd

from xlotkit.errors import InputError

__all__ = ["MISSING_MARKERS", "NumberColumn", "cell_kind", "numbers"]

NUM_POINT = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
NUM_COMMA = re.compile(r"^[-+]?\d*,\d+([eE][-+]?\d+)?$")
# 3,431 / 12,345,678.5 (thousands commas) and 1.234,5 (thousands points); a grouped number
# never starts with 0, so 0,500 can only be a decimal comma
NUM_THOUSANDS_COMMA = re.compile(r"^[-+]?[1-9]\d{0,2}(,\d{3})+(\.\d*)?$")
NUM_THOUSANDS_POINT = re.compile(r"^[-+]?[1-9]\d{0,2}(\.\d{3})+(,\d*)?$")
# a comma that can only be a decimal comma: not three digits after it, or a long integer part
NUM_COMMA_STRICT = re.compile(r"^[-+]?(\d*,(\d{1,2}|\d{4,})|\d{4,},\d+)([eE][-+]?\d+)?$")
DATE_TIME = re.compile(
    r"^(?P<a>\d{1,4})(?P<s1>[/.\-])(?P<b>\d{1,2}|[A-Za-z]{3,9})(?P=s1)(?P<c>\d{2,4})"
    r"(?P<sep>[ T]+|\s*,\s*|:)(?P<H>\d{1,2}):(?P<M>\d{2})(?::(?P<S>\d{2})(?P<F>[.,]\d+)?)?"
    r"\s*(?P<ampm>[AaPp][Mm])?\s*(?P<Z>Z|UTC|GMT|[+-]\d{2}:?\d{2})?$")
# the cementing unit's mm:dd:yyyy:hh:mm:ss
DATE_TIME_COLONS = re.compile(r"^\d{1,2}:\d{1,2}:\d{4}:\d{1,2}:\d{1,2}:\d{1,2}$")
DATE_ONLY = re.compile(r"^(\d{1,4})([/.\-])(\d{1,2}|[A-Za-z]{3,9})\2(\d{2,4})$")
CLOCK = re.compile(r"^\d{1,2}:\d{2}(:\d{2}([.,]\d+)?)?\s*([AaPp][Mm])?$")

#: Cells that mean "not recorded".
MISSING_MARKERS = frozenset(["", "-", "--", "---", "----", "n/a", "na", "nan", "null", "none",
                             "#n/a", "n.a.", "missing", "*", "**", "***", "****", "*****",
                             "#value!", "#div/0!", "#num!", "#ref!", "void", "?"])


def cell_kind(cell: str) -> str:
    """``"empty"``, ``"num"``, ``"numc"`` (decimal comma), ``"datetime"``, ``"date"``,
    ``"clock"`` or ``"text"``."""
    s = cell.strip()
    if not s:
        return "empty"
    if NUM_POINT.match(s) or NUM_THOUSANDS_COMMA.match(s):
        return "num"
    if NUM_COMMA.match(s) or NUM_THOUSANDS_POINT.match(s):
        return "numc"
    if CLOCK.match(s):
        return "clock"
    if DATE_TIME.match(s) or DATE_TIME_COLONS.match(s):
        return "datetime"
    if DATE_ONLY.match(s):
        return "date"
    return "text"


@dataclass
class NumberColumn:
    """A column turned into numbers.

    Attributes
    ----------
    values : ndarray of float
        The numbers; NaN where missing.
    missing : ndarray of bool
        Blank cells and not-recorded markers.
    separators : str
        How commas were read: ``""`` (none), ``"decimal"`` or ``"thousands"``.
    """

    values: np.ndarray
    missing: np.ndarray
    separators: str = ""


def _text(series: pd.Series) -> pd.Series:
    return series.astype(object).where(series.notna(), "").astype(str).str.strip()


def _grouped_where_due(plain: np.ndarray) -> bool:
    """Whether the plain cells of a column whose commas read both ways are whole numbers below
    1000, not all zero: then the column writes a comma exactly where a thousands separator is
    due (950, 3,500), while a decimal-comma writer would have put the same number of decimals
    on the whole numbers too (950,000) or trimmed them from the others (3,5). Zeros alone do
    not decide: loggers often write an exact zero as ``0`` whatever their format."""
    plain = plain[np.isfinite(plain)]
    return bool(np.any(plain != 0.0)) and bool(np.all(np.abs(plain) < 1000.0)) and \
        bool(np.all(plain == np.round(plain)))


def numbers(series: pd.Series, *, lines: np.ndarray, label: str, name: str,
            decimal: str | None = None) -> NumberColumn:
    """Numbers of one column; pandas already parsed the plain ones.

    Parameters
    ----------
    series : pandas.Series
        The column as pandas read it (float where it could, object otherwise).
    lines : ndarray of int
        File line of every row, for errors.
    label, name : str
        File label and column title for errors.
    decimal : {".", ","} or None
        The file's decimal separator if known (from ``--decimal`` or from other columns);
        decides whether ``3,431`` is 3431 or 3.431.

    Raises
    ------
    InputError
        For a cell that is not a number, or a column whose commas could be read both ways.
    """
    if series.dtype.kind in "fiub":
        v = series.to_numpy(dtype=float, na_value=np.nan)
        return NumberColumn(v, np.isnan(v))
    txt = _text(series)
    low = txt.str.lower()
    missing = low.isin(MISSING_MARKERS).to_numpy()
    num = pd.to_numeric(txt.where(~missing, None), errors="coerce")
    bad = (~missing) & num.isna().to_numpy()
    how = ""
    if bad.any():
        cand = txt[bad]
        has_comma = cand.str.contains(",", regex=False)
        if has_comma.any():
            comma_cells = txt[txt.str.contains(",", regex=False)]
            thou_ok = bool(comma_cells.str.match(NUM_THOUSANDS_COMMA.pattern).all())
            dec_ok = bool((comma_cells.str.match(NUM_COMMA.pattern)
                           | comma_cells.str.match(NUM_THOUSANDS_POINT.pattern)).all())
            plain = num[~bad & ~missing]
            if thou_ok and dec_ok:
                if decimal == ".":
                    how = "thousands"
                elif decimal == ",":
                    how = "decimal"
                elif txt.str.contains(".", regex=False).any():
                    how = "thousands"           # 3,431.5 somewhere in the column
                elif plain.size and float(np.nanmax(np.abs(plain))) >= 1000.0:
                    how = "decimal"             # 1234 written without a thousands comma
                elif plain.size and _grouped_where_due(plain.to_numpy(dtype=float)):
                    how = "thousands"           # 950 plain, 3,500 grouped: commas start at 1000
                else:
                    i = int(np.flatnonzero(bad)[0])
                    raise InputError(
                        f"column {name!r}: {txt.iloc[i]!r} could be {txt.iloc[i].replace(',', '')}"
                        f" (thousands separator) or {txt.iloc[i].replace(',', '.')} (decimal "
                        "comma), and the whole column does not decide: pass --decimal . or "
                        "--decimal ,", file=label, line=int(lines[i]))
            elif thou_ok:
                how = "thousands"
            elif dec_ok:
                how = "decimal"
            if how == "thousands":
                fixed = txt.str.replace(",", "", regex=False)
            elif how == "decimal":
                fixed = txt.str.replace(".", "", regex=False).str.replace(",", ".", regex=False) \
                    if txt.str.match(NUM_THOUSANDS_POINT.pattern).any() else \
                    txt.str.replace(",", ".", regex=False)
            else:
                fixed = txt
            num = pd.to_numeric(fixed.where(~missing, None), errors="coerce")
            bad = (~missing) & num.isna().to_numpy()
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"column {name!r}: value {txt.iloc[i]!r} is not a number",
                         file=label, line=int(lines[i]),
                         expected="a number, or a blank cell where nothing was recorded")
    v = num.to_numpy(dtype=float, na_value=np.nan)
    return NumberColumn(v, missing | np.isnan(v), how)
