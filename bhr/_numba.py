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
    # numba keeps each source folder's kernels in "<folder name>_<hash>": bhr's package folders
    folders = {p.parent.name for p in Path(__file__).parent.rglob("__init__.py")}
    try:
        return any(any(root.glob(f"{name}_*/*.nbi")) for name in folders)
    except OSError:
        return False


configure_cache()
