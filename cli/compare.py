"""bhr compare: run one trajectory with several solvers; print and plot their errors side by side."""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import click

from bhr.model._trajnames import traj_help
from bhr.cli._common import (check_parent_folder, check_writable, guarded, input_files, json_in_folder,
                             run_folder_name)
from bhr.cli._options import (build_robot, force_option, lumen_options, optimal_options, pop_solver_options,
                              pop_trajectory, robot_options, run_options, trajectory_options)


@click.command()
@click.option("--traj", default=None, metavar="NAME|PATH",
              help=traj_help() + " Required.")
@trajectory_options
@click.option("--solver", "solvers", multiple=True, metavar="NAME",
              help="A solver to run; give it once per solver, the first is the reference [thesis, optimal].")
@robot_options(feed=True)
@optimal_options
@lumen_options
@run_options
@click.option("--out", "out_dir", default=None, metavar="DIR",
              help="Output folder, replaced whole by this run [./bhr-out/compare-<traj>-<hash>/].")
@force_option
@click.option("--json", "json_path", default=None, metavar="PATH|-",
              help="Also write the comparison as JSON ('-': stdout).")
@click.option("--no-plots", is_flag=True, help="Skip the figure.")
@guarded
def compare(traj, solvers, out_dir, json_path, no_plots, force, **kwargs):
    """Run one trajectory with several solvers and compare their errors.

    Prints, per solver, the worst position error over all scored points
    (and its ratio to the first solver's), the tip errors, the lumen
    clearance when the trajectory has a lumen, and the time per step; writes
    DIR/compare.png with every run's errors on the same axes. The
    --lookahead ... --roll-weight options apply to the optimal solver.

        bhr compare --traj curve --angle 360 --solver thesis --solver optimal
    """
    from bhr.output._atomic import write_json
    from bhr._run.body import check_body_modules
    from bhr.cli._progress import announce_compiles, status
    from bhr._studies.compare import compare_json, compare_runs, format_table, write_compare
    from bhr._settings.errors import BhrError
    from bhr._run.driver import BhrWarning
    from bhr.model._generators import load_trajectory

    from bhr.solvers import check_solver_name

    names = list(solvers) or ["thesis", "optimal"]
    for name in names:
        check_solver_name(name)
    robot_file = kwargs.get("robot_file")
    robot = build_robot(kwargs)
    if traj is None:
        raise BhrError("give the trajectory to compare on: --traj line|curve|spiral|colon|FILE")
    from bhr.output._atomic import OutputFolder

    folder = None
    # as bhr follow: every solver's run is kept in a folder, unless stdout is the whole output (--json - --no-plots)
    use_folder = out_dir is not None or not (json_path == "-" and no_plots)
    if out_dir is not None:
        folder = OutputFolder(out_dir, "compare",  # checked before any work
                              inputs=input_files(traj, kwargs.get("robot_file")), force=force).check()
    elif use_folder:
        check_parent_folder("bhr-out")
    check_writable(json_path, "JSON")
    per_solver = pop_solver_options(kwargs, names)
    body_modules = kwargs.pop("body_modules")
    if body_modules is not None:
        check_body_modules(body_modules, robot.modules, "--body-modules")
    stop_at_wall = bool(kwargs.pop("stop_at_wall", None))
    if (kwargs.pop("reach", None) is not None or (kwargs.pop("locomotion", None) or "thesis") != "thesis"
            or kwargs.pop("all_poses", None)):
        raise BhrError("bhr compare runs the thesis's locomotion; use bhr follow (or bhr traverse) for --reach, "
                       "--locomotion and --all-poses")
    announce_compiles()
    traj_params = pop_trajectory(kwargs)
    tr = load_trajectory(traj, feed=robot.feed, **traj_params)
    from bhr._studies.follow_run import folder_stem, trajectory_parts

    stem = folder_stem(traj, traj_params.get("seed"))  # as follow's: one folder name per anatomical colon
    if folder is None and use_folder:
        name = run_folder_name(f"compare-{stem}", *trajectory_parts(tr), robot.to_dict(), names, per_solver,
                               body_modules, *(("stop_at_wall",) if stop_at_wall else ()))
        folder = OutputFolder(Path("bhr-out") / name, "compare", inputs=input_files(traj, robot_file),
                              force=force).check()
    if folder is not None:  # what makes the results (docs/commands.md#output-folders)
        folder.settings = run_folder_name("", *trajectory_parts(tr), robot.to_dict(), names, per_solver,
                                          body_modules, *(("stop_at_wall",) if stop_at_wall else ())
                                          ).rsplit("-", 1)[1]
    json_inside = json_in_folder(json_path, folder, COMPARE_NAMES) if folder is not None else None
    with warnings.catch_warnings(record=True) as caught, \
            status(f"following {tr.name} ({len(tr.points)} steps) with {', '.join(names)}"):
        warnings.simplefilter("always", BhrWarning)
        runs = compare_runs(tr, names, robot, solver_options=per_solver, body_modules=body_modules,
                            stop_at_wall=stop_at_wall)
    for w in {str(w.message) for w in caught if issubclass(w.category, BhrWarning)}:
        click.echo(f"Warning: {w}", err=True)
    stream = json_path == "-"
    written = []
    if folder is not None:
        with folder:
            written += write_compare(runs, folder, json_name=json_inside, plot=not no_plots, progress=status)
            if json_path and json_path != "-" and json_inside is None:
                write_json(Path(json_path), compare_json(runs))  # before the folder goes in place
                written.append(Path(json_path))
        if out_dir is None:
            from bhr.output._atomic import point_latest

            point_latest(folder.target)  # bhr-out/latest: the run just written
    if json_path == "-":
        click.echo(json.dumps(compare_json(runs), allow_nan=False))
    elif json_path and json_inside is None and folder is None:
        write_json(Path(json_path), compare_json(runs))
        written.append(Path(json_path))
    for line in format_table(runs):
        click.echo(line, err=stream)
    if written:
        click.echo("Wrote " + ", ".join(str(p) for p in written), err=stream)


#: What bhr compare writes into its folder.
COMPARE_NAMES = ("compare.png", "manifest.json")
