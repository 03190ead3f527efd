"""Lumped XLOT model (xlotkit.sim.lumped): physics checks, balance, determinism, validation."""

from pathlib import Path

import numpy as np
import pytest

from xlotkit import InputError, Record
from xlotkit.sim.lumped import (
    LumpedScene,
    fracture_compliance,
    load_lumped_scene,
    reopening_pressure,
    simulate_lumped,
    standard_lumped_scene,
)
from xlotkit.sim.schedule import Flowback, Pump, Schedule, ShutIn

Q = 0.5 / 60.0  # 500 l/min


@pytest.fixture(scope="module")
def standard():
    return simulate_lumped(standard_lumped_scene())


def test_standard_scene_is_a_two_cycle_xlot(standard):
    r = standard
    sc = standard_lumped_scene()
    tr = r.truth
    assert r.status == "ok"
    assert isinstance(r.record, Record) and r.record.reference.kind == "bottomhole"
    assert tr["fbp"] == pytest.approx(sc.breakdown_pressure, abs=1.0)
    # FPP/ISIP above sigma_h by the toughness net pressure; both cycles close at sigma_h.
    for cyc in (1, 2):
        assert sc.sigma_h + 0.3e6 < tr["isip"][cyc] < sc.sigma_h + 2e6
    assert len(tr["closure_times"]) == 2 and len(tr["reopening_times"]) == 1
    kinds = [(p["cycle"], p["kind"]) for p in tr["phases"]]
    assert kinds == [(1, "pump"), (1, "shut_in"), (1, "flowback"), (1, "shut_in"),
                     (2, "pump"), (2, "shut_in"), (2, "flowback")]
    # cycle 2 shut-in ends on its pressure condition after closure (decline reaches closure)
    assert tr["phases"][5]["end"] == "pressure_below"
    assert tr["phases"][5]["t_start"] < tr["closure_times"][1] < tr["phases"][5]["t_end"]
    for name in ("surface_pressure", "fracture_length", "fracture_volume"):
        assert r.record.channels[name].shape == r.record.t.shape
    assert r.record.meta["sigma_h"] == sc.sigma_h
    assert np.all(np.diff(r.record.t) == pytest.approx(1.0))


def test_mass_balance_closes_every_step(standard):
    tr = standard.truth
    # Each step's integrated volume balance is solved with Brent's method to round-off:
    # measured max ~1e-11 relative to the step's volume turnover.
    assert tr["mass_balance_error"].max() < 1e-8
    assert np.abs(tr["mass_balance_cumulative"]).max() < 1e-10


def _scene(schedule, **kw):
    # no leak-off and no entry loss: the closed forms below have one pressure and no leak
    base = dict(schedule=schedule, leakoff_coefficient=0.0, wall_leak_index=0.0,
                nwb_coefficient=0.0)
    base.update(kw)
    return standard_lumped_scene(**base)


def test_pressurisation_slope_is_q_over_cw():
    sc = _scene(Schedule([Pump(Q, pressure_above=35e6)]))
    r = simulate_lumped(sc)
    rec = r.record
    m = rec.t < r.truth["phases"][0]["t_end"] - 1.0
    slope = np.polyfit(rec.t[m], rec.pressure[m], 1)[0]
    # Before breakdown only well storage acts: exactly linear (required: within 0.5 %).
    assert slope == pytest.approx(Q / sc.c_well, rel=1e-9)


def test_breakdown_at_hubbert_willis_pressure():
    sc = _scene(Schedule([Pump(Q, volume=1.5)]))
    r = simulate_lumped(sc)
    tr = r.truth
    pb = 3 * 30e6 - 35e6 - 20e6 + 3e6
    assert sc.breakdown_pressure == pb
    assert tr["fbp"] == pytest.approx(pb, abs=1.0)
    assert r.record.pressure.max() <= pb + 1.0
    # time to breakdown from pure storage
    assert tr["breakdown_time"] == pytest.approx(sc.c_well * (pb - sc.p_initial) / Q,
                                                 rel=1e-8)
    # the fracture is then longer than the stable length and pressure dropped near sigma_h
    assert tr["fracture_length"].max() > tr["stable_length"]
    assert r.record.pressure[-1] < sc.sigma_h + 2e6


