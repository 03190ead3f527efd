"""Scenes: loading, validation messages, model choice, conversion to the lumped model."""

from __future__ import annotations

import dataclasses
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from xlotkit import InputError
from xlotkit.sim.lumped import load_lumped_scene, simulate_lumped
from xlotkit.sim.scene import (
    SCENE_KEYS,
    Rock,
    Scene,
    Stresses,
    carter_coefficient,
    load_scene,
    scene_from_dict,
    scene_reference_markdown,
)

ROOT = Path(__file__).resolve().parents[2]
EX = ROOT / "examples"
PHASES = {"phase": [{"kind": "pump", "rate": "500 l/min", "volume": "1 m3"},
                    {"kind": "shut_in", "duration": "5 min"}]}


def _scene(**sections) -> dict:
    return {**sections, "schedule": PHASES}


def _bare(sc: Scene) -> Scene:
    return dataclasses.replace(sc, given=frozenset(), source_text=None, source_file=None)


def test_lumped_format_file_loads_and_simulates_identically():
    sc = load_scene(EX / "lumped_standard.toml")
    assert sc.resolved_model == "lumped" and sc.model == "lumped"
    a = simulate_lumped(sc.to_lumped()).record
    b = simulate_lumped(load_lumped_scene(EX / "lumped_standard.toml")).record
    assert np.array_equal(a.pressure, b.pressure)
    assert np.array_equal(a.channels["surface_pressure"], b.channels["surface_pressure"])
    assert np.array_equal(a.return_volume, b.return_volume)


def test_new_format_example_is_the_lumped_standard_scene():
    new = load_scene(EX / "scene_standard.toml").to_lumped()
    old = load_lumped_scene(EX / "lumped_standard.toml")
    assert new.replace(noise=0.0, resolution=0.0, start_time=None) == old
    assert new.noise == pytest.approx(5e3) and new.resolution == pytest.approx(1e3)


def test_to_toml_round_trip():
    for f in ("scene_standard.toml", "scene_2d_heterogeneous.toml", "lumped_standard.toml",
              "scene_2d_standard.toml"):
        sc = load_scene(EX / f)
        back = scene_from_dict(tomllib.loads(sc.to_toml()))
        assert _bare(back) == _bare(sc), f


def test_defaults_and_units():
    sc = scene_from_dict(_scene(rock={"permeability": "2 mD"},
                                completion={"depth": "1500 m"}, fluid={"viscosity": "1 cP"}))
    assert sc.rock.permeability == pytest.approx(2 * 9.869233e-16)
    assert sc.completion_model().length_md == 1500.0
    assert sc.fluid.viscosity == pytest.approx(1e-3)
    assert sc.stresses == Stresses() and sc.resolved_model == "lumped"
    sc = scene_from_dict(_scene(model="mdem", rock={"friction_angle": "0.5 rad"}))
    assert sc.rock.friction_angle == pytest.approx(np.degrees(0.5))


@pytest.mark.parametrize("sections, key, value, allowed", [
    ({"rock": {"permeability": "5000 darcy"}}, "rock.permeability", "'5000 darcy'",
     "[0, 1e-09] m^2"),
    ({"rock": {"poisson_ratio": 0.5}}, "rock.poisson_ratio", "0.5", "[0, 0.5)"),
    ({"geometry": {"hole_radius": "-1 m"}}, "geometry.hole_radius", "'-1 m'",
     "[0.02, 0.6] m"),
    ({"output": {"noise": "-1 bar"}}, "output.noise", "'-1 bar'", "[0, 1e+06] Pa"),
    ({"numerics": {"checkpoint_steps": 0}}, "numerics.checkpoint_steps", "0",
     "[1, 1e+09]"),
    ({"stresses": {"sigma_H": "20 MPa"}}, "stresses.sigma_H", "'20 MPa'", ">= sigma_h"),
    ({"stresses": {"pore_pressure": "31 MPa"}}, "stresses.pore_pressure", "'31 MPa'",
     "< sigma_h"),
    ({"numerics": {"n1": 20, "n2": 5}}, "numerics.n1", "20", "<= n2"),
    ({"mesh": {"jitter": 0.5}}, "mesh.jitter", "0.5", "[0, 0.3]"),
    ({"model": "fem"}, "model", "'fem'", "'auto' or 'lumped' or 'mdem'"),
    ({"completion": {"pipe_od": "14 in"}}, "completion.pipe_od", "'14 in'", "[0, 0.32"),
])
def test_validation_error_names_file_key_value_and_range(sections, key, value, allowed):
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(**sections), file="scene.toml")
    e = ei.value
    assert e.file == "scene.toml" and e.key == key
    text = str(e)
    assert text.startswith(f"scene.toml: {key}: ")
    assert value in text and allowed in text


