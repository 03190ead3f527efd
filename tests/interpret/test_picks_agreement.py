"""One closure from the cycles that agree, outliers named (picks/agreement.py)."""

from __future__ import annotations

import pytest

from xlotkit.interpret.picks.agreement import agree_closures
from xlotkit.interpret.picks.details import ConsensusDetails
from xlotkit.interpret.picks.types import Pick

BAR = 1e5


def fcp(value, low, high, methods=("flowback_sqrt_p", "flowback_p_v"), quality="fair"):
    return Pick("FCP", "consensus", value * BAR, low * BAR, high * BAR, quality=quality,
                message="median of " + ", ".join(methods), level=0.9,
                details=ConsensusDetails(rule="median of best available", methods=methods))


def test_the_group_whose_intervals_overlap_and_the_outliers():
    # the AMS-01 XLOT 2 pattern: cycles 3 and 5 agree on ~146 bar from both flowback
    # methods; cycle 4 (one method, 118 bar) and cycle 2 (one method, 114 bar) agree with
    # each other only
    closures = [(1, Pick.not_found("FCP", "consensus", "none")),
                (2, fcp(114.3, 111.6, 117.2, ("flowback_sqrt_p",))),
                (3, fcp(146.0, 142.1, 149.4)),
                (4, fcp(118.0, 115.7, 121.4, ("flowback_sqrt_p",), "poor")),
                (5, fcp(145.4, 139.0, 149.5))]
    a = agree_closures(closures)
    assert a.cycles == (3, 5)
    assert a.value == pytest.approx(145.7 * BAR)          # median of 146.0 and 145.4
    assert (a.low, a.high) == (pytest.approx(139.0 * BAR), pytest.approx(149.5 * BAR))
    assert [i for i, _ in a.outliers] == [2, 4]
    why4 = dict(a.outliers)[4]
    assert "118.0 bar" in why4 and "below" in why4 and "flowback_sqrt_p" in why4
    assert a.level == pytest.approx(0.9) and a.representative in (3, 5)


def test_the_largest_group_wins_and_its_median_resists_an_edge_member():
    closures = [(1, fcp(100.0, 99.0, 101.0)), (2, fcp(100.5, 99.5, 101.5)),
                (3, fcp(101.9, 100.8, 102.5)), (4, fcp(90.0, 89.0, 91.0))]
    a = agree_closures(closures)
    # 1, 2, 3 share 100.8-101.0; the median is 2's value, not pulled to 3's
    assert a.cycles == (1, 2, 3) and a.value == pytest.approx(100.5 * BAR)
    assert [i for i, _ in a.outliers] == [4]


def test_equal_groups_are_decided_by_the_evidence():
    # 1, 2 share 99.5-101; 2, 3 share 101.2-101.5; 1 and 3 do not overlap: two groups of
    # two. More methods win; with the same methods, flowback and quality, the later cycles.
    closures = [(1, fcp(100.0, 99.0, 101.0)), (2, fcp(100.5, 99.5, 101.5)),
                (3, fcp(101.6, 101.2, 102.0))]
    assert agree_closures(closures).cycles == (2, 3)
    closures[0] = (1, fcp(100.0, 99.0, 101.0, ("tangent", "sqrt_t", "g_function")))
    assert agree_closures(closures).cycles == (1, 2)


def test_one_cycle_and_no_cycle():
    a = agree_closures([(2, fcp(50.0, 49.0, 51.0))])
    assert a.cycles == (2,) and a.value == 50.0 * BAR and not a.outliers
    none = agree_closures([(1, Pick.not_found("FCP", "consensus", "x"))])
    assert not none.found and none.cycles == ()


def test_disjoint_cycles_rest_on_the_best_founded_one():
    a = agree_closures([(1, fcp(80.0, 79.0, 81.0, ("tangent",), "poor")),
                        (2, fcp(60.0, 59.0, 61.0))])
    assert a.cycles == (2,) and [i for i, _ in a.outliers] == [1]
    assert "no two cycles" in a.message
