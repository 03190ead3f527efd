"""The AMS-01 field records read exactly as the reader before issue 15 read them.

``tests/data/golden/ams01_golden.json`` was written by ``make_ams01_golden.py`` with the
line-by-line reader of commit b307817, before the reader was rewritten. Equality is exact:
the same bytes for every array (SHA-256 of the float64 values), the same events, start
time, reference and column mapping. The golden data are hashes, sums, extremes and 200
sampled values per array, so a mismatch shows where the values differ.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from xlotkit.interpret.io import read_log

HERE = Path(__file__).resolve()
GOLDEN_DIR = HERE.parents[1] / "data" / "golden"
AMS = HERE.parents[2] / ".." / "shared" / "data" / "field" / "AMS-01"

import importlib.util  # noqa: E402

_spec = importlib.util.spec_from_file_location("make_ams01_golden",
                                               GOLDEN_DIR / "make_ams01_golden.py")
_golden = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_golden)
GOLDEN = json.loads((GOLDEN_DIR / "ams01_golden.json").read_text())

needs_ams = pytest.mark.skipif(
    not all((AMS / f).exists() for f in _golden.FILES.values()),
    reason=f"AMS-01 field data not found under {AMS}")


@needs_ams
@pytest.mark.parametrize("key", sorted(_golden.FILES))
def test_ams01_reads_exactly_as_before(key):
    rec = read_log(AMS / _golden.FILES[key])
    now = _golden.snapshot(rec)
    old = GOLDEN[key]
    assert now["start_time"] == old["start_time"]
    assert now["reference"] == old["reference"]
    assert now["events"] == old["events"]
    assert now["columns"] == old["columns"]
    assert set(now["arrays"]) == set(old["arrays"])
    for name, a in old["arrays"].items():
        b = now["arrays"][name]
        assert b["n"] == a["n"], name
        np.testing.assert_array_equal(b["values"], a["values"], err_msg=name)
        assert (b["sum"], b["min"], b["max"], b["n_nan"]) == \
            (a["sum"], a["min"], a["max"], a["n_nan"]), name
        assert b["sha256"] == a["sha256"], name
    # metadata the old reader recorded is still there with the same values (new keys may
    # be added: what the reader knows about missing cells, resolution, ...)
    for k, v in old["meta"].items():
        assert now["meta"].get(k) == v, k
