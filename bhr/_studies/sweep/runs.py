"""Running a sweep: every design is one ``bhr follow`` run without figures, through the studies' executor
(this process, worker processes or a Dask cluster); one row per design."""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from bhr.model._generators import load_trajectory
from bhr._run.driver import BhrWarning, follow
from bhr._settings.options import solver_options_for
from bhr._studies.executor import capture, run_jobs
from bhr._studies.study import ROBOT_KEYS, TRAJ_KEYS, make_robot, replay_options, sim_options, summary_row
from bhr._studies.sweep.grid import Sweep, colon_source

__all__ = ["METRICS", "PHYSICS_KEYS", "run_design", "warm_designs", "run_chunk", "SweepResult", "run_sweep"]
#: Result columns of every design, after its design keys.
METRICS = ("status", "finished", "verdict", "steps", "tip_max_error_mm", "tip_final_error_mm", "points_max_error_mm",
           "orientation_max_deg", "global_max", "tip_rmse_mm", "tip_orientation_rmse_deg", "tolerance_exceeded",
           "min_clearance_mm", "min_turn_radius_mm")


#: What a run's row gets from its physical replay (:func:`run_design` with ``physics``).
PHYSICS_KEYS = ("peak_wall_force_n", "wall_stretch_mm", "physical_cecum_step", "physically_traversed", "poses_replayed")


def run_design(design: dict[str, Any], traj_source: str, base_robot: dict[str, Any] | None = None,
               extra: Sequence[str] = (), physics: Sequence[tuple[str, Any]] = (), points: int | None = None,
               ) -> dict[str, Any]:
    """Follow one design's trajectory (its first ``points`` points only, when given); return its row (design
    keys, :data:`METRICS`, then the summary's ``extra`` keys as they are, None where the summary lacks one; with
    ``physics``, the run replayed as the physical robot with those options: :data:`PHYSICS_KEYS`). Never
    raises."""
    row = _blank_row(design, extra)
    if physics:
        row.update({k: None for k in PHYSICS_KEYS})
    with capture(row):  # one failed design must not stop the sweep
        robot = make_robot({k: v for k, v in design.items() if k in ROBOT_KEYS}, base_robot)
        row["min_turn_radius_mm"] = robot.min_turn_radius
        source, params = colon_source(traj_source, {k: v for k, v in design.items() if k in TRAJ_KEYS})
        tr = load_trajectory(source, feed=robot.feed, **params)
        if points is not None:
            tr = dataclasses.replace(tr, points=np.ascontiguousarray(tr.points[:points]),
                                     lumen=None if tr.lumen is None else np.ascontiguousarray(tr.lumen[:points]))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            res = follow(tr, solver=design["solver"], robot=robot,
                         solver_options=solver_options_for(design["solver"], design), **sim_options(design))
        summary = res.summary.to_dict()
        row.update(summary_row(summary))
        row.update({k: summary.get(k) for k in extra})
        if physics:
            from bhr._studies.physics import replay_physics

            ps = replay_physics(res, **replay_options(physics, design)).summary()
            row.update({"peak_wall_force_n": ps["max_total_force_n"], "wall_stretch_mm": ps["max_stretch_mm"],
                        "physical_cecum_step": ps["reached_cecum_step"], "physically_traversed": ps["traversed"],
                        "poses_replayed": ps["poses_replayed"]})  # "steps": an idealisation (bhr physics says so)
    return row


def warm_designs(items: Sequence[tuple[Any, ...]]) -> None:
    """Run each of ``items`` (:func:`run_design`'s arguments: a design of each kind, solver x locomotion x head
    or whole robot) on the first 60 points of its trajectory, so that every kernel the study's runs use is
    compiled, or loaded, before the first run is timed (:func:`bhr._studies.executor.run_jobs` runs it first in
    the process that starts the workers: compiled there once, with its one line, and loaded from numba's cache by
    each worker)."""
    for design, source, base, *rest in items:
        run_design(design, source, base, rest[0] if rest else (), rest[1] if len(rest) > 1 else (), points=60)


def _blank_row(design: dict[str, Any], extra: Sequence[str] = (), status: str = "ok") -> dict[str, Any]:
    return {**design, **{k: None for k in (*METRICS, *extra)}, "status": status}


def _lost_design(item: tuple[Any, ...], why: str) -> dict[str, Any]:
    """The row of a design whose worker process died."""
    return _blank_row(item[0], item[3] if len(item) > 3 else (), f"failed: {why}")


def run_chunk(chunk: Sequence[tuple[Any, ...]]) -> list[tuple[int, dict[str, Any]]]:
    """Run ``(index, design, trajectory source[, base robot fields[, extra keys]])`` items; return ``(index, row)``.

    Kept for callers of earlier versions; :func:`run_sweep` hands single designs to :mod:`bhr._studies.executor`.
    """
    return [(item[0], run_design(*item[1:])) for item in chunk]


def _design_job(item: tuple[Any, ...]) -> dict[str, Any]:
    """One design: ``(design, trajectory source, base robot fields[, extra keys])``, the job of every path."""
    return run_design(*item)


@dataclass
class SweepResult:
    sweep: Sweep
    rows: list[dict[str, Any]]
    wall_time_s: float
    runner: str  # "in-process", "N processes" or "dask tcp://..."
    workers: int

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r["status"] != "ok"]

    @property
    def columns(self) -> list[str]:
        return ["design", *self.sweep.keys, *METRICS, *self.sweep.extra]


def run_sweep(sweep: Sweep, *, jobs: int | None = None, scheduler: Any = None,
              progress: Callable[[int, int], None] | None = None) -> SweepResult:
    """Run every design of ``sweep``; rows come back in design order whatever ran them.

    ``jobs``: worker processes (default: the number of CPUs; 1 runs in this
    process). ``scheduler``: address of a Dask distributed scheduler to run
    on instead, or a ``distributed.Client`` (see :func:`connect_scheduler`).
    ``progress(done, total)`` is called as designs finish.
    """
    base = dict(sweep.robot) or None
    tail: tuple[Any, ...] = (sweep.extra, sweep.physics) if sweep.physics else ((sweep.extra,) if sweep.extra else ())
    items = [(d, sweep.traj_sources.get(d["traj"], d["traj"]), base, *tail) for d in sweep.designs()]
    first: dict[tuple[Any, ...], tuple[Any, ...]] = {}  # the warm-up's: a design of each kind of run
    for item in items:
        d = item[0]
        first.setdefault((d["solver"], d.get("locomotion"), bool(d.get("body_modules") or d.get("reach"))), item)
    done = run_jobs(_design_job, items, jobs=jobs, scheduler=scheduler, warm_up=warm_designs,
                    warm_up_args=(tuple(first.values()),), lost=_lost_design,
                    progress=None if progress is None else (lambda d, t, _row: progress(d, t)))
    final = [{"design": i + 1, **r} for i, r in enumerate(done.rows)]
    return SweepResult(sweep, final, done.wall_time_s, done.runner, done.workers)
