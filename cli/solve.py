"""bhr solve: one target, from a straight chain along +Y (thesis chapter 5)."""
from __future__ import annotations

import json

import click

from bhr.cli._common import check_writable, guarded
from bhr.cli._options import MM, build_robot, constraint_options, pop_constraints, robot_options


def _fmt(v: float | None, digits: int = 5) -> str:
    return "-" if v is None else f"{v:.{digits}f}"


def _status_text(result, robot) -> str:
    """``reached``, ``not reached (...)`` or ``out of reach (...)``, with the numbers that decide it."""
    tol = f"tolerance {robot.tol_pos:g}" + (f" and {robot.tol_ori:g} deg" if result.orientation_error_deg is not None
                                            else "")
    if result.status == "reached":
        return f"reached (within {tol})"
    if result.status == "out of reach":
        return f"out of reach: {result.reason} (the chain stretches toward it)"
    return f"not reached: {result.reason}"


def plot_title(solver: str, target, result) -> str:
    """The figure's title: the solver, the target and the verdict of the table's ``status`` row."""
    its = f"{result.iterations} iteration" + ("" if result.iterations == 1 else "s")
    return (f"{solver}: target ({', '.join(f'{v:g}' for v in target)}), {result.status or 'not judged'}, "
            f"{result.position_error_mm:.3g} mm off, {its}")


@click.command()
@click.option("--target", nargs=3, type=MM, required=True, metavar="X Y Z", help="Target point.")
@click.option("--orientation", nargs=3, type=MM, default=None, metavar="X Y Z",
              help="Wanted direction of the last module (any length).")
@click.option("--solver", default="fabrik", show_default=True,
              help="fabrik, ccd, thesis (the thesis's binary solver), constrained, optimal, lumen (keeps off a lumen's "
                   "wall; along a straight chain it solves as thesis).")
@robot_options(feed=False)
@constraint_options
@click.option("--json", "json_path", default=None, metavar="PATH|-", help="Write the result as JSON ('-': stdout).")
@click.option("--plot", "plot_path", default=None, metavar="PATH", help="Draw the initial and final chain (PNG).")
@guarded
def solve(target, orientation, solver, json_path, plot_path, **kwargs):
    """Solve one target from a straight chain along +Y starting at the origin.

    Defaults are the thesis's chapter 5 experiments: 5 modules of 2, position
    tolerance 0.01, 30 iterations. Example (Table 5.1):

        bhr solve --modules 5 --module-length 2 --target 3 9 0 --solver ccd
    """
    from bhr.cli._progress import announce_compiles
    from bhr.model._robot import CHAPTER5_ROBOT
    from bhr.solvers import canonical, check_solver_name, solve as run

    check_solver_name(solver)  # before numba or a solver module loads (bhr.solvers._names)

    check_writable(json_path, "JSON")
    check_writable(plot_path, "plot")
    if plot_path is not None:
        from bhr.output._figure import check_figure_path

        check_figure_path(plot_path)
    chapter5 = {k: getattr(CHAPTER5_ROBOT, k) for k in ("modules", "module_length", "tol_pos", "max_iter")}
    robot = build_robot(kwargs, **chapter5)  # bhr.solve's defaults
    constraints = pop_constraints(kwargs)
    announce_compiles()  # imports numba: the input is checked
    result = run(target, tip_direction=orientation, solver=solver, robot=robot, solver_options=constraints)
    doc = result.to_dict()
    solver = canonical(solver)  # tables name a solver one way (seed: thesis)
    if json_path == "-":
        click.echo(json.dumps(doc, indent=1))
    else:
        rows = [
            ("solver", solver),
            ("modules", f"{robot.modules} x {robot.module_length:g}"),
            ("target", " ".join(f"{v:g}" for v in target)),
            ("status", _status_text(result, robot)),
            ("iterations", str(result.iterations)),
            ("position error", _fmt(result.position_error_mm)),
            ("orientation error (deg)", _fmt(result.orientation_error_deg, 4)),
            ("codes", "-" if result.codes is None else " ".join(str(c) for c in result.codes)),
        ]
        width = max(len(k) for k, _ in rows)
        for k, v in rows:
            click.echo(f"{k:<{width}}  {v}")
        click.echo(f"{'point':>5} {'x':>10} {'y':>10} {'z':>10}")
        for j, p in enumerate(result.points, start=1):
            click.echo(f"{j:>5} {p[0]:>10.5f} {p[1]:>10.5f} {p[2]:>10.5f}")
    from bhr.output._atomic import together

    with together():  # the JSON and the figure: both or neither
        _write_outputs(json_path, plot_path, doc, robot, solver, target, result)


def _write_outputs(json_path, plot_path, doc, robot, solver, target, result) -> None:
    if json_path not in (None, "-"):
        from bhr.output._atomic import write_json

        write_json(json_path, doc)
    if plot_path:
        from bhr.output._figure import save_figure
        from bhr.output._path_plot import chain_figure
        from bhr.solvers import Chain

        initial = Chain.straight(robot, (0, 1, 0)).points
        save_figure(chain_figure(initial, result.points, target, None, plot_title(solver, target, result)), plot_path)
