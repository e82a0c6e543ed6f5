"""bhr: make a binary hyper-redundant (BHR) endoscope robot follow a path.

The library is importable without click or matplotlib. The two calls most
users need are re-exported here and loaded lazily:

>>> import bhr
>>> pts = bhr.trajectory("curve", radius=70, angle=90)      # doctest: +SKIP
>>> result = bhr.follow(pts, solver="thesis")                 # doctest: +SKIP
>>> doc = result.to_dict()                                     # doctest: +SKIP
"""
from __future__ import annotations

from bhr import _numba  # noqa: F401  (sets NUMBA_CACHE_DIR before numba loads)
from bhr.errors import BhrError, LinkError

__version__ = "0.1.0"

__all__ = ["BhrError", "LinkError", "Robot", "follow", "trajectory", "solve", "__version__"]


def __getattr__(name: str):  # PEP 562: lazy re-exports keep `import bhr` cheap
    # bhr.follow and bhr.trajectory are modules that can be called like their main
    # function (see bhr._callable), so they stay callable once imported.
    if name in ("follow", "trajectory"):
        import importlib

        return importlib.import_module(f"bhr.{name}")
    if name == "solve":
        from bhr.solvers import solve

        return solve
    if name == "Robot":
        from bhr.robot import Robot

        return Robot
    raise AttributeError(f"module 'bhr' has no attribute {name!r}")
