"""Fracture closure from a flowback through a fixed choke: the system stiffness approach.

Physics (Raaen et al. 2001; SPEC §9)
------------------------------------
During flowback the well is bled through a choke of fixed opening. The rate through the choke
follows the orifice law

.. math:: Q(t) = \\zeta \\sqrt{p_c(t) - p_{atm}},

with :math:`p_c` the pressure upstream of the choke (the surface pressure) and :math:`\\zeta`
a constant for a given choke and fluid. The system stiffness :math:`S = -dp/dV_{ret}` links
pressure and returned volume, so :math:`dp/dt = -S Q` and

.. math:: \\frac{d}{dt}\\sqrt{p_c - p_{atm}} = -\\frac{S \\zeta}{2}.

At constant stiffness, :math:`\\sqrt{p_c - p_{atm}}` is a straight line in time. While the
fracture is open the system is compliant (well plus fracture compliance, small ``S``); once it
has closed only the well compliance is left (large ``S``, a steeper line). The two lines meet
at closure. Plotting pressure against returned volume gives two straight lines as well, whose
slopes are the two system stiffnesses; they meet at the same closure point.

Two methods are offered, both returning a :class:`~xlotkit.interpret.picks.types.Pick` named
``"FCP"``:

``flowback_sqrt_p``
    two lines in :math:`\\sqrt{p_c - p_{atm}}` versus ``t``. The intersection time is mapped
    back to the record's own pressure reference (see *Choke pressure* below).
``flowback_p_v``
    two lines in record pressure versus returned volume; ``details.stiffness_open`` and
    ``details.stiffness_closed`` [Pa/m^3] with standard errors
    (:class:`~xlotkit.interpret.picks.details.FlowbackDetails`).

Choke pressure
--------------
The choke sees the surface pressure. It is taken, in order of preference, from

1. ``record.channels["surface_pressure"]`` (assumed gauge, as cementing-unit gauges are);
2. the record's own pressure when its reference is ``surface`` (made gauge with
   :meth:`~xlotkit.record.Record.gauge_pressure`);
3. for a downhole/bottom-hole record without a surface channel: the record pressure minus a
   base pressure, ``record.meta["hydrostatic_pa"]`` if given, else the pressure at the end of
   the flowback phase (median of its last samples). The base stands for the hydrostatic
   column: at the end of a full flowback the choke is at atmospheric pressure and the gauge
   reads the hydrostatic head. If the flowback is stopped early this base is too high and the
   lines bend slightly; the ``p vs V`` method does not depend on it.

The FCP is always reported on the record's pressure reference: for (1) the fitted choke
pressure at the intersection plus the local offset between record and choke pressure (median
of the difference around the intersection time: hydrostatic head plus friction); for (2)
the intersection squared (plus atmosphere for an absolute record); for (3) the intersection
squared plus the base.

Flowing samples
---------------
Only samples during which fluid flows back are used (:func:`flowing_mask`): a segmentation's
flowback phase may begin with a few shut-in samples, whose slow decline followed by the
fast flowback would look like a compliant line followed by a stiff one. With neither a
return rate nor a returned volume, this cannot be checked and every sample of the phase is
used.

Returned volume
---------------
``record.return_volume`` (relative to its value at flowback start), else the time integral of
``record.return_rate``, else the fall of the cumulative (net) volume ``record.volume``.

Intervals and quality
---------------------
Each method finds the break with a continuous two-line (hinge) fit, then fits the two
tangents independently on the data on either side (leaving out a margin around the break,
where a gradual closure bends the curve) and intersects them. The interval is the union of
``value ± 2 sigma`` (first-order propagation of the fit covariances,
:func:`~xlotkit.interpret.picks.models.intersect`) and the spread of the value over perturbed
windows (margins of 5/10/20 % of each side, outer ends trimmed by 0/10 %). Quality is
``good`` when both tangents fit well (R^2 >= 0.98), the stiffness contrast is clear (ratio of
slopes >= 1.5) and the interval is narrow (< 1 % of the value); ``fair`` with R^2 >= 0.9, a
ratio >= 1.2 and an interval < 5 %; ``poor`` otherwise.

When the data show one straight line only (the flowback ended above closure, or the fracture
was already closed when it started) the methods return :meth:`Pick.not_found` saying so.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from xlotkit.interpret.phases import Cycle, Phase
from xlotkit.interpret.picks.details import FlowbackDetails, LineDetails
from xlotkit.interpret.picks.intervals import (
    IntervalBudget,
    budget,
    correlation_inflation,
    find_transition,
)
from xlotkit.interpret.picks.models import (
    LineFit,
    fit_hinge,
    fit_line,
    intersect,
    window_spread,
)
from xlotkit.interpret.picks.pressurisation import noise_level, quantum
from xlotkit.interpret.picks.types import Pick
from xlotkit.record import ATMOSPHERE_PA, Record

__all__ = [
    "FLOWBACK_METHODS",
    "choke_pressure",
    "flowing_mask",
    "pick_fcp_flowback",
    "returned_volume",
]

#: Method names produced by :func:`pick_fcp_flowback`, in the order they are returned.
FLOWBACK_METHODS = ("flowback_sqrt_p", "flowback_p_v")

#: How a flowback pick's message starts when the decline is one straight line (the method
#: ran on enough data and saw no stiffness change); such a pick has ``details.single_line``.
ONE_LINE = "only one straight line"

# Fewest samples allowed on each tangent; below this the fit covariance is meaningless.
_MIN_POINTS = 5
# Smallest ratio of closed / open slopes accepted as a stiffness change. Fracture compliance
# below ~10 % of the well's is indistinguishable from curvature caused by leak-off or noise.
_MIN_RATIO = 1.1
# Hinge must beat a single line by this F statistic to count as two lines (very conservative
# compared with the F(2, n) 99.9 % quantile of ~7, because real declines are never exactly
# straight and curvature alone must not produce a "closure").
_MIN_F = 25.0
# Fraction of the initial choke pressure below which the choke law is no longer trusted
# (flow becomes laminar / intermittent, and sqrt amplifies gauge noise near zero).
_TAIL_FRACTION = 0.03
_TAIL_MIN_PA = 0.5e5


# --------------------------------------------------------------------------- inputs
@dataclass(frozen=True)
class ChokePressure:
    """Choke (surface gauge) pressure of a record and how to map it back.

    Attributes
    ----------
    p : ndarray, shape (n,)
        Gauge pressure upstream of the choke [Pa].
    source : {"channel", "record", "base"}
        Where it came from (see the module docstring).
    base : float
        For ``source == "base"``: the base pressure subtracted from the record [Pa].
    description : str
        Human-readable explanation for reports.
    """

    p: np.ndarray
    source: str
    base: float
    description: str


def _flowback_phase(cycle: Cycle, window: tuple[float, float] | None = None
                    ) -> tuple[Phase | None, tuple[str, ...]]:
    """The cycle's first flowback phase; a user window overrides the phase boundaries it
    crosses (the neighbouring phases it reaches into join the flowback, pumping never), with
    a note for each."""
    fb = cycle.phase("flowback")
    if fb is None or window is None:
        return fb, ()
    ph = list(cycle.phases)
    k = next(j for j, q in enumerate(ph) if q is fb)
    a = b = k
    notes = []
    while b + 1 < len(ph) and ph[b + 1].kind != "pump" and ph[b + 1].t_start <= window[1] \
            and window[1] > ph[b].t_end:
        notes.append(f"the window overrides the end of the flowback at t = {ph[b].t_end:.0f} s")
        b += 1
    while a - 1 >= 0 and ph[a - 1].kind != "pump" and ph[a - 1].t_end >= window[0] \
            and window[0] < ph[a].t_start:
        notes.append(f"the window overrides the start of the flowback at t = "
                     f"{ph[a].t_start:.0f} s")
        a -= 1
    if a == b:
        return fb, ()
    return replace(fb, i0=ph[a].i0, i1=ph[b].i1, t_start=ph[a].t_start,
                   t_end=ph[b].t_end), tuple(notes)


def choke_pressure(record: Record, phase: Phase | None = None) -> ChokePressure:
    """Pressure upstream of the choke, gauge [Pa] (see the module docstring for the rules).

    Parameters
    ----------
    record : Record
    phase : Phase, optional
        The flowback phase; needed for downhole records without a surface channel (its end
        gives the base pressure).
    """
    surf = record.channels.get("surface_pressure")
    if surf is not None:
        return ChokePressure(np.asarray(surf, float), "channel", 0.0,
                             "surface_pressure channel (gauge)")
    if record.reference.kind == "surface":
        return ChokePressure(record.gauge_pressure(), "record", 0.0,
                             "record pressure (surface gauge)")
    base = record.meta.get("hydrostatic_pa")
    if base is not None:
        base = float(base)
        how = "record pressure minus meta['hydrostatic_pa']"
    else:
        if phase is None:
            raise ValueError("a downhole record without a surface channel needs the flowback "
                             "phase to estimate the base (hydrostatic) pressure")
        tail = record.pressure[max(phase.i0, phase.i1 - 5):phase.i1]
        base = float(np.median(tail))
        how = "record pressure minus its value at the end of flowback (hydrostatic estimate)"
    return ChokePressure(record.pressure - base, "base", base, how)


def returned_volume(record: Record, phase: Phase) -> tuple[np.ndarray | None, str]:
    """Volume returned since the start of ``phase`` [m^3], for the phase's samples.

    Returns
    -------
    v : ndarray, shape (phase.i1 - phase.i0,) or None
        None when the record carries no volume information.
    source : str
        Which series was used.
    """
    sl = slice(phase.i0, phase.i1)
    if record.return_volume is not None:
        v = record.return_volume[sl]
        return v - v[0], "return_volume"
    if record.return_rate is not None:
        t = record.t[sl]
        q = record.return_rate[sl]
        v = np.concatenate([[0.0], np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(t))])
        return v, "integrated return_rate"
    if record.volume is not None:
        v = record.volume[sl]
        return v[0] - v, "fall of cumulative volume"
    return None, ""


def flowing_mask(record: Record, phase: Phase) -> tuple[np.ndarray, str]:
    """Samples of ``phase`` during which fluid actually flows back, as a boolean mask.

    A segmentation may let the flowback phase start a little early or end late (the
    pressure-based phase limits lag the choke operation); samples without flow are shut-in
    data and would masquerade as a second straight line. The flow is read from
    ``return_rate`` (> 2 % of its maximum in the phase), else from the rise of the returned
    volume (same threshold on its smoothed derivative). Without either, every sample counts.
    The mask is the contiguous span from the first to the last flowing sample.
    """
    sl = slice(phase.i0, phase.i1)
    n = phase.i1 - phase.i0
    q = None
    how = "all samples (no return flow recorded)"
    if record.return_rate is not None:
        q = np.asarray(record.return_rate[sl], float)
        how = "return_rate > 2 % of its maximum"
    else:
        v, src = returned_volume(record, phase)
        if v is not None and n >= 3:
            t = record.t[sl]
            k = max(1, n // 50)
            # Differences over k samples: volume totalisers are coarse.
            q = np.gradient(np.convolve(v, np.ones(k) / k, mode="same"), t)
            how = f"rise of the returned volume ({src})"
    mask = np.ones(n, bool)
    if q is not None and np.any(np.isfinite(q)) and np.nanmax(q) > 0:
        flowing = np.flatnonzero(q > 0.02 * np.nanmax(q))
        if flowing.size:
            mask[:] = False
            mask[flowing[0]:flowing[-1] + 1] = True
    return mask, how


# --------------------------------------------------------------------------- two lines
@dataclass(frozen=True)
class _TwoLines:
    x: float
    x_se: float
    y: float
    y_se: float
    left: LineFit
    right: LineFit
    masks: tuple[np.ndarray, np.ndarray]
    trials: tuple[tuple[float, float], ...]  # (x*, y*) over perturbed windows
    # The first n_graded trials are the margin/trim variants that grade the quality; the
    # rest (tangents next to the break) widen only the interval.
    n_graded: int = 10**9


def _line_or_none(x: np.ndarray, y: np.ndarray, m: np.ndarray) -> LineFit | None:
    if int(m.sum()) < _MIN_POINTS:
        return None
    try:
        return fit_line(x[m], y[m])
    except Exception:
        return None


def _masks_around(u: np.ndarray, u0: float, margin: float, trim: float):
    """Masks of the two tangents in the ordering variable ``u`` (time, increasing).

    ``margin`` and ``trim`` are fractions of each side's length: the margin is left out next
    to the break, the trim at the outer end.
    """
    a, b = float(u[0]), float(u[-1])
    la, lb = u0 - a, b - u0
    left = (u >= a + trim * la) & (u <= u0 - margin * la)
    right = (u >= u0 + margin * lb) & (u <= b - trim * lb)
    return left, right


def _two_lines(u: np.ndarray, x: np.ndarray, y: np.ndarray, *,
               tangents: Sequence[tuple[float, float]] | None) -> _TwoLines | str:
    """Find two straight lines in ``y(x)`` and their intersection.

    ``u`` is time (monotonic) used to order the data and to express windows; ``x`` is the
    abscissa of the fit (time or returned volume). Returns a message string when there is no
    clear second line.
    """
    n = x.size
    if n < 2 * _MIN_POINTS:
        return f"too few flowback samples ({n}) for two straight lines"
    n_graded_masks = 10**9
    if tangents is not None:
        (a0, a1), (b0, b1) = tangents
        base_masks = [((u >= a0) & (u <= a1), (u >= b0) & (u <= b1))]
        trials_masks = []
        for s in (0.0, 0.1):
            for r in (0.0, 0.1):
                la, lb = a1 - a0, b1 - b0
                trials_masks.append(((u >= a0 + s * la) & (u <= a1 - r * la),
                                     (u >= b0 + r * lb) & (u <= b1 - s * lb)))
    else:
        try:
            h = fit_hinge(x, y, min_points=_MIN_POINTS)
        except Exception as exc:
            return f"two-line fit failed: {exc}"
        single = fit_line(x, y)
        sse1 = float(np.sum((y - single(x)) ** 2))
        sse2 = float(np.sum((y - h(x)) ** 2))
        f_stat = (sse1 - sse2) / 2.0 / max(sse2 / max(n - 4, 1), 1e-300)
        s1, s2 = h.s1, h.s2
        if not (np.isfinite(s1) and np.isfinite(s2)):
            return "two-line fit did not converge"
        ratio = s2 / s1 if s1 != 0 else np.inf
        if f_stat < _MIN_F or not (s1 < 0 and s2 < 0) or ratio < _MIN_RATIO:
            return (f"{ONE_LINE} (slope ratio {ratio:.3g}, F={f_stat:.3g}): "
                    "no stiffness increase, the flowback either ended above closure or "
                    "started with the fracture already closed")
        # The hinge is in x; express the break in u (time) for the windows. Both abscissae
        # used here (time, returned volume) grow with time; the running maximum makes noisy
        # volumes monotonic for the interpolation.
        u0 = float(np.interp(h.x0, np.maximum.accumulate(x), u))
        base_masks = [_masks_around(u, u0, 0.10, 0.0)]
        trials_masks = [_masks_around(u, u0, m, tr) for m in (0.05, 0.10, 0.20)
                        for tr in (0.0, 0.10)]
        trials_masks.append(_masks_around(u, u0, 0.0, 0.0))
        # Tangents close to the break (the last / first 30 % of each side): on a curved
        # decline they, not the long secants, are the lines that meet at the break.
        n_graded_masks = len(trials_masks)
        trials_masks += [_masks_around(u, u0, m, tr) for m, tr in ((0.05, 0.65), (0.10, 0.6))]

    best = None
    for ml, mr in base_masks:
        left, right = _line_or_none(x, y, ml), _line_or_none(x, y, mr)
        if left is not None and right is not None:
            best = (left, right, ml, mr)
    if best is None:
        # Fall back to no margin: short flowbacks leave few points on the closed side.
        for ml, mr in trials_masks[::-1]:
            left, right = _line_or_none(x, y, ml), _line_or_none(x, y, mr)
            if left is not None and right is not None:
                best = (left, right, ml, mr)
                break
    if best is None:
        return f"fewer than {_MIN_POINTS} samples on one of the two tangents"
    left, right, ml, mr = best
    xs, xse, ys, yse = intersect(left, right)
    if not np.isfinite(xs):
        return "the two tangents are parallel"
    lo, hi = sorted((float(np.min(x)), float(np.max(x))))
    if not (lo <= xs <= hi):
        return "the tangents intersect outside the flowback data"
    trials = []
    n_graded = 0
    for k, (tl, tr) in enumerate(trials_masks):
        fl, fr = _line_or_none(x, y, tl), _line_or_none(x, y, tr)
        if fl is None or fr is None:
            continue
        xi, _, yi, _ = intersect(fl, fr)
        if np.isfinite(xi) and lo <= xi <= hi:
            trials.append((xi, yi))
            if k < n_graded_masks:
                n_graded += 1
    return _TwoLines(xs, xse, ys, yse, left, right, (ml, mr), tuple(trials), n_graded)


def _quality(tl: _TwoLines, value: float, low: float, high: float, ratio: float) -> str:
    # R^2 alone would penalise the short, shallow open-fracture line under gauge noise even
    # when it is precisely determined; the interval width measures that precision directly.
    r2 = min(tl.left.r2, tl.right.r2)
    rel = (high - low) / abs(value) if value else np.inf
    if r2 >= 0.98 and ratio >= 1.5 and rel < 0.01:
        return "good"
    if r2 >= 0.9 and ratio >= 1.2 and rel < 0.05:
        return "fair"
    return "poor"


def _line_details(f: LineFit) -> LineDetails:
    return LineDetails.of(f)


def _fit_width(value: float, se: float, spread: tuple[float, float]) -> tuple[float, float]:
    """The fit-only range (2 sigma and the window spread) that grades a pick's quality."""
    se = se if np.isfinite(se) else 0.0
    lo, hi = value - 2.0 * se, value + 2.0 * se
    s_lo, s_hi = spread
    if np.isfinite(s_lo):
        lo, hi = min(lo, s_lo), max(hi, s_hi)
    return float(lo), float(hi)


