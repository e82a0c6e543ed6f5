"""The racing line (bhr/model/_racing.py) and --solver lumen's racing_weight (bhr/solvers/_lumen.py)."""
from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bhr._bench.lumen import tight_colon
from bhr.model._racing import head_radius_mm, line_curvature, racing_line, transport_frames
from bhr.model._robot import Robot, forward_kinematics
from bhr._run.clearance import make_tube
from bhr._run.driver import follow
from bhr._settings.options import BY_NAME
from bhr.solvers._lumen import DEFAULTS, head_cost, lumen_config_cost, planned_line

CODES = (0, 3, 6, 12, 9)


def bend(radius: float, angle_deg: float, straight: float = 100.0, h: float = 2.0) -> np.ndarray:
    """A planar centerline: a straight, an arc of ``radius`` turning by ``angle_deg``, a straight."""
    pts = [[0.0, y, 0.0] for y in np.arange(-straight, 0.0, h)]
    a = math.radians(angle_deg)
    n = max(2, int(round(a * radius / h)))
    for i in range(n + 1):
        th = a * i / n
        pts.append([radius - radius * math.cos(th), radius * math.sin(th), 0.0])
    p = np.array(pts[-1])
    d = np.array([math.sin(a), math.cos(a), 0.0])
    pts += [list(p + d * j * h) for j in range(1, int(straight / h))]
    return np.array(pts)


def chord_radius(Q: np.ndarray, s: int = 5) -> float:
    """The tightest radius of the circles through points s apart (10 mm chords at 2 mm spacing)."""
    return float(1.0 / line_curvature(Q[::s]).max())


def offsets(C: np.ndarray, Q: np.ndarray) -> np.ndarray:
    return np.linalg.norm(Q - C, axis=1)


def test_the_head_bound():
    assert head_radius_mm(10.0, 10.0) == pytest.approx(57.37, abs=0.01)


def test_a_tight_bend_gets_a_much_wider_line_that_keeps_near_the_corridor():
    """A 90 deg bend of 15 mm radius, half-width 8 mm: the centerline bends at 15 mm; the racing line at more than
    three times that (the widest a circle through this corridor can be is about 66 mm), and leaves the corridor
    by little: the curvature above the bound is what it trades against."""
    C = bend(15.0, 90.0)
    W = np.full(C.shape[0], 8.0)
    Q = racing_line(C, W, 1.0 / head_radius_mm(10.0, 10.0))
    assert chord_radius(C) < 16.0
    assert chord_radius(Q) > 45.0
    assert float(np.max(offsets(C, Q) - W)) < 3.0
    # it goes outside, inside at the apex, outside: the apex is on the inner side (towards the bend's centre)
    apex = int(np.argmin(np.linalg.norm(C - np.array([15.0 - 15.0 / math.sqrt(2), 15.0 / math.sqrt(2), 0.0]), axis=1)))
    centre = np.array([15.0, 0.0, 0.0])
    assert np.linalg.norm(Q[apex] - centre) < np.linalg.norm(C[apex] - centre) - 4.0


def test_a_straight_lumen_keeps_the_centerline():
    C = np.stack([np.zeros(200), np.arange(200) * 2.0, np.zeros(200)], axis=1)
    Q = racing_line(C, np.full(200, 9.0), 1.0 / 57.4)
    assert float(offsets(C, Q).max()) < 1e-6


@settings(max_examples=15, deadline=None)
@given(radius=st.floats(20.0, 60.0), angle=st.floats(20.0, 120.0), width=st.floats(4.0, 12.0),
       roll=st.floats(0.0, 2 * math.pi))
def test_where_the_corridor_allows_the_bound_the_line_is_inside_it_and_no_tighter_than_the_centerline(
        radius, angle, width, roll):
    """Any bend, in any orientation: the racing line is no tighter than the centerline or the bound, whichever is
    wider (10 mm chords; below the bound curvature is free), and where the centerline itself keeps the bound it
    stays in the corridor (the corridor term is the only one then)."""
    c, s = math.cos(roll), math.sin(roll)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    C = bend(radius, angle) @ rot.T
    W = np.full(C.shape[0], width)
    kmax = 1.0 / 57.4
    Q = racing_line(C, W, kmax)
    assert chord_radius(Q) >= min(chord_radius(C), 1.0 / kmax) * 0.98
    if radius >= 1.0 / kmax:
        assert float(np.max(offsets(C, Q) - W)) < 1e-3


def test_frames_are_orthonormal_and_normal_to_the_centerline():
    C = tight_colon(3).points
    N1, N2 = transport_frames(C)
    T = np.gradient(C, axis=0)
    T /= np.linalg.norm(T, axis=1)[:, None]
    for a, b in ((N1, N2), (N1, T), (N2, T)):
        assert float(np.abs(np.einsum("ij,ij->i", a, b)).max()) < 1e-9
    assert np.allclose(np.linalg.norm(N1, axis=1), 1.0) and np.allclose(np.linalg.norm(N2, axis=1), 1.0)


@pytest.mark.run
@pytest.mark.parametrize("step", [60, 150])
def test_the_head_search_with_the_racing_term_is_the_exact_minimum(step):
    """With racing_weight on, branch and bound = the cheapest of all 5^(n-1) codes costed in numpy."""
    tight = tight_colon(1)
    robot = Robot(modules=4)
    cfg = dict(DEFAULTS, racing_weight=0.5, center_weight=0.0)
    tube = make_tube(tight.points, tight.lumen, tight.start_direction, cfg["window"], closed_end=True)
    line = planned_line(tube, robot, cfg["margin"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = follow(tight, solver="lumen", robot=robot, solver_options={"racing_weight": 0.5})
    P = run.points[step - 1]
    z = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
    base = P[0] + robot.feed * z
    x = np.cross([0.0, 0.0, 1.0], z) if abs(z[2]) < 0.9 else np.cross([1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    frame = np.stack([x, np.cross(z, x), z])
    codes, cost = head_cost(tube, robot, cfg, tight.points, step, base, frame, line)
    costs = {}
    for rest in itertools.product(CODES, repeat=robot.modules - 1):
        pts, _ = forward_kinematics(robot, [0, *rest], base, frame)
        costs[rest] = lumen_config_cost(tube, robot, cfg, tight.points, step, pts, line)
    best = min(costs.values())
    assert cost == pytest.approx(best, rel=1e-9, abs=1e-9)
    assert costs[tuple(codes)] == pytest.approx(best, rel=1e-9, abs=1e-9)
    # the term counts: without it the costs differ
    assert lumen_config_cost(tube, robot, dict(cfg, racing_weight=0.0), tight.points, step,
                             forward_kinematics(robot, [0, *codes], base, frame)[0]) < best


@pytest.mark.run
def test_racing_weight_changes_the_run_and_the_default_is_its_registry_value():
    tr = tight_colon(2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = follow(tr, solver="lumen", solver_options={"racing_weight": 0.0})
        b = follow(tr, solver="lumen")
        c = follow(tr, solver="lumen", solver_options={"racing_weight": BY_NAME["racing_weight"].default})
    assert BY_NAME["racing_weight"].default > 0.0  # the head is pulled to the racing line by default (docs/lumen.md)
    assert np.array_equal(b.points, c.points)
    assert not np.array_equal(a.points, b.points)
