"""DFIT-grade diagnostics of every shut-in of a record, and the reservoir pressure they give.

:func:`diagnose_record` runs, for each LOT/XLOT cycle with a shut-in, the G-function
diagnosis (:mod:`.gfunction`), the log-log flow regimes (:mod:`.loglog`) and the
after-closure analysis (:mod:`.after_closure`), on the cycle's closure: the consensus FCP
when it lies inside the shut-in, else the G-function pick. The record's reservoir pressure
(:attr:`RecordDiagnostics.reservoir_pressure`) is the best after-closure result: radial
flow before linear flow before the exponential approach (the more developed the regime,
the less the intercept depends on the closure time), then the narrower interval.
"""

from __future__ import annotations

from dataclasses import dataclass

from xlotkit.interpret.diagnostics.after_closure import AfterClosureResult, after_closure_analysis
from xlotkit.interpret.diagnostics.gfunction import GFunctionDiagnosis, diagnose_g_function
from xlotkit.interpret.diagnostics.loglog import LogLogDiagnostics, loglog_diagnostics
from xlotkit.interpret.picks.types import Pick

__all__ = ["CycleDiagnostics", "RecordDiagnostics", "diagnose_cycle", "diagnose_record"]

_REGIME_RANK = {"radial": 0, "linear": 1, "exponential": 2}


@dataclass(frozen=True)
class CycleDiagnostics:
    """The diagnostics of one cycle's shut-in.

    Attributes
    ----------
    cycle : int
        Cycle index.
    closure : Pick or None
        The closure the diagnostics used.
    g_function : GFunctionDiagnosis or None
    loglog : LogLogDiagnostics or None
    after_closure : AfterClosureResult
    """

    cycle: int
    closure: Pick | None
    g_function: GFunctionDiagnosis | None
    loglog: LogLogDiagnostics | None
    after_closure: AfterClosureResult

    def report(self) -> str:
        """The cycle's diagnostics in words."""
        parts = [f"cycle {self.cycle}:"]
        if self.g_function is not None:
            parts.append(self.g_function.report())
        if self.loglog is not None:
            parts.append(self.loglog.report() + ".")
        parts.append(self.after_closure.report() + ".")
        return " ".join(parts)


@dataclass(frozen=True)
class RecordDiagnostics:
    """Diagnostics of every shut-in of a record."""

    cycles: tuple[CycleDiagnostics, ...]

    @property
    def reservoir_pressure(self) -> tuple[int, AfterClosureResult] | None:
        """``(cycle, result)`` of the best after-closure result, None if none was reached."""
        found = [(c.cycle, c.after_closure) for c in self.cycles
                 if c.after_closure.reached and c.after_closure.reservoir_pressure is not None]
        if not found:
            return None
        return min(found, key=lambda x: (_REGIME_RANK.get(x[1].regime, 9),
                                         x[1].high - x[1].low))

    def cycle(self, index: int) -> CycleDiagnostics | None:
        """The diagnostics of cycle ``index``, or None."""
        return next((c for c in self.cycles if c.cycle == index), None)

    def report(self) -> str:
        """All cycles, one line each."""
        return "\n".join(c.report() for c in self.cycles) or "no shut-in to diagnose"


def _closure_in_shutin(cp) -> Pick | None:
    from xlotkit.interpret.picks.pressurisation import shutin_phase

    sh = shutin_phase(cp.cycle)
    if sh is None:
        return None
    for pk in (cp.fcp, cp.get("FCP", "g_function")):
        if pk is not None and pk.found and pk.t is not None \
                and sh.t_start <= pk.t <= sh.t_end:
            return pk
    return None


def diagnose_cycle(record, cycle_picks) -> CycleDiagnostics | None:
    """Diagnostics of one cycle (None when it has no shut-in after pumping)."""
    from xlotkit.interpret.picks.pressurisation import shutin_phase

    if shutin_phase(cycle_picks.cycle) is None:
        return None
    closure = _closure_in_shutin(cycle_picks)
    isip = cycle_picks.get("ISIP")
    isip = isip if isip is not None and isip.found else None
    g = diagnose_g_function(record, cycle_picks.cycle, closure)
    ll = loglog_diagnostics(record, cycle_picks.cycle, isip=isip, closure=closure)
    if closure is None and cycle_picks.fcp is not None and cycle_picks.fcp.found:
        ac = AfterClosureResult(False, None, "after-closure flow not reached: closure came "
                                "outside the shut-in (in the flowback), so the shut-in holds "
                                "no after-closure decline")
    else:
        ac = after_closure_analysis(record, cycle_picks.cycle, closure, isip)
    return CycleDiagnostics(cycle_picks.index, closure, g, ll, ac)


def diagnose_record(record_picks) -> RecordDiagnostics:
    """Diagnostics of every LOT/XLOT cycle with a shut-in."""
    out = []
    for cp in record_picks.test_cycles:
        d = diagnose_cycle(record_picks.record, cp)
        if d is not None:
            out.append(d)
    return RecordDiagnostics(tuple(out))
