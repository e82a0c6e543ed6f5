"""Batch error reports: many ``bhr follow`` runs from one TOML file, one HTML page to share.

A batch file is a list of ``[[run]]`` tables. Each names the run, the
trajectory (a built-in name or a trajectory file), the solver, and any
trajectory or robot option by its command-line long name with underscores
(``radius``, ``angle``, ``modules``, ``module_length``, ``alpha``, ...). An
optional ``[defaults]`` table gives values every run starts from, and
``title`` names the report::

    title = "Chapter 7"
    [defaults]
    solver = "thesis"
    [[run]]
    name = "curve 90"
    traj = "curve"
    radius = 70
    angle = 90

Everything the batch file alone decides (known keys, types, unique names,
the robot's values, the solver, a built-in trajectory's parameters) is checked
before anything runs, and a mistake is reported as one line naming the file,
the run and the key. What depends on other files or on running (a trajectory
or robot file, the solve) is checked by the run itself: a run that fails is
recorded with its reason and the other runs still run.

:func:`run_batch` writes into the output folder ``index.html`` (the summary
table first, then each run's figures), ``summary.csv`` and ``summary.json``
(one row per run) and, per run, ``runs/<name>/`` with the four figures of
``bhr follow``, ``run.json``, ``steps.csv`` and (binary solvers) ``codes.csv``.
Every file is written atomically.

This module does not import matplotlib until a run draws its figures.
"""
from __future__ import annotations

import contextlib
import os
import re
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from bhr import __version__
from bhr.output._atomic import write_json, write_text
from bhr._settings.errors import BhrError
from bhr._settings.inputs import check_document, read_text, read_toml
from bhr._studies.executor import capture, run_jobs
from bhr.model._generators import GENERATORS, builtin_names, load_trajectory
from bhr._run.driver import BhrWarning, follow
from bhr.output._htmlpage import PAGE_END, escape, figure, fmt, page_head
from bhr.output._htmlpage import table as html_table
from bhr._settings.options import LIMITS, by_group, check_run_name, excerpt, solver_options_for
from bhr.model._robot import Robot
from bhr.model._robotfile import load_robot_file
from bhr.output._steptable import write_run_files
from bhr.solvers import check_solver_name, get_solver
from bhr._studies.study import (BOOL_KEYS, CONSTRAINT_KEYS, INT_KEYS, NUMBER_KEYS, ROBOT_KEYS, SOLVER_KEYS, TRAJ_KEYS,
                       check_value, finished_cell, verdict_cell, verdict_class,
                       check_body, sim_options, suggest, summary_row, warm_up)
from bhr._studies.study import csv_text as _csv_text

__all__ = ["RunSpec", "Batch", "load_batch", "parse_batch", "execute_run", "run_batch", "BatchReport",
           "ROW_FIELDS", "TRAJ_KEYS", "ROBOT_KEYS", "CONSTRAINT_KEYS", "SOLVER_KEYS", "NUMBER_KEYS", "INT_KEYS",
           "summary_row", "format_table", "html_page", "csv_text", "robot_from_options"]

# The keys of a run table (TRAJ_KEYS, ROBOT_KEYS, ...) come from the option registry, via bhr._studies.study.
_STRING_KEYS = frozenset({"name", "description", "traj", "solver", "robot"}) | {
    o.name for o in by_group("constraint", "trajectory") if o.choices is not None}
RUN_KEYS = frozenset(NUMBER_KEYS | _STRING_KEYS | BOOL_KEYS)
_TOP_KEYS = ("title", "description", "defaults", "run")

#: Columns of summary.csv, in order (summary.json rows have these and more).
ROW_FIELDS = ("name", "status", "finished", "verdict", "traj", "solver", "steps", "tip_max_error_mm",
              "tip_final_error_mm", "points_max_error_mm", "orientation_max_deg", "global_max", "tip_rmse_mm",
              "tip_orientation_rmse_deg", "tolerance_exceeded", "min_clearance_mm", "warnings", "solve_time_s",
              "wall_time_s")

