"""The driver: run a scene to the end with checkpoints, write its outputs (:func:`simulate`)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import re
import signal
import threading
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from xlotkit import __version__
from xlotkit.atomic import atomic_write, atomic_write_text, fresh_output_dir
from xlotkit.errors import InputError, XlotkitError
from xlotkit.record import Record
from xlotkit.sim.output import (
    TRUTH_QUANTITIES,
    check_rows,
    surface_gauge_record,
    synthetic_log,
    write_pvd,
    write_snapshot,
    write_timeseries,
)
from xlotkit.sim.run.contract import Engine, EngineResult
from xlotkit.sim.run.engines import make_engine
from xlotkit.sim.scene import SCENE_KEYS, Scene

__all__ = ["CHECKPOINT", "SimulationInterrupted", "SimulationResult", "simulate"]

CHECKPOINT = "checkpoint.npz"
_CHECKPOINT_FORMAT = 1


class SimulationInterrupted(KeyboardInterrupt):
    """The run was interrupted (Ctrl-C, or the progress callback raised KeyboardInterrupt).

    Attributes
    ----------
    out_dir : Path
        The run's folder, to pass back with ``resume=True``.
    has_checkpoint : bool
        Whether a checkpoint was written before the interruption (else a resume starts
        over in the same folder).
    """

    def __init__(self, out_dir: Path, has_checkpoint: bool) -> None:
        super().__init__(f"simulation in {out_dir} interrupted")
        self.out_dir = out_dir
        self.has_checkpoint = has_checkpoint


@dataclass(frozen=True)
class SimulationResult:
    """What :func:`simulate` produced.

    Attributes
    ----------
    status : {"ok", "stopped"}
        ``stopped``: a phase hit ``numerics.max_phase_duration``.
    message : str
    model : str
        The model that ran.
    record : Record
        The synthetic field log as written (noise and resolution applied).
    clean_record : Record
        The engine's record before gauge effects.
    truth : dict
        The engine's truth plus ``imposed`` and ``realised`` (sigma_h, sigma_H,
        tensile_strength, pore_pressure) and ``realised_detail`` (every quantity the
        engine reports as realised, e.g. the 2D engine's stress range over the crack).
    paths : dict of str to Path
        ``dir``, ``scene``, ``scene_resolved``, ``timeseries``, ``log``, ``summary`` and,
        with snapshots, ``pvd``.
    n_steps : int
        Engine steps (including rejected trials).
    resumed : bool
        Whether the run continued from a checkpoint.
    wall_time : float
        Wall-clock seconds of this call.
    """

    status: str
    message: str
    model: str
    record: Record
    clean_record: Record
    truth: dict[str, Any]
    paths: dict[str, Path]
    n_steps: int
    resumed: bool = False
    wall_time: float = 0.0
    summary: str = field(default="")


def _scene_hash(scene: Scene) -> str:
    return hashlib.sha256(scene.to_toml().encode("utf-8")).hexdigest()


def _save_checkpoint(path: Path, engine: Engine, driver: dict[str, Any]) -> None:
    arrays: dict[str, Any] = {}
    for k, v in engine.state().items():
        arrays[f"engine:{k}"] = np.asarray(v)
    arrays["driver"] = np.asarray(json.dumps(driver))
    arrays["format"] = np.asarray(_CHECKPOINT_FORMAT)

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    atomic_write(path, write)


def _load_checkpoint(path: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    try:
        with np.load(path, allow_pickle=False) as z:
            if int(z["format"]) != _CHECKPOINT_FORMAT:
                raise InputError("checkpoint format not understood", file=path)
            driver = json.loads(str(z["driver"]))
            state = {k[len("engine:"):]: (z[k].item() if z[k].ndim == 0 else z[k])
                     for k in z.files if k.startswith("engine:")}
    except (OSError, ValueError, KeyError) as exc:
        raise InputError(f"cannot read checkpoint: {exc}", file=path) from None
    return driver, state


def simulate(scene: Scene, out_dir: str | Path, *, resume: bool = False,
             progress: Callable[[float, str], None] | None = None,
             started: Callable[[Path, bool], None] | None = None) -> SimulationResult:
    """Run a scene to the end, with checkpoints, and write its outputs.

    Parameters
    ----------
    scene : Scene
    out_dir : str or Path
        Results folder. A fresh run uses it when it does not exist or is empty, else the
        first free sibling ``DIR-2``, ``DIR-3``, ... (earlier results are never touched).
        With ``resume`` it must be the folder of the interrupted run.
    resume : bool
        Continue from ``out_dir/checkpoint.npz`` (or start over in ``out_dir`` if the run
        was stopped before its first checkpoint). The scene must be the one of the run.
        Snapshots written after the checkpoint are the run's own and are written again.
    progress : callable, optional
        ``progress(fraction, message)`` after every step. An exception it raises (e.g.
        KeyboardInterrupt) stops the run; a checkpoint of the state after the last step is
        written first.
    started : callable, optional
        ``started(folder, redirected)`` once the results folder is chosen, before the
        first step: ``redirected`` is True when ``out_dir`` held results and the run
        writes into a sibling ``DIR-2``, ... instead.

    Checkpoints (``checkpoint.npz``, atomic) are written when the run starts, at every
    phase end, every ``numerics.checkpoint_steps`` steps or ``numerics.checkpoint_seconds``
    of wall time, and when the run is interrupted (Ctrl-C is taken between two steps, so
    the checkpoint is of a whole step; a second Ctrl-C stops at once, the last checkpoint
    standing): an interrupted or killed run can always be resumed.

    Returns
    -------
    SimulationResult

    Raises
    ------
    EngineNotAvailable
        When the scene needs a model without an engine.
    InputError
        For a resume into a folder without a run of this scene; for a run that fails part
        way, naming the time, the phase and (where it can) the scene key behind it.
    SimulationInterrupted
        When interrupted; ``out_dir`` and the checkpoint are in it.
    """
    wall0 = _time.perf_counter()
    engine = make_engine(scene)
    out = Path(out_dir)
    chash = _scene_hash(scene)
    driver: dict[str, Any] = {"n_steps": 0, "snapshots": [], "next_snapshot": 0.0,
                              "scene_hash": chash, "model": engine.model, "phase": 0}
    resumed = False
    if resume:
        saved = _resume_point(scene, out, chash)
        if saved is not None:
            driver, state = saved
            driver.setdefault("phase", 0)
            engine.restore(state)
            resumed = True
        target = out
    else:
        target = fresh_output_dir(out)
    paths: dict[str, Path] = {"dir": target, "scene": target / "scene.toml",
                              "scene_resolved": target / "scene.resolved.toml"}
    ck_path = target / CHECKPOINT
    snap_dir = target / "snapshots"
    snap_every = scene.output.snapshot_interval

    def take_snapshots() -> None:
        if snap_every is None:
            return
        while engine.time >= driver["next_snapshot"] - 1e-9 * snap_every:
            snap = engine.snapshot()
            if snap is None:
                return
            snap_dir.mkdir(exist_ok=True)
            k = len(driver["snapshots"])
            name = f"snapshots/fields_{k:05d}.vtu"
            write_snapshot(target / name, snap)
            driver["snapshots"].append([float(snap.time), name])
            driver["next_snapshot"] += snap_every
            write_pvd(target / "fields.pvd", driver["snapshots"])

    num = scene.numerics
    # from here a Ctrl-C is taken between two steps (the first one; see _deferred_interrupt)
    with _deferred_interrupt() as asked:
        whole = resumed     # the engine and the driver's book are at a step's end
        try:
            if started is not None:
                started(target, not resume and target != out)
            _tidy_snapshots(target, driver["snapshots"])
            if not resumed:
                atomic_write_text(paths["scene"], scene.text)
                atomic_write_text(paths["scene_resolved"], scene.to_toml())
                engine.start()
                take_snapshots()
                _save_checkpoint(ck_path, engine, driver)   # a run killed now can resume
                whole = True
            since, last_ck = 0, _time.perf_counter()
            while not engine.is_done():
                if asked():
                    raise KeyboardInterrupt
                whole = False
                try:
                    outcome = engine.step()
                except (XlotkitError, RuntimeError, FloatingPointError) as exc:
                    raise _failed(scene, engine, driver, exc) from exc
                driver["n_steps"] += 1
                reason = getattr(outcome, "reason", "")
                if reason.startswith(("phase start", "phase end at start")):
                    driver["phase"] += 1
                since += 1
                take_snapshots()
                whole = True
                now = _time.perf_counter()
                if (since >= num.checkpoint_steps or now - last_ck >= num.checkpoint_seconds
                        or reason.startswith("phase end")) and not asked():
                    _save_checkpoint(ck_path, engine, driver)
                    since, last_ck = 0, now
                if progress is not None:
                    progress(engine.progress(), f"t = {engine.time:.0f} s")
        except KeyboardInterrupt as exc:
            if whole:
                _save_checkpoint(ck_path, engine, driver)
            raise SimulationInterrupted(target, ck_path.exists()) from exc
    res = engine.result()
    return _finish(scene, engine, res, driver, target, paths, resumed,
                   _time.perf_counter() - wall0)


def _resume_point(scene: Scene, out: Path, chash: str
                  ) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """The checkpoint to resume ``out`` from, or None to start over in it (a run stopped
    before its first checkpoint; its partial outputs are its own and are written again).

    Raises
    ------
    InputError
        No such folder, a finished run, another scene's run, or a folder that holds
        something else.
    """
    if not out.is_dir():
        raise InputError("no such results folder to resume", file=out,
                         expected="the --out folder of an interrupted run")
    differs = InputError("the scene differs from the one of the interrupted run", file=out,
                         key="resume", expected="the same scene file and --seed as the "
                                                "first run")
    ck = out / CHECKPOINT
    if ck.exists():
        saved, state = _load_checkpoint(ck)
        if saved.get("scene_hash") != chash:
            raise InputError(differs.message, file=ck, key="resume",
                             expected=differs.expected)
        return saved, state
    if (out / "summary.json").exists():
        raise InputError("this run has finished; nothing to resume", file=out,
                         key="resume", expected="the folder of an interrupted run")
    ours = {"scene.toml", "scene.resolved.toml", "snapshots", "fields.pvd"}
    if any(p.name not in ours for p in out.iterdir()):
        raise InputError("the folder holds no checkpoint of an interrupted run", file=out,
                         key="resume", expected="the folder of an interrupted run")
    resolved = out / "scene.resolved.toml"
    if resolved.exists() and resolved.read_text(encoding="utf-8") != scene.to_toml():
        raise differs
    return None


def _tidy_snapshots(target: Path, kept: list) -> None:
    """Remove the snapshots a resumed run's checkpoint does not know (written after it, by
    the same run: the resumed run writes them again, so the series has no duplicates)."""
    snap_dir = target / "snapshots"
    if not snap_dir.is_dir():
        return
    known = {Path(name).name for _, name in kept}
    for f in snap_dir.glob("fields_*.vtu"):
        if f.name not in known:
            f.unlink()
    pvd = target / "fields.pvd"
    if kept:
        write_pvd(pvd, kept)
    elif pvd.exists():
        pvd.unlink()


@contextlib.contextmanager
def _deferred_interrupt():
    """Take a Ctrl-C (SIGINT) between two steps: the first one sets a flag the loop reads
    after the step in progress (``asked()``), a second one interrupts at once. Only in the
    main thread (signal handlers cannot be set elsewhere; there Ctrl-C interrupts as is)."""
    flag = {"n": 0}

    def asked() -> bool:
        return flag["n"] > 0

    if threading.current_thread() is not threading.main_thread():
        yield asked
        return

    def handler(signum, frame):
        flag["n"] += 1
        if flag["n"] > 1:
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield asked
    finally:
        signal.signal(signal.SIGINT, previous)


_SCENE_KEY = re.compile(r"\b(?:schedule\.phase\[\d+\](?:\.\w+)?|(?:"
                        + "|".join(s for s in SCENE_KEYS if s) + r")\.\w+)")


def _failed(scene: Scene, engine: Engine, driver: dict[str, Any],
            exc: BaseException) -> InputError:
    """The error of a run that fails part way: when, in which phase, and the scene key
    behind it where one is known (the error's own key, a key its message names, or the
    key the failure points to)."""
    plan = scene.schedule.expanded()
    i = min(max(driver.get("phase", 0) - 1, 0), len(plan) - 1)
    cyc, ph = plan[i]
    n = len(scene.schedule.phases)
    where = (f"at t = {engine.time:.3f} s, in phase {i + 1} (cycle {cyc}, {ph.label}; "
             f"schedule.phase[{i % n}])")
    msg = exc.message if isinstance(exc, InputError) else str(exc)
    key = exc.key if isinstance(exc, InputError) else None
    expected = exc.expected if isinstance(exc, InputError) else None
    if key is not None and not _SCENE_KEY.fullmatch(key) and key not in SCENE_KEYS[""]:
        key = None
    if key is None:
        m = _SCENE_KEY.search(msg)
        key = m.group(0) if m else None
    if key is None:
        key, expected = _failure_key(scene, exc)
    return InputError(f"the run failed {where}: {msg}", file=scene.source_file, key=key,
                      expected=expected)


def _failure_key(scene: Scene, exc: BaseException) -> tuple[str | None, str | None]:
    """The scene key a failure without one points to."""
    num = scene.numerics
    if isinstance(exc, InputError) and exc.key == "column":
        return ("fluid.compressibility",
                "a fluid column that stands at the pressures of the test (fluid."
                "compressibility, fluid.density, completion.depth, effects.pipe_friction)")
    if scene.resolved_model == "mdem":
        return ("numerics.dt_max",
                f"gentler steps: a smaller numerics.dt_max (now {num.dt_max:g} s) or "
                f"numerics.dp_max (now {num.dp_max:g} Pa), or a smaller numerics.dt_min "
                f"(now {num.dt_min:g} s)")
    return ("numerics.dp_max",
            f"a smaller numerics.dp_max (now {num.dp_max:g} Pa): the lumped model's "
            f"largest pressure change per step")


def _finish(scene: Scene, engine: Engine, res: EngineResult, driver: dict[str, Any], target: Path,
            paths: dict[str, Path], resumed: bool, wall: float) -> SimulationResult:
    from xlotkit.logfile import write_log

    st = scene.stresses
    imposed = {"sigma_h": st.sigma_h, "sigma_H": st.sigma_H,
               "tensile_strength": scene.rock.tensile_strength,
               "pore_pressure": st.pore_pressure}
    realised = dict(imposed)
    realised.update({k: float(v) for k, v in dict(res.truth.get("realised", {})).items()
                     if k in TRUTH_QUANTITIES and v is not None})
    truth_model = {k: v for k, v in res.truth.items() if k not in ("realised", "wall_time")}
    clean: Record = res.record
    out = scene.output
    if out.gauge == "surface":
        log = synthetic_log(surface_gauge_record(clean), interval=out.log_interval,
                            noise=out.noise, resolution=out.resolution,
                            seed=scene.noise_seed, channels=())
    else:
        log = synthetic_log(clean, interval=out.log_interval, noise=out.noise,
                            resolution=out.resolution, seed=scene.noise_seed)
    log = log.replace(meta={**log.meta, "source": f"xlotkit simulate ({engine.model})",
                            "scene": scene.title or (scene.source_file or "")})
    rows = check_rows(engine.rows())
    paths["timeseries"] = target / "timeseries.h5"
    write_timeseries(paths["timeseries"], rows, record=clean, truth=truth_model,
                     imposed=imposed, realised=realised,
                     attrs={"model": engine.model, "coupling": scene.coupling,
                            "seed": int(scene.seed), "noise_seed": int(scene.noise_seed),
                            "scene": scene.text, "scene_resolved": scene.to_toml(),
                            "scene_file": scene.source_file or "", "status": res.status,
                            "message": res.message, "n_steps": int(driver["n_steps"])})
    paths["log"] = target / "synthetic_log.csv"
    # after an interruption while finishing, the same run's log may already be there
    write_log(log, paths["log"], overwrite=resumed)
    if driver["snapshots"]:
        paths["pvd"] = target / "fields.pvd"
    mb = rows.get("mass_balance_error")
    summary = {
        "status": res.status, "message": res.message, "model": engine.model,
        "xlotkit_version": __version__, "seed": int(scene.seed),
        "steps": int(driver["n_steps"]), "resumed": resumed,
        "simulated_time_s": float(rows["t"][-1]),
        "max_mass_balance_error": (None if mb is None or not np.isfinite(mb).any()
                                   else float(np.nanmax(mb))),
        "imposed_bar": {k: v / 1e5 for k, v in imposed.items()},
        "realised_bar": {k: v / 1e5 for k, v in realised.items()},
        "files": {k: str(p.relative_to(target)) for k, p in paths.items() if k != "dir"},
    }
    fbp = res.truth.get("fbp")
    if fbp is not None:
        summary["fbp_bar"] = float(fbp) / 1e5
    paths["summary"] = target / "summary.json"
    summary["files"]["summary"] = "summary.json"
    atomic_write_text(paths["summary"], json.dumps(summary, indent=2, allow_nan=False) + "\n")
    ck = target / CHECKPOINT
    if ck.exists():
        ck.unlink()
    text = (f"{engine.model} model: {res.status}, {res.message}; "
            f"{len(log.t)} log samples over {float(log.t[-1]):.0f} s"
            + (f", FBP {float(fbp) / 1e5:.1f} bar" if fbp is not None else ""))
    # every realised quantity the engine reports (e.g. the 2D engine's stress range over
    # the crack and its wall hoop stress), beyond the TRUTH_QUANTITIES kept above
    detail = {k: float(v) for k, v in dict(res.truth.get("realised", {})).items()
              if v is not None}
    truth = {**truth_model, "imposed": imposed, "realised": realised,
             "realised_detail": detail}
    return SimulationResult(status=res.status, message=res.message, model=engine.model,
                            record=log, clean_record=clean, truth=truth, paths=paths,
                            n_steps=int(driver["n_steps"]), resumed=resumed, wall_time=wall,
                            summary=text)

