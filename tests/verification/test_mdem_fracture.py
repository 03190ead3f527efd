"""MDEM fracture mechanics against analytic solutions: Sneddon opening, Hubbert-Willis
breakdown, and the effect of triangle-size strength scaling."""

import math

import numpy as np
import pytest

from xlotkit.sim.mechanics import (
    FAILED_TENSILE,
    OPEN,
    InSituStress,
    MechanicsModel,
    RockProperties,
    StrengthScaling,
    breakdown_pressure,
    crack_tip_toughness,
    wall_pressure_at_first_failure,
)
from xlotkit.sim.mechanics import mdem
from xlotkit.formulas import (
    critical_distance,
    critical_distance_breakdown,
    hubbert_willis,
    sneddon_width,
)
from xlotkit.sim.mesh import FractureBand, borehole_mesh

E, NU = 10e9, 0.25


def _crack_setup(h_band, half_length, rock, size=40.0):
    """Pre-cut crack along y = 0 through a small hole: clusters touching the line fail."""
    mesh = borehole_mesh(size=size, radius=0.02, growth=1.2,
                         fracture_band=FractureBand(0.0, 4 * h_band, h_band, 1.2 * half_length))
    model = MechanicsModel(mesh, rock, InSituStress(0.0, 0.0, 0.0, 0.0))
    y = mesh.nodes[:, 1][mesh.triangles]
    # clusters *touching* the line: a node on the line must not bridge the crack faces
    cut = (y.max(axis=1) >= 0) & (y.min(axis=1) <= 0) & (
        np.abs(mesh.centroids[:, 0]) < half_length)
    state = model.fail_clusters(model.initial_state(), np.nonzero(cut)[0])
    return mesh, model, state, cut


def _opening(mesh, u, cut, xs):
    nodes = np.unique(mesh.triangles[cut])
    top = nodes[mesh.nodes[nodes, 1] > 1e-9]
    bot = nodes[mesh.nodes[nodes, 1] < -1e-9]

    def face(ids):
        o = np.argsort(mesh.nodes[ids, 0])
        return np.interp(xs, mesh.nodes[ids[o], 0], u[ids[o], 1])

    return face(top) - face(bot)


def test_pressurised_crack_opens_like_sneddon():
    a, p = 1.0, 1e6
    rock = RockProperties(young=E, poisson=NU, tensile_strength=1e12, cohesion=1e12)
    mesh, model, s1, cut = _crack_setup(0.02, a, rock)
    res = model.step(s1, wall_pressure=p, pore_pressure=np.where(cut, p, 0.0),
                     check_failure=False)
    assert res.converged, res.reason
    xs = np.linspace(-0.9 * a, 0.9 * a, 37)
    w = _opening(mesh, res.state.displacement, cut, xs)
    w_max = 4 * p * (1 - NU ** 2) * a / E
    # the maximum opening (next to the 2 cm hole at the centre) within 5 %: measured
    # -2.8 % on this band (h = a/50); the deficit is the band's finite thickness and the
    # shear springs of its closed face-parallel contacts, and halves with h
    w_centre = w[np.abs(xs) < 0.06].max()
    assert w_centre == pytest.approx(w_max, rel=0.05)
    # the whole profile follows the ellipse within 5 % of w_max
    assert np.max(np.abs(w - sneddon_width(xs, a, p, E, NU))) < 0.05 * w_max
    # the crack is open along its length: contacts crossing it carry nothing
    st = res.state
    assert st.n_open > 0.6 * 3 * cut.sum()
    assert np.all(st.gap[st.contact_status == OPEN] > 0)


def _breakdown(n_wall, scaling=None):
    mesh = borehole_mesh(h_wall=2 * math.pi * 0.15 / n_wall)
    rock = RockProperties(tensile_strength=5e6, cohesion=15e6,
                          scaling=scaling or StrengthScaling())
    model = MechanicsModel(mesh, rock, InSituStress(35e6, 30e6, 0.0, 20e6))
    br = wall_pressure_at_first_failure(model, model.initial_state(), 60e6, dp=2e6, tol=1e3)
    return mesh, br


