"""The largest contact force of a run into the wall against the MuJoCo time step, and against the step's length.

    python3 tests/benchmarks/bench_physics_force.py                  # 8, 12, 16, 24, 32, 64 substeps at 20 Hz
    python3 tests/benchmarks/bench_physics_force.py --rate 2.5:128   # also 2.5 Hz steps of 128 substeps

(not collected by pytest: files here are named bench_*.py). The run is the thesis solver's on anatomical colon 4,
its first 130 steps (tests/integration/test_physics_replay.py's ``_head(130, "thesis", seed=4)``: bhr finds it in
the wall from step 112). Printed per setting: the time step, the largest contact force and its step, the
contact steps, the largest deviation from bhr's pose before the first contact and over the run.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--substeps", default="8,12,16,24,32,64", help="substeps per 20 Hz step, comma-separated")
    ap.add_argument("--rate", action="append", default=[], metavar="HZ:SUBSTEPS",
                    help="also replay at this step rate and substeps (repeatable)")
    args = ap.parse_args(argv)
    from bhr.studies.physics import replay_physics
    from tests.integration.test_physics_replay import _head

    run = _head(130, "thesis", seed=4)
    touched = run.clearance.touch_steps
    print(f"bhr: in the wall at {len(touched)} steps ({touched[0]}-{touched[-1]}), "
          f"deepest {run.clearance.max_penetration_mm:.1f} mm")
    settings = [(20.0, int(s)) for s in args.substeps.split(",")]
    settings += [(float(r.split(":")[0]), int(r.split(":")[1])) for r in args.rate]
    for rate, sub in settings:
        rep = replay_physics(run, rate=rate, substeps=sub)
        s = rep.summary()
        c = s["contact_steps"]
        first = c[0] if c else len(rep.deviation_mm) + 1
        span = f"{len(c)} steps ({c[0]}-{c[-1]})" if c else "none"
        print(f"{rate:5g} Hz x {sub:3d} substeps (dt {s['timestep_s'] * 1e3:.3f} ms): largest force "
              f"{s['max_force_n']:6.2f} N at step {s['max_force_step']}; contact {span}; deviation "
              f"{float(rep.deviation_mm[:first - 1].max(initial=0.0)):.4f} mm before contact, "
              f"{s['max_deviation_mm']:.3f} mm at most; {s['cpu_s']:.1f} s CPU", flush=True)


if __name__ == "__main__":
    main()
