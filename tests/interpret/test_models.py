"""Fit models: recover known lines and breakpoints, and honest error bars."""

import numpy as np
import pytest

from xlotkit.interpret.picks.models import fit_hinge, fit_line, hinge, intersect


def test_line_fit_recovers_slope_and_error_scales_with_noise():
    rng = np.random.default_rng(1)
    x = np.linspace(0, 10, 200)
    y = 3.0 * x + 2.0 + rng.normal(0, 0.1, x.size)
    f = fit_line(x, y)
    # OLS slope standard error for this design is 0.1/sqrt(sum((x-xbar)^2)) ~ 2.4e-3;
    # 4 sigma keeps the test deterministic-safe for the fixed seed and still tight.
    assert abs(f.slope - 3.0) < 4 * f.slope_stderr
    assert f.slope_stderr == pytest.approx(0.1 / np.sqrt(np.sum((x - x.mean()) ** 2)), rel=0.15)


def test_hinge_fit_finds_breakpoint_within_its_stderr():
    rng = np.random.default_rng(2)
    x = np.linspace(0, 100, 400)
    y = hinge(x, 37.0, 50.0, 0.8, 0.1) + rng.normal(0, 0.05, x.size)
    f = fit_hinge(x, y)
    assert abs(f.x0 - 37.0) < 4 * f.x0_stderr + 1e-9
    assert f.x0_stderr < 1.0
    assert f.s1 == pytest.approx(0.8, rel=0.01) and f.s2 == pytest.approx(0.1, rel=0.05)


def test_intersection_of_two_lines_and_propagated_error():
    rng = np.random.default_rng(3)
    xa = np.linspace(0, 5, 100)
    xb = np.linspace(6, 12, 100)
    a = fit_line(xa, 2 * xa + 1 + rng.normal(0, 0.01, xa.size))
    b = fit_line(xb, -xb + 19 + rng.normal(0, 0.01, xb.size))
    x, sx, y, sy = intersect(a, b)
    assert x == pytest.approx(6.0, abs=4 * sx) and y == pytest.approx(13.0, abs=4 * sy)
    assert 0 < sx < 0.05