def _flowback_budget(res: _TwoLines, u: np.ndarray, x: np.ndarray, y: np.ndarray,
                     pressure: np.ndarray, value: float, se: float, trials, resolution: float,
                     noise_floor: float = 0.0) -> IntervalBudget:
    """The 90 % interval of a two-line flowback pick (:mod:`~xlotkit.interpret.picks.
    intervals`): the intersection's standard error inflated for correlated residuals, the
    spread over the perturbed windows, the pressure span over which the data leaves both
    lines (a gradual closure) and the gauge's resolution."""
    (ml, mr) = res.masks
    infl = max(correlation_inflation(y[ml] - res.left(x[ml])),
               correlation_inflation(y[mr] - res.right(x[mr])))
    i_b = int(np.argmin(np.abs(x - res.x)))
    u0 = float(u[i_b])
    left, right = u0 - float(u[0]), float(u[-1]) - u0
    span = find_transition(u, x, y, pressure, u0, left, right,
                           noise=max(noise_level(y), noise_floor))
    tr = None if span is None else (span[0], span[1])
    return budget(value, stderr=se, inflation=infl, trials=trials, transition=tr,
                  resolution=resolution)


# --------------------------------------------------------------------------- methods
def _window_mask(t: np.ndarray, window: tuple[float, float] | None) -> np.ndarray:
    if window is None:
        return np.ones(t.size, bool)
    t0, t1 = window
    return (t >= t0) & (t <= t1)


