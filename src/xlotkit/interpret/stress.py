"""From picked pressures to in-situ stresses (thesis App. C).

Pure functions, SI units throughout (Pa, m, m^3, m^3/s). The chain of an XLOT interpretation is

1. bring every picked pressure to the depth of the open hole (:class:`DepthModel`,
   :func:`pressure_at_depth`, :func:`pick_at_depth`);
2. the fracture closure pressure is the minimum horizontal stress (:func:`sigma_h_from_fcp`);
3. breakdown minus reopening pressure is the tensile strength (:func:`tensile_strength`);
4. breakdown or reopening solved for the maximum horizontal stress, Eq. C.18 / C.19, with
   Monte-Carlo propagated uncertainty (:func:`sigma_H_estimates`).

Forward models used for checks and for the simulator's verification: the Kirsch stresses around
a circular hole (Eq. C.7 / C.8, :func:`kirsch_stresses`, :func:`hoop_stress_at_wall`), the
breakdown and reopening criteria (Eq. C.11 - C.13), the frictional-faulting stress polygon
(:func:`stress_polygon`), the thrust-belt bounds from a low leak-off pressure (Eq. C.16 / C.17,
:func:`thrust_belt_bounds`; both in :mod:`xlotkit.interpret.faulting`, re-exported here),
and the fracture stiffness of a penny or KGD crack (Eq. C.3, :func:`penny_stiffness`,
:func:`fracture_half_length_from_stiffness`). The closed forms themselves are
:mod:`xlotkit.formulas`; this module adds the input checks and the uncertainty.

Sign convention: **compression positive** for all stresses, as in rock mechanics. A tensile
hoop stress is negative; tensile failure of the wall happens when the effective hoop stress
``sigma_tt - p`` reaches ``-T0`` (``T0 >= 0`` is the tensile strength).

Horizontal stresses: ``sigma_h`` is the minimum, ``sigma_H`` the maximum horizontal stress, ``sv``
the vertical stress, ``p0`` the far-field pore pressure. Pressures entering the stress formulas
must be at the depth of the open hole, all on the same (gauge, i.e. relative to atmosphere)
reference.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from xlotkit import formulas
from xlotkit.errors import InputError
from xlotkit.interpret.faulting import (
    PolygonClassification,
    StressPolygon,
    ThrustBeltBounds,
    friction_ratio,
    stress_polygon,
    thrust_belt_bounds,
)
from xlotkit.interpret.picks.details import AtDepthDetails
from xlotkit.interpret.picks.types import Pick
from xlotkit.interpret.stress_checks import (
    _arr,
    _fmt,
    _nonneg,
    _ordered_horizontal,
    _out,
    _poisson,
    _positive,
    _pore_below,
)
from xlotkit.units import GRAVITY

__all__ = [
    "ATMOSPHERIC_PRESSURE",
    "GRAVITY",
    "WATER_DENSITY",
    "DepthModel",
    "PolygonClassification",
    "SigmaHEstimate",
    "SigmaHEstimates",
    "StressPolygon",
    "ThrustBeltBounds",
    "Uncertain",
    "as_uncertain",
    "breakdown_hubbert_willis",
    "breakdown_poroelastic",
    "fracture_half_length_from_stiffness",
    "friction_ratio",
    "from_emw",
    "hoop_stress_at_wall",
    "kgd_stiffness",
    "kirsch_stresses",
    "penny_stiffness",
    "pick_at_depth",
    "poroelastic_eta",
    "pressure_at_depth",
    "reopening_pressure",
    "sigma_H_estimates",
    "sigma_h_from_fcp",
    "stress_polygon",
    "tensile_strength",
    "thrust_belt_bounds",
    "to_emw",
]

#: Density of fresh water, the reference of specific gravity (sg) [kg/m^3].
WATER_DENSITY = 1000.0
#: Standard atmosphere [Pa], subtracted from absolute gauge readings.
ATMOSPHERIC_PRESSURE = 101_325.0

# Plausible fluid densities [kg/m^3]. Outside this range a value is almost surely in the wrong
# unit (1.09 given for 1090 kg/m^3, a gradient in bar/m, ...), so we refuse it.
_DENSITY_RANGE = (100.0, 5000.0)


# --------------------------------------------------------------------------------------------
# uncertain inputs
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Uncertain:
    """A quantity with its uncertainty, as fed to the Monte-Carlo propagation.

    Three kinds, told apart by which fields are set:

    * ``Uncertain(value)``: exact;
    * ``Uncertain(value, low, high)``: **triangular** distribution with support ``[low, high]``
      and mode ``value`` (the picked value is the most likely one; the pick's interval is
      taken as the range the true value lies in). Mean is ``(low + value + high) / 3``;
    * ``Uncertain(value, std=s)``: **normal** distribution with mean ``value`` and standard
      deviation ``s``.

    Attributes
    ----------
    value : float
        Best estimate (mode of a triangular, mean of a normal distribution), SI units.
    low, high : float or None
        Support of the triangular distribution; ``low <= value <= high``.
    std : float or None
        Standard deviation of the normal distribution.
    """

    value: float
    low: float | None = None
    high: float | None = None
    std: float | None = None

    def __post_init__(self) -> None:
        for name in ("value", "low", "high", "std"):
            v = getattr(self, name)
            if v is not None:
                if not isinstance(v, (int, float, np.floating, np.integer)) or not math.isfinite(v):
                    raise InputError(f"not a finite number: {v!r}", key=name,
                                     expected="a finite number")
                object.__setattr__(self, name, float(v))
        if (self.low is None) != (self.high is None):
            raise InputError("give both low and high, or neither", key="low/high",
                             expected="an interval low <= value <= high")
        if self.std is not None:
            if self.low is not None:
                raise InputError("both an interval and a standard deviation were given",
                                 key="std", expected="either (low, high) or std")
            if self.std < 0:
                raise InputError(f"negative standard deviation {self.std:g}", key="std",
                                 expected="std >= 0")
        if self.low is not None and not (self.low <= self.value <= self.high):
            raise InputError(f"value {self.value:g} is outside [{self.low:g}, {self.high:g}]",
                             key="value", expected="low <= value <= high")

    # constructors ------------------------------------------------------------------------
    @classmethod
    def exact(cls, value: float) -> Uncertain:
        """A value without uncertainty."""
        return cls(value)

    @classmethod
    def normal(cls, mean: float, std: float) -> Uncertain:
        """Normal distribution N(mean, std^2)."""
        return cls(mean, std=std)

    @classmethod
    def triangular(cls, low: float, mode: float, high: float) -> Uncertain:
        """Triangular distribution on ``[low, high]`` with its peak at ``mode``."""
        return cls(mode, low, high)

    # properties --------------------------------------------------------------------------
    @property
    def kind(self) -> Literal["exact", "normal", "triangular"]:
        """Which distribution this is."""
        if self.std is not None:
            return "normal"
        if self.low is not None:
            return "triangular"
        return "exact"

    @property
    def mean(self) -> float:
        """Expected value."""
        if self.kind == "triangular":
            return (self.low + self.value + self.high) / 3.0
        return self.value

    @property
    def sd(self) -> float:
        """Standard deviation (triangular: ``sqrt((a^2+b^2+c^2-ab-ac-bc)/18)``)."""
        if self.kind == "normal":
            return self.std
        if self.kind == "triangular":
            a, b, c = self.low, self.value, self.high
            return math.sqrt(max(a * a + b * b + c * c - a * b - a * c - b * c, 0.0) / 18.0)
        return 0.0

    @property
    def interval(self) -> tuple[float, float]:
        """Range for error bars: the support of a triangular, mean +/- 2 std of a normal
        (about 95 %), the value itself when exact."""
        if self.kind == "triangular":
            return self.low, self.high
        if self.kind == "normal":
            return self.value - 2.0 * self.std, self.value + 2.0 * self.std
        return self.value, self.value

    # operations --------------------------------------------------------------------------
    def shifted(self, dp: float) -> Uncertain:
        """The same distribution moved by ``dp`` (an exact additive correction)."""
        if self.kind == "triangular":
            return Uncertain(self.value + dp, self.low + dp, self.high + dp)
        return replace(self, value=self.value + dp)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` independent draws."""
        if self.kind == "normal" and self.std > 0:
            return rng.normal(self.value, self.std, n)
        if self.kind == "triangular" and self.high > self.low:
            return rng.triangular(self.low, self.value, self.high, n)
        # Degenerate distributions: numpy refuses a zero-width triangle, so handle them here.
        return np.full(n, self.value)


