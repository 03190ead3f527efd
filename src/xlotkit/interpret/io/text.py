"""Delimited text files: sniff the layout from the first lines, parse the body with pandas.

Only the first 256 kB (and, when the data reach past them, the last 64 kB for a trailer) are
read in Python; the body is parsed by pandas' C reader straight from the file, so a file of
ten million rows costs about what ``pandas.read_csv`` costs.
"""

from __future__ import annotations

import csv
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from xlotkit.errors import InputError

from .cells import DATE_TIME_COLONS
from .layout import Layout, is_data, sample_decimal, sniff_rows
from .table import Table

__all__ = ["read_text_table", "split_line"]

HEAD_BYTES = 256 * 1024
TAIL_BYTES = 64 * 1024
_SEPS = ("\t", ";", "|", ",")


def _decode(raw: bytes) -> tuple[str, str]:
    """Text and encoding name (UTF-8 with or without BOM, else Windows-1252)."""
    if raw.startswith(b"\xef\xbb\xbf"):
        enc = "utf-8-sig"
    else:
        enc = "utf-8"
    try:
        text = raw.decode(enc)
    except UnicodeDecodeError as exc:
        if exc.start >= len(raw) - 4:        # a character cut at the end of the head
            text = raw[:exc.start].decode(enc)
        else:
            enc = "cp1252"
            text = raw.decode(enc, errors="replace")
    if "\x00" in text:
        raise InputError("file is binary, not text", expected="a text log (.csv, .txt, .tsv)"
                         " or a workbook (.xlsx, .xls, .ods)")
    return text.replace("Â°", "°").replace("Âº", "º"), enc


def split_line(line: str, sep: str) -> list[str]:
    """Fields of one line (quotes honoured); whitespace-separated when ``sep`` is ``" "``."""
    if sep == " ":
        return line.split()
    if '"' not in line:
        return line.split(sep)
    try:
        return next(csv.reader([line], delimiter=sep, quotechar='"', skipinitialspace=True))
    except (csv.Error, StopIteration):
        return line.split(sep)


def _choose_sep(lines: list[str]) -> str:
    """The separator that gives the longest run of lines with one field count (> 1).

    Delimiters are preferred in the order tab, ``;``, ``|``, ``,`` (a run within 80 % of the
    longest is enough: decimal commas make ``,`` look consistent in a ``;`` file);
    whitespace only when no delimiter gives a run of two lines.
    """
    body = [x for x in lines if x.strip() and not re.match(r"^\s*(#|\*|;|//)", x)]

    def longest_run(sep: str) -> int:
        best = run = 0
        prev = None
        for x in body:
            c = len(split_line(x, sep))
            if sep != " ":
                c = len(split_line(x.rstrip().rstrip(sep), sep))
            if c > 1 and c == prev:
                run += 1
            else:
                run = 1 if c > 1 else 0
            prev = c
            best = max(best, run)
        return best

    runs = {sep: longest_run(sep) for sep in _SEPS}
    top = max(runs.values())
    if top >= 2:
        for sep in _SEPS:
            if runs[sep] >= 0.8 * top:
                return sep
    return " "


def _count_lines(path: Path) -> int:
    n = 0
    last = b"\n"
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 24):
            n += chunk.count(b"\n")
            last = chunk[-1:]
    return n + (0 if last == b"\n" else 1)


def _tail_trailer(path: Path, size: int, enc: str, sep: str, width: int) -> tuple[int, list[str]]:
    """Lines after the last data row at the end of a large file: (count, their text)."""
    with open(path, "rb") as fh:
        fh.seek(max(0, size - TAIL_BYTES))
        raw = fh.read()
    text = raw.decode(enc, errors="replace")
    lines = text.split("\n")
    if size > TAIL_BYTES:
        lines = lines[1:]                   # the first one is cut
    if lines and lines[-1] == "":
        lines = lines[:-1]
    after: list[str] = []
    for k in range(len(lines) - 1, -1, -1):
        x = lines[k].rstrip("\r")
        if not x.strip():
            after.append(x)
            continue
        cells = split_line(x, sep)
        if is_data(cells) and len(cells) >= width:
            break
        after.append(x)
    return len(after), [x for x in reversed(after) if x.strip()]


