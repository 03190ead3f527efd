"""Regenerate the AMS-01 field interpretation shown in docs/field/AMS-01.md.

Run from the repository root with the shared data beside it::

    .venv/bin/python docs/field/make_ams01.py

It runs the same code as ``xlotkit pick`` (no hand settings) on each surface + downhole pair
and on each surface record alone, copies a few of the plots into ``docs/field/AMS-01/`` and
writes the tables to ``docs/field/AMS-01/tables.md`` (included by hand in AMS-01.md).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / ".." / "shared" / "data" / "field" / "AMS-01"
if not DATA.is_dir():  # a worktree one level deeper than the main checkout
    DATA = Path("/work/shared/data/field/AMS-01")
OUT = ROOT / "docs" / "field" / "AMS-01"


def _fmt(p) -> str:
    if p is None or not p.found:
        return "–"
    lo = p.low if p.low is not None else p.value
    hi = p.high if p.high is not None else p.value
    return f"{p.value / 1e5:.1f} [{lo / 1e5:.1f}–{hi / 1e5:.1f}] {p.quality}"


def main() -> int:
    from xlotkit.interpret.io import read_log, read_logs
    from xlotkit.pipeline import interpret_record, write_interpretation

    OUT.mkdir(parents=True, exist_ok=True)
    for old in OUT.glob("*.png"):  # this folder only holds this script's output
        old.unlink()
    cases = []
    for test in ("XLOT 1", "XLOT 2"):
        files = sorted(DATA.glob(f"{test}*"))
        surf = [f for f in files if "Cementing" in f.name][0]
        tag = test.replace(" ", "").lower()
        fb = "cycle1_flowback_sqrt_p" if test == "XLOT 1" else "cycle3_flowback_sqrt_p"
        cases.append((f"{test} merged (downhole gauge)", tag + "_merged",
                      lambda fs=files: read_logs([str(f) for f in fs]),
                      ("overview", "cycle1_g_function", "cycle2_g_function", "cycle1_sqrt_t",
                       fb)))
        cases.append((f"{test} surface only", tag + "_surface",
                      lambda s=surf: read_log(str(s)), ("overview",)))
    lines = []
    methods = ("tangent", "sqrt_t", "g_function", "bilinear", "compliance",
               "flowback_sqrt_p", "flowback_p_v")
    for title, tag, load, keep in cases:
        rec = load()
        interp = interpret_record(rec)
        rp = interp.picks
        lines += [f"### {title}", "", f"Pressure reference: {rec.reference.describe()}.", ""]
        if "clock_offset_s" in rec.meta:
            lines += [f"Clock offset (surface − downhole): {rec.meta['clock_offset_s']:.1f} s.", ""]
        lines += ["| cycle | kind | LOP | FBP | Pr | ISIP | consensus FCP | "
                  + " | ".join(methods) + " |",
                  "|" + "---|" * (6 + len(methods))]
        for c in rp.test_cycles:
            row = [str(c.index), c.kind] + [_fmt(c.get(n)) for n in ("LOP", "FBP", "Pr", "ISIP")]
            row.append(_fmt(c.fcp))
            fm = c.fcp_methods()
            row += [_fmt(fm.get(m)) for m in methods]
            lines.append("| " + " | ".join(row) + " |")
        rejected = []
        for c in rp.test_cycles:
            seen = set()
            for m in methods[:5]:
                d = c.get("FCP", m).details
                for r in getattr(d, "rejected", ()):
                    if (r.t, r.pressure) not in seen:
                        seen.add((r.t, r.pressure))
                        rejected.append(f"cycle {c.index}: {r.describe()}")
            z = getattr(c.get("FCP", "sqrt_t").details, "boundary", None)
            if z is not None and z.onset != "sample margin":
                rejected.append(f"cycle {c.index}: boundary zone {z.describe()}")
        if rejected:
            lines += ["", "Closure candidates rejected and boundary zones:", ""]
            lines += [f"* {x}" for x in rejected]
        a = rp.consistency.closure
        if a is not None and a.found:
            lines += ["", f"Closure of the record: {a.value / 1e5:.1f} bar "
                          f"[{a.low / 1e5:.1f}–{a.high / 1e5:.1f}]: {a.message}."]
            lines += [f"* outlier {why}" for _, why in a.outliers]
        s = interp.stress.to_dict()
        if s["available"]:
            lines += ["", f"σh at {s['target_tvd_m']:g} m: {s['sigma_h_bar']} bar "
                          f"[{s['sigma_h_low_bar']}–{s['sigma_h_high_bar']}] "
                          f"({s['sigma_h_emw_sg']} sg), from cycles "
                          f"{', '.join(str(c) for c in s['source_cycles'])}; "
                          "assumed: " + "; ".join(s["assumptions"]) + "."]
        else:
            lines += ["", f"Stress: {s['message']}."]
        lines.append("")
        with tempfile.TemporaryDirectory() as tmp:
            paths = write_interpretation(interp, Path(tmp) / "r")
            for key, p in paths.items():
                if key in ("csv", "json", "dir"):
                    continue
                if key in keep:
                    shutil.copy(p, OUT / f"{tag}_{Path(p).name}")
    (OUT / "tables.md").write_text("\n".join(lines) + "\n")
    print((OUT / "tables.md").read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
