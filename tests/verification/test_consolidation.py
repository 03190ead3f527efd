"""Terzaghi 1D consolidation with the monolithic poroelastic step (xlotkit.sim.coupling).

Column of height H on ``rectangle_mesh``: rollers on the sides and the bottom (oedometer,
``u_x = 0`` on both sides, ``u_y = 0`` at the bottom), a compressive load step ``q`` on the
top at t = 0, drained top (p = p0), all other sides sealed. Compressible fluid and grains
(alpha = 0.8), plane strain, so the constrained modulus is ``K_v = lambda + 2 G``.

Closed form (linear poroelasticity)::

    1/M = phi c_f + (alpha - phi)/K_s            gamma = alpha M / (K_v + alpha^2 M)
    p(z, 0+) - p0 = p_i = gamma q                 c = (k/mu) / (1/M + alpha^2/K_v)
    p(z, t) - p0 = p_i sum_k 2/m_k sin(m_k z/H) exp(-m_k^2 T),   m_k = (2k+1) pi/2,
    T = c t / H^2, z the depth below the drained top;
    settlement s(t) = [q H - alpha int_0^H (p - p0) dz] / K_v
                    = [q H - alpha p_i H sum_k 2/m_k^2 exp(-m_k^2 T)] / K_v.

Mesh choice. ``rectangle_mesh`` splits each cell into two right triangles sharing their
hypotenuse; their circumcentres coincide, and the flow model's TPFA then uses centroid
distances across that diagonal, which adds a spurious series resistance (measured steady
conductance of a 1 m wide, 40-cell column: 0.61 of exact; square cells: 0.75; see
docs/coupling.md). The column is therefore made of slender cells (width 0.01 m, cell
height 0.25 m): the diagonal is nearly parallel to the flow and the artefact drops to
0.1 % of the conductance (measured 0.9989). The mechanics (CST) is exact for this
1D strain field up to its O(h) discretisation.
"""

from __future__ import annotations

import numpy as np
import pytest

from xlotkit.sim.coupling import (
    CoupledModel,
    CoupledStepper,
    biot_modulus,
    boundary_load,
    grain_pore_compressibility,
)
from xlotkit.sim.flow import FlowModel, FluidProperties, OuterBoundary, RockFlowProperties
from xlotkit.sim.mechanics import InSituStress, MechanicsModel, RockProperties
from xlotkit.sim.mesh import TOP, rectangle_mesh

E, NU, ALPHA, PHI, CF, K, MU = 10e9, 0.25, 0.8, 0.2, 4.5e-10, 1e-15, 1e-3
P0, H, Q = 10e6, 10.0, 1e6
REPORT_T = (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)


def _closed_form():
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    G = E / (2 * (1 + NU))
    Kv = lam + 2 * G
    M = biot_modulus(ALPHA, PHI, CF, E, NU)
    p_i = ALPHA * M / (Kv + ALPHA ** 2 * M) * Q
    c = (K / MU) / (1 / M + ALPHA ** 2 / Kv)
    m = (2 * np.arange(400) + 1) * np.pi / 2

    def pressure(z, T):
        return p_i * np.sum(2 / m[:, None] * np.sin(m[:, None] * z / H)
                            * np.exp(-m[:, None] ** 2 * T), axis=0)

    def settlement(T):
        return (Q * H - ALPHA * p_i * H * np.sum(2 / m ** 2 * np.exp(-m ** 2 * T))) / Kv

    return p_i, c, pressure, settlement


