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

import sys

if sys.argv and sys.argv[0].rsplit("/", 1)[-1] == "bhr":  # the bhr command: Ctrl-C from the first moment
    if "multiprocessing.spawn" in sys.modules:  # a worker process of the command: Ctrl-C is the parent's
        import signal as _signal

        _signal.signal(_signal.SIGINT, _signal.SIG_IGN)
    else:
        from bhr.settings.interrupts import install as _install_interrupts
        from bhr.settings.interrupts import release as _release_interrupts

        _install_interrupts()
        _release_interrupts()  # a Ctrl-C held since start-up (SIGINT blocked) ends the command here

import importlib
import types
import warnings
from typing import TYPE_CHECKING, Any

from bhr import _numba  # noqa: F401  (sets NUMBA_CACHE_DIR before numba loads)
from bhr.settings.errors import BhrError, LinkError

if TYPE_CHECKING:  # what the lazy names below are, for type checkers
    from bhr.run.driver import follow as follow
    from bhr.model.generators import trajectory as trajectory
    from bhr.model.path import Trajectory as Trajectory
    from bhr.model.robot import Robot as Robot
    from bhr.model.export import joint_values as joint_values
    from bhr.solvers import Solver as Solver
    from bhr.solvers import solve as solve

__version__ = "0.1.0"

__all__ = ["BhrError", "LinkError", "Robot", "Solver", "Trajectory", "follow", "trajectory", "solve", "joint_values",
           "__version__"]

#: The lazy re-exports: name -> (module, attribute).
_LAZY = {"follow": ("bhr.run.driver", "follow"), "trajectory": ("bhr.model.generators", "trajectory"),
         "solve": ("bhr.solvers", "solve"), "Robot": ("bhr.model.robot", "Robot"),
         "Trajectory": ("bhr.model.path", "Trajectory"), "Solver": ("bhr.solvers", "Solver"),
         "joint_values": ("bhr.model.export", "joint_values")}


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


class _MovedModule(types.ModuleType):
    """A module's old name, kept for one release: each name taken from it warns and comes from the new module."""

    def __init__(self, old: str, new: str) -> None:
        super().__init__(old, f"Deprecated: the old name of {new}.")
        self._new = new

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        warnings.warn(f"{self.__name__} is deprecated; import {name} from {self._new}", DeprecationWarning,
                      stacklevel=2)
        return getattr(importlib.import_module(self._new), name)


#: Modules' old names (bhr was flat until its layers became subpackages), kept for one release.
_MOVED = {
    # ``bhr.follow`` and ``bhr.trajectory`` are functions; the modules that held them are the driver and
    # the generators. The stand-ins are never set as attributes of this package, so ``bhr.follow`` stays
    # the function.
    "bhr.follow": "bhr.run.driver",
    "bhr.trajectory": "bhr.model.generators",
    "bhr.errors": "bhr.settings.errors",
    "bhr.options": "bhr.settings.options",
    "bhr._input": "bhr.settings.inputs",
    "bhr.names": "bhr.settings.names",
    "bhr.codes": "bhr.model.codes",
    "bhr.robot": "bhr.model.robot",
    "bhr.path": "bhr.model.path",
    "bhr.generators": "bhr.model.generators",
    "bhr.pathfile": "bhr.model.pathfile",
    "bhr.anatomy": "bhr.model.anatomy",
    "bhr.robotfile": "bhr.model.robotfile",
    "bhr.driver": "bhr.run.driver",
    "bhr.body": "bhr.run.body",
    "bhr.clearance": "bhr.run.clearance",
    "bhr.plots": "bhr.output.plots",
    "bhr.animate": "bhr.output.animate",
    "bhr.liveview": "bhr.output.liveview",
    "bhr.htmlpage": "bhr.output.htmlpage",
    "bhr.atomic": "bhr.output.atomic",
    "bhr.thermal_plot": "bhr.output.thermal_plot",
    "bhr.report": "bhr.studies.report",
    "bhr.sweep": "bhr.studies.sweep",
    "bhr.traverse": "bhr.studies.traverse",
    "bhr.compare": "bhr.studies.compare",
    "bhr.executor": "bhr.studies.executor",
    "bhr.study": "bhr.studies.study",
    "bhr.thermal": "bhr.hardware.thermal",
    "bhr.protocol": "bhr.hardware.protocol",
    "bhr.link": "bhr.hardware.link",
    "bhr.firmware_header": "bhr.hardware.firmware_header",
}
# ``from bhr.clearance import X`` still works, with a DeprecationWarning, through these stand-ins.
for _old, _new in _MOVED.items():
    sys.modules.setdefault(_old, _MovedModule(_old, _new))
