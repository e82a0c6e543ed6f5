"""Ctrl-C in the bhr command, the pieces that make it hold at any moment (bhr.settings.interrupts): a Ctrl-C
held since start-up (the command started with SIGINT blocked) is delivered once the handler is in place, one during a compiled
extension's initialisation waits until it is done, one after the command has ended changes nothing."""
from __future__ import annotations

import shutil
import signal
import subprocess
import sys
from importlib.machinery import ExtensionFileLoader

import pytest

from bhr.settings import interrupts
from bhr.settings.errors import INTERRUPTED


def _python(code: str, *, blocked: bool = False) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-c", code]
    if blocked:
        env_exe = shutil.which("env")
        assert env_exe is not None
        cmd = [env_exe, "--block-signal=INT"] + cmd
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


def test_a_ctrl_c_held_since_start_up_ends_the_command_once_bhr_is_imported():
    # Python started with SIGINT blocked (env --block-signal=INT); the Ctrl-C comes before bhr is imported
    r = _python("import os, signal, sys; os.kill(os.getpid(), signal.SIGINT); "
                "assert signal.SIGINT in signal.sigpending(); sys.argv[0] = 'bhr'; import bhr; print('went on')",
                blocked=True)
    assert (r.returncode, r.stderr, r.stdout) == (130, "Interrupted.\n", "")


def test_the_command_unblocks_ctrl_c_for_what_it_starts():
    r = _python("import signal, sys; sys.argv[0] = 'bhr'; import bhr; "
                "print(signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, set()))", blocked=True)
    assert (r.returncode, r.stdout.strip()) == (0, "False"), r.stderr


@pytest.mark.parametrize("settled, rc, err", [(False, 130, "Interrupted.\n"), (True, 0, "")])
def test_a_ctrl_c_after_the_command_ended_changes_nothing(settled, rc, err):
    r = _python("import os, signal, sys; sys.argv[0] = 'bhr'; import bhr; from bhr.settings import interrupts; "
                + ("interrupts.settle(); " if settled else "")
                + "os.kill(os.getpid(), signal.SIGINT); import time; time.sleep(0.05); sys.exit(0)")
    assert (r.returncode, r.stderr) == (rc, err)


def _inside_extension_init():
    """A frame as the one an extension module's init runs Python code from (ExtensionFileLoader.exec_module)."""
    def exec_module(self):  # noqa: ARG001 - its local 'self' is what the check looks at
        return sys._getframe()
    return exec_module(ExtensionFileLoader("fake", "/nowhere/fake.so"))


def test_a_ctrl_c_during_an_extensions_init_is_held_then_raised():
    frame = _inside_extension_init()
    assert interrupts._in_extension_init(frame) and not interrupts._in_extension_init(sys._getframe())
    old_alarm = signal.getsignal(signal.SIGALRM)
    try:
        interrupts._on_interrupt(signal.SIGINT, frame)  # held: no KeyboardInterrupt inside the init
        assert INTERRUPTED.is_set() and signal.getsignal(signal.SIGALRM) is interrupts._raise_when_clear
        assert signal.getitimer(signal.ITIMER_REAL)[0] > 0
        signal.setitimer(signal.ITIMER_REAL, 0)
        interrupts._raise_when_clear(signal.SIGALRM, frame)  # still initialising: held again
        assert signal.getitimer(signal.ITIMER_REAL)[0] > 0
        signal.setitimer(signal.ITIMER_REAL, 0)
        with pytest.raises(KeyboardInterrupt):
            interrupts._raise_when_clear(signal.SIGALRM, sys._getframe())
        with pytest.raises(KeyboardInterrupt):  # outside any extension's init: at once, as before
            interrupts._on_interrupt(signal.SIGINT, sys._getframe())
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old_alarm)
        INTERRUPTED.clear()


def test_a_ctrl_c_inside_llvmlites_ctypes_callback_is_held():
    """numba's compile calls back into Python through ctypes (llvmlite's object cache): a KeyboardInterrupt raised
    there was printed as "Exception ignored on calling ctypes callback function" with a traceback."""
    from llvmlite.binding import executionengine

    assert all(hasattr(executionengine.ExecutionEngine, name) for name in interrupts._C_CALLBACKS)
    scope: dict = {"sys": sys}
    for name in interrupts._C_CALLBACKS:
        exec(compile(f"def {name}(self, data):\n    return sys._getframe()\n", executionengine.__file__, "exec"), scope)
        assert interrupts._in_extension_init(scope[name](None, None))
    exec(compile("def other(self, data):\n    return sys._getframe()\n", executionengine.__file__, "exec"), scope)
    assert not interrupts._in_extension_init(scope["other"](None, None))


