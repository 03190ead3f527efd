"""Records for the segmentation tests, with where a person sets the phases and kinds.

Built by construction (pressure [bar], rates [l/min], 1 s samples) or simulated with the
lumped model and passed through the log writer and reader (:func:`lumped_log`). Kept out of
the test modules so several of them can share the same truth: each builder also returns
where a person sets the phase boundaries (sample indices) and the numbers the construction
put in.
"""

from __future__ import annotations

from datetime import datetime

import numpy as np

from xlotkit import Record
from xlotkit.interpret.io import read_log
from xlotkit.logfile import write_log

BAR = 1.0e5
LPM = 1.0e-3 / 60.0


def dfit_arrays(*, pre_s: int = 1, pump_s: int = 520, falloff_s: int = 5400, q_lpm: float = 600.0,
                closure_bar: float = 220.0, seed: int = 1, noise_bar: float = 0.2):
    """A standard DFIT at 1 s sampling: pump ``pump_s`` at constant rate, metered zero rate after.

    Pressure rises linearly (150 bar/min) to a breakdown at 330 bar, propagates at ~290 bar,
    drops 15 bar at pump stop (friction) and falls off for ``falloff_s``: linear in sqrt(t)
    down to closure at ``closure_bar`` 900 s after shut-in, then along a line in sqrt(t) with
    a quarter... of the slope (the stiffer closed system), never back to the base.

    Returns
    -------
    t [s], p [bar], q [l/min], truth dict with ``pump`` and ``shut_in`` as (i0, i1)
    """
    p = [np.zeros(pre_s)]
    tt = np.arange(1, pump_s + 1, dtype=float)
    lin = 150.0 / 60.0 * tt
    t_lop, t_fbp = 300.0 / 2.5, 300.0 / 2.5 + 2.0 * 30.0 / 2.5
    rise = lin.copy()
    bend = (tt > t_lop) & (tt <= t_fbp)
    s = (tt[bend] - t_lop) / (t_fbp - t_lop)
    rise[bend] = 300.0 + 30.0 * (1 - (1 - s) ** 2)
    after = tt > t_fbp
    rise[after] = 290.0 + 40.0 * np.exp(-(tt[after] - t_fbp) / 15.0)
    p.append(rise)
    p0 = rise[-1] - 15.0
    tf = np.arange(1, falloff_s + 1, dtype=float)
    tc = 900.0
    before = p0 - (p0 - closure_bar) * np.sqrt(tf / tc)
    closed = closure_bar - 40.0 * (np.sqrt(tf / tc) - 1.0)
    p.append(np.where(tf <= tc, before, closed))
    p = np.concatenate(p)
    if noise_bar:
        p = p + np.random.default_rng(seed).normal(0.0, noise_bar, p.size)
    q = np.zeros(p.size)
    q[pre_s:pre_s + pump_s] = q_lpm
    t = np.arange(p.size, dtype=float)
    truth = {"pump": (pre_s, pre_s + pump_s), "shut_in": (pre_s + pump_s, p.size),
             "closure_bar": closure_bar}
    return t, p, q, truth


def _approach(levels, durations, p_start, tau_s):
    """Pressure [bar] relaxing towards ``levels[k]`` for ``durations[k]`` samples each, with
    time constant ``tau_s`` (a well filling or draining to a new steady state)."""
    out = []
    p = p_start
    for level, n in zip(levels, durations):
        tt = np.arange(1, n + 1, dtype=float)
        seg = level + (p - level) * np.exp(-tt / tau_s)
        out.append(seg)
        p = seg[-1]
    return np.concatenate(out)