def _sniff(lines: list[str], canonical: bool, label: str, complete: bool
           ) -> tuple[str, list[list[str]], Layout]:
    sep = "," if canonical else _choose_sep(lines)
    rows = [split_line(x, sep) if x.strip() else [] for x in lines]
    if sep == " ":
        # whitespace-separated: titles may hold single spaces ("WHP psig") when columns are
        # apart by two or more; otherwise every word is a title ("Time(s) P(psi)")
        widths = [len(r) for r in rows if r and is_data(r)]
        w = max(set(widths), key=widths.count) if widths else 0
        split_rows = []
        for r, x in zip(rows, lines):
            if not r or is_data(r):
                split_rows.append(r)
                continue
            wide = re.split(r"\s{2,}|\t", x.strip())
            split_rows.append(r if len(r) == w and len(wide) != w else wide)
        rows = split_rows
    numbers = list(range(1, len(lines) + 1))
    return sep, rows, sniff_rows(rows, lines, numbers, label=label, complete=complete)


def read_text_table(path: Path, label: str, *, decimal: str | None = None) -> Table:
    """Read a delimited text log into a :class:`Table` (cells not yet interpreted)."""
    try:
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(HEAD_BYTES)
    except FileNotFoundError:
        raise InputError("file not found", file=label) from None
    except OSError as exc:
        raise InputError(f"cannot read file ({exc.strerror})", file=label) from None
    if not head.strip():
        raise InputError("file is empty", file=label, line=1,
                         expected="a header row followed by data rows")
    try:
        text, enc = _decode(head)
    except InputError as exc:
        raise InputError(exc.message, file=label, expected=exc.expected) from None
    complete = size <= HEAD_BYTES
    lines = text.split("\n")
    if not complete:
        lines = lines[:-1]                   # the last one may be cut
    lines = [x.rstrip("\r") for x in lines]
    if complete and lines and lines[-1] == "":
        lines = lines[:-1]
    canonical = any(x.startswith("# xlotkit-log:") for x in lines[:3])
    # sniff on the first few hundred lines; more only when the preamble is longer
    limit = 400
    while True:
        part = lines[:limit]
        part_complete = complete and limit >= len(lines)
        try:
            sep, rows, lay = _sniff(part, canonical, label, part_complete)
        except InputError:
            if limit >= len(lines):
                raise
            limit *= 4
            continue
        if (lay.data_end - lay.data_start >= 3 or limit >= len(lines)) and (
                not lay.to_end or lay.data_end - lay.data_start >= 3):
            break
        limit *= 4
    complete = part_complete
    lines = part
    first_data = lay.data_start + 1            # 1-based line
    data_rows = [rows[k] for k in range(lay.data_start, lay.data_end)]
    dec = decimal or sample_decimal(data_rows[:200], sep)
    # where the data end
    nrows = None
    trailer = list(lay.trailer)
    if lay.to_end:
        n_after, tail_text = _tail_trailer(path, size, enc, sep, lay.width)
        if n_after:
            total = _count_lines(path)
            nrows = total - n_after - first_data + 1
            trailer = tail_text
    else:
        nrows = lay.data_end - lay.data_start
    maxw = max([len(r) for r in data_rows] + [lay.width])
    if sep == " ":
        maxw = max(maxw, lay.width)
    df = _read_body(path, label, sep=sep, skip=first_data - 1, nrows=nrows, width=maxw,
                    decimal=dec or ".", encoding=enc)
    line_no = first_data + np.arange(len(df), dtype=np.int64)
    # fields past the header's columns must be empty (trailing separators)
    for j in range(lay.width, df.shape[1]):
        col = df[j]
        extra = col.notna() & (col.astype(str).str.strip() != "")
        if extra.any():
            i = int(np.flatnonzero(extra.to_numpy())[0])
            nv = int(df.iloc[i].notna().sum())
            raise InputError(f"row has {nv} values, the header has {len(lay.names)}",
                             file=label, line=int(line_no[i]),
                             expected=f"{len(lay.names)} values")
    cols = [df[j] if j in df.columns else pd.Series([np.nan] * len(df)) for j in
            range(lay.width)]
    meta: dict = {}
    if lay.preamble:
        meta["preamble"] = dict(lay.preamble)
    if lay.comments:
        meta["comments"] = list(lay.comments)
    if trailer:
        meta["trailer"] = trailer[:50]
    titles = _titles(rows, lay)
    tab = Table(label=label, source=path.name, path=path, names=lay.names,
                header_units=lay.header_units, row_units=lay.row_units,
                header_line=None if lay.header is None else lay.header + 1,
                units_line=None if lay.units is None else lay.units + 1,
                data=cols, lines=line_no, decimal=dec, meta=meta, titles=titles,
                canonical=canonical, raw_head=lines[:lay.header if lay.header is not None
                                                   else lay.data_start])
    _family(tab, lay, rows)
    return tab


