"""Fracture closure laws (xlotkit.sim.mechanics.closure): the closed forms, a joint in the
MDEM model closing by its law, the crack mouth sealing, and the coupled Jacobian."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit import InputError
from xlotkit.sim.coupling import (
    CoupledControl,
    CoupledModel,
    CoupledState,
    CoupledStepper,
)
from xlotkit.sim.flow import (
    FlowModel,
    FlowState,
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    WellCondition,
    sealing_aperture,
    sealing_aperture_derivative,
)
from xlotkit.sim.mechanics import (
    FAILED_TENSILE,
    BoundaryConditions,
    ClosureLaw,
    CrackPlanes,
    InSituStress,
    MechanicsModel,
    RockProperties,
)
from xlotkit.sim.mechanics.closure import (
    CLOSURE_CAP,
    closure_of_stress,
    stress_of_closure,
)
from xlotkit.sim.mesh import borehole_mesh, rectangle_mesh

E, NU = 10e9, 0.25
BB = ClosureLaw("barton_bandis", normal_stiffness=1e12, max_closure=2e-5,
                sealed_aperture=1e-6)
EXP = ClosureLaw("exponential", reference_stress=5e6, max_closure=2e-5, sealed_aperture=1e-6)


# ------------------------------------------------------------------ closed forms
def test_barton_bandis_closure_is_the_hyperbola():
    kni, vm = 1e12, 2e-5
    # independent points of delta = sigma Vm / (Kni Vm + sigma): half the maximum closure
    # at sigma = Kni Vm, three quarters at 3 Kni Vm, the initial slope 1 / Kni
    assert closure_of_stress(BB, kni * vm) == pytest.approx(vm / 2, rel=1e-15)
    assert closure_of_stress(BB, 3 * kni * vm) == pytest.approx(0.75 * vm, rel=1e-15)
    assert closure_of_stress(BB, 1e3) == pytest.approx(1e3 / kni, rel=1e-8)
    # the hyperbola approaches V_m (below the cap stress 1e4 K_ni V_m = 2e11 Pa)
    assert 0.99 * vm < closure_of_stress(BB, 1e10) < vm
    # the stress of a closure inverts it, and its tangent is K_ni / (1 - delta/Vm)^2
    sig = np.geomspace(1e3, 1e9, 40)
    d = closure_of_stress(BB, sig)
    s, k = stress_of_closure(BB, d)
    np.testing.assert_allclose(s, sig, rtol=1e-9)
    np.testing.assert_allclose(k, kni / (1 - d / vm) ** 2, rtol=1e-12)
    h = 1e-6 * d
    fd = (stress_of_closure(BB, d + h)[0] - stress_of_closure(BB, d - h)[0]) / (2 * h)
    np.testing.assert_allclose(k, fd, rtol=1e-6)


def test_exponential_closure():
    sr, vm = 5e6, 2e-5
    assert closure_of_stress(EXP, sr) == pytest.approx(vm * (1 - math.exp(-1)), rel=1e-15)
    assert closure_of_stress(EXP, 1e3) == pytest.approx(1e3 * vm / sr, rel=1e-3)
    assert EXP.initial_stiffness == sr / vm
    sig = np.geomspace(1e3, 8 * sr, 30)
    s, k = stress_of_closure(EXP, closure_of_stress(EXP, sig))
    np.testing.assert_allclose(s, sig, rtol=1e-9)
    np.testing.assert_allclose(k, sr / (vm - closure_of_stress(EXP, sig)), rtol=1e-9)


@pytest.mark.parametrize("law", [BB, EXP], ids=["barton_bandis", "exponential"])
def test_closure_law_is_continued_along_its_tangent(law):
    """Beyond (1 - CAP) V_m the law is its tangent line (finite for any Newton iterate),
    C1 at the switch; before contact (delta < 0) the initial tangent line."""
    vm = law.max_closure
    dc = (1 - CLOSURE_CAP) * vm
    d_in, d_out = dc * (1 - 1e-9), dc * (1 + 1e-9)
    s_in, k_in = stress_of_closure(law, np.array([d_in]))
    s_out, k_out = stress_of_closure(law, np.array([d_out]))
    # continuous: the jump across the switch is the slope times the step (to 1 %)
    assert s_out[0] - s_in[0] == pytest.approx(k_in[0] * (d_out - d_in), rel=1e-2)
    # C1: the slope 1e-9 before the switch differs by ~2e-9 / CAP (BB) from the line
    assert k_out[0] == pytest.approx(k_in[0], rel=1e-4)
    s2, k2 = stress_of_closure(law, np.array([2 * vm]))
    assert np.isfinite(s2[0]) and k2[0] == k_out[0]
    s3, k3 = stress_of_closure(law, np.array([-1e-6]))
    assert s3[0] == pytest.approx(-1e-6 * law.initial_stiffness) and k3[0] > 0
    # the closed form's inverse continues along the same line
    assert closure_of_stress(law, s2)[0] == pytest.approx(2 * vm, rel=1e-9)


def test_closure_law_parameters_name_the_key():
    with pytest.raises(InputError, match="rock.joint_normal_stiffness"):
        ClosureLaw("barton_bandis", max_closure=1e-5)
    with pytest.raises(InputError, match="rock.joint_reference_stress"):
        ClosureLaw("exponential", max_closure=1e-5)
    with pytest.raises(InputError, match="joint_normal_stiffness is not used"):
        ClosureLaw("exponential", max_closure=1e-5, reference_stress=1e6,
                   normal_stiffness=1e12)
    with pytest.raises(InputError, match="rock.joint_max_closure"):
        ClosureLaw("exponential", reference_stress=1e6, max_closure=-1.0)
    with pytest.raises(InputError, match="rock.closure_law"):
        ClosureLaw("bandis")
    with pytest.raises(InputError, match="rock.sealed_aperture"):
        ClosureLaw("exponential", reference_stress=1e6, max_closure=1e-5,
                   sealed_aperture=-1e-6)


def test_sealing_aperture():
    vm, w_inf = 2e-5, 1e-6
    g = np.array([1e-4, 0.0, -1e-5, -vm, -2 * vm])
    np.testing.assert_allclose(sealing_aperture(g, vm, w_inf),
                               [w_inf + vm + 1e-4, w_inf + vm, w_inf + 1e-5, w_inf, w_inf])
    np.testing.assert_array_equal(sealing_aperture_derivative(g, vm), [1, 1, 1, 0, 0])
    with pytest.raises(InputError, match="max_closure"):
        sealing_aperture(g, 0.0, w_inf)


# ------------------------------------------------------------------ a joint in the model
def _joint_block(law, sy=20e6, friction=0.0, sx=30e6):
    """A 1 m block (6 x 6 squares, two triangles each), far field sigma_x and sigma_y;
    the row of clusters in 0 < y < h pre-cut on planes normal to y (a straight
    joint across the block) with the closure law."""
    mesh = rectangle_mesh(1.0, 1.0, 6, 6, jitter=0.0)
    rock = RockProperties(young=E, poisson=NU, biot=1.0, tensile_strength=1e12,
                          cohesion=1e12)
    m = MechanicsModel(mesh, rock, InSituStress(sx, sy, 0.0, 0.0),
                       boundary=BoundaryConditions("tractions"),
                       crack_planes=CrackPlanes(friction), closure=law)
    h = 1.0 / 6
    row = np.flatnonzero(np.abs(mesh.centroids[:, 1] - h / 2) < h / 2)
    s0 = m.initial_state()
    return mesh, m, row, m.fail_clusters(s0, row, FAILED_TENSILE,
                                         plane_normal=np.array([0.0, 1.0]))


def _closure(m, st, row):
    uc = np.asarray(st.displacement).reshape(-1)[m.dofs]
    un = np.einsum("cmi,ci->cm", m.bn_c, uc)
    return -(un - np.asarray(st.ref_normal))[row][m.joint[row]]


@pytest.mark.parametrize("friction", [0.0, 30.0])
def test_a_joint_under_normal_load_closes_by_its_law(friction):
    """Uniform pore pressure p (Biot 1) lowers the effective normal stress on the joint
    to sigma_y - p; the joint's contacts close by the Barton-Bandis delta(sigma_y - p)."""
    sy = 20e6
    _, m, row, s1 = _joint_block(BB, sy, friction)
    assert len(row) == 12 and m.joint[row].sum() == 24
    for p in (0.0, 5e6, 10e6, 15e6, 19e6):
        r = m.step(s1, pore_pressure=p, check_failure=False)
        assert r.converged, r.reason
        d = _closure(m, r.state, row)
        law = float(closure_of_stress(BB, sy - p))
        # the mean closure of the joint's 24 contacts is the law's (measured within
        # 0.25 % down to 1 MPa effective; the contacts spread by +-10 % about it: the
        # failed row is horizontally softer than the rock about it); 0.5 %
        assert float(np.mean(d)) == pytest.approx(law, rel=5e-3), p
        assert np.all(d > 0.5 * law)
        # and the row carries the normal stress (total sigma_y) on average (equal areas;
        # force balance across it, to the solver's tolerance)
        assert float(np.mean(np.asarray(r.state.stress)[row, 1])) == pytest.approx(sy,
                                                                                  rel=1e-6)


