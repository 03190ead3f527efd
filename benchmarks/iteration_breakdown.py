"""Where the Newton iterations of a 2D run go (issue 20; results in docs/benchmarks.md).

    PYTHONPATH=src .venv/bin/python benchmarks/iteration_breakdown.py [--scene FILE] [--json OUT]

Runs a scene (default the frozen standard scene of issue 20,
``benchmarks/scene_2d_standard_issue20.toml``) through :class:`MDEMEngine` in this process
and records every Newton solve the stepper makes, classified by what it was for:

* ``first``: the first solve of a step trial (from the predictor);
* ``round``: a solve after a failure round (the same step, clusters just failed);
* ``fold``: the fold predictor's solves of a longer step and the step again from there;
* ``continuation``: a solve of a continuation level after a failed solve at the floor.

Each engine trial is classified by its outcome: accepted, rejected by the stepper (too many
failures, Newton, pressure change inside the stepper) or undone by the engine after the
stepper accepted it (the engine's pressure-change rule, locating a phase end, a crack
reversal). Printed: counts and iterations per class, the per-round iteration profile of
steps with failures, a histogram of iterations per accepted step, and the totals (Newton
iterations per accepted step, the issue's measure).

The instrumentation wraps the stepper module's ``newton`` and the stepper's ``_fail`` in
this process only (it changes nothing that the run computes).
"""

from __future__ import annotations

import argparse
import collections
import json
import time
from pathlib import Path

import tomllib

HERE = Path(__file__).resolve().parent
SCENE = HERE / "scene_2d_standard_issue20.toml"


def run(scene_path: Path, overrides: dict | None = None, newton_control: dict | None = None,
        time_control: dict | None = None) -> dict:
    """Run the scene with the stepper instrumented; ``overrides`` are scene sections
    merged in, ``newton_control`` / ``time_control`` fields of the engine's
    :class:`CoupledControl` / :class:`TimeStepControl` (experiments on the step rules)."""
    from dataclasses import replace

    import xlotkit.sim.coupling.engine as engine_mod
    import xlotkit.sim.coupling.stepper as stepper_mod
    from xlotkit.sim.coupling.engine import MDEMEngine
    from xlotkit.sim.scene import scene_from_dict

    with open(scene_path, "rb") as f:
        data = tomllib.load(f)
    for k, v in (overrides or {}).items():
        data.setdefault(k, {}).update(v)

    calls: list[dict] = []          # Newton solves of the present engine trial
    flags = {"after_fail": False, "in_fold": 0, "after_bad": False}
    orig_newton = stepper_mod.newton
    orig_fail = stepper_mod.CoupledStepper._fail
    orig_fold = stepper_mod.CoupledStepper._fold_predictor
    orig_solve = stepper_mod.CoupledStepper._solve

    def newton(stepper, x, old, dt, undrained, st, max_it=None, probe=None):
        n = orig_newton(stepper, x, old, dt, undrained, st, max_it, probe)
        if flags["in_fold"]:
            kind = "fold"
        elif flags["after_bad"]:
            kind = "continuation"
        elif flags["after_fail"]:
            kind = "round"
        else:
            kind = "first"
        calls.append({"kind": kind, "its": n.iterations, "ok": n.ok, "reason": n.reason,
                      "early": bool(getattr(n, "early", False)),
                      "n_failed": int((st.cluster_state != 0).sum()),
                      "trace": [tuple(float(v) for v in tr) for tr in stepper.last_newton_trace]})
        if not flags["in_fold"]:
            flags["after_bad"] = not n.ok
            flags["after_fail"] = False
        return n

    def _fail(self, st, cand, *a, **k):
        flags["after_fail"] = True
        calls.append({"kind": "fail", "its": 0, "ok": True, "count": len(cand)})
        return orig_fail(self, st, cand, *a, **k)

    def _fold(self, *a, **k):
        flags["in_fold"] += 1
        try:
            return orig_fold(self, *a, **k)
        finally:
            flags["in_fold"] -= 1

    def _solve(self, *a, **k):
        flags.update(after_fail=False, after_bad=False)
        calls.append({"kind": "trial", "its": 0, "ok": True})
        return orig_solve(self, *a, **k)

    orig_from_scene = engine_mod.Stepping.from_scene

    def from_scene(scene):
        s = orig_from_scene(scene)
        return replace(s, newton=replace(s.newton, **(newton_control or {})),
                       time=replace(s.time, **(time_control or {})))

    engine_mod.Stepping.from_scene = staticmethod(from_scene)
    stepper_mod.newton = newton
    stepper_mod.CoupledStepper._fail = _fail
    stepper_mod.CoupledStepper._fold_predictor = _fold
    stepper_mod.CoupledStepper._solve = _solve
    try:
        eng = MDEMEngine(scene_from_dict(data))
        eng.start()
        trials = []
        t0, c0 = time.perf_counter(), time.process_time()
        while not eng.is_done():
            calls.clear()
            n_hist = len(eng.stepper.history)
            out = eng.step()
            hist = eng.stepper.history[n_hist:]
            if not calls:
                continue              # a phase start, no solve
            trials.append({"reason": out.reason, "success": out.success,
                           "calls": list(calls),
                           "stepper": [(h.success, h.reason, h.newton_iterations,
                                        h.new_failures, h.failure_rounds, h.dt)
                                       for h in hist]})
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        engine_mod.Stepping.from_scene = orig_from_scene
        stepper_mod.newton = orig_newton
        stepper_mod.CoupledStepper._fail = orig_fail
        stepper_mod.CoupledStepper._fold_predictor = orig_fold
        stepper_mod.CoupledStepper._solve = orig_solve
    res = eng.result()
    return {"trials": trials, "wall_s": wall, "cpu_s": cpu,
            "counters": vars(eng.stepper.counters).copy(), "status": res.status,
            "message": res.message, "truth": _truth(res)}


