"""The one registry of settings: robot, trajectory, solver and constraint options.

Every setting a user can give -- on the command line (``--module-length``), in a
robot file (``module_length = 10``), in a batch run table, or as a sweep grid
key -- is one :class:`Option` here, with its type, unit, default, limits and
help. The command-line options (``bhr.cli._options``), the robot-file reader
(:mod:`bhr.model._robotfile`), the batch reader (:mod:`bhr._studies.report`) and the sweep
grids (:mod:`bhr._studies.sweep`) are all derived from :data:`OPTIONS`, so a setting has
the same name, limits and message everywhere.

Lower bounds and ranges that depend on other settings (alpha in (0, 90),
stroke shorter than lever, lookahead at most 200) are checked once, by
:class:`bhr.model._robot.Robot` and by the solver's constructor, which every path
goes through.

A new solver option is one entry here (group ``"solver"``, ``solvers`` naming
the solvers that take it) plus the keyword argument of the solver's
``__init__``.
"""
from __future__ import annotations

import math
import re
import sys
from dataclasses import dataclass
from typing import Any, Iterable

from bhr._settings.errors import BhrError

__all__ = ["Option", "OPTIONS", "MAX_MM", "by_group", "robot_limits", "check_option", "solver_options_for",
           "check_number", "parse_number", "did_you_mean", "MIN_MAGNITUDE", "MIN_MAGNITUDE_UNIT", "LIMITS", "excerpt",
           "type_name", "check_run_name", "MAX_NAME_CHARS", "has_control_char"]

#: Largest length or coordinate accepted anywhere (mm): 1 km. Larger values only overflow the arithmetic.
MAX_MM = 1e6
#: Largest angle (deg) or count accepted where no tighter limit applies.
MAX_ANY = 1e6


@dataclass(frozen=True)
class Option:
    """One setting.

    ``name`` is the key in batch files, robot files and sweep grids, the
    :class:`bhr.model._robot.Robot` field or the solver's or trajectory's keyword and, with dashes, the
    command-line option (``cli`` overrides it). ``kind`` is ``int``, ``float``, ``str``
    (with ``choices``) or ``"weights"`` (one number or one per point).
    ``maximum`` is the largest value accepted (``None``: checked elsewhere,
    magnitude capped at ``cap``); ``positive``/``nonneg`` the sign rule of robot
    files. ``default`` is the value used when the option is not given (``None``:
    none, or it depends on the trajectory); ``shown`` overrides how the help
    states it.
    """

    name: str
    group: str  # "robot", "trajectory", "constraint", "solver" or "run"
    kind: Any  # int, float, str (with choices), bool (a switch) or "weights"
    help: str
    default: Any = None
    unit: str = ""
    maximum: float | None = None
    cap: float = MAX_ANY
    positive: bool = False
    nonneg: bool = False
    choices: tuple[str, ...] | None = None
    cli: str | None = None
    shown: str | None = None
    solvers: tuple[str, ...] | None = None  # solvers taking this option (None: every constrained solver)
    metavar: str | None = None
    solver_defaults: tuple[tuple[str, Any], ...] = ()  # (solver, default) where a solver's default differs

    def default_for(self, solver: str) -> Any:
        """The default of this option for ``solver`` (its own where it has one)."""
        return dict(self.solver_defaults).get(solver, self.default)

    @property
    def flag(self) -> str:
        """The command-line option, e.g. ``--module-length``."""
        return "--" + (self.cli or self.name.replace("_", "-"))

    @property
    def tiny(self) -> float:
        """Smallest non-zero magnitude accepted: :data:`MIN_MAGNITUDE_UNIT` for lengths and angles (a robot
        of 1e-300 mm or degrees only overflows the arithmetic), else the smallest normal float (denormals out)."""
        return MIN_MAGNITUDE_UNIT if self.group == "robot" and self.unit in ("mm", "deg") else MIN_MAGNITUDE

    @property
    def limit(self) -> float:
        """Largest magnitude accepted on the command line and in files."""
        return self.maximum if self.maximum is not None else (MAX_MM if self.unit == "mm" else self.cap)

    def help_text(self) -> str:
        shown = self.shown if self.shown is not None else (None if self.default is None else f"{self.default:g}"
                                                           if isinstance(self.default, (int, float))
                                                           else str(self.default))
        return f"{self.help} [{shown}]." if shown else f"{self.help}."

    def check(self, value: Any, where: str) -> Any:
        """``value`` type-checked and within limits; BhrError naming ``where`` and the key otherwise."""
        key = self.name
        if self.kind is bool:  # a switch: true or false (TOML's booleans; on a grid's text, true or false)
            if isinstance(value, str) and value.strip().lower() in ("true", "false"):
                return value.strip().lower() == "true"
            if not isinstance(value, bool):
                raise BhrError(f"{where}: {key} must be true or false, got {excerpt(value)}")
            return value
        if self.choices is not None:
            if not isinstance(value, str) or value not in self.choices:
                raise BhrError(f"{where}: {key} must be one of {', '.join(self.choices)}, got {excerpt(value)}")
            return value
        if self.kind == "weights" and isinstance(value, (list, tuple)):
            return [self._number(v, where) for v in value]
        return self._number(value, where)

    def _number(self, value: Any, where: str) -> Any:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise BhrError(f"{where}: {self.name} must be a number, got {type_name(value)}")
        v = check_number(value, f"{where}: {self.name}", integer=self.kind is int, limit=self.limit, unit=self.unit,
                         tiny=self.tiny)
        return v if self.kind is int or not isinstance(value, int) else value


