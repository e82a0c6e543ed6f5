"""The host side of the serial link to the actuator board (docs/protocol.md).

``BoardLink`` opens any port pyserial can open: a device (``/dev/ttyUSB0``,
``COM3``), a pseudo-terminal (the simulated board from ``make -C firmware
sim``) or a pyserial URL (``loop://``, ``socket://host:port``, ...). Each call
sends one frame and waits for its answer (stop-and-wait): a timeout or a NAK
for a damaged frame is retried with a fresh sequence number, at most
``retries`` times, then :class:`~bhr._settings.errors.LinkError` is raised with one line
naming the problem and what to check.

>>> with BoardLink("/dev/ttyUSB0") as board:          # doctest: +SKIP
...     board.set_codes([3, 0, 6, 0, 0])
...     board.status()
{'codes': [3, 0, 6, 0, 0], 'faults': []}

No click in here: the command line passes ``progress`` callbacks.
"""
from __future__ import annotations

import shlex
import sys
import time
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

import bhr._hardware.protocol as P
from bhr.model._codes import check_code, check_codes
from bhr.model._robotfile import check_file_port
from bhr._settings.errors import BhrError, LinkError

__all__ = ["BoardLink", "Pacer", "StreamInterrupted", "StreamStopped", "StreamReport", "run_stream", "READY_TIMEOUT",
           "AT_END", "check_board", "interrupted", "stream_codes", "validate_codes",
           "wait_until_ready", "refuse_overheat", "with_stop_all", "DEFAULT_BAUD",
           "DEFAULT_TIMEOUT", "DEFAULT_RETRIES"]

try:  # a pty that vanishes between write and drain raises termios.error, which is not an OSError
    import termios

    _TTY_ERRORS: tuple[type[BaseException], ...] = (termios.error,)
except ImportError:  # pragma: no cover - not POSIX
    _TTY_ERRORS = ()

DEFAULT_BAUD = 115200
DEFAULT_TIMEOUT = 0.25  # seconds to wait for each answer
DEFAULT_RETRIES = 3     # extra tries after the first
#: While waiting for the next row, send a heartbeat this often (s). Must stay
#: well below the board's silence timeout (1 s on the real board).
DEFAULT_HEARTBEAT = 0.25


try:  # POSIX: pyserial's flush() calls termios.tcdrain, whose error is not an OSError
    import termios as _termios

    _TERMIOS_ERRORS: tuple[type[BaseException], ...] = (_termios.error,)
except ImportError:  # pragma: no cover - Windows
    _TERMIOS_ERRORS = ()


class StreamInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`stream_codes`; ``stopped`` tells whether stop-all was acknowledged."""

    def __init__(self, stopped: bool, sent: int, detail: str = "") -> None:
        super().__init__("interrupted")
        self.stopped = stopped
        self.sent = sent
        self.detail = detail


class StreamStopped(LinkError):
    """The board raised a fault that ends a stream (overheat); stop-all follows."""


class BoardLink:
    """A connection to the actuator board.

    ``BoardLink(port, baudrate=115200, timeout=0.25, retries=3,
    module_order=None, any_url=False)``; ``port`` is a serial device
    (``/dev/...``, ``COM3``), ``loop://`` or ``socket://host:port``: pyserial's
    other URL handlers (``spy://``, which writes the traffic into any file it
    names, and those that scan or load backends) are refused unless
    ``any_url=True``, the same check a robot file's and ``--port``'s port get;
    ``module_order`` (a robot file's ``link.module_order``) says which module
    is wired to each position of the shift-register chain, and the codes are
    rearranged on the way out and back so callers always speak in module
    order (module 1 = base first). Methods: ``set_codes(codes)``,
    ``status() -> {"codes": [...], "faults": [...]}``, ``stop_all()``,
    ``heartbeat()``, ``close()``; also a context manager. Opening and closing
    send nothing: the board keeps what it was last told until its silence
    timeout switches everything off.
    """

    def __init__(self, port: str, baudrate: int = DEFAULT_BAUD, timeout: float = DEFAULT_TIMEOUT,
                 retries: int = DEFAULT_RETRIES, module_order: Sequence[int] | None = None,
                 any_url: bool = False) -> None:
        try:
            import serial
        except ImportError:  # pragma: no cover - pyserial is a dependency
            raise LinkError("pyserial is not installed; install it with: "
                            f"{shlex.quote(sys.executable or 'python3')} -m pip install pyserial") from None
        if not port or not str(port).strip():
            raise LinkError("no serial port given; pass --port with a device such as /dev/ttyUSB0, loop:// or socket://host:port")
        if not any_url:
            try:
                check_file_port(str(port), "port")
            except BhrError as exc:
                raise LinkError(f"{exc}; or pass any_url=True to open another pyserial URL") from None
        if not timeout or timeout <= 0:
            raise LinkError(f"timeout must be positive, got {timeout}; give seconds such as 0.25")
        if retries < 0:
            raise LinkError(f"retries must be 0 or more, got {retries}")
        if module_order is not None:
            order = [int(m) for m in module_order]
            if sorted(order) != list(range(1, len(order) + 1)):
                raise LinkError(f"module order {order} must list each module 1..{len(order)} exactly once")
            module_order = tuple(order)
        self.port = str(port)
        self.baudrate = int(baudrate)
        #: ``module_order[k-1]`` is the module (1 = base) wired to chain position k; None: 1, 2, ..., n.
        self.module_order = module_order
        self.timeout = float(timeout)
        self.retries = int(retries)
        self._serial_mod = serial
        self._decoder = P.StreamDecoder()
        self._seq = 0
        self.frames_sent = 0
        #: Tries that got no answer, and answers that were NAKs for a damaged frame (both retried).
        self.timeouts = 0
        self.damaged = 0
        self.last_faults: list[str] = []
        #: Modules the board drives, from its first status reply (a later reply with another count is a lie).
        self.modules: int | None = None
        kwargs = {"baudrate": self.baudrate, "timeout": min(0.05, self.timeout),
                  "write_timeout": max(1.0, 4 * self.timeout)}
        if "://" not in self.port:
            kwargs["exclusive"] = True  # two programs on one port would steal each other's replies
        try:
            self._ser = serial.serial_for_url(self.port, **kwargs)
        except (serial.SerialException, OSError, ValueError, OverflowError) as exc:
            text = str(exc)
            if "exclusively lock" in text or getattr(exc, "errno", None) in (11, 16) or "busy" in text.lower():
                raise LinkError(f"serial port {self.port} is in use by another program (bhr stream, a serial "
                                "monitor, ...); close that program and try again") from None
            raise LinkError(f"cannot open serial port {self.port}: {_reason(exc)}; check the port name "
                            "(or pyserial URL) and that the board or simulator is running") from None
        try:
            self._ser.reset_input_buffer()
        except (serial.SerialException, OSError):  # pragma: no cover - some URL handlers lack it
            pass

    # -- context manager -------------------------------------------------
    def __enter__(self) -> "BoardLink":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the port. Sends nothing."""
        ser = getattr(self, "_ser", None)
        if ser is not None:
            try:
                ser.close()
            except Exception:  # noqa: BLE001 - closing a dead port must not mask the real error
                pass
            self._ser = None

    @property
    def is_open(self) -> bool:
        return getattr(self, "_ser", None) is not None

    # -- requests --------------------------------------------------------
    def set_codes(self, codes: Sequence[int]) -> list[str]:
        """Send one row of module codes (module 1 = base first); return the fault names the ACK carried.

        The codes are validated first: an unstable code raises BhrError and
        nothing is sent.
        """
        values = self._to_chain(check_codes(list(codes)))
        reply = self._transact(lambda seq: P.set_codes_frame(seq, values), "SET_CODES", P.Msg.SET_CODES,
                               n_codes=len(values))
        _, faults = P.parse_ack(reply)
        self.last_faults = P.fault_names(faults)
        return self.last_faults

    def status(self, detail: bool = False) -> dict:
        """The board's current output codes and faults: ``{"codes": [...], "faults": [...]}``.

        ``detail=True`` adds ``"relaxing"``: the modules (1-based) with a
        released wire that has not relaxed yet (docs/thermal.md). The reply is
        checked whole first (:func:`bhr._hardware.protocol.check_reply`): a board that
        reports 0 modules, another count than before, an unstable code or
        flags that contradict each other raises LinkError.
        """
        reply = self._transact(P.status_frame, "STATUS", P.Msg.STATUS)
        doc = P.parse_status(reply)
        if detail:
            doc["relaxing"] = P.relaxing_modules(reply)
        self.modules = len(doc["codes"])
        if self.module_order is not None:
            if len(doc["codes"]) != len(self.module_order):
                raise LinkError(f"board on {self.port} drives {len(doc['codes'])} modules but the robot file's "
                                f"link.module_order lists {len(self.module_order)}; fix module_order or build "
                                f"the firmware with 'make -C firmware MODULES={len(self.module_order)}'")
            chain = doc["codes"]
            doc["codes"] = [0] * len(chain)
            for pos, m in enumerate(self.module_order):
                doc["codes"][m - 1] = chain[pos]
            if detail:
                doc["relaxing"] = sorted(self.module_order[k - 1] for k in doc["relaxing"])
            doc["faults"] = [_rename_module(f, self.module_order) for f in doc["faults"]]
        return doc

    def stop_all(self, retries: int | None = None) -> None:
        """Switch every actuator off (and acknowledge latched overheat faults)."""
        self._transact(P.stop_all_frame, "STOP_ALL", P.Msg.STOP_ALL, retries=retries)

    def heartbeat(self) -> list[str]:
        """Tell the board the host is alive (restarts its silence timeout); return the fault names the ACK carried."""
        _, faults = P.parse_ack(self._transact(P.heartbeat_frame, "HEARTBEAT", P.Msg.HEARTBEAT))
        self.last_faults = P.fault_names(faults)
        return self.last_faults

    def try_stop_all(self) -> bool:
        """Stop-all as a last resort (after a failure): one try, no exception; True when acknowledged."""
        if not self.is_open:
            return False
        try:
            self.stop_all(retries=0)
            return True
        except BhrError:
            return False

    def stream(self, codes, rate: float = 10.0, progress: Callable[[int, int], None] | None = None,
               heartbeat: float = DEFAULT_HEARTBEAT) -> int:
        """Send a (steps x modules) table of codes at ``rate`` rows per second; see :func:`stream_codes`."""
        return stream_codes(self, codes, rate=rate, progress=progress, heartbeat=heartbeat)

    # -- internals -------------------------------------------------------
    def _to_chain(self, values: list[int]) -> list[int]:
        order = self.module_order
        if order is None:
            return values
        if len(values) != len(order):
            raise LinkError(f"{len(values)} codes for a board whose link.module_order lists {len(order)} modules; "
                            f"send one code per module")
        return [values[m - 1] for m in order]

    def _next_seq(self) -> int:
        seq = self._seq
        self._seq = (self._seq + 1) & 0xFF
        return seq

    def _io_error(self, exc: BaseException) -> LinkError:
        return LinkError(f"lost the serial link to the board on {self.port} ({_reason(exc)}); "
                         "check the cable, or that the simulator is still running")

    def _write(self, data: bytes) -> None:
        if self._ser is None:
            raise LinkError(f"the link to {self.port} is closed; open a new BoardLink")
        try:
            self._ser.write(data)
            self._ser.flush()
        except (self._serial_mod.SerialException, OSError, *_TTY_ERRORS) as exc:
            raise self._io_error(exc) from None
        self.frames_sent += 1

    def _await(self, seq: int, deadline: float) -> P.Frame | None:
        """Read until a reply with ``seq`` arrives (returned) or the deadline passes (None). Past the deadline,
        what had arrived by then is still read, once: a host that did not run for a while (a busy machine) finds the
        reply the board sent meanwhile instead of sending the frame again."""
        ser = self._ser
        while True:
            late = deadline - time.monotonic() <= 0
            try:
                waiting = ser.in_waiting
                data = ser.read(min(waiting, 4096) if late else max(1, min(waiting, 4096)))
            except (self._serial_mod.SerialException, OSError, *_TTY_ERRORS) as exc:
                raise self._io_error(exc) from None
            if data:
                for frame in self._decoder.feed(data):
                    if frame.seq == seq and frame.type >= 0x80:
                        return frame  # later frames of this chunk are stale by definition
            if late:  # once: a board that never stops sending cannot hold the wait open
                return None

    def _transact(self, build: Callable[[int], bytes], what: str, request: int, retries: int | None = None,
                  n_codes: int = 0) -> P.Frame:
        tries = 1 + (self.retries if retries is None else retries)
        last = "no answer"
        for _ in range(tries):
            seq = self._next_seq()
            self._write(build(seq))
            reply = self._await(seq, time.monotonic() + self.timeout)
            if reply is None:
                last = "no answer"
                self.timeouts += 1
                self._decoder.reset()  # whatever is buffered is stale
                continue
            if reply.version != P.VERSION:
                raise LinkError(f"board on {self.port} answered {what} in protocol version {reply.version}, bhr "
                                f"speaks {P.VERSION}; update the firmware or bhr so that they match")
            try:
                P.check_reply(reply, request, self.modules if request == P.Msg.STATUS else None)
            except P.ProtocolError as exc:
                raise self._lie(what, str(exc), request) from None
            if reply.type == P.Msg.NAK:
                _, reason, detail = P.parse_nak(reply)
                if reason in P.RETRYABLE:
                    last = P.nak_text(reason, detail)
                    self.damaged += 1
                    continue
                raise LinkError(self._nak_message(what, reason, detail, n_codes))
            return reply
        raise LinkError(f"board on {self.port} did not answer {what} after {tries} "
                        f"{'try' if tries == 1 else 'tries'} ({last}; {self.timeout:g} s each); check that it is "
                        f"powered and running bhr firmware, the port, and the baud rate ({self.baudrate})")

    def _lie(self, what: str, problem: str, request: int) -> LinkError:
        """An impossible reply: nothing it says is used; stop-all is tried once (unless that was the request)."""
        stopped = request != P.Msg.STOP_ALL and self.try_stop_all()
        then = "sent stop-all" if stopped else "stop-all was not acknowledged"
        return LinkError(f"board on {self.port} answered {what} with an impossible reply ({problem}); {then}; check "
                         "that the port is the bhr board and that its firmware matches this bhr")

    def _nak_message(self, what: str, reason: int, detail: int, n_codes: int) -> str:
        text = P.nak_text(reason, detail)
        if reason == P.Nak.BAD_COUNT:
            return (f"board on {self.port} refused {what}: it drives {detail} modules but {n_codes} codes were "
                    f"sent; use codes for {detail} modules or build the firmware with "
                    f"'make -C firmware MODULES={n_codes}'")
        if reason == P.Nak.BAD_VERSION:
            return (f"board on {self.port} refused {what}: it speaks protocol version {detail}, bhr speaks "
                    f"{P.VERSION}; update the firmware or bhr so they match")
        return f"board on {self.port} refused {what}: {text}; check that its firmware matches this bhr"


def _rename_module(fault: str, order: Sequence[int]) -> str:
    """``overheat:m2`` of chain position 2 -> the module wired there."""
    name, _, pos = fault.partition(":m")
    return f"{name}:m{order[int(pos) - 1]}" if pos.isdigit() and int(pos) <= len(order) else fault


#: Faults the board keeps until stop-all (docs/protocol.md): an ACK that carries one is followed by a status that
#: holds it too.
LATCHED = ("overheat", "early", "reset", "flood")

#: The longest the host waits for a board whose wires are cooling or relaxing (docs/protocol.md).
READY_TIMEOUT = 30.0


def with_stop_all(link: "BoardLink", text: str) -> str:
    """``text`` (a LinkError's line) with stop-all tried once where it has not been, and whether the board
    acknowledged it."""
    if "stop-all" in text:
        return text
    stopped = link.try_stop_all()
    return text + ("; sent stop-all, every actuator is off" if stopped else
                   "; stop-all was not acknowledged: the board switches off by itself after its silence timeout")


def refuse_overheat(link: "BoardLink", faults: Sequence[str]) -> None:
    """Raise LinkError when ``faults`` (a status before a stream) hold a latched overheat: the wire needs
    looking at, not a wait, so nothing is streamed (the caller's LinkError handling sends stop-all)."""
    hot = [f for f in faults if f.startswith("overheat")]
    if hot:
        raise LinkError(f"board on {link.port} reports {', '.join(hot)} (latched) before the stream; nothing "
                        "was sent; let the wires cool and check them (bhr status) before streaming again")


def wait_until_ready(link: "BoardLink", timeout: float = READY_TIMEOUT) -> float:
    """Poll the board until no module is cooling or relaxing (wires cold enough to plan from); return the wait (s).

    Raises LinkError at once when the board reports a latched overheat, and when it is still not ready after
    ``timeout`` seconds: the wait never runs past it (a board that reports "cooling"
    forever is not waited on longer).
    """
    t0 = time.monotonic()
    deadline = t0 + timeout
    while True:
        doc = link.status(detail=True)
        refuse_overheat(link, doc["faults"])
        busy = [f for f in doc["faults"] if f.startswith("cooling")] + [f"relaxing:m{m}" for m in doc["relaxing"]]
        if not busy:
            return time.monotonic() - t0
        if time.monotonic() + 0.1 > deadline:
            raise LinkError(f"board on {link.port} is still {', '.join(busy)} after {timeout:g} s (the longest bhr "
                            "waits); nothing was sent; let its wires cool (bhr status) and try again")
        time.sleep(0.1)


def _reason(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text and text[0] else type(exc).__name__


def validate_codes(codes, where: str = "") -> np.ndarray:
    """Check a (steps x modules) table of codes; raise BhrError naming row and module of the first bad one."""
    try:
        arr = np.asarray(codes)
    except (TypeError, ValueError):
        raise BhrError(f"codes{where} must be a table of steps by modules") from None
    if arr.ndim != 2 or arr.shape[0] == 0 or arr.shape[1] == 0:
        raise BhrError(f"codes{where} must be a non-empty table of steps by modules, got shape {arr.shape}")
    out = np.zeros(arr.shape, dtype=np.int64)
    for i in range(arr.shape[0]):
        for j in range(arr.shape[1]):
            out[i, j] = check_code(arr[i, j], f"at row {i + 1} module m{j + 1}{where}")
    return out


class Pacer:
    """Send rows of codes to the board no faster than ``rate`` rows per second.

    The first row goes at once; each further row is due ``1 / rate`` seconds
    (or its planned gap, with ``times``: seconds after the first row, one per
    row, from :func:`bhr._hardware.thermal.auto_schedule`) after the board acknowledged
    the row before it, so a late row (or a retried one) never shortens the gap after it. While waiting longer
    than ``heartbeat`` seconds, heartbeats keep the board's silence timeout
    from firing. ``wait_relaxed``: before a row that energises a recently
    released wire, ask the board and wait while that module still has a wire
    relaxing (the board's clock decides, so a board whose clock runs slow is
    still never asked too early); ``held``, the codes the board holds before the
    first row, counts a first row's switching off of their wires as a release.
    ``on_fault(step, names)`` is called once for
    each fault the board raises anew, with the 1-based step and the fault
    names with their modules (a status request gives the modules);
    ``known_faults`` (from a status before the stream) are not news. Calling
    the pacer as ``pacer(step, codes)`` fits :func:`bhr._run.driver.follow`'s
    ``on_step``. ``sent`` counts acknowledged rows, ``faults`` collects every
    fault name the board reported, ``fault_events`` the (step, name) pairs.
    """

    def __init__(self, link: BoardLink, rate: float = 10.0, heartbeat: float = DEFAULT_HEARTBEAT,
                 times: Sequence[float] | None = None,
                 on_fault: Callable[[int, list[str]], None] | None = None, known_faults: Sequence[str] = (),
                 wait_relaxed: bool = False, held: Sequence[int] | None = None) -> None:
        if not rate or not np.isfinite(rate) or rate <= 0:
            raise BhrError(f"rate must be a positive number of rows per second, got {rate}")
        self.link = link
        self.period = 1.0 / float(rate)
        self.times = None if times is None else [float(t) for t in times]
        self.heartbeat = heartbeat
        self.sent = 0
        self.faults: list[str] = []
        self.fault_events: list[tuple[int, str]] = []
        self.on_fault = on_fault
        self._t0: float | None = None
        self._seen: set[str] = set(known_faults)  # latched before the stream: not news
        self.wait_relaxed = wait_relaxed
        # the codes the board holds before the first row (a stream before it ended with --at-end hold): a first row
        # that switches one of their wires off starts its relaxation, which a later row re-energising it waits for
        self._last: list[int] | None = None if held is None else [int(c) for c in held]
        self._released: dict[tuple[int, int], float] = {}

    def send(self, codes: Sequence[int]) -> None:
        """Wait until the next row is due, then send ``codes`` (one per module, base first)."""
        if self._t0 is not None:
            # Each row waits its planned gap after the row before it was actually sent: a late row never
            # shortens the next gap (the wires' relaxation counts from the release).
            k = self.sent
            gap = self.period if self.times is None or k >= len(self.times) else self.times[k] - self.times[k - 1]
            due = self._t0 + max(gap, 0.0)
            while True:
                now = time.monotonic()
                if now >= due:
                    break
                if self.heartbeat and due - now > self.heartbeat:
                    time.sleep(self.heartbeat)
                    self._refuse_silence(self.link.heartbeat(), f"before step {self.sent + 1}")
                else:
                    time.sleep(due - now)
        codes = [int(c) for c in codes]
        if self.wait_relaxed and self._last is not None:
            # modules asked to energise a wire that was switched off recently (it may still be relaxing)
            now = time.monotonic()
            recent = [m for m, (c, p) in enumerate(zip(codes, self._last), start=1)
                      if any(now - self._released.get((m, b), -1e9) < 10.0 for b in range(4) if (c & ~p) >> b & 1)]
            if recent:
                self._await_relaxed(recent)
        names = self.link.set_codes(codes)
        # the next gap counts from the ACK: the board had the row by then (a retry, after a lost frame or a late
        # answer on a busy machine, gives it to the board later than the first try was sent)
        self._t0 = time.monotonic()
        if self._last is not None:
            for m, (c, p) in enumerate(zip(codes, self._last), start=1):
                for b in range(4):
                    if (p & ~c) >> b & 1:
                        self._released[(m, b)] = self._t0
        self._last = codes
        self.sent += 1
        self._refuse_silence(names, f"at step {self.sent}")
        if any(f != "silence" for f in names):
            # latched faults: the ACK has no module detail, so ask (only while the board reports a fault)
            detail = [f for f in self.link.status()["faults"] if f != "silence"]
            gone = [f for f in names if f in LATCHED and f not in {d.split(":")[0] for d in detail}]
            if gone:  # a latched fault stays until stop-all: an ACK that says one and a status that lacks it lie
                raise self.link._lie("STATUS", f"the ACK of step {self.sent} said {', '.join(gone)}, the status "
                                     "right after does not, though it stays until stop-all", P.Msg.STATUS)
            fresh = [f for f in detail if f not in self._seen and f.split(":")[0] != "cooling"]
            self._seen.update(detail)
            for f in fresh:
                self.fault_events.append((self.sent, f))
            hot = [f for f in fresh if f.split(":")[0] == "overheat"] or \
                [f for f in names if f == "overheat" and not any(k.startswith("overheat") for k in self._seen)]
            if fresh and self.on_fault is not None and not hot:  # an overheat is said by the one line below
                self.on_fault(self.sent, fresh)
            if hot:
                # the last line of defence fired: a planned stream never gets here, so the plan is wrong
                raise StreamStopped(f"board on {self.link.port} reports {', '.join(hot)} at step {self.sent}: a wire "
                                    "reached the thermal limit; the stream is stopped; let the wires cool (bhr status) "
                                    "and check the robot file's [thermal] table against the wires")
        for f in names:
            if f not in self.faults:
                self.faults.append(f)

    def _refuse_silence(self, names: list[str], when: str) -> None:
        """"silence" once the stream is under way: the board switched every wire off (it clears the flag on each
        row it accepts, so a healthy board never reports it then): the procedure did not happen, the stream stops."""
        if "silence" in names:
            raise StreamStopped(f"board on {self.link.port} reports silence {when}: it switched every wire off "
                                "during the stream, so the procedure did not happen as planned; the stream is "
                                "stopped; check the board and its link (bhr status), then stream again")

    def _await_relaxed(self, modules: list[int], timeout: float = 10.0) -> None:
        end = time.monotonic() + timeout
        while True:
            busy = set(self.link.status(detail=True)["relaxing"]) & set(modules)
            if not busy:
                return
            if time.monotonic() + 0.01 > end:
                names = ", ".join(f"m{m}" for m in sorted(busy))
                raise LinkError(f"board on {self.link.port} still reports module {names} relaxing {timeout:g} s after "
                                f"the wire was released (the model relaxes it in seconds); check the robot file's "
                                "[thermal] table against the wires, and the board")
            time.sleep(0.01)

    def __call__(self, step: int, codes: Sequence[int] | None) -> None:
        if codes is None:
            raise BhrError("this solver gives no module codes, so nothing can be sent to the board; use "
                           "--solver thesis, optimal, or constrained with --limit binary --axes local")
        self.send(codes)


def check_board(link: BoardLink, modules: int) -> dict:
    """Ask the board for its status and check it drives ``modules`` modules; return the status."""
    doc = link.status()
    if len(doc["codes"]) != modules:
        raise LinkError(f"board on {link.port} drives {len(doc['codes'])} modules but the robot has {modules}; "
                        f"use --modules {len(doc['codes'])} or build the firmware with "
                        f"'make -C firmware MODULES={modules}'")
    return doc


def interrupted(link: BoardLink, sent: int) -> StreamInterrupted:
    """After Ctrl-C: send stop-all (one retry) and describe what happened."""
    stopped, detail = False, ""
    if link.is_open:
        try:
            link.stop_all(retries=1)
            stopped = True
        except BhrError as exc:
            detail = str(exc)
    return StreamInterrupted(stopped, sent, detail)


@dataclass
class StreamReport:
    """What a stream did: rows acknowledged of the total, the faults the board raised, and how it ended."""

    sent: int
    total: int
    fault_events: list[tuple[int, str]]
    elapsed_s: float
    ended: str  # "stop": stop-all after the last row; "hold": a heartbeat left the last codes on; "": nothing


AT_END = ("stop", "hold")


def run_stream(link: BoardLink, codes, rate: float = 10.0, *, times: Sequence[float] | None = None,
               start: int = 0, progress: Callable[[int, int], None] | None = None,
               heartbeat: float = DEFAULT_HEARTBEAT, on_fault: Callable[[int, list[str]], None] | None = None,
               known_faults: Sequence[str] | None = None, wait_relaxed: bool = False, wait_ready: bool = False,
               at_end: str | None = None) -> StreamReport:
    """Stream rows of codes to the board: the one streaming loop of bhr (``bhr stream``, ``bhr follow --port``).

    Every code is validated before the first frame. ``wait_ready``: first
    wait (at most READY_TIMEOUT s) until no module is cooling or relaxing,
    and take the faults latched before the stream from a status
    (``known_faults``, not news). Rows are paced by :class:`Pacer` (never
    faster than ``rate`` or the planned ``times``, heartbeats while waiting).
    ``progress(done, total)`` after each acknowledged row. After the last row,
    ``at_end``: "stop" sends stop-all, "hold" a heartbeat (the board keeps the
    codes until its silence timeout), None nothing.

    Ctrl-C sends stop-all (one retry) and raises :class:`StreamInterrupted`.
    A link failure, an impossible reply or an overheat ends the stream with
    LinkError, one line saying how far it got and whether stop-all was
    acknowledged (it is tried once wherever the port still works).
    """
    if at_end is not None and at_end not in AT_END:
        raise BhrError(f"at_end must be one of {', '.join(AT_END)}, got {at_end!r}")
    table = validate_codes(codes)
    total = table.shape[0]
    planned = None if times is None else [float(t) for t in list(times)[start:]]
    if planned:
        planned = [t - planned[0] for t in planned]
    pacer: Pacer | None = None
    held = None
    t0 = time.monotonic()
    try:
        if wait_ready:
            wait_until_ready(link)
            doc = link.status()
            held = doc["codes"] if len(doc["codes"]) == table.shape[1] else None
            if known_faults is None:
                known_faults = doc["faults"]
        if link.modules is not None and table.shape[1] != link.modules:
            # the board said how many modules it drives: a row of another length would only be refused row by row
            raise LinkError(f"board on {link.port} drives {link.modules} modules but the codes have {table.shape[1]} "
                            f"per row; use codes for {link.modules} modules or build the firmware with "
                            f"'make -C firmware MODULES={table.shape[1]}'")
        pacer = Pacer(link, rate, heartbeat, times=planned, on_fault=on_fault, known_faults=known_faults or (),
                      wait_relaxed=wait_relaxed, held=held)
        t0 = time.monotonic()
        for i in range(start, total):
            pacer.send(table[i].tolist())
            if progress is not None:
                progress(pacer.sent, total - start)
        elapsed = time.monotonic() - t0
        if at_end == "stop":
            link.stop_all()
        elif at_end == "hold":
            link.heartbeat()
    except KeyboardInterrupt:
        raise interrupted(link, pacer.sent if pacer else 0) from None
    except LinkError as exc:
        sent = pacer.sent if pacer else 0
        raise type(exc)(f"{with_stop_all(link, str(exc))} (after {sent} of {total - start} rows)") from None
    return StreamReport(pacer.sent, total - start, list(pacer.fault_events), elapsed, at_end or "")


def stream_codes(link: BoardLink, codes, rate: float = 10.0, progress: Callable[[int, int], None] | None = None,
                 heartbeat: float = DEFAULT_HEARTBEAT, start: int = 0, times: Sequence[float] | None = None,
                 on_fault: Callable[[int, list[str]], None] | None = None, known_faults: Sequence[str] = (),
                 wait_relaxed: bool = False) -> int:
    """Send each row of ``codes`` (steps x modules) at ``rate`` rows per second; return the rows sent.

    :func:`run_stream` with nothing sent after the last row (the board keeps
    those codes until its silence timeout).
    """
    return run_stream(link, codes, rate, times=times, start=start, progress=progress, heartbeat=heartbeat,
                      on_fault=on_fault, known_faults=known_faults, wait_relaxed=wait_relaxed).sent
