"""Helpers shared by the command modules: error reporting and output checks."""
from __future__ import annotations

import contextlib
import functools
import os
import stat
import sys
from pathlib import Path
from typing import Any, Callable

import click

from bhr.output._paths import (check_parent_folder, folder_name, input_files, json_in_folder,  # noqa: F401
                              run_folder_name, short_path)
from bhr.cli._interrupt import end_interrupted, settle
from bhr._settings.errors import INTERRUPTED, BhrError


def refuse_replacing_beside(folder: Path, names: Any, beside: str, fix: str) -> None:
    """Files written beside a loose input (its folder has no bhr manifest: nothing proves what bhr wrote there)
    never replace a file already there: a user's path.png or thermal.png beside their run.json or codes.csv."""
    for name in names:
        target = folder / name
        if os.path.lexists(target):
            raise BhrError(f"{short_path(str(target))} already exists beside {short_path(beside)}, and no bhr "
                           f"manifest.json there says bhr wrote it; {fix}")


def os_error_line(exc: OSError, on_stdout: bool = True) -> str:
    """One line for a failed read or write: what, why, and what to do. An error that names no file is standard
    output's when ``on_stdout`` (:func:`_stdout_failed`), else a file some library was writing."""
    import errno

    what = short_path(str(exc.filename)) if exc.filename is not None else (
        "standard output" if on_stdout else _unnamed_writer(exc))
    why = exc.strerror or type(exc).__name__
    fixes = {
        errno.ENOSPC: "free some disk space or write to another device",
        errno.EDQUOT: "free some of your disk quota or write elsewhere",
        errno.EROFS: "the file system is read-only; choose another path",
        errno.EACCES: "check the permissions or choose another path",
        errno.EPERM: "check the permissions or choose another path",
        errno.EFBIG: "the file is too large for this file system; write elsewhere",
        errno.EIO: "the device reported an input/output error; check it and run again",
        errno.EBADF: "give it an open file or /dev/null",
    }
    fix = fixes.get(exc.errno or 0, "check the path and the device, then run again")
    return f"{what}: {why}; {fix}"


def _unnamed_writer(exc: OSError) -> str:
    """What wrote the file an OSError does not name: numba's cache of compiled kernels (its folder named, as
    NUMBA_CACHE_DIR can move it), else some library."""
    import traceback

    if any("numba" in f.filename and "caching" in f.filename for f in traceback.extract_tb(exc.__traceback__)):
        cache = short_path(os.environ.get("NUMBA_CACHE_DIR", "?"))
        return f"writing bhr's compiled kernels to {cache} (NUMBA_CACHE_DIR)"
    return "writing a file"


def _stdout_failed(exc: OSError | None = None) -> bool:
    """Whether standard output is what failed: what it holds cannot be written either (a failed write keeps its
    data buffered). An OSError that names no file came from standard output, or from a library writing a file of
    its own through an open file (numba's cache, matplotlib's font list): the line must not blame the wrong one.
    A failed flush drops what it held, so a second flush succeeds: a "no room" error is also standard output's
    when standard output itself has no room (``> /dev/full``, a file on a full disk)."""
    try:
        sys.stdout.flush()
    except (OSError, ValueError):  # ValueError: standard output closed
        return True
    import errno

    if exc is None or exc.errno not in (errno.ENOSPC, errno.EDQUOT):
        return False
    try:
        fd = sys.stdout.fileno()
        st = os.fstat(fd)
        if stat.S_ISCHR(st.st_mode):
            return st.st_rdev == os.makedev(1, 7)  # /dev/full
        return stat.S_ISREG(st.st_mode) and os.fstatvfs(fd).f_bavail == 0
    except (OSError, ValueError, AttributeError):
        return False


def _quiet_stdout() -> None:
    """Point standard output at /dev/null so that the interpreter's final flush cannot fail again."""
    with contextlib.suppress(Exception):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())