def as_uncertain(x: Any, key: str = "value") -> Uncertain:
    """Coerce an input into :class:`Uncertain`.

    Accepted: an :class:`Uncertain`; a :class:`~xlotkit.interpret.picks.types.Pick` (its
    ``low``/``high`` become a triangular distribution around ``value``, widened if needed so
    that it contains the value); a number (exact); a 2-tuple ``(mean, std)`` (normal); a 3-tuple
    ``(value, low, high)`` (triangular).

    Raises
    ------
    InputError
        If ``x`` is none of those, or a pick without a value.
    """
    if isinstance(x, Uncertain):
        return x
    if isinstance(x, Pick):
        if x.value is None:
            raise InputError(f"the {x.name} pick ({x.method}) has no value: {x.message}",
                             key=key, expected="a pick with a value")
        if x.low is None or x.high is None:
            return Uncertain(x.value)
        return Uncertain(x.value, min(x.low, x.value), max(x.high, x.value))
    if isinstance(x, (int, float, np.floating, np.integer)) and not isinstance(x, bool):
        return Uncertain(float(x))
    if isinstance(x, tuple):
        try:
            if len(x) == 2:
                return Uncertain.normal(x[0], x[1])
            if len(x) == 3:
                return Uncertain(x[0], x[1], x[2])
        except InputError as exc:
            raise InputError(exc.message, key=key, expected=exc.expected) from None
    raise InputError(f"cannot use {x!r} as an uncertain value", key=key,
                     expected="a number, Uncertain, Pick, (mean, std) or (value, low, high)")


