"""Test programs (xlotkit.sim.schedule)."""

import pytest

from xlotkit import InputError
from xlotkit.sim.schedule import Bleed, Flowback, Pump, Schedule, ShutIn, parse_quantity


def test_stepped_pump_rates_and_duration():
    p = Pump(steps=[(60.0, 1e-3), (120.0, 5e-3)])
    assert p.max_duration == 180.0
    assert p.rate_at(0.0) == 1e-3 and p.rate_at(59.9) == 1e-3 and p.rate_at(60.0) == 5e-3
    assert p.rate_at(500.0) == 5e-3
    assert p.breakpoints() == (60.0,)
    assert Pump(5e-3, volume=1.0).rate_at(10.0) == 5e-3


def test_cycles_start_at_each_pressurisation_and_repeat():
    s = Schedule([Pump(5e-3, volume=1.0), ShutIn(duration=60.0),
                  Flowback(zeta=1e-6, duration=60.0)], cycles=3)
    assert s.n_cycles == 3 and s.n_phases == 9
    assert [c for c, _ in s] == [1, 1, 1, 2, 2, 2, 3, 3, 3]
    two = Schedule([Pump(5e-3, volume=1.0), Pump(1e-3, duration=10.0), ShutIn(duration=9.0),
                    Pump(5e-3, volume=1.0), Bleed(1e-3, duration=5.0)])
    assert [c for c, _ in two] == [1, 1, 1, 2, 2]
    # the well at rest before the first pump is part of the first cycle
    rest = Schedule([ShutIn(duration=120.0), Pump(5e-3, volume=1.0), ShutIn(duration=60.0),
                     Pump(5e-3, volume=0.5)])
    assert [c for c, _ in rest] == [1, 1, 1, 2] and rest.n_cycles == 2


def test_from_dict_parses_field_units():
    s = Schedule.from_dict({"cycles": 2, "phase": [
        {"kind": "pump", "rate": "500 l/min", "volume": "1.5 m3", "pressure_above": "40 MPa"},
        {"kind": "pump", "steps": [["2 min", "100 l/min"], ["1 min", "3 bpm"]]},
        {"kind": "shut_in", "duration": "10 min", "pressure_below": "250 bar"},
        {"kind": "flowback", "initial_rate": "200 l/min", "pressure_below": "20 bar",
         "pressure_at": "surface"},
        {"kind": "bleed", "rate": 0.001, "volume": "100 l"},
    ]})
    ph = [p for _, p in s]
    assert ph[0].rate == pytest.approx(0.5 / 60) and ph[0].volume == 1.5
    assert ph[0].pressure_above == pytest.approx(40e6)
    assert ph[1].steps[1] == pytest.approx((60.0, 3 * 0.158987294928 / 60))
    assert ph[2].duration == 600.0 and ph[2].pressure_below == pytest.approx(25e6)
    assert ph[3].initial_rate == pytest.approx(0.2 / 60) and ph[3].pressure_at == "surface"
    assert ph[4].volume == pytest.approx(0.1)
    assert len(ph) == 10
    assert parse_quantity("1e-3 m3/s", "rate", key="x") == pytest.approx(1e-3)


@pytest.mark.parametrize("data,key", [
    ({"phase": [{"kind": "pump", "rate": "500 l/min"}]}, "schedule.phase[0]"),
    ({"phase": [{"kind": "pump", "rate": "500 bar", "duration": 5}]},
     "schedule.phase[0].rate"),
    ({"phase": [{"kind": "shut_in", "duration": 5}, {"kind": "bleed", "rate": -1,
                                                      "duration": 1}]},
     "schedule.phase[1].rate"),
    ({"phase": [{"kind": "flowback", "duration": 5}]}, "schedule.phase[0].zeta"),
    ({"phase": [{"kind": "dance", "duration": 5}]}, "schedule.phase[0].kind"),
    ({"phase": [{"kind": "shut_in", "duration": 5, "colour": "red"}]},
     "schedule.phase[0].colour"),
    ({"phase": [{"kind": "pump", "steps": [["1 min", "5 l/min"], ["x", "1 l/min"]]}]},
     "schedule.phase[0].steps[1].duration"),
    ({"cycles": 0, "phase": [{"kind": "shut_in", "duration": 5}]}, "schedule.cycles"),
    ({"phase": []}, "schedule.phase"),
])
def test_from_dict_errors_name_the_key(data, key):
    with pytest.raises(InputError) as exc:
        Schedule.from_dict(data)
    assert exc.value.key == key, str(exc.value)
    assert exc.value.expected


def test_direct_validation_messages():
    with pytest.raises(InputError) as exc:
        Pump(rate=5e-3, steps=[(1.0, 1e-3)], duration=1.0)
    assert exc.value.key == "pump.rate"
    with pytest.raises(InputError) as exc:
        ShutIn(pressure_above=1e6, pressure_below=2e6)
    assert exc.value.key == "shut_in.pressure_below"
    with pytest.raises(InputError) as exc:
        Flowback(zeta=1e-6, initial_rate=1e-3, duration=5.0)
    assert exc.value.key == "flowback.zeta"
    with pytest.raises(InputError):
        Schedule([])
