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

__all__ = ["tilt_frame", "fk_kernel", "tilt_reference", "fk_reference", "TILT_AXES"]

#: Code -> (local axis index 0 = x, 1 = y; sign) of the tilt it makes; 0 and 15 do not tilt.
TILT_AXES: dict[int, tuple[int, float]] = {code: (axis, float(sign)) for code, (axis, sign) in CODE_AXIS.items()}


@njit(cache=True)
def tilt_frame(F: np.ndarray, k: int, c: float, s: float, out: np.ndarray) -> None:
    """Frame ``F`` (rows x, y, z) tilted by alpha about its own +x, +y, -x, -y (k = 1..4) into ``out``.

    ``c``, ``s`` are cos and sin of alpha; ``k = 0`` copies the frame. The
    search index order (rest, +x, +y, -x, -y) is codes 0, 3, 6, 12, 9.
    """
    if k == 0:
        for a in range(3):
            for b in range(3):
                out[a, b] = F[a, b]
        return
    ss = s if k <= 2 else -s
    if k == 1 or k == 3:  # about x: y' = c y + s z, z' = c z - s y
        for b in range(3):
            x, y, z = F[0, b], F[1, b], F[2, b]
            out[0, b] = x
            out[1, b] = c * y + ss * z
            out[2, b] = c * z - ss * y
    else:  # about y: z' = c z + s x, x' = c x - s z
        for b in range(3):
            x, y, z = F[0, b], F[1, b], F[2, b]
            out[0, b] = c * x - ss * z
            out[1, b] = y
            out[2, b] = c * z + ss * x


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