# --------------------------------------------------------------------------------------------
# pressures to depth
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class DepthModel:
    """How to bring a measured pressure to the open hole.

    ``p_target = p_gauge + G (TVD_target - TVD_gauge) - dp_friction(q)`` where ``G`` is the
    hydrostatic gradient of the fluid in the well and ``dp_friction`` the frictional loss
    between gauge and target while fluid moves (zero when static).

    Parameters
    ----------
    target_tvd : float
        True vertical depth of the open hole / casing shoe [m], from the same datum as
        ``gauge_tvd`` (normally the rig floor, RKB).
    gauge_tvd : float, default 0
        True vertical depth of the gauge [m]; 0 for a surface (cementing unit) gauge.
    gauge_md : float, optional
        Measured depth of the gauge [m]; informative only (friction is calibrated over the whole
        path, hydrostatics needs TVD).
    mud_density : float, optional
        Density of the well fluid [kg/m^3]. Give this or ``gradient``.
    gradient : float, optional
        Measured hydrostatic gradient [Pa/m] (e.g. from a static pressure survey).
    friction : callable or float, optional
        Frictional pressure loss between gauge and target while pumping. A callable gets the
        absolute rate ``|q|`` [m^3/s] (array) and returns the loss [Pa] (>= 0). A number ``k``
        means ``dp = k |q|^n`` with ``n = friction_exponent`` (units Pa/(m^3/s)^n).
    friction_exponent : float, default 1.75
        Exponent ``n`` of the coefficient form; 1.75 is the Blasius scaling of turbulent flow in
        smooth pipe (use 1 for laminar flow).
    gauge_absolute : bool, default False
        True when the gauge reads absolute pressure; the atmosphere is then subtracted so that
        results are relative to atmosphere like every other pressure in a well.

    Notes
    -----
    Flow sign: ``q > 0`` is injection (friction makes the gauge read *more* than the pressure at
    the target, so the loss is subtracted); ``q < 0`` is flowback (added).
    """

    target_tvd: float
    gauge_tvd: float = 0.0
    gauge_md: float | None = None
    mud_density: float | None = None
    gradient: float | None = None
    friction: Callable[[np.ndarray], Any] | float | None = None
    friction_exponent: float = 1.75
    gauge_absolute: bool = False

    def __post_init__(self) -> None:
        _nonneg(self.target_tvd, "target_tvd", "a true vertical depth [m]")
        _nonneg(self.gauge_tvd, "gauge_tvd", "a true vertical depth [m]")
        if self.gauge_md is not None:
            md = float(_nonneg(self.gauge_md, "gauge_md", "a measured depth [m]"))
            if md + 1e-9 < self.gauge_tvd:
                raise InputError(f"gauge_md {md:g} m is less than gauge_tvd {self.gauge_tvd:g} m",
                                 key="gauge_md", expected="MD >= TVD")
        if (self.mud_density is None) == (self.gradient is None):
            raise InputError("give exactly one of mud_density and gradient",
                             key="mud_density/gradient",
                             expected="mud_density [kg/m^3] or gradient [Pa/m]")
        lo, hi = _DENSITY_RANGE
        if self.mud_density is not None:
            rho = float(_arr(self.mud_density, "mud_density"))
            if not lo <= rho <= hi:
                raise InputError(f"mud density {rho:g} kg/m^3 is implausible", key="mud_density",
                                 expected=f"{lo:g}..{hi:g} kg/m^3 (1.09 sg = 1090 kg/m^3)")
        else:
            g = float(_arr(self.gradient, "gradient"))
            if not lo * GRAVITY <= g <= hi * GRAVITY:
                raise InputError(f"hydrostatic gradient {g:g} Pa/m is implausible",
                                 key="gradient",
                                 expected=f"{lo * GRAVITY:.0f}..{hi * GRAVITY:.0f} Pa/m "
                                          "(1.09 sg = 10689 Pa/m)")
        if self.friction is not None and not callable(self.friction):
            _nonneg(self.friction, "friction", "a friction coefficient")
        _positive(self.friction_exponent, "friction_exponent", "an exponent")

    @property
    def hydrostatic_gradient(self) -> float:
        """Hydrostatic gradient of the well fluid [Pa/m]."""
        if self.gradient is not None:
            return float(self.gradient)
        return float(self.mud_density) * GRAVITY

    @property
    def hydrostatic(self) -> float:
        """Hydrostatic pressure added between gauge and target [Pa]."""
        return self.hydrostatic_gradient * (self.target_tvd - self.gauge_tvd)

    def friction_loss(self, rate) -> np.ndarray:
        """Signed frictional loss [Pa] between gauge and target at ``rate`` [m^3/s].

        Positive while injecting (subtract it from the gauge pressure), negative during
        flowback, zero at rest or when the model has no friction.
        """
        q = _arr(rate, "rate")
        if self.friction is None:
            return np.zeros_like(q)
        aq = np.abs(q)
        if callable(self.friction):
            loss = np.broadcast_to(np.asarray(self.friction(aq), dtype=float), aq.shape)
            if not np.all(np.isfinite(loss)) or np.any(loss < 0):
                raise InputError("the friction function returned a negative or non-finite loss",
                                 key="friction", expected="a loss >= 0 Pa for every |rate|")
        else:
            loss = float(self.friction) * aq ** self.friction_exponent
        return np.sign(q) * loss


def pressure_at_depth(p, model: DepthModel, *, rate=None):
    """Pressure at the target depth from a gauge reading.

    ``p_target = p - p_atm[absolute gauge] + G (TVD_target - TVD_gauge) - sign(q) dp_f(|q|)``

    Parameters
    ----------
    p : float or array_like
        Gauge pressure(s) [Pa].
    model : DepthModel
        Gauge and target depths, fluid gradient, friction.
    rate : float or array_like, optional
        Pump rate [m^3/s], broadcast against ``p``; positive for injection, negative for
        flowback. ``None`` means static (no friction), which is the case for shut-in picks.

    Returns
    -------
    float or ndarray
        Pressure at ``model.target_tvd`` [Pa], relative to atmosphere.
    """
    pa = _arr(p, "p")
    out = pa + model.hydrostatic
    if model.gauge_absolute:
        out = out - ATMOSPHERIC_PRESSURE
    if rate is not None:
        out = out - model.friction_loss(rate)
    return _out(out)


