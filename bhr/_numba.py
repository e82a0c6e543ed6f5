"""Where numba keeps its compiled cache, set before numba is first imported.

numba writes its cache next to the sources by default, which fails or
pollutes site-packages for installed copies. Unless the user chose a folder
with NUMBA_CACHE_DIR, bhr uses ``$XDG_CACHE_HOME/bhr/numba`` (``~/.cache``).
When that folder cannot be written (a read-only or missing home), bhr falls
back to a per-user folder in the system's temporary directory, so a run never
fails for want of a cache (numba refuses to load cached kernels at all when
no cache folder is writable).
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path


def _usable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return folder.is_dir() and os.access(folder, os.W_OK | os.X_OK)


def configure_cache() -> None:
    chosen = os.environ.get("NUMBA_CACHE_DIR")
    if chosen and _usable(Path(chosen)):
        return
    if not chosen:
        try:
            base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        except RuntimeError:  # no home directory at all
            base = ""
        if base and _usable(Path(base) / "bhr" / "numba"):
            os.environ["NUMBA_CACHE_DIR"] = str(Path(base) / "bhr" / "numba")
            return
    uid = os.getuid() if hasattr(os, "getuid") else 0
    fallback = Path(tempfile.gettempdir()) / f"bhr-numba-{uid}"
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


configure_cache()
