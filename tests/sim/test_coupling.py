"""Unit tests of the monolithic poroelastic step (xlotkit.sim.coupling).

Terzaghi consolidation against the series solution is in
tests/verification/test_consolidation.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit.errors import InputError
from xlotkit.sim.coupling import (
    CoupledModel,
    CoupledStepper,
    biot_modulus,
    boundary_load,
    grain_pore_compressibility,
)
from xlotkit.sim.flow import (
    FlowModel,
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    WellCondition,
)
from xlotkit.sim.mechanics import InSituStress, MechanicsModel, RockProperties
from xlotkit.sim.mesh import RIGHT, TOP, borehole_mesh, rectangle_mesh

E, NU, PHI, CF = 10e9, 0.25, 0.2, 4.5e-10
P0 = 10e6


def _model(mesh, biot=0.8, outer=None, well=None, load=None, k=1e-15, stress=(20e6, 18e6),
           cr=None, **kw):
    mech = MechanicsModel(mesh, RockProperties(young=E, poisson=NU, biot=biot),
                          InSituStress(stress[0], stress[1], 0.0, P0))
    cr = grain_pore_compressibility(biot, PHI, E, NU) if cr is None else cr
    flow = FlowModel(mesh, FluidProperties(compressibility=CF, viscosity=1e-3,
                                           reference_pressure=P0),
                     RockFlowProperties(k, PHI, cr, P0), well or WellCondition(),
                     outer or OuterBoundary(), height=2.0)
    return CoupledModel(mech, flow, load=load, **kw)


@pytest.fixture(scope="module")
def hole_mesh():
    # ~300 triangles around a 0.15 m hole in a 4 m square
    return borehole_mesh(size=4.0, radius=0.15, growth=1.5, h_wall=2 * math.pi * 0.15 / 16)


# ----------------------------------------------------------------- helpers
def test_grain_pore_compressibility_and_biot_modulus():
    K = E / (3 * (1 - 2 * NU))
    a = 0.7
    Ks = K / (1 - a)
    assert grain_pore_compressibility(1.0, PHI, E, NU) == 0.0
    assert math.isclose(PHI * grain_pore_compressibility(a, PHI, E, NU), (a - PHI) / Ks,
                        rel_tol=1e-12)
    assert math.isclose(1 / biot_modulus(a, PHI, CF, E, NU), PHI * CF + (a - PHI) / Ks,
                        rel_tol=1e-12)
    with pytest.raises(InputError):
        grain_pore_compressibility(0.1, PHI, E, NU)


def test_double_counted_storage_is_refused():
    mesh = rectangle_mesh(1.0, 1.0, 2, 2)
    with pytest.raises(InputError, match="double counting"):
        _model(mesh, biot=0.8, cr=1e-9)      # a drained pore compressibility
    _model(mesh, biot=0.8, cr=1e-9, check_storage=False)  # allowed when asked for


def test_mesh_mismatch_is_refused():
    m1 = rectangle_mesh(1.0, 1.0, 2, 2)
    m2 = rectangle_mesh(1.0, 1.0, 3, 2)
    mech = MechanicsModel(m1, RockProperties(young=E, poisson=NU), InSituStress(20e6, 20e6,
                                                                                0.0, P0))
    flow = FlowModel(m2, FluidProperties(), RockFlowProperties(1e-15, PHI, 0.0))
    with pytest.raises(InputError):
        CoupledModel(mech, flow)


# ----------------------------------------------------------------- Jacobian
def _fd_check(model, state, dt, rng, n_cols=60, undrained=False):
    """Compare analytic Jacobian columns with central differences at a perturbed iterate."""
    nu, m = model.n_u, model.n_cells
    x = model.x_of(state).copy()
    # a generic iterate: displacements ~1e-4 m, pressures +-0.5 MPa, well +1 MPa
    x[:nu] += rng.normal(0, 1e-4, nu)
    x[nu:nu + m] += rng.normal(0, 5e5, m)
    x[-1] += 1e6
    res = model.residual_and_jacobian(x, state, dt, undrained=undrained)
    J = res.jacobian.toarray()
    cols = np.unique(np.concatenate([rng.choice(nu, n_cols // 2, replace=False),
                                     nu + rng.choice(m, n_cols // 2, replace=False),
                                     [nu + m]]))
    for j in cols:
        h = 1e-7 if j < nu else 10.0        # [m] or [Pa]
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        fd = (model.residual_and_jacobian(xp, state, dt, undrained=undrained).residual
              - model.residual_and_jacobian(xm, state, dt, undrained=undrained).residual
              ) / (2 * h)
        # row blocks have different units: compare each block against its own scale
        for rows in (slice(0, nu), slice(nu, nu + m + 1)):
            a, b = J[rows, j], fd[rows]
            scale = max(np.max(np.abs(J[rows])), 1e-300)
            # central differences of a function that is linear (mechanics) or smooth
            # (exp density) away from upwind switches: truncation ~h^2, round-off
            # ~eps |R| / h; 1e-6 of the block's largest entry covers both
            assert np.max(np.abs(a - b)) <= 1e-6 * scale, (j, np.max(np.abs(a - b)), scale)


def test_jacobian_matches_finite_differences_well(hole_mesh):
    model = _model(hole_mesh, biot=0.7, well=WellCondition(storage=1e-10, rate=1e-5),
                   outer=OuterBoundary.fixed_pressure(P0))
    st = model.initial_state()
    _fd_check(model, st, 10.0, np.random.default_rng(1))


def test_jacobian_matches_finite_differences_undrained_and_constraints():
    mesh = rectangle_mesh(1.0, 2.0, 3, 5, jitter=0.2, seed=3)
    right = np.flatnonzero(np.isclose(mesh.nodes[:, 0], 0.5))
    model = _model(mesh, biot=1.0, outer=OuterBoundary({TOP: P0}),
                   load=boundary_load(mesh, TOP, 1e6), fixed_dofs=2 * right)
    st = model.initial_state()
    rng = np.random.default_rng(2)
    _fd_check(model, st, 5.0, rng)
    _fd_check(model, st, 1.0, rng, undrained=True)


def test_coupling_blocks_are_the_biot_transpose_pair(hole_mesh):
    """dR_f/du = -(rho/dt) h G^T: the fluid-volume operator is the transpose of the
    pressure-force operator (discrete Biot reciprocity)."""
    model = _model(hole_mesh, biot=0.8)
    st = model.initial_state()
    dt = 3.0
    res = model.residual_and_jacobian(model.x_of(st), st, dt)
    nu, m = model.n_u, model.n_cells
    J = res.jacobian.tocsr()
    Kp = J[:nu, nu:nu + m].toarray()
    Cf = J[nu:nu + m, :nu].toarray()
    rho = model.flow.fluid.rho(st.p)
    assert np.allclose(Cf, -(rho / dt * model.height)[:, None] * Kp.T, rtol=1e-14,
                       atol=0.0)


# ----------------------------------------------------------------- undrained response
@pytest.mark.parametrize("biot", [1.0, 0.8, 0.5])
def test_undrained_skempton_plane_strain(biot):
    """In-plane isotropic load step dq on a sealed sample (plane strain):
    p - p0 = B dq with B = alpha M / (K_2 + alpha^2 M), K_2 = lambda + G."""
    mesh = rectangle_mesh(1.0, 1.0, 5, 5, jitter=0.2, seed=7)
    dq = 1e5
    model = _model(mesh, biot=biot, load=boundary_load(mesh, (TOP, RIGHT), dq),
                   stress=(20e6, 20e6))
    stp = CoupledStepper(model)
    r = stp.step_undrained()
    assert r.success and r.t == 0.0 and r.dt == 0.0
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    G = E / (2 * (1 + NU))
    M = biot_modulus(biot, PHI, CF, E, NU)
    B = biot * M / (lam + G + biot ** 2 * M)
    dp = stp.state.p - P0
    # the discrete model stores mass with rho(p) = rho0 exp(c_f dp) and phi(p): it differs
    # from the linear closed form by O(c_f dp) = 4.5e-5; uniform field otherwise exact
    # (patch test), so 1e-4 relative
    assert np.allclose(dp / dq, B, rtol=1e-4, atol=0.0)
    assert np.ptp(dp) <= 1e-9 * dq
    # undrained: no mass moves anywhere
    assert abs(r.stored_mass_change) <= 1e-12 * model.flow.cell_mass(stp.state.flow).sum()
    # total stress change is the applied load
    s = model.stress(stp.state)
    assert np.allclose(s[:, :2], 20e6 + dq, rtol=1e-9)
    # and the volumetric strain closes the undrained storage: alpha eps_v = -dp/M
    ev = model.volumetric_strain(stp.state)
    assert np.allclose(biot * ev, -dp / M, rtol=2e-4)


def test_undrained_limit_of_short_steps():
    """A backward-Euler step much shorter than the diffusion time of a cell reproduces
    the instantaneous response away from a drained edge."""
    mesh = rectangle_mesh(1.0, 1.0, 4, 4)
    dq = 1e6
    model = _model(mesh, load=lambda t: boundary_load(mesh, (TOP, RIGHT), dq),
                   stress=(20e6, 20e6))
    a = CoupledStepper(model)
    a.step_undrained()
    b = CoupledStepper(model, model.initial_state())
    r = b.step(1e-3)
    assert r.success
    assert np.allclose(a.state.p, b.state.p, rtol=1e-12, atol=1e-6 * dq)


# ----------------------------------------------------------------- well injection
def test_injection_mass_balance_and_mechanics_consistency(hole_mesh):
    """Pump into the hole: mass balance every step; the displacements equal the
    mechanics' own equilibrium under the coupled pressures (same G and wall load)."""
    q = 2e-6
    model = _model(hole_mesh, biot=0.8, well=WellCondition(storage=5e-11, rate=q),
                   outer=OuterBoundary.fixed_pressure(P0), k=1e-16)
    stp = CoupledStepper(model)
    res = stp.run_to(60.0, 1.0, growth=1.5)
    assert stp.state.t == pytest.approx(60.0, rel=1e-14)
    assert len(res) == stp.counters.steps
    assert stp.counters.newton_iterations >= stp.counters.steps
    inj = sum(r.injected_mass for r in res)
    assert inj == pytest.approx(model.flow.fluid.density * q * 60.0, rel=1e-12)
    for r in res:
        assert r.success and r.relative_mass_balance_error <= 1e-8
        assert abs(r.injected_mass - r.stored_mass_change - r.outflow_mass) <= 1e-8 * abs(
            r.injected_mass)
    assert stp.state.p_w > P0 + 1e5
    mech = model.mechanics
    mr = mech.step(model.mech_state0, wall_pressure=stp.state.p_w,
                   pore_pressure=stp.state.p, check_failure=False)
    assert mr.converged
    u_m = np.asarray(mr.state.displacement)
    du = np.asarray(stp.state.displacement) - np.asarray(model.mech_state0.displacement)
    assert np.max(np.abs(np.asarray(stp.state.displacement) - u_m)) <= 1e-6 * np.max(
        np.abs(du))
    # stress post-processing agrees with the mechanics' own (compression positive)
    assert np.allclose(model.stress(stp.state), np.asarray(mr.state.stress), rtol=0,
                       atol=1e-6 * 20e6)


def test_bad_step_inputs(hole_mesh):
    model = _model(hole_mesh)
    stp = CoupledStepper(model)
    for dt in (0.0, -1.0, float("nan")):
        with pytest.raises(InputError):
            stp.step(dt)
    with pytest.raises(InputError):
        _model(hole_mesh, load=np.zeros(3))
