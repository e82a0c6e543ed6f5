"""Follow-the-leader driver: advance along a trajectory, re-solve, score (thesis ch. 7).

The robot starts straight with its tip on the trajectory's start (the thesis:
tip at the origin, body along -x). At step ``i`` the target is trajectory
point ``i`` and the wanted tip direction the unit vector to point ``i+1`` (the
last step reuses the previous one). After each solve the whole robot advances
by the feed along its base module, and the local axes of modules 2..n are
reset to those of a straight robot (module 1 keeps its own). Point ``j`` (1 =
base, n+1 = tip) is scored against the trajectory point ``(n+1-j) f`` steps
behind the current one (0 before that exists), ``f`` the feed divisor;
module ``j < n`` against the path direction there, and the tip module against
the wanted tip direction.

Solvers that provide ``follow_kernel`` run the whole loop compiled; any other
solver is driven step by step from Python with the same compiled scoring and
advance kernels.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numba import njit

from bhr._callable import make_callable
from bhr.errors import BhrError
from bhr.robot import Robot
from bhr.solvers import Chain, FollowContext, get_solver
from bhr.trajectory import Trajectory

__all__ = ["follow", "FollowResult", "path_directions", "score_step", "advance_kernel", "stats"]


class BhrWarning(UserWarning):
    """A run that completes but should be read with care (e.g. a curve tighter than the robot can turn)."""


@njit(cache=True)
def _angle_deg(ax: float, ay: float, az: float, d: np.ndarray) -> float:
    na = math.sqrt(ax * ax + ay * ay + az * az)
    nd = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    c = (ax * d[0] + ay * d[1] + az * d[2]) / (na * nd)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


@njit(cache=True)
def score_step(i: int, P: np.ndarray, path: np.ndarray, dirs: np.ndarray, f: int, tip_ori: float,
               pe: np.ndarray, oe: np.ndarray) -> None:
    """Errors of step ``i`` (0-based): points into ``pe`` (n+1), modules into ``oe`` (n)."""
    n = P.shape[0] - 1
    for j in range(n + 1):
        idx = i - (n - j) * f
        if idx < 0:
            pe[j] = 0.0
        else:
            dx = P[j, 0] - path[idx, 0]
            dy = P[j, 1] - path[idx, 1]
            dz = P[j, 2] - path[idx, 2]
            pe[j] = math.sqrt(dx * dx + dy * dy + dz * dz)
    oe[n - 1] = tip_ori
    for j in range(n - 1):
        idx = i - (n - j) * f
        if idx < 0:
            oe[j] = 0.0
        else:
            oe[j] = _angle_deg(P[j + 1, 0] - P[j, 0], P[j + 1, 1] - P[j, 1], P[j + 1, 2] - P[j, 2], dirs[idx])


@njit(cache=True)
def advance_kernel(P: np.ndarray, E1: np.ndarray, E2: np.ndarray, feed: float, length: float) -> None:
    """Advance by ``feed`` along the base module; reset the axes of modules 2..n (in place)."""
    n = P.shape[0] - 1
    ox, oy, oz = P[1, 0] - P[0, 0], P[1, 1] - P[0, 1], P[1, 2] - P[0, 2]
    no = math.sqrt(ox * ox + oy * oy + oz * oz)
    ob = np.array([ox / no, oy / no, oz / no])
    for j in range(n + 1):
        for c in range(3):
            P[j, c] = P[j, c] + feed * ob[c]
    for j in range(E1.shape[0]):
        for c in range(3):
            E1[j, c] = E1[j, c] + feed * ob[c]
            E2[j, c] = E2[j, c] + feed * ob[c]
    for E in (E1, E2):
        dx, dy, dz = E[0, 0] - P[0, 0], E[0, 1] - P[0, 1], E[0, 2] - P[0, 2]
        nd = math.sqrt(dx * dx + dy * dy + dz * dz)
        d = np.array([dx / nd, dy / nd, dz / nd])
        for j in range(1, n):
            for c in range(3):
                E[j, c] = P[0, c] + ob[c] * length * j + d[c]


def path_directions(path: np.ndarray) -> np.ndarray:
    """Unit vectors from each trajectory point to the next, (N-1, 3)."""
    diff = np.diff(path, axis=0)
    norms = np.linalg.norm(diff, axis=1)
    if np.any(norms == 0):
        k = int(np.argmin(norms))
        raise BhrError(f"trajectory points {k + 1} and {k + 2} are the same point; remove the duplicate")
    return diff / norms[:, None]


def stats(values: np.ndarray, first: int = 0) -> dict[str, float | int]:
    """max, mean, median and final of ``values[first:]`` and the worst step (1-based)."""
    v = values[first:] if first < len(values) else values[-1:]
    worst = int(np.argmax(values)) + 1
    return {
        "max": float(np.max(values)),
        "mean": float(np.mean(v)),
        "median": float(np.median(v)),
        "final": float(values[-1]),
        "worst_step": worst,
    }


@dataclass
class FollowResult:
    """A whole run: per-step poses, codes and errors, with the summary of the thesis's script."""

    trajectory: Trajectory
    robot: Robot
    solver: str
    points: np.ndarray  # (N, n+1, 3) solved pose at each step
    iterations: np.ndarray  # (N,)
    point_errors: np.ndarray  # (N, n+1) mm, base first
    orientation_errors: np.ndarray  # (N, n) degrees
    codes: np.ndarray | None = None  # (N, n)
    warnings: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def steps(self) -> int:
        return int(self.points.shape[0])

    @property
    def modules(self) -> int:
        return int(self.points.shape[1] - 1)

    @property
    def global_errors(self) -> np.ndarray:
        """(N, n): module j pairs point j+1 with module j, weighted and normalised by the tolerances."""
        r = self.robot
        return (r.weight_pos * self.point_errors[:, 1:] / r.tol_pos
                + r.weight_ori * self.orientation_errors / r.tol_ori)

    def summary(self) -> dict[str, Any]:
        """Max, mean, median and final per point and module (leading unscored steps left out of mean/median)."""
        n = self.modules
        f = self.robot.feed_divisor
        pts = [stats(self.point_errors[:, j], (n - j) * f) for j in range(n + 1)]
        mods = [stats(self.orientation_errors[:, j], (n - j - 1) * f) for j in range(n)]
        glob = [stats(self.global_errors[:, j], (n - j - 1) * f) for j in range(n)]
        worst_flat = int(np.argmax(self.point_errors.max(axis=1))) + 1
        out = {
            "steps": self.steps,
            "solver": self.solver,
            "trajectory": self.trajectory.name,
            "tip_max_error_mm": pts[-1]["max"],
            "tip_final_error_mm": pts[-1]["final"],
            "tip_worst_step": pts[-1]["worst_step"],
            "points_max_error_mm": float(self.point_errors.max()),
            "points_worst_step": worst_flat,
            "orientation_max_deg": float(self.orientation_errors.max()),
            "tip_orientation_max_deg": mods[-1]["max"],
            "tip_orientation_final_deg": mods[-1]["final"],
            "global_max": float(self.global_errors.max()),
            "mean_iterations": float(np.mean(self.iterations)),
            "points": pts,
            "modules": mods,
            "global": glob,
            "warnings": list(self.warnings),
        }
        out.update(self.extra.get("summary", {}))
        return out

    def to_json(self) -> dict[str, Any]:
        """The ``bhr follow --json`` document (SPEC.md section 3)."""
        steps = []
        for i in range(self.steps):
            steps.append({
                "step": i + 1,
                "target": [float(v) for v in self.trajectory.points[i]],
                "points": [[float(v) for v in row] for row in self.points[i]],
                "point_errors_mm": [float(v) for v in self.point_errors[i]],
                "module_orientation_errors_deg": [float(v) for v in self.orientation_errors[i]],
                "codes": None if self.codes is None else [int(c) for c in self.codes[i]],
                "iterations": int(self.iterations[i]),
            })
        return {
            "trajectory": {"name": self.trajectory.name, "params": self.trajectory.params,
                           "points": self.trajectory.points.tolist()},
            "robot": self.robot.to_dict(),
            "solver": self.solver,
            "steps": steps,
            "summary": self.summary(),
        }


