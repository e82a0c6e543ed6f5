"""Checks shared by the input-file readers (robot files, trajectory files).

Every problem becomes a :class:`~bhr._settings.errors.BhrError` whose one-line message
names the file, the key (or line), what is wrong and what is allowed.
"""
from __future__ import annotations

import math
import os
import tomllib
from pathlib import Path
from typing import Any, Iterable

from bhr._settings.errors import BhrError
from bhr._settings.options import MAX_MM, LIMITS, Underflow, check_number, did_you_mean, file_float, has_control_char
from bhr._settings.options import parse_number
from bhr._settings.options import excerpt as _excerpt
from bhr._settings.options import type_name as _type_name

__all__ = ["MAX_REASON_CHARS", "reason",
           "MAX_FILE_BYTES", "MAX_RUN_BYTES", "MAX_MM", "MAX_POINTS", "MAX_STEP_POINTS", "check_step_points",
           "read_capped", "read_text",
           "read_toml", "check_keys", "type_name", "number", "vector3", "text_value", "choice", "did_you_mean",
           "parse_number", "check_number", "excerpt", "check_regular", "check_input", "shown_path", "broken_link",
           "latest_note"]

#: Input files larger than this are refused: at most this many bytes are ever read, whatever the file's size
#: reads as (a link to /dev/zero reads as 0 bytes and never ends).
MAX_FILE_BYTES = 64 * 1024 * 1024
#: A path may have at most this many points after sampling (trajectory generators, segment and CSV files).
MAX_POINTS = LIMITS["points"]
#: A run may hold at most this many robot points in all: steps x (modules + 1), the body's modules when
#: simulated. Memory grows by about 0.7-1.4 kB per step and point (run.json and figures included; measured
#: in docs/commands.md), so a run at the limit stays within about 3.5 GB (a 5-module robot on a path of
#: MAX_POINTS fits, and the whole robot to the cecum of anatomical colon 3 at feed divisor 10).
MAX_STEP_POINTS = LIMITS["step_points"]
#: A run.json may be this large: a run bhr may write is one bhr reads back. run.json takes about 145 bytes
#: per step and robot point (a 61-module trail run on anatomical colon 2: 17.1 MB for 1,931 steps), so
#: 256 bytes per point leaves room for the longest numbers.
MAX_RUN_BYTES = 256 * MAX_STEP_POINTS


def check_step_points(steps: int, points: int) -> None:
    """A run of ``steps`` steps of ``points`` robot points each is within :data:`MAX_STEP_POINTS`, or one line."""
    if steps * points > MAX_STEP_POINTS:
        raise BhrError(f"{steps} steps x {points} robot points is {steps * points:,} points to keep, more than the "
                       f"{MAX_STEP_POINTS:,} a run may hold in memory; shorten the path, raise the feed or use fewer "
                       "modules")


def latest_note(p: Path) -> str:
    """Where ``bhr-out/latest`` on the way to a missing ``p`` points, and the files of that name inside it.

    ``latest`` is the folder the last command wrote: after ``bhr compare`` or a report its runs are one
    folder down (``bhr-out/latest/thesis/codes.csv``), and the note names them, so the hint that named
    ``bhr-out/latest/codes.csv`` leads on to a file that is there.
    """
    for parent in p.parents:
        if parent.name == "latest" and parent.is_symlink():  # bhr-out/latest, the link bhr keeps to a folder it wrote
            try:
                note = f" ({parent} points to {os.readlink(parent)}, which has none"
                rest = p.relative_to(parent)
                inside = sorted(q for q in parent.glob(f"*/{rest}") if q.is_file())
                inside += sorted(q for q in parent.glob(f"*/*/{rest}") if q.is_file())
            except (OSError, ValueError):
                return ""
            if inside:
                more = f" and {len(inside) - 3} more" if len(inside) > 3 else ""
                note += f"; its runs have {', '.join(str(q) for q in inside[:3])}{more}"
            return note + ")"
    return ""


