"""The well's completion and its storage compliance (thesis App. B.1, SPEC §5).

SI units, gauge pressures. ::

    C_w = c_f * V_fluid  [+ C_casing + C_pipe]          [m^3/Pa]
    V_fluid = L_c (pi/4) (D_csg^2 - D_po^2 + D_pi^2) + L_oh pi r_oh^2

with ``L_c`` the cased length (the drill pipe hangs over the cased length, open ended, so
both its bore and the annulus are filled), ``L_oh`` / ``r_oh`` the open-hole segment. Optional
steel terms: thin-walled, unconstrained casing under internal pressure (hoop strain
``dD/D = p D / (2 t E)``, so ``dA/A = p D / (t E)``), and compression of the drill-pipe steel,
which has well pressure on both sides (``dV_s/V_s = 3 (1 - 2 nu) p / E``). Cemented casing
is held by the formation; the casing term is then an upper bound and off by default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from xlotkit.checks import check_range as _check
from xlotkit.sim.well.column import INCH, WATER_COMPRESSIBILITY, Column

__all__ = ["INCH", "Completion", "well_compliance"]

@dataclass(frozen=True, kw_only=True)
class Completion:
    """Well completion above and including the open-hole segment (SI).

    Attributes
    ----------
    casing_id : float
        Casing inner diameter [m] (thesis: 12.715" for 13-3/8" casing).
    pipe_od, pipe_id : float
        Drill-pipe outer and inner diameter [m] (thesis: 5" / 4.276"). ``pipe_od = 0`` for a
        well without pipe in the hole.
    length_md : float
        Measured depth of the bottom of the open hole [m].
    depth_tvd : float or None
        True vertical depth of the open-hole segment [m]; None means vertical (= length_md).
    open_hole_length : float
        Length of new formation drilled below the shoe [m] (thesis: 10 m).
    open_hole_radius : float
        Radius of the open hole [m].
    compressibility : float
        Fluid compressibility c_f = 1/K_f [1/Pa].
    expansion : bool
        Add casing expansion and drill-pipe steel compression to the compliance.
    casing_od : float or None
        Casing outer diameter [m], needed when ``expansion`` is on.
    steel_modulus, steel_poisson : float
        Young's modulus [Pa] and Poisson's ratio of the steel.
    roughness : float
        Absolute pipe roughness [m] for the turbulent friction factor.
    """

    casing_id: float = 12.715 * INCH
    pipe_od: float = 5.0 * INCH
    pipe_id: float = 4.276 * INCH
    length_md: float = 2000.0
    depth_tvd: float | None = None
    open_hole_length: float = 10.0
    open_hole_radius: float = 0.15
    compressibility: float = WATER_COMPRESSIBILITY
    expansion: bool = False
    casing_od: float | None = None
    steel_modulus: float = 200e9
    steel_poisson: float = 0.3
    roughness: float = 4.6e-5

    def __post_init__(self) -> None:
        _check("completion.casing_id", self.casing_id, lo=0.0, hi=2.0, lo_open=True)
        _check("completion.pipe_od", self.pipe_od, lo=0.0, hi=self.casing_id, hi_open=True)
        _check("completion.pipe_id", self.pipe_id, lo=0.0, hi=self.pipe_od if self.pipe_od > 0
               else self.casing_id, lo_open=True, hi_open=self.pipe_od > 0)
        _check("completion.length_md", self.length_md, lo=0.0, hi=20000.0, lo_open=True)
        _check("completion.depth_tvd", self.depth_tvd, lo=0.0, hi=self.length_md,
               allow_none=True)
        _check("completion.open_hole_length", self.open_hole_length, lo=0.0,
               hi=self.length_md, hi_open=True)
        _check("completion.open_hole_radius", self.open_hole_radius, lo=0.0, hi=2.0,
               lo_open=True)
        _check("completion.compressibility", self.compressibility, lo=0.0, hi=1e-6)
        _check("completion.steel_modulus", self.steel_modulus, lo=1e9, hi=1e12)
        _check("completion.steel_poisson", self.steel_poisson, lo=0.0, hi=0.5, hi_open=True)
        _check("completion.roughness", self.roughness, lo=0.0, hi=0.01)
        if self.expansion:
            _check("completion.casing_od", self.casing_od, lo=self.casing_id, hi=3.0,
                   lo_open=True)

    @property
    def tvd(self) -> float:
        """True vertical depth of the open-hole segment [m]."""
        return self.length_md if self.depth_tvd is None else float(self.depth_tvd)

    @property
    def cased_length(self) -> float:
        """Measured length from surface to the casing shoe [m]."""
        return self.length_md - self.open_hole_length

    def fluid_volume(self) -> float:
        """Fluid volume in the well: pipe bore, annulus and open hole [m^3]."""
        a_csg = math.pi / 4.0 * self.casing_id**2
        a_steel = math.pi / 4.0 * (self.pipe_od**2 - self.pipe_id**2) if self.pipe_od > 0 else 0.0
        return (a_csg - a_steel) * self.cased_length + (
            math.pi * self.open_hole_radius**2 * self.open_hole_length)

    def column(self, *, density: float, viscosity: float = 0.01,
               compressibility: float | None = None) -> Column:
        """The fluid column from surface to the open hole, through the drill pipe.

        It spans the whole measured depth and TVD, so its bottom pressure is at the open
        hole; friction is charged at the pipe bore over the whole length (the few metres of
        open hole below the pipe shoe change it by well under 1 %).
        """
        return Column(
            length_md=self.length_md, tvd=self.tvd,
            pipe_id=self.pipe_id, roughness=self.roughness, density=density,
            compressibility=self.compressibility if compressibility is None else compressibility,
            viscosity=viscosity)


def well_compliance(completion: Completion) -> float:
    """Storage compliance of the well, dV/dp at constant fluid mass [m^3/Pa].

    ``C_w = c_f V_fluid`` plus, when ``completion.expansion`` is on, the thin-wall casing term
    ``A_csg L_c D_csg / (t E)`` (``t = (OD - ID)/2``) and the pipe-steel compression term
    ``V_steel 3 (1 - 2 nu) / E``.

    Parameters
    ----------
    completion : Completion

    Returns
    -------
    float
        Compliance [m^3/Pa] (multiply by 1e9 for l/MPa).
    """
    c = completion.compressibility * completion.fluid_volume()
    if completion.expansion:
        assert completion.casing_od is not None
        e_s = completion.steel_modulus
        t_wall = 0.5 * (completion.casing_od - completion.casing_id)
        a_csg = math.pi / 4.0 * completion.casing_id**2
        c += a_csg * completion.cased_length * completion.casing_id / (t_wall * e_s)
        if completion.pipe_od > 0:
            v_steel = math.pi / 4.0 * (completion.pipe_od**2 - completion.pipe_id**2) * (
                completion.cased_length)
            c += v_steel * 3.0 * (1.0 - 2.0 * completion.steel_poisson) / e_s
    return c


