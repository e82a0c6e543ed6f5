"""Pose figures: the whole path with the robot at one step (``path.png``) and the chain of ``bhr solve``."""
from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np
from matplotlib.figure import Figure

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult
from bhr.output._scene import (
    INSET_ZOOM,
    check_step,
    depth_cue,
    draw_context,
    draw_pose,
    equal_3d,
    inset_rect,
    legend_below,
    plot_points,
    pose_points,
    set_window,
    setup_axes,
    zoom_window,
    draw_robot,
    draw_section_names,
    draw_travel_arrow,
    label_sections,
    lumen_walls,
    marker_stride,
    run_is_planar,
)

__all__ = ["path_figure", "chain_figure"]


def path_figure(result: "FollowResult", step: int | None = None) -> Figure:
    """The whole path and the robot's pose at ``step`` (0-based, default: the last); top view when planar.

    The lumen's wall is drawn where the trajectory has a lumen, start and end
    are marked, and when the robot is small beside the path an inset (3-D: a
    second panel) zooms on it. The canvas takes the shape of the path.

    Parameters
    ----------
    result : FollowResult
        A run, as :func:`bhr.follow` returns it.
    step : int, optional
        The 0-based step whose pose is drawn; default the last.

    Returns
    -------
    matplotlib.figure.Figure
        The path (mm) with the robot's discs at ``step``; ``bhr follow`` saves it as ``path.png``.

    Raises
    ------
    BhrError
        A ``step`` outside the run.
    """
    i = check_step(result, result.steps - 1 if step is None else step)
    only = None if step is None else i  # a figure of one chosen step: that step's wall contacts, not every step's
    planar = run_is_planar(result)
    traj = result.trajectory
    walls = lumen_walls(traj, planar)
    pose = pose_points(result, i)
    every = marker_stride(traj.points)
    parts = [traj.points, pose] + (list(walls) if walls is not None else [])
    allpts = np.vstack(parts)
    centre, half = zoom_window(result, i, INSET_ZOOM)
    view = "top view" if planar else "3D view"
    title = f"{traj.name}: path and robot at step {i + 1} of {result.steps} ({view}, solver {result.solver})"
    if planar:
        lo, hi = allpts[:, :2].min(axis=0), allpts[:, :2].max(axis=0)
        span = hi - lo
        pad = result.robot.robot_radius + 0.03 * max(float(span.max()), 1.0)
        lo, hi = lo - pad, hi + pad
        w, h = float(hi[0] - lo[0]), float(hi[1] - lo[1])
        ax_w = 7.6
        ax_h = ax_w * h / w
        if ax_h > 8.0:
            ax_h, ax_w = 8.0, 8.0 * w / h
        if ax_h < 2.6:  # a flat path: show more around it rather than a thin strip
            ax_h = 2.6
            grow = (w * ax_h / ax_w - h) / 2
            lo, hi = lo - [0.0, grow], hi + [0.0, grow]
        # A fixed layout in inches (no tight_layout pass): the canvas takes the path's shape.
        left, right, bottom, top = 0.85, 0.3, 1.05, 0.4
        fw, fh = max(ax_w + left + right, 6.0), ax_h + bottom + top
        fig = Figure(figsize=(fw, fh))
        ax = setup_axes(fig, True, (left / fw, bottom / fh, ax_w / fw, ax_h / fh))
        draw_context(ax, result, True, every, contacts_step=only)
        label_sections(ax, traj, True)
        draw_travel_arrow(ax, traj.points, True)
        draw_pose(ax, result, i, True)
        draw_section_names(ax, traj, True)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        # placed at the top of the axes, where matplotlib's automatic placement puts it (nothing is drawn above
        # the axes), without that placement's measuring of every tick label at each draw
        ax.set_title(title, fontsize=10, y=1.0)
        legend_below(fig, ax)
        if 2 * half < 0.45 * min(w, h):
            window = (centre[0] - half, centre[0] + half, centre[1] - half, centre[1] + half)
            side = max(0.36 * min(w, h), 2.2 * half)
            rect = inset_rect((lo[0], hi[0], lo[1], hi[1]), np.vstack([traj.points, pose]), window, side)
            ins = ax.inset_axes(rect)
            draw_context(ins, result, True, contacts_step=only)
            draw_pose(ins, result, i, True, target_size=11)
            ins.set_xlim(window[0], window[1])
            ins.set_ylim(window[2], window[3])
            ins.set_aspect("equal", adjustable="box")
            ins.tick_params(labelsize=7)
            ins.set_facecolor("white")
            ins.set_title(f"robot, zoomed (step {i + 1})", fontsize=8, pad=2, y=1.0)
            ax.indicate_inset_zoom(ins, edgecolor="0.25", alpha=0.9)
        return fig
    extent = float(np.ptp(allpts, axis=0).max())
    zoom = 2 * half < 0.45 * extent
    fig = Figure(figsize=(14, 7) if zoom else (8, 7))
    ax = fig.add_subplot(1, 2 if zoom else 1, 1, projection="3d")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    equal_3d(ax, allpts, pad=0.02 * extent)
    draw_context(ax, result, False, every, contacts_step=only)
    label_sections(ax, traj, False)
    draw_travel_arrow(ax, traj.points, False)
    draw_pose(ax, result, i, False)
    depth_cue(ax, result, i, ax.get_zlim()[0])
    draw_section_names(ax, traj, False)
    ax.set_title(title, fontsize=10)  # a 3-D axes' title is laid out above its box (not at y = 1)
    if zoom:
        ins = fig.add_subplot(1, 2, 2, projection="3d")
        ins.set_xlabel("x (mm)")
        ins.set_ylabel("y (mm)")
        ins.set_zlabel("z (mm)")
        set_window(ins, centre, half, False)
        ins.set_box_aspect((1, 1, 1))
        draw_context(ins, result, False, contacts_step=only)
        draw_pose(ins, result, i, False, target_size=11)
        depth_cue(ins, result, i, ins.get_zlim()[0])
        ins.set_title(f"robot, zoomed (step {i + 1})", fontsize=10)
    fig.subplots_adjust(left=0.02, right=0.95 if zoom else 0.92, bottom=0.1, top=0.95, wspace=0.15)
    legend_below(fig, ax)
    return fig


