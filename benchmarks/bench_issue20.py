"""Benchmark for issue 20: the 2D engine's speed (run on demand, results in docs/benchmarks.md).

    PYTHONPATH=src .venv/bin/python benchmarks/bench_issue20.py compare --base /path/to/89f3225/src
    PYTHONPATH=src .venv/bin/python benchmarks/bench_issue20.py scaling [--levels 0 1 2 3]
    PYTHONPATH=src .venv/bin/python benchmarks/bench_issue20.py freepath [--segments 32]

``compare`` runs ``xlotkit simulate benchmarks/scene_2d_standard_issue20.toml`` (a frozen copy
of the standard scene, strip on, so the comparison stays like for like) with the baseline
source tree on PYTHONPATH and with this tree, one after the other in the same invocation
(each in its own process, the numba cache of this tree warmed first), and prints for each:
wall and CPU time, peak resident memory, steps, Newton iterations per accepted step, and the
realised sigma_h and FBP from summary.json with their relative differences (targets: ratio
>= 5, sigma_h within 0.2 %, FBP within 1 %). It then measures, in this tree, the time per
Newton iteration of the run against one sparse factorisation of the coupled Jacobian of the
same run (the equilibrated SuperLU factorisation the Newton uses, ordering included; median
of repeated factorisations of the Jacobian at the end of the run; target <= 2).

``scaling`` runs a two-cycle XLOT (the standard scene) on meshes refined uniformly by
halving every length of the mesh (wall element, band element) and ``growth - 1`` per level:
level 0 is the standard mesh (1008 triangles), levels 1, 2, 3 have about 4k, 18k and 73k.
Each level runs in its own process; wall time, CPU time, Newton iterations and peak memory
are printed, with the exponent of a least-squares fit of wall time against the number of
triangles (target <= 1.3).

``freepath`` runs the standard two-cycle XLOT on the free path (``mesh.band_strip = false``,
``effects.fracture_plane = false``: the crack finds its own way through the clusters) with
``--segments`` wall segments (target: >= 32 segments in <= 3 min).

Peak memory is the process's largest resident set size (``resource.getrusage``), which
includes the Python interpreter and its libraries (~150 MB).
"""

from __future__ import annotations

import argparse
import base64
import json
import math
import os
import resource
import pickle
import re
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENE = HERE / "scene_2d_standard_issue20.toml"

# run one scene in a child process: simulate, then report wall/CPU/peak memory and the
# engine's counters as one JSON line on stdout
_CHILD = r"""
import base64, json, pickle, resource, sys, time
from pathlib import Path
data = pickle.loads(base64.b64decode(sys.argv[1])); out = Path(sys.argv[2])
from xlotkit.sim.run import simulate
from xlotkit.sim.scene import scene_from_dict
t0, c0 = time.perf_counter(), time.process_time()
res = simulate(scene_from_dict(data), out)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
summ = json.loads((out / "summary.json").read_text())
print("RESULT " + json.dumps({
    "wall_s": wall, "cpu_s": cpu, "status": res.status, "message": res.message,
    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    "summary": summ}))
"""


# the command line in a child process (the baseline tree has no other entry point in
# common with this one), then its peak memory
_CLI = r"""
import resource, sys
from xlotkit.cli import main
try:
    main()
except SystemExit as e:
    code = e.code
print("PEAK_RSS_MB %.1f" % (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0))
"""


