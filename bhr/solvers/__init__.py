"""Solvers behind one interface (:class:`bhr.solvers.Solver`).

bhr's own solvers are listed, with the module each lives in, in the index
:mod:`bhr.solvers._names` (a new solver is its module and one line there); a
solver in another package registers itself through the ``bhr.solvers`` entry
point group (docs/model.md, "Adding a solver").
``get_solver(name, robot, **options)`` builds one; ``solve(...)`` runs one
target from the chapter 5 start (a straight chain along +Y from the origin).

Importing this package loads neither numpy nor a solver: :func:`check_solver_name`
knows bhr's own solvers from :mod:`bhr.solvers._names`, so a misspelt name is
refused at once; the solver modules load when a solver is built or listed.
"""
from __future__ import annotations

import importlib
import inspect
from typing import TYPE_CHECKING, Any, Sequence

from bhr._settings.inputs import did_you_mean
from bhr._settings.errors import BhrError
from bhr._settings.options import BY_NAME, excerpt, type_name
from bhr.model._robot import CHAPTER5_ROBOT, Robot, robot_with
from bhr.solvers._names import BUILTIN, REGISTRY, builtin_name

if TYPE_CHECKING:  # loaded lazily (numpy): what these names are, for type checkers
    from bhr.solvers._base import Chain, FollowContext, SolveResult, Solver, register

#: Names this package gives from bhr.solvers._base, loaded on first use (PEP 562).
_FROM_BASE = ("Chain", "FollowContext", "SolveResult", "Solver", "register")


def __getattr__(name: str) -> Any:
    if name in _FROM_BASE:
        from bhr.solvers import _base as base

        return getattr(base, name)
    raise AttributeError(f"module 'bhr.solvers' has no attribute {name!r}")

__all__ = ["Chain", "FollowContext", "SolveResult", "Solver", "available", "canonical", "check_solver_name",
           "get_solver", "register", "solve", "ENTRY_POINTS"]

#: The entry-point group through which other packages add solvers: ``name = "package.module:SolverClass"``.
ENTRY_POINTS = "bhr.solvers"

_loaded = False


def __dir__() -> list[str]:
    """The supported API: the names of ``__all__``."""
    return sorted(__all__)


def _load_all() -> None:
    global _loaded
    if _loaded:
        return
    _loaded = True
    import importlib.metadata

    from bhr.solvers._base import Solver

    for module in sorted({module for module, _ in BUILTIN.values()}):
        importlib.import_module(f"{__name__}.{module}")
    for ep in importlib.metadata.entry_points(group=ENTRY_POINTS):
        try:
            cls = ep.load()
        except Exception as exc:  # a broken plug-in names itself, it does not break bhr
            raise BhrError(f"the solver {ep.name!r} of entry point {ep.value!r} does not load ({type(exc).__name__}: "
                           f"{str(exc).splitlines()[0] if str(exc) else ''}); fix or uninstall that package") from None
        if not (isinstance(cls, type) and issubclass(cls, Solver)):
            raise BhrError(f"entry point {ep.name!r} ({ep.value}) is not a bhr.solvers.Solver subclass; "
                           "fix or uninstall that package")
        if cls.name not in REGISTRY:
            REGISTRY[cls.name] = cls
            for alias in cls.aliases:
                REGISTRY.setdefault(alias, cls)


def _load_builtin(name: str) -> type[Solver]:
    """bhr's own solver class ``name`` (a registered name of :data:`bhr.solvers._names.BUILTIN`), loading its module
    only: a plug-in never takes the name of one of bhr's solvers (:func:`_load_all` registers bhr's first)."""
    if name not in REGISTRY:
        importlib.import_module(f"{__name__}.{BUILTIN[name][0]}")
    return REGISTRY[name]


def _plugins() -> bool:
    """Whether another package adds solvers (entry points named, not loaded)."""
    import importlib.metadata

    return bool(importlib.metadata.entry_points(group=ENTRY_POINTS))


def available() -> dict[str, str]:
    """Solver names and one-line summaries: every registered solver, plug-ins included.

    Returns
    -------
    dict of str to str
        Each solver's registered name (sorted; aliases left out) to its one-line summary.

    Examples
    --------
    >>> from bhr.solvers import available
    >>> "thesis" in available() and "fabrik" in available()
    True
    """
    _load_all()
    return {name: REGISTRY[name].summary for name in sorted(REGISTRY) if REGISTRY[name].name == name}


