"""The real colons against a design: the clearance measured against each colon's surface mesh and against the tube
of its lumen diameters, on the same run; then the verdict with the insufflated lumen model (docs/real_colons.md).

    python docs/examples/real_colons_table.py [--alpha 30 --module-length 5 --solver lumen] [--colons gca:E60,...]
    python docs/examples/real_colons_table.py --whole-robot [--alpha 30 ...]

``--whole-robot``: the whole robot as it can be built (locomotion wires, as many modules as reach the cecum),
CT lumen and insufflated, instead of the head; with ``--stop-at-wall`` each run ends where the robot leaves the
lumen (the same verdict and step, in a fraction of the CPU; the touches and depth are then those up to there).
"""
from __future__ import annotations

import argparse
import resource
import warnings

import numpy as np

import bhr
from bhr.model import load_trajectory
from bhr.model._trajnames import real_colons
from bhr._run.clearance import clearance_report
from bhr._run.driver import BhrWarning


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--alpha", type=float, default=30.0)
    ap.add_argument("--module-length", type=float, default=5.0)
    ap.add_argument("--solver", default="lumen")
    ap.add_argument("--colons", default=",".join(real_colons()), help="comma-separated names (default: all five)")
    ap.add_argument("--whole-robot", action="store_true", help="the whole robot (wires, reach cecum), not the head")
    ap.add_argument("--lumen", choices=("ct", "insufflated", "both"), default="both",
                    help="--whole-robot: which lumen (default both)")
    ap.add_argument("--stop-at-wall", action="store_true",
                    help="--whole-robot: end each run where the robot leaves the lumen")
    a = ap.parse_args()
    robot = bhr.Robot(alpha=a.alpha, module_length=a.module_length)
    names = [n for n in a.colons.split(",") if n]
    if a.whole_robot:
        whole_robot(a, robot, names)
        return
    print(f"solver {a.solver}, alpha {a.alpha:g} deg, modules of {a.module_length:g} mm, robot radius "
          f"{robot.robot_radius:g} mm, feed {robot.feed:g} mm")
    print("| colon | steps | wall | mesh: min clearance (mm) | mesh: steps touching | tube: min clearance (mm) | "
          "tube: steps touching | steps where the two disagree | CPU s (run, mesh, tube) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |", flush=True)
    verdicts = []
    for name in names:
        tr = load_trajectory(name, feed=robot.feed)
        t0 = cpu()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            run = bhr.follow(tr, a.solver, robot)
        t1 = cpu()
        mesh = clearance_report(run)
        t2 = cpu()
        tube = clearance_report(run, mesh=False)
        t3 = cpu()
        assert mesh is not None and tube is not None
        ms, ts = set(mesh.touch_steps), set(tube.touch_steps)
        print(f"| {name} | {run.steps} | {mesh.wall} | {mesh.min_mm:.2f} | {len(ms)} | {tube.min_mm:.2f} | {len(ts)} | "
              f"{len(ms ^ ts)} | {t1 - t0:.1f}, {t2 - t1:.1f}, {t3 - t2:.1f} |")
        diff = mesh.per_step - tube.per_step
        ok = np.isfinite(diff)
        print(f"|   | | per step, mesh - tube: median {np.median(diff[ok]):+.2f} mm, 5-95 % "
              f"{np.percentile(diff[ok], 5):+.2f} to {np.percentile(diff[ok], 95):+.2f} mm | | | | | | |", flush=True)
        verdicts.append((name, run, mesh))
    print()
    print("| colon | lumen | verdict | steps touching the wall | deepest into the wall (mm) | left the lumen | "
          "wall measured against |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, run, rep in verdicts:
        print(_verdict_row(name, "CT", run, rep), flush=True)
        tr = load_trajectory(name, feed=robot.feed, lumen_model="insufflated")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            ins = bhr.follow(tr, a.solver, robot)
        print(_verdict_row(name, "insufflated (model)", ins, ins.clearance), flush=True)


def whole_robot(a, robot, names) -> None:
    """The whole robot (locomotion wires, reach cecum) on each colon, CT lumen and insufflated: the verdict."""
    print(f"whole robot: locomotion wires, as many modules as reach the cecum; solver {a.solver}, alpha {a.alpha:g} "
          f"deg, modules of {a.module_length:g} mm, robot radius {robot.robot_radius:g} mm, feed {robot.feed:g} mm")
    print("| colon | lumen | modules | verdict | steps touching the wall | deepest into the wall (mm) | "
          "left the lumen | tip short of the cecum (mm) | wall measured against | CPU s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |", flush=True)
    for name in names:
        for model, label in (("ct", "CT"), ("insufflated", "insufflated (model)")):
            if a.lumen not in ("both", model):
                continue
            tr = load_trajectory(name, feed=robot.feed, lumen_model=model)
            t0 = cpu()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BhrWarning)
                run = bhr.follow(tr, a.solver, robot, reach="cecum", locomotion="wires",
                                 stop_at_wall=a.stop_at_wall)
                rep = run.clearance
            t1 = cpu()
            s = run.summary.to_dict()
            left = f"step {rep.left_lumen_step}" if rep.left_lumen_step else "no"
            stopped = s.get("stopped_at_wall_step")
            steps = f"{run.steps} (the run ended there; the path has {s['path_steps']})" if stopped else run.steps
            short = "-" if stopped else f"{s.get('cecum_shortfall_mm', 0.0):.1f}"
            print(f"| {name} | {label} | {run.body.modules + robot.modules} | "
                  f"{run.status} | {len(rep.touch_steps)} of {steps} | {rep.max_penetration_mm:.2f} | {left} | "
                  f"{short} | {s.get('wall', rep.wall)} | {t1 - t0:.0f} |", flush=True)


def _verdict_row(name, lumen, run, rep) -> str:
    s = run.summary.to_dict()
    left = f"step {rep.left_lumen_step}" if rep.left_lumen_step else "no"
    return (f"| {name} | {lumen} | {run.status} | {len(rep.touch_steps)} of {run.steps} | "
            f"{rep.max_penetration_mm:.2f} | {left} | {s.get('wall', rep.wall)} |")


if __name__ == "__main__":
    main()
