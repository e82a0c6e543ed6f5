"""A passive body in the physics replay (``--passive-modules``): the rear modules have no wires, and each of their
joints is held towards straight by the body's flexural rigidity (``EI / l``). Clear of the wall the body is straight
whatever the run's codes and the head keeps its codes' tilts on it; pressed into a wall, a softer body gives way and
loads the wall less; none passive is the replay without the option; a count the robot cannot have is refused in one
line."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bhr.model._path import Trajectory
from bhr.model._robot import Robot, base_frame
from bhr._settings.errors import BhrError
from bhr._studies.physics import DEFAULT_WALL_STIFFNESS, Poses, replay_poses
from bhr._studies.physics.joints import PASSIVE_RIGIDITY_NMM2, passive_stiffness
from bhr._studies.physics.poses import chain_points, code_tilts

pytestmark = pytest.mark.integration


def _lumen(radius: float, length: float = 400.0) -> Trajectory:
    x = np.arange(0.0, length + 0.5, 0.5)
    pts = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    return Trajectory("straight", pts, lumen=np.full(len(x), 2.0 * radius), start_direction=(1.0, 0.0, 0.0))


def _poses(robot: Robot, tilts: np.ndarray, offset: float = 0.0) -> Poses:
    """Poses of ``tilts`` (P, M, 2), the feeder's axis ``offset`` mm to the -y side of the lumen's centerline."""
    frame = base_frame(np.array([1.0, 0.0, 0.0]))
    P, M = tilts.shape[:2]
    base = np.array([0.0, -offset, 0.0])
    pts = chain_points(np.broadcast_to(base, (P, 3)), frame, tilts, robot.module_length)
    return Poses(np.arange(P, dtype=float), np.zeros(P), pts, tilts, np.zeros((P, M), dtype=np.int64),
                 np.arange(1, P + 1), base, frame, robot.module_length)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), passive=st.integers(0, 7))
def test_clear_of_the_wall_the_passive_body_is_straight_and_the_head_keeps_its_codes(seed, passive):
    rng = np.random.default_rng(seed)
    robot = Robot(modules=8, module_length=5.0, robot_radius=2.0, alpha=10.0)
    codes = rng.choice([0, 3, 6, 9, 12], (2, 8))  # the thesis's tilts (and rest), alpha 10 deg: clear of a 60 mm lumen
    tilts = code_tilts(codes, np.radians(robot.alpha))
    rep = replay_poses(_poses(robot, tilts), SimpleNamespace(trajectory=_lumen(30.0), robot=robot),
                       passive_modules=passive)
    built = tilts.copy()
    built[:, :passive] = 0.0
    want = chain_points(np.zeros((2, 3)), base_frame(np.array([1.0, 0.0, 0.0])), built, robot.module_length)
    assert np.all(rep.total_force_n == 0.0)
    assert np.abs(rep.points_mm - want).max() < 1e-6
    assert rep.settings["passive_modules"] == passive


def test_none_passive_is_the_replay_without_the_option():
    robot = Robot(modules=10, module_length=5.0, robot_radius=5.0, alpha=10.0)
    run = SimpleNamespace(trajectory=_lumen(6.0), robot=robot)
    p = _poses(robot, np.zeros((1, 10, 2)), offset=3.0)
    a, b = replay_poses(p, run), replay_poses(p, run, passive_modules=0, passive_rigidity=1.0)
    assert np.array_equal(a.points_mm, b.points_mm) and np.array_equal(a.total_force_n, b.total_force_n)
    assert a.total_force_n[0] > 0.0


def test_a_softer_passive_body_gives_way_to_the_wall_and_a_rigid_one_loads_it_by_depth():
    # the whole robot's feeder axis 2 mm into the wall's -y side: held straight, it loads the wall with
    # k x 2 mm x 50 mm; a passive body as soft as a thin tube bends away from it and loads it less
    robot = Robot(modules=10, module_length=5.0, robot_radius=5.0, alpha=10.0)
    run = SimpleNamespace(trajectory=_lumen(6.0), robot=robot)
    p = _poses(robot, np.zeros((1, 10, 2)), offset=3.0)
    loads = [float(replay_poses(p, run, wire_force=1e6, passive_modules=9, passive_rigidity=ei).total_force_n[0])
             for ei in (1e9, PASSIVE_RIGIDITY_NMM2, 50.0)]
    assert loads[0] == pytest.approx(DEFAULT_WALL_STIFFNESS * 2.0 * 50.0, rel=0.1)
    assert loads[0] > loads[1] > loads[2] > 0.0
    assert passive_stiffness(5.0) == pytest.approx(PASSIVE_RIGIDITY_NMM2 / 5.0)


@pytest.mark.parametrize("passive", [10, 11, -1, 2.5])
def test_a_passive_body_the_robot_cannot_have_is_refused_in_one_line(passive):
    robot = Robot(modules=10, module_length=5.0, robot_radius=5.0, alpha=10.0)
    with pytest.raises(BhrError) as e:
        replay_poses(_poses(robot, np.zeros((1, 10, 2))), SimpleNamespace(trajectory=_lumen(6.0), robot=robot),
                     passive_modules=passive)
    assert "--passive-modules" in str(e.value) and "\n" not in str(e.value) and "0 to 9" in str(e.value)
