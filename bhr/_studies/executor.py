"""Where a study's runs execute: in this process, in ``spawn``-started :mod:`concurrent.futures` workers, or on a
Dask cluster (:mod:`bhr._studies.cluster`). Jobs go in chunks; the rows come back in job order. A job whose worker
dies is the row ``lost(job, reason)`` and the study goes on.
"""
from __future__ import annotations

import contextlib
import errno
import functools
import multiprocessing
import os
import signal
import threading
import time
import traceback
from collections import deque
# imported with this module, not when the workers start: an import in the main thread then could take a signal
# inside importlib's own clean-up, where its KeyboardInterrupt is printed and ignored
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, Callable, Generic, Iterator, Sequence, TypeVar

from bhr._settings.errors import BhrError
from bhr._settings.inputs import reason

__all__ = ["run_jobs", "Executed", "capture", "reason"]

J = TypeVar("J")
R = TypeVar("R")


@contextlib.contextmanager
def capture(row: dict[str, Any], *, keep_traceback: bool = False) -> Iterator[dict[str, Any]]:
    """An exception inside (not Ctrl-C, not a full disk: the study's output failed) becomes ``row["status"] =
    "failed: <reason>"`` (and, with ``keep_traceback``, a non-BhrError's traceback ``row["traceback"]``)."""
    try:
        yield row
    except Exception as exc:
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
            raise
        row["status"] = f"failed: {reason(exc)}"
        if keep_traceback and not isinstance(exc, BhrError):
            row["traceback"] = "".join(traceback.format_exception(exc, limit=8))


@dataclass
class Executed(Generic[R]):
    rows: list[R]
    wall_time_s: float
    runner: str  # "in-process", "N processes" or "dask tcp://..."
    workers: int


_WARMED: set[tuple[Any, ...]] = set()  # the warm-ups this process has run


def _run_chunk(fn: Callable[[Any], Any], warm_up: Callable[..., Any] | None, warm_up_args: tuple[Any, ...],
               chunk: Sequence[tuple[int, Any]]) -> list[tuple[int, Any]]:
    key = (getattr(warm_up, "__module__", ""), getattr(warm_up, "__qualname__", ""), repr(warm_up_args))
    if warm_up is not None and key not in _WARMED:
        warm_up(*warm_up_args)
        _WARMED.add(key)
    return [(i, fn(job)) for i, job in chunk]


