"""The synthetic XLOT library in data/synthetic (issue 7).

Fast: every stored log is read and picked as a field log and checked against the realised
stresses of its scene with issue 7's tolerances (:func:`xlotkit.library.evaluate`); the
library spans what the issue asks for; the stored truths hold what the README promises; the
tables in docs/synthetic-library.md and data/synthetic/README.md are the ones the stored
files give. Slow: every scene is simulated again and its log compared with the stored one.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from xlotkit.library import (
    FLOWBACK_RTOL,
    SHUTIN_RTOL,
    compare,
    entries,
    evaluate,
    evaluation_markdown,
    methods_markdown,
    scenes_markdown,
)
from xlotkit.sim.coupling.engine import total_well_compliance
from xlotkit.sim.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
ROOT = REPO / "data" / "synthetic"
NAMES = [e.name for e in entries(ROOT)]


@pytest.fixture(scope="module")
def evals():
    return {e.name: evaluate(e) for e in entries(ROOT)}


@pytest.fixture(scope="module")
def scenes():
    return {e.name: load_scene(e.scene_file) for e in entries(ROOT)}


# ----------------------------------------------------------------------------- picks
#: What the library's rules report, pinned (measured on the stored logs;
#: docs/synthetic-library.md, "The hard scenes", says why each happens): scenes issue 17
#: added for what the picks find hard; 09, a DFIT-like first cycle followed by a second
#: one; and 03, the high anisotropy, where the free path's lower flowback picks pass 3 %.
#: A miss that goes away, or a new one, fails the test until the docs say why.
#: Every other scene passes every rule.
KNOWN_FAILURES: dict[str, tuple[str, ...]] = {
    # the flowback of the high-anisotropy scene reads -3.52 / -3.39 % (measured on issue
    # 20's regeneration; -3.47 / -3.34 % with alpha = 0 in the intact rock, issue 17;
    # -2.9 % before): the free
    # path's closed crack stays soft below its mean normal stress, and sigma_H / sigma_h
    # = 1.5 raises the near-wall normal stress on the crack the flowback closes first
    "03_anisotropy_high": ("cycle 1: flowback_sqrt_p -", "cycle 1: flowback_p_v -"),
    # the second shut-in's closure is within 5 % (+0.32 %, issue 20's regeneration; +1.02 %
    # before), but its G-function reads "undetermined" while the crack grew 7.6 -> 8.9 m
    # open (tip extension)
    "09_perm_1e-16_shutin": ("cycle 2: g_function kept a closure",),
    # (20_pressure_dependent_leakoff passes every rule since issue 20's regeneration: its
    # first shut-in's break reads +4.17 to +4.18 % (tangent, sqrt t, G; compliance +4.35 %),
    # within 5 %, and the G-function diagnoses tip extension while the crack grew 2.8 ->
    # 4.7 m; before it, the break read +8.4 to +8.8 % at the near-wall stress with the
    # crack 2.8 -> 4.0 m, diagnosed "height recession", and six misses were pinned here.
    # The second cycle's flowback break at -9.2 % starts on the closed system's stiffness
    # and is rejected for the shut-in's right closure: test below.)
    # the surface log with pipe friction: its first cycle, read as an XLOT since the p-V
    # gain is counted net of the pump-start friction step (and a linear loading broken at
    # its peak departs there), gives flowback closures of -3.51 / -3.53 % (issue 20's
    # regeneration; -3.60 / -3.68 % before): the free path's -2.45 % of its friction-free
    # twin (16) plus the choke return's friction (~1 %)
    "17_surface_gauge_friction": ("cycle 1: flowback_sqrt_p -", "cycle 1: flowback_p_v -"),
    # the LOT: the crack takes a few litres at pump stop, the p-V line shows no departure,
    # so the interpreter reads the record as an "other" cycle (no test cycle, no LOP)
    "24_lot_before_breakdown": ("no test cycle found in the log", "no LOP picked in a LOT"),
}


#: XLOT scenes whose first cycle the interpreter does not read as a test cycle (pinned;
#: 17, the surface log with pipe friction, left it when the p-V gain was counted net of
#: the pump-start friction step)
MISSED_CYCLES: set[str] = set()


@pytest.mark.parametrize("name", NAMES)
def test_picks_against_the_realised_stresses(evals, name):
    ev = evals[name]
    got = list(ev.failures) + [f for c in ev.cycles for f in c.failures]
    want = KNOWN_FAILURES.get(name, ())
    assert len(got) == len(want) and all(any(g.startswith(w) for g in got) for w in want), got
    if ev.scene_kind == "xlot":
        # a scene in MISSED_CYCLES has only its second cycle judged
        want_cycles = 1 if name in MISSED_CYCLES else 2
        assert len(ev.cycles) == want_cycles, "every XLOT scene is a two-cycle test"
    for c in ev.cycles:
        if c.failures:
            continue
        if c.flowback_closure:
            # issue 7: the system-stiffness picks within 3 % of the realised sigma_h
            for m in ("flowback_sqrt_p", "flowback_p_v"):
                assert abs(c.errors[m]) <= FLOWBACK_RTOL, (c.cycle, m, c.errors)
        if c.closure_in_shutin is True:
            # issue 7: every shut-in method that picks, within 5 %
            for m in ("tangent", "sqrt_t", "g_function", "bilinear", "compliance"):
                if m in c.errors:
                    assert abs(c.errors[m]) <= SHUTIN_RTOL, (c.cycle, m, c.errors)
        if c.closure_in_shutin is False:
            # "no closure": no shut-in method picked one
            assert not {"tangent", "sqrt_t", "g_function", "bilinear",
                        "compliance"} & set(c.errors), (c.cycle, c.errors)


#: (scene, cycle) where the interpreter rejected shut-in closure picks because the flowback
#: after them found the crack still open below them, and where it rejected flowback picks
#: because the shut-in before had closed the crack with stronger evidence (measured on the
#: stored logs; docs/synthetic-library.md, "Closure picks the interpreter rejects").
#: Since issue 20's regeneration the shut-ins of 06 · 1, 12 · 2, 19 · 1, 21 · 1 and 22 · 1
#: pick no break at all (before it their breaks were picked and rejected here); the two left
#: start their flowbacks at 0.15 (01 · 1) and 0.23 (21 · 2) of the closed system's stiffness.
REJECTED_SHUTIN = {("01_standard", 1), ("21_shear_dilation", 2)}
#: the flowbacks of 09 and 20's second cycles start at 2.7 and 1.4 times the pressurisation
#: stiffness (no fracture compliance left): their breaks (-4.7 %, -9.2 %; issue 20's
#: regeneration) are rejected
REJECTED_FLOWBACK = {("09_perm_1e-16_shutin", 2), ("20_pressure_dependent_leakoff", 2)}
#: rejections that go the wrong way (pinned as misses in KNOWN_FAILURES): none since the
#: flowback's open side is judged against the closed system's stiffness (issue 17)
WRONG_REJECTIONS: set[tuple[str, int]] = set()
FLOWBACK = ("flowback_sqrt_p", "flowback_p_v")


def test_shutin_breaks_contradicted_by_the_flowback_are_rejected(evals):
    """A cycle's shut-in and the flowback after it are one monotonic decline: the crack
    closes in one of them at most. Where the shut-in methods found a break and the flowback
    a lower closure with the stronger evidence, the shut-in picks are rejected: every
    rejected value lies above the flowback's closure, and the cycle's closure (consensus)
    is the flowback's."""
    hit = set()
    for name, ev in evals.items():
        for c in ev.cycles:
            shut = {m: e for m, e in c.rejected_errors.items() if m not in FLOWBACK}
            if not shut:
                continue
            hit.add((name, c.cycle))
            if (name, c.cycle) in WRONG_REJECTIONS:
                assert c.closure_in_shutin is True and c.failures, (name, c.cycle)
                continue
            assert c.closure_in_shutin is not True, (name, c.cycle)
            fb = [c.errors[m] for m in FLOWBACK if m in c.errors]
            # the consensus is the flowback's closure (within the spread of its two picks)
            assert fb and min(fb) - 1e-9 <= c.errors["consensus"] <= max(fb) + 1e-9
            for m, e in shut.items():
                assert e > max(fb), (name, c.cycle, m)
    assert hit == REJECTED_SHUTIN


