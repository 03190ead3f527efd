"""The synthetic XLOT library: scenes, their simulated logs, and picks checked against truth.

A library is a folder with one sub-folder per scene::

    ROOT/<name>/scene.toml     the scene (input; the only file written by hand)
    ROOT/<name>/log.csv        the synthetic field log `xlotkit simulate` wrote for it
    ROOT/<name>/truth.json     the run's summary: imposed and realised sigma_h, sigma_H, T0,
                               p0, the FBP, the model, the exact command, wall time, and
                               (``model_truth``) what the engine knows beyond that: mud
                               column, initiation pressure, stress range over the crack,
                               wall hoop stress, well compliance, crack azimuth and length

:func:`build` (``xlotkit library build ROOT``) simulates the scenes whose log is missing
(``replace=True``: all of them, replacing the stored files) with
:func:`xlotkit.sim.run.simulate`, exactly as ``xlotkit simulate ROOT/<name>/scene.toml``
does, and keeps the log and the summary. :func:`compare` regenerates into a temporary
folder and compares with what is stored (the slow regression test). :func:`evaluate` reads
a stored log through the same reader and picks as a field log and compares each pick with
the scene's realised stresses (the fast regression test and ``xlotkit library check``);
:func:`scenes_markdown` tabulates the stored truths (``xlotkit library list``).
What "realised" means is the engine's (the 2D engine: the in-situ stresses over the crack it
made and the strength of the wall where it started, see
:func:`xlotkit.sim.coupling.results.realised_truth`; the lumped model: the input).

What "closure in the record" means is decided from the log itself: a shut-in that ends more
than :data:`CLOSURE_MARGIN` below the realised sigma_h holds a closure, one that ends more
than the margin above it does not, one in between is not judged; a flowback goes through
closure when it has :data:`FLOWBACK_OPEN_SAMPLES` samples above sigma_h and ends more than
the margin below it.
"""

from __future__ import annotations

import json
import math
import shutil
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from xlotkit.atomic import atomic_write_text
from xlotkit.errors import InputError

__all__ = [
    "CLOSURE_MARGIN",
    "BuildOutcome",
    "Comparison",
    "CycleCheck",
    "Entry",
    "Evaluation",
    "build",
    "compare",
    "entries",
    "evaluate",
    "evaluation_markdown",
    "scenes_markdown",
]

SCENE_FILE = "scene.toml"
LOG_FILE = "log.csv"
TRUTH_FILE = "truth.json"
#: Relative distance from sigma_h [-] within which the end of a shut-in is not judged for
#: closure (the shut-in methods need some decline below closure to see it).
CLOSURE_MARGIN = 0.01
#: Fewest samples a flowback must have above sigma_h for its closure to be judged: twice the
#: fewest samples the system-stiffness picks fit their open-fracture tangent to (5,
#: :mod:`xlotkit.interpret.picks.flowback`).
FLOWBACK_OPEN_SAMPLES = 10
#: Tolerances of the regression (issue 7): flowback system-stiffness methods, shut-in methods.
FLOWBACK_RTOL = 0.03
SHUTIN_RTOL = 0.05

Progress = Callable[[float, str], None]


# --------------------------------------------------------------------------- entries
@dataclass(frozen=True)
class Entry:
    """One scene of the library."""

    name: str
    folder: Path

    @property
    def scene_file(self) -> Path:
        return self.folder / SCENE_FILE

    @property
    def log_file(self) -> Path:
        return self.folder / LOG_FILE

    @property
    def truth_file(self) -> Path:
        return self.folder / TRUTH_FILE

    def truth(self) -> dict[str, Any]:
        """The stored truth (``truth.json``)."""
        if not self.truth_file.is_file():
            raise InputError("no truth.json: the scene has not been simulated yet",
                             file=self.truth_file,
                             expected=f"run `xlotkit library build {self.folder.parent}`")
        try:
            return json.loads(self.truth_file.read_text())
        except json.JSONDecodeError as exc:
            raise InputError(f"not valid JSON: {exc.msg}", file=self.truth_file,
                             line=exc.lineno) from exc

    def command(self) -> str:
        """The command that makes this entry's log on its own."""
        return f"xlotkit simulate {self.scene_file.as_posix()} --out DIR"


