"""The optimal solver: exact search (against plain enumeration), follow-the-leader runs, options, CLI."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr.model._codes import VALID_CODES
from bhr.model._generators import load_trajectory
from bhr.model._path import path_directions
from bhr.model._robot import Robot, base_frame, forward_kinematics
from bhr._run.driver import follow
from bhr._settings.errors import BhrError
from bhr.solvers import get_solver
from bhr.solvers._optimal import DEFAULTS, config_cost, path_features, search_all, search_head

SEARCHED = (0, 3, 6, 12, 9)  # rest and the four tilts; lift (15) is not searched


def random_frame(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 2] = -q[:, 2]
    return q.T  # rows x, y, z, right-handed


def enumerate_best(robot, base, frame, targets, weights, tip_dir, ori_weight, fixed_first=None):
    """Plain enumeration of every code combination with forward_kinematics: (min cost, all argmins)."""
    n = robot.modules
    best, arg = math.inf, []
    firsts = SEARCHED if fixed_first is None else (fixed_first,)
    for rest in itertools.product(SEARCHED, repeat=n - 1):
        for c1 in firsts:
            codes = (c1,) + rest
            pts, _ = forward_kinematics(robot, codes, base, frame)
            j = config_cost(pts, targets, weights, tip_dir, ori_weight)
            if not arg or j < best - 1e-9 * max(1.0, best):
                best, arg = j, [codes]
            elif abs(j - best) <= 1e-9 * max(1.0, best):
                arg.append(codes)
    return best, arg


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 4), seed=st.integers(0, 2**31 - 1), with_dir=st.booleans(), tip_only=st.booleans())
def test_search_all_is_exact_against_enumeration(n, seed, with_dir, tip_only):
    rng = np.random.default_rng(seed)
    robot = Robot(modules=n, module_length=float(rng.uniform(2, 12)), alpha=float(rng.uniform(5, 40)))
    base = rng.normal(scale=20, size=3)
    frame = random_frame(rng)
    targets = base + rng.normal(scale=robot.module_length * n / 2, size=(n + 1, 3))
    weights = np.zeros(n + 1) if tip_only else rng.uniform(0, 2, size=n + 1)
    weights[n] = max(weights[n], 0.5)
    tip_dir = rng.normal(size=3) if with_dir else None
    if tip_dir is not None:
        tip_dir /= np.linalg.norm(tip_dir)
    ori = float(rng.uniform(0, 0.5))
    codes, cost = search_all(base, frame, targets, weights, robot.module_length, robot.alpha, tip_dir, ori)
    best, args = enumerate_best(robot, base, frame, targets, weights, tip_dir, ori)
    assert cost == pytest.approx(best, rel=1e-9, abs=1e-9)
    assert tuple(codes) in args
    pts, _ = forward_kinematics(robot, codes, base, frame)
    assert config_cost(pts, targets, weights, tip_dir, ori) == pytest.approx(cost, rel=1e-9, abs=1e-9)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 4), seed=st.integers(0, 2**31 - 1), first=st.sampled_from(SEARCHED))
def test_search_head_is_exact_with_module_one_fixed(n, seed, first):
    rng = np.random.default_rng(seed)
    robot = Robot(modules=n, module_length=10.0, alpha=10.0)
    base = rng.normal(scale=5, size=3)
    frame = random_frame(rng)
    targets = base + rng.normal(scale=15, size=(n + 1, 3))
    weights = rng.uniform(0.1, 2, size=n + 1)
    tip_dir = rng.normal(size=3)
    tip_dir /= np.linalg.norm(tip_dir)
    # module 1's frame after its own tilt, as the follow solver hands it to the head search
    _, frames = forward_kinematics(robot, (first,) + (0,) * (n - 1), base, frame)
    codes, cost = search_head(base, frames[0], targets, weights, 10.0, 10.0, tip_dir, 0.2)
    best, args = enumerate_best(robot, base, frame, targets, weights, tip_dir, 0.2, fixed_first=first)
    assert cost == pytest.approx(best, rel=1e-9, abs=1e-9)
    assert (first, *codes) in args


def test_search_recovers_any_configuration():
    """Targets on the points of some codes: the search finds exactly those codes at zero cost."""
    rng = np.random.default_rng(7)
    robot = Robot(modules=5)
    frame = base_frame((1, 0, 0))
    for _ in range(20):
        codes = tuple(int(c) for c in rng.choice(SEARCHED, size=5))
        pts, _ = forward_kinematics(robot, codes, (1.0, -2.0, 3.0), frame)
        found, cost = search_all((1.0, -2.0, 3.0), frame, pts, np.ones(6), 10.0, 10.0)
        assert tuple(found) == codes
        assert cost == pytest.approx(0.0, abs=1e-18)


def test_five_modules_search_matches_enumeration_once():
    """The thesis's robot size: 3125 configurations, the search agrees with enumerating them."""
    rng = np.random.default_rng(3)
    robot = Robot(modules=5)
    frame = random_frame(rng)
    targets = rng.normal(scale=20, size=(6, 3))
    d = np.array([0.0, 0.6, 0.8])
    codes, cost = search_all(np.zeros(3), frame, targets, np.ones(6), 10.0, 10.0, d, 0.2)
    best, args = enumerate_best(robot, np.zeros(3), frame, targets, np.ones(6), d, 0.2)
    assert cost == pytest.approx(best, rel=1e-12)
    assert tuple(codes) in args


