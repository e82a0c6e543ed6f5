"""The error figures of a run (thesis Figs. 7.2-7.21): one panel per point or module against the trajectory step,
and the whole body's errors."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult
from bhr._settings.errors import BhrError
from bhr._settings.options import excerpt
from bhr.output._figure import amount, light_ticks, margins, mark_worst, subplots
from bhr.output._scene import draw_sections, mark_wall_touches

__all__ = ["ORDINALS", "ERROR_KINDS", "error_figure", "body_figure"]

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


def _unit(kind: str) -> str:
    return {"position": "mm", "orientation": "deg", "global": ""}[kind]


def error_data(result: "FollowResult", kind: str) -> np.ndarray:
    if not isinstance(kind, str) or kind not in ERROR_KINDS:
        raise BhrError(f"unknown error kind {excerpt(kind)}; give one of {', '.join(ERROR_KINDS)}")
    return {"position": result.point_errors_mm, "orientation": result.orientation_errors_deg,
            "global": result.global_errors}[kind]


def error_grid_shape(count: int) -> tuple[int, int]:
    cols = 2 if count > 1 else 1
    return int(np.ceil(count / cols)), cols


class ErrorGrid:
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
                                      gridspec_kw=margins(width, height, rows, cols))
        self.axes = [axes[j // cols][j % cols] for j in range(rows * cols)]
        self.steps = np.arange(1, self.n + 1)
        self.curves, self.tols, self.marks = [], [], []
        self.legend_entries: dict[int, tuple[int, ...]] = {}  # panel -> the artists its legend was made for
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
            light_ticks(ax)
        self.title = self.fig.suptitle("", fontsize=12, y=1 - 0.12 / height)

    def fill(self, kind: str) -> Figure:
        """The figure with ``kind``'s errors: one panel per point (position) or module (orientation, global)."""
        result, cols = self.result, self.cols
        data = error_data(result, kind)
        if data.shape[0] != self.n or error_grid_shape(data.shape[1]) != (self.rows, cols):
            raise ValueError(f"{kind} errors do not fit this grid")  # internal: ErrorGrid is made for one result
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
                mark.set_label(f"worst {amount(float(col[k]), unit)} (step {int(self.steps[k])})")
                mark.set_visible(True)
            else:
                mark.set_data([], [])
                mark.set_label("_worst")  # no legend entry
                mark.set_visible(False)
            ax.set_title(_panel_title(kind, j, count), fontsize=10, y=1.0, pad=4)  # placed, not laid out
            ax.set_ylabel(ylabel, fontsize=9)
            top = max(tol, float(np.nanmax(col)) if np.isfinite(col).any() else 0.0)
            ax.set_ylim(0, 1.45 * top if top > 0 else 1.0)  # room above for the legend
            light_ticks(ax, which="y")
            handles, labels = ax.get_legend_handles_labels()
            entries = tuple(map(id, handles))
            legend = ax.get_legend()
            if legend is not None and self.legend_entries.get(j) == entries:  # the same entries: new words only
                for text, label in zip(legend.get_texts(), labels):
                    text.set_text(label)
            else:
                ax.legend(handles, labels, loc="upper right", fontsize=7, framealpha=0.9, ncol=2)
                self.legend_entries[j] = entries
            bottom = j // cols == self.rows - 1 or j + cols >= count
            ax.set_xlabel("trajectory step" if bottom else "", fontsize=9)
        self.title.set_text(f"{title} - {result.trajectory.name}, solver {result.solver}")
        return self.fig


def error_figure(result: "FollowResult", kind: str) -> Figure:
    """One panel per point (position) or module (orientation, global) against trajectory step.

    Every panel has its step numbers, the tolerance line and its worst step
    circled, both named in the panel's legend.

    Parameters
    ----------
    result : FollowResult
        A run, as :func:`bhr.follow` returns it.
    kind : {"position", "orientation", "global"}
        Which error: of each point, mm (n+1 panels, base first); of each module's direction, deg (n panels);
        or the thesis's global error of each module, w_pos e_pos / tol_pos + w_ori e_ori / tol_ori, no unit.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per point or module, trajectory step (1-based) on x; ``bhr follow`` saves them as
        ``position_errors.png``, ``orientation_errors.png`` and ``global_errors.png``.

    Raises
    ------
    BhrError
        An unknown ``kind``.

    Examples
    --------
    >>> import bhr
    >>> fig = error_figure(bhr.follow(bhr.trajectory("line", length=20)), "orientation")
    >>> [ax.get_title() for ax in fig.axes if ax.get_visible()][::4], fig.axes[0].get_ylabel()
    (['First module (base)', 'Fifth module (tip)'], 'orientation error (deg)')
    """
    data = error_data(result, kind)
    return ErrorGrid(result, *error_grid_shape(data.shape[1])).fill(kind)


def body_figure(result: "FollowResult") -> Figure:
    """Position error of the body behind the head: the largest over its points, and its last point.

    The head's largest point error is drawn beside it, with the tolerance and each one's worst step.

    Parameters
    ----------
    result : FollowResult
        A run with a body, as ``bhr.follow(..., body_modules=M)`` or ``reach="cecum"`` returns it.

    Returns
    -------
    matplotlib.figure.Figure
        One panel: position error (mm) against trajectory step (1-based); ``bhr follow`` saves it as
        ``body_errors.png``.

    Raises
    ------
    BhrError
        A run without a body (the head alone).
    """
    b = result.body
    if b is None:
        raise BhrError("body_figure needs a run with a body behind the head; run bhr.follow(..., body_modules=M) "
                       "or bhr.follow(..., reach=\"cecum\")")
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
