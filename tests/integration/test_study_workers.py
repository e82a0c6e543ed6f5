"""Studies on local worker processes that hang or lose a helper (bhr.studies.executor): a worker stopped with
SIGSTOP, workers that use no CPU, a Ctrl-Z of the whole command, multiprocessing's resource tracker killed.
Each case runs in its own Python process: a study that waited for ever would otherwise hang the suite."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bhr.settings.errors import BhrError
from bhr.studies.executor import capture

def square(job: tuple[int, str]) -> dict:
    n, _ = job
    row = {"n": n, "status": "ok"}
    with capture(row):
        if n == 3:
            raise ValueError("three is bad")
        if n == 5:
            raise BhrError("five is refused")
        row["square"] = n * n
    return row


def stop_myself(job: int) -> int:
    import signal

    if job == 1:
        os.kill(os.getpid(), signal.SIGSTOP)  # as `kill -STOP <worker>` does
    return job


def hang(job: int) -> int:
    if job == 1:
        time.sleep(3600)  # a read that never returns, a deadlock: no CPU used
    return job


def _gone(pids: set[int], wait: float = 10.0) -> bool:
    from bhr.studies.executor import _proc_state

    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        if all(_proc_state(p) in (None,) or _proc_state(p)[0] == "Z" for p in pids):
            return True
        time.sleep(0.1)
    return False


def _workers_of(pid: int) -> set[int]:
    kids = set()
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[-1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                kids.add(int(d.name))
    return kids


WATCHED = r'''
import os, sys, time
sys.path.insert(0, sys.argv[1])
import test_study_workers
from bhr.settings.errors import BhrError
from bhr.studies import executor

if __name__ == "__main__":  # the workers import this script
    setattr(executor, sys.argv[3], float(sys.argv[4]))
    t0 = time.monotonic()
    try:
        executor.run_jobs(getattr(test_study_workers, sys.argv[2]), list(range(4)), jobs=2, max_chunk=1)
    except BhrError as exc:
        print(f"{time.monotonic() - t0:.1f}")
        print(exc)
        print(" ".join(str(p) for p in test_study_workers._workers_of(os.getpid())))
'''


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="the watchdog reads /proc (Linux)")
@pytest.mark.parametrize("job, setting, message", [
    ("stop_myself", "STOPPED_WAIT_S", r"worker process \d+ has been stopped for \d+ s \(SIGSTOP, or a debugger holds it\)"
                                      r", so the study stopped; run it again and let its workers run"),
    ("hang", "IDLE_WAIT_S", r"no worker process has done any work for \d+ s \(they hang\); the study stopped: run "
                            r"again, with --jobs 1 to run in this process"),
])
def test_workers_that_stop_or_hang_end_the_study_with_one_line_in_bounded_time(tmp_path, job, setting, message):
    """A worker stopped with SIGSTOP (or held by a debugger), or workers that hang without using any CPU: the
    study ends with one line in a bounded time, and no worker is left behind (the stopped one included)."""
    import re

    script = tmp_path / "watched.py"
    script.write_text(WATCHED)
    r = subprocess.run([sys.executable, str(script), str(Path(__file__).parent), job, setting, "2"],
                       capture_output=True, text=True, timeout=90)  # without the watchdog: waits for ever
    took, line, left = (r.stdout.split("\n") + ["", "", ""])[:3]
    assert r.returncode == 0 and re.fullmatch(message, line), (r.stdout, r.stderr)
    assert float(took) < 30
    assert _gone({int(p) for p in left.split()}), left  # killed with the pool, though stopped


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="the watchdog reads /proc (Linux)")
def test_the_watchdog_forgives_the_time_the_whole_command_was_stopped():
    """Ctrl-Z of the whole command stops the parent with its workers; after fg the stillness is not theirs."""
    from types import SimpleNamespace

    from bhr.studies.executor import IDLE_WAIT_S, STOPPED_WAIT_S, _Watchdog

    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        now = [0.0]
        pool = SimpleNamespace(_processes={0: SimpleNamespace(pid=sleeper.pid)})
        dog = _Watchdog(pool, clock=lambda: now[0])
        time.sleep(0.5)  # its start-up's CPU is counted before the watch starts
        dog.check()
        now[0] = 10 * (IDLE_WAIT_S + STOPPED_WAIT_S)  # this process was stopped all that time
        dog.check()  # no error: the gap is forgiven
        for k in range(1, int(IDLE_WAIT_S) + 2):  # then the worker stays still while the parent runs
            now[0] += 1.0
            if k >= IDLE_WAIT_S:
                with pytest.raises(BhrError, match="no worker process has done any work"):
                    dog.check()
            else:
                dog.check()
    finally:
        sleeper.kill()
        sleeper.wait()


TRACKER_KILLED = r'''
import os, signal, sys, time
from multiprocessing import resource_tracker
sys.path.insert(0, sys.argv[1])
from test_study_workers import square
from bhr.studies.executor import run_jobs

if __name__ == '__main__':  # the workers import this script
    rows = run_jobs(square, [(n, "") for n in range(6)], jobs=2).rows   # starts the tracker
    os.kill(resource_tracker._resource_tracker._pid, signal.SIGKILL)   # as kill -9 of it mid-study does
    time.sleep(0.3)
    rows += run_jobs(square, [(n, "") for n in range(6)], jobs=2).rows
    print(sum(r.get("square", 0) for r in rows))
'''


def test_a_killed_resource_tracker_leaves_no_traceback_and_the_study_goes_on(tmp_path):

    script = tmp_path / "tracker.py"
    script.write_text(TRACKER_KILLED)
    r = subprocess.run([sys.executable, str(script), str(Path(__file__).parent)], capture_output=True, text=True,
                       timeout=120)
    assert (r.returncode, r.stdout.strip(), r.stderr) == (0, str(2 * (0 + 1 + 4 + 16)), ""), r.stderr


TRACKER_STDERR = r'''
import os, sys
from multiprocessing import resource_tracker
sys.path.insert(0, sys.argv[1])
from test_study_workers import square
from bhr.studies.executor import run_jobs

if __name__ == '__main__':  # the workers import this script
    run_jobs(square, [(n, "") for n in range(4)], jobs=2)
    print(os.readlink(f"/proc/{resource_tracker._resource_tracker._pid}/fd/2"))
    print("still mine", file=sys.stderr)
'''


@pytest.mark.skipif(not Path("/proc/self/fd").exists(), reason="reads /proc")
def test_the_resource_tracker_speaks_to_no_terminal(tmp_path):
    """A Ctrl-C while the pool starts leaves the tracker to delete the pool's semaphores, and it printed "leaked
    semaphore objects" warnings after "Interrupted.": it starts with standard error on /dev/null, the command's
    own standard error is back as it was."""
    script = tmp_path / "tracker_stderr.py"
    script.write_text(TRACKER_STDERR)
    r = subprocess.run([sys.executable, str(script), str(Path(__file__).parent)], capture_output=True, text=True,
                       timeout=120)
    assert (r.returncode, r.stdout.strip(), r.stderr) == (0, os.devnull, "still mine\n"), r.stderr
