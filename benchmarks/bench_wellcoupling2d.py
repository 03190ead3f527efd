"""Benchmark: the well couplings on the 2D segment, on one small scene (run on demand).

    PYTHONPATH=src python benchmarks/bench_wellcoupling2d.py              # run all, update docs
    PYTHONPATH=src python benchmarks/bench_wellcoupling2d.py wfc wfd      # run some, update docs
    PYTHONPATH=src python benchmarks/bench_wellcoupling2d.py --print      # tables from the saved runs

Runs the scene of :func:`bench_scene` (a 2D borehole with a band along sigma_H, pumped
through breakdown and some propagation, shut in, flowed back through a choke) with
``monolithic`` (:class:`~xlotkit.sim.coupling.engine.MDEMEngine`) and the partitioned
schemes (:class:`~xlotkit.sim.coupling.partitioned.PartitionedMDEMEngine`): WFD at the
thesis's tolerance and at a tight one, WFC, WFDmod. Each run is summarised into
``benchmarks/results/wellcoupling2d.json`` (so that runs can be made one at a time on a
shared machine) and the tables are written into docs/coupling.md between the ``BENCH2D``
markers. One run at a time; the whole set takes ~30 min on the shared 2-core machine.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "coupling.md"
STORE = ROOT / "benchmarks" / "results" / "wellcoupling2d.json"
START, END = "<!-- BENCH2D:START -->", "<!-- BENCH2D:END -->"

#: name -> (coupling, [well_coupling] table, [numerics] changes)
RUNS = {
    "monolithic": ("monolithic", {}, {}),
    "monolithic-dt10ms": ("monolithic", {}, {"dt_max": 0.01}),
    "wfd": ("wfd", {}, {}),
    "wfd-1e-5": ("wfd", {"tolerance": 1e-5, "rate_tolerance": 1e-5, "max_iterations": 20},
                 {}),
    "wfc": ("wfc", {}, {}),
    "wfdmod": ("wfdmod", {}, {}),
}
#: runs whose every accepted step is compared with the monolithic step from its start
STEP_CHECK = ("wfd-1e-5",)



def bench_scene(coupling: str = "monolithic", well_coupling: dict | None = None,
                numerics: dict | None = None):
    """The benchmark scene (SI, gauge).

    4 m square, hole radius 0.15 m with 10 wall segments, a 0.5 m band of 0.25 m
    triangles along sigma_H (x) to 1.8 m (306 triangles); E = 10 GPa, nu = 0.25,
    T0 = 3 MPa with crack-tip strength scaling, k = 1e-18 m^2, sigma_H / sigma_h / p0 =
    40 / 30 / 20 MPa; 1.2 sg fluid, c_f = 1/2.34 GPa; a whole-well compliance of 2 l/MPa,
    6.6 times the borehole's own c_f pi r^2 h = 0.30 l/MPa (a short well: with the 67
    l/MPa of a 2000 m well the crack would run out of this small domain); start at 37 MPa.
    Pump 300 l/min for 11 l (breakdown at 41.2 MPa after 1.8 s, the crack runs to ~1.3 m
    while pumping and in the first second of the shut-in), shut in 5 s, flow back through
    a choke opened at 100 l/min until the BHP is 28 MPa (the crack closes on the way).
    """
    from xlotkit.sim.scene import scene_from_dict

    d = {
        "title": "2D well coupling benchmark", "model": "mdem", "coupling": coupling,
        "geometry": {"domain_size": "4 m"},
        "mesh": {"growth": 1.3, "wall_element_size": 2 * math.pi * 0.15 / 10,
                 "fracture_band": True, "band_width": "0.5 m",
                 "band_element_size": "0.25 m", "band_length": "1.8 m"},
        "rock": {"youngs_modulus": "10 GPa", "tensile_strength": "3 MPa",
                 "permeability": 1e-18},
        "stresses": {"sigma_H": "40 MPa", "sigma_h": "30 MPa", "pore_pressure": "20 MPa"},
        "effects": {"strength_scaling": True},
        "fluid": {"density": "1.2 sg"},
        "completion": {"well_compliance": 2e-9, "initial_pressure": "37 MPa"},
        "numerics": {"dt_max": "1 s", "dp_max": "0.5 MPa", "dt_min": 1e-4},
        "schedule": {"phase": [
            {"kind": "pump", "rate": "300 l/min", "volume": "0.011 m3"},
            {"kind": "shut_in", "duration": "5 s"},
            {"kind": "flowback", "initial_rate": "100 l/min", "pressure_below": "28 MPa"},
        ]},
    }
    if well_coupling:
        d["well_coupling"] = well_coupling
    if numerics:
        d["numerics"] = {**d["numerics"], **numerics}
    return scene_from_dict(d)


def run_one(name: str) -> dict:
    """Run one configuration and summarise it (plain JSON types)."""
    from xlotkit.sim.run import make_engine

    from xlotkit.sim.coupling.schemes import WellLoad

    coupling, wc, num = RUNS[name]
    sc = bench_scene(coupling, wc, num)
    e = make_engine(sc)
    t0 = time.perf_counter()
    e.start()
    check: list = []
    t_check = [0.0]
    if name in STEP_CHECK:
        # every accepted step against the monolithic step of the same length from the same
        # segment state (the well then starts at p_s), with this step's pump rate or
        # returns: the coupling's own error, free of the step sequence (not in the wall)
        stp = e.stepper
        take = stp.step
        h = stp.segment.height

        def record(dt, **kw):
            old = stp.state
            r = take(dt, **kw)
            if r.success:
                c0 = time.perf_counter()
                new = stp.state
                q = (r.injected_mass / (stp.segment.rho0 * dt * h)
                     if stp.phase_kind() == "pump" else 0.0)
                m = stp.segment.step(old.segment, dt, inflow=q, continuation=True,
                                     well=WellLoad(storage=stp.well.c_w,
                                                   outflow=stp.well.outflow()))
                check.append([old.t, dt, abs(new.well_pressure - m.pressure),
                              abs(old.well_pressure - old.segment_pressure),
                              abs(new.well_pressure - new.segment_pressure),
                              int(r.new_failures), int(new.n_failed),
                              int(m.state.coupled.n_failed),
                              bool(np.array_equal(m.state.coupled.cluster_state,
                                                  new.cluster_state)),
                              stp.phase_kind(),
                              bool(np.array_equal(
                                  m.state.coupled.mechanics.contact_status,
                                  new.mechanics.contact_status))])
                t_check[0] += time.perf_counter() - c0
            return r

        stp.step = record
    trials = 0
    last = time.perf_counter()
    while not e.is_done():
        e.step()
        trials += 1
        if time.perf_counter() - last > 30.0:
            print(f"  {name}: t = {e.time:.5f} s, {trials} trials, "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
            last = time.perf_counter()
    wall = time.perf_counter() - t0 - t_check[0]
    res = e.result()
    rows = e.rows()
    c = e.stepper.counters
    out = {
        "name": name, "coupling": coupling, "options": wc, "status": res.status,
        "message": res.message, "wall": wall, "trials": trials,
        "steps": c.steps, "rejected": c.failed_steps,
        "newton_iterations": c.newton_iterations, "linear_solves": c.linear_solves,
        "linear_solve_time": c.linear_solve_time,
        "n_triangles": int(e.cm.mesh.n_triangles),
        "phases": e.phases_out,
        "rows": {k: np.asarray(v, dtype=float).tolist() for k, v in rows.items()},
        "c_w": None, "coupling_counters": None, "calls_per_step": None,
        "step_check": check,
        # why trials were rejected (the partitioned runs name the failing segment call)
        "rejections": _reasons(e.stepper.history),
    }
    if coupling != "monolithic":
        stp = e.stepper
        out["c_w"] = stp.well.c_w * stp.segment.height
        out["coupling_counters"] = dict(vars(stp.coupling))
        out["calls_per_step"] = [[float(x[0]), float(x[1]), int(x[2]), bool(x[3])]
                                 for x in stp.call_log]
        # whole-run balance of the well side [m^3]: pumped - returned - stored - sent
        st, h = stp.state, stp.segment.height
        well = stp.well.store(stp.well.c_w, st.well_pressure, e.pw0) * h
        out["well_balance"] = float(rows["pumped_volume"][-1] - rows["returned_volume"][-1]
                                    - well - st.segment.injected * h)
    return out


def _reasons(history) -> dict:
    out: dict = {}
    for r in history:
        if not r.success:
            why = r.reason.split(": ", 1)[-1] if " segment call " in r.reason else r.reason
            out[why] = out.get(why, 0) + 1
    return out


# ------------------------------------------------------------------------------ tables
def _phase_sel(r: dict, pumping: bool) -> np.ndarray:
    t = np.asarray(r["rows"]["t"])
    sel = np.zeros(t.size, bool)
    for ph in r["phases"]:
        if (ph["kind"] == "pump") == pumping:
            sel |= (t > ph["t_start"]) & (t <= ph["t_end"])
    return sel


def _events(r: dict) -> dict:
    rw = {k: np.asarray(v) for k, v in r["rows"].items()}
    p, t = rw["bottomhole_pressure"], rw["t"]
    k = int(np.argmax(p))
    pump_end = next(ph["t_end"] for ph in r["phases"] if ph["kind"] == "pump")
    shut_end = next(ph["t_end"] for ph in r["phases"] if ph["kind"] == "shut_in")
    i_pe = int(np.searchsorted(t, pump_end - 1e-9))
    i_se = int(np.searchsorted(t, shut_end - 1e-9))
    return {"fbp": p[k], "t_fbp": t[k], "p_pump_end": p[i_pe], "p_shut_end": p[i_se],
            "t_end": t[-1], "L_end": rw["fracture_length"][-1],
            "V_end": rw["fracture_volume"][-1], "n_failed": rw["failed_clusters"][-1],
            "t_first": float(t[int(np.argmax(rw["failed_clusters"] > 0))]),
            "t_last": float(t[int(np.argmax(rw["failed_clusters"]
                                            == rw["failed_clusters"][-1]))])}


def tables(runs: dict) -> str:
    out = []
    m = runs.get("monolithic")
    any_r = next(iter(runs.values()))
    sc = bench_scene()
    ph = sc.schedule.phases
    g = sc.geometry
    own = sc.fluid.compressibility * math.pi * g.hole_radius**2 * g.segment_height
    out.append(f"Scene: `benchmarks/bench_wellcoupling2d.py::bench_scene` "
               f"({any_r['n_triangles']} triangles, h = {g.segment_height:g} m; "
               f"{ph[0].rate * 60000:.0f} l/min from "
               f"{sc.completion.initial_pressure / 1e6:g} MPa for {ph[0].volume * 1e3:g} l "
               f"through breakdown, shut-in {ph[1].max_duration:g} s, choke flowback to "
               f"{ph[2].pressure_below / 1e6:g} MPa; whole-well compliance "
               f"{sc.completion.well_compliance * 1e9:g} l/MPa, the borehole's own "
               f"{own * 1e9:.2f} l/MPa). One run each on the shared 2-core machine (other "
               "jobs running: wall times are indicative, the counts are not).\n")
    out.append("| run | status | steps (rejected) | segment calls (failed) | calls per step "
               "| Newton iterations | linear solves | mismatch max [MPa] | mismatch RMS "
               "[MPa] | RMS pumping / after [MPa] | volume error C_w·max\\|Δp\\| [l] "
               "| max step mass-balance error | well-side balance [m³] | wall [s] |")
    out.append("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, r in runs.items():
        rw = {k: np.asarray(v) for k, v in r["rows"].items()}
        mb = float(np.nanmax(rw["mass_balance_error"][1:]))
        if r["coupling"] == "monolithic":
            out.append(f"| `{name}` | {r['status']} | {r['steps']} ({r['rejected']}) | "
                       f"{r['steps'] + r['rejected']} (–) | 1 | {r['newton_iterations']} | "
                       f"{r['linear_solves']} | 0 | 0 | 0 / 0 | 0 | {mb:.1e} | – | "
                       f"{r['wall']:.0f} |")
            continue
        cc = r["coupling_counters"]
        mis = rw["well_pressure"] - rw["segment_pressure"]
        pump, after = _phase_sel(r, True), _phase_sel(r, False)
        rms = (lambda s: float(np.sqrt(np.mean(mis[s] ** 2))) if s.any() else 0.0)
        out.append(
            f"| `{name}` | {r['status']} | {r['steps']} ({r['rejected']}) | "
            f"{cc['segment_calls']} ({cc['failed_segment_calls']}) | "
            f"{cc['segment_calls'] / max(cc['steps'] + cc['rejected_steps'], 1):.2f} | "
            f"{r['newton_iterations']} | {r['linear_solves'] + cc['tangent_solves']} | "
            f"{np.max(np.abs(mis)) / 1e6:.3g} | {np.sqrt(np.mean(mis ** 2)) / 1e6:.3g} | "
            f"{rms(pump) / 1e6:.3g} / {rms(after) / 1e6:.3g} | "
            f"{r['c_w'] * np.max(np.abs(mis)) * 1e3:.3g} | {mb:.1e} | "
            f"{r['well_balance']:.1e} | {r['wall']:.0f} |")
    if m is not None:
        em = _events(m)
        out.append("\n**Against the monolithic run** (well BHP; the crack run after "
                   "breakdown is step-size dependent even for one scheme, see the text):\n")
        out.append("| run | FBP [MPa] | t_FBP [s] | first failure [s] | BHP end of pumping "
                   "[MPa] | BHP end of shut-in [MPa] | end of flowback [s] | failed "
                   "clusters | crack length [m] | crack volume [l] | max \\|Δp_w\\| before "
                   "the first failure [kPa] | max \\|Δp_w\\| once both cracks stopped "
                   "[MPa] |")
        out.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        rm = {k: np.asarray(v) for k, v in m["rows"].items()}
        for name, r in runs.items():
            ev = _events(r)
            rw = {k: np.asarray(v) for k, v in r["rows"].items()}
            tf = min(ev["t_first"], em["t_first"])
            sel = rw["t"] < tf
            pre = np.max(np.abs(rw["bottomhole_pressure"][sel] - np.interp(
                rw["t"][sel], rm["t"], rm["bottomhole_pressure"])))
            # after the last failure of either run, up to the earlier end
            t0 = max(ev["t_last"], em["t_last"])
            t1 = min(ev["t_end"], em["t_end"])
            tt = np.linspace(t0, t1, 2001)
            late = np.max(np.abs(np.interp(tt, rw["t"], rw["bottomhole_pressure"])
                                 - np.interp(tt, rm["t"], rm["bottomhole_pressure"])))
            out.append(
                f"| `{name}` | {ev['fbp'] / 1e6:.4f} | {ev['t_fbp']:.4f} | "
                f"{ev['t_first']:.4f} | {ev['p_pump_end'] / 1e6:.3f} | "
                f"{ev['p_shut_end'] / 1e6:.3f} | {ev['t_end']:.2f} | {ev['n_failed']:.0f} | "
                f"{ev['L_end']:.3f} | {ev['V_end'] * 1e3:.3f} | {pre / 1e3:.3g} | "
                f"{late / 1e6:.3g} (from {t0:.2f} s) |")
    # calls per step of the partitioned runs around breakdown
    lines = []
    for name, r in runs.items():
        if not r["calls_per_step"]:
            continue
        cps = np.array([x[2] for x in r["calls_per_step"] if x[3]])
        t = np.array([x[0] for x in r["calls_per_step"] if x[3]])
        ev = _events(r)
        win = (t >= ev["t_first"] - 1e-9) & (t <= ev["t_first"] + 0.2)
        lines.append(f"| `{name}` | {cps.mean():.2f} | {int(cps.max())} | "
                     f"{cps[win].mean() if win.any() else float('nan'):.2f} | "
                     f"{int(win.sum())} |")
    if lines:
        out.append("\n**Segment calls per accepted step** (all steps; in the 0.2 s after "
                   "the first failure):\n")
        out.append("| run | mean | max | mean after the first failure | steps in that "
                   "window |")
        out.append("|---|---:|---:|---:|---:|")
        out.extend(lines)
    rej = {name: r.get("rejections") for name, r in runs.items() if r.get("rejections")}
    if rej:
        reasons = sorted({k for v in rej.values() for k in v})
        out.append("\n**Rejected step trials by reason** (of the coupled stepper; for the "
                   "partitioned runs the reason of the segment call that failed):\n")
        out.append("| run | " + " | ".join(reasons) + " |")
        out.append("|---|" + "---:|" * len(reasons))
        for name, v in rej.items():
            out.append(f"| `{name}` | " + " | ".join(str(v.get(k, 0)) for k in reasons)
                       + " |")
    for name, r in runs.items():
        chk = r.get("step_check") or []
        if not chk:
            continue
        # a WFD step solves the monolithic equations but for the well's start at p_w
        # (not p_s) and its end mismatch e: |p_w' - p_mono| <= |p_w - p_s| + |e|
        same = [c for c in chk if c[5] == 0 and c[8]]
        quiet = [c for c in same if c[10]]
        contact = [c for c in same if not c[10]]
        fail = [c for c in chk if not (c[5] == 0 and c[8])]
        excess = max((c[2] - c[3] - c[4] for c in quiet), default=float("nan"))
        out.append(f"\n**`{name}` step by step against the monolithic step** (each "
                   "accepted WFD step against the monolithic step of the same length, pump "
                   "rate or choke from the same segment state):\n")
        out.append("| steps | | max \\|p_w,WFD − p_mono\\| [kPa] | largest excess over "
                   "the start and end mismatch [Pa] | failed counts differ | median "
                   "\\|Δp\\| [kPa] |")
        out.append("|---|---:|---:|---:|---:|---:|")
        for label, grp in (("no cluster fails, same contact statuses", quiet),
                           ("no cluster fails, contact statuses differ", contact),
                           ("clusters fail", fail)):
            if not grp:
                continue
            d = np.array([c[2] for c in grp])
            ndiff = sum(1 for c in grp if c[6] != c[7])
            ex = f"{excess:.3g}" if grp is quiet else "–"
            out.append(f"| {label} | {len(grp)} | {d.max() / 1e3:.3g} | {ex} | {ndiff} | "
                       f"{np.median(d) / 1e3:.3g} |")
    return "\n".join(out)


def main() -> None:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    store = json.loads(STORE.read_text()) if STORE.exists() else {}
    if "--print" not in sys.argv:
        for name in (args or list(RUNS)):
            if name not in RUNS:
                raise SystemExit(f"unknown run {name!r}; one of {', '.join(RUNS)}")
            print(f"running {name} ...", flush=True)
            store[name] = run_one(name)
            print(f"  {store[name]['message']} ({store[name]['wall']:.0f} s)", flush=True)
            STORE.parent.mkdir(parents=True, exist_ok=True)
            STORE.write_text(json.dumps(store))
    runs = {k: store[k] for k in RUNS if k in store}
    text = tables(runs)
    print(text)
    if "--print" in sys.argv or not runs:
        return
    doc = DOC.read_text()
    if START in doc:
        a, b = doc.index(START) + len(START), doc.index(END)
        DOC.write_text(doc[:a] + "\n" + text + "\n" + doc[b:])
        print(f"\nwritten to {DOC}")


if __name__ == "__main__":
    main()
