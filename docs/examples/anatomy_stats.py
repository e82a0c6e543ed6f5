"""Statistics of the anatomical colon generator over a population of seeds (docs/anatomy.md).

    python docs/examples/anatomy_stats.py            # seeds 1-100
    python docs/examples/anatomy_stats.py 1 1000     # seeds 1-1000
"""
import statistics
import sys
import time

import numpy as np

from bhr.anatomy import SECTIONS, anatomical_colon
from bhr.trajectory import load_trajectory

first, last = (int(sys.argv[1]), int(sys.argv[2])) if len(sys.argv) > 2 else (1, 100)
seeds = range(first, last + 1)
colons = [anatomical_colon(s) for s in seeds]
lumens = [c.sample(2.0)[1] for c in colons]


def row(name, values, unit="", fmt="{:.0f}"):
    v = sorted(values)
    print(f"{name:<34} {fmt.format(v[0]):>8} {fmt.format(np.percentile(v, 5)):>8} "
          f"{fmt.format(statistics.median(v)):>8} {fmt.format(np.percentile(v, 95)):>8} {fmt.format(v[-1]):>8}  {unit}")


print(f"{len(colons)} colons, seeds {first}-{last}")
print(f"{'':<34} {'min':>8} {'5 %':>8} {'median':>8} {'95 %':>8} {'max':>8}")
row("length, anus to cecum", [c.length for c in colons], "mm")
for s in SECTIONS:
    row(f"  {s}", [c.section_lengths[s] for c in colons], "mm")
row("smallest bend radius", [c.min_radius for c in colons], "mm", "{:.1f}")
row("splenic flexure angle", [c.bends["splenic flexure"][0] for c in colons], "deg")
row("hepatic flexure angle", [c.bends["hepatic flexure"][0] for c in colons], "deg")
row("acute flexures (turn > 90 deg)", [c.acute_flexures for c in colons], "", "{:.1f}")
row("narrowest lumen diameter", [lum.min() for lum in lumens], "mm", "{:.1f}")
row("widest lumen diameter", [lum.max() for lum in lumens], "mm", "{:.1f}")
print(f"mean acute flexures per colon: {np.mean([c.acute_flexures for c in colons]):.1f}")

# time to make one colon as the follow loop gets it (draw, build, sample at 2 mm), against the thesis's colon
load_trajectory("anatomy", seed=1)
load_trajectory("colon")
ta, tc = [], []
for s in seeds:
    t0 = time.perf_counter()
    load_trajectory("anatomy", seed=s)
    t1 = time.perf_counter()
    load_trajectory("colon")
    t2 = time.perf_counter()
    ta.append(t1 - t0)
    tc.append(t2 - t1)
print(f"time per colon: median {1000 * statistics.median(ta):.2f} ms for bhr.trajectory('anatomy', seed=N), "
      f"{1000 * statistics.median(tc):.2f} ms for the thesis's colon (ratio "
      f"{statistics.median(ta) / statistics.median(tc):.1f})")