def _flow(mesh, k=1e-18):
    return FlowModel(mesh, FluidProperties(compressibility=4.5e-10, viscosity=1e-3),
                     RockFlowProperties(k, 0.1, 0.0, 0.0), WellCondition(),
                     OuterBoundary(), height=1.0)


def test_the_crack_mouth_seals_under_rising_effective_stress():
    """The hydraulic aperture of the closed joint (from the coupled model's cell
    permeability, k = k_m + w_h^3 / (12 Delta)) falls along w_inf + V_m - delta(sigma')
    to the sealed aperture as the effective normal stress rises."""
    law = ClosureLaw("barton_bandis", normal_stiffness=1e11, max_closure=2e-5,
                     sealed_aperture=1e-6)         # half closed at K_ni V_m = 2 MPa
    sy = 60e6
    mesh, m, row, s1 = _joint_block(law, sy, sx=70e6)
    cm = CoupledModel(m, _flow(mesh), residual_aperture=law.zero_stress_aperture,
                      check_storage=False)
    cm.initial_state(s1)
    w_prev = np.inf
    for p in (58e6, 50e6, 40e6, 20e6, 0.0):
        r = m.step(s1, pore_pressure=p, check_failure=False)
        assert r.converged, r.reason
        nc = mesh.n_triangles
        st = CoupledState(r.state.displacement,
                          FlowState(0.0, np.full(nc, p), p, np.zeros(nc)), np.zeros(m.n_dof),
                          mechanics=r.state)
        k, *_ = cm.crack_permeability(r.state.cluster_state, cm.contact_gap(st),
                                      r.state.slip)
        wh = np.cbrt((k[row] - 1e-18) * 12 * cm.length_scale[row])
        w_law = law.sealed_aperture + law.max_closure - float(closure_of_stress(law, sy - p))
        # the mean aperture follows the law (the closure spread of the test above, a
        # few percent of the aperture here, near the sealed value); 3 %
        assert float(np.mean(wh)) == pytest.approx(w_law, rel=3e-2), p
        assert float(np.mean(wh)) < w_prev
        w_prev = float(np.mean(wh))
    # at 60 MPa (30 K_ni V_m) the mouth is sealed to within 4 % of V_m
    assert w_prev - law.sealed_aperture < 0.04 * law.max_closure


