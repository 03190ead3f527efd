"""Split a record into phases (pump, shut-in, flowback, bleed, idle), group them into cycles
and say what kind of test each cycle is.

* :mod:`~xlotkit.interpret.phases.types`: the data types (:class:`Phase`, :class:`Cycle`,
  :class:`Segmentation`, :class:`ReleaseEvidence`, :class:`RecordScales`);
* :mod:`~xlotkit.interpret.phases.options`: :class:`SegmentOptions` (fractions, multiples
  and sample counts only);
* :mod:`~xlotkit.interpret.phases.signal`: smoothing, slopes, noise, legs and steps;
* :mod:`~xlotkit.interpret.phases.pumping`: pumping from the rate or the pressure;
* :mod:`~xlotkit.interpret.phases.releases`: bleeds and flowbacks with their evidence;
* :mod:`~xlotkit.interpret.phases.kinds`: the cycle kinds;
* :mod:`~xlotkit.interpret.phases.segmentation`: :func:`segment`, the one call.

The rules: docs/field/segmentation.md.
"""

from xlotkit.interpret.phases.kinds import RateStep, rate_steps
from xlotkit.interpret.phases.options import SegmentOptions
from xlotkit.interpret.phases.segmentation import segment
from xlotkit.interpret.phases.types import (
    CYCLE_KINDS,
    Cycle,
    CycleKind,
    Phase,
    PhaseKind,
    RecordScales,
    ReleaseEvidence,
    Segmentation,
)

__all__ = ["CYCLE_KINDS", "Cycle", "CycleKind", "Phase", "PhaseKind", "RateStep",
           "RecordScales", "ReleaseEvidence", "SegmentOptions", "Segmentation", "rate_steps",
           "segment"]
