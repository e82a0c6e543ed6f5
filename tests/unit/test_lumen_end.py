"""--solver lumen plans against the lumen's end as the trajectory has it (a blind cecum by default), and its lead
term (the lead a robot could no longer lose before the end) is part of the exact head search's cost."""
from __future__ import annotations

import copy
import itertools
import warnings

import pytest

from bhr._bench.lumen import tight_colon
from bhr.model._robot import Robot, forward_kinematics
from bhr.model._tube import make_tube
from bhr._run.driver import follow
from tests.unit.test_lumen import pose_before
from bhr._settings.errors import BhrError
from bhr.solvers import get_solver
from bhr.solvers._lumen import DEFAULTS, head_cost, lumen_config_cost

CODES = (0, 3, 6, 12, 9)


@pytest.fixture(scope="module")
def tight():
    return tight_colon(3)


@pytest.mark.parametrize("end", ["closed", "open"])
def test_the_solver_plans_with_the_trajectorys_lumen_end(tight, end):
    tr = copy.copy(tight)
    if end == "open":
        tr.lumen_end = "open"
    s = get_solver("lumen", Robot())
    s.prepare(tr)
    assert s._tube is not None and s._tube.closed == (end == "closed")
    # a closed tube stops at the path's last point; an open one goes on past it
    n = tr.points.shape[0]
    assert s._tube.points.shape[0] == n + s._tube.pre + s._tube.post
    assert (s._tube.post == 0) == (end == "closed")


@pytest.mark.run
@pytest.mark.parametrize("step_back", [3, 12])
def test_the_head_search_with_the_lead_term_is_the_exact_minimum(tight, step_back):
    """Near the blind end, lead term on (no slack: every mm ahead counts): branch and bound = every code costed."""
    robot = Robot(modules=4)
    settings = dict(DEFAULTS, lead_weight=50.0, lead_slack=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = follow(tight, solver="lumen", robot=robot)
    tube = make_tube(tight.points, tight.lumen, tight.start_direction, settings["window"], closed_end=True)
    step = run.steps - step_back
    base, frame = pose_before(run, robot, step)
    codes, cost = head_cost(tube, robot, settings, tight.points, step, base, frame)
    costs = {}
    without = {}
    for rest in itertools.product(CODES, repeat=robot.modules - 1):
        pts, _ = forward_kinematics(robot, [0, *rest], base, frame)
        costs[rest] = lumen_config_cost(tube, robot, settings, tight.points, step, pts)
        without[rest] = lumen_config_cost(tube, robot, dict(settings, lead_weight=0.0), tight.points, step, pts)
    best = min(costs.values())
    assert cost == pytest.approx(best, rel=1e-9, abs=1e-9)
    assert costs[tuple(codes)] == pytest.approx(best, rel=1e-9, abs=1e-9)
    # the term is never negative, and it is what separates the two costs
    assert all(costs[k] >= without[k] - 1e-9 for k in costs)
    assert any(costs[k] > without[k] + 1e-6 for k in costs)


def test_lead_options_are_checked():
    s = get_solver("lumen", Robot(), lead_weight=3.0, lead_slack=0.2)
    assert s.settings["lead_weight"] == 3.0 and s.settings["lead_slack"] == 0.2
    with pytest.raises(BhrError, match="lead_slack = 1.5 is too large"):
        get_solver("lumen", Robot(), lead_slack=1.5)
    with pytest.raises(BhrError, match="lead-weight"):
        get_solver("lumen", Robot(), lead_weight=-1.0)


def test_cecum_step_is_the_first_step_the_tip_is_at_the_end():
    """The step a feeder that stops at the cecum would stop at: the tip's tracked nearest point is the last one and
    it is past the last point's cross-section (a path that loops back past its end plane does not count early)."""
    from types import SimpleNamespace

    import numpy as np

    from bhr._bench.lumen import cecum_step

    t = np.linspace(0.0, 1.5 * np.pi, 200)
    C = np.stack([30.0 * np.cos(t), 30.0 * np.sin(t), np.zeros_like(t)], axis=1)  # 3/4 of a circle
    tips = np.concatenate([C[10:], np.repeat(C[-1:] + [[1.0, 0.0, 0.0]], 15, axis=0)])  # ahead by 10 points
    pts = np.zeros((tips.shape[0], 2, 3))
    pts[:, -1] = tips
    res = SimpleNamespace(trajectory=SimpleNamespace(points=C), points=pts)
    assert cecum_step(res) == 189  # tips[189] is C[199], the end: the start, behind the end's plane, never counts
    res.points = pts[:150]
    assert cecum_step(res) == 149  # never reached: the last step
