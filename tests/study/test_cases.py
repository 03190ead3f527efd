"""Cases of a sweep: --vary parsing, the grid, Latin-hypercube samples and the dotted-key
overrides on a scene file's mapping (xlotkit.study.cases)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from xlotkit.errors import InputError
from xlotkit.study.cases import (
    BaseScene,
    grid,
    latin_hypercube,
    parse_key,
    parse_vary,
    sample,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
LUMPED = EXAMPLES / "scene_standard.toml"


def test_keys_with_indices():
    k = parse_key("schedule.phase[1].rate")
    assert k.parts == ("schedule", "phase", 1, "rate")
    assert parse_key("seed").parts == ("seed",)
    for bad in ("stresses..sigma_h", "1abc", "rock.perm eability", "a[x]"):
        with pytest.raises(InputError) as e:
            parse_key(bad)
        assert e.value.key == "--vary"


def test_values_are_toml_or_text_with_units():
    v = parse_vary("stresses.sigma_h=28 MPa, 300 bar,3.1e7")
    assert v.values == ("28 MPa", "300 bar", 3.1e7)
    assert parse_vary("effects.pipe_friction=true,false").values == (True, False)
    assert parse_vary('title="a, b"').values == ('"a', 'b"')   # commas always separate
    assert parse_vary("seed=0,1").values == (0, 1)
    # a date-time holds colons but is no range
    (t,) = parse_vary("output.start_time=2026-01-01T08:00:00").values
    assert t.hour == 8


def test_ranges():
    s = parse_vary("stresses.sigma_h=28 MPa:32 MPa").span
    assert (s.low, s.high, s.unit, s.log) == (28.0, 32.0, "MPa", False)
    assert s.at(0.5) == "30.0 MPa"
    # ends in two units: the high end is converted to the low end's (pint)
    s = parse_vary("stresses.sigma_h=280 bar:3.2e7 Pa").span
    assert s.high == pytest.approx(320.0) and s.unit == "bar"
    s = parse_vary("rock.permeability=1e-19:1e-17:log").span
    assert s.log and s.unit == ""
    # log-uniform: the middle of the unit interval is the geometric mean
    assert s.at(0.5) == pytest.approx(1e-18, rel=1e-12)
    for bad in ("rock.permeability=1e-17:1e-19", "rock.permeability=0:1:log",
                "stresses.sigma_h=28 MPa:32 furlongs", "stresses.sigma_h", "x=", "x=1,,2"):
        with pytest.raises(InputError) as e:
            parse_vary(bad)
        assert e.value.key == "--vary"


def test_grid_is_the_full_product_first_key_slowest():
    a = parse_vary("stresses.sigma_h=1,2")
    b = parse_vary("rock.porosity=0.1,0.2,0.3")
    cases = grid([a, b])
    assert [c.index for c in cases] == list(range(6))
    assert [tuple(v for _, v in c.overrides) for c in cases] == [
        (1, 0.1), (1, 0.2), (1, 0.3), (2, 0.1), (2, 0.2), (2, 0.3)]
    assert len(grid([])) == 1            # no --vary: the scene itself
    with pytest.raises(InputError, match="range"):
        grid([parse_vary("stresses.sigma_h=1:2")])
    with pytest.raises(InputError, match="twice"):
        grid([a, a])


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 60), d=st.integers(1, 4), seed=st.integers(0, 2**32))
def test_latin_hypercube_uses_every_stratum_once(n, d, seed):
    u = latin_hypercube(n, d, seed)
    assert u.shape == (n, d) and np.all((u >= 0) & (u < 1))
    for j in range(d):
        # one point in each of the n strata [k/n, (k+1)/n) of every axis
        assert sorted(np.floor(u[:, j] * n).astype(int)) == list(range(n))
    assert np.array_equal(u, latin_hypercube(n, d, seed))       # deterministic


def test_samples_are_deterministic_and_stay_in_their_ranges():
    vs = [parse_vary("stresses.sigma_h=28 MPa:32 MPa"),
          parse_vary("rock.permeability=1e-19:1e-17:log"),
          parse_vary("effects.pipe_friction=true,false")]
    a = sample(vs, 20, seed=3)
    assert a == sample(vs, 20, seed=3)
    assert a != sample(vs, 20, seed=4)
    sh = [float(c.inputs()["stresses.sigma_h"].split()[0]) for c in a]
    k = [c.inputs()["rock.permeability"] for c in a]
    assert all(28 <= x < 32 for x in sh) and all(1e-19 <= x < 1e-17 for x in k)
    # stratified: the 20 sigma_h values fall one in each 0.2 MPa stratum; the permeability
    # one in each twentieth of the decades (log-uniform)
    assert sorted(int((x - 28) / 0.2) for x in sh) == list(range(20))
    assert sorted(int((math.log10(x) + 19) / 0.1) for x in k) == list(range(20))
    # a list is a discrete choice, its strata shared evenly
    assert [c.inputs()["effects.pipe_friction"] for c in a].count(True) == 10
    with pytest.raises(InputError):
        sample(vs, 0, seed=0)
    with pytest.raises(InputError):
        sample([], 5, seed=0)


def test_overrides_change_a_copy_of_the_mapping():
    base = BaseScene.load(LUMPED)
    (case,) = grid([parse_vary("stresses.sigma_h=29 MPa"),
                    parse_vary("schedule.phase[4].rate=400 l/min"),
                    parse_vary("mesh.growth=1.3")])
    m = base.case_mapping(case)
    assert m["stresses"]["sigma_h"] == "29 MPa"
    assert m["schedule"]["phase"][4]["rate"] == "400 l/min"
    assert m["mesh"] == {"growth": 1.3}               # a missing table is made
    assert base.mapping["stresses"]["sigma_h"] == "30 MPa"       # the base is untouched
    assert "mesh" not in base.mapping
    sc = base.scene(grid([parse_vary("stresses.sigma_h=29 MPa"),
                          parse_vary("schedule.phase[4].rate=400 l/min")])[0])
    assert sc.stresses.sigma_h == pytest.approx(29e6)
    assert sc.schedule.phases[4].rate == pytest.approx(0.4 / 60)


@pytest.mark.parametrize("vary, key, what", [
    ("stresses.sigmah=29 MPa", "--vary stresses.sigmah", "unknown key"),
    ("stresses.sigma_h=29 furlongs", "--vary stresses.sigma_h", ""),
    ("rock.porosity=1.5", "--vary rock.porosity", "out of range"),
    ("schedule.phase[40].rate=1", "--vary", "past the end"),
    ("stresses.sigma_h.x=1", "--vary", "not a table"),
])
def test_a_bad_key_or_value_is_one_error_naming_it(vary, key, what):
    base = BaseScene.load(LUMPED)
    with pytest.raises(InputError) as e:
        base.scene(grid([parse_vary(vary)])[0])
    assert e.value.key == key
    assert what in e.value.message


def test_a_cross_check_failing_names_the_case():
    # sigma_h varied above the scene's sigma_H: the error is the scene's own cross-check,
    # on stresses.sigma_H, with the case's values
    base = BaseScene.load(LUMPED)
    with pytest.raises(InputError) as e:
        base.scene(grid([parse_vary("stresses.sigma_h=36 MPa")])[0])
    assert e.value.key == "stresses.sigma_H"
    assert "case 0: stresses.sigma_h = '36 MPa'" in e.value.message
