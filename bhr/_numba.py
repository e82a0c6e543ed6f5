"""Where numba keeps its compiled cache, set before numba is first imported.

numba writes its cache next to the sources by default, which fails or
pollutes site-packages for installed copies. Unless the user chose a folder
with NUMBA_CACHE_DIR, bhr uses ``$XDG_CACHE_HOME/bhr/numba/<key>``
(``~/.cache``), where the key names this copy of bhr's sources (their names,
sizes and modification times). numba checks only a kernel's own file before
loading it from the cache, so a kernel that calls a kernel of another module
would otherwise keep the old callee after that module changed (an upgrade,
or an edit in a checkout): a new copy of bhr starts a cache of its own
instead. When that folder cannot be written (a read-only or missing home),
bhr falls back to a per-user folder in the system's temporary directory, so
a run never fails for want of a cache (numba refuses to load cached kernels
at all when no cache folder is writable).
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

_SOURCES = Path(__file__).resolve().parent


def _usable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return folder.is_dir() and os.access(folder, os.W_OK | os.X_OK)


def source_key(root: Path = _SOURCES) -> str:
    """12 hex digits naming the Python sources under ``root`` as they are now (names, sizes, mtimes)."""
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        try:
            st = path.stat()
        except OSError:
            continue
        h.update(f"{path.relative_to(root)}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()[:12]


def configure_cache() -> None:
    chosen = os.environ.get("NUMBA_CACHE_DIR")
    if chosen and _usable(Path(chosen)):
        return
    key = source_key()
    if not chosen:
        try:
            base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        except RuntimeError:  # no home directory at all
            base = ""
        folder = Path(base) / "bhr" / "numba" / key if base else None
        if folder is not None and _usable(folder):
            os.environ["NUMBA_CACHE_DIR"] = str(folder)
            return
    uid = os.getuid() if hasattr(os, "getuid") else 0
    fallback = Path(tempfile.gettempdir()) / f"bhr-numba-{uid}" / key
    if not _usable(fallback):
        fallback = Path(tempfile.mkdtemp(prefix="bhr-numba-"))
    os.environ["NUMBA_CACHE_DIR"] = str(fallback)


def cache_dir() -> str:
    """The folder numba's compiled cache goes to (set by :func:`configure_cache` unless the user chose one)."""
    return os.environ.get("NUMBA_CACHE_DIR", "")


def cache_has_kernels() -> bool:
    """Whether numba's cache holds any compiled bhr kernel yet (False on a machine's first run)."""
    root = Path(cache_dir())
    # numba keeps each source folder's kernels in "<folder name>_<hash>": bhr's package folders
    folders = {p.parent.name for p in Path(__file__).parent.rglob("__init__.py")}
    try:
        return any(any(root.glob(f"{name}_*/*.nbi")) for name in folders)
    except OSError:
        return False


class _LightBlas:
    """Lets numba find scipy's BLAS without importing all of scipy.linalg (about 0.2 s of CPU per command).

    When numba loads its array functions (``numba.np.arraymath``, on the first
    kernel a command calls) it checks for BLAS by importing
    ``scipy.linalg.cython_blas``, which runs ``scipy.linalg``'s whole
    ``__init__`` (scipy's array API layer, numpy.testing, f2py...). The check
    needs only the extension module itself, so this import hook loads it
    straight from its file just before numba's check runs: numba sees the same
    BLAS (``_HAVE_BLAS`` unchanged), and ``scipy.linalg`` imported later is the
    whole package as usual. Without scipy, or when anything here fails, numba
    does what it always does.
    """

    def find_spec(self, name, path=None, target=None):  # a meta path finder
        import sys

        if name == "numba.np.arraymath":  # numba's check is about to run: the extension alone, from its file
            _preload_cython_blas()
        elif name == "scipy.linalg" and "scipy.linalg.cython_blas" in sys.modules:
            # the whole package after all: find it as usual, then give it its preloaded submodule as an attribute
            sys.meta_path[:] = [f for f in sys.meta_path if f is not self]
            import importlib.util

            spec = importlib.util.find_spec(name)
            if spec is not None and spec.loader is not None and hasattr(spec.loader, "exec_module"):
                loader = spec.loader
                run = loader.exec_module

                def exec_module(module, run=run):
                    run(module)
                    module.cython_blas = sys.modules["scipy.linalg.cython_blas"]

                loader.exec_module = exec_module  # type: ignore[method-assign]
            return spec
        return None


