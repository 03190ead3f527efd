"""What accuracy costs: picked FCP, FBP and FPP against CPU time over model settings.

    .venv/bin/python benchmarks/accuracy_vs_cost.py [--base SCENE.toml] [--only NAME ...]
                                                    [--out DIR] [--write-docs]

Runs the base scene (default ``examples/scene_2d_standard.toml``) with one setting changed
at a time: mesh fineness, crack-tip strength scaling on/off, the failure-count step
controls (N1/N2) and step limits, the coupling strategy, and the model level (lumped vs
2D). Each run's synthetic log (gauge noise off, so differences are the model's) goes
through the same reader and picks as a field log; the errors of the cycle-1 FCP (flowback
consensus), FBP and FPP are taken against the reference run (the finest mesh with the
tightest controls). Writes ``results.json``, ``accuracy_vs_cost.png`` (error against CPU
time with the Pareto front) and ``table.md`` into a fresh ``--out`` folder; with
``--write-docs`` the table and the plot also go into docs/accuracy-vs-cost.md (between the
``BENCH`` markers) and docs/accuracy-vs-cost.png. Runs one at a time; the cost is the
run's CPU time (the solver is single-threaded: on an idle machine that is its wall time,
and unlike wall time it does not depend on other jobs); wall times are reported beside it.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import re
import shutil
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "accuracy-vs-cost.md"
START, END = "<!-- BENCH:START -->", "<!-- BENCH:END -->"
QUANTITIES = ("FCP", "FBP", "FPP")
#: The cost axis: CPU seconds of the run (the solver is single-threaded, so on an idle
#: machine this is its wall time; unlike wall time it does not grow with other jobs)
COST = "cpu_s"


def merge(base: dict, over: dict) -> dict:
    """``base`` with ``over`` merged in, section by section (a new dict)."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = merge(out[k], v)
        elif v is None:
            out.pop(k, None)
        else:
            out[k] = copy.deepcopy(v)
    return out


def variants(base: dict) -> dict[str, tuple[str, dict]]:
    """Name -> (group, overrides of the base scene). ``reference`` is the converged run."""
    mesh = base.get("mesh", {})
    num = base.get("numerics", {})

    def scaled(key: str, f: float, default: float) -> str:
        v = mesh.get(key, default)
        if isinstance(v, str):
            num_, unit = v.split()[0], " ".join(v.split()[1:])
            return f"{float(num_) * f:g} {unit}".strip()
        return f * float(v)

    def mesh_f(f: float) -> dict:
        m = {"wall_element_size": scaled("wall_element_size", f, 0.06)}
        if "band_element_size" in mesh:
            m["band_element_size"] = scaled("band_element_size", f, 0.06)
        return {"mesh": m}

    tight = {"numerics": {"n1": 1, "n2": 2, "dt_max": "0.5 s", "dp_max": "0.1 MPa"}}
    v: dict[str, tuple[str, dict]] = {
        "reference": ("reference", merge(mesh_f(0.5), tight)),
        "base": ("base", {}),
        "mesh x1.5 coarser": ("mesh", mesh_f(1.5)),
        "mesh x0.75": ("mesh", mesh_f(0.75)),
        "mesh x0.5": ("mesh", mesh_f(0.5)),
        "no strength scaling": ("scaling", {"effects": {"strength_scaling": False}}),
        "N1/N2 = 1/2": ("steps", {"numerics": {"n1": 1, "n2": 2}}),
        "N1/N2 = 10/40": ("steps", {"numerics": {"n1": 10, "n2": 40}}),
        "dt_max 0.5 s, dp_max 0.1 MPa": ("steps", {"numerics": {"dt_max": "0.5 s",
                                                                 "dp_max": "0.1 MPa"}}),
        "dt_max x4, dp_max x4": ("steps", {"numerics": {
            "dt_max": f"{4 * _seconds(num.get('dt_max', 2.0)):g} s",
            "dp_max": f"{4 * _mpa(num.get('dp_max', 0.5e6)):g} MPa"}}),
        "coupling wfd": ("coupling", {"coupling": "wfd"}),
        "coupling wfc": ("coupling", {"coupling": "wfc"}),
        "lumped model": ("model", {"model": "lumped", "mesh": None,
                                   "effects": {"strength_scaling": False,
                                               "heterogeneity": False,
                                               "poroelastic": False,
                                               "fracture_plane": False}}),
    }
    return v


