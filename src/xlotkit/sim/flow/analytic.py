"""Reference solutions of radial flow for verifying the flow solver (SPEC §8).

All for linear diffusion of a slightly compressible fluid in a homogeneous, infinite
(or closed outer radius) reservoir of thickness ``h``::

    phi c_t dp/dt = (k / mu) (1/r) d/dr (r dp/dr),     eta = k / (mu phi c_t)   [m^2/s]

* :func:`line_source_pressure` -- constant rate ``q`` from a line source (Theis)::

      p(r, t) = p0 + q mu / (4 pi k h) E1(r^2 / (4 eta t))

* :func:`constant_pressure_radial` -- well of radius ``r_w`` held at ``p_w`` from ``t = 0``
  (van Everdingen & Hurst): Laplace-domain solutions in the dimensionless variables
  ``r_D = r / r_w``, ``t_D = eta t / r_w^2``, inverted numerically by Stehfest::

      p_D(r_D, s) = K0(r_D sqrt(s)) / (s K0(sqrt(s)))          p_D = (p - p0)/(p_w - p0)
      Q_D(s)      = K1(sqrt(s)) / (s^{3/2} K0(sqrt(s)))         V = 2 pi phi c_t h r_w^2 dp Q_D

* :func:`radial_reference` -- a fine 1D radial finite-volume solution (log-spaced cells,
  exact log-profile transmissibilities, backward Euler on a geometric time grid) for either
  well condition, with optional well storage; used where no closed form exists and tested
  against the two above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.linalg import solve_banded
from scipy.special import exp1, k0e, k1e

from xlotkit.errors import InputError

__all__ = [
    "RadialSolution",
    "constant_pressure_radial",
    "constant_rate_radial",
    "line_source_pressure",
    "radial_reference",
    "stehfest_coefficients",
    "stehfest_invert",
]


def line_source_pressure(r, t, *, rate, viscosity, permeability, height, porosity,
                         total_compressibility, p0=0.0):
    """Line-source (exponential-integral) pressure [Pa] for a constant rate.

    Parameters
    ----------
    r : array_like
        Radius [m].
    t : array_like
        Time since the start of injection [s] (> 0).
    rate : float
        Volume rate at reservoir conditions [m^3/s], positive for injection.
    viscosity, permeability, height, porosity, total_compressibility : float
        ``mu`` [Pa s], ``k`` [m^2], ``h`` [m], ``phi`` [-], ``c_t`` [1/Pa].
    p0 : float
        Initial pressure [Pa].
    """
    eta = permeability / (viscosity * porosity * total_compressibility)
    u = np.asarray(r, dtype=float) ** 2 / (4.0 * eta * np.asarray(t, dtype=float))
    return p0 + rate * viscosity / (4.0 * math.pi * permeability * height) * exp1(u)


def stehfest_coefficients(n: int = 14) -> np.ndarray:
    """Stehfest weights ``V_i``, ``i = 1..n`` (``n`` even), shape (n,)."""
    if n % 2 or n < 2 or n > 30:
        raise InputError("must be even, 2..30", key="stehfest.n")
    half = n // 2
    v = np.zeros(n)
    for i in range(1, n + 1):
        s = 0.0
        for k in range(((i + 1) // 2), min(i, half) + 1):
            s += (k ** half * math.factorial(2 * k)
                  / (math.factorial(half - k) * math.factorial(k) * math.factorial(k - 1)
                     * math.factorial(i - k) * math.factorial(2 * k - i)))
        v[i - 1] = (-1) ** (half + i) * s
    return v


def stehfest_invert(F: Callable[[np.ndarray], np.ndarray], t, n: int = 14) -> np.ndarray:
    """Numerical inverse Laplace transform ``f(t) ~ ln2/t sum_i V_i F(i ln2 / t)``.

    Good (5-7 digits in double precision with ``n`` = 12-16) for the smooth, monotone
    functions of diffusion problems; not for oscillating ones.

    Parameters
    ----------
    F : callable
        Laplace transform, vectorised over ``s``.
    t : array_like
        Times (> 0).
    n : int
        Number of terms (even).
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    v = stehfest_coefficients(n)
    a = math.log(2.0) / t
    i = np.arange(1, n + 1)
    s = a[:, None] * i[None, :]
    return a * np.sum(v[None, :] * F(s), axis=1)