def _pick_sqrt_p(record: Record, phase: Phase, window, tangents) -> Pick:
    name, method = "FCP", "flowback_sqrt_p"
    sl = slice(phase.i0, phase.i1)
    try:
        choke = choke_pressure(record, phase)
    except ValueError as exc:
        return Pick.not_found(name, method, str(exc))
    t = record.t[sl]
    pc = choke.p[sl]
    flow, flow_how = flowing_mask(record, phase)
    pcf = pc[flow]
    p_start = float(np.max(pcf[: max(3, pcf.size // 20)])) if pcf.size else 0.0
    keep = _window_mask(t, window) & (pc > max(_TAIL_FRACTION * p_start, _TAIL_MIN_PA))
    keep &= flow
    if window is None and tangents is None:
        # The first samples carry the choke-opening transient (friction of the starting
        # return flow); a few seconds are enough to skip it.
        k0 = min(3, max(0, int(keep.sum()) // 20))
        idx = np.flatnonzero(keep)
        keep[idx[:k0]] = False
    tt, y = t[keep], np.sqrt(pc[keep])
    win = (float(tt[0]), float(tt[-1])) if tt.size else None
    details = FlowbackDetails(choke_pressure=choke.description, choke_source=choke.source,
                              flowing_samples=flow_how)
    res = _two_lines(tt, tt, y, tangents=tangents)
    if isinstance(res, str):
        details = replace(details, single_line=res.startswith(ONE_LINE))
        return Pick.not_found(name, method, res, window=win, details=details)

    rec_p = record.pressure[sl][keep]
    pc_k = pc[keep]

    def to_record(ts: float, ys: float) -> float:
        p_choke = ys * ys
        if choke.source == "record":
            return p_choke + (ATMOSPHERE_PA if record.reference.absolute else 0.0)
        if choke.source == "base":
            return p_choke + choke.base
        # Local offset between the record's gauge and the choke (hydrostatic + friction).
        half = max(0.05 * (tt[-1] - tt[0]), 3 * np.median(np.diff(tt)))
        near = np.abs(tt - ts) <= half
        if near.sum() < 3:
            near = np.argsort(np.abs(tt - ts))[:3]
        return p_choke + float(np.median(rec_p[near] - pc_k[near]))

    value = to_record(res.x, res.y)
    # d p / d y = 2 y for the squared mapping; offsets are treated as exact.
    se_p = 2.0 * abs(res.y) * res.y_se
    trial_values = [to_record(xi, yi) for xi, yi in res.trials]
    spread = window_spread(trial_values[:res.n_graded])
    t_spread = window_spread([xi for xi, _ in res.trials])
    ratio = res.right.slope / res.left.slope
    q = _quality(res, value, *_fit_width(value, se_p, spread), ratio)
    # A whole-bar choke gauge is a staircase in sqrt(p) whose steps noise_level cannot see:
    # its quantisation noise q / sqrt(12), taken to the sqrt scale, is the floor.
    q_c = quantum(pc_k)
    floor = q_c / np.sqrt(12.0) / (2.0 * max(float(np.median(y)), 1.0))
    bud = _flowback_budget(res, tt, tt, y, rec_p, value, se_p, trial_values,
                           0.5 * max(quantum(rec_p), q_c), floor)
    low, high = bud.low, bud.high
    details = replace(
        details, x="t", y="sqrt(choke gauge pressure) [Pa^0.5]",
        line_open=_line_details(res.left), line_closed=_line_details(res.right),
        t_closure=float(res.x), t_closure_stderr=float(res.x_se),
        t_closure_range=tuple(float(v) for v in t_spread),
        sqrt_p_closure=float(res.y), sqrt_p_closure_stderr=float(res.y_se),
        choke_pressure_closure=float(res.y ** 2),
        base_pressure=None if choke.base is None else float(choke.base),
        slope_ratio=float(ratio), n_trials=len(res.trials),
        window_open=(float(tt[res.masks[0]][0]), float(tt[res.masks[0]][-1])),
        window_closed=(float(tt[res.masks[1]][0]), float(tt[res.masks[1]][-1])),
        interval=bud)
    msg = (f"closure where the sqrt(p) decline steepens x{ratio:.2f} "
           f"(system stiffness contrast); choke pressure from {choke.description}")
    return Pick(name=name, method=method, value=value, low=low, high=high, t=res.x,
                window=win, quality=q, message=msg, details=details, level=bud.level)


def _pick_p_v(record: Record, phase: Phase, window, tangents) -> Pick:
    name, method = "FCP", "flowback_p_v"
    sl = slice(phase.i0, phase.i1)
    v, vsrc = returned_volume(record, phase)
    t = record.t[sl]
    win = (float(t[0]), float(t[-1])) if t.size else None
    if v is None:
        return Pick.not_found(name, method, "no returned volume: the record has neither "
                              "return_volume, return_rate nor volume", window=win)
    p = record.pressure[sl]
    try:
        pc = choke_pressure(record, phase).p[sl]
    except ValueError:
        pc = p - np.min(p)
    flow = flowing_mask(record, phase)[0]
    pcf = pc[flow]
    p_start = float(np.max(pcf[: max(3, pcf.size // 20)])) if pcf.size else 0.0
    # Same tail cut as the sqrt(p) method: once the choke barely flows the returned volume
    # stalls while the pressure still drifts, which is not stiffness.
    keep = _window_mask(t, window) & (pc > max(_TAIL_FRACTION * p_start, _TAIL_MIN_PA))
    keep &= np.isfinite(v)
    keep &= flow
    tt, vv, pp = t[keep], v[keep], p[keep]
    if tt.size:
        win = (float(tt[0]), float(tt[-1]))
    details = FlowbackDetails(volume_source=vsrc)
    if tt.size and (np.nanmax(vv) - np.nanmin(vv)) <= 0:
        return Pick.not_found(name, method, "returned volume does not change during flowback",
                              window=win, details=details)
    res = _two_lines(tt, vv, pp, tangents=tangents)
    if isinstance(res, str):
        details = replace(details, single_line=res.startswith(ONE_LINE))
        return Pick.not_found(name, method, res, window=win, details=details)
    value = float(res.y)
    trial_values = [yi for _, yi in res.trials]
    spread = window_spread(trial_values[:res.n_graded])
    s_open, s_closed = -res.left.slope, -res.right.slope
    ratio = s_closed / s_open if s_open else np.inf
    q = _quality(res, value, *_fit_width(value, res.y_se, spread), ratio)
    bud = _flowback_budget(res, tt, vv, pp, pp, value, res.y_se, trial_values,
                           0.5 * quantum(pp))
    low, high = bud.low, bud.high
    vmono = np.maximum.accumulate(vv)
    t_c = float(np.interp(res.x, vmono, tt))
    details = replace(
        details, x="returned volume [m^3]", y="pressure [Pa]",
        line_open=_line_details(res.left), line_closed=_line_details(res.right),
        stiffness_open=float(s_open), stiffness_open_stderr=float(res.left.slope_stderr),
        stiffness_closed=float(s_closed), stiffness_closed_stderr=float(res.right.slope_stderr),
        stiffness_ratio=float(ratio), volume_closure=float(res.x),
        volume_closure_stderr=float(res.x_se), pressure_closure_stderr=float(res.y_se),
        t_closure=t_c, n_trials=len(res.trials),
        window_open=(float(tt[res.masks[0]][0]), float(tt[res.masks[0]][-1])),
        window_closed=(float(tt[res.masks[1]][0]), float(tt[res.masks[1]][-1])),
        interval=bud)
    msg = (f"closure where the system stiffness rises from {s_open / 1e5:.4g} to "
           f"{s_closed / 1e5:.4g} bar/m3 (returned volume from {vsrc})")
    return Pick(name=name, method=method, value=value, low=low, high=high, t=t_c,
                window=win, quality=q, message=msg, details=details, level=bud.level)


def pick_fcp_flowback(
    record: Record,
    cycle: Cycle,
    *,
    window: tuple[float, float] | None = None,
    tangents: Sequence[tuple[float, float]] | None = None,
    methods: Sequence[str] = FLOWBACK_METHODS,
) -> tuple[Pick, Pick]:
    """Fracture closure pressure from the cycle's flowback (system stiffness approach).

    Parameters
    ----------
    record : Record
    cycle : Cycle
        Must contain a ``flowback`` phase.
    window : (float, float), optional
        Elapsed-time window [s] of the flowback data to use (default: the whole phase, less
        the last few percent of choke pressure where the choke law fails); it overrides the
        flowback's phase boundaries it crosses (the phases it reaches into join the
        flowback, pumping never; only flowing samples are used, :func:`flowing_mask`).
    tangents : ((float, float), (float, float)), optional
        Fixed time windows [s] of the open-fracture and closed-fracture tangents; skips the
        automatic break search (both methods use the same windows).
    methods : sequence of str
        Which of :data:`FLOWBACK_METHODS` to compute; the others come back as not found with
        the message "not requested".

    Returns
    -------
    sqrt_p, p_v : Pick
        ``FCP`` by ``flowback_sqrt_p`` and ``flowback_p_v`` (values in Pa on the record's
        reference; not found -- with the reason in ``message`` -- when the cycle has no
        flowback or the flowback shows only one straight line).
    """
    for m in methods:
        if m not in FLOWBACK_METHODS:
            raise ValueError(f"unknown flowback method {m!r}; expected one of {FLOWBACK_METHODS}")
    if tangents is not None:
        tangents = tuple((float(a), float(b)) for a, b in tangents)
        if len(tangents) != 2 or any(b <= a for a, b in tangents):
            raise ValueError("tangents must be two (t_start, t_end) windows with t_end > t_start")
    phase, notes = _flowback_phase(cycle, window)
    if phase is None:
        msg = f"cycle {cycle.index} has no flowback phase"
        return (Pick.not_found("FCP", "flowback_sqrt_p", msg),
                Pick.not_found("FCP", "flowback_p_v", msg))
    out = []
    for m, fn in (("flowback_sqrt_p", _pick_sqrt_p), ("flowback_p_v", _pick_p_v)):
        if m in methods:
            pk = fn(record, phase, window, tangents)
            if notes:
                pk = replace(pk, message="; ".join((pk.message, *notes)).lstrip("; "))
            out.append(pk)
        else:
            out.append(Pick.not_found("FCP", m, "not requested"))
    return out[0], out[1]
