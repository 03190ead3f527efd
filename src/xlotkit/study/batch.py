"""Batch interpretation: every log of an archive picked on its own (``xlotkit pick --batch``).

:func:`run_batch` expands the inputs (files, folders: the files directly inside, and glob
patterns, ``**`` recursive), reads every file once on the executor to learn its kind and
clock span (:func:`survey_log`), groups them (:func:`group_logs`) and interprets each group
with :func:`interpret_group`: :func:`xlotkit.interpret.io.read_logs` (a surface + downhole
pair merged onto one clock, as ``xlotkit pick A B`` merges the two logs it is given) and
:func:`xlotkit.pipeline.interpret_record`, then
:func:`xlotkit.pipeline.write_interpretation` into the group's folder.

Grouping: a cementing-unit (surface) log and a downhole-gauge log in the same folder are a
pair when their recorded clock spans overlap once either is shifted by at most the largest
clock offset the merge searches (``max_offset_s``, 4 h: the loggers' clocks may disagree by
that much); of several candidates the pair with the longest overlap is taken first, and a
log is in one pair at most. Every other log is a group of its own. A file that cannot be
read is a group of its own with ``status = "failed"`` and the reader's one-line error.

Every group's folder ``DIR/logs/<id>/`` holds the interpretation (picks.csv, picks.json,
plots), ``group.log`` and ``result.json``; it is made as ``.<id>.partial`` and renamed when
complete, so a folder ``<id>`` is always a finished one. ``<id>`` is the first 16 hex digits
of the SHA-256 of the group's files (paths and contents) and the pick and stress options: a
rerun into the same DIR interprets only what is not finished.

Row columns (one row per test cycle; pressures in bar on the record's reference, the
stress at the target depth)
-----------------------------------------------------------------------------------
``log, index, files, status, message, reference, clock_offset_s, cycle, cycle_kind,
t_start_s, t_end_s``; for LOP, FBP, Pr, FPP, ISIP and the consensus FCP and every FCP
method ``<name>_bar, <name>_low_bar, <name>_high_bar, <name>_quality`` (``fcp_<method>_...``
for the methods); ``stiffness_bar_per_m3``; the log's stress estimate ``sigma_h_bar,
sigma_h_low_bar, sigma_h_high_bar, sigma_h_cycle, t0_bar, sigma_H_bar`` (Eq. C.19),
``regime, target_tvd_m``; ``wall_time_s``. A log without a test cycle has one row with
``status = "no test cycle"``.
"""

from __future__ import annotations

import functools
import glob
import hashlib
import os
import shutil
import time
import traceback
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

from xlotkit.atomic import atomic_write_text
from xlotkit.errors import InputError, XlotkitError
from xlotkit.study.driver import Item, Progress, StudyResult, drive
from xlotkit.study.executors import Executor, LocalPool, Lost, default_workers
from xlotkit.study.table import StudyFolder, write_result

__all__ = [
    "BatchSpec",
    "GroupTask",
    "LogGroup",
    "LogInfo",
    "expand_inputs",
    "group_logs",
    "interpret_group",
    "run_batch",
    "survey_log",
]

LOGS = "logs"
_BAR = 1e5
#: Largest clock offset between a surface and a downhole logger [s] (as the merge searches).
MAX_OFFSET_S = 4 * 3600.0
_PICKS = ("LOP", "FBP", "Pr", "FPP", "ISIP")


# --------------------------------------------------------------------------- spec
@dataclass(frozen=True)
class BatchSpec:
    """What to interpret.

    Attributes
    ----------
    inputs : tuple of str
        Files, folders and glob patterns.
    options : PickOptions or None
        Windows and methods for every log (``--window``, ``--method``).
    stress_inputs : StressInputs or None
        Depths, densities, gradients for every log (``--tvd``, ...).
    max_offset_s : float
        Largest clock offset between a surface and a downhole logger [s].
    read_options : ReadOptions or None
        What the files do not say, for every file (``--column``, ``--unit``, ``--sheet``,
        ``--date-order``, ``--decimal``; :func:`xlotkit.interpret.io.read_options`).
    """

    inputs: tuple[str, ...]
    options: Any = None
    stress_inputs: Any = None
    max_offset_s: float = MAX_OFFSET_S
    read_options: Any = None


