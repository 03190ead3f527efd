"""Compiled cluster loops of the MDEM mechanics: contact response and tangent blocks.

Each public function checks and allocates, then runs a private ``@njit(cache=True)``
kernel over the clusters. They are what :meth:`MechanicsModel._response` and
:meth:`MechanicsModel._tangent_blocks` compute (the NumPy forms they replaced are kept in
``tests/sim/test_kernels.py`` as the reference).

Everything that describes a contact is an array input, not a property baked in at build
time: the contact operators ``bn_c``/``bs_c`` (the normal and shear directions of every
contact, which a model may set per cluster when it fails), the normal and shear
stiffnesses ``kn``/``ks`` and the friction coefficient ``mu`` per contact. A model that
changes contact directions or makes the normal stiffness a function of the state passes
the new arrays; the kernels do not change.

Sign convention as in :mod:`xlotkit.sim.mechanics.solver`: internally tension positive;
a contact is open when its trial normal force ``k_n (U_n - U_n^0)`` is positive.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from xlotkit.errors import InputError
from xlotkit.sim.mechanics.states import BONDED, INTACT, OPEN, SLIP, STICK

__all__ = ["EPS_OPEN", "contact_response", "tangent_blocks"]

#: Fraction of the contact stiffness an open contact (and the shear of a slipping one)
#: keeps in the *Jacobian only*: nodes held only by open contacts would otherwise make the
#: matrix singular; the residual uses the exact zero force, so the answer is unaffected.
EPS_OPEN = 1e-9


@njit(cache=True)
def _response_kernel(u, dofs, cstate, ref_n, ref_s, p, bn, K, F0, bn_c, bs_c, kn, ks, mu,
                     g_pressure, biot, fmask, fstat, fsign,
                     Fn, Fs, status, sgn, f_c, Un, Us):  # pragma: no cover - compiled
    nc = dofs.shape[0]
    uc = np.empty(6)
    for c in range(nc):
        for i in range(6):
            uc[i] = u[dofs[c, i]]
        failed = cstate[c] != INTACT
        # contact relative displacements along the failed-state directions
        for m in range(3):
            sn = 0.0
            ss = 0.0
            for i in range(6):
                sn += bn_c[c, m, i] * uc[i]
                ss += bs_c[c, m, i] * uc[i]
            Un[c, m] = sn
            Us[c, m] = ss
        if failed:
            for m in range(3):
                tn = kn[c, m] * (Un[c, m] - ref_n[c, m])
                ts = ks[c, m] * (Us[c, m] - ref_s[c, m])
                sg = 1.0 if ts > 0.0 else (-1.0 if ts < 0.0 else 0.0)
                if fmask[c, m]:
                    # held on one branch of the law (its linear continuation)
                    st = fstat[c, m]
                    sg = fsign[c, m]
                    if st == OPEN:
                        fn = 0.0
                        fs = 0.0
                    elif st == SLIP:
                        fn = tn
                        fs = sg * mu[c, m] * (-tn)
                    else:
                        fn = tn
                        fs = ts
                else:
                    if tn > 0.0:
                        st = OPEN
                        fn = 0.0
                        fs = 0.0
                    else:
                        fn = tn
                        cap = mu[c, m] * (-fn)
                        # at the friction limit (|F_s| = cap, where every step leaves
                        # a contact that slipped: its shear reference is moved so, and
                        # a frictionless one sits at F_s = cap = 0) the force is the
                        # same on either branch; the slip branch's tangent is the one
                        # of the motion that put it there
                        if abs(ts) >= cap:
                            st = SLIP
                            fs = sg * cap
                        else:
                            st = STICK
                            fs = ts
                Fn[c, m] = fn
                Fs[c, m] = fs
                status[c, m] = st
                sgn[c, m] = sg
            for i in range(6):
                f = -p[c] * g_pressure[c, i]
                for m in range(3):
                    f += bn_c[c, m, i] * Fn[c, m] + bs_c[c, m, i] * Fs[c, m]
                f_c[c, i] = f
        else:
            # intact: F = F0 + K U_n (regular contact operators), Biot pressure
            for m in range(3):
                ts = ks[c, m] * (Us[c, m] - ref_s[c, m])
                sgn[c, m] = 1.0 if ts > 0.0 else (-1.0 if ts < 0.0 else 0.0)
                status[c, m] = BONDED
                Fs[c, m] = 0.0
            for m in range(3):
                f = F0[c, m]
                for n in range(3):
                    ur = 0.0
                    for i in range(6):
                        ur += bn[c, n, i] * uc[i]
                    f += K[c, m, n] * ur
                Fn[c, m] = f
            for i in range(6):
                f = -biot * p[c] * g_pressure[c, i]
                for m in range(3):
                    f += bn[c, m, i] * Fn[c, m]
                f_c[c, i] = f


@njit(cache=True)
def _tangent_kernel(cstate, status, sgn, soft, use_soft, k_intact, bn_c, bs_c, kn, ks, mu,
                    eps_open, out):  # pragma: no cover - compiled
    nc = cstate.shape[0]
    for c in range(nc):
        if cstate[c] == INTACT:
            for i in range(6):
                for j in range(6):
                    out[c, i, j] = k_intact[c, i, j]
            continue
        for i in range(6):
            for j in range(6):
                out[c, i, j] = 0.0
        for m in range(3):
            st = status[c, m]
            k_n = kn[c, m] * (1.0 if st != OPEN else eps_open)
            k_s = ks[c, m] * (1.0 if st == STICK else eps_open)
            k_sl = -mu[c, m] * sgn[c, m] * kn[c, m] if st == SLIP else 0.0
            if use_soft and soft[c, m]:
                # chattering contact: shear with its stick stiffness, no normal coupling
                k_s = ks[c, m]
                k_sl = 0.0
            for i in range(6):
                bni = bn_c[c, m, i]
                bsi = bs_c[c, m, i]
                for j in range(6):
                    out[c, i, j] += (k_n * bni * bn_c[c, m, j] + k_s * bsi * bs_c[c, m, j]
                                     + k_sl * bsi * bn_c[c, m, j])


def _f64(name: str, a, shape) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.shape != shape:
        raise InputError(f"{name} has shape {a.shape}, expected {shape}", key=name)
    return a


def _i64(name: str, a, shape) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.int64)
    if a.shape != shape:
        raise InputError(f"{name} has shape {a.shape}, expected {shape}", key=name)
    return a


def contact_response(u, dofs, cluster_state, ref_n, ref_s, p, *, bn, K, F0, bn_c, bs_c, kn,
                     ks, mu, g_pressure, biot: float, frozen=None):
    """Contact forces, statuses and cluster internal forces at a displacement.

    Parameters
    ----------
    u : ndarray (n_dof,) or (n_nodes, 2) [m]
        Nodal displacements.
    dofs : ndarray of int (n_c, 6)
        Global DOFs of each cluster.
    cluster_state : ndarray of int (n_c,)
        ``INTACT`` or a failed/contact state.
    ref_n, ref_s : ndarray (n_c, 3) [m]
        Stress-free references of the failed contacts' normal and shear relative
        displacements.
    p : ndarray (n_c,) [Pa]
        Cluster pressures (tension-positive convention: they push the faces apart).
    bn, K, F0 : ndarray (n_c, 3, 6), (n_c, 3, 3), (n_c, 3)
        Intact contact operators, micro-stiffness [N/m] and initial contact forces [N/m].
    bn_c, bs_c : ndarray (n_c, 3, 6)
        Normal and shear operators of the contacts of a failed cluster (their directions).
    kn, ks, mu : ndarray (n_c, 3)
        Normal and shear stiffness [N/m^2 per unit thickness] and friction coefficient of
        every contact.
    g_pressure : ndarray (n_c, 6) [m]
        Nodal force of a unit cluster pressure, ``A B^T (1, 1, 0)``.
    biot : float
        Pressure coefficient of intact clusters (failed ones take 1).
    frozen : tuple ``(mask, status, sign)`` of arrays (n_c, 3), optional
        Contacts held on one branch of their law (``OPEN``, ``STICK``, ``SLIP`` with a
        fixed sign): where ``mask`` is set (failed clusters only) the force is the linear
        law of that branch and the status/sign are the held ones.

    Returns
    -------
    Fn, Fs : ndarray (n_c, 3) [N/m]
        Normal (intact: ``F0 + K U_n``) and shear contact forces, tension positive.
    status : ndarray of int (n_c, 3)
        ``BONDED`` (intact), ``STICK``, ``SLIP`` or ``OPEN``.
    sgn : ndarray (n_c, 3)
        Sign of the trial shear force (the held sign where frozen).
    f_c : ndarray (n_c, 6) [N/m]
        Cluster internal forces on its DOFs.
    Un, Us : ndarray (n_c, 3) [m]
        Normal and shear relative displacements along the failed-state directions.
    """
    dofs = np.ascontiguousarray(dofs, dtype=np.int64)
    if dofs.ndim != 2 or dofs.shape[1] != 6:
        raise InputError(f"dofs has shape {dofs.shape}, expected (n_c, 6)", key="dofs")
    nc = dofs.shape[0]
    u = np.ascontiguousarray(u, dtype=np.float64).reshape(-1)
    if dofs.size and dofs.max() >= u.size:
        raise InputError(f"u has {u.size} entries, the DOFs reach {dofs.max()}", key="u")
    c3 = (nc, 3)
    cs = _i64("cluster_state", cluster_state, (nc,))
    args = (_f64("ref_n", ref_n, c3), _f64("ref_s", ref_s, c3), _f64("p", p, (nc,)),
            _f64("bn", bn, (nc, 3, 6)), _f64("K", K, (nc, 3, 3)), _f64("F0", F0, c3),
            _f64("bn_c", bn_c, (nc, 3, 6)), _f64("bs_c", bs_c, (nc, 3, 6)),
            _f64("kn", kn, c3), _f64("ks", ks, c3), _f64("mu", mu, c3),
            _f64("g_pressure", g_pressure, (nc, 6)), float(biot))
    if frozen is None:
        fmask = np.zeros(c3, dtype=np.bool_)
        fstat = np.zeros(c3, dtype=np.int64)
        fsign = np.zeros(c3)
    else:
        fmask = np.ascontiguousarray(np.broadcast_to(np.asarray(frozen[0], dtype=bool), c3))
        fmask = fmask & (cs != INTACT)[:, None]
        fstat = _i64("frozen status", frozen[1], c3)
        fsign = _f64("frozen sign", frozen[2], c3)
    Fn = np.empty(c3)
    Fs = np.empty(c3)
    status = np.empty(c3, dtype=np.int64)
    sgn = np.empty(c3)
    f_c = np.empty((nc, 6))
    Un = np.empty(c3)
    Us = np.empty(c3)
    _response_kernel(u, dofs, cs, *args, fmask, fstat, fsign, Fn, Fs, status, sgn, f_c,
                     Un, Us)
    return Fn, Fs, status, sgn, f_c, Un, Us


def tangent_blocks(cluster_state, status, sgn, *, k_intact, bn_c, bs_c, kn, ks, mu,
                   soft=None) -> np.ndarray:
    """Cluster tangent blocks ``dF_c/du_c`` (n_c, 6, 6) [N/m^2 per unit thickness].

    Intact clusters: ``k_intact``. Failed clusters: ``sum_m k_n b_n b_n^T + k_s b_s b_s^T
    - mu sgn k_n b_s b_n^T`` over the contacts, with an open contact's ``k_n`` and the
    shear of an open or slipping contact scaled by :data:`EPS_OPEN` (Jacobian only) and
    the friction term only on slipping contacts. ``soft`` (n_c, 3) marks chattering
    contacts whose shear is linearised with the stick stiffness and no normal coupling
    (an initial-stiffness tangent).

    Parameters
    ----------
    cluster_state : ndarray of int (n_c,)
    status : ndarray of int (n_c, 3)
    sgn : ndarray (n_c, 3)
        Shear sign of every contact (used on slipping ones).
    k_intact : ndarray (n_c, 6, 6)
    bn_c, bs_c : ndarray (n_c, 3, 6)
    kn, ks, mu : ndarray (n_c, 3)
    soft : ndarray of bool (n_c, 3), optional

    Returns
    -------
    ndarray (n_c, 6, 6)
    """
    cs = np.ascontiguousarray(cluster_state, dtype=np.int64)
    if cs.ndim != 1:
        raise InputError(f"cluster_state has shape {cs.shape}, expected (n_c,)",
                         key="cluster_state")
    nc = cs.shape[0]
    c3 = (nc, 3)
    use_soft = soft is not None
    sf = (np.ascontiguousarray(np.broadcast_to(np.asarray(soft, dtype=bool), c3))
          if use_soft else np.zeros(c3, dtype=np.bool_))
    out = np.empty((nc, 6, 6))
    _tangent_kernel(cs, _i64("status", status, c3), _f64("sgn", sgn, c3), sf, use_soft,
                    _f64("k_intact", k_intact, (nc, 6, 6)), _f64("bn_c", bn_c, (nc, 3, 6)),
                    _f64("bs_c", bs_c, (nc, 3, 6)), _f64("kn", kn, c3), _f64("ks", ks, c3),
                    _f64("mu", mu, c3), EPS_OPEN, out)
    return out
