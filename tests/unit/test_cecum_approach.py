"""A whole robot on a trail reaches the cecum: the feeder pushes on past the path's length until the tip is there.

A binary chain weaves about a smooth centerline, so its trail covers a little less of the colon than the robot's
insertion; after the path's length of insertion the tip is still short of the blind end (docs/locomotion.md).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import bhr
from bhr._run.clearance import clearance_report
from bhr._run.driver import FollowResult, follow
from bhr.model._path import approach_steps
from bhr._studies.follow_run import body_clearance_lines


@pytest.fixture(scope="module")
def wavy(tmp_path_factory):
    """A closed lumen 34 mm across around a centerline that winds in two planes, 300 mm long."""
    s = np.arange(0.0, 300.0, 1.0)
    csv = tmp_path_factory.mktemp("wavy") / "wavy.csv"
    rows = [f"{a:.3f},{18 * math.sin(a / 35):.3f},{12 * math.sin(a / 55):.3f},34" for a in s]
    csv.write_text("x,y,z,lumen\n" + "\n".join(rows) + "\n")
    return bhr.trajectory(str(csv), feed=1.0)


def _past_the_end(traj, tip: np.ndarray) -> bool:
    """The tip at or past the cross-section of the path's last point (the blind end's plane)."""
    P = traj.points
    d = (P[-1] - P[-2]) / np.linalg.norm(P[-1] - P[-2])
    return float(np.dot(tip - P[-1], d)) >= -1e-9


@pytest.mark.run
@pytest.mark.parametrize("locomotion", ["wires", "trail"])
def test_the_feeder_pushes_on_until_the_tip_reaches_the_cecum(wavy, locomotion):
    N = wavy.points.shape[0]
    run = follow(wavy, solver="lumen", alpha=25, module_length=5, reach="cecum", locomotion=locomotion)
    s = run.summary.to_dict()
    # the path's length of insertion leaves the tip short: the run has the steps that bring it on
    assert N < run.steps <= N + approach_steps(N) == N + math.ceil(0.25 * (N - 1))
    assert s["cecum_shortfall_mm"] == 0.0 and s["cecum_approach_steps"] == run.steps - N
    assert s["feeder_stop_step"] == run.steps
    assert _past_the_end(wavy, run.points[-1, -1])
    assert not _past_the_end(wavy, run.points[N - 1, -1])  # where the path's length alone took it
    # the robot is as long as that insertion: its tail at the anus at the end
    assert run.body.modules + run.robot.modules == math.ceil((run.steps - 1) / run.robot.feed_divisor)
    # those steps aim at the path's end, and the board is sent every one of them
    assert np.array_equal(run.targets[:N], wavy.points)
    assert np.array_equal(run.targets[N:], np.repeat(wavy.points[-1:], run.steps - N, axis=0))
    assert run.board_codes.shape[0] == run.steps
    assert run.point_errors_mm[-1, -1] == pytest.approx(np.linalg.norm(run.points[-1, -1] - wavy.points[-1]))
    said = " ".join(body_clearance_lines(s))
    assert f"until step {run.steps} ({run.steps - N} past the path's end" in said and "the tip at the cecum" in said
    if locomotion == "wires":  # every written pose still a chain of rigid modules
        seg = np.linalg.norm(np.diff(run.motion.points_mm, axis=1), axis=2)
        assert np.max(np.abs(seg - 5.0)) < 1e-6
    again = FollowResult.from_json(json.loads(run.to_json()))
    assert again.steps == run.steps and np.array_equal(again.targets, run.targets)
    assert np.array_equal(again.points, run.points)
    # read back, the run is judged as it was run: by every pose, not by its written steps alone (a whole robot on a
    # trail moves between its steps; each step's clearance_mm is the smallest over all its poses)
    a, b = run.clearance, again.clearance
    np.testing.assert_allclose(b.per_step, a.per_step, rtol=0, atol=1e-9)
    assert (b.min_mm, b.min_step, b.touch_steps, b.left_lumen_step) == (a.min_mm, a.min_step, a.touch_steps,
                                                                        a.left_lumen_step)
    if locomotion == "wires":  # its written steps alone are gentler: the motion between them is what touches
        steps_only = clearance_report(again)
        assert steps_only.min_mm > a.min_mm + 1.0 and len(steps_only.touch_steps) < len(a.touch_steps)


@pytest.mark.run
def test_a_robot_too_short_for_the_colon_is_not_pushed_past_the_path(wavy):
    N = wavy.points.shape[0]
    run = follow(wavy, solver="lumen", alpha=25, module_length=5, body_modules=20)
    s = run.summary.to_dict()
    assert run.steps == N and s["too_short_for_cecum"] and s["cecum_shortfall_mm"] > 0


def test_a_run_file_with_more_steps_than_its_path_is_refused_unless_a_trail_took_them(wavy):
    run = follow(bhr.trajectory("line", length=20))
    doc = json.loads(run.to_json())
    doc["steps"].append(dict(doc["steps"][-1], step=len(doc["steps"]) + 1))
    with pytest.raises(bhr.BhrError, match="steps but only"):
        FollowResult.from_json(doc)


@pytest.mark.parametrize("locomotion", ["wires", "trail", "thesis"])
def test_a_whole_robot_shorter_than_its_head_is_refused_in_one_line(wavy, locomotion):
    with pytest.raises(bhr.BhrError, match="body_modules 3 is fewer than the 5 head modules"):
        follow(wavy, solver="lumen", alpha=25, module_length=5, body_modules=3, locomotion=locomotion)


@pytest.mark.run
@pytest.mark.parametrize("locomotion", ["wires", "trail"])
@pytest.mark.parametrize("options", [{"body_modules": 20}, {"reach": "cecum"}])
def test_the_memory_check_counts_the_steps_the_run_takes_to_the_cecum(wavy, monkeypatch, locomotion, options):
    """Past the path's 320 steps the feeder pushes on to the cecum: a run whose steps to the cecum (and, reaching
    it, its robot's points) are over the limit is refused in one line once its plan knows them, before it keeps
    its poses; at exactly the limit it runs. (Refused up front instead, by the most steps an approach may take,
    the runs of docs/traverse.md at feed divisor 10 were refused although they fit.)"""
    import bhr._settings.inputs as inputs

    kw = dict(solver="lumen", alpha=25, module_length=5, locomotion=locomotion, **options)
    run = follow(wavy, **kw)
    steps, points = run.steps, run.robot.modules + run.body.modules + 1  # the whole robot's joints
    assert steps > wavy.points.shape[0] or "reach" not in options  # reaching the cecum, it went on past the end
    limit = steps * points
    monkeypatch.setattr(inputs, "MAX_STEP_POINTS", limit - 1)
    with pytest.raises(bhr.BhrError, match=f"^{steps} steps x {points} robot points is {limit:,} points to keep, "
                                           f"more than the {limit - 1:,} a run may hold in memory; shorten"):
        follow(wavy, **kw)
    monkeypatch.setattr(inputs, "MAX_STEP_POINTS", limit)
    assert follow(wavy, **kw).steps == steps


def test_a_path_too_long_to_keep_is_refused_before_anything_runs(wavy, monkeypatch):
    import bhr._settings.inputs as inputs

    monkeypatch.setattr(inputs, "MAX_STEP_POINTS", 320 * 21 - 1)
    with pytest.raises(bhr.BhrError, match="^320 steps x 21 robot points is 6,720 points to keep"):
        follow(wavy, solver="lumen", alpha=25, module_length=5, body_modules=20)