def read_text(path: str | os.PathLike[str], what: str, hint: str, limit: int | None = None, *,
              empty_ok: bool = False) -> str:
    """The UTF-8 text of ``path`` (at most ``limit`` bytes, :data:`MAX_FILE_BYTES` by default); a BhrError
    naming ``what`` and ``hint`` otherwise, also for a file of no text (nothing, or only white space) unless
    ``empty_ok``."""
    p = check_input(path, what, hint, empty_ok=True)  # missing, a folder, a FIFO or device, unreadable: one line
    try:
        raw = read_capped(p, what, hint, limit)
    except OSError as exc:  # it changed since
        raise BhrError(f"cannot read {what} {shown_path(p)} ({exc.strerror or exc.__class__.__name__}); {hint}"
                       ) from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise BhrError(f"{p}, line {line}: not UTF-8 text; save the {what} as UTF-8 ({hint})") from None
    if "\x00" in text:
        line = text[:text.index("\x00")].count("\n") + 1
        raise BhrError(f"{p}, line {line}: binary data (a NUL byte); give a {what} in text form ({hint})")
    if not empty_ok and not text.strip():
        raise BhrError(f"{p} is empty ({'only white space' if text else '0 bytes'}), not a {what}; {hint}")
    return text


def read_capped(path: str | os.PathLike[str], what: str, hint: str, limit: int | None = None) -> bytes:
    """The bytes of ``path``, reading at most ``limit`` (default :data:`MAX_FILE_BYTES`) + 1 of them.

    The size ``stat`` reports is not trusted: /dev/zero, /proc files and
    FIFOs report 0 and may never end. A longer input is refused.
    """
    limit = MAX_FILE_BYTES if limit is None else limit
    check_regular(path, what, hint)  # before open(): opening a FIFO waits for a writer forever
    with open(path, "rb") as fh:
        kind = _special_kind(os.fstat(fh.fileno()).st_mode)
        if kind:  # it became one between the check and open()
            raise BhrError(f"{path} is {kind}, not a {what}; {hint}")
        raw = fh.read(limit + 1)
    if len(raw) > limit:
        raise BhrError(f"{path} is larger than {limit // (1024 * 1024)} MiB, too large for a {what}; {hint}")
    return raw


def broken_link(path: str | os.PathLike[str]) -> str | None:
    """How ``path`` fails to resolve when it is a symbolic link that leads nowhere (a missing target or a loop),
    as words for a one-line message; None when it is not one (a plain missing file keeps its reader's words)."""
    import errno

    p = Path(path)
    try:
        if not p.is_symlink():
            return None
        target = os.readlink(p)
    except OSError:
        return None
    try:
        os.stat(p)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return f"{_excerpt(str(p), 80)} is a symbolic link that loops (it leads back to itself)"
        return f"{_excerpt(str(p), 80)} is a symbolic link to {_excerpt(target, 80)}, which does not exist"
    return None


def check_regular(path: str | os.PathLike[str], what: str, hint: str) -> None:
    """Refuse an input that is not a regular file (a FIFO, socket or device), before it is opened.

    Opening a FIFO blocks until someone writes to it, a device may never end:
    an input file must be a file. Missing files are left to the reader's own message.
    """
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    kind = _special_kind(mode)
    if kind:
        raise BhrError(f"{shown_path(path)} is {kind}, not a {what}; {hint}")


def shown_path(path: str | os.PathLike[str]) -> str:
    """``path`` as a one-line message shows it: as given, or quoted and escaped when it holds a control character
    (a line break in a file name would forge a second line)."""
    text = str(path)
    return _excerpt(text, 200) if has_control_char(text) else text


def _special_kind(mode: int) -> str | None:
    """What a file of ``mode`` is when it is neither a regular file nor a folder: "a FIFO (named pipe)", "a socket",
    "a character device" or "a block device"; None otherwise."""
    import stat as _stat

    kinds = ((_stat.S_ISFIFO, "a FIFO (named pipe)"), (_stat.S_ISSOCK, "a socket"),
             (_stat.S_ISCHR, "a character device"), (_stat.S_ISBLK, "a block device"))
    return next((kind for test, kind in kinds if test(mode)), None)


