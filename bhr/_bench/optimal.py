"""Benchmark of ``--solver optimal`` against ``--solver thesis``, both measured in the same run.

    python3 -m bhr._bench.optimal            # the table quoted in docs/optimal.md
    python3 -m bhr._bench.optimal --json -   # the same numbers as JSON

Three measurements, each a plain function returning numbers so that other
commands can reuse them:

* :func:`worst_error_ratios`: on each built-in trajectory (curve 90, curve 360,
  spiral, colon) the worst position error over all scored points of the
  whole run (max of ``FollowResult.point_errors_mm``) with the optimal solver,
  divided by the seed solver's, with the thesis's robot (5 modules of 10 mm,
  alpha 10 deg). The targets set for the optimal solver: at most 0.8, and 0.6 on the colon.
* :func:`solve_times`: median time of one ``Solver.solve`` call per step,
  driven step by step from Python as bhr.follow does without the compiled
  loop (so it includes the call overhead), after the kernels are loaded;
  and the compiled whole-run loop's time per step. Both solvers, same run.
* :func:`body_clearance`: a 60-module robot (5-module head, 55-module body)
  through the colon: the body's worst error, the minimum lumen clearance and
  the steps where the wall is touched (and the same robot along the spiral,
  which has no lumen, for the body's error in 3D).

``--sensitivity`` adds :func:`sensitivity`: the four ratios again with each
setting of the solver moved away from its default, and with the planner
switched off (the per-step optimum), to show how much the figures depend on
the defaults.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import numpy as np

__all__ = ["CASES", "TARGETS", "VARIANTS", "worst_error_ratios", "solve_times", "body_clearance", "sensitivity",
           "run_all", "format_report", "main"]

#: (label, trajectory, parameters) of the benchmark's trajectories.
CASES: list[tuple[str, str, dict[str, float]]] = [
    ("curve 90", "curve", {}),
    ("curve 360", "curve", {"angle": 360.0}),
    ("spiral", "spiral", {}),
    ("colon", "colon", {}),
]
#: The targets set for the optimal solver: optimal / thesis worst error.
TARGETS = {"curve 90": 0.8, "curve 360": 0.8, "spiral": 0.8, "colon": 0.6}


def _robot(robot=None):
    from bhr.model._robot import Robot

    return Robot() if robot is None else robot


def worst_error_ratios(robot=None, solver_options: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Worst point error of optimal and seed on every case, and their ratio (module doc)."""
    from bhr._run.driver import follow
    from bhr.model._generators import load_trajectory

    robot = _robot(robot)
    rows = []
    for label, name, params in CASES:
        tr = load_trajectory(name, feed=robot.feed, **params)
        seed = follow(tr, solver="seed", robot=robot)
        opt = follow(tr, solver="optimal", robot=robot, solver_options=solver_options)
        s, o = float(seed.point_errors_mm.max()), float(opt.point_errors_mm.max())
        rows.append({"case": label, "steps": int(tr.points.shape[0]), "seed_worst_mm": s, "optimal_worst_mm": o,
                     "ratio": o / s, "target": TARGETS[label], "ok": o / s <= TARGETS[label],
                     "seed_worst_step": int(np.argmax(seed.point_errors_mm.max(axis=1))) + 1,
                     "optimal_worst_step": int(np.argmax(opt.point_errors_mm.max(axis=1))) + 1})
    return rows


def _step_times(tr, solver: str, robot, options: dict[str, Any] | None) -> np.ndarray:
    """Seconds of each solve() call along ``tr``, driven as bhr.follow's step-by-step loop."""
    from bhr.model._path import path_directions
    from bhr.solvers import Chain, FollowContext, get_solver

    path = np.ascontiguousarray(tr.points, dtype=np.float64)
    dirs = path_directions(path)
    s = get_solver(solver, robot, **(options or {}))
    s.reset()
    chain = Chain.straight(robot, tr.start_direction, tr.start_point, tip_at_origin=True)
    N = path.shape[0]
    out = np.empty(N)
    for i in range(N):
        d = dirs[-1] if i == N - 1 else dirs[i]
        ctx = FollowContext(path, dirs, i)
        t0 = time.perf_counter()
        res = s.solve(chain, path[i], d, ctx)
        out[i] = time.perf_counter() - t0
        chain = res.chain.advance(robot.feed, robot.module_length)
    return out


