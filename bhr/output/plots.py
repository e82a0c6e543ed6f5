"""Figures with matplotlib: error plots (thesis Figs. 7.2-7.21) and robot views.

Import this module only when plotting; the rest of bhr does not need
matplotlib. The scene is drawn by small functions shared by the path figure
(:func:`path_figure`: the whole path, the pose, an inset on the robot), the
live view and the animation (:class:`StepView`: a view that follows the
robot): :func:`draw_lumen_wall`, :func:`draw_path`, :func:`draw_start_end`,
:func:`draw_target` and :func:`draw_robot` (points, links, and a disc of the
robot's radius at each module, oriented with it).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from bhr.output.atomic import atomic_path
from bhr.settings.errors import BhrError

if TYPE_CHECKING:  # pragma: no cover
    from bhr.run.driver import FollowResult

__all__ = ["subplots", "error_figure", "path_figure", "chain_figure", "draw_robot", "capsule_outline", "label_sections",
           "draw_travel_arrow", "colon_sections", "draw_path", "save_figure",
           "save_run_plots", "ERROR_KINDS", "StepView", "run_is_planar",
           "body_figure", "clearance_figure", "mark_wall_touches", "mark_worst", "draw_lumen_wall", "lumen_walls",
           "draw_start_end", "draw_target", "marker_stride", "zoom_half_width", "FRAME_INCHES", "draw_contacts",
           "draw_contact_steps"]

ORDINALS = ["First", "Second", "Third", "Fourth", "Fifth", "Sixth", "Seventh", "Eighth", "Ninth", "Tenth"]

ERROR_KINDS = {
    "position": ("position_errors.png", "Position error of each point", "position error (mm)"),
    "orientation": ("orientation_errors.png", "Orientation error of each module", "orientation error (deg)"),
    "global": ("global_errors.png", "Global error of each module", "global error (-)"),
}


def subplots(*grid: int, figsize: tuple[float, float], **kw: Any) -> tuple[Figure, Any]:
    """A new :class:`matplotlib.figure.Figure` of ``figsize`` inches and its axes (``Figure.subplots``): no pyplot,
    so nothing global to close and no backend to choose; the figure is saved by :func:`save_figure`."""
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(*grid, **kw)


def _panel_title(kind: str, j: int, count: int) -> str:
    what = "point" if kind == "position" else "module"
    name = ORDINALS[j] if j < len(ORDINALS) else f"{j + 1}th"
    label = f"{name} {what}"
    if j == 0:
        label += " (base)"
    if j == count - 1:
        label += " (tip)"
    return label


def _unit(kind: str) -> str:
    return {"position": "mm", "orientation": "deg", "global": ""}[kind]


def _amount(value: float, unit: str, digits: int = 2) -> str:
    return f"{value:.{digits}f} {unit}".rstrip() if unit else f"{value:.{digits}f}"


def mark_worst(ax: Any, steps: np.ndarray, values: np.ndarray, unit: str, color: str = "black",
               what: str = "worst") -> int | None:
    """Circle the largest value of ``values`` (first such step) and name it in the legend; return its index."""
    if values.size == 0 or not np.isfinite(values).any():
        return None
    k = int(np.nanargmax(values))
    ax.plot([steps[k]], [values[k]], "o", markersize=7, markerfacecolor="none", markeredgecolor=color,
            markeredgewidth=1.3, label=f"{what} {_amount(float(values[k]), unit)} (step {int(steps[k])})")
    return k


def _error_data(result: "FollowResult", kind: str) -> np.ndarray:
    if kind not in ERROR_KINDS:
        raise ValueError(f"kind must be one of {', '.join(ERROR_KINDS)}")
    return {"position": result.point_errors_mm, "orientation": result.orientation_errors_deg,
            "global": result.global_errors}[kind]


def _error_grid_shape(count: int) -> tuple[int, int]:
    cols = 2 if count > 1 else 1
    return int(np.ceil(count / cols)), cols


class _ErrorGrid:
    """The panels of the error figures, made once and filled with one kind of error after another.

    The three error figures of a run share their grid, their step axis and the steps where the wall is touched;
    what differs is each panel's curve, tolerance, worst step, title, y axis and legend. Filling the same
    figure again draws what a new one would (tests/unit/test_figures.py compares the pixels), without making
    the axes, their ticks and the step numbers' text again: most of an error figure's drawing time.
    """

    def __init__(self, result: "FollowResult", rows: int, cols: int) -> None:
        self.result, self.rows, self.cols = result, rows, cols
        self.n = result.steps
        width, height = 10.0, 2.6 * rows + 0.9
        self.fig, axes = subplots(rows, cols, figsize=(width, height), squeeze=False, sharex=True,
                                      gridspec_kw=_margins(width, height, rows, cols))
        self.axes = [axes[j // cols][j % cols] for j in range(rows * cols)]
        self.steps = np.arange(1, self.n + 1)
        self.curves, self.tols, self.marks = [], [], []
        for ax in self.axes:
            (curve,) = ax.plot(self.steps, np.zeros(self.n), color="tab:blue", linewidth=1.0)
            self.curves.append(curve)
            self.tols.append(ax.axhline(0.0, color="tab:red", linestyle="--", linewidth=0.8))
            (mark,) = ax.plot([], [], "o", markersize=7, markerfacecolor="none", markeredgecolor="black",
                              markeredgewidth=1.3)
            self.marks.append(mark)
            mark_wall_touches(ax, result)
            ax.grid(True, alpha=0.3)
            ax.set_xlim(1, max(2, self.n))
            ax.tick_params(labelbottom=True, labelsize=8)  # step numbers on every panel, not only the bottom row
            _light_ticks(ax)
        self.title = self.fig.suptitle("", fontsize=12, y=1 - 0.12 / height)

    def fill(self, kind: str) -> Figure:
        """The figure with ``kind``'s errors: one panel per point (position) or module (orientation, global)."""
        result, cols = self.result, self.cols
        data = _error_data(result, kind)
        if data.shape[0] != self.n or _error_grid_shape(data.shape[1]) != (self.rows, cols):
            raise ValueError(f"{kind} errors do not fit this grid")
        tol = {"position": result.robot.tol_pos, "orientation": result.robot.tol_ori, "global": 1.0}[kind]
        unit = _unit(kind)
        _, title, ylabel = ERROR_KINDS[kind]
        count = data.shape[1]
        tol_label = f"tolerance {tol:g} {unit}".rstrip() if kind != "global" else "tolerance (1)"
        for j, ax in enumerate(self.axes):
            if j >= count:
                ax.set_visible(False)
                continue
            ax.set_visible(True)
            col = data[:, j]
            self.curves[j].set_ydata(col)
            self.tols[j].set_ydata([tol, tol])
            self.tols[j].set_label(tol_label)
            mark = self.marks[j]
            if col.size and np.isfinite(col).any():
                k = int(np.nanargmax(col))
                mark.set_data([self.steps[k]], [col[k]])
                mark.set_label(f"worst {_amount(float(col[k]), unit)} (step {int(self.steps[k])})")
                mark.set_visible(True)
            else:
                mark.set_data([], [])
                mark.set_label("_worst")  # no legend entry
                mark.set_visible(False)
            ax.set_title(_panel_title(kind, j, count), fontsize=10, y=1.0, pad=4)  # placed, not laid out
            ax.set_ylabel(ylabel, fontsize=9)
            top = max(tol, float(np.nanmax(col)) if np.isfinite(col).any() else 0.0)
            ax.set_ylim(0, 1.45 * top if top > 0 else 1.0)  # room above for the legend
            _light_ticks(ax, which="y")
            ax.legend(loc="upper right", fontsize=7, framealpha=0.9, ncol=2)
            bottom = j // cols == self.rows - 1 or j + cols >= count
            ax.set_xlabel("trajectory step" if bottom else "", fontsize=9)
        self.title.set_text(f"{title} - {result.trajectory.name}, solver {result.solver}")
        return self.fig


