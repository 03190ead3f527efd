"""Cluster failure criteria and strength fields (thesis Eq. 2.15-2.23, section 4.4.4).

All stresses in this module are **compression positive** effective (Terzaghi) stresses
``sigma' = sigma - p I`` [Pa], as in the thesis.
"""

from __future__ import annotations

import numpy as np

from xlotkit.errors import InputError
from xlotkit.sim.mechanics.config import RockProperties

__all__ = [
    "TIP_TOUGHNESS_FACTOR",
    "crack_tip_margin",
    "crack_tip_toughness",
    "mohr_coulomb_margin",
    "principal_stresses",
    "reference_area",
    "strength_fields",
    "strength_scale_factor",
    "tensile_margin",
]


#: ``K_IC / (T A_ref^(1/4))`` of the crack-tip criterion (:func:`crack_tip_margin` with
#: exponent 1/4): ``p_ext sqrt(pi a) / (T A_ref^(1/4))`` at which a pre-cut, pressurised
#: Griffith crack extends, measured on band meshes with tip clusters of h = 0.04 and
#: 0.02 m and half-lengths a = 0.5 and 0.25 m (h/a <= 0.08): 1.105, 1.125, 1.111, mean
#: 1.11, spread +-1 %. (At h/a = 0.16 it was 1.45: the crack must span >~ 12 clusters.)
#: It is a property of the discrete tip (how the constant-strain triangle next to the tip
#: averages the ``K / sqrt(2 pi r)`` field), not of the rock; see docs/mechanics.md and
#: the re-measurement in tests/verification/test_mdem_fracture.py.
TIP_TOUGHNESS_FACTOR = 1.11