def pick_at_depth(pick: Pick, model: DepthModel, *, rate: float | None = None) -> Pick:
    """A copy of ``pick`` with its value and interval moved to the target depth.

    The depth correction is one constant shift (static, or at the constant ``rate`` the pick
    was made at), so the interval moves with the value unchanged in width. A pick without a
    value is returned as it is.
    """
    if pick.value is None:
        return pick
    dp = float(pressure_at_depth(0.0, model, rate=rate))
    return replace(pick,
                   value=pick.value + dp,
                   low=None if pick.low is None else pick.low + dp,
                   high=None if pick.high is None else pick.high + dp,
                   details=AtDepthDetails(original=pick.details, depth_shift=dp,
                                          target_tvd=float(model.target_tvd)))


def to_emw(p, tvd):
    """Equivalent mud weight [sg] of a pressure at a true vertical depth.

    ``EMW = p / (rho_w g TVD)``, the density (relative to fresh water) of a static fluid column
    from surface that would give ``p`` at ``tvd``; the usual way to report XLOT pressures.

    Parameters
    ----------
    p : float or array_like
        Pressure at depth [Pa] (relative to atmosphere).
    tvd : float or array_like
        True vertical depth [m] (> 0), from the same datum as the well's depth reference.
    """
    return _out(_arr(p, "p") / (WATER_DENSITY * GRAVITY * _positive(tvd, "tvd", "a depth [m]")))


def from_emw(emw, tvd):
    """Pressure [Pa] at ``tvd`` [m] of an equivalent mud weight ``emw`` [sg] (inverse of
    :func:`to_emw`)."""
    return _out(_arr(emw, "emw") * WATER_DENSITY * GRAVITY * _positive(tvd, "tvd", "a depth [m]"))


# --------------------------------------------------------------------------------------------
# sigma_h, T0
# --------------------------------------------------------------------------------------------

def sigma_h_from_fcp(fcp, model: DepthModel | None = None, *, rate: float | None = None
                     ) -> Uncertain:
    """Minimum horizontal stress from the fracture closure pressure.

    ``sigma_h = FCP`` at the depth of the fracture (thesis ch. 3 / C.2.2: closure is where the
    fracture walls take over the stress normal to them, which is the least principal stress,
    horizontal in a normal or strike-slip regime).

    Parameters
    ----------
    fcp : Pick, Uncertain, float or tuple
        Fracture closure pressure [Pa], on the gauge's reference (see :func:`as_uncertain`).
    model : DepthModel, optional
        Moves the pick from the gauge to the open hole; ``None`` when ``fcp`` is already at
        depth.
    rate : float, optional
        Rate during the pick [m^3/s], for friction (flowback through a choke); ``None`` = static.

    Returns
    -------
    Uncertain
        ``sigma_h`` [Pa] with the pick's interval shifted by the same exact depth correction.
    """
    u = as_uncertain(fcp, "fcp")
    if model is not None:
        u = u.shifted(float(pressure_at_depth(0.0, model, rate=rate)))
    if u.value <= 0:
        raise InputError(f"closure pressure at depth {u.value:g} Pa is not positive", key="fcp",
                         expected="a closure pressure > 0 Pa at depth")
    return u


def tensile_strength(fbp, pr) -> Uncertain:
    """Tensile strength from the first and second cycle peaks.

    ``T0 = FBP - Pr`` (Eq. C.11 minus Eq. C.13: reopening needs no tensile strength).

    Parameters
    ----------
    fbp, pr : Pick, Uncertain, float or tuple
        Formation breakdown and reopening pressures [Pa], same reference.

    Returns
    -------
    Uncertain
        ``T0`` [Pa]. Its interval is the worst case of the two intervals (``[FBP_low - Pr_high,
        FBP_high - Pr_low]``, clipped at 0) as a triangular distribution; if both inputs are
        normal the result is normal with ``std = hypot(std_fbp, std_pr)``.

    Raises
    ------
    InputError
        If ``Pr > FBP``: a negative tensile strength is not physical (the difference of the
        peaks is then dominated by other effects; see thesis C.2.3.2).
    """
    f, r = as_uncertain(fbp, "fbp"), as_uncertain(pr, "pr")
    t = f.value - r.value
    if t < 0:
        raise InputError(f"reopening pressure {r.value:g} Pa exceeds breakdown {f.value:g} Pa",
                         key="pr", expected="Pr <= FBP (T0 = FBP - Pr >= 0)")
    if f.kind != "triangular" and r.kind != "triangular":
        if f.kind == r.kind == "exact":
            return Uncertain(t)
        return Uncertain.normal(t, math.hypot(f.sd, r.sd))
    flo, fhi = f.interval
    rlo, rhi = r.interval
    return Uncertain(t, max(min(flo - rhi, t), 0.0), max(fhi - rlo, t))


# --------------------------------------------------------------------------------------------
# breakdown and reopening (Eq. C.11 - C.13)
# --------------------------------------------------------------------------------------------

def _stress_inputs(sigma_h, sigma_H, p0):
    sh = _nonneg(sigma_h, "sigma_h")
    sH = _nonneg(sigma_H, "sigma_H")
    pp = _nonneg(p0, "p0")
    _ordered_horizontal(sh, sH)
    _pore_below(pp, sh, "sigma_h")
    return sh, sH, pp


def breakdown_hubbert_willis(sigma_h, sigma_H, p0, T0):
    """Breakdown pressure of an impermeable wall (Hubbert & Willis), Eq. C.11.

    ``P_b = 3 sigma_h - sigma_H - p0 + T0``

    The Kirsch hoop stress at the azimuth of ``sigma_H`` (Eq. C.10) minus the unchanged pore
    pressure reaches ``-T0`` at this well pressure.

    Parameters
    ----------
    sigma_h, sigma_H : float or array_like
        Minimum and maximum horizontal stress [Pa], ``0 <= sigma_h <= sigma_H``.
    p0 : float or array_like
        Far-field pore pressure [Pa], ``0 <= p0 <= sigma_h``.
    T0 : float or array_like
        Tensile strength [Pa], ``>= 0``.

    Returns
    -------
    float or ndarray
        Well pressure at breakdown [Pa].
    """
    sh, sH, pp = _stress_inputs(sigma_h, sigma_H, p0)
    t0 = _nonneg(T0, "T0", "a tensile strength [Pa]")
    return _out(formulas.hubbert_willis(sh, sH, pp, t0))


