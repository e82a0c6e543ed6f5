"""Module codes: checking them, naming their actuators, reading and writing ``codes.csv``.

A module's *code* says which of its four nitinol actuators are on (bit
``k-1`` for actuator ``k``, thesis Table 4.1); only six codes are stable
(thesis Table 4.2): 0 rest, 3/6/12/9 tilt by alpha about local +x/+y/-x/-y,
15 lift. The table itself, and what every other part of bhr derives from it,
is :mod:`bhr._kinematics.codetable` (docs/conventions.md shows it).
"""
from __future__ import annotations

import csv
import io
import os
import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Sequence, TypeGuard

if TYPE_CHECKING:  # numpy loads when a table is read or written: a code is checked without it
    import numpy as np

from bhr._settings.errors import BhrError
from bhr._settings.inputs import MAX_POINTS, broken_link, latest_note, read_capped
from bhr._settings.options import LIMITS, excerpt
from bhr._kinematics.codetable import CODE_AXIS, LIFT, REST, TILT_CODES, VALID_CODES

__all__ = ["REST", "LIFT", "VALID_CODES", "TILT_CODES", "CODE_AXIS", "is_valid_code", "check_code", "check_codes",
           "actuators", "format_codes_csv", "read_codes_csv"]

_VALID = frozenset(VALID_CODES)
_ALLOWED = ", ".join(map(str, sorted(VALID_CODES)))
#: Each stable code as 'bhr follow' writes it in a codes.csv cell, and its value (anything else goes through
#: check_code, which accepts it or names it).
_CELLS = {str(c): c for c in VALID_CODES}


def _whole(code: object) -> TypeGuard[int]:
    """An int, or a numpy integer (numpy is not imported for this: without it there are none)."""
    if isinstance(code, int):
        return True
    numpy = sys.modules.get("numpy")
    return numpy is not None and isinstance(code, numpy.integer)


def is_valid_code(code: int) -> bool:
    """True when ``code`` is one of the six stable codes (0, 3, 6, 9, 12, 15)."""
    return _whole(code) and int(code) in _VALID


def check_code(code: object, where: str = "") -> int:
    """Return ``code`` as an int, or raise BhrError naming it and the allowed codes."""
    place = f" {where}" if where else ""
    try:
        if _whole(code):
            value = int(code)
        else:
            text = str(code).strip()
            if not (text.isascii() and text.lstrip("+-").isdigit()):  # no "1_5", no full-width or Arabic digits
                raise ValueError(text)
            value = int(text)
    except ValueError:
        shown = repr(code) if len(str(code)) <= 40 else repr(str(code)[:40]) + "..."
        raise BhrError(f"code {shown}{place} is not a whole number; use one of {_ALLOWED}") from None
    if value not in _VALID:
        shown = str(value) if abs(value) < 10 ** 30 else f"of {len(str(abs(value)))} digits"  # not 400 of them
        raise BhrError(
            f"code {shown}{place} is not a stable actuator code; use one of {_ALLOWED}"
        )
    return value


def check_codes(codes: Iterable[object], where: str = "") -> list[int]:
    """Validate a sequence of codes, naming the module (1-based) of the first bad one.

    Parameters
    ----------
    codes : iterable of int, shape (n,)
        One code per module, base first.
    where : str, optional
        Where the codes came from (a file and line), added to the error message.

    Returns
    -------
    list of int, shape (n,)
        The codes, each one of :data:`VALID_CODES` (0, 3, 6, 9, 12, 15).

    Raises
    ------
    BhrError
        A code that is not a whole number or not a stable actuator code.

    Examples
    --------
    >>> check_codes([3, 0, 15])
    [3, 0, 15]
    >>> check_codes([3, 5], "in codes.csv")
    Traceback (most recent call last):
    ...
    bhr._settings.errors.BhrError: code 5 for module 2 in codes.csv is not a stable actuator code; use one of ...
    """
    if isinstance(codes, (str, bytes)) or not hasattr(codes, "__iter__"):  # None, 5, "30600": not one per module
        shown = repr(codes) if len(repr(codes)) <= 40 else repr(codes)[:40] + "..."
        raise BhrError(f"codes{' ' + where if where else ''} must be a sequence of whole numbers, one per module "
                       f"(such as [3, 0, 15]), got {shown}")
    out = []
    for i, c in enumerate(codes, start=1):
        out.append(check_code(c, f"for module {i}{' ' + where if where else ''}"))
    return out


def actuators(code: int) -> tuple[int, ...]:
    """The actuators (1-4) that are on for ``code``."""
    return tuple(k for k in range(1, 5) if code & (1 << (k - 1)))


# ---------------------------------------------------------------------------
# codes.csv: header ``step,m1,...,mN`` then one row per step.


