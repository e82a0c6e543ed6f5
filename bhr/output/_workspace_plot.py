"""Figures of a robot by itself: a pose (:func:`plot_pose`, ``bhr fk --plot``) and the workspace (``bhr workspace``).

Drawn on :class:`matplotlib.figure.Figure` (no pyplot: nothing global, nothing
shown), saved atomically by :func:`save`. The pose figure draws each module as
the cylinder of the robot's radius it is, so that what a clearance figure
reports can be seen; the workspace figure is the classic one of binary
manipulators: the cloud of reachable tips, and their density seen from the
side and from the front.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from matplotlib.figure import Figure

from bhr.output._atomic import atomic_path
from bhr._settings.errors import BhrError

if TYPE_CHECKING:  # pragma: no cover
    from bhr.model._robot import Robot
    from bhr.model._workspace import Workspace

__all__ = ["plot_pose", "pose_figure", "workspace_figure", "draw_modules", "cylinder_surface", "save"]

#: Most tips the workspace figure's 3-D cloud draws (a random subset beyond, said in its title).
CLOUD_POINTS = 30_000
FORMATS = (".png", ".svg", ".pdf")


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def cylinder_surface(a: np.ndarray, b: np.ndarray, radius: float, count: int = 24) -> tuple[np.ndarray, ...]:
    """Surface grids (x, y, z), (2, count) each, of the cylinder of ``radius`` from ``a`` to ``b``."""
    axis = _unit(b - a)
    ref = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = _unit(np.cross(axis, ref))
    v = np.cross(axis, u)
    t = np.linspace(0.0, 2.0 * np.pi, count)
    ring = radius * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))  # (count, 3)
    grid = np.stack([a + ring, b + ring])  # (2, count, 3)
    return grid[..., 0], grid[..., 1], grid[..., 2]


def draw_modules(ax: Any, points: np.ndarray, radius: float, colors: Sequence[str] = ("#d9822b", "#3b73b9"),
                 alpha: float = 0.55) -> None:
    """Each module (points i to i+1) as a cylinder of ``radius`` on a 3-D axes, in two alternating colours."""
    for j in range(points.shape[0] - 1):
        a, b = points[j], points[j + 1]
        if np.linalg.norm(b - a) == 0:
            continue
        x, y, z = cylinder_surface(a, b, radius)
        ax.plot_surface(x, y, z, color=colors[j % len(colors)], alpha=alpha, linewidth=0, shade=True)


def _equal_box(ax: Any, pts: np.ndarray, pad: float) -> None:
    lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
    mid, half = (lo + hi) / 2.0, float((hi - lo).max()) / 2.0
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_box_aspect((1, 1, 1))


def pose_figure(robot: "Robot", codes: Sequence[int], points: np.ndarray, frames: np.ndarray,
                base_axes: np.ndarray, title: str | None = None) -> Figure:
    """The robot's pose for ``codes``: its modules as cylinders of its radius, the chain, the base frame's axes
    (``base_axes``, rows x, y, z) and each module's code written beside it."""
    import mpl_toolkits.mplot3d  # noqa: F401  (registers the 3-D projection)

    fig = Figure(figsize=(7.0, 6.4))
    ax = fig.add_subplot(projection="3d")
    ax.computed_zorder = False
    draw_modules(ax, points, robot.robot_radius)
    ax.plot(points[:, 0], points[:, 1], points[:, 2], "-o", color="black", markersize=2.5, linewidth=0.8,
            label="module axes and joints")
    ax.scatter(*points[-1], color="tab:red", s=30, label="tip", depthshade=False)
    arrow = 2.2 * robot.robot_radius  # out of the module's cylinder (x, y); z is the robot's axis at its base
    for k, (name, color) in enumerate((("x", "tab:red"), ("y", "tab:green"), ("z", "tab:blue"))):
        d = np.asarray(base_axes[k], dtype=np.float64)
        ax.quiver(*points[0], *(arrow * d), color=color, linewidth=1.5, arrow_length_ratio=0.2)
        ax.plot([], [], [], color=color, linewidth=1.5, marker=">", markersize=5, label=f"base {name} axis")
    for j, code in enumerate(codes):
        mid = (points[j] + points[j + 1]) / 2.0
        ax.text(*(mid + 1.3 * robot.robot_radius * frames[j][0]), str(int(code)), fontsize=7, color="0.25")
    _equal_box(ax, points, pad=1.6 * robot.robot_radius)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    d = points[-1] - points[0]
    ax.view_init(elev=22, azim=float(np.degrees(np.arctan2(d[1], d[0]))) - 60)
    tip = points[-1]
    ax.set_title(title or (f"{len(codes)} modules of {robot.module_length:g} mm, radius {robot.robot_radius:g} mm, "
                           f"\u03b1 = {robot.alpha:g}\u00b0\ncodes {','.join(str(int(c)) for c in codes)} "
                           f"(base first); tip at ({tip[0]:.4g}, {tip[1]:.4g}, {tip[2]:.4g}) mm"), fontsize=9)
    ax.legend(loc="upper left", fontsize=8)
    fig.subplots_adjust(left=0.02, right=0.95, top=0.9, bottom=0.04)
    return fig


