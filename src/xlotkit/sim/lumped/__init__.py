r"""Lumped XLOT model: well storage + an LEFM fracture + Carter leak-off + a surface choke.

A quick what-if tool and the test bed for the pick algorithms: one bottom-hole pressure
``p(t)`` for the whole well (hydraulic equilibrium, thesis 4.5.1), one fracture size ``L(t)``.
SI units; all pressures are gauge.

Physics
-------
*Volume balance.* With all volumes at reference density (mass / rho0), the well stores
``C_w (p - p_init)`` and the fracture ``V_f``; fluid is pumped in (``Q_in``), returned at
surface (``Q_ret``) and leaks off (``Q_leak``)::

    C_w dp/dt + dV_f/dt = Q_in - Q_ret - Q_leak                                  (1)

*Breakdown.* No fracture until ``p`` reaches the Hubbert–Willis pressure (thesis Eq. C.11)::

    P_b = 3 sigma_h - sigma_H - p_0 + T_0                                         (2)

Then a flaw of size ``L_0`` (default: the hole radius) becomes a fracture against
``sigma_h``; the tensile strength is spent and never comes back.

*Fracture (Sneddon, LEFM).* Net pressure ``dp = max(p - sigma_h, 0)``, plane-strain modulus
``E' = E / (1 - nu^2)``:

=========  ================================  ==================================
geometry   opening volume V_f                 stress intensity K_I
=========  ================================  ==================================
``kgd``    ``2 pi h L^2 dp / E'``              ``dp sqrt(pi L)``
``penny``  ``16 R^3 dp / (3 E')``              ``(2/pi) dp sqrt(pi R)``
=========  ================================  ==================================

``L`` is the KGD half-length (height ``h``), ``R`` the penny radius. (Sneddon's plane-strain
volume for half-length ``L`` is ``2 pi h L^2 dp / E'``; the penny stiffness
``dp/dV = 3E'/(16R^3)`` is thesis Eq. C.3.) Growth is quasi-static:
``K_I <= K_Ic`` always, ``L`` grows only while ``K_I = K_Ic``, and never shrinks. On the
growth (critical) branch ``dp = dp_c(L)`` with ``dp_c = K_Ic / sqrt(pi L)`` (KGD) or
``(K_Ic/2) sqrt(pi/R)`` (penny). Below ``sigma_h`` the fracture is mechanically closed
(``V_f = 0``), so the system compliance drops from ``C_w + dV_f/dp`` to ``C_w`` exactly at
``p_f = sigma_h``; it propagates again at ``sigma_h + dp_c(L)`` once reopened.

*Reopening.* ``reopening="wellbore"`` (default): the mouth of a closed fracture lies in the
borehole wall, whose hoop stress holds it shut until the well pressure reaches (thesis
Eq. C.13, no tensile strength left)::

    P_r = max(sigma_h, 3 sigma_h - sigma_H - p_0)                                 (3)

Between closure and ``P_r`` the fracture is *sealed*: no fracture compliance, and no Carter
leak from its faces (a closed fracture holds no fluid to leak; the open-hole wall leak ``J``
goes on). At ``P_r`` it reopens at its old size under net pressure ``P_r - sigma_h``; the
well's excess fills it at constant stored volume (the breakdown jump's zero-time step: at
fixed ``L`` if ``K_I <= K_Ic``, else growing to ``W(L_j) = W``): a reopening peak, then a
drop towards propagation, and ``FBP - P_r = T_0``. ``reopening="sigma_h"``: reopens as
soon as ``p_f`` exceeds ``sigma_h`` (no peak).

*Entry loss.* A near-wellbore (tortuosity) loss between well and fracture while the
fracture takes fluid at ``Q_f`` (``nwb_coefficient`` ``k``)::

    p = p_f + k max(Q_f, 0)^2,      Q_f = dV_f/dt + Q_Carter                      (4)

``p`` (well, bottom hole) drives the well storage, the choke and the wall leak; ``p_f``
(fracture mouth) drives ``V_f``, ``K_I`` and closure. At shut-in the well drains the loss
into the fracture in about ``2 C_w k Q_f`` (a few seconds): the ISIP lies ``k Q_f^2`` below
the last pumping pressure. Returning flow (``Q_f < 0``) is taken as unrestricted, so
flowback stiffness and closure are unaffected. Instantaneous jumps (breakdown, reopening)
are taken without the loss (they are equilibrium jumps of the whole system).

*Stability and the breakdown drop.* Along the critical branch the stored volume
``W(L) = C_w (sigma_h + dp_c(L)) + V_f(dp_c(L), L)`` falls with ``L`` while
``L < L_s`` and rises beyond, with ``L_s^2 = C_w E' / (6 pi h)`` (KGD) and
``L_s^3 = 3 C_w E' / 80`` (penny). A fracture shorter than ``L_s`` that reaches ``K_Ic``
cannot be held by the well: it jumps, at constant ``W`` (no time passes), to the length
``L_j > L_s`` with ``W(L_j) = W`` before the jump. That is formation breakdown: FBP, an
instantaneous pressure drop, then stable propagation (FPP slowly falling as ``L`` grows),
all from Eq. (1)–(2).

*Leak-off.* Carter leak-off from both faces of the area opened so far (area per face
``2 L h`` KGD, ``pi R^2`` penny); an element opened at ``tau`` leaks
``C_L / sqrt(t - tau)`` per unit area. The opening time of every area increment is kept
(the area is taken to grow linearly over a step, which makes the per-step integrals exact:
``(4/3) C_L dA sqrt(dt)`` for the new area). Leak-off only acts while the fracture is
open (``p > sigma_h``); the exposure clock keeps running while it is closed. An optional
wall leak ``Q_w = J (p - p_0)`` stands for a small constant-permeability open-hole wall
(see :func:`wall_leak_index`).

*Surface.* ``p_s`` follows from ``p`` through the fluid column with ``rho(p)`` and optional
pipe friction (:mod:`xlotkit.sim.well`). Flowback through a fixed choke returns
``Q_ret = zeta sqrt(p_s)`` (thesis Eq. 4.24), with ``p_s`` solved together with the friction
of the returning flow.

Numerics
--------
Each step solves Eq. (1) in integrated form (backward for the state, trapezoidal for the
choke and wall-leak rates, exact for the pump and Carter terms)::

    C_w (p' - p) + V_f' - V_f + dt (Q_ret + Q_ret')/2 + dt (Q_w + Q_w')/2
        + dV_Carter - dV_in = 0,        p' = p_f' + k (x/dt)^2,  x = V_f' - V_f + dV_Carter

for one scalar: ``p_f'`` on the elastic branch (``L' = L``), or ``ln L'`` on the critical
branch. With the entry loss on, ``p_f'`` and ``ln L'`` are ill-conditioned over short
(event) steps, so the unknown is then ``p'`` on the elastic branch (``x`` follows from the
quadratic ``k x^2/dt^2 + x/C_f = p' - sigma_h - (V_f - dV_Carter)/C_f``) and ``x`` on the
critical branch (``L'`` from the volume by Newton). All residuals are monotone, solved with
Brent's method to round-off, so the volume balance
closes to ~1e-12 relative every step (reported in ``truth["mass_balance_error"]``). The step
is adaptive (well and fracture pressure change per step <= ``dp_max``), never longer than
the output interval, and ends exactly on every output sample. Events are located to 1e-9 s:
breakdown, closure at ``sigma_h`` (on ``p_f``), reopening (``p`` at ``P_r``, or ``p_f`` at
``sigma_h``), and phase ends on pressure or volume; phase durations and rate steps are step
boundaries.

Layout of the package
---------------------
* :mod:`~xlotkit.sim.lumped.physics` -- the fracture and leak-off closed forms;
* :mod:`~xlotkit.sim.lumped.solver` -- one step's solution and event location;
* :mod:`~xlotkit.sim.lumped.engine` -- :class:`LumpedEngine` (the engine contract of
  :mod:`xlotkit.sim.run`, its step rules in :class:`LumpedStepControl`) and
  :func:`simulate_lumped`;
* :mod:`~xlotkit.sim.lumped.results` -- the run's events and the clean record.

Its configuration, :class:`LumpedScene` (and the older lumped file layout), is in
:mod:`xlotkit.sim.scene.lumped`.
"""

from xlotkit.sim.lumped.engine import (
    LumpedEngine,
    LumpedResult,
    LumpedStepControl,
    StepOutcome,
    simulate_lumped,
)
from xlotkit.sim.lumped.physics import (
    breakdown_pressure,
    critical_net_pressure,
    fracture_compliance,
    fracture_face_area,
    fracture_volume,
    reopening_pressure,
    stable_length,
    stress_intensity,
    wall_leak_index,
)
from xlotkit.sim.scene.lumped import (
    NWB_DEFAULT,
    LumpedScene,
    load_lumped_scene,
    standard_lumped_scene,
)

__all__ = [
    "NWB_DEFAULT",
    "LumpedEngine",
    "LumpedResult",
    "LumpedScene",
    "LumpedStepControl",
    "StepOutcome",
    "breakdown_pressure",
    "critical_net_pressure",
    "fracture_compliance",
    "fracture_face_area",
    "fracture_volume",
    "load_lumped_scene",
    "reopening_pressure",
    "simulate_lumped",
    "stable_length",
    "standard_lumped_scene",
    "stress_intensity",
    "wall_leak_index",
]
