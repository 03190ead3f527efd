"""Unit tests of the flow model: kernels, geometry, residual/Jacobian, stepper mechanics.

Physics verification against analytic solutions is in tests/verification/test_flow_radial.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit.errors import InputError
from xlotkit.sim.flow import (
    crack_opening,
    crack_permeability,
    crack_permeability_derivative,
    FlowModel,
    FlowState,
    FlowStepper,
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    StepControl,
    WellCondition,
    arithmetic_transmissibility,
    cluster_length_scale,
    cubic_law_permeability,
    density,
    edge_geometry,
    fracture_porosity,
    harmonic_transmissibility,
    hydraulic_aperture,
    permeability_multiplier,
    permeability_multiplier_derivative,
    upscaled_permeability,
)
from xlotkit.sim.flow.model import circumcentres
from xlotkit.sim.mesh import LEFT, RIGHT, borehole_mesh, mesh_from_triangles

P0 = 10e6


@pytest.fixture(scope="module")
def small_mesh():
    # ~300 triangles: enough structure (wall, rings, square boundary), fast
    return borehole_mesh(size=4.0, radius=0.15, growth=1.5, h_wall=2 * math.pi * 0.15 / 16)


def _fluid(**kw):
    base = dict(compressibility=4.5e-10, viscosity=1e-3, reference_pressure=P0)
    base.update(kw)
    return FluidProperties(**base)


def _rock(k=1e-15, phi=0.2, cr=1e-9):
    return RockFlowProperties(permeability=k, porosity=phi, pore_compressibility=cr,
                              reference_pressure=P0)


# --------------------------------------------------------------------- fracture kernels
class TestFractureKernels:
    def test_cubic_law(self):
        w = np.array([0.0, 1e-5, 1e-4])
        np.testing.assert_allclose(cubic_law_permeability(w), w ** 2 / 12.0, rtol=0, atol=0)
        # 10 micron aperture -> 8.33e-12 m^2 (about 8.4 darcy)
        assert cubic_law_permeability(1e-5) == pytest.approx(8.333333e-12, rel=1e-6)

    def test_hydraulic_aperture(self):
        wn = np.array([-1e-5, 0.0, 2e-5])
        np.testing.assert_allclose(hydraulic_aperture(wn, 1e-6), [1e-6, 1e-6, 2.1e-5])
        # dilation only with an angle; tan(psi)|u_s| added
        us = np.array([1e-4, -1e-4, 0.0])
        np.testing.assert_allclose(hydraulic_aperture(wn, 1e-6, us),
                                   hydraulic_aperture(wn, 1e-6))
        psi = math.radians(5.0)
        np.testing.assert_allclose(hydraulic_aperture(wn, 1e-6, us, psi),
                                   [1e-6 + math.tan(psi) * 1e-4,
                                    1e-6 + math.tan(psi) * 1e-4, 2.1e-5])

    def test_hydraulic_aperture_errors(self):
        with pytest.raises(InputError) as e:
            hydraulic_aperture([0.0], -1e-6)
        assert e.value.key == "residual_aperture"
        with pytest.raises(InputError) as e:
            hydraulic_aperture([0.0], 0.0, [1.0], math.pi / 2)
        assert e.value.key == "dilation_angle"

    def test_multiplier_and_upscaling(self):
        w, km, d = 1e-5, 1e-18, 0.1
        pm = permeability_multiplier(w, km, d)
        assert pm == pytest.approx(1.0 + (w ** 2 / 12) * w / (km * d), rel=1e-14)
        assert upscaled_permeability(w, km, d) == pytest.approx(km + w ** 3 / (12 * d),
                                                                rel=1e-12)
        assert permeability_multiplier(0.0, km, d) == 1.0
        # derivative by central differences
        h = 1e-9
        fd = (permeability_multiplier(w + h, km, d) - permeability_multiplier(w - h, km, d)) / (
            2 * h)
        assert permeability_multiplier_derivative(w, km, d) == pytest.approx(fd, rel=1e-6)
        with pytest.raises(InputError) as e:
            permeability_multiplier(w, 0.0, d)
        assert e.value.key == "matrix_permeability"

    def test_porosity_consistent_with_multiplier(self):
        # crack of aperture w and trace length l through a cell of area A, height h:
        # Delta = A/l makes k - k_m = k_f * phi_f (parallel flow through rock and crack)
        A, ell, h, w, km = 0.02, 0.15, 10.0, 3e-5, 1e-19
        delta = cluster_length_scale(A, ell)
        phi_f = fracture_porosity(w * ell * h, A * h)
        k = upscaled_permeability(w, km, delta)
        assert k - km == pytest.approx(cubic_law_permeability(w) * phi_f, rel=1e-12)
        assert cluster_length_scale(4.0) == 2.0
        assert fracture_porosity(-1.0, 2.0) == 0.0


# --------------------------------------------------------------------- geometry kernels
class TestGeometry:
    def test_transmissibility_averages(self):
        # series: 1/T = 1/t_a + 1/t_b
        assert harmonic_transmissibility(1.0, 1.0, 2.0, 2.0) == pytest.approx(1.0)
        assert harmonic_transmissibility(1e-12, 1e-18, 1.0, 1.0) == pytest.approx(
            1e-18, rel=1e-6)
        assert harmonic_transmissibility(0.0, 1.0, 1.0, 1.0) == 0.0
        assert harmonic_transmissibility(2.0, 1.0, 1.0, np.inf) == pytest.approx(2.0)
        # arithmetic mean lets the high value dominate
        assert arithmetic_transmissibility(1e-12, 1e-18, 1.0, 1.0) == pytest.approx(
            0.25e-12, rel=1e-5)
        # both agree for equal permeability
        assert arithmetic_transmissibility(3.0, 3.0, 2.0, 5.0) == pytest.approx(
            harmonic_transmissibility(3.0, 3.0, 2.0, 5.0))

    def test_edge_geometry_right_triangles(self):
        nodes = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
        tris = np.array([[0, 1, 2], [0, 2, 3]])
        m = mesh_from_triangles(nodes, tris)
        edges, owners = m.edges()
        length, dist = edge_geometry(m.nodes, edges, m.centroids, owners)
        diag = np.flatnonzero((owners[:, 1] >= 0))[0]
        assert length[diag] == pytest.approx(math.sqrt(2))
        # centroid (2/3, 1/3) to the diagonal y = x: distance (1/3)/sqrt(2)
        np.testing.assert_allclose(dist[diag], [1 / (3 * math.sqrt(2))] * 2)
        assert np.all(np.isinf(dist[owners[:, 1] < 0, 1]))
        # circumcentres of right triangles lie on the hypotenuse midpoint
        np.testing.assert_allclose(circumcentres(m.nodes, m.triangles), [[0.5, 0.5]] * 2,
                                   atol=1e-15)

    def test_circumcentres_equidistant(self, small_mesh):
        c = circumcentres(small_mesh.nodes, small_mesh.triangles)
        d = np.linalg.norm(small_mesh.nodes[small_mesh.triangles] - c[:, None, :], axis=2)
        np.testing.assert_allclose(d, d[:, :1].repeat(3, axis=1), rtol=1e-10)


# --------------------------------------------------------------------- model set-up
class TestModelSetup:
    def test_counts_and_storage(self, small_mesh):
        model = FlowModel(small_mesh, _fluid(), _rock(), height=10.0)
        assert model.n_unknowns == small_mesh.n_triangles + 1
        assert model.n_well_faces == len(small_mesh.hole_edges)
        assert model.n_fixed_faces == 0
        np.testing.assert_allclose(model.volumes, small_mesh.areas * 10.0)
        # default well storage: the segment's own fluid volume times c_f
        assert model.well_storage == pytest.approx(math.pi * 0.15 ** 2 * 10.0 * 4.5e-10)
        fixed = FlowModel(small_mesh, _fluid(), _rock(),
                          outer=OuterBoundary.fixed_pressure(P0))
        assert fixed.n_fixed_faces == len(small_mesh.boundary_edges) - len(
            small_mesh.hole_edges)

    def test_bad_inputs(self, small_mesh):
        with pytest.raises(InputError) as e:
            FlowModel(small_mesh, _fluid(), _rock(), averaging="geometric")
        assert e.value.key == "flow.averaging"
        with pytest.raises(InputError) as e:
            FlowModel(small_mesh, _fluid(), _rock(), height=0.0)
        assert e.value.key == "flow.height"
        with pytest.raises(InputError) as e:
            FlowModel(small_mesh, _fluid(), _rock(), cell_centres="incentre")
        assert e.value.key == "flow.cell_centres"
        with pytest.raises(InputError) as e:
            RockFlowProperties(permeability=1e-15, porosity=0.0)
        assert e.value.key == "rock.porosity"
        with pytest.raises(InputError) as e:
            FluidProperties(viscosity=-1.0)
        assert e.value.key == "fluid.viscosity"
        with pytest.raises(InputError) as e:
            FlowModel(small_mesh, _fluid(), RockFlowProperties(permeability=np.ones(3) * 1e-15,
                                                               porosity=0.1))
        assert e.value.key == "rock.permeability"
        with pytest.raises(InputError) as e:
            OuterBoundary({0: 1.0})
        assert e.value.key == "outer_boundary.fixed"
        with pytest.raises(InputError) as e:
            # zero storage and an impermeable wall: the well equation would be singular
            FlowModel(small_mesh, _fluid(), _rock(k=0.0), WellCondition(rate=1e-6, storage=0))
        assert e.value.key == "well.storage"

    def test_no_hole_mesh_rejects_well_rate(self):
        nodes = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
        m = mesh_from_triangles(nodes, [[0, 1, 2], [0, 2, 3]])
        with pytest.raises(InputError) as e:
            FlowModel(m, _fluid(), _rock(), WellCondition(rate=1e-6))
        assert e.value.key == "well"
        model = FlowModel(m, _fluid(), _rock())
        assert not model.has_well

    def test_density(self):
        f = _fluid()
        assert f.rho(P0) == 1000.0
        assert density(P0 + 1e6, f) == pytest.approx(1000.0 * math.exp(4.5e-4))


# --------------------------------------------------------------------- residual / Jacobian
def _fd_jacobian(model, state, old, dt, kwargs_of_x):
    x0 = state.x
    n = len(x0)
    J = np.zeros((n, n))
    for j in range(n):
        h = 1e-3 * max(abs(x0[j] - P0), 1e3)
        xp = x0.copy()
        xp[j] += h
        xm = x0.copy()
        xm[j] -= h
        rp = model.residual_and_jacobian(state.with_x(xp), old, dt,
                                         **kwargs_of_x(xp)).residual
        rm = model.residual_and_jacobian(state.with_x(xm), old, dt,
                                         **kwargs_of_x(xm)).residual
        J[:, j] = (rp - rm) / (2 * h)
    return J


@pytest.mark.parametrize("case", ["rate", "pressure", "fixed_outer", "arithmetic",
                                  "centroid", "choke"])
def test_jacobian_matches_finite_differences(small_mesh, case):
    rng = np.random.default_rng(3)
    m = small_mesh.n_triangles
    k = 10 ** rng.uniform(-16, -14, m)          # heterogeneous
    rock = RockFlowProperties(permeability=k, porosity=rng.uniform(0.05, 0.3, m),
                              pore_compressibility=1e-9, reference_pressure=P0)
    def kw(x):
        return {}
    well = WellCondition(rate=1e-5, storage=1e-9)
    outer = None
    opts = {}
    if case == "pressure":
        well = WellCondition(pressure=P0 + 5e5)
    elif case == "fixed_outer":
        outer = OuterBoundary({LEFT: P0 + 2e5, RIGHT: P0 - 1e5})
    elif case == "arithmetic":
        opts = dict(averaging="arithmetic")
    elif case == "centroid":
        opts = dict(cell_centres="centroid")
    elif case == "choke":
        def kw(x):  # rate depending on p_w (linearised choke flowback)
            return dict(well_rate=(-1e-5 - 2e-11 * (x[-1] - P0 - 4e5), -2e-11))
    model = FlowModel(small_mesh, _fluid(compressibility=1e-8), rock, well, outer, **opts)
    old = model.initial_state(P0 + rng.normal(0, 1e5, m), p_w=P0 + 3e5,
                              extra_pore_volume=rng.uniform(0, 1e-4, m))
    # random iterate: pressure differences of both signs exercise the upwinding
    new = FlowState(1.0, old.p + rng.normal(0, 3e5, m), P0 + 4e5,
                    old.extra_pore_volume + rng.uniform(0, 1e-5, m))
    res = model.residual_and_jacobian(new, old, 0.5, **kw(new.x))
    J = res.jacobian.toarray()
    Jfd = _fd_jacobian(model, new, old, 0.5, kw)
    scale = np.abs(J).max(axis=1, keepdims=True)
    assert np.max(np.abs(J - Jfd) / scale) < 1e-6


def test_extra_volume_derivative(small_mesh):
    m = small_mesh.n_triangles
    model = FlowModel(small_mesh, _fluid(), _rock())
    old = model.initial_state(P0)
    new = FlowState(1.0, old.p + 1e5, P0, np.full(m, 1e-5))
    res = model.residual_and_jacobian(new, old, 2.0)
    h = 1e-7
    vp = new.extra_pore_volume.copy()
    vp[7] += h
    rp = model.residual_and_jacobian(FlowState(1.0, new.p, new.p_w, vp), old, 2.0).residual
    assert (rp[7] - res.residual[7]) / h == pytest.approx(res.d_residual_d_extra_volume[7],
                                                          rel=1e-6)


def test_residual_sums_to_global_balance(small_mesh):
    """Interior fluxes cancel: sum of the rows = storage - injection + outflow."""
    rng = np.random.default_rng(0)
    m = small_mesh.n_triangles
    model = FlowModel(small_mesh, _fluid(), _rock(), WellCondition(rate=2e-5),
                      OuterBoundary.fixed_pressure(P0))
    old = model.initial_state(P0)
    new = FlowState(3.0, P0 + rng.normal(0, 1e5, m), P0 + 1e6, np.zeros(m))
    r = model.residual_and_jacobian(new, old, 3.0)
    total = np.sum(r.residual)
    assert total == pytest.approx(-r.mass_rate_imbalance, abs=1e-12 * r.throughput)
    assert r.injection_rate == pytest.approx(1000.0 * 2e-5)


def test_no_flow_at_rest(small_mesh):
    model = FlowModel(small_mesh, _fluid(), _rock(), outer=OuterBoundary.fixed_pressure(P0))
    s = model.initial_state(P0)
    r = model.residual_and_jacobian(FlowState(1.0, s.p, s.p_w, s.extra_pore_volume), s, 1.0)
    assert np.all(r.residual == 0.0)


# --------------------------------------------------------------------- stepper mechanics
def _closed_model(mesh, **well):
    return FlowModel(mesh, _fluid(), _rock(k=1e-16), WellCondition(**well), height=1.0)


def test_step_grows_dt_and_counts(small_mesh):
    model = _closed_model(small_mesh, rate=1e-7)
    st = FlowStepper(model, model.initial_state(P0),
                     StepControl(dt_initial=0.1, growth=2.0, dp_max=1e7))
    r = st.step()
    assert r.success and r.reason == "converged"
    assert st.dt == pytest.approx(0.2)
    assert st.counters.steps == 1
    assert st.counters.newton_iterations == r.newton_iterations >= 1
    assert st.counters.linear_solves >= r.newton_iterations
    assert st.state.t == pytest.approx(0.1)


def test_dp_limit_rejects_and_cuts(small_mesh):
    model = _closed_model(small_mesh, rate=1e-4)
    st = FlowStepper(model, model.initial_state(P0), StepControl(dt_initial=10.0, dp_max=1e5))
    r = st.step()
    assert not r.success and r.reason == "dp limit"
    assert st.state.t == 0.0 and st.counters.cuts == 1
    assert st.dt < 10.0 * 0.8 * 1e5 / r.max_dp * 1.0001
    res = st.run(1.0)
    assert res.success
    assert np.all(np.abs(np.diff(res.p_w)) <= 1e5 * (1 + 1e-12))


def test_newton_failure_is_reported_and_cut(small_mesh, monkeypatch):
    model = _closed_model(small_mesh, rate=1e-7)
    st = FlowStepper(model, model.initial_state(P0), StepControl(dt_initial=1.0, dt_min=0.1))
    orig = model.residual_and_jacobian
    calls = {"n": 0}

    def broken(*a, **k):
        r = orig(*a, **k)
        calls["n"] += 1
        r.residual[0] = np.nan
        return r

    monkeypatch.setattr(model, "residual_and_jacobian", broken)
    r = st.step()
    assert not r.success and r.reason == "newton: non-finite"
    assert st.dt == pytest.approx(0.25)
    res = st.run(1.0)
    assert res.status == -1 and "dt_min" in res.message
    assert not res.success


def test_run_lands_on_stop_times_and_keeps_snapshots(small_mesh):
    # piecewise-constant rate: 1e-6 until 5 s, then shut in
    q = lambda t: 1e-6 if t < 5.0 else 0.0  # noqa: E731
    model = _closed_model(small_mesh, rate=q)
    st = FlowStepper(model, model.initial_state(P0), StepControl(dt_initial=0.3, growth=1.7))
    res = st.run(12.0, stop_times=[5.0], snapshot_times=[2.0, 5.0])
    assert res.success and res.times[-1] == 12.0
    assert 5.0 in res.times and set(res.snapshots) == {2.0, 5.0}
    # rate evaluated at step midpoints: the schedule is integrated exactly
    assert res.injected_volume[-1] == pytest.approx(5e-6, rel=1e-12)
    assert np.max(res.mass_balance_error) < 1e-9
    seen = []
    st.run(13.0, progress=lambda t, te: seen.append((t, te)))
    assert seen[-1] == (13.0, 13.0)


def test_extra_pore_volume_draws_pressure_down(small_mesh):
    """Opening pore space in a sealed cell lowers its pressure; no mass is created."""
    m = small_mesh.n_triangles
    k = np.zeros(m)
    model = FlowModel(small_mesh, _fluid(), RockFlowProperties(permeability=k, porosity=0.1,
                                                               pore_compressibility=0.0,
                                                               reference_pressure=P0),
                      WellCondition(rate=0.0, storage=1e-9), height=1.0)
    st = FlowStepper(model, model.initial_state(P0), StepControl(dt_initial=1.0, dp_max=1e9))
    i = 5
    vx = np.zeros(m)
    vp = 0.1 * model.volumes[i]
    vx[i] = 1e-3 * vp                      # open 0.1 % of the pore volume (thesis Eq. 4.6)
    mass0 = model.cell_mass(st.state)[i]
    r = st.step(extra_pore_volume=vx)
    assert r.success
    # rho(p) (V_p + dV) = rho(p0) V_p  ->  dp = -ln(1 + dV/V_p) / c_f  (about -2.2 MPa)
    expected = -math.log(1.0 + 1e-3) / 4.5e-10
    assert st.state.p[i] - P0 == pytest.approx(expected, rel=1e-9)
    assert model.cell_mass(st.state)[i] == pytest.approx(mass0, rel=1e-13)
    others = np.delete(st.state.p, i)
    assert np.all(others == P0)


@pytest.mark.parametrize("averaging", ["harmonic", "arithmetic"])
@pytest.mark.parametrize("well", ["rate", "pressure"])
def test_d_residual_d_permeability(small_mesh, averaging, well):
    rng = np.random.default_rng(11)
    m = small_mesh.n_triangles
    k = 10 ** rng.uniform(-16, -13, m)
    w = WellCondition(rate=1e-5) if well == "rate" else WellCondition(pressure=P0 + 2e5)
    model = FlowModel(small_mesh, _fluid(), _rock(), w, OuterBoundary({LEFT: P0 + 1e5}),
                      averaging=averaging)
    old = model.initial_state(P0)
    new = FlowState(1.0, P0 + rng.normal(0, 2e5, m), P0 + 3e5, np.zeros(m))
    D = model.d_residual_d_permeability(new, k).toarray()
    wall = model._conn.a[model.n_interior_faces:]
    for j in np.r_[rng.choice(m, 10, replace=False), wall[:3]]:
        h = 1e-6 * k[j]
        kp, km_ = k.copy(), k.copy()
        kp[j] += h
        km_[j] -= h
        fd = (model.residual_and_jacobian(new, old, 1.0, permeability=kp).residual
              - model.residual_and_jacobian(new, old, 1.0, permeability=km_).residual) / (2 * h)
        np.testing.assert_allclose(D[:, j], fd, rtol=1e-5, atol=1e-8 * np.abs(fd).max())


# --------------------------------------------------------------------- coupling additions
def test_well_extra_volume_storage_and_derivatives(small_mesh):
    """The hole's volume change is stored in the well row as rho(p_w) V_w (difference form):
    dR_w/dV_w = rho(p_w)/dt, dR_w/dp_w gains c_f rho V_w/dt, the global balance still
    closes, and a compliance override replaces C_w."""
    m = small_mesh.n_triangles
    model = FlowModel(small_mesh, _fluid(), _rock(), WellCondition(rate=1e-5, storage=1e-10))
    old = FlowState(0.0, np.full(m, P0), P0, np.zeros(m), 2e-4)
    new = FlowState(2.0, np.full(m, P0 + 1e5), P0 + 3e5, np.zeros(m), 3e-4)
    r = model.residual_and_jacobian(new, old, 2.0)
    rho = model.fluid.rho
    exact = (1e-10 * (rho(P0 + 3e5) - rho(P0)) / model.fluid.compressibility
             + rho(P0 + 3e5) * 3e-4 - rho(P0) * 2e-4) / 2.0
    assert r.storage_rate_well == pytest.approx(exact, rel=1e-12)
    h = 1e-9
    rp = model.residual_and_jacobian(FlowState(2.0, new.p, new.p_w, new.extra_pore_volume,
                                               3e-4 + h), old, 2.0).residual
    assert (rp[-1] - r.residual[-1]) / h == pytest.approx(r.d_residual_d_well_volume,
                                                          rel=1e-6)
    assert r.d_residual_d_well_volume == pytest.approx(rho(P0 + 3e5) / 2.0, rel=1e-14)
    hp = 10.0
    rq = model.residual_and_jacobian(new.with_x(np.append(new.p, new.p_w + hp)), old, 2.0)
    assert (rq.residual[-1] - r.residual[-1]) / hp == pytest.approx(
        r.jacobian[m, m], rel=1e-6)
    assert np.sum(r.residual) == pytest.approx(-r.mass_rate_imbalance,
                                               abs=1e-12 * r.throughput)
    r2 = model.residual_and_jacobian(new, old, 2.0, well_storage=3e-10)
    assert r2.storage_rate_well - r.storage_rate_well == pytest.approx(
        2e-10 * (rho(P0 + 3e5) - rho(P0)) / model.fluid.compressibility / 2.0, rel=1e-9)
    # with_x keeps the well volume
    assert new.with_x(new.x).well_extra_volume == 3e-4


def test_crack_opening_and_permeability_kernels():
    gaps = np.array([[0.0, 2e-4, 1e-4], [0.0, 0.0, 0.0], [3e-5, 0.0, 0.0]])
    w, act = crack_opening(gaps)
    assert np.array_equal(w, [2e-4, 0.0, 3e-5]) and np.array_equal(act[[0, 2]], [1, 0])
    wh = 1e-5 + w
    delta = np.array([0.1, 0.2, 0.05])
    k = crack_permeability(wh, 1e-19, delta)
    # consistent with Eq. 4.3 (PM k_m) where k_m > 0, and defined for k_m = 0
    assert np.allclose(k, upscaled_permeability(wh, 1e-19, delta), rtol=1e-14)
    assert np.allclose(crack_permeability(wh, 0.0, delta), wh ** 3 / (12 * delta),
                       rtol=1e-14)
    dk = crack_permeability_derivative(wh, delta)
    e = 1e-12
    fd = (crack_permeability(wh + e, 0.0, delta) - crack_permeability(wh - e, 0.0, delta)
          ) / (2 * e)
    assert np.allclose(dk, fd, rtol=1e-6)
    with pytest.raises(InputError):
        crack_permeability(wh, -1.0, delta)
    with pytest.raises(InputError):
        crack_opening(np.zeros((3, 2)))
