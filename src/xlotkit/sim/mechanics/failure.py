"""Cluster failure criteria, crack-tip stress intensities and strength fields (thesis
Eq. 2.15-2.23, section 4.4.4).

All stresses in this module are **compression positive** [Pa], as in the thesis: effective
(Terzaghi) stresses ``sigma' = sigma - p I`` for the cluster criteria, the crack-induced
stress ``S - p_f I`` for the crack-tip ones.
"""

from __future__ import annotations

import numpy as np

from xlotkit import formulas
from xlotkit.errors import InputError
from xlotkit.sim.mechanics.config import RockProperties

__all__ = [
    "TIP_DOMAIN_RADII",
    "TIP_TOUGHNESS_FACTOR",
    "crack_tip_margin",
    "crack_tip_toughness",
    "material_length",
    "mohr_coulomb_margin",
    "principal_stresses",
    "reference_area",
    "strength_fields",
    "strength_scale_factor",
    "tensile_margin",
    "tip_stress_intensities",
    "toughness_margin",
]


#: ``K_IC / (T A_ref^(1/4))``: the convention that links the strength-scaling inputs
#: (``T``, ``A_ref``) to the toughness ``K_IC`` of the crack-tip criterion
#: (:func:`crack_tip_toughness`, :func:`reference_area`). Its value is the one first
#: measured for the cluster-average tip criterion (``p_ext sqrt(pi a) / (T A_ref^(1/4))``
#: at which a pre-cut, pressurised Griffith crack extended at flat tips: 1.105, 1.125,
#: 1.111 on h = 0.04 / 0.02 m, a = 0.5 / 0.25 m), kept so that a given ``A_ref`` means the
#: same ``K_IC`` as before. The tip criterion now compares ``K_I`` of the interaction
#: integral (:func:`tip_stress_intensities`, :func:`toughness_margin`) with ``K_IC`` itself,
#: at any tip shape (KGD band: 1.006-1.023 ``K_IC`` at flat and pointed tips, as
#: ``p sqrt(pi l)`` with the outer-node ``l``); see docs/mechanics.md and
#: tests/verification/test_mdem_fracture.py.
TIP_TOUGHNESS_FACTOR = 1.11

