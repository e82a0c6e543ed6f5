"""Compile every kernel any bhr command runs, once, so that later commands start warm.

numba compiles a kernel on its first call and caches it on disk (``cache=True``,
:mod:`bhr._numba`). One command compiles only what it runs, so each new kind of
command used to compile again. :func:`compile_all` runs tiny cases of every
solver, the forward kinematics, whole-body following, the lumen clearance and
the thermal model: every kernel bhr has, with the argument types the commands
give them (the types are what numba compiles for, not the sizes).

The first command on a machine that had to compile (or ran a cold kernel
interpreted, :func:`bhr._numba.call_cold`) starts this in the background when
it ends (``python -m bhr.warmup``, at low priority, one at a time per cache
folder), so the user waits only for the kernels of that first command. Setting
``BHR_NO_BACKGROUND_COMPILE=1`` turns that off.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

__all__ = ["compile_all", "run_once", "start_in_background", "background_enabled", "BACKGROUND_ENV"]

#: Set to 1 to keep bhr from compiling the remaining kernels in the background after a first run.
BACKGROUND_ENV = "BHR_NO_BACKGROUND_COMPILE"


def compile_all() -> None:
    """Run every kernel once on a tiny case (compiles what the cache lacks; loads the rest)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the tiny cases are tighter than the robot turns: no advice wanted here
        _run_all()


def _run_all() -> None:
    import numpy as np

    import bhr
    from bhr.run.driver import follow as run_follow
    from bhr.model.generators import load_trajectory
    from bhr.output.steptable import format_steps_csv

    def follow(*args, **kw):  # a run as a command finishes it: summary, clearance, run.json, steps.csv
        result = run_follow(*args, **kw)
        result.to_dict()
        format_steps_csv(result)
        return result

    from bhr.hardware.thermal import DEFAULT_THERMAL, auto_schedule, check_schedule

    for solver in ("fabrik", "ccd", "thesis", "constrained", "optimal", "lumen"):
        bhr.solve([3, 9, 0], modules=5, solver=solver, tol_pos=0.01)
    bhr.solve([3, 9, 0], modules=5, solver="thesis", orientation=[0, 1, 0])
    bhr.Robot().fk([3, 0, 6, 0, 15])
    from bhr.model.workspace import workspace  # bhr workspace: every pose, and a Monte Carlo sample

    workspace(bhr.Robot(modules=2))
    workspace(bhr.Robot(modules=2), exact=False, samples=4)
    line = load_trajectory("line", length=40)
    curve = load_trajectory("curve", angle=30, entry=4, exit=4)
    for solver in ("thesis", "constrained", "optimal", "fabrik", "ccd"):
        follow(curve, solver=solver)
    follow(line, solver="thesis", body_modules=8)
    colon = load_trajectory("anatomy", seed=1)  # a lumen: the clearance and the lumen solver's kernels
    short = type(colon)(colon.name, np.ascontiguousarray(colon.points[:60]), colon.params, colon.min_radius,
                        None if colon.lumen is None else np.ascontiguousarray(colon.lumen[:60]), colon.source,
                        start_direction=colon.start_direction, start_point=colon.start_point)
    follow(colon, solver="thesis")  # the whole colon: its arrays exactly as a command gives them
    follow(short, solver="lumen")
    follow(short, solver="thesis", body_modules=8)
    rows = np.array([[3, 0, 6, 0, 0], [0, 12, 0, 9, 15]], dtype=np.int64)
    auto_schedule(DEFAULT_THERMAL, rows, 10.0)
    check_schedule(DEFAULT_THERMAL, rows, 10.0)


def background_enabled() -> bool:
    """Whether a command that had to compile starts the background compile when it ends (BACKGROUND_ENV unset or 0)."""
    return os.environ.get(BACKGROUND_ENV, "") in ("", "0")


def start_in_background() -> bool:
    """Start ``python -m bhr.warmup`` detached and quiet, at low priority; False when turned off or impossible.

    It compiles this very copy of bhr: numba caches a kernel under the path of its source file, so a
    background compile that imported another copy (``python -m`` puts the current folder first on the
    path, and a user running ``bhr`` in a checkout after ``pip install .`` has the checkout's ``bhr/``
    there) would fill the cache for kernels no command of this installation loads. So it starts in
    the folder that holds this ``bhr`` package, that folder first on its ``PYTHONPATH``.
    """
    if not background_enabled():
        return False
    home = str(Path(__file__).resolve().parent.parent)
    path = os.environ.get("PYTHONPATH", "")
    env = {**os.environ, BACKGROUND_ENV: "1", "PYTHONPATH": home + (os.pathsep + path if path else "")}
    try:
        subprocess.Popen([sys.executable, "-m", "bhr.warmup"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, start_new_session=True, close_fds=True, cwd=home,
                         preexec_fn=_background_child, env=env)
    except OSError:
        return False
    return True


def _background_child() -> None:  # pragma: no cover - runs in the child between fork and exec
    """Low priority, and SIGTERM and SIGINT back to their defaults: the command that starts the compile ignores
    them as it ends (bhr.settings.interrupts.settle), and a child would inherit that (``kill PID`` did nothing)."""
    import signal

    if hasattr(os, "nice"):
        os.nice(10)
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, signal.SIG_DFL)


def run_once() -> int:
    """Compile everything unless another background compile of the same cache is under way: exit status 0 or 1.

    Several commands run one after another on a fresh machine each start one; they would compile the same
    kernels side by side. A lock file in numba's cache folder lets the first one work and the others end at once.
    """
    from bhr import _numba

    folder = _numba.cache_dir()
    lock = None
    try:
        import fcntl

        if folder:
            lock = open(Path(folder) / ".bhr-warmup.lock", "a")
            fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        if lock is not None:
            lock.close()
        return 0  # another one is compiling this cache
    except (ImportError, OSError):
        pass  # no lock to be had here: compile anyway
    try:
        compile_all()
    except Exception:  # a background convenience: a failure here only means a later command compiles
        return 1
    finally:
        if lock is not None:
            lock.close()
    return 0


if __name__ == "__main__":  # pragma: no cover - run by start_in_background
    raise SystemExit(run_once())