def test_impermeable_hole_breaks_down_at_hubbert_willis_perpendicular_to_sigma_min():
    # sigma_H = sigma_x = 35, sigma_h = sigma_y = 30, p0 = 20, T0 = 5 MPa -> 40 MPa
    hw = hubbert_willis(30e6, 35e6, 20e6, 5e6)   # sigma_h, sigma_H, p0, T0
    mesh, br = _breakdown(64)  # default wall resolution
    # measured -0.4 %: a wall cluster's hoop strain is measured by its contact lying on
    # the wall itself, so the cluster-average criterion sees nearly the wall value
    assert br.pressure == pytest.approx(hw, rel=0.05)
    assert np.all(br.mode == FAILED_TENSILE)
    # first failures sit at the wall on the sigma_H axis (theta = 0 or 180 deg) ...
    c = mesh.centroids[br.clusters]
    ang = np.degrees(np.arctan2(c[:, 1], c[:, 0]))
    assert np.all(np.minimum(np.abs(ang), 180 - np.abs(ang)) < 5.0)
    assert np.all(np.hypot(*c.T) < 0.15 + 0.02)
    # ... and the opened sub-edges have normals along y (sigma_min): the crack plane is
    # perpendicular to sigma_min
    st = br.result_after.state
    is_open = st.contact_status == OPEN
    cl, m = np.nonzero(is_open)
    g = mdem.cluster_geometry(mesh.nodes, mesh.triangles)
    ny = np.abs(g.normal[cl, m, 1])
    assert len(ny) > 0 and np.all(ny > 0.9)


def test_breakdown_pressure_is_insensitive_to_wall_resolution_without_scaling():
    # 32 vs 96 wall segments: measured 40.21 vs 39.69 MPa (HW 40); initiation at a smooth
    # wall has no length scale, so the nominal strength needs no size correction
    _, coarse = _breakdown(32)
    _, fine = _breakdown(96)
    hw = hubbert_willis(30e6, 35e6, 20e6, 5e6)   # sigma_h, sigma_H, p0, T0
    assert abs(coarse.pressure - hw) < 0.02 * hw
    assert abs(fine.pressure - hw) < 0.02 * hw


def _extension_pressure(h_band, scaling, half_length=0.5):
    rock = RockProperties(young=E, poisson=NU, tensile_strength=1e6, cohesion=1e12,
                          scaling=scaling)
    mesh, model, s1, _ = _crack_setup(h_band, half_length, rock, size=10.0)
    br = wall_pressure_at_first_failure(model, s1, 5e6, dp=0.05e6, tol=1e2,
                                        pressurize_failed=True)
    tip = mesh.centroids[br.clusters]
    assert np.all(np.abs(tip[:, 0]) > 0.9 * half_length)  # the crack grows at its tips
    return br.pressure


def test_strength_scaling_makes_crack_extension_pressure_mesh_independent():
    # A pressurised crack (half-length 0.5 m) grows when its tip cluster fails. The tip
    # cluster averages a sqrt(r) singular field over its size h, so without scaling the
    # extension pressure grows like sqrt(h) (LEFM: K = p sqrt(pi a) ~ T sqrt(h)). With
    # crack-tip scaling the tip is a toughness criterion, K_I (interaction integral over a
    # domain of 3-6 tip sizes) >= K_IC = 1.11 T A_ref^(1/4), so it does not depend on h.
    off = StrengthScaling(enabled=False)
    on = StrengthScaling(enabled=True, reference_area=1e-4)
    p_off = [_extension_pressure(h, off) for h in (0.04, 0.02)]
    p_on = [_extension_pressure(h, on) for h in (0.04, 0.02)]
    d_off = abs(p_off[0] - p_off[1])
    d_on = abs(p_on[0] - p_on[1])
    # measured: off 0.175 vs 0.120 MPa (ratio ~ sqrt 2), on 0.0881 vs 0.0896 MPa (with
    # the earlier cluster-average tip criterion 0.0882 vs 0.0897: both cracks end on flat
    # tips, where the two criteria agree)
    assert p_off[0] / p_off[1] == pytest.approx(math.sqrt(2), rel=0.1)
    assert d_on < 0.5 * d_off
    # and the scaled extension is the documented toughness: K = p sqrt(pi a) equals
    # crack_tip_toughness (1.11 T A_ref^(1/4) = 0.111 MPa sqrt(m)); measured -0.5 % and
    # +1.1 %. 5 % covers the outer-node length (1-2 % on the KGD band, see
    # test_crack_tip_toughness_does_not_depend_on_the_tip_shape) twice over.
    k_ic = crack_tip_toughness(RockProperties(tensile_strength=1e6, scaling=on))
    for p in p_on:
        assert p * math.sqrt(math.pi * 0.5) == pytest.approx(k_ic, rel=0.05)


