"""The compiled kernels of the 2D engine against independent answers.

* the mechanics' cluster loops (:mod:`xlotkit.sim.mechanics.kernels`) against the NumPy
  forms they replaced (kept here, verbatim in substance, as the reference);
* the flow's face loop and the coupled system's fixed-pattern assembly against the
  scipy-sparse construction and against central finite differences of the residual;
* the linear solver with ordering and factor reuse against a direct solve.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit.errors import InputError
from xlotkit.sim.mechanics import (
    BONDED,
    FAILED_TENSILE,
    INTACT,
    OPEN,
    SLIP,
    STICK,
    InSituStress,
    MechanicsModel,
    RockProperties,
)
from xlotkit.sim.mechanics.kernels import EPS_OPEN, contact_response, tangent_blocks
from xlotkit.sim.mesh import borehole_mesh

E, NU = 10e9, 0.25


# ----------------------------------------------------------------- NumPy references
def _response_ref(m, u, cstate, ref_n, ref_s, p, frozen=None):
    """The NumPy contact response the kernel replaced (plus the held-branch law that
    lived in the coupled model), with the one change the kernel made: a contact exactly
    at the friction limit is on the slip branch."""
    uc = u.reshape(-1)[m.dofs]
    failed = cstate != INTACT
    Un_reg = np.einsum("cmi,ci->cm", m.bn, uc)
    F_int = m.F0 + np.einsum("cmn,cn->cm", m.K, Un_reg)
    Un = np.einsum("cmi,ci->cm", m.bn_c, uc)
    Us = np.einsum("cmi,ci->cm", m.bs_c, uc)
    trial_n = m.kn * (Un - ref_n)
    is_open = trial_n > 0.0
    Fn = np.where(is_open, 0.0, trial_n)
    trial_s = m.ks * (Us - ref_s)
    cap = m.mu * (-Fn)
    # at the friction limit (|F_s| = cap) the slip branch (same force, its tangent)
    slip = ~is_open & (np.abs(trial_s) >= cap)
    Fs = np.where(is_open, 0.0, np.where(slip, np.sign(trial_s) * cap, trial_s))
    status = np.where(is_open, OPEN, np.where(slip, SLIP, STICK))
    status[~failed] = BONDED
    Fn = np.where(failed[:, None], Fn, F_int)
    Fs = np.where(failed[:, None], Fs, 0.0)
    alpha = np.where(failed, 1.0, m.rock.biot)
    sgn = np.sign(trial_s)
    f_c = (np.einsum("cmi,cm->ci", np.where(failed[:, None, None], m.bn_c, m.bn), Fn)
           + np.einsum("cmi,cm->ci", m.bs_c, Fs) - (alpha * p)[:, None] * m.g_pressure)
    if frozen is not None:
        mask, fst, fsg = frozen
        mask = mask & failed[:, None]
        op = fst == OPEN
        Fn_f = np.where(op, 0.0, trial_n)
        Fs_f = np.where(op, 0.0, np.where(fst == SLIP, fsg * m.mu * (-trial_n), trial_s))
        Fn = np.where(mask, Fn_f, Fn)
        Fs = np.where(mask, Fs_f, Fs)
        status = np.where(mask, fst, status)
        sgn = np.where(mask, fsg, sgn)
        rows = np.flatnonzero(mask.any(axis=1))
        f_c = f_c.copy()
        f_c[rows] = (np.einsum("cmi,cm->ci", m.bn_c[rows], Fn[rows])
                     + np.einsum("cmi,cm->ci", m.bs_c[rows], Fs[rows])
                     - p[rows, None] * m.g_pressure[rows])
    return Fn, Fs, status, sgn, f_c, Un, Us


def _tangent_ref(m, cstate, status, sgn, soft=None):
    blocks = m.k_intact.copy()
    failed = np.nonzero(cstate != INTACT)[0]
    st = status[failed]
    bn = m.bn_c[failed]
    bs = m.bs_c[failed]
    kn = m.kn[failed] * np.where(st != OPEN, 1.0, EPS_OPEN)
    kss = m.ks[failed] * np.where(st == STICK, 1.0, EPS_OPEN)
    kslip = -m.mu[failed] * sgn[failed] * m.kn[failed] * (st == SLIP)
    if soft is not None:
        sf = soft[failed]
        kss = np.where(sf, m.ks[failed], kss)
        kslip = np.where(sf, 0.0, kslip)
    blocks[failed] = (np.einsum("cm,cmi,cmj->cij", kn, bn, bn)
                      + np.einsum("cm,cmi,cmj->cij", kss, bs, bs)
                      + np.einsum("cm,cmi,cmj->cij", kslip, bs, bn))
    return blocks


@pytest.fixture(scope="module")
def mech():
    mesh = borehole_mesh(size=4.0, radius=0.15, growth=1.5, h_wall=2 * math.pi * 0.15 / 12)
    m = MechanicsModel(mesh, RockProperties(young=E, poisson=NU, biot=0.8),
                       InSituStress(20e6, 15e6, 0.0, 10e6))
    # vary the friction per contact, so that the kernel must read it per contact
    m.mu = m.mu * np.random.default_rng(3).uniform(0.5, 1.5, m.mu.shape)
    return m


def _random_state(m, seed):
    """A displacement field with every contact branch represented: failed clusters with
    references that put a third of their contacts open, some slipping, some sticking."""
    rng = np.random.default_rng(seed)
    nc = m.mesh.n_triangles
    u = rng.normal(0.0, 1e-4, (m.mesh.n_nodes, 2))
    cs = np.where(rng.random(nc) < 0.4, FAILED_TENSILE, INTACT).astype(np.int64)
    uc = u.reshape(-1)[m.dofs]
    Un = np.einsum("cmi,ci->cm", m.bn_c, uc)
    Us = np.einsum("cmi,ci->cm", m.bs_c, uc)
    ref_n = Un - rng.normal(0.0, 1e-4, (nc, 3))
    ref_s = Us - rng.normal(0.0, 3e-5, (nc, 3))
    p = rng.uniform(5e6, 15e6, nc)
    return u, cs, ref_n, ref_s, p


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_contact_response_kernel_equals_numpy(mech, seed):
    u, cs, ref_n, ref_s, p = _random_state(mech, seed)
    got = mech._response(u, cs, ref_n, ref_s, p)
    ref = _response_ref(mech, u, cs, ref_n, ref_s, p)
    st = got[2][cs != INTACT]
    # every branch of the law is exercised
    assert {OPEN, STICK, SLIP} <= set(np.unique(st).tolist())
    for name, a, b in zip(("Fn", "Fs", "status", "sgn", "f_c", "Un", "Us"), got, ref):
        # same arithmetic in another summation order: equal to a few ulps of the
        # largest term (forces ~1e6 N/m from displacements ~1e-4 m)
        scale = max(float(np.max(np.abs(b))), 1e-300)
        assert np.allclose(a, b, rtol=0, atol=1e-12 * scale), name


@pytest.mark.parametrize("seed", [0, 1])
def test_contact_response_kernel_frozen_branches_equal_numpy(mech, seed):
    u, cs, ref_n, ref_s, p = _random_state(mech, seed)
    rng = np.random.default_rng(10 + seed)
    nc = len(cs)
    mask = rng.random((nc, 3)) < 0.5
    fst = rng.choice([OPEN, STICK, SLIP], (nc, 3)).astype(np.int64)
    fsg = np.where(fst == SLIP, rng.choice([-1.0, 1.0], (nc, 3)), 0.0)
    got = mech._response(u, cs, ref_n, ref_s, p, frozen=(mask, fst, fsg))
    ref = _response_ref(mech, u, cs, ref_n, ref_s, p, frozen=(mask, fst, fsg))
    for name, a, b in zip(("Fn", "Fs", "status", "sgn", "f_c", "Un", "Us"), got, ref):
        scale = max(float(np.max(np.abs(b))), 1e-300)
        assert np.allclose(a, b, rtol=0, atol=1e-12 * scale), name


@pytest.mark.parametrize("soft", [False, True])
def test_tangent_blocks_kernel_equals_numpy(mech, soft):
    u, cs, ref_n, ref_s, p = _random_state(mech, 4)
    _, _, status, sgn, *_ = mech._response(u, cs, ref_n, ref_s, p)
    sf = np.random.default_rng(5).random(status.shape) < 0.3 if soft else None
    got = mech._tangent_blocks(cs, status, sgn, sf)
    ref = _tangent_ref(mech, cs, status, sgn, sf)
    assert np.allclose(got, ref, rtol=0, atol=1e-13 * np.max(np.abs(ref)))


def test_tangent_blocks_are_the_derivative_of_the_response(mech):
    """Away from the switch points of the law the tangent is the exact derivative of the
    internal forces: central differences of f_c per cluster (the open contacts' and
    slipping shear's 1e-9 regularisation is below the difference error)."""
    u, cs, ref_n, ref_s, p = _random_state(mech, 6)
    _, _, status, sgn, f_c, *_ = mech._response(u, cs, ref_n, ref_s, p)
    blocks = mech._tangent_blocks(cs, status, sgn)
    h = 1e-10
    uf = u.reshape(-1)
    fd = np.zeros_like(blocks)
    for j in range(6):
        # move DOF j of every cluster at once; clusters share nodes, so compare per
        # cluster with its own perturbation only: perturb through the cluster's own copy
        e = np.zeros((len(cs), 6))
        e[:, j] = h
        fp = _forces_of_cluster_displacements(mech, uf, e, cs, ref_n, ref_s, p)
        fm = _forces_of_cluster_displacements(mech, uf, -e, cs, ref_n, ref_s, p)
        fd[:, :, j] = (fp - fm) / (2 * h)
    # statuses must not change within +-h for the comparison to be exact
    rng = np.random.default_rng(7)
    for _ in range(2):
        e = rng.choice([-h, h], (len(cs), 6))
        st_h = _status_of_cluster_displacements(mech, uf, e, cs, ref_n, ref_s, p)
        assert np.array_equal(st_h, status)
    scale = np.max(np.abs(blocks))
    # central differences of a piecewise-linear force: exact but for round-off of
    # f_c (~1e6 N/m, eps 2e-16) over 2h: 1e6 * 2e-16 / 2e-10 = 1e0, i.e. 1e-9 of the
    # stiffness scale (~1e10); the EPS_OPEN regularisation adds 1e-9 of k_n
    assert np.allclose(blocks, fd, rtol=0, atol=5e-8 * scale)


def _forces_of_cluster_displacements(m, uf, e, cs, ref_n, ref_s, p):
    """f_c with each cluster's own DOFs moved by e (n_c, 6), clusters independent."""
    nc = len(cs)
    # every cluster gets its own copy of its nodes: a disjoint mesh of the same clusters
    ucl = uf[m.dofs] + e
    dofs = np.arange(6 * nc).reshape(nc, 6)
    return contact_response(ucl.reshape(-1), dofs, cs, ref_n, ref_s, p, bn=m.bn, K=m.K,
                            F0=m.F0, bn_c=m.bn_c, bs_c=m.bs_c, kn=m.kn, ks=m.ks, mu=m.mu,
                            g_pressure=m.g_pressure, biot=m.rock.biot)[4]


def _status_of_cluster_displacements(m, uf, e, cs, ref_n, ref_s, p):
    nc = len(cs)
    ucl = uf[m.dofs] + e
    dofs = np.arange(6 * nc).reshape(nc, 6)
    return contact_response(ucl.reshape(-1), dofs, cs, ref_n, ref_s, p, bn=m.bn, K=m.K,
                            F0=m.F0, bn_c=m.bn_c, bs_c=m.bs_c, kn=m.kn, ks=m.ks, mu=m.mu,
                            g_pressure=m.g_pressure, biot=m.rock.biot)[2]


def test_kernel_wrappers_refuse_bad_shapes(mech):
    u, cs, ref_n, ref_s, p = _random_state(mech, 0)
    with pytest.raises(InputError, match="ref_n"):
        mech._response(u, cs, ref_n[:-1], ref_s, p)
    with pytest.raises(InputError, match="dofs"):
        contact_response(u, mech.dofs[:, :5], cs, ref_n, ref_s, p, bn=mech.bn, K=mech.K,
                         F0=mech.F0, bn_c=mech.bn_c, bs_c=mech.bs_c, kn=mech.kn, ks=mech.ks,
                         mu=mech.mu, g_pressure=mech.g_pressure, biot=0.8)
    with pytest.raises(InputError, match="status"):
        tangent_blocks(cs, np.zeros((len(cs), 2)), np.zeros((len(cs), 3)),
                       k_intact=mech.k_intact, bn_c=mech.bn_c, bs_c=mech.bs_c, kn=mech.kn,
                       ks=mech.ks, mu=mech.mu)


def test_friction_limit_is_the_slip_branch(mech):
    """A closed contact exactly at the friction limit (a frictionless one at zero shear
    force, as every step leaves a contact that slipped) is on the slip branch: the same
    force as the stick branch, and the slip tangent (no shear stiffness when mu = 0)."""
    u, cs, ref_n, ref_s, p = _random_state(mech, 8)
    nc = len(cs)
    uc = u.reshape(-1)[mech.dofs]
    Un = np.einsum("cmi,ci->cm", mech.bn_c, uc)
    Us = np.einsum("cmi,ci->cm", mech.bs_c, uc)
    cs = np.full(nc, FAILED_TENSILE, dtype=np.int64)
    ref_n = Un + 1e-5                       # all closed
    ref_s = Us                              # zero shear displacement
    m2 = MechanicsModel.__new__(MechanicsModel)
    m2.__dict__.update(mech.__dict__)
    m2.mu = np.zeros((nc, 3))              # frictionless: cap = 0 = |F_s|
    Fn, Fs, status, sgn, *_ = m2._response(u, cs, ref_n, ref_s, p)
    assert np.all(status == SLIP) and np.all(Fs == 0.0) and np.all(Fn < 0.0)
    blocks = m2._tangent_blocks(cs, status, sgn)
    # the tangent has only the normal springs (and EPS_OPEN of the shear ones)
    kn_only = np.einsum("cm,cmi,cmj->cij", m2.kn, m2.bn_c, m2.bn_c) + np.einsum(
        "cm,cmi,cmj->cij", EPS_OPEN * m2.ks, m2.bs_c, m2.bs_c)
    assert np.allclose(blocks, kn_only, rtol=0, atol=1e-13 * np.max(np.abs(kn_only)))


# ----------------------------------------------------------------- flow face loop
def test_face_fluxes_kernel_equals_numpy():
    from xlotkit.sim.flow.kernels import face_fluxes
    rng = np.random.default_rng(0)
    n, k = 50, 200
    x = rng.uniform(1e7, 3e7, n)
    x[:5] = x[5]                                       # ties: delta = 0 takes lam_b
    cf = 4.5e-10
    lam = 1e3 * np.exp(cf * (x - 2e7)) / 1e-3
    a = rng.integers(0, n, k)
    b = rng.integers(0, n, k)
    a[:3], b[:3] = 0, 1
    T = rng.uniform(0, 1e-15, k)
    F, dFa, dFb = face_fluxes(x, lam, cf, T, a, b)
    delta = x[b] - x[a]
    up_a = delta < 0.0
    lam_up = np.where(up_a, lam[a], lam[b])
    assert np.allclose(F, lam_up * T * delta, rtol=1e-15, atol=0)
    assert np.allclose(dFa, T * (np.where(up_a, cf * lam[a], 0.0) * delta - lam_up),
                       rtol=1e-14, atol=0)
    assert np.allclose(dFb, T * (np.where(up_a, 0.0, cf * lam[b]) * delta + lam_up),
                       rtol=1e-14, atol=0)
    with pytest.raises(InputError):
        face_fluxes(x, lam, cf, T, a, b + n)


# ----------------------------------------------------------------- coupled assembly
def _opened_crack_model():
    """A small hole with a pre-cut crack along y = 0.01 m, at an iterate where some of
    its contacts are open (conductive) and some closed."""
    from xlotkit.sim.coupling import CoupledModel
    from xlotkit.sim.flow import (FlowModel, FluidProperties, OuterBoundary,
                                  RockFlowProperties, WellCondition)
    mesh = borehole_mesh(size=4.0, radius=0.15, growth=1.5, h_wall=2 * math.pi * 0.15 / 12)
    mech = MechanicsModel(mesh, RockProperties(young=E, poisson=NU, biot=0.8,
                                               tensile_strength=50e6, cohesion=100e6),
                          InSituStress(22e6, 20e6, 0.0, 10e6))
    flow = FlowModel(mesh, FluidProperties(compressibility=4.5e-10, viscosity=1e-3,
                                           reference_pressure=10e6),
                     RockFlowProperties(1e-19, 0.2, 0.0, 10e6), WellCondition(rate=2e-4),
                     OuterBoundary.fixed_pressure(10e6), height=2.0)
    model = CoupledModel(mech, flow, residual_aperture=1e-5, check_storage=False)
    ys = mesh.nodes[mesh.triangles, 1]
    cut = np.flatnonzero((ys.min(axis=1) < 0.01) & (ys.max(axis=1) > 0.01)
                         & (np.abs(mesh.centroids[:, 0]) < 0.5))
    st = model.initial_state(mech.fail_clusters(mech.initial_state(), cut))
    nu, m = model.n_u, model.n_cells
    # lift the rock above the crack's left half: those contacts open, the right half's
    # stay closed
    u = np.array(st.displacement)
    xy = mesh.nodes
    u[(xy[:, 1] > 0.01) & (xy[:, 0] < 0.0), 1] += 3e-4
    x = model.x_of(st).copy()
    x[:nu] = u.reshape(-1)[model.free_dofs]
    rng = np.random.default_rng(4)
    x[:nu] += rng.normal(0, 1e-7, nu)
    x[nu:nu + m] += rng.normal(0, 1e5, m)
    x[-1] += 2e6
    return model, st, x, cut


def _reference_jacobian(model, x, old, dt):
    """The coupled Jacobian built block by block with scipy.sparse, as the model did
    before its fixed-pattern assembly (bmat of K, G, -f_w, Cfu + dR/dk dk/du, J_flow)."""
    import scipy.sparse as sp
    from xlotkit.sim.mechanics.assembly import assemble_matrix
    mech = model.mechanics
    nu, m = model.n_u, model.n_cells
    st = model.structure_of(old)
    cs = np.asarray(st.cluster_state)
    failed = cs != INTACT
    it = model.state_of(x, old.t + dt, model.load_at(old.t + dt), st)
    _, _, status, sgn, _, Un, _ = mech._response(np.asarray(it.displacement), cs,
                                                 np.asarray(st.ref_normal),
                                                 np.asarray(st.ref_shear), np.asarray(it.p))
    keep = -np.ones(mech.n_dof, dtype=np.int64)
    keep[model.free_dofs] = np.arange(nu)
    K = assemble_matrix(mech._tangent_blocks(cs, status, sgn), mech.dofs, mech.n_dof,
                        keep=keep)
    G = model.pressure_operator(cs)
    gap = np.where(failed[:, None], np.maximum(Un - np.asarray(st.ref_normal), 0.0), 0.0)
    k, dk_dw, _, act = model.crack_permeability(cs, gap, st.slip)
    fr = model.flow.residual_and_jacobian(it.flow, old.flow, dt, permeability=k,
                                          well_storage=model.well_storage)
    Cfu = sp.diags(np.asarray(fr.d_residual_d_extra_volume)) @ (-model.height * G.T)
    cells = np.flatnonzero(dk_dw > 0)
    rows = np.repeat(cells, 6)
    vals = (dk_dw[cells, None] * mech.bn_c[cells, act[cells], :]).ravel()
    cols = keep[mech.dofs[cells].ravel()]
    ok = cols >= 0
    dk_du = sp.csr_matrix((vals[ok], (rows[ok], cols[ok])), shape=(m, nu))
    Ck = model.flow.d_residual_d_permeability(it.flow, k) @ dk_du
    wrow = sp.csr_matrix((fr.d_residual_d_well_volume * model.height * model.f_wall
                          ).reshape(1, -1))
    Cfu_full = sp.vstack([Cfu, wrow]) + Ck
    Kp = sp.hstack([G, sp.csr_matrix(-model.f_wall.reshape(-1, 1))])
    return sp.bmat([[K, Kp], [Cfu_full, fr.jacobian]], format="csr"), dk_dw


def test_fixed_pattern_jacobian_equals_the_block_construction():
    model, st, x, cut = _opened_crack_model()
    dt = 0.5
    res = model.residual_and_jacobian(x, st, dt)
    ref, dk_dw = _reference_jacobian(model, x, st, dt)
    assert np.any(dk_dw[cut] > 0) and np.any(dk_dw[cut] == 0)   # open and closed cells
    d = (res.jacobian - ref).toarray()
    nu = model.n_u
    # row blocks in their own units; the sums differ only in the order of additions
    for rows in (slice(0, nu), slice(nu, None)):
        scale = np.max(np.abs(ref[rows].toarray()))
        assert np.max(np.abs(d[rows])) <= 1e-13 * scale
    # the same failed clusters give the same pattern object (the solver's reuse key)
    res2 = model.residual_and_jacobian(x * (1 + 1e-9), st, dt)
    assert res2.pattern is res.pattern
    assert res.jacobian.nnz == res.pattern.nnz


def test_crack_block_added_afterwards_equals_the_full_jacobian():
    model, st, x, _ = _opened_crack_model()
    lagged = model.residual_and_jacobian(x, st, 0.5, permeability_derivative=False)
    full = model.residual_and_jacobian(x, st, 0.5)
    added = model.with_permeability_derivative(lagged, model.structure_of(st))
    assert (full.jacobian - lagged.jacobian).count_nonzero() > 0     # it is exercised
    assert np.array_equal(added.jacobian.toarray(), full.jacobian.toarray())
    assert np.array_equal(added.residual, full.residual)


def test_residual_only_equals_the_residual_of_the_full_evaluation():
    model, st, x, _ = _opened_crack_model()
    full = model.residual_and_jacobian(x, st, 0.5)
    alone = model.residual(x, st, 0.5)
    assert alone.jacobian is None
    assert np.array_equal(alone.residual, full.residual)
    assert alone.force_scale == full.force_scale and alone.mass_scale == full.mass_scale


# ----------------------------------------------------------------- linear solver
def test_linear_solver_reuse_matches_a_direct_solve_and_resets_to_bit_identity():
    from xlotkit.sim.coupling.linear import SOLVE_RTOL, LinearSolver
    from xlotkit.sim.coupling.newton import equilibrated_solve
    model, st, x, _ = _opened_crack_model()
    rng = np.random.default_rng(9)
    res = [model.residual_and_jacobian(x + s * rng.normal(0, 1e-7, len(x)), st, 0.5)
           for s in (0.0, 1.0, 2.0)]
    assert all(r.pattern is res[0].pattern for r in res)
    solver = LinearSolver()
    for r in res:
        b = -r.residual
        got = solver.solve(r.jacobian, b, pattern=r.pattern, status=r.status)
        ref = equilibrated_solve(r.jacobian, b)
        # both meet the scaled-residual test of the direct solve; the solutions agree
        # to what that residual allows on this (equilibrated) system
        assert np.linalg.norm(r.jacobian @ got - b) <= 1e3 * SOLVE_RTOL * np.linalg.norm(b)
        assert np.max(np.abs(got - ref)) <= 1e-6 * np.max(np.abs(ref))
    s = solver.stats
    assert s.factorisations == 1 and s.krylov_solves == 2 and s.orderings == 1
    # a reset makes the next solve independent of the history: bit-identical to a
    # fresh solver's
    solver.reset()
    a = solver.solve(res[2].jacobian, -res[2].residual, pattern=res[2].pattern,
                     status=res[2].status)
    b = LinearSolver().solve(res[2].jacobian, -res[2].residual, pattern=res[2].pattern,
                             status=res[2].status)
    assert np.array_equal(a, b)
    # the second factorisation on the pattern uses its stored ordering
    solver.krylov_iterations = 0
    n_ord = solver.stats.orderings
    c = solver.solve(res[1].jacobian, -res[1].residual, pattern=res[1].pattern,
                     status=res[1].status)
    assert solver.stats.orderings == n_ord
    assert np.max(np.abs(c - equilibrated_solve(res[1].jacobian, -res[1].residual))) <= (
        1e-6 * np.max(np.abs(c)))


def test_linear_solver_state_restores_its_memory_bit_for_bit():
    """A solver rebuilt from another's state (a checkpoint) solves the next systems with
    the same numbers: same reused factor, same ordering."""
    from xlotkit.sim.coupling.linear import LinearSolver
    model, st, x, _ = _opened_crack_model()
    rng = np.random.default_rng(11)
    res = [model.residual_and_jacobian(x + s * rng.normal(0, 1e-7, len(x)), st, 0.5)
           for s in (0.0, 1.0, 2.0)]
    a = LinearSolver()
    a.solve(res[0].jacobian, -res[0].residual, pattern=res[0].pattern, status=res[0].status)
    saved = {k: np.array(v) for k, v in a.state().items()}
    b = LinearSolver()
    b.restore(saved, model.layout.pattern)
    for r in res[1:]:
        xa = a.solve(r.jacobian, -r.residual, pattern=r.pattern, status=r.status)
        xb = b.solve(r.jacobian, -r.residual, pattern=r.pattern, status=r.status)
        assert np.array_equal(xa, xb)
    assert a.stats.krylov_solves == b.stats.krylov_solves == 2


# ----------------------------------------------------------------- issue 20: bit-identical kernels
def test_scaled_matvec_is_scipys_product_to_the_bit():
    """``r * (A @ x)`` of the GMRES kernel against SciPy's own CSR product: the same sums
    in the same order, so equal to the bit (entries over 16 decades)."""
    import scipy.sparse as sp

    from xlotkit.sim.coupling.linear import scaled_matvec

    rng = np.random.default_rng(7)
    n = 300
    A = (sp.random(n, n, density=0.03, random_state=3, format="csr")
         + sp.eye(n, format="csr")).tocsr()
    A.data = rng.standard_normal(A.nnz) * 10.0 ** rng.uniform(-8, 8, A.nnz)
    for _ in range(3):
        x = rng.standard_normal(n) * 10.0 ** rng.uniform(-5, 5, n)
        r = 10.0 ** rng.uniform(-5, 5, n)
        assert np.array_equal(scaled_matvec(A, x, r), r * (A @ x))
    with pytest.raises(InputError):
        scaled_matvec(A.tocsc(), x, r)
    with pytest.raises(InputError):
        scaled_matvec(A, x[:-1], r)


def test_abs_row_products_equal_the_bincount_form_to_the_bit():
    """Newton's ``|J[lo:hi]| |x|`` row sums against the NumPy form they replaced."""
    import scipy.sparse as sp

    from xlotkit.sim.coupling.newton import _abs_row_products

    rng = np.random.default_rng(11)
    n = 200
    J = (sp.random(n, n, density=0.05, random_state=5, format="csr")
         + sp.eye(n, format="csr")).tocsr()
    J.data = rng.standard_normal(J.nnz) * 10.0 ** rng.uniform(-9, 9, J.nnz)
    x = rng.standard_normal(n) * 10.0 ** rng.uniform(-6, 6, n)
    for lo, hi in ((0, 120), (120, n), (0, n), (7, 7)):
        a, b = int(J.indptr[lo]), int(J.indptr[hi])
        prod = np.abs(J.data[a:b]) * np.abs(x[J.indices[a:b]])
        rows = np.repeat(np.arange(hi - lo), np.diff(J.indptr[lo:hi + 1]))
        ref = np.bincount(rows, weights=prod, minlength=hi - lo)
        assert np.array_equal(_abs_row_products(J, x, lo, hi), ref)


def test_connected_labels_are_scipys_connected_components():
    """The crack fronts' union-find groups against scipy.sparse.csgraph on random graphs:
    the same number of groups and the same labels (numbered by lowest vertex)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    from xlotkit.sim.mechanics.fronts import connected_labels

    rng = np.random.default_rng(3)
    for _ in range(100):
        n = int(rng.integers(1, 40))
        m = int(rng.integers(0, 60))
        a, b = rng.integers(0, n, m), rng.integers(0, n, m)
        graph = sp.csr_matrix((np.ones(m), (a, b)), shape=(n, n))
        k_ref, lab_ref = connected_components(graph, directed=False)
        k, lab = connected_labels(n, a, b)
        assert k == k_ref and np.array_equal(lab, lab_ref)
    with pytest.raises(ValueError):
        connected_labels(3, np.array([0]), np.array([3]))


def test_crack_fields_equal_the_separate_formulas_to_the_bit():
    """The compiled crack permeability pass against crack_opening, hydraulic_aperture,
    crack_permeability and its derivative composed as the coupled model composed them
    (ties between contacts, closed and intact cells, a NaN gap)."""
    from xlotkit.sim.flow.fracture import (
        crack_fields,
        crack_opening,
        crack_permeability,
        crack_permeability_derivative,
        hydraulic_aperture,
    )

    rng = np.random.default_rng(5)
    m = 500
    for t in range(12):
        failed = rng.random(m) < 0.4
        gap = rng.standard_normal((m, 3)) * 1e-4 * (rng.random((m, 3)) < 0.5)
        gap[:, 1] = np.where(rng.random(m) < 0.1, gap[:, 0], gap[:, 1])
        if t == 0:
            gap[np.flatnonzero(failed)[0], 1] = np.nan
        km = 10.0 ** rng.uniform(-21, -18, m)
        L = 10.0 ** rng.uniform(-2, -1, m)
        wres = (1e-6, 0.0, 3e-5)[t % 3]
        wn, act = crack_opening(np.where(failed[:, None], gap, 0.0))
        wh = hydraulic_aperture(wn, wres)
        ref = (np.where(failed, crack_permeability(wh, km, L), km),
               np.where(failed & (wn > 0), crack_permeability_derivative(wh, L), 0.0),
               np.where(failed, wn, 0.0), act)
        for got, want in zip(crack_fields(failed, gap, km, L, wres), ref):
            assert np.array_equal(got, want, equal_nan=True)
    with pytest.raises(InputError):
        crack_fields(failed, gap[:, :2], km, L, 1e-6)
