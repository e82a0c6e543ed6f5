"""Traversability studies: which robot designs get through a population of anatomical colons.

A study is a grid of robot designs (any robot or solver option, as in a
sweep: ``alpha``, ``module_length``, ``modules``, ``robot_radius``, ...) times
a population of anatomical colons (:mod:`bhr.model._anatomy`, one per seed). Every
design follows every colon with the chosen solver(s); a colon is *traversed*
when the run touches the wall at no step (``wall_touch_steps`` empty). Per
design the study reports the pass rate (share of colons traversed), the
worst and median of the runs' ``max_penetration_mm`` and their contact
lengths, and it names the best design whose pass rate reaches the target. A whole robot's designs are
ranked by how far along the colons they get inside the lumen (``reach``) when as many colons are traversed;
its runs end where it leaves the lumen (``stop_at_wall``) unless each is replayed against the wall.

It is a sweep (:mod:`bhr._studies.sweep`) whose last axis is the colon's seed: the
same checks, chunks, worker processes and Dask path run it, so a study on a
cluster gives the same rows as one run locally.

Penetration and contact come from the run summary: ``max_penetration_mm``
and ``contact_length_mm`` when the follow loop reports them; otherwise the
penetration is read from ``min_clearance_mm`` (the wall clearance of each
point against its scored trajectory point) as ``max(0, -min_clearance_mm)``
and the contact length is not known. :attr:`StudyResult.clearance_kind`
says which was used.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
import re
import statistics
import textwrap
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from bhr import __version__
from bhr.model._anatomy import SECTIONS, SEED_MAX, anatomical_colon, check_seed
from bhr.output._atomic import write_json, write_text
from bhr._settings.errors import BhrError
from bhr._run.driver import BhrWarning, follow
from bhr.output._htmlpage import PAGE_END, escape, figure, fmt, page_head, table
from bhr._settings.names import axis_label
from bhr._settings.names import label as _label
from bhr._settings.options import LIMITS, excerpt, solver_options_for
from bhr._studies.study import (ROBOT_KEYS, TRAJ_KEYS, csv_text, finished_cell, make_robot, replay_options,
                               sim_options, verdict_cell)
from bhr._studies.sweep import PHYSICS_KEYS, Sweep, SweepResult, build_sweep, run_sweep
from bhr._studies.sweep import heatmap_axes as _sweep_axes
from bhr.model._generators import load_trajectory
from bhr.model._robot import Robot
from bhr._hardware.thermal import format_duration

__all__ = ["Study", "StudyResult", "parse_colons", "build_study", "run_study", "design_rows", "answer",
           "write_study", "format_study", "DESIGN_COLUMNS", "RUN_COLUMNS", "LUMEN_KEYS"]

#: Summary keys a study keeps from every run (the ones a run does not report stay empty).
LUMEN_KEYS = ("max_penetration_mm", "wall_touch_steps", "contact_length_mm", "procedure_time_s", "body_modules",
              "left_lumen_step", "left_lumen_reason", "wall", "path_steps", "cecum_shortfall_mm", "too_short_for_cecum",
              "feeder_stop_step", "cecum_approach_steps")
#: Columns of designs.csv after the design's own keys.
DESIGN_COLUMNS = ("robot_judged", "rank", "ranked_by", "colons", "traversed", "pass_rate", "failed_runs",
                  "median_reach_pct", "worst_reach_pct", "worst_penetration_mm", "median_penetration_mm",
                  "worst_clearance_mm", "median_contact_length_mm",
                  "worst_contact_length_mm", "median_touch_steps", "worst_colon", "min_turn_radius_mm",
                  "median_procedure_time_s", "worst_procedure_time_s", "left_lumen")
#: ... and, in a study judged by the physical replay (``--max-wall-force``), these.
PHYSICS_DESIGN_COLUMNS = ("worst_wall_force_n", "colons_replayed_from_steps")
#: Columns of runs.csv after the design's keys and the seed.
RUN_COLUMNS = ("status", "finished", "verdict", "steps", "traversed", "reach_pct", "max_penetration_mm", "touch_steps",
               "contact_length_mm", "min_clearance_mm", "points_max_error_mm", "tip_max_error_mm", "modules",
               "procedure_time_s", "left_lumen_step", "failure", "wall")
_MAX_COLONS = LIMITS["colons"]
#: One seed, or FIRST-LAST, or FIRST:LAST[:STEP] as in a sweep's grid (ends included); plain ASCII digits.
_RANGE = re.compile(r"^\s*([0-9]+)\s*(?:(-|:)\s*([0-9]+)\s*(?::\s*([0-9]+)\s*)?)?$", re.ASCII)


def real_colon_names() -> list[str]:
    """The shipped real colons (``gca:E20`` ...), as --colons names them."""
    from bhr.model._trajnames import real_colons

    return list(real_colons())


def parse_colons(text: str | Sequence[int | str]) -> tuple[int | str, ...]:
    """Colons from ``"1-100"`` or ``"1:100"`` (the grid's syntax, ``"1:100:2"`` with a step), ``"1-50,61,70-80"``
    (ends included), ``real`` (every shipped real colon), real colons by name (``gca:VHM``), any mix of these
    (``real,1-100``), or a list of whole numbers and real colons' names."""
    real = real_colon_names()
    seeds: list[int | str] = []
    if isinstance(text, str):
        if not text.strip():
            raise BhrError("--colons is empty; give seeds such as 1-100 or 1,2,5-9")
        for part in text.split(","):
            word = part.strip()
            if word == "real":
                seeds.extend(real)
                continue
            if word.startswith("gca:"):
                if word not in real:
                    raise BhrError(f"--colons: {excerpt(word)} is not a shipped real colon; real colons: "
                                   f"{', '.join(real)} (or real for all of them)")
                seeds.append(word)
                continue
            m = _RANGE.match(part)
            if m is None:
                raise BhrError(f"--colons: {excerpt(part.strip())} is not a seed or a range of seeds, nor a real "
                               "colon; give e.g. 1-100, 1:100, 1,2,5-9 (whole numbers), real or gca:VHM")
            a = int(m.group(1))
            b = int(m.group(3)) if m.group(3) is not None else a
            step = int(m.group(4)) if m.group(4) is not None else 1
            if m.group(4) is not None and m.group(2) != ":":
                raise BhrError(f"--colons: {excerpt(part.strip())} mixes - and :; give FIRST-LAST or FIRST:LAST:STEP")
            if step < 1:
                raise BhrError(f"--colons: the step of {excerpt(part.strip())} must be a whole number of at least 1")
            if b < a:
                raise BhrError(f"--colons: range {a}-{b} runs backwards; give FIRST-LAST with FIRST <= LAST")
            if a > SEED_MAX or b > SEED_MAX:
                raise BhrError(f"--colons: seeds go from 0 to {SEED_MAX}, got {excerpt(part.strip())}")
            if len(range(a, b + 1, step)) + len(seeds) > _MAX_COLONS:
                raise BhrError(f"--colons: more than {_MAX_COLONS} colons; give fewer seeds")
            seeds.extend(range(a, b + 1, step))
    else:
        if len(text) > _MAX_COLONS:
            raise BhrError(f"--colons: more than {_MAX_COLONS} colons; give fewer seeds")
        for s_ in text:
            if isinstance(s_, str) and s_ in real:
                seeds.append(s_)
            else:
                seeds.append(check_seed(s_, "--colons"))
    if not seeds:
        raise BhrError("--colons is empty; give seeds such as 1-100 or 1,2,5-9")
    if len(set(seeds)) != len(seeds):
        dup = next(s for s in seeds if seeds.count(s) > 1)
        raise BhrError(f"--colons lists seed {dup} twice; give each colon once")
    return tuple(seeds)


@dataclass(frozen=True)
class Study:
    """Designs (solvers x grid) x colons (seeds of the anatomical colon generator, or real colons' names)."""

    sweep: Sweep  # traj "anatomy", the design axes, then seed (the colons: a seed or a real colon's name) last
    colons: tuple[int | str, ...]
    target: float = 0.95

    @property
    def design_axes(self) -> list[tuple[str, tuple[Any, ...]]]:
        """The axes that make a design: solver and the grid keys (not the trajectory or the colon)."""
        return [(k, v) for k, v in self.sweep.axes if k not in ("traj", "seed")]

    @property
    def design_keys(self) -> list[str]:
        return [k for k, _ in self.design_axes]

    @property
    def designs(self) -> int:
        return math.prod(len(v) for _, v in self.design_axes)

    def __len__(self) -> int:
        return len(self.sweep)


def robot_axes(grid: Sequence[tuple[str, tuple[Any, ...]]], solvers: Sequence[str], head_only: bool = False,
               stop_at_wall: bool = True) -> tuple[list[tuple[str, tuple[Any, ...]]], tuple[str, ...], bool]:
    """The grid and solvers of ``bhr traverse``'s robot, and whether its runs end at the wall: by default the whole
    robot, long enough to reach the cecum (``reach=cecum``), with the lumen solver (so moved by its wires, the robot
    as it can be built) unless solvers are given, every run ending where the robot leaves the lumen (``stop_at_wall``:
    the verdict is known there, and no later pose a robot cannot take is scored; whole-robot designs are ranked by
    how far along the colons they get) except the trail model's, an idealisation planned inside the lumen (the
    third value, for :func:`build_study`; the grid gains ``stop_at_wall=True`` when no design is the trail
    model's); ``head_only``: the head alone (the modules the solver moves), with the thesis's solver unless solvers
    are given. A grid that sizes the robot (``body_modules``, ``reach``) or gives ``stop_at_wall`` is kept as it
    is."""
    axes = list(grid)
    sized = [k for k, _ in axes if k in ("body_modules", "reach")]
    if head_only and sized:
        raise BhrError(f"--head-only judges the head alone, but the grid sizes the whole robot ({sized[0]}); drop "
                       f"--head-only or --grid {sized[0]}=...")
    if not head_only and not sized:
        axes.append(("reach", ("cecum",)))
    stop = not head_only and stop_at_wall and "stop_at_wall" not in (k for k, _ in axes)
    trail = any("trail" in values for k, values in axes if k == "locomotion")
    if stop and not trail:
        axes.append(("stop_at_wall", (True,)))  # every run: a column of the tables, as the grid would give it
    return axes, tuple(solvers) or (("thesis",) if head_only else ("lumen",)), stop and trail


def build_study(grid: Sequence[tuple[str, tuple[Any, ...]]], colons: Sequence[int | str] | str, *,
                solvers: Sequence[str] = ("thesis",), target: float = 0.95, robot_file: str | None = None,
                title: str = "bhr traverse", where: str = "traverse", max_wall_force: float | None = None,
                stop_at_wall: bool = False) -> Study:
    """Check and assemble a study; every design and colon is checked before anything runs.

    ``stop_at_wall``: every run that is not the trail model's ends where its robot leaves the lumen (the third
    value of :func:`robot_axes`).

    ``max_wall_force`` (N): every run is also replayed as the physical robot against the wall
    (bhr._studies.physics), and a colon counts as traversed when the replayed tip reaches the cecum with the
    wall's load never above it (docs/physics.md)."""
    seeds = parse_colons(colons) if isinstance(colons, str) else parse_colons(list(colons))
    if isinstance(target, bool) or not isinstance(target, (int, float)) or not 0.0 < float(target) <= 1.0:
        raise BhrError(f"--target-pass must be a share of colons above 0 and at most 1 (e.g. 0.95), got {target!r}")
    grid = tuple(grid)
    for key, _ in grid:
        if key == "seed":
            raise BhrError(f"{where}: the colons are the study's population; give their seeds with --colons, "
                           "not --grid seed=...")
        if key in TRAJ_KEYS and key != "lumen_model":  # a real colon's lumen model is a study's axis
            raise BhrError(f"{where}: {excerpt(key)} is a trajectory option; a study varies the robot and its solver "
                           "(e.g. alpha, module_length, modules, robot_radius)")
    sweep = build_sweep(("anatomy",), tuple(solvers), (*grid, ("seed", seeds)), title=title, where=where,
                        robot_file=robot_file, replay=max_wall_force is not None)
    body, passive = dict(grid).get("body_modules"), dict(grid).get("passive_modules")
    if body and passive and max(passive) >= min(body):
        raise BhrError(f"{where}: passive_modules = {max(passive)} leaves no driven module of a {min(body)}-module "
                       "robot; give fewer passive modules than body_modules")
    sweep = dataclasses.replace(sweep, extra=LUMEN_KEYS, stop_at_wall=bool(stop_at_wall))
    if max_wall_force is not None:
        v = float(max_wall_force)
        if not (math.isfinite(v) and v > 0):
            raise BhrError(f"--max-wall-force must be a positive force in N, got {max_wall_force!r}")
        sweep = dataclasses.replace(sweep, physics=(("max_wall_force", v),))
    return Study(sweep, seeds, float(target))


@dataclass
class StudyResult:
    study: Study
    runs: list[dict[str, Any]]  # one per design x colon, in order, with the derived columns of RUN_COLUMNS
    designs: list[dict[str, Any]]  # one per design, in order: its keys, then DESIGN_COLUMNS
    wall_time_s: float
    runner: str
    workers: int
    clearance_kind: str  # "geometric" (the summary's max_penetration_mm) or "index-matched" (from min_clearance_mm)

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.runs if r["status"] != "ok"]


