"""--solver lumen (bhr/solvers/_lumen.py): exact head search, planning, options, and that it keeps off the wall."""
from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bhr._bench.lumen import tight_colon
from bhr.model._generators import Trajectory, load_trajectory
from bhr.model._robot import Robot, forward_kinematics
from bhr.model._tube import nearest_numpy
from bhr._run.clearance import make_tube
from bhr._run.driver import follow
from bhr._settings.errors import BhrError
from bhr.solvers import get_solver
from bhr.solvers._lumen import DEFAULTS, head_cost, head_search, lumen_config_cost

CODES = (0, 3, 6, 12, 9)


def quiet_follow(*a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return follow(*a, **kw)


@pytest.fixture(scope="module")
def tight():
    return tight_colon(1)


def pose_before(run, robot, step):
    """Module 1's base and frame at 1-based ``step`` of ``run`` before its solve: after a rest tilt, one feed on."""
    P = run.points[step - 1]
    base = P[0] + robot.feed * (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
    z = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
    x = np.cross([0.0, 0.0, 1.0], z) if abs(z[2]) < 0.9 else np.cross([1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    return base, np.stack([x, np.cross(z, x), z])


@pytest.mark.run
@pytest.mark.parametrize("modules,step", [(3, 40), (4, 95), (4, 150), (4, 210)])
def test_the_head_search_is_the_exact_minimum_of_the_cost(tight, modules, step):
    """Modules 2..n found by branch and bound = the cheapest of all 5^(n-1) codes, each costed in numpy."""
    robot = Robot(modules=modules)
    settings = dict(DEFAULTS)
    run = quiet_follow(tight, solver="lumen", robot=robot)
    tube = make_tube(tight.points, tight.lumen, tight.start_direction, settings["window"])
    # the pose the run had at this step, before the solve: module 1's frame after a rest tilt
    base, frame = pose_before(run, robot, step)
    codes, cost = head_cost(tube, robot, settings, tight.points, step, base, frame)
    costs = {}
    for rest in itertools.product(CODES, repeat=modules - 1):
        pts, _ = forward_kinematics(robot, [0, *rest], base, frame)
        costs[rest] = lumen_config_cost(tube, robot, settings, tight.points, step, pts)
    best = min(costs.values())
    assert cost == pytest.approx(best, rel=1e-9, abs=1e-9)
    assert costs[tuple(codes)] == pytest.approx(best, rel=1e-9, abs=1e-9)


@pytest.mark.run
def test_codes_are_always_valid_and_the_body_follows(tight):
    r = quiet_follow(tight, solver="lumen", body_modules=9, locomotion="thesis")  # the thesis model's body
    assert set(np.unique(r.codes)) <= set(CODES)
    assert r.body is not None and r.body.modules == 4
    s = r.summary.to_dict()
    assert len(s["contact_length_mm"]) == 9 and s["contact_modules"][5] == "body module 1"
    assert s["max_penetration_mm"] >= 0 and s["max_penetration_mm"] == max(0.0, -s["min_clearance_mm"])


def test_compiled_loop_and_step_by_step_driver_agree(tight):
    short = Trajectory("tight start", tight.points[:140].copy(), lumen=tight.lumen[:140].copy(),
                       start_direction=tight.start_direction)
    a = quiet_follow(short, solver="lumen")
    b = quiet_follow(short, solver="lumen", compiled=False)
    assert np.array_equal(a.codes, b.codes)
    np.testing.assert_allclose(a.points, b.points, atol=1e-12)


@pytest.mark.run
def test_keeps_off_the_wall_where_the_thesis_solver_touches_it(tight):
    lumen = quiet_follow(tight, solver="lumen").summary.to_dict()
    seed = quiet_follow(tight, solver="seed").summary.to_dict()
    assert seed["max_penetration_mm"] > 5 and len(seed["wall_touch_steps"]) > 20
    assert lumen["max_penetration_mm"] <= 0.5 * seed["max_penetration_mm"]
    assert len(lumen["wall_touch_steps"]) <= 0.5 * len(seed["wall_touch_steps"])


def test_a_wide_straight_lumen_is_never_touched():
    tr = load_trajectory("line", length=120.0)
    tr.lumen = np.full(len(tr.points), 24.0)
    s = quiet_follow(tr, solver="lumen").summary.to_dict()
    assert s["wall_touch_steps"] == [] and s["min_clearance_mm"] > 5.0


def test_without_a_lumen_it_says_what_is_missing():
    with pytest.raises(BhrError, match="needs a trajectory with a lumen"):
        follow(load_trajectory("curve"), solver="lumen")


def test_options_are_checked_and_reported():
    robot = Robot()
    s = get_solver("lumen", robot, lookahead=3, wall_weight=50.0, window=30.0)
    assert s.settings["lookahead"] == 3 and s.settings["wall_weight"] == 50.0 and s.settings["window"] == 30.0
    assert s.settings["beam"] == DEFAULTS["beam"]
    with pytest.raises(BhrError, match="window"):
        get_solver("lumen", robot, window=0.0)
    with pytest.raises(BhrError, match="wall-weight"):
        get_solver("lumen", robot, wall_weight=-1.0)
    with pytest.raises(BhrError, match="does not take"):
        get_solver("lumen", robot, drift_weight=1.0)


def test_cli_help_states_the_lumen_defaults():
    from bhr.cli.follow import follow as follow_cmd

    helps = {p.name: p.help for p in follow_cmd.params}
    for key in ("wall_weight", "margin", "center_weight", "track_weight", "window"):
        assert f"[{DEFAULTS[key]:g}]" in helps[key], (key, helps[key])
    for key in ("lookahead", "beam", "ori_weight"):
        assert f"(lumen [{DEFAULTS[key]:g}])" in helps[key], (key, helps[key])


@settings(max_examples=25, deadline=None)
@given(step=st.integers(20, 250), yaw=st.floats(-0.3, 0.3), pitch=st.floats(-0.3, 0.3), shift=st.floats(-8.0, 8.0))
def test_the_depth_the_beam_ranks_by_is_the_best_heads_deepest_sample_in_numpy(tight, step, yaw, pitch, shift):
    """head_search's depth (the beam's ranking) = the largest -clearance over the best head's base, far ends and
    module middles, each searched in numpy over the window around where it is expected."""
    robot = Robot()
    tube = make_tube(tight.points, tight.lumen, tight.start_direction, DEFAULTS["window"], closed_end=True)
    n, f = robot.modules, robot.feed_divisor
    k = step - n * f
    base = tight.points[max(k, 0)] + np.array([0.0, 0.0, shift])
    d = tight.points[max(k, 0) + 5] - tight.points[max(k, 0)]
    z = d / np.linalg.norm(d) + np.array([yaw, pitch, 0.0])
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    frame = np.stack([x, np.cross(z, x), z])
    codes, cost, got = head_search(tube, robot, dict(DEFAULTS), tight.points, step, base, frame)
    assert head_cost(tube, robot, dict(DEFAULTS), tight.points, step, base, frame) == (codes, cost)
    pts, _ = forward_kinematics(robot, [0, *codes], base, frame)
    want = -np.inf
    for j in range(n + 1):
        want = max(want, -nearest_numpy(tube, robot.robot_radius, pts[j], k + j * f + tube.pre)[0])
        if j:
            mid = 0.5 * (pts[j] + pts[j - 1])
            want = max(want, -nearest_numpy(tube, robot.robot_radius, mid, k + (j - 0.5) * f + tube.pre)[0])
    assert got == pytest.approx(want, abs=1e-9)


@pytest.mark.run
@settings(max_examples=8, deadline=None)
@given(seed=st.integers(1, 10_000), beam=st.integers(1, 7), lookahead=st.integers(0, 12), modules=st.integers(2, 5))
def test_the_beam_cutting_candidates_it_cannot_keep_is_the_beam_that_searches_them_all(seed, beam, lookahead, modules):
    """The beam stops the search of a candidate as soon as it is sure the candidate cannot be kept: the same codes
    and the same robot at every step as searching every candidate whole."""
    tr = tight_colon(seed)
    runs = []
    for prune in (True, False):
        s = get_solver("lumen", Robot(modules=modules), beam=beam, lookahead=lookahead)
        s._prune_beam = prune
        runs.append(quiet_follow(tr, solver=s, modules=modules))
    assert np.array_equal(runs[0].codes, runs[1].codes)
    assert np.array_equal(runs[0].points, runs[1].points)
