"""Outputs written whole or not at all: single files and whole output folders.

Single files (:func:`atomic_path`, :func:`write_text`, :func:`write_json`)
are written to a temporary file beside the target and renamed onto it, so an
interrupted or failed run never leaves a half-written file and never
replaces a good file with a bad one. Targets that are not regular files
(``/dev/null``, ``/dev/stdout``, a FIFO, a terminal) are written in place and
never replaced; a symbolic link is followed and the file it points to is
replaced, never the link itself; a read-only file is refused.

Output folders (:class:`OutputFolder`) hold the files of one run (for
``bhr follow``: ``run.json``, ``codes.csv``, the figures). They are staged in
a hidden folder beside the target (``.NAME.bhr-stage-PID-XXXX``) and put in
place in one step: ``rename`` onto a new name, or an atomic exchange with the
previous folder (Linux ``renameat2(RENAME_EXCHANGE)``), after which the
previous folder is deleted. A folder therefore always holds the complete set
of exactly one run, also when a run is killed (``kill -9``), the disk fills
up, or two runs write the same folder at once (the last to finish wins
whole). ``manifest.json`` in the folder names the run (``run_id``, the
command, the settings' hash, bhr's version), lists every file with its size
and SHA-256, and is signed: an HMAC-SHA256 with a secret key of the user's
(:func:`output_key`, ``~/.config/bhr/output-key``) over everything else in
it. A folder is replaced only when its manifest proves that bhr wrote every
file in it (:func:`verify_folder`): the signature is this user's bhr's, and
every file is listed with the size and hash it has. Anyone can compute the
hashes; only the user's bhr can sign them, so a manifest forged, edited,
copied from another user or machine, or written by an older bhr proves
nothing. A folder holding one of the run's inputs, the current folder and its
parents are refused. Staging folders of runs that died are deleted by the next
run into the same place when bhr's signed mark in them proves they are bhr's.
"""
from __future__ import annotations

import contextlib
import ctypes
import errno
import hashlib
import hmac
import json
import os
import secrets
import shutil
import stat
import tempfile
import time
import uuid
from pathlib import Path
from typing import Any, Iterable, Iterator

from bhr import __version__
from bhr.settings.errors import INTERRUPTED, BhrError
from bhr.settings.options import excerpt, has_control_char

__all__ = ["atomic_path", "write_text", "write_json", "check_output_file", "together", "place_now", "OutputFolder",
           "MANIFEST", "in_place_target", "point_latest", "verify_folder", "INTERRUPTED", "settings_hash",
           "output_key", "key_file", "sign_manifest", "signed_by_bhr", "KEY_ENV"]

#: The file in every output folder that ties its files to one run.
MANIFEST = "manifest.json"
_STAGE = ".bhr-stage-"
_ASIDE = ".bhr-old-"
#: A file in every staging folder while it is written (removed just before the folder goes in place), holding
#: bhr's signature of the staging folder's name: a leftover folder of a dead run is deleted by the next run only
#: when it has it, or a signed bhr manifest, so that a folder of the user's that only looks like one
#: (``.o.bhr-stage-99999-x``, even with a ``.bhr-staging`` file in it) is never deleted.
_STAGE_MARK = ".bhr-staging"


# --- single files ------------------------------------------------------------------------------------------------

