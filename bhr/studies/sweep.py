"""Design sweeps: follow trajectories with a grid of robot designs, in parallel or on a Dask cluster.

A sweep is the product of its trajectories, its solvers and a grid of
parameter values: any trajectory or robot option by its command-line long
name with underscores (``modules``, ``module_length``, ``alpha``,
``feed_divisor``, ``radius``, ``angle``, ...), the same keys as a batch file
(:mod:`bhr.studies.report`). Every design is one ``bhr follow`` run without figures;
the result is one row per design with its worst errors and, where the
trajectory has a lumen, its minimum clearance.

:func:`run_sweep` runs the designs through the studies' executor
(:mod:`bhr.studies.executor`): in this process (``jobs=1``), in a pool of worker
processes (``jobs>1``; the workers load the compiled kernels from numba's
on-disk cache once each), or on an existing Dask distributed cluster
(``scheduler="tcp://host:port"``); every path runs the same
:func:`run_design` on the same designs, so the rows are the same.

Neither matplotlib nor Dask is imported until a heat-map is drawn or a
scheduler is given.
"""
from __future__ import annotations

import itertools
import math
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

from bhr import __version__
from bhr.output.atomic import write_json, write_text
from bhr.settings.errors import BhrError
from bhr.settings.inputs import check_document, read_toml
from bhr.studies.cluster import connect_scheduler, dask_missing
from bhr.studies.executor import capture, run_jobs
from bhr.model.generators import GENERATORS, builtin_names, load_trajectory
from bhr.run.driver import VERDICTS, BhrWarning, follow
from bhr.output.htmlpage import PAGE_END, escape, figure, fmt, page_head, table
from bhr.settings.options import BY_NAME, LIMITS, MAX_NUMBER_CHARS, by_group, excerpt, solver_options_for
from bhr.model.robot import Robot
from bhr.model.robotfile import load_robot_file
from bhr.solvers import check_solver_name
from bhr.settings.names import AXIS_NAMES, COLUMN_TITLES, axis_label, axis_value, column_title
from bhr.settings.names import label as _label
from bhr.studies.study import (BOOL_KEYS, CONSTRAINT_KEYS, NUMBER_KEYS, ROBOT_KEYS, TRAJ_KEYS, check_body, check_value,
                       csv_text, finished_cell, verdict_cell, verdict_class,
                       make_robot, sim_options, suggest, summary_row, warm_up)

__all__ = ["Sweep", "SweepResult", "GRID_KEYS", "parse_grid_option", "parse_values", "sweep_from_toml",
           "load_sweep", "build_sweep", "run_design", "run_chunk", "run_sweep", "heatmap_axes",
           "heatmap_figure", "write_outputs", "METRICS", "dask_missing", "connect_scheduler", "make_robot",
           "axis_label", "axis_value", "column_title", "AXIS_NAMES", "COLUMN_TITLES"]

#: Keys a grid may vary: trajectory and robot options, and the constrained solvers' options.
#: How a run is simulated, by name (``locomotion = thesis, trail``; ``reach = cecum``).
RUN_CHOICE_KEYS = frozenset(o.name for o in by_group("run") if o.choices is not None)
#: Trajectory options taken by name (``lumen_end = closed, open``), for every trajectory with a lumen.
TRAJ_CHOICE_KEYS = frozenset(o.name for o in by_group("trajectory") if o.choices is not None)
GRID_KEYS = frozenset(NUMBER_KEYS | set(CONSTRAINT_KEYS) | RUN_CHOICE_KEYS | TRAJ_CHOICE_KEYS | BOOL_KEYS)
#: Result columns of every design, after its design keys.
METRICS = ("status", "finished", "verdict", "steps", "tip_max_error_mm", "tip_final_error_mm", "points_max_error_mm",
           "orientation_max_deg", "global_max", "tip_rmse_mm", "tip_orientation_rmse_deg", "tolerance_exceeded",
           "min_clearance_mm", "min_turn_radius_mm")
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
    #: Replay every run as the physical robot against the wall (bhr.studies.physics) with these options
    #: (``max_wall_force`` among them); () = no replay.
    physics: tuple[tuple[str, Any], ...] = ()

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
        return [dict(zip(keys, combo)) for combo in itertools.product(*(v for _, v in self.axes))]


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
                where: str = "sweep", robot_file: str | os.PathLike[str] | None = None) -> Sweep:
    """Check and assemble a sweep: known solvers, trajectories that load, values each design can start from.

    Each trajectory is loaded and each robot built once per grid value (the
    other keys at their first value), so a wrong key or a value out of range
    is reported before anything runs. What only fails in combination (a
    curve too short for some feed) is recorded per design when it runs.
    ``robot_file``: a robot description (TOML) every design starts from; its
    grid values replace the file's.
    """
    grid = tuple(grid)
    keys = [k for k, _ in grid]
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


