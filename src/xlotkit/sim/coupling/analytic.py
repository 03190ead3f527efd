"""Reference solutions for the coupled fracture model.

KGD (plane-strain) hydraulic fracture in the toughness-dominated regime: zero fluid
viscosity (uniform fluid pressure in the crack), impermeable rock, incompressible fracture
fluid, optionally a compressible injection system, fluid storage along the crack and a
pre-existing notch.
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
                  confining_stress: float = 0.0, initial_pressure: float | None = None,
                  crack_storage: float = 0.0) -> KGDSolution:
    """Toughness-dominated KGD fracture at time ``t`` (both wings, per unit height).

    A uniformly pressurised plane-strain crack of half-length ``l`` and net pressure ``p``
    has the elliptical opening ``w(x) = (4 p / E') sqrt(l^2 - x^2)`` and volume
    ``V = 2 pi p l^2 / E'``; it propagates when ``K_I = p sqrt(pi l) = K_IC``. With the
    injected volume shared between the crack, a compressible injection system of
    compliance ``C`` and an optional storage along the crack of ``s`` per unit length of
    crack (both wings: ``2 l s``; fluid at ``sigma + p``, starting from ``p_i``)::

        Q t = V(l, p) + (C + 2 l s) (sigma + p - p_i)

    Growing: ``p = K_IC / sqrt(pi l)``, so ``Q t = 2 sqrt(pi) K_IC l^(3/2) / E'
    + (C + 2 l s) (sigma + K_IC / sqrt(pi l) - p_i)``, solved for ``l`` on the stable
    branch (``l`` at or beyond the minimum of the right side, and at least the notch).
    Without a system compliance, crack storage and notch this is
    ``l = (E' Q t / (2 sqrt(pi) K_IC))^(2/3)``, i.e. Detournay's K-vertex
    ``l = 0.9324 (E' Q t / K')^(2/3)`` with ``K' = 4 sqrt(2/pi) K_IC``. Before the notch
    propagates: ``l = l_notch`` and ``p`` from the same volume balance.

    The crack storage ``s`` is for a model whose crack is a band of finite thickness
    holding fluid in its own pore space, e.g. failed clusters of porosity ``phi`` in a
    band of area ``b`` per unit crack length: ``s = phi c_f b`` (fluid compression; the
    opening itself is ``V``).

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
    crack_storage : float
        ``s`` [m^2/(Pa m)] per unit height: fluid volume stored per unit crack length and
        unit pressure rise besides the opening (0: none). With ``s > 0`` the initial
        pressure must not exceed ``sigma``.

    Returns
    -------
    KGDSolution
    """
    Ep, K, Q, C = float(plane_strain_modulus), float(toughness), float(rate), float(
        system_compliance)
    S = float(crack_storage)
    if not (Ep > 0 and K > 0 and Q > 0 and t >= 0 and C >= 0 and notch_half_length >= 0
            and S >= 0):
        raise InputError("need E' > 0, K_IC > 0, Q > 0, t >= 0, C >= 0, notch >= 0, "
                         "crack storage >= 0", key="kgd")
    sig = float(confining_stress)
    pi0 = sig if initial_pressure is None else float(initial_pressure)
    if S > 0 and pi0 > sig:
        raise InputError("with crack storage the initial pressure must not exceed the "
                         "confining stress", key="kgd.initial_pressure")
    vin = Q * t

    def grow(ell: float) -> float:            # injected volume needed at length ell
        p = K / math.sqrt(math.pi * ell)
        return 2.0 * math.pi * p * ell ** 2 / Ep + (C + 2.0 * ell * S) * (sig + p - pi0)

    # the stable branch starts where d(grow)/dl = 0; times l^(3/2):
    # 3 sqrt(pi) K l^2 / E' + 2 S (sig - p_i) l^(3/2) + S K l / sqrt(pi)
    #   - C K / (2 sqrt(pi)) = 0, increasing in l (sig >= p_i when S > 0);
    # S = 0: l* = (C E' / (6 pi))^(1/2)
    if C <= 0:
        l_star = 0.0
    elif S == 0:
        l_star = math.sqrt(C * Ep / (6.0 * math.pi))
    else:
        rpi = math.sqrt(math.pi)

        def slope(ell: float) -> float:
            return (3.0 * rpi * K * ell ** 2 / Ep + 2.0 * S * (sig - pi0) * ell ** 1.5
                    + S * K * ell / rpi - C * K / (2.0 * rpi))

        hi_s = math.sqrt(C * Ep / (6.0 * math.pi))   # the root without S: an upper bound
        l_star = (brentq(slope, 0.0, hi_s, xtol=1e-15, rtol=1e-13) if slope(hi_s) > 0
                  else hi_s)
    l_min = max(l_star, notch_half_length)
    if l_min > 0 and vin <= grow(l_min):
        ell = notch_half_length
        if ell <= 0:
            # no notch and the system is still being compressed: no crack yet
            p = (vin / C + pi0 - sig) if C > 0 else 0.0
            return KGDSolution(0.0, p, 0.0, 0.0, False)
        # static notch: Q t = 2 pi p l^2 / E' + (C + 2 l S) (sig + p - p_i), linear in p
        cs = C + 2.0 * ell * S
        p = (vin - cs * (sig - pi0)) / (2.0 * math.pi * ell ** 2 / Ep + cs)
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
