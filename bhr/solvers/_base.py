"""The interface every solver implements, and the chain state they share.

A solver takes the current :class:`Chain` (points and local tilt axes), a
target point and optionally a wanted tip direction, and returns a
:class:`SolveResult` with the new chain. Solvers that respect the binary
actuators also return one code per module. Register a solver with
:func:`register`; :mod:`bhr.solvers` finds every module in this package, so
a new solver is one new file.
"""
from __future__ import annotations

import functools
import json
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar, Sequence

import numpy as np

from bhr._settings.errors import BhrError
from bhr._settings.options import excerpt
from bhr._kinematics.leader import advance_kernel
from bhr.model._robot import Robot, base_frame, straight_chain
from bhr.solvers._names import BUILTIN, REGISTRY  # the light index of names, and the registry register() fills

__all__ = ["Chain", "SolveResult", "Solver", "FollowContext", "register", "REGISTRY"]


def register(cls: type["Solver"]) -> type["Solver"]:
    """Class decorator: make a solver available by its ``name`` (and its older ``aliases``).

    The decorated class is a :class:`Solver` subclass with a ``name``; bhr's own solvers must also be listed in the
    index ``bhr/solvers/_names.py``.

    Returns
    -------
    type
        ``cls`` itself, now known to :func:`bhr.solvers.get_solver`, ``--solver`` and :func:`bhr.solvers.available`.
    """
    if not getattr(cls, "name", None):
        raise TypeError(f"{cls.__name__} has no name")
    if cls.__module__.startswith("bhr.solvers."):  # bhr's own: listed in the light index of names, as it is here
        listed = BUILTIN.get(cls.name)
        if listed != (cls.__module__.rsplit(".", 1)[1], tuple(cls.aliases)):
            raise TypeError(f"solver {cls.name!r} ({cls.__module__}, aliases {tuple(cls.aliases)}) is listed as "
                            f"{listed} in bhr/solvers/_names.py; list it there as it is")
    REGISTRY[cls.name] = cls
    for alias in cls.aliases:
        REGISTRY[alias] = cls
    return cls


@dataclass
class Chain:
    """The robot's state between solves.

    ``points`` (n+1, 3), base first. ``axes`` (2, n, 3) holds, for each joint
    ``i``, the *points* ``P_i + x_i`` and ``P_i + y_i`` that mark its two local
    tilt axes, exactly as the thesis's script keeps them (EjeY, EjeZ), so that
    the thesis's algorithm can be ported without changing its arithmetic.

    Parameters
    ----------
    points : numpy.ndarray, shape (n+1, 3)
        The joints of a chain of n modules, base first, mm, float64.
    axes : numpy.ndarray, shape (2, n, 3)
        For each module's joint ``i``, the points ``P_i + x_i`` (``axes[0, i]``) and ``P_i + y_i``
        (``axes[1, i]``), mm: the ends of unit vectors along its two local tilt axes.

    Examples
    --------
    >>> from bhr.model import CHAPTER5_ROBOT
    >>> chain = Chain.straight(CHAPTER5_ROBOT, (0, 1, 0))
    >>> chain.points.shape, chain.axes.shape
    ((6, 3), (2, 5, 3))
    >>> chain.points[-1].tolist()   # 5 modules of 2 mm along +Y
    [0.0, 10.0, 0.0]
    """

    points: np.ndarray
    axes: np.ndarray

    @classmethod
    def straight(cls, robot: Robot, direction: Sequence[float] | np.ndarray = (1, 0, 0),
                 origin: Sequence[float] | np.ndarray = (0, 0, 0), tip_at_origin: bool = False) -> "Chain":
        """A straight chain along ``direction``; local axes from :func:`bhr.model._robot.base_frame`.

        Parameters
        ----------
        robot : Robot
            Gives the number of modules n and their length, mm.
        direction : sequence of float, shape (3,), default (1, 0, 0)
            The direction the chain runs along from its base (any length).
        origin : sequence of float, shape (3,), default (0, 0, 0)
            The base point, mm; with ``tip_at_origin`` the tip's.
        tip_at_origin : bool, default False
            Put the tip, not the base, at ``origin`` (follow-the-leader's start: the robot behind the path).

        Returns
        -------
        Chain
            ``points`` (n+1, 3) mm, base first, and the tilt axes (2, n, 3) of a straight robot.
        """
        pts = straight_chain(robot.modules, robot.module_length, direction, origin, tip_at_origin)
        fr = base_frame(direction)
        axes = np.stack([pts[:-1] + fr[0], pts[:-1] + fr[1]])
        return cls(pts, axes)

    @property
    def modules(self) -> int:
        return self.points.shape[0] - 1

    def copy(self) -> "Chain":
        """A copy with its own arrays.

        Returns
        -------
        Chain
            The same points and axes, copied.
        """
        return Chain(self.points.copy(), self.axes.copy())

    def base_frame(self) -> np.ndarray:
        """Frame (rows x, y, z) of the joint at the base: module 1's local axes and direction.

        Returns
        -------
        numpy.ndarray, shape (3, 3)
            Rows x, y (the base module's tilt axes) and z (its direction), unit vectors.
        """
        z = self.points[1] - self.points[0]
        x = self.axes[0, 0] - self.points[0]
        y = self.axes[1, 0] - self.points[0]
        return np.stack([x / np.linalg.norm(x), y / np.linalg.norm(y), z / np.linalg.norm(z)])

    def advance(self, feed: float, module_length: float) -> "Chain":
        """Move the whole robot by ``feed`` along its base module (thesis appendix 1).

        Module 1 keeps its local axes; the axes of modules 2..n are reset to
        those of a straight robot along the base module's direction.

        Parameters
        ----------
        feed : float
            How far the robot advances, mm.
        module_length : float
            The length of one module, mm.

        Returns
        -------
        Chain
            The advanced chain (this one is left as it is).
        """
        out = self.copy()
        advance_kernel(out.points, out.axes[0], out.axes[1], float(feed), float(module_length))
        return out