#: What a run's row gets from its physical replay (:func:`run_design` with ``physics``).
PHYSICS_KEYS = ("peak_wall_force_n", "wall_stretch_mm", "physical_cecum_step", "physically_traversed")


def run_design(design: dict[str, Any], traj_source: str, base_robot: dict[str, Any] | None = None,
               extra: Sequence[str] = (), physics: Sequence[tuple[str, Any]] = ()) -> dict[str, Any]:
    """Follow one design's trajectory; return its row (design keys, :data:`METRICS`, then the summary's
    ``extra`` keys as they are, None where the summary lacks one; with ``physics``, the run replayed as the
    physical robot with those options: :data:`PHYSICS_KEYS`). Never raises."""
    row = _blank_row(design, extra)
    if physics:
        row.update({k: None for k in PHYSICS_KEYS})
    with capture(row):  # one failed design must not stop the sweep
        robot = make_robot({k: v for k, v in design.items() if k in ROBOT_KEYS}, base_robot)
        row["min_turn_radius_mm"] = robot.min_turn_radius
        source, params = colon_source(traj_source, {k: v for k, v in design.items() if k in TRAJ_KEYS})
        tr = load_trajectory(source, feed=robot.feed, **params)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            res = follow(tr, solver=design["solver"], robot=robot,
                         solver_options=solver_options_for(design["solver"], design), **sim_options(design))
        summary = res.summary.to_dict()
        row.update(summary_row(summary))
        row.update({k: summary.get(k) for k in extra})
        if physics:
            from bhr.studies.physics import replay_physics

            ps = replay_physics(res, **dict(physics)).summary()
            row.update({"peak_wall_force_n": ps["max_total_force_n"], "wall_stretch_mm": ps["max_stretch_mm"],
                        "physical_cecum_step": ps["reached_cecum_step"], "physically_traversed": ps["traversed"]})
    return row


def _blank_row(design: dict[str, Any], extra: Sequence[str] = (), status: str = "ok") -> dict[str, Any]:
    return {**design, **{k: None for k in (*METRICS, *extra)}, "status": status}


def _lost_design(item: tuple[Any, ...], why: str) -> dict[str, Any]:
    """The row of a design whose worker process died."""
    return _blank_row(item[0], item[3] if len(item) > 3 else (), f"failed: {why}")


def run_chunk(chunk: Sequence[tuple[Any, ...]]) -> list[tuple[int, dict[str, Any]]]:
    """Run ``(index, design, trajectory source[, base robot fields[, extra keys]])`` items; return ``(index, row)``.

    Kept for callers of earlier versions; :func:`run_sweep` hands single designs to :mod:`bhr.studies.executor`.
    """
    return [(item[0], run_design(*item[1:])) for item in chunk]


def _design_job(item: tuple[Any, ...]) -> dict[str, Any]:
    """One design: ``(design, trajectory source, base robot fields[, extra keys])``, the job of every path."""
    return run_design(*item)


@dataclass
class SweepResult:
    sweep: Sweep
    rows: list[dict[str, Any]]
    wall_time_s: float
    runner: str  # "in-process", "N processes" or "dask tcp://..."
    workers: int

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r["status"] != "ok"]

    @property
    def columns(self) -> list[str]:
        return ["design", *self.sweep.keys, *METRICS, *self.sweep.extra]


