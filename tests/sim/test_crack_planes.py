"""Per-cluster crack planes (the free path): the plane a cluster gets when it fails, the
smooth joint on it, and a crack of such clusters closing at its normal stress."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit import InputError
from xlotkit.sim.mechanics import (
    FAILED_SHEAR,
    FAILED_TENSILE,
    INTACT,
    BoundaryConditions,
    CrackPlanes,
    InSituStress,
    MechanicsModel,
    RockProperties,
    mdem,
)
from xlotkit.sim.mechanics.planes import (
    choose_conjugate,
    joint_lengths,
    joint_operators,
    mean_axis,
    operator_stress,
    plane_crossing,
    plane_tangent,
)
from xlotkit.sim.mesh import FractureBand, borehole_mesh, rectangle_mesh

E, NU = 10e9, 0.25


def _rock(**kw):
    base = {"young": E, "poisson": NU, "biot": 1.0, "tensile_strength": 1e12,
            "cohesion": 1e12}
    base.update(kw)
    return RockProperties(**base)


def _cell(rock, sx, sy, sxy, friction=0.0):
    """Two triangles under a uniform far field: the cluster stress is exactly it."""
    mesh = rectangle_mesh(1.0, 1.0, 1, 1)
    m = MechanicsModel(mesh, rock, InSituStress(sx, sy, sxy, 0.0),
                       boundary=BoundaryConditions("tractions"),
                       crack_planes=CrackPlanes(friction))
    return m, m.initial_state()


def _eig(sx, sy, sxy, p):
    """Principal effective stresses (compression positive) and their directions, by an
    eigen-solver (independent of the model's closed form)."""
    w, v = np.linalg.eigh(np.array([[sx - p, sxy], [sxy, sy - p]]))
    return w, v          # ascending: w[0] = sigma'_min along v[:, 0]


def test_tensile_failure_sets_the_plane_normal_to_sigma_min():
    sx, sy, sxy, T = 30e6, 10e6, 6e6, 2e6
    m, s0 = _cell(_rock(tensile_strength=T), sx, sy, sxy)
    w, v = _eig(sx, sy, sxy, 0.0)
    p_star = w[0] + T                        # sigma'_min = w0 - p reaches -T
    r = m.step(s0, pore_pressure=p_star * (1 + 1e-9))
    st = r.state
    assert np.all(st.cluster_state == FAILED_TENSILE)
    n_min = v[:, 0]
    for c in range(2):
        n = np.asarray(st.crack_normal[c])
        # unit normal along sigma'_min (either sign): to round-off of the 2x2 eigenproblem
        assert abs(abs(n @ n_min) - 1.0) < 1e-12
        # two contacts cross the plane and measure along its normal, the third keeps its
        # sub-edge direction
        cross = m.joint[c]
        assert cross.sum() == 2
        for k in range(3):
            d = m.c_normal[c, k]
            if cross[k]:
                assert abs(abs(d @ n) - 1.0) < 1e-12
            else:
                assert np.allclose(d, m.geometry.normal[c, k], atol=0)
    az = m.plane_azimuth(st.crack_normal)
    t_min = np.degrees(math.atan2(v[1, 1], v[0, 1])) % 180.0    # sigma'_1's direction
    assert az == pytest.approx(np.full(2, t_min), abs=1e-9)


def test_shear_failure_sets_the_mohr_coulomb_plane():
    S0, phi_deg = 5e6, 30.0
    phi = math.radians(phi_deg)
    sx, sy, sxy = 40e6, 10e6, 7e6
    m, s0 = _cell(_rock(cohesion=S0, friction_angle_deg=phi_deg, tensile_strength=50e6),
                  sx, sy, sxy, friction=phi_deg)
    w, v = _eig(sx, sy, sxy, 0.0)
    c, r_ = 0.5 * (w[1] + w[0]), 0.5 * (w[1] - w[0])
    p_star = c - (r_ - S0 * math.cos(phi)) / math.sin(phi)
    st = m.step(s0, pore_pressure=p_star * (1 + 1e-9)).state
    assert np.all(st.cluster_state == FAILED_SHEAR)
    s_eff = np.array([[sx, sxy], [sxy, sy]]) - p_star * np.eye(2)
    a1 = math.atan2(v[1, 1], v[0, 1])                           # sigma'_1's direction
    beta = math.pi / 4 + phi / 2
    for k in range(2):
        n = np.asarray(st.crack_normal[k])
        # no crack next to it: the conjugate at +beta from sigma'_1 (the fixed rule)
        assert abs(abs(n @ np.array([math.cos(a1 + beta), math.sin(a1 + beta)])) - 1) < 1e-12
        # and on that plane the Mohr-Coulomb criterion is met exactly (independently:
        # the traction of the effective stress tensor on the plane)
        N = n @ s_eff @ n
        tau = abs(plane_tangent(n) @ s_eff @ n)
        assert tau - S0 - math.tan(phi) * N == pytest.approx(0.0, abs=1e-6 * S0)


def test_shear_plane_continues_the_crack_next_to_it():
    """Of the two conjugate planes a shear failure takes the one closer to the cracked
    clusters sharing a node with it."""
    sx, sy, sxy = 40e6, 10e6, 7e6
    m, s0 = _cell(_rock(cohesion=5e6, friction_angle_deg=30.0), sx, sy, sxy)
    phi = math.radians(30.0)
    a1 = 0.5 * math.atan2(2 * sxy, sx - sy)                    # sigma_1's direction
    minus = np.array([math.cos(a1 - math.pi / 4 - phi / 2),
                      math.sin(a1 - math.pi / 4 - phi / 2)])
    # cluster 0 cracked on (nearly) the -beta plane; cluster 1 (shares two nodes) fails
    s1 = m.fail_clusters(s0, [0], FAILED_TENSILE, plane_normal=minus + [0.05, 0.0])
    cs = np.asarray(s1.cluster_state)
    eff = np.tile([sx, sy, sxy], (2, 1)).astype(float)
    cn = m.set_crack_planes(np.array([1]), np.array([False]), eff, cs,
                            np.asarray(s1.crack_normal))
    assert abs(abs(cn[1] @ minus) - 1.0) < 1e-12
    # with no cracked neighbour: the +beta plane
    cn0 = m.set_crack_planes(np.array([1]), np.array([False]), eff,
                             np.full(2, INTACT), np.zeros((2, 2)))
    plus = np.array([math.cos(a1 + math.pi / 4 + phi / 2),
                     math.sin(a1 + math.pi / 4 + phi / 2)])
    assert abs(abs(cn0[1] @ plus) - 1.0) < 1e-12


def test_plane_helpers():
    # mean of axial directions: n and -n are the same axis
    ax = mean_axis(np.array([[1.0, 0.0], [-1.0, 0.0], [math.cos(0.2), math.sin(0.2)]]))
    assert abs(ax[1]) < 0.2 and abs(ax[0]) > 0.98
    assert np.array_equal(mean_axis(np.zeros((0, 2))), np.zeros(2))
    nm = np.array([[[1.0, 0.0], [0.0, 1.0]]])
    assert np.array_equal(choose_conjugate(nm, np.array([[0.1, -0.9]]))[0], [0.0, 1.0])
    assert np.array_equal(choose_conjugate(nm, np.zeros((1, 2)))[0], [1.0, 0.0])
    # the line through the centroid always separates one node from two
    rng = np.random.default_rng(4)
    pts = rng.uniform(-1, 1, (200, 3, 2))
    ang = rng.uniform(0, np.pi, 200)
    n = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    cross, _ = plane_crossing(pts, pts.mean(axis=1), n)
    assert np.all(cross.sum(axis=1) == 2)


def _random_planes(k=40, seed=0):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-1, 1, (k, 3, 2))
    d1, d2 = pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0]
    a = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    pts[a < 0] = pts[a < 0][:, [0, 2, 1]]
    pts = pts[np.abs(a) > 0.1]
    tris = np.arange(3 * len(pts)).reshape(-1, 3)
    g = mdem.cluster_geometry(pts.reshape(-1, 2), tris)
    ang = rng.uniform(0, np.pi, len(pts))
    n = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    cross, sgn = plane_crossing(pts, pts.mean(axis=1), n)
    cn = np.where(cross[..., None], sgn[..., None] * n[:, None, :], g.normal)
    ct = np.where(cross[..., None], sgn[..., None] * plane_tangent(n)[:, None, :], g.shear)
    return pts, g, n, cross, cn, ct


