"""Split a record into phases (pump, shut-in, flowback, bleed, idle) and group them into
cycles (docs/field/segmentation.md).

Every threshold is a fraction or multiple of one of the record's own scales
(:class:`~xlotkit.interpret.phases.types.RecordScales`): its pressure noise, its pre-test
level and its pressure span above it, its rate scale, the decline of its own shut-ins and
the steepness of its own rises; windows are counted in samples of the record's resolution
(:meth:`SegmentOptions.for_sampling`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from xlotkit.errors import InputError
from xlotkit.interpret.phases.kinds import classify, measure
from xlotkit.interpret.phases.options import SegmentOptions
from xlotkit.interpret.phases.pumping import (
    join_short,
    metered_pumping,
    pressure_pumping,
    pressure_rises,
    unmetered_rises,
)
from xlotkit.interpret.phases.releases import departure, find_releases, return_flow
from xlotkit.interpret.phases.signal import (
    cum_positive,
    cum_rate,
    noise_level,
    odd,
    running_median,
    runs,
    slope,
)
from xlotkit.interpret.phases.types import (
    Cycle,
    Phase,
    RecordScales,
    ReleaseEvidence,
    Segmentation,
)
from xlotkit.record import Record

__all__ = ["segment"]

_BAR = 1.0e5
_CODES = {"idle": 0, "shut_in": 1, "pump": 2, "flowback": 3, "bleed": 4}
_KINDS = {v: k for k, v in _CODES.items()}
_BITS = {ev: 1 << k for k, ev in enumerate(ReleaseEvidence)}


# ====================================================================== base level
def _dwell_level(t: np.ndarray, ps: np.ndarray, width: float, fraction: float) -> float:
    """Lowest pressure level where the record dwells at least ``fraction`` of its length.

    A histogram of time spent per ``width`` bin is scanned from the bottom; brief excursions
    below it (a gauge run in or pulled out) do not count.
    """
    ok = np.isfinite(ps)
    t, p = t[ok], ps[ok]
    if p.size < 3:
        return float(np.min(p)) if p.size else 0.0
    lo, hi = float(np.min(p)), float(np.max(p))
    if width <= 0 or hi - lo < width:
        return float(np.median(p))
    # never more bins than the record could fill (a wild value must not make the histogram
    # allocate terabytes); bins then widen relative to the record
    n_max = 20 * p.size + 1000
    if (hi - lo) / width > n_max:
        width = (hi - lo) / n_max
    edges = np.arange(lo, hi + width, width)
    w = np.diff(t, append=t[-1] + (t[-1] - t[-2]))
    dwell, _ = np.histogram(p, bins=edges, weights=w)
    good = np.flatnonzero(dwell >= fraction * float(np.sum(w)))
    if good.size == 0:
        return float(np.percentile(p, 5))
    k = int(good[0])
    sel = (p >= edges[k]) & (p <= edges[k + 1])
    return float(np.median(p[sel]))


def _base(t, ps, first: int | None, noise: float, opt: SegmentOptions) -> tuple[float, str]:
    """The pre-test level [Pa] and how it was found.

    The median of the ``settle_samples`` before the first pump start (the record's sample at
    the start if it begins pumping). A record that dwells for ``base_dwell_fraction`` of its
    length clearly below that level started pressurised (a test already under way): its
    base is that lower dwell level. Without any pumping: the lowest dwell level.
    """
    hi, lo = float(np.max(ps)), float(np.min(ps))
    width = 0.5 * max(opt.noise_multiple * noise, opt.idle_fraction * (hi - lo))
    dwell = _dwell_level(t, ps, width, opt.base_dwell_fraction)
    if first is None:
        return dwell, "lowest level the record dwells at: no pumping found"
    pre = ps[max(0, first - opt.settle_samples): first]
    level = float(np.median(pre)) if pre.size else float(ps[first])
    band = max(opt.noise_multiple * noise, opt.idle_fraction * (hi - level))
    if dwell < level - 2.0 * band:
        return dwell, ("the record starts pressurised: lowest level it dwells at, "
                       f"{(level - dwell) / _BAR:.1f} bar below the level before the first "
                       "pumping")
    return level, "level before the first pumping"


# ====================================================================== phases
def _label_runs(lab: np.ndarray) -> list[tuple[str, int, int]]:
    """Runs of equal label as ``(kind, i0, i1)``."""
    if lab.size == 0:
        return []
    cut = np.flatnonzero(np.diff(lab)) + 1
    edges = np.concatenate(([0], cut, [lab.size]))
    return [(_KINDS[int(lab[a])], int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def _merge_short(rs, shortest: int) -> list[tuple[str, int, int]]:
    """Fold shut-in / flowback / idle runs shorter than ``shortest`` samples into a neighbour.

    Pump and bleed runs were already filtered by their own rules (a bleed can take a few
    samples). The short run joins the neighbour it resembles most: the previous one unless
    that is a pump/bleed and the next one is not; between two pump/bleed runs it stays.
    """
    rs = list(rs)
    soft = ("idle", "shut_in", "flowback")
    changed = True
    while changed and len(rs) > 1:
        changed = False
        for k, (kind, a, b) in enumerate(rs):
            if kind in ("pump", "bleed") or b - a >= shortest:
                continue
            prev = rs[k - 1] if k > 0 else None
            nxt = rs[k + 1] if k + 1 < len(rs) else None
            if prev is not None and (prev[0] in soft or nxt is None or nxt[0] not in soft):
                target = k - 1
            elif nxt is not None:
                target = k + 1
            else:
                continue
            tk, ta, tb = rs[target]
            if tk in ("pump", "bleed"):
                continue
            rs[target] = (tk, min(a, ta), max(b, tb))
            del rs[k]
            changed = True
            break
    out: list[tuple[str, int, int]] = []
    for kind, a, b in rs:
        if out and out[-1][0] == kind:
            out[-1] = (kind, out[-1][1], b)
        else:
            out.append((kind, a, b))
    return out


def _own_first_step(cum: np.ndarray | None, starts) -> np.ndarray | None:
    """``cum`` with the step into each of the sample indices ``starts`` moved to the phase
    that starts there: a phase over ``[i0, i1)`` counts ``cum[i1] - cum[i0]``."""
    if cum is None:
        return None
    out = np.array(cum, float, copy=True)
    for a in starts:
        if a > 0:
            out[a] = cum[a - 1]
    return out


def _make_phase(record: Record, kind: str, i0: int, i1: int, cum_in, cum_out,
                bits: np.ndarray) -> Phase:
    """A :class:`Phase` over samples ``[i0, i1)`` with volumes, peak, mean rate, evidence."""
    t = record.t
    j = min(i1, record.n - 1)  # volumes are counted up to the first sample of the next phase
    pumped = float(cum_in[j] - cum_in[i0]) if cum_in is not None else 0.0
    returned = float(cum_out[j] - cum_out[i0]) if cum_out is not None else 0.0
    dur = float(t[j] - t[i0])
    if record.rate is not None and kind == "pump":
        mean_rate = float(np.nanmean(record.rate[i0:i1]))
    elif dur > 0:
        mean_rate = (pumped - returned) / dur
    else:
        mean_rate = 0.0
    ev: tuple[ReleaseEvidence, ...] = ()
    if kind in ("bleed", "flowback"):
        have = int(np.bitwise_or.reduce(bits[i0:i1])) if i1 > i0 else 0
        ev = tuple(e for e, bit in _BITS.items() if have & bit)
    return Phase(kind=kind, i0=i0, i1=i1, t_start=float(t[i0]), t_end=float(t[i1 - 1]),
                 pumped_m3=pumped, returned_m3=returned,
                 peak_pressure=float(np.nanmax(record.pressure[i0:i1])), mean_rate=mean_rate,
                 evidence=ev)


# ====================================================================== segment
def segment(record: Record, *, options: SegmentOptions | None = None) -> Segmentation:
    """Split ``record`` into phases and group them into cycles.

    Algorithm (docs/field/segmentation.md; thresholds in :class:`SegmentOptions`)
    ---------------------------------------------------------------------------
    1. The pressure (gauge, Pa) is median-smoothed and differentiated; its noise is read
       from its first differences.
    2. Pumping: from the pump rate when one is logged (fractions of the record's rate
       scale), plus steep, about linear rises while no rate is metered (a line-test pump).
       Without a rate, from the pressure: sustained rises, each extended through breakdown
       and propagation to the sudden fall at pump stop
       (:mod:`~xlotkit.interpret.phases.pumping`).
    3. The base is the pre-test level: the pressure before the first pumping. The span is
       the highest pressure above it; the idle band a fraction of the span (or a multiple of
       the noise).
    4. Releases: returns logged make a ``flowback``; a fall the shut-in's own leak-off
       cannot explain (or an operator remark) makes a ``bleed`` (with a rate logged) or a
       release told from the pressure alone; every release carries its evidence
       (:mod:`~xlotkit.interpret.phases.releases`). The rest is ``shut_in`` above the idle
       band, ``idle`` below it.
    5. Cycles: a pump phase opens a cycle when the pressure had been released since the
       current cycle's peak, or when it pumps from a shut-in well at least
       ``restart_fraction`` of what the cycle pumped so far (else it is a stage or top-up of
       the current cycle), and the cycle builds a
       ``cycle_fraction`` of the span above both base and its starting level. Without a rate,
       the cycle must also hold its pressure after pumping (a release at once is
       circulation). Pumping that opens no cycle from base is a flush: ``idle``. A cycle
       runs to the next one, or until the well has stood idle as long as it was pumped.
    6. Each cycle is classified (:mod:`~xlotkit.interpret.phases.kinds`).

    Parameters
    ----------
    record : Record
        The record; ``pressure`` is required, ``rate``/``volume``/``return_*`` are used when
        present.
    options : SegmentOptions, optional
        Thresholds (defaults: :class:`SegmentOptions`).

    Returns
    -------
    Segmentation
    """
    opt = options or SegmentOptions()
    n = record.n
    if n == 0:
        return Segmentation(phases=(), cycles=(), used_rate=False, notes=("empty record",))
    t = record.t
    if n > 1:
        # windows in samples of the record's own resolution: a coarse log counts them in time
        opt = opt.for_sampling(float(np.median(np.diff(t))), float(t[-1] - t[0]))
    p = np.asarray(record.gauge_pressure(), float)
    if np.any(~np.isfinite(p)):
        # gaps in a pressure series: carry the last reading (the segmentation is coarse)
        good = np.isfinite(p)
        if not good.any():
            raise InputError("the record has no finite pressure values", key="pressure")
        idx = np.where(good, np.arange(n), 0)
        np.maximum.accumulate(idx, out=idx)
        p = p[idx]
        p[: int(np.argmax(good))] = p[int(np.argmax(good))]
    ps = running_median(p, odd(opt.smooth_samples))
    dpdt = slope(t, ps, opt.slope_half)
    noise = noise_level(p)
    hi = float(np.max(ps))
    everywhere = np.ones(n, bool)
    rate = record.rate
    used_rate = rate is not None and bool(np.nanmax(np.abs(np.nan_to_num(rate))) > 0)
    notes: list[str] = []

    # ---------------------------------------------------------------- pumping and base
    rate_scale = None
    if used_rate:
        pump, short, rate_scale = metered_pumping(rate, opt)
        first = int(np.argmax(pump)) if pump.any() else None
        found = []
    else:
        pump = np.zeros(n, bool)
        r0 = hi - float(np.min(ps))
        thr0 = max(opt.noise_multiple * noise, opt.leg_fraction * r0)
        found = pressure_rises(t, ps, dpdt, everywhere, thr0, opt.cycle_fraction * r0, opt)
        first = found[0].a if found else None
    base, base_src = _base(t, ps, first, noise, opt)
    span = max(hi - base, 0.0)
    band = max(opt.noise_multiple * noise, opt.idle_fraction * span)
    thr = max(opt.noise_multiple * noise, opt.leg_fraction * span)
    if band <= 0:  # a constant record
        band = thr = max(abs(base), 1.0) * 1e-9
    dt = float(np.median(np.diff(t))) if n > 1 else 0.0
    scales = RecordScales(noise=noise, base=base, base_source=base_src, span=span, band=band,
                          rate_scale=rate_scale, dt=dt)
    notes.append(scales.describe())
    if used_rate:
        unmet = unmetered_rises(t, ps, dpdt, pump, thr, opt)
        for r in unmet:
            pump[r.a:r.b] = True
        pump = join_short(pump, short, opt.gap_samples)
        if unmet:
            notes.append(f"{len(unmet)} pressurisation(s) without metered rate taken as "
                         "pumping")
    else:
        found = pressure_rises(t, ps, dpdt, everywhere, thr, opt.cycle_fraction * span, opt)
        rough_level = max(opt.rough_multiple * noise, opt.rough_fraction * span)
        pump = pressure_pumping(t, ps, found, base, noise, opt, p, rough_level)
        notes.append("no pump rate: phases from pressure alone")

    # ---------------------------------------------------------------- releases
    free = ~pump
    returns, logged = return_flow(record, free, rate_scale, opt)
    bits = np.zeros(n, np.int64)
    bits[returns] |= _BITS[ReleaseEvidence.RETURN_FLOW]
    bleed = np.zeros(n, bool)
    flowback = returns.copy()
    releases = find_releases(record, ps, dpdt, pump, base, noise, opt,
                             pressure_only=not used_rate,
                             returns=returns.copy() if logged else None)
    pump_runs = runs(pump)
    # a return volume read through a slope window starts a return run up to half that window
    # before the fluid moves; where the pressure's own release starts within that reach,
    # the returns start with it (a metered return rate is taken as it is)
    for a_r, b_r in (runs(returns) if record.return_rate is None else []):
        later = [rel.a for rel in releases if a_r < rel.a < b_r]
        if later and min(later) - a_r <= opt.settle_samples:
            returns[a_r:min(later)] = False
    # a metered return rate is logged a sample or two after the choke opens: the flowback
    # starts where the pressure leaves its decline just before the returns
    for a_r, b_r in runs(returns):
        drop = float(ps[a_r] - np.min(ps[a_r:b_r]))
        d = departure(t, ps, pump, a_r, opt.slope_half, noise, drop, opt)
        if d is not None and a_r - opt.settle_samples <= d < a_r and not pump[d:a_r].any():
            returns[d:a_r] = True
    flowback = returns.copy()
    bits[:] = 0
    bits[returns] |= _BITS[ReleaseEvidence.RETURN_FLOW]
    for rel in releases:
        a, b = rel.a, rel.b
        notes.append(rel.describe(t))
        for ev in rel.evidence:
            bits[a:b] |= _BITS[ev]
        if np.mean(returns[a:b]) >= 0.5 or (not used_rate
                                             and _controlled(t, ps, a, b, pump_runs)):
            flowback[a:b] = True
        else:
            bleed[a:b] = True
    flowback &= ~bleed

    # ---------------------------------------------------------------- labels
    lab = np.where(ps - base >= band, _CODES["shut_in"], _CODES["idle"])
    lab[flowback] = _CODES["flowback"]
    lab[bleed] = _CODES["bleed"]
    lab[pump] = _CODES["pump"]
    rs = _merge_short(_label_runs(lab), opt.min_phase_samples)

    # ---------------------------------------------------------------- volumes
    if record.volume is not None:
        cum_in = cum_positive(record.volume)
    elif rate is not None:
        cum_in = cum_rate(t, rate)
    else:
        cum_in = None
    if record.return_volume is not None:
        cum_out = cum_positive(record.return_volume)
    elif record.return_rate is not None:
        cum_out = cum_rate(t, record.return_rate)
    elif record.volume is not None and rate_scale:
        v = np.nan_to_num(record.volume)
        dv = np.diff(v, prepend=v[:1])
        step = 2.0 * rate_scale * np.diff(t, prepend=t[0])
        cum_out = np.cumsum(np.where((dv < 0) & (-dv <= step) & free, -dv, 0.0))
    else:
        cum_out = None
    # the p-V curve wants the finest volume resolution: the integrated rate beats a
    # totaliser that counts in 0.1 m^3 steps
    pv_volume = cum_rate(t, rate) if used_rate else cum_in

    # a totaliser logs the volume moved since the sample before: the step into the first
    # sample of a pump phase (or of a flowback / bleed) was pumped (returned) by that phase,
    # not by the shut-in before it (on a 30 s log that step is a whole sample's pumping)
    cum_in = _own_first_step(cum_in, [a for kind, a, _ in rs if kind == "pump"])
    cum_out = _own_first_step(cum_out, [a for kind, a, _ in rs
                                        if kind in ("flowback", "bleed")])
    phases = [_make_phase(record, kind, a, b, cum_in, cum_out, bits) for kind, a, b in rs]
    phases, groups = _cycle_groups(phases, ps, base, span, band, noise, opt,
                                     pressure_only=not used_rate)
    merged: list[Phase] = []
    for ph in phases:  # neighbours of the same kind after flushes became idle
        if merged and merged[-1].kind == ph.kind and ph.kind != "pump":
            merged[-1] = _make_phase(record, ph.kind, merged[-1].i0, ph.i1, cum_in, cum_out,
                                     bits)
        else:
            merged.append(ph)
    starts = {phases[g[0]].i0 for g in groups}
    ends = {phases[g[1] - 1].i1 for g in groups}
    cycles = _cycles(record, merged, starts, ends, ps, base, pv_volume, opt, noise)
    notes.append(f"{len(cycles)} cycle(s): " + ", ".join(c.kind for c in cycles)
                 if cycles else "no cycles found")
    return Segmentation(phases=tuple(merged), cycles=tuple(cycles), used_rate=used_rate,
                        notes=tuple(notes), scales=scales)


def _controlled(t, ps, a: int, b: int, pump_runs) -> bool:
    """Without a rate: whether the release over ``[a, b)`` is a controlled flowback.

    A valve opened to bleed releases the pressure faster than the pump built it; a
    flowback through a choke returns the fluid at a lower rate than it was pumped, so its
    fall (10-90 % of the drop) takes longer than the rise (10-90 % of the gain) of the
    pumping before it.
    """
    before = [r for r in pump_runs if r[1] <= a]
    if not before:
        return False
    pa, pb = before[-1]
    rise = ps[pa:pb]
    if rise.size < 3:
        return False
    gain = float(np.max(rise) - rise[0])
    if gain <= 0:
        return False
    r10 = pa + int(np.argmax(rise >= rise[0] + 0.1 * gain))
    r90 = pa + int(np.argmax(rise >= rise[0] + 0.9 * gain))
    fall = ps[a:b]
    drop = float(fall[0] - np.min(fall))
    f10 = a + int(np.argmax(fall <= fall[0] - 0.1 * drop))
    f90 = a + int(np.argmax(fall <= fall[0] - 0.9 * drop))
    return (t[f90] - t[f10]) > (t[r90] - t[r10])


# ====================================================================== cycles
def _cycle_groups(phases: list[Phase], ps, base, span, band, noise, opt: SegmentOptions, *,
                  pressure_only: bool) -> tuple[list[Phase], list[tuple[int, int]]]:
    """Group the pump phases into cycles; pumping that opens none from base becomes idle.

    Returns the phases (flushes relabelled) and, per cycle, the range ``[k0, k1)`` of phase
    indices it covers (trailing idle excluded).
    """
    pumps = [k for k, ph in enumerate(phases) if ph.kind == "pump"]
    metered = any(phases[k].pumped_m3 > 0 for k in pumps)

    def amount(ph: Phase) -> float:
        return ph.pumped_m3 if metered else ph.duration

    groups: list[dict] = []
    for k in pumps:
        ph = phases[k]
        p_start = float(np.min(ps[max(0, ph.i0 - opt.settle_samples): ph.i0 + 1]))
        peak_i = ph.i0 + int(np.argmax(ps[ph.i0:ph.i1]))
        if groups:
            g = groups[-1]
            low = float(np.min(ps[g["peak_i"]: ph.i0 + 1])) if ph.i0 > g["peak_i"] else ps[ph.i0]
            released = (low - base <= opt.release_fraction * (g["peak"] - base)
                        or p_start - base < band)
            # from a shut-in well, pumping as much again as a good part of what the cycle
            # pumped so far is a new pressurisation, not a top-up
            restart = (phases[k - 1].kind == "shut_in"
                       and phases[k - 1].i1 - phases[k - 1].i0 >= opt.min_phase_samples
                       and amount(ph) >= opt.restart_fraction * g["amount"] > 0)
            if restart and pressure_only:
                # without a rate, pumping on from the level the last rise reached, not
                # fallen from it beyond the noise (a staircase: the pump held at a rate, the
                # pressure still approaching its level), is the same pressurisation; a
                # shut-in well pumped again (a held test pressurised further) had leaked off
                restart = g["peak"] - p_start > opt.noise_multiple * noise
            if not (released or restart):
                g["pumps"].append(k)
                g["amount"] += amount(ph)
                if ps[peak_i] > g["peak"]:
                    g["peak"], g["peak_i"] = float(ps[peak_i]), peak_i
                continue
        groups.append({"k0": k, "pumps": [k], "p_start": p_start, "peak": float(ps[peak_i]),
                       "peak_i": peak_i, "amount": amount(ph)})
    need = opt.cycle_fraction * span

    def enough(g):
        return g["peak"] - base >= need and g["peak"] - g["p_start"] >= need

    # a pressurisation from base too small to be a cycle, followed by pumping that starts
    # from the pressure it left (above the idle band), is the first stage of that cycle
    staged: list[dict] = []
    for g in groups:
        if staged and not enough(staged[-1]) and g["p_start"] - base >= band \
                and staged[-1]["p_start"] - base < band \
                and float(np.min(ps[phases[staged[-1]["pumps"][-1]].i1: phases[g["k0"]].i0 + 1]))\
                - base > opt.noise_multiple * noise:
            prev = staged.pop()
            g = {**g, "k0": prev["k0"], "pumps": prev["pumps"] + g["pumps"],
                 "p_start": prev["p_start"]}
            if prev["peak"] > g["peak"]:
                g["peak"], g["peak_i"] = prev["peak"], prev["peak_i"]
        staged.append(g)
    groups = staged
    keep: list[dict] = []
    out = list(phases)
    for g in groups:
        ok = enough(g)
        if ok and pressure_only:
            # the pressure must be held after the pumping (a shut-in, above half the
            # cycle's height): released at once, it was circulation against friction
            kl = g["pumps"][-1]
            last = phases[kl]
            half = base + 0.5 * (g["peak"] - base)
            below = np.flatnonzero(ps[last.i1:] < half)
            held = below[0] if below.size else ps.size - last.i1
            shut = kl + 1 < len(phases) and phases[kl + 1].kind == "shut_in"
            ok = shut and min(held, phases[kl + 1].i1 - phases[kl + 1].i0) \
                >= opt.min_phase_samples
        # a failed group that starts pressurised right after a cycle (no idle between) is
        # a top-up of that cycle; any other is a flush or circulation: not a test
        idle_between = bool(keep) and any(
            ph.kind == "idle" for ph in phases[keep[-1]["pumps"][-1] + 1: g["k0"]])
        g["top_up"] = not ok and bool(keep) and g["p_start"] - base >= band and not idle_between
        if ok:
            keep.append(g)
        elif not g["top_up"]:
            for k in g["pumps"]:
                out[k] = replace(out[k], kind="idle", evidence=())
    # a well shut in after a cycle's pumping stays shut in until something opens it (a
    # release) or it is pumped again, even if its pressure falls back to base (a long
    # falloff into a formation below the well's hydrostatic level)
    for g in keep:
        for k in range(g["pumps"][-1] + 1, len(out)):
            if out[k].kind == "idle":
                out[k] = replace(out[k], kind="shut_in")
            elif out[k].kind != "shut_in":
                break
    result: list[tuple[int, int]] = []
    starts = [g["k0"] for g in keep]
    failed_from_base = [g["k0"] for g in groups if g not in keep and not g["top_up"]]
    bounds = sorted(set(starts) | set(failed_from_base))
    for g in keep:
        k0 = g["k0"]
        later = [b for b in bounds if b > k0]
        k1 = later[0] if later else len(out)
        # the cycle is over once the well has stood idle for as long as it was pumped
        pumping = sum(out[k].duration for k in g["pumps"])
        for k in range(g["pumps"][-1] + 1, k1):
            if out[k].kind == "idle" and out[k].duration >= pumping:
                k1 = k
                break
        while k1 - 1 > k0 and out[k1 - 1].kind == "idle":
            k1 -= 1
        result.append((k0, k1))
    return out, result


def _cycles(record, phases, starts, ends, ps, base, pv_volume, opt, noise) -> list[Cycle]:
    """Cycles over the merged phases, from each start sample to each end sample."""
    by_start = {ph.i0: k for k, ph in enumerate(phases)}
    members_list = []
    for s in sorted(starts):
        k0 = by_start.get(s)
        if k0 is None:
            continue
        e = min((x for x in ends if x > s), default=phases[-1].i1)
        k1 = k0
        while k1 < len(phases) and phases[k1].i1 <= e:
            k1 += 1
        members_list.append(tuple(phases[k0:max(k1, k0 + 1)]))
    shapes = []
    for m in members_list:
        k_next = by_start.get(m[-1].i1)
        again = (m[-1].kind == "shut_in" and k_next is not None
                 and phases[k_next].kind == "pump")
        shapes.append(measure(record, m, ps, base, pv_volume, opt, repressurised=again,
                              noise=noise))
    kinds = classify(shapes, opt)
    cycles = []
    for c, (members, (kind, reason)) in enumerate(zip(members_list, kinds)):
        cycles.append(Cycle(
            index=c + 1, kind=kind, phases=members,
            t_start=members[0].t_start, t_end=members[-1].t_end,
            peak_pressure=max(ph.peak_pressure for ph in members),
            pumped_m3=float(sum(ph.pumped_m3 for ph in members)),
            returned_m3=float(sum(ph.returned_m3 for ph in members)),
            reason=reason))
    return cycles
