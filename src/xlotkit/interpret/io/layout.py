"""Sniffing a layout from the first rows: preamble, header, units row, data, trailer.

Works on rows of cells (a text file's first lines split on the sniffed separator, or a
workbook sheet's first rows), so text files and workbooks share one set of rules:

* Preamble lines before the header: comments and banners (``*``, ``#``, ``;``, ``//``,
  ``!``, ``%``, boxes of asterisks), program and version lines, key–value lines
  (``Well: X``, ``tinj 520``, ``Gauge:<TAB>9380``) go to ``meta``.
* The data are the longest run of rows that look like data (the first cell a number, date
  or clock time, and most cells numbers); the header is the text row above them, and a row
  between the two whose cells are all units is the units row (rows of ``-``/``_``/``=``
  are skipped).
* Rows after the data that do not look like it (an analysis or summary block such as
  ``GFunction`` / ``tClosure 522``) are the trailer, kept as text in ``meta``, never data.
* Header cells give the unit as ``Name (unit)``, ``Name [unit]``, ``Name, unit`` or
  ``Name unit`` (the last word only when it is a unit the field writes, see
  :data:`xlotkit.units.FIELD_UNITS`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from xlotkit.errors import InputError
from xlotkit.units import field_unit_kind

from .cells import NUM_COMMA_STRICT, NUM_POINT, cell_kind

__all__ = ["Layout", "sniff_rows", "split_name_unit"]

_COMMENT = re.compile(r"^\s*(#|\*|;|//|!|%|rem\b|--\s)", re.IGNORECASE)
_SEPARATOR_ROW = re.compile(r"^[\s_\-=*~+|.:]*$")
_FORMAT_SPEC = re.compile(r"^(?=.*(hh|mm|ss|yy|dd))[hmsdy:/.\- T]+$", re.IGNORECASE)
_NUMERICISH = ("num", "numc", "datetime", "clock", "date")
_UNIT_IN_BRACKETS = re.compile(r"^(?P<name>.*?)\s*[\(\[](?P<unit>[^\)\]]*)[\)\]]\s*$")
_UNIT_AFTER_COMMA = re.compile(r"^(?P<name>[^,]+?)\s*,\s*(?P<unit>[^,]+)$")


@dataclass
class Layout:
    """Where things are in a file.

    Attributes
    ----------
    header : int or None
        Index (into the sniffed rows) of the header row.
    units : int or None
        Index of the units row.
    data_start, data_end : int
        Index range ``[data_start, data_end)`` of the data rows among the sniffed rows
        (``data_end`` is the end of the sample when the data run to it).
    to_end : bool
        Whether the data run to the end of the sample (the file goes on past it).
    width : int
        Number of fields in a data row (the commonest count).
    names, header_units : list of str
        Column titles and the units written in them, one per data field.
    row_units : list of str or None
        The units row, one per data field.
    preamble : dict
        Key–value pairs of the preamble.
    comments : list of str
        Comment and banner lines, and preamble lines that are neither.
    trailer : list of str
        Rows after the data (when inside the sample).
    """

    header: int | None
    units: int | None
    data_start: int
    data_end: int
    to_end: bool
    width: int
    names: list[str]
    header_units: list[str]
    row_units: list[str] | None
    preamble: dict[str, str] = field(default_factory=dict)
    comments: list[str] = field(default_factory=list)
    trailer: list[str] = field(default_factory=list)


def _trim(cells: Sequence[str]) -> list[str]:
    out = [c.strip() for c in cells]
    while out and out[-1] == "":
        out.pop()
    return out


def _is_comment(raw: str) -> bool:
    return bool(_COMMENT.match(raw))


def _is_separator(raw: str) -> bool:
    s = raw.strip()
    return len(s) >= 3 and bool(_SEPARATOR_ROW.match(s)) and any(c in s for c in "_-=*~")


def is_data(cells: Sequence[str]) -> bool:
    """A row that looks like data: the first cell a number, date or time, most cells numbers."""
    c = _trim(cells)
    if not c or not c[0]:
        # a leading blank cell (gauge exports pad the point number): look at the rest
        c = [x for x in c if x]
        if not c:
            return False
    kinds = [cell_kind(x) for x in c if x]
    if kinds[0] not in _NUMERICISH:
        return False
    numeric = sum(k in _NUMERICISH for k in kinds)
    if len(kinds) == 1:
        return False
    # a remark row (time stamp + free text) still belongs to the data
    return numeric >= 1 and (numeric / len(kinds) >= 0.5 or len(kinds) == 2)


def _unit_like(cell: str) -> bool:
    s = cell.strip()
    if not s:
        return True
    if _FORMAT_SPEC.match(s):
        return True
    if field_unit_kind(s) is not None:
        return True
    if s.startswith(("(", "[")) and s.endswith((")", "]")):
        return True
    low = s.lower()
    return low in _OTHER_UNITS or bool(
        re.match(r"^(deg|°|º)\s*[cf]$", low)) or field_unit_kind(low.replace(" ", "")) is not None


#: Units of columns the reader does not use (proppant, additives, ...), so that a units row
#: holding them is still seen as a units row.
_OTHER_UNITS = frozenset(["-", "none", "unitless", "%", "#", "ppa", "ppg", "lb/gal", "lbm",
                          "lbs", "lb", "kg", "t", "sacks", "sx", "ppt", "gpt", "cp", "mpa.s",
                          "m", "ft", "rpm", "in", "mm", "kw", "hp", "v", "ma", "a", "api",
                          "lbm/gal", "kg/m3", "ppm", "mg/l", "ntu", "frac", "fraction", "ratio",
                          "count", "n", "bool", "sec/qt", "s/qt", "lb/mgal", "gal/mgal",
                          "l/m3", "kg/t", "°", "deg", "hz", "min/h"])


def _units_row_like(cells: Sequence[str]) -> bool:
    """Most cells are units (and the rest empty): a units row, even with units the reader
    has no use for."""
    c = [x for x in cells if x.strip()]
    if not c:
        return False
    known = sum(_unit_like(x) for x in c)
    return known == len(c) or (known >= 0.6 * len(c) and not any(
        cell_kind(x) in ("num", "numc") for x in c))


def _text_like(cells: Sequence[str]) -> bool:
    c = [x for x in _trim(cells) if x]
    if not c:
        return False
    return sum(cell_kind(x) == "text" for x in c) >= max(1, (len(c) + 1) // 2)


def split_name_unit(title: str) -> tuple[str, str]:
    """``"Pressure (psi)"``, ``"Pressure [bar]"``, ``"Time, min"``, ``"Rate bpm"`` ->
    ``(name, unit)``; ``(title, "")`` when no unit is written."""
    t = title.strip()
    m = _UNIT_IN_BRACKETS.match(t)
    if m and m.group("name").strip():
        return m.group("name").strip(), m.group("unit").strip()
    m = _UNIT_AFTER_COMMA.match(t)
    if m and _unit_like(m.group("unit")) and m.group("unit").strip():
        return m.group("name").strip(), m.group("unit").strip()
    parts = t.rsplit(None, 1)
    if len(parts) == 2 and field_unit_kind(parts[1]) is not None:
        return parts[0].strip(), parts[1].strip()
    # "Pressure psi absolute", "Pressure psi(a)"
    m = re.match(r"^(?P<name>.+?)\s+(?P<unit>\S+\s+(absolute|abs|gauge))$", t, re.IGNORECASE)
    if m and field_unit_kind(m.group("unit")) is not None:
        return m.group("name").strip(), m.group("unit").strip()
    return t, ""


def _preamble_pairs(cells: Sequence[str], raw: str, out: dict[str, str]) -> bool:
    """Key–value pairs of one preamble row; True if any was found."""
    f = [x.strip() for x in cells if x.strip()]
    found = False
    k = 0
    while k < len(f):
        x = f[k]
        if x.endswith(":") and k + 1 < len(f) and not f[k + 1].endswith(":"):
            out[x[:-1].strip()] = f[k + 1]
            k += 2
            found = True
            continue
        if ":" in x and not re.match(r"^\d", x):
            a, b = x.split(":", 1)
            out[a.strip()] = b.strip()
            found = True
        elif "=" in x:
            a, b = x.split("=", 1)
            if a.strip():
                out[a.strip()] = b.strip()
                found = True
        k += 1
    if not found:
        # "tinj 520", "Well  AMS-01": a name and one value
        m = re.match(r"^\s*([A-Za-z_][\w .\-/()]*?)\s+([-+]?[\w.,:/\-]+(\s+\S+)?)\s*$", raw)
        # a value is one word, or holds a number ("2450 m"); a title line is no pair
        if m and len(raw.split()) <= 4 and (m.group(3) is None or re.match(r"[-+]?\d", m.group(2))):
            out[m.group(1).strip()] = m.group(2).strip()
            found = True
    return found


def sniff_rows(rows: Sequence[Sequence[str]], raws: Sequence[str], lines: Sequence[int], *,
               label: str, complete: bool) -> Layout:
    """Find preamble, header, units row, data and trailer among the first rows.

    Parameters
    ----------
    rows : sequence of sequence of str
        The cells of each row.
    raws : sequence of str
        Each row as one string (comment and separator detection).
    lines : sequence of int
        1-based line (or sheet row) of each row, for errors.
    label : str
        File label for errors.
    complete : bool
        Whether ``rows`` hold the whole file (else the data may run past the end).

    Raises
    ------
    InputError
        If no data rows are found, or the header and the data rows disagree.
    """
    n = len(rows)
    flags = []
    for cells, raw in zip(rows, raws):
        if not raw.strip() or not any(c.strip() for c in cells):
            flags.append("blank")
        elif _is_comment(raw):
            flags.append("comment")
        elif _is_separator(raw):
            flags.append("sep")
        elif is_data(cells):
            flags.append("data")
        else:
            flags.append("other")
    # runs of data rows (blank rows inside a run allowed), by the width of their rows
    runs: list[tuple[int, int, int]] = []
    i = 0
    while i < n:
        if flags[i] != "data":
            i += 1
            continue
        j = i
        last = i
        count = 0
        while j < n and flags[j] in ("data", "blank"):
            if flags[j] == "data":
                last = j
                count += 1
            j += 1
        runs.append((i, last + 1, count))
        i = j
    if not runs:
        where = next((lines[k] for k in range(n) if flags[k] == "other"), lines[0] if n else 1)
        raise InputError("no data rows found (a row of numbers under a header)", file=label,
                         line=where, expected="a header row followed by rows of numbers")
    if not complete and runs[-1][1] >= n - 2:
        best = runs[-1]
        to_end = True
    else:
        best = max(runs, key=lambda r: r[2])
        to_end = not complete and best[1] >= n - 2
    a, b, _ = best
    widths = [len(_trim(rows[k])) for k in range(a, b) if flags[k] == "data"]
    width = max(set(widths), key=widths.count)
    # header and units row above the data
    k = a - 1
    while k >= 0 and flags[k] in ("sep", "blank"):
        k -= 1
    header = units = None
    if k >= 0 and flags[k] == "other":
        above = k - 1
        while above >= 0 and flags[above] in ("sep", "blank"):
            above -= 1
        cells_k = _trim(rows[k])
        if (_units_row_like(cells_k) and above >= 0 and flags[above] == "other"
                and _text_like(rows[above])
                and not _units_row_like(_trim(rows[above]))):
            units, header = k, above
        elif _text_like(rows[k]) or all(_unit_like(c) for c in cells_k):
            header = k
    # header blocks repeated inside the data (cementing units repeat them): the data go on
    if header is not None:
        hset = sorted(c.lower() for c in _trim(rows[header]) if c)
        while True:
            k = b
            while k < n and flags[k] == "blank":
                k += 1
            if k >= n or sorted(c.strip().lower() for c in rows[k] if c.strip()) != hset:
                break
            nxt = next((r for r in runs if r[0] > k), None)
            if nxt is None:
                break
            b = nxt[1]
            to_end = not complete and b >= n - 2
    # trailing columns left empty in every row (a "Note" or "Comment" column): the rows
    # still have the cells, so the header's width holds
    if header is not None:
        hw = len(_trim(rows[header]))
        raw_w = max(len(rows[k]) for k in range(a, b) if flags[k] == "data")
        if width < hw <= raw_w:
            width = hw
    # preamble: everything above the header
    top = header if header is not None else a
    preamble: dict[str, str] = {}
    comments: list[str] = []
    for r in range(top):
        if flags[r] in ("blank", "sep"):
            continue
        raw = raws[r].strip()
        if flags[r] == "comment":
            text = raw.lstrip("#*;/!% ").rstrip("* ").strip()
            # a comment holds a pair only as "Key: value" with a word for a key
            m = re.match(r"^([A-Za-z][A-Za-z _.\-/()]*?)\s*[:=]\s*(\S.*)$", text)
            if m:
                preamble[m.group(1).strip()] = m.group(2).strip()
            elif text:
                comments.append(text)
            continue
        if not _preamble_pairs(rows[r], raw, preamble):
            comments.append(raw)
    trailer = [raws[r] for r in range(b, n) if flags[r] != "blank"] if not to_end else []
    names, hunits, runits = _columns(rows, header, units, width, lines, label, a)
    return Layout(header, units, a, b, to_end, width, names, hunits, runits, preamble,
                  comments, trailer)


def _group_titles(cells: Sequence[str], width: int) -> list[str] | None:
    """Header cells regrouped into ``width`` titles, each a name followed by its unit.

    A header whose separator also stands between a name and its unit gives more cells than
    the data have values; every cell that is a unit closes the title it follows. None when
    that does not give one title per value, or when a title would have no name.
    """
    groups: list[list[str]] = []
    closed = True
    for c in cells:
        is_unit = bool(c) and (field_unit_kind(c) is not None or (
            c.startswith(("(", "[")) and c.endswith((")", "]"))))
        if is_unit and groups and not closed:
            groups[-1].append(f"({c.strip('()[]')})")
            closed = True
        elif is_unit:
            return None
        elif closed:
            groups.append([c])
            closed = False
        else:
            groups[-1].append(c)
    if len(groups) != width:
        return None
    return [" ".join(g) for g in groups]


def _columns(rows, header, units, width, lines, label, a):
    """Titles and units per data field (header padding with empty cells dropped)."""
    if header is None:
        return [f"column {j + 1}" for j in range(width)], [""] * width, None
    h = _trim(rows[header])
    if len(h) != width:
        kept = [c for c in h if c]
        if len(kept) == width:
            pos = [j for j, c in enumerate(h) if c]
        elif len(h) < width and all(not c for r in rows[a:a + 20] for c in _trim(r)[len(h):]):
            pos = list(range(len(h)))
        elif len(h) == width - 1 or len(kept) == width - 1:
            # a date and a clock time in two fields under one title ("Time")
            pos = [j for j, c in enumerate(h) if c] if len(kept) == width - 1 else \
                list(range(len(h)))
        elif (grouped := _group_titles(kept, width)
              or _group_titles([w for c in kept for w in c.split()], width)) is not None:
            # titles split at the separator between name and unit ("Time s Pressure bar"
            # with single spaces, an unquoted "Time, min,Pressure, psi")
            h, pos = grouped, list(range(width))
        else:
            raise InputError(f"the header has {len(kept)} titles but the data rows have "
                             f"{width} values", file=label, line=lines[header],
                             expected="one title per column (separate the titles by a tab "
                                      "or two spaces, or quote them)")
    else:
        pos = list(range(width))
    titles = [h[j] for j in pos]
    if any(not t for t in titles):
        j = titles.index("")
        raise InputError(f"header column {j + 1} has no title", file=label,
                         line=lines[header], expected="a title for every column")
    names, hunits = zip(*(split_name_unit(t) for t in titles))
    names, hunits = list(names), list(hunits)
    runits = None
    if units is not None:
        u = _trim(rows[units])
        uraw = [c.strip() for c in rows[units]]
        if len(uraw) >= len(h) and all(not uraw[j] or (j < len(h) and h[j]) for j in
                                       range(len(uraw))):
            runits = [uraw[j] if j < len(uraw) else "" for j in pos]
        else:
            tokens = [c for c in u if c]
            if len(tokens) > len(names):
                raise InputError(f"the units row has more entries than the header ({tokens})",
                                 file=label, line=lines[units], expected=f"units for {names}")
            # units stand under the value columns, which are the last ones: align right
            runits = [""] * (len(names) - len(tokens)) + tokens
    if len(names) == width - 1:
        # the date+clock pair: split the timestamp title into two fields
        j = next((k for k, r in enumerate(_trim(rows[a])) if cell_kind(r) == "date"), None)
        if j is None or j >= len(names):
            raise InputError(f"the header has {len(names)} titles but the data rows have "
                             f"{width} values", file=label, line=lines[header],
                             expected="one title per column")
        names.insert(j + 1, names[j] + " (clock)")
        hunits.insert(j + 1, "")
        if runits is not None:
            runits.insert(j + 1, "")
    return names, hunits, runits


def sample_decimal(rows: Sequence[Sequence[str]], sep: str) -> str | None:
    """``","`` when the data cells use decimal commas, ``"."`` for points, None if neither
    shows (only integers, or commas that could be thousands separators)."""
    comma = point = 0
    for r in rows:
        for c in r:
            s = c.strip()
            if sep != "," and NUM_COMMA_STRICT.match(s):
                comma += 1
            elif NUM_POINT.match(s) and "." in s:
                point += 1
    if comma and not point:
        return ","
    if point:
        return "."
    return None