def canonical(name: str) -> str:
    """The solver's registered name for ``name`` (``seed`` -> ``thesis``); unknown names come back unchanged.

    Parameters
    ----------
    name : str
        A solver's name or alias.

    Returns
    -------
    str
        The registered name, or ``name`` itself when no solver is called so.

    Examples
    --------
    >>> from bhr.solvers import canonical
    >>> canonical("seed"), canonical("nonsense")
    ('thesis', 'nonsense')
    """
    known = builtin_name(name) if isinstance(name, str) else None
    if known is not None:
        return known
    _load_all()
    cls = REGISTRY.get(name)
    return cls.name if cls is not None else name


def check_solver_name(name: Any, where: str = "") -> str:
    """The registered name of solver ``name``, or one BhrError line with a did-you-mean.

    Aliases such as ``seed`` give ``thesis``; an unknown name is refused with the names to choose from
    (``where`` prefixed).

    bhr's own solvers are known without loading them (:mod:`bhr.solvers._names`);
    the solver modules load only when another package adds solvers and the
    name is none of bhr's.

    Parameters
    ----------
    name : object
        The solver's name as given (anything: a value that is not a string is refused too).
    where : str, optional
        Where the name came from (an option, a file and line), put before the error message.

    Returns
    -------
    str
        The registered name.

    Raises
    ------
    BhrError
        No solver is called ``name``: one line with a did-you-mean and the names to choose from.

    Examples
    --------
    >>> from bhr.solvers import check_solver_name
    >>> check_solver_name("seed")
    'thesis'
    >>> check_solver_name("fabric", "--solver")
    Traceback (most recent call last):
    ...
    bhr._settings.errors.BhrError: --solver: unknown solver 'fabric'; did you mean 'fabrik'? choose from ...
    """
    known = builtin_name(name) if isinstance(name, str) else None
    if known is not None:
        return known
    if _loaded or _plugins():
        _load_all()
        cls = REGISTRY.get(name) if isinstance(name, str) else None
        if cls is not None:
            return cls.name
        names = list(available())
    else:
        names = sorted(BUILTIN)
    shown = excerpt(name) if isinstance(name, str) else type_name(name)
    raise BhrError(f"{where + ': ' if where else ''}unknown solver {shown}; "
                   f"{did_you_mean(str(name), names)}choose from {', '.join(names)}")


