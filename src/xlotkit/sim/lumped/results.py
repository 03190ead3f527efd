"""What a lumped run reports: the events it met (:class:`RunLog`) and the clean record."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from xlotkit.record import Event, PressureReference, Record
from xlotkit.sim.scene.lumped import LumpedScene

__all__ = ["RunLog", "make_record"]


@dataclass
class RunLog:
    """The events of a lumped run so far, which its truth reports.

    Attributes
    ----------
    phases_out : list of dict
        Per finished phase: cycle, kind, name, t_start, t_end, end reason.
    events : list of Event
        Phase starts, for the record.
    closure_times, reopening_times, reopening_ps : list of float
        Closures and reopenings [s] and the well pressure at each reopening [Pa].
    last_pump_p, isip : dict of int to float
        Per cycle: the well pressure at shut-in and the ISIP (the fracture pressure then).
    breakdown_time, initiation_time, initiation_p, fbp : float or None
        The first unstable jump (FBP and its time) and the Hubbert-Willis initiation.
    status : {"ok", "stopped"}
    messages : list of str
        Why the run stopped.
    """

    phases_out: list[dict[str, Any]] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    closure_times: list[float] = field(default_factory=list)
    reopening_times: list[float] = field(default_factory=list)
    reopening_ps: list[float] = field(default_factory=list)
    last_pump_p: dict[int, float] = field(default_factory=dict)
    isip: dict[int, float] = field(default_factory=dict)
    breakdown_time: float | None = None
    initiation_time: float | None = None
    initiation_p: float | None = None
    fbp: float | None = None
    status: Literal["ok", "stopped"] = "ok"
    messages: list[str] = field(default_factory=list)


def make_record(sc: LumpedScene, well_compliance: float, tvd: float,
                hist: dict[str, np.ndarray], events: list[Event]) -> Record:
    """The clean record on the log grid from the internal history ``hist`` (latest state
    at or before each sample, interpolated between states; noise and resolution of the
    scene on the pressures)."""
    t_int = hist["t"]
    t_end = float(t_int[-1])
    n = int(math.floor(t_end / sc.dt + 1e-9)) + 1
    t = np.arange(n) * sc.dt
    # Latest internal state at or before each sample time (post-jump at a shared time).
    idx = np.searchsorted(t_int, t + 1e-9, side="right") - 1
    idx = np.clip(idx, 0, t_int.size - 1)
    exact = np.abs(t_int[idx] - t) <= 1e-9

    def at(name: str) -> np.ndarray:
        v = hist[name]
        out = np.interp(t, t_int, v)
        out[exact] = v[idx[exact]]
        return out

    p = at("p")
    ps = at("ps")
    rate = hist["q_in"][idx].copy()
    if rate.size and hist["q_in"].size > 1:
        rate[0] = hist["q_in"][1]
    ret = hist["q_ret"][idx]
    rng = np.random.default_rng(sc.seed)
    if sc.noise > 0.0:
        p = p + rng.normal(0.0, sc.noise, size=p.size)
        ps = ps + rng.normal(0.0, sc.noise, size=ps.size)
    if sc.resolution > 0.0:
        p = np.round(p / sc.resolution) * sc.resolution
        ps = np.round(ps / sc.resolution) * sc.resolution
    comp = sc.completion_used
    meta = {
        "source": "xlotkit.sim.lumped", "simulated": True,
        "sigma_h": sc.sigma_h, "sigma_H": sc.sigma_H, "pore_pressure": sc.pore_pressure,
        "tensile_strength": sc.tensile_strength,
        "breakdown_pressure_model": sc.breakdown_pressure,
        "reopening": sc.reopening, "reopening_pressure_model": sc.reopening_pressure,
        "nwb_coefficient": sc.nwb_coefficient,
        "youngs_modulus": sc.youngs_modulus, "poisson_ratio": sc.poisson_ratio,
        "toughness": sc.toughness, "geometry": sc.geometry,
        "leakoff_coefficient": sc.leakoff_coefficient, "well_compliance": well_compliance,
        "tvd": tvd, "density": sc.density, "noise": sc.noise,
        "resolution": sc.resolution, "seed": int(sc.seed), "dt": sc.dt,
    }
    return Record(
        t=t, pressure=p,
        reference=PressureReference(kind="bottomhole", depth_m=comp.length_md, absolute=False),
        start_time=sc.start_time, rate=rate, volume=at("v_in"), return_rate=ret,
        return_volume=at("v_ret"), density=np.full(t.size, float(sc.density)),
        channels={"surface_pressure": ps, "fracture_pressure": at("pf"),
                  "fracture_length": at("L"),
                  "fracture_volume": at("vf"),
                  "leakoff_volume": at("v_carter") + at("v_wall")},
        events=tuple(events), meta=meta)


