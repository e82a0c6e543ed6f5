"""The physical robot's replay against the colon's wall (bhr._studies.physics, bhr physics).

A rigid chain held straight and pressed a known depth into one side of a straight lumen loads the wall with the
wall's stiffness x depth x contact length; the wall is the same for 5 and 6 mm modules; modules keep their length
at every pose (any codes, a hypothesis property); a robot clear of bhr's wall touches nothing and stays on its poses;
the wall's load converges as the motion between poses is refined; the command writes its set and refuses bad input in
one line.
"""
from __future__ import annotations

import json
import math
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import bhr
from bhr.model._path import Trajectory
from bhr.model._robot import Robot, base_frame
from bhr._run.driver import BhrWarning, load_run
from bhr._studies.physics import DEFAULT_WALL_STIFFNESS, Poses, poses_from_run, replay_physics, replay_poses
from bhr._studies.physics.poses import chain_points


def _straight_lumen(radius: float, length: float = 400.0) -> Trajectory:
    x = np.arange(0.0, length + 0.5, 0.5)
    pts = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    return Trajectory("straight", pts, lumen=np.full(len(x), 2.0 * radius), start_direction=(1.0, 0.0, 0.0))


def _straight_poses(robot: Robot, n: int, offset: float = 0.0) -> Poses:
    """One pose: the robot straight along +x from x = 0, its feeder's axis ``offset`` mm to the -y side of the
    lumen's centerline (so a robot of radius r in a lumen of radius R is offset + r - R into the wall's -y side,
    along its whole length)."""
    frame = base_frame(np.array([1.0, 0.0, 0.0]))
    tilts = np.zeros((1, n, 2))
    base = np.array([0.0, -offset, 0.0])
    pts = chain_points(base, frame, tilts[0], robot.module_length)[None]
    return Poses(np.zeros(1), np.zeros(1), pts, tilts, np.zeros((1, n), dtype=np.int64), np.array([1]), base, frame,
                 robot.module_length)


def _rigid(rep, length: float) -> None:
    seg = np.linalg.norm(np.diff(rep.points_mm, axis=1), axis=2)
    assert np.abs(seg - length).max() <= 1e-9, "a module changed its length"


@pytest.mark.parametrize("depth", [0.5, 2.0, 5.0])
def test_a_robot_pressed_into_a_straight_wall_loads_it_by_stiffness_depth_and_length(depth):
    robot = Robot(modules=10, module_length=5.0, robot_radius=5.0, alpha=10.0)
    run = SimpleNamespace(trajectory=_straight_lumen(6.0), robot=robot)
    # the wires made stiff enough that the robot stays straight: the wall's load alone is measured
    rep = replay_poses(_straight_poses(robot, 10, offset=1.0 + depth), run, wire_force=1e6)
    _rigid(rep, 5.0)
    contact = 50.0  # the whole robot presses the wall's -y side
    expected = DEFAULT_WALL_STIFFNESS * depth * contact
    assert abs(rep.total_force_n[0] - expected) <= 0.10 * expected, (rep.total_force_n[0], expected)
    assert abs(rep.stretch_mm[0] - depth) <= 0.05 * depth + 1e-3
    assert np.allclose(rep.module_force_n[0], rep.module_force_n[0].mean(), rtol=0.05)  # evenly along it
    assert rep.where_mm[0][1] < -depth  # on the -y side
    assert rep.module_force_n[0].sum() == pytest.approx(rep.total_force_n[0])
    assert rep.max_pressure_kpa[0] == pytest.approx(DEFAULT_WALL_STIFFNESS * rep.stretch_mm[0] / 10.0 * 1000, rel=1e-9)


def test_the_wall_does_not_change_with_the_module_length():
    """5 and 6 mm modules pressed 2 mm into the same wall: the same wall parameters, the same force per mm of
    contact (the wall used to be its stiffness divided by the module length)."""
    tr = _straight_lumen(6.0)
    force = []
    for length, n in ((5.0, 12), (6.0, 10)):  # both 60 mm long
        robot = Robot(modules=n, module_length=length, robot_radius=5.0, alpha=10.0)
        rep = replay_poses(_straight_poses(robot, n, offset=3.0), SimpleNamespace(trajectory=tr, robot=robot),
                           wire_force=1e6)
        _rigid(rep, length)
        assert rep.settings["wall_stiffness_n_per_mm2"] == DEFAULT_WALL_STIFFNESS
        force.append(rep.total_force_n[0])
    assert force[0] == pytest.approx(force[1], rel=0.02)
    assert force[0] == pytest.approx(DEFAULT_WALL_STIFFNESS * 2.0 * 60.0, rel=0.10)


