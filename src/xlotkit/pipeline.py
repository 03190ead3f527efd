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
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from xlotkit.atomic import atomic_write_text, fresh_output_dir
from xlotkit.errors import InputError
from xlotkit.interpret.stress import GRAVITY
from xlotkit.record import ATMOSPHERE_PA, Record

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


# --------------------------------------------------------------------------- stress
@dataclass(frozen=True)
class StressInputs:
    """What an interpretation needs beyond the log to turn pressures into stresses.

    Parameters
    ----------
    target_tvd : float, optional
        True vertical depth of the open hole [m]. Default: the depth of the pressure
        reference (a bottom-hole or downhole record); required for a surface record.
    gauge_tvd : float, optional
        TVD of the gauge [m]; default 0 for a surface gauge, the target depth for a
        bottom-hole record and the reference depth (vertical well) for a downhole gauge.
    mud_density : float, optional
        Well-fluid density [kg/m^3]; default: the median of the record's density series, else
        1000 kg/m^3 (stated in the assumptions).
    pore_pressure : float, optional
        Formation pore pressure at target depth [Pa]; default hydrostatic with 1030 kg/m^3.
    sv : float, optional
        Vertical stress at target depth [Pa]; default 22.6 kPa/m (2.3 sg) times the depth.
    mu : float
        Friction coefficient for the stress polygon.
    """

    target_tvd: float | None = None
    gauge_tvd: float | None = None
    mud_density: float | None = None
    pore_pressure: float | None = None
    sv: float | None = None
    mu: float = 0.6

    def __post_init__(self) -> None:
        for key in ("target_tvd", "gauge_tvd", "mud_density", "pore_pressure", "sv"):
            v = getattr(self, key)
            if v is not None and not (math.isfinite(v) and v >= 0):
                raise InputError(f"{v!r} is not a non-negative number", key=key,
                                 expected="a finite value >= 0")
        if not (0.0 < self.mu < 2.0):
            raise InputError(f"friction coefficient {self.mu!r} is implausible", key="mu",
                             expected="0 < mu < 2 (typically 0.6)")


