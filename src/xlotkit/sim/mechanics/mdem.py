"""MDEM cluster formulation (thesis section 2.2), vectorised over clusters.

Each triangle is a *cluster* of three Voronoi elements centred on its nodes. Two elements
touch across a *sub-edge* (the Voronoi facet inside the triangle, perpendicular to the
triangle edge joining the two nodes), so every cluster has three contacts. Contact ``m``
joins the nodes ``i = (m+1) % 3`` and ``j = (m+2) % 3`` (the edge opposite vertex ``m``);
``dx_m = x_j - x_i``, length ``d_m``, unit normal ``e_m = dx_m / d_m`` (the normal of the
sub-edge) and unit shear direction ``t_m`` (``e_m`` rotated +90 degrees).

Relative displacements of a contact: ``U_n = e_m . (u_j - u_i)`` (elongation, tension
positive) and ``U_s = t_m . (u_j - u_i)``. For a uniform strain
``eps = (eps_xx, eps_yy, gamma_xy)``:

    U_n = M eps,   M[m] = d_m (e_x^2, e_y^2, e_x e_y)                    (Eq. 2.9/2.10)

and by virtual work the cluster stress of the normal contact forces F_n is

    sigma = M^T F_n / A                                                (Eq. 2.7/2.11)

With ``F_n = K U_n`` and ``sigma = C eps`` the micro-stiffness follows from the macroscopic
plane-strain constitutive matrix ``C``:

    C = M^T K M / A   =>   K = A M^-T C M^-1                          (Eq. 2.13/2.14)

The cluster stiffness in nodal displacements is ``b_n^T K b_n`` where ``b_n`` (3 x 6) maps
the cluster's nodal displacements to ``U_n``. Because the edge elongations of a linear field
are exactly ``M B u`` (``B`` the CST strain-displacement matrix), ``b_n = M B`` and

    b_n^T K b_n = B^T M^T (A M^-T C M^-1) M B = A B^T C B,

the constant-strain-triangle stiffness: an intact MDEM cluster *is* a CST element.

Internally tension is positive (continuum convention). Units: m, Pa, N/m (forces per unit
thickness).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "ClusterGeometry",
    "cluster_geometry",
    "cluster_stress_from_forces",
    "cst_b_matrix",
    "cst_stiffness",
    "intact_cluster_stiffness",
    "m_matrix",
    "micro_stiffness",
    "plane_strain_matrix",
]

#: node pair (i, j) of contact m (edge opposite vertex m)
CONTACT_NODES = np.array([[1, 2], [2, 0], [0, 1]])


def plane_strain_matrix(young: float, poisson: float) -> np.ndarray:
    """Plane-strain isotropic constitutive matrix C, shape (3, 3), Voigt (xx, yy, xy).

    ``sigma = C eps`` with engineering shear strain ``gamma_xy``:

        C = E / ((1 + nu)(1 - 2 nu)) [[1-nu, nu, 0], [nu, 1-nu, 0], [0, 0, (1-2nu)/2]]

    Parameters
    ----------
    young : float
        E [Pa].
    poisson : float
        nu [-], in [0, 0.5).
    """
    f = young / ((1.0 + poisson) * (1.0 - 2.0 * poisson))
    return f * np.array([[1.0 - poisson, poisson, 0.0],
                         [poisson, 1.0 - poisson, 0.0],
                         [0.0, 0.0, 0.5 - poisson]])


@dataclass(frozen=True)
class ClusterGeometry:
    """Geometry of all clusters (arrays over clusters ``c`` and contacts ``m``).

    Attributes
    ----------
    area : ndarray (n_c,)
        Cluster (triangle) area [m^2].
    dx : ndarray (n_c, 3, 2)
        Contact vectors ``x_j - x_i`` [m].
    length : ndarray (n_c, 3)
        Contact lengths ``d_m`` [m].
    normal : ndarray (n_c, 3, 2)
        Sub-edge normals ``e_m`` (unit, along the triangle edge).
    shear : ndarray (n_c, 3, 2)
        Shear directions ``t_m`` (unit, ``e_m`` rotated by +90 degrees).
    """

    area: np.ndarray
    dx: np.ndarray
    length: np.ndarray
    normal: np.ndarray
    shear: np.ndarray


def cluster_geometry(nodes: np.ndarray, triangles: np.ndarray) -> ClusterGeometry:
    """Contact geometry of every cluster.

    Parameters
    ----------
    nodes : ndarray (n, 2)
        Node coordinates [m].
    triangles : ndarray of int (n_c, 3)
        CCW triangles.
    """
    p = nodes[triangles]  # (c, 3, 2)
    dx = p[:, CONTACT_NODES[:, 1]] - p[:, CONTACT_NODES[:, 0]]
    length = np.hypot(dx[..., 0], dx[..., 1])
    e = dx / length[..., None]
    t = np.stack([-e[..., 1], e[..., 0]], axis=-1)
    d1 = p[:, 1] - p[:, 0]
    d2 = p[:, 2] - p[:, 0]
    area = 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    return ClusterGeometry(area=area, dx=dx, length=length, normal=e, shear=t)


def m_matrix(geom: ClusterGeometry) -> np.ndarray:
    """Unit-normal matrix M of every cluster, shape (n_c, 3, 3) (Eq. 2.10).

    Row ``m`` is ``d_m (e_x^2, e_y^2, e_x e_y)`` so that ``U_n = M eps`` with
    ``eps = (eps_xx, eps_yy, gamma_xy)``.
    """
    e = geom.normal
    d = geom.length
    return np.stack([d * e[..., 0] ** 2, d * e[..., 1] ** 2, d * e[..., 0] * e[..., 1]],
                    axis=-1)


def micro_stiffness(M: np.ndarray, C: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Micro-stiffness ``K = A M^-T C M^-1`` of every cluster, shape (n_c, 3, 3) [N/m].

    Inverse of Eq. 2.13, ``C = M^T K M / A``. ``C`` may be (3, 3) or per cluster
    (n_c, 3, 3). K is symmetric positive definite for a non-degenerate triangle.
    """
    Minv = np.linalg.inv(M)
    return area[:, None, None] * np.einsum("cji,...jk,ckl->cil", Minv, C, Minv)