def error_figure(result: "FollowResult", kind: str) -> Figure:
    """One panel per point (position) or module (orientation, global) against trajectory step.

    Every panel has its step numbers, the tolerance line and its worst step
    circled, both named in the panel's legend.
    """
    data = _error_data(result, kind)
    return _ErrorGrid(result, *_error_grid_shape(data.shape[1])).fill(kind)


def _light_ticks(ax: Any, bins: int = 5, which: str = "xy") -> None:
    """Ticks fixed once from the axes' limits: the same kind of numbers as matplotlib's default, fewer of them,
    and none computed again at each draw (ticks and their labels are most of an error figure's drawing time).
    ``which``: the axes whose ticks are fixed ("x", "y" or "xy")."""
    from matplotlib.ticker import FixedLocator, MaxNLocator

    for axis, (lo, hi) in [(a, lim) for name, a, lim in (("x", ax.xaxis, ax.get_xlim()), ("y", ax.yaxis, ax.get_ylim()))
                           if name in which]:
        ticks = [t for t in MaxNLocator(nbins=bins, steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
                 if lo - 1e-9 * abs(hi - lo) <= t <= hi + 1e-9 * abs(hi - lo)]
        axis.set_major_locator(FixedLocator(ticks))


def _margins(width: float, height: float, rows: int, cols: int, left: float = 0.7, right: float = 0.15,
             top: float = 0.75, bottom: float = 0.55, between: float = 0.7, across: float = 0.8) -> dict[str, float]:
    """Subplot margins given in inches (a fixed layout: no tight_layout pass, which costs a draw)."""
    ax_h = (height - top - bottom - between * (rows - 1)) / rows
    ax_w = (width - left - right - across * (cols - 1)) / cols
    return {"left": left / width, "right": 1 - right / width, "top": 1 - top / height, "bottom": bottom / height,
            "hspace": between / ax_h, "wspace": across / ax_w}


def _circle(center: np.ndarray, normal: np.ndarray, radius: float, count: int = 40) -> np.ndarray:
    normal = normal / np.linalg.norm(normal)
    ref = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(normal, ref)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    t = np.linspace(0, 2 * np.pi, count)
    return center + radius * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))


def _plot(ax: Any, pts: np.ndarray, planar: bool, *args: Any, **kw: Any) -> list[Any]:
    """``ax.plot`` of (k, 3) points: x, y on a 2-D axes; x, y, z (clipped to the axes' box) on a 3-D one."""
    pts = np.atleast_2d(pts)
    if planar:
        return ax.plot(pts[:, 0], pts[:, 1], *args, **kw)
    return ax.plot(pts[:, 0], pts[:, 1], pts[:, 2], *args, axlim_clip=True, **kw)


#: Colours of the scene: the lumen (fill and wall lines), start and end marks, shadows on the floor.
LUMEN_FILL, LUMEN_WALL = "#f4e9e4", "#8c6d62"
SHADOW = "0.72"


def marker_stride(path: np.ndarray, marks: int = 120) -> int:
    """Every how many points a path mark is drawn so that a whole path shows about ``marks`` marks."""
    return max(1, int(round(len(path) / marks)))


def draw_path(ax: Any, path: np.ndarray, planar: bool, **kw: Any) -> list[Any]:
    """The trajectory in blue with x marks, as the thesis draws it (``markevery`` thins the marks)."""
    style = {"color": "tab:blue", "marker": "x", "markersize": 3, "linewidth": 0.8, "label": "trajectory"}
    style.update(kw)
    return _plot(ax, path, planar, **style)


def lumen_walls(traj: Any, planar: bool) -> tuple[np.ndarray, np.ndarray] | None:
    """The two sides of the lumen's tube in the view's plane: the centerline moved by +-diameter/2 sideways.

    Sideways is the direction in the view's plane (x, y) at right angles to
    the path. None when the trajectory has no lumen.
    """
    lumen = getattr(traj, "lumen", None)
    if lumen is None or len(traj.points) < 2:
        return None
    p = np.asarray(traj.points, dtype=float)
    t = np.gradient(p, axis=0)
    side = np.stack([-t[:, 1], t[:, 0], np.zeros(len(p))], axis=1)  # tangent x z: horizontal, across the path
    norm = np.linalg.norm(side, axis=1)
    bad = norm < 1e-12  # a vertical stretch: any horizontal direction will do
    side[bad] = [1.0, 0.0, 0.0]
    norm[bad] = 1.0
    side /= norm[:, None]
    half = np.asarray(lumen, dtype=float)[:, None] / 2.0
    return p + half * side, p - half * side