_FIGURES = (  # file, caption, thesis figures
    ("path.png", "Path and final pose", "Figs. 7.1, 7.5, 7.9, 7.13, 7.18"),
    ("position_errors.png", "Position error of each point", "Figs. 7.2, 7.6, 7.10, 7.14, 7.19"),
    ("orientation_errors.png", "Orientation error of each module", "Figs. 7.3, 7.7, 7.11, 7.15, 7.20"),
    ("global_errors.png", "Global error of each module", "Figs. 7.8, 7.12, 7.16, 7.21"),
    ("body_errors.png", "Errors of the body behind the head", ""),
    ("clearance.png", "Smallest clearance to the lumen wall at each step", ""),
)


@dataclass(frozen=True)
class RunSpec:
    """One run of a batch: what to follow, with which solver and robot."""

    name: str
    traj: str
    solver: str = "thesis"
    description: str = ""
    traj_params: dict[str, float] = field(default_factory=dict)
    robot_params: dict[str, Any] = field(default_factory=dict)  # Robot fields
    solver_options: dict[str, Any] = field(default_factory=dict)
    robot_file: str | None = None
    sim_options: dict[str, Any] = field(default_factory=dict)  # how the run is simulated (body_modules)

    def inputs(self) -> dict[str, Any]:
        """The run's table as given (batch keys), for summary.json."""
        out: dict[str, Any] = {"traj": self.traj, "solver": self.solver}
        out.update(self.traj_params)
        out.update(self.robot_params)
        out.update(self.solver_options)
        out.update(self.sim_options)
        if self.robot_file is not None:
            out["robot"] = self.robot_file
        return out


@dataclass(frozen=True)
class Batch:
    runs: tuple[RunSpec, ...]
    title: str = "bhr report"
    description: str = ""
    source: str = ""


def _check_table(table: Any, where: str, allowed: frozenset[str]) -> dict[str, Any]:
    if not isinstance(table, dict):
        raise BhrError(f"{where} must be a table of keys, got {type(table).__name__}")
    out = {}
    for key, value in table.items():
        if key not in allowed:
            raise BhrError(f"{where}: unknown key {excerpt(key)}; {suggest(key, allowed)}")
        out[key] = check_value(key, value, where)
    return out


def _resolve(path: str, base: Path) -> str:
    p = Path(path).expanduser()
    return str(p if p.is_absolute() else base / p)


def parse_batch(data: dict[str, Any], source: str = "batch", base_dir: str | os.PathLike[str] = ".") -> Batch:
    """A :class:`Batch` from the parsed TOML ``data``; relative paths are taken from ``base_dir``."""
    base = Path(base_dir)
    check_document(data, _TOP_KEYS, source, "top-level key", "runs are [[run]] tables")
    defaults = _check_table(data.get("defaults", {}), f"{source}: [defaults]", RUN_KEYS - {"name"})
    runs = data.get("run")
    if runs is None:
        raise BhrError(f"{source}: no runs; add at least one [[run]] table with name and traj")
    if isinstance(runs, list):
        check_run_count(len(runs), source)  # before any run is checked: a million took minutes
    if not isinstance(runs, list) or not all(isinstance(r, dict) for r in runs) or not runs:
        raise BhrError(f"{source}: 'run' must be a list of [[run]] tables with name and traj")
    specs: list[RunSpec] = []
    seen: dict[str, int] = {}
    for k, table in enumerate(runs, start=1):
        label = table.get("name") if isinstance(table.get("name"), str) else None
        where = f"{source}: run {k}" + (f" ({excerpt(label)})" if label else "")
        values = {**defaults, **_check_table(table, where, RUN_KEYS)}
        for need in ("name", "traj"):
            if need not in values:
                raise BhrError(f"{where}: missing key {need!r}; every [[run]] needs name and traj")
        name = check_run_name(values["name"], where)
        if name in seen:
            raise BhrError(f"{where}: name {excerpt(name)} is also run {seen[name]}'s; give every run its own name")
        seen[name] = k
        traj = values["traj"]
        tp = {key: values[key] if isinstance(values[key], str) else float(values[key]) for key in TRAJ_KEYS
              if key in values}
        if traj in GENERATORS:
            allowed = GENERATORS[traj].params
            for key in tp:
                if key not in allowed and key != "lumen_end":  # every trajectory with a lumen takes lumen_end
                    raise BhrError(f"{where}: the {traj} trajectory has no parameter {excerpt(key)} "
                                   f"(its parameters: {', '.join(allowed) or 'none'})")
        elif traj not in builtin_names():
            traj = _resolve(traj, base)
        solver = check_solver_name(values.get("solver", "thesis"), where)  # an alias (seed) is shown by its name
        spec = RunSpec(
            name=name, traj=traj, solver=solver, description=values.get("description", ""),
            traj_params=tp,
            robot_params={key: values[key] for key in ROBOT_KEYS if key in values},
            solver_options=solver_options_for(solver, values),
            robot_file=_resolve(values["robot"], base) if "robot" in values else None,
            sim_options=sim_options(values),
        )
        _check_values(spec, where)
        specs.append(spec)
    return Batch(tuple(specs), data.get("title", "bhr report"), data.get("description", ""), source)


