"""Fracture closure laws: the normal stress a closed crack carries against its closure, and
its hydraulic aperture (SPEC §3-4, thesis 4.7).

Small pure functions over arrays, SI units, compression positive. A crack face pair that
touches carries the effective normal stress ``sigma_n >= 0`` [Pa] at the closure
``delta >= 0`` [m] (how far the faces have moved towards each other since they touched at
zero stress). The laws:

``smooth`` (default)
    The former contact law: a closed contact is a linear spring of the contact's own
    stiffness ``k_n`` (the intact micro-stiffness, :class:`~xlotkit.sim.mechanics.
    MechanicsModel`), so a closed crack is nearly as stiff as the rock, and the hydraulic
    aperture of a closed crack is the constant residual aperture ``w_res``.

``barton_bandis`` (Bandis, Lumsden & Barton 1983)
    The hyperbola of a rough joint closing onto its asperities::

        delta(sigma) = sigma V_m / (K_ni V_m + sigma)
        sigma(delta) = K_ni delta / (1 - delta / V_m)
        k(delta) = d sigma / d delta = K_ni / (1 - delta / V_m)^2

    ``K_ni`` [Pa/m] the initial normal stiffness, ``V_m`` [m] the maximum closure.

``exponential``
    Closure that saturates exponentially with the effective normal stress (the
    aperture-stress law of Rutqvist & Tsang type)::

        delta(sigma) = V_m (1 - exp(-sigma / sigma_r))
        sigma(delta) = -sigma_r ln(1 - delta / V_m)
        k(delta) = sigma_r / (V_m - delta)

    ``sigma_r`` [Pa] the reference stress (``K_ni = sigma_r / V_m``).

Both closure laws go to infinity at ``delta = V_m``. So that a Newton iterate that
overshoots stays finite, :func:`stress_of_closure` continues each law along its tangent
beyond ``delta_c = (1 - CAP) V_m`` (``CAP`` = :data:`CLOSURE_CAP`): the law is C1 and
monotone everywhere, and the continuation is reached only at stresses of ``1/CAP`` times
``K_ni V_m`` (Barton-Bandis) or ``ln(1/CAP) sigma_r`` (exponential), where the hydraulic
aperture is at its sealed value already.

Hydraulic aperture (the closure laws; the relation itself is
:func:`xlotkit.sim.flow.fracture.sealing_aperture`): a crack at zero effective normal
stress has the aperture ``w_0 = w_inf + V_m``; closing by ``delta`` leaves
``w_0 - delta``, never below the sealed aperture ``w_inf``; opened by ``g > 0`` (the
contact gap) it is ``w_0 + g``. With ``g`` the signed contact gap (``g = -delta`` when
closed) this is one formula::

    w_h = w_inf + max(V_m + g, 0)

so under a rising effective normal stress the aperture falls from ``w_0`` towards
``w_inf`` along ``w_0 - delta(sigma)``: the crack mouth seals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from xlotkit.errors import InputError

__all__ = [
    "CLOSURE_CAP",
    "CLOSURE_LAWS",
    "ClosureLaw",
    "closure_of_stress",
    "stress_of_closure",
]

#: The closure laws a scene can ask for (``rock.closure_law``).
CLOSURE_LAWS = ("smooth", "barton_bandis", "exponential")

#: Fraction of the maximum closure left when the laws continue along their tangent
#: (module docstring): 1e-4 puts the continuation at 1e4 K_ni V_m (Barton-Bandis) and at
#: 9.2 sigma_r (exponential), where the aperture is within 1e-4 V_m of the sealed value.
CLOSURE_CAP = 1e-4


@dataclass(frozen=True)
class ClosureLaw:
    """A fracture closure law and its parameters (module docstring).

    Parameters
    ----------
    kind : {"smooth", "barton_bandis", "exponential"}
    normal_stiffness : float, optional
        ``K_ni`` [Pa/m] (Barton-Bandis only), > 0.
    max_closure : float, optional
        ``V_m`` [m] (Barton-Bandis, exponential), > 0.
    reference_stress : float, optional
        ``sigma_r`` [Pa] (exponential only), > 0.
    sealed_aperture : float
        ``w_inf`` [m], >= 0: the hydraulic aperture of a crack closed to ``V_m`` (closure
        laws only; the smooth law's closed aperture is the coupled model's residual
        aperture).
    """

    kind: Literal["smooth", "barton_bandis", "exponential"] = "smooth"
    normal_stiffness: float | None = None
    max_closure: float | None = None
    reference_stress: float | None = None
    sealed_aperture: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in CLOSURE_LAWS:
            raise InputError(f"unknown closure law {self.kind!r}", key="rock.closure_law",
                             expected=" or ".join(repr(k) for k in CLOSURE_LAWS))
        need = {"smooth": (), "barton_bandis": ("normal_stiffness", "max_closure"),
                "exponential": ("reference_stress", "max_closure")}[self.kind]
        keys = {"normal_stiffness": "rock.joint_normal_stiffness",
                "max_closure": "rock.joint_max_closure",
                "reference_stress": "rock.joint_reference_stress"}
        for name, key in keys.items():
            v = getattr(self, name)
            if name in need:
                if v is None:
                    raise InputError(f"closure_law = {self.kind!r} needs {key}", key=key,
                                     expected="a number > 0")
                v = float(v)
                if not (math.isfinite(v) and v > 0.0):
                    raise InputError(f"value {v!r} is out of range", key=key,
                                     expected="a number > 0")
                object.__setattr__(self, name, v)
            elif v is not None:
                raise InputError(f"{key} is not used by closure_law = {self.kind!r}",
                                 key=key, expected="no value, or a closure law that uses it")
        w = float(self.sealed_aperture)
        if not (math.isfinite(w) and w >= 0.0):
            raise InputError(f"value {w!r} is out of range", key="rock.sealed_aperture",
                             expected="a number >= 0")
        object.__setattr__(self, "sealed_aperture", w)

    @property
    def nonlinear(self) -> bool:
        """True for the closure laws (the smooth law is the linear contact spring)."""
        return self.kind != "smooth"

    @property
    def initial_stiffness(self) -> float:
        """``K_ni`` [Pa/m]: ``d sigma / d delta`` at ``delta = 0`` (closure laws)."""
        if self.kind == "barton_bandis":
            return float(self.normal_stiffness)
        if self.kind == "exponential":
            return float(self.reference_stress) / float(self.max_closure)
        raise ValueError("the smooth law has no joint stiffness of its own")

    @property
    def zero_stress_aperture(self) -> float:
        """``w_0 = w_inf + V_m`` [m]: the hydraulic aperture at zero effective stress."""
        if not self.nonlinear:
            raise ValueError("the smooth law's closed aperture is the residual aperture")
        return self.sealed_aperture + float(self.max_closure)


def closure_of_stress(law: ClosureLaw, sigma) -> np.ndarray:
    """Closure ``delta(sigma)`` [m]: the closed form, and beyond the stress at
    ``delta_c`` the inverse of :func:`stress_of_closure`'s tangent line (module docstring).

    Parameters
    ----------
    law : ClosureLaw
        A closure law (``barton_bandis`` or ``exponential``).
    sigma : array_like
        Effective normal stress [Pa], >= 0 (compression positive).
    """
    s = np.asarray(sigma, dtype=float)
    if np.any(s < 0):
        raise InputError("must be >= 0 (compression positive)", key="sigma")
    if not law.nonlinear:
        raise ValueError("the smooth law's closure is the contact's own k_n")
    vm = float(law.max_closure)
    if law.kind == "barton_bandis":
        kni = float(law.normal_stiffness)
        d = s * vm / (kni * vm + s)
    else:
        d = vm * -np.expm1(-s / float(law.reference_stress))
    dc = (1.0 - CLOSURE_CAP) * vm
    sc, kc = _raw(law, np.array(dc))
    return np.where(s > sc, dc + (s - sc) / kc, d)


def _raw(law: ClosureLaw, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    vm = float(law.max_closure)
    x = d / vm
    if law.kind == "barton_bandis":
        kni = float(law.normal_stiffness)
        r = 1.0 / (1.0 - x)
        return kni * d * r, kni * r * r
    sr = float(law.reference_stress)
    return -sr * np.log1p(-x), sr / (vm - d)


def stress_of_closure(law: ClosureLaw, delta) -> tuple[np.ndarray, np.ndarray]:
    """Normal stress ``sigma(delta)`` [Pa] and tangent ``d sigma / d delta`` [Pa/m].

    The closed form up to ``delta_c = (1 - CLOSURE_CAP) V_m``, its tangent line beyond
    (module docstring); ``delta < 0`` (not touching) gives the initial tangent line
    (negative stress), which callers use only for its sign.

    Parameters
    ----------
    law : ClosureLaw
        A closure law (``barton_bandis`` or ``exponential``).
    delta : array_like
        Closure [m].

    Returns
    -------
    sigma, stiffness : ndarray
        Same shape as ``delta``.
    """
    if not law.nonlinear:
        raise ValueError("the smooth law's stress is the contact's own k_n")
    d = np.asarray(delta, dtype=float)
    vm = float(law.max_closure)
    dc = (1.0 - CLOSURE_CAP) * vm
    sc, kc = _raw(law, np.array(dc))
    inside = np.clip(d, 0.0, dc)
    s, k = _raw(law, inside)
    k0 = law.initial_stiffness
    s = np.where(d > dc, sc + kc * (d - dc), np.where(d < 0.0, k0 * d, s))
    k = np.where(d > dc, kc, np.where(d < 0.0, k0, k))
    return s, k
