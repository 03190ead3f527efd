"""KGD (plane-strain, toughness-dominated) hydraulic fracture: the reference solution.

The pure function :func:`xlotkit.sim.coupling.kgd_toughness` is checked against the
closed-form K-vertex and its own defining relations.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from xlotkit.errors import InputError
from xlotkit.sim.coupling import kgd_toughness

EP = 10e9 / (1 - 0.25 ** 2)
KIC = 1e6
Q = 1e-5


def test_k_vertex_closed_form():
    """No notch, incompressible system: l = 0.9324 (E' Q t / K')^(2/3) with
    K' = 4 sqrt(2/pi) K_IC (Detournay's K-vertex constant, 4 digits), K_I = K_IC,
    V = Q t, w0 = 4 p l / E'."""
    Kp = 4 * math.sqrt(2 / math.pi) * KIC
    for t in (0.1, 1.0, 30.0):
        s = kgd_toughness(t, Q, EP, KIC)
        assert s.propagating
        assert s.half_length == pytest.approx(0.9324 * (EP * Q * t / Kp) ** (2 / 3),
                                              rel=1e-4)   # the constant's 4 digits
        assert s.net_pressure * math.sqrt(math.pi * s.half_length) == pytest.approx(
            KIC, rel=1e-12)
        assert s.volume == pytest.approx(Q * t, rel=1e-10)
        assert s.mouth_opening == pytest.approx(4 * s.net_pressure * s.half_length / EP,
                                                rel=1e-14)
    # self-similar: l ~ t^(2/3), p ~ t^(-1/3)
    a, b = kgd_toughness(1.0, Q, EP, KIC), kgd_toughness(8.0, Q, EP, KIC)
    assert b.half_length / a.half_length == pytest.approx(4.0, rel=1e-10)
    assert b.net_pressure / a.net_pressure == pytest.approx(0.5, rel=1e-10)


def test_notch_and_compressible_system():
    """With a notch the pressure rises linearly in the stored volume until it reaches
    K_IC / sqrt(pi l0); afterwards the volume balance Q t = V + C (sigma + p - p_i) holds
    on the propagating branch."""
    l0, C, sig = 0.2, 2e-12, 5e6
    p_prop = KIC / math.sqrt(math.pi * l0)
    v_prop = 2 * math.pi * p_prop * l0 ** 2 / EP + C * p_prop
    t_prop = v_prop / Q
    early = kgd_toughness(0.5 * t_prop, Q, EP, KIC, notch_half_length=l0,
                          system_compliance=C, confining_stress=sig)
    assert not early.propagating and early.half_length == l0
    assert early.net_pressure == pytest.approx(0.5 * p_prop, rel=1e-12)
    for t in (1.01 * t_prop, 3 * t_prop, 20 * t_prop):
        s = kgd_toughness(t, Q, EP, KIC, notch_half_length=l0, system_compliance=C,
                          confining_stress=sig)
        assert s.propagating and s.half_length >= l0
        assert s.volume + C * s.net_pressure == pytest.approx(Q * t, rel=1e-10)
        assert s.net_pressure == pytest.approx(KIC / math.sqrt(math.pi * s.half_length),
                                               rel=1e-12)
    # a compressible system stores part of the injection: shorter than without
    t = 5 * t_prop
    assert (kgd_toughness(t, Q, EP, KIC, notch_half_length=l0, system_compliance=1e-11
                          ).half_length
            < kgd_toughness(t, Q, EP, KIC, notch_half_length=l0).half_length)


