"""Hold under attack: output folders only bhr's own, numbers and bounds checked at the edge, faults said
truthfully, interrupts honoured, no formula and no leak. Every test runs the real `bhr` console script.
"""
from __future__ import annotations

import csv
import io
import json
import os
import resource
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import bhr_exe, bhr_in_process, finish, snapshot, start_bhr, wait_for_stderr

ENV = dict(os.environ, MPLBACKEND="Agg")
BIG = "9" * 400


def bhr(*args, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    """The command in this process (what it does with its input and its files); a test of the process itself
    runs the real ``bhr`` (bhr_exe)."""
    return bhr_in_process(*args, cwd=cwd, env=ENV, timeout=timeout)


def _cpu_seconds() -> float:
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def one_line(r: subprocess.CompletedProcess) -> str:
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip() and not ln.startswith("Compiling bhr's")]
    assert r.returncode != 0 and len(lines) == 1 and "Traceback" not in r.stderr, (r.returncode, r.stderr)
    return lines[0]


# --- output folders ------------------------------------------------------------------------------------------

def test_a_web_projects_folder_is_never_wiped(tmp_path):
    proj = tmp_path / "proj"
    (proj / "src").mkdir(parents=True)
    (proj / "manifest.json").write_text('{"name": "app", "start_url": "/"}')
    (proj / "index.html").write_text("<html></html>")
    (proj / "src" / "app.js").write_text("console.log(1)")
    before = snapshot(tmp_path)
    r = bhr("follow", "--traj", "curve", "--no-plots", "--out", "proj", cwd=tmp_path)
    assert "index.html" in one_line(r) and "no bhr run wrote" in one_line(r)
    assert snapshot(tmp_path) == before


def test_out_dotdot_never_replaces_the_parent(tmp_path):
    parent = tmp_path / "p"
    here = parent / "here"
    assert bhr("follow", "--traj", "line", "--no-plots", "--out", parent, cwd=tmp_path).returncode == 0
    here.mkdir()
    (here / "mine.txt").write_text("x")
    before = snapshot(tmp_path)
    for out in ("..", "."):
        assert "current folder" in one_line(bhr("follow", "--traj", "line", "--no-plots", "--out", out, cwd=here))
    assert snapshot(tmp_path) == before


def test_users_notes_in_a_run_folder_are_kept(tmp_path):
    assert bhr("follow", "--traj", "line", "--no-plots", "--out", "o", cwd=tmp_path).returncode == 0
    (tmp_path / "o" / "notes.txt").write_text("my observations")
    before = snapshot(tmp_path)
    line = one_line(bhr("follow", "--traj", "line", "--no-plots", "--out", "o", cwd=tmp_path))
    assert "notes.txt" in line and "move it out of o" in line
    assert snapshot(tmp_path) == before


def test_a_folder_holding_an_input_is_refused(tmp_path):
    assert bhr("follow", "--traj", "line", "--no-plots", "--out", "o", cwd=tmp_path).returncode == 0
    (tmp_path / "t.csv").write_text("x,y,z\n0,0,0\n0,10,0\n0,20,0\n")
    os.replace(tmp_path / "t.csv", tmp_path / "o" / "t.csv")
    (tmp_path / "b.toml").write_text('[[run]]\nname = "a"\ntraj = "line"\n')
    before = snapshot(tmp_path)
    assert "an input of this run" in one_line(bhr("follow", "--traj", "o/t.csv", "--out", "o", cwd=tmp_path))
    assert "an input of this run" in one_line(bhr("follow", "--traj", "line", "--robot", "o/t.csv", "--out", "o",
                                                  cwd=tmp_path))
    assert snapshot(tmp_path) == before
    os.makedirs(tmp_path / "r")
    os.replace(tmp_path / "b.toml", tmp_path / "r" / "b.toml")
    before = snapshot(tmp_path)
    assert "an input of this run" in one_line(bhr("report", "--file", "r/b.toml", "--out", "r", cwd=tmp_path))
    assert snapshot(tmp_path) == before