def test_tough_rock_initiates_at_pb_and_breaks_down_later():
    # K_I(P_b, L0) < K_Ic: the flaw opens at P_b (LOP-like) and runs away at
    # sigma_h + dp_c(L0) > P_b.
    sc = _scene(Schedule([Pump(Q, volume=2.0)]), toughness=5e6)
    tr = simulate_lumped(sc).truth
    dpc0 = 0.5 * np.pi * 5e6 / np.sqrt(np.pi * 0.15)
    assert tr["initiation_pressure"] == pytest.approx(sc.breakdown_pressure, abs=1.0)
    assert tr["fbp"] == pytest.approx(sc.sigma_h + dpc0, rel=1e-6)


def test_closure_exactly_at_sigma_h_with_stiffness_kink():
    # no leak-off: every returned m^3 comes from well storage or the fracture
    sched = Schedule([Pump(Q, volume=2.0), ShutIn(duration=60.0),
                      Flowback(initial_rate=Q, pressure_below=27e6)])
    sc = _scene(sched)
    r = simulate_lumped(sc)
    tr = r.truth
    assert len(tr["closure_times"]) == 1
    t_c = tr["closure_times"][0]
    it = np.searchsorted(tr["t"], t_c)
    assert tr["pressure"][it] == pytest.approx(sc.sigma_h, abs=1e-2)
    rec = r.record
    fb = tr["phases"][2]
    L = tr["fracture_length"][-1]
    c_f = fracture_compliance(L, "penny", sc.e_prime)
    before = (rec.t > fb["t_start"] + 1) & (rec.t < t_c - 1)
    after = (rec.t > t_c + 1) & (rec.t <= fb["t_end"])
    s_before = -np.polyfit(rec.return_volume[before], rec.pressure[before], 1)[0]
    s_after = -np.polyfit(rec.return_volume[after], rec.pressure[after], 1)[0]
    # system stiffness: open fracture 1/(C_w + dV_f/dp), closed 1/C_w (exact in the model)
    assert s_before == pytest.approx(1 / (sc.c_well + c_f), rel=1e-9)
    assert s_after == pytest.approx(1 / sc.c_well, rel=1e-9)


def test_no_closure_when_flowback_is_short():
    sched = Schedule([Pump(Q, volume=2.0), ShutIn(duration=120.0),
                      Flowback(initial_rate=0.2 / 60, duration=20.0), ShutIn(duration=60.0)])
    sc = _scene(sched, leakoff_coefficient=1e-5)
    r = simulate_lumped(sc)
    assert r.truth["closure_times"] == []
    after = r.record.t >= r.truth["breakdown_time"] + 1
    assert np.all(r.record.pressure[after] > sc.sigma_h)


def test_deterministic_for_same_seed_and_noise_applied():
    sc = standard_lumped_scene(noise=2e4, resolution=1e4, seed=7)
    a, b = simulate_lumped(sc).record, simulate_lumped(sc).record
    np.testing.assert_array_equal(a.pressure, b.pressure)
    np.testing.assert_array_equal(a.channels["surface_pressure"],
                                  b.channels["surface_pressure"])
    c = simulate_lumped(sc.replace(seed=8)).record
    assert not np.array_equal(a.pressure, c.pressure)
    assert np.allclose(np.round(a.pressure / 1e4) * 1e4, a.pressure)
    clean = simulate_lumped(standard_lumped_scene()).record
    assert np.std(a.pressure - clean.pressure) == pytest.approx(2e4, rel=0.15)


def test_progress_callback_is_monotone_and_finishes():
    seen = []
    simulate_lumped(standard_lumped_scene(), progress=seen.append)
    assert seen and seen[-1] == 1.0 and all(np.diff(seen) >= 0)


def test_kgd_geometry_runs_and_balances():
    r = simulate_lumped(standard_lumped_scene(geometry="kgd", toughness=1.5e6))
    assert r.status == "ok"
    assert r.truth["mass_balance_error"].max() < 1e-8


