"""The well above the open-hole segment: storage, fluid column, pipe friction and surface choke.

Pure functions and frozen dataclasses, SI units throughout (Pa, m, s, kg, m^3/s). Pressures
are **gauge** (relative to atmosphere) unless a function says otherwise; the fluid density
``density`` is its value at gauge pressure ``p_ref`` (default 0, i.e. at the surface).

Model summary
-------------
Well compliance (thesis App. B.1, SPEC §5)::

    C_w = c_f * V_fluid  [+ C_casing + C_pipe]          [m^3/Pa]
    V_fluid = L_c (pi/4) (D_csg^2 - D_po^2 + D_pi^2) + L_oh pi r_oh^2

with ``L_c`` the cased length (the drill pipe hangs over the cased length, open ended, so
both its bore and the annulus are filled), ``L_oh`` / ``r_oh`` the open-hole segment. Optional
steel terms: thin-walled, unconstrained casing under internal pressure (hoop strain
``dD/D = p D / (2 t E)``, so ``dA/A = p D / (t E)``), and compression of the drill-pipe steel,
which has well pressure on both sides (``dV_s/V_s = 3 (1 - 2 nu) p / E``). Cemented casing
is held by the formation; the casing term is then an upper bound and off by default.

Fluid column (thesis App. B.6, written here in closed form). Along the pipe's measured
depth ``s`` (down positive; inclination ``cos(theta) = TVD / MD``) with density
``rho(p) = rho0 exp(c_f (p - p_ref))`` and mass rate ``m = rho0 |Q|``::

    dp/ds = rho(p) g cos(theta) + sigma F / rho(p),     F = f m^2 / (2 d A^2)

``sigma = -1`` for flow down the pipe (pumping: friction lowers the bottom-hole pressure) and
``+1`` for flow up it (flowback). ``Re = 4 m / (pi d mu)`` does not change along the pipe (the
mass rate does not), so the Darcy factor ``f`` is constant: laminar ``f = 64/Re`` (Re < 2300),
turbulent Haaland ``1/sqrt(f) = -1.8 log10((eps/d/3.7)^1.11 + 6.9/Re)``. With
``u = exp(c_f (p - p_ref))`` the ODE becomes the Riccati equation ``du/ds = a u^2 + b``
(``a = c_f rho0 g cos(theta)``, ``b = sigma c_f F / rho0``), integrated exactly
(:func:`_riccati`); as the equation is autonomous, integrating up (``ds < 0``) is the exact
inverse of integrating down, so :func:`bottomhole_from_surface` and
:func:`surface_from_bottomhole` invert each other to round-off.

Rates ``Q`` are volumes at the reference density ``rho0`` per second (mass rate / rho0): the
pumps and the returns are metered at the surface, and friction is a small correction.

Surface choke (thesis Eq. 4.24 / C.4)::

    Q_return = zeta * sqrt(max(p_choke - p_atm, 0))
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from scipy.optimize import brentq

from xlotkit.errors import InputError
from xlotkit.units import GRAVITY

__all__ = [
    "GRAVITY",
    "INCH",
    "WATER_COMPRESSIBILITY",
    "Column",
    "Completion",
    "bottomhole_from_surface",
    "calibrate_choke",
    "choke_rate",
    "choke_surface_pressure",
    "colebrook_factor",
    "density_at",
    "friction_factor",
    "haaland_factor",
    "hydrostatic_bottomhole",
    "surface_from_bottomhole",
    "well_compliance",
]

#: One inch [m].
INCH = 0.0254
#: Compressibility of water/brine used by the thesis's pipe-flow model, 1 / 2.34 GPa [1/Pa].
WATER_COMPRESSIBILITY = 1.0 / 2.34e9
#: Reynolds number below which pipe flow is taken as laminar.
RE_LAMINAR = 2300.0


# --------------------------------------------------------------------------- validation
def _check(key: str, value: Any, *, lo: float | None = None, hi: float | None = None,
           lo_open: bool = False, hi_open: bool = False, allow_none: bool = False) -> None:
    """Raise :class:`InputError` naming ``key`` unless ``lo <= value <= hi`` (finite number).

    ``lo_open``/``hi_open`` make the bound strict. Shared by the sim config dataclasses.
    """
    if value is None:
        if allow_none:
            return
        raise InputError("is required", key=key, expected=_range_text(lo, hi, lo_open, hi_open))
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"must be a number, got {value!r}", key=key,
                         expected=_range_text(lo, hi, lo_open, hi_open))
    v = float(value)
    bad = not math.isfinite(v)
    if lo is not None and (v < lo or (lo_open and v == lo)):
        bad = True
    if hi is not None and (v > hi or (hi_open and v == hi)):
        bad = True
    if bad:
        raise InputError(f"value {value!r} is out of range", key=key,
                         expected=_range_text(lo, hi, lo_open, hi_open))


def _range_text(lo, hi, lo_open, hi_open) -> str:
    if lo is None and hi is None:
        return "a finite number"
    if hi is None:
        return f"a number {'>' if lo_open else '>='} {lo:g}"
    if lo is None:
        return f"a number {'<' if hi_open else '<='} {hi:g}"
    return (f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}")


# --------------------------------------------------------------------------- completion
@dataclass(frozen=True, kw_only=True)
class Completion:
    """Well completion above and including the open-hole segment (SI).

    Attributes
    ----------
    casing_id : float
        Casing inner diameter [m] (thesis: 12.715" for 13-3/8" casing).
    pipe_od, pipe_id : float
        Drill-pipe outer and inner diameter [m] (thesis: 5" / 4.276"). ``pipe_od = 0`` for a
        well without pipe in the hole.
    length_md : float
        Measured depth of the bottom of the open hole [m].
    depth_tvd : float or None
        True vertical depth of the open-hole segment [m]; None means vertical (= length_md).
    open_hole_length : float
        Length of new formation drilled below the shoe [m] (thesis: 10 m).
    open_hole_radius : float
        Radius of the open hole [m].
    compressibility : float
        Fluid compressibility c_f = 1/K_f [1/Pa].
    expansion : bool
        Add casing expansion and drill-pipe steel compression to the compliance.
    casing_od : float or None
        Casing outer diameter [m], needed when ``expansion`` is on.
    steel_modulus, steel_poisson : float
        Young's modulus [Pa] and Poisson's ratio of the steel.
    roughness : float
        Absolute pipe roughness [m] for the turbulent friction factor.
    """

    casing_id: float = 12.715 * INCH
    pipe_od: float = 5.0 * INCH
    pipe_id: float = 4.276 * INCH
    length_md: float = 2000.0
    depth_tvd: float | None = None
    open_hole_length: float = 10.0
    open_hole_radius: float = 0.15
    compressibility: float = WATER_COMPRESSIBILITY
    expansion: bool = False
    casing_od: float | None = None
    steel_modulus: float = 200e9
    steel_poisson: float = 0.3
    roughness: float = 4.6e-5

    def __post_init__(self) -> None:
        _check("completion.casing_id", self.casing_id, lo=0.0, hi=2.0, lo_open=True)
        _check("completion.pipe_od", self.pipe_od, lo=0.0, hi=self.casing_id, hi_open=True)
        _check("completion.pipe_id", self.pipe_id, lo=0.0, hi=self.pipe_od if self.pipe_od > 0
               else self.casing_id, lo_open=True, hi_open=self.pipe_od > 0)
        _check("completion.length_md", self.length_md, lo=0.0, hi=20000.0, lo_open=True)
        _check("completion.depth_tvd", self.depth_tvd, lo=0.0, hi=self.length_md,
               allow_none=True)
        _check("completion.open_hole_length", self.open_hole_length, lo=0.0,
               hi=self.length_md, hi_open=True)
        _check("completion.open_hole_radius", self.open_hole_radius, lo=0.0, hi=2.0,
               lo_open=True)
        _check("completion.compressibility", self.compressibility, lo=0.0, hi=1e-6)
        _check("completion.steel_modulus", self.steel_modulus, lo=1e9, hi=1e12)
        _check("completion.steel_poisson", self.steel_poisson, lo=0.0, hi=0.5, hi_open=True)
        _check("completion.roughness", self.roughness, lo=0.0, hi=0.01)
        if self.expansion:
            _check("completion.casing_od", self.casing_od, lo=self.casing_id, hi=3.0,
                   lo_open=True)

    @property
    def tvd(self) -> float:
        """True vertical depth of the open-hole segment [m]."""
        return self.length_md if self.depth_tvd is None else float(self.depth_tvd)

    @property
    def cased_length(self) -> float:
        """Measured length from surface to the casing shoe [m]."""
        return self.length_md - self.open_hole_length

    def fluid_volume(self) -> float:
        """Fluid volume in the well: pipe bore, annulus and open hole [m^3]."""
        a_csg = math.pi / 4.0 * self.casing_id**2
        a_steel = math.pi / 4.0 * (self.pipe_od**2 - self.pipe_id**2) if self.pipe_od > 0 else 0.0
        return (a_csg - a_steel) * self.cased_length + (
            math.pi * self.open_hole_radius**2 * self.open_hole_length)

    def column(self, *, density: float, viscosity: float = 0.01,
               compressibility: float | None = None) -> Column:
        """The fluid column from surface to the open hole, through the drill pipe.

        It spans the whole measured depth and TVD, so its bottom pressure is at the open
        hole; friction is charged at the pipe bore over the whole length (the few metres of
        open hole below the pipe shoe change it by well under 1 %).
        """
        return Column(
            length_md=self.length_md, tvd=self.tvd,
            pipe_id=self.pipe_id, roughness=self.roughness, density=density,
            compressibility=self.compressibility if compressibility is None else compressibility,
            viscosity=viscosity)


def well_compliance(completion: Completion) -> float:
    """Storage compliance of the well, dV/dp at constant fluid mass [m^3/Pa].

    ``C_w = c_f V_fluid`` plus, when ``completion.expansion`` is on, the thin-wall casing term
    ``A_csg L_c D_csg / (t E)`` (``t = (OD - ID)/2``) and the pipe-steel compression term
    ``V_steel 3 (1 - 2 nu) / E``.

    Parameters
    ----------
    completion : Completion

    Returns
    -------
    float
        Compliance [m^3/Pa] (multiply by 1e9 for l/MPa).
    """
    c = completion.compressibility * completion.fluid_volume()
    if completion.expansion:
        assert completion.casing_od is not None
        e_s = completion.steel_modulus
        t_wall = 0.5 * (completion.casing_od - completion.casing_id)
        a_csg = math.pi / 4.0 * completion.casing_id**2
        c += a_csg * completion.cased_length * completion.casing_id / (t_wall * e_s)
        if completion.pipe_od > 0:
            v_steel = math.pi / 4.0 * (completion.pipe_od**2 - completion.pipe_id**2) * (
                completion.cased_length)
            c += v_steel * 3.0 * (1.0 - 2.0 * completion.steel_poisson) / e_s
    return c


# --------------------------------------------------------------------------- fluid column
@dataclass(frozen=True, kw_only=True)
class Column:
    """The fluid column in the flow path between surface and the open hole (SI).

    Attributes
    ----------
    length_md : float
        Flow-path length (drill pipe) [m].
    tvd : float
        Vertical depth spanned by that length [m] (``0 <= tvd <= length_md``).
    pipe_id : float
        Flow-path inner diameter [m].
    density : float
        Fluid density at ``p_ref`` [kg/m^3].
    compressibility : float
        c_f [1/Pa]; 0 for an incompressible column.
    viscosity : float
        Dynamic viscosity [Pa s] (Newtonian).
    roughness : float
        Absolute roughness [m].
    p_ref : float
        Gauge pressure at which ``density`` holds [Pa].
    friction : bool
        Include pipe friction; False gives the static column at any rate.
    g : float
        Gravity [m/s^2].
    """

    length_md: float
    tvd: float
    pipe_id: float = 4.276 * INCH
    density: float = 1000.0
    compressibility: float = WATER_COMPRESSIBILITY
    viscosity: float = 0.01
    roughness: float = 4.6e-5
    p_ref: float = 0.0
    friction: bool = True
    g: float = GRAVITY

    def __post_init__(self) -> None:
        _check("column.length_md", self.length_md, lo=0.0, hi=20000.0)
        _check("column.tvd", self.tvd, lo=0.0, hi=max(self.length_md, 0.0))
        _check("column.pipe_id", self.pipe_id, lo=0.0, hi=2.0, lo_open=True)
        _check("column.density", self.density, lo=100.0, hi=5000.0)
        _check("column.compressibility", self.compressibility, lo=0.0, hi=1e-6)
        _check("column.viscosity", self.viscosity, lo=0.0, hi=100.0, lo_open=True)
        _check("column.roughness", self.roughness, lo=0.0, hi=0.01)

    @property
    def area(self) -> float:
        """Flow area [m^2]."""
        return math.pi / 4.0 * self.pipe_id**2

    @property
    def cos_incl(self) -> float:
        """TVD / MD of the flow path."""
        return self.tvd / self.length_md if self.length_md > 0 else 1.0

    def reynolds(self, rate: float) -> float:
        """Reynolds number for volume rate ``rate`` [m^3/s] (sign ignored)."""
        m = self.density * abs(rate)
        return 4.0 * m / (math.pi * self.pipe_id * self.viscosity)

    def friction_gradient_coefficient(self, rate: float) -> float:
        """``F = f m^2 / (2 d A^2)`` [Pa kg/m^4] so that the friction gradient is F / rho."""
        if not self.friction or rate == 0.0:
            return 0.0
        f = friction_factor(self.reynolds(rate), self.roughness / self.pipe_id)
        m = self.density * abs(rate)
        return f * m * m / (2.0 * self.pipe_id * self.area**2)


def haaland_factor(re: float, rel_roughness: float = 0.0) -> float:
    """Darcy friction factor from Haaland's explicit formula (turbulent flow).

    ``1/sqrt(f) = -1.8 log10((eps/d / 3.7)^1.11 + 6.9 / Re)``; within about 1.5 % of
    Colebrook–White for 4e3 < Re < 1e8.
    """
    x = -1.8 * math.log10((rel_roughness / 3.7) ** 1.11 + 6.9 / re)
    return 1.0 / (x * x)


def colebrook_factor(re: float, rel_roughness: float = 0.0) -> float:
    """Darcy friction factor from the implicit Colebrook–White equation (reference only).

    ``1/sqrt(f) = -2 log10(eps/d / 3.7 + 2.51 / (Re sqrt(f)))``, solved by fixed-point
    iteration on ``x = 1/sqrt(f)`` (a contraction for turbulent Re).
    """
    x = 1.0 / math.sqrt(haaland_factor(re, rel_roughness))
    for _ in range(100):
        x_new = -2.0 * math.log10(rel_roughness / 3.7 + 2.51 * x / re)
        if abs(x_new - x) < 1e-15 * abs(x):
            x = x_new
            break
        x = x_new
    return 1.0 / (x * x)


def friction_factor(re: float, rel_roughness: float = 0.0) -> float:
    """Darcy friction factor: ``64/Re`` for ``Re < 2300``, Haaland above; 0 at Re = 0."""
    if re <= 0.0:
        return 0.0
    if re < RE_LAMINAR:
        return 64.0 / re
    return haaland_factor(re, rel_roughness)


def density_at(p: float, column: Column) -> float:
    """Fluid density ``rho0 exp(c_f (p - p_ref))`` [kg/m^3] at gauge pressure ``p`` [Pa]."""
    return column.density * math.exp(column.compressibility * (p - column.p_ref))


def _riccati(q0: float, a: float, b: float, ell: float) -> float:
    """Exact solution of ``du/ds = a u^2 + b`` over ``ell``, in terms of ``q = u - 1``.

    Written with addition theorems so that small ``b`` (weak friction) loses no precision:
    ``b > 0``: ``u = (u0 + r t)/(1 - (u0/r) t)``, ``t = tan(a r ell)``, ``r = sqrt(b/a)``;
    ``b < 0``: ``u = (u0 - r T)/(1 - (u0/r) T)``, ``T = tanh(a r ell)``, ``r = sqrt(-b/a)``;
    ``b = 0``: ``u = u0 / (1 - a u0 ell)``. ``a = 0`` (horizontal): ``u = u0 + b ell``.
    """
    u0 = 1.0 + q0
    if a == 0.0:
        return q0 + b * ell
    if b == 0.0:
        d = 1.0 - a * u0 * ell
        _guard(d)
        return (q0 + a * u0 * ell) / d
    r = math.sqrt(abs(b) / a)
    if b > 0.0:
        t = math.tan(a * r * ell)
        d = 1.0 - (u0 / r) * t
        _guard(d)
        return (q0 + r * t + (u0 / r) * t) / d
    tt = math.tanh(a * r * ell)
    d = 1.0 - (u0 / r) * tt
    _guard(d)
    return (q0 - r * tt + (u0 / r) * tt) / d


def _guard(d: float) -> None:
    if not d > 0.0:
        raise InputError("fluid column has no finite solution (density or friction blows up)",
                         key="column", expected="a physically plausible well and rate")


def _integrate_column(p_start: float, rate: float, column: Column, ell: float) -> float:
    """Pressure after integrating the column ODE over signed length ``ell`` from ``p_start``."""
    c = column.compressibility
    rho0 = column.density
    sigma = -1.0 if rate > 0 else 1.0
    big_f = column.friction_gradient_coefficient(rate)
    hydro = rho0 * column.g * column.cos_incl
    if c == 0.0:
        return p_start + (hydro + sigma * big_f / rho0) * ell
    a = c * hydro
    b = sigma * c * big_f / rho0
    q0 = math.expm1(c * (p_start - column.p_ref))
    q = _riccati(q0, a, b, ell)
    if not q > -1.0:
        _guard(-1.0)
    return column.p_ref + math.log1p(q) / c


def bottomhole_from_surface(p_surface: float, rate: float, column: Column) -> float:
    """Bottom-hole gauge pressure [Pa] from the surface (standpipe/choke) pressure.

    Parameters
    ----------
    p_surface : float
        Gauge pressure at the top of the flow path [Pa].
    rate : float
        Volume rate at reference density [m^3/s]: > 0 pumping down, < 0 flowing back up,
        0 static.
    column : Column

    Returns
    -------
    float
        Gauge pressure at the bottom of the flow path [Pa].
    """
    return _integrate_column(float(p_surface), float(rate), column, column.length_md)


def surface_from_bottomhole(p_bottomhole: float, rate: float, column: Column) -> float:
    """Surface gauge pressure [Pa] from the bottom-hole pressure; inverse of
    :func:`bottomhole_from_surface` (same sign convention for ``rate``)."""
    return _integrate_column(float(p_bottomhole), float(rate), column, -column.length_md)


def hydrostatic_bottomhole(column: Column, p_surface: float = 0.0) -> float:
    """Static bottom-hole pressure under surface pressure ``p_surface`` [Pa]."""
    return bottomhole_from_surface(p_surface, 0.0, column)


# --------------------------------------------------------------------------- choke
def choke_rate(p_choke: float, zeta: float, p_atm: float = 0.0) -> float:
    """Flow through a fixed choke, ``Q = zeta sqrt(max(p_choke - p_atm, 0))`` [m^3/s].

    Parameters
    ----------
    p_choke : float
        Pressure upstream of the choke [Pa].
    zeta : float
        Choke coefficient [m^3 s^-1 Pa^-1/2].
    p_atm : float
        Downstream pressure on the same scale as ``p_choke``: 0 for gauge pressures (the
        xlotkit convention), :data:`xlotkit.record.ATMOSPHERE_PA` for absolute ones.
    """
    return zeta * math.sqrt(max(p_choke - p_atm, 0.0))


def calibrate_choke(q0: float, p0: float, p_atm: float = 0.0) -> float:
    """Choke coefficient ``zeta = q0 / sqrt(p0 - p_atm)`` from one rate/pressure pair.

    Raises
    ------
    InputError
        If ``p0 <= p_atm`` or ``q0 < 0``.
    """
    _check("initial_rate", q0, lo=0.0)
    if not p0 > p_atm:
        raise InputError(f"cannot calibrate a choke at surface pressure {p0:g} Pa "
                         f"(<= downstream {p_atm:g} Pa)", key="initial_rate",
                         expected="flowback started with positive surface pressure")
    return q0 / math.sqrt(p0 - p_atm)


def choke_surface_pressure(p_bottomhole: float, zeta: float, column: Column,
                           p_atm: float = 0.0) -> tuple[float, float]:
    """Surface pressure and rate of a well flowing back through a fixed choke.

    Solves ``p_bh = bottomhole_from_surface(p_s, -zeta sqrt(p_s - p_atm))`` for ``p_s`` (the
    right side increases with ``p_s``). Without friction this is explicit.

    Returns
    -------
    (p_surface, rate) : tuple of float
        Gauge surface pressure [Pa] and the (positive) return rate [m^3/s].
    """
    p_static = surface_from_bottomhole(p_bottomhole, 0.0, column)
    if p_static <= p_atm or zeta == 0.0:
        return p_static, 0.0
    if not column.friction:
        return p_static, choke_rate(p_static, zeta, p_atm)

    def resid(ps: float) -> float:
        return bottomhole_from_surface(ps, -choke_rate(ps, zeta, p_atm), column) - p_bottomhole

    # Upward flow adds friction to the column, so p_s <= p_static; p_atm gives resid < 0.
    if resid(p_atm) >= 0.0:
        return p_atm, 0.0
    ps = brentq(resid, p_atm, p_static, xtol=1e-9, rtol=1e-15, maxiter=200)
    return ps, choke_rate(ps, zeta, p_atm)

