"""bhr traverse: which robot designs get through a population of anatomical colons."""
from __future__ import annotations


import click

from bhr.cli._common import check_executor, guarded
from bhr.cli._options import Share, max_wall_force_option, study_options

OUTPUTS = ("designs.csv", "runs.csv", "study.json", "passrate.png", "worst-colon.png", "index.html")


@click.command()
@click.option("--grid", "-g", "grid", multiple=True, metavar="KEY=VALUES",
              help="Values of a robot or solver option: alpha=10:30:5, module_length=5,6,8, modules=5:8 "
                   "(START:STOP[:STEP], STOP included) or alpha=20-25,30 (FIRST-LAST, as --colons takes). "
                   "Repeat for each key.")
@click.option("--colons", default="1-100", show_default=True, metavar="COLONS",
              help="The colons every design must get through: generated colons' seeds such as 1-100 (or 1:100, as "
                   "in a grid) or 1,4,10-20; real for every shipped real colon, or real colons by name (gca:VHM); "
                   "or a mix: real,1-100.")
@click.option("--solver", "solvers", multiple=True, metavar="NAME",
              help="Solver (repeat for several) [lumen; thesis with --head-only].")
@click.option("--head-only", is_flag=True,
              help="Judge the head alone (the modules the solver moves, no body behind them; solver thesis unless "
                   "--solver): the earlier study, labelled 'head only'. Without it every design is the whole robot "
                   "reaching the cecum (--grid reach=cecum), moved by its wires with --solver lumen, unless the grid "
                   "gives body_modules or reach.")
@click.option("--target-pass", type=Share(), default=0.95, show_default=True, metavar="SHARE",
              help="Share of colons a design must traverse without touching the wall.")
@study_options("./bhr-out/traverse-<hash of the settings>/")
@click.option("--x", "hx", default=None, metavar="KEY", help="Heat-map columns [the design axis with the most values].")
@click.option("--y", "hy", default=None, metavar="KEY", help="Heat-map rows [the next one].")
@click.option("--no-plots", "no_plot", is_flag=True, help="Skip the figures (passrate.png, worst-colon.png).")
@click.option("--title", default=None, help="Title of the heat-map and page.")
@max_wall_force_option
@click.option("--physics", is_flag=True, help="Replay the answer's worst colon as the physical robot against the wall "
              "(worst-colon-physics.json, worst-colon-force.png; docs/physics.md).")
@guarded
def traverse(grid, colons, solvers, head_only, target_pass, robot_file, out_dir, force, jobs, scheduler, hx, hy,
             no_plot, title, max_wall_force, physics):
    """Follow a population of anatomical colons with every design of a grid.

    The robot judged is the whole robot, long enough to reach the cecum and moved by its wires (the robot
    as it can be built, --solver lumen), unless --head-only or the grid sizes it (body_modules, reach).
    A colon is traversed when the robot touches its wall at no step (with --max-wall-force: when the physical
    robot, replayed against the wall, reaches the cecum with the wall's load never above N). Each run of the
    whole robot ends where it leaves the lumen (--grid stop_at_wall=false: runs to the end), and designs that
    traverse as many colons are ranked by how far along the colons they get inside the lumen (reach). Prints,
    per design, the share of colons traversed, the reach, the worst and median
    penetration into the wall and the contact length, then the best design
    that traverses at least --target-pass of the colons. Writes into DIR
    designs.csv (one row per design), runs.csv (one row per design and
    colon), study.json, passrate.png (pass rate over two design axes),
    worst-colon.png (penetration along the answer's worst colon) and
    index.html. The exit status is 1 when any run failed.

    \b
        bhr traverse --grid alpha=20,25,30 --colons 1-20 --jobs 2
        bhr traverse --head-only --grid alpha=10:30:5 --grid module_length=5,6,8,10 --colons 1-100
    """
    from bhr.solvers import check_solver_name

    # a misspelt solver is refused before the studies' modules (numpy, numba) load; an alias is shown by its name
    solvers = tuple(check_solver_name(name, "traverse") for name in solvers)
    from bhr._settings.errors import BhrError
    from bhr._studies.sweep import parse_grid_option
    from bhr._studies.traverse import (build_study, format_study, heatmap_axes, robot_axes, run_study,
                                      write_study)

    check_executor(jobs, scheduler)
    # the physical replay of every run (--max-wall-force) needs each run whole, past its first wall touch
    axes, solvers, stop = robot_axes([parse_grid_option(g) for g in grid], solvers, head_only,
                                     stop_at_wall=max_wall_force is None)
    study = build_study(axes, colons, solvers=solvers,
                        target=target_pass, robot_file=robot_file, title=title or "bhr traverse",
                        max_wall_force=max_wall_force, stop_at_wall=stop)
    heatmap_axes(study, hx, hy)  # refuse unknown heat-map axes before running
    if physics:  # before the study: it ran whole, then --physics was refused, or silently skipped with --no-plots
        if no_plot:
            raise BhrError("--physics replays the worst colon beside its figures (worst-colon-force.png); drop "
                           "--no-plots or --physics")
    import dataclasses

    from bhr.cli._common import default_output, input_files, print_study

    folder = default_output("traverse", "traverse", (dataclasses.asdict(study), hx, hy),
                            input_files(robot_file), out_dir,
                            what="study output folder", force=force)  # before any work
    from bhr.cli._progress import status
    from bhr._studies.cluster import scheduler_client

    total = len(study)
    label = f"{total} runs ({study.designs} designs x {len(study.colons)} colons)" + (
        f" on {scheduler}" if scheduler else "")
    from bhr.cli._progress import announce_compiles

    announce_compiles()  # the input is checked: a first compile in this process says so
    with scheduler_client(scheduler) as client:  # fails in one line before anything starts
        with status(label, total, log=True) as bar:
            result = run_study(study, jobs=jobs, scheduler=client, progress=bar.set)
    with folder:
        files = write_study(result, folder, plot=not no_plot, x=hx, y=hy, physics=physics)
    return print_study(folder, out_dir, format_study(result), files, len(result.failed), total, "runs", "runs.csv")
