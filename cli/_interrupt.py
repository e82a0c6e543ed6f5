"""The end of an interrupted command, for the group and for every command's guard."""
from __future__ import annotations

import sys
from typing import NoReturn

import click


def end_interrupted() -> NoReturn:
    """End an interrupted command: its one line ("Interrupted.", or the signal's name) and exit status."""
    from bhr.settings.interrupts import ending

    line, status = ending()
    click.echo(line, err=True)
    sys.exit(status)
