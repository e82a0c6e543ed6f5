"""Hold under attack, round four: issue 23's classes attacked again (signals, workers, Dask, non-regular files,
a full disk, numbers), each case checked as the hidden set checks it: one line, non-zero exit, no traceback,
bounded time, nothing of the user's changed."""
from __future__ import annotations

import os
import shutil
import socket
import subprocess
from pathlib import Path

import pytest

from tests.conftest import bhr_exe, foreground, snapshot

from tests.cli.test_attack_round3 import ENV, bhr, bhr_process, one_line  # the same checks as round three


# --- a run file that is not a regular file -------------------------------------------------------------------

def _not_a_file(folder: Path, kind: str) -> str:
    if kind == "fifo":
        os.mkfifo(folder / "r.json")
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(folder / "r.json"))
        s.close()
    elif kind == "folder":
        (folder / "r.json").mkdir()
    else:
        os.symlink("/dev/zero", folder / "r.json")
    return "r.json"


@pytest.mark.parametrize("kind, words", [("fifo", "is a FIFO (named pipe), not a run file"),
                                         ("socket", "is a socket, not a run file"),
                                         ("device", "is a character device, not a run file"),
                                         ("folder", "is a folder; give the run.json inside it")])
def test_physics_names_a_run_file_that_is_not_a_file(tmp_path, kind, words):
    # it was "no such run file" for all four: the file is there, it is the wrong kind
    run = _not_a_file(tmp_path, kind)
    before = snapshot(tmp_path)
    line = one_line(bhr("physics", run, "--out", "ph", cwd=tmp_path, timeout=60))
    assert words in line and "no such" not in line, line
    assert snapshot(tmp_path) == before and sorted(os.listdir(tmp_path)) == ["r.json"]


# --- a Dask address that is not one ----------------------------------------------------------------------------

def test_a_port_that_answers_junk_is_not_blamed_on_memory(tmp_path):
    # its first bytes, read as Dask's message length, asked numpy for exabytes: "Unable to allocate 3.07 EiB"
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    port = srv.getsockname()[1]

    def talk():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            with conn:
                conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 0\r\n\r\n" + b"\xff" * 4096)

    threading.Thread(target=talk, daemon=True).start()
    try:
        line = one_line(bhr("sweep", "--traj", "line", "--grid", "modules=3", "--no-plots", "--out", "o",
                            "--scheduler", f"tcp://127.0.0.1:{port}", cwd=tmp_path, timeout=120))
    finally:
        srv.close()
    assert "it answered, but not as Dask does; is it a Dask scheduler?" in line, line
    assert "allocate" not in line and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("port", ["８７８６", "８7８6", "٨٧٨٦"])
def test_a_scheduler_port_in_other_digits_is_refused(tmp_path, port):
    # int() reads full-width and Arabic-Indic digits as 8786: the address was tried as tcp://127.0.0.1:8786
    line = one_line(bhr("sweep", "--traj", "line", "--grid", "modules=3", "--no-plots", "--out", "o",
                        "--scheduler", f"tcp://127.0.0.1:{port}", cwd=tmp_path, timeout=120))
    assert "is not plain digits 0-9" in line and "cannot connect to the Dask scheduler" in line, line
    assert list(tmp_path.iterdir()) == []


# --- a full disk ----------------------------------------------------------------------------------------------

@pytest.fixture
def full_disk(tmp_path):
    """tmp_path/full: a 64 kB tmpfs filled to the last byte (root only, as CI runs; elsewhere the test fails)."""
    full = tmp_path / "full"
    full.mkdir()
    if os.geteuid() != 0:
        pytest.fail("a full disk is a tmpfs mount: run this test as root (CI does)")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(full)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.fail(f"cannot mount a tmpfs here: {r.stderr.strip()}")
    try:
        fd = os.open(full / "fill", os.O_WRONLY | os.O_CREAT)
        try:
            while True:
                os.write(fd, b"x" * 512)
        except OSError:
            pass
        finally:
            os.close(fd)
        yield full
    finally:
        subprocess.run(["umount", "-l", str(full)], check=True)