def _seconds(v) -> float:
    return float(v.split()[0]) if isinstance(v, str) else float(v)


def _mpa(v) -> float:
    if isinstance(v, str):
        x, unit = v.split()[0], v.split()[1]
        return float(x) * {"MPa": 1.0, "bar": 0.1, "Pa": 1e-6}[unit]
    return float(v) / 1e6


class OverBudget(Exception):
    """A run went past its CPU budget (``--max-cpu``)."""


def run_one(data: dict, work: Path, max_cpu: float = math.inf) -> dict:
    """Simulate a scene dict, pick its log; wall time and the cycle-1 picks [Pa]. A run
    past ``max_cpu`` CPU seconds is stopped (:class:`OverBudget`)."""
    from xlotkit.interpret.io import read_log
    from xlotkit.pipeline import interpret_record
    from xlotkit.sim.run import simulate
    from xlotkit.sim.scene import scene_from_dict

    scene = scene_from_dict(data)
    t0, c0 = time.perf_counter(), time.process_time()
    def budget(_frac: float, _msg: str) -> None:
        if time.process_time() - c0 > max_cpu:
            raise OverBudget(f"stopped after {max_cpu:g} s CPU")

    res = simulate(scene, work, progress=budget)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    interp = interpret_record(read_log(res.paths["log"]))
    out = {"wall_s": wall, "cpu_s": cpu, "status": res.status, "model": res.model,
           "message": res.message, "picks": {}}
    cyc = interp.picks.test_cycles
    if cyc:
        c = cyc[0]
        for name in QUANTITIES:
            p = c.fcp if name == "FCP" else c.get(name)
            out["picks"][name] = p.value if p is not None and p.found else None
    return out


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points not beaten in both wall time and error (sorted by time)."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def fronts(results: dict) -> dict[str, set[str]]:
    """Per quantity, the runs on the Pareto front of CPU time against error."""
    errs = errors(results)
    out = {}
    for q in QUANTITIES:
        names = [n for n, r in results.items()
                 if n != "reference" and errs[n][q] is not None and math.isfinite(r[COST])]
        idx = pareto([(results[n][COST], errs[n][q]) for n in names])
        out[q] = {names[i] for i in idx}
    return out


def table(results: dict) -> str:
    ref = results["reference"]["picks"]
    errs = errors(results)
    front = fronts(results)
    lines = ["| run | group | model | CPU [s] | wall [s] | FCP err | FBP err | FPP err | "
             "on the front of |", "|---|---|---|---:|---:|---:|---:|---:|---|"]
    for n, r in results.items():
        cells = ["failed" if errs[n][q] is None else f"{100 * errs[n][q]:.2f} %"
                 for q in QUANTITIES]
        on = ", ".join(q for q in QUANTITIES if n in front[q])
        lines.append(f"| {n} | {r['group']} | {r.get('model', '')} | {_cost_cell(r)} | "
                     f"{_num(r['wall_s'])} | " + " | ".join(cells) + f" | {on} |")
    lines.append("")
    lines.append("Reference picks: " + ", ".join(
        f"{q} {ref[q] / 1e5:.2f} bar" if ref.get(q) else f"{q} –" for q in QUANTITIES))
    return "\n".join(lines) + "\n"


def _num(v: float) -> str:
    return f"{v:.1f}" if math.isfinite(v) else "–"


def _cost_cell(r: dict) -> str:
    """The CPU seconds, or what stopped the run (``--max-cpu``) or made it fail."""
    if math.isfinite(r[COST]):
        return f"{r[COST]:.1f}"
    m = re.search(r"stopped after (\S+) s CPU", r.get("message", ""))
    return f"> {m.group(1)} (stopped)" if m else "– (failed)"


def errors(results: dict) -> dict[str, dict[str, float | None]]:
    ref = results["reference"]["picks"]
    out = {}
    for n, r in results.items():
        out[n] = {}
        for q in QUANTITIES:
            v, rv = r["picks"].get(q), ref.get(q)
            out[n][q] = None if v is None or not rv else abs(v - rv) / rv
    return out


