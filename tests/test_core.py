"""Behaviour of the shared core: record, units, errors."""

import numpy as np
import pytest

from xlotkit import InputError, PressureReference, Record
from xlotkit.units import from_si, parse_unit, to_si


def test_units_field_spellings_convert_through_pint():
    assert to_si([1.0], "bars")[0] == pytest.approx(1e5)
    assert to_si([60.0], "l/min")[0] == pytest.approx(1e-3)
    assert to_si([1.0], "sgu")[0] == pytest.approx(1000.0)
    assert to_si([1.0], "psi absolute")[0] == pytest.approx(6894.757, rel=1e-6)
    assert parse_unit("psi absolute").absolute is True
    assert to_si([20.0], "°C")[0] == pytest.approx(293.15)
    # 1 bbl/min = 0.158987 m3 / 60 s
    assert to_si([1.0], "bpm")[0] == pytest.approx(0.158987294928 / 60.0, rel=1e-9)
    assert from_si(to_si([3.5], "MPa"), "psi")[0] == pytest.approx(507.632, rel=1e-5)


def test_unknown_unit_names_the_key_and_file():
    with pytest.raises(InputError) as exc:
        parse_unit("bananas/min", file="log.csv", line=2, key="Rate")
    msg = str(exc.value)
    assert "log.csv:2" in msg and "Rate" in msg and "expected" in msg


def test_record_is_immutable_and_select_keeps_time_origin():
    r = Record(t=np.arange(5.0), pressure=np.arange(5.0) * 1e5, rate=np.ones(5),
               reference=PressureReference("downhole", 1383.0, absolute=True))
    s = r.select(r.t >= 2)
    assert s.t[0] == 2.0 and s.n == 3 and r.n == 5
    assert np.allclose(s.gauge_pressure(), s.pressure - 101325.0)
    with pytest.raises(ValueError):
        Record(t=np.array([0.0, 0.0]), pressure=np.zeros(2))
    with pytest.raises(ValueError):
        Record(t=np.arange(3.0), pressure=np.zeros(2))