def test_traverse_writes_through_the_output_folder(tmp_path):
    args = ["traverse", "--head-only", "--grid", "alpha=20,25", "--colons", "1", "--jobs", "1", "--out", "t"]
    r = bhr(*args, cwd=tmp_path)
    assert r.returncode in (0, 1) and "Traceback" not in r.stderr, r.stderr
    man = json.loads((tmp_path / "t" / "manifest.json").read_text())
    assert man["command"] == "traverse" and "index.html" in man["files"] and "passrate.png" in man["files"]
    (tmp_path / "t" / "index.html").write_text("my own page")  # a changed file is the user's
    before = snapshot(tmp_path)
    assert "index.html" in one_line(bhr(*args, "--no-plots", cwd=tmp_path))
    assert snapshot(tmp_path) == before


def test_rerun_keeps_what_it_does_not_make_again(tmp_path):
    assert bhr("follow", "--traj", "line", cwd=tmp_path).returncode == 0
    folder = (tmp_path / "bhr-out" / "latest").resolve()
    figs = sorted(p.name for p in folder.glob("*.png"))
    assert figs
    r = bhr("follow", "--traj", "line", "--no-plots", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "bhr-out" / "latest").resolve() == folder
    assert sorted(p.name for p in folder.glob("*.png")) == figs
    man = json.loads((folder / "manifest.json").read_text())
    assert sorted(man["carried_over"]) == sorted(figs + ["view.html"]) and set(figs) <= set(man["files"])


def test_study_default_folders_are_named_by_their_settings(tmp_path):
    a = bhr("sweep", "--traj", "line", "--grid", "modules=3,4", "--jobs", "1", "--no-plots", cwd=tmp_path)
    b = bhr("sweep", "--traj", "line", "--grid", "modules=3", "--jobs", "1", "--no-plots", cwd=tmp_path)
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    folders = sorted(p.name for p in (tmp_path / "bhr-out").iterdir() if not p.is_symlink())
    assert len(folders) == 2 and all(f.startswith("sweep-") for f in folders), folders
    assert (tmp_path / "bhr-out" / "latest").resolve().name in folders


# --- numbers and names, checked at the edge --------------------------------------------------------------------

@pytest.mark.parametrize("args, files", [
    (["follow", "--traj", "t.toml", "--out", "o"],
     {"t.toml": f"[[segment]]\ntype = \"straight\"\nlength = {BIG}\n"}),
    (["follow", "--traj", "line", "--robot", "r.toml", "--out", "o"], {"r.toml": f"alpha = {BIG}\n"}),
    (["report", "--file", "b.toml", "--out", "o"],
     {"b.toml": f"[[run]]\nname = \"a\"\ntraj = \"line\"\nmodule_length = {BIG}\n"}),
    (["sweep", "--file", "s.toml", "--out", "o"],
     {"s.toml": f"traj = [\"line\"]\n[grid]\nmodules = [{BIG}]\n"}),
    (["plan", "--codes", "c.csv", "--robot", "r.toml", "--no-plots"],
     {"r.toml": f"[thermal]\nmax_full_ms = {BIG}\n", "c.csv": "step,m1\n1,3\n"}),
    (["plan", "--codes", "c.csv", "--robot", "r.toml", "--no-plots"],
     {"r.toml": f"[codes]\n{BIG} = \"x\"\n", "c.csv": "step,m1\n1,3\n"}),
], ids=["traj-toml", "robot-file", "batch", "sweep-file", "robot-thermal", "robot-codes"])
def test_an_integer_of_any_length_is_refused_cleanly(tmp_path, args, files):
    for n, text in files.items():
        (tmp_path / n).write_text(text)
    before = snapshot(tmp_path)
    line = one_line(bhr(*args, cwd=tmp_path))
    assert "OverflowError" not in line and ("digit" in line or "'999999" in line) and len(line) < 300
    assert snapshot(tmp_path) == before