def draw_lumen_wall(ax: Any, traj: Any, planar: bool) -> list[Any]:
    """The lumen's wall: from the top, both sides of the tube with the lumen shaded; in 3-D, rings around
    the centerline (one about every half lumen diameter). [] without a lumen."""
    walls = lumen_walls(traj, planar)
    if walls is None:
        return []
    style = {"color": LUMEN_WALL, "linewidth": 0.9, "zorder": 1}
    artists: list[Any] = []
    if planar:
        left, right = walls
        ring = np.vstack([left[:, :2], right[::-1, :2]])
        # the shading is added without updating the data limits (ax.fill would: a Python pass over its hundreds
        # of edges, 0.03 s a panel): the two walls drawn next are its outline and give the same limits
        from matplotlib.patches import Polygon

        shade = Polygon(ring, closed=True, color=LUMEN_FILL, linewidth=0, zorder=0.5, label="lumen")
        ax.add_artist(shade)
        artists.append(shade)
        artists += _plot(ax, left, planar, label="lumen wall", **style)
        artists += _plot(ax, right, planar, label="_lumen wall (other side)", **style)
        return artists
    pts = np.asarray(traj.points, dtype=float)
    diameter = np.asarray(traj.lumen, dtype=float)[: len(pts)]
    t = np.gradient(pts, axis=0)
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-12)[:, None]
    seg = float(np.median(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    every = max(1, int(round(0.5 * float(np.median(diameter)) / max(seg, 1e-9))))
    style.update(linewidth=0.6, alpha=0.55)
    for n, k in enumerate(list(range(0, len(pts), every)) + ([len(pts) - 1] if (len(pts) - 1) % every else [])):
        c = _circle(pts[k], t[k], diameter[k] / 2.0, 32)
        artists += _plot(ax, c, False, label="lumen wall" if n == 0 else "_lumen ring", **style)
    return artists


def draw_start_end(ax: Any, path: np.ndarray, planar: bool, size: float = 8) -> list[Any]:
    """The start (white circle) and the end (black square) of the path."""
    return (_plot(ax, path[:1], planar, "o", markersize=size, markerfacecolor="white", markeredgecolor="black",
                  markeredgewidth=1.5, linestyle="none", label="start", zorder=4)
            + _plot(ax, path[-1:], planar, "s", markersize=size - 1, color="black", linestyle="none",
                    label="end", zorder=4))


def colon_sections(traj: Any) -> list[tuple[str, int]] | None:
    """The anatomical sections of an anatomical colon's path: :func:`bhr.model.anatomy.path_sections`."""
    from bhr.model.anatomy import path_sections

    return path_sections(traj)


def label_sections(ax: Any, traj: Any, planar: bool) -> list[Any]:
    """Each anatomical section's name beside the middle of its stretch of path (anatomical colons only)."""
    sections = colon_sections(traj)
    if not sections:
        return []
    artists = []
    for name, k in sections:
        p = traj.points[k]
        kw = {"fontsize": 7.5, "color": "#5a3d33", "ha": "left", "va": "bottom", "zorder": 8,
              "bbox": {"boxstyle": "round,pad=0.15", "facecolor": "white", "alpha": 0.7, "linewidth": 0}}
        artists.append(ax.text(p[0], p[1], name, **kw) if planar else ax.text(p[0], p[1], p[2], name, **kw))
    return artists


def draw_travel_arrow(ax: Any, path: np.ndarray, planar: bool) -> list[Any]:
    """An arrow along the path near its start: the direction the robot travels (anus to cecum on a colon)."""
    pts = np.asarray(path, dtype=np.float64)
    if len(pts) < 3:
        return []
    extent = float(np.ptp(pts, axis=0).max()) or 1.0
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    a = int(np.searchsorted(s, 0.04 * extent))
    b = int(np.searchsorted(s, s[min(a, len(s) - 1)] + 0.08 * extent))
    a, b = min(a, len(pts) - 2), min(max(b, a + 1), len(pts) - 1)
    p, q = pts[a], pts[b]
    if planar:
        return [ax.annotate("", xy=(q[0], q[1]), xytext=(p[0], p[1]), zorder=8,
                            arrowprops={"arrowstyle": "-|>", "color": "#2b2b2b", "linewidth": 2.0}),
                ax.text(q[0], q[1], " direction of travel", fontsize=7.5, color="#2b2b2b", zorder=8)]
    d = q - p
    return [ax.quiver(p[0], p[1], p[2], d[0], d[1], d[2], color="#2b2b2b", linewidth=2.0, arrow_length_ratio=0.35),
            ax.text(q[0], q[1], q[2], " direction of travel", fontsize=7.5, color="#2b2b2b", va="top")]


def draw_target(ax: Any, point: np.ndarray, planar: bool, size: float = 9) -> list[Any]:
    """The step's target point (green x)."""
    return _plot(ax, point, planar, "x", color="tab:green", markersize=size, markeredgewidth=1.5, label="target",
                 zorder=5)


def capsule_outline(a: np.ndarray, b: np.ndarray, radius: float, count: int = 16) -> np.ndarray | None:
    """(K, 2) outline of the module from ``a`` to ``b`` (2-D) widened by ``radius``: the shape the clearance
    scores (the segment's points within the radius), None for a module of no length."""
    d = b - a
    length = float(np.hypot(d[0], d[1]))
    if length == 0.0:
        return None
    u = d / length
    n = np.array([-u[1], u[0]])
    t = np.linspace(-np.pi / 2, np.pi / 2, count)
    front = b + radius * (np.outer(np.cos(t), u) + np.outer(np.sin(t), n))  # around b, from -n through +u to +n
    back = a + radius * (np.outer(-np.cos(t), u) + np.outer(-np.sin(t), n))  # around a, from +n through -u to -n
    return np.vstack([front, back, front[:1]])


def draw_robot(ax: Any, points: np.ndarray, radius: float, planar: bool, color: str = "tab:red",
               label: str | None = "robot", discs: bool = True) -> list[Any]:
    """Points and links of the robot, and a disc of ``radius`` at the end of each module.

    The disc sits at the module's far end (where its actuators are), normal to
    the module, as in the thesis's figures. Returns the artists drawn.
    """
    artists: list[Any] = []
    artists += _plot(ax, points, planar, "-o", color=color, markersize=3, linewidth=1.5, label=label, zorder=6)
    if discs and planar and radius > 0:  # seen from the top each module is its capsule: the width clearance counts
        for j in range(points.shape[0] - 1):
            outline = capsule_outline(points[j, :2], points[j + 1, :2], radius)
            if outline is not None:
                artists += ax.fill(outline[:, 0], outline[:, 1], facecolor=color, alpha=0.18, edgecolor=color,
                                   linewidth=0.6, zorder=5, label=f"{label} (radius {radius:g} mm)"
                                   if (j == 0 and label) else None)
    if discs:
        for j in range(points.shape[0] - 1):
            d = points[j + 1] - points[j]
            if np.linalg.norm(d) == 0:
                continue
            c = _circle(points[j + 1], d, radius)
            artists += _plot(ax, c, planar, color=color, linewidth=0.6, alpha=0.7, zorder=6)
    return artists


def _setup_axes(fig: Figure, planar: bool, rect: tuple[float, float, float, float] | None = None) -> Any:
    kw: dict[str, Any] = {} if planar else {"projection": "3d"}
    ax: Any = fig.add_subplot(111, **kw) if rect is None else fig.add_axes(rect, **kw)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    if planar:
        ax.set_aspect("equal", adjustable="box")
    else:
        ax.set_zlabel("z (mm)")
    ax.grid(True, alpha=0.3)
    return ax


def _equal_3d(ax: Any, pts: np.ndarray, pad: float = 0.0) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    mid, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1.0) + pad
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_box_aspect((1, 1, 1))


def run_is_planar(result: "FollowResult") -> bool:
    """True when a run is drawn from the top (x, y): its path is planar and every pose keeps one height z."""
    return result.trajectory.planar and bool(np.ptp(result.points[:, :, 2]) <= 1e-9)


def _check_step(result: "FollowResult", i: int) -> int:
    if not -result.steps <= i < result.steps:
        raise BhrError(f"step {i + 1} is outside the run (steps 1 to {result.steps}); choose a step in that range")
    return i % result.steps


def _body_pose(result: "FollowResult", i: int) -> np.ndarray | None:
    body = getattr(result, "body", None)
    if body is None or not body.modules:
        return None
    return np.vstack([result.points[i, :1], body.points[i]])


def _pose_points(result: "FollowResult", i: int) -> np.ndarray:
    body = _body_pose(result, i)
    return result.points[i] if body is None else np.vstack([result.points[i], body])


def zoom_half_width(result: "FollowResult", factor: float) -> float:
    """Half the side of a square view around the head: ``factor`` head lengths, and the lumen with room."""
    head = float(np.sum(np.linalg.norm(np.diff(result.points[0], axis=0), axis=1)))
    head = max(head, result.robot.module_length * result.modules, 4 * result.robot.robot_radius)
    lumen = getattr(result.trajectory, "lumen", None)
    wall = 0.75 * float(np.max(lumen)) if lumen is not None and len(lumen) else 0.0
    return max(factor * head, wall, 3 * result.robot.robot_radius)


def _head_centre(result: "FollowResult", i: int) -> np.ndarray:
    pts = result.points[i]
    return (pts.min(axis=0) + pts.max(axis=0)) / 2


def _draw_context(ax: Any, result: "FollowResult", planar: bool, markevery: int = 1,
                  path_style: dict[str, Any] | None = None, contacts_step: int | None = None) -> list[Any]:
    """What does not move between steps: the lumen wall, the path, its start and end, the wall contacts (of every
    step, or of the 0-based ``contacts_step`` only)."""
    traj = result.trajectory
    artists = draw_lumen_wall(ax, traj, planar)
    artists += draw_path(ax, traj.points, planar, markevery=markevery, **(path_style or {}))
    artists += draw_start_end(ax, traj.points, planar)
    _draw_touch_points(ax, result, planar, contacts_step)
    return artists


def _draw_pose(ax: Any, result: "FollowResult", i: int, planar: bool, target_size: float = 9) -> list[Any]:
    """What changes with the step: the target, the robot (head) and the body behind it."""
    new = draw_target(ax, result.trajectory.points[i], planar, target_size)
    new += draw_robot(ax, result.points[i], result.robot.robot_radius, planar)
    body = _body_pose(result, i)
    if body is not None:
        new += draw_robot(ax, body, result.robot.robot_radius, planar, color="tab:orange", label="body")
    return new


def _depth_cue(ax: Any, result: "FollowResult", i: int | None, floor: float) -> list[Any]:
    """3-D depth cue: the path's (and at step ``i`` the robot's) shadow on the floor, and drop lines to it
    from the start, the end and the robot's tip."""
    path = result.trajectory.points

    def flat(p: np.ndarray) -> np.ndarray:
        q = np.array(p, dtype=float, copy=True)
        q[:, 2] = floor
        return q

    art = _plot(ax, flat(path), False, color=SHADOW, linewidth=0.9, label="shadow on the floor", zorder=0.5)
    drops = [path[0], path[-1]]
    if i is not None:
        art += _plot(ax, flat(_pose_points(result, i)), False, color="0.45", linewidth=2.0, zorder=0.6)
        drops.append(result.points[i, -1])
    for p in drops:
        art += _plot(ax, np.array([p, [p[0], p[1], floor]]), False, linestyle=":", color="0.45", linewidth=0.9)
    return art


Box = tuple[float, float, float, float]


def _inset_rect(ax_limits: Box, pts: np.ndarray, window: Box, side: float) -> Box:
    """Where an inset of ``side`` (data units) covers the fewest ``pts`` and not the zoomed ``window``."""
    x0, x1, y0, y1 = ax_limits
    w, h = x1 - x0, y1 - y0
    fw, fh = side / w, side / h
    m = 0.015
    cands = [(m, m), (1 - fw - m, m), (m, 1 - fh - m), (1 - fw - m, 1 - fh - m), ((1 - fw) / 2, (1 - fh) / 2),
             ((1 - fw) / 2, m), ((1 - fw) / 2, 1 - fh - m), (m, (1 - fh) / 2), (1 - fw - m, (1 - fh) / 2)]
    fx, fy = (pts[:, 0] - x0) / w, (pts[:, 1] - y0) / h
    wx0, wx1 = (window[0] - x0) / w, (window[1] - x0) / w
    wy0, wy1 = (window[2] - y0) / h, (window[3] - y0) / h
    best, best_score = cands[0], None
    for cx, cy in cands:
        inside = int(np.count_nonzero((fx >= cx) & (fx <= cx + fw) & (fy >= cy) & (fy <= cy + fh)))
        overlap = not (cx + fw < wx0 or cx > wx1 or cy + fh < wy0 or cy > wy1)
        score = inside + (10 * len(pts) if overlap else 0)
        if best_score is None or score < best_score:
            best, best_score = (cx, cy), score
    return best[0], best[1], fw, fh


def _zoom_window(result: "FollowResult", i: int, factor: float) -> tuple[np.ndarray, float]:
    return _head_centre(result, i), zoom_half_width(result, factor)


def _set_window(ax: Any, centre: np.ndarray, half: float, planar: bool) -> None:
    if planar:
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
    else:
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)


