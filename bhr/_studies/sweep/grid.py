"""A sweep's grid: its trajectories, solvers and the values of each key (``modules=4,5,6``, ``alpha=8:12``,
``modules=3-5,8``), read from the command line or a sweep file and checked once."""
from __future__ import annotations

import itertools
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Sequence

from bhr.model._generators import GENERATORS, builtin_names, load_trajectory
from bhr.model._robotfile import load_robot_file
from bhr._settings.errors import BhrError
from bhr._settings.inputs import check_document, read_toml
from bhr._settings.options import BY_NAME, LIMITS, MAX_NUMBER_CHARS, by_group, excerpt
from bhr.solvers import check_solver_name
from bhr._studies.study import (
    BOOL_KEYS,
    CONSTRAINT_KEYS,
    NUMBER_KEYS,
    REPLAY_KEYS,
    ROBOT_KEYS,
    TRAJ_KEYS,
    check_body,
    check_value,
    make_robot,
    suggest,
)

__all__ = ["RUN_CHOICE_KEYS", "TRAJ_CHOICE_KEYS", "GRID_KEYS", "parse_values", "parse_grid_option", "Sweep",
           "sweep_from_toml", "load_sweep", "build_sweep", "colon_source"]

#: Keys a grid may vary: trajectory and robot options, and the constrained solvers' options.
#: How a run is simulated, by name (``locomotion = thesis, trail``; ``reach = cecum``).
RUN_CHOICE_KEYS = frozenset(o.name for o in by_group("run") if o.choices is not None)
#: Trajectory options taken by name (``lumen_end = closed, open``), for every trajectory with a lumen.
TRAJ_CHOICE_KEYS = frozenset(o.name for o in by_group("trajectory") if o.choices is not None)
#: A study judged by the physical replay (``bhr traverse --max-wall-force``) may also vary the replay's options.
GRID_KEYS = frozenset(NUMBER_KEYS | set(CONSTRAINT_KEYS) | RUN_CHOICE_KEYS | TRAJ_CHOICE_KEYS | BOOL_KEYS
                      | set(REPLAY_KEYS))
_TOP_KEYS = ("title", "description", "traj", "solver", "robot", "grid")
_NUM = re.compile(r"^[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?$", re.ASCII)
_MAX_DESIGNS = LIMITS["study_runs"]


def _number(text: str, key: str, where: str) -> int | float:
    t = text.strip()
    if len(t) > MAX_NUMBER_CHARS:  # a 400-digit range end overflowed the count (OverflowError, a traceback)
        raise BhrError(f"{where}: {key} value {excerpt(t)} is {len(t)} characters, longer than any number "
                       f"({MAX_NUMBER_CHARS})")
    if not _NUM.match(t):
        raise BhrError(f"{where}: {key} value {excerpt(t)} is not a number; give numbers and ranges such as "
                       f"{key}=4,5,6, {key}=4:8:0.5 or {key}=4-8")
    whole = re.fullmatch(r"[+-]?\d+", t, re.ASCII)
    if not whole and BY_NAME.get(key) is not None and BY_NAME[key].kind is int:  # as --modules takes it
        raise BhrError(f"{where}: {key} must be a whole number written with digits only (no point or exponent), "
                       f"got {excerpt(t)}")
    v = int(t) if whole else float(t)
    if isinstance(v, float) and not math.isfinite(v):  # 1e400
        raise BhrError(f"{where}: {key} value {t} is not a finite number")
    return v


_DASH = re.compile(r"\s*(\d+(?:\.\d*)?)\s*-\s*(\d+(?:\.\d*)?)\s*", re.ASCII)


def _values(item: str, key: str, where: str) -> list[int | float]:
    """One comma-separated item of a grid value: a number, ``START:STOP[:STEP]`` or ``FIRST-LAST`` (step 1)."""
    t = item.strip()
    if not t:
        raise BhrError(f"{where}: {key} has an empty value; give e.g. {key}=4,5,6, {key}=4:8 or {key}=4-8")
    m = _DASH.fullmatch(t)
    if m is not None:  # FIRST-LAST, both plain numbers (a leading - is a negative number, not a range)
        first, last = _number(m.group(1), key, where), _number(m.group(2), key, where)
        return _range(first, last, 1, key, where, shown=t)
    if ":" in t:
        parts = t.split(":")
        if len(parts) not in (2, 3):
            raise BhrError(f"{where}: {key} range {excerpt(t)} must be START:STOP or START:STOP:STEP")
        nums = [_number(p, key, where) for p in parts]
        return _range(nums[0], nums[1], nums[2] if len(nums) == 3 else 1, key, where, shown=t)
    return [_number(t, key, where)]


