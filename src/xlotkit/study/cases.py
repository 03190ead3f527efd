"""The cases of a sweep: ``--vary`` specifications, the grid, Latin-hypercube samples, and
dotted-key overrides applied to a scene file's TOML mapping before it is validated.

A ``--vary`` is ``KEY=V1,V2,...`` (a list) or ``KEY=LOW:HIGH`` / ``KEY=LOW:HIGH:log`` (a
range). ``KEY`` is a dotted scene key as in a scene file: ``stresses.sigma_h``,
``rock.permeability``, ``seed``, or with a 0-based index into an array of tables,
``schedule.phase[1].rate``. A value is read as a TOML value (``1e-18``, ``true``, ``3``,
``"a string"``), and anything that is not one is taken as the string it is, so values carry
units exactly as in a scene file: ``28MPa``, ``"300 bar"``, ``1 mD``, ``500 l/min``.

Without ``samples`` the lists make a full grid (:func:`grid`: the first ``--vary`` varies
slowest). With ``samples = N`` (:func:`sample`) N cases are drawn by Latin-hypercube
sampling: the unit interval of every varied key is cut into N equal strata, each stratum is
used by exactly one case, the strata are matched across keys by independent random
permutations, and each case sits at a uniform random point within its stratum. A range maps
the unit interval linearly onto ``[LOW, HIGH]`` (``:log``: log-uniformly, for a
permeability over decades); a list in a sampled study is a discrete choice, its N strata
shared evenly among the values. The draws come from ``numpy.random.default_rng(seed)``, so
the same ``seed`` gives the same cases (the Latin hypercube is three lines of NumPy here,
not scipy.stats.qmc, whose random stream and keyword have changed between versions).

:class:`BaseScene` applies a case's overrides to a deep copy of the scene file's mapping and
validates the result with :func:`xlotkit.sim.scene.scene_from_dict`, so a bad key or value
gives one :class:`~xlotkit.errors.InputError` naming it (and ``--vary``).
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from xlotkit.errors import InputError

__all__ = [
    "BaseScene",
    "Case",
    "KeyPath",
    "Span",
    "Variation",
    "grid",
    "parse_key",
    "parse_vary",
    "sample",
]

_FLAG = "--vary"
_NAME = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)$")
_INDEX = re.compile(r"\[(\d+)\]")
# a number and an optional unit that starts with a letter (so that a date-time is no range)
_NUM_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*"
                       r"([A-Za-zµμ°%][^:]*?)?\s*$")


# --------------------------------------------------------------------------- keys
@dataclass(frozen=True)
class KeyPath:
    """A dotted scene key.

    Attributes
    ----------
    text : str
        As given: ``stresses.sigma_h``, ``schedule.phase[1].rate``.
    parts : tuple of (str or int)
        Table names and 0-based array indices, in order.
    """

    text: str
    parts: tuple[str | int, ...]

    def get(self, mapping: Mapping[str, Any]) -> Any:
        """The value at this key in a TOML mapping, or None where there is none."""
        node: Any = mapping
        for p in self.parts:
            if isinstance(p, int):
                if not isinstance(node, list) or p >= len(node):
                    return None
                node = node[p]
            else:
                if not isinstance(node, Mapping) or p not in node:
                    return None
                node = node[p]
        return node

    def set(self, mapping: dict[str, Any], value: Any) -> None:
        """Set the value in a TOML mapping (in place); tables that are missing are made.

        Raises
        ------
        InputError
            When the path runs through a value that is not a table or array of tables, or
            an index is past the end of its array.
        """
        node: Any = mapping
        where: list[str] = []
        for p, nxt in zip(self.parts, (*self.parts[1:], None)):
            last = nxt is None
            if isinstance(p, int):
                shown = "".join(where)
                if not isinstance(node, list):
                    raise InputError(f"{shown} is not an array of tables", key=_FLAG,
                                     expected=f"an index only after an array such as "
                                              f"schedule.phase (in {self.text!r})")
                if p >= len(node):
                    raise InputError(f"index {p} is past the end of {shown} "
                                     f"({len(node)} entries)", key=_FLAG,
                                     expected=f"0 to {len(node) - 1} (in {self.text!r})")
                where.append(f"[{p}]")
                if last:
                    node[p] = value
                else:
                    node = node[p]
                continue
            where.append(("." if where else "") + p)
            if not isinstance(node, dict):
                raise InputError(f"{''.join(where[:-1])} is a value, not a table", key=_FLAG,
                                 expected=f"a key inside a table (in {self.text!r})")
            if last:
                node[p] = value
            else:
                if p not in node:
                    if isinstance(nxt, int):
                        raise InputError(f"the scene has no array {''.join(where)}",
                                         key=_FLAG, expected=f"an array of tables the "
                                                             f"scene file has (in "
                                                             f"{self.text!r})")
                    node[p] = {}
                node = node[p]


def parse_key(text: str) -> KeyPath:
    """Read a dotted scene key (``rock.permeability``, ``schedule.phase[1].rate``).

    Raises
    ------
    InputError
        When a part is not a name, optionally followed by ``[INDEX]``.
    """
    text = text.strip()
    parts: list[str | int] = []
    for piece in text.split("."):
        m = _NAME.match(piece)
        if not m:
            raise InputError(f"cannot read the key {text!r}", key=_FLAG,
                             expected="a dotted scene key such as stresses.sigma_h or "
                                      "schedule.phase[1].rate")
        parts.append(m.group(1))
        parts.extend(int(i) for i in _INDEX.findall(m.group(2)))
    return KeyPath(text, tuple(parts))


# --------------------------------------------------------------------------- variations
@dataclass(frozen=True)
class Span:
    """A range ``LOW:HIGH`` of a sampled key, in one unit.

    Attributes
    ----------
    low, high : float
        Ends, in ``unit``.
    unit : str
        The unit as written after LOW ('' for a plain number).
    log : bool
        Log-uniform (``:log``): both ends > 0.
    """

    low: float
    high: float
    unit: str
    log: bool = False

    def at(self, u: float) -> str | float:
        """The value at fraction ``u`` in [0, 1) of the range, as a scene value."""
        if self.log:
            x = math.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        else:
            x = self.low + u * (self.high - self.low)
        return f"{x!r} {self.unit}" if self.unit else x


@dataclass(frozen=True)
class Variation:
    """One ``--vary``: a key and either a list of values or a range.

    Attributes
    ----------
    key : KeyPath
    values : tuple
        TOML values of a list (empty for a range).
    span : Span or None
        The range (None for a list).
    text : str
        The ``--vary`` as given.
    """

    key: KeyPath
    values: tuple[Any, ...] = ()
    span: Span | None = None
    text: str = ""

    def __post_init__(self) -> None:
        if (self.span is None) == (not self.values):
            raise InputError("give either a list of values or one range", key=_FLAG,
                             expected=f"KEY=V1,V2,... or KEY=LOW:HIGH (in {self.text!r})")

    def choose(self, u: float) -> Any:
        """The value at fraction ``u`` in [0, 1) (a sampled case)."""
        if self.span is not None:
            return self.span.at(u)
        return self.values[min(int(u * len(self.values)), len(self.values) - 1)]


def _toml_value(text: str) -> Any:
    """A TOML value (number, boolean, quoted string, date-time), or the text itself."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def _unit_factor(unit: str, to: str, vary: str) -> float:
    """Factor from ``unit`` to ``to`` (the two ends of a range written in different units)."""
    from xlotkit.units import registry

    ureg = registry()
    try:
        return float(ureg.Quantity(1.0, unit).to(to).magnitude)
    except Exception:  # pint raises several kinds for spellings it does not know
        raise InputError(f"cannot convert {unit!r} to {to!r}", key=_FLAG,
                         expected=f"both ends of the range in one unit (in {vary!r})") from None