def test_pipe_friction_separates_surface_pressure_when_pumping():
    on = simulate_lumped(standard_lumped_scene(pipe_friction=True)).record
    off = simulate_lumped(standard_lumped_scene()).record
    i = 60  # pressurising at 500 l/min: surface pressure higher by the friction loss
    dp = on.channels["surface_pressure"][i] - off.channels["surface_pressure"][i]
    assert 0.05e6 < dp < 1e6
    assert on.pressure[i] == pytest.approx(off.pressure[i])


def test_phase_that_never_ends_is_stopped_with_message():
    sched = Schedule([Pump(Q, volume=0.2), ShutIn(pressure_below=1e6)])
    r = simulate_lumped(_scene(sched, max_phase_duration=100.0))
    assert r.status == "stopped" and "max_phase_duration" in r.message


@pytest.mark.parametrize("kw,key", [
    (dict(sigma_H=25e6), "sigma_H"),
    (dict(poisson_ratio=0.6), "poisson_ratio"),
    (dict(geometry="radial"), "geometry"),
    (dict(toughness=0.0), "toughness"),
    (dict(dt=0.0), "dt"),
    (dict(fluid_compressibility=1e-9), "fluid_compressibility"),
    (dict(initial_pressure=40e6), "initial_pressure"),
    (dict(colour="red"), "colour"),
    (dict(reopening="hoop"), "reopening"),
    (dict(nwb_coefficient=-1.0), "nwb_coefficient"),
])
def test_validation_errors_name_the_key(kw, key):
    with pytest.raises(InputError) as exc:
        standard_lumped_scene(**kw)
    assert exc.value.key == key, str(exc.value)


def test_scene_requires_a_schedule():
    with pytest.raises(InputError) as exc:
        LumpedScene(schedule=[Pump(Q, volume=1.0)])
    assert exc.value.key == "schedule"


# ------------------------------------------------------------------ reopening at the wall
def test_reopening_pressure_formula_and_its_floor_at_sigma_h():
    assert reopening_pressure(30e6, 35e6, 20e6) == 35e6           # 3 sh - sH - p0 (C.13)
    # sigma_H > 2 sigma_h - p0: the wall's hoop stress is below sigma_h -> sigma_h
    assert reopening_pressure(30e6, 45e6, 20e6) == 30e6
    assert reopening_pressure(30e6, 35e6, 20e6, "sigma_h") == 30e6


def test_standard_scene_recovers_t0_from_fbp_minus_reopening(standard):
    sc = standard_lumped_scene()
    tr = standard.truth
    assert sc.reopening == "wellbore"
    assert tr["reopening_pressure_model"] == pytest.approx(35e6)
    assert tr["reopening_pressures"][0] == pytest.approx(35e6, abs=1.0)  # event: ~1e-5 Pa
    assert tr["fbp"] - tr["reopening_pressures"][0] == pytest.approx(3e6, rel=0.01)
    # from the record alone (0.05 s samples): the two cycle peaks; each sample is at most
    # one interval (~6 kPa at Q/C_w) below its peak, so T0 is within ~0.4 %
    fine = simulate_lumped(sc.replace(dt=0.05)).record
    cyc2 = fine.t >= tr["phases"][4]["t_start"]
    t0 = fine.pressure[~cyc2].max() - fine.pressure[cyc2].max()
    assert t0 == pytest.approx(sc.tensile_strength, rel=0.01)
    assert standard.record.meta["reopening_pressure_model"] == pytest.approx(35e6)


def test_reopening_at_sigma_h_still_available():
    r = simulate_lumped(standard_lumped_scene(reopening="sigma_h"))
    tr = r.truth
    assert tr["reopening_pressure_model"] == 30e6
    assert tr["reopening_pressures"][0] == pytest.approx(30e6, abs=1.0)
    # the second cycle then never sees P_r: its peak is the propagation pressure
    cyc2 = r.record.t >= tr["phases"][4]["t_start"]
    assert r.record.pressure[cyc2].max() < 32e6
    assert tr["mass_balance_error"].max() < 1e-8


