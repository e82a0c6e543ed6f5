"""New figures and saving them: a :class:`matplotlib.figure.Figure` (no pyplot), PNG/SVG/PDF written atomically,
and the axis helpers the figures share (fixed ticks and margins, the worst value marked)."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from bhr.output._atomic import atomic_path
from bhr._settings.errors import BhrError

__all__ = ["subplots", "mark_worst", "FIGURE_FORMATS", "check_figure_path", "RUN_PNG_COMPRESS", "TEXT_RENDERING",
           "save_figure"]


def subplots(*grid: int, figsize: tuple[float, float], **kw: Any) -> tuple[Figure, Any]:
    """A new :class:`matplotlib.figure.Figure` of ``figsize`` inches and its axes (``Figure.subplots``): no pyplot,
    so nothing global to close and no backend to choose; the figure is saved by :func:`save_figure`."""
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(*grid, **kw)


def amount(value: float, unit: str, digits: int = 2) -> str:
    return f"{value:.{digits}f} {unit}".rstrip() if unit else f"{value:.{digits}f}"


def mark_worst(ax: Any, steps: np.ndarray, values: np.ndarray, unit: str, color: str = "black",
               what: str = "worst") -> int | None:
    """Circle the largest value of ``values`` (first such step) and name it in the legend; return its index."""
    if values.size == 0 or not np.isfinite(values).any():
        return None
    k = int(np.nanargmax(values))
    ax.plot([steps[k]], [values[k]], "o", markersize=7, markerfacecolor="none", markeredgecolor=color,
            markeredgewidth=1.3, label=f"{what} {amount(float(values[k]), unit)} (step {int(steps[k])})")
    return k


def light_ticks(ax: Any, bins: int = 5, which: str = "xy") -> None:
    """Ticks fixed once from the axes' limits: the same kind of numbers as matplotlib's default, fewer of them,
    and none computed again at each draw (ticks and their labels are most of an error figure's drawing time).
    ``which``: the axes whose ticks are fixed ("x", "y" or "xy")."""
    from matplotlib.ticker import FixedLocator, MaxNLocator

    for axis, (lo, hi) in [(a, lim) for name, a, lim in (("x", ax.xaxis, ax.get_xlim()), ("y", ax.yaxis, ax.get_ylim()))
                           if name in which]:
        ticks = [t for t in MaxNLocator(nbins=bins, steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
                 if lo - 1e-9 * abs(hi - lo) <= t <= hi + 1e-9 * abs(hi - lo)]
        axis.set_major_locator(FixedLocator(ticks))


def margins(width: float, height: float, rows: int, cols: int, left: float = 0.7, right: float = 0.15,
             top: float = 0.75, bottom: float = 0.55, between: float = 0.7, across: float = 0.8) -> dict[str, float]:
    """Subplot margins given in inches (a fixed layout: no tight_layout pass, which costs a draw)."""
    ax_h = (height - top - bottom - between * (rows - 1)) / rows
    ax_w = (width - left - right - across * (cols - 1)) / cols
    return {"left": left / width, "right": 1 - right / width, "top": 1 - top / height, "bottom": bottom / height,
            "hspace": between / ax_h, "wspace": across / ax_w}


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
    """Save ``fig`` atomically as PNG (or SVG/PDF by extension); ``compress``: a PNG's zlib level.

    The file appears whole or not at all (written beside it, then renamed into place).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or os.PathLike
        The file: ``.svg`` and ``.pdf`` are written in those formats, anything else as PNG.
    dpi : int, default 110
        Dots per inch of a PNG.
    compress : int, optional
        A PNG's zlib level, 0 (none) to 9; default matplotlib's.

    Returns
    -------
    pathlib.Path
        The path written.
    """
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
