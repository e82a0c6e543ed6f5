"""bhr: make a binary hyper-redundant (BHR) endoscope robot follow a path.

The library is importable without click or matplotlib. The two calls most
users need are re-exported here and loaded lazily:

>>> import bhr
>>> pts = bhr.trajectory("curve", radius=70, angle=90)      # doctest: +SKIP
>>> result = bhr.follow(pts, solver="thesis")                 # doctest: +SKIP
>>> doc = result.to_dict()                                     # doctest: +SKIP
"""
from __future__ import annotations

import sys

if sys.argv and sys.argv[0].rsplit("/", 1)[-1] == "bhr":  # the bhr command: Ctrl-C from the first moment
    if "multiprocessing.spawn" in sys.modules:  # a worker process of the command: Ctrl-C is the parent's
        import signal as _signal

        _signal.signal(_signal.SIGINT, _signal.SIG_IGN)
    else:
        from bhr.interrupts import install as _install_interrupts

        _install_interrupts()

import importlib
import types
import warnings
from typing import TYPE_CHECKING, Any

from bhr import _numba  # noqa: F401  (sets NUMBA_CACHE_DIR before numba loads)
from bhr.errors import BhrError, LinkError

if TYPE_CHECKING:  # what the lazy names below are, for type checkers
    from bhr.driver import follow as follow
    from bhr.generators import trajectory as trajectory
    from bhr.robot import Robot as Robot
    from bhr.solvers import solve as solve

__version__ = "0.1.0"

__all__ = ["BhrError", "LinkError", "Robot", "follow", "trajectory", "solve", "__version__"]

#: The lazy re-exports: name -> (module, attribute).
_LAZY = {"follow": ("bhr.driver", "follow"), "trajectory": ("bhr.generators", "trajectory"),
         "solve": ("bhr.solvers", "solve"), "Robot": ("bhr.robot", "Robot")}


def __getattr__(name: str) -> Any:  # PEP 562: lazy re-exports keep `import bhr` cheap
    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    if not name.startswith("_") and name.isidentifier():  # a submodule, e.g. bhr.generators.load_trajectory
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


# ``bhr.follow`` and ``bhr.trajectory`` are functions; the modules that held them
# were renamed ``bhr.driver`` and ``bhr.generators``. ``from bhr.follow import X``
# still works (with a DeprecationWarning) through these stand-ins, which are
# never set as attributes of this package, so ``bhr.follow`` stays the function.
for _old, _new in (("bhr.follow", "bhr.driver"), ("bhr.trajectory", "bhr.generators")):
    sys.modules.setdefault(_old, _MovedModule(_old, _new))