def expand_inputs(inputs: Sequence[str]) -> list[Path]:
    """The files named by paths, folders (their files, not recursive, hidden ones left out)
    and glob patterns (``**`` recursive), each once, sorted.

    Raises
    ------
    InputError
        For an input that names nothing, or when no file is left.
    """
    found: dict[Path, None] = {}
    for text in inputs:
        p = Path(text)
        if p.is_file():
            found.setdefault(p.resolve(), None)
            continue
        if p.is_dir():
            files = sorted(f for f in p.iterdir() if f.is_file() and not f.name.startswith("."))
            if not files:
                raise InputError("the folder holds no files", file=text, key="--batch",
                                 expected="a folder of logs, a log, or a glob pattern")
            for f in files:
                found.setdefault(f.resolve(), None)
            continue
        hits = sorted(Path(h) for h in glob.glob(text, recursive=True))
        hits = [h for h in hits if h.is_file()]
        if not hits:
            raise InputError("no such file, folder or matching file", file=text,
                             key="--batch", expected="a log, a folder of logs or a glob "
                                                     "pattern such as 'archive/*.txt'")
        for h in hits:
            found.setdefault(h.resolve(), None)
    return sorted(found)


# --------------------------------------------------------------------------- survey
@dataclass(frozen=True)
class LogInfo:
    """What grouping needs to know of one file.

    Attributes
    ----------
    path : str
    sha256 : str
        Hash of the file's bytes.
    kind : str or None
        The record's pressure reference (``surface``, ``downhole``, ``bottomhole``); None
        when it could not be read.
    start, end : datetime or None
        Clock span of the record (None without a clock).
    error : str
        The reader's one-line error ('' when read).
    """

    path: str
    sha256: str
    kind: str | None = None
    start: datetime | None = None
    end: datetime | None = None
    error: str = ""


