"""xlotkit.atomic: complete files or none, with the user's umask."""

from __future__ import annotations

import os

import pytest

from xlotkit.atomic import atomic_write, atomic_write_text


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_files_get_the_umask_permissions(tmp_path, mask):
    old = os.umask(mask)
    try:
        p = atomic_write_text(tmp_path / "a.txt", "x")
        q = atomic_write(tmp_path / "b.bin", lambda t: t.write_bytes(b"\0"))
    finally:
        os.umask(old)
    # what open() would give a new file: 0o666 less the umask (not mkstemp's 0o600)
    for f in (p, q):
        assert f.stat().st_mode & 0o777 == 0o666 & ~mask


def test_a_failed_write_leaves_the_target_and_no_temporary(tmp_path):
    target = tmp_path / "r.txt"
    atomic_write_text(target, "old")

    def boom(tmp):
        tmp.write_text("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_write(target, boom)
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["r.txt"]