def test_run_json_numbers_and_codes(tmp_path):
    assert bhr("follow", "--traj", "line", "--no-plots", "--out", "o", cwd=tmp_path).returncode == 0
    doc = json.loads((tmp_path / "o" / "run.json").read_text())
    bad = json.loads(json.dumps(doc))
    bad["robot"]["module_length"] = int(BIG)
    (tmp_path / "big.json").write_text(json.dumps(bad))
    seven = json.loads(json.dumps(doc))
    seven["steps"][0]["codes"][0] = 7  # an unstable code
    (tmp_path / "seven.json").write_text(json.dumps(seven))
    big = one_line(bhr("replay", "big.json", "--out", "r1", cwd=tmp_path))
    assert "digit" in big and big.count("robot: ") == 1  # which table, said once
    assert "stable codes" in one_line(bhr("replay", "seven.json", "--out", "r2", cwd=tmp_path))
    assert not (tmp_path / "r1").exists() and not (tmp_path / "r2").exists()


@pytest.mark.parametrize("option", ["--alpha", "--tol-pos", "--tol-ori", "--stroke"])
def test_denormals_are_refused(tmp_path, option):
    line = one_line(bhr("follow", "--traj", "line", option, "1e-320", "--no-plots", "--out", "o", cwd=tmp_path))
    assert "too small" in line and "JSON" not in line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("colons", ["\uff11-\uff13", "\u0661-\u0663", "1_0"])
def test_colons_are_plain_ascii(tmp_path, colons):
    assert "--colons" in one_line(bhr("traverse", "--colons", colons, "--out", "o", cwd=tmp_path))


def test_a_long_run_name_is_refused_before_any_work(tmp_path):
    (tmp_path / "b.toml").write_text(f'[[run]]\nname = "{"n" * 300}"\ntraj = "line"\n')
    before = _cpu_seconds()
    line = one_line(bhr("report", "--file", "b.toml", cwd=tmp_path))
    after = _cpu_seconds()
    assert "300 characters" in line and "File name too long" not in line and len(line) < 200
    # the command's CPU seconds (it runs in this process, and any worker it started is a child), which a busy
    # machine does not stretch as it stretches wall time
    cpu = after - before
    assert cpu < 30 and not (tmp_path / "bhr-out").exists()


# --- bounds before work ---------------------------------------------------------------------------------------

def test_a_tiny_module_length_is_refused_before_work(tmp_path):
    r = bhr("follow", "--traj", "line", "--module-length", "0.0008", "--no-plots", "--out", "o", cwd=tmp_path,
            timeout=60)
    assert "in memory" in one_line(r) and not (tmp_path / "o").exists()


def test_codes_csv_with_too_many_modules(tmp_path):
    n = 20000
    (tmp_path / "c.csv").write_text("step," + ",".join(f"m{j + 1}" for j in range(n)) + "\n1," + ",".join("3" * n)
                                    + "\n")
    assert "module columns" in one_line(bhr("plan", "--codes", "c.csv", cwd=tmp_path, timeout=60))


def test_plan_of_many_modules_ends_in_bounded_time(tmp_path):
    n = 300
    (tmp_path / "c.csv").write_text("step," + ",".join(f"m{j + 1}" for j in range(n)) + "\n1," + ",".join("3" * n)
                                    + "\n")
    r = bhr("plan", "--codes", "c.csv", cwd=tmp_path, timeout=60)
    assert r.returncode == 0 and "Traceback" not in r.stderr and "1 steps" in r.stdout, r.stderr


@pytest.mark.parametrize("args", [["follow", "--traj", "p.csv", "--out", "o"], ["follow", "--traj", "p.toml"],
                                  ["plan", "--codes", "p.csv"], ["follow", "--traj", "line", "--robot", "p.toml"],
                                  ["report", "--file", "p.toml"], ["replay", "p.csv"]])
def test_a_fifo_as_input_is_refused_not_waited_on(tmp_path, args):
    os.mkfifo(tmp_path / "p.csv")
    os.mkfifo(tmp_path / "p.toml")
    assert "FIFO" in one_line(bhr(*args, cwd=tmp_path, timeout=30))


