"""Picks against the lumped simulator's truth over a grid of scenes.

Each scene is simulated with :func:`xlotkit.sim.lumped.simulate_lumped` and picked with
:func:`xlotkit.interpret.picks.core.pick_record` on the simulator's own phase list (so the
picks are tested, not the segmentation; one case also runs :func:`segment`). Where the
closure time reported by the simulator falls inside a cycle's flowback, both flowback methods
must find the FCP within 2 % of the imposed sigma_h (the lumped fracture closes exactly at
sigma_h, so the only error is the curvature the pressure-dependent fluid column adds between
surface and bottom hole); where it falls inside the shut-in, every shut-in method that finds
a value must be within 5 % (the methods read closure from a leak-off model, which is known to
overestimate it in tight rock by a few percent); where the record holds no closure, "not
found".

Grid (14 scenes): sigma_h 25/30/35 MPa; Carter leak-off 0 / 1e-5 / 1e-4 m/s^0.5; wall
permeability 0.1 / 1 mD; rate 250 / 500 / 1000 l/min; well compliance x0.5 / x1 / x2; gauge
noise 0 / 0.1 bar; sample interval 1 / 5 s; penny / KGD; and a flowback that stops above
closure.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

lumped = pytest.importorskip("xlotkit.sim.lumped")
schedule = pytest.importorskip("xlotkit.sim.schedule")

from xlotkit.interpret.phases import Cycle, Phase, Segmentation  # noqa: E402
from xlotkit.interpret.picks.core import SHUTIN_METHOD_NAMES, pick_record  # noqa: E402
from xlotkit.interpret.picks.flowback import FLOWBACK_METHODS  # noqa: E402

SH = 30e6
Pump, ShutIn, Flowback, Schedule = (schedule.Pump, schedule.ShutIn, schedule.Flowback,
                                    schedule.Schedule)


def _program(q=0.5 / 60, sh=SH, surface_end=2e6):
    """The standard two-cycle program at pump rate ``q`` [m^3/s], its pressure ends set
    for a minimum stress ``sh`` [Pa], the last flowback to ``surface_end`` [Pa] at
    surface."""
    return Schedule((
        Pump(q, volume=2.0, name="pump"), ShutIn(duration=180.0, name="shut-in"),
        Flowback(initial_rate=0.3 / 60, pressure_below=sh - 3e6, name="flowback"),
        ShutIn(duration=180.0, name="shut-in"),
        Pump(q, volume=1.5, name="pump"),
        ShutIn(pressure_below=sh - 0.3e6, duration=2400.0, name="shut-in"),
        Flowback(initial_rate=0.3 / 60, pressure_below=surface_end, pressure_at="surface",
                 name="flowback")))


def _no_closure_program(sh=SH):
    """One cycle whose short shut-in and flowback both end above sigma_h."""
    return Schedule((
        Pump(0.5 / 60, volume=2.0, name="pump"), ShutIn(duration=180.0, name="shut-in"),
        Flowback(initial_rate=0.3 / 60, pressure_below=sh + 0.2e6, name="flowback"),
        ShutIn(duration=60.0, name="shut-in")))


def _cases():
    wl = lumped.wall_leak_index
    return {
        "base": {},
        # the program's pressure ends follow sigma_h (a flowback to 27 MPa after a shut-in
        # at ~26 MPa, or to 2 MPa at surface from a well at 1 MPa, would end at once:
        # refused since issue 17; closure at 25 MPa is 1.2 MPa above the mud column)
        "sigma_h_25": dict(sigma_h=25e6, sigma_H=30e6, pore_pressure=15e6,
                           schedule=_program(sh=25e6, surface_end=0.5e6)),
        "sigma_h_35": dict(sigma_h=35e6, sigma_H=40e6),
        "no_leakoff": dict(leakoff_coefficient=0.0),
        "high_leakoff": dict(leakoff_coefficient=1e-4),
        "permeable_wall": dict(wall_leak_index=wl(1e-15, 0.01, 10.0, 0.15)),
        "rate_250": dict(schedule=_program(0.25 / 60)),
        "rate_1000": dict(schedule=_program(1.0 / 60)),
        "small_well": dict(well_compliance=3.35e-8),
        "large_well": dict(well_compliance=1.34e-7),
        "noise": dict(noise=0.1e5),
        "dt_5s": dict(dt=5.0),
        "kgd": dict(geometry="kgd", fracture_height=10.0),
        "no_closure": dict(schedule=_no_closure_program()),
    }


CASES = _cases()


def segmentation_from_truth(record, truth) -> Segmentation:
    """The simulator's phase list as a Segmentation (sample indices on the record)."""
    t = record.t
    by_cycle: dict[int, list[Phase]] = {}
    for ph in truth["phases"]:
        i0 = int(np.searchsorted(t, ph["t_start"] - 1e-6))
        i1 = int(np.searchsorted(t, ph["t_end"] - 1e-6))
        if i1 - i0 < 2:
            continue
        by_cycle.setdefault(ph["cycle"], []).append(
            Phase(ph["kind"], i0, i1, float(t[i0]), float(t[i1 - 1])))
    cycles = []
    for k, phs in sorted(by_cycle.items()):
        cycles.append(Cycle(k, "xlot", tuple(phs), phs[0].t_start, phs[-1].t_end,
                            float(record.pressure[phs[0].i0:phs[-1].i1].max()), 0.0, 0.0))
    return Segmentation(tuple(p for c in cycles for p in c.phases), tuple(cycles), True)


