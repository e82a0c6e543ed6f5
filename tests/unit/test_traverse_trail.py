"""The trail locomotion (bhr._run.trail, docs/locomotion.md): exact follow-the-leader of the whole robot."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr._kinematics.codetable import SEARCH_CODES
from bhr.model._generators import load_trajectory
from bhr.model._path import Trajectory
from bhr.model._robot import Robot
from bhr._run.driver import BhrWarning, follow
from bhr._run.trail import chord_sweep_numpy, sweep_bound_mm, trail_poses, trail_poses_numpy, trail_tables
from bhr.solvers._trail import dense_tube, plan_trail, plan_trail_numpy, trail_vertices
from bhr._settings.errors import BhrError

codes_st = st.lists(st.sampled_from([int(c) for c in SEARCH_CODES]), min_size=1, max_size=12)


@settings(max_examples=40, deadline=None)
@given(codes=codes_st, f=st.integers(1, 7), joints=st.integers(1, 6), alpha=st.floats(2, 40),
       L=st.floats(2, 12))
def test_poses_kernel_matches_numpy(codes, f, joints, alpha, L):
    back = joints + 2
    T = trail_vertices(np.array(codes), (0.3, -0.2, 1.0), (1.0, 2.0, 3.0), L, alpha, back)
    steps = (len(codes) - 1) * f + 1
    np.testing.assert_allclose(trail_poses(T, back, f, steps, joints), trail_poses_numpy(T, back, f, steps, joints),
                               rtol=0, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(codes=codes_st, f=st.integers(1, 7), alpha=st.floats(2, 40), L=st.floats(2, 12))
def test_every_module_takes_the_places_the_tip_took(codes, f, alpha, L):
    """Exact follow-the-leader: joint j at step i is where the tip was j module lengths of insertion before, every
    module is L long at whole module lengths, and a joint never tilts by more than alpha in between."""
    joints = 5
    back = joints + 2
    T = trail_vertices(np.array(codes), (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), L, alpha, back)
    steps = (len(codes) - 1) * f + 1
    X = trail_poses(T, back, f, steps, joints)
    for i in range(steps):
        for j in range(joints):
            if i - j * f >= 0:
                np.testing.assert_allclose(X[i, j], X[i - j * f, 0], atol=1e-12)
    seg = np.linalg.norm(np.diff(X, axis=1), axis=2)
    assert np.all(seg <= L + 1e-9)
    assert np.all(seg >= L * math.cos(math.radians(alpha) / 2) - 1e-9)
    np.testing.assert_allclose(seg[::f], L, atol=1e-9)
    u = np.diff(X, axis=1) / seg[..., None]
    cos = np.clip(np.sum(u[:, 1:] * u[:, :-1], axis=2), -1, 1)
    assert np.degrees(np.arccos(cos)).max() <= alpha + 1e-6


@settings(max_examples=60, deadline=None)
@given(alpha=st.floats(1, 45), L=st.floats(1, 20), theta=st.floats(0, 2 * math.pi), a=st.floats(0.05, 0.95),
       u=st.floats(0, 1))
def test_bounds_on_leaving_the_trail(alpha, L, theta, a, u):
    """The model's chord across a vertex stays within (L/2) sin(alpha/2) of the two pieces, a rigid module (length L,
    both ends on the pieces) within (L/2) tan(alpha/2)."""
    model, rigid = sweep_bound_mm(L, alpha)
    g0 = np.array([0.0, 0.0, 1.0])
    al = math.radians(alpha)
    g1 = np.array([math.sin(al) * math.cos(theta), math.sin(al) * math.sin(theta), math.cos(al)])
    V = np.zeros(3)

    def dist_to_trail(p):
        d = []
        for A, g in ((V - L * g0, g0), (V, g1)):
            t = np.clip(np.dot(p - A, g), 0, L)
            d.append(np.linalg.norm(p - (A + t * g)))
        return min(d)

    A, B = V - (1 - u) * L * g0, V + u * L * g1
    assert max(dist_to_trail(A + t * (B - A)) for t in np.linspace(0, 1, 41)) <= model + 1e-9
    # a rigid module with its rear a*L behind the vertex: its front where the distance is L
    back = a * L
    # |V + s g1 - (V - back g0)| = L  ->  s^2 + 2 s back cos(alpha) + back^2 - L^2 = 0
    c = math.cos(al)
    s = -back * c + math.sqrt(back * back * c * c - back * back + L * L)
    A, B = V - back * g0, V + s * g1
    assert abs(np.linalg.norm(B - A) - L) < 1e-9
    assert max(dist_to_trail(A + t * (B - A)) for t in np.linspace(0, 1, 81)) <= rigid + 1e-9


def _tube_path(n=160, bend=25.0, lumen=24.0):
    """A straight, a bend of radius ``bend`` through 120 deg, a straight: 1 mm apart, constant lumen."""
    s = np.arange(n, dtype=float)
    pts = []
    for t in s:
        if t < 40:
            pts.append((t, 0.0, 0.0))
        elif t < 40 + bend * math.radians(120):
            ph = (t - 40) / bend
            pts.append((40 + bend * math.sin(ph), bend * (1 - math.cos(ph)), 0.0))
        else:
            ph = math.radians(120)
            e = np.array([40 + bend * math.sin(ph), bend * (1 - math.cos(ph)), 0.0])
            d = np.array([math.cos(ph), math.sin(ph), 0.0])
            pts.append(tuple(e + (t - 40 - bend * ph) * d))
    P = np.array(pts)
    return Trajectory("bend", P, {}, lumen=np.full(len(P), lumen))


_SETTINGS = {"margin": 1.0, "wall_weight": 1000.0, "center_weight": 0.05, "along_weight": 0.05, "trail_beam": 4}


def test_planner_kernel_matches_numpy():
    tr = _tube_path()
    r = Robot(alpha=25, module_length=5, feed_divisor=5)
    tube = dense_tube(tr.points, tr.lumen, tr.start_direction, 40.0)
    a = plan_trail(tube, r, _SETTINGS, 20, tr.start_direction, tr.start_point)
    b = plan_trail_numpy(tube, r, _SETTINGS, 20, tr.start_direction, tr.start_point)
    assert a.tolist() == b.tolist()
    assert len(set(a.tolist())) > 1  # it bends


def test_motion_between_steps_against_brute_force():
    """The smallest clearance of the motion across a vertex (joints sliding, envelope arc) is what a dense grid of
    chords finds, within the grid's resolution, and never shallower."""
    tr = _tube_path(lumen=17.0)
    r = Robot(alpha=25, module_length=5, feed_divisor=3)
    tube = dense_tube(tr.points, tr.lumen, tr.start_direction, 40.0)
    codes = np.array([0] * 8 + [6] * 6 + [3, 6, 9, 6, 12, 0] + [0] * 4)
    back = 4
    T = trail_vertices(codes, tr.start_direction, tr.start_point, 5.0, 25.0, back)
    tb = trail_tables(tube, r.robot_radius, T, back, 3, 1, len(codes), 5.0)
    checked = 0
    for m in range(8, 16):  # into the bend and across its tightest vertices
        for k in range(3):
            brute = chord_sweep_numpy(tube, r.robot_radius, T, tb["z"], back + m, k / 3, (k + 1) / 3, 31, 31)
            sw = min(tb["sw"][m - 1, k], tb["mc"][m - 1, k])
            assert sw <= brute + 1e-6
            assert brute - sw <= 0.05
            checked += 1
    assert checked == 24


