"""Options shared by the commands that simulate: robot, solver constraints, trajectory.

Every option here is built from the registry in :mod:`bhr._settings.options` (name, type, unit, limit, default,
help), the same one robot files, batch files and sweep grids are checked against.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import click

from bhr._settings.errors import BhrError
from bhr._settings.options import BY_NAME, MAX_MM, Option, by_group, check_number, excerpt, parse_number


def plain_number(text: str) -> bool:
    """True for numbers written with ASCII digits only and no '_' separators ("15", "-2.5e3", "nan").

    Python's int() and float() also take "1_5", full-width "１５" and Arabic-Indic digits; a robot
    command should not guess what those mean.
    """
    return text.isascii() and "_" not in text


def _convert(t: click.ParamType, value: Any, param: Any, ctx: Any, kind: type, **checks: Any) -> Any:
    """Text -> number through the one checker (bhr._settings.options.parse_number, check_number); click's one-line
    failure."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        v: Any = value
    else:
        try:
            v = parse_number(str(value), "value", integer=kind is int)
        except BhrError as exc:
            t.fail(str(exc).removeprefix("value "), param, ctx)  # the checker's line names the value and the form
    if isinstance(v, float) and not math.isfinite(v):
        t.fail(f"{value} is not a finite number", param, ctx)
    try:
        return check_number(v, "value", integer=kind is int, **checks)
    except BhrError as exc:
        msg = str(exc)
        msg = msg[len("value = "):] if msg.startswith("value = ") else msg
        t.fail(msg[len("value "):] if msg.startswith("value ") else msg, param, ctx)


class Bounded(click.ParamType):
    """A finite int or float no larger in size than ``limit``: one clear line for nan, inf or 1e300.

    Signs and lower bounds are left to the library (bhr.model._robot.Robot, the
    trajectory checks), whose messages name the allowed range.
    """

    def __init__(self, kind: type = float, limit: float = MAX_MM, unit: str = "", tiny: float | None = None) -> None:
        self.kind = kind
        self.limit = limit
        self.unit = unit
        self.tiny = tiny
        self.name = "integer" if kind is int else "float"

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        v = _convert(self, value, param, ctx, self.kind, limit=self.limit, unit=self.unit, tiny=self.tiny)
        if isinstance(v, float) and not math.isfinite(v):  # pragma: no cover - check_number refuses it
            self.fail(f"{value} is not a finite number", param, ctx)
        return self.kind(v)


class FiniteRange(click.FloatRange):
    """click.FloatRange through the one checker: nan, inf, denormals and non-ASCII digits refused."""

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        v = _convert(self, value, param, ctx, float, limit=1e300)
        return super().convert(v, param, ctx)


class Share(FiniteRange):
    """A share (0 < x <= 1), its range shown as such; a value past it reaches the library's own one-line refusal,
    which says what a share is (95 for 95%: "e.g. 0.95") better than a bare range would."""

    def __init__(self) -> None:
        super().__init__(min=0, max=1e6)

    def _describe_range(self) -> str:
        return "0<x<=1"


class PlainIntRange(click.IntRange):
    """click.IntRange through the one checker: "1_5", non-ASCII digits and integers of any length refused."""

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        v = _convert(self, value, param, ctx, int, limit=1e18)
        return super().convert(v, param, ctx)


#: Slowest streaming rate accepted (Hz): one step every 100 s.
MIN_RATE = 0.01
#: Fastest rate (Hz) a stream, a plan or a follow --port may ask for.
MAX_RATE = 1000.0


def rate_type() -> "FiniteRange":
    """The one type of every --rate of a stream (follow --port, stream, plan): MIN_RATE to MAX_RATE Hz."""
    return FiniteRange(min=MIN_RATE, max=MAX_RATE)

#: Lengths and coordinates in mm (trajectory options, targets), and angles (ranges checked by the library).
MM = Bounded(float, MAX_MM, "mm")
DEG = Bounded(float, 1e6, "deg")

