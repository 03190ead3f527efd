"""Sweeps: many cases of one scene, each simulated and its synthetic log picked as a field log.

:func:`run_sweep` (``xlotkit sweep``) makes the cases of a :class:`SweepSpec` (a grid of
``--vary`` lists, or ``--samples N`` Latin-hypercube draws from ranges,
:mod:`xlotkit.study.cases`), validates every case's scene before anything runs, and runs
each unfinished case with :func:`run_case` on an executor. A case's folder
``DIR/cases/<id>/`` is laid out as an entry of the synthetic library
(:mod:`xlotkit.library`), so ``xlotkit library check DIR/cases`` works on a sweep::

    scene.toml      the case's scene, resolved (SI; ``xlotkit simulate`` runs it alone)
    case.json       the case's position and the values it gives the varied keys
    run/            what ``xlotkit simulate`` writes (time series, synthetic log, summary;
                    a checkpoint while it runs)
    log.csv         the synthetic log (a hard link to run/synthetic_log.csv where the file
                    system has them); truth.json: the run's summary (imposed, realised)
    case.log        what happened, with the traceback of a failure
    result.json     the case's row (written last: the case has finished)

The log is read back through :func:`xlotkit.interpret.io.read_log` and picked and compared
with the imposed and realised stresses by :func:`xlotkit.library.evaluate` (the same checks
as ``xlotkit library check``). The case's identity ``<id>`` is the first 16 hex digits of
the SHA-256 of its resolved scene (:meth:`xlotkit.sim.scene.Scene.to_toml`): a rerun into
the same DIR skips the finished cases, continues a simulation that was interrupted from its
checkpoint, and runs the rest.

Row columns (pressures in bar, at the open hole; relative errors as fractions)
------------------------------------------------------------------------------
``case, index, status, message``; each varied key as given and as the scene's value
(``<key>``, ``<key>_si``: SI, angles in degrees); ``model, seed, sim_status, sim_message,
steps, simulated_time_s, max_mass_balance_error``; the truth ``{sigma_h, sigma_H, t0,
p0}_{imposed, realised}_bar`` and ``fbp_model_bar``; the picks ``fbp_bar, pr_bar``
(breakdown of the first test cycle, reopening of the first later one), ``isip_bar`` (first
test cycle), ``t0_bar`` (FBP - Pr), ``sigma_h_bar`` and ``sigma_H_bar`` (the stress
estimate, Eq. C.19), each with ``_err_imposed`` and ``_err_realised`` (``fbp_err_model``
against the model's breakdown); per test cycle k (1, 2, ...) ``test<k>_fcp_<method>_bar``
and its ``_err_imposed`` / ``_err_realised`` for every closure method and the consensus,
``test<k>_isip_bar``, ``test<k>_fbp_bar``, ``test<k>_pr_bar``; ``library_passed`` and
``library_failures`` (issue 7's tolerances); ``wall_time_s, sim_wall_time_s,
pick_wall_time_s``. A failed case has ``status = "failed"`` and the error's one line in
``message``; a case its worker never returned has ``status = "lost"`` and runs again on
the next run.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import time
import tomllib
import traceback
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import date, datetime, time as dtime
from pathlib import Path
from typing import Any

from xlotkit.atomic import atomic_write, atomic_write_text
from xlotkit.errors import InputError, XlotkitError
from xlotkit.study.cases import BaseScene, Case, Variation, grid, parse_vary, sample, scene_of
from xlotkit.study.driver import Item, Progress, StudyResult, drive
from xlotkit.study.executors import Executor
from xlotkit.study.table import StudyFolder, dumps, write_result

__all__ = ["CaseTask", "SweepPlan", "SweepSpec", "plan_sweep", "run_case", "run_sweep"]

CASES = "cases"
_BAR = 1e5


# --------------------------------------------------------------------------- spec
@dataclass(frozen=True)
class SweepSpec:
    """What to sweep.

    Attributes
    ----------
    scene_file : str
        The scene every case starts from.
    variations : tuple of Variation
        One per ``--vary``.
    samples : int or None
        None: the full grid of the lists; N: N Latin-hypercube draws.
    seed : int
        Seed of the draws (``samples`` only).
    """

    scene_file: str
    variations: tuple[Variation, ...]
    samples: int | None = None
    seed: int = 0

    @classmethod
    def from_options(cls, scene_file: str | Path, vary: Sequence[str],
                     samples: int | None = None, seed: int | None = None) -> SweepSpec:
        """From the command line's ``--vary`` texts, ``--samples`` and ``--seed``.

        Raises
        ------
        InputError
            For a ``--vary`` that cannot be read, or ``--seed`` without ``--samples``.
        """
        if seed is not None and samples is None:
            raise InputError("a seed is for drawn cases", key="--seed",
                             expected="--samples N with --seed S (a grid draws nothing)")
        return cls(str(scene_file), tuple(parse_vary(v) for v in vary), samples,
                   0 if seed is None else seed)

    def cases(self) -> list[Case]:
        """The cases (grid or samples)."""
        if self.samples is None:
            return grid(self.variations)
        return sample(self.variations, self.samples, self.seed)

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (kept in study.json)."""
        return {"scene_file": self.scene_file,
                "vary": [v.text for v in self.variations],
                "samples": self.samples,
                "sampling": None if self.samples is None else "latin hypercube",
                "seed": self.seed if self.samples is not None else None}


