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
    CoupledControl,
    CoupledModel,
    CoupledStepper,
    TimeStepControl,
    biot_modulus,
    boundary_load,
    fracture_summary,
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


# ----------------------------------------------------------------- failed clusters
def _crack_model(hole_mesh, **kw):
    """Impermeable-ish rock around the small hole, a pre-cut crack of the clusters cut by
    the line y = 0.01 m within 0.5 m of the centre, pumped into the hole."""
    mesh = hole_mesh
    mech = MechanicsModel(mesh, RockProperties(young=E, poisson=NU, biot=1.0,
                                               tensile_strength=50e6, cohesion=100e6),
                          InSituStress(22e6, 20e6, 0.0, P0))
    flow = FlowModel(mesh, FluidProperties(compressibility=CF, viscosity=1e-3,
                                           reference_pressure=P0),
                     RockFlowProperties(1e-19, PHI, 0.0, P0),
                     WellCondition(rate=kw.pop("rate", 2e-4)),
                     OuterBoundary.fixed_pressure(P0), height=2.0)
    model = CoupledModel(mech, flow, residual_aperture=1e-5, **kw)
    ms0 = mech.initial_state()
    ys = mesh.nodes[mesh.triangles, 1]
    xc = mesh.centroids[:, 0]
    # the line y = 0.01 m passes no node (the wall nodes at y = 0 would split it)
    cut = np.flatnonzero((ys.min(axis=1) < 0.01) & (ys.max(axis=1) > 0.01)
                         & (np.abs(xc) < 0.5))
    return model, mech.fail_clusters(ms0, cut), cut


@pytest.fixture(scope="module")
def opened_crack(hole_mesh):
    """A pre-cut crack pressurised from the hole until it is open (no further failure)."""
    model, ms, cut = _crack_model(hole_mesh)
    stp = CoupledStepper(model, model.initial_state(ms), CoupledControl(check_failure=False))
    for _ in range(6):
        r = stp.step(2.0)
        assert r.success, r.reason
    return model, stp, cut


def test_precut_crack_opens_and_conserves_mass(opened_crack):
    model, stp, cut = opened_crack
    s = stp.state
    assert s.p_w > 22e6                                  # above the confining stress
    fs = fracture_summary(model, s)
    assert fs.n_failed == len(cut) and fs.max_opening > 1e-5
    # the open crack clusters are filled from the hole (pressure close to p_w)
    gap = np.asarray(s.mechanics.gap)
    open_c = cut[gap[cut].max(axis=1) > 0]
    assert open_c.size >= len(cut) // 2
    assert np.all(np.abs(s.p[open_c] - s.p_w) <= 0.05 * (s.p_w - P0))
    for r in stp.history:
        assert r.success and r.relative_mass_balance_error <= 1e-8


def test_jacobian_with_open_crack_matches_finite_differences(opened_crack):
    """All blocks incl. the contact tangent, the crack-face pressure load (coefficient 1),
    dR_f/dk dk/du (cubic law through the contact gaps) and the hole-volume row."""
    model, stp, cut = opened_crack
    st = stp.state
    nu, m = model.n_u, model.n_cells
    x = model.x_of(st).copy()
    rng = np.random.default_rng(5)
    # off the converged state: slipping contacts sit exactly on the Coulomb cap there (a
    # kink of the contact law); 1e-7 m moves every contact off it by far more than h
    x[:nu] += rng.normal(0, 1e-7, nu)
    x[nu:nu + m] += rng.normal(0, 1e3, m)
    dt = 0.5
    res = model.residual_and_jacobian(x, st, dt)
    assert np.any(res.permeability[cut] > 1e-15)     # conductive crack: dk/du is exercised
    J = res.jacobian.tocsc()
    mech = model.mechanics
    red = -np.ones(mech.n_dof, dtype=np.int64)
    red[model.free_dofs] = np.arange(nu)
    near = red[np.unique(mech.dofs[cut].ravel())]
    cols = np.concatenate([near[near >= 0], nu + cut, [nu + m]])
    for j in cols:
        h = 1e-10 if j < nu else 1.0
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        fd = (model.residual_and_jacobian(xp, st, dt).residual
              - model.residual_and_jacobian(xm, st, dt).residual) / (2 * h)
        a = J[:, j].toarray().ravel()
        for rows in (slice(0, nu), slice(nu, nu + m + 1)):
            scale = max(np.max(np.abs(a[rows])), 1e-300)
            # piecewise linear contact law (no kink within +-h at this iterate) and smooth
            # flow terms: central differences good to ~1e-7 of the column; 1e-5 margin
            assert np.max(np.abs(a[rows] - fd[rows])) <= 1e-5 * scale, (j, rows)