def run_sweep(sweep: Sweep, *, jobs: int | None = None, scheduler: Any = None,
              progress: Callable[[int, int], None] | None = None) -> SweepResult:
    """Run every design of ``sweep``; rows come back in design order whatever ran them.

    ``jobs``: worker processes (default: the number of CPUs; 1 runs in this
    process). ``scheduler``: address of a Dask distributed scheduler to run
    on instead, or a ``distributed.Client`` (see :func:`connect_scheduler`).
    ``progress(done, total)`` is called as designs finish.
    """
    base = dict(sweep.robot) or None
    tail: tuple[Any, ...] = (sweep.extra, sweep.physics) if sweep.physics else ((sweep.extra,) if sweep.extra else ())
    items = [(d, sweep.traj_sources.get(d["traj"], d["traj"]), base, *tail) for d in sweep.designs()]
    done = run_jobs(_design_job, items, jobs=jobs, scheduler=scheduler, warm_up=warm_up,
                    warm_up_args=(sweep.solvers,), lost=_lost_design,
                    progress=None if progress is None else (lambda d, t, _row: progress(d, t)))
    final = [{"design": i + 1, **r} for i, r in enumerate(done.rows)]
    return SweepResult(sweep, final, done.wall_time_s, done.runner, done.workers)


# ------------------------------------------------------------------------------------------ heat-map


def heatmap_axes(sweep: Sweep, x: str | None = None, y: str | None = None) -> tuple[str | None, str | None]:
    """The two axes a heat-map shows: ``x`` and ``y`` when given, else the two with the most values.

    Axes with one value are never picked by default; ties keep the sweep's
    order. ``None`` for an axis means a single row or column.
    """
    sizes = {k: len(v) for k, v in sweep.axes}
    for name, val in (("x", x), ("y", y)):
        if val is not None and val not in sizes:
            raise BhrError(f"heat-map {name} axis {excerpt(val)} is not an axis of this sweep; choose one of "
                           f"{', '.join(sizes)}")
    if x is not None and x == y:
        raise BhrError("heat-map x and y axes must differ")
    ranked = sorted((k for k in sweep.keys if sizes[k] > 1 and k not in (x, y)), key=lambda k: -sizes[k])
    if x is None and y is None:
        pair = sorted(ranked[:2], key=sweep.keys.index)  # the two biggest, shown in the sweep's order
        x = pair[0] if pair else None
        y = pair[1] if len(pair) > 1 else None
    elif x is None:
        x = ranked[0] if ranked else None
    elif y is None:
        y = ranked[0] if ranked else None
    return x, y


def _grid_values(sweep: Sweep, key: str | None) -> tuple[Any, ...]:
    return dict(sweep.axes)[key] if key is not None else (None,)


def heatmap_cells(result: SweepResult, x: str | None, y: str | None, metric: str,
                  worst: Callable[[Iterable[float]], float],
                  fixed: dict[str, Any] | None = None) -> list[list[float]]:
    """``metric`` per (y, x) cell, the ``worst`` over every other axis; NaN where no design has it.

    ``fixed`` keeps only the designs with those values (e.g. one panel's module length).
    """
    xs, ys = _grid_values(result.sweep, x), _grid_values(result.sweep, y)
    xi = {v: k for k, v in enumerate(xs)}
    yi = {v: k for k, v in enumerate(ys)}
    cells: list[list[list[float]]] = [[[] for _ in xs] for _ in ys]
    for r in result.rows:
        if fixed and any(r.get(k) != v for k, v in fixed.items()):
            continue
        v = r.get(metric)
        if r["status"] == "ok" and v is not None:
            cells[yi[r[y]] if y else 0][xi[r[x]] if x else 0].append(float(v))
    return [[worst(c) if c else math.nan for c in row] for row in cells]


#: At most this many panels, one per value of the third axis; more and the third axis joins the worst case.
MAX_PANELS = 9


def heatmap_panels(sweep: Sweep, x: str | None, y: str | None) -> str | None:
    """The axis whose values get a panel each: the biggest axis (most values) left after x and y, if any.

    On a tie a robot option (a design parameter) goes before a trajectory's, then the sweep's order.
    """
    rest = [k for k, v in sweep.axes if k not in (x, y) and 1 < len(v) <= MAX_PANELS]
    return max(rest, key=lambda k: (len(dict(sweep.axes)[k]), k in ROBOT_KEYS)) if rest else None


def _thesis_value(key: str) -> Any:
    """The thesis design's value of a robot key (bhr's default robot), or None for any other key."""
    return getattr(Robot(), key) if key in ROBOT_KEYS else None


def _row_tolerance(result: SweepResult, row: dict[str, Any]) -> float:
    """The position tolerance of a design (its grid value, the sweep's robot, or the thesis's 8 mm)."""
    try:
        return float(make_robot({k: v for k, v in row.items() if k in ROBOT_KEYS},
                                dict(result.sweep.robot) or None).tol_pos)
    except Exception:  # a failed design has no error to compare
        return math.inf


def heatmap_figure(result: SweepResult, x: str | None = None, y: str | None = None):
    """Worst point error and (when known) minimum clearance per (x, y) design.

    One panel per value of a third axis (:func:`heatmap_panels`), each cell the
    worst case over the remaining axes. Cells over the position tolerance are
    hatched; the thesis design (5 modules of 10 mm, alpha 10 deg, ...) is framed
    in red wherever the axes show it. :func:`bhr.output.sweep_plot.heatmap_figure` draws it.
    """
    import numpy as np

    from bhr.output.sweep_plot import HeatMetric
    from bhr.output.sweep_plot import heatmap_figure as draw

    x, y = heatmap_axes(result.sweep, x, y)
    z = heatmap_panels(result.sweep, x, y)
    xs, ys = _grid_values(result.sweep, x), _grid_values(result.sweep, y)
    zs = _grid_values(result.sweep, z)
    others = [k for k, v in result.sweep.axes if k not in (x, y, z) and len(v) > 1]
    over_cells = np.zeros((len(zs), len(ys), len(xs)), dtype=bool)
    ran = np.zeros((len(zs), len(ys), len(xs)), dtype=bool)  # some design of the cell ran (did not fail)
    xi = {v: k for k, v in enumerate(xs)}
    yi = {v: k for k, v in enumerate(ys)}
    zi = {v: k for k, v in enumerate(zs)}
    tols = set()
    for r in result.rows:
        e = r.get("points_max_error_mm")
        if r["status"] != "ok" or e is None:
            continue
        cell = (zi[r[z]] if z else 0, yi[r[y]] if y else 0, xi[r[x]] if x else 0)
        ran[cell] = True
        tol = _row_tolerance(result, r)
        tols.add(tol)
        if e > tol:
            over_cells[cell] = True
    thesis = {k: _thesis_value(k) for k in (x, y, z) if k is not None and _thesis_value(k) is not None}
    frames: list[tuple[int, int, int, int] | None] = []
    for zv in zs:
        frame = None
        if z not in thesis or zv == thesis[z]:
            tx = xs.index(thesis[x]) if x in thesis and thesis[x] in xs else (None if x in thesis else -1)
            ty = ys.index(thesis[y]) if y in thesis and thesis[y] in ys else (None if y in thesis else -1)
            if tx is not None and ty is not None and (tx >= 0 or ty >= 0):
                cx = [tx] if tx >= 0 else list(range(len(xs)))
                cy = [ty] if ty >= 0 else list(range(len(ys)))
                frame = (min(cx), min(cy), len(cx), len(cy))
        frames.append(frame)
    # one quantity per panel: the metric, and how a cell holding several designs shows it
    how = (f"each cell the worst over {', '.join(axis_label(o) for o in others)}" if others
           else "each cell one design")
    wanted = [("points_max_error_mm", "worst point error (mm)", max, "viridis")]
    if any(r.get("min_clearance_mm") is not None for r in result.rows):
        wanted.append(("min_clearance_mm", "minimum clearance (mm)", min, "viridis_r"))
    metrics = []
    for metric, label, worst, cmap in wanted:
        cells = [np.array(heatmap_cells(result, x, y, metric, worst, {z: zv} if z else None), dtype=float)
                 for zv in zs]
        titles = [f"{axis_value(z, zv)}\n{label}: {how}" if z else f"{label}:\n{how}" for zv in zs]
        error = metric == "points_max_error_mm"
        metrics.append(HeatMetric(label, cmap, cells, titles, over=list(over_cells) if error else None,
                                  marks=sorted(tols) if error else ()))
    tol_text = ", ".join(f"{t:g}" for t in sorted(tols) if math.isfinite(t)) or "8"
    what = ", ".join(f"{axis_label(k).split(' (')[0]} {_label(v)}" for k, v in thesis.items())
    return draw(metrics, list(ran), frames, [_label(v) for v in xs] if x else [""],
                [_label(v) for v in ys] if y else [""], axis_label(x), axis_label(y), tol_text, what,
                f"{result.sweep.title}: {what_ran(result)}")


