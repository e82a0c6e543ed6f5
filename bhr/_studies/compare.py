"""Side-by-side runs: the same trajectory and robot with several solvers (``bhr compare``).

:func:`compare_runs` runs each solver and times it; :func:`compare_rows` and
:func:`format_table` give the numbers the command prints (worst error over all
scored points, tip errors, clearance, time per step, and the worst error as a
ratio to the first solver's); :func:`compare_figure` draws every run's errors
on the same axes (matplotlib is imported only there).
"""
from __future__ import annotations

import math

import time
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from bhr._settings.errors import BhrError
from bhr._settings.inputs import MAX_STEP_POINTS
from bhr.model._robot import Robot
from bhr.model._generators import Trajectory
from bhr._run.driver import follow
from bhr.solvers import canonical, check_solver_name, get_solver

__all__ = ["Compared", "compare_runs", "compare_rows", "format_table", "compare_figure", "compare_json"]


@dataclass
class Compared:
    """One solver's run and the CPU time it took (seconds of this process's CPU, whole run)."""

    solver: str
    result: Any  # bhr._run.driver.FollowResult
    seconds: float

    @property
    def cpu_ms_per_step(self) -> float:
        """CPU milliseconds per step (this process's user + system time: not the wall clock, which counts what
        other programs on the machine take)."""
        return 1000.0 * self.seconds / self.result.steps


def compare_runs(traj: Trajectory, solvers: Sequence[str], robot: Robot, *,
                 solver_options: dict[str, dict[str, Any]] | None = None,
                 body_modules: int | None = None, stop_at_wall: bool = False) -> list[Compared]:
    """Run ``traj`` with each solver (options per solver name); raises BhrError for fewer than two or repeats."""
    names = [check_solver_name(s) for s in solvers]  # one name per solver in the table and the figure (seed: thesis)
    if len(names) < 2:
        raise BhrError("compare needs at least two solvers, e.g. --solver thesis --solver optimal")
    dup = next((s for s in names if names.count(s) > 1), None)
    if dup is not None:
        raise BhrError(f"solver {dup} is given twice; give each solver once")
    work = traj.points.shape[0] * (max(robot.modules, body_modules or 0) + 1) * len(names)
    if work > MAX_STEP_POINTS:  # every run is kept for the table and the figure: they share one run's budget
        raise BhrError(f"{len(names)} runs of {traj.points.shape[0]} steps x "
                       f"{max(robot.modules, body_modules or 0) + 1} robot points is {work:,} points to keep, "
                       f"more than the {MAX_STEP_POINTS:,} a command may hold in memory; shorten the path, raise "
                       "the feed, or compare fewer solvers")
    opts = {canonical(k): v for k, v in (solver_options or {}).items()}
    for s in names:  # every solver's options and needs (a lumen, say) checked before the first run, not after it
        get_solver(s, robot, **(opts.get(s) or {})).prepare(traj)
    out = []
    for s in names:
        # load (or compile) the solver's kernels first, so that the time is the run's
        warm = Trajectory(traj.name, np.ascontiguousarray(traj.points[:3]),
                          lumen=None if traj.lumen is None else traj.lumen[:3], start_direction=traj.start_direction,
                          start_point=traj.start_point)
        follow(warm, solver=s, robot=robot, solver_options=opts.get(s))
        t0 = time.process_time()  # CPU time: a busy machine does not change it
        res = follow(traj, solver=s, robot=robot, solver_options=opts.get(s), body_modules=body_modules,
                     stop_at_wall=stop_at_wall)
        out.append(Compared(s, res, time.process_time() - t0))
    return out


def compare_rows(runs: Sequence[Compared]) -> list[dict[str, Any]]:
    """Per solver: worst point error and its step, tip max and final, tip orientation max, clearance, time."""
    ref = runs[0].result.point_errors_mm.max()
    rows = []
    for c in runs:
        s = c.result.summary.to_dict()
        worst = float(c.result.point_errors_mm.max())
        row = {
            "solver": c.solver,
            "finished": s["finished"],
            "verdict": s["verdict"],
            "points_max_error_mm": worst,
            "points_worst_step": s["points_worst_step"],
            "tip_max_error_mm": s["tip_max_error_mm"],
            "tip_final_error_mm": s["tip_final_error_mm"],
            "tip_orientation_max_deg": s["tip_orientation_max_deg"],
            "cpu_ms_per_step": c.cpu_ms_per_step,
            "ratio_to_first": worst / ref if ref > 0 else float("nan"),
        }
        if "body_points_max_error_mm" in s:
            row["body_points_max_error_mm"] = s["body_points_max_error_mm"]
        if "min_clearance_mm" in s:
            row["min_clearance_mm"] = s["min_clearance_mm"]
            row["wall_touch_steps"] = s["wall_touch_steps"]
        rows.append(row)
    return rows