_R, _T, _C, _S, _RUN = "robot", "trajectory", "constraint", "solver", "run"
_OPT = ("optimal",)
_LUM = ("lumen",)

OPTIONS: tuple[Option, ...] = (
    # the robot (bhr.model._robot.Robot; thesis ch. 4 and 7)
    Option("modules", _R, int, "Number of modules the solver moves", 5, maximum=1000, positive=True, shown=""),
    Option("module_length", _R, float, "Length of one module (mm)", 10.0, "mm", 1e4, positive=True, shown=""),
    Option("robot_radius", _R, float, "Robot (disc) radius in mm", 5.0, "mm", 1e4, positive=True),
    Option("alpha", _R, float, "Tilt angle of one actuator pair (deg)", 10.0, "deg"),  # (0, 90): Robot
    Option("stroke", _R, float, "Actuator stroke h (mm); with --lever gives alpha = asin(h/L)", None, "mm", 1e4,
           positive=True),
    Option("lever", _R, float, "Actuator lever L (mm); see --stroke", None, "mm", 1e4, positive=True),
    Option("tol_pos", _R, float, "Position tolerance (mm)", 8.0, "mm", MAX_MM, positive=True, shown=""),
    Option("tol_ori", _R, float, "Orientation tolerance (deg)", 20.0, "deg", 180.0, positive=True),
    Option("max_iter", _R, int, "Iteration limit per solve", 30, maximum=100000, positive=True),
    Option("feed_divisor", _R, int, "Feed = module length / this; trajectory points are spaced by the feed", 5,
           maximum=1000, positive=True),
    Option("weight_pos", _R, float, "Weight of position in the global error", 0.7, maximum=1e6, nonneg=True),
    Option("weight_ori", _R, float, "Weight of orientation in the global error", 0.3, maximum=1e6, nonneg=True),
    # the trajectory generators (thesis appendix 3; bhr.trajectory)
    Option("length", _T, float, "line: length (mm)", 70.0, "mm"),
    Option("azimuth", _T, float, "line: angle to +x in the xy-plane (deg)", 0.0, "deg"),
    Option("elevation", _T, float, "line: angle above the xy-plane (deg)", 0.0, "deg"),
    Option("radius", _T, float, "curve/spiral: radius (mm)", None, "mm", shown="70 / 80"),
    Option("angle", _T, float, "curve: angle turned (deg)", 90.0, "deg"),
    Option("entry", _T, float, "curve: entry straight (mm)", 30.0, "mm"),
    Option("exit", _T, float, "curve: exit straight (mm)", 30.0, "mm"),
    Option("pitch", _T, float, "spiral: rise per turn (mm)", 40.0, "mm"),
    Option("turns", _T, float, "spiral: number of turns", 2.0),
    Option("seed", _T, int, "anatomy: which anatomical colon, a whole number 0 ... 4294967295", 1,
           maximum=2**32 - 1),
    Option("lumen_end", _T, str, "How the lumen ends past the trajectory's last point: closed (a blind end, as the "
           "cecum: past it is wall) or open (it goes on straight); the entrance is always open", "closed",
           choices=("closed", "open")),
    Option("lumen_model", _T, str, "A real colon's lumen: ct (as the CT surface has it) or insufflated (a "
           "literature-based model of the distended colon at colonoscopy, an idealisation; docs/real_colons.md)",
           "ct", choices=("ct", "insufflated")),
    # the constrained solvers (thesis ch. 6; bhr.solvers._thesis)
    Option("limit", _C, str, "Rotation limit of the constrained solvers", "binary",
           choices=("binary", "continuous", "none")),
    Option("axes", _C, str, "Tilt axes: the module's two local axes, or free", "local", choices=("local", "free")),
    Option("warmup", _C, int, "Unconstrained warm-up iterations of the constrained solvers", 10),
    # --solver optimal (bhr.solvers._optimal, docs/optimal.md) and --solver lumen (bhr.solvers._lumen, docs/lumen.md);
    # ranges checked by the solver
    Option("lookahead", _S, int, "optimal, lumen: steps the base module's tilt is planned ahead (lumen [10])", 10,
           solvers=_OPT + _LUM, metavar="STEPS", solver_defaults=(("lumen", 10),)),
    Option("beam", _S, int, "optimal, lumen: base-tilt sequences kept while planning (lumen [4])", 10,
           solvers=_OPT + _LUM, metavar="N", solver_defaults=(("lumen", 4),)),
    Option("point_weights", _S, "weights", "optimal: weight of each point's squared error, base to tip", 1.0,
           solvers=_OPT, metavar="W|W0,..,Wn"),
    Option("ori_weight", _S, float, "optimal, lumen: tip orientation weight, mm of error per degree (lumen [0.1])",
           0.2, solvers=_OPT + _LUM, metavar="MM/DEG", solver_defaults=(("lumen", 0.1),)),
    Option("drift_weight", _S, float, "optimal: weight of the predicted along-path drift of the base", 10.0,
           solvers=_OPT),
    Option("roll_weight", _S, float, "optimal: weight of tilt axes sitting diagonally to the bend", 1000.0,
           solvers=_OPT),
    Option("wall_weight", _S, float, "lumen: weight of the squared penetration past the margin, per mm^2", 1000.0,
           solvers=_LUM),
    Option("margin", _S, float, "lumen: clearance below which the wall cost starts (mm)", 1.0, solvers=_LUM,
           metavar="MM"),
    Option("center_weight", _S, float, "lumen: weight of the squared distance of each point of the head to the "
           "centerline", 0.0, solvers=_LUM),
    Option("track_weight", _S, float, "lumen: weight of each point's squared error to its trajectory point", 0.0,
           solvers=_LUM),
    Option("along_weight", _S, float, "lumen: weight of each point's squared lead along the centerline", 0.05,
           solvers=_LUM),
    Option("lead_weight", _S, float, "lumen: weight of the squared lead the robot could no longer lose before the "
           "path's end, per mm^2 (for a lumen with an open end; at a blind cecum the feeder stops)", 0.0,
           solvers=_LUM),
    Option("lead_slack", _S, float, "lumen: share of the path still ahead of a point that its lead may be before "
           "--lead-weight counts", 0.1, maximum=1.0, solvers=_LUM, metavar="SHARE"),
    Option("racing_weight", _S, float, "lumen: weight of each point's squared distance to a racing line planned "
           "before the run (a smooth line of bounded curvature inside the lumen, docs/lumen.md), per mm^2; 0: none",
           0.05, solvers=_LUM),
    Option("window", _S, float, "lumen: arc length searched on each side for a point's nearest centerline point "
           "(mm)", 40.0, solvers=_LUM, metavar="MM"),
    Option("trail_beam", _S, int, "lumen with --locomotion trail: trails kept by the planner's beam search", 64,
           maximum=4096, solvers=_LUM, metavar="N"),
    Option("trail_center_weight", _S, float, "lumen with --locomotion trail: weight of the squared distance of each "
           "new trail vertex to the centerline", 0.05, solvers=_LUM),
    # how a run is simulated (bhr._run.driver.follow)
    Option("body_modules", _RUN, int, "Also simulate the body: the whole robot has M modules (M >= --modules), "
           "those behind the head follow the leader and count in the errors and the lumen clearance", None,
           maximum=10000, positive=True, metavar="M", shown="head only"),
    Option("reach", _RUN, str, "cecum: the whole robot is long enough to reach the cecum of the path (its modules "
           "from the path's length; instead of --body-modules)", None, choices=("cecum",), shown="head only"),
    Option("locomotion", _RUN, str, "How the robot moves: thesis (the thesis's model, the head solved every step), "
           "wires (the robot as it can be built: rigid modules whose joints its wires drive along the trail the tip "
           "lays, every pose scored) or trail (ideal follow-the-leader, not buildable; docs/locomotion.md)",
           None, choices=("thesis", "wires", "trail"),
           shown="wires for a whole robot with --solver lumen on a path with a lumen, else thesis"),
    Option("stop_at_wall", _RUN, bool, "End the run at the step where the robot leaves the lumen (a point of its "
           "axis outside the wall): a study then scores no pose a real robot cannot take (docs/lumen.md)", None,
           shown="run to the end"),
    Option("all_poses", _RUN, bool, "Keep every pose of a whole robot moved by its wires, however many, and write "
           "them to poses.npz (a 1.5 m robot's: 5 GB of memory, 0.8 GB of file); bhr physics then replays every one "
           "of them, not the run's steps (docs/locomotion.md)", None, shown="at most 6 million robot points"),
    # the physics replay (bhr._studies.physics, docs/physics.md)
    Option("wall_stiffness", "physics", float, "Colon wall stiffness per mm of robot in contact, N/mm per mm "
           "(published indentation 0.7-2.4 N/mm over a 13 mm colonoscope head: 0.054-0.185)", 0.1192, "N/mm^2", 2.0,
           positive=True, metavar="N/MM2"),
    Option("wire_force", "physics", float, "Recovery force of one actuator wire, N (0.100 mm Flexinol: 1.47); with "
           "the lever and alpha it sets how stiffly the wires hold a joint", 1.4709975, "N", 1000.0, positive=True,
           metavar="N"),
    Option("feeder_force", "physics", float, "Force limit of the feeder that pushes the robot's rear end, N (the "
           "largest push measured on a colonoscope: 4.4 kg)", 43.14926, "N", 10000.0, positive=True, metavar="N"),
    Option("substeps", "physics", int, "Equilibria solved from one written pose to the next at least (more where a "
           "joint would move over 2 mm)", 1, maximum=1000, positive=True),
    Option("max_wall_force", "physics", float, "Largest total wall force a traversal may put on the colon, N "
           "(9.8: exceeded 5 % of the time in colonoscopy)", 9.8, "N", 10000.0, positive=True, metavar="N"),
    Option("passive_modules", "physics", int, "Rear modules without wires: a passive body, held towards straight by "
           "its bending stiffness (--passive-rigidity), pushed by the feeder; the run's codes drive the modules in "
           "front of it", 0, maximum=10000, nonneg=True, metavar="N", shown="0: every module driven"),
    Option("passive_rigidity", "physics", float, "Flexural rigidity of the passive body, N mm^2 (a colonoscope's "
           "insertion tube: 26,000-40,000 at room temperature, 17 % less at 37 C)", 27390.0, "N mm^2", 1e9,
           positive=True, metavar="N_MM2"),
)