def test_the_wires_yield_to_the_wall():
    """With the datasheet's wires the same press bends the robot away from the wall: less depth, less force."""
    robot = Robot(modules=10, module_length=5.0, robot_radius=5.0, alpha=10.0)
    run = SimpleNamespace(trajectory=_straight_lumen(6.0), robot=robot)
    stiff = replay_poses(_straight_poses(robot, 10, offset=3.0), run, wire_force=1e6)
    soft = replay_poses(_straight_poses(robot, 10, offset=3.0), run)
    _rigid(soft, 5.0)
    assert soft.total_force_n[0] < stiff.total_force_n[0]
    assert soft.deviation_mm[0] > 0.1 and stiff.deviation_mm[0] < 0.05


def _run(steps: int, body: int, seed: int = 7, alpha: float = 25.0, locomotion: str = "trail"):
    from bhr.model._generators import load_trajectory

    r = Robot(alpha=alpha, module_length=5.0)
    tr = load_trajectory("anatomy", feed=r.feed, seed=seed)
    cut = Trajectory(tr.name, tr.points[: steps + 10], dict(tr.params), tr.min_radius, tr.lumen[: steps + 10],
                     tr.source, tr.start_direction, tr.start_point)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        return bhr.follow(cut, solver="lumen", robot=r, body_modules=body, locomotion=locomotion)


def test_no_contact_where_bhrs_geometry_says_clear():
    """Poses clear of bhr's wall (its own tube and nearest-point kernel, sampled every 0.25 mm along every module)
    load nothing and the robot stays on them; a pose that goes into bhr's wall loads it."""
    from bhr.model._tube import _window_numpy, make_tube, nearest_kernel

    run = _run(240, 30)
    poses = poses_from_run(run)
    rep = replay_poses(poses, run)
    _rigid(rep, 5.0)
    tr = run.trajectory
    tube = make_tube(np.asarray(tr.points), np.asarray(tr.lumen), tr.start_direction, window_mm=1e4,
                     closed_end=True)
    C, R, radius = tube.points, tube.radius, run.robot.robot_radius
    lo, hi = _window_numpy(C.shape[0], float(C.shape[0]) / 2, tube.window)  # the whole tube
    s = np.linspace(0.0, 1.0, 21)
    clear = []
    for i in range(poses.points_mm.shape[0]):
        P = poses.points_mm[i]
        axis = (P[:-1, None] + s[None, :, None] * np.diff(P, axis=0)[:, None]).reshape(-1, 3)
        near = [nearest_kernel(C, R, lo, hi, float(x), float(y), float(z)) for x, y, z in axis]
        clear.append(min(r - radius - d for d, r, _ in near))
    clear = np.array(clear)
    first_touch = int(np.argmax(clear <= 0)) if np.any(clear <= 0) else len(clear)
    assert first_touch > 20
    assert np.all(rep.total_force_n[:first_touch] == 0.0)
    assert rep.deviation_mm[:first_touch].max() <= 1e-9
    if first_touch < len(clear):
        assert rep.total_force_n[first_touch] > 0.0


def test_the_wall_load_converges_as_the_motion_between_poses_is_refined():
    run = _run(400, 40, seed=4)
    poses = poses_from_run(run)
    a = replay_poses(poses, run, substeps=1)
    b = replay_poses(poses, run, substeps=4)
    _rigid(a, 5.0)
    _rigid(b, 5.0)
    fa, fb = float(a.total_force_n.max()), float(b.total_force_n.max())
    assert fb > 1.0, "this run should load the wall"
    assert abs(fa - fb) <= 0.10 * fb, (fa, fb)
    # and the equilibria are reached: the wall's depth is continuous, so no pose is held against a jump of it
    for rep in (a, b):
        assert rep.settings["equilibria_not_reached"] <= 0.01 * rep.settings["equilibria"], rep.settings


