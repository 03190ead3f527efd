"""The crack plane of a failed cluster: which plane, which of its contacts cross it, and
how much joint each crossing contact carries.

Small pure functions, vectorised over clusters; SI units, stresses compression positive.

Which plane (set once, when the cluster fails; see docs/mechanics.md, "Crack planes"):

* tensile failure away from any crack (:func:`tensile_plane_normal`): the plane normal to
  the minimum effective principal stress ``sigma'_min`` of the cluster at failure, the
  plane a mode-I crack opens on (a crack starting at the wall: radial, along sigma_H).
* tensile failure at a crack (the cluster shares a node with clusters failed in tension:
  a crack tip extending, or a cluster beside the faces): the crack's line there, the
  mean plane of those clusters (:func:`mean_axis`; shear cracks beside it do not count). Why not its own stress: a tip cluster's average
  stress depends on where it sits in the tip field (beside the crack's line at an angle
  ``theta`` the principal directions of the mode-I field turn by about ``theta / 2``),
  and on a lattice the path steps sideways: on the standard scene's free path the planes
  from the stress scattered by 21.8 deg (rms) about sigma_H, the crack closed on its
  inclined pieces and the closure picks came 4.4 % above the normal stress. The crack
  fronts' fitted line has no direction with one or two cracked clusters behind a tip (it
  gave a mouth cluster a plane 144 deg off its neighbour's); the maximum-hoop-stress kink
  of the fronts' ``K_I``, ``K_II`` put one 66 deg off (``K_II`` is first order in the error
  of that line). The cost: a crack does not turn at its tips; it turns where a new crack
  starts away from it (at an interface, or in a field that has turned).
* shear failure (:func:`shear_plane_normals`, :func:`choose_conjugate`): a Mohr-Coulomb
  plane, whose normal makes ``beta = pi/4 + phi/2`` with ``sigma'_1``. Of the two
  conjugate planes the one closer to the cracks already next to the cluster (their mean
  plane, :func:`mean_axis`) continues them; with no crack next to it, the plane at
  ``+beta`` (counter-clockwise from ``sigma'_1``), a fixed rule.

Which contacts (:func:`plane_crossing`): the plane is the line through the cluster's
centroid; the two contacts (sub-edges) whose nodes lie on either side of it measure
opening and sliding against the plane's normal (a smooth joint); the third joins two
nodes on one face and keeps its sub-edge direction.

How much joint (:func:`joint_lengths`): the two contacts crossing the plane ``n`` share
the joint length ``|n x dx_e| / 2`` (half the face edge ``e`` projected on the plane),
``l_m = |n x dx_e| / 4`` each, so that a joint stress ``sigma`` (contact forces
``-l_m sigma`` along ``n``) does on the crack's opening the work of the cluster stress
``sigma`` normal to the plane on the opening's strain (the crack-band view of a crack
smeared over its cluster). The joint lengths of a row of clusters along a straight crack
add up to the crack's length.
"""

from __future__ import annotations

import numpy as np

from xlotkit.sim.mechanics.failure import principal_stresses
from xlotkit.sim.mechanics.mdem import CONTACT_NODES, _operators

__all__ = [
    "choose_conjugate",
    "joint_lengths",
    "joint_operators",
    "mean_axis",
    "operator_stress",
    "plane_crossing",
    "plane_tangent",
    "shear_plane_normals",
    "tensile_plane_normal",
]


def tensile_plane_normal(stress: np.ndarray) -> np.ndarray:
    """Unit normal of the plane normal to ``sigma'_min``, shape (..., 2).

    Parameters
    ----------
    stress : ndarray (..., 3)
        Effective stress ``(sxx, syy, sxy)`` [Pa], compression positive.
    """
    _, _, a1 = principal_stresses(np.asarray(stress, dtype=float))
    # sigma'_min is normal to sigma'_1 (direction a1)
    return np.stack([-np.sin(a1), np.cos(a1)], axis=-1)


def shear_plane_normals(stress: np.ndarray, friction_angle: float) -> np.ndarray:
    """Unit normals of the two conjugate Mohr-Coulomb planes, shape (..., 2, 2).

    ``[..., 0, :]`` at ``+beta`` and ``[..., 1, :]`` at ``-beta`` from ``sigma'_1``,
    ``beta = pi/4 + phi/2`` (the planes of :func:`~xlotkit.sim.mechanics.failure.
    mohr_coulomb_margin`).

    Parameters
    ----------
    stress : ndarray (..., 3)
        Effective stress [Pa], compression positive.
    friction_angle : float
        ``phi`` [rad].
    """
    _, _, a1 = principal_stresses(np.asarray(stress, dtype=float))
    beta = 0.25 * np.pi + 0.5 * float(friction_angle)
    ang = np.stack([a1 + beta, a1 - beta], axis=-1)
    return np.stack([np.cos(ang), np.sin(ang)], axis=-1)


