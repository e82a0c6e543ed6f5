"""Helpers shared by the command modules: error reporting and output checks."""
from __future__ import annotations

import functools
import os
import sys
from pathlib import Path
from typing import Any, Callable

import click

from bhr.errors import BhrError


def guarded(func: Callable[..., Any]) -> Callable[..., Any]:
    """Turn a BhrError (and Ctrl-C) into one line on stderr and a non-zero exit."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except BhrError as exc:
            raise click.ClickException(str(exc).splitlines()[0] if str(exc) else type(exc).__name__) from None
        except KeyboardInterrupt:
            click.echo("Interrupted.", err=True)
            sys.exit(130)

    return wrapper


def check_writable(path: str | os.PathLike[str] | None, what: str = "output") -> None:
    """Fail before any work starts when ``path`` cannot be written.

    ``-`` (standard output) and ``None`` are always accepted.
    """
    if path is None or str(path) == "-":
        return
    p = Path(path)
    if p.exists() and p.is_dir():
        raise BhrError(f"{what} path {p} is a directory; give a file name")
    parent = p.parent if str(p.parent) else Path(".")
    probe = parent
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir() or not os.access(probe, os.W_OK):
        raise BhrError(f"cannot write {what} {p}: {probe} is not a writable folder; choose another path")
