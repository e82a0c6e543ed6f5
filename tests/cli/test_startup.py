"""The command line loads heavy modules only when a command needs them, and numba compiles once."""
import os
import subprocess
import sys

import pytest

CHECK = """
import sys
from bhr.cli.main import main
_err = None
try:
    main({args!r}, standalone_mode=False)
except (SystemExit, Exception) as exc:  # a failing command still shows what it loaded
    _err = type(exc).__name__
print(sorted(m for m in ("numba", "matplotlib", "serial", "quaternion", "numpy", "bhr._hardware.link")
             if m in sys.modules))
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


def test_follow_loads_the_kernels_of_its_own_solver_and_model_only(tmp_path):
    """The thesis's solver on the built-in colon (a tube lumen, the thesis's locomotion) loads neither the other
    solvers' modules nor the trail model nor the wall mesh's (each module's kernels cost their set-up at import)."""
    others = ("bhr.solvers._optimal", "bhr.solvers._lumen", "bhr.solvers._trail", "bhr._run.trail",
              "bhr.model._wallmesh")
    check = CHECK.replace('("numba", "matplotlib", "serial", "quaternion", "numpy", "bhr._hardware.link")',
                          repr(others + ("bhr.solvers._thesis",)))
    out = subprocess.run([sys.executable, "-c", check.format(args=["follow", "--traj", "colon", "--no-plots",
                                                                    "--out", "o"])],
                         capture_output=True, text=True, cwd=tmp_path, check=True)
    assert out.stdout.strip().splitlines()[-1] == "['bhr.solvers._thesis']"
    assert (tmp_path / "o" / "run.json").is_file()


def test_board_commands_load_the_serial_stack_and_no_numba(tmp_path):
    # no board answers on loop:// (the command fails after its one try): only what it loaded matters here
    args = ["status", "--port", "loop://", "--timeout", "0.01", "--retries", "0"]
    assert loaded(args, tmp_path) == "['bhr._hardware.link', 'numpy', 'serial']"


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


NOTICE = "Compiling bhr's kernels for this machine (once;"


def test_first_run_says_it_compiles_the_kernels_and_later_runs_do_not(tmp_path):
    from tests.conftest import bhr_exe

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "empty-cache"), MPLBACKEND="Agg")
    cmd = bhr_exe() + ["fk", "--codes", "3,0,6"]
    first = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, env=env, check=True)
    lines = first.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(NOTICE) and str(tmp_path / "empty-cache") in lines[0]
    second = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, env=env, check=True)
    assert second.stderr == "" and second.stdout == first.stdout
    # help and commands that compile nothing never say it
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "other-empty-cache")
    helped = subprocess.run(bhr_exe() + ["follow", "--help"], capture_output=True, text=True, env=env, check=True)
    assert NOTICE not in helped.stderr + helped.stdout


@pytest.mark.parametrize("args", [["follow", "--traj", "colon", "--solver", "thesus"], ["bench", "--case", "nope"],
                                  ["fk", "--codes", "3,0,7"]])
def test_a_refused_input_on_a_first_run_prints_its_error_only(tmp_path, args):
    """Nothing is compiled for an input that is refused, so the first run's compile notice is not printed."""
    from tests.conftest import bhr_exe

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "empty-cache"), MPLBACKEND="Agg")
    out = subprocess.run(bhr_exe() + args, cwd=tmp_path, capture_output=True, text=True, env=env)
    assert out.returncode != 0
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error:") and NOTICE not in out.stderr, out.stderr


def run_on_a_terminal(args, cwd, env):
    """Run bhr with stderr on a pseudo-terminal; return everything written there."""
    import pty
    import select

    from tests.conftest import bhr_exe

    master, slave = pty.openpty()
    proc = subprocess.Popen(bhr_exe() + args, cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=slave)
    os.close(slave)
    out = b""
    while True:
        r, _, _ = select.select([master], [], [], 0.5)
        if r:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # the child closed the terminal
                break
            if not chunk:
                break
            out += chunk
        elif proc.poll() is not None:
            break
    proc.wait(600)
    os.close(master)
    return proc.returncode, out.decode(errors="replace")


