"""The synthetic XLOT library: scenes, their simulated logs, and picks checked against truth.

A library is a folder with one sub-folder per scene::

    ROOT/<name>/scene.toml     the scene (input; the only file written by hand)
    ROOT/<name>/log.csv        the synthetic field log `xlotkit simulate` wrote for it
    ROOT/<name>/truth.json     the run's summary: imposed and realised sigma_h, sigma_H, T0,
                               p0, the FBP, the model, the exact command, wall time

:func:`build` (``xlotkit library build ROOT``) simulates the scenes whose log is missing
(``replace=True``: all of them, replacing the stored files) with
:func:`xlotkit.sim.run.simulate`, exactly as ``xlotkit simulate ROOT/<name>/scene.toml``
does, and keeps the log and the summary. :func:`compare` regenerates into a temporary
folder and compares with what is stored (the slow regression test). :func:`evaluate` reads
a stored log through the same reader and picks as a field log and compares each pick with
the scene's realised stresses (the fast regression test and ``xlotkit library check``).

What "closure in the record" means is decided from the log itself: a shut-in that ends more
than :data:`CLOSURE_MARGIN` below the realised sigma_h holds a closure, one that ends more
than the margin above it does not, one in between is not judged.
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
]

SCENE_FILE = "scene.toml"
LOG_FILE = "log.csv"
TRUTH_FILE = "truth.json"
#: Relative distance from sigma_h [-] within which the end of a shut-in is not judged for
#: closure (the shut-in methods need some decline below closure to see it).
CLOSURE_MARGIN = 0.01
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
    return Path(res.paths["log"]), truth


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
    """

    cycle: int
    shutin_end_pressure: float | None
    closure_in_shutin: bool | None
    flowback_closure: bool
    errors: dict[str, float]
    failures: tuple[str, ...]


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

    @property
    def passed(self) -> bool:
        return not self.failures and all(not c.failures for c in self.cycles)

    def realised(self, key: str) -> float:
        """Realised value [Pa] of ``sigma_h``, ``sigma_H`` or ``tensile_strength``."""
        return float(self.truth["realised_bar"][key]) * 1e5


def _shutin_end(record, cycle) -> float | None:
    ph = cycle.phase("shut_in")
    if ph is None:
        return None
    t = np.asarray(record.t)
    p = np.asarray(record.pressure)
    sel = (t >= ph.t_start) & (t <= ph.t_end)
    if not sel.any():
        return None
    # the last few samples: the median resists gauge noise
    return float(np.median(p[sel][-5:]))


def _flowback_through(record, cycle, sigma_h: float) -> bool:
    """Whether a flowback or bleed of the cycle starts above sigma_h and ends below it
    (each by :data:`CLOSURE_MARGIN`): the closure is then in that flowback."""
    t = np.asarray(record.t)
    p = np.asarray(record.pressure)
    for ph in cycle.phases:
        if ph.kind not in ("flowback", "bleed"):
            continue
        sel = np.flatnonzero((t >= ph.t_start) & (t <= ph.t_end))
        if sel.size < 2:
            continue
        start = float(np.median(p[sel[:3]]))
        if start > sigma_h * (1 + CLOSURE_MARGIN) and np.min(p[sel]) < sigma_h * (
                1 - CLOSURE_MARGIN):
            return True
    return False


