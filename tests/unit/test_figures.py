"""What the figures draw: read back from the matplotlib artists of real runs (no mocks).

Error figures: step numbers under every panel, the tolerance and the worst step
in each panel's legend, the worst step marked where it is. path.png: the whole
path and the lumen's wall on both sides, start and end, an inset on the robot,
thinned path marks, the canvas shaped to the path; 3-D: the depth cue. Frames:
a window that follows the robot, an overview and a readout of the step's errors.
Heat-maps: a panel per third axis with units, over-tolerance hatching and the
thesis design framed.
"""
from __future__ import annotations

import warnings

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from bhr.model._generators import load_trajectory  # noqa: E402
from bhr.output._error_plot import ERROR_KINDS, body_figure, error_figure  # noqa: E402
from bhr.output._path_plot import path_figure  # noqa: E402
from bhr.output._scene import FRAME_INCHES, FRAME_ZOOM, LUMEN_WALL, lumen_walls, zoom_half_width  # noqa: E402
from bhr.output._stepview import StepView  # noqa: E402
from bhr._run.driver import follow  # noqa: E402


@pytest.fixture(scope="module")
def colon():
    return follow(load_trajectory("colon"), solver="seed")


@pytest.fixture(scope="module")
def spiral():
    return follow(load_trajectory("spiral"), solver="seed")


def _visible_ticks(ax) -> list[str]:
    return [t.get_text() for t in ax.get_xticklabels() if t.get_visible() and t.get_text()]


@pytest.mark.parametrize("kind", list(ERROR_KINDS))
def test_every_error_panel_has_step_numbers_tolerance_and_worst_step(colon, kind):
    fig = error_figure(colon, kind)
    fig.canvas.draw()
    data = {"position": colon.point_errors_mm, "orientation": colon.orientation_errors_deg,
            "global": colon.global_errors}[kind]
    tol = {"position": "tolerance 8 mm", "orientation": "tolerance 20 deg", "global": "tolerance (1)"}[kind]
    unit = {"position": " mm", "orientation": " deg", "global": ""}[kind]
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert len(panels) == data.shape[1]
    for j, ax in enumerate(panels):
        ticks = _visible_ticks(ax)
        assert len(ticks) >= 4 and "800" in ticks, (ax.get_title(), ticks)  # the "Fourth" panels too
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        k = int(np.argmax(data[:, j]))
        assert legend[:2] == [tol, f"worst {data[k, j]:.2f}{unit} (step {k + 1})"], legend
        (mark,) = [ln for ln in ax.lines if ln.get_label().startswith("worst")]
        assert mark.get_xydata().tolist() == [[k + 1, data[k, j]]]
        assert ax.get_ylim()[1] > max(data[k, j], 1.0 if kind == "global" else 0.0)


@pytest.mark.parametrize("modules, traj", [(5, "curve"), (4, "curve"),
                                           pytest.param(5, "anatomy", marks=pytest.mark.run)])
def test_a_runs_error_figures_drawn_on_one_grid_are_the_figures_drawn_alone(tmp_path, modules, traj):
    """save_run_plots fills one figure with the three kinds of error in turn (each panel's legend made once and
    given the next kind's words); each PNG is, pixel for pixel, the figure error_figure draws on its own. With 4
    modules the points need 3 rows and the modules 2: two grids. The anatomical colon's run touches the wall: its
    legends have a third entry (a whole colon and all its figures, the lumen's too: a run)."""
    from PIL import Image

    from bhr.output._figure import save_figure
    from bhr.output._run_plots import save_run_plots

    path = load_trajectory("curve", angle=180.0) if traj == "curve" else load_trajectory(traj)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the anatomical colon's bends too tight for the robot: it touches the wall
        run = follow(path, solver="seed", modules=modules)
    if traj == "anatomy":
        assert run.clearance.touch_steps and "wall touched" in [t.get_text() for t in
                                                                error_figure(run, "global").axes[0].get_legend().get_texts()]
    save_run_plots(run, tmp_path)
    sizes = set()
    for kind, (name, _, _) in ERROR_KINDS.items():
        alone = save_figure(error_figure(run, kind), tmp_path / f"alone-{name}", compress=1)
        a, b = (np.asarray(Image.open(f)) for f in (tmp_path / name, alone))
        assert a.shape == b.shape and (a == b).all(), kind
        sizes.add(a.shape)
    assert len(sizes) == (1 if modules == 5 else 2)