def step_rate_arrays(*, rates_lpm=(40, 80, 120, 160, 200, 260, 320, 380), step_s=300,
                     pre_s=180, shut_s=1500, p_res_bar=200.0, lpm_per_bar=8.0,
                     q_c_lpm=170.0, above_bar_per_lpm=0.02, tau_s=40.0, seed=2,
                     noise_bar=0.1):
    """A step-rate test on a downhole gauge: rates held ``step_s`` each, then shut in.

    Steady matrix injection below fracture extension (``p = p_res + q / J``,
    ``J = lpm_per_bar``), a fracture taking any rate above ``q_c_lpm`` at little extra
    pressure (``above_bar_per_lpm``): the stabilised p-q line breaks at
    ``FEP = p_res + q_c / J`` (221.25 bar with the defaults). The pressure relaxes to each
    step's level with time constant ``tau_s`` (well storage over the formation's
    injectivity), and to the reservoir pressure after shut-in.

    Returns
    -------
    t [s], p [bar], q [l/min], truth dict: ``fep_bar``, ``steps`` ((i0, i1) per step),
    ``pump`` and ``shut_in`` (i0, i1)
    """
    rates = np.asarray(rates_lpm, float)
    fep = p_res_bar + q_c_lpm / lpm_per_bar
    level = np.where(rates <= q_c_lpm, p_res_bar + rates / lpm_per_bar,
                     fep + above_bar_per_lpm * (rates - q_c_lpm))
    p = np.concatenate([np.full(pre_s, p_res_bar),
                        _approach(level, [step_s] * rates.size, p_res_bar, tau_s),
                        _approach([p_res_bar], [shut_s], float(level[-1]), 4 * tau_s)])
    q = np.concatenate([np.zeros(pre_s), np.repeat(rates, step_s), np.zeros(shut_s)])
    if noise_bar:
        p = p + np.random.default_rng(seed).normal(0.0, noise_bar, p.size)
    t = np.arange(p.size, dtype=float)
    end = pre_s + step_s * rates.size
    steps = [(pre_s + k * step_s, pre_s + (k + 1) * step_s) for k in range(rates.size)]
    return t, p, q, {"fep_bar": fep, "steps": steps, "pump": (pre_s, end),
                     "shut_in": (end, p.size), "q_c_lpm": q_c_lpm}


def stimulation_arrays(*, seed=3, noise_bar=0.3):
    """A stimulation on the treating (surface) pressure: breakdown at a low rate, the rate
    stepped up to the main stage, stepped down again, then a falloff.

    Rates [m^3/min]: 0.5 for 150 s (pressure rises at 60 bar/min to a 350 bar breakdown),
    then 2, 3 and 4 for 90 s each, 4 for 600 s (main stage), 3, 2 and 1 for 90 s each (the
    step-down), then 1800 s shut in. While fracturing, the treating pressure is
    ``150 + 8 q^2`` bar (extension pressure at surface plus pipe friction), reached with a
    10 s time constant; after shut-in it falls 40 bar at once (friction and near-wellbore
    losses) and declines linearly in sqrt(t) to 80 bar.

    Returns
    -------
    t [s], p [bar], q [l/min], truth dict: ``pump`` and ``shut_in`` (i0, i1), ``levels``
    (rate levels [l/min] in order)
    """
    pre = 120
    sched = [(0.5, 150), (2.0, 90), (3.0, 90), (4.0, 690), (3.0, 90), (2.0, 90), (1.0, 90)]
    p = [np.zeros(pre)]
    # breakdown stage: linear rise, breakdown at 350 bar after 100 s, then propagation
    tt = np.arange(1, 151, dtype=float)
    first = np.where(tt <= 100, 3.5 * tt, 152.0 + 198.0 * np.exp(-(tt - 100) / 8.0))
    p.append(first)
    levels = [150.0 + 8.0 * qq ** 2 for qq, _ in sched[1:]]
    p.append(_approach(levels, [n for _, n in sched[1:]], float(first[-1]), 10.0))
    isip = 150.0 - 40.0 + 8.0  # after the 1 m3/min stage: friction and 40 bar gone
    tf = np.arange(1, 1801, dtype=float)
    p.append(isip - (isip - 80.0) * np.sqrt(tf / 1800.0))
    p = np.concatenate(p)
    q = np.concatenate([np.zeros(pre)] + [np.full(n, 1000.0 * qq) for qq, n in sched]
                       + [np.zeros(1800)])
    if noise_bar:
        p = p + np.random.default_rng(seed).normal(0.0, noise_bar, p.size)
    end = pre + sum(n for _, n in sched)
    return (np.arange(p.size, dtype=float), p, q,
            {"pump": (pre, end), "shut_in": (end, p.size),
             "levels": [1000.0 * qq for qq, _ in sched]})


