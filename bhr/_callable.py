"""Let a module be called like its main function.

``bhr.follow(points)`` and ``bhr.trajectory("colon")`` are the documented API,
but ``bhr.follow`` and ``bhr.trajectory`` are also modules, and importing a
submodule sets the package attribute to the module. Giving those two modules a
class with ``__call__`` makes both spellings work.
"""
from __future__ import annotations

import sys
import types


def make_callable(module_name: str, func_name: str) -> None:
    """Make ``sys.modules[module_name](...)`` call its ``func_name``."""

    class CallableModule(types.ModuleType):
        def __call__(self, *args, **kwargs):
            return getattr(self, func_name)(*args, **kwargs)

    sys.modules[module_name].__class__ = CallableModule
