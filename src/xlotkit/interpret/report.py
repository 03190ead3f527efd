"""Reports of an interpretation: JSON, a CSV table of picks and annotated plots.

Units: pressures in bar (gauge or absolute as the record's reference says), stiffness in
bar/m^3, times in s from the record's start (``t_min`` in minutes in the table). Stress results
passed in are written as they come (SI, Pa) -- see :func:`picks_to_dict`.

JSON schema (``picks.json``)
----------------------------
::

    {
      "sources": [str, ...],                # files the record was read from
      "reference": str,                     # where the pressure was measured
      "units": {"pressure": "bar", "stiffness": "bar/m3", "time": "s"},
      "reading_notes": [str, ...],          # what the reader decided about cells
      "consistency": {"fcp_mean_bar", "fcp_spread_bar", "fcp_relative_spread",
                      "t0_bar", "t0_low_bar", "t0_high_bar", "t0_level", "t0_message",
                      "stiffness_slope_bar_per_m3_per_cycle", "stiffness_relative_change",
                      "closure_bar", "closure_low_bar", "closure_high_bar", "closure_level",
                      "closure_cycles": [int, ...], "closure_message": str,
                      "closure_outliers": [{"cycle": int, "reason": str}, ...]},
      "cycles": [
        {"index": int, "kind": str, "reference": str, "t_start_s": float, "t_end_s": float,
         "lop_bar", "fbp_bar", "reopening_bar", "fpp_bar", "isip_bar": float | null,
         "fep_bar": float | null (fracture-extension pressure of a step-rate test),
         "fcp_bar", "fcp_low_bar", "fcp_high_bar", "fcp_level": float | null,
         "fcp_quality": str, "fcp_rule": str, "fcp_message": str,
         "stiffness_bar_per_m3", "stiffness_stderr_bar_per_m3": float | null,
         "methods": {<every FCP method>: {"fcp_bar", "low_bar", "high_bar", "level":
                                          float | null, "quality": str, "message": str}},
         "picks": [{"name", "method", "value_bar", "low_bar", "high_bar", "level", "t_s",
                    "quality", "message"}, ...],
         "notes": [str, ...]}
      ],
      "diagnostics": [{"cycle", "g_function": {"diagnosis", "reason", "g_closure", "m_bar"},
                       "flow_regimes": [{"name", "slope", "measured", "dt_start_s",
                                         "dt_end_s"}],
                       "after_closure": {"reached", "regime", "message",
                                         "reservoir_pressure_bar", "low_bar", "high_bar",
                                         "level"}}] | null,
      "stress": {...} | null
    }

``level`` is the nominal coverage of ``[low, high]`` (0.9), null where the interval states
none.

Values that were not picked (or are NaN) are ``null``. FCP methods that were not run for a
cycle appear in ``methods`` with null values, quality ``"none"`` and message ``"not run"``.

Never destroying results
------------------------
:func:`write_pick_report` writes each file to a temporary name in the target folder and moves
it into place with :func:`os.replace`, so a crash never leaves a half-written file. If the
target folder already holds a report (any file the report would write), nothing in it is
touched: by default the report goes to the first free numbered sibling folder
(``out``, ``out-2``, ``out-3``, ...), created exclusively so that two concurrent runs cannot
share one; with ``if_exists="error"`` a :class:`FileExistsError` is raised instead.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np

from xlotkit.atomic import atomic_write, fresh_sibling_dir
from xlotkit.interpret.io import reading_notes
from xlotkit.interpret.picks.core import FCP_METHODS, CyclePicks, RecordPicks, consensus_rule
from xlotkit.interpret.picks.types import Pick

__all__ = ["REPORT_FILES", "picks_table", "picks_to_dict", "write_pick_report"]

#: Files always written by :func:`write_pick_report` (plots are added per record).
REPORT_FILES = ("picks.csv", "picks.json")

_BAR = 1e5


def _bar(x: float | None) -> float | None:
    if x is None:
        return None
    x = float(x)
    return x / _BAR if math.isfinite(x) else None


def _num(x: Any) -> float | None:
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _value_bar(p: Pick | None) -> float | None:
    return _bar(p.value) if p is not None and p.found else None


def _jsonable(obj: Any) -> Any:
    """Plain JSON types from numbers, arrays, mappings, sequences, dataclasses and Picks."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return _num(obj)
    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if hasattr(obj, "to_dict") and callable(obj.to_dict):
        return _jsonable(obj.to_dict())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set, frozenset)):
        return [_jsonable(v) for v in obj]
    return str(obj)