def check_input(path: str | os.PathLike[str], what: str, hint: str, *, empty_ok: bool = False) -> Path:
    """``path`` as a Path when it is a regular file that bhr can read and (unless ``empty_ok``) holds at least a byte.

    Otherwise a BhrError, one line naming what the path is and ``hint``: missing (or a symbolic link that leads
    nowhere), a folder, a FIFO, socket or device (never opened: opening a FIFO waits for a writer), not readable,
    or empty. For readers that do not go through :func:`read_text` (meshes, images), before they dispatch on the
    file's extension, so that ``/dev/null`` is named a device rather than a file of the wrong type.
    """
    import stat as _stat

    p = Path(path)
    shown = shown_path(p)
    try:
        mode = os.stat(p).st_mode
    except FileNotFoundError:
        link = broken_link(p)
        raise BhrError(f"{link}; {hint}" if link else f"no such {what} {shown}{latest_note(p)}; {hint}") from None
    except PermissionError:
        raise BhrError(f"cannot reach {what} {shown}: permission denied on a folder on its way; {hint}") from None
    except OSError as exc:
        link = broken_link(p)
        raise BhrError(f"{link}; {hint}" if link else
                       f"cannot read {what} {shown} ({exc.strerror or exc.__class__.__name__}); {hint}") from None
    if _stat.S_ISDIR(mode):
        raise BhrError(f"{shown} is a folder, not a {what}; {hint}")
    kind = _special_kind(mode)
    if kind:
        raise BhrError(f"{shown} is {kind}, not a {what}; {hint}")
    try:
        with open(p, "rb") as fh:
            first = fh.read(1)
    except PermissionError:
        raise BhrError(f"cannot read {what} {shown}: permission denied (it must be readable by you); {hint}") from None
    except OSError as exc:
        raise BhrError(f"cannot read {what} {shown} ({exc.strerror or exc.__class__.__name__}); {hint}") from None
    if not first and not empty_ok:
        raise BhrError(f"{shown} is empty (0 bytes), not a {what}; {hint}")
    return p


def read_toml(path: str | os.PathLike[str], what: str, hint: str, *, empty_ok: bool = False) -> dict[str, Any]:
    """Parse ``path`` as TOML; a BhrError naming the line on a syntax error (and, unless ``empty_ok``, for an
    empty file)."""
    text = read_text(path, what, hint, empty_ok=empty_ok)
    try:
        return tomllib.loads(text, parse_float=file_float)
    except Underflow as exc:
        raise BhrError(f"{path}: {exc}") from None
    except RecursionError:
        raise BhrError(f"{path}: nested too deeply to read; {hint}") from None
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc).splitlines()[0] if str(exc) else "syntax error"
        raise BhrError(f"{path}: not valid TOML ({msg}); {hint}") from None


def check_keys(table: dict[str, Any], allowed: Iterable[str], where: str) -> None:
    """Refuse keys of ``table`` outside ``allowed``, suggesting the nearest allowed name."""
    allowed = list(allowed)
    for key in table:
        if key not in allowed:
            raise BhrError(f"{where}: unknown key {_excerpt(key)}; {did_you_mean(key, allowed)}allowed: "
                           f"{', '.join(allowed)}")


def check_document(data: dict[str, Any], allowed: Iterable[str], source: str, what: str, hint: str) -> None:
    """A batch or sweep file's top level: only ``allowed`` keys (with did-you-mean), ``title`` and
    ``description`` as text. ``what`` names a key ("top-level key"), ``hint`` says where other values go."""
    allowed = list(allowed)
    for key in data:
        if key not in allowed:
            raise BhrError(f"{source}: unknown {what} {_excerpt(key)}; {did_you_mean(key, allowed)}allowed: "
                           f"{', '.join(allowed)} ({hint})")
    for key in ("title", "description"):
        if key in data and not isinstance(data[key], str):
            raise BhrError(f"{source}: {key} must be a string, got {_excerpt(data[key])}")


