"""Design sweeps: follow trajectories with a grid of robot designs, in parallel or on a Dask cluster.

A sweep is the product of its trajectories, its solvers and a grid of
parameter values: any trajectory or robot option by its command-line long
name with underscores (``modules``, ``module_length``, ``alpha``,
``feed_divisor``, ``radius``, ``angle``, ...), the same keys as a batch file
(:mod:`bhr._studies.report`). Every design is one ``bhr follow`` run without figures;
the result is one row per design with its worst errors and, where the
trajectory has a lumen, its minimum clearance.

:func:`run_sweep` runs the designs through the studies' executor
(:mod:`bhr._studies.executor`): in this process (``jobs=1``), in a pool of worker
processes (``jobs>1``; the workers load the compiled kernels from numba's
on-disk cache once each), or on an existing Dask distributed cluster
(``scheduler="tcp://host:port"``); every path runs the same
:func:`run_design` on the same designs, so the rows are the same.

Neither matplotlib nor Dask is imported until a heat-map is drawn or a
scheduler is given.

The package by job: :mod:`.grid` (the grid, read and checked), :mod:`.runs` (running the designs),
:mod:`.ranking` (the rows ranked, the terminal's summary), :mod:`.heatmap` (the heat-map's data; drawn by
:mod:`bhr.output._sweep_plot`) and :mod:`.pages` (the output set).
"""
from __future__ import annotations

from bhr._settings.names import AXIS_NAMES, COLUMN_TITLES, axis_label, axis_value, column_title
from bhr._studies.cluster import connect_scheduler, dask_missing
from bhr._studies.study import make_robot
from bhr._studies.sweep.grid import (GRID_KEYS, Sweep, build_sweep, colon_source, load_sweep, parse_grid_option,
                                    parse_values, sweep_from_toml)
from bhr._studies.sweep.heatmap import heatmap_axes, heatmap_cells, heatmap_figure, heatmap_panels
from bhr._studies.sweep.pages import write_outputs
from bhr._studies.sweep.ranking import best_designs, best_rows, format_summary, results_csv, what_ran
from bhr._studies.sweep.runs import METRICS, PHYSICS_KEYS, SweepResult, run_chunk, run_design, run_sweep

__all__ = ["Sweep", "SweepResult", "GRID_KEYS", "parse_grid_option", "parse_values", "sweep_from_toml",
           "load_sweep", "build_sweep", "colon_source", "run_design", "run_chunk", "run_sweep", "METRICS",
           "PHYSICS_KEYS", "heatmap_axes", "heatmap_cells", "heatmap_panels", "heatmap_figure", "results_csv",
           "best_rows", "best_designs", "what_ran", "format_summary", "write_outputs", "dask_missing",
           "connect_scheduler", "make_robot", "axis_label", "axis_value", "column_title", "AXIS_NAMES",
           "COLUMN_TITLES"]
