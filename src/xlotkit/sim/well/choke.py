"""The surface choke: one law for every engine (thesis Eq. 4.24 / C.4).

::

    Q_return = zeta * sqrt(max(p_choke - p_atm, 0))

``zeta`` is given or calibrated from one rate at the surface pressure the flowback starts
with (:func:`calibrate_choke`). The surface pressure of a flowing well solves the column
together with the friction of the returning flow (:func:`choke_surface_pressure`). An
implicit step that needs the rate's derivative with respect to the bottom-hole pressure
(the 2D engine's Newton) takes :func:`choke_flow`: the same law, linearised below
:data:`CHOKE_LINEAR` at surface so that ``dQ/dp`` stays finite as the well dies.
"""

from __future__ import annotations

import math

from scipy.optimize import brentq

from xlotkit.checks import check_range as _check
from xlotkit.errors import InputError
from xlotkit.sim.well.column import (
    Column,
    bottomhole_from_surface,
    surface_from_bottomhole,
)

__all__ = ["CHOKE_LINEAR", "calibrate_choke", "choke_flow", "choke_rate",
           "choke_surface_pressure"]

#: Surface pressure [Pa] below which :func:`choke_flow` linearises the law (keeps dQ/dp
#: finite; the rate is then a trickle).
CHOKE_LINEAR = 1e4


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



def choke_flow(p_bottomhole: float, zeta: float, column: Column,
               linear_below: float = CHOKE_LINEAR) -> tuple[float, float]:
    """Net rate into the well through the choke and its derivative, ``(Q, dQ/dp_bh)``.

    ``Q = -zeta sqrt(p_s)`` [m^3/s] (returns are negative) with ``p_s`` the surface pressure
    of the column above ``p_bottomhole``:

    * without friction ``p_s`` is the static column's and ``dp_s/dp_bh`` its forward
      difference over 1 Pa;
    * with friction ``p_s`` solves ``p_bh = p_bh(p_s, -zeta sqrt(p_s))``
      (:func:`choke_surface_pressure`) and ``dQ/dp_bh = (dQ/dp_s) / (dp_bh/dp_s)``, the
      column's total derivative taken by a central difference of 1 kPa in ``p_s``.

    Below ``linear_below`` at surface the law is ``Q = -zeta p_s / sqrt(linear_below)``
    (with friction: on the static column), which keeps the derivative finite.
    """
    if column.friction:
        ps, q = choke_surface_pressure(p_bottomhole, zeta, column)
        if ps < linear_below:
            ps = surface_from_bottomhole(p_bottomhole, 0.0, column)
            if ps <= 0.0:
                return 0.0, 0.0
            k = zeta / math.sqrt(linear_below)
            dps = surface_from_bottomhole(p_bottomhole + 1.0, 0.0, column) - ps
            return -k * ps, -k * dps
        dp = 1e3

        def p_bh(p_s: float) -> float:
            return bottomhole_from_surface(p_s, -zeta * math.sqrt(p_s), column)

        dpbh = (p_bh(ps + dp) - p_bh(ps - dp)) / (2.0 * dp)
        return -q, -(0.5 * zeta / math.sqrt(ps)) / dpbh
    ps = surface_from_bottomhole(p_bottomhole, 0.0, column)
    dp = 1.0
    ps2 = surface_from_bottomhole(p_bottomhole + dp, 0.0, column)
    dps = (ps2 - ps) / dp
    if ps <= 0.0:
        qv, dq = 0.0, 0.0
    elif ps < linear_below:
        qv, dq = zeta * ps / math.sqrt(linear_below), zeta / math.sqrt(linear_below)
    else:
        qv, dq = zeta * math.sqrt(ps), 0.5 * zeta / math.sqrt(ps)
    return -qv, -dq * dps
