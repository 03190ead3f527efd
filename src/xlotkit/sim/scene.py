r"""Simulation scenes: one validated description of an XLOT to simulate (SPEC §6).

A scene is a TOML file with the sections below (every key optional unless stated; numbers
without a unit are SI; strings may carry field units: ``"2000 m"``, ``"10 l/min"``,
``"35 MPa"``, ``"1.2 sg"``, ``"10 cP"``, ``"1 mD"``, ``"30 deg"``)::

    title = "..."                 # free text
    model = "auto"                # auto | lumped | mdem
    coupling = "monolithic"       # monolithic | wfd | wfc | wfdmod (2D model only)
    seed = 0                      # master seed (mesh jitter, heterogeneity, gauge noise)
    [geometry]    domain_size, hole_radius, segment_height
    [mesh]        growth, wall_element_size, max_element_size, fracture_band, band_width,
                  band_element_size, band_length, jitter, seed, file
    [rock]        youngs_modulus, poisson_ratio, biot, porosity, permeability,
                  tensile_strength, cohesion, friction_angle, heterogeneity,
                  strength_scaling_exponent, strength_scaling_reference_area, seed
    [stresses]    sigma_H, sigma_h, sigma_H_azimuth, pore_pressure
    [fluid]       density, compressibility, viscosity
    [completion]  depth, tvd, casing_id, casing_od, pipe_od, pipe_id, open_hole_length,
                  expansion, steel_modulus, steel_poisson, roughness, well_compliance,
                  initial_pressure
    [schedule]    see :meth:`xlotkit.sim.schedule.Schedule.from_dict`
    [numerics]    dt_min, dt_max, n1, n2, newton_tol, max_newton, checkpoint_steps,
                  checkpoint_seconds, max_phase_duration, dp_max
    [effects]     well_storage, pipe_friction, poroelastic, heterogeneity, strength_scaling,
                  shear_dilation, [[effects.interface]] (start, end, friction_angle)
    [output]      log_interval, noise, resolution, seed, snapshot_interval, start_time
    [lumped]      fracture_geometry, toughness, initial_flaw, reopening, nwb_coefficient,
                  leakoff_coefficient, wall_leak_index
    [well_coupling] tolerance, rate_tolerance, max_iterations, calibration, wfc_gain,
                  wfc_damping, wfdmod_gain, wfdmod_damping (coupling = wfd | wfc | wfdmod)

Every key, its unit, default and allowed range is listed in :data:`SCENE_KEYS` (and in
``docs/simulate.md``, generated from it by :func:`scene_reference_markdown`).

Model choice
------------
``model = "auto"`` takes the lumped model (:mod:`xlotkit.sim.lumped`) unless the scene asks
for physics only the 2D hydro-mechanical (MDEM) model has: a ``[mesh]`` section,
``effects.poroelastic``, ``effects.heterogeneity``, ``effects.strength_scaling``,
``effects.shear_dilation``, interface planes, or a ``coupling`` other than
``"monolithic"`` (the thesis's WFD/WFC schemes couple the 2D model to the well).
:attr:`Scene.two_d_reasons` lists what was found; ``model = "lumped"`` with any of them is
an error naming the key. A partitioned ``coupling`` (``wfd``, ``wfc``, ``wfdmod``) also needs
a well to couple the open hole to: ``effects.well_storage`` on and a whole-well compliance
above the open hole's own ``c_f pi r^2 h`` (else an error naming the key); its tolerances,
gains and damping are in ``[well_coupling]`` (ignored by ``monolithic``).

Lumped parameters derived from the rock
---------------------------------------
Without explicit ``lumped.leakoff_coefficient`` / ``lumped.wall_leak_index`` the lumped
model takes them from the rock: the open-hole wall's radial productivity
``J = 2 pi k L_oh / (mu ln(10))`` (:func:`xlotkit.formulas.wall_leak_index`) and the
Carter coefficient combining the filtrate-viscosity and reservoir-compressibility terms
(Economides & Nolte, :func:`xlotkit.formulas.carter_coefficient`) with ``dp = sigma_h - p0``::

    C_v = sqrt(k phi dp / (2 mu)),   C_c = dp sqrt(k phi c_f / (pi mu)),
    C_L = 2 C_v C_c / (C_v + sqrt(C_v^2 + 4 C_c^2))

The lumped scene format of :func:`xlotkit.sim.lumped.load_lumped_scene` (sections
``[stress]``, ``[fracture]``, ``[well]``) is recognised by :func:`load_scene` and converted
(:meth:`Scene.from_lumped`), so old scene files run unchanged.
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, ClassVar, Literal

from xlotkit import formulas
from xlotkit.errors import InputError
from xlotkit.sim.lumped import (
    NWB_DEFAULT,
    LumpedScene,
    _quantity,
    _scene_from_dict,
)
from xlotkit.sim.schedule import Schedule
from xlotkit.sim.well import WATER_COMPRESSIBILITY, Completion, INCH, well_compliance
from xlotkit.sim.wellcoupling import CouplingOptions

__all__ = [
    "SCENE_KEYS",
    "CompletionOptions",
    "Effects",
    "Fluid",
    "Geometry",
    "Interface",
    "LumpedOptions",
    "MeshOptions",
    "Numerics",
    "OutputOptions",
    "Rock",
    "Scene",
    "Stresses",
    "WellCouplingOptions",
    "carter_coefficient",
    "load_scene",
    "scene_from_dict",
    "scene_reference_markdown",
    "standard_2d_scene",
]

Model = Literal["auto", "lumped", "mdem"]
Coupling = Literal["monolithic", "wfd", "wfc", "wfdmod"]
#: Couplings of the well to the 2D segment that are partitioned (thesis 4.5).
PARTITIONED_COUPLINGS = ("wfd", "wfc", "wfdmod")
_WC = CouplingOptions()


# =========================================================================== key specs
@dataclass(frozen=True)
class KeySpec:
    """One scene key: its dimension, unit, range and meaning.

    Attributes
    ----------
    kind : str
        A :func:`xlotkit.sim.schedule.parse_quantity` kind (``pressure``, ``length``,
        ``time``, ``density``, ``dimensionless``), a pint unit giving the dimension
        (``"Pa*s"``), ``"permeability"``, ``"angle"`` (degrees), ``"bool"``, ``"int"``,
        ``"choice"``, ``"datetime"`` or ``"path"``.
    unit : str
        SI unit the value is stored in (for messages and docs).
    lo, hi : float or None
        Allowed range; ``lo_open`` / ``hi_open`` make a bound strict.
    optional : bool
        None (absent) is allowed and means "derived" (``doc`` says from what).
    choices : tuple of str
        Allowed values of a ``choice``.
    doc : str
        One-line meaning.
    """

    kind: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    optional: bool = False
    choices: tuple[str, ...] = ()
    doc: str = ""

    def range_text(self) -> str:
        """``"a number in (0, 1e-9] m^2"``-style description of what is allowed."""
        if self.kind == "choice":
            return " or ".join(repr(c) for c in self.choices)
        if self.kind == "bool":
            return "true or false"
        if self.kind == "datetime":
            return "an ISO 8601 date-time, e.g. 2026-01-01T08:00:00"
        if self.kind == "path":
            return "a file name"
        what = "an integer" if self.kind == "int" else "a number"
        u = f" {self.unit}" if self.unit else ""
        if self.lo is None and self.hi is None:
            return what + u
        if self.hi is None:
            return f"{what} {'>' if self.lo_open else '>='} {self.lo:g}{u}"
        if self.lo is None:
            return f"{what} {'<' if self.hi_open else '<='} {self.hi:g}{u}"
        return (f"{what} in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}"
                f"{')' if self.hi_open else ']'}{u}")

    def in_range(self, v: float) -> bool:
        """Whether the SI value ``v`` is finite and within the range."""
        if not math.isfinite(v):
            return False
        if self.lo is not None and (v < self.lo or (self.lo_open and v == self.lo)):
            return False
        if self.hi is not None and (v > self.hi or (self.hi_open and v == self.hi)):
            return False
        return True


def _k(kind: str, unit: str = "", lo=None, hi=None, *, lo_open=False, hi_open=False,
       optional=False, choices=(), doc="") -> KeySpec:
    return KeySpec(kind, unit, lo, hi, lo_open, hi_open, optional, tuple(choices), doc)


_P = "pressure"
_L = "length"
_T = "time"

#: section -> key -> specification (the allowed keys of a scene file).
SCENE_KEYS: dict[str, dict[str, KeySpec]] = {
    "": {
        "title": _k("str", doc="free text"),
        "model": _k("choice", choices=("auto", "lumped", "mdem"),
                    doc="simulator: lumped (well + analytic fracture) or mdem (2D); auto "
                        "picks lumped unless 2D physics is asked for"),
        "coupling": _k("choice", choices=("monolithic", "wfd", "wfc", "wfdmod"),
                       doc="well-formation coupling of the 2D model (SPEC §5): the well as "
                           "storage on p_w, or the thesis's WFD / WFC / WFDmod schemes "
                           "(docs/well-coupling.md)"),
        "seed": _k("int", "", 0, 2**63 - 1,
                   doc="master seed: mesh jitter, heterogeneity and gauge noise unless "
                       "their sections set their own"),
    },
    "geometry": {
        "domain_size": _k(_L, "m", 1.0, 1e4, doc="side of the square 2D domain"),
        "hole_radius": _k(_L, "m", 0.01, 2.0, doc="open-hole (borehole) radius"),
        "segment_height": _k(_L, "m", 0.0, 1000.0, lo_open=True,
                             doc="height of the open-hole segment (2D plane-strain "
                                 "thickness; KGD fracture height of the lumped model)"),
    },
    "mesh": {
        "growth": _k("dimensionless", "", 1.0, 2.0, lo_open=True,
                     doc="element size growth rate away from the hole"),
        "wall_element_size": _k(_L, "m", 0.0, 1.0, lo_open=True, optional=True,
                                doc="edge length on the hole wall (default 2 pi r / 64)"),
        "max_element_size": _k(_L, "m", 0.0, 1e3, lo_open=True, optional=True,
                               doc="largest edge length (default domain_size / 10)"),
        "fracture_band": _k("bool", doc="refine a band along sigma_H (expected fracture)"),
        "band_width": _k(_L, "m", 0.0, 100.0, lo_open=True, doc="full width of the band"),
        "band_element_size": _k(_L, "m", 0.0, 1.0, lo_open=True, optional=True,
                                doc="edge length in the band (default wall_element_size)"),
        "band_length": _k(_L, "m", 0.0, 1e4, lo_open=True,
                          doc="half-length of the band from the hole centre"),
        "band_strip": _k("bool", doc="lay a crack strip along the band axis: two staggered "
                                     "node rows, every strip triangle straddling the axis "
                                     "(only they are band clusters)"),
        "jitter": _k("dimensionless", "", 0.0, 0.3,
                     doc="random node displacement, fraction of the local size"),
        "seed": _k("int", "", 0, 2**63 - 1, optional=True,
                   doc="seed of the jitter (default: the master seed)"),
        "file": _k("path", optional=True,
                   doc="a triangle mesh readable by meshio instead of the generator "
                       "(relative to the scene file)"),
    },
    "rock": {
        "youngs_modulus": _k(_P, "Pa", 1e8, 500e9, doc="Young's modulus E"),
        "poisson_ratio": _k("dimensionless", "", 0.0, 0.5, hi_open=True,
                            doc="Poisson's ratio nu"),
        "biot": _k("dimensionless", "", 0.0, 1.0, lo_open=True, doc="Biot coefficient alpha"),
        "porosity": _k("dimensionless", "", 0.0, 1.0, lo_open=True, hi_open=True,
                       doc="porosity phi"),
        "permeability": _k("permeability", "m^2", 0.0, 1e-9,
                           doc="matrix permeability k (accepts mD, uD, nD, darcy)"),
        "tensile_strength": _k(_P, "Pa", 0.0, 100e6, doc="tensile strength T0"),
        "cohesion": _k(_P, "Pa", 0.0, 500e6, doc="Mohr-Coulomb cohesion S0"),
        "friction_angle": _k("angle", "deg", 0.0, 89.0, doc="internal friction angle phi"),
        "heterogeneity": _k("dimensionless", "", 0.0, 1.0, hi_open=True,
                            doc="half-width of the uniform strength perturbation (used when "
                                "effects.heterogeneity)"),
        "strength_scaling_exponent": _k("dimensionless", "", 0.0, 1.0,
                                        doc="exponent m of (A_ref / A)^m (used when "
                                            "effects.strength_scaling)"),
        "strength_scaling_reference_area": _k("m**2", "m^2", 0.0, 1e4, lo_open=True,
                                              doc="reference cluster area A_ref"),
        "toughness": _k("Pa*m**0.5", "Pa m^0.5", 0.0, 100e6, lo_open=True, optional=True,
                        doc="fracture toughness K_IC of crack-tip clusters (used when "
                            "effects.strength_scaling; sets A_ref from T0, needs the "
                            "exponent 0.25)"),
        "fracture_friction_angle": _k("angle", "deg", 0.0, 89.0,
                                      doc="friction angle of failed fracture-band clusters "
                                          "(used when effects.fracture_plane)"),
        "seed": _k("int", "", 0, 2**63 - 1, optional=True,
                   doc="seed of the heterogeneity draw (default: the master seed)"),
    },
    "stresses": {
        "sigma_H": _k(_P, "Pa", 0.0, 500e6, lo_open=True,
                      doc="maximum horizontal total stress (>= sigma_h)"),
        "sigma_h": _k(_P, "Pa", 0.0, 500e6, lo_open=True,
                      doc="minimum horizontal total stress"),
        "sigma_H_azimuth": _k("angle", "deg", 0.0, 180.0, hi_open=True,
                              doc="direction of sigma_H, counter-clockwise from the 2D x axis"),
        "pore_pressure": _k(_P, "Pa", 0.0, 500e6, doc="initial pore pressure p0 (< sigma_h)"),
    },
    "fluid": {
        "density": _k("density", "kg/m^3", 100.0, 5000.0, doc="density rho0 at surface"),
        "compressibility": _k("1/Pa", "1/Pa", 0.0, 1e-6, doc="compressibility c_f"),
        "viscosity": _k("Pa*s", "Pa s", 0.0, 100.0, lo_open=True, doc="viscosity mu"),
    },
    "completion": {
        "depth": _k(_L, "m", 0.0, 20000.0, lo_open=True,
                    doc="measured depth of the bottom of the open hole"),
        "tvd": _k(_L, "m", 0.0, 20000.0, optional=True,
                  doc="true vertical depth of the open hole (default: depth, vertical)"),
        "casing_id": _k(_L, "m", 0.0, 2.0, lo_open=True, doc="casing inner diameter"),
        "casing_od": _k(_L, "m", 0.0, 3.0, lo_open=True, optional=True,
                        doc="casing outer diameter (needed with expansion)"),
        "pipe_od": _k(_L, "m", 0.0, 2.0, doc="drill-pipe outer diameter (0: no pipe)"),
        "pipe_id": _k(_L, "m", 0.0, 2.0, lo_open=True, doc="drill-pipe inner diameter"),
        "open_hole_length": _k(_L, "m", 0.0, 20000.0,
                               doc="length of new formation below the shoe"),
        "expansion": _k("bool", doc="add casing expansion and pipe-steel compression to "
                                    "the well compliance"),
        "steel_modulus": _k(_P, "Pa", 1e9, 1e12, doc="Young's modulus of the steel"),
        "steel_poisson": _k("dimensionless", "", 0.0, 0.5, hi_open=True,
                            doc="Poisson's ratio of the steel"),
        "roughness": _k(_L, "m", 0.0, 0.01, doc="absolute pipe roughness"),
        "well_compliance": _k("m**3/Pa", "m^3/Pa", 0.0, 1e-3, lo_open=True, optional=True,
                              doc="override of the well compliance C_w (default from the "
                                  "completion and c_f)"),
        "initial_pressure": _k(_P, "Pa", 0.0, 500e6, optional=True,
                               doc="bottom-hole pressure at t = 0 (default: static column)"),
    },
    "numerics": {
        "dt_min": _k(_T, "s", 0.0, 1.0, lo_open=True, doc="smallest time step (2D model)"),
        "dt_max": _k(_T, "s", 0.0, 3600.0, lo_open=True,
                     doc="largest time step (2D model; the lumped model never steps over a "
                         "log sample)"),
        "n1": _k("int", "", 0, 10**6, doc="step may grow when fewer clusters fail in it"),
        "n2": _k("int", "", 1, 10**6, doc="step is cut when more clusters fail in it"),
        "newton_tol": _k("dimensionless", "", 0.0, 1e-2, lo_open=True,
                         doc="relative Newton residual tolerance"),
        "max_newton": _k("int", "", 1, 1000, doc="Newton iterations per step"),
        "checkpoint_steps": _k("int", "", 1, 10**9, doc="checkpoint every this many steps"),
        "checkpoint_seconds": _k(_T, "s", 0.0, 86400.0, lo_open=True,
                                 doc="and at least every this much wall-clock time"),
        "max_phase_duration": _k(_T, "s", 1.0, 30 * 86400.0,
                                 doc="safety limit of a phase whose end is never met"),
        "dp_max": _k(_P, "Pa", 1e3, 10e6, doc="largest pressure change per step (lumped)"),
    },
    "effects": {
        "well_storage": _k("bool", doc="the whole well's fluid volume stores fluid (false: "
                                       "only the open-hole segment)"),
        "pipe_friction": _k("bool", doc="pipe friction between surface and bottom hole"),
        "poroelastic": _k("bool", doc="poroelastic coupling of matrix flow and rock (2D)"),
        "heterogeneity": _k("bool", doc="seeded strength heterogeneity (2D)"),
        "strength_scaling": _k("bool", doc="triangle-size strength scaling (2D)"),
        "shear_dilation": _k("bool", doc="shear dilation of fracture apertures (2D)"),
        "fracture_plane": _k("bool", doc="failed clusters of the fracture band open and "
                                         "close as a smooth joint along sigma_H, with "
                                         "rock.fracture_friction_angle (2D; needs "
                                         "mesh.fracture_band)"),
        "interface": _k("interfaces", doc="planes of weakness, [[effects.interface]] tables "
                                          "with start = [x, y], end = [x, y] (m), "
                                          "friction_angle (deg) (2D)"),
    },
    "output": {
        "log_interval": _k(_T, "s", 1e-3, 3600.0, doc="sample interval of the synthetic log"),
        "noise": _k(_P, "Pa", 0.0, 10e6, doc="standard deviation of Gaussian gauge noise"),
        "resolution": _k(_P, "Pa", 0.0, 10e6, doc="gauge resolution (0: none)"),
        "seed": _k("int", "", 0, 2**63 - 1, optional=True,
                   doc="seed of the gauge noise (default: the master seed)"),
        "snapshot_interval": _k(_T, "s", 0.0, 1e7, lo_open=True, optional=True,
                                doc="simulated time between field snapshots (models with "
                                    "a mesh; default none)"),
        "start_time": _k("datetime", optional=True, doc="clock time of t = 0 in the log"),
        "gauge": _k("choice", choices=("bottomhole", "surface"),
                    doc="gauge of the log's pressure: the bottom hole, or the surface "
                        "(cementing unit: the bottom-hole pressure less the fluid column, "
                        "and the pipe friction of the flow with effects.pipe_friction)"),
    },
    "lumped": {
        "fracture_geometry": _k("choice", choices=("penny", "kgd"),
                                doc="fracture geometry of the lumped model"),
        "toughness": _k("Pa*m**0.5", "Pa m^0.5", 0.0, 100e6, lo_open=True,
                        doc="apparent fracture toughness K_Ic"),
        "initial_flaw": _k(_L, "m", 0.0, 10.0, lo_open=True, optional=True,
                           doc="flaw size at breakdown (default: geometry.hole_radius)"),
        "reopening": _k("choice", choices=("wellbore", "sigma_h"),
                        doc="where a closed fracture reopens"),
        "nwb_coefficient": _k("Pa*s**2/m**6", "Pa s^2/m^6", 0.0, 1e13,
                              doc="near-wellbore entry loss k (p = p_f + k Q_f^2)"),
        "leakoff_coefficient": _k("m/s**0.5", "m/s^0.5", 0.0, 1e-2, optional=True,
                                  doc="Carter C_L (default: from rock and fluid, see docs)"),
        "wall_leak_index": _k("m**3/s/Pa", "m^3/(s Pa)", 0.0, 1e-6, optional=True,
                              doc="open-hole wall leak J (default: from the permeability)"),
    },
    "well_coupling": {
        "tolerance": _k("dimensionless", "", 0.0, 1.0, lo_open=True,
                        doc="wfd, wfdmod: relative BHP mismatch accepted per step "
                            "(eps_BHP,max, thesis Eq. 4.17a/4.18)"),
        "rate_tolerance": _k("dimensionless", "", 0.0, 10.0, lo_open=True,
                             doc="wfd: relative loss-rate change accepted on a step's first "
                                 "iteration (Eq. 4.17b)"),
        "max_iterations": _k("int", "", 1, 1000,
                             doc="wfd: segment calls per step before the least-mismatch one "
                                 "is kept"),
        "calibration": _k("dimensionless", "", 0.0, 10.0, lo_open=True,
                          doc="wfd: damping of the first update of the loss-rate guess"),
        "wfc_gain": _k("dimensionless", "", 0.0, 10.0,
                       doc="wfc: gain G on the BHP mismatch, per step (Eq. 4.19)"),
        "wfc_damping": _k("dimensionless", "", 0.0, 1.0, hi_open=True,
                          doc="wfc: damping gamma (Eq. 4.22)"),
        "wfdmod_gain": _k("dimensionless", "", 0.0, 10.0,
                          doc="wfdmod: gain after pumping (Eq. 4.23)"),
        "wfdmod_damping": _k("dimensionless", "", 0.0, 1.0, hi_open=True,
                             doc="wfdmod: damping after pumping (Eq. 4.23)"),
    },
}

_SECTIONS = tuple(s for s in SCENE_KEYS if s) + ("schedule",)
_LUMPED_FORMAT = {"stress", "fracture", "well"}

_DARCY = 9.869233e-13
_PERM_UNITS = {"d": _DARCY, "darcy": _DARCY, "md": 1e-3 * _DARCY, "millidarcy": 1e-3 * _DARCY,
               "ud": 1e-6 * _DARCY, "µd": 1e-6 * _DARCY, "μd": 1e-6 * _DARCY,
               "microdarcy": 1e-6 * _DARCY, "nd": 1e-9 * _DARCY, "nanodarcy": 1e-9 * _DARCY}
_NUM_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def _spec(section: str, key: str) -> KeySpec:
    return SCENE_KEYS[section][key]


def _dotted(section: str, key: str) -> str:
    return f"{section}.{key}" if section else key


def _range_error(section: str, key: str, raw: Any, si: float | None = None) -> InputError:
    sp = _spec(section, key)
    shown = repr(raw)
    if si is not None and isinstance(raw, str):
        shown += f" (= {si:g} {sp.unit})".replace("  ", " ")
    return InputError(f"value {shown} is out of range", key=_dotted(section, key),
                      expected=sp.range_text())


def _to_si(section: str, key: str, raw: Any) -> Any:
    """The SI value of one raw TOML value, checked against the key's range."""
    sp = _spec(section, key)
    dk = _dotted(section, key)
    if raw is None:
        if sp.optional:
            return None
        raise InputError("is required", key=dk, expected=sp.range_text())
    kind = sp.kind
    if kind == "bool":
        if not isinstance(raw, bool):
            raise InputError(f"must be true or false, got {raw!r}", key=dk,
                             expected="true or false")
        return raw
    if kind in ("str", "path"):
        if not isinstance(raw, str):
            raise InputError(f"must be a string, got {raw!r}", key=dk, expected="a string")
        return raw
    if kind == "choice":
        v = raw.strip().lower() if isinstance(raw, str) else raw
        if v not in sp.choices:
            raise InputError(f"unknown value {raw!r}", key=dk, expected=sp.range_text())
        return v
    if kind == "datetime":
        if isinstance(raw, datetime):
            return raw
        try:
            return datetime.fromisoformat(str(raw))
        except ValueError:
            raise InputError(f"cannot read {raw!r} as a date-time", key=dk,
                             expected=sp.range_text()) from None
    if kind == "int":
        if isinstance(raw, float) and raw.is_integer():
            raw = int(raw)
        if isinstance(raw, bool) or not isinstance(raw, int):
            raise InputError(f"must be an integer, got {raw!r}", key=dk,
                             expected=sp.range_text())
        if not sp.in_range(float(raw)):
            raise _range_error(section, key, raw)
        return raw
    if kind == "angle":
        v = _angle(raw, dk)
    elif kind == "permeability":
        v = _permeability(raw, dk)
    else:
        v = _quantity(raw, kind, dk)
    if not sp.in_range(v):
        raise _range_error(section, key, raw, v)
    return v