def _pick_row(p: Pick) -> dict[str, Any]:
    return {"name": p.name, "method": p.method, "value_bar": _bar(p.value),
            "low_bar": _bar(p.low), "high_bar": _bar(p.high), "level": _num(p.level),
            "t_s": _num(p.t), "quality": p.quality, "message": p.message}


def _cycle_dict(cp: CyclePicks) -> dict[str, Any]:
    fcp = cp.fcp
    methods: dict[str, Any] = {}
    run = cp.fcp_methods()
    for m in FCP_METHODS:
        p = run.get(m)
        if p is None:
            methods[m] = {"fcp_bar": None, "low_bar": None, "high_bar": None, "level": None,
                          "quality": "none", "message": "not run"}
        else:
            methods[m] = {"fcp_bar": _value_bar(p), "low_bar": _bar(p.low) if p.found else None,
                          "high_bar": _bar(p.high) if p.found else None,
                          "level": _num(p.level) if p.found else None,
                          "quality": p.quality, "message": p.message}
    return {
        "index": cp.index,
        "kind": cp.kind,
        "reference": cp.reference,
        "t_start_s": _num(cp.cycle.t_start),
        "t_end_s": _num(cp.cycle.t_end),
        "lop_bar": _value_bar(cp.get("LOP")),
        "fbp_bar": _value_bar(cp.get("FBP")),
        "reopening_bar": _value_bar(cp.get("Pr")),
        "fpp_bar": _value_bar(cp.get("FPP")),
        "isip_bar": _value_bar(cp.get("ISIP")),
        "fep_bar": _value_bar(cp.get("FEP")),
        "fcp_bar": _value_bar(fcp),
        "fcp_low_bar": _bar(fcp.low) if fcp.found else None,
        "fcp_high_bar": _bar(fcp.high) if fcp.found else None,
        "fcp_level": _num(fcp.level) if fcp.found else None,
        "fcp_quality": fcp.quality,
        "fcp_rule": consensus_rule(fcp),
        "fcp_message": fcp.message,
        "stiffness_bar_per_m3": _bar(cp.stiffness),
        "stiffness_stderr_bar_per_m3": _bar(cp.stiffness_stderr),
        "methods": methods,
        "picks": [_pick_row(p) for p in cp.picks],
        "notes": list(cp.notes),
    }


def _closure_dict(a) -> dict[str, Any]:
    """The record's closure from the cycles that agree (``closure_*`` keys)."""
    if a is None:
        return {"closure_bar": None, "closure_low_bar": None, "closure_high_bar": None,
                "closure_level": None, "closure_cycles": [], "closure_message": "",
                "closure_outliers": []}
    return {"closure_bar": _bar(a.value), "closure_low_bar": _bar(a.low),
            "closure_high_bar": _bar(a.high), "closure_level": _num(a.level),
            "closure_cycles": list(a.cycles), "closure_message": a.message,
            "closure_outliers": [{"cycle": i, "reason": why} for i, why in a.outliers]}


def _diagnostics_dict(diagnostics) -> list[dict[str, Any]]:
    out = []
    for c in diagnostics.cycles:
        g, ll, ac = c.g_function, c.loglog, c.after_closure
        out.append({
            "cycle": c.cycle,
            "g_function": None if g is None else {
                "diagnosis": g.diagnosis, "reason": g.reason,
                "g_closure": _num(g.g_closure), "m_bar": _bar(g.m)},
            "flow_regimes": [] if ll is None else [
                {"name": r.name, "slope": r.slope, "measured": r.measured,
                 "dt_start_s": r.dt_start, "dt_end_s": r.dt_end} for r in ll.regimes],
            "after_closure": {
                "reached": ac.reached, "regime": ac.regime, "message": ac.message,
                "reservoir_pressure_bar": _bar(ac.reservoir_pressure),
                "low_bar": _bar(ac.low), "high_bar": _bar(ac.high), "level": _num(ac.level)},
        })
    return out


