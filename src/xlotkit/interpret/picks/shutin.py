"""Fracture closure pressure (FCP) from a shut-in decline, by five methods.

All methods work on the decline after the cycle's pump stop (the shut-in that follows the
injection, :func:`~xlotkit.interpret.picks.decline.stop_pump`; a user window extends it over
the phase boundaries it crosses, :func:`~xlotkit.interpret.picks.decline.decline`) and leave
out the rapid drop right after pump stop (pipe friction, water hammer): fits start where the
early decline line of :func:`~xlotkit.interpret.picks.pressurisation.early_decline` starts.

Closure candidates at a boundary
--------------------------------
A decline ends where something is done to the well: a valve is opened for a bleed or a
flowback, the pumps restart, the record ends. The segmentation places that boundary from
filtered rates, so the operation often starts a few samples before it -- and its onset is a
sharp, lasting change of slope, which is what closure looks like. Hence:

* the **boundary zone** (:func:`~xlotkit.interpret.picks.boundary.boundary_zone`, reported as
  :class:`~xlotkit.interpret.picks.details.BoundaryZone`) is left out of every fit: the last
  :data:`~xlotkit.interpret.picks.boundary.BOUNDARY_MARGIN_SAMPLES` samples at least, and further back from where the decline
  already moves at the next phase's own rate or jumps off its line (the operation's own
  onset in this record, never a fixed number of seconds);
* a slope break must be seen to **last** inside the analysed decline (:func:`_scan_break`
  with ``confirm``): a new slope that runs straight into the next phase cannot be told from
  the operation;
* the break the scan finds on the whole decline, zone included, when it needs the zone,
  is reported as a :class:`~xlotkit.interpret.picks.details.RejectedCandidate` "at the phase
  boundary" with the reason, in the pick's ``details.rejected`` and its message;
* a candidate above the ISIP or before the early decline starts is **inside the pump-off
  drop** and rejected with that reason (:func:`_reject_reason`), as is one in the zone or
  below the decline;
* a user window overrides these automatic rejections (the user chose it): its pick is kept
  at quality ``poor`` with the reason as a warning in its message (:func:`_kept`).

Methods (``SHUTIN_METHODS``):

``tangent``
    Intersection of the early-decline tangent (the ISIP line) with a line through the late,
    stabilised decline, on p vs t (thesis Fig. 3.1 / C.6).
``sqrt_t``
    First departure from the straight line of p vs ``sqrt(dt)`` (formation linear flow).
``g_function``
    First departure from the straight line of p vs Nolte's G (``G dP/dG`` on a line through the
    origin), with the decline-type diagnosis.
``bilinear``
    Haimson's bilinear method: ``dp/dt`` vs p is two straight lines, closure where they meet.
``compliance``
    McClure et al. (2016): closure where the system stiffness starts to rise, i.e. where
    ``|dP/dG|`` starts to increase after its minimum (the fracture walls come into contact).

Closure in the record
---------------------
When the decline never leaves its straight line on both the sqrt(t) and the G plot (no
departure with statistical significance), the record does not reach closure; every method then
returns ``Pick.not_found`` with a message starting ``"no closure in the record"``.

Derivatives are local least-squares slopes over windows of constant width in log time
(Bourdet-style smoothing, :func:`~xlotkit.interpret.picks.pressurisation.local_fit`), never
sample-to-sample differences, because field pressures are quantised to 1 bar.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from xlotkit.interpret.phases import Cycle
from xlotkit.interpret.picks.boundary import boundary_zone, window_slopes
from xlotkit.interpret.picks.decline import decline
from xlotkit.interpret.picks.details import (
    BilinearDetails,
    BoundaryZone,
    ComplianceDetails,
    DepartureDetails,
    LineDetails,
    RejectedCandidate,
    ShutinDepartureDetails,
    ShutinDetails,
    SlopeBreakDetails,
    TangentDetails,
)
from xlotkit.interpret.picks.intervals import (
    IntervalBudget,
    budget,
    corner_profile,
    correlation_inflation,
    find_transition,
)
from xlotkit.interpret.picks.kink import KINK_Z, find_kink
from xlotkit.interpret.picks.models import LineFit, fit_hinge, fit_line, intersect
from xlotkit.interpret.picks.pressurisation import (
    MIN_LINE_POINTS,
    EarlyDecline,
    _user_stretch,
    departure_pick,
    early_decline,
    linear_stretch,
    local_fit,
    no_shutin_reason,
    noise_level,
    pump_phases,
    quality,
    quantum,
)
from xlotkit.interpret.picks.types import Pick
from xlotkit.record import Record

__all__ = [
    "SHUTIN_METHODS",
    "g_function",
    "nolte_g",
    "pick_fcp_bilinear",
    "pick_fcp_compliance",
    "pick_fcp_g_function",
    "pick_fcp_sqrt_t",
    "pick_fcp_tangent",
    "shutin_curves",
]

#: Fewest post-drop samples a shut-in must have to be analysed.
MIN_SHUTIN_POINTS = 20

#: Half-width of the Bourdet-style derivative window in ln(x).
DERIVATIVE_L = 0.1


# ===================================================================== G-function
def nolte_g(dtd, alpha: float = 1.0):
    """Nolte's g-function ``g(dtD, alpha)`` of dimensionless shut-in time ``dtD = dt / t_p``.

    ``alpha = 1`` (fracture area growing linearly in time, upper bound, the usual field choice):
    ``g = 4/3 [(1 + dtD)^1.5 - dtD^1.5]``, ``g0 = 4/3``.
    ``alpha = 1/2``: ``g = (1 + dtD) asin((1 + dtD)^-1/2) + dtD^1/2``, ``g0 = pi/2``.
    """
    d = np.clip(np.asarray(dtd, float), 0.0, None)
    if alpha == 1.0:
        return 4.0 / 3.0 * ((1.0 + d) ** 1.5 - d**1.5)
    if alpha == 0.5:
        return (1.0 + d) * np.arcsin((1.0 + d) ** -0.5) + np.sqrt(d)
    raise ValueError("alpha must be 0.5 or 1")


def g_function(dt, t_pump: float, alpha: float = 1.0):
    """Nolte's G-function ``G = 4/pi [g(dt/t_p) - g(0)]`` of shut-in time ``dt`` [s].

    ``t_pump`` is the pumping time [s]. With Carter leak-off and constant fracture area the
    pressure before closure is linear in G: ``p = ISIP - m G``.
    """
    g0 = 4.0 / 3.0 if alpha == 1.0 else np.pi / 2.0
    return 4.0 / np.pi * (nolte_g(np.asarray(dt, float) / t_pump, alpha) - g0)


# ===================================================================== shared data
@dataclass(frozen=True)
class _Shut:
    t: np.ndarray           # analysed decline sample times [s] (up to the boundary zone)
    p: np.ndarray           # pressures [Pa]
    dt: np.ndarray          # time since shut-in [s]
    t_s: float              # shut-in time [s]
    j0: int                 # first sample after the rapid drop
    t_pump: float           # pumping time of the cycle [s]
    isip: float             # ISIP [Pa]
    sigma: float            # noise [Pa]
    early: EarlyDecline | None
    t_all: np.ndarray       # the whole decline, boundary zone included [s]
    p_all: np.ndarray       # [Pa]
    zone: BoundaryZone      # the end of the decline where the next phase already acts
    overridden: bool        # a user window moved the end of the decline
    notes: tuple[str, ...]  # boundaries a user window overrode
    cache: dict = field(default_factory=dict, compare=False, repr=False)

    def context(self) -> dict[str, Any]:
        """The :class:`~xlotkit.interpret.picks.details.ShutinDetails` fields."""
        return {"isip": self.isip, "t_shut_in": self.t_s, "t_pump": self.t_pump,
                "drop_samples_skipped": self.j0,
                "data_window": (float(self.t[0]), float(self.t[-1])),
                "boundary": self.zone, "rejected": self.cache.get("rejected", ())}


def _isip_value(isip: Any) -> float | None:
    if isip is None:
        return None
    if isinstance(isip, Pick):
        return isip.value
    return float(isip)


def _prepare(record: Record, cycle: Cycle, method: str, isip: Any,
             window: tuple[float, float] | None = None) -> tuple[_Shut | None, Pick | None]:
    """Shut-in data with the rapid drop and the boundary zone located, or a not-found pick
    saying why. ``window`` (a user window) extends the decline over the phase boundaries it
    crosses (:func:`~xlotkit.interpret.picks.decline.decline`)."""
    dec = decline(record, cycle, window)
    if dec is None:
        return None, Pick.not_found("FCP", method, no_shutin_reason(cycle))
    t = record.t[dec.i0:dec.i1]
    p = record.pressure[dec.i0:dec.i1]
    if t.size < MIN_SHUTIN_POINTS:
        return None, Pick.not_found("FCP", method, f"shut-in too short ({t.size} samples)")
    t_s = dec.t_stop
    ed = early_decline(t, p, t_s)
    j0 = ed.j0 if ed is not None else 0
    if isinstance(isip, Pick) and isip.window is not None:
        j0 = max(j0, int(np.searchsorted(t, isip.window[0])))
    sigma = noise_level(p)
    zone = boundary_zone(record, t, p, j0, dec, sigma)
    end = int(np.searchsorted(t, zone.t_start))
    if end - j0 < MIN_SHUTIN_POINTS:
        return None, Pick.not_found(
            "FCP", method, f"shut-in too short after the pump-off drop and before "
            f"{zone.describe()} ({max(end - j0, 0)} samples)")
    pumps = pump_phases(cycle)
    t_pump = max(t_s - pumps[0].t_start, 1.0)
    iv = _isip_value(isip)
    if iv is None:
        iv = ed.fit.intercept if ed is not None else float(p[j0])
    return _Shut(t[:end], p[:end], t[:end] - t_s, t_s, j0, t_pump, float(iv), sigma, ed,
                 t, p, zone, dec.overridden, dec.notes), None


def _finish(pick: Pick, sh: _Shut) -> Pick:
    """The pick with the decline's context in its details (a ShutinDetails) and the user
    window's notes in its message."""
    ctx = sh.context()
    d = pick.details
    if isinstance(d, ShutinDetails):
        d = replace(d, **ctx)
    elif isinstance(d, DepartureDetails):
        d = ShutinDepartureDetails(departure=d, **ctx)
    else:
        d = ShutinDetails(**ctx)
    msg = "; ".join(m for m in (pick.message, *sh.notes) if m)
    return replace(pick, name="FCP", details=d, message=msg)


