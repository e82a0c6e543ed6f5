"""Where numba keeps its compiled cache, set before numba is first imported.

numba writes its cache next to the sources by default, which fails or
pollutes site-packages for installed copies. Unless the user chose a folder
with NUMBA_CACHE_DIR, bhr uses ``$XDG_CACHE_HOME/bhr/numba`` (``~/.cache``).
"""
from __future__ import annotations

import os
from pathlib import Path


def configure_cache() -> None:
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    os.environ["NUMBA_CACHE_DIR"] = str(Path(base) / "bhr" / "numba")


def cache_dir() -> str:
    """The folder numba's compiled cache goes to (set by :func:`configure_cache` unless the user chose one)."""
    return os.environ.get("NUMBA_CACHE_DIR", "")


def cache_has_kernels() -> bool:
    """Whether numba's cache holds any compiled bhr kernel yet (False on a machine's first run)."""
    root = Path(cache_dir())
    try:
        return any(root.glob("bhr_*/*.nbi")) or any(root.glob("solvers_*/*.nbi"))
    except OSError:
        return False


configure_cache()