def _range(start: float, stop: float, step: float, key: str, where: str, shown: str | None = None
           ) -> list[int | float]:
    for end in (start, stop):
        if abs(end) > 1e300:  # FIRST-LAST of whole numbers of any length: :g of one would overflow
            raise BhrError(f"{where}: {key} range end {excerpt(end)} is too large to be a value of {key}")
    if step <= 0:
        raise BhrError(f"{where}: {key} range step must be positive, got {step:g}")
    if stop < start:
        raise BhrError(f"{where}: {key} range {excerpt(shown) if shown else f'{start:g}:{stop:g}'} runs backwards; "
                       "give START:STOP[:STEP] or FIRST-LAST with the smaller first")
    try:
        span = (stop - start) / step
    except OverflowError:  # whole numbers too far apart for a float
        span = math.inf
    if not span < _MAX_DESIGNS:  # counted before any int() of it: 5:1e308 has a 309-digit count
        raise BhrError(f"{where}: {key} range {start:g}:{stop:g}:{step:g} has more than {_MAX_DESIGNS} values; "
                       "use a larger step")
    count = int(math.floor(span + 1e-9)) + 1
    if count > _MAX_DESIGNS:
        raise BhrError(f"{where}: {key} range {start:g}:{stop:g}:{step:g} has {count} values; use a larger step")
    integral = all(float(v).is_integer() for v in (start, stop, step))
    vals: list[int | float] = []
    for k in range(count):
        v = start + k * step
        vals.append(int(round(v)) if integral else round(v, 10))
    return vals


def parse_values(key: str, value: Any, where: str) -> tuple[Any, ...]:
    """The values of one grid key from a string (``"4,5,6"``, ``"8:12"``, ``"8:12:0.5"``), a list or a scalar.

    A range ``START:STOP[:STEP]`` includes STOP when the steps land on it;
    STEP defaults to 1. Values are type-checked for ``key``; raises BhrError.
    """
    if key not in GRID_KEYS:
        raise BhrError(f"{where}: {excerpt(key)} is not a parameter a sweep can vary; {suggest(key, GRID_KEYS)}")
    if isinstance(value, str):
        text = value.strip()
        if not text:
            raise BhrError(f"{where}: {key} has no values; give e.g. {key}=4,5,6 or {key}=4:8")
        if ((key in CONSTRAINT_KEYS and CONSTRAINT_KEYS[key] is not None)
                or key in RUN_CHOICE_KEYS | TRAJ_CHOICE_KEYS | BOOL_KEYS):
            raw: list[Any] = [t.strip() for t in text.split(",")]
        else:  # values and ranges, comma-separated, in any mix: 4,5,6 or 8:12:0.5 or 3-5,7 (as --colons takes)
            raw = []
            for item in text.split(","):
                raw.extend(_values(item, key, where))
                if len(raw) > _MAX_DESIGNS:
                    raise BhrError(f"{where}: {key} has more than {_MAX_DESIGNS} values; use fewer or a larger step")
    elif isinstance(value, list):
        raw = list(value)
    else:
        raw = [value]
    if not raw:
        raise BhrError(f"{where}: {key} has no values")
    out = [check_value(key, v, where) for v in raw]
    seen = set()
    for v in out:
        if v in seen:
            raise BhrError(f"{where}: {key} lists {excerpt(v)} twice; give each value once")
        seen.add(v)
    return tuple(out)


def parse_grid_option(text: str) -> tuple[str, tuple[Any, ...]]:
    """``KEY=VALUES`` from the command line (``--grid modules=4:8``)."""
    if "=" not in text:
        raise BhrError(f"--grid {excerpt(text)} must be KEY=VALUES, e.g. --grid modules=4,5,6 or --grid alpha=8:12:0.5")
    key, _, values = text.partition("=")
    key = key.strip().replace("-", "_")
    return key, parse_values(key, values, "--grid")