# ---------------------------------------------------------------------------
# follow-the-leader


@pytest.fixture(scope="module")
def curve90():
    return load_trajectory("curve")


def replay_frames(result) -> np.ndarray:
    """Module 1's frame at each step, replayed from the start frame and the base codes."""
    from bhr.solvers._optimal import CODE_OF, _rot

    r = result.robot
    idx = {int(c): k for k, c in enumerate(CODE_OF)}
    c, s = math.cos(math.radians(r.alpha)), math.sin(math.radians(r.alpha))
    F = base_frame(result.trajectory.start_direction)
    out = np.empty((result.steps, 3, 3))
    for i in range(result.steps):
        F1 = np.empty((3, 3))
        _rot(F, idx[int(result.codes[i, 0])], c, s, F1)
        out[i] = F1
        F = F1
    return out


def test_follow_poses_are_the_forward_kinematics_of_the_codes(curve90):
    res = follow(curve90, solver="optimal")
    assert res.codes is not None and set(np.unique(res.codes)) <= set(VALID_CODES) - {15}
    frames = replay_frames(res)
    robot = res.robot
    for i in range(res.steps):
        F = base_frame(curve90.start_direction) if i == 0 else frames[i - 1]
        pts, _ = forward_kinematics(robot, res.codes[i], res.points[i, 0], F)
        np.testing.assert_allclose(pts, res.points[i], atol=1e-9)
        if i:  # the robot advanced by one feed along the previous base module
            step = res.points[i, 0] - res.points[i - 1, 0]
            np.testing.assert_allclose(step, robot.feed * frames[i - 1][2], atol=1e-9)


def test_compiled_loop_equals_step_by_step(curve90):
    a = follow(curve90, solver="optimal")
    b = follow(curve90, solver="optimal", compiled=False)
    np.testing.assert_array_equal(a.codes, b.codes)
    np.testing.assert_allclose(a.points, b.points, atol=1e-12)
    np.testing.assert_allclose(a.point_errors_mm, b.point_errors_mm, atol=1e-12)
    np.testing.assert_allclose(a.orientation_errors_deg, b.orientation_errors_deg, atol=1e-9)


def test_without_lookahead_every_step_is_the_exact_optimum():
    """lookahead=0: each step's pose minimises that step's cost over all 5^n configurations."""
    robot = Robot(modules=3)
    tr = load_trajectory("curve", radius=80.0, angle=60.0, entry=10.0, exit=10.0)
    res = follow(tr, solver="optimal", robot=robot,
                 solver_options={"lookahead": 0, "ori_weight": 0.2, "drift_weight": 0.0, "roll_weight": 0.0})
    path = tr.points
    dirs = path_directions(path)
    frames = replay_frames(res)
    f, feed, n, N = robot.feed_divisor, robot.feed, robot.modules, res.steps
    for i in range(0, N, 7):
        T = np.array([path[i - (n - j) * f] if i - (n - j) * f >= 0 else path[0] + (i - (n - j) * f) * feed * dirs[0]
                      for j in range(n + 1)])
        d = dirs[min(i, N - 2)]
        F = base_frame(tr.start_direction) if i == 0 else frames[i - 1]
        best, args = enumerate_best(robot, res.points[i, 0], F, T, np.ones(n + 1), d, 0.2)
        assert tuple(int(c) for c in res.codes[i]) in args


