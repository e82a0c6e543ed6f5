"""A folder is replaced only when its manifest proves that bhr wrote it: the manifest is signed with a key of the
user's (bhr.output.atomic.output_key), so that one forged with the right sizes and hashes, edited, copied from
another user or machine, or written by an older bhr proves nothing.

Every test here keeps its key in a temporary config folder (XDG_CONFIG_HOME), never the user's.
"""
from __future__ import annotations

import copy
import hashlib
import json
import multiprocessing
import os
import stat
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from bhr.output import atomic
from bhr.output.atomic import (KEY_ENV, MANIFEST, OutputFolder, key_file, output_key, owning_folder, sign_manifest,
                               signed_by_bhr, verify_folder)
from bhr.settings.errors import BhrError

NOT_SIGNED = ("has a manifest.json not signed by bhr for this user (copied, edited or written by an older bhr); "
              "remove the folder yourself or give another folder for the output")


@pytest.fixture(autouse=True)
def config_home(tmp_path, monkeypatch) -> Path:
    """A config folder of the test's own: the key is made there (tests/conftest.py's BHR_OUTPUT_KEY_FILE unset)."""
    cfg = tmp_path / "config"
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(cfg))
    return cfg


def write_run(target: Path, files: dict[str, str], settings: str | None = None, **kw: Any) -> OutputFolder:
    with OutputFolder(target, "follow", settings=settings, **kw) as of:
        for name, text in files.items():
            of.path(name).write_text(text)
    return of


def everything(folder: Path) -> dict[str, tuple[int, int, bytes]]:
    """Every entry under ``folder`` but the test's config folder (bhr may make its key there): name, mode, time
    and content, to prove nothing changed."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.relative_to(folder).parts[0] == "config" and folder.name != "config":
            continue
        st_ = p.lstat()
        out[str(p.relative_to(folder))] = (st_.st_mode, st_.st_mtime_ns, p.read_bytes() if p.is_file() else b"")
    return out


def forged(files: dict[str, str], **extra: Any) -> str:
    """A manifest anyone can write: every file listed with its right size and SHA-256."""
    listed = {n: {"bytes": len(t.encode()), "sha256": hashlib.sha256(t.encode()).hexdigest()} for n, t in files.items()}
    return json.dumps({"bhr_output": 2, "written_by": "bhr 1", "bhr_version": "1", "command": "follow",
                       "made_by": "follow", "run_id": "0" * 32, "settings": None, "files": listed,
                       "carried_over": [], **extra}, indent=1)


def refused(target: Path, files: dict[str, str] | None = None) -> str:
    """Try to write a run into ``target``: the one-line refusal; nothing under target's parent changed."""
    before = everything(target.parent)
    with pytest.raises(BhrError) as e:
        write_run(target, files or {"run.json": "new"})
    assert everything(target.parent) == before
    msg = str(e.value)
    assert "\n" not in msg
    return msg


# --- a folder bhr wrote ------------------------------------------------------------------------------------------

def test_a_folder_bhr_wrote_is_signed_and_replaced(tmp_path, config_home):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1", "a.png": "x"})
    doc = json.loads((out / MANIFEST).read_text())
    assert doc["signature"].startswith("hmac-sha256:") and len(doc["signature"]) == len("hmac-sha256:") + 64
    key_path = config_home / "bhr" / "output-key"
    assert key_file() == key_path
    key = key_path.read_bytes()
    assert len(key) == 32 and stat.S_IMODE(key_path.stat().st_mode) == 0o600
    assert stat.S_IMODE(key_path.parent.stat().st_mode) == 0o700
    assert key.hex() not in (out / MANIFEST).read_text()  # the key itself is never written out
    assert verify_folder(out) == doc
    write_run(out, {"run.json": "2"})  # replaced whole, as before
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "run.json"]
    assert (out / "run.json").read_text() == "2" and key_path.read_bytes() == key  # the same key, not a new one