@pytest.mark.slow
def test_given_toughness_is_the_extension_toughness_of_a_shorter_crack():
    # K_IC given directly (A_ref derived from it), half the crack length of the test above
    # (0.25 m, h/a = 0.08): LEFM predicts p_ext = K_IC / sqrt(pi a) = 0.2257 MPa; measured
    # 0.2257 MPa (+0.0 %; 0.2259 with the earlier cluster-average tip criterion): the tip
    # criterion is a toughness, p_ext ~ a^(-1/2). Tolerance 5 % as above. (~5 s)
    k_ic = 0.2e6
    sc = StrengthScaling(True, toughness=k_ic)
    assert crack_tip_toughness(RockProperties(tensile_strength=1e6, scaling=sc)) == \
        pytest.approx(k_ic, rel=1e-12)
    p = _extension_pressure(0.02, sc, half_length=0.25)
    assert p * math.sqrt(math.pi * 0.25) == pytest.approx(k_ic, rel=0.05)


def _runaway(n_wall, scaling=None, stress=(35e6, 30e6, 20e6, None), T=5e6, S0=15e6):
    """Breakdown = hole pressure at which the hole-fluid-filled crack runs away."""
    mesh = borehole_mesh(h_wall=2 * math.pi * 0.15 / n_wall)
    rock = RockProperties(tensile_strength=T, cohesion=S0, scaling=scaling or StrengthScaling())
    sx, sy, p0, pw0 = stress
    model = MechanicsModel(mesh, rock, InSituStress(sx, sy, 0.0, p0, pw0))
    return breakdown_pressure(model, 60e6, dp=1e6, tol=1e4)


def _off_axis_deg(azimuth):
    a = abs(math.degrees(azimuth)) % 180.0
    return min(a, 180.0 - a)