def test_lagged_permeability_converges_to_the_same_step(opened_crack):
    """Picard on the crack permeability (Jacobian without dk/du) and the default hybrid
    (lagged until the mass residual is below 1e-3 of its scale, then the full Jacobian)
    reach the same solution; the hybrid needs no more iterations than pure Picard.

    Measured on this step: the full Jacobian from the first iteration does not converge in
    60 iterations (it heads for the w -> 0 root of the cubic-law flux and the contact
    statuses cycle); hybrid 8, lagged 9 iterations."""
    model, stp, _ = opened_crack
    out = []
    for rtol in (1e-3, 0.0):
        s = CoupledStepper(model, stp.state,
                           CoupledControl(check_failure=False, lagged_permeability_rtol=rtol))
        r = s.step(1.0)
        assert r.success and r.relative_mass_balance_error <= 1e-8
        out.append((s.state, r.newton_iterations))
    (auto, n_auto), (lag, n_lag) = out
    assert n_auto <= n_lag
    dp = stp.state.p_w - P0
    # both converged to 1e-11 of the mass scale: pressures agree to ~1e-9 of the rise
    assert abs(auto.p_w - lag.p_w) <= 1e-7 * dp
    assert np.max(np.abs(auto.p - lag.p)) <= 1e-7 * dp
    du = np.asarray(auto.displacement) - np.asarray(stp.state.displacement)
    assert np.max(np.abs(np.asarray(lag.displacement) - np.asarray(auto.displacement))
                  ) <= 1e-6 * np.max(np.abs(du))


def test_well_rate_function_shut_in_and_choke(hole_mesh):
    """Rate from a (t, p_w) function: pump, shut-in (rate 0) and a choke
    Q = -zeta sqrt(p_w - p_ref) with its derivative; the injected mass is the integral of
    the rate at the step midpoints / implicit p_w, and mass is conserved every step."""
    zeta = 2e-9

    def rate(t, pw):
        if t < 10.0:
            return 1e-5
        if t < 20.0:
            return 0.0
        d = max(pw - P0, 0.0)
        return (-zeta * math.sqrt(d), -0.5 * zeta / math.sqrt(d) if d > 0 else 0.0)

    model = _model(hole_mesh, biot=1.0, k=1e-17, well=WellCondition(),
                   outer=OuterBoundary.fixed_pressure(P0), well_rate=rate,
                   well_compliance=1e-9)
    stp = CoupledStepper(model)
    stp.run(40.0, TimeStepControl(dt_initial=1.0, dt_max=1.0), stop_times=(10.0, 20.0))
    hist = [r for r in stp.history if r.success]
    rho0 = model.flow.fluid.density
    pump = sum(r.injected_mass for r in hist if r.t <= 10.0 + 1e-9)
    assert pump == pytest.approx(rho0 * 1e-5 * 10.0, rel=1e-12)
    shut = [r for r in hist if 10.0 < r.t <= 20.0 + 1e-9]
    assert all(r.injected_mass == 0.0 for r in shut)
    back = [r for r in hist if r.t > 20.0 + 1e-9]
    assert all(r.injected_mass < 0 for r in back)       # flowing back through the choke
    for r in hist:
        assert r.relative_mass_balance_error <= 1e-8
    # the well storage includes the extra compliance (per unit height) and the hole
    assert model.well_storage == pytest.approx(model.flow.well_storage + 2.0 * 1e-9)