BATCH = '[[run]]\nname = "a"\ntraj = "colon"\n[[run]]\nname = "b"\ntraj = "curve"\n'


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_report_on_a_full_disk_names_the_file_and_leaves_no_folder(tmp_path, full_disk, jobs):
    # each run's failed write was "a: failed: OSError: ... .o.bhr-stage-.../runs/a/run.json", the report then
    # written beside them: "2 of 2 runs failed" and a folder of failed runs on the full disk
    # (the folder named relative to the command's, so that the path in the line is short on any test machine)
    (tmp_path / "b.toml").write_text(BATCH)
    r = bhr("report", "--file", "b.toml", "--out", "full/rep", "--jobs", jobs, cwd=tmp_path, timeout=300)
    line = one_line(r)
    assert line.startswith("Error: full/rep/runs/") and "No space left on device" in line, line
    assert "bhr-stage" not in line and "runs failed" not in line and "FAILED" not in r.stdout
    assert sorted(os.listdir(full_disk)) == ["fill"]


def test_a_report_over_the_file_size_limit_stops_at_the_first_file(tmp_path):
    # the same without a mount: a file-size limit (EFBIG) is the output's failure, not the run's
    import resource

    (tmp_path / "b.toml").write_text(BATCH)
    warm = bhr("report", "--file", "b.toml", "--out", "warm", "--jobs", "1", cwd=tmp_path, timeout=300)
    assert warm.returncode == 0, warm.stderr  # kernels cached first: the limit is for the report's files
    shutil.rmtree(tmp_path / "warm")
    before = snapshot(tmp_path)

    def small():
        resource.setrlimit(resource.RLIMIT_FSIZE, (5000, 5000))
    line = one_line(bhr_process("report", "--file", "b.toml", "--out", "rep", "--jobs", "1", "--no-plots",
                                cwd=tmp_path, timeout=300, preexec_fn=small))
    assert line.startswith("Error: rep/runs/a/") and "File too large" in line, line
    assert snapshot(tmp_path) == before and sorted(os.listdir(tmp_path)) == ["b.toml"]


@pytest.mark.parametrize("cmd", ["follow", "replay"])
def test_an_animation_on_a_full_disk_is_one_line(tmp_path, full_disk, cmd):
    # the progress bar's label ("Rendering full/a.gif") was written to a piped stderr before the error line
    if cmd == "replay":
        assert bhr("follow", "--traj", "line", "--no-plots", "--out", "run", cwd=tmp_path).returncode == 0
        args = ["replay", "run/run.json", "--animate", "full/a.gif"]
    else:
        args = ["follow", "--traj", "line", "--no-plots", "--out", "run", "--animate", "full/a.gif"]
    line = one_line(bhr(*args, cwd=tmp_path, timeout=300))  # full/ named relative: a short path on any machine
    assert full_disk == tmp_path / "full" and line.startswith("Error: full/a.gif: No space left on device"), line
    assert sorted(os.listdir(full_disk)) == ["fill"]


# --- numbers in a trajectory CSV -------------------------------------------------------------------------------

BIG = "1" + "0" * 399


@pytest.mark.parametrize("column", ["x", "lumen"])
@pytest.mark.parametrize("value, words", [
    ("1e-320", "= 1e-320 is too small to mean anything (a denormal"),
    ("4.9e-324", "= 4.9e-324 is too small to mean anything (a denormal"),
    (BIG, "is 400 characters, longer than any number (40)"),
], ids=["denormal", "smallest-denormal", "400-digits"])
def test_a_trajectory_csv_number_goes_through_the_one_checkers_rules(tmp_path, column, value, words):
    # a denormal x or lumen diameter was accepted (exit 0), a 400-digit integer quoted whole ("not finite")
    rows = [["0", "0", "0", "30"], ["2", "0", "0", "30"], ["4", "0", "0", "30"], ["6", "0", "0", "30"]]
    rows[2][0 if column == "x" else 3] = value
    (tmp_path / "t.csv").write_text("x,y,z,lumen\n" + "".join(",".join(r) + "\n" for r in rows))
    before = snapshot(tmp_path)
    line = one_line(bhr("follow", "--traj", "t.csv", "--no-plots", "--out", "o", cwd=tmp_path, timeout=120))
    assert line.startswith(f"Error: t.csv, line 4: {column} = ") and words in line and len(line) < 300, line
    assert snapshot(tmp_path) == before