def test_the_worst_step_check_can_fail(colon):
    """The legend names the largest error of its own panel, not of a neighbour's."""
    fig = error_figure(colon, "position")
    first = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    tip = [t.get_text() for t in fig.axes[5].get_legend().get_texts()]
    assert first[1] != tip[1]


def test_body_figure_marks_both_worst_steps_and_the_tolerance():
    r = follow(load_trajectory("curve", angle=180.0), solver="seed", body_modules=8)
    ax = body_figure(r).axes[0]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    head = r.point_errors_mm.max(axis=1)
    body = r.body.point_errors_mm.max(axis=1)
    assert "tolerance 8 mm" in legend
    assert f"head worst {head.max():.2f} mm (step {int(np.argmax(head)) + 1})" in legend
    assert f"body worst {body.max():.2f} mm (step {int(np.argmax(body)) + 1})" in legend


def _line(ax, label):
    found = [ln for ln in ax.lines if ln.get_label() == label]
    assert found, f"no {label!r} in {[ln.get_label() for ln in ax.lines]}"
    return found[0]


@pytest.mark.run
def test_3d_path_png_draws_the_lumen_wall_as_rings_around_the_centerline():
    """In 3-D the wall is a tube: rings of the lumen's radius, square to the path, about every half diameter."""
    run = follow(load_trajectory("anatomy", seed=3), solver="lumen")
    traj = run.trajectory
    spacing = float(np.median(np.linalg.norm(np.diff(traj.points, axis=0), axis=1)))
    fig = path_figure(run)
    for ax in fig.axes[:2]:  # the whole colon and the zoom on the robot
        rings = [ln for ln in ax.lines if ln.get_color() == LUMEN_WALL]
        assert [ln.get_label() for ln in rings].count("lumen wall") == 1  # one legend entry
        for ln in rings:
            xyz = np.column_stack(ln.get_data_3d())
            c = xyz[:-1].mean(axis=0)  # (the last point closes the ring)
            k = int(np.argmin(np.linalg.norm(traj.points - c, axis=1)))
            np.testing.assert_allclose(c, traj.points[k], atol=1e-6)
            np.testing.assert_allclose(np.linalg.norm(xyz - c, axis=1), traj.lumen[k] / 2, rtol=1e-9)
            t = traj.points[min(k + 1, len(traj.points) - 1)] - traj.points[max(k - 1, 0)]
            assert np.abs((xyz - c) @ (t / np.linalg.norm(t))).max() < 1e-6 * traj.lumen[k]
        expected = len(traj.points) * spacing / (0.5 * float(np.median(traj.lumen)))
        assert 0.8 * expected <= len(rings) <= 1.25 * expected + 1


