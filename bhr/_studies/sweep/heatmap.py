"""The heat-map's data: which axes it shows, its cells (the worst over the other axes), its panels and the thesis
design's frame; :mod:`bhr.output._sweep_plot` draws it."""
from __future__ import annotations

import math
from typing import Any, Callable, Iterable

from bhr.model._robot import Robot
from bhr._settings.errors import BhrError
from bhr._settings.names import axis_label, axis_value
from bhr._settings.names import label as _label
from bhr._settings.options import excerpt
from bhr._studies.study import ROBOT_KEYS, make_robot
from bhr._studies.sweep.grid import Sweep
from bhr._studies.sweep.ranking import what_ran
from bhr._studies.sweep.runs import SweepResult

__all__ = ["heatmap_axes", "heatmap_cells", "MAX_PANELS", "heatmap_panels", "heatmap_figure"]


# ------------------------------------------------------------------------------------------ heat-map


def heatmap_axes(sweep: Sweep, x: str | None = None, y: str | None = None) -> tuple[str | None, str | None]:
    """The two axes a heat-map shows: ``x`` and ``y`` when given, else the two with the most values.

    Axes with one value are never picked by default; ties keep the sweep's
    order. ``None`` for an axis means a single row or column.
    """
    sizes = {k: len(v) for k, v in sweep.axes}
    for name, val in (("x", x), ("y", y)):
        if val is not None and val not in sizes:
            raise BhrError(f"heat-map {name} axis {excerpt(val)} is not an axis of this sweep; choose one of "
                           f"{', '.join(sizes)}")
    if x is not None and x == y:
        raise BhrError("heat-map x and y axes must differ")
    ranked = sorted((k for k in sweep.keys if sizes[k] > 1 and k not in (x, y)), key=lambda k: -sizes[k])
    if x is None and y is None:
        pair = sorted(ranked[:2], key=sweep.keys.index)  # the two biggest, shown in the sweep's order
        x = pair[0] if pair else None
        y = pair[1] if len(pair) > 1 else None
    elif x is None:
        x = ranked[0] if ranked else None
    elif y is None:
        y = ranked[0] if ranked else None
    return x, y


def _grid_values(sweep: Sweep, key: str | None) -> tuple[Any, ...]:
    return dict(sweep.axes)[key] if key is not None else (None,)


def heatmap_cells(result: SweepResult, x: str | None, y: str | None, metric: str,
                  worst: Callable[[Iterable[float]], float],
                  fixed: dict[str, Any] | None = None) -> list[list[float]]:
    """``metric`` per (y, x) cell, the ``worst`` over every other axis; NaN where no design has it.

    ``fixed`` keeps only the designs with those values (e.g. one panel's module length).
    """
    xs, ys = _grid_values(result.sweep, x), _grid_values(result.sweep, y)
    xi = {v: k for k, v in enumerate(xs)}
    yi = {v: k for k, v in enumerate(ys)}
    cells: list[list[list[float]]] = [[[] for _ in xs] for _ in ys]
    for r in result.rows:
        if fixed and any(r.get(k) != v for k, v in fixed.items()):
            continue
        v = r.get(metric)
        if r["status"] == "ok" and v is not None:
            cells[yi[r[y]] if y else 0][xi[r[x]] if x else 0].append(float(v))
    return [[worst(c) if c else math.nan for c in row] for row in cells]


#: At most this many panels, one per value of the third axis; more and the third axis joins the worst case.
MAX_PANELS = 9


def heatmap_panels(sweep: Sweep, x: str | None, y: str | None) -> str | None:
    """The axis whose values get a panel each: the biggest axis (most values) left after x and y, if any.

    On a tie a robot option (a design parameter) goes before a trajectory's, then the sweep's order.
    """
    rest = [k for k, v in sweep.axes if k not in (x, y) and 1 < len(v) <= MAX_PANELS]
    return max(rest, key=lambda k: (len(dict(sweep.axes)[k]), k in ROBOT_KEYS)) if rest else None


def _thesis_value(key: str) -> Any:
    """The thesis design's value of a robot key (bhr's default robot), or None for any other key."""
    return getattr(Robot(), key) if key in ROBOT_KEYS else None


