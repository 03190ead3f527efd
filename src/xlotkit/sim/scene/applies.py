"""Which scene keys apply to the scene they are in: a key that the model would not read is
refused, never accepted and ignored.

Every key of :data:`~xlotkit.sim.scene.keys.SCENE_KEYS` is read by the lumped model, the
2D model or both, some only together with another key (``rock.heterogeneity`` with
``effects.heterogeneity``, ``mesh.band_length`` with ``mesh.fracture_band``,
``completion.roughness`` with ``effects.pipe_friction``, ``lumped.*`` by the lumped model
only, ...). :data:`CONDITIONS` says, per key that is not read everywhere, when it is read;
:func:`inapplicable` finds the first key *set* in a scene (given in its file, or different
from its default in a scene built in Python) that its scene does not read.

``tests/sim/test_scene_keys.py`` walks every key and checks that, changed, it either
changes the built model or is refused here.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from xlotkit.sim.scene.keys import SCENE_KEYS

if TYPE_CHECKING:
    from xlotkit.sim.scene.model import Scene

__all__ = ["CONDITIONS", "Condition", "applies", "inapplicable", "set_keys"]


@dataclass(frozen=True)
class Condition:
    """When a key is read.

    Attributes
    ----------
    test : callable ``(scene) -> bool``
        True when the scene's model reads the key.
    reason : str
        What the key needs (``"the 2D model"``, ``"effects.heterogeneity = true"``).
    """

    test: Callable[[Scene], bool]
    reason: str


def _two_d(sc: Scene) -> bool:
    return sc.resolved_model == "mdem"


def _lumped(sc: Scene) -> bool:
    return sc.resolved_model == "lumped"


def _generated(sc: Scene) -> bool:
    return _two_d(sc) and sc.mesh.file is None


def _band(sc: Scene) -> bool:
    return _generated(sc) and sc.mesh.fracture_band


def _storage_from_completion(sc: Scene) -> bool:
    return sc.effects.well_storage and sc.completion.well_compliance is None


def _scheme(*names: str) -> Callable[[Scene], bool]:
    def test(sc: Scene) -> bool:
        return _two_d(sc) and sc.coupling in names
    return test


_2D = "the 2D model (model = 'mdem')"
_GEN = "the generated 2D mesh (the 2D model, no mesh.file)"
_BAND = "a fracture band (mesh.fracture_band = true)"
_LUMPED = "the lumped model (model = 'lumped', or 'auto' without 2D physics)"
_WFD = "coupling = 'wfd' or 'wfdmod' (the 2D model)"

#: dotted key -> when it is read (keys absent here are read by every scene).
CONDITIONS: dict[str, Condition] = {
    "coupling": Condition(_two_d, _2D),
    "geometry.domain_size": Condition(_generated, _GEN),
    "geometry.segment_height": Condition(
        lambda sc: _two_d(sc) or sc.lumped.fracture_geometry == "kgd",
        "the 2D model, or lumped.fracture_geometry = 'kgd' (a penny-shaped fracture has "
        "no height)"),
    "completion.depth": Condition(
        lambda sc: sc.completion.tvd is None or _storage_from_completion(sc)
        or sc.effects.pipe_friction,
        "no completion.tvd (which sets the hydrostatic column), or a well whose storage "
        "comes from the completion, or effects.pipe_friction"),
    **{f"completion.{k}": Condition(
        lambda sc: _storage_from_completion(sc) or sc.effects.pipe_friction,
        "a well whose storage comes from the completion (effects.well_storage without "
        "completion.well_compliance), or effects.pipe_friction")
       for k in ("casing_id", "pipe_od", "pipe_id")},
    "completion.open_hole_length": Condition(
        lambda sc: _storage_from_completion(sc)
        or (_lumped(sc) and (sc.lumped.wall_leak_index is None
                             or not sc.effects.well_storage)),
        "a well whose storage comes from the completion, or a lumped model without "
        "lumped.wall_leak_index or without well storage (the open hole's alone)"),
    **{f"mesh.{k}": Condition(_generated, _GEN)
       for k in ("growth", "wall_element_size", "max_element_size", "fracture_band",
                 "jitter")},
    "mesh.file": Condition(_two_d, _2D),
    **{f"mesh.{k}": Condition(_band, _BAND)
       for k in ("band_width", "band_element_size", "band_length", "band_strip",
                 "band_centred_wall")},
    "mesh.seed": Condition(lambda sc: _generated(sc) and sc.mesh.jitter > 0.0,
                           "mesh.jitter > 0 (the generated 2D mesh)"),
    "rock.biot": Condition(lambda sc: _two_d(sc) and sc.effects.poroelastic,
                           "effects.poroelastic = true (the 2D model)"),
    "rock.porosity": Condition(
        lambda sc: _two_d(sc) or sc.lumped.leakoff_coefficient is None,
        "the 2D model, or a lumped model without lumped.leakoff_coefficient"),
    "rock.permeability": Condition(
        lambda sc: _two_d(sc) or sc.lumped.leakoff_coefficient is None
        or sc.lumped.wall_leak_index is None,
        "the 2D model, or a lumped model without both lumped.leakoff_coefficient and "
        "lumped.wall_leak_index"),
    "rock.cohesion": Condition(_two_d, _2D),
    "rock.friction_angle": Condition(_two_d, _2D),
    "rock.heterogeneity": Condition(lambda sc: _two_d(sc) and sc.effects.heterogeneity,
                                    "effects.heterogeneity = true (the 2D model)"),
    "rock.seed": Condition(lambda sc: _two_d(sc) and sc.effects.heterogeneity,
                           "effects.heterogeneity = true (the 2D model)"),
    "rock.strength_scaling_exponent": Condition(
        lambda sc: _two_d(sc) and sc.effects.strength_scaling,
        "effects.strength_scaling = true (the 2D model)"),
    "rock.strength_scaling_reference_area": Condition(
        lambda sc: _two_d(sc) and sc.effects.strength_scaling and sc.rock.toughness is None,
        "effects.strength_scaling = true without rock.toughness (which sets the reference "
        "area from T0)"),
    "rock.wall_criterion": Condition(lambda sc: _two_d(sc) and sc.effects.strength_scaling,
                                     "effects.strength_scaling = true (the 2D model)"),
    "rock.toughness": Condition(lambda sc: _two_d(sc) and sc.effects.strength_scaling,
                                "effects.strength_scaling = true (the 2D model)"),
    "rock.fracture_friction_angle": Condition(
        lambda sc: _two_d(sc) and (sc.effects.fracture_plane or sc.rock.crack_plane == "stress"),
        "effects.fracture_plane = true or rock.crack_plane = 'stress' (the 2D model)"),
    "rock.crack_plane": Condition(_two_d, _2D),
    "rock.closure_law": Condition(_two_d, _2D),
    "rock.joint_normal_stiffness": Condition(
        lambda sc: _two_d(sc) and sc.rock.closure_law == "barton_bandis",
        "rock.closure_law = 'barton_bandis' (the 2D model)"),
    "rock.joint_max_closure": Condition(
        lambda sc: _two_d(sc) and sc.rock.closure_law in ("barton_bandis", "exponential"),
        "rock.closure_law = 'barton_bandis' or 'exponential' (the 2D model)"),
    "rock.joint_reference_stress": Condition(
        lambda sc: _two_d(sc) and sc.rock.closure_law == "exponential",
        "rock.closure_law = 'exponential' (the 2D model)"),
    "rock.sealed_aperture": Condition(
        lambda sc: _two_d(sc) and sc.rock.closure_law != "smooth",
        "a rock.closure_law other than 'smooth' (the 2D model)"),
    "rock.dilation_angle": Condition(lambda sc: _two_d(sc) and sc.effects.shear_dilation,
                                     "effects.shear_dilation = true (the 2D model)"),
    "stresses.sigma_H_azimuth": Condition(_two_d, _2D),
    **{f"completion.{k}": Condition(
        lambda sc: _storage_from_completion(sc) and sc.completion.expansion,
        "completion.expansion = true, with effects.well_storage and no "
        "completion.well_compliance")
       for k in ("casing_od", "steel_modulus", "steel_poisson")},
    "completion.expansion": Condition(
        _storage_from_completion,
        "effects.well_storage = true without completion.well_compliance"),
    "completion.roughness": Condition(lambda sc: sc.effects.pipe_friction,
                                      "effects.pipe_friction = true"),
    "completion.well_compliance": Condition(lambda sc: sc.effects.well_storage,
                                            "effects.well_storage = true"),
    **{f"numerics.{k}": Condition(_two_d, _2D)
       for k in ("dt_min", "dt_max", "n1", "n2", "max_newton")},
    **{f"effects.{k}": Condition(_two_d, _2D)
       for k in ("poroelastic", "heterogeneity", "strength_scaling", "shear_dilation",
                 "fracture_plane", "interface")},
    "output.seed": Condition(lambda sc: sc.output.noise > 0.0, "output.noise > 0"),
    "output.snapshot_interval": Condition(_two_d, _2D),
    **{f"lumped.{k}": Condition(_lumped, _LUMPED) for k in SCENE_KEYS["lumped"]},
    **{f"well_coupling.{k}": Condition(_scheme("wfd", "wfdmod"), _WFD)
       for k in ("tolerance", "rate_tolerance", "max_iterations", "calibration")},
    "well_coupling.wfc_gain": Condition(_scheme("wfc"), "coupling = 'wfc'"),
    "well_coupling.wfc_damping": Condition(_scheme("wfc"), "coupling = 'wfc'"),
    "well_coupling.wfdmod_gain": Condition(_scheme("wfdmod"), "coupling = 'wfdmod'"),
    "well_coupling.wfdmod_damping": Condition(_scheme("wfdmod"), "coupling = 'wfdmod'"),
}


def applies(scene: Scene, key: str) -> bool:
    """Whether the scene's model reads the dotted ``key``."""
    cond = CONDITIONS.get(key)
    return cond is None or bool(cond.test(scene))