def partial_release_arrays(*, fraction: float | None = 0.15, speedup: float | None = None,
                           base_bar: float = 100.0, q_lpm: float = 300.0, seed: int = 4,
                           noise_bar: float = 0.1):
    """One XLOT cycle on a downhole gauge with a valve opened briefly during the shut-in.

    1 s samples. Idle at ``base_bar`` for 300 s; pumped 300 s at ``q_lpm`` (a linear rise
    at 100 bar/min, bending over at +120 bar, breakdown at +150 bar, propagation at
    +110 bar); at pump stop the pressure falls 10 bar at once (friction) and leaks off
    along a line in sqrt(t), 30 bar over 600 s (Carter leak-off: the decline only slows
    down). 300 s after pump stop a valve is opened: the well drains through it towards base
    with a 200 s time constant (choke flow, about 20 times the leak-off rate at that time)
    until it has lost ``fraction`` of the pressure above base, and the valve is shut; the
    leak-off goes on from the lower level for another 900 s. Finally the well is bled to
    base (60 s) and stands idle for 300 s. ``fraction=None``: no valve opening (the same
    cycle with its leak-off alone).

    ``speedup`` replaces the valve by leak-off that speeds up gradually (a fracture closing
    into a permeable formation): from 300 s after pump stop the decline rate grows
    smoothly over 150 s to ``speedup`` times the sqrt(t) decline's and stays there
    until the pressure has lost 15 % of its height, then eases back over 150 s.

    Returns
    -------
    t [s], p [bar], q [l/min] (zeros after the pump stops), truth dict: ``pump`` and
    ``valve`` ((i0, i1): opened, shut), ``drop_bar``, ``excess_bar``
    """
    pre, pump_s = 300, 300
    p = [np.full(pre, base_bar)]
    tt = np.arange(1, pump_s + 1, dtype=float)
    rise = base_bar + 100.0 / 60.0 * tt
    t_lop, t_fbp = 72.0, 72.0 + 2.0 * 30.0 / (100.0 / 60.0)
    bend = (tt > t_lop) & (tt <= t_fbp)
    s = (tt[bend] - t_lop) / (t_fbp - t_lop)
    rise[bend] = base_bar + 120.0 + 30.0 * (1 - (1 - s) ** 2)
    after = tt > t_fbp
    rise[after] = base_bar + 110.0 + 40.0 * np.exp(-(tt[after] - t_fbp) / 15.0)
    p.append(rise)
    p0 = rise[-1] - 10.0
    a_sqrt = 30.0 / np.sqrt(600.0)  # bar / sqrt(s)
    t_open = 300
    shut = [p0 - a_sqrt * np.sqrt(np.arange(1, t_open + 1, dtype=float))]
    level = float(shut[0][-1])
    truth = {"pump": (pre, pre + pump_s), "excess_bar": level - base_bar}
    i_open = pre + pump_s + t_open
    if fraction is not None:
        # choke flow towards base: d(p - base)/dt = -(p - base) / 200 s
        n_open = int(np.ceil(-200.0 * np.log(1.0 - fraction)))
        k = np.arange(1, n_open + 1, dtype=float)
        shut.append(base_bar + (level - base_bar) * np.exp(-k / 200.0))
        truth["valve"] = (i_open, i_open + n_open)
        truth["drop_bar"] = level - float(shut[-1][-1])
    elif speedup is not None:
        # the decline rate eases up to `speedup` times the leak-off's over 150 s, holds
        # until 15 % of the height is gone, eases back over 150 s
        ramp = 150
        rates, pp, j = [], level, 0
        target = level - 0.15 * (level - base_bar)
        while True:
            tau = t_open + j + 1
            r0 = a_sqrt / (2.0 * np.sqrt(tau))
            w = min(1.0, (j + 1) / ramp)
            up = 1.0 + (speedup - 1.0) * (3 * w ** 2 - 2 * w ** 3)
            pp -= r0 * up
            rates.append(pp)
            j += 1
            if pp <= target:
                break
        for m in range(1, ramp + 1):
            tau = t_open + j + 1
            w = 1.0 - m / ramp
            pp -= a_sqrt / (2.0 * np.sqrt(tau)) * (1.0 + (speedup - 1.0)
                                                    * (3 * w ** 2 - 2 * w ** 3))
            rates.append(pp)
            j += 1
        shut.append(np.array(rates))
        truth["speedup"] = (i_open, i_open + j)
    lvl = float(shut[-1][-1])
    t_done = t_open + sum(x.size for x in shut[1:])
    k = np.arange(1, 901, dtype=float)
    shut.append(lvl - a_sqrt * (np.sqrt(t_done + k) - np.sqrt(t_done)))
    p += shut
    last = float(shut[-1][-1])
    p.append(last + (base_bar - last) * np.arange(1, 61) / 60.0)
    p.append(np.full(300, base_bar))
    p = np.concatenate(p)
    if noise_bar:
        p = p + np.random.default_rng(seed).normal(0.0, noise_bar, p.size)
    q = np.zeros(p.size)
    q[pre:pre + pump_s] = q_lpm
    return np.arange(p.size, dtype=float), p, q, truth


