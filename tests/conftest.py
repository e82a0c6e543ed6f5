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
    beside = Path(sys.executable).parent / "bhr"  # the venv's own command, PATH or not
    exe = str(beside) if os.access(beside, os.X_OK) else shutil.which("bhr")
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


# ------------------------------------------------------------------ layers
# Every test belongs to one layer, its folder, so that a fast subset can run alone (README, "Tests"):
#   tests/unit         the library in-process: kernels against their numpy references, models, readers, API
#   tests/thesis       the thesis's published figures (chapters 5-7), pinned bit for bit
#   tests/cli          the `bhr` commands, run as a user runs them
#   tests/integration  real outside parts: firmware built with avr-gcc and run in simavr, serial ptys, Chromium,
#                      Dask, pinocchio and MuJoCo, the import-contract tool
# The marker is the folder's name. A test outside these folders, or an in-process test that asks for a command
# or a cluster, stops the collection with a line that says where it belongs.
LAYERS = ("unit", "thesis", "cli", "integration")
_NEEDS = {"run_bhr": "cli", "dask_cluster": "integration"}


def pytest_collection_modifyitems(config, items):
    for item in items:
        folder = Path(str(item.path)).resolve().parent
        layer = folder.name if folder.parent == REPO / "tests" else None
        if layer not in LAYERS:
            raise pytest.UsageError(f"{item.nodeid}: a test lives in one of tests/{{{','.join(LAYERS)}}}/ (its layer)")
        fixtures = set(getattr(item, "fixturenames", ()))
        for fixture, home in _NEEDS.items():
            if fixture in fixtures and layer == "unit":
                raise pytest.UsageError(f"{item.nodeid} uses {fixture}: move it to tests/{home}/")
        item.add_marker(getattr(pytest.mark, layer))

# A command that had to compile starts the other commands' kernels compiling in the background
# (bhr.warmup); tests run many fresh caches, so they turn it off (test_startup checks it).
os.environ.setdefault("BHR_NO_BACKGROUND_COMPILE", "1")
