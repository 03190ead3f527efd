"""Benchmark: the lumped XLOT model and the whole demo job (run on demand, not a test).

    .venv/bin/python benchmarks/bench_lumped.py

Prints a Markdown table; the numbers in docs/benchmarks.md were made with it.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path


def best_of(n: int, fn) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    from xlotkit.pipeline import interpret_record, run_demo
    from xlotkit.sim.lumped import simulate_lumped, standard_lumped_scene

    scene = standard_lumped_scene(noise=5e3, resolution=1e3)
    simulate_lumped(scene)  # warm-up: imports
    t_sim = best_of(5, lambda: simulate_lumped(scene))
    rec = simulate_lumped(scene).record
    t_pick = best_of(3, lambda: interpret_record(rec))
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run_demo(Path(tmp) / "demo", model="lumped")
        t_demo = time.perf_counter() - t0
    print("| step | seconds |")
    print("|---|---:|")
    print(f"| simulate standard two-cycle lumped XLOT ({rec.n} samples), best of 5 | {t_sim:.3f} |")
    print(f"| segment + all picks + stress on it, best of 3 | {t_pick:.3f} |")
    print(f"| whole demo (simulate, write log, read, pick, report, 15 plots) | {t_demo:.2f} |")


if __name__ == "__main__":
    main()
