"""Segmentation does not depend on the units a log is written in.

The same constructed record is written as CSV with the pressure in bar, psi, MPa or kPa and
the time in seconds or minutes (shifted by an offset: an affine change of the time axis), read
back with xlotkit's reader, and segmented. The phases (kind, sample bounds, evidence) and the
cycle kinds must be identical to those of the bar / seconds file. Then the DFIT of issue 16:
one injection, a shut-in falloff (not a bleed), and a closure picked where the construction
put it.
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from phase_fixtures import BAR, PRESSURE_UNITS, dfit_arrays, to_record, write_csv
from test_phases import two_cycle_xlot
from xlotkit.interpret.io import read_log
from xlotkit.interpret.phases import segment
from xlotkit.interpret.picks.core import pick_record


def _signature(seg):
    return ([(ph.kind, ph.i0, ph.i1, ph.evidence) for ph in seg.phases],
            [c.kind for c in seg.cycles])


def _xlot_arrays(seed, noise_bar):
    b = two_cycle_xlot()
    p = np.asarray(b.p) + np.random.default_rng(seed).normal(0.0, noise_bar, len(b.p))
    return np.arange(p.size, dtype=float), p, np.asarray(b.q), np.asarray(b.r)


def _read_segment(tmp_path, name, arrays, **kw):
    path = tmp_path / name
    write_csv(path, *arrays, **kw)
    return segment(read_log(path))


_UNITS = st.sampled_from([u for u in PRESSURE_UNITS if u != "bar"])


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["dfit", "xlot"]), seed=st.integers(0, 2**16),
       noise=st.floats(0.0, 0.5), p_unit=_UNITS, t_unit=st.sampled_from(["s", "min"]),
       offset=st.floats(0.0, 86400.0))
def test_same_record_in_other_units_gives_identical_phases(tmp_path, kind, seed, noise,
                                                           p_unit, t_unit, offset):
    if kind == "dfit":
        t, p, q, _ = dfit_arrays(seed=seed, noise_bar=noise)
        arrays = (t, p, q)
    else:
        arrays = _xlot_arrays(seed, noise)
    ref = _read_segment(tmp_path, "ref.csv", arrays)
    other = _read_segment(tmp_path, "other.csv", arrays, p_unit=p_unit, t_unit=t_unit,
                          t_offset_s=offset)
    assert _signature(other) == _signature(ref)
    # not vacuous: the reference found the test the construction contains
    assert [c.kind for c in ref.cycles] == (["xlot"] if kind == "dfit" else ["xlot", "xlot"])


def test_dfit_is_one_injection_and_a_shut_in_falloff_with_a_closure(tmp_path):
    t, p, q, truth = dfit_arrays()
    seg = segment(to_record(t, p, q))
    kinds = [ph.kind for ph in seg.phases]
    assert "bleed" not in kinds and "flowback" not in kinds
    pumps = [ph for ph in seg.phases if ph.kind == "pump"]
    assert len(pumps) == 1 and len(seg.cycles) == 1
    # the rate is metered: the pump phase is exactly the metered pumping (1 s samples)
    assert abs(pumps[0].i0 - truth["pump"][0]) <= 1 and abs(pumps[0].i1 - truth["pump"][1]) <= 1
    shut = seg.cycles[0].phase("shut_in")
    assert shut is not None and shut.i0 == pumps[0].i1
    # the shut-in runs well past closure (900 s after shut-in); the tail of the falloff is
    # still labelled idle because the base is the level the falloff dwells at (see the strict
    # xfail in test_phases_evidence.py) -- asserted here only up to what holds today
    assert shut.t_end - shut.t_start >= 0.8 * (truth["shut_in"][1] - truth["shut_in"][0])
    rp = pick_record(to_record(t, p, q), seg)
    fcp = rp.cycles[0].fcp
    assert fcp is not None
    # the construction breaks the sqrt(t) slope at exactly closure_bar; 0.2 bar noise and the
    # median of the shut-in methods place it within a few tenths of a bar (measured 220.05),
    # 2 bar leaves room for the methods' windowing without admitting a wrong event (ISIP is
    # 300 bar, the falloff end ~165 bar)
    assert abs(fcp.value / BAR - truth["closure_bar"]) < 2.0
