"""``bhr warmup``: run every kernel bhr's commands run on a tiny case, with the argument types the commands give (numba
compiles for types, not sizes), so that numba's cache holds them all."""
from __future__ import annotations

import warnings

def compile_all() -> None:
    import numpy as np

    import bhr
    from bhr._hardware.thermal import DEFAULT_THERMAL, auto_schedule, check_schedule
    from bhr.model._generators import load_trajectory
    from bhr.output._steptable import format_steps_csv
    from bhr._run.driver import follow as run_follow

    def follow(*args, **kw):  # as a command finishes a run: summary, clearance, run.json, steps.csv
        result = run_follow(*args, **kw)
        result.to_dict()
        format_steps_csv(result)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # tiny cases tighter than the robot turns: no advice wanted here
        for solver in ("fabrik", "ccd", "thesis", "constrained", "optimal", "lumen"):
            bhr.solve([3, 9, 0], modules=5, solver=solver, tol_pos=0.01)
        bhr.solve([3, 9, 0], modules=5, solver="thesis", tip_direction=[0, 1, 0])
        bhr.Robot().fk([3, 0, 6, 0, 15])
        from bhr.model._workspace import workspace  # bhr workspace: every pose, and a Monte Carlo sample

        workspace(bhr.Robot(modules=2))
        workspace(bhr.Robot(modules=2), exact=False, samples=4)
        curve = load_trajectory("curve", angle=30, entry=4, exit=4)
        for solver in ("thesis", "constrained", "optimal", "fabrik", "ccd"):
            follow(curve, solver=solver)
        follow(load_trajectory("line", length=40), solver="thesis", body_modules=8)
        colon = load_trajectory("anatomy", seed=1)  # a lumen: the clearance's and the lumen solver's kernels
        short = type(colon)(colon.name, np.ascontiguousarray(colon.points[:60]), colon.params, colon.min_radius,
                            None if colon.lumen is None else np.ascontiguousarray(colon.lumen[:60]), colon.source,
                            start_direction=colon.start_direction, start_point=colon.start_point)
        follow(colon, solver="thesis")  # the whole colon: its arrays exactly as a command gives them
        follow(short, solver="lumen")
        follow(short, solver="thesis", body_modules=8)
        # the whole robot: moved by its wires (its motion and every pose scored, stopped where it leaves the
        # lumen too), the trail model, and the physical replay against the wall
        wires = run_follow(short, solver="lumen", body_modules=8)
        wires.to_dict()
        run_follow(short, solver="lumen", body_modules=8, stop_at_wall=True).to_dict()
        run_follow(short, solver="lumen", body_modules=8, locomotion="trail").to_dict()
        from bhr._studies.physics import replay_physics

        replay_physics(wires).summary()
        try:  # a real colon's wall as its surface mesh (the anatomy extra)
            import vtk  # noqa: F401
        except ImportError:
            pass
        else:
            import dataclasses

            real = load_trajectory("gca:E60")  # its first 40 mm, with its mesh
            assert real.lumen is not None
            cut = dataclasses.replace(real, points=np.ascontiguousarray(real.points[:40]),
                                      lumen=np.ascontiguousarray(real.lumen[:40]))
            follow(cut, solver="lumen")
            run_follow(cut, solver="lumen", body_modules=8).to_dict()
        rows = np.array([[3, 0, 6, 0, 0], [0, 12, 0, 9, 15]], dtype=np.int64)
        auto_schedule(DEFAULT_THERMAL, rows, 10.0)
        check_schedule(DEFAULT_THERMAL, rows, 10.0)