def test_progress_is_drawn_on_a_terminal_and_not_when_piped(tmp_path):
    from tests.conftest import bhr_exe

    env = dict(os.environ, MPLBACKEND="Agg", TERM="xterm")
    args = ["follow", "--traj", "line", "--out", "o"]
    code, text = run_on_a_terminal(args, tmp_path, env)
    assert code == 0
    assert "following line (36 steps, solver thesis)" in text and "drawing the figures into o" in text
    assert "\r\x1b[K" in text  # the status line is cleared before the summary
    piped = subprocess.run(bhr_exe() + args, cwd=tmp_path, capture_output=True, text=True, env=env, check=True)
    assert "following line" not in piped.stderr and "\r" not in piped.stderr


def test_misspelt_trajectory_is_refused_before_numba_or_numpy_is_imported(tmp_path):
    assert loaded(["follow", "--traj", "colonn"], tmp_path) == "[]"


@pytest.mark.parametrize("args", [
    ["follow", "--traj", "colon", "--solver", "thesus"],
    ["follow", "--traj", "colon", "--modules", "-3"],
    ["follow", "--traj", "colon", "--alpha", "95"],
    ["solve", "--target", "1", "2", "3", "--solver", "x"],
    ["solve", "--target", "1", "2", "3", "--alpha", "0"],
    ["sweep", "--solver", "x"],
    ["traverse", "--solver", "x", "--colons", "1-3", "--grid", "alpha=10"],
    ["fk", "--codes", "3,0,7"],
    ["plan", "--codes", "missing.csv"],
])
def test_bad_input_is_refused_before_numba_or_numpy_is_imported(tmp_path, args):
    out = subprocess.run([sys.executable, "-c", CHECK.format(args=args) + "print(_err)"], capture_output=True,
                         text=True, cwd=tmp_path, env=dict(os.environ, MPLBACKEND="Agg"), check=True)
    *_, modules, error = out.stdout.strip().splitlines()
    assert error.startswith("ClickException")  # refused, in one line (what the check would print)
    assert modules == "[]", (args, error)


def test_trajectory_names_known_without_the_generators_are_the_generators():
    from bhr.model._generators import GENERATORS, builtin_names
    from bhr.model._trajnames import GENERATOR_NAMES
    from bhr.model._trajnames import builtin_names as light_names

    assert tuple(GENERATORS) == GENERATOR_NAMES
    assert builtin_names() == light_names()


def test_bhr_imported_after_numba_still_caches_in_its_own_folder(tmp_path):
    """A notebook or another library may import numba first: numba then read its environment before bhr set
    NUMBA_CACHE_DIR. bhr's kernels are still cached in bhr's folder (keyed by its sources), never beside them."""
    from pathlib import Path

    import bhr
    from bhr import _numba

    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")
    folder = tmp_path / "cache" / "bhr" / "numba" / _numba.source_key()
    tree = Path(bhr.__file__).parent
    before = set(tree.rglob("*.nbi"))
    script = ("import numba\nimport numpy as np\nimport bhr\nfrom bhr._run.motion import ordered_moves\n"
              "out = np.empty(1)\nordered_moves(np.zeros((1, 3)), np.ones((1, 1, 3)), np.zeros(1, np.int64), out)\n"
              "print(numba.config.CACHE_DIR, out[0])\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=tmp_path,
                         check=True)
    cache_dir, move = out.stdout.split()
    assert cache_dir == str(folder) and float(move) == pytest.approx(3 ** 0.5)
    assert list(folder.rglob("motion.ordered_moves-*.nbi"))
    assert set(tree.rglob("*.nbi")) == before