def test_unknown_keys_list_the_allowed_ones():
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(rock={"permeabilty": 1e-18}), file="s.toml")
    assert ei.value.key == "rock.permeabilty"
    assert all(k in ei.value.expected for k in SCENE_KEYS["rock"])
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(stress_field={"x": 1}), file="s.toml")
    assert ei.value.key == "stress_field" and "stresses" in ei.value.expected
    with pytest.raises(InputError) as ei:
        scene_from_dict({"rock": {}}, file="s.toml")
    assert ei.value.key == "schedule"
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(schedule=None) | {"schedule": {"phase": [
            {"kind": "pump", "rate": "-5 l/min", "volume": 1.0}]}}, file="s.toml")
    assert ei.value.key == "schedule.phase[0].rate"


def test_mesh_file_must_exist(tmp_path):
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(mesh={"file": "nope.msh"}), file=str(tmp_path / "s.toml"))
    assert ei.value.key == "mesh.file" and "nope.msh" in ei.value.message
    (tmp_path / "m.vtu").write_text("x")
    sc = scene_from_dict(_scene(mesh={"file": "m.vtu"}), file=str(tmp_path / "s.toml"))
    assert sc.mesh.file == str(tmp_path / "m.vtu") and sc.resolved_model == "mdem"


def test_wrong_unit_dimension_is_reported():
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(lumped={"toughness": "3 MPa"}), file="s.toml")
    assert ei.value.key == "lumped.toughness" and "dimension" in str(ei.value)


def test_toml_syntax_error_has_the_line(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text("[rock]\nyoungs_modulus = = 3\n")
    with pytest.raises(InputError) as ei:
        load_scene(f)
    assert ei.value.line == 2 and ei.value.file == str(f)


@pytest.mark.parametrize("sections, reason", [
    ({"mesh": {"growth": 1.3}}, "mesh"),
    ({"effects": {"heterogeneity": True}}, "effects.heterogeneity"),
    ({"effects": {"poroelastic": True}}, "effects.poroelastic"),
    ({"effects": {"shear_dilation": True}, "rock": {"dilation_angle": "5 deg"}},
     "effects.shear_dilation"),
    ({"effects": {"strength_scaling": True}}, "effects.strength_scaling"),
    ({"effects": {"interface": [{"start": [1, -1], "end": ["1 m", "1 m"]}]}},
     "effects.interface"),
    ({"coupling": "wfd"}, "coupling"),
])
def test_auto_model_picks_mdem_for_2d_physics(sections, reason):
    sc = scene_from_dict(_scene(**sections))
    assert sc.resolved_model == "mdem" and reason in sc.two_d_reasons
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(**sections, model="lumped"), file="s.toml")
    assert ei.value.key == reason and "lumped" in ei.value.message


def test_auto_model_picks_lumped_without_2d_physics():
    sc = scene_from_dict(_scene(effects={"pipe_friction": True, "well_storage": False}))
    assert sc.resolved_model == "lumped" and sc.two_d_reasons == ()
    ls = sc.to_lumped()
    assert ls.pipe_friction
    # without well storage only the open hole stores fluid
    oh = np.pi * 0.15**2 * 10.0 * sc.fluid.compressibility
    assert ls.c_well == pytest.approx(oh)
    # a 2D key without its effect does not ask for the 2D model: it is refused, not ignored
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(rock={"heterogeneity": 0.5}), file="s.toml")
    assert ei.value.key == "rock.heterogeneity" and "effects.heterogeneity" in str(ei.value)