def _truth(res) -> dict:
    """FBP and realised sigma_h [bar] of the run (the issue's acceptance quantities)."""
    t = res.truth
    real = t.get("realised") or {}
    return {"fbp_bar": None if t.get("fbp") is None else float(t["fbp"]) / 1e5,
            "sigma_h_bar": None if "sigma_h" not in real else float(real["sigma_h"]) / 1e5}


def summarise(r: dict) -> str:
    trials = r["trials"]
    lines = []
    total = sum(c["its"] for t in trials for c in t["calls"])
    acc = [t for t in trials if t["success"]]
    lines.append(f"status {r['status']}: {r['message']}")
    lines.append(f"engine trials with a solve: {len(trials)}, accepted {len(acc)}; "
                 f"Newton iterations {total} (counter {r['counters']['newton_iterations']}); "
                 f"per accepted step {total / max(len(acc), 1):.2f}; CPU {r['cpu_s']:.1f} s; "
                 f"stepper steps {r['counters']['steps']} ({r['counters']['failed_steps']} cut); "
                 f"FBP {r['truth']['fbp_bar']} bar, "
                 f"realised sigma_h {r['truth']['sigma_h_bar']} bar")
    # trial outcome classes
    cls = collections.defaultdict(lambda: [0, 0])
    for t in trials:
        its = sum(c["its"] for c in t["calls"])
        if t["success"]:
            nf = sum(c.get("count", 0) for c in t["calls"] if c["kind"] == "fail")
            key = "accepted, no failures" if nf == 0 else "accepted, with failures"
        else:
            key = "not accepted: " + t["reason"].split(":", 1)[-1].strip()
        cls[key][0] += 1
        cls[key][1] += its
    lines.append("\n| trial class | trials | iterations | per trial |")
    lines.append("| --- | ---: | ---: | ---: |")
    for k, (n, i) in sorted(cls.items(), key=lambda kv: -kv[1][1]):
        lines.append(f"| {k} | {n} | {i} | {i / n:.2f} |")
    # solve kinds over all trials
    kinds = collections.defaultdict(lambda: [0, 0, 0])
    for t in trials:
        for c in t["calls"]:
            if c["kind"] in ("fail", "trial"):
                continue
            kinds[c["kind"]][0] += 1
            kinds[c["kind"]][1] += c["its"]
            kinds[c["kind"]][2] += 0 if c["ok"] else 1
    lines.append("\n| Newton solve kind | solves | iterations | per solve | failed solves |")
    lines.append("| --- | ---: | ---: | ---: | ---: |")
    for k, (n, i, f) in sorted(kinds.items(), key=lambda kv: -kv[1][1]):
        lines.append(f"| {k} | {n} | {i} | {i / n:.2f} | {f} |")
    # per-round profile of accepted trials with failures
    prof = collections.defaultdict(list)
    rounds_hist = collections.Counter()
    for t in acc:
        seq = [c for c in t["calls"] if c["kind"] in ("first", "round")]
        if any(c["kind"] == "fail" for c in t["calls"]):
            rounds_hist[len(seq)] += 1
            for i, c in enumerate(seq):
                prof[min(i, 5)].append(c["its"])
    lines.append("\naccepted trials with failures: solves per trial "
                 + ", ".join(f"{k}: {v}" for k, v in sorted(rounds_hist.items())))
    lines.append("| solve index in the trial | solves | mean iterations |")
    lines.append("| --- | ---: | ---: |")
    for i in sorted(prof):
        v = prof[i]
        lab = str(i) if i < 5 else ">= 5"
        lines.append(f"| {lab} | {len(v)} | {sum(v) / len(v):.2f} |")
    # histogram of iterations per accepted trial
    h = collections.Counter(sum(c["its"] for c in t["calls"]) for t in acc)
    lines.append("\nhistogram (iterations: accepted trials): "
                 + ", ".join(f"{k}: {v}" for k, v in sorted(h.items())))
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", type=Path, default=SCENE)
    ap.add_argument("--json", type=Path, default=None, help="write the raw trials here")
    ap.add_argument("--newton", default="{}",
                    help="JSON dict of CoupledControl fields (experiments), e.g. "
                         "'{\"failures_per_round\": 8}'")
    ap.add_argument("--time", default="{}", help="JSON dict of TimeStepControl fields")
    a = ap.parse_args()
    r = run(a.scene, newton_control=json.loads(a.newton), time_control=json.loads(a.time))
    print(summarise(r))
    if a.json:
        a.json.write_text(json.dumps(r, default=str))


if __name__ == "__main__":
    main()
