"""Bleeds and flowbacks are declared from evidence; a metered zero rate falloff is a shut-in."""

from __future__ import annotations

import numpy as np

from xlotkit.interpret.phases import ReleaseEvidence, segment
from xlotkit.record import Event, Record

BAR = 1.0e5


def dfit(bleed_at: float | None = None, remark: bool = False) -> Record:
    """Constructed DFIT: pump 0-520 s at 0.5 m3/min, metered zero rate, 90 min falloff.

    The falloff is a leak-off decline: a fast pump-off drop (friction, 40 bar in ~20 s) and
    then a decline that only slows down (p - p_res ~ 1/sqrt(1 + t/tau)), which falls faster
    than 20 bar/min for minutes -- the old absolute bleed threshold labelled it "bleed".
    ``bleed_at`` adds a valve opening (release to base in 30 s) at that time.
    """
    t = np.arange(0.0, 520.0 + 5400.0, 1.0)
    q = np.where(t < 520.0, 0.5 / 60.0, 0.0)
    p = np.empty_like(t)
    pump = t < 520.0
    p[pump] = 20 * BAR + 380 * BAR * (1 - np.exp(-t[pump] / 120.0))
    p_stop = p[pump][-1]
    ts = t[~pump] - 520.0
    friction = 40 * BAR * (1 - np.exp(-ts / 5.0))
    p_res = 120 * BAR
    decline = (p_stop - 40 * BAR - p_res) / np.sqrt(1 + ts / 60.0)
    p[~pump] = p_res + decline + 40 * BAR - friction
    if bleed_at is not None:
        k = t >= bleed_at
        p0 = np.interp(bleed_at, t, p)
        p[k] = np.minimum(p[k], p0 * np.exp(-(t[k] - bleed_at) / 8.0) + 0.5 * BAR)
    ev = (Event(t=bleed_at - 10.0, text="open bleed valve"),) if (remark and bleed_at) else ()
    return Record(t=t, pressure=p, rate=q, events=ev)


def test_dfit_falloff_with_metered_zero_rate_is_one_shut_in():
    seg = segment(dfit())
    kinds = [ph.kind for ph in seg.phases]
    assert "bleed" not in kinds and "flowback" not in kinds
    assert len(seg.cycles) == 1
    shut = seg.cycles[0].phase("shut_in")
    assert shut is not None
    # the shut-in runs from pump stop (520 s) to the end of the record
    assert abs(shut.t_start - 520.0) <= 15.0
    assert shut.evidence == ()


def test_dfit_shut_in_runs_to_the_end_of_the_record():
    # the base is the pre-test level (20 bar), not the level the long falloff dwells at
    seg = segment(dfit())
    shut = seg.cycles[0].phase("shut_in")
    assert shut.t_end == seg.phases[-1].t_end


def test_valve_opened_late_in_falloff_is_a_bleed_from_unexplained_decline():
    seg = segment(dfit(bleed_at=3000.0))
    bleeds = [ph for ph in seg.phases if ph.kind == "bleed"]
    assert len(bleeds) == 1
    assert abs(bleeds[0].t_start - 3000.0) <= 15.0
    assert ReleaseEvidence.UNEXPLAINED_DECLINE in bleeds[0].evidence
    shut = seg.cycles[0].phase("shut_in")
    assert shut.duration > 2400.0


def test_remark_is_recorded_as_evidence():
    seg = segment(dfit(bleed_at=3000.0, remark=True))
    bleeds = [ph for ph in seg.phases if ph.kind == "bleed"]
    assert len(bleeds) == 1 and ReleaseEvidence.REMARK in bleeds[0].evidence
    # without the remark the same fall is declared from the decline alone
    plain = [ph for ph in segment(dfit(bleed_at=3000.0)).phases if ph.kind == "bleed"]
    assert plain[0].evidence == (ReleaseEvidence.UNEXPLAINED_DECLINE,)


def test_returns_logged_make_flowback_with_return_flow_evidence():
    rec = dfit()
    t = rec.t
    rr = np.where((t > 2000.0) & (t < 2600.0), 0.2 / 60.0, 0.0)
    p = rec.pressure.copy()
    k = t > 2000.0
    p[k] = np.minimum(p[k], np.interp(2000.0, t, p) - (t[k] - 2000.0) * 0.25 * BAR)
    p = np.maximum(p, 0.5 * BAR)
    seg = segment(rec.replace(pressure=p, return_rate=rr))
    fb = [ph for ph in seg.phases if ph.kind == "flowback"]
    assert fb and all(ReleaseEvidence.RETURN_FLOW in ph.evidence for ph in fb)
