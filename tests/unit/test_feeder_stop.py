"""The thesis's model's feeder stops when the tip reaches a blind cecum (docs/locomotion.md): the robot holds its
pose from then on, step by step as compiled, head and body; an open end or a path without a lumen never stops it;
and the watch that says when the tip has reached the end agrees with the geometry."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bhr._bench.lumen import tight_colon
from bhr.model._tube import make_tube
from bhr._run.clearance import CecumWatch, cecum_step
from bhr._run.driver import follow


def _quiet(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return follow(*args, **kwargs)


@pytest.fixture(scope="module")
def stopped():
    """The lumen solver on a tight colon: it cuts the bends and reaches the blind end before the path's last point.
    The tests below only read the run."""
    tr = tight_colon(2)
    return tr, _quiet(tr, solver="lumen")


@pytest.mark.run
def test_a_robot_ahead_of_its_schedule_stops_at_the_cecum_and_holds_its_pose(stopped):
    tr, run = stopped
    stop = run.summary.to_dict()["feeder_stop_step"]
    assert 1 <= stop < run.steps
    k = stop - 1
    t = run.trajectory  # the path as the run drew it at the robot's feed
    tube = make_tube(t.points, t.lumen, t.start_direction, closed_end=True)
    assert cecum_step(tube, run.points[:, -1]) == k  # the first step at the cecum
    assert np.all(run.points[k + 1:] == run.points[k]) and np.all(run.codes[k + 1:] == run.codes[k])
    assert np.all(run.iterations[k + 1:] == 0)
    assert not np.all(run.points[k] == run.points[k - 1])  # it moved until then
    # held steps are scored against their own trajectory points, as every step
    assert not np.array_equal(run.point_errors_mm[k + 1], run.point_errors_mm[k])
    # step by step, with a callback as a stream uses it: the same run, every step reported
    seen: list[np.ndarray] = []
    again = _quiet(tr, solver="lumen", on_step=lambda i, c: seen.append(np.array(c)))
    assert again.summary.to_dict()["feeder_stop_step"] == stop
    assert np.array_equal(again.points, run.points) and np.array_equal(again.codes, run.codes)
    assert np.array_equal(again.point_errors_mm, run.point_errors_mm)
    assert len(seen) == run.steps and all(np.array_equal(c, run.codes[k]) for c in seen[k:])


@pytest.mark.run
def test_the_body_holds_its_pose_behind_a_stopped_head(stopped):
    tr, head = stopped
    run = _quiet(tr, solver="lumen", body_modules=12, locomotion="thesis")  # the thesis model's body
    k = run.summary.to_dict()["feeder_stop_step"] - 1
    b = run.body
    assert b is not None and b.modules == 7
    assert np.all(b.points[k + 1:] == b.points[k]) and np.all(b.codes[k + 1:] == b.codes[k])
    assert np.array_equal(head.points, run.points)  # the body does not change the head


@pytest.mark.run
def test_an_open_end_or_no_lumen_never_stops_the_feeder():
    tr = tight_colon(2)
    open_end = _quiet(dataclasses.replace(tr, lumen_end="open"), solver="lumen")
    assert "feeder_stop_step" not in open_end.summary.to_dict()
    assert not np.all(open_end.points[-1] == open_end.points[-2])
    bare = _quiet(dataclasses.replace(tr, lumen=None), solver="thesis")
    assert "feeder_stop_step" not in bare.summary.to_dict()


@pytest.mark.run
def test_the_thesis_colon_runs_every_step():
    # the printed colon has a blind end; the thesis's solver keeps its tip within its tolerance of the schedule and
    # reaches the end at the last step, so the thesis's run is the thesis's, every step solved
    import bhr

    run = _quiet(bhr.trajectory("colon"), solver="thesis")
    assert "feeder_stop_step" not in run.summary.to_dict()
    assert np.all(run.iterations > 0)


@settings(max_examples=60, deadline=None)
@given(length=st.floats(20.0, 200.0), radius=st.floats(8.0, 25.0), step=st.floats(0.5, 4.0),
       lateral=st.floats(-0.9, 0.9), yaw=st.floats(0.0, 6.283))
def test_the_watch_says_reached_exactly_at_the_end_cross_section(length, radius, step, lateral, yaw):
    # a straight lumen along a direction in the plane, blind at its end: a tip moving along it, off its axis by
    # up to 0.9 of the radius, has reached the cecum from the first position at or past the end's cross-section
    d = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    side = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    pts = np.arange(0.0, length + 1e-9, 2.0)[:, None] * d
    tube = make_tube(pts, np.full(len(pts), 2 * radius), d, closed_end=True)
    end = float(np.dot(pts[-1], d))
    s = np.arange(0.0, end + 3 * step, step)
    tips = s[:, None] * d + lateral * radius * side
    got = cecum_step(tube, tips)
    want = int(np.argmax(s >= end - 1e-9))
    assert got == want
    # an open end has no cecum
    assert cecum_step(make_tube(pts, np.full(len(pts), 2 * radius), d, closed_end=False), tips) is None


def test_the_watch_follows_a_u_turn_and_is_not_fooled_by_the_other_limb():
    # a U-turn whose blind end lies beside its first limb: a tip in the first limb, level with the end, has not
    # reached it; the same tip position at the end of the second limb has
    a = np.arange(0.0, 100.0, 2.0)
    first = np.stack([a, np.zeros_like(a), np.zeros_like(a)], axis=1)
    th = np.linspace(0.0, np.pi, 40)[1:-1]
    turn = np.stack([100.0 + 30.0 * np.sin(th), 30.0 - 30.0 * np.cos(th), np.zeros_like(th)], axis=1)
    second = np.stack([a[::-1], np.full_like(a, 60.0), np.zeros_like(a)], axis=1)[:-10]  # ends at x = 20
    pts = np.concatenate([first, turn, second])
    tube = make_tube(pts, np.full(len(pts), 40.0), [1.0, 0.0, 0.0], closed_end=True)
    watch = CecumWatch(tube)
    assert not any(watch.reached(p) for p in first[:12])  # passes x = 20 in the first limb: not the cecum
    along = np.concatenate([first[12:], turn, second])
    hits = [i for i, p in enumerate(along) if watch.reached(p)]
    assert hits and hits[0] == len(along) - 1


@pytest.mark.run
def test_a_held_robot_travels_no_contact_length():
    # contact_length_mm is the path travelled while a module touched: one feed per step until the feeder stopped,
    # none while the robot is held at the cecum, though it touches there (the last 40 mm narrower than the robot)
    tr = tight_colon(2)
    lumen = tr.lumen.copy()
    lumen[-20:] = 9.0
    run = _quiet(dataclasses.replace(tr, lumen=lumen), solver="lumen")
    s = run.summary.to_dict()
    k = s["feeder_stop_step"]
    with np.errstate(invalid="ignore"):
        touching = run.clearance.module_table <= 0.0
    assert touching[k:].any() and k < run.steps  # held in contact
    assert s["contact_length_mm"] == (touching[:k].sum(axis=0) * run.robot.feed).tolist()


@pytest.mark.run
def test_a_stopped_run_reads_back_whole_and_a_bad_stop_is_refused(stopped):
    from bhr._run.driver import FollowResult
    from bhr._settings.errors import BhrError

    _, run = stopped
    doc = run.to_dict()
    back = FollowResult.from_json(doc)
    s, t = run.summary.to_dict(), back.summary.to_dict()
    assert t["feeder_stop_step"] == s["feeder_stop_step"]
    assert t["contact_length_mm"] == s["contact_length_mm"] and t["max_penetration_mm"] == s["max_penetration_mm"]
    for bad in (0, True, "12", run.steps, 1e3):
        doc["summary"]["feeder_stop_step"] = bad
        with pytest.raises(BhrError, match="feeder_stop_step must be a step"):
            FollowResult.from_json(doc, "r.json")


def _u_turn(gap: float, spacing: float, limb: float) -> np.ndarray:
    """A centerline out along +x, a half-turn of diameter ``gap``, and back: two limbs ``gap`` apart."""
    a = np.arange(0.0, limb, spacing)
    first = np.stack([a, np.zeros_like(a), np.zeros_like(a)], axis=1)
    r = gap / 2.0
    th = np.arange(spacing / r, np.pi, spacing / r)
    turn = np.stack([limb + r * np.sin(th), r - r * np.cos(th), np.zeros_like(th)], axis=1)
    second = np.stack([a[::-1], np.full_like(a, gap), np.zeros_like(a)], axis=1)
    return np.concatenate([first, turn, second])


def _random_chain(rng: np.random.Generator, n: int, spacing: float) -> np.ndarray:
    d = np.array([1.0, 0.0, 0.0])
    pts = [np.zeros(3)]
    for _ in range(n - 1):
        d = d + rng.normal(scale=0.35, size=3)
        d /= np.linalg.norm(d)
        pts.append(pts[-1] + spacing * d)
    return np.array(pts)


def _cecum_numpy(tube, tips):
    """The watch in numpy (the reference): each tip located by locate_numpy around where the one before was."""
    from bhr.model._tube import locate_numpy

    C = tube.points
    d = (C[-1] - C[-2]) / np.linalg.norm(C[-1] - C[-2])
    pos, track = float(tube.pre), []
    for i, p in enumerate(tips):
        _, pos, _ = locate_numpy(tube, 0.0, p, pos)
        track.append(pos)
        if pos >= C.shape[0] - 1 - 1e-9 and float(np.dot(p - C[-1], d)) >= -1e-9:
            return i, track
    return None, track


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), shape=st.sampled_from(["u-turn", "random"]), gap=st.floats(8.0, 70.0),
       diameter=st.floats(10.0, 50.0), spacing=st.floats(0.7, 3.0), wander=st.floats(0.0, 1.4),
       feed=st.floats(0.3, 4.0))
def test_the_compiled_watch_tracks_the_tip_as_the_numpy_search_does(seed, shape, gap, diameter, spacing, wander,
                                                                    feed):
    # a tip moving along U-turns whose limbs are near (their lumens may overlap) and along random chains, off the
    # axis by up to 1.4 lumen radii (outside the wall: the whole centerline is searched): the compiled local update
    # finds, step by step, the same nearest centerline point as the numpy search and stops at the same step
    rng = np.random.default_rng(seed)
    pts = _u_turn(gap, spacing, 60.0) if shape == "u-turn" else _random_chain(rng, 80, spacing)
    tube = make_tube(pts, np.full(len(pts), diameter), closed_end=True)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    s = np.arange(0.0, arc[-1] + 3 * feed, feed)
    axis = np.stack([np.interp(s, arc, pts[:, j]) for j in range(3)], axis=1)
    tips = axis + rng.normal(size=axis.shape) * wander * diameter / 2 / np.sqrt(3)
    want, track = _cecum_numpy(tube, tips)
    watch = CecumWatch(tube)
    for i, p in enumerate(tips[:len(track)]):
        hit = watch.reached(p)
        assert abs(watch._pos - track[i]) <= 1e-9, (i, watch._pos, track[i])  # numpy's einsum: an ulp apart
        assert hit == (want == i)
    assert cecum_step(tube, tips) == want
