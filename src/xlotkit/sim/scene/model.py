"""The scene: sections, schedule, model choice, seeds and the lumped model's scene of it."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any, Literal

from xlotkit import formulas
from xlotkit.errors import InputError
from xlotkit.sim.scene.applies import applies, inapplicable
from xlotkit.sim.scene.keys import PARTITIONED_COUPLINGS, Coupling, Model, _validate
from xlotkit.sim.scene.lumped import LumpedScene
from xlotkit.sim.scene.sections import (
    _SECTION_TYPES,
    MAX_WALL_SEGMENTS,
    CompletionOptions,
    Effects,
    Fluid,
    Geometry,
    LumpedOptions,
    MeshOptions,
    Numerics,
    OutputOptions,
    Rock,
    Stresses,
    WellCouplingOptions,
)
from xlotkit.sim.schedule import Schedule
from xlotkit.sim.well import Completion, well_compliance

__all__ = ["BAND_LENGTH", "Scene", "carter_coefficient"]

#: Default half-length of the fracture band [m] (or the domain's half-side if less).
BAND_LENGTH = 10.0

#: Combined Carter coefficient of the rock (:func:`xlotkit.formulas.carter_coefficient`).
carter_coefficient = formulas.carter_coefficient


@dataclass(frozen=True, kw_only=True)
class Scene:
    """A validated simulation scene (SI inside; see the module docstring for the file).

    Attributes
    ----------
    schedule : Schedule
        The test program.
    geometry, mesh, rock, stresses, fluid, completion, numerics, effects, output, lumped,
        well_coupling
        The sections (defaults where a section is absent).
    model : {"auto", "lumped", "mdem"}
    coupling : {"monolithic", "wfd", "wfc", "wfdmod"}
    seed : int
        Master seed.
    title : str
    given : frozenset of str
        Sections present in the scene file (a ``[mesh]`` section asks for the 2D model)
        and the dotted keys given in it (``"rock.cohesion"``, ``"seed"``): a key given
        that the scene's model does not read is refused
        (:mod:`xlotkit.sim.scene.applies`).
    source_text : str or None
        The scene file's text, kept for the outputs.
    source_file : str or None
        Where it was read from.
    """

    schedule: Schedule
    geometry: Geometry = field(default_factory=Geometry)
    mesh: MeshOptions = field(default_factory=MeshOptions)
    rock: Rock = field(default_factory=Rock)
    stresses: Stresses = field(default_factory=Stresses)
    fluid: Fluid = field(default_factory=Fluid)
    completion: CompletionOptions = field(default_factory=CompletionOptions)
    numerics: Numerics = field(default_factory=Numerics)
    effects: Effects = field(default_factory=Effects)
    output: OutputOptions = field(default_factory=OutputOptions)
    lumped: LumpedOptions = field(default_factory=LumpedOptions)
    well_coupling: WellCouplingOptions = field(default_factory=WellCouplingOptions)
    model: Model = "auto"
    coupling: Coupling = "monolithic"
    seed: int = 0
    title: str = ""
    given: frozenset[str] = frozenset()
    source_text: str | None = None
    source_file: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.schedule, Schedule):
            raise InputError(f"not a Schedule: {self.schedule!r}", key="schedule",
                             expected="a xlotkit.sim.schedule.Schedule")
        for name, cls in _SECTION_TYPES.items():
            if not isinstance(getattr(self, name), cls):
                raise InputError(f"not a {cls.__name__}: {getattr(self, name)!r}", key=name,
                                 expected=f"a xlotkit.sim.scene.{cls.__name__}")
        _validate(self, "")
        object.__setattr__(self, "given", frozenset(self.given))
        self.completion.completion(self.geometry, self.fluid)
        if self.effects.fracture_plane and not self.mesh.fracture_band:
            raise InputError("effects.fracture_plane needs a fracture band",
                             key="effects.fracture_plane",
                             expected="mesh.fracture_band = true, or fracture_plane = false")
        if self.effects.shear_dilation and self.rock.dilation_angle is None:
            raise InputError("effects.shear_dilation needs a dilation angle",
                             key="rock.dilation_angle",
                             expected="an angle in (0, 45] deg, e.g. dilation_angle = 5.0")
        if self.rock.dilation_angle is not None and not self.effects.shear_dilation:
            raise InputError(f"rock.dilation_angle = {self.rock.dilation_angle!r} deg is "
                             "only used with shear dilation, which is off",
                             key="rock.dilation_angle",
                             expected="effects.shear_dilation = true, or no dilation_angle")
        if self.resolved_model == "mdem" and self.mesh.file is None:
            self._check_mesh()
        self._check_well_compliance()
        if self.model == "lumped" and self.two_d_reasons:
            key = self.two_d_reasons[0]
            raise InputError(f"model = 'lumped' cannot simulate {key}", key=key,
                             expected="model = 'mdem' or 'auto', or drop " + key)
        if self.coupling in PARTITIONED_COUPLINGS:
            self._check_partitioned()
        bad = inapplicable(self)
        if bad is not None:
            key, needs = bad
            sec, _, name = key.rpartition(".")
            value = getattr(getattr(self, sec) if sec else self, name)
            model = ("the 2D model" if self.resolved_model == "mdem"
                     else "the lumped model")
            raise InputError(f"{key} = {_shown(value)} is not read by this scene ({model}): "
                             f"it needs {needs}", key=key,
                             expected=f"no {key}, or {needs}")
        if self.resolved_model == "lumped":
            # fail now, not mid-run, on values only the lumped model rejects
            try:
                self.to_lumped()
            except InputError as exc:
                raise InputError(exc.message, key=_LUMPED_KEYS.get(exc.key or "", exc.key),
                                 expected=exc.expected) from None

    def _check_mesh(self) -> None:
        """The generated mesh's sizes against the geometry (what the generator would
        refuse or silently clip, named by their scene keys before a run)."""
        g, mo = self.geometry, self.mesh
        r, size = g.hole_radius, g.domain_size
        h_wall = mo.wall_element_size if mo.wall_element_size is not None else (
            2 * math.pi * r / 64)
        h_max = mo.max_element_size if mo.max_element_size is not None else size / 10.0
        if mo.wall_element_size is not None:
            if h_wall > r:
                raise InputError(
                    f"value {h_wall!r} m is above the hole radius {r:g} m (fewer than "
                    f"{2 * math.pi:.2f} segments on the wall)", key="mesh.wall_element_size",
                    expected=f"a number in [{2 * math.pi * r / MAX_WALL_SEGMENTS:.3g}, {r:g}] "
                             f"m (2 pi r / {MAX_WALL_SEGMENTS} to the hole radius)")
            if h_wall < 2 * math.pi * r / MAX_WALL_SEGMENTS:
                raise InputError(
                    f"value {h_wall!r} m puts more than {MAX_WALL_SEGMENTS} segments on the "
                    f"wall", key="mesh.wall_element_size",
                    expected=f"a number in [{2 * math.pi * r / MAX_WALL_SEGMENTS:.3g}, {r:g}] m")
        if mo.max_element_size is not None and not h_wall <= h_max <= 0.5 * size:
            raise InputError(
                f"value {h_max!r} m is outside the wall's edge {h_wall:g} m to half the domain "
                f"{0.5 * size:g} m", key="mesh.max_element_size",
                expected=f"a number in [{h_wall:g}, {0.5 * size:g}] m")
        if not mo.fracture_band:
            return
        h_band = mo.band_element_size if mo.band_element_size is not None else h_wall
        half = 0.5 * size
        if not r < self.band_length <= half * (1.0 + 1e-12):
            raise InputError(
                f"value {self.band_length!r} m does not fit between the hole ({r:g} m) and the "
                f"domain's edge ({half:g} m from the hole centre: domain_size {size:g} m)",
                key="mesh.band_length",
                expected=f"a number in ({r:g}, {half:g}] m (or a larger geometry.domain_size)")
        if not mo.band_width <= half * (1.0 + 1e-12):
            raise InputError(f"value {mo.band_width!r} m is wider than half the domain",
                             key="mesh.band_width",
                             expected=f"a number in [{h_band:g}, {half:g}] m")
        if h_band > h_max:
            raise InputError(
                f"value {h_band!r} m is above the largest element {h_max:g} m",
                key=("mesh.band_element_size" if mo.band_element_size is not None
                     else "mesh.wall_element_size"),
                expected=f"a number <= mesh.max_element_size ({h_max:g} m)")
        if mo.band_width < h_band * (1.0 - 1e-12):
            raise InputError(
                f"value {mo.band_width!r} m is narrower than the band's elements "
                f"({h_band:g} m)", key="mesh.band_width",
                expected=f"a number in [{h_band:g}, {half:g}] m (or a smaller "
                         f"mesh.band_element_size)")

    @property
    def band_length(self) -> float:
        """Half-length of the fracture band [m]: ``mesh.band_length``, by default 10 m or
        the domain's half-side if less."""
        if self.mesh.band_length is not None:
            return float(self.mesh.band_length)
        return min(BAND_LENGTH, 0.5 * self.geometry.domain_size)

    def _check_well_compliance(self) -> None:
        """A given well compliance holds the open hole's own fluid storage, so it cannot
        be below it (the 2D model would take the difference as 0, the lumped model a well
        stiffer than its fluid)."""
        cw = self.completion.well_compliance
        if cw is None:
            return
        if not self.effects.well_storage:
            raise InputError(
                f"completion.well_compliance = {cw:g} m^3/Pa is the whole well's storage, "
                "which effects.well_storage = false leaves out",
                key="completion.well_compliance",
                expected="effects.well_storage = true, or no well_compliance")
        g = self.geometry
        if self.resolved_model == "mdem":
            h, what = g.segment_height, "geometry.segment_height"
        else:
            h, what = self.completion.open_hole_length, "completion.open_hole_length"
        own = self.fluid.compressibility * math.pi * g.hole_radius**2 * h
        if cw < own * (1.0 - 1e-9):
            raise InputError(
                f"value {cw:g} m^3/Pa is below the open hole's own fluid storage "
                f"c_f pi r^2 h = {own:.4g} m^3/Pa (h = {what} = {h:g} m)",
                key="completion.well_compliance",
                expected=f"a number in [{own:.4g}, 1e-05] m^3/Pa")

    def _check_partitioned(self) -> None:
        """A partitioned coupling needs a well beyond the open hole to couple it to."""
        c = self.coupling
        if not self.effects.well_storage:
            raise InputError(f"coupling = {c!r} couples the open hole to the rest of the "
                             "well, but effects.well_storage is false",
                             key="effects.well_storage",
                             expected="true, or coupling = 'monolithic'")
        g = self.geometry
        own = math.pi * g.hole_radius**2 * g.segment_height * self.fluid.compressibility
        given = self.completion.well_compliance
        total = (float(given) if given is not None
                 else well_compliance(self.completion_model()))
        if not total > own * (1.0 + 1e-9):
            key = ("completion.well_compliance" if given is not None
                   else "fluid.compressibility")
            raise InputError(
                f"coupling = {c!r}: the well's compliance {total:.4g} m^3/Pa is not above "
                f"the open hole's own {own:.4g} m^3/Pa (no well storage to couple)",
                key=key, expected="a whole-well compliance above c_f pi r^2 h, or "
                                  "coupling = 'monolithic'")

    # ------------------------------------------------------------------ model choice
    @property
    def two_d_reasons(self) -> tuple[str, ...]:
        """The keys that ask for the 2D model (empty: the lumped model can answer)."""
        out = []
        if "mesh" in self.given:
            out.append("mesh")
        ef = self.effects
        for name in ("poroelastic", "heterogeneity", "strength_scaling", "shear_dilation",
                     "fracture_plane"):
            if getattr(ef, name):
                out.append(f"effects.{name}")
        if ef.interface:
            out.append("effects.interface")
        # the crack inside failed clusters and its closure law exist only in 2D
        if self.rock.closure_law != "smooth":
            out.append("rock.closure_law")
        if self.rock.crack_plane != "stress":
            out.append("rock.crack_plane")
        if self.coupling != "monolithic":
            out.append("coupling")
        return tuple(out)

    @property
    def resolved_model(self) -> Literal["lumped", "mdem"]:
        """The model that will run: ``model``, or for ``"auto"`` lumped unless 2D physics
        is asked for (:attr:`two_d_reasons`)."""
        if self.model != "auto":
            return self.model
        return "mdem" if self.two_d_reasons else "lumped"

    def as_monolithic(self) -> Scene:
        """The same scene with the well coupled monolithically (the 2D segment a
        partitioned engine steps): ``coupling = "monolithic"``, no ``[well_coupling]``."""
        return dataclasses.replace(
            self, coupling="monolithic", well_coupling=WellCouplingOptions(),
            given=frozenset(k for k in self.given
                            if k != "coupling" and not k.startswith("well_coupling")))

    # ------------------------------------------------------------------ seeds
    @property
    def mesh_seed(self) -> int:
        """Seed of the mesh jitter."""
        return self.seed if self.mesh.seed is None else self.mesh.seed

    @property
    def rock_seed(self) -> int:
        """Seed of the strength heterogeneity."""
        return self.seed if self.rock.seed is None else self.rock.seed

    @property
    def noise_seed(self) -> int:
        """Seed of the gauge noise."""
        return self.seed if self.output.seed is None else self.output.seed

    def with_seed(self, seed: int) -> Scene:
        """A copy whose every random draw uses ``seed`` (section seeds are overridden)."""
        return dataclasses.replace(
            self, seed=seed, mesh=dataclasses.replace(self.mesh, seed=None),
            rock=dataclasses.replace(self.rock, seed=None),
            output=dataclasses.replace(self.output, seed=None))

    # ------------------------------------------------------------------ lumped
    def completion_model(self) -> Completion:
        """The :class:`~xlotkit.sim.well.Completion` of the scene."""
        return self.completion.completion(self.geometry, self.fluid)

    def to_lumped(self) -> LumpedScene:
        """The :class:`~xlotkit.sim.lumped.LumpedScene` of this scene (with gauge noise).

        Leak-off coefficient and wall leak index come from ``[lumped]`` or, when absent,
        from the rock (module docstring); without ``effects.well_storage`` the well
        compliance is the open-hole segment's alone.
        """
        comp = self.completion_model()
        lo, rk, st, fl = self.lumped, self.rock, self.stresses, self.fluid
        cw = self.completion.well_compliance
        if cw is None and not self.effects.well_storage:
            cw = fl.compressibility * math.pi * self.geometry.hole_radius**2 * (
                comp.open_hole_length)
        c_l = lo.leakoff_coefficient
        if c_l is None:
            c_l = carter_coefficient(rk.permeability, rk.porosity, fl.compressibility,
                                     fl.viscosity, st.sigma_h - st.pore_pressure)
        j = lo.wall_leak_index
        if j is None:
            j = formulas.wall_leak_index(rk.permeability, fl.viscosity, comp.open_hole_length,
                                self.geometry.hole_radius) if comp.open_hole_length > 0 else 0.0
        return LumpedScene(
            schedule=self.schedule, sigma_h=st.sigma_h, sigma_H=st.sigma_H,
            pore_pressure=st.pore_pressure, tensile_strength=rk.tensile_strength,
            youngs_modulus=rk.youngs_modulus, poisson_ratio=rk.poisson_ratio,
            toughness=lo.toughness, geometry=lo.fracture_geometry,
            fracture_height=self.geometry.segment_height,
            initial_flaw=(self.geometry.hole_radius if lo.initial_flaw is None
                          else lo.initial_flaw),
            reopening=lo.reopening, nwb_coefficient=lo.nwb_coefficient,
            leakoff_coefficient=c_l, wall_leak_index=j, completion=comp,
            well_compliance=cw, density=fl.density, viscosity=fl.viscosity,
            pipe_friction=self.effects.pipe_friction,
            initial_pressure=self.completion.initial_pressure, dt=self.output.log_interval,
            noise=self.output.noise, resolution=self.output.resolution,
            seed=self.noise_seed, start_time=self.output.start_time,
            max_phase_duration=self.numerics.max_phase_duration, dp_max=self.numerics.dp_max)

    @classmethod
    def from_lumped(cls, ls: LumpedScene, *, source_text: str | None = None,
                    source_file: str | None = None) -> Scene:
        """The scene of a :class:`~xlotkit.sim.lumped.LumpedScene` (``model = "lumped"``).

        ``Scene.from_lumped(ls).to_lumped()`` simulates exactly like ``ls``.
        """
        comp = ls.completion_used
        tvd = ls.tvd if ls.tvd is not None else comp.depth_tvd
        return cls(
            schedule=ls.schedule,
            geometry=Geometry(hole_radius=comp.open_hole_radius,
                              segment_height=ls.fracture_height),
            rock=Rock(youngs_modulus=ls.youngs_modulus, poisson_ratio=ls.poisson_ratio,
                      tensile_strength=ls.tensile_strength),
            stresses=Stresses(sigma_H=ls.sigma_H, sigma_h=ls.sigma_h,
                              pore_pressure=ls.pore_pressure),
            fluid=Fluid(density=ls.density, compressibility=comp.compressibility,
                        viscosity=ls.viscosity),
            completion=CompletionOptions(
                depth=comp.length_md, tvd=tvd, casing_id=comp.casing_id,
                casing_od=comp.casing_od, pipe_od=comp.pipe_od, pipe_id=comp.pipe_id,
                open_hole_length=comp.open_hole_length, expansion=comp.expansion,
                steel_modulus=comp.steel_modulus, steel_poisson=comp.steel_poisson,
                roughness=comp.roughness, well_compliance=ls.well_compliance,
                initial_pressure=ls.initial_pressure),
            numerics=Numerics(max_phase_duration=ls.max_phase_duration, dp_max=ls.dp_max),
            effects=Effects(pipe_friction=ls.pipe_friction),
            output=OutputOptions(log_interval=ls.dt, noise=ls.noise, resolution=ls.resolution,
                                 start_time=ls.start_time),     # noise: the master seed
            lumped=LumpedOptions(fracture_geometry=ls.geometry, toughness=ls.toughness,
                                 initial_flaw=ls.initial_flaw, reopening=ls.reopening,
                                 nwb_coefficient=ls.nwb_coefficient,
                                 leakoff_coefficient=ls.leakoff_coefficient,
                                 wall_leak_index=ls.wall_leak_index),
            model="lumped", seed=int(ls.seed), source_text=source_text,
            source_file=source_file)

    # ------------------------------------------------------------------ text
    def to_toml(self) -> str:
        """The scene as TOML in SI (every key written; loads back to an equal scene)."""
        lines = []
        for key in ("title", "model", "coupling", "seed"):
            if applies(self, key):
                lines.append(f"{key} = {_toml_value(getattr(self, key))}")
        for sec, cls in _SECTION_TYPES.items():
            if sec == "mesh" and "mesh" not in self.given:
                continue    # a [mesh] section asks for the 2D model
            obj = getattr(self, sec)
            body = []
            for f in dataclasses.fields(obj):
                v = getattr(obj, f.name)
                if v is None or f.name == "interface" or not applies(self, f"{sec}.{f.name}"):
                    continue    # a key the scene does not read is not written
                body.append(f"{f.name} = {_toml_value(v)}")
            if not body and not (sec == "effects" and self.effects.interface):
                continue
            lines.append(f"\n[{sec}]")
            lines.extend(body)
            if sec == "effects":
                for p in self.effects.interface:
                    lines.append("[[effects.interface]]")
                    lines.append(f"start = [{p.start[0]!r}, {p.start[1]!r}]")
                    lines.append(f"end = [{p.end[0]!r}, {p.end[1]!r}]")
                    lines.append(f"friction_angle = {float(p.friction_angle)!r}")
        lines.append("\n[schedule]")
        lines.append(f"cycles = {self.schedule.cycles}")
        for ph in self.schedule.phases:
            lines.append("[[schedule.phase]]")
            lines.append(f'kind = "{ph.kind}"')
            for f in dataclasses.fields(ph):
                v = getattr(ph, f.name)
                if v is None or (f.name == "name" and not v) or (
                        f.name == "pressure_at" and v == "bottomhole"):
                    continue
                if f.name == "steps":
                    v = "[" + ", ".join(f"[{d!r}, {r!r}]" for d, r in v) + "]"
                    lines.append(f"steps = {v}")
                    continue
                lines.append(f"{f.name} = {_toml_value(v)}")
        return "\n".join(lines) + "\n"

    @property
    def text(self) -> str:
        """The scene file's text if it was read from one, else :meth:`to_toml`."""
        return self.source_text if self.source_text is not None else self.to_toml()


_LUMPED_KEYS = {  # LumpedScene field -> scene key, for errors only the lumped model raises
    "initial_pressure": "completion.initial_pressure", "density": "fluid.density",
    "well_compliance": "completion.well_compliance", "dt": "output.log_interval",
    "fracture_height": "geometry.segment_height", "initial_flaw": "lumped.initial_flaw",
    "youngs_modulus": "rock.youngs_modulus", "tensile_strength": "rock.tensile_strength",
    "leakoff_coefficient": "lumped.leakoff_coefficient",
    "wall_leak_index": "lumped.wall_leak_index", "tvd": "completion.tvd",
}


def _shown(v: Any) -> str:
    if isinstance(v, tuple):
        return f"{len(v)} entries"
    return _toml_value(v)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, datetime):
        return v.isoformat()
    return '"' + str(v).replace("\\", "\\\\").replace('"', '\\"') + '"'