def _one_line(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    text = lines[0] if lines else ""
    return text if isinstance(exc, XlotkitError) else f"{type(exc).__name__}: {text}"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def survey_log(path: str, read_options: Any = None) -> LogInfo:
    """Read one file (:func:`xlotkit.interpret.io.read_log`, with the batch's
    ``read_options``) for its kind and clock span; a file that cannot be read gives its
    error instead."""
    from xlotkit.interpret.io import read_log

    p = Path(path)
    try:
        digest = _sha256(p)
    except OSError as exc:
        return LogInfo(path, "", error=f"cannot read: {exc.strerror}")
    try:
        rec = read_log(p, options=read_options)
    except Exception as exc:        # a reader failing on garbage: the file's row says so
        return LogInfo(path, digest, error=_one_line(exc))
    start = rec.start_time
    end = None
    if start is not None and len(rec.t):
        end = start + timedelta(seconds=float(rec.t[-1]))
    return LogInfo(path, digest, rec.reference.kind, start, end)


@dataclass(frozen=True)
class LogGroup:
    """Logs interpreted together (one, or a surface + downhole pair), or an unreadable one."""

    logs: tuple[LogInfo, ...]

    @property
    def files(self) -> tuple[str, ...]:
        return tuple(i.path for i in self.logs)

    @property
    def error(self) -> str:
        return "; ".join(i.error for i in self.logs if i.error)


def _overlap(a: LogInfo, b: LogInfo, max_offset_s: float) -> float | None:
    """Seconds the two clock spans overlap (negative: the gap), or None when they cannot be
    the same test even with a clock offset of ``max_offset_s``."""
    ov = (min(a.end, b.end) - max(a.start, b.start)).total_seconds()
    return ov if ov > -max_offset_s else None


def group_logs(infos: Sequence[LogInfo], max_offset_s: float = MAX_OFFSET_S) -> list[LogGroup]:
    """Pair surface and downhole logs of one test (module docstring); the rest alone.

    Returns
    -------
    list of LogGroup
        In the order of their first file.
    """
    timed = [i for i in infos if not i.error and i.start is not None and i.end is not None]
    surf = [i for i in timed if i.kind == "surface"]
    down = [i for i in timed if i.kind == "downhole"]
    cands = []
    for s in surf:
        for d in down:
            if Path(s.path).parent != Path(d.path).parent:
                continue
            ov = _overlap(s, d, max_offset_s)
            if ov is not None:
                cands.append((-ov, s.path, d.path, s, d))
    cands.sort(key=lambda c: c[:3])
    used: set[str] = set()
    groups: list[LogGroup] = []
    for _, _, _, s, d in cands:
        if s.path in used or d.path in used:
            continue
        used.update((s.path, d.path))
        groups.append(LogGroup((s, d)))
    groups += [LogGroup((i,)) for i in infos if i.path not in used]
    groups.sort(key=lambda g: min(g.files))
    return groups


# --------------------------------------------------------------------------- one group
@dataclass(frozen=True)
class GroupTask:
    """Everything a worker needs to interpret one group (picklable).

    Attributes
    ----------
    group_id : str
    index : int
    folder : str
        The group's folder (made as ``.<id>.partial`` beside it, renamed when complete).
    files : tuple of str
    error : str
        The survey's error for an unreadable file ('' otherwise).
    options, stress_inputs : PickOptions, StressInputs or None
    max_offset_s : float
    read_options : ReadOptions or None
    """

    group_id: str
    index: int
    folder: str
    files: tuple[str, ...]
    error: str = ""
    options: Any = None
    stress_inputs: Any = None
    max_offset_s: float = MAX_OFFSET_S
    read_options: Any = None


def _head(task: GroupTask) -> dict[str, Any]:
    return {"log": task.group_id, "index": task.index,
            "files": " + ".join(task.files), "status": "", "message": ""}


def _pick_cells(prefix: str, p) -> dict[str, Any]:
    found = p is not None and p.found
    return {f"{prefix}_bar": p.value / _BAR if found else None,
            f"{prefix}_low_bar": p.low / _BAR if found and p.low is not None else None,
            f"{prefix}_high_bar": p.high / _BAR if found and p.high is not None else None,
            f"{prefix}_quality": p.quality if p is not None else None}


def _rows(task: GroupTask, interp) -> list[dict[str, Any]]:
    from xlotkit.interpret.picks.core import consensus_rule

    rec = interp.record
    s = interp.stress
    log_cols: dict[str, Any] = {
        "reference": rec.reference.describe(),
        "clock_offset_s": (float(rec.meta["clock_offset_s"]) if "clock_offset_s" in rec.meta
                           else None)}
    sigma_H = None
    if s.available and s.sigma_H:
        est = s.sigma_H.get("C.19") or next(iter(s.sigma_H.values()))
        sigma_H = est.get("value")
    stress_cols = {
        "sigma_h_bar": s.sigma_h / _BAR if s.available and s.sigma_h is not None else None,
        "sigma_h_low_bar": (s.sigma_h_low / _BAR if s.available and s.sigma_h_low is not None
                            else None),
        "sigma_h_high_bar": (s.sigma_h_high / _BAR
                             if s.available and s.sigma_h_high is not None else None),
        "sigma_h_cycle": s.source_cycle if s.available else None,
        "t0_bar": s.t0 / _BAR if s.available and s.t0 is not None else None,
        "sigma_H_bar": sigma_H / _BAR if sigma_H is not None else None,
        "regime": s.regime if s.available else None,
        "target_tvd_m": s.target_tvd if s.available else None,
        "stress_message": s.message,
    }
    cycles = interp.picks.test_cycles
    if not cycles:
        row = {**_head(task), **log_cols, **stress_cols}
        row.update(status="no test cycle",
                   message=f"{len(interp.picks.cycles)} cycle(s), none a LOT or XLOT")
        return [row]
    rows = []
    for c in cycles:
        row = {**_head(task), "status": "ok", **log_cols, "cycle": c.index,
               "cycle_kind": c.kind, "t_start_s": float(c.cycle.t_start),
               "t_end_s": float(c.cycle.t_end)}
        for name in _PICKS:
            row.update(_pick_cells(name, c.get(name)))
        row.update(_pick_cells("fcp", c.fcp))
        row["fcp_rule"] = consensus_rule(c.fcp) if c.fcp.found else ""
        for m, p in c.fcp_methods().items():
            row.update(_pick_cells(f"fcp_{m}", p))
        row["stiffness_bar_per_m3"] = c.stiffness / _BAR if c.stiffness is not None else None
        row.update(stress_cols)
        rows.append(row)
    return rows


def interpret_group(task: GroupTask) -> list[dict[str, Any]]:
    """Interpret one group into its folder (module docstring); every error of the group is
    caught and becomes its one row with ``status = "failed"``. Returns the group's rows."""
    from xlotkit.interpret.io import read_logs
    from xlotkit.pipeline import interpret_record, write_interpretation

    t0 = time.perf_counter()
    final = Path(task.folder)
    work = final.with_name(f".{final.name}.partial")
    if work.exists():
        shutil.rmtree(work)     # an earlier run stopped while writing it: not a result
    work.mkdir(parents=True)
    log = [f"log group {task.index} ({task.group_id}): " + " + ".join(task.files)]
    stage = "read"
    try:
        if task.error:
            raise InputError(task.error)
        rec = read_logs(list(task.files), max_offset_s=task.max_offset_s,
                        options=task.read_options)
        if "clock_offset_s" in rec.meta:
            log.append(f"merged: downhole clock + {float(rec.meta['clock_offset_s']):.1f} s "
                       f"= surface clock")
        stage = "pick"
        interp = interpret_record(rec, options=task.options, stress_inputs=task.stress_inputs)
        stage = "write"
        write_interpretation(interp, work)
        rows = _rows(task, interp)
        log.append(f"{len(rows)} row(s): " + ", ".join(
            f"cycle {r.get('cycle')} FCP {r.get('fcp_bar')}" for r in rows))
    except Exception as exc:
        row = _head(task)
        row.update(status="failed", message=f"{stage}: {_one_line(exc)}")
        rows = [row]
        log.append(f"FAILED in {stage}: {_one_line(exc)}")
        if not task.error:
            log.append(traceback.format_exc())
    wall = time.perf_counter() - t0
    for r in rows:
        r["wall_time_s"] = wall
    log.append(f"status {rows[0]['status']}; {wall:.2f} s")
    atomic_write_text(work / "group.log", "\n".join(log) + "\n")
    write_result(work, rows)
    os.replace(work, final)
    return rows


def _lost_rows(item: Item, message: str) -> list[dict[str, Any]]:
    row = _head(item.task)
    row.update(status="lost", message=f"{message}; rerun the batch to interpret it again")
    return [row]


def _group_id(group: LogGroup, spec: BatchSpec) -> str:
    h = hashlib.sha256()
    for info in group.logs:
        h.update(f"{info.path}\0{info.sha256}\0".encode())
    # everything that changes a group's result: a rerun with other reader flags (--unit,
    # --column, ...) reads the files again instead of keeping results read the old way
    h.update(f"{spec.options!r}\0{spec.stress_inputs!r}\0{spec.max_offset_s!r}\0"
             f"{spec.read_options!r}".encode())
    return h.hexdigest()[:16]


def run_batch(spec: BatchSpec, out: str | Path, *, executor: Executor | None = None,
              progress: Progress | None = None) -> StudyResult:
    """Interpret every log of ``spec.inputs`` into ``out`` (or continue there).

    The files are first read on the executor to group them (the first tenth of the
    progress), then each group is interpreted on it.

    Returns
    -------
    StudyResult

    Raises
    ------
    InputError
        For an input that names no file, or ``out`` holding other results.
    """
    t0 = time.perf_counter()
    files = expand_inputs(spec.inputs)
    executor = executor or LocalPool(default_workers())
    infos: list[LogInfo | None] = [None] * len(files)
    for k, (pos, info) in enumerate(executor.run(functools.partial(survey_log, read_options=spec.read_options),
                                        [str(f) for f in files]), 1):
        if isinstance(info, Lost):
            info = LogInfo(str(files[pos]), "", error=info.message)
        infos[pos] = info
        if progress is not None:
            progress(0.1 * k / len(files), f"read {k}/{len(files)} files")
    groups = group_logs([i for i in infos if i is not None], spec.max_offset_s)
    logs_dir = Path(out) / LOGS
    tasks = []
    for k, g in enumerate(groups):
        gid = _group_id(g, spec)
        tasks.append(GroupTask(gid, k, str(logs_dir / gid), g.files, g.error, spec.options,
                               spec.stress_inputs, spec.max_offset_s, spec.read_options))
    folder = StudyFolder.open(out, "batch", LOGS, [t.group_id for t in tasks],
                              {"inputs": list(spec.inputs), "files": [str(f) for f in files],
                               "options": repr(spec.options),
                               "stress_inputs": repr(spec.stress_inputs),
                               "max_offset_s": spec.max_offset_s,
                               "read_options": repr(spec.read_options)})
    items = [Item(t.group_id, t.index, t, " + ".join(Path(f).name for f in t.files))
             for t in tasks]

    def sub(frac: float, msg: str) -> None:
        if progress is not None:
            progress(0.1 + 0.9 * frac, msg)

    return drive(folder, items, interpret_group, _lost_rows, executor=executor,
                 progress=sub, what="logs", t_start=t0)

