"""Picks that hold on every kind of test (issue 16), on records built by construction.

* FBP is the breakdown event -- the peak before the pressure falls at an unchanged rate --
  not the highest pumping pressure (a higher rate raises it by friction alone).
* The ISIP comes from the pump-off drop of the injection, for every cycle kind that has a
  pump stop followed by a shut-in (and not from a later top-up).
* A closure candidate at a phase boundary (a valve opened for the flowback) or inside the
  pump-off drop is rejected, with that reason; a closure well inside the shut-in is kept.
* A user window overrides the phase boundaries it crosses.

Every record is written down in closed form here, so the truth each test compares against
is the construction, not anything the picks computed.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from phase_fixtures import dfit_arrays, to_record

from xlotkit.interpret.phases import Cycle, Phase, Segmentation
from xlotkit.interpret.picks.core import PickOptions, pick_cycle, pick_record
from xlotkit.interpret.picks.details import (
    BreakdownDetails,
    IsipDetails,
    RejectedDetails,
    ShutinDetails,
)
from xlotkit.interpret.picks.pressurisation import pick_fbp, pick_isip
from xlotkit.interpret.picks.shutin import SHUTIN_METHODS, g_function, pick_fcp_sqrt_t
from xlotkit.record import Record

BAR = 1e5
BPM = 0.158987294928 / 60.0  # oil barrel per minute -> m^3/s


def _phase(kind, t, i0, i1, **kw):
    return Phase(kind, i0, i1, float(t[i0]), float(t[i1 - 1]), **kw)


def _cycle(kind, phases, p):
    return Cycle(1, kind, tuple(phases), phases[0].t_start, phases[-1].t_end, float(p.max()),
                 sum(ph.pumped_m3 for ph in phases), 0.0)


# =========================================================================== FBP
def _two_rate_record(*, rate=True, cut=False, seed=3):
    """Pump at 2.9 bpm to a 300 bar peak, the formation breaks down (the pressure falls 80
    bar at the same rate), then 9.8 bpm lifts the pumping pressure to 350 bar by friction;
    pump stop and a shut-in. With ``cut`` the 2.9 bpm stage ends with the rate cut to 1 bpm
    at the peak (the pressure falls 40 bar by friction, no breakdown)."""
    t = np.arange(0.0, 700.0, 1.0)
    q1, q2 = 2.9 * BPM, 9.8 * BPM
    p = np.empty(t.size)
    q = np.zeros(t.size)
    rise = t <= 200
    p[rise] = 20 * BAR + 280 * BAR * t[rise] / 200.0
    q[t < 430] = q1
    a = (t > 200) & (t < 320)
    if cut:
        q[(t > 200) & (t < 320)] = 1.0 * BPM
        p[a] = 260 * BAR + 40 * BAR * np.exp(-(t[a] - 200) / 5.0)
    else:
        p[a] = 220 * BAR + 80 * BAR * np.exp(-(t[a] - 200) / 8.0)
    b = (t >= 320) & (t < 430)
    q[b] = q2
    p[b] = (260 if cut else 220) * BAR + 130 * BAR * (1 - np.exp(-(t[b] - 320) / 4.0))
    s = t >= 430
    p[s] = 230 * BAR - 0.01 * BAR * (t[s] - 430)
    p = p + np.random.default_rng(seed).normal(0.0, 0.2 * BAR, t.size)
    rec = Record(t=t, pressure=p, rate=q if rate else None)
    n1 = int(np.searchsorted(t, 430.0))
    vol = float(np.sum(q[:n1]))
    cyc = _cycle("xlot", [_phase("pump", t, 0, n1, pumped_m3=vol),
                          _phase("shut_in", t, n1, t.size)], p)
    return rec, cyc


def test_fbp_is_the_breakdown_not_the_highest_pumping_pressure():
    rec, cyc = _two_rate_record()
    pk = pick_fbp(rec, cyc)
    # the breakdown peak is 300 bar (construction); 0.2 bar noise and a 3-sample median
    assert pk.found and abs(pk.value - 300 * BAR) < 1.5 * BAR, pk.message
    assert pk.low <= 300 * BAR <= pk.high + 0.5 * BAR
    assert abs(pk.t - 200.0) <= 3.0
    d = pk.details
    assert isinstance(d, BreakdownDetails)
    assert d.highest_pumping_pressure > 345 * BAR          # the 9.8 bpm friction plateau
    assert d.drop_after_peak > 70 * BAR
    assert "not a breakdown" in pk.message


def test_a_fall_from_a_rate_cut_is_no_breakdown():
    rec, cyc = _two_rate_record(cut=True)
    pk = pick_fbp(rec, cyc)
    assert not pk.found
    assert "rate" in pk.message and "cut" in pk.message


def test_fbp_without_a_rate_log_takes_the_largest_fall_while_pumping():
    rec, cyc = _two_rate_record(rate=False)
    pk = pick_fbp(rec, cyc)
    assert pk.found and abs(pk.value - 300 * BAR) < 1.5 * BAR
    assert "no rate logged" in pk.message and pk.quality != "good"


# =========================================================================== ISIP
ISIP_TRUE = 188 * BAR


def _stop_and_decline(pump_parts, *, t_shut=600.0, dt=1.0, seed=5, top_up=False):
    """Pump phases (duration [s], rate [m^3/s]) ending at 200 bar; at pump stop 12 bar of
    friction vanish at once and a 2 s water hammer decays; the shut-in then falls linearly at
    0.01 bar/s from the ISIP, 188 bar. With ``top_up`` a 20 s top-up and a flowback follow
    the shut-in (the top-up's stop is not the one the ISIP belongs to)."""
    t_end = sum(d for d, _ in pump_parts)
    t = np.arange(0.0, t_end + t_shut + (80.0 if top_up else 0.0), dt)
    p = np.empty(t.size)
    q = np.zeros(t.size)
    t0 = 0.0
    for k, (d, rate) in enumerate(pump_parts):
        sel = (t >= t0) & (t < t0 + d)
        q[sel] = rate
        # a step-rate test climbs a friction staircase; it ends at 200 bar
        p[sel] = 200 * BAR - 8 * BAR * (len(pump_parts) - 1 - k) - 30 * BAR * np.exp(
            -(t[sel] - t0) / 10.0)
        t0 += d
    s = (t >= t_end) & (t < t_end + t_shut)
    ds = t[s] - t_end
    p[s] = ISIP_TRUE - 0.01 * BAR * ds + 6 * BAR * np.exp(-ds / 2.0) * np.cos(ds)
    if top_up:
        u = (t >= t_end + t_shut) & (t < t_end + t_shut + 20)
        q[u] = pump_parts[-1][1]
        p[u] = p[s][-1] + 5 * BAR * (t[u] - t[u][0]) / 20.0
        f = t >= t_end + t_shut + 20
        p[f] = p[u][-1] - 1.0 * BAR * (t[f] - t[f][0])
    p = p + np.random.default_rng(seed).normal(0.0, 0.05 * BAR, t.size)
    rec = Record(t=t, pressure=p, rate=q)
    n1 = int(np.searchsorted(t, t_end))
    n2 = int(np.searchsorted(t, t_end + t_shut))
    phases = [_phase("pump", t, 0, n1, pumped_m3=float(np.sum(q[:n1]))),
              _phase("shut_in", t, n1, n2)]
    if top_up:
        n3 = int(np.searchsorted(t, t_end + t_shut + 20))
        phases += [_phase("pump", t, n2, n3, pumped_m3=float(np.sum(q[n2:n3]))),
                   _phase("flowback", t, n3, t.size)]
    return rec, phases, p


@pytest.mark.parametrize("kind, parts, top_up", [
    ("xlot", [(300.0, 0.01)], False),
    ("lot", [(300.0, 0.01)], False),
    ("dfit", [(520.0, 0.01)], False),
    ("step_rate", [(120.0, 0.002), (120.0, 0.004), (120.0, 0.008), (120.0, 0.012)], False),
    ("stimulation", [(200.0, 0.01)], True),
    ("line_test", [(60.0, 0.001)], False),
    ("casing_test", [(300.0, 0.002)], False),
    ("some_new_kind", [(300.0, 0.01)], False),
])
def test_isip_for_every_kind_with_a_pump_stop_and_a_shutin(kind, parts, top_up):
    rec, phases, p = _stop_and_decline(parts, top_up=top_up)
    cp = pick_cycle(rec, _cycle(kind, phases, p))
    isip = cp.get("ISIP")
    assert isip is not None and isip.found, (kind, isip.message if isip else "not run")
    # the decline is linear in time from 188 bar; 0.05 bar noise, quantisation none: the
    # tangent's intercept is within a few noise levels of it
    assert abs(isip.value - ISIP_TRUE) < 0.25 * BAR, (kind, isip.value / BAR)
    assert isip.low - 0.05 * BAR <= ISIP_TRUE <= isip.high + 0.05 * BAR
    assert isinstance(isip.details, IsipDetails)
    assert isip.details.friction_drop == pytest.approx(12 * BAR, abs=1.0 * BAR)
    # the stop it belongs to is the injection's, not the top-up's
    assert isip.details.pump_window[1] < phases[1].t_start


def test_isip_says_why_when_the_pumps_stop_into_a_flowback():
    rec, phases, p = _stop_and_decline([(300.0, 0.01)])
    ph = [phases[0], Phase("flowback", phases[1].i0, phases[1].i1, phases[1].t_start,
                           phases[1].t_end)]
    pk = pick_isip(rec, _cycle("xlot", ph, p))
    assert not pk.found and "no shut-in after pumping" in pk.message
    assert "flowback" in pk.message


# =========================================================================== boundaries
T_PUMP = 600.0


def _shutin_then_valve(*, gc=None, valve="step", dt=3.0, t_shut=2400.0, seed=11,
                       noise=0.01 * BAR):
    """Pump 600 s, a shut-in declining linearly in G from 160 bar (closure at G = ``gc``
    with the slope x4 after it, or none), then the valve is opened for a flowback 30 s
    before the flowback phase starts (where the segmentation puts the boundary):
    ``"step"`` a 2 bar drop with a water hammer, ``"steepen"`` the decline 8 times faster
    over those 30 s, with no jump. Returns record, cycle, t of the valve opening, boundary.
    """
    t_pre = np.arange(0.0, T_PUMP, dt)
    t_b = T_PUMP + t_shut                       # flowback phase starts here
    t_v = t_b - 30.0                            # the valve opens here
    t_post = np.arange(T_PUMP, t_b + 300.0, dt)
    d = t_post - T_PUMP
    G = g_function(d, T_PUMP)
    m = 4.0 * BAR                               # dP/dG before closure
    p = 160 * BAR - m * G
    if gc is not None:
        p = np.where(G < gc, p, 160 * BAR - m * gc - 4.0 * m * (G - gc))
    p = p + 10 * BAR * np.exp(-d / 3.0)        # the pump-off drop
    v = t_post >= t_v
    pv = float(np.interp(t_v, t_post, p))
    if valve == "step":
        hammer = 0.8 * BAR * np.cos(2 * np.pi * (t_post - t_v) / 12.0) * np.exp(
            -(t_post - t_v) / 40.0)
        p[v] = pv - 2 * BAR - 0.05 * BAR * (t_post[v] - t_v) + hammer[v]
    else:
        slope = 8.0 * float(np.interp(t_v, t_post[1:], np.diff(p) / dt))
        p[v] = pv + slope * (t_post[v] - t_v)
    f = t_post >= t_b
    p[f] = float(np.interp(t_b, t_post, p)) - 0.3 * BAR * (t_post[f] - t_b)
    t = np.concatenate([t_pre, t_post])
    p = np.concatenate([20 * BAR + 150 * BAR * t_pre / T_PUMP, p])
    p = p + np.random.default_rng(seed).normal(0.0, noise, p.size)
    rec = Record(t=t, pressure=p, rate=np.where(t < T_PUMP, 0.01, 0.0),
                 return_rate=np.where(t >= t_b, 0.005, 0.0))
    n1 = t_pre.size
    n2 = int(np.searchsorted(t, t_b))
    cyc = _cycle("xlot", [_phase("pump", t, 0, n1, pumped_m3=6.0),
                          _phase("shut_in", t, n1, n2), _phase("flowback", t, n2, t.size)], p)
    return rec, cyc, t_v, t_b


@pytest.mark.parametrize("valve", ["step", "steepen"])
def test_a_break_at_the_valve_opening_is_rejected_with_the_reason(valve):
    rec, cyc, t_v, t_b = _shutin_then_valve(valve=valve)
    for name, f in SHUTIN_METHODS.items():
        pk = f(rec, cyc)
        # the decline has no closure: the only break is where the valve opens
        assert not pk.found, (name, valve, pk.value / BAR, pk.t)
        d = pk.details
        assert isinstance(d, ShutinDetails), name
        assert d.boundary is not None and d.boundary.next_phase == "flowback"
        assert d.boundary.t_boundary == pytest.approx(t_b)
        rej = [r for r in d.rejected if r.where == "phase boundary"]
        assert rej, (name, valve, pk.message)
        assert all(t_v - 60.0 <= r.t <= t_b for r in rej), [r.t for r in rej]
        assert "phase boundary" in pk.message and "rejected" in pk.message
    if valve == "step":
        # the valve's own onset is the zone, found from the pressure step (3 s sampling)
        zone = pick_fcp_sqrt_t(rec, cyc).details.boundary
        assert zone.onset == "pressure step" and abs(zone.t_start - t_v) <= 6.0


def test_a_closure_well_inside_the_shutin_is_kept_before_the_valve_zone():
    rec, cyc, _, _ = _shutin_then_valve(gc=1.2)
    pc = 160 * BAR - 4.0 * BAR * 1.2          # construction: closure pressure
    t_c = T_PUMP + float(np.interp(1.2, g_function(np.arange(0, 3000.0), T_PUMP),
                                   np.arange(0, 3000.0)))
    for name in ("tangent", "sqrt_t", "g_function"):
        pk = SHUTIN_METHODS[name](rec, cyc)
        assert pk.found, (name, pk.message)
        # 0.01 bar noise, a kink: the breakpoint is within 0.3 bar of the construction
        assert abs(pk.value - pc) < 0.3 * BAR, (name, pk.value / BAR, pc / BAR)
        assert abs(pk.t - t_c) < 60.0 and pk.t < pk.details.boundary.t_start


def test_reconcile_does_not_prefer_a_boundary_break_over_the_flowback():
    # the same record, now picked as a whole: no shut-in pick survives at the boundary, so
    # nothing there can reject a flowback pick
    rec, cyc, _, _ = _shutin_then_valve(valve="step")
    cp = pick_cycle(rec, cyc)
    for p in cp.picks:
        assert not isinstance(p.details, RejectedDetails), (p.method, p.message)
    assert not any(p.found for m, p in cp.fcp_methods().items() if not m.startswith("flow"))


def test_a_break_inside_the_pump_off_drop_is_rejected():
    # A closure above the ISIP lies inside the pump-off drop (the friction and water hammer
    # vanishing), whatever its slope break: with the ISIP at 1 bar below the constructed
    # closure, the slope-break methods' candidate (found at the closure without it) is in
    # the drop.
    rec, cyc, _, _ = _shutin_then_valve(gc=1.2)
    pc = 160 * BAR - 4.0 * BAR * 1.2
    for name in ("tangent", "sqrt_t", "g_function"):
        pk = SHUTIN_METHODS[name](rec, cyc, isip=pc - 1 * BAR)
        assert not pk.found, (name, pk.value / BAR)
        assert "inside the pump-off drop" in pk.message, (name, pk.message)


# =========================================================================== --window
def _dfit(shut_end_s: float, after_kind: str):
    """The constructed DFIT (closure 220 bar at 900 s after shut-in) with its shut-in phase
    ending at ``shut_end_s`` and the rest of the falloff labelled ``after_kind`` -- "idle"
    after the cycle (as the segmentation of issue 16 labelled it) or "bleed" inside it."""
    t, p, q, truth = dfit_arrays()
    rec = to_record(t, p, q)
    i0, i1 = truth["pump"]
    k = int(np.searchsorted(t, shut_end_s)) + 1
    pump = _phase("pump", t, i0, i1, pumped_m3=float(np.sum(q[i0:i1])) / 60000.0)
    shut = _phase("shut_in", t, i1, k)
    rest = _phase(after_kind, t, k, t.size)
    pre = _phase("idle", t, 0, i0)
    members = (pump, shut) if after_kind == "idle" else (pump, shut, rest)
    cyc = Cycle(1, "dfit", members, pump.t_start, members[-1].t_end, float(rec.pressure.max()),
                pump.pumped_m3, 0.0)
    seg = Segmentation((pre, pump, shut, rest), (cyc,), True)
    return rec, seg, truth, t[i1] - 0.5


def test_isip_window_crosses_the_end_of_the_shutin():
    rec, seg, _, _ = _dfit(5149.0, "idle")
    rp = pick_record(rec, seg, options=PickOptions(windows={"ISIP": (600.0, 5900.0)}))
    isip = rp.cycles[0].get("ISIP")
    assert isip.found
    # the early-decline window reaches past the shut-in's end at 5149 s into the idle label
    assert isip.window[0] >= 600.0 and isip.window[1] > 5800.0
    assert isip.details.data_window[1] > 5900.0
    assert "overrides the end of the shut-in" in isip.message


def test_closure_window_across_a_mislabelled_boundary():
    # the falloff labelled "bleed" from 1200 s on: closure (t = 1421 s) is past the label
    rec, seg, truth, t_s = _dfit(1200.0, "bleed")
    auto = pick_record(rec, seg).cycles[0].get("FCP", "sqrt_t")
    assert not auto.found
    win = (560.0, 1300.0)                       # the straight sqrt(t) stretch, across 1200 s
    rp = pick_record(rec, seg, options=PickOptions(windows={"sqrt_t": win}))
    pk = rp.cycles[0].get("FCP", "sqrt_t")
    assert pk.found, pk.message
    # construction: closure at 220 bar, 900 s after shut-in; 0.2 bar noise, 1 s sampling
    assert abs(pk.value - truth["closure_bar"] * BAR) < 2.0 * BAR, pk.value / BAR
    assert abs(pk.t - (t_s + 900.0)) < 60.0
    assert pk.details.data_window[1] > 5000.0
    assert "overrides the end of the shut-in" in pk.message


def test_a_user_window_overrides_the_pump_off_drop_rejection():
    # issue 16 audit D7: the same candidate from a user window is kept -- the user chose the
    # window -- at quality poor, with the automatic rejection's reason as a warning
    rec, cyc, _, _ = _shutin_then_valve(gc=1.2)
    pc = 160 * BAR - 4.0 * BAR * 1.2
    d = np.arange(1.0, 2400.0)
    d_c = float(d[np.searchsorted(g_function(d, T_PUMP), 1.2)])  # closure [s after stop]
    win = (T_PUMP + 60.0, T_PUMP + 0.7 * d_c)  # the straight stretch before closure
    for name in ("sqrt_t", "g_function", "tangent"):
        pk = SHUTIN_METHODS[name](rec, cyc, window=win, isip=pc - 1 * BAR)
        assert pk.found, (name, pk.message)
        assert pk.quality == "poor"
        assert "warning: inside the pump-off drop" in pk.message, (name, pk.message)
        # the override adds the warning, nothing else: the same window with an ISIP that
        # rejects nothing gives the same pick
        free = SHUTIN_METHODS[name](rec, cyc, window=win)
        assert free.found and "warning" not in free.message, (name, free.message)
        assert pk.value == pytest.approx(free.value, rel=1e-12), name


def test_cli_window_across_a_phase_boundary(tmp_path):
    # issue 16 audit D7: `xlotkit pick --window` across the shut-in -> flowback boundary of
    # the constructed two-cycle XLOT (flowback phase from t = 1200 s): the decline is taken
    # on past the boundary, and the pick says so
    from click.testing import CliRunner
    from phase_fixtures import write_csv
    from test_phases import two_cycle_xlot

    from xlotkit.cli import main

    b = two_cycle_xlot()
    p = np.asarray(b.p) + np.random.default_rng(0).normal(0.0, 0.2, len(b.p))
    path = tmp_path / "xlot.csv"
    write_csv(path, np.arange(p.size, dtype=float), p, np.asarray(b.q), np.asarray(b.r))

    def sqrt_t(*args):
        r = CliRunner().invoke(main, ["pick", str(path), "--json", *args])
        assert r.exit_code == 0, r.output
        cyc = json.loads(r.stdout)["cycles"][0]
        (pk,) = [x for x in cyc["picks"] if x["method"] == "sqrt_t"]
        return pk

    auto = sqrt_t()
    user = sqrt_t("--window", "1:sqrt_t=700:1300")
    assert "overrides the end of the shut-in at t = 1199 s" in user["message"]
    assert "overrides" not in auto["message"]
    # the user's straight stretch decides the pick: found, and not the automatic one
    assert user["value_bar"] is not None and user["value_bar"] != auto["value_bar"]
    r = CliRunner().invoke(main, ["pick", str(path), "--window", "1:sqrt_t=700:1300"])
    assert r.exit_code == 0 and "Traceback" not in r.output


def test_a_test_hours_after_another_is_a_new_test_with_its_own_breakdown():
    # issue 16 audit D3: on the AMS-01 XLOT 1 gauge (left in the hole) a pressure test six
    # hours before the XLOT was the "first test cycle": its FBP and the XLOT's Pr gave
    # T0 = -57 bar. A test cycle after the well stood idle longer than the test before it
    # lasted opens a new test
    from xlotkit.interpret.picks.core import separate_tests

    def cyc(i, kind, t0, t1):
        return Cycle(i, kind, (), t0, t1, 1e7, 1.0, 0.0)

    cycles = [cyc(1, "dfit", 0.0, 1000.0),          # a 1000 s test
              cyc(2, "line_test", 1500.0, 1600.0),  # not a test cycle
              cyc(3, "xlot", 21000.0, 23000.0),     # 20000 s idle > 1000 s: a new test
              cyc(4, "xlot", 23300.0, 24000.0),     # 300 s later: its reopening
              cyc(5, "xlot", 25000.0, 26000.0)]     # 1000 s < 3000 s of the test so far
    assert separate_tests(cycles) == [[0], [2, 3, 4]]
    # a test's own reopening cycles stay in it however long the shut-ins between
    assert separate_tests([cyc(1, "xlot", 0.0, 600.0), cyc(2, "xlot", 1100.0, 2000.0)]) \
        == [[0, 1]]