# ------------------------------------------------------------------------------------------ outputs


def results_csv(result: SweepResult) -> str:
    """One row per design: design number, its keys, then :data:`METRICS` (floats in full, unknown empty)."""
    return csv_text(result.rows, result.columns)


def best_rows(result: SweepResult, count: int = 10) -> list[dict[str, Any]]:
    """The ``count`` rows (one design on one trajectory) with the smallest worst point error (design order
    breaks ties). The rankings bhr prints and pages show are :func:`best_designs`."""
    ok = [r for r in result.rows if r["status"] == "ok"]
    return sorted(ok, key=lambda r: (r["points_max_error_mm"], r["design"]))[:count]


def robot_design_keys(sweep: Sweep) -> list[str]:
    """The sweep's axes that make a robot design (solver, robot and solver settings): all but the trajectory's."""
    return [k for k in sweep.keys if k != "traj" and k not in TRAJ_KEYS]


def best_designs(result: SweepResult, count: int | None = 10) -> list[dict[str, Any]]:
    """Robot designs ranked as the heat-map shows them: each by its worst over every trajectory it ran.

    A design is one combination of :func:`robot_design_keys`; its ``points_max_error_mm`` is the largest
    over its trajectories (rows), ``min_clearance_mm`` the smallest, ``worst_row`` the design number of
    the row with the largest error, ``trajectories`` how many rows it has and ``failed`` how many of
    them failed. A design with a failed row ranks after every design whose rows all ran. Ties: the
    first design number. ``count=None`` returns them all.
    """
    keys = robot_design_keys(result.sweep)
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in result.rows:
        groups.setdefault(tuple(r.get(k) for k in keys), []).append(r)
    out = []
    for vals, rows in groups.items():
        ok = [r for r in rows if r["status"] == "ok" and r.get("points_max_error_mm") is not None]
        if not ok:
            continue
        worst = max(ok, key=lambda r: (r["points_max_error_mm"], -r["design"]))
        clear = [r["min_clearance_mm"] for r in ok if r.get("min_clearance_mm") is not None]
        out.append({**dict(zip(keys, vals)), "design": rows[0]["design"], "worst_row": worst["design"],
                    "worst_traj": worst.get("traj"), "points_max_error_mm": worst["points_max_error_mm"],
                    "min_clearance_mm": min(clear) if clear else None, "trajectories": len(rows),
                    "failed": len(rows) - len(ok)})
    out.sort(key=lambda d: (d["failed"] > 0, d["points_max_error_mm"], d["design"]))
    return out if count is None else out[:count]


