"""Options shared by the commands that simulate: robot, solver constraints, trajectory."""
from __future__ import annotations

from typing import Any, Callable

import click

ROBOT_FIELDS = {
    "modules": "modules",
    "module_length": "module_length",
    "robot_radius": "radius",
    "alpha": "alpha",
    "stroke": "stroke",
    "lever": "lever",
    "tol_pos": "tol_pos",
    "tol_ori": "tol_ori",
    "max_iter": "max_iter",
    "feed_divisor": "feed_divisor",
    "weight_pos": "weight_pos",
    "weight_ori": "weight_ori",
}
TRAJ_FIELDS = ("length", "azimuth", "elevation", "radius", "angle", "entry", "exit", "pitch", "turns")
CONSTRAINT_FIELDS = ("limit", "axes", "warmup")


def _stack(*decorators: Callable[[Any], Any]) -> Callable[[Any], Any]:
    def apply(f: Any) -> Any:
        for d in reversed(decorators):
            f = d(f)
        return f

    return apply


def robot_options(feed: bool = True) -> Callable[[Any], Any]:
    """--modules, --module-length, --robot-radius, --alpha (or --stroke/--lever), tolerances..."""
    opts = [
        click.option("--robot", "robot_file", default=None, metavar="FILE",
                     help="Robot description (TOML); options given here override its values."),
        click.option("--modules", type=int, default=None, help="Number of modules the solver moves."),
        click.option("--module-length", type=float, default=None, help="Length of one module (mm)."),
        click.option("--robot-radius", type=float, default=None, help="Robot (disc) radius in mm [5]."),
        click.option("--alpha", type=float, default=None, help="Tilt angle of one actuator pair (deg) [10]."),
        click.option("--stroke", type=float, default=None, help="Actuator stroke h (mm); with --lever gives alpha = asin(h/L)."),
        click.option("--lever", type=float, default=None, help="Actuator lever L (mm); see --stroke."),
        click.option("--tol-pos", type=float, default=None, help="Position tolerance (mm)."),
        click.option("--tol-ori", type=float, default=None, help="Orientation tolerance (deg) [20]."),
        click.option("--max-iter", type=int, default=None, help="Iteration limit per solve [30]."),
        click.option("--weight-pos", type=float, default=None, help="Weight of position in the global error [0.7]."),
        click.option("--weight-ori", type=float, default=None, help="Weight of orientation in the global error [0.3]."),
    ]
    if feed:
        opts.append(click.option("--feed-divisor", type=int, default=None,
                                 help="Feed = module length / this [5]; trajectory points are spaced by the feed."))
    return _stack(*opts)


def constraint_options(f: Any) -> Any:
    """--limit, --axes, --warmup for the constrained solvers (thesis ch. 6 steps)."""
    return _stack(
        click.option("--limit", type=click.Choice(["binary", "continuous", "none"]), default=None,
                     help="Rotation limit of the constrained solvers [binary]."),
        click.option("--axes", type=click.Choice(["local", "free"]), default=None,
                     help="Tilt axes: the module's two local axes, or free [local]."),
        click.option("--warmup", type=int, default=None,
                     help="Unconstrained warm-up iterations of the constrained solvers [10]."),
    )(f)


def trajectory_options(f: Any) -> Any:
    return _stack(
        click.option("--length", type=float, default=None, help="line: length (mm) [70]."),
        click.option("--azimuth", type=float, default=None, help="line: angle to +x in the xy-plane (deg) [0]."),
        click.option("--elevation", type=float, default=None, help="line: angle above the xy-plane (deg) [0]."),
        click.option("--radius", type=float, default=None, help="curve/spiral: radius (mm) [70 / 80]."),
        click.option("--angle", type=float, default=None, help="curve: angle turned (deg) [90]."),
        click.option("--entry", type=float, default=None, help="curve: entry straight (mm) [30]."),
        click.option("--exit", "exit_", type=float, default=None, help="curve: exit straight (mm) [30]."),
        click.option("--pitch", type=float, default=None, help="spiral: rise per turn (mm) [40]."),
        click.option("--turns", type=float, default=None, help="spiral: number of turns [2]."),
    )(f)


def pop_robot(kwargs: dict[str, Any]) -> dict[str, Any]:
    """Remove the robot options from ``kwargs``; return the given ones as Robot fields."""
    out = {}
    for opt, fld in ROBOT_FIELDS.items():
        v = kwargs.pop(opt, None)
        if v is not None:
            out[fld] = v
    return out


def build_robot(kwargs: dict[str, Any], **defaults: Any):
    """The Robot for a command: ``defaults``, then the --robot file, then the options given.

    Removes the robot options (and --robot) from ``kwargs``.
    """
    from bhr.robot import Robot

    path = kwargs.pop("robot_file", None)
    given = pop_robot(kwargs)
    if path is not None:
        from bhr.robotfile import load_robot_file

        base = load_robot_file(path).robot
        return base.replace(**given) if given else base
    return Robot(**{**defaults, **given})


def pop_constraints(kwargs: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for k in CONSTRAINT_FIELDS:
        v = kwargs.pop(k, None)
        if v is not None:
            out[k] = v
    return out


def pop_trajectory(kwargs: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for k in TRAJ_FIELDS:
        key = "exit_" if k == "exit" else k
        v = kwargs.pop(key, None)
        if v is not None:
            out[k] = v
    return out
