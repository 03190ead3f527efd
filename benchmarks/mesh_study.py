"""Breakdown against the wall's resolution: the standard scene on 12, 24 and 48 wall segments.

    .venv/bin/python benchmarks/mesh_study.py [--base SCENE.toml] [--segments 12 24 48]
                                              [--path free strip] [--out DIR]
                                              [--reuse RESULTS.json] [--write-docs]

Runs the base scene (default ``examples/scene_2d_standard.toml``) with the wall element
size set to ``2 pi a / n`` for each ``n`` of ``--segments`` (nothing else changed: the
band's and the far mesh's element sizes are the scene's), on the path ``--path`` sets
explicitly, whatever the base scene has (:data:`PATHS`): ``free`` (the default, and the
scenes' default since issue 17: every failed cluster on its own crack plane,
``mesh.band_strip = false``, ``effects.fracture_plane = false``, ``rock.crack_plane =
"stress"``) or ``strip`` (the crack strip with the band's preset plane). Each run's
synthetic log (gauge noise off) goes through the reader and the picks as a field log; the
table gives the triangles, the model's own initiation and breakdown pressures (engine
truth: first cluster failure, first drop of the well pressure while pumping), the picked
cycle-1 FBP and FPP (a pick not found: its reason below the table), and the run's wall and
CPU time. ``results.json`` and ``table.md`` go into a fresh ``--out`` folder; with
``--write-docs`` the table goes into docs/mechanics.md between the ``MESH-STUDY`` markers.
Runs one at a time, the whole schedule of the base scene (the standard two-cycle XLOT: 42,
213 and 173 s of CPU on 12, 24 and 48 wall segments; 5 to 21 minutes of wall time each on
the shared machine).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from accuracy_vs_cost import merge

DOC = ROOT / "docs" / "mechanics.md"
START, END = "<!-- MESH-STUDY:START -->", "<!-- MESH-STUDY:END -->"


#: The crack's path, set explicitly whatever the base scene has: ``free`` = every failed
#: cluster on its own crack plane, no strip, no preset plane (the scenes' default);
#: ``strip`` = the crack strip along the band axis with the band's preset plane (the
#: scenes' path before issue 17).
PATHS: dict[str, dict] = {
    "free": {"mesh": {"band_strip": False}, "effects": {"fracture_plane": False},
             "rock": {"crack_plane": "stress"}},
    "strip": {"mesh": {"band_strip": True}, "effects": {"fracture_plane": True}},
}


def variant(base: dict, segments: int, path: str, refine: str = "wall") -> dict:
    """The base scene with ``segments`` wall elements, on the free or the strip path.

    ``refine="all"`` scales the band's element size with the wall's (the base scene's band
    element size belongs to its own wall segments), as the mesh rows of
    benchmarks/accuracy_vs_cost.py do."""
    from xlotkit.sim.scene import scene_from_dict

    sc = scene_from_dict(base)
    a = sc.geometry.hole_radius
    h_wall = 2.0 * math.pi * a / segments
    over: dict = {"mesh": {"wall_element_size": h_wall}}
    if refine == "all" and sc.mesh.band_element_size is not None:
        f = h_wall / (sc.mesh.wall_element_size or 2.0 * math.pi * a / 64)
        over["mesh"]["band_element_size"] = sc.mesh.band_element_size * f
    return merge(merge(base, PATHS[path]), over)


def run_one(data: dict, work: Path) -> dict:
    """Simulate a scene dict and pick its log: triangles, truth and picks [Pa], times."""
    from xlotkit.interpret.io import read_log
    from xlotkit.pipeline import interpret_record
    from xlotkit.sim.coupling.build import build_model
    from xlotkit.sim.run import simulate
    from xlotkit.sim.scene import scene_from_dict

    scene = scene_from_dict(data)
    n_tri = build_model(scene)[0].mesh.n_triangles
    t0, c0 = time.perf_counter(), time.process_time()
    res = simulate(scene, work)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    out = {"triangles": n_tri, "wall_s": wall, "cpu_s": cpu, "status": res.status,
           "message": res.message, "initiation": res.truth.get("initiation_pressure"),
           "fbp_truth": res.truth.get("fbp"), "picks": {}, "missed": {}}
    interp = interpret_record(read_log(res.paths["log"]))
    cyc = interp.picks.test_cycles
    for name in ("FBP", "FPP"):
        p = cyc[0].get(name) if cyc else None
        out["picks"][name] = p.value if p is not None and p.found else None
        if p is None or not p.found:
            out["missed"][name] = p.message if p is not None else "no test cycle"
    return out


def _bar(v) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v / 1e5:.1f}"


def _sec(v) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v:.0f}"


def table(results: dict) -> str:
    head = ("| path / refined | wall segments | triangles | initiation [bar] "
            "| breakdown (model) [bar] | FBP picked [bar] | FPP picked [bar] | wall time [s] "
            "| CPU [s] |")
    lines = [head, "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    notes = []
    for key, r in results.items():
        path, n = key.split(":")
        path = path.replace("/", " / ")
        lines.append(f"| {path} | {n} | {r['triangles'] or '–'} | {_bar(r['initiation'])} | "
                     f"{_bar(r['fbp_truth'])} | {_bar(r['picks'].get('FBP'))} | "
                     f"{_bar(r['picks'].get('FPP'))} | {_sec(r['wall_s'])} | {_sec(r['cpu_s'])} |")
        if r["status"] != "ok":
            notes.append(f"{key}: {r['status']}: {r['message'][:200]}")
        for q, why in r.get("missed", {}).items():
            notes.append(f"{key}: no {q} pick: {why}")
    if notes:
        lines.append("")
        lines.extend(f"* {n}" for n in notes)
    for path in sorted({k.split(":")[0] for k in results}):
        for q in ("FBP", "FPP"):
            v = [r["picks"].get(q) for k, r in results.items() if k.startswith(path + ":")]
            v = [x for x in v if x]
            if len(v) > 1:
                lines.append("")
                lines.append(f"{path}: {q} spread (max − min)/min = "
                             f"{100 * (max(v) - min(v)) / min(v):.2f} %")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--base", default=str(ROOT / "examples" / "scene_2d_standard.toml"))
    ap.add_argument("--segments", nargs="*", type=int, default=[12, 24, 48])
    ap.add_argument("--path", nargs="*", default=["free"], choices=sorted(PATHS))
    ap.add_argument("--refine", nargs="*", default=["wall"], choices=["wall", "all"],
                    help="wall: only the wall elements; all: the band's elements with them")
    ap.add_argument("--out", default=str(ROOT / "results" / "mesh-study"))
    ap.add_argument("--reuse", default=None, metavar="RESULTS.json")
    ap.add_argument("--write-docs", action="store_true")
    args = ap.parse_args()

    from xlotkit.atomic import fresh_output_dir

    base = tomllib.loads(Path(args.base).read_text())
    base = merge(base, {"output": {"noise": 0.0, "snapshot_interval": None}})
    out = fresh_output_dir(args.out)
    results = json.loads(Path(args.reuse).read_text()) if args.reuse else {}
    for path, refine in [(p, f) for p in args.path for f in args.refine]:
        for n in args.segments:
            key = f"{path}/{refine}:{n}"
            if key in results:
                continue
            print(f"{key} ...", flush=True)
            with tempfile.TemporaryDirectory() as tmp:
                try:
                    r = run_one(variant(base, n, path, refine), Path(tmp) / "run")
                except Exception as exc:  # noqa: BLE001 -- a failing run is a result too
                    r = {"triangles": None, "wall_s": math.nan, "cpu_s": math.nan,
                         "status": "failed", "message": f"{type(exc).__name__}: {exc}",
                         "initiation": None, "fbp_truth": None, "picks": {}, "missed": {}}
            results[key] = r
            print(f"  {r['status']} {r['triangles']} triangles in {_sec(r['wall_s'])} s: "
                  f"initiation {_bar(r['initiation'])}, breakdown {_bar(r['fbp_truth'])}, "
                  f"FBP {_bar(r['picks'].get('FBP'))}, FPP {_bar(r['picks'].get('FPP'))} bar",
                  flush=True)
            (out / "results.json").write_text(json.dumps(results, indent=2, default=str))
    tab = table(results)
    (out / "table.md").write_text(tab)
    print(tab)
    if args.write_docs:
        text = DOC.read_text()
        a, b = text.index(START) + len(START), text.index(END)
        DOC.write_text(text[:a] + "\n" + tab + text[b:])
    print(f"results in {out}")


if __name__ == "__main__":
    main()
