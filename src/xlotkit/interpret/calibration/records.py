r"""XLOT records by construction, with a known truth, for calibrating pick intervals.

The generator is deliberately small and transparent: every pressure in a record follows
from a few lines of physics with chosen numbers, so the truth of every pick is known
exactly. It is not a simulator (see :mod:`xlotkit.sim` for those); it exists so that the
interval of a pick can be checked against a truth on hundreds of records that differ in
the ways field records differ (closure pressure, how gradually the fracture closes, noise,
sample interval, gauge resolution, leak-off behaviour, shut-in or flowback).

Physics of a record
-------------------
All pressures are bottom-hole gauge pressures [Pa] until the gauge is applied; the well
fluid's hydrostatic head is ``p_hyd = rho g D``.

*Pressurisation* (pure well storage ``C_w`` [m^3/Pa]): ``p = p_start + V / C_w`` for the
pumped volume ``V``. In cycle 1 the line bends at the leak-off pressure ``LOP`` as
``p = LOP + A (1 - exp(-(V - V_LOP) / (A C_w)))`` (slope continuous) and the formation
breaks down when ``p`` reaches ``FBP``; the pressure then relaxes to the propagation level
``ISIP + dp_nwb`` with time constant ``tau_b`` (``dp_nwb`` is the near-wellbore entry loss
the well gauge sees while fluid enters the fracture). In cycle 2 the line bends at the
reopening pressure ``Pr`` in the same way towards ``ISIP_2 + dp_nwb``: ``Pr`` is the onset
of the departure (the curve has the line's slope there and leaves it quadratically).

*Pump stop.* The entry loss drains in a few seconds:
``p_gauge = p_f + dp_nwb exp(-(t - t_s) / tau_d)``; the ISIP is the fracture pressure
``p_f(t_s)`` at pump stop.

*Decline* (shut-in and flowback) -- the volume balance of well plus fracture::

    C(p) dp/dt = -Q_leak(t, p) - Q_choke(p) - Q_wall(p)

with the system compliance ``C(p) = C_w + C_f0 S(p) H(p)``: the fracture's compliance
``C_f0`` leaves the system over a **smooth transition** ``S`` (a smootherstep, 0 below
``sigma_h - w/2``, 1 above ``sigma_h + w/2``; ``w`` the transition width). The step is
symmetric about ``sigma_h``, so the stiffness lines before and after meet exactly at
``sigma_h`` (the intersection of the two tangents of ``V(p)`` is ``sigma_h`` for any
symmetric ``S``): ``sigma_h`` is the closure truth for every method.
Leak-off models (``leakoff``):

``carter``
    ``Q_leak = kappa dG/dt (S + (1 - S) lambda (p - p0) / (sigma_h - p0))``: Carter
    leak-off from a constant area, linear in Nolte's G (``alpha = 1``) while the fracture
    is open; after closure reduced to the fraction ``lambda`` and falling with the pressure
    above the reservoir's, so the decline ends at ``p0``. ``kappa`` is set so that the
    open-fracture decline reaches ``sigma_h`` at ``G_c``.
``pressure_dependent``
    The Carter rate times ``1 + beta (p - sigma_h)_+ / (ISIP - sigma_h)`` (fissures that
    open with net pressure leak more).
``height_recession``
    Carter leak-off, and the fracture compliance grows with net pressure,
    ``H = 1 + gamma (p - sigma_h)_+ / (ISIP - sigma_h)`` (the fracture recedes from
    bounding layers as it closes, so the system stiffens gradually before closure).
``wall_leak``
    Carter leak-off plus a constant-permeability open-hole wall, ``Q_wall = J (p - p0)``.

*No closure* (``closure=False``, for the false-find rate of the closure picks): a
**single-compliance decline**. The fracture compliance never leaves the system
(``C = C_w + C_f0`` throughout, ``S = 1``) and the Carter leak falls smoothly with the
pressure above the reservoir's, ``Q_leak = kappa dG/dt (p - p0) / (ISIP - p0)`` (with
``wall_leak`` the wall leak is added): the decline bends gradually towards ``p0`` and
nothing happens at ``sigma_h``, so it holds no closure to find (``closure_in_data`` is
False for both cycles). Only ``carter`` and ``wall_leak`` are allowed: the other two
models change the leak or the compliance at ``sigma_h``.

*Flowback* through a fixed choke: ``Q_choke = zeta sqrt(p_s)``, ``p_s = p - p_hyd`` the
static surface pressure (the choke law of :mod:`xlotkit.interpret.picks.flowback`).

*Gauges.* ``gauge = "bottomhole"``: the record is ``p + noise`` rounded to the downhole
gauge resolution, with a ``surface_pressure`` channel (``p - p_hyd``, plus pipe friction
while pumping, plus noise, rounded to whole bar as cementing units log it).
``gauge = "surface"``: the record is that surface pressure. Rates and returned volumes are
recorded exactly.

The truth (:class:`Truth`) is given on the record's own pressure reference, as the gauge
would read it without noise: ``sigma_h - p_hyd`` on a surface record, and so on; T0 is a
difference and does not depend on the reference.

*Closure in the data.* A cycle's closure is a **case** for the closure picks when the
recorded decline holds it: from the pump stop to the end of the phase that crosses closure
(the shut-in, or the short shut-in and the flowback), at least :data:`CASE_SAMPLES`
samples lie above the transition (``p > sigma_h + w/2``, counted after the pump-stop drop
has decayed, three drop times) and at least as many below it (``p < sigma_h - w/2``). A
decline that ends above closure, or starts below it, holds no closure to find
(:attr:`Truth.closure_in_data`). How visible the closure is, is recorded too
(:attr:`Truth.closure_contrast`): the ratio of the clean decline's slopes just after and
just before the transition (on ``G`` for a shut-in, on the returned volume for a
flowback; 1 means no signature at all).

Everything is deterministic for a given :class:`ConstructedSpec` (its ``seed`` drives the
noise); :func:`draw_spec` draws a spec from a documented distribution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from scipy.integrate import solve_ivp

from xlotkit.interpret.phases import Cycle, Phase, Segmentation
from xlotkit.record import PressureReference, Record
from xlotkit.units import GRAVITY

__all__ = [
    "AFTER_CLOSURE",
    "CASE_SAMPLES",
    "PRE_CLOSURE",
    "DfitTruth",
    "dfit_record",
    "LEAKOFF_MODELS",
    "ConstructedRecord",
    "ConstructedSpec",
    "Truth",
    "construct_record",
    "draw_spec",
    "smootherstep",
]

_BAR = 1e5
_LPM = 1e-3 / 60.0

#: Samples needed on each side of the closure transition for a closure to be in the data.
CASE_SAMPLES = 10

#: Leak-off models of the generator (module docstring).
LEAKOFF_MODELS = ("carter", "pressure_dependent", "height_recession", "wall_leak")

Leakoff = Literal["carter", "pressure_dependent", "height_recession", "wall_leak"]


def smootherstep(u):
    """Ken Perlin's smootherstep ``6u^5 - 15u^4 + 10u^3`` on ``[0, 1]``, 0 below, 1 above.

    Twice continuously differentiable and symmetric, ``S(u) + S(1 - u) = 1``.
    """
    u = np.clip(np.asarray(u, float), 0.0, 1.0)
    return u * u * u * (u * (6.0 * u - 15.0) + 10.0)


def _g_alpha1(d):
    d = np.clip(np.asarray(d, float), 0.0, None)
    return 4.0 / 3.0 * ((1.0 + d) ** 1.5 - d ** 1.5)


def _G(dt, t_p):
    """Nolte's G (alpha = 1) of shut-in time ``dt`` [s] after ``t_p`` [s] of pumping."""
    return 4.0 / math.pi * (_g_alpha1(np.asarray(dt, float) / t_p) - 4.0 / 3.0)


