"""No scene key is accepted and ignored: a walk over every key of ``SCENE_KEYS``.

For each key (every ``effects.*`` flag included) and each model (lumped, 2D), the key is
changed from its base value and either

* the scene is refused with an error naming the key (the key does not apply there:
  :mod:`xlotkit.sim.scene.applies`), or
* what the model does changes: for the lumped model a whole short run through the driver
  (log, clean record, truth, status, checkpoints); for the 2D model the built model (a
  fingerprint of every array and number it holds), its step control and its first steps,
  or, for keys of the driver and the output, a whole short run as for the lumped model.

A key that is read only with another one (``rock.dilation_angle`` with
``effects.shear_dilation``) is changed with that one set in both scenes, and must be live
(change the result) in the models :class:`Probe` names; changed on its own, it must still
be refused or change the result. The keys are taken from ``SCENE_KEYS``, so a key added
later fails :func:`test_every_key_has_a_probe` until ``PROBES`` says how to observe it.

A probe's change is compared with the same scene without it, so what is measured is the
key's effect, not a constant of the scene; the base scenes are checked to be
deterministic first (otherwise every key would look live).
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import pytest

from xlotkit import InputError
from xlotkit.sim.run import driver as driver_mod
from xlotkit.sim.run import make_engine, simulate
from xlotkit.sim.scene import SCENE_KEYS, Scene, scene_from_dict

#: A short two-cycle lumped XLOT (breakdown at ~38 MPa, flowback, reopening): 0.3 s a run.
LUMPED_BASE: dict[str, Any] = {
    "title": "walker, lumped", "model": "lumped",
    "schedule": {"phase": [
        {"kind": "pump", "rate": "500 l/min", "volume": "1.6 m3"},
        {"kind": "shut_in", "duration": "60 s"},
        {"kind": "flowback", "initial_rate": "300 l/min", "pressure_below": "27 MPa"},
        {"kind": "shut_in", "duration": "30 s"},
        {"kind": "pump", "rate": "500 l/min", "volume": "0.3 m3"},
        {"kind": "shut_in", "duration": "30 s"}]},
}

#: A small 2D scene (3 m square, 12 segments on the wall), pumped 2 s below breakdown,
#: shut in and flowed back: the built model carries every key, the run its stepping.
MDEM_BASE: dict[str, Any] = {
    "title": "walker, 2D", "model": "mdem",
    "geometry": {"domain_size": "3 m"},
    "mesh": {"growth": 1.3, "wall_element_size": "0.0785 m"},
    "rock": {"tensile_strength": "3 MPa", "permeability": 1e-18},
    "stresses": {"sigma_H": "40 MPa", "sigma_h": "30 MPa", "pore_pressure": "20 MPa"},
    "effects": {"strength_scaling": True},
    "completion": {"well_compliance": 2e-9},
    "numerics": {"dt_max": "1 s", "dp_max": "0.5 MPa", "dt_min": 1e-4},
    "schedule": {"phase": [
        {"kind": "pump", "rate": "300 l/min", "duration": "2 s"},
        {"kind": "shut_in", "duration": "2 s"},
        {"kind": "flowback", "initial_rate": "100 l/min", "pressure_below": "25 MPa"}]},
}
BASES = {"lumped": LUMPED_BASE, "mdem": MDEM_BASE}
#: 2D steps taken for a "model" observation.
STEPS_2D = 12
BOTH = ("lumped", "mdem")
TWO_D = ("mdem",)
LUMPED = ("lumped",)


@dataclass(frozen=True)
class Probe:
    """How to observe one key.

    Attributes
    ----------
    alt : Any
        The changed value, as written in a scene file.
    live : tuple of str
        Models in which the change must change the result (elsewhere it may be refused).
    with_ : dict
        Dotted keys set in both scenes (what makes the key read).
    also : dict
        Dotted keys set in the changed scene only (what must come with the change).
    without : tuple of str
        Dotted keys dropped from both (what the change makes unread).
    observe : {"model", "run", "engine"}
        2D: the built model and its first steps, or a whole run through the driver (keys
        of the driver and the output); "engine": only which engine the scene gets (both
        models).
    other : Any, optional
        The changed value in the models not in ``live`` (default ``alt``).
    per_model : dict
        model -> dotted keys set in both scenes of that model only.
    refused_as : tuple of str
        Other keys a refusal of the change may name (``model = "lumped"`` in a scene with
        a ``[mesh]`` is refused naming ``mesh``).
    """

    alt: Any
    live: tuple[str, ...] = BOTH
    with_: dict = field(default_factory=dict)
    also: dict = field(default_factory=dict)
    without: tuple[str, ...] = ()
    observe: str = "model"
    other: Any = None
    per_model: dict = field(default_factory=dict)
    refused_as: tuple[str, ...] = ()


_FRACTURE_BAND = {"mesh.fracture_band": True}
_DILATION = {"effects.shear_dilation": True, "rock.dilation_angle": "5 deg"}
_NOISE = {"output.noise": "0.05 bar"}
_EXPONENTIAL = {"rock.joint_reference_stress": "5 MPa", "rock.joint_max_closure": "0.1 mm"}
_EXPANSION = {"completion.expansion": True, "completion.casing_od": "14 in"}

#: dotted key -> how to observe it.
PROBES: dict[str, Probe] = {
    "title": Probe("another title", observe="run"),
    "model": Probe("mdem", live=LUMPED, observe="engine", other="lumped",
                   refused_as=("mesh",)),
    "coupling": Probe("wfd", live=TWO_D),
    "seed": Probe(5, with_=_NOISE, observe="run"),      # without draws: recorded only
    "geometry.domain_size": Probe("4 m", live=TWO_D),
    "geometry.hole_radius": Probe("0.12 m"),
    "geometry.segment_height": Probe("6 m",
                                     per_model={"lumped": {"lumped.fracture_geometry": "kgd"}}),
    "mesh.growth": Probe(1.45, live=TWO_D),
    "mesh.wall_element_size": Probe("0.06 m", live=TWO_D),
    "mesh.max_element_size": Probe("0.2 m", live=TWO_D),
    "mesh.fracture_band": Probe(True, live=TWO_D),
    "mesh.band_width": Probe("0.4 m", live=TWO_D, with_=_FRACTURE_BAND),
    "mesh.band_element_size": Probe("0.05 m", live=TWO_D, with_=_FRACTURE_BAND),
    "mesh.band_length": Probe("1.4 m", live=TWO_D, with_=_FRACTURE_BAND),
    "mesh.band_strip": Probe(True, live=TWO_D, with_=_FRACTURE_BAND),
    "mesh.band_centred_wall": Probe(True, live=TWO_D, with_=_FRACTURE_BAND),
    "mesh.jitter": Probe(0.1, live=TWO_D),
    "mesh.seed": Probe(3, live=TWO_D, with_={"mesh.jitter": 0.1}),
    "mesh.file": Probe("walker_mesh.vtu", live=TWO_D,
                       without=("geometry.domain_size", "mesh.growth",
                                "mesh.wall_element_size")),
    "rock.youngs_modulus": Probe("20 GPa"),
    "rock.poisson_ratio": Probe(0.3),
    "rock.biot": Probe(0.7, live=TWO_D, with_={"effects.poroelastic": True}),
    "rock.porosity": Probe(0.2),
    "rock.permeability": Probe(1e-17),
    "rock.tensile_strength": Probe("4 MPa"),
    "rock.cohesion": Probe("12 MPa", live=TWO_D),
    "rock.friction_angle": Probe("35 deg", live=TWO_D),
    "rock.heterogeneity": Probe(0.4, live=TWO_D, with_={"effects.heterogeneity": True}),
    "rock.strength_scaling_exponent": Probe(0.3, live=TWO_D),
    "rock.strength_scaling_reference_area": Probe(1e-3, live=TWO_D),
    "rock.toughness": Probe("1 MPa*m**0.5", live=TWO_D),
    "rock.fracture_friction_angle": Probe(
        "10 deg", live=TWO_D, with_={**_FRACTURE_BAND, "effects.fracture_plane": True}),
    "rock.dilation_angle": Probe("10 deg", live=TWO_D, with_=_DILATION),
    "rock.wall_criterion": Probe("cluster", live=TWO_D),
    "rock.crack_plane": Probe("edges", live=TWO_D),
    "rock.closure_law": Probe("exponential", live=TWO_D, also=_EXPONENTIAL),
    "rock.joint_normal_stiffness": Probe(
        2e11, live=TWO_D, with_={"rock.closure_law": "barton_bandis",
                                 "rock.joint_normal_stiffness": 1e11,
                                 "rock.joint_max_closure": "0.1 mm"}),
    "rock.joint_max_closure": Probe("0.2 mm", live=TWO_D,
                                    with_={"rock.closure_law": "exponential", **_EXPONENTIAL}),
    "rock.joint_reference_stress": Probe("8 MPa", live=TWO_D,
                                         with_={"rock.closure_law": "exponential",
                                                **_EXPONENTIAL}),
    "rock.sealed_aperture": Probe("0.002 mm", live=TWO_D,
                                  with_={"rock.closure_law": "exponential", **_EXPONENTIAL}),
    "rock.seed": Probe(3, live=TWO_D, with_={"effects.heterogeneity": True}),
    "stresses.sigma_H": Probe("42 MPa"),
    "stresses.sigma_h": Probe("31 MPa"),
    "stresses.sigma_H_azimuth": Probe("30 deg", live=TWO_D),
    "stresses.pore_pressure": Probe("19 MPa"),
    "fluid.density": Probe("1.3 sg"),
    "fluid.compressibility": Probe(5e-10),
    "fluid.viscosity": Probe("5 cP"),
    "completion.depth": Probe("2200 m"),
    "completion.tvd": Probe("1800 m"),
    "completion.casing_id": Probe("10 in", live=LUMPED),
    "completion.casing_od": Probe("15 in", live=LUMPED, with_=_EXPANSION),
    "completion.pipe_od": Probe("4.5 in", live=LUMPED),
    "completion.pipe_id": Probe("3.8 in", live=LUMPED),
    "completion.open_hole_length": Probe("20 m", live=LUMPED),
    "completion.expansion": Probe(True, live=LUMPED, also={"completion.casing_od": "14 in"}),
    "completion.steel_modulus": Probe("150 GPa", live=LUMPED, with_=_EXPANSION),
    "completion.steel_poisson": Probe(0.25, live=LUMPED, with_=_EXPANSION),
    "completion.roughness": Probe("0.1 mm", with_={"effects.pipe_friction": True}),
    "completion.well_compliance": Probe(3e-9),
    "completion.initial_pressure": Probe("25 MPa"),
    "numerics.dt_min": Probe("1e-3 s", live=TWO_D),
    "numerics.dt_max": Probe("0.3 s", live=TWO_D),
    "numerics.n1": Probe(1, live=TWO_D),
    "numerics.n2": Probe(5, live=TWO_D),
    "numerics.max_newton": Probe(30, live=TWO_D),
    "numerics.checkpoint_steps": Probe(7, observe="run"),
    "numerics.checkpoint_seconds": Probe("3 s", observe="run"),
    "numerics.max_phase_duration": Probe("1 s"),
    "numerics.dp_max": Probe("0.1 MPa"),
    "effects.well_storage": Probe(False, without=("completion.well_compliance",)),
    "effects.pipe_friction": Probe(True),
    "effects.poroelastic": Probe(True, live=TWO_D),
    "effects.heterogeneity": Probe(True, live=TWO_D),
    "effects.strength_scaling": Probe(False, live=TWO_D),
    "effects.shear_dilation": Probe(True, live=TWO_D, also={"rock.dilation_angle": "5 deg"}),
    "effects.fracture_plane": Probe(True, live=TWO_D, with_=_FRACTURE_BAND),
    "effects.interface": Probe([{"start": ["0.8 m", "-1 m"], "end": ["0.8 m", "1 m"]}],
                               live=TWO_D),
    "output.log_interval": Probe("0.5 s", observe="run"),
    "output.noise": Probe("0.1 bar", observe="run"),
    "output.resolution": Probe("0.05 bar", observe="run"),
    "output.seed": Probe(9, with_=_NOISE, observe="run"),
    "output.snapshot_interval": Probe("1 s", live=TWO_D, observe="run"),
    "output.start_time": Probe(datetime(2026, 3, 1, 9, 0, 0), observe="run"),
    "output.gauge": Probe("surface", observe="run"),
    "lumped.fracture_geometry": Probe("kgd", live=LUMPED),
    "lumped.toughness": Probe("1 MPa*m**0.5", live=LUMPED),
    "lumped.initial_flaw": Probe("0.3 m", live=LUMPED),
    "lumped.reopening": Probe("sigma_h", live=LUMPED),
    "lumped.nwb_coefficient": Probe(1e10, live=LUMPED),
    "lumped.leakoff_coefficient": Probe(1e-4, live=LUMPED),
    "lumped.wall_leak_index": Probe(1e-10, live=LUMPED),
    "well_coupling.tolerance": Probe(1e-5, live=TWO_D, with_={"coupling": "wfd"}),
    "well_coupling.rate_tolerance": Probe(1e-5, live=TWO_D, with_={"coupling": "wfd"}),
    "well_coupling.max_iterations": Probe(2, live=TWO_D, with_={"coupling": "wfd"}),
    "well_coupling.calibration": Probe(0.5, live=TWO_D, with_={"coupling": "wfd"}),
    "well_coupling.wfc_gain": Probe(0.6, live=TWO_D, with_={"coupling": "wfc"}),
    "well_coupling.wfc_damping": Probe(0.3, live=TWO_D, with_={"coupling": "wfc"}),
    "well_coupling.wfdmod_gain": Probe(0.9, live=TWO_D, with_={"coupling": "wfdmod"}),
    "well_coupling.wfdmod_damping": Probe(0.3, live=TWO_D, with_={"coupling": "wfdmod"}),
}


def _all_keys() -> list[str]:
    return [f"{s}.{k}" if s else k for s, keys in SCENE_KEYS.items() for k in keys]


# ----------------------------------------------------------------------------- scenes
def _edit(base: dict, set_: dict, drop: tuple[str, ...] = ()) -> dict:
    d = copy.deepcopy(base)
    for key in drop:
        sec, _, name = key.rpartition(".")
        (d.get(sec, {}) if sec else d).pop(name, None)
    for key, v in set_.items():
        sec, _, name = key.rpartition(".")
        if sec:
            d.setdefault(sec, {})[name] = v
        else:
            d[name] = v
    return d


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A folder for the runs, with the mesh file of the ``mesh.file`` probe (a graded
    mesh other than the base scene's)."""
    from xlotkit.sim.mesh import borehole_mesh, write_mesh

    d = tmp_path_factory.mktemp("walk")
    write_mesh(borehole_mesh(size=3.0, radius=0.15, growth=1.5, h_wall=0.07), d / "m.vtu")
    return d