@dataclass
class FollowContext:
    """What a solver may know about the path when it is driven by follow-the-leader.

    :func:`bhr.follow` passes one to :meth:`Solver.solve` at every step driven from Python; a solver that
    plans ahead (``"lumen"``, ``"optimal"``) reads the path beyond the current target from it.

    Parameters
    ----------
    path : numpy.ndarray, shape (N, 3)
        The trajectory's points, mm, one feed apart.
    directions : numpy.ndarray, shape (N-1, 3)
        Unit vectors from each point to the next.
    step : int
        The 0-based index of the current target in ``path``.
    """

    path: np.ndarray  # (N, 3) trajectory points
    directions: np.ndarray  # (N-1, 3) unit vectors between points
    step: int  # 0-based index of the current target


@dataclass(repr=False)
class SolveResult:
    """One solve: the new chain, iterations and errors (mm, degrees), codes if binary.

    ``success`` is whether the errors are within the robot's tolerances
    (position, and orientation when a tip direction was asked for), and
    ``status`` says which: ``"reached"``, ``"not reached"`` (the solver
    stopped at its iteration limit short of the tolerance) or ``"out of
    reach"`` (the target lies farther from the base than the robot is
    long); ``reason`` says it in words, with the figures. Every solver's
    :meth:`Solver.solve` sets them.

    Parameters
    ----------
    chain : Chain
        The chain after the solve: ``points`` (n+1, 3) mm, base first, and its tilt axes.
    iterations : int
        The iterations the solver took.
    position_error_mm : float
        Distance from the tip to the target, mm.
    orientation_error_deg : float or None
        Angle between the last module and the wanted tip direction, deg; None when none was asked for.
    codes : list of int, optional
        One code per module (0, 3, 6, 9, 12 or 15, ``docs/conventions.md``), base first, for the solvers
        that respect the binary actuators; None for a continuous solver.
    extra : dict of str to object, optional
        A solver's own figures about the solve.
    success : bool or None, optional
        Within the robot's tolerances (position, and orientation when aimed); None until judged.
    status : {"reached", "not reached", "out of reach", ""}, optional
        The verdict; empty until judged.
    reason : str, optional
        The verdict in words, with the figures (mm, deg, iterations).

    Examples
    --------
    >>> import bhr
    >>> bhr.solve([3, 9, 0], modules=10)
    SolveResult(reached: ... mm off, 1 iterations)
    """

    chain: Chain
    iterations: int
    position_error_mm: float
    orientation_error_deg: float | None
    codes: list[int] | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    success: bool | None = None
    status: str = ""
    reason: str = ""

    @property
    def points(self) -> np.ndarray:
        return self.chain.points


    def __repr__(self) -> str:
        ori = "" if self.orientation_error_deg is None else f", tip {self.orientation_error_deg:.4g} deg off"
        codes = "" if self.codes is None else f", codes {list(self.codes)}"
        return (f"SolveResult({self.status or 'not judged'}: {self.position_error_mm:.4g} mm off{ori}, "
                f"{self.iterations} iterations{codes})")

    def to_json(self) -> str:
        """:meth:`to_dict` as a JSON string.

        Returns
        -------
        str
            The ``bhr solve --json`` document.
        """
        return json.dumps(self.to_dict())

    def to_dict(self) -> dict[str, Any]:
        """The ``bhr solve --json`` document (its keys are a documented contract, docs/commands.md).

        Returns
        -------
        dict of str to object
            ``bhr_version``, ``iterations``, ``position_error`` (mm), ``orientation_error_deg`` (deg or
            None), ``points`` ((n+1) lists of 3 floats, mm, base first), ``codes`` (n ints or None),
            ``success``, ``status`` and ``reason``: plain Python values, ready for :mod:`json`.
        """
        import sys

        return {
            "bhr_version": sys.modules["bhr"].__version__,  # the package, loaded before any of its modules
            "iterations": int(self.iterations),
            "position_error": float(self.position_error_mm),
            "orientation_error_deg": None if self.orientation_error_deg is None else float(self.orientation_error_deg),
            "points": [[float(v) for v in row] for row in self.chain.points],
            "codes": None if self.codes is None else [int(c) for c in self.codes],
            "success": self.success,
            "status": self.status,
            "reason": self.reason,
        }