def constant_rate_radial(r, t, *, well_radius, rate, permeability, viscosity, porosity,
                         total_compressibility, height=1.0, well_storage=0.0, n: int = 14):
    """Constant rate into a well of finite radius with storage, infinite reservoir.

    The van Everdingen-Hurst solution with wellbore storage (no skin): with
    ``C_D = C_w / (2 pi phi c_t h r_w^2)`` and ``p_D = 2 pi k h (p - p0) / (q mu)``::

        p_D(r_D, s) = K0(r_D sqrt(s)) / (s [sqrt(s) K1(sqrt(s)) + C_D s K0(sqrt(s))])

    inverted by Stehfest. ``r = r_w`` gives the well pressure. Approaches the line source
    :func:`line_source_pressure` when ``eta t / r^2`` is large.

    Parameters
    ----------
    r : array_like, shape (nr,)
        Radii [m] (>= ``well_radius``).
    t : array_like, shape (nt,)
        Times [s] (> 0).
    rate : float
        Injection rate [m^3/s] (reservoir volume).
    well_storage : float
        ``C_w`` [m^3/Pa].

    Returns
    -------
    ndarray, shape (nt, nr)
        ``p(r, t) - p0`` [Pa].
    """
    r = np.atleast_1d(np.asarray(r, dtype=float))
    t = np.atleast_1d(np.asarray(t, dtype=float))
    eta = permeability / (viscosity * porosity * total_compressibility)
    td = eta * t / well_radius ** 2
    cd = well_storage / (2.0 * math.pi * porosity * total_compressibility * height
                         * well_radius ** 2)
    scale = rate * viscosity / (2.0 * math.pi * permeability * height)
    out = np.empty((len(t), len(r)))
    for j, rj in enumerate(r):
        rd = rj / well_radius

        def F(s, rd=rd):
            q = np.sqrt(s)
            k0, k1 = k0e(q), k1e(q)
            # exponentially scaled Bessel functions: K(x) = Ke(x) exp(-x)
            return k0e(rd * q) * np.exp(-(rd - 1.0) * q) / (s * (q * k1 + cd * s * k0))
        out[:, j] = scale * stehfest_invert(F, td, n)
    return out


def _pd_laplace(r_d):
    def F(s):
        q = np.sqrt(s)
        return k0e(r_d * q) / (s * k0e(q)) * np.exp(-(r_d - 1.0) * q)
    return F


def _qd_laplace(s):
    q = np.sqrt(s)
    return k1e(q) / (s * q * k0e(q))


def constant_pressure_radial(r, t, *, well_radius, dp, permeability, viscosity, porosity,
                             total_compressibility, height=1.0, n: int = 14):
    """Well held at ``p0 + dp`` from ``t = 0`` in an infinite radial reservoir.

    Parameters
    ----------
    r : array_like, shape (nr,)
        Radii [m] (>= ``well_radius``).
    t : array_like, shape (nt,)
        Times [s] (> 0).
    well_radius : float
        ``r_w`` [m].
    dp : float
        Well pressure step ``p_w - p0`` [Pa].
    permeability, viscosity, porosity, total_compressibility, height : float

    Returns
    -------
    dp_field : ndarray, shape (nt, nr)
        ``p(r, t) - p0`` [Pa].
    cumulative : ndarray, shape (nt,)
        Cumulative volume influx (reservoir volume) [m^3].
    """
    r = np.atleast_1d(np.asarray(r, dtype=float))
    t = np.atleast_1d(np.asarray(t, dtype=float))
    eta = permeability / (viscosity * porosity * total_compressibility)
    td = eta * t / well_radius ** 2
    out = np.empty((len(t), len(r)))
    for j, rj in enumerate(r):
        out[:, j] = stehfest_invert(_pd_laplace(rj / well_radius), td, n)
    vol = (2.0 * math.pi * porosity * total_compressibility * height * well_radius ** 2 * dp
           * stehfest_invert(_qd_laplace, td, n))
    return dp * out, vol