#: Zoom of the path figure's inset and of the animation: half the view's side, in head lengths.
INSET_ZOOM = 0.8
FRAME_ZOOM = 1.2
#: The frame of the animation and the live view: inches (1000 x 700 pixels at 100 dpi).
FRAME_INCHES = (10.0, 7.0)


def path_figure(result: "FollowResult", step: int | None = None) -> Figure:
    """The whole path and the robot's pose at ``step`` (0-based, default: the last); top view when planar.

    The lumen's wall is drawn where the trajectory has a lumen, start and end
    are marked, and when the robot is small beside the path an inset (3-D: a
    second panel) zooms on it. The canvas takes the shape of the path.
    """
    i = _check_step(result, result.steps - 1 if step is None else step)
    only = None if step is None else i  # a figure of one chosen step: that step's wall contacts, not every step's
    planar = run_is_planar(result)
    traj = result.trajectory
    walls = lumen_walls(traj, planar)
    pose = _pose_points(result, i)
    every = marker_stride(traj.points)
    parts = [traj.points, pose] + (list(walls) if walls is not None else [])
    allpts = np.vstack(parts)
    centre, half = _zoom_window(result, i, INSET_ZOOM)
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
        ax = _setup_axes(fig, True, (left / fw, bottom / fh, ax_w / fw, ax_h / fh))
        _draw_context(ax, result, True, every, contacts_step=only)
        label_sections(ax, traj, True)
        draw_travel_arrow(ax, traj.points, True)
        _draw_pose(ax, result, i, True)
        draw_section_names(ax, traj, True)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_title(title, fontsize=10)
        _legend_below(fig, ax)
        if 2 * half < 0.45 * min(w, h):
            window = (centre[0] - half, centre[0] + half, centre[1] - half, centre[1] + half)
            side = max(0.36 * min(w, h), 2.2 * half)
            rect = _inset_rect((lo[0], hi[0], lo[1], hi[1]), np.vstack([traj.points, pose]), window, side)
            ins = ax.inset_axes(rect)
            _draw_context(ins, result, True, contacts_step=only)
            _draw_pose(ins, result, i, True, target_size=11)
            ins.set_xlim(window[0], window[1])
            ins.set_ylim(window[2], window[3])
            ins.set_aspect("equal", adjustable="box")
            ins.tick_params(labelsize=7)
            ins.set_facecolor("white")
            ins.set_title(f"robot, zoomed (step {i + 1})", fontsize=8, pad=2)
            ax.indicate_inset_zoom(ins, edgecolor="0.25", alpha=0.9)
        return fig
    extent = float(np.ptp(allpts, axis=0).max())
    zoom = 2 * half < 0.45 * extent
    fig = Figure(figsize=(14, 7) if zoom else (8, 7))
    ax = fig.add_subplot(1, 2 if zoom else 1, 1, projection="3d")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    _equal_3d(ax, allpts, pad=0.02 * extent)
    _draw_context(ax, result, False, every, contacts_step=only)
    label_sections(ax, traj, False)
    draw_travel_arrow(ax, traj.points, False)
    _draw_pose(ax, result, i, False)
    _depth_cue(ax, result, i, ax.get_zlim()[0])
    draw_section_names(ax, traj, False)
    ax.set_title(title, fontsize=10)
    if zoom:
        ins = fig.add_subplot(1, 2, 2, projection="3d")
        ins.set_xlabel("x (mm)")
        ins.set_ylabel("y (mm)")
        ins.set_zlabel("z (mm)")
        _set_window(ins, centre, half, False)
        ins.set_box_aspect((1, 1, 1))
        _draw_context(ins, result, False, contacts_step=only)
        _draw_pose(ins, result, i, False, target_size=11)
        _depth_cue(ins, result, i, ins.get_zlim()[0])
        ins.set_title(f"robot, zoomed (step {i + 1})", fontsize=10)
    fig.subplots_adjust(left=0.02, right=0.95 if zoom else 0.92, bottom=0.1, top=0.95, wspace=0.15)
    _legend_below(fig, ax)
    return fig


