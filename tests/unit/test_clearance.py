"""Lumen clearance (bhr/clearance.py): lumen radius - robot radius - deviation, and wall touches."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from bhr.model._generators import COLON_SECTIONS, colon, load_trajectory
from bhr._run.clearance import clearance_table, step_ranges
from bhr._run.driver import follow
from bhr._settings.errors import BhrError


def with_lumen(tr, diameter):
    tr.lumen = np.full(tr.points.shape[0], float(diameter)) if np.isscalar(diameter) else np.asarray(diameter, float)
    return tr


def test_table_arithmetic():
    pe = np.array([[1.0, 2.0], [0.5, 3.0], [0.0, 1.0]])
    lumen = np.array([30.0, 20.0, 40.0])
    t = clearance_table(pe, np.array([1, 0]), lumen, 5.0)
    assert np.isnan(t[0, 0])  # scored one step behind: nothing at step 1
    assert t[0, 1] == pytest.approx(15 - 5 - 2)
    assert t[1, 0] == pytest.approx(15 - 5 - 0.5) and t[1, 1] == pytest.approx(10 - 5 - 3)
    assert t[2, 0] == pytest.approx(10 - 5 - 0) and t[2, 1] == pytest.approx(20 - 5 - 1)


def test_no_lumen_no_clearance():
    r = follow(load_trajectory("curve"), solver="optimal")
    assert r.clearance is None
    s = r.summary.to_dict()
    assert "min_clearance_mm" not in s and "wall_touch_steps" not in s
    assert "clearance_mm" not in r.to_dict()["steps"][0]


def test_touches_are_the_steps_where_some_point_or_module_reaches_the_wall():
    tr = load_trajectory("curve", angle=180.0)
    r = follow(with_lumen(tr, 2 * (5.0 + 3.0)), solver="seed")  # the wall 3 mm from the robot's surface
    cl = r.clearance
    both = np.concatenate([cl.table, cl.module_table], axis=1)
    with np.errstate(invalid="ignore"):
        want = [i + 1 for i in range(r.steps) if np.any(both[i] <= 0.0)]
    assert want  # the seed solver strays 3 mm on this curve
    s = r.summary.to_dict()
    assert s["wall_touch_steps"] == want
    assert s["min_clearance_mm"] == pytest.approx(np.nanmin(both))
    assert s["max_penetration_mm"] == pytest.approx(max(0.0, -np.nanmin(both)))
    # each module's contact length: one feed per step it touches
    with np.errstate(invalid="ignore"):
        per_module = (cl.module_table <= 0).sum(axis=0) * r.robot.feed
    assert s["contact_length_mm"] == pytest.approx(per_module.tolist())
    assert len(s["contact_length_mm"]) == len(s["contact_modules"]) == r.robot.modules
    i = s["min_clearance_step"] - 1
    assert cl.per_step[i] == pytest.approx(s["min_clearance_mm"])
    doc = r.to_dict()
    assert doc["steps"][i]["clearance_mm"] == pytest.approx(s["min_clearance_mm"])
    assert doc["trajectory"]["lumen"][0] == pytest.approx(16.0)
    # geometric: never below the index-matched figure's point for point on a single curve (nearest <= matched)
    assert s["index_matched_min_clearance_mm"] <= np.nanmin(cl.table) + 1e-9
    # the same robot in a lumen wider by its worst miss touches nothing
    wide = follow(with_lumen(load_trajectory("curve", angle=180.0), 2 * (5.0 + 3.0 - s["min_clearance_mm"] + 0.01)),
                  solver="seed")
    assert wide.summary.to_dict()["wall_touch_steps"] == [] and wide.summary.to_dict()["max_penetration_mm"] == 0.0


def test_exactly_at_the_wall_counts_as_touching():
    tr = with_lumen(load_trajectory("line", length=40.0), 10.0)  # lumen radius = robot radius
    r = follow(tr, solver="optimal")
    assert r.point_errors_mm.max() < 1e-9
    assert r.summary.to_dict()["min_clearance_mm"] == pytest.approx(0.0, abs=1e-9)
    assert r.summary.to_dict()["wall_touch_steps"] == list(range(1, r.steps + 1))


def test_colon_lumen_comes_from_the_trajectory_file():
    tr = load_trajectory("colon")
    sec: list[int] = []
    colon(tr.points[1, 0] - tr.points[0, 0], sec)
    sec = np.array(sec[:tr.points.shape[0]])
    rectum = sec == COLON_SECTIONS.index("rectum")
    assert np.all(tr.lumen[rectum] == 30.0) and np.all(tr.lumen[~rectum] == 45.0)
    r = follow(tr, solver="optimal")
    t = r.clearance.table
    n = r.robot.modules
    i = 15  # the tip is in the rectum's 30 mm, on the straight: its nearest centerline point is beside it
    assert rectum[i] and t[i, n] == pytest.approx(15.0 - 5.0 - abs(r.points[i, n, 1]), abs=1e-9)
    im = clearance_table(r.point_errors_mm, np.array([(n - j) * 5 for j in range(n + 1)]), tr.lumen, 5.0)
    assert r.summary.to_dict()["index_matched_min_clearance_mm"] == pytest.approx(np.nanmin(im))


def test_step_ranges():
    assert step_ranges([]) == "none"
    assert step_ranges([4]) == "4"
    assert step_ranges([1, 2, 3, 7, 9, 10]) == "1-3, 7, 9-10"


def test_plots_mark_the_touches(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from bhr.output._clearance_plot import clearance_figure
    from bhr.output._error_plot import error_figure
    from bhr.output._path_plot import path_figure
    from bhr.output._run_plots import save_run_plots

    r = follow(with_lumen(load_trajectory("curve", angle=180.0), 16.0), solver="seed", body_modules=8)
    assert r.summary.to_dict()["wall_touch_steps"]
    fig = error_figure(r, "position")
    labels = [p.get_label() for ax in fig.axes for p in ax.patches]
    assert "wall touched" in labels
    fig = path_figure(r)
    assert "wall contact (every step)" in [ln.get_label() for ax in fig.axes for ln in ax.lines]
    fig = clearance_figure(r)
    assert any(ln.get_label().startswith("minimum") for ln in fig.axes[0].lines)
    files = save_run_plots(r, tmp_path)
    assert {p.name for p in files} >= {"clearance.png", "body_errors.png", "position_errors.png", "path.png"}
    clean = follow(load_trajectory("curve"), solver="seed")
    fig = error_figure(clean, "position")
    assert "wall touched" not in [p.get_label() for ax in fig.axes for p in ax.patches]


# --- the geometry: kernels against the numpy reference, properties ---------------------------------------------

from hypothesis import example, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from bhr._run.clearance import clearance_run, clearance_run_numpy, make_tube, run_chain  # noqa: E402


@pytest.mark.run
def test_kernel_equals_numpy_reference_on_a_run_with_a_body():
    from bhr._bench.lumen import tight_colon

    tr = tight_colon(4)
    r = follow(tr, solver="seed", body_modules=9)
    tube = make_tube(tr.points, tr.lumen, tr.start_direction)
    Q, E, B = run_chain(r)
    assert B == 4
    sl = slice(0, 120)  # the numpy reference is slow: the first 120 steps (robot entering, bends, contacts)
    fast = clearance_run(tube, 5.0, Q[sl], E[sl])
    ref = clearance_run_numpy(tube, 5.0, Q[sl], E[sl])
    for a, b, tol in zip(fast, ref, (1e-12, 1e-7, 1e-4)):  # golden-section ties may pick another flat spot
        assert np.array_equal(np.isnan(a), np.isnan(b))
        assert np.nanmax(np.abs(a - b)) <= tol
    assert np.nanmin(fast[1]) < 0  # the case has contacts


def _straight_tube(direction, diameter, count=80, spacing=2.0, origin=(0.0, 0.0, 0.0)):
    d = np.asarray(direction, float)
    d /= np.linalg.norm(d)
    path = np.asarray(origin, float) + spacing * np.arange(count)[:, None] * d
    return path, np.full(count, float(diameter)), d


unit3 = st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=40, deadline=None)
@given(direction=unit3, diameter=st.floats(12.0, 60.0), radius=st.floats(0.0, 5.0),
       first=st.integers(0, 30), modules=st.integers(1, 6))
def test_robot_on_the_centerline_of_a_straight_tube_clears_radius_minus_robot_radius(direction, diameter, radius,
                                                                                      first, modules):
    path, lumen, d = _straight_tube(direction, diameter)
    tube = make_tube(path, lumen, d)
    E = (first + 5.0 * np.arange(modules + 1))[None, :]
    Q = path[0] + 2.0 * E[..., None] * d
    pt, mod, where = clearance_run(tube, radius, Q, E)
    assert np.allclose(pt, diameter / 2 - radius, atol=1e-9)
    assert np.allclose(mod, diameter / 2 - radius, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(direction=unit3, offset=st.floats(0.0, 20.0), shift=st.tuples(*[st.floats(-1e3, 1e3)] * 3),
       angle=st.floats(0.0, 6.283))
def test_clearance_falls_with_the_distance_from_the_axis_and_ignores_where_the_tube_is(direction, offset, shift,
                                                                                        angle):
    path, lumen, d = _straight_tube(direction, 30.0)
    # a sideways unit vector, turned by angle about the axis
    a = np.cross(d, [0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.cross(d, [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(d, a)
    side = np.cos(angle) * a + np.sin(angle) * b
    E = np.array([[20.0, 25.0, 30.0]])
    Q = path[0] + 2.0 * E[..., None] * d + offset * side
    pt, mod, _ = clearance_run(make_tube(path, lumen, d), 5.0, Q, E)
    assert np.allclose(pt, 15.0 - 5.0 - offset, atol=1e-9) and np.allclose(mod, 15.0 - 5.0 - offset, atol=1e-9)
    # translation invariance: the same tube and robot elsewhere
    s = np.asarray(shift)
    pt2, mod2, _ = clearance_run(make_tube(path + s, lumen, d), 5.0, Q + s, E)
    assert np.allclose(pt2, pt, atol=1e-6) and np.allclose(mod2, mod, atol=1e-6)


def test_a_module_cutting_the_inside_of_a_bend_is_scored_along_its_body():
    """Both ends on the centerline of a 30 mm bend, the chord's middle 8.79 mm inside: into a 6 mm lumen radius."""
    R, lumen_r, robot_r = 30.0, 6.0, 0.5
    t = np.linspace(0.0, np.pi, int(np.pi * R / 0.5) + 1)
    path = np.stack([R * np.sin(t), R - R * np.cos(t), np.zeros_like(t)], axis=1)
    tube = make_tube(path, np.full(len(t), 2 * lumen_r))
    k = int(np.argmin(np.abs(t - np.pi / 2)))
    E = np.array([[0.0, float(k)]])
    Q = path[[0, k]][None]
    pt, mod, where = clearance_run(tube, robot_r, Q, E)
    assert np.allclose(pt, lumen_r - robot_r, atol=1e-9)
    sag = R * (1 - np.cos(t[k] / 2))  # the chord's middle, inside the bend
    assert mod[0, 0] == pytest.approx(lumen_r - robot_r - sag, abs=0.01)
    assert np.allclose(where[0, 0], (path[0] + path[k]) / 2, atol=0.05)


