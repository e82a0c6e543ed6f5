"""Studies on a Dask cluster: ``client.submit`` per chunk, ``distributed.wait`` for them.

A job whose worker died Dask runs again elsewhere, and after several tries reports ``KilledWorker``: that job's
row. A cluster that cannot go on (no worker for :data:`DASK_WAIT_S`, a scheduler gone or silent that long, workers
without bhr) stops the study with one line.
"""
from __future__ import annotations

import contextlib
from collections import deque
from typing import Any, Callable, Iterator

from bhr._settings.errors import BhrError
from bhr._settings.inputs import reason
from bhr._settings.options import excerpt

__all__ = ["DASK_WAIT_S", "connect_scheduler", "scheduler_client", "dask_missing", "run_dask"]

DASK_WAIT_S = 20.0  # how long a study waits for a Dask cluster without workers, or a silent scheduler (s)


def dask_missing() -> str:
    from bhr._settings.extras import install_command

    return ("--scheduler needs Dask's distributed package, which is not installed; "
            f"install it with: {install_command('dask')}")


def run_dask(client: Any, call: Callable[[Any], Any], todo: deque, finished: Callable[..., None],
             died: Callable[..., None]) -> int:
    """Run the chunks on the cluster; return its worker threads."""
    from distributed import wait

    _quiet_dask()
    address, alone = client.scheduler.address, None
    sent: dict[Any, Any] = {}
    try:
        client.wait_for_workers(1, timeout=DASK_WAIT_S)
        threads = max(1, sum(client.nthreads().values()))
        while todo or sent:
            while todo:
                chunk = todo.popleft()
                sent[client.submit(call, chunk, pure=False)] = chunk
            try:
                with client.as_current():
                    wait(list(sent), timeout=2.0, return_when="FIRST_COMPLETED")
            except TimeoutError:  # nothing finished for a while
                alone = _check_cluster(client, address, alone)
            for future in [f for f in sent if f.done()]:
                try:
                    finished(future.result(timeout=DASK_WAIT_S))
                except TimeoutError:  # a result lost with its worker is computed again; a silent scheduler stops
                    alone = _check_cluster(client, address, alone)  # the study (else this done future is asked
                    continue  # for its result again and again, each time for DASK_WAIT_S)
                except Exception as exc:
                    if type(exc).__name__ != "KilledWorker":
                        raise _dask_failure(address, exc) from None
                    died(sent[future], reason(exc), todo)
                del sent[future]
    except BhrError:
        raise
    except TimeoutError:
        raise BhrError(f"the Dask scheduler at {address} has no workers (waited {DASK_WAIT_S:g} s); start one "
                       f"with: dask worker {address}") from None
    except Exception as exc:  # anything else Dask raises: the cluster, not the study, failed
        raise _lost(address, reason(exc)) from None
    return threads


def _check_cluster(client: Any, address: str, alone: float | None) -> float | None:
    """The scheduler must answer, and have a worker, within :data:`DASK_WAIT_S`; since when it has none."""
    import time

    try:
        info = client.sync(client.scheduler.identity, callback_timeout=DASK_WAIT_S)
    except Exception:
        raise _lost(address, f"no answer for {DASK_WAIT_S:g} s") from None
    alone = None if info.get("workers") else alone or time.monotonic()
    if alone is not None and time.monotonic() - alone > DASK_WAIT_S:
        raise BhrError(f"every worker of the Dask scheduler at {address} is gone (waited {DASK_WAIT_S:g} s); start "
                       f"one with: dask worker {address}")
    return alone


def _lost(address: str, why: str) -> BhrError:
    return BhrError(f"lost the Dask scheduler at {address} ({why}); start it again (dask scheduler) and rerun")


def _dask_failure(address: str, exc: BaseException) -> BhrError:
    """One line for a chunk that failed on the cluster: a lost scheduler, or a worker without bhr."""
    name = type(exc).__name__
    if isinstance(exc, (ImportError, AttributeError)) or "pickle" in name.lower():
        return BhrError(f"a Dask worker could not run bhr's jobs ({reason(exc)}); check that every worker has "
                        "this bhr installed")
    if isinstance(exc, OSError) or "Cancelled" in name or "CommClosed" in name:
        return _lost(address, "the connection was lost" if "Cancelled" in name else reason(exc))
    return BhrError(f"a Dask worker failed ({reason(exc)}); rerun, or run locally with --jobs")


def _quiet_dask() -> None:
    """Dask's own log lines (reconnects, a lost scheduler's tracebacks) stay out of the one-line report."""
    import logging

    for name in ["distributed", "tornado", "asyncio", *logging.root.manager.loggerDict]:
        if name.startswith(("distributed", "tornado", "asyncio")):
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)


@contextlib.contextmanager
def scheduler_client(address: str | None) -> Iterator[Any]:
    """None without an address, else a client on the scheduler at ``address``, closed on leaving."""
    client = None if address is None else connect_scheduler(address)
    try:
        yield client
    finally:
        _quiet_dask()
        with contextlib.suppress(Exception):
            client is not None and client.close(timeout=2)  # without waiting long: the scheduler may be gone


def connect_scheduler(address: str, timeout: float = 15.0) -> Any:
    """A ``distributed.Client`` on the scheduler at ``address``, or one BhrError line saying why not. A Dask
    handshake is tried first within ``timeout``: a port that answers nothing would hold Dask's own connect for
    ever."""
    import asyncio
    import socket

    _quiet_dask()
    try:
        from distributed import Client
        from distributed.comm import connect
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        raise BhrError(dask_missing()) from None
    address = address.strip()

    def cannot(why: Any) -> BhrError:
        why = str(why).splitlines()[0] if str(why) else type(why).__name__
        return BhrError(f"cannot connect to the Dask scheduler at {_shown(address, 60)} ({_shown(why, 120)}); "
                        "check the address (e.g. tcp://127.0.0.1:8786) and that the scheduler is running")

    async def handshake() -> None:
        await (await connect(address, timeout=f"{timeout}s")).close()

    try:
        scheme, location = parse_address(address)
        if scheme == "tcp":  # a closed port fails at once, without Dask's retries
            host, port = parse_host_port(location)
            if not (location.rpartition(":")[2].isascii() and location.rpartition(":")[2].isdigit()):
                raise ValueError(f"the port {location.rpartition(':')[2]!r} is not plain digits 0-9")  # not '８７８６'
            socket.create_connection((host, port), timeout=timeout).close()
        asyncio.run(asyncio.wait_for(handshake(), timeout))
        client = Client(address, timeout=f"{timeout}s", set_as_default=False)
    except (asyncio.TimeoutError, TimeoutError):
        raise cannot(f"no Dask handshake within {timeout:g} s; is it a Dask scheduler?") from None
    except MemoryError:  # its first bytes, read as Dask's message length, ask for exabytes
        raise cannot("it answered, but not as Dask does; is it a Dask scheduler?") from None
    except Exception as exc:
        raise cannot(getattr(exc, "strerror", None) or exc) from None
    _quiet_dask()
    return client


def _shown(text: str, limit: int) -> str:
    return text if len(text) <= limit and text.isprintable() else excerpt(text, limit)