def contact_operators(geom: ClusterGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Operators from cluster nodal displacements to contact relative displacements.

    Returns
    -------
    bn, bs : ndarray (n_c, 3, 6)
        ``U_n = bn @ u_c`` and ``U_s = bs @ u_c`` with
        ``u_c = (u0x, u0y, u1x, u1y, u2x, u2y)``.
    """
    return _operators(geom.normal), _operators(geom.shear)


def _operators(direction: np.ndarray) -> np.ndarray:
    nc = direction.shape[0]
    b = np.zeros((nc, 3, 6))
    for m, (i, j) in enumerate(CONTACT_NODES):
        b[:, m, 2 * i:2 * i + 2] = -direction[:, m]
        b[:, m, 2 * j:2 * j + 2] = direction[:, m]
    return b


def intact_cluster_stiffness(K: np.ndarray, bn: np.ndarray) -> np.ndarray:
    """Cluster stiffness in nodal displacements ``bn^T K bn``, shape (n_c, 6, 6) [N/m]."""
    return np.einsum("cmi,cmn,cnj->cij", bn, K, bn)


def cst_b_matrix(nodes: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Strain-displacement matrix B of linear triangles, shape (n_c, 3, 6) [1/m].

    ``eps = (eps_xx, eps_yy, gamma_xy) = B u_c``.
    """
    p = nodes[triangles]
    x, y = p[..., 0], p[..., 1]
    b = np.stack([y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1]], axis=1)
    c = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1)
    two_a = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    B = np.zeros((len(triangles), 3, 6))
    B[:, 0, 0::2] = b
    B[:, 1, 1::2] = c
    B[:, 2, 0::2] = c
    B[:, 2, 1::2] = b
    return B / two_a[:, None, None]


def cst_stiffness(nodes: np.ndarray, triangles: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Constant-strain-triangle element stiffness ``A B^T C B``, shape (n_c, 6, 6)."""
    B = cst_b_matrix(nodes, triangles)
    p = nodes[triangles]
    d1 = p[:, 1] - p[:, 0]
    d2 = p[:, 2] - p[:, 0]
    area = 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    return area[:, None, None] * np.einsum("cki,kl,clj->cij", B, C, B)


def cluster_stress_from_forces(
    area: np.ndarray,
    dx: np.ndarray,
    normal: np.ndarray,
    fn: np.ndarray,
    shear: np.ndarray | None = None,
    fs: np.ndarray | None = None,
) -> np.ndarray:
    """Cluster stress from contact forces (generalised Eq. 2.7/2.11), tension positive.

    ``sigma = (1/A) sum_m sym(f_m (x) dx_m)`` with ``f_m = F_n,m n_m + F_s,m t_m`` the
    internal force of contact ``m`` on its node ``j`` (virtual work). For normal forces
    along the sub-edge normals this is exactly ``M^T F_n / A``.

    Parameters
    ----------
    area : (n_c,)
    dx : (n_c, 3, 2)
    normal : (n_c, 3, 2)
        Direction of the normal force of each contact.
    fn : (n_c, 3)
        Normal forces [N/m], tension positive.
    shear, fs : (n_c, 3, 2), (n_c, 3), optional
        Shear directions and shear forces [N/m].

    Returns
    -------
    ndarray (n_c, 3)
        ``(sigma_xx, sigma_yy, sigma_xy)`` [Pa], tension positive.
    """
    f = fn[..., None] * normal
    if fs is not None and shear is not None:
        f = f + fs[..., None] * shear
    sxx = np.sum(f[..., 0] * dx[..., 0], axis=1)
    syy = np.sum(f[..., 1] * dx[..., 1], axis=1)
    sxy = 0.5 * np.sum(f[..., 0] * dx[..., 1] + f[..., 1] * dx[..., 0], axis=1)
    return np.stack([sxx, syy, sxy], axis=1) / area[:, None]
