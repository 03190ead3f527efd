"""Run a study's items on an executor, skipping the finished ones, and write its table.

Shared by :mod:`xlotkit.study.sweep` and :mod:`xlotkit.study.batch`: every item (a case or
a log group) has an identity, a folder and a task; an item whose folder holds
``result.json`` is finished and is not run again, the others go to the executor, and the
rows of all items, in the study's order, make the table.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from xlotkit.study.executors import Executor, LocalPool, Lost, default_workers
from xlotkit.study.table import StudyFolder, frame, write_table

__all__ = ["Item", "Progress", "StudyResult", "drive"]

Progress = Callable[[float, str], None]


@dataclass(frozen=True)
class Item:
    """One case or log group of a study.

    Attributes
    ----------
    item_id : str
        Identity (a hash of the item's inputs): the name of its folder.
    index : int
        Position in the study.
    task : object
        What the executor's function gets (picklable).
    label : str
        For progress messages.
    """

    item_id: str
    index: int
    task: Any
    label: str


@dataclass(frozen=True)
class StudyResult:
    """What a run of a study did.

    Attributes
    ----------
    folder : Path
    table : pandas.DataFrame
        Every row of the study, in its order.
    paths : dict
        ``parquet``, ``csv``: the table's files.
    computed, skipped, lost : tuple of str
        Items run now, items finished by an earlier run, items that did not come back
        (they run again on the next run of the study).
    executor : str
        Where the items ran.
    wall_time : float
        Seconds this run took.
    """

    folder: Path
    table: Any
    paths: dict[str, Path]
    computed: tuple[str, ...]
    skipped: tuple[str, ...]
    lost: tuple[str, ...]
    executor: str
    wall_time: float

    @property
    def complete(self) -> bool:
        """Every item has its result (none lost)."""
        return not self.lost

    def count(self, status: str) -> int:
        """Rows with this ``status``."""
        if "status" not in self.table.columns:
            return 0
        return int((self.table["status"] == status).sum())


def drive(folder: StudyFolder, items: Sequence[Item], fn: Callable[[Any], list[dict]],
          lost_rows: Callable[[Item, str], list[dict]], *, executor: Executor | None = None,
          progress: Progress | None = None, what: str = "cases",
          t_start: float | None = None,
          order: Callable[[list[str]], list[str]] | None = None) -> StudyResult:
    """Run the unfinished items, then write the table of all of them.

    Parameters
    ----------
    folder : StudyFolder
    items : sequence of Item
    fn : callable
        ``fn(item.task) -> rows`` (runs on the executor; writes the item's ``result.json``).
    lost_rows : callable
        The rows of an item that did not come back, from its message.
    executor : Executor, optional
        Default: a :class:`LocalPool` of :func:`default_workers` processes.
    progress : callable, optional
        ``progress(fraction, message)`` after each item.
    what : str
        What the items are, for messages.
    t_start : float, optional
        ``time.perf_counter()`` when the study started (default: now).
    order : callable, optional
        Puts the table's columns in order (:func:`xlotkit.study.table.frame`).
    """
    t0 = time.perf_counter() if t_start is None else t_start
    executor = executor or LocalPool(default_workers())
    rows: dict[int, list[dict]] = {}
    skipped, todo = [], []
    for it in items:
        done = folder.finished(it.item_id)
        if done is None:
            todo.append(it)
        else:
            rows[it.index] = done
            skipped.append(it.item_id)
    n = len(items)
    if progress is not None:
        progress(len(skipped) / n if n else 1.0,
                 f"{len(skipped)}/{n} {what} finished earlier; {len(todo)} to run on "
                 f"{executor.describe()}")
    computed, lost = [], []
    done_n = len(skipped)
    for pos, out in executor.run(fn, [it.task for it in todo]):
        it = todo[pos]
        if isinstance(out, Lost):
            rows[it.index] = lost_rows(it, out.message)
            lost.append(it.item_id)
            status = "lost"
        else:
            rows[it.index] = out
            computed.append(it.item_id)
            status = ",".join(sorted({r.get("status", "") for r in out})) or "no rows"
        done_n += 1
        if progress is not None:
            progress(done_n / n, f"{done_n}/{n} {what}: {it.label} {status}")
    table = frame((r for i in sorted(rows) for r in rows[i]), order)
    paths = write_table(table, folder.root)
    return StudyResult(folder.root, table, paths, tuple(computed), tuple(skipped), tuple(lost),
                       executor.describe(), time.perf_counter() - t0)
