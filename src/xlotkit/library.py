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

import dataclasses
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
    "DFIT_FALLOFF_RATIO",
    "FLOWBACK_RTOL",
    "GROWTH_MIN",
    "GROWTH_MIN_REL",
    "LOP_RTOL",
    "OUTCOMES",
    "SHUTIN_RTOL",
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
    "grew",
    "method_rows",
    "methods_markdown",
    "phase_truth",
    "scene_kind",
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
#: Tolerance of a LOT's leak-off point against the model's leak-off (the well pressure at
#: the wall's first failure): the LOP is a break of the pressurisation line read like the
#: flowback's system-stiffness break, so it gets the flowback's tolerance.
LOP_RTOL = 0.03
#: A DFIT's falloff lasts at least this many times its injection (the usual design rule of
#: a DFIT; also the interpreter's ``SegmentOptions.dfit_falloff_ratio``).
DFIT_FALLOFF_RATIO = 5.0
#: Growth of the crack in a shut-in while it is open that counts as tip extension: at
#: least two of the band's 0.5 m elements along it and 10 % of its length at shut-in.
GROWTH_MIN = 1.0
GROWTH_MIN_REL = 0.10

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
    if "timeseries" in res.paths and res.truth.get("phases"):
        from xlotkit.sim.output import read_timeseries

        series = read_timeseries(res.paths["timeseries"]).series
        phases = phase_truth(res.truth["phases"], series,
                             (summary.get("realised_bar") or {}).get("sigma_h"))
        if phases:
            model["phases"] = phases
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


#: Time-series columns kept per phase in ``model_truth.phases``: column -> (key, scale to
#: the stored unit).
_PHASE_SERIES = (("fracture_length", "half_length_m", 1.0),
                 ("failed_clusters", "failed_clusters", 1.0),
                 ("fracture_volume", "fracture_volume_l", 1e3),
                 ("leakoff_volume", "leakoff_volume_l", 1e3),
                 ("bottomhole_pressure", "pressure_bar", 1e-5))


def phase_truth(phases: Iterable[dict[str, Any]], series: dict[str, np.ndarray],
                sigma_h_bar: float | None) -> list[dict[str, Any]]:
    """What the crack did in every phase of a run, from the engine's time series.

    Parameters
    ----------
    phases : iterable of dict
        The engine's phases (``cycle``, ``kind``, ``name``, ``t_start``, ``t_end`` [s]).
    series : dict of ndarray
        The time series (:data:`xlotkit.sim.output.SERIES_COLUMNS`; a column the engine
        does not have is left out).
    sigma_h_bar : float or None
        The realised sigma_h [bar]: in a shut-in, where the bottom-hole pressure first falls
        to it (``open_until_s``) and the crack's half-length then (``half_length_open_m``):
        the growth of the crack while the shut-in pressure is still above closure.

    Returns
    -------
    list of dict
        Per phase: ``cycle``, ``kind``, ``name``, ``t_start_s``, ``t_end_s`` and, for each
        column of :data:`_PHASE_SERIES` the engine has, ``[start, end]`` of the phase
        (half-length m, failed clusters, fracture and cumulative leak-off volumes l,
        bottom-hole pressure bar); for shut-ins ``open_until_s`` (None: above sigma_h to
        its end) and ``half_length_open_m``.
    """
    t = np.asarray(series.get("t", ()), dtype=float)
    out: list[dict[str, Any]] = []
    if t.size == 0:
        return out
    for ph in phases:
        t0, t1 = float(ph["t_start"]), float(ph["t_end"])
        d: dict[str, Any] = {"cycle": int(ph["cycle"]), "kind": str(ph["kind"]),
                             "name": str(ph["name"]), "t_start_s": round(t0, 3),
                             "t_end_s": round(t1, 3)}
        # the rows at the phase's ends (a row is pushed at every accepted step)
        i0 = int(np.clip(np.searchsorted(t, t0, side="left"), 0, t.size - 1))
        i1 = int(np.clip(np.searchsorted(t, t1, side="right") - 1, 0, t.size - 1))
        for col, key, scale in _PHASE_SERIES:
            if col in series:
                v = np.asarray(series[col], dtype=float)
                d[key] = [round(float(v[i0]) * scale, 4), round(float(v[i1]) * scale, 4)]
        if (ph["kind"] == "shut_in" and sigma_h_bar is not None
                and "bottomhole_pressure" in series and "fracture_length" in series):
            p = np.asarray(series["bottomhole_pressure"], dtype=float)[i0:i1 + 1] * 1e-5
            below = np.flatnonzero(p <= float(sigma_h_bar))
            j = i0 + int(below[0]) if below.size else i1
            d["open_until_s"] = round(float(t[j]), 3) if below.size else None
            d["half_length_open_m"] = round(float(series["fracture_length"][j]), 4)
        out.append(d)
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


