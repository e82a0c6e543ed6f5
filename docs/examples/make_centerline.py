"""Write trajectories/example_centerline.csv: a measured-looking colon centerline.

A smooth 3D path (rectum, sigmoid loop, descending colon with gentle rises and
falls) is drawn with bhr's segment sampler at 0.05 mm, then picked at
irregular spacings of 0.5-4 mm, perturbed by 0.05 mm of Gaussian noise (as a
CT centerline extraction might be) and given a lumen diameter that widens
from 30 mm in the rectum to 45 mm. Run from the repository root:

    python docs/examples/make_centerline.py
"""
from __future__ import annotations

import sys
import tomllib
from pathlib import Path

import numpy as np

from bhr.output._atomic import write_text
from bhr.model._pathfile import segments_trajectory

SHAPE = """
name = "centerline source"
[[segment]]
type = "straight"
length = 40.0
[[segment]]
type = "arc"
radius = 70.0
angle = 90.0
turn = "left"
[[segment]]
type = "arc"
radius = 90.0
angle = 25.0
turn = "up"
[[segment]]
type = "arc"
radius = 90.0
angle = 25.0
turn = "down"
[[segment]]
type = "straight"
length = 80.0
[[segment]]
type = "arc"
radius = 75.0
angle = 120.0
turn = "right"
[[segment]]
type = "straight"
length = 60.0
[[segment]]
type = "arc"
radius = 100.0
angle = 60.0
turn = "left"
[[segment]]
type = "straight"
length = 100.0
"""


def main(out: Path) -> None:
    rng = np.random.default_rng(20240607)
    dense = segments_trajectory(tomllib.loads(SHAPE), Path("shape.toml"), 0.05).points
    picks = [0]
    while True:
        nxt = picks[-1] + int(rng.uniform(0.5, 4.0) / 0.05)
        if nxt >= len(dense) - 1:
            break
        picks.append(nxt)
    picks.append(len(dense) - 1)
    pts = dense[picks] + rng.normal(0.0, 0.05, (len(picks), 3))
    s = np.asarray(picks, dtype=float) * 0.05
    lumen = 30.0 + 15.0 * np.clip((s - 20.0) / 120.0, 0.0, 1.0)
    lines = ["# Example centerline (docs/trajectories.md), written by docs/examples/make_centerline.py:",
             "# irregularly spaced points (mm) with 0.05 mm of noise and the lumen diameter (mm) at each.",
             "x,y,z,lumen"]
    lines += [f"{p[0]:.3f},{p[1]:.3f},{p[2]:.3f},{d:.1f}" for p, d in zip(pts, lumen)]
    write_text(out, "\n".join(lines) + "\n")
    print(f"wrote {out}: {len(pts)} points")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("trajectories/example_centerline.csv"))