#: Command-line parameter name -> registry option, for every option built from bhr._settings.options.
_PARAM: dict[str, Option] = {}


def _param(o: Option) -> str:
    return "exit_" if o.name == "exit" else o.name


def _click_option(o: Option) -> Callable[[Any], Any]:
    """The click option of one registry entry: its flag, type (with the registry's limit), help and default."""
    _PARAM[_param(o)] = o
    if o.kind is bool:  # a switch: present or not (None when absent, so that a robot file or default decides)
        return click.option(o.flag, _param(o), is_flag=True, default=None, help=o.help_text())
    if o.choices is not None:
        kind: Any = click.Choice(list(o.choices))
    elif o.kind == "weights":
        kind = WeightList()
    elif o.group == "solver":  # ranges checked by the solver, with its own messages; the number checked here
        kind = Bounded(o.kind, o.limit, o.unit, o.tiny)
    else:
        kind = Bounded(o.kind, o.limit, o.unit, o.tiny)
    return click.option(o.flag, _param(o), type=kind, default=None, help=o.help_text(), metavar=o.metavar)


ROBOT_FIELDS = {_param(o): o.name for o in by_group("robot")}
TRAJ_FIELDS = tuple(o.name for o in by_group("trajectory"))
CONSTRAINT_FIELDS = tuple(o.name for o in by_group("constraint"))


def stack_options(*decorators: Callable[[Any], Any]) -> Callable[[Any], Any]:
    def apply(f: Any) -> Any:
        for d in reversed(decorators):
            f = d(f)
        return f

    return apply


#: --force, for every command that writes an output folder (docs/commands.md#output-folders).
force_option = click.option(
    "--force", is_flag=True,
    help="Replace the output folder even when bhr did not write it (a folder without bhr's manifest.json, or "
         "holding files its manifest does not list): what it holds is deleted.")


def study_options(out_default: str) -> Callable[[Any], Any]:
    """--robot, --out, --force, --jobs and --scheduler, as every study (sweep, traverse) takes them."""
    return stack_options(
        click.option("--robot", "robot_file", default=None, metavar="FILE",
                     help="Robot description (.toml or .json, docs/robot-files.md) every design starts from; grid "
                          "values replace its values."),
        click.option("--out", "out_dir", default=None, metavar="DIR", help=f"Output folder [{out_default}]."),
        force_option,
        click.option("--jobs", "-j", type=PlainIntRange(min=1, max=1024), default=None, metavar="N",
                     help="Worker processes [the number of CPUs]; 1 runs in this process."),
        click.option("--scheduler", default=None, metavar="ADDRESS",
                     help="Run on an existing Dask distributed cluster instead, e.g. tcp://127.0.0.1:8786."))


#: Robot options only a solver uses (tolerances, iteration limit, error weights).
SOLVING_ONLY = ("tol_pos", "tol_ori", "max_iter", "weight_pos", "weight_ori")


def robot_options(feed: bool = True, solving: bool = True) -> Callable[[Any], Any]:
    """--robot FILE and the robot options of :mod:`bhr._settings.options` (--modules, --module-length, ...).

    ``solving=False`` leaves out what only a solver uses (:data:`SOLVING_ONLY`):
    ``bhr fk`` solves nothing.
    """
    opts = [click.option("--robot", "robot_file", default=None, metavar="FILE",
                         help="Robot description (.toml or .json, docs/robot-files.md), or a run.json whose robot to "
                              "reuse; options given here override its values.")]
    opts += [_click_option(o) for o in by_group("robot")
             if (feed or o.name != "feed_divisor") and (solving or o.name not in SOLVING_ONLY)]
    return stack_options(*opts)


def constraint_options(f: Any) -> Any:
    """--limit, --axes, --warmup for the constrained solvers (thesis ch. 6 steps)."""
    return stack_options(*[_click_option(o) for o in by_group("constraint")])(f)


def run_options(f: Any) -> Any:
    """How a run is simulated (--body-modules), from :mod:`bhr._settings.options`."""
    return stack_options(*[_click_option(o) for o in by_group("run")])(f)


