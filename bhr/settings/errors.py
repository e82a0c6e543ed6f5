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
