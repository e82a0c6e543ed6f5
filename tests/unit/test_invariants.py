"""Kinematic invariants under hypothesis: lengths kept, tilts in {0, alpha}, frames orthonormal, codes valid."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bhr.model._codes import VALID_CODES, check_code, is_valid_code
from bhr.model._robot import Robot, base_frame, forward_kinematics
from bhr._settings.errors import BhrError
from bhr.solvers import Chain, get_solver

coord = st.floats(-30, 30, allow_nan=False)
target = st.tuples(coord, coord, coord).map(np.array)
direction = st.tuples(coord, coord, coord).filter(lambda v: np.linalg.norm(v) > 1e-3).map(np.array)
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def link_lengths(points):
    return np.linalg.norm(np.diff(points, axis=0), axis=1)


@pytest.mark.parametrize("solver, options", [
    ("fabrik", {}), ("ccd", {}), ("seed", {}),
    ("constrained", {"limit": "continuous", "axes": "free", "warmup": 0}),
    ("constrained", {"limit": "binary", "axes": "free", "warmup": 10}),
])
@SETTINGS
@given(t=target, d=direction, n=st.integers(2, 8), length=st.floats(0.5, 12))
def test_every_solver_keeps_link_lengths(solver, options, t, d, n, length):
    robot = Robot(modules=n, module_length=length, tol_pos=0.01, tol_ori=5, max_iter=30)
    s = get_solver(solver, robot, **options)
    chain = Chain.straight(robot, (0, 1, 0))
    res = s.solve(chain, t, None if solver == "ccd" else d / np.linalg.norm(d))
    np.testing.assert_allclose(link_lengths(res.points), length, rtol=1e-9)
    np.testing.assert_array_equal(res.points[0], [0, 0, 0])  # the base never moves
    assert res.iterations <= 30
    assert np.all(np.isfinite(res.points))


@pytest.mark.parametrize("solver", ["fabrik", "ccd", "seed", "constrained", "optimal"])
@pytest.mark.parametrize("n, length, t", [
    (3, 10.0, (0, 0, 0)),      # target on the base: FABRIK's pull meets coincident points
    (2, 1.0, (0, 0, 1)),       # the case hypothesis found for the seed solver
    (4, 5.0, (0, 10, 0)),      # target on a point of the initial chain
])
def test_coincident_points_do_not_break_solvers(solver, n, length, t):
    robot = Robot(modules=n, module_length=length, max_iter=30)
    res = get_solver(solver, robot).solve(Chain.straight(robot, (0, 1, 0)), np.array(t, float), None)
    assert np.all(np.isfinite(res.points))
    np.testing.assert_allclose(link_lengths(res.points), length, rtol=1e-9)
    assert math.isfinite(res.position_error_mm)


def test_ccd_keeps_link_lengths_on_a_target_in_the_underflow_range():
    # hypothesis found it: |target - joint| ~ 1e-161 makes the squares subnormal,
    # the rotation axis came out 1.0148 long and so did the second link
    robot = Robot(modules=2, module_length=1.0, tol_pos=0.01, max_iter=30)
    res = get_solver("ccd", robot).solve(Chain.straight(robot, (0, 1, 0)), np.array([0.0, 0.0, 9.5e-162]), None)
    np.testing.assert_allclose(link_lengths(res.points), 1.0, rtol=1e-12)
    assert res.position_error_mm < 0.01


# degenerate targets: zero, subnormal or tiny coordinates, points of the initial chain (its axis)
tiny = st.one_of(st.just(0.0), st.floats(-1e-150, 1e-150, allow_nan=False, allow_subnormal=True),
                 st.sampled_from([5e-324, -5e-324, 9.5e-162, 1e-300]))
degenerate = st.one_of(
    st.tuples(tiny, tiny, tiny),
    st.tuples(tiny, st.floats(-12, 12, allow_nan=False), tiny),  # on the chain's axis (+Y), up to both sides
).map(lambda v: np.array(v, dtype=float))


@pytest.mark.parametrize("solver", ["fabrik", "ccd", "seed", "constrained", "optimal"])
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(t=degenerate, n=st.integers(2, 5), length=st.sampled_from([0.5, 1.0, 2.0, 10.0]))
def test_every_solver_keeps_link_lengths_on_degenerate_targets(solver, t, n, length):
    robot = Robot(modules=n, module_length=length, tol_pos=0.01, max_iter=30)
    res = get_solver(solver, robot).solve(Chain.straight(robot, (0, 1, 0)), t, None)
    assert np.all(np.isfinite(res.points))
    np.testing.assert_allclose(link_lengths(res.points), length, rtol=1e-9)
    np.testing.assert_array_equal(res.points[0], [0, 0, 0])


def angles_between_modules(points, first_dir):
    dirs = np.diff(points, axis=0)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    prev = np.vstack([first_dir, dirs[:-1]])
    # atan2 of |cross| and dot keeps full precision near 0 (arccos does not)
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(prev, dirs), axis=1), np.sum(prev * dirs, axis=1)))


@SETTINGS
@given(t=target, d=direction, n=st.integers(2, 8), alpha=st.floats(2, 40))
def test_seed_tilts_are_zero_or_alpha_about_local_axes(t, d, n, alpha):
    robot = Robot(modules=n, module_length=10, alpha=alpha)
    chain = Chain.straight(robot, (1, 0, 0))
    res = get_solver("seed", robot).solve(chain, t, d / np.linalg.norm(d))
    assert all(is_valid_code(c) and c != 15 for c in res.codes)
    tilts = angles_between_modules(res.points, np.array([1.0, 0, 0]))
    for code, tilt in zip(res.codes, tilts):
        assert abs(tilt - (0.0 if code == 0 else alpha)) < 1e-6
    # the codes rebuild the same chain through forward kinematics
    pts, frames = forward_kinematics(robot, res.codes, frame=chain.base_frame())
    np.testing.assert_allclose(pts, res.points, atol=1e-8)


codes_list = st.lists(st.sampled_from(VALID_CODES), min_size=1, max_size=12)


@SETTINGS
@given(codes=codes_list, alpha=st.floats(1, 60), length=st.floats(1, 20), d=direction)
def test_forward_kinematics_invariants(codes, alpha, length, d):
    robot = Robot(modules=len(codes), module_length=length, alpha=alpha)
    frame0 = base_frame(d)
    pts, frames = forward_kinematics(robot, codes, frame=frame0)
    # frames stay orthonormal and right-handed
    for f in np.concatenate([frame0[None], frames]):
        np.testing.assert_allclose(f @ f.T, np.eye(3), atol=1e-9)
        assert np.linalg.det(f) == pytest.approx(1.0, abs=1e-9)
    # module lengths: l, or l + stroke when lifted
    expect = [length + (robot.lift if c == 15 else 0.0) for c in codes]
    np.testing.assert_allclose(link_lengths(pts), expect, rtol=1e-9)
    # tilt between consecutive modules is exactly 0 or alpha
    tilts = angles_between_modules(pts, frame0[2])
    for c, tilt in zip(codes, tilts):
        assert abs(tilt - (0.0 if c in (0, 15) else alpha)) < 1e-6
    # each module runs along its frame's z
    dirs = np.diff(pts, axis=0)
    np.testing.assert_allclose(dirs / np.linalg.norm(dirs, axis=1)[:, None], frames[:, 2], atol=1e-9)


def test_code_axis_table_direction():
    """Code 3 turns +alpha about local +x: for the robot along +x (x = +Y, y = +Z) the tip goes to -z."""
    robot = Robot(modules=1, module_length=10, alpha=10)
    expected = {3: (0, 0, -1), 12: (0, 0, 1), 6: (0, 1, 0), 9: (0, -1, 0)}
    for code, sign in expected.items():
        pts, _ = forward_kinematics(robot, [code])
        off = pts[1] - np.array([10 * math.cos(math.radians(10)), 0, 0])
        np.testing.assert_allclose(off, np.array(sign) * 10 * math.sin(math.radians(10)), atol=1e-12)


@given(st.integers(-5, 40))
def test_only_stable_codes_are_valid(c):
    ok = c in (0, 3, 6, 9, 12, 15)
    assert is_valid_code(c) == ok
    if ok:
        assert check_code(c) == c
    else:
        with pytest.raises(BhrError, match="not a stable actuator code"):
            check_code(c)
