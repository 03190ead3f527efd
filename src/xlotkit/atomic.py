"""Writing files so that a crash never leaves a half-written result.

Every file xlotkit writes (logs, reports, plots) goes through :func:`atomic_write`: the content
is written to a temporary file in the target folder and moved into place with
:func:`os.replace`, which is atomic on one file system. The file gets the permissions a plain ``open()`` would give it
(``0666`` less the user's umask; an existing file being replaced keeps its mode), and an error
while writing names the file the user asked for, never the temporary one.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from xlotkit.errors import InputError

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
    # Keep the real suffix last so writers that infer the format from it still work.
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}",
                                   dir=path.parent)
    except OSError as exc:
        raise InputError(f"cannot write the file ({exc.strerror})", file=path,
                         expected="a folder that exists and is writable") from None
    os.close(fd)
    try:
        write(Path(tmp))
        # mkstemp makes the file private (0600); a result gets the user's normal permissions
        os.chmod(tmp, _mode_for(path))
        if before_replace is not None:
            before_replace()
        os.replace(tmp, path)
    except OSError as exc:
        _unlink(tmp)
        # the temporary name means nothing to the user: name the file they asked for
        raise InputError(f"cannot write the file ({exc.strerror or exc})", file=path,
                         expected="a writable folder with free space") from None
    except BaseException:
        _unlink(tmp)
        raise
    return path


def _unlink(tmp: str) -> None:
    try:
        os.unlink(tmp)
    except OSError:
        pass


def _mode_for(path: Path) -> int:
    """Permissions a new file gets from the user's umask (an existing file keeps its own)."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


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
