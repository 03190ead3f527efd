"""Regenerate the figures of docs/intervals.md (diagnostics and intervals on records with a
known truth, and on the AMS-01 field records).

Usage: ``.venv/bin/python docs/diagnostics/make_figures.py`` (about a minute). Writes PNGs
next to this script, overwriting the previous ones (they are documentation, regenerated
from code; the interpretation results of ``xlotkit pick`` are never overwritten).
"""

from __future__ import annotations

import tomllib
from pathlib import Path
import tempfile

import numpy as np
from matplotlib.figure import Figure

from xlotkit.interpret.calibration.records import (
    PRE_CLOSURE,
    ConstructedSpec,
    construct_record,
    dfit_record,
)
from xlotkit.interpret.diagnostics import diagnose_record
from xlotkit.interpret.diagnostics.gfunction import diagnose_g_function
from xlotkit.interpret.picks.core import pick_record
from xlotkit.interpret.picks.types import Pick
from xlotkit.interpret.plots.labels import LabelPlacer
from xlotkit.interpret.plots.picks import pick_figures

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
#: The AMS-01 field records, in the project's shared data next to the checkout (or a
#: worktree of it).
FIELD = next((d / "shared" / "data" / "field" / "AMS-01" for d in HERE.parents
              if (d / "shared" / "data" / "field" / "AMS-01").is_dir()), ROOT / "missing")


def save(fig, name: str) -> None:
    fig.savefig(HERE / f"{name}.png", dpi=100)
    print("wrote", name)


def signatures() -> None:
    """G dP/dG of the four constructed leak-off signatures, each with its line through the
    origin and the diagnosis the toolkit reads from it."""
    fig = Figure(figsize=(11, 7.5), layout="constrained")
    axes = fig.subplots(2, 2).ravel()
    placer = LabelPlacer()
    for ax, pre in zip(axes, PRE_CLOSURE):
        rec, seg, tr = dfit_record(pre=pre, after="exponential", duration=3.0, dt=2.0,
                                   noise=0.02e5)
        g = diagnose_g_function(rec, seg.cycles[0], Pick("FCP", "given", tr.sigma_h,
                                                          t=tr.t_closure))
        sel = g.G <= 1.3 * g.g_closure
        ax.plot(g.G[sel], g.g_dpdg[sel] / 1e5, color="tab:red", lw=1.2, label="G·dP/dG")
        gg = np.linspace(0, 1.3 * g.g_closure, 20)
        ax.plot(gg, g.m * gg / 1e5, "k--", lw=0.9, label="line through the origin, tangent at closure")
        ax.axvline(g.g_closure, color="tab:green", ls=":", label="closure (constructed)")
        ax.set_title(f"constructed: {pre.replace('_', ' ')}\ndiagnosed: {g.words}",
                     fontsize=9)
        ax.set_xlabel("G")
        ax.set_ylabel("G·dP/dG [bar]")
        placer.legend(ax, fontsize=7, prefer="upper left")
        ax.grid(alpha=0.3)
    placer.place(fig)
    save(fig, "g_signatures")


def dfit_radial() -> None:
    rec, seg, tr = dfit_record(pre="normal", after="radial", duration=30.0, dt=5.0,
                               noise=0.02e5)
    rp = pick_record(rec, seg)
    figs = pick_figures(rp, diagnose_record(rp))
    for k in ("cycle1_g_function", "cycle1_loglog", "cycle1_after_closure"):
        save(figs[k], f"dfit_radial_{k.split('_', 1)[1]}")


def dfit_linear() -> None:
    """A long DFIT-like shut-in (30 closure times) with linear flow after closure, closure
    picked by the toolkit."""
    rec, seg, tr = dfit_record(pre="normal", after="linear", duration=30.0, dt=5.0,
                               noise=0.02e5)
    rp = pick_record(rec, seg)
    figs = pick_figures(rp, diagnose_record(rp))
    for k in ("cycle1_g_function", "cycle1_after_closure"):
        save(figs[k], f"dfit_linear_{k.split('_', 1)[1]}")


def lumped_exponential() -> None:
    from xlotkit.sim.run import simulate
    from xlotkit.sim.scene import scene_from_dict

    d = tomllib.loads((ROOT / "examples" / "lumped_standard.toml").read_text())
    d["rock"]["wall_leak_index"] = 2e-10
    d["rock"]["leakoff_coefficient"] = 1e-4
    d["output"]["noise"] = "0.02 bar"
    d["output"]["dt"] = "2 s"
    ph = d["schedule"]["phase"][:6]
    ph[5]["duration"] = "120 min"
    ph[5].pop("pressure_below", None)
    d["schedule"]["phase"] = ph
    with tempfile.TemporaryDirectory() as tmp:
        sim = simulate(scene_from_dict(d), Path(tmp) / "run")
    rp = pick_record(sim.record)
    figs = pick_figures(rp, diagnose_record(rp))
    save(figs["cycle2_after_closure"], "lumped_after_closure")
    save(figs["overview"], "lumped_overview")


def gradual_flowback() -> None:
    cr = construct_record(ConstructedSpec(transition=0.02, noise=0.05e5,
                                          flowback=(True, False)))
    rp = pick_record(cr.record, cr.segmentation)
    figs = pick_figures(rp)
    save(figs["cycle1_flowback_p_v"], "constructed_flowback_p_v")
    save(figs["cycle1_flowback_sqrt_p"], "constructed_flowback_sqrt_p")


def field() -> None:
    from xlotkit.interpret.io import read_logs
    from xlotkit.pipeline import interpret_record

    files = sorted(FIELD.glob("XLOT 1*"))
    it = interpret_record(read_logs([str(f) for f in files]))
    figs = pick_figures(it.picks, it.diagnostics)
    for k in ("overview", "cycle1_g_function", "cycle1_loglog", "cycle1_sqrt_t",
              "cycle3_g_function"):
        save(figs[k], f"ams01_xlot1_{k}")


if __name__ == "__main__":
    signatures()
    dfit_radial()
    dfit_linear()
    lumped_exponential()
    gradual_flowback()
    if FIELD.is_dir():
        field()
