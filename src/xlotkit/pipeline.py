"""End-to-end jobs built from the library: interpret logs, turn picks into stresses, run the demo.

These functions are what the CLI calls; they hold no physics of their own. They compose
:mod:`xlotkit.interpret.io` (read), :mod:`xlotkit.interpret.phases` (segment),
:mod:`xlotkit.interpret.picks` (pick), :mod:`xlotkit.interpret.stress` (stress) and
:mod:`xlotkit.interpret.report` (write), and for the demo :mod:`xlotkit.sim.run` (the 2D
model) or :mod:`xlotkit.sim.lumped` (simulate).
Progress is reported through an optional callback ``progress(fraction, message)``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from xlotkit.atomic import atomic_write_text, fresh_output_dir
from xlotkit.errors import InputError
from xlotkit.interpret.estimate import StressInputs, StressSummary, estimate_stress
from xlotkit.interpret.stress import GRAVITY  # noqa: F401  (re-exported for the CLI)
from xlotkit.record import Record

__all__ = [
    "DemoResult",
    "StressInputs",
    "StressSummary",
    "estimate_stress",
    "interpret_record",
    "DEMO_MODELS",
    "new_output_dir",
    "run_demo",
]

_BAR = 1e5

Progress = Callable[[float, str], None]


# --------------------------------------------------------------------------- output folders
def new_output_dir(out: str | Path) -> Path:
    """A folder for new results that never holds earlier results.

    ``out`` itself when it does not exist or is empty; otherwise the first free sibling
    ``out-2``, ``out-3``, ... The folder is created exclusively, so two runs started at the
    same time cannot share one.
    """
    return fresh_output_dir(out)


# --------------------------------------------------------------------------- interpretation
@dataclass(frozen=True)
class Interpretation:
    """A record with its segmentation, picks and stress summary."""

    record: Record
    picks: Any
    stress: StressSummary
    diagnostics: Any = None


def interpret_record(record: Record, *, options=None,
                     stress_inputs: StressInputs | None = None) -> Interpretation:
    """Segment, pick, diagnose the shut-ins and estimate stress for one record."""
    from xlotkit.interpret.diagnostics import diagnose_record
    from xlotkit.interpret.phases import segment
    from xlotkit.interpret.picks.core import pick_record

    seg = segment(record)
    rp = pick_record(record, seg, options=options)
    diag = diagnose_record(rp)
    return Interpretation(record, rp, estimate_stress(rp, stress_inputs, diag), diag)


def write_interpretation(interp: Interpretation, out_dir: str | Path) -> dict[str, Path]:
    """Write the pick report (CSV, JSON, plots, ``report.pdf``), the record plot and the
    stress polygon.

    ``out_dir`` is used as given if empty or new, otherwise a fresh sibling is taken (see
    :func:`new_output_dir`): earlier results are never overwritten.
    """
    from xlotkit.interpret.plots.record import plot_record
    from xlotkit.interpret.report import write_pick_report

    target = new_output_dir(out_dir)
    extra = {}
    s = interp.stress
    if s.available and s.sigma_H and s.sv and s.pore_pressure is not None:
        from xlotkit.interpret.plots.stress import plot_stress_polygon

        est = s.estimates if s.estimates is not None else (s.sigma_h,
                                                           next(iter(s.sigma_H.values()))["value"])
        extra["stress_polygon"] = plot_stress_polygon(s.sv, s.pore_pressure, s.mu, est)
    paths = write_pick_report(interp.picks, target, stress=s.to_dict(), if_exists="error",
                              diagnostics=interp.diagnostics, pdf=True, extra_figures=extra)
    paths["record"] = target / "record.png"
    plot_record(interp.record, interp.picks.segmentation, path=paths["record"])
    return paths


# --------------------------------------------------------------------------- demo
@dataclass(frozen=True)
class DemoResult:
    """What the demo produced.

    Attributes
    ----------
    out_dir : Path
    log_path : Path
        The synthetic field log (CSV) the interpretation read.
    paths : dict of str to Path
        Every file written.
    truth : dict
        Imposed sigma_h, sigma_H, T0, p0, the model's FBP and (2D model) its realised
        ``sigma_h_realised`` [Pa].
    interpretation : Interpretation
    summary : str
        The text report.
    """

    out_dir: Path
    log_path: Path
    paths: dict
    truth: dict
    interpretation: Interpretation
    summary: str


DEMO_MODELS = ("2d", "lumped")


def run_demo(out_dir: str | Path, *, model: str = "2d", seed: int = 0,
             noise_bar: float = 0.05, progress: Progress | None = None,
             scene: Any = None, started: Callable[[Path], None] | None = None) -> DemoResult:
    """Simulate a two-cycle XLOT, write it as a field log, read it back, pick, report.

    ``model="2d"`` (default) simulates the standard 2D scene
    (:func:`xlotkit.sim.scene.standard_2d_scene`, ``examples/scene_2d_standard.toml``: the
    2D MDEM model with the 2000 m well's storage on the bottom-hole pressure) with
    :func:`xlotkit.sim.run.simulate` into ``simulation/`` and interprets the synthetic log
    it wrote there. ``model="lumped"`` uses the lumped model
    (:func:`xlotkit.sim.lumped.standard_lumped_scene`) instead, in about a second. Gauge
    noise of ``noise_bar`` (standard deviation) and 0.01 bar resolution at 1 s sampling
    either way. The log goes through the same reader and picks as a field record; the
    report compares every closure pick with the model's sigma_h (for the 2D model the
    *realised* one, the in-situ stress normal to the crack over its extent; see
    :meth:`xlotkit.sim.coupling.engine.MDEMEngine.result`) and the pressurisation slope
    with ``Q / C_total``.

    Parameters
    ----------
    out_dir : str or Path
        Results folder (a fresh sibling is used if it already holds results).
    model : {"2d", "lumped"}
    seed : int
        Seed of the gauge noise.
    noise_bar : float
        Gauge noise standard deviation [bar].
    progress : callable, optional
        ``progress(fraction, message)``.
    scene : Scene, optional
        A 2D scene to run instead of the standard one (its noise and seed are replaced
        by ``noise_bar`` and ``seed``); used by tests for a short variant.
    started : callable, optional
        ``started(folder)`` with the results folder (``out_dir`` or a fresh sibling)
        before the simulation starts.

    Returns
    -------
    DemoResult
    """
    from xlotkit.interpret.io import read_log
    from xlotkit.logfile import write_log

    if model not in DEMO_MODELS:
        raise InputError(f"unknown demo model {model!r}", key="model",
                         expected=" or ".join(repr(m) for m in DEMO_MODELS))

    def report(f: float, msg: str) -> None:
        if progress is not None:
            progress(f, msg)

    target = new_output_dir(out_dir)
    if started is not None:
        started(target)
    if model == "lumped":
        from xlotkit.sim.lumped import simulate_lumped, standard_lumped_scene

        lscene = standard_lumped_scene(noise=noise_bar * _BAR, resolution=0.01 * _BAR,
                                       seed=seed, start_time=datetime(2026, 1, 1, 8, 0, 0))
        result = simulate_lumped(lscene, progress=lambda f: report(0.6 * f, "simulating"))
        if result.status != "ok":
            raise InputError(f"the demo simulation did not finish: {result.message}",
                             key="demo")
        log_path = target / "synthetic_xlot.csv"
        write_log(result.record, log_path)
        truth = {k: result.truth[k] for k in ("sigma_h", "sigma_H", "pore_pressure",
                                              "tensile_strength", "fbp") if k in result.truth}
        sim_label = "lumped model"
        sim_message = result.message
        extra: dict[str, Any] = {}
    else:
        sim, sc = _simulate_2d(target, scene, seed, noise_bar,
                               lambda f, msg: report(0.8 * f, msg))
        log_path = sim.paths["log"]
        truth = _truth_2d(sim)
        sim_label = "2D MDEM model"
        sim_message = sim.message
        extra = {"simulation_dir": str(sim.paths["dir"]),
                 "simulation_wall_time_s": round(sim.wall_time, 2),
                 "pressurisation": _pressurisation_check(sim, sc)}
    report(0.82, "interpreting")
    record = read_log(log_path)
    interp = interpret_record(record)
    report(0.88, "writing report")
    paths = write_interpretation(interp, target / "interpretation")
    paths["log"] = log_path
    ref = truth.get("sigma_h_realised", truth["sigma_h"])
    summary = demo_summary(interp, truth, sim_message, model=sim_label,
                           pressurisation=extra.get("pressurisation"))
    paths["report"] = target / "report.md"
    atomic_write_text(paths["report"], summary)
    paths["summary_json"] = target / "summary.json"
    atomic_write_text(paths["summary_json"], json.dumps(
        {"model": model,
         "truth_bar": {k: v / _BAR for k, v in truth.items()},
         "fcp_reference": "sigma_h_realised" if "sigma_h_realised" in truth else "sigma_h",
         "fcp_error_percent": _fcp_errors(interp, ref),
         "stress": interp.stress.to_dict(),
         "simulation": sim_message, **extra}, indent=2, allow_nan=False) + "\n")
    report(1.0, "done")
    return DemoResult(target, log_path, paths, truth, interp, summary)


def _simulate_2d(target: Path, scene: Any, seed: int, noise_bar: float,
                 progress: Progress):
    """Run the (standard) 2D scene into ``target / "simulation"``."""
    from dataclasses import replace

    from xlotkit.sim.run import simulate
    from xlotkit.sim.scene import standard_2d_scene

    sc = standard_2d_scene() if scene is None else scene
    sc = replace(sc.with_seed(seed),
                 output=replace(sc.output, noise=noise_bar * _BAR, seed=None))
    sim = simulate(sc, target / "simulation",
                   progress=lambda f, msg: progress(f, f"simulating (2D), {msg}"))
    if sim.status != "ok":
        raise InputError(f"the demo simulation did not finish: {sim.message}", key="demo")
    return sim, sc


def _truth_2d(sim) -> dict[str, float]:
    """Imposed stresses and strength, the model's FBP and its realised sigma_h [Pa]."""
    imposed = sim.truth["imposed"]
    truth = {k: float(imposed[k]) for k in ("sigma_h", "sigma_H", "pore_pressure",
                                            "tensile_strength")}
    if sim.truth.get("fbp") is not None:
        truth["fbp"] = float(sim.truth["fbp"])
    realised = sim.truth.get("realised", {})
    if "sigma_h" in realised and realised["sigma_h"] != imposed["sigma_h"]:
        truth["sigma_h_realised"] = float(realised["sigma_h"])
    return truth


