"""Progress on stderr: one status line, redrawn on a terminal, nothing when piped; the first-compile notice.

Work that can take more than about a second runs inside :func:`status`: on a
terminal a spinner line shows what runs, how far it is (``done/total`` and a
bar when the total is known) and the seconds spent; when stderr is a pipe or
a file nothing is written, so logs stay clean. Statuses nest: the innermost is
shown, and the outer one comes back when it ends.

:func:`announce_compiles` makes the first run on a machine say, in one line,
that numba is compiling the kernels (once: they are cached), and, on a
terminal, which kernel it is compiling.
"""
from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from typing import IO, Iterator

FRAMES = "|/-\\"
BAR = 20


def _stderr() -> IO[str]:
    return sys.stderr


def on_terminal() -> bool:
    """True when progress should be drawn: stderr is a terminal (and TERM is not 'dumb')."""
    try:
        return _stderr().isatty() and os.environ.get("TERM") != "dumb"
    except (AttributeError, ValueError):
        return False


class Progress:
    """One entry of the status line; ``update`` it as work is done."""

    def __init__(self, label: str, total: int | None) -> None:
        self.label = label
        self.total = total
        self.done = 0
        self.item = ""
        self.t0 = time.perf_counter()

    def update(self, n: int = 1, item: str | None = None) -> None:
        self.done += n
        if item is not None:
            self.item = item

    def text(self, frame: str) -> str:
        parts = [frame, self.label]
        if self.total:
            filled = int(BAR * min(self.done, self.total) / self.total)
            parts.append(f"[{'#' * filled}{'-' * (BAR - filled)}] {self.done}/{self.total}")
        if self.item:
            parts.append(self.item)
        parts.append(f"{time.perf_counter() - self.t0:.0f} s")
        return " ".join(parts)


class _Line:
    """The status line: a stack of Progress entries and the thread that redraws the innermost."""

    def __init__(self) -> None:
        self.stack: list[Progress] = []
        self.lock = threading.RLock()
        self.thread: threading.Thread | None = None
        self.wake = threading.Event()
        self.shown = False

    def _draw(self, frame: str) -> None:
        err = _stderr()
        with self.lock:
            if not self.stack:
                return
            width = 79
            try:
                width = max(os.get_terminal_size(err.fileno()).columns - 1, 0) or width
            except (OSError, ValueError, AttributeError):
                pass
            err.write("\r\033[K" + self.stack[-1].text(frame)[:width])
            err.flush()
            self.shown = True

    def clear(self) -> None:
        with self.lock:
            if self.shown:
                err = _stderr()
                err.write("\r\033[K")
                err.flush()
                self.shown = False

    def _run(self) -> None:
        k = 0
        while True:
            with self.lock:
                if not self.stack:
                    self.clear()
                    self.thread = None
                    return
            self._draw(FRAMES[k % len(FRAMES)])
            k += 1
            self.wake.wait(0.1)
            self.wake.clear()

    def push(self, p: Progress) -> None:
        with self.lock:
            self.stack.append(p)
            self._draw(FRAMES[0])  # at once: short work is shown too
            if self.thread is None:
                self.thread = threading.Thread(target=self._run, name="bhr-progress", daemon=True)
                self.thread.start()

    def pop(self, p: Progress) -> None:
        thread = None
        with self.lock:
            if p in self.stack:
                self.stack.remove(p)
            if not self.stack:
                thread = self.thread
                self.wake.set()
        if thread is not None and thread is not threading.current_thread():
            thread.join(1.0)
        with self.lock:
            if not self.stack:
                self.clear()

    def echo(self, message: str) -> None:
        """Print a line above the status line (which is redrawn on its next tick)."""
        with self.lock:
            self.clear()
            err = _stderr()
            err.write(message + "\n")
            err.flush()


LINE = _Line()


@contextlib.contextmanager
def status(label: str, total: int | None = None) -> Iterator[Progress]:
    """Show ``label`` (and ``done/total`` when given) with a spinner while the block runs, on a terminal only."""
    p = Progress(label, total)
    if not on_terminal():
        yield p
        return
    LINE.push(p)
    try:
        yield p
    finally:
        LINE.pop(p)


def echo(message: str) -> None:
    """A line on stderr that does not collide with a status line being drawn."""
    if LINE.stack and on_terminal():
        LINE.echo(message)
    else:
        err = _stderr()
        err.write(message + "\n")
        err.flush()


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
