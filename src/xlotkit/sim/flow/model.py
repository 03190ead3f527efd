"""Cell-centred finite-volume flow on the MDEM triangles, with the borehole as one unknown.

Unknowns ``x = (p_0, ..., p_{m-1}, p_w)``: one pressure per triangle and the well pressure.

Discrete equations (backward Euler, one per cell ``i`` and one for the well), residuals in
kg/s (mass rate)::

    R_i = [M_i(p_i) - M_i(p_i^n)] / dt  -  sum_j F_ij  -  F_wi  -  F_Di
    R_w = [M_w(p_w) - M_w(p_w^n)] / dt  +  sum_i F_wi  -  rho0 Q(t_{n+1/2})

with the cell fluid mass ``M_i = rho(p_i) (phi(p_i) A_i h + V^x_i)`` (``V^x`` an extra pore
volume supplied by the mechanics: crack volume, skeleton volume change), the well mass of
:mod:`properties` and the two-point mass fluxes (from ``j`` into ``i``)::

    F_ij = (rho_up / mu) T_ij (p_j - p_i)         rho_up = rho(p_j) if p_j > p_i else rho(p_i)

``F_wi`` (well -> wall cell ``i``, through the hole-wall edges) and ``F_Di`` (fixed-pressure
outer edges) have the same form. With a prescribed well pressure the well row becomes
``s (p_w - p_set) = 0`` and the injected mass rate is diagnosed from the well balance.

Hooks for the hydro-mechanical coupling
---------------------------------------
* ``FlowState.extra_pore_volume`` ``V^x`` (crack volume ``phi_f V_b`` of Eq. 4.4 plus the
  skeleton's pore-volume change) enters the cell mass, so its change over a step is the
  ``dV_pore(u)/dt`` term; ``FlowResidual.d_residual_d_extra_volume`` (``rho/dt``, diagonal)
  chains with ``dV^x/du`` from the mechanics.
* ``permeability=`` overrides the cell permeability (aperture-dependent, Eq. 4.3) and
  :meth:`FlowModel.d_residual_d_permeability` gives ``dR/dk`` for the chain rule.
* ``well_rate=(Q, dQ/dp_w)`` makes the injection pressure-dependent (choke flowback,
  Eq. 4.24) with its Jacobian entry; the well storage ``C_w`` is a number (whole-well
  compliance from :mod:`xlotkit.sim.well`).

Transmissibility (two-point flux approximation, TPFA)
-----------------------------------------------------
For the edge ``f`` (length ``L``, unit normal ``n``, midpoint ``x_f``) and the cell ``i``
with pressure point ``c_i``, the half-transmissibility is ``t_i = k_i L h / d_i`` with
``d_i = (x_f - c_i) . n`` the centre-to-edge distance projected on the normal. The face
transmissibility is the harmonic combination (series resistances; thesis 4.4.3)::

    T_ij = t_i t_j / (t_i + t_j)          [m^3]   (0 if either side is impermeable)

A wall cell connects to the well with its half-transmissibility alone (no resistance on the
well side); a fixed-pressure outer edge likewise. ``averaging="arithmetic"`` uses instead
``T_ij = (k_i + k_j)/2 * L h / (d_i + d_j)`` -- the mean that caused "parallel fracturing" in
the thesis; it is available for comparison only.

Consistency caveat and the choice of cell centre: TPFA is consistent only when the line
joining the two pressure points is parallel to the edge normal (K-orthogonal grids). With
*centroids* (``cell_centres="centroid"``) that fails on general triangles: the tangential
pressure difference is ignored, an O(1) flux error that does not shrink with refinement.
On the generator's ring-structured borehole meshes it over-predicts the radial conductance
(well pressure ~5 % low, cell pressures up to ~10 % off in the radial tests, docs/flow.md).
The default ``cell_centres="circumcentre"`` places each cell's pressure at its circumcentre:
on a Delaunay mesh the circumcentres of two neighbours lie on the perpendicular bisector of
their shared edge (the Voronoi dual), so the two-point flux is consistent (errors <= 1 %
in the same tests). An obtuse triangle's circumcentre lies outside it; the edge's
circumcentre spacing ``d_i + d_j`` (>= 0 for Delaunay edges) is kept and split no more
unevenly than 5 %/95 % so the harmonic weights stay finite; for a non-Delaunay edge, or
where the spacing vanishes (right triangles sharing a hypotenuse), the centroid distances
are used. Storage always uses the triangle area.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.sparse as sp

from xlotkit.errors import InputError
from xlotkit.sim.flow.kernels import face_fluxes
from xlotkit.sim.flow.properties import (
    FluidProperties,
    OuterBoundary,
    RockFlowProperties,
    WellCondition,
    expm1_over_x,
)
from xlotkit.sim.mesh import HOLE, Mesh

__all__ = [
    "FlowModel",
    "FlowResidual",
    "FlowState",
    "arithmetic_transmissibility",
    "circumcentres",
    "edge_geometry",
    "harmonic_transmissibility",
]


def _ro(a) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


# --------------------------------------------------------------------------- state
@dataclass(frozen=True, eq=False)
class FlowState:
    """Flow state at one time (read-only arrays).

    Attributes
    ----------
    t : float
        Time [s].
    p : ndarray, shape (m,)
        Cell pressures [Pa].
    p_w : float
        Well (borehole) pressure [Pa].
    extra_pore_volume : ndarray, shape (m,)
        Pore volume added to each cell by the skeleton [m^3] (crack volume ``phi_f V_b``,
        poroelastic volume change); zeros for rigid rock. The hydro-mechanical step sets
        it from the displacements; its time change is the ``dV_pore(u)/dt`` term.
    well_extra_volume : float
        Volume added to the well [m^3] (the hole's enlargement by the wall displacement,
        ``h f_wall . (u - u_0)``, set by the hydro-mechanical step); 0 for a rigid hole.
        The well mass is ``M_w(p_w) + rho(p_w) * well_extra_volume``.
    """

    t: float
    p: np.ndarray
    p_w: float
    extra_pore_volume: np.ndarray
    well_extra_volume: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "t", float(self.t))
        object.__setattr__(self, "p_w", float(self.p_w))
        object.__setattr__(self, "well_extra_volume", float(self.well_extra_volume))
        object.__setattr__(self, "p", _ro(self.p))
        object.__setattr__(self, "extra_pore_volume", _ro(self.extra_pore_volume))
        if self.p.ndim != 1 or self.extra_pore_volume.shape != self.p.shape:
            raise InputError("p and extra_pore_volume must be 1D arrays of equal length",
                             key="state")

    @property
    def x(self) -> np.ndarray:
        """Unknown vector ``(p, p_w)``, shape (m + 1,)."""
        return np.append(self.p, self.p_w)

    def with_x(self, x: np.ndarray, t: float | None = None) -> "FlowState":
        """Copy with the unknowns replaced by ``x`` (shape (m + 1,)) and optionally ``t``."""
        return FlowState(self.t if t is None else t, x[:-1], x[-1], self.extra_pore_volume,
                         self.well_extra_volume)


@dataclass(frozen=True, eq=False)
class FlowResidual:
    """Residual, Jacobian and the mass-rate diagnostics of one backward-Euler step.

    Attributes
    ----------
    residual : ndarray, shape (m + 1,)
        ``R(p, p_w)`` [kg/s]; the last entry is the well row.
    jacobian : scipy.sparse.csr_matrix, shape (m + 1, m + 1)
        ``dR/dx`` [kg/(s Pa)].
    d_residual_d_extra_volume : ndarray, shape (m,)
        ``dR_i/dV^x_i = rho(p_i)/dt`` [kg/(s m^3)], the (diagonal) chain-rule factor for the
        coupled Jacobian ``dR/du = diag(.) dV^x/du``.
    injection_rate : float
        Mass rate pumped into the well [kg/s] (``rho0 Q``; diagnosed when pressure-driven).
    formation_rate : float
        Mass rate from the well into the wall cells [kg/s].
    boundary_rate : float
        Mass rate leaving through fixed-pressure outer edges [kg/s].
    storage_rate_cells : ndarray, shape (m,)
        ``(M_i - M_i^n)/dt`` [kg/s].
    storage_rate_well : float
        ``(M_w - M_w^n)/dt`` [kg/s].
    throughput : float
        Scale of the step's mass rates for relative tolerances [kg/s]:
        ``|injection| + sum |F_well| + sum |F_fixed| + sum_i |storage_i| + |storage_w|``.
    d_residual_d_well_volume : float
        ``dR_w/dV^x_w = rho(p_w)/dt`` [kg/(s m^3)] (rate-driven well; 0 when the well row
        is a pressure equation), the chain-rule factor for the hole's volume change.
    jacobian_values : ndarray, optional
        The Jacobian's entries in the fixed order of :attr:`FlowModel.jacobian_triplets`
        (duplicates to be summed), for callers that assemble it into a larger matrix of a
        fixed sparsity pattern.
    """

    residual: np.ndarray
    jacobian: sp.csr_matrix
    d_residual_d_extra_volume: np.ndarray
    injection_rate: float
    formation_rate: float
    boundary_rate: float
    storage_rate_cells: np.ndarray
    storage_rate_well: float
    throughput: float
    d_residual_d_well_volume: float = 0.0
    jacobian_values: np.ndarray | None = None

    @property
    def mass_rate_imbalance(self) -> float:
        """``injection - d(stored)/dt - boundary outflow`` [kg/s] (0 at convergence)."""
        return (self.injection_rate - float(np.sum(self.storage_rate_cells))
                - self.storage_rate_well - self.boundary_rate)



# --------------------------------------------------------------------------- kernels
def edge_geometry(nodes: np.ndarray, edges: np.ndarray, centres: np.ndarray,
                  owners: np.ndarray, centroids: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Edge lengths and centre-to-edge distances projected on the edge normal.

    Parameters
    ----------
    nodes : ndarray, shape (n, 2)
    edges : ndarray of int, shape (e, 2)
    centres : ndarray, shape (m, 2)
        Cell pressure points [m] (centroids or circumcentres).
    owners : ndarray of int, shape (e, 2)
        Cells on each side (-1: none).
    centroids : ndarray, shape (m, 2), optional
        Triangle centroids; when given the distance is *signed*: positive when the centre
        lies on the same side of the edge as the cell (a circumcentre of an obtuse
        triangle may not). Without it ``|d|`` is returned.

    Returns
    -------
    length : ndarray, shape (e,)
        Edge length ``L`` [m].
    distance : ndarray, shape (e, 2)
        ``d = (x_f - c) . n`` [m] for each owner (``inf`` where the owner is -1).
    """
    a = nodes[edges[:, 0]]
    b = nodes[edges[:, 1]]
    t = b - a
    length = np.hypot(t[:, 0], t[:, 1])
    normal = np.column_stack([t[:, 1], -t[:, 0]]) / length[:, None]
    mid = 0.5 * (a + b)
    dist = np.full(owners.shape, np.inf)
    for s in (0, 1):
        ok = owners[:, s] >= 0
        d = np.einsum("ij,ij->i", mid[ok] - centres[owners[ok, s]], normal[ok])
        if centroids is None:
            d = np.abs(d)
        else:
            side = np.einsum("ij,ij->i", mid[ok] - centroids[owners[ok, s]], normal[ok])
            d = d * np.sign(side)
        dist[ok, s] = d
    return length, dist