def _penetration(row: dict[str, Any]) -> float | None:
    if row.get("max_penetration_mm") is not None:
        return float(row["max_penetration_mm"])
    c = row.get("min_clearance_mm")
    return None if c is None else max(0.0, -float(c))


def _contact(row: dict[str, Any]) -> float | None:
    v = row.get("contact_length_mm")
    if v is None:
        return None
    if isinstance(v, (list, tuple)):
        return float(sum(float(x) for x in v))
    return float(v)


def _short(row: dict[str, Any]) -> float:
    """How far short of the cecum a whole robot's tip stopped because the robot is shorter than the colon (the
    feeder at the anus pushes it in no further than its own length), mm; 0 for a robot that is long enough."""
    return float(row.get("cecum_shortfall_mm") or 0.0) if row.get("too_short_for_cecum") else 0.0


def _too_short(result: StudyResult, design: dict[str, Any] | None = None) -> bool:
    """Some run (of ``design``, if given) stopped short of the cecum because the robot is shorter than its colon."""
    mine = {} if design is None else {k: design[k] for k in result.study.design_keys}
    return any(_TOO_SHORT in (r.get("failure") or "") for r in result.runs
               if all(r[k] == v for k, v in mine.items()))


_TOO_SHORT = "too short to reach the cecum"