def _angle(raw: Any, key: str) -> float:
    """Degrees from a number (degrees) or ``"30 deg"`` / ``"0.5 rad"``."""
    if isinstance(raw, bool):
        raise InputError(f"must be an angle, got {raw!r}", key=key, expected="e.g. '30 deg'")
    if isinstance(raw, (int, float)):
        return float(raw)
    m = _NUM_UNIT.match(str(raw))
    if not m:
        raise InputError(f"cannot read {raw!r}", key=key, expected="e.g. '30 deg'")
    num, unit = float(m.group(1)), m.group(2).strip().lower()
    if unit in ("", "deg", "degree", "degrees", "°"):
        return num
    if unit in ("rad", "radian", "radians"):
        return math.degrees(num)
    raise InputError(f"unit {unit!r} is not an angle unit", key=key,
                     expected="deg or rad, e.g. '30 deg'")


def _permeability(raw: Any, key: str) -> float:
    """m^2 from a number (m^2) or ``"1 mD"``, ``"50 nD"``, ``"1e-18 m**2"``."""
    if isinstance(raw, str):
        m = _NUM_UNIT.match(raw)
        if m and m.group(2).strip().lower() in _PERM_UNITS:
            return float(m.group(1)) * _PERM_UNITS[m.group(2).strip().lower()]
    return _quantity(raw, "m**2", key)