def test_a_socket_as_input_is_refused(tmp_path):
    s = socket.socket(socket.AF_UNIX)
    s.bind(str(tmp_path / "s.csv"))
    try:
        assert "socket" in one_line(bhr("follow", "--traj", "s.csv", "--out", "o", cwd=tmp_path, timeout=30))
    finally:
        s.close()


# --- faults said truthfully -----------------------------------------------------------------------------------

def _limit_file_size():
    resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


def test_a_full_disk_names_the_output_file(tmp_path):
    r = subprocess.run(bhr_exe() + ["follow", "--traj", "line", "--out", "o"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=300, env=ENV, preexec_fn=_limit_file_size)
    line = one_line(r)
    assert "standard output" not in line and line.startswith("Error: o/"), line
    assert not (tmp_path / "o").exists()


# --- interrupts honoured --------------------------------------------------------------------------------------

@pytest.mark.parametrize("args, ready", [
    (["follow", "--traj", "colon"], "following colon"),
    (["follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen"], "following "),
    (["sweep", "--traj", "colon", "--grid", "modules=3:12", "--grid", "alpha=6:15", "--jobs", "2"],
     "Running 100 designs: 2/100"),  # workers busy
    (["report", "--file", "b.toml", "--jobs", "2"], "Running 4 runs: 1/4"),
    (["traverse", "--head-only", "--colons", "1-8", "--jobs", "2"], ": 1/8"),
], ids=["follow", "follow-anatomy", "sweep", "report", "traverse"])
def test_ctrl_c_at_any_moment(tmp_path, args, ready):
    (tmp_path / "b.toml").write_text("".join(f'[[run]]\nname = "r{k}"\ntraj = "colon"\nmodules = {3 + k}\n'
                                             for k in range(4)))
    p = start_bhr(args, tmp_path)
    read = wait_for_stderr(p, ready)
    os.killpg(p.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole process group
    rc, _, lines = finish(p, read)
    assert rc == 130 and lines == ["Interrupted."], (rc, read)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.toml"]  # no folder, not even bhr-out/


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(x) for x in out.split()]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    return not (stat.exists() and stat.read_text().split(") ")[-1].startswith("Z"))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_no_worker_outlives_a_killed_parent(tmp_path):
    p = subprocess.Popen(bhr_exe() + ["sweep", "--traj", "colon", "--grid", "modules=3:10", "--jobs", "2"],
                         cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=ENV)
    deadline = time.monotonic() + 60
    kids: list[int] = []
    while time.monotonic() < deadline and len(kids) < 2:
        time.sleep(0.5)
        kids = _children(p.pid)
    assert kids, "the sweep started no worker"
    time.sleep(2.0)
    p.kill()
    p.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(k) for k in kids):
        time.sleep(0.2)
    assert not any(_alive(k) for k in kids), kids


# --- no formula, no leak --------------------------------------------------------------------------------------

def test_formula_run_names_are_escaped_in_csv(tmp_path):
    names = ['=HYPERLINK("http://evil","x")', "@SUM(1+1)", "+cmd", "-2+3"]
    (tmp_path / "b.toml").write_text("".join(f"[[run]]\nname = {json.dumps(n)}\ntraj = \"line\"\n" for n in names))
    r = bhr("report", "--file", "b.toml", "--no-plots", "--jobs", "1", "--out", "o", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(io.StringIO((tmp_path / "o" / "summary.csv").read_text(), newline="")))
    assert [row["name"] for row in rows] == ["'" + n for n in names]


def test_a_batch_never_copies_a_files_content_into_the_report(tmp_path):
    secret = "TOKEN-8f2d9c4e1b7a6d3f5e0c2b9a8d7e6f5a4b3c2d1e"
    (tmp_path / "secret.csv").write_text(secret + "\nmore secrets\n")
    (tmp_path / "b.toml").write_text('[[run]]\nname = "a"\ntraj = "secret.csv"\n')
    r = bhr("report", "--file", "b.toml", "--no-plots", "--jobs", "1", "--out", "o", cwd=tmp_path)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    for name in ("summary.csv", "summary.json", "index.html"):
        text = (tmp_path / "o" / name).read_text()
        assert secret[:21] not in text and "more secrets" not in text, name