def test_hole_volume_change_enters_the_well_storage(hole_mesh):
    """Sealed rock, pumping into the hole: the injected volume is the compressed well
    fluid plus the hole's enlargement h f_w.(u - u0), to round-off."""
    q = 1e-6
    model = _model(hole_mesh, biot=1.0, k=0.0, well=WellCondition(rate=q, storage=1e-10))
    stp = CoupledStepper(model)
    stp.run_to(5.0, 1.0)
    s = stp.state
    rho0 = model.flow.fluid.density
    dvw = s.flow.well_extra_volume
    assert dvw > 0          # the pressurised hole grows
    du = np.asarray(s.displacement).reshape(-1)[model.free_dofs] - model.u0[model.free_dofs]
    assert dvw == pytest.approx(model.height * float(model.f_wall @ du), rel=1e-12)
    # mass: rho0 q t = C_w-compressed mass + rho(p_w) * dV_hole + compressed pore fluid
    inj = sum(r.injected_mass for r in stp.history if r.success)
    stored = sum(r.stored_mass_change for r in stp.history if r.success)
    assert inj == pytest.approx(rho0 * q * 5.0, rel=1e-12)
    assert stored == pytest.approx(inj, rel=1e-9)


def test_failure_count_controls_the_step(hole_mesh):
    """A step in which more than n2 clusters would fail is rejected and cut; the run
    reports progress through the callback and ends with a result object."""
    model, ms, cut = _crack_model(hole_mesh, rate=5e-4)
    weak = MechanicsModel(model.mesh, RockProperties(young=E, poisson=NU, biot=1.0,
                                                     tensile_strength=0.5e6, cohesion=5e6),
                          InSituStress(22e6, 20e6, 0.0, P0))
    m2 = CoupledModel(weak, model.flow, residual_aperture=1e-5)
    stp = CoupledStepper(m2, m2.initial_state(weak.fail_clusters(weak.initial_state(), cut)))
    seen = []
    res = stp.run(30.0, TimeStepControl(dt_initial=5.0, dt_min=1e-3, n1=1, n2=3),
                  callback=lambda r, s: seen.append((r.t, r.new_failures)),
                  stop=lambda s: s.n_failed >= len(cut) + 12)
    assert res.success, res.message
    assert len(seen) == len(res.steps) and seen[-1][0] == res.t
    assert any(not r.success and r.reason == "too many failures" for r in stp.history)
    ok = [r for r in stp.history if r.success]
    assert all(r.new_failures <= 3 or r.dt <= 1e-3 * (1 + 1e-9) for r in ok)
    assert stp.counters.failed_clusters == stp.state.n_failed - len(cut)
    assert all(r.relative_mass_balance_error <= 1e-8 for r in ok)


