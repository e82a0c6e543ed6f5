"""Outputs written whole or not at all: single files, output folders, and sets of both.

A file is written beside its target and renamed onto it (a device or anything under /dev is written in place).
An output folder is staged beside its target (``.NAME.bhr-stage-*``) and renamed into place under a lock file
(``.NAME.bhr-lock``, filelock); its ``manifest.json`` marks it as bhr's. A non-empty folder bhr did not write (or
that was changed since) is refused unless ``force``.
"""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
import tempfile
import time
import uuid
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator

from bhr import __version__
from bhr.output.paths import (check_output_file, current_folder, in_place_target, refuse_control, sha256_file,
                              short_path, unwritable_folder)
from bhr.settings.errors import INTERRUPTED, BhrError

if TYPE_CHECKING:
    from filelock import FileLock  # imported when a folder is written (30 ms): not by a command writing a file
from bhr.settings.options import has_control_char

__all__ = ["atomic_path", "write_text", "write_json", "json_text", "together", "place_now", "OutputFolder", "MANIFEST",
           "read_manifest", "owning_folder", "point_latest"]

#: The file in every output folder that says bhr wrote it, and what.
MANIFEST = "manifest.json"
#: How long a run waits for another one putting the same folder in place (seconds).
LOCK_WAIT_S = 600.0


def _mode_for(target: Path, new: int = 0o666) -> int:
    """The old file's permissions, else ``new`` less the umask (mkstemp and mkdtemp make files private)."""
    with contextlib.suppress(OSError):
        return target.stat().st_mode & 0o7777
    mask = os.umask(0)
    os.umask(mask)
    return new & ~mask


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
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix if suffix is None else suffix,
                                dir=target.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, _mode_for(target))
        if _set is not None and not any(s in tmp.parents for s in _stages):  # a file in a stage goes with it
            _set.files.append((tmp, target))
        else:
            os.replace(tmp, target)
    except OSError as exc:
        if exc.filename is None or str(exc.filename) == name:
            exc.filename = str(path)  # the message names the output, not the temporary file
        raise
    finally:
        if tmp.exists() and (_set is None or all(tmp != t for t, _ in _set.files)):
            tmp.unlink()


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
    """Write ``doc`` as JSON (:func:`json_text`) to ``path`` whole."""
    write_text(path, json_text(doc) + "\n")


# --- sets: every output of a command, or none --------------------------------------------------------------------

class _Set:
    def __init__(self) -> None:
        self.folders: list[OutputFolder] = []  # placed first: a folder refused at the end still stops the set
        self.files: list[tuple[Path, Path]] = []  # (temporary file, target)
        self.after: list[Callable[[], Any]] = []

    def discard(self) -> None:
        for tmp, _ in self.files:
            with contextlib.suppress(OSError):
                tmp.unlink()
        for folder in self.folders:
            folder._discard()

    def place(self) -> None:
        try:
            while self.folders:
                self.folders[0]._place()
                self.folders.pop(0)
            while self.files:
                try:
                    os.replace(*self.files[0])
                except OSError as exc:
                    exc.filename = str(self.files[0][1])
                    raise
                self.files.pop(0)
        except BaseException:
            self.discard()
            raise
        for action in self.after:
            action()


_set: _Set | None = None
_stages: set[Path] = set()  # the stages of the folders being written


@contextlib.contextmanager
def together(check: Callable[[], Any] | None = None) -> Iterator[None]:
    """What is written inside goes in place only when the block (and ``check()``) succeeds; nested blocks join."""
    global _set
    if _set is not None:
        yield
        return
    _set = staged = _Set()
    try:
        yield
        if check is not None:
            check()
        if INTERRUPTED.is_set():  # a Ctrl-C caught on the way
            raise KeyboardInterrupt
    except BaseException:
        _set = None
        staged.discard()
        raise
    _set = None
    staged.place()


def place_now(check: Callable[[], Any] | None = None) -> None:
    """Inside :func:`together`: put what was staged so far in place now (a command that then waits on the user)."""
    global _set
    if _set is None:
        return
    if check is not None:
        check()
    staged, _set = _set, _Set()
    staged.place()


# --- output folders ----------------------------------------------------------------------------------------------

