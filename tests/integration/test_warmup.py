"""The first command compiles what it runs and says so once; after `bhr warmup` no command compiles."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from tests.conftest import bhr_exe

NOTICE = "Compiling bhr's kernels for this machine (once;"


def test_after_the_warmup_no_command_compiles(tmp_path):
    """From an empty cache; or, under tests/run, from a copy of the cache its ``bhr warmup`` filled before any
    test ran (``BHR_WARMUP_CACHE``), which spares compiling everything a second time."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), MPLBACKEND="Agg")
    warmed = os.environ.get("BHR_WARMUP_CACHE")
    if warmed:
        assert list(Path(warmed).rglob("*.nbi")), f"BHR_WARMUP_CACHE={warmed} holds no compiled kernel"
        shutil.copytree(warmed, tmp_path / "cache")
    else:
        warm = subprocess.run(bhr_exe() + ["warmup"], cwd=tmp_path, env=env, check=True, timeout=1800,
                              capture_output=True, text=True)
        assert warm.stderr.count(NOTICE) == 1 and str(tmp_path / "cache") in warm.stdout
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
        ["follow", "--traj", "line", "--body-modules", "8", "--no-plots", "--out", "b"],
        # the whole robot: moved by its wires, stopped where it leaves the lumen, the trail model, the replay
        ["follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen", "--body-modules", "12", "--no-plots",
         "--out", "w"],
        ["follow", "--traj", "anatomy", "--seed", "1", "--solver", "lumen", "--body-modules", "30", "--stop-at-wall",
         "--no-plots", "--out", "s"],
        ["follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen", "--body-modules", "12", "--locomotion",
         "trail", "--no-plots", "--out", "t"],
        ["physics", "w/run.json", "--out", "p"],
        ["traverse", "--grid", "alpha=25", "--colons", "2", "--jobs", "1", "--no-plots", "--out", "v"],
        ["follow", "--traj", "gca:E60", "--solver", "lumen", "--body-modules", "12", "--no-plots", "--out", "e"],
    ]
    for args in commands:
        res = subprocess.run(bhr_exe() + args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
        assert res.returncode == 0, (args, res.stderr)
        assert NOTICE not in res.stderr, args
    again = subprocess.run(bhr_exe() + ["warmup"], cwd=tmp_path, env=env, check=True, capture_output=True, text=True)
    assert NOTICE not in again.stderr


def test_a_home_bhr_cannot_write_runs_twice(tmp_path):
    """No writable home: numba's cache goes to the temporary folder, and a second run uses it."""
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    env.update(HOME="/proc/nohome", TMPDIR=str(tmp_path / "tmp"), MPLBACKEND="Agg")
    os.mkdir(tmp_path / "tmp")
    runs = [subprocess.run(bhr_exe() + ["follow", "--traj", "line", "--no-plots", "--out", out], cwd=tmp_path,
                           env=env, capture_output=True, text=True, timeout=900) for out in ("a", "b")]
    assert [r.returncode for r in runs] == [0, 0], runs[1].stderr
    assert NOTICE in runs[0].stderr and NOTICE not in runs[1].stderr
    assert list((tmp_path / "tmp" / f"bhr-numba-{os.getuid()}").rglob("*.nbi"))  # numba's index files
