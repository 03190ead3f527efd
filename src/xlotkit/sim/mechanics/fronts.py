"""Crack tips and crack fronts of an MDEM model, and the stress intensity at each crack end.

:class:`CrackFronts` holds the mesh topology the crack-tip criterion needs (cluster-node
incidence, clusters sharing a node, edge neighbours, a node search tree, the shape-function
gradients and compliance of the interaction integral) and answers, for a mechanics state:
which clusters touch the crack (:meth:`CrackFronts.touches_crack`), which are ahead of a
crack end (:meth:`CrackFronts.crack_tips`), and how the tips group into fronts with their
``K_I`` and the cluster that fails next (:meth:`CrackFronts.fronts`). Used by
:meth:`xlotkit.sim.mechanics.MechanicsModel.failure_margins`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.spatial import cKDTree

from xlotkit.sim.mechanics.failure import (
    TIP_DOMAIN_RADII,
    principal_stresses,
    tip_stress_intensities,
)
from xlotkit.sim.mechanics.states import FAILED_SHEAR, FAILED_TENSILE, INTACT, PRESET
from xlotkit.sim.mesh import Mesh

__all__ = ["CrackFront", "CrackFronts"]


# crack fronts (see MechanicsModel.crack_fronts): a cluster may extend the crack when
# every failed cluster sharing an edge with it lies behind it within acos(0.4) = 66 deg
# of the crack direction (on the KGD band the step past a pointed tip is 57 deg off the
# crack line, a cluster beside the faces 80-90 deg); candidates within 0.1 h of the one
# closest to the crack's line are ties; the line is fitted over twice the domain radius
_FRONT_COS = 0.4
_FRONT_TIE = 0.1
_FRONT_LINE = 2.0


@dataclass(frozen=True, eq=False)
class CrackFront:
    """A crack tip as seen by the crack-tip criterion (:meth:`MechanicsModel.crack_fronts`).

    Attributes
    ----------
    members : ndarray of int
        The tip clusters (:meth:`MechanicsModel.crack_tips`) of this front: a connected
        group of intact clusters around one crack end.
    lead : int
        The intact cluster that fails when the front propagates (at the tip, sharing an
        edge with the crack behind it, closest to the crack's line; usually a member), or
        -1 when the group is not at a crack end (e.g. clusters beside the faces classed as
        tips in a nearly isotropic field) or no cluster qualifies; such groups keep the
        cluster-average tip criterion
        (:func:`xlotkit.sim.mechanics.failure.crack_tip_margin`).
    stress_intensity : float
        Mode-I stress intensity ``K_I`` [Pa m^0.5] at the front's tip (interaction
        integral); nan when the group is not a crack end.
    shear_stress_intensity : float
        ``K_II`` [Pa m^0.5] (nan likewise).
    direction : ndarray (2,)
        The crack's direction at the tip, pointing ahead (zeros when not a crack end).
    face_pressure : float
        Crack fluid pressure used for the front [Pa].
    """

    members: np.ndarray
    lead: int
    stress_intensity: float
    shear_stress_intensity: float
    direction: np.ndarray
    face_pressure: float


class CrackFronts:
    """Crack tips and fronts on a mesh (module docstring).

    Parameters
    ----------
    mesh : Mesh
    area : ndarray (n_c,)
        Cluster areas [m^2].
    grad_n : ndarray (n_c, 2, 3)
        Shape-function gradients of the clusters.
    compliance : ndarray (3, 3)
        Plane-strain compliance of the rock.
    young, poisson : float
        Elastic constants of the rock (the interaction integral's auxiliary field).
    """

    def __init__(self, mesh: Mesh, area: np.ndarray, grad_n: np.ndarray,
                 compliance: np.ndarray, young: float, poisson: float) -> None:
        self.mesh = mesh
        self.area = area
        self.young, self.poisson = young, poisson
        self._grad_n = grad_n
        self._compliance = compliance
        self._node_tree = cKDTree(mesh.nodes)
        self._boundary_nodes = np.unique(mesh.boundary_edges)
        self._edge_nbrs = _edge_neighbours(mesh)
        # cluster-node incidence (n_c x n_nodes), for "touches a failed cluster"
        nt = mesh.n_triangles
        tris = mesh.triangles
        self.incidence = sp.csr_matrix(
            (np.ones(3 * nt), (np.repeat(np.arange(nt), 3), tris.reshape(-1))),
            shape=(nt, mesh.n_nodes))
        # pairs (i, j) of clusters sharing a node (i == j included), for crack tips
        touch = (self.incidence @ self.incidence.T).tocoo()
        self._touch_pairs = (touch.row.astype(np.int64), touch.col.astype(np.int64))
        self._node_clusters = self.incidence.T.tocsr()
        # the last state asked for its crack tips, with the answer (crack_tips)
        self._tips_of: tuple | None = None
        # what depends only on the set of failed clusters (the tip points and crack
        # directions, the interaction-integral domains: geometry), kept for the last set
        self._geometry_of: tuple[bytes, dict] = (b"", {})

    def touches_crack(self, cluster_state: np.ndarray) -> np.ndarray:
        """Clusters sharing at least one node with a failed (tensile, shear or preset)
        cluster, i.e. the clusters around the crack faces and tips.

        Interface clusters do not count: a pre-defined plane is not a crack the rock grew.
        """
        cs = np.asarray(cluster_state)
        cracked = (cs == FAILED_TENSILE) | (cs == FAILED_SHEAR) | (cs == PRESET)
        if not cracked.any():
            return np.zeros(len(cs), dtype=bool)
        # (the incidence's rows are the triangles' nodes: index them directly, which
        # is ~20x cheaper than slicing the sparse incidence; it is asked at every
        # failure check, several times)
        tris = self.mesh.triangles
        on_crack = np.zeros(self.mesh.n_nodes, dtype=bool)
        on_crack[tris[cracked].ravel()] = True
        return on_crack[tris].any(axis=1)

    def crack_tips(self, state) -> tuple[np.ndarray, np.ndarray]:
        """Intact clusters ahead of a crack end, and the fluid pressure on that crack.

        A cluster ``i`` touching the crack (:meth:`touches_crack`) is a *tip* cluster when
        every failed cluster it shares a node with lies in ``i``'s own plane of largest
        tension: the offset ``x_i - x_c`` between the centroids is closer to the
        direction of the most compressive principal stress of ``i`` than to the least
        compressive one (the opening direction). A mode-I crack grows in that plane, so
        ``i`` is where the crack would extend; a cluster beside the crack faces has a
        failed neighbour across the crack (offset along its opening direction) and is
        not a tip.

        Parameters
        ----------
        state : MechanicsState

        Returns
        -------
        tip : ndarray of bool (n_c,)
        face_pressure : ndarray (n_c,) [Pa]
            Mean pressure of the failed clusters touching each tip cluster (the crack
            fluid pressure at that tip); 0 elsewhere.
        """
        last = self._tips_of
        if last is not None and last[0] is state:
            # asked again for the same state (the failure check asks, then the crack
            # fronts it measures): the state is immutable, the answer the same
            return last[1], last[2]
        tip, pf = self._crack_tips(state)
        tip.setflags(write=False)
        pf.setflags(write=False)
        self._tips_of = (state, tip, pf)
        return tip, pf

    def _crack_tips(self, state) -> tuple[np.ndarray, np.ndarray]:
        cs = np.asarray(state.cluster_state)
        nc = len(cs)
        cracked = (cs == FAILED_TENSILE) | (cs == FAILED_SHEAR) | (cs == PRESET)
        tip = np.zeros(nc, dtype=bool)
        pf = np.zeros(nc)
        if not cracked.any():
            return tip, pf
        i, c = self._touch_pairs
        keep = (cs[i] == INTACT) & cracked[c]
        i, c = i[keep], c[keep]
        d = self.mesh.centroids[i] - self.mesh.centroids[c]
        # angle of the most compressive principal stress of i = the crack plane direction
        _, _, ang = principal_stresses(np.asarray(state.effective_stress)[i])
        along = np.abs(d[:, 0] * np.cos(ang) + d[:, 1] * np.sin(ang))
        across = np.abs(d[:, 1] * np.cos(ang) - d[:, 0] * np.sin(ang))
        tip[i] = True
        tip[i[across >= along]] = False
        n = np.bincount(i, minlength=nc)
        p = np.asarray(state.pore_pressure)
        pf = np.where(tip, np.bincount(i, weights=p[c], minlength=nc) / np.maximum(n, 1), 0.0)
        return tip, pf

    def fronts(self, state, strength: np.ndarray) -> list[CrackFront]:
        """Group the tip clusters into crack fronts and measure ``K_I`` at each crack end.

        The tip clusters (:meth:`crack_tips`) that share nodes form a group. Around the
        group's most loaded member ``c0`` (largest singular opening tension relative to its
        strength; size ``h = sqrt(2 A)``, ``r_in, r_out = TIP_DOMAIN_RADII h``) the crack is
        located from the failed clusters: its direction ``t`` is the principal axis (area
        weighted) of the failed centroids within ``2 r_out``, pointing towards ``c0``; its
        tip is the point of the line through their centroid level with the furthest node,
        along ``t``, of the failed clusters within ``r_out`` (the node or edge where the
        crack ends). The group is a crack end only if that tip lies within ``r_in / 2`` of
        ``c0``: groups beside the faces, or at the crack mouth on the hole wall, find it
        farther away (or not at all) and get no lead.

        At a crack end ``K_I`` (and ``K_II``) is measured by the interaction integral over
        the annulus ``r_in < r < r_out`` about the tip
        (:func:`~xlotkit.sim.mechanics.failure.tip_stress_intensities`; the crack-induced
        field ``S - p_f I`` of the intact clusters, the failed clusters as the crack,
        weight 0 on the mesh boundary). The domain is several clusters wide, so ``K_I`` does
        not depend on whether the crack ends on an edge or at a node, which the
        cluster-average criterion did (KGD band: flat tips extended at 0.99-1.03 ``K_IC``,
        pointed ones at 1.19-1.38; now 1.006-1.023 for both).

        The front's *lead* is the cluster that fails when ``K_I`` reaches the toughness:
        among the intact clusters within ``r_in / 2`` of the tip that share an edge with a
        failed cluster, and whose every such failed neighbour lies behind them within 66
        deg of ``t``, the one closest to the crack's line, ties (within 0.1 h) broken by the
        opening tension. Growing the crack through an edge keeps it connected (for the
        fluid too); the line fitted over ``2 r_out`` keeps a mode-I crack straight on a
        lattice whose rows run at +-26.6 deg to it (over ``r_out`` the ~h/2 wander of the
        lattice path tilted it by up to 13 deg and the path drifted out of the KGD band).

        Parameters
        ----------
        state : MechanicsState
        strength : ndarray (n_c,)
            Tensile strength of every cluster in its present state
            (:meth:`MechanicsModel.strengths`) [Pa].

        Returns
        -------
        list of CrackFront
        """
        tip, pf = self.crack_tips(state)
        if not tip.any():
            return []
        T = strength
        cs = np.asarray(state.cluster_state)
        cracked = (cs == FAILED_TENSILE) | (cs == FAILED_SHEAR) | (cs == PRESET)
        idx = np.flatnonzero(tip)
        stress = np.asarray(state.stress)
        sing = stress[idx].copy()
        sing[:, :2] -= pf[idx, None]
        _, s2, _ = principal_stresses(sing)
        load = -s2 / np.maximum(T[idx], 1.0)
        i, c = self._touch_pairs
        keep = tip[i] & tip[c]
        pos = np.full(len(cs), -1, dtype=np.int64)
        pos[idx] = np.arange(len(idx))
        n_groups, label = connected_labels(len(idx), pos[i[keep]], pos[c[keep]])
        cen = self.mesh.centroids
        cracked_idx = np.flatnonzero(cracked)
        # clusters that can extend a crack: intact, sharing an edge with a failed one
        nb = self._edge_nbrs
        pool = np.flatnonzero((cs == INTACT) & np.any((nb >= 0) & cracked[np.maximum(nb, 0)],
                                                      axis=1))
        fronts = []
        for gi in range(n_groups):
            mem = np.flatnonzero(label == gi)
            c0 = idx[mem[np.argmax(load[mem])]]
            h = math.sqrt(2.0 * self.area[c0])
            r_in, r_out = TIP_DOMAIN_RADII[0] * h, TIP_DOMAIN_RADII[1] * h
            front = self._locate_tip(c0, cracked_idx, r_out)
            lead, k1, k2 = -1, math.nan, math.nan
            t = np.zeros(2)
            if front is not None and np.hypot(*(front[0] - cen[c0])) <= 0.5 * r_in:
                x_tip, t = front
                k1, k2 = self._tip_stress_intensities(state, x_tip, t, r_in, r_out,
                                                      float(pf[c0]), cracked)
                cand = pool[np.hypot(*(cen[pool] - x_tip).T) <= 0.5 * r_in]
                lead = self._front_lead(cand, stress, float(pf[c0]), T, cracked, t, x_tip, h)
            fronts.append(CrackFront(members=idx[mem], lead=lead, stress_intensity=k1,
                                     shear_stress_intensity=k2, direction=t,
                                     face_pressure=float(pf[c0])))
        return fronts

    def _geometry(self, cracked: np.ndarray) -> dict:
        """The memo of the geometric answers for the failed clusters ``cracked`` (bool,
        (n_c,)): a new (empty) one when the set differs from the last one asked for. The
        failure checks of one failure round (at a loose and at the converged iterate,
        retries) ask for the same set."""
        key = np.packbits(cracked).tobytes()
        if self._geometry_of[0] != key:
            self._geometry_of = (key, {})
        return self._geometry_of[1]

    def _locate_tip(self, c0: int, cracked_idx: np.ndarray, radius: float):
        """Tip point and crack direction near cluster ``c0`` (see :meth:`fronts`),
        or None without failed clusters nearby (a function of the failed clusters'
        geometry alone, remembered for the present set)."""
        memo = self._geometry(self._cracked_mask(cracked_idx))
        key = ("tip", int(c0), float(radius))
        if key not in memo:
            memo[key] = self._locate_tip_now(c0, cracked_idx, radius)
        return memo[key]

    def _cracked_mask(self, cracked_idx: np.ndarray) -> np.ndarray:
        m = np.zeros(self.mesh.n_triangles, dtype=bool)
        m[cracked_idx] = True
        return m

    def _locate_tip_now(self, c0: int, cracked_idx: np.ndarray, radius: float):
        cen = self.mesh.centroids
        dist = np.hypot(*(cen[cracked_idx] - cen[c0]).T)
        near = cracked_idx[dist < radius]
        if near.size == 0:
            return None
        # the crack's line over twice the radius: a lattice path wanders by ~h/2, which
        # tilted a line fitted over 6 h by up to 13 deg (measured), and the lead is chosen
        # on it
        line = cracked_idx[dist < _FRONT_LINE * radius]
        w = self.area[line]
        m = (w @ cen[line]) / w.sum()
        d = cen[line] - m
        if line.size == 1:
            t = cen[c0] - m
        else:
            evals, evecs = np.linalg.eigh((d * w[:, None]).T @ d)
            t = evecs[:, int(np.argmax(evals))]
        nt = float(np.hypot(*t))
        if nt == 0.0:
            return None
        t = t / nt
        if (cen[c0] - m) @ t < 0.0:
            t = -t
        ahead = float(np.max((self.mesh.nodes[self.mesh.triangles[near]] - m) @ t))
        return m + ahead * t, t

    def _front_lead(self, cand: np.ndarray, stress: np.ndarray, face_pressure: float,
                    strength: np.ndarray, cracked: np.ndarray, t: np.ndarray,
                    x_tip: np.ndarray, h: float) -> int:
        """The cluster that extends the crack (see :meth:`fronts`), or -1."""
        cen = self.mesh.centroids
        ok = []
        for ci in cand:
            nb = self._edge_nbrs[ci]
            nb = nb[nb >= 0]
            nb = nb[cracked[nb]]
            d = cen[ci] - cen[nb]
            if nb.size and np.all(d @ t > _FRONT_COS * np.hypot(d[:, 0], d[:, 1])):
                ok.append(ci)
        if not ok:
            return -1
        ok = np.array(ok)
        lat = np.abs((cen[ok] - x_tip) @ np.array([-t[1], t[0]]))
        tie = ok[lat <= lat.min() + _FRONT_TIE * h]
        sing = stress[tie].copy()
        sing[:, :2] -= face_pressure
        _, s2, _ = principal_stresses(sing)
        return int(tie[np.argmax(-s2 / np.maximum(strength[tie], 1.0))])

    def _tip_stress_intensities(self, state, x_tip: np.ndarray,
                                t: np.ndarray, r_in: float, r_out: float,
                                face_pressure: float,
                                cracked: np.ndarray) -> tuple[float, float]:
        """``K_I, K_II`` [Pa m^0.5] by the interaction integral (see :meth:`fronts`)."""
        tris = self.mesh.triangles
        memo = self._geometry(cracked)
        key = ("domain", np.asarray(x_tip, dtype=float).tobytes(), float(r_in), float(r_out))
        if key not in memo:
            memo[key] = self._domain(x_tip, r_in, r_out, cracked)
        dom = memo[key]
        if dom is None:
            return 0.0, 0.0
        els, q = dom
        stress = np.array(np.asarray(state.stress)[els], dtype=float)
        stress[:, :2] -= face_pressure
        return tip_stress_intensities(
            self._grad_n[els], tris[els], self.area[els], self.mesh.centroids[els],
            np.asarray(state.displacement), stress, self._compliance, q, x_tip, t,
            self.young, self.poisson)

    def _domain(self, x_tip: np.ndarray, r_in: float, r_out: float, cracked: np.ndarray):
        """The interaction integral's domain about ``x_tip``: the intact clusters with a
        node within ``r_out`` and the weight ``q`` of every node (1 inside ``r_in``, 0
        beyond ``r_out`` and on the mesh boundary); None when no node is that close."""
        nodes = self.mesh.nodes
        tris = self.mesh.triangles
        near = np.asarray(self._node_tree.query_ball_point(x_tip, r_out), dtype=np.int64)
        if near.size == 0:
            return None
        # the clusters with a node in the disc (sorted, each once)
        on = np.zeros(self.mesh.n_nodes, dtype=bool)
        on[near] = True
        els = np.flatnonzero(on[tris].any(axis=1))
        els = els[~cracked[els]]
        q = np.zeros(self.mesh.n_nodes)
        q[near] = np.clip((r_out - np.hypot(*(nodes[near] - x_tip).T)) / (r_out - r_in),
                          0.0, 1.0)
        q[self._boundary_nodes] = 0.0
        els.setflags(write=False)
        q.setflags(write=False)
        return els, q


@njit(cache=True)
def _components_kernel(a, b, parent, label):  # pragma: no cover - compiled
    for v in range(parent.shape[0]):
        parent[v] = v
    for e in range(a.shape[0]):
        # union by the smaller root, with path halving
        x = a[e]
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        y = b[e]
        while parent[y] != y:
            parent[y] = parent[parent[y]]
            y = parent[y]
        if x < y:
            parent[y] = x
        elif y < x:
            parent[x] = y
    # labels in the order of each component's first vertex
    n_groups = 0
    for v in range(parent.shape[0]):
        r = v
        while parent[r] != r:
            r = parent[r]
        if r == v:
            label[v] = n_groups
            n_groups += 1
        else:
            label[v] = label[r]
    return n_groups


def connected_labels(n: int, a: np.ndarray, b: np.ndarray) -> tuple[int, np.ndarray]:
    """Connected components of the undirected graph on ``n`` vertices with the edges
    ``(a_e, b_e)``: ``(n_groups, labels)``, the labels numbered in the order of each
    component's lowest vertex (as :func:`scipy.sparse.csgraph.connected_components`
    numbers them), without building a sparse matrix."""
    a = np.ascontiguousarray(a, dtype=np.int64)
    b = np.ascontiguousarray(b, dtype=np.int64)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError("a and b must be 1D arrays of the same length")
    if a.size and (min(a.min(), b.min()) < 0 or max(a.max(), b.max()) >= n):
        raise ValueError(f"edge ends out of range [0, {n})")
    label = np.empty(n, dtype=np.int32)
    n_groups = _components_kernel(a, b, np.empty(n, dtype=np.int64), label)
    return int(n_groups), label


def _edge_neighbours(mesh: Mesh) -> np.ndarray:
    """Triangles sharing an edge with each triangle, (n_c, 3), padded with -1."""
    _, owners = mesh.edges()
    a, b = owners[owners[:, 1] >= 0].T
    pairs = np.concatenate([np.column_stack([a, b]), np.column_stack([b, a])])
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]
    slot = np.arange(len(pairs)) - np.searchsorted(pairs[:, 0], pairs[:, 0], side="left")
    nb = -np.ones((mesh.n_triangles, 3), dtype=np.int64)
    nb[pairs[:, 0], slot] = pairs[:, 1]
    return nb
