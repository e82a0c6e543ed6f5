"""Where numba caches bhr's compiled kernels, set before numba is imported (``import bhr`` runs this first).

bhr's kernels are plain ``numba.njit(cache=True)`` functions. numba checks
only a kernel's own source file before loading it from its cache, so a
kernel calling a kernel of another module would keep a stale callee after
that module changed (numba issue #1833). So, unless the user chose a folder
with NUMBA_CACHE_DIR, the cache is ``$XDG_CACHE_HOME/bhr/numba/<key>``
(``~/.cache``), the key naming bhr's sources as they are (names, sizes,
mtimes): a changed bhr starts a cache of its own. When that folder cannot be
written (no home, a read-only home), a per-user folder in the temporary
directory is used instead.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

_SOURCES = Path(__file__).resolve().parent


def source_key(root: Path = _SOURCES) -> str:
    """12 hex digits naming the Python sources under ``root`` as they are now (names, sizes, mtimes)."""
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        st = path.stat()
        h.update(f"{path.relative_to(root)}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()[:12]


def _usable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(folder, os.W_OK | os.X_OK)


def configure_cache() -> str:
    """Set NUMBA_CACHE_DIR (unless the user set a usable one) and return it."""
    chosen = os.environ.get("NUMBA_CACHE_DIR")
    if chosen and _usable(Path(chosen)):
        return chosen
    key = source_key()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    folder = Path(base) / "bhr" / "numba" / key
    if not _usable(folder):
        folder = Path(tempfile.gettempdir()) / f"bhr-numba-{os.getuid()}" / key
        if not _usable(folder):
            folder = Path(tempfile.mkdtemp(prefix="bhr-numba-"))
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    return str(folder)


def cache_dir() -> str:
    """The folder numba caches bhr's kernels in."""
    return os.environ.get("NUMBA_CACHE_DIR", "")


configure_cache()
