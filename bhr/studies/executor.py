"""Where a study's runs execute: in this process, in local worker processes, or on a Dask cluster.

Every study (batch reports, sweeps, traversability studies) is a list of
independent, picklable jobs and one function that runs a job and returns its
row. :func:`run_jobs` runs them

- in this process (``jobs=1``),
- in ``jobs`` local worker processes (started with ``spawn``, safe next to
  threads such as a Dask client or a GUI), or
- on an existing Dask distributed cluster (``scheduler``: its address or a
  ``distributed.Client``),

and returns the rows in job order whatever ran them. Jobs travel in chunks
(at most ``max_chunk`` jobs each) so that many short jobs cost few round
trips. The same conventions hold on every path:

- **warm-up**: ``warm_up(*warm_up_args)`` runs once in each process before
  its first job (loading modules and compiled kernels), so no job's own
  timing carries the start-up;
- **progress**: ``progress(done, total, row)`` is called in this process once
  per finished job, in the order they finish;
- **failures**: a job never raises; the code that runs one records a failure
  in its row with :class:`capture` (``status`` = ``failed: <one-line
  reason>``), and the other jobs still run. A worker that dies or a cluster
  that cannot run the jobs stops the study with one line (:class:`BhrError`).

Dask is imported only when a scheduler is given.
"""
from __future__ import annotations

import contextlib
import errno
import functools
import math
import os
import threading
import time
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Generic, Iterator, Sequence, TypeVar

from bhr.settings.errors import BhrError
from bhr.settings.options import excerpt

__all__ = ["run_jobs", "Executed", "capture", "reason", "connect_scheduler", "dask_missing", "worker_init",
           "DASK_WAIT_S", "close_client"]

J = TypeVar("J")
R = TypeVar("R")


def dask_missing() -> str:
    """The one-line error for --scheduler without Dask's distributed package, with the command that installs it."""
    from bhr.settings.extras import install_command

    return ("--scheduler needs Dask's distributed package, which is not installed; "
            f"install it with: {install_command('dask')}")


# ------------------------------------------------------------------------------------------ failures


#: The longest reason a study's row keeps (summary.csv, the report's page, the table printed).
MAX_REASON_CHARS = 300


def reason(exc: BaseException) -> str:
    """One line saying why a run failed: a BhrError's own first line, a failed read or write's file (quoted short)
    and why, else the exception's type and first line; at most :data:`MAX_REASON_CHARS` characters (a file name of
    thousands of characters in a batch file was quoted whole)."""
    if isinstance(exc, BhrError):
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    elif isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror + (f": {excerpt(str(exc.filename), 80)}" if exc.filename is not None else "")
    else:
        lines = str(exc).splitlines()
        text = f"{type(exc).__name__}: {lines[0]}" if lines else type(exc).__name__
    return text if len(text) <= MAX_REASON_CHARS else text[:MAX_REASON_CHARS - 3] + "..."


#: A write that failed for want of room (a full disk, a quota, a file-size limit): the study's output failed, not
#: one run, and the next run's files would not fit either.
_OUTPUT_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


class capture:
    """``with capture(row):`` -- an exception inside (not Ctrl-C) becomes ``row["status"] = "failed: <reason>"``.

    With ``keep_traceback`` the traceback of an unexpected error (anything
    but a BhrError, which explains itself) is kept in ``row["traceback"]``.
    One failed run must not stop a study: the others still run. A disk that is
    full (:data:`_OUTPUT_FULL`) stops it: the output folder cannot be written.
    """

    def __init__(self, row: dict[str, Any], *, keep_traceback: bool = False) -> None:
        self.row = row
        self.keep_traceback = keep_traceback

    def __enter__(self) -> dict[str, Any]:
        return self.row

    def __exit__(self, kind: Any, exc: BaseException | None, tb: Any) -> bool:
        if exc is None or not isinstance(exc, Exception):  # KeyboardInterrupt, SystemExit go on
            return False
        if isinstance(exc, OSError) and exc.errno in _OUTPUT_FULL:
            return False
        self.row["status"] = f"failed: {reason(exc)}"
        if self.keep_traceback and not isinstance(exc, BhrError):
            self.row["traceback"] = "".join(traceback.format_exception(kind, exc, tb, limit=8))
        return True


