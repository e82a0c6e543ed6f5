"""Errors that bhr reports to users as one line naming the problem and the fix."""
from __future__ import annotations


class BhrError(ValueError):
    """Bad input or an unusable environment.

    The message is a single line that names what is wrong and what to do
    instead; the command-line layer prints it without a traceback and exits
    with a non-zero status. A subclass of :class:`ValueError`, so code that
    catches bad values catches it too.

    Raised as ``BhrError(message)``: it takes no parameter of its own.

    Attributes
    ----------
    args : tuple of str
        ``(message,)``: one line, what is wrong and the fix, e.g. ``"modules must be greater than 0, got 0"``;
        ``str(error)`` is the message.

    Examples
    --------
    >>> import bhr
    >>> try:
    ...     bhr.Robot(modules=0)
    ... except bhr.BhrError as exc:
    ...     print("refused")
    refused
    """


class LinkError(BhrError):
    """The serial link to the actuator board failed (timeout, NAK, port gone).

    A :class:`BhrError`, so it is reported the same way: one line, no traceback.

    Attributes
    ----------
    args : tuple of str
        ``(message,)``: one line, what failed on the link and what to do (check the port, the board's power).
    """


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