@dataclass(frozen=True)
class CaseTask:
    """Everything a worker needs to run one case (picklable, no open files).

    Attributes
    ----------
    case_id : str
    index : int
    folder : str
        The case's folder.
    scene_file : str
        The base scene file (errors; relative mesh files).
    mapping : dict
        The case's scene as a TOML mapping (overrides applied).
    inputs : tuple of (key, value as given, scene value or None)
    """

    case_id: str
    index: int
    folder: str
    scene_file: str
    mapping: dict[str, Any]
    inputs: tuple[tuple[str, Any, Any], ...]


@dataclass(frozen=True)
class SweepPlan:
    """A validated sweep: the base scene and one task per case, in order."""

    spec: SweepSpec
    base: BaseScene
    tasks: tuple[CaseTask, ...]


def _jsonable(v: Any) -> Any:
    """A TOML value as JSON (date-times as ISO text)."""
    if isinstance(v, (datetime, date, dtime)):
        return v.isoformat()
    if isinstance(v, list):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    return v


def _scalar(v: Any) -> Any:
    """A value for a table cell: numbers, text and booleans as they are, others as text."""
    v = _jsonable(v)
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    return json.dumps(v)


def plan_sweep(spec: SweepSpec, out: str | Path) -> SweepPlan:
    """Make and validate every case of a sweep.

    Raises
    ------
    InputError
        For a scene file that is not valid, a bad ``--vary`` key or value (naming it and
        the case), or two cases that are the same scene.
    """
    base = BaseScene.load(spec.scene_file)
    cases_dir = Path(out) / CASES
    tasks, seen = [], {}
    for case in spec.cases():
        mapping = base.case_mapping(case)
        scene = scene_of(mapping, base.file, case)
        text = scene.to_toml()
        cid = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
        if cid in seen:
            raise InputError(f"cases {seen[cid]} and {case.index} are the same scene "
                             f"({case.inputs()})", key="--vary",
                             expected="values that differ (e.g. not 300 bar and 30 MPa)")
        seen[cid] = case.index
        resolved = tomllib.loads(text)
        inputs = tuple((k.text, v, k.get(resolved)) for k, v in case.overrides)
        tasks.append(CaseTask(cid, case.index, str(cases_dir / cid), base.file, mapping,
                              inputs))
    return SweepPlan(spec, base, tuple(tasks))


def run_sweep(spec: SweepSpec, out: str | Path, *, executor: Executor | None = None,
              progress: Progress | None = None, plan: SweepPlan | None = None) -> StudyResult:
    """Run a sweep into ``out`` (or continue it there) and write its table.

    Parameters
    ----------
    spec : SweepSpec
    out : str or Path
        The study folder (``--out``): new, empty, or holding this same sweep.
    executor : Executor, optional
        Default: a local process pool on every CPU.
    progress : callable, optional
        ``progress(fraction, message)`` as cases finish.
    plan : SweepPlan, optional
        ``plan_sweep(spec, out)`` made already (it is not made twice).

    Returns
    -------
    StudyResult

    Raises
    ------
    InputError
        Before anything runs: a bad scene or ``--vary``, or ``out`` holding other results.
    """
    t0 = time.perf_counter()
    if plan is None:
        plan = plan_sweep(spec, out)
    elif plan.spec != spec:
        raise ValueError("the plan is of another sweep")
    folder = StudyFolder.open(out, "sweep", CASES, [t.case_id for t in plan.tasks],
                              spec.describe())
    items = [Item(t.case_id, t.index, t, f"case {t.index} ({t.case_id})") for t in plan.tasks]
    return drive(folder, items, run_case, _lost_rows, executor=executor, progress=progress,
                 what="cases", t_start=t0, order=_order)