def test_flowback_breaks_contradicted_by_the_shutin_are_rejected(evals):
    """The other way round: a shut-in that closed the crack with a stiffening break stronger
    than the flowback's makes the flowback's (lower) break the rejected one."""
    hit = set()
    for name, ev in evals.items():
        for c in ev.cycles:
            fb = {m: e for m, e in c.rejected_errors.items() if m in FLOWBACK}
            if not fb:
                continue
            hit.add((name, c.cycle))
            # the shut-in's closure is kept and is the cycle's; the rejected breaks lie below
            kept = [c.errors[m] for m in ("tangent", "sqrt_t", "g_function") if m in c.errors]
            assert kept, (name, c.cycle)
            for m, e in fb.items():
                assert e < min(kept), (name, c.cycle, m)
    assert hit == REJECTED_FLOWBACK


def test_the_library_exercises_every_closure_rule(evals):
    cycles = [c for ev in evals.values() for c in ev.cycles]
    # a shut-in through closure, judged by the 5 % rule with picks present
    assert any(c.closure_in_shutin is True and "g_function" in c.errors for c in cycles)
    # a shut-in that ends above sigma_h, judged by the "no closure" rule
    assert sum(c.closure_in_shutin is False for c in cycles) >= 5
    # flowbacks through closure (the system-stiffness rule)
    assert sum(c.flowback_closure for c in cycles) >= 20


