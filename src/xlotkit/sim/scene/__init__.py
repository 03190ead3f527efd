r"""Simulation scenes: one validated description of an XLOT to simulate (SPEC §6).

A scene is a TOML file with the sections below (every key optional unless stated; numbers
without a unit are SI; strings may carry field units: ``"2000 m"``, ``"10 l/min"``,
``"35 MPa"``, ``"1.2 sg"``, ``"10 cP"``, ``"1 mD"``, ``"30 deg"``)::

    title = "..."                 # free text
    model = "auto"                # auto | lumped | mdem
    coupling = "monolithic"       # monolithic | wfd | wfc | wfdmod (2D model only)
    seed = 0                      # master seed (mesh jitter, heterogeneity, gauge noise)
    [geometry]    domain_size, hole_radius, segment_height
    [mesh]        growth, wall_element_size, max_element_size, fracture_band, band_width,
                  band_element_size, band_length, jitter, seed, file
    [rock]        youngs_modulus, poisson_ratio, biot, porosity, permeability,
                  tensile_strength, cohesion, friction_angle, heterogeneity,
                  strength_scaling_exponent, strength_scaling_reference_area, seed
    [stresses]    sigma_H, sigma_h, sigma_H_azimuth, pore_pressure
    [fluid]       density, compressibility, viscosity
    [completion]  depth, tvd, casing_id, casing_od, pipe_od, pipe_id, open_hole_length,
                  expansion, steel_modulus, steel_poisson, roughness, well_compliance,
                  initial_pressure
    [schedule]    see :meth:`xlotkit.sim.schedule.Schedule.from_dict`
    [numerics]    dt_min, dt_max, n1, n2, max_newton, checkpoint_steps,
                  checkpoint_seconds, max_phase_duration, dp_max
    [effects]     well_storage, pipe_friction, poroelastic, heterogeneity, strength_scaling,
                  shear_dilation, [[effects.interface]] (start, end, friction_angle)
    [output]      log_interval, noise, resolution, seed, snapshot_interval, start_time
    [lumped]      fracture_geometry, toughness, initial_flaw, reopening, nwb_coefficient,
                  leakoff_coefficient, wall_leak_index
    [well_coupling] tolerance, rate_tolerance, max_iterations, calibration, wfc_gain,
                  wfc_damping, wfdmod_gain, wfdmod_damping (coupling = wfd | wfc | wfdmod)

Every key, its unit, default and allowed range is listed in :data:`SCENE_KEYS` (and in
``docs/simulate.md``, generated from it by :func:`scene_reference_markdown`).

Layout of the package (configuration: it imports no engine)
-----------------------------------------------------------
* :mod:`~xlotkit.sim.scene.quantities` -- values in SI from numbers and unit strings;
* :mod:`~xlotkit.sim.scene.keys` -- :data:`SCENE_KEYS` and the checks of each key;
* :mod:`~xlotkit.sim.scene.sections` -- one frozen dataclass per section (and
  :class:`CouplingOptions`, the partitioned schemes' tuning);
* :mod:`~xlotkit.sim.scene.lumped` -- :class:`LumpedScene`, the lumped model's own
  configuration, and the older lumped file layout;
* :mod:`~xlotkit.sim.scene.model` -- :class:`Scene`;
* :mod:`~xlotkit.sim.scene.applies` -- which keys each model reads (a key set where it
  is not read is refused);
* :mod:`~xlotkit.sim.scene.io` -- :func:`load_scene`, :func:`scene_from_dict`,
  :func:`standard_2d_scene`; :mod:`~xlotkit.sim.scene.reference` -- the key tables.

Model choice
------------
``model = "auto"`` takes the lumped model (:mod:`xlotkit.sim.lumped`) unless the scene asks
for physics only the 2D hydro-mechanical (MDEM) model has: a ``[mesh]`` section,
``effects.poroelastic``, ``effects.heterogeneity``, ``effects.strength_scaling``,
``effects.shear_dilation``, interface planes, or a ``coupling`` other than
``"monolithic"`` (the thesis's WFD/WFC schemes couple the 2D model to the well).
:attr:`Scene.two_d_reasons` lists what was found; ``model = "lumped"`` with any of them is
an error naming the key. A partitioned ``coupling`` (``wfd``, ``wfc``, ``wfdmod``) also needs
a well to couple the open hole to: ``effects.well_storage`` on and a whole-well compliance
above the open hole's own ``c_f pi r^2 h`` (else an error naming the key); its tolerances,
gains and damping are in ``[well_coupling]`` (ignored by ``monolithic``).

Lumped parameters derived from the rock
---------------------------------------
Without explicit ``lumped.leakoff_coefficient`` / ``lumped.wall_leak_index`` the lumped
model takes them from the rock: the open-hole wall's radial productivity
``J = 2 pi k L_oh / (mu ln(10))`` (:func:`xlotkit.formulas.wall_leak_index`) and the
Carter coefficient combining the filtrate-viscosity and reservoir-compressibility terms
(Economides & Nolte, :func:`xlotkit.formulas.carter_coefficient`) with ``dp = sigma_h - p0``::

    C_v = sqrt(k phi dp / (2 mu)),   C_c = dp sqrt(k phi c_f / (pi mu)),
    C_L = 2 C_v C_c / (C_v + sqrt(C_v^2 + 4 C_c^2))

The lumped scene format of :func:`xlotkit.sim.lumped.load_lumped_scene` (sections
``[stress]``, ``[fracture]``, ``[well]``) is recognised by :func:`load_scene` and converted
(:meth:`Scene.from_lumped`), so old scene files run unchanged.
"""

from xlotkit.sim.scene.io import load_scene, scene_from_dict, standard_2d_scene
from xlotkit.sim.scene.keys import PARTITIONED_COUPLINGS, SCENE_KEYS, KeySpec
from xlotkit.sim.scene.lumped import (
    NWB_DEFAULT,
    LumpedScene,
    load_lumped_scene,
    standard_lumped_scene,
)
from xlotkit.sim.scene.model import Scene, carter_coefficient
from xlotkit.sim.scene.reference import scene_reference_markdown
from xlotkit.sim.scene.sections import (
    CompletionOptions,
    CouplingOptions,
    Effects,
    Fluid,
    Geometry,
    Interface,
    LumpedOptions,
    MeshOptions,
    Numerics,
    OutputOptions,
    Rock,
    Stresses,
    WellCouplingOptions,
)

__all__ = [
    "NWB_DEFAULT",
    "PARTITIONED_COUPLINGS",
    "SCENE_KEYS",
    "CompletionOptions",
    "CouplingOptions",
    "Effects",
    "Fluid",
    "Geometry",
    "Interface",
    "KeySpec",
    "LumpedOptions",
    "LumpedScene",
    "MeshOptions",
    "Numerics",
    "OutputOptions",
    "Rock",
    "Scene",
    "Stresses",
    "WellCouplingOptions",
    "carter_coefficient",
    "load_lumped_scene",
    "load_scene",
    "scene_from_dict",
    "scene_reference_markdown",
    "standard_2d_scene",
    "standard_lumped_scene",
]
