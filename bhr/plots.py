"""Figures with matplotlib: error plots (thesis Figs. 7.2-7.21) and robot views.

Import this module only when plotting; the rest of bhr does not need
matplotlib. One drawing function, :func:`draw_robot`, draws the robot (points,
links, and a disc of the robot's radius at each module, oriented with it) for
the final-pose figure, the report, the live view and the animation.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import matplotlib

if os.environ.get("DISPLAY", "") == "" and os.environ.get("MPLBACKEND") is None:
    matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bhr.atomic import atomic_path  # noqa: E402

if TYPE_CHECKING:  # pragma: no cover
    from bhr.follow import FollowResult

__all__ = ["error_figure", "path_figure", "chain_figure", "draw_robot", "draw_path", "save_figure",
           "save_run_plots", "ERROR_KINDS", "StepView", "run_is_planar",
           "body_figure", "clearance_figure", "mark_wall_touches", "draw_contacts", "draw_tube",
           "draw_contact_steps"]

ORDINALS = ["First", "Second", "Third", "Fourth", "Fifth", "Sixth", "Seventh", "Eighth", "Ninth", "Tenth"]

ERROR_KINDS = {
    "position": ("position_errors.png", "Position error of each point", "position error (mm)"),
    "orientation": ("orientation_errors.png", "Orientation error of each module", "orientation error (deg)"),
    "global": ("global_errors.png", "Global error of each module", "global error (-)"),
}


def _panel_title(kind: str, j: int, count: int) -> str:
    what = "point" if kind == "position" else "module"
    name = ORDINALS[j] if j < len(ORDINALS) else f"{j + 1}th"
    label = f"{name} {what}"
    if j == 0:
        label += " (base)"
    if j == count - 1:
        label += " (tip)"
    return label


def error_figure(result: "FollowResult", kind: str) -> plt.Figure:
    """One panel per point (position) or module (orientation, global) against trajectory step."""
    if kind not in ERROR_KINDS:
        raise ValueError(f"kind must be one of {', '.join(ERROR_KINDS)}")
    data = {"position": result.point_errors, "orientation": result.orientation_errors,
            "global": result.global_errors}[kind]
    tol = {"position": result.robot.tol_pos, "orientation": result.robot.tol_ori, "global": 1.0}[kind]
    _, title, ylabel = ERROR_KINDS[kind]
    count = data.shape[1]
    cols = 2 if count > 1 else 1
    rows = int(np.ceil(count / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(10, 2.6 * rows + 0.8), squeeze=False, sharex=True)
    steps = np.arange(1, data.shape[0] + 1)
    for j in range(rows * cols):
        ax = axes[j // cols][j % cols]
        if j >= count:
            ax.set_visible(False)
            continue
        ax.plot(steps, data[:, j], color="tab:blue", linewidth=1.0)
        ax.axhline(tol, color="tab:red", linestyle="--", linewidth=0.8, label="tolerance")
        mark_wall_touches(ax, result)
        ax.set_title(_panel_title(kind, j, count), fontsize=10)
        ax.set_ylabel(ylabel, fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.set_xlim(1, max(2, data.shape[0]))
        ax.set_ylim(bottom=0)
        if j // cols == rows - 1 or j + cols >= count:
            ax.set_xlabel("trajectory step", fontsize=9)
    fig.suptitle(f"{title} - {result.trajectory.name}, solver {result.solver}", fontsize=12)
    fig.tight_layout()
    return fig


def _circle(center: np.ndarray, normal: np.ndarray, radius: float, count: int = 40) -> np.ndarray:
    normal = normal / np.linalg.norm(normal)
    ref = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(normal, ref)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    t = np.linspace(0, 2 * np.pi, count)
    return center + radius * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))


def draw_path(ax: Any, path: np.ndarray, planar: bool, **kw: Any) -> list[Any]:
    """The trajectory in blue with x marks, as the thesis draws it."""
    style = {"color": "tab:blue", "marker": "x", "markersize": 3, "linewidth": 0.8, "label": "trajectory"}
    style.update(kw)
    if planar:
        return ax.plot(path[:, 0], path[:, 1], **style)
    return ax.plot(path[:, 0], path[:, 1], path[:, 2], **style)


def draw_robot(ax: Any, points: np.ndarray, radius: float, planar: bool, color: str = "tab:red",
               label: str | None = "robot", discs: bool = True) -> list[Any]:
    """Points and links of the robot, and a disc of ``radius`` at the end of each module.

    The disc sits at the module's far end (where its actuators are), normal to
    the module, as in the thesis's figures. Returns the artists drawn.
    """
    artists: list[Any] = []
    if planar:
        artists += ax.plot(points[:, 0], points[:, 1], "-o", color=color, markersize=3, linewidth=1.5, label=label)
    else:
        artists += ax.plot(points[:, 0], points[:, 1], points[:, 2], "-o", color=color, markersize=3,
                           linewidth=1.5, label=label)
    if discs:
        for j in range(points.shape[0] - 1):
            d = points[j + 1] - points[j]
            if np.linalg.norm(d) == 0:
                continue
            c = _circle(points[j + 1], d, radius)
            if planar:
                artists += ax.plot(c[:, 0], c[:, 1], color=color, linewidth=0.6, alpha=0.7)
            else:
                artists += ax.plot(c[:, 0], c[:, 1], c[:, 2], color=color, linewidth=0.6, alpha=0.7)
    return artists


def _setup_axes(fig: plt.Figure, planar: bool) -> Any:
    if planar:
        ax = fig.add_subplot(111)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
    else:
        ax = fig.add_subplot(111, projection="3d")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_zlabel("z (mm)")
    ax.grid(True, alpha=0.3)
    return ax


def _equal_3d(ax: Any, pts: np.ndarray) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    mid, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1.0)
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)


def run_is_planar(result: "FollowResult") -> bool:
    """True when a run is drawn from the top (x, y): its path is planar and every pose keeps one height z."""
    return result.trajectory.planar and bool(np.ptp(result.points[:, :, 2]) <= 1e-9)


class StepView:
    """The path, the target and the robot at one step of a run, on one axes.

    This is the one frame-drawing code of bhr: :func:`path_figure` (the
    final-pose figure and the report), the live view (:mod:`bhr.liveview`)
    and the animation (:mod:`bhr.animate`) all draw through it. The axes
    limits cover the path and every pose of the run, so that the frames of a
    run line up; :meth:`draw` replaces the robot and target of the previous
    step. Pass ``fig`` to draw on a figure made elsewhere (e.g. an off-screen
    Agg figure).
    """

    def __init__(self, result: "FollowResult", fig: plt.Figure | None = None,
                 figsize: tuple[float, float] = (8, 7)) -> None:
        self.result = result
        self.planar = run_is_planar(result)
        self.fig = plt.figure(figsize=figsize) if fig is None else fig
        self.ax = _setup_axes(self.fig, self.planar)
        self.step: int | None = None
        self.artists: list[Any] = []
        traj = result.trajectory
        draw_tube(self.ax, traj, self.planar)
        draw_path(self.ax, traj.points, self.planar)
        pts = np.vstack([traj.points, result.points.reshape(-1, 3)] + _body_points(result))
        _draw_touch_points(self.ax, result, self.planar)
        if self.planar:
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            pad = result.robot.radius + 0.03 * max(float((hi - lo)[:2].max()), 1.0)
            self.ax.set_xlim(lo[0] - pad, hi[0] + pad)
            self.ax.set_ylim(lo[1] - pad, hi[1] + pad)
            self.ax.set_aspect("equal", adjustable="box")
        else:
            _equal_3d(self.ax, pts)
        self.ax.autoscale(False)
        self._laid_out = False

    def title(self, i: int) -> str:
        r = self.result
        view = "top view" if self.planar else "3D view"
        return (f"{r.trajectory.name}: path and robot at step {i + 1} of {r.steps} "
                f"({view}, solver {r.solver})")

    def draw(self, i: int) -> list[Any]:
        """Draw step ``i`` (0-based): the target point and the robot's pose; return the new artists."""
        r = self.result
        if not -r.steps <= i < r.steps:
            from bhr.errors import BhrError

            raise BhrError(f"step {i + 1} is outside the run (steps 1 to {r.steps}); choose a step in that range")
        i = i % r.steps
        for a in self.artists:
            a.remove()
        tgt = r.trajectory.points[i]
        if self.planar:
            new = self.ax.plot([tgt[0]], [tgt[1]], "x", color="tab:green", markersize=9, label="target")
        else:
            new = self.ax.plot([tgt[0]], [tgt[1]], [tgt[2]], "x", color="tab:green", markersize=9, label="target")
        new += draw_robot(self.ax, r.points[i], r.robot.radius, self.planar)
        if r.body is not None and r.body.modules:
            body = np.vstack([r.points[i, :1], r.body.points[i]])
            new += draw_robot(self.ax, body, r.robot.radius, self.planar, color="tab:orange", label="body")
        self.artists = new
        self.step = i
        self.ax.set_title(self.title(i), fontsize=10)
        if not self._laid_out:
            # Legend below the axes (fixed, so it never hides the path nor moves between frames),
            # and the layout computed once for all frames.
            handles, labels = self.ax.get_legend_handles_labels()
            self.fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8, frameon=False)
            self.fig.tight_layout(rect=(0, 0.04, 1, 1))
            self._laid_out = True
        return new