def _value(scene: Scene, key: str) -> Any:
    sec, _, name = key.rpartition(".")
    return getattr(getattr(scene, sec) if sec else scene, name)


def _default(scene: Scene, key: str) -> Any:
    sec, _, name = key.rpartition(".")
    cls = type(getattr(scene, sec)) if sec else type(scene)
    f = {x.name: x for x in dataclasses.fields(cls)}[name]
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def set_keys(scene: Scene) -> list[str]:
    """The dotted keys set in a scene, in :data:`SCENE_KEYS` order: given in its file
    (``scene.given``), or different from their default. (The master ``seed`` is read by
    every scene: it seeds whatever draws the scene has and is recorded in the outputs.)"""
    out = []
    for sec, keys in SCENE_KEYS.items():
        for k in keys:
            key = f"{sec}.{k}" if sec else k
            if key in scene.given:
                out.append(key)
            elif key != "seed" and _value(scene, key) != _default(scene, key):
                out.append(key)
    return out


def inapplicable(scene: Scene) -> tuple[str, str] | None:
    """``(key, what it needs)`` of the first key set in ``scene`` that its model does not
    read, or None."""
    for key in set_keys(scene):
        cond = CONDITIONS.get(key)
        if cond is not None and not cond.test(scene):
            return key, cond.reason
    return None
