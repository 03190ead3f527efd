"""The library's issue-17 rules on hand-made inputs (no simulation): the per-phase crack
record (:func:`xlotkit.library.phase_truth`), what test a scene is
(:func:`xlotkit.library.scene_kind`), tip extension (:func:`xlotkit.library.grew`) and the
per-method error tables (:func:`xlotkit.library.method_rows`,
:func:`xlotkit.library.methods_markdown`)."""

from __future__ import annotations

import numpy as np
import pytest

from xlotkit.library import (
    DFIT_FALLOFF_RATIO,
    CycleCheck,
    Entry,
    Evaluation,
    grew,
    method_rows,
    methods_markdown,
    phase_truth,
    scene_kind,
)


# ----------------------------------------------------------------------------- phases
def _series():
    """A pump (0-10 s) and a shut-in (10-30 s): the crack grows from 2 to 4 m while the
    pressure falls linearly from 320 to 280 bar, so it crosses 300 bar at t = 20 s."""
    t = np.arange(0.0, 31.0)
    p = np.where(t <= 10, 250e5 + 7e5 * t, 320e5 - 2e5 * (t - 10))
    half = np.where(t <= 10, 0.2 * t, 2.0 + 0.1 * (t - 10))
    return {"t": t, "bottomhole_pressure": p, "fracture_length": half,
            "fracture_volume": 1e-3 * t, "leakoff_volume": 1e-4 * t}


PHASES = [{"cycle": 1, "kind": "pump", "name": "pump", "t_start": 0.0, "t_end": 10.0},
          {"cycle": 1, "kind": "shut_in", "name": "si", "t_start": 10.0, "t_end": 30.0}]


def test_phase_truth_reads_each_phase_and_the_open_part_of_a_shutin():
    pump, si = phase_truth(PHASES, _series(), 300.0)
    assert pump["pressure_bar"] == [250.0, 320.0]
    assert pump["half_length_m"] == [0.0, 2.0]
    assert pump["fracture_volume_l"] == [0.0, 10.0]          # m3 -> l
    assert "open_until_s" not in pump                          # only shut-ins
    assert si["half_length_m"] == [2.0, 4.0]
    # 320 - 2 (t - 10) <= 300 first at t = 20 s, where the half-length is 2 + 1 = 3 m
    assert si["open_until_s"] == 20.0 and si["half_length_open_m"] == 3.0
    assert "failed_clusters" not in si                         # a column the series lacks


def test_phase_truth_a_shutin_that_stays_above_sigma_h():
    _, si = phase_truth(PHASES, _series(), 250.0)
    assert si["open_until_s"] is None and si["half_length_open_m"] == 4.0
    assert phase_truth(PHASES, {"t": np.array([])}, 300.0) == []


# ----------------------------------------------------------------------------- kinds
def _truth(phases, *, fbp=340.0, initiation=320.0):
    mt = {"initiation_pressure_bar": initiation, "phases": phases}
    return {"fbp_bar": fbp, "model_truth": mt}


def _ph(kind, t0, t1):
    return {"kind": kind, "t_start_s": t0, "t_end_s": t1}


def test_scene_kind():
    dfit = [_ph("shut_in", 0, 60), _ph("pump", 60, 160),
            _ph("shut_in", 160, 160 + DFIT_FALLOFF_RATIO * 100)]
    assert scene_kind(_truth(dfit)) == "dfit"
    short = [_ph("shut_in", 0, 60), _ph("pump", 60, 160), _ph("shut_in", 160, 599)]
    assert scene_kind(_truth(short)) == "xlot"                # falloff 4.39 x injection
    flowback = dfit + [_ph("flowback", 660, 700)]
    assert scene_kind(_truth(flowback)) == "xlot"
    # the wall failed, the pressure never fell while pumping: a LOT before breakdown
    assert scene_kind(_truth(flowback, fbp=None)) == "lot"
    # no failure at all and no FBP: not a LOT past its leak-off point
    assert scene_kind(_truth(flowback, fbp=None, initiation=None)) == "xlot"
    assert scene_kind({"realised_bar": {}}) == "xlot"        # a truth without the detail


def test_grew():
    assert grew((6.0, 8.0)) and not grew(None)
    assert not grew((6.0, 6.9))           # less than 1 m
    assert not grew((12.0, 13.1))         # 1.1 m but under 10 % of 12 m
    assert grew((12.0, 13.25))


