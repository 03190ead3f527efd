"""Segmentation does not depend on how finely the record is sampled.

The same test logged every 1, 2, 5, 10 or 30 s (the fine record decimated) segments into
the same phases and cycle kinds, the phase boundaries at the same times within one sample
of the coarser log: the windows are counted in samples of the record's resolution, which
on a coarse log is a fixed share of its duration
(:meth:`~xlotkit.interpret.phases.options.SegmentOptions.for_sampling`). Issue 16's audit:
a lumped-model DFIT resampled to 2 s had its falloff labelled bleed and no closure; at 10 s
an XLOT's flowbacks were bleeds, at 30 s the four cycles one cycle of kind 'other'.
"""

from __future__ import annotations

import numpy as np
import pytest
from phase_fixtures import (
    LPM,
    lumped_log,
    to_record,
)
from test_phases_units import _arrays

from xlotkit import Record
from xlotkit.interpret.phases import SegmentOptions, segment
from xlotkit.interpret.picks.core import pick_record
from xlotkit.sim.schedule import Pump, Schedule, ShutIn

FACTORS = (1, 2, 5, 10, 30)


KINDS = {"dfit": ["dfit"], "xlot": ["xlot", "xlot"], "step_rate": ["step_rate"],
         "stimulation": ["stimulation"]}


def _decimated(arrays, k):
    t, p, q, r = arrays
    s = slice(0, None, k)
    return to_record(t[s], p[s], q[s], None if r is None else r[s])


def _phases(rec, seg):
    return [(ph.kind, float(rec.t[ph.i0]), float(rec.t[ph.i1 - 1])) for ph in seg.phases]


@pytest.mark.parametrize("kind", sorted(KINDS))
@pytest.mark.parametrize("seed", [0, 7])
def test_decimated_record_gives_the_same_phases(kind, seed):
    arrays = _arrays(kind, seed)
    ref_rec = _decimated(arrays, 1)
    ref = _phases(ref_rec, segment(ref_rec))
    for k in FACTORS[1:]:
        rec = _decimated(arrays, k)
        seg = segment(rec)
        assert [c.kind for c in seg.cycles] == KINDS[kind], (k, [c.reason for c in seg.cycles])
        got = _phases(rec, seg)
        assert [g[0] for g in got] == [r[0] for r in ref], k
        dt = float(rec.t[1] - rec.t[0])
        for (kind_g, a_g, b_g), (_, a_r, b_r) in zip(got, ref):
            # a boundary at sample j of the fine log lies between two samples of the coarse
            # one: the coarse phase starts at most one coarse sample later and ends at most
            # one earlier; a window that grew with the sampling would shift it by several
            assert abs(a_g - a_r) <= dt and abs(b_g - b_r) <= dt, (k, kind_g, a_g, a_r,
                                                                  b_g, b_r)


def test_windows_keep_their_length_in_time_on_a_coarse_log():
    opt = SegmentOptions()
    fine = opt.for_sampling(1.0, 4000.0)
    assert fine == opt  # 4000 samples: finer than the resolution, counted in samples
    coarse = opt.for_sampling(30.0, 4000.0)
    per_sample = 4000.0 / opt.time_resolution  # [s] of the resolution
    for name in ("min_phase_samples", "settle_samples", "gap_samples", "min_pump_samples"):
        want = getattr(opt, name) * per_sample / 30.0
        assert getattr(coarse, name) == max(2 if name != "gap_samples" else 1, round(want))
    assert coarse.smooth_samples % 2 == 1 and coarse.rate_filter_samples % 2 == 1
    # a test run five times slower on the same samples keeps its windows in samples
    assert opt.for_sampling(150.0, 20000.0) == coarse


@pytest.mark.parametrize("dt", [1.0, 2.0, 10.0])
def test_lumped_dfit_with_a_metered_zero_rate_falls_off_shut_in(tmp_path, dt):
    # issue 16 audit D1: the standard DFIT (300 l/min for 520 s, 90 min falloff, zero return
    # rate logged) at 2 s had its falloff past closure labelled bleed (the lumped fracture's
    # closure stiffens the system: the decline speeds up five-fold and goes on to the end)
    sched = Schedule((Pump(300 * LPM, duration=520.0, name="injection"),
                      ShutIn(duration=5400.0, name="falloff")))
    rec, res = lumped_log(tmp_path, f"dfit{dt:g}", sched, noise=0.05e5, dt=dt)
    seg = segment(rec)
    assert [c.kind for c in seg.cycles] == ["dfit"]
    assert not [ph for ph in seg.phases if ph.kind in ("bleed", "flowback")]
    shut = seg.cycles[0].phase("shut_in")
    assert shut.i1 == rec.n
    fcp = pick_record(rec, seg).cycles[0].fcp
    # the lumped fracture closes at sigma_h exactly; the shut-in methods within 5 % as in
    # test_picks_lumped.py
    assert fcp.found and abs(fcp.value / res.truth["sigma_h"] - 1.0) < 0.05


@pytest.mark.parametrize("k", FACTORS)
def test_a_totaliser_counts_pumped_volume_in_the_pump_phases_only(k):
    # issue 16 audit D5: on a coarse log a shut-in was reported "pumped" the totaliser's step
    # into the next pump phase's first sample (the volume moved since the sample before)
    arrays = _arrays("xlot", 0)
    t, p, q, r = arrays
    # the totaliser integrates the rate exactly between the 1 s samples [m^3]
    vol = np.concatenate([[0.0], np.cumsum(q[:-1] * LPM * np.diff(t))])
    ret = np.concatenate([[0.0], np.cumsum(r[:-1] * LPM * np.diff(t))])
    s = slice(k // 2, None, k)  # coarse samples that straddle the pump starts and stops
    rec = to_record(t[s], p[s], q[s], r[s])
    rec = Record(t=rec.t, pressure=rec.pressure, rate=rec.rate, return_rate=rec.return_rate,
                 volume=vol[s], return_volume=ret[s])
    seg = segment(rec)
    assert [c.kind for c in seg.cycles] == ["xlot", "xlot"]
    for ph in seg.phases:
        if ph.kind != "pump":
            assert ph.pumped_m3 == 0.0, (k, ph.kind, ph.pumped_m3)
        if ph.kind in ("pump", "shut_in"):  # (the returns trail off into the idle well)
            assert ph.returned_m3 == 0.0, (k, ph.kind, ph.returned_m3)
    # the two pump phases pumped what the construction did (0.5 and 0.4 m^3): every step of
    # the totaliser is in one of them
    pumped = [ph.pumped_m3 for ph in seg.phases if ph.kind == "pump"]
    assert pumped == pytest.approx([0.5, 0.4], rel=1e-9)
