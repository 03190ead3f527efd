"""Input checks of the stress formulas (values as float arrays; one :class:`InputError` each)."""

from __future__ import annotations

import numpy as np

from xlotkit.errors import InputError


def _arr(x, key: str) -> np.ndarray:
    """``x`` as a float array; non-numbers and non-finite values are input errors."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"not a number: {x!r}", key=key, expected="a finite number") from None
    if not np.all(np.isfinite(a)):
        raise InputError(f"not finite: {x!r}", key=key, expected="a finite number")
    return a


def _out(a):
    """A 0-d result as a Python float, arrays unchanged."""
    a = np.asarray(a, dtype=float)
    return float(a) if a.ndim == 0 else a


def _nonneg(x, key: str, what: str = "a stress or pressure [Pa]") -> np.ndarray:
    a = _arr(x, key)
    if np.any(a < 0):
        raise InputError(f"negative value {_fmt(a[a < 0])}", key=key, expected=f"{what} >= 0")
    return a


def _positive(x, key: str, what: str) -> np.ndarray:
    a = _arr(x, key)
    if np.any(a <= 0):
        raise InputError(f"non-positive value {_fmt(a[a <= 0])}", key=key,
                         expected=f"{what} > 0")
    return a


def _poisson(nu, key: str = "nu") -> np.ndarray:
    a = _arr(nu, key)
    if np.any((a <= 0) | (a >= 0.5)):
        raise InputError(f"Poisson's ratio {_fmt(a)} is outside (0, 0.5)", key=key,
                         expected="0 < nu < 0.5")
    return a


def _fmt(a) -> str:
    a = np.atleast_1d(np.asarray(a, dtype=float))
    return f"{a[0]:g}" if a.size == 1 else f"{a[0]:g} (and {a.size - 1} more)"


def _ordered_horizontal(sigma_h: np.ndarray, sigma_H: np.ndarray) -> None:
    """The breakdown criteria assume initiation at the azimuth of sigma_H >= sigma_h."""
    if np.any(sigma_H < sigma_h):
        raise InputError("sigma_H is smaller than sigma_h", key="sigma_H",
                         expected="sigma_H >= sigma_h (maximum >= minimum horizontal stress)")


def _pore_below(p0: np.ndarray, sigma: np.ndarray, name: str) -> None:
    # A pore pressure above the least stress would have fractured the rock already.
    if np.any(p0 > sigma):
        raise InputError(f"pore pressure exceeds {name}", key="p0",
                         expected=f"0 <= p0 <= {name}")


