"""The first run on an empty cache: small loops interpreted (bhr._numba.call_cold) against compiling them all.

    python tests/benchmarks/bench_first_run.py            # 3 rounds: the A/B table, then the calibration
    python tests/benchmarks/bench_first_run.py --rounds 5 --no-calibration

A/B, alternating in one run, each `bhr follow --traj colon --out o` with an empty numba cache of its own:
- "interpreted where cheaper": as a user's first command runs (the background compile on; it is stopped as the
  command ends, its time not the command's);
- "compile everything": BHR_NO_BACKGROUND_COMPILE=1, so every kernel the command runs is compiled (the
  behaviour before call_cold).
CPU seconds (user + system) of the command, medians, and their ratio.

The calibration backs the constants in bhr/solvers/thesis.py, bhr/hardware/thermal.py and bhr/run/clearance.py:
interpreted CPU seconds per unit of size (the largest over the cases; for the clearance, its numpy version per
place scored), and the CPU seconds numba takes to compile each kernel (a fresh cache, in a process of its own).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bhr.bench.commands import run_once

CALIBRATE = r'''
import json, sys, time
import numpy as np
import bhr
from bhr import _numba
from bhr.hardware import thermal
from bhr.run import clearance
from bhr.solvers import thesis

what = sys.argv[1]
out = {}
cases = [("colon", {}), ("curve", {}), ("line", {"length": 400})]
if what == "interpreted":
    per_loop, per_drive, per_step, ratios = [], [], [], []
    for name, kw in cases:
        traj = bhr.trajectory(name, **kw)
        for modules in (5, 10):
            calls = []
            def timed(kernel, i_s, c_s, *args, instead=None, calls=calls):
                t = time.process_time()
                r = (instead if instead is not None else _numba.interpreted(kernel))(*args)
                calls.append((kernel.py_func.__name__, args, time.process_time() - t))
                return r
            for module in (thesis, thermal, clearance):
                module.call_cold = timed
            r = bhr.follow(traj, solver="thesis", modules=modules)
            thermal.auto_schedule(thermal.DEFAULT_THERMAL, np.asarray(r.codes, dtype=np.int64), 10.0)
            for fname, args, s in calls:
                if fname == "follow_constrained_kernel":
                    per_loop.append(s / (args[0].shape[0] * (args[2].shape[0] - 1) ** 2))
                elif fname == "_kernel_py":
                    per_drive.append(s / (args[1].shape[0] * args[1].shape[1]))
    for seed in (1, 2, 3):  # the clearance in numpy, per place scored, on anatomical colons with and without a body
        traj = bhr.trajectory("anatomy", seed=seed)
        for body in (None, 20):
            r = bhr.follow(traj, solver="thesis", body_modules=body)
            Q, E, _ = clearance.run_chain(r)
            tube = clearance.make_tube(traj.points, traj.lumen, traj.start_direction, closed_end=True)
            seen = []
            clearance.call_cold = lambda k, i_s, c_s, *args, instead=None: seen.append(args) or k(*args)
            clearance.clearance_run_all(tube, 5.0, Q, E)  # warm: the arguments of the run
            t = time.process_time(); clearance._run_vectorised(*seen[-1]); vectorised = time.process_time() - t
            t = time.process_time(); clearance._run_kernel(*seen[-1]); compiled = time.process_time() - t
            per_step.append(vectorised / clearance._places(Q, 1.0))
            ratios.append(vectorised / compiled)
    out = {"loop_per_step_module2": max(per_loop), "drive_per_row_module": max(per_drive),
           "clearance_numpy_per_place": max(per_step),
           "clearance_numpy_over_compiled": [round(min(ratios), 1), round(max(ratios), 1)]}
else:  # compile times: each kernel on its first call, a fresh cache
    traj = bhr.trajectory("colon")
    t = time.process_time(); r = bhr.follow(traj, solver="thesis"); out["follow loop (thesis)"] = time.process_time() - t
    codes = np.asarray(r.codes, dtype=np.int64)
    t = time.process_time(); thermal.auto_schedule(thermal.DEFAULT_THERMAL, codes[:2], 10.0)
    out["drive model"] = time.process_time() - t
    Q, E, _ = clearance.run_chain(r)
    tube = clearance.make_tube(traj.points, traj.lumen, traj.start_direction)
    K = Q.shape[1]
    S, BC, BR = tube.search_arrays()
    t = time.process_time()
    clearance.clearance_chain_kernel(tube.points, tube.radius, S, BC, BR, float(tube.pre), float(tube.window), 5.0,
                                     Q[0], E[0], E[0].copy(), 1.0, np.empty(K), np.empty(K - 1),
                                     np.empty((K - 1, 3)), np.full(K, np.nan))
    out["clearance step kernel"] = time.process_time() - t
    t = time.process_time(); clearance.clearance_run_all(tube, 5.0, Q[:2], E[:2])
    out["clearance loop (its step kernel compiled)"] = time.process_time() - t
    out["clearance, both"] = out["clearance step kernel"] + out["clearance loop (its step kernel compiled)"]
print(json.dumps(out))
'''


def first_run(interpret: bool) -> float:
    """CPU seconds of one `bhr follow --traj colon` on an empty cache."""
    with tempfile.TemporaryDirectory() as tmp:
        cpu, _, code = run_once(["follow", "--traj", "colon", "--out", "o"], Path(tmp), cold=True,
                                interpret=interpret)
        if code != 0:
            raise SystemExit(f"bhr follow --traj colon failed on an empty cache (exit {code})")
        return cpu


def calibrate(what: str) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "cache"), BHR_NO_BACKGROUND_COMPILE="1")
        if what == "interpreted":  # a warm cache: only the interpreted code is timed
            env.pop("NUMBA_CACHE_DIR")
        proc = subprocess.run([sys.executable, "-c", CALIBRATE, what], env=env, capture_output=True, text=True)
        if proc.returncode != 0:
            raise SystemExit(proc.stderr)
        return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--no-calibration", action="store_true")
    a = ap.parse_args(argv)
    load0 = os.getloadavg()
    runs: dict[str, list[float]] = {"interpreted where cheaper": [], "compile everything": []}
    for _ in range(a.rounds):
        runs["interpreted where cheaper"].append(first_run(True))
        runs["compile everything"].append(first_run(False))
    load1 = os.getloadavg()
    print(f"# bhr follow --traj colon, empty cache, {a.rounds} rounds alternating; load average "
          f"{load0[0]:.1f} before, {load1[0]:.1f} after; {time.strftime('%Y-%m-%d %H:%M')}")
    print("| first run | CPU median (range) |")
    print("| --- | --- |")
    for name, v in runs.items():
        print(f"| {name} | {statistics.median(v):.2f} s ({min(v):.2f}–{max(v):.2f}) |")
    ratio = statistics.median(runs["interpreted where cheaper"]) / statistics.median(runs["compile everything"])
    print(f"ratio interpreted / compiled: {ratio:.2f}×")
    if not a.no_calibration:
        print("interpreted, CPU s per unit (largest over the cases):", json.dumps(calibrate("interpreted")))
        print("compile, CPU s per kernel (fresh cache):", json.dumps(calibrate("compile")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