def test_path_png_shows_the_whole_colon_its_wall_start_end_and_an_inset(colon):
    fig = path_figure(colon)
    ax = fig.axes[0]
    traj = colon.trajectory
    left, right = lumen_walls(traj, True)
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    for pts in (traj.points, left, right, colon.points[-1]):
        assert (pts[:, 0] > x0).all() and (pts[:, 0] < x1).all() and (pts[:, 1] > y0).all() and (pts[:, 1] < y1).all()
    # the wall: both sides of the tube, half the lumen's diameter from the centerline, in the view's plane
    walls = [ln for ln in ax.lines if ln.get_color() == LUMEN_WALL]
    assert len(walls) == 2 and _line(ax, "lumen wall") in walls
    for ln in walls:
        xy = ln.get_xydata()
        assert np.allclose(np.hypot(*(xy - traj.points[:, :2]).T), traj.lumen / 2)
    assert [p.get_label() for p in ax.patches if p.get_label() == "lumen"] == ["lumen"]
    assert _line(ax, "start").get_xydata().tolist() == [traj.points[0, :2].tolist()]
    assert _line(ax, "end").get_xydata().tolist() == [traj.points[-1, :2].tolist()]
    # path marks thinned: a line with at most ~120 marks, not 827 crosses
    path = _line(ax, "trajectory")
    every = path.get_markevery()
    assert isinstance(every, int) and 1 < every and len(traj.points) / every <= 150
    # the inset zooms on the final pose: the robot drawn in it, a window a few head lengths wide
    (inset,) = ax.child_axes
    robot = _line(inset, "robot")
    assert np.allclose(robot.get_xydata(), colon.points[-1][:, :2])
    ix0, ix1 = inset.get_xlim()
    assert ix1 - ix0 < 0.2 * (x1 - x0)
    assert (colon.points[-1][:, 0] > ix0).all() and (colon.points[-1][:, 0] < ix1).all()
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    for want in ("lumen wall", "trajectory", "start", "end", "target", "robot"):
        assert want in legend


def test_a_short_path_has_no_inset():
    r = follow(load_trajectory("curve"), solver="seed")
    assert path_figure(r).axes[0].child_axes == []


@pytest.mark.run
def test_body_run_path_png_fills_its_canvas_with_the_path():
    r = follow(load_trajectory("colon"), solver="seed", body_modules=60)
    fig = path_figure(r)
    ax = fig.axes[0]
    fig.canvas.draw()
    # the straight body of the first steps (600 mm along -x) does not widen the final view
    assert ax.get_xlim()[0] > -60
    box = ax.get_position()
    assert box.width * box.height > 0.6  # the axes take most of the figure
    assert _line(ax, "body") is not None


def test_3d_spiral_has_a_depth_cue(spiral):
    fig = path_figure(spiral)
    ax = fig.axes[0]
    assert ax.name == "3d"
    shadow = _line(ax, "shadow on the floor")
    xs, ys, zs = shadow.get_data_3d()
    assert np.allclose(xs, spiral.trajectory.points[:, 0]) and np.allclose(ys, spiral.trajectory.points[:, 1])
    assert np.allclose(zs, ax.get_zlim()[0])  # on the floor of the box
    drops = [ln for ln in ax.lines if ln.get_linestyle() == ":"]
    assert len(drops) == 3  # from the start, the end and the robot's tip down to the floor
    for ln in drops:
        xs, ys, zs = ln.get_data_3d()
        assert xs[0] == xs[1] and ys[0] == ys[1] and zs[1] == ax.get_zlim()[0]


def _frame(result) -> StepView:
    fig = Figure(figsize=FRAME_INCHES, dpi=100)
    FigureCanvasAgg(fig)
    return StepView(result, fig=fig)