@dataclass(frozen=True)
class Sweep:
    """Trajectories x solvers x grid. ``traj_sources`` maps each trajectory label to what is loaded."""

    trajs: tuple[str, ...] = ("curve",)
    solvers: tuple[str, ...] = ("thesis",)
    grid: tuple[tuple[str, tuple[Any, ...]], ...] = ()
    title: str = "bhr sweep"
    description: str = ""
    traj_sources: dict[str, str] = field(default_factory=dict)
    #: The robot every design starts from (a robot file's fields), before its grid values; () = bhr's defaults.
    robot: tuple[tuple[str, Any], ...] = ()
    robot_file: str | None = None
    #: Further keys of each run's summary to keep in its row, after :data:`METRICS` (e.g. lumen keys).
    extra: tuple[str, ...] = ()
    #: Replay every run as the physical robot against the wall (bhr._studies.physics) with these options
    #: (``max_wall_force`` among them); () = no replay.
    physics: tuple[tuple[str, Any], ...] = ()
    #: End every run where its robot leaves the lumen, except the trail model's (an idealisation that plans its
    #: trail inside the lumen), when the grid does not give ``stop_at_wall`` itself.
    stop_at_wall: bool = False

    @property
    def axes(self) -> list[tuple[str, tuple[Any, ...]]]:
        """Every axis of the product in order: traj, solver, then the grid keys."""
        return [("traj", self.trajs), ("solver", self.solvers), *self.grid]

    @property
    def keys(self) -> list[str]:
        return [k for k, _ in self.axes]

    def __len__(self) -> int:
        return math.prod(len(v) for _, v in self.axes)

    def designs(self) -> list[dict[str, Any]]:
        """One dict per design, in order (the last axis varies fastest)."""
        keys = self.keys
        designs = [dict(zip(keys, combo)) for combo in itertools.product(*(v for _, v in self.axes))]
        if self.stop_at_wall and "stop_at_wall" not in keys:
            for d in designs:
                d["stop_at_wall"] = d.get("locomotion") != "trail"
        return designs


def _as_list(value: Any, key: str, where: str) -> tuple[str, ...]:
    items = value if isinstance(value, list) else [value]
    if not items or not all(isinstance(v, str) and v.strip() for v in items):
        raise BhrError(f"{where}: {key} must be a name or a list of names, got {excerpt(value)}")
    if len(set(items)) != len(items):
        raise BhrError(f"{where}: {key} lists a name twice; give each once")
    return tuple(items)


def sweep_from_toml(data: dict[str, Any], source: str = "sweep", base_dir: str | os.PathLike[str] = ".") -> Sweep:
    """A :class:`Sweep` from a parsed TOML document (``traj``, ``solver``, ``[grid]``, ``title``)."""
    check_document(data, _TOP_KEYS, source, "key", "parameters go in the [grid] table")
    grid_table = data.get("grid", {})
    if not isinstance(grid_table, dict):
        raise BhrError(f"{source}: [grid] must be a table of KEY = values")
    grid = tuple((k, parse_values(k, v, f"{source}: [grid]")) for k, v in grid_table.items())
    trajs = _as_list(data.get("traj", "curve"), "traj", source)
    solvers = _as_list(data.get("solver", "thesis"), "solver", source)
    robot_file = None
    if "robot" in data:
        if not isinstance(data["robot"], str) or not data["robot"].strip():
            raise BhrError(f"{source}: robot must be the path of a robot file (TOML), got {excerpt(data['robot'])}")
        rp = Path(data["robot"]).expanduser()
        robot_file = str(rp if rp.is_absolute() else Path(base_dir) / rp)
    return build_sweep(trajs, solvers, grid, title=data.get("title", "bhr sweep"),
                       description=data.get("description", ""), base_dir=base_dir, where=source,
                       robot_file=robot_file)


def load_sweep(path: str | os.PathLike[str]) -> Sweep:
    """Read a sweep file (TOML); relative trajectory paths are taken from its folder."""
    p = Path(path)  # a folder, a FIFO or a missing file: read_toml says so in one line
    data = read_toml(p, "sweep file", "give a TOML file with traj, solver and a [grid] table")
    return sweep_from_toml(data, str(p), p.parent)


