"""Shared fixtures: run the real `bhr` console script, and a thesis robot."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


def bhr_exe() -> list[str]:
    exe = shutil.which("bhr")
    if exe is None:  # installed without the scripts folder on PATH: run the entry point module
        return [sys.executable, "-c", "from bhr.cli.main import main; main()"]
    return [exe]


@pytest.fixture
def run_bhr(tmp_path):
    """Run `bhr ARGS...` in a subprocess (cwd = a temporary folder); return CompletedProcess."""

    def run(*args: str, cwd: Path | None = None, timeout: float = 600, input: str | None = None):
        env = dict(os.environ)
        env.setdefault("MPLBACKEND", "Agg")
        return subprocess.run(bhr_exe() + [str(a) for a in args], cwd=cwd or tmp_path, capture_output=True,
                              text=True, timeout=timeout, env=env, input=input)

    return run


def snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    """Names, sizes and mtimes of every file under ``folder`` (to prove nothing changed)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            st = p.stat()
            out[str(p.relative_to(folder))] = (st.st_size, st.st_mtime_ns)
    return out
