"""The ``xlotkit`` command line.

Each command is a thin layer: it parses options (field units allowed here), calls the library,
and prints. Errors a user can cause are :class:`~xlotkit.errors.XlotkitError`; they are printed
as one line ``error: ...`` with exit status 2, never as a traceback.
"""

from __future__ import annotations

import functools
import sys

import click

from xlotkit import __version__
from xlotkit.errors import InputError, XlotkitError

__all__ = ["main"]


def _friendly_errors(func):
    """Turn xlotkit errors and unreadable files into one clear line and exit status 2."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except XlotkitError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)
        except (OSError, UnicodeDecodeError) as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)

    return wrapper


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="xlotkit")
def main() -> None:
    """Simulate and interpret extended leak-off tests (XLOT)."""


# ====================================================================== inspect
def _fmt_clock(record, t: float) -> str:
    ts = record.time_at(t)
    return ts.strftime("%H:%M:%S") if ts is not None else "-"


def _fmt_elapsed(seconds: float) -> str:
    s = int(round(seconds))
    sign = "-" if s < 0 else ""
    s = abs(s)
    return f"{sign}{s // 3600:d}:{s % 3600 // 60:02d}:{s % 60:02d}"


def _bar(pa: float) -> float:
    from xlotkit.units import from_si

    return float(from_si([pa], "bar", fast=True)[0])     # shown rounded


_READER_HELP = {
    "column": "The column that plays ROLE (time, pressure, surface_pressure [the second "
              "pressure of a pair], rate, volume, return_rate, return_volume, density, "
              "temperature); NAME is its title or its 1-based number. Repeatable.",
    "unit": "The unit of the column playing ROLE (psi, bar, kPa, MPa, atm, kgf/cm2, bpm, "
            "l/min, m3/min, gal/min, s, min, h ...): supplies a unit the file never "
            "states, or corrects one. Repeatable.",
    "sheet": "Workbook sheet by name or 1-based number (default: the first sheet with a "
             "time and a pressure column).",
    "date_order": "Order of day, month and year where the dates leave it open "
                  "(01/02/2024).",
    "decimal": "Decimal separator where the numbers leave it open (3,431).",
}


def _reader_options(func):
    """The options that tell the reader what a file does not say (inspect and pick)."""
    opts = [
        click.option("--column", "columns", multiple=True, metavar="ROLE=NAME",
                     help=_READER_HELP["column"]),
        click.option("--unit", "units", multiple=True, metavar="ROLE=UNIT",
                     help=_READER_HELP["unit"]),
        click.option("--sheet", "sheet", default=None, metavar="NAME|N",
                     help=_READER_HELP["sheet"]),
        click.option("--date-order", "date_order", default=None,
                     type=click.Choice(["DMY", "MDY", "YMD"], case_sensitive=False),
                     help=_READER_HELP["date_order"]),
        click.option("--decimal", "decimal", default=None, type=click.Choice([".", ","]),
                     help=_READER_HELP["decimal"]),
    ]
    for o in reversed(opts):
        func = o(func)
    return func


def _read_kw(columns, units, sheet, date_order, decimal) -> dict:
    return {"columns": list(columns), "units": list(units), "sheet": sheet,
            "date_order": date_order.upper() if date_order else None, "decimal": decimal}


def _records(logs: list[str], read_kw: dict | None = None) -> list[tuple[list[str], object]]:
    """The records to inspect: a surface + downhole pair merged, otherwise one per log.

    Two logs are a pair when one is a cementing-unit (surface) record and the other a
    downhole gauge record; any other combination is inspected log by log.
    """
    from xlotkit.interpret.io import merge_surface_downhole, read_each

    try:
        recs = read_each(list(logs), **(read_kw or {}))
    except XlotkitError:
        raise
    except (ValueError, IndexError, KeyError) as exc:
        # a reader failing on garbage still gives one clear line
        raise InputError(f"cannot read log: {exc}", file=", ".join(logs)) from exc
    kinds = [r.reference.kind for r in recs]
    if len(recs) == 2 and sorted(kinds) == ["downhole", "surface"]:
        s, d = (recs[0], recs[1]) if kinds[0] == "surface" else (recs[1], recs[0])
        return [(list(logs), merge_surface_downhole(s, d)[0])]
    return [([p], r) for p, r in zip(logs, recs)]


def _as_json(paths, record, seg) -> dict:
    from xlotkit.interpret.io import reading_notes

    def phase(ph):
        return {
            "kind": ph.kind,
            "start_s": round(ph.t_start, 3),
            "end_s": round(ph.t_end, 3),
            "duration_s": round(ph.duration, 3),
            "pumped_m3": round(ph.pumped_m3, 4),
            "returned_m3": round(ph.returned_m3, 4),
            "peak_pressure_bar": round(_bar(ph.peak_pressure), 2),
            "evidence": [e.value for e in ph.evidence],
        }

    out = {
        "files": [str(p) for p in paths],
        "reference": record.reference.describe(),
        "start_time": record.start_time.isoformat() if record.start_time else None,
        "used_rate": seg.used_rate,
    }
    if "clock_offset_s" in record.meta:
        out["clock_offset_s"] = round(float(record.meta["clock_offset_s"]), 2)
    out["cycles"] = [
        {
            "index": c.index,
            "kind": c.kind,
            "start_s": round(c.t_start, 3),
            "end_s": round(c.t_end, 3),
            "start_time": (record.time_at(c.t_start).isoformat()
                           if record.start_time else None),
            "peak_pressure_bar": round(_bar(c.peak_pressure), 2),
            "pumped_m3": round(c.pumped_m3, 4),
            "returned_m3": round(c.returned_m3, 4),
            "reason": c.reason,
            "phases": [phase(ph) for ph in c.phases],
        }
        for c in seg.cycles
    ]
    out["reading_notes"] = reading_notes(record)
    out["notes"] = list(seg.notes)
    return out


def _as_table(paths, record, seg) -> str:
    from pathlib import Path

    from xlotkit.interpret.io import reading_notes

    lines = [", ".join(Path(p).name for p in paths)]
    lines.append(f"  pressure reference: {record.reference.describe()}"
                 + ("" if not record.reference.absolute else "; pressures below in bar abs"))
    if record.start_time is not None:
        lines.append(f"  record start: {record.start_time:%Y-%m-%d %H:%M:%S}")
    if "clock_offset_s" in record.meta:
        unc = record.meta.get("clock_offset_uncertainty_s")
        lines.append(f"  merged: downhole clock + {record.meta['clock_offset_s']:.1f} s"
                     + (f" (± {unc:.1f} s)" if unc is not None else "")
                     + " = surface clock")
    lines += [f"  read: {n}" for n in reading_notes(record)]
    lines.append("  phases from " + ("the pump rate" if seg.used_rate else "pressure alone"))
    if not seg.cycles:
        lines.append("  no cycles found")
        return "\n".join(lines)
    head = (f"  {'#':>2} {'kind':<12} {'start':>8} {'elapsed':>8} {'end':>8} {'duration':>8} "
            f"{'peak bar':>8} {'pumped m3':>9} {'return m3':>9}")
    lines.append(head)
    for c in seg.cycles:
        lines.append(
            f"  {c.index:>2} {c.kind:<12} {_fmt_clock(record, c.t_start):>8} "
            f"{_fmt_elapsed(c.t_start):>8} {_fmt_clock(record, c.t_end):>8} "
            f"{_fmt_elapsed(c.duration):>8} {_bar(c.peak_pressure):>8.1f} "
            f"{c.pumped_m3:>9.3f} {c.returned_m3:>9.3f}")
        for ph in c.phases:
            lines.append(
                f"     {'- ' + ph.kind:<12} {_fmt_clock(record, ph.t_start):>8} "
                f"{_fmt_elapsed(ph.t_start):>8} {_fmt_clock(record, ph.t_end):>8} "
                f"{_fmt_elapsed(ph.duration):>8} {_bar(ph.peak_pressure):>8.1f} "
                f"{ph.pumped_m3:>9.3f} {ph.returned_m3:>9.3f}"
                + (f"  evidence: {', '.join(e.value for e in ph.evidence)}"
                   if ph.evidence else ""))
        lines.append(f"     reason: {c.reason}")
    return "\n".join(lines)


def _plot_paths(plot: str, n: int) -> list[str]:
    """One plot file per inspected record: ``FILE`` or ``STEM-1.SUFFIX``, ``STEM-2...``."""
    from pathlib import Path

    if n == 1:
        return [plot]
    p = Path(plot)
    return [str(p.with_name(f"{p.stem}-{k + 1}{p.suffix}")) for k in range(n)]


_PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".svgz", ".eps", ".ps", ".jpg", ".jpeg", ".tif",
                  ".tiff", ".webp")


def _check_plot_target(plot: str) -> None:
    """Refuse an unknown plot format or an existing file before any work is done."""
    from pathlib import Path

    suffix = Path(plot).suffix.lower()
    if suffix not in _PLOT_SUFFIXES:
        raise InputError(f"cannot write a plot as {suffix or 'a file without suffix'!r}",
                         file=plot, key="--plot",
                         expected="a file ending in " + ", ".join(_PLOT_SUFFIXES))
    parent = Path(plot).resolve().parent
    if not parent.is_dir():
        raise InputError("the directory for the plot does not exist", file=plot,
                         key="--plot")


@main.command("inspect")
@click.argument("logs", nargs=-1, required=True, metavar="LOG [LOG ...]")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object instead of the table.")
@click.option("--plot", "plot", type=click.Path(dir_okay=False), default=None,
              metavar="FILE", help="Write an overview plot (PNG, PDF, SVG by suffix); an "
                                   "existing file is never replaced.")
@_reader_options
@_friendly_errors
def inspect_cmd(logs: tuple[str, ...], as_json: bool, plot: str | None, columns, units, sheet,
                date_order, decimal) -> None:
    """Find the cycles (line test, casing test, LOT, XLOT) and phases in field logs.

    A cementing-unit (surface) log and a downhole-gauge log of the same test are merged
    onto one clock; other logs are inspected one by one. Pressures are shown in bar (on the
    record's reference: the downhole gauge for a merged pair), volumes in m3.

    With --json a single log or merged pair prints one object with top-level "cycles"; several
    independent logs print {"logs": [object, ...]}. With several independent logs and --plot
    FILE, one plot per log is written as FILE's stem plus "-1", "-2", ....
    """
    import json
    from pathlib import Path

    for p in logs:
        path = Path(p)
        if not path.exists():
            raise InputError("no such file", file=p)
        if path.is_dir():
            raise InputError("is a directory, expected a log file", file=p)
    if plot is not None:
        _check_plot_target(plot)

    from xlotkit.interpret.phases import segment

    results = [(g, r, segment(r)) for g, r in _records(list(logs), _read_kw(
        columns, units, sheet, date_order, decimal))]

    if plot is not None:
        from xlotkit.interpret.plots.record import plot_record

        targets = _plot_paths(plot, len(results))
        for target in targets:
            if Path(target).exists():
                raise InputError("file exists; an earlier plot is never replaced",
                                 file=target, key="--plot", expected="a new file name")
        for (g, record, seg), target in zip(results, targets):
            plot_record(record, seg, path=target)

    if as_json:
        objs = [_as_json(g, r, s) for g, r, s in results]
        obj = objs[0] if len(objs) == 1 else {"logs": objs}
        click.echo(json.dumps(obj, indent=2))
    else:
        click.echo("\n\n".join(_as_table(g, r, s) for g, r, s in results))


# ====================================================================== pick
def _executor_options(func):
    """``--workers N`` (a local process pool) and ``--scheduler ADDRESS`` (Dask)."""
    func = click.option("--scheduler", "scheduler", default=None, metavar="ADDRESS",
                        help="Run on the Dask distributed cluster of this scheduler "
                             "(tcp://HOST:8786) instead of a local process pool; its workers "
                             "need xlotkit and a file system shared with DIR.")(func)
    return click.option("--workers", "workers", type=int, default=None, metavar="N",
                        help="Processes of the local pool (default: every CPU).")(func)


def _batch_options(func):
    """``--batch``, ``--workers``, ``--scheduler`` of ``pick`` (the batch interpretation)."""
    func = _executor_options(func)
    return click.option("--batch", "batch", is_flag=True,
                        help="Interpret a whole archive: LOG arguments are files, folders "
                             "or glob patterns; needs --out DIR (results.parquet, "
                             "results.csv, one folder per log).")(func)


def _parse_window(text: str):
    """``NAME=T0:T1`` or ``CYCLE:NAME=T0:T1`` (times in s from the record start)."""
    try:
        key, span = text.split("=", 1)
        t0, t1 = (float(v) for v in span.split(":", 1))
    except ValueError:
        raise InputError(f"cannot read window {text!r}", key="--window",
                         expected="NAME=T0:T1 or CYCLE:NAME=T0:T1 with times in s") from None
    if ":" in key:
        cyc, name = key.split(":", 1)
        try:
            return (int(cyc), name), (t0, t1)
        except ValueError:
            raise InputError(f"cycle {cyc!r} is not a number", key="--window",
                             expected="CYCLE:NAME=T0:T1") from None
    return key, (t0, t1)


def _pick_options(windows: tuple[str, ...], methods: tuple[str, ...]):
    from xlotkit.interpret.picks.core import PickOptions

    kw = {}
    if windows:
        kw["windows"] = dict(_parse_window(w) for w in windows)
    if methods:
        kw["methods"] = tuple(methods)
    try:
        return PickOptions(**kw)
    except ValueError as exc:
        raise InputError(str(exc), key="--window/--method") from None


def _stress_inputs(tvd, gauge_tvd, mud_density, pore_gradient, sv_gradient, mu):
    from xlotkit.interpret.estimate import GRAVITY, StressInputs

    p0 = sv = None
    if pore_gradient is not None or sv_gradient is not None:
        if tvd is None:
            raise InputError("needs the target depth", key="--pore-gradient/--sv-gradient",
                             expected="--tvd METRES as well")
        if pore_gradient is not None:
            p0 = pore_gradient * 1000.0 * GRAVITY * tvd
        if sv_gradient is not None:
            sv = sv_gradient * 1000.0 * GRAVITY * tvd
    return StressInputs(target_tvd=tvd, gauge_tvd=gauge_tvd,
                        mud_density=None if mud_density is None else mud_density * 1000.0,
                        pore_pressure=p0, sv=sv, mu=mu)


def _fmt_bar(p) -> str:
    if p is None or not p.found:
        return "-"
    return f"{p.value / 1e5:.1f}"


def _pick_table(label: str, interp) -> str:
    from xlotkit.interpret.picks.core import consensus_rule

    rp = interp.picks
    lines = [label, f"  pressure reference: {rp.record.reference.describe()}"]
    tests = rp.test_cycles
    if not tests:
        lines.append("  no test cycle (LOT, XLOT, DFIT, step-rate test, stimulation) found")
    for c in tests:
        lines.append(f"  cycle {c.index} ({c.kind})  LOP {_fmt_bar(c.get('LOP'))}  "
                     f"FBP {_fmt_bar(c.get('FBP'))}  Pr {_fmt_bar(c.get('Pr'))}  "
                     f"FPP {_fmt_bar(c.get('FPP'))}  ISIP {_fmt_bar(c.get('ISIP'))} bar"
                     + (f"  stiffness {c.stiffness / 1e5:.0f} bar/m3" if c.stiffness else ""))
        fep = c.get("FEP")
        if fep is not None:
            lines.append(f"    FEP (step-rate break): {_fmt_bar(fep)} bar"
                         + (f" [{fep.low / 1e5:.1f}-{fep.high / 1e5:.1f}]" if fep.found else
                            f" ({fep.message})"))
        f = c.fcp
        if f.found:
            lv = f"{100 * f.level:.0f} % " if f.level is not None else ""
            lines.append(f"    FCP {f.value / 1e5:.1f} bar, {lv}interval "
                         f"[{(f.low or f.value) / 1e5:.1f} - "
                         f"{(f.high or f.value) / 1e5:.1f}] ({f.quality}; "
                         f"{consensus_rule(f)})")
        else:
            lines.append(f"    FCP: none ({f.message[:100]})")
        for m, p in c.fcp_methods().items():
            if p.found:
                lo = p.low if p.low is not None else p.value
                hi = p.high if p.high is not None else p.value
                lv = f"{100 * p.level:.0f} %" if p.level is not None else "range"
                lines.append(f"      {m:<16} {p.value / 1e5:8.1f} bar {lv} [{lo / 1e5:.1f} - "
                             f"{hi / 1e5:.1f}] {p.quality}")
            else:
                lines.append(f"      {m:<16}        - {p.message[:70]}")
    agreement = rp.consistency.closure
    if agreement is not None and agreement.found:
        lines.append(f"  closure of the record {agreement.value / 1e5:.1f} bar "
                     f"[{agreement.low / 1e5:.1f} - {agreement.high / 1e5:.1f}]: "
                     f"{agreement.message}")
        for _, why in agreement.outliers:
            lines.append(f"    outlier {why}")
    s = interp.stress
    if s.available:
        d = s.to_dict()
        lines.append(f"  stress at {d['target_tvd_m']:g} m TVD: sigma_h {d['sigma_h_bar']:.1f} bar "
                     f"[{d['sigma_h_low_bar']:.1f} - {d['sigma_h_high_bar']:.1f}] "
                     f"({d['sigma_h_emw_sg']:.3f} sg)")
        if d["t0_bar"] is not None:
            lines.append(f"    T0 = FBP - Pr = {d['t0_bar']:.1f} bar [{d['t0_low_bar']:.1f} - "
                         f"{d['t0_high_bar']:.1f}]")
        for eq, v in d["sigma_H"].items():
            if v["value_bar"] is not None:
                lines.append(f"    sigma_H (Eq. {eq}) {v['value_bar']:.1f} bar "
                             f"[{v['low_bar']:.1f} - {v['high_bar']:.1f}] {v['message']}")
        if d["regime"]:
            lines.append(f"    regime (mu={d['mu']}): {d['regime']}")
        for a in d["assumptions"]:
            lines.append(f"    assumed: {a}")
        for o in d.get("omitted", []):
            lines.append(f"    not estimated: {o}")
    else:
        lines.append(f"  stress: {s.message}")
    if interp.diagnostics is not None:
        for cd in interp.diagnostics.cycles:
            if cd.g_function is not None:
                lines.append(f"  cycle {cd.cycle} {cd.g_function.report()}")
            lines.append(f"  cycle {cd.cycle} {cd.after_closure.report()}")
    return "\n".join(lines)


@main.command("pick")
@click.argument("logs", nargs=-1, required=True, metavar="LOG [LOG ...]")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--out", "out", type=click.Path(file_okay=False), default=None, metavar="DIR",
              help="Write picks.csv, picks.json, annotated plots and report.pdf into DIR "
                   "(a fresh DIR-2, DIR-3... if DIR already holds results).")
@click.option("--window", "windows", multiple=True, metavar="[CYCLE:]NAME=T0:T1",
              help="Override an automatic window (s from the record start); NAME is a pick "
                   "(LOP, FBP, Pr, FPP, ISIP) or an FCP method. Repeatable.")
@click.option("--method", "methods", multiple=True,
              help="Run only these FCP methods (repeatable).")
@click.option("--tvd", type=float, default=None, help="Target (open-hole) TVD [m].")
@click.option("--gauge-tvd", type=float, default=None, help="Gauge TVD [m].")
@click.option("--mud-density", type=float, default=None, help="Well-fluid density [sg].")
@click.option("--pore-gradient", type=float, default=None,
              help="Pore pressure gradient [sg EMW] (default 1.03).")
@click.option("--sv-gradient", type=float, default=None,
              help="Vertical stress gradient [sg EMW] (default 2.30).")
@click.option("--mu", type=float, default=0.6, show_default=True,
              help="Friction coefficient for the stress polygon.")
@_reader_options
@_batch_options
@_friendly_errors
def pick_cmd(logs, as_json, out, windows, methods, tvd, gauge_tvd, mud_density,
             pore_gradient, sv_gradient, mu, columns, units, sheet, date_order,
             decimal, batch, workers, scheduler) -> None:
    """Pick LOP, FBP, Pr, FPP, ISIP and closure (every method) with intervals; estimate stress.

    Logs are grouped as for `inspect` (a surface + downhole pair is merged). The table shows
    every test cycle with each closure method's pick and interval, the consensus FCP and the
    stress estimate. --json prints one object with a "cycles" list (several independent logs:
    {"logs": [...]}).

    With --batch, LOG arguments are files, folders or glob patterns of a whole archive:
    every log (a surface + downhole pair of one test merged) is interpreted on its own, on
    a local process pool (--workers N) or a Dask cluster (--scheduler ADDRESS), into
    DIR/results.parquet and DIR/results.csv (one row per test cycle) and one folder per log
    in DIR/logs/; a rerun into the same DIR continues where it stopped.
    """
    import json
    from pathlib import Path

    from xlotkit.interpret.report import picks_to_dict
    from xlotkit.pipeline import interpret_record, write_interpretation

    if batch:
        _pick_batch(logs, out, as_json, _pick_options(windows, methods),
                    _stress_inputs(tvd, gauge_tvd, mud_density, pore_gradient, sv_gradient,
                                   mu), workers, scheduler,
                    _read_kw(columns, units, sheet, date_order, decimal))
        return
    _refuse_executor_options(workers, scheduler, "--batch")
    for p in logs:
        if not Path(p).is_file():
            raise InputError("no such file", file=p)
    options = _pick_options(windows, methods)
    sin = _stress_inputs(tvd, gauge_tvd, mud_density, pore_gradient, sv_gradient, mu)
    results = []
    for group, record in _records(list(logs), _read_kw(columns, units, sheet, date_order,
                                                       decimal)):
        label = " + ".join(Path(g).name for g in group)
        results.append((label, interpret_record(record, options=options, stress_inputs=sin)))
    written = []
    if out is not None:
        for k, (label, interp) in enumerate(results):
            target = Path(out) if len(results) == 1 else Path(out) / f"log-{k + 1}"
            paths = write_interpretation(interp, target)
            written.append(paths["dir"])
    if as_json:
        objs = [picks_to_dict(i.picks, i.stress.to_dict(), i.diagnostics) for _, i in results]
        obj = objs[0] if len(objs) == 1 else {"logs": objs}
        click.echo(json.dumps(obj, indent=2, allow_nan=False))
    else:
        click.echo("\n\n".join(_pick_table(label, i) for label, i in results))
        for d in written:
            click.echo(f"report written to {d}")


# ====================================================================== demo
@main.command("demo")
@click.option("--out", "out", type=click.Path(file_okay=False), default="results/demo",
              show_default=True, metavar="DIR",
              help="Results folder (a fresh DIR-2, DIR-3... if DIR already holds results).")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the gauge noise.")
@click.option("--noise", type=float, default=0.05, show_default=True,
              help="Gauge noise standard deviation [bar].")
@click.option("--model", "model", type=click.Choice(["2d", "lumped"]), default="2d",
              show_default=True,
              help="2d: the 2D MDEM model on the standard scene "
                   "(examples/scene_2d_standard.toml, about a minute); lumped: the lumped "
                   "model (about a second).")
@_friendly_errors
def demo_cmd(out: str, seed: int, noise: float, model: str) -> None:
    """Simulate a two-cycle XLOT, read its log back, pick it and write plots and a report."""
    from tqdm import tqdm

    from xlotkit.pipeline import run_demo

    with tqdm(total=100, desc="demo", unit="%", bar_format="{l_bar}{bar}| {elapsed}",
              file=sys.stderr) as bar:
        def progress(frac: float, msg: str) -> None:
            bar.set_description(f"demo: {msg}")
            bar.update(max(0, int(round(100 * frac)) - bar.n))

        def started(folder) -> None:
            from pathlib import Path

            where = (f"{out} holds earlier results; the demo writes to {folder}"
                     if Path(folder) != Path(out) else f"results in {folder}")
            bar.write(where, file=sys.stderr)

        res = run_demo(out, model=model, seed=seed, noise_bar=noise, progress=progress,
                       started=started)
    click.echo(res.summary)
    click.echo(f"results in {res.out_dir}")


# ====================================================================== simulate
@main.command("simulate")
@click.argument("scene_file", metavar="SCENE.toml", type=click.Path(dir_okay=False))
@click.option("--out", "out", type=click.Path(file_okay=False), required=True, metavar="DIR",
              help="Results folder (a fresh DIR-2, DIR-3... if DIR already holds results).")
@click.option("--resume", is_flag=True,
              help="Continue the interrupted run in DIR from its last checkpoint.")
@click.option("--seed", type=int, default=None,
              help="Seed of every random draw (mesh jitter, heterogeneity, gauge noise); "
                   "overrides the scene's seeds.")
@_friendly_errors
def simulate_cmd(scene_file: str, out: str, resume: bool, seed: int | None) -> None:
    """Simulate the XLOT described by a scene file and write its outputs.

    Writes timeseries.h5 (time series, scene, truth), synthetic_log.csv (the field log that
    `xlotkit inspect` and `xlotkit pick` read), summary.json, the scene, and for the 2D
    model VTU snapshots with fields.pvd. A run interrupted (Ctrl-C, killed) continues with
    --resume from its last checkpoint to the same result.
    """
    from tqdm import tqdm

    from xlotkit.sim.run import SimulationInterrupted, require_engine, simulate
    from xlotkit.sim.scene import load_scene

    scene = load_scene(scene_file)
    if seed is not None:
        if seed < 0:
            raise InputError(f"value {seed} is out of range", key="--seed",
                             expected="an integer >= 0")
        scene = scene.with_seed(seed)
    require_engine(scene)
    with tqdm(total=1000, desc="simulate", unit="", file=sys.stderr,
              bar_format="{l_bar}{bar}| {elapsed}<{remaining} {postfix}",
              mininterval=0.2) as bar:
        def progress(frac: float, msg: str) -> None:
            n = int(round(1000 * frac))
            if n > bar.n:
                bar.set_postfix_str(msg, refresh=False)
                bar.update(n - bar.n)

        def started(folder, redirected: bool) -> None:
            # named now, not only at the end: a user who stops the run must know where
            if redirected:
                bar.write(f"{out} holds earlier results; this run writes to {folder}",
                          file=sys.stderr)
            elif resume:
                bar.write(f"resuming the run in {folder}", file=sys.stderr)
            else:
                bar.write(f"results in {folder}", file=sys.stderr)

        try:
            res = simulate(scene, out, resume=resume, progress=progress, started=started)
        except SimulationInterrupted as exc:
            bar.close()
            seed_opt = "" if seed is None else f" --seed {seed}"
            click.echo(f"interrupted; continue with: xlotkit simulate {scene_file} --out "
                       f"{exc.out_dir}{seed_opt} --resume", err=True)
            sys.exit(130)
    click.echo(res.summary)
    tr = res.truth["imposed"]
    click.echo(f"imposed: sigma_h {tr['sigma_h'] / 1e5:.1f} bar, sigma_H "
               f"{tr['sigma_H'] / 1e5:.1f} bar, T0 {tr['tensile_strength'] / 1e5:.1f} bar, "
               f"p0 {tr['pore_pressure'] / 1e5:.1f} bar")
    click.echo(f"results in {res.paths['dir']}" + (" (resumed)" if res.resumed else ""))


# ====================================================================== library
@main.group("library")
def library_group() -> None:
    """The synthetic XLOT library: simulate its scenes, check the picks against the truth."""


def _progress_bar(desc: str):
    from tqdm import tqdm

    bar = tqdm(total=1000, desc=desc, unit="", file=sys.stderr,
               bar_format="{l_bar}{bar}| {elapsed}<{remaining} {postfix}", mininterval=0.5)

    def progress(frac: float, msg: str) -> None:
        n = int(round(1000 * frac))
        if n > bar.n:
            bar.set_postfix_str(msg[:60], refresh=False)
            bar.update(n - bar.n)

    return bar, progress


@library_group.command("build")
@click.argument("root", metavar="ROOT", type=click.Path(file_okay=False))
@click.option("--only", "names", multiple=True, metavar="NAME",
              help="Only this scene (repeatable).")
@click.option("--replace", is_flag=True,
              help="Simulate every selected scene again and replace its stored log and truth "
                   "(without it, scenes that have a log are kept).")
@_friendly_errors
def library_build_cmd(root: str, names: tuple[str, ...], replace: bool) -> None:
    """Simulate the scenes of library ROOT (ROOT/<name>/scene.toml) and store each log
    (log.csv) and truth (truth.json) beside its scene."""
    from xlotkit.library import build

    bar, progress = _progress_bar("library")
    with bar:
        out = build(root, names or None, replace=replace, progress=progress)
    for o in out:
        if o.action == "kept":
            click.echo(f"{o.entry.name}: kept (has a log; --replace simulates it again)")
        else:
            click.echo(f"{o.entry.name}: {o.status}, {o.wall_time:.1f} s: {o.message}")


def _refuse_existing(markdown: str | None) -> None:
    """Stop before any work when ``--markdown FILE`` names a file that exists (results are
    never written over)."""
    from pathlib import Path

    if markdown is not None and Path(markdown).exists():
        raise InputError("exists already; results are never written over", file=markdown,
                         expected="a new file name")


def _show_table(table: str, markdown: str | None) -> None:
    """Print a Markdown table and, with ``--markdown FILE``, write it there too."""
    from pathlib import Path

    from xlotkit.atomic import atomic_write_text

    click.echo(table)
    if markdown is not None:
        atomic_write_text(Path(markdown), table)


@library_group.command("check")
@click.argument("root", metavar="ROOT", type=click.Path(file_okay=False))
@click.option("--only", "names", multiple=True, metavar="NAME",
              help="Only this scene (repeatable).")
@click.option("--markdown", "markdown", type=click.Path(dir_okay=False), default=None,
              metavar="FILE", help="Also write the table to FILE (a new file only).")
@_friendly_errors
def library_check_cmd(root: str, names: tuple[str, ...], markdown: str | None) -> None:
    """Pick every stored log of library ROOT and compare with the realised stresses.

    Flowback system-stiffness FCP within 3 % of sigma_h where a flowback goes through
    closure; shut-in methods within 5 % where the shut-in holds a closure and no pick where
    it clearly does not. Exit status 1 when any scene misses.
    """
    from xlotkit.library import entries, evaluate, evaluation_markdown

    _refuse_existing(markdown)
    evals = [evaluate(e) for e in entries(root, names or None)]
    _show_table(evaluation_markdown(evals), markdown)
    misses = [(ev.entry.name, f) for ev in evals
              for f in (*ev.failures, *(x for c in ev.cycles for x in c.failures))]
    for name, f in misses:
        click.echo(f"MISS {name}: {f}")
    if misses:
        sys.exit(1)


@library_group.command("list")
@click.argument("root", metavar="ROOT", type=click.Path(file_okay=False))
@click.option("--only", "names", multiple=True, metavar="NAME",
              help="Only this scene (repeatable).")
@click.option("--markdown", "markdown", type=click.Path(dir_okay=False), default=None,
              metavar="FILE", help="Also write the table to FILE (a new file only).")
@_friendly_errors
def library_list_cmd(root: str, names: tuple[str, ...], markdown: str | None) -> None:
    """Table of the scenes of library ROOT from their stored truths: imposed and realised
    sigma_h, sigma_H, T0, FBP, crack half-length, steps and wall time."""
    from xlotkit.library import entries, scenes_markdown

    _refuse_existing(markdown)
    _show_table(scenes_markdown(entries(root, names or None)), markdown)


@library_group.command("compare")
@click.argument("root", metavar="ROOT", type=click.Path(file_okay=False))
@click.option("--only", "names", multiple=True, metavar="NAME",
              help="Only this scene (repeatable).")
@_friendly_errors
def library_compare_cmd(root: str, names: tuple[str, ...]) -> None:
    """Simulate the scenes of library ROOT again (in a temporary folder) and compare each new
    log with the stored one. Exit status 1 when any differs."""
    from xlotkit.library import compare

    bar, progress = _progress_bar("compare")
    with bar:
        out = compare(root, names or None, progress=progress)
    for c in out:
        click.echo(f"{c.entry.name}: {'same' if c.same else 'DIFFERENT'} ({c.message})")
    if not all(c.same for c in out):
        sys.exit(1)


# ====================================================================== studies
def _refuse_executor_options(workers, scheduler, needs: str) -> None:
    """The executor options are for a study only (never accepted and ignored)."""
    for flag, v in (("--workers", workers), ("--scheduler", scheduler)):
        if v is not None:
            raise InputError("is for a batch of logs", key=flag, expected=f"{needs} as well")


def _executor(workers, scheduler):
    from xlotkit.study.executors import DaskCluster, LocalPool, default_workers

    if scheduler is not None:
        if workers is not None:
            raise InputError("sets the local pool, not a Dask cluster's workers", key="--workers",
                             expected="--workers or --scheduler, not both (a cluster's "
                                      "workers are set where it is started)")
        return DaskCluster(address=scheduler)
    return LocalPool(default_workers() if workers is None else workers)


def _run_study(run, what: str, command: str):
    """Run a study with one progress bar; Ctrl-C says how to continue."""
    bar, progress = _progress_bar(what)
    try:
        with bar:
            return run(progress)
    except KeyboardInterrupt:
        click.echo(f"interrupted; the finished {what} are kept: run `{command}` again to "
                   f"continue", err=True)
        sys.exit(130)


def _study_report(res, what: str) -> None:
    """The summary lines of a finished study; exit status 1 if items were lost."""
    n_items = len(res.computed) + len(res.skipped) + len(res.lost)
    counts = res.table["status"].value_counts() if len(res.table) else {}
    statuses = ", ".join(f"{int(v)} {k}" for k, v in counts.items())
    click.echo(f"{n_items} {what} ({len(res.skipped)} finished earlier, {len(res.computed)} "
               f"run now on {res.executor}) in {res.wall_time:.1f} s; rows: {statuses}")
    bad = [r for r in res.table.to_dict("records") if r.get("status") in ("failed", "lost")]
    for r in bad[:10]:
        click.echo(f"  {r['status']}: {r.get('case', r.get('log'))}: {r['message']}")
    if len(bad) > 10:
        click.echo(f"  ... {len(bad) - 10} more in the table")
    click.echo(f"table: {res.paths['parquet']}, {res.paths['csv']}")
    if res.lost:
        click.echo(f"{len(res.lost)} {what} did not come back; run the same command again "
                   f"to run them", err=True)
        sys.exit(1)


def _pick_batch(logs, out, as_json, options, stress_inputs, workers, scheduler,
                read_kw) -> None:
    """``xlotkit pick --batch``: every log of an archive into one table, every file read
    with the same reader options (``read_kw``, as :func:`_read_kw` gives them)."""
    import shlex

    from xlotkit.interpret.io import read_options
    from xlotkit.study.batch import BatchSpec, expand_inputs, run_batch

    if out is None:
        raise InputError("a batch needs a results folder", key="--batch",
                         expected="--out DIR")
    if as_json:
        raise InputError("is for single logs; a batch writes DIR/results.parquet and "
                         "results.csv", key="--json", expected="--json without --batch")
    executor = _executor(workers, scheduler)
    expand_inputs(logs)             # an input that names no file: one error, before the bar
    spec = BatchSpec(tuple(logs), options, stress_inputs,
                     read_options=read_options(**read_kw, strict=False))
    command = "xlotkit pick --batch " + " ".join(shlex.quote(x) for x in logs) + \
        f" --out {shlex.quote(out)}"
    res = _run_study(lambda progress: run_batch(spec, out, executor=executor,
                                                progress=progress), "logs", command)
    _study_report(res, "log groups")


@main.command("sweep")
@click.argument("scene_file", metavar="SCENE.toml", type=click.Path(dir_okay=False))
@click.option("--vary", "vary", multiple=True, metavar="KEY=V1,V2,...|KEY=LOW:HIGH[:log]",
              help="A dotted scene key and its values (units as in a scene: "
                   "'stresses.sigma_h=28 MPa,30 MPa,32 MPa'), or with --samples a range "
                   "('rock.permeability=1e-19:1e-17:log'). Repeatable: lists make a grid.")
@click.option("--samples", type=int, default=None, metavar="N",
              help="Draw N cases by Latin-hypercube sampling from the --vary ranges.")
@click.option("--seed", type=int, default=None, metavar="S",
              help="Seed of the --samples draws (default 0; same seed, same cases).")
@click.option("--out", "out", type=click.Path(file_okay=False), required=True, metavar="DIR",
              help="Study folder: new, or the folder of the same sweep to continue it.")
@_executor_options
@_friendly_errors
def sweep_cmd(scene_file, vary, samples, seed, out, workers, scheduler) -> None:
    """Simulate many cases of a scene and pick each synthetic log as a field log.

    Writes DIR/results.parquet and DIR/results.csv (one row per case: the varied inputs,
    the picks -- FCP per method, ISIP, FBP, Pr -- with their errors against the imposed and
    the realised stresses, wall time and status) and one folder per case in DIR/cases/
    (scene, simulation, log, case.log). A failed case is a row with its error and does not
    stop the sweep. A rerun of the same command continues: finished cases are kept.
    Every case's scene is checked before any runs: a bad --vary key or value is one error.
    """
    import shlex

    from xlotkit.study.sweep import SweepSpec, plan_sweep, run_sweep

    spec = SweepSpec.from_options(scene_file, vary, samples, seed)
    executor = _executor(workers, scheduler)
    plan = plan_sweep(spec, out)    # every case's scene checked before the bar and the pool
    command = " ".join(["xlotkit sweep", shlex.quote(scene_file),
                        *(f"--vary {shlex.quote(v)}" for v in vary),
                        *([f"--samples {samples}"] if samples is not None else []),
                        *([f"--seed {seed}"] if seed is not None else []),
                        f"--out {shlex.quote(out)}"])
    res = _run_study(lambda progress: run_sweep(spec, out, executor=executor,
                                                progress=progress, plan=plan),
                     "cases", command)
    _study_report(res, "cases")