# ------------------------------------------------------------------------------------------ running


@dataclass
class Executed(Generic[R]):
    """What :func:`run_jobs` did: the rows in job order, the time, and what ran them."""

    rows: list[R]
    wall_time_s: float
    runner: str  # "in-process", "N processes" or "dask tcp://..."
    workers: int


_WARMED: set[tuple[str, str, tuple[Any, ...]]] = set()  # the warm-ups this process has run


def _warm(warm_up: Callable[..., Any] | None, args: tuple[Any, ...]) -> None:
    if warm_up is None:
        return
    key = (warm_up.__module__, warm_up.__qualname__, args)
    if key not in _WARMED:
        warm_up(*args)
        _WARMED.add(key)


def _run_chunk(fn: Callable[[Any], Any], warm_up: Callable[..., Any] | None, warm_up_args: tuple[Any, ...],
               chunk: Sequence[tuple[int, Any]]) -> list[tuple[int, Any]]:
    """Run ``(index, job)`` pairs in a worker (after its warm-up); return ``(index, row)`` pairs."""
    _warm(warm_up, warm_up_args)
    return [(i, fn(job)) for i, job in chunk]


def _chunks(items: list[Any], workers: int, max_chunk: int) -> list[list[Any]]:
    size = max(1, min(max_chunk, math.ceil(len(items) / (workers * 8))))
    return [items[k:k + size] for k in range(0, len(items), size)]


def run_jobs(fn: Callable[[J], R], jobs_list: Sequence[J], *, jobs: int | None = None, scheduler: Any = None,
             warm_up: Callable[..., Any] | None = None, warm_up_args: tuple[Any, ...] = (), max_chunk: int = 64,
             progress: Callable[[int, int, R], None] | None = None) -> Executed[R]:
    """Run ``fn(job)`` for every job; return the rows in job order.

    ``jobs``: worker processes (default: the number of CPUs, at most one per
    job; 1 runs in this process). ``scheduler``: a Dask scheduler's address or
    a ``distributed.Client`` to run on instead (the cluster decides how many
    workers run). ``fn``, the jobs, ``warm_up`` and its arguments must pickle
    (module-level functions, plain data) for the worker paths.
    """
    if scheduler is not None and jobs is not None:
        raise BhrError("give either jobs (local processes) or a Dask scheduler, not both")
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise BhrError(f"jobs must be a whole number of processes, 1 or more, got {jobs!r}")
    total = len(jobs_list)
    items = list(enumerate(jobs_list))
    rows: list[Any] = [None] * total
    got = [False] * total
    done = 0

    def finished(pairs: Sequence[tuple[int, Any]]) -> None:
        nonlocal done
        for i, row in pairs:
            rows[i] = row
            got[i] = True
            done += 1
            if progress is not None:
                progress(done, total, row)

    t0 = time.perf_counter()
    if scheduler is not None:
        workers = _run_dask(scheduler, fn, warm_up, warm_up_args, _chunks(items, 8, max_chunk), finished)
        runner = f"dask {scheduler if isinstance(scheduler, str) else scheduler.scheduler.address}"
    else:
        workers = max(1, min(jobs or os.cpu_count() or 1, total))
        if workers == 1:
            _warm(warm_up, warm_up_args)
            for pair in items:
                finished(_run_chunk(fn, None, (), [pair]))
            runner = "in-process"
        else:
            _run_pool(workers, fn, warm_up, warm_up_args, _chunks(items, workers, max_chunk), finished)
            runner = f"{workers} processes"
    wall = time.perf_counter() - t0
    if not all(got):
        raise BhrError("some runs came back without a result; run again")
    return Executed(rows, wall, runner, workers)