# --------------------------------------------------------------------------- scene kinds
def scene_kind(truth: dict[str, Any]) -> str:
    """What test a library scene is, from what its run did (``truth.json``).

    * ``"lot"``: the wall's first clusters failed (``model_truth.initiation_pressure_bar``)
      but the pressure never fell while pumping (no ``fbp_bar``): a leak-off test stopped
      before breakdown;
    * ``"dfit"``: one pump phase, no flowback or bleed, and shut-in after it at least
      :data:`DFIT_FALLOFF_RATIO` times the injection time (``model_truth.phases``);
    * ``"xlot"``: everything else (breakdown, propagation, cycles; also a truth without
      the model's detail, such as a sweep's).
    """
    mt = truth.get("model_truth") or {}
    if mt.get("initiation_pressure_bar") is not None and truth.get("fbp_bar") is None:
        return "lot"
    phases = mt.get("phases") or []
    pumps = [p for p in phases if p["kind"] == "pump"]
    if len(pumps) == 1 and not any(p["kind"] in ("flowback", "bleed") for p in phases):
        injection = pumps[0]["t_end_s"] - pumps[0]["t_start_s"]
        falloff = sum(p["t_end_s"] - p["t_start_s"] for p in phases
                      if p["kind"] == "shut_in" and p["t_start_s"] >= pumps[0]["t_end_s"])
        if injection > 0 and falloff >= DFIT_FALLOFF_RATIO * injection:
            return "dfit"
    return "xlot"


def _model_shutin(truth: dict[str, Any], t0: float, t1: float) -> dict[str, Any] | None:
    """The model's shut-in phase (``model_truth.phases``) that overlaps the interpreter's
    shut-in ``[t0, t1]`` [s] most, or None (no phase record, no overlap)."""
    best, most = None, 0.0
    for p in (truth.get("model_truth") or {}).get("phases") or []:
        if p["kind"] != "shut_in":
            continue
        ov = min(t1, p["t_end_s"]) - max(t0, p["t_start_s"])
        if ov > most:
            best, most = p, ov
    return best


def _growth(truth: dict[str, Any], cycle) -> tuple[float, float] | None:
    """Half-length of the crack [m] when the cycle's first shut-in starts and when its
    pressure falls to the realised sigma_h (or at its end), from the model's phase record;
    None without it."""
    ph = cycle.phase("shut_in")
    if ph is None:
        return None
    m = _model_shutin(truth, ph.t_start, ph.t_end)
    if m is None or "half_length_m" not in m or m.get("half_length_open_m") is None:
        return None
    return float(m["half_length_m"][0]), float(m["half_length_open_m"])


def grew(growth: tuple[float, float] | None) -> bool:
    """Whether the crack grew in a shut-in while it was open: by at least
    :data:`GROWTH_MIN` and :data:`GROWTH_MIN_REL` of its length at shut-in."""
    if growth is None:
        return False
    a, b = growth
    return b - a >= GROWTH_MIN and b >= (1.0 + GROWTH_MIN_REL) * a