def read_manifest(path: Path) -> dict[str, Any] | None:
    """The content of a bhr ``manifest.json`` (any bhr version), else None."""
    try:
        if path.is_symlink() or not path.is_file() or path.stat().st_size > 16 << 20:
            return None
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not (isinstance(doc, dict) and isinstance(doc.get("bhr_output"), int) and isinstance(doc.get("files"), dict)):
        return None
    inside = all(isinstance(r, str) and r and not r.startswith("/") and "\\" not in r and not has_control_char(r)
                 and all(p not in ("", ".", "..") for p in r.split("/")) for r in doc["files"])
    return doc if inside else None  # a manifest naming "../x" or "/etc/x" is not bhr's


class OutputFolder:
    """Stage an output folder beside ``target``; rename it into place when the ``with`` block succeeds.

    Refused even with ``force``: the current folder or one above it, home, root, a folder holding one of the
    run's ``inputs``, a folder inside a bhr folder. A rerun of the same ``command`` and ``settings`` (or any run
    with ``keep``) carries over the files it does not write. ``names``: the files a run writes at its top.
    """

    def __init__(self, target: Any, command: str, names: Iterable[str] = (), keep: bool = False,
                 what: str = "output folder", inputs: Iterable[Any] = (), settings: str | None = None,
                 force: bool = False) -> None:
        if str(target) == "-":
            raise BhrError(f"{what} '-' is standard output, which cannot hold a folder; give a folder name (./- for "
                           "a folder named '-')")
        refuse_control(target, what)
        current_folder()
        self.given = Path(target)
        if self.given.is_symlink() and not self.given.exists():
            raise BhrError(f"{what} {short_path(self.given)} is a symbolic link to a missing "
                           f"{short_path(os.readlink(self.given))}; create its target or choose another folder")
        self.target = Path(os.path.realpath(self.given))
        self.command, self.names, self.keep, self.what = command, tuple(names), keep, what
        self.settings, self.force, self.made_by = settings, force, None
        self.inputs = tuple(str(i) for i in inputs if i is not None and str(i) != "-")
        self.stage: Path | None = None
        self.carried: list[str] = []
        self.made: list[Path] = []
        self._lock: FileLock | None = None

    def add_inputs(self, *paths: Any) -> "OutputFolder":
        """Name more input files of the run; checks again."""
        self.inputs += tuple(str(i) for i in paths if i is not None and str(i) != "-")
        return self.check()

    def check(self) -> "OutputFolder":
        """Refuse, before any work, a target bhr must not replace or cannot write."""
        t, shown = self.target, short_path(self.given)
        if t.exists() and not t.is_dir():
            raise BhrError(f"{self.what} {shown} is a file, not a folder; choose a folder name")
        cwd = Path(os.path.realpath(current_folder()))
        if t in (Path(os.path.abspath(os.sep)), Path(os.path.realpath(Path.home())), cwd) or t in cwd.parents:
            raise BhrError(f"{self.what} {shown} is the current folder or holds it; give a new folder for the "
                           "output, such as bhr-out/run1")
        for name in self.inputs:
            real = Path(os.path.realpath(name))
            if (real == t or t in real.parents) and not self.keep:  # with keep, the input is carried over
                raise BhrError(f"{self.what} {shown} holds {short_path(name)}, an input of this run; give another "
                               "folder for the output (bhr replaces the whole folder)")
        for parent in t.parents:
            if read_manifest(parent / MANIFEST) is not None:
                raise BhrError(f"{self.what} {shown} is inside {short_path(parent)}, a folder bhr wrote (bhr replaces "
                               "such a folder whole); give a folder outside it, such as bhr-out/run2")
        if (bad := unwritable_folder(t.parent)) is not None:
            raise BhrError(f"cannot write {self.what} {shown}: {short_path(bad)} is not a writable folder; choose "
                           "another path")
        if t.is_dir():
            with self._locked():  # not while another run replaces it
                self.previous()
        return self

    def previous(self) -> dict[str, Any] | None:
        """The manifest of the folder there now, if any; a BhrError naming the first thing bhr did not write."""
        t, shown = self.target, short_path(self.given)
        try:
            entries = sorted(os.listdir(t))
        except FileNotFoundError:
            return None
        except OSError as exc:  # not a folder (any more), not readable
            raise BhrError(f"cannot use {self.what} {shown} ({exc.strerror}); choose another folder") from None
        doc = read_manifest(t / MANIFEST) if entries else None
        if not entries or self.force:
            return doc
        fix = f"move it out of {shown}" + ("" if self.keep else ", give another folder, or give --force to replace it")
        if doc is None:
            raise BhrError(f"{self.what} {shown} holds {short_path(entries[0])}, which no bhr run wrote (no bhr "
                           f"manifest.json lists it); {fix}")
        for root, dirs, files in os.walk(t):
            for p in sorted(Path(root) / n for n in dirs + files):
                rel, st = p.relative_to(t).as_posix(), os.lstat(p)
                entry = doc["files"].get(rel)
                if stat.S_ISLNK(st.st_mode):
                    raise BhrError(f"{self.what} {shown} holds {short_path(rel)}, a link bhr did not make; {fix}")
                if stat.S_ISDIR(st.st_mode) or rel == MANIFEST:
                    continue
                if not stat.S_ISREG(st.st_mode) or not isinstance(entry, dict):
                    raise BhrError(f"{self.what} {shown} holds {short_path(rel)}, which no bhr run wrote; {fix}")
                if st.st_size != entry.get("bytes") or sha256_file(p) != entry.get("sha256"):
                    raise BhrError(f"{self.what} {shown} holds {short_path(rel)}, changed since bhr wrote it; {fix}")
        return doc

    def path(self, name: Any) -> Path:
        """Where to write ``name`` (relative to the folder) while staging."""
        assert self.stage is not None, "use OutputFolder in a with block"
        (self.stage / name).parent.mkdir(parents=True, exist_ok=True)
        return self.stage / name

    def final(self, name: Any) -> Path:
        """Where ``name`` will be once the folder is in place."""
        return self.given / name

    def _beside(self, kind: str) -> str:
        return f".{self.target.name}.bhr-{kind}-"

    def __enter__(self) -> "OutputFolder":
        self.check()
        parent = self.target.parent
        while not parent.exists() and parent != parent.parent:
            self.made.append(parent)  # made by this run: removed again (when empty) if it fails
            parent = parent.parent
        try:
            self.target.parent.mkdir(parents=True, exist_ok=True)
            with self._locked():  # what runs killed before left here
                self._clean_dead_stages()
            stage = self.target.parent / (self._beside("stage") + uuid.uuid4().hex[:12])
            from filelock import FileLock

            self._lock = FileLock(f"{stage}.lock")  # held while the stage is written: its run is alive
            self._lock.acquire()
            stage.mkdir()
            self.stage = stage
            os.chmod(stage, _mode_for(self.target, 0o777))
        except BaseException as failure:
            self._discard()
            if isinstance(failure, OSError) and (failure.filename is None or ".bhr-stage-" in str(failure.filename)):
                failure.filename = str(self.given)
            raise
        _stages.add(stage)
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        assert self.stage is not None
        _stages.discard(self.stage)
        try:
            if exc_type is not None:
                raise exc
            self._carry_over()
            self._write_manifest()
        except BaseException as failure:
            self._discard()
            if isinstance(failure, OSError) and failure.filename is not None:
                with contextlib.suppress(ValueError):  # the output as the user named it, not its stage
                    failure.filename = str(self.given / Path(os.path.abspath(failure.filename)).relative_to(self.stage))
            if exc_type is not None:
                return None  # the with block's own exception goes on
            raise
        if _set is not None:  # one set with the command's other outputs: in place at its end
            _set.folders.append(self)
        else:
            self._place()

    def _carry_over(self) -> None:
        assert self.stage is not None
        old = read_manifest(self.target / MANIFEST)
        if old is None:
            return
        old_made_by = old.get("made_by", old.get("command"))
        if self.keep and self.settings is None:  # files added beside a run: the folder still holds that run
            self.settings, self.made_by = old.get("settings"), old_made_by
        if self.keep or (self.settings is not None and (old.get("settings"), old_made_by) ==
                         (self.settings, self.command)):
            for rel in old["files"]:
                src, dst = self.target / rel, self.stage / rel
                if not (os.path.lexists(dst) or src.is_symlink() or not src.is_file()):
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copy2(src, dst)
                    self.carried.append(rel)

    def _write_manifest(self) -> None:
        assert self.stage is not None
        files = {p.relative_to(self.stage).as_posix(): {"bytes": p.stat().st_size, "sha256": sha256_file(p)}
                 for p in sorted(self.stage.rglob("*")) if p.is_file() and p.name != MANIFEST}
        doc = {"bhr_output": 2, "bhr_version": __version__,
               "command": self.command, "made_by": self.made_by or self.command, "run_id": uuid.uuid4().hex,
               "settings": self.settings, "written": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
               "files": files, "carried_over": sorted(self.carried)}
        (self.stage / MANIFEST).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        os.chmod(self.stage / MANIFEST, _mode_for(self.target / MANIFEST))

    def _place(self) -> None:
        """Under the folder's lock: the old folder aside, the new one in; then the old one deleted."""
        assert self.stage is not None
        aside = None
        try:
            with self._locked():
                if os.path.lexists(self.target):
                    self.previous()  # again: the user may have added a file meanwhile
                    aside = self.target.with_name(self._beside("old") + uuid.uuid4().hex[:12])
                    os.rename(self.target, aside)
                try:
                    os.rename(self.stage, self.target)
                except BaseException:
                    if aside is not None:
                        os.rename(aside, self.target)
                        aside = None
                    raise
        except BaseException:
            self._discard()
            raise
        self._discard()  # the stage's lock, and the parents made (not empty now: kept)
        if aside is not None:
            shutil.rmtree(aside, ignore_errors=True)

    @contextlib.contextmanager
    def _locked(self) -> Iterator[None]:
        """Hold the folder's lock; first put back a folder a killed run moved aside."""
        from filelock import FileLock, Timeout

        lock = FileLock(self.target.parent / self._beside("lock")[:-1])
        try:
            lock.acquire(timeout=LOCK_WAIT_S)
        except Timeout:
            raise BhrError(f"another bhr held {self.what} {short_path(self.given)} for {LOCK_WAIT_S:g} s; run "
                           "again") from None
        with _releasing(lock):
            self._restore_aside()
            yield

    def _restore_aside(self) -> None:
        """A folder a killed run moved aside: put back when whole, else deleted."""
        for e in self.target.parent.iterdir():
            doc = read_manifest(e / MANIFEST) if e.name.startswith(self._beside("old")) else None
            if doc is not None and not e.is_symlink():
                if not os.path.lexists(self.target) and all((e / r).is_file() for r in doc["files"]):
                    os.rename(e, self.target)
                else:
                    shutil.rmtree(e, ignore_errors=True)

    def _clean_dead_stages(self) -> None:
        """Delete the staging folders of dead runs (their lock is no longer held)."""
        from filelock import FileLock, Timeout

        for e in self.target.parent.iterdir():
            if e.name.startswith(self._beside("stage")) and e.name.endswith(".lock"):
                lock = FileLock(e)
                try:
                    lock.acquire(timeout=0)
                except (Timeout, OSError):
                    continue  # a live run's (or not ours to take)
                with _releasing(lock):
                    stage = e.with_name(e.name[:-len(".lock")])
                    if stage.is_dir() and not stage.is_symlink():
                        shutil.rmtree(stage, ignore_errors=True)

    def _discard(self) -> None:
        if self.stage is not None and self.stage.is_dir():
            shutil.rmtree(self.stage, ignore_errors=True)
        if self._lock is not None:
            with _releasing(self._lock):
                self._lock = None
        for p in self.made:  # innermost first; one that someone filled meanwhile stays
            with contextlib.suppress(OSError):
                p.rmdir()


@contextlib.contextmanager
def _releasing(lock: FileLock) -> Iterator[None]:
    """Release ``lock`` at the end, its file deleted first (no lock file is left behind)."""
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(lock.lock_file)
        lock.release()


def owning_folder(path: Any) -> tuple[Path, str] | None:
    """The bhr folder (up to two levels up) whose manifest lists ``path``, and ``path`` inside it; else None."""
    p = Path(os.path.realpath(path))
    for folder in list(p.parents)[:3]:
        doc = read_manifest(folder / MANIFEST)
        if doc is not None:
            rel = p.relative_to(folder).as_posix()
            return (folder, rel) if rel in doc["files"] else None
    return None


def point_latest(folder: Any, link_name: str = "latest") -> Path | None:
    """Point the link ``<parent>/latest`` at ``folder`` (not a user's file of that name), once the set is placed."""
    target = Path(folder)
    link = target.parent / link_name
    if _set is not None:
        _set.after.append(lambda: point_latest(target, link_name))
        return link
    if link.exists() and not link.is_symlink():
        return None
    tmp = target.parent / f".{link_name}.bhr-link-{uuid.uuid4().hex[:12]}"
    try:
        os.symlink(target.name, tmp)
        os.replace(tmp, link)
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        return None
    return link
