"""The result type shared by every pick."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from xlotkit.interpret.picks.details import Details

__all__ = ["Pick", "PickQuality"]

PickQuality = Literal["good", "fair", "poor", "none"]


@dataclass(frozen=True)
class Pick:
    """One picked pressure by one method.

    Attributes
    ----------
    name : str
        What was picked: ``"LOP"``, ``"FBP"``, ``"Pr"``, ``"FPP"``, ``"ISIP"``, ``"FCP"``.
    method : str
        How: e.g. ``"tangent"``, ``"sqrt_t"``, ``"g_function"``, ``"bilinear"``,
        ``"compliance"``, ``"flowback_sqrt_p"``, ``"flowback_p_v"``, ``"max"``.
    value : float or None
        Picked pressure [Pa] on the record's reference; None when the record does not
        contain it (e.g. the decline never reaches closure) -- ``message`` says why.
    low, high : float or None
        Interval [Pa]. Where ``level`` is set it is meant to contain the true value with that
        probability and is built from every source of error the method knows (fit, windows,
        a gradual transition, the gauge's resolution; :mod:`~xlotkit.interpret.picks.
        intervals`, the parts in ``details.interval``); otherwise it is the range of the
        fit's covariance and nearby windows, without a stated level.
    t : float or None
        Elapsed time of the pick [s].
    window : tuple of float or None
        Time window [s] of the data the pick was made from.
    quality : {"good", "fair", "poor", "none"}
        ``none`` when there is no value.
    message : str
        Human-readable note (why no value, diagnosis of the decline, ...).
    details : Details or None
        Method-specific numbers (fitted slopes, stiffnesses [Pa/m^3], R^2, G at closure, ...),
        SI units: one typed class per method family (:mod:`~xlotkit.interpret.picks.details`),
        None when the method stopped before fitting anything.
    level : float or None
        Nominal coverage of ``[low, high]`` (e.g. 0.9), None when the interval states none.
    """

    name: str
    method: str
    value: float | None
    low: float | None = None
    high: float | None = None
    t: float | None = None
    window: tuple[float, float] | None = None
    quality: PickQuality = "good"
    message: str = ""
    details: Details | None = None
    level: float | None = None

    @property
    def found(self) -> bool:
        """Whether a value was picked."""
        return self.value is not None

    @classmethod
    def not_found(cls, name: str, method: str, message: str, **kw: Any) -> Pick:
        """A pick that reports why there is no value."""
        return cls(name=name, method=method, value=None, quality="none", message=message, **kw)
