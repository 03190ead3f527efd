"""The pick orchestrator: options, consensus rule, cycle and record summaries."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from xlotkit.interpret.phases import Cycle, Phase, Segmentation
from xlotkit.interpret.picks.core import (
    FCP_METHODS,
    CyclePicks,
    PickOptions,
    RecordPicks,
    consensus_fcp,
    pick_cycle,
    pick_record,
    reconcile_closures,
)
from xlotkit.interpret.picks.details import FlowbackDetails, SlopeBreakDetails
from xlotkit.interpret.picks.types import Pick

BAR = 1e5


def _flowback_helpers():
    # The analytic fixed-choke record lives with the flowback tests; load it by path so this
    # works whatever pytest import mode is used.
    path = Path(__file__).with_name("test_picks_flowback.py")
    spec = importlib.util.spec_from_file_location("_xlot_fb_helpers", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


fb = _flowback_helpers()


def fcp(method, value, quality="good", half=1.0, t=None):
    return Pick("FCP", method, value * BAR, low=(value - half) * BAR, high=(value + half) * BAR,
                quality=quality, t=t)


def _cycle(index=1, kind="xlot"):
    ph = (Phase("pump", 0, 10, 0.0, 9.0),)
    return Cycle(index, kind, ph, 0.0, 9.0, 1e7, 0.1, 0.0)


# ----------------------------------------------------------------------- options
def test_options_validate_and_resolve_windows():
    o = PickOptions(methods=("tangent", "flowback_sqrt_p"),
                    windows={"ISIP": (10, 20), (2, "ISIP"): (30, 40), "tangent": (1, 2)},
                    tangents={(1, "flowback_sqrt_p"): ((0, 10), (20, 30))})
    assert o.window(1, "ISIP") == (10.0, 20.0)
    assert o.window(2, "ISIP") == (30.0, 40.0)  # cycle-specific wins
    assert o.window(3, "LOP") is None
    assert o.tangent(1, "flowback_sqrt_p") == ((0.0, 10.0), (20.0, 30.0))
    assert o.tangent(2, "flowback_sqrt_p") is None
    assert PickOptions().methods == FCP_METHODS
    with pytest.raises(ValueError, match="unknown FCP method"):
        PickOptions(methods=("magic",))
    with pytest.raises(ValueError, match="t_end > t_start"):
        PickOptions(windows={"ISIP": (20, 10)})
    with pytest.raises(ValueError, match="unknown name"):
        PickOptions(windows={"XYZ": (0, 1)})
    with pytest.raises(ValueError, match="fixed tangents"):
        PickOptions(tangents={"sqrt_t": ((0, 1), (2, 3))})
    with pytest.raises(ValueError, match="cycle index"):
        PickOptions(windows={(0, "ISIP"): (0, 1)})
    with pytest.raises(Exception):
        o.methods = ()  # frozen


# ----------------------------------------------------------------------- consensus
def test_consensus_prefers_good_flowback():
    picks = [fcp("tangent", 110), fcp("sqrt_t", 108), fcp("flowback_sqrt_p", 100, half=0.5),
             fcp("flowback_p_v", 100.4, half=0.5)]
    c = consensus_fcp(picks)
    assert c.method == "consensus" and c.value == 100 * BAR
    assert c.details.rule == "flowback" and c.details.chosen == "flowback_sqrt_p"
    # The interval covers both good flowback picks.
    assert c.low == pytest.approx(99.5 * BAR) and c.high == pytest.approx(100.9 * BAR)


def test_consensus_falls_back_to_shutin_median_when_flowback_is_poor():
    picks = [fcp("tangent", 110), fcp("sqrt_t", 106, "fair"), fcp("g_function", 104),
             fcp("bilinear", 90, "poor"), fcp("flowback_sqrt_p", 80, "poor")]
    c = consensus_fcp(picks)
    assert c.details.rule == "shut-in median"
    assert c.value == pytest.approx(106 * BAR)
    assert c.low == pytest.approx(103 * BAR) and c.high == pytest.approx(111 * BAR)
    assert set(c.details.methods) == {"tangent", "sqrt_t", "g_function"}
    assert c.quality == "good"  # three methods within 5 % of the median


def test_consensus_quality_and_not_found():
    assert consensus_fcp([fcp("tangent", 100), fcp("sqrt_t", 120)]).quality == "fair"
    assert consensus_fcp([fcp("bilinear", 90, "poor")]).quality == "poor"
    nf = consensus_fcp([Pick.not_found("FCP", "tangent", "no closure in the decline")])
    assert not nf.found and "no closure in the decline" in nf.message


# ----------------------------------------------------------------------- cycle/record
def test_cyclepicks_get_and_non_test_cycles():
    cp = CyclePicks(_cycle(), (fcp("tangent", 100), Pick("ISIP", "x", 120 * BAR)))
    assert cp.get("FCP").method == "consensus"
    assert cp.get("FCP", "tangent").value == 100 * BAR
    assert cp.get("ISIP").value == 120 * BAR and cp.get("LOP") is None
    casing = CyclePicks(_cycle(kind="casing_test"), ())
    assert not casing.fcp.found


def test_record_consistency_t0_and_stiffness_trend():
    c1 = CyclePicks(_cycle(1), (Pick("FBP", "max", 200 * BAR, low=199 * BAR, high=201 * BAR),
                                fcp("flowback_sqrt_p", 100)), stiffness=1000 * BAR)
    c2 = CyclePicks(_cycle(2), (Pick("Pr", "d", 150 * BAR, low=148 * BAR, high=151 * BAR),
                                fcp("flowback_sqrt_p", 102)), stiffness=900 * BAR)
    c3 = CyclePicks(_cycle(3), (fcp("flowback_sqrt_p", 101),), stiffness=800 * BAR)
    seg = Segmentation((), (c1.cycle, c2.cycle, c3.cycle), True)
    t, p, v, _ = fb.choke_flowback()
    rec, _ = fb.make_record(t, p, v)
    rp = RecordPicks(rec, seg, (c1, c2, c3))
    k = rp.consistency
    assert k.fcp_spread == pytest.approx(2 * BAR) and k.fcp_mean == pytest.approx(101 * BAR)
    assert rp.t0.value == pytest.approx(50 * BAR)
    assert rp.t0.low == pytest.approx(48 * BAR) and rp.t0.high == pytest.approx(53 * BAR)
    assert k.stiffness_slope == pytest.approx(-100 * BAR)
    assert k.stiffness_relative_change == pytest.approx(-0.2)
    assert rp.cycle(2) is c2
    with pytest.raises(KeyError):
        rp.cycle(9)


def test_pick_cycle_on_analytic_flowback_record():
    t, p, v, _ = fb.choke_flowback()
    rec, cyc = fb.make_record(t, p, v)
    cp = pick_cycle(rec, cyc)
    fmeth = cp.fcp_methods()
    assert set(fb_m for fb_m in ("flowback_sqrt_p", "flowback_p_v")) <= set(fmeth)
    assert fmeth["flowback_sqrt_p"].value == pytest.approx(100 * BAR, rel=5e-3)
    # Consensus follows the good flowback pick.
    assert cp.fcp.details.rule == "flowback"
    assert cp.fcp.value == pytest.approx(100 * BAR, rel=5e-3)
    # LOP / FBP / FPP / ISIP picks are present (found or with a reason), never invented.
    names = {pk.name for pk in cp.picks}
    assert {"LOP", "FBP", "FPP", "ISIP"} <= names
    for pk in cp.picks:
        assert pk.found or pk.message
    # Synthetic pump-in: 150 bar over 2.5 m^3 -> 60 bar/m^3.
    assert cp.stiffness == pytest.approx(150 * BAR / 2.5, rel=0.02)
    assert "surface" in cp.reference


def test_pick_record_with_segmentation_and_method_subset():
    t, p, v, _ = fb.choke_flowback()
    rec, cyc = fb.make_record(t, p, v)
    seg = Segmentation(cyc.phases, (cyc,), True)
    rp = pick_record(rec, seg, options=PickOptions(methods=("flowback_p_v",)))
    (cp,) = rp.cycles
    methods = [pk.method for pk in cp.picks if pk.name == "FCP"]
    assert methods == ["flowback_p_v"]
    assert rp.consistency.fcp[0][1] == pytest.approx(100 * BAR, rel=5e-3)
    assert not rp.t0.found


def test_later_cycle_gets_reopening_not_lop():
    t, p, v, _ = fb.choke_flowback()
    rec, cyc = fb.make_record(t, p, v)
    first = pick_cycle(rec, cyc)
    second = pick_cycle(rec, cyc, previous=first)
    assert second.get("Pr") is not None and second.get("LOP") is None
    assert second.get("FBP") is None


# ----------------------------------------------------------------------- reconcile
def _pump_shut_flow():
    ph = (Phase("pump", 0, 10, 0.0, 9.0), Phase("shut_in", 10, 20, 10.0, 19.0),
          Phase("flowback", 20, 30, 20.0, 29.0))
    return Cycle(1, "xlot", ph, 0.0, 29.0, 3.5e7, 0.5, 0.4)


def _shut(method, value, signature=None, ratio=None):
    p = fcp(method, value)
    d = None if signature is None else SlopeBreakDetails(x_name="G", closure_signature=signature,
                                                         slope_ratio=ratio)
    return Pick(p.name, p.method, p.value, p.low, p.high, quality="good", details=d)


def _flow(method, value, ratio):
    p = fcp(method, value)
    d = FlowbackDetails(slope_ratio=ratio) if method == "flowback_sqrt_p" else \
        FlowbackDetails(stiffness_ratio=ratio)
    return Pick(p.name, p.method, p.value, p.low, p.high, quality="good", details=d)


def test_a_flattening_shutin_break_above_a_flowback_closure_is_rejected():
    # The flowback sees the crack open below the shut-in's break: the crack cannot have
    # closed in the shut-in (one monotonic decline), so the flattening break is not closure.
    picks = [_shut("sqrt_t", 307.5, "flattening", 0.36), _shut("bilinear", 306.0),
             _flow("flowback_sqrt_p", 300.4, 13.7), _flow("flowback_p_v", 300.5, 13.8)]
    out, notes = reconcile_closures(picks, _pump_shut_flow())
    by = {p.method: p for p in out}
    assert not by["sqrt_t"].found and not by["bilinear"].found
    assert by["sqrt_t"].details.rejected_value == pytest.approx(307.5 * BAR)
    assert by["sqrt_t"].details.original.closure_signature == "flattening"
    assert "still open" in by["sqrt_t"].message and "flattening" in by["sqrt_t"].message
    assert by["flowback_sqrt_p"].found and by["flowback_p_v"].found
    assert len(notes) == 2
    # and the consensus is then the flowback's
    assert consensus_fcp(out).value == pytest.approx(300.4 * BAR)


def test_a_stiffening_shutin_closure_overrules_a_weaker_flowback_break():
    picks = [_shut("g_function", 301.0, "stiffening", 3.2), _flow("flowback_sqrt_p", 286.2, 1.18),
             _flow("flowback_p_v", 288.3, 1.26)]
    out, _ = reconcile_closures(picks, _pump_shut_flow())
    by = {p.method: p for p in out}
    assert by["g_function"].found
    assert not by["flowback_sqrt_p"].found and not by["flowback_p_v"].found
    assert "started with the fracture closed" in by["flowback_p_v"].message
    # ... and a stronger flowback wins over a weaker stiffening
    picks[1:] = [_flow("flowback_sqrt_p", 286.2, 8.0)]
    out, _ = reconcile_closures(picks, _pump_shut_flow())
    assert [p.found for p in out] == [False, True]


def test_reconcile_leaves_agreeing_unrelated_and_user_fixed_picks_alone():
    cyc = _pump_shut_flow()
    # overlapping intervals: the two halves see the same closure
    agree = [_shut("sqrt_t", 301.0, "flattening", 0.5), _flow("flowback_sqrt_p", 300.5, 10.0)]
    assert reconcile_closures(agree, cyc) == (agree, [])
    # a break the other flowback method does not see is no evidence; equal (none): both kept
    lone = [_shut("sqrt_t", 110.0, "flattening", 0.5), _flow("flowback_sqrt_p", 48.0, 2.3),
            Pick.not_found("FCP", "flowback_p_v", "only one straight line",
                           details=FlowbackDetails(single_line=True))]
    out, notes = reconcile_closures(lone, cyc)
    assert out == lone and "both kept" in notes[0]
    # a fixed window keeps the pick, with a note
    bad = [_shut("sqrt_t", 307.5, "flattening", 0.36), _flow("flowback_sqrt_p", 300.4, 13.7)]
    out, notes = reconcile_closures(bad, cyc, fixed={"sqrt_t"})
    assert out == bad and "fixed by the user" in notes[0]
    # pumping between shut-in and flowback: two declines, nothing to reconcile
    ph = cyc.phases
    pumped = Cycle(1, "xlot", (ph[0], ph[1], Phase("pump", 20, 22, 20.0, 21.0),
                               Phase("flowback", 22, 30, 22.0, 29.0)), 0.0, 29.0, 3.5e7, 0.5,
                   0.4)
    assert reconcile_closures(bad, pumped) == (bad, [])


def _flow_pv(value, k_open, k_closed, se=0.0):
    p = fcp("flowback_p_v", value)
    d = FlowbackDetails(stiffness_open=k_open, stiffness_closed=k_closed,
                        stiffness_ratio=k_closed / k_open, stiffness_open_stderr=se)
    return Pick(p.name, p.method, p.value, p.low, p.high, quality="good", details=d)


def test_the_flowback_open_side_against_the_closed_system_decides_before_the_contrasts():
    # Closed-system (pressurisation) stiffness 0.15 bar/l = 1.5e7 bar/m3 = 1.5e12 Pa/m3.
    k = 1.5e12
    cyc = _pump_shut_flow()
    # A sharp stiffening shut-in break (x69, an inclined crack piece closing) above a flowback
    # that starts at 0.2 of the closed system's stiffness: the fracture was open at the
    # flowback start, so the shut-in's break is not its closure, however strong (the contrast
    # rule alone keeps the shut-in: checked first).
    picks = [_shut("g_function", 313.0, "stiffening", 69.0), _flow("flowback_sqrt_p", 294.0, 4.3),
             _flow_pv(294.2, 0.2 * k, 0.9 * k, se=0.01 * k)]
    out, _ = reconcile_closures(picks, cyc)
    assert [p.found for p in out] == [True, False, False]
    out, notes = reconcile_closures(picks, cyc, closed_stiffness=k,
                                    closed_stiffness_stderr=0.02 * k)
    assert [p.found for p in out] == [False, True, True]
    assert "softer than the closed system" in out[0].message and len(notes) == 1
    # A flowback that starts at 1.4 times the pressurisation stiffness has no fracture
    # compliance left to lose: its break (x1.9, stronger than the shut-in's flattening, which
    # alone would keep the flowback) is rejected and the shut-in's closure stands.
    picks = [_shut("sqrt_t", 297.0, "flattening", -0.08), _flow("flowback_sqrt_p", 276.0, 1.8),
             _flow_pv(276.5, 1.4 * k, 2.7 * k, se=0.02 * k)]
    out, _ = reconcile_closures(picks, cyc)
    assert [p.found for p in out] == [False, True, True]
    out, _ = reconcile_closures(picks, cyc, closed_stiffness=k, closed_stiffness_stderr=0.02 * k)
    assert [p.found for p in out] == [True, False, False]
    assert "closed system's stiffness" in out[2].message
    # In between (softer, but not by two standard errors) the contrasts decide as before.
    picks[2] = _flow_pv(276.5, 0.97 * k, 2.7 * k, se=0.05 * k)
    out, _ = reconcile_closures(picks, cyc, closed_stiffness=k, closed_stiffness_stderr=0.02 * k)
    assert [p.found for p in out] == [False, True, True]
