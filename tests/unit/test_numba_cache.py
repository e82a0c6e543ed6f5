"""numba's compiled cache is kept per copy of bhr's sources (bhr/_numba.py)."""
from __future__ import annotations

import os

from bhr import _numba


def test_the_key_changes_with_any_source_and_only_then(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "b.py").write_text("y = 2\n")
    (pkg / "notes.txt").write_text("not a source")
    key = _numba.source_key(pkg)
    assert len(key) == 12 and key == _numba.source_key(pkg)
    (pkg / "notes.txt").write_text("changed, still not a source")
    assert _numba.source_key(pkg) == key
    st = (pkg / "sub" / "b.py").stat()
    os.utime(pkg / "sub" / "b.py", ns=(st.st_atime_ns, st.st_mtime_ns + 1))  # a callee edited in another module
    touched = _numba.source_key(pkg)
    assert touched != key
    (pkg / "c.py").write_text("")
    assert _numba.source_key(pkg) not in (key, touched)


def test_the_default_folder_names_this_copy_of_the_sources(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    _numba.configure_cache()
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "bhr" / "numba" / _numba.source_key())
    assert (tmp_path / "bhr" / "numba" / _numba.source_key()).is_dir()


def test_a_folder_the_user_chose_is_kept(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    _numba.configure_cache()
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "mine")


def test_an_unwritable_home_falls_back_to_the_temporary_folder(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", "/proc/nohome")
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)  # read TMPDIR again
    folder = _numba.configure_cache()
    assert folder == str(tmp_path / f"bhr-numba-{os.getuid()}" / _numba.source_key())
    assert os.environ["NUMBA_CACHE_DIR"] == folder and os.path.isdir(folder)
