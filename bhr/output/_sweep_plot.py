"""The heat-map of ``bhr sweep`` (on a Figure, no pyplot). It takes plain arrays and labels;
:mod:`bhr._studies.sweep` computes them from a sweep's rows."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle

from bhr.output._figure import subplots

__all__ = ["HeatMetric", "heatmap_figure"]


@dataclass(frozen=True)
class HeatMetric:
    """One quantity of the heat-map, shown on every panel (one panel per value of a third axis).

    ``cells[k]`` is panel ``k``'s (rows, cols) array (NaN: no value), ``titles[k]`` its title. ``over[k]``
    (bool, same shape) hatches the cells over the tolerance; ``marks`` are values drawn on the colour bar
    (the tolerances). ``cmap`` is ``"viridis"`` (small is good) or ``"viridis_r"`` (large is good).
    """

    label: str
    cmap: str
    cells: Sequence[np.ndarray]
    titles: Sequence[str]
    over: Sequence[np.ndarray] | None = None
    marks: Sequence[float] = field(default_factory=tuple)


def heatmap_figure(metrics: Sequence[HeatMetric], ran: Sequence[np.ndarray],
                   frames: Sequence[tuple[int, int, int, int] | None], xticks: Sequence[str], yticks: Sequence[str],
                   xlabel: str, ylabel: str, tolerance_text: str, thesis_text: str, title: str) -> Figure:
    """Panels of cells, one row of panels per metric, each cell's value written in it.

    Parameters
    ----------
    metrics : the quantities (:class:`HeatMetric`), one block of panel rows each.
    ran : per panel, (rows, cols) bool: some design of the cell ran (a NaN cell then says "n/a", else "failed").
    frames : per panel, the thesis design's cells to frame in red as (col, row, cols, rows), or None.
    xticks, yticks, xlabel, ylabel : the cells' axes.
    tolerance_text : the tolerances named in the legend ("8" mm).
    thesis_text : what the red frame is ("modules 5, alpha 10").
    title : the figure's title.
    """
    count = len(ran)
    ncols = min(count, 3)
    zrows = -(-count // ncols)
    w = min(max(4.0, 0.5 * len(xticks) + 1.6), 9)
    h = min(max(3.2, 0.42 * len(yticks) + 1.6), 8)
    fig, axes = subplots(zrows * len(metrics), ncols, figsize=(w * ncols + 1.2, h * zrows * len(metrics) + 1.2),
                         squeeze=False)
    bars: list[tuple[Any, list[Any], str, Sequence[float]]] = []
    framed = False  # the thesis design is on the map
    for m, metric in enumerate(metrics):
        datas = [np.asarray(c, dtype=float) for c in metric.cells]
        finite = np.concatenate([d[np.isfinite(d)] for d in datas])
        lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
        cm = colormaps[metric.cmap].with_extremes(bad="#d0d0d0")
        # errors spanning more than a decade: a log scale keeps the small (good) ones apart
        norm = LogNorm(lo, hi) if lo > 0 and hi > 10 * lo else Normalize(lo, hi)
        block = axes[m * zrows:(m + 1) * zrows]
        for k in range(zrows * ncols):
            ax = block[k // ncols][k % ncols]
            if k >= count:
                ax.set_visible(False)
                continue
            data = datas[k]
            im = ax.imshow(np.ma.masked_invalid(data), origin="lower", aspect="auto", cmap=cm,
                           interpolation="nearest", norm=norm)
            ax.set_xticks(range(len(xticks)), list(xticks), rotation=45 if len(xticks) > 8 else 0, fontsize=8)
            ax.set_yticks(range(len(yticks)), list(yticks), fontsize=8)
            ax.set_xlabel(xlabel)
            ax.set_ylabel(ylabel)
            mid = float(norm.inverse(0.5))
            for (j, i), v in np.ndenumerate(data):
                if metric.over is not None and metric.over[k][j][i]:
                    ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False, hatch="///", linewidth=0,
                                           edgecolor=(1, 1, 1, 0.45)))
                if data.size <= 400:
                    text = f"{v:.2f}" if np.isfinite(v) else ("n/a" if ran[k][j][i] else "failed")
                    dark = np.isfinite(v) and ((v < mid) if metric.cmap == "viridis" else (v > mid))
                    ax.text(i, j, text, ha="center", va="center", fontsize=7 if data.size <= 100 else 6,
                            color="white" if dark else "black")
            frame = frames[k]
            if frame is not None:
                x0, y0, nx, ny = frame
                ax.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), nx, ny, fill=False, edgecolor="red", linewidth=2.5,
                                       zorder=5))
                framed = True
            ax.set_title(metric.titles[k], fontsize=9)
        bars.append((im, [a for row in block for a in row if a.get_visible()], metric.label, metric.marks))
    handles = [Patch(facecolor="#777", hatch="///", edgecolor="white", label=f"over the position tolerance "
                     f"({tolerance_text} mm)")]
    if framed:
        handles.append(Patch(facecolor="none", edgecolor="red", linewidth=2.5, label=f"thesis design ({thesis_text})"))
    handles.append(Patch(facecolor="#d0d0d0", label="every design in the cell failed"))
    legend = fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=9, frameon=False)
    fig.suptitle(title, fontsize=12)
    need = legend.get_window_extent().width / fig.dpi + 0.4
    if need > fig.get_figwidth():  # a narrow grid: widen the canvas so that the legend is whole
        fig.set_figwidth(need)
    fh, fw = fig.get_figheight(), fig.get_figwidth()
    fig.subplots_adjust(bottom=0.95 / fh, top=1 - 1.15 / fh, hspace=1.6 / (h - 1.6), wspace=1.0 / (w - 1.0),
                        left=0.85 / fw, right=1 - 1.3 / fw)
    for im, axs, label, marks in bars:  # one colour bar per metric, right of its panels
        y0 = min(a.get_position().y0 for a in axs)
        y1 = max(a.get_position().y1 for a in axs)
        cax = fig.add_axes((1 - 1.1 / fw, y0, 0.18 / fw, y1 - y0))
        bar = fig.colorbar(im, cax=cax, label=label)
        if isinstance(im.norm, LogNorm):
            lo, hi = float(im.norm.vmin or 0.0), float(im.norm.vmax or 1.0)
            ticks = [t * 10.0 ** e for e in range(-2, 6) for t in (1, 2, 5) if lo <= t * 10.0 ** e <= hi]
            bar.set_ticks(ticks, labels=[f"{t:g}" for t in ticks])
            bar.ax.minorticks_off()
        for t in marks:  # the tolerance on the colour scale
            if im.norm.vmin <= t <= im.norm.vmax:
                bar.ax.axhline(t, color="red", linewidth=2)
                bar.ax.text(-0.3, t, f"tol. {t:g}", transform=bar.ax.get_yaxis_transform(), ha="right",
                            va="center", fontsize=8, color="red")
    return fig