def test_joint_operators_ignore_rigid_motion_and_measure_the_opening():
    pts, g, n, cross, cn, ct = _random_planes()
    bn, bs = joint_operators(g.dx, cn, ct, cross)
    k = len(pts)
    # a rigid rotation (1e-3 rad) and translation load no contact at all (exactly, up to
    # round-off of the ~1e-3 m displacements)
    u = 1e-3 * np.stack([-pts[..., 1], pts[..., 0]], axis=-1) + np.array([0.3, -0.2])
    u = u.reshape(k, 6)
    assert np.max(np.abs(np.einsum("cmi,ci->cm", bn, u))) < 1e-15
    assert np.max(np.abs(np.einsum("cmi,ci->cm", bs, u)[cross])) < 1e-15
    # the lone node moved by w along the normal opens both crossing contacts by w
    w = 1e-4
    side = np.einsum("kni,ki->kn", pts - pts.mean(axis=1, keepdims=True), n) >= 0
    lone = np.where(side.sum(axis=1) == 1, np.argmax(side, axis=1), np.argmin(side, axis=1))
    du = np.zeros((k, 3, 2))
    du[np.arange(k), lone] = w * n * np.where(side[np.arange(k), lone], 1.0, -1.0)[:, None]
    gap = np.einsum("cmi,ci->cm", bn, du.reshape(k, 6))
    np.testing.assert_allclose(gap[cross], w, rtol=1e-12)
    # joint lengths: a joint stress sigma on the crossing contacts (forces -l_m sigma) does
    # on the opening w the work of the cluster stress -sigma n n on the opening's CST
    # strain (from the CST B matrix, independent of the joint code)
    ell = joint_lengths(g.area, g.dx, cn, cross)
    B = mdem.cst_b_matrix(pts.reshape(-1, 2), np.arange(3 * k).reshape(-1, 3))
    eps = np.einsum("cij,cj->ci", B, du.reshape(k, 6))          # (exx, eyy, gxy)
    enn = eps[:, 0] * n[:, 0] ** 2 + eps[:, 1] * n[:, 1] ** 2 + eps[:, 2] * n[:, 0] * n[:, 1]
    # (where the face edge is steep to the plane the opening's CST strain normal to the
    # plane can be of the other sign; the joint length is the magnitude there)
    np.testing.assert_allclose(np.sum(ell * gap * cross, axis=1), g.area * np.abs(enn),
                               rtol=1e-12)
    assert np.mean(enn > 0) > 0.8 and np.all(ell[cross] > 0)
    # and the crossing contacts share it equally
    assert np.array_equal(np.max(ell, axis=1), np.min(np.where(cross, ell, np.inf), axis=1))
    assert operator_stress(bn, pts, g.area).shape == (k, 3, 3)


