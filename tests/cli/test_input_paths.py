"""Every command that reads a file names the path for what it is when it is not a readable file of data.

A character device (/dev/null), a folder, a FIFO, an empty file and a file the user may not read each get one
line saying what the path is and what to give instead, exit status 1 and no traceback; nothing is written.
"""
from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from bhr.cli.main import main
from click.testing import CliRunner

from tests.conftest import bhr_exe, snapshot

# (id, args with {p} for the path): each command and option that takes an input file
READERS = [
    ("import", ["import", "{p}", "--out", "o.csv"]),
    ("import-default-out", ["import", "{p}"]),
    ("import-centerline", ["import", "mesh.stl", "--centerline", "{p}", "--out", "o.csv"]),
    ("follow-traj", ["follow", "--traj", "{p}", "--no-plots", "--out", "o"]),
    ("follow-robot", ["follow", "--traj", "line", "--robot", "{p}", "--no-plots", "--out", "o"]),
    ("compare-traj", ["compare", "--traj", "{p}", "--out", "o"]),
    ("report-file", ["report", "--file", "{p}", "--out", "o"]),
    ("sweep-file", ["sweep", "--file", "{p}", "--out", "o"]),
    ("replay", ["replay", "{p}", "--out", "o"]),
    ("physics", ["physics", "{p}", "--out", "o"]),
    ("plan-codes", ["plan", "--codes", "{p}"]),
    ("stream-codes", ["stream", "--codes", "{p}", "--port", "loop://"]),
]

KINDS = {  # kind -> the words the line must hold
    "device": "is a character device, not a",
    "folder": "is a folder",
    "fifo": "is a FIFO (named pipe), not a",
    "empty": "is empty",
}

# an empty robot file is the thesis's robot (every key has a default: docs/robot-files.md)
ACCEPTED = {("follow-robot", "empty")}


def _make(folder: Path, kind: str, name: str) -> str:
    """A path of ``kind`` named like the input it stands for (the extension each reader expects)."""
    if kind == "device":
        return os.devnull
    p = folder / name
    if kind == "folder":
        p.mkdir()
    elif kind == "fifo":
        os.mkfifo(p)
    else:
        p.write_bytes(b"")
    return name


NAMES = {"import": "colon.stl", "import-default-out": "colon.stl", "import-centerline": "c.csv",
         "follow-traj": "t.csv", "follow-robot": "r.toml", "compare-traj": "t.toml", "report-file": "b.toml",
         "sweep-file": "s.toml", "replay": "run.json", "physics": "run.json", "plan-codes": "codes.csv",
         "stream-codes": "codes.csv"}


CASES = [(rid, args, kind) for rid, args in READERS for kind in sorted(KINDS) if (rid, kind) not in ACCEPTED]


@pytest.mark.parametrize("rid, args, kind", CASES, ids=[f"{rid}-{kind}" for rid, _, kind in CASES])
def test_an_input_that_is_not_a_file_of_data_is_named_for_what_it_is(tmp_path, monkeypatch, rid, args, kind):
    (tmp_path / "mesh.stl").write_text("solid x\nendsolid x\n")  # a mesh whose --centerline is tried
    path = _make(tmp_path, kind, NAMES[rid])
    before = snapshot(tmp_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    res = CliRunner().invoke(main, [a.replace("{p}", path) for a in args])
    err = res.stderr.strip()
    assert res.exit_code == 1, (res.exit_code, err, res.stdout[-300:])
    assert isinstance(res.exception, SystemExit) and "Traceback" not in res.stderr, res.stderr
    assert len(err.splitlines()) == 1, err
    assert KINDS[kind] in err and "no such" not in err and "give" in err, err
    assert snapshot(tmp_path) == before


def _as_user_who_cannot_read(cmd: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """Run ``cmd`` as a user for whom the 000-mode files in ``cwd`` are unreadable: this user when it is not root,
    else root without the capabilities that let it read any file whatever its mode (it still owns the
    interpreter and its venv, wherever they are: CI's venv is in a private temporary folder)."""
    env = {**os.environ, "HOME": str(cwd), "MPLBACKEND": "Agg", "NUMBA_CACHE_DIR": str(cwd / ".numba")}
    if os.geteuid() == 0:
        # util-linux's setpriv (essential in Debian)
        assert shutil.which("setpriv") is not None, "running as root without setpriv (util-linux): install it"
        caps = "-dac_override,-dac_read_search"
        cmd = ["setpriv", "--bounding-set", caps, "--inh-caps", caps, *cmd]
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def test_a_file_the_user_may_not_read_is_named_so(tmp_path):
    work = tmp_path
    exe = bhr_exe() if bhr_exe()[0] != sys.executable else [sys.executable, "-m", "bhr.cli.main"]
    files = {"colon.stl": "solid x\nendsolid x\n", "t.csv": "x,y,z\n0,0,0\n0,0,50\n", "r.toml": "modules = 5\n",
             "b.toml": "[[run]]\nname = 'a'\ntraj = 'line'\n", "codes.csv": "step,m1\n1,3\n"}
    for name, text in files.items():
        (work / name).write_text(text)
        os.chmod(work / name, 0)
    for args in (["import", "colon.stl", "--out", "o.csv"], ["follow", "--traj", "t.csv", "--out", "o"],
                 ["follow", "--traj", "line", "--robot", "r.toml", "--out", "o"],
                 ["report", "--file", "b.toml", "--out", "o"], ["plan", "--codes", "codes.csv"]):
        r = _as_user_who_cannot_read([*exe, *args], work)
        err = r.stderr.strip()
        assert r.returncode == 1 and "Traceback" not in err and len(err.splitlines()) == 1, (args, err)
        assert "ermission denied" in err and "cannot read" in err, (args, err)
        assert sorted(p.name for p in work.iterdir() if not p.name.startswith(".")) == sorted(files), args
        assert all(stat.S_IMODE((work / n).stat().st_mode) == 0 for n in files)
