"""Hold under attack, round seven: issue 23's classes attacked again by a driver of several hundred new cases
(standard streams closed or full, a background job's SIGTERM, run.json, manifests, staging names, the current
folder deleted, long text in files), each regression checked as the hidden set checks it: one line, non-zero exit,
no traceback, bounded time, nothing of the user's changed. (The board's cases live beside its fake board,
tests/integration/test_link.py.)"""
from __future__ import annotations

import json
import os
import signal
import subprocess
from pathlib import Path

import pytest

from tests.conftest import bhr_exe, finish, foreground, snapshot, start_bhr, wait_for_stderr

from tests.cli.test_attack_round3 import ENV, bhr, bhr_process, one_line  # the same checks as rounds three to five
from tests.cli.test_attack_round5 import loose_run as loose_run_files  # noqa: F401  (a fixture)

BATCH = '[[run]]\nname = "a"\ntraj = "line"\nlength = 20\n'


@pytest.fixture(scope="module")
def loose_run(loose_run_files):
    """The run.json of a run with a lumen (21 points), outside any bhr folder (round five's run)."""
    return loose_run_files[0]


# --- standard output full or closed: the command's outputs and its summary are one set ---------------------------

COMMANDS = {
    "follow": ["follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o"],
    "follow-default-folder": ["follow", "--traj", "line", "--length", "20", "--no-plots"],
    "follow-json-out": ["follow", "--traj", "line", "--length", "20", "--no-plots", "--json", "-", "--out", "o"],
    "follow-animate": ["follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o", "--animate", "a.gif"],
    "replay": ["replay", "r.json", "--out", "o"],
    "report": ["report", "--file", "b.toml", "--out", "o", "--jobs", "1", "--no-plots"],
    "sweep": ["sweep", "--traj", "line", "--grid", "modules=3,4", "--out", "o", "--jobs", "1", "--no-plots"],
    "export": ["export", "--format", "urdf", "--out", "x.urdf"],
    "plan": ["plan", "--codes", "c.csv", "--csv", "p.csv", "--no-plots"],
}


def _inputs(folder: Path, run_json: str) -> None:
    (folder / "r.json").write_text(run_json)
    (folder / "b.toml").write_text(BATCH)
    (folder / "c.csv").write_text("step,m1,m2\n1,3,0\n2,0,6\n")


@pytest.mark.parametrize("name", list(COMMANDS))
def test_a_full_standard_output_leaves_no_folder(tmp_path, loose_run, name):
    # > /dev/full: "Error: standard output: No space left on device" and exit 1, but the whole folder (or file) was
    # put in place before the summary failed to print: half the output set
    _inputs(tmp_path, loose_run)
    before = snapshot(tmp_path)
    with open("/dev/full", "w") as full:
        r = subprocess.run(bhr_exe() + COMMANDS[name], cwd=tmp_path, stdout=full, stderr=subprocess.PIPE, text=True,
                           timeout=300, env=ENV)
    assert one_line(r).startswith("Error: standard output: No space left on device"), r.stderr
    assert snapshot(tmp_path) == before and sorted(os.listdir(tmp_path)) == ["b.toml", "c.csv", "r.json"]


@pytest.mark.parametrize("name", ["follow", "follow-json-out", "follow-animate", "report", "export", "plan"])
def test_a_closed_standard_output_is_one_line_and_leaves_no_folder(tmp_path, loose_run, name):
    # bhr ... >&- : Python leaves sys.stdout None: "AttributeError: 'NoneType' object has no attribute 'flush'" with
    # a traceback, after the folder was put in place
    _inputs(tmp_path, loose_run)
    before = snapshot(tmp_path)
    r = subprocess.run(bhr_exe() + COMMANDS[name], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                       text=True, timeout=300, env=ENV, preexec_fn=lambda: os.close(1))
    assert one_line(r) == "Error: standard output: closed by the caller; give it an open file or /dev/null", r.stderr
    assert snapshot(tmp_path) == before and sorted(os.listdir(tmp_path)) == ["b.toml", "c.csv", "r.json"]


