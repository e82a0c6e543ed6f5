"""The workspace of a binary robot: the enumeration kernel and the sampling kernel against numpy forward
kinematics of every pose, the indices, the pose and workspace figures, and the layers (no matplotlib to load)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr._kinematics.frames import fk_reference
from bhr._kinematics.reach import enumerate_tips, tips_of_codes, tips_reference
from bhr.model._robot import Robot, base_frame
from bhr.model._workspace import LIFT_CHOICES, TILT_CHOICES, workspace
from bhr._settings.errors import BhrError


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 4), lift=st.booleans(), alpha=st.floats(1.0, 60.0), length=st.floats(1.0, 20.0),
       lift_mm=st.floats(0.0, 3.0), direction=st.sampled_from([(1, 0, 0), (0, 1, 0), (0.3, -1, 2)]))
def test_enumeration_is_the_forward_kinematics_of_every_pose_in_order(n, lift, alpha, length, lift_mm, direction):
    choices = np.array(LIFT_CHOICES if lift else TILT_CHOICES, dtype=np.int64)
    frame = base_frame(direction)
    base = np.array([1.0, -2.0, 3.0])
    count = len(choices) ** n
    tips, dirs = np.empty((count, 3)), np.empty((count, 3))
    enumerate_tips(choices, n, base, frame, length, lift_mm, alpha, tips, dirs)
    want_t, want_d = tips_reference(choices, n, base, frame, length, lift_mm, alpha)
    assert np.abs(tips - want_t).max() < 1e-9 and np.abs(dirs - want_d).max() < 1e-12


@settings(max_examples=30, deadline=None)
@given(rows=st.lists(st.lists(st.sampled_from(LIFT_CHOICES), min_size=7, max_size=7), min_size=1, max_size=20),
       alpha=st.floats(1.0, 60.0))
def test_sampled_tips_are_the_forward_kinematics_of_their_codes(rows, alpha):
    codes = np.array(rows, dtype=np.int64)
    frame = base_frame((1, 0, 0))
    tips, dirs = np.empty((len(rows), 3)), np.empty((len(rows), 3))
    tips_of_codes(codes, np.zeros(3), frame, 10.0, 1.5, alpha, tips, dirs)
    for k, row in enumerate(codes):
        pts, frames = fk_reference(row, np.zeros(3), frame, 10.0, 1.5, alpha)
        assert np.abs(tips[k] - pts[-1]).max() < 1e-9 and np.abs(dirs[k] - frames[-1][2]).max() < 1e-12


@pytest.mark.parametrize("n,lift", [(1, True), (2, False), (3, True), (4, False)])
def test_exact_workspace_has_every_pose_and_counts_coinciding_tips_once(n, lift):
    robot = Robot(modules=n, alpha=15)
    ws = workspace(robot, lift=lift)
    choices = LIFT_CHOICES if lift else TILT_CHOICES
    assert ws.exact and ws.poses == ws.evaluated == len(choices) ** n
    tips = {tuple(np.round(robot.fk(list(c))[0][-1], 6)) for c in itertools.product(choices, repeat=n)}
    ix = ws.indices()
    assert ix["distinct_tips"] == len(tips) <= ws.poses
    assert ix["reach_max_mm"] == pytest.approx(n * (robot.module_length + (robot.lift if lift else 0.0)))
    cells, counts = ws.voxels()
    assert counts.sum() == ws.poses and ix["volume_mm3"] == pytest.approx(len(cells) * ws.voxel ** 3)


def test_two_modules_reach_a_tip_by_two_code_sequences():
    """A tilt of module 1 undone by module 2 puts the tip where module 2's tilt alone does: 25 poses, 21 tips."""
    ws = workspace(Robot(modules=2), lift=False)
    a, _ = Robot(modules=2).fk([3, 12])
    b, _ = Robot(modules=2).fk([0, 3])
    assert np.allclose(a[-1], b[-1])
    assert (ws.poses, ws.indices()["distinct_tips"]) == (25, 25 - 4)


def test_monte_carlo_samples_lie_in_the_exact_workspace():
    robot = Robot(modules=4, alpha=12)
    exact = {tuple(p) for p in np.round(workspace(robot).tips, 6)}
    ws = workspace(robot, exact=False, samples=3000, seed=5)
    assert not ws.exact and ws.evaluated == 3000 and ws.indices()["method"] == "monte carlo"
    assert all(tuple(p) in exact for p in np.round(ws.tips, 6))
    again = workspace(robot, exact=False, samples=3000, seed=5)
    assert np.array_equal(ws.tips, again.tips)


def test_resolution_shrinks_as_modules_are_added():
    """More binary modules place the tip more finely (the point of hyper-redundancy)."""
    res = [workspace(Robot(modules=n, alpha=20), lift=False).resolution()[0] for n in (3, 4, 5, 6)]
    assert all(b < a for a, b in zip(res, res[1:]))


def test_too_many_poses_to_enumerate_is_refused_with_the_fix():
    with pytest.raises(BhrError, match="sample them instead"):
        workspace(Robot(modules=12), exact=True)
    with pytest.raises(BhrError, match="samples"):
        workspace(Robot(modules=12), exact=False, samples=0)


def test_plot_pose_draws_each_module_with_its_radius(tmp_path):
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    robot = Robot(modules=4, robot_radius=3.0)
    from bhr.output import plot_pose

    fig = plot_pose(robot, [3, 0, 6, 15], tmp_path / "pose.png")
    assert isinstance(fig, Figure) and (tmp_path / "pose.png").stat().st_size > 10_000
    ax = fig.axes[0]
    tubes = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    assert len(tubes) == 4
    pts, _ = robot.fk([3, 0, 6, 15])
    from bhr.output._workspace_plot import cylinder_surface

    for a, b in zip(pts[:-1], pts[1:]):  # the surface drawn: every vertex one radius from its module's axis
        verts = np.stack([g.ravel() for g in cylinder_surface(a, b, robot.robot_radius)], axis=1)
        axis = (b - a) / np.linalg.norm(b - a)
        rel = verts - a
        radial = rel - np.outer(rel @ axis, axis)
        assert np.allclose(np.linalg.norm(radial, axis=1), 3.0)
        assert np.allclose(np.sort(np.unique(np.round(rel @ axis, 9))), [0.0, np.linalg.norm(b - a)])
    with pytest.raises(BhrError, match=".png, .svg or .pdf"):
        plot_pose(robot, [0, 0, 0, 0], tmp_path / "pose.jpg")


def test_workspace_figure_says_exact_or_sampled(tmp_path):
    from bhr.output._workspace_plot import save, workspace_figure

    fig = workspace_figure(workspace(Robot(modules=3)))
    assert "all 216 poses (exact)" in fig._suptitle.get_text()
    fig = workspace_figure(workspace(Robot(modules=3), exact=False, samples=100, seed=2))
    assert "100 random poses of 216 (Monte Carlo, seed 2)" in fig._suptitle.get_text()
    assert save(fig, tmp_path / "w.png").stat().st_size > 10_000
