"""The study folder and its tidy table.

A study folder (``--out DIR`` of ``xlotkit sweep`` and ``xlotkit pick --batch``) holds::

    DIR/study.json          what the study is: its kind and its cases' identities, in order
    DIR/results.parquet     the table, one row per case (sweep) or per test cycle (batch)
    DIR/results.csv         the same table as CSV
    DIR/<items>/<id>/       one folder per case or log group: result.json (its rows, written
                            last: the item is finished) and its log and outputs

:class:`StudyFolder` refuses a folder that holds anything else, or a study with other cases
(results are never written over); it lets a rerun of the same study continue where it
stopped. Every file is written through :mod:`xlotkit.atomic`.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from xlotkit.atomic import atomic_write, atomic_write_text
from xlotkit.errors import InputError

__all__ = [
    "RESULT_FILE",
    "STUDY_FILE",
    "TIMING_COLUMNS",
    "StudyFolder",
    "frame",
    "same_table",
    "write_table",
]

STUDY_FILE = "study.json"
RESULT_FILE = "result.json"
TABLE_STEM = "results"
_FORMAT = 1
#: Columns that hold wall-clock times: they differ between runs of the same study.
TIMING_COLUMNS = ("wall_time_s", "sim_wall_time_s", "pick_wall_time_s")


def dumps(obj: Any) -> str:
    """JSON text of a study file (no NaN: a missing value is null)."""
    return json.dumps(obj, indent=2, allow_nan=False) + "\n"


@dataclass(frozen=True)
class StudyFolder:
    """The folder of one study.

    Attributes
    ----------
    root : Path
    kind : str
        ``sweep`` or ``batch``.
    items : str
        Name of the sub-folder with one folder per case (``cases``) or log group (``logs``).
    """

    root: Path
    kind: str
    items: str

    @classmethod
    def open(cls, root: str | Path, kind: str, items: str, ids: Sequence[str],
             description: Mapping[str, Any]) -> StudyFolder:
        """Start a study in ``root`` or continue the same study there.

        Parameters
        ----------
        root : str or Path
            The folder; made if missing.
        kind, items : str
        ids : sequence of str
            The identities of the study's cases, in order.
        description : mapping
            What the study was made from (scene, options), kept in ``study.json``.

        Raises
        ------
        InputError
            If ``root`` is a file, holds files that are not this study's, or holds a
            study of another kind or with other cases.
        """
        root = Path(root)
        if root.exists() and not root.is_dir():
            raise InputError("is a file, expected a results folder", file=root, key="--out")
        study = root / STUDY_FILE
        ids = list(ids)
        if study.is_file():
            try:
                known = json.loads(study.read_text())
            except json.JSONDecodeError as exc:
                raise InputError(f"not valid JSON: {exc.msg}", file=study,
                                 line=exc.lineno) from None
            if known.get("kind") != kind:
                raise InputError(f"holds a {known.get('kind')!r} study, not a {kind!r} one",
                                 file=root, key="--out",
                                 expected="a new folder, or the folder of the same study")
            if known.get("cases") != ids:
                old = known.get("cases") or []
                k = next((i for i, (a, b) in enumerate(zip(old, ids)) if a != b),
                         min(len(old), len(ids)))
                raise InputError(f"holds another study ({len(old)} cases, this one has "
                                 f"{len(ids)}; they differ from case {k} on); results are "
                                 f"never written over", file=root, key="--out",
                                 expected="a new folder, or the same scene (or logs) and "
                                          "options to continue the study in it")
        else:
            if root.is_dir() and any(root.iterdir()):
                raise InputError("holds other results (no study.json); results are never "
                                 "written over", file=root, key="--out",
                                 expected="a new or empty folder")
            root.mkdir(parents=True, exist_ok=True)
            atomic_write_text(study, dumps({"format": _FORMAT, "kind": kind, "items": items,
                                            "description": dict(description),
                                            "cases": ids}))
        (root / items).mkdir(exist_ok=True)
        return cls(root, kind, items)

    def item_dir(self, item_id: str) -> Path:
        """The folder of one case or log group (not made here)."""
        return self.root / self.items / item_id

    def finished(self, item_id: str) -> list[dict[str, Any]] | None:
        """The rows of a finished case or log group, or None if it has not finished."""
        path = self.item_dir(item_id) / RESULT_FILE
        if not path.is_file():
            return None
        try:
            data = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise InputError(f"not valid JSON: {exc.msg}", file=path, line=exc.lineno,
                             expected="a result written by xlotkit; delete the case's "
                                      "folder to run it again") from None
        return list(data["rows"])


def write_result(folder: Path, rows: Sequence[Mapping[str, Any]]) -> Path:
    """Write a finished item's rows into ``folder/result.json`` (the last file it writes)."""
    return atomic_write_text(folder / RESULT_FILE, dumps({"rows": [dict(r) for r in rows]}))


