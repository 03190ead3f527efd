"""Frictional limits on the stresses: the stress polygon and the thrust-belt bounds (App. C).

Sign convention and units as in :mod:`xlotkit.interpret.stress` (compression positive, SI).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from xlotkit.errors import InputError
from xlotkit.interpret.stress_checks import (
    _arr,
    _fmt,
    _nonneg,
    _ordered_horizontal,
    _out,
    _positive,
)

__all__ = ["PolygonClassification", "Regime", "StressPolygon", "ThrustBeltBounds",
           "friction_ratio", "stress_polygon", "thrust_belt_bounds"]


# --------------------------------------------------------------------------------------------
# frictional limits: stress polygon and thrust-belt bounds (Eq. C.16 / C.17)
# --------------------------------------------------------------------------------------------

def friction_ratio(mu) -> float:
    """Limiting effective-stress ratio ``(s1 - p)/(s3 - p) = [sqrt(mu^2 + 1) + mu]^2`` of a
    cohesionless fault with friction coefficient ``mu > 0`` optimally oriented (Jaeger & Cook;
    equal to ``(1 + sin phi)/(1 - sin phi)`` with ``mu = tan phi``)."""
    m = _positive(mu, "mu", "a friction coefficient")
    return _out((np.sqrt(m * m + 1.0) + m) ** 2)


Regime = Literal["normal", "strike-slip", "reverse"]


@dataclass(frozen=True)
class PolygonClassification:
    """Where a ``(sigma_h, sigma_H)`` point lies relative to the stress polygon.

    Attributes
    ----------
    inside : bool
        True if no optimally oriented fault would slip (on the boundary counts as inside).
    regime : {"normal", "strike-slip", "reverse"}
        Andersonian regime from the order of ``sv``, ``sigma_h``, ``sigma_H`` (``sv >= sigma_H``:
        normal; ``sv <= sigma_h``: reverse; otherwise strike-slip; ties go to the first).
    ratio : float
        ``(s1 - p0)/(s3 - p0)`` of the point (``inf`` if ``s3 == p0``).
    limit : float
        The frictional limit of that ratio.
    """

    inside: bool
    regime: Regime
    ratio: float
    limit: float


@dataclass(frozen=True)
class StressPolygon:
    """Frictional-faulting limits on the horizontal stresses (Zoback's stress polygon).

    With ``q = [sqrt(mu^2+1) + mu]^2`` and ``sigma_H >= sigma_h``:

    * normal faulting (``sv`` largest): ``sigma_h >= p0 + (sv - p0)/q = sigma_h_min``;
    * strike-slip: ``sigma_H <= p0 + q (sigma_h - p0)``;
    * reverse faulting (``sv`` least): ``sigma_H <= p0 + q (sv - p0) = sigma_H_max``.

    Attributes
    ----------
    sv, p0, mu, q : float
        Inputs [Pa, Pa, -] and the limiting ratio.
    sigma_h_min, sigma_H_max : float
        The normal-faulting lower and reverse-faulting upper bounds [Pa].
    vertices : ndarray, shape (4, 2)
        ``(sigma_h, sigma_H)`` corners in order: ``(h_min, h_min)``, ``(h_min, sv)``,
        ``(sv, H_max)``, ``(H_max, H_max)``; closed back along the line ``sigma_h = sigma_H``.
    regions : dict
        ``{"normal"|"strike-slip"|"reverse": (n, 2) array}`` polygons of the three regimes
        (they meet at ``(sv, sv)``).
    """

    sv: float
    p0: float
    mu: float
    q: float
    sigma_h_min: float
    sigma_H_max: float
    vertices: np.ndarray
    regions: dict[str, np.ndarray]

    def classify(self, sigma_h: float, sigma_H: float, *, rtol: float = 1e-9
                 ) -> PolygonClassification:
        """Classify a stress state; see :class:`PolygonClassification`.

        ``rtol`` (relative to ``sv``) lets points on the boundary count as inside despite
        rounding.

        Raises
        ------
        InputError
            Negative stresses, or ``sigma_H < sigma_h``.
        """
        sh = float(_nonneg(sigma_h, "sigma_h"))
        sH = float(_nonneg(sigma_H, "sigma_H"))
        _ordered_horizontal(np.asarray(sh), np.asarray(sH))
        sv, p0 = self.sv, self.p0
        if sv >= sH:
            regime: Regime = "normal"
            s1, s3 = sv, sh
        elif sv <= sh:
            regime = "reverse"
            s1, s3 = sH, sv
        else:
            regime = "strike-slip"
            s1, s3 = sH, sh
        # Compare in the product form to avoid dividing by s3 - p0 (0 or negative when the
        # least stress is at or below the pore pressure: beyond any frictional limit).
        tol = rtol * sv
        inside = (s1 - p0) <= self.q * (s3 - p0) + tol and s3 >= p0
        ratio = (s1 - p0) / (s3 - p0) if s3 > p0 else math.inf
        return PolygonClassification(bool(inside), regime, float(ratio), float(self.q))


def stress_polygon(sv, p0, mu) -> StressPolygon:
    """The stress polygon for vertical stress ``sv``, pore pressure ``p0`` and friction ``mu``.

    Limit of frictional equilibrium on optimally oriented cohesionless faults,
    ``(s1 - p0) / (s3 - p0) <= [sqrt(mu^2 + 1) + mu]^2``, applied in each Andersonian regime
    (see :class:`StressPolygon`). Used with ``p0 = LOP - C0/mu`` it gives the thrust-belt
    bounds of Eq. C.16 / C.17 (:func:`thrust_belt_bounds`).

    Parameters
    ----------
    sv : float
        Vertical stress [Pa], > 0.
    p0 : float
        Pore pressure [Pa], ``0 <= p0 < sv``.
    mu : float
        Friction coefficient, > 0 (0.6 - 1.0 for most rocks, Byerlee).

    Returns
    -------
    StressPolygon
    """
    s = float(_positive(sv, "sv", "a vertical stress [Pa]"))
    p = float(_nonneg(p0, "p0"))
    if p >= s:
        raise InputError(f"pore pressure {p:g} Pa is not below sv = {s:g} Pa", key="p0",
                         expected="0 <= p0 < sv")
    m = float(_positive(mu, "mu", "a friction coefficient"))
    return _polygon(s, p, m)


def _polygon(s: float, p: float, m: float) -> StressPolygon:
    # No validation: also used with the (possibly negative) Mohr-Coulomb apex as "p".
    q = float(friction_ratio(m))
    h_min = p + (s - p) / q
    H_max = p + q * (s - p)
    verts = np.array([[h_min, h_min], [h_min, s], [s, H_max], [H_max, H_max]])
    regions = {
        "normal": np.array([[h_min, h_min], [h_min, s], [s, s]]),
        "strike-slip": np.array([[h_min, s], [s, H_max], [s, s]]),
        "reverse": np.array([[s, s], [s, H_max], [H_max, H_max]]),
    }
    return StressPolygon(sv=s, p0=p, mu=m, q=q, sigma_h_min=h_min, sigma_H_max=H_max,
                         vertices=verts, regions=regions)


@dataclass(frozen=True)
class ThrustBeltBounds:
    """Bounds on the horizontal stresses from a leak-off by shear dilation (Eq. C.16 / C.17).

    Attributes
    ----------
    sv, lop, mu, cohesion : float or ndarray
        Inputs [Pa, Pa, -, Pa].
    phi : float or ndarray
        Friction angle ``atan(mu)`` [rad].
    apex : float or ndarray
        Where the Mohr-Coulomb line meets the normal-stress axis, ``LOP - C0/tan(phi)`` [Pa].
    sigma_h_lim : float or ndarray
        Eq. C.16, lower bound of the minimum horizontal stress (normal-fault circle) [Pa].
    sigma_H_lim : float or ndarray
        Eq. C.17, upper bound of the maximum horizontal stress (reverse-fault circle) [Pa].
    """

    sv: Any
    lop: Any
    mu: Any
    cohesion: Any
    phi: Any
    apex: Any
    sigma_h_lim: Any
    sigma_H_lim: Any

    def polygon(self) -> StressPolygon:
        """The stress polygon these bounds are the corners of (scalar inputs only)."""
        if np.ndim(self.apex) or np.ndim(self.mu):
            raise InputError("the polygon needs scalar inputs", key="mu",
                             expected="one friction coefficient and one LOP")
        return _polygon(float(self.sv), float(self.apex), float(self.mu))


def thrust_belt_bounds(sv, lop, *, mu=None, phi=None, cohesion=0.0) -> ThrustBeltBounds:
    """Stress bounds from a leak-off pressure below the overburden (Couzens-Schultz & Chan),
    Eq. C.16 and C.17.

    In a compressional setting a low LOP is read as shear slip (and dilation) on pre-existing
    fractures, not tensile fracturing: at a fluid pressure equal to the LOP the stress state
    just touches the Mohr-Coulomb line ``tau = C0 + tan(phi) (sigma_n - LOP)``. With
    ``A = LOP - C0 / tan(phi)`` and ``sv`` principal::

        sigma_h_lim = sv - 2 (sv - A) sin(phi) / (1 + sin(phi))    (C.16, normal-fault circle)
        sigma_H_lim = sv + 2 (sv - A) sin(phi) / (1 - sin(phi))    (C.17, reverse-fault circle)

    (The thesis prints ``sin(theta)`` in the numerators; it is the friction angle, as the
    derivation from a Mohr circle tangent to the failure line requires.) These are the corners
    of the stress polygon with pore pressure ``A``: ``sigma_h_lim = A + (sv - A)/q`` and
    ``sigma_H_lim = A + q (sv - A)``, ``q = (1 + sin(phi))/(1 - sin(phi))``.

    Parameters
    ----------
    sv : float
        Vertical stress at the shoe [Pa], > 0.
    lop : float or array_like
        Leak-off pressure at depth [Pa], ``>= 0``, with ``A < sv``.
    mu : float or array_like, optional
        Friction coefficient ``tan(phi)`` (> 0). Give ``mu`` or ``phi``; arrays give one bound
        per value (e.g. a range of laboratory friction values).
    phi : float or array_like, optional
        Friction angle [rad], in (0, pi/2).
    cohesion : float, default 0
        Cohesion ``C0`` of the fractures [Pa], ``>= 0``.

    Returns
    -------
    ThrustBeltBounds
    """
    s = _positive(sv, "sv", "a vertical stress [Pa]")
    lp = _nonneg(lop, "lop", "a leak-off pressure [Pa]")
    c0 = _nonneg(cohesion, "cohesion", "a cohesion [Pa]")
    if (mu is None) == (phi is None):
        raise InputError("give exactly one of mu and phi", key="mu/phi",
                         expected="a friction coefficient mu > 0 or a friction angle phi [rad]")
    if mu is not None:
        m = _positive(mu, "mu", "a friction coefficient")
        ph = np.arctan(m)
    else:
        ph = _arr(phi, "phi")
        if np.any((ph <= 0) | (ph >= math.pi / 2)):
            raise InputError(f"friction angle {_fmt(ph)} rad is outside (0, pi/2)", key="phi",
                             expected="0 < phi < pi/2 [rad]")
        m = np.tan(ph)
    apex = lp - c0 / m
    if np.any(apex >= s):
        raise InputError("LOP - C0/tan(phi) is not below the vertical stress", key="lop",
                         expected="a leak-off pressure below sv (the method explains a low LOP)")
    sn = np.sin(ph)
    h_lim = s - 2.0 * (s - apex) * sn / (1.0 + sn)
    H_lim = s + 2.0 * (s - apex) * sn / (1.0 - sn)
    return ThrustBeltBounds(sv=_out(s), lop=_out(lp), mu=_out(m), cohesion=_out(c0),
                            phi=_out(ph), apex=_out(apex), sigma_h_lim=_out(h_lim),
                            sigma_H_lim=_out(H_lim))