def _span(rhs: str, vary: str) -> Span | None:
    """The range of ``LOW:HIGH[:log]``, or None when ``rhs`` is no range."""
    pieces = rhs.split(":")
    log = False
    if len(pieces) == 3 and pieces[2].strip().lower() in ("log", "lin"):
        log = pieces[2].strip().lower() == "log"
        pieces = pieces[:2]
    if len(pieces) != 2:
        return None
    ends = [_NUM_UNIT.match(p) for p in pieces]
    if not all(ends):
        return None
    lo, hi = (float(m.group(1)) for m in ends)
    ulo, uhi = ((m.group(2) or "").strip() for m in ends)
    unit = ulo or uhi
    if ulo and uhi and ulo != uhi:
        hi *= _unit_factor(uhi, ulo, vary)
    if not (math.isfinite(lo) and math.isfinite(hi)) or not lo < hi:
        raise InputError(f"the range {rhs!r} is empty", key=_FLAG,
                         expected=f"LOW < HIGH (in {vary!r})")
    if log and lo <= 0:
        raise InputError(f"a log range needs LOW > 0, got {rhs!r}", key=_FLAG,
                         expected=f"LOW:HIGH:log with 0 < LOW < HIGH (in {vary!r})")
    return Span(lo, hi, unit, log)


