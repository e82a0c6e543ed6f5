"""Output folders replace only bhr's own output (bhr.output._atomic.OutputFolder): a plain manifest.json marks it.

Library-level tests of the rules every command's output goes through; tests/cli/test_outputs.py runs
the commands themselves.
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import pytest

from bhr.output._atomic import MANIFEST, OutputFolder, owning_folder
from bhr.output._paths import settings_hash
from bhr._settings.errors import BhrError


def write_run(target: Path, files: dict[str, str], settings: str | None = None, command: str = "follow",
              **kw) -> OutputFolder:
    with OutputFolder(target, command, settings=settings, **kw) as of:
        for name, text in files.items():
            of.path(name).write_text(text)
    return of


def test_a_bhr_folder_is_replaced_whole(tmp_path):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1", "a.png": "x"})
    write_run(out, {"run.json": "2"})
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "run.json"]
    doc = json.loads((out / MANIFEST).read_text())
    assert doc["bhr_output"] == 2 and set(doc["files"]) == {"run.json"} and doc["bhr_version"]


@pytest.mark.parametrize("extra", ["notes.txt", "sub/notes.md"])
def test_a_users_file_in_a_run_folder_is_never_deleted(tmp_path, extra):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    (out / extra).parent.mkdir(exist_ok=True)
    (out / extra).write_text("my notes")
    with pytest.raises(BhrError) as e:
        write_run(out, {"run.json": "2"})
    msg = str(e.value)
    assert Path(extra).as_posix() in msg and "move it out" in msg and "\n" not in msg
    assert (out / extra).read_text() == "my notes" and (out / "run.json").read_text() == "1"


def test_a_changed_file_is_the_users(tmp_path):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    (out / "run.json").write_text("edited by hand")
    with pytest.raises(BhrError, match="run.json, changed since bhr wrote it"):
        write_run(out, {"run.json": "2"})
    assert (out / "run.json").read_text() == "edited by hand"


def test_a_foreign_manifest_proves_nothing(tmp_path):
    """A web project's folder (manifest.json, index.html, src/app.js) is refused, untouched."""
    proj = tmp_path / "proj"
    (proj / "src").mkdir(parents=True)
    (proj / MANIFEST).write_text(json.dumps({"name": "app", "files": {}}))
    (proj / "index.html").write_text("<html>")
    (proj / "src" / "app.js").write_text("x")
    with pytest.raises(BhrError, match="no bhr run wrote"):
        write_run(proj, {"index.html": "bhr"})
    assert (proj / "src" / "app.js").read_text() == "x" and (proj / "index.html").read_text() == "<html>"


def test_a_manifest_that_does_not_list_a_file_is_refused(tmp_path):
    """Only the files the manifest lists may be there: a copied-in bhr manifest does not license others."""
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    (out / "index.html").write_text("mine")
    with pytest.raises(BhrError, match="index.html"):
        write_run(out, {"run.json": "2"})


def test_a_folder_holding_an_input_is_refused(tmp_path):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    with pytest.raises(BhrError, match="an input of this run"):
        OutputFolder(out, "follow", inputs=[out / "run.json"]).check()
    with pytest.raises(BhrError, match="an input of this run"):
        OutputFolder(tmp_path, "follow", inputs=[out / "run.json"]).check()  # a parent of the input too
    # with keep (bhr replay redrawing a run's figures) the input is carried over, so allowed
    OutputFolder(out, "replay", inputs=[out / "run.json"], keep=True).check()


def test_the_current_folder_and_its_parents_are_refused(tmp_path, monkeypatch):
    write_run(tmp_path / "a", {"run.json": "1"})  # even a bhr folder: it holds the current folder
    here = tmp_path / "a" / "b"
    here.mkdir(parents=True)
    monkeypatch.chdir(here)
    for target in (".", "..", str(tmp_path), "/"):
        with pytest.raises(BhrError, match="current folder"):
            OutputFolder(target, "follow").check()


def test_same_settings_keep_what_the_rerun_does_not_make(tmp_path):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1", "path.png": "fig"}, settings="abc")
    write_run(out, {"run.json": "2"}, settings="abc")  # --no-plots: the figure of the same settings stays
    assert (out / "path.png").read_text() == "fig" and (out / "run.json").read_text() == "2"
    doc = json.loads((out / MANIFEST).read_text())
    assert set(doc["files"]) == {"run.json", "path.png"} and doc["carried_over"] == ["path.png"]
    OutputFolder(out, "follow").check()  # still only bhr's files: replaceable
    write_run(out, {"run.json": "3"}, settings="other")  # other settings: the old figure is not this run's
    assert not (out / "path.png").exists()


