"""Error types.

Every error a user can cause (a malformed log, a missing column, a wrong unit, an impossible
scene value) is raised as an :class:`InputError` that names where the problem is (file, line,
key) and what was expected. The CLI prints it as one line and exits with status 2; it never
shows a traceback for these.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["InputError", "XlotkitError"]


class XlotkitError(Exception):
    """Base class of all errors raised on purpose by xlotkit."""


class InputError(XlotkitError, ValueError):
    """Bad user input, located as precisely as it can be.

    Parameters
    ----------
    message : str
        What is wrong.
    file : str or Path, optional
        The file the input came from.
    line : int, optional
        1-based line number in ``file``.
    key : str, optional
        Column name, option name or scene key concerned.
    expected : str, optional
        What would have been accepted.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | Path | None = None,
        line: int | None = None,
        key: str | None = None,
        expected: str | None = None,
    ) -> None:
        self.message = message
        self.file = None if file is None else str(file)
        self.line = line
        self.key = key
        self.expected = expected
        super().__init__(self._format())

    def _format(self) -> str:
        where = ""
        if self.file is not None:
            where = self.file
            if self.line is not None:
                where += f":{self.line}"
            where += ": "
        elif self.line is not None:
            where = f"line {self.line}: "
        key = f"{self.key}: " if self.key else ""
        exp = f" (expected {self.expected})" if self.expected else ""
        return f"{where}{key}{self.message}{exp}"
