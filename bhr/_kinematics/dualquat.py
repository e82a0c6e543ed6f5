"""Dual quaternions for rigid motions (thesis ch. 3, Ec. 3.31-3.44).

A dual quaternion ``q = a + b*eps`` (``eps**2 = 0``) is stored as eight float64
numbers ``[a_w, a_x, a_y, a_z, b_w, b_x, b_y, b_z]``. A unit dual quaternion
(|a| = 1, a.b = 0) is a rigid motion; a point ``p`` is the dual quaternion
``1 + eps*p`` and moves as ``q (1 + eps p) conj_both(q)`` (Ec. 3.44).

The numba kernels here (``k_*``, compiled with ``cache=True``) work over
plain float64 values in the solvers' hot loops. The tests hold them equal to
a readable reference of the same maths (``tests/dualquat_reference.py``,
on numpy-quaternion), which is itself checked against an independent library
(pytransform3d).

Examples (thesis ch. 3): A = (1, 0, 1) rotated 180 deg about -x gives
(1, 0, -1); translated by (1, 0, 1) gives (2, 0, 2); rotated 180 deg about x
then translated gives (2, 0, 0); translated then rotated gives (2, 0, -2).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "k_qmul",
    "k_dq_mul",
    "k_rotate",
    "k_rotate_about",
]


# ---------------------------------------------------------------------------
# numba kernels


@njit(cache=True)
def k_qmul(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Hamilton product of two quaternions (w, x, y, z) into ``out``."""
    w1, x1, y1, z1 = a[0], a[1], a[2], a[3]
    w2, x2, y2, z2 = b[0], b[1], b[2], b[3]
    out[0] = w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2
    out[1] = w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2
    out[2] = w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2
    out[3] = w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2


@njit(cache=True)
def k_dq_mul(p: np.ndarray, q: np.ndarray, out: np.ndarray) -> None:
    """Dual quaternion product ``p q`` into ``out`` (8 values)."""
    t1 = np.empty(4)
    t2 = np.empty(4)
    k_qmul(p[:4], q[:4], out[:4])
    k_qmul(p[:4], q[4:], t1)
    k_qmul(p[4:], q[:4], t2)
    for i in range(4):
        out[4 + i] = t1[i] + t2[i]


@njit(cache=True)
def k_rotate(vx: float, vy: float, vz: float, c: float, s: float, ax: float, ay: float, az: float):
    """Rotate vector v by the rotation dual quaternion ``(c, s*a) + 0 eps``.

    Computes ``r (1 + v eps) conj_both(r)`` term by term, as Ec. 6.8 does,
    with ``c = cos(theta/2)``, ``s = sin(theta/2)`` and unit axis ``a``.
    Returns the rotated vector as three floats.
    """
    rw, rx, ry, rz = c, s * ax, s * ay, s * az
    # t = r * (0, v)
    tw = -rx * vx - ry * vy - rz * vz
    tx = rw * vx + ry * vz - rz * vy
    ty = rw * vy - rx * vz + rz * vx
    tz = rw * vz + rx * vy - ry * vx
    # t * r^*  with r^* = (rw, -rx, -ry, -rz)
    ox = -tw * rx + tx * rw - ty * rz + tz * ry
    oy = -tw * ry + tx * rz + ty * rw - tz * rx
    oz = -tw * rz - tx * ry + ty * rx + tz * rw
    return ox, oy, oz


@njit(cache=True)
def k_rotate_about(v: np.ndarray, angle_deg: float, axis: np.ndarray, out: np.ndarray) -> None:
    """Rotate ``v`` by ``angle_deg`` about unit ``axis`` (through the origin) into ``out``."""
    h = math.radians(angle_deg) / 2.0
    ox, oy, oz = k_rotate(v[0], v[1], v[2], math.cos(h), math.sin(h), axis[0], axis[1], axis[2])
    out[0] = ox
    out[1] = oy
    out[2] = oz