@pytest.mark.run
@pytest.mark.parametrize("seed", [1, 2])
def test_same_answer_at_every_feed(seed):
    """The verdict and the worst penetration and clearance agree at feed divisors 1, 5 and 10 (docs/locomotion.md)."""
    out = []
    for f in (1, 5, 10):
        r = Robot(alpha=25, module_length=5, feed_divisor=f)
        tr = load_trajectory("anatomy", feed=r.feed, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            s = follow(tr, solver="lumen", robot=r, locomotion="trail").summary.to_dict()
        out.append((len(s["wall_touch_steps"]) == 0, s["max_penetration_mm"], s["min_clearance_mm"]))
    assert len({o[0] for o in out}) == 1
    assert max(o[1] for o in out) - min(o[1] for o in out) <= 0.5
    assert max(o[2] for o in out) - min(o[2] for o in out) <= 0.5


@pytest.mark.run
def test_whole_robot_clearance_is_the_tips():
    """Every module passes where the tip passed: the whole robot's smallest clearance is the head's."""
    r = Robot(alpha=25, module_length=5, feed_divisor=5)
    tr = load_trajectory("anatomy", feed=r.feed, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        head = follow(tr, solver="lumen", robot=r, locomotion="trail")
        whole = follow(tr, solver="lumen", robot=r, locomotion="trail", reach="cecum")
    sw, sh = whole.summary.to_dict(), head.summary.to_dict()
    stop = sw["feeder_stop_step"] - 1  # the tip reaches the cecum: the feeder stops
    assert sw["body_modules"] == math.ceil(stop / 5)
    np.testing.assert_array_equal(whole.trail.codes, head.trail.codes)
    assert abs(sw["min_clearance_mm"] - sh["min_clearance_mm"]) < 1e-9
    assert sw["procedure_time_s"] > 0
    # the tail at the end: still at the anus, less than one module behind it on the line the robot entered along
    d = np.asarray(tr.start_direction) / np.linalg.norm(tr.start_direction)
    behind = np.dot(whole.body.points[-1, -1] - tr.points[0], d)
    assert -5.0 < behind <= 1e-9
    np.testing.assert_allclose(whole.body.points[-1, -1], tr.points[0] + behind * d, atol=1e-9)


def test_trail_refusals():
    tr = load_trajectory("anatomy", feed=2.0, seed=1)
    with pytest.raises(BhrError, match="use --solver lumen"):
        follow(tr, solver="thesis", locomotion="trail")
    with pytest.raises(BhrError, match="either body_modules or reach"):
        follow(tr, solver="lumen", locomotion="trail", reach="cecum", body_modules=20)
    with pytest.raises(BhrError, match="locomotion must be"):
        follow(tr, solver="lumen", locomotion="walk")
    with pytest.raises(BhrError, match="has none"):
        follow(load_trajectory("curve"), solver="lumen", locomotion="trail")


def test_grid_values_of_a_whole_length_study():
    from bhr._studies.sweep import parse_grid_option
    from bhr._studies.traverse import build_study

    assert parse_grid_option("locomotion=thesis,trail") == ("locomotion", ("thesis", "trail"))
    assert parse_grid_option("reach=cecum") == ("reach", ("cecum",))
    with pytest.raises(BhrError, match="locomotion must be one of thesis, wires, trail"):
        parse_grid_option("locomotion=walk")
    study = build_study([("alpha", (25,)), ("module_length", (5,)), ("reach", ("cecum",)),
                         ("locomotion", ("trail",))], "1-2", solvers=["lumen"])
    assert study.design_keys == ["solver", "alpha", "module_length", "reach", "locomotion"]
