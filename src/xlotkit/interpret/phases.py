"""Split a record into phases (pump, shut-in, flowback, bleed, idle) and group them into cycles.

Data types are fixed here so that the picks, reports and CLI can rely on them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

__all__ = ["Cycle", "Phase", "PhaseKind", "CycleKind", "Segmentation"]

PhaseKind = Literal["pump", "shut_in", "flowback", "bleed", "idle"]
CycleKind = Literal["line_test", "casing_test", "lot", "xlot", "other"]


@dataclass(frozen=True)
class Phase:
    """A contiguous stretch of a record with one operating state.

    Attributes
    ----------
    kind : PhaseKind
        ``pump`` (fluid pumped in), ``shut_in`` (well closed, no flow), ``flowback`` (fluid
        returned through a choke: return rate or falling volume), ``bleed`` (pressure released
        quickly / at a controlled rate), ``idle`` (no test: well open, pressure at base level).
    i0, i1 : int
        Sample indices into the record, half-open ``[i0, i1)``.
    t_start, t_end : float
        Elapsed times of the first and last sample [s].
    pumped_m3, returned_m3 : float
        Volume pumped in and returned during the phase [m^3].
    peak_pressure : float
        Highest pressure in the phase [Pa], on the record's reference.
    mean_rate : float
        Mean pump rate (negative for returns) [m^3/s].
    """

    kind: PhaseKind
    i0: int
    i1: int
    t_start: float
    t_end: float
    pumped_m3: float = 0.0
    returned_m3: float = 0.0
    peak_pressure: float = 0.0
    mean_rate: float = 0.0

    @property
    def duration(self) -> float:
        """Phase length [s]."""
        return self.t_end - self.t_start


@dataclass(frozen=True)
class Cycle:
    """One pressurisation and what follows it until the next one.

    Attributes
    ----------
    index : int
        1-based cycle number in the record.
    kind : CycleKind
        ``line_test`` (surface lines against a closed valve), ``casing_test`` (casing held at
        pressure, no leak-off), ``lot`` (pumping stopped at/soon after leak-off), ``xlot``
        (pumped past leak-off into breakdown/propagation), ``other``.
    phases : tuple of Phase
        The phases, in time order; the first is the pressurising ``pump`` phase.
    t_start, t_end : float
        Elapsed times [s].
    peak_pressure : float
        Highest pressure in the cycle [Pa].
    pumped_m3, returned_m3 : float
        Volumes pumped and returned in the cycle [m^3].
    reason : str
        Why it was classified as it was (for reports).
    """

    index: int
    kind: CycleKind
    phases: tuple[Phase, ...]
    t_start: float
    t_end: float
    peak_pressure: float
    pumped_m3: float
    returned_m3: float
    reason: str = ""

    @property
    def duration(self) -> float:
        """Cycle length [s]."""
        return self.t_end - self.t_start

    def phase(self, kind: PhaseKind) -> Phase | None:
        """The first phase of ``kind`` in the cycle, or None."""
        for p in self.phases:
            if p.kind == kind:
                return p
        return None


@dataclass(frozen=True)
class Segmentation:
    """Phases and cycles found in a record.

    Attributes
    ----------
    phases : tuple of Phase
        All phases covering the record, in order.
    cycles : tuple of Cycle
        Cycles (each a sub-sequence of ``phases``).
    used_rate : bool
        Whether the pump rate drove the split (False: pressure alone).
    notes : tuple of str
        Remarks about the segmentation (thresholds used, ambiguities).
    """

    phases: tuple[Phase, ...]
    cycles: tuple[Cycle, ...]
    used_rate: bool
    notes: tuple[str, ...] = field(default_factory=tuple)