def test_a_ctrl_c_inside_a_finalizer_is_held():
    class Ref:
        def __del__(self):
            Ref.frame = sys._getframe()

    Ref().__del__()
    assert interrupts._in_extension_init(Ref.frame)


def test_a_ctrl_c_inside_an_imports_module_lock_callback_is_held():
    """importlib drops a module's lock through a weakref callback (``_get_module_lock.<locals>.cb``): a Ctrl-C
    raised there was printed as "Exception ignored in" with a traceback before "Interrupted."."""
    scope: dict = {"sys": sys}
    exec(compile("def cb(ref):\n    return sys._getframe()\n", "<frozen importlib._bootstrap>", "exec"), scope)
    assert interrupts._in_extension_init(scope["cb"](None))
    exec(compile("def cb(ref):\n    return sys._getframe()\n", "elsewhere.py", "exec"), scope)
    assert not interrupts._in_extension_init(scope["cb"](None))


WEAKREF_CALLBACK = (
    "import os, signal, sys, time, weakref; sys.argv[0] = 'bhr'; import bhr\n"
    "class Thing: pass\n"
    "def cb(ref):\n"
    "    os.kill(os.getpid(), signal.SIGINT)\n"
    "    for _ in range(10 ** 6): pass  # the Ctrl-C's KeyboardInterrupt is raised in here, unraisable\n"
    "t = Thing(); r = weakref.ref(t, cb); del t\n"
    "time.sleep(2); print('went on')\n")


def test_a_ctrl_c_that_python_cannot_raise_where_it_arrives_still_ends_the_command():
    """A Ctrl-C whose KeyboardInterrupt is raised where Python can only print it and go on (any weakref callback,
    not only those the frame check knows): the command still ends with "Interrupted." and 130, no traceback."""
    r = _python(WEAKREF_CALLBACK)
    assert (r.returncode, r.stderr, r.stdout) == (130, "Interrupted.\n", ""), r.stderr


def test_other_unraisable_exceptions_are_printed_as_python_prints_them():
    r = _python("import sys, weakref; sys.argv[0] = 'bhr'; import bhr\n"
                "class Thing: pass\n"
                "def cb(ref): raise ValueError('from a callback')\n"
                "t = Thing(); r = weakref.ref(t, cb); del t\nprint('went on')\n")
    assert r.returncode == 0 and r.stdout == "went on\n" and "ValueError: from a callback" in r.stderr


LIBRARY_SWALLOWS = r'''
import os, signal, sys, time
import bhr.output.plots as plots

SIG = getattr(signal, sys.argv[1])


def save_run_plots(*args, **kwargs):  # a library whose callback took the signal's KeyboardInterrupt
    try:
        os.kill(os.getpid(), SIG)
        time.sleep(0.5)  # the handler runs as soon as os.kill returns
    except KeyboardInterrupt:
        raise ValueError("Invalid bounding box") from None  # as matplotlib's renderer reports it
    raise AssertionError("the signal did not arrive")

plots.save_run_plots = save_run_plots
sys.argv = ["bhr", "follow", "--traj", "curve", "--out", "o"]
from bhr.cli.main import run
run()
'''


@pytest.mark.parametrize("sig, status", [("SIGINT", 130), ("SIGHUP", 129), ("SIGTERM", 143)])
def test_a_signal_a_library_turned_into_its_own_error_still_ends_the_command_as_the_signal(tmp_path, sig, status):
    """A signal's KeyboardInterrupt raised inside a library's callback can come back as that library's error
    (seen: SIGHUP while matplotlib drew, "ValueError: Invalid bounding box" and a traceback): still one line."""
    import os

    env = dict(os.environ, MPLBACKEND="Agg")
    res = subprocess.run([sys.executable, "-c", LIBRARY_SWALLOWS, sig], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=300)
    expected = "Interrupted." if sig == "SIGINT" else f"Interrupted by {sig}."
    lines = [ln for ln in res.stderr.splitlines() if not ln.startswith("Compiling bhr's")]
    assert (res.returncode, lines) == (status, [expected]), res.stderr[-1500:]
    assert not (tmp_path / "o").exists()
