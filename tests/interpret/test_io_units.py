"""Units of the field: the reader's table of SI factors is pint's, bit for bit."""

from __future__ import annotations

import pytest

from xlotkit import units as U


@pytest.mark.parametrize("expr", sorted(U._FAST_SI))
def test_fast_si_table_is_pints_own_conversion(expr):
    scale, offset, kind = U._FAST_SI[expr]
    assert (scale, offset) == U._pint_affine(expr)
    ref = {"pressure": "Pa", "rate": "m**3/s", "volume": "m**3", "density": "kg/m**3",
           "temperature": "kelvin", "time": "second", "length": "meter",
           "dimensionless": "dimensionless"}[kind]
    reg = U.registry()
    assert reg.Unit(expr).dimensionality == reg.Unit(ref).dimensionality


@pytest.mark.parametrize("spelling", sorted({u for us in U.FIELD_UNITS.values() for u in us}))
def test_every_field_spelling_is_understood_and_of_its_kind(spelling):
    pu = U.parse_unit(spelling)
    assert pu.is_a(U.field_unit_kind(spelling))
    # the value converts like pint converts it
    q = U.registry().Quantity(2.5, pu.expr).to_base_units().magnitude
    assert U.to_si([2.5], pu)[0] == pytest.approx(q, rel=1e-15)


@pytest.mark.parametrize("text,absolute", [("psia", True), ("psig", False), ("psi(a)", True),
                                           ("bar (g)", False), ("psi absolute", True),
                                           ("bara", True), ("barg", False), ("psi", None)])
def test_absolute_and_gauge_marks(text, absolute):
    assert U.parse_unit(text).absolute is absolute