def run_cli(src: Path, scene: Path, out: Path) -> dict:
    """``xlotkit simulate scene --out out`` with the source tree ``src`` in a fresh
    process: wall and CPU time (interpreter start and imports included), peak memory and
    the run's summary."""
    env = dict(os.environ, PYTHONPATH=str(src))
    t0 = time.perf_counter()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run([sys.executable, "-c", _CLI, "simulate", str(scene), "--out",
                           str(out)], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if not (out / "summary.json").is_file():
        raise RuntimeError(f"run failed ({src}):\n{proc.stderr[-3000:]}")
    peak = next((float(ln.split()[1]) for ln in proc.stdout.splitlines()
                 if ln.startswith("PEAK_RSS_MB")), float("nan"))
    return {"wall_s": wall, "cpu_s": (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime),
            "peak_rss_mb": peak, "summary": json.loads((out / "summary.json").read_text())}


def _scene_dict(path: Path = SCENE) -> dict:
    with open(path, "rb") as f:
        return tomllib.load(f)


def _merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(base.get(k, {}), v) if isinstance(v, dict) else v
    return out


def run_child(src: Path, data: dict, out: Path, timeout: float | None = None) -> dict:
    """Simulate ``data`` with the source tree ``src`` in a fresh process."""
    env = dict(os.environ, PYTHONPATH=str(src))
    arg = base64.b64encode(pickle.dumps(data)).decode()
    proc = subprocess.run([sys.executable, "-c", _CHILD, arg, str(out)],
                          env=env, capture_output=True, text=True, timeout=timeout)
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT "):])
    raise RuntimeError(f"run failed ({src}):\n{proc.stderr[-3000:]}")


def _counters(summary: dict) -> tuple[int | None, int | None]:
    """(accepted steps, Newton iterations) of a 2D run, from its summary's message
    ("... N steps (k cut), M Newton iterations ...")."""
    m = re.search(r"(\d+) steps \(\d+ cut\), (\d+) Newton iterations",
                  summary.get("message", ""))
    return (int(m.group(1)), int(m.group(2))) if m else (None, None)


def _find(d, key):
    """First value of ``key`` anywhere in a nested dict."""
    if isinstance(d, dict):
        if key in d:
            return d[key]
        for v in d.values():
            r = _find(v, key)
            if r is not None:
                return r
    return None


def factorisation_time(data: dict, repeats: int = 15) -> dict:
    """Time per Newton iteration of a run of ``data`` (this tree, in this process) and the
    median time of one equilibrated sparse LU factorisation of the coupled Jacobian at the
    run's last state, ordering included."""
    import numpy as np
    import scipy.sparse.linalg as spla

    from xlotkit.sim.coupling.engine import MDEMEngine
    from xlotkit.sim.coupling.linear import equilibrate
    from xlotkit.sim.scene import scene_from_dict

    eng = MDEMEngine(scene_from_dict(data))
    eng.start()
    t0, c0 = time.perf_counter(), time.process_time()
    while not eng.is_done():
        eng.step()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    stp = eng.stepper
    its = stp.counters.newton_iterations
    model, st = stp.model, stp.state
    res = model.residual_and_jacobian(model.x_of(st), st, 1.0)
    A, _, _ = equilibrate(res.jacobian.tocsc())
    tw, tc = [], []
    for _ in range(repeats):
        a, b = time.perf_counter(), time.process_time()
        spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                  options={"SymmetricMode": True})
        tw.append(time.perf_counter() - a)
        tc.append(time.process_time() - b)
    ls = stp.linear_solver.stats
    return {"wall_s": wall, "cpu_s": cpu, "iterations": its,
            "wall_per_iteration_ms": 1e3 * wall / its, "cpu_per_iteration_ms": 1e3 * cpu / its,
            "factorisation_wall_ms": 1e3 * float(np.median(tw)),
            "factorisation_cpu_ms": 1e3 * float(np.median(tc)),
            "unknowns": int(res.jacobian.shape[0]), "nnz": int(res.jacobian.nnz),
            "factorisations": ls.factorisations, "krylov_solves": ls.krylov_solves,
            "krylov_iterations": ls.krylov_iterations}