def test_leakoff_derived_from_the_rock():
    sc = scene_from_dict(_scene(rock={"permeability": "1 mD", "porosity": 0.2}))
    ls = sc.to_lumped()
    k, phi, mu, cf, dp = 9.869233e-16, 0.2, 0.01, sc.fluid.compressibility, 10e6
    cv = np.sqrt(k * phi * dp / (2 * mu))
    cc = dp * np.sqrt(k * phi * cf / (np.pi * mu))
    assert ls.leakoff_coefficient == pytest.approx(2 * cv * cc / (cv + np.sqrt(cv**2 + 4 * cc**2)))
    assert ls.leakoff_coefficient < min(cv, cc)
    assert ls.wall_leak_index == pytest.approx(2 * np.pi * k * 10.0 / (mu * np.log(10.0)))
    assert carter_coefficient(0.0, 0.1, 1e-9, 1e-3, 1e7) == 0.0


def test_seeds_default_to_the_master_seed_and_with_seed_overrides():
    sc = scene_from_dict(_scene(seed=5, output={"seed": 9, "noise": "0.05 bar"},
                                mesh={"jitter": 0.1}, effects={"heterogeneity": True}))
    assert (sc.mesh_seed, sc.rock_seed, sc.noise_seed) == (5, 5, 9)
    s2 = sc.with_seed(11)
    assert (s2.mesh_seed, s2.rock_seed, s2.noise_seed) == (11, 11, 11)
    assert s2.to_lumped().seed == 11


def test_python_construction_is_validated_too():
    with pytest.raises(InputError) as ei:
        Rock(porosity=1.5)
    assert ei.value.key == "rock.porosity" and "(0, 1)" in ei.value.expected


def test_docs_list_every_key():
    doc = (ROOT / "docs" / "simulate.md").read_text()
    ref = scene_reference_markdown()
    assert ref in doc, "docs/simulate.md is out of date: paste scene_reference_markdown()"
    for sec, keys in SCENE_KEYS.items():
        for k in keys:
            assert re.search(rf"\| `{re.escape(k)}` \|", ref), (sec, k)


def test_standard_2d_scene_is_the_example_file():
    from xlotkit.sim.scene import standard_2d_scene

    pkg = ROOT / "src" / "xlotkit" / "sim" / "scenes" / "standard_2d.toml"
    assert pkg.read_text() == (EX / "scene_2d_standard.toml").read_text()
    sc = standard_2d_scene()
    assert sc.resolved_model == "mdem"
    # the free path: no crack strip, no preset plane; every failed cluster its own plane
    assert not sc.effects.fracture_plane and not sc.mesh.band_strip
    assert sc.mesh.fracture_band and sc.rock.crack_plane == "stress"
    assert sc.rock.closure_law == "smooth" and sc.rock.toughness == 1e6


def test_fracture_plane_and_toughness_are_checked():
    with pytest.raises(InputError, match="effects.fracture_plane"):
        scene_from_dict(_scene(effects={"fracture_plane": True}))
    with pytest.raises(InputError, match="rock.strength_scaling_exponent"):
        scene_from_dict(_scene(rock={"toughness": "1 MPa*m**0.5",
                                     "strength_scaling_exponent": 0.3}))
    sc = scene_from_dict(_scene(mesh={"fracture_band": True, "band_strip": True},
                                effects={"fracture_plane": True},
                                rock={"fracture_friction_angle": "5 deg"}))
    assert sc.rock.fracture_friction_angle == 5.0 and sc.resolved_model == "mdem"


@pytest.mark.parametrize("sections, found", [
    ({"effects": {"shear_dilation": True}}, "needs a dilation angle"),
    ({"rock": {"dilation_angle": "5 deg"}}, "only used with shear dilation"),
])
def test_dilation_angle_and_shear_dilation_come_together(sections, found):
    """Neither is accepted without the other: a dilation angle with dilation off would be
    read and ignored, dilation without an angle would need an invented one."""
    with pytest.raises(InputError) as ei:
        scene_from_dict(_scene(**sections), file="s.toml")
    assert ei.value.key == "rock.dilation_angle" and found in ei.value.message


