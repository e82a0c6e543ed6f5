"""Ctrl-C in the ``bhr`` command: "Interrupted." and exit status 130 at any moment, never a traceback.

:func:`install` replaces Python's default SIGINT handler with one that also
sets :data:`bhr.settings.errors.INTERRUPTED` (so that a KeyboardInterrupt caught
somewhere on the way still ends the command, and no output folder is put in
place once it is set), and a ``sys.excepthook`` for a Ctrl-C that reaches the
top before any command's guard runs (while modules are still importing), and a ``sys.unraisablehook`` for
one raised where Python can only print it and go on (a weakref callback, a finalizer): it is raised again a
few ms later in the command's own code. It
is installed by the command line only: ``bhr/__init__`` calls it first thing
when the running program is the ``bhr`` console script, ``bhr.cli`` otherwise;
a program that imports the library keeps Python's own handling.

A command started with SIGINT *blocked* (``env --block-signal=INT bhr ...``) holds a Ctrl-C during Python's
own start-up and imports, not lost and not a traceback; :func:`install` lets it through once the handler is
in place (a held Ctrl-C then ends the command at once). :func:`settle` is called when the command
has ended: a Ctrl-C from then on, while the interpreter shuts down, changes nothing (the exit status is the
command's), instead of killing the process by the signal after its outputs are written.
"""
from __future__ import annotations

import os
import signal
import sys

from bhr.settings.errors import INTERRUPTED

__all__ = ["install", "is_bhr_command", "release", "settle", "ending"]

_installed = False


def is_bhr_command() -> bool:
    """True when the running program is the ``bhr`` console script."""
    return bool(sys.argv) and os.path.basename(sys.argv[0] or "") in ("bhr", "bhr.exe")


#: llvmlite's ctypes callbacks, which run Python code inside a numba compile (its object cache): ctypes prints a
#: KeyboardInterrupt raised there with a traceback and goes on, so a Ctrl-C waits until it has returned.
_C_CALLBACKS = ("_raw_object_cache_notify", "_raw_object_cache_getbuffer")


def _in_extension_init(frame: object) -> bool:
    """True while a compiled extension module initialises (its init calls Python code), inside a ``__del__``, or
    inside one of llvmlite's ctypes callbacks (:data:`_C_CALLBACKS`):
    a KeyboardInterrupt raised in an init leaves the extension half made (matplotlib's ft2font: "initialization
    failed", then a fatal error and SIGABRT while the interpreter shuts down); one raised in a finalizer is
    printed as "Exception ignored" with a traceback and lost. Either way the Ctrl-C waits a few ms."""
    from importlib.machinery import ExtensionFileLoader

    f = frame
    while f is not None:
        code = getattr(f, "f_code", None)
        if code is None:
            break
        if code.co_name == "cb" and code.co_filename == "<frozen importlib._bootstrap>":
            return True  # the weakref callback of an import's module lock: "Exception ignored in" and lost
        if code.co_name == "__del__":  # a finalizer (llvmlite's ObjectRef): Python would print the
            return True                # KeyboardInterrupt as "Exception ignored in ..." and a traceback
        if code.co_name in _C_CALLBACKS and "llvmlite" in code.co_filename:  # a ctypes callback of numba's
            return True  # compile (the object cache): "Exception ignored on calling ctypes callback function"
        if code.co_name in ("create_module", "exec_module") and isinstance(
                getattr(f, "f_locals", {}).get("self"), ExtensionFileLoader):
            return True
        f = getattr(f, "f_back", None)
    return False


def _raise_when_clear(signum: int, frame: object) -> None:
    """SIGALRM after a deferred Ctrl-C: raise it once no extension module is initialising."""
    if _in_extension_init(frame):
        signal.setitimer(signal.ITIMER_REAL, 0.01)
        return
    signal.signal(signal.SIGALRM, signal.SIG_DFL)
    raise KeyboardInterrupt


#: The signal that interrupted the command (SIGINT unless SIGTERM or SIGHUP came first).
_received: list[int] = []


