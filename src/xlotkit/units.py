"""Unit handling at the edges of the package (readers, CLI, plots), built on pint.

Everything inside xlotkit is SI. Field logs write units the way service companies do
(``bars``, ``l/min``, ``sgu``, ``m3``, ``psi absolute``, ``bpm``, ``°C``); :func:`parse_unit`
normalises those spellings to pint expressions and :func:`to_si` converts values. Spellings
pint cannot understand raise :class:`~xlotkit.errors.InputError`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from xlotkit.errors import InputError

__all__ = ["FIELD_UNITS", "GRAVITY", "ParsedUnit", "field_unit_kind", "from_si", "parse_unit",
           "registry", "same_unit", "to_si"]

#: Standard gravity [m/s^2] (the one definition: the well model and the stress
#: conversions must use the same hydrostatic gradient).
GRAVITY = 9.80665

# Oilfield spellings -> pint expressions. Only the spelling is translated here; the conversion
# factors all come from pint's definitions.
_ALIASES = {
    "bars": "bar",
    "barg": "bar",
    "bara": "bar",
    "psia": "psi",
    "psig": "psi",
    "kpa": "kPa",
    "mpa": "MPa",
    "pa": "Pa",
    "sgu": "sg",
    "sg": "sg",
    "s.g.": "sg",
    "ppg": "lb/gallon",
    "lb/gal": "lb/gallon",
    "m3": "m**3",
    "m^3": "m**3",
    "m³": "m**3",
    "m3/min": "m**3/min",
    "m3/s": "m**3/s",
    "m3/h": "m**3/hour",
    "m3/hr": "m**3/hour",
    "l/min": "liter/minute",
    "lpm": "liter/minute",
    "l/s": "liter/second",
    "liters": "liter",
    "litre": "liter",
    "l": "liter",
    "bpm": "oil_barrel/minute",
    "bbl/min": "oil_barrel/minute",
    "bbl": "oil_barrel",
    "gpm": "gallon/minute",
    "gal": "gallon",
    "°c": "degC",
    "ºc": "degC",
    "degc": "degC",
    "c": "degC",
    "deg c": "degC",
    "°f": "degF",
    "deg f": "degF",
    "ºf": "degF",
    "degf": "degF",
    "f": "degF",
    "k": "kelvin",
    "s": "second",
    "sec": "second",
    "secs": "second",
    "seconds": "second",
    "min": "minute",
    "mins": "minute",
    "minutes": "minute",
    "h": "hour",
    "hr": "hour",
    "hrs": "hour",
    "hours": "hour",
    "kg/m3": "kg/m**3",
    "g/cc": "g/cm**3",
    "g/cm3": "g/cm**3",
    "m": "meter",
    "ft": "foot",
    # pressure units of the field (technical atmosphere = kgf/cm2)
    "atm": "atmosphere",
    "at": "technical_atmosphere",
    "ata": "technical_atmosphere",
    "atü": "technical_atmosphere",
    "kgf/cm2": "kilogram_force/centimeter**2",
    "kgf/cm²": "kilogram_force/centimeter**2",
    "kg/cm2": "kilogram_force/centimeter**2",
    "kg/cm²": "kilogram_force/centimeter**2",
    "kgf/cm^2": "kilogram_force/centimeter**2",
    "mbar": "millibar",
    "hpa": "hectopascal",
    "gpa": "gigapascal",
    "ksi": "ksi",
    "psi": "psi",
    "bar": "bar",
    "pascal": "Pa",
    # viscosity (pint's "cp" is a cup)
    "cp": "centipoise",
    # rates
    "m3/d": "m**3/day",
    "m³/min": "m**3/min",
    "m³/h": "m**3/hour",
    "m³/s": "m**3/s",
    "m^3/min": "m**3/min",
    "m^3/h": "m**3/hour",
    "l/mn": "liter/minute",
    "l/h": "liter/hour",
    "lps": "liter/second",
    "gal/min": "gallon/minute",
    "usgpm": "gallon/minute",
    "bbl/d": "oil_barrel/day",
    "bpd": "oil_barrel/day",
    "bbl/h": "oil_barrel/hour",
    "bbls": "oil_barrel",
    "bbl/m": "oil_barrel/minute",
    "gallons": "gallon",
    "usgal": "gallon",
    "dm3": "liter",
    "litres": "liter",
    "liters/min": "liter/minute",
    "litres/min": "liter/minute",
    # time
    "hour": "hour",
    "minute": "minute",
    "second": "second",
    "d": "day",
    "day": "day",
    "days": "day",
    "ms": "millisecond",
}

#: Units the field writes, by kind: the only spellings a reader accepts as the last word of a
#: header (``Pressure psi``), where a pint unit such as ``P`` (poise) or ``at`` could
#: otherwise be mistaken for part of a name. Lower case, after absolute/gauge markers are
#: removed.
FIELD_UNITS = {
    "pressure": ("pa", "kpa", "mpa", "gpa", "hpa", "bar", "bars", "bara", "barg", "mbar", "psi",
                 "psia", "psig", "ksi", "atm", "at", "ata", "kgf/cm2", "kgf/cm²", "kg/cm2",
                 "kg/cm²", "kgf/cm^2"),
    "rate": ("bpm", "bbl/min", "bbl/m", "l/min", "lpm", "l/s", "lps", "l/h", "m3/min", "m3/h",
             "m3/hr", "m3/s", "m3/d", "m³/min", "m³/h", "m³/s", "m^3/min", "m^3/h", "gpm",
             "gal/min", "usgpm", "bpd", "bbl/d", "bbl/h", "l/mn"),
    "volume": ("m3", "m^3", "m³", "l", "liters", "litres", "litre", "bbl", "bbls", "gal",
               "gallons", "usgal", "dm3"),
    "time": ("s", "sec", "secs", "seconds", "min", "mins", "minutes", "h", "hr", "hrs",
             "hours", "d", "day", "days", "ms"),
    "temperature": ("°c", "ºc", "degc", "deg c", "°f", "ºf", "degf", "deg f", "k"),
    "density": ("sg", "sgu", "s.g.", "ppg", "lb/gal", "kg/m3", "g/cc", "g/cm3"),
}
_FIELD_UNIT_KIND = {u: k for k, us in FIELD_UNITS.items() for u in us}


def field_unit_kind(text: str) -> str | None:
    """The kind (``"pressure"``, ``"rate"``, ...) of a unit the field writes, else None.

    ``text`` may carry an absolute/gauge marker (``psi absolute``, ``bar(g)``, ``psia``).
    Only spellings in :data:`FIELD_UNITS` count: this decides whether the last word of a
    header is a unit.
    """
    s = re.sub(r"\((a|g|abs|gauge)\)\s*[\])]?$", "", text.strip().lower()).strip()
    s = s.strip("[]()").strip()
    m = _SPACED_MARK.match(s)
    if m:
        s = m.group(1)
    s = re.sub(r"\b(absolute|abs|gauge|gage)\b", "", s).strip()
    return _FIELD_UNIT_KIND.get(s)


# A pressure unit with its absolute/gauge mark as a separate letter ("psi g", "bar a").
_SPACED_MARK = re.compile(r"^(psi|bar|kpa|mpa|atm|at|kgf/cm2|kg/cm2)\s+([ag])$", re.IGNORECASE)

# Markers of absolute / gauge pressure written next to the unit.
_ABS_RE = re.compile(r"\b(absolute|abs)\b|^(psia|bara|ata)$", re.IGNORECASE)
_GAUGE_RE = re.compile(r"\b(gauge|gage|g)\b|^(psig|barg|atü)$", re.IGNORECASE)


#: SI conversions of the spellings above, ``expr: (scale, offset, kind)`` with
#: ``SI = scale * value + offset``: pint's own numbers, written out so that reading a log in
#: field units does not wait for pint's registry (half a second) to be built. The test
#: ``tests/interpret/test_io_units.py`` checks every entry against pint, bit for bit; any
#: other unit goes to pint itself.
_FAST_SI: dict[str, tuple[float, float, str]] = {
    'MPa': (1000000.0, 0.0, 'pressure'),
    'Pa': (1.0, 0.0, 'pressure'),
    'atmosphere': (101325.0, 0.0, 'pressure'),
    'bar': (100000.0, 0.0, 'pressure'),
    'day': (86400.0, 0.0, 'time'),
    'degC': (1.0, 273.15, 'temperature'),
    'degF': (0.5555555555555556, 255.37222222222223, 'temperature'),
    'dimensionless': (1.0, 0.0, 'dimensionless'),
    'foot': (0.30479999999999996, 0.0, 'length'),
    'g/cm**3': (999.9999999999999, 0.0, 'density'),
    'gallon': (0.0037854117839999993, 0.0, 'volume'),
    'gallon/minute': (6.309019639999999e-05, 0.0, 'rate'),
    'gigapascal': (1000000000.0, 0.0, 'pressure'),
    'hectopascal': (100.0, 0.0, 'pressure'),
    'hour': (3600.0, 0.0, 'time'),
    'kPa': (1000.0, 0.0, 'pressure'),
    'kelvin': (1.0, 0.0, 'temperature'),
    'kg/m**3': (1.0, 0.0, 'density'),
    'kilogram_force/centimeter**2': (98066.5, 0.0, 'pressure'),
    'ksi': (6894757.293168363, 0.0, 'pressure'),
    'lb/gallon': (119.82642731689667, 0.0, 'density'),
    'liter': (0.0010000000000000002, 0.0, 'volume'),
    'liter/hour': (2.7777777777777787e-07, 0.0, 'rate'),
    'liter/minute': (1.666666666666667e-05, 0.0, 'rate'),
    'liter/second': (0.0010000000000000002, 0.0, 'rate'),
    'm**3': (1.0, 0.0, 'volume'),
    'm**3/day': (1.1574074074074073e-05, 0.0, 'rate'),
    'm**3/hour': (0.0002777777777777778, 0.0, 'rate'),
    'm**3/min': (0.016666666666666666, 0.0, 'rate'),
    'm**3/s': (1.0, 0.0, 'rate'),
    'meter': (1.0, 0.0, 'length'),
    'millibar': (100.0, 0.0, 'pressure'),
    'millisecond': (0.001, 0.0, 'time'),
    'minute': (60.0, 0.0, 'time'),
    'oil_barrel': (0.15898729492799996, 0.0, 'volume'),
    'oil_barrel/day': (1.8401307283333327e-06, 0.0, 'rate'),
    'oil_barrel/hour': (4.416313747999999e-05, 0.0, 'rate'),
    'oil_barrel/minute': (0.0026497882487999994, 0.0, 'rate'),
    'psi': (6894.7572931683635, 0.0, 'pressure'),
    'second': (1.0, 0.0, 'time'),
    'sg': (1000.0, 0.0, 'density'),
    'technical_atmosphere': (98066.5, 0.0, 'pressure'),

}


@lru_cache(maxsize=1)
def registry():
    """The package's pint :class:`~pint.UnitRegistry` (created on first use).

    Adds ``sg`` (specific gravity, 1000 kg/m^3 of fresh water) which pint lacks.
    """
    import pint

    ureg = pint.UnitRegistry(autoconvert_offset_to_baseunit=True)
    ureg.define("specific_gravity = 1000 * kilogram / meter ** 3 = sg")
    return ureg


@dataclass(frozen=True)
class ParsedUnit:
    """A unit string as found in a file, understood.

    Attributes
    ----------
    text : str
        The original spelling.
    expr : str
        The pint expression it maps to.
    absolute : bool or None
        For pressures: True if marked absolute, False if marked gauge, None if unmarked.
    """

    text: str
    expr: str
    absolute: bool | None = None

    @property
    def unit(self):
        """The pint unit."""
        return registry().Unit(self.expr)

    @property
    def dimensionality(self):
        """pint dimensionality (``[mass] / [length] / [time] ** 2`` for pressure, ...)."""
        return self.unit.dimensionality

    def is_a(self, kind: str) -> bool:
        """Whether this unit measures ``kind``.

        ``kind`` is one of ``pressure``, ``rate``, ``volume``, ``density``,
        ``temperature``, ``time``, ``length``, ``dimensionless``.
        """
        if self.expr in _FAST_SI:
            return _FAST_SI[self.expr][2] == kind
        ref = {
            "pressure": "Pa",
            "rate": "m**3/s",
            "volume": "m**3",
            "density": "kg/m**3",
            "temperature": "kelvin",
            "time": "second",
            "length": "meter",
            "dimensionless": "dimensionless",
        }[kind]
        return self.dimensionality == registry().Unit(ref).dimensionality


def parse_unit(text: str, *, file: str | None = None, line: int | None = None,
               key: str | None = None, exact_case: bool = False) -> ParsedUnit:
    """Understand a unit as written in a log (see :func:`_parse_unit`); cached.

    ``exact_case=True`` (scene files, where a unit is typed by hand and its case is the
    only difference between a millipascal and a megapascal) refuses a spelling that the
    field-spelling table reads differently from what its case says in SI: ``"mPa"``
    (millipascal as written, megapascal as a log's ``mpa``), ``"Mbar"``.
    """
    try:
        pu = _parse_unit_cached(text)
        if exact_case:
            _check_case(text, pu)
        return pu
    except InputError as exc:
        raise InputError(exc.message, file=file, line=line, key=key,
                         expected=exc.expected) from None


@lru_cache(maxsize=512)
def _parse_unit_cached(text: str) -> ParsedUnit:
    return _parse_unit(text)


@lru_cache(maxsize=512)
def _literal_scale(text: str) -> tuple[float, object] | None:
    """``(SI scale, dimensionality)`` of ``text`` read by pint exactly as written, or None
    when pint does not know the spelling."""
    ureg = registry()
    try:
        q = ureg.Quantity(1.0, text).to_base_units()
    except Exception:  # noqa: BLE001 -- pint raises many kinds on an unknown spelling
        return None
    return float(q.magnitude), q.dimensionality


def _check_case(text: str, pu: ParsedUnit) -> None:
    """Refuse a unit whose case says one SI unit and whose field spelling another."""
    s = re.sub(r"\b(absolute|abs|gauge|gage)\b", "", text, flags=re.IGNORECASE)
    s = s.strip().strip("[]()").strip()
    if not s or s == pu.expr:
        return
    lit = _literal_scale(s)
    if lit is None or pu.expr == "dimensionless":
        return
    scale, dim = lit
    if dim != pu.dimensionality:
        return           # e.g. "h" (Planck's constant to pint, an hour here): no doubt
    ours = _si_affine(pu.expr)[0]
    if abs(scale - ours) <= 1e-9 * max(abs(scale), abs(ours)):
        return
    ureg = registry()
    as_written, meant = str(ureg.Unit(s)), str(ureg.Unit(pu.expr))
    symbol = f"{ureg.Unit(pu.expr):~}"
    raise InputError(
        f"unit {s!r} is ambiguous: in SI case it is {as_written}, as field logs write it "
        f"{meant}",
        expected=f"'{symbol}' for {meant} (the SI case), or the unit's full name")


def _parse_unit(text: str, *, file: str | None = None, line: int | None = None,
                key: str | None = None) -> ParsedUnit:
    """Understand a unit as written in a log.

    Parameters
    ----------
    text : str
        E.g. ``"bars"``, ``"l/min"``, ``"psi absolute"``, ``"°C"``, ``"(bpm)"``.
    file, line, key : optional
        Location reported if the unit is not understood.

    Returns
    -------
    ParsedUnit

    Raises
    ------
    InputError
        If pint cannot interpret the unit.
    """

    raw = text
    s = text.strip()
    m = re.match(r"^[\[(]?\s*(.*?)\s*\((a|g|abs|gauge)\)\s*[\])]?$", s, re.IGNORECASE)
    if m:                      # "psi(a)", "bar (g)", "[psi(g)]"
        s = m.group(1).strip() + (" absolute" if m.group(2).lower() in ("a", "abs") else
                                  " gauge")
    s = s.strip("[]()").strip()
    m = _SPACED_MARK.match(s)
    if m:                      # "psi g", "bar a"
        s = m.group(1) + (" absolute" if m.group(2).lower() == "a" else " gauge")
    absolute: bool | None = None
    if _ABS_RE.search(s):
        absolute = True
    elif _GAUGE_RE.search(s) and s.lower() not in ("g/cc", "g/cm3", "g"):
        absolute = False
    s = re.sub(r"\b(absolute|abs|gauge|gage)\b", "", s, flags=re.IGNORECASE).strip()
    low = s.lower()
    if low in ("", "-", "none", "dimensionless", "1"):
        return ParsedUnit(raw, "dimensionless", None)
    expr = _ALIASES.get(low, s)
    if expr in _FAST_SI:
        return ParsedUnit(raw, expr, absolute)
    try:
        registry().Unit(expr)
    except Exception as exc:  # noqa: BLE001 -- pint raises many kinds (TokenError, ...) on garbage
        raise InputError(f"unit {raw!r} is not understood ({exc.__class__.__name__})",
                         file=file, line=line, key=key,
                         expected="a unit such as bar, psi, MPa, l/min, bpm, m3, sg, degC") from None
    return ParsedUnit(raw, expr, absolute)


def to_si(values, unit: str | ParsedUnit) -> np.ndarray:
    """Convert values from ``unit`` to SI base units.

    Parameters
    ----------
    values : array_like
        Numbers in ``unit``.
    unit : str or ParsedUnit
        Source unit (field spellings accepted, see :func:`parse_unit`).

    Returns
    -------
    ndarray
        Values in SI (Pa, m^3/s, m^3, kg/m^3, K, s, m).
    """
    pu = unit if isinstance(unit, ParsedUnit) else parse_unit(unit)
    scale, offset = _si_affine(pu.expr)
    v = np.asarray(values, dtype=float)
    # the factors are pint's (cached per unit): SI = scale * value + offset
    return v * scale + offset if offset else v * scale


def from_si(values, unit: str | ParsedUnit, *, fast: bool = False) -> np.ndarray:
    """Convert SI values to ``unit`` (the inverse of :func:`to_si`).

    ``fast=True`` divides by the tabulated factor instead of asking pint (which multiplies
    by its inverse: the two can differ in the last bit); for numbers only shown rounded.
    """
    pu = unit if isinstance(unit, ParsedUnit) else parse_unit(unit)
    if fast and pu.expr in _FAST_SI:
        scale, offset, _ = _FAST_SI[pu.expr]
        return (np.asarray(values, dtype=float) - offset) / scale
    ureg = registry()
    base = ureg.Quantity(1.0, pu.expr).to_base_units().units
    q = ureg.Quantity(np.asarray(values, dtype=float), base)
    return np.asarray(q.to(pu.expr).magnitude, dtype=float)


@lru_cache(maxsize=256)
def _si_affine(expr: str) -> tuple[float, float]:
    """``(scale, offset)`` with ``SI = scale * value + offset`` for a pint expression."""
    if expr in _FAST_SI:
        return _FAST_SI[expr][:2]
    return _pint_affine(expr)


def _pint_affine(expr: str) -> tuple[float, float]:
    """``(scale, offset)`` computed by pint (offset units: the scale of their degree)."""
    ureg = registry()
    zero = float(ureg.Quantity(0.0, expr).to_base_units().magnitude)
    if zero != 0.0:
        try:
            scale = float(ureg.Quantity(1.0, "delta_" + expr).to_base_units().magnitude)
        except Exception:  # noqa: BLE001 -- no delta unit: fall back to the difference
            scale = float(ureg.Quantity(1.0, expr).to_base_units().magnitude) - zero
        return scale, zero
    return float(ureg.Quantity(1.0, expr).to_base_units().magnitude), 0.0


def same_unit(a: ParsedUnit, b: ParsedUnit) -> bool:
    """Whether two spellings mean the same unit (same conversion to SI, same abs/gauge mark).

    An unmarked pressure agrees with a marked one (``psi`` and ``psi absolute``).
    """
    if a.expr in _FAST_SI and b.expr in _FAST_SI:
        if _FAST_SI[a.expr][2] != _FAST_SI[b.expr][2]:
            return False
    elif a.dimensionality != b.dimensionality:
        return False
    sa, oa = _si_affine(a.expr)
    sb, ob = _si_affine(b.expr)
    if abs(sa - sb) > 1e-12 * max(abs(sa), abs(sb)) or abs(oa - ob) > 1e-9 * max(1.0, abs(oa)):
        return False
    return a.absolute is None or b.absolute is None or a.absolute == b.absolute
