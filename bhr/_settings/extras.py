"""The command that adds one of bhr's optional parts (``physics``, ``dask``) to the bhr that is running.

An error that says "install the physics extra" must give a command that works as printed. The
tempting ``pip install 'bhr[physics]'`` does not: bhr is installed from its source folder
(``python3 -m pip install .``), and an index asked for a package called ``bhr`` has none, or
another project's. Nor does a bare ``pip``, which may belong to another Python than the one
running bhr. So the command names this Python (:data:`sys.executable`) and the folder bhr was
installed from, read from the installation's ``direct_url.json`` (PEP 610, written by pip for
``pip install .`` and ``pip install -e .``), or the source folder this copy runs from:

    /home/me/venv/bin/python3 -m pip install '/home/me/bhr[physics]'

Only where neither is known (bhr installed from an index or an archive) does it name the package
``bhr[physics]``.
"""
from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path
from urllib.parse import unquote, urlparse

__all__ = ["install_command", "source_folder"]

_HERE = Path(__file__).resolve().parent.parent.parent  # the folder holding this copy's ``bhr`` package


def _declares_bhr(folder: Path) -> bool:
    """Whether ``folder`` holds bhr's own pyproject.toml (a project named bhr)."""
    try:
        text = (folder / "pyproject.toml").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    import tomllib

    try:
        return tomllib.loads(text).get("project", {}).get("name") == "bhr"
    except tomllib.TOMLDecodeError:
        return False


def _installed_from() -> Path | None:
    """The local folder pip installed bhr from (direct_url.json's ``file:`` URL), if it is one."""
    from importlib import metadata

    try:
        text = metadata.distribution("bhr").read_text("direct_url.json")
    except metadata.PackageNotFoundError:
        return None
    if not text:
        return None
    try:
        info = json.loads(text)
    except ValueError:
        return None
    url = info.get("url") if isinstance(info, dict) else None
    if not isinstance(url, str) or "dir_info" not in info:  # an archive or a VCS URL: no folder to point at
        return None
    parts = urlparse(url)
    if parts.scheme != "file" or parts.netloc not in ("", "localhost"):
        return None
    return Path(unquote(parts.path))


def source_folder() -> Path | None:
    """bhr's source folder (with its pyproject.toml) for this installation, or None when it is not known."""
    for folder in (_installed_from(), _HERE):
        if folder is not None and _declares_bhr(folder):
            return folder
    return None


def install_command(extra: str) -> str:
    """One shell line that installs bhr's optional part ``extra`` for the Python running bhr.

    >>> install_command("physics")  # doctest: +SKIP
    "/home/me/venv/bin/python3 -m pip install '/home/me/bhr[physics]'"
    """
    folder = source_folder()
    target = f"{folder}[{extra}]" if folder is not None else f"bhr[{extra}]"
    python = sys.executable or "python3"
    return f"{shlex.quote(python)} -m pip install {shlex.quote(target)}"