def _pressurised_crack(crack_planes):
    """A 6 m crack along y = 0 in a 12 m section (sigma_x 40, sigma_y 30 MPa), pre-cut in
    the clusters of the strip along the axis with the planes the model gives them, its
    pressure (and the hole's) raised 24 -> 33 MPa and lowered back in 1 MPa steps."""
    band = FractureBand(0.0, 1.0, 0.4, 4.0, strip=True)
    mesh = borehole_mesh(size=12.0, radius=0.15, growth=1.5, h_wall=2 * math.pi * 0.15 / 12,
                         fracture_band=band)
    m = MechanicsModel(mesh, RockProperties(young=E, poisson=NU, tensile_strength=3e6),
                       InSituStress(40e6, 30e6, 0.0, 20e6, 24e6), crack_planes=crack_planes)
    crack = np.flatnonzero((mesh.triangle_markers == 1) & (np.abs(mesh.centroids[:, 0]) < 3.0))
    s0 = m.initial_state(24e6)
    area = mesh.areas[crack]
    sigma_n = float(np.sum(np.asarray(s0.stress)[crack, 1] * area) / np.sum(area))
    # a pre-cut crack along the axis (at the mud column the wall's least effective stress
    # is radial, so the stress would give the wall clusters a plane along the wall)
    s = m.fail_clusters(s0, crack, FAILED_TENSILE, plane_normal=np.array([0.0, 1.0]))
    up, down = {}, {}
    for leg, ps in ((up, range(24, 34)), (down, range(32, 23, -1))):
        for p in ps:
            pp = np.full(mesh.n_triangles, 20e6)
            pp[crack] = p * 1e6
            r = m.step(s, wall_pressure=p * 1e6, pore_pressure=pp, check_failure=False)
            assert r.converged, r.reason
            s = r.state
            du = (np.asarray(s.displacement) - np.asarray(s0.displacement)).reshape(-1)
            leg[p] = float(np.sum(m.g_pressure[crack] * du[m.dofs[crack]]))
    return m, s, crack, up, down, sigma_n


