"""Scene -> model: the 2D coupled model a scene asks for (what each key becomes, SPEC §2-§6).

See :mod:`xlotkit.sim.coupling.engine` for the list; :func:`build_model` assembles the mesh,
the MDEM mechanics, the finite-volume flow and the well's storage on the borehole pressure.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from xlotkit.errors import InputError
from xlotkit.sim.coupling.model import CoupledModel, grain_pore_compressibility
from xlotkit.sim.flow import (
    FlowModel,
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    WellCondition,
)
from xlotkit.sim.mechanics import (
    BoundaryConditions,
    ClosureLaw,
    CrackPlanes,
    FracturePlane,
    InSituStress,
    InterfacePlane,
    MechanicsModel,
    RockProperties,
    StrengthScaling,
)
from xlotkit.sim.mesh import FractureBand, Mesh, borehole_mesh, read_mesh
from xlotkit.sim.scene import Scene
from xlotkit.sim.well import Column, hydrostatic_bottomhole, well_compliance

__all__ = ["RESIDUAL_APERTURE", "build_model", "total_well_compliance",
           "well_column"]

#: Crack residual (closed) hydraulic aperture [m].
RESIDUAL_APERTURE = 1e-5


def _scene_mesh(scene: Scene) -> Mesh:
    mo, geo = scene.mesh, scene.geometry
    if mo.file is not None:
        path = Path(mo.file)
        if not path.is_absolute() and scene.source_file:
            path = Path(scene.source_file).parent / path
        return read_mesh(path)
    band = None
    h_wall = mo.wall_element_size
    if mo.fracture_band:
        h_band = mo.band_element_size or h_wall or 2 * math.pi * geo.hole_radius / 64
        band = FractureBand(math.radians(scene.stresses.sigma_H_azimuth), mo.band_width,
                            h_band, scene.band_length, strip=bool(mo.band_strip),
                            centred_wall=bool(mo.band_centred_wall))
    try:
        return borehole_mesh(size=geo.domain_size, radius=geo.hole_radius, growth=mo.growth,
                             h_wall=h_wall, h_max=mo.max_element_size, fracture_band=band,
                             jitter=mo.jitter, seed=scene.mesh_seed)
    except InputError as exc:
        key = {"h_wall": "mesh.wall_element_size", "h_max": "mesh.max_element_size",
               "fracture_band.h": "mesh.band_element_size", "radius": "geometry.hole_radius",
               "size": "geometry.domain_size"}.get(exc.key or "", f"mesh.{exc.key}")
        raise InputError(exc.message, key=key, file=scene.source_file,
                         expected=exc.expected) from None


def _far_field(scene: Scene) -> tuple[float, float, float]:
    """Far-field (sigma_x, sigma_y, sigma_xy) [Pa] with sigma_H along its azimuth."""
    st = scene.stresses
    th = math.radians(st.sigma_H_azimuth)
    c, s = math.cos(th), math.sin(th)
    sx = st.sigma_H * c * c + st.sigma_h * s * s
    sy = st.sigma_H * s * s + st.sigma_h * c * c
    sxy = (st.sigma_H - st.sigma_h) * s * c
    # round-off of the rotation must not create a shear the roller boundaries cannot carry
    if abs(sxy) < 1e-9 * max(st.sigma_H, 1.0):
        sxy = 0.0
    return sx, sy, sxy


def well_column(scene: Scene) -> Column:
    """The fluid column surface -> open hole (friction only with ``effects.pipe_friction``)."""
    comp = scene.completion_model()
    col = comp.column(density=scene.fluid.density, viscosity=scene.fluid.viscosity)
    if not scene.effects.pipe_friction:
        col = replace(col, friction=False)
    return col


def total_well_compliance(scene: Scene) -> float:
    """Whole-well compliance C_w [m^3/Pa] the scene asks for (0 without well storage)."""
    if not scene.effects.well_storage:
        return 0.0
    if scene.completion.well_compliance is not None:
        return float(scene.completion.well_compliance)
    return well_compliance(scene.completion_model())


def build_model(scene: Scene) -> tuple[CoupledModel, float]:
    """The coupled model of a scene and the initial borehole pressure [Pa].

    See the module docstring for what each scene key becomes.
    """
    if not isinstance(scene, Scene):
        raise InputError(f"not a Scene: {scene!r}", key="scene")
    mesh = _scene_mesh(scene)
    rk, fl, eff, geo = scene.rock, scene.fluid, scene.effects, scene.geometry
    sx, sy, sxy = _far_field(scene)
    p0 = scene.stresses.pore_pressure
    col = well_column(scene)
    pw0 = (float(scene.completion.initial_pressure)
           if scene.completion.initial_pressure is not None else hydrostatic_bottomhole(col))
    if pw0 < p0 * (1.0 - 1e-12):
        raise InputError(
            f"initial borehole pressure {pw0 / 1e6:.3f} MPa is below the pore pressure "
            f"{p0 / 1e6:.3f} MPa (an underbalanced hole is not a leak-off test)",
            key="completion.initial_pressure", file=scene.source_file,
            expected=f">= stresses.pore_pressure ({p0:g} Pa)")
    if sxy != 0.0:
        # rollers need a diagonal far field; the mechanics pins rigid modes otherwise
        boundary = BoundaryConditions("tractions")
    else:
        boundary = None
    # poroelastic off: the intact skeleton is decoupled from the pore fluid (alpha = 0; the
    # model then assembles no pressure-coupling blocks for intact clusters)
    biot = float(rk.biot) if eff.poroelastic else 0.0
    scaling = StrengthScaling(enabled=bool(eff.strength_scaling),
                              reference_area=rk.strength_scaling_reference_area,
                              exponent=rk.strength_scaling_exponent,
                              toughness=rk.toughness, wall=rk.wall_criterion)
    rock = RockProperties(young=rk.youngs_modulus, poisson=rk.poisson_ratio, biot=biot,
                          tensile_strength=rk.tensile_strength, cohesion=rk.cohesion,
                          friction_angle_deg=rk.friction_angle,
                          heterogeneity=rk.heterogeneity if eff.heterogeneity else 0.0,
                          seed=int(scene.rock_seed) % (2**63), scaling=scaling)
    planes = tuple(InterfacePlane(p.start, p.end, p.friction_angle) for p in eff.interface)
    fplane = None
    if eff.fracture_plane:
        fplane = FracturePlane(math.radians(scene.stresses.sigma_H_azimuth),
                               friction_angle_deg=rk.fracture_friction_angle)
    cplanes = (CrackPlanes(friction_angle_deg=rk.fracture_friction_angle)
               if rk.crack_plane == "stress" else None)
    closure = ClosureLaw(rk.closure_law, normal_stiffness=rk.joint_normal_stiffness,
                         max_closure=rk.joint_max_closure,
                         reference_stress=rk.joint_reference_stress,
                         sealed_aperture=(RESIDUAL_APERTURE if rk.sealed_aperture is None
                                          else rk.sealed_aperture))
    mech = MechanicsModel(mesh, rock, InSituStress(sx, sy, sxy, p0, pw0), boundary=boundary,
                          interfaces=planes, fracture_plane=fplane, crack_planes=cplanes,
                          closure=closure, permeable_wall=rk.permeability > 0.0)
    cr = (float(np.min(grain_pore_compressibility(biot, rk.porosity, rk.youngs_modulus,
                                                  rk.poisson_ratio)))
          if eff.poroelastic else 0.0)
    fluid = FluidProperties(density=fl.density, compressibility=fl.compressibility,
                            viscosity=fl.viscosity, reference_pressure=0.0)
    flow = FlowModel(mesh, fluid, RockFlowProperties(rk.permeability, rk.porosity, cr, p0),
                     WellCondition(rate=0.0), OuterBoundary.fixed_pressure(p0),
                     height=geo.segment_height)
    h = geo.segment_height
    extra = max(total_well_compliance(scene) - float(flow.well_storage), 0.0) / h
    psi = (math.radians(rk.dilation_angle) if eff.shear_dilation else None)
    # the closed crack's aperture: the smooth law's constant one, or the closure law's at
    # zero effective stress (the gap tolerance of the Newton is a fraction of it)
    w_res = closure.zero_stress_aperture if closure.nonlinear else RESIDUAL_APERTURE
    model = CoupledModel(mech, flow, residual_aperture=w_res,
                         well_compliance=extra, check_storage=eff.poroelastic,
                         dilation_angle=psi)
    return model, pw0