BY_NAME: dict[str, Option] = {o.name: o for o in OPTIONS}

#: Sizes checked before anything is allocated (docs/commands.md#limits): the one place they are set.
LIMITS: dict[str, int] = {
    "points": 500_000,  # points of a path after sampling (generators, segment and CSV files)
    # steps x (modules + 1) of one run: about 0.7-1.4 kB each in memory with run.json and the figures, 2-3.5 GB at
    # most (docs/commands.md#limits: anatomy colon 3 at feed divisor 10, the whole robot, 2.49 M points, 1.85 GB)
    "step_points": 2_500_000,
    "segments": 10_000,  # segments of a trajectory TOML
    "modules": 1000,  # modules the solver moves (--modules)
    "body_modules": 10_000,  # modules of the whole simulated robot (--body-modules)
    "code_modules": 1000,  # module columns of a codes.csv (bhr plan, bhr stream)
    "code_steps": 500_000,  # rows of a codes.csv
    "plan_cells": 5_000_000,  # steps x modules of a codes.csv (bhr plan keeps about 40 bytes per cell)
    "figure_modules": 64,  # modules whose wires bhr plan draws in thermal.png (4 lines each)
    # anatomical colons of a traversability study (--colons): each is drawn (about 7 ms) and checked before the
    # first run, and each design follows every one of them (about 0.3 s a run)
    "colons": 10_000,
    "study_runs": 1_000_000,  # runs of a sweep or a traversability study (designs x trajectories or colons)
}