def test_crack_of_own_planes_closes_reversibly_at_its_normal_stress():
    """A crack of clusters on their own planes (with the face rotation taken out of the
    joint, planes.joint_operators) opens and closes as a frictionless smooth joint, like
    the preset FracturePlane (tests/sim/test_mechanics.py)."""
    m, s, crack, up, down, sigma_n = _pressurised_crack(CrackPlanes(0.0))
    az = m.plane_azimuth(s.crack_normal)[crack]
    assert np.all(np.minimum(az, 180.0 - az) < 1e-12)
    for p in range(24, 33):
        # reversible to the solver's tolerance (measured: 4e-9 of the open volume)
        assert down[p] == pytest.approx(up[p], rel=1e-4, abs=1e-6 * up[33])
    closed = np.polyfit(range(24, 30), [up[p] for p in range(24, 30)], 1)
    open_ = np.polyfit(range(31, 34), [up[p] for p in range(31, 34)], 1)
    # stiff when closed (measured 2.4 % of the open compliance, as the preset plane)
    assert closed[0] < 0.05 * open_[0]
    p_c = (closed[1] - open_[1]) / (open_[0] - closed[0])
    # the lines meet at the in-situ normal stress over the crack (measured +0.40 %, the
    # preset plane +0.13 %); 1 %: the kink spreads over one 1 MPa step near the tips
    assert p_c * 1e6 == pytest.approx(sigma_n, rel=1e-2)


def test_crack_planes_config_is_checked():
    with pytest.raises(InputError, match="crack_planes.friction_angle_deg"):
        CrackPlanes(95.0)
    mesh = rectangle_mesh(1.0, 1.0, 1, 1)
    with pytest.raises(InputError, match="crack_planes"):
        MechanicsModel(mesh, _rock(), InSituStress(1e6, 1e6, 0.0, 0.0),
                       crack_planes=object())
    m, s0 = _cell(_rock(), 20e6, 10e6, 0.0)
    with pytest.raises(InputError, match="plane_normal"):
        m.fail_clusters(s0, [0], plane_normal=np.zeros(2))


def test_tensile_failure_at_a_crack_continues_its_line():
    """A cluster failing in tension beside a tensile crack takes that crack's plane, not
    its own stress's (a tip cluster's average stress depends on where it sits in the tip
    field); a shear crack beside it does not count, and away from cracks the stress
    decides."""
    sx, sy, sxy = 30e6, 10e6, 6e6
    m, s0 = _cell(_rock(), sx, sy, sxy)
    w, v = _eig(sx, sy, sxy, 0.0)
    along = np.array([0.6, 0.8])
    eff = np.tile([sx, sy, sxy], (2, 1)).astype(float)
    for state, expect in ((FAILED_TENSILE, along), (FAILED_SHEAR, v[:, 0])):
        s1 = m.fail_clusters(s0, [0], state, plane_normal=along)
        cn = m.set_crack_planes(np.array([1]), np.array([True]), eff,
                                np.asarray(s1.cluster_state), np.asarray(s1.crack_normal))
        assert abs(abs(cn[1] @ expect) - 1.0) < 1e-12, state


def test_band_centred_wall_puts_a_wall_edge_on_the_axis():
    from xlotkit.sim.scene import scene_from_dict

    d = {"model": "mdem", "geometry": {"domain_size": "4 m"},
         "mesh": {"growth": 1.5, "wall_element_size": "0.1 m", "fracture_band": True,
                  "band_width": "0.4 m", "band_length": "1.5 m", "band_centred_wall": True},
         "stresses": {"sigma_H": "35 MPa", "sigma_h": "30 MPa", "pore_pressure": "20 MPa",
                      "sigma_H_azimuth": "30 deg"},
         "schedule": {"phase": [{"kind": "pump", "rate": "100 l/min", "duration": "5 s"}]}}
    from xlotkit.sim.coupling.build import build_model

    mesh = build_model(scene_from_dict(d))[0].mesh
    wall = mesh.nodes[mesh.hole_nodes]
    ang = np.degrees(np.arctan2(wall[:, 1], wall[:, 0]))
    step = 360.0 / len(ang)
    # no wall node on the axis; two of them half an edge either side of it
    off = np.abs((ang - 30.0 + 180.0) % 360.0 - 180.0)
    assert np.sort(off)[:2] == pytest.approx([0.5 * step] * 2, abs=1e-9)
    d["mesh"]["fracture_band"] = False
    with pytest.raises(InputError) as ei:
        scene_from_dict(d)
    assert ei.value.key == "mesh.band_centred_wall"
