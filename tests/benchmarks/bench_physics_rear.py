"""A whole robot whose rear goes into the colon, replayed in MuJoCo: contact at the end of each step and at every
time step, the largest deviation from bhr's poses, CPU seconds.

    python3 tests/benchmarks/bench_physics_rear.py                       # 100 modules, the first 600 steps
    python3 tests/benchmarks/bench_physics_rear.py --modules 100 --steps 1000

(not collected by pytest: files here are named bench_*.py). The run is the trail model's whole robot on
anatomical colon 1 (``bhr follow --traj anatomy --seed 1 --solver lumen --locomotion trail --alpha 25
--module-length 5 --body-modules M``) cut to its first steps (``bhr.bench.cases.first_steps``); its rear end
passes the entrance after step M + 1 and the carriage then turns with the rear module (docs/physics.md). The
count over every time step wraps ``mujoco.mj_step`` and looks for a contact of ``dist <= 0`` after each.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modules", type=int, default=100, help="the whole robot's modules (--body-modules)")
    ap.add_argument("--steps", type=int, default=600, help="replay the run's first STEPS steps")
    args = ap.parse_args(argv)
    import mujoco
    import numpy as np

    import bhr
    from bhr.bench.cases import first_steps
    from bhr.model.generators import load_trajectory
    from bhr.model.robot import Robot
    from bhr.run.driver import BhrWarning
    from bhr.studies.physics import replay_physics

    r = Robot(alpha=25.0, module_length=5.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        run = bhr.follow(load_trajectory("anatomy", feed=r.feed, seed=1), solver="lumen", robot=r,
                         body_modules=args.modules, locomotion="trail")
    run = first_steps(run, args.steps)
    print(f"bhr: clearance >= {run.clearance.min_mm:.2f} mm over the first {args.steps} steps")
    real = mujoco.mj_step
    count = {"time_steps": 0, "touching": 0}

    def step(m, d, nstep=1):
        for _ in range(nstep):
            real(m, d)
            count["time_steps"] += 1
            if d.ncon and np.any(d.contact.dist[:d.ncon] <= 0):
                count["touching"] += 1

    mujoco.mj_step = step
    try:
        t0 = time.process_time()
        rep = replay_physics(run)
        cpu = time.process_time() - t0
    finally:
        mujoco.mj_step = real
    s = rep.summary()
    # a time step that found a contact with the damping folded in was undone and stepped again (the same contact)
    count["time_steps"] -= s["time_steps_redone"]
    count["touching"] -= s["time_steps_redone"]
    c = s["contact_steps"]
    span = f" ({c[0]}-{c[-1]})" if c else ""
    print(f"MuJoCo: contact at {len(c)} steps{span}, largest {s['max_force_n']:.2f} N; deviation at most "
          f"{s['max_deviation_mm']:.3f} mm; carriage moved at {s['carriage_moved_steps']} steps; a contact at "
          f"{count['touching']} of {count['time_steps']} time steps; {cpu:.1f} s CPU")


if __name__ == "__main__":
    main()