# --------------------------------------------------------------------------- evaluate
#: The outcome of one closure method in one cycle (:attr:`CycleCheck.outcomes`).
OUTCOMES = ("pass", "fail", "miss", "rejected", "unjudged", "none")


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
    kind : str
        The interpreter's kind of the cycle (``xlot``, ``lot``, ``dfit``, ...).
    outcomes : dict
        By method (``consensus`` included), one of :data:`OUTCOMES`: ``pass`` (picked and
        within its tolerance), ``fail`` (picked and outside it, or picked where the record
        holds no closure), ``miss`` (the record holds the closure this method reads and it
        picked none, or the interpreter rejected its pick), ``rejected`` (rejected by the
        interpreter where there was nothing to find), ``unjudged`` (picked where no rule
        judges it), ``none`` (no pick, none expected).
    rejected_errors : dict
        Relative error [-] of the picks the interpreter rejected, by method.
    g_diagnosis : str or None
        The G-function's decline diagnosis of the shut-in (None: no G-function pick, kept
        or rejected).
    growth : (float, float) or None
        The crack's half-length [m] when the shut-in starts and when its pressure falls to
        sigma_h (or at its end), from the model (None: not recorded).
    notes : dict
        By method without a kept value: why (the interpreter's rejection reason, or the
        picker's message, e.g. "no break in the decline").
    """

    cycle: int
    shutin_end_pressure: float | None
    closure_in_shutin: bool | None
    flowback_closure: bool
    errors: dict[str, float]
    failures: tuple[str, ...]
    shutin_judged: bool = False
    kind: str = ""
    outcomes: dict[str, str] = field(default_factory=dict)
    rejected_errors: dict[str, float] = field(default_factory=dict)
    g_diagnosis: str | None = None
    growth: tuple[float, float] | None = None
    notes: dict[str, str] = field(default_factory=dict)

    @property
    def tip_extension(self) -> bool:
        """The crack grew in the shut-in while open (:func:`grew`)."""
        return grew(self.growth)


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
    #: what test the scene is (:func:`scene_kind`)
    scene_kind: str = "xlot"
    #: [Pa] picked LOP of the first test cycle, at depth
    lop: float | None = None

    @property
    def passed(self) -> bool:
        return not self.failures and all(not c.failures for c in self.cycles)

    def realised(self, key: str) -> float:
        """Realised value [Pa] of ``sigma_h``, ``sigma_H`` or ``tensile_strength``."""
        return float(self.truth["realised_bar"][key]) * 1e5

    @property
    def leakoff(self) -> float | None:
        """The model's leak-off [Pa]: the well pressure when the wall's first cluster
        failed (``model_truth.initiation_pressure_bar``), None when not recorded."""
        v = (self.truth.get("model_truth") or {}).get("initiation_pressure_bar")
        return None if v is None else float(v) * 1e5


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


def _judge_cycle(c, rec, truth: dict[str, Any], sh: float, offset: float,
                 kind: str) -> CycleCheck:
    """The rules of :func:`evaluate` on one test cycle (``c``: its picks)."""
    from xlotkit.interpret.picks.core import SHUTIN_METHOD_NAMES
    from xlotkit.interpret.picks.details import RejectedDetails
    from xlotkit.interpret.picks.flowback import FLOWBACK_METHODS

    fails: list[str] = []
    methods = c.fcp_methods()
    errors = {m: (p.value + offset - sh) / sh
              for m, p in {**methods, "consensus": c.fcp}.items() if p.found}
    rejected = {m: (p.details.rejected_value + offset - sh) / sh
                for m, p in methods.items()
                if not p.found and isinstance(p.details, RejectedDetails)}
    # why a method has no value: the rejection's reason, or the picker's own message
    notes = {m: (p.details.reason if isinstance(p.details, RejectedDetails) else p.message)
             for m, p in {**methods, "consensus": c.fcp}.items() if not p.found}
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
        # closed in it: judge that claim like a closure in the record; the flowback then
        # starts closed (the picker rejects a break in it that contradicts the shut-in's
        # closure) and is not judged.
        judge_shutin, fb_closure = True, False
    else:
        judge_shutin = closure is True
    out: dict[str, str] = {}

    def judge(m: str, expected: bool, rtol: float | None, what: str) -> None:
        p = methods.get(m)
        if p is None:
            return
        if p.found:
            if rtol is None:
                out[m] = "unjudged"
            elif abs(errors[m]) > rtol:
                out[m] = "fail"
                fails.append(f"cycle {c.index}: {m} {errors[m]:+.1%} of sigma_h "
                             f"(allowed {rtol:.0%})")
            else:
                out[m] = "pass"
        elif expected:
            out[m] = "miss"
            if what:
                fails.append(f"cycle {c.index}: {m} found no closure in {what}"
                             + (" (its pick was rejected)" if m in rejected else ""))
        else:
            out[m] = "rejected" if m in rejected else "none"

    for m in FLOWBACK_METHODS:
        judge(m, fb_closure, FLOWBACK_RTOL if fb_closure else None,
              "a flowback through sigma_h")
    for m in SHUTIN_METHOD_NAMES:
        # "miss" is reported where the shut-in holds a closure; the rule asks only that
        # every method that picks is right (and, below, that one of them picks)
        judge(m, closure is True, SHUTIN_RTOL if judge_shutin else None, "")
        p = methods.get(m)
        if closure is False and p is not None and p.found:
            out[m] = "fail"
            fails.append(f"cycle {c.index}: {m} picked closure at {p.value / 1e5:.1f} bar "
                         "in a shut-in that ends above sigma_h")
    # the consensus: judged where the cycle's closure rests on the shut-in alone
    shut_only = closure is True and not fb_closure
    if c.fcp.found:
        if shut_only and abs(errors["consensus"]) > SHUTIN_RTOL:
            out["consensus"] = "fail"
            fails.append(f"cycle {c.index}: consensus {errors['consensus']:+.1%} of sigma_h "
                         f"(allowed {SHUTIN_RTOL:.0%})")
        elif fb_closure or judge_shutin:
            tol = FLOWBACK_RTOL if fb_closure else SHUTIN_RTOL
            out["consensus"] = "pass" if abs(errors["consensus"]) <= tol else "unjudged"
        else:
            out["consensus"] = "unjudged"
    elif shut_only or fb_closure:
        out["consensus"] = "miss"
        if shut_only:
            fails.append(f"cycle {c.index}: no closure picked in a shut-in that holds one "
                         f"(it ends {(p_end - sh) / sh:+.1%} of sigma_h)")
    else:
        out["consensus"] = "none"
    # tip extension: the crack grew in the shut-in while open; a G-function closure kept
    # there must say so (Barree's tip-extension signature), else it is a false reading of
    # the decline
    g = methods.get("g_function")
    diag = None
    if g is not None:
        d = g.details.original if isinstance(g.details, RejectedDetails) else g.details
        diag = getattr(d, "diagnosis", None)
    growth = _growth(truth, c.cycle)
    if grew(growth) and g is not None and g.found and diag != "tip_extension":
        fails.append(f"cycle {c.index}: g_function kept a closure at "
                     f"{(g.value + offset) / 1e5:.1f} bar diagnosed {diag!r} in a shut-in "
                     f"in which the crack grew {growth[0]:.1f} -> {growth[1]:.1f} m while "
                     "open (tip extension)")
    return CycleCheck(c.index, p_end, closure, fb_closure, errors, tuple(fails),
                      shutin_judged=judge_shutin, kind=c.kind, outcomes=out,
                      rejected_errors=rejected, g_diagnosis=diag, growth=growth,
                      notes={m: str(v or "") for m, v in notes.items()})


def evaluate(entry: Entry) -> Evaluation:
    """Read the entry's stored log, pick it as a field log and check against its truth.

    The tolerances are issue 7's: the flowback system-stiffness FCP within
    :data:`FLOWBACK_RTOL` (3 %) of the realised sigma_h where the flowback goes through
    closure; every shut-in method within :data:`SHUTIN_RTOL` (5 %) where the shut-in
    holds a closure and "no closure" where it clearly does not. Issue 17 adds, by what the
    scene is (:func:`scene_kind`) and what its crack did:

    * a shut-in that holds a closure with no flowback through closure after it (a DFIT's
      falloff, a shut-in-only cycle): a closure is picked (the consensus), within 5 %;
    * a shut-in in which the crack grew while open (:func:`grew`, from the model's phase
      record): a G-function closure kept there is diagnosed tip extension;
    * a DFIT: its falloff holds a closure (the scene does what it says);
    * a LOT stopped before breakdown: no FBP picked, an LOP picked within
      :data:`LOP_RTOL` of the model's leak-off (the well pressure at the first failure).

    The stress estimate gets the scene's pore pressure (``imposed_bar.pore_pressure``), as
    a field interpretation gets it from the pore-pressure prediction: the library checks
    the picks and Eq. C.19, not the interpreter's hydrostatic default (1.03 sg), which
    would put the scene's own choice of p0 into the sigma_H error. A surface-gauge log
    (``output.gauge = "surface"``) gets the open hole's TVD from the log's metadata
    (``meta.tvd``), as the field interpreter gives ``--tvd``; its pressures are taken to
    depth by the interpreter's own hydrostatic column.
    """
    from xlotkit.interpret.estimate import StressInputs
    from xlotkit.interpret.io import read_log
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
    general: list[str] = []
    offset = _depth_offset(interp)
    if offset is None:
        offset = 0.0
        if rec.reference.kind != "bottomhole":
            general.append("no stress estimate: the gauge's picks cannot be taken to depth")
    kind = scene_kind(truth)
    cycles = interp.picks.test_cycles
    if not cycles:
        general.append("no test cycle found in the log")
    checks = [_judge_cycle(c, rec, truth, sh, offset, kind) for c in cycles]
    s = interp.stress
    sig_H = None
    if s.available and s.sigma_H:
        est = s.sigma_H.get("C.19") or next(iter(s.sigma_H.values()))
        sig_H = est.get("value")

    def first(name: str, cs) -> Any:
        return next((c.get(name) for c in cs if c.get(name) is not None
                     and c.get(name).found), None)

    fbp = first("FBP", cycles[:1])
    pr = first("Pr", cycles[1:])
    lop = first("LOP", cycles[:1])
    ev_lop = lop.value + offset if lop is not None else None
    ev = Evaluation(entry, truth, tuple(checks), s.t0 if s.available else None, sig_H,
                    s.sigma_h if s.available else None, (),
                    fbp=fbp.value + offset if fbp is not None else None,
                    pr=pr.value + offset if pr is not None else None, depth_offset=offset,
                    interpretation=interp, scene_kind=kind, lop=ev_lop)
    if kind == "lot":
        if ev.fbp is not None:
            general.append(f"FBP picked at {ev.fbp / 1e5:.1f} bar in a LOT that the model "
                           "never broke down")
        lo = ev.leakoff
        if ev_lop is None:
            general.append("no LOP picked in a LOT past the wall's first failure")
        elif lo is not None and abs(ev_lop - lo) > LOP_RTOL * lo:
            general.append(f"LOP {ev_lop / 1e5:.1f} bar, {(ev_lop - lo) / lo:+.1%} of the "
                           f"model's leak-off {lo / 1e5:.1f} bar (allowed {LOP_RTOL:.0%})")
    if kind == "dfit" and checks and checks[0].closure_in_shutin is not True:
        general.append("the DFIT's falloff does not fall more than "
                       f"{CLOSURE_MARGIN:.0%} below sigma_h: no closure in the record")
    return dataclasses.replace(ev, failures=tuple(general))


def _pct(v: float | None, ref: float) -> str:
    return "–" if v is None else f"{100 * (v - ref) / ref:+.1f} %"


def _bar_pct(v: float | None, ref: float | None) -> str:
    """``value [bar] (error %)`` or a dash."""
    if v is None:
        return "–"
    if ref is None:
        return f"{v / 1e5:.1f}"
    return f"{v / 1e5:.1f} ({_pct(v, ref)})"


def _bar(v: float | None) -> str:
    return "–" if v is None else f"{v / 1e5:.1f}"


#: How each outcome reads in a table cell (``{e}``: the error in %).
_CELL = {"pass": "{e}", "fail": "{e} ✗", "unjudged": "({e})", "miss": "miss",
         "rejected": "rej. {e}", "none": "–"}

_DIAG = {"normal": "normal", "pressure_dependent_leakoff": "PDL",
         "tip_extension": "tip ext.", "height_recession": "height rec.",
         "undetermined": "undet."}


def _cell(c: CycleCheck, m: str) -> str:
    o = c.outcomes.get(m)
    e = c.errors.get(m)
    if o is None:           # a cycle checked before outcomes existed, or a method not run
        return "–" if e is None else f"{100 * e:+.2f} %"
    if o == "miss" and m in c.rejected_errors:
        return f"miss (rej. {100 * c.rejected_errors[m]:+.2f} %)"
    if o == "rejected":
        e = c.rejected_errors.get(m)
    return _CELL[o].format(e="" if e is None else f"{100 * e:+.2f} %").strip()


def evaluation_markdown(evals: Iterable[Evaluation]) -> str:
    """Markdown tables of the picks against the realised stresses: one row per cycle
    (every closure method's error against the realised sigma_h, with what each outcome
    was: within its tolerance, outside it (✗), not judged (in brackets), a miss, rejected
    by the interpreter, or nothing to find (–); the interpreter's kind of the cycle, the
    G-function's diagnosis, the crack's growth in the shut-in while open; whether the
    shut-in and a flowback hold a closure, i.e. which rules judged the cycle; whether it
    passed), then one row per scene (what test it is; sigma_h estimate, LOP against the
    model's leak-off, FBP and Pr at depth, T0 = FBP - Pr and sigma_H by Eq. C.19 against
    the realised values; the scene's own misses), then the per-method tables
    (:func:`methods_markdown`)."""
    methods = ("flowback_sqrt_p", "flowback_p_v", "tangent", "sqrt_t", "g_function",
               "bilinear", "compliance", "consensus")
    lines = [("| scene | model | cycle | kind | flowback √p–t | flowback p–V | tangent | √t | "
              "G | bilinear | compliance | consensus | G diagnosis | crack in shut-in [m] | "
              "shut-in closure | flowback closure | passed |"),
             "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|---|---|"]
    evals = list(evals)
    for ev in evals:
        model = ev.truth.get("model", "")
        for c in ev.cycles:
            clo = {True: "yes", False: "no", None: "–"}[c.closure_in_shutin]
            if c.closure_in_shutin is None and c.shutin_judged:
                clo = "picked"      # ends within the margin, its methods picked closure
            diag = "–" if c.g_diagnosis is None else _DIAG.get(c.g_diagnosis, c.g_diagnosis)
            growth = ("–" if c.growth is None else
                      f"{c.growth[0]:.1f} → {c.growth[1]:.1f}"
                      + (" (grew)" if c.tip_extension else ""))
            cells = " | ".join(_cell(c, m) for m in methods)
            lines.append(
                f"| {ev.entry.name} | {model} | {c.cycle} | {c.kind or '–'} | {cells} | "
                f"{diag} | {growth} | {clo} | {'yes' if c.flowback_closure else 'no'} | "
                f"{'yes' if not c.failures else 'NO'} |")
    lines += ["", ("| scene | test | realised σh [bar] | picked σh | model leak-off [bar] | "
                   "LOP [bar] | FBP [bar] | Pr [bar] | realised T0 [bar] | "
                   "T0 = FBP − Pr [bar] | realised σH [bar] | σH (C.19) [bar] | scene rules |"),
              "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for ev in evals:
        sh, sH, t0 = (ev.realised(k) for k in ("sigma_h", "sigma_H", "tensile_strength"))
        lo = ev.leakoff
        rules = "; ".join(ev.failures) if ev.failures else "passed"
        lines.append(f"| {ev.entry.name} | {ev.scene_kind} | {sh / 1e5:.1f} | "
                     f"{_pct(ev.sigma_h, sh)} | {_bar(lo)} | {_bar_pct(ev.lop, lo)} | "
                     f"{_bar(ev.fbp)} | {_bar(ev.pr)} | {t0 / 1e5:.1f} | "
                     f"{_bar_pct(ev.t0, t0)} | {sH / 1e5:.1f} | {_bar_pct(ev.sigma_H, sH)} | "
                     f"{rules} |")
    return "\n".join(lines) + "\n\n" + methods_markdown(evals)


#: The closure methods of the per-method tables, with their labels.
_METHODS = (("flowback_sqrt_p", "flowback √p–t"), ("flowback_p_v", "flowback p–V"),
            ("tangent", "tangent"), ("sqrt_t", "√t"), ("g_function", "G-function"),
            ("bilinear", "bilinear"), ("compliance", "compliance"),
            ("consensus", "consensus (record closure)"))

#: How each outcome reads in the per-method table.
_OUTCOME_TEXT = {"pass": "within tolerance", "fail": "outside tolerance", "miss": "miss",
                 "rejected": "rejected", "unjudged": "not judged", "none": "no pick"}


def _short(note: str, limit: int = 140) -> str:
    """A note for a table cell: its first sentence, at most ``limit`` characters, with no
    character that breaks a Markdown table."""
    note = " ".join(str(note).replace("|", "/").split())
    first = note.split("; ")[0].split(". ")[0]
    return first if len(first) <= limit else first[:limit - 1].rstrip() + "…"


def method_rows(evals: Iterable[Evaluation]) -> list[dict[str, Any]]:
    """Every closure method's result in every cycle of every scene: one dict per (scene,
    cycle, method) with ``scene``, ``cycle``, ``kind``, ``method``, ``outcome`` (one of
    :data:`OUTCOMES`), ``value_bar`` (the pick at depth, kept or rejected; None without
    one), ``err_realised`` and ``err_imposed`` (relative error [-] against the realised and
    the imposed sigma_h; None without a value) and ``note`` (why there is no kept value)."""
    out = []
    for ev in evals:
        sh = ev.realised("sigma_h")
        imp = float(ev.truth["imposed_bar"]["sigma_h"]) * 1e5
        if not ev.cycles:
            # no test cycle: no method ran; one row says so, with how the interpreter read
            # the record (each cycle's classification)
            why = "; ".join(ev.failures) or "no test cycle"
            if ev.interpretation is not None:
                why += "; " + "; ".join(c.cycle.reason for c in ev.interpretation.picks.cycles)
            out.append({"scene": ev.entry.name, "cycle": None, "kind": "",
                        "method": "all", "outcome": "miss", "value_bar": None,
                        "err_realised": None, "err_imposed": None, "note": why})
        for c in ev.cycles:
            for m, _ in _METHODS:
                o = c.outcomes.get(m)
                if o is None:
                    continue
                e = c.errors.get(m, c.rejected_errors.get(m))
                v = None if e is None else sh * (1.0 + e)
                out.append({"scene": ev.entry.name, "cycle": c.cycle, "kind": c.kind,
                            "method": m, "outcome": o,
                            "value_bar": None if v is None else v / 1e5,
                            "err_realised": e,
                            "err_imposed": None if v is None else (v - imp) / imp,
                            "note": "" if m in c.errors else c.notes.get(m, "")})
    return out


def methods_markdown(evals: Iterable[Evaluation], *, per_pick: bool = True) -> str:
    """Markdown tables of every closure method against the realised sigma_h: a summary by
    method (kept picks, their outcomes, the median and largest absolute error against the
    realised and the median against the imposed sigma_h, misses and rejections), then one
    row per scene, cycle and method that picked, was rejected or missed (a method with no
    pick where the record holds nothing for it is counted in the summary only), with the
    picked value at depth, both errors and, for a miss or a rejection, why. A scene in which
    the interpreter found no test cycle gets one row ("every method") with how it read the
    record, and counts as a miss of every method. ``per_pick=False``: the summary only."""
    rows = method_rows(evals)
    lines = ["| method | kept picks | within tolerance | outside | not judged | misses | "
             "rejected | no pick | median abs. error vs realised σh | largest | "
             "median abs. error vs imposed σh |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for m, label in _METHODS:
        mine = [r for r in rows if r["method"] == m]
        kept = [r for r in mine if r["outcome"] in ("pass", "fail", "unjudged")]
        n = {o: sum(r["outcome"] == o for r in mine) for o in OUTCOMES}
        # a scene with no test cycle is a miss of every method
        n["miss"] += sum(r["method"] == "all" for r in rows)
        er = [abs(r["err_realised"]) for r in kept]
        ei = [abs(r["err_imposed"]) for r in kept]

        def pc(v: float | None) -> str:
            return "–" if v is None else f"{100 * v:.2f} %"

        lines.append(f"| {label} | {len(kept)} | {n['pass']} | {n['fail']} | "
                     f"{n['unjudged']} | {n['miss']} | {n['rejected']} | {n['none']} | "
                     f"{pc(float(np.median(er)) if er else None)} | "
                     f"{pc(max(er) if er else None)} | "
                     f"{pc(float(np.median(ei)) if ei else None)} |")
    if not per_pick:
        return "\n".join(lines) + "\n"
    lines += ["", "| scene | cycle | kind | method | picked [bar] | vs realised σh | "
              "vs imposed σh | outcome | why no kept value |",
              "|---|---:|---|---|---:|---:|---:|---|---|"]
    labels = {**dict(_METHODS), "all": "every method"}
    for r in rows:
        if r["outcome"] == "none":
            continue
        e, i, v = r["err_realised"], r["err_imposed"], r["value_bar"]
        note = r["note"]
        note = "" if not note else (_short(note) if r["method"] != "all"
                                    else " ".join(note.replace("|", "/").split()))
        lines.append(
            f"| {r['scene']} | {r['cycle'] or '–'} | {r['kind'] or '–'} | "
            f"{labels[r['method']]} | "
            f"{'–' if v is None else f'{v:.1f}'} | "
            f"{'–' if e is None else f'{100 * e:+.2f} %'} | "
            f"{'–' if i is None else f'{100 * i:+.2f} %'} | {_OUTCOME_TEXT[r['outcome']]} | "
            f"{note} |")
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
