"""Calibration of the pick intervals: how often a nominal-90 % interval contains the truth.

Draws constructed records with a known truth (:mod:`xlotkit.interpret.calibration.records`:
random closure pressure, closure transitions from 0.2 % to 5 % of sigma_h, gauge noise,
sample intervals of 1-10 s, bottom-hole gauges and surface gauges quantised to 1 bar,
four leak-off models, closure on the shut-in or on a choke flowback), picks them with the
toolkit (:func:`xlotkit.interpret.picks.core.pick_record`) and reports, per quantity and
method, the cases (truths the data hold: a closure only where the recorded decline goes
through it), the found rate, the coverage of the stated intervals among the picks found and
over all cases (a case without a pick counts as a miss), and their median width; and the
consensus closure's found rate by factor (closure contrast, gauge, leak-off model, phase).

Usage::

    .venv/bin/python benchmarks/interval_calibration.py [--n 300] [--seed 2024] [--out docs]
        [--jobs 2]

Writes ``OUT/intervals-table.md`` (the table pasted into ``docs/intervals.md``),
``OUT/intervals-coverage.png`` (coverage against width: each interval scaled about its
value by a factor from 0.25 to 3, so the stated interval is the point at factor 1) and
with ``--outcomes FILE`` every pick against its truth as JSON. Deterministic for a seed,
whatever ``--jobs`` (the records are drawn in order in the main process; only their
evaluation runs in parallel).
Existing files are not overwritten (a numbered sibling name is used instead).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from xlotkit.interpret.calibration.records import construct_record, draw_spec
from xlotkit.interpret.calibration.study import StudyResult, evaluate_record, run_study

_BAR = 1e5
#: Quantities and methods drawn in the figure.
CURVES = (("FCP", "consensus"), ("FCP", "flowback_sqrt_p"), ("FCP", "flowback_p_v"),
          ("FCP", "g_function"), ("FCP", "sqrt_t"), ("FCP", "tangent"),
          ("FCP", "compliance"), ("FCP", "bilinear"), ("ISIP", "tangent"),
          ("LOP", "departure"), ("FBP", "max"), ("Pr", "departure"), ("T0", "FBP-Pr"))
#: Each curve in words (the figure's legend).
WORDS = {("FCP", "consensus"): "closure, consensus of the methods",
         ("FCP", "flowback_sqrt_p"): "closure, flowback √p against time",
         ("FCP", "flowback_p_v"): "closure, flowback pressure against returned volume",
         ("FCP", "g_function"): "closure, G-function",
         ("FCP", "sqrt_t"): "closure, square root of time",
         ("FCP", "tangent"): "closure, tangents on pressure-time",
         ("FCP", "compliance"): "closure, compliance (stiffness rise)",
         ("FCP", "bilinear"): "closure, bilinear decay rate against pressure",
         ("ISIP", "tangent"): "ISIP, early-decline line",
         ("LOP", "departure"): "leak-off pressure (no level stated)",
         ("FBP", "max"): "breakdown pressure FBP",
         ("Pr", "departure"): "reopening pressure Pr",
         ("T0", "FBP-Pr"): "tensile strength T0 = FBP − Pr"}
#: Breakdowns of the consensus closure's found rate: factor and bin edges (None: values).
BREAKDOWNS = (("closure_contrast", (0.9, 1.1, 1.3, 1.6, 2.5)), ("gauge", None),
              ("leakoff", None), ("closure_phase", None), ("dt", None))


def _evaluate(args):
    i, sp = args
    return evaluate_record(construct_record(sp), i)


def run_parallel(n: int, seed: int, jobs: int, progress) -> StudyResult:
    """:func:`run_study` with the records evaluated by ``jobs`` processes (the same
    records and numbers: the specs are drawn in order first)."""
    from concurrent.futures import ProcessPoolExecutor

    rng = np.random.default_rng(seed)
    specs = [(i, draw_spec(rng)) for i in range(n)]
    outcomes = []
    with ProcessPoolExecutor(jobs) as ex:
        for out in ex.map(_evaluate, specs, chunksize=1):
            outcomes.extend(out)
            progress()
    return StudyResult(n, seed, tuple(outcomes))


def _free(path: Path) -> Path:
    """``path`` if it does not exist, else ``stem-2.suffix``, ``stem-3.suffix``, ..."""
    if not path.exists():
        return path
    k = 2
    while True:
        cand = path.with_name(f"{path.stem}-{k}{path.suffix}")
        if not cand.exists():
            return cand
        k += 1


def _finite(x):
    """JSON-ready: numbers as float (NaN as None), bools and text as they are."""
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, float, np.floating, np.integer)):
        return float(x) if math.isfinite(float(x)) else None
    return x


def coverage_curve(res: StudyResult, quantity: str, method: str,
                   factors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coverage and median relative width [%] of the intervals scaled about the value."""
    found = [o for o in res.select(quantity, method) if o.found]
    if not found:
        return np.full(factors.size, np.nan), np.full(factors.size, np.nan)
    v = np.array([o.value for o in found])
    lo = np.array([o.low for o in found])
    hi = np.array([o.high for o in found])
    tr = np.array([o.truth for o in found])
    sc = np.array([o.scale for o in found])
    cov, wid = [], []
    for f in factors:
        a, b = v - f * (v - lo), v + f * (hi - v)
        cov.append(float(np.mean((a <= tr) & (tr <= b))))
        wid.append(float(np.median((b - a) / sc)) * 100.0)
    return np.array(cov), np.array(wid)


