"""Range checks of configuration values (the ground floor).

One function, :func:`check_range`, that every configuration dataclass of the simulator
(the schedule's phases, the completion, the fluid column, the lumped and well-coupling
scenes) uses to refuse a value with one :class:`~xlotkit.errors.InputError` naming the key,
the value and the allowed range.
"""

from __future__ import annotations

import math
from typing import Any

from xlotkit.errors import InputError

__all__ = ["check_range", "range_text"]


def check_range(key: str, value: Any, *, lo: float | None = None, hi: float | None = None,
                lo_open: bool = False, hi_open: bool = False,
                allow_none: bool = False, unit: str = "") -> None:
    """Raise :class:`InputError` naming ``key`` unless ``lo <= value <= hi`` (finite number).

    ``lo_open``/``hi_open`` make the bound strict; ``allow_none`` accepts None (absent);
    ``unit`` (the SI unit of the value) is named in the allowed range.
    """
    if value is None:
        if allow_none:
            return
        raise InputError("is required", key=key,
                         expected=range_text(lo, hi, lo_open, hi_open, unit))
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"must be a number, got {value!r}", key=key,
                         expected=range_text(lo, hi, lo_open, hi_open, unit))
    v = float(value)
    bad = not math.isfinite(v)
    if lo is not None and (v < lo or (lo_open and v == lo)):
        bad = True
    if hi is not None and (v > hi or (hi_open and v == hi)):
        bad = True
    if bad:
        shown = f"{value!r}" + (f" {unit}" if unit else "")
        raise InputError(f"value {shown} is out of range", key=key,
                         expected=range_text(lo, hi, lo_open, hi_open, unit))


def range_text(lo: float | None, hi: float | None, lo_open: bool = False,
               hi_open: bool = False, unit: str = "") -> str:
    """``"a number in (0, 1] m^3/s"``-style description of a range."""
    u = f" {unit}" if unit else ""
    if lo is None and hi is None:
        return "a finite number" + u
    if hi is None:
        return f"a number {'>' if lo_open else '>='} {lo:g}{u}"
    if lo is None:
        return f"a number {'<' if hi_open else '<='} {hi:g}{u}"
    return (f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}"
            f"{')' if hi_open else ']'}{u}")
