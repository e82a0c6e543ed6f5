"""Output paths checked before any work (a refusal costs one line and no work), and the names of run folders."""
from __future__ import annotations

import fnmatch
import hashlib
import json
import os
from pathlib import Path
from typing import Any

from bhr._settings.errors import BhrError
from bhr._settings.options import excerpt, has_control_char

__all__ = ["short_path", "current_folder", "in_place_target", "check_output_file", "check_parent_folder",
           "settings_hash", "run_folder_name", "folder_name", "input_files", "json_in_folder", "sha256_file"]


def sha256_file(path: Path) -> str:
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def short_path(p: Any, limit: int = 80) -> str:
    """A path as quoted in a one-line message: control characters escaped, at most ``limit`` characters."""
    text = str(p) if str(p).isprintable() else str(p).encode("unicode_escape").decode("ascii")
    return text if len(text) <= limit else text[:limit - 3] + "..."


def current_folder() -> Path:
    try:
        return Path(os.getcwd())
    except FileNotFoundError:
        raise BhrError("the current folder no longer exists (it was deleted or moved away); cd into an existing "
                       "folder and run again") from None


def refuse_control(path: Any, what: str) -> None:
    if has_control_char(str(path)):
        raise BhrError(f"{what} path {excerpt(str(path))} contains a control character (a newline or tab); "
                       "give a plain name")


def unwritable_folder(p: Path) -> Path | None:
    """The nearest existing folder at or above ``p`` when this user cannot make files in it, else None."""
    while not p.exists() and p != p.parent:
        p = p.parent
    return None if p.is_dir() and os.access(p, os.W_OK | os.X_OK) else p


def in_place_target(path: Any) -> bool:
    """True for a target written in place: anything under /dev or /proc, or an existing non-regular file."""
    return os.path.abspath(path).startswith(("/dev/", "/proc/")) or (
        os.path.exists(path) and not os.path.isfile(path) and not os.path.isdir(path))


def check_output_file(path: Any, what: str = "output") -> None:
    """Refuse, before any work, an output file that cannot be written (``-``, standard output, always can)."""
    if str(path) == "-":
        return
    refuse_control(path, what)
    p = Path(path)
    if not p.is_absolute():
        current_folder()
    if p.is_dir():
        raise BhrError(f"{what} path {p} is a directory; give a file name")
    if p.is_symlink() and not in_place_target(p):
        raise BhrError(f"{what} {short_path(p)} is a symbolic link to {short_path(os.readlink(p))}; bhr does not "
                       "write through links: remove the link or choose another path")
    if p.exists() and not (os.access(p, os.W_OK) and (in_place_target(p) or p.stat().st_mode & 0o222)):
        raise BhrError(f"{what} {p} is read-only; make it writable (chmod u+w) or choose another path")
    if not in_place_target(p) and (bad := unwritable_folder(p.parent)) is not None:
        raise BhrError(f"cannot write {what} {p}: {bad} is not a writable folder; choose another path")


def settings_hash(*parts: Any) -> str:
    """8 hex digits of a SHA-256 over ``parts``: arrays' bytes, the content of files named by ``Path``, else JSON."""
    h = hashlib.sha256()
    for part in parts:
        if hasattr(part, "tobytes"):
            h.update(part.tobytes())
        elif isinstance(part, Path) and part.is_file():
            h.update(sha256_file(part).encode())
        else:
            h.update(json.dumps(part, sort_keys=True, default=repr).encode())
        h.update(b"\x00")
    return h.hexdigest()[:8]


def run_folder_name(readable: str, *parts: Any) -> str:
    return folder_name(readable, settings_hash(*parts))


def folder_name(readable: str, settings: str) -> str:
    """``readable`` made safe for a file name (at most 60 characters) plus ``-`` and the settings hash."""
    safe = "".join(c if c.isalnum() and c.isascii() or c in "-_." else "_" for c in readable)[:60].lstrip(".")
    return f"{safe or 'run'}-{settings}"


def input_files(*paths: Any) -> list[Path]:
    """The ones of ``paths`` that name existing files (inputs a run reads)."""
    return [Path(p) for p in paths if p is not None and str(p) != "-" and os.path.isfile(p)]


def json_in_folder(json_path: str | None, folder: Any, taken: tuple[str, ...], option: str = "--json") -> str | None:
    """The name inside the output folder that ``--json`` (or ``option``) names, else None; refuses a name that
    another output of the run writes."""
    if json_path is None or json_path == "-":
        return None
    try:
        name = str(Path(os.path.abspath(os.path.realpath(json_path))).relative_to(folder.target))
    except ValueError:
        return None
    if name in (".", "manifest.json") or any(fnmatch.fnmatch(name, pat) for pat in taken):
        raise BhrError(f"{option} {json_path} names another output of this run; choose another file name")
    return name


def check_parent_folder(folder: str | os.PathLike[str], what: str = "output folder") -> None:
    """Fail before any work when run folders cannot be made inside ``folder`` (the default ``bhr-out``)."""
    p = Path(folder)
    if not p.is_absolute():
        current_folder()
    if (bad := unwritable_folder(p)) is not None:
        raise BhrError(f"cannot make the {what} in {p}: {bad} is not a writable folder; give --out DIR")
