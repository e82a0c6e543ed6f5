"""How the bhr program ends (bhr.cli.main.run): the command's exit status, the exit handlers run, the output
flushed, and Python's own exit where a thread still runs."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest


def _run(code: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, capture_output=True, text=True,
                          timeout=120)


@pytest.mark.parametrize("argv, status", [(["--version"], 0), (["fk", "--codes", "3,0,7"], 1),
                                          (["follow", "--bogus"], 2)])
def test_the_exit_status_the_handlers_and_the_buffered_output_survive(tmp_path, argv, status):
    r = _run(f"""
        import atexit, sys
        atexit.register(lambda: open("handler-ran", "w").write("yes"))
        sys.stdout.write("buffered, not yet flushed")  # written by the command's process, flushed at exit
        sys.argv = ["bhr"] + {argv!r}
        from bhr.cli.main import run
        run()
        """, tmp_path)
    assert r.returncode == status, r.stderr
    assert r.stdout.startswith("buffered, not yet flushed")
    assert (tmp_path / "handler-ran").read_text() == "yes"
    assert "Traceback" not in r.stderr


def test_a_thread_still_running_is_waited_for(tmp_path):
    r = _run("""
        import sys, threading, time
        def late():
            time.sleep(0.5)
            open("thread-done", "w").write("yes")
        threading.Thread(target=late).start()
        sys.argv = ["bhr", "--version"]
        from bhr.cli.main import run
        run()
        """, tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "thread-done").read_text() == "yes"


def test_an_exit_message_is_printed_as_python_prints_it(tmp_path):
    r = _run("""
        import sys
        import bhr.cli.main as m
        def main():
            sys.exit("a message, not a status")
        m.main = main
        m.run()
        """, tmp_path)
    assert r.returncode == 1 and r.stderr.strip() == "a message, not a status"