def _legend_below(fig: Figure, ax: Any, ncol: int | None = None, x: float = 0.5) -> Any:
    """One legend below the axes (fixed, so it never hides the path nor moves between frames)."""
    handles, labels = ax.get_legend_handles_labels()
    seen: dict[str, Any] = {}
    for hd, lb in zip(handles, labels):
        seen.setdefault(lb, hd)
    return fig.legend(list(seen.values()), list(seen), loc="lower center", bbox_to_anchor=(x, 0.0),
                      ncol=ncol or min(len(seen), 5), fontsize=8, frameon=False)


class StepView:
    """One step of a run as the animation and the live view show it: a view that follows the robot.

    The left axes (``ax``) is a square window around the robot's head, moved
    with it at every step; the path, the lumen wall, start and end stay
    drawn, so that the robot is large and its surroundings readable. On the
    right, an overview shows the whole path with the window and the robot's
    place, and a readout gives the step's errors against the tolerances.
    :meth:`draw` replaces the previous step's robot, target, window and
    readout. Pass ``fig`` to draw on a figure made elsewhere (e.g. an
    off-screen Agg figure); its size should be :data:`FRAME_INCHES`.
    """

    def __init__(self, result: "FollowResult", fig: Figure | None = None,
                 figsize: tuple[float, float] = FRAME_INCHES) -> None:
        self.result = result
        self.planar = run_is_planar(result)
        self.fig = Figure(figsize=figsize) if fig is None else fig
        self.half = zoom_half_width(result, FRAME_ZOOM)
        traj = result.trajectory
        main = (0.07, 0.15, 0.58, 0.77)
        self.ax = _setup_axes(self.fig, self.planar, main)
        self.ax.grid(False)  # grid lines sliding under a moving view only blur it (and bloat a GIF)
        _draw_context(self.ax, result, self.planar, 1)
        self.overview = _setup_axes(self.fig, self.planar, (0.71, 0.47, 0.27, 0.42))
        self.overview.set_title("whole path", fontsize=9)
        self.overview.tick_params(labelsize=7)
        self.overview.xaxis.label.set_size(8)
        self.overview.yaxis.label.set_size(8)
        walls = lumen_walls(traj, self.planar)
        pts = np.vstack([traj.points] + (list(walls) if walls is not None else []))
        draw_lumen_wall(self.overview, traj, self.planar)
        draw_path(self.overview, traj.points, self.planar, marker=None, linewidth=1.0)
        draw_start_end(self.overview, traj.points, self.planar, size=6)
        if self.planar:
            lo, hi = pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)
            pad = 0.05 * max(float((hi - lo).max()), 1.0)
            self.overview.set_xlim(lo[0] - pad, hi[0] + pad)
            self.overview.set_ylim(lo[1] - pad, hi[1] + pad)
        else:
            self.overview.zaxis.label.set_size(8)
            _equal_3d(self.overview, pts)
            _depth_cue(self.overview, result, None, self.overview.get_zlim()[0])
        self.overview.autoscale(False)
        self.readout = self.fig.text(0.71, 0.40, "", ha="left", va="top", family="monospace", fontsize=9)
        self.step: int | None = None
        self.artists: list[Any] = []
        self._laid_out = False
        self._background: Any = None

    def render(self) -> None:
        """Draw the figure on its (Agg) canvas: whole the first time, then only what moves.

        What never moves (the overview's path, the legend) is kept as an image
        after the first frame; each later frame restores it and draws the view,
        the overview's window and robot, and the readout over it. Canvases
        without that ability are drawn whole.
        """
        canvas = self.fig.canvas
        if not hasattr(canvas, "copy_from_bbox") or not hasattr(canvas, "restore_region"):
            canvas.draw()
            return
        moving = [a for a in self.artists if a.axes is self.overview] + [self.readout, self.ax]
        if self._background is None:
            for a in moving:
                a.set_visible(False)
            canvas.draw()
            self._background = canvas.copy_from_bbox(self.fig.bbox)
            for a in moving:
                a.set_visible(True)
        canvas.restore_region(self._background)
        renderer = canvas.get_renderer()  # type: ignore[attr-defined]  # the Agg canvas
        self.ax.draw(renderer)
        for a in moving[:-2]:
            self.overview.draw_artist(a)
        self.fig.draw_artist(self.readout)

    def title(self, i: int) -> str:
        r = self.result
        view = "top view" if self.planar else "3D view"
        return (f"{r.trajectory.name}: robot at step {i + 1} of {r.steps} "
                f"({view}, following the robot, solver {r.solver})")

    def window_centre(self, i: int) -> np.ndarray:
        """Centre of the view at step ``i``: the centre of the head's bounding box (the step alone sets it)."""
        return _head_centre(self.result, i)

    def readout_text(self, i: int) -> str:
        """The step's numbers: tip error, worst point, tip orientation, global error, each against its tolerance."""
        r = self.result
        pe, oe = r.point_errors_mm[i], r.orientation_errors_deg[i]
        worst = int(np.argmax(pe))
        over = " OVER" if float(pe.max()) > r.robot.tol_pos else ""
        lines = [f"step {i + 1} of {r.steps}",
                 f"tip error     {pe[-1]:7.2f} mm",
                 f"worst point   {pe[worst]:7.2f} mm, pt {worst + 1}{over}",
                 f"  tolerance   {r.robot.tol_pos:7.2f} mm",
                 f"tip angle     {oe[-1]:7.2f} deg",
                 f"  tolerance   {r.robot.tol_ori:7.2f} deg",
                 f"global error  {float(r.global_errors[i].max()):7.2f} (1 = tol.)",
                 f"iterations    {int(r.iterations[i]):4d}"]
        return "\n".join(lines)

    def draw(self, i: int) -> list[Any]:
        """Draw step ``i`` (0-based): target, robot, window around it, overview and readout; return the new artists."""
        r = self.result
        i = _check_step(r, i)
        for a in self.artists:
            a.remove()
        new = _draw_pose(self.ax, r, i, self.planar)
        centre = self.window_centre(i)
        _set_window(self.ax, centre, self.half, self.planar)
        h = self.half
        if self.planar:
            # the window the left view shows: a shaded square (clipped to the overview like the path), so that
            # at the path's ends it reads as a window and not as loose lines
            from matplotlib.patches import Rectangle

            window = Rectangle((centre[0] - h, centre[1] - h), 2 * h, 2 * h, facecolor="0.2", alpha=0.12,
                               edgecolor="0.2", linewidth=0.9, zorder=3, label="_view window")
            self.overview.add_patch(window)  # clipped to the overview's box
            new.append(window)
        else:
            new += _depth_cue(self.ax, r, i, self.ax.get_zlim()[0])
        new += _plot(self.overview, r.points[i], self.planar, "-", color="tab:red", linewidth=2.5)
        new += _plot(self.overview, r.points[i, -1:], self.planar, "o", color="tab:red", markersize=4)
        self.readout.set_text(self.readout_text(i))
        self.artists = new
        self.step = i
        self.ax.set_title(self.title(i), fontsize=10)
        if not self._laid_out:
            # The legend is fixed below the view and the layout set once for all frames.
            _legend_below(self.fig, self.ax, ncol=5, x=0.36)
            self._laid_out = True
        return new


