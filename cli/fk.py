"""bhr fk: forward kinematics from module codes."""
from __future__ import annotations

import json

import click

from bhr.cli._common import check_writable, guarded
from bhr.cli._options import build_robot, robot_options


@click.command()
@click.option("--codes", "codes", required=True, metavar="C1,C2,...",
              help="One code per module, base first, comma-separated (0, 3, 6, 9, 12 or 15).")
@robot_options(feed=False, solving=False)
@click.option("--json", "json_path", default=None, metavar="PATH|-", help="Write points and frames as JSON.")
@click.option("--plot", "plot_path", default=None, metavar="PATH",
              help="Draw the pose (.png, .svg or .pdf): each module as a cylinder of the robot's radius.")
@guarded
def fk(codes, json_path, plot_path, **kwargs):
    """Points of the chain for a list of codes (robot straight along +X from the origin).

    Example: bhr fk --codes 3,0,6,0,0 --plot bhr-out/pose.png
    """
    from bhr.output._atomic import write_json
    from bhr.cli._progress import announce_compiles
    from bhr.model._codes import check_codes
    from bhr._settings.errors import BhrError
    from bhr.model._robot import forward_kinematics

    check_writable(json_path, "JSON")
    check_writable(plot_path, "plot")
    if plot_path is not None:
        from bhr.output._workspace_plot import check_path

        check_path(plot_path)
    values = [c.strip() for c in codes.split(",")] if "," in codes else codes.split()
    if not any(values):
        raise BhrError("--codes needs at least one code, e.g. --codes 3,0,6")
    if "" in values:  # 0,,3: a module left out, not two modules
        raise BhrError(f"--codes: code {values.index('') + 1} is empty; give one code per module, e.g. --codes 3,0,6")
    checked = check_codes(values)
    if kwargs.get("modules") is None and kwargs.get("robot_file") is None:
        kwargs["modules"] = len(checked)
    robot = build_robot(kwargs)
    announce_compiles()
    points, frames = forward_kinematics(robot, checked)
    doc = {"codes": checked, "points": points.tolist(), "frames": frames.tolist()}
    if plot_path:
        from bhr.output._workspace_plot import plot_pose

        plot_pose(robot, checked, plot_path)
    if json_path == "-":
        click.echo(json.dumps(doc, indent=1))
        return
    if json_path:
        write_json(json_path, doc)
    click.echo(f"{'point':>5} {'x':>10} {'y':>10} {'z':>10}")
    for j, p in enumerate(points, start=1):
        click.echo(f"{j:>5} {p[0]:>10.4f} {p[1]:>10.4f} {p[2]:>10.4f}")