def _scene(d: dict, workdir: Path) -> Scene:
    d = copy.deepcopy(d)
    if d.get("mesh", {}).get("file") == "walker_mesh.vtu":
        d["mesh"]["file"] = str(workdir / "m.vtu")
    return scene_from_dict(d, file=str(workdir / "scene.toml"))


# ----------------------------------------------------------------------------- observing
def _fingerprint(obj: Any, h: Any, seen: set[int], depth: int = 0) -> None:
    """Feed every number, string and array reachable from ``obj`` into ``h`` (attributes
    sorted by name; callables and scenes left out: a scene holds every key, the model
    only what it took from it)."""
    if depth > 12:
        return
    if obj is None or isinstance(obj, (bool, int, float, complex, str, bytes, np.generic)):
        h.update(repr(obj).encode())
        return
    if isinstance(obj, np.ndarray):
        h.update(f"{obj.dtype}{obj.shape}".encode())
        if obj.dtype != object:
            h.update(np.ascontiguousarray(obj).tobytes())
            return
        obj = obj.tolist()
    if id(obj) in seen or isinstance(obj, Scene) or isinstance(obj, type):
        return
    seen.add(id(obj))
    if isinstance(obj, dict):
        for k in sorted(obj, key=repr):
            h.update(repr(k).encode())
            _fingerprint(obj[k], h, seen, depth + 1)
    elif isinstance(obj, (list, tuple)):
        for x in obj:
            _fingerprint(x, h, seen, depth + 1)
    elif isinstance(obj, (set, frozenset)):
        for x in sorted(obj, key=repr):
            _fingerprint(x, h, seen, depth + 1)
    elif callable(obj) and not dataclasses.is_dataclass(obj):
        return
    elif hasattr(obj, "__dict__") or hasattr(obj, "__slots__"):
        names = set(getattr(obj, "__dict__", {}))
        for cls in type(obj).__mro__:
            names.update(getattr(cls, "__slots__", ()))
        for k in sorted(names):
            v = getattr(obj, k, None)
            if callable(v) and not dataclasses.is_dataclass(v) and not isinstance(
                    v, np.ndarray):
                continue
            h.update(k.encode())
            _fingerprint(v, h, seen, depth + 1)