def frame(rows: Iterable[Mapping[str, Any]],
          order: Callable[[list[str]], list[str]] | None = None):
    """The tidy table of some rows: columns in the order they first appear (or as
    ``order(columns)`` puts them), the wall times (:data:`TIMING_COLUMNS`) last.

    Returns
    -------
    pandas.DataFrame
        Missing values are NaN (numbers) or None (text).
    """
    import pandas as pd

    rows = [dict(r) for r in rows]
    columns: dict[str, None] = {}
    for r in rows:
        for k in r:
            if k not in TIMING_COLUMNS:
                columns.setdefault(k, None)
    cols = list(columns) if order is None else order(list(columns))
    # the wall times last, whichever row came first
    cols += [c for c in TIMING_COLUMNS if any(c in r for r in rows)]
    return pd.DataFrame.from_records(rows, columns=cols)


def write_table(table, root: str | Path) -> dict[str, Path]:
    """Write ``results.parquet`` (pyarrow) and ``results.csv`` into ``root``, atomically.

    Returns
    -------
    dict
        ``parquet`` and ``csv`` paths.
    """
    root = Path(root)
    paths = {"parquet": root / f"{TABLE_STEM}.parquet", "csv": root / f"{TABLE_STEM}.csv"}
    atomic_write(paths["parquet"],
                 lambda tmp: table.to_parquet(tmp, engine="pyarrow", index=False))
    atomic_write(paths["csv"], lambda tmp: table.to_csv(tmp, index=False))
    return paths


def same_table(a, b, *, ignore: Sequence[str] = TIMING_COLUMNS) -> tuple[bool, str]:
    """Whether two study tables hold the same rows and values, ``ignore`` columns aside.

    Numbers must be equal exactly (NaN equal to NaN): the same study on any executor runs
    the same code on the same inputs.

    Returns
    -------
    (bool, str)
        The verdict and, when they differ, the first difference.
    """
    a = a.drop(columns=[c for c in ignore if c in a.columns])
    b = b.drop(columns=[c for c in ignore if c in b.columns])
    if list(a.columns) != list(b.columns):
        extra = sorted(set(a.columns) ^ set(b.columns))
        return False, f"columns differ: {extra or 'order'}"
    if len(a) != len(b):
        return False, f"{len(a)} rows vs {len(b)}"
    for c in a.columns:
        x, y = a[c].tolist(), b[c].tolist()
        for i, (u, v) in enumerate(zip(x, y)):
            if _same(u, v):
                continue
            return False, f"row {i}, column {c}: {u!r} vs {v!r}"
    return True, f"{len(a)} rows x {len(a.columns)} columns equal"


def _same(u: Any, v: Any) -> bool:
    nan_u = isinstance(u, float) and u != u
    nan_v = isinstance(v, float) and v != v
    if nan_u or nan_v or u is None or v is None:
        return (nan_u or u is None) and (nan_v or v is None)
    return u == v
