"""What batch reports, sweeps and traversability studies share.

- the keys a run table or a grid may give, derived from the option registry
  (:mod:`bhr._settings.options`), and the check of one value;
- the row of one finished run (:func:`summary_row`) and the robot of a design;
- the warm-up every worker process runs once before its first run;
- CSV text with floats in full.

The names of options and result columns in words are in :mod:`bhr._settings.names`.
"""
from __future__ import annotations

import csv
import io
import math
from typing import Any, Iterable, Sequence

from bhr._settings.errors import BhrError
from bhr._run.body import check_body_modules
from bhr._run.driver import follow
from bhr._settings.options import BY_NAME, by_group, did_you_mean, excerpt
from bhr.model._robot import Robot

__all__ = ["TRAJ_KEYS", "ROBOT_KEYS", "CONSTRAINT_KEYS", "SOLVER_KEYS", "SIM_KEYS", "INT_KEYS", "NUMBER_KEYS",
           "BOOL_KEYS", "REPLAY_KEYS", "replay_options", "sim_options", "check_body", "suggest",
           "check_value", "summary_row", "finished_cell", "verdict_cell", "verdict_class",
           "make_robot", "warm_up", "csv_text", "csv_safe", "FORMULA_STARTS"]

# The keys of a run table come from the option registry (bhr._settings.options), as the command-line options do.
#: Trajectory options (CLI long names with underscores), as in ``bhr follow``.
TRAJ_KEYS = tuple(o.name for o in by_group("trajectory"))
#: Robot options: batch keys and :class:`bhr.model._robot.Robot` fields (``robot_radius`` is the robot's, ``radius``
#: the path's).
ROBOT_KEYS = tuple(o.name for o in by_group("robot"))
#: Options of the constrained solvers and their allowed values (None: a whole number).
CONSTRAINT_KEYS: dict[str, tuple[str, ...] | None] = {o.name: o.choices for o in by_group("constraint")}
#: Options of one solver (``--solver optimal``): key -> the solvers that take it.
SOLVER_KEYS: dict[str, tuple[str, ...]] = {o.name: o.solvers or () for o in by_group("solver")}
#: How each run is simulated (``body_modules``): keyword arguments of :func:`bhr._run.driver.follow`.
SIM_KEYS = tuple(o.name for o in by_group("run"))
#: Options of the physical replay a study may vary (``passive_modules``, ``wire_force``, ...): keyword arguments of
#: :func:`bhr._studies.physics.replay_physics`, for a study judged by it (``--max-wall-force``, its own option).
REPLAY_KEYS = tuple(o.name for o in by_group("physics") if o.name != "max_wall_force")
_GROUPS = ("robot", "trajectory", "constraint", "solver", "run")
#: Keys whose value is a whole number.
INT_KEYS = frozenset(o.name for o in by_group(*_GROUPS) if o.kind is int)
#: Keys whose value is a number.
NUMBER_KEYS = frozenset(o.name for o in by_group(*_GROUPS) if o.choices is None and o.kind is not bool)
#: Switches (true or false), such as stop_at_wall.
BOOL_KEYS = frozenset(o.name for o in by_group(*_GROUPS) if o.kind is bool)


def check_body(options: dict[str, Any], robot: Robot) -> None:
    """Refuse a ``body_modules`` (the whole robot) shorter than the robot's head."""
    if options.get("body_modules") is not None:
        check_body_modules(options["body_modules"], robot.modules)


def replay_options(physics: Any, design: dict[str, Any]) -> dict[str, Any]:
    """The physical replay's options for one design: the study's (``physics``, pairs), then the design's own
    :data:`REPLAY_KEYS`."""
    return {**dict(physics), **{k: design[k] for k in REPLAY_KEYS if k in design}}


def sim_options(values: dict[str, Any]) -> dict[str, Any]:
    """The :data:`SIM_KEYS` among ``values``: how :func:`bhr._run.driver.follow` simulates the run."""
    return {k: values[k] for k in SIM_KEYS if k in values and values[k] is not None}


def suggest(key: str, allowed: Iterable[str]) -> str:
    """The nearest allowed key to a mistyped one, as the second half of an error line."""
    tip = did_you_mean(key, sorted(allowed))
    return tip.rstrip() if tip else "see docs/report.md for the keys"


def check_value(key: str, value: Any, where: str) -> Any:
    """The value of one run key, type-checked and within its limits (bhr._settings.options); raises BhrError
    naming ``where``."""
    if key in BY_NAME:
        return BY_NAME[key].check(value, where)
    if not isinstance(value, str):
        raise BhrError(f"{where}: {key} must be a string, got {excerpt(value)}")
    if key in ("name", "traj", "solver", "robot") and not value.strip():
        raise BhrError(f"{where}: {key} must not be empty")
    return value


