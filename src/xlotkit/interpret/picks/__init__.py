"""Picks of characteristic XLOT pressures, each with an interval, a window and a quality.

Submodules
----------
models
    Fit models in the style of lmfit (model functions with a ``guess``).
pressurisation
    LOP (with system stiffness), FBP, reopening pressure, FPP, ISIP.
shutin
    Fracture closure from a shut-in decline: tangents, sqrt(t), G-function, bilinear, compliance.
flowback
    Fracture closure from a flowback through a fixed choke (system stiffness approach).
"""

from xlotkit.interpret.picks.types import Pick, PickQuality

__all__ = ["Pick", "PickQuality"]