def test_two_loops_passing_close_are_not_mistaken_for_each_other():
    """A U-turn: the return limb runs 40 mm from the outgoing one; a point by the outgoing limb is scored on it."""
    out = np.stack([np.arange(0, 300, 2.0), np.zeros(150), np.zeros(150)], axis=1)
    t = np.linspace(0, np.pi, 32)[1:-1]
    turn = np.stack([298 + 20 * np.sin(t), 20 - 20 * np.cos(t), np.zeros_like(t)], axis=1)
    back = np.stack([np.arange(298, -2, -2.0), np.full(150, 40.0), np.zeros(150)], axis=1)
    path = np.vstack([out, turn, back])
    tube = make_tube(path, np.full(len(path), 30.0))
    p = np.array([[[100.0, 25.0, 0.0]]])  # 25 mm from the outgoing limb, 15 from the return limb
    pt, _, _ = clearance_run(tube, 5.0, p, np.array([[50.0]]))
    assert pt[0, 0] == pytest.approx(15 - 5 - 25)
    pt_back, _, _ = clearance_run(tube, 5.0, p, np.array([[float(150 + 30 + 100)]]))  # expected on the return limb
    assert pt_back[0, 0] == pytest.approx(15 - 5 - 15)


def test_a_point_is_followed_along_the_centerline_from_step_to_step():
    """A robot running far ahead of its schedule is still scored on the stretch of lumen it is in."""
    path, lumen, d = _straight_tube((1, 0, 0), 30.0, count=400)
    tube = make_tube(path, lumen, d)
    N = 100
    E = np.arange(N, dtype=float)[:, None]
    lead = 1.3 * np.arange(N)[:, None]  # gains 2.6 mm on its target every step: 257 mm ahead at the end
    Q = path[0] + 2.0 * (E + lead)[..., None] * d + np.array([0.0, 3.0, 0.0])
    pt, _, _ = clearance_run(tube, 5.0, Q, E)
    assert np.allclose(pt, 15 - 5 - 3, atol=1e-9)


