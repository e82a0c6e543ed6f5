"""Progress on stderr: a status line redrawn on a terminal, plain lines in a log; the first-compile notice.

Work that can take more than about a second runs inside :func:`status`. On a terminal a status line shows what
runs, ``done/total`` with a bar when the total is known, and the seconds spent, redrawn in place; statuses nest,
the innermost is shown. When stderr is a pipe or a file, the statuses of long work (``log=True``: a study's runs,
a stream, a replay) write a plain line every ``BHR_PROGRESS_INTERVAL`` seconds (30; 0: when the work starts and at
every step), so that a log shows the command is alive.

:func:`announce_compiles` makes the first run on a machine say, in one line, that numba is compiling the kernels
(once: they are cached), and, on a terminal, which kernel it is compiling.
"""
from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from typing import Iterator

_LOCK = threading.RLock()
_WAKE = threading.Event()
_STACK: list[Progress] = []  # the statuses shown, innermost last
_DRAWN = [False]  # a status line is on the terminal


def on_terminal() -> bool:
    """True when the status line is drawn: stderr is a terminal (and TERM is not 'dumb')."""
    with contextlib.suppress(AttributeError, ValueError):
        return sys.stderr.isatty() and os.environ.get("TERM") != "dumb"
    return False


def _interval() -> float:
    with contextlib.suppress(ValueError):
        return max(0.0, float(os.environ.get("BHR_PROGRESS_INTERVAL", "30")))
    return 30.0


def _write(text: str) -> None:
    with contextlib.suppress(OSError, ValueError):
        sys.stderr.write(text)
        sys.stderr.flush()


class Progress:
    """One status; ``update`` it as work is done (``item``: what it is on), or ``set`` it (a (done, total) callback)."""

    def __init__(self, label: str, total: int | None = None) -> None:
        self.label, self.total, self.done, self.item, self.t0 = label, total, 0, "", time.perf_counter()
        self.tty = on_terminal()

    def update(self, n: int = 1, item: str | None = None) -> None:
        self.done += n
        self.item = self.item if item is None else item
        if self.tty or _interval() == 0:  # a terminal shows every step; a log too when asked to
            self.draw()

    def set(self, done: int, total: int | None = None) -> None:
        self.total = total or self.total
        self.update(done - self.done)

    def draw(self) -> None:
        """Its status line (over the one drawn), or its line in a log: ``label: done/total, item, seconds``."""
        with _LOCK:
            if _STACK[-1:] != [self]:
                return
            parts = [f"{self.done}/{self.total}" if self.total else "", self.item,
                     f"{time.perf_counter() - self.t0:.0f} s"]
            if not self.tty:
                return _write(f"{self.label.rstrip(':')}: " + ", ".join(p for p in parts if p) + "\n")
            if self.total:
                filled = int(20 * min(self.done, self.total) / self.total)
                parts[0] = f"[{'#' * filled}{'-' * (20 - filled)}] {parts[0]}"
            width = 79
            with contextlib.suppress(OSError, ValueError):
                width = max(os.get_terminal_size(sys.stderr.fileno()).columns - 1, 0) or width  # 0: no size known
            _write("\r\033[K" + " ".join([self.label, *(p for p in parts if p)])[:width])
            _DRAWN[0] = True

    def _tick(self, seconds: float) -> None:
        while self in _STACK:
            _WAKE.wait(seconds)
            self.draw()


def clear() -> None:
    with _LOCK:
        if _DRAWN[0]:
            _write("\r\033[K")
            _DRAWN[0] = False


@contextlib.contextmanager
def status(label: str, total: int | None = None, log: bool = False) -> Iterator[Progress]:
    """Show ``label`` (and ``done/total`` when given) while the block runs: on a terminal, and in a log when
    ``log`` (see the module's text)."""
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
            threading.Thread(target=p._tick, args=(seconds,), name="bhr-progress", daemon=True).start()
    return p


def stop(p: Progress) -> None:
    with _LOCK:
        if p in _STACK:
            _STACK.remove(p)
        clear()
    _WAKE.set()  # its thread ends now
    _WAKE.clear()