def test_breakdown_runaway_is_hubbert_willis_along_sigma_H_and_crack_tip_scaling_keeps_it():
    # Thesis stresses: 3 sh - sH - p0 + T = 40 MPa >> sh = 30 MPa, so the crack filled at
    # initiation has 10 MPa net pressure and runs through any toughness: breakdown (runaway)
    # equals initiation. Measured on 32 wall segments: 40.21 MPa without scaling and with
    # crack-tip scaling whose wall keeps the cluster average (intact wall clusters keep the
    # nominal T; the tip clusters' size factor only changes how easily an already running
    # crack grows). With the crack tips' toughness (K_IC = 1.11 T A_ref^(1/4) = 0.555
    # MPa m^0.5) the wall's point method sits at L/2 = 2.0 mm (L = (K_IC/T)^2/pi): the
    # Kirsch point value is 40.59 MPa (+1.5 % over Hubbert-Willis, L/a = 0.026: the small
    # material-length limit), measured 40.64 MPa (+0.1 %).
    hw = hubbert_willis(30e6, 35e6, 20e6, 5e6)   # sigma_h, sigma_H, p0, T0
    k_ic = 1.11 * 5e6 * 1e-4 ** 0.25
    tcd = critical_distance_breakdown(30e6, 35e6, 20e6, 5e6, 0.15,
                                      0.5 * critical_distance(k_ic, 5e6))
    off = _runaway(32)
    cluster = _runaway(32, StrengthScaling(True, reference_area=1e-4, mode="crack_tip",
                                           wall="cluster"))
    tip = _runaway(32, StrengthScaling(True, reference_area=1e-4, mode="crack_tip"))
    for b in (off, cluster, tip):
        assert b.converged, b.reason
        assert b.pressure == pytest.approx(hw, rel=0.05)           # measured +0.5 / +1.6 %
        assert b.pressure == pytest.approx(b.initiation_pressure, abs=2e4)
        # it really ran: to 20 radii, or > 4 radii growing at constant pressure until the
        # quasi-static equilibrium was lost (measured 1.8 m = 12 radii unscaled and 0.93 m
        # = 6 radii with crack-tip scaling on this mesh)
        assert b.runaway_length > 4 * 0.15
        assert _off_axis_deg(b.azimuth) < 10.0                      # along sigma_H (x)
        assert _off_axis_deg(b.start_azimuth) < 10.0                # starts along x
    # the cluster-average wall: the same pressure to the bisection tolerance (10 kPa)
    assert abs(cluster.pressure - off.pressure) <= 2e4
    # the point method: the Kirsch value at L/2 to 1 % (the recovery's error at the wall,
    # 0.1-0.3 MPa on 9-48 segments, docs/mechanics.md, plus the 10 kPa bracket)
    assert tip.pressure == pytest.approx(tcd, rel=0.01)


@pytest.mark.slow
def test_breakdown_runaway_wall_resolution_hubbert_willis_case():
    # 32 vs 96 wall segments (~45 s). Measured: unscaled 40.21 / 39.70 MPa, crack-tip
    # scaling identical (breakdown = initiation, no length scale), scaling of every cluster
    # 38.66 / 40.52 MPa. The 0.5 MPa (1.3 %) left is the O(h) error of the discrete wall
    # stress, which a strength-size factor cannot and should not remove.
    # Direction: the crack must *start* perpendicular to sigma_min (issue 4), checked on
    # the clusters at the wall. With crack-tip scaling on 96 segments the run loses its
    # quasi-static equilibrium at 3.85 m (0.92 m with the earlier cluster-average tip
    # criterion) and the unconverged cascade has failed 487 clusters; the wall clusters'
    # axis is 5 deg off x (measured). The end of a dynamic run has no meaningful
    # quasi-static shape, so the final azimuth is checked only without scaling. (A trial
    # version of the toughness criterion without the crack-end test of
    # MechanicsModel.crack_fronts let the wall clusters beside the crack mouth take the
    # running crack's K: the whole wall ring failed, start axis 67 deg off x on 32
    # segments, measured.)
    hw = hubbert_willis(30e6, 35e6, 20e6, 5e6)   # sigma_h, sigma_H, p0, T0
    off = [_runaway(n) for n in (32, 96)]
    tip = [_runaway(n, StrengthScaling(True, 1e-4, mode="crack_tip")) for n in (32, 96)]
    for b in off + tip:
        assert b.converged, b.reason
        assert abs(b.pressure - hw) < 0.02 * hw
        assert _off_axis_deg(b.start_azimuth) < 10.0
    for b in off:
        assert _off_axis_deg(b.azimuth) < 10.0
    d_off = abs(off[0].pressure - off[1].pressure)
    d_tip = abs(tip[0].pressure - tip[1].pressure)
    assert d_tip <= d_off + 2e4


