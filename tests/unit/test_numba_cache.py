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


def test_a_failed_cache_write_costs_a_compile_not_the_command(tmp_path, monkeypatch):
    import errno

    import numba
    from numba.core import caching

    assert getattr(caching.Cache.save_overload, "_bhr_guarded", False)  # bhr imported: numba's cache is guarded

    @numba.njit(cache=True)
    def twice(x):
        return 2.0 * x

    def too_large(*_args):
        raise OSError(errno.EFBIG, "File too large")  # as a write under ulimit -f

    monkeypatch.setattr(caching.IndexDataCacheFile, "save", too_large)
    assert twice(3.0) == 6.0  # compiled, not cached, and runs

    class Cache:  # a module whose Cache is not guarded yet: guarded once, its other errors untouched
        def save_overload(self, sig, data):
            raise OSError(errno.ENOSPC, "No space left on device")

    module = type(os)("caching")
    module.Cache = Cache
    _numba.guard_cache_writes(module)
    guarded = Cache.save_overload
    _numba.guard_cache_writes(module)
    assert Cache.save_overload is guarded
    Cache().save_overload(None, None)