def plot(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    errs = errors(results)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharex=True)
    groups = sorted({r["group"] for r in results.values()})
    marks = dict(zip(groups, "osD^v<>p*"))
    colours = dict(zip(groups, plt.cm.tab10.colors))
    for ax, q in zip(axes, QUANTITIES):
        pts, names = [], []
        for n, r in results.items():
            e = errs[n][q]
            if e is None or n == "reference":
                continue
            y = max(e, 1e-5)          # an exact match is drawn on the axis floor
            ax.loglog(r[COST], 100 * y, marks[r["group"]], color=colours[r["group"]],
                      label=r["group"])
            ax.annotate(n, (r[COST], 100 * y), fontsize=6, xytext=(3, 3),
                        textcoords="offset points")
            pts.append((r[COST], y))
            names.append(n)
        f = pareto(pts)
        if f:
            ax.loglog([pts[i][0] for i in f], [100 * pts[i][1] for i in f], "k--", lw=0.8)
        ax.set_title(f"{q} error vs the reference")
        ax.set_xlabel("CPU time [s]")
        ax.set_ylabel("error [%]")
        ax.grid(True, which="both", lw=0.3)
    h, lab = axes[0].get_legend_handles_labels()
    uniq = dict(zip(lab, h))
    axes[0].legend(uniq.values(), uniq.keys(), fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--base", default=str(ROOT / "examples" / "scene_2d_standard.toml"))
    ap.add_argument("--only", nargs="*", default=None, help="variant names")
    ap.add_argument("--out", default=str(ROOT / "results" / "accuracy-vs-cost"))
    ap.add_argument("--write-docs", action="store_true")
    ap.add_argument("--reuse", default=None, metavar="RESULTS.json",
                    help="take the variants already in this results.json (of the same base "
                         "scene and code) and run only the others")
    ap.add_argument("--max-cpu", type=float, default=1800.0,
                    help="stop a variant after this many CPU seconds (reported as failed)")
    args = ap.parse_args()

    from xlotkit.atomic import fresh_output_dir

    base = tomllib.loads(Path(args.base).read_text())
    base = merge(base, {"output": {"noise": 0.0, "snapshot_interval": None}})
    todo = variants(base)
    if args.only:
        unknown = [n for n in args.only if n not in todo]
        if unknown:
            sys.exit(f"unknown variants {unknown}; known: {list(todo)}")
        todo = {n: todo[n] for n in ["reference", *args.only] if n in todo}
    out = fresh_output_dir(args.out)
    results: dict[str, dict] = {}
    reused = json.loads(Path(args.reuse).read_text()) if args.reuse else {}
    for name, (group, over) in todo.items():
        if name in reused:
            results[name] = reused[name]
            continue
        data = merge(base, over)
        print(f"{name} ...", flush=True)
        with tempfile.TemporaryDirectory() as tmp:
            try:
                r = run_one(data, Path(tmp) / "run", args.max_cpu)
            except Exception as exc:  # noqa: BLE001 -- a failing variant is a result too
                r = {"wall_s": math.nan, "cpu_s": math.nan, "status": "failed", "model": "",
                     "message": f"{type(exc).__name__}: {exc}", "picks": {}}
        r["group"] = group
        results[name] = r
        print(f"  {r['status']} in {r['wall_s']:.1f} s ({r['cpu_s']:.1f} s CPU); picks "
              + ", ".join(
            f"{q} {v / 1e5:.2f} bar" if v else f"{q} -" for q, v in r["picks"].items())
            + f"; {r['message'][:120]}", flush=True)
        (out / "results.json").write_text(json.dumps(results, indent=2, default=str))
    tab = table(results)
    (out / "table.md").write_text(tab)
    plot(results, out / "accuracy_vs_cost.png")
    print(tab)
    if args.write_docs:
        text = DOC.read_text()
        a, b = text.index(START) + len(START), text.index(END)
        DOC.write_text(text[:a] + "\n" + tab + text[b:])
        shutil.copyfile(out / "accuracy_vs_cost.png", DOC.with_suffix(".png"))
    print(f"results in {out}")


if __name__ == "__main__":
    main()