def chain_figure(initial: np.ndarray, final: np.ndarray, target: Sequence[float], radius: float | None = None,
                 title: str = "") -> Figure:
    """Initial and final chain of one solve (thesis Figs. 5.8-5.22): 2D when all lies in z = 0.

    Parameters
    ----------
    initial : numpy.ndarray, shape (n+1, 3)
        The chain before the solve, base first, mm (drawn grey and dashed).
    final : numpy.ndarray, shape (n+1, 3)
        The chain after the solve, base first, mm.
    target : sequence of float, shape (3,)
        The target, mm (a green cross).
    radius : float, optional
        The disc radius, mm: the final chain is drawn with its discs; None or 0 draws it as a line.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        One panel, mm on its axes; ``bhr solve --plot`` saves it.

    Examples
    --------
    >>> import bhr
    >>> from bhr.model import CHAPTER5_ROBOT
    >>> from bhr.solvers import Chain
    >>> start = Chain.straight(CHAPTER5_ROBOT.replace(modules=10), (0, 1, 0)).points
    >>> res = bhr.solve([3, 9, 0], modules=10)
    >>> fig = chain_figure(start, res.points, [3, 9, 0], title="one solve")
    >>> fig.axes[0].get_title()
    'one solve'
    """
    t = np.asarray(target, dtype=np.float64)
    allpts = np.vstack([initial, final, t[None]])
    planar = bool(np.all(np.abs(allpts[:, 2]) < 1e-12))
    fig = Figure(figsize=(7, 7))
    ax = setup_axes(fig, planar)
    if not planar:
        ax.computed_zorder = False  # draw in zorder: the solution over the initial chain, whatever the depth
    # the initial chain thin, grey and dashed behind; the solution and the target on top
    plot_points(ax, initial, planar, "--o", color="0.55", markersize=2.5, linewidth=1.0, label="initial", zorder=2)
    draw_robot(ax, final, radius or 0.0, planar, color="tab:red", label="final", discs=bool(radius))
    plot_points(ax, t[None], planar, "x", color="tab:green", markersize=11, markeredgewidth=2.0, label="target",
          zorder=8)
    span = float(np.ptp(allpts, axis=0).max()) or 1.0
    pad = 0.08 * span  # room around the chain and the target so that no marker is cut at the frame
    if planar:
        lo, hi = allpts[:, :2].min(axis=0) - pad, allpts[:, :2].max(axis=0) + pad
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    else:
        equal_3d(ax, allpts, pad=pad)
        # look across the plane the solution bends in, so that it does not hide behind the initial chain
        d = final[-1] - final[0]
        ax.view_init(elev=20, azim=float(np.degrees(np.arctan2(d[1], d[0]))) - 60)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig
