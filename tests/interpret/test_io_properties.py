"""Property tests of the reader (hypothesis): mutated files, unit invariance, layout invariance.

* 10^4 mutated small files (characters replaced, deleted, inserted; lines duplicated, dropped,
  cut) end only in :class:`InputError` or in a record that obeys the record's rules: strictly
  increasing finite time, and no value in a role column beyond what its unit allows.
* A file rescaled by a unit factor and relabelled reads to the same SI values (every
  pressure, rate and time unit the field uses).
* Rewriting a file in another layout (separator, decimal comma, header spelling, preamble,
  blank lines, CRLF) reads to the same values.

Examples are derandomised (the same every run) and have no deadline; each read of a small
file costs a few milliseconds, so the 10^4 mutated files take about half a minute.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xlotkit.errors import InputError
from xlotkit.interpret.io import read_log

_DIR = Path(tempfile.mkdtemp(prefix="xlotkit-io-prop-"))

# unit -> factor to SI, from the definitions (independent of pint)
PSI = 0.45359237 * 9.80665 / 0.0254 ** 2
BBL = 42 * 231 * 0.0254 ** 3
GAL = 231 * 0.0254 ** 3
PRESSURE_UNITS = {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "bar": 1e5, "bara": 1e5, "barg": 1e5,
                  "psi": PSI, "psia": PSI, "psig": PSI, "atm": 101325.0, "at": 98066.5,
                  "kgf/cm2": 98066.5, "mbar": 100.0, "ksi": 1000 * PSI}
RATE_UNITS = {"bpm": BBL / 60, "l/min": 1e-3 / 60, "m3/min": 1 / 60, "m3/h": 1 / 3600,
              "gal/min": GAL / 60, "l/s": 1e-3, "m3/s": 1.0}
TIME_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}

_SETTINGS = dict(deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                        HealthCheck.filter_too_much])


def _base_text(n: int, sep: str = ",") -> str:
    k = np.arange(n)
    p = 20 + 7 * k
    q = np.where(k % 5 < 3, 300.0, 0.0)
    rows = [f"time (s){sep}Pressure (bar){sep}Rate (l/min){sep}Volume (m3)"]
    rows += [f"{i * 2}{sep}{p[i]:.2f}{sep}{q[i]:.1f}{sep}{i * 0.01:.3f}" for i in k]
    return "\n".join(rows) + "\n"


def _check_record(r) -> None:
    """What any record the reader returns must satisfy."""
    assert r.n >= 1
    assert np.all(np.isfinite(r.t)) and (r.n < 2 or np.all(np.diff(r.t) > 0))
    p = r.pressure[np.isfinite(r.pressure)]
    assert np.all(np.abs(p) <= 5e8)
    for name, lim in (("rate", 2.0), ("volume", 1e5), ("return_rate", 2.0)):
        v = r.series(name)
        if v is not None:
            v = v[np.isfinite(v)]
            assert np.all(np.abs(v) <= lim) or name == "volume"   # volume made continuous


_CHARS = list("0123456789.,;:\t -+eE#*/\n\"'abcxyzPa()[]") + ["\r", "\x00", "é", "°", "1e30",
                                                              "NaN", "inf", "\n\n", "9" * 30]


@st.composite
def mutated(draw):
    n = draw(st.integers(1, 12))
    sep = draw(st.sampled_from([",", ";", "\t"]))
    text = _base_text(n, sep)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["replace", "delete", "insert", "dup_line", "drop_line",
                                     "cut"]))
        if not text:
            break
        i = draw(st.integers(0, len(text) - 1))
        if kind == "replace":
            text = text[:i] + draw(st.sampled_from(_CHARS)) + text[i + 1:]
        elif kind == "delete":
            j = min(len(text), i + draw(st.integers(1, 8)))
            text = text[:i] + text[j:]
        elif kind == "insert":
            text = text[:i] + draw(st.sampled_from(_CHARS)) + text[i:]
        elif kind in ("dup_line", "drop_line"):
            lines = text.split("\n")
            k = draw(st.integers(0, len(lines) - 1))
            lines = lines[:k] + ([lines[k]] * 2 if kind == "dup_line" else []) + lines[k + 1:]
            text = "\n".join(lines)
        else:
            text = text[:i]
    return text


@settings(max_examples=10_000, **_SETTINGS)
@given(mutated())
def test_mutated_files_end_in_input_error_or_a_valid_record(text):
    p = _DIR / "m.csv"
    p.write_bytes(text.encode("utf-8"))
    try:
        r = read_log(p)
    except InputError as exc:
        assert str(exc)                  # one message naming the file
        assert "m.csv" in str(exc) or exc.file is None
        return
    _check_record(r)


@st.composite
def rescaled(draw):
    pu = draw(st.sampled_from(sorted(PRESSURE_UNITS)))
    qu = draw(st.sampled_from(sorted(RATE_UNITS)))
    tu = draw(st.sampled_from(sorted(TIME_UNITS)))
    style = draw(st.sampled_from(["({})", "[{}]", ", {}", "units_row"]))
    n = draw(st.integers(2, 20))
    p_si = np.array(draw(st.lists(st.floats(2e5, 3e7), min_size=n, max_size=n)))
    q_si = np.array(draw(st.lists(st.floats(0.0, 0.05), min_size=n, max_size=n)))
    t_si = np.cumsum(np.array(draw(st.lists(st.floats(0.5, 100.0), min_size=n, max_size=n))))
    return pu, qu, tu, style, p_si, q_si, t_si


@settings(max_examples=400, **_SETTINGS)
@given(rescaled())
def test_rescaled_and_relabelled_file_reads_the_same_si_values(case):
    pu, qu, tu, style, p_si, q_si, t_si = case
    sep = "\t"
    vals = [t_si / TIME_UNITS[tu], p_si / PRESSURE_UNITS[pu], q_si / RATE_UNITS[qu]]
    if style == "units_row":
        head = [f"Time{sep}Pressure{sep}Rate", f"{tu}{sep}{pu}{sep}{qu}"]
    elif style == ", {}":
        head = [f'Time, {tu}{sep}Pressure, {pu}{sep}Rate, {qu}']
    else:
        head = [sep.join(f"{nm} {style.format(u)}" for nm, u in
                         (("Time", tu), ("Pressure", pu), ("Rate", qu)))]
    rows = [sep.join(repr(float(v[i])) for v in vals) for i in range(t_si.size)]
    p = _DIR / "u.tsv"
    p.write_text("\n".join(head + rows) + "\n")
    r = read_log(p)
    # repr() round-trips: the only error is the conversion's rounding
    np.testing.assert_allclose(r.t, t_si, rtol=1e-12)
    np.testing.assert_allclose(r.pressure, p_si, rtol=1e-12)
    np.testing.assert_allclose(r.rate, q_si, rtol=1e-12, atol=1e-300)
    absolute = pu in ("psia", "bara")
    gauge = pu in ("psig", "barg")
    assert r.reference.absolute is (True if absolute else False)
    if gauge:
        assert not r.reference.absolute


@st.composite
def relaid(draw):
    n = draw(st.integers(2, 15))
    sep = draw(st.sampled_from([",", ";", "\t", "|", " "]))
    comma = draw(st.booleans()) and sep not in (",", " ")
    title = draw(st.sampled_from(["({})", "[{}]", "units_row"]))
    names = draw(st.sampled_from([("Time", "Pressure", "Rate"),
                                  ("Elapsed", "Treating Pressure", "Pump Rate"),
                                  ("Zeit", "Druck", "Durchfluss"),
                                  ("t", "WHP", "Rate in")]))
    pre = draw(st.lists(st.sampled_from(["# exported", "* banner *", "Well: X", "tinj 520",
                                         "; note", ""]), max_size=4))
    crlf = draw(st.booleans())
    blank_tail = draw(st.integers(0, 3))
    p = np.round(np.array(draw(st.lists(st.floats(1.0, 900.0), min_size=n, max_size=n))), 3)
    q = np.round(np.array(draw(st.lists(st.floats(0.0, 2000.0), min_size=n, max_size=n))), 1)
    return n, sep, comma, title, names, pre, crlf, blank_tail, p, q


@settings(max_examples=500, **_SETTINGS)
@given(relaid())
def test_the_same_data_in_another_layout_reads_the_same(case):
    n, sep, comma, title, names, pre, crlf, blank_tail, p, q = case
    units = ("s", "bar", "l/min")
    sp = "  " if sep == " " else sep
    if title == "units_row":
        head = [sp.join(names), sp.join(units)]
    else:
        head = [sp.join(f"{a} {title.format(u)}" for a, u in zip(names, units))]
    if sep == " ":
        head = [h.replace(" (", "(").replace(" [", "[") for h in head]

    def num(x, d):
        s = f"{x:.{d}f}"
        return s.replace(".", ",") if comma else s

    rows = [sp.join([str(i * 3), num(p[i], 3), num(q[i], 1)]) for i in range(n)]
    nl = "\r\n" if crlf else "\n"
    text = nl.join(pre + head + rows) + nl + nl * blank_tail
    f = _DIR / "l.txt"
    f.write_bytes(text.encode("utf-8"))
    r = read_log(f)
    np.testing.assert_array_equal(r.t, np.arange(n) * 3.0)
    np.testing.assert_allclose(r.pressure, p * 1e5, rtol=1e-15)
    np.testing.assert_allclose(r.rate, q * 1e-3 / 60, rtol=1e-15)
