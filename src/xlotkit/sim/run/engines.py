"""Which engine runs a scene: the registry of engine factories per model name."""

from __future__ import annotations

from collections.abc import Callable

from xlotkit.errors import InputError, XlotkitError
from xlotkit.sim.run.contract import Engine
from xlotkit.sim.scene import Scene

__all__ = ["ENGINES", "EngineFactory", "EngineNotAvailable", "make_engine", "register_engine",
           "require_engine"]

EngineFactory = Callable[[Scene], Engine]


class EngineNotAvailable(XlotkitError):
    """No engine is registered for the model a scene needs."""


def _lumped_factory(scene: Scene) -> Engine:
    from xlotkit.sim.lumped import LumpedEngine

    # The engine's record stays clean: the driver puts the gauge noise on the log.
    return LumpedEngine(scene.to_lumped().replace(noise=0.0, resolution=0.0))


def _mdem_factory(scene: Scene) -> Engine:
    # the well coupling is chosen per scene: the well as storage on p_w (MDEMEngine), or
    # the thesis's partitioned schemes around the same engine
    if scene.coupling != "monolithic":
        from xlotkit.sim.coupling.partitioned import PartitionedMDEMEngine

        return PartitionedMDEMEngine(scene)
    from xlotkit.sim.coupling.engine import MDEMEngine

    return MDEMEngine(scene)


#: model name -> engine factory.
ENGINES: dict[str, EngineFactory] = {"lumped": _lumped_factory, "mdem": _mdem_factory}


def register_engine(model: str, factory: EngineFactory) -> None:
    """Register (or replace) the engine factory for ``model`` (``"lumped"``, ``"mdem"``)."""
    if model not in ("lumped", "mdem"):
        raise InputError(f"unknown model {model!r}", key="model", expected="lumped or mdem")
    ENGINES[model] = factory


def require_engine(scene: Scene) -> EngineFactory:
    """The registered factory for the scene's resolved model.

    Raises
    ------
    EngineNotAvailable
        When no engine is registered for it (both models have one by default; a
        caller may have replaced the registry's entries).
    """
    model = scene.resolved_model
    factory = ENGINES.get(model)
    if factory is None:
        why = ", ".join(scene.two_d_reasons) or "model = 'mdem'"
        where = f"{scene.source_file}: " if scene.source_file else ""
        raise EngineNotAvailable(
            f"{where}model: the scene needs the 2D MDEM simulator ({why}), which is not "
            f"available yet (no engine registered for {model!r}); use model = 'lumped' "
            f"without those keys, or register one with "
            f"xlotkit.sim.run.register_engine({model!r}, factory)")
    return factory


def make_engine(scene: Scene) -> Engine:
    """A new engine for the scene's resolved model (see :func:`require_engine`)."""
    return require_engine(scene)(scene)


