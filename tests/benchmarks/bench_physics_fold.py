"""The physics replay with the implicit damping folded into the mass matrix, against MuJoCo's own at every time step,
in one process: CPU seconds, MuJoCo's timers per time step, and how far the two replays' figures differ.

    python3 tests/benchmarks/bench_physics_fold.py                      # 300 modules, the first 100 steps
    python3 tests/benchmarks/bench_physics_fold.py --run wall           # the thesis run into the wall (colon 4)
    python3 tests/benchmarks/bench_physics_fold.py --modes old,folded,exact --repeat 2
    python3 tests/benchmarks/bench_physics_fold.py --run wall --modes old,all --substeps 32

(not collected by pytest: files here are named bench_*.py). Modes: ``old`` MuJoCo's implicit damping at every
time step (``bhr.studies.physics.DAMPING_IN_ARMATURE = False``: the replay before the fold), ``folded`` the
default (folded wherever no contact acts), ``exact`` folded wherever no constraint acts (a joint limit unfolds it
too: ``FOLD_AT_JOINT_LIMITS = False``), ``all`` folded at every time step, contacts too (``_Stepper`` told that no
constraint ever acts: the contacts solved with M + h D, which the replay does not do). The 300-module run is ``bhr bench --case physics-300``'s (the trail model's
whole robot on anatomical colon 1) cut with ``bhr.bench.cases.first_steps``; ``wall`` is
tests/integration/test_physics_replay.py's ``_head(130, "thesis", seed=4)``. The timers are MuJoCo's own
(``data.timer``, summed over the replay's time steps), read from the last ``mujoco.mj_step`` call's data.
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

TIMERS = ("STEP", "POS_INERTIA", "ADVANCE", "POS_COLLISION", "CONSTRAINT")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", choices=("p300", "wall"), default="p300", help="which run to replay")
    ap.add_argument("--steps", type=int, default=100, help="p300: replay the run's first STEPS steps")
    ap.add_argument("--substeps", type=int, default=16, help="MuJoCo time steps per step")
    ap.add_argument("--modes", default="old,folded", help="comma-separated: old, folded, exact, all")
    ap.add_argument("--repeat", type=int, default=1, help="replays of each mode, interleaved")
    args = ap.parse_args(argv)
    import mujoco
    import numpy as np

    from bhr.studies import physics as ph

    if args.run == "wall":
        from tests.integration.test_physics_replay import _head

        run = _head(130, "thesis", seed=4)
    else:
        from bhr.bench.cases import first_steps
        from bhr.model.generators import load_trajectory
        from bhr.model.robot import Robot
        from bhr.run.driver import BhrWarning, follow

        r = Robot(alpha=25.0, module_length=5.0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            run = follow(load_trajectory("anatomy", feed=r.feed, seed=1), solver="lumen", robot=r,
                         body_modules=300, locomotion="trail")
        first_steps(run, min(args.steps, run.steps))
    modes = args.modes.split(",")
    for m in modes:
        if m not in ("old", "folded", "exact", "all"):
            raise SystemExit(f"--modes: unknown mode {m!r}; give old, folded, exact or all")
    step = mujoco.mj_step
    last: dict[str, object] = {}

    def wrapped(model, data, nstep=1):
        step(model, data, nstep)
        last["data"] = data

    mujoco.mj_step = wrapped
    constrained = ph._Stepper._constrained
    first: dict[str, object] = {}
    cpu: dict[str, list[float]] = {m: [] for m in modes}
    for _ in range(args.repeat):
        for m in modes:
            ph.DAMPING_IN_ARMATURE = m != "old"
            ph.FOLD_AT_JOINT_LIMITS = m != "exact"
            ph._Stepper._constrained = (lambda self: False) if m == "all" else constrained  # type: ignore[method-assign]
            t0 = time.process_time()
            rep = ph.replay_physics(run, substeps=args.substeps)
            cpu[m].append(time.process_time() - t0)
            first.setdefault(m, rep)
            d = last["data"]
            n = max(1, int(d.timer[mujoco.mjtTimer.mjTIMER_STEP].number))
            ms = {t: 1e3 * float(d.timer[getattr(mujoco.mjtTimer, "mjTIMER_" + t)].duration) / n for t in TIMERS}
            s = rep.summary()
            print(f"{m:6s} {cpu[m][-1]:7.2f} s CPU; per time step (ms) " + ", ".join(f"{k} {v:.2f}" for k, v in ms.items())
                  + f"; time steps with MuJoCo's implicit damping {s['time_steps_unfolded']} of "
                  f"{len(rep.max_force_n) * args.substeps} (undone {s['time_steps_redone']}); largest force "
                  f"{s['max_force_n']:.4f} N, contact steps {len(s['contact_steps'])}, deviation at most "
                  f"{s['max_deviation_mm']:.4f} mm", flush=True)
    mujoco.mj_step = step
    ph._Stepper._constrained = constrained  # type: ignore[method-assign]
    if "old" in first:
        a = first["old"]
        for m in modes:
            if m == "old":
                continue
            b = first[m]
            print(f"{m} against old: CPU {np.median(cpu[m]) / np.median(cpu['old']):.2f}x (medians); largest "
                  f"|force difference| {float(np.abs(a.max_force_n - b.max_force_n).max()):.2g} N, largest "
                  f"|deviation difference| {float(np.abs(a.deviation_mm - b.deviation_mm).max()):.2g} mm, same "
                  f"contact steps: {a.contact_steps == b.contact_steps}")


if __name__ == "__main__":
    main()