# ------------------------------------------------------------------ coupled Jacobian
@pytest.mark.parametrize("law", [BB, EXP], ids=["barton_bandis", "exponential"])
def test_jacobian_with_closure_law_and_own_planes_matches_finite_differences(law):
    """A pre-cut crack on its own planes with a closure law, partly open: every block of
    the coupled Jacobian (the law's tangent stiffness, the sealing aperture's dk/du)
    against central differences."""
    mesh = borehole_mesh(size=4.0, radius=0.15, growth=1.5, h_wall=2 * math.pi * 0.15 / 16)
    mech = MechanicsModel(mesh, RockProperties(young=E, poisson=NU, biot=1.0,
                                               tensile_strength=50e6, cohesion=100e6),
                          InSituStress(26e6, 24e6, 0.0, 20e6),
                          crack_planes=CrackPlanes(20.0), closure=law)
    flow = FlowModel(mesh, FluidProperties(compressibility=4.5e-10, viscosity=1e-3,
                                           reference_pressure=20e6),
                     RockFlowProperties(1e-19, 0.1, 0.0, 20e6), WellCondition(rate=2e-4),
                     OuterBoundary.fixed_pressure(20e6), height=2.0)
    model = CoupledModel(mech, flow, residual_aperture=law.zero_stress_aperture)
    ys = mesh.nodes[mesh.triangles, 1]
    cut = np.flatnonzero((ys.min(axis=1) < 0.01) & (ys.max(axis=1) > 0.01)
                         & (np.abs(mesh.centroids[:, 0]) < 0.5))
    ms = mech.fail_clusters(mech.initial_state(), cut, plane_normal=np.array([0.0, 1.0]))
    stp = CoupledStepper(model, model.initial_state(ms), CoupledControl(check_failure=False))
    for _ in range(20):
        # pump until the crack is open near the hole, still closed further out
        r = stp.step(0.1)
        assert r.success, r.reason
        jg = model.contact_gap(stp.state)[cut][mech.joint[cut]]
        if np.mean(jg > 0) > 0.3:
            break
    st = stp.state
    nu, m = model.n_u, model.n_cells
    x = model.x_of(st).copy()
    rng = np.random.default_rng(5)
    x[:nu] += rng.normal(0, 1e-7, nu)
    x[nu:nu + m] += rng.normal(0, 1e3, m)
    dt = 0.5
    res = model.residual_and_jacobian(x, st, dt)
    g = model.contact_gap(model.finish_state(res, model.structure_of(st)))
    jg = g[cut][mech.joint[cut]]
    # both branches of the law are exercised: open and closed joint contacts
    assert np.any(jg > 0) and np.any(jg < 0)
    J = res.jacobian.tocsc()
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
            # smooth law pieces (no switch within +-h at this iterate): central
            # differences good to ~1e-7 of the column; 1e-5 margin as the smooth-law test
            assert np.max(np.abs(a[rows] - fd[rows])) <= 1e-5 * scale, (j, rows)