def picks_to_dict(record_picks: RecordPicks, stress: Any = None,
                  diagnostics: Any = None) -> dict[str, Any]:
    """The JSON report of a record's picks (schema in the module docstring).

    Parameters
    ----------
    record_picks : RecordPicks
    stress : object, optional
        Stress results (e.g. :class:`xlotkit.interpret.stress.SigmaHEstimates` or a dict).
        Mappings are written as given; other objects are converted field by field
        (``to_dict()`` if they have one), in their own SI units.

    Returns
    -------
    dict
        JSON-serialisable (no NaN: missing values are None).
    """
    rec = record_picks.record
    k = record_picks.consistency
    t0 = k.t0
    out: dict[str, Any] = {
        "sources": list(rec.sources),
        "reference": rec.reference.describe(),
        "units": {"pressure": "bar", "stiffness": "bar/m3", "time": "s"},
        "reading_notes": reading_notes(rec),
        "consistency": {
            "fcp_mean_bar": _bar(k.fcp_mean),
            "fcp_spread_bar": _bar(k.fcp_spread),
            "fcp_relative_spread": _num(k.fcp_relative_spread),
            "t0_bar": _value_bar(t0),
            "t0_low_bar": _bar(t0.low) if t0.found else None,
            "t0_high_bar": _bar(t0.high) if t0.found else None,
            "t0_level": _num(t0.level) if t0.found else None,
            "t0_message": t0.message,
            "stiffness_slope_bar_per_m3_per_cycle": _bar(k.stiffness_slope),
            "stiffness_relative_change": _num(k.stiffness_relative_change),
            **_closure_dict(k.closure),
        },
        "cycles": [_cycle_dict(cp) for cp in record_picks.cycles],
        "diagnostics": None if diagnostics is None else _diagnostics_dict(diagnostics),
        "stress": None if stress is None else _jsonable(stress),
    }
    return out


def picks_table(record_picks: RecordPicks):
    """All picks as a table, one row per cycle x pick x method (consensus FCP included).

    Returns
    -------
    pandas.DataFrame
        Columns ``cycle, kind, reference, name, method, value_bar, low_bar, high_bar, level,
        t_s, t_min, window_start_s, window_end_s, quality, message``; missing values NaN
        (``level`` NaN where the interval states none).
    """
    import pandas as pd

    rows = []
    for cp in record_picks.cycles:
        for p in (*cp.picks, *((cp.fcp,) if cp.picks else ())):
            w = p.window or (None, None)
            rows.append({
                "cycle": cp.index, "kind": cp.kind, "reference": cp.reference,
                "name": p.name, "method": p.method,
                "value_bar": _bar(p.value), "low_bar": _bar(p.low) if p.found else None,
                "high_bar": _bar(p.high) if p.found else None,
                "level": _num(p.level) if p.found else None,
                "t_s": _num(p.t), "t_min": None if p.t is None else float(p.t) / 60.0,
                "window_start_s": _num(w[0]), "window_end_s": _num(w[1]),
                "quality": p.quality, "message": p.message,
            })
    cols = ["cycle", "kind", "reference", "name", "method", "value_bar", "low_bar", "high_bar",
            "level", "t_s", "t_min", "window_start_s", "window_end_s", "quality", "message"]
    df = pd.DataFrame(rows, columns=cols)
    for c in ("value_bar", "low_bar", "high_bar", "level", "t_s", "t_min", "window_start_s",
              "window_end_s"):
        df[c] = pd.to_numeric(df[c], errors="coerce")
    return df


# --------------------------------------------------------------------------- writing
def _holds_report(folder: Path, names) -> bool:
    return any((folder / n).exists() for n in names)