def test_the_key_lives_in_the_home_config_folder_without_xdg(tmp_path, monkeypatch):
    monkeypatch.delenv("XDG_CONFIG_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert key_file() == tmp_path / "home" / ".config" / "bhr" / "output-key"
    monkeypatch.setenv("XDG_CONFIG_HOME", "relative/cfg")  # not a config folder (the XDG rule): the home's
    assert key_file() == tmp_path / "home" / ".config" / "bhr" / "output-key"
    write_run(tmp_path / "o", {"run.json": "1"})
    write_run(tmp_path / "o", {"run.json": "2"})
    assert (tmp_path / "home" / ".config" / "bhr" / "output-key").stat().st_size == 32


def test_a_signed_manifest_reformatted_is_still_bhrs(tmp_path):
    """The signature covers the content, not its layout: keys in another order, other indentation."""
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    doc = json.loads((out / MANIFEST).read_text())
    (out / MANIFEST).write_text(json.dumps(dict(reversed(list(doc.items()))), indent=4, sort_keys=False))
    write_run(out, {"run.json": "2"})
    assert (out / "run.json").read_text() == "2"


# --- manifests that prove nothing --------------------------------------------------------------------------------

@pytest.mark.parametrize("signature", [None, "", "hmac-sha256:" + "0" * 64, "hmac-sha256:" + "é" * 64, 7,
                                       "another key"])
def test_a_forged_manifest_with_the_right_hashes_is_refused(tmp_path, signature):
    mine = {"notes.txt": "my thesis notes", "data.csv": "1,2,3\n"}
    proj = tmp_path / "proj"
    proj.mkdir()
    for name, text in mine.items():
        (proj / name).write_text(text)
    extra: dict[str, Any] = {} if signature is None else {"signature": signature}
    if signature == "another key":  # signed properly, with a key that is not this user's
        extra = {"signature": sign_manifest(json.loads(forged(mine)), os.urandom(32))}
    (proj / MANIFEST).write_text(forged(mine, **extra))
    msg = refused(proj)
    assert msg == f"output folder {proj} {NOT_SIGNED}"
    assert (proj / "notes.txt").read_text() == "my thesis notes"
    assert sorted(os.listdir(tmp_path)) == ["config", "proj"]  # no staging folder left beside it


@pytest.mark.parametrize("edit", ["command", "add a file", "drop a file", "settings", "signature"])
def test_an_edited_signed_manifest_is_refused(tmp_path, edit):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1", "codes.csv": "c"}, settings="abc")
    doc = json.loads((out / MANIFEST).read_text())
    if edit == "command":
        doc["command"] = "plan"
    elif edit == "add a file":  # the user's file, listed with its right hash in bhr's own manifest
        (out / "notes.txt").write_text("mine")
        doc["files"]["notes.txt"] = {"bytes": 4, "sha256": hashlib.sha256(b"mine").hexdigest()}
    elif edit == "drop a file":
        (out / "codes.csv").unlink()
        del doc["files"]["codes.csv"]
    elif edit == "settings":
        doc["settings"] = "xyz"
    else:
        doc["signature"] = doc["signature"][:-1] + ("0" if doc["signature"][-1] != "0" else "1")
    (out / MANIFEST).write_text(json.dumps(doc, indent=1))
    assert refused(out).endswith(NOT_SIGNED)


def test_a_folder_copied_from_another_user_or_machine_is_refused(tmp_path, monkeypatch):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config" / "other-machine"))  # another key
    assert refused(out) == f"output folder {out} {NOT_SIGNED}"


def test_an_older_bhrs_manifest_is_refused(tmp_path):
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    doc = json.loads((out / MANIFEST).read_text())
    del doc["signature"]  # as bhr wrote them before it signed them
    (out / MANIFEST).write_text(json.dumps(doc, indent=1))
    assert refused(out).endswith(NOT_SIGNED)


def test_an_empty_folder_needs_no_proof(tmp_path):
    (tmp_path / "o").mkdir()
    write_run(tmp_path / "o", {"run.json": "1"})
    assert (tmp_path / "o" / "run.json").read_text() == "1"


def test_only_a_signed_manifest_owns_a_file(tmp_path):
    """bhr plan and replay put their figures into the folder whose manifest lists the codes: only a signed one."""
    out = tmp_path / "cmp"
    write_run(out, {"thesis/codes.csv": "c"})
    assert owning_folder(out / "thesis" / "codes.csv") == (out.resolve(), "thesis/codes.csv")
    loose = tmp_path / "mine"
    (loose / "thesis").mkdir(parents=True)
    (loose / "thesis" / "codes.csv").write_text("c")
    (loose / MANIFEST).write_text(forged({"thesis/codes.csv": "c"}))
    assert owning_folder(loose / "thesis" / "codes.csv") is None


def test_a_users_folder_with_a_forged_staging_mark_is_kept(tmp_path):
    """A folder named like a dead run's stage, holding a .bhr-staging file bhr did not sign, is not deleted."""
    mine = tmp_path / ".o.bhr-stage-999999-abc"
    mine.mkdir()
    (mine / ".bhr-staging").write_text("")
    (mine / "notes.txt").write_text("mine")
    dead = tmp_path / ".o.bhr-stage-999998-def"  # a dead run's, with the mark bhr signed
    dead.mkdir()
    write_run(tmp_path / "x", {"a": "1"})  # the key exists now
    key, _ = output_key()
    assert key is not None
    (dead / ".bhr-staging").write_text(atomic._stage_mark_text(dead.name, key))
    (dead / "run.json").write_text("{")
    write_run(tmp_path / "o", {"run.json": "1"})
    assert (mine / "notes.txt").read_text() == "mine" and not dead.exists()
    assert ".bhr-staging" not in os.listdir(tmp_path / "o")


# --- the key -------------------------------------------------------------------------------------------------------

def _make_key(path: str, start: Any, out: Any) -> None:
    os.environ[KEY_ENV] = path
    start.wait()
    key, why = output_key()
    out.put(hashlib.sha256(key).hexdigest() if key is not None else why)  # never the key itself


def test_processes_making_the_key_at_once_agree_on_one(tmp_path):
    ctx = multiprocessing.get_context("fork")
    n = 6
    for attempt in range(4):
        path = tmp_path / f"cfg{attempt}" / "bhr" / "output-key"
        start, out = ctx.Barrier(n), ctx.Queue()
        procs = [ctx.Process(target=_make_key, args=(str(path), start, out)) for _ in range(n)]
        for p in procs:
            p.start()
        got = [out.get(timeout=60) for _ in procs]
        for p in procs:
            p.join(60)
            assert p.exitcode == 0
        assert got == [hashlib.sha256(path.read_bytes()).hexdigest()] * n, got
        assert os.listdir(path.parent) == ["output-key"]  # every process's own attempt removed


def _a_key(config_home: Path, content: bytes = b"k" * 32, mode: int = 0o600) -> Path:
    path = config_home / "bhr" / "output-key"
    path.parent.mkdir(parents=True, mode=0o700)
    path.write_bytes(content)
    os.chmod(path, mode)
    return path


@pytest.mark.parametrize("case", ["group-readable", "world-readable", "group-writable", "too short", "too long",
                                  "a folder", "a symbolic link", "another user's"])
def test_a_key_file_not_to_be_trusted_is_not_used(tmp_path, config_home, case):
    if case == "another user's" and os.geteuid() != 0:
        pytest.skip("giving a file to another user needs root")
    path = config_home / "bhr" / "output-key"
    if case == "a folder":
        path.mkdir(parents=True)
    elif case == "a symbolic link":  # to a key that would do otherwise
        real = _a_key(tmp_path / "elsewhere")
        path.parent.mkdir(parents=True)
        os.symlink(real, path)
    else:
        content = {"too short": b"k" * 31, "too long": b"k" * 33}.get(case, b"k" * 32)
        mode = {"group-readable": 0o640, "world-readable": 0o604, "group-writable": 0o620}.get(case, 0o600)
        _a_key(config_home, content, mode)
        if case == "another user's":
            os.chown(path, 65534, 65534)
    before = everything(config_home)
    key, why = output_key()
    assert key is None and str(path) in why and "does not trust it" in why
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})  # the output is still written, unsigned
    assert "signature" not in json.loads((out / MANIFEST).read_text())
    msg = refused(out)  # and never replaced
    assert msg.startswith(f"output folder {out} has a manifest.json that bhr cannot check: the signing key {path}")
    assert msg.endswith("remove the folder yourself or give another folder for the output")
    assert everything(config_home) == before  # the key file is left as it was, not replaced


