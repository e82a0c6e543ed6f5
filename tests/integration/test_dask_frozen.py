"""A Dask scheduler that stops answering without going away (SIGSTOP: a frozen machine, a suspended process):
its connections stay open, so only a deadline ends the wait. One line within a bounded wait, no folder."""
from __future__ import annotations

import os
import signal
import time

from bhr._studies.cluster import DASK_WAIT_S
from tests.integration.test_dask_faults import _dask, _one_line, _run_then, _stop, scheduler  # noqa: F401


def _stopped_mid_run(tmp_path, address, which):
    """A sweep on the cluster, then SIGSTOP to ``which(scheduler, worker)``'s process group: its exit status, its
    stderr and how long it waited after the stop."""
    worker = _dask("worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard", log=tmp_path / "w.log")
    try:
        time.sleep(6)
        t = []
        rc, err = _run_then(tmp_path, address, lambda: (t.append(time.monotonic()),
                                                        os.killpg(which(worker).pid, signal.SIGSTOP)))
        return rc, err, time.monotonic() - t[0]
    finally:
        _stop(worker)


def test_a_stopped_scheduler_mid_run_gives_one_line(tmp_path, scheduler):  # noqa: F811
    # the sweep asked a stopped scheduler for its workers and waited for ever (scheduler_info has no deadline)
    sched, address = scheduler
    rc, err, waited = _stopped_mid_run(tmp_path, address, lambda worker: sched)
    line = _one_line(rc, err)
    assert f"lost the Dask scheduler at {address} (no answer for {DASK_WAIT_S:g} s)" in line, line
    assert waited < DASK_WAIT_S + 30 and not (tmp_path / "o").exists()
