"""Benchmark for issue 20: the standard 2D scene, baseline commit vs this tree (run on demand).

    PYTHONPATH=src .venv/bin/python benchmarks/bench_issue20.py --base /path/to/89f3225/src

Runs ``xlotkit simulate benchmarks/scene_2d_standard_issue20.toml`` (a frozen copy of the
standard scene, so the comparison stays like for like) once with the baseline source tree on
PYTHONPATH and once with this tree, one after the other in the same invocation, and prints the
wall time of each, their ratio, and the realised sigma_h and FBP from each run's summary.json
with their relative differences (targets: ratio >= 5, sigma_h within 0.2 %, FBP within 1 %).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENE = HERE / "scene_2d_standard_issue20.toml"


def _run(src: Path, out: Path) -> tuple[float, dict]:
    env = dict(os.environ, PYTHONPATH=str(src))
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import sys; from xlotkit.cli import main; sys.exit(main())",
                    "simulate", str(SCENE),
                    "--out", str(out)], env=env, check=True)
    wall = time.perf_counter() - t0
    return wall, json.loads((out / "summary.json").read_text())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--base", type=Path, required=True, help="src/ of the baseline commit")
    ap.add_argument("--new", type=Path, default=HERE.parent / "src")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tb, sb = _run(a.base, Path(tmp) / "base")
        tn, sn = _run(a.new, Path(tmp) / "new")
    print("| run | wall time (s) | sigma_h realised (bar) | FBP (bar) |")
    print("| --- | --- | --- | --- |")
    rows = []
    for name, t, s in (("base", tb, sb), ("new", tn, sn)):
        sh = s.get("realised_bar", {}).get("sigma_h")
        fbp = s.get("fbp_bar")
        rows.append((sh, fbp))
        print(f"| {name} | {t:.2f} | {sh} | {fbp} |")
    print(f"\nspeed-up base/new: {tb / tn:.2f}x")
    for label, i in (("sigma_h", 0), ("FBP", 1)):
        b, n = rows[0][i], rows[1][i]
        if b and n is not None:
            print(f"{label} relative difference: {abs(n - b) / abs(b):.2e}")


if __name__ == "__main__":
    main()
