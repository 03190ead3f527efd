"""Fracture measures of a coupled state: failed counts, wing lengths, azimuth, volume.

Pure functions of a :class:`CoupledState` and its model (no solver state).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from xlotkit.sim.coupling.model import CoupledModel, CoupledState
from xlotkit.sim.mechanics import FAILED_SHEAR, FAILED_TENSILE, PRESET
from xlotkit.sim.mechanics.breakdown import crack_geometry

__all__ = ["FractureSummary", "fracture_summary"]


@dataclass(frozen=True)
class FractureSummary:
    """Fracture measures of one state.

    Attributes
    ----------
    n_failed, n_tensile, n_shear : int
        Failed clusters (tensile + shear + preset), and by mode.
    n_connected : int
        Failed clusters of the hole-connected crack (sharing nodes with a chain reaching
        the wall).
    azimuth_deg : float
        Direction of the crack's principal axis [deg] in ``(-90, 90]`` (principal axis of
        the connected clusters' centroids about the hole centre, area weighted; ``nan``
        without a crack).
    wing_lengths : tuple of float
        ``(L+, L-)`` [m]: for each side of the hole along the principal axis, the largest
        distance from the wall (``|x| - a``) of a connected cluster's centroid.
    length : float
        Tip-to-tip length ``L+ + L- + 2 a`` [m] (0 without a crack).
    volume : float
        Pore volume opened by the failed clusters since they failed,
        ``sum (V^x - V^x_at_failure)`` [m^3] (for the segment height).
    max_opening : float
        Largest crack opening ``w_n`` of a failed cluster [m].
    mouth_opening : float
        Largest crack opening of a connected cluster touching the hole wall [m].
    """

    n_failed: int
    n_tensile: int
    n_shear: int
    n_connected: int
    azimuth_deg: float
    wing_lengths: tuple
    length: float
    volume: float
    max_opening: float
    mouth_opening: float


def fracture_summary(model: CoupledModel, state: CoupledState) -> FractureSummary:
    """Fracture measures of ``state`` (see :class:`FractureSummary`)."""
    mech = model.mechanics
    mesh = model.mesh
    cs = state.cluster_state
    cracked = (cs == FAILED_TENSILE) | (cs == FAILED_SHEAR) | (cs == PRESET)
    ms = state.mechanics
    gap = np.zeros((len(cs), 3)) if ms is None else np.asarray(ms.gap)
    _, _, wn, _ = model.crack_permeability(cs, gap, None if ms is None else ms.slip)
    vol = float(np.sum((np.asarray(state.flow.extra_pore_volume)
                        - np.asarray(state.failure_volume))[cracked]))
    n_t = int(np.sum(cs == FAILED_TENSILE))
    n_s = int(np.sum(cs == FAILED_SHEAR))
    if not cracked.any():
        return FractureSummary(0, 0, 0, 0, math.nan, (0.0, 0.0), 0.0, 0.0, 0.0, 0.0)
    connected, _, _ = crack_geometry(mech, cs)
    centre = (np.zeros(2) if mesh.hole_center is None
              else np.asarray(mesh.hole_center, dtype=float))
    a = 0.0 if mesh.hole_radius is None else float(mesh.hole_radius)
    idx = np.flatnonzero(connected)
    wall = np.zeros(mesh.n_nodes, dtype=bool)
    wall[mesh.hole_nodes] = True
    if idx.size == 0:
        return FractureSummary(int(cracked.sum()), n_t, n_s, 0, math.nan, (0.0, 0.0), 0.0,
                               vol, float(np.max(wn)), 0.0)
    xc = mesh.centroids[idx] - centre
    w = mesh.areas[idx]
    S = (xc * w[:, None]).T @ xc
    evals, evecs = np.linalg.eigh(S)
    d = evecs[:, np.argmax(evals)]
    ang = math.degrees(math.atan2(d[1], d[0]))
    if ang <= -90.0:
        ang += 180.0
    elif ang > 90.0:
        ang -= 180.0
    d = np.array([math.cos(math.radians(ang)), math.sin(math.radians(ang))])
    proj = xc @ d
    r = np.hypot(xc[:, 0], xc[:, 1]) - a
    lp = float(np.max(r[proj > 0], initial=0.0))
    lm = float(np.max(r[proj <= 0], initial=0.0))
    on_wall = wall[mesh.triangles[idx]].any(axis=1)
    mouth = float(np.max(wn[idx][on_wall], initial=0.0))
    return FractureSummary(int(cracked.sum()), n_t, n_s, int(idx.size), ang, (lp, lm),
                           lp + lm + 2 * a, vol, float(np.max(wn)), mouth)
