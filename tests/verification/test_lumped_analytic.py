"""Lumped model against closed-form solutions (SPEC §8)."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from xlotkit.formulas import hubbert_willis
from xlotkit.sim.lumped import (
    breakdown_pressure,
    fracture_compliance,
    fracture_volume,
    simulate_lumped,
    standard_lumped_scene,
    stress_intensity,
)
from xlotkit.sim.schedule import Flowback, Pump, Schedule, ShutIn

Q = 0.5 / 60.0


def test_penny_stiffness_is_eq_c3_and_sneddon_volumes():
    e, nu, r = 10e9, 0.25, 12.0
    ep = e / (1 - nu**2)
    assert 1 / fracture_compliance(r, "penny", ep) == pytest.approx(
        3 * e / (16 * r**3 * (1 - nu**2)), rel=1e-14)
    # KGD: integral of w = 4 dp sqrt(L^2 - x^2)/E' over (-L, L) times h
    assert fracture_volume(1e6, 5.0, "kgd", ep, 10.0) == pytest.approx(
        4e6 / ep * math.pi * 25.0 / 2 * 10.0, rel=1e-14)
    assert stress_intensity(1e6, 4.0, "penny") == pytest.approx(2e6 * math.sqrt(4 / math.pi))
    assert breakdown_pressure(30e6, 35e6, 20e6, 3e6) == 38e6
    assert hubbert_willis(30e6, 35e6, 20e6, 3e6) == 38e6


def test_kgd_storage_toughness_propagation_matches_closed_form():
    """Constant rate, no leak-off, quasi-static K_I = K_Ic.

    After breakdown the state is on the critical branch p = sigma_h + K/sqrt(pi L), and all
    pumped volume is stored:

        Q t = C_w (sigma_h + K/sqrt(pi L) - p_init) + 2 sqrt(pi) h K L^1.5 / E'

    i.e. t(L) in closed form, monotone for L > L_s; invert it at each sample time. (No
    entry loss: the closed form has one pressure for well and fracture.)
    """
    k, h = 1e6, 10.0
    sc = standard_lumped_scene(schedule=Schedule([Pump(Q, volume=3.0)]), geometry="kgd",
                               toughness=k, fracture_height=h, leakoff_coefficient=0.0,
                               wall_leak_index=0.0, nwb_coefficient=0.0)
    r = simulate_lumped(sc)
    tr, rec = r.truth, r.record
    cw, ep, sh, p_init = sc.c_well, sc.e_prime, sc.sigma_h, sc.p_initial

    def stored(L):
        return cw * (sh + k / math.sqrt(math.pi * L) - p_init) + (
            2 * math.sqrt(math.pi) * h * k * L**1.5 / ep)

    ls = tr["stable_length"]
    assert ls == pytest.approx(math.sqrt(cw * ep / (6 * math.pi * h)), rel=1e-14)
    m = rec.t > tr["breakdown_time"] + 0.5
    l_exact = np.array([brentq(lambda L: stored(L) - Q * t, ls, 1e4, xtol=1e-13, rtol=1e-15)
                        for t in rec.t[m]])
    p_exact = sh + k / np.sqrt(np.pi * l_exact)
    # The algebraic constraint is solved to round-off at every step; measured ~1e-12.
    np.testing.assert_allclose(rec.channels["fracture_length"][m], l_exact, rtol=1e-9)
    np.testing.assert_allclose(rec.pressure[m], p_exact, rtol=1e-12, atol=1e-3)
    # FPP falls slowly while the fracture grows (toughness regime under volume control)
    assert np.all(np.diff(rec.pressure[m]) < 0)


def _flowback_scene(pump_to, **kw):
    # tvd = 0: the choke sees the bottom-hole pressure directly (p_s = p)
    sched = Schedule([Pump(Q, **pump_to), ShutIn(duration=10.0),
                      Flowback(zeta=2e-6, pressure_below=2e6)])
    base = dict(schedule=sched, tvd=0.0, leakoff_coefficient=0.0, wall_leak_index=0.0,
                sigma_h=14e6, sigma_H=15e6, pore_pressure=5e6, tensile_strength=3e6)
    base.update(kw)
    return standard_lumped_scene(**base)


def test_fixed_choke_flowback_at_constant_stiffness_eq_c5():
    """No fracture: C_w dp/dt = -zeta sqrt(p) so sqrt(p) = sqrt(p0) - zeta t / (2 C_w)."""
    sc = _flowback_scene(dict(pressure_above=20e6), sigma_h=14e6, sigma_H=14e6,
                         tensile_strength=10e6)      # P_b = 23 MPa: never reached
    r = simulate_lumped(sc)
    tr, rec = r.truth, r.record
    fb = tr["phases"][2]
    m = (rec.t >= fb["t_start"]) & (rec.t <= fb["t_end"])
    t = rec.t[m] - fb["t_start"]
    p0 = np.interp(fb["t_start"], tr["t"], tr["pressure"])  # phase starts between samples
    sqrt_p = np.sqrt(rec.channels["surface_pressure"][m])
    expected = np.sqrt(p0) - 2e-6 * t / (2 * sc.c_well)
    # trapezoidal choke flux, steps <= 1 s, p''-driven error O(dt^2): measured ~1e-9
    np.testing.assert_allclose(sqrt_p, expected, rtol=1e-6)
    slope = np.polyfit(t, sqrt_p, 1)[0]
    assert slope == pytest.approx(-2e-6 / (2 * sc.c_well), rel=1e-6)


def test_flowback_two_straight_lines_meet_at_closure():
    """Open fracture of fixed size, then closed: two straight lines on sqrt(p_s) vs t."""
    sc = _flowback_scene(dict(volume=2.5))  # P_b = 25 MPa is reached at ~1.7 m3
    r = simulate_lumped(sc)
    tr, rec = r.truth, r.record
    fb = tr["phases"][2]
    t_c = tr["closure_times"][0]
    L = tr["fracture_length"][-1]
    s_open = 1 / (sc.c_well + fracture_compliance(L, "penny", sc.e_prime))
    s_closed = 1 / sc.c_well
    sp = np.sqrt(rec.channels["surface_pressure"])
    pre = (rec.t >= fb["t_start"]) & (rec.t < t_c)
    post = (rec.t > t_c) & (rec.t <= fb["t_end"])
    k_pre = np.polyfit(rec.t[pre], sp[pre], 1)[0]
    k_post = np.polyfit(rec.t[post], sp[post], 1)[0]
    assert k_pre == pytest.approx(-2e-6 * s_open / 2, rel=1e-5)
    assert k_post == pytest.approx(-2e-6 * s_closed / 2, rel=1e-5)
    # the tangent intersection recovers sigma_h (what the system-stiffness pick does)
    b_pre = np.polyfit(rec.t[pre], sp[pre], 1)[1]
    b_post = np.polyfit(rec.t[post], sp[post], 1)[1]
    t_x = (b_post - b_pre) / (k_pre - k_post)
    assert t_x == pytest.approx(t_c, abs=1e-3)
    assert (k_pre * t_x + b_pre) ** 2 == pytest.approx(sc.sigma_h, rel=1e-7)


def test_reopening_at_the_wall_eq_c13_and_t0_from_fbp_minus_pr():
    """Second cycle reopens at P_r = 3 sigma_h - sigma_H - p0 (Eq. C.13), so FBP - P_r = T0.

    Before P_r the closed fracture is sealed at the wall: the system stiffness is the well's
    alone, also above sigma_h (no leak-off here, so the rise is exactly Q / C_w).
    """
    sc = standard_lumped_scene(leakoff_coefficient=0.0, wall_leak_index=0.0)
    r = simulate_lumped(sc)
    tr, rec = r.truth, r.record
    pr = 3 * 30e6 - 35e6 - 20e6
    assert tr["reopening_pressure_model"] == pr == sc.reopening_pressure
    assert len(tr["reopening_pressures"]) == 1
    # event located to 1e-10 s at dp/dt = Q/C_w ~ 0.12 MPa/s: 1e-5 Pa; 1 Pa is generous
    assert tr["reopening_pressures"][0] == pytest.approx(pr, abs=1.0)
    t0 = tr["fbp"] - tr["reopening_pressures"][0]
    assert t0 == pytest.approx(sc.tensile_strength, rel=0.01)
    # sealed: storage-only slope between sigma_h + 0.5 MPa and P_r - 0.5 MPa
    t_r = tr["reopening_times"][0]
    pump2 = tr["phases"][4]
    m = (rec.t > pump2["t_start"]) & (rec.t < t_r) & (rec.pressure > 30.5e6) & (
        rec.pressure < pr - 0.5e6)
    assert m.sum() > 20
    slope = np.polyfit(rec.t[m], rec.pressure[m], 1)[0]
    assert slope == pytest.approx(Q / sc.c_well, rel=1e-9)
    # then the fracture takes the well's excess at once: a reopening peak and a drop
    after = rec.pressure[(rec.t > t_r) & (rec.t < t_r + 5)]
    assert after.max() < sc.sigma_h + 1e6


def test_entry_loss_drops_well_pressure_by_k_q2_at_shut_in():
    """Well pressure = fracture pressure + k Q_f^2 while the fracture takes Q_f.

    No leak-off: the fracture's inflow in the last pump step is dV_f/dt from the truth
    history, and the well-to-fracture difference at shut-in is exactly k Q_f^2.
    """
    k = 4.32e9
    sched = Schedule([Pump(Q, volume=2.0), ShutIn(duration=60.0)])
    sc = standard_lumped_scene(schedule=sched, leakoff_coefficient=0.0, wall_leak_index=0.0,
                               nwb_coefficient=k)
    r = simulate_lumped(sc)
    tr, rec = r.truth, r.record
    t_si = tr["phases"][0]["t_end"]
    t, p, pf, vf = tr["t"], tr["pressure"], tr["fracture_pressure"], tr["fracture_volume"]
    dt = np.diff(t)
    q_f = np.diff(vf) / np.where(dt > 0, dt, 1.0)
    # propagation steps of the pump phase (>= 0.1 s: shorter event steps lose digits in
    # the V_f difference; the solver itself works with the inflow, not the difference)
    m = (t[1:] > tr["breakdown_time"] + 10.0) & (t[1:] <= t_si) & (dt >= 0.1)
    assert m.sum() > 50
    # backward-Euler inflow, Brent to round-off: measured ~1e-13
    np.testing.assert_allclose((p - pf)[1:][m], k * q_f[m] ** 2, rtol=1e-8)
    drop = tr["last_pump_pressure"][1] - tr["isip"][1]
    # the last full step vs the end of the phase (a 1e-10 s event step later): ~1e-10
    assert drop == pytest.approx(k * q_f[m][-1] ** 2, rel=1e-6)
    # ~98 % of the pumped rate enters the fracture (the rest compresses the well)
    assert drop == pytest.approx(k * Q**2, rel=0.05)
    # the well then falls to the fracture pressure within seconds (2 C_w k Q_f ~ 5 s):
    # 30 s later the two differ by < 1 % of the drop
    j = np.searchsorted(rec.t, t_si + 30.0)
    assert np.all(pf <= p + 1e-6)           # the well is never below the fracture here
    assert abs(rec.pressure[j] - rec.channels["fracture_pressure"][j]) < 0.01 * drop
    assert rec.pressure[j] == pytest.approx(tr["isip"][1], abs=0.05 * drop)
    # mass still balances every step
    assert tr["mass_balance_error"].max() < 1e-8