def _best_html(result: SweepResult, count: int = 10) -> str:
    """The ranking the heat-map shows: robot designs by their worst point error over the trajectories."""
    keys = robot_design_keys(result.sweep)
    ranked = best_designs(result, None)
    many = len({tuple(r.get(k) for k in keys) for r in result.rows}) < len(result.rows)
    title = ("Best designs (smallest worst point error over the trajectories, as the heat-map shows)" if many
             else "Best designs (smallest worst point error)")
    cols = ["rank", *keys, "points_max_error_mm", "min_clearance_mm"] + (["worst_traj", "worst_row",
                                                                            "trajectories"] if many else [])
    heads = {"rank": "rank", "points_max_error_mm": "worst point error (mm)", "min_clearance_mm":
             "min clearance (mm)", "worst_traj": "worst on", "worst_row": "its row (design #)",
             "trajectories": "rows"}

    def cell(item: tuple[int, dict[str, Any]], c: str) -> tuple[str, str]:
        n, d = item
        if c == "rank":
            return str(n), ""
        v = _label(d[c]) if c in ("traj", "worst_traj") else d.get(c)
        return escape(fmt(v)), "l" if c in ("traj", "solver", "worst_traj") else (
            "rank" if c == "points_max_error_mm" else "")

    shown = ranked[:count]
    note = "" if len(ranked) <= count else (f"<p class=\"meta\">The best {count} of {len(ranked)} designs; every "
                                            "row is in the table below and in results.csv.</p>\n")
    return (f"<h2>{escape(title)}</h2>\n" + table("best", cols, list(enumerate(shown, 1)), cell, heads=heads,
                                                 head_class=lambda c: "rank" if c == "points_max_error_mm" else "")
            + note)


def _html(result: SweepResult, heatmap: str | None) -> str:
    # The ranking column (worst point error) right after the design's values, so it shows without scrolling.
    rank = "points_max_error_mm"
    # "finished" (how the run ended, or FAILED) and the verdict (followed, out of tolerance, touched the wall, left
    # the lumen) in words, apart: the status column of a run that raised is its error, in the row's own line
    cols = ["design", *result.sweep.keys, rank, *[m for m in METRICS if m not in (rank, "status")]]

    def cell(item: tuple[int, dict[str, Any]], c: str) -> tuple[str, str]:
        n, r = item
        if c == "rank":
            return str(n), ""
        if c == "finished":
            return escape(finished_cell(r) if r["status"] == "ok" else f"FAILED: {r['status']}"), (
                "l" if r["status"] == "ok" else "l bad")
        if c == "verdict":
            return escape(verdict_cell(r)), f"l {verdict_class(r)}" if r["status"] == "ok" else "l"
        v = _label(r[c]) if c == "traj" else r.get(c)
        return escape(fmt(v)), "l" if c in ("traj", "solver") else ("rank" if c == rank else "")

    def designs(rows: Sequence[dict[str, Any]], tid: str, ranked: bool = False) -> str:
        return table(tid, ["rank", *cols] if ranked else cols, list(enumerate(rows, 1)), cell,
                     head_class=lambda c: "rank" if c == rank else "",
                     row_class=lambda item: "ok" if item[1]["status"] == "ok" else "failed")

    s = result.sweep
    parts = [page_head(s.title), f"<h1>{escape(s.title)}</h1>\n"]
    if s.description:
        parts.append(f"<p>{escape(s.description)}</p>\n")
    axes = "; ".join(f"{k}: {', '.join(_label(v) for v in vals)}" for k, vals in s.axes)
    if s.robot_file:
        axes += f"; robot file: {s.robot_file}"
    parts.append(f"<p class=\"meta\">{what_ran(result)}, {len(result.failed)} failed, "
                 f"{result.wall_time_s:.1f} s on {escape(result.runner)}; bhr {escape(__version__)}.<br>"
                 f"{escape(axes)}</p>\n")
    if heatmap:
        parts.append(figure(heatmap, "heat-map of worst error per design",
                            "Worst point error (largest error of any point at any step) and, where the trajectory "
                            "has a lumen, minimum clearance per design; hatched: over the position tolerance; "
                            "framed in red: the thesis design; grey: every design in the cell failed"))
    parts.append(_best_html(result))
    parts.append("<h2>Every design</h2>\n")
    parts.append(designs(result.rows, "designs"))
    parts.append(PAGE_END)
    return "".join(parts)