def test_physics_command_writes_its_set(run_bhr, tmp_path):
    run = _run(60, 20, locomotion="thesis")  # a cut trail run's summary names a feeder stop past its last step
    (tmp_path / "run.json").write_text(run.to_json())
    r = run_bhr("physics", "run.json", "--out", "phys")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "phys" / "physics.json").read_text())
    assert len(doc["steps"]) == run.steps and doc["bhr_version"] == bhr.__version__
    assert {"total_force_n", "max_module_force_n", "max_pressure_kpa", "stretch_mm", "deviation_mm"} <= set(doc["steps"][0])
    assert {"max_total_force_n", "contact_steps", "max_stretch_mm", "reached_cecum_step", "traversed"} <= set(doc["summary"])
    assert (tmp_path / "phys" / "force.png").stat().st_size > 10000
    assert (tmp_path / "phys" / "view.html").stat().st_size > 1e6
    assert "wall load at most" in r.stdout


def test_a_wires_run_is_replayed_from_its_poses_and_its_view_marks_each_steps_contacts(run_bhr, tmp_path):
    # a robot moved by its wires writes many poses a step, and none once its feeder stopped (the robot's length in):
    # the view's frames are the run's steps, each with the contacts of its own poses
    r = run_bhr("follow", "--traj", "anatomy", "--seed", "1", "--solver", "lumen", "--alpha", "25",
                "--module-length", "5", "--body-modules", "20", "--no-plots", "--out", "w")
    assert r.returncode == 0, r.stderr
    run = load_run(str(tmp_path / "w" / "run.json"))
    poses = np.load(tmp_path / "w" / "poses.npz")["step"]
    assert poses.max() < run.steps and len(poses) > poses.max()  # fewer steps with poses, more poses than those
    r = run_bhr("physics", "w/run.json", "--out", "phys")
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    rep = replay_physics(run, str(tmp_path / "w" / "run.json"))
    assert rep.deviation_mm[0] < 1e-9 and rep.total_force_n[0] == 0.0  # straight in the feeder: where it was written
    by_step = rep.contacts_by_step(run.steps)
    assert len(by_step) == run.steps
    for s in (int(k) for k in np.unique(rep.step)):
        want = [c for k, c in zip(rep.step, rep.contacts) if k == s and len(c)]
        assert np.array_equal(by_step[s - 1], np.vstack(want) if want else np.zeros((0, 3)))
    assert all(len(c) == 0 for c in by_step[int(rep.step.max()):])
    assert (tmp_path / "phys" / "view.html").stat().st_size > 1e5


@pytest.mark.parametrize("args,word", [
    (("missing.json", "--out", "p"), "missing.json"),
    (("run.json", "--out", "p", "--wall-stiffness", "0"), "wall"),
    (("run.json", "--out", "p", "--wall-stiffness", "50"), "wall"),
    (("run.json", "--out", "p", "--substeps", "x"), "substeps"),
    (("run.json", "--out", "p", "--passive-modules", "-1"), "passive-modules"),
    (("run.json", "--out", "p", "--passive-rigidity", "0"), "passive-rigidity"),
])
def test_physics_bad_input_one_line(run_bhr, tmp_path, args, word):
    (tmp_path / "run.json").write_text("{}")
    r = run_bhr("physics", *args)
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0] and "Traceback" not in r.stderr


def test_run_without_lumen_is_refused(run_bhr, tmp_path):
    run = bhr.follow(bhr.trajectory("line", length=20), solver="thesis")
    (tmp_path / "run.json").write_text(run.to_json())
    r = run_bhr("physics", "run.json", "--out", "p")
    assert r.returncode != 0 and "lumen" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_joint_stiffness_is_the_wires_pull_over_the_tilt():
    from bhr._studies.physics import WIRE_FORCE_N, joint_stiffness

    r = Robot(alpha=25.0, robot_radius=5.0)
    assert joint_stiffness(r) == pytest.approx(2 * WIRE_FORCE_N * 10.0 / math.radians(25.0))
    assert joint_stiffness(Robot(stroke=1.7365, lever=10.0)) == pytest.approx(
        2 * WIRE_FORCE_N * 10.0 / math.asin(0.17365))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(codes=st.lists(st.sampled_from([0, 3, 6, 12, 9]), min_size=3, max_size=12),
       lumen=st.floats(min_value=8.0, max_value=60.0), alpha=st.floats(min_value=5.0, max_value=30.0))
