"""Workbooks (.xlsx, .xlsm, .xls, .xlsb, .ods) read through python-calamine.

A sheet is turned into rows of cells and goes through the same layout sniffer as a text
file (preamble, header, units row, data, trailer). Native cell types are kept: numbers stay
numbers, dates become ISO date-times (no day/month question), times of day clock times.
The sheet is ``--sheet NAME`` or ``--sheet N`` (1-based), by default the first sheet that
holds a time and a pressure column.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pandas as pd

from xlotkit.errors import InputError

from .layout import sniff_rows
from .names import ReadOptions
from .table import Table

__all__ = ["WORKBOOK_SUFFIXES", "read_workbook_table"]

WORKBOOK_SUFFIXES = (".xlsx", ".xlsm", ".xls", ".xlsb", ".ods")
_SNIFF_ROWS = 400


def _cell_text(v) -> str:
    if v is None or v == "":
        return ""
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, dt.datetime):
        return v.isoformat(sep=" ", timespec="milliseconds" if v.microsecond else "seconds")
    if isinstance(v, dt.date):
        return v.isoformat()
    if isinstance(v, dt.time):
        return v.isoformat(timespec="milliseconds" if v.microsecond else "seconds")
    if isinstance(v, dt.timedelta):
        s = v.total_seconds()
        return f"{int(s // 3600)}:{int(s % 3600 // 60):02d}:{s % 60:06.3f}"
    return str(v).strip()


def _column(values: list) -> pd.Series:
    """One sheet column: floats when every cell is a number or blank, else text.

    A date-time cell that falls exactly on midnight comes out of the workbook reader as a
    bare date; in a column that holds date-times it is that date at 00:00:00 (a log that
    runs across midnight), not a date without a time.
    """
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) or v in ("", None)
           for v in values):
        return pd.Series([np.nan if v in ("", None) else float(v) for v in values],
                         dtype=float)
    if any(isinstance(v, dt.datetime) for v in values):
        values = [dt.datetime.combine(v, dt.time()) if type(v) is dt.date else v
                  for v in values]
    return pd.Series([_cell_text(v) for v in values], dtype=object)


def _open(path: Path, label: str):
    try:
        from python_calamine import CalamineWorkbook
    except ImportError:  # pragma: no cover - a base dependency
        raise InputError("reading workbooks needs python-calamine", file=label,
                         expected="pip install python-calamine") from None
    try:
        return CalamineWorkbook.from_path(str(path))
    except FileNotFoundError:
        raise InputError("file not found", file=label) from None
    except Exception as exc:  # noqa: BLE001 -- calamine raises its own types for bad files
        raise InputError(f"cannot read the workbook ({type(exc).__name__}: "
                         f"{str(exc)[:120]})", file=label,
                         expected="an .xlsx, .xls or .ods workbook") from None


def _sheet_table(wb, name: str, path: Path, label: str) -> Table:
    sheet = wb.get_sheet_by_name(name)
    rows = sheet.to_python(skip_empty_area=False)
    r0 = sheet.start[0] if sheet.start else 0
    slabel = f"{label}[{name}]"
    if not rows:
        raise InputError("sheet is empty", file=slabel, line=1)
    width = max(len(r) for r in rows)
    head = rows[:_SNIFF_ROWS]
    cells = [[_cell_text(v) for v in r] for r in head]
    raws = ["\t".join(c) for c in cells]
    numbers = [r0 + i + 1 for i in range(len(head))]
    lay = sniff_rows(cells, raws, numbers, label=slabel, complete=len(rows) <= _SNIFF_ROWS)
    end = len(rows) if lay.to_end else lay.data_end
    if lay.to_end:
        # the trailer of a long sheet: rows at the end that are not data
        from .layout import is_data
        k = len(rows)
        while k > lay.data_start and not is_data([_cell_text(v) for v in rows[k - 1]]):
            k -= 1
        trailer = [" ".join(_cell_text(v) for v in r).strip() for r in rows[k:]]
        end = k
    else:
        trailer = lay.trailer
    body = rows[lay.data_start:end]
    # data fields: the header may pad with empty cells (dropped in the layout)
    hdr = [_cell_text(v) for v in rows[lay.header]] if lay.header is not None else []
    pos = [j for j, c in enumerate(hdr) if c] if hdr else list(range(lay.width))
    if len(pos) != len(lay.names):
        pos = list(range(len(lay.names)))
    data = []
    for j in pos:
        data.append(_column([r[j] if j < len(r) else "" for r in body]))
    for j in range(width):
        if j in pos:
            continue
        extra = [r[j] for r in body if j < len(r) and r[j] not in ("", None)]
        if extra:
            i = next(i for i, r in enumerate(body) if j < len(r) and r[j] not in ("", None))
            raise InputError(f"a value in column {j + 1}, which has no title", file=slabel,
                             line=r0 + lay.data_start + i + 1,
                             expected="a title above every column of values")
    meta: dict = {"sheet": name}
    if lay.preamble:
        meta["preamble"] = dict(lay.preamble)
    if lay.comments:
        meta["comments"] = list(lay.comments)
    if trailer:
        meta["trailer"] = [x for x in trailer if x][:50]
    line_no = r0 + lay.data_start + 1 + np.arange(len(body), dtype=np.int64)
    return Table(label=slabel, source=path.name, path=path, names=lay.names,
                 header_units=lay.header_units, row_units=lay.row_units,
                 header_line=None if lay.header is None else numbers[lay.header],
                 units_line=None if lay.units is None else numbers[lay.units],
                 data=data, lines=line_no, decimal=".", meta=meta,
                 titles=[c for c in hdr if c] if hdr else list(lay.names),
                 family="workbook", raw_head=[])


def read_workbook_table(path: Path, label: str, opts: ReadOptions) -> Table:
    """The table of the chosen sheet (see the module docstring)."""
    from .assemble import column_roles

    wb = _open(path, label)
    names = list(wb.sheet_names)
    if not names:
        raise InputError("workbook has no sheets", file=label)
    if opts.sheet is not None:
        s = opts.sheet
        if isinstance(s, int) or (isinstance(s, str) and s.strip().isdigit()
                                  and s not in names):
            k = int(s)
            if not 0 <= k < len(names):
                raise InputError(f"--sheet {k + 1}: the workbook has {len(names)} sheets",
                                 file=label, expected=f"1 to {len(names)} or one of {names}")
            return _sheet_table(wb, names[k], path, label)
        if s not in names:
            raise InputError(f"--sheet {s!r}: no such sheet", file=label,
                             expected=f"one of {names}")
        return _sheet_table(wb, s, path, label)
    problems = []
    for name in names:
        try:
            tab = _sheet_table(wb, name, path, label)
        except InputError as exc:
            problems.append(f"{name}: {exc.message}")
            continue
        roles = column_roles(tab, opts)
        has_time = any(r in ("time", "timestamp", "clock", "date") for r in roles)
        if has_time and "pressure" in roles:
            if len(names) > 1:
                tab.meta["sheet_chosen"] = f"first sheet with a time and a pressure column " \
                                           f"(of {names})"
            return tab
        problems.append(f"{name}: columns {tab.names}")
    raise InputError("no sheet holds a time and a pressure column (" + "; ".join(problems)
                     + "): pass --sheet NAME and --column time=NAME --column pressure=NAME",
                     file=label)