def _validate(obj: Any, section: str) -> None:
    """Range-check every field of a section dataclass built in Python (SI values)."""
    for f in dataclasses.fields(obj):
        if f.name not in SCENE_KEYS[section]:
            continue
        sp = _spec(section, f.name)
        v = getattr(obj, f.name)
        dk = _dotted(section, f.name)
        if v is None:
            if not sp.optional:
                raise InputError("is required", key=dk, expected=sp.range_text())
            continue
        if sp.kind == "bool":
            if not isinstance(v, bool):
                raise InputError(f"must be true or false, got {v!r}", key=dk,
                                 expected="true or false")
        elif sp.kind == "choice":
            if v not in sp.choices:
                raise InputError(f"unknown value {v!r}", key=dk, expected=sp.range_text())
        elif sp.kind in ("str", "path", "interfaces"):
            continue
        elif sp.kind == "datetime":
            if not isinstance(v, datetime):
                raise InputError(f"must be a datetime, got {v!r}", key=dk,
                                 expected=sp.range_text())
        elif sp.kind == "int":
            if isinstance(v, bool) or not isinstance(v, int) or not sp.in_range(float(v)):
                raise _range_error(section, f.name, v)
        else:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise InputError(f"must be a number, got {v!r}", key=dk,
                                 expected=sp.range_text())
            if not sp.in_range(float(v)):
                raise _range_error(section, f.name, v)


