"""Quick loop on the closure picks: found rate, coverage, and false finds without closure.

Draws ``--n`` records of the calibration distribution
(:func:`xlotkit.interpret.calibration.records.draw_spec`, the draw of
``benchmarks/interval_calibration.py`` for the same seed) and ``--n-none`` records of the
same distribution whose declines hold **no closure** (``closure=False``: a
single-compliance decline), picks them (:func:`xlotkit.interpret.calibration.study.
evaluate_record`) and reports for the consensus closure and each closure method:

* found rate on the cases, coverage of the picks found, coverage over all cases (a case
  without a pick is a miss), median width;
* the **false-find rate**: closure picks made on the no-closure declines, per decline
  (each record has two, one per cycle);

and, with ``--misses``, every missed consensus case with its factors (closure contrast,
gauge, leak-off model, phase, sample interval) for diagnosis.

Usage::

    .venv/bin/python benchmarks/closure_found_rate.py [--n 80] [--n-none 40] [--seed 7]
        [--jobs 2] [--misses]

Deterministic for a seed (the records are drawn in order in the main process and only
evaluated in parallel).
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from xlotkit.interpret.calibration.records import construct_record, draw_spec
from xlotkit.interpret.calibration.study import StudyResult, evaluate_record

_BAR = 1e5


def _evaluate(args):
    i, sp = args
    return evaluate_record(construct_record(sp), i)


def draw(n: int, seed: int, closure: bool, jobs: int) -> StudyResult:
    """``n`` records of the calibration draw (``closure=False``: no closure), evaluated."""
    rng = np.random.default_rng(seed)
    specs = [(i, draw_spec(rng, closure=closure)) for i in range(n)]
    if jobs > 1:
        with ProcessPoolExecutor(jobs) as ex:
            outs = list(ex.map(_evaluate, specs, chunksize=1))
    else:
        outs = [_evaluate(a) for a in specs]
    return StudyResult(n, seed, tuple(o for out in outs for o in out))


def closure_rows(res: StudyResult, res_none: StudyResult | None) -> str:
    """Markdown: per closure method, the found rate, coverages, median width and the
    false-find rate on the no-closure declines."""
    lines = [("| method | cases | found rate | coverage of found | coverage over all | "
              "median width [bar] | false finds (no closure) |"), "|---|---|---|---|---|---|---|"]
    rows = [r for r in res.summary() if r.quantity == "FCP"]
    for r in rows:
        ff = "–"
        if res_none is not None:
            sel = res_none.select("FCP", r.method)
            n_decl = len(res_none.select("FCP", "consensus"))
            k = sum(o.found for o in sel)
            ff = f"{k}/{n_decl} ({100 * k / max(n_decl, 1):.1f} %)"
        lines.append(f"| {r.method} | {r.n_cases} | {100 * r.found_rate:.1f} % | "
                     f"{100 * r.coverage:.1f} % | {100 * r.coverage_all:.1f} % | "
                     f"{r.median_width / _BAR:.2f} | {ff} |")
    return "\n".join(lines)


def misses(res: StudyResult) -> str:
    """Every consensus case without a pick, with its factors."""
    out = ["record cycle contrast gauge leakoff phase dt noise_bar transition"]
    for o in res.select("FCP", "consensus"):
        if o.case and not o.found:
            f = o.factors
            out.append(f"{o.record:4d} {o.cycle} {f['closure_contrast']:6.2f} {f['gauge']:10s} "
                       f"{f['leakoff']:18s} {f['closure_phase']:8s} {f['dt']:4.0f} "
                       f"{f['noise_bar']:.3f} {f['transition']:.4f}")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=80)
    ap.add_argument("--n-none", type=int, default=40)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--misses", action="store_true")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    res = draw(args.n, args.seed, True, args.jobs)
    res_none = draw(args.n_none, args.seed + 1, False, args.jobs) if args.n_none else None
    print(f"{args.n} records (seed {args.seed}), {args.n_none} without closure "
          f"(seed {args.seed + 1}), {time.perf_counter() - t0:.0f} s\n")
    print(closure_rows(res, res_none))
    if args.misses:
        print()
        print(misses(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