def reopening_pressure(sigma_h, sigma_H, p0):
    """Reopening pressure of an existing fracture, Eq. C.13.

    ``P_r = 3 sigma_h - sigma_H - p0`` (Eq. C.11 with ``T0 = 0``).

    Parameters
    ----------
    sigma_h, sigma_H, p0 : float or array_like
        Stresses and pore pressure [Pa], as in :func:`breakdown_hubbert_willis`.
    """
    sh, sH, pp = _stress_inputs(sigma_h, sigma_H, p0)
    return _out(formulas.reopening_pressure(sh, sH, pp))


def poroelastic_eta(alpha, nu):
    """Poroelastic stress coefficient ``eta = alpha (1 - 2 nu) / (2 (1 - nu))``, in [0, 0.5).

    Parameters
    ----------
    alpha : float or array_like
        Biot coefficient, ``0 <= alpha <= 1``.
    nu : float or array_like
        Drained Poisson's ratio, ``0 < nu < 0.5``.
    """
    a = _arr(alpha, "alpha")
    if np.any((a < 0) | (a > 1)):
        raise InputError(f"Biot coefficient {_fmt(a)} is outside [0, 1]", key="alpha",
                         expected="0 <= alpha <= 1")
    n = _poisson(nu)
    return _out(a * (1.0 - 2.0 * n) / (2.0 * (1.0 - n)))


def breakdown_poroelastic(sigma_h, sigma_H, p0, T0, alpha=None, nu=None, *, eta=None):
    """Breakdown pressure of a permeable wall (Haimson & Fairhurst), Eq. C.12.

    ``P_b = (3 sigma_h - sigma_H - 2 eta p0 + T0) / (2 (1 - eta))``,
    ``eta = alpha (1 - 2 nu) / (2 (1 - nu))``.

    Fluid enters the wall: the pore pressure at the wall equals the well pressure, and the
    diffusion adds ``2 eta (P - p0)`` of compressive hoop stress. Limits: ``eta -> 0`` (no
    poroelastic stress) gives ``(P_HW + p0) / 2``, half-way between the pore pressure and the
    Hubbert-Willis value; ``eta = 1/2`` gives back Hubbert-Willis exactly. In general
    ``P_b = w P_HW + (1 - w) p0`` with ``w = 1 / (2 (1 - eta))`` in [1/2, 1], so the
    poroelastic breakdown lies between ``p0`` and the Hubbert-Willis value and rises with eta.

    Parameters
    ----------
    sigma_h, sigma_H, p0, T0 : float or array_like
        As in :func:`breakdown_hubbert_willis` [Pa].
    alpha, nu : float or array_like, optional
        Biot coefficient [0, 1] and Poisson's ratio (0, 0.5), giving ``eta``.
    eta : float or array_like, optional
        The coefficient directly, ``0 <= eta <= 0.5``, instead of ``alpha`` and ``nu``.

    Returns
    -------
    float or ndarray
        Well pressure at breakdown [Pa].
    """
    sh, sH, pp = _stress_inputs(sigma_h, sigma_H, p0)
    t0 = _nonneg(T0, "T0", "a tensile strength [Pa]")
    if eta is not None:
        if alpha is not None or nu is not None:
            raise InputError("give eta, or alpha and nu, not both", key="eta",
                             expected="eta alone or (alpha, nu)")
        e = _arr(eta, "eta")
        if np.any((e < 0) | (e > 0.5)):
            raise InputError(f"eta {_fmt(e)} is outside [0, 0.5]", key="eta",
                             expected="0 <= eta <= 0.5")
    else:
        if alpha is None or nu is None:
            raise InputError("the poroelastic breakdown needs alpha and nu (or eta)",
                             key="alpha" if alpha is None else "nu",
                             expected="Biot coefficient and Poisson's ratio")
        e = np.asarray(poroelastic_eta(alpha, nu))
    return _out((3.0 * sh - sH - 2.0 * e * pp + t0) / (2.0 * (1.0 - e)))


# --------------------------------------------------------------------------------------------
# sigma_H (Eq. C.18 / C.19) with Monte-Carlo uncertainty
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class SigmaHEstimate:
    """Maximum horizontal stress from one equation, with its sampled distribution.

    Attributes
    ----------
    equation : str
        ``"C.18"`` (from breakdown and T0) or ``"C.19"`` (from reopening).
    value : float
        The equation evaluated at the inputs' best values [Pa].
    mean, median, std : float
        Of the Monte-Carlo samples [Pa].
    low, high : float
        Percentiles ``percentiles`` of the samples [Pa].
    percentiles : tuple of float
        Which percentiles ``low`` and ``high`` are.
    n_samples : int
    fraction_below_sigma_h : float
        Share of samples with ``sigma_H < sigma_h`` (inconsistent with the labels; large
        values say the inputs do not support the equation's assumptions).
    message : str
        Warning when the best value itself is below ``sigma_h``; empty otherwise.
    """

    equation: str
    value: float
    mean: float
    median: float
    std: float
    low: float
    high: float
    percentiles: tuple[float, float]
    n_samples: int
    fraction_below_sigma_h: float
    message: str = ""

    @property
    def std_error(self) -> float:
        """Standard error of ``mean`` [Pa]: ``std / sqrt(n_samples)``."""
        return self.std / math.sqrt(self.n_samples)

    @property
    def interval(self) -> tuple[float, float]:
        """``(low, high)`` [Pa]."""
        return self.low, self.high


