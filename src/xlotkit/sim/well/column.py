r"""The fluid column between surface and the open hole (thesis App. B.6, in closed form).

Pure functions and a frozen dataclass, SI units (Pa, m, s, kg, m^3/s). Pressures are
**gauge**; the fluid density ``density`` is its value at gauge pressure ``p_ref`` (default 0,
i.e. at the surface).

Along the pipe's measured depth ``s`` (down positive; inclination ``cos(theta) = TVD / MD``)
with density ``rho(p) = rho0 exp(c_f (p - p_ref))`` and mass rate ``m = rho0 |Q|``::

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from xlotkit.checks import check_range as _check
from xlotkit.errors import InputError
from xlotkit.units import GRAVITY

__all__ = [
    "GRAVITY",
    "ColumnBlowUp",
    "INCH",
    "RE_LAMINAR",
    "WATER_COMPRESSIBILITY",
    "Column",
    "bottomhole_from_surface",
    "colebrook_factor",
    "density_at",
    "friction_factor",
    "haaland_factor",
    "hydrostatic_bottomhole",
    "surface_from_bottomhole",
]

class ColumnBlowUp(InputError):
    """The fluid column has no finite solution at the pressure and rate asked (its density
    ``exp(c_f (p - p_ref))`` or its friction blows up over the column's length): a well
    that cannot stand, or a pressure no solution will visit (a wild Newton iterate)."""


#: One inch [m].
INCH = 0.0254
#: Compressibility of water/brine used by the thesis's pipe-flow model, 1 / 2.34 GPa [1/Pa].
WATER_COMPRESSIBILITY = 1.0 / 2.34e9
#: Reynolds number below which pipe flow is taken as laminar.
RE_LAMINAR = 2300.0


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
        raise ColumnBlowUp("fluid column has no finite solution (density or friction blows "
                           "up)", key="column", expected="a physically plausible well and rate")


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


