"""Which bends a robot cannot follow inside its lumen (bhr.model._path.unfollowable_bends) and the warning built on it."""
from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import bhr
from bhr.model._generators import load_trajectory
from bhr.model._path import BEND_WINDOWS_MM, unfollowable_bends
from bhr.model._robot import Robot
from bhr._run.driver import BhrWarning

SETTINGS = settings(max_examples=40, deadline=None)


def bend(radius: float, turn_deg: float, straight: float = 100.0, step: float = 1.0) -> np.ndarray:
    """A straight, an arc of ``radius`` turning ``turn_deg``, a straight: points ``step`` mm apart along the path
    (planar), evenly spaced as the rule's centerlines are, across the arc's ends too."""
    th = math.radians(turn_deg)
    s = np.arange(0.0, 2.0 * straight + radius * th + 0.5 * step, step) - straight  # arc length from the arc's start
    u = np.clip(s, 0.0, radius * th) / radius
    d = np.column_stack([np.cos(th) + 0 * s, np.sin(th) + 0 * s, 0 * s])
    on_arc = np.column_stack([radius * np.sin(u), radius * (1 - np.cos(u)), 0 * u])
    before = np.column_stack([s, 0 * s, 0 * s])
    after = on_arc + np.maximum(s - radius * th, 0.0)[:, None] * d
    return np.where((s < 0.0)[:, None], before, after)


@SETTINGS
@given(st.floats(5.0, 80.0), st.floats(10.0, 180.0), st.floats(0.0, 20.0), st.floats(10.0, 80.0))
@example(5.0, 10.0, 0.0, 18.0)  # a kink shorter than the shortest stretch judged
@example(5.0, 90.0, 0.0, 18.0)
def test_the_rule_on_one_circular_bend(r, turn, e, big_r):
    """A robot of turn radius R takes a circular bend of radius r turning theta in a tube leaving e either way
    when R - r <= e (1 + c) / (1 - c), c = cos(theta / 2); clearly inside or outside that, the rule agrees."""
    pts = bend(r, turn)
    lumen = np.full(len(pts), 2.0 * (e + 5.0))
    c = math.cos(math.radians(turn) / 2)
    limit = r + e * (1 + c) / (1 - c)
    found = unfollowable_bends(pts, lumen, big_r, 5.0)
    # the stretches are judged at whole points (a stretch one point longer reads 1 / theta mm wider), in 8 %
    # steps of length, and are at least 2 BEND_WINDOWS_MM[0] long: a bend shorter than that reads as that
    # stretch's mean radius (a 10 deg kink of 5 mm radius, 0.9 mm long, reads 23 mm)
    shortest = 2.0 * max(round(BEND_WINDOWS_MM[0] / 1.0), 1) * 1.0 / math.radians(turn)  # the points are 1 mm apart
    if big_r > 1.25 * max(limit, shortest) + 2.0 / math.radians(turn):
        assert found
        first, last, r_bend, d = found[0]
        assert 100 - 2 * big_r <= first <= 100 + r * math.radians(turn) and r_bend < big_r
        assert d == pytest.approx(2.0 * (e + 5.0))
    if big_r <= 0.95 * r:  # (to the few per cent of the chords' estimate of the headings)
        assert not found  # never tighter than the robot turns: always followable


@SETTINGS
@given(st.floats(1.0, 500.0), st.floats(5.0, 100.0))
def test_a_path_no_tighter_than_the_robot_is_always_followable(r, big_r):
    pts = bend(max(r, big_r) / 0.95, 170.0, step=0.5)
    assert unfollowable_bends(pts, np.full(len(pts), 10.0), big_r, 5.0) == []  # even in a lumen as wide as the robot


def test_wider_lumen_more_room():
    pts = bend(20.0, 90.0)
    narrow = unfollowable_bends(pts, np.full(len(pts), 14.0), 57.15, 5.0)
    wide = unfollowable_bends(pts, np.full(len(pts), 120.0), 57.15, 5.0)
    assert narrow and not wide
    # the same bend, the lumen narrow only far away from it: followable
    lum = np.full(len(pts), 120.0)
    lum[:5] = 14.0
    assert unfollowable_bends(pts, lum, 57.15, 5.0) == []


@pytest.mark.run
def test_the_warning_fires_only_where_the_robot_cannot_follow():
    full = load_trajectory("anatomy", seed=7)
    tr = dataclasses.replace(full, points=full.points[:60].copy(), lumen=full.lumen[:60].copy())  # the first 120 mm
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always", BhrWarning)
        bhr.follow(tr, solver="lumen", robot=Robot(alpha=25, module_length=5))  # the anal canal: followable
    assert not [x for x in w if "bends tighter" in str(x.message) or "turns with radius" in str(x.message)]
    thesis = Robot()
    bends = unfollowable_bends(tr.points, tr.lumen, thesis.min_turn_radius, thesis.robot_radius)
    assert bends  # the thesis robot (57 mm turn radius) cannot take the anorectal flexure in a 15 mm lumen
    with pytest.warns(BhrWarning, match=r"bends tighter than the robot's minimum turn radius 57\.15 mm with too "
                                        r"little lumen to swing wide at 1 place, tightest at points 14-30 \(a 10\.1 mm bend in a lumen "
                                        r"14\.7 mm across\); expect the robot to touch the wall there"):
        bhr.follow(tr, solver="thesis")


@pytest.mark.parametrize("seed", range(1, 31))
def test_the_compiled_rule_is_its_numpy_reference(seed):
    """The kernel (sparse-table minima, point by point) finds the numpy reference's stretches on anatomical colons
    for the thesis robot and a 5 mm / 25 deg one; radii agree to rounding (acos in libm and in numpy)."""
    from bhr.model._path import unfollowable_bends_numpy

    t = bhr.trajectory("anatomy", seed=seed)
    for robot in (Robot(), Robot(module_length=5.0, alpha=25.0)):
        args = (t.points, np.asarray(t.lumen), robot.min_turn_radius, robot.robot_radius)
        got, want = unfollowable_bends(*args), unfollowable_bends_numpy(*args)
        assert [g[:2] for g in got] == [w[:2] for w in want]
        for g, w in zip(got, want):
            assert g[2] == pytest.approx(w[2], rel=1e-12) and g[3] == w[3]
