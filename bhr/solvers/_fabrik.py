"""FABRIK, Forward And Backward Reaching Inverse Kinematics (thesis ch. 5.1.1).

Reachability check first: a target farther from the base than the chain's
length gets the chain stretched toward it. Otherwise each iteration is a
tip-to-base pass (tip on the target, each point pulled to one module length
from the next) then a base-to-tip pass (base back in place); the error is the
tip's distance to the target, checked after each iteration. With a wanted
tip direction the tip-to-base pass puts point n one module length behind the
target, opposite that direction (ch. 6.1), the reachability check is skipped,
and both tolerances must be met.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from bhr._kinematics.leader import acos_deg
from bhr.solvers._base import Chain, FollowContext, SolveResult, Solver, register


@njit(cache=True, inline="always")
def pull_point(P: np.ndarray, src: int, dst: int, length: float) -> None:
    """Move P[dst] onto the line P[src]-P[dst], ``length`` from P[src].

    Written ``(1 - lam) P[src] + lam P[dst]`` as the thesis's MATLAB does (the
    constrained solver keeps its arithmetic); plain FABRIK below uses the
    equivalent ``P[src] + lam (P[dst] - P[src])`` with the point in registers.
    FABRIK's pull is undefined for coincident points (a target at the base, a folded chain): the chain then
    continues straight, along the link on the other side of ``src``, or (0, 0, 1) when there is none.

    Inlined where it is called, and written without calls that take the array (they would cost a pair of
    atomic reference counts per pull): the thesis's loop pulls some 60 points per step.
    """
    dx = P[dst, 0] - P[src, 0]
    dy = P[dst, 1] - P[src, 1]
    dz = P[dst, 2] - P[src, 2]
    r = math.sqrt(dx * dx + dy * dy + dz * dz)
    if r == 0.0:
        ux, uy, uz = 0.0, 0.0, 1.0
        other = 2 * src - dst
        if 0 <= other < P.shape[0]:
            vx = P[src, 0] - P[other, 0]
            vy = P[src, 1] - P[other, 1]
            vz = P[src, 2] - P[other, 2]
            nv = math.sqrt(vx * vx + vy * vy + vz * vz)
            if nv > 0.0:
                ux, uy, uz = vx / nv, vy / nv, vz / nv
        P[dst, 0] = P[src, 0] + length * ux
        P[dst, 1] = P[src, 1] + length * uy
        P[dst, 2] = P[src, 2] + length * uz
        return
    lam = length / r
    for k in range(3):
        P[dst, k] = (1.0 - lam) * P[src, k] + lam * P[dst, k]


@njit(cache=True, inline="always")
def point_distance(P: np.ndarray, i: int, t: np.ndarray) -> float:
    dx = t[0] - P[i, 0]
    dy = t[1] - P[i, 1]
    dz = t[2] - P[i, 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True, inline="always")
def tip_angle_deg(P: np.ndarray, d: np.ndarray) -> float:
    """Angle in degrees between the last module and unit direction ``d``."""
    n = P.shape[0] - 1
    vx = P[n, 0] - P[n - 1, 0]
    vy = P[n, 1] - P[n - 1, 1]
    vz = P[n, 2] - P[n - 1, 2]
    nv = math.sqrt(vx * vx + vy * vy + vz * vz)
    return acos_deg((vx * d[0] + vy * d[1] + vz * d[2]) / nv)  # d is a unit vector here


@njit(cache=True)
def fabrik_kernel(P: np.ndarray, target: np.ndarray, length: float, tol: float, max_iter: int,
                  direction: np.ndarray, has_dir: bool, tol_ori: float):
    """Unconstrained FABRIK on ``P`` (modified in place). Returns (iterations, error, angle)."""
    n = P.shape[0] - 1
    bx, by, bz = P[0, 0], P[0, 1], P[0, 2]
    if not has_dir:
        reach = math.sqrt((target[0] - bx) ** 2 + (target[1] - by) ** 2 + (target[2] - bz) ** 2)
        if reach > n * length:
            # unreachable: stretch the chain toward the target
            for i in range(n):
                r = point_distance(P, i, target)
                lam = length / r
                for k in range(3):
                    P[i + 1, k] = (1.0 - lam) * P[i, k] + lam * target[k]
            return 0, point_distance(P, n, target), 0.0
    err = point_distance(P, n, target)
    ang = tip_angle_deg(P, direction) if has_dir else 0.0
    k = 0
    while (err > tol or (has_dir and ang > tol_ori)) and k < max_iter:
        # tip to base; the point just placed is carried in registers (sx, sy, sz)
        sx, sy, sz = target[0], target[1], target[2]
        P[n, 0], P[n, 1], P[n, 2] = sx, sy, sz
        start = n - 1
        if has_dir:
            sx, sy, sz = sx - length * direction[0], sy - length * direction[1], sz - length * direction[2]
            P[n - 1, 0], P[n - 1, 1], P[n - 1, 2] = sx, sy, sz
            start = n - 2
        for i in range(start, -1, -1):
            dx, dy, dz = P[i, 0] - sx, P[i, 1] - sy, P[i, 2] - sz
            r = math.sqrt(dx * dx + dy * dy + dz * dz)
            if r == 0.0:
                pull_point(P, i + 1, i, length)
                sx, sy, sz = P[i, 0], P[i, 1], P[i, 2]
                continue
            lam = length / r
            sx, sy, sz = sx + lam * dx, sy + lam * dy, sz + lam * dz
            P[i, 0], P[i, 1], P[i, 2] = sx, sy, sz
        # base to tip, from the fixed base
        sx, sy, sz = bx, by, bz
        P[0, 0], P[0, 1], P[0, 2] = bx, by, bz
        for i in range(n):
            dx, dy, dz = P[i + 1, 0] - sx, P[i + 1, 1] - sy, P[i + 1, 2] - sz
            r = math.sqrt(dx * dx + dy * dy + dz * dz)
            if r == 0.0:
                pull_point(P, i, i + 1, length)
                sx, sy, sz = P[i + 1, 0], P[i + 1, 1], P[i + 1, 2]
                continue
            lam = length / r
            sx, sy, sz = sx + lam * dx, sy + lam * dy, sz + lam * dz
            P[i + 1, 0], P[i + 1, 1], P[i + 1, 2] = sx, sy, sz
        err = point_distance(P, n, target)
        if has_dir:
            ang = tip_angle_deg(P, direction)
        k += 1
    return k, err, ang


@register
class Fabrik(Solver):
    """Unconstrained FABRIK (thesis ch. 5.1.1); continuous angles, no codes."""

    name = "fabrik"
    summary = "unconstrained FABRIK (thesis ch. 5); optional tip orientation"

    def solve(self, chain: Chain, target: np.ndarray, tip_direction: np.ndarray | None = None,
              context: FollowContext | None = None) -> SolveResult:
        r = self.robot
        out = chain.copy()
        has_dir = tip_direction is not None
        d = np.zeros(3) if tip_direction is None else np.asarray(tip_direction, dtype=np.float64)
        k, err, ang = fabrik_kernel(out.points, np.asarray(target, dtype=np.float64), float(r.module_length),
                                    float(r.tol_pos), int(r.max_iter), d, has_dir, float(r.tol_ori))
        return SolveResult(out, int(k), float(err), float(ang) if has_dir else None)
