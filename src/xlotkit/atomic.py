"""Writing files so that a crash never leaves a half-written result.

Every file xlotkit writes (logs, reports, plots) goes through :func:`atomic_write`: the content
is written to a temporary file in the target folder and moved into place with
:func:`os.replace`, which is atomic on one file system. The temporary file is created with
mode 0o666 less the process's umask, as :func:`open` creates files, so a result gets the
user's normal permissions (:func:`tempfile.mkstemp` would make it private, 0o600).
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path

__all__ = ["atomic_write", "atomic_write_text", "fresh_output_dir", "fresh_sibling_dir",
           "save_figure"]


def atomic_write(path: str | Path, write: Callable[[Path], None], *,
                 before_replace: Callable[[], None] | None = None) -> Path:
    """Write ``path`` through a temporary sibling file.

    Parameters
    ----------
    path : str or Path
        Target file; its folder must exist.
    write : callable
        ``write(tmp_path)`` writes the whole content to ``tmp_path``.
    before_replace : callable, optional
        Called after writing, just before the move (e.g. to refuse if the target appeared
        meanwhile); an exception here leaves the target untouched.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    tmp = _create_temporary(path)
    try:
        write(Path(tmp))
        if before_replace is not None:
            before_replace()
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def _create_temporary(path: Path) -> str:
    """Create an empty, new temporary sibling of ``path`` (exclusively, like mkstemp, but
    with the umask applied by the kernel) and return its name. The real suffix is kept last
    so writers that infer the format from it still work."""
    while True:
        tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp{path.suffix}"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return str(tmp)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 text (``\\n`` line ends) atomically."""

    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)

    return atomic_write(path, write)


def save_figure(fig, path: str | Path, *, dpi: int = 120) -> Path:
    """Save a matplotlib figure atomically; the format follows the suffix (default PNG)."""
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    return atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt, dpi=dpi))


def fresh_sibling_dir(path: str | Path) -> Path:
    """Create and return the first free folder ``<path>-2``, ``<path>-3``, ...

    Each candidate is created exclusively, so two runs started at the same time never share
    one. Used wherever a results folder already holds earlier results.
    """
    path = Path(path)
    k = 2
    while True:
        cand = path.with_name(f"{path.name}-{k}")
        try:
            cand.mkdir(parents=True)
            return cand
        except FileExistsError:
            k += 1


def fresh_output_dir(out: str | Path) -> Path:
    """A results folder that holds no earlier results.

    ``out`` itself when it does not exist or is empty; otherwise the first free sibling
    ``out-2``, ``out-3``, ... (:func:`fresh_sibling_dir`, created exclusively).
    """
    out = Path(out)
    if not out.exists():
        out.mkdir(parents=True)
        return out
    if out.is_dir() and not any(out.iterdir()):
        return out
    return fresh_sibling_dir(out)
