"""Command-line layer of bhr (installed as ``bhr.cli``).

Each command lives in its own module and is loaded only when it is invoked,
so ``bhr --help`` does not import numba, matplotlib or pyserial.
"""

import os as _os
import signal as _signal
import sys as _sys

from bhr.errors import INTERRUPTED as _INTERRUPTED


def _on_interrupt(signum: int, frame: object) -> None:
    """Ctrl-C: remember it (so that a KeyboardInterrupt swallowed somewhere still ends the command) and raise."""
    _INTERRUPTED.set()
    raise KeyboardInterrupt


def _excepthook(kind: type[BaseException], exc: BaseException, tb: object) -> None:
    """A Ctrl-C that reached the top before any command's guard (while importing): one line, exit 130."""
    if issubclass(kind, KeyboardInterrupt):
        with __import__("contextlib").suppress(Exception):
            _sys.stderr.write("Interrupted.\n")
            _sys.stderr.flush()
        _os._exit(130)
    _previous_hook(kind, exc, tb)  # type: ignore[arg-type]


_previous_hook = _sys.excepthook
# Only in the bhr command itself (not when a test runner or a notebook imports the commands), in the main
# thread, and not when the shell asked this process to ignore Ctrl-C (a background job).
if "pytest" not in _sys.modules and _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler:
    try:
        _signal.signal(_signal.SIGINT, _on_interrupt)
        _sys.excepthook = _excepthook
    except ValueError:  # not the main thread
        pass