#: Inner and outer radius of the interaction-integral domain
#: (:func:`tip_stress_intensities`) around a crack tip, in units of the tip cluster's size
#: ``h = sqrt(2 A)``: the weight is 1 inside the inner radius, so the discrete tip (a node or
#: an edge) is well inside, and the auxiliary field is integrated where it is smooth on the
#: elements. Measured on the KGD band (h = 2 cm, l = 0.1-0.3 m): (1.5, 4) h and (3, 6) h
#: agree within 1.5 %; with the J-integral on (1.5, 4) h, mechanics-only growth ran one wing
#: ahead of the other on 1 % differences between the tips, with (3, 6) h the two grew in turn.
TIP_DOMAIN_RADII = (3.0, 6.0)


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
    """Tensile criterion on the singular part of a crack-tip cluster's average stress.

    The first form of the crack-tip criterion; the model now uses it only for tip clusters
    that are not at a crack end (:meth:`MechanicsModel.crack_fronts` finds no end near
    them), the crack ends get :func:`toughness_margin` with ``K_I`` from
    :func:`tip_stress_intensities`: how much of the singular field one cluster carries
    depends on how the discrete tip ends (docs/mechanics.md).

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


def _tip_field(x: np.ndarray, y: np.ndarray, young: float, poisson: float, mode: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """Plane-strain mode-I or mode-II tip field with unit stress intensity in tip
    coordinates (tension positive): stress ``(s11, s22, s12)`` (e, 3) and displacement
    gradient ``du_i/dx_k`` (e, 2, 2)."""
    mu = young / (2.0 * (1.0 + poisson))
    kap = 3.0 - 4.0 * poisson
    r = np.hypot(x, y)
    th = np.arctan2(y, x)
    f = 1.0 / np.sqrt(2.0 * np.pi * r)
    c, s = np.cos(0.5 * th), np.sin(0.5 * th)
    s3, c3 = np.sin(1.5 * th), np.cos(1.5 * th)
    g = np.sqrt(r / (2.0 * np.pi)) / (2.0 * mu)
    # displacement u_i = g a_i(th); a_i and d a_i / d th
    if mode == 1:
        stress = np.column_stack([f * c * (1.0 - s * s3), f * c * (1.0 + s * s3),
                                  f * c * s * c3])
        a = (c * (kap - 1.0 + 2.0 * s * s), s * (kap + 1.0 - 2.0 * c * c))
        da = (-0.5 * s * (kap - 1.0 + 2.0 * s * s) + 2.0 * c * c * s,
              0.5 * c * (kap + 1.0 - 2.0 * c * c) + 2.0 * s * s * c)
    else:
        stress = np.column_stack([-f * s * (2.0 + c * c3), f * s * c * c3,
                                  f * c * (1.0 - s * s3)])
        a = (s * (kap + 1.0 + 2.0 * c * c), -c * (kap - 1.0 - 2.0 * s * s))
        da = (0.5 * c * (kap + 1.0 + 2.0 * c * c) - 2.0 * s * s * c,
              0.5 * s * (kap - 1.0 - 2.0 * s * s) + 2.0 * c * c * s)
    gr = g / (2.0 * r)                                                 # d g / d r
    ct, st = np.cos(th), np.sin(th)
    H = np.empty((len(x), 2, 2))
    for i in range(2):
        dr = gr * a[i]
        dth = g * da[i] / r
        H[:, i, 0] = ct * dr - st * dth
        H[:, i, 1] = st * dr + ct * dth
    return stress, H


def tip_stress_intensities(grad_n: np.ndarray, triangles: np.ndarray, area: np.ndarray,
                           centroids: np.ndarray, displacement: np.ndarray,
                           stress: np.ndarray, compliance: np.ndarray, weight: np.ndarray,
                           tip: np.ndarray, direction: np.ndarray, young: float,
                           poisson: float) -> tuple[float, float]:
    """Stress intensities ``K_I, K_II`` [Pa m^0.5] of a crack tip by the interaction integral.

    With an auxiliary plane-strain tip field of unit ``K_I`` (or ``K_II``, superscript ``a``),

        M = sum_e A_e (s_ij u^a_i,1 + s^a_ij u_i,1 - s_ik eps^a_ik delta_1j) q,j

    in tip coordinates (``x_1`` along ``direction``), over constant-strain triangles with
    a nodal weight ``q`` equal to 1 around the tip and 0 on the domain's outer contour and on
    loaded boundaries; ``K = E' M / 2`` for the mode of the auxiliary field. ``M`` is that
    mode's part of the J-integral: it does not depend on the domain, hence not on which
    cluster sits at the tip, and a uniform stress (the confinement, a crack-parallel
    T-stress) contributes nothing to it, where it contributes to ``J`` through the crack
    band, which is softer along the crack than the rock (docs/mechanics.md). ``K_I`` changes
    only to second order with an error in ``direction``, ``K_II`` to first order (times the
    T-stress): on exact Williams fields (slot of one triangle) ``K_I`` is recovered to
    1e-4, ``K_II`` 3-4 % low (its auxiliary field loads the faces, which the slot leaves
    out).

    The crack carries the fluid pressure ``p_f`` on its faces; the field whose faces are
    traction free is ``sigma + p_f I`` (compression positive ``stress = S - p_f I``, the
    singular part of :func:`crack_tip_margin`), with strain ``C^-1 sigma`` and the rotation
    of the actual displacement (the superposed uniform field has no rotation). Pass the
    intact triangles only: the crack band is the traction-free slot (the auxiliary field
    nearly vanishes on the crack line behind the tip, so its width hardly matters).

    Parameters
    ----------
    grad_n : ndarray (n_e, 2, 3)
        Shape-function gradients ``(d/dx, d/dy)`` of the triangles' three nodes [1/m].
    triangles : ndarray (n_e, 3)
        Node indices (into ``displacement`` and ``weight``).
    area : ndarray (n_e,)
        [m^2].
    centroids : ndarray (n_e, 2)
        [m] (one-point quadrature of the auxiliary field).
    displacement : ndarray (n_nodes, 2)
        [m].
    stress : ndarray (n_e, 3)
        ``(sxx, syy, sxy)`` of the traction-free-face field [Pa], compression positive.
    compliance : ndarray (3, 3)
        ``C^-1`` (Voigt, engineering shear strain) [1/Pa].
    weight : ndarray (n_nodes,)
        Nodal ``q``.
    tip : ndarray (2,)
        Crack tip [m].
    direction : ndarray (2,)
        Unit vector along the crack, pointing ahead of the tip.
    young, poisson : float
        ``E`` [Pa] and ``nu`` of the rock (plane strain).

    Returns
    -------
    k1, k2 : float
        ``K_I`` (negative when the tip field closes the crack) and ``K_II`` (positive when
        the face on the left of ``direction`` slides ahead relative to the other, the
        Williams convention) [Pa m^0.5].
    """
    t = np.asarray(direction, dtype=float)
    rot = np.array([t, [-t[1], t[0]]])                   # rows: crack axes in x, y
    sig = -np.asarray(stress, dtype=float)              # tension positive
    eps = sig @ np.asarray(compliance).T                # (exx, eyy, gxy)
    u = np.asarray(displacement)[triangles]             # (e, 3, 2)
    grad = np.einsum("eka,eai->eik", grad_n, u)          # du_i/dx_k, actual field
    om = 0.5 * (grad[:, 1, 0] - grad[:, 0, 1])

    def tensor(v, shear=1.0):
        m = np.empty((len(v), 2, 2))
        m[:, 0, 0] = v[:, 0]
        m[:, 1, 1] = v[:, 1]
        m[:, 0, 1] = m[:, 1, 0] = shear * v[:, 2]
        return m

    s_loc = rot @ tensor(sig) @ rot.T
    h = tensor(eps, 0.5)
    h[:, 0, 1] -= om
    h[:, 1, 0] += om
    h_loc = rot @ h @ rot.T
    gq = np.einsum("eka,ea->ek", grad_n, np.asarray(weight)[triangles]) @ rot.T
    xl = (np.asarray(centroids) - np.asarray(tip)) @ rot.T
    out = []
    for mode in (1, 2):
        s_aux, h_aux = _tip_field(xl[:, 0], xl[:, 1], young, poisson, mode)
        sa = tensor(s_aux)
        ea = 0.5 * (h_aux + np.transpose(h_aux, (0, 2, 1)))
        integrand = (np.einsum("eij,ei,ej->e", s_loc, h_aux[:, :, 0], gq)
                     + np.einsum("eij,ei,ej->e", sa, h_loc[:, :, 0], gq)
                     - np.einsum("eik,eik->e", s_loc, ea) * gq[:, 0])
        out.append(0.5 * young / (1.0 - poisson ** 2) * float(np.asarray(area) @ integrand))
    return out[0], out[1]


def toughness_margin(stress_intensity: np.ndarray | float, area: np.ndarray | float,
                     tensile_strength: np.ndarray | float) -> np.ndarray:
    """Toughness criterion of a crack-tip cluster in the units of a strength margin.

    The tip cluster (area ``A``, size-scaled strength ``T_i = T f (A_ref/A)^(1/4)``, ``f``
    the heterogeneity factor) has the toughness ``K_IC,i = c T_i A^(1/4) = f K_IC``
    (``c`` = :data:`TIP_TOUGHNESS_FACTOR`, :func:`crack_tip_toughness`). Returns
    ``K / (c A^(1/4)) - T_i`` [Pa], which is >= 0 exactly when ``K >= K_IC,i`` and, divided
    by ``T_i``, is ``K / K_IC,i - 1`` (the severity used to order failures).
    """
    return (np.asarray(stress_intensity, dtype=float)
            / (TIP_TOUGHNESS_FACTOR * np.asarray(area, dtype=float) ** 0.25)
            - np.asarray(tensile_strength, dtype=float))


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

    With size scaling on in mode ``"crack_tip"`` and the LEFM exponent ``m = 1/4`` a crack
    end extends when its mode-I stress intensity (interaction integral,
    :func:`tip_stress_intensities`) reaches ``K_IC = c T A_ref^(1/4)`` with ``c`` =
    :data:`TIP_TOUGHNESS_FACTOR` (equal to ``rock.scaling.toughness`` when that is given);
    :func:`toughness_margin` writes this as a margin of the size-scaled strength
    ``T (A_ref/A)^(1/4)`` of the cluster that fails. Heterogeneity multiplies it per cluster
    like the strengths.

    The criterion assumes the crack faces carry the fluid pressure only; in MDEM a
    failed cluster carries it on all three contacts, so a crack filled above the rock's
    pore pressure also swells the failed band along the crack, which adds to ``K_I`` at its
    end (measured ~0.01 MPa sqrt(m) per MPa of ``p_f - p_rock`` on a pre-cut crack failed
    under compression, docs/mechanics.md).

    Returns
    -------
    float or None
        None when scaling is off, in mode ``"all"`` or with ``m != 1/4``: then the tip
        criterion has no mesh-independent toughness (without scaling there is no tip
        criterion and the cluster-average one grows like ``T sqrt(h)``; mode ``"all"``
        keeps the cluster-average criterion, whose confinement term is not scaled; with
        ``m != 1/4`` the toughness ``c T_i A^(1/4)`` of a tip cluster depends on its area).
    """
    sc = rock.scaling
    if not sc.enabled or sc.mode != "crack_tip" or sc.exponent != 0.25:
        return None
    return TIP_TOUGHNESS_FACTOR * rock.tensile_strength * reference_area(rock) ** 0.25


def material_length(rock: RockProperties) -> float | None:
    """Material length ``L = (K_IC / T)^2 / pi`` [m] shared by the crack-tip and the wall
    criteria (:func:`xlotkit.formulas.critical_distance`), or None when the crack tips have
    no toughness (:func:`crack_tip_toughness`) or the wall keeps the cluster average
    (``StrengthScaling.wall = "cluster"``).

    The point method at ``L/2`` ahead of a crack tip is ``K_I = K_IC``; at the wall it is
    the initiation criterion of :mod:`xlotkit.sim.mechanics.wall`.
    """
    k_ic = crack_tip_toughness(rock)
    if k_ic is None or rock.scaling.wall != "critical_distance":
        return None
    return formulas.critical_distance(k_ic, rock.tensile_strength)


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