def _stuck(row: dict[str, Any]) -> float:
    """How far short of the cecum a whole robot long enough for the colon stopped, mm: the feeder pushes it on past
    the path's end until its tip is there (docs/locomotion.md), so only a trail that could not get there within
    bhr.model._path.approach_steps leaves one; 0 otherwise."""
    return 0.0 if row.get("too_short_for_cecum") else float(row.get("cecum_shortfall_mm") or 0.0)


def _reach(row: dict[str, Any]) -> float | None:
    """How far along the colon the tip went before the robot left the lumen (its axis outside the wall), or before
    the feeder stopped a robot too short to reach the cecum, % of the path (100: it stayed inside and reached the
    cecum); None for a failed run or a path without a lumen."""
    if row["status"] != "ok" or row.get("wall_touch_steps") is None:
        return None
    # the path's own steps: a whole robot pushed on to the cecum past the path's end has more
    path = row.get("path_steps") or (row.get("steps") or 0) - int(row.get("cecum_approach_steps") or 0)
    ends = [s for s in (row.get("left_lumen_step"), row.get("feeder_stop_step") if _short(row) else None)
            if s is not None]
    if not ends or not path or path < 2:
        return 100.0
    return min(100.0, 100.0 * (min(ends) - 1) / (path - 1))


def _run_row(row: dict[str, Any], keys: Sequence[str]) -> dict[str, Any]:
    out = {k: row[k] for k in keys}
    out["seed"] = row["seed"]
    ok = row["status"] == "ok"
    touches = row.get("wall_touch_steps")
    physical = "physically_traversed" in row  # the study replays every run: its verdict is the physical one
    out.update({
        "status": row["status"],
        "finished": finished_cell(row),  # how the run ended (or FAILED), apart from its verdict
        "verdict": verdict_cell(row),
        "steps": row.get("steps"),
        "traversed": bool(ok and row.get("physically_traversed")) if physical else
        bool(ok and touches is not None and len(touches) == 0 and row.get("left_lumen_step") is None
             and not _short(row) and not _stuck(row)),
        "reach_pct": _reach(row),
        "max_penetration_mm": _penetration(row) if ok else None,
        "touch_steps": len(touches) if (ok and touches is not None) else None,
        "contact_length_mm": _contact(row) if ok else None,
        "min_clearance_mm": row.get("min_clearance_mm"),
        "points_max_error_mm": row.get("points_max_error_mm"),
        "tip_max_error_mm": row.get("tip_max_error_mm"),
        "modules": row.get("body_modules"),
        # a run stopped at the wall did not do the whole procedure
        "procedure_time_s": (row.get("procedure_time_s") if ok and row.get("finished") != "stopped at the wall"
                             else None),
        # a colon fails when the run fails or the robot left the lumen (bhr._run.clearance.left_lumen): the reason
        "left_lumen_step": row.get("left_lumen_step") if ok else None,
        "failure": (row.get("left_lumen_reason") or (f"the robot is {_TOO_SHORT}: its tip stopped "
                                                      f"{_short(row):.0f} mm short" if _short(row) else "")
                    or (f"its tip stopped {_stuck(row):.0f} mm short of the cecum" if _stuck(row) else ""))
        if ok else str(row["status"]),
        "wall": row.get("wall"),  # what the clearance was measured against: the tube or the colon's mesh
    })
    if physical:
        out.update({k: row.get(k) for k in PHYSICS_KEYS})
    return out