def test_crack_storage():
    """Fluid stored along the crack (``s`` per unit length, both wings ``2 l s``): the
    balance Q t = V + (C + 2 l s)(sigma + p - p_i) holds on both branches, the crack is
    shorter than without it, and s = 0 is the plain solution."""
    l0, C, sig, S = 0.2, 2e-12, 5e6, 4e-12
    kw = dict(notch_half_length=l0, system_compliance=C, confining_stress=sig)
    p_prop = KIC / math.sqrt(math.pi * l0)
    t_prop = (2 * math.pi * p_prop * l0 ** 2 / EP + (C + 2 * l0 * S) * p_prop) / Q
    early = kgd_toughness(0.5 * t_prop, Q, EP, KIC, crack_storage=S, **kw)
    assert not early.propagating and early.half_length == l0
    assert early.net_pressure == pytest.approx(0.5 * p_prop, rel=1e-12)
    for t in (1.01 * t_prop, 3 * t_prop, 20 * t_prop):
        s = kgd_toughness(t, Q, EP, KIC, crack_storage=S, **kw)
        assert s.propagating
        assert s.volume + (C + 2 * s.half_length * S) * s.net_pressure == pytest.approx(
            Q * t, rel=1e-10)
        assert s.net_pressure == pytest.approx(KIC / math.sqrt(math.pi * s.half_length),
                                               rel=1e-12)
        assert s.half_length < kgd_toughness(t, Q, EP, KIC, **kw).half_length
    assert kgd_toughness(3.0, Q, EP, KIC, crack_storage=0.0, **kw) == kgd_toughness(
        3.0, Q, EP, KIC, **kw)
    # no notch, compressible system: the stable branch starts at the minimum of the
    # injected volume over l (the crack appears there at a jump, as without storage)
    s_min = kgd_toughness(1e-9, Q, EP, KIC, system_compliance=1e-10, crack_storage=S)
    assert not s_min.propagating and s_min.half_length == 0.0
    late = kgd_toughness(100.0, Q, EP, KIC, system_compliance=1e-10, crack_storage=S)
    need = (2 * math.sqrt(math.pi) * KIC * late.half_length ** 1.5 / EP
            + (1e-10 + 2 * late.half_length * S) * late.net_pressure)
    assert late.propagating and need == pytest.approx(Q * 100.0, rel=1e-10)
    for f in (0.9, 0.99):       # grow(l) is increasing on the branch (stable)
        ell = f * late.half_length
        assert (2 * math.sqrt(math.pi) * KIC * ell ** 1.5 / EP
                + (1e-10 + 2 * ell * S) * KIC / math.sqrt(math.pi * ell)) < need


def test_bad_inputs():
    with pytest.raises(InputError):
        kgd_toughness(1.0, -1.0, EP, KIC)
    with pytest.raises(InputError):
        kgd_toughness(-1.0, Q, EP, KIC)
    with pytest.raises(InputError):
        kgd_toughness(1.0, Q, EP, KIC, crack_storage=-1e-12)
    with pytest.raises(InputError):
        kgd_toughness(1.0, Q, EP, KIC, crack_storage=1e-12, confining_stress=1e6,
                      initial_pressure=2e6)


# --------------------------------------------------------------------- coupled model
A_HOLE = 0.02       # injection "notch" hole radius [m]
H_BAND = 0.02       # element size along the fracture path [m]
BAND_LENGTH = 1.0   # the refined band reaches x = +-1 m
E, NU = 10e9, 0.25


