"""bhr's robot in pinocchio and MuJoCo: the exported URDF/MJCF reproduce bhr's forward kinematics.

Real pinocchio and MuJoCo load the exported text; every module point and frame is compared with
:func:`bhr.model._robot.forward_kinematics` for random code sets (docs/export.md measures 1,000 per size).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import bhr
from bhr._settings.errors import BhrError
from bhr.model._export import MM, joint_names, joint_values, module_inertia, to_mjcf, to_urdf
from bhr.model._robot import Robot, forward_kinematics
from bhr.model._robotfile import load_robot_file

import mujoco
import pinocchio as pin
from bhr._studies.physics import fk_cross_check, pinocchio_points, pinocchio_q

CODES = (0, 3, 6, 12, 9, 15)


@pytest.mark.parametrize("modules,sets", [(5, 200), (60, 40), (300, 8)])
def test_fk_agrees_in_pinocchio_and_mujoco(modules, sets):
    got = fk_cross_check(modules, sets, seed=modules)
    assert got.pinocchio_mm <= 1e-9 and got.mujoco_mm <= 1e-9
    assert got.pinocchio_frame <= 1e-12 and got.mujoco_frame <= 1e-12


def test_pinocchio_data_free_fk_is_pinocchios_own():
    """The composition used for long robots equals pinocchio's framesForwardKinematics."""
    robot = Robot(modules=12, alpha=17)
    model = pin.buildModelFromXML(to_urdf(robot))
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = pinocchio_q(model, joint_values(rng.choice(CODES, 12), robot))
        a, fa = pinocchio_points(model, q, full=True)
        b, fb = pinocchio_points(model, q, full=False)
        assert np.abs(a - b).max() < 1e-12 and np.abs(fa - fb).max() < 1e-14


def test_rotated_base_matches_bhr_default_frame():
    """bhr's default chain along +X is the exported model placed with the base frame's rows as columns."""
    robot = Robot(modules=7)
    codes = [3, 6, 0, 12, 15, 9, 3]
    pts, frames = forward_kinematics(robot, codes)
    from bhr.model._robot import base_frame

    model = pin.buildModelFromXML(to_urdf(robot))
    p, f = pinocchio_points(model, pinocchio_q(model, joint_values(codes, robot)), full=True)
    R = base_frame((1, 0, 0)).T
    assert np.abs(p @ R.T - pts).max() < 1e-12
    assert np.abs(f @ R.T - frames).max() < 1e-14


def test_joint_order_and_names_in_both_engines():
    robot = Robot(modules=4)
    model = pin.buildModelFromXML(to_urdf(robot))
    assert list(model.names)[1:] == joint_names(4)
    m = mujoco.MjModel.from_xml_string(to_mjcf(robot))
    assert [m.joint(i).name for i in range(m.njnt)] == joint_names(4)
    assert joint_names(2) == ["m1_tilt_x", "m1_tilt_y", "m1_lift", "m2_tilt_x", "m2_tilt_y", "m2_lift"]


def test_limits_are_alpha_and_the_stroke():
    robot = Robot(modules=3, stroke=2.0, lever=8.0)
    a = math.radians(robot.alpha)
    model = pin.buildModelFromXML(to_urdf(robot))
    assert np.allclose(model.upperPositionLimit, [a, a, 2.0 * MM] * 3)
    assert np.allclose(model.lowerPositionLimit, [-a, -a, 0.0] * 3)
    m = mujoco.MjModel.from_xml_string(to_mjcf(robot))
    assert np.allclose(m.jnt_range, [[-a, a], [-a, a], [0, 2.0 * MM]] * 3)
    assert m.jnt_limited.all()


def test_files_load_without_warnings(capfd):
    robot = Robot(modules=30)
    pin.buildModelFromXML(to_urdf(robot)).createData()
    m = mujoco.MjModel.from_xml_string(to_mjcf(robot))
    d = mujoco.MjData(m)
    d.qpos[:] = joint_values([3, 6, 12, 9, 15, 0] * 5, robot)
    mujoco.mj_step(m, d)
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    assert not any(d.warning.number)  # MuJoCo's own warning counters


def test_mass_from_robot_file(tmp_path):
    f = tmp_path / "r.toml"
    f.write_text("modules = 3\n[mass]\nmodule_mass = 2.5\n")
    rf = load_robot_file(f)
    assert rf.mass == {"module_mass": 2.5}
    assert module_inertia(rf.robot, rf.mass["module_mass"]).mass == pytest.approx(0.0025)
    f.write_text("modules = 3\n[mass]\nmodule_mas = 2.5\n")
    with pytest.raises(BhrError, match="did you mean 'module_mass'"):
        load_robot_file(f)
    m = mujoco.MjModel.from_xml_string(to_mjcf(rf.robot, density=2000.0))
    assert m.body_mass[m.body("m1").id] == pytest.approx(2000.0 * math.pi * 0.005 ** 2 * 0.01)