def _as_trajectory(points: Any) -> Trajectory:
    if isinstance(points, Trajectory):
        return points
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise BhrError("trajectory points must be an (N, 3) array of x, y, z in mm")
    if not np.all(np.isfinite(arr)):
        raise BhrError("trajectory points must be finite numbers")
    return Trajectory("points", arr)


def follow(points: Any, solver: str = "seed", robot: Robot | None = None, *,
           solver_options: dict[str, Any] | None = None,
           on_step: Callable[[int, np.ndarray | None], None] | None = None,
           compiled: bool = True, **robot_options: Any) -> FollowResult:
    """Run follow-the-leader along ``points`` ((N, 3) array or a :class:`Trajectory`).

    ``robot_options`` are :class:`bhr.robot.Robot` fields (``modules``,
    ``module_length``, ``alpha``, ``tol_pos``, ...); defaults are the thesis's.
    ``on_step(i, codes)`` is called after each step (0-based) when given, e.g.
    to stream codes to the board; it forces the step-by-step driver.
    """
    traj = _as_trajectory(points)
    if robot is None:
        robot = Robot(**robot_options)
    elif robot_options:
        robot = robot.replace(**robot_options)
    path = np.ascontiguousarray(traj.points, dtype=np.float64)
    if path.shape[0] < 2:
        raise BhrError("a trajectory needs at least two points")
    dirs = path_directions(path)
    s = get_solver(solver, robot, **(solver_options or {}))
    s.reset()
    msgs: list[str] = []
    if traj.min_radius < robot.min_turn_radius:
        msg = (f"the trajectory turns with radius {traj.min_radius:.2f} mm, tighter than the robot's minimum "
               f"turn radius {robot.min_turn_radius:.2f} mm; expect large errors")
        msgs.append(msg)
        warnings.warn(msg, BhrWarning, stacklevel=2)
    n = robot.modules
    N = path.shape[0]
    chain = Chain.straight(robot, traj.start_direction, traj.start_point, tip_at_origin=True)
    out_points = np.zeros((N, n + 1, 3))
    out_iters = np.zeros(N, dtype=np.int64)
    pe = np.zeros((N, n + 1))
    oe = np.zeros((N, n))
    codes = np.zeros((N, n), dtype=np.int64)
    has_codes = True
    kernel = getattr(s, "follow_kernel", None)
    if compiled and on_step is None and kernel is not None:
        has_codes = kernel(path, dirs, chain, out_points, out_iters, pe, oe, codes)
    else:
        f = robot.feed_divisor
        for i in range(N):
            d = dirs[-1] if i == N - 1 else dirs[i]
            res = s.solve(chain, path[i], d if s.accepts_orientation else None,
                          FollowContext(path, dirs, i))
            P = res.chain.points
            tip = res.orientation_error_deg
            if tip is None:
                tip = float(_angle_deg(P[n, 0] - P[n - 1, 0], P[n, 1] - P[n - 1, 1], P[n, 2] - P[n - 1, 2], d))
            out_points[i] = P
            out_iters[i] = res.iterations
            score_step(i, P, path, dirs, f, tip, pe[i], oe[i])
            if res.codes is None:
                has_codes = False
            else:
                codes[i] = res.codes
            if on_step is not None:
                on_step(i, None if res.codes is None else codes[i])
            chain = res.chain.advance(robot.feed, robot.module_length)
    return FollowResult(traj, robot, solver, out_points, out_iters, pe, oe, codes if has_codes else None, msgs)


make_callable(__name__, "follow")
