"""Segmentation into phases and cycles (:mod:`xlotkit.interpret.phases`).

Synthetic records are built piecewise (1 s samples, bar and l/min converted to SI) so that
each feature the segmentation must handle is present on purpose; the AMS-01 field records
check it on real, messy data.
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from xlotkit import InputError, PressureReference, Record
from xlotkit.interpret.phases import ReleaseEvidence, SegmentOptions, segment

BAR = 1e5
LPM = 1e-3 / 60.0


class _Builder:
    """Piecewise synthetic test: pressure [bar] and rates [l/min] per 1 s sample."""

    def __init__(self, rng=None):
        self.p: list[float] = []
        self.q: list[float] = []
        self.r: list[float] = []
        self.rng = rng

    @property
    def last(self) -> float:
        return self.p[-1] if self.p else 0.0

    def add(self, p, q=0.0, r=0.0):
        p = np.atleast_1d(np.asarray(p, float))
        self.p += list(p)
        self.q += list(np.broadcast_to(q, p.shape))
        self.r += list(np.broadcast_to(r, p.shape))

    def idle(self, n, level=0.0):
        self.add(np.full(n, level))

    def pump_xlot(self, n, q=100.0, slope=100.0, lop=170.0, fbp=200.0, fpp=160.0):
        """Linear rise at ``slope`` bar/min, bend over after ``lop``, break down at ``fbp``,
        then propagate at ``fpp``; ``lop=fbp`` skips the bend (a reopening)."""
        p0 = self.last
        t = np.arange(1, n + 1, dtype=float)
        lin = p0 + slope / 60.0 * t
        out = lin.copy()
        t_lop = (lop - p0) / (slope / 60.0)
        t_fbp = t_lop + 2.0 * (fbp - lop) / (slope / 60.0)
        bend = (t > t_lop) & (t <= t_fbp)
        s = (t[bend] - t_lop) / max(t_fbp - t_lop, 1e-9)
        out[bend] = lop + (fbp - lop) * (1 - (1 - s) ** 2)
        after = t > t_fbp
        out[after] = fpp + (fbp - fpp) * np.exp(-(t[after] - t_fbp) / 15.0)
        self.add(out, q)

    def pump_linear(self, n, q, slope):
        self.add(self.last + slope / 60.0 * np.arange(1, n + 1), q)

    def shut_in(self, n, step=10.0, closure=None, tau=200.0, leak=0.0):
        """Instant drop by ``step`` (pump stop), decay towards ``closure``, slow ``leak``."""
        p0 = self.last - step
        c = p0 - 20.0 if closure is None else closure
        t = np.arange(1, n + 1, dtype=float)
        self.add(c + (p0 - c) * np.exp(-t / tau) - leak / 60.0 * t)

    def flowback(self, n, q0=40.0):
        """Flow back through a choke: sqrt(p) linear in time down to 0, return rate ~ sqrt(p)."""
        p0 = self.last
        s = 1.0 - np.arange(1, n + 1) / n
        p = p0 * s**2
        self.add(p, 0.0, q0 * s)

    def bleed(self, n=10):
        p0 = self.last
        self.add(p0 * (1.0 - np.arange(1, n + 1) / n))

    def record(self, *, rate=True, returns=True, noise=0.0, rate_noise=0.0):
        p = np.array(self.p) * BAR
        q = np.array(self.q) * LPM
        r = np.array(self.r) * LPM
        rng = np.random.default_rng(1)
        if noise:
            p = p + rng.normal(0.0, noise * BAR, p.size)
        if rate_noise:
            q = np.where(q > 0, q * (1 + rng.normal(0.0, rate_noise, q.size)), 0.0)
            # isolated one-sample dropouts and spikes
            k = rng.choice(q.size, size=q.size // 100, replace=False)
            q[k] = np.where(q[k] > 0, 0.0, 200 * LPM)
            q = np.clip(q, 0.0, None)
        t = np.arange(p.size, dtype=float)
        kw = {}
        if rate:
            kw["rate"] = q
            kw["volume"] = np.concatenate(([0.0], np.cumsum(0.5 * (q[1:] + q[:-1]))))
        if returns:
            kw["return_rate"] = r
        return Record(t=t, pressure=p, start_time=datetime(2024, 1, 1, 8, 0, 0), **kw)


def two_cycle_xlot(topup=False, flush=False) -> _Builder:
    """Idle, XLOT cycle (breakdown, propagation), shut-in, flowback, idle, reopening cycle."""
    b = _Builder()
    b.idle(300)
    if flush:
        b.add(np.full(120, 2.0), 300.0)  # line flush: pumping at ~2 bar
        b.idle(180)
    b.pump_xlot(300)  # 0.5 m3 at 100 l/min
    if topup:
        b.shut_in(300, step=10, closure=120)
        b.add(b.last + np.linspace(0.0, 3.0, 20), 60.0)  # 20 l top-up, +3 bar
        b.shut_in(300, step=0, closure=125)
    else:
        b.shut_in(600, step=10, closure=120)
    b.flowback(600)
    b.idle(300)
    b.pump_xlot(240, lop=150, fbp=150, fpp=158)  # reopening: bends at 150, plateaus at 158
    b.shut_in(600, step=8, closure=125)
    b.flowback(600)
    b.idle(300)
    return b


def kinds(seg):
    return [c.kind for c in seg.cycles]


# ====================================================================== synthetic
def test_clean_two_cycle_xlot_phases_and_volumes():
    rec = two_cycle_xlot().record()
    seg = segment(rec)
    assert seg.used_rate
    assert kinds(seg) == ["xlot", "xlot"]
    c1, c2 = seg.cycles
    assert [p.kind for p in c1.phases] == ["pump", "shut_in", "flowback"]
    assert [p.kind for p in c2.phases] == ["pump", "shut_in", "flowback"]
    # the pump phase starts at 300 s and ends at 600 s (within the smoothing windows)
    assert c1.phases[0].t_start == pytest.approx(300, abs=5)
    assert c1.phases[0].t_end == pytest.approx(600, abs=5)
    assert c1.pumped_m3 == pytest.approx(0.5, rel=0.02)
    assert c2.pumped_m3 == pytest.approx(0.4, rel=0.02)
    # returned volume: the integral of 40 l/min * (1 - t/600) over 600 s = 0.2 m3
    assert c1.returned_m3 == pytest.approx(0.2, rel=0.05)
    assert c1.peak_pressure == pytest.approx(200 * BAR, rel=0.01)
    assert "breakdown" in c1.reason and "xlot" in c1.reason
    # phases cover the record without gaps or overlaps
    assert seg.phases[0].i0 == 0 and seg.phases[-1].i1 == rec.n
    assert all(a.i1 == b.i0 for a, b in zip(seg.phases, seg.phases[1:]))
    assert seg.phases[0].kind == "idle" and seg.phases[-1].kind == "idle"


def test_noisy_rate_and_pressure_do_not_split_phases():
    rec = two_cycle_xlot().record(noise=1.0, rate_noise=0.2)
    seg = segment(rec)
    assert kinds(seg) == ["xlot", "xlot"]
    pumps = [p for p in seg.phases if p.kind == "pump"]
    assert len(pumps) == 2
    assert pumps[0].duration == pytest.approx(300, abs=10)


def test_topup_during_shut_in_stays_inside_the_cycle():
    seg = segment(two_cycle_xlot(topup=True).record())
    assert kinds(seg) == ["xlot", "xlot"]
    c1 = seg.cycles[0]
    assert [p.kind for p in c1.phases] == ["pump", "shut_in", "pump", "shut_in", "flowback"]
    assert c1.phases[2].pumped_m3 == pytest.approx(0.02, rel=0.1)


def test_flush_at_base_pressure_is_not_a_cycle():
    seg = segment(two_cycle_xlot(flush=True).record())
    assert kinds(seg) == ["xlot", "xlot"]
    first = seg.phases[0]
    assert first.kind == "idle" and first.pumped_m3 == pytest.approx(0.6, rel=0.02)
    assert seg.cycles[0].t_start == pytest.approx(600, abs=5)


def test_line_test_and_casing_test_are_classified():
    b = _Builder()
    b.idle(200)
    b.pump_linear(30, q=20.0, slope=600.0)  # 10 l to 300 bar: lines against a valve
    b.shut_in(600, step=0.0, closure=299.0, tau=100.0)
    b.bleed(5)
    b.idle(300)
    b.pump_linear(150, q=100.0, slope=60.0)  # 0.25 m3 to 150 bar, straight p-V
    b.shut_in(900, step=1.0, closure=146.0, tau=300.0)
    b.bleed(60)
    b.idle(300)
    seg = segment(b.record())
    assert kinds(seg) == ["line_test", "casing_test"]
    line, casing = seg.cycles
    assert line.peak_pressure == pytest.approx(300 * BAR, rel=0.01)
    assert "closed valve" in line.reason
    assert "no departure" in casing.reason
    assert [p.kind for p in casing.phases] == ["pump", "shut_in", "bleed"]


def test_lot_stops_soon_after_departure():
    b = _Builder()
    b.idle(300)
    # bends over from 150 bar and is stopped at ~184 bar, still rising
    b.pump_xlot(120, lop=150, fbp=190, fpp=150)
    b.shut_in(600, step=5, closure=120)
    b.bleed(60)
    b.idle(300)
    seg = segment(b.record())
    assert kinds(seg) == ["lot"]


def test_pressure_only_finds_the_same_cycles():
    b = two_cycle_xlot()
    with_rate = segment(b.record())
    alone = segment(b.record(rate=False, returns=False))
    assert not alone.used_rate
    assert kinds(alone) == kinds(with_rate) == ["xlot", "xlot"]
    for a, c in zip(alone.cycles, with_rate.cycles):
        assert a.phases[0].t_start == pytest.approx(c.phases[0].t_start, abs=20)
        assert a.phases[0].t_end == pytest.approx(c.phases[0].t_end, abs=20)
        assert a.peak_pressure == pytest.approx(c.peak_pressure)


def test_pressure_only_on_a_downhole_gauge_with_hydrostatic_base():
    b = two_cycle_xlot()
    rec = b.record(rate=False, returns=False)
    hydro = 150 * BAR + 101_325.0
    rec = rec.replace(pressure=rec.pressure + hydro,
                      reference=PressureReference("downhole", 1500.0, absolute=True))
    seg = segment(rec)
    assert kinds(seg) == ["xlot", "xlot"]
    assert seg.cycles[0].peak_pressure == pytest.approx(200 * BAR + hydro, rel=0.01)


def test_options_are_validated():
    with pytest.raises(InputError, match="pump_off"):
        SegmentOptions(pump_on=0.01, pump_off=0.02)
    with pytest.raises(InputError, match="bleed_fraction"):
        SegmentOptions(bleed_fraction=1.5)
    with pytest.raises(InputError, match="idle_fraction"):
        SegmentOptions(idle_fraction=-1.0)
    with pytest.raises(InputError, match="smooth_samples"):
        SegmentOptions(smooth_samples=2.5)
    with pytest.raises(InputError, match="acceleration"):
        SegmentOptions(acceleration=0.5)


def test_empty_and_flat_records():
    assert segment(Record(t=np.array([]), pressure=np.array([]))).cycles == ()
    flat = Record(t=np.arange(100.0), pressure=np.zeros(100))
    seg = segment(flat)
    assert seg.cycles == () and [p.kind for p in seg.phases] == ["idle"]


# ====================================================================== AMS-01 field data
DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "field" / "AMS-01"
if not DATA.is_dir():
    DATA = Path("/work/shared/data/field/AMS-01")
CU1 = DATA / "XLOT 1 - Main Claystone_Cementing Unit_Data.txt"
DH1 = DATA / "XLOT 1 - Main Claystone_Downhole Gauge_Data.TXT"
CU2 = DATA / "XLOT 2 - Vlieland Claystone_Cementing Unit_Data.TXT"
DH2 = DATA / "XLOT 2 - Vlieland Claystone_Downhole Gauge_Data.TXT"

field = pytest.mark.skipif(not CU1.exists(), reason="AMS-01 field data not available")


def _clock(rec, t):
    return rec.time_at(t).strftime("%H:%M")


@pytest.fixture(scope="module")
def io():
    return pytest.importorskip("xlotkit.interpret.io")


@pytest.fixture(scope="module")
def ams(io):
    """Records and segmentations, read once for the module."""
    out = {}
    for key, paths in {"cu1": [CU1], "cu2": [CU2], "m1": [CU1, DH1], "m2": [CU2, DH2],
                       "dh1": [DH1], "dh2": [DH2]}.items():
        rec = io.read_logs(paths)
        out[key] = (rec, segment(rec))
    return out


@field
def test_ams01_xlot1_cementing_unit(ams):
    # Looked at the plot of the cementing-unit record (surface, 1 s):
    # 14:45-14:47 line flush at ~250 l/min, ~3 bar; 14:49 "Start Pressure Test Lines": a
    # 60 l/min blip to ~40 bar, held ~25 bar, then 14:56:30-14:58:30 the lines go to
    # ~340 bar with no metered rate, held flat until the bleed at 15:12 (line test).
    # XLOT cycle 1: 15:17:40-15:25:20 at 100 then ~270 l/min, breakdown at 229 bar, propagation
    # ~180 bar, shut-in ~117 bar, staged releases at 15:42 and 16:10 each followed by a slow
    # recovery of the shut-in well (no pumping), bleed at 16:38.
    # Cycle 2 ("start test 2"): 16:45-16:47 at ~50 l/min, 0.1 m3, peak 180 bar then falling
    # while still pumping, shut-in, released at 16:56.
    # Cycle 3: 17:03-17:15:20 at ~230 l/min, 2.4 m3, peak 193 bar, propagation ~165 bar,
    # shut-in 117 bar, release at 17:20, recovery to 115 bar until the end.
    rec, seg = ams["cu1"]
    assert kinds(seg) == ["line_test", "xlot", "xlot", "xlot"]
    line, x1, x2, x3 = seg.cycles
    assert _clock(rec, line.t_start) == "14:49" and _clock(rec, line.t_end) == "15:12"
    assert line.peak_pressure / BAR == pytest.approx(346, abs=2)
    assert _clock(rec, x1.t_start) == "15:17"
    assert x1.peak_pressure / BAR == pytest.approx(229, abs=1)
    assert x1.pumped_m3 == pytest.approx(1.56, abs=0.02)
    assert _clock(rec, x2.t_start) == "16:45"
    assert x2.peak_pressure / BAR == pytest.approx(180, abs=1)
    assert _clock(rec, x3.t_start) == "17:02"
    assert x3.pumped_m3 == pytest.approx(2.39, abs=0.02)
    # the flush before the line test is idle, not a cycle
    assert seg.phases[0].kind == "idle" and seg.phases[0].pumped_m3 == pytest.approx(0.35, abs=0.02)
    # the slow recoveries after the releases are shut-in, never pumping
    pumps = [p for p in seg.phases if p.kind == "pump" and p.t_start > x1.phases[0].t_end]
    assert all(p.t_start >= x2.t_start for p in pumps)


@field
def test_ams01_xlot2_cementing_unit(ams):
    # Looked at the plot: 14:16-14:24 flushes (up to 580 l/min at ~0 bar, then 40 l/min at
    # 2 bar); 14:25 "Ptest Lines": ~25 bar stage, then 14:31 to 335 bar held to 14:43
    # (line test); 14:51:30 a second short line test to 326 bar, bled at 14:52:50.
    # XLOT cycles: 14:55 ("Start first XLOT test", 90 then 550 l/min, breakdown 116 bar,
    # propagation ~92 bar, 2.0 m3); 15:28 (short: 90 l/min, 0.1 m3, flattens at 75 bar);
    # 15:38 ("XLOT#3", 500 l/min, 3.2 m3, ~92 bar, flowback 15:50-16:01 at ~35 l/min, top-ups
    # of ~30 l/min at 15:48 and 16:07 during shut-in); 16:21 (short, 0.1 m3, 75 bar);
    # 16:27 (490 l/min, 3.1 m3, ~95 bar, flowback 16:36-16:58). The operators' "XLOT#3"
    # remark on the 15:38 cycle confirms the short 15:28 pump-in counts as XLOT cycle 2.
    rec, seg = ams["cu2"]
    assert kinds(seg) == ["line_test", "line_test", "xlot", "xlot", "xlot", "xlot", "xlot"]
    starts = [_clock(rec, c.t_start) for c in seg.cycles]
    assert starts == ["14:25", "14:51", "14:55", "15:27", "15:37", "16:21", "16:27"]
    peaks = [round(c.peak_pressure / BAR) for c in seg.cycles]
    assert peaks[0] == pytest.approx(337, abs=2) and peaks[2] == pytest.approx(116, abs=2)
    assert "XLOT#3" in seg.cycles[4].reason
    # top-ups during the shut-in of cycle 5 remain pump phases inside it
    c5 = seg.cycles[4]
    assert sum(p.kind == "pump" for p in c5.phases) >= 2
    assert any(p.kind == "flowback" and p.returned_m3 > 0.3 for p in c5.phases)


@field
def test_ams01_merged_pairs(ams):
    # Merged on the downhole gauge (reference downhole, absolute): the line tests against
    # a closed surface valve do not reach the gauge, the XLOT cycles do.
    # XLOT 1: three cycles, gauge peaks 375 bar abs (breakdown), 328 and 334 bar abs.
    # XLOT 2: five cycles, gauge peaks 212, 171, 183, 170 and 186 bar abs.
    rec1, seg1 = ams["m1"]
    assert rec1.reference.kind == "downhole"
    assert kinds(seg1) == ["xlot"] * 3
    assert [round(c.peak_pressure / BAR) for c in seg1.cycles] == pytest.approx(
        [375, 328, 334], abs=2)
    rec2, seg2 = ams["m2"]
    assert kinds(seg2) == ["xlot"] * 5
    assert [round(c.peak_pressure / BAR) for c in seg2.cycles] == pytest.approx(
        [212, 171, 183, 170, 186], abs=2)
    # the same cycles as on the surface record, on the same (surface) clock
    cu_rec, cu = ams["cu2"]
    xl = [c for c in cu.cycles if c.kind == "xlot"]
    for a, b in zip(seg2.cycles, xl):
        assert abs((rec2.time_at(a.t_start) - cu_rec.time_at(b.t_start)).total_seconds()) < 10


@field
def test_ams01_downhole_gauge_alone(ams):
    # The gauge alone (3 s, no rate) holds a day of other operations too; inside the
    # XLOT window the pressure-only segmentation finds the XLOT cycles seen on the merged
    # record (gauge clock ~61.5 min behind the cementing unit).
    for key, merged_key in (("dh1", "m1"), ("dh2", "m2")):
        rec, seg = ams[key]
        mrec, mseg = ams[merged_key]
        assert not seg.used_rate
        off = mrec.meta["clock_offset_s"]
        want = [mrec.time_at(c.t_start).timestamp() - off for c in mseg.cycles]
        got = [rec.time_at(c.t_start).timestamp() for c in seg.cycles]
        for w in want:
            assert min(abs(g - w) for g in got) < 60
        peaks = {round(c.peak_pressure / BAR) for c in seg.cycles}
        for c in mseg.cycles:
            assert any(abs(p - c.peak_pressure / BAR) <= 2 for p in peaks)


@field
def test_ams01_gauge_alone_cycles_a_person_sees(ams):
    # Looked at the plots of the gauges alone (docs/field/segmentation.md). XLOT 1: after
    # running in (0-4.6 h, not a test) a two-stage pressure-up to 258 bar abs (5.67 h),
    # held ~23 min and bled; a test to 192 then 302 bar (10.46 h); a small two-stage
    # test to 182 bar (16.19 h); the three XLOT cycles at 375, 328, 334 bar. XLOT 2: the
    # five XLOT cycles only -- the pulsing pump-ins at ~+20 bar (3.7-4.7 h, 15.2 h,
    # 15.5-16.9 h) are circulation: released at once, no shut-in.
    _, seg1 = ams["dh1"]
    peaks1 = [round(c.peak_pressure / BAR) for c in seg1.cycles]
    assert 258 in peaks1
    staged = seg1.cycles[peaks1.index(258)]
    assert staged.kind == "casing_test" and abs(staged.t_start / 3600 - 5.67) < 0.02
    assert sum(ph.kind == "pump" for ph in staged.phases) == 2  # the two stages, one cycle
    assert [c.kind for c in seg1.cycles if c.peak_pressure / BAR > 320] == ["xlot"] * 3
    _, seg2 = ams["dh2"]
    assert [c.kind for c in seg2.cycles] == ["xlot"] * 5


@field
def test_ams01_xlot2_gauge_alone_cycle4_release_where_the_surface_record_opens_the_valve(ams):
    # XLOT 2, the short cycle at 16:21 (surface clock): 76 s after pump stop the valve is
    # opened and the well flows back to base. The cementing unit logs it (return rate and
    # volume from 16:23:46, its flowback phase from 16:23:44); the downhole gauge alone has
    # only its pressure, which falls 17 times faster than the shut-in's decline just before.
    # Before the re-acceleration cut the gauge's shut-in ran on through the whole fall (the
    # candidate fall started at pump stop, where there is no decline to compare with), and
    # the closure was picked where the fall ended (97.5 bar). The surface record is the
    # independent truth of where the valve opened: the gauge's release starts within 3 of
    # its samples (9 s; the clock offset between the files is itself known to a few s).
    crec, cseg = ams["cu2"]
    grec, gseg = ams["dh2"]
    off = ams["m2"][0].meta["clock_offset_s"]
    cc = next(c for c in cseg.cycles if _clock(crec, c.t_start) == "16:21")
    fb = next(ph for ph in cc.phases if ph.kind == "flowback")
    assert ReleaseEvidence.RETURN_FLOW in fb.evidence
    t_valve = crec.time_at(fb.t_start).timestamp() - off
    t_cycle = crec.time_at(cc.t_start).timestamp() - off
    gc = min(gseg.cycles, key=lambda c: abs(grec.time_at(c.t_start).timestamp() - t_cycle))
    kinds_g = [ph.kind for ph in gc.phases]
    k = next(i for i, ph in enumerate(gc.phases) if ph.kind in ("bleed", "flowback"))
    rel = gc.phases[k]
    assert kinds_g[:k] == ["pump", "shut_in"], kinds_g
    assert abs(grec.time_at(rel.t_start).timestamp() - t_valve) <= 9.0
    assert rel.evidence == (ReleaseEvidence.UNEXPLAINED_DECLINE, ReleaseEvidence.PRESSURE_ONLY)
    # the release runs to base (it took the whole pressure above it: no partial one here)
    pg = grec.gauge_pressure()
    base = gseg.scales.base
    assert pg[rel.i1 - 1] - base < 0.05 * (pg[rel.i0] - base)


@field
def test_ams01_gauge_alone_pump_phases_match_the_metered_ones(ams, io):
    # The cementing unit's metered rate is an independent record of when the pump ran: on
    # the gauge alone each XLOT cycle's first pump phase starts at the sustained rise and
    # stops at the sharp break to the shut-in within 20 s (7 gauge samples; the clock
    # offset between the two files is itself known to a few seconds) of the metered pump
    # phase. (Before issue 16 the pump phases of XLOT 2's cycles 3 and 5 ran on through
    # the shut-in and flowback, 22 and 29 min for 7 min of pumping.)
    for cu_key, dh_key, merged_key in (("cu1", "dh1", "m1"), ("cu2", "dh2", "m2")):
        crec, cseg = ams[cu_key]
        grec, gseg = ams[dh_key]
        off = ams[merged_key][0].meta["clock_offset_s"]
        for cc in [c for c in cseg.cycles if c.kind == "xlot"]:
            pc = cc.phases[0]
            a = crec.time_at(pc.t_start).timestamp() - off
            b = crec.time_at(pc.t_end).timestamp() - off
            gc = min(gseg.cycles, key=lambda c: abs(grec.time_at(c.t_start).timestamp() - a))
            pg = gc.phases[0]
            assert pg.kind == "pump"
            assert abs(grec.time_at(pg.t_start).timestamp() - a) < 20, (cu_key, cc.index)
            assert abs(grec.time_at(pg.t_end).timestamp() - b) < 20, (cu_key, cc.index)
