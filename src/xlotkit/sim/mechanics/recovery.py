"""Recovery of point values from cluster (constant) stresses.

MDEM clusters carry one stress each — the average over the triangle, which a CST element
reproduces with an O(h) error and at its centroid with O(h^2) for smooth fields. At the
borehole wall the stress concentration decays like ``a^2/r^2`` and ``a^4/r^4``, so the wall
clusters' stress is below the wall value by about the gradient times the centroid offset
(about a third of the wall-triangle height).

:func:`wall_stress` extrapolates to the wall: around the requested azimuth it fits the
polar components of the clusters near the wall by a quadratic polynomial in
``q - 1 = a^2/r^2 - 1`` and in the angle offset ``psi`` (least squares), and evaluates it at
``q = 1, psi = 0``. ``q = a^2/r^2`` is the natural radial variable of the Michell/Kirsch
series for a traction-loaded circular hole (the Kirsch field is a quadratic polynomial in
``q`` at fixed angle), so the extrapolation is exact for it up to the discretisation error
of the cluster values themselves.
"""

from __future__ import annotations

import numpy as np

from xlotkit.errors import InputError
from xlotkit.sim.mesh import Mesh

__all__ = ["polar_components", "wall_stress"]


def polar_components(stress: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotate ``(sxx, syy, sxy)`` to ``(s_rr, s_tt, s_rt)`` at polar angle ``angle`` [rad]."""
    sxx, syy, sxy = stress[..., 0], stress[..., 1], stress[..., 2]
    c, s = np.cos(angle), np.sin(angle)
    srr = sxx * c ** 2 + syy * s ** 2 + 2 * sxy * s * c
    stt = sxx * s ** 2 + syy * c ** 2 - 2 * sxy * s * c
    srt = (syy - sxx) * s * c + sxy * (c ** 2 - s ** 2)
    return np.stack([srr, stt, srt], axis=-1)


def wall_stress(mesh: Mesh, stress: np.ndarray, theta, layers: float = 8.0,
                window: float = 2.5) -> np.ndarray:
    """Polar stress at the hole wall extrapolated from cluster stresses.

    Parameters
    ----------
    mesh : Mesh
        With ``hole_center`` and ``hole_radius``.
    stress : ndarray (n_c, 3)
        Cluster stresses ``(sxx, syy, sxy)`` (any sign convention; returned in the same).
    theta : float or array_like
        Azimuths [rad] from +x about the hole centre.
    layers : float
        Radial extent of the fitting patch in wall edge lengths.
    window : float
        Half-width of the angular window in wall edge lengths.

    Returns
    -------
    ndarray (k, 3)
        ``(s_rr, s_tt, s_rt)`` at ``r = a`` for every azimuth.
    """
    if mesh.hole_center is None or mesh.hole_radius is None:
        raise InputError("mesh has no hole", key="mesh")
    stress = np.asarray(stress, dtype=float)
    if stress.shape != (mesh.n_triangles, 3):
        raise InputError("stress must have shape (n_triangles, 3)", key="stress")
    a = mesh.hole_radius
    he = mesh.hole_edges
    h = float(np.mean(np.hypot(*(mesh.nodes[he[:, 1]] - mesh.nodes[he[:, 0]]).T)))
    c = mesh.centroids - mesh.hole_center
    r = np.hypot(c[:, 0], c[:, 1])
    ang = np.arctan2(c[:, 1], c[:, 0])
    near = np.nonzero(r < a + layers * h)[0]
    out = []
    for t0 in np.atleast_1d(np.asarray(theta, dtype=float)):
        psi = np.angle(np.exp(1j * (ang[near] - t0)))
        sel = np.abs(psi) < window * h / a
        idx = near[sel]
        if len(idx) < 8:
            raise InputError("too few clusters near the wall for recovery", key="theta")
        q = (a / r[idx]) ** 2 - 1.0
        ps = psi[sel]
        A = np.column_stack([np.ones_like(q), q, q ** 2, ps, ps ** 2, q * ps])
        vals = polar_components(stress[idx], ang[idx])
        coef, *_ = np.linalg.lstsq(A, vals, rcond=None)
        out.append(coef[0])
    return np.array(out)
