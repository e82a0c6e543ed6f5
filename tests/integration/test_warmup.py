"""After bhr.warmup, every command starts warm: none of them says it compiles (a fresh numba cache)."""
from __future__ import annotations

import os
import subprocess
import sys

from tests.conftest import bhr_exe

NOTICE = "Compiling bhr's kernels"


def test_background_compile_is_off_when_asked(monkeypatch):
    from bhr.warmup import BACKGROUND_ENV, start_in_background

    monkeypatch.setenv(BACKGROUND_ENV, "1")
    assert start_in_background() is False


def test_after_the_warmup_no_command_compiles(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), MPLBACKEND="Agg", BHR_NO_BACKGROUND_COMPILE="1")
    subprocess.run([sys.executable, "-m", "bhr.warmup"], cwd=tmp_path, env=env, check=True, timeout=1800,
                   capture_output=True)
    commands = [
        ["solve", "--target", "3", "9", "0", "--solver", "ccd"],
        ["solve", "--target", "3", "9", "0", "--solver", "fabrik"],
        ["solve", "--target", "3", "9", "0", "--solver", "thesis"],
        ["solve", "--target", "3", "9", "0", "--solver", "lumen"],
        ["fk", "--codes", "3,0,6,0,0"],
        ["compare", "--traj", "curve", "--solver", "thesis", "--solver", "optimal", "--no-plots"],
        ["follow", "--traj", "anatomy", "--seed", "3", "--no-plots", "--out", "a"],
        ["follow", "--traj", "colon", "--solver", "lumen", "--no-plots", "--out", "l"],
        ["follow", "--traj", "colon", "--no-plots", "--out", "c"],
    ]
    for args in commands:
        res = subprocess.run(bhr_exe() + args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
        assert res.returncode == 0, (args, res.stderr)
        assert NOTICE not in res.stderr, args


def _warmups_for(cache: str) -> list[int]:
    from pathlib import Path

    found = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            cmdline = (proc / "cmdline").read_bytes().split(b"\0")
            environ = (proc / "environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"bhr.warmup" in cmdline and f"NUMBA_CACHE_DIR={cache}".encode() in environ:
            found.append(int(proc.name))
    return found


def test_a_first_command_starts_the_background_compile_as_it_ends(tmp_path):
    """The compile of the other commands' kernels starts from the command's exit handlers (bhr.cli.main.run
    runs them before the process ends)."""
    import signal
    import time

    cache = str(tmp_path / "cache")
    env = {k: v for k, v in os.environ.items() if k != "BHR_NO_BACKGROUND_COMPILE"}
    env.update(NUMBA_CACHE_DIR=cache, MPLBACKEND="Agg")
    res = subprocess.run(bhr_exe() + ["fk", "--codes", "0,3"], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0 and NOTICE in res.stderr, res.stderr
    deadline = time.monotonic() + 10
    pids = _warmups_for(cache)
    while not pids and time.monotonic() < deadline:
        time.sleep(0.1)
        pids = _warmups_for(cache)
    for pid in pids:  # seen: stop it (it would compile every kernel into this test's cache)
        os.kill(pid, signal.SIGKILL)
    assert pids, "no python -m bhr.warmup started after the first command"
