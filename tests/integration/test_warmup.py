"""After bhr.warmup, every command starts warm: none of them says it compiles (a fresh numba cache)."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from bhr.bench.commands import background_compiles
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


def _first_command(tmp_path, args: list[str]):
    """``bhr ARGS`` in ``tmp_path`` on an empty cache of its own with the background compile on: the result, the
    cache folder and the background compiles seen within 10 s (still running: the caller stops them)."""
    import time

    cache = str(tmp_path / "cache")
    env = {k: v for k, v in os.environ.items() if k != "BHR_NO_BACKGROUND_COMPILE"}
    env.update(NUMBA_CACHE_DIR=cache, MPLBACKEND="Agg")
    res = subprocess.run(bhr_exe() + args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    names = sorted(p.name for p in Path(cache).rglob("*.nbi"))  # what the command compiled, before the warmup
    deadline = time.monotonic() + 10
    pids = background_compiles(cache)
    while not pids and time.monotonic() < deadline:
        time.sleep(0.1)
        pids = background_compiles(cache)
    return res, cache, names, pids


def _stop(pids: list[int]) -> None:
    import signal

    for pid in pids:  # it would compile every kernel into the test's cache
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:  # it had ended already
            pass


def test_a_first_command_starts_the_background_compile_as_it_ends(tmp_path):
    """The compile of the other commands' kernels starts from the command's exit handlers (bhr.cli.main.run
    runs them before the process ends)."""
    res, _, _, pids = _first_command(tmp_path, ["fk", "--codes", "0,3"])
    _stop(pids)
    assert res.returncode == 0 and NOTICE in res.stderr, res.stderr
    assert pids, "no python -m bhr.warmup started after the first command"


def test_a_first_run_interprets_the_small_loops_and_writes_what_a_warm_run_writes(tmp_path):
    """On an empty cache, with the background compile on, `bhr follow --traj colon` runs the thesis loop and the
    drive model interpreted and scores the clearance in numpy (each cheaper than compiling): it compiles
    nothing, says nothing about compiling, and its files are byte for byte those of a warm run."""
    cold, _, names, pids = _first_command(tmp_path, ["follow", "--traj", "colon", "--no-plots", "--out", "cold"])
    _stop(pids)
    assert cold.returncode == 0 and NOTICE not in cold.stderr, cold.stderr
    assert pids, "no background compile after a first run that interpreted kernels"
    assert names == [], names  # not one kernel compiled
    warm_env = dict(os.environ, MPLBACKEND="Agg", BHR_NO_BACKGROUND_COMPILE="1")  # the session's warm cache
    warm = subprocess.run(bhr_exe() + ["follow", "--traj", "colon", "--no-plots", "--out", "warm"], cwd=tmp_path,
                          env=warm_env, capture_output=True, text=True, timeout=600)
    assert warm.returncode == 0, warm.stderr
    assert cold.stdout.replace("cold", "warm") == warm.stdout
    for name in ("codes.csv", "steps.csv", "run.json"):
        assert (tmp_path / "cold" / name).read_bytes() == (tmp_path / "warm" / name).read_bytes(), name
    assert sorted(p.name for p in (tmp_path / "cold").iterdir()) == sorted(p.name for p in (tmp_path / "warm").iterdir())


def test_the_background_compile_compiles_the_bhr_that_started_it_not_one_in_the_current_folder(tmp_path):
    """numba caches a kernel under its source file's path: a background compile that imported a bhr/ of the
    current folder (a checkout the user installed from and runs bhr in) would never warm this installation."""
    import time

    import bhr

    marker = tmp_path / "the-folder's-bhr-was-imported"
    (tmp_path / "bhr").mkdir()
    (tmp_path / "bhr" / "__init__.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    res, cache, _, pids = _first_command(tmp_path, ["fk", "--codes", "0,3"])
    try:
        assert res.returncode == 0 and NOTICE in res.stderr, res.stderr
        assert pids, "no python -m bhr.warmup started after the first command"
        folder = Path(os.readlink(f"/proc/{pids[0]}/cwd"))
        time.sleep(3)  # long enough to have imported bhr (the folder's would write the marker at once)
        alive = bool(background_compiles(cache))
    finally:
        _stop(pids)
    assert folder == Path(bhr.__file__).resolve().parent.parent
    assert alive and not marker.exists()


def test_a_kernel_in_the_cache_on_disk_is_ready_in_a_new_process(tmp_path):
    from tests.unit.test_first_run import KERNEL

    (tmp_path / "cached_k.py").write_text(KERNEL)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=os.pathsep.join(
        [str(tmp_path)] + [p for p in sys.path if p]))
    code = textwrap.dedent("""
        import sys, numpy as np
        from bhr import _numba
        import cached_k
        print(_numba.is_ready(cached_k.twice))
        cached_k.twice(np.arange(3.0))
    """)
    first = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    second = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert (first.returncode, second.returncode) == (0, 0), first.stderr + second.stderr
    assert (first.stdout.strip(), second.stdout.strip()) == ("False", "True")
    (tmp_path / "cached_k.py").write_text(KERNEL + "\n# edited\n")  # the source changed: the cache is stale
    third = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert third.stdout.strip() == "False", third.stderr


def test_one_background_compile_at_a_time_and_kill_ends_it(tmp_path):
    """Two first commands one after the other each start a background compile: the second sees the first at
    work on the same cache and ends at once. And a plain ``kill`` (SIGTERM) ends it: the command that starts it
    ignores SIGTERM as it ends, which the compile used to inherit."""
    import signal
    import time

    res, cache, _, pids = _first_command(tmp_path, ["fk", "--codes", "0,3"])
    try:
        assert res.returncode == 0 and len(pids) == 1, (res.stderr, pids)
        env = {k: v for k, v in os.environ.items() if k != "BHR_NO_BACKGROUND_COMPILE"}
        env.update(NUMBA_CACHE_DIR=cache, MPLBACKEND="Agg")
        second = subprocess.run(bhr_exe() + ["solve", "--target", "3", "9", "0", "--solver", "ccd"], cwd=tmp_path,
                                env=env, capture_output=True, text=True, timeout=600)
        assert second.returncode == 0 and NOTICE in second.stderr, second.stderr  # it compiled: it starts one too
        deadline = time.monotonic() + 20
        while background_compiles(cache) != pids and time.monotonic() < deadline:
            time.sleep(0.2)  # the second one's start and its end at the lock
        assert background_compiles(cache) == pids
        os.kill(pids[0], signal.SIGTERM)
        deadline = time.monotonic() + 10
        while background_compiles(cache) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not background_compiles(cache), "SIGTERM did not end the background compile"
    finally:
        _stop(background_compiles(cache))