def test_any_codes_in_a_straight_lumen_keep_modules_rigid_and_load_only_where_bhrs_wall_is(codes, lumen, alpha):
    """Whatever the codes and the lumen: every module keeps its length, the wall's load is the sum of the
    modules', and a pose whose every axis point is clear of bhr's tube loads nothing and is kept exactly."""
    from bhr._studies.physics.poses import code_tilts

    n = len(codes)
    robot = Robot(modules=n, module_length=5.0, robot_radius=3.0, alpha=alpha)
    frame = base_frame(np.array([1.0, 0.0, 0.0]))
    tilts = code_tilts(np.array([codes]), math.radians(alpha))
    pts = chain_points(np.zeros(3), frame, tilts[0], 5.0)[None]
    poses = Poses(np.zeros(1), np.zeros(1), pts, tilts, np.array([codes]), np.array([1]), np.zeros(3), frame, 5.0)
    tr = _straight_lumen(lumen / 2.0)
    rep = replay_poses(poses, SimpleNamespace(trajectory=tr, robot=robot))
    _rigid(rep, 5.0)
    assert rep.total_force_n[0] == pytest.approx(rep.module_force_n[0].sum(), rel=1e-12, abs=1e-12)
    s = np.linspace(0.0, 1.0, 41)
    axis = (pts[0][:-1, None] + s[None, :, None] * np.diff(pts[0], axis=0)[:, None]).reshape(-1, 3)
    # the straight lumen's clearance: its radius - the robot's - the distance from the x axis (x >= 0 here)
    clear = lumen / 2.0 - 3.0 - np.hypot(axis[:, 1], axis[:, 2])
    if np.all(axis[:, 0] >= 0.0) and clear.min() > 0.0:
        assert rep.total_force_n[0] == 0.0 and rep.deviation_mm[0] <= 1e-9
    if clear.min() < -0.5:
        assert rep.total_force_n[0] > 0.0


def test_a_runs_poses_file_is_read_as_the_contract_says(tmp_path):
    """poses.npz beside run.json (t_s, insertion_mm, points_mm, tilts_rad, codes, step) is what the replay reads;
    a file with a wrong shape is refused in one line."""
    from bhr._studies.physics import load_poses, replay_physics
    from bhr._settings.errors import BhrError

    run = _run(30, 12)
    p = poses_from_run(run)
    (tmp_path / "run.json").write_text(run.to_json())
    arrays = {k: getattr(p, k) for k in ("t_s", "insertion_mm", "points_mm", "tilts_rad", "codes", "step")}
    np.savez(tmp_path / "poses.npz", **arrays)
    q = load_poses(tmp_path / "run.json", run)
    for k, v in arrays.items():
        assert np.array_equal(getattr(q, k), v)
    a, b = replay_physics(run, tmp_path / "run.json"), replay_poses(p, run)
    assert np.array_equal(a.points_mm, b.points_mm)
    np.savez(tmp_path / "poses.npz", **{**arrays, "codes": arrays["codes"][:, :-1]})
    with pytest.raises(BhrError) as e:
        load_poses(tmp_path / "run.json", run)
    assert "codes has shape" in str(e.value) and "\n" not in str(e.value)


def test_a_wires_run_in_memory_is_replayed_at_every_pose_and_a_replay_of_steps_says_so():
    # a study replays its runs in memory: a run moved by its wires is replayed at every pose it went through, as
    # its poses.npz would be (it was replayed from its steps, the joints moved linearly between them)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        tr = bhr.trajectory("anatomy", seed=1)
        wires = bhr.follow(tr, solver="lumen", alpha=25, module_length=5, body_modules=20)
        trail = bhr.follow(tr, solver="lumen", alpha=25, module_length=5, body_modules=20, locomotion="trail")
    rep = replay_physics(wires)
    assert rep.settings["poses_replayed"] == "every pose" and rep.total_force_n.size == wires.motion.t_s.size
    assert np.array_equal(rep.step, wires.motion.step) and rep.deviation_mm[0] < 1e-9
    assert replay_physics(trail).settings["poses_replayed"] == "steps"