# =========================================================================== sections
@dataclass(frozen=True, kw_only=True)
class Geometry:
    """``[geometry]``: the 2D section through the open hole (SI)."""

    section: ClassVar[str] = "geometry"
    domain_size: float = 100.0
    hole_radius: float = 0.15
    segment_height: float = 10.0

    def __post_init__(self) -> None:
        _validate(self, self.section)
        if self.hole_radius >= 0.25 * self.domain_size:
            raise InputError(f"value {self.hole_radius!r} is too large for the domain",
                             key="geometry.hole_radius",
                             expected=f"a radius < domain_size / 4 = "
                                      f"{0.25 * self.domain_size:g} m")


@dataclass(frozen=True, kw_only=True)
class MeshOptions:
    """``[mesh]``: the graded borehole mesh of the 2D model (see :func:`borehole_mesh`)."""

    section: ClassVar[str] = "mesh"
    growth: float = 1.2
    wall_element_size: float | None = None
    max_element_size: float | None = None
    fracture_band: bool = False
    band_width: float = 1.0
    band_element_size: float | None = None
    band_length: float = 10.0
    band_strip: bool = False
    jitter: float = 0.0
    seed: int | None = None
    file: str | None = None

    def __post_init__(self) -> None:
        _validate(self, self.section)


@dataclass(frozen=True, kw_only=True)
class Rock:
    """``[rock]``: elastic, hydraulic and strength properties (SI; angles in degrees)."""

    section: ClassVar[str] = "rock"
    youngs_modulus: float = 10e9
    poisson_ratio: float = 0.25
    biot: float = 1.0
    porosity: float = 0.1
    permeability: float = 1e-18
    tensile_strength: float = 3e6
    cohesion: float = 10e6
    friction_angle: float = 30.0
    heterogeneity: float = 0.25
    strength_scaling_exponent: float = 0.25
    strength_scaling_reference_area: float = 1e-4
    toughness: float | None = None
    fracture_friction_angle: float = 0.0
    seed: int | None = None

    def __post_init__(self) -> None:
        _validate(self, self.section)
        if self.toughness is not None and self.strength_scaling_exponent != 0.25:
            raise InputError("a toughness needs the LEFM exponent 0.25",
                             key="rock.strength_scaling_exponent", expected="0.25")
        if self.toughness is not None and self.tensile_strength == 0.0:
            raise InputError("a toughness needs a positive tensile strength",
                             key="rock.tensile_strength", expected="> 0 with rock.toughness")