def surface_pressurisation_arrays(*, friction_bar: float = 20.0, rise_s: int = 60,
                                 bend_bar: float = 0.0, fall_bar: float = 0.0,
                                 past_s: int = 0, early_leak: float = 0.0,
                                 q_lpm: float = 500.0, seed: int = 6, noise_bar: float = 0.1):
    """One pressurisation on a surface gauge: a friction step at the pump start, then the
    well's compression.

    1 s samples, base 0 bar. Idle 120 s; pumped at ``q_lpm``: the gauge reads the pipe
    friction ``friction_bar`` from the moment the rate is on (reached over 2 samples, the
    rate ramping up) on top of the compression, which rises by 100 bar over ``rise_s``
    samples along a line in pumped volume -- bent below it by ``bend_bar`` at the peak over
    the last quarter of the rise (leak-off: a LOT), or concave from the start with
    ``early_leak`` (``100 (u + early_leak u (1 - u))``, ``u`` the fraction of the rise: a
    formation taking fluid from the first litre). At the peak the pressure falls
    ``fall_bar`` over 2 s and holds while the pump runs on ``past_s`` s (a brittle
    breakdown; ``past_s = 0``: the pump stops at the peak). At pump stop the friction
    vanishes; the well leaks off 5 bar over 180 s and is bled to base over 30 s; idle 120 s.

    Returns
    -------
    t [s], p [bar], q [l/min], truth dict: ``pump`` (i0, i1), ``friction_bar``,
    ``net_gain_bar`` (100)
    """
    pre = 120
    u = np.arange(rise_s, dtype=float) / (rise_s - 1)
    comp = 100.0 * (u + early_leak * u * (1.0 - u))
    w = np.clip((u - 0.75) / 0.25, 0.0, None)
    comp = comp - bend_bar * w ** 2
    if past_s:
        comp = np.concatenate([comp, comp[-1] - fall_bar * np.array([0.5, 1.0]),
                               np.full(max(past_s - 2, 0), comp[-1] - fall_bar)])
    n_pump = comp.size
    fr = np.full(n_pump, friction_bar)
    fr[:2] = friction_bar * np.array([0.4, 0.9])
    last = float(comp[-1])
    shut = last - 5.0 * np.sqrt(np.arange(1, 181, dtype=float) / 180.0)
    bleed = float(shut[-1]) * (1.0 - np.arange(1, 31) / 30.0)
    p = np.concatenate([np.zeros(pre), comp + fr, shut, bleed, np.zeros(120)])
    if noise_bar:
        p = p + np.random.default_rng(seed).normal(0.0, noise_bar, p.size)
    q = np.zeros(p.size)
    q[pre:pre + n_pump] = q_lpm
    return (np.arange(p.size, dtype=float), p, q,
            {"pump": (pre, pre + n_pump), "friction_bar": friction_bar, "net_gain_bar": 100.0})


def lumped_log(tmp_path, name, schedule, **scene):
    """Simulate ``schedule`` with the lumped model (the standard scene, ``scene`` overrides),
    write the record with the log writer and read it back as a field log.

    Returns
    -------
    (Record read back, EngineResult)
    """
    from xlotkit.sim.lumped import simulate_lumped
    from xlotkit.sim.scene.lumped import standard_lumped_scene

    res = simulate_lumped(standard_lumped_scene(schedule=schedule, **scene))
    assert res.status == "ok", res.message
    path = write_log(res.record, tmp_path / f"{name}.csv")
    return read_log(path), res


def to_record(t, p_bar, q_lpm, r_lpm=None) -> Record:
    """A Record (SI) from field-unit arrays."""
    kw = {"rate": np.asarray(q_lpm) * LPM}
    if r_lpm is not None:
        kw["return_rate"] = np.asarray(r_lpm) * LPM
    return Record(t=np.asarray(t, float), pressure=np.asarray(p_bar) * BAR,
                  start_time=datetime(2024, 1, 1, 8, 0, 0), **kw)


# pressure unit -> bar per unit (independent of xlotkit's own table: NIST SP 811 values)
PRESSURE_UNITS = {"bar": 1.0, "psi": 0.0689475729316836, "MPa": 10.0, "kPa": 0.01}
TIME_UNITS = {"s": 1.0, "min": 60.0}


def write_csv(path, t_s, p_bar, q_lpm, r_lpm=None, *, p_unit="bar", t_unit="s",
              t_offset_s=0.0) -> None:
    """Write a log with the pressure in ``p_unit`` and time in ``t_unit`` (shifted by
    ``t_offset_s``); full float precision so only the unit differs."""
    tt = (np.asarray(t_s) + t_offset_s) / TIME_UNITS[t_unit]
    pp = np.asarray(p_bar) / PRESSURE_UNITS[p_unit]
    head = [f"Time ({t_unit})", f"Pressure ({p_unit})", "Rate (l/min)"]
    cols = [tt, pp, np.asarray(q_lpm)]
    if r_lpm is not None:
        head.append("Return rate (l/min)")
        cols.append(np.asarray(r_lpm))
    with open(path, "w") as fh:
        fh.write(",".join(head) + "\n")
        for row in zip(*cols):
            fh.write(",".join(repr(float(v)) for v in row) + "\n")