def build_sweep(trajs: Sequence[str], solvers: Sequence[str], grid: Iterable[tuple[str, tuple[Any, ...]]], *,
                title: str = "bhr sweep", description: str = "", base_dir: str | os.PathLike[str] = ".",
                where: str = "sweep", robot_file: str | os.PathLike[str] | None = None, replay: bool = False
                ) -> Sweep:
    """Check and assemble a sweep: known solvers, trajectories that load, values each design can start from.

    Each trajectory is loaded and each robot built once per grid value (the
    other keys at their first value), so a wrong key or a value out of range
    is reported before anything runs. What only fails in combination (a
    curve too short for some feed) is recorded per design when it runs.
    ``robot_file``: a robot description (TOML) every design starts from; its
    grid values replace the file's. ``replay``: the runs are replayed as the physical robot, whose options
    (:data:`bhr._studies.study.REPLAY_KEYS`) the grid may then vary.
    """
    grid = tuple(grid)
    keys = [k for k, _ in grid]
    for k in keys:
        if k in REPLAY_KEYS and not replay:
            raise BhrError(f"{where}: {k} is an option of the physical replay, which this {where} does not run; "
                           "vary it in a study judged by it: bhr traverse --max-wall-force N --grid "
                           f"{k}=...")
    dup = {k for k in keys if keys.count(k) > 1}
    if dup:
        raise BhrError(f"{where}: grid key {excerpt(sorted(dup)[0])} is given twice; give each key once")
    if not trajs or not solvers:
        raise BhrError(f"{where}: a sweep needs at least one trajectory and one solver")
    # tables name a solver one way (seed: thesis)
    solvers = tuple(dict.fromkeys(check_solver_name(s, where) for s in solvers))
    count = len(trajs) * len(solvers) * math.prod(len(v) for _, v in grid)
    if count > _MAX_DESIGNS:  # before a trajectory is loaded or a colon drawn for any of them
        raise BhrError(f"{where}: {count} designs is more than {_MAX_DESIGNS}; use fewer values")
    shipped = set(builtin_names())
    sources = {}
    base = Path(base_dir)
    for t in trajs:
        if t in shipped:
            sources[t] = t
        else:
            p = Path(t).expanduser()
            sources[t] = str(p if p.is_absolute() else base / p)
    base_robot: dict[str, Any] = {}
    if robot_file is not None:
        from dataclasses import fields

        rb = load_robot_file(robot_file).robot
        base_robot = {f.name: getattr(rb, f.name) for f in fields(rb)}
    first = {k: v[0] for k, v in grid}
    robot_first = {k: v for k, v in first.items() if k in ROBOT_KEYS}
    traj_first = {k: v for k, v in first.items() if k in TRAJ_KEYS}

    def check_robot(params: dict[str, Any], what: str) -> Any:
        try:
            return make_robot(params, base_robot)
        except BhrError as exc:
            raise BhrError(f"{where}: {what}: {str(exc).splitlines()[0]}") from None

    robot = check_robot(robot_first, "robot")
    for k, values in grid:
        if k in ROBOT_KEYS:
            for v in values[1:]:
                check_robot({**robot_first, k: v}, f"{k} = {v}")
    body = dict(grid).get("body_modules")
    if body is not None:  # the whole robot is at least its head, with every head of the grid
        most = max(check_robot({**robot_first, "modules": m}, f"modules = {m}").modules
                   for m in dict(grid).get("modules", (robot.modules,)))
        try:
            check_body({"body_modules": min(body)}, make_robot({**robot_first, "modules": most}, base_robot))
        except BhrError as exc:
            raise BhrError(f"{where}: {exc}") from None
    for loco in dict(grid).get("locomotion", ()):  # each design's run as bhr follow would refuse it
        from bhr._run.driver import check_locomotion

        for stop in dict(grid).get("stop_at_wall", (None,)):
            for every in dict(grid).get("all_poses", (None,)):
                try:
                    check_locomotion(loco, stop, every)
                except BhrError as exc:
                    said = f", all_poses = {every}" if every is not None else ""
                    raise BhrError(f"{where}: locomotion = {loco}, stop_at_wall = {stop}{said}: {exc}") from None
    for t in trajs:
        def check_traj(params: dict[str, Any], what: str, t: str = t) -> None:
            try:
                src, prm = colon_source(sources[t], params)
                load_trajectory(src, feed=robot.feed, **prm)
            except BhrError as exc:
                raise BhrError(f"{where}: trajectory {t}{what}: {str(exc).splitlines()[0]}") from None

        if t in GENERATORS:
            for k in traj_first:
                if k not in GENERATORS[t].params and k not in TRAJ_CHOICE_KEYS:
                    raise BhrError(f"{where}: grid key {excerpt(k)} is not a parameter of the {t} trajectory (its "
                                   f"parameters: {', '.join(GENERATORS[t].params) or 'none'}); sweep it on its own")
        check_traj(traj_first, "")
        for k, values in grid:
            if k in TRAJ_KEYS:
                for v in values[1:]:
                    check_traj({**traj_first, k: v}, f" with {k} = {v}")
    sweep = Sweep(tuple(trajs), tuple(solvers), grid, title, description, sources, tuple(base_robot.items()),
                  None if robot_file is None else str(robot_file))
    if len(sweep) > _MAX_DESIGNS:
        raise BhrError(f"{where}: {len(sweep)} designs is more than {_MAX_DESIGNS}; use fewer values")
    return sweep


# ------------------------------------------------------------------------------------------ running


def colon_source(traj_source: str, params: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """The trajectory to load and its parameters: a study's colon given as a real colon's name in place of an
    anatomy seed (``seed = "gca:VHM"``) is that real colon."""
    seed = params.get("seed")
    if isinstance(seed, str) and seed.startswith("gca:"):
        return seed, {k: v for k, v in params.items() if k != "seed"}
    return traj_source, params