@pytest.mark.slow
def test_propagation_controlled_breakdown_is_mesh_insensitive_with_crack_tip_scaling():
    # sH = 45, sh = 30, p0 = 20, T = 3 MPa: initiation (28 MPa Hubbert-Willis; 30.36 /
    # 28.24 MPa on 32 / 96 wall segments, the O(h) wall-stress error) is below sh; the
    # crack arrests in the hoop-tension zone and breakdown is the pressure at which it runs
    # away. Without scaling the tip clusters need an opening stress p - p0 + T, whose
    # confinement part does not shrink with h, so the graded meshes hold the crack until
    # 37.56 / 36.95 MPa (difference 0.61 MPa). The crack-tip criterion compares only the
    # singular part, now K_I by the interaction integral, with K_IC = 1.11 T A_ref^(1/4)
    # = 0.33 MPa sqrt(m): measured 30.36 / 30.18 MPa (difference 0.18 MPa; the earlier
    # cluster-average tip criterion gave 30.36 / 30.47), just above sh as LEFM predicts for
    # a toughness this small (a crack fed at p > sh runs once K_I = (p - sh)
    # sqrt(pi (L + a)) > K_IC; on 96 segments it grows stably to 1.39 m at 30.18 MPa). On 32
    # segments breakdown is the (overestimated) initiation. (~1-3 min: four searches.)
    stress = (45e6, 30e6, 20e6, 25e6)
    kw = dict(stress=stress, T=3e6, S0=20e6)
    off = [_runaway(n, **kw) for n in (32, 96)]
    tip = [_runaway(n, StrengthScaling(True, 1e-4), **kw) for n in (32, 96)]
    for b in off + tip:
        assert b.converged, b.reason
        assert b.runaway_length > 4 * 0.15
        assert _off_axis_deg(b.azimuth) < 10.0
    d_off = abs(off[0].pressure - off[1].pressure)
    d_tip = abs(tip[0].pressure - tip[1].pressure)
    assert d_tip < 0.5 * d_off
    # toughness-controlled: breakdown at most ~0.5 MPa above sigma_h (measured +0.36 /
    # +0.18 MPa) and never below it (a crack fed at p < sigma_h arrests)
    for b in tip:
        assert 30e6 <= b.pressure < 31e6


# ------------------------------------------------------- tip shape (KGD fracture band)
def _kgd_band_model():
    """The mechanics of tests/verification/test_kgd.py: unconfined rock (E = 10 GPa,
    nu = 0.25), K_IC = 1 MPa sqrt(m) given, a 2 cm hole and a band of 2 cm triangles along
    x to +-1 m. The band's nodes lie in columns across it (alternate columns offset by
    half a spacing), so a straight crack along x ends alternately on a column edge (flat
    tip) or at a single node (pointed tip)."""
    mesh = borehole_mesh(size=6.0, radius=0.02, growth=1.3, h_wall=2 * math.pi * 0.02 / 8,
                         h_max=0.6, fracture_band=FractureBand(0.0, 0.1, 0.02, 1.0))
    rock = RockProperties(young=E, poisson=NU, biot=0.01, tensile_strength=5e6,
                          cohesion=50e6, scaling=StrengthScaling(True, toughness=1e6))
    return mesh, MechanicsModel(mesh, rock, InSituStress(0.0, 0.0, 0.0, 0.0))


def _straight_cut(mesh, radius):
    """Clusters crossing y = 1 mm with centroid radius < ``radius`` (the KGD notch for
    0.1 m) and half the tip-to-tip extent of their nodes."""
    ys = mesh.nodes[mesh.triangles, 1]
    cut = ((ys.min(axis=1) < 1e-3) & (ys.max(axis=1) > 1e-3)
           & (np.hypot(*mesh.centroids.T) < radius))
    xs = mesh.nodes[mesh.triangles[cut], 0]
    return cut, 0.5 * float(xs.max() - xs.min())