def in_place_target(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` exists and is not a regular file (a device, FIFO, socket, terminal, /dev/stdout).

    Such targets are written in place: replacing them would destroy them
    (``/dev/null`` as root) or cut the link to whoever reads them.
    """
    try:
        st = os.stat(path)  # follows symbolic links
    except OSError:
        return False
    if not stat.S_ISREG(st.st_mode) and not stat.S_ISDIR(st.st_mode):
        return True
    return stat.S_ISREG(st.st_mode) and _via_special(path)


def _via_special(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` or a link on the way to its file is under /dev or /proc (``/dev/stdout`` redirected
    to a file): the file is someone else's open descriptor and is written in place, not replaced."""
    p = os.path.abspath(path)
    for _ in range(40):
        if p.startswith(("/dev/", "/proc/")):
            return True
        if not os.path.islink(p):
            return False
        p = os.path.abspath(os.path.join(os.path.dirname(p), os.readlink(p)))
    return False


def _refuse_control(path: Any, what: str) -> None:
    """A path with a newline, tab or other control character is refused: every message that names it would
    break across lines, and no user means one."""
    if has_control_char(str(path)):
        raise BhrError(f"{what} path {excerpt(str(path))} contains a control character (a newline or tab); "
                       "give a plain name")


def current_folder() -> Path:
    """The current folder; a BhrError when it no longer exists (deleted or moved away under the command): every
    output named relative to it would fail, after the work, with a message naming no file."""
    try:
        return Path(os.getcwd())
    except FileNotFoundError:
        raise BhrError("the current folder no longer exists (it was deleted or moved away); cd into an existing "
                       "folder and run again") from None


def _real_target(path: Path, what: str = "output") -> Path:
    """Where a write to ``path`` lands: ``path`` itself. A symbolic link to a file is refused, never written
    through (the file behind it may be anyone's); links to devices (/dev/stdout) are written in place before
    this is reached."""
    if path.is_symlink():
        raise BhrError(f"{what} {short_path(path)} is a symbolic link to {short_path(os.readlink(path))}; bhr does not "
                       "write through links: remove the link or choose another path")
    return path


def check_output_file(path: str | os.PathLike[str], what: str = "output") -> None:
    """Refuse, before any work, an output file that cannot be written or must not be replaced.

    ``-`` (standard output) is always accepted. Devices and FIFOs must be
    writable by this user; a regular file must not be read-only; a new
    file needs a writable folder.
    """
    if str(path) == "-":
        return
    _refuse_control(path, what)
    p = Path(path)
    if not p.is_absolute():
        current_folder()
    if p.is_symlink() and not p.exists():
        raise BhrError(f"{what} {p} is a symbolic link to a missing {os.readlink(p)}; "
                       "create its target or choose another path")
    if p.is_dir():
        raise BhrError(f"{what} path {p} is a directory; give a file name")
    if in_place_target(p):
        with contextlib.suppress(OSError):
            if stat.S_ISSOCK(os.stat(p).st_mode):
                raise BhrError(f"{what} {short_path(p)} is a socket, not a file; give a file name")
        if not os.access(p, os.W_OK):
            raise BhrError(f"cannot write {what} {p}: permission denied; choose another path")
        return
    real = _real_target(p, what)
    if real.exists():
        mode = real.stat().st_mode
        if not (mode & 0o222) or not os.access(real, os.W_OK):
            raise BhrError(f"{what} {p} is read-only; make it writable (chmod u+w) or choose another path")
    parent = real.parent if str(real.parent) else Path(".")
    probe = parent
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
        raise BhrError(f"cannot write {what} {p}: {probe} is not a writable folder; choose another path")


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``path`` on success.

    The temporary name keeps the target's extension (``suffix``) so writers
    that look at it (matplotlib, Pillow) pick the right format. A target
    that is not a regular file is yielded itself (written in place); a
    symbolic link to a file is refused (nothing is written through it).
    """
    target = Path(path)
    if in_place_target(target):
        held = _wait_for_reader(target)
        try:
            yield target
        except OSError as exc:
            if exc.filename is None:
                exc.filename = str(target)  # so that the one-line message names the device
            raise
        finally:
            if held is not None:
                os.close(held)
        return
    target = _real_target(target)
    if target.exists() and not (target.stat().st_mode & 0o222 and os.access(target, os.W_OK)):
        raise BhrError(f"{path} is read-only; make it writable (chmod u+w) or choose another path")
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=suffix if suffix is not None else target.suffix,
                               dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        try:
            yield tmp_path
            os.chmod(tmp_path, _mode_for(target))
            if _together is not None and not any(_within(target.resolve(), st.resolve()) for st in _staging):
                # one set with the command's other files: put in place at the end (a file inside an output
                # folder's stage goes in with its folder)
                kept = tmp_path.with_name(tmp_path.name + ".set")
                os.replace(tmp_path, kept)
                _together.files.append((kept, target, str(path)))
            else:
                os.replace(tmp_path, target)
        except OSError as exc:
            if exc.filename is None or str(exc.filename) == str(tmp_path):
                exc.filename = str(path)  # the one-line message names the output, not a temporary name
            raise
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


#: How long a named pipe given as an output may wait for its reader (seconds).
FIFO_READER_WAIT_S = 10.0


def _wait_for_reader(target: Path) -> int | None:
    """A named pipe as an output: wait (bounded) for a reader instead of for ever; return a write end kept open
    while the file is written, so that the reader sees one stream. Anything else: None."""
    try:
        if not stat.S_ISFIFO(os.stat(target).st_mode):
            return None
    except OSError:
        return None
    import time

    deadline = time.monotonic() + FIFO_READER_WAIT_S
    while True:
        try:
            return os.open(target, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as exc:
            if exc.errno != errno.ENXIO:  # ENXIO: nobody has it open for reading yet
                raise
        if time.monotonic() > deadline:
            raise BhrError(f"nobody reads the named pipe {short_path(target)} (waited {FIFO_READER_WAIT_S:g} s); "
                           "start its reader first, or give a file name")
        time.sleep(0.05)


class _Set:
    """The outputs of one :func:`together` block: single files staged beside their targets (``.NAME.XXXX.set``),
    output folders staged whole (their manifest written), and what follows their placing (``bhr-out/latest``)."""

    def __init__(self) -> None:
        self.files: list[tuple[Path, Path, str]] = []   # (staged file, target, the name the user gave)
        self.folders: list["OutputFolder"] = []
        self.after: list[Any] = []                       # callables run once everything is in place

    def discard(self) -> None:
        for kept, _, _ in self.files:
            with contextlib.suppress(OSError):
                kept.unlink()
        for folder in self.folders:
            folder._discard()
        self.files, self.folders, self.after = [], [], []

    def place(self) -> None:
        """Put every staged folder, then every staged file, in place; on a failure the rest are discarded."""
        folders, files, after = self.folders, self.files, self.after
        self.folders, self.files, self.after = [], [], []
        for k, folder in enumerate(folders):
            try:
                folder._place()
            except BaseException:
                for rest in folders[k + 1:]:
                    rest._discard()
                self.files = files
                self.discard()
                raise
        for k, (kept, target, given) in enumerate(files):
            try:
                os.replace(kept, target)
            except OSError as exc:
                for later, _, _ in files[k:]:
                    with contextlib.suppress(OSError):
                        later.unlink()
                if exc.filename is None or str(exc.filename) == str(kept):
                    exc.filename = given
                raise
        for action in after:
            action()


_together: _Set | None = None
_staging: set[Path] = set()  # the stage folders of the OutputFolders being written


@contextlib.contextmanager
def together(check: Any = None) -> Iterator[None]:
    """The outputs written inside are one set: single files (:func:`atomic_path`, :func:`write_text`,
    :func:`write_json`) and output folders (:class:`OutputFolder`, staged whole) are put in place only when the
    block ends without an error, so a failure writing the last one (disk full) leaves none of them, not the first
    ones alone. ``check()``, when given, runs after the block and before anything is put in place; an exception
    from it leaves nothing either (the command line flushes its standard output there, so that a summary that
    cannot be printed, ``> /dev/full``, leaves no folder behind it). Nested blocks join the outermost one."""
    global _together
    if _together is not None:  # already inside one
        yield
        return
    staged = _Set()
    _together = staged
    try:
        yield
        if INTERRUPTED.is_set():  # a Ctrl-C caught on the way: none of them
            raise KeyboardInterrupt
        if check is not None:
            check()
        if INTERRUPTED.is_set():
            raise KeyboardInterrupt
    except BaseException:
        _together = None
        staged.discard()
        raise
    _together = None
    staged.place()


def place_now(check: Any = None) -> None:
    """Inside :func:`together`: put what the block has staged so far in place now, after ``check()``, as its end
    would (what it writes afterwards goes in place at its end). For a command that goes on after its outputs are
    written, waiting on the user (the live view's window): its folder is there while the window is open. Outside a
    block, nothing to do."""
    staged = _together
    if staged is None:
        return
    if INTERRUPTED.is_set():
        raise KeyboardInterrupt
    if check is not None:
        check()
    staged.place()


def _mode_for(target: Path, new: int = 0o666) -> int:
    """The permissions a plain ``open(target, "w")`` (``new`` = 0o666) or ``mkdir`` (0o777) would give: the old
    file's or folder's, else ``new`` less the umask.

    (mkstemp creates its file 0o600, and mkdtemp its folder 0o700, which would hide outputs from the
    user's group.)
    """
    try:
        return target.stat().st_mode & 0o7777
    except OSError:
        mask = os.umask(0)
        os.umask(mask)
        return new & ~mask


def write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to ``path`` atomically (UTF-8)."""
    with atomic_path(path) as tmp:
        if tmp == Path(path) or in_place_target(tmp):
            # a device or FIFO: written in place; a file reached through /dev/stdout: appended, not truncated
            with open(tmp, "a" if os.path.isfile(tmp) else "w", encoding="utf-8") as fh:
                fh.write(text)
        else:
            tmp.write_text(text, encoding="utf-8")


#: Levels of a JSON document written indented (one item a line); deeper values are written on one line each.
JSON_DEPTH = 2


def json_text(doc: Any, depth: int = JSON_DEPTH) -> str:
    """``doc`` as JSON indented by one space for ``depth`` levels, each deeper value on one line.

    A run's step (its points, errors and codes) is one line, not one line per number: the colon's run.json
    is 0.59 MB instead of 0.84 MB and written mostly by json's C encoder, which no ``indent`` uses (0.016 s
    of CPU instead of 0.038 s).
    """
    out: list[str] = []

    def put(value: Any, level: int) -> None:
        if level >= depth or not isinstance(value, (dict, list)) or not value:
            out.append(json.dumps(value, allow_nan=False))
            return
        pad = "\n" + " " * (level + 1)
        if isinstance(value, dict):
            out.append("{")
            for k, (key, item) in enumerate(value.items()):
                out.append(("," if k else "") + pad + json.dumps(str(key)) + ": ")
                put(item, level + 1)
            out.append("\n" + " " * level + "}")
        else:
            out.append("[")
            for k, item in enumerate(value):
                out.append(("," if k else "") + pad)
                put(item, level + 1)
            out.append("\n" + " " * level + "]")

    put(doc, 0)
    return "".join(out)


def write_json(path: str | os.PathLike[str], doc: Any) -> None:
    """Write ``doc`` as JSON (:func:`json_text`) to ``path`` atomically."""
    write_text(path, json_text(doc) + "\n")


# --- whole folders -----------------------------------------------------------------------------------------------

_RENAME_NOREPLACE = 1
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _renameat2(src: Path, dst: Path, flags: int) -> None:
    """``renameat2(2)``; OSError with the errno on failure (ENOSYS/EINVAL where unsupported)."""
    libc = ctypes.CDLL(None, use_errno=True)
    fn = getattr(libc, "renameat2", None)
    if fn is None:
        raise OSError(errno.ENOSYS, "renameat2 not available")
    if fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), flags) != 0:
        e = ctypes.get_errno()
        raise OSError(e, os.strerror(e), str(dst))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


# --- bhr's signature: a secret key of the user's ---------------------------------------------------------------

#: Names the key file instead of ``$XDG_CONFIG_HOME/bhr/output-key`` (tests; a home shared between machines).
KEY_ENV = "BHR_OUTPUT_KEY_FILE"
_KEY_BYTES = 32
_SIGNATURE = "hmac-sha256:"


def key_file() -> Path | None:
    """Where this user's signing key is: ``$BHR_OUTPUT_KEY_FILE``, else ``$XDG_CONFIG_HOME/bhr/output-key``, else
    ``~/.config/bhr/output-key``; None without a home folder."""
    given = os.environ.get(KEY_ENV, "")
    if given:
        return Path(os.path.abspath(given))
    base = os.environ.get("XDG_CONFIG_HOME", "")
    if not os.path.isabs(base):  # unset, empty or relative: not a config folder (the XDG rule)
        try:
            base = str(Path.home() / ".config")
        except (RuntimeError, KeyError):  # no home folder at all
            return None
    return Path(base) / "bhr" / "output-key"


def output_key() -> tuple[bytes | None, str]:
    """This user's key for signing output folders, made on first need; ``(None, why)`` when there is no key bhr
    can trust (``why`` says so in a clause for a one-line message; the key itself is never shown).

    The key is 32 random bytes in :func:`key_file`, mode 0600, in a folder made 0700. Several bhr processes
    making it at once agree on one (each writes its own beside it and links it into place; the losers read the
    winner's). A key file that is not a regular file of this user's, that other users may read or write, or that
    does not hold 32 bytes, is not trusted, and not replaced either.
    """
    path = key_file()
    if path is None:
        return None, "bhr has no signing key (there is no home folder to keep it in)"
    key, why = _read_key(path)
    if key is not None or why:
        return key, why
    try:
        _make_key(path)
    except OSError as exc:
        return None, (f"bhr has no signing key: it cannot make {short_path(path, 200)} "
                      f"({exc.strerror or type(exc).__name__})")
    key, why = _read_key(path)
    return key, why or f"bhr has no signing key: {short_path(path, 200)} disappeared as it was made"


def _read_key(path: Path) -> tuple[bytes | None, str]:
    """The key in ``path``; ``(None, "")`` when there is no file; ``(None, why)`` when it is not to be trusted."""
    shown = short_path(path, 200)
    untrusted = "so bhr does not trust it (delete it and bhr makes a new one)"
    for _ in range(40):
        try:
            fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
        except (FileNotFoundError, NotADirectoryError):  # none yet (or no folder for it: making it says why)
            return None, ""
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                return None, f"the signing key {shown} is a symbolic link, {untrusted}"
            return None, f"bhr cannot read its signing key {shown} ({exc.strerror or type(exc).__name__})"
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode):
                return None, f"the signing key {shown} is not a regular file, {untrusted}"
            if hasattr(os, "geteuid") and st.st_uid != os.geteuid():
                return None, f"the signing key {shown} belongs to another user, {untrusted}"
            if st.st_mode & 0o077:
                return None, f"the signing key {shown} can be read or written by other users, {untrusted}"
            data = os.read(fd, _KEY_BYTES + 1)
        except OSError as exc:
            return None, f"bhr cannot read its signing key {shown} ({exc.strerror or type(exc).__name__})"
        finally:
            os.close(fd)
        if len(data) == _KEY_BYTES:
            return data, ""
        if len(data) < _KEY_BYTES and time.time() - st.st_mtime < 2.0:
            time.sleep(0.05)  # another bhr writing it in place (a file system without hard links): wait for it
            continue
        break
    return None, f"the signing key {shown} does not hold {_KEY_BYTES} bytes, {untrusted}"


