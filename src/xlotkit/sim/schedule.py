"""The test program: pump, shut-in, flowback and bleed phases, grouped into cycles.

Shared by the lumped model and the 2D simulator, so it only describes *what the operator
does*; each simulator decides how to honour it. All values are SI (m^3/s, s, m^3, Pa); field
units appear only in :meth:`Schedule.from_dict`, which accepts ``"500 l/min"``-style strings
(parsed with :mod:`xlotkit.units`) and is what a TOML scene file maps to.

Phases
------
* :class:`Pump` — constant ``rate`` or stepped ``steps = ((duration, rate), ...)``.
* :class:`ShutIn` — well closed, no flow at surface.
* :class:`Flowback` — return through a fixed surface choke, ``Q = zeta sqrt(p_s - p_atm)``
  (thesis Eq. 4.24); ``zeta`` given, or calibrated from ``initial_rate`` at the surface
  pressure the phase starts with.
* :class:`Bleed` — return at constant ``rate``.

Each phase ends at the first of: its ``duration`` or its ``volume`` (pumped for
:class:`Pump`, returned for :class:`Flowback` / :class:`Bleed`; one of the two, not both);
the pressure rising to ``pressure_above`` or falling to ``pressure_below`` (measured at
``pressure_at``: ``"bottomhole"`` or ``"surface"``, gauge). A stepped pump with no
``duration`` ends with its last step. Every phase needs at least one end condition. A
pressure end that cannot be met is refused: statically, a return phase's
``pressure_below`` at or above the ``pressure_above`` the pump before it stops at (same
gauge); in a run, a phase whose pressure end is met when it starts
(:meth:`xlotkit.sim.well.WellDrive.begin`).

Numbers are SI and must be plausible for a leak-off test (rates up to 0.1 m^3/s, volumes
up to 100 m^3): a number without a unit is read in SI, so ``rate = 500`` meant as l/min is
refused, not pumped at 500 m^3/s.

What a phase does at the well head is answered by the phase itself (``pumps``,
``through_choke``, ``pump_rate(tau)``, ``fixed_return_rate``, ``breakpoints()``,
``time_to_volume(v)``, ``volume_done(...)``, ``ends_when_dead``), so a simulator needs no
dispatch on the phase types; :class:`xlotkit.sim.well.WellDrive` turns them, with the well's
column and choke, into the rates and end tests every engine asks for.

Cycles: the phase list is run ``cycles`` times; within it a new cycle starts at every pump
phase that follows a non-pump phase (an XLOT cycle is a pressurisation and what follows);
phases before the first pump (the well at rest before the test) belong to the first cycle.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Literal, Union

from xlotkit.errors import InputError
from xlotkit.checks import check_range as _check
from xlotkit.units import parse_unit, to_si

__all__ = ["Bleed", "Flowback", "Phase", "PressureAt", "Pump", "Schedule", "ShutIn",
           "parse_quantity"]

PressureAt = Literal["bottomhole", "surface"]

#: Plausible bounds of a leak-off or step-rate test, in SI (a number without a unit is SI,
#: so they also catch a unit left out: ``rate = 500`` meant as l/min, ``rate = 0.5`` as
#: m^3/min). A cementing unit or a rig pump delivers up to a few m^3/min: 0.1 m^3/s
#: (6 m^3/min, 38 bpm) is above any XLOT or mini-frac; an XLOT pumps litres to a few m^3:
#: 100 m^3 is above any.
_MAX_RATE = 0.1          # m^3/s (6 m^3/min)
_MAX_DURATION = 30 * 86400.0
_MAX_VOLUME = 100.0      # m^3
_MAX_PRESSURE = 500e6    # Pa
#: A choke coefficient of 1e-4 m^3 s^-1 Pa^-1/2 returns 0.3 m^3/s at 10 MPa: above any
#: choke (300 l/min at 5 MPa is 2.2e-6).
_MAX_ZETA = 1e-4


@dataclass(frozen=True, kw_only=True)
class _PhaseBase:
    """End conditions common to all phases (see module docstring)."""

    kind: ClassVar[str] = ""
    #: The phase pumps fluid into the well (a cycle starts at a pump phase).
    pumps: ClassVar[bool] = False
    #: The well returns through the surface choke (the rate follows the surface pressure).
    through_choke: ClassVar[bool] = False
    #: The phase ends when the surface pressure is gone (a bleed cannot draw a vacuum).
    ends_when_dead: ClassVar[bool] = False
    duration: float | None = None
    pressure_above: float | None = None
    pressure_below: float | None = None
    pressure_at: PressureAt = "bottomhole"
    name: str = ""

    def _validate_common(self) -> None:
        k = self.kind
        _check(f"{k}.duration", self.duration, lo=0.0, hi=_MAX_DURATION, lo_open=True,
               allow_none=True, unit="s")
        _check(f"{k}.pressure_above", self.pressure_above, lo=-1e6, hi=_MAX_PRESSURE,
               allow_none=True, unit="Pa")
        _check(f"{k}.pressure_below", self.pressure_below, lo=-1e6, hi=_MAX_PRESSURE,
               allow_none=True, unit="Pa")
        if self.pressure_at not in ("bottomhole", "surface"):
            raise InputError(f"unknown pressure reference {self.pressure_at!r}",
                             key=f"{k}.pressure_at", expected="'bottomhole' or 'surface'")
        if (self.pressure_above is not None and self.pressure_below is not None
                and self.pressure_below >= self.pressure_above):
            raise InputError("pressure_below must be lower than pressure_above",
                             key=f"{k}.pressure_below",
                             expected=f"a pressure < {self.pressure_above:g} Pa")

    def _volume_or_duration(self, volume: float | None) -> None:
        """A phase ends at its volume or at its duration, not at whichever comes first of
        the two: given both, one of them is a wrong expectation of the other (a pressure
        limit may be added to either)."""
        if volume is not None and self.duration is not None:
            raise InputError(
                f"both volume ({volume:g} m^3) and duration ({self.duration:g} s) are given",
                key=f"{self.kind}.volume",
                expected="one of volume and duration (the rate sets the other)")

    def _require_end(self, *extra: Any) -> None:
        conds = (self.duration, self.pressure_above, self.pressure_below, *extra)
        if all(c is None for c in conds):
            raise InputError("phase has no end condition", key=f"{self.kind}",
                             expected="duration, volume, pressure_above or pressure_below")

    @property
    def label(self) -> str:
        """``name`` or the phase kind."""
        return self.name or self.kind

    @property
    def volume_target(self) -> float | None:
        """Volume end condition [m^3] (pumped or returned), None if there is none."""
        return getattr(self, "volume", None)

    @property
    def max_duration(self) -> float | None:
        """Duration limit [s] or None."""
        return None if self.duration is None else float(self.duration)

    @property
    def fixed_return_rate(self) -> float:
        """Return rate at surface that does not depend on the pressure [m^3/s] (a bleed's
        rate; 0 for the other phases, the choke's rate being the well's)."""
        return 0.0

    def pump_rate(self, tau: float) -> float:
        """Pump rate [m^3/s] at time ``tau`` [s] into the phase (0 unless it pumps)."""
        return 0.0

    def breakpoints(self) -> tuple[float, ...]:
        """Times [s] into the phase where a rate set by the phase changes."""
        return ()

    def time_to_volume(self, volume: float) -> float | None:
        """Time [s] into the phase at which ``volume`` [m^3] has been metered, when the
        phase's rate does not depend on the pressure; None when it does (a flowback:
        the volume end is then located as an event) or the phase meters nothing."""
        return None

    def volume_done(self, pumped: float, returned: float) -> float:
        """The volume [m^3] this phase's volume end meters, from the volumes pumped and
        returned since the phase began: the pumped volume for a pump phase, else the
        returned one."""
        return pumped if self.pumps else returned


@dataclass(frozen=True)
class Pump(_PhaseBase):
    """Pump into the well at a constant or stepped rate.

    Parameters
    ----------
    rate : float, optional
        Constant pump rate [m^3/s] (> 0). Exactly one of ``rate`` / ``steps``.
    steps : sequence of (duration, rate), optional
        Stepped rate: ``rate_i`` [m^3/s] for ``duration_i`` [s], in order. Without an explicit
        ``duration`` the phase lasts the sum of the steps; a longer ``duration`` keeps the
        last rate.
    volume : float, optional
        End when this volume [m^3] has been pumped in the phase.
    duration, pressure_above, pressure_below, pressure_at, name
        See the module docstring.
    """

    kind: ClassVar[str] = "pump"
    pumps: ClassVar[bool] = True
    rate: float | None = None
    steps: tuple[tuple[float, float], ...] | None = None
    volume: float | None = None

    def __post_init__(self) -> None:
        if self.steps is not None:
            try:
                steps = tuple((float(d), float(r)) for d, r in self.steps)
            except (TypeError, ValueError):
                raise InputError("steps must be a list of (duration, rate) pairs",
                                 key="pump.steps", expected="[(s, m^3/s), ...]") from None
            object.__setattr__(self, "steps", steps)
        if (self.rate is None) == (self.steps is None):
            raise InputError("give exactly one of rate and steps", key="pump.rate",
                             expected="a constant rate or a list of (duration, rate) steps")
        if self.rate is not None:
            _check("pump.rate", self.rate, lo=0.0, hi=_MAX_RATE, lo_open=True, unit="m^3/s")
        else:
            if not self.steps:
                raise InputError("steps is empty", key="pump.steps",
                                 expected="at least one (duration, rate) pair")
            for i, (d, r) in enumerate(self.steps):
                _check(f"pump.steps[{i}].duration", d, lo=0.0, hi=_MAX_DURATION, lo_open=True,
                       unit="s")
                _check(f"pump.steps[{i}].rate", r, lo=0.0, hi=_MAX_RATE, unit="m^3/s")
            if self.volume is not None:
                raise InputError("a stepped pump lasts its steps (or its duration); a volume "
                                 "would end it at whichever comes first",
                                 key="pump.volume",
                                 expected="no volume with steps (or a constant rate)")
        _check("pump.volume", self.volume, lo=0.0, hi=_MAX_VOLUME, lo_open=True,
               allow_none=True, unit="m^3")
        self._validate_common()
        self._volume_or_duration(self.volume)
        self._require_end(self.volume, self.steps)

    @property
    def max_duration(self) -> float | None:
        """Duration limit [s]: ``duration``, else the sum of the steps, else None."""
        if self.duration is not None:
            return float(self.duration)
        if self.steps is not None:
            return math.fsum(d for d, _ in self.steps)
        return None

    def pump_rate(self, tau: float) -> float:
        """Pump rate [m^3/s] at time ``tau`` [s] into the phase (:meth:`rate_at`)."""
        return self.rate_at(tau)

    def time_to_volume(self, volume: float) -> float:
        """Time [s] into the phase at which ``volume`` [m^3] has been pumped (inf if the
        stepped rate ends at 0 before it)."""
        if self.rate is not None:
            return volume / self.rate
        assert self.steps is not None
        acc_v = acc_t = 0.0
        for d, r in self.steps:
            if r > 0 and acc_v + r * d >= volume:
                return acc_t + (volume - acc_v) / r
            acc_v += r * d
            acc_t += d
        last = self.steps[-1][1]
        return acc_t + (volume - acc_v) / last if last > 0 else math.inf

    def rate_at(self, tau: float) -> float:
        """Pump rate [m^3/s] at time ``tau`` [s] into the phase (right-continuous)."""
        if self.rate is not None:
            return float(self.rate)
        assert self.steps is not None
        acc = 0.0
        for d, r in self.steps:
            acc += d
            if tau < acc:
                return r
        return self.steps[-1][1]

    def breakpoints(self) -> tuple[float, ...]:
        """Times [s] into the phase where the rate changes (step boundaries)."""
        if self.steps is None:
            return ()
        out, acc = [], 0.0
        for d, _ in self.steps[:-1]:
            acc += d
            out.append(acc)
        return tuple(out)


@dataclass(frozen=True, kw_only=True)
class ShutIn(_PhaseBase):
    """Well closed at surface: no pumping, no returns."""

    kind: ClassVar[str] = "shut_in"

    def __post_init__(self) -> None:
        self._validate_common()
        self._require_end()


@dataclass(frozen=True, kw_only=True)
class Flowback(_PhaseBase):
    """Return through a fixed surface choke, ``Q = zeta sqrt(p_choke - p_atm)``.

    Parameters
    ----------
    zeta : float, optional
        Choke coefficient [m^3 s^-1 Pa^-1/2].
    initial_rate : float, optional
        Return rate [m^3/s] at the start of the phase; the simulator calibrates ``zeta`` from
        it and the surface pressure then. Exactly one of ``zeta`` / ``initial_rate``.
    volume : float, optional
        End when this volume [m^3] has returned in the phase.
    """

    kind: ClassVar[str] = "flowback"
    through_choke: ClassVar[bool] = True
    zeta: float | None = None
    initial_rate: float | None = None
    volume: float | None = None

    def __post_init__(self) -> None:
        if (self.zeta is None) == (self.initial_rate is None):
            raise InputError("give exactly one of zeta and initial_rate", key="flowback.zeta",
                             expected="a choke coefficient or an initial return rate")
        _check("flowback.zeta", self.zeta, lo=0.0, hi=_MAX_ZETA, lo_open=True,
               allow_none=True, unit="m^3 s^-1 Pa^-1/2")
        _check("flowback.initial_rate", self.initial_rate, lo=0.0, hi=_MAX_RATE, lo_open=True,
               allow_none=True, unit="m^3/s")
        _check("flowback.volume", self.volume, lo=0.0, hi=_MAX_VOLUME, lo_open=True,
               allow_none=True, unit="m^3")
        self._validate_common()
        self._volume_or_duration(self.volume)
        self._require_end(self.volume)


@dataclass(frozen=True)
class Bleed(_PhaseBase):
    """Return at a constant rate (bleed-off).

    Parameters
    ----------
    rate : float
        Return rate [m^3/s] (> 0).
    volume : float, optional
        End when this volume [m^3] has returned in the phase.
    """

    kind: ClassVar[str] = "bleed"
    ends_when_dead: ClassVar[bool] = True
    rate: float = 0.0
    volume: float | None = None

    def __post_init__(self) -> None:
        _check("bleed.rate", self.rate, lo=0.0, hi=_MAX_RATE, lo_open=True, unit="m^3/s")
        _check("bleed.volume", self.volume, lo=0.0, hi=_MAX_VOLUME, lo_open=True,
               allow_none=True, unit="m^3")
        self._validate_common()
        self._volume_or_duration(self.volume)
        self._require_end(self.volume)

    @property
    def fixed_return_rate(self) -> float:
        """The bleed rate [m^3/s]."""
        return float(self.rate)

    def time_to_volume(self, volume: float) -> float:
        """Time [s] into the phase at which ``volume`` [m^3] has been bled."""
        return volume / self.rate


Phase = Union[Pump, ShutIn, Flowback, Bleed]
_KINDS: dict[str, type] = {"pump": Pump, "shut_in": ShutIn, "shutin": ShutIn,
                           "shut-in": ShutIn, "flowback": Flowback, "flow_back": Flowback,
                           "bleed": Bleed}


@dataclass(frozen=True)
class Schedule:
    """A test program: ``phases`` run ``cycles`` times.

    Parameters
    ----------
    phases : sequence of Phase
        The phases in order (any number of XLOT cycles can be written out here).
    cycles : int
        How many times to run the list (default 1).
    """

    phases: tuple[Phase, ...]
    cycles: int = 1

    def __post_init__(self) -> None:
        phases = tuple(self.phases) if isinstance(self.phases, Sequence) else None
        if not phases:
            raise InputError("schedule has no phases", key="schedule.phases",
                             expected="at least one pump/shut_in/flowback/bleed phase")
        for i, ph in enumerate(phases):
            if not isinstance(ph, (Pump, ShutIn, Flowback, Bleed)):
                raise InputError(f"not a phase: {ph!r}", key=f"schedule.phases[{i}]",
                                 expected="Pump, ShutIn, Flowback or Bleed")
        if isinstance(self.cycles, bool) or not isinstance(self.cycles, int) or not (
                1 <= self.cycles <= 1000):
            raise InputError(f"value {self.cycles!r} is out of range", key="schedule.cycles",
                             expected="an integer in [1, 1000]")
        object.__setattr__(self, "phases", phases)
        self._check_targets()

    def _check_targets(self) -> None:
        """A return phase cannot end at a pressure at or above the one the pump before it
        stops at: the flowback would start below its own target and end at once."""
        stop: tuple[int, float, str] | None = None
        n = len(self.phases)
        for j in range(n * min(self.cycles, 2)):
            i = j % n
            ph = self.phases[i]
            if ph.pumps:
                stop = (None if ph.pressure_above is None
                        else (i, float(ph.pressure_above), ph.pressure_at))
                continue
            if stop is None or ph.pressure_below is None or ph.pressure_at != stop[2]:
                continue
            if ph.pressure_below >= stop[1]:
                raise InputError(
                    f"a {ph.kind} to pressure_below = {ph.pressure_below:g} Pa "
                    f"({ph.pressure_at}) after a pump that stops at pressure_above = "
                    f"{stop[1]:g} Pa (phase[{stop[0]}]) starts below its target",
                    key=f"schedule.phase[{i}].pressure_below",
                    expected=f"a pressure below {stop[1]:g} Pa ({ph.pressure_at})")

    def expanded(self) -> tuple[tuple[int, Phase], ...]:
        """All phases in run order as ``(cycle_number, phase)``; cycles are 1-based."""
        out: list[tuple[int, Phase]] = []
        cyc = 0
        prev: Phase | None = None
        pumped = False        # the current cycle has pumped already
        for _ in range(self.cycles):
            for ph in self.phases:
                if cyc == 0 or (ph.pumps and not (prev is not None and prev.pumps)
                                and pumped):
                    cyc += 1
                    pumped = False
                pumped = pumped or ph.pumps
                out.append((cyc, ph))
                prev = ph
        return tuple(out)

    def __iter__(self) -> Iterator[tuple[int, Phase]]:
        return iter(self.expanded())

    @property
    def n_cycles(self) -> int:
        """Number of XLOT cycles in the expanded program."""
        return self.expanded()[-1][0]

    @property
    def n_phases(self) -> int:
        """Number of phases in the expanded program."""
        return len(self.phases) * self.cycles

    # ------------------------------------------------------------------ dict / TOML
    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, key: str = "schedule") -> Schedule:
        """Build from a mapping (a TOML ``[schedule]`` table), field units allowed.

        Layout::

            cycles = 2                        # optional, default 1
            [[schedule.phase]]                # or "phases"
            kind = "pump"                     # pump | shut_in | flowback | bleed
            rate = "500 l/min"                # numbers are taken as SI
            volume = "1.5 m3"
            pressure_above = "40 MPa"
            [[schedule.phase]]
            kind = "pump"
            steps = [["2 min", "200 l/min"], ["3 min", "500 l/min"]]
            [[schedule.phase]]
            kind = "flowback"
            initial_rate = "200 l/min"        # or zeta = 1.3e-6 (SI)
            pressure_below = "27 MPa"
            pressure_at = "bottomhole"        # or "surface"

        Raises
        ------
        InputError
            Naming the offending key, e.g. ``schedule.phase[2].rate``.
        """
        if not isinstance(data, Mapping):
            raise InputError("must be a table", key=key, expected="a mapping with 'phase'")
        allowed = {"phase", "phases", "cycles"}
        for k in data:
            if k not in allowed:
                raise InputError(f"unknown key {k!r}", key=f"{key}.{k}",
                                 expected=", ".join(sorted(allowed)))
        raw = data.get("phase", data.get("phases"))
        if not isinstance(raw, Sequence) or isinstance(raw, (str, bytes)) or not raw:
            raise InputError("missing or empty phase list", key=f"{key}.phase",
                             expected="a list of phase tables")
        phases = [_phase_from_dict(p, f"{key}.phase[{i}]") for i, p in enumerate(raw)]
        cycles = data.get("cycles", 1)
        if isinstance(cycles, float) and cycles.is_integer():
            cycles = int(cycles)
        try:
            return cls(tuple(phases), cycles)
        except InputError as exc:
            raise _rekey(exc, key, "schedule") from None


_NUM_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def parse_quantity(value: Any, kind: str, *, key: str) -> float:
    """A scalar in SI from a number (taken as SI) or a ``"value unit"`` string.

    Parameters
    ----------
    value : float or str
        E.g. ``0.008``, ``"500 l/min"``, ``"3 bpm"``, ``"40 MPa"``, ``"10 min"``.
    kind : str
        Expected dimension: ``rate``, ``volume``, ``pressure``, ``time``, ``length``, ...
    key : str
        Reported in errors.

    Raises
    ------
    InputError
        If the string cannot be read or has the wrong dimension.
    """
    if isinstance(value, bool):
        raise InputError(f"must be a {kind}, got {value!r}", key=key)
    if isinstance(value, (int, float)):
        return float(value)
    if not isinstance(value, str):
        raise InputError(f"must be a number or a 'value unit' string, got {value!r}", key=key,
                         expected=f"a {kind}, e.g. {_EXAMPLES.get(kind, '1.0')!r}")
    m = _NUM_UNIT.match(value)
    if not m:
        raise InputError(f"cannot read {value!r}", key=key,
                         expected=f"a {kind}, e.g. {_EXAMPLES.get(kind, '1.0')!r}")
    num, unit = float(m.group(1)), m.group(2)
    if not unit:
        return num
    pu = parse_unit(unit, key=key, exact_case=True)
    if not pu.is_a(kind):
        raise InputError(f"unit {unit!r} is not a {kind} unit", key=key,
                         expected=f"a {kind}, e.g. {_EXAMPLES.get(kind, '1.0')!r}")
    return float(to_si([num], pu)[0])


_EXAMPLES = {"rate": "500 l/min", "volume": "1.5 m3", "pressure": "40 MPa",
             "time": "10 min", "length": "2000 m"}

_FIELDS: dict[type, dict[str, str | None]] = {
    Pump: {"rate": "rate", "volume": "volume"},
    ShutIn: {},
    Flowback: {"zeta": None, "initial_rate": "rate", "volume": "volume"},
    Bleed: {"rate": "rate", "volume": "volume"},
}
_COMMON = {"duration": "time", "pressure_above": "pressure", "pressure_below": "pressure"}


def _rekey(exc: InputError, prefix: str, old: str) -> InputError:
    """The same error with key ``old...`` moved under ``prefix`` (``pump.rate`` ->
    ``schedule.phase[0].rate``)."""
    k = exc.key or ""
    if k == old or k.startswith(old + ".") or k.startswith(old + "["):
        k = prefix + k[len(old):]
    return InputError(exc.message, file=exc.file, line=exc.line, key=k,
                      expected=exc.expected)


def _phase_from_dict(d: Any, key: str) -> Phase:
    if not isinstance(d, Mapping):
        raise InputError("must be a table", key=key, expected="a phase table with 'kind'")
    kind = str(d.get("kind", "")).strip().lower()
    cls = _KINDS.get(kind)
    if cls is None:
        raise InputError(f"unknown phase kind {d.get('kind')!r}", key=f"{key}.kind",
                         expected="pump, shut_in, flowback or bleed")
    spec = {**_FIELDS[cls], **_COMMON}
    kw: dict[str, Any] = {}
    for k, v in d.items():
        if k == "kind":
            continue
        if k == "name":
            kw["name"] = str(v)
        elif k == "pressure_at":
            kw["pressure_at"] = str(v).strip().lower()
        elif k == "steps" and cls is Pump:
            if not isinstance(v, Sequence) or isinstance(v, str):
                raise InputError("must be a list of [duration, rate] pairs",
                                 key=f"{key}.steps", expected='[["2 min", "200 l/min"], ...]')
            steps = []
            for i, s in enumerate(v):
                if isinstance(s, Mapping):
                    dur, rate = s.get("duration"), s.get("rate")
                elif isinstance(s, Sequence) and not isinstance(s, str) and len(s) == 2:
                    dur, rate = s
                else:
                    raise InputError("must be a [duration, rate] pair",
                                     key=f"{key}.steps[{i}]",
                                     expected='["2 min", "200 l/min"]')
                steps.append((parse_quantity(dur, "time", key=f"{key}.steps[{i}].duration"),
                              parse_quantity(rate, "rate", key=f"{key}.steps[{i}].rate")))
            kw["steps"] = tuple(steps)
        elif k in spec:
            dim = spec[k]
            kw[k] = float(v) if dim is None and not isinstance(v, str) else (
                parse_quantity(v, dim or "dimensionless", key=f"{key}.{k}"))
        else:
            raise InputError(f"unknown key {k!r} for a {cls.kind} phase", key=f"{key}.{k}",
                             expected=", ".join(sorted([*spec, "name", "pressure_at"]
                                                       + (["steps"] if cls is Pump else []))))
    try:
        return cls(**kw)
    except InputError as exc:
        err = _rekey(exc, key, cls.kind)
        field_ = (err.key or "").removeprefix(key + ".")
        raw = d.get(field_)
        if "out of range" in err.message and raw is not None and not isinstance(raw, str) \
                and spec.get(field_):
            err = InputError(err.message + f" (a number without a unit is read in SI; "
                             f"write e.g. {_EXAMPLES.get(spec[field_], '1.0')!r})",
                             file=err.file, line=err.line, key=err.key,
                             expected=err.expected)
        raise err from None
