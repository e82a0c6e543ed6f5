"""bhr export: the robot as a URDF or MJCF model (pinocchio, RViz, MuJoCo)."""
from __future__ import annotations

import click

from bhr.cli._common import check_writable, guarded
from bhr.cli._options import build_robot, model_modules_option, robot_options


@click.command()
@click.option("--format", "fmt", required=True, metavar="urdf|mjcf",
              help="urdf (pinocchio, RViz, ROS) or mjcf (MuJoCo).")
@click.option("--out", "out", required=True, metavar="FILE", help="File to write (- for standard output).")
@robot_options(feed=False, solving=False)
@model_modules_option
@guarded
def export(fmt, out, **kwargs):
    """Write the robot as a URDF or MJCF model: per module two revolute tilts (+-alpha) and a prismatic lift.

    The model has --body-modules modules when given (the whole robot), else --modules. Joint names,
    units and masses: docs/export.md. Example:

    \b
        bhr export --format urdf --modules 60 --out bhr-out/bhr60.urdf
    """
    from bhr.output._atomic import write_text
    from bhr._settings.errors import BhrError
    from bhr.model._export import FORMATS, export_text

    fmt = fmt.lower()
    if fmt not in FORMATS:
        raise BhrError(f"--format {fmt!r} is not a format bhr writes; give --format urdf or --format mjcf")
    check_writable(out, "model")
    path = kwargs.get("robot_file")
    mass: dict = {}
    if path is not None:
        from bhr.model._robotfile import load_robot_file

        mass = load_robot_file(path).mass
    body = kwargs.pop("body_modules", None)
    robot = build_robot(kwargs)
    modules = robot.modules
    if body is not None:
        from bhr._run.body import check_body_modules

        modules = check_body_modules(body, robot.modules, "--body-modules")
    text = export_text(fmt, robot, modules, mass_g=mass.get("module_mass"), density=mass.get("density"))
    if out == "-":
        click.echo(text, nl=False)
        return
    write_text(out, text)
    click.echo(f"{fmt.upper()}: {modules} modules, {3 * modules} joints -> {out}")