@dataclass(frozen=True, eq=False)
class RadialSolution:
    """1D radial reference solution.

    Attributes
    ----------
    r : ndarray, shape (nr,)
        Cell-centre radii [m].
    times : ndarray, shape (nt,)
    p : ndarray, shape (nt, nr)
        Pressures [Pa].
    p_w : ndarray, shape (nt,)
        Well pressure [Pa].
    cumulative : ndarray, shape (nt,)
        Cumulative volume that entered the formation [m^3] (``phi c_t``-weighted storage
        integral, i.e. reservoir volume).
    """

    r: np.ndarray
    times: np.ndarray
    p: np.ndarray
    p_w: np.ndarray
    cumulative: np.ndarray

    def at(self, r) -> np.ndarray:
        """Pressure interpolated in ``ln r`` at radii ``r``, shape (nt, len(r))."""
        r = np.atleast_1d(np.asarray(r, dtype=float))
        lr = np.log(self.r)
        return np.array([np.interp(np.log(r), lr, row) for row in self.p])


def radial_reference(times, *, well_radius, outer_radius, permeability, viscosity, porosity,
                     total_compressibility, height=1.0, p0=0.0, well_pressure=None,
                     rate=None, well_storage=0.0, n_cells=400, steps_per_decade=200,
                     t_first=None) -> RadialSolution:
    """Fine 1D radial finite-volume solution (closed outer radius).

    Exactly one of ``well_pressure`` (the well held at that pressure from ``t = 0``) and
    ``rate`` (constant injection [m^3/s] into a well of storage ``well_storage`` [m^3/Pa])
    must be given. Cells are log-spaced between ``well_radius`` and ``outer_radius``; the
    face transmissibility ``2 pi k h / (mu ln(r_{i+1}/r_i))`` is exact for the logarithmic
    near-well profile. Backward Euler on a geometric time grid with ``steps_per_decade``
    steps per decade from ``t_first`` (default ``1e-4 r_w^2 / eta``), landing on ``times``.

    Returns
    -------
    RadialSolution
    """
    if (well_pressure is None) == (rate is None):
        raise InputError("give exactly one of well_pressure and rate", key="radial_reference")
    times = np.sort(np.atleast_1d(np.asarray(times, dtype=float)))
    lam = permeability / viscosity
    store_c = porosity * total_compressibility
    eta = lam / store_c
    faces = np.geomspace(well_radius, outer_radius, n_cells + 1)
    rc = np.sqrt(faces[:-1] * faces[1:])
    vol = math.pi * (faces[1:] ** 2 - faces[:-1] ** 2) * height
    S = store_c * vol                                    # [m^3/Pa]
    Tf = 2 * math.pi * lam * height / np.log(rc[1:] / rc[:-1])   # between cells
    Tw = 2 * math.pi * lam * height / math.log(rc[0] / well_radius)
    t_first = 1e-4 * well_radius ** 2 / eta if t_first is None else t_first
    n_dec = max(math.log10(times[-1] / t_first), 0.0)
    grid = np.geomspace(t_first, times[-1], int(n_dec * steps_per_decade) + 2)
    grid = np.unique(np.concatenate([[0.0], grid, times]))
    n = n_cells + 1  # unknown 0 = well
    p = np.full(n, float(p0))
    if well_pressure is not None:
        p[0] = well_pressure
    cum = 0.0
    out_p, out_w, out_c = [], [], []
    ti = 0
    for k in range(1, len(grid)):
        dt = grid[k] - grid[k - 1]
        # banded (tridiagonal) system A p_new = b
        diag = np.empty(n)
        upper = np.zeros(n)
        lower = np.zeros(n)
        b = np.empty(n)
        diag[1:] = S / dt
        b[1:] = S / dt * p[1:]
        tl = np.concatenate([[Tw], Tf])          # face to the left of cell i (i = 1..)
        diag[1:] += tl
        diag[1:-1] += Tf
        lower[:-1] = -tl                         # A[i, i-1] stored at lower[i-1]
        upper[2:] = -Tf                          # A[i, i+1] stored at upper[i+1]
        if well_pressure is not None:
            diag[0] = 1.0
            upper[1] = 0.0
            b[0] = well_pressure
        else:
            diag[0] = well_storage / dt + Tw
            upper[1] = -Tw
            b[0] = well_storage / dt * p[0] + rate
        ab = np.vstack([upper, diag, lower])
        p_new = solve_banded((1, 1), ab, b)
        cum += dt * Tw * (p_new[0] - p_new[1])
        p = p_new
        while ti < len(times) and grid[k] >= times[ti] * (1 - 1e-14):
            out_p.append(p[1:].copy())
            out_w.append(p[0])
            out_c.append(cum)
            ti += 1
    return RadialSolution(r=rc, times=times, p=np.array(out_p), p_w=np.array(out_w),
                          cumulative=np.array(out_c))