def _density(ax: Any, fig: Figure, a: np.ndarray, b: np.ndarray, cell: float, xlabel: str, ylabel: str,
             title: str) -> None:
    """A 2-D histogram of the poses (log colour) on a 2-D axes, bins of ``cell`` mm, equal aspect."""
    from matplotlib.colors import LogNorm

    def edges(v: np.ndarray) -> np.ndarray:  # cells centred on multiples of ``cell`` (0, the robot's axis, is one)
        size = max(cell, float(np.ptp(v)) / 400.0)
        lo, hi = np.floor(float(v.min()) / size + 0.5) - 0.5, np.ceil(float(v.max()) / size - 0.5) + 0.5
        return np.arange(lo, hi + 0.5) * size

    h, xe, ye = np.histogram2d(a, b, bins=(edges(a), edges(b)))
    h[h == 0] = np.nan
    mesh = ax.pcolormesh(xe, ye, h.T, norm=LogNorm(vmin=1, vmax=max(2.0, float(np.nanmax(h)))), cmap="viridis",
                         shading="flat")
    fig.colorbar(mesh, ax=ax, shrink=0.85, label="poses per cell")
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.grid(True, alpha=0.3)


def workspace_figure(ws: "Workspace") -> Figure:
    """The reachable tips of ``ws``: a 3-D cloud of the distinct tips (coloured by how far along the robot's
    axis), the density of poses seen from the side (x, z) and from the front (y, z), and the indices."""
    import mpl_toolkits.mplot3d  # noqa: F401  (registers the 3-D projection)

    ix = ws.indices()
    pts = ws.distinct_tips()
    shown = pts
    if len(pts) > CLOUD_POINTS:
        shown = pts[np.random.default_rng(0).choice(len(pts), CLOUD_POINTS, replace=False)]
    fig = Figure(figsize=(15.0, 5.6))
    grid = fig.add_gridspec(1, 3, width_ratios=[1.35, 1.0, 1.0])
    ax = fig.add_subplot(grid[0, 0], projection="3d")
    sc = ax.scatter(shown[:, 0], shown[:, 1], shown[:, 2], c=shown[:, 0], s=1.0, cmap="plasma", depthshade=False,
                    linewidths=0)
    fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.1, label="x along the straight robot (mm)")
    ax.scatter([0], [0], [0], color="black", s=25, marker="s", depthshade=False)
    ax.text(0, 0, 0, " base", fontsize=8)
    _equal_box(ax, np.vstack([pts, np.zeros((1, 3))]), pad=2.0)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.view_init(elev=18, azim=-60)
    cloud = (f"{len(shown):,} of {len(pts):,} distinct tips" if len(shown) < len(pts)
             else f"{len(pts):,} distinct tips")
    ax.set_title(f"reachable tips: {cloud}", fontsize=9)
    cell = ws.voxel
    _density(fig.add_subplot(grid[0, 1]), fig, ws.tips[:, 0], ws.tips[:, 2], cell, "x (mm)", "z (mm)",
             f"density seen from the side (cells of {cell:g} mm)")
    _density(fig.add_subplot(grid[0, 2]), fig, ws.tips[:, 1], ws.tips[:, 2], cell, "y (mm)", "z (mm)",
             f"density seen along the robot (cells of {cell:g} mm)")
    r = ws.robot
    how = (f"all {ix['poses']:,} poses (exact)" if ws.exact else
           f"{ix['evaluated_poses']:,} random poses of {ix['poses']:.3g} (Monte Carlo, seed {ws.seed})")
    lift = "rest, 4 tilts and the lift" if 15 in ws.choices else "rest and 4 tilts"
    sampled = "" if ws.exact else " of the sample (the robot's: at least this volume, at most this gap)"
    fig.suptitle(f"Workspace of {ws.modules} binary modules of {r.module_length:g} mm, \u03b1 = {r.alpha:g}\u00b0 "
                 f"({lift} per module): {how}\n"
                 f"reach {ix['reach_min_mm']:.4g}\u2013{ix['reach_max_mm']:.4g} mm, volume "
                 f"{ix['volume_mm3']:.4g} mm\u00b3 ({ix['occupied_voxels']:,} cells of {cell:g} mm), resolution "
                 f"{ix['resolution_median_mm']:.3g} mm (median gap to the nearest other tip), "
                 f"{ix['distinct_tip_directions']:,} tip directions{sampled}", fontsize=10)
    fig.subplots_adjust(left=0.0, right=0.97, top=0.84, bottom=0.1, wspace=0.28)
    return fig


