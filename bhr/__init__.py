"""bhr: make a binary hyper-redundant (BHR) endoscope robot follow a path.

The library is importable without click or matplotlib. The calls most users
need are re-exported here and loaded lazily:

>>> import bhr
>>> path = bhr.trajectory("curve", radius=70, angle=90)   # a Trajectory: points, feed, lumen
>>> run = bhr.follow(path, solver="thesis")                # the thesis's robot unless told otherwise
>>> round(run.summary.tip_final_error_mm, 4)               # thesis 7.1.2
0.9099
>>> bhr.solve([3, 9, 0], modules=10, tol_pos=0.01).status  # one target from the chapter 5 chain
'reached'
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from bhr import _numba  # noqa: F401  (sets NUMBA_CACHE_DIR before numba loads)
from bhr._settings.errors import BhrError, LinkError

if TYPE_CHECKING:  # what the lazy names below are, for type checkers
    from bhr._run.driver import FollowResult as FollowResult
    from bhr._run.driver import follow as follow
    from bhr.model._generators import trajectory as trajectory
    from bhr.model._path import Trajectory as Trajectory
    from bhr.model._robot import Robot as Robot
    from bhr.model._export import joint_values as joint_values
    from bhr.solvers import Solver as Solver
    from bhr.solvers import solve as solve

__version__ = "0.1.0"

__all__ = ["BhrError", "LinkError", "Robot", "Solver", "Trajectory", "FollowResult", "follow", "trajectory", "solve",
           "joint_values", "__version__"]

#: The lazy re-exports: name -> (module, attribute).
_LAZY = {"follow": ("bhr._run.driver", "follow"), "FollowResult": ("bhr._run.driver", "FollowResult"),
         "trajectory": ("bhr.model._generators", "trajectory"),
         "solve": ("bhr.solvers", "solve"), "Robot": ("bhr.model._robot", "Robot"),
         "Trajectory": ("bhr.model._path", "Trajectory"), "Solver": ("bhr.solvers", "Solver"),
         "joint_values": ("bhr.model._export", "joint_values")}


def __getattr__(name: str) -> Any:  # PEP 562: lazy re-exports keep `import bhr` cheap
    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    if not name.startswith("_") and name.isidentifier():  # a submodule, e.g. bhr.model or bhr.solvers
        try:
            return importlib.import_module(f"bhr.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"bhr.{name}":
                raise
    raise AttributeError(f"module 'bhr' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The supported API: the names of ``__all__`` and the public subpackages."""
    return sorted([*__all__, "model", "output", "solvers"])
