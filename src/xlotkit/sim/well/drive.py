r"""The well drive: what the phase in force does to the well, for every engine.

Every simulator (the lumped engine, the unit-segment well-coupling study, the 2D engine
monolithic and partitioned) asks one :class:`PhaseDrive` what the surface does while a
phase of the schedule is in force:

* the **rates**: the pump rate at time ``t`` (:meth:`PhaseDrive.pump_rate`), the return
  rate at a bottom-hole pressure (:meth:`PhaseDrive.return_rate`: the choke's
  ``zeta sqrt(p_s)`` of a flowback, a bleed's fixed rate), and the net rate into the well
  with its derivative with respect to the bottom-hole pressure
  (:meth:`PhaseDrive.rate`, for an implicit step that solves ``p_w`` with Newton);
* the **surface pressure** of the column above the bottom hole
  (:meth:`PhaseDrive.surface`: solved together with the choke and the friction of the
  returning flow in a flowback; :meth:`PhaseDrive.surface_at` the column at the net rate
  of :meth:`PhaseDrive.rate`);
* the **phase-end test**: one margin per end condition, ``<= 0`` once it is met
  (:meth:`PhaseDrive.end_tests`, :meth:`PhaseDrive.end_margins`).

:class:`WellDrive` holds what does not change over a run (the fluid column: hydrostatics,
density and friction) and starts a :class:`PhaseDrive` per phase
(:meth:`WellDrive.begin`), calibrating the choke from the flowback's ``initial_rate`` at the
static surface pressure the phase starts with. The choke law, its calibration and the
column are those of :mod:`xlotkit.sim.well.choke` and :mod:`xlotkit.sim.well.column`:
written once. What each phase type does is answered by the phase
(:mod:`xlotkit.sim.schedule`), so neither the drive nor an engine dispatches on the phase
types.

Rates are volumes at the surface (reference) density per second, pressures gauge [Pa].
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from xlotkit.errors import InputError
from xlotkit.sim.schedule import Phase, ShutIn
from xlotkit.sim.well.choke import (
    CHOKE_LINEAR,
    calibrate_choke,
    choke_flow,
    choke_surface_pressure,
)
from xlotkit.sim.well.column import Column, surface_from_bottomhole

__all__ = ["EndTest", "PhaseDrive", "WellDrive", "phase_place"]

#: A phase-end margin as a function of ``(p_bottomhole, p_surface, v_pumped, v_returned)``
#: (totals since the start of the run): ``<= 0`` once the end condition is met.
EndTest = Callable[[float, float, float, float], float]

#: The drive between phases (and before the first): nothing flows at surface.
_IDLE = ShutIn(duration=1.0)


@dataclass(frozen=True)
class PhaseDrive:
    """The phase in force at the well head (see the module docstring).

    Attributes
    ----------
    phase : Phase
    column : Column
        The fluid column surface -> open hole.
    t0 : float
        Start of the phase [s].
    zeta : float
        Choke coefficient [m^3 s^-1 Pa^-1/2] of a flowback (0 otherwise).
    v_in0, v_ret0 : float
        Volumes pumped and returned before the phase [m^3].
    choke_linear : float
        Surface pressure [Pa] below which :meth:`rate` linearises the choke law.
    """

    phase: Phase
    column: Column
    t0: float = 0.0
    zeta: float = 0.0
    v_in0: float = 0.0
    v_ret0: float = 0.0
    choke_linear: float = CHOKE_LINEAR

    # ------------------------------------------------------------------ what flows
    @property
    def pumps(self) -> bool:
        """The phase pumps into the well."""
        return self.phase.pumps

    @property
    def returns(self) -> bool:
        """The well returns fluid at surface (choke or bleed)."""
        return self.phase.through_choke or self.phase.fixed_return_rate > 0.0

    def pump_rate(self, t: float) -> float:
        """Pump rate [m^3/s] at time ``t`` [s]."""
        return self.phase.pump_rate(t - self.t0)

    def return_rate(self, p_bh: float) -> float:
        """Return rate at surface [m^3/s] (>= 0) at bottom-hole pressure ``p_bh``: the
        choke's through the column (with the friction of the returning flow), or the
        phase's fixed rate."""
        if self.phase.through_choke:
            return choke_surface_pressure(p_bh, self.zeta, self.column)[1]
        return self.phase.fixed_return_rate

    def choke(self, p_bh: float) -> tuple[float, float]:
        """``(p_s, Q_return)`` of the well flowing back through the choke at ``p_bh``."""
        return choke_surface_pressure(p_bh, self.zeta, self.column)

    def rate(self, t: float, p_bh: float) -> tuple[float, float]:
        """Net rate into the well [m^3/s] and its derivative with respect to the
        bottom-hole pressure [m^3/(s Pa)]: the pump rate, minus the bleed rate, or the
        choke's return (:func:`~xlotkit.sim.well.choke.choke_flow`, linearised below
        ``choke_linear`` at surface)."""
        ph = self.phase
        if ph.pumps:
            return self.pump_rate(t), 0.0
        if ph.through_choke:
            return choke_flow(p_bh, float(self.zeta), self.column, self.choke_linear)
        r = ph.fixed_return_rate
        if r > 0.0:
            return -r, 0.0
        return 0.0, 0.0

    # ------------------------------------------------------------------ surface pressure
    def surface(self, p_bh: float, pump_rate: float = 0.0) -> tuple[float, float]:
        """``(surface pressure, return rate)`` at bottom-hole pressure ``p_bh`` [Pa]: the
        choke's solution in a flowback, else the column at the phase's rate (``pump_rate``
        while pumping, the bleed's return)."""
        if self.phase.through_choke:
            return choke_surface_pressure(p_bh, self.zeta, self.column)
        r = self.phase.fixed_return_rate
        if r > 0.0:
            return surface_from_bottomhole(p_bh, -r, self.column), r
        return surface_from_bottomhole(p_bh, pump_rate, self.column), 0.0

    def surface_at(self, t: float, p_bh: float) -> float:
        """Surface pressure [Pa] of the column at the net rate :meth:`rate` (t, p_bh)."""
        q, _ = self.rate(t, p_bh)
        return surface_from_bottomhole(p_bh, q, self.column)

    def column_surface(self, p_bh: float, rate: float) -> float:
        """Surface pressure [Pa] of the column at bottom-hole pressure ``p_bh`` and net
        rate ``rate`` into the well (> 0 pumping) [m^3/s]."""
        return surface_from_bottomhole(p_bh, rate, self.column)

    # ------------------------------------------------------------------ phase end
    @property
    def needs_surface(self) -> bool:
        """An end test reads the surface pressure."""
        ph = self.phase
        return ph.ends_when_dead or (ph.pressure_at == "surface" and (
            ph.pressure_above is not None or ph.pressure_below is not None))

    def volume_done(self, v_in: float, v_ret: float) -> float:
        """The volume [m^3] the phase's volume end meters, from the run's totals."""
        return self.phase.volume_done(v_in - self.v_in0, v_ret - self.v_ret0)

    def end_tests(self) -> dict[str, EndTest]:
        """The phase's end conditions as margins ``g(p_bh, p_s, v_in, v_ret) <= 0`` once
        met, in the order they are reported: ``pressure_above``, ``pressure_below`` (at the
        phase's gauge), ``volume`` (pumped for a pump phase, else returned) and
        ``well_dead`` (a bleed whose surface pressure is gone). Durations are the engines'
        time targets."""
        ph = self.phase
        fns: dict[str, EndTest] = {}
        surface = ph.pressure_at == "surface"
        if ph.pressure_above is not None:
            thr = float(ph.pressure_above)
            if surface:
                fns["pressure_above"] = lambda p, ps, vi, vr: thr - ps
            else:
                fns["pressure_above"] = lambda p, ps, vi, vr: thr - p
        if ph.pressure_below is not None:
            thr2 = float(ph.pressure_below)
            if surface:
                fns["pressure_below"] = lambda p, ps, vi, vr: ps - thr2
            else:
                fns["pressure_below"] = lambda p, ps, vi, vr: p - thr2
        vt = ph.volume_target
        if vt is not None:
            if ph.pumps:
                v_in0 = self.v_in0
                fns["volume"] = lambda p, ps, vi, vr: (v_in0 + vt) - vi
            else:
                v_ret0 = self.v_ret0
                fns["volume"] = lambda p, ps, vi, vr: (v_ret0 + vt) - vr
        if ph.ends_when_dead:
            fns["well_dead"] = lambda p, ps, vi, vr: ps
        return fns

    def end_margins(self, p_bh: float, p_s: float, v_in: float,
                    v_ret: float) -> dict[str, float]:
        """:meth:`end_tests` evaluated (``<= 0``: met)."""
        return {k: f(p_bh, p_s, v_in, v_ret) for k, f in self.end_tests().items()}


