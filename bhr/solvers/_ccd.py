"""CCD, Cyclic Coordinate Descent (thesis ch. 5.1.2).

One iteration is one sweep from the joint nearest the tip down to the base.
Each joint rotates the sub-chain beyond it by the angle between joint-to-tip
and joint-to-target (Ec. 5.1) about their normal (Ec. 5.2), using the dual
quaternion rotation kernel. The error is checked after each sweep. CCD cannot
aim the tip, so it refuses a wanted orientation.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from bhr._kinematics.dualquat import k_rotate
from bhr._settings.errors import BhrError
from bhr.solvers._base import Chain, FollowContext, SolveResult, Solver, register
from bhr.solvers._fabrik import point_distance


# Below this norm the squares of a vector's components may be subnormal or
# zero, so sqrt(x*x + y*y + z*z) loses digits (a target 1e-161 from a joint gave
# a rotation axis of norm 1.0148 and stretched the link behind it).
_TINY = 1e-150


@njit(cache=True)
def _unit3(x: float, y: float, z: float):
    """(x, y, z) / |(x, y, z)| and the norm; vectors in the underflow range are scaled first."""
    nv = math.sqrt(x * x + y * y + z * z)
    if nv < _TINY:
        m = max(abs(x), abs(y), abs(z))
        if m == 0.0:
            return 0.0, 0.0, 0.0, 0.0
        x, y, z = x / m, y / m, z / m
        s = math.sqrt(x * x + y * y + z * z)
        return x / s, y / s, z / s, m * s
    return x / nv, y / nv, z / nv, nv


@njit(cache=True)
def ccd_kernel(P: np.ndarray, target: np.ndarray, tol: float, max_iter: int):
    """CCD on ``P`` (modified in place). Returns (iterations, error)."""
    n = P.shape[0] - 1
    err = point_distance(P, n, target)
    k = 0
    while err > tol and k < max_iter:
        for j in range(n - 1, -1, -1):
            ex, ey, ez = P[n, 0] - P[j, 0], P[n, 1] - P[j, 1], P[n, 2] - P[j, 2]
            tx, ty, tz = target[0] - P[j, 0], target[1] - P[j, 1], target[2] - P[j, 2]
            ne = math.sqrt(ex * ex + ey * ey + ez * ez)
            nt = math.sqrt(tx * tx + ty * ty + tz * tz)
            if ne < _TINY or nt < _TINY:
                # tiny vectors: work with their directions (the angle and the
                # axis depend on nothing else)
                ex, ey, ez, ne = _unit3(ex, ey, ez)
                tx, ty, tz, nt = _unit3(tx, ty, tz)
                if ne == 0.0 or nt == 0.0:
                    continue
                ne, nt = 1.0, 1.0
            c = (ex * tx + ey * ty + ez * tz) / (ne * nt)
            theta = math.acos(max(-1.0, min(1.0, c)))
            rx, ry, rz = ey * tz - ez * ty, ez * tx - ex * tz, ex * ty - ey * tx
            nr = math.sqrt(rx * rx + ry * ry + rz * rz)
            if nr < _TINY:
                rx, ry, rz, nr = _unit3(rx, ry, rz)
                if nr == 0.0:
                    continue
            else:
                rx, ry, rz = rx / nr, ry / nr, rz / nr
            ch, sh = math.cos(theta / 2.0), math.sin(theta / 2.0)
            for m in range(j + 1, n + 1):
                vx, vy, vz = k_rotate(P[m, 0] - P[j, 0], P[m, 1] - P[j, 1], P[m, 2] - P[j, 2], ch, sh, rx, ry, rz)
                P[m, 0], P[m, 1], P[m, 2] = P[j, 0] + vx, P[j, 1] + vy, P[j, 2] + vz
        err = point_distance(P, n, target)
        k += 1
    return k, err


@register
class CCD(Solver):
    """Cyclic Coordinate Descent, tip to base (thesis ch. 5.1.2); no codes."""

    name = "ccd"
    summary = "cyclic coordinate descent, tip to base (thesis ch. 5); position only"
    accepts_orientation = False

    def solve(self, chain: Chain, target: np.ndarray, tip_direction: np.ndarray | None = None,
              context: FollowContext | None = None) -> SolveResult:
        if tip_direction is not None:
            raise BhrError("the ccd solver cannot aim the tip; drop --orientation or use --solver fabrik or thesis")
        r = self.robot
        out = chain.copy()
        k, err = ccd_kernel(out.points, np.asarray(target, dtype=np.float64), float(r.tol_pos), int(r.max_iter))
        return SolveResult(out, int(k), float(err), None)
