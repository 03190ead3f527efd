"""MDEM mechanics (thesis section 2.2): intact clusters behave as CST elements, failed
clusters as frictional DEM contacts; quasi-static implicit solve.

Compression is positive in this package's public API (stresses, pressures, contact normal
forces); SI units throughout.
"""

from xlotkit.sim.mechanics.closure import CLOSURE_LAWS, ClosureLaw
from xlotkit.sim.mechanics.config import (
    BoundaryConditions,
    CrackPlanes,
    FracturePlane,
    InSituStress,
    InterfacePlane,
    RockProperties,
    SolverOptions,
    StrengthScaling,
)
from xlotkit.sim.mechanics.failure import TIP_TOUGHNESS_FACTOR, crack_tip_toughness
from xlotkit.sim.mechanics.breakdown import (
    BreakdownResult,
    PressureBreakdown,
    breakdown_pressure,
    crack_geometry,
    crack_start_azimuth,
    wall_pressure_at_first_failure,
)
from xlotkit.sim.mechanics.fronts import CrackFront, CrackFronts
from xlotkit.sim.mechanics.solver import (
    BONDED,
    FAILED_SHEAR,
    FAILED_TENSILE,
    INTACT,
    INTERFACE,
    OPEN,
    PRESET,
    SLIP,
    STICK,
    MechanicsModel,
    MechanicsResult,
    MechanicsState,
)

__all__ = [
    "CrackFront",
    "CrackFronts",
    "BONDED",
    "FAILED_SHEAR",
    "FAILED_TENSILE",
    "INTACT",
    "INTERFACE",
    "OPEN",
    "PRESET",
    "SLIP",
    "STICK",
    "TIP_TOUGHNESS_FACTOR",
    "BoundaryConditions",
    "BreakdownResult",
    "CLOSURE_LAWS",
    "ClosureLaw",
    "CrackPlanes",
    "InSituStress",
    "FracturePlane",
    "InterfacePlane",
    "MechanicsModel",
    "MechanicsResult",
    "MechanicsState",
    "PressureBreakdown",
    "RockProperties",
    "SolverOptions",
    "StrengthScaling",
    "breakdown_pressure",
    "crack_start_azimuth",
    "crack_geometry",
    "crack_tip_toughness",
    "wall_pressure_at_first_failure",
]
