"""A Dask cluster that cannot run the study: one line within a bounded wait, never a hang or a traceback.

Real Dask: a scheduler and workers started as the `dask` command starts them, then taken away.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bhr._studies.cluster import DASK_WAIT_S
from tests.conftest import bhr_exe

ENV = dict(os.environ, MPLBACKEND="Agg", PYTHONFAULTHANDLER="1")
SWEEP = ["sweep", "--traj", "colon", "--grid", "modules=3:12", "--grid", "alpha=8:12", "--no-plots"]
#: Long enough (500 designs, over a minute on one worker even with warm kernels) to be still running when its
#: worker or scheduler is taken away, on a fast machine too.
LONG_SWEEP = SWEEP + ["--grid", "module_length=6:15"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args: str, log: Path) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "dask", *args]  # the `dask` command of this environment
    return subprocess.Popen(cmd, stdout=log.open("w"), stderr=subprocess.STDOUT, start_new_session=True)


def _stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        with __import__("contextlib").suppress(ProcessLookupError):
            os.killpg(p.pid, signal.SIGKILL)
    p.wait(timeout=30)


def _wait_for_port(port: int, timeout: float = 60) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise AssertionError(f"no Dask scheduler on port {port}")


@pytest.fixture
def scheduler(tmp_path):
    port = _free_port()
    p = _dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard", log=tmp_path / "s.log")
    try:
        _wait_for_port(port)
        yield p, f"tcp://127.0.0.1:{port}"
    finally:
        _stop(p)


def _one_line(r_code: int, err: str) -> str:
    lines = [ln for ln in err.strip().splitlines() if ln.strip() and not ln.startswith("Compiling bhr's")]
    assert r_code == 1 and len(lines) == 1 and "Traceback" not in err, (r_code, err)
    return lines[0]


def test_a_cluster_without_workers_gives_one_line(tmp_path, scheduler):
    _, address = scheduler
    t0 = time.monotonic()
    r = subprocess.run(bhr_exe() + [*SWEEP, "--scheduler", address, "--out", "o"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=DASK_WAIT_S + 90, env=ENV)
    line = _one_line(r.returncode, r.stderr)
    assert "has no workers" in line and f"dask worker {address}" in line
    assert time.monotonic() - t0 < DASK_WAIT_S + 60 and not (tmp_path / "o").exists()


def _run_then(tmp_path, address, take_away) -> tuple[int, str]:
    p = subprocess.Popen(bhr_exe() + [*LONG_SWEEP, "--scheduler", address, "--out", "o"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    time.sleep(12)  # connected and running
    assert p.poll() is None, p.communicate()
    take_away()
    try:
        out, err = p.communicate(timeout=DASK_WAIT_S + 90)
    except subprocess.TimeoutExpired:
        p.send_signal(signal.SIGABRT)  # PYTHONFAULTHANDLER: where it hangs
        out, err = p.communicate(timeout=30)
        raise AssertionError(f"no answer within {DASK_WAIT_S + 90:g} s:\n{err[-4000:]}") from None
    return p.returncode, err


def test_every_worker_lost_gives_one_line(tmp_path, scheduler):
    _, address = scheduler
    worker = _dask("worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                   log=tmp_path / "w.log")
    try:
        time.sleep(6)
        rc, err = _run_then(tmp_path, address, lambda: _stop(worker))
    finally:
        _stop(worker)
    assert "every worker of the Dask scheduler" in _one_line(rc, err)
    assert not (tmp_path / "o").exists()


def test_a_killed_scheduler_gives_one_line_that_blames_the_scheduler(tmp_path, scheduler):
    sched, address = scheduler
    worker = _dask("worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                   log=tmp_path / "w.log")
    try:
        time.sleep(6)
        rc, err = _run_then(tmp_path, address, lambda: _stop(sched))
    finally:
        _stop(worker)
    line = _one_line(rc, err)
    assert "lost the Dask scheduler" in line and "installed" not in line
    assert not (tmp_path / "o").exists()