def _digest(obj: Any) -> str:
    h = hashlib.sha256()
    _fingerprint(obj, h, set())
    return h.hexdigest()[:16]


class _Clock:
    """A wall clock that advances 1 s per reading: checkpoints by wall time become
    deterministic (``numerics.checkpoint_seconds``)."""

    def __init__(self) -> None:
        self.t = 0.0

    def perf_counter(self) -> float:
        self.t += 1.0
        return self.t


#: Truth entries that are wall-clock measurements, not simulated quantities.
_WALL_CLOCK = {"linear_solve_time", "wall_time"}


def _simulated(truth: Any) -> Any:
    if isinstance(truth, dict):
        return {k: _simulated(v) for k, v in truth.items() if k not in _WALL_CLOCK}
    return truth


def _run_parts(scene: Scene, out: Path) -> dict[str, str]:
    """What a whole run through the driver shows: the log as written, the engine's clean
    record, truth, status, checkpoints and snapshots."""
    saves = []
    real = driver_mod._save_checkpoint

    def counting(path, engine, drv):
        saves.append(engine.time)
        real(path, engine, drv)

    with mock.patch.object(driver_mod, "_save_checkpoint", counting), \
            mock.patch.object(driver_mod, "_time", _Clock()):
        r = simulate(scene, out)
    rec, clean = r.record, r.clean_record
    return {
        "engine": r.model,
        "status": f"{r.status}: {r.message}",
        "log": _digest([rec.t, rec.pressure, rec.rate, rec.volume, rec.return_rate,
                        rec.return_volume, rec.channels, str(rec.reference),
                        str(rec.start_time), rec.meta.get("scene")]),
        "clean": _digest([clean.t, clean.pressure, clean.channels]),
        "truth": json.dumps(_simulated(r.truth), sort_keys=True, default=str),
        "checkpoints": repr(saves),
        "snapshots": repr(sorted(p.name for p in out.glob("snapshots/*.vtu"))),
        "summary": (out / "summary.json").read_text(),
    }


