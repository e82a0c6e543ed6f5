"""The clearance figure of a run with a lumen: the smallest clearance to the wall at each step."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult
from bhr._settings.errors import BhrError
from bhr.output._figure import margins, subplots
from bhr.output._scene import draw_contact_steps, draw_sections, mark_wall_touches

__all__ = ["clearance_figure"]


def clearance_figure(result: "FollowResult") -> Figure:
    """Smallest clearance to the lumen wall at each step (mm); below zero the wall is touched.

    Parameters
    ----------
    result : FollowResult
        A run along a trajectory with a lumen (``result.clearance`` is not None).

    Returns
    -------
    matplotlib.figure.Figure
        One panel: the smallest clearance of the robot's points and modules (mm) against trajectory step
        (1-based), its minimum marked; ``bhr follow`` saves it as ``clearance.png``.

    Raises
    ------
    BhrError
        A run along a trajectory without a lumen (nothing to measure the clearance against).
    """
    cl = result.clearance
    if cl is None:
        raise BhrError(f"clearance_figure needs a run along a trajectory with a lumen, and {result.trajectory.name} "
                       "has none; follow a colon (bhr.trajectory(\"colon\")) or a trajectory file with a lumen "
                       "column")
    steps = np.arange(1, result.steps + 1)
    fig, ax = subplots(figsize=(10, 4), gridspec_kw=margins(10, 4, 1, 1, left=0.75, top=0.4))  # fixed layout
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
    ax.set_title(f"Clearance to the lumen wall - {result.trajectory.name}, solver {result.solver}; wall: "
                 f"{cl.wall.split(' (')[0]}", fontsize=11, y=1.0)  # the top of the axes: placed, not laid out
    return fig