def test_without_a_key_output_is_written_unsigned_and_never_replaced(tmp_path, monkeypatch):
    (tmp_path / "afile").write_text("not a folder")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "afile"))  # no key can be made there
    out = tmp_path / "o"
    write_run(out, {"run.json": "1"})
    assert "signature" not in json.loads((out / MANIFEST).read_text())
    msg = refused(out)
    assert msg == (f"output folder {out} has a manifest.json that bhr cannot check: bhr has no signing key: it "
                   f"cannot make {tmp_path}/afile/bhr/output-key (Not a directory); remove the folder yourself or "
                   "give another folder for the output")


# --- any change to a signed manifest's content invalidates it (property) ---------------------------------------------

@pytest.fixture(scope="module")
def signed_run(tmp_path_factory):
    """One folder bhr wrote, its manifest and key (module-wide: the property below tries many changes to it)."""
    root = tmp_path_factory.mktemp("signed")
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv(KEY_ENV, raising=False)
        mp.setenv("XDG_CONFIG_HOME", str(root / "config"))
        out = root / "o"
        write_run(out, {"run.json": "1", "codes.csv": "c", "figs/path.png": "p"}, settings="abc")
        key, _ = output_key()
        text = (out / MANIFEST).read_text()
        yield out, json.loads(text), key, text, root / "config"
    (out / MANIFEST).write_text(text)