def design_rows(study: Study, runs: Sequence[dict[str, Any]], min_turn: dict[tuple[Any, ...], float | None]
                ) -> list[dict[str, Any]]:
    """Per design: colons, how many were traversed, the pass rate and the penetration and contact figures."""
    keys = study.design_keys
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in runs:
        groups.setdefault(tuple(r[k] for k in keys), []).append(r)
    out = []
    for n, (combo, rows) in enumerate(groups.items(), start=1):
        # the worst colon: deepest into the wall, then (when none touches) the least clearance left
        pen = [(r["max_penetration_mm"], r["seed"], r.get("min_clearance_mm"), -k) for k, r in enumerate(rows)
               if r["max_penetration_mm"] is not None]
        contact = [r["contact_length_mm"] for r in rows if r["contact_length_mm"] is not None]
        touch = [r["touch_steps"] for r in rows if r["touch_steps"] is not None]
        clear = [r["min_clearance_mm"] for r in rows if r["status"] == "ok" and r.get("min_clearance_mm") is not None]
        proc = [r["procedure_time_s"] for r in rows if r.get("procedure_time_s") is not None]
        reach = [(r["reach_pct"], -(r["max_penetration_mm"] or 0.0), r["seed"], k) for k, r in enumerate(rows)
                 if r.get("reach_pct") is not None]
        passed = sum(1 for r in rows if r["traversed"])
        # ties: the colon listed first
        worst = max(pen, key=lambda p: (p[0], -(p[2] if p[2] is not None else math.inf), p[3])) if pen else None
        d = {"design": n, **dict(zip(keys, combo))}
        worst_colon = worst[1] if worst else None
        if by_reach(d) and reach:  # a whole robot: the worst colon is the one it got least far in
            worst_colon = min(reach)[2]
        d.update({
            "colons": len(rows),
            "traversed": passed,
            "pass_rate": passed / len(rows),
            "failed_runs": sum(1 for r in rows if r["status"] != "ok"),
            "median_reach_pct": statistics.median(p[0] for p in reach) if reach else None,
            "worst_reach_pct": min(p[0] for p in reach) if reach else None,
            "worst_penetration_mm": worst[0] if worst else None,
            "median_penetration_mm": statistics.median(p[0] for p in pen) if pen else None,
            "worst_clearance_mm": min(clear) if clear else None,
            "median_contact_length_mm": statistics.median(contact) if contact else None,
            "worst_contact_length_mm": max(contact) if contact else None,
            "median_touch_steps": statistics.median(touch) if touch else None,
            "worst_colon": worst_colon,
            "min_turn_radius_mm": min_turn.get(combo),
            "median_procedure_time_s": statistics.median(proc) if proc else None,
            "worst_procedure_time_s": max(proc) if proc else None,
            "left_lumen": sum(1 for r in rows if r.get("left_lumen_step") is not None),
        })
        if study.sweep.physics:
            force = [r["peak_wall_force_n"] for r in rows if r.get("peak_wall_force_n") is not None]
            d.update({"worst_wall_force_n": max(force) if force else None,
                      "colons_replayed_from_steps": sum(1 for r in rows if r.get("poses_replayed") == "steps")})
        d["robot_judged"] = robot_judged(study, d)
        out.append(d)
    ranked = sorted(out, key=_rank)
    for k, d in enumerate(ranked):
        d["rank"] = k + 1
        other = ranked[k + 1] if k + 1 < len(ranked) else (ranked[k - 1] if k else None)
        d["ranked_by"] = "" if other is None else _separated_by(d, other)
    return out


#: What ranks designs, in order (:func:`_rank`): the words the tables and the figure use.
RANKING = ("pass rate", "worst penetration", "worst clearance", "median penetration", "design order (a tie)")
#: ... of a whole robot (its runs ending where it leaves the lumen, ``stop_at_wall``, by default): how far along the
#: colons each design gets inside the lumen, then how deep it went into the wall.
RANKING_REACH = ("pass rate", "median reach", "worst reach", "worst penetration", "design order (a tie)")


def by_reach(d: dict[str, Any]) -> bool:
    """Design ``d`` is a whole robot (``reach`` or ``body_modules``): ranked by :data:`RANKING_REACH`."""
    return d.get("reach") is not None or d.get("body_modules") is not None


def ranking(d: dict[str, Any]) -> tuple[str, ...]:
    """The words of what ranks design ``d``: :data:`RANKING_REACH` for a whole robot, else :data:`RANKING`."""
    return RANKING_REACH if by_reach(d) else RANKING


#: What puts a buildable design ahead of the trail model's (:func:`_rank`'s first key).
IDEAL_LAST = "buildable first"


def _ideal(d: dict[str, Any]) -> bool:
    """Design ``d`` is the trail model: ideal follow-the-leader, which cannot be built."""
    return d.get("locomotion") == "trail"


def _mixed(designs: Sequence[dict[str, Any]]) -> bool:
    """The study has both the trail model's designs and designs a robot can be built to."""
    return any(_ideal(d) for d in designs) and not all(_ideal(d) for d in designs)


def _separated_by(d: dict[str, Any], other: dict[str, Any]) -> str:
    """The first of :func:`ranking` on which design ``d`` and ``other`` differ: what puts one ahead of the other
    (:data:`IDEAL_LAST` when one of them is the trail model and the other can be built)."""
    a0, b0 = _rank(d), _rank(other)
    if a0[0] != b0[0]:
        return IDEAL_LAST
    words = ranking(d)
    for name, a, b in zip(words, a0[1:], b0[1:]):
        if a != b:
            return name
    return words[-1]


def robot_judged(study: "Study", d: dict[str, Any]) -> str:
    """Which robot a design's verdict is about: ``head only (5 modules)`` (the modules the solver moves; no body
    behind them scored), ``whole robot (300 modules)`` (``body_modules``) or ``whole robot (to the cecum)``
    (``reach``); the trail model's whole robot is labelled as the idealisation it is."""
    ideal = ", the trail model: ideal follow-the-leader, not buildable" if d.get("locomotion") == "trail" else ""
    if d.get("reach") is not None:
        return "whole robot (to the cecum)" + ideal
    if d.get("body_modules") is not None:
        return f"whole robot ({d['body_modules']} modules)" + ideal
    base = dict(study.sweep.robot) if study.sweep.robot else {}
    modules = d.get("modules", base.get("modules", Robot().modules))
    return f"head only ({modules} modules)"


def _rank(d: dict[str, Any]) -> tuple[Any, ...]:
    """The sort key of design ``d``: every design that can be built ahead of the trail model's (an idealisation is
    never the answer), then :func:`ranking`'s measures."""
    def q(v: float | None, sign: float = 1.0) -> float:
        """A measure to a millionth (mm or %): two designs that differ only by rounding are a tie."""
        return math.inf if v is None else round(sign * float(v), 6) + 0.0

    if by_reach(d):
        return (_ideal(d), -d["pass_rate"], q(d.get("median_reach_pct"), -1.0), q(d.get("worst_reach_pct"), -1.0),
                q(d.get("worst_penetration_mm")), d["design"])
    return (_ideal(d), -d["pass_rate"], q(d["worst_penetration_mm"]), q(d.get("worst_clearance_mm"), -1.0),
            q(d["median_penetration_mm"]), d["design"])


def answer(result: StudyResult) -> tuple[dict[str, Any] | None, list[dict[str, Any]]]:
    """The best design whose pass rate reaches the target (None if none does), and all that reach it, best first.

    Best: the highest pass rate, then the smallest worst penetration, then the
    largest worst clearance (the margin left to the wall on its worst colon),
    then the smallest median penetration, then the design listed first. In a study
    that has designs a robot can be built to, the trail model's (ideal follow-the-leader,
    not buildable) are a reference, never the answer.
    """
    pool = [d for d in result.designs if not _ideal(d)] or result.designs
    meeting = sorted((d for d in pool if d["pass_rate"] >= result.study.target - 1e-12), key=_rank)
    return (meeting[0] if meeting else None), meeting


