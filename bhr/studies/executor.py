"""Where a study's runs execute: in this process, in local worker processes, or on a Dask cluster.

A study is a list of picklable jobs and a function that turns a job into its row (a failure recorded in it with
:class:`capture`). :func:`run_jobs` runs them in this process, in ``spawn``-started :mod:`concurrent.futures`
workers, or on Dask (:mod:`bhr.studies.cluster`), in chunks, and returns the rows in job order. A job whose worker
dies is the row ``lost(job, reason)``. Local workers start with Ctrl-C, SIGTERM and SIGHUP blocked and end with
this process.
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
from dataclasses import dataclass
from typing import Any, Callable, Generic, Iterator, Sequence, TypeVar

from bhr.settings.errors import BhrError
from bhr.settings.inputs import reason

__all__ = ["run_jobs", "Executed", "capture", "reason"]

J = TypeVar("J")
R = TypeVar("R")
#: A write that failed for want of room: the study's output failed, not one run, and the next run's would too.
_OUTPUT_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


@contextlib.contextmanager
def capture(row: dict[str, Any], *, keep_traceback: bool = False) -> Iterator[dict[str, Any]]:
    """``with capture(row):`` -- an exception inside (not Ctrl-C, not a full disk) becomes ``row["status"] =
    "failed: <reason>"`` (and, with ``keep_traceback``, a non-BhrError's traceback ``row["traceback"]``)."""
    try:
        yield row
    except Exception as exc:
        if isinstance(exc, OSError) and exc.errno in _OUTPUT_FULL:
            raise
        row["status"] = f"failed: {reason(exc)}"
        if keep_traceback and not isinstance(exc, BhrError):
            row["traceback"] = "".join(traceback.format_exception(exc, limit=8))


@dataclass
class Executed(Generic[R]):
    """What :func:`run_jobs` did: the rows in job order, the time, and what ran them."""

    rows: list[R]
    wall_time_s: float
    runner: str  # "in-process", "N processes" or "dask tcp://..."
    workers: int


_WARMED: set[tuple[str, str, tuple[Any, ...]]] = set()  # the warm-ups this process has run


def _run_chunk(fn: Callable[[Any], Any], warm_up: Callable[..., Any] | None, warm_up_args: tuple[Any, ...],
               chunk: Sequence[tuple[int, Any]]) -> list[tuple[int, Any]]:
    key = (getattr(warm_up, "__module__", ""), getattr(warm_up, "__qualname__", ""), warm_up_args)
    if warm_up is not None and key not in _WARMED:
        warm_up(*warm_up_args)
        _WARMED.add(key)
    return [(i, fn(job)) for i, job in chunk]


def run_jobs(fn: Callable[[J], R], jobs_list: Sequence[J], *, jobs: int | None = None, scheduler: Any = None,
             warm_up: Callable[..., Any] | None = None, warm_up_args: tuple[Any, ...] = (), max_chunk: int = 64,
             progress: Callable[[int, int, R], None] | None = None,
             lost: Callable[[J, str], R] | None = None) -> Executed[R]:
    """Run ``fn(job)`` for every job; return the rows in job order. ``jobs``: worker processes (default: one per
    CPU, at most one per job); ``scheduler``: a Dask address or ``distributed.Client``; ``warm_up(*warm_up_args)``
    runs once per process; ``progress(done, total, row)`` per finished job; ``lost(job, reason)``: a dead worker's
    row."""
    if scheduler is not None and jobs is not None:
        raise BhrError("give either jobs (local processes) or a Dask scheduler, not both")
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise BhrError(f"jobs must be a whole number of processes, 1 or more, got {jobs!r}")
    total, done = len(jobs_list), 0
    rows: list[Any] = [None] * total

    def finished(pairs: Sequence[tuple[int, Any]]) -> None:
        nonlocal done
        for i, row in pairs:
            rows[i] = row
            done += 1
            if progress is not None:
                progress(done, total, row)

    def died(chunk: list[tuple[int, Any]], why: str, todo: deque) -> None:
        """A chunk whose worker died: its jobs again one by one, or the one job's row says so."""
        if len(chunk) > 1:
            todo.extendleft([pair] for pair in reversed(chunk))
        elif lost is None:
            raise BhrError(f"a worker process died while running a job ({why}); run again, with fewer workers "
                           "if memory is short")
        else:
            finished([(chunk[0][0], lost(chunk[0][1], f"its worker process died ({why})"))])

    t0 = time.perf_counter()
    call = functools.partial(_run_chunk, fn, warm_up, warm_up_args)  # what a worker is sent with each chunk
    workers = max(1, min(jobs or os.cpu_count() or 1, total))
    size = max(1, min(max_chunk, -(-total // (8 * (8 if scheduler is not None else workers)))))
    chunks = deque(list(enumerate(jobs_list))[k:k + size] for k in range(0, total, size))
    if scheduler is not None:
        from bhr.studies.cluster import run_dask, scheduler_client

        own = isinstance(scheduler, str)
        with scheduler_client(scheduler) if own else contextlib.nullcontext(scheduler) as client:
            workers = run_dask(client, call, chunks, finished, died)
            runner = f"dask {scheduler if own else client.scheduler.address}"
    elif workers == 1:
        for pair in enumerate(jobs_list):
            finished(call([pair]))
        runner = "in-process"
    else:
        _run_local(workers, call, chunks, finished, died)
        runner = f"{workers} processes"
    return Executed(rows, time.perf_counter() - t0, runner, workers)


# ------------------------------------------------------------------------------------------ local processes


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP blocked while a worker starts (it inherits them blocked); one that comes
    meanwhile is raised again at the end."""
    noted: list[int] = []
    main = threading.current_thread() is threading.main_thread()
    handlers = {s: signal.signal(s, lambda n, _f: noted.append(n)) for s in _SIGNALS
                if main and callable(signal.getsignal(s))}
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
        if noted:
            signal.raise_signal(noted[0])


def _end_with_parent() -> None:
    """A worker ends when its parent does (``kill -9`` too)."""
    parent = multiprocessing.parent_process()

    def watch() -> None:
        if parent is not None:
            parent.join()
            os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


class _Lane:
    """One local worker: a one-process executor, and the chunk it runs."""

    def __init__(self) -> None:
        self.pool: Any = None
        self.process: Any = None
        self.sent: tuple[Any, list[Any]] | None = None  # (future, chunk)

    def feed(self, todo: deque, call: Callable[[Any], Any]) -> None:
        """Send the next chunk once the worker has none: a worker that dies was running the chunk it was sent."""
        from concurrent.futures import ProcessPoolExecutor

        if self.sent is not None or not todo:
            return
        with _signals_held():
            if self.pool is None:
                self.pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                                                initializer=_end_with_parent)
            # blocked again: the pool's first lock starts multiprocessing's resource tracker, which unblocks Ctrl-C
            # and SIGTERM in this thread once it has started it, and the worker starts just below
            signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
            before = set(multiprocessing.active_children())
            chunk = todo.popleft()
            self.sent = (self.pool.submit(call, chunk), chunk)
            self.process = self.process or next(iter(set(multiprocessing.active_children()) - before), None)

    def stop(self, kill: bool) -> None:
        if kill and self.process is not None:
            self.process.kill()
        if self.pool is not None:
            self.pool.shutdown(wait=not kill, cancel_futures=True)
        self.pool = self.process = None


def _run_local(workers: int, call: Callable[[Any], Any], todo: deque, finished: Callable[..., None],
               died: Callable[..., None]) -> None:
    """Run the chunks on ``workers`` local worker processes; a worker that dies is replaced."""
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool

    lanes = [_Lane() for _ in range(workers)]
    try:
        for lane in lanes:
            lane.feed(todo, call)
        while any(lane.sent for lane in lanes):
            wait([lane.sent[0] for lane in lanes if lane.sent], return_when=FIRST_COMPLETED)
            for lane in lanes:
                if lane.sent is not None and lane.sent[0].done():
                    (future, chunk), lane.sent = lane.sent, None
                    try:
                        finished(future.result())
                    except BrokenProcessPool:  # its worker died running this chunk
                        if lane.process is not None:
                            lane.process.join(5)
                        code = getattr(lane.process, "exitcode", None)
                        lane.stop(kill=True)
                        died(chunk, f"killed by {signal.Signals(-code).name}" if code and code < 0 else
                             f"exit status {code}", todo)
                lane.feed(todo, call)
    except BaseException:  # Ctrl-C, a failure: no worker goes on working
        for lane in lanes:
            lane.stop(kill=True)
        raise
    for lane in lanes:
        lane.stop(kill=False)
