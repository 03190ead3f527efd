"""What a finished 2D run reports: the clean record on the log grid and the realised truth."""

from __future__ import annotations

import math

import numpy as np

from xlotkit.record import Event, PressureReference, Record
from xlotkit.sim.coupling.geometry import fracture_summary
from xlotkit.sim.coupling.model import CoupledModel, CoupledState
from xlotkit.sim.mechanics import FAILED_SHEAR, FAILED_TENSILE
from xlotkit.sim.mechanics.breakdown import crack_geometry
from xlotkit.sim.scene import Scene
from xlotkit.sim.well import Column

__all__ = ["make_record", "realised_truth"]


def realised_truth(cm: CoupledModel, st: CoupledState, stress0: np.ndarray,
               at_wall: np.ndarray) -> dict[str, float]:
    """What the model realised, where it differs from the scene's input.

    All from the in-situ state (the drilled hole at the mud column, before pumping: far
    field, Kirsch concentration as the mesh resolves it, finite domain) over the
    clusters of the hole-connected crack at the end of the run, with the crack's
    principal axis (:func:`~xlotkit.sim.coupling.geometry.fracture_summary`) as its
    plane:

    * ``sigma_h``, ``sigma_h_min``, ``sigma_h_max`` [Pa]: the total stress normal to the
      crack's plane, area-weighted mean (and range) over the crack's clusters. This is
      the stress the crack closes against; a closure pick is compared with it.
    * ``sigma_H`` [Pa]: the total stress along the crack's plane, area-weighted over the
      same clusters: the far-field stress parallel to the crack where the crack is (the
      largest horizontal stress when the crack runs along sigma_H), with the hole's
      radial-stress dip near the wall and the finite domain's disturbance. What
      Eq. C.18/C.19 estimates is compared with it.
    * ``tensile_strength`` [Pa]: the mean tensile strength of the crack's clusters at
      the wall, where it started (the nominal strength, or the heterogeneous draw; the
      crack-tip size scaling does not apply at the smooth wall). What T0 = FBP - Pr
      estimates.
    * ``wall_hoop_stress`` [Pa]: the total stress normal to the crack's plane in the
      crack's wall clusters (mean), at the mud column ``initial_pressure``; the ideal
      (Kirsch) wall value is ``3 sigma_h - sigma_H - p_mud``. A coarse wall resolves the
      concentration only in a cluster average, which sets where the wall breaks down.
    * ``fracture_azimuth_deg``, ``fracture_half_length`` [deg, m]: the crack's axis and
      half its tip-to-tip length.
    """
    cs = st.cluster_state
    cracked = (cs == FAILED_TENSILE) | (cs == FAILED_SHEAR)
    out: dict[str, float] = {}
    if not cracked.any():
        return out
    connected, _, _ = crack_geometry(cm.mechanics, cs)
    fs = fracture_summary(cm, st)
    if connected.any() and math.isfinite(fs.azimuth_deg):
        az = math.radians(fs.azimuth_deg)
        tx, ty = math.cos(az), math.sin(az)
        nx, ny = -ty, tx
        s0 = stress0
        sn = s0[:, 0] * nx * nx + s0[:, 1] * ny * ny + 2.0 * s0[:, 2] * nx * ny
        sp = s0[:, 0] * tx * tx + s0[:, 1] * ty * ty + 2.0 * s0[:, 2] * tx * ty
        w = np.asarray(cm.mesh.areas)[connected]
        out["sigma_h"] = float(np.sum(w * sn[connected]) / np.sum(w))
        out["sigma_h_min"] = float(np.min(sn[connected]))
        out["sigma_h_max"] = float(np.max(sn[connected]))
        out["sigma_H"] = float(np.sum(w * sp[connected]) / np.sum(w))
        wall = connected & at_wall
        if wall.any():
            out["wall_hoop_stress"] = float(np.mean(sn[wall]))
        out["fracture_azimuth_deg"] = float(fs.azimuth_deg)
        out["fracture_half_length"] = 0.5 * float(fs.length)
    sel = cracked & at_wall
    if sel.any():
        out["tensile_strength"] = float(np.mean(
            np.asarray(cm.mechanics.tensile_strength)[sel]))
    return out


def make_record(sc: Scene, rows: dict[str, np.ndarray], events, column: Column) -> Record:
    """The clean record on the log grid: bottom-hole gauge pressure (latest state at or
    before each sample, interpolated between steps), rates (of the step the sample falls
    in), volumes, density, and surface/fracture pressure channels."""
    dt = sc.output.log_interval
    t_int = rows["t"]
    n = int(math.floor(float(t_int[-1]) / dt + 1e-9)) + 1
    t = np.arange(n) * dt
    # rate of the step each sample lies in (a step's rate is constant over it)
    j = np.clip(np.searchsorted(t_int, t, side="right"), 1, t_int.size - 1)

    def at(name: str) -> np.ndarray:
        return np.interp(t, t_int, rows[name])

    rate = rows["pump_rate"][j] if t_int.size > 1 else np.zeros(n)
    ret = rows["return_rate"][j] if t_int.size > 1 else np.zeros(n)
    comp = sc.completion_model()
    meta = {
        "source": "xlotkit.sim.coupling.engine", "simulated": True, "model": "mdem",
        "sigma_h": sc.stresses.sigma_h, "sigma_H": sc.stresses.sigma_H,
        "pore_pressure": sc.stresses.pore_pressure,
        "tensile_strength": sc.rock.tensile_strength,
        "youngs_modulus": sc.rock.youngs_modulus, "poisson_ratio": sc.rock.poisson_ratio,
        "tvd": column.tvd, "density": sc.fluid.density, "dt": dt,
    }
    return Record(
        t=t, pressure=at("bottomhole_pressure"),
        reference=PressureReference(kind="bottomhole", depth_m=comp.length_md, absolute=False),
        start_time=sc.output.start_time, rate=rate, volume=at("pumped_volume"),
        return_rate=ret, return_volume=at("returned_volume"),
        density=np.full(n, float(sc.fluid.density)),
        channels={"surface_pressure": at("surface_pressure"),
                  "fracture_pressure": at("fracture_pressure"),
                  "fracture_length": at("fracture_length"),
                  "fracture_volume": at("fracture_volume"),
                  "leakoff_volume": at("leakoff_volume")},
        events=tuple(Event(t=float(te), text=str(x)) for te, x in events), meta=meta)