def _target_dir(out_dir: Path, names, if_exists: str) -> Path:
    """The folder to write into: ``out_dir`` if it holds no report, else a fresh sibling."""
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    try:
        out_dir.mkdir()
        return out_dir
    except FileExistsError:
        if not out_dir.is_dir():
            raise FileExistsError(f"{out_dir} exists and is not a folder") from None
    if not _holds_report(out_dir, names):
        return out_dir
    if if_exists == "error":
        raise FileExistsError(f"{out_dir} already holds a pick report; refusing to overwrite it")
    return fresh_sibling_dir(out_dir)


def write_pick_report(record_picks: RecordPicks, out_dir: str | Path, *, stress: Any = None,
                      plots: bool = True,
                      if_exists: Literal["new", "error"] = "new", diagnostics: Any = None,
                      pdf: bool = False, extra_figures: Mapping[str, Any] | None = None
                      ) -> dict[str, Path]:
    """Write ``picks.csv``, ``picks.json``, the plots (PNG) and optionally ``report.pdf``.

    Parameters
    ----------
    record_picks : RecordPicks
    out_dir : str or Path
        Target folder (created if missing).
    stress : object, optional
        Stress results for the JSON (see :func:`picks_to_dict`).
    plots : bool
        Also write the figures of :func:`xlotkit.interpret.plots.picks.pick_figures`.
    if_exists : {"new", "error"}
        When ``out_dir`` already holds a report: write into the first free sibling
        ``<out_dir>-2``, ``-3``, ... (default) or raise :class:`FileExistsError`.
    diagnostics : RecordDiagnostics, optional
        Shut-in diagnostics (computed for the plots when not given; written to the JSON
        when given).
    pdf : bool
        Also write ``report.pdf``: every plot, ``extra_figures``, the picks table and the
        stress estimate with its assumptions (:mod:`xlotkit.interpret.plots.pdf`).
    extra_figures : mapping of str to Figure, optional
        Further figures for the PNGs and the PDF (e.g. the stress polygon).

    Returns
    -------
    dict of str to Path
        ``{"csv": ..., "json": ..., "dir": ..., <plot name>: ...}``.
    """
    if if_exists not in ("new", "error"):
        raise ValueError(f"if_exists must be 'new' or 'error', got {if_exists!r}")
    out_dir = Path(out_dir)
    figures: dict[str, Any] = {}
    if plots:
        from xlotkit.interpret.plots.picks import pick_figures

        if diagnostics is None:
            from xlotkit.interpret.diagnostics import diagnose_record

            diagnostics = diagnose_record(record_picks)
        figures = pick_figures(record_picks, diagnostics)
        figures.update(extra_figures or {})
    names = [*REPORT_FILES, *(f"{k}.png" for k in figures), *(["report.pdf"] if pdf else [])]
    # Also treat a folder with any earlier plot or table as holding a report.
    target = _target_dir(out_dir, names, if_exists)

    paths: dict[str, Path] = {"dir": target}
    df = picks_table(record_picks)
    p_csv = target / "picks.csv"
    atomic_write(p_csv, lambda tmp: df.to_csv(tmp, index=False))
    paths["csv"] = p_csv
    data = picks_to_dict(record_picks, stress, diagnostics)
    p_json = target / "picks.json"
    atomic_write(p_json, lambda tmp: tmp.write_text(json.dumps(data, indent=2,
                                                                allow_nan=False) + "\n"))
    paths["json"] = p_json
    for name, fig in figures.items():
        p_png = target / f"{name}.png"
        atomic_write(p_png, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=110))
        paths[name] = p_png
    if pdf:
        from xlotkit.interpret.plots.pdf import write_report_pdf

        p_pdf = target / "report.pdf"
        extra = dict(extra_figures or {})
        main = {k: f for k, f in figures.items() if k not in extra}
        atomic_write(p_pdf, lambda tmp: write_report_pdf(
            tmp, record_picks, main, stress=stress if isinstance(stress, Mapping) else None,
            diagnostics=diagnostics, extra=extra))
        paths["pdf"] = p_pdf
    return paths