def test_a_closed_standard_input_is_one_line(tmp_path):
    # bhr replay - <&- : "AttributeError: 'NoneType' object has no attribute 'buffer'" with a traceback
    r = subprocess.run(bhr_exe() + ["replay", "-", "--out", "o"], cwd=tmp_path, stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True, timeout=120, env=ENV, preexec_fn=lambda: os.close(0))
    assert one_line(r) == "Error: standard input: closed by the caller; give it an open file or /dev/null", r.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_closed_standard_error_keeps_the_exit_status_and_no_file_takes_its_place(tmp_path):
    # with descriptor 2 closed, the first file bhr opened took number 2: whatever a library wrote to "stderr"
    # went into that file
    r = subprocess.run(bhr_exe() + ["follow", "--traj", "nosuch", "--out", "o"], cwd=tmp_path, stdout=subprocess.PIPE,
                       stderr=subprocess.DEVNULL, text=True, timeout=120, env=ENV, preexec_fn=lambda: os.close(2))
    assert r.returncode == 1 and r.stdout == "" and list(tmp_path.iterdir()) == []
    r = subprocess.run(bhr_exe() + ["follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o"],
                       cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, timeout=300,
                       env=ENV, preexec_fn=lambda: os.close(2))
    assert r.returncode == 0 and "Wrote o/codes.csv" in r.stdout
    assert sorted(os.listdir(tmp_path / "o")) == ["codes.csv", "manifest.json", "run.json", "steps.csv"]


def test_an_animation_outside_the_folder_is_one_set_with_it(tmp_path):
    # the animation's file goes in place with the folder, at the end: its size is measured before (it was read
    # back from its target, which is not there yet: "Error: a.gif: No such file or directory")
    r = bhr("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o", "--animate", "a.gif",
            cwd=tmp_path, timeout=300)
    assert r.returncode == 0 and "Animation: " in r.stdout and r.stderr == "", r.stderr
    assert (tmp_path / "a.gif").read_bytes()[:3] == b"GIF" and (tmp_path / "o" / "run.json").is_file()


# --- SIGTERM of a background job ----------------------------------------------------------------------------------