def run_jobs(fn: Callable[[J], R], jobs_list: Sequence[J], *, jobs: int | None = None, scheduler: Any = None,
             warm_up: Callable[..., Any] | None = None, warm_up_args: tuple[Any, ...] = (), max_chunk: int = 64,
             progress: Callable[[int, int, R], None] | None = None,
             lost: Callable[[J, str], R] | None = None) -> Executed[R]:
    """Run ``fn(job)`` for every job. ``jobs``: worker processes (default: one per CPU); ``scheduler``: a Dask
    address or ``distributed.Client``; ``warm_up(*warm_up_args)`` runs once per process; ``progress(done, total,
    row)`` per finished job; ``lost(job, reason)``: the row of a job whose worker died."""
    if scheduler is not None and jobs is not None:
        raise BhrError("give either jobs (local processes) or a Dask scheduler, not both")
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise BhrError(f"jobs must be a whole number of processes, 1 or more, got {jobs!r}")
    total, rows = len(jobs_list), [None] * len(jobs_list)
    done = 0

    def finished(pairs: Sequence[tuple[int, Any]]) -> None:
        nonlocal done
        for i, row in pairs:
            rows[i], done = row, done + 1
            if progress is not None:
                progress(done, total, row)

    def died(chunk: list[tuple[int, Any]], why: str, todo: deque) -> None:
        """A chunk whose worker died: its jobs again one by one; a single job's row says so."""
        if len(chunk) > 1:
            todo.extendleft([pair] for pair in reversed(chunk))
        elif lost is None:
            raise BhrError(f"a worker process died while running a job ({why}); run again, with fewer workers "
                           "if memory is short")
        else:
            finished([(chunk[0][0], lost(chunk[0][1], f"its worker process died ({why})"))])

    t0 = time.perf_counter()
    call = functools.partial(_run_chunk, fn, warm_up, warm_up_args)
    workers = max(1, min(jobs or os.cpu_count() or 1, total))
    size = max(1, min(max_chunk, -(-total // (8 * (8 if scheduler is not None else workers)))))
    chunks = deque(list(enumerate(jobs_list))[k:k + size] for k in range(0, total, size))
    if scheduler is not None:
        from bhr._studies.cluster import run_dask, scheduler_client

        own = isinstance(scheduler, str)
        with scheduler_client(scheduler) if own else contextlib.nullcontext(scheduler) as client:
            workers = run_dask(client, call, chunks, finished, died)
            runner = f"dask {client.scheduler.address}"
    elif workers == 1:
        for pair in enumerate(jobs_list):
            finished(call([pair]))
        runner = "in-process"
    else:
        # the warm-up here first: what it compiles is compiled once (and said so in one line), not in every
        # worker, which then loads it from numba's cache
        call([])
        _run_local(workers, call, chunks, finished, died)
        runner = f"{workers} processes"
    return Executed(rows, time.perf_counter() - t0, runner, workers)  # type: ignore[arg-type]


def _worker_start() -> None:
    """In each worker: Ctrl-C, SIGTERM and SIGHUP are the parent's to answer (it kills its workers), and the worker
    ends when its parent does (``kill -9`` too)."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_IGN)
    parent = multiprocessing.parent_process()

    def end_with_parent() -> None:
        if parent is not None:
            parent.join()
            os._exit(1)

    threading.Thread(target=end_with_parent, daemon=True).start()


class _Lane:
    """One worker in a one-process executor, so that a worker that dies names the chunk it ran."""

    #: How long a stopped lane waits for its pool's threads to end (a thread blocked on a killed worker's pipe
    #: would never end: the command ends without it).
    THREAD_WAIT_S = 10.0

    def __init__(self) -> None:
        self.pool: Any = None
        self.process: Any = None
        self.threads: set[threading.Thread] = set()

    def submit(self, call: Callable[[Any], Any], chunk: Any) -> Any:
        if self.pool is not None:
            return self.pool.submit(call, chunk)
        started: list[Any] = []
        failed: list[BaseException] = []
        done = threading.Event()

        def start() -> None:
            # Ctrl-C, SIGTERM and SIGHUP blocked in this thread, which starts the worker, and so in the worker, the
            # pool's threads and multiprocessing's resource tracker (it ignores SIGINT and SIGTERM itself), which
            # inherit the mask: the tracker outlives a closed terminal's SIGHUP to the whole group and ends when
            # bhr does; the workers ignore all three.
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGHUP, signal.SIGINT, signal.SIGTERM})
            before, threads = set(multiprocessing.active_children()), set(threading.enumerate())
            try:
                pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                                           initializer=_worker_start)
                future = pool.submit(call, chunk)  # starts the worker and the pool's threads
                started.append((pool, future, next(iter(set(multiprocessing.active_children()) - before), None),
                                set(threading.enumerate()) - threads))
            except BaseException as exc:
                failed.append(exc)
            finally:
                done.set()

        # A signal is answered in the main thread, here, while the start goes on in its own thread to its end: the
        # worker gets what it needs to start (cut off half way it would print a traceback, reading it from a
        # closed pipe) and is known, to be stopped with the others. (Cut off before its thread began, within
        # Thread.start, there is nothing to wait for.)
        try:
            threading.Thread(target=start, name="bhr-worker-start").start()
            done.wait()
        finally:
            done.wait(self.THREAD_WAIT_S)
            if started:
                self.pool, future, self.process, self.threads = started[0]
        if failed:
            raise failed[0]
        return future

    def stop(self, kill: bool) -> str:
        """Stop the worker (``kill``: at once); how it ended. The pool's threads end here, within
        :attr:`THREAD_WAIT_S` when killed: a thread still ending as bhr ends leaks the pool's semaphores."""
        code = None
        if self.process is not None and kill:
            self.process.kill()
        if self.pool is not None:
            self.pool.shutdown(wait=not kill, cancel_futures=True)
        if kill:
            deadline = time.monotonic() + self.THREAD_WAIT_S
            for t in self.threads:
                while True:
                    try:
                        t.join(max(0.0, deadline - time.monotonic()))
                        break
                    except RuntimeError:  # one of the pool's threads, starting as the worker was stopped: not yet
                        if time.monotonic() >= deadline:  # started, it is joined once it is
                            break
                        time.sleep(0.01)
        if self.process is not None and kill:
            self.process.join(5)
            code = self.process.exitcode
        self.pool = self.process = None
        self.threads = set()
        return f"killed by {signal.Signals(-code).name}" if code and code < 0 else f"exit status {code}"


def _run_local(workers: int, call: Callable[[Any], Any], todo: deque, finished: Callable[..., None],
               died: Callable[..., None]) -> None:
    lanes = [_Lane() for _ in range(workers)]
    idle, sent = list(lanes), {}  # type: ignore[var-annotated]
    ended = False
    try:
        while todo or sent:
            while todo and idle:
                lane, chunk = idle.pop(), todo.popleft()
                sent[lane.submit(call, chunk)] = (lane, chunk)
            for future in wait(sent, return_when=FIRST_COMPLETED).done:
                lane, chunk = sent.pop(future)
                idle.append(lane)
                try:
                    finished(future.result())
                except BrokenProcessPool:  # its worker died running this chunk
                    died(chunk, lane.stop(kill=True), todo)
        ended = True
    finally:  # Ctrl-C, a failure (even one at the start of a chunk not yet counted as sent): no worker goes on
        for lane in lanes:
            lane.stop(kill=not ended)