def _model_parts(scene: Scene) -> dict[str, str]:
    """What the 2D engine is made of and does first: its built model, step control,
    coupling options and the rows of its first steps."""
    e = make_engine(scene)
    e.start()
    error = ""
    try:
        for _ in range(STEPS_2D):
            if e.is_done():
                break
            e.step()
    except InputError as exc:                # a run the change makes fail: a change too
        error = exc.message
    return {
        "error": error,
        "engine": type(e).__name__,
        "model": _digest([e.cm, e.pw0]),
        "column": _digest(e.column),
        "stepping": _digest(e.stepping),
        "options": _digest(getattr(e, "options", None)),
        "rows": _digest(e.rows()),
    }


_CACHE: dict[tuple[str, str, str], dict[str, str]] = {}


def _observe(model: str, d: dict, how: str, workdir: Path) -> dict[str, str]:
    key = (model, how, json.dumps(d, sort_keys=True, default=str))
    if key not in _CACHE:
        scene = _scene(d, workdir)
        if how == "engine":
            _CACHE[key] = {"engine": type(make_engine(scene)).__name__}
        elif model == "mdem" and how == "model" and scene.resolved_model == "mdem":
            _CACHE[key] = _model_parts(scene)
        else:
            out = workdir / f"run{len(_CACHE):04d}"
            try:
                _CACHE[key] = _run_parts(scene, out)
            except InputError as exc:       # a run the change makes fail: a change too
                _CACHE[key] = {"error": str(exc).replace(str(workdir), "")}
    return _CACHE[key]