def test_files_added_beside_a_run_survive_its_rerun(tmp_path):
    """bhr plan (or replay) adds a figure to a follow run's folder; the same follow run again keeps it, as it keeps
    its own figures (it was deleted: plan's manifest named another command and no settings)."""
    out = tmp_path / "o"
    write_run(out, {"run.json": "1", "codes.csv": "c"}, settings="abc")
    write_run(out, {"thermal.png": "t"}, command="plan", keep=True)
    doc = json.loads((out / MANIFEST).read_text())
    assert doc["command"] == "plan" and doc["made_by"] == "follow" and doc["settings"] == "abc"
    write_run(out, {"run.json": "2", "codes.csv": "c"}, settings="abc")  # the rerun: same settings
    assert (out / "thermal.png").read_text() == "t" and (out / "run.json").read_text() == "2"
    assert json.loads((out / MANIFEST).read_text())["carried_over"] == ["thermal.png"]
    write_run(out, {"thermal.png": "t2"}, command="plan", keep=True)  # plan again, then another follow
    write_run(out, {"run.json": "3"}, settings="other")  # other settings: the old figure is not this run's
    assert not (out / "thermal.png").exists()


def test_a_symbolic_link_inside_is_not_bhrs(tmp_path):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    victim = tmp_path / "victim"
    victim.mkdir()
    os.symlink(victim, out / "link")
    with pytest.raises(BhrError, match="link, which no bhr run wrote"):
        write_run(out, {"run.json": "2"})
    assert victim.is_dir()


def test_settings_hash_follows_file_content(tmp_path):
    f = tmp_path / "t.csv"
    f.write_text("1")
    a = settings_hash({"x": 1}, f)
    f.write_text("2")
    assert settings_hash({"x": 1}, f) != a and settings_hash({"x": 1}, f) == settings_hash({"x": 1}, f)


def _listing(files: dict[str, str], **fields) -> str:
    """A manifest.json as bhr writes it, listing ``files`` (name -> text)."""
    listed = {n: {"bytes": len(t.encode()), "sha256": hashlib.sha256(t.encode()).hexdigest()} for n, t in files.items()}
    return json.dumps({"bhr_output": 2, "command": "follow", "run_id": "0" * 32, "files": listed, **fields})


@pytest.mark.parametrize("fields", [
    {"written_by": "bhr 0.0.9", "bhr_version": "0.0.9"},  # an older bhr
    {"signature": "hmac-sha256:" + "0" * 64},  # signed with a key of another user or machine
    {"bhr_output": 1},  # the first manifest format
    {"bhr_output": 7, "host": "elsewhere", "user": "someone"},  # a later bhr, on another machine
])
def test_a_folder_from_another_machine_user_or_bhr_is_replaced(tmp_path, fields):
    out = tmp_path / "o"
    out.mkdir()
    mine = {"run.json": "theirs", "figs/path.png": "png"}
    for name, text in mine.items():
        (out / name).parent.mkdir(exist_ok=True)
        (out / name).write_text(text)
    (out / MANIFEST).write_text(_listing(mine, **fields))
    write_run(out, {"run.json": "new"})
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "run.json"] and (out / "run.json").read_text() == "new"
    assert sorted(os.listdir(tmp_path)) == ["o"]  # no staging folder, no lock file, no folder set aside


def test_a_foreign_folder_is_refused_and_replaced_with_force(tmp_path):
    proj = tmp_path / "proj"
    (proj / "src").mkdir(parents=True)
    (proj / "notes.txt").write_text("mine")
    (proj / "src" / "a.c").write_text("int x;")
    with pytest.raises(BhrError) as e:
        write_run(proj, {"run.json": "1"})
    assert str(e.value) == (f"output folder {proj} holds notes.txt, which no bhr run wrote (no bhr manifest.json "
                            f"lists it); move it out of {proj}, give another folder, or give --force to replace it")
    assert (proj / "notes.txt").read_text() == "mine" and (proj / "src" / "a.c").read_text() == "int x;"
    write_run(proj, {"run.json": "1"}, force=True)
    assert sorted(p.name for p in proj.iterdir()) == [MANIFEST, "run.json"]
    assert sorted(os.listdir(tmp_path)) == ["proj"]


def test_force_never_replaces_the_current_folder_or_an_inputs_folder(tmp_path, monkeypatch):
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "t.csv").write_text("x,y,z\n")
    monkeypatch.chdir(tmp_path / "d")
    with pytest.raises(BhrError, match="current folder"):
        OutputFolder(".", "follow", force=True).check()
    monkeypatch.chdir(tmp_path)
    with pytest.raises(BhrError, match="an input of this run"):
        OutputFolder("d", "follow", inputs=["d/t.csv"], force=True).check()


def test_a_plain_manifest_owns_the_files_it_lists(tmp_path):
    """bhr plan and replay add their figures to the folder whose manifest lists the codes, whoever wrote it."""
    out = tmp_path / "cmp"
    write_run(out, {"thesis/codes.csv": "c"})
    assert owning_folder(out / "thesis" / "codes.csv") == (out.resolve(), "thesis/codes.csv")
    other = tmp_path / "copied"
    (other / "thesis").mkdir(parents=True)
    (other / "thesis" / "codes.csv").write_text("c")
    (other / MANIFEST).write_text(_listing({"thesis/codes.csv": "c"}))
    assert owning_folder(other / "thesis" / "codes.csv") == (other.resolve(), "thesis/codes.csv")
    assert owning_folder(other / "thesis" / "other.csv") is None