def worker_init(parent: int) -> None:
    """Set up a local worker process: Ctrl-C is the parent's to handle, and the worker dies with its parent.

    A Ctrl-C in a terminal reaches every process of the group; the workers
    ignore it (no traceback from each) and the parent stops them. A parent
    that is killed (``kill -9``) takes its workers along: on Linux the kernel
    sends them SIGKILL (``PR_SET_PDEATHSIG``), elsewhere a watchdog thread
    sees the parent gone within a second.
    """
    import signal
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # the parent died before the death signal was armed
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(1.0)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="bhr-parent-watchdog", daemon=True).start()


def _stop_pool(pool: Any) -> None:
    """Stop a process pool at once: queued jobs cancelled, running workers terminated (Ctrl-C, a failure)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for p in procs:  # first the workers: the pool then sees them gone and winds down without writing to them
        with contextlib.suppress(Exception):
            p.kill()
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(timeout=2.0)
    with contextlib.suppress(Exception):
        pool.shutdown(wait=False, cancel_futures=True)


def _no_tracker_relaunch() -> Callable[[], None] | None:
    """A resource tracker that dies (killed) is not started again: the study goes on without it.

    multiprocessing's tracker only deletes the pool's semaphores should this process die without doing so; when
    it is killed, the next message to it starts a new one, which prints a warning and, for every semaphore the
    pool then releases, a KeyError traceback (it never heard of them), and the command still exits 0. Here the
    tracker's messages go to ``/dev/null`` from then on instead (this process still releases its semaphores
    itself as it ends)."""
    from multiprocessing import resource_tracker

    tracker = getattr(resource_tracker, "_resource_tracker", None)
    original = getattr(tracker, "ensure_running", None)
    if getattr(original, "_bhr_quiet", False):
        return original
    if tracker is None or original is None or \
            not all(hasattr(tracker, a) for a in ("_lock", "_fd", "_pid", "_check_alive")):
        return None

    def ensure_running() -> None:
        with tracker._lock:
            if tracker._fd is not None and not tracker._check_alive():
                with contextlib.suppress(OSError):
                    os.close(tracker._fd)
                with contextlib.suppress(OSError, ChildProcessError, TypeError):
                    os.waitpid(tracker._pid, 0)
                tracker._fd = os.open(os.devnull, os.O_WRONLY)
                tracker._pid = None
                return
        original()

    ensure_running._bhr_quiet = True  # type: ignore[attr-defined]
    tracker.ensure_running = ensure_running  # what the tracker's own register/unregister call
    return ensure_running


_WAKEUP_LOCK = threading.Lock()


def _serialised_wakeups() -> None:
    """Make a process pool's wake-up pipe safe to use while its manager thread closes it (once per process).

    At interpreter exit, ``concurrent.futures.process._python_exit`` wakes every pool's manager thread without
    the pool's lock, while that thread may be closing the pipe (CPython 3.11-3.13): the check "not closed" and
    the write can straddle the close, and the command that had printed "Interrupted by SIGHUP." went on with
    "Exception ignored in: <module 'threading'>" and an OSError (Bad file descriptor) traceback. Waking up and
    closing now take one lock, so a wake-up finds the pipe either open or marked closed, never half-closed.
    """
    from concurrent.futures import process

    cls = getattr(process, "_ThreadWakeup", None)
    if cls is None or getattr(cls, "_bhr_serialised", False) or not all(hasattr(cls, a) for a in ("wakeup", "close")):
        return
    wakeup, close = cls.wakeup, cls.close

    def serialised_wakeup(self: Any) -> None:
        with _WAKEUP_LOCK:
            wakeup(self)

    def serialised_close(self: Any) -> None:
        with _WAKEUP_LOCK:
            close(self)

    cls.wakeup, cls.close = serialised_wakeup, serialised_close
    cls._bhr_serialised = True


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Standard error on /dev/null for what starts inside (the resource tracker, which keeps it).

    The tracker outlives a command interrupted (Ctrl-C) while its pool starts, and then deletes the pool's
    semaphores itself, printing "leaked semaphore objects" warnings after "Interrupted."; what it cleans up is
    this command's own, so it says nothing the user could act on."""
    try:
        saved = os.dup(2)
    except OSError:  # no standard error at all: nothing to hide
        yield
        return
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 2)
        finally:
            os.close(null)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