def _dG_dt(dt, t_p):
    d = max(float(dt), 0.0) / t_p
    return 4.0 / math.pi * 2.0 * (math.sqrt(1.0 + d) - math.sqrt(d)) / t_p


def _dt_at_G(G, t_p):
    """Shut-in time [s] at which Nolte's G reaches ``G`` (G is increasing in dt)."""
    lo, hi = 0.0, t_p
    while _G(hi, t_p) < G:
        hi *= 2.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if _G(mid, t_p) < G:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


# ============================================================================ spec
@dataclass(frozen=True)
class ConstructedSpec:
    """Everything that defines one constructed two-cycle record (SI units).

    Attributes
    ----------
    depth, density : float
        Gauge/open-hole depth [m] and well-fluid density [kg/m^3] (hydrostatic head).
    sigma_h : float
        Closure pressure at the bottom hole [Pa]: the centre of the closure transition.
    transition : float
        Full width of the closure transition as a fraction of ``sigma_h``.
    p0 : float
        Reservoir pressure [Pa] (drives the wall leak).
    lop, fbp : float
        Leak-off and breakdown pressure of cycle 1 at the bottom hole [Pa], ``lop <= fbp``.
    isip : tuple of float
        Fracture pressure at pump stop of cycles 1 and 2 [Pa].
    reopening : float
        Onset of the reopening departure in cycle 2 [Pa].
    well_compliance, fracture_compliance : float
        ``C_w`` and ``C_f0`` [m^3/Pa].
    rate : float
        Pump rate [m^3/s].
    t_prop : float
        Pumping time after breakdown in cycle 1 [s].
    g_closure : tuple of float
        G at which the Carter decline reaches ``sigma_h``, per cycle.
    leak_after : float
        Fraction ``lambda`` of the Carter leak that goes on after closure.
    leakoff : str
        One of :data:`LEAKOFF_MODELS`.
    leak_parameter : float
        ``beta`` (pressure_dependent), ``gamma`` (height_recession), or the wall leak as a
        fraction of the Carter rate at pump stop (wall_leak); unused for carter.
    nwb, pipe_friction : float
        Entry loss seen by the well gauge and pipe friction seen by the surface gauge while
        pumping [Pa].
    drop_tau, breakdown_tau : float
        Time constants [s] of the pump-stop drop and of the relaxation after breakdown.
    flowback : tuple of bool
        Whether each cycle's decline goes on as a choke flowback (closure in the flowback)
        or as a shut-in through closure.
    flowback_rate : float
        Pressure fall rate [Pa/s] the choke would give the closed well alone at the start
        of the flowback (the choke's size).
    gauge : {"bottomhole", "surface"}
    noise : float
        Gauge noise (one sigma) [Pa] before rounding.
    resolution : float
        Rounding step of the recorded pressure [Pa] (0: none); the surface channel of a
        bottom-hole record is always rounded to whole bar.
    dt : float
        Sample interval [s].
    seed : int
    closure : bool
        False: a single-compliance decline with no closure (module docstring).
    """

    depth: float = 2000.0
    density: float = 1200.0
    sigma_h: float = 300e5
    transition: float = 0.01
    p0: float = 205e5
    lop: float = 390e5
    fbp: float = 400e5
    isip: tuple[float, float] = (320e5, 318e5)
    reopening: float = 312e5
    well_compliance: float = 4e-8
    fracture_compliance: float = 8e-8
    rate: float = 500 * _LPM
    t_prop: float = 240.0
    g_closure: tuple[float, float] = (1.2, 1.0)
    leak_after: float = 0.8
    leakoff: Leakoff = "carter"
    leak_parameter: float = 0.0
    nwb: float = 3e5
    pipe_friction: float = 5e5
    drop_tau: float = 2.0
    breakdown_tau: float = 15.0
    flowback: tuple[bool, bool] = (True, False)
    flowback_rate: float = 15 * _BAR / 60
    gauge: Literal["bottomhole", "surface"] = "bottomhole"
    noise: float = 0.02e5
    resolution: float = 0.0
    dt: float = 1.0
    seed: int = 0
    closure: bool = True

    def __post_init__(self) -> None:
        if self.leakoff not in LEAKOFF_MODELS:
            raise ValueError(f"leakoff {self.leakoff!r}: expected one of {LEAKOFF_MODELS}")
        if self.gauge not in ("bottomhole", "surface"):
            raise ValueError(f"gauge {self.gauge!r}: expected 'bottomhole' or 'surface'")
        if not self.p_hyd < self.sigma_h < min(self.isip) < self.fbp:
            raise ValueError("need p_hyd < sigma_h < ISIP < FBP")
        if not self.sigma_h < self.reopening < self.isip[1] + self.nwb:
            raise ValueError("need sigma_h < Pr < ISIP_2 + nwb")
        if not self.p0 < self.sigma_h:
            raise ValueError("need p0 < sigma_h")
        if not 0.0 <= self.transition < 0.2:
            raise ValueError("transition must be a fraction of sigma_h in [0, 0.2)")
        if not self.closure and self.leakoff not in ("carter", "wall_leak"):
            raise ValueError(f"leakoff {self.leakoff!r} changes the decline at sigma_h: a "
                             "record without closure takes 'carter' or 'wall_leak'")

    @property
    def p_hyd(self) -> float:
        """Hydrostatic head of the well fluid [Pa]."""
        return self.density * GRAVITY * self.depth

    @property
    def transition_width(self) -> float:
        """Full width of the closure transition [Pa]."""
        return self.transition * self.sigma_h


