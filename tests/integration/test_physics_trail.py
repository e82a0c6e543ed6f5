"""The physics replay of a trail-model run (docs/locomotion.md, docs/physics.md): the trail's intermediate tilts
become joint targets within the joints' limits, a chain on them with each module as long as its chord is bhr's
whole robot, and the robot is inserted by the slide joint with the carriage at rest and stays within 0.5 mm of
bhr's poses."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import bhr
from bhr.model.generators import load_trajectory
from bhr.model.robot import Robot
from bhr.run.driver import BhrWarning
from bhr.studies.physics import insertion, mujoco_model, mujoco_points, replay_chain, replay_physics

mujoco = pytest.importorskip("mujoco")


def colon1_trail(body_modules: int, steps: int):
    """The trail model's whole robot (alpha 25 deg, 5 mm modules) on anatomical colon 1, cut to its first steps."""
    from bhr.bench.cases import first_steps

    r = Robot(alpha=25.0, module_length=5.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        run = bhr.follow(load_trajectory("anatomy", feed=r.feed, seed=1), solver="lumen", robot=r,
                         body_modules=body_modules, locomotion="trail")
    return first_steps(run, steps)


@pytest.fixture(scope="module")
def trail_run():
    return colon1_trail(40, 160)


def test_trail_tilts_stay_within_the_joints_and_put_the_chain_on_bhrs(trail_run):
    ch = replay_chain(trail_run)
    assert not ch.from_codes  # the trail's codes alone do not give its intermediate tilts
    N, J = ch.points.shape[:2]
    tilts = ch.values.reshape(N, J - 1, 3)[:, :, :2]
    a = math.radians(trail_run.robot.alpha)
    assert np.abs(tilts).max() <= a + 1e-9
    model = mujoco_model(trail_run.robot, J - 1)
    data = mujoco.MjData(model)
    L = trail_run.robot.module_length
    for i in range(0, N, 7):
        data.qpos[:] = ch.values[i]
        mujoco.mj_kinematics(model, data)
        p, _ = mujoco_points(model, data, J - 1)
        world = ch.roots[i] + p @ ch.frames[i]
        shortfall = float(np.sum(L - np.linalg.norm(np.diff(ch.points[i], axis=0), axis=1)))
        assert np.linalg.norm(world - ch.points[i], axis=1).max() <= shortfall + 1e-6


def test_trail_run_is_inserted_by_the_slide_alone_and_stays_clear(trail_run):
    ch = replay_chain(trail_run)
    depth, _, _, moved = insertion(trail_run, ch.roots, ch.frames)
    assert not moved.any()  # the rear end stays on the entrance line: the slide joint alone inserts the robot
    assert np.allclose(np.diff(depth), trail_run.robot.feed)  # one feed a step
    assert trail_run.clearance.min_mm >= 1.0
    rep = replay_physics(trail_run)
    assert rep.contact_steps == []
    assert rep.summary()["carriage_moved_steps"] == 0
    L = trail_run.robot.module_length
    shortfall = max(float(np.sum(L - np.linalg.norm(np.diff(p, axis=0), axis=1))) for p in ch.points)
    assert shortfall > 1.0  # a rigid chain of full modules would be this far off: the chords are what keep it on
    assert rep.deviation_mm.max() <= 0.5


def test_trail_chords_put_the_chain_exactly_on_bhrs(trail_run):
    """With each module's length set to its chord (the next module's body on its axis), the tilts give bhr's
    whole robot exactly: what is left of the replay's deviation is the servos', not the model's."""
    ch = replay_chain(trail_run)
    N, J = ch.points.shape[:2]
    L = trail_run.robot.module_length
    a = math.radians(trail_run.robot.alpha)
    assert ch.chords is not None
    assert ch.chords.max() <= 0.0
    assert ch.chords.min() >= -L * (1 - math.cos(a / 2)) - 1e-9  # the model's shortest chord, L cos(alpha/2)
    model = mujoco_model(trail_run.robot, J - 1)
    data = mujoco.MjData(model)
    bodies = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"m{i}") for i in range(2, J)]
    tip = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tip")
    for i in range(0, N, 3):
        model.body_pos[bodies, 2] = (L + ch.chords[i, :-1]) * 1e-3
        model.site_pos[tip, 2] = (L + ch.chords[i, -1]) * 1e-3
        data.qpos[:] = ch.values[i]
        mujoco.mj_kinematics(model, data)
        p, _ = mujoco_points(model, data, J - 1)
        world = ch.roots[i] + p @ ch.frames[i]
        assert np.linalg.norm(world - ch.points[i], axis=1).max() <= 1e-6


@pytest.fixture(scope="module")
def rear_in_run():
    """A whole robot of 30 modules on colon 1, its first 230 steps: its rear end passes the entrance after step 151
    and turns into the colon from step 162 on, so the carriage moves and turns with it (bhr's clearance >= 5.9 mm)."""
    return colon1_trail(30, 230)


def test_trail_run_whose_rear_enters_the_colon_stays_clear_and_on_bhrs_poses(rear_in_run):
    """The rear module turns into the colon, the carriage with it: the servos follow the model's motion between
    steps with it (no lag that would swing the robot beyond the rear about it), so a run clear of the wall in bhr
    is clear in MuJoCo and on bhr's poses. (Before: contact at steps 183-186 and 11.8 mm off.)"""
    ch = replay_chain(rear_in_run)
    _, _, _, moved = insertion(rear_in_run, ch.roots, ch.frames)
    assert moved.sum() >= 50  # the carriage moves and turns: the case this test is for
    assert rear_in_run.clearance.min_mm >= 1.0
    rep = replay_physics(rear_in_run)
    assert rep.summary()["carriage_moved_steps"] == int(moved.sum())
    assert rep.contact_steps == []
    assert rep.deviation_mm.max() <= 0.5


def test_trail_substeps_are_the_models_robot_between_two_steps(rear_in_run):
    """Between two steps every joint slides along one piece of the trail: the replay's intermediate chain is each
    joint that far along its way, the tilts put a chain of those chords there, and a whole fraction is the step."""
    from bhr.studies.physics import trail_substeps

    ch = replay_chain(rear_in_run)
    L = rear_in_run.robot.module_length
    fr = np.array([0.25, 0.5, 1.0])
    roots, frames, values, chords = trail_substeps(ch, fr, L)
    N, J = ch.points.shape[:2]
    assert np.allclose(values[:, -1], ch.values, atol=1e-12) and np.allclose(frames[:, -1], ch.frames, atol=1e-12)
    model = mujoco_model(rear_in_run.robot, J - 1)
    data = mujoco.MjData(model)
    bodies = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"m{i}") for i in range(2, J)]
    tip = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tip")
    for i in range(160, N, 9):
        for k, s in enumerate(fr[:-1]):
            want = ch.points[i - 1] + s * (ch.points[i] - ch.points[i - 1])
            model.body_pos[bodies, 2] = (L + chords[i, k, :-1]) * 1e-3
            model.site_pos[tip, 2] = (L + chords[i, k, -1]) * 1e-3
            data.qpos[:] = values[i, k]
            mujoco.mj_kinematics(model, data)
            p, _ = mujoco_points(model, data, J - 1)
            assert np.linalg.norm(roots[i, k] + p @ frames[i, k] - want, axis=1).max() <= 1e-6
