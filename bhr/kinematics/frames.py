"""Module frames: a frame tilted by alpha about a local axis, and forward kinematics from codes.

A module's frame has rows x, y, z (z along the module). The code table
(:mod:`bhr.codes`, thesis Table 4.2) turns the next module by alpha about its
own +x (code 3), +y (6), -x (12) or -y (9); 0 keeps the frame and 15 keeps it
and lengthens the module by the lift. :func:`tilt_frame` and
:func:`fk_kernel` are the compiled kernels; :func:`tilt_reference` and
:func:`fk_reference` the same maths in numpy (a rotation matrix about the
axis), which the tests hold them equal to.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from bhr.kinematics.dualquat import k_rotate

__all__ = ["tilt_frame", "fk_kernel", "tilt_reference", "fk_reference", "TILT_AXES"]

#: Code -> (local axis index 0 = x, 1 = y; sign) of the tilt it makes; 0 and 15 do not tilt.
TILT_AXES: dict[int, tuple[int, float]] = {3: (0, 1.0), 6: (1, 1.0), 12: (0, -1.0), 9: (1, -1.0)}


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
    """Chain points and module frames from codes (see :func:`bhr.robot.forward_kinematics`)."""
    # scalars and element loops only: numba's array-slice assignment and array
    # arithmetic compile its string formatting, which made this kernel's first
    # compile take ten seconds
    n = codes.shape[0]
    h = math.radians(alpha_deg) / 2.0
    c, s = math.cos(h), math.sin(h)
    fx0, fx1, fx2 = frame[0, 0], frame[0, 1], frame[0, 2]
    fy0, fy1, fy2 = frame[1, 0], frame[1, 1], frame[1, 2]
    fz0, fz1, fz2 = frame[2, 0], frame[2, 1], frame[2, 2]
    for k in range(3):
        points[0, k] = base[k]
    for i in range(n):
        code = codes[i]
        extra = 0.0
        axis_idx = -1
        sign = 1.0
        if code == 3:
            axis_idx = 0
        elif code == 6:
            axis_idx = 1
        elif code == 12:
            axis_idx = 0
            sign = -1.0
        elif code == 9:
            axis_idx = 1
            sign = -1.0
        elif code == 15:
            extra = lift
        if axis_idx >= 0:
            if axis_idx == 0:
                a0, a1, a2 = fx0 * sign, fx1 * sign, fx2 * sign
            else:
                a0, a1, a2 = fy0 * sign, fy1 * sign, fy2 * sign
            # rotate the three frame vectors about a (a is one of them, up to sign)
            x0, x1, x2 = k_rotate(fx0, fx1, fx2, c, s, a0, a1, a2)
            y0, y1, y2 = k_rotate(fy0, fy1, fy2, c, s, a0, a1, a2)
            z0, z1, z2 = k_rotate(fz0, fz1, fz2, c, s, a0, a1, a2)
            fx0, fx1, fx2 = x0, x1, x2
            fy0, fy1, fy2 = y0, y1, y2
            fz0, fz1, fz2 = z0, z1, z2
        frames[i, 0, 0], frames[i, 0, 1], frames[i, 0, 2] = fx0, fx1, fx2
        frames[i, 1, 0], frames[i, 1, 1], frames[i, 1, 2] = fy0, fy1, fy2
        frames[i, 2, 0], frames[i, 2, 1], frames[i, 2, 2] = fz0, fz1, fz2
        step = length + extra
        points[i + 1, 0] = points[i, 0] + step * fz0
        points[i + 1, 1] = points[i, 1] + step * fz1
        points[i + 1, 2] = points[i, 2] + step * fz2


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