@pytest.fixture(scope="module")
def terzaghi():
    mesh = rectangle_mesh(0.01, H, 1, 40)
    mech = MechanicsModel(mesh, RockProperties(young=E, poisson=NU, biot=ALPHA),
                          InSituStress(20e6, 20e6, 0.0, P0))
    flow = FlowModel(mesh, FluidProperties(compressibility=CF, viscosity=MU,
                                           reference_pressure=P0),
                     RockFlowProperties(K, PHI, grain_pore_compressibility(ALPHA, PHI, E, NU),
                                        P0),
                     outer=OuterBoundary({TOP: P0}), height=1.0)
    right = np.flatnonzero(np.isclose(mesh.nodes[:, 0], mesh.nodes[:, 0].max()))
    model = CoupledModel(mech, flow, load=boundary_load(mesh, TOP, Q), fixed_dofs=2 * right)
    stp = CoupledStepper(model)
    p_i, c, pressure, settlement = _closed_form()
    top = np.flatnonzero(np.isclose(mesh.nodes[:, 1], H / 2))
    z = H / 2 - flow.centres[:, 1]          # depth of each cell's pressure point

    def snapshot():
        return (stp.state.p - P0, -float(np.mean(stp.state.displacement[top, 1])))

    undrained = stp.step_undrained()
    snaps = {0.0: snapshot()}
    tc = H * H / c
    dt = 1e-4 * tc
    for T in REPORT_T:
        while stp.state.t < T * tc * (1 - 1e-12):
            h = min(dt, T * tc - stp.state.t)
            r = stp.step(h)
            assert r.success, r.reason
            dt = min(1.08 * dt, 0.005 * tc)   # Delta T <= 0.005: backward-Euler error
        snaps[T] = snapshot()
    return dict(model=model, stepper=stp, undrained=undrained, snaps=snaps, p_i=p_i,
                pressure=pressure, settlement=settlement, z=z)


def test_undrained_initial_pressure(terzaghi):
    dp, s = terzaghi["snaps"][0.0]
    p_i = terzaghi["p_i"]
    # uniform 1D state: exact up to the O(c_f dp) = 2e-4 density nonlinearity of the
    # discrete storage (measured 5e-5)
    assert np.allclose(dp, p_i, rtol=2e-4)
    # instantaneous settlement (q - alpha p_i) H / K_v: uniform strain, CST exact;
    # measured -2.8e-4 (same density effect, amplified by K_u / K_v)
    assert s == pytest.approx(terzaghi["settlement"](0.0), rel=2e-3)
    assert terzaghi["undrained"].relative_mass_balance_error <= 1e-8


@pytest.mark.parametrize("T", REPORT_T)
def test_pressure_and_settlement_vs_series(terzaghi, T):
    dp, s = terzaghi["snaps"][T]
    p_i = terzaghi["p_i"]
    exact = terzaghi["pressure"](terzaghi["z"], T)
    # 2 % of the initial excess pressure (task requirement). Measured max over cells:
    # 0.87 % (T = 0.01), 0.72 %, 0.63 %, 0.50 %, 0.26 %, 0.32 %, 0.19 % (T = 1): the
    # backward-Euler error of the growing steps and the P0 pressure cells (dz = 0.25 m
    # against a front of width ~ 2 sqrt(T) H = 2 m at T = 0.01)
    assert np.max(np.abs(dp - exact)) <= 0.02 * p_i
    s_ex = terzaghi["settlement"](T)
    s0 = terzaghi["settlement"](0.0)
    # total settlement within 2 % (measured <= 0.08 %), and the consolidation part
    # s - s0 within 2 % (measured <= 0.57 %, worst at T = 0.01 where it is smallest)
    assert s == pytest.approx(s_ex, rel=0.02)
    s_num0 = terzaghi["snaps"][0.0][1]
    assert (s - s_num0) == pytest.approx(s_ex - s0, rel=0.02)


def test_mass_balance_every_step(terzaghi):
    stp = terzaghi["stepper"]
    assert stp.counters.failed_steps == 0
    assert all(r.relative_mass_balance_error <= 1e-8 for r in stp.history)
    # the fluid expelled through the top equals the pore-volume loss (over all steps)
    out = sum(r.outflow_mass for r in stp.history)
    stored = sum(r.stored_mass_change for r in stp.history)
    assert out > 0 and abs(out + stored) <= 1e-8 * out
