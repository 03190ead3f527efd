"""Read field logs of leak-off tests into :class:`~xlotkit.record.Record`, merge surface and
downhole records, and write the canonical CSV layout.

The reader works from what the file says and asks for what it does not:

* :mod:`.text` and :mod:`.workbook` read delimited text and workbooks (.xlsx, .xls, .ods)
  into a table of cells; :mod:`.layout` sniffs preamble, header, units row, data and trailer
  from the first rows; the body of a text file is parsed by pandas' C reader.
* :mod:`.names` holds the synonyms table and the user's choices (``--column ROLE=NAME``,
  ``--unit ROLE=UNIT``, ``--sheet``, ``--date-order``, ``--decimal``); :mod:`.cells` turns
  cells into numbers (decimal and thousands separators decided column-wide);
  :mod:`.timebase` parses elapsed, clock and date-time columns.
* :mod:`.assemble` maps columns to record fields, converts units (:mod:`xlotkit.units`),
  checks values against what their unit allows and builds the record.
* :mod:`.align` estimates the clock offset between a surface and a downhole logger and
  merges the two.

File families recognised from their content (``kind="auto"``): the cementing-unit export
(``mm:dd:yyyy:hh:mm:ss`` stamps, free-text remark rows, repeated header blocks; surface,
gauge pressure), the memory-gauge export (``Well:`` / ``Gauge:`` / ``No Points:`` preamble;
downhole at the preamble's depth, absolute for ``psi absolute``), the canonical layout
written by :func:`write_log`, and any other delimited text or workbook.
Everything returned is SI (Pa, m^3/s, m^3, kg/m^3, K, s).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from xlotkit.errors import InputError
from xlotkit.logfile import write_log
from xlotkit.record import PressureReference, Record

from .align import ClockOffset, estimate_clock_offset, merge_surface_downhole
from .assemble import assemble
from .names import ROLE_KIND, ColumnChoice, ReadOptions, parse_assignments
from .text import read_text_table
from .workbook import WORKBOOK_SUFFIXES, read_workbook_table

__all__ = [
    "ClockOffset",
    "ReadOptions",
    "estimate_clock_offset",
    "merge_surface_downhole",
    "read_log",
    "read_logs",
    "read_options",
    "reading_notes",
    "write_log",
]

def reading_notes(record: Record) -> list[str]:
    """What the reader decided about a record's cells, for the user to see.

    Cells dropped as impossible, zeros taken as not recorded, commas read as thousands
    separators, columns not read: the reader's notes (``meta["notes"]``), and for a merged
    surface + downhole record each side's, prefixed with the side.
    """
    notes = [str(n) for n in record.meta.get("notes", ())]
    for side in ("surface", "downhole"):
        sub = record.meta.get(side)
        if isinstance(sub, Mapping):
            notes += [f"{side} log: {n}" for n in sub.get("notes", ())]
    return notes


_KINDS = ("auto", "cementing_unit", "downhole_gauge", "csv", "workbook")
_DATE_ORDERS = ("DMY", "MDY", "YMD")


def read_options(columns: Mapping[str, str] | Sequence[str] | None = None,
                 units: Mapping[str, str] | Sequence[str] | None = None, *,
                 column_map: Mapping[str, str] | None = None,
                 sheet: str | int | None = None, date_order: str | None = None,
                 dayfirst: bool | None = None, decimal: str | None = None,
                 strict: bool = True) -> ReadOptions:
    """The reader's options from the command line's spellings (``--column ROLE=NAME``,
    ``--unit ROLE=UNIT``, ``--sheet``, ``--date-order``, ``--decimal``), validated once, e.g.
    to read many files of an archive alike (``strict=False``: a ``--column`` choice need not
    fit every file). Parameters as for :func:`read_log`."""
    return _options(columns, units, column_map, sheet, date_order, dayfirst, decimal,
                    strict=strict)


def _options(columns, units, column_map, sheet, date_order, dayfirst, decimal,
             strict: bool = True) -> ReadOptions:
    roles = parse_assignments(columns, "--column")
    role_units: dict[str, str] = {}
    col_units: dict[str, str] = {}
    if units:
        items = units.items() if isinstance(units, Mapping) else [
            tuple(u.split("=", 1)) if "=" in u else (u, "") for u in units]
        for k, v in items:
            if not str(v).strip():
                raise InputError(f"cannot read unit {k!r}", key="--unit", expected="ROLE=UNIT")
            key = str(k).strip()
            r = key.lower().replace("-", "_")
            r = {"pressure2": "surface_pressure", "second_pressure": "surface_pressure"}.get(r, r)
            if r in ROLE_KIND:
                role_units[r] = str(v).strip()
            elif isinstance(units, Mapping):
                col_units[key] = str(v).strip()       # Python API: units by column title
            else:
                raise InputError(f"unknown role {key!r}", key="--unit",
                                 expected="ROLE one of " + ", ".join(ROLE_KIND))
    if dayfirst is not None and date_order is None:
        date_order = "DMY" if dayfirst else "MDY"
    if date_order is not None:
        date_order = str(date_order).upper()
        if date_order not in _DATE_ORDERS:
            raise InputError(f"unknown date order {date_order!r}", key="--date-order",
                             expected="DMY, MDY or YMD")
    if decimal is not None and decimal not in (".", ","):
        raise InputError(f"unknown decimal separator {decimal!r}", key="--decimal",
                         expected="'.' or ','")
    if isinstance(sheet, str) and sheet.strip().isdigit():
        sheet = int(sheet) - 1
        if sheet < 0:
            raise InputError("--sheet counts from 1", key="--sheet", expected="1, 2, ...")
    return ReadOptions(columns=tuple(ColumnChoice(r, n) for r, n in roles.items()),
                       role_units=role_units, column_units=col_units,
                       column_fields=dict(column_map or {}), sheet=sheet,
                       date_order=date_order, decimal=decimal, strict=strict)


def read_log(path: str | os.PathLike, *, kind: str = "auto",
             columns: Mapping[str, str] | Sequence[str] | None = None,
             units: Mapping[str, str] | Sequence[str] | None = None,
             column_map: Mapping[str, str] | None = None,
             reference: PressureReference | None = None,
             sheet: str | int | None = None, date_order: str | None = None,
             dayfirst: bool | None = None, decimal: str | None = None,
             options: ReadOptions | None = None) -> Record:
    """Read one field log into a :class:`~xlotkit.record.Record` (SI units).

    Parameters
    ----------
    path : str or path-like
        A delimited text file (.csv, .txt, .tsv, any suffix) or a workbook (.xlsx, .xlsm,
        .xls, .xlsb, .ods).
    kind : {"auto", "cementing_unit", "downhole_gauge", "csv", "workbook"}
        File family; ``"auto"`` recognises it from the content (and the suffix for
        workbooks). A family given explicitly must be the one the content shows.
    columns : mapping or sequence of ``"ROLE=NAME"``, optional
        The column that plays a role (``--column``): ROLE one of ``time``, ``pressure``,
        ``surface_pressure`` (the second pressure of a pair), ``rate``, ``volume``,
        ``return_rate``, ``return_volume``, ``density``, ``temperature``; NAME a title or a
        1-based column number. E.g. ``{"pressure": "BH P", "rate": "Q in"}``.
    units : mapping or sequence of ``"ROLE=UNIT"``, optional
        Units (``--unit``): keys are roles (``{"pressure": "psi"}``), or, in a mapping,
        column titles (``{"Druk": "bar"}``). Supplies a unit the file never states, or
        replaces one it states.
    column_map : mapping of str to str, optional
        Column title -> field (``"pressure"``, ..., ``"timestamp"``, ``"channel:NAME"``, or
        ``""`` to ignore the column).
    reference : PressureReference, optional
        Where the pressure was measured; replaces what is inferred (cementing unit: surface,
        gauge; memory gauge: downhole at the preamble's depth; other files: downhole when
        the pressure's title says so (``BH Pressure``), else surface; absolute when the unit
        says so).
    sheet : str or int, optional
        Workbook sheet: a name, or a 0-based position (``"2"`` as a string is the 1-based
        position, as on the command line).
    date_order : {"DMY", "MDY", "YMD"}, optional
        For dates whose day and month the column does not decide (``dayfirst=True`` is
        ``"DMY"``).
    dayfirst : bool, optional
        Older spelling of ``date_order``.
    decimal : {".", ","}, optional
        For numbers like ``3,431`` that the column does not decide.
    options : ReadOptions, optional
        All of the above at once (used by :func:`read_logs`); replaces them.

    Returns
    -------
    Record
        ``t`` [s], ``start_time`` when the file has clock times, ``pressure`` [Pa] (NaN
        where not recorded), optional ``rate`` [m^3/s], ``volume`` [m^3] (continuous across
        totaliser resets), ``return_rate``, ``return_volume``, ``density`` [kg/m^3],
        ``temperature`` [K]; other columns with units in ``channels``; remarks in
        ``events``; per column its provenance, resolution, missing and dropped cells in
        ``columns``; preamble, comments, trailer and the reader's notes in ``meta``.

    Raises
    ------
    InputError
        For anything the file does not say or says inconsistently; the message names the
        file, the line, what was found, and the flag that supplies or corrects it.
    """
    p = Path(path)
    label = str(path)
    if kind not in _KINDS:
        raise InputError(f"unknown kind {kind!r}", file=label, key="kind",
                         expected=", ".join(_KINDS))
    opts = options or _options(columns, units, column_map, sheet, date_order, dayfirst,
                               decimal)
    if not p.exists():
        raise InputError("file not found", file=label)
    if p.is_dir():
        raise InputError("is a directory, expected a log file", file=label)
    if p.suffix.lower() in WORKBOOK_SUFFIXES or kind == "workbook":
        tab = read_workbook_table(p, label, opts)
    else:
        if opts.sheet is not None:
            raise InputError("--sheet is for workbooks; this is a text file", file=label,
                             key="--sheet", expected="an .xlsx, .xls or .ods file")
        tab = read_text_table(p, label, decimal=opts.decimal)
    if kind not in ("auto", "workbook", tab.family) and not (kind == "csv" and tab.canonical):
        if kind == "csv":
            tab.family = "csv"
        else:
            raise InputError(f"the file is not a {kind} export (it reads as {tab.family})",
                             file=label, key="kind", expected="kind='auto'")
    return assemble(tab, opts, reference=reference)


def read_logs(paths: Iterable[str | os.PathLike], *, offset_s: float | None = None,
              max_offset_s: float = 4 * 3600.0, **kw: Any) -> Record:
    """Read several logs of one test; a surface + downhole pair is merged.

    Parameters
    ----------
    paths : iterable of path-like
        One file, or a surface (cementing unit) file and a downhole-gauge file.
    offset_s : float, optional
        Clock offset [s] to apply instead of estimating it (see
        :func:`merge_surface_downhole`).
    max_offset_s : float
        Largest clock offset searched [s].
    **kw
        Passed to :func:`read_log` for every file. With several files a ``columns`` choice
        need only fit one of them.

    Returns
    -------
    Record
        The single record, or the merged one.
    """
    recs = read_each(list(paths), **kw)
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


def read_each(paths: Sequence[str | os.PathLike], **kw: Any) -> list[Record]:
    """Read every file with the same options; a ``--column`` choice must fit one of them."""
    paths = list(paths)
    if len(paths) <= 1:
        return [read_log(p, **kw) for p in paths]
    opts = kw.pop("options", None) or _options(
        kw.pop("columns", None), kw.pop("units", None), kw.pop("column_map", None),
        kw.pop("sheet", None), kw.pop("date_order", None), kw.pop("dayfirst", None),
        kw.pop("decimal", None), strict=False)
    opts = ReadOptions(**{**opts.__dict__, "strict": False})
    recs = [read_log(p, options=opts, **kw) for p in paths]
    for ch in opts.columns:
        if not any(ch.matches(c.name, k + 1) for r in recs for k, c in enumerate(r.columns)):
            raise InputError(f"--column {ch.role}={ch.name}: no such column in any of the files",
                             key="--column",
                             expected="a column title (or number) of one of the files")
    return recs