def _background_job():
    """As `bhr ... &` in a script: Ctrl-C ignored (not the job's), SIGTERM and SIGHUP as they come."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
@pytest.mark.parametrize("args", [["follow", "--traj", "colon"],
                                  ["sweep", "--traj", "colon", "--grid", "modules=3:12", "--grid", "alpha=6:15",
                                   "--jobs", "2"]], ids=["follow", "sweep"])
def test_kill_of_a_background_job_ends_it_as_in_the_foreground(tmp_path, sig, args):
    # with Ctrl-C ignored (a background job), bhr installed no handler at all: kill PID ended it by the signal, with
    # no line, its staging folder and bhr-out/ left behind
    p = start_bhr(args, tmp_path, preexec_fn=_background_job)
    # follow: while its figures are drawn; sweep: once its workers are busy
    read = wait_for_stderr(p, "drawing the figures" if args[0] == "follow" else "Running 100 designs: 1/100")
    os.kill(p.pid, sig)
    code, _, lines = finish(p, read)
    assert code == 128 + sig and lines == [f"Interrupted by {sig.name}."], (code, read)
    assert list(tmp_path.iterdir()) == []


# --- run.json ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("command", ["replay", "physics"])
@pytest.mark.parametrize("value", [-30.0, 0.0])
def test_a_run_json_lumen_is_a_positive_diameter(tmp_path, loose_run, command, value):
    # a negative lumen: replay drew it (exit 0), physics ended in "ValueError: Error: size 1 must be positive in
    # geom" with a traceback
    doc = json.loads(loose_run)
    doc["trajectory"]["lumen"] = [value] * len(doc["trajectory"]["points"])
    (tmp_path / "r.json").write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    line = one_line(bhr(command, "r.json", "--out", "o", cwd=tmp_path, timeout=300))
    assert line.startswith(f"Error: r.json: trajectory lumen diameters must be greater than 0 mm, got {value:g}"), line
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("name", ["a\nError: forged", "a\x1b[2Jb", "a\u202eb", 5])
def test_a_run_json_trajectory_name_is_one_line_of_printable_text(tmp_path, loose_run, name):
    # it reached the figures' titles and view.html as it was (a trajectory file's name is refused the same way)
    doc = json.loads(loose_run)
    doc["trajectory"]["name"] = name
    (tmp_path / "r.json").write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    line = one_line(bhr("replay", "r.json", "--out", "o", cwd=tmp_path, timeout=300))
    assert line.startswith("Error: r.json: trajectory name must be one line of printable text"), line
    assert snapshot(tmp_path) == before


# --- output folders: the manifest, a rerun, staging names -----------------------------------------------------------

def test_a_rerun_after_a_figure_was_deleted_keeps_the_rest(tmp_path):
    # the carry-over linked every file the old manifest listed: a figure the user deleted failed the rerun with
    # "Error: .../o/path.png: No such file or directory"
    assert bhr("follow", "--traj", "line", "--length", "20", "--out", "o", cwd=tmp_path, timeout=300).returncode == 0
    (tmp_path / "o" / "path.png").unlink()
    r = bhr("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o", cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    man = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert "path.png" not in man["files"] and "position_errors.png" in man["carried_over"]
    assert sorted(os.listdir(tmp_path / "o")) == sorted([*man["files"], "manifest.json"])


@pytest.mark.parametrize("name", ["../mine.txt", "/etc/hostname", "a/../../mine.txt", ""])
def test_a_manifest_naming_files_outside_its_folder_is_not_bhrs(tmp_path, name):
    # such a manifest was taken as bhr's: the folder was replaced and the carry-over followed the name outside
    assert bhr("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o", cwd=tmp_path,
               timeout=300).returncode == 0
    (tmp_path / "mine.txt").write_text("mine")
    man = json.loads((tmp_path / "o" / "manifest.json").read_text())
    man["files"][name] = {"bytes": 4, "sha256": "0" * 64}
    (tmp_path / "o" / "manifest.json").write_text(json.dumps(man))
    before = snapshot(tmp_path)
    line = one_line(bhr("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o", cwd=tmp_path,
                        timeout=300))
    assert "output folder o holds " in line and "which no bhr run wrote" in line, line
    assert snapshot(tmp_path) == before


def test_a_users_folder_named_like_a_staging_folder_is_kept(tmp_path):
    # .o.bhr-stage-<a dead pid>-x was deleted as the staging folder of a dead run, whatever it held
    mine = tmp_path / ".o.bhr-stage-999999-abc"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    r = bhr("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o", cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (mine / "notes.txt").read_text() == "mine"
    assert sorted(os.listdir(tmp_path)) == [".o.bhr-stage-999999-abc", "o"]
    assert ".bhr-staging" not in os.listdir(tmp_path / "o")


def test_a_dead_runs_staging_folder_is_still_cleaned(tmp_path):
    # a run killed while it staged leaves its stage and the lock file it held beside it (nobody holds it now)
    dead = tmp_path / ".o.bhr-stage-0123456789ab"
    dead.mkdir()
    (dead / "run.json").write_text("{")
    (tmp_path / ".o.bhr-stage-0123456789ab.lock").write_text("")
    r = bhr("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o", cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    assert sorted(os.listdir(tmp_path)) == ["o"]


@pytest.mark.parametrize("args", [["follow", "--traj", "line", "--no-plots", "--out", "-"],
                                  ["sweep", "--traj", "line", "--grid", "modules=3", "--out", "-", "--jobs", "1"],
                                  ["report", "--file", "b.toml", "--out", "-"]], ids=["follow", "sweep", "report"])
def test_out_dash_is_not_a_folder_named_dash(tmp_path, args):
    # '-' is standard output everywhere else; --out - made a folder named '-'
    (tmp_path / "b.toml").write_text(BATCH)
    line = one_line(bhr(*args, cwd=tmp_path, timeout=300))
    assert "'-' is standard output, which cannot hold a folder" in line, line
    assert os.listdir(tmp_path) == ["b.toml"]


@pytest.mark.parametrize("args", [["follow", "--traj", "line", "--no-plots"], ["fk", "--codes", "0,3"],
                                  ["sweep", "--traj", "line", "--grid", "modules=3", "--jobs", "1", "--out", "o"]],
                         ids=["follow", "fk", "sweep"])
def test_a_deleted_current_folder_is_one_line_before_any_work(tmp_path, args):
    # the run was solved, then "Error: writing a file: No such file or directory" (getcwd failed), which names
    # no file
    here = tmp_path / "here"
    here.mkdir()
    python = str(Path(bhr_exe()[0]).parent / "python")
    code = ("import os, sys; os.chdir(sys.argv[1]); os.rmdir(sys.argv[1]); "
            "sys.argv = ['bhr'] + sys.argv[2:]; from bhr.cli.main import run; run()")
    r = subprocess.run([python, "-c", code, str(here), *args], capture_output=True, text=True, timeout=300,
                       env=ENV)
    assert one_line(r) == ("Error: the current folder no longer exists (it was deleted or moved away); cd into an "
                           "existing folder and run again"), r.stderr
    assert list(tmp_path.iterdir()) == []


# --- a file's text quoted short -------------------------------------------------------------------------------------

LONG = "k" * 5000


@pytest.mark.parametrize("file, text, args", [
    ("t.toml", f'[[segment]]\ntype = "{LONG}"\n', ["follow", "--traj", "t.toml", "--out", "o"]),
    ("t.toml", f'[[segment]]\ntype = "arc"\nradius = 70\nangle = 90\nturn = "{LONG}"\n',
     ["follow", "--traj", "t.toml", "--out", "o"]),
    ("t.toml", f'generator = "{LONG}"\n', ["follow", "--traj", "t.toml", "--out", "o"]),
    ("s.toml", f'traj = "line"\n[grid]\n{LONG} = [1]\n', ["sweep", "--file", "s.toml", "--out", "o"]),
    ("r.toml", f'[codes]\n0 = "rest"\n3 = "{LONG}"\n', ["fk", "--codes", "0", "--robot", "r.toml"]),
    ("r.toml", f'[thermal]\n{LONG} = 1\n', ["fk", "--codes", "0", "--robot", "r.toml"]),
], ids=["segment-type", "arc-turn", "generator", "sweep-grid-key", "robot-codes", "robot-thermal-key"])
def test_a_long_text_from_a_file_is_quoted_short(tmp_path, file, text, args):
    # the message quoted all 5,000 characters of the file's text
    (tmp_path / file).write_text(text)
    before = snapshot(tmp_path)
    line = one_line(bhr(*args, cwd=tmp_path, timeout=300))
    assert line.startswith("Error: ") and "k" * 60 not in line and len(line) < 600, line
    assert snapshot(tmp_path) == before


def test_a_run_that_failed_on_a_long_file_name_is_reported_short(tmp_path):
    # a batch's traj of 5,000 characters: the run's row said "failed: OSError: [Errno 36] File name too long: 'kkk..."
    # with all 5,000 characters, on standard output and in summary.csv, summary.json and the page
    (tmp_path / "b.toml").write_text(f'[[run]]\nname = "a"\ntraj = "{LONG}"\n[[run]]\nname = "b"\ntraj = "line"\n'
                                     'length = 20\n')
    r = bhr("report", "--file", "b.toml", "--out", "o", "--no-plots", "--jobs", "1", cwd=tmp_path, timeout=300)
    assert one_line(r) == "Error: 1 of 2 runs failed; see o/summary.csv"
    assert "a: failed: File name too long: 'kkk" in r.stdout and "k" * 100 not in r.stdout, r.stdout[-500:]
    rows = json.loads((tmp_path / "o" / "summary.json").read_text())["runs"]
    assert rows[0]["status"].startswith("failed: File name too long: 'kkk") and len(rows[0]["status"]) < 200, rows[0]


# --- numba's own environment variables ---------------------------------------------------------------------------

def test_numba_disable_jit_runs_the_kernels_interpreted(tmp_path):
    # NUMBA_DISABLE_JIT=1 (numba's debugging switch): "AttributeError: 'function' object has no attribute
    # 'get_call_template'" with a traceback, in every command that runs a kernel
    for args in (["follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o"], ["fk", "--codes", "0,3"],
                 ["solve", "--target", "3", "9", "0", "--solver", "ccd"]):
        r = bhr_process(*args, cwd=tmp_path, timeout=300, env=dict(ENV, NUMBA_DISABLE_JIT="1"))
        assert r.returncode == 0 and "Traceback" not in r.stderr, (args, r.stderr[-1500:])
    assert sorted(os.listdir(tmp_path / "o")) == ["codes.csv", "manifest.json", "run.json", "steps.csv"]


def test_a_numba_setting_numba_refuses_is_one_line(tmp_path):
    # NUMBA_NUM_THREADS=0: "ValueError: Number of threads specified must be > 0." with a traceback, after the work
    line = one_line(bhr_process("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o",
                                cwd=tmp_path, timeout=300, env=dict(ENV, NUMBA_NUM_THREADS="0")))
    assert line == ("Error: numba refused its settings (Number of threads specified must be > 0.); check the "
                    "environment's NUMBA_NUM_THREADS"), line
    assert list(tmp_path.iterdir()) == []


# --- a signal while the outputs go in place -------------------------------------------------------------------------

SLOW_RENAME = r'''
import os, signal, sys, time

SIG = getattr(signal, sys.argv[1])


def signal_at_rename(event, args):  # the signal comes as the staged folder is renamed into place
    if event == "os.rename" and os.path.basename(os.fspath(args[0])).startswith(".o.bhr-stage-"):
        os.kill(os.getpid(), SIG)
        time.sleep(0.5)  # the handler runs as soon as os.kill returns


sys.addaudithook(signal_at_rename)
sys.argv = ["bhr", "follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "o"]
from bhr.cli.main import run
run()
'''


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_signal_while_the_folder_goes_in_place_changes_nothing(tmp_path, sig):
    # the folder was renamed into place, then the signal: "Interrupted." and 130 with the folder there (the
    # summary printed, the set whole, the status a lie). Once the summary is out, the set goes in place whole and
    # the command ends with its own status; a signal before that still leaves nothing (the tests above).
    python = str(Path(bhr_exe()[0]).parent / "python")
    r = subprocess.run([python, "-c", SLOW_RENAME, sig], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                       env=ENV, preexec_fn=foreground)
    lines = [ln for ln in r.stderr.splitlines() if not ln.startswith("Compiling bhr's")]  # a cold kernel cache
    assert (r.returncode, lines) == (0, []), r.stderr[-1500:]
    assert "Wrote o/codes.csv" in r.stdout
    assert sorted(os.listdir(tmp_path / "o")) == ["codes.csv", "manifest.json", "run.json", "steps.csv"]


def test_physics_never_replaces_the_folder_of_its_own_run(tmp_path):
    # bhr physics o/run.json --out o: o (bhr's, so replaceable) was replaced by the replay's files, deleting the
    # run.json it read, codes.csv and steps.csv; every other command refuses a folder that holds its input
    (tmp_path / "lum.csv").write_text("x,y,z,lumen\n" + "".join(f"{2 * k},0,0,30\n" for k in range(21)))
    assert bhr("follow", "--traj", "lum.csv", "--no-plots", "--out", "o", cwd=tmp_path, timeout=300).returncode == 0
    before = snapshot(tmp_path)
    line = one_line(bhr("physics", "o/run.json", "--out", "o", cwd=tmp_path, timeout=300))
    assert line == ("Error: output folder o holds o/run.json, an input of this run; give another folder for the "
                    "output (bhr replaces the whole folder)"), line
    assert snapshot(tmp_path) == before