def _differs(a: dict[str, str], b: dict[str, str]) -> list[str]:
    return [k for k in a if a[k] != b.get(k)]


# ----------------------------------------------------------------------------- tests
def test_every_key_has_a_probe():
    missing = [k for k in _all_keys() if k not in PROBES]
    assert not missing, (
        f"scene keys {missing} have no probe: add to PROBES in {Path(__file__).name} how to "
        f"observe each (the changed value, the models it must change, the keys it needs)")
    stale = [k for k in PROBES if k not in _all_keys()]
    assert not stale, f"PROBES names keys that are not scene keys: {stale}"


def test_the_conditions_name_scene_keys():
    from xlotkit.sim.scene.applies import CONDITIONS

    assert set(CONDITIONS) <= set(_all_keys())


@pytest.mark.parametrize("model", ["lumped", "mdem"])
@pytest.mark.parametrize("how", ["model", "run"])
def test_the_base_scenes_are_deterministic(model, how, workdir):
    if model == "lumped" and how == "model":
        pytest.skip("the lumped model is observed by its run")
    d = BASES[model]
    a = _observe(model, d, how, workdir)
    _CACHE.clear()
    b = _observe(model, d, how, workdir)
    assert a == b


@pytest.mark.parametrize("key", _all_keys())
def test_no_key_is_accepted_and_ignored(key, workdir):
    probe = PROBES.get(key)
    if probe is None:
        pytest.fail(f"{key} has no probe: add to PROBES how to observe it")
    for model in ("lumped", "mdem"):
        base = BASES[model]
        how = probe.observe if model == "mdem" or probe.observe == "engine" else "run"
        if model in probe.live:
            b = _edit(base, {**probe.with_, **probe.per_model.get(model, {})}, probe.without)
            c = _edit(b, {key: probe.alt, **probe.also})
            before, after = _observe(model, b, how, workdir), _observe(model, c, how, workdir)
            assert _differs(before, after), (
                f"{key} = {probe.alt!r} is accepted and ignored by the {model} model "
                f"(nothing of {sorted(before)} changed)")
        alt = probe.alt if model in probe.live or probe.other is None else probe.other
        if model in probe.live and not (probe.with_ or probe.without or probe.per_model):
            continue                        # the bare change is the one just observed
        # changed on its own (without what makes it read): refused, or it changes the result
        c = _edit(base, {key: alt, **probe.also}, probe.without)
        try:
            _scene(c, workdir)
        except InputError as exc:
            named = exc.key or ""
            related = {key, *probe.with_, *probe.also, *probe.without, *probe.refused_as}
            assert (named in related or key.startswith(named + ".")
                    or named.startswith(key + "[")), (
                f"{key} changed in the {model} scene is refused for another key: {exc}")
            continue
        b = _edit(base, {}, probe.without)
        assert _differs(_observe(model, b, how, workdir), _observe(model, c, how, workdir)), (
            f"{key} = {alt!r} is accepted and ignored by the {model} model when "
            f"{sorted(probe.with_) or 'nothing else'} is not set: refuse it there "
            f"(xlotkit.sim.scene.applies.CONDITIONS)")