def _pressurisation_check(sim, sc) -> dict[str, float]:
    """The first pump-in's pressure slope against ``Q / C_total``.

    ``C_total`` is the whole well's compliance on the bottom-hole pressure (the engine's
    ``well_compliance``) plus the open hole's elastic enlargement in plane strain,
    ``2 pi a^2 h (1 + nu) / E``. The slope is fitted to the bottom-hole pressure of the
    clean record from 10 s after the pump starts to 10 s before the first cluster fails
    (or the pump stops).
    """

    truth = sim.truth
    pump = next(p for p in truth["phases"] if p["kind"] == "pump")
    t0, t1 = float(pump["t_start"]), float(pump["t_end"])
    if truth.get("initiation_time") is not None:
        t1 = min(t1, float(truth["initiation_time"]))
    rec = sim.clean_record
    sel = (rec.t >= t0 + 10.0) & (rec.t <= t1 - 10.0)
    slope = float(np.polyfit(rec.t[sel], rec.pressure[sel], 1)[0])
    ph = next(p for _, p in sc.schedule.expanded() if p.pumps)
    q = float(ph.pump_rate(0.0))
    g, rk = sc.geometry, sc.rock
    hole = (2.0 * math.pi * g.hole_radius ** 2 * g.segment_height * (1.0 + rk.poisson_ratio)
            / rk.youngs_modulus)
    c_total = float(truth["well_compliance"]) + hole
    expected = q / c_total
    return {"slope_bar_per_s": slope / _BAR, "q_over_c_total_bar_per_s": expected / _BAR,
            "c_total_l_per_mpa": c_total * 1e9, "error_percent": 100.0 * (slope - expected)
            / expected}


