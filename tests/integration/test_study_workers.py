"""Studies on local worker processes that die: a run whose worker is killed (as the out-of-memory killer kills it) is a
row saying so and the study goes on; a study's workers end with it, however it ends (bhr._studies.executor)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from bhr._studies.executor import run_jobs
from bhr._studies.sweep import build_sweep, run_sweep
from tests.conftest import start_bhr, wait_for_stderr


def kill_my_worker(job: int) -> int:
    if job == 2:
        os.kill(os.getpid(), signal.SIGKILL)  # as the out-of-memory killer does
    return job


def test_a_run_whose_worker_is_killed_is_a_row_and_the_others_run():
    rows = run_jobs(kill_my_worker, list(range(8)), jobs=2, max_chunk=4, lost=lambda job, why: f"{job}: {why}").rows
    assert rows == [0, 1, "2: its worker process died (killed by SIGKILL)", 3, 4, 5, 6, 7]


def test_a_sweep_design_whose_worker_dies_is_a_failed_row():
    from bhr._studies.sweep import runs

    s = build_sweep(["line"], ["seed"], [("modules", (3, 4, 5))])
    rows = run_sweep(s, jobs=1).rows
    lost = runs._lost_design((s.designs()[1], "line", None), "its worker process died (killed by SIGKILL)")
    assert set(lost) == set(rows[1]) - {"design"}
    assert lost["status"] == "failed: its worker process died (killed by SIGKILL)" and lost["modules"] == 4


def _alive(pid: int) -> bool:
    stat = Path(f"/proc/{pid}/stat")
    try:
        return not stat.read_text().rsplit(")", 1)[-1].split()[0] == "Z"
    except OSError:
        return False


SLEEPY = r'''
import os, sys, time
sys.path.insert(0, sys.argv[1])
from bhr._studies.executor import run_jobs

def nap(job):
    print(os.getpid(), flush=True)  # the worker is running
    time.sleep(600)

if __name__ == "__main__":  # the workers import this script
    run_jobs(nap, [1, 2], jobs=2, max_chunk=1)
'''


def test_workers_end_when_their_parent_is_killed(tmp_path):
    script = tmp_path / "sleepy.py"
    script.write_text(SLEEPY)
    p = subprocess.Popen([sys.executable, str(script), str(tmp_path)], stdout=subprocess.PIPE, text=True)
    workers = {int(p.stdout.readline()), int(p.stdout.readline())}  # both workers are running a job
    p.kill()  # kill -9: nothing of the parent runs
    p.wait()
    deadline = time.monotonic() + 60
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(w) for w in workers)


def test_a_killed_study_command_leaves_no_worker(tmp_path):
    # the command itself, killed while its workers run
    p = start_bhr(["sweep", "--traj", "colon", "--grid", "modules=3:10", "--jobs", "2"], tmp_path)
    wait_for_stderr(p, ": 1/8")  # the workers are running
    kids = [int(x) for x in subprocess.run(["ps", "-o", "pid=", "--ppid", str(p.pid)], capture_output=True,
                                           text=True).stdout.split()]
    p.kill()
    p.wait()
    deadline = time.monotonic() + 60
    while any(_alive(k) for k in kids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert kids and not any(_alive(k) for k in kids)