@dataclass(frozen=True)
class SigmaHEstimates(Mapping[str, SigmaHEstimate]):
    """The sigma_H estimates by equation (a read-only mapping ``"C.18"/"C.19" -> estimate``),
    with the inputs they were made from.

    Attributes
    ----------
    sigma_h : Uncertain
        Minimum horizontal stress used [Pa].
    p0 : Uncertain
        Pore pressure used [Pa].
    estimates : dict
        ``{equation: SigmaHEstimate}``.
    notes : tuple of str
        Why an equation is missing, if one is.
    """

    sigma_h: Uncertain
    p0: Uncertain
    estimates: dict[str, SigmaHEstimate] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def __getitem__(self, key: str) -> SigmaHEstimate:
        return self.estimates[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.estimates)

    def __len__(self) -> int:
        return len(self.estimates)


def sigma_H_estimates(sigma_h, *, p0, pr=None, fbp=None, T0=None, n_samples: int = 20_000,
                      seed: int | None = 0, percentiles: tuple[float, float] = (5.0, 95.0)
                      ) -> SigmaHEstimates:
    """Maximum horizontal stress from breakdown (Eq. C.18) and reopening (Eq. C.19).

    * Eq. C.18 (Eq. C.11 solved for sigma_H): ``sigma_H = 3 sigma_h - FBP - p0 + T0``
    * Eq. C.19 (Eq. C.13 solved for sigma_H): ``sigma_H = 3 sigma_h - Pr - p0``

    Each input is sampled independently ``n_samples`` times (normal or triangular, see
    :class:`Uncertain`) and pushed through the equation; the same draws of ``sigma_h`` and
    ``p0`` feed both equations so the two are comparable. The thesis (C.2.5) puts the accuracy
    of sigma_H at 15 % at best, because FBP and Pr carry effects the equations ignore; the
    intervals here only propagate the *stated* input uncertainties.

    Parameters
    ----------
    sigma_h : Uncertain, Pick, float or tuple
        Minimum horizontal stress [Pa] (e.g. from :func:`sigma_h_from_fcp`).
    p0 : Uncertain, float or tuple
        Pore pressure [Pa].
    pr : optional
        Reopening pressure at depth [Pa]; enables Eq. C.19.
    fbp : optional
        Breakdown pressure at depth [Pa] (or the LOP if it is taken as fracture initiation);
        with ``T0`` enables Eq. C.18.
    T0 : optional
        Tensile strength [Pa] from an *independent* source (core tests, breakouts). With
        ``T0 = FBP - Pr`` Eq. C.18 is identical to Eq. C.19, so it is not computed from the
        peaks here.
    n_samples : int, default 20000
        Monte-Carlo samples (standard error of the mean is ``std / sqrt(n)``).
    seed : int or None, default 0
        Seed of :func:`numpy.random.default_rng`; the default makes reports reproducible.
    percentiles : (float, float), default (5, 95)
        Percentiles reported as ``low`` and ``high``.

    Returns
    -------
    SigmaHEstimates
        Mapping ``equation -> SigmaHEstimate``; empty (with ``notes``) if neither equation has
        its inputs.

    Raises
    ------
    InputError
        Missing or impossible inputs (negative stresses, ``n_samples < 2``, bad percentiles).
    """
    sh = as_uncertain(sigma_h, "sigma_h")
    pp = as_uncertain(p0, "p0")
    if sh.value <= 0:
        raise InputError(f"sigma_h {sh.value:g} Pa is not positive", key="sigma_h",
                         expected="sigma_h > 0")
    if pp.value < 0:
        raise InputError(f"pore pressure {pp.value:g} Pa is negative", key="p0",
                         expected="p0 >= 0")
    if pp.value > sh.value:
        raise InputError("pore pressure exceeds sigma_h", key="p0", expected="0 <= p0 <= sigma_h")
    if int(n_samples) != n_samples or n_samples < 2:
        raise InputError(f"n_samples = {n_samples!r}", key="n_samples", expected="an integer >= 2")
    lo_p, hi_p = (float(v) for v in percentiles)
    if not 0.0 <= lo_p < hi_p <= 100.0:
        raise InputError(f"percentiles {percentiles!r}", key="percentiles",
                         expected="0 <= low < high <= 100")
    if pr is None and fbp is None:
        raise InputError("need a reopening pressure (Eq. C.19) or a breakdown pressure and T0 "
                         "(Eq. C.18)", key="pr/fbp", expected="pr=..., or fbp=... and T0=...")
    n = int(n_samples)
    rng = np.random.default_rng(seed)
    # Draw order is fixed (sigma_h, p0, then per equation) so a seed always gives the same
    # numbers for the same set of inputs.
    s_sh = sh.sample(n, rng)
    s_pp = pp.sample(n, rng)

    estimates: dict[str, SigmaHEstimate] = {}
    notes: list[str] = []
    if fbp is not None:
        if T0 is None:
            notes.append("Eq. C.18 skipped: needs a tensile strength T0 from an independent "
                         "source (with T0 = FBP - Pr it equals Eq. C.19)")
        else:
            fb = as_uncertain(fbp, "fbp")
            t0 = as_uncertain(T0, "T0")
            if fb.value <= 0:
                raise InputError(f"breakdown pressure {fb.value:g} Pa", key="fbp",
                                 expected="fbp > 0")
            if t0.value < 0:
                raise InputError(f"tensile strength {t0.value:g} Pa", key="T0",
                                 expected="T0 >= 0")
            # Eq. C.18 is Eq. C.11 solved for sigma_H: the same expression with sigma_H and
            # P_b exchanged
            central = formulas.hubbert_willis(sh.value, fb.value, pp.value, t0.value)
            samples = formulas.hubbert_willis(s_sh, fb.sample(n, rng), s_pp, t0.sample(n, rng))
            estimates["C.18"] = _summarise("C.18", central, samples, s_sh, sh.value,
                                           (lo_p, hi_p))
    if pr is not None:
        r = as_uncertain(pr, "pr")
        if r.value <= 0:
            raise InputError(f"reopening pressure {r.value:g} Pa", key="pr", expected="pr > 0")
        # Eq. C.19 is Eq. C.13 solved for sigma_H (sigma_H and P_r exchanged)
        central = formulas.reopening_pressure(sh.value, r.value, pp.value)
        samples = formulas.reopening_pressure(s_sh, r.sample(n, rng), s_pp)
        estimates["C.19"] = _summarise("C.19", central, samples, s_sh, sh.value, (lo_p, hi_p))
    return SigmaHEstimates(sigma_h=sh, p0=pp, estimates=estimates, notes=tuple(notes))


