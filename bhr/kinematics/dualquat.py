"""Dual quaternions for rigid motions (thesis ch. 3, Ec. 3.31-3.44).

A dual quaternion ``q = a + b*eps`` (``eps**2 = 0``) is stored as eight float64
numbers ``[a_w, a_x, a_y, a_z, b_w, b_x, b_y, b_z]``. A unit dual quaternion
(|a| = 1, a.b = 0) is a rigid motion; a point ``p`` is the dual quaternion
``1 + eps*p`` and moves as ``q (1 + eps p) conj_both(q)`` (Ec. 3.44).

Two layers with the same maths:

* Python-level functions (``dq_mul``, ``dq_transform_point``, ...) built on
  numpy-quaternion, for clarity and for checking;
* numba kernels (``k_*``, compiled with ``cache=True``) over plain float64
  values, used in the solvers' hot loops. Tests check that both agree.

Examples (thesis ch. 3): A = (1, 0, 1) rotated 180 deg about -x gives
(1, 0, -1); translated by (1, 0, 1) gives (2, 0, 2); rotated 180 deg about x
then translated gives (2, 0, 0); translated then rotated gives (2, 0, -2).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "dq_mul",
    "dq_conj_quat",
    "dq_conj_dual",
    "dq_conj_both",
    "dq_norm",
    "dq_inverse",
    "dq_is_unit",
    "dq_from_rotation",
    "dq_from_translation",
    "dq_from_point",
    "dq_to_point",
    "dq_transform_point",
    "k_qmul",
    "k_dq_mul",
    "k_rotate",
    "k_rotate_about",
]


def _quaternion():
    """numpy-quaternion, imported on first use (it pulls in scipy, slow to load).

    Only these Python-level reference functions use it (the solvers run the
    ``k_*`` kernels), so it is installed with the test extras, not with bhr.
    """
    try:
        import quaternion
    except ModuleNotFoundError:
        raise ModuleNotFoundError("the dual-quaternion reference functions need numpy-quaternion; "
                                  "pip install numpy-quaternion (or bhr[test])") from None
    return quaternion


def _split(q: np.ndarray):
    quaternion = _quaternion()
    q = np.asarray(q, dtype=np.float64)
    if q.shape != (8,):
        raise ValueError(f"a dual quaternion has 8 components, got shape {q.shape}")
    return quaternion.from_float_array(q[:4]), quaternion.from_float_array(q[4:])


def _join(a, b) -> np.ndarray:
    quaternion = _quaternion()
    return np.concatenate([quaternion.as_float_array(a), quaternion.as_float_array(b)])


def dq_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Product ``p q = a a' + (a b' + b a') eps`` (Ec. 3.33)."""
    a, b = _split(p)
    c, d = _split(q)
    return _join(a * c, a * d + b * c)


def dq_conj_quat(q: np.ndarray) -> np.ndarray:
    """Quaternion conjugate ``a* + b* eps`` (Ec. 3.35)."""
    a, b = _split(q)
    return _join(a.conjugate(), b.conjugate())


def dq_conj_dual(q: np.ndarray) -> np.ndarray:
    """Dual conjugate ``a - b eps``."""
    a, b = _split(q)
    return _join(a, -b)


def dq_conj_both(q: np.ndarray) -> np.ndarray:
    """Both conjugates ``a* - b* eps`` (Ec. 3.36), used to move points."""
    a, b = _split(q)
    return _join(a.conjugate(), -b.conjugate())


def dq_norm(q: np.ndarray) -> tuple[float, float]:
    """Dual-number norm ``|a| + (a.b / |a|) eps`` (Ec. 3.34), as (real, dual)."""
    q = np.asarray(q, dtype=np.float64)
    na = float(np.linalg.norm(q[:4]))
    if na == 0.0:
        raise ValueError("the real part of the dual quaternion is zero; its norm has no dual part")
    return na, float(np.dot(q[:4], q[4:]) / na)


def dq_inverse(q: np.ndarray) -> np.ndarray:
    """Inverse ``a^-1 - a^-1 b a^-1 eps`` (equal to Ec. 3.37), defined for a != 0."""
    a, b = _split(q)
    if a.norm() == 0.0:
        raise ValueError("a dual quaternion with zero real part has no inverse")
    ai = a.inverse()
    return _join(ai, -(ai * b * ai))


def dq_is_unit(q: np.ndarray, tol: float = 1e-9) -> bool:
    """True when |a| = 1 and a.b = 0 within ``tol`` (Ec. 3.38)."""
    q = np.asarray(q, dtype=np.float64)
    return abs(float(np.dot(q[:4], q[:4])) - 1.0) <= tol and abs(float(np.dot(q[:4], q[4:]))) <= tol


def dq_from_rotation(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """Rotation by ``angle_rad`` about the unit ``axis`` through the origin (Ec. 3.40)."""
    axis = np.asarray(axis, dtype=np.float64)
    n = float(np.linalg.norm(axis))
    if n == 0.0:
        raise ValueError("rotation axis must not be the zero vector")
    s = math.sin(angle_rad / 2.0)
    return np.array([math.cos(angle_rad / 2.0), *(s * axis / n), 0.0, 0.0, 0.0, 0.0])


def dq_from_translation(d: np.ndarray) -> np.ndarray:
    """Translation by ``d`` (Ec. 3.41): ``1 + (d/2) eps``."""
    d = np.asarray(d, dtype=np.float64)
    return np.array([1.0, 0.0, 0.0, 0.0, 0.0, *(d / 2.0)])


def dq_from_point(p: np.ndarray) -> np.ndarray:
    """The dual quaternion of a point, ``1 + p eps`` (Ec. 3.39)."""
    p = np.asarray(p, dtype=np.float64)
    return np.array([1.0, 0.0, 0.0, 0.0, 0.0, *p])


def dq_to_point(q: np.ndarray) -> np.ndarray:
    """The point held in the dual vector part of ``1 + p eps``."""
    return np.asarray(q, dtype=np.float64)[5:8].copy()


def dq_transform_point(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Move point ``p`` by the unit dual quaternion ``q``: ``q (1 + p eps) conj_both(q)``."""
    return dq_to_point(dq_mul(dq_mul(q, dq_from_point(p)), dq_conj_both(q)))


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
