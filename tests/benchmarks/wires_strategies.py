"""Which switching strategies keep a long robot closest to its trail, and how the swing grows with the robot's
length, alpha and module length (docs/locomotion.md, "The wires: measured").

    python tests/benchmarks/wires_strategies.py strategies --colon 1 --modules 40,100
    python tests/benchmarks/wires_strategies.py growth --colon 1 --modules 20,60,140 --alpha 20,25,30 --module 5,6

``strategies``: every strategy of bhr._run.motion.STRATEGIES alone, and the planner that picks one per module
length, on the same robot (alpha 25 deg, 5 mm modules): the largest distance of a joint from the trail between
module lengths, the median over module lengths of each one's largest, the least clearance, and the procedure
time. ``growth``: the planner's figures against the robot's length, alpha and module length. CPU seconds at
the end.
"""
from __future__ import annotations

import argparse
import resource
import warnings

import numpy as np


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _one(seed: int, M: int, alpha: float, L: float, strategies=None) -> dict:
    import bhr
    from bhr.model._robot import Robot
    from bhr._run.driver import BhrWarning
    from bhr._run.motion import wires_motion
    from bhr.solvers import get_solver

    robot = Robot(alpha=alpha, module_length=L)
    tr = bhr.trajectory("anatomy", seed=seed).at_feed(robot.feed)
    s = get_solver("lumen", robot)
    s.prepare(tr)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        mo = wires_motion(tr, robot, s, M, False, strategies)[0]
    per = [float(np.max(mo.trail_offset_mm[a + 1:b + 1])) for a, b in zip(np.r_[-1, mo.ends[:-1]], mo.ends)]
    return {"offset_max": float(np.max(mo.trail_offset_mm)), "offset_median": float(np.median(per)),
            "clear_min": float(np.nanmin(mo.pose_clear)), "time_s": float(mo.t_s[-1]), "poses": int(mo.t_s.size)}


def main() -> None:
    from bhr._run.motion import STRATEGIES

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("strategies", "growth"))
    ap.add_argument("--colon", type=int, default=1)
    ap.add_argument("--modules", default="40,100")
    ap.add_argument("--alpha", default="25")
    ap.add_argument("--module", default="5")
    a = ap.parse_args()
    t0 = _cpu()
    Ms = [int(v) for v in a.modules.split(",")]
    if a.what == "strategies":
        print("| robot | strategy | largest off the trail | median per module length | least clearance | time |")
        print("|---|---|---|---|---|---|")
        for M in Ms:
            for st in (None,) + STRATEGIES:
                r = _one(a.colon, M, 25.0, 5.0, None if st is None else (st,))
                name = "planner (best of all, per module length)" if st is None else st.name
                print(f"| {M} x 5 mm | {name} | {r['offset_max']:.1f} mm | {r['offset_median']:.1f} mm | "
                      f"{r['clear_min']:.1f} mm | {r['time_s']:.0f} s |", flush=True)
    else:
        print("| α | module | robot | largest off the trail | median per module length | least clearance |")
        print("|---|---|---|---|---|---|")
        for alpha in (float(v) for v in a.alpha.split(",")):
            for L in (float(v) for v in a.module.split(",")):
                for M in Ms:
                    r = _one(a.colon, M, alpha, L)
                    print(f"| {alpha:g}° | {L:g} mm | {M} ({M * L / 1000:g} m) | {r['offset_max']:.1f} mm | "
                          f"{r['offset_median']:.1f} mm | {r['clear_min']:.1f} mm |", flush=True)
    print(f"\n{_cpu() - t0:.0f} s CPU")


if __name__ == "__main__":
    main()