def _before_placing() -> None:
    """The command's work is done and its outputs staged: standard output takes the summary (a full or closed one
    fails here, and nothing is put in place), then a signal from now on changes nothing, so that the set goes in
    place whole and the command ends with its own status (a Ctrl-C while a folder was renamed into place ended in
    "Interrupted." and 130 with the folder there; one before this point still leaves nothing)."""
    sys.stdout.flush()
    settle()


def guarded(func: Callable[..., Any]) -> Callable[..., Any]:
    """Turn a BhrError, a failed write (disk or standard output full), memory exhaustion and Ctrl-C into one
    line on stderr and a non-zero exit."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        from bhr.output._atomic import together
        from bhr.output._paths import current_folder

        try:
            current_folder()  # deleted under the command: one line before any work, not a failed write after it
            # the command's files and folders, and what it prints, are one set: they are put in place only once
            # standard output took the summary (a full or closed standard output fails at this flush, and then
            # leaves no folder, as a full disk does)
            with together(check=_before_placing):
                rv = func(*args, **kwargs)
            if INTERRUPTED.is_set():  # a Ctrl-C that something caught on the way: still honoured
                raise KeyboardInterrupt
            return rv
        except BhrError as exc:
            if INTERRUPTED.is_set():  # a worker that went with the same Ctrl-C or SIGTERM: the interrupt is the news
                end_interrupted()
            raise click.ClickException(str(exc).splitlines()[0] if str(exc) else type(exc).__name__) from None
        except ValueError as exc:
            if _raised_in_numba(exc):  # NUMBA_NUM_THREADS=0 and the like: numba's own settings, not bhr's
                names = ", ".join(sorted(k for k in os.environ
                                         if k.startswith("NUMBA_") and k != "NUMBA_CACHE_DIR")[:4]) or "NUMBA_*"
                raise click.ClickException(f"numba refused its settings ({str(exc).splitlines()[0][:120]}); check "
                                           f"the environment's {names}") from None
            if not str(exc).startswith("Key backend:"):
                raise
            shown = repr(os.environ.get("MPLBACKEND", ""))[:40]  # matplotlib refused the environment's backend
            raise click.ClickException(f"MPLBACKEND={shown} is not a matplotlib backend; unset it or set "
                                       "MPLBACKEND=Agg") from None
        except KeyboardInterrupt:
            end_interrupted()
        except BrokenPipeError:
            _quiet_stdout()  # the reader went away (bhr ... | head): stop quietly
            sys.exit(141)
        except OSError as exc:
            on_stdout = exc.filename is None and _stdout_failed(exc)
            if on_stdout:
                _quiet_stdout()
            raise click.ClickException(os_error_line(exc, on_stdout)) from None
        except MemoryError:
            raise click.ClickException("out of memory; use a shorter trajectory, fewer modules or a larger feed "
                                       "(the limits are in docs/commands.md)") from None
        except RecursionError:
            raise click.ClickException("input nested too deeply to read; give a file as bhr writes it") from None

    return wrapper


def _raised_in_numba(exc: BaseException) -> bool:
    """Whether ``exc`` was raised inside numba itself (its innermost frame is in numba's package)."""
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return tb is not None and f"{os.sep}numba{os.sep}" in tb.tb_frame.f_code.co_filename


def check_writable(path: str | os.PathLike[str] | None, what: str = "output") -> None:
    """Fail before any work starts when ``path`` cannot be written (or is a read-only file).

    ``-`` (standard output) and ``None`` are always accepted; devices and
    FIFOs (``/dev/null``) are written in place and accepted when writable.
    """
    if path is None or str(path) == "-":
        return
    from bhr.output._paths import check_output_file

    check_output_file(path, what)
    _refuse_an_input(path, what)
    _refuse_a_second_output(path, what)


def _refuse_a_second_output(path: str | os.PathLike[str], what: str) -> None:
    """Two outputs of one command on one file (``--csv p.png --plot p.png``, ``--json s --plot s``), existing or
    not, are refused before any work: the second would replace the first. A device takes both."""
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return
    real = os.path.realpath(os.path.abspath(path))
    if os.path.exists(real) and not os.path.isfile(real):  # a device (/dev/null for both) is written in place
        return
    seen = ctx.meta.setdefault("bhr.outputs", {})
    if real in seen and seen[real] != what:
        raise click.ClickException(f"the {seen[real]} and the {what} are both {str(path)[:80]!r}: one would replace "
                                   "the other; give each output its own path")
    seen.setdefault(real, what)


def _same_file(a: Any, b: Any) -> bool:
    with contextlib.suppress(OSError, ValueError, TypeError):
        return os.path.isfile(a) and os.path.samefile(a, b)
    return False


def _refuse_an_input(path: str | os.PathLike[str], what: str) -> None:
    """An output file that another option of the command names too (an input: --traj, --codes, --robot, or
    a second output) is refused before any work: writing it would replace what the command reads."""
    if not os.path.isfile(path):
        return
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return
    naming = []
    for name, value in ctx.params.items():
        values = value if isinstance(value, (tuple, list)) else (value,)
        if any(isinstance(v, (str, os.PathLike)) and str(v) != "-" and _same_file(v, path) for v in values):
            naming.append(name)
    if len(naming) >= 2:
        flags = {p.name: (p.opts[0] if getattr(p, "opts", None) else p.name) for p in ctx.command.params}
        named = " and ".join(str(flags.get(n, n)) for n in naming[:3])
        raise click.ClickException(f"{what} {str(path)[:80]!r} is named by both {named}; writing it would replace "
                                   "what this command reads: choose another path")


def default_output(command: str, readable: str, settings_parts: tuple[Any, ...], inputs: list[Path],
                   out_dir: str | None, what: str = "output folder", force: bool = False):
    """The checked output folder of a study command: ``--out`` or ``bhr-out/<readable>-<hash of the settings>``.

    The hash covers ``settings_parts`` and the content of every input file, so two runs share the
    default folder only when they would make the same results; the manifest records it, so a rerun keeps
    what the earlier run made and this one does not make again (docs/commands.md#output-folders).
    """
    from bhr.output._atomic import OutputFolder
    from bhr.output._paths import settings_hash

    settings = settings_hash(*settings_parts, *inputs)
    if out_dir is None:
        check_parent_folder("bhr-out")
        target: Path = Path("bhr-out") / folder_name(readable, settings)
    else:
        target = Path(out_dir)
    return OutputFolder(target, command, what=what, inputs=inputs, settings=settings,
                        force=force).check()


def point_latest_if_default(folder: Any, out_dir: str | None) -> None:
    """bhr-out/latest: the run just written, when it went to its default folder."""
    if out_dir is None:
        from bhr.output._atomic import point_latest

        point_latest(folder.target)


def check_executor(jobs: int | None, scheduler: str | None) -> None:
    """Local worker processes or a Dask cluster, not both; Dask installed when a cluster is named."""
    if scheduler is not None and jobs is not None:
        raise BhrError("--jobs and --scheduler exclude each other: the cluster decides how many workers run")
    if scheduler is not None:
        try:
            import distributed  # noqa: F401
        except ImportError:
            from bhr._studies.cluster import dask_missing

            raise BhrError(dask_missing()) from None


def print_study(folder: Any, out_dir: str | None, lines: Any, files: Any, failed: int, total: int, what: str,
                table: str) -> int:
    """A study's ending: ``latest`` pointed at its folder, its summary lines, what it wrote, and the exit
    status (1 with one line naming ``table`` when ``failed`` of ``total`` ``what`` failed)."""
    point_latest_if_default(folder, out_dir)
    for line in lines:
        click.echo(line)
    click.echo("Wrote " + ", ".join(str(p) for p in files))
    if failed:
        click.echo(f"Error: {failed} of {total} {what} failed; see {folder.final(table)}", err=True)
        return 1
    return 0
