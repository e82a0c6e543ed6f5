"""Outputs written whole or not at all: single files, output folders, and sets of both.

A file is written beside its target and renamed onto it (a device, or anything under /dev, is written in place).
An output folder is staged beside its target (``.NAME.bhr-stage-*``) and renamed into place; the lock file
``.NAME.bhr-lock`` (filelock) is held from the stage's start until then. Its plain ``manifest.json`` lists the files
bhr wrote: a folder holding anything else (or a listed file changed) is refused unless ``force``, as ``git clone``
refuses a non-empty folder. Inside :func:`together`, everything goes in place at the end of the block, or nothing.
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import time
import uuid
from pathlib import Path
from typing import Any, Callable, Iterator

from bhr import __version__
from bhr.output._paths import (check_output_file, current_folder, in_place_target, refuse_control, sha256_file,
                              short_path, unwritable_folder)
from bhr._settings.errors import INTERRUPTED, BhrError
from bhr._settings.options import has_control_char

__all__ = ["atomic_path", "write_text", "write_json", "json_text", "together", "place_now", "OutputFolder", "MANIFEST",
           "read_manifest", "owning_folder", "point_latest"]

MANIFEST = "manifest.json"
LOCK_WAIT_S = 600.0  # how long a run waits for another one writing the same folder
_set: list[tuple[int, Callable[[], Any], Callable[[], Any]]] | None = None  # (rank, place, discard) of a set
# the temporary files and stages not yet placed or removed: a Ctrl-C lands as any call starts or returns, even as
# an ``__exit__`` is called, before its clean-up runs; then :func:`together` removes what its block left
_pending: set[Path] = set()


def _mode_for(target: Path, new: int = 0o666) -> int:
    """The old file's permissions, else ``new`` less the umask (temporary files are made private)."""
    with contextlib.suppress(OSError):
        return target.stat().st_mode & 0o7777
    mask = os.umask(0)
    os.umask(mask)
    return new & ~mask


def _replace(tmp: Path, target: Path) -> None:
    try:
        os.replace(tmp, target)
    except OSError as exc:
        exc.filename = str(target)  # the message names the output, not the temporary file
        raise
    _pending.discard(tmp)


