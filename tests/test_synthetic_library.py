"""The synthetic XLOT library in data/synthetic (issue 7).

Fast: every stored log is read and picked as a field log and checked against the realised
stresses of its scene with issue 7's tolerances (:func:`xlotkit.library.evaluate`); the
library spans what the issue asks for; the stored truths hold what the README promises; the
tables in docs/synthetic-library.md and data/synthetic/README.md are the ones the stored
files give. Slow: every scene is simulated again and its log compared with the stored one.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from xlotkit.interpret.picks.details import RejectedDetails
from xlotkit.library import (
    FLOWBACK_RTOL,
    SHUTIN_RTOL,
    compare,
    entries,
    evaluate,
    evaluation_markdown,
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
@pytest.mark.parametrize("name", NAMES)
def test_picks_against_the_realised_stresses(evals, name):
    ev = evals[name]
    assert not ev.failures, ev.failures
    assert len(ev.cycles) == 2, "every scene is a two-cycle test"
    for c in ev.cycles:
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


def _rejected(name: str) -> dict[int, dict[str, object]]:
    """Cycle -> {method: Pick} of the closure picks the interpreter rejected as contradicting
    the other half of the cycle (xlotkit.interpret.picks.core.reconcile_closures)."""
    from xlotkit.interpret.io import read_log
    from xlotkit.pipeline import interpret_record

    e = entries(ROOT, [name])[0]
    out: dict[int, dict[str, object]] = {}
    for k, c in enumerate(interpret_record(read_log(e.log_file)).picks.test_cycles, 1):
        rej = {m: p for m, p in c.fcp_methods().items()
               if not p.found and isinstance(p.details, RejectedDetails)}
        if rej:
            out[k] = rej
    return out


def test_shutin_breaks_of_a_growing_crack_are_rejected(evals):
    """After the first pump-in the crack keeps growing into the shut-in (fluid runs to its
    tip); the decline flattens as the growth slows, a lasting break of p vs G 2-3 % above
    sigma_h that the shut-in methods take for closure. The flowback that follows sees the
    crack still open below it (stiffness rising x10-14 at sigma_h), so the interpreter
    rejects those picks (docs/synthetic-library.md, "Shut-in breaks of a growing crack").
    Pinned: the scenes where it happens, that every rejected pick was above sigma_h, that
    the breaks were flattening ones, and that what is left is right."""
    hit = {}
    for name, ev in evals.items():
        sh = ev.realised("sigma_h")
        for cycle, rej in _rejected(name).items():
            shut = {m: p for m, p in rej.items() if m not in ("flowback_sqrt_p", "flowback_p_v")}
            if not shut:
                continue
            hit[name] = cycle
            c = ev.cycles[cycle - 1]
            assert c.closure_in_shutin is False and c.flowback_closure
            for m, p in shut.items():
                assert p.details.rejected_value > sh, (name, m)
                if m in ("sqrt_t", "g_function"):
                    assert p.details.original.closure_signature == "flattening", (name, m)
            assert abs(c.errors["consensus"]) <= FLOWBACK_RTOL
    # the first shut-in of the standard scene and of its stress/permeability variants (which
    # others pass the scan's significance is a borderline: 01, 02, 04, 07, 08 since the
    # issue-19 break scan, 01, 02, 03, 04, 06 before; docs/synthetic-library.md)
    assert {"01_standard", "04_stress_high", "07_perm_1e-19"} <= set(hit), hit
    assert set(hit.values()) == {1}


def test_a_real_shutin_closure_overrules_a_weak_flowback_break(evals):
    """Scene 09's second shut-in closes the crack (a stiffening break, x1.85, +0.19 %); the
    flowback after it starts closed, and its weak break (x1.18, 4.7 % low: the formation
    flowing back at k = 1e-16 m2) is rejected, not the shut-in's closure."""
    rej = _rejected("09_perm_1e-16_shutin")
    assert set(rej) == {2} and set(rej[2]) == {"flowback_sqrt_p", "flowback_p_v"}
    c = evals["09_perm_1e-16_shutin"].cycles[1]
    assert c.shutin_judged and not c.flowback_closure
    assert abs(c.errors["g_function"]) <= 0.005
    from xlotkit.interpret.io import read_log
    from xlotkit.pipeline import interpret_record

    e = entries(ROOT, ["09_perm_1e-16_shutin"])[0]
    cp = interpret_record(read_log(e.log_file)).picks.test_cycles
    for k in (1, 2):
        assert cp[k - 1].fcp_methods()["g_function"].details.closure_signature == "stiffening"


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
        # crack, at or just above the far field (the hole's concentration near the wall)
        assert mt["sigma_h_min_bar"] <= rea["sigma_h"] <= mt["sigma_h_max_bar"]
        assert imp["sigma_h"] <= rea["sigma_h"] <= 1.01 * imp["sigma_h"], name
        # the crack runs along sigma_H and inside its 20 m strip
        assert abs(mt["fracture_azimuth_deg"]) < 1.0
        assert mt["fracture_half_length_m"] < 20.0
        # the stress along the crack is the far-field sigma_H less the radial-stress dip
        # near the wall, averaged over the crack: within 1 %
        assert rea["sigma_H"] == pytest.approx(imp["sigma_H"], rel=0.01)
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