@dataclass(frozen=True)
class WellDrive:
    """The well head of one run: the column and the choke law; a :class:`PhaseDrive` per
    phase.

    Parameters
    ----------
    column : Column
        Surface -> open hole (its ``friction`` switches the friction of the flow on).
    choke_linear : float
        Surface pressure [Pa] below which :meth:`PhaseDrive.rate` linearises the choke
        law (only the derivative form; the other queries use the exact law).
    """

    column: Column
    choke_linear: float = CHOKE_LINEAR

    def idle(self, t0: float = 0.0, v_in: float = 0.0, v_ret: float = 0.0) -> PhaseDrive:
        """The drive when no phase is in force (before the first, between phases)."""
        return PhaseDrive(_IDLE, self.column, float(t0), 0.0, v_in, v_ret, self.choke_linear)

    def begin(self, phase: Phase, *, t0: float, p_bh: float, v_in: float = 0.0,
              v_ret: float = 0.0, zeta: float | None = None,
              where: str | None = None) -> PhaseDrive:
        """The drive of ``phase`` starting at ``t0`` with the well at ``p_bh``.

        A flowback's choke is its ``zeta``, or calibrated from ``initial_rate`` at the
        static surface pressure of the column above ``p_bh``. ``zeta`` given here (a
        checkpoint's) is taken as is.

        Parameters
        ----------
        where : str, optional
            ``"phase 3 (cycle 1)|schedule.phase[2]"``: the phase's place in the program
            and its key, named in the error of a choke that cannot be calibrated.

        Raises
        ------
        InputError
            A flowback that starts without surface pressure to calibrate its choke from; a
            phase (not restored from a checkpoint) whose pressure end is already met at
            ``p_bh`` (it would end at once: the target is on the wrong side).
        """
        fresh = zeta is None
        if zeta is None:
            zeta = 0.0
            if phase.through_choke:
                zeta = self._calibrate(phase, p_bh, where)
        drive = PhaseDrive(phase, self.column, float(t0), float(zeta), float(v_in),
                           float(v_ret), self.choke_linear)
        if fresh:
            self._check_reachable(drive, p_bh, where)
        return drive

    def _check_reachable(self, drive: PhaseDrive, p_bh: float, where: str | None) -> None:
        """A phase whose pressure end is met when it starts would end at once: the scene
        asked for a target on the wrong side of the pressure the test reaches (a
        flowback to 60 MPa after a test that peaked at 40)."""
        ph = drive.phase
        ps = surface_from_bottomhole(p_bh, 0.0, self.column)
        p_now = ps if ph.pressure_at == "surface" else p_bh
        label, _, key = (where or f"{ph.kind}|{ph.kind}").partition("|")
        for name in ("pressure_above", "pressure_below"):
            thr = getattr(ph, name)
            if thr is None:
                continue
            met = p_now >= thr if name == "pressure_above" else p_now <= thr
            if met:
                side = "above" if name == "pressure_above" else "below"
                raise InputError(
                    f"{label} ({ph.label}) starts at {p_now / 1e6:.3f} MPa "
                    f"({ph.pressure_at}), already {side} its {name} = {thr / 1e6:.3f} MPa: "
                    f"it would end at once", key=f"{key}.{name}",
                    expected=f"a {name} {'above' if side == 'above' else 'below'} the "
                             f"{p_now / 1e6:.3f} MPa the phase starts at")

    def _calibrate(self, phase: Phase, p_bh: float, where: str | None) -> float:
        if phase.zeta is not None:
            return float(phase.zeta)
        ps = surface_from_bottomhole(p_bh, 0.0, self.column)
        if where is None:
            return calibrate_choke(float(phase.initial_rate), ps)
        label, _, key = where.partition("|")
        try:
            return calibrate_choke(float(phase.initial_rate), ps)
        except InputError:
            raise InputError(
                f"{label} starts with surface pressure {ps / 1e6:.3f} MPa; cannot "
                f"calibrate the choke from initial_rate", key=f"{key}.initial_rate",
                expected="flowback from a pressured well") from None


def phase_place(i_ph: int, cycle: int, n_listed: int) -> str:
    """The ``where`` of :meth:`WellDrive.begin` for the ``i_ph``-th phase of the expanded
    program (0-based) in ``cycle``, of a schedule listing ``n_listed`` phases."""
    return f"phase {i_ph + 1} (cycle {cycle})|schedule.phase[{i_ph % n_listed}]"
