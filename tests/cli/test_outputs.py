"""Output sets are written whole: one run per folder, devices and links never replaced, failures leave the old set.

Every test runs the real `bhr` console script and checks the folders it leaves with their manifest.json
(each file's size and SHA-256) and with the run itself (codes.csv has one row per step of run.json).
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import resource
import signal
import stat
import subprocess
import threading
import time
from pathlib import Path

import pytest

from tests.conftest import bhr_exe, bhr_in_process, snapshot

ENV = dict(os.environ, MPLBACKEND="Agg")


def bhr(*args, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    """The command in this process (what it does with its input and its files); a test of the process itself
    (killed, limited, its standard streams full) runs the real ``bhr`` (bhr_exe)."""
    return bhr_in_process(*args, cwd=cwd, env=ENV, timeout=timeout)


def one_line(err: str) -> str:
    # the first run after an upgrade may also announce, in its own line, that it compiles the kernels
    lines = [ln for ln in err.strip().splitlines() if ln.strip() and not ln.startswith("Compiling bhr's kernels")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def check_whole(folder: Path) -> dict:
    """The folder is one run's set: every file listed in manifest.json with its hash, nothing else, and
    codes.csv (when present) has one row per step of run.json (when present)."""
    man = json.loads((folder / "manifest.json").read_text())
    files = {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()} - {"manifest.json"}
    assert files == set(man["files"]), (files, set(man["files"]))
    for name, info in man["files"].items():
        data = (folder / name).read_bytes()
        assert len(data) == info["bytes"] and hashlib.sha256(data).hexdigest() == info["sha256"], name
    if (folder / "run.json").exists() and (folder / "codes.csv").exists():
        steps = len(json.loads((folder / "run.json").read_text())["steps"])
        assert (folder / "codes.csv").read_text().count("\n") == steps + 1
    return man


def no_staging(parent: Path) -> None:
    assert not [p.name for p in parent.iterdir() if ".bhr-" in p.name], sorted(p.name for p in parent.iterdir())


def test_newcomer_sequence_leaves_no_mixed_folder(tmp_path):
    """The 360-degree curve, then the default curve to stdout only: each folder holds one run, whole."""
    r1 = bhr("follow", "--traj", "curve", "--radius", "70", "--angle", "360", cwd=tmp_path)
    assert r1.returncode == 0, r1.stderr
    before = snapshot(tmp_path / "bhr-out")
    r2 = bhr("follow", "--traj", "curve", "--json", "-", "--no-plots", cwd=tmp_path)
    assert r2.returncode == 0, r2.stderr
    assert len(json.loads(r2.stdout)["steps"]) == 85
    assert snapshot(tmp_path / "bhr-out") == before  # stdout was the whole output: no folder touched
    (folder,) = [p for p in (tmp_path / "bhr-out").iterdir() if not p.is_symlink()]
    assert folder.name.startswith("curve-thesis-")
    man = check_whole(folder)
    assert {"run.json", "codes.csv", "path.png", "position_errors.png"} <= set(man["files"])
    assert json.loads((folder / "run.json").read_text())["trajectory"]["params"]["angle"] == 360.0
    # a run with other settings gets its own folder; the first stays as it was
    r3 = bhr("follow", "--traj", "curve", "--no-plots", "--alpha", "12", cwd=tmp_path)
    assert r3.returncode == 0, r3.stderr
    folders = sorted(p for p in (tmp_path / "bhr-out").iterdir() if not p.is_symlink())
    assert len(folders) == 2 and all(check_whole(f) for f in folders)
    assert (tmp_path / "bhr-out" / "latest").resolve() == [f for f in folders if f != folder][0].resolve()
    assert snapshot(folder) == before_folder(before, folder.name)
    no_staging(tmp_path / "bhr-out")


def before_folder(snap: dict, name: str) -> dict:
    return {k[len(name) + 1:]: v for k, v in snap.items() if k.startswith(name + "/")}


def test_explicit_out_is_replaced_whole(tmp_path):
    """--out DIR of an earlier run with figures, then a run without: no figure of the old run survives."""
    out = tmp_path / "o"
    assert bhr("follow", "--traj", "curve", "--angle", "360", "--out", out, cwd=tmp_path).returncode == 0
    assert (out / "path.png").exists()
    r = bhr("follow", "--traj", "curve", "--no-plots", "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    man = check_whole(out)
    assert set(man["files"]) == {"run.json", "codes.csv", "steps.csv"}
    # --json - with --out: the folder gets the rest of the set; other settings: never the old run.json
    r = bhr("follow", "--traj", "line", "--no-plots", "--json", "-", "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert set(check_whole(out)["files"]) == {"codes.csv", "steps.csv"}
    # the same settings again: what this run does not write into the folder is kept (docs/commands.md)
    r = bhr("follow", "--traj", "line", "--no-plots", "--out", out, cwd=tmp_path)
    first = (out / "run.json").read_bytes()
    r = bhr("follow", "--traj", "line", "--no-plots", "--json", "-", "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    man = check_whole(out)
    assert set(man["files"]) == {"codes.csv", "run.json", "steps.csv"} and man["carried_over"] == ["run.json"]
    assert (out / "run.json").read_bytes() == first
    no_staging(tmp_path)


def test_out_folder_of_other_files_is_refused(tmp_path):
    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "chapter1.tex").write_text("text")
    before = snapshot(tmp_path)
    r = bhr("follow", "--traj", "line", "--out", mine, cwd=tmp_path)
    assert r.returncode == 1 and "no bhr run wrote" in one_line(r.stderr)
    r = bhr("follow", "--traj", "line", "--out", ".", cwd=tmp_path)
    assert r.returncode == 1 and "is the current folder or holds it" in one_line(r.stderr)
    assert snapshot(tmp_path) == before


def test_json_may_not_name_another_output_of_the_run(tmp_path):
    out = tmp_path / "o"
    assert bhr("follow", "--traj", "line", "--no-plots", "--out", out, cwd=tmp_path).returncode == 0
    before = snapshot(tmp_path)
    for name in ("o/codes.csv", "o/steps.csv", "o/path.png", "o/manifest.json", "o"):
        r = bhr("follow", "--traj", "curve", "--out", "o", "--json", name, cwd=tmp_path)
        assert r.returncode != 0 and "another output" in one_line(r.stderr) or "directory" in r.stderr, r.stderr
    assert snapshot(tmp_path) == before
    r = bhr("follow", "--traj", "curve", "--no-plots", "--out", "o", "--json", "o/curve.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert set(check_whole(out)["files"]) == {"codes.csv", "steps.csv", "curve.json"}


def test_killed_runs_leave_the_old_set_and_their_staging_is_cleaned(tmp_path):
    """kill -9 at many moments of a run into one folder: the folder is always one whole run."""
    out = tmp_path / "o"
    assert bhr("follow", "--traj", "curve", "--no-plots", "--out", out, cwd=tmp_path).returncode == 0
    first = check_whole(out)["run_id"]
    seen = {first}
    for delay in (0.2, 0.6, 1.0, 1.4, 1.8, 2.2, 2.6, 3.0, 3.5, 4.0):
        proc = subprocess.Popen(bhr_exe() + ["follow", "--traj", "colon", "--out", str(out)], cwd=tmp_path, env=ENV,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        seen.add(check_whole(out)["run_id"])
    assert len(seen) <= 11
    r = bhr("follow", "--traj", "line", "--no-plots", "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    check_whole(out)
    no_staging(tmp_path)  # the staging folders of the killed runs are gone


def test_a_failed_write_keeps_the_previous_set(tmp_path):
    """A run that cannot finish writing (file size limit: EFBIG, as a full disk gives ENOSPC) keeps the old set."""
    out = tmp_path / "o"
    assert bhr("follow", "--traj", "line", "--out", out, cwd=tmp_path).returncode == 0
    before = snapshot(out)

    def small_files():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (50_000, 50_000))

    r = subprocess.run(bhr_exe() + ["follow", "--traj", "curve", "--angle", "360", "--out", str(out)], cwd=tmp_path,
                       env=ENV, capture_output=True, text=True, timeout=300, preexec_fn=small_files)
    assert r.returncode == 1
    assert "too large" in one_line(r.stderr)
    assert snapshot(out) == before
    check_whole(out)
    no_staging(tmp_path)


def test_concurrent_runs_into_one_folder_never_mix(tmp_path):
    """Two different runs into one --out at once, several times: the folder is always one of them, whole."""
    out = tmp_path / "o"
    for _ in range(3):
        a = subprocess.Popen(bhr_exe() + ["follow", "--traj", "curve", "--out", str(out)], cwd=tmp_path, env=ENV,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        b = subprocess.Popen(bhr_exe() + ["follow", "--traj", "curve", "--angle", "360", "--out", str(out)],
                             cwd=tmp_path, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        assert a.wait(300) == 0 and b.wait(300) == 0, (a.stderr.read(), b.stderr.read())
        man = check_whole(out)
        steps = len(json.loads((out / "run.json").read_text())["steps"])
        assert steps in (85, 250)  # the 90 and the 360 degree curve
        assert man["command"] == "follow"
    no_staging(tmp_path)


def test_device_nodes_are_written_in_place_never_replaced(tmp_path):
    """Real device nodes (null and full, made with mknod: the suite runs as root) as --json and --plot targets."""
    null, full = tmp_path / "null", tmp_path / "full"
    os.mknod(null, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    os.mknod(full, 0o666 | stat.S_IFCHR, os.makedev(1, 7))
    r = bhr("solve", "--target", "3", "9", "0", "--json", null, "--plot", null, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for cmd in (["solve", "--target", "3", "9", "0", "--json", full], ["solve", "--target", "3", "9", "0", "--plot", full],
                ["fk", "--codes", "3,0,0", "--json", full],
                ["follow", "--traj", "line", "--no-plots", "--out", "o", "--json", full]):
        r = bhr(*cmd, cwd=tmp_path)
        assert r.returncode == 1 and "No space left on device" in one_line(r.stderr), (cmd, r.stderr)
    for dev in (null, full):
        assert stat.S_ISCHR(dev.lstat().st_mode), dev


def test_full_standard_output_is_one_line(tmp_path):
    with open("/dev/full", "w") as full:
        for cmd in (["solve", "--target", "3", "9", "0"], ["fk", "--codes", "3,0,0", "--json", "-"],
                    ["follow", "--traj", "line", "--no-plots", "--json", "-"]):
            r = subprocess.run(bhr_exe() + cmd, cwd=tmp_path, env=ENV, stdout=full, stderr=subprocess.PIPE,
                               text=True, timeout=300)
            assert r.returncode == 1 and "No space left on device" in one_line(r.stderr), (cmd, r.stderr)


def test_fifo_target_is_written_in_place(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    r = bhr("fk", "--codes", "3,0,0", "--json", fifo, cwd=tmp_path)
    reader.join(30)
    assert r.returncode == 0, r.stderr
    assert json.loads(got[0])["codes"] == [3, 0, 0]
    assert stat.S_ISFIFO(fifo.lstat().st_mode)


def test_symlinks_to_files_are_refused_and_folder_links_kept(tmp_path):
    # a link planted at an output file's path: refused in one line, the file behind it untouched
    real = tmp_path / "real.json"
    real.write_text("{}")
    link = tmp_path / "link.json"
    link.symlink_to(real.name)
    r = bhr("fk", "--codes", "3,0,0", "--json", link, cwd=tmp_path)
    assert r.returncode == 1 and "symbolic link" in one_line(r.stderr) and "write through" in r.stderr
    assert link.is_symlink() and real.read_text() == "{}"
    victim = tmp_path / "victim.gif"
    victim.write_bytes(b"precious")
    (tmp_path / "x.gif").symlink_to(victim.name)
    r = bhr("follow", "--traj", "line", "--no-plots", "--out", "a", "--animate", "x.gif", cwd=tmp_path)
    assert r.returncode == 1 and "symbolic link" in one_line(r.stderr), r.stderr
    assert victim.read_bytes() == b"precious" and not (tmp_path / "a").exists()
    # a link to a folder as --out: the folder it points to gets the run, the link stays
    (tmp_path / "runs").mkdir()
    (tmp_path / "o").symlink_to("runs")
    assert bhr("follow", "--traj", "line", "--no-plots", "--out", "o", cwd=tmp_path).returncode == 0
    assert (tmp_path / "o").is_symlink() and check_whole(tmp_path / "runs")
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to("nowhere/x.json")
    r = bhr("fk", "--codes", "3", "--json", dangling, cwd=tmp_path)
    assert r.returncode == 1 and "symbolic link" in one_line(r.stderr) and dangling.is_symlink()


def test_read_only_file_is_refused(tmp_path):
    ro = tmp_path / "ro.json"
    ro.write_text("{}")
    ro.chmod(0o444)
    r = bhr("fk", "--codes", "3,0,0", "--json", ro, cwd=tmp_path)
    assert r.returncode == 1 and "read-only" in one_line(r.stderr)
    assert ro.read_text() == "{}"


def test_report_leaves_no_stale_run_folders(tmp_path):
    batch = tmp_path / "b.toml"
    batch.write_text('[[run]]\nname = "a"\ntraj = "line"\n[[run]]\nname = "b"\ntraj = "curve"\n')
    assert bhr("report", "--batch", batch, "--out", "r", "--jobs", "1", cwd=tmp_path).returncode == 0
    assert (tmp_path / "r" / "runs" / "b").is_dir()
    batch.write_text('[[run]]\nname = "a"\ntraj = "line"\n')
    r = bhr("report", "--batch", batch, "--out", "r", "--jobs", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in (tmp_path / "r" / "runs").iterdir()) == ["a"]
    check_whole(tmp_path / "r")
    no_staging(tmp_path)


def test_full_standard_output_is_one_line_in_every_printing_command(tmp_path):
    """replay, report, sweep and stream print to stdout too: a full stdout costs one line, never a traceback."""
    assert bhr("follow", "--traj", "line", "--out", "run", "--no-plots", cwd=tmp_path).returncode == 0
    (tmp_path / "b.toml").write_text('[[run]]\nname = "a"\ntraj = "line"\n')
    (tmp_path / "c.csv").write_text("step,m1,m2\n1,3,0\n")
    with open("/dev/full", "w") as full:
        for cmd in (["replay", "run/run.json", "--out", "figs"], ["report", "--batch", "b.toml", "--out", "r", "-j", "1"],
                    ["sweep", "--traj", "line", "--grid", "alpha=8,10", "--out", "s", "-j", "1"],
                    ["stream", "--codes", "c.csv", "--dry-run"]):
            r = subprocess.run(bhr_exe() + cmd, cwd=tmp_path, env=ENV, stdout=full, stderr=subprocess.PIPE,
                               text=True, timeout=300)
            assert r.returncode == 1, (cmd, r.stderr)
            assert "No space left on device" in r.stderr.strip().splitlines()[-1] and "Traceback" not in r.stderr


def test_unwritable_cache_folder_falls_back(tmp_path):
    """A cache folder that cannot be made (its parent is a file): numba's cache goes elsewhere, the run works."""
    (tmp_path / "afile").write_text("x")
    env = dict(ENV, XDG_CACHE_HOME=str(tmp_path / "afile" / "cache"))
    env.pop("NUMBA_CACHE_DIR", None)
    r = subprocess.run(bhr_exe() + ["fk", "--codes", "3,0,6", "--json", "-"], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["codes"] == [3, 0, 6]
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "afile" / "numba")
    r = subprocess.run(bhr_exe() + ["fk", "--codes", "3", "--json", "-"], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and json.loads(r.stdout)["codes"] == [3], r.stderr


def test_a_busy_port_says_so(tmp_path):
    """Another program holds the port (pyserial's exclusive lock on a real pty): the message says it is busy."""
    import serial

    master, slave = os.openpty()
    name = os.ttyname(slave)
    holder = serial.Serial(name, exclusive=True)
    try:
        r = bhr("status", "--port", name, "--timeout", "0.2", "--retries", "0", cwd=tmp_path)
        assert r.returncode == 1 and "in use by another program" in one_line(r.stderr)
    finally:
        holder.close()
        os.close(master)
        os.close(slave)


def test_replies_of_another_protocol_version_are_refused(tmp_path):
    """A peer on a real pty answers every frame correctly framed but in protocol version 2: one clear line."""
    from bhr._hardware import protocol as P
    master, slave = os.openpty()
    name = os.ttyname(slave)
    import tty

    tty.setraw(slave)
    stop = threading.Event()

    def board():
        dec = P.StreamDecoder()
        while not stop.is_set():
            import select

            ready, _, _ = select.select([master], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(master, 1024)
            except OSError:
                return
            for frame in dec.feed(data):
                os.write(master, P.encode_frame(P.Msg.ACK, frame.seq, b"", version=2))

    t = threading.Thread(target=board, daemon=True)
    t.start()
    try:
        r = bhr("status", "--port", name, "--timeout", "0.5", "--retries", "0", cwd=tmp_path)
        assert r.returncode == 1
        assert "protocol version 2" in one_line(r.stderr) and "bhr speaks 1" in r.stderr
    finally:
        stop.set()
        t.join(2)
        os.close(master)
        os.close(slave)


def test_dev_stdout_as_a_target_is_written_in_place(tmp_path):
    """--plot /dev/stdout into a pipe (not seekable) and --json /dev/stdout: the bytes arrive, nothing replaced."""
    r = subprocess.run(bhr_exe() + ["fk", "--codes", "3,0", "--json", "/dev/stdout"], cwd=tmp_path, env=ENV,
                       capture_output=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout.split(b"\n}\n")[0] + b"\n}")["codes"] == [3, 0]
    r = subprocess.run(bhr_exe() + ["solve", "--target", "3", "9", "0", "--json", "-", "--plot", "/dev/stderr"],
                       cwd=tmp_path, env=ENV, capture_output=True, timeout=300)
    assert r.returncode == 0 and r.stderr.startswith(b"\x89PNG\r\n\x1a\n"), r.stderr[:200]
    assert os.path.islink("/dev/stdout") or stat.S_ISCHR(os.stat("/dev/stdout").st_mode)


def test_plan_adds_its_figure_to_the_run_folder_whole(tmp_path):
    """bhr plan on a run's codes.csv: the wires' figure joins that run's folder, which stays one listed set."""
    r = bhr("follow", "--traj", "curve", "--no-plots", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    latest = tmp_path / "bhr-out" / "latest"
    run_files = {k: v for k, v in check_whole(latest.resolve())["files"].items()}
    p = bhr("plan", "--codes", latest / "codes.csv", "--schedule", "auto", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert re.search(r": 85 steps, [\d.]+ s at the wires' pace, at most 10 Hz", p.stdout), p.stdout
    man = check_whole(latest.resolve())
    assert set(man["files"]) == set(run_files) | {"thermal-auto-10hz.png"}
    assert all(man["files"][k] == v for k, v in run_files.items())  # the run's own files untouched
    assert (latest / "thermal-auto-10hz.png").stat().st_size > 10_000
    # the run's own rerun keeps the figure plan added, as it keeps its own (it was deleted)
    r = bhr("follow", "--traj", "curve", "--no-plots", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert set(check_whole(latest.resolve())["files"]) == set(run_files) | {"thermal-auto-10hz.png"}
    # the figure is named as the user named the codes (it was the resolved absolute path)
    p = bhr("plan", "--codes", "bhr-out/latest/codes.csv", cwd=tmp_path)
    assert p.returncode == 0 and p.stderr == "Wrote bhr-out/latest/thermal-auto-10hz.png\n", p.stderr
    # a loose codes.csv (no run folder): the figure is written beside it, nothing else appears
    loose = tmp_path / "loose"
    loose.mkdir()
    (loose / "codes.csv").write_bytes((latest / "codes.csv").read_bytes())
    p = bhr("plan", "--codes", "loose/codes.csv", "--schedule", "auto", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert sorted(q.name for q in loose.iterdir()) == ["codes.csv", "thermal-auto-10hz.png"]
    no_staging(tmp_path / "bhr-out")


@pytest.mark.parametrize("args", [
    ["follow", "--traj", "line", "--no-plots", "--out", "a\nb"],
    ["follow", "--traj", "line", "--no-plots", "--out", "o", "--json", "r\tun.json"],
    ["fk", "--codes", "3,0,0", "--json", "x\ny.json"],
])
def test_output_paths_with_control_characters_are_refused(tmp_path, args):
    r = bhr(*args, cwd=tmp_path)
    assert r.returncode == 1 and r.stdout == ""
    assert "contains a control character" in one_line(r.stderr)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", [["follow", "--solver", "thesis"], ["compare", "--solver", "thesis", "--solver",
                                                                          "ccd"]])
def test_an_open_lumen_end_is_a_different_run_with_its_own_folder(tmp_path, command):
    """--lumen-end changes the clearance, but was left out of the default folder's hash: the open-ended rerun
    replaced the closed one's data in its folder and kept its figures beside it."""
    def folder(*extra: str) -> str:
        r = bhr(*command, "--traj", "anatomy-short", "--no-plots", *extra, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        return re.search(r"bhr-out/([^/]+)/", r.stdout).group(1)

    default, closed, opened = folder(), folder("--lumen-end", "closed"), folder("--lumen-end", "open")
    assert default == closed != opened  # the default end is closed: same run, same folder as before
    assert (tmp_path / "bhr-out" / closed).is_dir() and (tmp_path / "bhr-out" / opened).is_dir()


def test_the_thesis_solver_by_its_old_name_is_the_same_run_shown_by_its_one_name(tmp_path):
    """`--solver seed` (the accepted alias) wrote bhr-out/line-seed-*, a second folder for the thesis's run, and
    a batch run with solver = "seed" showed seed in its summary."""
    def run(*args: str) -> subprocess.CompletedProcess:
        r = bhr(*args, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        return r

    a = run("follow", "--traj", "line", "--length", "40", "--no-plots", "--solver", "seed")
    b = run("follow", "--traj", "line", "--length", "40", "--no-plots", "--solver", "thesis")
    folder = re.search(r"bhr-out/(line-thesis-[0-9a-f]{8})/", a.stdout).group(1)
    assert f"bhr-out/{folder}/" in b.stdout and "seed" not in a.stdout + a.stderr
    assert json.loads((tmp_path / "bhr-out" / folder / "run.json").read_text())["solver"] == "thesis"
    (tmp_path / "b.toml").write_text('[[run]]\nname = "a"\ntraj = "line"\nlength = 40\nsolver = "seed"\n')
    run("report", "--file", "b.toml", "--out", "bhr-out/r", "--no-plots")
    summary = (tmp_path / "bhr-out" / "r" / "summary.csv").read_text()
    assert ",thesis," in summary and "seed" not in summary


@pytest.mark.parametrize("command, figures", [
    (["report", "--file", "b.toml"], ["runs/a/path.png", "runs/a/position_errors.png"]),
    (["sweep", "--grid", "modules=3:4", "--traj", "line"], ["heatmap.png"]),
])
def test_a_rerun_without_figures_keeps_the_earlier_figures(tmp_path, command, figures):
    """--no-plots was part of the studies' settings hash, so the same study rerun with --no-plots into the same
    folder replaced it whole and the figures were gone; as bhr follow does, it now keeps what it does not redraw."""
    (tmp_path / "b.toml").write_text('[[run]]\nname = "a"\ntraj = "line"\nlength = 40\n')
    first = bhr(*command, "--out", "bhr-out/s", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    before = {f: (tmp_path / "bhr-out" / "s" / f).read_bytes() for f in figures}
    again = bhr(*command, "--out", "bhr-out/s", "--no-plots", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert {f: (tmp_path / "bhr-out" / "s" / f).read_bytes() for f in figures} == before
    man = check_whole(tmp_path / "bhr-out" / "s")
    assert set(figures) <= set(man["carried_over"])


def test_a_home_bhr_cannot_write_costs_nothing(tmp_path):
    """HOME=/proc/nohome: the same run twice both succeed (the second replaced the first's folder)."""
    env = dict(ENV, HOME="/proc/nohome")
    env.pop("XDG_CONFIG_HOME", None)
    for _ in range(2):
        r = subprocess.run(bhr_exe() + ["follow", "--traj", "line", "--no-plots"], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
    (folder,) = [p for p in (tmp_path / "bhr-out").iterdir() if not p.is_symlink()]
    check_whole(folder)
    no_staging(tmp_path / "bhr-out")


def test_a_folder_of_another_machine_is_replaced(tmp_path):
    """A run folder copied from another machine (another user, an older bhr, a signed manifest of the old format)
    is bhr's: the same command replaces it."""
    out = tmp_path / "o"
    assert bhr("follow", "--traj", "line", "--no-plots", "--out", out, cwd=tmp_path).returncode == 0
    man = json.loads((out / "manifest.json").read_text())
    man.update(written_by="bhr 0.0.1", bhr_version="0.0.1", signature="hmac-sha256:" + "5" * 64, host="lab-pc")
    (out / "manifest.json").write_text(json.dumps(man))
    r = bhr("follow", "--traj", "curve", "--no-plots", "--out", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert len(json.loads((out / "run.json").read_text())["steps"]) == 85 and "signature" not in check_whole(out)


@pytest.mark.parametrize("args", [["follow", "--traj", "line", "--no-plots"],
                                  ["sweep", "--traj", "line", "--grid", "modules=3", "--jobs", "1", "--no-plots"]],
                         ids=["follow", "sweep"])
def test_a_foreign_folder_is_refused_and_replaced_with_force(tmp_path, args):
    mine = tmp_path / "mine"
    (mine / "src").mkdir(parents=True)
    (mine / "chapter1.tex").write_text("text")
    (mine / "src" / "x.py").write_text("x = 1")
    before = snapshot(tmp_path)
    r = bhr(*args, "--out", "mine", cwd=tmp_path)
    line = one_line(r.stderr)
    assert r.returncode == 1 and line.endswith("folder mine holds chapter1.tex, which no bhr run wrote (no bhr "
                                               "manifest.json lists it); move it out of mine, give another folder, "
                                               "or give --force to replace it"), line
    assert snapshot(tmp_path) == before
    r = bhr(*args, "--out", "mine", "--force", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "chapter1.tex" not in check_whole(mine)["files"] and not (mine / "src").exists()
    no_staging(tmp_path)
