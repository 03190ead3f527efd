"""Benchmark of the field-log reader (issue 15): wall time against bare pandas, peak memory.

Usage::

    .venv/bin/python benchmarks/bench_reader.py [--rows 1000000] [--big-rows 10000000]
                                                 [--repeat 3] [--dir DIR]

Writes a CSV of ``--rows`` rows (``time (s),Pressure (bar),Rate (l/min),Volume (m3)``, a
pump/shut-in sequence at 1 s) and measures, each the best of ``--repeat`` runs in a fresh
process:

* ``python -c "import pandas; pandas.read_csv(F)"`` (the reference);
* ``xlotkit inspect --json F`` (read, segment, print);
* ``python -c "from xlotkit.interpret.io import read_log; read_log(F)"`` (the reader alone).

Then writes ``--big-rows`` rows and reports the peak resident memory (``ru_maxrss`` of the
child) of ``read_log`` on it. Targets (docs/benchmarks.md, "Reader"): ``inspect --json``
within 2.5x the bare pandas time at 10^6 rows; 10^7 rows read in under 2 GB.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def _cycles(t: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Pressure [bar] and rate [l/min] of four test cycles spread over an n-second record:
    pump 20 min at 500 l/min (rise to ~170 bar), shut in 40 min, bleed off; idle between."""
    p = np.full(t.size, 20.0)
    q = np.zeros(t.size)
    for frac in (0.15, 0.35, 0.6, 0.85):
        t0 = frac * n
        pump = (t >= t0) & (t < t0 + 1200)
        shut = (t >= t0 + 1200) & (t < t0 + 3600)
        bleed = (t >= t0 + 3600) & (t < t0 + 3900)
        q[pump] = 500.0
        p[pump] = 20 + 150 * (t[pump] - t0) / 1200
        p[shut] = 20 + 150 * np.exp(-(t[shut] - t0 - 1200) / 1500)
        p[bleed] = 20 + (p[shut][-1] - 20 if shut.any() else 60) * (1 - (t[bleed] - t0 - 3600) / 300)
    return p, q


def write_csv(path: Path, n: int, chunk: int = 1_000_000) -> None:
    """A memory-gauge-like record at 1 s with four test cycles, deterministic (seed 0)."""
    rng = np.random.default_rng(0)
    with open(path, "w") as fh:
        fh.write("time (s),Pressure (bar),Rate (l/min),Volume (m3)\n")
        vol = 0.0
        for a in range(0, n, chunk):
            t = np.arange(a, min(n, a + chunk), dtype=float)
            p, q = _cycles(t, n)
            p = p + rng.normal(0, 0.1, t.size)
            v = vol + np.cumsum(q / 60.0) / 1000.0
            vol = float(v[-1])
            np.savetxt(fh, np.c_[t, p, q, v], fmt=["%.0f", "%.3f", "%.1f", "%.4f"],
                       delimiter=",")


def run(cmd: list[str]) -> tuple[float, float]:
    """Wall time [s] and peak RSS of the child [MB] of one fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
    wall = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return wall, max(peak, before) / 1024.0


def peak_mb(cmd: list[str]) -> float:
    """Peak RSS of one child, measured in a wrapper so earlier children do not count."""
    code = ("import resource, subprocess, sys; subprocess.run(sys.argv[1:], check=True, "
            "stdout=subprocess.DEVNULL); "
            "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    out = subprocess.run([sys.executable, "-c", code, *cmd], check=True, capture_output=True,
                         text=True, cwd=ROOT)
    return int(out.stdout.strip()) / 1024.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--big-rows", type=int, default=10_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dir", type=Path, default=None)
    args = ap.parse_args()
    d = args.dir or Path(tempfile.mkdtemp(prefix="xlotkit-bench-reader-"))
    d.mkdir(parents=True, exist_ok=True)
    f = d / f"log_{args.rows}.csv"
    if not f.exists():
        write_csv(f, args.rows)
    py = sys.executable
    xl = str(BIN / "xlotkit")
    cmds = {"pandas": [py, "-c", f"import pandas; pandas.read_csv({str(f)!r})"],
            "inspect": [xl, "inspect", "--json", str(f)],
            "read_log": [py, "-c", f"from xlotkit.interpret.io import read_log; "
                                   f"read_log({str(f)!r})"]}
    times: dict[str, list[float]] = {k: [] for k in cmds}
    for _ in range(args.repeat):          # interleaved: a busy machine slows all alike
        for k, c in cmds.items():
            times[k].append(run(c)[0])
    lo = {k: min(v) for k, v in times.items()}
    med = {k: float(np.median(v)) for k, v in times.items()}
    print("| rows | file MB | statistic | pandas.read_csv s | xlotkit inspect --json s | ratio "
          "| read_log s | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for name, st in (("best", lo), ("median", med)):
        print(f"| {args.rows:.0e} | {f.stat().st_size / 1e6:.0f} | {name} of {args.repeat} | "
              f"{st['pandas']:.2f} | {st['inspect']:.2f} | {st['inspect'] / st['pandas']:.2f} | "
              f"{st['read_log']:.2f} | {st['read_log'] / st['pandas']:.2f} |")
    if args.big_rows:
        g = d / f"log_{args.big_rows}.csv"
        if not g.exists():
            write_csv(g, args.big_rows)
        t0 = time.perf_counter()
        mem = peak_mb([py, "-c", f"from xlotkit.interpret.io import read_log; "
                                 f"read_log({str(g)!r})"])
        wall = time.perf_counter() - t0
        mem_pd = peak_mb([py, "-c", f"import pandas; pandas.read_csv({str(g)!r})"])
        print()
        print("| rows | file MB | read_log peak MB | read_log s | pandas.read_csv peak MB |")
        print("|---|---|---|---|---|")
        print(f"| {args.big_rows:.0e} | {g.stat().st_size / 1e6:.0f} | {mem:.0f} | {wall:.1f} "
              f"| {mem_pd:.0f} |")
    print(f"\n(files in {d}; cores: {os.cpu_count()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