# ----------------------------------------------------------------------------- span
def test_the_library_spans_the_issue(scenes, evals):
    assert len(scenes) >= 12
    assert all(s.resolved_model == "mdem" for s in scenes.values())
    assert all(ev.truth["status"] == "ok" for ev in evals.values())
    st = [s.stresses for s in scenes.values()]
    ratio = [s.sigma_H / s.sigma_h for s in st]
    assert min(ratio) <= 1.1 and max(ratio) >= 1.5
    assert min(s.sigma_h for s in st) <= 20e6 and max(s.sigma_h for s in st) >= 40e6
    k = [s.rock.permeability for s in scenes.values()]
    assert min(k) <= 1e-21 and max(k) >= 1e-17
    rates = {ph.rate for s in scenes.values() for _, ph in s.schedule.expanded()
             if ph.kind == "pump"}
    assert min(rates) <= 250 / 60000 + 1e-12 and max(rates) >= 1000 / 60000 - 1e-12
    cw = [total_well_compliance(s) for s in scenes.values()]
    assert max(cw) / min(cw) > 2.5
    kinds = [[ph.kind for _, ph in s.schedule.expanded()] for s in scenes.values()]
    # cycles closed by a flowback, and a cycle watched through closure in a shut-in only
    assert any("flowback" in k for k in kinds)
    assert any(k.count("flowback") == 1 for k in kinds)
    eff = [s.effects for s in scenes.values()]
    assert any(e.heterogeneity for e in eff)
    assert any(e.interface for e in eff)
    assert any(e.pipe_friction for e in eff) and not all(e.pipe_friction for e in eff)
    assert {s.output.gauge for s in scenes.values()} == {"bottomhole", "surface"}
    # issue 17's hard cases: a closure law, shear dilation, an interface at a shallow angle
    # to sigma_H (one a crack may turn along), a DFIT and a LOT, a crack that grew in a
    # shut-in while open (tip extension, from the model's own record)
    assert any(s.rock.closure_law != "smooth" for s in scenes.values())
    assert any(e.shear_dilation for e in eff)

    def angle(i) -> float:
        (x0, y0), (x1, y1) = i.start, i.end
        return abs(math.degrees(math.atan2(y1 - y0, x1 - x0))) % 180.0

    assert any(min(angle(i), 180.0 - angle(i)) <= 30.0 for e in eff for i in e.interface)
    assert {"xlot", "dfit", "lot"} <= {ev.scene_kind for ev in evals.values()}
    assert any(c.tip_extension for ev in evals.values() for c in ev.cycles)


def _has_interface(name: str) -> bool:
    return bool(load_scene(ROOT / name / "scene.toml").effects.interface)


