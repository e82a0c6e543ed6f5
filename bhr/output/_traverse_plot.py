"""The figures of ``bhr traverse``: the pass-rate map of the designs and the worst colon's clearance (on a Figure,
no pyplot). They take plain arrays and labels; :mod:`bhr._studies.traverse` computes them from a study."""
from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from bhr.output._figure import subplots

__all__ = ["passrate_figure", "penetration_figure"]


def passrate_figure(rate: np.ndarray, clear: np.ndarray, texts: Sequence[Sequence[str]], reached: np.ndarray,
                    best: tuple[int, int] | None, xticks: Sequence[str], yticks: Sequence[str], xlabel: str,
                    ylabel: str, title: str, tie_label: str = "worst clearance (mm)") -> Figure:
    """Pass rate per (x, y) cell as a colour map with each cell's text.

    Parameters
    ----------
    rate : ndarray, shape (rows, cols)
        Share of colons traversed (0 ... 1; NaN: no design in the cell).
    clear : ndarray, shape (rows, cols)
        The measure that ranks cells of one pass rate, higher better (by default the cell's worst clearance,
        mm; NaN unknown): the colour when every cell has the same pass rate.
    texts : rows x cols str
        What each cell says.
    reached : ndarray of bool, shape (rows, cols)
        Cells at or over the study's target (outlined black).
    best : (row, col) or None
        The best design's cell (outlined dashed red, marked "best").
    xticks, yticks, xlabel, ylabel, title : str
        Axis labels and the title.
    tie_label : str, default "worst clearance (mm)"
        What ``clear`` is, with its unit (the colour bar's label when it colours the map).

    Returns
    -------
    matplotlib.figure.Figure
        The map, one cell per (x, y) design.
    """
    finite = rate[np.isfinite(rate)]
    # every cell at one pass rate (all through, say): a map of it would be one colour and hide what ranks them;
    # the colour then shows the next measure that tells the designs apart, and says so
    tied = finite.size > 1 and float(np.ptp(finite)) == 0.0 and bool(np.isfinite(clear).any())
    w = min(max(8.5, 1.5 * len(xticks) + 3.0), 16)  # room for each cell's four lines
    h = min(max(5.0, 0.55 * len(yticks) + 2.8), 12)
    fig, ax = subplots(figsize=(w, h))
    if tied:
        lo, hi = float(np.nanmin(clear)), float(np.nanmax(clear))
        im = ax.imshow(clear, origin="lower", aspect="auto", cmap="viridis", vmin=lo, vmax=hi if hi > lo else lo + 1,
                       interpolation="nearest")
        fig.colorbar(im, ax=ax, label=f"{tie_label}\nthe tie-break: every cell {100 * float(finite[0]):.0f}%")
    else:
        im = ax.imshow(rate * 100, origin="lower", aspect="auto", cmap="RdYlGn", vmin=0, vmax=100,
                       interpolation="nearest")
        fig.colorbar(im, ax=ax, label="colons traversed without wall contact (%)")
    ax.set_xticks(range(len(xticks)), list(xticks))
    ax.set_yticks(range(len(yticks)), list(yticks))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    for (j, i), v in np.ndenumerate(rate):
        if tied:
            share = (clear[j, i] - np.nanmin(clear)) / max(1e-12, float(np.nanmax(clear) - np.nanmin(clear)))
            dark = bool(np.isfinite(share) and share < 0.55)  # viridis is dark at its low end
        else:
            dark = bool(np.isfinite(v) and (v < 0.25 or v > 0.85))  # the deep red and deep green ends of the map
        ax.text(i, j, texts[j][i], ha="center", va="center", fontsize=8, color="white" if dark else "black")
        if reached[j, i]:
            ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False, edgecolor="black", linewidth=2.2))
        if best == (j, i):  # the answer: marked, whatever the colours
            ax.add_patch(Rectangle((i - 0.46, j - 0.46), 0.92, 0.92, fill=False, edgecolor="#e8112d",
                                   linewidth=3.0, linestyle="--"))
            ax.annotate("best", (i + 0.44, j + 0.44), ha="right", va="top", fontsize=8, color="#e8112d",
                        fontweight="bold")
    ax.set_title(title, fontsize=8.5)
    fig.tight_layout()
    return fig


def penetration_figure(distance_mm: np.ndarray, clearance_mm: np.ndarray, sections: Sequence[str],
                       starts: np.ndarray, ends: np.ndarray, title: str) -> Figure:
    """The robot's smallest clearance to the wall at each step against the tip's distance from the anus; below
    zero (shaded red) the robot is that deep in the wall.

    Parameters
    ----------
    distance_mm, clearance_mm : ndarray, shape (steps,)
        The tip's distance along the colon and the smallest clearance (mm; NaN unknown) at each step.
    sections, starts, ends : the colon's sections, named, and where each starts and ends along it (mm).
    title : str
    """
    s, clearance = distance_mm, clearance_mm
    fig, ax = subplots(figsize=(11, 4.2))
    finite = clearance[np.isfinite(clearance)]
    lo = min(-1.0, float(finite.min()) if finite.size else -1.0)
    hi = max(1.0, float(finite.max()) if finite.size else 1.0)
    top = hi + 0.25 * (hi - lo)
    for k, (a, b) in enumerate(zip(starts, ends)):
        if k % 2 == 0:
            ax.axvspan(a, b, color="#eef0f4", zorder=0)
        ax.text((a + b) / 2, top - 0.02 * (top - lo), sections[k].replace(" flexure", "\nflexure"), ha="center",
                va="top", fontsize=7, color="#444")
    ax.axhline(0.0, color="black", linewidth=0.8, zorder=2)
    ax.fill_between(s, 0, np.minimum(0.0, np.nan_to_num(clearance, nan=0.0)), color="#d62728", alpha=0.45,
                    step="mid", zorder=3, label="into the wall")
    ax.plot(s, clearance, color="#1f4e79", linewidth=0.9, zorder=4, label="smallest clearance")
    ax.set_xlim(0, max(float(ends[-1]), float(s[-1]) if len(s) else 1.0))
    ax.set_ylim(lo - 0.05 * (hi - lo), top)
    ax.set_xlabel("tip's distance from the anus along the colon (mm)")
    ax.set_ylabel("robot's smallest clearance\nto the wall (mm)")
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return fig