def entries(root: str | Path, names: Iterable[str] | None = None) -> list[Entry]:
    """The scenes of a library (sorted by name), or the named ones.

    Raises
    ------
    InputError
        If ``root`` is not a folder, holds no scene, or a name is not in it.
    """
    root = Path(root)
    if not root.is_dir():
        raise InputError("no such library folder", file=root,
                         expected="a folder with one sub-folder per scene (scene.toml)")
    found = {d.name: Entry(d.name, d) for d in sorted(root.iterdir())
             if d.is_dir() and (d / SCENE_FILE).is_file()}
    if not found:
        raise InputError("no scenes in the library folder", file=root,
                         expected="sub-folders holding scene.toml")
    if names is None:
        return list(found.values())
    out = []
    for n in names:
        if n not in found:
            raise InputError(f"no scene {n!r} in the library", file=root,
                             expected="one of " + ", ".join(found))
        out.append(found[n])
    return out


# --------------------------------------------------------------------------- build
@dataclass(frozen=True)
class BuildOutcome:
    """What :func:`build` did with one entry (``action``: simulated or kept)."""

    entry: Entry
    action: str
    status: str = ""
    message: str = ""
    wall_time: float = 0.0


def _simulate_into(entry: Entry, work: Path, progress: Progress | None) -> tuple[Path, dict]:
    """Simulate ``entry`` into ``work`` (a fresh folder); the log path and its truth."""
    from xlotkit.sim.run import require_engine, simulate
    from xlotkit.sim.scene import load_scene

    scene = load_scene(entry.scene_file)
    require_engine(scene)
    t0 = time.perf_counter()
    res = simulate(scene, work, progress=progress)
    wall = time.perf_counter() - t0
    summary = json.loads(Path(res.paths["summary"]).read_text())
    truth = {"name": entry.name, "command": entry.command(),
             "library_command": f"xlotkit library build {entry.folder.parent.as_posix()} "
                                f"--only {entry.name} --replace",
             "wall_time_s": round(wall, 2), **summary}
    truth.pop("files", None)
    model = _model_truth(res.truth)
    if model:
        truth["model_truth"] = model
    return Path(res.paths["log"]), truth


#: Pressures of the engine's truth kept in ``truth.json`` (``model_truth``, in bar).
_MODEL_PRESSURES = ("initial_pressure", "initiation_pressure", "fbp")
#: Pressures of the engine's realised detail kept there (bar).
_DETAIL_PRESSURES = ("sigma_h_min", "sigma_h_max", "wall_hoop_stress")


def _model_truth(truth: dict[str, Any]) -> dict[str, Any]:
    """What the engine knows beyond the realised stresses, for the library's discussion:
    the mud-column, initiation and breakdown pressures, the stress range over the crack,
    the wall's hoop stress (bar), the well compliance (l/MPa), the crack's azimuth and
    half-length and the mesh size. Keys the engine does not report are left out."""
    out: dict[str, Any] = {}
    for k in _MODEL_PRESSURES:
        if truth.get(k) is not None:
            out[f"{k}_bar"] = float(truth[k]) / 1e5
    detail = truth.get("realised_detail") or {}
    for k in _DETAIL_PRESSURES:
        if k in detail:
            out[f"{k}_bar"] = float(detail[k]) / 1e5
    if truth.get("well_compliance") is not None:
        out["well_compliance_l_per_MPa"] = float(truth["well_compliance"]) * 1e9
    if "fracture_azimuth_deg" in detail:
        out["fracture_azimuth_deg"] = float(detail["fracture_azimuth_deg"])
    if "fracture_half_length" in detail:
        out["fracture_half_length_m"] = float(detail["fracture_half_length"])
    if truth.get("n_triangles") is not None:
        out["n_triangles"] = int(truth["n_triangles"])
    return out


def build(root: str | Path, names: Iterable[str] | None = None, *, replace: bool = False,
          progress: Progress | None = None) -> list[BuildOutcome]:
    """Simulate the library's scenes and store their logs and truths.

    Parameters
    ----------
    root : str or Path
        The library folder.
    names : iterable of str, optional
        Only these scenes.
    replace : bool
        Simulate every selected scene and replace its stored log and truth; without it a
        scene that already has a log is kept as it is.
    progress : callable, optional
        ``progress(fraction, message)`` over the whole build.

    Returns
    -------
    list of BuildOutcome
    """
    todo = entries(root, names)
    out: list[BuildOutcome] = []
    for i, e in enumerate(todo):
        if e.log_file.exists() and not replace:
            out.append(BuildOutcome(e, "kept"))
            continue

        def sub(f: float, msg: str, i=i, e=e) -> None:
            if progress is not None:
                progress((i + f) / len(todo), f"{e.name}: {msg}")

        with tempfile.TemporaryDirectory(dir=e.folder, prefix=".build-") as tmp:
            log, truth = _simulate_into(e, Path(tmp) / "run", sub)
            # the stored pair changes together: the new files are complete before either
            # replaces its predecessor (atomic renames within the folder)
            staged_log = Path(tmp) / LOG_FILE
            shutil.copyfile(log, staged_log)
            atomic_write_text(Path(tmp) / TRUTH_FILE,
                              json.dumps(truth, indent=2, allow_nan=False) + "\n")
            staged_log.replace(e.log_file)
            (Path(tmp) / TRUTH_FILE).replace(e.truth_file)
        out.append(BuildOutcome(e, "simulated", truth.get("status", ""),
                                truth.get("message", ""), truth["wall_time_s"]))
    return out


