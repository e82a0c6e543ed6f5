"""Whole-body follow-the-leader (bhr/body.py): the modules behind the head."""
from __future__ import annotations

import math

import numpy as np
import pytest

from bhr.model._generators import load_trajectory
from bhr._run.body import module1_frames, simulate_body, whole_robot
from bhr._run.driver import follow
from bhr._settings.errors import BhrError


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def angles_deg(a, b):
    return np.degrees(np.arccos(np.clip(np.sum(unit(a) * unit(b), axis=-1), -1, 1)))


@pytest.fixture(scope="module")
def curve_body():
    return follow(load_trajectory("curve", angle=180.0), solver="optimal", body_modules=20)


def test_body_shape_and_summary(curve_body):
    r = curve_body
    assert r.body.modules == 15
    assert r.body.points.shape == (r.steps, 15, 3) and r.body.codes.shape == (r.steps, 15)
    s = r.summary.to_dict()
    assert s["body_modules"] == 20
    assert s["body_points_max_error_mm"] == pytest.approx(r.body.point_errors_mm.max())
    assert whole_robot(r, 10).shape == (21, 3)
    np.testing.assert_array_equal(whole_robot(r, 10)[-6:], r.points[10])


def test_every_body_module_is_rigid_and_every_joint_binary(curve_body):
    r = curve_body
    L, alpha = r.robot.module_length, r.robot.alpha
    full = np.stack([whole_robot(r, i) for i in range(r.steps)])  # tail first
    seg = np.diff(full, axis=1)
    np.testing.assert_allclose(np.linalg.norm(seg, axis=2), L, atol=1e-9)
    ang = angles_deg(seg[:, :-1], seg[:, 1:])  # joint angles along the whole robot
    assert np.all((ang < 1e-4) | (np.abs(ang - alpha) < 1e-4))
    # each joint's angle is the code of the module in front of it: rest is straight, a tilt is alpha
    codes = np.concatenate([r.body.codes[:, ::-1], r.codes], axis=1)  # tail first, like full
    tilted = codes[:, 1:] != 0
    assert np.array_equal(ang > alpha / 2, tilted)


def test_joint_behind_module_one_is_module_ones_code(curve_body):
    """Body module 1 is the thesis's virtual module: module 1's frame before this step's tilt."""
    r = curve_body
    start, F1 = module1_frames(r.codes, r.trajectory.start_direction, r.robot.alpha)
    back = r.points[:, 0] - r.body.points[:, 0]  # direction of body module 1
    prev = np.vstack([start[2][None], F1[:-1, 2]])
    np.testing.assert_allclose(unit(back), prev, atol=1e-9)


def test_body_follows_where_module_one_has_been(curve_body):
    """Body point k sits near where module 1's base joint was k f steps earlier, and on the path."""
    r = curve_body
    f = r.robot.feed_divisor
    for k in (2, 5, 10, 15):
        i = np.arange(k * f, r.steps)
        d = np.linalg.norm(r.body.points[i, k - 1] - r.points[i - k * f, 0], axis=1)
        assert np.median(d) < 1.0 and d.max() < r.robot.tol_pos
    assert r.body.point_errors_mm.max() < r.robot.tol_pos


def test_straight_line_body_is_exact():
    r = follow(load_trajectory("line", length=120.0), solver="optimal", body_modules=12)
    assert np.all(r.body.codes == 0)
    assert r.body.point_errors_mm.max() < 1e-9
    assert r.point_errors_mm.max() < 1e-9


def test_scoring_matches_the_head_convention(curve_body):
    r = curve_body
    n, f = r.robot.modules, r.robot.feed_divisor
    path = r.trajectory.points
    for i in (40, 120, r.steps - 1):
        for k in (1, 7, 15):
            idx = i - (n + k) * f
            want = 0.0 if idx < 0 else np.linalg.norm(r.body.points[i, k - 1] - path[idx])
            assert r.body.point_errors_mm[i, k - 1] == pytest.approx(want)
            assert r.body.scored[i, k - 1] == (idx >= 0)


def test_bad_body_requests():
    tr = load_trajectory("curve")
    with pytest.raises(BhrError, match="fewer than the 5 head modules"):
        follow(tr, solver="optimal", body_modules=4)
    with pytest.raises(BhrError, match="no module codes"):
        follow(tr, solver="fabrik", body_modules=10)
    r = follow(tr, solver="seed", body_modules=5)
    assert r.body.modules == 0 and r.summary.to_dict()["body_modules"] == 5
    with pytest.raises(BhrError, match="whole number"):
        simulate_body(r, 7.5)


def test_seed_runs_carry_a_body_too():
    r = follow(load_trajectory("curve"), solver="seed", body_modules=15)
    assert r.body.point_errors_mm.max() < r.robot.tol_pos


@pytest.mark.run
def test_sixty_module_robot_through_the_colon():
    """The issue's whole-body run: 60 modules end to end through the colon, clearance reported."""
    tr = load_trajectory("colon")
    assert tr.lumen is not None
    r = follow(tr, solver="optimal", body_modules=60)
    s = r.summary.to_dict()
    assert r.steps == tr.points.shape[0] and s["body_modules"] == 60
    assert r.body.scored[-1].all()  # at the end the whole body is inside the path
    assert s["body_points_max_error_mm"] < r.robot.tol_pos
    assert s["min_clearance_mm"] is not None and 0 < s["min_clearance_mm"] < 45 / 2 - r.robot.robot_radius
    assert s["wall_touch_steps"] == []


def test_module_one_frames_follow_the_codes(curve_body):
    r = curve_body
    _, F1 = module1_frames(r.codes, r.trajectory.start_direction, r.robot.alpha)
    np.testing.assert_allclose(F1[:, 2], unit(r.points[:, 1] - r.points[:, 0]), atol=1e-9)
    assert np.allclose(np.einsum("nij,nkj->nik", F1, F1), np.eye(3), atol=1e-9)
    assert math.isclose(np.linalg.det(F1[-1]), 1.0, rel_tol=1e-9)


def test_board_codes_are_the_whole_robots_rear_first(curve_body):
    from bhr._run.body import whole_robot_codes

    codes = curve_body.board_codes
    assert codes.shape == (curve_body.steps, 20)
    assert np.array_equal(codes[:, 15:], curve_body.codes)  # the head last, base first
    assert np.array_equal(codes[:, 0], np.zeros(curve_body.steps))  # the rear module: nothing behind it to tilt from
    assert np.array_equal(codes[:, 1:15], curve_body.body.codes[:, :-1][:, ::-1])  # the body from the rear forwards
    head = follow(load_trajectory("curve", angle=30.0), solver="thesis")
    assert np.array_equal(head.board_codes, head.codes) and whole_robot_codes(head.codes, None) is not None
