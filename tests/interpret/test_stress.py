"""Stress interpretation: analytic checks of every formula in xlotkit.interpret.stress.

Tolerances: formulas that are exact in real arithmetic are checked to a few ulps of the
magnitudes involved (rel 1e-12, or abs 1e-6 Pa on stresses of ~1e7 Pa); finite-difference and
Monte-Carlo checks state their own error bounds next to the assertion.
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from xlotkit.errors import InputError
from xlotkit.interpret.picks.types import Pick
from xlotkit.interpret.stress import (
    GRAVITY,
    DepthModel,
    Uncertain,
    as_uncertain,
    breakdown_hubbert_willis,
    breakdown_poroelastic,
    fracture_half_length_from_stiffness,
    friction_ratio,
    from_emw,
    hoop_stress_at_wall,
    kgd_stiffness,
    kirsch_stresses,
    penny_stiffness,
    pick_at_depth,
    poroelastic_eta,
    pressure_at_depth,
    reopening_pressure,
    sigma_H_estimates,
    sigma_h_from_fcp,
    stress_polygon,
    tensile_strength,
    thrust_belt_bounds,
    to_emw,
)

MPa = 1e6
EXACT = dict(rel=1e-12, abs=1e-6)  # rounding only: ~1e-16 relative on ~1e7 Pa values


# ---------------------------------------------------------------------------------------------
# depth conversion
# ---------------------------------------------------------------------------------------------

def test_hydrostatic_by_hand_1_09_sg_over_1383_m():
    m = DepthModel(target_tvd=1383.0, mud_density=1090.0)
    # 1090 kg/m3 * 9.80665 m/s2 * 1383 m = 14 783 230.68 Pa (hand multiplication)
    assert m.hydrostatic == pytest.approx(14_783_230.6755, rel=1e-12)
    assert pressure_at_depth(50e5, m) == pytest.approx(50e5 + 14_783_230.6755, rel=1e-12)
    # A static column of the mud itself has an EMW equal to the mud's specific gravity.
    assert to_emw(pressure_at_depth(0.0, m), 1383.0) == pytest.approx(1.09, rel=1e-12)
    assert from_emw(1.09, 1383.0) == pytest.approx(14_783_230.6755, rel=1e-12)
    # The same from a measured gradient, and vectorised over a series.
    g = DepthModel(target_tvd=1383.0, gradient=1090.0 * GRAVITY)
    np.testing.assert_allclose(pressure_at_depth([0.0, 1e6], g), [14_783_230.6755, 15_783_230.6755],
                               rtol=1e-12)


def test_downhole_gauge_absolute_and_friction():
    # A gauge 1300 m TVD reading absolute, target at 1383 m: only 83 m of mud below it.
    m = DepthModel(target_tvd=1383.0, gauge_tvd=1300.0, gauge_md=1450.0, mud_density=1000.0,
                   gauge_absolute=True)
    assert pressure_at_depth(2e7, m) == pytest.approx(2e7 - 101_325.0 + 1000.0 * GRAVITY * 83.0)
    # Friction as a function of |q|: subtracted while pumping, added during flowback.
    f = DepthModel(target_tvd=1000.0, mud_density=1000.0, friction=lambda q: 5e5 * (q > 0))
    hyd = 1000.0 * GRAVITY * 1000.0
    np.testing.assert_allclose(pressure_at_depth([1e7] * 3, f, rate=[0.01, 0.0, -0.01]),
                               [1e7 + hyd - 5e5, 1e7 + hyd, 1e7 + hyd + 5e5], rtol=1e-12)
    # Coefficient form dp = k |q|^1.75.
    k = DepthModel(target_tvd=1000.0, mud_density=1000.0, friction=2e8)
    assert pressure_at_depth(1e7, k, rate=0.02) == pytest.approx(1e7 + hyd - 2e8 * 0.02 ** 1.75)
    # No rate given = static: friction ignored.
    assert pressure_at_depth(1e7, k) == pytest.approx(1e7 + hyd)


def test_pick_and_fcp_move_to_depth_with_their_interval():
    m = DepthModel(target_tvd=1383.0, mud_density=1090.0)
    pick = Pick("FCP", "sqrt_t", 80e5, low=78e5, high=83e5)
    moved = pick_at_depth(pick, m)
    dp = 14_783_230.6755
    assert (moved.value, moved.low, moved.high) == pytest.approx((80e5 + dp, 78e5 + dp, 83e5 + dp))
    sh = sigma_h_from_fcp(pick, m)
    assert sh.kind == "triangular"
    assert (sh.value, sh.low, sh.high) == pytest.approx((80e5 + dp, 78e5 + dp, 83e5 + dp))
    # Normal input stays normal with the same spread.
    shn = sigma_h_from_fcp((80e5, 1e5), m)
    assert (shn.value, shn.std) == pytest.approx((80e5 + dp, 1e5))
    with pytest.raises(InputError) as ei:
        sigma_h_from_fcp(Pick.not_found("FCP", "sqrt_t", "decline too short"))
    assert ei.value.key == "fcp"


# ---------------------------------------------------------------------------------------------
# Kirsch
# ---------------------------------------------------------------------------------------------

def test_kirsch_at_the_wall():
    a, sx, sy, pw = 0.108, 40 * MPa, 30 * MPa, 20 * MPa
    th = np.linspace(0, 2 * np.pi, 73)
    srr, stt, trt = kirsch_stresses(a, th, a, sx, sy, pw)
    assert np.all(srr == pw) and np.all(trt == 0.0)  # Eq. C.8a, C.8c
    np.testing.assert_allclose(stt, hoop_stress_at_wall(th, sx, sy, pw), rtol=1e-13)
    # Eq. C.10: minimum at the azimuth of sigma_max, maximum 90 degrees away.
    assert hoop_stress_at_wall(0.0, sx, sy, pw) == pytest.approx(3 * sy - sx - pw, **EXACT)
    assert hoop_stress_at_wall(np.pi / 2, sx, sy, pw) == pytest.approx(3 * sx - sy - pw, **EXACT)
    assert stt.min() == pytest.approx(3 * sy - sx - pw, **EXACT)


def test_kirsch_hand_value_of_eq_c7():
    # sigma_H = 40, sigma_h = 30, P_w = 20 MPa at r = 2a, theta = 30 deg: q = a^2/r^2 = 1/4.
    # s_rr = 35*0.75 + 5*cos60*(1 + 3/16 - 1) + 20/4 = 31.71875
    # s_tt = 35*1.25 - 5*cos60*(1 + 3/16) - 20/4    = 35.78125
    # t_rt = -5*sin60*(1 - 3/16 + 1/2)               = -5.6832917...
    srr, stt, trt = kirsch_stresses(0.2, np.pi / 6, 0.1, 40 * MPa, 30 * MPa, 20 * MPa)
    assert srr == pytest.approx(31.71875 * MPa, **EXACT)
    assert stt == pytest.approx(35.78125 * MPa, **EXACT)
    assert trt == pytest.approx(-5 * math.sin(math.pi / 3) * 1.3125 * MPa, **EXACT)


def test_kirsch_far_field_limit():
    a, sx, sy, txy = 0.1, 40 * MPa, 30 * MPa, 3 * MPa
    th = np.linspace(0, np.pi, 13)
    r = 1e4 * a
    srr, stt, trt = kirsch_stresses(r, th, a, sx, sy, 25 * MPa, tau_xy=txy)
    c, s = np.cos(2 * th), np.sin(2 * th)
    far_rr = (sx + sy) / 2 + (sx - sy) / 2 * c + txy * s
    far_tt = (sx + sy) / 2 - (sx - sy) / 2 * c - txy * s
    far_rt = -(sx - sy) / 2 * s + txy * c
    # Perturbation terms are at most ~4 q * 40 MPa with q = (a/r)^2 = 1e-8: < 2 Pa.
    bound = 4 * (a / r) ** 2 * 50 * MPa
    for got, want in ((srr, far_rr), (stt, far_tt), (trt, far_rt)):
        assert np.max(np.abs(got - want)) < bound


def test_kirsch_satisfies_equilibrium_and_compatibility():
    """Equilibrium + compatibility + boundary values make it the elastic solution."""
    a, sx, sy, txy, pw = 0.1, 42 * MPa, 27 * MPa, 4 * MPa, 33 * MPa
    r = np.linspace(1.05 * a, 6 * a, 40)[:, None]
    th = np.linspace(0, 2 * np.pi, 37)[None, :]
    hr, ht = 1e-5 * a, 1e-5

    def f(rr, tt):
        return kirsch_stresses(rr, tt, a, sx, sy, pw, tau_xy=txy)

    srr, stt, trt = f(r, th)
    d_r = [(p - m) / (2 * hr) for p, m in zip(f(r + hr, th), f(r - hr, th))]
    d_t = [(p - m) / (2 * ht) for p, m in zip(f(r, th + ht), f(r, th - ht))]
    eq_r = d_r[0] + d_t[2] / r + (srr - stt) / r
    eq_t = d_r[2] + d_t[1] / r + 2 * trt / r
    # Terms are of order 50 MPa / a = 5e8 Pa/m. Central differences err by ~(h^2/6) * 3rd
    # derivative ~ 1e-10 relative (negligible) and by rounding ~ eps * 5e7 Pa / h ~ 1e-2 Pa/m
    # per difference (observed residual ~0.4 Pa/m); 2 Pa/m is 4e-9 of the terms.
    assert np.max(np.abs(eq_r)) < 2.0 and np.max(np.abs(eq_t)) < 2.0

    # Compatibility (no body force, plane problem): the sum s_rr + s_tt is harmonic.
    def ssum(rr, tt):
        s1, s2, _ = f(rr, tt)
        return s1 + s2

    h2r, h2t = 1e-4 * a, 1e-4
    lap = ((ssum(r + h2r, th) - 2 * ssum(r, th) + ssum(r - h2r, th)) / h2r**2
           + (ssum(r + h2r, th) - ssum(r - h2r, th)) / (2 * h2r) / r
           + (ssum(r, th + h2t) - 2 * ssum(r, th) + ssum(r, th - h2t)) / h2t**2 / r**2)
    # Individual terms reach ~12 (sx - sy) / a^2 ~ 2e10 Pa/m^2 near the wall. Second
    # differences err by ~(h^2/12) * 4th derivative, ~1e-7 of that, plus rounding
    # ~eps * 1e8 Pa / h^2 ~ 2e2 Pa/m^2; a tolerance of 1e-6 of the term scale covers both and
    # is far below what a wrong coefficient would leave (~1e-1 of the scale).
    scale = 12 * abs(sx - sy) / a**2
    assert np.max(np.abs(lap)) < 1e-6 * scale


def test_kirsch_far_field_shear_is_a_rotation_of_principal_stresses():
    a, sx, sy, txy, pw = 0.1, 38 * MPa, 31 * MPa, -5 * MPa, 12 * MPa
    mean, rad = (sx + sy) / 2, math.hypot((sx - sy) / 2, txy)
    theta_p = 0.5 * math.atan2(2 * txy, sx - sy)  # azimuth of the larger principal stress
    r = np.array([0.1, 0.13, 0.3, 2.0])[:, None]
    th = np.linspace(0, 2 * np.pi, 25)[None, :]
    got = kirsch_stresses(r, th, a, sx, sy, pw, tau_xy=txy)
    want = kirsch_stresses(r, th - theta_p, a, mean + rad, mean - rad, pw)
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, rtol=0, atol=1e-6 * MPa)


# ---------------------------------------------------------------------------------------------
# breakdown and reopening
# ---------------------------------------------------------------------------------------------

SH, SHH, P0, T0 = 30 * MPa, 40 * MPa, 15 * MPa, 5 * MPa


def test_hubbert_willis_by_hand_and_kirsch_tensile_criterion():
    pb = breakdown_hubbert_willis(SH, SHH, P0, T0)
    assert pb == pytest.approx(90 * MPa - 40 * MPa - 15 * MPa + 5 * MPa, **EXACT)  # 40 MPa
    # Eq. C.9 at breakdown: effective hoop stress at the sigma_H azimuth is exactly -T0.
    assert hoop_stress_at_wall(0.0, SHH, SH, pb) - P0 == pytest.approx(-T0, rel=0, abs=1e-6)
    # Reopening (Eq. C.13) is breakdown without the tensile strength.
    assert reopening_pressure(SH, SHH, P0) == pytest.approx(pb - T0, **EXACT)
    assert hoop_stress_at_wall(0.0, SHH, SH, reopening_pressure(SH, SHH, P0)) - P0 == \
        pytest.approx(0.0, abs=1e-6)
    # vectorised
    np.testing.assert_allclose(breakdown_hubbert_willis(SH, [SH, SHH], P0, [0.0, T0]),
                               [2 * SH - P0, pb])


def test_poroelastic_breakdown_limits_and_criterion():
    hw = breakdown_hubbert_willis(SH, SHH, P0, T0)
    # eta = 1/2 gives Hubbert-Willis back; eta = 0 gives the mean of HW and p0.
    assert breakdown_poroelastic(SH, SHH, P0, T0, eta=0.5) == pytest.approx(hw, **EXACT)
    assert breakdown_poroelastic(SH, SHH, P0, T0, eta=0.0) == pytest.approx((hw + P0) / 2, **EXACT)
    # alpha = 1, nu = 0.25: eta = 1 * 0.5 / 1.5 = 1/3 (by hand).
    assert poroelastic_eta(1.0, 0.25) == pytest.approx(1 / 3, rel=1e-15)
    pb = breakdown_poroelastic(SH, SHH, P0, T0, 1.0, 0.25)
    assert pb == pytest.approx(breakdown_poroelastic(SH, SHH, P0, T0, eta=1 / 3), rel=1e-15)
    # Tensile criterion with fluid in the wall: hoop stress + poroelastic increase 2 eta (P - p0),
    # minus the wall pore pressure P, equals -T0.
    eta = 1 / 3
    eff = hoop_stress_at_wall(0.0, SHH, SH, pb) + 2 * eta * (pb - P0) - pb
    assert eff == pytest.approx(-T0, rel=0, abs=1e-6)
    # The result is a weighted mean of p0 and the HW value, so it lies between them.
    etas = np.linspace(0, 0.5, 11)
    pbs = breakdown_poroelastic(SH, SHH, P0, T0, eta=etas)
    assert np.all((pbs >= P0 - 1e-6) & (pbs <= hw + 1e-6)) and np.all(np.diff(pbs) > 0)


# ---------------------------------------------------------------------------------------------
# tensile strength and sigma_H (Eq. C.18 / C.19)
# ---------------------------------------------------------------------------------------------

def test_tensile_strength():
    assert tensile_strength(45 * MPa, 40 * MPa).value == pytest.approx(5 * MPa)
    t = tensile_strength(Uncertain(45 * MPa, 44 * MPa, 46 * MPa), Uncertain(40 * MPa, 39 * MPa,
                                                                          41 * MPa))
    assert (t.low, t.value, t.high) == pytest.approx((3 * MPa, 5 * MPa, 7 * MPa))
    tn = tensile_strength((45 * MPa, 0.3 * MPa), (40 * MPa, 0.4 * MPa))
    assert tn.std == pytest.approx(0.5 * MPa)
    with pytest.raises(InputError) as ei:
        tensile_strength(40 * MPa, 41 * MPa)
    assert ei.value.key == "pr" and "Pr <= FBP" in ei.value.expected


def test_sigma_H_recovered_from_synthetic_breakdown_and_reopening():
    for sH_true in (30 * MPa, 36 * MPa, 40 * MPa):
        fbp = breakdown_hubbert_willis(SH, sH_true, P0, T0)
        pr = reopening_pressure(SH, sH_true, P0)
        est = sigma_H_estimates(SH, p0=P0, fbp=fbp, pr=pr, T0=T0, n_samples=100)
        assert set(est) == {"C.18", "C.19"}
        for e in est.values():
            assert e.value == pytest.approx(sH_true, **EXACT)
            # Exact inputs: every sample is the exact value.
            assert e.std == pytest.approx(0.0, abs=1e-6) and e.low == pytest.approx(sH_true)
        # And T0 = FBP - Pr by construction.
        assert tensile_strength(fbp, pr).value == pytest.approx(T0, **EXACT)
    # Without an independent T0, Eq. C.18 is not computed (it would duplicate C.19).
    est = sigma_H_estimates(SH, p0=P0, fbp=45 * MPa, pr=40 * MPa)
    assert list(est) == ["C.19"] and "C.18" in est.notes[0]


def test_monte_carlo_converges_to_analytic_moments_normal():
    n = 40_000
    sh, pr, p0, t0, fbp = (30 * MPa, 1 * MPa), (40 * MPa, 1.5 * MPa), (15 * MPa, 0.5 * MPa), \
        (5 * MPa, 1 * MPa), (46 * MPa, 2 * MPa)
    est = sigma_H_estimates(sh, p0=p0, pr=pr, fbp=fbp, T0=t0, n_samples=n, seed=7)
    want19 = 3 * 30 - 40 - 15
    sd19 = math.sqrt(9 * 1.0 + 1.5**2 + 0.5**2)
    want18 = 3 * 30 - 46 - 15 + 5
    sd18 = math.sqrt(9 * 1.0 + 2**2 + 0.5**2 + 1.0)
    for eq, want, sd in (("C.19", want19, sd19), ("C.18", want18, sd18)):
        e = est[eq]
        # Linear in normal inputs: mean within 3 standard errors of the analytic value.
        assert abs(e.mean - want * MPa) < 3 * e.std_error
        # Sample std has relative standard error 1/sqrt(2n) = 0.35 %; allow ~6 of them.
        assert e.std == pytest.approx(sd * MPa, rel=0.02)
        # 5/95 % quantiles of a normal: mean -/+ 1.6449 sd; quantile standard error
        # sqrt(p(1-p))/(phi(z) sqrt(n)) = 0.0106 sd; allow 4 of them plus the mean's error.
        z = 1.6448536
        assert abs(e.low - (want - z * sd) * MPa) < 0.06 * sd * MPa
        assert abs(e.high - (want + z * sd) * MPa) < 0.06 * sd * MPa
        assert e.median == pytest.approx(want * MPa, abs=0.05 * sd * MPa)


def test_monte_carlo_triangular_mean_and_determinism():
    # Asymmetric triangles: the mean is (low + mode + high) / 3, not the mode.
    sh = Uncertain(30 * MPa, 29 * MPa, 33 * MPa)   # mean 30.666...
    pr = Uncertain(40 * MPa, 38 * MPa, 41 * MPa)   # mean 39.666...
    p0 = Uncertain.exact(15 * MPa)
    a = sigma_H_estimates(sh, p0=p0, pr=pr, n_samples=30_000, seed=3)["C.19"]
    want = 3 * sh.mean - pr.mean - p0.mean
    assert abs(a.mean - want) < 3 * a.std_error
    assert a.std == pytest.approx(math.sqrt(9 * sh.sd**2 + pr.sd**2), rel=0.02)
    assert a.value == pytest.approx(3 * 30 * MPa - 40 * MPa - 15 * MPa)  # from the modes
    b = sigma_H_estimates(sh, p0=p0, pr=pr, n_samples=30_000, seed=3)["C.19"]
    c = sigma_H_estimates(sh, p0=p0, pr=pr, n_samples=30_000, seed=4)["C.19"]
    assert a == b and a.mean != c.mean


def test_sigma_H_below_sigma_h_is_reported_not_hidden():
    e = sigma_H_estimates(30 * MPa, p0=15 * MPa, pr=50 * MPa)["C.19"]  # 90 - 50 - 15 = 25
    assert e.value < 30 * MPa and "below sigma_h" in e.message
    assert e.fraction_below_sigma_h == 1.0


def test_as_uncertain_forms():
    assert as_uncertain(3.0).kind == "exact"
    assert as_uncertain((3.0, 0.1)).kind == "normal"
    u = as_uncertain((3.0, 2.0, 5.0))
    assert u.kind == "triangular" and u.mean == pytest.approx(10 / 3)
    # triangular sd by the closed form sqrt((a^2+b^2+c^2-ab-ac-bc)/18) for (2, 3, 5): sqrt(7/18)
    assert u.sd == pytest.approx(math.sqrt(7 / 18))
    assert as_uncertain(Pick("FCP", "x", 3.0, 2.5, 3.5)).interval == (2.5, 3.5)
    with pytest.raises(InputError):
        as_uncertain("3 bar", key="sigma_h")
    with pytest.raises(InputError) as ei:
        Uncertain(3.0, 4.0, 5.0)
    assert ei.value.key == "value"


# ---------------------------------------------------------------------------------------------
# stress polygon and thrust-belt bounds
# ---------------------------------------------------------------------------------------------

def test_polygon_vertices_by_hand_mu_0_6():
    # q = (sqrt(1.36) + 0.6)^2 = 1.36 + 0.36 + 1.2 sqrt(1.36) = 3.1194284548 (hand);
    # sv = 50, p0 = 20 MPa: h_min = 20 + 30/q = 29.6171464, H_max = 20 + 30 q = 113.5828536.
    poly = stress_polygon(50 * MPa, 20 * MPa, 0.6)
    assert poly.q == pytest.approx(3.1194284548, rel=1e-10)
    assert friction_ratio(0.6) == pytest.approx(3.1194284548, rel=1e-10)
    want = np.array([[29.6171464, 29.6171464], [29.6171464, 50.0], [50.0, 113.5828536],
                     [113.5828536, 113.5828536]]) * MPa
    np.testing.assert_allclose(poly.vertices, want, rtol=1e-8)
    # q equals (1 + sin phi) / (1 - sin phi) with phi = atan(mu).
    s = math.sin(math.atan(0.6))
    assert poly.q == pytest.approx((1 + s) / (1 - s), rel=1e-13)


@pytest.mark.parametrize("sh, sH, inside, regime", [
    (35, 45, True, "normal"),
    (25, 40, False, "normal"),        # sigma_h below the normal-fault limit 29.6
    (40, 80, True, "strike-slip"),    # limit 20 + q * 20 = 82.4
    (40, 90, False, "strike-slip"),
    (60, 100, True, "reverse"),
    (60, 120, False, "reverse"),      # above H_max = 113.6
    (29.6171464, 50.0, True, "normal"),  # a vertex is on the boundary
])
def test_polygon_classification(sh, sH, inside, regime):
    c = stress_polygon(50 * MPa, 20 * MPa, 0.6).classify(sh * MPa, sH * MPa, rtol=1e-8)
    assert (c.inside, c.regime) == (inside, regime)


def test_thrust_belt_bounds_are_tangent_mohr_circles_and_polygon_corners():
    sv, lop, mu, c0 = 50 * MPa, 38 * MPa, 0.7, 2 * MPa
    b = thrust_belt_bounds(sv, lop, mu=mu, cohesion=c0)
    assert b.apex == pytest.approx(lop - c0 / mu)
    # Each limiting Mohr circle touches tau = C0 + mu (sigma_n - LOP): the distance from its
    # centre to the line equals its radius.
    for s1, s3 in ((sv, b.sigma_h_lim), (b.sigma_H_lim, sv)):
        c, rad = (s1 + s3) / 2, (s1 - s3) / 2
        dist = abs(mu * (c - lop) + c0) / math.sqrt(1 + mu**2)
        assert dist == pytest.approx(rad, rel=1e-12)
    poly = b.polygon()
    assert (poly.sigma_h_min, poly.sigma_H_max) == pytest.approx((b.sigma_h_lim, b.sigma_H_lim),
                                                                 rel=1e-12)
    # mu and phi give the same bounds; arrays give one bound per friction value.
    bp = thrust_belt_bounds(sv, lop, phi=math.atan(mu), cohesion=c0)
    assert bp.sigma_H_lim == pytest.approx(b.sigma_H_lim, rel=1e-13)
    ba = thrust_belt_bounds(sv, lop, mu=np.array([0.6, 0.7, 0.8]), cohesion=c0)
    assert ba.sigma_H_lim[1] == pytest.approx(b.sigma_H_lim, rel=1e-13)
    assert np.all(np.diff(ba.sigma_H_lim) > 0) and np.all(np.diff(ba.sigma_h_lim) < 0)


# ---------------------------------------------------------------------------------------------
# fracture size from stiffness (Eq. C.3)
# ---------------------------------------------------------------------------------------------

def test_penny_stiffness_by_hand_and_from_sneddon_volume():
    E, nu, R = 10e9, 0.25, 5.0
    # 3 E / (16 R^3 (1 - nu^2)) = 3e10 / (16 * 125 * 0.9375) = 1.6e7 Pa/m3 (hand)
    assert penny_stiffness(R, E, nu) == pytest.approx(1.6e7, rel=1e-14)
    # Sneddon opening of a penny crack, w(r) = 8 (1-nu^2) p sqrt(R^2 - r^2) / (pi E).
    p = 1e6
    vol, _ = quad(lambda r: 2 * np.pi * r * 8 * (1 - nu**2) * p / (np.pi * E)
                  * np.sqrt(R**2 - r**2), 0, R)
    assert p / vol == pytest.approx(penny_stiffness(R, E, nu), rel=1e-10)


def test_kgd_stiffness_from_sneddon_volume():
    E, nu, L, h, p = 10e9, 0.25, 12.0, 3.0, 1e6
    vol, _ = quad(lambda x: 4 * (1 - nu**2) * p / E * np.sqrt(L**2 - x**2), -L, L)
    assert p / (vol * h) == pytest.approx(kgd_stiffness(L, h, E, nu), rel=1e-10)


@pytest.mark.parametrize("geometry, size, kw", [("penny", 5.0, {}), ("penny", 23.0, {}),
                                                ("kgd", 12.0, {"h": 3.0})])
def test_half_length_from_stiffness_contrast_round_trip(geometry, size, kw):
    E, nu = 10e9, 0.25
    s_well = 4.4e7  # ~50 m3 of mud with compressibility 4.5e-10 1/Pa
    s_frac = penny_stiffness(size, E, nu) if geometry == "penny" else \
        kgd_stiffness(size, kw["h"], E, nu)
    s_open = 1 / (1 / s_well + 1 / s_frac)   # compliances in parallel add
    got = fracture_half_length_from_stiffness(s_open, s_well, E, nu, geometry, **kw)
    assert got == pytest.approx(size, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# impossible inputs
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("call, key", [
    (lambda: breakdown_hubbert_willis(-1.0, 40e6, 10e6, 0.0), "sigma_h"),
    (lambda: breakdown_hubbert_willis(40e6, 30e6, 10e6, 0.0), "sigma_H"),
    (lambda: breakdown_hubbert_willis(30e6, 40e6, 35e6, 0.0), "p0"),
    (lambda: breakdown_hubbert_willis(30e6, 40e6, 10e6, -1e6), "T0"),
    (lambda: breakdown_poroelastic(30e6, 40e6, 10e6, 0.0, 1.0, 0.5), "nu"),
    (lambda: breakdown_poroelastic(30e6, 40e6, 10e6, 0.0, 1.0, 0.0), "nu"),
    (lambda: breakdown_poroelastic(30e6, 40e6, 10e6, 0.0, 1.2, 0.2), "alpha"),
    (lambda: breakdown_poroelastic(30e6, 40e6, 10e6, 0.0, eta=0.6), "eta"),
    (lambda: breakdown_poroelastic(30e6, 40e6, 10e6, 0.0), "alpha"),
    (lambda: stress_polygon(50e6, 20e6, 0.0), "mu"),
    (lambda: stress_polygon(50e6, 60e6, 0.6), "p0"),
    (lambda: stress_polygon(-5.0, 0.0, 0.6), "sv"),
    (lambda: stress_polygon(50e6, 20e6, 0.6).classify(40e6, 30e6), "sigma_H"),
    (lambda: thrust_belt_bounds(50e6, 55e6, mu=0.6), "lop"),
    (lambda: thrust_belt_bounds(50e6, 30e6), "mu/phi"),
    (lambda: thrust_belt_bounds(50e6, 30e6, phi=2.0), "phi"),
    (lambda: kirsch_stresses(0.05, 0.0, 0.1, 1.0, 1.0, 0.0), "r"),
    (lambda: kirsch_stresses(0.2, 0.0, 0.0, 1.0, 1.0, 0.0), "a"),
    (lambda: kirsch_stresses(0.2, float("nan"), 0.1, 1.0, 1.0, 0.0), "theta"),
    (lambda: fracture_half_length_from_stiffness(5e7, 4e7, 1e10, 0.25), "S_open"),
    (lambda: fracture_half_length_from_stiffness(1e7, 4e7, 1e10, 0.25, "kgd"), "h"),
    (lambda: fracture_half_length_from_stiffness(1e7, 4e7, 1e10, 0.25, "pkn"), "geometry"),
    (lambda: fracture_half_length_from_stiffness(1e7, 4e7, -1e10, 0.25), "E"),
    (lambda: DepthModel(target_tvd=1383.0, mud_density=1.09), "mud_density"),
    (lambda: DepthModel(target_tvd=1383.0), "mud_density/gradient"),
    (lambda: DepthModel(target_tvd=-1.0, mud_density=1090.0), "target_tvd"),
    (lambda: DepthModel(target_tvd=1000.0, gauge_tvd=500.0, gauge_md=400.0, mud_density=1090.0),
     "gauge_md"),
    (lambda: pressure_at_depth(1e7, DepthModel(target_tvd=1e3, mud_density=1e3,
                                               friction=lambda q: -q), rate=0.1), "friction"),
    (lambda: to_emw(1e7, 0.0), "tvd"),
    (lambda: sigma_H_estimates(30e6, p0=10e6), "pr/fbp"),
    (lambda: sigma_H_estimates(30e6, p0=40e6, pr=40e6), "p0"),
    (lambda: sigma_H_estimates(30e6, p0=10e6, pr=40e6, n_samples=1), "n_samples"),
    (lambda: sigma_H_estimates(30e6, p0=10e6, fbp=40e6, T0=-1e6), "T0"),
    (lambda: Uncertain.normal(1.0, -1.0), "std"),
])
def test_impossible_inputs_raise_input_error_naming_the_argument(call, key):
    with pytest.raises(InputError) as ei:
        call()
    assert ei.value.key == key
    assert ei.value.expected  # the allowed range is stated


# ---------------------------------------------------------------------------------------------
# plots (Agg-safe Figure objects; content checked through the drawn data)
# ---------------------------------------------------------------------------------------------

def test_plot_stress_polygon_draws_the_polygon_and_estimate(tmp_path):
    from matplotlib.figure import Figure

    from xlotkit.interpret.plots.stress import plot_stress_polygon

    est = sigma_H_estimates(Uncertain(36 * MPa, 34 * MPa, 37 * MPa), p0=20 * MPa,
                            pr=(40 * MPa, 1.5 * MPa), n_samples=2000)
    out = tmp_path / "poly.png"
    fig = plot_stress_polygon(50 * MPa, 20 * MPa, 0.6, est, path=out)
    assert isinstance(fig, Figure) and out.stat().st_size > 10_000
    ax = fig.axes[0]
    poly = stress_polygon(50 * MPa, 20 * MPa, 0.6)
    closed = np.vstack([poly.vertices, poly.vertices[:1]]) / MPa
    assert any(np.allclose(np.column_stack(line.get_data()), closed)
               for line in ax.get_lines() if len(line.get_xdata()) == 5)
    # The estimate point sits at (sigma_h, Eq. C.19 value) in MPa.
    pts = [np.column_stack(line.get_data()) for line in ax.get_lines()
           if len(line.get_xdata()) == 1]
    assert any(np.allclose(p, [[36.0, est["C.19"].value / MPa]]) for p in pts)
    # Drawing into given axes returns that axes' figure.
    fig2 = Figure()
    ax2 = fig2.add_subplot()
    assert plot_stress_polygon(50 * MPa, 20 * MPa, 0.6, (40 * MPa, 70 * MPa), ax=ax2) is fig2


def test_plot_hoop_stress(tmp_path):
    from xlotkit.interpret.plots.stress import plot_hoop_stress

    pb = breakdown_hubbert_willis(36 * MPa, 62 * MPa, 20 * MPa, 5 * MPa)
    fig = plot_hoop_stress(62 * MPa, 36 * MPa, [25 * MPa, pb], p0=20 * MPa, T0=5 * MPa,
                           path=tmp_path / "hoop.png")
    ax_w = fig.axes[0]
    # The breakdown curve's minimum touches the failure level p0 - T0 = 15 MPa.
    curve = ax_w.get_lines()[1].get_ydata()
    assert curve.min() == pytest.approx(15.0, abs=1e-9)
    assert (tmp_path / "hoop.png").stat().st_size > 10_000