def mean_axis(normals: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Mean of axial directions (``n`` and ``-n`` the same), a unit vector or zeros.

    Averages the doubled angles: ``sum w (cos 2 theta, sin 2 theta)``, halved back.

    Parameters
    ----------
    normals : ndarray (k, 2)
        Unit vectors (zero rows are ignored).
    weights : ndarray (k,), optional
    """
    n = np.asarray(normals, dtype=float).reshape(-1, 2)
    w = np.ones(len(n)) if weights is None else np.asarray(weights, dtype=float)
    c = np.sum(w * (n[:, 0] ** 2 - n[:, 1] ** 2))
    s = np.sum(w * 2.0 * n[:, 0] * n[:, 1])
    r = np.hypot(c, s)
    if not r > 1e-12 * max(float(np.sum(np.abs(w))), 1e-300):
        return np.zeros(2)
    half = 0.5 * np.arctan2(s, c)
    return np.array([np.cos(half), np.sin(half)])


def choose_conjugate(normals: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Of two conjugate plane normals, the one closer (as an axis) to ``reference``.

    Parameters
    ----------
    normals : ndarray (k, 2, 2)
        The two candidates per cluster (:func:`shear_plane_normals`).
    reference : ndarray (k, 2)
        Normal of the nearby cracks' mean plane, or zeros for none: then the first
        candidate (``+beta``). Ties go to the first candidate too.

    Returns
    -------
    ndarray (k, 2)
    """
    nm = np.asarray(normals, dtype=float)
    ref = np.asarray(reference, dtype=float)
    d0 = np.abs(np.einsum("ki,ki->k", nm[:, 0], ref))
    d1 = np.abs(np.einsum("ki,ki->k", nm[:, 1], ref))
    return np.where((d1 > d0)[:, None], nm[:, 1], nm[:, 0])


def plane_tangent(normal: np.ndarray) -> np.ndarray:
    """The plane's direction for a normal ``n``: ``n`` rotated by -90 degrees, (..., 2).

    (So that ``n`` is the tangent rotated by +90 degrees, as for
    :class:`~xlotkit.sim.mechanics.FracturePlane`.)
    """
    n = np.asarray(normal, dtype=float)
    return np.stack([n[..., 1], -n[..., 0]], axis=-1)


def plane_crossing(points: np.ndarray, centroid: np.ndarray,
                   normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Contacts crossing the line through the centroid normal to ``normal``.

    A node exactly on the line counts on the side the normal points to, so exactly two
    contacts cross (the line through the centroid always separates one node from the
    other two).

    Parameters
    ----------
    points : ndarray (k, 3, 2)
        Node coordinates of the clusters [m].
    centroid : ndarray (k, 2)
    normal : ndarray (k, 2)
        Unit plane normals.

    Returns
    -------
    crossing : ndarray of bool (k, 3)
        Contact ``m`` (nodes ``CONTACT_NODES[m]``) crosses the plane.
    sign : ndarray (k, 3)
        +1 when the contact's node ``j`` is on the side ``normal`` points to, else -1:
        ``sign * normal`` points from node ``i``'s face to node ``j``'s.
    """
    side = np.einsum("kni,ki->kn", np.asarray(points, dtype=float)
                     - np.asarray(centroid, dtype=float)[:, None, :],
                     np.asarray(normal, dtype=float)) >= 0.0
    i, j = CONTACT_NODES[:, 0], CONTACT_NODES[:, 1]
    crossing = side[:, i] != side[:, j]
    sign = np.where(side[:, j], 1.0, -1.0)
    return crossing, sign


def joint_lengths(area: np.ndarray, dx: np.ndarray, normals: np.ndarray,
                  joint: np.ndarray) -> np.ndarray:
    """Joint length ``l_m`` of every joint contact [m] (module docstring); 0 for the others.

    A cluster on a plane (two joint contacts, the third the face edge ``e``): the crack's
    opening ``w`` (the lone node moving off the face along ``n``) is the CST strain
    ``w n . grad N_k`` normal to the plane, so a joint traction ``sigma`` does the work
    ``sigma w A |n . grad N_k| = sigma w |n x dx_e| / 2`` on it; the two crossing contacts
    share that joint length equally, ``l_m = |n x dx_e| / 4``. (Where the face edge is
    steep to the plane, the opening's CST strain normal to the plane can even be of the
    other sign; the joint length is its magnitude, half the face edge's shadow on the
    plane.) Along a straight crack the joint lengths of its clusters add up to the
    crack's length. Any other count of
    joint contacts (all three: no plane): ``l_m = A / (n_j |n_m . dx_m|)``, which gives a
    cluster whose joint contacts close alike the average stress ``sigma`` along their
    normals.

    Parameters
    ----------
    area : ndarray (k,)
        Cluster areas [m^2].
    dx : ndarray (k, 3, 2)
        Contact vectors ``x_j - x_i`` [m].
    normals : ndarray (k, 3, 2)
        Normal direction of each contact.
    joint : ndarray of bool (k, 3)
        Contacts on the crack (crossing the plane).
    """
    jt = np.asarray(joint, dtype=bool)
    nrm = np.asarray(normals, dtype=float)
    d = np.asarray(dx, dtype=float)
    proj = np.abs(np.einsum("kmi,kmi->km", nrm, d))
    nj = np.sum(jt, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ell = np.asarray(area, dtype=float)[:, None] / (np.maximum(nj, 1)[:, None] * proj)
    two = np.flatnonzero(nj == 2)
    if two.size:
        e = np.argmin(jt[two], axis=1)                        # the face edge
        m0 = np.argmax(jt[two], axis=1)                       # a crossing contact
        n = nrm[two, m0]
        de = d[two, e]
        ell[two] = (0.25 * np.abs(n[:, 0] * de[:, 1] - n[:, 1] * de[:, 0]))[:, None]
    return np.where(jt & (proj > 0), ell, 0.0)


def joint_operators(dx: np.ndarray, normals: np.ndarray, shears: np.ndarray,
                    crossing: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Relative-displacement operators of clusters on their crack planes, (k, 3, 6) each.

    A contact ``m`` crossing the plane joins nodes ``i``, ``j`` that lie apart along the
    plane by ``t . dx_m``: measured as ``n . (u_j - u_i)``, a rigid rotation ``omega`` of
    the cluster would open or close it by ``omega (n x dx_m)``, and its force along ``n``
    would have a moment the triangle cannot balance (a row of such clusters along a
    straight joint then closes unevenly). The rotation is taken out as that of the face
    that holds two nodes, ``omega_f = r . (u_q - u_p)`` with ``r = (-dx_y, dx_x) / d^2``
    of the edge ``p -> q`` (the non-crossing contact): exactly the rigid rotation for a
    rigid motion, and zero when the lone node moves against that face (the crack's own
    opening and sliding):

        U_n = n . (u_j - u_i) + (n x dx_m) omega_f,
        U_s = t . (u_j - u_i) + (t x dx_m) omega_f      (a x b = a_x b_y - a_y b_x)

    The internal forces ``b^T F`` then carry the couple on the face that balances the
    joint forces' moment. The non-crossing contact keeps the plain operators.

    Parameters
    ----------
    dx : ndarray (k, 3, 2)
        Contact vectors ``x_j - x_i`` [m].
    normals, shears : ndarray (k, 3, 2)
        Contact normal and shear directions (plane normal / tangent on crossing contacts).
    crossing : ndarray of bool (k, 3)
        The two crossing contacts of every cluster.

    Returns
    -------
    bn, bs : ndarray (k, 3, 6)
    """
    bn = _operators(normals)
    bs = _operators(shears)
    cr = np.asarray(crossing, dtype=bool)
    k = len(cr)
    # the face edge: the one non-crossing contact of each cluster
    e = np.argmin(cr, axis=1)
    rows = np.arange(k)
    de = dx[rows, e]                                            # (k, 2), p -> q
    r = np.stack([-de[:, 1], de[:, 0]], axis=1) / np.sum(de * de, axis=1)[:, None]
    p_node = CONTACT_NODES[e, 0]
    q_node = CONTACT_NODES[e, 1]
    rot = np.zeros((k, 6))                                      # omega_f = rot . u_c
    for c_ in range(2):
        rot[rows, 2 * q_node + c_] += r[:, c_]
        rot[rows, 2 * p_node + c_] -= r[:, c_]
    an = normals[..., 0] * dx[..., 1] - normals[..., 1] * dx[..., 0]     # n x dx
    at = shears[..., 0] * dx[..., 1] - shears[..., 1] * dx[..., 0]       # t x dx
    # a rigid rotation gives n . (u_j - u_i) = -omega (n x dx): add it back
    bn = bn + np.where(cr, an, 0.0)[..., None] * rot[:, None, :]
    bs = bs + np.where(cr, at, 0.0)[..., None] * rot[:, None, :]
    return bn, bs


def operator_stress(b: np.ndarray, points: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Cluster stress of a unit force of each contact, (k, 3, 3) [1/m] (tension positive).

    The virtual-work average ``sigma = sym(sum_a f_a (x) x_a) / A`` of the nodal forces
    ``f = b^T`` of a unit contact force (the generalised Eq. 2.7/2.11: for a plain
    operator, ``n (x) dx_m / A``; with the face rotation of :func:`joint_operators`, also
    the couple on the face). Rows ``[c, m]`` are ``(sxx, syy, sxy)``.

    Parameters
    ----------
    b : ndarray (k, 3, 6)
        Contact operators.
    points : ndarray (k, 3, 2)
        Node coordinates [m].
    area : ndarray (k,)
    """
    f = np.asarray(b, dtype=float).reshape(len(b), 3, 3, 2)        # contact, node, comp
    x = np.asarray(points, dtype=float)
    x = x - x.mean(axis=1, keepdims=True)
    t = np.einsum("kmai,kaj->kmij", f, x)
    out = np.stack([t[..., 0, 0], t[..., 1, 1], 0.5 * (t[..., 0, 1] + t[..., 1, 0])], axis=-1)
    return out / np.asarray(area, dtype=float)[:, None, None]