def _reject_reason(sh: _Shut, value: float | None, t_pick: float | None = None) -> str | None:
    """Why a closure candidate cannot be closure, or None when it can.

    Inside the pump-off drop: above the ISIP (the friction and water-hammer drop is not the
    fracture's decline) or before the early decline starts. At the phase boundary: in the
    boundary zone (:func:`~xlotkit.interpret.picks.boundary.boundary_zone`). Below the decline: lower than the lowest
    analysed pressure.
    """
    if value is None or not np.isfinite(value):
        return "no finite value"
    if value > sh.isip + 3 * sh.sigma:
        return (f"inside the pump-off drop: {value / 1e5:.1f} bar is above the ISIP "
                f"({sh.isip / 1e5:.1f} bar)")
    if t_pick is not None and np.isfinite(t_pick):
        if t_pick < float(sh.t[sh.j0]) - 1e-9:
            return (f"inside the pump-off drop: before the early decline starts at t = "
                    f"{sh.t[sh.j0]:.0f} s")
        if t_pick >= sh.zone.t_start:
            return f"at the phase boundary: inside the zone before {sh.zone.describe()}"
    if value < float(np.min(sh.p[sh.j0:])) - 3 * sh.sigma:
        return "below the lowest pressure of the analysed decline"
    return None


def _kept(pick: Pick, why: str) -> Pick:
    """A pick from a user window that the automatic checks would reject: kept (the user
    chose the window, it overrides the automatic rejections), the reason as a warning and
    the quality at most ``poor``."""
    return replace(pick, quality="poor" if pick.quality != "none" else pick.quality,
                   message="; ".join(m for m in (pick.message, f"warning: {why} (kept: the "
                                                 "user's window overrides the automatic "
                                                 "rejection)") if m))


def _inside(sh: _Shut, value: float | None) -> bool:
    """Closure must lie inside the decline: below the ISIP, above the last pressure."""
    return _reject_reason(sh, value) is None


def _pressure_at(sh: _Shut, tt: float) -> float:
    """Smoothed shut-in pressure at time ``tt`` [s] (local line over +-5 % of dt)."""
    dt = max(tt - sh.t_s, 1e-9)
    sel = (np.abs(sh.dt - dt) <= max(0.05 * dt, 2.0)) & (np.arange(sh.t.size) >= sh.j0)
    if sel.sum() >= 3:
        return float(fit_line(sh.dt[sel], sh.p[sel])(dt))
    return float(np.interp(tt, sh.t, sh.p))


# ===================================================================== closure = slope break
#: Smallest relative change of the decline slope across closure that counts as closure.
MIN_SLOPE_CHANGE = 0.1

#: Window half-widths of the break scan, as fractions of the post-drop range of G.
BREAK_SCALES = (0.03, 0.05, 0.08, 0.12)

#: Window half-widths as fractions of G itself (constant width in ln G): on a long shut-in
#: (tens of closure times, DFIT-like) the range of G dwarfs G at closure, and windows scaled
#: by the range cannot resolve the closure; these can. Their breaks only ever displace the
#: sharpest one to an earlier break of the other sense (:func:`_find_break`).
BREAK_SCALES_LOCAL = (0.1, 0.2, 0.3)

#: An earlier break of the other sense displaces the sharpest break when it scores at least
#: this fraction of it (:func:`_find_break`).
EARLIER_BREAK_FRACTION = 0.5


@dataclass(frozen=True)
class _Break:
    """The significant break of slope of the decline (closure), on p vs G.

    ``i`` indexes the post-drop samples; ``w`` is the scan window [G]; ``s_before`` and
    ``s_after`` are the slopes dP/dG [Pa] just before and after; ``score`` the jump in
    excess of the curvature trend and the noise, relative to ``|s_before|``.
    """

    i: int
    G: float
    t: float
    w: float
    s_before: float
    s_after: float
    score: float

    @property
    def ratio(self) -> float:
        """``s_after / s_before``: > 1 the system stiffens at closure, < 1 it flattens."""
        return self.s_after / self.s_before

    @property
    def kind(self) -> str:
        """``"stiffening"`` or ``"flattening"``."""
        return "stiffening" if self.ratio > 1.0 else "flattening"