#: How often a study's parent looks at its local workers (s).
WATCH_TICK_S = 1.0
#: How long a worker may stay stopped (SIGSTOP, Ctrl-Z of it alone, a debugger) before the study stops (s).
STOPPED_WAIT_S = 10.0
#: How long every worker may go without using any CPU, with runs still to do, before the study stops (s): a
#: worker runs compiled loops and draws, so this long without a CPU tick is a worker that hangs (a deadlock,
#: a read that never returns), not one that works slowly on a busy machine.
IDLE_WAIT_S = 120.0


def _proc_state(pid: int) -> tuple[str, int] | None:
    """A process's state letter and its CPU time in clock ticks (user + system), from ``/proc`` (None: gone or
    not Linux)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            text = f.read().decode("ascii", "replace")
    except OSError:
        return None
    fields = text.rsplit(")", 1)[-1].split()
    try:
        return fields[0], int(fields[11]) + int(fields[12])
    except (IndexError, ValueError):
        return None


class _Watchdog:
    """Stops a study whose local workers no longer work, with one line, instead of waiting for ever.

    A worker that is stopped (state T or t in ``/proc``) for :data:`STOPPED_WAIT_S`, or workers none of which
    has used any CPU for :data:`IDLE_WAIT_S` while no run finished: :class:`BhrError`. Linux only (elsewhere
    it never fires). A worker that dies is the pool's to report (BrokenProcessPool)."""

    def __init__(self, pool: Any, clock: Callable[[], float] = time.monotonic) -> None:
        self.pool = pool
        self.clock = clock
        self.stopped_since: dict[int, float] = {}
        self.cpu: dict[int, int] = {}
        self.busy_at = self.checked = clock()

    def check(self, progressed: bool = False) -> None:
        now = self.clock()
        if progressed:
            self.busy_at = now
        if now - self.checked > 5 * WATCH_TICK_S:
            # this process was itself stopped (Ctrl-Z of the whole command) or starved: the workers' stillness
            # until now is not theirs to answer for
            self.busy_at = now
            self.stopped_since.clear()
        self.checked = now
        pids = [p.pid for p in list((getattr(self.pool, "_processes", None) or {}).values()) if p.pid]
        for pid in pids:
            state = _proc_state(pid)
            if state is None:
                self.stopped_since.pop(pid, None)
                continue
            letter, ticks = state
            if letter in ("T", "t"):
                since = self.stopped_since.setdefault(pid, now)
                if now - since >= STOPPED_WAIT_S:
                    raise BhrError(f"worker process {pid} has been stopped for {now - since:.0f} s (SIGSTOP, or a "
                                   "debugger holds it), so the study stopped; run it again and let its workers run")
            else:
                self.stopped_since.pop(pid, None)
            if self.cpu.get(pid) != ticks:
                self.cpu[pid] = ticks
                self.busy_at = now
        if pids and now - self.busy_at >= IDLE_WAIT_S:
            raise BhrError(f"no worker process has done any work for {now - self.busy_at:.0f} s (they hang); the "
                           "study stopped: run again, with --jobs 1 to run in this process")


