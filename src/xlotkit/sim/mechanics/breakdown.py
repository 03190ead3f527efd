"""Breakdown pressure of a pressure-controlled, quasi-static hole test.

An XLOT sees *breakdown* as the hole pressure at which the fracture stops needing more
pressure to grow: beyond it the fracture runs away. On a model this is the lowest wall
pressure at which, with the crack filled by the hole fluid, failure keeps advancing the
crack without bound. It is the larger of

* the initiation pressure (first cluster failure at the intact wall; Hubbert-Willis,
  Eq. C.11, for an impermeable wall), and
* the pressure needed to propagate the near-wall crack out of the hole's stress
  concentration (a toughness-controlled, LEFM quantity).

Which one controls depends on the stresses: with ``3 sigma_h - sigma_H - p0 + T`` well
above ``sigma_h`` (the Hubbert-Willis test case) the net pressure in the crack at
initiation drives it through any toughness and breakdown equals initiation; with
``sigma_H + p0 > 2 sigma_h + T`` the crack initiates below ``sigma_h``, arrests in the hoop
tension zone, and breakdown is a propagation pressure. See docs/mechanics.md.

Compression positive, SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph

from xlotkit.errors import InputError
from xlotkit.sim.mechanics.solver import (
    FAILED_SHEAR,
    FAILED_TENSILE,
    INTACT,
    PRESET,
    MechanicsModel,
    MechanicsResult,
    MechanicsState,
)

__all__ = ["BreakdownResult", "PressureBreakdown", "breakdown_pressure", "crack_geometry",
           "crack_start_azimuth", "wall_pressure_at_first_failure"]

# halvings of a pressure increment tried when no equilibrium is found (see settle)
_MAX_SUBSTEP_DEPTH = 3


@dataclass(frozen=True, eq=False)
class PressureBreakdown:
    """Result of :func:`breakdown_pressure`.

    Attributes
    ----------
    pressure : float
        Breakdown pressure [Pa]: upper end of the final bracket, i.e. the lowest wall
        pressure tried at which the crack ran away (``nan`` if none did).
    converged : bool
        True when the bracket ``[pressure_below, pressure]`` is narrower than ``tol``.
    reason : str
        ``"converged"`` or why not (nothing failed / nothing ran away up to ``p_max``,
        equilibrium failure).
    initiation_pressure : float
        Wall pressure [Pa] of the first cluster failure (``nan`` if none).
    pressure_below : float
        Highest wall pressure [Pa] tried at which the crack stayed bounded.
    crack_length : float
        Length [m] of the stable crack at ``pressure_below``: largest distance of a
        cluster of the hole-connected crack from the hole wall (0 if no crack).
    azimuth : float
        Direction [rad, (-pi, pi]] of the longest wing of the runaway crack at
        ``pressure`` (see :func:`crack_geometry`).
    runaway_length : float
        Crack length [m] at which the run was stopped (at ``pressure``).
    start_azimuth : float
        Axis [rad, (-pi/2, pi/2]] along which the runaway crack leaves the hole: principal
        axis of the crack clusters touching the wall (:func:`crack_start_azimuth`). Unlike
        ``azimuth`` it does not depend on how the run ended: when the quasi-static
        equilibrium is lost, the clusters failed in the unconverged cascade spread about
        the crack, while the wall clusters still show where it started.
    state_below : MechanicsState
        Stable state at ``pressure_below``.
    state_after : MechanicsState or None
        State at ``pressure`` when the run was stopped.
    iterations : int
        Active-set iterations of all equilibrium solves.
    solves : int
        Quasi-static steps (``MechanicsModel.step`` calls and search solves).
    history : list of (float, float)
        ``(wall pressure [Pa], crack length [m])`` of every stable continuation point,
        in pressure order (the crack growth curve below breakdown).
    """

    pressure: float
    converged: bool
    reason: str
    initiation_pressure: float
    pressure_below: float
    crack_length: float
    azimuth: float
    runaway_length: float
    state_below: MechanicsState
    state_after: MechanicsState | None
    iterations: int
    solves: int
    history: list
    start_azimuth: float = math.nan


def crack_start_azimuth(model: MechanicsModel, cluster_state: np.ndarray) -> float:
    """Axis [rad, (-pi/2, pi/2]] along which the hole-connected crack leaves the wall.

    Principal axis (about the hole centre, area weighted) of the centroids of the crack
    clusters that touch the hole wall; ``nan`` without such clusters. An axis, not a
    direction: a two-winged crack along x gives 0 whichever wing is longer.
    """
    connected, _, _ = crack_geometry(model, cluster_state)
    mesh = model.mesh
    wall = np.zeros(mesh.n_nodes, dtype=bool)
    wall[mesh.hole_nodes] = True
    at_wall = connected & wall[mesh.triangles].any(axis=1)
    if not at_wall.any():
        return math.nan
    c, _ = _hole(model)
    xc = mesh.centroids[at_wall] - c
    w = np.asarray(model.area)[at_wall]
    evals, evecs = np.linalg.eigh((xc * w[:, None]).T @ xc)
    d = evecs[:, int(np.argmax(evals))]
    ang = math.atan2(d[1], d[0])
    if ang <= -0.5 * math.pi:
        ang += math.pi
    elif ang > 0.5 * math.pi:
        ang -= math.pi
    return ang


def _hole(model: MechanicsModel) -> tuple[np.ndarray, float]:
    mesh = model.mesh
    hn = mesh.hole_nodes
    if len(hn) == 0:
        raise InputError("the mesh has no hole wall", key="mesh")
    c = (np.asarray(mesh.hole_center) if mesh.hole_center is not None
         else mesh.nodes[hn].mean(axis=0))
    a = (float(mesh.hole_radius) if mesh.hole_radius is not None
         else float(np.mean(np.hypot(*(mesh.nodes[hn] - c).T))))
    return c, a


def crack_geometry(model: MechanicsModel, cluster_state: np.ndarray
                   ) -> tuple[np.ndarray, float, float]:
    """The crack connected to the hole, its length and the azimuth of its tip.

    Failed clusters (tensile, shear or preset) are connected when they share a node (a
    zig-zag path of triangles through the mesh is one crack); the hole-connected crack is
    every failed cluster connected to one that touches the hole wall.

    Parameters
    ----------
    model : MechanicsModel
    cluster_state : ndarray (n_c,)

    Returns
    -------
    connected : ndarray of bool (n_c,)
        Clusters of the hole-connected crack.
    length : float
        ``max |x_c - x_0| - a`` over its clusters' farthest nodes [m] (0 if empty).
    azimuth : float
        Direction [rad] of the wing holding the farthest node: from the hole centre to
        the area-weighted centroid of the crack clusters on that side (``nan`` if empty).
    """
    cs = np.asarray(cluster_state)
    mesh = model.mesh
    cracked = (cs == FAILED_TENSILE) | (cs == FAILED_SHEAR) | (cs == PRESET)
    connected = np.zeros(len(cs), dtype=bool)
    if not cracked.any():
        return connected, 0.0, math.nan
    idx = np.nonzero(cracked)[0]
    inc = model.cracks.incidence[idx]                    # (k, n_nodes)
    adj = (inc @ inc.T).tocsr()                    # share >= 1 node
    _, labels = csgraph.connected_components(sp.csr_matrix(adj), directed=False)
    on_wall = np.zeros(mesh.n_nodes, dtype=bool)
    on_wall[mesh.hole_nodes] = True
    touches = on_wall[mesh.triangles[idx]].any(axis=1)
    good = np.isin(labels, np.unique(labels[touches]))
    connected[idx[good]] = True
    if not connected.any():
        return connected, 0.0, math.nan
    c, a = _hole(model)
    nodes = np.unique(mesh.triangles[connected])
    d = mesh.nodes[nodes] - c
    r = np.hypot(d[:, 0], d[:, 1])
    k = int(np.argmax(r))
    # azimuth of the longest wing: the area-weighted mean position of the crack clusters
    # on the tip's side of the hole (a single tip node zig-zags by ~h about the path)
    cc = mesh.centroids[connected] - c
    w = model.area[connected] * (cc @ d[k] > 0)
    m = (w[:, None] * cc).sum(axis=0) if w.sum() > 0 else d[k]
    return connected, max(float(r[k]) - a, 0.0), float(math.atan2(m[1], m[0]))


def breakdown_pressure(
    model: MechanicsModel,
    p_max: float,
    state: MechanicsState | None = None,
    dp: float | None = None,
    tol: float = 1e4,
    run_length: float | None = None,
    max_fill: int = 200,
) -> PressureBreakdown:
    """Hole pressure at which the hydraulic fracture runs away (formation breakdown).

    Pressure-controlled quasi-static test of an impermeable rock: the pore pressure of
    intact clusters stays as in ``state``; clusters of the hole-connected crack
    (:func:`crack_geometry`) carry the wall pressure (the fluid fills the crack at no
    pressure loss). At a fixed wall pressure ``p`` the state is *settled*: step with
    failure (:meth:`MechanicsModel.step`), fill the newly connected clusters with ``p``,
    and repeat until nothing fails and the filled set no longer changes (stable crack),
    or the crack is longer than ``run_length`` (runaway).

    Search:

    1. initiation ``p_i`` = first cluster failure (:func:`wall_pressure_at_first_failure`,
       bisection to ``tol``);
    2. continuation from the last intact state: settle at ``p_i``, ``p_i + dp``, ... until
       the crack runs away (every stable state is the start of the next pressure, so the
       crack history is followed);
    3. bisection on ``[p_stable, p_run]`` from the stable state (failure is irreversible
       and the crack only grows with pressure, so the stable state below is a valid start
       for any higher pressure) until the bracket is narrower than ``tol``.

    Parameters
    ----------
    model : MechanicsModel
    p_max : float
        Highest wall pressure to try [Pa].
    state : MechanicsState, optional
        Start, without overstressed clusters; default ``model.initial_state()``.
    dp : float, optional
        Continuation increment [Pa]; default ``(p_max - p_start) / 20``.
    tol : float
        Width of the final bracket [Pa].
    run_length : float, optional
        Crack length [m] (from the wall) that counts as unbounded growth; default
        ``min(20 a, 0.4 d_out)`` with ``a`` the hole radius and ``d_out`` the distance from
        the hole centre to the outer boundary (several metres for a 0.15 m hole, and clear
        of the boundary conditions).
    max_fill : int
        Cap on step/fill cycles at one pressure.

    Returns
    -------
    PressureBreakdown
        ``converged=False`` with a reason if nothing fails or runs away up to ``p_max`` or
        an equilibrium fails.

    Notes
    -----
    A step that finds no equilibrium is first retried by approaching its pressure from the
    last settled state in halves (up to three halvings; the crack only grows with
    pressure, so a settled intermediate state is a valid start, and a crack that runs away
    at the intermediate pressure runs away at the higher one too): a long pressurised crack
    can take the active-set solver out of its convergence range in one jump of ``dp``
    (e.g. 96 wall segments, sigma_H = 45, sigma_h = 30, p0 = 20 MPa: no equilibrium at
    36.99 MPa from the 1.13 m crack of 36.74 MPa; with the halvings the search converges,
    breakdown 36.95 MPa). If that fails too it is reported as a failure (``converged=False``),
    except when at that same pressure the crack (including the clusters failed in the
    unconverged step, which were decided on an equilibrium) has grown to at least twice
    its length at the start of the pressure and beyond ``4 a``: growth at constant
    pressure followed by loss of a quasi-static equilibrium is the instability, and counts
    as runaway (``runaway_length`` then is the length reached, below ``run_length``).
    """
    if state is None:
        state = model.initial_state()
    p_start = float(state.wall_pressure)
    if not p_max > p_start:
        raise InputError("p_max must exceed the current wall pressure", key="p_max")
    dp = (p_max - p_start) / 20.0 if dp is None else float(dp)
    if not dp > 0:
        raise InputError("must be positive", key="dp")
    if not tol > 0:
        raise InputError("must be positive", key="tol")
    c, a = _hole(model)
    if run_length is None:
        nodes = model.mesh.nodes
        d_out = float(min(c[0] - nodes[:, 0].min(), nodes[:, 0].max() - c[0],
                          c[1] - nodes[:, 1].min(), nodes[:, 1].max() - c[1]))
        run_length = min(20.0 * a, 0.4 * d_out)
    run_length = float(run_length)
    base_p = np.array(state.pore_pressure, dtype=float)
    counters = {"it": 0, "solves": 0, "lost": 0}

    def settle(st: MechanicsState, p: float, depth: int = 0):
        """Settle at wall pressure p: (state, ran, ok, why, length, azimuth)."""
        res = _settle(st, p)
        if not res[2]:
            # no equilibrium with the step's own failure rounds: their new clusters keep
            # the rock's pore pressure until the next fill, and a node enclosed by failed
            # clusters with open contacts and unequal pressures has no equilibrium (a
            # mechanism of the cascade, not of the crack). Retry filling every round.
            res = _settle(st, p, filled_rounds=True)
        if res[2] or depth >= _MAX_SUBSTEP_DEPTH:
            return res
        # no equilibrium from st: approach p in two halves. The crack only grows with
        # pressure, so the settled state at the midpoint is a valid start for p, and a
        # crack that runs away at the midpoint runs away at p too.
        mid = 0.5 * (float(st.wall_pressure) + p)
        half = settle(st, mid, depth + 1)
        if not half[2] or half[1]:
            return half if half[1] else res
        return settle(half[0], p, depth + 1)

    def _settle(st: MechanicsState, p: float, filled_rounds: bool = False):
        """One settle attempt. ``filled_rounds``: equilibrate without failure, fail the
        overstressed clusters (:meth:`MechanicsModel.failure_margins`), fill, repeat, so
        no failed cluster of the crack is ever without the crack fluid in a solve."""
        length, az = 0.0, math.nan
        start_length = crack_geometry(model, st.cluster_state)[1]
        for _ in range(max_fill):
            conn, length, az = crack_geometry(model, st.cluster_state)
            if length >= run_length:
                return st, True, True, "ran", length, az
            pores = np.where(conn, p, base_p)
            r = model.step(st, wall_pressure=p, pore_pressure=pores,
                           check_failure=not filled_rounds)
            counters["it"] += r.iterations
            counters["solves"] += 1
            if filled_rounds and r.converged:
                r = _fail_overstressed(r)
            if not r.converged:
                # the failures of the step's last round were decided on an equilibrium,
                # so the crack of the unconverged state is one the rock did grow
                _, reached, reached_az = crack_geometry(model, r.state.cluster_state)
                if reached >= max(4.0 * a, 2.0 * start_length):
                    # the crack has at least doubled, beyond 4 hole radii, at this constant
                    # pressure and no quasi-static equilibrium of its next extension is
                    # found: that is the instability itself, counted as runaway
                    counters["lost"] += 1
                    return r.state, True, True, "ran (equilibrium lost)", reached, reached_az
                return (st, False, False, f"equilibrium at p_w = {p:g} Pa: {r.reason}",
                        length, az)
            st = r.state
            umax = float(np.max(np.abs(st.displacement)))
            if not math.isfinite(umax) or umax > 0.1 * run_length:
                # an "equilibrium" held only by the 1e-9 tangent of open contacts (a failed
                # region without stiffness) is a mechanism, not a crack that ran
                return (st, False, False, f"mechanism at p_w = {p:g} Pa: displacement "
                        f"{umax:.3g} m", length, az)
            if r.new_failures.size == 0:
                # the step ran with the crack filled as it is: nothing more moves
                return st, False, True, "stable", length, az
        return (st, False, False, f"no stable state after {max_fill} fill cycles",
                length, az)

    def _fail_overstressed(r: MechanicsResult) -> MechanicsResult:
        """Fail the clusters overstressed in r.state (tensile before shear, as in
        :meth:`MechanicsModel.step`); ``new_failures`` lists them."""
        st = r.state
        mt, ms = model.failure_margins(st)
        intact = np.asarray(st.cluster_state) == INTACT
        tens = np.nonzero(intact & (mt >= 0.0))[0]
        shear = np.nonzero(intact & (mt < 0.0) & (ms >= 0.0))[0]
        if tens.size:
            st = model.fail_clusters(st, tens, FAILED_TENSILE)
        if shear.size:
            st = model.fail_clusters(st, shear, FAILED_SHEAR)
        return MechanicsResult(state=st, converged=True, reason=r.reason,
                               iterations=r.iterations, failure_rounds=r.failure_rounds,
                               new_failures=np.concatenate([tens, shear]))

    def result(pressure, ok, why, p_i, p_lo, st_lo, len_lo, az, run_len, st_hi, hist):
        return PressureBreakdown(
            pressure=pressure, converged=ok, reason=why, initiation_pressure=p_i,
            pressure_below=p_lo, crack_length=len_lo, azimuth=az, runaway_length=run_len,
            state_below=st_lo, state_after=st_hi, iterations=counters["it"],
            solves=counters["solves"], history=hist,
            start_azimuth=(math.nan if st_hi is None
                           else crack_start_azimuth(model, st_hi.cluster_state)))

    # a crack already connected to the hole (a flaw) carries the hole's fluid from the start
    flaw = crack_geometry(model, state.cluster_state)[0]
    first = wall_pressure_at_first_failure(model, state, p_max, dp=dp, tol=tol,
                                           filled=flaw if flaw.any() else None)
    if first is None:
        return result(math.nan, False, f"no cluster fails up to p_max = {p_max:g} Pa",
                      math.nan, p_max, state, 0.0, math.nan, 0.0, None, [])
    counters["solves"] += first.solves
    p_i = float(first.pressure)
    lo, lo_state, lo_len = float(first.state_before.wall_pressure), first.state_before, 0.0
    history = [(lo, 0.0)]
    # continuation upwards from initiation
    p = p_i
    hi = None
    while True:
        st, ran, ok, why, length, az = settle(lo_state, p)
        if not ok:
            return result(math.nan, False, why, p_i, lo, lo_state, lo_len, math.nan, 0.0,
                          st, history)
        if ran:
            hi, hi_state, hi_len, hi_az = p, st, length, az
            break
        lo, lo_state, lo_len = p, st, length
        history.append((p, length))
        if p >= p_max:
            return result(math.nan, False,
                          f"crack stays bounded up to p_max = {p_max:g} Pa "
                          f"(length {length:.3g} m)", p_i, lo, lo_state, lo_len, az, 0.0,
                          None, history)
        p = min(p + dp, p_max)
    # bisection between the stable and the runaway pressure
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        st, ran, ok, why, length, az = settle(lo_state, mid)
        if not ok:
            return result(hi, False, why, p_i, lo, lo_state, lo_len, hi_az, hi_len,
                          hi_state, sorted(history))
        if ran:
            hi, hi_state, hi_len, hi_az = mid, st, length, az
        else:
            lo, lo_state, lo_len = mid, st, length
            history.append((mid, length))
    return result(hi, True, "converged", p_i, lo, lo_state, lo_len, hi_az, hi_len, hi_state,
                  sorted(history))


# =========================================================================== first failure
@dataclass(frozen=True, eq=False)
class BreakdownResult:
    """First cluster failure under rising wall pressure.

    Attributes
    ----------
    pressure : float
        Wall pressure [Pa] at which the first cluster fails (within ``tol``).
    clusters : ndarray of int
        Clusters failing first (at ``pressure``, before any redistribution).
    mode : ndarray of int
        ``FAILED_TENSILE`` or ``FAILED_SHEAR`` for each of ``clusters``.
    state_before : MechanicsState
        Equilibrium just below ``pressure`` (no failure).
    result_after : MechanicsResult
        Step to ``pressure`` with failure (and its cascade) enabled.
    solves : int
        Equilibrium solves used by the search.
    """

    pressure: float
    clusters: np.ndarray
    mode: np.ndarray
    state_before: MechanicsState
    result_after: MechanicsResult
    solves: int


def wall_pressure_at_first_failure(
    model: MechanicsModel,
    state: MechanicsState,
    p_max: float,
    dp: float | None = None,
    tol: float = 1e3,
    pressurize_failed: bool = False,
    filled: np.ndarray | None = None,
) -> BreakdownResult | None:
    """Raise the wall pressure (pore pressure unchanged: impermeable wall) until a cluster
    fails; locate that pressure by bisection.

    Parameters
    ----------
    model : MechanicsModel
    state : MechanicsState
        Start (normally :meth:`MechanicsModel.initial_state`); must have no overstressed
        cluster.
    p_max : float
        Highest wall pressure to try [Pa].
    dp : float, optional
        Scan increment [Pa]; default ``(p_max - p_start) / 20``.
    tol : float
        Width of the final bracket [Pa].
    pressurize_failed : bool
        If True the failed clusters (a crack connected to the hole) are filled with
        the wall pressure; otherwise all cluster pressures stay as in ``state``.
    filled : ndarray of bool (n_c,), optional
        The clusters filled with the wall pressure, instead of every failed one
        (:func:`breakdown_pressure` passes the hole-connected crack of its start).

    Returns
    -------
    BreakdownResult or None
        None if nothing fails up to ``p_max``.

    Notes
    -----
    The criterion is the MDEM one: each intact cluster's *average* Terzaghi effective stress
    (Eq. 2.15-2.21). At a stress concentration this average lies below the peak value at
    the wall by about the stress gradient times the centroid offset of the wall clusters,
    so the breakdown pressure of a mesh exceeds the point-criterion (Hubbert-Willis) value
    by an amount proportional to the wall element size (see docs/mechanics.md).
    """
    p0 = state.wall_pressure
    if not p_max > p0:
        raise InputError("p_max must exceed the current wall pressure", key="p_max")
    dp = (p_max - p0) / 20.0 if dp is None else float(dp)
    if not dp > 0:
        raise InputError("must be positive", key="dp")
    solves = 0

    base_p = np.asarray(state.pore_pressure)
    failed = np.asarray(state.cluster_state) != INTACT
    if filled is not None:
        failed, pressurize_failed = np.asarray(filled, dtype=bool), True

    def pores(p: float) -> np.ndarray:
        return np.where(failed, p, base_p) if pressurize_failed else base_p

    def trial(p: float):
        nonlocal solves
        solves += 1
        r = model.step(state, wall_pressure=p, pore_pressure=pores(p), check_failure=False)
        if not r.converged:
            raise RuntimeError(f"equilibrium at p_w = {p:g} Pa failed: {r.reason}")
        mt, ms = model.failure_margins(r.state)
        intact = np.asarray(r.state.cluster_state) == INTACT
        return r.state, intact & (mt >= 0.0), intact & (ms >= 0.0)

    st, t, s = trial(p0)
    if np.any(t | s):
        raise InputError("clusters are already overstressed at the start", key="state")
    lo, lo_state = p0, st
    hi = None
    p = p0
    while p < p_max:
        p = min(p + dp, p_max)
        st, t, s = trial(p)
        if np.any(t | s):
            hi = p
            break
        lo, lo_state = p, st
    if hi is None:
        return None
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        st, t, s = trial(mid)
        if np.any(t | s):
            hi = mid
        else:
            lo, lo_state = mid, st
    _, t, s = trial(hi)
    clusters = np.nonzero(t | s)[0]
    mode = np.where(t[clusters], FAILED_TENSILE, FAILED_SHEAR)
    after = model.step(lo_state, wall_pressure=hi, pore_pressure=pores(hi),
                       check_failure=True)
    solves += 1
    return BreakdownResult(pressure=hi, clusters=clusters, mode=mode, state_before=lo_state,
                           result_after=after, solves=solves)