def _make_key(path: Path) -> None:
    """Make the key file, unless another process makes it first (then theirs stays): never replace one."""
    folder = path.parent
    if not folder.is_dir():
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=folder)  # 0600, never an existing file
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(secrets.token_bytes(_KEY_BYTES))
            fh.flush()
            os.fsync(fh.fileno())
        try:
            os.link(tmp, path)  # whole or not at all; fails when another process was first
        except FileExistsError:
            pass
        except OSError as exc:
            if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.ENOSYS, errno.EMLINK,
                                 errno.EXDEV):
                raise
            _make_key_in_place(path)  # a file system without hard links
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)


def _make_key_in_place(path: Path) -> None:
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
    except FileExistsError:
        return
    with os.fdopen(fd, "wb") as fh:
        fh.write(secrets.token_bytes(_KEY_BYTES))
        fh.flush()
        os.fsync(fh.fileno())


def _mac(key: bytes, text: str) -> str:
    return _SIGNATURE + hmac.new(key, text.encode("ascii"), hashlib.sha256).hexdigest()


def _canonical(doc: dict[str, Any]) -> str:
    """The text a manifest's signature is made over: everything in it but ``signature``, as sorted, compact,
    ASCII JSON (so the indentation it is written with does not matter)."""
    return json.dumps({k: v for k, v in doc.items() if k != "signature"}, sort_keys=True, separators=(",", ":"),
                      ensure_ascii=True)


