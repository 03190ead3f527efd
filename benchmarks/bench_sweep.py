"""Benchmark: sweep throughput (cases/s) against the number of local workers, and the same
sweep on a Dask cluster (run on demand, not a test).

    .venv/bin/python benchmarks/bench_sweep.py                       # lumped, 24 cases, 1 2 4
    .venv/bin/python benchmarks/bench_sweep.py --cases 50 --workers 2 --dask
    .venv/bin/python benchmarks/bench_sweep.py --scene examples/scene_2d_standard.toml \\
        --cases 4 --workers 1 2

Every run is a fresh sweep (new folder) of ``--cases`` Latin-hypercube draws (seed 0) over
sigma_h 28-31 MPa, sigma_H 33-40 MPa, T0 2-5 MPa and the first pump rate 400-600 l/min,
through :func:`xlotkit.study.sweep.run_sweep`; the wall time includes starting the pool's
processes (spawn, imports) and writing the table; with ``--repeat R`` the fastest of R
runs is kept. ``--dask`` also runs it on a
:class:`distributed.LocalCluster` of as many single-threaded worker processes. Every
table is checked to equal the first one, timing columns aside. The load average before
and after is printed: the machine is shared, say what else was running.

Prints a Markdown table; the numbers in docs/benchmarks.md were made with it.
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARY = ("stresses.sigma_h=28 MPa:31 MPa", "stresses.sigma_H=33 MPa:40 MPa",
        "rock.tensile_strength=2 MPa:5 MPa", "schedule.phase[{pump}].rate=400 l/min:600 l/min")


def _first_pump(scene_file: Path) -> int:
    import tomllib

    phases = tomllib.loads(scene_file.read_text())["schedule"]["phase"]
    return next(i for i, p in enumerate(phases) if p.get("kind") == "pump")


def main() -> None:
    from xlotkit.study.executors import DaskCluster, LocalPool
    from xlotkit.study.sweep import SweepSpec, run_sweep
    from xlotkit.study.table import same_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(ROOT / "examples" / "scene_standard.toml"))
    ap.add_argument("--cases", type=int, default=24)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--dask", action="store_true", help="also on a Dask LocalCluster")
    ap.add_argument("--repeat", type=int, default=1,
                    help="run each executor and worker count this many times (fresh folders) "
                         "and keep the fastest, against the noise of a shared machine")
    ap.add_argument("--keep", default=None, help="keep the study folders under this folder")
    a = ap.parse_args()
    scene = Path(a.scene)
    vary = [v.format(pump=_first_pump(scene)) for v in VARY]
    spec = SweepSpec.from_options(scene, vary, samples=a.cases, seed=0)
    runs = []
    ref = None
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(a.keep) if a.keep else Path(tmp)
        for w in a.workers:
            for kind in ("local", "dask") if a.dask else ("local",):
                load0 = os.getloadavg()[0]
                best = None
                for r in range(a.repeat):
                    out = base / f"{kind}-{w}-{r}"
                    t0 = time.perf_counter()
                    if kind == "local":
                        res = run_sweep(spec, out, executor=LocalPool(w))
                    else:
                        from distributed import Client, LocalCluster

                        with LocalCluster(n_workers=w, threads_per_worker=1, processes=True,
                                          dashboard_address=None) as cl, Client(cl) as c:
                            res = run_sweep(spec, out, executor=DaskCluster(client=c))
                    wall = time.perf_counter() - t0
                    if best is None or wall < best[0]:
                        best = (wall, res)
                wall, res = best
                if ref is None:
                    ref, same = res.table, "reference"
                else:
                    ok, why = same_table(ref, res.table)
                    same = "yes" if ok else f"NO: {why}"
                case_wall = float(res.table["wall_time_s"].sum())
                # largest resident size of any worker process that has ended so far [MB]
                rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
                runs.append((kind, w, wall, a.cases / wall, case_wall, res.count("ok"),
                             load0, os.getloadavg()[0], rss, same))
    print(f"scene {scene.name}, {a.cases} cases, {os.cpu_count()} CPUs, fastest of "
          f"{a.repeat} run(s) each")
    print("| executor | workers | wall [s] | cases/s | sum of case wall times [s] | ok | "
          "load before / after | peak worker RSS so far [MB] | same table |")
    print("|---|---:|---:|---:|---:|---:|---|---:|---|")
    for kind, w, wall, thr, cw, ok, l0, l1, rss, same in runs:
        print(f"| {kind} | {w} | {wall:.1f} | {thr:.3f} | {cw:.1f} | {ok} | "
              f"{l0:.2f} / {l1:.2f} | {rss:.0f} | {same} |")


if __name__ == "__main__":
    main()
