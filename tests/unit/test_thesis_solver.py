"""`--solver thesis` is the thesis's algorithm; `seed`, its former name, gives the same results bit for bit."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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




@pytest.mark.run  # twelve whole paths through the plain numpy loop (about 10 s of CPU): a run
@settings(max_examples=12, deadline=None)  # each example runs the numpy loop over a whole path
@given(radius=st.floats(30.0, 200.0), angle=st.floats(20.0, 330.0))
def test_the_compiled_thesis_loop_is_the_numpy_loop(radius, angle):
    """The compiled loop leaves out only work whose result is overwritten before it is read (the warm-up's last
    points, point 0 before the base is put back); the tip error of every step is the plain numpy loop's."""
    from bhr._bench.cases import numpy_seed_follow

    pts = bhr.trajectory("curve", radius=radius, angle=angle).points
    run = bhr.follow(pts)
    assert np.abs(run.point_errors_mm[:, -1] - numpy_seed_follow(pts)).max() < 1e-9
