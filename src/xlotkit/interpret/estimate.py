"""The stress estimate of an interpreted record: sigma_h, sigma_H, T0, pore pressure, sigma_v.

Moved here from :mod:`xlotkit.pipeline` (which re-exports it): :func:`estimate_stress` turns a
record's picks (:class:`~xlotkit.interpret.picks.core.RecordPicks`) and the well data
(:class:`StressInputs`) into a :class:`StressSummary`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from xlotkit.errors import InputError
from xlotkit.interpret.stress import GRAVITY
from xlotkit.record import ATMOSPHERE_PA, Record

__all__ = ["GRAVITY", "StressInputs", "StressSummary", "estimate_stress"]

_BAR = 1e5

@dataclass(frozen=True)
class StressInputs:
    """What an interpretation needs beyond the log to turn pressures into stresses.

    Parameters
    ----------
    target_tvd : float, optional
        True vertical depth of the open hole [m]. Default: the depth of the pressure
        reference (a bottom-hole or downhole record); required for a surface record.
    gauge_tvd : float, optional
        TVD of the gauge [m]; default 0 for a surface gauge, the target depth for a
        bottom-hole record and the reference depth (vertical well) for a downhole gauge.
    mud_density : float, optional
        Well-fluid density [kg/m^3]; default: the median of the record's density series, else
        1000 kg/m^3 (stated in the assumptions).
    pore_pressure : float, optional
        Formation pore pressure at target depth [Pa]; default hydrostatic with 1030 kg/m^3.
    sv : float, optional
        Vertical stress at target depth [Pa]; default 22.6 kPa/m (2.3 sg) times the depth.
    mu : float
        Friction coefficient for the stress polygon.
    """

    target_tvd: float | None = None
    gauge_tvd: float | None = None
    mud_density: float | None = None
    pore_pressure: float | None = None
    sv: float | None = None
    mu: float = 0.6

    def __post_init__(self) -> None:
        for key in ("target_tvd", "gauge_tvd", "mud_density", "pore_pressure", "sv"):
            v = getattr(self, key)
            if v is not None and not (math.isfinite(v) and v >= 0):
                raise InputError(f"{v!r} is not a non-negative number", key=key,
                                 expected="a finite value >= 0")
        if not (0.0 < self.mu < 2.0):
            raise InputError(f"friction coefficient {self.mu!r} is implausible", key="mu",
                             expected="0 < mu < 2 (typically 0.6)")


@dataclass(frozen=True)
class StressSummary:
    """Stress estimates from a record's picks.

    Attributes
    ----------
    available : bool
        False when the picks or inputs do not allow a stress estimate (``message`` says why).
    message : str
    target_tvd : float or None
        [m].
    sigma_h, sigma_h_low, sigma_h_high : float or None
        Minimum horizontal stress and interval [Pa] at target depth.
    t0, t0_low, t0_high : float or None
        Tensile strength ``FBP - Pr`` [Pa].
    sigma_H : dict
        Per equation (``"C.19"``...) the estimate ``{"value", "low", "high", "message"}`` [Pa].
    pore_pressure, sv : float or None
        Used values [Pa].
    pore_pressure_low, pore_pressure_high : float or None
        Interval of the pore pressure [Pa] when it came from the after-closure analysis.
    pore_pressure_source : {"default", "given", "after-closure"}
        Where the pore pressure came from.
    mu : float
    regime : str or None
        Faulting regime of the estimate in the stress polygon.
    assumptions : tuple of str
        Every default that was used.
    source_cycle : int or None
        The agreeing cycle whose closure is nearest the record's (for reports naming one).
    omitted : tuple of str
        What the estimate left out and why (sigma_H, the stress polygon's regime), in
        words.
    source_cycles : tuple of int
        The cycles whose closures agree and gave sigma_h
        (:func:`~xlotkit.interpret.picks.agreement.agree_closures`).
    outliers : tuple of (int, str)
        Cycles with a closure that disagrees, each with its reason.
    sigma_h_message : str
        How sigma_h was formed from the cycles.
    """

    available: bool
    message: str = ""
    target_tvd: float | None = None
    sigma_h: float | None = None
    sigma_h_low: float | None = None
    sigma_h_high: float | None = None
    t0: float | None = None
    t0_low: float | None = None
    t0_high: float | None = None
    sigma_H: dict = field(default_factory=dict)
    pore_pressure: float | None = None
    sv: float | None = None
    mu: float = 0.6
    regime: str | None = None
    assumptions: tuple[str, ...] = ()
    source_cycle: int | None = None
    estimates: Any = None
    pore_pressure_low: float | None = None
    pore_pressure_high: float | None = None
    pore_pressure_source: str = "default"
    omitted: tuple[str, ...] = ()
    source_cycles: tuple[int, ...] = ()
    outliers: tuple[tuple[int, str], ...] = ()
    sigma_h_message: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict in field units (bar, m, sg)."""

        def bar(x):
            return None if x is None or not math.isfinite(x) else round(float(x) / _BAR, 4)

        emw = None
        if self.sigma_h is not None and self.target_tvd:
            emw = round(self.sigma_h / (GRAVITY * self.target_tvd) / 1000.0, 4)
        return {
            "available": self.available,
            "message": self.message,
            "target_tvd_m": self.target_tvd,
            "source_cycle": self.source_cycle,
            "source_cycles": list(self.source_cycles),
            "outlier_cycles": [{"cycle": i, "reason": why} for i, why in self.outliers],
            "sigma_h_message": self.sigma_h_message,
            "sigma_h_bar": bar(self.sigma_h),
            "sigma_h_low_bar": bar(self.sigma_h_low),
            "sigma_h_high_bar": bar(self.sigma_h_high),
            "sigma_h_emw_sg": emw,
            "t0_bar": bar(self.t0),
            "t0_low_bar": bar(self.t0_low),
            "t0_high_bar": bar(self.t0_high),
            "sigma_H": {k: {"value_bar": bar(v["value"]), "low_bar": bar(v["low"]),
                            "high_bar": bar(v["high"]), "message": v["message"]}
                        for k, v in self.sigma_H.items()},
            "pore_pressure_bar": bar(self.pore_pressure),
            "pore_pressure_low_bar": bar(self.pore_pressure_low),
            "pore_pressure_high_bar": bar(self.pore_pressure_high),
            "pore_pressure_source": self.pore_pressure_source,
            "sv_bar": bar(self.sv),
            "mu": self.mu,
            "regime": self.regime,
            "assumptions": list(self.assumptions),
            "omitted": list(self.omitted),
        }


def _gauge(record: Record, p: float | None) -> float | None:
    """Pick value on an absolute reference -> gauge (relative to atmosphere)."""
    if p is None:
        return None
    return p - ATMOSPHERE_PA if record.reference.absolute else p


def estimate_stress(record_picks, inputs: StressInputs | None = None,
                    diagnostics=None) -> StressSummary:
    """Turn a record's picks into sigma_h, T0, sigma_H and a faulting regime.

    sigma_h is the record's closure from the test cycles that agree
    (:func:`~xlotkit.interpret.picks.agreement.agree_closures`: the largest group of cycles
    whose closure intervals share a pressure, the median of their closures and the union of
    their intervals; every other cycle is named as an outlier with its reason), moved to
    the target depth with the well-fluid hydrostatics (:class:`~xlotkit.interpret.stress.
    DepthModel`; closure picks are static pressures, so no friction). T0 = FBP - Pr. sigma_H
    from Eq. C.19 (reopening) with Monte-Carlo intervals; the estimate is placed in the stress
    polygon for ``mu``.

    The pore pressure is, in order: the one given in ``inputs``; the reservoir pressure of
    the after-closure analysis (``diagnostics``, :func:`xlotkit.interpret.diagnostics.
    diagnose_record`) moved to the target depth, with its interval (a triangular
    distribution in the Monte-Carlo of sigma_H); else hydrostatic with 1.03 sg. The
    assumptions say which, and why the analysis did not give one.

    Parameters
    ----------
    record_picks : RecordPicks
    inputs : StressInputs, optional
    diagnostics : RecordDiagnostics, optional

    Returns
    -------
    StressSummary
    """
    from xlotkit.interpret import stress as st
    from xlotkit.interpret.picks.core import breakdown_and_reopening

    inputs = inputs or StressInputs()
    record = record_picks.record
    ref = record.reference
    assumptions: list[str] = []

    agreement = record_picks.consistency.closure
    if agreement is None or not agreement.found:
        return StressSummary(False, "no fracture closure was picked in any test cycle")

    target = inputs.target_tvd
    if target is None:
        if ref.kind in ("bottomhole", "downhole") and ref.depth_m is not None:
            target = float(ref.depth_m)
            assumptions.append(f"target depth = reference depth {target:g} m "
                               "(vertical well, gauge at the open hole)")
        else:
            return StressSummary(False, "give the target TVD (--tvd) to turn surface pressures "
                                        "into stresses")
    gauge_tvd = inputs.gauge_tvd
    if gauge_tvd is None:
        if ref.kind == "surface":
            gauge_tvd = 0.0
        elif ref.depth_m is not None:
            gauge_tvd = float(ref.depth_m)
            if ref.kind == "downhole":
                assumptions.append(f"gauge TVD = gauge MD {gauge_tvd:g} m (vertical well)")
        else:
            gauge_tvd = target
    gauge_tvd = min(gauge_tvd, target)
    rho = inputs.mud_density
    if rho is None:
        if record.density is not None and np.any(np.isfinite(record.density)):
            rho = float(np.nanmedian(record.density))
            assumptions.append(f"well-fluid density = median of the log, {rho / 1000:.3f} sg")
        else:
            rho = 1000.0
            assumptions.append("well-fluid density 1.00 sg (not in the log; give --mud-density)")
    model = st.DepthModel(target_tvd=target, gauge_tvd=gauge_tvd, mud_density=rho)
    dp = float(model.hydrostatic)

    def at_depth(p):
        return None if p is None else _gauge(record, p) + dp

    sh = at_depth(agreement.value)
    sh_lo = at_depth(agreement.low)
    sh_hi = at_depth(agreement.high)
    if len(agreement.cycles) > 1 or agreement.outliers:
        assumptions.append("sigma_h from the cycles that agree: " + agreement.message)

    p0 = inputs.pore_pressure
    p0_lo = p0_hi = None
    p0_src = "given"
    p0_u = None
    if p0 is None:
        best = diagnostics.reservoir_pressure if diagnostics is not None else None
        if best is not None:
            cyc, ac = best
            p0, p0_lo, p0_hi = at_depth(ac.reservoir_pressure), at_depth(ac.low), \
                at_depth(ac.high)
            p0_src = "after-closure"
            name = "exponential approach" if ac.regime == "exponential" else \
                f"{ac.regime} flow"
            assumptions.append(
                f"pore pressure {p0 / _BAR:.1f} bar [{p0_lo / _BAR:.1f} - {p0_hi / _BAR:.1f}] "
                f"({100 * ac.level:.0f} % interval) at target depth from the after-closure "
                f"analysis of cycle {cyc} ({name}), replacing the default 1.03 sg gradient")
            p0_u = st.Uncertain(p0, low=min(p0_lo, p0), high=max(p0_hi, p0))
        else:
            p0 = 1030.0 * GRAVITY * target
            p0_src = "default"
            why = ""
            if diagnostics is not None and diagnostics.cycles:
                why = "; " + "; ".join(f"cycle {c.cycle}: {c.after_closure.message}"
                                       for c in diagnostics.cycles)
            assumptions.append("pore pressure hydrostatic, 1.03 sg" + why)
    sv = inputs.sv
    if sv is None:
        sv = 2300.0 * GRAVITY * target
        assumptions.append("vertical stress 2.30 sg (22.6 kPa/m)")

    t0 = record_picks.t0
    t0v = t0.value if t0.found else None
    sigma_H: dict[str, dict[str, Any]] = {}
    estimates = None
    # the reopening pressure of the same test as the breakdown (not of another operation)
    _, pr = breakdown_and_reopening(record_picks.cycles)
    if pr is None:
        pr = next((c.get("Pr") for c in record_picks.test_cycles[1:]
                   if c.get("Pr") is not None and c.get("Pr").found), None)
    regime = None
    omitted: list[str] = []
    p0_words = {"given": "given", "after-closure": "from the after-closure analysis",
                "default": "hydrostatic 1.03 sg default"}[p0_src]
    if pr is None:
        omitted.append("sigma_H and the faulting regime: no reopening pressure Pr was picked "
                       "in a later cycle (Eq. C.19 needs it)")
    elif not sh > p0:
        omitted.append(f"sigma_H and the faulting regime: sigma_h {sh / _BAR:.1f} bar is not "
                       f"above the pore pressure {p0 / _BAR:.1f} bar ({p0_words}); Eq. C.19 "
                       "and the stress polygon need sigma_h > p0 (give --pore-gradient if the "
                       "pore pressure is known)")
    if pr is not None and sh is not None and sh > p0:
        pr_u = st.Uncertain(at_depth(pr.value),
                            low=at_depth(pr.low if pr.low is not None else pr.value),
                            high=at_depth(pr.high if pr.high is not None else pr.value))
        sh_u = st.Uncertain(sh, low=min(sh_lo, sh), high=max(sh_hi, sh))
        try:
            estimates = st.sigma_H_estimates(sh_u, p0=p0_u if p0_u is not None else p0,
                                             pr=pr_u)
            for eq, est in estimates.items():
                sigma_H[eq] = {"value": est.value, "low": est.low, "high": est.high,
                               "message": est.message}
        except InputError as exc:
            sigma_H["C.19"] = {"value": float("nan"), "low": float("nan"),
                               "high": float("nan"), "message": str(exc)}
    if sigma_H and sh is not None and sv > p0:
        best = next(iter(sigma_H.values()))["value"]
        if math.isfinite(best):
            poly = st.stress_polygon(sv, p0, inputs.mu)
            lo_s, hi_s = sorted((sh, best))
            regime = poly.classify(lo_s, hi_s).regime
        else:
            omitted.append("the faulting regime: sigma_H could not be computed "
                           f"({next(iter(sigma_H.values()))['message']})")
    elif sigma_H and not sv > p0:
        omitted.append(f"the faulting regime: the vertical stress {sv / _BAR:.1f} bar is not "
                       f"above the pore pressure {p0 / _BAR:.1f} bar ({p0_words}), so there "
                       "is no stress polygon")
    return StressSummary(
        True, "", target, sh, sh_lo, sh_hi,
        t0v, t0.low if t0.found else None, t0.high if t0.found else None,
        sigma_H, p0, sv, inputs.mu, regime, tuple(assumptions), agreement.representative,
        estimates, p0_lo, p0_hi, p0_src, tuple(omitted), agreement.cycles,
        agreement.outliers, agreement.message,
    )