def path_figure(result: "FollowResult", step: int | None = None) -> plt.Figure:
    """The path and the robot's pose at ``step`` (0-based, default: the last); top view when planar."""
    view = StepView(result)
    view.draw(result.steps - 1 if step is None else step)
    return view.fig


def chain_figure(initial: np.ndarray, final: np.ndarray, target: Sequence[float], radius: float | None = None,
                 title: str = "") -> plt.Figure:
    """Initial and final chain of one solve (thesis Figs. 5.8-5.22): 2D when all lies in z = 0."""
    t = np.asarray(target, dtype=np.float64)
    planar = bool(np.all(np.abs(np.vstack([initial, final, t[None]])[:, 2]) < 1e-12))
    fig = plt.figure(figsize=(7, 7))
    ax = _setup_axes(fig, planar)
    draw_robot(ax, initial, radius or 0.0, planar, color="black", label="initial", discs=False)
    draw_robot(ax, final, radius or 0.0, planar, color="tab:red", label="final", discs=bool(radius))
    if planar:
        ax.plot([t[0]], [t[1]], "x", color="tab:green", markersize=10, label="target")
    else:
        ax.plot([t[0]], [t[1]], [t[2]], "x", color="tab:green", markersize=10, label="target")
        _equal_3d(ax, np.vstack([initial, final, t[None]]))
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig


#: Figure formats bhr writes (by file extension); a path without one (a device such as /dev/null) gets PNG.
FIGURE_FORMATS = (".png", ".svg", ".pdf")


def check_figure_path(path: str | os.PathLike[str]) -> None:
    """Refuse a figure path whose extension is not a format bhr draws (.png, .svg, .pdf)."""
    from bhr.errors import BhrError

    suffix = Path(path).suffix.lower()
    if suffix and suffix not in FIGURE_FORMATS:
        raise BhrError(f"cannot draw a figure as {path}: give a file ending in .png, .svg or .pdf")


def save_figure(fig: plt.Figure, path: str | os.PathLike[str], dpi: int = 110) -> Path:
    """Save ``fig`` atomically as PNG and close it."""
    p = Path(path)
    try:
        fmt = p.suffix.lower().lstrip(".") if p.suffix.lower() in FIGURE_FORMATS else "png"
        with atomic_path(p) as tmp:
            if tmp == p:  # a device, FIFO or /dev/stdout: render in memory, then one plain write (no seeking)
                import io

                buf = io.BytesIO()
                fig.savefig(buf, dpi=dpi, format=fmt)
                with open(p, "ab" if p.is_file() else "wb") as fh:
                    fh.write(buf.getvalue())
            else:
                fig.savefig(tmp, dpi=dpi, format=fmt)
    finally:
        plt.close(fig)
    return p


