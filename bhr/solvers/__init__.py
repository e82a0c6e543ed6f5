"""Solvers behind one interface (:class:`bhr.solvers.base.Solver`).

Every module in this package that registers a solver is found here, so a new
solver is one new file. ``get_solver(name, robot, **options)`` builds one;
``solve(...)`` runs one target from the chapter 5 start (a straight chain
along +Y from the origin).
"""
from __future__ import annotations

import importlib
import pkgutil
from typing import Any, Sequence

import numpy as np

from bhr._input import did_you_mean
from bhr.errors import BhrError
from bhr.robot import Robot
from bhr.solvers.base import REGISTRY, Chain, FollowContext, SolveResult, Solver, check_direction, check_target

__all__ = ["Chain", "FollowContext", "SolveResult", "Solver", "available", "canonical", "get_solver", "solve"]

_loaded = False


def _load_all() -> None:
    global _loaded
    if _loaded:
        return
    for info in pkgutil.iter_modules(__path__):
        if not info.name.startswith("_") and info.name != "base":
            importlib.import_module(f"{__name__}.{info.name}")
    _loaded = True


def available() -> dict[str, str]:
    """Solver names and one-line summaries."""
    _load_all()
    return {name: REGISTRY[name].summary for name in sorted(REGISTRY) if REGISTRY[name].name == name}


def canonical(name: str) -> str:
    """The solver's registered name for ``name`` (``seed`` -> ``thesis``); unknown names come back unchanged."""
    _load_all()
    cls = REGISTRY.get(name)
    return cls.name if cls is not None else name


def get_solver(name: str, robot: Robot, **options: Any) -> Solver:
    """Build the solver called ``name`` for ``robot``; options go to its constructor."""
    _load_all()
    if name not in REGISTRY:
        raise BhrError(f"unknown solver {name!r}; {did_you_mean(name, REGISTRY)}choose one of "
                       f"{', '.join(available())}")
    options = {k: v for k, v in options.items() if v is not None}
    try:
        return REGISTRY[name](robot, **options)
    except TypeError as exc:
        raise BhrError(f"solver {name} does not take these options ({exc}); see 'bhr solve --help'") from None


def solve(target: Sequence[float], *, modules: int | None = None, module_length: float | None = None,
          orientation: Sequence[float] | None = None, solver: str = "fabrik",
          direction: Sequence[float] = (0, 1, 0), robot: Robot | None = None,
          solver_options: dict[str, Any] | None = None, **robot_options: Any) -> SolveResult:
    """Solve one target from a straight chain (default along +Y from the origin, as thesis ch. 5).

    ``modules`` (default 5), ``module_length`` (default 2 mm) and
    ``robot_options`` are :class:`bhr.robot.Robot` fields (``alpha``,
    ``tol_pos``, ``tol_ori``, ``max_iter`` ...); the chapter 5 experiments use
    ``tol_pos=0.01`` and ``max_iter=30``. With ``robot`` given they override
    its fields (``bhr.solve(t, robot=r, modules=7)`` solves with 7 modules).
    The result's ``success`` says whether the errors are within tolerance.
    """
    t = check_target(target)
    d = check_direction(orientation)
    given: dict[str, Any] = {k: v for k, v in dict(modules=modules, module_length=module_length).items()
                             if v is not None}
    given.update(robot_options)
    if robot is None:
        robot = Robot(**{"modules": 5, "module_length": 2.0, **given})
    elif given:
        if not isinstance(robot, Robot):
            raise BhrError(f"robot must be a bhr.Robot, got {type(robot).__name__}")
        unknown = sorted(set(given) - set(Robot.__dataclass_fields__))
        if unknown:
            tip = did_you_mean(unknown[0], Robot.__dataclass_fields__)
            raise BhrError(f"{unknown[0]!r} is not a robot setting; {tip}give Robot fields such as modules or alpha")
        robot = robot.replace(**given)
    s = get_solver(solver, robot, **(solver_options or {}))
    if d is not None and not s.accepts_orientation:
        raise BhrError(f"the {solver} solver cannot aim the tip; drop --orientation or use --solver fabrik or thesis")
    chain = Chain.straight(robot, direction)
    res = s.judge(s.solve(chain, t, d))
    res.reach_mm = float(np.sum(np.linalg.norm(np.diff(chain.points, axis=0), axis=1)))
    res.target = t
    return res
