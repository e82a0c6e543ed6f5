"""The wall's depth in the physics replay is continuous in the robot's position: no jump where two stretches of the
centerline are equally near and the lumen's radius differs between them (the inner side of a bend that narrows)."""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr._studies.physics.equilibrium import _depth


def _bend(turn_deg: float, r0: float, r1: float, r2: float) -> tuple[np.ndarray, np.ndarray]:
    """Two 10 mm segments meeting at the origin at ``turn_deg``, the lumen's radius r0, r1, r2 at their points."""
    a = math.radians(turn_deg)
    C = np.array([[-10.0, 0.0, 0.0], [0.0, 0.0, 0.0], [10.0 * math.cos(a), 10.0 * math.sin(a), 0.0]])
    return C, np.array([r0, r1, r2])


@settings(max_examples=500, deadline=None)
@given(turn=st.floats(20.0, 150.0), r0=st.floats(4.0, 12.0), r1=st.floats(4.0, 12.0), r2=st.floats(4.0, 12.0),
       x=st.floats(-8.0, 2.0), y=st.floats(-2.0, 8.0), z=st.floats(-3.0, 3.0),
       dx=st.floats(-1.0, 1.0), dy=st.floats(-1.0, 1.0))
def test_the_depth_moves_no_faster_than_the_point_and_the_radius_slope(turn, r0, r1, r2, x, y, z, dx, dy):
    """Around the bend's vertex, on its inner side too (x < 0 < y: between the two segments)."""
    C, R = _bend(turn, r0, r1, r2)
    slope = max(abs(r1 - r0), abs(r2 - r1)) / 10.0
    a = _depth(C, R, 0, 2, x, y, z, 5.0)
    b = _depth(C, R, 0, 2, x + dx, y + dy, z, 5.0)
    step = math.hypot(dx, dy)
    assert abs(a[0] - b[0]) <= (1.0 + slope) * step + 1e-9, (a, b)


def test_the_depth_is_the_nearest_segments_where_the_radius_is_the_same():
    C, R = _bend(60.0, 8.0, 8.0, 8.0)
    for p in [(-5.0, 3.0, 0.0), (3.0, 7.0, 1.0), (-1.0, -2.0, 0.5)]:
        pen, k, t, d = _depth(C, R, 0, 2, *p, 5.0)
        near = min(np.linalg.norm(np.asarray(p) - (C[j] + s * (C[j + 1] - C[j])))
                   for j in range(2) for s in np.linspace(0.0, 1.0, 20001))
        assert abs(d - near) < 1e-6 and abs(pen - (near + 5.0 - 8.0)) < 1e-6
