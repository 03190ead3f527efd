"""Fluid, rock, well and boundary descriptions of the flow model, and their small kernels.

All SI: Pa, m, s, kg, m^3/s. Pressures are those of the simulator (absolute or gauge, as the
caller chooses, consistently); only differences and the reference pressures enter.

Constitutive kernels
--------------------
Brine (slightly compressible, constant viscosity ``mu``)::

    rho(p) = rho0 exp(c_f (p - p_ref))                                   [kg/m^3]

Pore compressibility ``c_r`` (linear, the usual reservoir-simulator form)::

    phi(p) = phi_ref (1 + c_r (p - p_ref_rock))                           [-]

Well storage: the well holds the fluid mass ``M_w(p_w)`` with ``dM_w/dp_w = rho(p_w) C_w``
(``C_w`` the compliance [m^3/Pa]); integrated exactly::

    M_w(p) - M_w(p_old) = C_w rho(p_old) expm1(c_f (p - p_old)) / c_f

which for a rigid well volume ``V_w`` with ``C_w = V_w c_f`` is exactly
``V_w (rho(p) - rho(p_old))``. Differences of stored mass are always evaluated in this
``expm1`` form: forming ``rho(p) phi(p) V`` and subtracting would lose up to eight digits
(stored mass ~1e6 kg, change per step ~1e-3 kg) and spoil the mass-balance check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from xlotkit.errors import InputError

__all__ = [
    "FluidProperties",
    "OuterBoundary",
    "RockFlowProperties",
    "WellCondition",
    "density",
    "expm1_over_x",
]

RateFunction = Callable[[float], float]


def _num(key: str, v, lo=None, hi=None, lo_open=False, allow_none=False):
    if v is None and allow_none:
        return None
    if isinstance(v, bool):
        raise InputError(f"must be a number, got {v!r}", key=key)
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"must be a number, got {v!r}", key=key) from None
    if not math.isfinite(x):
        raise InputError(f"must be finite, got {v!r}", key=key)
    if (lo is not None and (x < lo or (lo_open and x == lo))) or (hi is not None and x > hi):
        lb = "(" if lo_open else "["
        raise InputError(f"value {x!r} out of range", key=key,
                         expected=f"{lb}{'-inf' if lo is None else lo}, "
                                  f"{'inf' if hi is None else hi}]")
    return x


def expm1_over_x(x):
    """``expm1(x) / x`` with the limit 1 at ``x = 0`` (vectorised, accurate near 0)."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 1e-8
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 + 0.5 * x, np.expm1(safe) / safe)


def density(p, fluid: "FluidProperties"):
    """Brine density ``rho(p) = rho0 exp(c_f (p - p_ref))`` [kg/m^3]."""
    return fluid.density * np.exp(fluid.compressibility
                                  * (np.asarray(p, dtype=float) - fluid.reference_pressure))


@dataclass(frozen=True)
class FluidProperties:
    """Single-phase slightly compressible brine.

    Attributes
    ----------
    density : float
        ``rho0`` at ``reference_pressure`` [kg/m^3]. Injection rates are volumes at this
        density (pumps are metered at surface conditions).
    compressibility : float
        ``c_f`` [1/Pa], ``>= 0``; water ~4.3e-10.
    viscosity : float
        ``mu`` [Pa s].
    reference_pressure : float
        ``p_ref`` [Pa].
    """

    density: float = 1000.0
    compressibility: float = 4.5e-10
    viscosity: float = 1.0e-3
    reference_pressure: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "density", _num("fluid.density", self.density, 1.0, 1e5,
                                                 lo_open=True))
        object.__setattr__(self, "compressibility",
                           _num("fluid.compressibility", self.compressibility, 0.0, 1e-5))
        object.__setattr__(self, "viscosity",
                           _num("fluid.viscosity", self.viscosity, 0.0, 1e3, lo_open=True))
        object.__setattr__(self, "reference_pressure",
                           _num("fluid.reference_pressure", self.reference_pressure))

    def rho(self, p):
        """Density at pressure ``p`` [kg/m^3]."""
        return density(p, self)


