"""The ``xlotkit`` command line.

Each command is a thin layer: it parses options (field units allowed here), calls the library,
and prints. Errors a user can cause are :class:`~xlotkit.errors.XlotkitError`; they are printed
as one line ``error: ...`` with exit status 2, never as a traceback.
"""

from __future__ import annotations

import functools
import sys

import click

from xlotkit import __version__
from xlotkit.errors import XlotkitError

__all__ = ["main"]


def _friendly_errors(func):
    """Turn xlotkit errors and unreadable files into one clear line and exit status 2."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except XlotkitError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)
        except (OSError, UnicodeDecodeError) as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)

    return wrapper


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="xlotkit")
def main() -> None:
    """Simulate and interpret extended leak-off tests (XLOT)."""
