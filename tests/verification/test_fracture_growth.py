"""Fracture initiation and growth from the borehole with the monolithic coupled step.

Thesis 4.2 case: sigma_H = 35 MPa along x, sigma_h = 30 MPa along y, p0 = 20 MPa,
k = 1e-19 m^2, brine, injection at a constant rate into the hole (segment height 10 m,
the segment's own hole volume as the only well storage). Hubbert-Willis breakdown
3 sigma_h - sigma_H - p0 + T = 40 MPa. Small graded mesh (3 m square, 24 wall segments,
a band of wall-sized triangles along x), so the run stays around half a minute.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit.sim.coupling import (
    CoupledModel,
    CoupledStepper,
    TimeStepControl,
    fracture_summary,
)
from xlotkit.sim.flow import (
    FlowModel,
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    WellCondition,
)
from xlotkit.sim.mechanics import InSituStress, MechanicsModel, RockProperties
from xlotkit.sim.mesh import FractureBand, borehole_mesh

A = 0.15
SIZE = 3.0
N_WALL = 24
H_WALL = 2 * math.pi * A / N_WALL


def _anisotropic_model(rate=2e-4):
    mesh = borehole_mesh(size=SIZE, radius=A, growth=1.3, h_wall=H_WALL,
                         fracture_band=FractureBand(0.0, 0.2, H_WALL, 0.4 * SIZE))
    mech = MechanicsModel(mesh, RockProperties(young=10e9, poisson=0.25, biot=1.0,
                                               tensile_strength=5e6),
                          InSituStress(35e6, 30e6, 0.0, 20e6))
    flow = FlowModel(mesh, FluidProperties(compressibility=4.5e-10, viscosity=1e-3,
                                           reference_pressure=20e6),
                     RockFlowProperties(1e-19, 0.1, 0.0, 20e6), WellCondition(rate=rate),
                     OuterBoundary.fixed_pressure(20e6), height=10.0)
    return CoupledModel(mech, flow, residual_aperture=1e-5)


@pytest.fixture(scope="module")
def grown():
    model = _anisotropic_model()
    stp = CoupledStepper(model)
    steps, opening = [], []

    def record(r, s):
        steps.append(r)
        _, _, wn, _ = model.crack_permeability(s.cluster_state, np.asarray(s.mechanics.gap))
        opening.append(np.where(s.cluster_state != 0, wn, np.nan))

    res = stp.run(200.0, TimeStepControl(dt_initial=2.0, dt_min=1e-4, dt_max=5.0),
                  callback=record,
                  stop=lambda s: fracture_summary(model, s).length >= 1.0)
    return model, stp, res, steps, np.array(opening)


@pytest.mark.slow
def test_fracture_grows_along_sigma_max(grown):
    model, stp, res, steps, _ = grown
    assert res.status == "stopped", res.message
    fs = fracture_summary(model, stp.state)
    assert fs.length >= 1.0
    # perpendicular to sigma_min (y): along x within 10 degrees, for the whole crack and
    # for each wing separately
    assert abs(fs.azimuth_deg) <= 10.0
    mesh = model.mesh
    cs = stp.state.cluster_state
    failed = np.flatnonzero(cs != 0)
    xc = mesh.centroids[failed]
    for side in (xc[:, 0] > 0, xc[:, 0] < 0):
        w = mesh.areas[failed][side]
        ang = math.degrees(math.atan2(np.sum(w * xc[side, 1]), abs(np.sum(w * xc[side, 0]))))
        assert abs(ang) <= 10.0
    # two wings, each at least two wall-element sizes long
    assert min(fs.wing_lengths) >= 2 * H_WALL
    # every failed cluster belongs to the hole-connected crack
    assert fs.n_connected == fs.n_failed


@pytest.mark.slow
def test_no_parallel_fracturing(grown):
    """No layers of failed clusters beside the crack: all failed clusters lie in a narrow
    strip around the crack line (three band elements either side; the band is the refined
    region along x), and none fails on the wall away from the crack mouths."""
    model, stp, *_ = grown
    mesh = model.mesh
    failed = np.flatnonzero(stp.state.cluster_state != 0)
    xc = mesh.centroids[failed]
    assert np.max(np.abs(xc[:, 1])) <= 3 * H_WALL
    wall = np.zeros(mesh.n_nodes, bool)
    wall[mesh.hole_nodes] = True
    at_wall = failed[wall[mesh.triangles[failed]].any(axis=1)]
    az = np.degrees(np.arctan2(mesh.centroids[at_wall, 1], np.abs(mesh.centroids[at_wall, 0])))
    assert np.all(np.abs(az) <= 20.0)


@pytest.mark.slow
def test_mass_balance_steps_and_apertures(grown):
    model, stp, res, steps, opening = grown
    assert len(steps) == len(res.steps) > 10
    assert all(r.relative_mass_balance_error <= 1e-8 for r in steps)
    assert res.max_relative_mass_balance_error <= 1e-8
    assert res.min_dt >= 1e-4
    assert stp.counters.failed_clusters == stp.state.n_failed
    # injected mass = stored change over the run (outer edges at p0 carry ~nothing)
    inj = sum(r.injected_mass for r in steps)
    assert inj == pytest.approx(1000.0 * 2e-4 * stp.state.t, rel=1e-9)
    # no aperture sign-flip oscillation: a failed cluster's crack does not go
    # open -> closed -> open (or closed -> open -> closed) over consecutive steps
    is_open = opening > 0
    known = ~np.isnan(opening)
    flips = 0
    for k in range(2, len(opening)):
        both = known[k - 2] & known[k - 1] & known[k]
        flips += int(np.sum(both & (is_open[k - 2] == is_open[k])
                            & (is_open[k - 1] != is_open[k])))
    assert flips == 0