_TEST = re.compile(r"^test(\d+)_(.*)$")


def _order(columns: list[str]) -> list[str]:
    """The per-test-cycle columns together, cycle by cycle, each cycle's in one order (the
    order they first appear in any cycle), where the first of them appeared."""
    tests = [c for c in columns if _TEST.match(c)]
    if not tests:
        return columns
    suffixes: dict[str, None] = {}
    for c in tests:
        suffixes.setdefault(_TEST.match(c).group(2), None)
    rank = {s: i for i, s in enumerate(suffixes)}
    tests.sort(key=lambda c: (int(_TEST.match(c).group(1)), rank[_TEST.match(c).group(2)]))
    at = columns.index(next(c for c in columns if _TEST.match(c)))
    rest = [c for c in columns if not _TEST.match(c)]
    return rest[:at] + tests + rest[at:]


# --------------------------------------------------------------------------- one case
def _head(task: CaseTask) -> dict[str, Any]:
    row: dict[str, Any] = {"case": task.case_id, "index": task.index, "status": "",
                           "message": ""}
    for key, given, value in task.inputs:
        row[key] = _scalar(given)
        row[f"{key}_si"] = value if isinstance(value, (int, float)) and \
            not isinstance(value, bool) else None
    return row


def _lost_rows(item: Item, message: str) -> list[dict[str, Any]]:
    row = _head(item.task)
    row.update(status="lost", message=f"{message}; rerun the sweep to run it again")
    return [row]