@lru_cache(maxsize=None)
def run(name: str):
    """Simulate and pick one case (cached: several tests share it)."""
    res = lumped.simulate_lumped(lumped.standard_lumped_scene(**CASES[name]))
    assert res.status == "ok", res.message
    rp = pick_record(res.record, segmentation_from_truth(res.record, res.truth))
    return res, rp


def _closure_in(truth, cycle_index: int, kind: str) -> bool | None:
    """Whether a simulated closure falls in the cycle's first phase of ``kind`` (None: no
    such phase)."""
    for ph in truth["phases"]:
        if ph["cycle"] == cycle_index and ph["kind"] == kind:
            return any(ph["t_start"] <= tc <= ph["t_end"] for tc in truth["closure_times"])
    return None


@pytest.mark.parametrize("name", list(CASES))
def test_flowback_fcp_against_imposed_sigma_h(name):
    res, rp = run(name)
    sh = res.truth["sigma_h"]
    checked = 0
    for cp in rp.cycles:
        inside = _closure_in(res.truth, cp.index, "flowback")
        if inside is None or cp.cycle.phase("flowback") is None:
            # (A flowback that ends at once -- already below its end pressure -- has no
            # samples and no phase.)
            continue
        for m in FLOWBACK_METHODS:
            pk = cp.get("FCP", m)
            if inside:
                assert pk.found, f"{name} cycle {cp.index} {m}: {pk.message}"
                assert abs(pk.value / sh - 1) < 0.02, (name, cp.index, m, pk.value)
                checked += 1
            else:
                assert not pk.found, (name, cp.index, m, pk.value)
                assert pk.message
    if name == "no_closure":
        assert all(not cp.fcp.found for cp in rp.cycles)


#: Methods that read closure from the slope break itself: within 1 % of sigma_h, and their
#: interval must contain it.
_BREAK_METHODS = ("tangent", "sqrt_t", "g_function")


def _slope_change_at_closure(record, truth, phase) -> float | None:
    """Relative change of dp/dt across the simulated closure inside ``phase`` (lines over the
    60 s either side), or None when no closure falls in it.

    With some parameters the fracture's compliance and its Carter leak-off vanish together at
    closure in proportions that leave the decline rate almost unchanged: such a closure is in
    the record but no shut-in method can see it.
    """
    tc = [x for x in truth["closure_times"] if phase.t_start + 30 <= x <= phase.t_end - 30]
    if not tc:
        return None
    t, p = record.t, record.pressure
    before = (t >= tc[0] - 60) & (t < tc[0])
    after = (t > tc[0]) & (t <= min(tc[0] + 60, phase.t_end))
    s1 = np.polyfit(t[before], p[before], 1)[0]
    s2 = np.polyfit(t[after], p[after], 1)[0]
    return abs(s2 / s1 - 1.0)


