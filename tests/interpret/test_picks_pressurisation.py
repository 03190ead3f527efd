"""Pressurisation picks (LOP, FBP, Pr, FPP) and ISIP on analytic synthetic records.

The pressurisation curve is a storage line ``p = p0 + K V`` with a soft toe (air, line filling),
a parabolic bend away from the line at a known LOP, a peak (FBP), and a decay to a plateau (FPP).
"""

import numpy as np
import pytest

from xlotkit.interpret.phases import Cycle, Phase
from xlotkit.interpret.picks.pressurisation import (
    pick_fbp,
    pick_fpp,
    pick_isip,
    pick_lop,
    pick_reopening,
)
from xlotkit.record import Record

BAR = 1e5
RATE = 50e-3 / 60.0          # 50 l/min [m^3/s]
K = 0.44 * BAR / 1e-3        # system stiffness [Pa/m^3]
LOP = 150 * BAR
FPP = 155 * BAR


def pressurisation(*, dt=1.0, noise=0.0, quant=0.0, seed=0, bend=0.05, t_pump=900.0):
    """Record and cycle of one pumping phase with a known LOP, FBP and FPP."""
    t = np.arange(0.0, t_pump + 1e-9, dt)
    v = RATE * t
    toe = 0.02
    ve = toe * np.log1p(np.exp((v - toe) / toe * 3)) / 3
    p = 2 * BAR + K * ve
    v_lop = np.interp(LOP, p, v)
    x = np.clip(v - v_lop, 0, None)
    p = np.where(v < v_lop, p, LOP + K * (x - x**2 / (2 * bend)))
    peak = LOP + K * bend / 2
    past = v >= v_lop + bend
    t_peak = t[np.argmax(past)] if past.any() else np.inf
    p = np.where(t > t_peak, FPP + (peak - FPP) * np.exp(-(t - t_peak) / 30.0), p)
    p = p + np.random.default_rng(seed).normal(0, noise, p.size)
    if quant:
        p = np.round(p / quant) * quant
    rec = Record(t=t, pressure=p, rate=np.full(t.size, RATE))
    ph = Phase("pump", 0, t.size, t[0], t[-1])
    cyc = Cycle(1, "xlot", (ph,), t[0], t[-1], p.max(), v[-1], 0.0)
    return rec, cyc, peak


def shutin_record(*, quant=0.0, noise=0.0, seed=0, friction=15 * BAR, isip=160 * BAR):
    """Pumping then a shut-in with a 2 s friction transient and a smooth decline."""
    t = np.arange(0.0, 1500.0, 1.0)
    tp = 600.0
    dt = np.clip(t - tp, 0, None)
    p = np.where(t < tp, 2 * BAR + (isip + friction - 2 * BAR) * np.minimum(1, t / 200),
                 isip - 0.05 * BAR * dt + 1e-5 * BAR * dt**2
                 + friction * np.exp(-dt / 2.0))
    p = p + np.random.default_rng(seed).normal(0, noise, p.size)
    if quant:
        p = np.round(p / quant) * quant
    n1 = int(np.sum(t < tp))
    rec = Record(t=t, pressure=p, rate=np.where(t < tp, RATE, 0.0))
    cyc = Cycle(1, "xlot", (Phase("pump", 0, n1, t[0], t[n1 - 1]),
                            Phase("shut_in", n1, t.size, t[n1], t[-1])),
                t[0], t[-1], p.max(), RATE * tp, 0.0)
    return rec, cyc


@pytest.mark.parametrize("kw", [dict(noise=0.02 * BAR), dict(noise=0.1 * BAR, quant=BAR),
                                dict(noise=0.05 * BAR, dt=3.0)])
def test_lop_and_stiffness(kw):
    rec, cyc, _ = pressurisation(**kw)
    pk = pick_lop(rec, cyc)
    assert pk.found and pk.name == "LOP"
    assert abs(pk.value - LOP) < 1.5 * BAR
    assert pk.low <= pk.value <= pk.high
    assert pk.details.stiffness == pytest.approx(K, rel=0.01)
    assert pk.details.stiffness_stderr < 0.01 * K
    # The toe (first ~30 l) is left out of the straight stretch.
    assert pk.window[0] > 20.0


def test_lop_noise_moves_pick_less_than_its_interval():
    a = pick_lop(*pressurisation(noise=0.02 * BAR)[:2])
    b = pick_lop(*pressurisation(noise=0.1 * BAR, seed=5)[:2])
    assert abs(a.value - b.value) < max(a.high - a.low, b.high - b.low)


def test_lop_user_window_and_reopening_name():
    rec, cyc, _ = pressurisation(noise=0.02 * BAR)
    pk = pick_lop(rec, cyc, window=(60.0, 300.0))
    assert abs(pk.value - LOP) < 1.5 * BAR and pk.window[0] >= 60.0
    pr = pick_reopening(rec, cyc)
    assert pr.name == "Pr" and abs(pr.value - LOP) < 1.5 * BAR


def test_lop_without_rate_uses_time():
    rec, cyc, _ = pressurisation(noise=0.02 * BAR)
    pk = pick_lop(rec.replace(rate=None), cyc)
    assert pk.found and pk.details.stiffness is None
    assert pk.details.pressurisation_rate == pytest.approx(K * RATE, rel=0.01)


@pytest.mark.parametrize("quant", [0.0, BAR])
def test_fbp_and_fpp(quant):
    rec, cyc, peak = pressurisation(noise=0.05 * BAR, quant=quant)
    fbp = pick_fbp(rec, cyc)
    assert fbp.method == "max" and abs(fbp.value - peak) < 0.6 * BAR
    fpp = pick_fpp(rec, cyc)
    assert abs(fpp.value - FPP) < 0.3 * BAR
    assert fpp.low <= FPP + 0.3 * BAR and fpp.high >= FPP - 0.3 * BAR
    assert fpp.window[0] > fbp.t


def test_fbp_not_found_without_breakdown():
    rec, cyc, _ = pressurisation(noise=0.02 * BAR, t_pump=440.0)   # stopped before the peak
    assert not pick_fbp(rec, cyc).found
    assert not pick_fpp(rec, cyc).found


@pytest.mark.parametrize("kw", [dict(noise=0.02 * BAR), dict(noise=0.1 * BAR, quant=BAR)])
def test_isip_excludes_friction_drop(kw):
    rec, cyc = shutin_record(**kw)
    pk = pick_isip(rec, cyc)
    assert pk.found
    assert abs(pk.value - 160 * BAR) < 0.5 * BAR
    assert pk.low - 0.2 * BAR <= 160 * BAR <= pk.high + 0.2 * BAR
    assert pk.details.friction_drop == pytest.approx(15 * BAR, abs=1 * BAR)
    assert pk.window[0] > 600.0


def test_isip_not_found_without_shutin():
    rec, cyc, _ = pressurisation()
    assert not pick_isip(rec, cyc).found