def best_design(result: StudyResult) -> dict[str, Any]:
    """The best design by the same order, whether or not it reaches the target."""
    return sorted(result.designs, key=_rank)[0]


def run_study(study: Study, *, jobs: int | None = None, scheduler: Any = None,
              progress: Callable[[int, int], None] | None = None) -> StudyResult:
    """Run every design on every colon (local processes, this process with ``jobs=1``, or a Dask scheduler)."""
    res: SweepResult = run_sweep(study.sweep, jobs=jobs, scheduler=scheduler, progress=progress)
    keys = study.design_keys
    runs = [_run_row(r, keys) for r in res.rows]
    min_turn: dict[tuple[Any, ...], float | None] = {}
    for r in res.rows:
        combo = tuple(r[k] for k in keys)
        if min_turn.get(combo) is None:
            min_turn[combo] = r.get("min_turn_radius_mm")
    geometric = any(r.get("max_penetration_mm") is not None for r in res.rows)
    return StudyResult(study, runs, design_rows(study, runs, min_turn), res.wall_time_s, res.runner, res.workers,
                       "geometric" if geometric else "index-matched")


# ------------------------------------------------------------------------------------------ figures


def heatmap_axes(study: Study, x: str | None = None, y: str | None = None) -> tuple[str | None, str | None]:
    """The heat-map's axes: ``x`` and ``y`` when given, else the two design axes with the most values."""
    design_only = Sweep(trajs=("anatomy",), solvers=study.sweep.solvers,
                        grid=tuple((k, v) for k, v in study.sweep.grid if k != "seed"))
    for name, val in (("x", x), ("y", y)):
        if val is not None and val not in study.design_keys:
            raise BhrError(f"heat-map {name} axis {excerpt(val)} is not a design axis of this study; give --{name} "
                           f"one of {', '.join(study.design_keys)}")
    return _sweep_axes(design_only, x, y)


def passrate_figure(result: StudyResult, x: str | None = None, y: str | None = None):
    """Pass rate per (x, y) design, the best over the other design axes; cells reaching the target outlined
    (:func:`bhr.output._traverse_plot.passrate_figure` draws it)."""
    import numpy as np

    from bhr.output._traverse_plot import passrate_figure as draw

    study = result.study
    x, y = heatmap_axes(study, x, y)
    axes = dict(study.design_axes)
    xs = axes[x] if x else (None,)
    ys = axes[y] if y else (None,)
    others = [k for k, v in study.design_axes if k not in (x, y) and len(v) > 1]
    data = np.full((len(ys), len(xs)), np.nan)
    best: dict[tuple[int, int], dict[str, Any]] = {}
    for d in result.designs:
        i = xs.index(d[x]) if x else 0
        j = ys.index(d[y]) if y else 0
        if (j, i) not in best or _rank(d) < _rank(best[(j, i)]):
            best[(j, i)] = d
            data[j, i] = d["pass_rate"]
    top = min(result.designs, key=_rank) if result.designs else None
    at_wall = top is not None and by_reach(top)
    # what ranks cells of one pass rate: how far along the colons the robot got inside the lumen (a whole robot),
    # else the clearance it left
    tie_key, tie_label = (("median_reach_pct", "median reach inside the lumen (% of the colon)") if at_wall else
                          ("worst_clearance_mm", "worst clearance (mm)"))
    clear = np.full(data.shape, np.nan)
    for (j, i), d in best.items():
        if d.get(tie_key) is not None:
            clear[j, i] = d[tie_key]
    texts = [["" for _ in xs] for _ in ys]
    for (j, i), v in np.ndenumerate(data):
        cell = best.get((j, i))
        text = "-" if not np.isfinite(v) else f"{100 * v:.0f}%"
        if cell is not None and data.size <= 200:
            text = f"rank {cell.get('rank', '')}: " + text
            if by_reach(cell) and cell.get("median_reach_pct") is not None:
                text += f"\nreach {cell['median_reach_pct']:.0f}% (worst {cell['worst_reach_pct']:.0f}%)"
            if cell["worst_penetration_mm"] is not None:
                text += f"\npen {cell['worst_penetration_mm']:.2f} mm"
            if cell["worst_clearance_mm"] is not None and not (by_reach(cell) and cell["worst_clearance_mm"] < 0):
                text += f"\nclear {cell['worst_clearance_mm']:.2f} mm"  # (a negative one is the pen line's)
        texts[j][i] = text
    reached = np.isfinite(data) & (np.nan_to_num(data, nan=-1.0) >= study.target - 1e-12)
    top_cell = next((c for c, d in best.items() if top is not None and d is top), None)
    over = f"best design over {', '.join(others)}" if others else "one design per cell"
    judged = sorted({d.get("robot_judged") or robot_judged(study, d) for d in result.designs})
    order = ("ranked by pass rate, then median reach (how far along the colon, %, before the robot left the "
             "lumen),\nthen worst reach, then worst penetration (pen)" if at_wall else
             "ranked by pass rate, then worst penetration (pen), then worst clearance (clear)")
    if _mixed(result.designs):
        order = order.replace("ranked by ", "ranked by every buildable design before the trail model's (ideal, not "
                              "buildable),\nthen by ", 1)
    judged_text = "\n".join(textwrap.wrap(f"robot judged: {'; '.join(judged)}", 110))
    title = (f"Share of {len(study.colons)} colons traversed without wall contact\n{judged_text}\n{order}; {over}"
             f"\noutlined black: at least {100 * study.target:g}%; dashed red: the best design")
    return draw(data, clear, texts, reached, top_cell, [_label(v) for v in xs] if x else [""],
                [_label(v) for v in ys] if y else [""], axis_label(x), axis_label(y), title, tie_label=tie_label)


def colons_phrase(colons: Sequence[int | str]) -> str:
    """``100 anatomical colons (seeds 1-100)``, ``5 real colons (gca:E20, ...)`` or both."""
    seeds = [c for c in colons if not isinstance(c, str)]
    real = [c for c in colons if isinstance(c, str)]
    parts = []
    if seeds:
        span = f"{seeds[0]}-{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) else ", ".join(
            map(str, seeds[:20])) + (" ..." if len(seeds) > 20 else "")
        parts.append(f"{len(seeds)} anatomical colon{'s' * (len(seeds) != 1)} (seeds {span})")
    if real:
        parts.append(f"{len(real)} real colon{'s' * (len(real) != 1)} ({', '.join(real)})")
    return " and ".join(parts)


def colon_label(colon: int | str) -> str:
    """A colon as the outputs name it: ``seed 7`` or the real colon's name."""
    return colon if isinstance(colon, str) else f"seed {colon}"


