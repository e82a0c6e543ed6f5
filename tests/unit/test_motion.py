"""The robot as it can be built (bhr._run.motion): wires, joints, rigid chains, every pose written and scored."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import bhr
from bhr._kinematics.codetable import CODE_AXIS, VALID_CODES
from bhr.model._robot import base_frame
from bhr.model._wires import DEFAULT_THERMAL, contraction_reference, transform_thetas
from bhr._run.driver import follow
from bhr._run.motion import (MAX_JOINT_STEP_MM, chain_poses, code_wires, contraction, joint_tilts, switch_times,
                            wire_states)
from bhr.solvers._trail import trail_vertices

ALPHAS = st.floats(5.0, 35.0)
TILT_CODES = [0, 3, 6, 12, 9]


def test_codes_give_their_tilts_all_four_none():
    for code in VALID_CODES:
        t = joint_tilts(np.array(code_wires(code), dtype=float), 25.0)
        if code in CODE_AXIS:
            axis, sign = CODE_AXIS[code]
            want = np.zeros(2)
            want[axis] = sign * math.radians(25.0)
            assert np.allclose(t, want, atol=1e-15)
        else:  # rest and the lift: no tilt
            assert np.allclose(t, 0.0, atol=1e-15)


@given(st.lists(st.floats(0.0, 1.0), min_size=4, max_size=4), ALPHAS)
def test_a_joint_never_tilts_more_than_alpha(s, alpha):
    t = joint_tilts(np.array(s), alpha)
    assert np.linalg.norm(t) <= math.radians(alpha) * (1 + 1e-12)


def test_contraction_has_the_transformation_hysteresis():
    thetas = transform_thetas(DEFAULT_THERMAL)
    a_s, a_f, m_s, m_f = thetas
    assert m_f < m_s < a_s < a_f == 1.0
    assert math.isclose(m_f, DEFAULT_THERMAL.theta_relax)
    up = np.linspace(0.0, 1.2, 61)
    heat = contraction_reference(up, thetas, 0.0)
    cool = contraction_reference(up[::-1], thetas, 1.0)[::-1]
    # heating from cold: nothing until As, all by Af; cooling from hot: all until Ms, nothing by Mf
    mid = (m_s + a_s) / 2
    k = int(np.argmin(np.abs(up - mid)))
    assert heat[k] == 0.0 and cool[k] == 1.0
    assert heat[-1] == 1.0 and cool[0] == 0.0
    assert all(a <= b for a, b in zip(heat, heat[1:]))  # monotone on a monotone path
    for th, want in zip(up, heat):  # the compiled branch is the reference's
        assert contraction(0.0, th, *thetas) == pytest.approx(want, abs=1e-15)


def test_switching_ends_on_the_new_code_with_the_board_drive():
    window, delay = switch_times(DEFAULT_THERMAL)
    assert window >= DEFAULT_THERMAL.relax_ms  # the old wires have relaxed when a group's window ends
    old, new = [3, 3, 12, 0, 6], [6, 12, 12, 9, 0]
    s_end = wire_states(old, new, window, 0.0)
    assert np.array_equal(s_end, np.array([code_wires(c) for c in new], dtype=float))
    s_start = wire_states(old, new, 0.0, 0.0)
    assert np.array_equal(s_start, np.array([code_wires(c) for c in old], dtype=float))
    # in between a joint going from +x to +y passes through tilts no code gives, never more than alpha
    for t in np.linspace(0.0, window, 23):
        s = wire_states([3], [6], t, 0.0)
        assert np.linalg.norm(joint_tilts(s, 25.0)) <= math.radians(25.0) + 1e-12


@settings(max_examples=40, deadline=None)
@given(st.lists(st.lists(st.floats(0.0, 1.0), min_size=4, max_size=4), min_size=1, max_size=400), ALPHAS,
       st.floats(2.0, 12.0))
def test_every_chain_is_rigid_and_bends_within_the_wires(wires, alpha, L):
    tilts = joint_tilts(np.array(wires), alpha)
    pts = chain_poses(np.zeros(3), base_frame((1.0, 0.0, 0.0)), L, tilts)
    seg = np.diff(pts, axis=0)
    assert np.max(np.abs(np.linalg.norm(seg, axis=1) - L)) <= 1e-6
    u = seg / np.linalg.norm(seg, axis=1)[:, None]
    bend = np.degrees(np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1.0, 1.0)))
    most = math.degrees(math.acos(math.cos(math.radians(alpha)) ** 2))
    assert bend.size == 0 or bend.max() <= most + 1e-6


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), alpha=ALPHAS, delay=st.floats(0.0, 900.0))
def test_the_motion_kernel_gives_the_wires_and_the_chain_of_the_references_bit_for_bit(seed, alpha, delay):
    """motion_kernel computes once what does not change in time (a heating wire's state when energised, a cold
    wire's, a steady joint's turn, the frames behind the first joint that turned since the pose before): every
    pose's tilts are those of _wire, module by module, and its points chain_kernel's, bit for bit."""
    from bhr._run.motion import WIRE_DIRECTIONS, _heat_start, _wire, motion_kernel, wire_prm

    rng = np.random.default_rng(seed)
    M, K, L = 24, 40, 5.0
    prm = wire_prm(DEFAULT_THERMAL)
    window, _ = switch_times(DEFAULT_THERMAL)
    a = math.radians(alpha)
    code_old = rng.choice(TILT_CODES, M).astype(np.int64)
    code_new = code_old.copy()
    change = rng.random(M) < 0.4
    change[: int(rng.integers(0, M))] = False  # a steady part behind the first joint that changes, of any length
    code_new[change] = rng.choice(TILT_CODES, int(change.sum()))
    wires = np.array([code_wires(c) for c in range(16)], dtype=np.bool_)
    on_old, on_new = wires[code_old], wires[code_new]
    th0 = np.where(on_old, 1.0, 0.0)
    s0 = th0.copy()
    warm = rng.random((M, 4)) < 0.2  # some wires not yet settled from the module length before
    th0[warm] = rng.random(int(warm.sum()))
    s0[warm] = rng.random(int(warm.sum()))
    tsw = np.where(code_new != code_old, rng.choice([0.0, 0.4 * window, window], M), np.inf)
    times = np.sort(np.concatenate([rng.random(K - 10) * 2.5 * window, np.repeat(rng.random(5) * window, 2)]))
    xs = np.where(rng.random(K) < 0.5, L * M, L * M + rng.random(K) * L)
    axis = np.array([0.0, 0.0, 1.0])
    frame = base_frame(axis)
    start = np.array([1.0, 2.0, 3.0])
    T = np.cumsum(rng.normal(size=(2 * M + 8, 3)), axis=0)
    z = np.arange(T.shape[0], dtype=np.float64)
    C = np.cumsum(np.ones((8, 3)), axis=0)
    out = (np.empty((K, M + 1, 3)), np.empty((K, M, 2)), np.empty((K, M), dtype=np.int64), np.empty(K), np.empty(K))
    motion_kernel(times, xs, tsw, delay, th0, s0, on_old, on_new, code_old, code_new, prm, start, axis, frame, L, a,
                  T, M + 2, z, C, np.ones(8), np.arange(8.0), np.zeros((2, 3)), np.ones(2), 0.0, 3.0, -1.0, *out)
    pts, tilts = out[0], out[1]
    wst = np.empty(2)
    for j in range(K):
        want = np.empty((M, 2))
        for i in range(M):
            if not (on_old[i] != on_new[i]).any() and np.array_equal(s0[i], np.where(on_old[i], 1.0, 0.0)):
                want[i] = 0.0
                for k in range(4):
                    if on_old[i, k]:
                        want[i] += a * WIRE_DIRECTIONS[k]
                continue
            tx = ty = 0.0
            for k in range(4):
                th = _heat_start(on_old[i, k], on_new[i, k], tsw[i], delay, th0[i, k], prm)
                _wire(on_old[i, k], on_new[i, k], tsw[i], th, th0[i, k], s0[i, k], times[j], prm, wst)
                tx += WIRE_DIRECTIONS[k, 0] * wst[1]
                ty += WIRE_DIRECTIONS[k, 1] * wst[1]
            want[i] = (a * tx, a * ty)
        assert np.array_equal(tilts[j], want)
        tail = start + (xs[j] - M * L) * axis
        assert np.array_equal(pts[j], chain_poses(tail, frame, L, tilts[j]))


@settings(max_examples=25, deadline=None)
@given(st.lists(st.sampled_from(TILT_CODES), min_size=2, max_size=300), ALPHAS)
def test_codes_lay_the_trail_exactly(codes, alpha):
    codes = np.array(codes)
    M = len(codes)
    T = trail_vertices(codes, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), 5.0, alpha, 0)
    s = np.array([code_wires(c) for c in codes], dtype=float)
    pts = chain_poses(T[0], base_frame((1.0, 0.0, 0.0)), 5.0, joint_tilts(s, alpha))
    assert np.max(np.abs(pts - T[:M + 1])) <= 1e-9


@pytest.fixture(scope="module")
def wires_run():
    tr = bhr.trajectory("anatomy", seed=2)
    return follow(tr, solver="lumen", alpha=25, module_length=5, body_modules=30)


@pytest.mark.run
def test_a_whole_robot_moves_by_its_wires_by_default(wires_run):
    assert wires_run.extra["summary"]["locomotion"] == "wires"
    assert wires_run.motion is not None


@pytest.mark.run
def test_every_written_pose_is_a_rigid_chain_within_the_wires(wires_run):
    mo = wires_run.motion
    L, alpha = 5.0, 25.0
    seg = np.diff(mo.points_mm, axis=1)
    assert np.max(np.abs(np.linalg.norm(seg, axis=2) - L)) <= 1e-6
    u = seg / np.linalg.norm(seg, axis=2)[..., None]
    bend = np.degrees(np.arccos(np.clip(np.sum(u[:, 1:] * u[:, :-1], axis=2), -1.0, 1.0)))
    assert bend.max() <= math.degrees(math.acos(math.cos(math.radians(alpha)) ** 2)) + 1e-6
    assert np.linalg.norm(mo.tilts_rad, axis=2).max() <= math.radians(alpha) + 1e-12
    # the tail lies in the feeder, straight along the insertion axis
    d = mo.points_mm[:, 1] - mo.points_mm[:, 0]
    assert np.allclose(d / L, np.array(wires_run.trajectory.start_direction)[None, :], atol=1e-9)


@pytest.mark.run
def test_no_joint_moves_more_than_2_mm_between_written_poses(wires_run):
    mo = wires_run.motion
    move = np.linalg.norm(np.diff(mo.points_mm, axis=0), axis=2)
    assert move.max() <= min(2.0, MAX_JOINT_STEP_MM + 1e-9)
    assert np.all(np.diff(mo.t_s) > 0) and np.all(np.diff(mo.insertion_mm) >= -1e-12)
    assert np.all(np.diff(mo.step) >= 0) and mo.step[0] == 1


@pytest.mark.run
def test_each_module_length_ends_on_the_trail(wires_run):
    mo = wires_run.motion
    assert np.max(mo.trail_offset_mm[mo.ends[:-1]]) <= 1e-6


def _brute(path, lumen, radius, points, closed=True):
    """Clearance of points against the whole centerline (no window), the lumen radius linear along it."""
    a, b = path[:-1], path[1:]
    u = b - a
    uu = np.einsum("ij,ij->i", u, u)
    out = np.empty(len(points))
    for k, p in enumerate(points):
        t = np.clip(np.einsum("ij,ij->i", p - a, u) / uu, 0.0, 1.0)
        d = np.linalg.norm(p - (a + t[:, None] * u), axis=1)
        j = int(np.argmin(d))
        out[k] = lumen[j] / 2 + t[j] * (lumen[j + 1] - lumen[j]) / 2 - radius - d[j]
    return out


@pytest.mark.run
def test_clearance_of_the_written_poses_agrees_with_an_independent_one(wires_run):
    """Dense samples along every module of every written pose (0.25 mm), the nearest point of the whole
    centerline refined as bhr's (a Catmull-Rom spline, <= 1 mm): bhr's minimum within 0.5 mm, same touches."""
    from bhr.solvers._trail import dense_tube

    tr = wires_run.trajectory
    tube = dense_tube(tr.points, tr.lumen, tr.start_direction, 40.0)
    C = tube.points[tube.pre:]
    Rd = 2 * tube.radius[tube.pre:]
    mo = wires_run.motion
    radius = wires_run.robot.robot_radius
    rng = np.random.default_rng(0)
    # every pose of the run is too many for numpy here: the worst 40 by bhr plus 40 at random
    worst = np.argsort(np.where(np.isnan(mo.pose_clear), np.inf, mo.pose_clear))[:40]
    pick = np.unique(np.concatenate([worst, rng.choice(len(mo.t_s), 40, replace=False)]))
    f = np.linspace(0.0, 1.0, 21)
    for p in pick:
        P = mo.points_mm[p]
        inside = mo.insertion_mm[p] - (P.shape[0] - 1 - np.arange(P.shape[0])) * 5.0 >= 0.0
        samples = (P[:-1, None] + f[None, :, None] * (P[1:] - P[:-1])[:, None])[inside[:-1] & inside[1:]]
        if not samples.size:
            continue
        mine = _brute(C, Rd, radius, samples.reshape(-1, 3)).min()
        bhrs = mo.pose_clear[p]
        assert abs(mine - bhrs) <= 0.5, (p, mine, bhrs)
        assert (mine <= 0.0) == (bhrs <= 0.0) or abs(mine) < 0.05


@pytest.mark.run
def test_the_run_scores_the_poses(wires_run):
    s = wires_run.summary.extra
    mo = wires_run.motion
    assert s["min_clearance_mm"] == pytest.approx(float(np.nanmin(mo.pose_clear)))
    with np.errstate(invalid="ignore"):
        touched = set(int(k) for k in mo.step[mo.pose_clear <= 0.0])
    # every step with a pose in the wall is a wall-touch step, and every touch step has one (or holds one)
    stop = s["feeder_stop_step"]
    assert touched == {k for k in s["wall_touch_steps"] if k <= stop}
    assert s["poses"] == mo.points_mm.shape[0]


def test_a_pose_deeper_in_the_wall_than_the_robot_radius_has_left_the_lumen():
    """The first step with a written pose whose joint or module is more than the robot's radius into the wall is the
    step the run left the lumen (docs/lumen.md's left_lumen_step), as for the thesis's model."""
    run = follow(bhr.trajectory("anatomy", seed=1), solver="lumen", alpha=25, module_length=5, body_modules=30)
    s = run.summary.extra
    mo = run.motion
    radius = run.robot.robot_radius
    with np.errstate(invalid="ignore"):
        deep = sorted(set(int(k) for k in mo.step[mo.pose_clear < -radius]))
    assert deep, "this run should go deeper than the robot's radius into the wall"
    assert s["left_lumen_step"] == deep[0]
    assert s["left_lumen_reason"].startswith(f"left the lumen at step {deep[0]}: ")


def test_stop_at_wall_ends_a_wires_run_where_it_leaves_the_lumen_as_the_whole_runs_first_steps():
    """A study that must not score impossible poses ends each run where the robot left the lumen: the run stopped
    there is the whole run's first steps (a pose depends only on the poses before it), poses and tables alike."""
    tr = bhr.trajectory("anatomy", seed=1)
    whole = follow(tr, solver="lumen", alpha=25, module_length=5, body_modules=30)
    cut = follow(tr, solver="lumen", alpha=25, module_length=5, body_modules=30, stop_at_wall=True)
    k = whole.summary.extra["left_lumen_step"]
    assert k is not None and 1 < k < whole.steps
    assert cut.steps == k and cut.finished == "stopped at the wall" and cut.status == "left the lumen"
    s = cut.summary.extra
    assert s["stopped_at_wall_step"] == k and s["path_steps"] == whole.steps and s["left_lumen_step"] == k
    assert np.array_equal(cut.points, whole.points[:k]) and np.array_equal(cut.codes, whole.codes[:k])
    assert np.array_equal(cut.body.points, whole.body.points[:k])
    for name in ("joint_clear", "module_clear", "module_where", "step_joints", "step_codes"):
        np.testing.assert_array_equal(getattr(cut.motion, name), getattr(whole.motion, name)[:k], err_msg=name)
    P = cut.motion.points_mm.shape[0]
    np.testing.assert_array_equal(cut.motion.points_mm, whole.motion.points_mm[:P])
    assert cut.motion.step[-1] == k and whole.motion.step[P] == k + 1  # the poses of step k, whole, and no more
    np.testing.assert_array_equal(cut.point_errors_mm, whole.point_errors_mm[:k])
    assert cut.clearance.touch_steps == [t for t in whole.clearance.touch_steps if t <= k]
    with pytest.raises(bhr.BhrError, match="trail model is an idealisation"):
        follow(tr, solver="lumen", body_modules=30, locomotion="trail", stop_at_wall=True)


@pytest.mark.run
def test_past_the_pose_limit_a_run_keeps_its_poses_only_when_asked(monkeypatch):
    """Past POSE_POINTS_LIMIT robot points a run scores every pose but keeps none (a 1.5 m robot's take about 5 GB),
    and a physics replay reads its steps; all_poses keeps every one: the same poses, scored the same."""
    import bhr._run.motion as motion
    from bhr._studies.follow_run import body_clearance_lines
    from bhr._studies.physics.poses import poses_from_motion

    tr = bhr.trajectory("anatomy", seed=1)
    kw = dict(solver="lumen", alpha=25, module_length=5, body_modules=30, stop_at_wall=True)
    under = follow(tr, **kw)
    P, J = under.motion.points_mm.shape[:2]
    monkeypatch.setattr(motion, "POSE_POINTS_LIMIT", P * J // 2)
    dropped = follow(tr, **kw)
    every = follow(tr, all_poses=True, **kw)
    assert under.motion.kept and every.motion.kept and not dropped.motion.kept
    assert dropped.motion.points_mm.shape[0] == 0 and dropped.summary.extra["poses_file"] is None
    assert every.summary.extra["poses_file"] == "poses.npz" and every.summary.extra["poses"] == P
    assert "--all-poses writes them" in " ".join(body_clearance_lines(dropped.summary.to_dict()))
    for name in ("points_mm", "tilts_rad", "codes", "step", "t_s", "insertion_mm"):
        np.testing.assert_array_equal(getattr(every.motion, name), getattr(under.motion, name), err_msg=name)
    for name in ("pose_clear", "joint_clear", "module_clear", "step_joints"):
        np.testing.assert_array_equal(getattr(dropped.motion, name), getattr(under.motion, name), err_msg=name)
    assert poses_from_motion(every) is not None and poses_from_motion(dropped) is None
    with pytest.raises(bhr.BhrError, match="the trail model has one pose a step.*drop --all-poses"):
        follow(tr, solver="lumen", body_modules=30, locomotion="trail", all_poses=True)
    with pytest.raises(bhr.BhrError, match="all_poses must be True or False"):
        follow(tr, solver="lumen", body_modules=30, all_poses="yes")


@pytest.mark.run
def test_a_robot_shorter_than_the_colon_is_stopped_by_its_tail_and_said_to_be_too_short(wires_run):
    """A feeder at the anus pushes the tail in no further than the robot's length: a robot shorter than the colon
    stops there, its tip far short of the cecum, and its summary says it is too short. One as long as the colon
    (reach cecum) is not, though its tip ends a little short along the centerline, about which it weaves."""
    s = wires_run.extra["summary"]  # 30 modules of 5 mm on a colon of about 1.9 m
    f = wires_run.robot.feed_divisor
    assert s["too_short_for_cecum"] is True and s["feeder_stop_step"] == 30 * f + 1
    assert s["cecum_shortfall_mm"] > 1000.0
    tr = bhr.trajectory("anatomy", seed=2)
    whole = follow(tr, solver="lumen", alpha=25, module_length=5, reach="cecum", stop_at_wall=True).extra["summary"]
    assert whole["too_short_for_cecum"] is False


@pytest.mark.run
def test_poses_file_keeps_its_contract(wires_run, tmp_path):
    from bhr.output._steptable import write_poses

    write_poses(wires_run, tmp_path / "poses.npz")
    d = np.load(tmp_path / "poses.npz")
    P = wires_run.motion.points_mm.shape[0]
    M = wires_run.motion.points_mm.shape[1] - 1
    assert d["t_s"].shape == (P,) and d["insertion_mm"].shape == (P,) and d["step"].shape == (P,)
    assert d["points_mm"].shape == (P, M + 1, 3) and d["tilts_rad"].shape == (P, M, 2)
    assert d["codes"].shape == (P, M) and set(np.unique(d["codes"])) <= set(VALID_CODES)
    # the feeder's insertion, as the replay reads it (docs/physics.md): how far the rear end is past the entrance
    # along the start direction (it was the tip's, M module lengths ahead, and the replay put the robot there)
    d0 = np.asarray(wires_run.trajectory.start_direction, dtype=np.float64)
    rear = (d["points_mm"][:, 0] - np.asarray(wires_run.trajectory.points[0])) @ (d0 / np.linalg.norm(d0))
    assert np.abs(d["insertion_mm"] - rear).max() < 1e-9 and d["insertion_mm"].max() <= 1e-9


@pytest.mark.run
def test_scoring_only_what_may_have_come_nearer_the_wall_gives_the_tables_of_scoring_everything():
    """A joint or module is scored again only when it may have come nearer the wall than its step's or its pose's
    worst since it was last scored (score_kernel's bound): every step's table and every pose's smallest are those
    of scoring every joint and module of every pose."""
    from bhr.model._robot import Robot
    from bhr._run.motion import wires_motion
    from bhr.solvers import get_solver

    tr = bhr.trajectory("anatomy", seed=1)
    robot = Robot(alpha=25.0, module_length=5.0)
    solver = get_solver("lumen", robot)
    fast = wires_motion(tr, robot, solver, 40)[0]
    ref = wires_motion(tr, robot, solver, 40, bound=False)[0]
    assert fast.points_mm.shape == ref.points_mm.shape and np.array_equal(fast.points_mm, ref.points_mm)
    np.testing.assert_array_equal(fast.joint_clear, ref.joint_clear)
    np.testing.assert_allclose(fast.module_clear, ref.module_clear, atol=1e-9)
    np.testing.assert_allclose(fast.pose_clear, ref.pose_clear, atol=1e-9)
    assert fast.crossed == ref.crossed
    # the robot left the lumen (its axis outside the wall): the poses after it, scored in the stretch of lumen
    # each point is in, are held to the same tables
    assert np.nanmin(ref.joint_clear) < -robot.robot_radius
