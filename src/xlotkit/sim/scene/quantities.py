"""Values of a scene file in SI: numbers, ``"value unit"`` strings, angles, permeabilities.

A number without a unit is SI (angles: degrees); a string carries its unit (``"2000 m"``,
``"500 l/min"``, ``"35 MPa"``, ``"1.2 sg"``, ``"10 cP"``, ``"1 mD"``, ``"30 deg"``), read
with :mod:`xlotkit.units`. Every failure is one :class:`~xlotkit.errors.InputError` naming
the key.
"""

from __future__ import annotations

import math
from datetime import datetime
from typing import Any

from xlotkit.errors import InputError
from xlotkit.sim.schedule import _NUM_UNIT, parse_quantity

__all__ = ["angle", "convert", "permeability", "quantity"]

_STD_KINDS = ("pressure", "rate", "volume", "density", "time", "length", "dimensionless")

_DARCY = 9.869233e-13
_PERM_UNITS = {"d": _DARCY, "darcy": _DARCY, "md": 1e-3 * _DARCY, "millidarcy": 1e-3 * _DARCY,
               "ud": 1e-6 * _DARCY, "µd": 1e-6 * _DARCY, "μd": 1e-6 * _DARCY,
               "microdarcy": 1e-6 * _DARCY, "nd": 1e-9 * _DARCY, "nanodarcy": 1e-9 * _DARCY}


def quantity(value: Any, dim: str, key: str) -> float:
    """SI value of a number or ``"value unit"`` string of dimension ``dim``."""
    if dim in _STD_KINDS:
        return parse_quantity(value, dim, key=key)
    from xlotkit.units import parse_unit, registry, to_si

    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise InputError(f"must be a number or a 'value unit' string, got {value!r}",
                         key=key, expected=f"a number in SI ({dim}) or e.g. '1 {dim}'")
    if not isinstance(value, str):
        return float(value)
    m = _NUM_UNIT.match(value)
    if not m:
        raise InputError(f"cannot read {value!r}", key=key, expected=f"e.g. '1 {dim}'")
    num, unit = float(m.group(1)), m.group(2)
    if not unit:
        return num
    pu = parse_unit(unit, key=key, exact_case=True)
    if pu.dimensionality != registry().Unit(dim).dimensionality:
        raise InputError(f"unit {unit!r} has the wrong dimension", key=key,
                         expected=f"a unit of the dimension of {dim}")
    return float(to_si([num], pu)[0])


def convert(value: Any, kind: Any, key: str) -> Any:
    if kind is str:
        if not isinstance(value, str):
            raise InputError(f"must be a string, got {value!r}", key=key, expected="a string")
        return value.strip().lower()
    if kind is bool:
        if not isinstance(value, bool):
            raise InputError(f"must be true or false, got {value!r}", key=key,
                             expected="true or false")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"must be an integer, got {value!r}", key=key,
                             expected="an integer")
        return value
    if kind is datetime:
        if isinstance(value, datetime):
            return value
        try:
            return datetime.fromisoformat(str(value))
        except ValueError:
            raise InputError(f"cannot read {value!r} as a date-time", key=key,
                             expected="an ISO 8601 date-time, e.g. 2014-03-01T08:00:00") \
                from None
    return quantity(value, kind, key)


def angle(raw: Any, key: str) -> float:
    """Degrees from a number (degrees) or ``"30 deg"`` / ``"0.5 rad"``."""
    if isinstance(raw, bool):
        raise InputError(f"must be an angle, got {raw!r}", key=key, expected="e.g. '30 deg'")
    if isinstance(raw, (int, float)):
        return float(raw)
    m = _NUM_UNIT.match(str(raw))
    if not m:
        raise InputError(f"cannot read {raw!r}", key=key, expected="e.g. '30 deg'")
    num, unit = float(m.group(1)), m.group(2).strip().lower()
    if unit in ("", "deg", "degree", "degrees", "°"):
        return num
    if unit in ("rad", "radian", "radians"):
        return math.degrees(num)
    raise InputError(f"unit {unit!r} is not an angle unit", key=key,
                     expected="deg or rad, e.g. '30 deg'")


def permeability(raw: Any, key: str) -> float:
    """m^2 from a number (m^2) or ``"1 mD"``, ``"50 nD"``, ``"1e-18 m**2"``."""
    if isinstance(raw, str):
        m = _NUM_UNIT.match(raw)
        unit = m.group(2).strip() if m else ""
        if unit.lower() in _PERM_UNITS:
            if unit[:1] == "M":
                # "MD" is a megadarcy in SI case and a millidarcy as the field writes it
                raise InputError(f"unit {unit!r} is ambiguous: in SI case it is a "
                                 "megadarcy, as the field writes it a millidarcy", key=key,
                                 expected="'mD' for millidarcy (the SI case)")
            return float(m.group(1)) * _PERM_UNITS[unit.lower()]
    return quantity(raw, "m**2", key)