def _check_values(spec: RunSpec, where: str) -> None:
    """Refuse values the batch file alone shows to be wrong: the robot, the solver, a built-in trajectory.

    What depends on other files (trajectory and robot files) is checked when
    the run runs, and a failure there is recorded for that run only.
    """
    if spec.robot_file is not None:
        return
    try:
        robot = Robot(**spec.robot_params)
        get_solver(spec.solver, robot, **spec.solver_options)
        check_body(spec.sim_options, robot)
        if spec.traj in GENERATORS:
            load_trajectory(spec.traj, feed=robot.feed, **spec.traj_params)
    except BhrError as exc:
        raise BhrError(f"{where}: {str(exc).splitlines()[0]}") from None


#: Runs a batch may hold: as many as a sweep or a traversability study (docs/commands.md#limits).
MAX_RUNS = LIMITS["study_runs"]
#: A line that opens a [[run]] table.
_RUN_HEADER = re.compile(r"^[ \t]*\[\[[ \t]*run[ \t]*\]\]", re.MULTILINE)


def check_run_count(count: int, source: str) -> None:
    """Refuse a batch of more runs than :data:`MAX_RUNS`, in the words a sweep refuses its designs."""
    if count > MAX_RUNS:
        raise BhrError(f"{source}: {count} runs is more than {MAX_RUNS}; use fewer runs")


def load_batch(path: str | os.PathLike[str]) -> Batch:
    """Read and check a batch file (TOML); raises BhrError with one line naming the problem."""
    p = Path(path)  # a folder, a FIFO or a missing file: read_toml says so in one line
    hint = "give a TOML file of [[run]] tables (see docs/report.md)"
    # counted before the TOML is parsed (11 s of CPU for a million runs); parse_batch counts the runs parsed
    check_run_count(len(_RUN_HEADER.findall(read_text(p, "batch file", hint))), str(p))
    data = read_toml(p, "batch file", hint)
    return parse_batch(data, str(p), p.parent)


def robot_from_options(robot_params: dict[str, Any], robot_file: str | None = None):
    """The :class:`bhr.model._robot.Robot` of a run: the robot file (if any) with the options on top."""
    if robot_file is not None:
        base = load_robot_file(robot_file).robot
        return base.replace(**robot_params) if robot_params else base
    return Robot(**robot_params)


def _slug(name: str) -> str:
    s = re.sub(r"[^a-z0-9._-]+", "-", name.lower(), flags=re.ASCII).strip("-.")[:80].strip("-.")
    return s or "run"