def solve_times(case: str = "colon", robot=None, repeat: int = 3,
                solver_options: dict[str, Any] | None = None) -> dict[str, Any]:
    """Median per-step solve time (s) of optimal and seed, step by step and in the compiled loop (module doc)."""
    from bhr._run.driver import follow
    from bhr.model._generators import load_trajectory

    robot = _robot(robot)
    label, name, params = next(c for c in CASES if c[0] == case)
    tr = load_trajectory(name, feed=robot.feed, **params)
    N = tr.points.shape[0]
    out: dict[str, Any] = {"case": label, "steps": N, "modules": robot.modules, "repeat": repeat}
    for solver, opts in (("optimal", solver_options), ("seed", None)):
        follow(tr.points[:5], solver=solver, robot=robot, solver_options=opts)  # load the kernels
        _step_times(load_trajectory("curve", feed=robot.feed), solver, robot, opts)
        per_step = np.concatenate([_step_times(tr, solver, robot, opts) for _ in range(repeat)])
        loop = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            follow(tr, solver=solver, robot=robot, solver_options=opts)
            loop.append((time.perf_counter() - t0) / N)
        out[solver] = {"median_solve_s": float(np.median(per_step)), "p90_solve_s": float(np.percentile(per_step, 90)),
                       "max_solve_s": float(per_step.max()), "compiled_loop_per_step_s": float(np.median(loop))}
    out["median_ratio_optimal_to_seed"] = out["optimal"]["median_solve_s"] / out["seed"]["median_solve_s"]
    out["loop_ratio_optimal_to_seed"] = (out["optimal"]["compiled_loop_per_step_s"]
                                         / out["seed"]["compiled_loop_per_step_s"])
    return out


def body_clearance(body_modules: int = 60, solver: str = "optimal", robot=None, case: str = "colon") -> dict[str, Any]:
    """A robot of ``body_modules`` modules along ``case``: body error, minimum clearance, wall touches."""
    from bhr._run.driver import follow
    from bhr.model._generators import load_trajectory

    robot = _robot(robot)
    label, name, params = next(c for c in CASES if c[0] == case)
    tr = load_trajectory(name, feed=robot.feed, **params)
    res = follow(tr, solver=solver, robot=robot, body_modules=body_modules)
    s = res.summary.to_dict()
    return {"case": label, "solver": solver, "modules": body_modules, "steps": res.steps,
            "lumen_mm": sorted({float(v) for v in tr.lumen}) if tr.lumen is not None else None,
            "head_worst_mm": s["points_max_error_mm"], "body_worst_mm": s["body_points_max_error_mm"],
            "body_worst_step": s["body_worst_step"], "min_clearance_mm": s.get("min_clearance_mm"),
            "min_clearance_step": s.get("min_clearance_step"), "min_clearance_point": s.get("min_clearance_point"),
            "wall_touch_steps": s.get("wall_touch_steps")}


#: Settings tried by :func:`sensitivity`: (label, solver options).
VARIANTS: list[tuple[str, dict[str, Any]]] = [
    ("defaults", {}),
    ("per-step optimum (lookahead 0, no steering terms)", {"lookahead": 0, "drift_weight": 0.0, "roll_weight": 0.0}),
    ("no steering terms", {"drift_weight": 0.0, "roll_weight": 0.0}),
    ("no roll term", {"roll_weight": 0.0}),
    ("no drift term", {"drift_weight": 0.0}),
    ("lookahead 0", {"lookahead": 0}),
    ("lookahead 8", {"lookahead": 8}),
    ("lookahead 12", {"lookahead": 12}),
    ("beam 5", {"beam": 5}),
    ("beam 16", {"beam": 16}),
    ("drift weight 5", {"drift_weight": 5.0}),
    ("drift weight 20", {"drift_weight": 20.0}),
    ("roll weight 500", {"roll_weight": 500.0}),
    ("roll weight 2000", {"roll_weight": 2000.0}),
    ("ori weight 0.1", {"ori_weight": 0.1}),
    ("ori weight 0.3", {"ori_weight": 0.3}),
]


def sensitivity(robot=None) -> list[dict[str, Any]]:
    """The four ratios for every entry of :data:`VARIANTS` (seed measured once per case)."""
    from bhr._run.driver import follow
    from bhr.model._generators import load_trajectory

    robot = _robot(robot)
    trajs = [(label, load_trajectory(name, feed=robot.feed, **params)) for label, name, params in CASES]
    seed = {label: float(follow(tr, solver="seed", robot=robot).point_errors_mm.max()) for label, tr in trajs}
    rows = []
    for label, opts in VARIANTS:
        ratios = {case: float(follow(tr, solver="optimal", robot=robot, solver_options=opts).point_errors_mm.max())
                  / seed[case] for case, tr in trajs}
        rows.append({"variant": label, "options": opts, "ratios": ratios,
                     "ok": all(ratios[c] <= TARGETS[c] for c in ratios)})
    return rows


