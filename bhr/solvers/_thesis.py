"""The thesis's constrained FABRIK (ch. 6, appendix 2), ported as one numba kernel.

Each iteration has a tip-to-base pass with the tip-orientation constraint
(tip on the target, point n one module length behind it against the wanted
direction, the rest as plain FABRIK) and a base-to-tip pass where, from
iteration ``warmup + 1`` on, each module's new point is the previous module's
direction rotated (dual quaternion, Ec. 6.1-6.9) about a chosen axis by a
limited angle:

* ``limit``: ``binary`` (0 or alpha, switching when the free angle exceeds
  alpha/2), ``continuous`` (at most alpha) or ``none``;
* ``axes``: ``local`` (the module's two local axes and their opposites, the one
  nearest the free rotation axis) or ``free`` (the free rotation axis);
* ``warmup``: iterations run with the orientation constraint alone (10 in the
  thesis); with a warm-up, at least ``warmup + 1`` iterations always run.

``--solver thesis`` (also accepted as ``seed``) is the full thesis algorithm
(binary, local axes, 10 warm-up iterations) and returns module codes (see :mod:`bhr.model._codes`). Every other
setting reruns one of the chapter 6 steps.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from bhr.model._codes import TILT_CODES
from bhr._kinematics.dualquat import k_rotate
from bhr._settings.errors import BhrError
from bhr._settings.options import BY_NAME
from bhr._kinematics.leader import acos_deg, finish_step
from bhr.solvers._base import Chain, FollowContext, SolveResult, Solver, register
from bhr.solvers._fabrik import point_distance, pull_point, tip_angle_deg

LIMIT_NONE, LIMIT_CONTINUOUS, LIMIT_BINARY = 0, 1, 2
LIMITS = {"none": LIMIT_NONE, "continuous": LIMIT_CONTINUOUS, "binary": LIMIT_BINARY}
AXES = BY_NAME["axes"].choices or ()
_TILT = np.array(TILT_CODES, dtype=np.int64)


@njit(cache=True, inline="always")
def _rotate_about(A: np.ndarray, j: int, pivot: np.ndarray, ch: float, sh: float, ax: float, ay: float, az: float):
    """A[j] (held relative to ``pivot``) rotated, then made absolute again."""
    x, y, z = k_rotate(A[j, 0], A[j, 1], A[j, 2], ch, sh, ax, ay, az)
    A[j, 0] = x + pivot[0]
    A[j, 1] = y + pivot[1]
    A[j, 2] = z + pivot[2]


#: Cosines further than this below the largest cannot give the least angle (see :func:`nearest_axis`).
_COS_NEAR = 1e-9


@njit(cache=True)
def nearest_axis(ax: float, ay: float, az: float, g: np.ndarray) -> int:
    """Which of the four unit axes ``g`` (4, 3) is at the least angle from the unit axis (ax, ay, az): the first
    ``q`` of least ``acos_deg(a . g[q])``, as the thesis picks it, with fewer arc cosines.

    The arc cosine falls as the cosine rises, by at least as much (its slope is at most -1), so an axis whose
    cosine is more than :data:`_COS_NEAR` below the largest is more than 5e-8 deg further away than the axis of
    the largest, far more than the arc cosine's rounding (1e-13 deg): it is never the least. Only the axes
    within that of the largest are compared by their arc cosines, in order, the first of the least winning:
    the same axis, to the bit, as taking every arc cosine (usually one axis is left and no arc cosine is taken).
    """
    c0 = max(-1.0, min(1.0, ax * g[0, 0] + ay * g[0, 1] + az * g[0, 2]))  # clamped as acos_deg clamps
    c1 = max(-1.0, min(1.0, ax * g[1, 0] + ay * g[1, 1] + az * g[1, 2]))
    c2 = max(-1.0, min(1.0, ax * g[2, 0] + ay * g[2, 1] + az * g[2, 2]))
    c3 = max(-1.0, min(1.0, ax * g[3, 0] + ay * g[3, 1] + az * g[3, 2]))
    top = -math.inf
    for c in (c0, c1, c2, c3):
        if c > top:  # a NaN is never the largest
            top = c
    near = 0
    idx = 0
    for q, c in enumerate((c0, c1, c2, c3)):
        if top - c <= _COS_NEAR:  # false for a NaN, whose arc cosine is never the least either
            if near == 0:
                idx = q
            near += 1
    if near <= 1:
        return idx
    best = 1e300
    for q, c in enumerate((c0, c1, c2, c3)):
        if top - c <= _COS_NEAR:
            a = acos_deg(c)
            if a < best:
                best = a
                idx = q
    return idx


@njit(cache=True)
def constrained_kernel(P: np.ndarray, E1: np.ndarray, E2: np.ndarray, target: np.ndarray, direction: np.ndarray,
                has_dir: bool, length: float, tol_pos: float, tol_ori: float, alpha: float, max_iter: int,
                limit: int, local_axes: bool, warmup: int, codes: np.ndarray, tilts: np.ndarray):
    """Constrained FABRIK on ``P``; ``E1``/``E2`` are the axis points (modified in place).

    Returns (iterations, position error, orientation error in degrees).
    ``codes`` and ``tilts`` (degrees) receive each module's result from the
    last constrained iteration.
    """
    n = P.shape[0] - 1
    return _constrained(P, E1, E2, target, direction, has_dir, length, tol_pos, tol_ori, alpha, max_iter, limit,
                        local_axes, warmup, codes, tilts, np.empty((n, 3)), np.empty((n, 3)), np.empty((4, 3)))


@njit(cache=True, inline="always")
def _constrained(P, E1, E2, target, direction, has_dir, length, tol_pos, tol_ori, alpha, max_iter, limit, local_axes,
                 warmup, codes, tilts, A1, A2, g):
    """:func:`constrained_kernel` with its work arrays given: ``A1``, ``A2`` (n, 3) and ``g`` (4, 3), so that a
    follow-the-leader loop allocates them once, not at every step."""
    n = P.shape[0] - 1
    # reference point behind the base: the base module's direction before the solve
    n0 = math.sqrt((P[1, 0] - P[0, 0]) ** 2 + (P[1, 1] - P[0, 1]) ** 2 + (P[1, 2] - P[0, 2]) ** 2)
    bx, by, bz = P[0, 0], P[0, 1], P[0, 2]
    before_x = P[0, 0] - length * ((P[1, 0] - P[0, 0]) / n0)
    before_y = P[0, 1] - length * ((P[1, 1] - P[0, 1]) / n0)
    before_z = P[0, 2] - length * ((P[1, 2] - P[0, 2]) / n0)
    err = point_distance(P, n, target)
    ang = tip_angle_deg(P, direction) if has_dir else 0.0
    min_iter = warmup + 1 if warmup > 0 else 0
    h_alpha = math.radians(alpha) / 2.0
    ch_alpha, sh_alpha = math.cos(h_alpha), math.sin(h_alpha)
    for i in range(n):
        codes[i] = 0
        tilts[i] = 0.0
    touched = False  # whether a constrained iteration ran (it moves the axis points)
    k = 0
    # the warm-up's iterations always run: their errors are not needed, and they leave the axis points as they were
    while k < min_iter or err > tol_pos or (has_dir and ang > tol_ori):
        # tip to base, with the tip-orientation constraint
        for c in range(3):
            P[n, c] = target[c]
        start = n - 1
        if has_dir:
            for c in range(3):
                P[n - 1, c] = target[c] - length * direction[c]
            start = n - 2
        for i in range(start, 0, -1):  # point 0 too, but the base to tip pass puts it back on the base at once
            pull_point(P, i + 1, i, length)
        # base to tip
        P[0, 0] = bx
        P[0, 1] = by
        P[0, 2] = bz
        constrained = k >= warmup and limit != LIMIT_NONE
        # in a warm-up iteration that another one follows, points n-1 and n are dead: the next tip-to-base pass
        # sets both from the target before it reads them
        last = n - 2 if has_dir and not constrained and k + 1 < min_iter and k + 1 < max_iter else n
        if constrained:
            touched = True
            for a in range(n):
                for c in range(3):
                    A1[a, c] = E1[a, c]
                    A2[a, c] = E2[a, c]
        for i in range(n):
            if not constrained:
                if i < last:
                    pull_point(P, i, i + 1, length)
                continue
            for j in range(i, n):
                for c in range(3):
                    A1[j, c] -= P[i, c]
                    A2[j, c] -= P[i, c]
            m1 = math.sqrt(A1[i, 0] ** 2 + A1[i, 1] ** 2 + A1[i, 2] ** 2)
            m2 = math.sqrt(A2[i, 0] ** 2 + A2[i, 1] ** 2 + A2[i, 2] ** 2)
            for c in range(3):
                g[0, c] = A1[i, c] / m1
                g[1, c] = A2[i, c] / m2
                g[2, c] = -g[0, c]
                g[3, c] = -g[1, c]
            # the point plain FABRIK would choose
            if i == 0:
                v1x, v1y, v1z = before_x - P[0, 0], before_y - P[0, 1], before_z - P[0, 2]
            else:
                v1x, v1y, v1z = P[i - 1, 0] - P[i, 0], P[i - 1, 1] - P[i, 1], P[i - 1, 2] - P[i, 2]
            r = math.sqrt((P[i + 1, 0] - P[i, 0]) ** 2 + (P[i + 1, 1] - P[i, 1]) ** 2 + (P[i + 1, 2] - P[i, 2]) ** 2)
            if r == 0.0:
                # coincident points (a target at the base): continue straight
                lam = -length / math.sqrt(v1x ** 2 + v1y ** 2 + v1z ** 2)
                v2x, v2y, v2z = lam * v1x, lam * v1y, lam * v1z
            else:
                lam = length / r
                v2x = (1.0 - lam) * P[i, 0] + lam * P[i + 1, 0] - P[i, 0]
                v2y = (1.0 - lam) * P[i, 1] + lam * P[i + 1, 1] - P[i, 1]
                v2z = (1.0 - lam) * P[i, 2] + lam * P[i + 1, 2] - P[i, 2]
            # free rotation axis and angle (v2 x v1, 180 - angle(v2, v1))
            rx = v2y * v1z - v2z * v1y
            ry = v2z * v1x - v2x * v1z
            rz = v2x * v1y - v2y * v1x
            nr = math.sqrt(rx * rx + ry * ry + rz * rz)
            n1 = math.sqrt(v1x ** 2 + v1y ** 2 + v1z ** 2)
            n2 = math.sqrt(v2x * v2x + v2y * v2y + v2z * v2z)
            theta = 180.0 - acos_deg((v2x * v1x + v2y * v1y + v2z * v1z) / (n2 * n1))
            if limit == LIMIT_BINARY:  # one of two tilts: their half-angles' cosines and sines taken once
                if theta > alpha / 2.0:
                    theta, ch, sh = alpha, ch_alpha, sh_alpha
                else:
                    theta, ch, sh = 0.0, 1.0, 0.0  # cos 0 and sin 0, exactly
            else:
                if theta > alpha:
                    theta = alpha
                h = math.radians(theta) / 2.0
                ch, sh = math.cos(h), math.sin(h)
            tilts[i] = theta
            if theta == 0.0:
                # no tilt (code 0): the rotation is the identity (its quaternion is (1, 0): cos 0 and sin 0 exactly),
                # to the value, so the axis is not needed and only the shifts remain
                codes[i] = 0
                P[i + 1, 0] = -v1x + P[i, 0]
                P[i + 1, 1] = -v1y + P[i, 1]
                P[i + 1, 2] = -v1z + P[i, 2]
                for j in range(i, n):
                    for c in range(3):
                        A1[j, c] = A1[j, c] + P[i, c]
                        A2[j, c] = A2[j, c] + P[i, c]
                continue
            idx = 0
            if nr == 0.0:
                ax, ay, az = g[0, 0], g[0, 1], g[0, 2]
            else:
                ax, ay, az = rx / nr, ry / nr, rz / nr
                if local_axes:
                    idx = nearest_axis(ax, ay, az, g)
                    ax, ay, az = g[idx, 0], g[idx, 1], g[idx, 2]
            codes[i] = _TILT[idx]
            x, y, z = k_rotate(-v1x, -v1y, -v1z, ch, sh, ax, ay, az)
            P[i + 1, 0] = x + P[i, 0]
            P[i + 1, 1] = y + P[i, 1]
            P[i + 1, 2] = z + P[i, 2]
            for j in range(i, n):
                _rotate_about(A1, j, P[i], ch, sh, ax, ay, az)
            for j in range(i, n):
                _rotate_about(A2, j, P[i], ch, sh, ax, ay, az)
        k += 1
        if k >= min_iter or k >= max_iter:
            err = point_distance(P, n, target)
            if has_dir:
                ang = tip_angle_deg(P, direction)
        if k >= max_iter:
            break
    if touched:
        for a in range(n):
            for c in range(3):
                E1[a, c] = A1[a, c]
                E2[a, c] = A2[a, c]
    return k, err, ang


@njit(cache=True)
def follow_constrained_kernel(path, dirs, P, E1, E2, length, feed, f, tol_pos, tol_ori, alpha, max_iter, limit,
                       local_axes, warmup, out_points, out_iters, pe, oe, codes):
    """The thesis's whole trajectory loop with the constrained FABRIK kernel, compiled."""
    N = path.shape[0]
    n = P.shape[0] - 1
    tilts = np.zeros(n)
    step_codes = np.zeros(n, dtype=np.int64)
    A1, A2, g = np.empty((n, 3)), np.empty((n, 3)), np.empty((4, 3))
    for i in range(N):
        d = dirs[N - 2] if i == N - 1 else dirs[i]
        k, ep, eo = _constrained(P, E1, E2, path[i], d, True, length, tol_pos, tol_ori, alpha, max_iter, limit,
                                 local_axes, warmup, step_codes, tilts, A1, A2, g)
        finish_step(i, P, E1, E2, path, dirs, f, feed, length, eo, k, step_codes, out_points, out_iters, pe, oe, codes)