def parse_vary(text: str) -> Variation:
    """Read one ``--vary KEY=V1,V2,...`` or ``--vary KEY=LOW:HIGH[:log]``.

    Raises
    ------
    InputError
        Naming ``--vary`` and what could not be read.
    """
    if "=" not in text:
        raise InputError(f"cannot read {text!r}", key=_FLAG,
                         expected="KEY=V1,V2,... or KEY=LOW:HIGH")
    key_text, rhs = text.split("=", 1)
    key = parse_key(key_text)
    rhs = rhs.strip()
    if not rhs:
        raise InputError(f"no values for {key.text}", key=_FLAG,
                         expected="KEY=V1,V2,... or KEY=LOW:HIGH")
    span = _span(rhs, text) if "," not in rhs else None
    if span is not None:
        return Variation(key, span=span, text=text)
    raw = [v.strip() for v in rhs.split(",")]
    if any(not v for v in raw):
        raise InputError(f"an empty value in {rhs!r}", key=_FLAG,
                         expected=f"values separated by single commas (in {text!r})")
    return Variation(key, values=tuple(_toml_value(v) for v in raw), text=text)


# --------------------------------------------------------------------------- cases
@dataclass(frozen=True)
class Case:
    """One case of a study: its position and the values it gives the varied keys.

    Attributes
    ----------
    index : int
        0-based position in the study.
    overrides : tuple of (KeyPath, value)
        In the order of the ``--vary`` options.
    """

    index: int
    overrides: tuple[tuple[KeyPath, Any], ...]

    def inputs(self) -> dict[str, Any]:
        """The overrides as ``{key text: value}``."""
        return {k.text: v for k, v in self.overrides}


def _check_keys(variations: Sequence[Variation]) -> None:
    seen: set[str] = set()
    for v in variations:
        if v.key.text in seen:
            raise InputError(f"{v.key.text} is varied twice", key=_FLAG,
                             expected="each key in one --vary")
        seen.add(v.key.text)


def grid(variations: Sequence[Variation]) -> list[Case]:
    """Every combination of the lists (the first variation varies slowest).

    Raises
    ------
    InputError
        If a variation is a range (ranges need ``samples``) or a key is varied twice.
    """
    _check_keys(variations)
    for v in variations:
        if v.span is not None:
            raise InputError(f"{v.key.text} is a range, which is sampled", key=_FLAG,
                             expected="KEY=V1,V2,... for a grid, or --samples N to draw "
                                      f"from the range (in {v.text!r})")
    combos = itertools.product(*(v.values for v in variations)) if variations else [()]
    return [Case(i, tuple((v.key, x) for v, x in zip(variations, combo)))
            for i, combo in enumerate(combos)]


