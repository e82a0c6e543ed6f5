"""Statistics of the anatomical colon population (bhr.model._anatomy) beside the published figures (docs/anatomy.md).

    python docs/examples/anatomy_stats.py                 # seeds 1-1000
    python docs/examples/anatomy_stats.py --seeds 1-100 --sex female

Every figure is measured on the centerline as bhr follows it (points 1 mm
apart along the arc): the total length, each section's length, the acute
flexures (bhr.model._anatomy.acute_flexures: the heading 25 mm before a point and
25 mm after it differ by more than 90 deg), the bend radius of every point
(the circle through it and the points 5 mm of arc before and after it), and
the lumen diameter.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from bhr.model._anatomy import POPULATION, SECTIONS, acute_flexures, anatomical_colon, bend_radii
from bhr.model._anatomy_stats import bend_profile, real_colons

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--seeds", default="1-1000", help="first-last seed (default 1-1000)")
ap.add_argument("--sex", default="any", choices=tuple(POPULATION))
args = ap.parse_args()
first, last = (int(v) for v in args.seeds.split("-"))
seeds = range(first, last + 1)

t0 = time.process_time()
colons = [anatomical_colon(s, args.sex) for s in seeds]
gen_cpu = (time.process_time() - t0) / len(colons)
length = np.array([c.length for c in colons]) / 10.0  # cm
sections = {s: np.array([c.section_lengths[s] for c in colons]) / 10.0 for s in SECTIONS}
flex, med_r, tight57, tight20, lum_min, lum_max, min_r = [], [], [], [], [], [], []
lum_sec = {s: [] for s in SECTIONS}
all_r = []
for c in colons:
    pts, lumen, section = c.sample(1.0)
    flex.append(acute_flexures(pts, 1.0))
    r = bend_radii(pts, 1.0, 5.0)
    all_r.append(r)
    med_r.append(np.median(r))
    tight57.append(np.mean(r < 57.0))
    tight20.append(np.mean(r < 20.0))
    lum_min.append(lumen.min())
    lum_max.append(lumen.max())
    min_r.append(c.min_radius)
    for k, s in enumerate(SECTIONS):
        if np.any(section == k):
            lum_sec[s].append(float(np.mean(lumen[section == k])))
flex = np.array(flex)
pooled = np.concatenate(all_r)
mean_ref, sd_ref = POPULATION[args.sex]


# the shipped real colons (trajectories/gca) measured the same way: 5 mm chords, no smoothing
real_r = [bend_profile(r.points, 0.0, 5.0) for r in real_colons()]


def real(f) -> str:
    v = [f(r) for r in real_r]
    return f"{min(v):.1f}-{max(v):.1f}"


def ms(v: np.ndarray) -> str:
    return f"{np.mean(v):.1f} ± {np.std(v, ddof=1):.1f}"


print(f"{len(colons)} colons, seeds {first}-{last}, sex {args.sex}; {1000 * gen_cpu:.1f} ms CPU per colon")
print()
print("| quantity | generated (mean ± SD) | source |")
print("| --- | --- | --- |")
print(f"| total length, anus to cecum | {ms(length)} cm (range {length.min():.1f}-{length.max():.1f}) | "
      f"{mean_ref / 10:.1f} ± {sd_ref / 10:.1f} cm, Khashab 2009 [2] |")
for s in SECTIONS:
    print(f"| {s} length | {ms(sections[s])} cm | |")
print(f"| acute flexures (turn > 90 deg within ±25 mm) | {ms(flex)} (range {flex.min()}-{flex.max()}) | "
      "10.9 ± 2.4, Khashab 2009 [2] |")
print(f"| median bend radius (5 mm chords), all points pooled | {np.median(pooled):.1f} mm "
      f"(per colon {np.percentile(med_r, 5):.1f}-{np.percentile(med_r, 95):.1f}, 5-95 %) | "
      f"{real(np.median)} mm, the five real colons [8] |")
print(f"| share of length with bend radius < 57 mm | {100 * np.mean(tight57):.1f} % "
      f"(per colon {100 * np.percentile(tight57, 5):.1f}-{100 * np.percentile(tight57, 95):.1f} %) | "
      f"{real(lambda r: 100 * np.mean(r < 57.0))} %, the five real colons [8] |")
print(f"| share of length with bend radius < 20 mm | {100 * np.mean(tight20):.1f} % "
      f"(per colon {100 * np.percentile(tight20, 5):.1f}-{100 * np.percentile(tight20, 95):.1f} %) | "
      f"{real(lambda r: 100 * np.mean(r < 20.0))} %, the five real colons [8] |")
print(f"| smallest radius of curvature | {ms(np.array(min_r))} mm | |")
for s in SECTIONS:
    print(f"| lumen, {s} (mean diameter) | {ms(np.array(lum_sec[s]))} mm | |")
print(f"| lumen, narrowest / widest | {ms(np.array(lum_min))} / {ms(np.array(lum_max))} mm | |")
