"""What takes a real second process: a study's workers and signals, a run's stage held by another process, bhr
imported without matplotlib."""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bhr.output._atomic import MANIFEST
from tests.conftest import foreground
from tests.unit.test_executor import FRESH_PROCESS
from tests.unit.test_output_folders import write_run


def _run_script(folder, text: str) -> subprocess.CompletedProcess:
    """``text`` run as a Python script in a fresh process, started as a shell's foreground job is (whatever this
    test run inherited: nohup, `&`)."""
    script = folder / "script.py"
    script.write_text(text)
    return subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                          preexec_fn=foreground)


def test_workers_ignore_the_signals_and_this_process_keeps_them(tmp_path):
    # a Ctrl-C to the terminal's process group is the command's (it stops its workers): a worker that took it
    # printed its own traceback
    r = _run_script(tmp_path, FRESH_PROCESS)
    assert r.returncode == 0, r.stderr
    ignored = ["SIGHUP", "SIGINT", "SIGTERM"]
    assert r.stdout.splitlines() == [str([ignored, ignored, ignored]), "[] set()"]


INTERRUPTED_STUDY = r'''
import atexit, os, sys, threading, time
from bhr._studies.executor import run_jobs

def slow(job):
    time.sleep(0.2 if job == 0 else 30)
    return job

def stop(done, total, row):
    raise KeyboardInterrupt  # Ctrl-C while the other worker is busy

if __name__ == "__main__":
    try:
        run_jobs(slow, [0, 1], jobs=2, max_chunk=1, progress=stop)
    except KeyboardInterrupt:
        pass
    print(threading.active_count(), flush=True)
    atexit._run_exitfuncs()  # then the process ends as bhr's does, without Python's own tidy-up
    sys.stderr.flush()
    os._exit(0)
'''


def test_a_study_stopped_by_ctrl_c_leaves_no_thread_of_its_workers_running_and_no_semaphore(tmp_path):
    # a worker pool's thread still ending when bhr ended had unlinked a semaphore without telling multiprocessing's
    # resource tracker, which then warned of a leaked semaphore after "Interrupted."
    r = _run_script(tmp_path, INTERRUPTED_STUDY)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["1"]  # only the main thread is left
    assert r.stderr == ""


def test_stages_of_dead_runs_are_cleaned_and_a_users_folder_is_kept(tmp_path):
    """A stage (and the lock file beside it, from older bhr) found by the run that holds the folder's lock is a dead
    run's: deleted. A folder only named like a stage is the user's and kept."""
    dead = tmp_path / ".o.bhr-stage-0123456789ab"
    dead.mkdir()
    (dead / "run.json").write_text("{")
    (tmp_path / f"{dead.name}.lock").write_text("")
    users = tmp_path / ".o.bhr-stage-999999-abc"
    users.mkdir()
    (users / "run.json").write_text("mine")
    write_run(tmp_path / "o", {"run.json": "1"})
    assert sorted(os.listdir(tmp_path)) == [users.name, "o"] and (users / "run.json").read_text() == "mine"


def test_model_and_workspace_load_without_matplotlib():
    code = ("import sys; import bhr, bhr.model._workspace, bhr.model._robot; "
            "bhr.model._workspace.workspace(bhr.Robot(modules=2)).indices(); print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_concurrent_writers_in_real_processes_leave_one_whole_set(tmp_path):
    out = tmp_path / "o"
    for rnd in range(3):
        procs = [writer(out, 10 * rnd + k) for k in range(10)]
        for p in procs:
            _, err = p.communicate(timeout=300)
            assert p.returncode == 0, err
        assert int(whole(out)) in range(10 * rnd, 10 * rnd + 10)
        assert sorted(os.listdir(tmp_path)) == ["o"]  # no stage, lock file or old folder left


# --- real processes: concurrent writers, kill -9 ---------------------------------------------------------------------

WRITER = """
import os, sys, time
from bhr.output._atomic import OutputFolder, write_text
target, tag, pause_at = sys.argv[1], sys.argv[2], sys.argv[3]
n = 3 + int(tag) % 4  # writers write different numbers of files: a mix of two shows
if pause_at == "aside":  # stop between moving the old folder aside and moving the new one in
    def hook(event, args):
        if event == "os.rename" and ".bhr-old-" in os.fspath(args[1]):
            hook.armed = True
        elif event == "os.rename" and getattr(hook, "armed", False):
            print("aside", flush=True)
            time.sleep(600)
    sys.addaudithook(hook)
with OutputFolder(target, "test") as of:
    for k in range(n):
        write_text(of.path(f"f{k}.txt"), (tag + "\\n") * 500)
        if pause_at == "staging" and k == 1:
            print("staging", flush=True)
            time.sleep(600)
"""


def whole(folder: Path) -> str:
    """The tag of the one writer whose set ``folder`` holds, whole: every file listed with its hash, nothing else,
    all of one writer, as many as that writer writes."""
    doc = json.loads((folder / MANIFEST).read_text())
    files = {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()} - {MANIFEST}
    assert files == set(doc["files"])
    for name, entry in doc["files"].items():
        assert hashlib.sha256((folder / name).read_bytes()).hexdigest() == entry["sha256"]
    texts = {(folder / name).read_text() for name in files}
    (text,) = texts
    tag = text.split("\n")[0]
    assert text == (tag + "\n") * 500
    assert len(files) == 3 + int(tag) % 4
    return tag


def writer(target: Path, tag: int, pause_at: str = "") -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", WRITER, str(target), str(tag), pause_at],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("moment", ["staging", "aside"])
def test_kill_9_of_a_writer_leaves_a_whole_folder(tmp_path, moment):
    """kill -9 while the writer stages its files, or between its two renames (the old folder moved aside, the
    new one not yet in): the folder is the old one, whole (after the second kind, once the next run put it back);
    the next run cleans up what the killed one left."""
    out = tmp_path / "o"
    p = writer(out, 1)
    assert p.communicate(timeout=300)[0] == "" and p.returncode == 0
    for tag in (2, 3):
        p = writer(out, tag, moment)
        assert p.stdout.readline() == moment + "\n"
        p.kill()
        p.wait()
        if moment == "staging":
            assert whole(out) == "1"
        else:
            assert not out.exists() and len([e for e in os.listdir(tmp_path) if ".o.bhr-old-" in e]) == 1
        p.stdout.close()
        p.stderr.close()
    p = writer(out, 4)
    assert p.communicate(timeout=300)[1] == "" and p.returncode == 0
    assert whole(out) == "4" and sorted(os.listdir(tmp_path)) == ["o"]