@dataclass(frozen=True, kw_only=True)
class Stresses:
    """``[stresses]``: far-field stresses and pore pressure (Pa; azimuth in degrees)."""

    section: ClassVar[str] = "stresses"
    sigma_H: float = 35e6
    sigma_h: float = 30e6
    sigma_H_azimuth: float = 0.0
    pore_pressure: float = 20e6

    def __post_init__(self) -> None:
        _validate(self, self.section)
        if self.sigma_H < self.sigma_h:
            raise InputError(f"value {self.sigma_H!r} is below sigma_h", key="stresses.sigma_H",
                             expected=f"a number in [{self.sigma_h:g}, 5e+08] Pa (>= sigma_h)")
        if self.pore_pressure >= self.sigma_h:
            raise InputError(f"value {self.pore_pressure!r} is not below sigma_h",
                             key="stresses.pore_pressure",
                             expected=f"a number in [0, {self.sigma_h:g}) Pa (< sigma_h)")


@dataclass(frozen=True, kw_only=True)
class Fluid:
    """``[fluid]``: the well fluid (also the pore fluid)."""

    section: ClassVar[str] = "fluid"
    density: float = 1200.0
    compressibility: float = WATER_COMPRESSIBILITY
    viscosity: float = 0.01

    def __post_init__(self) -> None:
        _validate(self, self.section)


