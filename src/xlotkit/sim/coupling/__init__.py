"""Monolithic implicit hydro-mechanics: displacements, cell pressures and the well pressure
solved together each step, with cluster failure, fracture flow and mass balance.

Submodules:

* :mod:`~xlotkit.sim.coupling.model` -- :class:`CoupledModel` (residual and Jacobian),
  :class:`CoupledState`, storage helpers;
* :mod:`~xlotkit.sim.coupling.stepper` -- :class:`CoupledStepper` (Newton with the contact
  active set, failure rounds, mass balance, adaptive runs);
* :mod:`~xlotkit.sim.coupling.geometry` -- :func:`fracture_summary`;
* :mod:`~xlotkit.sim.coupling.analytic` -- :func:`kgd_toughness` (reference solution).

See docs/coupling.md.
"""

from xlotkit.sim.coupling.analytic import KGDSolution, kgd_toughness
from xlotkit.sim.coupling.geometry import FractureSummary, fracture_summary
from xlotkit.sim.coupling.model import (
    CoupledModel,
    CoupledResidual,
    CoupledState,
    Structure,
    WellRateFunction,
    biot_modulus,
    boundary_load,
    drained_bulk_modulus,
    grain_pore_compressibility,
)
from xlotkit.sim.coupling.stepper import (
    CoupledControl,
    CoupledCounters,
    CoupledRunResult,
    CoupledStepper,
    StepResult,
    TimeStepControl,
)

__all__ = [
    "CoupledControl",
    "CoupledCounters",
    "CoupledModel",
    "CoupledResidual",
    "CoupledRunResult",
    "CoupledState",
    "CoupledStepper",
    "FractureSummary",
    "KGDSolution",
    "StepResult",
    "Structure",
    "TimeStepControl",
    "WellRateFunction",
    "biot_modulus",
    "boundary_load",
    "drained_bulk_modulus",
    "fracture_summary",
    "grain_pore_compressibility",
    "kgd_toughness",
]