def _run_pool(workers: int, fn: Callable[[Any], Any], warm_up: Callable[..., Any] | None,
              warm_up_args: tuple[Any, ...], chunks: list[list[Any]],
              finished: Callable[[Sequence[tuple[int, Any]]], None]) -> None:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context("spawn")  # safe next to threads (a Dask client, a GUI)
    import signal
    import threading

    if hasattr(signal, "pthread_sigmask"):  # multiprocessing's resource tracker, started with the pool's first
        # lock, ignores SIGINT and SIGTERM but not SIGHUP: a closed terminal killed it, and the one started in its
        # place printed a KeyError traceback. Started here with SIGHUP blocked, it keeps it blocked.
        from multiprocessing import resource_tracker

        ensure = _no_tracker_relaunch() or resource_tracker.ensure_running
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGHUP})
        try:
            with _quiet_stderr():  # the tracker inherits it: see _quiet_stderr
                ensure()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    _serialised_wakeups()
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=worker_init,
                               initargs=(os.getpid(),))
    try:
        # The workers start inside submit(): with Ctrl-C blocked here they start with it blocked (the mask is
        # inherited), so a Ctrl-C while they import is never theirs; here it is delivered when unblocked.
        # SIGTERM and SIGHUP too: they end the command as a Ctrl-C does (bhr.settings.interrupts), and one that
        # came while a worker was being started left that worker reading its start-up data from a closed pipe
        # (a traceback of EOFError)
        # The mask is this thread's only: a signal sent to the process can land on another thread (one that
        # does not block it), and Python then runs the handler here, between a worker's start and the write of
        # its start-up data (the same EOFError). So the handlers only note a signal until every worker has
        # started, and it is raised again after.
        blocked = hasattr(signal, "pthread_sigmask")
        held = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
        noted: list[int] = []
        handlers = {}
        if threading.current_thread() is threading.main_thread():
            handlers = {sig: signal.signal(sig, lambda sig, frame: noted.append(sig)) for sig in held}
        old = signal.pthread_sigmask(signal.SIG_BLOCK, held) if blocked else None
        try:
            futures = [pool.submit(_run_chunk, fn, warm_up, warm_up_args, c) for c in chunks]
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_SETMASK, old or set())
            for sig, handler in handlers.items():
                signal.signal(sig, signal.SIG_DFL if handler is None else handler)
            if noted:
                signal.raise_signal(noted[0])  # now the command's own handler: it ends as that signal ends it
        pending = set(futures)
        watch = _Watchdog(pool)
        while pending:
            done, pending = wait(pending, timeout=WATCH_TICK_S, return_when=FIRST_COMPLETED)
            for fut in done:
                try:
                    part = fut.result()
                except BrokenProcessPool as exc:
                    raise BhrError(f"a worker process stopped ({reason(exc)}); run again, with fewer --jobs if "
                                   "memory is short") from None
                finished(part)
            if pending:
                watch.check(progressed=bool(done))
    except BaseException:  # Ctrl-C, a failure: no worker goes on working (nor outlives this process)
        _stop_pool(pool)
        raise
    pool.shutdown(wait=True)


#: How long a study waits for a Dask cluster that has no worker (none yet, or all lost) before it stops (s).
DASK_WAIT_S = 20.0


def _lost(address: str, why: str) -> BhrError:
    return BhrError(f"lost the Dask scheduler at {address} ({why}); start it again (dask scheduler) and rerun")


def _no_workers(address: str, waited: float, lost: bool, silent: bool = False) -> BhrError:
    what = ("every worker of the Dask scheduler at {a} has stopped answering (no heartbeat for" if silent else
            "every worker of the Dask scheduler at {a} is gone (waited" if lost else
            "the Dask scheduler at {a} has no workers (waited")
    return BhrError(f"{what.format(a=address)} {waited:g} s); start one with: dask worker {address}")


def _ask(client: Any, address: str, limit: float, call: Any, **kwargs: Any) -> Any:
    """A call to the scheduler answered within ``limit`` seconds, else one line: a scheduler that is stopped
    (SIGSTOP, a frozen machine) keeps its connection open and never answers."""
    try:
        return client.sync(call, callback_timeout=limit, **kwargs)
    except TimeoutError:  # asyncio's too (Python 3.11)
        raise _lost(address, f"no answer for {limit:g} s") from None
    except Exception as exc:
        raise _lost(address, reason(exc)) from None


def _answering_workers(client: Any, address: str, limit: float,
                       heard: dict[str, tuple[Any, float]]) -> tuple[int, int]:
    """How many of the scheduler's workers answer, and how many it knows. A worker whose heartbeat (its
    ``last_seen`` on the scheduler) has not changed for ``limit`` seconds of this clock is stopped: the
    scheduler keeps it for minutes (its worker-ttl) and its jobs would wait as long."""
    info = _ask(client, address, limit, client.scheduler.identity)
    workers = (info or {}).get("workers", {}) or {}
    now = time.monotonic()
    count = 0
    for name, w in workers.items():
        seen = w.get("last_seen", w.get("last-seen")) if isinstance(w, dict) else None
        if name not in heard or heard[name][0] != seen:
            heard[name] = (seen, now)
        if seen is None or now - heard[name][1] <= limit:
            count += 1
    return count, len(workers)