def write_outputs(result: SweepResult, out_dir: str | os.PathLike[str], *, plot: bool = True,
                  x: str | None = None, y: str | None = None) -> list[Path]:
    """Write results.csv, results.json, heatmap.png (when ``plot``) and index.html into ``out_dir``."""
    out = Path(out_dir)
    files = [out / "results.csv", out / "results.json"]
    write_text(files[0], results_csv(result))
    s = result.sweep
    hx, hy = heatmap_axes(s, x, y)
    write_json(files[1], {
        "title": s.title,
        "bhr_version": __version__,
        "axes": {k: [v for v in vals] for k, vals in s.axes},
        "trajectory_sources": s.traj_sources,
        "robot_file": s.robot_file,
        "robot": dict(s.robot) or None,
        "designs": len(result.rows),
        "failed": len(result.failed),
        "wall_time_s": result.wall_time_s,
        "runner": result.runner,
        "workers": result.workers,
        "heatmap": {"x": hx, "y": hy},
        "rows": result.rows,
    })
    heat = None
    if plot:
        from bhr.output.figure import save_figure

        files.append(save_figure(heatmap_figure(result, x, y), out / "heatmap.png"))
        heat = "heatmap.png"
    write_text(out / "index.html", _html(result, heat))
    files.append(out / "index.html")
    return files


def what_ran(result: SweepResult) -> str:
    """'1000 runs (500 designs x 2 trajectories)', or '30 designs' when each design ran once.

    A robot design runs once per trajectory: runs are counted as runs, and designs as the ranking and the
    heat-map count them (the terminal, the heat-map's title and the page say the same)."""
    runs, designs = len(result.rows), len(best_designs(result, None))
    if designs in (0, runs):
        return f"{runs} designs"
    return f"{runs} runs ({designs} designs x {runs // designs} trajectories)"


def format_summary(result: SweepResult, count: int = 5) -> list[str]:
    """A few lines for the terminal: counts, time, and the best designs."""
    ranked = best_designs(result, None)
    runs = len(result.rows)
    lines = [f"{what_ran(result)} on {result.runner}: {runs - len(result.failed)} finished, "
             f"{len(result.failed)} failed, {result.wall_time_s:.2f} s"]
    best = ranked[:count]
    if best:
        design_keys = robot_design_keys(result.sweep)
        many = len({tuple(r.get(k) for k in design_keys) for r in result.rows}) < len(result.rows)
        keys = [k for k, v in result.sweep.axes if len(v) > 1 and k in design_keys] or (
            design_keys if many else [k for k, v in result.sweep.axes if len(v) > 1] or ["traj"])
        what = "worst point error over the trajectories (mm), as the heat-map shows" if many else \
            "worst point error (mm)"
        shown = f"Best {len(best)} of {len(ranked)} designs" if len(ranked) > len(best) else f"Best {len(best)}"
        lines.append(f"{shown} by {what}:")
        for r in best:
            desc = ", ".join(f"{k}={_label(r[k])}" for k in keys if k in r) or f"traj={_label(r.get('worst_traj'))}"
            clear = "" if r["min_clearance_mm"] is None else f", clearance {r['min_clearance_mm']:.2f} mm"
            where = f" (worst: {_label(r['worst_traj'])}, row #{r['worst_row']})" if many else ""
            lines.append(f"  #{r['design']}: {desc}: {r['points_max_error_mm']:.3f}{clear}{where}")
    verdicts: dict[str, int] = {}
    for r in result.rows:
        if r["status"] == "ok" and r.get("verdict"):
            verdicts[r["verdict"]] = verdicts.get(r["verdict"], 0) + 1
    if verdicts:
        lines.append("Verdicts: " + ", ".join(f"{verdicts[v]} {v}" for v in VERDICTS if v in verdicts) + ".")
    reasons: dict[str, int] = {}
    for r in result.failed:
        reasons[r["status"]] = reasons.get(r["status"], 0) + 1
    for reason, n in sorted(reasons.items(), key=lambda kv: -kv[1])[:5]:
        lines.append(f"{n} x {reason}")
    return lines