def sign_manifest(doc: dict[str, Any], key: bytes) -> str:
    """The signature of manifest ``doc`` with ``key``: ``hmac-sha256:`` and 64 hex digits."""
    return _mac(key, _canonical(doc))


def signed_by_bhr(doc: dict[str, Any], key: bytes | None) -> bool:
    """True when ``doc`` carries the signature ``key`` makes of its content (False without a key)."""
    given = doc.get("signature")
    if key is None or not isinstance(given, str) or not given.isascii():
        return False
    try:
        wanted = sign_manifest(doc, key)
    except (ValueError, TypeError, RecursionError):
        return False
    return hmac.compare_digest(wanted.encode("ascii"), given.encode("ascii"))


def _stage_mark_text(stage_name: str, key: bytes) -> str:
    """What the mark in a staging folder holds: bhr's signature of the folder's name."""
    return _mac(key, "bhr-stage:" + stage_name.encode("unicode_escape").decode("ascii")) + "\n"


def _stage_mark_ok(stage: Path, key: bytes | None) -> bool:
    """True when ``stage`` holds the mark this user's bhr put in it (a regular file with its signed name)."""
    if key is None:
        return False
    mark = stage / _STAGE_MARK
    try:
        if mark.is_symlink() or not mark.is_file() or mark.stat().st_size > 200:
            return False
        given = mark.read_bytes()
    except OSError:
        return False
    return hmac.compare_digest(given, _stage_mark_text(stage.name, key).encode("ascii"))