def evaluate(entry: Entry) -> Evaluation:
    """Read the entry's stored log, pick it as a field log and check against its truth.

    The tolerances are issue 7's: the flowback system-stiffness FCP within
    :data:`FLOWBACK_RTOL` (3 %) of the realised sigma_h where the flowback goes through
    closure; every shut-in method within :data:`SHUTIN_RTOL` (5 %) where the shut-in
    holds a closure and "no closure" where it clearly does not.
    """
    from xlotkit.interpret.io import read_log
    from xlotkit.interpret.picks.core import SHUTIN_METHOD_NAMES
    from xlotkit.interpret.picks.flowback import FLOWBACK_METHODS
    from xlotkit.pipeline import interpret_record

    truth = entry.truth()
    if "realised_bar" not in truth:
        raise InputError("missing key 'realised_bar'", file=entry.truth_file,
                         key="realised_bar", expected="the summary of `xlotkit simulate`")
    sh = float(truth["realised_bar"]["sigma_h"]) * 1e5
    interp = interpret_record(read_log(entry.log_file))
    rec = interp.record
    checks = []
    general: list[str] = []
    cycles = interp.picks.test_cycles
    if not cycles:
        general.append("no test cycle found in the log")
    for c in cycles:
        fails: list[str] = []
        methods = c.fcp_methods()
        errors = {m: (p.value - sh) / sh for m, p in {**methods, "consensus": c.fcp}.items()
                  if p.found}
        p_end = _shutin_end(rec, c.cycle)
        if p_end is None:
            closure = None
        elif p_end < sh * (1 - CLOSURE_MARGIN):
            closure = True
        elif p_end > sh * (1 + CLOSURE_MARGIN):
            closure = False
        else:
            closure = None
        fb_closure = _flowback_through(rec, c.cycle, sh)
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
            if closure is True and p.found and abs(errors[m]) > SHUTIN_RTOL:
                fails.append(f"cycle {c.index}: {m} {errors[m]:+.1%} of sigma_h "
                             f"(allowed {SHUTIN_RTOL:.0%})")
            if closure is False and p.found:
                fails.append(f"cycle {c.index}: {m} picked closure at "
                             f"{p.value / 1e5:.1f} bar in a shut-in that ends above sigma_h")
        checks.append(CycleCheck(c.index, p_end, closure, fb_closure, errors, tuple(fails)))
    s = interp.stress
    sig_H = None
    if s.available and s.sigma_H:
        est = s.sigma_H.get("C.19") or next(iter(s.sigma_H.values()))
        sig_H = est.get("value")
    return Evaluation(entry, truth, tuple(checks), s.t0 if s.available else None, sig_H,
                      s.sigma_h if s.available else None, tuple(general))


def _pct(v: float | None, ref: float) -> str:
    return "–" if v is None else f"{100 * (v - ref) / ref:+.1f} %"


def evaluation_markdown(evals: Iterable[Evaluation]) -> str:
    """A Markdown table of the picks against the realised stresses, one row per cycle."""
    lines = ["| scene | model | cycle | flowback √p–t | flowback p–V | tangent | √t | G | "
             "bilinear | compliance | consensus | shut-in closure | passed |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|"]
    for ev in evals:
        model = ev.truth.get("model", "")
        for c in ev.cycles:
            def cell(m, c=c):
                e = c.errors.get(m)
                return "–" if e is None else f"{100 * e:+.2f} %"

            clo = {True: "yes", False: "no", None: "–"}[c.closure_in_shutin]
            lines.append(
                f"| {ev.entry.name} | {model} | {c.cycle} | {cell('flowback_sqrt_p')} | "
                f"{cell('flowback_p_v')} | {cell('tangent')} | {cell('sqrt_t')} | "
                f"{cell('g_function')} | {cell('bilinear')} | {cell('compliance')} | "
                f"{cell('consensus')} | {clo} | {'yes' if not c.failures else 'NO'} |")
    lines += ["", "| scene | realised σh [bar] | picked σh | realised T0 [bar] | T0 = FBP − Pr "
              "| realised σH [bar] | σH (C.19) |", "|---|---:|---:|---:|---:|---:|---:|"]
    for ev in evals:
        sh, sH, t0 = (ev.realised(k) for k in ("sigma_h", "sigma_H", "tensile_strength"))
        lines.append(f"| {ev.entry.name} | {sh / 1e5:.1f} | {_pct(ev.sigma_h, sh)} | "
                     f"{t0 / 1e5:.1f} | {_pct(ev.t0, t0)} | {sH / 1e5:.1f} | "
                     f"{_pct(ev.sigma_H, sH)} |")
    return "\n".join(lines) + "\n"
