"""Keep numerical libraries' own messages off the terminal and hand them to the caller.

NumPy warns through :mod:`warnings` (``RankWarning: Polyfit may be poorly conditioned``);
LAPACK writes from C straight to file descriptor 1 (``** On entry to DLASCL parameter
number 4 had an illegal value``), which no Python-level redirection catches and which would
corrupt ``--json`` output. :func:`captured` redirects both descriptors to a temporary file
and records the warnings; the caller turns them into a quality note.
"""

from __future__ import annotations

import ctypes
import os
import sys
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

__all__ = ["Captured", "captured"]


@dataclass
class Captured:
    """What a block said: Python warnings and native output (filled when the block ends)."""

    warnings: list[str] = field(default_factory=list)
    native: str = ""

    def notes(self) -> list[str]:
        """One short line per distinct message."""
        out: list[str] = []
        for w in self.warnings:
            if w not in out:
                out.append(w)
        for line in self.native.splitlines():
            s = " ".join(line.replace("*", " ").split())
            if s and s not in out:
                out.append(s)
        return out


def _flush_c_stdio() -> None:
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # pragma: no cover - no libc (Windows)
        pass


@contextmanager
def captured() -> Iterator[Captured]:
    """Capture warnings and what C code writes to stdout/stderr inside the block.

    Not for concurrent threads: file descriptors are process-wide.
    """
    out = Captured()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    try:
        saved = (os.dup(1), os.dup(2))
    except OSError:                      # no descriptors to redirect (embedded use)
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            yield out
        out.warnings = [f"{w.category.__name__}: {w.message}" for w in rec]
        return
    tmp = tempfile.TemporaryFile()
    try:
        _flush_c_stdio()
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            try:
                yield out
            finally:
                out.warnings = [f"{w.category.__name__}: {w.message}" for w in rec]
    finally:
        _flush_c_stdio()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
        tmp.seek(0)
        out.native = tmp.read().decode("utf-8", errors="replace")
        tmp.close()