def _summarise(eq: str, central: float, samples: np.ndarray, s_sh: np.ndarray, sh: float,
               pct: tuple[float, float]) -> SigmaHEstimate:
    lo, hi = np.percentile(samples, pct)
    msg = ""
    if central < sh:
        msg = (f"Eq. {eq} gives sigma_H = {central / 1e6:.2f} MPa below sigma_h = "
               f"{sh / 1e6:.2f} MPa: the picks do not fit the elastic breakdown model")
    return SigmaHEstimate(
        equation=eq, value=float(central), mean=float(np.mean(samples)),
        median=float(np.median(samples)), std=float(np.std(samples, ddof=1)),
        low=float(lo), high=float(hi), percentiles=pct, n_samples=int(samples.size),
        fraction_below_sigma_h=float(np.mean(samples < s_sh)), message=msg)


# --------------------------------------------------------------------------------------------
# Kirsch (Eq. C.7 / C.8)
# --------------------------------------------------------------------------------------------

def kirsch_stresses(r, theta, a, sigma_x, sigma_y, p_w, *, tau_xy=0.0):
    """Linear-elastic stresses around a pressurised circular hole, Eq. C.7 (Kirsch).

    Plane problem (the hole axis is a principal direction of the far field), infinite isotropic
    elastic medium, far-field stresses ``sigma_x, sigma_y, tau_xy`` in the plane normal to the
    hole, well pressure ``p_w`` on the wall, no fluid entering the rock. With ``q = a^2/r^2``::

        s_rr = (sx+sy)/2 (1 - q) + [(sx-sy)/2 cos 2t + txy sin 2t] (1 + 3q^2 - 4q) + p_w q
        s_tt = (sx+sy)/2 (1 + q) - [(sx-sy)/2 cos 2t + txy sin 2t] (1 + 3q^2)      - p_w q
        t_rt = [-(sx-sy)/2 sin 2t + txy cos 2t] (1 - 3q^2 + 2q)

    which is Eq. C.7 with ``sigma_x = sigma_H`` and ``tau_xy = 0``, plus the far-field shear term.

    Convention: **compression positive**; ``theta`` [rad] is measured from the x axis towards
    the y axis; ``tau_xy`` follows the same sign rule as the polar ``tau_rt`` (the shear
    stress transformation ``t_rt(r->inf) = -(sx-sy)/2 sin 2t + txy cos 2t``). The solution is
    linear in its loads, so tensile (negative) far-field values are accepted as well (Kirsch's
    original problem is uniaxial tension).

    Parameters
    ----------
    r : float or array_like
        Distance from the hole axis [m], ``r >= a``.
    theta : float or array_like
        Azimuth [rad].
    a : float
        Hole radius [m], > 0.
    sigma_x, sigma_y, tau_xy : float
        Far-field stresses [Pa].
    p_w : float or array_like
        Well pressure [Pa].

    Returns
    -------
    sigma_rr, sigma_tt, tau_rt : ndarray or float
        Radial, hoop and shear stress [Pa], broadcast over ``r``, ``theta`` and ``p_w``.

    Notes
    -----
    Limits: ``r = a`` gives ``s_rr = p_w``, ``t_rt = 0`` and Eq. C.8; ``r -> inf`` gives the
    far field rotated to polar axes.
    """
    aa = float(_positive(a, "a", "a hole radius [m]"))
    rr = _arr(r, "r")
    if np.any(rr < aa):
        raise InputError(f"r = {_fmt(rr[rr < aa])} m is inside the hole (a = {aa:g} m)",
                         key="r", expected=f"r >= a = {aa:g} m")
    th = _arr(theta, "theta")
    sx, sy, txy = _arr(sigma_x, "sigma_x"), _arr(sigma_y, "sigma_y"), _arr(tau_xy, "tau_xy")
    pw = _arr(p_w, "p_w")
    s_rr, s_tt, t_rt = formulas.kirsch_polar(rr, th, aa, sx, sy, pw, txy)
    # At r = a the shear factor (1 - 3 + 2) is 0 only up to rounding; set the boundary value
    # exactly because this function is a verification reference.
    t_rt = np.where(rr == aa, 0.0, t_rt)
    s_rr = np.where(rr == aa, np.broadcast_to(pw, s_rr.shape), s_rr)
    return _out(s_rr), _out(s_tt), _out(t_rt)


