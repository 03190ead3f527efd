"""The keys of a scene file: dimension, unit, range and meaning of each (:data:`SCENE_KEYS`),
and their conversion to SI with range checks."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from datetime import datetime
from typing import Any, Literal

from xlotkit.errors import InputError
from xlotkit.sim.scene.quantities import angle as _angle
from xlotkit.sim.scene.quantities import permeability as _permeability
from xlotkit.sim.scene.quantities import quantity as _quantity

__all__ = ["PARTITIONED_COUPLINGS", "SCENE_KEYS", "Coupling", "KeySpec", "Model"]

Model = Literal["auto", "lumped", "mdem"]
Coupling = Literal["monolithic", "wfd", "wfc", "wfdmod"]
#: Couplings of the well to the 2D segment that are partitioned (thesis 4.5).
PARTITIONED_COUPLINGS = ("wfd", "wfc", "wfdmod")


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
    zero_ok : bool
        Exactly 0 is allowed besides the range (a strength of 0: a rock without one; a
        nonzero value below ``lo`` is a unit mistake, e.g. ``"3 mPa"``).
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
    zero_ok: bool = False

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
        if self.zero_ok:
            what = "0 or " + what
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
        if self.zero_ok and v == 0.0:
            return True
        if self.lo is not None and (v < self.lo or (self.lo_open and v == self.lo)):
            return False
        if self.hi is not None and (v > self.hi or (self.hi_open and v == self.hi)):
            return False
        return True


def _k(kind: str, unit: str = "", lo=None, hi=None, *, lo_open=False, hi_open=False,
       optional=False, choices=(), doc="", zero_ok=False) -> KeySpec:
    return KeySpec(kind, unit, lo, hi, lo_open, hi_open, optional, tuple(choices), doc,
                   zero_ok)


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
        "hole_radius": _k(_L, "m", 0.02, 0.6,
                         doc="open-hole (borehole) radius (a 1.6 in to 47 in hole; at most "
                             "domain_size / 20)"),
        "segment_height": _k(_L, "m", 0.1, 1000.0,
                             doc="height of the open-hole segment (2D plane-strain "
                                 "thickness; KGD fracture height of the lumped model)"),
    },
    "mesh": {
        "growth": _k("dimensionless", "", 1.0, 2.0, lo_open=True,
                     doc="element size growth rate away from the hole"),
        "wall_element_size": _k(_L, "m", 0.0, 1.0, lo_open=True, optional=True,
                                doc="edge length on the hole wall (default 2 pi r / 64; "
                                    "at most hole_radius, at least 2 pi r / 2048)"),
        "max_element_size": _k(_L, "m", 0.0, 1e3, lo_open=True, optional=True,
                               doc="largest edge length (default domain_size / 10; at least "
                                   "the wall's, at most domain_size / 2)"),
        "fracture_band": _k("bool", doc="refine a band along sigma_H (expected fracture)"),
        "band_width": _k(_L, "m", 0.0, 100.0, lo_open=True,
                         doc="full width of the band (at least band_element_size, at most "
                             "domain_size / 2)"),
        "band_element_size": _k(_L, "m", 0.0, 1.0, lo_open=True, optional=True,
                                doc="edge length in the band (default wall_element_size; "
                                    "at most max_element_size)"),
        "band_length": _k(_L, "m", 0.0, 1e4, lo_open=True, optional=True,
                          doc="half-length of the band from the hole centre (beyond the "
                              "hole, within the domain: at most domain_size / 2; default "
                              "10 m or domain_size / 2 if less)"),
        "band_strip": _k("bool", doc="lay a crack strip along the band axis: two staggered "
                                     "node rows, every strip triangle straddling the axis "
                                     "(only they are band clusters)"),
        "band_centred_wall": _k("bool", doc="place the hole wall's nodes so that the band "
                                            "axis meets the wall in the middle of an edge "
                                            "(always so with band_strip)"),
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
        "tensile_strength": _k(_P, "Pa", 1e3, 100e6, zero_ok=True,
                               doc="tensile strength T0 (0, or 1 kPa to 100 MPa: a strength "
                                   "below 1 kPa is a unit mistake)"),
        "cohesion": _k(_P, "Pa", 1e3, 500e6, zero_ok=True,
                       doc="Mohr-Coulomb cohesion S0 (0, or 1 kPa to 500 MPa)"),
        "friction_angle": _k("angle", "deg", 0.0, 70.0,
                             doc="internal friction angle phi (rocks: 15 to 60 deg)"),
        "heterogeneity": _k("dimensionless", "", 0.0, 1.0, hi_open=True,
                            doc="half-width of the uniform strength perturbation (used when "
                                "effects.heterogeneity)"),
        "strength_scaling_exponent": _k("dimensionless", "", 0.0, 1.0, lo_open=True,
                                        doc="exponent m of (A_ref / A)^m (used when "
                                            "effects.strength_scaling)"),
        "strength_scaling_reference_area": _k("m**2", "m^2", 0.0, 1e4, lo_open=True,
                                              doc="reference cluster area A_ref"),
        "toughness": _k("Pa*m**0.5", "Pa m^0.5", 1e4, 100e6, optional=True,
                        doc="fracture toughness K_IC of crack-tip clusters (used when "
                            "effects.strength_scaling; sets A_ref from T0, needs the "
                            "exponent 0.25)"),
        "wall_criterion": _k("choice", choices=("critical_distance", "cluster"),
                             doc="tensile and shear initiation at the hole wall (used when "
                                 "effects.strength_scaling): critical_distance = the stress "
                                 "at L/2 from the wall, L = (K_IC/T0)^2/pi with the crack "
                                 "tips' toughness (one material length, independent of the "
                                 "wall's mesh); cluster = the wall clusters' average stress"),
        "fracture_friction_angle": _k("angle", "deg", 0.0, 70.0,
                                      doc="friction angle of the faces of tensile cracks "
                                          "on a crack plane (crack_plane = 'stress'; "
                                          "shear cracks slide with friction_angle), and "
                                          "of the fracture band's (effects.fracture_plane)"),
        "crack_plane": _k("choice", choices=("stress", "edges"),
                          doc="the crack inside a failed cluster: 'stress' = its own plane, "
                              "set when it fails (normal to sigma'_min in tension, the "
                              "Mohr-Coulomb plane in shear), a smooth joint; 'edges' = "
                              "the triangle's sub-edge contacts with the rock's friction "
                              "(the former free path)"),
        "closure_law": _k("choice", choices=("smooth", "barton_bandis", "exponential"),
                          doc="normal law of a closed crack: 'smooth' = the contact's "
                              "linear stiffness and a constant residual aperture; "
                              "'barton_bandis' / 'exponential' = closure against effective "
                              "normal stress, the aperture falling to sealed_aperture"),
        "joint_normal_stiffness": _k("Pa/m", "Pa/m", 0.0, 1e18, lo_open=True, optional=True,
                                     doc="initial normal stiffness K_ni of the "
                                         "barton_bandis closure law (needed by it only)"),
        "joint_max_closure": _k(_L, "m", 0.0, 0.1, lo_open=True, optional=True,
                                doc="maximum closure V_m of the barton_bandis and "
                                    "exponential closure laws (needed by them only)"),
        "joint_reference_stress": _k(_P, "Pa", 0.0, 500e6, lo_open=True, optional=True,
                                     doc="reference stress sigma_r of the exponential "
                                         "closure law, delta = V_m (1 - exp(-sigma'_n / "
                                         "sigma_r)) (needed by it only)"),
        "sealed_aperture": _k(_L, "m", 0.0, 0.01, optional=True,
                              doc="hydraulic aperture of a crack closed to V_m (closure "
                                  "laws only; default 1e-5 m, the smooth law's residual "
                                  "aperture)"),
        "dilation_angle": _k("angle", "deg", 0.0, 45.0, lo_open=True, optional=True,
                             doc="shear-dilation angle psi of failed clusters' cracks: the "
                                 "hydraulic aperture gains tan(psi) |u_s| (needs, and is "
                                 "needed by, effects.shear_dilation)"),
        "seed": _k("int", "", 0, 2**63 - 1, optional=True,
                   doc="seed of the heterogeneity draw (default: the master seed)"),
    },
    "stresses": {
        "sigma_H": _k(_P, "Pa", 1e5, 500e6,
                      doc="maximum horizontal total stress (>= sigma_h)"),
        "sigma_h": _k(_P, "Pa", 1e5, 500e6,
                      doc="minimum horizontal total stress"),
        "sigma_H_azimuth": _k("angle", "deg", 0.0, 180.0, hi_open=True,
                              doc="direction of sigma_H, counter-clockwise from the 2D x axis"),
        "pore_pressure": _k(_P, "Pa", 0.0, 500e6, doc="initial pore pressure p0 (< sigma_h)"),
    },
    "fluid": {
        "density": _k("density", "kg/m^3", 500.0, 3000.0,
                      doc="density rho0 at surface (well fluids: 0.5 to 3 sg)"),
        "compressibility": _k("1/Pa", "1/Pa", 0.0, 1e-7,
                              doc="compressibility c_f (water 4.3e-10; at most 100 times)"),
        "viscosity": _k("Pa*s", "Pa s", 1e-5, 10.0,
                        doc="viscosity mu (0.01 cP, a gas, to 10 000 cP)"),
    },
    "completion": {
        "depth": _k(_L, "m", 1.0, 20000.0,
                    doc="measured depth of the bottom of the open hole"),
        "tvd": _k(_L, "m", 0.0, 20000.0, optional=True,
                  doc="true vertical depth of the open hole (default: depth, vertical)"),
        "casing_id": _k(_L, "m", 0.03, 1.0, doc="casing inner diameter"),
        "casing_od": _k(_L, "m", 0.03, 1.2, optional=True,
                        doc="casing outer diameter (needed with expansion)"),
        "pipe_od": _k(_L, "m", 0.01, 1.0, zero_ok=True,
                      doc="drill-pipe outer diameter (0: no pipe)"),
        "pipe_id": _k(_L, "m", 0.005, 1.0, doc="drill-pipe inner diameter"),
        "open_hole_length": _k(_L, "m", 0.0, 20000.0,
                               doc="length of new formation below the shoe"),
        "expansion": _k("bool", doc="add casing expansion and pipe-steel compression to "
                                    "the well compliance"),
        "steel_modulus": _k(_P, "Pa", 50e9, 300e9,
                            doc="Young's modulus of the steel (aluminium to tungsten "
                                "alloys: 50 to 300 GPa)"),
        "steel_poisson": _k("dimensionless", "", 0.0, 0.5, hi_open=True,
                            doc="Poisson's ratio of the steel"),
        "roughness": _k(_L, "m", 0.0, 0.01, doc="absolute pipe roughness"),
        "well_compliance": _k("m**3/Pa", "m^3/Pa", 1e-13, 1e-5, optional=True,
                              doc="override of the well compliance C_w (default from the "
                                  "completion and c_f); at least the open hole's own "
                                  "c_f pi r^2 h (needs effects.well_storage)"),
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
        "max_newton": _k("int", "", 1, 1000, doc="Newton iterations per step"),
        "checkpoint_steps": _k("int", "", 1, 10**9, doc="checkpoint every this many steps"),
        "checkpoint_seconds": _k(_T, "s", 1.0, 86400.0,
                                 doc="and at least every this much wall-clock time (also at "
                                     "the start and at every phase end)"),
        "max_phase_duration": _k(_T, "s", 1.0, 30 * 86400.0,
                                 doc="safety limit of a phase whose end is never met"),
        "dp_max": _k(_P, "Pa", 1e3, 10e6,
                     doc="largest pressure change per step (the 2D model: on a step "
                         "without failures)"),
    },
    "effects": {
        "well_storage": _k("bool", doc="the whole well's fluid volume stores fluid (false: "
                                       "only the open-hole segment)"),
        "pipe_friction": _k("bool", doc="pipe friction between surface and bottom hole"),
        "poroelastic": _k("bool", doc="poroelastic coupling of matrix flow and rock (2D)"),
        "heterogeneity": _k("bool", doc="seeded strength heterogeneity (2D)"),
        "strength_scaling": _k("bool", doc="triangle-size strength scaling (2D)"),
        "shear_dilation": _k("bool", doc="shear dilation of fracture apertures by "
                                              "rock.dilation_angle (2D)"),
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
        "noise": _k(_P, "Pa", 0.0, 1e6,
                    doc="standard deviation of Gaussian gauge noise (at most 10 bar)"),
        "resolution": _k(_P, "Pa", 0.0, 1e6, doc="gauge resolution (0: none; at most 10 bar)"),
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
        "toughness": _k("Pa*m**0.5", "Pa m^0.5", 1e4, 100e6,
                        doc="apparent fracture toughness K_Ic"),
        "initial_flaw": _k(_L, "m", 0.0, 10.0, lo_open=True, optional=True,
                           doc="flaw size at breakdown (default: geometry.hole_radius)"),
        "reopening": _k("choice", choices=("wellbore", "sigma_h"),
                        doc="where a closed fracture reopens"),
        "nwb_coefficient": _k("Pa*s**2/m**6", "Pa s^2/m^6", 0.0, 1e12,
                              doc="near-wellbore entry loss k (p = p_f + k Q_f^2)"),
        "leakoff_coefficient": _k("m/s**0.5", "m/s^0.5", 0.0, 1e-3, optional=True,
                                  doc="Carter C_L (default: from rock and fluid, see docs)"),
        "wall_leak_index": _k("m**3/s/Pa", "m^3/(s Pa)", 0.0, 1e-8, optional=True,
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



def _spec(section: str, key: str) -> KeySpec:
    return SCENE_KEYS[section][key]


def _dotted(section: str, key: str) -> str:
    return f"{section}.{key}" if section else key


def _range_error(section: str, key: str, raw: Any, si: float | None = None) -> InputError:
    sp = _spec(section, key)
    shown = repr(raw)
    if si is not None and isinstance(raw, str):
        shown += f" (= {si:g} {sp.unit})".replace("  ", " ")
    elif sp.unit and sp.kind not in ("int", "angle") and not isinstance(raw, str):
        # a number without a unit is SI: say so, a unit left out is the likely mistake
        shown += f" (a number without a unit is SI: {sp.unit})"
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
    try:
        if kind == "angle":
            v = _angle(raw, dk)
        elif kind == "permeability":
            v = _permeability(raw, dk)
        else:
            v = _quantity(raw, kind, dk)
    except InputError as exc:
        # the value as given and what the key allows, besides what the unit parser said
        raise InputError(f"{exc.message} (given {raw!r})", key=dk,
                         expected=f"{exc.expected}; allowed: {sp.range_text()}"
                         if exc.expected else sp.range_text()) from None
    if not sp.in_range(v):
        raise _range_error(section, key, raw, v)
    return v


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


