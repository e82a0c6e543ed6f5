"""Shared fixtures: run the real `bhr` console script, and a thesis robot."""
from __future__ import annotations

import os
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


def bhr_exe() -> list[str]:
    beside = Path(sys.executable).parent / "bhr"  # the venv's own command, PATH or not
    exe = str(beside) if os.access(beside, os.X_OK) else shutil.which("bhr")
    if exe is None:  # installed without the scripts folder on PATH: run the entry point module
        return [sys.executable, "-m", "bhr.cli.main"]
    return [exe]


def cli_install_command(extra: str) -> str:
    """``install_command(extra)`` as the bhr command prints it: with the Python that runs the command (its script's
    ``#!`` line, e.g. the venv's python3), which may be another name for this test run's Python."""
    import shlex

    from bhr._settings.extras import install_command

    first = Path(bhr_exe()[0]).read_text(errors="replace").splitlines()[0] if bhr_exe()[0] != sys.executable else ""
    python = first[2:].strip() if first.startswith("#!") else sys.executable
    return install_command(extra).replace(shlex.quote(sys.executable), shlex.quote(python), 1)


@pytest.fixture
def run_bhr(tmp_path):
    """Run `bhr ARGS...` in a subprocess (cwd = a temporary folder); return CompletedProcess."""

    def run(*args: str, cwd: Path | None = None, timeout: float = 600, input: str | None = None):
        env = dict(os.environ)
        env.setdefault("MPLBACKEND", "Agg")
        return subprocess.run(bhr_exe() + [str(a) for a in args], cwd=cwd or tmp_path, capture_output=True,
                              text=True, timeout=timeout, env=env, input=input)

    return run


@pytest.fixture
def run_bhr_in_process(tmp_path):
    """`bhr ARGS...` in this process (:func:`bhr_in_process`), cwd = a temporary folder; the same call and the same
    result as :func:`run_bhr`, for a test of what the command does rather than of the process."""

    def run(*args: str, cwd: Path | None = None, timeout: float = 600, input: str | None = None):
        return bhr_in_process(*args, cwd=cwd or tmp_path, input=input, timeout=timeout)

    return run


def bhr_in_process(*args: object, cwd: Path, env: dict | None = None, input: str | None = None,
                   timeout: float | None = None) -> subprocess.CompletedProcess:
    """Run `bhr ARGS...` in this process, as the console script runs it (the same command group through click's
    CliRunner, named ``bhr``), in ``cwd``, with ``env`` as the whole environment when given; return what a
    process would: its exit status, standard output and standard error (text). An exception that escapes the
    command is printed on standard error as the interpreter prints it (``Traceback ...``), exit status 1. A
    command still running after ``timeout`` seconds (a guard against a hang, as the process helpers' timeout is)
    ends this test process with the stacks of its threads (faulthandler): the test fails, the run goes on.

    For tests of what a command does with its input and its files; a test of the process itself (signals, exit
    status of a killed command, closed or full standard streams, rlimits, what the interpreter does at start or
    at exit, an environment read when Python starts) runs the real ``bhr`` (:func:`bhr_exe`)."""
    import contextlib
    import faulthandler
    import traceback

    from click.testing import CliRunner

    from bhr.cli.main import main

    changes: dict[str, str | None] = {}
    if env is not None:  # the environment it names, no more: what it leaves out is unset for the command
        changes = {k: v for k, v in env.items() if os.environ.get(k) != v}
        changes.update({k: None for k in os.environ if k not in env})
    if "MPLBACKEND" not in (env or os.environ):
        changes["MPLBACKEND"] = "Agg"
    argv = [str(a) for a in args]
    faulthandler.dump_traceback_later(timeout or 600, exit=True)
    try:
        with contextlib.chdir(cwd):
            res = CliRunner().invoke(main, argv, input=input, env=changes, prog_name="bhr")
    finally:
        faulthandler.cancel_dump_traceback_later()
    err = res.stderr
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        err += "".join(traceback.format_exception(res.exception))  # an uncaught one: the interpreter's traceback
    return subprocess.CompletedProcess(["bhr", *argv], res.exit_code, res.stdout, err)