def test_planning_ahead_beats_the_per_step_optimum_on_a_long_curve():
    """The per-step optimum cuts inside a long curve and runs ahead of its targets; the planner does not."""
    tr = load_trajectory("curve", angle=360)
    greedy = follow(tr, solver="optimal", solver_options={"lookahead": 0, "drift_weight": 0.0, "roll_weight": 0.0})
    planned = follow(tr, solver="optimal")
    assert planned.point_errors_mm.max() < 0.85 * greedy.point_errors_mm.max()


@pytest.mark.parametrize("name,params,limit", [
    ("curve", {}, 0.8), ("curve", {"angle": 360}, 0.8), ("spiral", {}, 0.8), ("colon", {}, 0.6)])
def test_worst_error_against_the_thesis_solver(name, params, limit):
    """The issue's targets (docs/optimal.md): worst position error over all scored points vs --solver seed."""
    tr = load_trajectory(name, **params)
    seed = follow(tr, solver="seed").point_errors_mm.max()
    opt = follow(tr, solver="optimal").point_errors_mm.max()
    assert opt <= limit * seed


def test_options_are_validated():
    robot = Robot()
    with pytest.raises(BhrError, match="6 point weights"):
        get_solver("optimal", robot, point_weights=[1, 1, 1])
    with pytest.raises(BhrError, match="lookahead"):
        get_solver("optimal", robot, lookahead=-1)
    with pytest.raises(BhrError, match="beam"):
        get_solver("optimal", robot, beam=0)
    with pytest.raises(BhrError, match="ori.weight"):
        get_solver("optimal", robot, ori_weight=float("nan"))
    with pytest.raises(BhrError, match="positive"):
        get_solver("optimal", robot, point_weights=0.0)
    with pytest.raises(BhrError, match="too many"):
        get_solver("optimal", Robot(modules=13))
    s = get_solver("optimal", robot, point_weights=[0, 1, 1, 1, 2, 4], lookahead=3)
    assert s.settings["point_weights"] == [0, 1, 1, 1, 2, 4] and s.settings["lookahead"] == 3
    assert get_solver("optimal", robot).settings["lookahead"] == DEFAULTS["lookahead"]


def test_point_weights_change_what_is_fitted(curve90):
    """At one step, weighting only the tip fits the tip at least as well as the default, the others worse."""
    from bhr.solvers import Chain, FollowContext

    robot = Robot()
    path = curve90.points
    dirs = path_directions(path)
    plain = {"lookahead": 0, "drift_weight": 0.0, "roll_weight": 0.0}
    better = 0
    for step in (18, 22, 26, 30):
        chain = Chain.straight(robot, dirs[step - 1], path[step - 1], tip_at_origin=True)
        ctx = FollowContext(path, dirs, step)
        a = get_solver("optimal", robot, **plain).solve(chain, path[step], dirs[step], ctx)
        b = get_solver("optimal", robot, **plain, point_weights=[0, 0, 0, 0, 0, 1], ori_weight=0.0).solve(
            chain, path[step], dirs[step], ctx)
        assert b.position_error_mm <= a.position_error_mm + 1e-12
        better += b.position_error_mm < a.position_error_mm - 1e-6
    assert better >= 1


def test_path_features_of_a_circle():
    tr = load_trajectory("curve", radius=70.0, angle=180.0)
    kvec, spacing, kcurve, kbend = path_features(tr.points, path_directions(tr.points), 5)
    mid = tr.points.shape[0] // 2
    assert np.linalg.norm(kvec[mid]) == pytest.approx(1 / 70.0, rel=0.02)
    # toward the centre: the curve turns clockwise from +x, centre at (x, -70)
    assert kvec[mid] @ (np.array([tr.points[mid, 0], -70.0, 0.0]) - tr.points[mid]) > 0
    assert spacing[mid] == pytest.approx(2.0, rel=0.01)
    assert 0 < kcurve[mid] <= 40
    assert np.linalg.norm(kbend[mid]) == pytest.approx(math.sin(10 / 70), rel=0.02)


def test_cli_help_states_the_solver_defaults():
    from bhr.cli.follow import follow as follow_cmd

    helps = {p.name: p.help for p in follow_cmd.params}
    for key in ("lookahead", "beam", "ori_weight", "drift_weight", "roll_weight", "point_weights"):
        assert f"[{DEFAULTS[key]:g}]" in helps[key], (key, helps[key])
