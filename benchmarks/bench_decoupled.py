"""Benchmark for issue 17, "effects not asked for are not assembled": the cost of the
Biot blocks that ``effects.poroelastic = false`` no longer assembles.

    PYTHONPATH=src .venv/bin/python benchmarks/bench_decoupled.py --old /path/to/old/src \
        [--repeat 3]

Runs the frozen standard scene (``benchmarks/scene_2d_standard_issue20.toml``, poroelastic
off) with the source tree ``--old`` (a commit before this change: intact clusters coupled
with Biot 1e-3, their ``G`` / ``Cfu`` entries in every Jacobian) and with this tree (alpha
0, those entries absent), each run in its own process, the two interleaved ``--repeat``
times so that load on a shared machine slows them alike. For each run it reports the wall
time of the whole run, the time in the coupled residual + Jacobian evaluations and in the
linear solves (the two wrapped and timed), both per accepted step and per Newton
iteration, and the run's counters. It then times, in the same child process, the
Jacobian evaluation and one fresh equilibrated factorisation + solve (ordering included)
of the coupled Jacobian at the initial (intact) state and at the run's last state
(median of 15), with the Jacobian's stored entries. Min and median over the repeats are
printed. Both trees' numba caches are warmed first by a run of the scene's first phase.
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import pickle
import statistics
import subprocess
import sys
from pathlib import Path

import tomllib

HERE = Path(__file__).resolve().parent
SCENE = HERE / "scene_2d_standard_issue20.toml"

_CHILD = r"""
import base64, json, pickle, sys, time
import numpy as np
from xlotkit.sim.coupling.model import CoupledModel
from xlotkit.sim.coupling.linear import LinearSolver
from xlotkit.sim.coupling.engine import MDEMEngine
from xlotkit.sim.scene import scene_from_dict

data = pickle.loads(base64.b64decode(sys.argv[1]))
acc = {"rj": 0.0, "rj_n": 0, "solve": 0.0, "solve_n": 0}
_rj, _solve = CoupledModel.residual_and_jacobian, LinearSolver.solve

def rj(self, *a, **k):
    t = time.perf_counter(); r = _rj(self, *a, **k)
    acc["rj"] += time.perf_counter() - t; acc["rj_n"] += 1
    return r

def solve(self, *a, **k):
    t = time.perf_counter(); r = _solve(self, *a, **k)
    acc["solve"] += time.perf_counter() - t; acc["solve_n"] += 1
    return r

CoupledModel.residual_and_jacobian, LinearSolver.solve = rj, solve

def micro(model, st, n=15):
    x = model.x_of(st)
    ta, tf = [], []
    for _ in range(n):
        t = time.perf_counter(); res = _rj(model, x, st, 1.0); ta.append(time.perf_counter() - t)
    J = res.jacobian
    rhs = -res.residual
    for _ in range(n):
        t = time.perf_counter(); _solve(LinearSolver(krylov_iterations=0), J, rhs)
        tf.append(time.perf_counter() - t)
    return {"nnz": int(J.nnz), "n": int(J.shape[0]), "jac_ms": 1e3 * float(np.median(ta)),
            "factor_solve_ms": 1e3 * float(np.median(tf))}

eng = MDEMEngine(scene_from_dict(data))
eng.start()
stp = eng.stepper
first = micro(stp.model, stp.state)
acc.update(rj=0.0, rj_n=0, solve=0.0, solve_n=0)
t0 = time.perf_counter()
while not eng.is_done():
    eng.step()
wall = time.perf_counter() - t0
last = micro(stp.model, stp.state)
c = stp.counters
res = eng.result()
print("RESULT " + json.dumps({
    "wall_s": wall, "steps": c.steps, "its": c.newton_iterations, "acc": acc,
    "first": first, "last": last, "status": res.status,
    "message": res.message}))
"""


def run(src: Path, data: dict) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src))
    arg = base64.b64encode(pickle.dumps(data)).decode()
    p = subprocess.run([sys.executable, "-c", _CHILD, arg], env=env, capture_output=True,
                       text=True, check=False)
    for line in p.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(p.stderr[-3000:])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", type=Path, required=True, help="src/ of the DECOUPLED_BIOT tree")
    ap.add_argument("--new", type=Path, default=HERE.parent / "src")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    with open(SCENE, "rb") as f:
        data = tomllib.load(f)
    # warm both trees' numba caches (compiled kernels are cached on disk, as in use)
    warm = dict(data, schedule={"phase": data["schedule"]["phase"][:1]})
    for src in (a.old, a.new):
        run(src.resolve(), warm)
    out: dict[str, list] = {"old": [], "new": []}
    for i in range(a.repeat):
        for name, src in (("old", a.old), ("new", a.new)):
            r = run(src.resolve(), data)
            out[name].append(r)
            print(f"# {name} run {i}: {r['wall_s']:.1f} s, {r['steps']} steps, "
                  f"{r['its']} its, {r['status']}", flush=True)
    rows = [
        ("wall time of the run [s]", lambda r: r["wall_s"]),
        ("residual + Jacobian per step [ms]", lambda r: 1e3 * r["acc"]["rj"] / r["steps"]),
        ("linear solves per step [ms]", lambda r: 1e3 * r["acc"]["solve"] / r["steps"]),
        ("(residual + Jacobian + solve) per step [ms]",
         lambda r: 1e3 * (r["acc"]["rj"] + r["acc"]["solve"]) / r["steps"]),
        ("(residual + Jacobian + solve) per iteration [ms]",
         lambda r: 1e3 * (r["acc"]["rj"] + r["acc"]["solve"]) / r["its"]),
        ("Jacobian evaluation, intact state [ms]", lambda r: r["first"]["jac_ms"]),
        ("fresh factorisation + solve, intact state [ms]",
         lambda r: r["first"]["factor_solve_ms"]),
        ("Jacobian evaluation, last state [ms]", lambda r: r["last"]["jac_ms"]),
        ("fresh factorisation + solve, last state [ms]",
         lambda r: r["last"]["factor_solve_ms"]),
    ]
    print("\n| quantity | old min | old median | new min | new median |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for label, f in rows:
        o = [f(r) for r in out["old"]]
        n = [f(r) for r in out["new"]]
        print(f"| {label} | {min(o):.2f} | {statistics.median(o):.2f} | {min(n):.2f} | "
              f"{statistics.median(n):.2f} |")
    for name in ("old", "new"):
        r = out[name][0]
        print(f"{name}: {r['steps']} steps, {r['its']} Newton its "
              f"({r['its'] / r['steps']:.2f}/step), unknowns {r['first']['n']}, nnz intact "
              f"{r['first']['nnz']}, nnz last {r['last']['nnz']}; {r['message']}")


if __name__ == "__main__":
    main()
