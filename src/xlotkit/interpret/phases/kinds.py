"""What kind of test a cycle is: line test, casing test, LOT, XLOT, DFIT, step-rate test,
stimulation or other.

Each cycle is measured first (:class:`CycleShape`: its p-V curve, the departure from the
linear trend, the fall while pumping, the hold after pump stop, its rate steps), then
classified with the other cycles of the record at hand, because a line test is told by
comparison: its pressurisation is far stiffer, on far less volume, than the well's.

Rules, in order (thresholds: :class:`~xlotkit.interpret.phases.options.SegmentOptions`):

1. ``line_test``: pressurised with less than ``line_test_volume`` of the largest volume
   pumped to a cycle's peak (no metered volume at all: an unmetered test pump), or with
   less than ten times that and a pressurisation stiffness dp/dV ``line_test_stiffness``
   times that of the softest other cycle. Needs a metered volume and another cycle to
   compare with (a record holding a line test alone calls it a casing test).
2. ``step_rate``: pumped in at least ``min_rate_steps`` rate steps, each higher than the
   one before, with the pressure stabilised on each (it moves over the step's last third by
   at most ``rate_step_stable`` of the change into the step, beyond three standard errors
   of that movement), and no breakdown: the
   pressure never rose more than ``xlot_fall`` of the gain above the highest stabilised
   level. (An XLOT whose rate was raised in steps after breakdown stays an XLOT.)
3. ``stimulation``: pumped in at least ``min_rate_steps`` rate levels (steps at least
   ``4 rate_step_change`` of the highest rate apart) that climb to a highest rate and then
   step down again (a treatment with a step-down at its end).
4. The p-V curve of the pressurisation (every pumping sample up to the pump phase reaching
   the cycle's highest pressure; p against pumping time when no volume is known) gives the
   stiffness as a line between 15 % and 60 % of the gain and the departure as the first
   lasting fall below it by more than ``departure_tolerance`` of the gain -- or, linear all
   the way to the peak, the peak itself when pumping went on past it (0.15 times the
   volume to the peak) with the pressure below the line (a brittle breakdown). The gain is
   counted from the level before pumping or, when the gauge steps up the moment the rate
   is on (pipe friction and entry losses on a surface gauge: the line's intercept at zero
   volume lies a significant step above that level and the early samples are already on
   the line), from the line's intercept: net of the friction step.
   ``xlot`` when pumped more than ``xlot_past_ratio`` times the volume to departure past
   it, or at least 0.15 times while the pressure flattened (gained less than 30 % of the
   linear trend), or fell by ``xlot_fall`` of the gain while pumping; ``lot`` when it
   departed but pumping stopped soon after.
5. ``dfit``: a ``lot``/``xlot`` with one injection (no second pump phase, and the falloff
   not ended by pumping into the shut-in well), no flowback, and a shut-in at least
   ``dfit_falloff_ratio`` times the injection time: a DFIT or mini-frac.
6. No departure: ``casing_test`` when held (the pressure falls at most ``hold_max_drop`` of
   its height above base over up to ``hold_ratio`` times the pumping time, held at least
   ``min_hold_ratio`` times it), else ``other``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from xlotkit.interpret.phases.options import SegmentOptions
from xlotkit.interpret.phases.signal import noise_level, running_median
from xlotkit.interpret.phases.types import Phase
from xlotkit.record import Record

__all__ = ["CycleShape", "RateStep", "classify", "measure", "rate_steps"]

_BAR = 1.0e5


@dataclass(frozen=True)
class RateStep:
    """One rate step of a pump phase: samples ``[i0, i1)`` at a steady metered rate.

    Attributes
    ----------
    i0, i1 : int
        Sample range of the step.
    rate : float
        Median rate on the step [m^3/s].
    pressure : float
        Pressure at the end of the step: median over its last third [Pa].
    drift : float
        How much the pressure moved over the step's last third (end minus start of a line
        fitted to it) [Pa].
    stable : bool
        Whether the pressure had stabilised (docstring of the module).
    """

    i0: int
    i1: int
    rate: float
    pressure: float
    drift: float
    stable: bool


def rate_steps(record: Record, pumps: list[Phase], opt: SegmentOptions | None = None,
               gain: float | None = None) -> tuple[RateStep, ...]:
    """The steady-rate steps of the pumping in ``pumps`` (empty without a metered rate).

    The rate is median-filtered over ``3 rate_filter_samples``; a step runs while the rate
    stays within half of ``rate_step_change`` of the highest rate (or three times the
    rate's own noise, if larger) of its running median, and is kept if it lasts at least
    ``min_pump_samples`` and a twentieth of the pumping. Successive steps at rates closer
    than ``rate_step_change`` of the highest rate are one step (what lies between them,
    a ramp or a pause, included).

    Parameters
    ----------
    record : Record
    pumps : list of Phase
        The pump phases (in order).
    opt : SegmentOptions, optional
    gain : float, optional
        Pressure gained over the pressurisation [Pa] (the scale of "stabilised" when the
        change into a step is small); default: the pressure range over the pumping.
    """
    opt = opt or SegmentOptions()
    if record.rate is None or not pumps:
        return ()
    idx = np.concatenate([np.arange(ph.i0, ph.i1) for ph in pumps])
    q = running_median(np.nan_to_num(record.rate[idx]), 3 * opt.rate_filter_samples)
    qmax = float(np.max(q)) if q.size else 0.0
    if qmax <= 0:
        return ()
    p = np.asarray(record.pressure, float)[idx]
    t = record.t[idx]
    if gain is None:
        gain = float(np.nanmax(p) - np.nanmin(p))
    tol = max(0.5 * opt.rate_step_change * qmax, 3.0 * noise_level(q))
    shortest = max(opt.min_pump_samples, idx.size // 20)
    spans: list[list[int]] = []
    a = 0
    for j in range(1, q.size + 1):
        gap = j < q.size and idx[j] != idx[j - 1] + 1
        if j == q.size or gap or abs(q[j] - np.median(q[a:j])) > tol:
            if j - a >= shortest and np.median(q[a:j]) > opt.pump_on * qmax:
                spans.append([a, j])
            a = j
    merged: list[list[int]] = []
    for s in spans:
        if merged and abs(np.median(q[s[0]:s[1]]) - np.median(q[merged[-1][0]:merged[-1][1]])
                          ) < opt.rate_step_change * qmax:
            merged[-1][1] = s[1]
        else:
            merged.append(s)
    out: list[RateStep] = []
    prev_p = float(np.nanmin(p[: max(1, opt.settle_samples)]))
    for a, b in merged:
        third = max(3, (b - a) // 3)
        tt, pp = t[b - third:b], p[b - third:b]
        ok = np.isfinite(pp)
        drift = drift_se = 0.0
        if ok.sum() >= 4 and np.ptp(tt[ok]) > 0:
            x, y = tt[ok] - tt[ok].mean(), pp[ok]
            s = float(np.dot(x, y - y.mean()) / np.dot(x, x))
            res = y - y.mean() - s * x
            span = float(tt[ok][-1] - tt[ok][0])
            drift = s * span
            # the drift's own noise: the standard error of the fitted slope times the span
            drift_se = float(np.sqrt(np.dot(res, res) / (x.size - 2) / np.dot(x, x))) * span
        level = float(np.nanmedian(pp))
        change = abs(level - prev_p)
        stable = abs(drift) <= opt.rate_step_stable * max(change, 0.1 * gain) + 3.0 * drift_se
        out.append(RateStep(int(idx[a]), int(idx[b - 1]) + 1, float(np.median(q[a:b])),
                            level, drift, bool(stable)))
        prev_p = level
    return tuple(out)


@dataclass(frozen=True)
class CycleShape:
    """What :func:`classify` reads from one cycle (pressures [Pa], volumes [m^3])."""

    head: str
    p0: float
    peak: float
    gain: float
    volume_to_peak: float | None
    volume_pumped: float | None
    stiffness: float | None
    stiffness_text: str
    departure_text: str | None
    departed: bool
    xlot: bool
    fell_text: str
    held: bool
    held_text: str
    single_injection: bool
    falloff_ratio: float
    has_flowback: bool
    steps: tuple[RateStep, ...]
    hint: str
    staged: int = 0


def _pump_time(t: np.ndarray, members: tuple[Phase, ...], kmain: int) -> float:
    return float(sum(t[min(ph.i1, t.size - 1)] - t[ph.i0] for ph in members[: kmain + 1]
                     if ph.kind == "pump"))


def _main_pump(members) -> int:
    """Index (in ``members``) of the pump phase that reaches the cycle's highest pressure."""
    pumps = [k for k, ph in enumerate(members) if ph.kind == "pump"]
    return max(pumps, key=lambda k: (members[k].peak_pressure, -k))


def _hold(t, members, kmain, ps, base, tp, opt) -> tuple[float, float]:
    """Duration [s] and fractional fall of the shut-in after the main pump phase.

    The hold runs over the shut-in (and top-up) phases that follow; the fall is read over
    ``hold_ratio`` times the pumping time ``tp``, after skipping ``settle_samples`` (the
    step at pump stop is friction and compliance, not a leak), relative to the pressure
    above base.
    """
    i0 = members[kmain].i1
    i1 = i0
    for ph in members[kmain + 1:]:
        if ph.kind in ("shut_in", "pump"):
            i1 = ph.i1
        else:
            break
    if i1 <= i0 + 1:
        return 0.0, 1.0
    s = min(i0 + opt.settle_samples, i1 - 1)
    e = i0 + int(np.searchsorted(t[i0:i1], t[s] + opt.hold_ratio * tp))
    e = min(max(e, s + 1), i1 - 1)
    excess = ps[s] - base
    if excess <= 0:
        return float(t[i1 - 1] - t[i0]), 1.0
    fall = float((ps[s] - np.min(ps[s:e + 1])) / excess)
    return float(t[i1 - 1] - t[i0]), max(fall, 0.0)


_HINT_WORDS = ("test", "xlot", "lot", "line", "casing", "fit", "flush", "bleed", "flow",
               "dfit", "frac", "step")


def _event_hint(record: Record, members, lookback: int) -> str:
    """Remarks logged around the cycle's first pump phase (from ``lookback`` samples before
    it), as supporting text."""
    t0 = float(record.t[max(members[0].i0 - lookback, 0)])
    t1 = members[0].t_end
    texts = [e.text for e in record.events
             if t0 <= e.t <= t1 and any(w in e.text.lower() for w in _HINT_WORDS)]
    return ("; remarks: " + ", ".join(repr(s) for s in texts)) if texts else ""


def _pv_line(x: np.ndarray, p: np.ndarray, k: int, p0: float, gain: float
             ) -> tuple[np.ndarray, float | None, float]:
    """The linear p-V trend of a pressurisation up to its peak sample ``k``.

    Fitted between 15 % and 60 % of the gain above ``p0``; a coarse log that puts fewer
    than 3 samples in that band is read over the lower three quarters of the rise instead
    (still below any leak-off bend), through two samples if that is all it has there.
    Returns the samples used, the slope (None when fewer than two samples or no spread)
    and the intercept at ``x = 0``.
    """
    lo, hi = p0 + 0.15 * gain, p0 + 0.6 * gain
    sel = np.flatnonzero((p[: k + 1] >= lo) & (p[: k + 1] <= hi))
    if sel.size < 3:
        sel = np.flatnonzero((p[: k + 1] >= p0 + 0.05 * gain) & (p[: k + 1] <= p0 + 0.75 * gain))
    if sel.size >= 2 and np.ptp(x[sel]) > 0:
        slope, icpt = np.polyfit(x[sel], p[sel], 1)
        return sel, float(slope), float(icpt)
    return sel, None, 0.0


def _start_step(x: np.ndarray, p: np.ndarray, raw: np.ndarray, k: int, p0: float,
                gain: float, noise: float, opt: SegmentOptions) -> float | None:
    """The pressure step at the pump start [Pa], or None when there is none.

    A surface gauge reads the pipe friction and entry losses on top of the well's
    pressure: they appear the moment the rate is on, as a step, and the loading line starts
    from there. The step is the p-V line's intercept at zero pumped volume above the level
    before pumping ``p0``. It is taken when it is significant (``noise_multiple`` noise and
    ``departure_tolerance`` of the gain) and, with the line refitted over the band above
    the step, the early pumping samples below that band (the first two left out: the rate
    ramping up) already lie on it within ``departure_tolerance`` of the gain: the pressure
    jumped onto the line. Leak-off from the start bends the early p-V curve below its later
    line instead (its intercept is above ``p0`` too, but the early samples fall short of
    it); a stiffening start puts the intercept below ``p0``.
    """
    _, slope, icpt = _pv_line(x, p, k, p0, gain)
    tol = opt.departure_tolerance * gain
    if slope is None or slope <= 0 or icpt - p0 <= max(opt.noise_multiple * noise, tol) \
            or icpt - p0 >= 0.5 * gain:
        return None
    sel, slope, icpt = _pv_line(x, p, k, icpt, p[k] - icpt)
    if slope is None or slope <= 0 or not sel.size:
        return None
    early = np.arange(2, int(sel[0]))
    if early.size < 2:
        return None
    off = raw[early] - (icpt + slope * x[early])
    if np.mean(np.abs(off) <= tol) < 0.8:
        return None
    step = icpt - p0
    return float(step) if step > max(opt.noise_multiple * noise, tol) else None


def measure(record: Record, members: tuple[Phase, ...], ps: np.ndarray, base: float,
            pv_volume: np.ndarray | None, opt: SegmentOptions, *,
            repressurised: bool = False, noise: float = 0.0) -> CycleShape:
    """Measure one cycle for :func:`classify` (module docstring, rule 4).

    ``repressurised``: the cycle's shut-in is ended by the next cycle's pumping (no release
    between), which a DFIT's falloff is not. ``noise``: the record's pressure noise [Pa]
    (a step at the pump start must exceed ``noise_multiple`` times it).
    """
    t = record.t
    kmain = _main_pump(members)
    pumps = [ph for ph in members[: kmain + 1] if ph.kind == "pump"]
    idx = np.concatenate([np.arange(ph.i0, ph.i1) for ph in pumps])
    p = ps[idx]
    nstart = max(1, min(members[0].i1 - members[0].i0, opt.settle_samples))
    # the level the pumping started from: on a coarse log the first pumping sample may
    # already be well up the rise, the sample before it is not
    p0 = float(np.min(ps[max(idx[0] - 1, 0): idx[0] + nstart]))
    k = int(np.argmax(p))
    pk = float(p[k])
    gain = pk - p0
    have_v = pv_volume is not None
    if have_v:
        x = np.cumsum(np.diff(pv_volume[idx], prepend=pv_volume[idx[0]]))
    else:
        # pumping time; steps between separate pump phases are not counted
        dt = np.diff(t[idx], prepend=t[idx[0]])
        dt[1:][np.diff(idx) > 1] = 0.0
        x = np.cumsum(dt)
    xu = "m3" if have_v else "s of pumping"
    tp = _pump_time(t, members, kmain)
    hold_s, hold_fall = _hold(t, members, kmain, ps, base, tp, opt)
    held = hold_s >= opt.min_hold_ratio * tp and hold_fall <= opt.hold_max_drop
    if hold_s <= 0:
        held_text = "not held"
    elif hold_fall >= 1.0:
        # the fall is read relative to the pressure above base: at or below base it is all
        # of it (a falloff into a formation below the well's hydrostatic level)
        held_text = f"held {hold_s / 60:.0f} min, fell to the pre-test level"
    else:
        held_text = (f"held {hold_s / 60:.0f} min, fell {100 * hold_fall:.0f} % of the "
                     "pressure above the pre-test level")
    hint = _event_hint(record, members, 15 * opt.settle_samples)
    pumped = float(sum(ph.pumped_m3 for ph in pumps))
    # ------------------------------------------------------------ p-V linearity
    raw = np.asarray(record.gauge_pressure(), float)[idx]
    step = _start_step(x, p, raw, k, p0, gain, noise, opt)
    net = ""
    if step is not None:
        # a step at the pump start (pipe friction and entry losses on a surface gauge, read
        # the moment the rate is on): the pressurisation is judged from the p-V line's own
        # start, its intercept at zero volume, not from the level before pumping
        p0 += step
        gain = pk - p0
        net = f" (net of a {step / _BAR:.3g} bar step at the pump start)"
    sel, slope, icpt = _pv_line(x, p, k, p0, gain)
    head = f"+{gain / _BAR:.0f} bar{net} to {pk / _BAR:.0f} bar gauge"
    if have_v:
        head = f"{pumped:.3g} m3 pumped, " + head
    vpk = max(float(x[k]), 0.0) if have_v else None
    stiff_v = gain / vpk if (have_v and vpk and vpk > 0) else (np.inf if have_v else None)
    dep = None
    if slope is not None:
        if slope > 0:
            tol = opt.departure_tolerance * gain
            below = (icpt + slope * x[: k + 1] - p[: k + 1]) > tol
            below[: sel[-1] + 1] = False
            # lasting: the rest of the way to the peak stays mostly below the line
            for j in np.flatnonzero(below):
                if np.mean(below[j: k + 1]) >= 0.8:
                    dep = int(j)
                    break
            # linear all the way to the peak, and pumping went on past it (at least 0.15
            # times the volume to the peak) with the pressure mostly below the line: the
            # rock gave way at the peak (a brittle breakdown, no bend first)
            if dep is None and k + 1 < p.size and x[-1] - x[k] >= 0.15 * x[k] > 0 \
                    and np.mean(icpt + slope * x[k + 1:] - p[k + 1:] > tol) >= 0.8:
                dep = k
        else:
            slope = None
    if have_v and slope is not None:
        stiff_v = float(slope)
    fall = float((pk - np.min(p[k:])) / gain) if gain > 0 else 0.0
    x_total = float(x[-1])
    stiff_text = ""
    if slope is not None:
        stiff_text = (f"; linear p-V at {slope / _BAR:.3g} bar/m3" if have_v
                      else f"; linear rise at {slope / _BAR * 60:.3g} bar/min")
    fell_text = (f"; pressure fell {100 * fall:.0f} % while pumping"
                 if fall >= opt.xlot_fall else "")
    if dep is None and fall >= opt.xlot_fall:
        dep = k  # breakdown straight off the linear trend
    dep_text = None
    xlot = False
    if dep is not None:
        x_dep = max(float(x[dep]), 1e-300)
        past = (x_total - x_dep) / x_dep
        dep_text = (f"; departs from linear at {p[dep] / _BAR:.0f} bar after {x_dep:.3g} {xu}, "
                    f"{x_total - x_dep:.3g} {xu} pumped past it ({past:.1f}x)")
        # how much of the pressure the linear trend promised for the volume pumped past the
        # departure was actually gained: ~0 when the pressure flattened or fell (the
        # fracture took the fluid), ~1 when the curve had only just begun to bend
        promised = (slope if slope is not None else gain / max(float(x[k]), 1e-300)) * (
            x_total - x_dep)
        built = (pk - float(p[dep])) / promised if promised > 0 else 1.0
        flattened = past >= 0.15 and built <= 0.3
        if flattened:
            dep_text += f", gaining {100 * built:.0f} % of the linear trend"
        # a breakdown (the pressure fell while pumping) is never a LOT
        xlot = past >= opt.xlot_past_ratio or flattened or fall >= opt.xlot_fall

    # ------------------------------------------------------------ DFIT shape
    after = members[kmain + 1:]
    n_pumps = sum(ph.kind == "pump" for ph in members)
    shut = 0.0
    for ph in after:
        if ph.kind != "shut_in":
            break
        shut = float(t[min(ph.i1, t.size - 1)] - t[members[kmain].i1])
    has_flowback = any(ph.kind == "flowback" for ph in members)
    steps = rate_steps(record, pumps, opt, gain=gain)
    # without a rate: pump phases (rises) each to a higher level than the one before, the
    # level held between them -- rate steps or pressurisation stages
    staged = 0
    if record.rate is None and len(pumps) > 1:
        tops = [float(np.max(ps[ph.i0:ph.i1])) for ph in pumps]
        staged = len(pumps) if all(b > a for a, b in zip(tops, tops[1:])) else 0
    return CycleShape(head=head, p0=p0, peak=pk, gain=gain, volume_to_peak=vpk,
                      volume_pumped=float(x_total) if have_v else None,
                      stiffness=None if stiff_v is None else float(stiff_v),
                      stiffness_text=stiff_text, departure_text=dep_text,
                      departed=dep is not None, xlot=xlot, fell_text=fell_text, held=held,
                      held_text=held_text,
                      single_injection=n_pumps == 1 and not repressurised,
                      falloff_ratio=shut / tp if tp > 0 else 0.0,
                      has_flowback=has_flowback, steps=steps, hint=hint, staged=staged)


def _steps_text(steps: tuple[RateStep, ...]) -> str:
    return ", ".join(f"{s.rate * 6e4:.4g} l/min at {s.pressure / _BAR:.1f} bar"
                     + ("" if s.stable else " (not stabilised)") for s in steps)


def classify(shapes: list[CycleShape], opt: SegmentOptions) -> list[tuple[str, str]]:
    """Kind and reason of every cycle of a record (module docstring)."""
    out: list[tuple[str, str]] = []
    vols = [s.volume_pumped for s in shapes if s.volume_pumped is not None]
    vmax = max(vols) if vols else 0.0
    for i, s in enumerate(shapes):
        # ------------------------------------------------------------ line test
        others = [o.stiffness for j, o in enumerate(shapes)
                  if j != i and o.stiffness is not None and np.isfinite(o.stiffness)]
        if s.volume_to_peak is not None and len(shapes) > 1:
            soft = min(others) if others else None
            tiny = vmax > 0 and s.volume_to_peak < opt.line_test_volume * vmax
            stiff = (soft is not None and s.stiffness is not None
                     and s.stiffness >= opt.line_test_stiffness * soft
                     and s.volume_to_peak < 10.0 * opt.line_test_volume * vmax)
            if tiny or stiff:
                what = (f"stiffness {s.stiffness / _BAR / 1000.0:.2g} bar/l"
                        if s.stiffness is not None and np.isfinite(s.stiffness)
                        else "no metered volume")
                cmp = (f", {s.stiffness / soft:.0f}x the softest other cycle" if stiff
                       else f", {100 * s.volume_to_peak / vmax:.2g} % of the largest "
                            "cycle volume")
                out.append(("line_test", f"line_test: {s.head}; {what}{cmp}: lines against "
                                         f"a closed valve; {s.held_text}{s.hint}"))
                continue
        # ------------------------------------------------------------ rate steps
        if len(s.steps) >= opt.min_rate_steps:
            rates = [st.rate for st in s.steps]
            up = all(b > a for a, b in zip(rates, rates[1:]))
            # a treatment's stages: levels at least four rate steps apart, climbing to the
            # highest rate and stepping down again
            levels = [rates[0]]
            for r in rates[1:]:
                if abs(r - levels[-1]) >= 4 * opt.rate_step_change * max(rates):
                    levels.append(r)
            top = int(np.argmax(levels))
            up_down = (len(levels) >= opt.min_rate_steps and 0 < top < len(levels) - 1
                       and all(b > a for a, b in zip(levels[:top], levels[1:top + 1]))
                       and all(b < a for a, b in zip(levels[top:], levels[top + 1:])))
            stable = all(st.stable for st in s.steps)
            # a breakdown before or on the steps leaves the peak above every stabilised level
            hump = (s.peak - max(st.pressure for st in s.steps)) / s.gain if s.gain > 0 else 0
            txt = _steps_text(s.steps)
            if up and stable and hump < opt.xlot_fall:
                out.append(("step_rate", f"step_rate: {s.head}; {len(s.steps)} increasing "
                                         f"rate steps, pressure stabilised on each: {txt}"
                                         f"{s.hint}"))
                continue
            if up_down:
                out.append(("stimulation", f"stimulation: {s.head}; {len(levels)} rate "
                                           f"levels up to {levels[top] * 6e4:.4g} l/min and "
                                           f"down again: {txt}{s.fell_text}{s.hint}"))
                continue
        # ------------------------------------------------------------ staged, no rate
        if s.staged >= opt.min_rate_steps:
            # the plateaus may be the pump running at a steady rate (a step-rate test) or
            # holds between pressurisation stages: the pressure alone cannot tell
            out.append(("other", f"other: {s.head}; from the pressure alone: {s.staged} "
                                 "rises, each to a higher level held before the next -- the "
                                 "rate steps of a step-rate test or the stages of a "
                                 "pressurisation, which only a metered rate can tell apart "
                                 f"(and give the FEP){s.hint}"))
            continue
        # ------------------------------------------------------------ departure
        if s.departed:
            base_kind = "xlot" if s.xlot else "lot"
            if (s.single_injection and not s.has_flowback
                    and s.falloff_ratio >= opt.dfit_falloff_ratio):
                out.append(("dfit", f"dfit: {s.head}{s.stiffness_text}{s.departure_text}"
                                    f"{s.fell_text}: one injection past leak-off and a falloff "
                                    f"{s.falloff_ratio:.1f}x the injection time without "
                                    f"flowback (DFIT / mini-frac){s.hint}"))
            elif base_kind == "xlot":
                out.append(("xlot", f"xlot: {s.head}{s.stiffness_text}{s.departure_text}"
                                    f"{s.fell_text}: pumped well past leak-off "
                                    f"(breakdown/propagation); {s.held_text}{s.hint}"))
            else:
                out.append(("lot", f"lot: {s.head}{s.stiffness_text}{s.departure_text}"
                                   f"{s.fell_text}: pumping stopped soon after leak-off; "
                                   f"{s.held_text}{s.hint}"))
            continue
        if s.held:
            out.append(("casing_test", f"casing_test: {s.head}{s.stiffness_text}; no departure "
                                       f"from linear; {s.held_text}{s.hint}"))
        else:
            out.append(("other", f"other: {s.head}{s.stiffness_text}; no departure, "
                                 f"{s.held_text}{s.hint}"))
    return out
