"""Benchmark: `xlotkit demo` on the 2D model (run on demand, not a test).

    PYTHONPATH=src .venv/bin/python benchmarks/bench_demo.py

Times the standard 2D scene (xlotkit.sim.scene.standard_2d_scene,
examples/scene_2d_standard.toml) three ways: the simulation alone (xlotkit.sim.run.simulate:
engine, outputs, synthetic log), the interpretation of its log (read, segment, all picks,
stress, report with plots) and the whole demo job (xlotkit.pipeline.run_demo: both plus
the report). Prints a Markdown table with the solver's work counters and the demo's checks
(closure picks against the realised sigma_h, pressurisation slope against Q / C_total);
the numbers in docs/benchmarks.md were made with it. The machine's load average is printed
too: the development machine is shared, and a second job on its two cores slows a run.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path


def main() -> None:
    from xlotkit.interpret.io import read_log
    from xlotkit.pipeline import interpret_record, run_demo, write_interpretation
    from xlotkit.sim.run import simulate
    from xlotkit.sim.scene import standard_2d_scene

    scene = standard_2d_scene()
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        sim = simulate(scene, Path(tmp) / "sim")
        t_sim = time.perf_counter() - t0
        t0 = time.perf_counter()
        interp = interpret_record(read_log(sim.paths["log"]))
        write_interpretation(interp, Path(tmp) / "interp")
        t_pick = time.perf_counter() - t0
        t0 = time.perf_counter()
        res = run_demo(Path(tmp) / "demo")
        t_demo = time.perf_counter() - t0
        summary = json.loads(res.paths["summary_json"].read_text())
    tr = sim.truth
    load1 = os.getloadavg()[0]
    print(f"load average (1 min) before / after: {load0:.2f} / {load1:.2f}")
    print()
    print("| step | seconds |")
    print("|---|---:|")
    print(f"| simulate the standard 2D XLOT ({tr['n_triangles']} triangles, {tr['steps']} "
          f"steps, {tr['cut_steps']} cut, {tr['newton_iterations']} Newton iterations; "
          f"sparse LU {tr['linear_solve_time']:.1f} s) | {t_sim:.1f} |")
    print(f"| read its log, segment, all picks, stress, report with plots | {t_pick:.1f} |")
    print(f"| whole demo (`run_demo`: simulate, read, pick, report, plots) | {t_demo:.1f} |")
    print()
    truth = summary["truth_bar"]
    print(f"realised sigma_h {truth['sigma_h_realised']:.2f} bar (imposed "
          f"{truth['sigma_h']:.2f}); FBP {truth['fbp']:.2f} bar")
    for cyc, row in summary["fcp_error_percent"].items():
        print(f"{cyc}: flowback_sqrt_p {row['flowback_sqrt_p']} %, flowback_p_v "
              f"{row['flowback_p_v']} %, consensus {row['consensus']} %")
    pz = summary["pressurisation"]
    print(f"pressurisation {pz['slope_bar_per_s']:.4f} bar/s vs Q/C_total "
          f"{pz['q_over_c_total_bar_per_s']:.4f} bar/s: {pz['error_percent']:+.2f} %")


if __name__ == "__main__":
    main()