# --------------------------------------------------------------------------- compare
@dataclass(frozen=True)
class Comparison:
    """A regenerated log against the stored one."""

    entry: Entry
    same: bool
    max_pressure_difference: float        # [Pa]
    message: str


def _log_arrays(path: Path) -> tuple[np.ndarray, np.ndarray]:
    from xlotkit.interpret.io import read_log

    rec = read_log(path)
    return np.asarray(rec.t, dtype=float), np.asarray(rec.pressure, dtype=float)


def compare(root: str | Path, names: Iterable[str] | None = None, *,
            pressure_atol: float = 1.0, progress: Progress | None = None) -> list[Comparison]:
    """Regenerate the selected scenes into a temporary folder and compare with the stored
    logs: same samples, pressures within ``pressure_atol`` [Pa]."""
    todo = entries(root, names)
    out = []
    for i, e in enumerate(todo):
        if not e.log_file.is_file():
            raise InputError("no stored log to compare with", file=e.log_file,
                             expected=f"run `xlotkit library build {Path(root)}`")

        def sub(f: float, msg: str, i=i, e=e) -> None:
            if progress is not None:
                progress((i + f) / len(todo), f"{e.name}: {msg}")

        with tempfile.TemporaryDirectory(prefix="xlotkit-library-") as tmp:
            log, _ = _simulate_into(e, Path(tmp) / "run", sub)
            t_new, p_new = _log_arrays(log)
        t_old, p_old = _log_arrays(e.log_file)
        if t_new.shape != t_old.shape or not np.allclose(t_new, t_old, rtol=0, atol=1e-6):
            out.append(Comparison(e, False, math.inf,
                                  f"{len(t_new)} samples regenerated vs {len(t_old)} stored"))
            continue
        d = float(np.max(np.abs(p_new - p_old))) if p_new.size else 0.0
        out.append(Comparison(e, d <= pressure_atol, d,
                              f"max |dp| = {d:.3g} Pa over {len(t_new)} samples"))
    return out


# --------------------------------------------------------------------------- evaluate
@dataclass(frozen=True)
class CycleCheck:
    """The picks of one test cycle against the realised sigma_h.

    Attributes
    ----------
    cycle : int
    shutin_end_pressure : float or None
        Pressure at the end of the cycle's first shut-in [Pa] (None: no shut-in).
    closure_in_shutin : bool or None
        True/False when the shut-in ends clearly below/above sigma_h, None in between.
    flowback_closure : bool
        A flowback of the cycle starts above sigma_h and ends below it (by the margin).
    errors : dict
        Relative error [-] of every FCP pick found, by method (``consensus`` included).
    failures : tuple of str
        Each way the cycle misses the library's tolerances.
    shutin_judged : bool
        The shut-in picks were held to the shut-in tolerance: the shut-in ends clearly
        below sigma_h, or within the margin and its methods picked a closure.
    """

    cycle: int
    shutin_end_pressure: float | None
    closure_in_shutin: bool | None
    flowback_closure: bool
    errors: dict[str, float]
    failures: tuple[str, ...]
    shutin_judged: bool = False


