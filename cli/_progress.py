"""Progress on stderr, and the first-compile notice.

On a terminal, work that takes a while shows a status line (``label done/total, item, seconds``) redrawn in place;
statuses nest, the innermost is shown. When stderr is not a terminal, long work (``log=True``: a study's runs, a
stream, an animation) writes it as a plain line every ``BHR_PROGRESS_INTERVAL`` seconds (30; 0: at every step).
"""
from __future__ import annotations

import contextlib
import os
import shutil
import sys
import threading
import time
from typing import Any, Iterator

_LOCK = threading.RLock()
_STACK: list[Progress] = []  # the statuses shown, innermost last
_DRAWN = [False]  # a status line is on the terminal


def _write(text: str) -> None:
    with contextlib.suppress(OSError, ValueError, AttributeError):
        sys.stderr.write(text)
        sys.stderr.flush()


def _interval() -> float:
    with contextlib.suppress(ValueError):
        return max(0.0, float(os.environ.get("BHR_PROGRESS_INTERVAL", "30")))
    return 30.0


class Progress:
    """One status; ``update`` it as work is done (``item``: what it is on), or ``set`` it (a (done, total) callback)."""

    def __init__(self, label: str, total: int | None = None) -> None:
        self.label, self.total, self.done, self.item, self.t0 = label, total, 0, "", time.perf_counter()
        self.stopped = threading.Event()
        self.tty = False
        with contextlib.suppress(AttributeError, ValueError):
            self.tty = sys.stderr.isatty() and os.environ.get("TERM") != "dumb"

    def update(self, n: int = 1, item: str | None = None) -> None:
        self.done, self.item = self.done + n, self.item if item is None else item
        if self.tty or _interval() == 0:
            self.draw()

    def set(self, done: int, total: int | None = None) -> None:
        self.total = total or self.total
        self.update(done - self.done)

    def draw(self) -> None:
        with _LOCK:
            if _STACK[-1:] == [self]:
                parts = [f"{self.done}/{self.total}" if self.total else "", self.item,
                         f"{time.perf_counter() - self.t0:.0f} s"]
                line = f"{self.label.rstrip(':')}: " + ", ".join(p for p in parts if p)
                if not self.tty:
                    return _write(line + "\n")
                _write("\r\033[K" + line[:shutil.get_terminal_size().columns - 1])
                _DRAWN[0] = True

    def _tick(self, seconds: float) -> None:
        while not self.stopped.wait(seconds):
            self.draw()


@contextlib.contextmanager
def status(label: str, total: int | None = None, log: bool = False) -> Iterator[Progress]:
    """Show ``label`` (and ``done/total``) while the block runs: on a terminal, and in a log when ``log``."""
    p = start(label, total, log)
    try:
        yield p
    finally:
        stop(p)


def start(label: str, total: int | None = None, log: bool = False) -> Progress:
    """:func:`status` without a block: shown until :func:`stop`."""
    p = Progress(label, total)
    seconds = 0.1 if p.tty else _interval()
    if p.tty or log:
        with _LOCK:
            _STACK.append(p)
            if p.tty or seconds == 0:
                p.draw()  # at once: short work is shown too
        if seconds > 0:
            threading.Thread(target=p._tick, args=(seconds,), daemon=True).start()
    return p


def stop(p: Progress) -> None:
    p.stopped.set()
    with _LOCK:
        if p in _STACK:
            _STACK.remove(p)
        echo("")


def echo(message: str) -> None:
    """A line on stderr (``""``: none) that does not collide with a status line being drawn."""
    with _LOCK:
        if _DRAWN[0]:
            _write("\r\033[K")
            _DRAWN[0] = False
        if message:
            _write(message + "\n")


COMPILE_NOTICE = ("Compiling bhr's kernels for this machine (once; they are cached in {cache}); "
                  "'bhr warmup' compiles every command's kernels at once.")
_announcer: Any = None


def announce_compiles() -> None:
    """From now on, numba's first compile of a bhr kernel (a cache miss) says so in one line. Call it once the
    command's input is checked: it imports numba."""
    global _announcer
    from numba.core import event

    from bhr import _numba

    class Announcer(event.Listener):
        said = False

        def on_start(self, ev: event.Event) -> None:
            func = getattr(ev.data.get("dispatcher"), "py_func", None)
            if not self.said and getattr(func, "__module__", "").startswith("bhr"):
                self.said = True
                echo(COMPILE_NOTICE.format(cache=_numba.configure_cache()))

        def on_end(self, ev: event.Event) -> None:
            pass

    if _announcer is None:
        _announcer = Announcer()
        event.register("numba:compile", _announcer)