def test_truths_hold_imposed_realised_and_the_command(evals):
    for name, ev in evals.items():
        t = ev.truth
        assert t["command"] == f"xlotkit simulate data/synthetic/{name}/scene.toml --out DIR"
        assert t["library_command"] == (
            f"xlotkit library build data/synthetic --only {name} --replace")
        assert t["wall_time_s"] > 0 and t["max_mass_balance_error"] <= 1e-8
        imp, rea, mt = t["imposed_bar"], t["realised_bar"], t["model_truth"]
        for key in ("sigma_h", "sigma_H", "tensile_strength", "pore_pressure"):
            assert key in imp and key in rea
        # the realised sigma_h is the crack's mean normal stress: within its range over the
        # crack and within 1.5 % of the far field (measured on the free path: -1.28 % where
        # the crack turned along the slipping interface of 22, whose slip unloads it; +0.06
        # to +0.43 % elsewhere, the hole's concentration near the wall)
        assert mt["sigma_h_min_bar"] <= rea["sigma_h"] <= mt["sigma_h_max_bar"]
        assert rea["sigma_h"] == pytest.approx(imp["sigma_h"], rel=0.015), name
        # the crack runs along sigma_H: on the free path its axis is within 4 deg of it
        # (measured -3.6 to +1.2 deg; the strip's was 0), inside the 50 m section. The limit
        # is one element of the crack band (0.5 m) across a wing of 7-12 m: 2.4-4.1 deg.
        # It was 3 deg (measured -2.9 to +1.6) until issue 20's regeneration, where 09's
        # crack came out one-sided (wings 12.5 m and 5.4 m, measured from its last snapshot)
        # with its long wing one band row (-0.5 to -0.76 m) off the axis beyond 5 m: -3.6 deg
        # (-2.1 before). With little anisotropy (02: sigma_H / sigma_h = 1.07) the path is
        # less held (12.5 deg measured on issue 20's regeneration, 4.1 before; within 15),
        # and in the +-25 % heterogeneous rock of 14 it follows the weaker clusters (-2.7 deg
        # measured, -4.8 before; within 6)
        lim = 4.0
        if imp["sigma_H"] / imp["sigma_h"] < 1.2:
            lim = 15.0
        elif name == "14_heterogeneity":
            lim = 6.0
        assert abs(mt["fracture_azimuth_deg"]) < lim, (name, mt["fracture_azimuth_deg"])
        assert mt["fracture_half_length_m"] < 25.0
        # the stress along the crack is the far-field sigma_H less the radial-stress dip
        # near the wall, averaged over the crack: within 1 % (measured -0.12 to -0.61 %),
        # and within 5 % where an interface crosses the crack's path (its slip unloads
        # sigma_H there: measured -3.86 % in 22, -1.14 % in 20)
        tol = 0.05 if _has_interface(name) else 0.01
        assert rea["sigma_H"] == pytest.approx(imp["sigma_H"], rel=tol), name
        # the wall's hoop stress (a cluster average) and the mud column it was taken at
        assert mt["wall_hoop_stress_bar"] > 0 and mt["initial_pressure_bar"] > imp[
            "pore_pressure"]
        if name != "14_heterogeneity":
            assert rea["tensile_strength"] == imp["tensile_strength"]
    het = evals["14_heterogeneity"].truth["realised_bar"]["tensile_strength"]
    # +-25 % heterogeneity: the wall broke in clusters whose mean strength is not nominal
    assert het != 30.0 and 22.5 <= het <= 37.5


def test_stored_files_are_small_and_only_the_three(evals):
    for e in entries(ROOT):
        assert sorted(p.name for p in e.folder.iterdir()) == ["log.csv", "scene.toml",
                                                              "truth.json"]
        # 1 s logs: well under 100 kB each (no HDF5 or VTU in the repository)
        assert e.log_file.stat().st_size < 100_000


def test_the_documented_tables_are_the_stored_ones(evals):
    """docs/synthetic-library.md and data/synthetic/README.md hold the tables that the stored
    logs and truths give now (`xlotkit library check data/synthetic --markdown FILE`,
    `xlotkit library list data/synthetic --markdown FILE`)."""
    doc = (REPO / "docs" / "synthetic-library.md").read_text()
    assert evaluation_markdown([evals[n] for n in NAMES]) in doc, (
        "docs/synthetic-library.md is out of date: paste `xlotkit library check "
        "data/synthetic --markdown FILE`")
    # the per-method summary over the logs made on the free path alone (their truths hold
    # the per-phase record, model_truth.phases, that this generation of the build writes)
    free = [evals[n] for n in NAMES if "phases" in evals[n].truth.get("model_truth", {})]
    assert methods_markdown(free, per_pick=False) in doc
    readme = (ROOT / "README.md").read_text()
    assert scenes_markdown(entries(ROOT)) in readme, (
        "data/synthetic/README.md is out of date: paste `xlotkit library list data/synthetic "
        "--markdown FILE`")
    for name in NAMES:
        assert f"`{name}`" in readme


# ----------------------------------------------------------------------------- slow
@pytest.mark.slow
def test_regenerated_logs_are_the_stored_ones():
    """Every scene simulated again (~20 min): the same samples and pressures to 1 Pa (the
    log's 0.01 bar resolution is 1000 Pa; same scene and seed give the same numbers)."""
    out = compare(ROOT)
    assert [c.entry.name for c in out] == NAMES
    bad = [(c.entry.name, c.message) for c in out if not c.same]
    assert not bad, bad
