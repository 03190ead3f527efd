"""The data types of a segmentation: phases, cycles and what a release was declared from.

Fixed here so that the picks, reports and CLI can rely on them.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Literal

__all__ = ["CYCLE_KINDS", "Cycle", "CycleKind", "Phase", "PhaseKind", "RecordScales",
           "ReleaseEvidence", "Segmentation"]

PhaseKind = Literal["pump", "shut_in", "flowback", "bleed", "idle"]
CycleKind = Literal["line_test", "casing_test", "lot", "xlot", "dfit", "step_rate",
                    "stimulation", "other"]
#: Every cycle kind, in the order the documentation lists them.
CYCLE_KINDS: tuple[str, ...] = ("line_test", "casing_test", "lot", "xlot", "dfit",
                                "step_rate", "stimulation", "other")


class ReleaseEvidence(enum.Enum):
    """What shows that a fall of pressure is a bleed or flowback rather than leak-off.

    ``RETURN_FLOW``: a return rate or return/pumped volume column shows fluid coming back.
    ``REMARK``: an operator remark near the fall mentions a bleed, flowback or opened valve.
    ``UNEXPLAINED_DECLINE``: the fall accelerates well past the decline the same shut-in
    showed before it (leak-off only slows down), or releases the pressure to base much faster
    than the record's own pump-off decline.
    ``PRESSURE_ONLY``: no rate is logged at all; the release was told from the pressure's
    shape alone (with the decline evidence above).
    """

    RETURN_FLOW = "return_flow"
    REMARK = "remark"
    UNEXPLAINED_DECLINE = "unexplained_decline"
    PRESSURE_ONLY = "pressure_only"


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
    evidence : tuple of ReleaseEvidence
        For ``bleed`` and ``flowback`` phases: what the release was declared from (empty for
        other kinds).
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
    evidence: tuple[ReleaseEvidence, ...] = ()

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
        (pumped past leak-off into breakdown/propagation), ``dfit`` (one injection past
        leak-off and a long falloff: a DFIT or mini-frac), ``step_rate`` (several increasing
        rate steps with the pressure stabilised on each), ``stimulation`` (pumped in several
        rate steps that are not a step-rate test), ``other``.
        :mod:`xlotkit.interpret.phases.kinds` gives the rules.
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
class RecordScales:
    """The record's own scales every segmentation threshold is a multiple or fraction of.

    Attributes
    ----------
    noise : float
        Standard deviation of the pressure noise [Pa]
        (:func:`xlotkit.interpret.phases.signal.noise_level`).
    base : float
        Pre-test pressure level [Pa] (gauge pressure on the record's reference).
    base_source : str
        How the base was found.
    span : float
        Highest (median-smoothed) pressure above the base [Pa].
    band : float
        Pressure above the base below which the well counts as idle [Pa].
    rate_scale : float or None
        The record's pump rate scale (high percentile of the metered pump rate) [m^3/s].
    dt : float
        Median sample interval [s] (reported only: no threshold uses it).
    """

    noise: float
    base: float
    base_source: str
    span: float
    band: float
    rate_scale: float | None
    dt: float

    def describe(self) -> str:
        """One line in bar for the notes."""
        b = 1e5
        out = (f"base {self.base / b:.1f} bar ({self.base_source}), span {self.span / b:.1f} "
               f"bar, noise {self.noise / b:.3g} bar, idle band {self.band / b:.2f} bar")
        if self.rate_scale:
            out += f", rate scale {self.rate_scale * 6e4:.4g} l/min"
        return out


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
    scales : RecordScales or None
        The record's scales the thresholds were taken from (None when built by hand).
    """

    phases: tuple[Phase, ...]
    cycles: tuple[Cycle, ...]
    used_rate: bool
    notes: tuple[str, ...] = field(default_factory=tuple)
    scales: RecordScales | None = None