class Solver(ABC):
    """Base class of all solvers.

    Subclasses set ``name`` and ``summary`` and implement :meth:`solve`.
    Solvers that respect the binary actuators return one code per module in
    their results. ``options`` are solver-specific keyword settings, validated
    in ``__init__`` (and listed in :mod:`bhr._settings.options`).
    :func:`bhr.solvers.get_solver` builds one by name; docs/model.md, "Adding a
    solver", writes a new one.

    Parameters
    ----------
    robot : Robot
        The robot the solver moves: its modules, module length (mm), alpha (deg) and tolerances (mm, deg).
    **options
        The solver's own settings, each an entry of the option registry; the base class takes none and
        refuses any with a :class:`~bhr.BhrError`.

    Attributes
    ----------
    name : str
        The registered name (``bhr solve --solver NAME``).
    summary : str
        One line on what the solver does, shown by ``bhr solvers``.
    accepts_orientation : bool
        Whether the solver takes a wanted tip direction.
    aliases : tuple of str
        Other names it is found by.
    robot : Robot
        The robot given.

    Examples
    --------
    >>> import numpy as np
    >>> from bhr.model import CHAPTER5_ROBOT
    >>> from bhr.solvers import Chain, get_solver
    >>> solver = get_solver("fabrik", CHAPTER5_ROBOT.replace(modules=10))
    >>> solver.solve(Chain.straight(solver.robot, (0, 1, 0)), np.array([3.0, 9.0, 0.0])).status
    'reached'
    """

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    accepts_orientation: ClassVar[bool] = True
    aliases: ClassVar[tuple[str, ...]] = ()

    def __init__(self, robot: Robot, **options: Any) -> None:
        self.robot = robot
        if options:
            raise BhrError(f"solver {self.name} takes no option {excerpt(sorted(options)[0])}")

    @abstractmethod
    def solve(self, chain: Chain, target: np.ndarray, tip_direction: np.ndarray | None = None,
              context: FollowContext | None = None) -> SolveResult:
        """Move ``chain`` toward ``target`` (and the tip along ``tip_direction``, if given).

        A subclass implements it; the base class judges what it returns (``success``, ``status``,
        ``reason``, :meth:`judge`).

        Parameters
        ----------
        chain : Chain
            The chain to start from (not changed: the result holds a new one).
        target : numpy.ndarray, shape (3,)
            The point the tip should reach, mm.
        tip_direction : numpy.ndarray, shape (3,), optional
            The wanted direction of the last module (a unit vector); None leaves the tip free.
        context : FollowContext, optional
            The path and step when driven by follow-the-leader; None for one solve.

        Returns
        -------
        SolveResult
            The new chain, iterations, errors (mm, deg), codes for a binary solver, and the verdict.
        """

    def reset(self) -> None:  # noqa: B027 (a default, not abstract: most solvers keep no state)
        """Forget any state kept between steps of a run (default: none)."""

    def prepare(self, trajectory: Any) -> None:  # noqa: B027 (a default: most solvers need nothing)
        """Look at the whole trajectory (e.g. its lumen) before a run follows it (default: nothing).

        Parameters
        ----------
        trajectory : Trajectory
            The path the run is about to follow, at the robot's feed.
        """

    def follow_kernel(self, path: np.ndarray, dirs: np.ndarray, chain: Chain, out_points: np.ndarray,
                      out_iters: np.ndarray, pe: np.ndarray, oe: np.ndarray, codes: np.ndarray) -> bool | None:
        """Optionally run a whole follow-the-leader run compiled; default: no (``None``).

        A solver that has a compiled per-step kernel may run the driver's loop
        (:func:`bhr._run.driver.follow`) in one compiled call: solve step ``i``
        toward ``path[i]`` with the tip along ``dirs[i]``, write the chain into
        ``out_points[i]``, iterations, scores (``pe``, ``oe``, with
        :func:`bhr._kinematics.leader.score_step`) and codes, then advance with
        :func:`bhr._kinematics.leader.advance_kernel`, giving the same numbers
        as the step-by-step driver. Return whether ``codes`` were filled, or
        ``None`` to be driven step by step through :meth:`solve`.

        Parameters
        ----------
        path : numpy.ndarray, shape (N, 3)
            The trajectory's points, mm, float64.
        dirs : numpy.ndarray, shape (N-1, 3)
            Unit vectors from each point to the next.
        chain : Chain
            The starting chain (n modules, tip at the path's start).
        out_points : numpy.ndarray, shape (N, n+1, 3)
            Filled: the chain at each step, mm, base first.
        out_iters : numpy.ndarray of int64, shape (N,)
            Filled: the iterations of each step.
        pe : numpy.ndarray, shape (N, n+1)
            Filled: each point's position error at each step, mm.
        oe : numpy.ndarray, shape (N, n)
            Filled: each module's orientation error at each step, deg.
        codes : numpy.ndarray of int64, shape (N, n)
            Filled by a binary solver: the codes at each step.

        Returns
        -------
        bool or None
            Whether ``codes`` were filled; None (the default) when the solver has no compiled loop.
        """
        return None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Every subclass's :meth:`solve` judges its result (success, status, reason) before returning it."""
        super().__init_subclass__(**kwargs)
        inner = cls.__dict__.get("solve")
        if inner is None or getattr(inner, "_judged", False) or getattr(inner, "__isabstractmethod__", False):
            return

        @functools.wraps(inner)
        def solve(self: "Solver", chain: Chain, target: np.ndarray, tip_direction: np.ndarray | None = None,
                  context: FollowContext | None = None) -> SolveResult:
            return self.judge(inner(self, chain, target, tip_direction, context), chain, target)

        solve._judged = True  # type: ignore[attr-defined]
        cls.solve = solve  # type: ignore[method-assign]

    def judge(self, result: SolveResult, start: Chain | None = None, target: Any = None) -> SolveResult:
        """Set ``result``'s ``success``, ``status`` and ``reason`` from the robot's tolerances.

        Position in mm, and orientation in degrees when aimed; ``start`` and ``target`` tell an unreachable
        target from one the solver fell short of.

        Parameters
        ----------
        result : SolveResult
            The solve to judge; changed in place.
        start : Chain, optional
            The chain the solve started from (its length is the robot's reach).
        target : array_like, shape (3,), optional
            The target, mm.

        Returns
        -------
        SolveResult
            ``result``, with ``success``, ``status`` (``"reached"``, ``"not reached"``, ``"out of reach"``)
            and ``reason`` set.
        """
        r = self.robot
        ori = result.orientation_error_deg
        pos_ok = result.position_error_mm <= r.tol_pos
        ori_ok = ori is None or ori <= r.tol_ori
        result.success = bool(pos_ok and ori_ok)
        if result.success:
            result.status = "reached"
            aimed = "" if ori is None else f" and {ori:.4g} deg (tolerance {r.tol_ori:g} deg)"
            result.reason = (f"within tolerance: {result.position_error_mm:.4g} mm (tolerance {r.tol_pos:g} mm)"
                             f"{aimed} after {result.iterations} iterations")
            return result
        if start is not None and target is not None and not pos_ok:
            reach = float(np.linalg.norm(np.diff(start.points, axis=0), axis=1).sum())  # the chain, straight
            far = float(np.linalg.norm(np.asarray(target, dtype=np.float64) - start.points[0]))
            if far > reach + 1e-9:
                result.status = "out of reach"
                result.reason = (f"the target is {far:.4g} mm from the base but the chain is {reach:.4g} mm long; "
                                 f"the tip stops {result.position_error_mm:.4g} mm short")
                return result
        result.status = "not reached"
        parts = []
        if not pos_ok:
            parts.append(f"position {result.position_error_mm:.4g} mm off (tolerance {r.tol_pos:g} mm)")
        if not ori_ok:
            parts.append(f"tip {ori:.4g} deg off (tolerance {r.tol_ori:g} deg)")
        result.reason = f"{' and '.join(parts)} after {result.iterations} iterations"
        return result


def check_target(target: Sequence[float], what: str = "target") -> np.ndarray:
    t = np.asarray(target, dtype=np.float64)
    if t.shape != (3,):
        raise BhrError(f"{what} must have three coordinates X Y Z")
    if not np.all(np.isfinite(t)):
        raise BhrError(f"{what} must be finite numbers, got {t.tolist()}")
    return t


def check_direction(direction: Sequence[float] | None, what: str = "orientation") -> np.ndarray | None:
    if direction is None:
        return None
    d = check_target(direction, what)
    n = float(np.linalg.norm(d))
    if n == 0.0 or not math.isfinite(n):
        raise BhrError(f"{what} must be a non-zero vector")
    return d / n
