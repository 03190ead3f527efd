"""Run a 2D scene step by step and check the invariants every hard case must keep.

The invariants (issue 7, "hard cases stay stable"):

* the run finishes (no step fails at the floor, every phase of the schedule is reached);
* the relative mass-balance error of every accepted step is <= 1e-8;
* no aperture sign-flip oscillation: within a phase, no failed cluster's crack alternates
  open, closed, open, closed (or the reverse) over four consecutive steps;
* no layers of failed wall clusters: every failed cluster touching the hole lies within
  ``wall_sector`` degrees of the crack's axis (both mouths), none elsewhere on the wall;
* the bottom-hole pressure follows the well model: while the rock is intact in the first
  pump phase, ``dp/dt = Q rho0 / (rho(p) C_total)`` within 2 % (``C_total``: the well
  row's storage plus the discrete hole's elastic compliance);
* no accepted step shorter than the floor, except steps that land on a phase end or an
  event (their length is set by the schedule, not by the solver).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse.linalg as spla

from xlotkit.sim.coupling.engine import MDEMEngine
from xlotkit.sim.coupling.geometry import fracture_summary
from xlotkit.sim.scene import scene_from_dict

BASE = {
    "title": "stability case", "model": "mdem",
    "geometry": {"domain_size": "4 m", "hole_radius": "0.15 m", "segment_height": "10 m"},
    "mesh": {"growth": 1.3, "wall_element_size": "0.08 m", "fracture_band": True,
             "band_width": "0.3 m", "band_length": "2 m"},   # to the domain's edge
    "rock": {"youngs_modulus": "10 GPa", "poisson_ratio": 0.25, "porosity": 0.1,
             "permeability": 1e-18, "tensile_strength": "3 MPa", "cohesion": "20 MPa",
             "friction_angle": "30 deg"},
    "stresses": {"sigma_H": "40 MPa", "sigma_h": "30 MPa", "pore_pressure": "20 MPa"},
    "fluid": {"density": "1.1 sg", "viscosity": "1 cP"},
    # the well starts pressured to 30 MPa (the test is about breakdown, not the pump-in)
    "completion": {"depth": "2000 m", "initial_pressure": "30 MPa"},
    "effects": {"strength_scaling": True},
    "numerics": {"dt_min": "1e-4 s", "dt_max": "5 s", "dp_max": "1 MPa"},
    "output": {"log_interval": "1 s"},
    "schedule": {"phase": [
        {"kind": "pump", "rate": "300 l/min", "pressure_above": "34 MPa",
         "duration": "10 min"},
    ]},
}


def scene_dict(**over) -> dict:
    """:data:`BASE` with sections updated (a dict replaces keys, a key given None is
    dropped, a list replaces)."""
    import copy

    d = copy.deepcopy(BASE)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(d.get(k), dict):
            d[k] = {kk: vv for kk, vv in {**d[k], **v}.items() if vv is not None}
        elif v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return d


@dataclass
class StabilityRun:
    """What :func:`run` saw, one entry per accepted step."""

    engine: MDEMEngine
    t: list = field(default_factory=list)
    dt: list = field(default_factory=list)
    phase: list = field(default_factory=list)
    scheduled: list = field(default_factory=list)   # the step landed on a phase end/event
    mass_balance: list = field(default_factory=list)
    crack_open: list = field(default_factory=list)  # per cluster: 1 open, 0 closed, -1 intact
    p: list = field(default_factory=list)           # cell pressures [Pa]
    p_w: list = field(default_factory=list)         # well pressure [Pa]
    error: str = ""
    stopped: bool = False                            # ended by the crack-length stop


def run(data: dict, stop_length: float | None = None) -> StabilityRun:
    """Run the scene ``data`` to the end (or to its first error) and record every step.

    ``stop_length`` [m]: stop once the crack is this long tip to tip (the domain of a fast
    test is small; a breakdown into a whole well's storage would otherwise run the crack
    into its edge). ``StabilityRun.stopped`` then says so."""
    sc = scene_from_dict(data)
    e = MDEMEngine(sc)
    e.start()
    out = StabilityRun(e)
    cm = None
    try:
        while not e.is_done():
            if stop_length is not None and out.t and fracture_summary(
                    e.cm, e.stepper.state).length >= stop_length:
                out.stopped = True
                break
            t_old = e.time
            o = e.step()
            if not o.ok or not (o.reason == "accepted" or o.reason.startswith("phase end:")):
                continue
            cm = e.cm
            st = e.stepper.state
            r = e.stepper.history[-1]
            out.t.append(st.t)
            out.dt.append(st.t - t_old)
            out.phase.append(len(e.phases_out))
            out.scheduled.append(o.reason.startswith("phase end:") or e._retry is not None)
            out.mass_balance.append(r.relative_mass_balance_error)
            cs = st.cluster_state
            _, _, wn, _ = cm.crack_permeability(cs, np.asarray(st.mechanics.gap))
            out.crack_open.append(np.where(cs != 0, (wn > 0).astype(int), -1))
            out.p.append(np.array(st.p))
            out.p_w.append(float(st.p_w))
    except Exception as exc:  # noqa: BLE001 -- the invariant "finishes" reports it
        out.error = f"{type(exc).__name__}: {exc}"
    return out


def sign_flips(r: StabilityRun) -> int:
    """Aperture sign-flip oscillations: a failed cluster whose crack alternates open,
    closed, open, closed (or the reverse) over four consecutive steps of one phase (the
    step-to-step sawtooth of thesis Fig. 4.5). One reversal alone is not counted: a crack
    face behind an advancing tip may close and open again as the tip passes."""
    n = 0
    co = r.crack_open
    for k in range(3, len(co)):
        if len(set(r.phase[k - 3:k + 1])) != 1:
            continue
        a, b, c, d = co[k - 3], co[k - 2], co[k - 1], co[k]
        known = (a >= 0) & (b >= 0) & (c >= 0) & (d >= 0)
        n += int(np.sum(known & (a == c) & (b == d) & (a != b)))
    return n


def wall_failures_off_axis(r: StabilityRun, sector_deg: float) -> int:
    """Failed clusters at the wall farther than ``sector_deg`` from both the crack's axis
    and the sigma_H direction.

    The crack leaves the wall along sigma_H (the hoop stress is least there); the axis
    fitted to the whole crack tilts away from that mouth when the wings are unequal
    (measured: wings of 0.53 and 1.27 m on the coarse graded mesh, axis -5.4 deg, the
    mouth's wall clusters at +-6.4 and +-23.4 deg). A wall failure is spurious only when
    it is off both."""
    e = r.engine
    st = e.stepper.state
    cs = st.cluster_state
    failed = cs != 0
    if not failed.any():
        return 0
    fs = fracture_summary(e.cm, st)
    xc = e.cm.mesh.centroids[failed & e._at_wall]
    off = np.full(len(xc), np.inf)
    for axis_deg in (fs.azimuth_deg, e.scene.stresses.sigma_H_azimuth):
        ang = np.arctan2(xc[:, 1], xc[:, 0]) - math.radians(axis_deg)
        # distance to the nearer mouth (axis or axis + 180 deg)
        off = np.minimum(off, np.degrees(np.abs(np.angle(np.exp(2j * ang)) / 2)))
    return int(np.sum(off > sector_deg))


def intact_pressurisation_slope_error(r: StabilityRun) -> float:
    """Relative error of the first pump phase's slope while intact vs the well model."""
    e = r.engine
    rows = e.rows()
    t, p = rows["t"], rows["bottomhole_pressure"]
    t_end = e.phases_out[0]["t_end"] if e.phases_out else float(t[-1])
    if e.truth_events["initiation_time"] is not None:
        t_end = min(t_end, e.truth_events["initiation_time"])
    sel = (t > 2.0) & (t < t_end - 1.0)
    if np.sum(sel) < 3:
        return math.nan
    slope = np.polyfit(t[sel], p[sel], 1)[0]
    sc = e.scene
    q = float(sc.schedule.expanded()[0][1].rate)
    cm = e.cm
    # the well row's storage (the whole well, or the hole's own fluid without well
    # storage) plus the discrete hole's elastic enlargement h f_w . K^-1 f_w (the polygonal
    # hole in a finite domain is ~20 % stiffer than the analytic 2 pi a^2 h (1 + nu) / E,
    # which matters when the well stores little)
    du = spla.spsolve(cm.mechanics.tangent(cm.mech_state0).tocsc(), cm.f_wall)
    c_total = cm.well_storage + cm.height * float(cm.f_wall @ du)
    dens = math.exp(-sc.fluid.compressibility * float(np.mean(p[sel])))
    return slope / (q * dens / c_total) - 1.0


def assert_stable(r: StabilityRun, *, dt_floor: float = 1e-4, wall_sector: float = 25.0,
                  check_slope: bool = True) -> None:
    """Assert every invariant of the module docstring."""
    e = r.engine
    assert not r.error, r.error
    assert r.stopped or (e.is_done() and e.status == "ok"), e.messages
    assert len(r.t) > 5
    assert max(r.mass_balance) <= 1e-8
    assert sign_flips(r) == 0
    assert wall_failures_off_axis(r, wall_sector) == 0
    free = [dt for dt, s in zip(r.dt, r.scheduled) if not s]
    assert min(free) >= dt_floor * (1 - 1e-9), min(free)
    if check_slope:
        # 2 %: the demo's criterion; the hole's enlargement is 0.3 % of C_total and the
        # finite domain changes it by O((a/R)^2) of that
        err = intact_pressurisation_slope_error(r)
        assert math.isfinite(err) and abs(err) <= 0.02, err