@pytest.mark.parametrize("mode", ["pore", "continuous"])
def test_dilatation_at_failure_is_pore_volume_or_kept_continuous(hole_mesh, mode):
    """With alpha < 1 a cluster's pressure coefficient jumps to 1 when it fails.
    ``failure_dilatation="pore"``: from then on its whole dilatation since the in-situ state
    is pore volume (``V^x = h A eps_vol``, no offset); ``"continuous"``: an offset keeps
    ``V^x`` continuous, so ``V^x - h A eps_vol = (alpha - 1) h A eps_vol`` at failure. The
    fluid is conserved either way (the jump is filled by flow, not created)."""
    mesh, biot = hole_mesh, 0.5
    mech = MechanicsModel(mesh, RockProperties(young=E, poisson=NU, biot=biot,
                                               tensile_strength=0.5e6, cohesion=5e6),
                          InSituStress(22e6, 20e6, 0.0, P0))
    flow = FlowModel(mesh, FluidProperties(compressibility=CF, viscosity=1e-3,
                                           reference_pressure=P0),
                     RockFlowProperties(1e-19, PHI, grain_pore_compressibility(biot, PHI, E, NU),
                                        P0),
                     WellCondition(rate=5e-4), OuterBoundary.fixed_pressure(P0), height=2.0)
    model = CoupledModel(mech, flow, residual_aperture=1e-5, failure_dilatation=mode)
    stp = CoupledStepper(model)
    res = stp.run(60.0, TimeStepControl(dt_initial=2.0, dt_min=1e-3, n1=1, n2=4),
                  stop=lambda s: s.n_failed >= 3)
    assert res.success, res.message
    s = stp.state
    failed = np.flatnonzero(s.cluster_state != 0)
    assert failed.size >= 3
    vx = np.asarray(s.flow.extra_pore_volume)[failed]
    whole = model.height * mesh.areas[failed] * model.volumetric_strain(s)[failed]
    off = np.asarray(s.volume_offset)[failed]
    # V^x is assembled from the same dilatation: equal to round-off of the largest term
    assert np.allclose(vx, whole + off, rtol=0, atol=1e-12 * np.max(np.abs(whole)))
    if mode == "pore":
        assert np.all(off == 0.0)
    else:
        # tension failure stretches the cluster first, so the offset is a real (negative)
        # correction, a sizeable share of the dilatation
        assert np.all(off < 0.0)
    assert all(r.relative_mass_balance_error <= 1e-8 for r in stp.history if r.success)
    ok = [r for r in stp.history if r.success]
    balance = sum(r.injected_mass - r.stored_mass_change - r.outflow_mass for r in ok)
    assert abs(balance) <= 1e-8 * sum(r.injected_mass for r in ok)


def test_unknown_failure_dilatation_is_refused(hole_mesh):
    with pytest.raises(InputError, match="failure_dilatation"):
        _model(hole_mesh, failure_dilatation="elastic")


def test_newton_backs_off_a_non_finite_update(hole_mesh):
    """A Newton update whose residual is not finite (rho(p) overflowing at a wild cell
    pressure) is shortened along its direction instead of ending the solve; the step then
    converges to the same answer as an undisturbed one. The overflow is imitated: the
    residual at the first full Newton update is made non-finite."""
    q = 2e-6
    model = _model(hole_mesh, biot=0.8, well=WellCondition(storage=5e-11, rate=q),
                   outer=OuterBoundary.fixed_pressure(P0), k=1e-16)
    ref = CoupledStepper(model)
    assert ref.step(5.0).success
    real = model.residual_and_jacobian

    def run(control):
        calls = []

        def wild(x, *a, **kw):
            out = real(x, *a, **kw)
            calls.append(x[-1])
            if len(calls) == 2:           # the first update lands "too far"
                out.residual[:] = np.nan
            return out

        model.residual_and_jacobian = wild
        try:
            stp = CoupledStepper(model, control=control)
            return stp.step(5.0), stp, calls
        finally:
            del model.residual_and_jacobian

    r, stp, calls = run(CoupledControl())
    assert r.success, r.reason
    pw0 = model.initial_state().p_w
    # the third evaluation is a quarter of the way along the rejected update
    assert calls[2] - pw0 == pytest.approx(0.25 * (calls[1] - pw0), rel=1e-9)
    jump = abs(ref.state.p_w - pw0)
    assert stp.state.p_w == pytest.approx(ref.state.p_w, rel=0, abs=1e-6 * jump)
    # without back-offs the same disturbance ends the solve (the fold predictor, which
    # would solve the step again from a longer one, is off: this tests the back-off alone)
    r, _, _ = run(CoupledControl(nonfinite_backoffs=0, fold_factors=()))
    assert not r.success and r.reason == "newton: non-finite"
