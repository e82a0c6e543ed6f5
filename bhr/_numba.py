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

import functools
import hashlib
import math
import os
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

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


# --- kernels made when first used ------------------------------------------------------------------------------

_lazy_lock = threading.RLock()
_pending: list["LazyKernel"] = []
_made = False  # numba imported and every kernel defined so far made a dispatcher
_on_load: list[Any] = []  # what to do when numba is imported for the first kernel (when_numba_loads)


class LazyKernel:
    """A kernel declared with :func:`njit` before numba is imported: numba's dispatcher is made at its first use.

    Importing numba costs about 0.4 s of CPU, which a command that refuses
    its input (a misspelt solver, a negative module count) should not pay.
    On the first call (or attribute such as ``.stats``) of any bhr kernel,
    numba is imported, every kernel declared so far becomes its
    ``numba.njit(...)`` dispatcher, and the module globals of bhr that name
    a kernel are given the dispatcher itself: compiled callers see numba's
    dispatchers as they always did, and Python callers call them with no
    indirection. Kernels declared after that are dispatchers at once.
    """

    def __init__(self, func: Any, options: dict[str, Any]) -> None:
        self.py_func = func
        self._options = options
        self._dispatcher: Any = None
        functools.update_wrapper(self, func)

    def dispatcher(self) -> Any:
        """numba's dispatcher of this kernel (numba imported, every pending kernel made, on the first use)."""
        if self._dispatcher is None:
            make_kernels()
        if self._dispatcher is None:  # declared outside the pending list (a test's own): made alone
            with _lazy_lock:
                if self._dispatcher is None:
                    self._dispatcher = _dispatcher_of(self.py_func, self._options)
        return self._dispatcher

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.dispatcher()(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name in ("py_func", "_options", "_dispatcher"):
            raise AttributeError(name)
        return getattr(self.dispatcher(), name)

    def __reduce__(self) -> Any:  # pickled by name, as numba's dispatchers are
        return (_kernel_by_name, (self.py_func.__module__, self.py_func.__qualname__))

    def __repr__(self) -> str:
        return f"<bhr kernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


def _kernel_by_name(module: str, qualname: str) -> Any:
    import importlib

    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def njit(*args: Any, **options: Any) -> Any:
    """``numba.njit`` with the same options, numba imported only when a kernel is first used (:class:`LazyKernel`)."""

    def declare(func: Any) -> Any:
        with _lazy_lock:
            if _made:
                return _dispatcher_of(func, options)
            kernel = LazyKernel(func, options)
            _pending.append(kernel)
            return kernel

    if args and callable(args[0]) and len(args) == 1:
        return declare(args[0])
    if args:
        raise TypeError("bhr._numba.njit takes keyword options only (no signatures)")
    return declare


def _dispatcher_of(func: Any, options: dict[str, Any]) -> Any:
    """``numba.njit(**options)(func)``, typed by its arguments' types and never by their values.

    numba compiles a kernel called from another kernel for the types of the
    arguments at that call, and a constant argument (``f(x, 0)``, ``f(x, True)``)
    has a literal type: each such call site compiled the kernel once more
    (``constrained_kernel`` twice, 2 s each: once with ``has_dir`` a bool from
    Python, once with ``True`` from the follow loop), and the cache held each.
    The call is typed with the plain types instead (``int64``, ``bool``), as a
    call from Python is: one compile per kernel and argument types. Literal
    values can only fold constants of integer and boolean logic, so the
    float64 arithmetic and its results are the same.
    """
    import numba
    from numba.core import types

    dispatcher = numba.njit(**options)(func)
    if not hasattr(dispatcher, "get_call_template"):  # NUMBA_DISABLE_JIT=1: numba gives the function back
        return dispatcher
    typed_by_value = dispatcher.get_call_template

    def get_call_template(args: Any, kws: Any) -> Any:
        return typed_by_value(tuple(types.unliteral(a) for a in args),
                              {k: types.unliteral(v) for k, v in kws.items()})

    dispatcher.get_call_template = get_call_template
    return dispatcher


def make_kernels() -> None:
    """Import numba and make every declared kernel its dispatcher, bhr's module globals pointing at them."""
    global _made
    with _lazy_lock:
        if _made and not _pending:
            return
        import numba  # noqa: F401  (the callbacks run with numba imported, before any kernel is made)

        while _on_load:
            _on_load.pop(0)()
        for kernel in _pending:
            kernel._dispatcher = _dispatcher_of(kernel.py_func, kernel._options)
        _pending.clear()
        _made = True
        for name, module in list(sys.modules.items()):
            if module is None or not (name == "bhr" or name.startswith("bhr.") or name == "__main__"):
                continue
            space = getattr(module, "__dict__", None)
            if not isinstance(space, dict):
                continue
            for key, value in list(space.items()):
                if isinstance(value, LazyKernel) and value._dispatcher is not None:
                    space[key] = value._dispatcher


def when_numba_loads(callback: Any) -> None:
    """Call ``callback()`` when the first kernel is used (numba imported, nothing compiled yet), or now if it was."""
    with _lazy_lock:
        if _made:
            callback()
        else:
            _on_load.append(callback)


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


# --- the first run: a kernel whose cache is cold runs interpreted when that costs less than compiling -----------

_interpreting = False  # turned on by a command whose end compiles every kernel in the background (cli)
_interpreted: dict[Any, Any] = {}  # a kernel's Python function -> its interpreted copy
_spent: dict[Any, float] = {}  # a kernel's Python function -> the interpreted seconds estimated so far


def allow_interpreting(allowed: bool = True) -> None:
    """Let :func:`call_cold` run cold kernels interpreted (for a process that then compiles them all).

    The command line turns this on when the background compile (:mod:`bhr.warmup`) will run as the
    command ends, so that each kernel is interpreted in at most one first command: a program that
    calls bhr in a loop, or a command with the background compile turned off, compiles as always.
    """
    global _interpreting
    _interpreting = bool(allowed)


def interpreted_any() -> bool:
    """Whether a kernel ran interpreted in this process (its compiled code is still to be made)."""
    return bool(_spent)


def _is_kernel(value: Any) -> bool:
    return isinstance(value, LazyKernel) or (hasattr(value, "py_func") and hasattr(value, "overloads"))


def interpreted(kernel: Any) -> Any:
    """The kernel's own Python code run by the interpreter, every kernel it calls interpreted as well.

    A copy of the kernel's function whose module globals name, instead of each compiled kernel, that
    kernel's interpreted copy: the same statements on the same float64 and int64 values, so the
    results are those of the compiled kernel (IEEE arithmetic both ways; bhr's kernels use no
    fastmath), only slower.
    """
    import types as pytypes

    func = kernel.py_func if _is_kernel(kernel) else kernel
    done = _interpreted.get(func)
    if done is not None:
        return done
    space = dict(func.__globals__)
    copy = pytypes.FunctionType(func.__code__, space, func.__name__, func.__defaults__, func.__closure__)
    copy.__kwdefaults__ = func.__kwdefaults__
    _interpreted[func] = copy
    for key, value in list(space.items()):
        if _is_kernel(value):
            space[key] = interpreted(value)
    return copy


def is_ready(kernel: Any) -> bool:
    """Whether calling the kernel needs no compile: made in this process, or in numba's on-disk cache."""
    dispatcher = kernel.dispatcher() if isinstance(kernel, LazyKernel) else kernel
    if getattr(dispatcher, "overloads", None):
        return True
    try:
        return bool(dispatcher._cache._cache_file._load_index())  # numba's index: empty when stale or absent
    except Exception:  # no cache, or numba's layout changed: numba decides, as for any call
        return True


def call_cold(kernel: Any, interpreted_s: float, compile_s: float, *args: Any, instead: Any = None) -> Any:
    """``kernel(*args)``; on a cold cache, interpreted instead when that is estimated to cost less.

    ``interpreted_s`` is a bound on what this call costs interpreted (CPU seconds, from the call's
    size), ``compile_s`` what compiling the kernel costs. While interpreting is allowed
    (:func:`allow_interpreting`) and the kernel is neither compiled nor cached, the call runs
    interpreted as long as the interpreted seconds this process spent on the kernel stay within
    ``compile_s``; past that, or for a large call, it compiles as always.

    ``instead``, if given, runs in place of the interpreted kernel: a numpy version of it that gives
    its results bit for bit (``interpreted_s`` is then that version's estimated cost), called as
    ``instead(*args, deadline=...)``. Its cost may depend on more than the call's size (how much of
    a robot lies in the wall), so it gets the CPU time (:func:`time.process_time`) by which it must
    be done and raises :class:`TooSlow` past it: the kernel then runs compiled, the seconds spent
    costing at most what compiling costs.
    """
    if _interpreting and interpreted_s <= compile_s:
        func = kernel.py_func if _is_kernel(kernel) else kernel
        before = _spent.get(func, 0.0)
        spent = before + interpreted_s
        if spent <= compile_s and not is_ready(kernel):
            _spent[func] = spent
            if instead is None:
                return interpreted(kernel)(*args)
            import time

            try:
                return instead(*args, deadline=time.process_time() + (compile_s - before))
            except TooSlow:
                _spent[func] = math.inf  # this process compiles it from now on
    return kernel(*args)


class TooSlow(Exception):
    """Raised by a numpy version of a kernel (``call_cold(..., instead=...)``) past its deadline."""


configure_cache()
install_light_blas()
install_cache_write_guard()