def test_a_lumen_narrower_than_the_robot_is_warned_about(tmp_path):
    import warnings

    from bhr.model._generators import load_trajectory
    from bhr._run.driver import BhrWarning

    x = np.arange(0.0, 60.0, 1.0)
    for width, warned in ((8.0, True), (10.0, False), (30.0, False)):
        lumen = np.full(len(x), 30.0)
        lumen[20:25] = width  # a stricture
        p = tmp_path / f"w{width:g}.csv"
        p.write_text("x,y,z,lumen\n" + "".join(f"{v},0,0,{d}\n" for v, d in zip(x, lumen)))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            run = follow(load_trajectory(str(p)), solver="thesis")
        said = [w for w in run.summary.warnings if "narrower than the robot" in w]
        assert bool(said) == warned, run.summary.warnings
        assert any(issubclass(c.category, BhrWarning) and "narrower" in str(c.message) for c in caught) == warned
        if warned:
            assert "narrowest 8.00 mm" in said[0] and "(10 mm across)" in said[0]
            assert run.summary.to_dict()["min_clearance_mm"] < 0  # and the clearance shows the contact


# --- a blind end, a search that recovers, leaving the lumen ---------------------------------------------------

from bhr._run.clearance import brute_force_clearance, clearance_run_all  # noqa: E402