def solver_defaults(solver: str) -> dict[str, Any]:
    """Every option ``solver`` takes, with its default for that solver."""
    return {o.name: o.default_for(solver) for o in OPTIONS if o.group == "solver" and solver in (o.solvers or ())}


def by_group(*groups: str) -> tuple[Option, ...]:
    """The options of the given groups, in registry order."""
    return tuple(o for o in OPTIONS if o.group in groups)


def robot_limits() -> dict[str, tuple[float, str]]:
    """Robot field -> (largest value, unit), for readers that check robot settings."""
    return {o.name: (o.limit, o.unit) for o in by_group(_R)}


def check_option(name: str, value: Any, where: str) -> Any:
    """Check one option by its batch/grid name (see :meth:`Option.check`)."""
    return BY_NAME[name].check(value, where)


def solver_options_for(solver: str, values: dict[str, Any]) -> dict[str, Any]:
    """The constraint and solver options among ``values`` that ``solver`` takes.

    Constraint options go to every solver (one that does not take them says
    so); options of a named solver (``solvers``) only to that solver, so a sweep
    over several solvers can vary one solver's options.
    """
    out = {}
    for o in by_group(_C, _S):
        if o.name in values and (o.solvers is None or solver in o.solvers):
            out[o.name] = values[o.name]
    return out


