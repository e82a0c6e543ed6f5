"""Errors that bhr reports to users as one line naming the problem and the fix."""
from __future__ import annotations


class BhrError(ValueError):
    """Bad input or an unusable environment.

    The message is a single line that names what is wrong and what to do
    instead; the command-line layer prints it without a traceback and exits
    with a non-zero status.
    """


class LinkError(BhrError):
    """The serial link to the actuator board failed (timeout, NAK, port gone)."""


class _Flag:
    """A process-wide flag (``set``/``is_set``), cheap to import: no threading needed to read or set it."""

    def __init__(self) -> None:
        self._set = False

    def set(self) -> None:
        self._set = True

    def clear(self) -> None:
        self._set = False

    def is_set(self) -> bool:
        return self._set


#: Set by the command line's Ctrl-C handler (``bhr.cli``): whatever catches the KeyboardInterrupt later, the
#: command ends "Interrupted." with exit status 130 and no output folder is put in place once it is set.
INTERRUPTED = _Flag()
