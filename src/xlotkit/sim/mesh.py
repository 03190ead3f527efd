"""Triangle meshes for the 2D MDEM / flow model.

Geometry convention
-------------------
The built-in borehole geometry is a square ``[-size/2, size/2]^2`` (metres) with a circular
hole of radius ``radius`` centred at the origin. The hole is the borehole; its wall is the
*inner* boundary loop. Each triangle is one MDEM cluster and one flow control volume.

Boundary tags (``Mesh.boundary_tags``)
--------------------------------------
``HOLE`` (0) hole wall, ``LEFT`` (1) ``x = xmin``, ``RIGHT`` (2) ``x = xmax``, ``BOTTOM`` (3)
``y = ymin``, ``TOP`` (4) ``y = ymax``, ``OUTER`` (5) any other outer-boundary edge (meshes
read from files whose outline is not an axis-aligned rectangle).

Generator
---------
:func:`borehole_mesh` places nodes on closed "levels" that morph from the hole circle
(level 0) to the outer square (last level); the level spacing and the node spacing along each
level follow a size function ``h(x)`` that grows geometrically away from the hole (and from an
optional fracture band). Candidate nodes closer than ``0.8 h`` to already accepted nodes are
dropped, the point set is triangulated by :class:`scipy.spatial.Delaunay`, the triangles
inside the hole are removed and, when nodes were dropped, a few density-weighted centroidal
smoothing sweeps even the node spacing. Everything is deterministic for a given ``seed``
(the seed only drives the optional jitter).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from scipy.spatial import Delaunay, cKDTree

from xlotkit.errors import InputError

__all__ = [
    "BOTTOM",
    "HOLE",
    "LEFT",
    "OUTER",
    "RIGHT",
    "TOP",
    "FractureBand",
    "Mesh",
    "MeshQuality",
    "borehole_mesh",
    "mesh_from_triangles",
    "mesh_quality",
    "read_mesh",
    "rectangle_mesh",
    "refine_uniform",
    "write_mesh",
]

HOLE, LEFT, RIGHT, BOTTOM, TOP, OUTER = 0, 1, 2, 3, 4, 5
TAG_NAMES = {HOLE: "hole", LEFT: "left", RIGHT: "right", BOTTOM: "bottom", TOP: "top",
             OUTER: "outer"}

#: node markers
NODE_INTERIOR, NODE_HOLE, NODE_OUTER = 0, 1, 2
#: triangle markers set by the generator
TRI_DEFAULT, TRI_BAND = 0, 1


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Mesh:
    """An immutable 2D triangle mesh.

    Attributes
    ----------
    nodes : ndarray, shape (n, 2)
        Node coordinates [m].
    triangles : ndarray of int, shape (m, 3)
        Node indices of each triangle, counter-clockwise.
    boundary_edges : ndarray of int, shape (k, 2)
        Boundary edges, oriented so that the domain lies on their left.
    boundary_tags : ndarray of int, shape (k,)
        Tag of each boundary edge (``HOLE``, ``LEFT``, ...).
    node_markers : ndarray of int, shape (n,)
        0 interior, 1 on the hole wall, 2 on the outer boundary.
    triangle_markers : ndarray of int, shape (m,)
        User/generator markers (the generator sets 1 inside the fracture band).
    hole_center : ndarray, shape (2,), optional
        Centre of the hole [m] (least-squares circle through the wall nodes when read).
    hole_radius : float, optional
        Radius of the hole [m].

    Notes
    -----
    All arrays are read-only; use :meth:`replace` (``dataclasses.replace``) to get a changed
    copy. Construct meshes from raw arrays with :func:`mesh_from_triangles`, which orients the
    triangles and finds and tags the boundary.
    """

    nodes: np.ndarray
    triangles: np.ndarray
    boundary_edges: np.ndarray
    boundary_tags: np.ndarray
    node_markers: np.ndarray
    triangle_markers: np.ndarray
    hole_center: np.ndarray | None = None
    hole_radius: float | None = None

    def __post_init__(self) -> None:
        nodes = np.asarray(self.nodes, dtype=float)
        tris = np.asarray(self.triangles, dtype=np.int64)
        if nodes.ndim != 2 or nodes.shape[1] != 2:
            raise InputError("nodes must have shape (n, 2)", key="nodes")
        if tris.ndim != 2 or tris.shape[1] != 3:
            raise InputError("triangles must have shape (m, 3)", key="triangles")
        if tris.size and (tris.min() < 0 or tris.max() >= len(nodes)):
            raise InputError("triangle node index out of range", key="triangles")
        object.__setattr__(self, "nodes", _frozen(nodes))
        object.__setattr__(self, "triangles", _frozen(tris))
        object.__setattr__(self, "boundary_edges",
                           _frozen(np.asarray(self.boundary_edges, dtype=np.int64).reshape(-1, 2)))
        object.__setattr__(self, "boundary_tags",
                           _frozen(np.asarray(self.boundary_tags, dtype=np.int64).reshape(-1)))
        object.__setattr__(self, "node_markers",
                           _frozen(np.asarray(self.node_markers, dtype=np.int64).reshape(-1)))
        object.__setattr__(self, "triangle_markers",
                           _frozen(np.asarray(self.triangle_markers, dtype=np.int64).reshape(-1)))
        if self.hole_center is not None:
            object.__setattr__(self, "hole_center",
                               _frozen(np.asarray(self.hole_center, dtype=float).reshape(2)))
        if len(self.boundary_tags) != len(self.boundary_edges):
            raise InputError("one tag per boundary edge expected", key="boundary_tags")
        if len(self.node_markers) != len(self.nodes):
            raise InputError("one marker per node expected", key="node_markers")
        if len(self.triangle_markers) != len(self.triangles):
            raise InputError("one marker per triangle expected", key="triangle_markers")
        if np.any(self.areas <= 0.0):
            raise InputError("triangles must be counter-clockwise with positive area",
                             key="triangles")

    # -- derived geometry -------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
        return int(self.nodes.shape[0])

    @property
    def n_triangles(self) -> int:
        """Number of triangles (= MDEM clusters = flow cells)."""
        return int(self.triangles.shape[0])

    @property
    def areas(self) -> np.ndarray:
        """Signed triangle areas [m^2], shape (m,); positive for CCW triangles."""
        p = self.nodes[self.triangles]
        d1 = p[:, 1] - p[:, 0]
        d2 = p[:, 2] - p[:, 0]
        return 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])

    @functools.cached_property
    def centroids(self) -> np.ndarray:
        """Triangle centroids [m], shape (m, 2) (read-only; computed once: the crack-front
        searches ask for them after every converged step)."""
        return _frozen(self.nodes[self.triangles].mean(axis=1))

    @property
    def hole_edges(self) -> np.ndarray:
        """Hole-wall edges (node pairs, domain on the left), shape (h, 2)."""
        return self.boundary_edges[self.boundary_tags == HOLE]

    @property
    def hole_nodes(self) -> np.ndarray:
        """Indices of the nodes on the hole wall, sorted by angle about the hole centre."""
        idx = np.unique(self.hole_edges)
        if idx.size == 0:
            return idx
        c = self.hole_center if self.hole_center is not None else self.nodes[idx].mean(axis=0)
        ang = np.arctan2(self.nodes[idx, 1] - c[1], self.nodes[idx, 0] - c[0])
        return idx[np.argsort(ang)]

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Unique edges and the triangles on each side.

        Returns
        -------
        edges : ndarray of int, shape (e, 2)
            Node pairs with ``edges[:, 0] < edges[:, 1]``.
        owners : ndarray of int, shape (e, 2)
            The two triangles sharing each edge; ``-1`` in column 1 on the boundary.
        """
        return _edges_and_owners(self.triangles)

    def replace(self, **changes: Any) -> "Mesh":
        """Return a copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def with_triangle_markers(self, markers: np.ndarray) -> "Mesh":
        """Return a copy with new triangle markers, shape (m,)."""
        return self.replace(triangle_markers=np.asarray(markers, dtype=np.int64))


@dataclass(frozen=True)
class FractureBand:
    """A band of finer triangles along an expected fracture direction.

    The band is centred on the line through the hole centre at ``azimuth`` (radians,
    counter-clockwise from +x) and covers both wings out to ``length`` from the centre.

    Parameters
    ----------
    azimuth : float
        Direction of the band [rad].
    width : float
        Full width of the band [m].
    h : float
        Target edge length inside the band [m].
    length : float
        Half-length of the band measured from the hole centre [m].
    strip : bool
        Lay a *crack strip* along the band axis: two rows of nodes at ``+-sqrt(3)/4 h``
        either side of the axis, staggered by half a spacing, from the hole wall (whose
        nodes are then placed so that the axis meets the wall in the middle of an edge)
        to ``length``; the spacing ``h`` follows the generator's size (graded from the
        wall edge length up to the band's ``h``). Every strip triangle straddles the axis,
        so a crack along it runs through a chain of triangles and never through a node.
        Only the strip triangles get the band marker (the band still sets the
        refinement).
    centred_wall : bool
        Place the hole wall's nodes so that the axis meets the wall in the middle of an
        edge (an even number of equal wall edges), as the strip does: the wall cluster on
        the axis then straddles it instead of two clusters meeting at a node there.
    """

    azimuth: float
    width: float
    h: float
    length: float
    strip: bool = False
    centred_wall: bool = False

    def __post_init__(self) -> None:
        for key in ("width", "h", "length"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"must be a positive number, got {v!r}",
                                 key=f"fracture_band.{key}", expected="> 0")
        if not np.isfinite(self.azimuth):
            raise InputError("must be finite", key="fracture_band.azimuth")


@dataclass(frozen=True)
class MeshQuality:
    """Quality figures of a triangle mesh.

    Attributes
    ----------
    min_angle_deg, max_angle_deg : float
        Smallest and largest interior angle over all triangles [deg].
    mean_min_angle_deg : float
        Mean over triangles of each triangle's smallest angle [deg].
    max_neighbour_size_ratio : float
        Largest ratio of sqrt(area) between two triangles sharing an edge (grading).
    min_area, max_area : float
        Triangle areas [m^2].
    n_nodes, n_triangles : int
    """

    min_angle_deg: float
    max_angle_deg: float
    mean_min_angle_deg: float
    max_neighbour_size_ratio: float
    min_area: float
    max_area: float
    n_nodes: int
    n_triangles: int


# ---------------------------------------------------------------------------------------
# topology helpers
# ---------------------------------------------------------------------------------------
def _edges_and_owners(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    m = len(tris)
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    owner = np.concatenate([np.arange(m)] * 3)
    key = np.sort(e, axis=1)
    uniq, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    if np.any(counts > 2):
        raise InputError("non-manifold mesh: an edge is shared by more than two triangles",
                         key="triangles")
    order = np.argsort(inv, kind="stable")
    owners = np.full((len(uniq), 2), -1, dtype=np.int64)
    first = np.ones(len(order), dtype=bool)
    sorted_inv = inv[order]
    first[1:] = sorted_inv[1:] != sorted_inv[:-1]
    owners[sorted_inv[first], 0] = owner[order[first]]
    owners[sorted_inv[~first], 1] = owner[order[~first]]
    return uniq.astype(np.int64), owners


def _boundary_edges(tris: np.ndarray) -> np.ndarray:
    """Boundary edges oriented with the domain on the left (as they appear in CCW tris)."""
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[counts[inv.reshape(-1)] == 1]


def _loops(bedges: np.ndarray) -> list[np.ndarray]:
    """Split oriented boundary edges into closed loops (lists of edge indices)."""
    nxt = {int(a): i for i, (a, _) in enumerate(bedges)}
    if len(nxt) != len(bedges):
        raise InputError("boundary is not a set of simple loops (pinched node)",
                         key="triangles")
    seen = np.zeros(len(bedges), dtype=bool)
    loops = []
    for start in range(len(bedges)):
        if seen[start]:
            continue
        loop = []
        i = start
        while not seen[i]:
            seen[i] = True
            loop.append(i)
            i = nxt.get(int(bedges[i, 1]), -1)
            if i < 0:
                raise InputError("open boundary loop", key="triangles")
        loops.append(np.array(loop, dtype=np.int64))
    return loops


def _loop_area(nodes: np.ndarray, bedges: np.ndarray) -> float:
    a = nodes[bedges[:, 0]]
    b = nodes[bedges[:, 1]]
    return 0.5 * float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))


def _fit_circle(pts: np.ndarray) -> tuple[np.ndarray, float]:
    # algebraic (Kasa) least-squares circle: x^2 + y^2 + D x + E y + F = 0
    A = np.column_stack([pts[:, 0], pts[:, 1], np.ones(len(pts))])
    rhs = -(pts[:, 0] ** 2 + pts[:, 1] ** 2)
    (D, E, F), *_ = np.linalg.lstsq(A, rhs, rcond=None)
    c = np.array([-D / 2, -E / 2])
    r = math.sqrt(max(c @ c - F, 0.0))
    return c, r


def mesh_from_triangles(
    nodes: np.ndarray,
    triangles: np.ndarray,
    triangle_markers: np.ndarray | None = None,
    hole_center: np.ndarray | None = None,
    hole_radius: float | None = None,
) -> Mesh:
    """Build a :class:`Mesh` from raw arrays: orient, find and tag the boundary.

    Parameters
    ----------
    nodes : array_like, shape (n, 2) or (n, 3)
        Node coordinates [m]; a third column (z) is dropped.
    triangles : array_like of int, shape (m, 3)
    triangle_markers : array_like of int, shape (m,), optional
    hole_center, hole_radius : optional
        Hole geometry; fitted to the hole-wall nodes when not given.

    Notes
    -----
    The outer loop is the boundary loop enclosing the largest area; the hole wall is the
    inner loop with the largest enclosed area (other inner loops are tagged ``OUTER``).
    Unused nodes are removed. Outer edges are tagged ``LEFT``/``RIGHT``/``BOTTOM``/``TOP``
    when both end nodes lie on the corresponding side of the bounding box (relative
    tolerance 1e-9 of its size), ``OUTER`` otherwise.
    """
    nodes = np.asarray(nodes, dtype=float)
    if nodes.ndim != 2 or nodes.shape[1] not in (2, 3):
        raise InputError("nodes must have shape (n, 2) or (n, 3)", key="nodes")
    nodes = nodes[:, :2]
    tris = np.asarray(triangles, dtype=np.int64)
    if tris.ndim != 2 or tris.shape[1] != 3 or len(tris) == 0:
        raise InputError("need at least one triangle with 3 nodes", key="triangles")
    if tris.min() < 0 or tris.max() >= len(nodes):
        raise InputError("triangle node index out of range", key="triangles")
    # drop unused nodes
    used = np.unique(tris)
    if len(used) != len(nodes):
        remap = -np.ones(len(nodes), dtype=np.int64)
        remap[used] = np.arange(len(used))
        nodes = nodes[used]
        tris = remap[tris]
    # orient counter-clockwise
    p = nodes[tris]
    cross = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
             - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    if np.any(cross == 0.0):
        raise InputError("degenerate (zero-area) triangle", key="triangles")
    tris = tris.copy()
    flip = cross < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]

    bedges = _boundary_edges(tris)
    loops = _loops(bedges)
    areas = np.array([_loop_area(nodes, bedges[lp]) for lp in loops])
    outer = int(np.argmax(areas))
    tags = np.full(len(bedges), OUTER, dtype=np.int64)
    inner = [i for i in range(len(loops)) if i != outer]
    hole_loop = None
    if inner:
        hole_loop = max(inner, key=lambda i: -areas[i])  # inner loops have negative area
        tags[loops[hole_loop]] = HOLE
    # tag outer sides
    lo = nodes.min(axis=0)
    hi = nodes.max(axis=0)
    tol = 1e-9 * float(np.max(hi - lo))
    oe = loops[outer]
    a = nodes[bedges[oe, 0]]
    b = nodes[bedges[oe, 1]]
    for tag, axis, val in ((LEFT, 0, lo[0]), (RIGHT, 0, hi[0]), (BOTTOM, 1, lo[1]),
                           (TOP, 1, hi[1])):
        on = (np.abs(a[:, axis] - val) <= tol) & (np.abs(b[:, axis] - val) <= tol)
        tags[oe[on]] = tag
    node_markers = np.zeros(len(nodes), dtype=np.int64)
    node_markers[bedges[tags != HOLE].ravel()] = NODE_OUTER
    node_markers[bedges[tags == HOLE].ravel()] = NODE_HOLE
    if hole_loop is not None and (hole_center is None or hole_radius is None):
        c, r = _fit_circle(nodes[bedges[loops[hole_loop], 0]])
        hole_center = c if hole_center is None else hole_center
        hole_radius = r if hole_radius is None else hole_radius
    if triangle_markers is None:
        triangle_markers = np.zeros(len(tris), dtype=np.int64)
    return Mesh(nodes=nodes, triangles=tris, boundary_edges=bedges, boundary_tags=tags,
                node_markers=node_markers, triangle_markers=triangle_markers,
                hole_center=hole_center,
                hole_radius=None if hole_radius is None else float(hole_radius))


# ---------------------------------------------------------------------------------------
# generator
# ---------------------------------------------------------------------------------------
def _check_pos(name: str, v: float) -> float:
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise InputError(f"must be a number, got {v!r}", key=name) from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"must be a positive number, got {v!r}", key=name, expected="> 0")
    return v


def _size_function(radius: float, h_wall: float, growth: float, h_max: float,
                   band: FractureBand | None):
    """Target edge length h(x) [m] of the generator (vectorised over points (k, 2))."""
    g = growth - 1.0

    def h(p: np.ndarray) -> np.ndarray:
        r = np.hypot(p[:, 0], p[:, 1])
        out = h_wall + g * np.maximum(r - radius, 0.0)
        if band is not None:
            d = np.array([math.cos(band.azimuth), math.sin(band.azimuth)])
            along = np.abs(p @ d)
            across = np.abs(p[:, 0] * d[1] - p[:, 1] * d[0])
            dist = np.hypot(np.maximum(across - 0.5 * band.width, 0.0),
                            np.maximum(along - band.length, 0.0))
            out = np.minimum(out, band.h + g * dist)
        return np.minimum(out, h_max)

    return h


def _level_curve(rho: float, radius: float, half: float, theta: np.ndarray) -> np.ndarray:
    """Points of the level of 'radius' rho: circle morphing into the outer square."""
    w = ((rho - radius) / (half - radius)) ** 2
    c, s = np.cos(theta), np.sin(theta)
    sq = 1.0 / np.maximum(np.abs(c), np.abs(s))
    f = rho * ((1.0 - w) + w * sq)
    return np.column_stack([f * c, f * s])


def _place_on_curve(curve: np.ndarray, h, closed: bool, offset: float) -> np.ndarray:
    """Nodes along a densely sampled polyline with local spacing ~h (1/h arc integral)."""
    pts = np.vstack([curve, curve[:1]]) if closed else curve
    seg = np.hypot(*np.diff(pts, axis=0).T)
    mid = 0.5 * (pts[1:] + pts[:-1])
    dens = seg / h(mid)
    cum = np.concatenate([[0.0], np.cumsum(dens)])
    total = cum[-1]
    if closed:
        n = max(6, int(round(total)))
        targets = (np.arange(n) + offset) * total / n
    else:
        n = max(1, int(round(total)))
        targets = np.linspace(0.0, total, n + 1)
    x = np.interp(targets, cum, pts[:, 0])
    y = np.interp(targets, cum, pts[:, 1])
    return np.column_stack([x, y])


def _add_crack_strip(pts: np.ndarray, fixed: np.ndarray, n_wall: int, radius: float,
                     half: float, band: FractureBand, h):
    """Replace the generated nodes along the band axis by a crack strip (see
    :class:`FractureBand`); returns the new nodes, their fixed flags and the strip mask."""
    d = np.array([math.cos(band.azimuth), math.sin(band.azimuth)])
    nrm = np.array([-d[1], d[0]])
    c = math.sqrt(3.0) / 4.0
    wall = pts[:n_wall]
    mouth_along = radius * math.cos(math.pi / n_wall)
    end = min(band.length, 0.95 * half)
    rows = []
    for wing in (1.0, -1.0):
        # the two wall nodes of the mouth edge start the strip; then nodes alternate
        # between the rows, half a local spacing apart along the axis
        def size(s: float) -> float:
            return float(h((wing * s * d)[None, :])[0])

        s_pos = mouth_along
        side = 1.0
        while True:
            s_pos += 0.5 * size(s_pos + 0.25 * size(s_pos))
            if s_pos > end:
                break
            rows.append(wing * s_pos * d + side * c * size(s_pos) * nrm)
            side = -side
    new = np.array(rows)
    # generated nodes within about one local size of the strip give way (not the wall or
    # the outer boundary)
    along = pts @ d
    across = pts @ nrm
    hp = h(pts)
    clear = ((np.abs(across) < c * hp + 0.6 * hp) & (np.abs(along) > mouth_along)
             & (np.abs(along) <= end + 0.6 * hp) & ~fixed)
    keep = ~clear
    mouth = np.zeros(len(pts), dtype=bool)
    w_al = wall @ d
    w_ac = wall @ nrm
    mouth[:n_wall] = np.abs(np.abs(w_al) - mouth_along) < 1e-9 * radius
    mouth[:n_wall] &= np.abs(w_ac) < radius * math.sin(1.5 * math.pi / n_wall)
    pts = np.vstack([pts[keep], new])
    fixed = np.concatenate([fixed[keep], np.ones(len(new), dtype=bool)])
    strip = np.concatenate([mouth[keep], np.ones(len(new), dtype=bool)])
    return pts, fixed, strip


def _outer_square(half: float, h) -> np.ndarray:
    corners = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    out = []
    for i in range(4):
        a, b = corners[i], corners[(i + 1) % 4]
        t = np.linspace(0.0, 1.0, 2001)[:, None]
        line = a + t * (b - a)
        p = _place_on_curve(line, h, closed=False, offset=0.0)
        out.append(p[:-1])
    return np.vstack(out)


def borehole_mesh(
    size: float = 100.0,
    radius: float = 0.15,
    growth: float = 1.2,
    h_wall: float | None = None,
    h_max: float | None = None,
    fracture_band: FractureBand | None = None,
    jitter: float = 0.0,
    seed: int = 0,
) -> Mesh:
    """Graded triangle mesh of a square domain with a borehole at its centre.

    Parameters
    ----------
    size : float
        Side of the square domain [m] (domain ``[-size/2, size/2]^2``).
    radius : float
        Borehole radius [m].
    growth : float
        Geometric growth rate of the element size away from the hole: the target edge length
        is ``h(r) = h_wall + (growth - 1)(r - radius)``, i.e. successive rings grow by the
        factor ``growth``. Must be in (1, 2].
    h_wall : float, optional
        Edge length on the hole wall [m]; default ``2 pi radius / 64`` (64 wall segments).
    h_max : float, optional
        Cap on the edge length [m]; default ``size / 10``.
    fracture_band : FractureBand, optional
        Finer band along an expected fracture direction; its triangles get marker 1.
    jitter : float
        Random displacement of interior nodes as a fraction of the local size (0 to 0.3).
    seed : int
        Seed of the jitter (the mesh is deterministic for a given seed).

    Returns
    -------
    Mesh
        With ``hole_center = (0, 0)`` and ``hole_radius = radius``; hole-wall nodes lie
        exactly on the circle.
    """
    size = _check_pos("size", size)
    radius = _check_pos("radius", radius)
    growth = _check_pos("growth", growth)
    if not (1.0 < growth <= 2.0):
        raise InputError(f"must be in (1, 2], got {growth}", key="growth", expected="(1, 2]")
    if radius >= 0.4 * size:
        raise InputError("hole radius must be smaller than 0.4 * size", key="radius")
    if h_wall is None:
        h_wall = 2.0 * math.pi * radius / 64.0
    h_wall = _check_pos("h_wall", h_wall)
    if h_wall > radius:
        raise InputError("h_wall must not exceed the hole radius", key="h_wall",
                         expected=f"<= {radius}")
    h_max = size / 10.0 if h_max is None else _check_pos("h_max", h_max)
    if h_max < h_wall:
        raise InputError("h_max must be >= h_wall", key="h_max")
    if not (0.0 <= jitter <= 0.3):
        raise InputError(f"must be in [0, 0.3], got {jitter}", key="jitter")
    band = fracture_band
    if band is not None and band.h > h_max:
        raise InputError("band element size above h_max", key="fracture_band.h")
    half = 0.5 * size
    h = _size_function(radius, h_wall, growth, h_max, band)

    # 1. levels from the hole circle to the outer square
    levels = [radius]
    while True:
        rho = levels[-1]
        nth = max(256, int(8 * 2 * math.pi * rho / h_wall) if band is None else 4096)
        nth = min(nth, 20000)
        th = np.linspace(0.0, 2 * math.pi, nth, endpoint=False)
        step = float(h(_level_curve(rho, radius, half, th)).min())
        if band is None:
            # radially graded: use the step at the middle of the interval (symmetric)
            step = float(h(_level_curve(rho + 0.5 * step, radius, half, th[:1])).min())
        if rho + 1.5 * step >= half:
            levels.append(half)
            break
        levels.append(rho + step)
    # 2. nodes on levels, thinning against already accepted nodes
    accepted: list[np.ndarray] = []
    thinned = False
    recent: list[tuple[float, np.ndarray]] = []
    for k, rho in enumerate(levels):
        if k == len(levels) - 1:
            pts = _outer_square(half, h)
        else:
            n_s = int(min(200000, max(512, 40 * 2 * math.pi * rho / float(
                h(_level_curve(rho, radius, half, np.linspace(0, 6.28, 64))).min()))))
            th = np.linspace(0.0, 2 * math.pi, n_s, endpoint=False)
            pts = _place_on_curve(_level_curve(rho, radius, half, th), h, closed=True,
                                  offset=0.5 * (k % 2))
            if k == 0:
                # exact circle for the wall
                ang = np.arctan2(pts[:, 1], pts[:, 0])
                if band is not None and (band.strip or band.centred_wall):
                    # an even number of equal wall edges, the band axis through the middle
                    # of one on either side (the crack strip starts on that edge)
                    n_w = len(ang) + len(ang) % 2
                    ang = band.azimuth + (np.arange(n_w) + 0.5) * 2.0 * math.pi / n_w
                pts = radius * np.column_stack([np.cos(ang), np.sin(ang)])
        if k > 0 and recent:
            ref = np.vstack([p for _, p in recent])
            dist, _ = cKDTree(ref).query(pts)
            keep = dist >= 0.8 * h(pts)
            if k == len(levels) - 1:
                keep[:] = True  # the outer boundary is never thinned
                # ... but interior nodes too close to it are removed instead
                d_out, _ = cKDTree(pts).query(ref)
                recent_ok = d_out >= 0.5 * h(ref)
                if not np.all(recent_ok):
                    thinned = True
                    drop = set(map(tuple, ref[~recent_ok]))
                    accepted = [a[[tuple(q) not in drop for q in a]] for a in accepted]
            if not np.all(keep):
                thinned = True
            pts = pts[keep]
        accepted.append(pts)
        hmax_here = float(h(pts).max()) if len(pts) else h_wall
        recent.append((rho, pts))
        recent = [(r, p) for r, p in recent if r >= rho - 2.5 * hmax_here]
    pts = np.vstack(accepted)
    n_wall = len(accepted[0])
    n_outer = len(accepted[-1])
    fixed = np.zeros(len(pts), dtype=bool)
    fixed[:n_wall] = True
    fixed[len(pts) - n_outer:] = True
    strip_nodes = np.zeros(len(pts), dtype=bool)
    if band is not None and band.strip:
        pts, fixed, strip_nodes = _add_crack_strip(pts, fixed, n_wall, radius, half, band, h)

    def triangulate(p: np.ndarray) -> np.ndarray:
        tri = Delaunay(p)
        if len(tri.coplanar):
            raise RuntimeError("Delaunay dropped nodes (coincident points)")
        t = tri.simplices
        inside = np.all(t < n_wall, axis=1)  # all three nodes on the hole circle
        t = t[~inside]
        q = p[t]
        area = 0.5 * ((q[:, 1, 0] - q[:, 0, 0]) * (q[:, 2, 1] - q[:, 0, 1])
                      - (q[:, 1, 1] - q[:, 0, 1]) * (q[:, 2, 0] - q[:, 0, 0]))
        t = t[np.abs(area) > 1e-12 * h_wall ** 2]
        return t

    tris = triangulate(pts)
    # 3. density-weighted centroidal smoothing where nodes were thinned
    if thinned:
        for _ in range(6):
            c = pts[tris].mean(axis=1)
            q = pts[tris]
            area = 0.5 * np.abs((q[:, 1, 0] - q[:, 0, 0]) * (q[:, 2, 1] - q[:, 0, 1])
                                - (q[:, 1, 1] - q[:, 0, 1]) * (q[:, 2, 0] - q[:, 0, 0]))
            w = area / h(c) ** 2
            num = np.zeros_like(pts)
            den = np.zeros(len(pts))
            for j in range(3):
                np.add.at(num, tris[:, j], w[:, None] * c)
                np.add.at(den, tris[:, j], w)
            new = num / np.maximum(den, 1e-300)[:, None]
            move = ~fixed & (den > 0)
            pts = pts.copy()
            pts[move] = 0.5 * pts[move] + 0.5 * new[move]
            r = np.hypot(pts[:, 0], pts[:, 1])
            bad = move & (r < radius + 0.3 * h_wall)
            pts[bad] *= ((radius + 0.3 * h_wall) / r[bad])[:, None]
            tris = triangulate(pts)
    # 4. jitter
    if jitter > 0.0:
        rng = np.random.default_rng(seed)
        hl = h(pts)
        d = rng.uniform(-1.0, 1.0, size=pts.shape) * (jitter * hl)[:, None]
        d[fixed] = 0.0
        pts = pts + d
        tris = triangulate(pts)
    mesh = mesh_from_triangles(pts, tris, hole_center=np.zeros(2), hole_radius=radius)
    hole = mesh.hole_edges
    if len(hole) != n_wall:
        raise RuntimeError("mesh generation failed: hole wall not recovered; "
                           "try a smaller growth or h_wall")
    markers = np.zeros(mesh.n_triangles, dtype=np.int64)
    if band is not None and band.strip:
        # the strip triangles: three strip nodes (the mouth's wall nodes included), on
        # both sides of the axis
        d = np.array([math.cos(band.azimuth), math.sin(band.azimuth)])
        nodes = mesh.nodes
        across = nodes[:, 0] * d[1] - nodes[:, 1] * d[0]
        t = mesh.triangles
        on = strip_nodes[t].all(axis=1)
        sides = np.sign(across[t])
        markers[on & (sides.max(axis=1) > 0) & (sides.min(axis=1) < 0)] = TRI_BAND
    elif band is not None:
        c = mesh.centroids
        d = np.array([math.cos(band.azimuth), math.sin(band.azimuth)])
        across = np.abs(c[:, 0] * d[1] - c[:, 1] * d[0])
        along = np.abs(c @ d)
        markers[(across <= 0.5 * band.width) & (along <= band.length)] = TRI_BAND
    return mesh.with_triangle_markers(markers)


def rectangle_mesh(width: float = 1.0, height: float = 1.0, nx: int = 4, ny: int = 4,
                   jitter: float = 0.0, seed: int = 0) -> Mesh:
    """Structured triangle mesh of ``[-width/2, width/2] x [-height/2, height/2]`` (no hole).

    Each of the ``nx x ny`` cells is split along alternating diagonals; interior nodes are
    moved by up to ``jitter`` times the cell size (seeded). Used for patch tests.
    """
    width = _check_pos("width", width)
    height = _check_pos("height", height)
    if int(nx) < 1 or int(ny) < 1:
        raise InputError("need at least one cell per direction", key="nx")
    if not (0.0 <= jitter <= 0.3):
        raise InputError(f"must be in [0, 0.3], got {jitter}", key="jitter")
    x = np.linspace(-width / 2, width / 2, nx + 1)
    y = np.linspace(-height / 2, height / 2, ny + 1)
    X, Y = np.meshgrid(x, y, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    if jitter > 0:
        rng = np.random.default_rng(seed)
        d = rng.uniform(-1, 1, size=pts.shape) * jitter * np.array([width / nx, height / ny])
        inner = ((np.abs(pts[:, 0]) < width / 2 - 1e-12 * width)
                 & (np.abs(pts[:, 1]) < height / 2 - 1e-12 * height))
        pts[inner] += d[inner]
    idx = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    tris = []
    for i in range(nx):
        for j in range(ny):
            a, b, c, d = idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]
            if (i + j) % 2 == 0:
                tris += [[a, b, c], [a, c, d]]
            else:
                tris += [[a, b, d], [b, c, d]]
    return mesh_from_triangles(pts, np.array(tris))


def refine_uniform(mesh: Mesh) -> Mesh:
    """Split every triangle into four; new hole-wall nodes are projected onto the circle.

    Parameters
    ----------
    mesh : Mesh

    Returns
    -------
    Mesh
        Triangle markers are inherited by the children.
    """
    edges, _ = mesh.edges()
    n = mesh.n_nodes
    mid = 0.5 * (mesh.nodes[edges[:, 0]] + mesh.nodes[edges[:, 1]])
    # project wall midpoints onto the hole circle
    hole = {tuple(sorted(map(int, e))) for e in mesh.hole_edges}
    if hole and mesh.hole_center is not None and mesh.hole_radius is not None:
        is_hole = np.array([tuple(map(int, e)) in hole for e in edges])
        v = mid[is_hole] - mesh.hole_center
        mid[is_hole] = mesh.hole_center + mesh.hole_radius * v / np.hypot(*v.T)[:, None]
    lookup = {(int(a), int(b)): n + i for i, (a, b) in enumerate(edges)}

    def m(a, b):
        return np.array([lookup[(min(x, y), max(x, y))] for x, y in zip(a, b)])

    t = mesh.triangles
    m01 = m(t[:, 0], t[:, 1])
    m12 = m(t[:, 1], t[:, 2])
    m20 = m(t[:, 2], t[:, 0])
    new = np.concatenate([
        np.column_stack([t[:, 0], m01, m20]),
        np.column_stack([m01, t[:, 1], m12]),
        np.column_stack([m20, m12, t[:, 2]]),
        np.column_stack([m01, m12, m20]),
    ])
    markers = np.tile(mesh.triangle_markers, 4)
    return mesh_from_triangles(np.vstack([mesh.nodes, mid]), new, triangle_markers=markers,
                               hole_center=mesh.hole_center, hole_radius=mesh.hole_radius)


# ---------------------------------------------------------------------------------------
# quality and I/O
# ---------------------------------------------------------------------------------------
def mesh_quality(mesh: Mesh) -> MeshQuality:
    """Angles and grading of a mesh.

    Returns
    -------
    MeshQuality
        The grading figure is the largest ratio of the size ``sqrt(area)`` of two
        triangles sharing an edge.
    """
    p = mesh.nodes[mesh.triangles]
    ang = np.empty((mesh.n_triangles, 3))
    for j in range(3):
        a = p[:, (j + 1) % 3] - p[:, j]
        b = p[:, (j + 2) % 3] - p[:, j]
        cosv = np.einsum("ij,ij->i", a, b) / (np.hypot(*a.T) * np.hypot(*b.T))
        ang[:, j] = np.degrees(np.arccos(np.clip(cosv, -1.0, 1.0)))
    area = mesh.areas
    s = np.sqrt(area)
    _, owners = mesh.edges()
    inner = owners[owners[:, 1] >= 0]
    ratio = s[inner[:, 0]] / s[inner[:, 1]]
    ratio = np.maximum(ratio, 1.0 / ratio)
    return MeshQuality(
        min_angle_deg=float(ang.min()),
        max_angle_deg=float(ang.max()),
        mean_min_angle_deg=float(ang.min(axis=1).mean()),
        max_neighbour_size_ratio=float(ratio.max()) if len(ratio) else 1.0,
        min_area=float(area.min()),
        max_area=float(area.max()),
        n_nodes=mesh.n_nodes,
        n_triangles=mesh.n_triangles,
    )


def read_mesh(path: str | Path) -> Mesh:
    """Read any linear triangle mesh meshio understands.

    The hole wall is identified as the inner boundary loop (see :func:`mesh_from_triangles`).
    Cell data named ``triangle_markers`` (or ``gmsh:physical``) become the triangle markers.

    Raises
    ------
    InputError
        If the file cannot be read or holds no triangles.
    """
    import meshio

    path = Path(path)
    if not path.is_file():
        raise InputError("no such file", file=path)
    try:
        m = meshio.read(path)
    except (Exception, SystemExit) as exc:  # meshio raises many types, even SystemExit
        raise InputError(f"cannot read mesh: {exc or type(exc).__name__}", file=path) from None
    tris = []
    markers = []
    for i, block in enumerate(m.cells):
        if block.type != "triangle":
            continue
        tris.append(block.data)
        mk = None
        for name in ("triangle_markers", "gmsh:physical", "medit:ref"):
            if name in m.cell_data:
                mk = np.asarray(m.cell_data[name][i]).reshape(-1)
                break
        markers.append(np.zeros(len(block.data), dtype=np.int64) if mk is None else mk)
    if not tris:
        raise InputError("no linear triangles in the mesh file", file=path,
                         expected="cells of type 'triangle'")
    return mesh_from_triangles(m.points, np.vstack(tris),
                               triangle_markers=np.concatenate(markers).astype(np.int64))


def write_mesh(
    mesh: Mesh,
    path: str | Path,
    cell_data: Mapping[str, np.ndarray] | None = None,
    point_data: Mapping[str, np.ndarray] | None = None,
) -> None:
    """Write a mesh (and fields) with meshio; ``.vtu`` gives a ParaView file.

    Parameters
    ----------
    mesh : Mesh
    path : str or Path
    cell_data : mapping name -> array, shape (m,) or (m, k), optional
        Per-triangle fields (e.g. stress, state). ``triangle_markers`` is always written.
    point_data : mapping name -> array, shape (n,) or (n, k), optional
        Per-node fields (e.g. displacement (n, 2) — padded to 3 components for VTK).
    """
    import meshio

    pts = np.column_stack([mesh.nodes, np.zeros(mesh.n_nodes)])
    cd = {"triangle_markers": [np.asarray(mesh.triangle_markers)]}
    for k, v in (cell_data or {}).items():
        v = np.asarray(v)
        if v.shape[0] != mesh.n_triangles:
            raise InputError(f"cell field has {v.shape[0]} rows, mesh has "
                             f"{mesh.n_triangles} triangles", key=k)
        cd[k] = [v]
    pdict = {}
    for k, v in (point_data or {}).items():
        v = np.asarray(v)
        if v.shape[0] != mesh.n_nodes:
            raise InputError(f"point field has {v.shape[0]} rows, mesh has "
                             f"{mesh.n_nodes} nodes", key=k)
        if v.ndim == 2 and v.shape[1] == 2:
            v = np.column_stack([v, np.zeros(len(v))])
        pdict[k] = v
    meshio.write(Path(path), meshio.Mesh(pts, [("triangle", np.asarray(mesh.triangles))],
                                         cell_data=cd, point_data=pdict))
