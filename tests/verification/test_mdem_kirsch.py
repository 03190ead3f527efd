"""Intact MDEM around a borehole against the Kirsch solution (thesis Eq. C.7/C.8)."""

import math

import numpy as np
import pytest

from xlotkit.sim.mechanics import BoundaryConditions, InSituStress, MechanicsModel, RockProperties
from xlotkit.formulas import kirsch_cartesian, kirsch_polar
from xlotkit.sim.mechanics.recovery import polar_components, wall_stress
from xlotkit.sim.mesh import borehole_mesh, refine_uniform

A = 0.15


def _solve(mesh, sx, sy, sxy, pw, kind="rollers"):
    model = MechanicsModel(mesh, RockProperties(), InSituStress(sx, sy, sxy, 20e6, pw),
                           boundary=BoundaryConditions(kind))
    return model.initial_state()


@pytest.mark.parametrize("sx,sy,sxy,pw,kind", [
    (35e6, 30e6, 0.0, 25e6, "rollers"),      # thesis stresses, mud weight above p0
    (40e6, 25e6, 6e6, 32e6, "tractions"),    # rotated anisotropic far field
])
def test_wall_hoop_stress_within_2_percent_on_default_mesh(sx, sy, sxy, pw, kind):
    mesh = borehole_mesh()  # default: 64 wall segments, growth 1.2, ~2.4k triangles
    st = _solve(mesh, sx, sy, sxy, pw, kind)
    theta = np.linspace(0.0, 2 * np.pi, 33)[:-1]
    # cluster stresses are triangle averages; the wall value is recovered by a local least-
    # squares fit in q = a^2/r^2 and the angle (recovery.wall_stress, 8 wall edge lengths
    # deep): the Kirsch field is quadratic in q, so the fit adds no bias and averages the
    # O(h) element-to-element scatter of constant-strain stresses.
    rec = wall_stress(mesh, st.stress, theta)
    c = 0.5 * (sx + sy)
    r = math.hypot(0.5 * (sx - sy), sxy)
    phi = 0.5 * math.atan2(2 * sxy, sx - sy)
    _, hoop, _ = kirsch_polar(A, theta - phi, A, c + r, c - r, pw)
    # relative to the local hoop stress where it is at least half its peak, and relative to
    # the peak everywhere (the rotated case has a hoop stress crossing zero on the wall,
    # where a relative error is void)
    peak = np.abs(hoop).max()
    big = np.abs(hoop) >= 0.5 * peak
    assert np.max(np.abs(rec[big, 1] - hoop[big]) / np.abs(hoop[big])) < 0.02
    assert np.max(np.abs(rec[:, 1] - hoop)) < 0.02 * peak
    # radial stress at the wall equals the wall pressure (Eq. C.8a). sigma_rr has the
    # steepest radial gradient at the wall, so its extrapolation is the least accurate:
    # measured 1.3-2.1 % of the peak hoop stress; 3 % bounds it.
    assert np.abs(rec[:, 0] - pw).max() < 0.03 * np.abs(hoop).max()
    # raw cluster stresses far from the hole are the far field (size 100 m, a = 0.15 m:
    # the Kirsch perturbation there is < (a/r)^2 ~ 1e-4)
    cen = mesh.centroids
    far = np.hypot(*cen.T) > 10.0
    np.testing.assert_allclose(st.stress[far], np.broadcast_to([sx, sy, sxy], st.stress[far].shape),
                               atol=0.003 * sx)


def test_kirsch_stress_error_converges_at_first_order():
    # coarse graded base mesh (32 wall segments) refined uniformly twice (projected wall);
    # 20 m domain: the truncation error (a/R)^2 ~ 2e-4 is far below the measured errors
    mesh = borehole_mesh(size=20.0, h_wall=2 * math.pi * A / 32, growth=1.3)
    hs, errs = [], []
    for level in range(3):
        st = _solve(mesh, 35e6, 30e6, 0.0, 25e6)
        cen = mesh.centroids
        near = np.hypot(*cen.T) < 5 * A
        ex = kirsch_cartesian(cen[near, 0], cen[near, 1], A, 35e6, 30e6, 0.0, 25e6)
        w = mesh.areas[near, None]
        errs.append(math.sqrt(np.sum(w * (st.stress[near] - ex) ** 2) / np.sum(w * ex ** 2)))
        hs.append(2 * math.pi * A / 32 / 2 ** level)
        if level < 2:
            mesh = refine_uniform(mesh)
    rate = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    # constant-strain elements converge in stress (L2) at order 1; measured ~0.95 here.
    # 0.85 leaves room for the pre-asymptotic first level without accepting order 1/2.
    assert rate >= 0.85, (rate, errs)
    assert errs[-1] < 0.005


def test_polar_rotation_round_trip():
    s = np.array([[3.0, -1.0, 2.0]])
    ang = 0.3
    p = polar_components(s, np.array([ang]))
    assert p[0, 0] + p[0, 1] == pytest.approx(2.0)  # trace invariant
    ex = kirsch_cartesian(np.array([0.3]), np.array([0.2]), A, 30.0, 30.0, 0.0, 30.0)
    np.testing.assert_allclose(ex, [[30.0, 30.0, 0.0]], atol=1e-12)