def test_a_trajectory_csv_keeps_tiny_normal_numbers(tmp_path):
    # rounding noise of an exported centerline (1e-15) is a number, not a denormal
    (tmp_path / "t.csv").write_text("x,y,z\n0,0,0\n2,1e-15,0\n4,-0,0\n6,0,0\n")
    r = bhr("follow", "--traj", "t.csv", "--no-plots", "--out", "o", cwd=tmp_path, timeout=120)
    assert r.returncode == 0, r.stderr


# --- numbers in a sweep's grid and in --colons -------------------------------------------------------------------

@pytest.mark.parametrize("alpha, words", [
    (f'"5:{BIG}"', "is 400 characters, longer than any number (40)"),
    ('"5:1e400"', "alpha value 1e400 is not a finite number"),
    ('"5:1e308"', "alpha range end 1e+308 is too large"),
    ('"5:6:1e-300"', "has more than 1000000 values; use a larger step"),
], ids=["400-digit-end", "infinite-end", "huge-end", "tiny-step"])
def test_a_sweep_file_range_with_impossible_ends_is_one_short_line(tmp_path, alpha, words):
    # OverflowError with a traceback (400 digits, 1e400), or a 309-digit count quoted whole (1e308)
    (tmp_path / "s.toml").write_text(f'traj = "line"\n[grid]\nalpha = {alpha}\n')
    before = snapshot(tmp_path)
    line = one_line(bhr("sweep", "--file", "s.toml", "--out", "o", "--jobs", "1", "--no-plots", cwd=tmp_path,
                        timeout=120))
    assert line.startswith("Error: s.toml: [grid]: alpha ") and words in line and len(line) < 300, line
    assert snapshot(tmp_path) == before


# the range end is read as any value is (one syntax for ranges): a 400-digit end is refused by its length
@pytest.mark.parametrize("grid, words", [(f"modules=3-{BIG}", "modules value '1" + "0" * 35 + "... is 400 characters, "
                                                             "longer than any number (40)"),
                                         ("modules=１-３", "modules value '１-３' is not a number")],
                         ids=["400-digit-last", "full-width"])
def test_a_grid_first_last_range_takes_plain_digits_of_a_sane_size(tmp_path, grid, words):
    line = one_line(bhr("sweep", "--traj", "line", "--grid", grid, "--out", "o", "--jobs", "1", "--no-plots",
                        cwd=tmp_path, timeout=120))
    assert words in line and len(line) < 300, line
    assert list(tmp_path.iterdir()) == []


def test_colons_beyond_the_last_seed_are_quoted_short(tmp_path):
    line = one_line(bhr("traverse", "--colons", f"1-{BIG}", "--out", "o", cwd=tmp_path, timeout=120))
    assert "--colons: seeds go from 0 to 4294967295" in line and len(line) < 200, line
    assert list(tmp_path.iterdir()) == []


# --- numbers in a run.json and a codes.csv ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def a_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("run")
    r = bhr("follow", "--traj", "line", "--no-plots", "--out", "run", cwd=folder, timeout=300)
    assert r.returncode == 0, r.stderr
    return (folder / "run" / "run.json").read_text()


@pytest.mark.parametrize("value, words", [('"１０"', "trajectory points must be numbers, not text"),
                                          ('"12.5"', "trajectory points must be numbers, not text"),
                                          ("1e-320", "trajectory points must not be denormals"),
                                          ("true", "trajectory points must be numbers, not true/false")],
                         ids=["full-width-text", "text", "denormal", "true-among-numbers"])
