"""Sparse assembly of cluster matrices and boundary loads (vectorised NumPy).

Degrees of freedom: node ``k`` owns ``2k`` (x) and ``2k + 1`` (y). Cluster ``c`` with
nodes ``(a, b, d)`` owns ``(2a, 2a+1, 2b, 2b+1, 2d, 2d+1)``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from xlotkit.errors import InputError

__all__ = [
    "assemble_matrix",
    "assemble_vector",
    "cluster_dofs",
    "edge_traction_load",
]


def cluster_dofs(triangles: np.ndarray) -> np.ndarray:
    """Global DOF indices of every cluster, shape (n_c, 6)."""
    t = np.asarray(triangles, dtype=np.int64)
    return np.stack([2 * t[:, 0], 2 * t[:, 0] + 1, 2 * t[:, 1], 2 * t[:, 1] + 1,
                     2 * t[:, 2], 2 * t[:, 2] + 1], axis=1)


def assemble_matrix(blocks: np.ndarray, dofs: np.ndarray, n_dof: int,
                    keep: np.ndarray | None = None) -> sp.csr_matrix:
    """Sum cluster blocks into a sparse matrix.

    Parameters
    ----------
    blocks : ndarray (n_c, 6, 6)
        Cluster matrices.
    dofs : ndarray of int (n_c, 6)
        Global DOFs of each cluster.
    n_dof : int
        Size of the global matrix (before reduction).
    keep : ndarray of int (n_dof,), optional
        Reduced index of each DOF (``-1`` = constrained DOF, dropped). The result then has
        size ``keep.max() + 1``.

    Returns
    -------
    scipy.sparse.csr_matrix
    """
    blocks = np.asarray(blocks, dtype=float)
    dofs = np.asarray(dofs, dtype=np.int64)
    if blocks.shape != (dofs.shape[0], 6, 6):
        raise InputError(f"blocks must have shape ({dofs.shape[0]}, 6, 6), got "
                         f"{blocks.shape}", key="blocks")
    rows = np.repeat(dofs, 6, axis=1).ravel()
    cols = np.tile(dofs, (1, 6)).ravel()
    vals = blocks.ravel()
    n = n_dof
    if keep is not None:
        rows = keep[rows]
        cols = keep[cols]
        ok = (rows >= 0) & (cols >= 0)
        rows, cols, vals = rows[ok], cols[ok], vals[ok]
        n = int(keep.max()) + 1
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))


def assemble_vector(vectors: np.ndarray, dofs: np.ndarray, n_dof: int) -> np.ndarray:
    """Sum cluster vectors (n_c, 6) into a global vector (n_dof,)."""
    return np.bincount(np.asarray(dofs).ravel(), weights=np.asarray(vectors).ravel(),
                       minlength=n_dof)


def edge_traction_load(nodes: np.ndarray, edges: np.ndarray, stress: np.ndarray) -> np.ndarray:
    """Consistent nodal loads of a uniform stress acting on boundary edges.

    The traction on an edge is ``t = S n`` with ``S`` the (tension-positive) 2x2 stress
    tensor and ``n`` the outward unit normal; each end node receives ``t L / 2``.

    Parameters
    ----------
    nodes : ndarray (n, 2)
    edges : ndarray of int (k, 2)
        Boundary edges oriented with the domain on their left (outward normal on the right).
    stress : ndarray (2, 2)
        Tension-positive stress tensor [Pa].

    Returns
    -------
    ndarray (2 n,)
        Nodal forces [N/m].
    """
    a = nodes[edges[:, 0]]
    b = nodes[edges[:, 1]]
    d = b - a
    # outward normal times length: right-hand normal of the edge direction
    nl = np.column_stack([d[:, 1], -d[:, 0]])
    t = nl @ np.asarray(stress, dtype=float).T  # (k, 2) = S n L
    f = np.zeros(2 * len(nodes))
    for col in (0, 1):
        np.add.at(f, 2 * edges[:, col], 0.5 * t[:, 0])
        np.add.at(f, 2 * edges[:, col] + 1, 0.5 * t[:, 1])
    return f