def chain_figure(initial: np.ndarray, final: np.ndarray, target: Sequence[float], radius: float | None = None,
                 title: str = "") -> Figure:
    """Initial and final chain of one solve (thesis Figs. 5.8-5.22): 2D when all lies in z = 0."""
    t = np.asarray(target, dtype=np.float64)
    allpts = np.vstack([initial, final, t[None]])
    planar = bool(np.all(np.abs(allpts[:, 2]) < 1e-12))
    fig = Figure(figsize=(7, 7))
    ax = _setup_axes(fig, planar)
    if not planar:
        ax.computed_zorder = False  # draw in zorder: the solution over the initial chain, whatever the depth
    # the initial chain thin, grey and dashed behind; the solution and the target on top
    _plot(ax, initial, planar, "--o", color="0.55", markersize=2.5, linewidth=1.0, label="initial", zorder=2)
    draw_robot(ax, final, radius or 0.0, planar, color="tab:red", label="final", discs=bool(radius))
    _plot(ax, t[None], planar, "x", color="tab:green", markersize=11, markeredgewidth=2.0, label="target",
          zorder=8)
    span = float(np.ptp(allpts, axis=0).max()) or 1.0
    pad = 0.08 * span  # room around the chain and the target so that no marker is cut at the frame
    if planar:
        lo, hi = allpts[:, :2].min(axis=0) - pad, allpts[:, :2].max(axis=0) + pad
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    else:
        _equal_3d(ax, allpts, pad=pad)
        # look across the plane the solution bends in, so that it does not hide behind the initial chain
        d = final[-1] - final[0]
        ax.view_init(elev=20, azim=float(np.degrees(np.arctan2(d[1], d[0]))) - 60)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig


#: Figure formats bhr writes (by file extension); a path without one (a device such as /dev/null) gets PNG.
FIGURE_FORMATS = (".png", ".svg", ".pdf")


def check_figure_path(path: str | os.PathLike[str]) -> None:
    """Refuse a figure path whose extension is not a format bhr draws (.png, .svg, .pdf)."""
    suffix = Path(path).suffix.lower()
    if suffix and suffix not in FIGURE_FORMATS:
        raise BhrError(f"cannot draw a figure as {path}: give a file ending in .png, .svg or .pdf")


#: zlib level of a run's PNG figures (save_run_plots): 1 instead of Pillow's 6 makes the files about 10 % larger
#: and saves some 0.04 s of CPU over the three error figures (bhr follow draws five figures every run).
RUN_PNG_COMPRESS = 1

#: How the saved figures render their text: without FreeType's hinting. matplotlib's default (autohinting) looks
#: the same at 110 dpi but makes text most of a figure's drawing. (``text.hinting_factor``, the other setting of
#: this kind, does nothing in this matplotlib and warns that it is deprecated.)
TEXT_RENDERING: dict[Any, Any] = {"text.hinting": "none"}


def save_figure(fig: Figure, path: str | os.PathLike[str], dpi: int = 110, compress: int | None = None) -> Path:
    """Save ``fig`` atomically as PNG (or SVG/PDF by extension); ``compress``: a PNG's zlib level."""
    p = Path(path)
    fmt = p.suffix.lower().lstrip(".") if p.suffix.lower() in FIGURE_FORMATS else "png"
    kw: dict[str, Any] = {}
    if compress is not None and fmt == "png":
        kw["pil_kwargs"] = {"compress_level": int(compress)}
    with atomic_path(p) as tmp, matplotlib.rc_context(TEXT_RENDERING):
        if tmp == p:  # a device, FIFO or /dev/stdout: render in memory, then one plain write (no seeking)
            import io

            buf = io.BytesIO()
            fig.savefig(buf, dpi=dpi, format=fmt, **kw)
            with open(p, "ab" if p.is_file() else "wb") as fh:
                fh.write(buf.getvalue())
        else:
            fig.savefig(tmp, dpi=dpi, format=fmt, **kw)
    return p


def run_plot_names(result: "FollowResult", step: int | None = None) -> list[str]:
    """The names of the files :func:`save_run_plots` writes for ``result``, in its order."""
    names = [name for name, _, _ in ERROR_KINDS.values()]
    names.append("path.png" if step is None else f"path-step{step}.png")
    if result.body is not None and result.body.modules:
        names.append("body_errors.png")
    if result.clearance is not None:
        names.append("clearance.png")
    return names


def save_run_plots(result: "FollowResult", out_dir: str | os.PathLike[str], step: int | None = None) -> list[Path]:
    """Write a run's figures into ``out_dir``: the three error figures, the path view (``path.png``, or with the
    robot at 1-based ``step``, ``path-stepK.png``) and, where the run has them, the body's errors and the
    lumen clearance."""
    out = Path(out_dir)
    files = []
    grids: dict[tuple[int, int], _ErrorGrid] = {}  # the three error figures share one grid where their panels fit
    for kind, (name, _, _) in ERROR_KINDS.items():
        shape = _error_grid_shape(_error_data(result, kind).shape[1])
        if shape not in grids:
            grids[shape] = _ErrorGrid(result, *shape)
        files.append(save_figure(grids[shape].fill(kind), out / name, compress=RUN_PNG_COMPRESS))
    path_name = "path.png" if step is None else f"path-step{step}.png"
    files.append(save_figure(path_figure(result, None if step is None else step - 1), out / path_name,
                             compress=RUN_PNG_COMPRESS))
    if result.body is not None and result.body.modules:
        files.append(save_figure(body_figure(result), out / "body_errors.png", compress=RUN_PNG_COMPRESS))
    if result.clearance is not None:
        files.append(save_figure(clearance_figure(result), out / "clearance.png",
                                 compress=RUN_PNG_COMPRESS))
    return files


# --- lumen clearance and the whole body (bhr.run.clearance, bhr.run.body) ---


def mark_wall_touches(ax: Any, result: "FollowResult") -> None:
    """Shade the steps where some point of the robot touches the lumen wall (clearance <= 0)."""
    cl = getattr(result, "clearance", None)
    if cl is None or not cl.touch_steps:
        return
    steps = cl.touch_steps
    start = prev = steps[0]
    first = True
    for s in steps[1:] + [None]:
        if s is not None and s == prev + 1:
            prev = s
            continue
        ax.axvspan(start - 0.5, prev + 0.5, color="tab:red", alpha=0.18, linewidth=0,
                   label="wall touched" if first else None)
        first = False
        if s is not None:
            start = prev = s