def test_a_folder_set_aside_by_a_killed_run_is_put_back(tmp_path):
    """Killed between its two renames, a run leaves the old folder whole under .NAME.bhr-old-*: the next run into
    the place puts it back before anything else (here: its work then fails, so the old folder stays)."""
    out = tmp_path / "o"
    write_run(out, {"run.json": "1", "a.png": "x"}, settings="s")
    os.rename(out, tmp_path / ".o.bhr-old-0123456789ab")
    mine = tmp_path / ".o.bhr-old-mine"  # the user's, only named like one: no bhr manifest
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    with pytest.raises(RuntimeError):  # fails after the lock was taken once
        with OutputFolder(out, "follow"):
            raise RuntimeError
    assert (out / "run.json").read_text() == "1" and (out / "a.png").read_text() == "x"
    assert sorted(os.listdir(tmp_path)) == [".o.bhr-old-mine", "o"]


def test_what_is_placed_early_is_placed_once(tmp_path):
    """A command that waits on the user (``--show``) places its set first (place_now); the block's end then places
    only what came after, and the folder placed early stays as it is."""
    from bhr.output._atomic import place_now, together, write_text

    with together():
        write_run(tmp_path / "run", {"run.json": "1"})
        place_now()
        assert (tmp_path / "run" / "run.json").read_text() == "1"  # in place while the block still runs
        write_text(tmp_path / "later.txt", "2")
    assert (tmp_path / "run" / "run.json").read_text() == "1" and (tmp_path / "later.txt").read_text() == "2"
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]  # no stage left behind


def _interrupted_at(n: int, write) -> str | None:
    """Run ``write()`` with a Ctrl-C at the ``n``-th place one can land; where it landed, or None if it ended first.

    Python runs a signal's handler as a function starts and as a call returns (not between two plain lines): so
    at the ``n``-th start or return of a Python function of bhr's or of one that bhr calls (the import machinery
    and objects' finalisers aside: a KeyboardInterrupt there is Python's to print and drop; deeper in a library,
    a Ctrl-C leaves bhr as one in the call bhr made does). A generator's yield is not a return: there the Ctrl-C
    lands in its caller once the call returns.
    """
    import inspect
    import sys

    import bhr

    BHR, count, where, ours = os.path.dirname(bhr.__file__) + os.sep, [0], [], []

    def near_bhr(frame) -> bool:
        for _ in range(2):
            if frame is None:
                return False
            if frame.f_code.co_filename.startswith((BHR, __file__)):
                return True
            frame = frame.f_back
        return False

    def trace(frame, event, arg):
        code = frame.f_code
        if code.co_filename.startswith("<frozen") or code.co_name == "__del__":
            return None
        frame.f_trace_lines = False  # its calls and returns only
        if (event == "call" or event == "return" and not code.co_flags & inspect.CO_GENERATOR) and near_bhr(frame):
            count[0] += 1
            if count[0] == n:
                where.append(f"{event} of {code.co_name} ({os.path.basename(code.co_filename)}:{frame.f_lineno})")
                ours.append(code.co_filename.startswith(BHR))
                raise KeyboardInterrupt  # as the command line's signal handler does
        return trace

    sys.settrace(trace)
    try:
        write()
    except KeyboardInterrupt:
        return where[0]
    finally:
        sys.settrace(None)
    # landed in a callback the garbage collector ran meanwhile (a weak reference's): Python printed and dropped it,
    # and the write went on, as in a real run; bhr's own code never drops one
    assert not any(ours), f"bhr went on after a Ctrl-C at {where[0]}"
    return f"{where[0]}, dropped by Python" if where else None


# a Ctrl-C landing in a finaliser a collection runs meanwhile (an abandoned lock's, a file object's) is printed and
# dropped by Python, as in a real run
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning", "ignore::ResourceWarning")
@pytest.mark.parametrize("what", ["file", "folder"])
def test_a_ctrl_c_at_any_place_leaves_nothing_half_made(tmp_path, what):
    # wherever a Ctrl-C lands, the output is there whole or not at all and nothing else is left (a temporary file
    # named only once made stayed behind when it landed just after, a stage when it landed as the block that wrote
    # it ended); written inside together(), as every command writes; and the next write works
    from bhr.output._atomic import atomic_path, together

    def write(d: Path) -> None:
        with together():
            if what == "folder":
                write_run(d / "o", {"run.json": "1"})
            else:
                with atomic_path(d / "a.gif") as tmp:
                    tmp.write_text("frames")

    write(tmp_path)  # what it imports on first use, imported
    whole = ["o", f"o/{MANIFEST}", "o/run.json"] if what == "folder" else ["a.gif"]
    place = 0
    while True:
        place += 1
        d = tmp_path / f"try{place}"
        d.mkdir()
        landed = _interrupted_at(place, lambda: write(d))
        left = sorted(p.relative_to(d).as_posix() for p in d.rglob("*") if not p.name.endswith(".bhr-lock"))
        assert left in ([], whole), (landed, left)
        if left:
            assert (d / whole[-1]).read_text() == ("1" if what == "folder" else "frames"), landed
        if landed is None:
            assert left == whole  # not landing, the write went through
            break
    assert place > 50  # the write's every call was a place
