"""The command line loads heavy modules only when a command needs them, and numba compiles once."""
import os
import subprocess
import sys

import pytest

CHECK = """
import sys
from bhr.cli.main import main
try:
    main({args!r}, standalone_mode=False)
except (SystemExit, Exception):  # a failing command still shows what it loaded
    pass
print(sorted(m for m in ("numba", "matplotlib", "serial", "quaternion", "numpy") if m in sys.modules))
"""


def loaded(args, cwd):
    out = subprocess.run([sys.executable, "-c", CHECK.format(args=args)], capture_output=True, text=True, cwd=cwd,
                         env=dict(os.environ, MPLBACKEND="Agg"), check=True)
    return out.stdout.strip().splitlines()[-1]


def test_help_imports_nothing_heavy(tmp_path):
    assert loaded(["--help"], tmp_path) == "[]"


def test_follow_without_plots_skips_matplotlib(tmp_path):
    assert loaded(["follow", "--traj", "line", "--no-plots", "--out", "o"], tmp_path) == "['numba', 'numpy']"


def test_follow_with_plots_loads_matplotlib(tmp_path):
    assert loaded(["follow", "--traj", "line", "--out", "o"], tmp_path) == "['matplotlib', 'numba', 'numpy']"


def test_board_commands_load_the_serial_stack_and_no_numba(tmp_path):
    # no board answers on loop:// (the command fails after its one try): only what it loaded matters here
    args = ["status", "--port", "loop://", "--timeout", "0.01", "--retries", "0"]
    assert loaded(args, tmp_path) == "['numpy', 'serial']"


def test_second_run_loads_compiled_code_from_cache(tmp_path, run_bhr):
    env_cache = tmp_path / "cache"
    cmd = [sys.executable, "-m", "bhr.cli.main", "follow", "--traj", "curve", "--no-plots", "--out", "o"]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(env_cache), NUMBA_DEBUG_CACHE="1")
    first = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, env=env, check=True)
    assert "index saved" in first.stdout + first.stderr
    second = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, env=env, check=True)
    log = second.stdout + second.stderr
    assert "data loaded" in log
    assert "index saved" not in log and "data saved" not in log
