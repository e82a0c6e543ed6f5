"""`--solver thesis` is the thesis's algorithm; `seed`, its former name, gives the same results bit for bit."""

import numpy as np
import pytest

import bhr
from bhr.model._robot import Robot
from bhr.solvers import available, canonical, get_solver


def test_seed_is_an_alias_of_thesis():
    assert canonical("seed") == "thesis" and canonical("thesis") == "thesis"
    assert "thesis" in available() and "seed" not in available()
    assert type(get_solver("seed", Robot())) is type(get_solver("thesis", Robot()))


@pytest.mark.parametrize("traj", ["curve", "spiral"])
def test_follow_thesis_equals_seed_bit_for_bit(traj):
    pts = bhr.trajectory(traj)
    a, b = bhr.follow(pts, solver="thesis"), bhr.follow(pts, solver="seed")
    assert np.array_equal(a.points, b.points) and np.array_equal(a.point_errors_mm, b.point_errors_mm)
    assert np.array_equal(a.orientation_errors_deg, b.orientation_errors_deg) and np.array_equal(a.codes, b.codes)


