"""The same sweep through `xlotkit sweep` on the local pool and on a Dask cluster started
here with the `dask` command (a scheduler and worker processes on 127.0.0.1); the two
tables must be equal, timing columns aside (run on demand, not a test).

    .venv/bin/python benchmarks/sweep_executors.py lumped50   # 50 lumped cases, 2 workers
    .venv/bin/python benchmarks/sweep_executors.py 2d12       # 12 cases of the 2D scene

Prints the commands, their wall times and the comparison as Markdown; the numbers in
docs/studies.md were made with it. ``--keep DIR`` keeps the two study folders.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
PRESETS = {
    # Latin-hypercube draws over the stresses, the strength and the first pump rate
    "lumped50": ["examples/scene_standard.toml", "--samples", "50", "--seed", "1",
                 "--vary", "stresses.sigma_h=28 MPa:31 MPa",
                 "--vary", "stresses.sigma_H=33 MPa:40 MPa",
                 "--vary", "rock.tensile_strength=2 MPa:5 MPa",
                 "--vary", "schedule.phase[0].rate=400 l/min:600 l/min"],
    # a 3 x 2 x 2 grid of the stresses and the strength on the standard 2D scene
    "2d12": ["examples/scene_2d_standard.toml",
             "--vary", "stresses.sigma_h=29 MPa,30 MPa,31 MPa",
             "--vary", "stresses.sigma_H=38 MPa,42 MPa",
             "--vary", "rock.tensile_strength=2 MPa,4 MPa"],
}


def run(cmd: list[str]) -> float:
    print("    " + " ".join(shlex.quote(c) for c in cmd), file=sys.stderr)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=ROOT, stdout=sys.stderr)
    return time.perf_counter() - t0


def start_cluster(folder: Path, workers: int) -> tuple[list[subprocess.Popen], str]:
    """A `dask scheduler` and `dask worker` processes on the loopback address."""
    sched_file = folder / "scheduler.json"
    procs = [subprocess.Popen([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file",
                               str(sched_file)], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    deadline = time.monotonic() + 60
    while not sched_file.exists():
        if time.monotonic() > deadline:
            raise RuntimeError("the scheduler did not start")
        time.sleep(0.1)
    address = json.loads(sched_file.read_text())["address"]
    procs.append(subprocess.Popen([str(BIN / "dask"), "worker", address, "--nworkers",
                                   str(workers), "--nthreads", "1", "--no-dashboard"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    from distributed import Client

    with Client(address, timeout=60) as c:
        c.wait_for_workers(workers, timeout=120)
    return procs, address


def main() -> None:
    import pandas as pd

    from xlotkit.study.table import same_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("preset", choices=sorted(PRESETS))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--keep", default=None)
    a = ap.parse_args()
    args = PRESETS[a.preset]
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(a.keep) if a.keep else Path(tmp)
        base.mkdir(parents=True, exist_ok=True)
        xl = str(BIN / "xlotkit")
        load0 = os.getloadavg()
        t_local = run([xl, "sweep", *args, "--workers", str(a.workers),
                       "--out", str(base / "local")])
        load1 = os.getloadavg()
        procs, address = start_cluster(base, a.workers)
        try:
            t_dask = run([xl, "sweep", *args, "--scheduler", address,
                          "--out", str(base / "dask")])
        finally:
            for p in reversed(procs):
                p.terminate()
                p.wait(timeout=60)
        load2 = os.getloadavg()
        local = pd.read_parquet(base / "local" / "results.parquet")
        dask = pd.read_parquet(base / "dask" / "results.parquet")
        same, why = same_table(local, dask)
        raw_same, _ = same_table(local, dask, ignore=())
    print(f"sweep `{a.preset}`: xlotkit sweep {' '.join(shlex.quote(x) for x in args)}")
    print(f"| executor | wall [s] | cases | ok | cases/s | load (1 min) before / after |")
    print("|---|---:|---:|---:|---:|---|")
    for name, t, tab, l0, l1 in (
            (f"local pool, --workers {a.workers}", t_local, local, load0, load1),
            (f"Dask, scheduler + {a.workers} worker processes", t_dask, dask, load1, load2)):
        print(f"| {name} | {t:.1f} | {len(tab)} | {int((tab['status'] == 'ok').sum())} | "
              f"{len(tab) / t:.3f} | {l0[0]:.2f} / {l1[0]:.2f} |")
    print(f"\nidentical tables (timing columns aside): {same} ({why}); "
          f"including timing columns: {raw_same}")


if __name__ == "__main__":
    main()