class OutputFolder:
    """Stage an output folder beside ``target`` and put it in place whole when the ``with`` block succeeds.

    An existing folder is replaced only when bhr provably wrote it: it is
    empty, or its ``manifest.json`` is a bhr manifest (``bhr_output``), signed
    with this user's key (:func:`output_key`), that lists every file in the
    folder with the size and SHA-256 it still has. A folder holding anything
    else (a user's notes, a file changed since, a web project's own
    manifest.json, a manifest forged, edited, copied or written by an older
    bhr) is refused with one line naming the file or the manifest, and so are
    the current folder, its parents, the home and root folders, and a folder
    holding one of the run's ``inputs``.

    ``settings`` is a short text (a hash) of what determines the run's
    results. When the folder being replaced was written by the same command
    with the same settings, the files this run does not write again are
    carried over (hard links): a rerun never deletes what the earlier run
    made unless it makes it again (``bhr follow --no-plots`` keeps the
    figures of the earlier run with the same settings). With ``keep`` every
    file of the existing folder is carried over unless the run writes it
    again, whatever its settings (``bhr replay`` and ``bhr plan`` add files
    beside a run's data); the folder then still holds that run (its manifest's
    ``made_by`` and ``settings``), so the run's own rerun keeps those files.
    ``names`` are the files a run may write at the top of the folder (for
    messages; patterns like ``*.png`` allowed).

        with OutputFolder("bhr-out/curve", command="follow") as of:
            write_json(of.path("run.json"), doc)
    """

    def __init__(self, target: str | os.PathLike[str], command: str, names: Iterable[str] = (),
                 keep: bool = False, what: str = "output folder", inputs: Iterable[Any] = (),
                 settings: str | None = None) -> None:
        if str(target) == "-":  # standard output everywhere else (--json -, export --out -): no folder
            raise BhrError(f"{what} '-' is standard output, which cannot hold a folder; give a folder name (./- for "
                           "a folder named '-')")
        self.given = Path(target)
        self.command = command
        self.names = tuple(names)
        self.keep = keep
        self.what = what
        self.inputs = tuple(str(i) for i in inputs if i is not None and str(i) != "-")
        self.settings = settings
        self.run_id = uuid.uuid4().hex
        self.stage: Path | None = None
        self.carried: list[str] = []
        self.made: list[Path] = []
        self.made_by: str | None = None  # the command whose settings the folder holds (see _carry_over)
        self.target = self._resolve()

    # -- checks (also callable before any work starts) --

    def _resolve(self) -> Path:
        p = self.given
        _refuse_control(p, self.what)
        current_folder()  # checks below compare with it
        if p.is_symlink():
            if not p.exists():
                raise BhrError(f"{self.what} {short_path(p)} is a symbolic link to a missing "
                               f"{short_path(os.readlink(p))}; create its target or choose another folder")
        return Path(os.path.realpath(os.path.abspath(p)))

    def add_inputs(self, *paths: Any) -> "OutputFolder":
        """Name more input files of the run (a folder holding one is refused); checks again."""
        self.inputs += tuple(str(i) for i in paths if i is not None and str(i) != "-")
        return self.check()

    def check(self) -> "OutputFolder":
        """Refuse, before any work, a target that is a file, a folder bhr did not write, or not writable."""
        t = self.target
        if t.exists() and not t.is_dir():
            raise BhrError(f"{self.what} {short_path(self.given)} is a file, not a folder; choose a folder name")
        cwd = Path(os.path.realpath(current_folder()))
        home = Path(os.path.realpath(Path.home()))
        if t == Path(os.path.abspath(os.sep)) or t == home or _within(cwd, t):
            raise BhrError(f"{self.what} {short_path(self.given)} is the current folder or holds it; give a new "
                           "folder for the output, such as bhr-out/run1")
        for name in self.inputs:
            real = Path(os.path.realpath(os.path.abspath(name)))
            if _within(real, t) and not self.keep:  # with keep, every file it holds is carried over, inputs too
                raise BhrError(f"{self.what} {short_path(self.given)} holds {short_path(name)}, an input of this run; "
                               "give another folder for the output (bhr replaces the whole folder)")
        for parent in t.parents:  # a run inside a run: the outer one could then never be replaced (or checked)
            if _read_manifest(parent / MANIFEST) is not None:
                raise BhrError(f"{self.what} {short_path(self.given)} is inside {short_path(parent)}, a folder bhr "
                               "wrote (bhr replaces such a folder whole); give a folder outside it, such as "
                               "bhr-out/run2")
        if t.is_dir():
            self.previous()
        probe = t.parent
        while not probe.exists() and probe != probe.parent:
            probe = probe.parent
        if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
            raise BhrError(f"cannot write {self.what} {short_path(self.given)}: {short_path(probe)} is not a writable "
                           "folder; choose another path")
        return self

    def previous(self) -> dict[str, Any] | None:
        """The manifest of the existing folder once every file in it is proven bhr's (None: empty or missing).

        Raises a BhrError naming the first file bhr did not write.
        """
        return verify_folder(self.target, self.given, self.what)

    # -- staging --

    def _clean_stale(self) -> None:
        """Delete staging folders of dead runs into this target; put back a folder left aside by one."""
        parent, name = self.target.parent, self.target.name
        if not parent.is_dir():
            return
        key: bytes | None = None
        for e in parent.iterdir():
            for mark in (_STAGE, _ASIDE):
                prefix = f".{name}{mark}"
                if not e.name.startswith(prefix):
                    continue
                try:
                    pid = int(e.name[len(prefix):].split("-", 1)[0])
                except ValueError:
                    continue
                if _pid_alive(pid) and pid != os.getpid():
                    continue
                if e.is_symlink() or not e.is_dir():
                    continue
                if key is None:
                    key = output_key()[0] or b""  # b"": no key; looked for once
                doc = _read_manifest(e / MANIFEST)
                if not ((mark == _STAGE and _stage_mark_ok(e, key or None))
                        or (doc is not None and signed_by_bhr(doc, key or None))):
                    with contextlib.suppress(OSError):
                        e.rmdir()  # killed before its mark was written: empty; a folder with anything in it ...
                    continue  # ... and neither signed mark nor signed manifest is not one bhr staged or set aside,
                    # whatever its name
                if mark == _ASIDE and not self.target.exists():
                    with contextlib.suppress(OSError):
                        os.rename(e, self.target)  # the fallback swap died half-way: restore the old set
                        continue
                shutil.rmtree(e, ignore_errors=True)

    def __enter__(self) -> "OutputFolder":
        self.check()
        self.made = []  # parents this run creates: removed again (when empty) if it fails or is interrupted
        p = self.target.parent
        while not p.exists() and p != p.parent:
            self.made.append(p)
            p = p.parent
        try:
            self.target.parent.mkdir(parents=True, exist_ok=True)
            self._clean_stale()
            self.stage = Path(tempfile.mkdtemp(prefix=f".{self.target.name}{_STAGE}{os.getpid()}-",
                                               dir=self.target.parent))
            os.chmod(self.stage, _mode_for(self.target, 0o777))
            self._mark_stage()
        except BaseException as failure:  # a Ctrl-C (or a full disk) in here: no with block to clean up after
            mine = f".{self.target.name}{_STAGE}{os.getpid()}-"
            with contextlib.suppress(OSError):
                for e in self.target.parent.iterdir():  # this process's stage, made or half made
                    if e.name.startswith(mine):
                        shutil.rmtree(e, ignore_errors=True)
            self._remove_made()
            if isinstance(failure, OSError) and (failure.filename is None or mine in str(failure.filename)):
                failure.filename = str(self.given)  # the folder as the user named it, not its hidden stage
            raise
        _staging.add(self.stage)
        return self

    def _mark_stage(self) -> None:
        """Mark the stage bhr's (signed with the user's key), so that the next run deletes it if this one dies."""
        assert self.stage is not None
        mark = self.stage / _STAGE_MARK
        mark.touch()  # empty, when there is no key or no room: never deleted as a dead run's, not a failure
        key, _ = output_key()
        if key is None:
            return
        try:
            mark.write_text(_stage_mark_text(self.stage.name, key), encoding="ascii")
        except OSError as exc:  # a full disk fails at the run's first file, which the message then names
            if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
                raise

    def path(self, name: str | os.PathLike[str]) -> Path:
        """Where to write ``name`` (relative to the folder) while staging."""
        assert self.stage is not None, "use OutputFolder in a with block"
        p = self.stage / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if p.is_file() or p.is_symlink():
            p.unlink()  # a carried-over hard link: never write through it into the old folder
        return p

    def final(self, name: str | os.PathLike[str]) -> Path:
        """Where ``name`` will be once the folder is in place (as the user named the folder)."""
        return self.given / name

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        assert self.stage is not None
        _staging.discard(self.stage)
        if exc_type is not None:
            self._discard()
            if isinstance(exc, OSError):
                self._name_output(exc)
            return
        try:
            if INTERRUPTED.is_set():  # Ctrl-C was seen (and perhaps swallowed somewhere): no folder
                raise KeyboardInterrupt
            old_doc = self.previous() if self.target.is_dir() else None  # again: the user may have added a file
            self._carry_over(old_doc)
            self._write_manifest()
            if INTERRUPTED.is_set():
                raise KeyboardInterrupt
        except BaseException as failure:
            self._discard()
            if isinstance(failure, OSError):
                self._name_output(failure)
            raise
        if _together is not None:  # one set with the command's other outputs: put in place at its end
            _together.folders.append(self)
            return
        self._place(verify=False)

    def _discard(self) -> None:
        """Delete the staged folder and the parents this run made (a failure, an interrupt, a set not placed)."""
        if self.stage is not None:
            shutil.rmtree(self.stage, ignore_errors=True)
        self._remove_made()

    def _place(self, verify: bool = True) -> None:
        """Put the staged folder (manifest written) in place, and delete the folder it replaced. ``verify``: prove
        the folder being replaced is still only bhr's (a set placed at its end: a file added meanwhile is kept)."""
        try:
            if INTERRUPTED.is_set():
                raise KeyboardInterrupt
            if verify and self.target.is_dir():
                self.previous()
            assert self.stage is not None
            with contextlib.suppress(FileNotFoundError):
                (self.stage / _STAGE_MARK).unlink()  # the manifest marks it bhr's from now on
            old = self._commit()
        except BaseException as failure:
            self._discard()
            if isinstance(failure, OSError):
                self._name_output(failure)
            raise
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)

    def _remove_made(self) -> None:
        for p in getattr(self, "made", []):  # innermost first; a folder someone else filled meanwhile stays
            with contextlib.suppress(OSError):
                p.rmdir()

    def _name_output(self, exc: OSError) -> None:
        """Make a failed write's message name the output as the user named it (not the staging folder)."""
        assert self.stage is not None
        name = exc.filename
        if name is None:
            exc.filename = str(self.given)
            return
        try:
            rel = Path(os.path.abspath(name)).relative_to(self.stage)
        except ValueError:
            return
        exc.filename = str(self.given / rel) if str(rel) != "." else str(self.given)

    def _carry_over(self, old_doc: dict[str, Any] | None) -> None:
        """Hard-link into the stage the earlier run's files this run does not write again (see the class)."""
        assert self.stage is not None
        if old_doc is None:
            return
        if self.keep and self.settings is None:
            # files added beside a run (replay, plan): the folder still holds that run, of its command and
            # settings, so that the run's own rerun keeps these files as it keeps its other ones
            self.settings, self.made_by = old_doc.get("settings"), _made_by(old_doc)
        same = (self.settings is not None and old_doc.get("settings") == self.settings
                and _made_by(old_doc) == self.command)
        if not (self.keep or same):
            return
        for rel in old_doc.get("files", {}):
            dst = self.stage / rel
            if dst.exists() or dst.is_symlink():
                continue
            src = self.target / rel
            if not src.is_file() or src.is_symlink():  # a figure the user deleted since: not there to keep
                continue
            dst.parent.mkdir(parents=True, exist_ok=True)
            try:
                os.link(src, dst)
            except OSError:
                shutil.copy2(src, dst)
            self.carried.append(rel)

    def _write_manifest(self) -> None:
        assert self.stage is not None
        files = {}
        for p in sorted(self.stage.rglob("*")):
            rel = p.relative_to(self.stage).as_posix()
            if p.is_file() and rel not in (MANIFEST, _STAGE_MARK):
                files[rel] = {"bytes": p.stat().st_size, "sha256": _sha256(p)}
        doc = {"bhr_output": 2, "written_by": f"bhr {__version__}", "bhr_version": __version__,
               "command": self.command, "made_by": self.made_by or self.command, "run_id": self.run_id,
               "settings": self.settings,
               "written": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "files": files,
               "carried_over": sorted(self.carried)}
        key, _ = output_key()
        if key is not None:  # without a key the manifest is written unsigned: no later run may replace the folder
            doc["signature"] = sign_manifest(doc, key)
        (self.stage / MANIFEST).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        os.chmod(self.stage / MANIFEST, _mode_for(self.target / MANIFEST))

    def _commit(self) -> Path | None:
        """Put the staged folder in place; return the folder it displaced (to delete), if any."""
        assert self.stage is not None
        stage, target = self.stage, self.target
        for _ in range(1000):
            try:
                _renameat2(stage, target, _RENAME_NOREPLACE)
                return None
            except FileExistsError:
                pass
            except OSError as exc:
                if exc.errno in (errno.ENOSYS, errno.EINVAL):
                    return self._commit_fallback()
                raise
            try:
                _renameat2(stage, target, _RENAME_EXCHANGE)
                return stage  # now holds the previous set
            except FileNotFoundError:
                continue  # the target vanished in between (another run's swap): try again
            except NotADirectoryError:
                raise BhrError(f"{self.what} {self.given} became a file while the run worked; "
                               "choose another folder") from None
        raise BhrError(f"could not put {self.what} {self.given} in place (another run keeps replacing it); "
                       "run again")

    def _commit_fallback(self) -> Path | None:
        """Without renameat2: under a lock, move the old folder aside, then the new one in (restored if killed)."""
        import fcntl

        assert self.stage is not None
        lock = self.target.parent / f".{self.target.name}.bhr-lock"
        with open(lock, "a") as fh:
            fcntl.flock(fh, fcntl.LOCK_EX)
            aside = None
            if self.target.exists():
                aside = Path(tempfile.mkdtemp(prefix=f".{self.target.name}{_ASIDE}{os.getpid()}-",
                                              dir=self.target.parent))
                os.rmdir(aside)
                os.rename(self.target, aside)
            os.rename(self.stage, self.target)
            return aside



