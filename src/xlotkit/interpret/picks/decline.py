"""The pump stop of a cycle and the decline after it, as the ISIP and closure picks see it.

Which pump stop
---------------
A cycle can hold several pump phases: the injection, top-ups that keep the pressure up,
stages at different rates. The ISIP and the shut-in closure methods start from **one pump
stop followed by a shut-in** (:func:`stop_pump`), whatever the cycle's kind:

* candidates are the pump phases followed directly by a ``shut_in`` phase;
* of these, the last one that pumped at least half as much as the cycle's largest pump phase
  (volume when the record meters it, else pumping time) -- a top-up is small next to the
  injection it tops up, a stage of a stimulation is not;
* when only smaller pump phases are followed by a shut-in (the injection ran straight into a
  flowback), the last of them.

The decline
-----------
:func:`decline` returns the samples of the shut-in after that stop. A user window
(``--window``) overrides the phase boundaries it crosses: when it reaches past the end of
the shut-in, the phases it reaches into (a "bleed", "flowback" or "idle" label on what the
user reads as the same decline, up to the start of the next pumping) join the decline, and
the decline runs to the end of the last of them. Pumping samples never join a decline: a
window reaching into the next pump phase is cut at its start, and a note says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from xlotkit.interpret.phases import Cycle, Phase
from xlotkit.record import Record

__all__ = ["Decline", "decline", "pump_phases", "shutin_phase", "shutin_time", "stop_pump"]

#: A pump phase counts as the injection (not a top-up) when it pumped at least this
#: fraction of the cycle's largest pump phase.
MAIN_PUMP_FRACTION = 0.5


def pump_phases(cycle: Cycle) -> list[Phase]:
    """The cycle's ``pump`` phases in time order."""
    return [p for p in cycle.phases if p.kind == "pump"]


def _next_phase(cycle: Cycle, ph: Phase) -> Phase | None:
    ph_list = list(cycle.phases)
    k = next((j for j, q in enumerate(ph_list) if q is ph), None)
    if k is None:
        k = next((j for j, q in enumerate(ph_list) if q == ph), None)
    return ph_list[k + 1] if k is not None and k + 1 < len(ph_list) else None


def _size(ph: Phase, by_volume: bool) -> float:
    return ph.pumped_m3 if by_volume else ph.duration


def stop_pump(cycle: Cycle) -> Phase | None:
    """The pump phase whose stop starts the cycle's shut-in analysis (module docstring), or
    None when no pump phase is followed by a shut-in."""
    pumps = pump_phases(cycle)
    if not pumps:
        return None
    by_volume = any(p.pumped_m3 > 0 for p in pumps)
    largest = max(_size(p, by_volume) for p in pumps)
    followed = [p for p in pumps
                if (n := _next_phase(cycle, p)) is not None and n.kind == "shut_in"]
    if not followed:
        return None
    main = [p for p in followed if _size(p, by_volume) >= MAIN_PUMP_FRACTION * largest]
    return (main or followed)[-1]


def shutin_phase(cycle: Cycle) -> Phase | None:
    """The shut-in phase right after the pump stop of :func:`stop_pump`, or None."""
    pump = stop_pump(cycle)
    return None if pump is None else _next_phase(cycle, pump)


def shutin_time(record: Record, cycle: Cycle, shut: Phase) -> float:
    """Time the pumps stopped [s]: half-way between the last pumping and the first shut-in
    sample."""
    pumps = [p for p in pump_phases(cycle) if p.i1 <= shut.i0]
    i = shut.i0
    if pumps and i > 0:
        return 0.5 * (record.t[pumps[-1].i1 - 1] + record.t[i])
    return float(record.t[i])


@dataclass(frozen=True)
class Decline:
    """The decline after a pump stop.

    Attributes
    ----------
    pump : Phase
        The pump phase whose stop starts it.
    phases : tuple of Phase
        The phases it spans: the shut-in, and those a user window reached into.
    i0, i1 : int
        Record samples ``[i0, i1)``.
    t_stop : float
        Pump stop [s].
    next_phase : str
        What ends it: the kind of the phase after it (``"flowback"``, ``"bleed"``,
        ``"pump"``, ``"idle"``) or ``"end of record"``.
    t_next : float
        Time [s] the next phase starts (the last sample's time at the end of the record).
    notes : tuple of str
        Boundaries a user window overrode, or where it was cut.
    """

    pump: Phase
    phases: tuple[Phase, ...]
    i0: int
    i1: int
    t_stop: float
    next_phase: str
    t_next: float
    notes: tuple[str, ...] = ()

    @property
    def overridden(self) -> bool:
        """Whether a user window moved the end of the decline."""
        return len(self.phases) > 1


def decline(record: Record, cycle: Cycle, window: tuple[float, float] | None = None
            ) -> Decline | None:
    """The decline after the cycle's pump stop (:func:`stop_pump`), or None without one.

    Parameters
    ----------
    record : Record
    cycle : Cycle
        May carry, after its own phases, the idle phases that follow it in the record (so
        that a window can reach into them).
    window : (float, float), optional
        User window [s]; the decline is extended over the phases it reaches into (module
        docstring).
    """
    shut = shutin_phase(cycle)
    if shut is None:
        return None
    pump = stop_pump(cycle)
    phases = [shut]
    notes: list[str] = []
    last = shut
    nxt = _next_phase(cycle, shut)
    if window is not None:
        while nxt is not None and window[1] > last.t_end and nxt.t_start <= window[1]:
            if nxt.kind == "pump":
                notes.append(f"the window reaches into the pumping that starts at t = "
                             f"{nxt.t_start:.0f} s; the decline stops there")
                break
            notes.append(f"the window overrides the end of the {last.kind.replace('_', '-')} "
                         f"at t = {last.t_end:.0f} s: the {nxt.kind.replace('_', '-')} after "
                         "it is taken as the same decline")
            phases.append(nxt)
            last = nxt
            nxt = _next_phase(cycle, nxt)
    i1 = last.i1
    if nxt is not None:
        what, t_next = nxt.kind, float(nxt.t_start)
    elif i1 >= record.n:
        what, t_next = "end of record", float(record.t[-1])
    else:
        what, t_next = "pump", float(record.t[i1])
    return Decline(pump, tuple(phases), shut.i0, int(i1), shutin_time(record, cycle, shut),
                   what, t_next, tuple(notes))


def user_stretch(t: np.ndarray, window: tuple[float, float] | None) -> tuple[int, int] | None:
    """Inclusive index range of samples with ``t0 <= t <= t1``."""
    if window is None:
        return None
    t0, t1 = window
    idx = np.flatnonzero((t >= t0) & (t <= t1))
    if idx.size < 3:
        raise ValueError(f"window {window} holds fewer than 3 samples")
    return int(idx[0]), int(idx[-1])