# --- the one number checker -------------------------------------------------------------------------------------

#: Smallest non-zero magnitude accepted for a robot's length (mm) or angle (deg) option: below it a value means
#: nothing physical and only overflows the arithmetic (--alpha 1e-320 gives an infinite turn radius).
MIN_MAGNITUDE_UNIT = 1e-9
#: Smallest non-zero magnitude accepted for any other number (the smallest normal float64; denormals out).
MIN_MAGNITUDE = sys.float_info.min
#: Longest number accepted as text (digits, sign, point, exponent).
MAX_NUMBER_CHARS = 40

_PLAIN_INT = re.compile(r"[+-]?[0-9]+", re.ASCII)
_PLAIN_FLOAT = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|[+-]?(?:nan|inf|infinity)",
                          re.ASCII | re.IGNORECASE)


def excerpt(value: Any, limit: int = 40) -> str:
    """``value`` as quoted in a one-line message: repr, at most ``limit`` characters (an int: its size)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10 ** 30:
        try:
            return f"a {len(str(abs(value)))}-digit whole number"
        except ValueError:  # more digits than Python converts to text
            return f"a whole number of about {int(abs(value).bit_length() * 0.30103) + 1} digits"
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def has_control_char(text: str) -> bool:
    """``text`` holds a control character or a line break (a tab, a newline, an escape, U+2028 ...): a name, a path
    or a port that has one would break or garble every one-line message that quotes it."""
    return any(ord(c) < 32 or ord(c) == 127 or c in "\u2028\u2029\x85" for c in text)


def parse_number(text: str, where: str, *, integer: bool = False) -> int | float:
    """A number written as plain text: ASCII digits only (no ``1_5``, full-width or Arabic-Indic digits), at
    most :data:`MAX_NUMBER_CHARS` long, and for ``integer`` digits with an optional sign only (no ``3.0``,
    ``1e3``); a BhrError naming ``where`` otherwise. Not range-checked: pass the
    result to :func:`check_number`."""
    t = str(text).strip()
    kind = "a whole number" if integer else "a number"
    if len(t) > MAX_NUMBER_CHARS:
        raise BhrError(f"{where} must be {kind} of at most {MAX_NUMBER_CHARS} characters, got {len(t)} characters")
    if _PLAIN_INT.fullmatch(t):
        return int(t) if integer else float(t) if abs(int(t)) < 10 ** 300 else float("inf")
    if not integer and _PLAIN_FLOAT.fullmatch(t):
        v = float(t)
        if _underflows(t, v):  # 1e-400: not 0, and too small for a float
            raise BhrError(f"{where} {t} is too small to mean anything; give 0 or a larger number")
        return v
    if integer and _PLAIN_FLOAT.fullmatch(t):  # "3.0", "1e3": a count or a seed is written as digits only
        raise BhrError(f"{where} must be a whole number written with digits only (no point or exponent), "
                       f"got {excerpt(t)}")
    raise BhrError(f"{where} must be {kind} written with plain digits (0-9), got {excerpt(t)}")


def _underflows(text: str, value: float) -> bool:
    """True when ``text`` is a number other than 0 that a float can only hold as 0 (1e-400)."""
    return value == 0.0 and any(c in "123456789" for c in text.lower().split("e")[0])


class Underflow(ValueError):
    """A number in a file that is not 0 but reads as 0 (1e-400): raised by :func:`file_float`; its text is the
    clause a reader puts after the file's name."""