@dataclass(frozen=True)
class Evaluation:
    """The picks of one library log against its truth."""

    entry: Entry
    truth: dict
    cycles: tuple[CycleCheck, ...]
    t0: float | None                      # [Pa] picked FBP - Pr
    sigma_H: float | None                 # [Pa] picked (Eq. C.19 where available)
    sigma_h: float | None                 # [Pa] the stress estimate's sigma_h
    failures: tuple[str, ...] = field(default=())
    fbp: float | None = None              # [Pa] picked FBP of the first test cycle, at depth
    pr: float | None = None               # [Pa] picked Pr of the first later cycle, at depth
    depth_offset: float = 0.0             # [Pa] gauge -> open hole (0 at the bottom hole)
    #: the :class:`xlotkit.pipeline.Interpretation` the checks were made on (every pick,
    #: on the gauge's reference: add ``depth_offset`` for the open hole)
    interpretation: Any = None

    @property
    def passed(self) -> bool:
        return not self.failures and all(not c.failures for c in self.cycles)

    def realised(self, key: str) -> float:
        """Realised value [Pa] of ``sigma_h``, ``sigma_H`` or ``tensile_strength``."""
        return float(self.truth["realised_bar"][key]) * 1e5


def _depth_offset(interp) -> float | None:
    """Pressure [Pa] the interpreter adds to a pick at the gauge to have it at the open
    hole (0 for a bottom-hole record; the fluid column for a surface gauge), read off its
    own sigma_h estimate: ``sigma_h`` minus the record's closure it was made from (the
    cycles that agree, :func:`~xlotkit.interpret.picks.agreement.agree_closures`). None
    when there is no estimate."""
    from xlotkit.interpret.estimate import _gauge

    s = interp.stress
    closure = interp.picks.consistency.closure
    if not s.available or s.sigma_h is None or closure is None or not closure.found:
        return None
    return float(s.sigma_h - _gauge(interp.record, closure.value))


def _shutin_end(record, cycle, offset: float = 0.0) -> float | None:
    """Pressure at the open hole [Pa] at the end of the cycle's first shut-in (the gauge's
    pressure plus ``offset``), or None without a shut-in."""
    ph = cycle.phase("shut_in")
    if ph is None:
        return None
    t = np.asarray(record.t)
    p = np.asarray(record.pressure)
    sel = (t >= ph.t_start) & (t <= ph.t_end)
    if not sel.any():
        return None
    # the last few samples: the median resists gauge noise
    return float(np.median(p[sel][-5:])) + offset


def _flowback_through(record, cycle, sigma_h: float, offset: float = 0.0) -> bool:
    """Whether a flowback or bleed of the cycle goes through closure (the gauge's pressure
    plus ``offset``): it starts above sigma_h with at least :data:`FLOWBACK_OPEN_SAMPLES`
    samples above it (a stretch of the open fracture's line for the system-stiffness
    tangent) and ends more than :data:`CLOSURE_MARGIN` below it (a stretch of the closed
    one).

    The open side is not asked for the margin as well: a 2D crack's net pressure at shut-in
    is only ~1 % of sigma_h (a long crack at K_IC 1 MPa m^0.5), so a second cycle's
    flowback typically starts 0.9 % above sigma_h and runs a minute above it; that is
    enough for the open line, and its closure pick is to be judged, not skipped."""
    t = np.asarray(record.t)
    p = np.asarray(record.pressure) + offset
    for ph in cycle.phases:
        if ph.kind not in ("flowback", "bleed"):
            continue
        sel = np.flatnonzero((t >= ph.t_start) & (t <= ph.t_end))
        if sel.size < 2:
            continue
        start = float(np.median(p[sel[:3]]))
        if (start > sigma_h and int(np.sum(p[sel] > sigma_h)) >= FLOWBACK_OPEN_SAMPLES
                and np.min(p[sel]) < sigma_h * (1 - CLOSURE_MARGIN)):
            return True
    return False