def latin_hypercube(n: int, d: int, seed: int) -> np.ndarray:
    """``n`` points in ``[0, 1)^d``, one in each of the ``n`` strata of every axis.

    Returns
    -------
    ndarray, shape (n, d)
    """
    rng = np.random.default_rng(seed)
    u = np.empty((n, d))
    for j in range(d):
        u[:, j] = (rng.permutation(n) + rng.random(n)) / n
    return u


def sample(variations: Sequence[Variation], n: int, seed: int) -> list[Case]:
    """``n`` cases drawn by Latin-hypercube sampling (module docstring).

    Raises
    ------
    InputError
        If ``n`` < 1, ``seed`` < 0, no key is varied or a key is varied twice.
    """
    if n < 1:
        raise InputError(f"{n} samples", key="--samples", expected="an integer >= 1")
    if seed < 0:
        raise InputError(f"seed {seed} is negative", key="--seed", expected="an integer >= 0")
    if not variations:
        raise InputError("nothing to sample", key=_FLAG,
                         expected="at least one --vary KEY=LOW:HIGH with --samples")
    _check_keys(variations)
    u = latin_hypercube(n, len(variations), seed)
    return [Case(i, tuple((v.key, v.choose(float(u[i, j])))
                          for j, v in enumerate(variations)))
            for i in range(n)]


# --------------------------------------------------------------------------- scenes
@dataclass(frozen=True)
class BaseScene:
    """A scene file read as TOML, to which cases apply their overrides.

    Attributes
    ----------
    file : str
        The scene file (named in errors; relative ``mesh.file`` paths are taken from its
        folder).
    mapping : Mapping
        Its parsed TOML.
    sha256 : str
        Hash of the file's bytes.
    """

    file: str
    mapping: Mapping[str, Any]
    sha256: str

    @classmethod
    def load(cls, path: str | Path) -> BaseScene:
        """Read and validate a scene file (as :func:`xlotkit.sim.scene.load_scene` does).

        Raises
        ------
        InputError
            If the file cannot be read, is not TOML, or is not a valid scene.
        """
        from xlotkit.sim.scene import load_scene

        load_scene(path)            # one error naming the file, line and key
        raw = Path(path).read_bytes()
        mapping = tomllib.loads(raw.decode("utf-8"))
        return cls(str(path), mapping, hashlib.sha256(raw).hexdigest())

    def case_mapping(self, case: Case) -> dict[str, Any]:
        """A deep copy of the scene's mapping with the case's overrides applied."""
        data = copy.deepcopy(dict(self.mapping))
        for key, value in case.overrides:
            key.set(data, value)
        return data

    def scene(self, case: Case):
        """The validated :class:`~xlotkit.sim.scene.Scene` of a case.

        Raises
        ------
        InputError
            Naming the scene file, ``--vary`` and the key when an override is not a valid
            scene key or value.
        """
        return scene_of(self.case_mapping(case), self.file, case)


def scene_of(mapping: Mapping[str, Any], file: str, case: Case | None = None):
    """Validate a case's mapping (:func:`xlotkit.sim.scene.scene_from_dict`); an error
    about a varied key is reported as ``--vary KEY`` with the value the case gave it."""
    from xlotkit.sim.scene import scene_from_dict

    try:
        return scene_from_dict(mapping, file=file)
    except InputError as exc:
        if case is None:
            raise
        given = case.inputs()
        ek = exc.key or ""
        hit = next((k for k in given if ek == k or ek.startswith(k + ".")
                    or _base(k) == ek), None)
        if hit is None:
            shown = ", ".join(f"{k} = {v!r}" for k, v in given.items())
            raise InputError(f"{exc.message} (case {case.index}: {shown})" if given
                             else exc.message, file=file, line=exc.line, key=exc.key,
                             expected=exc.expected) from None
        raise InputError(f"{exc.message} (case {case.index}: {hit} = {given[hit]!r})",
                         file=file, key=f"{_FLAG} {ek}", expected=exc.expected) from None


def _base(key: str) -> str:
    """A key without its array indices (the scene names ``schedule.phase`` errors so)."""
    return _INDEX.sub("", key)
