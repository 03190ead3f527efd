"""Column names: the synonyms table, the roles a column can play, and the user's choices.

A *role* is what a column means for the record: ``time``, ``pressure`` (the main pressure),
``surface_pressure`` (the second pressure of a pair: the surface reading when the main one is
downhole), ``rate``, ``volume``, ``return_rate``, ``return_volume``, ``density``,
``temperature``, plus ``timestamp`` / ``date`` / ``clock`` for the time columns. Names are
matched after :func:`norm_name` (lower case, accents and punctuation removed).
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from xlotkit.errors import InputError

__all__ = ["ROLES", "ROLE_KIND", "ColumnChoice", "ReadOptions", "norm_name", "parse_assignments",
           "sanitize", "synonym"]

#: Roles a user can assign with ``--column ROLE=NAME`` / ``--unit ROLE=UNIT``, and the kind of
#: unit each one needs.
ROLE_KIND = {
    "time": "time",
    "pressure": "pressure",
    "surface_pressure": "pressure",
    "rate": "rate",
    "volume": "volume",
    "return_rate": "rate",
    "return_volume": "volume",
    "density": "density",
    "temperature": "temperature",
}
ROLES = tuple(ROLE_KIND)
#: Other spellings of roles accepted on the command line.
_ROLE_ALIASES = {"pressure2": "surface_pressure", "second_pressure": "surface_pressure",
                 "p": "pressure", "q": "rate", "t": "time"}


def norm_name(name: str) -> str:
    """Lower case, accents dropped, punctuation to spaces: ``"Débit-Inj."`` -> ``"debit inj"``."""
    s = unicodedata.normalize("NFKD", str(name))
    s = "".join(c for c in s if not unicodedata.combining(c)).lower()
    return " ".join(re.sub(r"[^0-9a-z\u0400-\u04ff]+", " ", s).split())


def sanitize(name: str) -> str:
    """Channel name from a column title: ``"RDA2 IN1"`` -> ``"rda2_in1"``."""
    s = re.sub(r"[^0-9a-z]+", "_", str(name).lower()).strip("_")
    return s or "column"


def _words(*names: str) -> list[str]:
    return [norm_name(n) for n in names]


# Roles by normalised name. Pressures carry where they were measured: ``pressure`` at
# surface, ``pressure@downhole`` downhole; annulus and return pressures are channels.
_SYNONYMS: dict[str, str] = {
    **dict.fromkeys(_words(
        "pressure", "treating pressure", "treating press", "treating pres", "treat pressure",
        "pump pressure", "surface pressure", "standpipe pressure", "spp", "p", "press", "pres",
        "tubing pressure", "tubing press", "injection pressure", "inj pressure",
        "wellhead pressure", "well head pressure", "whp", "thp", "tubing head pressure",
        "wht pressure", "surface treating pressure", "stp", "pump press", "line pressure",
        "frac pressure", "treating pressure 1", "pressure 1", "p1", "casing pressure test",
        # non-English
        "druk", "pompdruk", "druck", "pumpendruck", "pression", "pression de pompage",
        "presion", "presión", "pressao", "pressão", "pressione", "trykk", "tryck", "tryk",
        "давление", "ciśnienie", "cisnienie", "tlak"), "pressure"),
    **dict.fromkeys(_words(
        "downhole pressure", "pressure downhole", "bottomhole pressure", "bottom hole pressure",
        "bh pressure", "bhp", "bh press", "bhp calc", "calc bhp", "calculated bhp",
        "gauge pressure downhole", "dh pressure", "pressure dh", "memory gauge pressure",
        "downhole gauge pressure", "bottom hole press", "bhtp", "p bh", "pbh", "p downhole",
        "druck unten", "pression de fond", "presion de fondo", "bunnhullstrykk",
        "забойное давление"), "pressure@downhole"),
    **dict.fromkeys(_words(
        "annulus", "annulus pressure", "annulus press", "ann pressure", "ann press", "ap",
        "casing pressure", "csg pressure", "csg press", "backside pressure", "backside",
        "ringraumdruck", "annulaire"), "channel:annulus_pressure"),
    **dict.fromkeys(_words(
        "rate", "flow rate", "flowrate", "pump rate", "injection rate", "inj rate", "q",
        "slurry rate", "rate in", "flow", "flow in", "clean rate", "fluid rate", "pumping rate",
        "total rate", "slurry rate 1", "debiet", "pompdebiet", "durchfluss", "forderrate",
        "förderrate", "pumprate", "debit", "débit", "caudal", "vazao", "vazão", "portata",
        "rate inn", "rate inn", "расход", "przeplyw", "przepływ"), "rate"),
    **dict.fromkeys(_words(
        "volume", "pumped volume", "total volume", "cumulative volume", "vol", "pump volume",
        "injected volume", "volume pumped", "volume in", "slurry volume", "clean volume",
        "total slurry", "cum volume", "cumulative slurry", "stage volume", "volumen",
        "gepompt volume", "volume injecte", "volume injecté", "объем", "объём"), "volume"),
    **dict.fromkeys(_words(
        "return rate", "cmt return rate", "flowback rate", "return flow rate", "return flow",
        "returns rate", "rate out", "flow out", "returns", "bleed rate"), "return_rate"),
    **dict.fromkeys(_words(
        "return volume", "return vol", "cmt return volume", "cmt return vol", "returned volume",
        "flowback volume", "returns volume", "bleed volume", "volume out", "bled volume"),
        "return_volume"),
    **dict.fromkeys(_words("density", "fluid density", "mud density", "dens", "mud weight",
                           "slurry density", "dichte", "densite", "densidad"), "density"),
    **dict.fromkeys(_words("temperature", "temp", "gauge temperature", "bht", "temperatur",
                           "temperatura", "température", "температура"), "temperature"),
    **dict.fromkeys(_words(
        "time", "elapsed", "elapsed time", "delta time", "t", "time elapsed", "runtime",
        "time since start", "tijd", "zeit", "temps", "tiempo", "tempo", "tid", "время",
        "test time", "job time", "run time", "elapsed seconds", "seconds", "minutes", "hours",
        "delta t", "dt", "etime", "time from start", "czas", "cas"), "time"),
    **dict.fromkeys(_words(
        "timestamp", "time stamp", "date time", "datetime", "date and time", "date time stamp",
        "date/time", "datum tijd", "datum zeit", "datum uhrzeit", "date heure", "fecha hora",
        "dato tid", "date time utc", "utc time"), "timestamp"),
    **dict.fromkeys(_words("clock time", "clock", "time of day", "hh mm ss", "uhrzeit", "heure",
                           "hora", "klokke", "klok"), "clock"),
    **dict.fromkeys(_words("date", "datum", "fecha", "dato", "дата"), "date"),
    **dict.fromkeys(_words("cmt return press", "cmt return pressure", "return pressure",
                           "return press"), "channel:return_pressure"),
    **dict.fromkeys(_words("cmt return dens", "cmt return density", "return density"),
                    "channel:return_density"),
    **dict.fromkeys(_words("point no", "point", "no", "nr", "index", "sample", "row", "#",
                           "record", "sample no", "point number"), "index"),
}


def synonym(name: str) -> str | None:
    """Role of a column name from the synonyms table (``"pressure@downhole"`` for a
    bottom-hole pressure), or None."""
    return _SYNONYMS.get(norm_name(name))


@dataclass(frozen=True)
class ColumnChoice:
    """A column named by the user: by its title or by its 1-based position."""

    role: str
    name: str

    def matches(self, title: str, position: int) -> bool:
        """Whether the column ``title`` at 1-based ``position`` is the one meant."""
        if self.name.strip().isdigit():
            return int(self.name) == position
        return self.name == title or norm_name(self.name) == norm_name(title)


@dataclass(frozen=True)
class ReadOptions:
    """What the user tells the reader that the file does not say.

    Attributes
    ----------
    columns : tuple of ColumnChoice
        ``--column ROLE=NAME``: the column that plays a role (NAME a title or a 1-based
        column number).
    role_units : Mapping[str, str]
        ``--unit ROLE=UNIT``: the unit of the column playing ROLE (supplies a unit the file
        never states, or corrects one).
    column_units : Mapping[str, str]
        Unit by column title (the Python API's ``units={TITLE: UNIT}``).
    column_fields : Mapping[str, str]
        Field by column title (the Python API's ``column_map={TITLE: FIELD}``).
    sheet : str or int or None
        Workbook sheet by name or 0-based position (``--sheet`` counts from 1).
    date_order : {"DMY", "MDY", "YMD"} or None
        Order of day, month and year in dates the file leaves ambiguous.
    decimal : {".", ","} or None
        Decimal separator where the file leaves it ambiguous (``3,431``).
    strict : bool
        A ``--column`` naming no column of the file is an error (False when several files
        are read together: the choice must then fit one of them).
    """

    columns: tuple[ColumnChoice, ...] = ()
    role_units: Mapping[str, str] = field(default_factory=dict)
    column_units: Mapping[str, str] = field(default_factory=dict)
    column_fields: Mapping[str, str] = field(default_factory=dict)
    sheet: str | int | None = None
    date_order: str | None = None
    decimal: str | None = None
    strict: bool = True


def _role(text: str, flag: str) -> str:
    r = text.strip().lower().replace("-", "_")
    r = _ROLE_ALIASES.get(r, r)
    if r not in ROLE_KIND:
        raise InputError(f"unknown role {text!r}", key=flag,
                         expected="ROLE one of " + ", ".join(ROLES))
    return r


def parse_assignments(items: Sequence[str] | Mapping[str, str] | None, flag: str
                      ) -> dict[str, str]:
    """``["pressure=BH P", "rate=Q"]`` (or a mapping) -> ``{"pressure": "BH P", ...}``.

    Raises
    ------
    InputError
        For an item without ``=``, an unknown role, or a role given twice.
    """
    out: dict[str, str] = {}
    if not items:
        return out
    pairs = items.items() if isinstance(items, Mapping) else []
    if not isinstance(items, Mapping):
        pl = []
        for it in items:
            if "=" not in it:
                raise InputError(f"cannot read {it!r}", key=flag, expected="ROLE=VALUE")
            k, v = it.split("=", 1)
            pl.append((k, v))
        pairs = pl
    for k, v in pairs:
        r = _role(k, flag)
        if r in out:
            raise InputError(f"role {r!r} given twice", key=flag, expected="each role once")
        if not str(v).strip():
            raise InputError(f"empty value for {r}", key=flag, expected="ROLE=VALUE")
        out[r] = str(v).strip()
    return out