def file_float(text: str) -> float:
    """The ``parse_float`` of every TOML and JSON file bhr reads: 1e-400 is refused (:class:`Underflow`), not
    silently read as 0."""
    v = float(text)
    if _underflows(text, v):
        raise Underflow(f"the number {text[:40]} is too small to mean anything (it would read as 0); give 0 or a "
                        "larger number")
    return v


def _whole(x: float) -> str:
    """A limit as an integer is written: 4294967295, not 4.29497e+09 (1e+18 and beyond in the short form)."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e16 else f"{x:g}"


def check_number(value: Any, where: str, *, integer: bool = False, limit: float = MAX_ANY, unit: str = "",
                 positive: bool = False, nonneg: bool = False, minimum: float | None = None,
                 maximum: float | None = None, tiny: float | None = None) -> Any:
    """The one check of a number from anywhere (command line, robot, batch, sweep and trajectory files,
    run.json): a real int or float (not a bool, not text), finite, at most ``limit`` in size (an integer of
    any length is compared exactly, never converted), not a denormal nor, for mm and degrees, a magnitude
    under :data:`MIN_MAGNITUDE_UNIT`; ``integer``: a whole number; ``positive``/``nonneg``/``minimum``: the
    sign or lower bound. Returns an int (``integer``) or a float. BhrError naming ``where`` otherwise.
    """
    u = f" {unit}" if unit else ""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        try:
            import numpy as np

            if isinstance(value, (np.integer, np.floating)) and not isinstance(value, np.bool_):
                value = value.item()
        except ImportError:  # pragma: no cover - numpy is a dependency
            pass
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise BhrError(f"{where} must be {'a whole number' if integer else 'a number'}, got {type_name(value)}")
    if isinstance(value, int):
        shown = str(value) if abs(value) < 10 ** 30 else excerpt(value)
        if maximum is not None and value > maximum and abs(value) > limit:
            raise BhrError(f"{where} must be at most {_whole(maximum)}{u}, got {shown}")
        if abs(value) > limit:
            raise BhrError(f"{where} = {shown} is too large; the limit is {_whole(limit)}{u}")
    else:
        if not math.isfinite(value):
            raise BhrError(f"{where} must be a finite number, got {value}")
        if abs(value) > limit:
            raise BhrError(f"{where} = {value:g} is too large; the limit is {limit:g}{u}")
        small = tiny if tiny is not None else MIN_MAGNITUDE
        if value != 0.0 and abs(value) < small:
            raise BhrError(f"{where} = {value:g} is too small to mean anything; give 0 or at least {small:g}{u}")
        if integer:
            if not value.is_integer():
                raise BhrError(f"{where} must be a whole number, got {value:g}")
            value = int(value)
    if positive and value <= 0:
        raise BhrError(f"{where} must be greater than 0{u}, got {value:g}")
    if nonneg and value < 0:
        raise BhrError(f"{where} must be 0 or more{u}, got {value:g}")
    if minimum is not None and value < minimum:
        raise BhrError(f"{where} must be at least {minimum:g}{u}, got {value:g}")
    if maximum is not None and value > maximum:
        raise BhrError(f"{where} must be at most {maximum:g}{u}, got {value:g}")
    return int(value) if integer else float(value)


def type_name(value: Any) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, str):
        return f"the text {excerpt(value)}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "a list"
    return type(value).__name__


def did_you_mean(word: Any, choices: Iterable[str]) -> str:
    """``"did you mean 'x'? "`` for the choice nearest ``word`` (difflib), or ``""`` when none is close.

    The one suggestion function of every "unknown name" message (options, keys, solvers, trajectories).
    """
    import difflib

    close = difflib.get_close_matches(str(word)[:100].replace("-", "_"), list(choices), n=1, cutoff=0.6)
    if not close:
        close = difflib.get_close_matches(str(word)[:100], list(choices), n=1, cutoff=0.6)
    return f"did you mean {close[0]!r}? " if close else ""


#: Longest run name accepted (batch files); the run's folder name is cut to fit any file system.
MAX_NAME_CHARS = 100


def check_run_name(value: Any, where: str) -> str:
    """A run's name, checked before any work: text of 1 to :data:`MAX_NAME_CHARS` printable characters."""
    if not isinstance(value, str):
        raise BhrError(f"{where}: name must be text in quotes, got {type_name(value)}")
    name = value.strip()
    if not name:
        raise BhrError(f"{where}: name must not be empty; give every run a short name")
    if len(name) > MAX_NAME_CHARS:
        raise BhrError(f"{where}: name is {len(name)} characters long; give at most {MAX_NAME_CHARS}")
    if has_control_char(name):
        raise BhrError(f"{where}: name {excerpt(name)} holds a control character (a tab or a line break); "
                       "give a name on one line")
    hidden = next((c for c in name if not c.isprintable()), None)
    if hidden is not None:  # a format or invisible character: a right-to-left override shows the name reversed
        raise BhrError(f"{where}: name {excerpt(name)} holds U+{ord(hidden):04X}, an invisible or formatting "
                       "character; give a name of printable characters")
    return name
