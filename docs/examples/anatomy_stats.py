"""Statistics of the anatomical colon generator over a population of seeds (docs/anatomy.md).

    python docs/examples/anatomy_stats.py            # seeds 1-100
    python docs/examples/anatomy_stats.py 1 1000     # seeds 1-1000
"""
import statistics
import sys
import time

import numpy as np

from bhr.model.anatomy import SECTIONS, anatomical_colon
from bhr.model.generators import load_trajectory

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

# time to make one colon as the follow loop gets it (draw, build, sample at 2 mm), against the thesis's colon;
# CPU time of this process (time.process_time), which a busy machine does not inflate, and wall time
load_trajectory("anatomy", seed=1)
load_trajectory("colon")
cpu = {"anatomy": [], "colon": []}
wall = {"anatomy": [], "colon": []}
for s in seeds:
    for name, args in (("anatomy", {"seed": s}), ("colon", {})):
        w0, c0 = time.perf_counter(), time.process_time()
        load_trajectory(name, **args)
        cpu[name].append(time.process_time() - c0)
        wall[name].append(time.perf_counter() - w0)
ma, mc = statistics.median(cpu["anatomy"]), statistics.median(cpu["colon"])
print(f"time per colon (median): bhr.trajectory('anatomy', seed=N) {1000 * ma:.2f} ms CPU "
      f"({1000 * statistics.median(wall['anatomy']):.2f} ms wall), the thesis's colon {1000 * mc:.2f} ms CPU "
      f"({1000 * statistics.median(wall['colon']):.2f} ms wall); ratio {ma / mc:.2f}")
