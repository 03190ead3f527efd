"""Outputs (issue 15): numerical warnings become notes, files get the umask, errors name the
user's path."""

from __future__ import annotations

import os
import stat

import numpy as np
import pytest

from xlotkit.atomic import atomic_write, atomic_write_text
from xlotkit.errors import InputError
from xlotkit.interpret.picks.core import MethodEntry, _run
from xlotkit.interpret.picks.types import Pick


def _noisy_pick(*_a, **_k):
    a = np.ones((5, 2))
    a[0, 0] = np.nan
    try:
        np.linalg.lstsq(a, np.ones(5), rcond=None)       # LAPACK DLASCL, written by C to fd 1
    except np.linalg.LinAlgError:
        pass
    np.polyfit(np.ones(5), np.arange(5.0), 3)           # RankWarning
    return Pick("FCP", "test", 1.0e7, quality="good")


def _call(fn):
    entry = MethodEntry("FCP", "test", "shut_in", fn)
    return _run(entry, None, None, window=None, tangents=None, isip=None)


def test_numpy_and_lapack_warnings_become_a_note_not_terminal_output(capfd):
    p = _call(_noisy_pick)
    out, err = capfd.readouterr()
    assert "DLASCL" not in out + err and "RankWarning" not in out + err
    assert "numerical warnings" in p.message and "RankWarning" in p.message
    assert p.quality == "fair" and p.value == 1.0e7


def test_non_finite_result_is_not_a_value():
    p = _call(lambda *_a, **_k: Pick("FCP", "test", float("nan")))
    assert not p.found and "finite" in p.message


def test_a_method_that_raises_is_not_found_with_the_errors_first_line():
    def broken(*_a, **_k):
        raise ValueError("window holds 3 samples\nsecond line of detail")

    p = _call(broken)
    assert not p.found and (p.name, p.method) == ("FCP", "test")
    assert p.message == "test failed: ValueError: window holds 3 samples"


def test_files_get_the_umask_and_errors_name_the_users_path(tmp_path):
    target = tmp_path / "r.txt"
    atomic_write_text(target, "x")
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~mask

    def fail(tmp):
        raise OSError(28, "No space left on device", str(tmp))

    with pytest.raises(InputError) as exc:
        atomic_write(tmp_path / "full.png", fail)
    msg = str(exc.value)
    assert str(tmp_path / "full.png") in msg and ".tmp" not in msg and "No space" in msg
    assert sorted(x.name for x in tmp_path.iterdir()) == ["r.txt"]
    with pytest.raises(InputError, match="nope"):
        atomic_write_text(tmp_path / "nope" / "a.txt", "x")
