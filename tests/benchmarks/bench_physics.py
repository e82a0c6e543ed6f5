"""The physical robot's replay: CPU seconds for a whole robot through one colon, and a study of colons.

    python3 tests/benchmarks/bench_physics.py                        # 300 modules of 5 mm (1.5 m), colon 1
    python3 tests/benchmarks/bench_physics.py --modules 60 --colons 1-3 --substeps 1,4
    python3 tests/benchmarks/bench_physics.py --steps 1000 --max-iterations 3000   # ten times the limit

(not collected by pytest: files here are named bench_*.py). Per colon: the run (``bhr follow --traj anatomy
--seed K --solver lumen --locomotion trail --alpha 25 --module-length 5 --body-modules M``), then its replay
(bhr._studies.physics.replay_physics); printed: the CPU seconds of the replay (this process's user + system, by
time.process_time around it), the equilibria solved, the wall's peak load, the stretch, the feeder's push, whether
the tip reached the cecum and the equilibria not reached. The runs themselves are not counted.
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
    ap.add_argument("--modules", type=int, default=300)
    ap.add_argument("--colons", default="1", help="FIRST-LAST or one seed")
    ap.add_argument("--alpha", type=float, default=25.0)
    ap.add_argument("--substeps", default="1", help="comma-separated")
    ap.add_argument("--steps", type=int, default=0, help="replay only the first STEPS steps (0: all)")
    ap.add_argument("--max-iterations", type=int, default=0,
                    help="of one equilibrium (0: the replay's own limit); a higher limit shows whether the "
                         "equilibria not reached converge slowly or not at all")
    args = ap.parse_args(argv)
    import bhr
    from bhr.model._generators import load_trajectory
    from bhr.model._robot import Robot
    from bhr._run.driver import BhrWarning
    from bhr._studies.physics import poses_from_run, replay_poses
    from bhr._studies.physics.poses import Poses

    a, _, b = args.colons.partition("-")
    seeds = range(int(a), int(b or a) + 1)
    total = 0.0
    for seed in seeds:
        r = Robot(alpha=args.alpha, module_length=5.0)
        tr = load_trajectory("anatomy", feed=r.feed, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            run = bhr.follow(tr, solver="lumen", robot=r, body_modules=args.modules, locomotion="trail")
        p = poses_from_run(run)
        if args.steps:
            k = slice(0, args.steps)
            p = Poses(p.t_s[k], p.insertion_mm[k], p.points_mm[k], p.tilts_rad[k], p.codes[k], p.step[k], p.entrance,
                      p.frame, p.module_length)
        for sub in (int(x) for x in args.substeps.split(",")):
            t0 = time.process_time()
            rep = replay_poses(p, run, substeps=sub, **({"max_iterations": args.max_iterations}
                                                        if args.max_iterations else {}))
            cpu = time.process_time() - t0
            total += cpu
            s = rep.summary()
            print(f"colon {seed}: {args.modules} modules, {s['poses']} poses, substeps {sub}: {cpu:.1f} s CPU, "
                  f"{s['equilibria']} equilibria ({s['equilibria_not_reached']} not reached); wall load at most "
                  f"{s['max_total_force_n']:.2f} N (module {s['max_module_force_n']:.2f} N, "
                  f"{s['max_pressure_kpa']:.0f} kPa), {s['steps_over_9_8_n']} steps over 9.8 N; stretch "
                  f"{s['max_stretch_mm']:.1f} mm; feeder {s['max_feeder_force_n']:.1f} N, "
                  f"{s['max_feeder_lag_mm']:.0f} mm behind; cecum {s['reached_cecum_step']} "
                  f"(written poses {s['written_poses_reach_cecum_step']})", flush=True)
    print(f"total {total:.1f} s CPU over {len(seeds)} colon(s)")


if __name__ == "__main__":
    main()