def _kgd_setup():
    """Unconfined, impermeable rock (far field and pore pressure 0), a pre-cut notch of
    half-length ~0.1 m through a 2 cm hole, a band of 2 cm triangles along x to 1 m.

    Biot alpha = 0.01 with porosity 0.5 and c_r = 0 (``check_storage=False``: the grain
    term would need alpha >= phi): the intact rock's pore fluid then barely couples
    (undrained pressure change ~ alpha M eps ~ 4 kPa at the tip), as in the KGD model
    whose rock is dry and impermeable; failed clusters carry the fluid with coefficient 1.
    """
    from xlotkit.sim.coupling import CoupledModel
    from xlotkit.sim.flow import FlowModel, FluidProperties, RockFlowProperties, WellCondition
    from xlotkit.sim.mechanics import (
        InSituStress,
        MechanicsModel,
        RockProperties,
        StrengthScaling,
    )
    from xlotkit.sim.mesh import FractureBand, borehole_mesh

    mesh = borehole_mesh(size=6.0, radius=A_HOLE, growth=1.3, h_wall=2 * math.pi * A_HOLE / 8,
                         h_max=0.6,
                         fracture_band=FractureBand(0.0, 5 * H_BAND, H_BAND, BAND_LENGTH))
    rock = RockProperties(young=E, poisson=NU, biot=0.01, tensile_strength=5e6,
                          cohesion=50e6, scaling=StrengthScaling(enabled=True, toughness=KIC))
    mech = MechanicsModel(mesh, rock, InSituStress(0.0, 0.0, 0.0, 0.0))
    flow = FlowModel(mesh, FluidProperties(compressibility=4.5e-10, viscosity=1e-3),
                     RockFlowProperties(0.0, 0.5, 0.0, 0.0), WellCondition(rate=Q), height=1.0)
    model = CoupledModel(mech, flow, residual_aperture=1e-5, check_storage=False)
    ys = mesh.nodes[mesh.triangles, 1]
    r = np.hypot(*mesh.centroids.T)
    notch = np.flatnonzero((ys.min(axis=1) < 1e-3) & (ys.max(axis=1) > 1e-3) & (r < 0.1))
    return model, mech.fail_clusters(mech.initial_state(), notch)


def _half_length(mesh, cluster_state):
    """Half the tip-to-tip extent of the failed clusters along x [m] (their outer nodes)."""
    xs = mesh.nodes[mesh.triangles[cluster_state != 0], 0]
    return 0.5 * float(xs.max() - xs.min())


def _wing_tip(mesh, cluster_state):
    """Largest |x| of a failed cluster's node [m] (the longer wing's tip)."""
    return float(np.max(np.abs(mesh.nodes[mesh.triangles[cluster_state != 0], 0])))


def _band_storage(model, notch):
    """Fluid stored per unit crack length and pressure by the failed band's own pores,
    ``s = phi c_f b`` [m^2/(Pa m)]: the failed clusters keep their porosity, whose fluid the
    crack pressure compresses (their opening is the crack volume). ``b`` is the area of the
    pre-cut notch's clusters per unit tip-to-tip length (measured once, like K_app)."""
    flow = model.flow
    phi = np.broadcast_to(np.asarray(flow.porosity, dtype=float), (model.n_cells,))
    stored = float(np.sum(phi[notch] * flow.volumes[notch])) / model.height
    l0 = _half_length(model.mesh, np.isin(np.arange(model.n_cells), notch).astype(int))
    return flow.fluid.compressibility * stored / (2.0 * l0)


def _mouth_opening(mesh, state):
    """Opening at the hole: jump of u_y across the failed wall clusters [m]."""
    u = np.asarray(state.displacement)
    wall = np.zeros(mesh.n_nodes, bool)
    wall[mesh.hole_nodes] = True
    cs = state.cluster_state
    wc = np.flatnonzero((cs != 0) & wall[mesh.triangles].any(axis=1))
    return float(np.mean([np.ptp(u[mesh.triangles[c], 1]) for c in wc]))


