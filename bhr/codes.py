"""Module codes: which actuators are on, and which tilt or lift that gives.

Each module carries four nitinol actuators numbered 1-4 around its axis. A
module's *code* is a 4-bit number with bit ``k-1`` set when actuator ``k`` is
on (thesis Table 4.1). Only six codes are stable (thesis Table 4.2):

====  =========  ===========================================  ==================
code  actuators  motion of the next module                    signed local axis
====  =========  ===========================================  ==================
0     none       rest (straight)                              --
3     1+2        tilt by alpha                                +x
6     2+3        tilt by alpha                                +y
12    3+4        tilt by alpha                                -x
9     4+1        tilt by alpha                                -y
15    all four   lift (straight, longer by the stroke)        --
====  =========  ===========================================  ==================

Local frame of a module: ``z`` along the module (base to tip), ``x`` and ``y``
its two tilt axes, right-handed. Actuator ``k`` sits at azimuth
``45 deg + (k-1)*90 deg`` from ``x`` toward ``y``; raising two neighbours
raises that side, which tips the next module away from it, i.e. a right-hand
rotation by alpha about the axis in the table. The same table is used by the
solvers, the serial protocol and the firmware (docs/conventions.md).
"""
from __future__ import annotations

import csv
import io
import os
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from bhr.errors import BhrError

REST = 0
LIFT = 15
#: The stable codes, in the order rest, +x, +y, -x, -y, lift.
VALID_CODES: tuple[int, ...] = (0, 3, 6, 12, 9, 15)
#: Tilt codes indexed by signed axis: 0 -> +x, 1 -> +y, 2 -> -x, 3 -> -y.
TILT_CODES: tuple[int, ...] = (3, 6, 12, 9)
#: For each tilt code, (axis index 0=x/1=y, sign +1/-1).
CODE_AXIS: dict[int, tuple[int, int]] = {3: (0, 1), 6: (1, 1), 12: (0, -1), 9: (1, -1)}
_VALID = frozenset(VALID_CODES)


def is_valid_code(code: int) -> bool:
    """True when ``code`` is one of the six stable codes 0, 3, 6, 9, 12, 15."""
    return isinstance(code, (int, np.integer)) and int(code) in _VALID


def check_code(code: object, where: str = "") -> int:
    """Return ``code`` as an int, or raise BhrError naming it and the allowed codes."""
    place = f" {where}" if where else ""
    try:
        if isinstance(code, (int, np.integer)):
            value = int(code)
        else:
            text = str(code).strip()
            if not (text.isascii() and text.lstrip("+-").isdigit()):  # no "1_5", no full-width or Arabic digits
                raise ValueError(text)
            value = int(text)
    except ValueError:
        shown = repr(code) if len(str(code)) <= 40 else repr(str(code)[:40]) + "..."
        raise BhrError(f"code {shown}{place} is not a whole number; use one of 0, 3, 6, 9, 12, 15") from None
    if value not in _VALID:
        raise BhrError(
            f"code {value}{place} is not a stable actuator code; use one of 0, 3, 6, 9, 12, 15"
        )
    return value


def check_codes(codes: Iterable[object], where: str = "") -> list[int]:
    """Validate a sequence of codes, naming the module (1-based) of the first bad one."""
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
    """Render a (steps, modules) array of codes as the text of ``codes.csv``."""
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


def read_codes_csv(path: str | os.PathLike[str]) -> tuple[list[int], np.ndarray]:
    """Read and validate a ``codes.csv``; return (steps, codes array of shape (steps, N)).

    The whole file is checked before anything is returned: an invalid code is
    reported with its line and column name, so nothing is ever sent from a
    file that holds one.
    """
    from bhr._input import MAX_POINTS, read_capped

    p = Path(path)
    hint = "give the codes.csv written by 'bhr follow'"
    try:
        if p.is_dir():
            raise IsADirectoryError(str(p))
        text = read_capped(p, "codes file", hint).decode("utf-8-sig")
    except FileNotFoundError:
        raise BhrError(f"codes file {p} does not exist; {hint}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise BhrError(f"cannot read codes file {p}: {exc.__class__.__name__}; give a readable CSV file") from None
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
        raise BhrError(f"{p} is empty; expected a header 'step,m1,...,mN' and one row per step")
    header = [h.strip() for h in rows[0]]
    n = len(header) - 1
    if n < 1 or header[0] != "step" or header[1:] != [f"m{j}" for j in range(1, n + 1)]:
        raise BhrError(f"{p}:1: header must be 'step,m1,...,mN' (as 'bhr follow' writes), got {','.join(header)!r}")
    if len(rows) < 2:
        raise BhrError(f"{p} has a header but no steps; add at least one row")
    steps: list[int] = []
    table = np.zeros((len(rows) - 1, n), dtype=np.int64)
    for i, row in enumerate(rows[1:]):
        line = i + 2
        if len(row) != n + 1:
            raise BhrError(f"{p}:{line}: expected {n + 1} columns (step and {n} modules), got {len(row)}")
        cell = row[0].strip()
        if not (cell.isascii() and cell.lstrip("+-").isdigit() and len(cell) <= 12):
            raise BhrError(f"{p}:{line}: step {cell[:40]!r} is not a whole number of at most 12 digits")
        steps.append(int(cell))
        for j, cell in enumerate(row[1:]):
            table[i, j] = check_code(cell, f"at {p}:{line} column m{j + 1}")
    return steps, table
