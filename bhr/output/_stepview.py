"""One step of a run as the animation and the live view show it (:class:`StepView`)."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult
from bhr.output._scene import (
    FRAME_INCHES,
    FRAME_ZOOM,
    check_step,
    depth_cue,
    draw_context,
    draw_pose,
    equal_3d,
    head_centre,
    legend_below,
    plot_points,
    set_window,
    setup_axes,
    draw_lumen_wall,
    draw_path,
    draw_start_end,
    lumen_walls,
    run_is_planar,
    zoom_half_width,
)

__all__ = ["StepView"]


class StepView:
    """One step of a run as the animation and the live view show it: a view that follows the robot.

    The left axes (``ax``) is a square window around the robot's head, moved
    with it at every step; the path, the lumen wall, start and end stay
    drawn, so that the robot is large and its surroundings readable. On the
    right, an overview shows the whole path with the robot's place (and, in a
    top view, the window), and a readout gives the step's errors against the
    tolerances.
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
        self.ax = setup_axes(self.fig, self.planar, main)
        self.ax.grid(False)  # grid lines sliding under a moving view only blur it (and bloat a GIF)
        draw_context(self.ax, result, self.planar, 1)
        self.overview = setup_axes(self.fig, self.planar, (0.71, 0.47, 0.27, 0.42))
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
            equal_3d(self.overview, pts)
            depth_cue(self.overview, result, None, self.overview.get_zlim()[0])
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
        return head_centre(self.result, i)

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
        i = check_step(r, i)
        for a in self.artists:
            a.remove()
        new = draw_pose(self.ax, r, i, self.planar)
        centre = self.window_centre(i)
        set_window(self.ax, centre, self.half, self.planar)
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
            new += depth_cue(self.ax, r, i, self.ax.get_zlim()[0])
        new += plot_points(self.overview, r.points[i], self.planar, "-", color="tab:red", linewidth=2.5)
        new += plot_points(self.overview, r.points[i, -1:], self.planar, "o", color="tab:red", markersize=4)
        self.readout.set_text(self.readout_text(i))
        self.artists = new
        self.step = i
        self.ax.set_title(self.title(i), fontsize=10)
        if not self._laid_out:
            # The legend is fixed below the view and the layout set once for all frames.
            legend_below(self.fig, self.ax, ncol=5, x=0.36)
            self._laid_out = True
        return new