@settings(max_examples=30, deadline=None)
@given(direction=unit3, past=st.floats(0.0, 300.0), side=st.floats(0.0, 10.0))
def test_the_lumen_ends_in_a_cap_where_the_centerline_ends(direction, past, side):
    """A robot running up to 300 mm ahead of the end of a closed lumen is in the wall; open, it is not."""
    path, lumen, d = _straight_tube(direction, 30.0, count=100)
    a = np.cross(d, [0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.cross(d, [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    N = 40
    E = np.linspace(60.0, 99.0, N)[:, None]  # expected along the path, the last at its end
    lead = np.linspace(0.0, past, N)[:, None]  # ahead of schedule, up to `past` mm beyond the end at the last step
    Q = (path[0] + (2.0 * E + lead)[..., None] * d + side * a)
    closed = make_tube(path, lumen, d, closed_end=True)
    pt, _, _ = clearance_run(closed, 5.0, Q, E)
    assert np.allclose(pt[:, 0], brute_force_clearance(path, lumen, 5.0, Q[:, 0]), atol=1e-9)
    beyond = 2.0 * E[-1, 0] + past - 2.0 * 99
    assert pt[-1, 0] == pytest.approx(15.0 - 5.0 - math.hypot(beyond, side), abs=1e-6)
    opened, _, _ = clearance_run(make_tube(path, lumen, d), 5.0, Q, E)
    near = (2.0 * E + lead)[:, 0] - 2.0 * 99 <= 40.0  # an open end goes on straight for the search window (40 mm)
    assert np.allclose(opened[near], 15.0 - 5.0 - side, atol=1e-9)


def _helix(turns=3.0, radius=60.0, pitch=80.0, spacing=1.0):
    L = turns * math.hypot(2 * math.pi * radius, pitch)
    s = np.arange(0.0, L, spacing)
    t = s / L * turns * 2 * math.pi
    return np.stack([radius * np.cos(t), radius * np.sin(t), pitch * t / (2 * math.pi)], axis=1)


@settings(max_examples=25, deadline=None)
@given(stray=st.floats(-50.0, 50.0), off=st.tuples(*[st.floats(-12.0, 12.0)] * 3), at=st.integers(100, 900))
def test_a_point_strayed_50_mm_from_where_it_is_expected_is_found(stray, off, at):
    """Expected `stray` mm of arc from where it is (and off the centerline): the same as the brute-force check."""
    path = _helix()
    lumen = np.full(len(path), 30.0)
    tube = make_tube(path, lumen, closed_end=True)
    N = 30
    E = (at + np.arange(N, dtype=float))[:, None]
    Q = path[(E[:, 0] + np.round(stray * np.linspace(0, 1, N))).astype(int)] + np.asarray(off)
    pt, _, _ = clearance_run(tube, 5.0, Q[:, None, :], E)
    assert np.allclose(pt[:, 0], brute_force_clearance(path, lumen, 5.0, Q), atol=1e-9)


@settings(max_examples=25, deadline=None)
@given(toward=st.floats(0.0, 14.9), along=st.floats(20.0, 280.0))
def test_two_loops_5_mm_apart_are_kept_apart(toward, along):
    """A U-turn whose limbs' walls are 5 mm apart (centerlines 35 mm): a point in the outgoing limb's lumen, however
    close to the other limb, is scored on its own limb, and touching it does not make it jump."""
    out = np.stack([np.arange(0, 300, 1.0), np.zeros(300), np.zeros(300)], axis=1)
    t = np.linspace(0, np.pi, 57)[1:-1]
    turn = np.stack([299 + 17.5 * np.sin(t), 17.5 - 17.5 * np.cos(t), np.zeros_like(t)], axis=1)
    back = np.stack([np.arange(299, -1, -1.0), np.full(300, 35.0), np.zeros(300)], axis=1)
    path = np.vstack([out, turn, back])
    tube = make_tube(path, np.full(len(path), 30.0), closed_end=True)
    p = np.array([[[along, toward, 0.0]]])
    pt, _, _, lost = clearance_run_all(tube, 5.0, p, np.array([[along]]))
    assert pt[0, 0] == pytest.approx(15 - 5 - toward, abs=1e-9)
    assert not lost[0]


@pytest.mark.run
def test_a_body_that_strays_agrees_with_the_brute_force_check_and_the_reference():
    """A 40-module body behind the thesis robot on a tight colon, its end closed: bhr's minimum is the brute-force
    minimum (within 0.5 mm), and the kernel is its numpy reference."""
    from bhr._bench.lumen import tight_colon

    tr = tight_colon(4)
    r = follow(tr, solver="seed", body_modules=40)
    tube = make_tube(tr.points, tr.lumen, tr.start_direction, closed_end=True)
    Q, E, B = run_chain(r)
    sl = slice(0, 60)
    fast = clearance_run_all(tube, 5.0, Q[sl], E[sl])
    lost = np.zeros(60, dtype=bool)
    ref = clearance_run_numpy(tube, 5.0, Q[sl], E[sl], lost=lost)
    for a, b, tol in zip(fast[:3], ref, (1e-12, 1e-7, 1e-4)):
        assert np.array_equal(np.isnan(a), np.isnan(b))
        assert np.nanmax(np.abs(a - b)) <= tol
    assert np.array_equal(fast[3], lost)
    rep = r.clearance
    i = rep.min_step - 1
    ok = E[i] >= 0
    pts = [Q[i][ok]] + [Q[i, m] + np.linspace(0, 1, 41)[:, None] * (Q[i, m + 1] - Q[i, m])
                        for m in range(Q.shape[1] - 1) if E[i, m] >= 0 and E[i, m + 1] >= 0]
    brute = brute_force_clearance(tr.points, tr.lumen, 5.0, np.vstack(pts)).min()
    assert abs(brute - rep.min_mm) <= 0.5


def test_an_open_end_from_the_option_or_the_file(tmp_path):
    from bhr.model._generators import load_trajectory

    x = np.arange(0.0, 60.0, 1.0)
    body = "x,y,z,lumen\n" + "".join(f"{v},0,0,30\n" for v in x)
    p = tmp_path / "c.csv"
    p.write_text(body)
    assert load_trajectory(str(p)).lumen_end == "closed"
    assert load_trajectory(str(p), lumen_end="open").lumen_end == "open"
    q = tmp_path / "o.csv"
    q.write_text("# lumen_end: open\n" + body)
    assert load_trajectory(str(q)).lumen_end == "open"
    bad = tmp_path / "b.csv"
    bad.write_text("# lumen_end: ajar\n" + body)
    with pytest.raises(BhrError, match="lumen_end: closed"):
        load_trajectory(str(bad))


@pytest.mark.run
def test_a_colon_the_robot_left_is_failed_by_traverse_with_its_reason():
    from bhr._studies.traverse import build_study, run_study

    res = run_study(build_study([("alpha", (10,))], "3-4", solvers=("seed",)), jobs=1)
    for r in res.runs:
        s = follow(load_trajectory("anatomy", seed=r["seed"], feed=2.0), solver="seed").summary.to_dict()
        assert r["left_lumen_step"] == s["left_lumen_step"]
        assert r["failure"] == (s["left_lumen_reason"] or "")
        if r["left_lumen_step"] is not None:
            assert not r["traversed"] and r["failure"].startswith("left the lumen at step")
    assert res.designs[0]["left_lumen"] == sum(r["left_lumen_step"] is not None for r in res.runs) >= 1


# the local search from a guess: the windowed scan's own result, bit for bit (U-turns with near limbs, random chains)

from bhr.model._tube import local_scan, local_scan_from, segment_scan, window_scan  # noqa: E402


def _chain(rng: np.random.Generator, shape: str, n: int, spacing: float, gap: float) -> np.ndarray:
    if shape == "u-turn":  # out along +x, a half-turn, back: two limbs `gap` apart
        a = np.arange(n // 2) * spacing
        r = gap / 2.0
        th = np.arange(spacing / r, np.pi, spacing / r)
        return np.concatenate([np.stack([a, 0 * a, 0 * a], 1),
                               np.stack([a[-1] + r * np.sin(th), r - r * np.cos(th), 0 * th], 1),
                               np.stack([a[::-1], 0 * a + gap, 0 * a], 1)])
    if shape == "straight":  # many segments equally near a point on the axis's side: ties
        return np.arange(n)[:, None] * np.array([spacing, 0.0, 0.0])
    d, pts = np.array([1.0, 0.0, 0.0]), [np.zeros(3)]
    for _ in range(n - 1):
        d = d + rng.normal(scale=0.6, size=3)
        d /= np.linalg.norm(d)
        pts.append(pts[-1] + spacing * d)
    return np.array(pts)


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), shape=st.sampled_from(["u-turn", "random", "straight"]),
       n=st.integers(2, 200), spacing=st.floats(0.3, 4.0), gap=st.floats(2.0, 60.0), spread=st.floats(0.0, 40.0),
       width=st.integers(1, 120), guess=st.floats(-0.2, 1.2), quantise=st.booleans())
def test_the_search_from_a_guess_finds_the_windows_nearest_segment_bit_for_bit(seed, shape, n, spacing, gap, spread,
                                                                               width, guess, quantise):
    rng = np.random.default_rng(seed)
    C = np.ascontiguousarray(_chain(rng, shape, n, spacing, gap))
    M = C.shape[0]
    tube = make_tube(C, np.full(M, 10.0))
    S, BC, BR = tube.search_arrays()
    P = tube.points
    for _ in range(20):
        at = P[rng.integers(0, P.shape[0])]
        p = at + rng.normal(size=3) * spread
        if quantise:  # on a grid: exact ties between segments
            p = np.round(p)
        lo = int(rng.integers(0, P.shape[0] - 1))
        hi = min(P.shape[0] - 1, lo + width)
        g = lo + int(guess * (hi - lo))
        assert window_scan(P, BC, BR, lo, hi, g, *p) == segment_scan(P, lo, hi, *p)
        assert local_scan_from(P, BC, BR, lo, hi, g, *p) == local_scan(P, lo, hi, *p)


def test_the_bounding_spheres_hold_their_segments():
    from bhr.model._tube import BLOCK, GROUP, _spheres

    rng = np.random.default_rng(3)
    for m in (2, 3, 5, 17, 18, 100):
        pts = np.cumsum(rng.normal(size=(m, 3)) * 3.0, axis=0)
        for size in (BLOCK, GROUP):
            c, r = _spheres(pts, size)
            assert c.shape == (-(-(m - 1) // size), 3)
            for j in range(c.shape[0]):
                run = pts[j * size:min(j * size + size, m - 1) + 1]
                assert np.all(np.linalg.norm(run - c[j], axis=1) <= r[j])


def _wavy_tube(rng, bend, wave, count=120, spacing=2.0):
    """A centerline bending at radius >= ``bend`` mm in a plane and waving out of it, with a lumen 30-50 mm
    across that widens and narrows along it."""
    s = spacing * np.arange(count)
    phase = rng.uniform(0, 2 * np.pi, size=2)
    theta = s / bend
    pts = np.stack([bend * np.sin(theta), bend * (1 - np.cos(theta)),
                    wave * np.sin(s / 37.0 + phase[0])], axis=1)
    # resample to an even spacing along the curve (the waving stretches it a little)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    even = np.arange(0.0, arc[-1], spacing)
    pts = np.stack([np.interp(even, arc, pts[:, c]) for c in range(3)], axis=1)
    lumen = 40.0 + 10.0 * np.sin(even / 23.0 + phase[1])
    return pts, lumen


@settings(max_examples=30, deadline=None)  # each example measures 4,001 points against the whole centerline
@given(seed=st.integers(0, 2**32 - 1), bend=st.floats(40.0, 400.0), wave=st.floats(0.0, 15.0),
       start=st.floats(20.0, 120.0), length=st.floats(1.0, 20.0), off=st.floats(0.0, 9.0))
@example(seed=37613, bend=45.0, wave=0.0, start=84.0, length=6.0, off=3.5)  # least at its end, lower past it
def test_a_module_inside_the_lumen_gets_its_exact_smallest_clearance(seed, bend, wave, start, length, off):
    """A module inside the lumen: bhr's smallest clearance along it is never above that of any of 4,001 points
    along it measured against the whole centerline, and is within 0.005 mm of their least (their spacing is at
    most 0.005 mm)."""
    rng = np.random.default_rng(seed)
    path, lumen = _wavy_tube(rng, bend, wave)
    tube = make_tube(path, lumen, closed_end=True)
    i0 = int(start / 2.0)
    i1 = i0 + max(1, int(round(length / 2.0)))
    side = rng.normal(size=(2, 3))
    side /= np.linalg.norm(side, axis=1)[:, None]
    Q = (path[[i0, i1]] + off * side)[None]
    E = np.array([[float(i0), float(i1)]])
    pt, mod, where = clearance_run(tube, 5.0, Q, E)
    dense = Q[0, 0] + np.linspace(0.0, 1.0, 4001)[:, None] * (Q[0, 1] - Q[0, 0])
    brute = brute_force_clearance(path, lumen, 5.0, dense)
    assert mod[0, 0] <= brute.min() + 1e-9
    assert mod[0, 0] >= brute.min() - 0.005
    # where it is: on the module, and the clearance comes down to that minimum there (where the nearest
    # centerline point jumps across a bend, from one side only)
    L = np.linalg.norm(Q[0, 1] - Q[0, 0])
    u = (Q[0, 1] - Q[0, 0]) / L
    assert np.linalg.norm(np.cross(where[0, 0] - Q[0, 0], u)) < 1e-9
    at = np.clip(np.dot(where[0, 0] - Q[0, 0], u) + np.linspace(-1e-4, 1e-4, 21), 0.0, L)  # on the module only
    near = Q[0, 0] + at[:, None] * u
    assert brute_force_clearance(path, lumen, 5.0, near).min() == pytest.approx(mod[0, 0], abs=1e-4)


def test_a_module_narrowest_where_it_passes_the_outside_of_a_corner_is_scored_there():
    """The lumen narrows from 50 to 20 mm across into a 60 deg corner and widens again after it. A module coming
    at the corner from its outside is least clear where it passes the corner's plane: before it the lumen
    narrows faster than the module nears the centerline, after it the module nears the corner point."""
    u = np.array([np.cos(np.pi / 3), np.sin(np.pi / 3), 0.0])
    path = np.vstack([np.arange(-10.0, 0.1, 2.0)[:, None] * [1.0, 0.0, 0.0],
                      np.arange(2.0, 10.1, 2.0)[:, None] * u])
    lumen = 2 * np.concatenate([25.0 - 1.5 * (path[:6, 0] + 10.0), 10.0 + 1.5 * np.arange(2.0, 10.1, 2.0)])
    tube = make_tube(path, lumen, (1.0, 0.0, 0.0), closed_end=True)
    Q = np.array([[[-4.0, -4.0, 0.0], [2.0, 1.0, 0.0]]])
    pt, mod, where = clearance_run(tube, 0.0, Q, np.array([[3.0, 6.0]]))
    assert mod[0, 0] == pytest.approx(10.0 - 2.0 / 3.0, abs=1e-9)
    assert where[0, 0] == pytest.approx([0.0, -2.0 / 3.0, 0.0], abs=1e-9)
    dense = Q[0, 0] + np.linspace(0.0, 1.0, 6001)[:, None] * (Q[0, 1] - Q[0, 0])
    assert brute_force_clearance(path, lumen, 0.0, dense).min() == pytest.approx(mod[0, 0], abs=1e-3)


@settings(max_examples=20, deadline=None)  # each example measures 4,001 points against the whole centerline
@given(seed=st.integers(0, 2**32 - 1), bend=st.floats(40.0, 400.0), wave=st.floats(0.0, 15.0),
       back=st.floats(0.5, 8.0), ahead=st.integers(1, 6), off=st.floats(0.0, 9.0))
def test_a_module_entering_the_colon_gets_the_exact_smallest_clearance_of_its_part_inside(seed, bend, wave, back,
                                                                                           ahead, off):
    """A module whose rear end is still behind the entrance is scored on its part past it: bhr's smallest
    clearance there is never above that of 4,001 points along that part, within 0.005 mm of their least, and the
    same as the numpy reference's."""
    rng = np.random.default_rng(seed)
    path, lumen = _wavy_tube(rng, bend, wave)
    tube = make_tube(path, lumen, closed_end=True)
    d0 = (path[1] - path[0]) / np.linalg.norm(path[1] - path[0])
    side = rng.normal(size=(2, 3))
    side -= (side @ d0)[:, None] * d0  # across the entrance's direction
    side /= np.linalg.norm(side, axis=1)[:, None]
    Q = np.stack([path[0] - back * d0 + off * side[0], path[ahead] + off * side[1]])[None]
    E = np.array([[-back / 2.0, float(ahead)]])  # the points 2 mm apart: expected indices
    pt, mod, where = clearance_run(tube, 5.0, Q, E)
    assert np.isnan(pt[0, 0]) and not np.isnan(mod[0, 0])
    t0 = (back / 2.0) / (back / 2.0 + ahead)
    dense = Q[0, 0] + np.linspace(t0, 1.0, 4001)[:, None] * (Q[0, 1] - Q[0, 0])
    brute = brute_force_clearance(tube.points, 2.0 * tube.radius, 5.0, dense)  # the lumen as bhr's tube has it:
    assert brute.min() - 0.005 <= mod[0, 0] <= brute.min() + 1e-9           # open at the entrance, going on straight
    ref_pt, ref_mod, ref_where = clearance_run_numpy(tube, 5.0, Q, E)
    assert ref_mod[0, 0] == pytest.approx(mod[0, 0], abs=1e-9) and ref_where[0, 0] == pytest.approx(where[0, 0], abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), steps=st.integers(1, 30), points=st.integers(0, 5), modules=st.integers(0, 5),
       nan_share=st.floats(0.0, 1.0), moved=st.one_of(st.none(), st.integers(0, 40)))
def test_the_report_pass_equals_numpy(seed, steps, points, modules, nan_share, moved):
    """The report's one pass over a run's clearances (each step's least, the touches, the contact per module, where
    the least is) equals numpy's nanmin, nanargmin and counts: rows of NaN, ties, a feeder stopped early."""
    from bhr._run.clearance import _tables_kernel, row_min

    rng = np.random.default_rng(seed)
    both = np.round(rng.normal(2.0, 3.0, size=(steps, points + modules)), 1)  # rounded: ties and exact zeros
    both[rng.random(both.shape) < nan_share] = np.nan
    per = np.empty(steps)
    touching = np.zeros(modules)
    s, p = _tables_kernel(both, modules, steps if moved is None else moved, per, touching)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # nanmin of a row of NaN
        np.testing.assert_array_equal(per, np.nanmin(both, axis=1) if both.shape[1] else np.full(steps, np.nan))
        np.testing.assert_array_equal(per, row_min(both))
        np.testing.assert_array_equal(touching, np.sum(both[:moved, points:] <= 0.0, axis=0))
    if np.all(np.isnan(both)):
        assert (s, p) == (-1, -1)
    else:
        assert (s, p) == divmod(int(np.nanargmin(both)), both.shape[1])
