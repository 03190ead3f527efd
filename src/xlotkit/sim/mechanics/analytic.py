"""Analytic solutions used to verify the mechanics (compression positive, SI).

* Kirsch stresses around a pressurised circular hole in an infinite plate (thesis Eq. C.7);
* Hubbert-Willis breakdown pressure of an impermeable wall (Eq. C.11);
* Sneddon's opening of a pressurised plane-strain crack.
"""

from __future__ import annotations

import numpy as np

__all__ = ["hubbert_willis", "kirsch_cartesian", "kirsch_polar", "sneddon_width"]


def kirsch_polar(r, theta, radius, sigma_H, sigma_h, wall_pressure):
    """Kirsch stresses (Eq. C.7), compression positive.

    Parameters
    ----------
    r : array_like
        Distance from the hole centre [m], ``>= radius``.
    theta : array_like
        Angle from the direction of ``sigma_H`` [rad].
    radius : float
        Hole radius [m].
    sigma_H, sigma_h : float
        Far-field principal stresses [Pa] (``sigma_H`` along ``theta = 0``).
    wall_pressure : float
        Pressure in the hole [Pa].

    Returns
    -------
    sigma_r, sigma_theta, sigma_rtheta : ndarray
        ``sigma_r = S(1 - q) + D(1 + 3q^2 - 4q) cos 2t + p q``,
        ``sigma_t = S(1 + q) - D(1 + 3q^2) cos 2t - p q``,
        ``sigma_rt = -D(1 - 3q^2 + 2q) sin 2t``, with ``q = a^2/r^2``,
        ``S = (sH + sh)/2``, ``D = (sH - sh)/2``.
    """
    r = np.asarray(r, dtype=float)
    t = np.asarray(theta, dtype=float)
    q = (radius / r) ** 2
    S = 0.5 * (sigma_H + sigma_h)
    D = 0.5 * (sigma_H - sigma_h)
    c2, s2 = np.cos(2 * t), np.sin(2 * t)
    sr = S * (1 - q) + D * (1 + 3 * q ** 2 - 4 * q) * c2 + wall_pressure * q
    st = S * (1 + q) - D * (1 + 3 * q ** 2) * c2 - wall_pressure * q
    srt = -D * (1 - 3 * q ** 2 + 2 * q) * s2
    return sr, st, srt


def kirsch_cartesian(x, y, radius, sigma_x, sigma_y, sigma_xy, wall_pressure):
    """Kirsch stresses in Cartesian components for a general far field.

    Parameters
    ----------
    x, y : array_like
        Coordinates relative to the hole centre [m].
    sigma_x, sigma_y, sigma_xy : float
        Far-field stress components [Pa], compression positive.

    Returns
    -------
    ndarray (..., 3)
        ``(sigma_xx, sigma_yy, sigma_xy)`` [Pa], compression positive.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    c = 0.5 * (sigma_x + sigma_y)
    rr = np.hypot(0.5 * (sigma_x - sigma_y), sigma_xy)
    sH, sh = c + rr, c - rr
    phi = 0.5 * np.arctan2(2 * sigma_xy, sigma_x - sigma_y)  # direction of sigma_H
    r = np.hypot(x, y)
    ang = np.arctan2(y, x)
    sr, st, srt = kirsch_polar(r, ang - phi, radius, sH, sh, wall_pressure)
    cs, sn = np.cos(ang), np.sin(ang)
    sxx = sr * cs ** 2 + st * sn ** 2 - 2 * srt * sn * cs
    syy = sr * sn ** 2 + st * cs ** 2 + 2 * srt * sn * cs
    sxy = (sr - st) * sn * cs + srt * (cs ** 2 - sn ** 2)
    return np.stack([sxx, syy, sxy], axis=-1)


def hubbert_willis(sigma_H, sigma_h, pore_pressure, tensile_strength):
    """Breakdown pressure of an impermeable wall ``3 sh - sH - p0 + T`` [Pa] (Eq. C.11)."""
    return 3.0 * sigma_h - sigma_H - pore_pressure + tensile_strength


def sneddon_width(x, half_length, pressure, young, poisson):
    """Opening of a pressurised plane-strain crack (Sneddon) [m].

    ``w(x) = 4 p (1 - nu^2) / E * sqrt(a^2 - x^2)`` for ``|x| < a``, 0 outside; the
    maximum ``4 p (1 - nu^2) a / E`` is at the centre.
    """
    x = np.asarray(x, dtype=float)
    return 4.0 * pressure * (1.0 - poisson ** 2) / young * np.sqrt(
        np.maximum(half_length ** 2 - x ** 2, 0.0))
