"""Intervals with a stated level: the parts (against independent answers) and a small
calibration draw on constructed records with a known truth (the full study is
``benchmarks/interval_calibration.py``, results in docs/intervals.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit.interpret.calibration.records import (
    ConstructedSpec,
    construct_record,
    draw_spec,
    smootherstep,
)
from xlotkit.interpret.calibration.study import evaluate_record, run_study
from xlotkit.interpret.picks.intervals import (
    LEVEL,
    budget,
    corner_profile,
    correlation_inflation,
    find_transition,
    onset_profile,
    z_value,
)

BAR = 1e5


def test_z_value_is_the_normal_quantile():
    assert z_value(0.90) == pytest.approx(1.6448536, rel=1e-6)
    assert z_value(0.95) == pytest.approx(1.9599640, rel=1e-6)
    with pytest.raises(ValueError):
        z_value(1.0)


def test_correlation_inflation_of_ar1_noise():
    # AR(1) with rho = 0.6: the variance of a mean grows by (1 + rho) / (1 - rho) = 4, so
    # the factor is 2; 20000 samples estimate rho to ~0.01 (factor within 5 %).
    rng = np.random.default_rng(1)
    e = rng.normal(size=20000)
    r = np.empty_like(e)
    r[0] = e[0]
    for i in range(1, e.size):
        r[i] = 0.6 * r[i - 1] + e[i]
    assert correlation_inflation(r) == pytest.approx(2.0, rel=0.05)
    assert correlation_inflation(rng.normal(size=5000)) == pytest.approx(1.0, abs=0.05)


def test_budget_adds_random_parts_in_quadrature_and_covers_ranges():
    b = budget(100.0, stderr=1.0, inflation=2.0, trials=[99.0, 101.5],
               transition=(98.0, 100.5), resolution=1.0, extra=[("x", 97.0, 99.0)])
    e = math.hypot(z_value() * 2.0, 1.0)
    assert b.low == pytest.approx(97.0 - e)
    assert b.high == pytest.approx(101.5 + e)
    assert b.level == LEVEL and "transition" in b.describe()


def _kinked(width: float, n: int = 400, noise: float = 0.0, seed: int = 0):
    """Slope -1 then -3 around x = 5 (corner value 0 there), smoothed over ``width``."""
    x = np.linspace(0.0, 10.0, n)
    s = -1.0 - 2.0 * smootherstep((x - 5.0 + width / 2) / max(width, 1e-12))
    y = np.concatenate([[0.0], np.cumsum(0.5 * (s[1:] + s[:-1]) * np.diff(x))])
    # Shift so that the corner of the asymptotes (line 1 through x < 5 - w/2) is y = 0.
    m1 = x < 5.0 - width / 2 - 0.05
    a1 = np.polyfit(x[m1], y[m1], 1)
    y = y - np.polyval(a1, 5.0)
    return x, y + np.random.default_rng(seed).normal(0, noise, n)


def test_find_transition_sees_a_gradual_change_and_not_a_sharp_one():
    x, y = _kinked(0.0, noise=0.01)
    assert find_transition(x, x, y, y, 5.0, 5.0, 5.0, noise=0.01) is None
    x, y = _kinked(2.0, noise=0.01)
    span = find_transition(x, x, y, y, 5.0, 5.0, 5.0, noise=0.01)
    assert span is not None
    # The span of departure lies inside the bend (x 4..6) and contains its middle.
    assert 4.0 - 0.1 <= span[2] < 5.0 < span[3] <= 6.0 + 0.1
    assert span[0] < 0.0 < span[1] + 1.0  # pressures: the corner's level is within reach


@pytest.mark.parametrize("width", [0.0, 1.0, 3.0])
def test_corner_profile_contains_the_corner(width):
    x, y = _kinked(width, noise=0.05, seed=3)
    # A window wide enough that each side reaches its asymptote (bend up to half of it).
    near = (x > 1.5) & (x < 8.5)
    lo, hi, _, _ = corner_profile(x[near], y[near], 5.0, 3.5)
    # The corner of the asymptotes is y = 0. The smooth hinge's bend (a hyperbola) is not
    # the smootherstep's, so the interval may miss by a fraction of the bend's depth below
    # the corner, |s2 - s1| w / 8 (0.75 for w = 3), plus one noise level: allow half of it.
    tol = 0.05 + 0.5 * 2.0 * width / 8.0
    assert lo - tol <= 0.0 <= hi + tol


def test_onset_profile_reaches_back_to_a_parabolic_onset():
    # Line, then a departure (x - 6)^2 below it: detected late, but the onset x0 = 6 and
    # the line's value there (-6) lie in the interval.
    rng = np.random.default_rng(4)
    x = np.linspace(0.0, 10.0, 300)
    y = -x - 0.5 * np.clip(x - 6.0, 0.0, None) ** 2 + rng.normal(0, 0.02, x.size)
    lo, hi, x_lo, x_hi = onset_profile(x, y, -1)
    assert x_lo <= 6.0 <= x_hi and lo <= -6.0 <= hi


def test_a_sharp_noise_free_closure_gives_a_narrow_interval():
    cr = construct_record(ConstructedSpec(transition=0.0, noise=0.0, flowback=(True, False)))
    outs = evaluate_record(cr)
    fb = [o for o in outs if o.quantity == "FCP" and o.method.startswith("flowback")
          and o.cycle == 1 and o.found]
    assert fb
    for o in fb:
        assert o.covered
        assert o.width < 0.01 * cr.spec.sigma_h


def test_constructed_truth_is_consistent():
    # The tangents of V(p) before and after a symmetric transition meet at sigma_h: check
    # on the clean bottom-hole pressure of a flowback (p-V lines, exact returned volume).
    sp = ConstructedSpec(transition=0.03, noise=0.0, flowback=(True, False))
    cr = construct_record(sp)
    assert cr.truth.sigma_h == sp.sigma_h and cr.truth.closure_phase == ("flowback", "shut_in")
    assert cr.truth.t0 == pytest.approx(sp.fbp - sp.reopening)
    kinds = [c.phases[i].kind for c in cr.segmentation.cycles for i in range(len(c.phases))]
    assert kinds.count("flowback") == 1 and kinds.count("pump") == 2


def _binomial_floor(n: int, level: float = 0.90, tail: float = 0.01) -> int:
    """Fewest covered of ``n`` picks a calibrated interval gives with probability > ``tail``:
    at a true coverage ``level`` the number covered is Binomial(n, level), and its
    ``tail`` quantile is the floor (a calibrated interval fails with probability < 1 %)."""
    from scipy.stats import binom

    return int(binom.ppf(tail, n, level))


def test_calibration_small_draw():
    """Coverage of the 90 % intervals on 40 constructed records (the benchmark draws 300).

    Each quantity is held to the binomial floor of its own count (``_binomial_floor``):
    with n picks at a true 90 % coverage the covered count is Binomial(n, 0.9) and falls
    below its 1st percentile with probability 1 %. For the 220 pooled closure picks of this
    draw that is 187 (85.0 %), for the consensus (66 picks) 53 (80 %), ISIP (73) 59 (81 %),
    FBP (40) 31 (77.5 %), Pr and T0 (25 each) 19 (76 %); observed 205, 61, 70, 40, 24, 25
    (with the kink detector; 215 pooled picks, 203 covered, and 65 consensus picks before).
    The cases (closures the data hold), the found rate and the coverage over all cases are
    consistent with the picks, and the consensus's found rate and coverage over all cases
    hold what the 300-record draws measure."""
    res = run_study(40, seed=11)
    rows = {(r.quantity, r.method): r for r in res.summary()}
    closure = [o for o in res.select("FCP") if o.found and o.method != "consensus"]
    assert len(closure) > 150
    assert sum(o.covered for o in closure) >= _binomial_floor(len(closure))
    for key in (("FCP", "consensus"), ("ISIP", "tangent"), ("FBP", "max"),
                ("Pr", "departure"), ("T0", "FBP-Pr")):
        r = rows[key]
        made = r.n_found + r.n_extra
        assert made >= 15, key
        assert r.n_covered >= _binomial_floor(made), (key, r.n_covered, made)
    for (q, _), r in rows.items():
        if q != "LOP":
            assert r.level == LEVEL, (q, r.method)
    # Cases: every consensus truth is a case exactly when the record holds its closure;
    # coverage over all cases counts a case without a pick as a miss.
    cons = res.select("FCP", "consensus")
    assert [o.case for o in cons] == [o.factors["closure_in_data"] for o in cons]
    r = rows[("FCP", "consensus")]
    assert r.n_cases == sum(o.case for o in cons) >= 60
    assert r.coverage_all == pytest.approx(
        sum(o.covered for o in cons if o.case) / r.n_cases)
    assert r.coverage_all <= r.found_rate
    # The found rate and the coverage over all cases the 300-record draws measure (seeds
    # 2024 and 2025, docs/intervals.md: consensus found 89.2 % and 88.9 %, covering 83.9 %
    # of all cases on both), held to their binomial 1st percentile on this draw's cases
    # (77: found >= 62 at 0.889, covered >= 57 at 0.839; before the kink detector the
    # floors were 59 and 54). Observed 66 found, 61 covered (65 and 61 before it).
    found = sum(o.found for o in cons if o.case)
    assert found >= _binomial_floor(r.n_cases, 0.889), (found, r.n_cases)
    covered = sum(o.covered for o in cons if o.case)
    assert covered >= _binomial_floor(r.n_cases, 0.839), (covered, r.n_cases)
    # Deterministic: the same seed gives the same numbers.
    again = run_study(3, seed=11)
    assert [o.value for o in again.outcomes] == [o.value for o in res.outcomes
                                                 if o.record < 3]


def test_a_shutin_that_ends_above_closure_is_no_case():
    # Truncate a constructed shut-in before closure: the generator's truth says the record
    # does not hold the closure, so the study does not count it as a case.
    import dataclasses

    from xlotkit.interpret.calibration.records import _closure_case

    sp = ConstructedSpec(transition=0.01, noise=0.0, flowback=(False, False))
    cr = construct_record(sp)
    assert cr.truth.closure_in_data == (True, True)
    assert all(c > 1.2 for c in cr.truth.closure_contrast)   # the system stiffens
    cyc = cr.segmentation.cycles[0]
    sh = next(ph for ph in cyc.phases if ph.kind == "shut_in")
    pump_stop = cyc.phases[0].t_end
    t_above = float(cr.clean["t"][sh.i0 + np.flatnonzero(
        cr.clean["p_bottomhole"][sh.i0:sh.i1] > sp.sigma_h + sp.transition_width)[-1]])
    cut = dataclasses.replace(cr, clean={"t": cr.clean["t"][cr.clean["t"] < t_above],
                                         "p_bottomhole": cr.clean["p_bottomhole"][
                                             cr.clean["t"] < t_above]})
    in_data, _ = _closure_case(sp, cut, "shut_in", sh.t_start, t_above, pump_stop,
                               pump_stop - cyc.t_start)
    assert not in_data


def test_draw_spec_covers_the_factors():
    rng = np.random.default_rng(0)
    specs = [draw_spec(rng) for _ in range(60)]
    assert {s.gauge for s in specs} == {"bottomhole", "surface"}
    assert {s.leakoff for s in specs} == {"carter", "pressure_dependent", "height_recession",
                                          "wall_leak"}
    tr = [s.transition for s in specs]
    assert 0.002 <= min(tr) and max(tr) <= 0.05
    assert all(s.resolution == BAR for s in specs if s.gauge == "surface")


def test_a_record_without_closure_holds_no_case():
    # closure=False: one compliance throughout and a leak falling smoothly with the pressure
    # above the reservoir's, so nothing happens at sigma_h; both cycles hold no closure.
    sp = ConstructedSpec(transition=0.01, noise=0.0, flowback=(False, True), closure=False)
    cr = construct_record(sp)
    assert cr.truth.closure_in_data == (False, False)
    # The clean shut-in of cycle 1 against G has no slope break: its slope changes by under
    # 5 % between neighbouring spans of 0.1 G (a closure of contrast 1.1 changes it 10 %).
    from xlotkit.interpret.picks.shutin import g_function

    cyc = cr.segmentation.cycles[0]
    sh = next(ph for ph in cyc.phases if ph.kind == "shut_in")
    t, p = cr.clean["t"][sh.i0:sh.i1], cr.clean["p_bottomhole"][sh.i0:sh.i1]
    keep = t > t[0] + 5 * sp.drop_tau
    G = g_function(t[keep] - cyc.phases[0].t_end, cyc.phases[0].t_end - cyc.t_start)
    edges = np.arange(G[0], G[-1], 0.1)
    slopes = [np.polyfit(G[(G >= a) & (G < a + 0.1)], p[keep][(G >= a) & (G < a + 0.1)], 1)[0]
              for a in edges[:-1] if np.sum((G >= a) & (G < a + 0.1)) >= 5]
    ratio = np.array(slopes[1:]) / np.array(slopes[:-1])
    assert np.all(np.abs(ratio - 1.0) < 0.05), ratio
    with pytest.raises(ValueError, match="record without closure"):
        ConstructedSpec(leakoff="pressure_dependent", leak_parameter=2.0, closure=False)


def test_false_find_rate_on_declines_without_closure():
    """Closure picks on 12 records of the calibration draw whose declines hold no closure
    (``closure=False``, 24 declines, half shut-ins and half flowbacks, half on whole-bar
    surface gauges).

    The requirement is a false-find rate of at most 5 %. At a true rate of 5 % the number
    of declines with a consensus closure is Binomial(24, 0.05), above 4 with probability
    under 1 % (``binom.ppf(0.99, 24, 0.05) = 4``): more than 4 false finds fails the test.
    Observed on this draw: 0 (the quick loop ``benchmarks/closure_found_rate.py``: 1 of 80
    declines on seed 8, as with the break scan before issue 19's change)."""
    from scipy.stats import binom

    res = run_study(12, seed=5, draw_kw={"closure": False})
    cons = res.select("FCP", "consensus")
    assert len(cons) == 24
    assert not any(o.case for o in cons)
    false_finds = sum(o.found for o in cons)
    assert false_finds <= int(binom.ppf(0.99, 24, 0.05)) == 4, false_finds
