"""Ctrl-C in the ``bhr`` command: "Interrupted." and exit status 130 at any moment, never a traceback.

:func:`install` replaces Python's default SIGINT handler with one that also
sets :data:`bhr.settings.errors.INTERRUPTED` (so that a KeyboardInterrupt caught
somewhere on the way still ends the command, and no output folder is put in
place once it is set), and a ``sys.excepthook`` for a Ctrl-C that reaches the
top before any command's guard runs (while modules are still importing). It
is installed by the command line only: ``bhr/__init__`` calls it first thing
when the running program is the ``bhr`` console script, ``bhr.cli`` otherwise;
a program that imports the library keeps Python's own handling.
"""
from __future__ import annotations

import os
import signal
import sys

from bhr.settings.errors import INTERRUPTED

__all__ = ["install", "is_bhr_command"]

_installed = False


def is_bhr_command() -> bool:
    """True when the running program is the ``bhr`` console script."""
    return bool(sys.argv) and os.path.basename(sys.argv[0] or "") in ("bhr", "bhr.exe")


def _on_interrupt(signum: int, frame: object) -> None:
    INTERRUPTED.set()
    raise KeyboardInterrupt


def _excepthook(kind: type[BaseException], exc: BaseException, tb: object) -> None:
    if issubclass(kind, KeyboardInterrupt):
        try:
            sys.stderr.write("Interrupted.\n")
            sys.stderr.flush()
        except Exception:
            pass
        os._exit(130)
    _previous(kind, exc, tb)  # type: ignore[arg-type]


_previous = sys.excepthook


def install() -> None:
    """Install the handler and the hook (once; in the main thread; not where Ctrl-C is ignored or under pytest)."""
    global _installed
    if _installed or "pytest" in sys.modules:
        return
    try:
        if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:  # a background job: SIG_IGN
            return
        signal.signal(signal.SIGINT, _on_interrupt)
    except ValueError:  # not the main thread
        return
    sys.excepthook = _excepthook
    _installed = True
