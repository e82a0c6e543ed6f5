"""bhr sweep: a grid of robot designs over trajectories, in local processes or on a Dask cluster."""
from __future__ import annotations

from pathlib import Path

import click

from bhr.cli._common import check_executor, guarded
from bhr.cli._options import study_options


@click.command()
@click.option("--file", "sweep_file", default=None, metavar="FILE.toml",
              help="Sweep file: traj, solver and a [grid] table (see docs/sweep.md); options given here override it.")
@click.option("--traj", "trajs", multiple=True, metavar="NAME|PATH",
              help="Trajectory to follow (repeat for several) [curve].")
@click.option("--solver", "solvers", multiple=True, metavar="NAME", help="Solver (repeat for several) [thesis].")
@click.option("--grid", "-g", "grid", multiple=True, metavar="KEY=VALUES",
              help="Values of a robot or trajectory option: modules=4,5,6 or alpha=8:12 or module_length=8:12:0.5 "
                   "(START:STOP[:STEP], STOP included) or modules=3-5,8 (FIRST-LAST, as --colons takes). "
                   "Repeat for each key.")
@study_options("./bhr-out/<sweep file or sweep>-<hash of the settings>/")
@click.option("--x", "hx", default=None, metavar="KEY", help="Heat-map columns [the axis with the most values].")
@click.option("--y", "hy", default=None, metavar="KEY", help="Heat-map rows [the axis with the next most values].")
@click.option("--no-plots", "no_plot", is_flag=True, help="Skip heatmap.png.")
@click.option("--no-plot", "no_plot_old", is_flag=True, hidden=True)  # the old spelling
@click.option("--title", default=None, help="Title of the heat-map and page.")
@guarded
def sweep(sweep_file, trajs, solvers, grid, robot_file, out_dir, force, jobs, scheduler, hx, hy, no_plot, no_plot_old,
          title):
    """Follow trajectories with every design of a parameter grid.

    Writes DIR/results.csv and DIR/results.json (one row per design and
    trajectory: its parameters, status, worst errors and minimum clearance
    where known),
    DIR/heatmap.png (worst point error and minimum clearance per design over
    two axes, the worst case over the others) and DIR/index.html. The exit
    status is 1 when any design failed.

    \b
        bhr sweep --traj curve --grid modules=3:12 --grid alpha=6:15 --grid module_length=8,10,12
    """
    from bhr.cli._progress import announce_compiles, status

    no_plot = no_plot or no_plot_old
    from bhr.solvers import check_solver_name

    # a misspelt solver is refused before the studies' modules (numpy, numba) load; an alias is shown by its name
    solvers = tuple(check_solver_name(name, "sweep") for name in solvers)
    from bhr._studies.sweep import (build_sweep, format_summary, heatmap_axes, load_sweep, parse_grid_option,
                                    run_sweep, write_outputs)

    check_executor(jobs, scheduler)
    cli_grid = [parse_grid_option(g) for g in grid]
    if sweep_file:
        from bhr.model._generators import builtin_names

        base = load_sweep(sweep_file)
        merged = dict(base.grid)
        merged.update(dict(cli_grid))
        # trajectory files named here are relative to the current folder, the file's to its folder
        given = tuple(t if t in builtin_names() else str(Path(t).resolve()) for t in trajs)
        s = build_sweep(given or base.trajs, solvers or base.solvers, tuple(merged.items()),
                        title=title or base.title, description=base.description,
                        base_dir=Path(sweep_file).parent, where=str(sweep_file),
                        robot_file=robot_file or base.robot_file)
    else:
        s = build_sweep(trajs or ("curve",), solvers or ("thesis",), cli_grid, title=title or "bhr sweep",
                        robot_file=robot_file)
    heatmap_axes(s, hx, hy)  # refuse unknown heat-map axes before running
    import dataclasses

    from bhr.cli._common import default_output, input_files, print_study

    inputs = input_files(sweep_file, robot_file, s.robot_file, *s.traj_sources.values())
    folder = default_output("sweep", Path(sweep_file).stem if sweep_file else "sweep",
                            (dataclasses.asdict(s), hx, hy), inputs, out_dir,
                            what="sweep output folder", force=force)  # before any work
    out = folder.final("")
    total = len(s)
    from bhr._studies.cluster import scheduler_client

    where = f"on {scheduler}" if scheduler else ""
    with scheduler_client(scheduler) as client:  # fails in one line before anything starts
        announce_compiles()
        with status(f"Running {total} designs {where}".rstrip(), total=total, log=True) as bar:
            result = run_sweep(s, jobs=jobs, scheduler=client, progress=bar.set)
    with status(f"writing {out}"), folder:
        files = [folder.final(p.name) for p in write_outputs(result, folder.stage, plot=not no_plot, x=hx, y=hy)]
    return print_study(folder, out_dir, format_summary(result), files, len(result.failed), total, "designs",
                       "results.csv")


#: What bhr sweep writes into its folder (an existing folder holding only such files may be replaced).
