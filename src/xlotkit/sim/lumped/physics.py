"""The lumped model's fracture and leak-off closed forms (SI; see :mod:`xlotkit.sim.lumped`).

Geometry switches over :mod:`xlotkit.formulas` (Sneddon volumes, LEFM stress intensity) and
the lumped model's own: the stable length against well storage, the face area, Carter's
unit leak of area opened linearly over a step.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from xlotkit import formulas

__all__ = [
    "breakdown_pressure",
    "critical_net_pressure",
    "fracture_compliance",
    "fracture_face_area",
    "fracture_volume",
    "reopening_pressure",
    "stable_length",
    "stress_intensity",
    "wall_leak_index",
]

Geometry = Literal["kgd", "penny"]
Reopening = Literal["wellbore", "sigma_h"]


def breakdown_pressure(sigma_h: float, sigma_H: float, pore_pressure: float,
                       tensile_strength: float) -> float:
    """Hubbert–Willis breakdown pressure ``3 sigma_h - sigma_H - p0 + T0`` [Pa] (Eq. C.11;
    :func:`xlotkit.formulas.hubbert_willis`)."""
    return formulas.hubbert_willis(sigma_h, sigma_H, pore_pressure, tensile_strength)


def reopening_pressure(sigma_h: float, sigma_H: float, pore_pressure: float,
                       model: Reopening = "wellbore") -> float:
    """Well pressure that reopens a closed fracture [Pa].

    ``"wellbore"``: the fracture mouth sits in the borehole wall, whose hoop stress must be
    overcome again, now without tensile strength (thesis Eq. C.13,
    :func:`xlotkit.formulas.reopening_pressure`)::

        P_r = max(sigma_h, 3 sigma_h - sigma_H - p_0)

    (the ``max``: where the wall's hoop stress is below ``sigma_h``, i.e.
    ``sigma_H > 2 sigma_h - p_0``, the far field still holds the faces shut up to
    ``sigma_h``). ``"sigma_h"``: ``P_r = sigma_h`` (a fracture open to the well all along).
    """
    if model == "sigma_h":
        return sigma_h
    return formulas.wellbore_reopening_pressure(sigma_h, sigma_H, pore_pressure)


def fracture_volume(net_pressure: float, size: float, geometry: Geometry, e_prime: float,
                    height: float = 1.0) -> float:
    """Sneddon opening volume [m^3]; 0 for a closed fracture (``net_pressure <= 0``).

    KGD: ``2 pi h L^2 dp / E'`` (``size`` = half-length L); penny: ``16 R^3 dp / (3 E')``
    (:func:`xlotkit.formulas.kgd_volume`, :func:`~xlotkit.formulas.penny_volume`).
    """
    if net_pressure <= 0.0:
        return 0.0
    if geometry == "kgd":
        return formulas.kgd_volume(net_pressure, size, height, e_prime)
    return formulas.penny_volume(net_pressure, size, e_prime)


def fracture_compliance(size: float, geometry: Geometry, e_prime: float,
                        height: float = 1.0) -> float:
    """``dV_f/dp`` of an open fracture at fixed size [m^3/Pa] (inverse of Eq. C.3 for penny)."""
    return fracture_volume(1.0, size, geometry, e_prime, height)


def stress_intensity(net_pressure: float, size: float, geometry: Geometry) -> float:
    """Mode-I stress intensity [Pa m^0.5]: ``dp sqrt(pi L)`` (KGD), ``(2/pi) dp sqrt(pi R)``."""
    if geometry == "kgd":
        return formulas.kgd_stress_intensity(net_pressure, size)
    return formulas.penny_stress_intensity(net_pressure, size)


def critical_net_pressure(size: float, geometry: Geometry, toughness: float) -> float:
    """Net pressure at which ``K_I = K_Ic`` [Pa] for a fracture of ``size`` [m]."""
    if geometry == "kgd":
        return formulas.kgd_critical_net_pressure(size, toughness)
    return formulas.penny_critical_net_pressure(size, toughness)


def fracture_face_area(size: float, geometry: Geometry, height: float = 1.0) -> float:
    """Area of one fracture face [m^2]: ``2 L h`` (KGD, both wings) or ``pi R^2``."""
    return 2.0 * size * height if geometry == "kgd" else math.pi * size * size


def stable_length(well_compliance: float, geometry: Geometry, e_prime: float,
                  height: float = 1.0) -> float:
    """Smallest fracture size [m] that can propagate stably against well storage ``C_w``.

    KGD: ``sqrt(C_w E' / (6 pi h))``; penny: ``(3 C_w E' / 80)^(1/3)`` (see module docs).
    """
    if geometry == "kgd":
        return math.sqrt(well_compliance * e_prime / (6.0 * math.pi * height))
    return (3.0 * well_compliance * e_prime / 80.0) ** (1.0 / 3.0)


#: Steady radial productivity of the open-hole wall (:func:`xlotkit.formulas.wall_leak_index`).
wall_leak_index = formulas.wall_leak_index


def _carter_unit(t: float, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Leaked volume per face and per unit C_L by time t from unit area opened linearly over
    [a, b] (or at once when b == a): ``(4/3) [(t-a)^1.5 - (t-b)^1.5] / (b-a)``."""
    ta = np.maximum(t - a, 0.0)
    tb = np.maximum(t - b, 0.0)
    w = b - a
    inst = w <= 0.0
    w = np.where(inst, 1.0, w)
    sa = np.sqrt(ta)
    lin = (4.0 / 3.0) * (ta * sa - tb * np.sqrt(tb)) / w
    return np.where(inst, 2.0 * sa, lin)