def circumcentres(nodes: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Circumcentres of triangles [m], shape (m, 2).

    On a Delaunay mesh the segment joining the circumcentres of two neighbours is
    perpendicular to their shared edge (the Voronoi dual), which makes the two-point flux
    consistent.
    """
    p = nodes[triangles]
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    ba = b - a
    ca = c - a
    d = 2.0 * (ba[:, 0] * ca[:, 1] - ba[:, 1] * ca[:, 0])
    nb = np.einsum("ij,ij->i", ba, ba)
    nc = np.einsum("ij,ij->i", ca, ca)
    ux = (ca[:, 1] * nb - ba[:, 1] * nc) / d
    uy = (ba[:, 0] * nc - ca[:, 0] * nb) / d
    return a + np.column_stack([ux, uy])


def harmonic_transmissibility(k_a, k_b, g_a, g_b):
    """Harmonic (series) face transmissibility ``T = t_a t_b / (t_a + t_b)``, ``t = k g``.

    Parameters
    ----------
    k_a, k_b : array_like
        Permeabilities of the two cells [m^2].
    g_a, g_b : array_like
        Geometric half factors ``L h / d`` [m] (``inf`` for a resistance-free side).

    Returns
    -------
    ndarray
        ``T`` [m^3]; 0 where either side is impermeable.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = np.asarray(k_a, dtype=float) * np.asarray(g_a, dtype=float)
        tb = np.asarray(k_b, dtype=float) * np.asarray(g_b, dtype=float)
        # 1/(1/ta + 1/tb) written to handle ta or tb = 0 (-> 0) and = inf (-> the other)
        out = 1.0 / (1.0 / ta + 1.0 / tb)
    return np.where((ta == 0) | (tb == 0), 0.0, out)


def arithmetic_transmissibility(k_a, k_b, g_a, g_b):
    """Arithmetic-mean transmissibility ``T = (k_a + k_b)/2 * L h / (d_a + d_b)`` [m^3].

    ``g = L h / d``, so ``L h / (d_a + d_b) = 1 / (1/g_a + 1/g_b)``. For comparison only:
    it lets a high-permeability cell leak into a tight neighbour far too easily.
    """
    ga = np.asarray(g_a, dtype=float)
    gb = np.asarray(g_b, dtype=float)
    return 0.5 * (np.asarray(k_a, dtype=float) + np.asarray(k_b, dtype=float)) / (
        1.0 / ga + 1.0 / gb)


def _circumcentre_distances(mesh: Mesh, edges, owners, centres, d_centroid) -> np.ndarray:
    """Circumcentre-to-edge distances, made safe for TPFA.

    Interior edge: the sum ``s = d_a + d_b`` (the circumcentre spacing, exact for the
    Voronoi dual) is kept; each side is clipped into ``[0.05 s, 0.95 s]`` so the harmonic
    weights stay finite (an obtuse triangle's circumcentre lies outside it). Where ``s`` is
    not positive (a non-Delaunay edge) the centroid distances are used. Boundary edge: at
    least half the centroid distance.
    """
    _, d = edge_geometry(mesh.nodes, edges, centres, owners, centroids=mesh.centroids)
    out = d.copy()
    inner = owners[:, 1] >= 0
    s = d[:, 0] + d[:, 1]
    good = inner & (s > 1e-3 * (d_centroid[:, 0] + d_centroid[:, 1]))
    da = np.clip(d[good, 0], 0.05 * s[good], 0.95 * s[good])
    out[good, 0] = da
    out[good, 1] = s[good] - da
    bad = inner & ~good
    out[bad] = d_centroid[bad]
    bnd = ~inner
    out[bnd, 0] = np.maximum(d[bnd, 0], 0.5 * d_centroid[bnd, 0])
    return out


# --------------------------------------------------------------------------- model
@dataclass(frozen=True, eq=False)
class _Connections:
    """Two-point connections between unknowns (``b`` may be the well index ``m``)."""

    a: np.ndarray
    b: np.ndarray
    g_a: np.ndarray
    g_b: np.ndarray          # inf on the well side
    is_well: np.ndarray      # bool
    d_cell: np.ndarray       # Dirichlet edges: owner cell
    d_g: np.ndarray          # its geometric factor
    d_p: np.ndarray          # boundary pressure [Pa]
    d_tag: np.ndarray        # boundary tag


class FlowModel:
    """Single-phase slightly compressible flow on a triangle mesh with a borehole unknown.

    Parameters
    ----------
    mesh : Mesh
        Triangles are the control volumes; the hole-wall edges connect to the well.
    fluid : FluidProperties
    rock : RockFlowProperties
        Scalars or per-cell arrays, shape (m,).
    well : WellCondition, optional
        Rate (default 0) or pressure control and storage ``C_w`` (default: the hole
        segment's volume ``pi r_w^2 h`` times ``c_f``).
    outer : OuterBoundary, optional
        Default no-flow.
    height : float
        Segment height ``h`` [m] (cell volume ``A h``); 1 gives per-unit-height results.
    averaging : {"harmonic", "arithmetic"}
        Face permeability averaging; harmonic is the physical default.
    cell_centres : {"circumcentre", "centroid"}
        Pressure point of each triangle for the two-point distances (see module notes).

    Attributes
    ----------
    n_cells : int
    volumes : ndarray, shape (m,)
        Bulk cell volumes ``A h`` [m^3].
    well_storage : float
        ``C_w`` [m^3/Pa].
    has_well : bool
        False when the mesh has no hole (the well row then just keeps ``p_w``).
    centres : ndarray, shape (m, 2)
        The cells' pressure points [m] (circumcentres or centroids); compare cell pressures
        with analytic fields at these points.
    """

    def __init__(self, mesh: Mesh, fluid: FluidProperties, rock: RockFlowProperties,
                 well: WellCondition | None = None, outer: OuterBoundary | None = None,
                 height: float = 10.0,
                 averaging: Literal["harmonic", "arithmetic"] = "harmonic",
                 cell_centres: Literal["circumcentre", "centroid"] = "circumcentre") -> None:
        if not isinstance(mesh, Mesh):
            raise InputError("must be a xlotkit.sim.mesh.Mesh", key="mesh")
        if cell_centres not in ("circumcentre", "centroid"):
            raise InputError(f"unknown cell centre {cell_centres!r}", key="flow.cell_centres",
                             expected="'circumcentre' or 'centroid'")
        if averaging not in ("harmonic", "arithmetic"):
            raise InputError(f"unknown averaging {averaging!r}", key="flow.averaging",
                             expected="'harmonic' or 'arithmetic'")
        try:
            height = float(height)
        except (TypeError, ValueError):
            raise InputError("must be a number", key="flow.height") from None
        if not (np.isfinite(height) and height > 0):
            raise InputError("must be > 0", key="flow.height", expected="> 0 m")
        self.mesh = mesh
        self.fluid = fluid
        self.rock = rock
        self.well = well if well is not None else WellCondition()
        self.outer = outer if outer is not None else OuterBoundary()
        self.height = height
        self.averaging = averaging
        m = mesh.n_triangles
        self.n_cells = m
        self.permeability, self.porosity = rock.for_cells(m)
        self.volumes = _ro(mesh.areas * height)

        edges, owners = mesh.edges()
        self.centres = _ro(mesh.centroids if cell_centres == "centroid"
                           else circumcentres(mesh.nodes, mesh.triangles))
        length, dist = edge_geometry(mesh.nodes, edges, mesh.centroids, owners)
        if np.any(dist[owners >= 0] <= 0):
            raise InputError("degenerate cell: centroid on an edge", key="mesh")
        if cell_centres == "circumcentre":
            dist = _circumcentre_distances(mesh, edges, owners, self.centres, dist)
        g = length[:, None] * height / dist  # inf where no owner
        interior = owners[:, 1] >= 0
        # tag the boundary edges
        nn = np.int64(mesh.n_nodes)
        bkey = np.sort(mesh.boundary_edges, axis=1)
        bkey = bkey[:, 0] * nn + bkey[:, 1]
        ekey = edges[:, 0] * nn + edges[:, 1]
        order = np.argsort(bkey)
        tag = np.full(len(edges), -1, dtype=np.int64)
        bnd = np.flatnonzero(~interior)
        pos = np.searchsorted(bkey[order], ekey[bnd])
        if np.any(pos >= len(bkey)) or np.any(bkey[order][np.minimum(pos, len(bkey) - 1)]
                                              != ekey[bnd]):
            raise InputError("mesh boundary edges do not match its triangles", key="mesh")
        tag[bnd] = mesh.boundary_tags[order][pos]
        hole = bnd[tag[bnd] == HOLE]
        self.has_well = len(hole) > 0
        fixed = self.outer.fixed
        dmask = np.isin(tag, np.array(list(fixed.keys()), dtype=np.int64)) & ~interior
        dirichlet = np.flatnonzero(dmask)
        d_p = np.array([fixed[int(t)] for t in tag[dirichlet]], dtype=float)
        d_p.setflags(write=False)
        # (density_of: the densities of the last read-only pressure arrays asked)
        self._density_memo: list = []
        ia = owners[interior, 0]
        ib = owners[interior, 1]
        self._conn = _Connections(
            a=np.concatenate([ia, owners[hole, 0]]),
            b=np.concatenate([ib, np.full(len(hole), m, dtype=np.int64)]),
            g_a=np.concatenate([g[interior, 0], g[hole, 0]]),
            g_b=np.concatenate([g[interior, 1], np.full(len(hole), np.inf)]),
            is_well=np.concatenate([np.zeros(len(ia), bool), np.ones(len(hole), bool)]),
            d_cell=owners[dirichlet, 0], d_g=g[dirichlet, 0], d_p=d_p, d_tag=tag[dirichlet],
        )
        self.n_interior_faces = int(interior.sum())
        self._well_t0 = self.permeability[owners[hole, 0]] * g[hole, 0]
        self.n_well_faces = len(hole)
        self.n_fixed_faces = len(dirichlet)
        self._setup_triplets()

        if self.well.storage is not None:
            self.well_storage = float(self.well.storage)
        else:
            self.well_storage = self.hole_area * height * fluid.compressibility
        if (not self.has_well) and (self.well.pressure_controlled
                                    or callable(self.well.rate) or self.well.rate != 0.0):
            raise InputError("the mesh has no hole: no well rate or pressure possible",
                             key="well")
        if (self.has_well and not self.well.pressure_controlled and self.well_storage == 0.0
                and not np.any(self.permeability[owners[hole, 0]] > 0)):
            raise InputError("a rate-driven well with zero storage needs a permeable wall",
                             key="well.storage", expected="> 0")

    # ---------------------------------------------------------------- geometry helpers
    @property
    def hole_area(self) -> float:
        """Cross-section of the hole [m^2]: ``pi r_w^2`` (polygon area if no radius)."""
        if self.mesh.hole_radius is not None:
            return float(np.pi * self.mesh.hole_radius ** 2)
        e = self.mesh.hole_edges
        if len(e) == 0:
            return 0.0
        a = self.mesh.nodes[e[:, 0]]
        b = self.mesh.nodes[e[:, 1]]
        return abs(0.5 * float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])))

    @property
    def n_unknowns(self) -> int:
        """``m + 1`` (cell pressures and the well pressure)."""
        return self.n_cells + 1

    def _setup_triplets(self) -> None:
        """The fixed (row, col) order of the Jacobian's entries and of ``dR/dk``'s, and the
        CSR structure they are summed into (built once: the connections never change)."""
        m = self.n_cells
        c = self._conn
        a, b, da = c.a, c.b, c.d_cell
        cells = np.arange(m, dtype=np.int64)
        wm = np.array([m], dtype=np.int64)
        # storage diagonal, well storage, the four entries of every connection, the
        # fixed-pressure edges and the well row's own entry (rate derivative or the
        # pressure equation); see residual_and_jacobian for the values
        rows = np.concatenate([cells, wm, a, a, b, b, da, wm])
        cols = np.concatenate([cells, wm, a, b, a, b, da, wm])
        self._trip = (rows, cols)
        # entries of the well row other than its last one: zero when the well row is a
        # pressure equation (or there is no well)
        self._well_row_entries = np.flatnonzero(rows[:-1] == m)
        n = m + 1
        key = rows * np.int64(n) + cols
        uniq, slot = np.unique(key, return_inverse=True)
        self._jac_slot = slot.astype(np.int64)
        self._jac_indices = (uniq % n).astype(np.int32)
        self._jac_indptr = np.concatenate(
            [[0], np.cumsum(np.bincount(uniq // n, minlength=n))]).astype(np.int32)
        ni = self.n_interior_faces
        bk = np.where(c.is_well, 0, b)
        self._perm_trip = (np.concatenate([a, b, a[:ni], b[:ni], da]),
                           np.concatenate([a, a, bk[:ni], bk[:ni], da]))

    @property
    def jacobian_triplets(self) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, cols)`` of the Jacobian's entries in the order of
        :attr:`FlowResidual.jacobian_values` (fixed for the model; duplicates summed)."""
        return self._trip

    @property
    def permeability_triplets(self) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, cols)`` of the entries of ``dR/dk`` (rows: unknowns, cols: cells) in
        the order of :meth:`permeability_derivative_values` (fixed for the model)."""
        return self._perm_trip

    def initial_state(self, p0, p_w: float | None = None, t: float = 0.0,
                      extra_pore_volume=None) -> FlowState:
        """State with uniform (or given, shape (m,)) pressure ``p0`` [Pa]; ``p_w`` defaults
        to the mean of ``p0`` (or the prescribed well pressure at ``t``)."""
        p = np.broadcast_to(np.asarray(p0, dtype=float), (self.n_cells,)).copy()
        if p_w is None:
            p_w = (self.well.pressure_at(t) if self.well.pressure_controlled
                   else float(np.mean(p)))
        vx = (np.zeros(self.n_cells) if extra_pore_volume is None
              else np.broadcast_to(np.asarray(extra_pore_volume, float), (self.n_cells,)))
        return FlowState(t, p, p_w, vx)

    def density_of(self, p: np.ndarray) -> np.ndarray:
        """``rho(p)`` [kg/m^3] of a pressure array; for a read-only array (a state's, the
        boundary pressures) remembered with the fluid it was computed for: the old
        state's densities are asked at every Newton iteration of a step."""
        memo = self._density_memo
        if isinstance(p, np.ndarray) and not p.flags.writeable:
            for q, fluid, rho in memo:
                if q is p and fluid is self.fluid:
                    return rho
            rho = np.asarray(self.fluid.rho(p))
            rho.setflags(write=False)
            memo.insert(0, (p, self.fluid, rho))
            del memo[3:]
            return rho
        return self.fluid.rho(p)

    def transmissibilities(self, permeability=None) -> tuple[np.ndarray, np.ndarray]:
        """Face transmissibilities [m^3] for a permeability field (default: the rock's).

        Returns
        -------
        T : ndarray, shape (n_interior + n_well_faces,)
            Interior edges first, then the hole-wall edges (cell <-> well).
        T_fixed : ndarray, shape (n_fixed_faces,)
            Fixed-pressure outer edges.
        """
        k = self.permeability if permeability is None else np.asarray(permeability, float)
        if k.shape != (self.n_cells,):
            raise InputError(f"needs shape ({self.n_cells},)", key="permeability")
        c = self._conn
        ni = self.n_interior_faces  # interior connections come first
        avg = (harmonic_transmissibility if self.averaging == "harmonic"
               else arithmetic_transmissibility)
        t = np.empty(len(c.a))
        t[:ni] = avg(k[c.a[:ni]], k[c.b[:ni]], c.g_a[:ni], c.g_b[:ni])
        t[ni:] = k[c.a[ni:]] * c.g_a[ni:]  # no resistance on the well side
        return t, k[c.d_cell] * c.d_g

    def fixed_edge_rates(self, state: FlowState, permeability=None
                         ) -> tuple[np.ndarray, np.ndarray]:
        """Mass rates *into* the domain through the fixed-pressure outer edges.

        Returns
        -------
        tags : ndarray of int, shape (n_fixed_faces,)
            Boundary tag of each edge.
        rates : ndarray, shape (n_fixed_faces,)
            Upwinded two-point mass rate [kg/s], positive into the domain.
        """
        c = self._conn
        _, Td = self.transmissibilities(permeability)
        p = state.p[c.d_cell]
        rho_up = np.where(c.d_p > p, self.fluid.rho(c.d_p), self.fluid.rho(p))
        return c.d_tag.copy(), rho_up / self.fluid.viscosity * Td * (c.d_p - p)

    def transmissibility_derivatives(self, permeability=None
                                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Derivatives of the transmissibilities with respect to the cell permeabilities.

        Returns
        -------
        dT_dka, dT_dkb : ndarray, shape (n_interior + n_well_faces,)
            ``dT/dk_a`` and ``dT/dk_b`` [m] of each connection (``dT/dk_b = 0`` for the
            well connections).
        dTfixed_dk : ndarray, shape (n_fixed_faces,)
            ``dT/dk`` of the fixed-pressure edges [m].
        """
        k = self.permeability if permeability is None else np.asarray(permeability, float)
        c = self._conn
        ni = self.n_interior_faces
        ga, gb = c.g_a[:ni], c.g_b[:ni]
        dka = np.empty(len(c.a))
        dkb = np.zeros(len(c.a))
        if self.averaging == "harmonic":
            ta, tb = k[c.a[:ni]] * ga, k[c.b[:ni]] * gb
            s = ta + tb
            with np.errstate(divide="ignore", invalid="ignore"):
                dka[:ni] = np.where(s > 0, ga * tb ** 2 / s ** 2, 0.0)
                dkb[:ni] = np.where(s > 0, gb * ta ** 2 / s ** 2, 0.0)
        else:
            dka[:ni] = dkb[:ni] = 0.5 / (1.0 / ga + 1.0 / gb)
        dka[ni:] = c.g_a[ni:]
        return dka, dkb, c.d_g.copy()

    def permeability_derivative_values(self, state: FlowState, permeability=None
                                       ) -> np.ndarray:
        """The entries of ``dR/dk`` [kg/(s m^2)] at ``state`` in the order of
        :attr:`permeability_triplets` (duplicates to be summed). The well row of a
        pressure-controlled well (or of a mesh without a hole) does not depend on ``k``:
        its entries are 0."""
        m = self.n_cells
        mu = self.fluid.viscosity
        c = self._conn
        x = state.x
        lam = self.fluid.rho(x) / mu
        a, b = c.a, c.b
        delta = x[b] - x[a]
        lam_up = np.where(delta < 0.0, lam[a], lam[b])
        dka, dkb, dkd = self.transmissibility_derivatives(permeability)
        g = lam_up * delta                      # dF/dT, F flows from b into a
        ni = self.n_interior_faces
        da = c.d_cell
        dd = c.d_p - state.p[da]
        lam_d = np.where(dd < 0.0, lam[da], self.fluid.rho(c.d_p) / mu)
        vals = np.concatenate([-g * dka, g * dka, -g[:ni] * dkb[:ni], g[:ni] * dkb[:ni],
                               -lam_d * dd * dkd])
        if self.well.pressure_controlled or not self.has_well:
            vals[self._perm_trip[0] == m] = 0.0
        return vals

    def d_residual_d_permeability(self, state: FlowState, permeability=None):
        """``dR/dk`` [kg/(s m^2)], sparse, shape (m + 1, m), at ``state``.

        For the monolithic hydro-mechanical Jacobian with aperture-dependent permeability:
        ``dR/du += dR/dk . dk/du`` (``dk/dw_h`` from
        :func:`~xlotkit.sim.flow.fracture.permeability_multiplier_derivative`). The well row
        of a pressure-controlled well does not depend on ``k``; its entries are dropped.
        """
        m = self.n_cells
        rows, cols = self._perm_trip
        vals = self.permeability_derivative_values(state, permeability)
        if self.well.pressure_controlled or not self.has_well:
            keep = rows != m
            rows, cols, vals = rows[keep], cols[keep], vals[keep]
        return sp.csr_matrix((vals, (rows, cols)), shape=(m + 1, m))

    # ---------------------------------------------------------------- storage kernels
    def cell_mass(self, state: FlowState) -> np.ndarray:
        """Fluid mass in each cell ``rho (phi V + V^x)`` [kg], shape (m,) (for reports;
        differences are computed without cancellation by :meth:`residual_and_jacobian`)."""
        f, r = self.fluid, self.rock
        rho = f.rho(state.p)
        phi = self.porosity * (1.0 + r.pore_compressibility * (state.p - r.reference_pressure))
        return rho * (phi * self.volumes + state.extra_pore_volume)

    # ---------------------------------------------------------------- residual
    def residual_and_jacobian(self, state: FlowState, state_old: FlowState, dt: float, *,
                              permeability=None, well_rate=None,
                              well_pressure: float | None = None,
                              well_storage: float | None = None,
                              jacobian: str = "csr") -> FlowResidual:
        """Backward-Euler residual ``R(p, p_w)`` and its analytic sparse Jacobian.

        Parameters
        ----------
        state : FlowState
            Current Newton iterate at ``t_{n+1}`` (its ``extra_pore_volume`` is the
            skeleton's pore volume at the iterate, set by the caller).
        state_old : FlowState
            Converged state at ``t_n``.
        dt : float
            Step ``t_{n+1} - t_n`` [s], > 0.
        permeability : ndarray, shape (m,), optional
            Cell permeability at the iterate (e.g. aperture-dependent); default the rock's.
        well_rate : float or (float, float), optional
            Override of ``Q`` [m^3/s], or ``(Q, dQ/dp_w)`` for a pressure-dependent rate
            (choke flowback). Default ``well.rate`` at ``t_n + dt/2``.
        well_pressure : float, optional
            Override of the prescribed well pressure (pressure-controlled wells).
        well_storage : float, optional
            Override of the well compliance ``C_w`` [m^3/Pa] (e.g. the segment's own plus
            the whole well's, set by the hydro-mechanical step).
        jacobian : {"csr", "values", "none"}
            ``"csr"``: the Jacobian as a CSR matrix (and its entries); ``"values"``: only
            its entries in the order of :attr:`jacobian_triplets`
            (``FlowResidual.jacobian_values``, ``jacobian`` None), for assembly into a
            larger matrix; ``"none"``: the residual alone (a line search's trial point).

        Returns
        -------
        FlowResidual
        """
        if jacobian not in ("csr", "values", "none"):
            raise InputError(f"unknown Jacobian form {jacobian!r}", key="jacobian",
                             expected="'csr', 'values' or 'none'")
        if not (dt > 0 and np.isfinite(dt)):
            raise InputError(f"time step must be > 0, got {dt!r}", key="dt")
        m = self.n_cells
        f, r = self.fluid, self.rock
        cf, mu = f.compressibility, f.viscosity
        p, po = state.p, state_old.p
        vx, vxo = state.extra_pore_volume, state_old.extra_pore_volume

        # -- accumulation (difference form, no cancellation)
        rho_o = self.density_of(po)
        dp = p - po
        drho = rho_o * cf * dp * expm1_over_x(cf * dp)
        rho = rho_o + drho
        phi_ref = self.porosity
        cr = r.pore_compressibility
        phi = phi_ref * (1.0 + cr * (p - r.reference_pressure))
        dphi = phi_ref * cr * dp
        V = self.volumes
        store = (V * (drho * phi + rho_o * dphi) + drho * vx + rho_o * (vx - vxo)) / dt
        dstore = (V * (cf * rho * phi + rho * phi_ref * cr) + cf * rho * vx) / dt

        pw, pwo = state.p_w, state_old.p_w
        Cw = self.well_storage if well_storage is None else float(well_storage)
        rho_wo = float(f.rho(pwo))
        dpw = pw - pwo
        e_w = float(expm1_over_x(cf * dpw))
        drho_w = rho_wo * cf * dpw * e_w
        vw, vwo = state.well_extra_volume, state_old.well_extra_volume
        # compliance storage plus the extra (hole-enlargement) volume, difference form
        store_w = (Cw * rho_wo * dpw * e_w + drho_w * vw + rho_wo * (vw - vwo)) / dt
        rho_w = float(f.rho(pw))
        dstore_w = (Cw * rho_w + cf * rho_w * vw) / dt

        # -- two-point fluxes between unknowns (interior + well connections)
        c = self._conn
        T, Td = self.transmissibilities(permeability)
        x = np.append(p, pw)
        rho_x = np.append(rho, rho_w)
        lam = rho_x / mu
        a, b = c.a, c.b
        F, dF_da, dF_db = face_fluxes(x, lam, cf, T, a, b)   # from b into a [kg/s]

        # -- fixed-pressure outer edges
        da = c.d_cell
        ddelta = c.d_p - p[da]
        lam_d = self.density_of(c.d_p) / mu
        dup_a = ddelta < 0.0
        dlam_up = np.where(dup_a, lam[da], lam_d)
        Fd = dlam_up * Td * ddelta   # into the cell
        dFd_da = Td * (np.where(dup_a, cf * lam[da], 0.0) * ddelta - dlam_up)

        n = m + 1
        R = np.zeros(n)
        R[:m] = store
        R[m] = store_w
        R -= np.bincount(a, weights=F, minlength=n)
        R += np.bincount(b, weights=F, minlength=n)
        R -= np.bincount(da, weights=Fd, minlength=n)
        formation_rate = float(np.sum(F[c.is_well]))
        boundary_rate = float(-np.sum(Fd))

        if not self.has_well:
            # isolated well unknown: keep p_w (no hole, nothing to inject into)
            s = 1.0
            R[m] = s * (pw - pwo)
            injection = 0.0
            last = s
            keep_well_row = False
        elif self.well.pressure_controlled or well_pressure is not None:
            p_set = (well_pressure if well_pressure is not None
                     else self.well.pressure_at(state.t))
            injection = store_w + formation_rate  # diagnosed from the well balance
            # row scale with the units of the other rows, independent of the iterate and
            # of a permeability override (so dR_w/dp_w = s exactly and dR_w/dk = 0)
            s = (float(np.sum(self._well_t0)) / mu + Cw / dt) * f.density
            s = s if s > 0 else 1.0
            R[m] = s * (pw - p_set)
            last = s
            keep_well_row = False
        else:
            if well_rate is None:
                q, dq = self.well.rate_at(state_old.t + 0.5 * dt), 0.0
            elif np.ndim(well_rate) == 0:
                q, dq = float(well_rate), 0.0
            else:
                q, dq = (float(v) for v in well_rate)
            injection = f.density * q
            R[m] -= injection
            last = -f.density * dq
            keep_well_row = True

        J = vals = None
        if jacobian != "none":
            # entries in the fixed order of jacobian_triplets
            vals = np.concatenate([dstore, [dstore_w], -dF_da, -dF_db, dF_da, dF_db,
                                   -dFd_da, [last]])
            if not keep_well_row:
                # the well row is the pressure equation (its last entry) only
                vals[self._well_row_entries] = 0.0
            if jacobian == "csr":
                data = np.bincount(self._jac_slot, weights=vals,
                                   minlength=len(self._jac_indices))
                J = sp.csr_matrix((data, self._jac_indices.copy(), self._jac_indptr.copy()),
                                  shape=(n, n))
        return FlowResidual(
            residual=R, jacobian=J, d_residual_d_extra_volume=rho / dt,
            jacobian_values=vals,
            injection_rate=float(injection), formation_rate=formation_rate,
            boundary_rate=boundary_rate, storage_rate_cells=store,
            storage_rate_well=float(store_w),
            d_residual_d_well_volume=(rho_w / dt if keep_well_row else 0.0),
            throughput=float(abs(injection) + np.sum(np.abs(F[c.is_well]))
                             + np.sum(np.abs(Fd)) + np.sum(np.abs(store)) + abs(store_w)),
        )
