"""A readable reference of bhr's dual-quaternion kernels (thesis ch. 3, Ec. 3.31-3.44), on numpy-quaternion.

A dual quaternion ``q = a + b*eps`` is eight numbers ``[a_w, a_x, a_y, a_z,
b_w, b_x, b_y, b_z]``. tests/unit/test_dualquat.py holds the kernels of
:mod:`bhr._kinematics.dualquat` equal to these functions, and these functions
equal to pytransform3d's.
"""
from __future__ import annotations

import math

import numpy as np
import quaternion


def _split(q: np.ndarray):
    q = np.asarray(q, dtype=np.float64)
    if q.shape != (8,):
        raise ValueError(f"a dual quaternion has 8 components, got shape {q.shape}")
    return quaternion.from_float_array(q[:4]), quaternion.from_float_array(q[4:])


def _join(a, b) -> np.ndarray:
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
