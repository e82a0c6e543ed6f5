"""Where numba caches bhr's ``njit(cache=True)`` kernels; set before bhr's kernels are defined (``import bhr`` runs
it). numba reads its environment when it is imported: when something imported numba before bhr (a notebook, another
library), numba is asked to read it again (``numba.config.reload_config``), else bhr's kernels would be cached
beside their sources, where a stale callee is never noticed.

numba checks only a kernel's own source file before loading it from its cache, so a kernel calling a kernel of
another module would keep a stale callee after that module changed (numba issue #1833). So, unless the user set a
usable NUMBA_CACHE_DIR, the cache is ``$XDG_CACHE_HOME/bhr/numba/<key>`` (``~/.cache``), the key naming bhr's
sources as they are: a changed bhr starts a cache of its own. Without a writable home, a per-user temporary folder
is used.
"""
from __future__ import annotations

import hashlib
import os
import sys
import tempfile
from pathlib import Path


def source_key(root: Path | None = None) -> str:
    """12 hex digits naming the Python sources under ``root`` (bhr's) as they are now (names, sizes, mtimes)."""
    root, h = root or Path(__file__).resolve().parent, hashlib.sha256()
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
    """Set NUMBA_CACHE_DIR (unless the user set a usable one: numba would fall back to the source tree) and
    return it."""
    if not (os.environ.get("NUMBA_CACHE_DIR") and _usable(Path(os.environ["NUMBA_CACHE_DIR"]))):
        home = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        key = source_key()
        for base in (Path(home) / "bhr" / "numba", Path(tempfile.gettempdir()) / f"bhr-numba-{os.getuid()}"):
            if _usable(base / key):
                os.environ["NUMBA_CACHE_DIR"] = str(base / key)
                break
    if "numba" in sys.modules:  # imported before bhr, with the environment of then
        sys.modules["numba"].config.reload_config()
    return os.environ.get("NUMBA_CACHE_DIR", "")


configure_cache()
