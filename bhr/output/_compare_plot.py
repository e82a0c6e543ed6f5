"""The figure of ``bhr compare``: every solver's errors on the same axes (drawn on a Figure, no pyplot)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from matplotlib import rcParams
from matplotlib.figure import Figure

from bhr.output._figure import mark_worst, subplots

__all__ = ["CompareSeries", "compare_figure"]


@dataclass(frozen=True)
class CompareSeries:
    """One solver's run: its name, the largest point error and the tip error per step (mm, steps from 1), and
    the 1-based steps where the robot touched the wall."""

    solver: str
    worst_mm: np.ndarray
    tip_mm: np.ndarray
    touch_steps: Sequence[int] = ()


def compare_figure(series: Sequence[CompareSeries], tol_pos: float, title: str) -> Figure:
    """Largest point error and tip error per step, every solver on the same axes; wall touches marked.

    ``tol_pos`` is the position tolerance (mm), drawn on both panels; ``title`` the figure's title.
    """
    colors = rcParams["axes.prop_cycle"].by_key()["color"]
    fig, axes = subplots(2, 1, figsize=(10, 6.5), sharex=True)
    count = max(len(s.worst_mm) for s in series)
    for k, s in enumerate(series):
        col = colors[k % len(colors)]
        steps = np.arange(1, len(s.worst_mm) + 1)
        axes[0].plot(steps, s.worst_mm, color=col, linewidth=1.0, label=s.solver)
        axes[1].plot(steps, s.tip_mm, color=col, linewidth=1.0, label=s.solver)
        mark_worst(axes[0], steps, s.worst_mm, "mm", color=col, what=f"{s.solver} worst")
        mark_worst(axes[1], steps, s.tip_mm, "mm", color=col, what=f"{s.solver} worst")
        if len(s.touch_steps):
            for ax in axes:
                ax.plot(s.touch_steps, np.zeros(len(s.touch_steps)), "|", color=col, markersize=12,
                        label=f"{s.solver}: wall touched" if ax is axes[0] else None)
    top = max([tol_pos] + [float(np.max(s.worst_mm)) for s in series if len(s.worst_mm)])
    for ax, name in zip(axes, ("Largest position error over the robot's points", "Tip position error")):
        ax.axhline(tol_pos, color="tab:red", linestyle="--", linewidth=0.8, label=f"tolerance {tol_pos:g} mm")
        ax.set_ylabel("error (mm)")
        ax.set_title(name, fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.set_ylim(0, 1.4 * top)  # room above for the legend
        ax.tick_params(labelbottom=True)  # step numbers under both panels
        ax.set_xlim(1, max(2, count))
        ax.legend(loc="upper right", fontsize=8, ncol=2)
    axes[1].set_xlabel("trajectory step")
    fig.suptitle(title, fontsize=12)
    fig.tight_layout()
    return fig