@pytest.mark.parametrize("name", list(CASES))
def test_shutin_fcp_against_imposed_sigma_h(name):
    res, rp = run(name)
    sh = res.truth["sigma_h"]
    for cp in rp.cycles:
        inside = _closure_in(res.truth, cp.index, "shut_in")
        phase = cp.cycle.phase("shut_in")
        if inside is None or phase is None:
            continue
        picks = [cp.get("FCP", m) for m in SHUTIN_METHOD_NAMES]
        found = [pk for pk in picks if pk is not None and pk.found]
        change = _slope_change_at_closure(res.record, res.truth, phase) if inside else None
        if inside and change is not None and change > 0.2:
            assert len(found) >= 3, [(pk.method, pk.message) for pk in picks]
            for pk in found:
                assert abs(pk.value / sh - 1) < 0.05, (name, cp.index, pk.method, pk.value)
                if pk.method in _BREAK_METHODS:
                    assert abs(pk.value / sh - 1) < 0.01, (name, cp.index, pk.method, pk.value)
                    assert pk.low <= sh <= pk.high, (name, cp.index, pk.method, pk.low,
                                                     pk.high)
        elif inside:
            # A closure the decline rate hardly notices (or too close to the end of the
            # shut-in): "not found" is right, a value must still be near sigma_h.
            for pk in found:
                assert abs(pk.value / sh - 1) < 0.05, (name, cp.index, pk.method, pk.value)
        else:
            # The shut-in ends above sigma_h: an open-fracture decline, however curved, is
            # not closure.
            assert not found, [(pk.method, pk.value / sh - 1) for pk in found]
            for pk in picks:
                assert pk.message.startswith("no closure in the record"), (pk.method,
                                                                           pk.message)


def test_noise_moves_flowback_picks_less_than_their_interval():
    _, clean = run("base")
    _, noisy = run("noise")
    for cc, cn in zip(clean.cycles, noisy.cycles):
        for m in FLOWBACK_METHODS:
            pc, pn = cc.get("FCP", m), cn.get("FCP", m)
            assert pc.found == pn.found, (cc.index, m)
            if pc.found:
                # The clean value lies in the interval the noisy pick states for itself.
                assert pn.low <= pc.value <= pn.high, (cc.index, m, pc.value, pn.low, pn.high)
                assert pn.high - pn.low < 0.005 * pc.value


def test_noise_moves_other_picks_less_than_their_interval():
    _, clean = run("base")
    _, noisy = run("noise")
    moved = []
    for cc, cn in zip(clean.cycles, noisy.cycles):
        for pc in cc.picks:
            if pc.method in FLOWBACK_METHODS:
                continue
            pn = cn.get(pc.name, pc.method)
            if pc.found and pn is not None and pn.found and not pn.low <= pc.value <= pn.high:
                moved.append((cc.index, pc.name, pc.method, pc.value, pn.value))
    assert not moved, moved


def test_end_to_end_with_segmentation():
    from xlotkit.interpret.phases import segment

    res, _ = run("base")
    rp = pick_record(res.record, segment(res.record))
    sh = res.truth["sigma_h"]
    first = rp.test_cycles[0]
    for m in FLOWBACK_METHODS:
        pk = first.get("FCP", m)
        assert pk.found and abs(pk.value / sh - 1) < 0.02, (m, pk.message)
    assert abs(first.fcp.value / sh - 1) < 0.02
    # Pressurisation stiffness of the first cycle is the well's (1 / C_w) within 10 %: the
    # fluid density's pressure dependence makes the measured one a few percent lower.
    assert first.stiffness == pytest.approx(1 / res.truth["well_compliance"], rel=0.1)
