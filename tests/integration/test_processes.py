"""What takes a real second process: a study's workers and signals, a run's stage held by another process, bhr
imported without matplotlib."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tests.unit.test_executor import FRESH_PROCESS
from tests.unit.test_output_folders import HOLD, write_run


def test_workers_start_with_the_signals_blocked_and_this_process_gets_them_back(tmp_path):
    # a Ctrl-C to the terminal's process group is the command's: a worker that took it printed its own traceback.
    # A fresh process: the pool's first lock starts multiprocessing's resource tracker, which unblocked Ctrl-C and
    # SIGTERM in the thread starting the first worker.
    import subprocess
    import sys

    script = tmp_path / "fresh.py"
    script.write_text(FRESH_PROCESS)
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    held = ["SIGHUP", "SIGINT", "SIGTERM"]
    assert r.stdout.splitlines() == [str([held, held, held]), "[]"]


def test_a_dead_runs_stage_is_cleaned_a_live_runs_and_a_users_are_kept(tmp_path):
    """A stage is a live run's while the lock file beside it is held (a real process holds it here); a killed
    run's lock is free (the kernel dropped it), so the next run deletes its stage; a folder that only has a
    stage's name (no lock file beside it) is the user's and kept."""
    def stage(name: str, lock: bool) -> Path:
        (tmp_path / name).mkdir()
        (tmp_path / name / "run.json").write_text("{")
        if lock:
            (tmp_path / f"{name}.lock").write_text("")
        return tmp_path / name

    dead, live, users = stage(".o.bhr-stage-dead", True), stage(".o.bhr-stage-live", True), \
        stage(".o.bhr-stage-999999-abc", False)
    holder = subprocess.Popen([sys.executable, "-c", HOLD, f"{live}.lock"], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        write_run(tmp_path / "o", {"run.json": "1"})
        assert not dead.exists() and not Path(f"{dead}.lock").exists()
        assert (live / "run.json").exists() and (users / "run.json").exists()
    finally:
        holder.communicate("")
    write_run(tmp_path / "o", {"run.json": "2"})  # its run ended without cleaning up (killed): now it goes
    assert sorted(os.listdir(tmp_path)) == [".o.bhr-stage-999999-abc", "o"]


def test_model_and_workspace_load_without_matplotlib():
    code = ("import sys; import bhr, bhr.model.workspace, bhr.model.robot; "
            "bhr.model.workspace.workspace(bhr.Robot(modules=2)).indices(); print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