def _row_tolerance(result: SweepResult, row: dict[str, Any]) -> float:
    """The position tolerance of a design (its grid value, the sweep's robot, or the thesis's 8 mm)."""
    try:
        return float(make_robot({k: v for k, v in row.items() if k in ROBOT_KEYS},
                                dict(result.sweep.robot) or None).tol_pos)
    except Exception:  # a failed design has no error to compare
        return math.inf


def heatmap_figure(result: SweepResult, x: str | None = None, y: str | None = None):
    """Worst point error and (when known) minimum clearance per (x, y) design.

    One panel per value of a third axis (:func:`heatmap_panels`), each cell the
    worst case over the remaining axes. Cells over the position tolerance are
    hatched; the thesis design (5 modules of 10 mm, alpha 10 deg, ...) is framed
    in red wherever the axes show it. :func:`bhr.output._sweep_plot.heatmap_figure` draws it.
    """
    import numpy as np

    from bhr.output._sweep_plot import HeatMetric
    from bhr.output._sweep_plot import heatmap_figure as draw

    x, y = heatmap_axes(result.sweep, x, y)
    z = heatmap_panels(result.sweep, x, y)
    xs, ys = _grid_values(result.sweep, x), _grid_values(result.sweep, y)
    zs = _grid_values(result.sweep, z)
    others = [k for k, v in result.sweep.axes if k not in (x, y, z) and len(v) > 1]
    over_cells = np.zeros((len(zs), len(ys), len(xs)), dtype=bool)
    ran = np.zeros((len(zs), len(ys), len(xs)), dtype=bool)  # some design of the cell ran (did not fail)
    xi = {v: k for k, v in enumerate(xs)}
    yi = {v: k for k, v in enumerate(ys)}
    zi = {v: k for k, v in enumerate(zs)}
    tols = set()
    for r in result.rows:
        e = r.get("points_max_error_mm")
        if r["status"] != "ok" or e is None:
            continue
        cell = (zi[r[z]] if z else 0, yi[r[y]] if y else 0, xi[r[x]] if x else 0)
        ran[cell] = True
        tol = _row_tolerance(result, r)
        tols.add(tol)
        if e > tol:
            over_cells[cell] = True
    thesis = {k: _thesis_value(k) for k in (x, y, z) if k is not None and _thesis_value(k) is not None}
    frames: list[tuple[int, int, int, int] | None] = []
    for zv in zs:
        frame = None
        if z not in thesis or zv == thesis[z]:
            tx = xs.index(thesis[x]) if x in thesis and thesis[x] in xs else (None if x in thesis else -1)
            ty = ys.index(thesis[y]) if y in thesis and thesis[y] in ys else (None if y in thesis else -1)
            if tx is not None and ty is not None and (tx >= 0 or ty >= 0):
                cx = [tx] if tx >= 0 else list(range(len(xs)))
                cy = [ty] if ty >= 0 else list(range(len(ys)))
                frame = (min(cx), min(cy), len(cx), len(cy))
        frames.append(frame)
    # one quantity per panel: the metric, and how a cell holding several designs shows it
    how = (f"each cell the worst over {', '.join(axis_label(o) for o in others)}" if others
           else "each cell one design")
    wanted = [("points_max_error_mm", "worst point error (mm)", max, "viridis")]
    if any(r.get("min_clearance_mm") is not None for r in result.rows):
        wanted.append(("min_clearance_mm", "minimum clearance (mm)", min, "viridis_r"))
    metrics = []
    for metric, label, worst, cmap in wanted:
        cells = [np.array(heatmap_cells(result, x, y, metric, worst, {z: zv} if z else None), dtype=float)
                 for zv in zs]
        titles = [f"{axis_value(z, zv)}\n{label}: {how}" if z else f"{label}:\n{how}" for zv in zs]
        error = metric == "points_max_error_mm"
        metrics.append(HeatMetric(label, cmap, cells, titles, over=list(over_cells) if error else None,
                                  marks=sorted(tols) if error else ()))
    tol_text = ", ".join(f"{t:g}" for t in sorted(tols) if math.isfinite(t)) or "8"
    what = ", ".join(f"{axis_label(k).split(' (')[0]} {_label(v)}" for k, v in thesis.items())
    return draw(metrics, list(ran), frames, [_label(v) for v in xs] if x else [""],
                [_label(v) for v in ys] if y else [""], axis_label(x), axis_label(y), tol_text, what,
                f"{result.sweep.title}: {what_ran(result)}")