def execute_run(spec: RunSpec, out_dir: str | os.PathLike[str] | None = None, plots: bool = True) -> dict[str, Any]:
    """Run one batch entry; return its row. Never raises for a failed run: the row says why.

    With ``out_dir`` the run's figures (when ``plots``) and ``run.json`` are
    written there. Extra keys of the row: ``inputs``, ``trajectory``
    (name and parameters), ``robot``, ``stats`` (per point and module),
    ``figures`` (file names written).
    """
    t0 = time.perf_counter()
    row = _blank_row(spec)
    with capture(row, keep_traceback=True):  # one failed run must not stop the batch
        robot = robot_from_options(spec.robot_params, spec.robot_file)
        row["robot"] = robot.to_dict()
        tr = load_trajectory(spec.traj, feed=robot.feed, **spec.traj_params)
        row["trajectory"] = {"name": tr.name, "params": dict(tr.params), "points": int(tr.points.shape[0])}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            s0 = time.perf_counter()
            result = follow(tr, solver=spec.solver, robot=robot, solver_options=spec.solver_options,
                            **spec.sim_options)
            row["solve_time_s"] = time.perf_counter() - s0
        summary = result.summary.to_dict()
        row.update(summary_row(summary))
        row["warnings"] = [str(w) for w in summary.get("warnings", [])]
        if row["min_clearance_mm"] is not None:
            row["clearance"] = {k: summary.get(k) for k in ("min_clearance_step", "min_clearance_point",
                                                            "wall_touch_steps")}
        row["stats"] = {"points": summary["points"], "modules": summary["modules"], "global": summary["global"]}
        if out_dir is not None:
            out = Path(out_dir)
            write_run_files(result, out)  # as bhr follow writes them: replay, plan and stream take them
            if plots:
                from bhr.output._run_plots import save_run_plots

                row["figures"] = [p.name for p in save_run_plots(result, out)]
                from bhr.output._view import save_view

                row["view"] = save_view(result, out).name
    if row["status"] != "ok":
        row["status"] = _without_file_text(row["status"], (spec.traj, spec.robot_file))
    row["wall_time_s"] = time.perf_counter() - t0
    return row


#: A quoted piece of a message: 'text' or "text".
_QUOTED = re.compile(r"'([^'\n]{1,300})'|\"([^\"\n]{1,300})\"")


def _without_file_text(status: str, files: tuple[str | None, ...]) -> str:
    """``status`` with every quoted piece that comes from one of ``files`` (a run's trajectory and robot files)
    left out: a report's files are shared, and a message about a file's line 2 quoted its cell ("x = 'TOKEN...'
    is not a number"), so that a file a batch names reached summary.csv, summary.json and index.html."""
    texts = []
    for f in files:
        with contextlib.suppress(OSError, ValueError):
            if f is not None and os.path.isfile(f) and os.path.getsize(f) <= 64 << 20:
                texts.append((Path(f).name, Path(f).read_text(encoding="utf-8", errors="replace")))

    def hide(m: re.Match[str]) -> str:
        piece = m.group(1) if m.group(1) is not None else m.group(2)
        owner = next((name for name, text in texts if piece in text), None)
        return m.group(0) if owner is None else f"(text of {owner} left out)"

    return _QUOTED.sub(hide, status) if texts else status


def _blank_row(spec: RunSpec, status: str = "ok") -> dict[str, Any]:
    row: dict[str, Any] = {"name": spec.name, "status": status, "traj": spec.traj, "solver": spec.solver,
                           "description": spec.description, "inputs": spec.inputs()}
    for key in ROW_FIELDS:
        row.setdefault(key, None)
    row["warnings"] = []
    row["figures"] = []
    return row


def _lost_job(job: tuple[RunSpec, str | None, bool], why: str) -> dict[str, Any]:
    """The row of a run whose worker process died."""
    return _blank_row(job[0], f"failed: {why}")


def _execute_job(job: tuple[RunSpec, str | None, bool]) -> dict[str, Any]:
    spec, out, plots = job
    return execute_run(spec, out, plots)


@dataclass
class BatchReport:
    """What :func:`run_batch` did: the rows in batch order and where the files are."""

    batch: Batch
    rows: list[dict[str, Any]]
    out_dir: Path
    wall_time_s: float

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r["status"] != "ok"]

    def files(self) -> list[Path]:
        return [self.out_dir / n for n in ("index.html", "summary.csv", "summary.json")]