def hoop_stress_at_wall(theta, sigma_x, sigma_y, p_w, *, tau_xy=0.0):
    """Hoop stress on the wall of a pressurised hole, Eq. C.8b.

    ``s_tt(a, t) = sx + sy - 2 (sx - sy) cos 2t - 4 txy sin 2t - p_w``

    With ``sigma_x = sigma_H``, ``sigma_y = sigma_h`` its minimum is at ``t = 0`` (the azimuth
    of sigma_H): ``3 sigma_h - sigma_H - p_w`` (Eq. C.10), where fractures initiate.
    Conventions as in :func:`kirsch_stresses` (compression positive, ``theta`` [rad] from x).

    Parameters
    ----------
    theta : float or array_like
        Azimuth [rad].
    sigma_x, sigma_y, tau_xy : float
        Far-field stresses [Pa].
    p_w : float or array_like
        Well pressure [Pa].

    Returns
    -------
    float or ndarray
        Hoop stress [Pa].
    """
    th = _arr(theta, "theta")
    sx, sy, txy = _arr(sigma_x, "sigma_x"), _arr(sigma_y, "sigma_y"), _arr(tau_xy, "tau_xy")
    pw = _arr(p_w, "p_w")
    return _out(formulas.kirsch_wall_hoop(th, sx, sy, pw, txy))


# --------------------------------------------------------------------------------------------
# fracture size from stiffness (Eq. C.3)
# --------------------------------------------------------------------------------------------

def _elastic(E, nu):
    return _positive(E, "E", "a Young's modulus [Pa]"), _poisson(nu)


def penny_stiffness(R, E, nu):
    """Stiffness ``dp/dV`` of a pressurised penny-shaped crack of radius ``R``, Eq. C.3.

    ``S_f = 3 E / (16 R^3 (1 - nu^2))`` [Pa/m^3], from Sneddon's volume
    ``V = 16 (1 - nu^2) p R^3 / (3 E)`` (both faces' opening).

    Parameters
    ----------
    R : float or array_like
        Crack radius [m], > 0.
    E : float
        Young's modulus [Pa], > 0.
    nu : float
        Poisson's ratio, 0 < nu < 0.5.
    """
    e, n = _elastic(E, nu)
    r = _positive(R, "R", "a radius [m]")
    return _out(formulas.penny_stiffness(r, e, n))


def kgd_stiffness(L, h, E, nu):
    """Stiffness ``dp/dV`` of a plane-strain (KGD) crack of half-length ``L`` and height ``h``.

    Sneddon's plane-strain opening ``w(x) = 4 p sqrt(L^2 - x^2) / E'``, ``E' = E / (1 - nu^2)``,
    integrates to ``V = 2 pi p L^2 h / E'``, so ``S = E' / (2 pi L^2 h)`` [Pa/m^3].

    Parameters
    ----------
    L : float or array_like
        Half-length (tip to well) [m], > 0.
    h : float
        Fracture height [m], > 0.
    E, nu : float
        Young's modulus [Pa] and Poisson's ratio.
    """
    e, n = _elastic(E, nu)
    ll = _positive(L, "L", "a half-length [m]")
    hh = _positive(h, "h", "a fracture height [m]")
    return _out(formulas.kgd_stiffness(ll, hh, e, n))


def fracture_half_length_from_stiffness(S_open, S_closed, E, nu, geometry: str = "penny", *,
                                        h=None):
    """Fracture size from the system-stiffness contrast at closure (inverse of Eq. C.3).

    The open fracture and the well store fluid in parallel, so compliances add:
    ``C_f = 1/S_open - 1/S_closed`` is the fracture's compliance ``dV/dp``. Then

    * ``"penny"``: ``R = [3 E C_f / (16 (1 - nu^2))]^(1/3)`` (Eq. C.3 solved for R);
    * ``"kgd"``: ``L = sqrt(E' C_f / (2 pi h))``, ``E' = E / (1 - nu^2)`` (see
      :func:`kgd_stiffness`).

    Parameters
    ----------
    S_open : float or array_like
        System stiffness ``dp/dV`` with the fracture open [Pa/m^3], e.g. the first flowback
        line's slope.
    S_closed : float or array_like
        System stiffness with the fracture closed [Pa/m^3] (well storage), ``> S_open``.
    E, nu : float
        Young's modulus [Pa] and Poisson's ratio of the formation.
    geometry : {"penny", "kgd"}
    h : float, optional
        Fracture height [m], required for ``"kgd"``.

    Returns
    -------
    float or ndarray
        Penny radius ``R`` or KGD half-length ``L`` [m].
    """
    so = _positive(S_open, "S_open", "a stiffness [Pa/m^3]")
    sc = _positive(S_closed, "S_closed", "a stiffness [Pa/m^3]")
    if np.any(so >= sc):
        raise InputError("the stiffness with an open fracture is not below the closed one",
                         key="S_open", expected="0 < S_open < S_closed")
    e, n = _elastic(E, nu)
    cf = 1.0 / so - 1.0 / sc
    if geometry == "penny":
        if h is not None:
            raise InputError("h is not used by the penny geometry", key="h",
                             expected="h only with geometry='kgd'")
        return _out(formulas.penny_radius(cf, e, n))
    if geometry == "kgd":
        if h is None:
            raise InputError("the KGD geometry needs the fracture height", key="h",
                             expected="h > 0 [m]")
        hh = _positive(h, "h", "a fracture height [m]")
        return _out(formulas.kgd_half_length(cf, hh, e, n))
    raise InputError(f"unknown geometry {geometry!r}", key="geometry",
                     expected="'penny' or 'kgd'")
