"""bhr's robot in pinocchio and MuJoCo: the exported URDF/MJCF reproduce bhr's forward kinematics: the tests that run in-process."""
from __future__ import annotations
import math
import xml.etree.ElementTree as ET
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
import bhr
from bhr._settings.errors import BhrError
from bhr.model._export import FORMATS, MM, joint_values, module_inertia, to_urdf
from bhr.model._robot import Robot
from bhr.model._codes import VALID_CODES as CODES  # the six stable codes


def test_urdf_is_well_formed_with_masses():
    robot = Robot(modules=3)
    root = ET.fromstring(to_urdf(robot))
    links = {e.get("name"): e for e in root.iter("link")}
    assert {"base", "m1", "m1_tx", "m1_ty", "m3", "tip"} <= set(links)
    inert = module_inertia(robot)
    mass = float(links["m2"].find("inertial/mass").get("value"))
    assert mass == pytest.approx(1240.0 * math.pi * 0.005 ** 2 * 0.01)
    assert mass == pytest.approx(inert.mass)
    assert inert.izz == pytest.approx(inert.mass * 0.005 ** 2 / 2)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(CODES), min_size=1, max_size=12), st.floats(1.0, 60.0))
def test_joint_values_follow_the_code_table(codes, alpha):
    robot = Robot(modules=len(codes), alpha=alpha)
    v = joint_values(codes, robot).reshape(-1, 3)
    a = math.radians(alpha)
    expect = {0: (0, 0, 0), 3: (a, 0, 0), 12: (-a, 0, 0), 6: (0, a, 0), 9: (0, -a, 0), 15: (0, 0, robot.lift * MM)}
    assert np.array_equal(v, np.array([expect[c] for c in codes], dtype=float))
    # one tilt at most per module: two revolute joints in series are exactly bhr's tilt
    assert (np.count_nonzero(v[:, :2], axis=1) <= 1).all()


def test_joint_values_of_rows_and_bad_codes():
    rows = joint_values([[0, 3], [6, 15]], Robot(modules=2))
    assert rows.shape == (2, 6)
    assert np.array_equal(rows[1], joint_values([6, 15], Robot(modules=2)))
    assert bhr.joint_values is joint_values
    with pytest.raises(BhrError):
        joint_values([0, 5])
    with pytest.raises(BhrError):
        joint_values([])


def test_formats():
    assert FORMATS == ("urdf", "mjcf")