def run_batch(batch: Batch, out_dir: str | os.PathLike[str], *, jobs: int = 1, plots: bool = True,
              inline_images: bool = False,
              progress: Callable[[int, int, dict[str, Any]], None] | None = None) -> BatchReport:
    """Run every run of ``batch`` and write the report into ``out_dir``.

    ``jobs`` > 1 runs that many worker processes (each loads the compiled
    kernels from numba's on-disk cache once). ``progress(done, total, row)``
    is called as each run finishes. Returns the rows in batch order; failed
    runs are rows whose ``status`` starts with ``failed:``.
    """
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise BhrError(f"jobs must be a whole number of processes, 1 or more, got {jobs!r}")
    out = Path(out_dir)
    slugs: list[str] = []
    for spec in batch.runs:
        s, k = _slug(spec.name), 2
        while s in slugs:
            s = f"{_slug(spec.name)}-{k}"
            k += 1
        slugs.append(s)
    job_list = [(spec, str(out / "runs" / s), plots) for spec, s in zip(batch.runs, slugs)]
    solvers = tuple(dict.fromkeys(spec.solver for spec in batch.runs))
    # one run per job: runs last from a fraction of a second to minutes, so workers take them one at a time
    done = run_jobs(_execute_job, job_list, jobs=jobs, warm_up=warm_up, warm_up_args=(solvers, plots), max_chunk=1,
                    progress=progress, lost=_lost_job)
    rows, wall = done.rows, done.wall_time_s
    final: list[dict[str, Any]] = []
    for row, s in zip(rows, slugs):
        assert row is not None
        row["folder"] = f"runs/{s}"
        final.append(row)
    report = BatchReport(batch, final, out, wall)
    write_report(report, inline_images=inline_images)
    return report


def csv_text(rows: Sequence[dict[str, Any]], fields: Sequence[str] = ROW_FIELDS) -> str:
    """CSV of ``rows`` with ``fields`` as header; unknown values are empty cells, floats in full."""
    return _csv_text(rows, fields, joined=("warnings",))


def _json_row(row: dict[str, Any]) -> dict[str, Any]:
    keep = list(ROW_FIELDS) + ["clearance", "description", "inputs", "trajectory", "robot", "folder", "figures",
                               "view", "stats"]
    return {k: row.get(k) for k in keep if k in row}


def write_report(report: BatchReport, inline_images: bool = False) -> list[Path]:
    """Write index.html, summary.csv and summary.json of ``report`` (atomically)."""
    out = report.out_dir
    write_text(out / "summary.csv", csv_text(report.rows))
    write_json(out / "summary.json", {
        "title": report.batch.title,
        "batch": report.batch.source,
        "bhr_version": __version__,
        "runs_total": len(report.rows),
        "runs_failed": len(report.failed),
        "wall_time_s": report.wall_time_s,
        "runs": [_json_row(r) for r in report.rows],
    })
    write_text(out / "index.html", html_page(report, inline_images=inline_images))
    return report.files()


# ---------------------------------------------------------------------------------------------- text