def _one_line(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    text = lines[0] if lines else ""
    return text if isinstance(exc, XlotkitError) else f"{type(exc).__name__}: {text}"


def _rel(v: float | None, ref: float | None) -> float | None:
    if v is None or ref is None or ref == 0:
        return None
    return (v - ref) / ref


def _bar(v: float | None) -> float | None:
    return None if v is None else float(v) / _BAR


def _simulate(scene, run: Path, log: list[str]):
    """Simulate into ``run``, or continue or reuse what an earlier run of the case left
    there; returns the summary (``summary.json``) and the wall time of this call [s]."""
    from xlotkit.sim.run import simulate

    t0 = time.perf_counter()
    if (run / "summary.json").is_file():
        log.append("simulation: finished by an earlier run, kept")
    elif (run / "checkpoint.npz").is_file():
        res = simulate(scene, run, resume=True)
        log.append(f"simulation (resumed from its checkpoint): {res.summary}")
    else:
        if run.exists():
            # an earlier run of this case stopped before its first checkpoint: nothing in
            # the folder is a result (no summary, no checkpoint), start it again
            shutil.rmtree(run)
            log.append("simulation: the earlier run left no checkpoint, started again")
        res = simulate(scene, run)
        log.append(f"simulation: {res.summary}")
    summary = json.loads((run / "summary.json").read_text())
    return summary, time.perf_counter() - t0


def _link(src: Path, dst: Path) -> None:
    """``dst`` the same file as ``src`` (a hard link, so the log is stored once; a copy
    where the file system has none), put in place atomically."""

    def write(tmp: Path) -> None:
        tmp.unlink()
        try:
            os.link(src, tmp)
        except OSError:
            shutil.copyfile(src, tmp)

    atomic_write(dst, write)


def run_case(task: CaseTask) -> list[dict[str, Any]]:
    """Simulate one case, pick its synthetic log and write its folder (module docstring).

    Every error of the case is caught: the row then has ``status = "failed"`` and the
    error's one line, the traceback goes to ``case.log``. Returns the case's one row.
    """
    from xlotkit.library import Entry, evaluate

    t0 = time.perf_counter()
    folder = Path(task.folder)
    folder.mkdir(parents=True, exist_ok=True)
    row = _head(task)
    log = [f"case {task.index} ({task.case_id}) of a sweep of {task.scene_file}",
           "inputs: " + ", ".join(f"{k} = {g!r}" for k, g, _ in task.inputs)]
    stage = "scene"
    sim_wall = pick_wall = None
    try:
        scene = scene_of(task.mapping, task.scene_file)
        atomic_write_text(folder / "scene.toml", scene.to_toml())
        atomic_write_text(folder / "case.json", dumps(
            {"case": task.case_id, "index": task.index, "scene_file": task.scene_file,
             "inputs": {k: _jsonable(g) for k, g, _ in task.inputs}}))
        log.append(f"alone: xlotkit simulate {(folder / 'scene.toml').as_posix()} --out DIR")
        row.update(model=scene.resolved_model, seed=int(scene.seed))
        stage = "simulate"
        summary, sim_wall = _simulate(scene, folder / "run", log)
        _link(folder / "run" / "synthetic_log.csv", folder / "log.csv")
        entry = Entry(task.case_id, folder)
        truth = {"name": task.case_id, "command": entry.command(), "wall_time_s": sim_wall,
                 **{k: v for k, v in summary.items() if k != "files"}}
        atomic_write_text(folder / "truth.json", dumps(truth))
        stage = "pick"
        tp = time.perf_counter()
        ev = evaluate(entry)
        pick_wall = time.perf_counter() - tp
        row.update(_truth_columns(summary))
        row.update(_pick_columns(ev, summary))
        row["status"] = "ok"
        log.append(f"picks: {'passed' if ev.passed else 'missed'} the library's checks"
                   + "".join(f"\n  {f}" for f in row["library_failures"].split("; ") if f))
    except Exception as exc:
        row["status"] = "failed"
        row["message"] = f"{stage}: {_one_line(exc)}"
        log.append(f"FAILED in {stage}: {_one_line(exc)}")
        log.append(traceback.format_exc())
    row["wall_time_s"] = time.perf_counter() - t0
    row["sim_wall_time_s"] = sim_wall
    row["pick_wall_time_s"] = pick_wall
    log.append(f"status {row['status']}; {row['wall_time_s']:.2f} s")
    atomic_write_text(folder / "case.log", "\n".join(log) + "\n")
    write_result(folder, [row])
    return [row]


def _truth_columns(summary: Mapping[str, Any]) -> dict[str, Any]:
    imp, rea = summary["imposed_bar"], summary["realised_bar"]
    out: dict[str, Any] = {
        "sim_status": summary.get("status"), "sim_message": summary.get("message"),
        "steps": summary.get("steps"), "simulated_time_s": summary.get("simulated_time_s"),
        "max_mass_balance_error": summary.get("max_mass_balance_error"),
    }
    for key, name in (("sigma_h", "sigma_h"), ("sigma_H", "sigma_H"),
                      ("tensile_strength", "t0"), ("pore_pressure", "p0")):
        out[f"{name}_imposed_bar"] = imp.get(key)
        out[f"{name}_realised_bar"] = rea.get(key)
    out["fbp_model_bar"] = summary.get("fbp_bar")
    return out


def _pick_columns(ev, summary: Mapping[str, Any]) -> dict[str, Any]:
    """The picks of an :class:`xlotkit.library.Evaluation` at the open hole [bar] with
    their relative errors against the imposed and realised values."""
    imp = {k: v * _BAR for k, v in summary["imposed_bar"].items()}
    rea = {k: v * _BAR for k, v in summary["realised_bar"].items()}
    fbp_model = summary.get("fbp_bar")
    fbp_model = None if fbp_model is None else fbp_model * _BAR
    off = ev.depth_offset
    cycles = ev.interpretation.picks.test_cycles
    out: dict[str, Any] = {"test_cycles": len(cycles)}
    first = cycles[0].get("ISIP") if cycles else None
    out["fbp_bar"] = _bar(ev.fbp)
    out["fbp_err_model"] = _rel(ev.fbp, fbp_model)
    out["pr_bar"] = _bar(ev.pr)
    out["isip_bar"] = _bar(first.value + off) if first is not None and first.found else None
    for name, v, key in (("t0", ev.t0, "tensile_strength"), ("sigma_h", ev.sigma_h, "sigma_h"),
                         ("sigma_H", ev.sigma_H, "sigma_H")):
        out[f"{name}_bar"] = _bar(v)
        out[f"{name}_err_imposed"] = _rel(v, imp[key])
        out[f"{name}_err_realised"] = _rel(v, rea[key])
    for k, (c, check) in enumerate(zip(cycles, ev.cycles), start=1):
        p = f"test{k}_"
        for m, pk in {**c.fcp_methods(), "consensus": c.fcp}.items():
            v = pk.value + off if pk.found else None
            out[f"{p}fcp_{m}_bar"] = _bar(v)
            out[f"{p}fcp_{m}_err_imposed"] = _rel(v, imp["sigma_h"])
            out[f"{p}fcp_{m}_err_realised"] = check.errors.get(m) if pk.found else None
        for name in ("ISIP", "FBP", "Pr"):
            pk = c.get(name)
            out[f"{p}{name.lower()}_bar"] = (_bar(pk.value + off) if pk is not None
                                             and pk.found else None)
    failures = [*ev.failures, *(f for c in ev.cycles for f in c.failures)]
    out["library_passed"] = ev.passed
    out["library_failures"] = "; ".join(failures)
    return out
