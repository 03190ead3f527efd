"""Cluster failure criteria and strength fields (thesis Eq. 2.15-2.23, section 4.4.4).

All stresses in this module are **compression positive** effective (Terzaghi) stresses
``sigma' = sigma - p I`` [Pa], as in the thesis.
"""

from __future__ import annotations

import numpy as np

from xlotkit.errors import InputError
from xlotkit.sim.mechanics.config import RockProperties

__all__ = [
    "mohr_coulomb_margin",
    "principal_stresses",
    "strength_fields",
    "strength_scale_factor",
    "tensile_margin",
]


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


def strength_fields(rock: RockProperties, area: np.ndarray,
                    scaled: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Per-cluster tensile strength and cohesion [Pa].

    ``T_i = T * f_size,i * (1 + h U_i)``, ``S_i = S0 * f_size,i * (1 + h U_i)`` with
    ``U_i ~ uniform(-1, 1)`` drawn once per cluster from ``rock.seed`` (a weak cluster is
    weak in tension and in shear) and ``f_size = (A_ref / A_i)^m`` from
    :func:`strength_scale_factor`.

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
        factor = factor * strength_scale_factor(area, rock.scaling.reference_area,
                                                rock.scaling.exponent)
    return rock.tensile_strength * factor, rock.cohesion * factor