def colon_trajectory(colon: int | str, feed: float, **params: Any):
    """The trajectory of one colon of a study: a generated colon's seed or a real colon's name (``params``: the
    design's trajectory keys, such as ``lumen_model``)."""
    if isinstance(colon, str):
        return load_trajectory(colon, feed=feed, **params)
    return load_trajectory("anatomy", feed=feed, seed=colon, **params)


def colon_sections(colon: int | str, run: Any) -> tuple[list[str], Any, Any]:
    """Section names, start and end (mm from the anus) of a study's colon: a generated colon's drawn sections or a
    real colon's landmarks (its run's trajectory)."""
    import numpy as np

    if isinstance(colon, str):
        tr = run.trajectory
        feed = run.robot.feed
        return ([n for n, _, _ in tr.sections], np.array([a * feed for _, a, _ in tr.sections]),
                np.array([(b - 1) * feed for _, _, b in tr.sections]))
    ends = anatomical_colon(colon).section_ends()
    return list(SECTIONS), np.concatenate([[0.0], ends[:-1]]), ends


def worst_colon_run(result: StudyResult, design: dict[str, Any]):
    """Follow ``design``'s worst colon again (same robot, solver and options) and return the run."""
    s = result.study.sweep
    robot = make_robot({k: design[k] for k in result.study.design_keys if k in ROBOT_KEYS},
                       dict(s.robot) or None)
    traj_keys = {k: design[k] for k in result.study.design_keys if k in TRAJ_KEYS}  # a real colon's lumen model
    tr = colon_trajectory(design["worst_colon"], robot.feed, **traj_keys)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        keys = {k: design[k] for k in result.study.design_keys}
        return follow(tr, solver=design["solver"], robot=robot, solver_options=solver_options_for(design["solver"],
                      keys), **sim_options(keys))


def penetration_figure(result: StudyResult, design: dict[str, Any], run):
    """The worst colon followed again: the robot's smallest clearance to the wall at each step against the tip's
    distance from the anus; below zero (shaded red) the robot is that deep in the wall
    (:func:`bhr.output._traverse_plot.penetration_figure` draws it)."""
    import numpy as np

    from bhr.output._traverse_plot import penetration_figure as draw

    doc = run.to_dict()
    clearance = np.array([np.nan if st.get("clearance_mm") is None else st["clearance_mm"] for st in doc["steps"]],
                         dtype=float)
    s = np.arange(len(clearance)) * run.robot.feed
    names, starts, ends = colon_sections(design["worst_colon"], run)
    keys = ", ".join(f"{k} {_label(design[k])}" for k in result.study.design_keys)
    low = float(np.nanmin(clearance))
    stopped = run.extra.get("summary", {}).get("stopped_at_wall_step")
    if stopped:  # the colon the robot got least far in: its run ended where it left the lumen
        path = run.extra["summary"]["path_steps"]
        why = (f"the run ended where the robot left the lumen, {100.0 * (stopped - 1) / max(1, path - 1):.1f}% of "
               "the way along: the least of its colons")
        pen = run.summary.to_dict().get("max_penetration_mm") or 0.0
    elif run.extra.get("summary", {}).get("too_short_for_cecum"):  # a robot shorter than its colons
        why = (f"the robot is {_TOO_SHORT}: its tip stopped {run.extra['summary']['cecum_shortfall_mm']:.0f} mm "
               "short of it")
        pen = design["worst_penetration_mm"]
        k = int(run.extra["summary"]["feeder_stop_step"])  # then it holds its pose: its clearance up to there
        s, clearance = s[:k], clearance[:k]
    else:
        why, pen = "its deepest into the wall", design["worst_penetration_mm"]
    title = (f"Worst colon ({colon_label(design['worst_colon'])}) of design #{design['design']} ({keys}):\n"
             f"{why};\n{pen:.2f} mm into the wall at worst, smallest clearance {low:.2f} mm; "
             f"{result.clearance_kind} clearance")
    return draw(s, clearance, names, starts, ends, title)


# ------------------------------------------------------------------------------------------ outputs


def design_columns(study: Study) -> list[str]:
    return ["design", *study.design_keys, *DESIGN_COLUMNS, *(PHYSICS_DESIGN_COLUMNS if study.sweep.physics else ())]


def _max_wall_force(study: Study) -> float | None:
    """The wall load (N) a study judged by the physical replay allows, else None."""
    return dict(study.sweep.physics).get("max_wall_force") if study.sweep.physics else None


def judged_by_replay(result: StudyResult) -> str:
    """How a study judged by the physical replay counts a colon, and which replays are an idealisation; "" for a
    geometric study."""
    limit = _max_wall_force(result.study)
    if limit is None:
        return ""
    steps = sum(1 for r in result.runs if r.get("poses_replayed") == "steps")
    return (f"Judged by the physical replay (bhr physics): a colon is traversed when the replayed tip reaches the "
            f"cecum with the wall's load never above {limit:g} N"
            + (f"; {steps} of {len(result.runs)} runs replayed from their steps only, the joints moved linearly "
               "between codes (their every pose too many to keep; --grid all_poses=true keeps them, at a cost): an "
               "idealisation" if steps else
               "; every run replayed at every pose its wires went through"))


def _pen_words(result: StudyResult) -> str:
    """The answer's words for the worst penetration: the written poses' (geometric) beside a physical verdict."""
    return "the written poses' worst penetration" if _max_wall_force(result.study) is not None else "worst penetration"


def _physical(result: StudyResult, d: dict[str, Any]) -> str:
    """A design's physical figures for the answer line, "" for a geometric study."""
    if _max_wall_force(result.study) is None:
        return ""
    force = d.get("worst_wall_force_n")
    steps = d.get("colons_replayed_from_steps") or 0
    return (" by the physical replay (the wall's load at most "
            + ("-" if force is None else f"{force:.2f} N") + (
                f"; {steps} of its {d['colons']} colons replayed from their steps: an idealisation" if steps else "")
            + ")")


def run_columns(study: Study) -> list[str]:
    return [*study.design_keys, "seed", *RUN_COLUMNS, *(PHYSICS_KEYS if study.sweep.physics else ())]


def _describe(study: Study, d: dict[str, Any]) -> str:
    return ", ".join(f"{k}={_label(d[k])}" for k in study.design_keys)


