"""DFIT-grade diagnostics of shut-in declines (thesis App. C).

Submodules
----------
gfunction
    G dP/dG, its straight line through the origin, closure at the departure, and the
    leak-off diagnosis from its shape (normal, pressure-dependent leak-off, tip extension,
    height recession).
loglog
    dp and its Bourdet derivative against dt with the flow-regime slopes.
after_closure
    Nolte's linear- and radial-flow time functions (and an exponential approach), the
    reservoir pressure from their extrapolation with an interval, or "after-closure flow
    not reached" with why.
core
    All of it for every cycle of a record (:func:`diagnose_record`).
"""

from xlotkit.interpret.diagnostics.core import (
    CycleDiagnostics,
    RecordDiagnostics,
    diagnose_cycle,
    diagnose_record,
)

__all__ = ["CycleDiagnostics", "RecordDiagnostics", "diagnose_cycle", "diagnose_record"]