#: A manifest larger than this is not bhr's (a run's lists a few thousand files at most).
_MAX_MANIFEST = 16 * 1024 * 1024


def _made_by(doc: dict[str, Any]) -> Any:
    """The command whose run (and settings) a folder holds: ``made_by``, else (older manifests) ``command``."""
    return doc.get("made_by", doc.get("command"))


def short_path(p: Any, limit: int = 80) -> str:
    """A path as quoted in a one-line message: control characters escaped, at most ``limit`` characters."""
    text = str(p)
    text = text.encode("unicode_escape").decode("ascii") if not text.isprintable() else text
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _within(path: Path, folder: Path) -> bool:
    """True when ``path`` is ``folder`` or inside it (both absolute, resolved)."""
    return path == folder or folder in path.parents


def verify_folder(folder: Path, given: Any = None, what: str = "output folder") -> dict[str, Any] | None:
    """The bhr manifest of ``folder`` when it proves bhr wrote every file there; None when the folder is empty.

    Proof: ``manifest.json`` is a bhr manifest (``bhr_output``, ``files``)
    signed with this user's key (:func:`output_key`, compared in constant
    time), and every file under the folder is listed with the size and
    SHA-256 it has now; no symbolic link, device, or folder the manifest does
    not account for. Anything else raises a BhrError naming the file (or the
    manifest) and the fix (bhr replaces the whole folder, so it would be
    deleted).
    """
    shown = short_path(given if given is not None else folder)
    fix = f"move it out of {shown} or give another folder for the output"
    try:
        entries = list(folder.iterdir())
    except OSError as exc:
        raise BhrError(f"cannot read {what} {shown} ({exc.strerror}); choose another folder") from None
    if not entries:
        return None
    found: list[str] = []
    dirs: list[str] = []
    for root, dnames, fnames in os.walk(folder):
        rel_root = Path(root).relative_to(folder)
        for d in dnames:
            rel = (rel_root / d).as_posix()
            if os.path.islink(os.path.join(root, d)):
                raise BhrError(f"{what} {shown} holds {short_path(rel)}, a link bhr did not make; {fix}")
            dirs.append(rel)
        for f in fnames:
            found.append((rel_root / f).as_posix())
    doc = _read_manifest(folder / MANIFEST)
    if doc is None:
        first = sorted(e.name for e in entries)[0]
        raise BhrError(f"{what} {shown} holds {short_path(first)}, which no bhr run wrote (no bhr manifest.json "
                       f"lists it); {fix}")
    key, why = output_key()
    if not signed_by_bhr(doc, key):
        if key is None:
            raise BhrError(f"{what} {shown} has a manifest.json that bhr cannot check: {why}; remove the folder "
                           "yourself or give another folder for the output")
        raise BhrError(f"{what} {shown} has a manifest.json not signed by bhr for this user (copied, edited or "
                       "written by an older bhr); remove the folder yourself or give another folder for the output")
    listed = doc["files"]
    for rel in sorted(found):
        if rel == MANIFEST:
            continue
        p = folder / rel
        entry = listed.get(rel)
        if entry is None or not isinstance(entry, dict):
            raise BhrError(f"{what} {shown} holds {short_path(rel)}, which no bhr run wrote; {fix}")
        st = os.lstat(p)
        if not stat.S_ISREG(st.st_mode):
            raise BhrError(f"{what} {shown} holds {short_path(rel)}, which is not a file bhr wrote; {fix}")
        if st.st_size != entry.get("bytes") or _sha256(p) != entry.get("sha256"):
            raise BhrError(f"{what} {shown} holds {short_path(rel)}, changed since bhr wrote it; {fix}")
    holding = {Path(r).parent.as_posix() for r in found}
    for d in dirs:
        if not any(h == d or h.startswith(d + "/") for h in holding):
            raise BhrError(f"{what} {shown} holds the folder {short_path(d)}, which bhr did not write; {fix}")
    return doc