def coupled_kgd_errors():
    """Run the coupled KGD case; relative errors against the reference at every accepted
    step with ``0.4 m <= l`` (``err_l, err_w, err_p``) and the run's diagnostics.

    The apparent toughness is measured once on this mesh: the net pressure at which the
    pressurised notch first extends (mechanics only, crack clusters at the wall pressure),
    ``K_app = p_ext sqrt(pi l0)``. The reference then includes the notch, the hole's fluid
    compressibility (``model.well_storage``) and the fluid the failed band's pores store by
    compression (:func:`_band_storage`). The run stops at ``l = 0.8 m`` or when a wing tip
    reaches the end of the refined band (the discrete crack need not grow symmetrically).
    """
    from xlotkit.sim.coupling import CoupledStepper, TimeStepControl
    from xlotkit.sim.mechanics import wall_pressure_at_first_failure

    model, ms = _kgd_setup()
    mesh = model.mesh
    cs0 = np.asarray(ms.cluster_state)
    l0 = _half_length(mesh, cs0)
    ext = wall_pressure_at_first_failure(model.mechanics, ms, p_max=5e6, dp=0.1e6, tol=1e3,
                                         pressurize_failed=True)
    k_app = ext.pressure * math.sqrt(math.pi * l0)
    s_band = _band_storage(model, np.flatnonzero(cs0 != 0))
    stp = CoupledStepper(model, model.initial_state(ms))
    rows = []

    def record(r, s):
        rows.append((r.t, _half_length(mesh, s.cluster_state), s.p_w,
                     _mouth_opening(mesh, s), r.relative_mass_balance_error))

    def stop(s):
        return (_half_length(mesh, s.cluster_state) >= 0.8
                or _wing_tip(mesh, s.cluster_state) >= BAND_LENGTH - 2 * H_BAND)

    res = stp.run(200.0, TimeStepControl(dt_initial=0.5, dt_min=1e-4, dt_max=2.0, n1=1,
                                         n2=4),
                  callback=record, stop=stop)
    ep = E / (1 - NU ** 2)
    err_l, err_p, err_w, mbs = [], [], [], []
    for t, ell, pw, w0, mb in rows:
        mbs.append(mb)
        if ell < 20 * H_BAND:
            continue
        ref = kgd_toughness(t, Q, ep, k_app, notch_half_length=l0,
                            system_compliance=model.well_storage, crack_storage=s_band)
        err_l.append(ell / ref.half_length - 1)
        err_p.append(pw / ref.net_pressure - 1)
        err_w.append(w0 / ref.mouth_opening - 1)
    info = dict(status=res.status, message=res.message, k_app=k_app, l0=l0,
                crack_storage=s_band, max_mass_balance=max(mbs), rows=rows)
    return np.array(err_l), np.array(err_w), np.array(err_p), info


@pytest.mark.slow
def test_coupled_kgd_against_toughness_solution():
    """Coupled run vs the KGD toughness solution with the model's apparent toughness
    (:func:`coupled_kgd_errors`), compared once the crack is >= 20 band elements long
    (l >= 0.4 m). Measured (K_I crack-tip criterion, ``failure_dilatation="pore"``,
    2026-12-01): K_app = 1.0228 MPa sqrt(m), 42 steps compared (l = 0.41 ... 0.82 m):
    length +3.6 ... +7.3 %, mouth opening -4.3 ... -1.9 %, net pressure -9.2 ... -5.4 %,
    mass balance <= 7.5e-17 per step. With ``"continuous"`` (the pre-failure stretch of
    a tip cluster kept out of the crack volume) the length error reached +12.1 %. History
    and the error budget: docs/coupling.md, "KGD verification"."""
    err_l, err_w, err_p, info = coupled_kgd_errors()
    assert info["status"] == "stopped", info["message"]
    assert info["max_mass_balance"] <= 1e-8
    assert len(err_l) >= 10
    # issue 5: length, mouth opening and net pressure within 10 % of the KGD solution at
    # every compared step. 10 % covers what the discrete model cannot remove: the tip
    # advances a band element (5 % of l at l = 0.4 m) at a time, so length and pressure
    # saw-tooth around the continuous solution, and the band's failed clusters are a
    # 2 cm wide strip, not a line crack (the measured bias is -7 % in pressure).
    assert np.max(np.abs(err_l)) <= 0.10, err_l
    assert np.max(np.abs(err_w)) <= 0.10, err_w
    assert np.max(np.abs(err_p)) <= 0.10, err_p