def check_path(path: str | os.PathLike[str]) -> None:
    """Refuse a figure path whose extension is not one bhr draws."""
    suffix = Path(path).suffix.lower()
    if suffix and suffix not in FORMATS:
        raise BhrError(f"cannot draw a figure as {path}: give a file ending in .png, .svg or .pdf")


def plot_pose(robot: "Robot", codes: Sequence[int], path: str | os.PathLike[str] | None = None,
              title: str | None = None) -> Figure:
    """A figure of ``robot``'s pose for ``codes`` (one per module, base first), as ``bhr fk --plot`` draws it.

    The robot runs straight along +X from the origin as :meth:`bhr.model.Robot.fk` puts it; with ``path``
    (.png, .svg or .pdf) the figure is also written there.

    Parameters
    ----------
    robot : Robot
        The robot: modules n, module length (mm), alpha (deg), disc radius (mm).
    codes : sequence of int, shape (n,)
        One code per module, base first (0, 3, 6, 9, 12 or 15).
    path : str or os.PathLike, optional
        A file to save the figure to as well.
    title : str, optional
        The figure's title; default one naming the modules, their length and the disc radius.

    Returns
    -------
    matplotlib.figure.Figure
        The chain and its discs in 3-D, mm, with each module's frame.

    Examples
    --------
    >>> from bhr.model import Robot
    >>> fig = plot_pose(Robot(modules=3), [3, 0, 15])
    >>> len(fig.axes) >= 1
    True
    """
    from bhr.model._robot import base_frame

    points, frames = robot.fk(codes)
    fig = pose_figure(robot, [int(c) for c in codes], points, frames, base_frame((1, 0, 0)), title)
    if path is not None:
        save(fig, path)
    return fig


def save(fig: Figure, path: str | os.PathLike[str], dpi: int = 110) -> Path:
    """Write ``fig`` to ``path`` whole or not at all (PNG, or SVG/PDF by extension)."""
    check_path(path)
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)  # bhr-out/ on a first run, as a run's folder is
    fmt = p.suffix.lower().lstrip(".") or "png"
    with atomic_path(p) as tmp:
        if tmp == p:  # a device or FIFO: render in memory, then one plain write
            import io

            buf = io.BytesIO()
            fig.savefig(buf, dpi=dpi, format=fmt)
            with open(p, "ab" if p.is_file() else "wb") as fh:
                fh.write(buf.getvalue())
        else:
            fig.savefig(tmp, dpi=dpi, format=fmt)
    return p