def test_dilation_angle_reaches_the_model():
    from xlotkit.sim.coupling.build import build_model

    d = _scene(effects={"shear_dilation": True}, rock={"dilation_angle": "8 deg"},
               mesh={"growth": 1.3})
    model, _ = build_model(scene_from_dict(d))
    assert model.dilation_angle == pytest.approx(np.radians(8.0), rel=1e-12)
    model_off, _ = build_model(scene_from_dict(_scene(mesh={"growth": 1.3})))
    assert model_off.dilation_angle is None


# ----------------------------------------------------------------------------- issue 17
def _error(sections=None, schedule=None, file="s.toml") -> InputError:
    d = _scene(**(sections or {}))
    if schedule is not None:
        d["schedule"] = schedule
    with pytest.raises(InputError) as ei:
        scene_from_dict(d, file=file)
    e = ei.value
    assert e.file == file and str(e).startswith(f"{file}: {e.key}: ") and e.expected
    return e


@pytest.mark.parametrize("value", ["3 mPa", "3 Mbar"])
def test_a_unit_whose_case_decides_is_refused(value):
    """'3 mPa' is a millipascal in SI case and a megapascal as field logs write 'mpa': it
    was read as 3 MPa; now refused as ambiguous, naming the key, the value and the range."""
    e = _error({"rock": {"tensile_strength": value}})
    assert e.key == "rock.tensile_strength" and "ambiguous" in e.message
    assert repr(value) in e.message and "[1000, 1e+08] Pa" in e.expected
    assert scene_from_dict(_scene(rock={"tensile_strength": "3 MPa"})).rock.tensile_strength \
        == 3e6
    assert scene_from_dict(_scene(rock={"tensile_strength": "3 mpa"})).rock.tensile_strength \
        == 3e6                                           # a field spelling, unambiguous
    e = _error({"rock": {"permeability": "1 MD"}})
    assert e.key == "rock.permeability" and "ambiguous" in e.message


def test_an_implausible_strength_is_refused():
    e = _error({"rock": {"tensile_strength": 0.003}})
    assert e.key == "rock.tensile_strength" and "without a unit is SI: Pa" in e.message
    assert scene_from_dict(_scene(rock={"tensile_strength": 0})).rock.tensile_strength == 0.0
    e = _error({"rock": {"cohesion": "5 Pa"}})
    assert e.key == "rock.cohesion" and "0 or a number in [1000" in e.expected


@pytest.mark.parametrize("rate", [0.5, 500])
def test_a_unitless_rate_is_si_and_refused_when_implausible(rate):
    e = _error(schedule={"phase": [{"kind": "pump", "rate": rate, "volume": "1 m3"}]})
    assert e.key == "schedule.phase[0].rate"
    assert f"{float(rate)!r} m^3/s" in e.message and "without a unit is read in SI" in e.message
    assert "(0, 0.1] m^3/s" in e.expected


def test_a_phase_with_volume_and_duration_is_refused():
    e = _error(schedule={"phase": [{"kind": "pump", "rate": "500 l/min", "volume": "1 m3",
                                    "duration": "2 min"}]})
    assert e.key == "schedule.phase[0].volume" and "duration" in e.message
    e = _error(schedule={"phase": [{"kind": "pump", "rate": "500 l/min", "volume": "1 m3"},
                                   {"kind": "bleed", "rate": "100 l/min", "volume": "0.2 m3",
                                    "duration": "1 min"}]})
    assert e.key == "schedule.phase[1].volume"