def figure(res: StudyResult, path: Path) -> None:
    """Coverage against median relative width for every quantity/method: filled dots the
    stated interval over the picks found, open dots the same over all cases."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from xlotkit.interpret.plots.labels import LabelPlacer

    factors = np.concatenate([np.linspace(0.25, 1.0, 7), np.linspace(1.25, 3.0, 8)])
    rows = {(r.quantity, r.method): r for r in res.summary()}
    fig = Figure(figsize=(11.0, 7.5), layout="constrained")
    ax = fig.subplots()
    cmap = __import__("matplotlib").colormaps["tab20"]
    handles, labels = [], []
    for k, (q, m) in enumerate(CURVES):
        cov, wid = coverage_curve(res, q, m, factors)
        if not np.any(np.isfinite(cov)):
            continue
        n = len([o for o in res.select(q, m) if o.found])
        col = cmap(k % 20)
        lw = 2.4 if m == "consensus" else 1.2
        (h,) = ax.plot(wid, 100 * cov, "-", color=col, lw=lw)
        handles.append(h)
        labels.append(f"{WORDS.get((q, m), q + ' ' + m)} (n={n})")
        i1 = int(np.argmin(np.abs(factors - 1.0)))
        ax.plot(wid[i1], 100 * cov[i1], "o", color=col, ms=7, mec="k")
        row = rows.get((q, m))
        if row is not None and np.isfinite(row.coverage_all):
            # The same interval over all cases, a case without a pick a miss.
            ax.plot(wid[i1], 100 * row.coverage_all, "o", color=col, ms=6, mfc="none",
                    mew=1.4)
    h90 = ax.axhline(90, color="k", ls="--", lw=1)
    h85 = ax.axhline(85, color="tab:red", ls=":", lw=1)
    handles += [h90, h85, Line2D([], [], ls="none", marker="o", color="0.5", mec="k", ms=7),
                Line2D([], [], ls="none", marker="o", color="0.5", mfc="none", ms=6)]
    labels += ["nominal level 90 %", "required 85 %",
               "stated interval, over the picks found",
               "stated interval, over all cases (no pick = miss)"]
    ax.set_xscale("log")
    ax.set_xlabel("median interval width [% of sigma_h; T0: % of T0]")
    ax.set_ylabel("intervals containing the truth [%]")
    ax.set_ylim(0, 101)
    ax.set_title(f"Calibration on {res.n_records} constructed records (seed {res.seed}): each "
                 "interval scaled about its value by 0.25-3", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    placer = LabelPlacer()
    placer.legend(ax, handles, labels, fontsize=7, prefer="lower right", ncol=2)
    placer.place(fig)
    fig.savefig(path, dpi=110)


def breakdown(res: StudyResult) -> str:
    """Markdown: the consensus closure's found rate and coverage over all cases, by
    factor."""
    out = []
    for factor, bins in BREAKDOWNS:
        out.append(f"| {factor.replace('_', ' ')} | cases | found | found rate | "
                   "coverage over all cases |")
        out.append("|---|---|---|---|---|")
        for lab, n, f, c in res.found_rate_by("FCP", "consensus", factor, bins):
            out.append(f"| {lab} | {n} | {f} | {100 * f / n:.1f} % | {100 * c / n:.1f} % |")
        out.append("")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=300, help="number of records (default 300)")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--out", type=Path, default=Path("docs"))
    ap.add_argument("--outcomes", type=Path, default=None,
                    help="also write every pick against its truth to this JSON file")
    ap.add_argument("--jobs", type=int, default=1,
                    help="processes evaluating the records (default 1)")
    args = ap.parse_args(argv)
    from tqdm import tqdm

    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    bar = tqdm(total=args.n, desc="records", unit="rec")
    if args.jobs > 1:
        res = run_parallel(args.n, args.seed, args.jobs, lambda: bar.update(1))
    else:
        res = run_study(args.n, seed=args.seed, progress=lambda i, n: bar.update(1))
    bar.close()
    wall = time.perf_counter() - t0
    table = res.to_markdown() + "\n\nConsensus closure by factor:\n\n" + breakdown(res)
    head = (f"{args.n} constructed records, seed {args.seed}, "
            f"{wall:.0f} s wall time ({wall / args.n:.2f} s per record)\n\n")
    p_tab = _free(args.out / "intervals-table.md")
    p_tab.write_text(head + table + "\n")
    p_fig = _free(args.out / "intervals-coverage.png")
    figure(res, p_fig)
    written = [p_tab, p_fig]
    if args.outcomes is None:
        print(head + table)
        print("wrote " + ", ".join(map(str, written)))
        return 0
    p_json = _free(args.outcomes)
    p_json.write_text(json.dumps(
        [{"record": o.record, "cycle": o.cycle, "quantity": o.quantity, "method": o.method,
          "truth_bar": o.truth / _BAR,
          "value_bar": None if o.value is None else o.value / _BAR,
          "low_bar": None if o.low is None else o.low / _BAR,
          "high_bar": None if o.high is None else o.high / _BAR,
          "level": o.level, "case": o.case, "covered": o.covered,
          "factors": {k: _finite(v) for k, v in o.factors.items()}}
         for o in res.outcomes], indent=1, allow_nan=False))
    print(head + table)
    print(f"wrote {p_tab}, {p_fig}, {p_json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