def _cell_array(key: str, v, n: int | None, lo=None, hi=None, lo_open=False) -> np.ndarray:
    a = np.array(v, dtype=float, copy=True)
    if a.ndim > 1:
        raise InputError("must be a number or a 1D per-cell array", key=key)
    if n is not None and a.ndim == 1 and len(a) != n:
        raise InputError(f"has {len(a)} values, the mesh has {n} cells", key=key)
    if not np.all(np.isfinite(a)):
        raise InputError("must be finite", key=key)
    if lo is not None and (np.any(a < lo) or (lo_open and np.any(a == lo))):
        raise InputError("value out of range", key=key,
                         expected=f"{'>' if lo_open else '>='} {lo}")
    if hi is not None and np.any(a > hi):
        raise InputError("value out of range", key=key, expected=f"<= {hi}")
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class RockFlowProperties:
    """Per-cell flow properties of the rock (isotropic).

    Attributes
    ----------
    permeability : float or ndarray, shape (m,)
        Matrix permeability ``k`` [m^2], ``>= 0`` (0 makes a cell impermeable).
    porosity : float or ndarray, shape (m,)
        ``phi_ref`` in ``(0, 1]`` at ``reference_pressure`` (strictly positive so every cell
        has storage and the Jacobian is regular).
    pore_compressibility : float
        ``c_r = (1/phi) dphi/dp`` [1/Pa], ``>= 0``.
    reference_pressure : float
        Pressure at which ``porosity`` holds [Pa].

    Notes
    -----
    Scalars are broadcast to all cells by :meth:`for_cells`.
    """

    permeability: float | np.ndarray
    porosity: float | np.ndarray
    pore_compressibility: float = 0.0
    reference_pressure: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "permeability",
                           _cell_array("rock.permeability", self.permeability, None, 0.0, 1e-6))
        object.__setattr__(self, "porosity",
                           _cell_array("rock.porosity", self.porosity, None, 0.0, 1.0,
                                       lo_open=True))
        object.__setattr__(self, "pore_compressibility",
                           _num("rock.pore_compressibility", self.pore_compressibility, 0.0,
                                1e-5))
        object.__setattr__(self, "reference_pressure",
                           _num("rock.reference_pressure", self.reference_pressure))

    def for_cells(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Permeability and porosity as arrays of shape (n,) (validated against ``n``)."""
        k = _cell_array("rock.permeability", np.broadcast_to(self.permeability, (n,))
                        if np.ndim(self.permeability) == 0 else self.permeability, n)
        phi = _cell_array("rock.porosity", np.broadcast_to(self.porosity, (n,))
                          if np.ndim(self.porosity) == 0 else self.porosity, n)
        return k, phi


@dataclass(frozen=True)
class WellCondition:
    """The borehole: one pressure unknown ``p_w`` with storage, driven by rate or pressure.

    Attributes
    ----------
    storage : float, optional
        Well compliance ``C_w`` [m^3/Pa], ``>= 0``. Default: the open-hole segment's own
        fluid volume times ``c_f`` (``pi r_w^2 h c_f``); pass the whole well's compliance
        (:func:`xlotkit.sim.well.well_compliance`, scaled to the segment) for a real test.
    rate : float or callable, optional
        Injection rate ``Q(t)`` [m^3/s at the reference density], positive *into* the well.
        A callable is evaluated at the middle of each step (so a piecewise-constant schedule
        whose breaks are step ends is integrated exactly). Ignored when ``pressure`` is set.
    pressure : float or callable, optional
        Prescribed well pressure ``p_w(t)`` [Pa] (evaluated at the end of each step, i.e.
        implicitly). The injection rate is then an output.
    """

    storage: float | None = None
    rate: float | RateFunction = 0.0
    pressure: float | RateFunction | None = None

    def __post_init__(self) -> None:
        if self.storage is not None:
            object.__setattr__(self, "storage", _num("well.storage", self.storage, 0.0))
        if not callable(self.rate):
            object.__setattr__(self, "rate", _num("well.rate", self.rate))
        if self.pressure is not None and not callable(self.pressure):
            object.__setattr__(self, "pressure", _num("well.pressure", self.pressure))

    @property
    def pressure_controlled(self) -> bool:
        """True if ``p_w`` is prescribed."""
        return self.pressure is not None

    def rate_at(self, t: float) -> float:
        """``Q(t)`` [m^3/s]."""
        q = self.rate(t) if callable(self.rate) else self.rate
        return _num("well.rate", q)

    def pressure_at(self, t: float) -> float:
        """Prescribed ``p_w(t)`` [Pa]."""
        if self.pressure is None:
            raise InputError("the well is rate controlled", key="well.pressure")
        p = self.pressure(t) if callable(self.pressure) else self.pressure
        return _num("well.pressure", p)


@dataclass(frozen=True)
class OuterBoundary:
    """Outer-boundary condition of the flow model.

    Attributes
    ----------
    fixed : mapping tag -> pressure
        Boundary tags (:data:`xlotkit.sim.mesh.LEFT`, ``RIGHT``, ``BOTTOM``, ``TOP``,
        ``OUTER``) held at a fixed pressure [Pa]. Edges with other tags are no-flow. The hole
        wall (tag ``HOLE``) is never in this map: it is connected to the well.

    Examples
    --------
    ``OuterBoundary()`` is closed (no flow); ``OuterBoundary.fixed_pressure(p0)`` holds every
    outer edge at ``p0``.
    """

    fixed: Mapping[int, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        clean = {}
        for tag, p in dict(self.fixed).items():
            t = int(tag)
            if t == 0:
                raise InputError("the hole wall (tag 0) cannot have a fixed pressure",
                                 key="outer_boundary.fixed", expected="tags 1..5")
            clean[t] = _num(f"outer_boundary.fixed[{t}]", p)
        object.__setattr__(self, "fixed", clean)

    @classmethod
    def fixed_pressure(cls, pressure: float, tags=(1, 2, 3, 4, 5)) -> "OuterBoundary":
        """All listed outer tags (default: all outer edges) held at ``pressure`` [Pa]."""
        return cls({int(t): pressure for t in tags})
