"""The kink detector (``picks/kink.py``): closure on coarsely quantised declines that the
local break scan cannot resolve, and no kink on smooth curves.

The records with a closure are calibration records (``draw_spec(default_rng(2024))``,
records 68 and 20) that the break scan missed (issue 19, ``docs/intervals.md``): surface
gauges in whole bar, Carter leak-off, a net pressure of 14-26 bar, the slope rising only
x1.18-1.59 across closure. Their truth is ``sigma_h`` on the surface reference.
"""

import numpy as np
import pytest

from xlotkit.interpret.calibration.records import ConstructedSpec, construct_record
from xlotkit.interpret.picks import shutin
from xlotkit.interpret.picks.kink import KINK_Z, find_kink
from xlotkit.interpret.picks.shutin import SHUTIN_METHODS, g_function, pick_fcp_g_function

BAR = 1e5

WEAK_WHOLE_BAR = {
    # seed 2024, record 68, cycle 1: contrast 1.18, 3 s samples
    "carter_x1.18": (ConstructedSpec(
        depth=1731.867, density=1348.484, sigma_h=340.1694e5, transition=0.0021494,
        p0=217.903e5, lop=401.578e5, fbp=408.521e5, isip=(376.3081e5, 376.1841e5),
        reopening=358.793e5, well_compliance=3.3945e-08, fracture_compliance=1.8759e-08,
        rate=6.10466e-3, t_prop=152.58, g_closure=(1.65940, 3.01635), leak_after=0.79877,
        leakoff="carter", nwb=2.7456e5, pipe_friction=14.578e5, drop_tau=3.589,
        breakdown_tau=8.480, flowback=(False, True), flowback_rate=0.23207e5,
        gauge="surface", noise=0.21918e5, resolution=BAR, dt=3.0, seed=1562717451), 0),
    # seed 2024, record 20, cycle 2: contrast 1.59, 3 s samples, 0.27 bar noise
    "carter_x1.59": (ConstructedSpec(
        depth=2533.376, density=1198.830, sigma_h=412.5343e5, transition=0.0028381,
        p0=237.251e5, lop=473.591e5, fbp=480.872e5, isip=(426.2374e5, 426.1842e5),
        reopening=422.188e5, well_compliance=1.57421e-08, fracture_compliance=2.49041e-08,
        rate=8.86679e-3, t_prop=267.65, g_closure=(1.18691, 6.75976), leak_after=0.62700,
        leakoff="carter", nwb=7.2912e5, pipe_friction=13.196e5, drop_tau=4.447,
        breakdown_tau=15.601, flowback=(False, False), flowback_rate=0.09237e5,
        gauge="surface", noise=0.26855e5, resolution=BAR, dt=3.0, seed=2105003044), 1),
}


def _decline_of(rec, cyc):
    sh, _ = shutin._prepare(rec, cyc, "g_function", None)
    sl = slice(sh.j0, None)
    return sh, g_function(sh.dt[sl], sh.t_pump), sh.p[sl], sh.t[sl]


@pytest.mark.parametrize("name", sorted(WEAK_WHOLE_BAR))
def test_weak_closure_on_a_whole_bar_gauge(name):
    sp, k = WEAK_WHOLE_BAR[name]
    cr = construct_record(sp)
    cyc = cr.segmentation.cycles[k]
    assert cr.truth.closure_in_data[k]
    # The local scan finds no break here (why the kink detector exists) ...
    sh, G, p, t = _decline_of(cr.record, cyc)
    assert shutin._best_break(G, p, t, sh.sigma, confirm=True) is None
    # ... the kink against a smooth cubic does, and the pick's 90 % interval holds the
    # truth (the same interval budget as every break pick).
    pk = pick_fcp_g_function(cr.record, cyc)
    assert pk.found, pk.message
    assert pk.details.closure_signature == "stiffening"
    assert pk.low <= cr.truth.sigma_h <= pk.high, (pk.low / BAR, cr.truth.sigma_h / BAR,
                                                   pk.high / BAR)
    # within the transition plus two quantisation steps of the truth
    assert abs(pk.value - cr.truth.sigma_h) <= sp.transition_width + 2 * BAR


def _staircase(p_clean, noise, seed):
    rng = np.random.default_rng(seed)
    return np.round((p_clean + rng.normal(0.0, noise, p_clean.size)) / BAR) * BAR


@pytest.mark.parametrize("seed", range(3))
def test_find_kink_locates_an_analytic_kink_in_a_staircase(seed):
    # p = 120 bar - 8 bar/G + a mild curvature, the slope 3.4 bar/G steeper after
    # G = 1.5 (x1.5), 800 samples, 0.2 bar noise rounded to whole bar. The kink is found
    # within 0.1 of G (the trial positions are at most 0.6 % of the G range apart, 0.023
    # here, and the staircase moves the best one by a few of them; measured: 0.06 at most
    # over five seeds) and the slopes within their noise (measured: ratio 1.40-1.53).
    G = np.linspace(0.05, 4.0, 800)
    gc = 1.5
    p = 120e5 - 8e5 * G + 0.4e5 * G**2 - 3.4e5 * np.maximum(G - gc, 0.0)
    k = find_kink(G, _staircase(p, 0.2e5, seed), BAR)
    assert k is not None and k.z >= KINK_Z
    assert abs(G[k.i] - gc) < 0.1
    # slopes at the kink: -8 + 0.8 gc = -6.8 bar/G before, x1.5 after
    assert k.s_before == pytest.approx(-6.8e5, rel=0.1)
    assert k.s_after / k.s_before == pytest.approx(1.5, abs=0.12)


@pytest.mark.parametrize("seed", range(4))
def test_no_kink_on_smooth_whole_bar_declines(seed):
    # Smooth declines with no closure, rounded to whole bar: an exponential approach to
    # the reservoir pressure (a wall leak; the quartic fits it as well as any hinge), and
    # a pressure-dependent leak-off hump decaying into a straight Carter line.
    G = np.linspace(0.05, 6.0, 700)
    expo = 80e5 + 40e5 * np.exp(-G / 2.5)
    hump = 120e5 - 5e5 * G - 6e5 * (1.0 - np.exp(-G / 0.6))
    for p in (expo, hump):
        assert find_kink(G, _staircase(p, 0.25e5, seed), BAR) is None


def test_no_closure_in_a_whole_bar_decline_without_one():
    # A calibration record drawn without closure (closure=False: one compliance, the leak
    # falling smoothly with the pressure), surface gauge in whole bar, first cycle: no
    # shut-in method may find a closure.
    sp = ConstructedSpec(
        depth=2534.867, density=1122.476, sigma_h=324.2582e5, transition=0.0070373,
        p0=247.680e5, lop=369.313e5, fbp=373.956e5, isip=(359.9794e5, 359.7593e5),
        reopening=347.461e5, well_compliance=1.15396e-08, fracture_compliance=9.08499e-09,
        rate=5.44997e-3, t_prop=185.69, g_closure=(1.57687, 8.01218), leak_after=0.95647,
        leakoff="wall_leak", leak_parameter=0.455348, nwb=2.3200e5, pipe_friction=7.531e5,
        drop_tau=3.218, breakdown_tau=11.835, flowback=(False, False),
        flowback_rate=0.29071e5, gauge="surface", noise=0.36655e5, resolution=BAR, dt=3.0,
        seed=1604231913, closure=False)
    cr = construct_record(sp)
    for name, f in SHUTIN_METHODS.items():
        pk = f(cr.record, cr.segmentation.cycles[0])
        assert not pk.found, (name, pk.value / BAR)
