"""The compiled kinematics kernels equal their numpy references (bhr._kinematics)."""
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr._kinematics.frames import fk_kernel, fk_reference, tilt_frame, tilt_frame_at, tilt_reference
from bhr._kinematics.leader import advance_kernel, advance_reference, score_reference, score_step
from bhr.model._generators import load_trajectory
from bhr.model._robot import Robot, base_frame, forward_kinematics
from bhr._run.driver import follow

seeds = st.integers(min_value=0, max_value=2**32 - 1)


@settings(max_examples=40, deadline=None)
@given(seeds, st.integers(min_value=0, max_value=4), st.floats(min_value=0.5, max_value=80.0))
def test_tilt_frame_equals_reference(seed, k, alpha_deg):
    rng = np.random.default_rng(seed)
    F = base_frame(rng.normal(size=3))
    out = np.empty((3, 3))
    a = math.radians(alpha_deg)
    tilt_frame(F, k, math.cos(a), math.sin(a), out)
    np.testing.assert_allclose(out, tilt_reference(F, k, a), atol=1e-12)
    if k:  # a real tilt turns z by alpha
        assert abs(math.degrees(math.acos(np.clip(out[2] @ F[2], -1, 1))) - alpha_deg) < 1e-6


@settings(max_examples=40, deadline=None)
@given(seeds, st.integers(min_value=0, max_value=4), st.floats(min_value=0.5, max_value=80.0),
       st.integers(min_value=0, max_value=3), st.integers(min_value=0, max_value=3))
def test_tilt_frame_at_is_tilt_frame_within_a_stack(seed, k, alpha_deg, i, j):
    """The searches tilt frames inside a stack of frames (no views made); the same numbers to the last bit."""
    rng = np.random.default_rng(seed)
    stack = np.stack([base_frame(rng.normal(size=3)) for _ in range(4)])
    a = math.radians(alpha_deg)
    want = np.empty((3, 3))
    tilt_frame(stack[i].copy(), k, math.cos(a), math.sin(a), want)
    got = stack.copy()
    tilt_frame_at(got, i, k, math.cos(a), math.sin(a), j)
    assert np.array_equal(got[j], want)
    assert all(np.array_equal(got[m], stack[m]) for m in range(4) if m != j)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.sampled_from([0, 3, 6, 12, 9, 15]), min_size=1, max_size=12), st.floats(1.0, 30.0), seeds)
def test_fk_kernel_equals_reference(codes, alpha, seed):
    rng = np.random.default_rng(seed)
    c = np.asarray(codes, dtype=np.int64)
    base = rng.normal(size=3)
    frame = base_frame(rng.normal(size=3))
    pts, frs = np.empty((len(c) + 1, 3)), np.empty((len(c), 3, 3))
    fk_kernel(c, base, frame, 10.0, 1.5, alpha, pts, frs)
    rp, rf = fk_reference(c, base, frame, 10.0, 1.5, alpha)
    np.testing.assert_allclose(pts, rp, atol=1e-9)
    np.testing.assert_allclose(frs, rf, atol=1e-12)


def test_robot_fk_uses_the_kernel():
    r = Robot(modules=4)
    pts, frs = forward_kinematics(r, [3, 0, 9, 15])
    rp, rf = fk_reference(np.array([3, 0, 9, 15]), np.zeros(3), base_frame((1, 0, 0)), r.module_length, r.lift,
                          r.alpha)
    np.testing.assert_allclose(pts, rp, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(seeds, st.integers(min_value=2, max_value=8), st.floats(0.1, 5.0))
def test_advance_kernel_equals_reference(seed, n, feed):
    rng = np.random.default_rng(seed)
    P = np.cumsum(rng.normal(size=(n + 1, 3)), axis=0)
    E1 = P[:-1] + rng.normal(size=(n, 3))
    E2 = P[:-1] + rng.normal(size=(n, 3))
    rP, rE1, rE2 = advance_reference(P, E1, E2, feed, 10.0)
    advance_kernel(P, E1, E2, feed, 10.0)
    np.testing.assert_allclose(P, rP, atol=1e-12)
    np.testing.assert_allclose(E1, rE1, atol=1e-12)
    np.testing.assert_allclose(E2, rE2, atol=1e-12)


def test_score_step_equals_reference_along_a_run():
    tr = load_trajectory("curve", radius=70, angle=90)
    res = follow(tr, solver="thesis")
    path = tr.points
    dirs = np.diff(path, axis=0)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    f = res.robot.feed_divisor
    for i in range(res.steps):
        pe, oe = np.empty(res.modules + 1), np.empty(res.modules)
        tip = float(res.orientation_errors_deg[i, -1])
        score_step(i, res.points[i], path, dirs, f, tip, pe, oe)
        rpe, roe = score_reference(i, res.points[i], path, dirs, f, tip)
        np.testing.assert_allclose(pe, rpe, atol=1e-9)
        np.testing.assert_allclose(oe, roe, atol=1e-9)
        np.testing.assert_allclose(pe, res.point_errors_mm[i], atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(seeds, st.integers(min_value=2, max_value=40), st.floats(min_value=-3.0, max_value=3.0),
       st.booleans(), st.booleans())
def test_polyline_spacing_and_tangents_equal_numpy_to_the_bit(seed, m, scale, walk, repeat):
    """The compiled median spacing and unit tangents are numpy's expressions, bit for bit (a path's spacing decides
    its feed check, its tube and the bends it is judged over): odd and even counts, repeated points, any scale."""
    from bhr._kinematics.polyline import median_spacing, unit_tangents

    rng = np.random.default_rng(seed)
    P = rng.normal(size=(m, 3)) * 10.0 ** scale
    if walk:
        P = np.cumsum(P, axis=0)
    if repeat:
        P[rng.integers(0, m)] = P[0]
    assert median_spacing(P) == float(np.median(np.linalg.norm(np.diff(P, axis=0), axis=1)))
    ref = np.empty_like(P)
    ref[1:-1] = P[2:] - P[:-2]
    ref[0], ref[-1] = P[1] - P[0], P[-1] - P[-2]
    ref /= np.maximum(np.linalg.norm(ref, axis=1), 1e-300)[:, None]
    out = np.empty((m, 3))
    unit_tangents(P, out)
    assert np.array_equal(out, ref)
    P[rng.integers(0, m)] = np.nan
    assert math.isnan(median_spacing(P))