@dataclass(frozen=True, kw_only=True)
class CompletionOptions:
    """``[completion]``: the well above the open hole (the thesis's 2000 m well by default).

    :meth:`completion` builds the :class:`xlotkit.sim.well.Completion` (open-hole radius
    from ``[geometry]``, compressibility from ``[fluid]``).
    """

    section: ClassVar[str] = "completion"
    depth: float = 2000.0
    tvd: float | None = None
    casing_id: float = 12.715 * INCH
    casing_od: float | None = None
    pipe_od: float = 5.0 * INCH
    pipe_id: float = 4.276 * INCH
    open_hole_length: float = 10.0
    expansion: bool = False
    steel_modulus: float = 200e9
    steel_poisson: float = 0.3
    roughness: float = 4.6e-5
    well_compliance: float | None = None
    initial_pressure: float | None = None

    def __post_init__(self) -> None:
        _validate(self, self.section)
        self.completion(Geometry(), Fluid())    # cross-checks (pipe in casing, ...)

    _RENAME: ClassVar[dict[str, str]] = {"length_md": "depth", "depth_tvd": "tvd"}

    def completion(self, geometry: Geometry, fluid: Fluid) -> Completion:
        """The :class:`~xlotkit.sim.well.Completion` this section describes."""
        try:
            return Completion(
                casing_id=self.casing_id, casing_od=self.casing_od, pipe_od=self.pipe_od,
                pipe_id=self.pipe_id, length_md=self.depth, depth_tvd=self.tvd,
                open_hole_length=self.open_hole_length,
                open_hole_radius=geometry.hole_radius, compressibility=fluid.compressibility,
                expansion=self.expansion, steel_modulus=self.steel_modulus,
                steel_poisson=self.steel_poisson, roughness=self.roughness)
        except InputError as exc:
            k = (exc.key or "").removeprefix("completion.")
            key = {"open_hole_radius": "geometry.hole_radius",
                   "compressibility": "fluid.compressibility"}.get(
                k, "completion." + self._RENAME.get(k, k))
            raise InputError(exc.message, key=key, expected=exc.expected) from None


@dataclass(frozen=True, kw_only=True)
class Numerics:
    """``[numerics]``: time stepping, Newton and checkpoints."""

    section: ClassVar[str] = "numerics"
    dt_min: float = 1e-6
    dt_max: float = 1.0
    n1: int = 2
    n2: int = 10
    newton_tol: float = 1e-9
    max_newton: int = 50
    checkpoint_steps: int = 1000
    checkpoint_seconds: float = 60.0
    max_phase_duration: float = 6 * 3600.0
    dp_max: float = 0.2e6

    def __post_init__(self) -> None:
        _validate(self, self.section)
        if self.dt_min > self.dt_max:
            raise InputError(f"value {self.dt_min!r} is above dt_max", key="numerics.dt_min",
                             expected=f"a number in (0, {self.dt_max:g}] s (<= dt_max)")
        if self.n1 > self.n2:
            raise InputError(f"value {self.n1!r} is above n2", key="numerics.n1",
                             expected=f"an integer in [0, {self.n2}] (<= n2)")


@dataclass(frozen=True)
class Interface:
    """A plane of weakness (``[[effects.interface]]``): a segment in the 2D section.

    Attributes
    ----------
    start, end : tuple of float
        End points [m] (hole centre at the origin).
    friction_angle : float
        Friction angle of the plane [deg], in [0, 89].
    """

    start: tuple[float, float]
    end: tuple[float, float]
    friction_angle: float = 30.0

    def __post_init__(self) -> None:
        for name in ("start", "end"):
            v = getattr(self, name)
            try:
                pt = tuple(float(x) for x in v)
            except (TypeError, ValueError):
                pt = ()
            if len(pt) != 2 or not all(map(math.isfinite, pt)):
                raise InputError(f"value {v!r} is not a point", key=f"interface.{name}",
                                 expected="[x, y] in m")
            object.__setattr__(self, name, pt)
        if self.start == self.end:
            raise InputError("start and end coincide", key="interface.end",
                             expected="a segment of positive length")
        if not (0.0 <= float(self.friction_angle) <= 89.0):
            raise InputError(f"value {self.friction_angle!r} is out of range",
                             key="interface.friction_angle", expected="a number in [0, 89] deg")


@dataclass(frozen=True, kw_only=True)
class Effects:
    """``[effects]``: the physics the scene asks for (the engine assembles only these)."""

    section: ClassVar[str] = "effects"
    well_storage: bool = True
    pipe_friction: bool = False
    poroelastic: bool = False
    heterogeneity: bool = False
    strength_scaling: bool = False
    shear_dilation: bool = False
    fracture_plane: bool = False
    interface: tuple[Interface, ...] = ()

    def __post_init__(self) -> None:
        _validate(self, self.section)
        object.__setattr__(self, "interface", tuple(self.interface))
        for i, p in enumerate(self.interface):
            if not isinstance(p, Interface):
                raise InputError(f"not an Interface: {p!r}", key=f"effects.interface[{i}]",
                                 expected="a table with start, end, friction_angle")