@pytest.mark.parametrize("step", [0, 300, 826])
def test_frames_follow_the_robot_with_an_overview_and_a_readout(colon, step):
    view = _frame(colon)
    view.draw(step)
    half = zoom_half_width(colon, FRAME_ZOOM)
    head = colon.points[step]
    centre = (head.min(axis=0) + head.max(axis=0)) / 2
    assert np.allclose(view.ax.get_xlim(), [centre[0] - half, centre[0] + half])
    assert np.allclose(view.ax.get_ylim(), [centre[1] - half, centre[1] + half])
    span = np.ptp(colon.trajectory.points, axis=0).max()
    assert 2 * half < span / 3  # zoomed: the 50 mm robot is large, not lost on the 800 mm colon
    ox0, ox1 = view.overview.get_xlim()
    oy0, oy1 = view.overview.get_ylim()
    p = colon.trajectory.points
    assert ox0 < p[:, 0].min() and p[:, 0].max() < ox1 and oy0 < p[:, 1].min() and p[:, 1].max() < oy1
    text = view.readout.get_text()
    assert f"step {step + 1} of 827" in text
    assert f"tip error     {colon.point_errors_mm[step, -1]:7.2f} mm" in text
    assert f"tip angle     {colon.orientation_errors_deg[step, -1]:7.2f} deg" in text
    # the overview shows the left view's window as one shaded square clipped to the overview, no loose lines
    from matplotlib.patches import Rectangle

    windows = [a for a in view.artists if isinstance(a, Rectangle)]
    assert len(windows) == 1 and windows[0].axes is view.overview and windows[0].get_clip_on()
    assert windows[0].get_clip_box() is not None
    assert np.allclose(windows[0].get_xy(), [centre[0] - half, centre[1] - half])
    assert np.isclose(windows[0].get_width(), 2 * half)
    # the readout fits inside the frame
    view.fig.canvas.draw()
    box = view.readout.get_window_extent()
    assert box.x1 <= view.fig.bbox.x1 and box.y0 >= 0
    # the window moves with the robot: another step, another window
    other = 200 if step != 200 else 600
    view.draw(other)
    assert not np.allclose(view.ax.get_xlim(), [centre[0] - half, centre[0] + half]) or \
        not np.allclose(view.ax.get_ylim(), [centre[1] - half, centre[1] + half])


def test_3d_frames_follow_the_robot(spiral):
    view = _frame(spiral)
    view.draw(250)
    half = zoom_half_width(spiral, FRAME_ZOOM)
    head = spiral.points[250]
    centre = (head.min(axis=0) + head.max(axis=0)) / 2
    for lim, c in zip((view.ax.get_xlim(), view.ax.get_ylim(), view.ax.get_zlim()), centre):
        assert np.allclose(lim, [c - half, c + half])
    assert "tip error" in view.readout.get_text()


def test_compare_figure_has_step_numbers_tolerance_and_each_solvers_worst_step():
    from bhr.model._robot import Robot
    from bhr._studies.compare import compare_figure, compare_runs

    runs = compare_runs(load_trajectory("curve", angle=180.0), ["seed", "fabrik"], Robot())
    fig = compare_figure(runs)
    fig.canvas.draw()
    for ax, values in zip(fig.axes, (lambda r: r.point_errors_mm.max(axis=1), lambda r: r.point_errors_mm[:, -1])):
        assert len(_visible_ticks(ax)) >= 4
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert "tolerance 8 mm" in legend
        for c in runs:
            v = values(c.result)
            k = int(np.argmax(v))
            assert f"{c.solver} worst {v[k]:.2f} mm (step {k + 1})" in legend


def test_solve_plot_keeps_the_target_inside_and_the_solution_in_front():
    from bhr.output._path_plot import chain_figure

    initial = np.array([[0, 2.0 * k, 0] for k in range(6)])
    final = np.array([[0, 0, 0], [0, 2, 0], [0.35, 3.97, 0], [1.03, 5.85, 0], [2.03, 7.58, 0], [3.0, 9.0, 0]])
    fig = chain_figure(initial, final, (3, 9, 0))
    ax = fig.axes[0]
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    assert x0 < 0 - 0.05 * 10 and x1 > 3 + 0.05 * 10 and y1 > 10 + 0.05 * 10  # room around the target's marker
    lifted = final.copy()
    lifted[2:, 2] = [0.5, 1.5, 2.5, 4.0]
    fig = chain_figure(initial, lifted, lifted[-1])
    ax = fig.axes[0]
    assert ax.computed_zorder is False
    z = {ln.get_label(): ln.get_zorder() for ln in ax.get_lines()}
    assert z["final"] > z["initial"] and z["target"] > z["final"]
    lo, hi = np.array([ax.get_xlim(), ax.get_ylim(), ax.get_zlim()]).T
    assert np.all(lifted[-1] > lo) and np.all(lifted[-1] < hi)