def _draw_touch_points(ax: Any, result: "FollowResult", planar: bool, step: int | None = None) -> None:
    """Mark where the robot touched the wall on the path view (every step, or ``step``'s): see
    :func:`draw_contacts`."""
    draw_contacts(ax, result, planar, step)


def draw_contacts(ax: Any, result: "FollowResult", planar: bool, step: int | None = None) -> list[Any]:
    """Red dots where the robot touched the lumen wall: each touching module's deepest spot, at every step, or at
    the 0-based ``step`` only (a figure of one step shows that step's contacts, labelled with it)."""
    cl = getattr(result, "clearance", None)
    if cl is None or not cl.touch_steps:
        return []
    w = cl.contacts(step)
    if not len(w):
        return []
    label = "wall contact (every step)" if step is None else f"wall contact at step {step + 1}"
    style = {"color": "tab:red", "marker": "o", "markersize": 3.5 if step is None else 6, "linestyle": "none",
             "alpha": 0.55 if step is None else 0.9, "label": label, "zorder": 4 if step is None else 7}
    if planar:
        return ax.plot(w[:, 0], w[:, 1], **style)
    return ax.plot(w[:, 0], w[:, 1], w[:, 2], axlim_clip=True, **style)  # none outside a zoomed 3-D view


def body_figure(result: "FollowResult") -> Figure:
    """Position error of the body behind the head: the largest over its points, and its last point."""
    b = result.body
    assert b is not None, "body_figure needs a run with a body (follow(..., body_modules=M))"
    steps = np.arange(1, result.steps + 1)
    fig, ax = subplots(figsize=(10, 4))
    draw_sections(ax, result)
    ax.plot(steps, result.point_errors_mm.max(axis=1), color="tab:blue", linewidth=1.0, label="head (largest point)")
    ax.plot(steps, b.point_errors_mm.max(axis=1), color="tab:orange", linewidth=1.0, label="body (largest point)")
    ax.plot(steps, b.point_errors_mm[:, -1], color="tab:brown", linewidth=0.8, linestyle=":", label="tail point")
    ax.axhline(result.robot.tol_pos, color="tab:red", linestyle="--", linewidth=0.8,
               label=f"tolerance {result.robot.tol_pos:g} mm")
    mark_worst(ax, steps, result.point_errors_mm.max(axis=1), "mm", color="tab:blue", what="head worst")
    mark_worst(ax, steps, b.point_errors_mm.max(axis=1), "mm", color="tab:orange", what="body worst")
    mark_wall_touches(ax, result)
    ax.set_xlabel("trajectory step")
    ax.set_ylabel("position error (mm)")
    ax.set_xlim(1, max(2, result.steps))
    top = max(result.robot.tol_pos, float(np.nanmax(b.point_errors_mm)), float(np.nanmax(result.point_errors_mm)))
    ax.set_ylim(0, 1.45 * top)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8, ncol=3)
    ax.set_title(f"Whole body ({result.modules + b.modules} modules) - {result.trajectory.name}, "
                 f"solver {result.solver}", fontsize=11)
    fig.tight_layout()
    return fig


def draw_contact_steps(ax: Any, result: "FollowResult") -> list[Any]:
    """On a per-step clearance plot: a red dot at each step where the robot touches the wall."""
    cl = getattr(result, "clearance", None)
    if cl is None or not cl.touch_steps:
        return []
    steps = np.asarray(cl.touch_steps)
    per = cl.per_step[steps - 1]
    pen = cl.max_penetration_mm
    return ax.plot(steps, per, "o", color="tab:red", markersize=2.5, linestyle="none",
                   label=f"wall contact ({len(steps)} steps, deepest {pen:.2f} mm)")


def draw_sections(ax: Any, result: "FollowResult") -> None:
    """On a per-step figure: the trajectory's anatomical sections as alternate grey bands named at the top
    (step k targets point k - 1, so a section of points [a, b) covers steps a + 1 ... b)."""
    sections = getattr(result.trajectory, "sections", ())
    if not sections:
        return
    import matplotlib.transforms as mtransforms

    trans = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    for k, (name, a, b) in enumerate(sections):
        lo, hi = a + 0.5, min(b, result.steps) + 0.5
        if lo >= hi:
            continue
        if k % 2 == 0:
            ax.axvspan(lo, hi, color="#e6e9f0", zorder=0, linewidth=0)
        ax.text((lo + hi) / 2, 0.985, name.replace(" and ", "\nand "), transform=trans, ha="center", va="top",
                fontsize=7, color="#333", zorder=5, clip_on=True)


def draw_section_names(ax: Any, traj: Any, planar: bool) -> None:
    """On a path view: each anatomical section's name beside its middle point."""
    for name, a, b in getattr(traj, "sections", ()):
        p = traj.points[(a + b - 1) // 2]
        kw = {"fontsize": 7, "color": "#222", "ha": "left", "va": "bottom", "zorder": 10,
              "bbox": {"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.7}}
        if planar:
            ax.text(p[0], p[1], " " + name, **kw)
        else:
            ax.text(p[0], p[1], p[2], " " + name, **kw)


def clearance_figure(result: "FollowResult") -> Figure:
    """Smallest clearance to the lumen wall at each step (mm); below zero the wall is touched."""
    cl = result.clearance
    assert cl is not None, "clearance_figure needs a trajectory with a lumen"
    steps = np.arange(1, result.steps + 1)
    fig, ax = subplots(figsize=(10, 4), gridspec_kw=_margins(10, 4, 1, 1, left=0.75, top=0.4))  # fixed layout
    draw_sections(ax, result)
    ax.plot(steps, cl.per_step, color="tab:green", linewidth=1.0, label="smallest clearance")
    ax.axhline(0.0, color="tab:red", linestyle="--", linewidth=0.8, label="wall (clearance 0)")
    mark_wall_touches(ax, result)
    draw_contact_steps(ax, result)
    if cl.min_step:
        ax.plot([cl.min_step], [cl.min_mm], "v", color="black", markersize=6,
                label=f"minimum {cl.min_mm:.2f} mm (step {cl.min_step}, {cl.min_point})")
    ax.set_xlabel("trajectory step")
    ax.set_ylabel("clearance (mm)")
    ax.set_xlim(1, max(2, result.steps))
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"Clearance to the lumen wall - {result.trajectory.name}, solver {result.solver}", fontsize=11)
    return fig
