"""Progress where there is no terminal: long commands whose stderr is a pipe or a file write a plain progress line
every BHR_PROGRESS_INTERVAL seconds (30 by default; 0: when the work starts and at every step)."""
from __future__ import annotations

import os
import re
import subprocess

from tests.conftest import PROGRESS, bhr_exe


def _run(args, cwd, interval: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, MPLBACKEND="Agg", BHR_PROGRESS_INTERVAL=interval)
    return subprocess.run(bhr_exe() + args, cwd=cwd, capture_output=True, text=True, timeout=600, env=env)


def test_a_piped_sweep_writes_a_line_when_it_starts_and_at_every_step(tmp_path):
    r = _run(["sweep", "--traj", "line", "--grid", "modules=3:6", "--jobs", "2", "--no-plots", "--out", "o"],
             tmp_path, "0")
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if not ln.startswith("Compiling bhr's")]
    assert [re.sub(r", \d+ s$", "", ln) for ln in lines] == [f"Running 4 designs: {k}/4" for k in range(5)], lines
    assert all(PROGRESS.match(ln) for ln in lines) and "\r" not in r.stderr


def test_a_piped_traverse_writes_progress_lines_while_it_runs(tmp_path):
    # a line every 0.01 s: however fast or busy the machine, the study lasts longer than that (its workers start)
    r = _run(["traverse", "--head-only", "--grid", "alpha=10", "--colons", "1-2", "--no-plots", "--jobs", "2", "--out", "o"],
             tmp_path, "0.01")
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if not ln.startswith("Compiling bhr's")]
    assert lines and all(re.fullmatch(r"2 runs \(1 designs x 2 colons\): [0-2]/2, \d+ s", ln) for ln in lines), lines
    assert "2 runs (1 designs x 2 colons)" in r.stdout


def test_short_work_and_quick_commands_write_no_progress_in_a_log(tmp_path):
    # statuses of short work (a comparison of solvers, drawing figures, the first compile) stay on the terminal
    r = _run(["compare", "--traj", "line", "--solver", "thesis", "--solver", "fabrik", "--out", "o"], tmp_path, "0")
    assert r.returncode == 0 and [ln for ln in r.stderr.splitlines() if not ln.startswith("Compiling")] == []
