"""Benchmark of ``--solver lumen`` against the thesis's solver on tight colons (docs/lumen.md).

    python3 -m bhr._bench.lumen                    # 100 colons, seeds 1-100
    python3 -m bhr._bench.lumen --seeds 1-20 --json out.json

Colons: the anatomical generator (``bhr.trajectory("anatomy", seed=N)``)
when this bhr has it, else :func:`tight_colon` (below), a stand-in with the
same features: ~660 mm from the rectum to the cecum in 3-D, flexures bent to
10-15 mm radius, lumen diameter 32-52 mm varying along it. Robot: the
thesis's (5 modules of 10 mm, alpha 10 deg, radius 5 mm, feed 2 mm).

Per colon, for each solver, the geometric clearance (:mod:`bhr._run.clearance`):
``max_penetration_mm`` and the number of wall-touch steps; then the median
over colons and the ratios lumen / thesis. And the time per step of
``--solver lumen`` against ``--solver thesis`` on one colon, both driven
step by step (the same Python overhead), as a ratio measured in the same run.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from typing import Any

import numpy as np

from bhr._run.driver import follow
from bhr.model._pathfile import segments_trajectory
from bhr.model._robot import Robot
from bhr.model._generators import Trajectory

__all__ = ["tight_colon", "colon_for", "cecum_step", "population", "solve_times", "main"]


def tight_colon(seed: int, feed: float = 2.0) -> Trajectory:
    """A stand-in 3-D colon (deterministic per seed): rectum, sigmoid loop, descending, splenic flexure,
    transverse, hepatic flexure, ascending; flexures of 10-15 mm radius; lumen 32-52 mm."""
    rng = np.random.default_rng(seed)

    def u(a: float, b: float) -> float:
        return float(rng.uniform(a, b))

    def lum(a: float = 32.0, b: float = 52.0) -> float:
        return round(u(a, b), 1)

    turns = ["left", "right", "up", "down"]
    segs: list[dict[str, Any]] = [
        {"type": "straight", "length": u(60, 80), "lumen": lum(32, 40)},  # rectum
        {"type": "arc", "radius": u(10, 15), "angle": u(50, 80), "turn": "up", "roll": u(-30, 30), "lumen": lum()},
        {"type": "straight", "length": u(30, 50), "lumen": lum()},  # sigmoid
        {"type": "arc", "radius": u(10, 15), "angle": u(60, 100), "turn": turns[int(rng.integers(2))],
         "roll": u(-40, 40), "lumen": lum()},
        {"type": "straight", "length": u(30, 45), "lumen": lum()},
        {"type": "arc", "radius": u(10, 15), "angle": u(50, 90), "turn": "left", "roll": u(-30, 30), "lumen": lum()},
        {"type": "straight", "length": u(110, 140), "lumen": lum()},  # descending
        {"type": "arc", "radius": u(10, 13), "angle": u(80, 120), "turn": "right", "roll": u(-20, 20),
         "lumen": lum()},  # splenic flexure
        {"type": "straight", "length": u(60, 80), "lumen": lum()},  # transverse (sagging)
        {"type": "arc", "radius": u(12, 15), "angle": u(20, 40), "turn": "down", "lumen": lum()},
        {"type": "arc", "radius": u(12, 15), "angle": u(20, 40), "turn": "up", "lumen": lum()},
        {"type": "straight", "length": u(60, 80), "lumen": lum()},
        {"type": "arc", "radius": u(10, 13), "angle": u(80, 120), "turn": "right", "roll": u(-20, 20),
         "lumen": lum()},  # hepatic flexure
        {"type": "straight", "length": u(60, 80), "lumen": lum(40, 52)},  # ascending, cecum
    ]
    from pathlib import Path

    tr = segments_trajectory({"name": f"tight-colon-{seed}", "segment": segs}, Path(f"tight-colon-{seed}"), feed)
    # a diameter that varies smoothly along the colon: the segments' values averaged over +-10 mm
    k = max(1, int(round(10.0 / feed)))
    lumen = np.convolve(np.pad(tr.lumen, k, mode="edge"), np.ones(2 * k + 1) / (2 * k + 1), mode="valid")
    tr.lumen = lumen
    tr.name = f"tight-colon-{seed}"
    return tr


def colon_for(seed: int, feed: float = 2.0) -> Trajectory:
    """The anatomical colon of ``seed`` when bhr has the generator, else the stand-in :func:`tight_colon`."""
    from bhr.model._generators import GENERATORS, load_trajectory

    if "anatomy" in GENERATORS:
        return load_trajectory("anatomy", feed=feed, seed=seed)
    return tight_colon(seed, feed)


def cecum_step(res) -> int:
    """0-based first step at which the tip has reached the cecum: its nearest centerline point (tracked from step
    to step) is the path's last point and it is at or past that point's cross-section. The last step if it never
    is."""
    C = res.trajectory.points
    M = C.shape[0]
    d = C[-1] - C[-2]
    d = d / np.linalg.norm(d)
    k = 0
    for i in range(res.points.shape[0]):
        tip = res.points[i, -1]
        lo, hi = max(0, k - 20), min(M, k + 40)
        k = lo + int(np.argmin(np.linalg.norm(C[lo:hi] - tip, axis=1)))
        if k == M - 1 and float(np.dot(tip - C[-1], d)) >= 0.0:
            return i
    return res.points.shape[0] - 1


def _metrics(res) -> dict[str, Any]:
    s = res.summary.to_dict()
    per = res.clearance.per_step
    stop = cecum_step(res)
    until = per[:stop + 1]
    return {"max_penetration_mm": s["max_penetration_mm"], "wall_touch_steps": len(s["wall_touch_steps"]),
            "min_clearance_mm": s["min_clearance_mm"], "points_max_error_mm": s["points_max_error_mm"],
            "steps": s["steps"], "cecum_step": stop + 1,
            # what a feeder that stops when the tip reaches the cecum would leave (docs/lumen.md)
            "max_penetration_to_cecum_mm": float(max(0.0, -np.nanmin(until))) if np.any(~np.isnan(until)) else 0.0}


def population(seeds: list[int], solvers: tuple[str, ...] = ("thesis", "lumen"), robot: Robot | None = None,
               solver_options: dict[str, dict[str, Any]] | None = None, progress: bool = False) -> dict[str, Any]:
    """Each solver on each colon; medians over colons and the ratios to the first solver."""
    robot = robot or Robot()
    opts = solver_options or {}
    rows = []
    import warnings

    for sd in seeds:
        tr = colon_for(sd, robot.feed)
        row: dict[str, Any] = {"seed": sd, "colon": tr.name, "length_mm": float(tr.params.get("length", 0.0))}
        for s in solvers:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = follow(tr, solver=s, robot=robot, solver_options=opts.get(s))
            row[s] = _metrics(res)
        rows.append(row)
        if progress:
            print(f"  colon {sd}: " + ", ".join(f"{s} pen {row[s]['max_penetration_mm']:.2f} mm "
                                                 f"touch {row[s]['wall_touch_steps']}" for s in solvers),
                  file=sys.stderr)
    med = {s: {m: statistics.median(r[s][m] for r in rows) for m in ("max_penetration_mm", "wall_touch_steps")}
           for s in solvers}
    for s in solvers:
        med[s]["max_penetration_to_cecum_mm"] = statistics.median(r[s]["max_penetration_to_cecum_mm"] for r in rows)
    ref = solvers[0]
    ratio = {s: {m: (med[s][m] / med[ref][m] if med[ref][m] else math.nan) for m in med[s]} for s in solvers[1:]}
    return {"seeds": seeds, "robot": robot.to_dict(), "rows": rows, "median": med, "ratio_to_" + ref: ratio}


def solve_times(seed: int = 1, repeats: int = 3, robot: Robot | None = None) -> dict[str, Any]:
    """Median CPU time per ``solve()`` call along one colon, lumen and thesis, driven step by step (same run)."""
    robot = robot or Robot()
    tr = colon_for(seed, robot.feed)
    out: dict[str, Any] = {"colon": tr.name, "steps": int(tr.points.shape[0]), "repeats": repeats}
    import warnings

    from bhr.solvers import available, _base as base

    available()  # load every solver module
    for name in ("thesis", "lumen"):
        per_run = []
        for _ in range(repeats + 1):  # the first run compiles
            times: list[float] = []
            cls: Any = base.REGISTRY[name]
            orig = cls.solve

            def timed(self, *a, _orig=orig, _t=times, **kw):
                t0 = time.process_time()  # CPU time: other processes on the machine do not count
                r = _orig(self, *a, **kw)
                _t.append(time.process_time() - t0)
                return r

            cls.solve = timed
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    follow(tr, solver=name, robot=robot, compiled=False)
            finally:
                cls.solve = orig
            per_run.append(statistics.median(times))
        out[name + "_ms"] = 1e3 * statistics.median(per_run[1:])
    out["lumen_over_thesis"] = out["lumen_ms"] / out["thesis_ms"]
    return out


def _seeds(text: str) -> list[int]:
    """The colons' seeds, in ``bhr traverse --colons``'s syntax (one line naming the problem otherwise)."""
    from bhr._settings.errors import BhrError
    from bhr._studies.traverse import parse_colons

    try:
        seeds = parse_colons(text)
    except BhrError as exc:
        raise argparse.ArgumentTypeError(str(exc).replace("--colons", "--seeds")) from None
    if any(isinstance(s, str) for s in seeds):
        raise argparse.ArgumentTypeError("--seeds takes the generated colons' seeds, not real colons")
    return [int(s) for s in seeds]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m bhr._bench.lumen", description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1-100", type=_seeds, help="colon seeds, e.g. 1-100 or 1,5,9 [1-100]")
    ap.add_argument("--json", default=None, help="also write the figures as JSON here")
    ap.add_argument("--no-timing", action="store_true", help="skip the time per step")
    a = ap.parse_args(argv)
    seeds = a.seeds
    pop = population(seeds, progress=True)
    doc: dict[str, Any] = {"population": pop}
    med, ratio = pop["median"], pop["ratio_to_thesis"]["lumen"]
    print(f"{len(seeds)} colons ({pop['rows'][0]['colon']} ...), thesis robot, geometric clearance:")
    print(f"  median max_penetration_mm  thesis {med['thesis']['max_penetration_mm']:.3f}  "
          f"lumen {med['lumen']['max_penetration_mm']:.3f}  ratio {ratio['max_penetration_mm']:.3f}")
    print(f"  median max_penetration_mm until the tip reaches the cecum  thesis "
          f"{med['thesis']['max_penetration_to_cecum_mm']:.3f}  lumen {med['lumen']['max_penetration_to_cecum_mm']:.3f}"
          f"  ratio {ratio['max_penetration_to_cecum_mm']:.3f}")
    print(f"  median wall-touch steps    thesis {med['thesis']['wall_touch_steps']:.1f}  "
          f"lumen {med['lumen']['wall_touch_steps']:.1f}  ratio {ratio['wall_touch_steps']:.3f}")
    if not a.no_timing:
        t = solve_times(seeds[0])
        doc["timing"] = t
        print(f"  solve() per step on {t['colon']} (median of {t['repeats']} runs): lumen {t['lumen_ms']:.3f} ms, "
              f"thesis {t['thesis_ms']:.3f} ms, lumen / thesis {t['lumen_over_thesis']:.1f}")
    if a.json:
        with open(a.json, "w", encoding="utf-8") as fh:
            json.dump(doc, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