def test_branch_violation_measures_the_miss_of_each_held_branch(hole_mesh):
    """The gap tolerance of the held contact branches (CoupledControl.contact_gap_rtol)
    compares distances [m]: overlap of a contact held open, opening of one held closed,
    shear displacement past the friction limit (stick) or short of it (slip)."""
    from types import SimpleNamespace

    from xlotkit.sim.coupling.newton import branch_violation
    from xlotkit.sim.mechanics import OPEN, SLIP, STICK

    model = _model(hole_mesh)
    model.initial_state()
    stp = CoupledStepper(model)
    mech = model.mechanics
    nc = model.n_cells
    kn, ks, mu = mech.kn, mech.ks, mech.mu
    zero = np.zeros((nc, 3))
    st = SimpleNamespace(ref_normal=zero, ref_shear=zero)
    # contact 0 of every cluster: normal displacement -1e-6 m (1 um overlap), shear
    # displacement chosen so |F_s| is 10 % above the friction limit
    Un = np.full((nc, 3), -1e-6)
    cap_disp = mu * kn * 1e-6 / ks            # shear displacement at the friction limit
    Us = 1.1 * cap_disp
    res = SimpleNamespace(response=(None, None, None, Un, Us))
    held = np.full((nc, 3), OPEN)
    v = branch_violation(stp.model, res, st, held, zero)
    assert np.allclose(v, 1e-6, rtol=1e-12)                 # overlap of an open contact
    v = branch_violation(stp.model, res, st, np.full((nc, 3), STICK), zero)
    assert np.allclose(v, 0.1 * cap_disp, rtol=1e-9)         # past the limit in stick
    v = branch_violation(stp.model, res, st, np.full((nc, 3), SLIP), np.ones((nc, 3)))
    assert np.all(v == 0.0)                                  # slipping in its sign: exact
    v = branch_violation(stp.model, res, st, np.full((nc, 3), SLIP), -np.ones((nc, 3)))
    assert np.allclose(v, 2.1 * cap_disp, rtol=1e-9)         # wrong sign: the whole way back
    # an opening of 2 um is the violation of a contact held closed
    res = SimpleNamespace(response=(None, None, None, np.full((nc, 3), 2e-6), zero))
    v = branch_violation(stp.model, res, st, np.full((nc, 3), STICK), zero)
    assert np.allclose(v, 2e-6, rtol=1e-12)
    with pytest.raises(InputError, match="contact_gap_rtol"):
        CoupledControl(contact_gap_rtol=-1.0)


def test_attempt_steps_over_a_floor_failure_and_limits_a_running_crack(hole_mesh):
    """CoupledStepper.attempt (the rules run() and the 2D engine share): a floor step that
    fails is retried with continuation and then stepped over by dt_min * jump^k; while the
    crack runs the failure limit is crack_growth * n_failed, not n2."""
    from types import SimpleNamespace

    from xlotkit.sim.coupling import StepResult

    model = _model(hole_mesh)
    stp = CoupledStepper(model, model.initial_state())
    calls = []

    def fake_step(dt, max_new_failures=None, max_dp_w=None, continuation=False):
        calls.append((dt, max_new_failures, continuation))
        ok = dt > 1.5e-4           # the floor step (1e-4 s) has no solution, 4e-4 s has
        return StepResult(ok, "converged" if ok else "newton: stalled", 1, 1, dt,
                          stp.state.t + (dt if ok else 0.0))

    stp.step = fake_step
    c = TimeStepControl(dt_min=1e-4, dt_max=1.0, n2=8, crack_growth=0.5)
    r, h = stp.attempt(1e-4, c, limit=10.0)
    assert r.success and h == pytest.approx(4e-4)
    # the floor try: no failure limit, with continuation; then the jump, all rules waived
    assert calls == [(1e-4, None, True), (pytest.approx(4e-4), None, True)]
    # jumps are capped by the next mark: one try up to it, then the failure is final
    calls.clear()
    r, h = stp.attempt(1e-4, c, limit=1.2e-4)
    assert not r.success and h == 1e-4
    assert [d for d, _, _ in calls] == [1e-4, pytest.approx(1.2e-4)]
    # a running crack of 40 failed clusters may fail 20 in the next step (n2 = 8)
    calls.clear()
    stp.state = SimpleNamespace(t=0.0, n_failed=40)          # a crack of 40 clusters
    stp.attempt(0.1, c, running=True)
    stp.attempt(0.1, c, running=False)
    assert [m for _, m, _ in calls] == [20, 8]
