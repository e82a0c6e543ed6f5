"""The studies' executor: rows in job order on every path, one warm-up per process, progress, failures."""
from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from bhr._settings.errors import BhrError
from bhr._studies.executor import capture, reason, run_jobs


def square(job: tuple[int, str]) -> dict:
    n, folder = job
    row = {"n": n, "status": "ok", "pid": os.getpid()}
    with capture(row, keep_traceback=True):
        if n == 3:
            raise ValueError("three is bad\nsecond line")
        if n == 5:
            raise BhrError("five is refused; give another number")
        row["square"] = n * n
    return row


def note_warm_up(folder: str, tag: str) -> None:
    """Leaves one file per call, named by process and tag."""
    Path(folder, f"{os.getpid()}-{tag}-{len(os.listdir(folder))}").write_text("")


def die(job: int) -> int:
    if job == 2:
        os._exit(3)  # a worker that vanishes (killed, out of memory)
    return job


def test_rows_come_back_in_job_order_on_both_local_paths(tmp_path):
    jobs = [(n, str(tmp_path)) for n in range(12)]
    seen: list[tuple[int, int, int]] = []
    serial = run_jobs(square, jobs, jobs=1, progress=lambda d, t, r: seen.append((d, t, r["n"])))
    pool = run_jobs(square, jobs, jobs=2, max_chunk=2)
    assert serial.runner == "in-process" and serial.workers == 1
    assert pool.runner == "2 processes" and pool.workers == 2
    assert [r["n"] for r in pool.rows] == list(range(12))
    drop = ("pid", "traceback")
    assert [{k: v for k, v in r.items() if k not in drop} for r in serial.rows] == \
           [{k: v for k, v in r.items() if k not in drop} for r in pool.rows]
    assert [d for d, _, _ in seen] == list(range(1, 13)) and {t for _, t, _ in seen} == {12}
    assert {r["pid"] for r in pool.rows} - {os.getpid()}  # they did run elsewhere
    assert os.getpid() not in {r["pid"] for r in pool.rows}


def test_a_job_that_raises_is_a_failed_row_with_a_one_line_reason():
    rows = run_jobs(square, [(n, "") for n in (2, 3, 5)], jobs=1).rows
    assert rows[0] == {"n": 2, "status": "ok", "pid": os.getpid(), "square": 4}
    assert rows[1]["status"] == "failed: ValueError: three is bad" and "square" not in rows[1]
    assert "Traceback" in rows[1]["traceback"] and "three is bad" in rows[1]["traceback"]
    assert rows[2]["status"] == "failed: five is refused; give another number" and "traceback" not in rows[2]
    assert reason(KeyError()) == "KeyError"


def test_ctrl_c_is_not_captured():
    row: dict = {}
    with pytest.raises(KeyboardInterrupt):
        with capture(row):
            raise KeyboardInterrupt
    assert row == {}


def test_warm_up_runs_once_in_each_process(tmp_path):
    marks = tmp_path / "marks"
    marks.mkdir()
    jobs = [(n, "") for n in range(8)]
    res = run_jobs(square, jobs, jobs=2, max_chunk=1, warm_up=note_warm_up, warm_up_args=(str(marks), "a"))
    pids = {r["pid"] for r in res.rows} | {os.getpid()}  # this process first: what it compiles, the workers load
    warmed = {p.name.split("-")[0] for p in marks.iterdir()}
    assert warmed == {str(p) for p in pids}  # every process that ran a job warmed up first, once
    assert len(list(marks.iterdir())) == len(pids)
    run_jobs(square, jobs, jobs=1, warm_up=note_warm_up, warm_up_args=(str(marks), "b"))
    run_jobs(square, jobs, jobs=1, warm_up=note_warm_up, warm_up_args=(str(marks), "b"))
    assert len([p for p in marks.iterdir() if f"{os.getpid()}-b-" in p.name]) == 1  # once in this process too


def test_a_job_whose_worker_dies_is_a_row_saying_so_and_the_others_run():
    rows = run_jobs(die, list(range(6)), jobs=2, max_chunk=3, lost=lambda job, why: f"lost {job}: {why}").rows
    assert rows == [0, 1, "lost 2: its worker process died (exit status 3)", 3, 4, 5]


def test_without_a_row_for_it_a_worker_that_dies_stops_the_study_with_one_line():
    with pytest.raises(BhrError, match=r"^a worker process died while running a job \(exit status 3\); run again"):
        run_jobs(die, list(range(6)), jobs=2, max_chunk=1)


@pytest.mark.parametrize("kwargs, msg", [
    ({"jobs": 0}, "jobs must be a whole number"), ({"jobs": True}, "jobs must be a whole number"),
    ({"jobs": 2, "scheduler": "tcp://127.0.0.1:1"}, "not both"),
])
def test_bad_executor_settings(kwargs, msg):
    with pytest.raises(BhrError, match=msg):
        run_jobs(square, [(1, "")], **kwargs)


def test_a_signal_taken_by_another_thread_while_a_worker_starts_leaves_it_its_start_up_data(capfd, monkeypatch):
    # A Ctrl-C sent to the process can land on a thread that does not block it; Python then runs the handler in
    # the main thread, which had raised KeyboardInterrupt between a worker's spawn and the write of its start-up
    # data: the worker printed "EOFError: Ran out of input". Ctrl-C raises here as in a foreground job, also when
    # this test run was started with it ignored (a background job, nohup).
    import multiprocessing
    import queue
    import signal
    import threading
    from multiprocessing import util

    asks: queue.Queue = queue.Queue()
    answered: queue.Queue = queue.Queue()

    def other_thread():  # started before the workers, so it does not block the signal
        while asks.get():
            signal.raise_signal(signal.SIGINT)  # delivered to this thread: the handler runs in the main thread
            answered.put(True)

    real = util.spawnv_passfds

    def spawn(*args, **kwargs):
        pid = real(*args, **kwargs)
        if "spawn_main" in str(args):  # a worker, not the resource tracker
            asks.put(True)
            answered.get()
        return pid

    threading.Thread(target=other_thread, daemon=True).start()
    monkeypatch.setattr(util, "spawnv_passfds", spawn)
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            run_jobs(abs, [-1, -2, -3, -4], jobs=2, max_chunk=1)
    finally:
        signal.signal(signal.SIGINT, old)
        asks.put(False)
    deadline = time.monotonic() + 60
    while multiprocessing.active_children() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert multiprocessing.active_children() == []
    err = capfd.readouterr().err
    assert "EOFError" not in err and "Traceback" not in err, err


FRESH_PROCESS = r'''
import signal, sys
from bhr._studies.executor import run_jobs

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

def ignored(job):
    return sorted(signal.Signals(s).name for s in SIGNALS if signal.getsignal(s) is signal.SIG_IGN)

if __name__ == "__main__":  # the workers import this script
    print(run_jobs(ignored, [1, 2, 3], jobs=2, max_chunk=1).rows)
    print(ignored(0), signal.pthread_sigmask(signal.SIG_BLOCK, []))
'''
