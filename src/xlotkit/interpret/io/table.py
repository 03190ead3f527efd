"""The table a layout parser hands to the assembler: cells not yet interpreted."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from xlotkit.record import Event

__all__ = ["Table"]


@dataclass
class Table:
    """Columns of cells and where they came from.

    Attributes
    ----------
    label : str
        How errors name the file (``path``, or ``path[Sheet]`` for a workbook).
    source : str
        File name recorded in the record's provenance.
    path : Path
    names : list of str
        Column titles without the unit.
    header_units, row_units : list of str
        Unit written in the title, and in the units row (None without one).
    header_line, units_line : int or None
        1-based lines (sheet rows) of the header and of the units row.
    data : list of pandas.Series
        One per column, as parsed (float where pandas could, object otherwise).
    lines : ndarray of int
        Line (sheet row) of every data row.
    decimal : str or None
        Decimal separator of the file where it showed one.
    meta : dict
        Preamble, comments, trailer and family-specific items.
    titles : list of str
        The header cells as written (for recognising a repeated header).
    family : str
        ``"csv"``, ``"cementing_unit"``, ``"downhole_gauge"``, ``"workbook"``.
    date_hint : str or None
        Date order the layout fixes (``"MDY"`` for ``mm:dd:yyyy``).
    canonical : bool
        The canonical xlotkit layout (``# xlotkit-log``).
    raw_head : list of str
        The lines above the header (preamble, canonical ``# key: value`` lines).
    events : list of Event
        Remarks found by the layout parser itself.
    """

    label: str
    source: str
    path: Path
    names: list[str]
    header_units: list[str]
    row_units: list[str] | None
    header_line: int | None
    units_line: int | None
    data: list[pd.Series]
    lines: np.ndarray
    decimal: str | None
    meta: dict[str, Any]
    titles: list[str]
    canonical: bool = False
    raw_head: list[str] = field(default_factory=list)
    family: str = "csv"
    date_hint: str | None = None
    events: list[Event] = field(default_factory=list)
