"""Dual quaternions: the thesis's worked examples, algebra, the kernels equal to the numpy-quaternion reference,
and the reference equal to an independent library (pytransform3d)."""
import math

import numpy as np
import pytransform3d.rotations as pr
import pytransform3d.transformations as pt
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr._kinematics.dualquat import k_dq_mul, k_qmul, k_rotate, k_rotate_about
from tests.dualquat_reference import (
    dq_conj_both,
    dq_conj_dual,
    dq_conj_quat,
    dq_from_point,
    dq_from_rotation,
    dq_from_translation,
    dq_inverse,
    dq_is_unit,
    dq_mul,
    dq_norm,
    dq_transform_point,
)

A = np.array([1.0, 0.0, 1.0])


def test_rotation_example_ec_3_22_to_3_28():
    q = dq_from_rotation([-1, 0, 0], math.pi)
    np.testing.assert_allclose(dq_transform_point(q, A), [1, 0, -1], atol=1e-12)


def test_pure_translation_example_ec_3_45_to_3_53():
    q = dq_from_translation([1, 0, 1])
    np.testing.assert_allclose(dq_transform_point(q, A), [2, 0, 2], atol=1e-12)


def test_rotation_then_translation_ec_3_54_to_3_59():
    q = dq_mul(dq_from_translation([1, 0, 1]), dq_from_rotation([1, 0, 0], math.pi))  # d * r
    np.testing.assert_allclose(q, [0, 1, 0, 0, -0.5, 0, 0.5, 0], atol=1e-12)  # Ec. 3.55
    np.testing.assert_allclose(dq_transform_point(q, A), [2, 0, 0], atol=1e-12)


def test_translation_then_rotation_ec_3_60_to_3_63():
    q = dq_mul(dq_from_rotation([1, 0, 0], math.pi), dq_from_translation([1, 0, 1]))  # r * d
    np.testing.assert_allclose(q, [0, 1, 0, 0, -0.5, 0, -0.5, 0], atol=1e-12)  # Ec. 3.60
    # Ec. 3.61 prints -i - 1/2 eps - 1/2 j eps; a* - b* eps with b = -1/2 - 1/2 j is -i + (1/2 - 1/2 j) eps
    np.testing.assert_allclose(dq_conj_both(q), [0, -1, 0, 0, 0.5, 0, -0.5, 0], atol=1e-12)
    np.testing.assert_allclose(dq_transform_point(q, A), [2, 0, -2], atol=1e-12)


def test_conjugates_and_norm():
    q = np.array([1.0, 2, 3, 4, 5, 6, 7, 8])
    np.testing.assert_array_equal(dq_conj_quat(q), [1, -2, -3, -4, 5, -6, -7, -8])
    np.testing.assert_array_equal(dq_conj_dual(q), [1, 2, 3, 4, -5, -6, -7, -8])
    np.testing.assert_array_equal(dq_conj_both(q), [1, -2, -3, -4, -5, 6, 7, 8])
    real, dual = dq_norm(q)
    assert real == math.sqrt(30)
    assert dual == (5 + 12 + 21 + 32) / math.sqrt(30)


finite = st.floats(-10, 10, allow_nan=False)
vec3 = st.tuples(finite, finite, finite).map(np.array)
dq8 = st.lists(finite, min_size=8, max_size=8).map(np.array)


def unit_motion(axis, angle, d):
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([0.0, 0.0, 1.0])
    return dq_mul(dq_from_translation(d), dq_from_rotation(axis, angle))


@settings(max_examples=200, deadline=None)
@given(dq8, dq8)
def test_kernel_product_equals_numpy_quaternion(p, q):
    out = np.empty(8)
    k_dq_mul(p, q, out)
    np.testing.assert_allclose(out, dq_mul(p, q), rtol=1e-12, atol=1e-9)
    qo = np.empty(4)
    k_qmul(p[:4], q[:4], qo)
    np.testing.assert_allclose(qo, dq_mul(p, q)[:4], rtol=1e-12, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(vec3, st.floats(-7, 7), vec3, vec3)
def test_unit_motion_properties(axis, angle, d, p):
    q = unit_motion(axis, angle, d)
    assert dq_is_unit(q)
    # inverse undoes the motion, and q q^-1 = 1
    np.testing.assert_allclose(dq_mul(q, dq_inverse(q)), [1, 0, 0, 0, 0, 0, 0, 0], atol=1e-9)
    moved = dq_transform_point(q, p)
    np.testing.assert_allclose(dq_transform_point(dq_inverse(q), moved), p, atol=1e-8)
    # a rigid motion keeps distances
    np.testing.assert_allclose(np.linalg.norm(moved - dq_transform_point(q, np.zeros(3))), np.linalg.norm(p),
                               atol=1e-8)


@settings(max_examples=200, deadline=None)
@given(vec3, st.floats(-360, 360), vec3)
def test_rotation_kernel_equals_python_path(axis, angle_deg, v):
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([1.0, 0.0, 0.0])
    a = axis / np.linalg.norm(axis)
    expect = dq_transform_point(dq_from_rotation(a, math.radians(angle_deg)), v)
    out = np.empty(3)
    k_rotate_about(v, angle_deg, a, out)
    np.testing.assert_allclose(out, expect, atol=1e-9)
    h = math.radians(angle_deg) / 2
    np.testing.assert_allclose(k_rotate(v[0], v[1], v[2], math.cos(h), math.sin(h), *a), expect, atol=1e-9)


def test_point_round_trip():
    np.testing.assert_array_equal(dq_from_point([1, 2, 3]), [1, 0, 0, 0, 0, 1, 2, 3])
    assert not dq_is_unit(np.array([2.0, 0, 0, 0, 0, 0, 0, 0]))


@settings(max_examples=200, deadline=None)
@given(vec3, st.floats(-7, 7), vec3, vec3, st.floats(-7, 7), vec3, vec3)
def test_reference_equals_pytransform3d(axis, angle, d, p, angle2, axis2, d2):
    """The reference's motions, products, conjugates and moved points equal pytransform3d's (same layout:
    real part w, x, y, z then dual part)."""
    q = unit_motion(axis, angle, d)
    a = axis / np.linalg.norm(axis) if np.linalg.norm(axis) >= 1e-3 else np.array([0.0, 0.0, 1.0])
    theirs = pt.dual_quaternion_from_pq(np.concatenate([d, pr.quaternion_from_axis_angle(np.concatenate([a, [angle]]))]))
    # a dual quaternion and its negative are the same motion
    sign = 1.0 if np.dot(q[:4], theirs[:4]) >= 0 else -1.0
    np.testing.assert_allclose(q, sign * theirs, atol=1e-9)
    np.testing.assert_allclose(dq_transform_point(q, p), pt.dq_prod_vector(theirs, p), atol=1e-8)
    np.testing.assert_allclose(dq_conj_both(q), pt.dq_conj(q), atol=1e-12)
    np.testing.assert_allclose(dq_conj_quat(q), pt.dq_q_conj(q), atol=1e-12)
    r = unit_motion(axis2, angle2, d2)
    np.testing.assert_allclose(dq_mul(q, r), pt.concatenate_dual_quaternions(q, r), atol=1e-8)