def _read_manifest(path: Path) -> dict[str, Any] | None:
    """A bhr manifest's content, or None when ``path`` is missing or not a bhr manifest."""
    try:
        if path.is_symlink() or not path.is_file() or path.stat().st_size > _MAX_MANIFEST:
            return None
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(doc, dict) or doc.get("bhr_output") not in (1, 2) or not isinstance(doc.get("files"), dict):
        return None
    if not isinstance(doc.get("run_id"), str) or not isinstance(doc.get("command"), str):
        return None
    if not all(isinstance(rel, str) and _inside_name(rel) for rel in doc["files"]):
        return None  # bhr lists only the files inside its folder: "../x" or "/etc/x" is no manifest of bhr's
    return doc


def _inside_name(rel: str) -> bool:
    """``rel`` names a file inside a folder: relative, without ``..``, ``.`` or empty parts, one line."""
    parts = rel.split("/")
    return bool(rel) and not rel.startswith("/") and "\\" not in rel and not has_control_char(rel) and \
        all(p not in ("", ".", "..") for p in parts)


def owning_folder(path: str | os.PathLike[str]) -> tuple[Path, str] | None:
    """The bhr output folder whose manifest lists ``path``, and ``path`` inside it (None: none does).

    A run's own folder (``bhr-out/colon-thesis-<hash>/codes.csv``), or a folder one or two levels up that holds
    runs (``compare``'s ``thesis/codes.csv``, a report's ``runs/colon/codes.csv``): ``bhr plan`` and ``bhr replay``
    add their figures to that folder whole, so its manifest lists them and a rerun never takes them for a
    user's file. Only a manifest signed by this user's bhr counts (:func:`verify_folder`): with any other the
    file is taken as loose.
    """
    p = Path(os.path.realpath(path))
    for folder in list(p.parents)[:3]:
        doc = _read_manifest(folder / MANIFEST)
        if doc is not None:
            if not signed_by_bhr(doc, output_key()[0]):
                return None
            rel = p.relative_to(folder).as_posix()
            return (folder, rel) if rel in doc["files"] else None
    return None