def evaluate(entry: Entry) -> Evaluation:
    """Read the entry's stored log, pick it as a field log and check against its truth.

    The tolerances are issue 7's: the flowback system-stiffness FCP within
    :data:`FLOWBACK_RTOL` (3 %) of the realised sigma_h where the flowback goes through
    closure; every shut-in method within :data:`SHUTIN_RTOL` (5 %) where the shut-in
    holds a closure and "no closure" where it clearly does not.

    The stress estimate gets the scene's pore pressure (``imposed_bar.pore_pressure``), as
    a field interpretation gets it from the pore-pressure prediction: the library checks
    the picks and Eq. C.19, not the interpreter's hydrostatic default (1.03 sg), which
    would put the scene's own choice of p0 into the sigma_H error. A surface-gauge log
    (``output.gauge = "surface"``) gets the open hole's TVD from the log's metadata
    (``meta.tvd``), as the field interpreter gives ``--tvd``; its pressures are taken to
    depth by the interpreter's own hydrostatic column.
    """
    from xlotkit.interpret.io import read_log
    from xlotkit.interpret.picks.core import SHUTIN_METHOD_NAMES
    from xlotkit.interpret.picks.flowback import FLOWBACK_METHODS
    from xlotkit.interpret.estimate import StressInputs
    from xlotkit.pipeline import interpret_record

    truth = entry.truth()
    if "realised_bar" not in truth:
        raise InputError("missing key 'realised_bar'", file=entry.truth_file,
                         key="realised_bar", expected="the summary of `xlotkit simulate`")
    sh = float(truth["realised_bar"]["sigma_h"]) * 1e5
    p0 = truth.get("imposed_bar", {}).get("pore_pressure")
    record = read_log(entry.log_file)
    tvd = record.meta.get("tvd") if record.reference.kind == "surface" else None
    inputs = StressInputs(pore_pressure=None if p0 is None else float(p0) * 1e5,
                          target_tvd=None if tvd is None else float(tvd))
    interp = interpret_record(record, stress_inputs=inputs)
    rec = interp.record
    checks = []
    general: list[str] = []
    offset = _depth_offset(interp)
    if offset is None:
        offset = 0.0
        if rec.reference.kind != "bottomhole":
            general.append("no stress estimate: the gauge's picks cannot be taken to depth")
    cycles = interp.picks.test_cycles
    if not cycles:
        general.append("no test cycle found in the log")
    for c in cycles:
        fails: list[str] = []
        methods = c.fcp_methods()
        errors = {m: (p.value + offset - sh) / sh
                  for m, p in {**methods, "consensus": c.fcp}.items()
                  if p.found}
        p_end = _shutin_end(rec, c.cycle, offset)
        if p_end is None:
            closure = None
        elif p_end < sh * (1 - CLOSURE_MARGIN):
            closure = True
        elif p_end > sh * (1 + CLOSURE_MARGIN):
            closure = False
        else:
            closure = None
        shut_found = [m for m in SHUTIN_METHOD_NAMES
                      if methods.get(m) is not None and methods[m].found]
        fb_closure = _flowback_through(rec, c.cycle, sh, offset)
        if closure is None and shut_found:
            # The shut-in ends within the margin of sigma_h and its methods say the crack
            # closed in it: judge that claim like a closure in the record; the flowback
            # then starts closed (the picker rejects a break in it that contradicts the
            # shut-in's closure) and is not judged.
            judge_shutin, fb_closure = True, False
        else:
            judge_shutin = closure is True
        if fb_closure:
            for m in FLOWBACK_METHODS:
                p = methods.get(m)
                if p is None or not p.found:
                    fails.append(f"cycle {c.index}: {m} found no closure in a flowback "
                                 f"through sigma_h")
                elif abs(errors[m]) > FLOWBACK_RTOL:
                    fails.append(f"cycle {c.index}: {m} {errors[m]:+.1%} of sigma_h "
                                 f"(allowed {FLOWBACK_RTOL:.0%})")
        for m in SHUTIN_METHOD_NAMES:
            p = methods.get(m)
            if p is None:
                continue
            if judge_shutin and p.found and abs(errors[m]) > SHUTIN_RTOL:
                fails.append(f"cycle {c.index}: {m} {errors[m]:+.1%} of sigma_h "
                             f"(allowed {SHUTIN_RTOL:.0%})")
            if closure is False and p.found:
                fails.append(f"cycle {c.index}: {m} picked closure at "
                             f"{p.value / 1e5:.1f} bar in a shut-in that ends above sigma_h")
        checks.append(CycleCheck(c.index, p_end, closure, fb_closure, errors, tuple(fails),
                                 shutin_judged=judge_shutin))
    s = interp.stress
    sig_H = None
    if s.available and s.sigma_H:
        est = s.sigma_H.get("C.19") or next(iter(s.sigma_H.values()))
        sig_H = est.get("value")
    fbp = next((c.get("FBP") for c in cycles[:1] if c.get("FBP") is not None
                and c.get("FBP").found), None)
    pr = next((c.get("Pr") for c in cycles[1:] if c.get("Pr") is not None
               and c.get("Pr").found), None)
    return Evaluation(entry, truth, tuple(checks), s.t0 if s.available else None, sig_H,
                      s.sigma_h if s.available else None, tuple(general),
                      fbp=fbp.value + offset if fbp is not None else None,
                      pr=pr.value + offset if pr is not None else None, depth_offset=offset,
                      interpretation=interp)


def _pct(v: float | None, ref: float) -> str:
    return "–" if v is None else f"{100 * (v - ref) / ref:+.1f} %"


