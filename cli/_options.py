"""Options shared by the commands that simulate: robot, solver constraints, trajectory."""
from __future__ import annotations

import math
from typing import Any, Callable

import click

from bhr._input import MAX_MM, ROBOT_LIMITS


def plain_number(text: str) -> bool:
    """True for numbers written with ASCII digits only and no '_' separators ("15", "-2.5e3", "nan").

    Python's int() and float() also take "1_5", full-width "１５" and Arabic-Indic digits; a robot
    command should not guess what those mean.
    """
    return text.isascii() and "_" not in text


class Bounded(click.ParamType):
    """A finite int or float no larger in size than ``limit``: one clear line for nan, inf or 1e300.

    Signs and lower bounds are left to the library (bhr.robot.Robot, the
    trajectory checks), whose messages name the allowed range.
    """

    def __init__(self, kind: type = float, limit: float = MAX_MM, unit: str = "") -> None:
        self.kind = kind
        self.limit = limit
        self.unit = unit
        self.name = "integer" if kind is int else "float"

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            v = value
        else:
            text = str(value).strip()
            try:
                if not plain_number(text):
                    raise ValueError(text)
                v = int(text) if self.kind is int else float(text)
            except ValueError:
                self.fail(f"{value!r} is not a valid {self.name}", param, ctx)
        u = f" {self.unit}" if self.unit else ""
        if not math.isfinite(v):
            self.fail(f"{value} is not a finite number", param, ctx)
        if abs(v) > self.limit:
            self.fail(f"{v:g} is too large; the limit is {self.limit:g}{u}", param, ctx)
        return self.kind(v)


class FiniteRange(click.FloatRange):
    """click.FloatRange that also refuses nan (nan passes every comparison click makes) and non-ASCII digits."""

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        if isinstance(value, str) and not plain_number(value.strip()):
            self.fail(f"{value!r} is not a valid float (write plain ASCII digits)", param, ctx)
        v = super().convert(value, param, ctx)
        if not math.isfinite(v):
            self.fail(f"{value} is not a finite number", param, ctx)
        return v


class PlainIntRange(click.IntRange):
    """click.IntRange that refuses "1_5" and non-ASCII digits."""

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        if isinstance(value, str) and not plain_number(value.strip()):
            self.fail(f"{value!r} is not a valid integer (write plain ASCII digits)", param, ctx)
        return super().convert(value, param, ctx)


def _lim(field: str, kind: type = float) -> Bounded:
    top, unit = ROBOT_LIMITS[field]
    return Bounded(kind, top, unit)


#: Slowest streaming rate accepted (Hz): one step every 100 s.
MIN_RATE = 0.01

#: Lengths and coordinates in mm (trajectory options, targets), and angles (ranges checked by the library).
MM = Bounded(float, MAX_MM, "mm")
DEG = Bounded(float, 1e6, "deg")

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
        click.option("--modules", type=_lim("modules", int), default=None, help="Number of modules the solver moves."),
        click.option("--module-length", type=_lim("module_length"), default=None, help="Length of one module (mm)."),
        click.option("--robot-radius", type=_lim("radius"), default=None, help="Robot (disc) radius in mm [5]."),
        click.option("--alpha", type=DEG,
                     help="Tilt angle of one actuator pair (deg) [10]."),
        click.option("--stroke", type=_lim("stroke"),
                     help="Actuator stroke h (mm); with --lever gives alpha = asin(h/L)."),
        click.option("--lever", type=_lim("lever"),
                     help="Actuator lever L (mm); see --stroke."),
        click.option("--tol-pos", type=_lim("tol_pos"),
                     help="Position tolerance (mm)."),
        click.option("--tol-ori", type=_lim("tol_ori"),
                     help="Orientation tolerance (deg) [20]."),
        click.option("--max-iter", type=_lim("max_iter", int),
                     help="Iteration limit per solve [30]."),
        click.option("--weight-pos", type=_lim("weight_pos"),
                     help="Weight of position in the global error [0.7]."),
        click.option("--weight-ori", type=_lim("weight_ori"),
                     help="Weight of orientation in the global error [0.3]."),
    ]
    if feed:
        opts.append(click.option("--feed-divisor", type=_lim("feed_divisor", int), default=None,
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
        click.option("--length", type=MM, default=None, help="line: length (mm) [70]."),
        click.option("--azimuth", type=DEG,
                     help="line: angle to +x in the xy-plane (deg) [0]."),
        click.option("--elevation", type=DEG,
                     help="line: angle above the xy-plane (deg) [0]."),
        click.option("--radius", type=MM, default=None, help="curve/spiral: radius (mm) [70 / 80]."),
        click.option("--angle", type=DEG, default=None, help="curve: angle turned (deg) [90]."),
        click.option("--entry", type=MM, default=None, help="curve: entry straight (mm) [30]."),
        click.option("--exit", "exit_", type=MM, default=None, help="curve: exit straight (mm) [30]."),
        click.option("--pitch", type=MM, default=None, help="spiral: rise per turn (mm) [40]."),
        click.option("--turns", type=Bounded(float, 1e6), default=None, help="spiral: number of turns [2]."),
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


# --solver optimal (bhr/solvers/optimal.py, docs/optimal.md)
OPTIMAL_FIELDS = ("lookahead", "beam", "point_weights", "ori_weight", "drift_weight", "roll_weight")


class WeightList(click.ParamType):
    """One weight for every point, or a comma-separated list of them, base to tip."""

    name = "weights"

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        if isinstance(value, (float, tuple)):
            return value
        try:
            vals = [float(p) for p in str(value).split(",")]
        except ValueError:
            self.fail(f"{value!r} is not a number or a comma-separated list of numbers (base to tip)", param, ctx)
        if not all(math.isfinite(v) for v in vals):
            self.fail(f"{value!r} has a value that is not a finite number", param, ctx)
        return vals[0] if len(vals) == 1 else tuple(vals)


def optimal_options(f: Any) -> Any:
    """--lookahead, --beam, --point-weights, --ori-weight, --drift-weight, --roll-weight."""
    return _stack(
        click.option("--lookahead", type=int, default=None, metavar="STEPS",
                     help="optimal: steps the base module's tilt is planned ahead [10]."),
        click.option("--beam", type=int, default=None, metavar="N",
                     help="optimal: base-tilt sequences kept while planning [10]."),
        click.option("--point-weights", type=WeightList(), default=None, metavar="W|W0,..,Wn",
                     help="optimal: weight of each point's squared error, base to tip [1]."),
        click.option("--ori-weight", type=float, default=None, metavar="MM/DEG",
                     help="optimal: tip orientation weight, mm of error per degree [0.2]."),
        click.option("--drift-weight", type=float, default=None,
                     help="optimal: weight of the predicted along-path drift of the base [10]."),
        click.option("--roll-weight", type=float, default=None,
                     help="optimal: weight of tilt axes sitting diagonally to the bend [1000]."),
    )(f)


def pop_optimal(kwargs: dict[str, Any]) -> dict[str, Any]:
    """Remove the optimal solver's options from ``kwargs``; return the given ones as solver options."""
    out = {}
    for k in OPTIMAL_FIELDS:
        v = kwargs.pop(k, None)
        if v is not None:
            out[k] = list(v) if isinstance(v, tuple) else v
    return out