def settings_hash(*parts: Any) -> str:
    """8 hex digits of a SHA-256 over ``parts``: arrays (their bytes), files named by ``Path`` (their content),
    anything else as sorted JSON. Two runs agree on it only when they agree on all parts."""
    h = hashlib.sha256()
    for part in parts:
        if hasattr(part, "tobytes"):
            h.update(part.tobytes())
        elif isinstance(part, Path):
            try:
                h.update(_sha256(part).encode())
            except OSError:
                h.update(str(part).encode())
        else:
            h.update(json.dumps(part, sort_keys=True, default=repr).encode())
        h.update(b"\x00")
    return h.hexdigest()[:8]


def point_latest(folder: str | os.PathLike[str], link_name: str = "latest") -> Path | None:
    """Make ``<parent>/latest`` a symbolic link to ``folder`` (the run just written); return the link.

    The link is replaced by a rename, so it always points at a whole folder.
    Nothing is done when ``latest`` exists and is not a symbolic link (a
    user's own file or folder), or when the file system has no links.
    """
    target = Path(folder)
    if _together is not None:  # the folder goes in place at the end of the set: the link after it
        _together.after.append(lambda: point_latest(target, link_name))
        return target.parent / link_name
    link = target.parent / link_name
    if link.exists() and not link.is_symlink():
        return None
    tmp = target.parent / f".{link_name}.bhr-link-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    try:
        os.symlink(target.name, tmp)
        os.replace(tmp, link)
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        return None
    return link


# --- run folders: names from settings, and the checks made before any work (bhr follow and the studies) ---


def run_folder_name(readable: str, *parts: Any) -> str:
    """A folder name for a run: ``readable`` plus 8 hex digits of a hash of what makes the run different.

    ``parts`` are JSON-able descriptions (trajectory points, robot, solver and
    its options; a ``Path`` stands for its file's content); two runs share a
    folder only when they agree on all of them (:func:`bhr.output.atomic.settings_hash`).
    """
    return folder_name(readable, settings_hash(*parts))


def folder_name(readable: str, settings: str) -> str:
    """``readable`` made safe for a file name (at most 60 characters) plus ``-`` and the settings hash."""
    safe = "".join(c if c.isalnum() and c.isascii() or c in "-_." else "_" for c in readable)[:60].lstrip(".")
    return f"{safe or 'run'}-{settings}"


def input_files(*paths: Any) -> list[Path]:
    """The ones of ``paths`` that name existing files (inputs a run reads), for output checks and hashes."""
    out = []
    for p in paths:
        if p is None or str(p) == "-":
            continue
        with contextlib.suppress(OSError, ValueError):
            if os.path.isfile(p):
                out.append(Path(p))
    return out


def json_in_folder(json_path: str | None, folder: Any, taken: tuple[str, ...], option: str = "--json"
                   ) -> str | None:
    """The name inside the output folder that ``--json`` (or ``option``) names, if it names a file in it.

    None when it names a file elsewhere. Refuses a name that another output of the same run writes
    (codes.csv, a figure, the manifest).
    """
    import fnmatch

    if json_path is None or json_path == "-":
        return None
    real = Path(os.path.abspath(os.path.realpath(json_path)))
    try:
        rel = real.relative_to(folder.target)
    except ValueError:
        return None
    name = str(rel)
    if name == "." or any(fnmatch.fnmatch(name, pat) for pat in taken) or name == "manifest.json":
        raise BhrError(f"{option} {json_path} names another output of this run; choose another file name")
    return name


def check_parent_folder(folder: str | os.PathLike[str], what: str = "output folder") -> None:
    """Fail before any work when run folders cannot be made inside ``folder`` (the default ``bhr-out``)."""
    p = Path(folder)
    if not p.is_absolute():
        current_folder()
    probe = p
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
        raise BhrError(f"cannot make the {what} in {p}: {probe} is not a writable folder; give --out DIR")