def save_run_plots(result: "FollowResult", out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write the three error figures and the path view of a run into ``out_dir``."""
    out = Path(out_dir)
    files = []
    for kind, (name, _, _) in ERROR_KINDS.items():
        files.append(save_figure(error_figure(result, kind), out / name))
    files.append(save_figure(path_figure(result), out / "path.png"))
    if result.body is not None and result.body.modules:
        files.append(save_figure(body_figure(result), out / "body_errors.png"))
    if result.clearance is not None:
        files.append(save_figure(clearance_figure(result), out / "clearance.png"))
    return files


# --- lumen clearance and the whole body (bhr.clearance, bhr.body) ---


def _body_points(result: "FollowResult") -> list[np.ndarray]:
    body = getattr(result, "body", None)
    return [body.points.reshape(-1, 3)] if body is not None and body.modules else []


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


def _draw_touch_points(ax: Any, result: "FollowResult", planar: bool) -> None:
    """Mark where the robot touched the wall (any step) on the path view: see :func:`draw_contacts`."""
    draw_contacts(ax, result, planar)


def draw_contacts(ax: Any, result: "FollowResult", planar: bool) -> list[Any]:
    """Red dots where the robot touched the lumen wall: each touching module's deepest spot, at every step."""
    cl = getattr(result, "clearance", None)
    if cl is None or not cl.touch_steps:
        return []
    w = cl.contacts()
    if not len(w):
        return []
    style = {"color": "tab:red", "marker": "o", "markersize": 3.5, "linestyle": "none", "alpha": 0.55,
             "label": "wall contact", "zorder": 4}
    if planar:
        return ax.plot(w[:, 0], w[:, 1], **style)
    return ax.plot(w[:, 0], w[:, 1], w[:, 2], **style)


def draw_tube(ax: Any, trajectory: Any, planar: bool, rings_every_mm: float = 12.0) -> list[Any]:
    """The lumen's wall: both sides of the tube from the top (planar runs), rings around the centerline in 3-D."""
    lumen = getattr(trajectory, "lumen", None)
    pts = trajectory.points
    if lumen is None or len(pts) < 2:
        return []
    t = np.gradient(pts, axis=0)
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-12)[:, None]
    half = np.asarray(lumen, dtype=float)[: len(pts)] / 2.0
    style = {"color": "0.45", "linewidth": 0.7, "alpha": 0.8}
    if planar:
        side = np.stack([-t[:, 1], t[:, 0]], axis=1)
        left = pts[:, :2] + half[:, None] * side
        right = pts[:, :2] - half[:, None] * side
        return ax.plot(left[:, 0], left[:, 1], label="lumen wall", **style) + ax.plot(right[:, 0], right[:, 1], **style)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    every = max(1, int(round(rings_every_mm / max(float(np.median(seg)), 1e-9))))
    artists: list[Any] = []
    for k in range(0, len(pts), every):
        c = _circle(pts[k], t[k], half[k], 24)
        artists += ax.plot(c[:, 0], c[:, 1], c[:, 2], linewidth=0.5, color="0.55", alpha=0.45,
                           label="lumen wall" if k == 0 else None)
    return artists


def body_figure(result: "FollowResult") -> plt.Figure:
    """Position error of the body behind the head: the largest over its points, and its last point."""
    b = result.body
    assert b is not None, "body_figure needs a run with a body (follow(..., body_modules=M))"
    steps = np.arange(1, result.steps + 1)
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.plot(steps, result.point_errors.max(axis=1), color="tab:blue", linewidth=1.0, label="head (largest point)")
    ax.plot(steps, b.point_errors.max(axis=1), color="tab:orange", linewidth=1.0, label="body (largest point)")
    ax.plot(steps, b.point_errors[:, -1], color="tab:brown", linewidth=0.8, linestyle=":", label="tail point")
    ax.axhline(result.robot.tol_pos, color="tab:red", linestyle="--", linewidth=0.8, label="tolerance")
    mark_wall_touches(ax, result)
    ax.set_xlabel("trajectory step")
    ax.set_ylabel("position error (mm)")
    ax.set_xlim(1, max(2, result.steps))
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
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


def clearance_figure(result: "FollowResult") -> plt.Figure:
    """Smallest clearance to the lumen wall at each step (mm); below zero the wall is touched."""
    cl = result.clearance
    assert cl is not None, "clearance_figure needs a trajectory with a lumen"
    steps = np.arange(1, result.steps + 1)
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.plot(steps, cl.per_step, color="tab:green", linewidth=1.0, label="smallest clearance")
    ax.axhline(0.0, color="tab:red", linestyle="--", linewidth=0.8, label="wall")
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
    fig.tight_layout()
    return fig