def test_crack_tip_toughness_does_not_depend_on_the_tip_shape():
    # Pre-cut straight cracks filled with the wall pressure, mechanics only: the pressure
    # at which the first cluster fails, as K = p sqrt(pi l) / K_IC with l half the outer
    # nodes' extent. With the cluster-average tip criterion: 0.989-1.030 at flat tips
    # (R = 0.1, 0.15, 0.2) but 1.19 / 1.34 / 1.38 at pointed ones (R = 0.105, 0.125,
    # 0.145), where the two clusters beside the tip node failed (docs/coupling.md). With
    # K_I from the interaction integral: measured 1.023, 1.014, 1.011 (flat) and 1.020,
    # 1.021, 1.019 (pointed); the 1-2 % above 1 is the outer-node length, which
    # overestimates the discrete crack's (K_I / (p sqrt(pi l)) = 0.97-0.98 at l = 0.1 m, 0.99 at
    # 0.3 m). The failing cluster continues the crack: at its end, inside the band row.
    mesh, model = _kgd_band_model()
    s0 = model.initial_state()
    ks = {}
    for radius in (0.1, 0.15, 0.2, 0.105, 0.125, 0.145):
        cut, ell = _straight_cut(mesh, radius)
        st = model.fail_clusters(s0, np.flatnonzero(cut))
        br = wall_pressure_at_first_failure(model, st, 3e6, dp=0.2e6, tol=1e3,
                                            pressurize_failed=True)
        ks[radius] = br.pressure * math.sqrt(math.pi * ell) / 1e6
        c = mesh.centroids[br.clusters]
        assert np.all(np.abs(c[:, 0]) > ell - 0.03) and np.all(np.abs(c[:, 1]) < 0.015)
    flat = [ks[r] for r in (0.1, 0.15, 0.2)]
    pointed = [ks[r] for r in (0.105, 0.125, 0.145)]
    for k in flat + pointed:
        assert k == pytest.approx(1.0, abs=0.04)
    assert abs(np.mean(pointed) - np.mean(flat)) < 0.02
    assert max(flat + pointed) - min(flat + pointed) < 0.03


@pytest.mark.slow
def test_crack_grows_straight_from_the_notch_at_one_toughness():
    # Quasi-static growth from the KGD notch, mechanics only, one cluster at a time: the
    # crack filled at p (far field and pore pressure 0) is linear in p, so one solve at
    # 1 MPa gives every margin's load part, the extension pressure is the smallest
    # T_i / load_i, and the cluster reaching it fails next. With the cluster-average tip
    # criterion the thresholds alternated 0.98-1.11 / 1.19-1.38 K_IC (flat / pointed
    # tips) and at the first pointed tip a cluster beside the crack failed, the path
    # kinking out of the band along a 26.6 deg lattice row (docs/coupling.md). Measured
    # now over 60 clusters: thresholds 1.002-1.023 K_IC, failed centroids |y| <= 0.0143 m
    # (the band row the notch is cut in), both wings grow (failed centroids from -0.492
    # to +0.288 m: which wing goes first is decided by 1 % differences in K_I, as between
    # two equal tips it must be). (~10 s)
    mesh, model = _kgd_band_model()
    cut, _ = _straight_cut(mesh, 0.1)
    s0 = model.initial_state()
    ks = []
    for _ in range(60):
        st = model.step(model.fail_clusters(s0, np.flatnonzero(cut)), wall_pressure=1e6,
                        pore_pressure=np.where(cut, 1e6, 0.0), check_failure=False).state
        mt, _ = model.failure_margins(st)
        T, _ = model.strengths(st.cluster_state)
        load = mt + T
        lam = np.where((st.cluster_state == 0) & (load > 0), T / np.maximum(load, 1e-30),
                       np.inf)
        nxt = int(np.argmin(lam))
        xs = mesh.nodes[mesh.triangles[cut], 0]
        ks.append(lam[nxt] * math.sqrt(math.pi * 0.5 * float(xs.max() - xs.min())))
        cut = cut.copy()
        cut[nxt] = True
    c = mesh.centroids[cut]
    assert np.all(np.abs(c[:, 1]) < 0.02)
    assert c[:, 0].min() < -0.2 and c[:, 0].max() > 0.2
    assert min(ks) > 0.98 and max(ks) < 1.04