def _check_solver_options(cls: type[Solver], options: dict[str, Any]) -> dict[str, Any]:
    """``options`` checked against what ``cls`` takes (did-you-mean) and, where it knows them, the registry."""
    if not options:
        return {}
    params = inspect.signature(cls.__init__).parameters
    takes_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    allowed = [k for k, p in params.items() if k not in ("self", "robot")
               and p.kind in (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    out = {}
    for key, value in options.items():
        if not takes_any and key not in allowed:
            takes = f"its options: {', '.join(allowed)}" if allowed else "it takes no options"
            raise BhrError(f"solver {cls.name} does not take the option {excerpt(key)}; "
                           f"{did_you_mean(key, allowed)}{takes}")
        opt = BY_NAME.get(key)
        out[key] = opt.check(value, f"solver {cls.name}") if opt is not None and opt.group in (
            "solver", "constraint") else value
    return out


def get_solver(name: str | Solver | type[Solver], robot: Robot, **options: Any) -> Solver:
    """Build the solver called ``name`` for ``robot``; options go to its constructor.

    ``name`` may also be a :class:`Solver` subclass (built here) or a
    configured :class:`Solver` object, used as it is when it was built for
    ``robot`` and given no further options.

    Parameters
    ----------
    name : str, Solver subclass or Solver
        A registered name or alias (:func:`available`), a :class:`Solver` subclass, or a configured
        :class:`Solver` object.
    robot : Robot
        The robot the solver moves (modules, module length mm, alpha deg, tolerances mm and deg).
    **options
        The solver's own settings (e.g. ``limit``, ``axes``, ``lookahead``), checked against what its
        constructor takes and by the option registry; None values are left out.

    Returns
    -------
    Solver
        The solver, ready for :meth:`Solver.solve`.

    Raises
    ------
    BhrError
        An unknown name or option, or a solver object built for another robot or given options again.

    Examples
    --------
    >>> from bhr.model import CHAPTER5_ROBOT
    >>> from bhr.solvers import get_solver
    >>> get_solver("seed", CHAPTER5_ROBOT).name
    'thesis'
    """
    from bhr.solvers._base import Solver

    if not isinstance(name, str):
        _load_all()
    options = {k: v for k, v in options.items() if v is not None}
    if isinstance(name, Solver):
        if options:
            raise BhrError(f"the {name.name} solver object is already configured; give its options when building it "
                           f"(not also as solver_options: {', '.join(sorted(options))})")
        if name.robot != robot:
            raise BhrError(f"the {name.name} solver object was built for {name.robot!r}, not for {robot!r}; build it "
                           "with this robot, or give no robot settings")
        return name
    if isinstance(name, type) and issubclass(name, Solver):
        cls = name
    elif isinstance(name, str) and name in REGISTRY:
        cls = REGISTRY[name]
    elif isinstance(name, str) and (known := builtin_name(name)) is not None:
        cls = _load_builtin(known)  # one of bhr's own: its module alone (the others define kernels it does not run)
    elif isinstance(name, str):
        cls = REGISTRY[check_solver_name(name)]
    else:
        raise BhrError(f"unknown solver {type_name(name)}; give a solver's name ({', '.join(available())}) or a "
                       "bhr.solvers.Solver object")
    return cls(robot, **_check_solver_options(cls, options))


def solve(target: Sequence[float], *, robot: Robot | None = CHAPTER5_ROBOT, solver: str | Solver = "fabrik",
          tip_direction: Sequence[float] | None = None, base_direction: Sequence[float] = (0, 1, 0),
          solver_options: dict[str, Any] | None = None, **robot_options: Any) -> SolveResult:
    """Solve one target from a straight chain whose base sits at the origin (thesis ch. 5).

    Parameters
    ----------
    target : sequence of 3 floats
        The point the tip should reach, in mm.
    robot : Robot, optional
        The chain; default the chapter 5 chain (5 modules of 2 mm, position tolerance 0.01 mm, 30 iterations), the
        same as ``bhr solve``'s defaults.
    solver : str or Solver, default "fabrik"
        A solver's name (:func:`available`) or a configured :class:`Solver` object.
    tip_direction : sequence of 3 floats, optional
        The wanted direction of the last module (any length); ``None`` leaves the tip free (``--orientation``).
    base_direction : sequence of 3 floats, default (0, 1, 0)
        The direction the straight starting chain runs along from the origin (+Y in the thesis's chapter 5).
    solver_options : dict, optional
        Solver settings (``limit``, ``axes``, ``warmup``, ...), checked by the option registry.
    **robot_options
        Robot settings that change ``robot`` (``modules``, ``module_length``, ``alpha``, ``tol_pos``, ``tol_ori``,
        ``max_iter``, ...), checked by the option registry.

    Returns
    -------
    SolveResult
        ``status`` ('reached', 'not reached', 'out of reach') and ``reason``; ``iterations``;
        ``position_error_mm``; ``orientation_error_deg`` (None without ``tip_direction``); ``points`` (n+1, 3) in mm,
        base first; ``codes`` (n,) for the binary solvers.

    Examples
    --------
    >>> res = solve([3, 9, 0], modules=10)
    >>> res.success, res.iterations
    (True, 1)
    """
    from bhr.solvers._base import Chain, Solver, check_direction, check_target

    t = check_target(target)
    d = check_direction(tip_direction)
    if isinstance(solver, Solver) and robot is CHAPTER5_ROBOT and not robot_options:
        robot = solver.robot
    robot = robot_with(robot, robot_options, default=CHAPTER5_ROBOT)
    s = get_solver(solver, robot, **(solver_options or {}))
    if d is not None and not s.accepts_orientation:
        raise BhrError(f"the {s.name} solver cannot aim the tip; drop --orientation or use --solver fabrik or thesis")
    chain = Chain.straight(robot, base_direction)
    return s.solve(chain, t, d)
