"""A sweep's results ranked: the rows as CSV, the best rows and robot designs, and the summary the terminal prints."""
from __future__ import annotations

from typing import Any

from bhr._run.driver import VERDICTS
from bhr._settings.names import label as _label
from bhr._studies.study import TRAJ_KEYS, csv_text
from bhr._studies.sweep.grid import Sweep
from bhr._studies.sweep.runs import SweepResult

__all__ = ["results_csv", "best_rows", "robot_design_keys", "best_designs", "what_ran", "format_summary"]


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
