"""The names ``--traj`` accepts, without numba or the generators: a misspelt name is refused at once.

:mod:`bhr.model._generators` builds the trajectories (and imports the compiled
kernels of :mod:`bhr.model._pathfile`); this module only knows their names, so that
the command line can refuse ``--traj colonn`` before anything heavy is
imported.
"""
from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from bhr._settings.inputs import broken_link, did_you_mean, excerpt
from bhr._settings.errors import BhrError

__all__ = ["GENERATOR_NAMES", "REAL_PREFIX", "trajectory_folder", "shipped_csvs", "real_colons", "builtin_names",
           "check_trajectory_name", "traj_help"]

#: The generators' names (the keys of ``bhr.model._generators.GENERATORS``, in that order).
GENERATOR_NAMES = ("line", "curve", "spiral", "colon", "anatomy")
#: Real colons are named ``gca:SHORT`` (trajectories/gca/SHORT.csv, docs/real_colons.md).
REAL_PREFIX = "gca:"


def trajectory_folder() -> Path | None:
    """The folder of shipped trajectories (installed as ``bhr.trajectories``, else the repository's)."""
    try:
        res = resources.files("bhr.trajectories")
    except ModuleNotFoundError:
        res = None
    if res is not None and res.is_dir():
        return Path(str(res))
    repo = Path(__file__).resolve().parents[2] / "trajectories"
    return repo if repo.is_dir() else None


def shipped_csvs() -> dict[str, Path]:
    """Shipped point files by name (``anatomy-typical`` is trajectories/anatomy-typical.csv)."""
    folder = trajectory_folder()
    if folder is None:
        return {}
    return {p.stem: p for p in folder.glob("*.csv") if p.is_file()}


def real_colons() -> dict[str, Path]:
    """The shipped real colons by name (``gca:VHM`` is trajectories/gca/VHM.csv), in name order."""
    folder = trajectory_folder()
    if folder is None or not (folder / "gca").is_dir():
        return {}
    return {REAL_PREFIX + p.stem: p for p in sorted((folder / "gca").glob("*.csv")) if p.is_file()}


def builtin_names() -> list[str]:
    """Names ``load_trajectory`` knows: the generators, the shipped point files (trajectories/NAME.csv), the real
    colons (gca:NAME)."""
    return list(GENERATOR_NAMES) + sorted(shipped_csvs()) + list(real_colons())


def traj_help() -> str:
    """The ``--traj`` help: every name :func:`check_trajectory_name` accepts, from the same lists."""
    shipped = sorted(shipped_csvs())
    files = f"a shipped point file ({', '.join(shipped)}), " if shipped else ""
    real = list(real_colons())
    reals = f"a real colon ({', '.join(real)}), " if real else ""
    return (f"{', '.join(GENERATOR_NAMES)} (anatomy: --seed N), {files}{reals}or a trajectory file: .toml "
            "(segments) or .csv (points).")


def check_trajectory_name(key: str | os.PathLike[str]) -> None:
    """Refuse a ``--traj`` that is neither a built-in, a shipped colon nor an existing file (one line)."""
    key = str(key)
    if key in GENERATOR_NAMES or Path(key).exists() or key in shipped_csvs() or key in real_colons():
        return
    link = broken_link(key)
    if link:
        raise BhrError(f"{link}; give the trajectory file itself, or a built-in")
    names = builtin_names()
    raise BhrError(f"unknown trajectory {excerpt(key)}: not a built-in ({', '.join(names)}) and no such file; "
                   f"{did_you_mean(key, names)}give one of the built-ins or a .toml/.csv file")