def _decided(result: StudyResult, best: dict[str, Any]) -> str:
    """`` (ahead of design #6 by its worst clearance, 1.34 against 0.64 mm)``: what put the best design first."""
    ranked = sorted(result.designs, key=_rank)
    if len(ranked) < 2 or ranked[0] is not best:
        return ""
    nxt = ranked[1]
    by = _separated_by(best, nxt)
    fields = {"pass rate": ("pass_rate", "{:.0%}"), "worst penetration": ("worst_penetration_mm", "{:.2f} mm"),
              "median reach": ("median_reach_pct", "{:.1f}%"), "worst reach": ("worst_reach_pct", "{:.1f}%"),
              "worst clearance": ("worst_clearance_mm", "{:.2f} mm"),
              "median penetration": ("median_penetration_mm", "{:.2f} mm")}
    if by == IDEAL_LAST:
        return " (the only buildable design; the trail model's rank after it)"
    if by not in fields:
        return f" (tied with design #{nxt['design']} on every measure; listed first)"
    key, form = fields[by]
    a, b = best.get(key), nxt.get(key)
    if a is not None and b is not None and form.format(a) == form.format(b):  # apart below the shown digits
        form = form.replace(".2f", ".4f").replace(".1f", ".3f").replace(".0%", ".2%")
    vals = "" if a is None or b is None else f", {form.format(a)} against {form.format(b)}"
    tie = "; a tie-break at the same pass rate" if by != "pass rate" else ""
    return f" (ahead of design #{nxt['design']} by its {by}{vals}{tie})"


def answer_line(result: StudyResult) -> str:
    """The study's answer in one line (and, beside designs that can be built, the trail model's best as the
    reference it is)."""
    line = _answer_line(result)
    if _mixed(result.designs):
        d = min((d for d in result.designs if _ideal(d)), key=_rank)
        line += (f"; the trail model (ideal follow-the-leader, not buildable) at best: design #{d['design']}, "
                 f"{d['traversed']}/{d['colons']} traversed")
    return line


def _answer_line(result: StudyResult) -> str:
    study = result.study
    best, meeting = answer(result)
    pct = f"{100 * study.target:g}%"
    if best is not None:
        return (f"{len(meeting)} of {len(result.designs)} designs traverse at least {pct} of the "
                f"{len(study.colons)} colons; best: design #{best['design']} ({_describe(study, best)}), "
                f"{best.get('robot_judged') or robot_judged(study, best)}: "
                f"{best['traversed']}/{best['colons']} traversed{_physical(result, best)}, {_pen_words(result)} "
                f"{best['worst_penetration_mm']:.2f} mm" + (
                    "" if best["worst_clearance_mm"] is None else
                    f", worst clearance {best['worst_clearance_mm']:.2f} mm") + _decided(result, best))
    top = best_design(result)
    worst = "-" if top["worst_penetration_mm"] is None else f"{top['worst_penetration_mm']:.2f} mm"
    how = f"{_pen_words(result)} {worst}"
    if by_reach(top) and top.get("worst_reach_pct") is not None:
        how = ("it stays inside the lumen on every colon, " + how if top["worst_reach_pct"] >= 100.0 else
               f"gets {top['median_reach_pct']:.1f}% of the way along the median colon before it leaves the lumen"
               + (" or its length runs out" if _too_short(result, top) else "")
               + f" (worst {top['worst_reach_pct']:.1f}%), " + how)
    return (f"No design traverses {pct} of the {len(study.colons)} colons; the best, design #{top['design']} "
            f"({_describe(study, top)}), traverses {top['traversed']}/{top['colons']} "
            f"({100 * top['pass_rate']:.0f}%){_physical(result, top)}, {how}" + _decided(result, top))


def format_study(result: StudyResult, count: int = 8) -> list[str]:
    """The terminal summary: what ran, the best designs, and the answer."""
    study = result.study
    lines = [f"{len(result.runs)} runs ({len(result.designs)} designs x {len(study.colons)} colons) on "
             f"{result.runner}: {len(result.runs) - len(result.failed)} finished, {len(result.failed)} failed, "
             f"{result.wall_time_s:.1f} s; penetration from the {result.clearance_kind} clearance"]
    keys = study.design_keys
    judged = sorted({d.get("robot_judged") or robot_judged(study, d) for d in result.designs})
    lines.append(f"Robot judged: {'; '.join(judged)}" + (
        " -- the modules the solver moves, no body behind them (without --head-only: the whole robot to the cecum, "
        "moved by its wires)" if all(j.startswith("head only") for j in judged) else ""))
    if replay := judged_by_replay(result):
        lines.append(replay)
    at_wall = any(by_reach(d) for d in result.designs)
    words = RANKING_REACH[:4] if at_wall else RANKING[:4]
    ended = any(d.get("stop_at_wall") for d in study.sweep.designs())  # some run ends where it leaves the lumen
    lines.append("Ranked by " + ("every buildable design before the trail model's (ideal follow-the-leader, not "
                                 "buildable), then " if _mixed(result.designs) else "")
                 + ", then ".join(words) + "; 'ranked by': what puts a design ahead of the next"
                 + ("; reach: how far along the colon (% of its length) the tip went before the robot left the lumen"
                    + (", where its run ended (--stop-at-wall)" if ended else "")
                    + (" or, for a robot shorter than the colon, before the feeder stopped it"
                       if _too_short(result) else "")
                    if at_wall else ""))
    head = "  ".join(f"{k:>13}" for k in keys)
    proc = any(d.get("median_procedure_time_s") is not None for d in result.designs)
    lines.append(f"{'#':>5}  {head}  {'traversed':>10}" + (f"  {'median reach':>12}  {'worst reach':>11}" if at_wall
                                                           else "")
                 + f"  {'worst pen':>9}  {'median pen':>10}  {'worst clear':>11}  "
                 f"{'median contact':>14}  {'left lumen':>10}" + (f"  {'median time':>11}" if proc else "")
                 + "  ranked by")
    ranked = sorted(result.designs, key=_rank)
    for d in ranked[:count]:
        vals = "  ".join(f"{_label(d[k]):>13}" for k in keys)
        wp = "-" if d["worst_penetration_mm"] is None else f"{d['worst_penetration_mm']:.2f}"
        mp = "-" if d["median_penetration_mm"] is None else f"{d['median_penetration_mm']:.2f}"
        mc = "-" if d["median_contact_length_mm"] is None else f"{d['median_contact_length_mm']:.1f}"
        wc = "-" if d["worst_clearance_mm"] is None else f"{d['worst_clearance_mm']:.2f}"
        pt = "-" if d.get("median_procedure_time_s") is None else format_duration(d["median_procedure_time_s"])
        reach = "" if not at_wall else "".join(
            f"  {'-' if d.get(k) is None else format(d[k], '.1f') + '%':>{w}}"
            for k, w in (("median_reach_pct", 12), ("worst_reach_pct", 11)))
        line = (f"{d['design']:>5}  {vals}  {100 * d['pass_rate']:>9.0f}%{reach}  {wp:>9}  {mp:>10}  {wc:>11}  {mc:>14}"
                f"  {d['left_lumen']:>10}" + (f"  {pt:>11}" if proc else "") + f"  {d.get('ranked_by', '')}")
        lines.append(line.rstrip())
    if len(ranked) > count:
        rest = ranked[count:]
        lines.append(f"  ... the best {count} of {len(ranked)} designs shown; {len(rest)} more (down to design "
                     f"#{rest[-1]['design']}, {100 * rest[-1]['pass_rate']:.0f}% traversed) are in designs.csv")
    lines.append(answer_line(result))
    return lines