def _quiet_dask() -> None:
    """Dask's own log lines (reconnect attempts, tracebacks of a lost scheduler) stay out of the one-line report."""
    import logging

    names = ["distributed", "distributed.client", "tornado", "asyncio"]
    names += [n for n in list(logging.root.manager.loggerDict) if n.startswith(("distributed.", "tornado."))]
    for name in names:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _run_dask(scheduler: Any, fn: Callable[[Any], Any], warm_up: Callable[..., Any] | None,
              warm_up_args: tuple[Any, ...], chunks: list[list[Any]],
              finished: Callable[[Sequence[tuple[int, Any]]], None], wait_s: float | None = None) -> int:
    """Run the chunks on a Dask cluster. With no worker (none at the start, or every one lost) for
    ``wait_s`` seconds (:data:`DASK_WAIT_S`), or with the scheduler gone, stop with one line."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise BhrError(dask_missing()) from None
    limit = DASK_WAIT_S if wait_s is None else float(wait_s)
    own = isinstance(scheduler, str)
    client = connect_scheduler(scheduler) if own else scheduler
    _quiet_dask()  # after distributed made its loggers
    address = scheduler if own else client.scheduler.address
    try:
        workers = _wait_for_workers(client, address, limit, lost=False)
        futures = client.map(functools.partial(_run_chunk, fn, warm_up, warm_up_args), chunks, pure=False)
        pending = set(futures)
        heard: dict[str, tuple[Any, float]] = {}  # worker -> (its last heartbeat as the scheduler saw it, when)
        idle_since: float | None = None
        checked = 0.0
        while pending:
            done = [f for f in futures if f in pending and f.done()]  # in job order
            if not done:
                time.sleep(0.2)
            for fut in done:
                try:
                    part = fut.result(timeout=5)  # bounded: a result lost with its worker waits for a recompute
                except TimeoutError:
                    continue  # still pending; the worker check below bounds the wait
                except Exception as exc:
                    raise _dask_failure(address, exc) from None
                pending.discard(fut)
                finished(part)
            if not pending:
                break
            if client.status not in ("running", "connecting", "newly-created"):
                raise _lost(address, f"the client is {client.status}")
            now = time.monotonic()
            if client.status == "connecting":  # the scheduler went away; Dask tries to reconnect
                idle_since = idle_since or now
                if now - idle_since > limit:
                    raise _lost(address, f"no answer for {limit:g} s")
                continue
            if now - checked < 1.0:
                continue
            checked = now
            count, known = _answering_workers(client, address, limit, heard)
            if count:
                idle_since = None
            else:
                idle_since = idle_since or now
                if now - idle_since > limit:
                    raise _no_workers(address, limit, lost=True, silent=known > 0)
    except (BhrError, KeyboardInterrupt):
        raise
    except Exception as exc:  # anything else Dask raises: the cluster, not the study, failed
        raise _lost(address, reason(exc)) from None
    finally:
        if own:
            with contextlib.suppress(Exception):
                client.close(timeout=2)
    return workers


def close_client(client: Any) -> None:
    """Close a Dask client without waiting long or printing Dask's log lines (the scheduler may be gone)."""
    _quiet_dask()
    with contextlib.suppress(Exception):
        client.close(timeout=2)


def _wait_for_workers(client: Any, address: str, limit: float, lost: bool) -> int:
    """The cluster's worker threads once it has a worker; one line after ``limit`` seconds without one."""
    t0 = time.monotonic()
    while True:
        threads = sum((_ask(client, address, limit, client.scheduler.ncores) or {}).values())
        if threads:
            return max(1, threads)
        if time.monotonic() - t0 > limit:
            raise _no_workers(address, limit, lost)
        time.sleep(0.25)