def _nodes(obj: Any, path: tuple = ()) -> list[tuple]:
    found = [path]
    if isinstance(obj, dict):
        for k, v in obj.items():
            found += _nodes(v, path + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            found += _nodes(v, path + (i,))
    return found


JSON_VALUES = st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=12),
                           lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner,
                                                                                        max_size=3),
                           max_leaves=6)


def _canonical(doc: dict) -> str:
    return json.dumps({k: v for k, v in doc.items() if k != "signature"}, sort_keys=True)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_change_to_a_signed_manifests_content_invalidates_it(signed_run, monkeypatch, data):
    out, doc, key, text, config = signed_run
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(config))
    assert signed_by_bhr(doc, key)
    changed = copy.deepcopy(doc)
    where = data.draw(st.sampled_from([p for p in _nodes(doc) if p[:1] != ("signature",)]), label="where")
    how = data.draw(st.sampled_from(["replace", "delete", "add"]), label="how")
    parent = changed
    for step in where[:-1]:
        parent = parent[step]
    node = parent[where[-1]] if where else changed
    if how == "replace" and where:
        parent[where[-1]] = data.draw(JSON_VALUES, label="value")
    elif how == "delete" and where:
        del parent[where[-1]]
    elif isinstance(node, dict):
        name = data.draw(st.text(max_size=8).filter(lambda k: where or k != "signature"), label="new key")
        node[name] = data.draw(JSON_VALUES, label="value")
    elif isinstance(node, list):
        node.append(data.draw(JSON_VALUES, label="value"))
    else:
        parent[where[-1]] = data.draw(JSON_VALUES, label="value")
    assume(_canonical(changed) != _canonical(doc))
    assert not signed_by_bhr(changed, key)
    (out / MANIFEST).write_text(json.dumps(changed, indent=1))
    try:
        with pytest.raises(BhrError):
            verify_folder(out)
    finally:
        (out / MANIFEST).write_text(text)
    assert verify_folder(out) == doc
