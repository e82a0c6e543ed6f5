"""A run's figures written into its folder: the error figures, the path, the body's errors and the clearance."""
from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult
from bhr.output._clearance_plot import clearance_figure
from bhr.output._error_plot import ERROR_KINDS, error_data, error_grid_shape, ErrorGrid, body_figure
from bhr.output._figure import RUN_PNG_COMPRESS, save_figure
from bhr.output._path_plot import path_figure

__all__ = ["run_plot_names", "save_run_plots"]


def run_plot_names(result: "FollowResult", step: int | None = None) -> list[str]:
    """The names of the files :func:`save_run_plots` writes for ``result``, in its order."""
    names = [name for name, _, _ in ERROR_KINDS.values()]
    names.append("path.png" if step is None else f"path-step{step}.png")
    if result.body is not None and result.body.modules:
        names.append("body_errors.png")
    if result.clearance is not None:
        names.append("clearance.png")
    return names


def save_run_plots(result: "FollowResult", out_dir: str | os.PathLike[str], step: int | None = None) -> list[Path]:
    """Write a run's figures into ``out_dir``, as ``bhr follow`` does.

    The three error figures, the path view (``path.png``, or with the robot at 1-based ``step``,
    ``path-stepK.png``) and, where the run has them, the body's errors and the lumen clearance.

    Parameters
    ----------
    result : FollowResult
        A run, as :func:`bhr.follow` returns it.
    out_dir : str or os.PathLike
        An existing folder to write the PNGs into.
    step : int, optional
        The 1-based step whose pose the path view shows (``path-stepK.png``); default the last (``path.png``).

    Returns
    -------
    list of pathlib.Path
        The files written: ``position_errors.png``, ``orientation_errors.png``, ``global_errors.png``, the
        path view, then ``body_errors.png`` and ``clearance.png`` where the run has them.
    """
    out = Path(out_dir)
    files = []
    grids: dict[tuple[int, int], ErrorGrid] = {}  # the three error figures share one grid where their panels fit
    for kind, (name, _, _) in ERROR_KINDS.items():
        shape = error_grid_shape(error_data(result, kind).shape[1])
        if shape not in grids:
            grids[shape] = ErrorGrid(result, *shape)
        files.append(save_figure(grids[shape].fill(kind), out / name, compress=RUN_PNG_COMPRESS))
    path_name = "path.png" if step is None else f"path-step{step}.png"
    files.append(save_figure(path_figure(result, None if step is None else step - 1), out / path_name,
                             compress=RUN_PNG_COMPRESS))
    if result.body is not None and result.body.modules:
        files.append(save_figure(body_figure(result), out / "body_errors.png", compress=RUN_PNG_COMPRESS))
    if result.clearance is not None:
        files.append(save_figure(clearance_figure(result), out / "clearance.png",
                                 compress=RUN_PNG_COMPRESS))
    return files