def ending() -> tuple[str, int]:
    """The line and exit status of an interrupted command: "Interrupted." and 130 for a Ctrl-C; for SIGTERM
    (``kill``) and SIGHUP (a closed terminal), which end the command the same way, the signal's name and
    128 + its number, as a shell reports a command it ended."""
    sig = _received[0] if _received else signal.SIGINT
    if sig == signal.SIGINT:
        return "Interrupted.", 130
    return f"Interrupted by {signal.Signals(sig).name}.", 128 + int(sig)


def _on_interrupt(signum: int, frame: object) -> None:
    if not _received:
        _received.append(signum)
    INTERRUPTED.set()
    if hasattr(signal, "setitimer") and _in_extension_init(frame):  # Ctrl-C held a few ms, not lost
        signal.signal(signal.SIGALRM, _raise_when_clear)
        signal.setitimer(signal.ITIMER_REAL, 0.01)
        return
    raise KeyboardInterrupt


def _unraisablehook(args: object) -> None:
    """A Ctrl-C raised where Python cannot raise it (a weakref callback such as importlib's module-lock ``cb``, a
    finalizer, a ctypes callback, wherever the frame check above does not foresee) would be printed as
    "Exception ignored in ..." with a traceback and lost: it is raised again a few ms later, in the command's
    own code, instead. Any other unraisable exception goes to Python's hook as before."""
    if issubclass(getattr(args, "exc_type", type(None)) or type(None), KeyboardInterrupt):
        try:
            signal.signal(signal.SIGALRM, _raise_when_clear)
            signal.setitimer(signal.ITIMER_REAL, 0.01)
            return
        except (AttributeError, ValueError, OSError):  # not the main thread, or no timers: as Python would
            pass
    _previous_unraisable(args)  # type: ignore[arg-type]


_previous_unraisable = sys.unraisablehook


def _excepthook(kind: type[BaseException], exc: BaseException, tb: object) -> None:
    if issubclass(kind, KeyboardInterrupt):
        line, status = ending()
        try:
            sys.stderr.write(line + "\n")
            sys.stderr.flush()
        except Exception:
            pass
        os._exit(status)
    _previous(kind, exc, tb)  # type: ignore[arg-type]


_previous = sys.excepthook


def release() -> None:
    """Let through a SIGINT, SIGTERM or SIGHUP blocked since start-up (the launcher blocks them: one held until now
    is delivered now)."""
    if hasattr(signal, "pthread_sigmask"):
        try:
            held = signal.pthread_sigmask(signal.SIG_BLOCK, set()) & {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
            if held:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, held)
        except (OSError, ValueError):
            pass


def install() -> None:
    """Install the handler and the hook (once; in the main thread; not under pytest): for Ctrl-C unless it is
    ignored (a background job), for SIGTERM and SIGHUP unless they are (nohup)."""
    global _installed
    if _installed or "pytest" in sys.modules:
        return
    try:
        # SIG_IGN: a background job, where Ctrl-C is not the command's (SIG_DFL: Python's own not yet put); its
        # SIGTERM and SIGHUP are still the command's (kill %1 of `bhr sweep ... &` ends it as a Ctrl-C would)
        ctrl_c = signal.getsignal(signal.SIGINT) in (signal.default_int_handler, signal.SIG_DFL)
        # SIGTERM and SIGHUP end the command as a Ctrl-C does (its outputs are not put in place, its staging
        # folders and workers go), unless they were ignored when it started (nohup)
        others = [s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None))
                  if s is not None and signal.getsignal(s) == signal.SIG_DFL]
        if not ctrl_c and not others:
            return
        sys.excepthook = _excepthook
        sys.unraisablehook = _unraisablehook
        if ctrl_c:
            signal.signal(signal.SIGINT, _on_interrupt)
        for other in others:
            signal.signal(other, _on_interrupt)
    except ValueError:  # not the main thread
        return
    _installed = True


def settle() -> None:
    """The command has ended: from now on a Ctrl-C changes nothing (no traceback, no death by signal at exit)."""
    if not _installed:
        return
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        for other in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)):
            if other is not None and signal.getsignal(other) is _on_interrupt:
                signal.signal(other, signal.SIG_IGN)
        if hasattr(signal, "setitimer") and signal.getsignal(signal.SIGALRM) is _raise_when_clear:
            signal.setitimer(signal.ITIMER_REAL, 0)  # a deferred Ctrl-C (the flag is already set)
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
    except (ValueError, OSError):
        pass
