"""Module frames: a frame tilted by alpha about a local axis, and forward kinematics from codes.

A module's frame has rows x, y, z (z along the module). The code table
(:mod:`bhr._kinematics.codetable`, thesis Table 4.2) turns the next module by
alpha about its own +x (code 3), +y (6), -x (12) or -y (9); 0 keeps the frame
and 15 keeps it and lengthens the module by the lift. :func:`tilt_frame` is
the one tilt every kernel uses; :func:`fk_kernel` chains it along the robot.
:func:`tilt_reference` and :func:`fk_reference` are the same maths in numpy (a
rotation matrix about the axis, Rodrigues), which the tests hold them equal to.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from bhr._kinematics.codetable import CODE_AXIS, LIFT_OF, SEARCH_INDEX

__all__ = ["tilt_frame", "tilt_frame_at", "tilt_column", "fk_kernel", "tilt_reference", "fk_reference", "TILT_AXES"]

#: Code -> (local axis index 0 = x, 1 = y; sign) of the tilt it makes; 0 and 15 do not tilt.
TILT_AXES: dict[int, tuple[int, float]] = {code: (axis, float(sign)) for code, (axis, sign) in CODE_AXIS.items()}


@njit(cache=True, inline="always")
def tilt_column(k: int, c: float, s: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    """Column ``(x, y, z)`` of a frame (rows x, y, z) after the tilt of search index ``k`` (see :func:`tilt_frame`)."""
    if k == 0:
        return x, y, z
    ss = s if k <= 2 else -s
    if k == 1 or k == 3:  # about x: y' = c y + s z, z' = c z - s y
        return x, c * y + ss * z, c * z - ss * y
    return c * x - ss * z, y, c * z + ss * x  # about y: z' = c z + s x, x' = c x - s z


@njit(cache=True)
def tilt_frame(F: np.ndarray, k: int, c: float, s: float, out: np.ndarray) -> None:
    """Frame ``F`` (rows x, y, z) tilted by alpha about its own +x, +y, -x, -y (k = 1..4) into ``out``.

    ``c``, ``s`` are cos and sin of alpha; ``k = 0`` copies the frame. The
    search index order (rest, +x, +y, -x, -y) is codes 0, 3, 6, 12, 9.
    """
    for b in range(3):
        out[0, b], out[1, b], out[2, b] = tilt_column(k, c, s, F[0, b], F[1, b], F[2, b])


@njit(cache=True, inline="always")
def tilt_frame_at(frames: np.ndarray, i: int, k: int, c: float, s: float, j: int) -> None:
    """:func:`tilt_frame` of ``frames[i]`` into ``frames[j]`` (frames of shape (m, 3, 3)), indexing the stack
    itself: no array views are made, which a compiled search calling it at every node would pay for."""
    for b in range(3):
        frames[j, 0, b], frames[j, 1, b], frames[j, 2, b] = tilt_column(k, c, s, frames[i, 0, b], frames[i, 1, b],
                                                                        frames[i, 2, b])


@njit(cache=True)
def fk_kernel(codes: np.ndarray, base: np.ndarray, frame: np.ndarray, length: float, lift: float,
               alpha_deg: float, points: np.ndarray, frames: np.ndarray) -> None:
    """Chain points and module frames from codes (see :func:`bhr.model._robot.forward_kinematics`).

    Module ``i``'s frame is module ``i-1``'s (``frame`` for the first) tilted
    by :func:`tilt_frame` as its code says; the module runs from point ``i``
    along that frame's z, longer by ``lift`` for the lift code.
    """
    # element loops only: numba's array-slice assignment and array arithmetic
    # compile its string formatting, which made this kernel's first compile
    # take ten seconds
    n = codes.shape[0]
    a = math.radians(alpha_deg)
    c, s = math.cos(a), math.sin(a)
    F = np.empty((3, 3))
    for r in range(3):
        for b in range(3):
            F[r, b] = frame[r, b]
        points[0, r] = base[r]
    for i in range(n):
        code = codes[i]
        tilt_frame(F, SEARCH_INDEX[code], c, s, frames[i])
        for r in range(3):
            for b in range(3):
                F[r, b] = frames[i, r, b]
        step = length + lift * LIFT_OF[code]
        for b in range(3):
            points[i + 1, b] = points[i, b] + step * F[2, b]


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about the unit ``axis`` by ``angle`` radians (Rodrigues)."""
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def tilt_reference(F: np.ndarray, k: int, alpha: float) -> np.ndarray:
    """numpy reference of :func:`tilt_frame` (``alpha`` in radians; k = 0 rest, 1..4 = +x, +y, -x, -y)."""
    if k == 0:
        return F.copy()
    axis = F[(k - 1) % 2] * (1.0 if k <= 2 else -1.0)
    return F @ _rotation(axis, alpha).T


def fk_reference(codes: np.ndarray, base: np.ndarray, frame: np.ndarray, length: float, lift: float,
                 alpha_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """numpy reference of :func:`fk_kernel`: (points (n+1, 3), frames (n, 3, 3))."""
    n = len(codes)
    points = np.empty((n + 1, 3))
    frames = np.empty((n, 3, 3))
    F = np.asarray(frame, dtype=np.float64).copy()
    points[0] = base
    for i, code in enumerate(codes):
        if int(code) in TILT_AXES:
            idx, sign = TILT_AXES[int(code)]
            F = F @ _rotation(F[idx] * sign, math.radians(alpha_deg)).T
        frames[i] = F
        points[i + 1] = points[i] + (length + (lift if code == 15 else 0.0)) * F[2]
    return points, frames