def _html(result: StudyResult, heat: str | None, worst: str | None, worst_design: dict[str, Any] | None) -> str:
    study = result.study
    cols = design_columns(study)
    best, meeting = answer(result)
    ids = {d["design"] for d in meeting}
    parts = [page_head(study.sweep.title), f"<h1>{escape(study.sweep.title)}</h1>\n"]
    axes = "; ".join(f"{k}: {', '.join(_label(v) for v in vals)}" for k, vals in study.design_axes)
    parts.append(f"<p class=\"meta\">{len(result.designs)} designs &times; {escape(colons_phrase(study.colons))}, "
                 f"{len(result.runs)} runs, {len(result.failed)} failed, {result.wall_time_s:.1f} s "
                 f"on {escape(result.runner)}; penetration from the {escape(result.clearance_kind)} clearance; bhr "
                 f"{escape(__version__)}.<br>{escape(axes)}"
                 + (f"; robot file: {escape(study.sweep.robot_file)}" if study.sweep.robot_file else "") + "</p>\n")
    if replay := judged_by_replay(result):
        parts.append(f"<p id=\"judged\">{escape(replay)}.</p>\n")
    parts.append(f"<p id=\"answer\"><strong>{escape(answer_line(result))}.</strong></p>\n")
    if heat:
        parts.append(figure(heat, "pass rate per design", "Share of colons traversed without touching the wall, "
                            "per design; outlined cells reach the target", style="max-width:760px"))
    if worst and worst_design is not None:
        parts.append(f"<h2>Worst colon of design #{worst_design['design']}</h2>\n")
        parts.append(figure(worst, "clearance along the worst colon", "The robot's smallest clearance to the wall "
                            "at each step of the design's worst colon (the largest max_penetration_mm, then the least "
                            "clearance), against the tip's distance from the anus; red: how deep it is in the wall; "
                            "grey bands: the colon's sections"))
        parts.append('<p><a href="worst-colon-view.html">The worst colon in 3-D</a> (view.html)</p>\n')

    def cell(d: dict[str, Any], c: str) -> tuple[str, str]:
        if c == "pass_rate":
            return escape(f"{100 * d[c]:.1f}%"), "ok" if d["design"] in ids else ""
        v = d.get(c)
        return escape(("yes" if v else "no") if isinstance(v, bool) else fmt(v)), ""

    parts.append("<h2>Designs, best first</h2>\n")
    parts.append(table("designs", cols, sorted(result.designs, key=_rank), cell,
                       row_class=lambda d: "meets" if d["design"] in ids else "below"))
    parts.append("<p>Every run: <a href=\"runs.csv\">runs.csv</a>; per design: "
                 "<a href=\"designs.csv\">designs.csv</a>; everything: <a href=\"study.json\">study.json</a>.</p>\n")
    parts.append(PAGE_END)
    return "".join(parts)


def write_study(result: StudyResult, out_dir: Any, *, plot: bool = True,
                x: str | None = None, y: str | None = None, physics: bool = False) -> list[Path]:
    """Write designs.csv, runs.csv, study.json, passrate.png and worst-colon.png (``plot``), index.html.

    ``out_dir`` is an :class:`bhr.output._atomic.OutputFolder` (the files go into its
    staging folder and the set is put in place whole when its ``with`` block
    ends) or a folder path, which is then written through an OutputFolder of
    its own: the one mechanism every command's output goes through.
    """
    from bhr.output._atomic import OutputFolder

    study = result.study
    own = None if isinstance(out_dir, OutputFolder) else OutputFolder(out_dir, "traverse", what="study output folder")
    folder = out_dir if own is None else own
    with own if own is not None else contextlib.nullcontext():
        stage = folder.path("")
        names = ["designs.csv", "runs.csv", "study.json"]
        write_text(stage / "designs.csv", csv_text(result.designs, design_columns(study)))
        write_text(stage / "runs.csv", csv_text(result.runs, run_columns(study)))
        best, meeting = answer(result)
        focus = best if best is not None else best_design(result)
        hx, hy = heatmap_axes(study, x, y)
        heat = worst = None
        if plot:
            from bhr.output._figure import save_figure

            save_figure(passrate_figure(result, hx, hy), stage / "passrate.png")
            heat = "passrate.png"
            names.append(heat)
            if focus.get("worst_colon") is not None:
                worst_run = worst_colon_run(result, focus)
                save_figure(penetration_figure(result, focus, worst_run), stage / "worst-colon.png")
                worst = "worst-colon.png"
                names.append(worst)
                from bhr._studies.physics.extras import worst_colon_extras  # the 3-D view; with physics, the replay

                names += worst_colon_extras(worst_run, stage, physics, replay_options(study.sweep.physics, focus))
        write_json(stage / "study.json", {
            "title": study.sweep.title,
            "bhr_version": __version__,
            "design_axes": {k: list(v) for k, v in study.design_axes},
            "colons": list(study.colons),
            "target_pass": study.target,
            "robot_file": study.sweep.robot_file,
            "robot": dict(study.sweep.robot) or None,
            "clearance": result.clearance_kind,
            "runs_total": len(result.runs),
            "failed_runs": len(result.failed),
            "wall_time_s": result.wall_time_s,
            "runner": result.runner,
            "workers": result.workers,
            "heatmap": {"x": hx, "y": hy},
            "answer": None if best is None else best["design"],
            "meeting_target": [d["design"] for d in meeting],
            "summary": answer_line(result),
            "worst_colon_figure": None if worst is None else {"design": focus["design"], "seed": focus["worst_colon"]},
            "designs": result.designs,
            "runs": result.runs,
        })
        write_text(stage / "index.html", _html(result, heat, worst, focus if worst else None))
        names.append("index.html")
    return [folder.final(n) for n in names]