def format_table(runs: Sequence[Compared]) -> list[str]:
    """The lines ``bhr compare`` prints."""
    rows = compare_rows(runs)
    r0 = runs[0].result
    rb = r0.robot
    lines = [f"{r0.trajectory.name}: {r0.steps} steps, {rb.modules} modules x {rb.module_length:g} mm, "
             f"alpha {rb.alpha:g} deg, feed {rb.feed:g} mm", ""]
    body = "body_points_max_error_mm" in rows[0]
    lumen = "min_clearance_mm" in rows[0]
    head = f"{'solver':<13}{'worst mm':>10}{'at step':>9}{'tip max':>9}{'tip end':>9}{'tip deg':>9}"
    if body:
        head += f"{'body mm':>9}"
    if lumen:
        head += f"{'clear mm':>10}{'touches':>9}"
    head += f"{'CPU ms/step':>13}{'x ' + rows[0]['solver']:>12}  {'finished':<20}verdict"
    lines.append(head)
    for row in rows:
        line = (f"{row['solver']:<13}{row['points_max_error_mm']:>10.3f}{row['points_worst_step']:>9d}"
                f"{row['tip_max_error_mm']:>9.3f}{row['tip_final_error_mm']:>9.3f}{row['tip_orientation_max_deg']:>9.2f}")
        if body:
            line += f"{row['body_points_max_error_mm']:>9.3f}"
        if lumen:
            mc = row["min_clearance_mm"]
            line += f"{'-' if mc is None else format(mc, '.3f'):>10}{len(row['wall_touch_steps']):>9d}"
        line += f"{row['cpu_ms_per_step']:>13.3f}{row['ratio_to_first']:>12.3f}  {row['finished']:<20}{row['verdict']}"
        lines.append(line)
    lines.append("")
    lines.append(f"worst mm: largest position error over all scored points and steps; x {rows[0]['solver']}: "
                 f"that error divided by {rows[0]['solver']}'s; CPU ms/step: this process's CPU time (user + system, "
                 "not the wall clock) of the run / steps, after loading the kernels; finished: how the run ended; "
                 "verdict: followed, out of tolerance, touched the wall or left the lumen.")
    return lines


def compare_json(runs: Sequence[Compared]) -> dict[str, Any]:
    """The ``bhr compare --json`` document: the rows, and each run's largest point error and tip error per step."""
    from bhr import __version__

    r0 = runs[0].result
    return {
        "bhr_version": __version__,
        "trajectory": {"name": r0.trajectory.name, "params": r0.trajectory.params, "steps": r0.steps},
        "robot": r0.robot.to_dict(),
        "rows": [{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()}
                 for row in compare_rows(runs)],  # JSON has no NaN: an undefined ratio is null
        "runs": [{"solver": c.solver,
                  "points_max_error_mm": [float(v) for v in c.result.point_errors_mm.max(axis=1)],
                  "tip_error_mm": [float(v) for v in c.result.point_errors_mm[:, -1]],
                  "summary": c.result.summary.to_dict()} for c in runs],
    }


def compare_figure(runs: Sequence[Compared]):
    """Largest point error and tip error per step, every solver on the same axes; wall touches marked
    (:func:`bhr.output._compare_plot.compare_figure` draws it)."""
    from bhr.output._compare_plot import CompareSeries, compare_figure as draw

    r0 = runs[0].result
    series = [CompareSeries(c.solver, c.result.point_errors_mm.max(axis=1), c.result.point_errors_mm[:, -1],
                            tuple(c.result.clearance.touch_steps) if c.result.clearance is not None else ())
              for c in runs]
    return draw(series, r0.robot.tol_pos, f"{r0.trajectory.name}: " + " vs ".join(c.solver for c in runs))


def write_compare(runs: Sequence[Compared], folder: Any, *, json_name: str | None = None, plot: bool = True,
                  progress: Any = None) -> list[Any]:
    """Write a comparison's whole set into the staged ``folder`` (an :class:`bhr.output._atomic.OutputFolder`
    being written): each solver's run as ``bhr follow`` writes it (``SOLVER/run.json``, the per-step table
    and ``codes.csv``, so replay, plan and stream take it), the comparison's JSON as ``json_name`` and
    ``compare.png``. Returns where each will be once the folder is in place. ``progress(text)`` (a
    context manager) wraps the drawing."""
    import contextlib

    from bhr.output._atomic import write_json
    from bhr.output._steptable import write_run_files

    written = []
    for c in runs:
        sub = folder.path(c.result.solver)
        sub.mkdir(parents=True, exist_ok=True)
        write_run_files(c.result, sub)
        written.append(folder.final(c.result.solver))
    if json_name is not None:
        write_json(folder.path(json_name), compare_json(runs))
        written.append(folder.final(json_name))
    if plot:
        from bhr.output._figure import save_figure

        with progress(f"drawing {folder.final('compare.png')}") if progress else contextlib.nullcontext():
            save_figure(compare_figure(runs), folder.path("compare.png"))
        written.append(folder.final("compare.png"))
    return written