def _num(value: Any) -> float | None:
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def summary_row(summary: dict[str, Any]) -> dict[str, Any]:
    """The metrics of one run's summary as a report row (``min_clearance_mm`` None when unknown)."""
    return {
        "steps": int(summary["steps"]),
        "tip_max_error_mm": float(summary["tip_max_error_mm"]),
        "tip_final_error_mm": float(summary["tip_final_error_mm"]),
        "points_max_error_mm": float(summary["points_max_error_mm"]),
        "orientation_max_deg": float(summary["orientation_max_deg"]),
        "global_max": float(summary["global_max"]),
        "tip_rmse_mm": float(summary["tip_rmse_mm"]),
        "tip_orientation_rmse_deg": float(summary["tip_orientation_rmse_deg"]),
        "tolerance_exceeded": bool(summary["tolerance_exceeded"]),
        "min_clearance_mm": _num(summary.get("min_clearance_mm")),
        "finished": summary.get("finished", "ran to the end"),
        "verdict": summary.get("verdict"),
    }


def finished_cell(row: dict[str, Any]) -> str:
    """A result row's "finished" in words: how the run ended (ran to the end, stopped at the wall), or FAILED
    (it raised; the row's status says why)."""
    return str(row.get("finished") or "ran to the end") if row.get("status") == "ok" else "FAILED"


def verdict_cell(row: dict[str, Any]) -> str:
    """A result row's verdict (followed, out of tolerance, touched the wall, left the lumen); empty for a run that
    failed."""
    return str(row.get("verdict") or "") if row.get("status") == "ok" else ""


def verdict_class(row: dict[str, Any]) -> str:
    """The table cell class of a row's verdict: "ok" (green) only for a run that followed."""
    return "ok" if verdict_cell(row) == "followed" else "bad"


def make_robot(params: dict[str, Any], base: dict[str, Any] | None = None) -> Robot:
    """The Robot of a design: ``base`` (a robot file's fields, or bhr's defaults) with ``params`` on top."""
    return Robot(**base).replace(**params) if base else Robot(**params)


def warm_up(solvers: Sequence[str], plots: bool = False) -> None:
    """Load what the runs need (modules, compiled kernels, matplotlib when ``plots``) before any run is timed.

    Each process pays this once (:func:`bhr._studies.executor.run_jobs` sees to it);
    without it the first run of every worker carried the start-up in its time
    and a trivial run read slowest.
    """
    import numpy as np

    pts = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [4.0, 0.0, 0.0]])
    for name in solvers:
        try:
            follow(pts, solver=name)
        except Exception:  # noqa: BLE001  (a bad solver name fails, and is reported, in its run)
            pass
    if plots:
        import bhr.output._run_plots  # noqa: F401


def _cell(key: str, value: Any, joined: Iterable[str]) -> str:
    if value is None:
        return ""
    if key in joined:
        return "; ".join(value)
    if isinstance(value, float):
        return repr(value)
    return str(value)


#: What a spreadsheet takes as the start of a formula in a cell (OWASP "CSV injection").
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r", "\n")


def csv_safe(cell: str) -> str:
    """``cell`` as a spreadsheet shows it but never runs it: text starting like a formula gets a leading ``'``;
    a carriage return becomes a line break (which the CSV writer quotes, so it never ends a row)."""
    cell = "'" + cell if cell.startswith(FORMULA_STARTS) else cell
    return cell.replace("\r\n", "\n").replace("\r", "\n")


def csv_text(rows: Sequence[dict[str, Any]], fields: Sequence[str], joined: Iterable[str] = ()) -> str:
    """CSV of ``rows`` with ``fields`` as header; unknown values are empty cells, floats in full.

    The lists of the ``joined`` keys (e.g. warnings) are one cell, joined by ``"; "``. Text cells that a
    spreadsheet would run as a formula (``=``, ``+``, ``-``, ``@``, a tab or CR first) are escaped with a
    leading ``'`` (:func:`csv_safe`); numbers are written as they are.
    """
    joined = frozenset(joined)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([csv_safe(str(f)) for f in fields])
    for r in rows:
        w.writerow([_safe(r.get(k), _cell(k, r.get(k), joined)) for k in fields])
    return buf.getvalue()


def _safe(value: Any, cell: str) -> str:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return cell  # a number: "-1.5" is a number to a spreadsheet, not a formula
    return csv_safe(cell)