def test_entry_loss_keeps_closure_on_the_fracture_pressure(standard):
    tr = standard.truth
    sh = 30e6
    for tc in tr["closure_times"]:
        i = np.searchsorted(tr["t"], tc)
        # the fracture closes at sigma_h (event tolerance 1e-10 s; 1 mPa is generous) and
        # with no inflow to the fracture the well sees the same pressure
        assert tr["fracture_pressure"][i] == pytest.approx(sh, abs=1e-2)
        assert tr["pressure"][i] == pytest.approx(sh, abs=1e3)
    # ISIP below the last pumping pressure by k Q_f^2 (~3 bar at ~500 l/min into the crack)
    for cyc in (1, 2):
        drop = tr["last_pump_pressure"][cyc] - tr["isip"][cyc]
        assert 0.25e6 < drop < 0.31e6


# ------------------------------------------------------------------ scene files
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lumped_standard.toml"


def test_example_toml_is_the_standard_scene():
    a = load_lumped_scene(EXAMPLE)
    b = standard_lumped_scene()
    for name in ("sigma_h", "sigma_H", "pore_pressure", "tensile_strength", "youngs_modulus",
                 "toughness", "geometry", "reopening", "nwb_coefficient", "density",
                 "viscosity", "leakoff_coefficient", "wall_leak_index", "dt", "seed"):
        va, vb = getattr(a, name), getattr(b, name)
        assert va == (vb if isinstance(vb, str) else pytest.approx(vb, rel=1e-15)), name
    ra, rb = simulate_lumped(a), simulate_lumped(b)
    # "500 l/min" through pint is 1 ulp off 0.5/60: round-off-level differences only
    np.testing.assert_allclose(ra.record.pressure, rb.record.pressure, rtol=0, atol=1e-3)
    assert [p["end"] for p in ra.truth["phases"]] == [p["end"] for p in rb.truth["phases"]]


def _toml(tmp_path, text):
    f = tmp_path / "scene.toml"
    f.write_text(text)
    return f


_MIN = """
[stress]
sigma_h = "30 MPa"
sigma_H = "35 MPa"
pore_pressure = "200 bar"
[schedule]
[[schedule.phase]]
kind = "pump"
rate = "500 l/min"
volume = "1 m3"
"""


def test_from_dict_units_and_defaults(tmp_path):
    sc = load_lumped_scene(_toml(tmp_path, _MIN + '[fluid]\nviscosity = "10 cP"\n'
                                 '[rock]\ntoughness = "3 MPa*m**0.5"\n'))
    assert sc.pore_pressure == pytest.approx(20e6)
    assert sc.viscosity == pytest.approx(0.01)
    assert sc.toughness == pytest.approx(3e6)
    assert sc.schedule.phases[0].rate == pytest.approx(Q)
    assert sc.completion is None


@pytest.mark.parametrize("extra,key", [
    ('[stress.extra]\nsigma_X = 1\n', "stress.extra"),
    ('[rocks]\nE = 1\n', "rocks"),
    ('[output]\nseed = 1.5\n', "output.seed"),
    ('[rock]\nyoungs_modulus = "6 m"\n', "rock.youngs_modulus"),
    ('[rock]\npoisson_ratio = 0.7\n', "rock.poisson_ratio"),
    ('[well]\ncasing_id = "-1 in"\n', "well.casing_id"),
    ('[fracture]\nreopening = "hoop"\n', "fracture.reopening"),
])
def test_from_dict_errors_name_the_key(tmp_path, extra, key):
    with pytest.raises(InputError) as exc:
        load_lumped_scene(_toml(tmp_path, _MIN + extra))
    assert exc.value.key == key, str(exc.value)
    assert exc.value.file is not None


def test_from_dict_out_of_range_names_key_value_and_range():
    import tomllib
    d = tomllib.loads(_MIN.replace('"35 MPa"', '"25 MPa"'))
    with pytest.raises(InputError) as exc:
        LumpedScene.from_dict(d)
    e = exc.value
    assert e.key == "stress.sigma_H" and "25000000" in str(e) and "[3e+07" in e.expected


def test_from_dict_needs_a_schedule():
    with pytest.raises(InputError) as exc:
        LumpedScene.from_dict({"stress": {"sigma_h": 30e6}})
    assert exc.value.key == "schedule"
