"""bhr's own solvers by name, without numpy, numba or the solver modules: a misspelt ``--solver`` is refused at once.

Each solver class registers itself under its name and aliases
(:func:`bhr.solvers._base.register`), and that registry is what builds
solvers. This index names bhr's own solvers, the module each lives in and
their aliases, so that :func:`bhr.solvers.check_solver_name` can check a name
before any solver module (and numpy and numba with it) is imported.
``register`` refuses a solver of this package that is missing here or listed
differently, so the index cannot drift from the classes.
"""
from __future__ import annotations

from typing import Any

__all__ = ["BUILTIN", "REGISTRY", "builtin_name"]

#: Every solver class (a :class:`bhr.solvers._base.Solver` subclass) by name and alias, as
#: :func:`bhr.solvers._base.register` records them, filled when the solver modules load. Typed loosely so that this
#: index imports nothing of the package (the classes' module imports it).
REGISTRY: dict[str, Any] = {}

#: name -> (its module in bhr.solvers, its aliases): every solver class of this package.
BUILTIN: dict[str, tuple[str, tuple[str, ...]]] = {
    "ccd": ("_ccd", ()),
    "constrained": ("_thesis", ()),
    "fabrik": ("_fabrik", ()),
    "lumen": ("_lumen", ()),
    "optimal": ("_optimal", ()),
    "thesis": ("_thesis", ("seed",)),
}


def builtin_name(name: str) -> str | None:
    """The registered name of bhr's own solver ``name`` or alias (``seed`` -> ``thesis``); None if not one of them."""
    if name in BUILTIN:
        return name
    for key, (_, aliases) in BUILTIN.items():
        if name in aliases:
            return key
    return None