def _preload_cython_blas() -> None:
    import importlib.machinery
    import importlib.util
    import sys

    if "scipy.linalg" in sys.modules or "scipy.linalg.cython_blas" in sys.modules:
        sys.meta_path[:] = [f for f in sys.meta_path if not isinstance(f, _LightBlas)]
        return
    name = "scipy.linalg.cython_blas"
    try:
        top = importlib.util.find_spec("scipy")
        if top is None or not top.submodule_search_locations:
            return
        for base in top.submodule_search_locations:
            for suffix in importlib.machinery.EXTENSION_SUFFIXES:
                file = Path(base) / "linalg" / f"cython_blas{suffix}"
                if file.is_file():
                    break
            else:
                continue
            break
        else:
            return
        import scipy  # noqa: F401  (the package itself is light)

        spec = importlib.util.spec_from_file_location(name, file)
        if spec is None or spec.loader is None:
            return
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    except Exception:  # anything unexpected: numba's own import decides, as without this hook
        sys.modules.pop(name, None)


def install_light_blas() -> None:
    """Put the :class:`_LightBlas` hook first on ``sys.meta_path`` (once; no effect once numba's arrays loaded)."""
    import sys

    if "numba.np.arraymath" in sys.modules or any(isinstance(f, _LightBlas) for f in sys.meta_path):
        return
    sys.meta_path.insert(0, _LightBlas())


class _CacheWriteGuard:
    """Makes a failed write to numba's cache cost a compile next time instead of the command.

    numba saves each kernel it compiled to its cache (a temporary file, then renamed into place) and lets an
    OSError of that write end the program: a file-size limit (``ulimit -f``), a full disk or a folder made
    read-only under it stopped a command whose kernel had compiled and would have run, with a line about
    "standard output". This import hook wraps numba's ``Cache.save_overload`` when numba loads its caching
    module, so such a kernel is used uncached (numba removes its temporary file) and compiled again next
    time; the command's own outputs still fail by name if they cannot be written.
    """

    def find_spec(self, name, path=None, target=None):  # a meta path finder
        import sys

        if name != "numba.core.caching":
            return None
        sys.meta_path[:] = [f for f in sys.meta_path if f is not self]
        import importlib.util

        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None and hasattr(spec.loader, "exec_module"):
            run = spec.loader.exec_module

            def exec_module(module, run=run):
                run(module)
                guard_cache_writes(module)

            spec.loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


def guard_cache_writes(caching) -> None:
    """Wrap ``caching.Cache.save_overload`` (numba's cache module) so that an OSError while saving is ignored."""
    cls = getattr(caching, "Cache", None)
    save = getattr(cls, "save_overload", None)
    if cls is None or save is None or getattr(save, "_bhr_guarded", False):
        return

    def save_overload(self, sig, data, _save=save):
        try:
            _save(self, sig, data)
        except OSError:  # not cached: the compiled kernel runs all the same, and compiles again next time
            pass

    save_overload._bhr_guarded = True  # type: ignore[attr-defined]
    cls.save_overload = save_overload


def install_cache_write_guard() -> None:
    """Guard numba's cache writes (:class:`_CacheWriteGuard`): now if numba is loaded, else when it loads."""
    import sys

    if "numba.core.caching" in sys.modules:
        guard_cache_writes(sys.modules["numba.core.caching"])
    elif not any(isinstance(f, _CacheWriteGuard) for f in sys.meta_path):
        sys.meta_path.insert(0, _CacheWriteGuard())


configure_cache()
install_light_blas()
install_cache_write_guard()