def format_table(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The summary as fixed-width text lines (what ``bhr report`` prints)."""
    cols = [("name", "run", None), ("finished", "finished", None), ("verdict", "verdict", None),
            ("steps", "steps", None),
            ("tip_max_error_mm", "tip max mm", 3), ("points_max_error_mm", "pts max mm", 3),
            ("orientation_max_deg", "ori max deg", 2), ("global_max", "global max", 3),
            ("tip_rmse_mm", "tip rmse mm", 3), ("tip_orientation_rmse_deg", "tip rmse deg", 2),
            ("tolerance_exceeded", "over tol.", None), ("min_clearance_mm", "clear. mm", 2),
            ("wall_time_s", "time s", 2)]
    cells = [[h for _, h, _ in cols]]
    for r in rows:
        cells.append([finished_cell(r) if k == "finished" else verdict_cell(r) if k == "verdict"
                      else ("OVER" if r.get(k) else "") if k == "tolerance_exceeded"
                      else fmt(r.get(k), d or 3) for k, _, d in cols])
    widths = [max(len(c[i]) for c in cells) for i in range(len(cols))]
    lines = []
    for c in cells:
        lines.append("  ".join(v.ljust(widths[i]) if i < 3 else v.rjust(widths[i]) for i, v in enumerate(c)))
    for r in rows:
        if r["status"] != "ok":
            lines.append(f"{r['name']}: {r['status']}")
    return lines


# ---------------------------------------------------------------------------------------------- HTML

#: The summary table's columns and the decimals of each number.
_SUMMARY = (("name", 0), ("finished", 0), ("verdict", 0), ("traj", 0), ("solver", 0), ("steps", 0),
            ("tip_max_error_mm", 3),
            ("tip_final_error_mm", 4), ("points_max_error_mm", 3), ("orientation_max_deg", 2), ("global_max", 3),
            ("tip_rmse_mm", 3), ("tip_orientation_rmse_deg", 2), ("tolerance_exceeded", 0), ("min_clearance_mm", 2),
            ("wall_time_s", 2))
_DIGITS = dict(_SUMMARY)


def _summary_table(rows: Sequence[dict[str, Any]], anchors: Sequence[str]) -> str:
    def cell(item: tuple[dict[str, Any], str], k: str) -> tuple[str, str]:
        r, anchor = item
        if k == "name":
            return f"<a href=\"#{escape(anchor)}\">{escape(r['name'])}</a>", "l"
        if k == "finished":  # how the run ended; whether it followed is the verdict's, beside it
            return escape(finished_cell(r)), "l" if r["status"] == "ok" else "bad"
        if k == "verdict":
            return escape(verdict_cell(r)), f"l {verdict_class(r)}" if r["status"] == "ok" else "l"
        if k == "traj":
            return escape((r.get("trajectory") or {}).get("name", r["traj"])), "l"
        if k == "solver":
            return escape(r["solver"]), "l"
        if k == "tolerance_exceeded":
            return ("over", "bad") if r.get(k) else ("", "")
        return escape(fmt(r.get(k), _DIGITS[k] or 3)), ""

    return html_table("summary", [k for k, _ in _SUMMARY], list(zip(rows, anchors)), cell,
                 head_class=lambda k: "l" if k in ("name", "finished", "verdict", "traj", "solver") else "",
                 row_class=lambda item: "ok" if item[0]["status"] == "ok" else "failed")


def _stats_table(stats: dict[str, Any]) -> str:
    parts = []
    for key, title, label, unit in (("points", "Position error", "point", "mm"),
                                    ("modules", "Orientation error", "module", "deg"),
                                    ("global", "Global error", "module", "1 = tolerance")):
        rows = stats.get(key) or []
        parts.append(f"<table class=\"stats\"><thead><tr><th class=\"l\">{escape(title)} ({escape(unit)})</th>"
                     "<th>max</th><th>at step</th><th>mean</th><th>median</th><th>RMSE</th><th>final</th></tr>"
                     "</thead><tbody>")
        for j, st in enumerate(rows):
            tag = " (base)" if j == 0 else (" (tip)" if j == len(rows) - 1 else "")
            parts.append(f"<tr><td class=\"l\">{escape(label)} {j + 1}{escape(tag)}</td><td>{st['max']:.3f}</td>"
                         f"<td>{int(st['worst_step'])}</td><td>{st['mean']:.3f}</td><td>{st['median']:.3f}</td>"
                         f"<td>{fmt(st.get('rmse'), 3)}</td><td>{st['final']:.3f}</td></tr>")
        parts.append("</tbody></table>\n")
    return "".join(parts)


def _run_section(row: dict[str, Any], anchor: str, out_dir: Path, inline: bool) -> str:
    ok = row["status"] == "ok"
    out = [f"<section id=\"{escape(anchor)}\">\n<h2>{escape(row['name'])}</h2>\n"]
    if row.get("description"):
        out.append(f"<p>{escape(row['description'])}</p>\n")
    if not ok:
        out.append(f"<p class=\"reason\">{escape(row['status'])}</p>\n")
    dl = []
    tr = row.get("trajectory")
    if tr:
        params = ", ".join(f"{k} {v:g}" for k, v in tr["params"].items()) or "no parameters"
        dl.append(("trajectory", f"{tr['name']} ({params}); {tr['points']} points"))
    else:
        dl.append(("trajectory", row["traj"]))
    dl.append(("solver", row["solver"]))
    rb = row.get("robot")
    if rb:
        disc = rb.get("robot_radius", 0.0)
        dl.append(("robot", f"{rb['modules']} modules x {rb['module_length']:g} mm, radius {disc:g} mm, "
                            f"alpha {rb['alpha']:g} deg (min turn radius {rb['min_turn_radius']:.2f} mm), "
                            f"feed {rb['feed']:g} mm"))
        dl.append(("tolerances", f"{rb['tol_pos']:g} mm, {rb['tol_ori']:g} deg; at most {rb['max_iter']} iterations"))
    if ok:
        dl.append(("steps", str(row["steps"])))
        dl.append(("tip error", f"max {row['tip_max_error_mm']:.4f} mm, final {row['tip_final_error_mm']:.4f} mm"))
        if row.get("min_clearance_mm") is not None:
            where = row.get("clearance") or {}
            at = (f" at step {where['min_clearance_step']} ({where['min_clearance_point']})"
                  if where.get("min_clearance_step") else "")
            touch = len(where.get("wall_touch_steps") or [])
            dl.append(("min clearance", f"{row['min_clearance_mm']:.3f} mm{at}"
                                        + (f"; touches the wall at {touch} steps" if touch else "")))
    dl.append(("wall time", f"{row['wall_time_s']:.2f} s"))
    out.append("<dl>" + "".join(f"<dt>{escape(k)}</dt><dd>{escape(v)}</dd>" for k, v in dl) + "</dl>\n")
    for w in row.get("warnings") or []:
        out.append(f"<p class=\"warn\">Warning: {escape(w)}</p>\n")
    figs = list(row.get("figures") or [])
    known = [f for f, _, _ in _FIGURES]
    shown = [(f, cap, ref) for f, cap, ref in _FIGURES if f in figs]
    shown += [(f, f, "") for f in figs if f not in known]  # any figure a newer bhr draws
    if shown:
        out.append("<div class=\"figs\">\n")
        for f, cap, ref in shown:
            rel = f"{row['folder']}/{f}"
            caption = escape(cap) + (f" (thesis {escape(ref)})" if ref else "")
            out.append(figure(rel, f"{cap} - {row['name']}", caption, folder=out_dir, inline=inline))
        out.append("</div>\n")
    if row.get("view"):
        out.append(f"<p><a href=\"{escape(row['folder'])}/{escape(row['view'])}\">Interactive 3-D view</a></p>\n")
    if row.get("stats"):
        out.append("<details><summary>Errors per point and module</summary>\n")
        out.append(_stats_table(row["stats"]))
        out.append("</details>\n")
    if row.get("traceback"):
        out.append(f"<details><summary>Traceback</summary><pre>{escape(row['traceback'])}</pre></details>\n")
    out.append("</section>\n")
    return "".join(out)


def html_page(report: BatchReport, inline_images: bool = False) -> str:
    """The report page: title, the summary table, then one section per run (escaped, self-contained)."""
    b = report.batch
    anchors = [f"run-{r['folder'].split('/', 1)[1]}" for r in report.rows]
    failed = len(report.failed)
    parts = [page_head(b.title), f"<h1>{escape(b.title)}</h1>\n"]
    if b.description:
        parts.append(f"<p>{escape(b.description)}</p>\n")
    parts.append(f"<p class=\"meta\">{len(report.rows)} runs, {failed} failed; batch {escape(b.source)}; "
                 f"{report.wall_time_s:.1f} s; bhr {escape(__version__)}. "
                 "Errors are in mm and degrees; the global error is 1 at the tolerances.</p>\n")
    parts.append(_summary_table(report.rows, anchors))
    for row, a in zip(report.rows, anchors):
        parts.append(_run_section(row, a, report.out_dir, inline_images))
    parts.append(PAGE_END)
    return "".join(parts)
