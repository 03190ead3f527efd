"""Compiled face loop of the finite-volume flow: upwinded two-point mass fluxes.

:func:`face_fluxes` checks and allocates, then runs a private ``@njit(cache=True)`` kernel
over the connections; :meth:`~xlotkit.sim.flow.FlowModel.residual_and_jacobian` calls it
(the NumPy form it replaced is the reference in ``tests/sim/test_kernels.py``).

For a connection from unknown ``a`` to unknown ``b`` with transmissibility ``T`` [m^3] the
mass rate from ``b`` into ``a`` is ``F = lam_up T (x_b - x_a)`` with ``lam = rho(x)/mu``
taken upstream (``a`` when ``x_b < x_a``); with ``rho = rho0 exp(c_f (p - p_ref))``,
``d lam / dp = c_f lam``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from xlotkit.errors import InputError

__all__ = ["face_fluxes"]


@njit(cache=True)
def _face_kernel(x, lam, cf, T, a, b, F, dFa, dFb):  # pragma: no cover - compiled
    for k in range(a.shape[0]):
        ia = a[k]
        ib = b[k]
        d = x[ib] - x[ia]
        t = T[k]
        if d < 0.0:
            # flow from a to b: a is upstream
            lu = lam[ia]
            dFa[k] = t * (cf * lu * d - lu)
            dFb[k] = t * lu
        else:
            lu = lam[ib]
            dFa[k] = -t * lu
            dFb[k] = t * (cf * lu * d + lu)
        F[k] = lu * t * d


def face_fluxes(x, lam, compressibility: float, T, a, b):
    """Upwinded mass rates of two-point connections and their derivatives.

    Parameters
    ----------
    x : ndarray (n,) [Pa]
        Unknown pressures (cells, then the well).
    lam : ndarray (n,) [kg/(m^3 Pa s)]
        Mobility ``rho(x) / mu`` of every unknown.
    compressibility : float
        ``c_f`` [1/Pa] (``d lam / dp = c_f lam``).
    T : ndarray (k,) [m^3]
        Transmissibility of each connection.
    a, b : ndarray of int (k,)
        The two unknowns of each connection.

    Returns
    -------
    F : ndarray (k,) [kg/s]
        Mass rate from ``b`` into ``a``.
    dF_da, dF_db : ndarray (k,) [kg/(s Pa)]
        Its derivatives with respect to ``x_a`` and ``x_b``.
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    lam = np.ascontiguousarray(lam, dtype=np.float64)
    T = np.ascontiguousarray(T, dtype=np.float64)
    a = np.ascontiguousarray(a, dtype=np.int64)
    b = np.ascontiguousarray(b, dtype=np.int64)
    n = x.shape[0]
    if x.ndim != 1 or lam.shape != (n,):
        raise InputError(f"x and lam must be 1D of equal length, got {x.shape}, {lam.shape}",
                         key="x")
    k = a.shape[0]
    if a.ndim != 1 or b.shape != (k,) or T.shape != (k,):
        raise InputError(f"a, b and T must be 1D of equal length, got {a.shape}, {b.shape}, "
                         f"{T.shape}", key="T")
    if k and (min(a.min(), b.min()) < 0 or max(a.max(), b.max()) >= n):
        raise InputError(f"connection index out of range [0, {n})", key="a")
    F = np.empty(k)
    dFa = np.empty(k)
    dFb = np.empty(k)
    _face_kernel(x, lam, float(compressibility), T, a, b, F, dFa, dFb)
    return F, dFa, dFb