def test_a_flowback_target_above_the_pressure_it_starts_at_is_refused(tmp_path):
    # statically: after a pump that stops at 40 MPa
    e = _error(schedule={"phase": [
        {"kind": "pump", "rate": "500 l/min", "pressure_above": "40 MPa"},
        {"kind": "flowback", "initial_rate": "300 l/min", "pressure_below": "60 MPa"}]})
    assert e.key == "schedule.phase[1].pressure_below" and "4e+07" in e.expected
    # in a run: the flowback would start below its target and end at once
    from xlotkit.sim.run import simulate

    sc = scene_from_dict(_scene() | {"schedule": {"phase": [
        {"kind": "pump", "rate": "500 l/min", "volume": "0.5 m3"},
        {"kind": "flowback", "initial_rate": "300 l/min", "pressure_below": "60 MPa"}]}},
        file="s.toml")
    with pytest.raises(InputError) as ei:
        simulate(sc, tmp_path / "run")
    e = ei.value
    assert e.key == "schedule.phase[1].pressure_below" and e.file == "s.toml"
    assert "already below its pressure_below = 60.000 MPa" in e.message
    assert "phase 2 (cycle 1) (flowback) starts at" in e.message
    assert e.message.startswith("the run failed at t = ")


def test_a_band_longer_than_the_domain_is_refused():
    e = _error({"geometry": {"domain_size": "50 m"},
                "mesh": {"fracture_band": True, "band_length": "80 m"}})
    assert e.key == "mesh.band_length" and "(0.15, 25] m" in e.expected
    e = _error({"geometry": {"domain_size": "50 m"},
                "mesh": {"fracture_band": True, "band_width": "0.1 m",
                         "band_element_size": "0.5 m"}})
    assert e.key == "mesh.band_width"
    # the default band reaches 10 m, or the domain's edge in a smaller domain
    sc = scene_from_dict(_scene(geometry={"domain_size": "4 m"},
                                mesh={"fracture_band": True}))
    assert sc.band_length == 2.0


def test_wall_and_domain_sizes_are_cross_checked():
    e = _error({"mesh": {"wall_element_size": "0.2 m"}})
    assert e.key == "mesh.wall_element_size" and "hole radius" in e.message
    e = _error({"mesh": {"wall_element_size": "1e-4 m"}})
    assert e.key == "mesh.wall_element_size" and "2048" in e.message
    e = _error({"geometry": {"domain_size": "2 m", "hole_radius": "0.15 m"}, "mesh": {}})
    assert e.key == "geometry.hole_radius" and "domain_size / 20" in e.expected
    e = _error({"mesh": {"max_element_size": "80 m"}})
    assert e.key == "mesh.max_element_size"


def test_an_implausible_well_compliance_is_refused():
    e = _error({"completion": {"well_compliance": 1e-30}})
    assert e.key == "completion.well_compliance" and "[1e-13, 1e-05] m^3/Pa" in e.expected
    # below the open hole's own fluid storage c_f pi r^2 h (lumped: the open-hole length)
    e = _error({"completion": {"well_compliance": 1e-12}})
    own = 4.2735042735042736e-10 * np.pi * 0.15**2 * 10.0
    assert e.key == "completion.well_compliance" and f"{own:.4g}" in e.message
    e = _error({"completion": {"well_compliance": 1e-8}, "effects": {"well_storage": False}})
    assert e.key == "completion.well_compliance" and "well_storage" in e.message


def test_a_key_the_model_does_not_read_is_refused():
    e = _error({"rock": {"cohesion": "10 MPa"}})                 # lumped scene
    assert e.key == "rock.cohesion" and "2D model" in e.message
    e = _error({"model": "mdem", "lumped": {"toughness": "1 MPa*m**0.5"}})
    assert e.key == "lumped.toughness" and "lumped model" in e.message
    e = _error({"effects": {"pipe_friction": False}, "completion": {"roughness": "0.1 mm"}})
    assert e.key == "completion.roughness" and "pipe_friction" in e.expected
    e = _error({"output": {"seed": 3}})
    assert e.key == "output.seed" and "noise" in e.expected
    # what Scene.to_toml writes loads back: only keys the model reads
    sc = scene_from_dict(_scene(model="mdem", mesh={"growth": 1.3}))
    text = sc.to_toml()
    assert "[lumped]" not in text and "band_width" not in text and "biot" not in text
    assert _bare(scene_from_dict(tomllib.loads(text))) == _bare(sc)