def _drop(path: Path) -> None:
    """Remove a temporary file or stage, if it is still there."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            path.unlink()
    _pending.discard(path)


@contextlib.contextmanager
def atomic_path(path: Any, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``, renamed onto it on success (inside :func:`together`: at its end)."""
    target = Path(path)
    if in_place_target(target):
        try:
            yield target
        except OSError as exc:
            exc.filename = str(path) if exc.filename is None else exc.filename  # the message names the device
            raise
        return
    check_output_file(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    # named before it exists, so that a Ctrl-C at any moment leaves no file behind (mkstemp names it only after)
    name = str(target.parent / f".{target.name}.{uuid.uuid4().hex[:8]}{target.suffix if suffix is None else suffix}")
    tmp, queued = Path(name), False
    _pending.add(tmp)
    try:
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        yield tmp
        os.chmod(tmp, _mode_for(target))
        if _set is not None and not any(s in tmp.parents for s in _pending):  # a file in a stage goes with it
            _set.append((1, lambda: _replace(tmp, target), lambda: _drop(tmp)))
            queued = True
        else:
            _replace(tmp, target)
    except OSError as exc:
        if exc.filename is None or str(exc.filename) == name:
            exc.filename = str(path)
        raise
    finally:
        if not queued:
            _drop(tmp)


def write_text(path: Any, text: str) -> None:
    """Write ``text`` to ``path`` whole (UTF-8)."""
    with atomic_path(path) as tmp:
        with open(tmp, "a" if tmp == Path(path) and os.path.isfile(tmp) else "w", encoding="utf-8") as fh:
            fh.write(text)  # a file behind /dev/stdout is appended to, not truncated


def json_text(doc: Any, depth: int = 2, level: int = 0) -> str:
    """``doc`` as JSON indented for ``depth`` levels, each deeper value on one line (a run's step is one line)."""
    if level >= depth or not isinstance(doc, (dict, list)) or not doc:
        return json.dumps(doc, allow_nan=False)
    pairs = doc.items() if isinstance(doc, dict) else ((None, v) for v in doc)
    items = [("" if k is None else json.dumps(str(k)) + ": ") + json_text(v, depth, level + 1) for k, v in pairs]
    pad, (start, end) = "\n" + " " * (level + 1), ("{}" if isinstance(doc, dict) else "[]")
    return start + pad + ("," + pad).join(items) + "\n" + " " * level + end


def write_json(path: Any, doc: Any) -> None:
    write_text(path, json_text(doc) + "\n")


def _place_all(items: list[tuple[int, Callable[[], Any], Callable[[], Any]]]) -> None:
    """Folders first (one refused at the end still stops the set), then files, then links; a failure discards the
    rest."""
    items = sorted(items, key=lambda item: item[0])
    try:
        while items:
            items[0][1]()
            items.pop(0)
    finally:
        for _, _, discard in items:
            discard()


@contextlib.contextmanager
def together(check: Callable[[], Any] | None = None) -> Iterator[None]:
    """What is written inside goes in place only when the block (and ``check()``) succeeds; nested blocks join."""
    global _set
    if _set is not None:
        yield
        return
    staged: list[Any] = []
    _set, before = staged, set(_pending)  # what was being written before the block is not the block's
    try:
        try:
            yield
            if check is not None:
                check()
            if INTERRUPTED.is_set():  # a Ctrl-C that something caught on the way
                raise KeyboardInterrupt
        except BaseException:
            for _, _, discard in staged:
                discard()
            raise
        finally:
            _set = None
        _place_all(staged)
    except BaseException:
        for path in _pending - before:  # left by a Ctrl-C that came before a clean-up could start
            _drop(path)
        raise


def place_now(check: Callable[[], Any] | None = None) -> None:
    """Inside :func:`together`: put what was staged so far in place now (a command that then waits on the user)."""
    if _set is not None:
        if check is not None:
            check()
        staged = list(_set)
        _set.clear()  # the same list the enclosing block places at its end: what is placed now is not placed twice
        _place_all(staged)


def read_manifest(path: Path) -> dict[str, Any] | None:
    """The content of a bhr ``manifest.json`` (any bhr version, any machine) whose files are inside its folder."""
    try:
        doc = None if path.is_symlink() or path.stat().st_size > 16 << 20 else json.loads(path.read_text("utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not (isinstance(doc, dict) and isinstance(doc.get("bhr_output"), int) and isinstance(doc.get("files"), dict)):
        return None
    inside = all(isinstance(r, str) and r and not r.startswith("/") and not has_control_char(r)
                 and all(p not in ("", ".", "..") for p in r.split("/")) for r in doc["files"])
    return doc if inside else None


class OutputFolder:
    """Stage an output folder beside ``target``; rename it into place when the ``with`` block succeeds.

    Refused even with ``force``: the current folder or one above it, home, root, a folder holding one of the run's
    ``inputs``. A rerun of the same ``command`` and ``settings`` (or any run with ``keep``) carries over the files it
    does not write. The folder's lock is held from the start of the block until the folder is in place.
    """

    def __init__(self, target: Any, command: str, keep: bool = False, what: str = "output folder",
                 inputs: Any = (), settings: str | None = None, force: bool = False) -> None:
        if str(target) == "-":
            raise BhrError(f"{what} '-' is standard output, which cannot hold a folder; give a folder name (./- for "
                           "a folder named '-')")
        refuse_control(target, what)
        current_folder()
        self.given, self.target = Path(target), Path(os.path.realpath(target))
        self.command, self.keep, self.what, self.settings, self.force = command, keep, what, settings, force
        self.inputs = [str(i) for i in inputs if i is not None and str(i) != "-"]
        self.made_by: str | None = None
        self.stage: Path | None = None
        self.carried: list[str] = []
        self._lock: Any = None
        self.made: list[Path] = []

    def check(self) -> OutputFolder:
        """Refuse, before any work, a target bhr must not replace or cannot write."""
        t, shown = self.target, short_path(self.given)
        if t.exists() and not t.is_dir():
            raise BhrError(f"{self.what} {shown} is a file, not a folder; choose a folder name")
        cwd = Path(os.path.realpath(current_folder()))
        if t in (Path("/"), Path(os.path.realpath(Path.home())), cwd) or t in cwd.parents:
            raise BhrError(f"{self.what} {shown} is the current folder or holds it; give a new folder for the "
                           "output, such as bhr-out/run1")
        for name in self.inputs:
            real = Path(os.path.realpath(name))
            if (real == t or t in real.parents) and not self.keep:  # with keep, the input is carried over
                raise BhrError(f"{self.what} {shown} holds {short_path(name)}, an input of this run; give another "
                               "folder for the output (bhr replaces the whole folder)")
        if any(read_manifest(parent / MANIFEST) for parent in t.parents):
            raise BhrError(f"{self.what} {shown} is inside a folder bhr wrote (bhr replaces such a folder whole); give "
                           "a folder outside it, such as bhr-out/run2")
        if (bad := unwritable_folder(t.parent)) is not None:
            raise BhrError(f"cannot write {self.what} {shown}: {short_path(bad)} is not a writable folder; choose "
                           "another path")
        if t.is_dir():
            self._acquire()  # not while another run writes it
            try:
                self._previous()
            finally:
                self._release()
        return self

    def _previous(self) -> None:
        """A BhrError naming the first thing in the folder there now that bhr did not write (unless ``force``)."""
        t, shown = self.target, short_path(self.given)
        try:
            entries = sorted(os.listdir(t))
        except FileNotFoundError:
            return
        except OSError as exc:
            raise BhrError(f"cannot use {self.what} {shown} ({exc.strerror}); choose another folder") from None
        if not entries or self.force:
            return
        fix = f"move it out of {shown}" + ("" if self.keep else ", give another folder, or give --force to replace it")
        if (doc := read_manifest(t / MANIFEST)) is None:
            raise BhrError(f"{self.what} {shown} holds {short_path(entries[0])}, which no bhr run wrote (no bhr "
                           f"manifest.json lists it); {fix}")
        for root, dirs, files in os.walk(t):
            for p in sorted(Path(root) / n for n in dirs + files):
                rel = p.relative_to(t).as_posix()
                entry = doc["files"].get(rel)
                if (p.is_dir() and not p.is_symlink()) or rel == MANIFEST:
                    continue
                if p.is_symlink() or not p.is_file() or not isinstance(entry, dict):
                    raise BhrError(f"{self.what} {shown} holds {short_path(rel)}, which no bhr run wrote; {fix}")
                if p.stat().st_size != entry.get("bytes") or sha256_file(p) != entry.get("sha256"):
                    raise BhrError(f"{self.what} {shown} holds {short_path(rel)}, changed since bhr wrote it; {fix}")

    def path(self, name: Any) -> Path:
        """Where to write ``name`` (relative to the folder) while staging."""
        assert self.stage is not None
        (self.stage / name).parent.mkdir(parents=True, exist_ok=True)
        return self.stage / name

    def final(self, name: Any) -> Path:
        """Where ``name`` will be once the folder is in place."""
        return self.given / name

    def __enter__(self) -> OutputFolder:
        self.check()
        # named before it exists, so that a Ctrl-C at any moment leaves no stage behind
        self.stage = stage = self.target.parent / f".{self.target.name}.bhr-stage-{uuid.uuid4().hex[:12]}"
        _pending.add(stage)
        self.made = [p for p in self.target.parents if not p.exists()]  # removed again (when empty) on failure
        try:
            self.target.parent.mkdir(parents=True, exist_ok=True)
            self._acquire()
            stage.mkdir(mode=_mode_for(self.target, 0o777))
            return self
        except BaseException as failure:
            self._discard()
            if isinstance(failure, OSError) and (failure.filename is None or ".bhr-stage-" in str(failure.filename)):
                failure.filename = str(self.given)
            raise

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        assert self.stage is not None
        try:
            if exc is not None:
                raise exc
            self._carry_over()
            self._write_manifest()
        except BaseException as failure:
            self._discard()
            if isinstance(failure, OSError) and failure.filename is not None:
                with contextlib.suppress(ValueError):  # the output as the user named it, not its stage
                    failure.filename = str(self.given / Path(os.path.abspath(failure.filename)).relative_to(self.stage))
            if exc is not None:
                return  # the block's own exception goes on
            raise
        if _set is not None:  # one set with the command's other outputs: in place at its end
            _set.append((0, self._place, self._discard))
        else:
            self._place()

    def _carry_over(self) -> None:
        assert self.stage is not None
        if (old := read_manifest(self.target / MANIFEST)) is None:
            return
        old_made_by = old.get("made_by", old.get("command"))
        if self.keep and self.settings is None:  # files added beside a run: the folder still holds that run
            self.settings, self.made_by = old.get("settings"), old_made_by
        if self.keep or (self.settings is not None and (old.get("settings"), old_made_by) ==
                         (self.settings, self.command)):
            for rel in old["files"]:
                src, dst = self.target / rel, self.stage / rel
                if not os.path.lexists(dst) and src.is_file() and not src.is_symlink():
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copy2(src, dst)
                    self.carried.append(rel)

    def _write_manifest(self) -> None:
        assert self.stage is not None
        files = {p.relative_to(self.stage).as_posix(): {"bytes": p.stat().st_size, "sha256": sha256_file(p)}
                 for p in sorted(self.stage.rglob("*")) if p.is_file() and p.name != MANIFEST}
        doc = {"bhr_output": 2, "bhr_version": __version__, "command": self.command,
               "made_by": self.made_by or self.command, "run_id": uuid.uuid4().hex, "settings": self.settings,
               "written": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "files": files,
               "carried_over": sorted(self.carried)}
        (self.stage / MANIFEST).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        os.chmod(self.stage / MANIFEST, _mode_for(self.target / MANIFEST))

    def _place(self) -> None:
        """The old folder aside, the new one in, the old one deleted (a run killed in between: see _acquire)."""
        assert self.stage is not None
        aside = self.target.with_name(f".{self.target.name}.bhr-old-{uuid.uuid4().hex[:12]}")
        try:
            self._previous()  # again: the user may have added a file meanwhile
            if moved := os.path.lexists(self.target):
                os.rename(self.target, aside)
            try:
                os.rename(self.stage, self.target)
                _pending.discard(self.stage)
            except BaseException:
                if moved:
                    os.rename(aside, self.target)
                raise
        finally:
            self._discard()
        shutil.rmtree(aside, ignore_errors=True)

    def _acquire(self) -> None:
        """Take the folder's lock (again); at the first take, clean up after runs killed while they held it: their
        stages are deleted, an old folder they set aside goes back in place."""
        from filelock import FileLock, Timeout

        if self._lock is None:
            self._lock = FileLock(self.target.parent / f".{self.target.name}.bhr-lock")
        try:
            self._lock.acquire(timeout=LOCK_WAIT_S)
        except Timeout:
            raise BhrError(f"another bhr held {self.what} {short_path(self.given)} for {LOCK_WAIT_S:g} s; run "
                           "again") from None
        if self._lock.lock_counter > 1:
            return
        prefix = re.escape(f".{self.target.name}.bhr-")
        for e in self.target.parent.iterdir():
            if re.fullmatch(prefix + r"stage-[0-9a-f]{12}(\.lock)?", e.name) and not e.is_symlink():
                shutil.rmtree(e, ignore_errors=True) if e.is_dir() else e.unlink()
            elif re.fullmatch(prefix + r"old-[0-9a-f]{12}", e.name) and (doc := read_manifest(e / MANIFEST)):
                if not os.path.lexists(self.target) and all((e / r).is_file() for r in doc["files"]):
                    os.rename(e, self.target)
                else:
                    shutil.rmtree(e, ignore_errors=True)

    def _release(self) -> None:
        """Release the lock once; at the last release its file is deleted first (filelock re-checks the file)."""
        if self._lock is not None and self._lock.is_locked:
            if self._lock.lock_counter == 1:
                with contextlib.suppress(OSError):
                    os.unlink(self._lock.lock_file)
            self._lock.release()

    def _discard(self) -> None:
        if self.stage is not None:
            _drop(self.stage)
        while self._lock is not None and self._lock.is_locked:
            self._release()
        for p in self.made:  # innermost first; one filled meanwhile (or by the placed folder) stays
            with contextlib.suppress(OSError):
                p.rmdir()


def owning_folder(path: Any) -> tuple[Path, str] | None:
    """The bhr folder (up to two levels up) whose manifest lists ``path``, and ``path`` inside it; else None."""
    p = Path(os.path.realpath(path))
    for folder in list(p.parents)[:3]:
        if (doc := read_manifest(folder / MANIFEST)) is not None:
            rel = p.relative_to(folder).as_posix()
            return (folder, rel) if rel in doc["files"] else None
    return None


def point_latest(folder: Any) -> None:
    """Point the link ``<parent>/latest`` at ``folder`` (never a user's file of that name), once the set is placed."""
    target = Path(folder)
    link, tmp = target.parent / "latest", target.parent / f".latest.bhr-link-{uuid.uuid4().hex[:12]}"
    if _set is not None:
        _set.append((2, lambda: point_latest(target), lambda: None))
    elif link.is_symlink() or not link.exists():
        with contextlib.suppress(OSError):
            os.symlink(target.name, tmp)
            os.replace(tmp, link)
