"""Run a scene: the stepwise-engine protocol, the engine registry and the driver.

Engine protocol
---------------
A simulator is driven one step at a time through :class:`Engine`:

``start()``
    Set up the state at t = 0. Called once for a fresh run (instead of ``restore``).
``step() -> StepOutcome``
    Advance by one step (:class:`~xlotkit.sim.run.contract.StepOutcome`): ``success``
    (False: a rejected trial that will be retried, nothing changed), ``t`` the simulated
    time after the call, ``reason`` a short text (why it was rejected, or what happened)
    and ``counters`` the engine's cumulative work (accepted and rejected steps, events,
    Newton iterations, linear solves). An engine raises
    :class:`~xlotkit.errors.XlotkitError` for a failure it cannot step past.
``is_done() -> bool``
    True once the whole schedule has run (``step`` is then not called again).
``progress() -> float``
    Fraction done in [0, 1], non-decreasing over the run.
``time`` (property) -> float
    Simulated time [s].
``state() -> dict[str, ndarray | int | float | bool | str]``
    Everything the remaining steps depend on, as NumPy arrays and scalars (strings allowed,
    e.g. JSON for small structured data). Must be exact: ``restore(state())`` followed
    by the remaining steps gives bit-identical results.
``restore(state)``
    Continue from a ``state()`` dict (values may come back as 0-d arrays).
``rows() -> dict[str, ndarray]``
    The time series produced so far, one row per accepted step, built by
    :func:`~xlotkit.sim.run.contract.series_rows`: column names from
    :data:`xlotkit.sim.output.SERIES_COLUMNS` (``t`` required; columns the engine does not
    have are left out, never filled with zeros).
``snapshot() -> Snapshot | None``
    Fields on the mesh now (:class:`xlotkit.sim.output.Snapshot`), or None for an engine
    without a mesh.
``result() -> EngineResult``
    Once done, one type for every engine (:class:`~xlotkit.sim.run.contract.EngineResult`):
    ``status`` ("ok" or "stopped"), ``message``, ``record`` (the clean
    :class:`~xlotkit.record.Record` sampled every ``scene.output.log_interval``: bottom-hole
    ``pressure``, rates, volumes, ``density``, channel ``surface_pressure``) and ``truth`` (a
    dict; it may carry ``"realised": {"sigma_h": ..., "sigma_H": ...,
    "tensile_strength": ...}`` when the realised values differ from the imposed ones,
    e.g. with heterogeneity).

The package: :mod:`~xlotkit.sim.run.contract` (the types above),
:mod:`~xlotkit.sim.run.engines` (the registry), :mod:`~xlotkit.sim.run.driver`
(:func:`simulate`).

Engines are made by factories ``factory(scene) -> Engine`` registered per model name in
:data:`ENGINES` (:func:`register_engine`). ``lumped`` is built in
(:class:`xlotkit.sim.lumped.LumpedEngine`), and so is ``mdem``
(:class:`xlotkit.sim.coupling.engine.MDEMEngine`, the 2D coupled model; a scene with
``coupling = "wfd" | "wfc" | "wfdmod"`` gets
:class:`xlotkit.sim.coupling.partitioned.PartitionedMDEMEngine`). A model without a
registered engine raises :class:`EngineNotAvailable`.

Driver
------
:func:`simulate` writes into a fresh results folder, checkpoints every
``numerics.checkpoint_steps`` steps or ``numerics.checkpoint_seconds`` of wall time
(atomically, ``checkpoint.npz``), and at the end writes ``timeseries.h5``,
``synthetic_log.csv`` (noise, resolution and sample interval from ``[output]``),
``summary.json`` and, for engines with a mesh, ``snapshots/*.vtu`` with ``fields.pvd``;
the checkpoint is then removed. ``simulate(..., resume=True)`` continues an interrupted
run from its last checkpoint and ends with the same numbers as an uninterrupted run.
"""

from xlotkit.sim.run.contract import (
    Engine,
    EngineResult,
    StepCounters,
    StepOutcome,
    series_rows,
)
from xlotkit.sim.run.driver import (
    CHECKPOINT,
    SimulationInterrupted,
    SimulationResult,
    simulate,
)
from xlotkit.sim.run.engines import (
    ENGINES,
    EngineFactory,
    EngineNotAvailable,
    make_engine,
    register_engine,
    require_engine,
)

__all__ = [
    "CHECKPOINT",
    "ENGINES",
    "Engine",
    "EngineFactory",
    "EngineNotAvailable",
    "EngineResult",
    "SimulationInterrupted",
    "SimulationResult",
    "StepCounters",
    "StepOutcome",
    "make_engine",
    "register_engine",
    "require_engine",
    "series_rows",
    "simulate",
]