def _bar_pct(v: float | None, ref: float) -> str:
    """``value [bar] (error %)`` or a dash."""
    return "–" if v is None else f"{v / 1e5:.1f} ({_pct(v, ref)})"


def _bar(v: float | None) -> str:
    return "–" if v is None else f"{v / 1e5:.1f}"


def evaluation_markdown(evals: Iterable[Evaluation]) -> str:
    """Markdown tables of the picks against the realised stresses: one row per cycle
    (relative error of every closure pick; whether the shut-in and a flowback hold a
    closure, i.e. which rules judged the cycle; whether it passed), then one row per scene
    (sigma_h estimate, FBP and Pr at depth, T0 = FBP - Pr and sigma_H by Eq. C.19 against
    the realised values)."""
    lines = ["| scene | model | cycle | flowback √p–t | flowback p–V | tangent | √t | G | "
             "bilinear | compliance | consensus | shut-in closure | flowback closure | "
             "passed |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|"]
    for ev in evals:
        model = ev.truth.get("model", "")
        for c in ev.cycles:
            def cell(m, c=c):
                e = c.errors.get(m)
                return "–" if e is None else f"{100 * e:+.2f} %"

            clo = {True: "yes", False: "no", None: "–"}[c.closure_in_shutin]
            if c.closure_in_shutin is None and c.shutin_judged:
                clo = "picked"      # ends within the margin, its methods picked closure
            lines.append(
                f"| {ev.entry.name} | {model} | {c.cycle} | {cell('flowback_sqrt_p')} | "
                f"{cell('flowback_p_v')} | {cell('tangent')} | {cell('sqrt_t')} | "
                f"{cell('g_function')} | {cell('bilinear')} | {cell('compliance')} | "
                f"{cell('consensus')} | {clo} | {'yes' if c.flowback_closure else 'no'} | "
                f"{'yes' if not c.failures else 'NO'} |")
    lines += ["", "| scene | realised σh [bar] | picked σh | FBP [bar] | Pr [bar] | "
              "realised T0 [bar] | T0 = FBP − Pr [bar] | realised σH [bar] | σH (C.19) [bar] |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for ev in evals:
        sh, sH, t0 = (ev.realised(k) for k in ("sigma_h", "sigma_H", "tensile_strength"))
        lines.append(f"| {ev.entry.name} | {sh / 1e5:.1f} | {_pct(ev.sigma_h, sh)} | "
                     f"{_bar(ev.fbp)} | {_bar(ev.pr)} | {t0 / 1e5:.1f} | "
                     f"{_bar_pct(ev.t0, t0)} | {sH / 1e5:.1f} | {_bar_pct(ev.sigma_H, sH)} |")
    return "\n".join(lines) + "\n"


def scenes_markdown(items: Iterable[Entry]) -> str:
    """A Markdown table of the library's scenes from their stored truths: title, status,
    imposed and realised sigma_h / sigma_H / T0 [bar], the model's FBP and crack
    half-length, steps and the wall time of the run that made the log.

    Raises
    ------
    InputError
        If a scene has no truth yet (not simulated).
    """
    import tomllib

    lines = ["| scene | title | status | imposed σh / σH / T0 [bar] | "
             "realised σh / σH / T0 [bar] | FBP [bar] | crack half-length [m] | steps | "
             "wall time [s] |", "|---|---|---|---|---|---:|---:|---:|---:|"]
    for e in items:
        truth = e.truth()
        try:
            title = str(tomllib.loads(e.scene_file.read_text()).get("title", ""))
        except tomllib.TOMLDecodeError:
            title = ""
        imp, rea = truth.get("imposed_bar", {}), truth.get("realised_bar", {})

        def triple(d: dict) -> str:
            return " / ".join("–" if d.get(k) is None else f"{float(d[k]):.1f}"
                              for k in ("sigma_h", "sigma_H", "tensile_strength"))

        mt = truth.get("model_truth", {})
        fbp = truth.get("fbp_bar")
        half = mt.get("fracture_half_length_m")
        lines.append(
            f"| {e.name} | {title} | {truth.get('status', '')} | {triple(imp)} | "
            f"{triple(rea)} | {'–' if fbp is None else f'{float(fbp):.1f}'} | "
            f"{'–' if half is None else f'{float(half):.1f}'} | {truth.get('steps', '–')} | "
            f"{float(truth.get('wall_time_s', math.nan)):.0f} |")
    return "\n".join(lines) + "\n"
