"""The engine contract: what every simulator offers and returns (see :mod:`xlotkit.sim.run`).

One step type, one result type, one row builder for every engine (the lumped engine, the
2D engine monolithic and partitioned), as scipy's ``OdeSolver``: ``step()`` returns a
:class:`StepOutcome` (success, reason, counters), a finished run one :class:`EngineResult`
(status, message, record, truth), and the time-series rows are validated and converted by
:func:`series_rows`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np

from xlotkit.record import Record
from xlotkit.sim.output import Snapshot, check_rows

__all__ = ["Engine", "EngineResult", "StepCounters", "StepOutcome", "series_rows"]


@dataclass(frozen=True)
class StepCounters:
    """An engine's cumulative work when a step returned.

    Attributes
    ----------
    accepted : int
        Accepted time steps.
    rejected : int
        Rejected trials (repeated shorter).
    events : int
        Events located inside steps (the lumped model's breakdown, closure, reopening,
        phase ends; 0 where an engine locates them by repeating the step).
    newton_iterations, linear_solves : int
        Nonlinear iterations and linear solves (0 for an engine without them).
    """

    accepted: int = 0
    rejected: int = 0
    events: int = 0
    newton_iterations: int = 0
    linear_solves: int = 0


@dataclass(frozen=True)
class StepOutcome:
    """What one call of an engine's ``step()`` did.

    Attributes
    ----------
    success : bool
        True when the simulation advanced (an accepted step, a phase start or end); False
        when the trial was rejected and will be retried shorter (nothing advanced).
    t : float
        Simulated time after the call [s].
    reason : str
        What it did or why it was rejected (``"accepted"``, ``"phase start"``,
        ``"phase end: volume"``, ``"rejected: pressure change"``, ``"done"``).
    counters : StepCounters
        The engine's cumulative work after the call.
    """

    success: bool
    t: float
    reason: str
    counters: StepCounters = field(default_factory=StepCounters)

    @property
    def ok(self) -> bool:
        """Alias of :attr:`success`."""
        return self.success


@dataclass(frozen=True)
class EngineResult:
    """Outcome of a finished run of any engine.

    Attributes
    ----------
    status : {"ok", "stopped"}
        ``stopped`` when a phase hit its safety limit (``max_phase_duration``) before its end
        condition.
    message : str
        Human-readable summary.
    record : Record
        The clean synthetic log on the log grid (bottom-hole ``pressure``, rates, volumes,
        ``density``, channels such as ``surface_pressure``).
    truth : dict
        What the model imposed and realised (engine-specific; ``"realised"`` holds the
        realised ``sigma_h``, ``sigma_H``, ``tensile_strength`` where they differ from the
        scene's).
    """

    status: Literal["ok", "stopped"]
    message: str
    record: Record
    truth: dict[str, Any] = field(default_factory=dict)


def series_rows(columns: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """An engine's time-series rows: known column names (:data:`xlotkit.sim.output.
    SERIES_COLUMNS`), ``t`` present, one-dimensional float arrays of equal length.

    Raises
    ------
    xlotkit.sim.output.OutputError
        Naming the offending column.
    """
    return check_rows(columns)


@runtime_checkable
class Engine(Protocol):
    """A stepwise simulator (see the module docstring for the contract)."""

    model: str

    def start(self) -> None: ...

    def step(self) -> StepOutcome: ...

    def is_done(self) -> bool: ...

    def progress(self) -> float: ...

    @property
    def time(self) -> float: ...

    def state(self) -> dict[str, Any]: ...

    def restore(self, state: Mapping[str, Any]) -> None: ...

    def rows(self) -> dict[str, np.ndarray]: ...

    def snapshot(self) -> Snapshot | None: ...

    def result(self) -> EngineResult: ...


