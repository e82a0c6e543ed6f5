"""A sweep's output set: results.csv, results.json, heatmap.png and index.html, written whole."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

from bhr import __version__
from bhr.output._atomic import write_json, write_text
from bhr.output._htmlpage import PAGE_END, escape, figure, fmt, page_head, table
from bhr._settings.names import label as _label
from bhr._studies.study import finished_cell, verdict_cell, verdict_class
from bhr._studies.sweep.heatmap import heatmap_axes, heatmap_figure
from bhr._studies.sweep.ranking import best_designs, results_csv, robot_design_keys, what_ran
from bhr._studies.sweep.runs import METRICS, SweepResult

__all__ = ["write_outputs"]


def _best_html(result: SweepResult, count: int = 10) -> str:
    """The ranking the heat-map shows: robot designs by their worst point error over the trajectories."""
    keys = robot_design_keys(result.sweep)
    ranked = best_designs(result, None)
    many = len({tuple(r.get(k) for k in keys) for r in result.rows}) < len(result.rows)
    title = ("Best designs (smallest worst point error over the trajectories, as the heat-map shows)" if many
             else "Best designs (smallest worst point error)")
    cols = ["rank", *keys, "points_max_error_mm", "min_clearance_mm"] + (["worst_traj", "worst_row",
                                                                            "trajectories"] if many else [])
    heads = {"rank": "rank", "points_max_error_mm": "worst point error (mm)", "min_clearance_mm":
             "min clearance (mm)", "worst_traj": "worst on", "worst_row": "its row (design #)",
             "trajectories": "rows"}

    def cell(item: tuple[int, dict[str, Any]], c: str) -> tuple[str, str]:
        n, d = item
        if c == "rank":
            return str(n), ""
        v = _label(d[c]) if c in ("traj", "worst_traj") else d.get(c)
        return escape(fmt(v)), "l" if c in ("traj", "solver", "worst_traj") else (
            "rank" if c == "points_max_error_mm" else "")

    shown = ranked[:count]
    note = "" if len(ranked) <= count else (f"<p class=\"meta\">The best {count} of {len(ranked)} designs; every "
                                            "row is in the table below and in results.csv.</p>\n")
    return (f"<h2>{escape(title)}</h2>\n" + table("best", cols, list(enumerate(shown, 1)), cell, heads=heads,
                                                 head_class=lambda c: "rank" if c == "points_max_error_mm" else "")
            + note)


def _html(result: SweepResult, heatmap: str | None) -> str:
    # The ranking column (worst point error) right after the design's values, so it shows without scrolling.
    rank = "points_max_error_mm"
    # "finished" (how the run ended, or FAILED) and the verdict (followed, out of tolerance, touched the wall, left
    # the lumen) in words, apart: the status column of a run that raised is its error, in the row's own line
    cols = ["design", *result.sweep.keys, rank, *[m for m in METRICS if m not in (rank, "status")]]

    def cell(item: tuple[int, dict[str, Any]], c: str) -> tuple[str, str]:
        n, r = item
        if c == "rank":
            return str(n), ""
        if c == "finished":
            return escape(finished_cell(r) if r["status"] == "ok" else f"FAILED: {r['status']}"), (
                "l" if r["status"] == "ok" else "l bad")
        if c == "verdict":
            return escape(verdict_cell(r)), f"l {verdict_class(r)}" if r["status"] == "ok" else "l"
        v = _label(r[c]) if c == "traj" else r.get(c)
        return escape(fmt(v)), "l" if c in ("traj", "solver") else ("rank" if c == rank else "")

    def designs(rows: Sequence[dict[str, Any]], tid: str, ranked: bool = False) -> str:
        return table(tid, ["rank", *cols] if ranked else cols, list(enumerate(rows, 1)), cell,
                     head_class=lambda c: "rank" if c == rank else "",
                     row_class=lambda item: "ok" if item[1]["status"] == "ok" else "failed")

    s = result.sweep
    parts = [page_head(s.title), f"<h1>{escape(s.title)}</h1>\n"]
    if s.description:
        parts.append(f"<p>{escape(s.description)}</p>\n")
    axes = "; ".join(f"{k}: {', '.join(_label(v) for v in vals)}" for k, vals in s.axes)
    if s.robot_file:
        axes += f"; robot file: {s.robot_file}"
    parts.append(f"<p class=\"meta\">{what_ran(result)}, {len(result.failed)} failed, "
                 f"{result.wall_time_s:.1f} s on {escape(result.runner)}; bhr {escape(__version__)}.<br>"
                 f"{escape(axes)}</p>\n")
    if heatmap:
        parts.append(figure(heatmap, "heat-map of worst error per design",
                            "Worst point error (largest error of any point at any step) and, where the trajectory "
                            "has a lumen, minimum clearance per design; hatched: over the position tolerance; "
                            "framed in red: the thesis design; grey: every design in the cell failed"))
    parts.append(_best_html(result))
    parts.append("<h2>Every design</h2>\n")
    parts.append(designs(result.rows, "designs"))
    parts.append(PAGE_END)
    return "".join(parts)


def write_outputs(result: SweepResult, out_dir: str | os.PathLike[str], *, plot: bool = True,
                  x: str | None = None, y: str | None = None) -> list[Path]:
    """Write results.csv, results.json, heatmap.png (when ``plot``) and index.html into ``out_dir``."""
    out = Path(out_dir)
    files = [out / "results.csv", out / "results.json"]
    write_text(files[0], results_csv(result))
    s = result.sweep
    hx, hy = heatmap_axes(s, x, y)
    write_json(files[1], {
        "title": s.title,
        "bhr_version": __version__,
        "axes": {k: [v for v in vals] for k, vals in s.axes},
        "trajectory_sources": s.traj_sources,
        "robot_file": s.robot_file,
        "robot": dict(s.robot) or None,
        "designs": len(result.rows),
        "failed": len(result.failed),
        "wall_time_s": result.wall_time_s,
        "runner": result.runner,
        "workers": result.workers,
        "heatmap": {"x": hx, "y": hy},
        "rows": result.rows,
    })
    heat = None
    if plot:
        from bhr.output._figure import save_figure

        files.append(save_figure(heatmap_figure(result, x, y), out / "heatmap.png"))
        heat = "heatmap.png"
    write_text(out / "index.html", _html(result, heat))
    files.append(out / "index.html")
    return files