@dataclass(frozen=True)
class Truth:
    """The truth of a constructed record, on the record's pressure reference [Pa].

    Attributes
    ----------
    sigma_h : float
        Closure pressure (what every closure pick should find).
    isip : tuple of float
        ISIP of cycles 1 and 2.
    lop : float
        Leak-off pressure of cycle 1 (onset of the departure from the storage line).
    fbp : float
        Breakdown pressure (the highest pressure the gauge would read in cycle 1).
    reopening : float
        Reopening pressure of cycle 2 (onset of the departure).
    t0 : float
        Tensile strength ``FBP - Pr`` (reference independent).
    p0 : float
        Reservoir pressure at the bottom hole.
    closure_phase : tuple of str
        ``"shut_in"`` or ``"flowback"``: where each cycle's decline crosses closure.
    transition_width : float
        Full width of the closure transition.
    reference : str
        ``"bottomhole"`` or ``"surface"``.
    closure_in_data : tuple of bool
        Per cycle, whether the recorded decline holds the closure (module docstring): the
        closure picks' cases.
    closure_contrast : tuple of float
        Per cycle, the clean decline's slope after the transition over the slope before it
        (G for a shut-in, returned volume for a flowback); NaN where not measurable.
    """

    sigma_h: float
    isip: tuple[float, float]
    lop: float
    fbp: float
    reopening: float
    t0: float
    p0: float
    closure_phase: tuple[str, str]
    transition_width: float
    reference: str
    closure_in_data: tuple[bool, bool] = (True, True)
    closure_contrast: tuple[float, float] = (math.nan, math.nan)


@dataclass(frozen=True)
class ConstructedRecord:
    """A constructed record, its truth, the spec it was made from, the clean bottom-hole
    pressure (``clean["t"]``, ``clean["p_bottomhole"]``) and the phases and cycles as
    constructed (``segmentation``: the picks can be checked without the segmentation)."""

    record: Record
    truth: Truth
    spec: ConstructedSpec
    clean: dict = field(default_factory=dict)
    segmentation: Segmentation | None = None


# ============================================================================ physics
class _Decline:
    """Right-hand side of the decline volume balance (module docstring)."""

    def __init__(self, sp: ConstructedSpec, cycle: int, t_s: float, t_p: float,
                 choke: float) -> None:
        self.sp = sp
        self.t_s, self.t_p = t_s, t_p
        self.choke = choke
        self.w = max(sp.transition_width, 1e-6 * sp.sigma_h)
        isip = sp.isip[cycle]
        self.isip = isip
        self.net0 = isip - sp.sigma_h
        cw, cf = sp.well_compliance, sp.fracture_compliance
        # kappa: the open-fracture Carter decline reaches sigma_h at G_c.
        self.kappa = (cw + cf) * self.net0 / sp.g_closure[cycle]
        self.J = 0.0
        if sp.leakoff == "wall_leak":
            q0 = self.kappa * _dG_dt(0.0, t_p)
            self.J = sp.leak_parameter * q0 / max(isip - sp.p0, 1.0)

    def S(self, p: float) -> float:
        if not self.sp.closure:
            return 1.0
        return float(smootherstep((p - (self.sp.sigma_h - 0.5 * self.w)) / self.w))

    def compliance(self, p: float) -> float:
        sp = self.sp
        h = 1.0
        if sp.leakoff == "height_recession":
            h += sp.leak_parameter * max(p - sp.sigma_h, 0.0) / self.net0
        return sp.well_compliance + sp.fracture_compliance * self.S(p) * h

    def rhs(self, t: float, y: np.ndarray) -> list[float]:
        sp = self.sp
        p = float(y[0])
        s = self.S(p)
        # Below closure the leak falls to the fraction lambda and then with the pressure
        # above the reservoir's (the decline ends at p0); blended by S, so smooth.
        below = sp.leak_after * max(p - sp.p0, 0.0) / (sp.sigma_h - sp.p0)
        if not sp.closure:
            # One compliance throughout; the leak falls smoothly with the pressure above
            # the reservoir's (nothing happens at sigma_h).
            s, below = 0.0, max(p - sp.p0, 0.0) / max(self.isip - sp.p0, 1.0)
        q = self.kappa * _dG_dt(t - self.t_s, self.t_p) * (s + (1.0 - s) * below)
        if sp.leakoff == "pressure_dependent":
            q *= 1.0 + sp.leak_parameter * max(p - sp.sigma_h, 0.0) / self.net0
        q += self.J * (p - sp.p0)
        if self.choke > 0:
            q += self.choke * math.sqrt(max(p - sp.p_hyd, 0.0))
        return [-q / self.compliance(p)]


