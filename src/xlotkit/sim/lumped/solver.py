"""One step of the lumped model: the state, a trial step's solution, event location.

:class:`StepSolver` solves the integrated volume balance of one step (equations in
:mod:`xlotkit.sim.lumped`) for the phase in force (a :class:`~xlotkit.sim.well.PhaseDrive`)
and keeps the accepted history and the Carter increments; :func:`locate` finds the sub-step
where an event function crosses zero.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from xlotkit.sim.lumped.physics import (
    _carter_unit,
    critical_net_pressure,
    fracture_compliance,
    fracture_face_area,
    fracture_volume,
    stable_length,
)
from xlotkit.sim.scene.lumped import LumpedScene
from xlotkit.sim.well import PhaseDrive

__all__ = ["State", "StepSolver", "TrialStep", "locate"]


@dataclass
class State:
    t: float
    p: float                  # well (bottom-hole) pressure
    L: float = 0.0            # fracture size (0 while intact)
    broken: bool = False
    pf: float = math.nan      # fracture(-mouth) pressure; = p when no fluid enters it
    sealed: bool = False      # closed, mouth held shut by the wall until p reaches P_r
    vf: float = 0.0           # fracture volume
    v_in: float = 0.0
    v_ret: float = 0.0
    v_carter: float = 0.0
    v_wall: float = 0.0
    ps: float = 0.0           # surface pressure
    q_in: float = 0.0         # pump rate in the step that ended here
    q_ret: float = 0.0        # return rate at this state
    margin: float = math.inf  # elastic-branch residual at K_I = K_Ic (< 0: must grow)


@dataclass
class TrialStep:
    """Result of one trial step."""

    dt: float
    p: float
    pf: float
    L: float
    vf: float
    dv_in: float
    dv_ret: float
    dv_carter: float
    dv_wall: float
    q_ret: float
    ps: float
    dA: float
    resid: float
    scale: float
    jump: bool
    margin: float


class StepSolver:
    HIST_KEYS = ("t", "p", "pf", "L", "vf", "v_in", "v_ret", "v_carter", "v_wall", "ps",
                 "q_in", "q_ret")

    def __init__(self, scene: LumpedScene, closure_band: float = 1e-3):
        self.sc = scene
        self.cw = scene.c_well
        self.col = scene.column
        self.geo = scene.geometry
        self.ep = scene.e_prime
        self.h = scene.fracture_height
        self.K = scene.toughness
        self.sh = scene.sigma_h
        self.pb = scene.breakdown_pressure
        self.pr = scene.reopening_pressure
        self.k_nwb = scene.nwb_coefficient
        self.J = scene.wall_leak_index
        self.p0 = scene.pore_pressure
        self.CL = scene.leakoff_coefficient
        self.L_stab = stable_length(self.cw, self.geo, self.ep, self.h)
        self.tol_p = closure_band  # [Pa] band around sigma_h treated as "at closure"
        # Seal closed fractures only when P_r is measurably above sigma_h; otherwise the
        # wellbore model is the sigma_h model.
        self.seal = self.pr > self.sh + self.tol_p
        # Carter increments: area dA created linearly over [a, b].
        self._ca = np.zeros(64)
        self._cb = np.zeros(64)
        self._cdA = np.zeros(64)
        self._cn = 0
        self._cache: dict[tuple[float, int], float] = {}
        # History of accepted states.
        self.hist: dict[str, list[float]] = {k: [] for k in self.HIST_KEYS}
        self.mb_err: list[float] = []
        self.mb_t: list[float] = []
        self.n_steps = 0
        self.n_rejected = 0
        self.n_events = 0

    # ------------------------------------------------------------------ small physics
    def vol(self, dp: float, L: float) -> float:
        return fracture_volume(dp, L, self.geo, self.ep, self.h)

    def dpc(self, L: float) -> float:
        return critical_net_pressure(L, self.geo, self.K)

    def area(self, L: float) -> float:
        return fracture_face_area(L, self.geo, self.h) if L > 0 else 0.0

    def carter_old(self, t0: float, t1: float) -> float:
        """Leak volume over [t0, t1] from both faces of all area opened before t0."""
        n = self._cn
        if n == 0 or self.CL == 0.0:
            return 0.0
        return 2.0 * self.CL * (self._carter_sum(t1) - self._carter_sum(t0))

    def _carter_sum(self, t: float) -> float:
        """Sum over increments of dA * unit leak by time t (cached: event searches and the
        next step reuse the same times)."""
        key = (t, self._cn)
        v = self._cache.get(key)
        if v is None:
            n = self._cn
            v = float(np.dot(self._cdA[:n], _carter_unit(t, self._ca[:n], self._cb[:n])))
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = v
        return v

    def add_area(self, a: float, b: float, dA: float) -> None:
        if dA <= 0.0:
            return
        if self._cn == self._ca.size:
            for name in ("_ca", "_cb", "_cdA"):
                arr = getattr(self, name)
                setattr(self, name, np.concatenate([arr, np.zeros(arr.size)]))
        self._ca[self._cn], self._cb[self._cn], self._cdA[self._cn] = a, b, dA
        self._cn += 1

    # ------------------------------------------------------------------ one step
    def solve(self, s: State, dt: float, drive: PhaseDrive, q_pump: float,
              force_jump: bool = False) -> TrialStep:
        """One trial step of ``dt`` from ``s`` under the phase in force (``drive``) with the
        pump rate ``q_pump`` of the step."""
        cw, sh, k = self.cw, self.sh, self.k_nwb
        # The fracture exchanges fluid with the well only when it exists and its mouth is
        # not sealed by the borehole wall (wellbore reopening model).
        linked = s.broken and not s.sealed
        pf0 = s.pf if linked else s.p
        is_open = linked and pf0 > sh + self.tol_p
        dv_in = q_pump * dt
        dv_c_old = self.carter_old(s.t, s.t + dt) if (is_open and dt > 0) else 0.0
        c_new = (2.0 * 4.0 / 3.0 * self.CL * math.sqrt(dt)) if is_open else 0.0
        q_ret_n = s.q_ret if dt > 0 else 0.0
        wall_n = self.J * (s.p - self.p0)
        A_n = self.area(s.L)
        half = 0.5 * dt
        # returns at a fixed rate (bleed; 0 pumping or shut in) or through the choke
        fixed_return = not drive.phase.through_choke
        # Entry loss acts on time-resolved inflow only: zero-duration steps are the
        # instantaneous equilibrium jumps (breakdown, reopening), taken without it.
        throttle = k > 0.0 and dt > 0.0 and linked

        def parts(pf: float, dp: float, L: float, p: float | None = None,
                  vf: float | None = None):
            if vf is None:
                vf = self.vol(dp, L) if linked else 0.0
            dA = self.area(L) - A_n if linked else 0.0
            dv_c = dv_c_old + c_new * dA
            x = (vf - s.vf) + dv_c            # volume that entered the fracture
            if p is None:
                # Well pressure: fracture pressure + k Q_f^2 while the fracture takes
                # fluid (backward Euler: Q_f = x / dt, the step-mean inflow).
                p = pf + k * (x / dt) ** 2 if (throttle and x > 0.0) else pf
            if fixed_return:
                q_ret = drive.phase.fixed_return_rate
                dv_ret = q_ret * dt
                ps = None
            else:
                ps, q_ret = drive.choke(p)
                dv_ret = half * (q_ret_n + q_ret)
            dv_w = half * (wall_n + self.J * (p - self.p0))
            r = cw * (p - s.p) + x + dv_ret + dv_w - dv_in
            return r, vf, dv_ret, dv_w, dv_c, q_ret, ps, dA, p

        def r_el(pf: float) -> float:
            return parts(pf, pf - sh, s.L)[0]

        def r_cr(lam: float) -> float:
            L = Ls * math.exp(lam)
            dp = self.dpc(L)
            return parts(sh + dp, dp, L)[0]

        jump = False
        margin = math.inf
        p_w: float | None = None
        vf_w: float | None = None
        if throttle:
            res = self._solve_throttled(s, dt, parts, dv_c_old, c_new, A_n, force_jump)
            if res is None:         # an unstable jump: instantaneous, taken without loss
                throttle = False
            else:
                pf, dp, L, p_w, vf_w, jump, margin = res
        if throttle:
            pass
        elif not linked:
            pf = _solve_monotone(r_el, pf0)
            L, dp = s.L, pf - sh
        else:
            p_star = sh + self.dpc(s.L)
            margin = r_el(p_star)
            if margin >= 0.0 and not force_jump:
                pf = _solve_monotone(r_el, min(pf0, p_star), hi=p_star)
                L, dp = s.L, pf - sh
            else:
                Ls = max(s.L, self.L_stab)
                jump = Ls > s.L
                if r_cr(0.0) >= 0.0:   # pathological: settles right at L_s
                    lam = 0.0
                else:
                    hi = 1.0
                    while r_cr(hi) < 0.0:
                        hi *= 2.0
                        if hi > 60.0:
                            raise RuntimeError("fracture growth did not bracket")
                    lam = brentq(r_cr, 0.0, hi, xtol=1e-15, rtol=1e-15, maxiter=200)
                L = Ls * math.exp(lam)
                dp = self.dpc(L)
                pf = sh + dp
        r, vf, dv_ret, dv_w, dv_c, q_ret, ps, dA, p = parts(pf, dp, L, p_w, vf_w)
        if ps is None:
            ps = drive.surface(p, q_pump)[0]
        # Relative to the step's volume turnover; for sub-millisecond (event) steps the
        # turnover is at the round-off level of the stored volume, so floor the scale at
        # 1e-6 of it (C_w p + V_f).
        scale = max(abs(dv_in) + abs(dv_ret) + abs(dv_w) + abs(dv_c) + cw * abs(p - s.p)
                    + abs(vf - s.vf), 1e-6 * (cw * abs(p) + vf), 1e-300)
        return TrialStep(dt, p, pf if linked else p, L, vf, dv_in, dv_ret, dv_c, dv_w, q_ret, ps,
                     dA, r, scale, jump, margin)

    def _solve_throttled(self, s: State, dt: float, parts, dv_c_old: float, c_new: float,
                         A_n: float, force_jump: bool):
        """One step of a linked fracture with the entry loss on (``dt > 0``).

        The fracture pressure is nearly fixed over a short step while the well pressure
        moves by ``k (x/dt)^2``, so ``p_f`` (or ``ln L``) is an ill-conditioned unknown
        for sub-millisecond event steps. Instead the unknown is the well pressure ``p`` on
        the elastic branch, where the inflow follows in closed form, and the inflow
        volume ``x`` on the critical branch; both residuals are increasing.
        """
        sh, k = self.sh, self.k_nwb
        cf = fracture_compliance(s.L, self.geo, self.ep, self.h)
        base = s.vf - dv_c_old          # fracture volume left if nothing flowed in
        inv_dt2 = 1.0 / (dt * dt)

        def el(p: float) -> tuple[float, float]:
            """(p_f, V_f) at fixed L for well pressure p: the inflow x > 0 solves
            ``k x^2/dt^2 + x/C_f = p - sh - base/C_f`` (stable root form)."""
            d = p - sh - base / cf
            if d > 0.0:
                x = 2.0 * d / (1.0 / cf + math.sqrt(1.0 / cf**2 + 4.0 * k * d * inv_dt2))
                vf = max(base + x, 0.0)
                return p - k * x * x * inv_dt2, vf
            return p, cf * max(p - sh, 0.0)

        def r_el(p: float) -> float:
            pf, vf = el(p)
            return parts(pf, pf - sh, s.L, p, vf)[0]

        p_star = sh + self.dpc(s.L)
        x_star = cf * (p_star - sh) - base
        pw_star = p_star + (k * x_star * x_star * inv_dt2 if x_star > 0.0 else 0.0)
        # Over a very short step, reaching K_Ic would take an absurd well pressure; cap it
        # (far above any valid scene pressure) so the fluid column stays finite. The
        # margin keeps its sign and stays continuous in dt.
        pw_star = min(pw_star, _P_CAP)
        margin = r_el(pw_star)
        if margin < 0.0 and pw_star == _P_CAP:
            raise RuntimeError("entry loss needs a well pressure above 1 GPa")
        if margin >= 0.0 and not force_jump:
            p = _solve_monotone(r_el, min(s.p, pw_star), hi=pw_star)
            pf, vf = el(p)
            return pf, pf - sh, s.L, p, vf, False, margin
        if force_jump:
            return None
        if s.L < self.L_stab:
            # K_I > K_Ic at a size that cannot hold: the "unstable" event cuts the step
            # where the margin crosses 0 and jumps (at dt = 0). Meanwhile keep the trial
            # on the elastic branch past K_Ic, so the margin stays continuous in dt.
            p = _solve_monotone(r_el, s.p)
            pf, vf = el(p)
            return pf, pf - sh, s.L, p, vf, False, margin
        # Critical branch: the inflow x fixes L (volume + new-area leak), L fixes p_f.
        Ls = s.L
        m_v, m_a = (2.5, 2.0) if self.geo == "penny" else (1.5, 1.0)

        def size(x: float) -> float:
            target = base + x
            v1 = self.vol(self.dpc(Ls), Ls)
            a1 = self.area(Ls)
            # start right of the root (the no-leak solution); Newton on a convex
            # increasing function then converges monotonically
            lam = max(0.0, math.log(max(target, 1e-300) / v1) / m_v)
            for _ in range(60):
                ev, ea = v1 * math.exp(m_v * lam), a1 * math.exp(m_a * lam)
                g = ev + c_new * (ea - A_n) - target
                step = g / (m_v * ev + m_a * c_new * ea)
                lam_new = max(lam - step, 0.0)
                if abs(lam_new - lam) <= 1e-15 * max(1.0, lam):
                    lam = lam_new
                    break
                lam = lam_new
            return Ls * math.exp(lam)

        def r_x(x: float) -> float:
            L = size(x)
            dp = self.dpc(L)
            return parts(sh + dp, dp, L, sh + dp + k * x * x * inv_dt2)[0]

        x_lo = self.vol(self.dpc(Ls), Ls) + c_new * (self.area(Ls) - A_n) - base
        x_lo = max(x_lo, 0.0)
        if r_x(x_lo) >= 0.0:
            x = x_lo
        else:
            hi = max(2.0 * x_lo, 1e-9)
            while r_x(hi) < 0.0:
                hi *= 2.0
                if hi > 1e6:
                    raise RuntimeError("fracture growth did not bracket")
            x = brentq(r_x, x_lo, hi, xtol=1e-300, rtol=1e-15, maxiter=300)
        L = size(x)
        dp = self.dpc(L)
        return sh + dp, dp, L, sh + dp + k * x * x * inv_dt2, None, False, margin

    def accept(self, s: State, st: TrialStep, q_pump: float) -> State:
        if st.dA > 0.0:
            self.add_area(s.t, s.t + st.dt, st.dA)
        new = State(t=s.t + st.dt, p=st.p, L=st.L, broken=s.broken, vf=st.vf, pf=st.pf,
                     sealed=s.sealed,
                     v_in=s.v_in + st.dv_in, v_ret=s.v_ret + st.dv_ret,
                     v_carter=s.v_carter + st.dv_carter, v_wall=s.v_wall + st.dv_wall,
                     ps=st.ps, q_in=q_pump, q_ret=st.q_ret)
        self.mb_err.append(abs(st.resid) / st.scale)
        self.mb_t.append(new.t)
        self.n_steps += 1
        self.push(new)
        return new

    def push(self, s: State) -> None:
        h = self.hist
        for k in h:
            h[k].append(getattr(s, k))


_P_CAP = 1e9   # [Pa] ceiling of trial well pressures in the entry-loss solve


def _solve_monotone(f: Callable[[float], float], x0: float, hi: float | None = None) -> float:
    """Root of an increasing function near x0 (bracket by doubling), optional upper bound."""
    span = 1e5
    lo = x0 - span
    while f(lo) > 0.0:
        span *= 2.0
        lo = x0 - span
        if span > 1e10:
            raise RuntimeError("pressure did not bracket (below)")
    if hi is None:
        span = 1e5
        hi = x0 + span
        while f(hi) < 0.0:
            span *= 2.0
            hi = x0 + span
            if span > 1e10:
                raise RuntimeError("pressure did not bracket (above)")
    elif f(hi) <= 0.0:
        return hi
    return brentq(f, lo, hi, xtol=1e-9, rtol=1e-15, maxiter=200)


def _view(s: State, st: TrialStep) -> State:
    """The state a trial step would lead to (for event functions)."""
    return State(t=s.t + st.dt, p=st.p, L=st.L, broken=s.broken, vf=st.vf, pf=st.pf,
                  sealed=s.sealed,
                  v_in=s.v_in + st.dv_in, v_ret=s.v_ret + st.dv_ret, ps=st.ps,
                  margin=st.margin)


def _event_value(sim: StepSolver, s: State, drive: PhaseDrive, q_pump: float, fn, d: float) -> float:
    st = sim.solve(s, d, drive, q_pump)
    return fn(_view(s, st), st.ps)


def locate(g: Callable[[float], float], dt: float) -> float:
    """Smallest sub-step in (0, dt] after which the event function g is <= 0 (g(dt) <= 0)."""
    if g(0.0) <= 0.0:
        return 0.0
    r = brentq(g, 0.0, dt, xtol=1e-10, rtol=1e-14, maxiter=200)
    # Make sure the event has fired in the returned state (brentq may stop just before).
    step = max(1e-10, 1e-14 * r)
    while g(r) > 0.0 and r < dt:
        r = min(dt, r + step)
        step *= 2.0
    return r