def _dask_failure(address: str, exc: BaseException) -> BhrError:
    """One line for a chunk that failed on the cluster: a lost scheduler or worker, or a worker without bhr."""
    name = type(exc).__name__
    if isinstance(exc, (ImportError, ModuleNotFoundError, AttributeError)) or "pickle" in name.lower():
        return BhrError(f"a Dask worker could not run bhr's jobs ({reason(exc)}); check that every worker has "
                        "this bhr installed")
    if isinstance(exc, (OSError, TimeoutError)) or name in ("CancelledError", "CommClosedError", "KilledWorker",
                                                             "FutureCancelledError"):
        why = "the connection was lost" if "Cancelled" in name else reason(exc)
        return _lost(address, why) if name != "KilledWorker" else BhrError(
            f"the Dask workers at {address} died while running a job ({reason(exc)}); check their memory and rerun")
    return BhrError(f"a Dask worker failed ({reason(exc)}); rerun, or run locally with --jobs")


# ------------------------------------------------------------------------------------------ Dask


def _cannot(address: str, why: str) -> BhrError:
    from bhr.settings.options import excerpt

    shown = address if len(address) <= 60 and address.isprintable() else excerpt(address, 60)
    why = why if len(why) <= 120 and why.isprintable() else excerpt(why, 120)  # may quote the address again
    return BhrError(f"cannot connect to the Dask scheduler at {shown} ({why}); check the address "
                    "(e.g. tcp://127.0.0.1:8786) and that the scheduler is running")


@contextlib.contextmanager
def scheduler_client(address: str | None) -> Iterator[Any]:
    """``None`` without an address (local processes), else a client on the scheduler at ``address``
    (:func:`connect_scheduler`, one line when it cannot connect), closed on leaving."""
    client = None if address is None else connect_scheduler(address)
    try:
        yield client
    finally:
        if client is not None:
            close_client(client)


def connect_scheduler(address: str, timeout: float = 15.0) -> Any:
    """A ``distributed.Client`` on the scheduler at ``address``, or one BhrError line saying why not.

    The address is checked, then a Dask handshake is tried with a deadline
    (so a port that answers but is not a scheduler fails in ``timeout``
    seconds instead of hanging), then the client is made.
    """
    import asyncio

    _quiet_dask()
    try:
        from distributed import Client
        from distributed.comm import connect
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        raise BhrError(dask_missing()) from None
    try:
        scheme, loc = parse_address(address.strip())
        if scheme in ("tcp", "tls"):
            parse_host_port(loc)
            port = loc.rpartition(":")[2]
            if not (port.isascii() and port.isdigit()):  # int() takes full-width digits: '８７８６' is 8786
                raise ValueError(f"the port {port!r} is not plain digits 0-9")
    except (ValueError, TypeError) as exc:
        raise _cannot(address, str(exc).splitlines()[0] if str(exc) else "malformed address") from None

    if scheme == "tcp":  # a closed port fails at once, without Dask's retries
        import socket

        host, port = parse_host_port(loc)
        try:
            socket.create_connection((host, port), timeout=timeout).close()
        except OSError as exc:
            raise _cannot(address, exc.strerror or exc.__class__.__name__) from None

    async def handshake() -> None:
        comm = await connect(address.strip(), timeout=f"{timeout}s")
        await comm.close()

    async def bounded() -> None:
        # Dask's connect() does not bound the handshake: a port that answers but never speaks Dask would hang
        await asyncio.wait_for(handshake(), timeout)

    try:
        asyncio.run(bounded())
    except (asyncio.TimeoutError, TimeoutError):
        raise _cannot(address, f"no Dask handshake within {timeout:g} s; is it a Dask scheduler?") from None
    except MemoryError:  # its first bytes, read as Dask's message length, ask for exabytes: not a Dask answer
        raise _cannot(address, "it answered, but not as Dask does; is it a Dask scheduler?") from None
    except Exception as exc:  # OSError, ValueError
        raise _cannot(address, str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__) from None
    try:
        client = Client(address.strip(), timeout=f"{timeout}s", set_as_default=False)
        _quiet_dask()
        return client
    except Exception as exc:
        raise _cannot(address, str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__) from None