def _fcp_errors(interp: Interpretation, sigma_h: float) -> dict[str, dict[str, float | None]]:
    """Relative error [%] of every FCP pick of every test cycle against ``sigma_h``."""
    out: dict[str, dict[str, float | None]] = {}
    for c in interp.picks.test_cycles:
        row: dict[str, float | None] = {}
        for m, p in {**c.fcp_methods(), "consensus": c.fcp}.items():
            row[m] = None if not p.found else round(100.0 * (p.value - sigma_h) / sigma_h, 3)
        out[f"cycle {c.index}"] = row
    return out


def demo_summary(interp: Interpretation, truth: dict, sim_message: str,
                 model: str = "lumped model", pressurisation: dict | None = None) -> str:
    """One-page markdown report of the demo: truth vs picks.

    Closure picks are compared with ``truth["sigma_h_realised"]`` when the model reports
    one (the 2D model: the in-situ stress normal to the crack over its extent), else with
    the imposed ``sigma_h``.
    """
    sh_imp = truth["sigma_h"]
    sh = truth.get("sigma_h_realised", sh_imp)
    ref = "realised sigma_h" if "sigma_h_realised" in truth else "sigma_h"
    lines = [
        "# xlotkit demo: a synthetic XLOT simulated, interpreted and checked",
        "",
        f"Simulation ({model}): {sim_message}.",
        f"Imposed: sigma_h = {sh_imp / _BAR:.2f} bar, sigma_H = {truth['sigma_H'] / _BAR:.2f} "
        f"bar, p0 = {truth['pore_pressure'] / _BAR:.2f} bar, T0 = "
        f"{truth['tensile_strength'] / _BAR:.2f} bar; model breakdown at "
        f"{truth.get('fbp', float('nan')) / _BAR:.2f} bar (bottom hole).",
    ]
    if "sigma_h_realised" in truth:
        lines.append(f"Realised by the model: sigma_h = {sh / _BAR:.2f} bar (the in-situ stress "
                     "normal to the crack's plane, averaged over the crack; the closure picks "
                     "are checked against it).")
    if pressurisation:
        pz = pressurisation
        lines.append(f"Pressurisation: {pz['slope_bar_per_s']:.4f} bar/s against Q / C_total = "
                     f"{pz['q_over_c_total_bar_per_s']:.4f} bar/s (C_total "
                     f"{pz['c_total_l_per_mpa']:.1f} l/MPa): {pz['error_percent']:+.2f} %.")
    lines += [
        "",
        f"| cycle | method | FCP [bar] | interval [bar] | error vs {ref} | quality |",
        "|---|---|---|---|---|---|",
    ]
    for c in interp.picks.test_cycles:
        for m, p in {**c.fcp_methods(), "consensus": c.fcp}.items():
            if p.found:
                lo = p.low if p.low is not None else p.value
                hi = p.high if p.high is not None else p.value
                err = 100.0 * (p.value - sh) / sh
                lines.append(f"| {c.index} | {m} | {p.value / _BAR:.2f} | "
                             f"{lo / _BAR:.2f} – {hi / _BAR:.2f} | {err:+.2f} % | {p.quality} |")
            else:
                lines.append(f"| {c.index} | {m} | – | – | – | {p.message[:60]} |")
    lines += ["", "| cycle | LOP | FBP | Pr | FPP | ISIP |", "|---|---|---|---|---|---|"]
    for c in interp.picks.test_cycles:
        cells = []
        for name in ("LOP", "FBP", "Pr", "FPP", "ISIP"):
            p = c.get(name)
            cells.append(f"{p.value / _BAR:.2f}" if p is not None and p.found else "–")
        lines.append(f"| {c.index} | " + " | ".join(cells) + " |")
    s = interp.stress
    lines += ["", "## Stress"]
    if s.available:
        lines.append(f"sigma_h = {s.sigma_h / _BAR:.2f} bar "
                     f"({s.sigma_h_low / _BAR:.2f} – {s.sigma_h_high / _BAR:.2f}) from cycle(s) "
                     f"{', '.join(str(c) for c in s.source_cycles)}; {ref} {sh / _BAR:.2f} bar "
                     f"({100 * (s.sigma_h - sh) / sh:+.2f} %).")
        if s.t0 is not None:
            lines.append(f"T0 = FBP − Pr = {s.t0 / _BAR:.2f} bar "
                         f"(imposed {truth['tensile_strength'] / _BAR:.2f} bar).")
        for eq, v in s.sigma_H.items():
            lines.append(f"sigma_H (Eq. {eq}) = {v['value'] / _BAR:.2f} bar "
                         f"({v['low'] / _BAR:.2f} – {v['high'] / _BAR:.2f}); imposed "
                         f"{truth['sigma_H'] / _BAR:.2f} bar. {v['message']}")
        if s.regime:
            lines.append(f"Faulting regime (mu = {s.mu}): {s.regime}.")
        for a in s.assumptions:
            lines.append(f"* assumed: {a}")
        for o in s.omitted:
            lines.append(f"* not estimated: {o}")
    else:
        lines.append(s.message)
    lines += ["", "Plots: `interpretation/*.png`. Picks: `interpretation/picks.csv`, "
              "`interpretation/picks.json`.", ""]
    return "\n".join(lines)
