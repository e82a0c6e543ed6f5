"""The real colons' wall grids (docs/real_colons.md, "The wall as the real surface"): the CPU seconds of each
shipped colon's signed-distance grid on an empty cache, then the grid against vtk's exact distance on the written
poses of a 35-module robot through E60 (the poses tests/unit/test_wallmesh.py checks), by depth into the wall.

    python docs/examples/mesh_checks.py
"""
from __future__ import annotations

import os
import tempfile
import time
import warnings

import numpy as np


def main() -> None:
    os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="bhr-mesh-checks-")  # an empty grid cache
    import bhr
    from bhr.model import load_trajectory
    from bhr.model._trajnames import real_colons
    from bhr.model._wallmesh import exact_distance, read_mesh, wall_grid

    warnings.simplefilter("ignore")
    for name in real_colons():
        t = load_trajectory(name)
        cpu = time.process_time()
        _, wall = wall_grid(t)
        print(f"{name}: grid {time.process_time() - cpu:.1f} s of CPU ({wall})")

    t = load_trajectory("gca:E60", feed=1.0)
    run = bhr.follow(t, solver="lumen", alpha=30, module_length=5, body_modules=30)
    mo, mesh = run.motion, read_mesh(t.mesh)
    radius, length = run.robot.robot_radius, run.robot.module_length
    worst = np.argsort(np.where(np.isnan(mo.pose_clear), np.inf, mo.pose_clear))[:40]
    pick = np.unique(np.concatenate([worst, np.random.default_rng(0).choice(len(mo.t_s), 40, replace=False)]))
    f = np.linspace(0.0, 1.0, 21)
    rows = []
    for p in pick:  # each module's part inside the anus, every 0.25 mm
        P = mo.points_mm[p]
        q = mo.insertion_mm[p] / length - (P.shape[0] - 1) + np.arange(P.shape[0])
        ok = q[1:] >= 0.0
        u = np.clip(-q[:-1][ok], 0.0, 1.0)[:, None] + f[None, :] * (1.0 - np.clip(-q[:-1][ok], 0.0, 1.0)[:, None])
        samples = (P[:-1][ok][:, None] + u[:, :, None] * (P[1:] - P[:-1])[ok][:, None]).reshape(-1, 3)
        if samples.size:
            rows.append((float(np.min(-exact_distance(mesh, samples) - radius)), float(mo.pose_clear[p])))
    exact, grid = np.array(rows).T
    diff = grid - exact
    print(f"E60, {len(rows)} poses: grid - exact clearance, median |diff| {np.median(np.abs(diff)):.2f} mm")
    for lo, hi in ((0.0, 8.0), (8.0, 20.0), (20.0, np.inf)):
        m = (-exact >= lo) & (-exact < hi)
        if m.any():
            print(f"  {m.sum()} poses {-exact[m].max():.1f}-{-exact[m].min():.1f} mm into the wall: |diff| at most "
                  f"{np.abs(diff[m]).max():.2f} mm (grid - exact {diff[m].min():+.2f} to {diff[m].max():+.2f})")


if __name__ == "__main__":
    main()
