"""Follow-the-leader kernels: advance the robot, score one step (thesis ch. 7, appendix 1).

After each solve the whole robot advances by the feed along its base module's
direction; module 1 keeps its local axes and the axes of modules 2..n are
reset to those of a straight robot along that direction
(:func:`advance_kernel`). Point ``j`` (0 = base, n = tip) is scored against
the trajectory point ``(n - j) f`` steps behind the current one (0 before that
exists), ``f`` the feed divisor; module ``j < n-1`` against the path direction
there, the tip module against the wanted tip direction (:func:`score_step`).
:func:`finish_step` is what every compiled follow-the-leader loop does after
its solver's step: record the chain, iterations and codes, score, advance.

:func:`advance_reference` and :func:`score_reference` are the same maths in
numpy, written to be read; the tests hold the kernels equal to them.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["score_step", "advance_kernel", "finish_step", "acos_deg", "angle_deg", "tip_angle",
           "score_reference", "advance_reference"]


@njit(cache=True, inline="always")
def acos_deg(c: float) -> float:
    """The angle in degrees whose cosine is ``c``, clamped to [-1, 1] (rounding can leave a cosine just outside)."""
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


@njit(cache=True, inline="always")
def angle_deg(ax: float, ay: float, az: float, d: np.ndarray) -> float:
    """The angle in degrees between the vector ``(ax, ay, az)`` and ``d`` (neither need be a unit vector)."""
    na = math.sqrt(ax * ax + ay * ay + az * az)
    nd = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    return acos_deg((ax * d[0] + ay * d[1] + az * d[2]) / (na * nd))


@njit(cache=True)
def tip_angle(P: np.ndarray, d: np.ndarray) -> float:
    """The tip's orientation error: the angle in degrees between the last module of chain ``P`` and ``d``."""
    n = P.shape[0] - 1
    return angle_deg(P[n, 0] - P[n - 1, 0], P[n, 1] - P[n - 1, 1], P[n, 2] - P[n - 1, 2], d)


@njit(cache=True, inline="always")
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
            oe[j] = angle_deg(P[j + 1, 0] - P[j, 0], P[j + 1, 1] - P[j, 1], P[j + 1, 2] - P[j, 2], dirs[idx])


@njit(cache=True, inline="always")
def _reset_axes(P: np.ndarray, E: np.ndarray, obx: float, oby: float, obz: float, length: float) -> None:
    dx, dy, dz = E[0, 0] - P[0, 0], E[0, 1] - P[0, 1], E[0, 2] - P[0, 2]
    nd = math.sqrt(dx * dx + dy * dy + dz * dz)
    dx, dy, dz = dx / nd, dy / nd, dz / nd
    for j in range(1, P.shape[0] - 1):
        E[j, 0] = P[0, 0] + obx * length * j + dx
        E[j, 1] = P[0, 1] + oby * length * j + dy
        E[j, 2] = P[0, 2] + obz * length * j + dz


@njit(cache=True, inline="always")
def advance_kernel(P: np.ndarray, E1: np.ndarray, E2: np.ndarray, feed: float, length: float) -> None:
    """Advance by ``feed`` along the base module; reset the axes of modules 2..n (in place).

    Scalars only (no temporary arrays): a smaller first compile.
    """
    n = P.shape[0] - 1
    ox, oy, oz = P[1, 0] - P[0, 0], P[1, 1] - P[0, 1], P[1, 2] - P[0, 2]
    no = math.sqrt(ox * ox + oy * oy + oz * oz)
    obx, oby, obz = ox / no, oy / no, oz / no
    for j in range(n + 1):
        P[j, 0] = P[j, 0] + feed * obx
        P[j, 1] = P[j, 1] + feed * oby
        P[j, 2] = P[j, 2] + feed * obz
    for j in range(E1.shape[0]):
        E1[j, 0] = E1[j, 0] + feed * obx
        E1[j, 1] = E1[j, 1] + feed * oby
        E1[j, 2] = E1[j, 2] + feed * obz
        E2[j, 0] = E2[j, 0] + feed * obx
        E2[j, 1] = E2[j, 1] + feed * oby
        E2[j, 2] = E2[j, 2] + feed * obz
    _reset_axes(P, E1, obx, oby, obz, length)
    _reset_axes(P, E2, obx, oby, obz, length)