@dataclass(frozen=True)
class StressSummary:
    """Stress estimates from a record's picks.

    Attributes
    ----------
    available : bool
        False when the picks or inputs do not allow a stress estimate (``message`` says why).
    message : str
    target_tvd : float or None
        [m].
    sigma_h, sigma_h_low, sigma_h_high : float or None
        Minimum horizontal stress and interval [Pa] at target depth.
    t0, t0_low, t0_high : float or None
        Tensile strength ``FBP - Pr`` [Pa].
    sigma_H : dict
        Per equation (``"C.19"``...) the estimate ``{"value", "low", "high", "message"}`` [Pa].
    pore_pressure, sv : float or None
        Used values [Pa].
    pore_pressure_low, pore_pressure_high : float or None
        Interval of the pore pressure [Pa] when it came from the after-closure analysis.
    pore_pressure_source : {"default", "given", "after-closure"}
        Where the pore pressure came from.
    mu : float
    regime : str or None
        Faulting regime of the estimate in the stress polygon.
    assumptions : tuple of str
        Every default that was used.
    source_cycle : int or None
        Cycle whose FCP gave sigma_h.
    """

    available: bool
    message: str = ""
    target_tvd: float | None = None
    sigma_h: float | None = None
    sigma_h_low: float | None = None
    sigma_h_high: float | None = None
    t0: float | None = None
    t0_low: float | None = None
    t0_high: float | None = None
    sigma_H: dict = field(default_factory=dict)
    pore_pressure: float | None = None
    sv: float | None = None
    mu: float = 0.6
    regime: str | None = None
    assumptions: tuple[str, ...] = ()
    source_cycle: int | None = None
    estimates: Any = None
    pore_pressure_low: float | None = None
    pore_pressure_high: float | None = None
    pore_pressure_source: str = "default"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict in field units (bar, m, sg)."""

        def bar(x):
            return None if x is None or not math.isfinite(x) else round(float(x) / _BAR, 4)

        emw = None
        if self.sigma_h is not None and self.target_tvd:
            emw = round(self.sigma_h / (GRAVITY * self.target_tvd) / 1000.0, 4)
        return {
            "available": self.available,
            "message": self.message,
            "target_tvd_m": self.target_tvd,
            "source_cycle": self.source_cycle,
            "sigma_h_bar": bar(self.sigma_h),
            "sigma_h_low_bar": bar(self.sigma_h_low),
            "sigma_h_high_bar": bar(self.sigma_h_high),
            "sigma_h_emw_sg": emw,
            "t0_bar": bar(self.t0),
            "t0_low_bar": bar(self.t0_low),
            "t0_high_bar": bar(self.t0_high),
            "sigma_H": {k: {"value_bar": bar(v["value"]), "low_bar": bar(v["low"]),
                            "high_bar": bar(v["high"]), "message": v["message"]}
                        for k, v in self.sigma_H.items()},
            "pore_pressure_bar": bar(self.pore_pressure),
            "pore_pressure_low_bar": bar(self.pore_pressure_low),
            "pore_pressure_high_bar": bar(self.pore_pressure_high),
            "pore_pressure_source": self.pore_pressure_source,
            "sv_bar": bar(self.sv),
            "mu": self.mu,
            "regime": self.regime,
            "assumptions": list(self.assumptions),
        }


_QUALITY = {"good": 0, "fair": 1, "poor": 2, "none": 3}


def _fcp_rank(cycle_picks) -> tuple[int, int, int]:
    """Order in which cycles are trusted for sigma_h (smallest first).

    A closure seen on flowback (system stiffness) beats one inferred from a shut-in decline,
    because it needs no leak-off model; then the better quality; then the later cycle (a
    grown fracture closes more cleanly than the first, near-wellbore one).
    """
    f = cycle_picks.fcp
    methods = f.details.get("methods", ()) if f.details else ()
    from_flowback = any(str(m).startswith("flowback") for m in methods)
    return (0 if from_flowback else 1, _QUALITY.get(f.quality, 3), -cycle_picks.index)


def _gauge(record: Record, p: float | None) -> float | None:
    """Pick value on an absolute reference -> gauge (relative to atmosphere)."""
    if p is None:
        return None
    return p - ATMOSPHERE_PA if record.reference.absolute else p


def estimate_stress(record_picks, inputs: StressInputs | None = None,
                    diagnostics=None) -> StressSummary:
    """Turn a record's picks into sigma_h, T0, sigma_H and a faulting regime.

    sigma_h is the consensus FCP of the most trusted test cycle (:func:`_fcp_rank`: flowback
    closure first, then quality, then the later cycle), moved to
    the target depth with the well-fluid hydrostatics (:class:`~xlotkit.interpret.stress.
    DepthModel`; closure picks are static pressures, so no friction). T0 = FBP - Pr. sigma_H
    from Eq. C.19 (reopening) with Monte-Carlo intervals; the estimate is placed in the stress
    polygon for ``mu``.

    The pore pressure is, in order: the one given in ``inputs``; the reservoir pressure of
    the after-closure analysis (``diagnostics``, :func:`xlotkit.interpret.diagnostics.
    diagnose_record`) moved to the target depth, with its interval (a triangular
    distribution in the Monte-Carlo of sigma_H); else hydrostatic with 1.03 sg. The
    assumptions say which, and why the analysis did not give one.

    Parameters
    ----------
    record_picks : RecordPicks
    inputs : StressInputs, optional
    diagnostics : RecordDiagnostics, optional

    Returns
    -------
    StressSummary
    """
    from xlotkit.interpret import stress as st

    inputs = inputs or StressInputs()
    record = record_picks.record
    ref = record.reference
    assumptions: list[str] = []

    tests = [c for c in record_picks.cycles if c.fcp is not None and c.fcp.found]
    if not tests:
        return StressSummary(False, "no fracture closure was picked in any test cycle")
    src = min(tests, key=_fcp_rank)
    fcp = src.fcp

    target = inputs.target_tvd
    if target is None:
        if ref.kind in ("bottomhole", "downhole") and ref.depth_m is not None:
            target = float(ref.depth_m)
            assumptions.append(f"target depth = reference depth {target:g} m "
                               "(vertical well, gauge at the open hole)")
        else:
            return StressSummary(False, "give the target TVD (--tvd) to turn surface pressures "
                                        "into stresses")
    gauge_tvd = inputs.gauge_tvd
    if gauge_tvd is None:
        if ref.kind == "surface":
            gauge_tvd = 0.0
        elif ref.depth_m is not None:
            gauge_tvd = float(ref.depth_m)
            if ref.kind == "downhole":
                assumptions.append(f"gauge TVD = gauge MD {gauge_tvd:g} m (vertical well)")
        else:
            gauge_tvd = target
    gauge_tvd = min(gauge_tvd, target)
    rho = inputs.mud_density
    if rho is None:
        if record.density is not None and np.any(np.isfinite(record.density)):
            rho = float(np.nanmedian(record.density))
            assumptions.append(f"well-fluid density = median of the log, {rho / 1000:.3f} sg")
        else:
            rho = 1000.0
            assumptions.append("well-fluid density 1.00 sg (not in the log; give --mud-density)")
    model = st.DepthModel(target_tvd=target, gauge_tvd=gauge_tvd, mud_density=rho)
    dp = float(model.hydrostatic)

    def at_depth(p):
        return None if p is None else _gauge(record, p) + dp

    sh = at_depth(fcp.value)
    sh_lo = at_depth(fcp.low if fcp.low is not None else fcp.value)
    sh_hi = at_depth(fcp.high if fcp.high is not None else fcp.value)

    p0 = inputs.pore_pressure
    p0_lo = p0_hi = None
    p0_src = "given"
    p0_u = None
    if p0 is None:
        best = diagnostics.reservoir_pressure if diagnostics is not None else None
        if best is not None:
            cyc, ac = best
            p0, p0_lo, p0_hi = at_depth(ac.reservoir_pressure), at_depth(ac.low), \
                at_depth(ac.high)
            p0_src = "after-closure"
            name = "exponential approach" if ac.regime == "exponential" else \
                f"{ac.regime} flow"
            assumptions.append(
                f"pore pressure {p0 / _BAR:.1f} bar [{p0_lo / _BAR:.1f} - {p0_hi / _BAR:.1f}] "
                f"({100 * ac.level:.0f} % interval) at target depth from the after-closure "
                f"analysis of cycle {cyc} ({name}), replacing the default 1.03 sg gradient")
            p0_u = st.Uncertain(p0, low=min(p0_lo, p0), high=max(p0_hi, p0))
        else:
            p0 = 1030.0 * GRAVITY * target
            p0_src = "default"
            why = ""
            if diagnostics is not None and diagnostics.cycles:
                why = "; " + "; ".join(f"cycle {c.cycle}: {c.after_closure.message}"
                                       for c in diagnostics.cycles)
            assumptions.append("pore pressure hydrostatic, 1.03 sg" + why)
    sv = inputs.sv
    if sv is None:
        sv = 2300.0 * GRAVITY * target
        assumptions.append("vertical stress 2.30 sg (22.6 kPa/m)")

    t0 = record_picks.t0
    t0v = t0.value if t0.found else None
    sigma_H: dict[str, dict[str, Any]] = {}
    estimates = None
    pr = next((c.get("Pr") for c in record_picks.test_cycles[1:]
               if c.get("Pr") is not None and c.get("Pr").found), None)
    regime = None
    if pr is not None and sh is not None and sh > p0:
        pr_u = st.Uncertain(at_depth(pr.value),
                            low=at_depth(pr.low if pr.low is not None else pr.value),
                            high=at_depth(pr.high if pr.high is not None else pr.value))
        sh_u = st.Uncertain(sh, low=min(sh_lo, sh), high=max(sh_hi, sh))
        try:
            estimates = st.sigma_H_estimates(sh_u, p0=p0_u if p0_u is not None else p0,
                                             pr=pr_u)
            for eq, est in estimates.items():
                sigma_H[eq] = {"value": est.value, "low": est.low, "high": est.high,
                               "message": est.message}
        except InputError as exc:
            sigma_H["C.19"] = {"value": float("nan"), "low": float("nan"),
                               "high": float("nan"), "message": str(exc)}
    if sigma_H and sh is not None and sv > p0:
        best = next(iter(sigma_H.values()))["value"]
        if math.isfinite(best):
            poly = st.stress_polygon(sv, p0, inputs.mu)
            lo_s, hi_s = sorted((sh, best))
            regime = poly.classify(lo_s, hi_s).regime
    return StressSummary(
        True, "", target, sh, sh_lo, sh_hi,
        t0v, t0.low if t0.found else None, t0.high if t0.found else None,
        sigma_H, p0, sv, inputs.mu, regime, tuple(assumptions), src.index, estimates,
        p0_lo, p0_hi, p0_src,
    )


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
             scene: Any = None) -> DemoResult:
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
                     f"({s.sigma_h_low / _BAR:.2f} – {s.sigma_h_high / _BAR:.2f}) from cycle "
                     f"{s.source_cycle}; {ref} {sh / _BAR:.2f} bar "
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
    else:
        lines.append(s.message)
    lines += ["", "Plots: `interpretation/*.png`. Picks: `interpretation/picks.csv`, "
              "`interpretation/picks.json`.", ""]
    return "\n".join(lines)
