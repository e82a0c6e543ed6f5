"""Measure how well bhr estimates a CSV centerline's smallest turn radius under noise.

For each true radius R, a path (200 mm straight, then a 400 mm arc of radius
R) is picked at 10,000 uniformly random arc lengths and every point is moved
by Gaussian noise of standard deviation e in x, y and z. The file is read as
`bhr follow --traj FILE.csv` reads it (resampled at the thesis feed, 2 mm) and
the estimated min_radius is printed; the last row is a 1000 mm straight line
(true radius: infinite). docs/trajectories.md quotes the output of

    python docs/examples/csv_curvature.py
"""
from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

from bhr.model import load_trajectory

NOISE = (0.0, 0.05, 0.1, 0.2)


def write_csv(path: Path, pts: np.ndarray) -> None:
    path.write_text("x,y,z\n" + "\n".join(f"{x:.9f},{y:.9f},{z:.9f}" for x, y, z in pts) + "\n")


def bend(rng: np.random.Generator, radius: float, n: int = 10000) -> np.ndarray:
    s = np.sort(rng.uniform(0.0, 600.0, n))
    s[0], s[-1] = 0.0, 600.0
    a = np.clip((s - 200.0) / radius, 0.0, None)
    x = np.where(s < 200.0, s, 200.0 + radius * np.sin(a))
    y = np.where(s < 200.0, 0.0, radius * (1.0 - np.cos(a)))
    return np.stack([x, y, np.zeros_like(s)], axis=1)


def main() -> None:
    rng = np.random.default_rng(7)
    print("true radius (mm) | " + " | ".join(f"noise {e:g} mm" for e in NOISE))
    print("---|" + "---|" * len(NOISE))
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "c.csv"
        for radius in (30.0, 57.15, 70.0, 150.0, math.inf):
            row = []
            for e in NOISE:
                if math.isinf(radius):
                    s = np.sort(rng.uniform(0.0, 1000.0, 10000))
                    pts = np.stack([s, 0 * s, 0 * s], axis=1)
                else:
                    pts = bend(rng, radius)
                write_csv(f, pts + rng.normal(0.0, e, pts.shape))
                row.append(f"{load_trajectory(f, feed=2.0).min_radius:.1f}")
            print(("straight" if math.isinf(radius) else f"{radius:g}") + " | " + " | ".join(row))
        print()
        print("short bends without noise (100 mm straight, bend, 100 mm straight):")
        for radius, angle in ((10.0, 90.0), (20.0, 90.0), (30.0, 45.0), (57.15, 30.0)):
            total = 200.0 + radius * math.radians(angle)
            s = np.sort(rng.uniform(0.0, total, 10000))
            s[0], s[-1] = 0.0, total
            a = np.clip((s - 100.0) / radius, 0.0, math.radians(angle))
            rest = np.clip(s - 100.0 - radius * math.radians(angle), 0.0, None)
            x = np.where(s < 100.0, s, 100.0 + radius * np.sin(a)) + rest * math.cos(math.radians(angle))
            y = np.where(s < 100.0, 0.0, radius * (1.0 - np.cos(a))) + rest * math.sin(math.radians(angle))
            write_csv(f, np.stack([x, y, 0 * s], axis=1))
            print(f"  radius {radius:g} mm, {angle:g} deg: estimated {load_trajectory(f, feed=2.0).min_radius:.1f} mm")


if __name__ == "__main__":
    main()