def principal_stresses(stress: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Principal stresses of 2D stress states.

    Parameters
    ----------
    stress : ndarray (..., 3)
        ``(sigma_xx, sigma_yy, sigma_xy)`` [Pa].

    Returns
    -------
    s1, s2 : ndarray (...)
        ``s1 >= s2``: ``(sxx + syy)/2 +- sqrt(((sxx - syy)/2)^2 + sxy^2)``.
    angle : ndarray (...)
        Direction of ``s1`` [rad] from +x.
    """
    sxx, syy, sxy = stress[..., 0], stress[..., 1], stress[..., 2]
    c = 0.5 * (sxx + syy)
    r = np.hypot(0.5 * (sxx - syy), sxy)
    return c + r, c - r, 0.5 * np.arctan2(2.0 * sxy, sxx - syy)


def tensile_margin(stress: np.ndarray, tensile_strength: np.ndarray) -> np.ndarray:
    """Tensile criterion (Eq. 2.15): failure when ``sigma'_min <= -T``.

    Returns ``-T - sigma'_min`` [Pa]; the cluster fails when it is >= 0.
    """
    _, s2, _ = principal_stresses(stress)
    return -tensile_strength - s2


def crack_tip_margin(stress: np.ndarray, face_pressure: np.ndarray,
                     tensile_strength: np.ndarray) -> np.ndarray:
    """Tensile criterion on the singular part of the stress at a crack tip.

    Ahead of a crack whose faces carry the fluid pressure ``p_f`` the total opening
    stress (compression positive) is ``sigma_nn = p_f - K_I / sqrt(2 pi r) + O(sqrt r)``:
    the constant term of the Williams expansion equals the face load, whatever the
    far field or the rock's pore pressure. The crack-induced (singular) part is therefore
    ``sigma - p_f I``; a tip cluster fails when its least compressive principal value
    reaches ``-T_i``, with ``T_i`` the size-scaled strength, i.e. at ``K_I = K_IC``
    (:func:`crack_tip_toughness`).

    Parameters
    ----------
    stress : ndarray (..., 3)
        Cluster-average **total** stress [Pa], compression positive.
    face_pressure : ndarray (...)
        Fluid pressure on the crack faces at the tip [Pa].
    tensile_strength : ndarray (...)
        Size-scaled tensile strength ``T_i`` [Pa].

    Returns
    -------
    ndarray
        ``-T_i - min principal(sigma - p_f I)`` [Pa]; failure when >= 0.
    """
    sing = np.array(stress, dtype=float, copy=True)
    sing[..., :2] -= np.asarray(face_pressure, dtype=float)[..., None]
    return tensile_margin(sing, tensile_strength)


def mohr_coulomb_margin(stress: np.ndarray, cohesion: np.ndarray,
                        friction_angle: np.ndarray | float) -> np.ndarray:
    """Mohr-Coulomb criterion on the plane at ``beta = pi/4 + phi/2`` (Eq. 2.16-2.21).

    With principal effective stresses ``s1 >= s2`` (compression positive), the normal and
    shear stress on the plane whose normal makes the angle ``beta`` with ``s1`` are

        N   = (s1 + s2)/2 + (s1 - s2)/2 cos(2 beta)
        tau = (s1 - s2)/2 sin(2 beta)

    and the cluster fails when ``tau >= S0 + tan(phi) N``.

    Returns
    -------
    ndarray
        ``tau - S0 - tan(phi) N`` [Pa]; failure when >= 0.
    """
    s1, s2, _ = principal_stresses(stress)
    beta = 0.25 * np.pi + 0.5 * np.asarray(friction_angle)
    n = 0.5 * (s1 + s2) + 0.5 * (s1 - s2) * np.cos(2 * beta)
    tau = 0.5 * (s1 - s2) * np.sin(2 * beta)
    return tau - cohesion - np.tan(friction_angle) * n


def strength_scale_factor(area: np.ndarray, reference_area: float,
                          exponent: float = 0.25) -> np.ndarray:
    """Size factor ``(A_ref / A) ** m`` of cluster strengths.

    ``m = 1/4`` makes the fracture energy released by failing a cluster independent of
    its size (``G_c ~ T^2 l / E'`` with ``l ~ sqrt(A)``); see docs/mechanics.md.
    """
    area = np.asarray(area, dtype=float)
    if np.any(area <= 0):
        raise InputError("cluster areas must be positive", key="mesh")
    return (reference_area / area) ** exponent


def reference_area(rock: RockProperties) -> float:
    """Reference area ``A_ref`` [m^2] of the size factor.

    ``rock.scaling.reference_area``, or, when ``rock.scaling.toughness`` is given,
    ``(K_IC / (c T))^4`` with ``c`` = :data:`TIP_TOUGHNESS_FACTOR`, so that the crack-tip
    clusters have that toughness (inverse of :func:`crack_tip_toughness`).
    """
    sc = rock.scaling
    if sc.toughness is None:
        return sc.reference_area
    return (sc.toughness / (TIP_TOUGHNESS_FACTOR * rock.tensile_strength)) ** 4


def crack_tip_toughness(rock: RockProperties) -> float | None:
    """Effective mode-I fracture toughness ``K_IC`` [Pa m^0.5] of crack-tip clusters.

    With size scaling on in mode ``"crack_tip"`` and the LEFM exponent ``m = 1/4`` a tip
    cluster of area ``A`` fails when the singular part of its average opening stress
    (:func:`crack_tip_margin`) reaches ``T (A_ref / A)^(1/4)``; it averages the tip field
    ``K / sqrt(2 pi r)`` over its size ``~ sqrt(A)``, so it fails at
    ``K = c T A_ref^(1/4)``, independent of its size, with ``c`` =
    :data:`TIP_TOUGHNESS_FACTOR` (measured; equal to ``rock.scaling.toughness`` when that
    is given). Heterogeneity multiplies it per cluster like the strengths.

    The criterion assumes the crack faces carry the fluid pressure only; in MDEM a
    failed cluster carries it on all three contacts, so a crack filled above the rock's
    pore pressure also swells the failed band along the crack, which adds tension at its
    end (measured ~0.4 (p_f - p_rock) on a pre-cut crack failed under compression,
    docs/mechanics.md). The toughness above is measured without that term
    (``p_rock = 0``, net pressure ~ ``K_IC / sqrt(pi a)``).

    Returns
    -------
    float or None
        None when scaling is off, in mode ``"all"`` or with ``m != 1/4``: then the tip
        criterion has no mesh-independent toughness (without scaling it grows like
        ``T sqrt(h)``; mode ``"all"`` keeps the cluster-average criterion, whose
        confinement term is not scaled).
    """
    sc = rock.scaling
    if not sc.enabled or sc.mode != "crack_tip" or sc.exponent != 0.25:
        return None
    return TIP_TOUGHNESS_FACTOR * rock.tensile_strength * reference_area(rock) ** 0.25


def strength_fields(rock: RockProperties, area: np.ndarray,
                    scaled: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Per-cluster tensile strength and cohesion [Pa].

    ``T_i = T * f_size,i * (1 + h U_i)``, ``S_i = S0 * f_size,i * (1 + h U_i)`` with
    ``U_i ~ uniform(-1, 1)`` drawn once per cluster from ``rock.seed`` (a weak cluster is
    weak in tension and in shear) and ``f_size = (A_ref / A_i)^m`` from
    :func:`strength_scale_factor` with ``A_ref`` from :func:`reference_area`.

    Parameters
    ----------
    rock : RockProperties
    area : ndarray (n_c,)
        Cluster areas [m^2].
    scaled : bool
        Apply the size factor (only if ``rock.scaling.enabled``). With scaling mode
        ``"crack_tip"`` the model uses the scaled fields for clusters touching a crack and
        the unscaled ones elsewhere; see :meth:`MechanicsModel.strengths`.

    Returns
    -------
    tensile_strength, cohesion : ndarray (n_c,) [Pa]
    """
    n = len(area)
    factor = np.ones(n)
    if rock.heterogeneity > 0.0:
        rng = np.random.default_rng(rock.seed)
        factor = 1.0 + rock.heterogeneity * rng.uniform(-1.0, 1.0, size=n)
    if scaled and rock.scaling.enabled:
        factor = factor * strength_scale_factor(area, reference_area(rock),
                                                rock.scaling.exponent)
    return rock.tensile_strength * factor, rock.cohesion * factor