@dataclass(frozen=True, kw_only=True)
class OutputOptions:
    """``[output]``: synthetic log sampling, gauge noise and field snapshots."""

    section: ClassVar[str] = "output"
    log_interval: float = 1.0
    noise: float = 0.0
    resolution: float = 0.0
    seed: int | None = None
    snapshot_interval: float | None = None
    start_time: datetime | None = None
    gauge: Literal["bottomhole", "surface"] = "bottomhole"

    def __post_init__(self) -> None:
        _validate(self, self.section)


@dataclass(frozen=True, kw_only=True)
class LumpedOptions:
    """``[lumped]``: parameters only the lumped model uses."""

    section: ClassVar[str] = "lumped"
    fracture_geometry: Literal["penny", "kgd"] = "penny"
    toughness: float = 2e6
    initial_flaw: float | None = None
    reopening: Literal["wellbore", "sigma_h"] = "wellbore"
    nwb_coefficient: float = NWB_DEFAULT
    leakoff_coefficient: float | None = None
    wall_leak_index: float | None = None

    def __post_init__(self) -> None:
        _validate(self, self.section)


@dataclass(frozen=True, kw_only=True)
class WellCouplingOptions:
    """``[well_coupling]``: tolerances, gains and damping of the partitioned couplings
    (``coupling = "wfd" | "wfc" | "wfdmod"``; :class:`xlotkit.sim.wellcoupling.
    CouplingOptions`, docs/well-coupling.md). Ignored by ``monolithic``."""

    section: ClassVar[str] = "well_coupling"
    tolerance: float = _WC.wfd_tolerance
    rate_tolerance: float = _WC.wfd_rate_tolerance
    max_iterations: int = _WC.wfd_max_iterations
    calibration: float = _WC.wfd_calibration
    wfc_gain: float = _WC.wfc_gain
    wfc_damping: float = _WC.wfc_damping
    wfdmod_gain: float = _WC.wfdmod_gain
    wfdmod_damping: float = _WC.wfdmod_damping

    def __post_init__(self) -> None:
        _validate(self, self.section)

    def options(self) -> CouplingOptions:
        """The :class:`~xlotkit.sim.wellcoupling.CouplingOptions` of this section."""
        return CouplingOptions(
            wfd_tolerance=self.tolerance, wfd_rate_tolerance=self.rate_tolerance,
            wfd_max_iterations=self.max_iterations, wfd_calibration=self.calibration,
            wfc_gain=self.wfc_gain, wfc_damping=self.wfc_damping,
            wfdmod_gain=self.wfdmod_gain, wfdmod_damping=self.wfdmod_damping)


_SECTION_TYPES: dict[str, type] = {
    "geometry": Geometry, "mesh": MeshOptions, "rock": Rock, "stresses": Stresses,
    "fluid": Fluid, "completion": CompletionOptions, "numerics": Numerics,
    "effects": Effects, "output": OutputOptions, "lumped": LumpedOptions,
    "well_coupling": WellCouplingOptions,
}


#: Combined Carter coefficient of the rock (:func:`xlotkit.formulas.carter_coefficient`).
carter_coefficient = formulas.carter_coefficient


# =========================================================================== scene
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
        Sections present in the scene file (a ``[mesh]`` section asks for the 2D model).
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
        if self.model == "lumped" and self.two_d_reasons:
            key = self.two_d_reasons[0]
            raise InputError(f"model = 'lumped' cannot simulate {key}", key=key,
                             expected="model = 'mdem' or 'auto', or drop " + key)
        if self.coupling in PARTITIONED_COUPLINGS:
            self._check_partitioned()
        if self.resolved_model == "lumped":
            # fail now, not mid-run, on values only the lumped model rejects
            try:
                self.to_lumped()
            except InputError as exc:
                raise InputError(exc.message, key=_LUMPED_KEYS.get(exc.key or "", exc.key),
                                 expected=exc.expected) from None

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
                                 seed=int(ls.seed), start_time=ls.start_time),
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
            lines.append(f"{key} = {_toml_value(getattr(self, key))}")
        for sec, cls in _SECTION_TYPES.items():
            if sec == "mesh" and "mesh" not in self.given:
                continue    # a [mesh] section asks for the 2D model
            obj = getattr(self, sec)
            lines.append(f"\n[{sec}]")
            for f in dataclasses.fields(obj):
                v = getattr(obj, f.name)
                if v is None or f.name == "interface":
                    continue
                lines.append(f"{f.name} = {_toml_value(v)}")
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


# =========================================================================== reading
def scene_from_dict(data: Mapping[str, Any], *, file: str | None = None,
                    text: str | None = None) -> Scene:
    """Build a :class:`Scene` from a mapping laid out like a scene file.

    Parameters
    ----------
    data : mapping
        The parsed TOML.
    file : str, optional
        Named in errors; relative ``mesh.file`` paths are taken from its folder.
    text : str, optional
        The file's text, kept in :attr:`Scene.source_text`.

    Raises
    ------
    InputError
        One error naming the file, the dotted key (``rock.permeability``), the value given
        and the allowed range; an unknown section or key lists the allowed ones.
    """
    try:
        return _build(data, file=file, text=text)
    except InputError as exc:
        if exc.file is None and file is not None:
            raise InputError(exc.message, file=file, line=exc.line, key=exc.key,
                             expected=exc.expected) from None
        raise