def run_all(with_sensitivity: bool = False) -> dict[str, Any]:
    """Every measurement, with the machine it ran on."""
    import os
    import platform

    doc = {"machine": {"python": platform.python_version(), "processor": platform.processor() or platform.machine(),
                       "cpus": os.cpu_count()},
           "ratios": worst_error_ratios(), "times": solve_times(),
           "body": [body_clearance(60, "optimal"), body_clearance(60, "seed"),
                    body_clearance(60, "optimal", case="spiral"), body_clearance(60, "seed", case="spiral")]}
    if with_sensitivity:
        doc["sensitivity"] = sensitivity()
    return doc


def format_report(doc: dict[str, Any]) -> list[str]:
    """The report as printed: each solver by its one name (the thesis's solver runs here by its alias, seed)."""
    from bhr.solvers import canonical

    lines = ["Worst position error over all scored points (mm), thesis robot: 5 x 10 mm, alpha 10 deg",
             f"{'trajectory':<12}{'steps':>7}{'thesis':>9}{'optimal':>9}{'ratio':>8}{'target':>8}"]
    for r in doc["ratios"]:
        lines.append(f"{r['case']:<12}{r['steps']:>7d}{r['seed_worst_mm']:>9.3f}{r['optimal_worst_mm']:>9.3f}"
                     f"{r['ratio']:>8.3f}{'<= ' + format(r['target'], '.1f'):>8}{'' if r['ok'] else '  MISSED'}")
    t = doc["times"]
    lines += ["", f"Time per step on the {t['case']} ({t['steps']} steps, {t['modules']} head modules, "
                  f"median of {t['repeat']} runs):",
              f"{'':<12}{'solve() median':>16}{'p90':>10}{'compiled loop':>16}"]
    for s in ("optimal", "seed"):
        v = t[s]
        lines.append(f"{canonical(s):<12}{v['median_solve_s'] * 1e3:>13.3f} ms{v['p90_solve_s'] * 1e3:>7.3f} ms"
                     f"{v['compiled_loop_per_step_s'] * 1e3:>13.3f} ms")
    lines.append(f"optimal / thesis: {t['median_ratio_optimal_to_seed']:.1f}x per solve() call, "
                 f"{t['loop_ratio_optimal_to_seed']:.1f}x in the compiled loop")
    lines += ["", "Whole body (colon lumen: 30 mm rectum, 45 mm elsewhere; robot radius 5 mm):"]
    for b in doc["body"]:
        line = (f"  {b['case']}, {b['modules']} modules, {canonical(b['solver'])}: "
                f"head worst {b['head_worst_mm']:.3f} mm, "
                f"body worst {b['body_worst_mm']:.3f} mm (step {b['body_worst_step']})")
        if b["min_clearance_mm"] is not None:
            touch = b["wall_touch_steps"] or []
            line += (f", minimum clearance {b['min_clearance_mm']:.3f} mm at step {b['min_clearance_step']} "
                     f"({b['min_clearance_point']}), wall touched at {len(touch)} steps")
        lines.append(line)
    if "sensitivity" in doc:
        lines += ["", "optimal / thesis worst error with one setting changed:",
                  f"{'':<52}" + "".join(f"{c:>11}" for c, _, _ in CASES)]
        for row in doc["sensitivity"]:
            lines.append(f"{row['variant']:<52}" + "".join(f"{row['ratios'][c]:>11.3f}" for c, _, _ in CASES)
                         + ("" if row["ok"] else "   (misses a target)"))
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m bhr._bench.optimal", description=__doc__.splitlines()[0])
    ap.add_argument("--json", metavar="PATH|-", help="also write the numbers as JSON ('-': stdout)")
    ap.add_argument("--sensitivity", action="store_true", help="also rerun the ratios with each setting changed")
    args = ap.parse_args(argv)
    doc = run_all(args.sensitivity)
    text = "\n".join(format_report(doc))
    if args.json == "-":
        print(json.dumps(doc, indent=1))
        print(text, file=sys.stderr)
    else:
        print(text)
        if args.json:
            from bhr.output._atomic import write_json

            write_json(args.json, doc)
    return 0 if all(r["ok"] for r in doc["ratios"]) else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
