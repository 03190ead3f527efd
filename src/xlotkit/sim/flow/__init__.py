"""Single-phase flow on the MDEM triangles with the borehole as one pressure unknown.

Replaces TOUGH2 of the thesis (SPEC §4, §5). Submodules:

* :mod:`~xlotkit.sim.flow.properties` -- fluid, rock, well and outer-boundary descriptions;
* :mod:`~xlotkit.sim.flow.fracture` -- aperture-dependent permeability and porosity
  (Eq. 4.2-4.4) as pure kernels;
* :mod:`~xlotkit.sim.flow.model` -- TPFA finite volumes, backward-Euler residual and
  analytic Jacobian (:meth:`FlowModel.residual_and_jacobian`);
* :mod:`~xlotkit.sim.flow.stepper` -- Newton, adaptive time steps, mass-balance checks;
* :mod:`~xlotkit.sim.flow.analytic` -- reference solutions for verification (line source,
  constant-pressure radial diffusion via Stehfest, a 1D radial finite-volume reference).
"""

from xlotkit.sim.flow.fracture import (
    cluster_length_scale,
    crack_opening,
    crack_permeability,
    crack_permeability_derivative,
    cubic_law_permeability,
    fracture_porosity,
    hydraulic_aperture,
    permeability_multiplier,
    permeability_multiplier_derivative,
    sealing_aperture,
    sealing_aperture_derivative,
    upscaled_permeability,
)
from xlotkit.sim.flow.model import (
    FlowModel,
    FlowResidual,
    FlowState,
    arithmetic_transmissibility,
    edge_geometry,
    harmonic_transmissibility,
)
from xlotkit.sim.flow.properties import (
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    WellCondition,
    density,
)
from xlotkit.sim.flow.stepper import (
    FlowCounters,
    FlowResult,
    FlowStepper,
    StepControl,
    StepResult,
)

__all__ = [
    "FlowCounters",
    "FlowModel",
    "FlowResidual",
    "FlowResult",
    "FlowState",
    "FlowStepper",
    "FluidProperties",
    "OuterBoundary",
    "RockFlowProperties",
    "StepControl",
    "StepResult",
    "WellCondition",
    "arithmetic_transmissibility",
    "cluster_length_scale",
    "crack_opening",
    "crack_permeability",
    "crack_permeability_derivative",
    "cubic_law_permeability",
    "density",
    "edge_geometry",
    "fracture_porosity",
    "harmonic_transmissibility",
    "hydraulic_aperture",
    "permeability_multiplier",
    "permeability_multiplier_derivative",
    "sealing_aperture",
    "sealing_aperture_derivative",
    "upscaled_permeability",
]
