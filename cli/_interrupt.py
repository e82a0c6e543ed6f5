"""Ctrl-C, SIGTERM and SIGHUP end a bhr command with one line and exit status 128 + the signal's number.

:func:`install` (called by the ``bhr`` program, not by code that imports bhr) gives the three signals one plain
handler that raises :class:`Interrupted`, a KeyboardInterrupt, so that ``except KeyboardInterrupt`` ends the
command (:func:`end_interrupted`). A signal the caller ignored stays ignored: Ctrl-C in a background job
(``bhr ... &``), SIGHUP under ``nohup``.
"""
from __future__ import annotations

import signal
import sys
from typing import NoReturn

import click

from bhr.settings.errors import INTERRUPTED

SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


class Interrupted(KeyboardInterrupt):
    """The command was interrupted by ``signum``."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


_received: list[int] = []


def _raise(signum: int, frame: object) -> None:
    _received.append(signum)
    INTERRUPTED.set()  # seen even where a library catches the KeyboardInterrupt
    raise Interrupted(signum)


def install() -> None:
    """Raise :class:`Interrupted` on each of :data:`SIGNALS` that has its default action."""
    for sig in SIGNALS:
        if signal.getsignal(sig) in (signal.SIG_DFL, signal.default_int_handler):
            signal.signal(sig, _raise)


def settle() -> None:
    """The command's outputs go in place now: from here on the signals are ignored, so the set goes in place whole
    and the command ends with its own status."""
    for sig in SIGNALS:
        if signal.getsignal(sig) is _raise:
            signal.signal(sig, signal.SIG_IGN)


def end_interrupted(exc: BaseException | None = None) -> NoReturn:
    """End an interrupted command: "Interrupted." (or "Interrupted by SIGTERM.") and 128 + the signal."""
    signum = getattr(exc, "signum", _received[0] if _received else signal.SIGINT)
    click.echo("Interrupted." if signum == signal.SIGINT else f"Interrupted by {signal.Signals(signum).name}.",
               err=True)
    sys.exit(128 + signum)
