"""Studies on a Dask cluster: the connection to its scheduler, and the jobs run there.

A cluster that cannot run the jobs stops the study with one line: an address that is no Dask scheduler, no worker
for :data:`DASK_WAIT_S`, a scheduler that goes away, or a scheduler or every worker silent that long (a stopped
process keeps its connections open, and Dask would wait minutes). A job whose worker died Dask runs again
elsewhere, and reports as ``KilledWorker`` after several: that job's row.
"""
from __future__ import annotations

import contextlib
import time
from collections import deque
from typing import Any, Callable, Iterator

from bhr.settings.errors import BhrError
from bhr.settings.options import excerpt
from bhr.settings.inputs import reason

__all__ = ["DASK_WAIT_S", "connect_scheduler", "scheduler_client", "dask_missing", "run_dask"]

#: How long a study waits for a Dask cluster with no worker, or one whose scheduler or workers are silent (s).
DASK_WAIT_S = 20.0


def dask_missing() -> str:
    """The one-line error for --scheduler without Dask's distributed package."""
    from bhr.settings.extras import install_command

    return ("--scheduler needs Dask's distributed package, which is not installed; "
            f"install it with: {install_command('dask')}")


def run_dask(client: Any, call: Callable[[Any], Any], todo: deque, finished: Callable[..., None],
             died: Callable[..., None]) -> int:
    """Run the chunks on the cluster; return its worker threads."""
    from distributed import wait

    _quiet_dask()
    address = client.scheduler.address
    try:
        client.wait_for_workers(1, timeout=DASK_WAIT_S)
        threads = max(1, sum(client.nthreads().values()))
        sent: dict[Any, Any] = {}
        heard: dict[Any, Any] = {}
        while todo or sent:
            while todo:
                chunk = todo.popleft()
                sent[client.submit(call, chunk, pure=False)] = chunk
            try:
                with client.as_current():
                    wait(list(sent), timeout=2.0, return_when="FIRST_COMPLETED")
            except TimeoutError:
                _check_cluster(client, address, heard)
                continue
            for future in [f for f in sent if f.done()]:
                try:
                    rows = future.result(timeout=DASK_WAIT_S)  # a result lost with its worker is computed again
                except TimeoutError:
                    continue
                except Exception as exc:
                    if type(exc).__name__ != "KilledWorker":
                        raise _dask_failure(address, exc) from None
                    died(sent.pop(future), reason(exc), todo)
                    continue
                finished(rows)
                sent.pop(future)
    except (BhrError, KeyboardInterrupt):
        raise
    except TimeoutError:
        raise BhrError(f"the Dask scheduler at {address} has no workers (waited {DASK_WAIT_S:g} s); start one "
                       f"with: dask worker {address}") from None
    except Exception as exc:  # anything else Dask raises: the cluster, not the study, failed
        raise _lost(address, reason(exc)) from None
    return threads


def _check_cluster(client: Any, address: str, heard: dict[Any, Any]) -> None:
    """No job finished for a while: the scheduler must answer, and some worker must have sent a heartbeat, within
    :data:`DASK_WAIT_S`."""
    try:
        info = client.sync(client.scheduler.identity, n_workers=-1, callback_timeout=DASK_WAIT_S)
    except Exception:
        raise _lost(address, f"no answer for {DASK_WAIT_S:g} s") from None
    now, workers = time.monotonic(), (info or {}).get("workers") or {}
    for name, w in workers.items():
        seen = w.get("last_seen", w.get("last-seen"))
        if heard.get(name, (None,))[0] != seen:
            heard[name] = (seen, now)
    if any(now - heard[name][1] < DASK_WAIT_S for name in workers):
        heard.pop(None, None)
    elif now - heard.setdefault(None, now) >= DASK_WAIT_S:
        raise BhrError(f"every worker of the Dask scheduler at {address} " + (
            f"has stopped answering (no heartbeat for {DASK_WAIT_S:g} s)" if workers else
            f"is gone (waited {DASK_WAIT_S:g} s)") + f"; start one with: dask worker {address}")


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

    names = ["distributed", "tornado", "asyncio"] + [n for n in logging.root.manager.loggerDict
                                                     if n.startswith(("distributed.", "tornado."))]
    for name in names:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


@contextlib.contextmanager
def scheduler_client(address: str | None) -> Iterator[Any]:
    """None without an address, else a client on the scheduler at ``address``, closed on leaving."""
    if address is None:
        yield None
        return
    client = connect_scheduler(address)
    try:
        yield client
    finally:  # without waiting long: the scheduler may be gone
        _quiet_dask()
        with contextlib.suppress(Exception):
            client.close(timeout=2)


def connect_scheduler(address: str, timeout: float = 15.0) -> Any:
    """A ``distributed.Client`` on the scheduler at ``address``, or one BhrError line saying why not: the address
    is checked, then a Dask handshake tried within ``timeout`` (Dask's own connect does not bound it)."""
    import asyncio
    import socket

    _quiet_dask()
    try:
        from distributed import Client
        from distributed.comm import connect
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        raise BhrError(dask_missing()) from None

    def cannot(why: Any) -> BhrError:
        why = str(why).splitlines()[0] if str(why) else type(why).__name__
        shown = address if len(address) <= 60 and address.isprintable() else excerpt(address, 60)
        return BhrError(f"cannot connect to the Dask scheduler at {shown} "
                        f"({why if len(why) <= 120 and why.isprintable() else excerpt(why, 120)}); check the "
                        "address (e.g. tcp://127.0.0.1:8786) and that the scheduler is running")

    async def handshake() -> None:
        await (await connect(address.strip(), timeout=f"{timeout}s")).close()

    try:
        scheme, loc = parse_address(address.strip())
        if scheme in ("tcp", "tls"):
            host, port = parse_host_port(loc)
            if not (loc.rpartition(":")[2].isascii() and loc.rpartition(":")[2].isdigit()):  # int() reads '８７８６'
                raise ValueError(f"the port {loc.rpartition(':')[2]!r} is not plain digits 0-9")
            if scheme == "tcp":  # a closed port fails at once, without Dask's retries
                socket.create_connection((host, port), timeout=timeout).close()
    except OSError as exc:
        raise cannot(exc.strerror or exc) from None
    except (ValueError, TypeError) as exc:
        raise cannot(exc or "malformed address") from None
    try:
        asyncio.run(asyncio.wait_for(handshake(), timeout))
        client = Client(address.strip(), timeout=f"{timeout}s", set_as_default=False)
    except (asyncio.TimeoutError, TimeoutError):
        raise cannot(f"no Dask handshake within {timeout:g} s; is it a Dask scheduler?") from None
    except MemoryError:  # its first bytes, read as Dask's message length, ask for exabytes
        raise cannot("it answered, but not as Dask does; is it a Dask scheduler?") from None
    except Exception as exc:
        raise cannot(exc) from None
    _quiet_dask()
    return client