def test_a_run_json_point_is_a_number_as_written(tmp_path, a_run, value, words):
    # numpy's float() read the text "１０" as 10 and "12.5" as 12.5, and a true among numbers as 1; a
    # denormal passed: the replay went on
    import json

    doc = json.loads(a_run)
    first = doc["trajectory"]["points"][0]
    text = a_run.replace(json.dumps(first), json.dumps(first).replace(repr(first[0]), value, 1), 1)
    assert text != a_run
    (tmp_path / "r.json").write_text(text)
    before = snapshot(tmp_path)
    line = one_line(bhr("replay", "r.json", "--out", "o", cwd=tmp_path, timeout=120))
    assert line.startswith("Error: r.json: ") and words in line, line
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("args", [["fk", "--codes", f"0,{BIG}"], ["plan", "--codes", "c.csv", "--no-plots"],
                                  ["stream", "--codes", "c.csv", "--dry-run"]], ids=["fk", "plan", "stream"])
def test_a_400_digit_code_is_named_by_its_size(tmp_path, args):
    # the message quoted all 400 digits
    (tmp_path / "c.csv").write_text(f"step,m1,m2\n1,{BIG},0\n")
    line = one_line(bhr(*args, cwd=tmp_path, timeout=120))
    assert "code of 400 digits" in line and "is not a stable actuator code" in line and len(line) < 200, line
    assert sorted(os.listdir(tmp_path)) == ["c.csv"]


@pytest.mark.parametrize("args", [["fk", "--codes", "0,3"], ["fk", "--codes", "0,3", "--json", "-"],
                                  ["solve", "--target", "0", "0", "10"]], ids=["fk", "fk-json", "solve"])
def test_a_full_standard_output_is_named_as_such(tmp_path, args):
    # a failed flush drops what it held, so the check's second flush passed: "writing a file: No space left"
    with open("/dev/full", "w") as full:
        r = subprocess.run(bhr_exe() + args, cwd=tmp_path, stdout=full, stderr=subprocess.PIPE, text=True,
                           timeout=120, env=ENV)
    line = one_line(r)
    assert line == ("Error: standard output: No space left on device; free some disk space or write to another "
                    "device"), line
    assert list(tmp_path.iterdir()) == []


# --- Ctrl-C while an animation renders ---------------------------------------------------------------------------

def _living(session: int) -> list[str]:
    out = subprocess.run(["ps", "-s", str(session), "-o", "pid=,stat=,args="], capture_output=True, text=True).stdout
    return [ln for ln in out.splitlines() if ln.split() and "Z" not in ln.split()[1]]


@pytest.mark.parametrize("cmd", ["follow", "replay"])
def test_a_ctrl_c_while_the_animation_renders_leaves_no_folder(tmp_path, cmd):
    # the run's folder was put in place before the animation was rendered: "Interrupted." and 130, its folder left
    import signal
    import time

    # the colon: 827 frames, many seconds of rendering after the animation's file appears, so that the Ctrl-C
    # lands while it renders even on a busy machine (with the curve's few frames a late Ctrl-C came after the end)
    if cmd == "replay":
        assert bhr("follow", "--traj", "colon", "--no-plots", "--out", "run", cwd=tmp_path).returncode == 0
        args = ["replay", "run/run.json", "--out", "figs", "--animate", "a.gif"]
    else:
        args = ["follow", "--traj", "colon", "--no-plots", "--out", "figs", "--animate", "a.gif"]
    before = snapshot(tmp_path)
    p = subprocess.Popen(bhr_exe() + args, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=ENV, start_new_session=True, preexec_fn=foreground)
    deadline = time.monotonic() + 240
    while not [n for n in os.listdir(tmp_path) if n.startswith(".a.gif.")]:  # the animation's file being written
        assert p.poll() is None and time.monotonic() < deadline, p.communicate()
        time.sleep(0.01)
    os.killpg(p.pid, signal.SIGINT)
    out, err = p.communicate(timeout=120)
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("Compiling bhr's")]
    assert p.returncode == 130 and lines == ["Interrupted."], (p.returncode, err[-2000:])
    assert snapshot(tmp_path) == before and "figs" not in os.listdir(tmp_path)
    assert _living(p.pid) == []
