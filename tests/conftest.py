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
# Every test belongs to one layer, so that a fast subset can run alone (README, "Tests"):
#   unit         the library in-process: kernels against their numpy references, models, readers, API
#   thesis       the thesis's published figures (chapters 5-7), pinned bit for bit
#   cli          the `bhr` commands, run as a user runs them
#   integration  real outside parts: firmware built with avr-gcc and run in simavr, serial ptys, Chromium, Dask
_LAYER = {
    "test_solve_chapter5.py": "thesis", "test_constrained_chapter6.py": "thesis", "test_follow_chapter7.py": "thesis",
    "test_cli_basics.py": "cli", "test_bad_input.py": "cli", "test_report.py": "cli", "test_sweep.py": "cli",
    "test_compare.py": "cli", "test_replay.py": "cli", "test_animate.py": "cli", "test_startup.py": "cli",
    "test_bench.py": "cli", "test_hostile.py": "cli",
    "test_firmware_host.py": "integration", "test_firmware_sim.py": "integration",
    "test_firmware_thermal.py": "integration", "test_link.py": "integration",
    "test_liveview.py": "integration", "test_report_browser.py": "integration",
    "test_view_browser.py": "integration", "test_physics_replay.py": "integration", "test_warmup.py": "integration",
    "test_dask_faults.py": "integration",
}
_INTEGRATION_FIXTURES = {"dask_cluster"}


def pytest_collection_modifyitems(config, items):
    for item in items:
        folder = item.path.parent.name  # the new layout: tests/unit, tests/cli, tests/thesis, tests/integration
        layer = folder if folder in ("unit", "cli", "thesis", "integration") else _LAYER.get(item.path.name, "unit")
        fixtures = set(getattr(item, "fixturenames", ()))
        if fixtures & _INTEGRATION_FIXTURES:
            layer = "integration"
        elif layer == "unit" and "run_bhr" in fixtures:
            layer = "cli"
        item.add_marker(getattr(pytest.mark, layer))

# A command that had to compile starts the other commands' kernels compiling in the background
# (bhr.warmup); tests run many fresh caches, so they turn it off (test_startup checks it).
os.environ.setdefault("BHR_NO_BACKGROUND_COMPILE", "1")