def _build(data: Mapping[str, Any], *, file: str | None, text: str | None) -> Scene:
    if not isinstance(data, Mapping):
        raise InputError("a scene must be a table", key="scene",
                         expected="a mapping of sections")
    if _LUMPED_FORMAT & set(data) and not (set(data) - {"title", "rock", "fluid", "output",
                                                        "schedule"} - _LUMPED_FORMAT):
        ls = _scene_from_dict(data, file=file)
        sc = Scene.from_lumped(ls, source_text=text, source_file=file)
        title = data.get("title")
        return dataclasses.replace(sc, title=str(title)) if isinstance(title, str) else sc
    top = SCENE_KEYS[""]
    kw: dict[str, Any] = {}
    given: set[str] = set()
    for name, body in data.items():
        if name in top:
            kw[name] = _to_si("", name, body)
            continue
        if name not in _SECTIONS:
            raise InputError(f"unknown section or key {name!r}", key=name,
                             expected="one of " + ", ".join([*top, *_SECTIONS]))
        given.add(name)
        if name == "schedule":
            kw["schedule"] = Schedule.from_dict(body, key="schedule")
            continue
        if not isinstance(body, Mapping):
            raise InputError("must be a table", key=name, expected=f"a [{name}] table")
        allowed = SCENE_KEYS[name]
        skw: dict[str, Any] = {}
        for k, v in body.items():
            if k not in allowed:
                raise InputError(f"unknown key {k!r}", key=f"{name}.{k}",
                                 expected="one of " + ", ".join(allowed))
            if name == "effects" and k == "interface":
                skw[k] = _interfaces(v)
            else:
                skw[k] = _to_si(name, k, v)
        if name == "mesh" and skw.get("file"):
            mf = Path(skw["file"])
            if file is not None and not mf.is_absolute():
                mf = Path(file).parent / mf
            if not mf.is_file():
                raise InputError(f"no such mesh file {skw['file']!r}", key="mesh.file",
                                 expected="a triangle mesh readable by meshio (relative "
                                          "to the scene file)")
            skw["file"] = str(mf)
        try:
            kw[name] = _SECTION_TYPES[name](**skw)
        except InputError as exc:
            # a cross-check (sigma_H >= sigma_h, ...) reports SI values: add what was given
            k = (exc.key or "").removeprefix(name + ".")
            msg = exc.message
            if k in body and isinstance(body[k], str):
                msg += f" (given {body[k]!r})"
            raise InputError(msg, key=exc.key, expected=exc.expected) from None
    if "schedule" not in kw:
        raise InputError("missing [schedule]", key="schedule",
                         expected="a [schedule] table with [[schedule.phase]] entries")
    return Scene(**kw, given=frozenset(given), source_text=text, source_file=file)


def _interfaces(v: Any) -> tuple[Interface, ...]:
    if not isinstance(v, list):
        raise InputError("must be a list of tables", key="effects.interface",
                         expected="[[effects.interface]] tables with start, end")
    out = []
    for i, d in enumerate(v):
        key = f"effects.interface[{i}]"
        if not isinstance(d, Mapping):
            raise InputError("must be a table", key=key, expected="start, end, friction_angle")
        extra = set(d) - {"start", "end", "friction_angle"}
        if extra:
            raise InputError(f"unknown key {sorted(extra)[0]!r}", key=f"{key}.{sorted(extra)[0]}",
                             expected="one of start, end, friction_angle")
        try:
            pts = {n: [_quantity(x, "length", f"{key}.{n}") for x in d.get(n, ())]
                   for n in ("start", "end")}
            fa = _angle(d.get("friction_angle", 30.0), f"{key}.friction_angle")
            out.append(Interface(start=tuple(pts["start"]), end=tuple(pts["end"]),
                                 friction_angle=fa))
        except InputError as exc:
            k = (exc.key or "").replace("interface.", f"{key}.", 1)
            raise InputError(exc.message, key=k, expected=exc.expected) from None
        except TypeError:
            raise InputError("start and end must be [x, y] lists", key=key,
                             expected="[x, y] in m") from None
    return tuple(out)


def load_scene(path: str | Path) -> Scene:
    """Read a scene file (the layout above, or the lumped layout of
    :func:`xlotkit.sim.lumped.load_lumped_scene`).

    Raises
    ------
    InputError
        If the file cannot be read, is not valid TOML (with the line), or a key is unknown,
        of the wrong unit or out of range.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read scene file: {exc.strerror}", file=str(p)) from None
    try:
        text = raw.decode("utf-8")
        data = tomllib.loads(text)
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text file", file=str(p)) from None
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        raise InputError(f"not valid TOML: {exc}", file=str(p),
                         line=int(m.group(1)) if m else None) from None
    return scene_from_dict(data, file=str(p), text=text)


def standard_2d_scene() -> Scene:
    """The standard two-cycle XLOT on the 2D model (what ``xlotkit demo`` simulates).

    Shipped with the package (``xlotkit/sim/scenes/standard_2d.toml``; the same file as
    ``examples/scene_2d_standard.toml``): the thesis's 2000 m well (~67 l/MPa), sigma_H
    40 / sigma_h 30 MPa, p0 20 MPa, T0 3 MPa with K_IC 1 MPa m^0.5 at crack tips, a 50 m
    section with a crack strip along sigma_H whose failed clusters close as a smooth joint;
    500 l/min pump-ins of 1.1 and 0.6 m^3, shut-ins and choke flowbacks (300 l/min at
    opening) to 27 MPa and to 2 MPa at surface.
    """
    from importlib.resources import as_file, files

    with as_file(files("xlotkit.sim") / "scenes" / "standard_2d.toml") as path:
        return load_scene(path)


# =========================================================================== docs
def _default_text(section: str, key: str) -> str:
    if section == "":
        return {"title": '""', "model": '"auto"', "coupling": '"monolithic"',
                "seed": "0"}[key]
    if section == "effects" and key == "interface":
        return "none"
    cls = _SECTION_TYPES[section]
    f = {x.name: x for x in dataclasses.fields(cls)}[key]
    v = f.default
    if v is None:
        return "derived" if _spec(section, key).optional else "none"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.6g}"
    return f'"{v}"' if isinstance(v, str) else str(v)


def scene_reference_markdown() -> str:
    """Markdown tables of every scene key: unit, default, allowed values, meaning."""
    out = []
    for sec, keys in SCENE_KEYS.items():
        out.append(f"### {'top level' if not sec else '[' + sec + ']'}\n")
        out.append("| key | unit | default | allowed | meaning |")
        out.append("|---|---|---|---|---|")
        for k, sp in keys.items():
            allowed = "" if sp.kind in ("str", "interfaces") else sp.range_text()
            if sp.optional:
                allowed += " (or absent)"
            out.append(f"| `{k}` | {sp.unit or '-'} | {_default_text(sec, k)} | {allowed} | "
                       f"{sp.doc} |")
        out.append("")
    return "\n".join(out)
