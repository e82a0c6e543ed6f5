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


def _nearest_axis_every_acos(a: np.ndarray, g: np.ndarray) -> int:
    """The thesis's rule as it reads: the first of the four axes of least arc cosine, every arc cosine taken."""
    from bhr._kinematics.leader import acos_deg

    best, idx = 1e300, 0
    for q in range(4):
        aq = acos_deg(float(a[0] * g[q, 0] + a[1] * g[q, 1] + a[2] * g[q, 2]))
        if aq < best:
            best, idx = aq, q
    return idx


_unit = st.tuples(*[st.floats(-1.0, 1.0, allow_subnormal=False)] * 3).filter(lambda v: 1e-3 < np.linalg.norm(v))


@settings(max_examples=400, deadline=None)
@given(a=_unit, e1=_unit, e2=_unit, tie=st.sampled_from(["none", "e2=e1", "e2=-e1", "a=e1", "a between", "a ulp off"]))
def test_nearest_axis_is_the_every_arc_cosine_rule(a, e1, e2, tie):
    """The thesis's axis choice with fewer arc cosines picks the same axis, ties (equal and within rounding of
    each other), clamped cosines and an axis on the rotation axis included."""
    from bhr.solvers._thesis import nearest_axis

    u = lambda v: np.asarray(v) / np.linalg.norm(v)  # noqa: E731
    a, e1, e2 = u(a), u(e1), u(e2)
    if tie == "e2=e1":
        e2 = e1.copy()
    elif tie == "e2=-e1":
        e2 = -e1
    elif tie == "a=e1":
        a = e1.copy()
    elif tie == "a between":
        a = u(e1 + e2) if np.linalg.norm(e1 + e2) > 1e-3 else a
    elif tie == "a ulp off":
        a = np.nextafter(e1, 2.0)
    g = np.array([e1, e2, -e1, -e2])
    assert nearest_axis(a[0], a[1], a[2], g) == _nearest_axis_every_acos(a, g)