def _scan_break(G: np.ndarray, p: np.ndarray, w: float, sigma: float, q: float = 0.0,
                confirm: float | np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Score of a slope break at every sample, for window ``w``.

    Three adjacent windows of width ``w`` in G: ``LL`` and ``L`` before the sample, ``R``
    after; the jump is ``s_R - s_L`` and the trend ``s_L - s_LL`` (the curvature an
    open-fracture decline has anyway: a smooth curve changes its slope by about as much over
    two equal spans, a kink does so in one). Three readings:

    * the jump goes beyond the trend extrapolated (the excess ``s_R - 2 s_L + s_LL``, the
      second difference of the window slopes, has the jump's sign): the excess must exceed
      three of its standard errors. That error is ``sigma sqrt(1/S_R + 4/S_L + 1/S_LL)``
      inflated by the record's own spread of the standardised excess over all samples
      (1.4826 MAD, when above 1): a whole-bar staircase along a slow decline, or any other
      noise correlated over a window, shows there, where the white-noise ``sigma`` would
      understate it;
    * ... but the trend runs against the jump: often a kink one window back seen from after
      it (``LL | L`` straddle it). The jump must also beat twice the part of the trend its
      noise cannot explain (beyond two standard errors) plus three errors of its own;
    * the excess runs against the jump (a curvature that ends: the tail of a decaying
      transient looks like that at every scale near its decay length): the strict rule, the
      jump beyond twice the whole trend plus three standard errors of the combination.

    The jump and the excess must each be at least :data:`MIN_SLOPE_CHANGE` of ``|s_L|``.
    Before this rule the jump always had to beat twice the trend: the trend's own noise
    then counted twice, and weak breaks on whole-bar gauges were missed (issue 19,
    ``docs/intervals.md``). Windows must hold ``MIN_LINE_POINTS`` samples each and ``R`` at
    least 60 % of its width (the new slope has to last). On pressure quantised in steps of
    ``q`` the pressure must fall by at least ``3 q`` across a window: over less, a window's
    slope depends on where the steps of the staircase fall (errors that are not independent,
    so the standard error understates them).

    Lasting (judged against ``s_2``, one line over ``LL`` and ``L`` together, so that an
    outlying slope of ``L`` alone, weighted twice in the excess, does not pass for a lasting
    change): a window further on (``RR``, to ``2 w`` after the sample) keeps at least half
    the jump; where the data end before it, that passes. With ``confirm`` (a width ``c`` of
    G, the finest scan window) the new slope must also be seen to last inside the data:
    the window from ``c`` to ``2 c`` after the sample (widened to ``MIN_LINE_POINTS``
    samples where the sampling is sparser) must lie inside the data, and it and the first
    ``c`` after the sample must each keep half the jump (the new slope holds from the break
    on) -- a break whose new slope runs straight into the
    data end (the next phase, the end of the record) cannot be told from the operation that
    ends the decline.
    """
    n = G.size
    i = np.arange(n)
    l1 = np.searchsorted(G, G - w, "left")
    l2 = np.searchsorted(G, G - 2 * w, "left")
    r1 = np.searchsorted(G, G + w, "right")
    sL, nL, xL = window_slopes(G, p, l1, i + 1)
    sLL, nLL, xLL = window_slopes(G, p, l2, np.maximum(l1, l2 + 1))
    sR, nR, xR = window_slopes(G, p, i, r1)
    ok = ((nL >= MIN_LINE_POINTS) & (nLL >= MIN_LINE_POINTS) & (nR >= MIN_LINE_POINTS)
          & (G[np.clip(r1 - 1, 0, n - 1)] - G >= 0.6 * w) & (G - G[l2] >= 1.6 * w))
    jump, trend = sR - sL, sL - sLL
    excess = jump - trend
    with np.errstate(invalid="ignore", divide="ignore"):
        z = excess / (sigma * np.sqrt(1.0 / xR + 4.0 / xL + 1.0 / xLL))
    # The noise as the record's own statistic shows it (correlated errors, a staircase).
    zs = z[ok & np.isfinite(z)]
    infl = max(1.0, 1.4826 * float(np.median(np.abs(zs - np.median(zs))))) if zs.size >= 5 \
        else 1.0
    sig = sigma * infl
    with np.errstate(invalid="ignore", divide="ignore"):
        se = sig * np.sqrt(1.0 / xR + 4.0 / xL + 1.0 / xLL)
        # A curvature that ends (the excess against the jump: a decaying transient, the end
        # of a leak-off hump) is told from a kink only by the strict rule.
        se_old = sig * np.sqrt(1.0 / xR + 1.0 / xL + 4.0 * (1.0 / xL + 1.0 / xLL))
        score = np.where(np.sign(excess) == np.sign(jump),
                         (np.abs(excess) - 3.0 * se) / np.abs(sL),
                         (np.abs(jump) - 2.0 * np.abs(trend) - 3.0 * se_old) / np.abs(sL))
        # A trend against the jump is often a kink one window back seen from after it (the
        # windows LL | L straddle it): the jump must then beat twice the part of the trend
        # the noise cannot explain, on its own error.
        se_t = sig * np.sqrt(1.0 / xL + 1.0 / xLL)
        se_j = sig * np.sqrt(1.0 / xR + 1.0 / xL)
        against = (np.sign(trend) != np.sign(jump)) & (np.sign(excess) == np.sign(jump))
        mirror = (np.abs(jump) - 2.0 * np.maximum(np.abs(trend) - 2.0 * se_t, 0.0)
                  - 3.0 * se_j) / np.abs(sL)
        score = np.where(against, np.minimum(score, mirror), score)
        rel = np.minimum(np.abs(jump), np.abs(excess)) / np.abs(sL)
    good = ok & np.isfinite(score) & (sL < 0) & (rel >= MIN_SLOPE_CHANGE) & (score > 0)
    # The slope the new one is judged against in the lasting checks: one line over both
    # windows before (LL and L), so that an outlying slope of the window just before (weight
    # two in the excess) does not pass for a lasting change.
    s2, _, _ = window_slopes(G, p, l2, i + 1)
    if q > 0:
        with np.errstate(invalid="ignore"):
            good &= np.minimum(np.abs(sL), np.abs(sR)) * w >= 3.0 * q
    # Lasting: where there is data a window further on, the slope there keeps at least half
    # the jump (a blip of the derivative is not closure).
    r2 = np.searchsorted(G, G + 2 * w, "right")
    sRR, nRR, _ = window_slopes(G, p, np.minimum(r1, n - 1), r2)
    far = (nRR >= MIN_LINE_POINTS) & (G[np.clip(r2 - 1, 0, n - 1)] - G >= 1.6 * w)
    with np.errstate(invalid="ignore"):
        good &= ~far | (np.sign(jump) * (sRR - s2) >= 0.5 * np.abs(jump))
    if confirm is not None:
        c1 = np.searchsorted(G, G + confirm, "right")
        c2 = np.searchsorted(G, G + 2 * confirm, "right")
        # a window too narrow for a line is widened to MIN_LINE_POINTS samples (sparse
        # sampling), which must then exist
        wide = c2 - c1 < MIN_LINE_POINTS
        c2 = np.where(wide, c1 + MIN_LINE_POINTS, c2)
        seen = np.where(wide, c2 <= n,
                        G[np.clip(c2 - 1, 0, n - 1)] - G >= 1.6 * confirm)
        sC, nC, _ = window_slopes(G, p, np.minimum(c1, n - 1), np.minimum(c2, n))
        # and from the break on: the first c after it (at least MIN_LINE_POINTS samples)
        e1 = np.maximum(c1, i + MIN_LINE_POINTS)
        sC0, nC0, _ = window_slopes(G, p, i, np.minimum(e1, n))
        seen &= (nC >= MIN_LINE_POINTS) & (nC0 >= MIN_LINE_POINTS)
        with np.errstate(invalid="ignore"):
            good &= seen & (np.sign(jump) * (sC - s2) >= 0.5 * np.abs(jump)) \
                & (np.sign(jump) * (sC0 - s2) >= 0.5 * np.abs(jump))
    return np.where(good, score, -np.inf), sL, sR


def _best_break(G: np.ndarray, p: np.ndarray, t: np.ndarray, sigma: float,
                confirm: bool) -> _Break | None:
    """The closure break of p vs G (``t`` the samples' times), or None.

    The sharpest break (highest score over the windows :data:`BREAK_SCALES`) is closure
    unless an earlier break of the other sense (stiffening before a flattening, or the
    reverse), clear of it by its window and found at any scale (:data:`BREAK_SCALES` or the
    local :data:`BREAK_SCALES_LOCAL`), scores at least :data:`EARLIER_BREAK_FRACTION` of it:
    then that one is. After closure a long decline changes its regime again (the
    after-closure flow bending towards the reservoir pressure), and that later change can
    be the sharper one; closure comes first. A later break of the *same* sense is not
    displaced (a gradual stiffening, such as height recession, shows early breaks of the
    same sense that are not closure). With ``confirm`` a break must be seen to last inside
    the data (:func:`_scan_break`).
    """
    span = float(G[-1] - G[0]) if G.size else 0.0
    if not span > 0:
        return None
    # A noise-free record still has round-off; the floor keeps the score finite.
    sigma = max(sigma, 1e-7 * float(np.max(np.abs(p))))
    q = quantum(p)
    best: _Break | None = None
    candidates: list[_Break] = []
    widths = [f * span for f in BREAK_SCALES] + [f * G for f in BREAK_SCALES_LOCAL]
    for j, w in enumerate(widths):
        # the new slope is confirmed over the finest window of the same kind: the finest
        # scan window of the range, or the local window itself (a long decline's range
        # would ask an early closure to last far into the after-closure flow)
        conf = (BREAK_SCALES[0] * span if j < len(BREAK_SCALES) else w) if confirm else None
        score, sL, sR = _scan_break(G, p, w, sigma, q, confirm=conf)
        ok = np.isfinite(score)
        edges = np.diff(np.concatenate([[0], ok.astype(int), [0]]))
        # One candidate per run of admissible samples: its highest score.
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            k = a + int(np.argmax(score[a:b]))
            wk = float(w[k]) if np.ndim(w) else float(w)
            c = _Break(k, float(G[k]), float(t[k]), wk, float(sL[k]), float(sR[k]),
                       float(score[k]))
            candidates.append(c)
            if j < len(BREAK_SCALES) and (best is None or c.score > best.score):
                best = c
    if best is None:
        return None
    earlier = [c for c in candidates if c.G + c.w < best.G and c.kind != best.kind
               and c.score >= EARLIER_BREAK_FRACTION * best.score]
    return max(earlier, key=lambda c: c.score) if earlier else best


def _kink_break(G: np.ndarray, p: np.ndarray, t: np.ndarray) -> _Break | None:
    """Closure as a kink against a smooth curve over wide windows
    (:func:`~xlotkit.interpret.picks.kink.find_kink`) on a coarsely quantised decline,
    where the local scan finds none (issue 19).

    Only where quantisation denies the scan its windows: the scan asks a fall of ``3 q``
    across a window, and where the decline falls by less over its finest window
    (``BREAK_SCALES[0]`` of the G range) at most of its samples (the median; a whole-bar
    gauge on a decline of less than about 100 bar) the scan cannot see the slope there.
    Elsewhere its windows see the slope, and a smooth, strongly bending decline (tip
    extension, a pressure transient in a shut-in that ends above closure, simulated to
    the Pa) is told from closure by its rules, not by a polynomial's misfit. The lines
    either side are fitted over ``2 w = W`` before and ``w = W / 2`` after the kink."""
    q = quantum(p)
    if not q > 0:
        return None
    w0 = BREAK_SCALES[0] * float(G[-1] - G[0])
    ahead = G + w0 <= G[-1]
    fall = p[ahead] - np.interp(G[ahead] + w0, G, p)
    if not (fall.size and float(np.median(fall)) < 3.0 * q):
        return None
    k = find_kink(G, p, q, min_change=MIN_SLOPE_CHANGE)
    if k is None:
        return None
    rel = abs(k.s_after - k.s_before) / abs(k.s_before)
    return _Break(k.i, float(G[k.i]), float(t[k.i]), 0.5 * k.w, k.s_before, k.s_after,
                  rel * (1.0 - KINK_Z / k.z))


def _find_break(sh: _Shut, alpha: float = 1.0) -> _Break | None:
    """Closure as the sharpest significant, lasting change of slope of p vs G, or None.

    Searched on the decline up to its boundary zone (:func:`_best_break`), a break must be
    seen to last there; where it finds none, a kink against a smooth curve over wider
    windows is looked for (:func:`_kink_break`). The break the search finds on the whole
    decline, boundary zone
    included, is kept in ``sh.cache["rejected"]`` when its new slope needs samples of the
    zone: a candidate at the phase boundary, rejected with that reason.
    """
    key = ("break", alpha)
    if key in sh.cache:
        return sh.cache[key]
    sl = slice(sh.j0, None)
    G = g_function(sh.dt[sl], sh.t_pump, alpha)
    best = _best_break(G, sh.p[sl], sh.t[sl], sh.sigma, confirm=True)
    if best is None:
        best = _kink_break(G, sh.p[sl], sh.t[sl])
    rejected = list(sh.cache.get("rejected", ()))
    if sh.t_all.size > sh.t.size:
        G_all = g_function(sh.t_all[sh.j0:] - sh.t_s, sh.t_pump, alpha)
        t_all, p_all = sh.t_all[sh.j0:], sh.p_all[sh.j0:]
        cand = _best_break(G_all, p_all, t_all, sh.sigma, confirm=False)
        if cand is not None:
            # the new slope is seen to last over 1.6 c of G after the break (_scan_break)
            c = BREAK_SCALES[0] * float(G_all[-1] - G_all[0])
            t_conf = float(np.interp(cand.G + 1.6 * c, G_all, t_all))
            if t_conf >= sh.zone.t_start or cand.t >= sh.zone.t_start:
                z = sh.zone
                what = ("the end of the record" if z.next_phase == "end of record"
                        else f"the {z.next_phase.replace('_', '-')} at t = {z.t_boundary:.0f} s")
                why = (f"at the phase boundary: its new slope runs into {what} "
                       f"({z.onset} from t = {z.t_start:.0f} s) and is not seen to last "
                       "before it")
                if all(abs(r.t - cand.t) > 1e-6 for r in rejected):
                    rejected.append(RejectedCandidate(
                        t=cand.t, pressure=float(p_all[cand.i]), where="phase boundary",
                        reason=why, slope_ratio=float(cand.ratio)))
    sh.cache["rejected"] = tuple(rejected)
    sh.cache[key] = best
    return best


def _no_break_message(sh: _Shut) -> str:
    rej = sh.cache.get("rejected", ())
    if rej:
        return ("no closure in the record before the phase boundary: the decline shows no "
                f"significant, lasting change of slope before {sh.zone.describe()}; rejected: "
                + "; ".join(r.describe() for r in rej))
    return ("no closure in the record: the decline shows no significant, lasting change of "
            f"slope to the end of the shut-in ({sh.dt[-1]:.0f} s after pump stop)")


def _closure_gate(sh: _Shut, alpha: float) -> str | None:
    """Message when the decline never goes through closure (no slope break), else None."""
    return None if _find_break(sh, alpha) is not None else _no_break_message(sh)


def _break_fit(x: np.ndarray, p: np.ndarray, t: np.ndarray, brk: _Break, G: np.ndarray,
               scale: float = 1.0):
    """Hinge fit of ``p(x)`` on the samples around the break: ``2 w`` of G before it (a
    short span, so the open-fracture curvature barely bends the line) and ``w`` after."""
    w = brk.w * scale
    sel = (G >= brk.G - 2.0 * w) & (G <= brk.G + w)
    if sel.sum() < 2 * MIN_LINE_POINTS:
        return None
    try:
        return fit_hinge(x[sel], p[sel], min_points=MIN_LINE_POINTS), sel
    except (ValueError, TypeError):
        return None


# ===================================================================== straight-line methods
def _sample_resolution(x: np.ndarray, s1: float, s2: float, x0: float) -> float:
    """Pressure change over half a sample interval at ``x0`` on the steeper line [Pa]."""
    k = int(np.clip(np.searchsorted(x, x0), 1, x.size - 1))
    dx = float(x[k] - x[k - 1])
    return 0.5 * max(abs(s1), abs(s2)) * abs(dx) if np.isfinite(dx) else 0.0


def _bootstrap_values(x: np.ndarray, p: np.ndarray, sel: np.ndarray, h, n: int = 4,
                      seed: int = 0) -> list[float]:
    """Breakpoint pressures of the hinge refitted on residual-bootstrap copies of the data.

    The residuals of the hinge fit, resampled with replacement onto the fitted curve, give
    copies of the data with the record's own noise; the spread of their breakpoints is how
    far another noise realisation would move the pick.
    """
    rng = np.random.default_rng(seed)
    xs, ps = x[sel], p[sel]
    fitted = h(xs)
    resid = ps - fitted
    out = []
    for _ in range(n):
        try:
            hb = fit_hinge(xs, fitted + rng.choice(resid, resid.size, replace=True),
                           min_points=MIN_LINE_POINTS)
        except (ValueError, TypeError):
            continue
        if np.isfinite(hb.y0):
            out.append(float(hb.y0))
    return out


def _break_pick(sh: _Shut, brk: _Break, method: str, x: np.ndarray, x_name: str,
                alpha: float) -> Pick:
    """Closure at the slope break on ``p(x)``: breakpoint of a hinge fitted around it."""
    sl = slice(sh.j0, None)
    p, t = sh.p[sl], sh.t[sl]
    G = g_function(sh.dt[sl], sh.t_pump, alpha)
    base = _break_fit(x, p, t, brk, G)
    if base is None:
        return Pick.not_found("FCP", method, "could not fit the lines either side of closure")
    h, sel = base
    value = float(h.y0)
    xs = x[sel]
    details = SlopeBreakDetails(
        x_name=x_name,
        # The line before closure (drawn on plots; on the G plot m G through the origin is
        # then the tangent to G dP/dG at closure).
        line_before=LineDetails(slope=float(h.s1), slope_stderr=float(h.s1_stderr),
                                intercept=float(h.y0 - h.s1 * h.x0),
                                x_range=(float(xs[0]), float(h.x0))),
        line_after=LineDetails(slope=float(h.s2), slope_stderr=float(h.s2_stderr),
                               intercept=float(h.y0 - h.s2 * h.x0),
                               x_range=(float(h.x0), float(xs[-1]))),
        x_range=(float(xs[0]), float(h.x0)), x_pick=float(h.x0),
        x_pick_stderr=float(h.x0_stderr), closure_signature=brk.kind,
        slope_ratio=float(brk.ratio), break_score=float(brk.score), r2=float(h.r2),
        n=int(h.n))
    t_pick = float(np.interp(h.x0, xs, t[sel]))
    why = _reject_reason(sh, value, t_pick)
    if why is not None:
        return Pick.not_found("FCP", method, f"closure candidate at {value / 1e5:.1f} bar "
                              f"rejected: {why}", details=details)
    vals = [value]
    for scale in (0.6, 1.5):
        r = _break_fit(x, p, t, brk, G, scale)
        if r is not None and _inside(sh, r[0].y0):
            vals.append(float(r[0].y0))
    vals += [v for v in _bootstrap_values(x, p, sel, h) if _inside(sh, v)]
    s = float(np.nan_to_num(h.y0_stderr))
    # The kink lies somewhere between two samples: on clean data that, not the fit, limits
    # how well the breakpoint pressure is known.
    res = _sample_resolution(xs, h.s1, h.s2, h.x0)
    # Quality grades the fit (R^2 and its own width), as before intervals had a level.
    q = quality(h.r2, value, min(vals) - max(s, res), max(vals) + max(s, res), h.n)
    bud = _shutin_budget(sh, brk, x, value, s, p[sel] - h(x[sel]), vals, res, t_pick, alpha)
    details = replace(details, trial_values=tuple(float(v) for v in vals),
                      breakpoint_stderr=s, sampling_resolution=float(res), interval=bud)
    return Pick("FCP", method, value, bud.low, bud.high, t=t_pick,
                window=(float(t[sel][0]), float(t[sel][-1])),
                quality=q, message=f"slope break ({brk.kind}: dP/dG x{brk.ratio:.2f})",
                details=details, level=bud.level)


def _derivative_budget(sh: _Shut, value: float, se: float, resid: np.ndarray, trials,
                       t_pick: float, alpha: float = 1.0, extra=()) -> IntervalBudget:
    """The 90 % interval of a closure pick read from a derivative (bilinear, compliance):
    its own fit error and trials, and the decline's transition around the pick, searched
    on p vs G as for the straight-line methods (:func:`_shutin_budget`) with the break
    scan's window."""
    brk = _find_break(sh, alpha)
    sl = slice(sh.j0, None)
    if brk is None:
        return budget(value, stderr=se, inflation=correlation_inflation(resid),
                      trials=trials, resolution=0.5 * quantum(sh.p[sl]), extra=extra)
    G = g_function(sh.dt[sl], sh.t_pump, alpha)
    return _shutin_budget(sh, brk, G, value, se, resid, trials, 0.0, t_pick, alpha, extra)


def _shutin_budget(sh: _Shut, brk: _Break, x: np.ndarray, value: float, se: float,
                   resid: np.ndarray, trials, sampling: float, t_pick: float,
                   alpha: float = 1.0, extra=()) -> IntervalBudget:
    """The 90 % interval of a closure pick at a slope break of the decline
    (:mod:`~xlotkit.interpret.picks.intervals`): the fit's standard error inflated for
    correlated residuals, the spread over fit spans and bootstrap copies, the pressure span
    over which the decline leaves both the line before and the line after closure (a
    gradual closure, searched on the method's own abscissa ``x`` around the break, sides
    of ``2 w`` and ``w`` of G as the break scan), and the resolution: half the gauge's
    quantisation step and the pressure change over half a sample at the kink."""
    sl = slice(sh.j0, None)
    G = g_function(sh.dt[sl], sh.t_pump, alpha)
    p = sh.p[sl]
    g0 = float(np.interp(t_pick, sh.t[sl], G))
    span = find_transition(G, x, p, p, g0, 2.0 * brk.w, brk.w, noise=sh.sigma)
    tr = None if span is None else (span[0], span[1])
    resolution = float(np.hypot(0.5 * quantum(p), sampling))
    infl = correlation_inflation(resid)
    extra = list(extra)
    near = (G >= g0 - brk.w) & (G <= g0 + brk.w)
    x0 = float(np.interp(g0, G, x))
    hw = 0.5 * float(np.ptp(x[near])) if near.sum() >= 8 else 0.0
    cp = corner_profile(x[near], p[near], x0, hw, inflation=infl) if hw > 0 else None
    if cp is not None:
        # Closure lies inside the decline (as every pick is checked, _inside).
        lo_p = float(np.min(p)) - 3.0 * sh.sigma
        hi_p = sh.isip + 3.0 * sh.sigma
        extra.append(("corner fit", min(max(cp[0], lo_p), value), max(min(cp[1], hi_p), value)))
    return budget(value, stderr=se, inflation=infl, trials=trials,
                  transition=tr, resolution=resolution, extra=extra)


def _straight_line_method(record: Record, cycle: Cycle, method: str, to_x: Callable,
                          x_name: str, *, window, isip, alpha: float = 1.0
                          ) -> tuple[Pick, Any, _Break | None]:
    sh, nf = _prepare(record, cycle, method, isip, window)
    if sh is None:
        return nf, None, None
    sl = slice(sh.j0, None)
    x = to_x(sh)[sl]
    if window is None:
        brk = _find_break(sh, alpha)
        if brk is None:
            nf = Pick.not_found("FCP", method, _no_break_message(sh))
            return _finish(nf, sh), sh, None
        return _finish(_break_pick(sh, brk, method, x, x_name, alpha), sh), sh, brk
    # A user window is the straight stretch: closure is the first departure from it.
    stretch = _user_stretch(sh.t[sl], window)
    pick = departure_pick("FCP", method, x, sh.p[sl], sh.t[sl], slope_sign=-1,
                          stretch=stretch, noise=sh.sigma, x_name=x_name,
                          not_found_msg="no closure in the record", prefer_early=True)
    if pick.found:
        why = _reject_reason(sh, pick.value, pick.t)
        if why is not None:
            pick = _kept(pick, why)
    return _finish(pick, sh), sh, None


def pick_fcp_sqrt_t(record: Record, cycle: Cycle, *, window: tuple[float, float] | None = None,
                    isip: Pick | float | None = None) -> Pick:
    """FCP where the slope ``dP/dsqrt(t)`` of p vs ``sqrt(dt)`` changes.

    While fluid leaks off by linear flow through the open fracture faces the pressure falls
    about linearly in the square root of shut-in time, ``p = p_1 - m sqrt(dt)``. At closure the
    derivative ``dP/dsqrt(t)`` changes abruptly -- it steepens when the system stiffens (the
    fracture compliance is gone), flattens when leak-off drops -- and closure is the pressure
    at that change: the breakpoint of two lines fitted to p vs ``sqrt(dt)`` just before and
    just after it. The break is located on the G plot (:func:`_find_break`; a kink in time
    is a kink on every time axis): it must be sharp (beyond the curvature the open-fracture
    decline has anyway), significant (beyond the noise) and lasting; without one the record
    does not reach closure. The gradual curvature of an open-fracture decline is not closure.

    Parameters
    ----------
    record, cycle
        Data and the cycle whose shut-in is analysed.
    window : (t0, t1), optional
        Elapsed-time window [s] of the straight stretch before closure; closure is then the
        first significant departure from the line through it.
    isip : Pick or float, optional
        ISIP [Pa] (its window's start also marks the end of the pump-off drop).

    Returns
    -------
    Pick
        ``name="FCP"``, ``method="sqrt_t"``; details (:class:`~xlotkit.interpret.picks.
        details.SlopeBreakDetails`): ``slope`` is ``dP/dsqrt(t)`` [Pa/s^0.5] before closure
        (``slope_after`` after), ``x_pick`` the ``sqrt(dt)`` of closure. The interval covers the
        breakpoint's standard error, the spread over fit spans and over residual-bootstrap
        copies of the data.
    """
    pick, _, _ = _straight_line_method(record, cycle, "sqrt_t", lambda s: np.sqrt(s.dt),
                                       "sqrt_t", window=window, isip=isip)
    return pick


def pick_fcp_g_function(record: Record, cycle: Cycle, *,
                        window: tuple[float, float] | None = None,
                        isip: Pick | float | None = None, alpha: float = 1.0) -> Pick:
    """FCP from the G-function plot, with the decline-type diagnosis.

    With Carter leak-off from a fracture of constant area, ``p = ISIP - m G`` before closure
    (:func:`g_function`), so ``G dP/dG`` lies on a straight line through the origin. Closure is
    where ``G dP/dG`` leaves its trend for good: upward when ``dP/dG`` rises (the system
    stiffens as the walls touch, McClure's reading), downward when it falls (leak-off stops,
    Barree's reading) -- the sharp, lasting change of slope of p vs G (:func:`_find_break`),
    at the breakpoint of two lines fitted just before and after it. A gradual curvature
    of the decline (pressure-dependent leak-off, height recession) is not closure: with
    pressure-dependent leak-off closure is at the end of the hump, not where it starts.

    The diagnosis (``details.diagnosis``) reads the shape of ``G dP/dG`` before closure
    against the line ``m G`` through the origin tangent to it at closure (Barree et al.
    2009): ``normal``, ``pressure_dependent_leakoff``, ``tip_extension``,
    ``height_recession`` or ``undetermined`` -- the rule of
    :mod:`xlotkit.interpret.diagnostics.gfunction`.

    Parameters
    ----------
    alpha : {1, 0.5}
        Area-growth exponent of Nolte's g-function.

    Returns
    -------
    Pick
        ``name="FCP"``, ``method="g_function"``; details (:class:`~xlotkit.interpret.picks.
        details.SlopeBreakDetails`): ``diagnosis``, ``x_pick`` (G at closure), ``slope``
        (``dP/dG`` [Pa] just before closure).
    """
    pick, sh, brk = _straight_line_method(
        record, cycle, "g_function", lambda s: g_function(s.dt, s.t_pump, alpha), "G",
        window=window, isip=isip, alpha=alpha)
    if sh is None:
        return replace(pick, details=SlopeBreakDetails(x_name="G", diagnosis="undetermined",
                                                       alpha=alpha))
    diagnosis, why = _diagnose(sh, pick, alpha)
    d = pick.details
    if isinstance(d, (SlopeBreakDetails, ShutinDepartureDetails)):
        d = replace(d, diagnosis=diagnosis, alpha=alpha)
    else:
        ctx = {f.name: getattr(d, f.name) for f in fields(ShutinDetails)}
        d = SlopeBreakDetails(x_name="G", diagnosis=diagnosis, alpha=alpha, **ctx)
    msg = f"decline type: {diagnosis.replace('_', ' ')} ({why})"
    if pick.message:
        msg = pick.message + "; " + msg
    return replace(pick, message=msg, details=d)


def _diagnose(sh: _Shut, pick: Pick, alpha: float) -> tuple[str, str]:
    """Decline type from the shape of ``|dP/dG|`` before closure: the rule of
    :mod:`xlotkit.interpret.diagnostics.gfunction` (one rule for the pick and the
    diagnostics)."""
    from xlotkit.interpret.diagnostics.gfunction import diagnose_curves

    if not pick.found or pick.t is None:
        return "undetermined", "no closure on the G plot"
    sl = slice(sh.j0, None)
    G = g_function(sh.dt[sl], sh.t_pump, alpha)
    dpdg, _ = local_fit(G, sh.p[sl], DERIVATIVE_L, u=np.log(np.maximum(G, 1e-12)),
                        min_points=5)
    g_c = float(np.interp(pick.t, sh.t[sl], G))
    diagnosis, why, *_ = diagnose_curves(G, -dpdg, g_c, sh.p[sl])
    return diagnosis, why


# ===================================================================== tangent
def _tangents_at_break(sh: _Shut, brk: _Break) -> Pick:
    """Tangent pick from lines on p vs t over ``2 w`` of G before the break and ``w`` after."""
    method = "tangent"
    G = g_function(sh.dt, sh.t_pump)
    post = np.arange(sh.t.size) >= sh.j0

    def lines_at(scale: float):
        w = brk.w * scale
        pre = post & (G >= brk.G - 2.0 * w) & (G <= brk.G)
        aft = post & (G > brk.G) & (G <= brk.G + w)
        if pre.sum() < MIN_LINE_POINTS or aft.sum() < MIN_LINE_POINTS:
            return None
        return fit_line(sh.dt[pre], sh.p[pre]), fit_line(sh.dt[aft], sh.p[aft]), pre, aft

    base = lines_at(1.0)
    if base is None:
        return Pick.not_found("FCP", method, "could not fit the tangents either side of closure")
    fe, fl, pre, aft = base
    xs, sxs, ys, sys_ = intersect(fe, fl)
    ie, il = np.flatnonzero(pre), np.flatnonzero(aft)
    details = TangentDetails(early=LineDetails.of(fe), late=LineDetails.of(fl),
                             early_window=(float(sh.t[ie[0]]), float(sh.t[ie[-1]])),
                             late_window=(float(sh.t[il[0]]), float(sh.t[il[-1]])),
                             closure_signature=brk.kind)
    if not np.isfinite(ys):
        return Pick.not_found("FCP", method, "no closure in the record: the tangents do not "
                              "meet", details=details)
    why = _reject_reason(sh, ys, float(sh.t_s + xs))
    if why is not None:
        return Pick.not_found("FCP", method, f"tangents meet at {ys / 1e5:.1f} bar: rejected: "
                              f"{why}", details=details)
    vals = [ys]
    for scale in (0.6, 1.5):
        r = lines_at(scale)
        if r is not None:
            y2 = intersect(r[0], r[1])[2]
            if np.isfinite(y2) and _inside(sh, y2):
                vals.append(y2)
    s = float(np.nan_to_num(sys_))
    res = _sample_resolution(sh.dt[post], fe.slope, fl.slope, xs)
    q = quality(min(fe.r2, fl.r2), ys, min(vals) - max(s, res), max(vals) + max(s, res),
                min(fe.n, fl.n))
    resid = np.concatenate([sh.p[pre] - fe(sh.dt[pre]), sh.p[aft] - fl(sh.dt[aft])])
    bud = _shutin_budget(sh, brk, sh.dt[sh.j0:], float(ys), s, resid, vals, res,
                         float(sh.t_s + xs))
    details = replace(details, sampling_resolution=float(res),
                      t_intersection=float(sh.t_s + xs), t_intersection_stderr=float(sxs),
                      pressure_on_curve=_pressure_at(sh, sh.t_s + xs),
                      trial_values=tuple(float(v) for v in vals), intersection_stderr=s,
                      interval=bud)
    return Pick("FCP", method, float(ys), bud.low, bud.high, t=float(sh.t_s + xs),
                window=(float(sh.t[ie[0]]), float(sh.t[il[-1]])), quality=q, details=details,
                level=bud.level)


def pick_fcp_tangent(record: Record, cycle: Cycle, *, window: tuple[float, float] | None = None,
                     isip: Pick | float | None = None,
                     lines: tuple[tuple[float, float], tuple[float, float]] | None = None
                     ) -> Pick:
    """FCP at the intersection of the decline tangents before and after closure, on p vs t.

    Closure shows on p vs t as a knee: the slope changes sharply (steeper when the system
    stiffens, flatter when leak-off stops). The knee is located as the sharpest significant,
    lasting change of slope (:func:`_find_break`, on the G axis; without one the record does
    not reach closure). The early tangent is fitted to the decline just before the knee (on
    a straight decline it is the ISIP line; on a curved one the ISIP line would cross the late
    line away from the knee), the late tangent to the decline just after it; closure is their
    intersection ``(t*, p*)``, ``p*`` the value. The interval combines the propagated covariance
    (:func:`~xlotkit.interpret.picks.models.intersect`) with the spread over shorter and longer
    tangent spans.

    With ``window`` or ``lines`` the tangents are the user's: the early tangent is the ISIP line
    (first smooth decline after the pump-off drop) unless ``lines`` fixes it, the late one the
    longest stretch of stable slope after it unless ``window``/``lines`` fixes it.

    Parameters
    ----------
    window : (t0, t1), optional
        Elapsed-time window [s] of the late line.
    lines : ((t0, t1), (t2, t3)), optional
        Fixed windows [s] of the early and the late line (override everything).
    """
    method = "tangent"
    spans = [w for w in ((window,) if lines is None else tuple(lines)) if w is not None]
    reach = (min(w[0] for w in spans), max(w[1] for w in spans)) if spans else None
    sh, nf = _prepare(record, cycle, method, isip, reach)
    if sh is None:
        return nf
    if lines is None:
        brk = _find_break(sh, 1.0)
        if brk is None:
            return _finish(Pick.not_found("FCP", method, _no_break_message(sh)), sh)
        if window is None:
            return _finish(_tangents_at_break(sh, brk), sh)

    def early_fit(shift: int = 0) -> tuple[LineFit, int, int] | None:
        if lines is not None:
            a, b = _user_stretch(sh.t, lines[0])
        elif sh.early is not None:
            a, b = sh.early.j0 + shift, sh.early.j1 + shift
        else:
            return None
        if b - a + 1 < 3 or b >= sh.t.size:
            return None
        return fit_line(sh.dt[a:b + 1], sh.p[a:b + 1]), a, b

    def late_fit(tol: float) -> tuple[LineFit, int, int] | None:
        """Late tangent: the longest stretch of stable slope (within ``tol``) on p vs t after
        the early window -- the "stabilised" decline."""
        win = lines[1] if lines is not None else window
        if win is not None:
            a, b = _user_stretch(sh.t, win)
            return fit_line(sh.dt[a:b + 1], sh.p[a:b + 1]), a, b
        if e is None:
            return None
        start = e[2] + 1
        half = 0.04 * float(sh.dt[-1] - sh.dt[start])
        slopes, _ = local_fit(sh.dt, sh.p, half, min_points=max(5, (sh.t.size - start) // 50))
        slopes[:start] = np.nan
        st = linear_stretch(slopes, tol=tol, min_len=MIN_LINE_POINTS, sign=-1, start=start,
                            x=sh.dt)
        if st is None:
            return None
        a, b = st
        return fit_line(sh.dt[a:b + 1], sh.p[a:b + 1]), a, b

    e = early_fit()
    lt = late_fit(0.15)
    if e is None or lt is None:
        return _finish(Pick.not_found("FCP", method, "could not fit the early or late tangent"),
                       sh)
    fe, ea, eb = e
    fl, la, lb = lt
    xs, sxs, ys, sys_ = intersect(fe, fl)
    details = TangentDetails(early=LineDetails.of(fe), late=LineDetails.of(fl),
                             early_window=(float(sh.t[ea]), float(sh.t[eb])),
                             late_window=(float(sh.t[la]), float(sh.t[lb])))
    ds = abs(fe.slope - fl.slope)
    sds = np.hypot(fe.slope_stderr, fl.slope_stderr)
    if not np.isfinite(xs) or ds <= 3 * np.nan_to_num(sds) or not (
            sh.dt[eb] <= xs <= sh.dt[lb]):
        return _finish(Pick.not_found("FCP", method, "no closure in the record: the tangents do "
                                      "not meet inside the decline", details=details), sh)
    # the lines are the user's (a window or fixed lines): a rejection becomes a warning
    why = _reject_reason(sh, ys, float(sh.t_s + xs)) if spans else None
    if why is None and not spans:
        why = _reject_reason(sh, ys, float(sh.t_s + xs))
        if why is not None:
            return _finish(Pick.not_found("FCP", method, f"tangents meet at {ys / 1e5:.1f} "
                                          f"bar: rejected: {why}", details=details), sh)
    vals = [ys]
    trial_specs = [(0, 0.1), (0, 0.25), (2, 0.15)] if lines is None else []
    for shift, frac in trial_specs:
        e_keep = e
        e = e2 = early_fit(shift)
        l2 = late_fit(frac)
        e = e_keep
        if e2 is None or l2 is None:
            continue
        _, _, y2, _ = intersect(e2[0], l2[0])
        if np.isfinite(y2) and _inside(sh, y2):
            vals.append(y2)
    s = np.nan_to_num(sys_)
    low, high = min(vals) - s, max(vals) + s
    details = replace(details, t_intersection=float(sh.t_s + xs),
                      t_intersection_stderr=float(sxs),
                      pressure_on_curve=_pressure_at(sh, sh.t_s + xs),
                      trial_values=tuple(float(v) for v in vals), intersection_stderr=float(s))
    q = quality(min(fe.r2, fl.r2), ys, low, high, min(fe.n, fl.n))
    pick = Pick("FCP", method, float(ys), float(low), float(high), t=float(sh.t_s + xs),
                window=(float(sh.t[ea]), float(sh.t[lb])), quality=q, details=details)
    return _finish(pick if why is None else _kept(pick, why), sh)


# ===================================================================== bilinear (Haimson)
def _derivative_t(sh: _Shut, L: float = DERIVATIVE_L) -> tuple[np.ndarray, np.ndarray]:
    """``dp/dt`` [Pa/s] and smoothed p over post-drop samples, window of +-L in ln(dt)."""
    sl = slice(sh.j0, None)
    dt = np.maximum(sh.dt[sl], 1e-9)
    return local_fit(dt, sh.p[sl], L, u=np.log(dt), min_points=5)


def pick_fcp_bilinear(record: Record, cycle: Cycle, *, window: tuple[float, float] | None = None,
                      isip: Pick | float | None = None) -> Pick:
    """FCP by Haimson's bilinear method: ``dp/dt`` vs p as two lines meeting at closure.

    The pressure-decay rate ``dp/dt`` [Pa/s] (log-time-windowed local slope) is plotted against
    the smoothed pressure; an open and a closed fracture each give a near-linear relation with
    a different slope. A continuous two-line (hinge) fit gives the closure pressure as its
    breakpoint, with the standard error from the fit. The lines must differ significantly
    (``|s1 - s2| > 3 sigma``) and the record must reach closure.

    Parameters
    ----------
    window : (t0, t1), optional
        Elapsed-time window [s] of the samples used (default all post-drop samples).
    """
    method = "bilinear"
    sh, nf = _prepare(record, cycle, method, isip, window)
    if sh is None:
        return nf
    gate = _closure_gate(sh, 1.0)
    if gate:
        return _finish(Pick.not_found("FCP", method, gate), sh)
    t = sh.t[sh.j0:]

    def run(L: float, cut0: float, cut1: float):
        dpdt, ps = _derivative_t(sh, L)
        sel = np.isfinite(dpdt) & np.isfinite(ps)
        if window is not None:
            sel &= (t >= window[0]) & (t <= window[1])
        else:
            n = t.size
            idx = np.arange(n)
            sel &= (idx >= int(cut0 * n)) & (idx < n - int(cut1 * n))
        if sel.sum() < 2 * MIN_LINE_POINTS:
            return None
        try:
            return fit_hinge(ps[sel], dpdt[sel], min_points=MIN_LINE_POINTS), ps[sel]
        except (ValueError, TypeError):
            return None

    base = run(DERIVATIVE_L, 0.0, 0.0)
    if base is None:
        return _finish(Pick.not_found("FCP", method, "too few samples for the bilinear fit"),
                       sh)
    h, ps = base
    details = BilinearDetails(s_closed=float(h.s1), s_open=float(h.s2),
                              s_closed_stderr=float(h.s1_stderr),
                              s_open_stderr=float(h.s2_stderr), dpdt_at_closure=float(h.y0),
                              r2=float(h.r2), n=int(h.n))
    sds = np.hypot(np.nan_to_num(h.s1_stderr), np.nan_to_num(h.s2_stderr))
    if abs(h.s1 - h.s2) <= 3 * sds:
        return _finish(Pick.not_found("FCP", method, "no closure in the record: dp/dt vs p is "
                                      "a single line", details=details), sh)
    vals = [h.x0]
    if window is None:
        for L, c0, c1 in ((0.05, 0, 0), (0.2, 0, 0), (DERIVATIVE_L, 0.1, 0), (DERIVATIVE_L, 0, .2)):
            r = run(L, c0, c1)
            if r is not None and _inside(sh, r[0].x0):
                vals.append(r[0].x0)
    s = np.nan_to_num(h.x0_stderr)
    low, high = min(vals) - s, max(vals) + s
    # Time of closure: when the smoothed pressure crossed the breakpoint.
    _, psm = _derivative_t(sh)
    k = int(np.argmax(psm <= h.x0)) if np.any(psm <= h.x0) else psm.size - 1
    why = _reject_reason(sh, float(h.x0), float(t[k]))
    if why is not None and window is None:
        return _finish(Pick.not_found("FCP", method, f"closure candidate at {h.x0 / 1e5:.1f} "
                                      f"bar rejected: {why}", details=details), sh)
    q = quality(h.r2, h.x0, low, high, h.n)
    bud = _derivative_budget(sh, float(h.x0), s, base[0].result.residual, vals, float(t[k]))
    details = replace(details, trial_values=tuple(float(v) for v in vals), x0_stderr=float(s),
                      interval=bud)
    pick = Pick("FCP", method, float(h.x0), bud.low, bud.high, t=float(t[k]),
                window=(float(t[0]), float(t[-1])) if window is None else tuple(window),
                quality=q, details=details, level=bud.level)
    return _finish(pick if why is None else _kept(pick, why), sh)


# ===================================================================== compliance (McClure)
def pick_fcp_compliance(record: Record, cycle: Cycle, *,
                        window: tuple[float, float] | None = None,
                        isip: Pick | float | None = None, alpha: float = 1.0) -> Pick:
    """FCP by the compliance method (McClure et al. 2016): onset of the stiffness increase.

    While the fracture is open the system compliance is large and ``|dP/dG|`` stays flat (or
    falls, with pressure-dependent leak-off). When the walls come into contact the compliance
    drops, the system stiffens and ``|dP/dG|`` rises. ``|dP/dG|`` is a log-G-windowed local
    slope; from its minimum to its following maximum a hinge is fitted, and closure is the
    pressure at the hinge's breakpoint ``G_c``. The rise must be significant (hinge slopes differ
    by > 3 sigma, the later one larger) and the record must reach closure.

    Parameters
    ----------
    window : (t0, t1), optional
        Elapsed-time window [s] of the derivative samples used for the hinge fit.
    alpha : {1, 0.5}
        Area-growth exponent of the G-function.
    """
    method = "compliance"
    sh, nf = _prepare(record, cycle, method, isip, window)
    if sh is None:
        return nf
    gate = _closure_gate(sh, alpha)
    if gate:
        return _finish(Pick.not_found("FCP", method, gate), sh)
    sl = slice(sh.j0, None)
    G = g_function(sh.dt[sl], sh.t_pump, alpha)
    p = sh.p[sl]
    t = sh.t[sl]
    uG = np.log(np.maximum(G, 1e-12))

    def run(L: float):
        slope, psm = local_fit(G, p, L, u=uG, min_points=5)
        d = -slope
        ok = np.isfinite(d)
        if window is not None:
            idx = np.flatnonzero(ok & (t >= window[0]) & (t <= window[1]))
        else:
            idx = np.flatnonzero(ok)
            if idx.size < 2 * MIN_LINE_POINTS:
                return None
            # Skip the first ~5 % (derivative windows clipped at the start of the data).
            idx = idx[idx.size // 20:]
            # Largest rise of |dP/dG|: maximise d[k] - min(d[:k]) over k.
            dd = d[idx]
            runmin = np.minimum.accumulate(dd)
            kk = int(np.argmax(dd - runmin))
            jmax = idx[kk]
            jmin = idx[int(np.argmin(dd[:kk + 1]))]
            # Include the approach to the minimum so the hinge has a "before" line.
            span = max(jmax - jmin, MIN_LINE_POINTS)
            idx = idx[(idx >= jmin - 2 * span) & (idx <= jmax)]
        if idx.size < 2 * MIN_LINE_POINTS:
            return None
        try:
            h = fit_hinge(G[idx], d[idx], min_points=MIN_LINE_POINTS)
        except (ValueError, TypeError):
            return None
        return h, psm, float(G[idx[-1]])

    base = run(DERIVATIVE_L)
    if base is None:
        return _finish(Pick.not_found("FCP", method, "no closure found by the compliance method: "
                                      "|dP/dG| does not rise after its minimum"), sh)
    h, psm, g_end = base
    details = ComplianceDetails(G_pick=float(h.x0), G_pick_stderr=float(h.x0_stderr),
                                dPdG_at_closure=float(-h.y0), s_before=float(h.s1),
                                s_after=float(h.s2), r2=float(h.r2), n=int(h.n), alpha=alpha)
    sds = np.hypot(np.nan_to_num(h.s1_stderr), np.nan_to_num(h.s2_stderr))
    if not (h.s2 - h.s1 > 3 * sds and h.s2 > 0):
        return _finish(Pick.not_found("FCP", method, "no closure found by the compliance method: "
                                      "no significant stiffness increase (|dP/dG| does not "
                                      "rise)",
                                      details=details), sh)

    def p_at(g0: float) -> float:
        return float(np.interp(g0, G, psm))

    value = p_at(h.x0)
    vals = [value]
    for L in (0.05, 0.2):
        r = run(L)
        if r is not None and r[0].s2 > r[0].s1:
            vals.append(p_at(r[0].x0))
    se = np.nan_to_num(h.x0_stderr)
    vals += [p_at(h.x0 - se), p_at(h.x0 + se)]
    vals = [v for v in vals if _inside(sh, v)]
    t_pick = float(np.interp(h.x0, G, t))
    why = _reject_reason(sh, value, t_pick)
    if why is not None and window is None:
        return _finish(Pick.not_found("FCP", method, f"stiffness rise at {value / 1e5:.1f} bar "
                                      f"rejected: {why}", details=details), sh)
    low, high = min(vals), max(vals)
    q = quality(h.r2, value, low, high, h.n)
    # The stiffness rises from the walls' first contact (the pick) to the end of the rise
    # (the largest |dP/dG|): the fracture closes over that span, which the interval covers.
    rise = [("stiffness rise", *sorted((p_at(g_end), value)))] if g_end > h.x0 else []
    bud = _derivative_budget(sh, value, 0.0, h.result.residual, vals, t_pick, alpha, rise)
    details = replace(details, trial_values=tuple(float(v) for v in vals), interval=bud)
    pick = Pick("FCP", method, value, bud.low, bud.high, t=t_pick,
                window=(float(t[0]), float(t[-1])), quality=q, details=details,
                level=bud.level)
    return _finish(pick if why is None else _kept(pick, why), sh)


# ===================================================================== curves for plots
def shutin_curves(record: Record, cycle: Cycle, *, alpha: float = 1.0,
                  L: float = DERIVATIVE_L) -> dict[str, np.ndarray] | None:
    """Diagnostic curves of the post-drop shut-in, for plots.

    Returns
    -------
    dict or None
        ``t`` [s], ``dt`` [s], ``p`` [Pa], ``sqrt_t`` [s^0.5], ``dp_dsqrt_t`` [Pa/s^0.5],
        ``G``, ``dp_dG`` [Pa], ``G_dp_dG`` [Pa], ``dp_dt`` [Pa/s] (log-windowed local slopes);
        None without a usable shut-in.
    """
    sh, _ = _prepare(record, cycle, "curves", None)
    if sh is None:
        return None
    sl = slice(sh.j0, None)
    dt = np.maximum(sh.dt[sl], 1e-9)
    p = sh.p[sl]
    G = g_function(dt, sh.t_pump, alpha)
    st = np.sqrt(dt)
    d_st, _ = local_fit(st, p, L / 2, u=np.log(st), min_points=5)
    d_g, _ = local_fit(G, p, L, u=np.log(np.maximum(G, 1e-12)), min_points=5)
    d_t, _ = local_fit(dt, p, L, u=np.log(dt), min_points=5)
    return {"t": sh.t[sl], "dt": dt, "p": p, "sqrt_t": st, "dp_dsqrt_t": d_st, "G": G,
            "dp_dG": d_g, "G_dp_dG": -G * d_g, "dp_dt": d_t}


#: Method name -> pick function.
SHUTIN_METHODS: dict[str, Callable[..., Pick]] = {
    "tangent": pick_fcp_tangent,
    "sqrt_t": pick_fcp_sqrt_t,
    "g_function": pick_fcp_g_function,
    "bilinear": pick_fcp_bilinear,
    "compliance": pick_fcp_compliance,
}