def foreground() -> None:
    """``preexec_fn`` of a command a test sends signals to: Ctrl-C, SIGTERM and SIGHUP at their default actions, as
    a shell's foreground job has them, whatever this test run inherited (``bash tests/run &`` and nohup ignore
    some of them, and a child inherits what is ignored)."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def start_bhr(args, cwd: Path, env: dict | None = None, preexec_fn=foreground) -> subprocess.Popen:
    """Start `bhr ARGS...` in its own session, stdout and stderr piped (bytes, unbuffered), its progress lines
    written as its work starts and at every step (BHR_PROGRESS_INTERVAL=0): :func:`wait_for_stderr` waits for one."""
    env = dict(env or os.environ, BHR_PROGRESS_INTERVAL="0")
    env.setdefault("MPLBACKEND", "Agg")
    return subprocess.Popen(bhr_exe() + [str(a) for a in args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, bufsize=0, env=env, start_new_session=True, preexec_fn=preexec_fn)


def wait_for_stderr(p: subprocess.Popen, needle: str, timeout: float = 300.0) -> str:
    """Read ``p``'s stderr until it holds ``needle`` (a readiness line); return what was read. The timeout is only
    a guard against a hang: the test waits for the line, not for a time."""
    got, fd, deadline = b"", p.stderr.fileno(), time.monotonic() + timeout
    while needle.encode() not in got:
        ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        chunk = os.read(fd, 65536) if ready else b""
        if not chunk:
            raise AssertionError(f"no {needle!r} on bhr's stderr ({'ended' if ready else 'timed out'}): "
                                 f"{got.decode(errors='replace')[-2000:]}")
        got += chunk
    return got.decode(errors="replace")


def finish(p: subprocess.Popen, read: str = "", timeout: float = 300.0) -> tuple[int, str, list[str]]:
    """Wait for ``p``; its exit status, stdout, and the lines of its stderr (with ``read``, what was read before)
    that are neither progress lines nor the first-compile notice."""
    out, err = p.communicate(timeout=timeout)
    lines = (read + err.decode(errors="replace")).strip().splitlines()
    return p.returncode, out.decode(errors="replace"), [
        ln for ln in lines if ln.strip() and not ln.startswith("Compiling bhr's") and not PROGRESS.match(ln)]


#: A progress line of a command whose stderr is not a terminal (bhr.cli._progress): ``label: ..., N s``.
PROGRESS = __import__("re").compile(r"^.+: .*\b\d+ s$")


FIRMWARE = REPO / "firmware"


def make_firmware(*args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    """``make ARGS`` in firmware/ (output captured, text), one at a time across the parallel test workers: two
    makes of one target at once would write the same object files."""
    from filelock import FileLock

    (FIRMWARE / "build").mkdir(exist_ok=True)
    with FileLock(FIRMWARE / "build" / ".make.lock"):
        return subprocess.run(["make", *args], capture_output=True, text=True, timeout=timeout)


def snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    """Names, sizes and mtimes of every file under ``folder`` (to prove nothing changed)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            st = p.stat()
            out[str(p.relative_to(folder))] = (st.st_size, st.st_mtime_ns)
    return out


# ------------------------------------------------------------------ layers
# Every test belongs to one layer, its folder, so that a fast subset can run alone (README, "Tests"):
#   tests/unit         the library in-process: kernels against their numpy references, models, readers, API
#   tests/thesis       the thesis's published figures (chapters 5-7), pinned bit for bit
#   tests/cli          the `bhr` commands, run as a user runs them: a real process where the process is what is
#                      tested, else in this process through the same command group (bhr_in_process)
#   tests/integration  real outside parts: firmware built with avr-gcc and run in simavr, serial ptys, Chromium,
#                      Dask, pinocchio and MuJoCo, the import-contract tool
# The marker is the folder's name, but for one layer without a folder of its own:
#   run                in-process tests in tests/unit marked @pytest.mark.run: whole runs of the library (colons,
#                      whole robots, studies) end to end; `pytest -m unit` leaves them out, the whole suite runs them
# A test outside these folders, or an in-process test that asks for a command or a cluster, stops the collection
# with a line that says where it belongs.
FOLDERS = ("unit", "thesis", "cli", "integration")
LAYERS = ("unit", "run", "thesis", "cli", "integration")
_NEEDS = {"run_bhr": "cli", "run_bhr_in_process": "cli", "dask_cluster": "integration"}


