"""Poroelastic coupling off: the coupled step is pure mechanics plus uncoupled flow.

With ``effects.poroelastic`` off the intact rock's skeleton is decoupled from its pore
fluid (Biot ``alpha = 0``): the monolithic step (xlotkit.sim.coupling) must then give

* the matrix and well pressures of the flow model stepped on its own (no skeleton volume
  change, the same well, the same steps): :class:`xlotkit.sim.flow.FlowStepper`;
* the displacements of the mechanics model equilibrated on its own under the well
  pressure only (the pore pressure does not load an ``alpha = 0`` skeleton):
  :meth:`xlotkit.sim.mechanics.MechanicsModel.step`;

and its Jacobian stores no pressure-coupling entry (``G``, ``Cfu``) for an intact cluster:
the blocks are absent, not zero-weighted (issue 17).

The hole's volume change with the wall displacement is a well effect, not Biot coupling;
it is switched off here (``hole_volume_change=False``) so that the well row, too, is the
flow model's own.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit.sim.coupling import CoupledControl, CoupledModel, CoupledStepper
from xlotkit.sim.flow import (
    FlowModel,
    FlowStepper,
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    StepControl,
    WellCondition,
)
from xlotkit.sim.mechanics import InSituStress, MechanicsModel, RockProperties
from xlotkit.sim.mesh import borehole_mesh

E, NU, PHI, CF, P0, Q = 10e9, 0.25, 0.2, 4.5e-10, 10e6, 2e-6
DTS = [1.0, 2.0, 4.0, 8.0, 8.0, 16.0]


def _flow(mesh):
    # uncoupled storage: porosity x fluid compressibility only (no grain term)
    return FlowModel(mesh, FluidProperties(compressibility=CF, viscosity=1e-3,
                                           reference_pressure=P0),
                     RockFlowProperties(1e-16, PHI, 0.0, P0),
                     WellCondition(storage=5e-11, rate=Q), OuterBoundary.fixed_pressure(P0),
                     height=2.0)


def _mech(mesh, biot):
    # strong rock: no cluster fails, the answer is the intact (linear) one
    return MechanicsModel(mesh, RockProperties(young=E, poisson=NU, biot=biot,
                                               tensile_strength=100e6, cohesion=200e6),
                          InSituStress(20e6, 18e6, 0.0, P0))


@pytest.fixture(scope="module")
def mesh():
    return borehole_mesh(size=4.0, radius=0.15, growth=1.5, h_wall=2 * math.pi * 0.15 / 16)


def _coupled_run(mesh, biot):
    model = CoupledModel(_mech(mesh, biot), _flow(mesh), hole_volume_change=False,
                         check_storage=False)
    stp = CoupledStepper(model, control=CoupledControl(check_failure=False))
    for dt in DTS:
        r = stp.step(dt)
        assert r.success, r.reason
    return model, stp


def _flow_alone(mesh):
    flow = _flow(mesh)
    fs = FlowStepper(flow, flow.initial_state(P0),
                     StepControl(newton_rtol=1e-12, stagnation_rtol=1e-9))
    for dt in DTS:
        r = fs.step(dt)
        assert r.success, r.reason
    return fs.state


def test_poroelastic_off_is_mechanics_plus_uncoupled_flow(mesh):
    model, stp = _coupled_run(mesh, 0.0)
    s = stp.state
    f = _flow_alone(mesh)
    dp = np.asarray(f.p) - P0
    assert s.p_w - P0 > 1e5 and np.max(dp) > 1e4          # the pump has raised both
    # Flow: the same discrete equations solved by two Newtons, each to a mass residual
    # of <= 1e-10 of the throughput (coupled) / 1e-12 (flow alone), so the pressures
    # agree to ~1e-10 of their change (measured: 6e-13 well, 4e-13 matrix). 1e-9 leaves
    # room for round-off of the two assemblies and is 1e4 below the effect of the former
    # alpha = 1e-3 stand-in (3.6e-5 of the change; test below).
    assert abs(s.p_w - f.p_w) <= 1e-9 * (f.p_w - P0)
    assert np.max(np.abs(np.asarray(s.p) - np.asarray(f.p))) <= 1e-9 * np.max(np.abs(dp))
    # Mechanics: equilibrium under the well pressure alone (pore pressure left at p0;
    # alpha = 0 means it does not matter); the coupled Newton's force tolerance is
    # 1e-10 of the force scale, so displacements agree to ~1e-9 of their change
    # (measured: 7e-14); alpha = 1e-3 moves them by 4e-4 of the change
    mech = model.mechanics
    mr = mech.step(model.mech_state0, wall_pressure=s.p_w, check_failure=False)
    assert mr.converged
    du = np.asarray(mr.state.displacement) - np.asarray(model.mech_state0.displacement)
    assert np.max(np.abs(np.asarray(s.displacement) - np.asarray(mr.state.displacement))
                  ) <= 1e-9 * np.max(np.abs(du))


def test_old_small_biot_path_is_measurably_coupled(mesh):
    """The former stand-in for "off" (intact alpha = 1e-3) couples: its pressures differ
    from the uncoupled flow by far more than the tolerance above, so the test above
    discriminates."""
    _, stp = _coupled_run(mesh, 1e-3)
    f = _flow_alone(mesh)
    dp = np.max(np.abs(np.asarray(f.p) - P0))
    # measured 3.6e-5 of the pressure change: 1e4 x the tolerance above
    assert np.max(np.abs(np.asarray(stp.state.p) - np.asarray(f.p))) > 1e-6 * dp


def test_no_pressure_coupling_entries_for_intact_clusters(mesh):
    """alpha = 0: the Jacobian has no G / Cfu entry of an intact cluster, so it has
    exactly the entries of the alpha > 0 Jacobian minus those blocks' own (the mechanics
    and flow blocks do not share their positions)."""
    m0, s0 = _coupled_run(mesh, 0.0)
    m1, s1 = _coupled_run(mesh, 0.5)
    assert not m0.layout.biot_blocks and m1.layout.biot_blocks
    x0, x1 = m0.x_of(s0.state), m1.x_of(s1.state)
    J0 = m0.residual_and_jacobian(x0, s0.state, 1.0).jacobian
    J1 = m1.residual_and_jacobian(x1, s1.state, 1.0).jacobian
    nu = m0.n_u
    # the u-rows x cell-columns block (G) and the cell-rows x u-columns block (Cfu)
    assert J0[:nu, nu:nu + m0.n_cells].nnz == 0
    assert J0[nu:nu + m0.n_cells, :nu].nnz == 0
    g1 = J1[:nu, nu:nu + m1.n_cells].nnz
    c1 = J1[nu:nu + m1.n_cells, :nu].nnz
    assert g1 > 0 and c1 > 0
    assert J0.nnz == J1.nnz - g1 - c1