def test_export_command_writes_files_that_load(run_bhr, tmp_path):
    r = run_bhr("export", "--format", "urdf", "--modules", "6", "--alpha", "12", "--out", "r.urdf")
    assert r.returncode == 0, r.stderr
    model = pin.buildModelFromXML((tmp_path / "r.urdf").read_text())
    assert model.nq == 18 and model.upperPositionLimit[0] == pytest.approx(math.radians(12))
    r = run_bhr("export", "--format", "MJCF", "--modules", "5", "--body-modules", "40", "--out", "r.xml")
    assert r.returncode == 0, r.stderr
    assert mujoco.MjModel.from_xml_path(str(tmp_path / "r.xml")).njnt == 120




@settings(max_examples=25, deadline=None)
@given(codes=st.lists(st.sampled_from(CODES), min_size=6, max_size=6),
       frame=st.sampled_from(["follow", "solve", "model", (1.0, -2.0, 0.5)]),
       base=st.tuples(*[st.floats(-500, 500, allow_nan=False)] * 3))
def test_base_transform_maps_pinocchio_and_mujoco_fk_to_bhrs_frames(codes, frame, base):
    """base_transform's 4x4 takes the exported model's FK (pinocchio and MuJoCo, in metres) onto bhr's FK in the
    named frame (Robot.fk along +X, bhr solve along +Y, any direction), base point in mm."""
    from bhr.model._export import BASE_DIRECTIONS, base_transform
    from bhr.model._robot import base_frame

    robot = Robot(modules=6, alpha=13)
    direction = BASE_DIRECTIONS[frame] if isinstance(frame, str) else frame
    want_pts, want_frames = forward_kinematics(robot, codes, base=base, frame=base_frame(direction))
    T = base_transform(frame, base)
    values = joint_values(codes, robot)
    model = pin.buildModelFromXML(to_urdf(robot))
    p_mm, f = pinocchio_points(model, pinocchio_q(model, values), full=True)
    p_m = np.c_[p_mm * MM, np.ones(len(p_mm))] @ T.T  # the model's metres through T
    assert np.abs(p_m[:, :3] / MM - want_pts).max() < 1e-9
    assert np.abs(f @ T[:3, :3].T - want_frames).max() < 1e-12
    Tmm = base_transform(frame, base, units="mm")
    assert np.abs(np.c_[p_mm, np.ones(len(p_mm))] @ Tmm.T - np.c_[want_pts, np.ones(len(want_pts))]).max() < 1e-9
    # MuJoCo: the base body placed by T (pos, quat) puts the model where bhr's FK is
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, T[:3, :3].ravel())
    xml = to_mjcf(robot).replace('<body name="base" pos="0 0 0" quat="1 0 0 0">',
                                 f'<body name="base" pos="{" ".join(repr(float(v)) for v in T[:3, 3])}" '
                                 f'quat="{" ".join(repr(float(v)) for v in quat)}">')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = values
    mujoco.mj_kinematics(m, d)
    from bhr._studies.physics import mujoco_points

    mp, mf = mujoco_points(m, d, 6)
    assert np.abs(mp - want_pts).max() < 1e-9
    assert np.abs(mf - want_frames).max() < 1e-12


def test_base_transform_of_the_solve_chain_and_robot_fk():
    """The chapter 5 chain of bhr solve starts straight along +Y; Robot.fk along +X: both from the model's +Z."""
    from bhr.model._export import base_transform

    assert np.array_equal(base_transform("solve")[:3, :3] @ [0, 0, 1], [0, 1, 0])
    assert np.array_equal(base_transform("follow")[:3, :3] @ [0, 0, 1], [1, 0, 0])
    assert np.array_equal(base_transform("model"), np.eye(4))
    res = bhr.solve([0, 10, 0], modules=5, module_length=2)  # on the straight chain's axis: stays straight
    tip = base_transform("solve", units="mm") @ [0, 0, 10, 1]
    assert np.allclose(res.points[-1], tip[:3])
    for bad, msg in (("folow", "unknown frame"), ((1, 0), "3 numbers")):
        with pytest.raises(BhrError, match=msg):
            base_transform(bad)
    with pytest.raises(BhrError, match="units"):
        base_transform("follow", units="cm")