def type_name(value: Any) -> str:
    return _type_name(value)


def number(value: Any, where: str, *, positive: bool = False, nonneg: bool = False, integer: bool = False,
           unit: str = "", maximum: float | None = None) -> float:
    """A finite number (int or float, not bool) with the given sign and at most ``maximum``; BhrError otherwise.

    The one checker of :func:`bhr._settings.options.check_number` (integers of any length, denormals, the sign).
    """
    return check_number(value, where, integer=integer, limit=1e300, unit=unit, positive=positive, nonneg=nonneg,
                        maximum=maximum)


def vector3(value: Any, where: str, *, nonzero: bool = False) -> tuple[float, float, float]:
    """Three finite numbers ``[x, y, z]`` (not all zero when ``nonzero``)."""
    if not isinstance(value, list) or len(value) != 3:
        raise BhrError(f"{where} must be a list of three numbers [x, y, z], got {type_name(value)}"
                       + (f" of {len(value)}" if isinstance(value, list) else ""))
    out = tuple(number(v, f"{where}[{i}]") for i, v in enumerate(value))
    if any(abs(v) > MAX_MM for v in out):
        raise BhrError(f"{where} must have coordinates within +-{MAX_MM:g} mm, got {list(out)}")
    if nonzero and math.hypot(*out) < 1e-9:
        raise BhrError(f"{where} must not be [0, 0, 0] or nearly so (length under 1e-9); give a direction "
                       "such as [1, 0, 0]")
    return out  # type: ignore[return-value]


def excerpt(value: Any, limit: int = 40) -> str:
    """``value`` as a message may quote it: its repr, escaped, cut to ``limit`` characters."""
    return _excerpt(value, limit)


def text_value(value: Any, where: str) -> str:
    if not isinstance(value, str):
        raise BhrError(f"{where} must be text in quotes, got {type_name(value)}")
    return value


def name_value(value: Any, where: str) -> str:
    """A file's ``name`` (a trajectory's, a robot's): text on one line of printable characters, since the summary,
    the warnings and the figures print it (a newline in it would forge a line such as "Error: ...")."""
    name = text_value(value, where)
    if has_control_char(name):
        raise BhrError(f"{where} {_excerpt(name)} holds a control character (a tab, a line break or an escape); "
                       "give a name on one line")
    hidden = next((c for c in name if not c.isprintable()), None)
    if hidden is not None:  # a right-to-left override shows the name reversed
        raise BhrError(f"{where} {_excerpt(name)} holds U+{ord(hidden):04X}, an invisible or formatting character; "
                       "give a name of printable characters")
    return name


def choice(value: Any, where: str, allowed: Iterable[str]) -> str:
    allowed = list(allowed)
    if not isinstance(value, str) or value not in allowed:
        shown = _excerpt(value) if isinstance(value, str) else type_name(value)
        raise BhrError(f"{where} must be one of {', '.join(repr(a) for a in allowed)}, got {shown}")
    return value


#: The longest reason a study's row keeps (summary.csv, the report's page, the table printed).
MAX_REASON_CHARS = 300


def reason(exc: BaseException) -> str:
    """One line saying why a run failed: a BhrError's own first line, a failed read or write's file (quoted short)
    and why, else the exception's type and first line; at most :data:`MAX_REASON_CHARS` characters."""
    if isinstance(exc, BhrError):
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    elif isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror + (f": {_excerpt(str(exc.filename), 80)}" if exc.filename is not None else "")
    else:
        lines = str(exc).splitlines()
        text = f"{type(exc).__name__}: {lines[0]}" if lines else type(exc).__name__
    return text if len(text) <= MAX_REASON_CHARS else text[:MAX_REASON_CHARS - 3] + "..."
