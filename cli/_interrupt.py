"""Ctrl-C, SIGTERM and SIGHUP end a bhr command with one line and exit status 128 + the signal's number.

:func:`install` (the ``bhr`` program, not ``import bhr``) makes each raise KeyboardInterrupt, unless the caller
ignored it: Ctrl-C in a background job (``bhr ... &``) and SIGHUP under ``nohup`` stay ignored.
"""
from __future__ import annotations

import signal
import sys
from typing import NoReturn

import click

from bhr._settings.errors import INTERRUPTED

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_received: list[int] = []


def _raise(signum: int, frame: object) -> None:
    _received.append(signum)
    INTERRUPTED.set()  # seen even where a library catches the KeyboardInterrupt
    raise KeyboardInterrupt


def install() -> None:
    for sig in SIGNALS:
        if signal.getsignal(sig) in (signal.SIG_DFL, signal.default_int_handler):
            signal.signal(sig, _raise)


def settle() -> None:
    """The outputs go in place now: the signals are ignored from here on, so the set goes in place whole."""
    for sig in SIGNALS:
        if signal.getsignal(sig) is _raise:
            signal.signal(sig, signal.SIG_IGN)


def exit_status() -> int:
    return 128 + (_received[0] if _received else signal.SIGINT)


def end_interrupted() -> NoReturn:
    """Say "Interrupted." (or "Interrupted by SIGTERM.") and exit with 128 + the signal."""
    signum = exit_status() - 128
    click.echo("Interrupted." if signum == signal.SIGINT else f"Interrupted by {signal.Signals(signum).name}.",
               err=True)
    sys.exit(128 + signum)