# ----------------------------------------------------------------------------- tables
def _evaluation():
    """One scene, realised sigma_h 300 bar, imposed 299 bar: a flowback pick 1 % low that
    passes, a rejected shut-in pick, a missed p-V pick and a consensus."""
    truth = {"realised_bar": {"sigma_h": 300.0, "sigma_H": 400.0, "tensile_strength": 30.0},
             "imposed_bar": {"sigma_h": 299.0}, "model": "mdem"}
    return Evaluation(Entry("x", None), truth, (CycleCheck(
        cycle=1, shutin_end_pressure=290e5, closure_in_shutin=True, flowback_closure=True,
        errors={"flowback_sqrt_p": -0.01, "consensus": -0.01, "tangent": 0.02,
                "bilinear": 0.08},
        failures=("cycle 1: flowback_p_v found no closure in a flowback through sigma_h",),
        kind="xlot",
        outcomes={"flowback_sqrt_p": "pass", "flowback_p_v": "miss", "tangent": "pass",
                  "sqrt_t": "rejected", "g_function": "none", "bilinear": "fail",
                  "compliance": "none", "consensus": "pass"},
        rejected_errors={"sqrt_t": 0.04},
        notes={"flowback_p_v": "no stiffness contrast | in the window",
               "sqrt_t": "the flowback that follows finds closure lower",
               "g_function": "no break"}),), None, None, None, ())


def test_method_rows_hold_values_and_both_errors():
    rows = {r["method"]: r for r in method_rows([_evaluation()])}
    r = rows["flowback_sqrt_p"]
    assert r["value_bar"] == pytest.approx(297.0)             # 300 bar x (1 - 1 %)
    assert r["err_imposed"] == pytest.approx((297.0 - 299.0) / 299.0)
    assert rows["sqrt_t"]["value_bar"] == pytest.approx(312.0)  # the rejected value
    assert rows["sqrt_t"]["note"].startswith("the flowback")
    assert rows["flowback_p_v"]["value_bar"] is None and rows["flowback_p_v"]["note"]
    assert rows["tangent"]["note"] == ""                      # a kept pick needs no "why"


def test_methods_markdown_counts_and_medians():
    md = methods_markdown([_evaluation()])
    lines = md.splitlines()
    row = next(ln for ln in lines if ln.startswith("| flowback √p–t |"))
    # one kept pick within tolerance, |error| 1 % realised, 0.67 % against 299 bar
    assert row == "| flowback √p–t | 1 | 1 | 0 | 0 | 0 | 0 | 0 | 1.00 % | 1.00 % | 0.67 % |"
    assert next(ln for ln in lines if ln.startswith("| flowback p–V |")) == (
        "| flowback p–V | 0 | 0 | 0 | 0 | 1 | 0 | 0 | – | – | – |")
    bil = next(ln for ln in lines if ln.startswith("| bilinear |"))
    assert "| 1 | 0 | 1 | 0 |" in bil and "8.00 %" in bil
    # per-pick rows: the miss with its reason ('|' made safe), the rejection with its value;
    # methods with nothing to find are left out
    assert "| x | 1 | xlot | flowback p–V | – | – | – | miss | no stiffness contrast / in " \
           "the window |" in md
    assert "| x | 1 | xlot | √t | 312.0 | +4.00 % | +4.35 % | rejected |" in md
    assert "G-function | –" not in md


def test_a_scene_without_a_test_cycle_is_a_miss_of_every_method():
    truth = {"realised_bar": {"sigma_h": 300.0, "sigma_H": 400.0, "tensile_strength": 30.0},
             "imposed_bar": {"sigma_h": 300.0}}
    ev = Evaluation(Entry("lot", None), truth, (), None, None, None,
                    ("no test cycle found in the log",))
    (row,) = method_rows([ev])
    assert row["method"] == "all" and row["outcome"] == "miss"
    md = methods_markdown([ev])
    assert "| lot | – | – | every method | – | – | – | miss | no test cycle found in the log |" \
        in md
    for label in ("flowback √p–t", "G-function", "consensus"):
        row = next(ln for ln in md.splitlines() if ln.startswith(f"| {label}"))
        assert row.split(" | ")[5] == "1"                   # the misses column