def _layers_asked(config) -> set[str] | None:
    """The layers a ``-m`` expression made of layer names only asks for (``-m unit``, ``-m "cli or thesis"``), else
    None (any other expression may select tests of any folder)."""
    words = (config.getoption("markexpr", "") or "").split()
    if not words or words[1::2] != ["or"] * (len(words) // 2) or not set(words[::2]) <= set(LAYERS):
        return None
    return set(words[::2])


def pytest_ignore_collect(collection_path, config):
    """``-m unit`` (or another expression of layers) collects only the folders of those layers: importing every
    other test module costs the run seconds (pytest rewrites the asserts of each) for tests it then deselects."""
    asked = _layers_asked(config)
    folder = Path(str(collection_path)).resolve()
    if asked is None or folder.parent != REPO / "tests" or folder.name not in FOLDERS:
        return None
    wanted = {"unit" if layer == "run" else layer for layer in asked}
    return True if folder.name not in wanted else None


def pytest_collection_modifyitems(config, items):
    for item in items:
        folder = Path(str(item.path)).resolve().parent
        layer = folder.name if folder.parent == REPO / "tests" else None
        if layer not in FOLDERS:
            raise pytest.UsageError(f"{item.nodeid}: a test lives in one of tests/{{{','.join(FOLDERS)}}}/ (its layer)")
        fixtures = set(getattr(item, "fixturenames", ()))
        for fixture, home in _NEEDS.items():
            if fixture in fixtures and layer == "unit":
                raise pytest.UsageError(f"{item.nodeid} uses {fixture}: move it to tests/{home}/")
        if item.get_closest_marker("run") is not None:
            if layer != "unit":
                raise pytest.UsageError(f"{item.nodeid}: the run marker is for in-process tests in tests/unit/")
            continue  # its own marker is its layer
        item.add_marker(getattr(pytest.mark, layer))

# Progress lines of long commands whose stderr is not a terminal come every 30 s: a test that pins what a command
# writes to stderr must not depend on how fast this machine is, so they come once an hour unless a test asks.
os.environ.setdefault("BHR_PROGRESS_INTERVAL", "3600")


# ------------------------------------------------------------------ CPU seconds per test
# BHR_TEST_CPU=FILE appends one CSV row per test: nodeid, layer, CPU seconds (user+sys of pytest and of the
# processes it waited for, setup to teardown), wall seconds, outcome. CPU seconds hold on a busy machine where wall time
# does not; tests/layer_times.py sums the rows per layer (README, "Tests").
_CPU_CSV = os.environ.get("BHR_TEST_CPU")


def _cpu_seconds() -> float:
    import resource

    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


if _CPU_CSV:
    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        cpu, wall = _cpu_seconds(), time.monotonic()
        yield
        cpu, wall = _cpu_seconds() - cpu, time.monotonic() - wall
        layer = next((m.name for m in item.iter_markers() if m.name in LAYERS), "")
        outcome = getattr(item, "_bhr_outcome", "")
        import csv
        import io

        row = io.StringIO()
        csv.writer(row, lineterminator="\n").writerow([item.nodeid, layer, f"{cpu:.3f}", f"{wall:.3f}", outcome])
        with open(_CPU_CSV, "a") as f:  # one short write per row: rows of parallel workers do not interleave
            f.write(row.getvalue())

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(item, call):
        report = (yield).get_result()
        if getattr(item, "_bhr_outcome", "") in ("failed", "error"):
            return  # the first failure stands (a teardown after it does not change the row)
        if report.failed:
            item._bhr_outcome = "failed" if call.when == "call" else "error"
        elif report.skipped or call.when == "call":
            item._bhr_outcome = report.outcome