def format_codes_csv(codes: np.ndarray | Sequence[Sequence[int]], steps: Sequence[int] | None = None) -> str:
    """Render a (steps, modules) array of codes as the text of ``codes.csv``.

    Parameters
    ----------
    codes : array_like of int, shape (S, n)
        One row per step, one code per module, base first (``m1`` is the base module).
    steps : sequence of int, shape (S,), optional
        The step numbers written in the ``step`` column; default 1 ... S.

    Returns
    -------
    str
        The CSV text: a header ``step,m1,...,mn`` and one line per step, each ending in a newline.

    Raises
    ------
    BhrError
        ``codes`` is not a two-dimensional table.

    Examples
    --------
    >>> print(format_codes_csv([[3, 0], [0, 6]]), end="")
    step,m1,m2
    1,3,0
    2,0,6
    """
    import numpy as np

    arr = np.asarray(codes, dtype=np.int64)
    if arr.ndim != 2:
        raise BhrError("codes must be a table of steps by modules")
    if steps is None:
        steps = range(1, arr.shape[0] + 1)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["step"] + [f"m{j}" for j in range(1, arr.shape[1] + 1)])
    for s, row in zip(steps, arr):
        writer.writerow([int(s)] + [int(v) for v in row])
    return buf.getvalue()


def raw_line(path: Path, offset: int) -> int:
    """The line (from 1) that byte ``offset`` of ``path`` is on."""
    with open(path, "rb") as fh:
        return fh.read(offset).count(b"\n") + 1


def read_codes_csv(path: str | os.PathLike[str]) -> tuple[list[int], np.ndarray]:
    """Read and validate a ``codes.csv``; return (steps, codes array of shape (steps, N)).

    The whole file is checked before anything is returned: an invalid code is
    reported with its line and column name, so nothing is ever sent from a
    file that holds one.

    Parameters
    ----------
    path : str or os.PathLike
        The ``codes.csv`` file (as ``bhr follow`` writes it: ``step,m1,...,mn`` then one row per step).

    Returns
    -------
    steps : list of int, shape (S,)
        The ``step`` column.
    codes : numpy.ndarray of int64, shape (S, n)
        One row per step, one code per module, each one of :data:`VALID_CODES`.

    Raises
    ------
    BhrError
        A missing or unreadable file, a malformed table or an invalid code, named with its line and column.
    """
    p = Path(path)
    hint = "give the codes.csv written by 'bhr follow'"
    try:
        if p.is_dir():
            raise BhrError(f"{p} is a folder, not a codes file; {hint}")
        text = read_capped(p, "codes file", hint).decode("utf-8-sig")
    except OSError as exc:
        link = broken_link(p)
        if link:
            raise BhrError(f"{link}; {hint}") from None
        if isinstance(exc, FileNotFoundError):
            raise BhrError(f"codes file {p} does not exist{latest_note(p)}; {hint}") from None
        raise BhrError(f"cannot read codes file {p} ({exc.strerror or exc.__class__.__name__}); {hint}") from None
    except UnicodeDecodeError as exc:
        raise BhrError(f"{p}, line {raw_line(p, exc.start)}: not UTF-8 text; save the codes file as UTF-8 "
                       f"({hint})") from None
    if "\x00" in text:
        raise BhrError(f"{p}: binary data (a NUL byte); {hint}")
    try:
        rows = list(csv.reader(io.StringIO(text)))
    except csv.Error as exc:  # e.g. a field longer than csv's 131072-character limit
        raise BhrError(f"{p}: not a codes table ({str(exc).splitlines()[0][:80]}); {hint}") from None
    if len(rows) > MAX_POINTS + 1:
        raise BhrError(f"{p}: more than {MAX_POINTS} steps; split the file ({hint})")
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if not rows:
        raise BhrError(f"{p} is empty; {hint} (a header 'step,m1,...,mN' and one row per step)")
    header = [h.strip() for h in rows[0]]
    n = len(header) - 1
    if n > LIMITS["code_modules"]:
        raise BhrError(f"{p}:1: {n} module columns, more than the {LIMITS['code_modules']} a robot may have; "
                       f"{hint}")
    if n < 1 or header[0] != "step" or header[1:] != [f"m{j}" for j in range(1, n + 1)]:
        raise BhrError(f"{p}:1: header must be 'step,m1,...,mN' (as 'bhr follow' writes), got "
                       f"{excerpt(','.join(header))}")
    if (len(rows) - 1) * n > LIMITS["plan_cells"]:
        raise BhrError(f"{p}: {len(rows) - 1} steps x {n} modules is more than the {LIMITS['plan_cells']:,} codes "
                       f"a table may hold; split the file ({hint})")
    if len(rows) < 2:
        raise BhrError(f"{p} has a header but no steps; add at least one row")
    import numpy as np  # the file is a table: only now

    steps: list[int] = []
    table = np.zeros((len(rows) - 1, n), dtype=np.int64)
    for i, row in enumerate(rows[1:]):
        line = i + 2
        if len(row) != n + 1:
            raise BhrError(f"{p}:{line}: expected {n + 1} columns (step and {n} modules), got {len(row)}")
        cell = row[0].strip()
        if not (re.fullmatch(r"[+-]?[0-9]+", cell) and len(cell) <= 12):  # one sign at most: not "--1"
            raise BhrError(f"{p}:{line}: step {cell[:40]!r} is not a whole number of at most 12 digits")
        steps.append(int(cell))
        cells = row[1:]
        if all(c in _CELLS for c in cells):  # the written form of the stable codes: no need to look closer
            table[i] = [_CELLS[c] for c in cells]
            continue
        for j, cell in enumerate(cells):
            table[i, j] = check_code(cell, f"at {p}:{line} column m{j + 1}")
    return steps, table
