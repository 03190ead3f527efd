"""How a column's commas are read: decided from the whole column, or asked for."""

import numpy as np
import pandas as pd
import pytest

from xlotkit.errors import InputError
from xlotkit.interpret.io.cells import cell_kind, numbers


def _read(cells, decimal=None):
    s = pd.Series(cells, dtype=object)
    return numbers(s, lines=np.arange(2, 2 + len(cells)), label="f.txt", name="p",
                   decimal=decimal)


def test_plain_whole_numbers_below_1000_beside_grouped_ones_are_thousands():
    col = _read(["950", "3,500", "3,600", "4,000"])
    assert col.separators == "thousands"
    np.testing.assert_array_equal(col.values, [950.0, 3500.0, 3600.0, 4000.0])


def test_zeros_alone_do_not_decide():
    # a rate logger writing exact zeros as "0" and 1,250 bpm or 1.25 bpm: ask
    with pytest.raises(InputError, match="--decimal"):
        _read(["0", "1,250", "0"])
    np.testing.assert_array_equal(_read(["0", "1,250", "0"], decimal=",").values,
                                  [0.0, 1.25, 0.0])


def test_every_cell_grouped_is_asked_for():
    with pytest.raises(InputError, match=r"f.txt.*--decimal"):
        _read(["3,431", "3,500", "4,000"])
    assert _read(["3,431", "3,500"], decimal=".").values.tolist() == [3431.0, 3500.0]


def test_a_leading_zero_is_a_decimal_comma():
    # 0,500 cannot be a thousands group, so the column is decimal-comma throughout
    assert cell_kind("0,500") == "numc"
    col = _read(["0,500", "1,250", "2,000"])
    assert col.separators == "decimal"
    np.testing.assert_allclose(col.values, [0.5, 1.25, 2.0])


def test_whole_numbers_with_a_large_plain_cell_are_decimal():
    # 1234 written without a comma: the commas cannot be thousands separators
    col = _read(["1234", "3,500"])
    assert col.separators == "decimal"
    np.testing.assert_allclose(col.values, [1234.0, 3.5])
