"""The wires' motion, scoring only what may have come nearer the wall against scoring every joint and module of
every pose (docs/locomotion.md, "Speed"): CPU seconds of each in the same process, and the tables compared.

    python tests/benchmarks/wires_scoring.py --colon 1 --modules 60,100
"""
from __future__ import annotations

import argparse
import resource


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    import numpy as np

    import bhr
    from bhr.model._robot import Robot
    from bhr._run.motion import wires_motion
    from bhr.solvers import get_solver

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--colon", type=int, default=1)
    ap.add_argument("--modules", default="60,100")
    ap.add_argument("--alpha", type=float, default=25.0)
    ap.add_argument("--module", type=float, default=5.0)
    a = ap.parse_args()
    tr = bhr.trajectory("anatomy", seed=a.colon)
    robot = Robot(alpha=a.alpha, module_length=a.module)
    solver = get_solver("lumen", robot)
    wires_motion(tr, robot, solver, 10)  # compiles
    wires_motion(tr, robot, solver, 10, bound=False)
    print("| modules | poses | every joint and module | bounded | ratio | largest table difference |")
    print("|---|---|---|---|---|---|")
    for m in (int(v) for v in a.modules.split(",")):
        t0 = _cpu()
        ref = wires_motion(tr, robot, solver, m, bound=False)[0]
        t1 = _cpu()
        fast = wires_motion(tr, robot, solver, m)[0]
        t2 = _cpu()
        diff = max(float(np.nanmax(np.abs(x - y), initial=0.0)) for x, y in (
            (fast.joint_clear, ref.joint_clear), (fast.module_clear, ref.module_clear),
            (fast.pose_clear, ref.pose_clear)))
        print(f"| {m} | {fast.t_s.size} | {t1 - t0:.1f} s | {t2 - t1:.1f} s | {(t1 - t0) / (t2 - t1):.2f}x | "
              f"{diff:.2g} mm |", flush=True)


if __name__ == "__main__":
    main()
