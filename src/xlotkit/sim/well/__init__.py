"""The well above the open-hole segment: completion and storage, fluid column, surface choke,
and the drive every engine asks what the phase in force does at the well head.

* :mod:`~xlotkit.sim.well.completion` -- :class:`Completion`, :func:`well_compliance`
  (thesis App. B.1);
* :mod:`~xlotkit.sim.well.column` -- :class:`Column`, the fluid column with ``rho(p)`` and
  pipe friction in closed form (App. B.6): :func:`bottomhole_from_surface`,
  :func:`surface_from_bottomhole`, friction factors;
* :mod:`~xlotkit.sim.well.choke` -- the surface choke ``Q = zeta sqrt(p_s)`` (Eq. 4.24):
  :func:`choke_rate`, :func:`calibrate_choke`, :func:`choke_surface_pressure`,
  :func:`choke_flow`;
* :mod:`~xlotkit.sim.well.drive` -- :class:`WellDrive` / :class:`PhaseDrive`: rates, their
  pressure derivative, surface pressure and phase-end tests of the phase in force.

SI units, gauge pressures; rates are volumes at the surface density per second.
"""

from xlotkit.sim.well.choke import (
    CHOKE_LINEAR,
    calibrate_choke,
    choke_flow,
    choke_rate,
    choke_surface_pressure,
)
from xlotkit.sim.well.column import (
    GRAVITY,
    INCH,
    RE_LAMINAR,
    WATER_COMPRESSIBILITY,
    Column,
    ColumnBlowUp,
    bottomhole_from_surface,
    colebrook_factor,
    density_at,
    friction_factor,
    haaland_factor,
    hydrostatic_bottomhole,
    surface_from_bottomhole,
)
from xlotkit.sim.well.completion import Completion, well_compliance
from xlotkit.sim.well.drive import EndTest, PhaseDrive, WellDrive, phase_place

__all__ = [
    "CHOKE_LINEAR",
    "GRAVITY",
    "INCH",
    "RE_LAMINAR",
    "WATER_COMPRESSIBILITY",
    "Column",
    "ColumnBlowUp",
    "Completion",
    "EndTest",
    "PhaseDrive",
    "WellDrive",
    "bottomhole_from_surface",
    "calibrate_choke",
    "choke_flow",
    "choke_rate",
    "choke_surface_pressure",
    "colebrook_factor",
    "density_at",
    "friction_factor",
    "haaland_factor",
    "hydrostatic_bottomhole",
    "phase_place",
    "surface_from_bottomhole",
    "well_compliance",
]
