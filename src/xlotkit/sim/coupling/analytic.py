"""Reference solutions for the coupled fracture model.

KGD (plane-strain) hydraulic fracture in the toughness-dominated regime: zero fluid
viscosity (uniform fluid pressure in the crack), impermeable rock, incompressible fracture
fluid, optionally a compressible injection system and a pre-existing notch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.optimize import brentq

from xlotkit.errors import InputError

__all__ = ["KGDSolution", "kgd_toughness"]


@dataclass(frozen=True)
class KGDSolution:
    """KGD state at one time.

    Attributes
    ----------
    half_length : float
        ``l`` [m] (centre to tip).
    net_pressure : float
        Fluid pressure minus the confining stress normal to the crack [Pa].
    mouth_opening : float
        Opening at the centre ``w0 = 4 p l / E'`` [m].
    volume : float
        Crack volume per unit height ``V = 2 pi p l^2 / E'`` [m^2].
    propagating : bool
        False while the pressure is still below the notch's propagation pressure.
    """

    half_length: float
    net_pressure: float
    mouth_opening: float
    volume: float
    propagating: bool


def kgd_toughness(t: float, rate: float, plane_strain_modulus: float, toughness: float, *,
                  notch_half_length: float = 0.0, system_compliance: float = 0.0,
                  confining_stress: float = 0.0, initial_pressure: float | None = None
                  ) -> KGDSolution:
    """Toughness-dominated KGD fracture at time ``t`` (both wings, per unit height).

    A uniformly pressurised plane-strain crack of half-length ``l`` and net pressure ``p``
    has the elliptical opening ``w(x) = (4 p / E') sqrt(l^2 - x^2)`` and volume
    ``V = 2 pi p l^2 / E'``; it propagates when ``K_I = p sqrt(pi l) = K_IC``. With the
    injected volume shared between the crack and a compressible injection system of
    compliance ``C`` (fluid at ``sigma + p``, starting from ``p_i``)::

        Q t = V(l, p) + C (sigma + p - p_i)

    Growing: ``p = K_IC / sqrt(pi l)``, so ``Q t = 2 sqrt(pi) K_IC l^(3/2) / E'
    + C (sigma + K_IC / sqrt(pi l) - p_i)``, solved for ``l`` on the stable branch
    (``l`` at or beyond the minimum of the right side, and at least the notch). Without a
    system compliance and a notch this is ``l = (E' Q t / (2 sqrt(pi) K_IC))^(2/3)``, i.e.
    Detournay's K-vertex ``l = 0.9324 (E' Q t / K')^(2/3)`` with ``K' = 4 sqrt(2/pi) K_IC``.
    Before the notch propagates: ``l = l_notch`` and ``p`` from the same volume balance.

    Parameters
    ----------
    t : float
        Time since the start of injection [s], >= 0.
    rate : float
        Injection rate per unit height ``Q`` [m^2/s], > 0.
    plane_strain_modulus : float
        ``E' = E / (1 - nu^2)`` [Pa].
    toughness : float
        ``K_IC`` [Pa m^0.5], > 0.
    notch_half_length : float
        Pre-existing crack half-length [m] (0: none).
    system_compliance : float
        ``C`` [m^2/Pa] per unit height (well + hole fluid, ``V_sys c_f``); 0 for an
        incompressible system.
    confining_stress : float
        Stress normal to the crack ``sigma`` [Pa].
    initial_pressure : float, optional
        System pressure at ``t = 0`` [Pa]; default ``sigma`` (no storage term at the
        start).

    Returns
    -------
    KGDSolution
    """
    Ep, K, Q, C = float(plane_strain_modulus), float(toughness), float(rate), float(
        system_compliance)
    if not (Ep > 0 and K > 0 and Q > 0 and t >= 0 and C >= 0 and notch_half_length >= 0):
        raise InputError("need E' > 0, K_IC > 0, Q > 0, t >= 0, C >= 0, notch >= 0",
                         key="kgd")
    sig = float(confining_stress)
    pi0 = sig if initial_pressure is None else float(initial_pressure)
    vin = Q * t

    def grow(ell: float) -> float:            # injected volume needed at length ell
        p = K / math.sqrt(math.pi * ell)
        return 2.0 * math.pi * p * ell ** 2 / Ep + C * (sig + p - pi0)

    # the stable branch starts where d(grow)/dl = 0: 3 sqrt(pi) K sqrt(l)/E' =
    # C K / (2 sqrt(pi) l^(3/2))  ->  l* = (C E' / (6 pi))^(1/2)
    l_min = max(math.sqrt(C * Ep / (6.0 * math.pi)), notch_half_length)
    if l_min > 0 and vin <= grow(l_min):
        ell = notch_half_length
        if ell <= 0:
            # no notch and the system is still being compressed: no crack yet
            p = (vin / C + pi0 - sig) if C > 0 else 0.0
            return KGDSolution(0.0, p, 0.0, 0.0, False)
        # static notch: Q t = 2 pi p l^2 / E' + C (sig + p - p_i), linear in p
        p = (vin - C * (sig - pi0)) / (2.0 * math.pi * ell ** 2 / Ep + C)
        if p < K / math.sqrt(math.pi * ell):
            return KGDSolution(ell, p, 4.0 * p * ell / Ep, 2.0 * math.pi * p * ell ** 2 / Ep,
                               False)
    lo = l_min if l_min > 0 else 1e-300
    hi = max(2.0 * lo, 1.0)
    while grow(hi) < vin:
        hi *= 2.0
    if vin <= grow(lo):
        ell = lo
    else:
        ell = brentq(lambda x: grow(x) - vin, lo, hi, xtol=1e-15, rtol=1e-13)
    p = K / math.sqrt(math.pi * ell)
    return KGDSolution(ell, p, 4.0 * p * ell / Ep, 2.0 * math.pi * p * ell ** 2 / Ep, True)