def echo(message: str) -> None:
    """A line on stderr that does not collide with a status line being drawn."""
    with _LOCK:
        clear()
        _write(message + "\n")


# ---------------------------------------------------------------------------
# the first compile

COMPILE_NOTICE = ("Compiling bhr's kernels for this machine; this happens once (they are cached in {cache}), "
                  "later runs start at once. When this command ends, the kernels of the other commands are "
                  "compiled in the background ({env}=1 turns that off).")
#: The notice when the background compile is turned off: other commands then compile their own kernels.
COMPILE_NOTICE_ALONE = ("Compiling bhr's kernels for this machine; this happens once for each kernel (they are cached "
                        "in {cache}): this command starts at once next time, and another command compiles the "
                        "kernels it adds the first time it runs ({env} is set, so nothing is compiled in the "
                        "background; 'python -m bhr.warmup' compiles them all now).")


def compile_notice() -> str:
    """The first-compile line, true to what happens next: the other commands' kernels compiled in the background
    (:func:`bhr.warmup.start_in_background`) or not (BHR_NO_BACKGROUND_COMPILE set)."""
    from bhr import _numba
    from bhr.warmup import BACKGROUND_ENV, background_enabled

    text = COMPILE_NOTICE if background_enabled() else COMPILE_NOTICE_ALONE
    return text.format(cache=_numba.cache_dir(), env=BACKGROUND_ENV)


_announcer = None
_registered = False


def announce_compiles() -> None:
    """From now on, the first numba compile of a bhr kernel says so in one line, with progress on a terminal.

    Nothing is printed when every kernel comes from numba's on-disk cache
    (numba only fires its compile event on a cache miss).
    """
    global _registered
    if _registered:
        return
    _registered = True

    # numba is imported by the first kernel a command calls, after its input is checked, and its compile event
    # says so at the first compile: a refused input never prints the notice
    from bhr import _numba

    _numba.when_numba_loads(_listen)  # numba's compile event, once the first kernel imports numba
    from bhr.warmup import background_enabled

    # every kernel is compiled in the background when this command ends: a kernel whose cache is cold may run
    # interpreted now where that costs less than compiling it (bhr._numba.call_cold)
    if background_enabled():
        _numba.allow_interpreting()
    import atexit

    atexit.register(_compile_the_rest)


def _listen() -> None:
    """Register the compile listener (numba's compile event), once numba is imported for the first kernel."""
    global _announcer
    from numba.core import event

    class Announcer(event.Listener):
        def __init__(self) -> None:
            self.depth = 0
            self.announced = False
            self.kernels = 0
            self.progress: Progress | None = None
            self.cm: contextlib.AbstractContextManager[Progress] | None = None

        def on_start(self, ev: event.Event) -> None:
            disp = ev.data.get("dispatcher")
            func = getattr(disp, "py_func", None)
            ours = func is not None and getattr(func, "__module__", "").startswith("bhr")
            if self.depth == 0 and ours:
                if not self.announced:
                    self.announced = True
                    echo(compile_notice())
                self.cm = status("compiling kernels:")
                self.progress = self.cm.__enter__()
            if self.progress is not None and func is not None and ours:
                self.progress.item = f"{func.__name__} ({self.kernels} done)"
            self.depth += 1

        def on_end(self, ev: event.Event) -> None:
            self.depth -= 1
            func = getattr(ev.data.get("dispatcher"), "py_func", None)
            if func is not None and getattr(func, "__module__", "").startswith("bhr"):
                self.kernels += 1
                if self.progress is not None:
                    self.progress.item = f"{self.kernels} done"
            if self.depth == 0 and self.cm is not None:
                cm, self.cm, self.progress = self.cm, None, None
                cm.__exit__(None, None, None)

    _announcer = Announcer()
    event.register("numba:compile", _announcer)


def _compile_the_rest() -> None:
    """After a command that had to compile: compile every other command's kernels in the background, once."""
    from bhr import _numba

    if (_announcer is None or not _announcer.kernels) and not _numba.interpreted_any():
        return
    from bhr.warmup import start_in_background

    start_in_background()