def _integrate(dec: _Decline, p_start: float, t0: float, t1: float,
               stop_below: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Dense solution of the decline from ``(t0, p_start)`` to ``t1`` (or to ``stop_below``).

    The transition is integrated with short steps (its width can be a fraction of a bar).
    """
    sp = dec.sp
    lo, hi = sp.sigma_h - 0.5 * dec.w, sp.sigma_h + 0.5 * dec.w
    ts, ps = [t0], [p_start]
    t, p = t0, p_start

    def ev_factory(level):
        def ev(_t, y):
            return y[0] - level
        ev.terminal = True
        ev.direction = -1
        return ev

    while t < t1 - 1e-9:
        inside = lo <= p <= hi
        events = []
        if stop_below is not None:
            events.append(ev_factory(stop_below))
        if p > hi:
            events.append(ev_factory(hi))
        elif inside:
            events.append(ev_factory(lo))
        # Steps short against the time the pressure needs to cross the transition.
        rate = abs(dec.rhs(t, np.array([p]))[0]) or 1.0
        max_step = max(min(0.05 * dec.w / rate, 5.0), 1e-3) if inside else 30.0
        sol = solve_ivp(dec.rhs, (t, t1), [p], method="RK45", rtol=1e-9, atol=1e-3,
                        max_step=max_step, events=events or None, dense_output=False)
        ts.extend(sol.t[1:].tolist())
        ps.extend(sol.y[0, 1:].tolist())
        t, p = float(sol.t[-1]), float(sol.y[0, -1])
        if sol.status == 1:
            hit = [e.size for e in sol.t_events]
            if stop_below is not None and hit[0]:
                break
            # Nudge past the boundary so the next segment starts on the other side.
            p -= 1e-6 * dec.w
        elif sol.status != 0:
            raise RuntimeError(f"decline integration failed: {sol.message}")
    return np.asarray(ts), np.asarray(ps)


@dataclass
class _Timeline:
    """Piecewise definition of the clean bottom-hole pressure and the rates."""

    pieces: list = field(default_factory=list)   # (t0, t1, fn(t) -> p_bh, rate, ret)
    phases: list = field(default_factory=list)   # (kind, t0, t1)

    def add(self, t0, t1, fn, rate=0.0, ret=None, kind="idle"):
        self.pieces.append((t0, t1, fn, rate, ret))
        self.phases.append((kind, t0, t1))


def _pump_curve(p_start: float, bend_at: float, asymptote: float, cw: float, q: float):
    """Pressure of a pump-in at rate ``q`` from ``p_start``: well-storage line, then a
    slope-continuous exponential bend from ``bend_at`` towards ``asymptote``."""
    a = asymptote - bend_at
    v_b = (bend_at - p_start) * cw

    def p_of_v(v):
        v = np.asarray(v, float)
        lin = p_start + v / cw
        # (np.where evaluates both branches: keep the unused one finite.)
        bent = bend_at + a * (1.0 - np.exp(-np.clip(v - v_b, 0.0, None) / (a * cw)))
        return np.where(v <= v_b, lin, bent)

    def v_at(p):
        """Pumped volume at which the curve reaches ``p`` (< asymptote)."""
        if p <= bend_at:
            return (p - p_start) * cw
        return v_b - a * cw * math.log(1.0 - (p - bend_at) / a)

    return p_of_v, v_at


def construct_record(sp: ConstructedSpec) -> ConstructedRecord:
    """Build the record of ``sp`` (physics in the module docstring).

    Returns
    -------
    ConstructedRecord
    """
    rng = np.random.default_rng(sp.seed)
    q, cw = sp.rate, sp.well_compliance
    tl = _Timeline()
    t = 0.0
    p_hyd = sp.p_hyd
    tl.add(0.0, 60.0, lambda tt: np.full(np.shape(tt), p_hyd), kind="idle")
    t = 60.0
    truth_isip = []
    closure_phase = []
    # ------------------------------------------------------------------ cycle 1 pump
    bend_at = sp.lop
    asym = sp.fbp + max(0.3 * (sp.fbp - sp.lop), 1e3) if sp.lop < sp.fbp else sp.fbp * 2
    p_of_v, v_at = _pump_curve(p_hyd, sp.lop, asym, cw, q)
    t_b = t + v_at(sp.fbp) / q
    t_pump0 = t
    tl.add(t, t_b, lambda tt, t0=t: p_of_v(q * (np.asarray(tt) - t0)), rate=q, kind="pump")
    target = sp.isip[0] + sp.nwb
    t_s = t_b + sp.t_prop

    def prop(tt, t_b=t_b):
        return target + (sp.fbp - target) * np.exp(-(np.asarray(tt) - t_b) / sp.breakdown_tau)

    tl.add(t_b, t_s, prop, rate=q, kind="pump")
    p_fs = float(prop(t_s)) - sp.nwb
    truth_isip.append(p_fs)
    spans: list = []
    t_end = _decline_cycle(sp, tl, 0, t_s, t_s - t_pump0, p_fs, closure_phase, spans)
    # ------------------------------------------------------------------ cycle 2 pump
    p_start = tl.pieces[-1][2](t_end)
    p_start = float(np.asarray(p_start))
    asym2 = sp.isip[1] + sp.nwb
    p_of_v2, v_at2 = _pump_curve(p_start, sp.reopening, asym2, cw, q)
    # Pump until the bend is within 1 % of its asymptote.
    v_end = v_at2(sp.reopening + 0.99 * (asym2 - sp.reopening))
    t2 = t_end
    t_s2 = t2 + v_end / q
    tl.add(t2, t_s2, lambda tt, t0=t2: p_of_v2(q * (np.asarray(tt) - t0)), rate=q,
           kind="pump")
    p_fs2 = float(p_of_v2(v_end)) - sp.nwb
    truth_isip.append(p_fs2)
    t_end = _decline_cycle(sp, tl, 1, t_s2, t_s2 - t2, p_fs2, closure_phase, spans)
    cr = _sample(sp, tl, rng, truth_isip, closure_phase, t_end)
    cases = [_closure_case(sp, cr, *span) for span in spans]
    truth = replace(cr.truth, closure_in_data=tuple(c[0] for c in cases),
                    closure_contrast=tuple(c[1] for c in cases))
    return replace(cr, truth=truth)


def _closure_case(sp: ConstructedSpec, cr: ConstructedRecord, kind: str, t0: float,
                  t1: float, t_s: float, t_p: float) -> tuple[bool, float]:
    """``(closure_in_data, closure_contrast)`` of the phase ``[t0, t1)`` that crosses
    closure (module docstring); ``t_s``, ``t_p``: pump stop and pumping time [s]."""
    if not sp.closure:
        return False, math.nan
    t, p = cr.clean["t"], cr.clean["p_bottomhole"]
    w = sp.transition_width
    dec = (t >= t_s + 3.0 * sp.drop_tau) & (t < t1)
    in_data = (int(np.sum(dec & (p > sp.sigma_h + 0.5 * w))) >= CASE_SAMPLES
               and int(np.sum(dec & (p < sp.sigma_h - 0.5 * w))) >= CASE_SAMPLES)
    m = (t >= t0) & (t < t1)
    tt, pp = t[m], p[m]
    if kind == "shut_in":
        x = _G(np.maximum(tt - t_s, 0.0), t_p)
    else:
        rv = cr.record.return_volume[m]
        x = rv - rv[0]
    ia = np.flatnonzero(pp <= sp.sigma_h + 0.5 * w)
    ib = np.flatnonzero(pp <= sp.sigma_h - 0.5 * w)
    contrast = math.nan
    if ia.size and ib.size:
        xa, xb = float(x[ia[0]]), float(x[ib[0]])
        d = 0.25 * max(xa - float(x[0]), 1e-12)
        m1 = (x >= xa - d) & (x <= xa)
        m2 = (x >= xb) & (x <= xb + d)
        if m1.sum() >= 3 and m2.sum() >= 3:
            s1 = np.polyfit(x[m1], pp[m1], 1)[0]
            s2 = np.polyfit(x[m2], pp[m2], 1)[0]
            if s1 != 0:
                contrast = float(s2 / s1)
    return in_data, contrast


def _decline_cycle(sp: ConstructedSpec, tl: _Timeline, c: int, t_s: float, t_p: float,
                   p_fs: float, closure_phase: list, spans: list) -> float:
    """Shut-in (through closure, or short and then a flowback through closure) of cycle
    ``c`` from pump stop ``t_s``; appends pieces to ``tl``, the phase crossing closure to
    ``spans`` as ``(kind, t0, t1, t_s, t_p)``, and returns the end time."""
    g_c = sp.g_closure[c]
    drop = sp.nwb

    def with_drop(fn, t_s=t_s):
        return lambda tt: fn(tt) + drop * np.exp(-(np.asarray(tt) - t_s) / sp.drop_tau)

    if not sp.flowback[c]:
        # Through closure on the shut-in: to 2.5 G_c or three times the time to closure,
        # at least 10 min, at most 2 h.
        t1 = t_s + min(max(_dt_at_G(2.5 * g_c, t_p), 3.0 * _dt_at_G(g_c, t_p), 600.0), 7200.0)
        dec = _Decline(sp, c, t_s, t_p, 0.0)
        ts, ps = _integrate(dec, p_fs, t_s, t1)
        tl.add(t_s, t1, with_drop(_interp_fn(ts, ps)), kind="shut_in")
        closure_phase.append("shut_in")
        spans.append(("shut_in", t_s, t1, t_s, t_p))
        return t1
    # A short shut-in that stays above closure (it ends with half the net pressure left,
    # at the latest), then the choke opens.
    t1 = t_s + max(_dt_at_G(0.35 * g_c, t_p), 30.0 * sp.dt, 120.0)
    dec = _Decline(sp, c, t_s, t_p, 0.0)
    ts, ps = _integrate(dec, p_fs, t_s, t1, stop_below=sp.sigma_h + 0.4 * (p_fs - sp.sigma_h))
    t1 = float(ts[-1])
    tl.add(t_s, t1, with_drop(_interp_fn(ts, ps)), kind="shut_in")
    p1 = float(ps[-1])
    # The choke is sized so that the closed well alone would fall at ``flowback_rate``
    # [Pa/s] at the start (a flowback, not a bleed), and slower when the flowback would
    # otherwise hold fewer than 80 samples.
    stop = sp.sigma_h - 0.4 * (sp.sigma_h - sp.p_hyd)
    rate = min(sp.flowback_rate, (p1 - stop) / (80.0 * sp.dt))
    zeta = rate * sp.well_compliance / math.sqrt(max(p1 - sp.p_hyd, 1.0))
    dec_fb = _Decline(sp, c, t_s, t_p, zeta)
    # Flow back until the pressure is 40 % of the way from sigma_h to the hydrostatic head.
    t2 = t1 + 7200.0
    ts2, ps2 = _integrate(dec_fb, p1, t1, t2, stop_below=stop)
    t2 = float(ts2[-1])
    fn2 = _interp_fn(ts2, ps2)
    ret = (lambda tt, f=fn2, z=zeta: z * np.sqrt(np.clip(f(tt) - sp.p_hyd, 0.0, None)))
    tl.add(t1, t2, with_drop(fn2), ret=ret, kind="flowback")
    closure_phase.append("flowback")
    spans.append(("flowback", t1, t2, t_s, t_p))
    # The choke closes; a short shut-in.
    t3 = t2 + 120.0
    ts3, ps3 = _integrate(dec, float(ps2[-1]), t2, t3)
    tl.add(t2, t3, with_drop(_interp_fn(ts3, ps3)), kind="shut_in")
    return t3


def _interp_fn(ts: np.ndarray, ps: np.ndarray):
    """Piecewise-cubic interpolant of an ODE solution (dense enough for the record)."""
    from scipy.interpolate import PchipInterpolator

    ts, idx = np.unique(ts, return_index=True)
    f = PchipInterpolator(ts, ps[idx], extrapolate=True)
    return lambda tt: f(np.asarray(tt, float))


def _sample(sp: ConstructedSpec, tl: _Timeline, rng: np.random.Generator, truth_isip,
            closure_phase, t_end: float) -> ConstructedRecord:
    offset = float(rng.uniform(0.0, sp.dt))
    t = np.arange(offset, t_end, sp.dt)
    p = np.full(t.size, np.nan)
    rate = np.zeros(t.size)
    ret = np.zeros(t.size)
    for t0, t1, fn, r, rf in tl.pieces:
        m = (t >= t0) & (t < t1)
        if m.any():
            p[m] = fn(t[m])
            rate[m] = r
            if rf is not None:
                ret[m] = rf(t[m])
    if np.any(~np.isfinite(p)):
        raise RuntimeError("constructed record has gaps")
    p_hyd = sp.p_hyd
    surf_clean = p - p_hyd + np.where(rate > 0, sp.pipe_friction, 0.0)
    ret_vol = np.concatenate([[0.0], np.cumsum(0.5 * (ret[1:] + ret[:-1]) * np.diff(t))])
    vol = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])

    def gauge(x, noise, res):
        y = x + rng.normal(0.0, noise, x.size) if noise > 0 else x.copy()
        return np.round(y / res) * res if res > 0 else y

    if sp.gauge == "bottomhole":
        pressure = gauge(p, sp.noise, sp.resolution)
        ref = PressureReference("bottomhole", sp.depth, False)
        channels = {"surface_pressure": gauge(surf_clean, max(sp.noise, 0.1e5), _BAR)}
        shift = 0.0
        fbp_truth = sp.fbp
    else:
        pressure = gauge(surf_clean, sp.noise, sp.resolution)
        ref = PressureReference("surface", None, False)
        channels = {}
        shift = -p_hyd
        fbp_truth = sp.fbp - p_hyd + sp.pipe_friction
    rec = Record(t=t, pressure=pressure, reference=ref, rate=rate, volume=vol,
                 return_rate=ret, return_volume=ret_vol, channels=channels,
                 meta={"constructed": True, "hydrostatic_pa": p_hyd})
    pr_truth = sp.reopening + shift + (sp.pipe_friction if sp.gauge == "surface" else 0.0)
    truth = Truth(
        sigma_h=sp.sigma_h + shift,
        isip=(truth_isip[0] + shift, truth_isip[1] + shift),
        lop=sp.lop + shift + (sp.pipe_friction if sp.gauge == "surface" else 0.0),
        fbp=fbp_truth,
        reopening=pr_truth,
        t0=fbp_truth - pr_truth,
        p0=sp.p0,
        closure_phase=tuple(closure_phase),
        transition_width=sp.transition_width,
        reference=sp.gauge,
    )
    return ConstructedRecord(rec, truth, sp, {"t": t, "p_bottomhole": p},
                             _segmentation(rec, tl.phases))


def _segmentation(rec: Record, spans) -> Segmentation:
    """The record's phases and cycles as constructed (consecutive spans of one kind
    merged; a cycle from each pump-in to the next)."""
    t = rec.t
    merged: list[list] = []
    for kind, t0, t1 in spans:
        if merged and merged[-1][0] == kind:
            merged[-1][2] = t1
        else:
            merged.append([kind, t0, t1])
    phases = []
    for kind, t0, t1 in merged:
        i0, i1 = int(np.searchsorted(t, t0)), int(np.searchsorted(t, t1))
        if i1 > i0:
            vol = rec.volume[i0:i1]
            rv = rec.return_volume[i0:i1]
            phases.append(Phase(kind, i0, i1, float(t[i0]), float(t[i1 - 1]),
                                pumped_m3=float(vol[-1] - vol[0]),
                                returned_m3=float(rv[-1] - rv[0]),
                                peak_pressure=float(np.max(rec.pressure[i0:i1])),
                                mean_rate=float(np.mean(rec.rate[i0:i1]
                                                        - rec.return_rate[i0:i1]))))
    starts = [k for k, ph in enumerate(phases) if ph.kind == "pump"]
    cycles = []
    for c, k0 in enumerate(starts):
        k1 = starts[c + 1] if c + 1 < len(starts) else len(phases)
        members = tuple(phases[k0:k1])
        cycles.append(Cycle(c + 1, "xlot", members, members[0].t_start, members[-1].t_end,
                            max(ph.peak_pressure for ph in members),
                            sum(ph.pumped_m3 for ph in members),
                            sum(ph.returned_m3 for ph in members),
                            reason="constructed"))
    return Segmentation(tuple(phases), tuple(cycles), True, ("constructed record",))


# ============================================================================ drawing
def draw_spec(rng: np.random.Generator, seed: int | None = None, *,
              gauge: str | None = None, flowback: tuple[bool, bool] | None = None,
              leakoff: str | None = None, transition: float | None = None,
              closure: bool = True) -> ConstructedSpec:
    """A random spec from the calibration distribution (keywords fix a draw's factor).

    Distribution (each factor independent; ``U`` uniform, ``LU`` log-uniform):

    * depth U(500, 3000) m, fluid density U(1000, 1500) kg/m^3;
    * ``sigma_h = p_hyd U(1.15, 1.9)``; ``p0 = p_hyd U(0.75, 0.98)`` (overbalanced well);
    * ``ISIP = sigma_h + U(0.03, 0.15) sigma_h`` (cycle 2: 0.98-1.0 of that),
      ``FBP = ISIP + nwb + U(10, 80) bar``, ``LOP = FBP - U(0, 0.15) (FBP - sigma_h)``,
      ``Pr = sigma_h + U(0.3, 0.8) (ISIP_2 - sigma_h)``;
    * closure transition LU(0.2 %, 5 %) of ``sigma_h`` (full width);
    * well compliance LU(1, 10) l/bar; fracture/well compliance ratio LU(0.5, 5);
      fraction of leak-off after closure U(0.5, 1);
    * leak-off model uniform over :data:`LEAKOFF_MODELS`, parameter U(1, 3) (pressure
      dependent, height recession) or U(0.2, 0.6) (wall leak);
    * G at closure U(0.5, 2.5), raised where needed so that closure comes at least 80
      samples after pump stop; pump rate U(200, 600) l/min; U(60, 400) s of propagation;
    * flowback in each cycle with probability 1/2, the choke sized so that the closed well
      would fall at U(5, 30) bar/min at the start;
    * gauge: bottom hole (noise LU(0.003, 0.1) bar, resolution 0 / 0.01 / 0.07 bar) or
      surface (noise U(0.05, 0.4) bar, rounded to whole bar), probability 1/2 each;
    * sample interval 1, 2, 3, 5 or 10 s; entry loss U(0, 8) bar, pipe friction U(0, 15)
      bar, pump-stop drop time U(1, 6) s, breakdown relaxation U(5, 30) s.

    ``closure=False`` draws the same distribution for a single-compliance decline with no
    closure (:class:`ConstructedSpec`; leak-off ``carter`` or ``wall_leak``, 1/2 each).
    """
    u = rng.uniform
    depth = u(500.0, 3000.0)
    rho = u(1000.0, 1500.0)
    p_hyd = rho * GRAVITY * depth
    sh = p_hyd * u(1.15, 1.9)
    p0 = p_hyd * u(0.75, 0.98)
    isip1 = sh * (1.0 + u(0.03, 0.15))
    isip2 = sh + (isip1 - sh) * u(0.98, 1.0)
    nwb = u(0.0, 8.0) * _BAR
    fbp = isip1 + nwb + u(10.0, 80.0) * _BAR
    lop = fbp - u(0.0, 0.15) * (fbp - sh)
    pr = sh + u(0.3, 0.8) * (isip2 - sh)
    cw = math.exp(u(math.log(1.0), math.log(10.0))) * 1e-3 / _BAR
    ratio = math.exp(u(math.log(0.5), math.log(5.0)))
    models = LEAKOFF_MODELS if closure else ("carter", "wall_leak")
    model = leakoff or models[int(rng.integers(len(models)))]
    par = {"carter": 0.0, "pressure_dependent": u(1.0, 3.0),
           "height_recession": u(1.0, 3.0), "wall_leak": u(0.2, 0.6)}[model]
    if gauge is None:
        gauge = "bottomhole" if rng.uniform() < 0.5 else "surface"
    if gauge == "bottomhole":
        noise = math.exp(u(math.log(0.003), math.log(0.1))) * _BAR
        res = float(rng.choice([0.0, 0.01, 0.07])) * _BAR
    else:
        noise = u(0.05, 0.4) * _BAR
        res = _BAR
    if flowback is None:
        flowback = (bool(rng.uniform() < 0.5), bool(rng.uniform() < 0.5))
    tr = transition if transition is not None else math.exp(u(math.log(0.002), math.log(0.05)))
    dt = float(rng.choice([1.0, 2.0, 3.0, 5.0, 10.0]))
    q = u(200.0, 600.0) * _LPM
    t_prop = u(60.0, 400.0)
    # Pumping time of each cycle (well-storage rise + propagation), for the G-function:
    # closure comes at least 80 samples after pump stop.
    t_p1 = (fbp - p_hyd) * cw / q + t_prop
    t_p2 = (isip2 - p_hyd) * cw / q
    g_c = tuple(max(u(0.5, 2.5), float(_G(80.0 * dt, tp))) for tp in (t_p1, t_p2))
    return ConstructedSpec(
        depth=depth, density=rho, sigma_h=sh, transition=tr, p0=p0, lop=lop, fbp=fbp,
        isip=(isip1, isip2), reopening=pr, well_compliance=cw,
        fracture_compliance=cw * ratio, rate=q, t_prop=t_prop, g_closure=g_c,
        leak_after=u(0.5, 1.0), leakoff=model, leak_parameter=par, nwb=nwb,
        pipe_friction=u(0.0, 15.0) * _BAR, drop_tau=u(1.0, 6.0), breakdown_tau=u(5.0, 30.0),
        flowback=flowback, flowback_rate=u(5.0, 30.0) * _BAR / 60.0, gauge=gauge,
        noise=noise, resolution=res, dt=dt,
        seed=int(rng.integers(2**31)) if seed is None else seed, closure=closure)


# ============================================================================ DFIT cases
#: Pre-closure declines of :func:`dfit_record` (the G-function signatures).
PRE_CLOSURE = ("normal", "pressure_dependent_leakoff", "tip_extension", "height_recession")
#: After-closure declines of :func:`dfit_record`.
AFTER_CLOSURE = ("linear", "radial", "exponential", "none")


@dataclass(frozen=True)
class DfitTruth:
    """Truth of a constructed DFIT: closure, reservoir pressure, the decline's types."""

    sigma_h: float
    reservoir_pressure: float
    isip: float
    t_closure: float
    t_pump_start: float
    pre_closure: str
    after_closure: str


def dfit_record(*, pre: str = "normal", after: str = "radial", isip: float = 250e5,
                sigma_h: float = 230e5, p_r: float = 180e5, t_pump: float = 600.0,
                g_closure: float = 1.5, duration: float = 30.0, tau: float = 1500.0,
                noise: float = 0.01e5, dt: float = 5.0, resolution: float = 0.0,
                seed: int = 0) -> tuple[Record, Segmentation, DfitTruth]:
    """A one-cycle DFIT by construction, with analytic declines before and after closure.

    Pumping for ``t_pump`` seconds (well storage to the ISIP), then a shut-in. Before
    closure (``G <= g_closure``, net pressure ``n = ISIP - sigma_h``) the pressure against
    Nolte's G is

    * ``normal``: ``ISIP - n G / G_c`` (Carter, constant area);
    * ``pressure_dependent_leakoff``: ``ISIP - m G - h (1 - exp(-G / g1))``,
      ``h = 0.3 n``, ``g1 = 0.15 G_c`` (extra leak-off early, at high net pressure);
    * ``tip_extension``: ``ISIP - a ln(1 + G / g0) - b G``, ``g0 = 0.02 G_c``, half the net
      pressure on each term (``G dP/dG = a G / (g0 + G) + b G``, a line above the origin);
    * ``height_recession``: ``ISIP - m1 G - k G^2``, ``k = m1 / (2 G_c)`` (``|dP/dG|``
      doubles to closure);

    continuous at closure (``p = sigma_h`` at ``G_c``). After closure, with ``t`` the time
    since pumping started and ``t_c`` that of closure,

    * ``linear``: ``p = p_r + M F_L(t, 0.8 t_c)`` (Nolte's linear time function);
    * ``radial``: ``p = p_r + M F_R(t, 0.8 t_c)``;

      ``M`` such that ``p(t_c) = sigma_h``: the regime from an effective closure a little
      earlier, so that the decline leaves closure with a finite slope and the analysis,
      which uses the picked closure, meets the regime only late, as in a field record;
    * ``exponential``: ``p = p_r + (sigma_h - p_r) exp(-(t - t_c) / tau)``;
    * ``none``: the record ends at ``1.3 t_c`` (too short for any regime).

    The record runs to ``duration`` times ``t_c``; noise and rounding as in
    :class:`ConstructedSpec`. Bottom-hole gauge pressures [Pa].
    """
    from xlotkit.interpret.diagnostics.after_closure import nolte_linear, nolte_radial

    if pre not in PRE_CLOSURE:
        raise ValueError(f"pre {pre!r}: expected one of {PRE_CLOSURE}")
    if after not in AFTER_CLOSURE:
        raise ValueError(f"after {after!r}: expected one of {AFTER_CLOSURE}")
    rng = np.random.default_rng(seed)
    t0 = 60.0
    n_net = isip - sigma_h
    dtc = _dt_at_G(g_closure, t_pump)
    ts = t0 + t_pump
    tc = ts + dtc
    t_end = t0 + (tc - t0) * (1.3 if after == "none" else duration)
    t = np.arange(0.0, t_end, dt)
    p = np.full(t.size, 100e5)
    pump = (t >= t0) & (t < ts)
    p[pump] = 100e5 + (isip - 100e5) * (t[pump] - t0) / t_pump
    sh = t >= ts
    G = _G(t[sh] - ts, t_pump)
    gc = g_closure
    if pre == "normal":
        pre_p = isip - n_net * G / gc
    elif pre == "pressure_dependent_leakoff":
        h, g1 = 0.3 * n_net, 0.15 * gc
        m = (n_net - h * (1.0 - math.exp(-gc / g1))) / gc
        pre_p = isip - m * G - h * (1.0 - np.exp(-G / g1))
    elif pre == "tip_extension":
        g0 = 0.02 * gc
        a = 0.5 * n_net / math.log(1.0 + gc / g0)
        pre_p = isip - a * np.log1p(G / g0) - 0.5 * n_net / gc * G
    else:
        m1 = n_net / (1.5 * gc)
        pre_p = isip - m1 * G - m1 / (2.0 * gc) * G ** 2
    tt = t[sh] - t0
    tcc = tc - t0
    if after in ("linear", "none"):
        tce = 0.8 * tcc
        post = p_r + (sigma_h - p_r) * (nolte_linear(np.maximum(tt, tcc), tce)
                                        / float(nolte_linear(tcc, tce)))
    elif after == "radial":
        tce = 0.8 * tcc
        M = (sigma_h - p_r) / float(nolte_radial(tcc, tce))
        post = p_r + M * nolte_radial(np.maximum(tt, tcc), tce)
    else:
        post = p_r + (sigma_h - p_r) * np.exp(-(np.maximum(tt, tcc) - tcc) / tau)
    p[sh] = np.where(G <= gc, pre_p, post)
    if noise > 0:
        p = p + rng.normal(0.0, noise, p.size)
    if resolution > 0:
        p = np.round(p / resolution) * resolution
    rate = np.where(pump, 0.5 / 60.0, 0.0)
    vol = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])
    rec = Record(t=t, pressure=p, reference=PressureReference("bottomhole", 2000.0, False),
                 rate=rate, volume=vol, meta={"constructed": True})
    i0, i1 = int(np.searchsorted(t, t0)), int(np.searchsorted(t, ts))
    phases = (Phase("idle", 0, i0, float(t[0]), float(t[i0 - 1])),
              Phase("pump", i0, i1, float(t[i0]), float(t[i1 - 1]),
                    pumped_m3=float(vol[i1 - 1]), peak_pressure=float(p[i0:i1].max())),
              Phase("shut_in", i1, t.size, float(t[i1]), float(t[-1]),
                    peak_pressure=float(p[i1:].max())))
    cyc = Cycle(1, "lot", phases[1:], phases[1].t_start, phases[2].t_end,
                float(p.max()), float(vol[-1]), 0.0, reason="constructed DFIT")
    seg = Segmentation(phases, (cyc,), True, ("constructed DFIT",))
    return rec, seg, DfitTruth(sigma_h, p_r, isip, tc, t0, pre, after)