class ConstrainedFabrik(Solver):
    """Constrained FABRIK with each of the thesis's constraints selectable."""

    name = "constrained"
    summary = "constrained FABRIK with selectable --limit, --axes and --warmup (thesis ch. 6)"
    default_limit = BY_NAME["limit"].default
    default_axes = BY_NAME["axes"].default
    default_warmup = BY_NAME["warmup"].default

    def __init__(self, robot, limit: str | None = None, axes: str | None = None, warmup: int | None = None) -> None:
        super().__init__(robot)
        self.limit = self.default_limit if limit is None else limit
        self.axes = self.default_axes if axes is None else axes
        self.warmup = self.default_warmup if warmup is None else warmup
        if self.limit not in LIMITS:
            raise BhrError(f"unknown limit {self.limit!r}; use one of {', '.join(LIMITS)}")
        if self.axes not in AXES:
            raise BhrError(f"unknown axes {self.axes!r}; use local or free")
        if isinstance(self.warmup, bool) or not isinstance(self.warmup, int) or self.warmup < 0:
            raise BhrError(f"warmup must be a whole number >= 0, got {self.warmup!r}")
        if self.limit != "none" and robot.max_iter <= self.warmup:
            raise BhrError(
                f"max-iter {robot.max_iter} leaves no constrained iteration after {self.warmup} warm-up "
                f"iterations; raise --max-iter above {self.warmup} or lower --warmup"
            )

    @property
    def returns_codes(self) -> bool:
        return self.limit == "binary" and self.axes == "local"

    def solve(self, chain: Chain, target: np.ndarray, tip_direction: np.ndarray | None = None,
              context: FollowContext | None = None) -> SolveResult:
        r = self.robot
        out = chain.copy()
        n = out.modules
        codes = np.zeros(n, dtype=np.int64)
        tilts = np.zeros(n)
        has_dir = tip_direction is not None
        d = np.zeros(3) if tip_direction is None else np.asarray(tip_direction, dtype=np.float64)
        E1 = np.ascontiguousarray(out.axes[0])
        E2 = np.ascontiguousarray(out.axes[1])
        k, err, ang = constrained_kernel(out.points, E1, E2, np.asarray(target, dtype=np.float64), d, has_dir,
                                  float(r.module_length), float(r.tol_pos), float(r.tol_ori), float(r.alpha),
                                  int(r.max_iter), LIMITS[self.limit], self.axes == "local", int(self.warmup),
                                  codes, tilts)
        out.axes[0] = E1
        out.axes[1] = E2
        return SolveResult(out, int(k), float(err), float(ang) if has_dir else None,
                           [int(c) for c in codes] if self.returns_codes else None,
                           {"tilts_deg": [float(t) for t in tilts]})


    def follow_kernel(self, path: np.ndarray, dirs: np.ndarray, chain: Chain, out_points: np.ndarray,
                      out_iters: np.ndarray, pe: np.ndarray, oe: np.ndarray, codes: np.ndarray) -> bool:
        """Run the whole follow-the-leader loop compiled (see :mod:`bhr._run.driver`); returns whether codes are
        valid."""
        r = self.robot
        c = chain.copy()
        follow_constrained_kernel(path, dirs, c.points, np.ascontiguousarray(c.axes[0]),
                                  np.ascontiguousarray(c.axes[1]), float(r.module_length), float(r.feed),
                                  int(r.feed_divisor), float(r.tol_pos), float(r.tol_ori), float(r.alpha),
                                  int(r.max_iter), LIMITS[self.limit], self.axes == "local", int(self.warmup),
                                  out_points, out_iters, pe, oe, codes)
        return self.returns_codes


register(ConstrainedFabrik)


@register
class Thesis(ConstrainedFabrik):
    """The thesis's full algorithm: binary actuators, local axes, 10 warm-up iterations.

    Registered as ``thesis``; ``seed`` is an older name for it, still accepted.
    """

    name = "thesis"
    aliases = ("seed",)
    summary = "the thesis's constrained FABRIK: binary tilts about local axes, returns codes"