@njit(cache=True, inline="always")
def finish_step(i: int, P: np.ndarray, E1: np.ndarray, E2: np.ndarray, path: np.ndarray, dirs: np.ndarray, f: int,
                feed: float, length: float, tip_ori: float, iterations: int, step_codes: np.ndarray,
                out_points: np.ndarray, out_iters: np.ndarray, pe: np.ndarray, oe: np.ndarray,
                codes: np.ndarray) -> None:
    """End step ``i`` of a compiled follow-the-leader run, after the solver moved the chain ``P``.

    Records the chain, the iterations and the step's codes in row ``i`` of the
    run's arrays, scores the step (:func:`score_step`, ``tip_ori`` the tip
    module's orientation error in degrees) and advances the robot
    (:func:`advance_kernel`): the same as the driver's step-by-step loop.
    """
    n = P.shape[0] - 1
    # element loops, not slice assignment: numba's broadcasting path compiles
    # string formatting that doubles the first run's compile time
    for j in range(n + 1):
        for c in range(3):
            out_points[i, j, c] = P[j, c]
    out_iters[i] = iterations
    for j in range(n):
        codes[i, j] = step_codes[j]
    score_step(i, P, path, dirs, f, tip_ori, pe[i], oe[i])
    advance_kernel(P, E1, E2, feed, length)


def score_reference(i: int, P: np.ndarray, path: np.ndarray, dirs: np.ndarray, f: int,
                    tip_ori: float) -> tuple[np.ndarray, np.ndarray]:
    """numpy reference of :func:`score_step`: (point errors (n+1), module errors (n))."""
    n = P.shape[0] - 1
    idx = i - (n - np.arange(n + 1)) * f
    pe = np.where(idx >= 0, np.linalg.norm(P - path[np.maximum(idx, 0)], axis=1), 0.0)
    oe = np.zeros(n)
    oe[n - 1] = tip_ori
    for j in range(n - 1):
        if idx[j] >= 0:
            a = P[j + 1] - P[j]
            d = dirs[idx[j]]
            c = np.dot(a, d) / (np.linalg.norm(a) * np.linalg.norm(d))
            oe[j] = math.degrees(math.acos(np.clip(c, -1.0, 1.0)))
    return pe, oe


def advance_reference(P: np.ndarray, E1: np.ndarray, E2: np.ndarray, feed: float,
                      length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """numpy reference of :func:`advance_kernel`: new (points, axis-1 points, axis-2 points)."""
    n = P.shape[0] - 1
    ob = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
    P2, out = P + feed * ob, []
    for E in (E1, E2):
        E = E + feed * ob
        d = (E[0] - P2[0]) / np.linalg.norm(E[0] - P2[0])
        j = np.arange(1, n)[:, None]
        E[1:n] = P2[0] + ob * length * j + d
        out.append(E)
    return P2, out[0], out[1]


@njit(cache=True)
def _sorts_before(a: float, b: float) -> bool:
    """numba's order of floats when sorting: ascending, NaN last (``numba.np.numpy_support.lt_floats``)."""
    return a < b or (b != b and a == a)


@njit(cache=True)
def stable_argsort(keys: np.ndarray, m: int) -> np.ndarray:
    """The indices that sort ``keys[:m]``, equal keys in index order: ``np.argsort(keys[:m], kind="mergesort")``.

    A bottom-up merge sort, so the permutation is the one stable order, the
    same as numpy's and numba's mergesort. Written out because numba's own
    ``argsort`` compiles its generic recursive mergesort (about 1.6 s of CPU
    on the first run) for each kernel that calls it.
    """
    order = np.empty(m, dtype=np.int64)
    spare = np.empty(m, dtype=np.int64)
    for i in range(m):
        order[i] = i
    width = 1
    while width < m:
        lo = 0
        while lo < m:
            mid = min(lo + width, m)
            hi = min(lo + 2 * width, m)
            i = lo
            j = mid
            o = lo
            while i < mid and j < hi:
                if _sorts_before(keys[order[j]], keys[order[i]]):  # the right run's only when strictly first
                    spare[o] = order[j]
                    j += 1
                else:
                    spare[o] = order[i]
                    i += 1
                o += 1
            while i < mid:
                spare[o] = order[i]
                i += 1
                o += 1
            while j < hi:
                spare[o] = order[j]
                j += 1
                o += 1
            lo = hi
        order, spare = spare, order
        width *= 2
    return order
