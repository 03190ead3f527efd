"""Aperture-dependent permeability and porosity of a failed cluster (thesis 4.3, SPEC §4).

Small pure kernels, vectorised over clusters, SI units. The mechanics supplies the normal
opening ``w_n`` (and the shear slip ``u_s``) of a failed cluster's crack; the flow model uses
the results as per-cell permeability and as extra pore volume.

Model
-----
Hydraulic aperture (the residual aperture keeps a closed crack slightly conductive; shear
dilation only when the scene enables it)::

    w_h = w_res + max(w_n, 0) [+ tan(psi) |u_s|]                          [m]

With a fracture closure law (:mod:`xlotkit.sim.mechanics.closure`) the closed crack's
aperture falls with the effective normal stress instead: :func:`sealing_aperture`,
``w_h = w_inf + max(V_m + g, 0)`` with ``g`` the signed contact gap (``-delta`` when closed
by ``delta``), from ``w_inf + V_m`` at zero stress down to the sealed ``w_inf``.

Parallel-plate ("cubic law") permeability of the crack (Eq. 4.2)::

    k_f = w_h^2 / 12                                                      [m^2]

Up-scaling of the crack into the cluster (Eq. 4.3): a crack of aperture ``w_h`` crossing a
cell of width ``Delta`` perpendicular to it adds ``k_f w_h / Delta`` to the matrix
permeability ``k_m`` (flow in parallel through rock and crack)::

    PM = 1 + k_f w_h / (k_m Delta),        k = PM k_m = k_m + w_h^3 / (12 Delta)

Fracture porosity (Eq. 4.4), with ``V_f`` the crack volume and ``V_b`` the bulk volume::

    phi_f = V_f / V_b

In the flow residual the crack volume ``V_f`` enters as extra pore volume of the cell (see
:class:`xlotkit.sim.flow.FlowState`), so opening a crack lowers its pressure through the fluid
compressibility and draws fluid in (thesis 4.4.2) instead of creating mass.

The cluster length scale: for a crack of trace length ``l`` through a cell of area ``A``,
``Delta = A / l`` makes the up-scaled permeability consistent with the fracture porosity
(``k - k_m = k_f phi_f`` when ``V_f = w_h l h``). Without a trace length ``sqrt(A)`` is used.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from xlotkit.errors import InputError

__all__ = [
    "cluster_length_scale",
    "crack_fields",
    "crack_opening",
    "crack_permeability",
    "crack_permeability_derivative",
    "cubic_law_permeability",
    "fracture_porosity",
    "hydraulic_aperture",
    "permeability_multiplier",
    "permeability_multiplier_derivative",
    "sealing_aperture",
    "sealing_aperture_derivative",
    "upscaled_permeability",
]


def hydraulic_aperture(normal_opening, residual_aperture, shear_slip=None,
                       dilation_angle=None):
    """Hydraulic aperture ``w_h = w_res + max(w_n, 0) [+ tan(psi) |u_s|]`` [m].

    Parameters
    ----------
    normal_opening : array_like, shape (m,)
        Normal opening ``w_n`` of the crack [m]; negative (overlap / closed) counts as 0.
    residual_aperture : float or array_like, shape (m,)
        ``w_res >= 0`` [m], the aperture of a closed crack.
    shear_slip : array_like, shape (m,), optional
        Accumulated shear slip ``u_s`` [m]; used only together with ``dilation_angle``.
    dilation_angle : float or array_like, optional
        Dilation angle ``psi`` [rad] in ``[0, pi/2)``; ``None`` disables shear dilation.

    Returns
    -------
    ndarray, shape (m,)
        Hydraulic aperture [m].
    """
    wn = np.asarray(normal_opening, dtype=float)
    wres = np.asarray(residual_aperture, dtype=float)
    if np.any(wres < 0) or not np.all(np.isfinite(wres)):
        raise InputError("must be finite and >= 0", key="residual_aperture", expected=">= 0")
    w = wres + np.maximum(wn, 0.0)
    if dilation_angle is not None and shear_slip is not None:
        psi = np.asarray(dilation_angle, dtype=float)
        if np.any(psi < 0) or np.any(psi >= 0.5 * np.pi):
            raise InputError("must be in [0, pi/2) rad", key="dilation_angle",
                             expected="[0, pi/2)")
        w = w + np.tan(psi) * np.abs(np.asarray(shear_slip, dtype=float))
    return w


def sealing_aperture(gap, max_closure, sealed_aperture):
    """Hydraulic aperture of a crack with a closure law, ``w_inf + max(V_m + g, 0)`` [m].

    A crack at zero effective normal stress has the aperture ``w_0 = w_inf + V_m``; the
    closure law closes it by ``delta(sigma'_n) < V_m`` (the contact gap is then
    ``g = -delta``), so the aperture ``w_0 - delta`` falls towards the sealed ``w_inf`` as
    the effective normal stress rises; an open crack (``g > 0``) has ``w_0 + g``.

    Parameters
    ----------
    gap : array_like, shape (m,)
        Signed normal gap ``g`` of the crack [m] (opening positive, closure negative).
    max_closure : float
        ``V_m > 0`` [m], the closure law's maximum closure.
    sealed_aperture : float
        ``w_inf >= 0`` [m], the aperture of a crack closed to ``V_m``.

    Returns
    -------
    ndarray, shape (m,)
        ``w_h`` [m].
    """
    vm = float(max_closure)
    w_inf = float(sealed_aperture)
    if not (np.isfinite(vm) and vm > 0):
        raise InputError("must be finite and > 0", key="max_closure", expected="> 0")
    if not (np.isfinite(w_inf) and w_inf >= 0):
        raise InputError("must be finite and >= 0", key="sealed_aperture", expected=">= 0")
    return w_inf + np.maximum(vm + np.asarray(gap, dtype=float), 0.0)


def sealing_aperture_derivative(gap, max_closure):
    """``d w_h / d g`` of :func:`sealing_aperture`: 1 until the crack is sealed, then 0."""
    return np.where(float(max_closure) + np.asarray(gap, dtype=float) > 0.0, 1.0, 0.0)


def cubic_law_permeability(hydraulic_aperture_):
    """Parallel-plate permeability ``k_f = w_h^2 / 12`` [m^2] (Eq. 4.2).

    Parameters
    ----------
    hydraulic_aperture_ : array_like
        ``w_h`` [m].
    """
    w = np.asarray(hydraulic_aperture_, dtype=float)
    return w * w / 12.0


def cluster_length_scale(area, trace_length=None):
    """Cell width ``Delta`` perpendicular to the crack [m] used by Eq. 4.3.

    Parameters
    ----------
    area : array_like, shape (m,)
        Cell areas [m^2].
    trace_length : array_like, shape (m,), optional
        Length of the crack trace inside each cell [m]; ``Delta = A / l``. Default
        ``Delta = sqrt(A)`` (a crack crossing a cell of typical size).
    """
    a = np.asarray(area, dtype=float)
    if np.any(a <= 0):
        raise InputError("cell areas must be > 0", key="area")
    if trace_length is None:
        return np.sqrt(a)
    ell = np.asarray(trace_length, dtype=float)
    if np.any(ell <= 0):
        raise InputError("must be > 0", key="trace_length")
    return a / ell


def permeability_multiplier(hydraulic_aperture_, matrix_permeability, length_scale):
    """Permeability multiplier ``PM = 1 + k_f w_h / (k_m Delta)`` (Eq. 4.3), dimensionless.

    Parameters
    ----------
    hydraulic_aperture_ : array_like, shape (m,)
        ``w_h`` [m].
    matrix_permeability : float or array_like, shape (m,)
        ``k_m > 0`` [m^2].
    length_scale : float or array_like, shape (m,)
        ``Delta > 0`` [m], see :func:`cluster_length_scale`.
    """
    w = np.asarray(hydraulic_aperture_, dtype=float)
    km = np.asarray(matrix_permeability, dtype=float)
    d = np.asarray(length_scale, dtype=float)
    if np.any(km <= 0):
        raise InputError("must be > 0 (PM is relative to the matrix)",
                         key="matrix_permeability", expected="> 0")
    if np.any(d <= 0):
        raise InputError("must be > 0", key="length_scale", expected="> 0")
    return 1.0 + cubic_law_permeability(w) * w / (km * d)


def permeability_multiplier_derivative(hydraulic_aperture_, matrix_permeability,
                                       length_scale):
    """``d PM / d w_h = w_h^2 / (4 k_m Delta)`` [1/m] (for the coupled Jacobian)."""
    w = np.asarray(hydraulic_aperture_, dtype=float)
    return w * w / (4.0 * np.asarray(matrix_permeability, dtype=float)
                    * np.asarray(length_scale, dtype=float))


def upscaled_permeability(hydraulic_aperture_, matrix_permeability, length_scale):
    """Cell permeability of a cracked cluster ``k = PM k_m = k_m + w_h^3 / (12 Delta)`` [m^2]."""
    return (permeability_multiplier(hydraulic_aperture_, matrix_permeability, length_scale)
            * np.asarray(matrix_permeability, dtype=float))


def fracture_porosity(fracture_volume, bulk_volume):
    """Fracture porosity ``phi_f = V_f / V_b`` (Eq. 4.4), dimensionless.

    Parameters
    ----------
    fracture_volume : array_like, shape (m,)
        Crack volume in each cell [m^3] (negative values count as 0).
    bulk_volume : array_like, shape (m,)
        Bulk cell volume ``A h`` [m^3].
    """
    vb = np.asarray(bulk_volume, dtype=float)
    if np.any(vb <= 0):
        raise InputError("must be > 0", key="bulk_volume")
    return np.maximum(np.asarray(fracture_volume, dtype=float), 0.0) / vb


def crack_opening(contact_gaps):
    """Normal opening of each failed cluster's crack from its contact gaps.

    A crack crossing a triangle separates one node from the other two; the two contacts
    (sub-edges) it crosses open by ``w |n . e_m|`` (``n`` the crack normal, ``e_m`` the
    contact direction), the third not at all. The cluster's opening is taken as the largest
    contact gap: exact when a crossed edge is normal to the crack, and otherwise a lower
    bound by the factor ``max_m |n . e_m|`` (>= 0.5 for two crossed edges at <= 120
    degrees). It is piecewise linear in the displacements (one active contact), so its
    derivative is that contact's normal-displacement operator.

    Parameters
    ----------
    contact_gaps : array_like, shape (m, 3)
        Opening of each contact [m] (>= 0; 0 when closed or bonded).

    Returns
    -------
    opening : ndarray, shape (m,)
        ``w_n = max_m gap_m`` [m].
    active : ndarray of int, shape (m,)
        Index (0..2) of the contact that gives it.
    """
    g = np.asarray(contact_gaps, dtype=float)
    if g.ndim != 2 or g.shape[1] != 3:
        raise InputError("contact gaps must have shape (m, 3)", key="contact_gaps")
    active = np.argmax(g, axis=1)
    return np.maximum(g[np.arange(len(g)), active], 0.0), active


def crack_permeability(hydraulic_aperture_, matrix_permeability, length_scale):
    """Up-scaled permeability of a cracked cell ``k = k_m + w_h^3 / (12 Delta)`` [m^2].

    The same as :func:`upscaled_permeability` (``PM k_m``, Eq. 4.3) written so that an
    impermeable matrix (``k_m = 0``) is allowed: the crack alone conducts.

    Parameters
    ----------
    hydraulic_aperture_ : array_like, shape (m,)
        ``w_h`` [m].
    matrix_permeability : float or array_like, shape (m,)
        ``k_m >= 0`` [m^2].
    length_scale : float or array_like, shape (m,)
        ``Delta > 0`` [m].
    """
    w = np.asarray(hydraulic_aperture_, dtype=float)
    km = np.asarray(matrix_permeability, dtype=float)
    d = np.asarray(length_scale, dtype=float)
    if np.any(km < 0):
        raise InputError("must be >= 0", key="matrix_permeability", expected=">= 0")
    if np.any(d <= 0):
        raise InputError("must be > 0", key="length_scale", expected="> 0")
    return km + w * w * w / (12.0 * d)


def crack_permeability_derivative(hydraulic_aperture_, length_scale):
    """``dk/dw_h = w_h^2 / (4 Delta)`` [m] of :func:`crack_permeability`."""
    w = np.asarray(hydraulic_aperture_, dtype=float)
    return w * w / (4.0 * np.asarray(length_scale, dtype=float))


@njit(cache=True)
def _crack_fields_kernel(failed, gap, km, length_scale, w_res, k, dk,
                         opening, active):  # pragma: no cover - compiled
    # per cell, the operations of crack_opening, hydraulic_aperture, crack_permeability
    # and its derivative in the same order (the same numbers to the bit)
    for c in range(failed.shape[0]):
        if failed[c]:
            # np.argmax: the first largest, or the first NaN
            a = 0
            best = gap[c, 0]
            if best == best:
                for j in range(1, 3):
                    v = gap[c, j]
                    if v != v:
                        a = j
                        break
                    if v > best:
                        best = v
                        a = j
            v = gap[c, a]
            wn = v if (v > 0.0 or v != v) else 0.0
            wh = w_res + wn
            d = length_scale[c]
            k[c] = km[c] + wh * wh * wh / (12.0 * d)
            dk[c] = wh * wh / (4.0 * d) if wn > 0.0 else 0.0
            opening[c] = wn
            active[c] = a
        else:
            k[c] = km[c]
            dk[c] = 0.0
            opening[c] = 0.0
            active[c] = 0


def crack_fields(failed, contact_gaps, matrix_permeability, length_scale,
                 residual_aperture: float):
    """Permeability of every cell, cracked or not, and what its Jacobian needs, in one pass.

    For the failed cells: the opening ``w_n = max(max_m gap_m, 0)`` and its contact
    (:func:`crack_opening`), ``w_h = w_res + w_n`` (:func:`hydraulic_aperture` without
    dilation), ``k = k_m + w_h^3 / (12 Delta)`` (:func:`crack_permeability`) and
    ``dk/dw_n = w_h^2 / (4 Delta)`` where the crack is open
    (:func:`crack_permeability_derivative`); the other cells keep ``k_m``. The same
    numbers as those functions give, to the bit.

    Parameters
    ----------
    failed : ndarray of bool (m,)
    contact_gaps : ndarray (m, 3) [m]
        Contact openings (used for the failed cells only).
    matrix_permeability : ndarray (m,) [m^2]
        ``k_m >= 0``.
    length_scale : ndarray (m,) [m]
        ``Delta > 0``.
    residual_aperture : float
        ``w_res >= 0`` [m].

    Returns
    -------
    k : ndarray (m,) [m^2]
    dk_dw : ndarray (m,) [m]
        0 where the cell is intact or its crack closed.
    opening : ndarray (m,) [m]
        ``w_n`` of the failed cells, 0 elsewhere.
    active : ndarray of int (m,)
        Contact giving ``w_n`` (0 for intact cells).
    """
    fl = np.ascontiguousarray(failed, dtype=np.bool_)
    m = fl.shape[0]
    g = np.ascontiguousarray(contact_gaps, dtype=np.float64)
    km = np.ascontiguousarray(matrix_permeability, dtype=np.float64)
    d = np.ascontiguousarray(length_scale, dtype=np.float64)
    if fl.ndim != 1 or g.shape != (m, 3) or km.shape != (m,) or d.shape != (m,):
        raise InputError(f"shapes {fl.shape}, {g.shape}, {km.shape}, {d.shape} do not "
                         "match: expected (m,), (m, 3), (m,), (m,)", key="contact_gaps")
    w_res = float(residual_aperture)
    if not (w_res >= 0 and np.isfinite(w_res)):
        raise InputError("must be finite and >= 0", key="residual_aperture", expected=">= 0")
    k = np.empty(m)
    dk = np.empty(m)
    opening = np.empty(m)
    active = np.empty(m, dtype=np.int64)
    _crack_fields_kernel(fl, g, km, d, w_res, k, dk, opening, active)
    return k, dk, opening, active