# ------------------------------------------------------------------ scene keys
def _scene(**rock):
    from xlotkit.sim.scene import scene_from_dict

    return scene_from_dict({
        "model": "mdem", "geometry": {"domain_size": "4 m"},
        "mesh": {"growth": 1.5, "wall_element_size": "0.1 m"},
        "rock": rock,
        "stresses": {"sigma_H": "35 MPa", "sigma_h": "30 MPa", "pore_pressure": "20 MPa"},
        "schedule": {"phase": [{"kind": "pump", "rate": "100 l/min", "duration": "5 s"}]},
    }, file="s.toml")


def test_scene_closure_law_keys_reach_the_model():
    from xlotkit.sim.coupling.build import RESIDUAL_APERTURE, build_model

    cm, _ = build_model(_scene(closure_law="barton_bandis",
                               joint_normal_stiffness="50 GPa/m", joint_max_closure="50 um",
                               sealed_aperture="2 um"))
    law = cm.mechanics.closure
    assert law.kind == "barton_bandis" and law.normal_stiffness == pytest.approx(5e10)
    assert law.max_closure == pytest.approx(5e-5)
    assert law.sealed_aperture == pytest.approx(2e-6)
    assert cm.residual_aperture == pytest.approx(5.2e-5)      # the zero-stress aperture
    assert cm.mechanics.crack_planes is not None               # the default free path
    cm, _ = build_model(_scene(closure_law="exponential", joint_reference_stress="4 MPa",
                               joint_max_closure="30 um", crack_plane="edges"))
    assert cm.mechanics.closure.reference_stress == pytest.approx(4e6)
    assert cm.mechanics.closure.sealed_aperture == RESIDUAL_APERTURE
    assert cm.mechanics.crack_planes is None
    cm, _ = build_model(_scene())
    assert not cm.mechanics.closure.nonlinear and cm.residual_aperture == RESIDUAL_APERTURE


@pytest.mark.parametrize("rock, key, found", [
    ({"closure_law": "barton_bandis", "joint_max_closure": "50 um"},
     "rock.joint_normal_stiffness", "needs"),
    ({"closure_law": "exponential", "joint_max_closure": "50 um",
      "joint_reference_stress": "4 MPa", "joint_normal_stiffness": "50 GPa/m"},
     "rock.joint_normal_stiffness", "not used"),
    ({"sealed_aperture": "1 um"}, "rock.sealed_aperture", "not used"),
    ({"joint_max_closure": "50 um"}, "rock.joint_max_closure", "not used"),
    ({"closure_law": "bandis"}, "rock.closure_law", "unknown"),
    ({"crack_plane": "free"}, "rock.crack_plane", "unknown"),
])
def test_scene_closure_law_keys_are_checked(rock, key, found):
    with pytest.raises(InputError) as ei:
        _scene(**rock)
    assert ei.value.key == key and found in ei.value.message


def test_closure_law_and_crack_plane_ask_for_the_2d_model():
    from xlotkit.sim.scene import scene_from_dict

    base = {"stresses": {"sigma_H": "35 MPa", "sigma_h": "30 MPa", "pore_pressure": "20 MPa"},
            "schedule": {"phase": [{"kind": "pump", "rate": "100 l/min", "duration": "5 s"}]}}
    assert scene_from_dict(base).resolved_model == "lumped"
    sc = scene_from_dict({**base, "rock": {"closure_law": "exponential",
                                           "joint_reference_stress": "4 MPa",
                                           "joint_max_closure": "30 um"}})
    assert sc.resolved_model == "mdem" and "rock.closure_law" in sc.two_d_reasons
    sc = scene_from_dict({**base, "rock": {"crack_plane": "edges"}})
    assert sc.resolved_model == "mdem" and "rock.crack_plane" in sc.two_d_reasons

