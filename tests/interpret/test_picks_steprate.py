"""Fracture-extension pressure of a step-rate test (:mod:`xlotkit.interpret.picks.steprate`).

Verified against the construction: stabilised pressures on two straight lines in rate
(``p_res + q / J`` below the break, a flatter line above), whose intersection is known
exactly (``phase_fixtures.step_rate_arrays``).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from phase_fixtures import BAR, LPM, step_rate_arrays, to_record

from xlotkit import Record
from xlotkit.interpret.phases import segment
from xlotkit.interpret.picks.core import pick_record
from xlotkit.interpret.picks.details import RateStepPoint, StepRateDetails
from xlotkit.interpret.picks.intervals import LEVEL
from xlotkit.interpret.report import _jsonable
from xlotkit.interpret.picks.steprate import fep_two_lines, pick_fep


def test_two_lines_meet_where_the_construction_put_them():
    q = np.array([40, 80, 120, 160, 200, 260, 320, 380], float) * LPM
    p_res, J, qc = 200e5, 8.0 * LPM / BAR, 170 * LPM  # J: 8 l/min per bar, in m3/s per Pa
    fep = p_res + qc / J
    p = np.where(q <= qc, p_res + q / J, fep + 0.02 * BAR / LPM * (q - qc))
    k, lo, _hi, q_fep, p_fep, _se = fep_two_lines(q, p)
    # exact data: the split puts the four points below qc on the lower line and the lines
    # meet at the construction's break (floating point only)
    assert k == 4
    assert p_fep == pytest.approx(fep, rel=1e-12)
    assert q_fep == pytest.approx(qc, rel=1e-9)
    assert lo.slope == pytest.approx(1 / J, rel=1e-9)


def test_fep_interval_holds_its_level_on_constructed_tests():
    # 30 constructed tests: the break anywhere between the 3rd and 6th step, 0.05-0.5 bar
    # gauge noise, 20-60 s storage time constant (each step 300 s, read over its last
    # 100 s). At the stated 90 %, 30 draws contain the truth at least 24 times with
    # probability 0.93 if the level holds; measured 30 of 30 (the intervals are
    # conservative: the points' errors include the drift left in each step).
    rng = np.random.default_rng(11)
    inside, errors, widths = 0, [], []
    for _ in range(30):
        t, p, q, truth = step_rate_arrays(q_c_lpm=rng.uniform(110, 260),
                                          noise_bar=rng.uniform(0.05, 0.5),
                                          tau_s=rng.uniform(20, 60),
                                          seed=int(rng.integers(2**31)))
        rec = to_record(t, p, q)
        pk = pick_fep(rec, segment(rec).cycles[0])
        assert pk.found and pk.level == LEVEL
        inside += pk.low <= truth["fep_bar"] * BAR <= pk.high
        errors.append(abs(pk.value / BAR - truth["fep_bar"]))
        widths.append((pk.high - pk.low) / BAR)
    assert inside >= 24
    # and the intervals are not vacuous: under a bar wide on ~0.05-0.5 bar noise
    assert np.median(widths) < 1.0 and np.median(errors) < 0.5 * np.median(widths)


def test_a_straight_p_q_line_has_no_break():
    # every step below the break: matrix injection only
    t, p, q, _ = step_rate_arrays(q_c_lpm=1000.0)
    rec = to_record(t, p, q)
    pk = pick_fep(rec, segment(rec).cycles[0])
    assert not pk.found and "no break" in pk.message


def test_too_few_steps_and_no_rate_are_not_found():
    t, p, q, _ = step_rate_arrays(rates_lpm=(50, 150, 300))
    rec = to_record(t, p, q)
    pk = pick_fep(rec, segment(rec).cycles[0])
    assert not pk.found and "at least 4" in pk.message
    t, p, q, _ = step_rate_arrays()
    bare = Record(t=t, pressure=p * BAR)
    cyc = segment(to_record(t, p, q)).cycles[0]
    pk = pick_fep(bare, cyc)
    assert not pk.found and "no pump rate" in pk.message


def test_unstabilised_steps_are_left_out_and_named():
    # steps of 60 s with a 60 s storage constant: none stabilises
    t, p, q, _ = step_rate_arrays(step_s=60, tau_s=60.0)
    rec = to_record(t, p, q)
    seg = segment(rec)
    pk = pick_fep(rec, seg.cycles[0])
    assert not pk.found and "not stabilised" in pk.message


def test_fep_details_are_typed_and_the_lines_meet_at_the_pick():
    # issue 16 audit D8: the FEP details were a dict; they are a StepRateDetails whose two
    # lines meet at the picked pressure (checked from the lines, not the pick's own number)
    t, p, q, truth = step_rate_arrays()
    rec = to_record(t, p, q)
    fep = pick_fep(rec, segment(rec).cycles[0])
    d = fep.details
    assert isinstance(d, StepRateDetails)
    assert all(isinstance(s, RateStepPoint) for s in d.steps) and len(d.steps) == 8
    assert d.points_lower + d.points_upper == sum(s.stable for s in d.steps)
    # the lines cross at q_fep; there both give the FEP (floating point only)
    assert d.line_lower(d.q_fep) == pytest.approx(fep.value, rel=1e-9)
    assert d.line_upper(d.q_fep) == pytest.approx(fep.value, rel=1e-9)
    assert d.slope_ratio == pytest.approx(d.line_upper.slope / d.line_lower.slope)
    # the construction breaks at 170 l/min
    assert d.q_fep == pytest.approx(170 * LPM, rel=0.05)
    m = d.to_dict()
    json.dumps(_jsonable(d))
    assert {"steps", "line_lower", "line_upper", "q_fep", "slope_ratio", "interval"} <= set(m)


def test_a_step_rate_cycle_has_no_lop_but_an_fep():
    # issue 16 audit D4: the LOP was picked on step-rate cycles, where the pressure bends at
    # every rate step -- a departure from the first line is the second step, not leak-off
    t, p, q, _ = step_rate_arrays()
    rec = to_record(t, p, q)
    cp = pick_record(rec).cycles[0]
    assert cp.cycle.kind == "step_rate"
    assert cp.get("LOP") is None and cp.get("Pr") is None
    assert cp.get("FEP") is not None and cp.get("FEP").found
    assert any("no LOP" in n for n in cp.notes)
