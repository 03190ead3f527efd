"""Records built by construction for the segmentation tests (pressure [bar], rates [l/min]).

Kept out of the test modules so several of them can share the same truth: each builder also
returns where a person sets the phase boundaries (sample indices).
"""

from __future__ import annotations

from datetime import datetime

import numpy as np

from xlotkit import Record

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