def cmd_compare(a) -> None:
    data = _scene_dict()
    new_src = a.new.resolve()
    with tempfile.TemporaryDirectory() as tmp:
        # warm this tree's numba cache (compiled kernels are cached on disk, as in use)
        run_child(new_src, _merge(data, {"schedule": {"phase": data["schedule"]["phase"][:1]}}),
                  Path(tmp) / "warm")
        runs = {}
        for name, src in (("base", a.base.resolve()), ("new", new_src)):
            runs[name] = run_cli(src, SCENE, Path(tmp) / name)
    print("| run | wall (s) | CPU (s) | peak RSS (MB) | steps | Newton its | its/step "
          "| sigma_h realised (bar) | FBP (bar) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    vals = {}
    for name, r in runs.items():
        s = r["summary"]
        steps, its = _counters(s)
        sh = _find(s, "realised_bar")
        sh = sh.get("sigma_h") if isinstance(sh, dict) else None
        fbp = _find(s, "fbp_bar")
        vals[name] = (r["wall_s"], r["cpu_s"], sh, fbp)
        ips = f"{its / steps:.2f}" if steps and its else "-"
        print(f"| {name} | {r['wall_s']:.2f} | {r['cpu_s']:.2f} | {r['peak_rss_mb']:.0f} | "
              f"{steps} | {its} | {ips} | {sh} | {fbp} |")
    (tb, cb, shb, fb), (tn, cn, shn, fn) = vals["base"], vals["new"]
    print(f"\nspeed-up base/new: wall {tb / tn:.2f}x, CPU {cb / cn:.2f}x")
    for label, b, n in (("sigma_h", shb, shn), ("FBP", fb, fn)):
        if b and n is not None:
            print(f"{label} relative difference: {abs(n - b) / abs(b):.2e}")
    if not a.no_factor:
        f = factorisation_time(data)
        print(f"\nper Newton iteration (in-process run of this tree, {f['iterations']} its): "
              f"wall {f['wall_per_iteration_ms']:.2f} ms, CPU {f['cpu_per_iteration_ms']:.2f} ms")
        print(f"one factorisation of the coupled Jacobian ({f['unknowns']} unknowns, "
              f"{f['nnz']} entries): wall {f['factorisation_wall_ms']:.2f} ms, CPU "
              f"{f['factorisation_cpu_ms']:.2f} ms")
        print(f"ratio iteration/factorisation: wall "
              f"{f['wall_per_iteration_ms'] / f['factorisation_wall_ms']:.2f}, CPU "
              f"{f['cpu_per_iteration_ms'] / f['factorisation_cpu_ms']:.2f} "
              f"({f['factorisations']} factorisations, {f['krylov_solves']} Krylov solves "
              f"with {f['krylov_iterations']} iterations)")


def level_overrides(level: int) -> dict:
    """Mesh of refinement level ``level``: every length of the standard mesh halved
    ``level`` times (wall and band elements, ``growth - 1``)."""
    f = 0.5 ** level
    return {"mesh": {"wall_element_size": f"{0.0785 * f:.6g} m",
                     "band_element_size": f"{0.5 * f:.6g} m",
                     "growth": 1.0 + 0.5 * f}}


def cmd_scaling(a) -> None:
    import numpy as np

    from xlotkit.sim.coupling.build import _scene_mesh
    from xlotkit.sim.scene import scene_from_dict

    base = _scene_dict()
    src = a.new.resolve()
    rows = []
    print("| level | triangles | wall (s) | CPU (s) | steps | Newton its | peak RSS (MB) "
          "| status |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as tmp:
        run_child(src, _merge(base, {"schedule": {"phase": base["schedule"]["phase"][:1]}}),
                  Path(tmp) / "warm")
        for lv in a.levels:
            data = _merge(base, level_overrides(lv))
            n = _scene_mesh(scene_from_dict(data)).n_triangles
            r = run_child(src, data, Path(tmp) / f"l{lv}", timeout=a.timeout)
            s = r["summary"]
            rows.append((n, r["wall_s"]))
            steps, its = _counters(s)
            print(f"| {lv} | {n} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | "
                  f"{steps} | {its} | "
                  f"{r['peak_rss_mb']:.0f} | {r['status']} |", flush=True)
    if len(rows) >= 2:
        n, w = np.log([r[0] for r in rows]), np.log([r[1] for r in rows])
        p = np.polyfit(n, w, 1)[0]
        print(f"\nwall time ~ N^{p:.2f} (least squares over {len(rows)} levels)")


def cmd_freepath(a) -> None:
    base = _scene_dict()
    h = 2 * math.pi * 0.15 / a.segments
    data = _merge(base, {"mesh": {"band_strip": False, "wall_element_size": f"{h:.6g} m"},
                         "effects": {"fracture_plane": False}})
    from xlotkit.sim.coupling.build import _scene_mesh
    from xlotkit.sim.scene import scene_from_dict
    n = _scene_mesh(scene_from_dict(data)).n_triangles
    with tempfile.TemporaryDirectory() as tmp:
        run_child(a.new.resolve(), _merge(base, {"schedule": {
            "phase": base["schedule"]["phase"][:1]}}), Path(tmp) / "warm")
        r = run_child(a.new.resolve(), data, Path(tmp) / "free", timeout=a.timeout)
    s = r["summary"]
    steps, its = _counters(s)
    print(f"free path, {a.segments} wall segments, {n} triangles: wall {r['wall_s']:.1f} s, "
          f"CPU {r['cpu_s']:.1f} s, {steps} steps, {its} Newton iterations, peak RSS "
          f"{r['peak_rss_mb']:.0f} MB, status {r['status']}: {r['message']}")
    print(f"FBP {_find(s, 'fbp_bar')} bar, realised sigma_h "
          f"{(_find(s, 'realised_bar') or {}).get('sigma_h')} bar")


def main() -> None:
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd")
    c = sub.add_parser("compare")
    c.add_argument("--base", type=Path, required=True, help="src/ of the baseline commit")
    c.add_argument("--no-factor", action="store_true",
                   help="skip the per-iteration vs factorisation measurement")
    s = sub.add_parser("scaling")
    s.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2, 3])
    f = sub.add_parser("freepath")
    f.add_argument("--segments", type=int, default=32)
    for p in (c, s, f):
        p.add_argument("--new", type=Path, default=HERE.parent / "src")
    for p in (s, f):
        p.add_argument("--timeout", type=float, default=None, help="per run [s]")
    argv = sys.argv[1:]
    if argv and argv[0].startswith("--"):
        argv = ["compare"] + argv            # the former interface: --base ...
    a = ap.parse_args(argv)
    {"compare": cmd_compare, "scaling": cmd_scaling, "freepath": cmd_freepath}[a.cmd or
                                                                               "compare"](a)


if __name__ == "__main__":
    main()