def model_modules_option(f: Any) -> Any:
    """--body-modules for a command that builds a model, not a run (bhr export): the registry's entry and limits,
    with help that speaks of the model (--reach and --locomotion, which need a path, are not offered)."""
    from dataclasses import replace

    o = next(o for o in by_group("run") if o.name == "body_modules")
    return _click_option(replace(o, help="The whole robot has M modules (M >= --modules): the model's links",
                                 shown="--modules"))(f)


def max_wall_force_option(f: Any) -> Any:
    """``bhr traverse --max-wall-force N``: the registry's entry (bhr._settings.options); left out, the study keeps the
    geometric verdict and replays nothing."""
    import dataclasses

    return _click_option(dataclasses.replace(BY_NAME["max_wall_force"], shown="not given: the geometric verdict; "
                                             "bhr physics's default 9.8"))(f)


def physics_options(f: Any) -> Any:
    """The physics replay's options (--wall-stiffness, --rate, --substeps), from :mod:`bhr._settings.options`."""
    return stack_options(*[_click_option(o) for o in by_group("physics")])(f)


def trajectory_options(f: Any) -> Any:
    """The generators' parameters (--length, --radius, ...)."""
    return stack_options(*[_click_option(o) for o in by_group("trajectory")])(f)


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
    from bhr.model._robot import Robot

    path = kwargs.pop("robot_file", None)
    given = pop_robot(kwargs)
    if path is not None:
        from bhr.model._robotfile import load_robot_file

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


# --solver optimal (bhr/solvers/_optimal.py, docs/optimal.md)
OPTIMAL_FIELDS = tuple(o.name for o in by_group("solver") if o.solvers is not None and "optimal" in o.solvers)


class WeightList(click.ParamType):
    """One weight for every point, or a comma-separated list of them, base to tip."""

    name = "weights"

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        if isinstance(value, (float, tuple)):
            return value
        vals = []
        for part in str(value).split(","):
            try:
                vals.append(check_number(parse_number(part, "weight"), "weight", limit=1e300))
            except BhrError:
                self.fail(f"{excerpt(str(value))} is not a number or a comma-separated list of finite numbers "
                          "(base to tip)", param, ctx)
        return vals[0] if len(vals) == 1 else tuple(vals)


def optimal_options(f: Any) -> Any:
    """--lookahead, --beam, --point-weights, --ori-weight, --drift-weight, --roll-weight."""
    return stack_options(*[_click_option(o) for o in by_group("solver") if o.name in OPTIMAL_FIELDS])(f)


# --solver lumen (bhr/solvers/_lumen.py, docs/lumen.md); it shares --lookahead, --beam and --ori-weight with optimal
LUMEN_FIELDS = tuple(o.name for o in by_group("solver") if o.solvers == ("lumen",))
SHARED_FIELDS = tuple(o.name for o in by_group("solver") if o.solvers is not None and len(o.solvers) > 1)


def lumen_options(f: Any) -> Any:
    """--wall-weight, --margin, --center-weight, --track-weight, --window."""
    return stack_options(*[_click_option(o) for o in by_group("solver") if o.name in LUMEN_FIELDS])(f)


def pop_solver_options(kwargs: dict[str, Any], solvers: list[str]) -> dict[str, dict[str, Any]]:
    """The solver options given (optimal, lumen), per solver run; refuses an option no solver run takes."""
    from bhr._settings.errors import BhrError

    out: dict[str, dict[str, Any]] = {}
    for o in by_group("solver"):
        v = kwargs.pop(_param(o), None)
        if v is None:
            continue
        takers = [s for s in solvers if o.solvers is None or s in o.solvers]
        if not takers:
            which = " or ".join(f"--solver {s}" for s in (o.solvers or ()))
            raise BhrError(f"{o.flag} is an option of {which}; drop it or use {which}")
        for s in takers:
            out.setdefault(s, {})[o.name] = list(v) if isinstance(v, tuple) else v
    return out
