"""Ctrl-C, SIGTERM and SIGHUP in the bhr command: one line, 128 + the signal, no folder; a signal the caller ignored
(a background job's Ctrl-C, nohup's SIGHUP) stays ignored; a signal once the outputs go in place changes nothing.
Each command is started as a shell starts a foreground job (the signals at their default actions, whatever this test
run inherited), and each signal is sent once the command's readiness line (its first progress line) is out."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import bhr_exe, finish, foreground, start_bhr, wait_for_stderr

SWEEP = ["sweep", "--traj", "colon", "--grid", "modules=3:6", "--jobs", "2", "--no-plots", "--out", "o"]


@pytest.mark.parametrize("sig, status, line", [("SIGINT", 130, "Interrupted."), ("SIGTERM", 143, "Interrupted by SIGTERM."),
                                               ("SIGHUP", 129, "Interrupted by SIGHUP.")])
def test_a_signal_ends_a_study_with_one_line_and_no_folder(tmp_path, sig, status, line):
    p = start_bhr(SWEEP, tmp_path)
    read = wait_for_stderr(p, "Running 4 designs: 0/4")
    os.killpg(p.pid, getattr(signal, sig))  # the whole process group, as a terminal sends it
    assert finish(p, read)[::2] == (status, [line])
    assert list(tmp_path.iterdir()) == []


def _ignoring(sig: int):
    def preexec() -> None:
        foreground()
        signal.signal(sig, signal.SIG_IGN)
    return preexec


@pytest.mark.parametrize("sig", ["SIGINT", "SIGHUP"], ids=["background-job-ctrl-c", "nohup-sighup"])
def test_a_signal_the_caller_ignored_stays_ignored(tmp_path, sig):
    # `bhr ... &` in a script starts it with Ctrl-C ignored, nohup with SIGHUP ignored: the shell's choice holds
    p = start_bhr(SWEEP, tmp_path, preexec_fn=_ignoring(getattr(signal, sig)))
    read = wait_for_stderr(p, "Running 4 designs: 0/4")
    os.killpg(p.pid, getattr(signal, sig))
    code, out, lines = finish(p, read)
    assert (code, lines) == (0, []) and "Wrote o/results.csv" in out


LIBRARY_SWALLOWS = r'''
import os, signal, sys, time
import bhr.output._run_plots as run_plots

SIG = getattr(signal, sys.argv[1])


def save_run_plots(*args, **kwargs):  # a library whose callback took the signal's KeyboardInterrupt
    try:
        os.kill(os.getpid(), SIG)
        time.sleep(60)  # the handler runs as soon as os.kill returns
    except KeyboardInterrupt:
        raise ValueError("Invalid bounding box") from None  # as matplotlib's renderer reports it
    raise AssertionError("the signal did not arrive")

run_plots.save_run_plots = save_run_plots
sys.argv = ["bhr", "follow", "--traj", "curve", "--out", "o"]
from bhr.cli.main import run
run()
'''


@pytest.mark.parametrize("sig, status", [("SIGINT", 130), ("SIGHUP", 129), ("SIGTERM", 143)])
def test_a_signal_a_library_turned_into_its_own_error_still_ends_the_command_as_the_signal(tmp_path, sig, status):
    """A signal's KeyboardInterrupt raised inside a library's callback can come back as that library's error
    (seen: SIGHUP while matplotlib drew, "ValueError: Invalid bounding box" and a traceback): still one line."""
    res = subprocess.run([sys.executable, "-c", LIBRARY_SWALLOWS, sig], cwd=tmp_path, capture_output=True, text=True,
                         timeout=300, env=dict(os.environ, MPLBACKEND="Agg"), preexec_fn=foreground)
    expected = "Interrupted." if sig == "SIGINT" else f"Interrupted by {sig}."
    lines = [ln for ln in res.stderr.splitlines() if not ln.startswith("Compiling bhr's")]
    assert (res.returncode, lines) == (status, [expected]), res.stderr[-1500:]
    assert not (tmp_path / "o").exists()


def test_importing_bhr_leaves_the_signals_alone():
    # a program that imports the library keeps Python's own handling; only the bhr program installs its handler
    code = ("import signal, bhr, bhr.cli.main; "
            "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler, "
            "signal.getsignal(signal.SIGTERM) == signal.SIG_DFL)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       preexec_fn=foreground)
    assert (r.returncode, r.stdout.strip()) == (0, "True True"), r.stderr


def test_the_bhr_command_is_an_entry_point_script():
    # pip's generated script (no launcher of bhr's own): it calls bhr.cli.main:run
    script = Path(bhr_exe()[0]).read_text()
    assert "from bhr.cli.main import run" in script and "env --block-signal" not in script