def _titles(rows, lay: Layout) -> list[str]:
    if lay.header is None:
        return list(lay.names)
    return [c.strip() for c in rows[lay.header] if c.strip()]


def _family(tab: Table, lay: Layout, rows) -> None:
    """Recognise the cementing-unit and downhole-gauge exports (their conventions)."""
    first_unit = (lay.row_units or [""])[0].lower()
    first_cell = next((c.strip() for c in rows[lay.data_start] if c.strip()), "")
    if first_unit.startswith("mm:dd:yyyy") or DATE_TIME_COLONS.match(first_cell):
        tab.family = "cementing_unit"
        tab.date_hint = "MDY"
        return
    keys = {k.lower() for k in lay.preamble}
    if keys & {"well", "gauge"} and keys & {"no points", "position", "gauge"} and any(
            "time" in n.lower() for n in lay.names) and any(
            n.lower().startswith("pressure") for n in lay.names):
        tab.family = "downhole_gauge"


def _read_body(path: Path, label: str, *, sep: str, skip: int, nrows: int | None, width: int,
               decimal: str, encoding: str) -> pd.DataFrame:
    kw = dict(sep=r"\s+" if sep == " " else sep, header=None, names=list(range(width)),
              skiprows=skip, nrows=nrows, skip_blank_lines=False, keep_default_na=False,
              na_values=[""], decimal=decimal, engine="c", quotechar='"', index_col=False,
              dtype=None)
    for enc in (encoding, "cp1252", "latin-1"):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", pd.errors.DtypeWarning)
                warnings.simplefilter("ignore", pd.errors.ParserWarning)
                return pd.read_csv(path, encoding=enc, **kw)
        except UnicodeDecodeError:
            continue
        except pd.errors.EmptyDataError:
            return pd.DataFrame({j: pd.Series([], dtype=float) for j in range(width)})
        except pd.errors.ParserError as exc:
            m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(exc))
            if m:
                raise InputError(f"row has {m.group(3)} values, the header has fewer",
                                 file=label, line=int(m.group(2)),
                                 expected=f"at most {m.group(1)} values") from None
            raise InputError(f"cannot parse the data rows ({str(exc).strip()[:120]})",
                             file=label, line=skip + 1) from None
        except MemoryError:
            raise InputError("file too large to read into memory", file=label) from None
    raise InputError("cannot decode the file", file=label)  # pragma: no cover


def read_head_text(path: Path) -> str:
    """The decoded first 256 kB of a file (for recognising its kind)."""
    with open(path, "rb") as fh:
        return _decode(fh.read(HEAD_BYTES))[0]

