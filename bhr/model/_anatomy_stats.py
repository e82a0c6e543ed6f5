"""Shape statistics of colon centerlines: the generated population (bhr.model._anatomy) beside the real colons.

    python -m bhr.model._anatomy_stats                         # seeds 1-1000 beside every shipped real colon
    python -m bhr.model._anatomy_stats --seeds 1-100 --smoothing 3 --chord 5

Every path is measured the same way (docs/anatomy.md, "Calibration on real colons"): resampled to points
1 mm apart along its arc length, smoothed by a Gaussian of ``smoothing`` mm (standard deviation, along the
arc), and the bend radius of each point is the radius of the circle through it and the points ``chord`` mm
of arc before and after it (:func:`bhr.model._anatomy.bend_radii`). Segment shares come from landmarks: the
real colons' (descending-sigmoid junction, splenic and hepatic flexures, ileocaecal valve, as their files'
``section`` column gives them) and, for a generated colon, the ends of its sigmoid, the middles of its
flexures and the start of its cecum. The real colons are read from the shipped files
``trajectories/gca/*.csv``.

This module imports nothing of bhr above the model layer, and no plotting library.
"""
from __future__ import annotations

import argparse
import csv
import io
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from bhr.model._anatomy import SECTIONS, Colon, anatomical_colon, bend_radii
from bhr.model._trajnames import trajectory_folder
from bhr._settings.errors import BhrError

__all__ = ["SMOOTHING_MM", "CHORD_MM", "TIGHT_MM", "GROUPS", "Shape", "bend_profile", "shape", "generated_shape",
           "real_colons", "RealColon", "main"]

#: The smoothing (Gaussian standard deviation along the arc, mm) and chord (mm) the calibration is stated at.
SMOOTHING_MM = 3.0
CHORD_MM = 5.0
#: "Tighter than the thesis robot can turn": its minimum turn radius, 57 mm (10 mm modules, 10 deg; Ec. 7.1).
TIGHT_MM = 57.0
#: Spacing (mm) the paths are resampled to before smoothing.
SPACING_MM = 1.0
#: The segments the shares are given for: what the real colons' landmarks bound (the real colons have no
#: rectosigmoid junction but one, so rectum and sigmoid are one segment).
GROUPS = ("rectum and sigmoid", "descending", "transverse", "ascending", "cecum")
#: How far from the anus (mm) the lumen of the anal canal and low rectum is read.
CANAL_MM = 40.0


@dataclass(frozen=True)
class Shape:
    """The shape statistics of one centerline."""

    name: str
    length: float  # mm
    radii: np.ndarray  # bend radius (mm) of every point that has a chord either side
    tightest_at: float  # mm of arc from the anus
    shares: dict[str, float]  # GROUPS -> share of the length
    lumen: np.ndarray | None  # inner diameter (mm) every SPACING_MM, or None

    @property
    def median_radius(self) -> float:
        return float(np.median(self.radii))

    @property
    def tight_share(self) -> float:
        """Share of the length bending tighter than TIGHT_MM."""
        return float(np.mean(self.radii < TIGHT_MM))

    @property
    def tightest(self) -> float:
        return float(self.radii.min())

    def canal_lumen(self) -> tuple[float, float]:
        """Narrowest and widest inner diameter (mm) over the first CANAL_MM from the anus."""
        if self.lumen is None:
            return (math.nan, math.nan)
        first = self.lumen[: int(CANAL_MM / SPACING_MM) + 1]
        return float(first.min()), float(first.max())


def _resample(points: np.ndarray, spacing: float) -> np.ndarray:
    """Points every ``spacing`` mm of arc length along the polyline ``points`` (linear between its points)."""
    pts = np.asarray(points, dtype=np.float64)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    t = np.arange(0.0, s[-1] + 1e-9, spacing)
    return np.column_stack([np.interp(t, s, pts[:, k]) for k in range(3)])


def bend_profile(points: np.ndarray, smoothing: float = SMOOTHING_MM, chord: float = CHORD_MM,
                 spacing: float = SPACING_MM) -> np.ndarray:
    """Bend radius (mm) along a path: resampled every ``spacing`` mm, smoothed by a Gaussian of ``smoothing`` mm
    (0: not smoothed), the circle through each point and the points ``chord`` mm of arc either side.

    Entry k is the point (k + chord / spacing) * spacing mm from the path's start.
    """
    from scipy.ndimage import gaussian_filter1d

    if smoothing < 0 or chord <= 0:
        raise BhrError(f"smoothing must be >= 0 and chord > 0 (mm), got {smoothing:g} and {chord:g}")
    pts = _resample(points, spacing)
    if smoothing > 0:
        pts = gaussian_filter1d(pts, smoothing / spacing, axis=0, mode="nearest")
    if len(pts) < 2 * max(int(round(chord / spacing)), 1) + 1:
        raise BhrError(f"a path of {len(pts)} points is too short for {chord:g} mm chords")
    return bend_radii(pts, spacing, chord)


def shape(name: str, points: np.ndarray, shares: dict[str, float], lumen: np.ndarray | None = None,
          smoothing: float = SMOOTHING_MM, chord: float = CHORD_MM) -> Shape:
    """The statistics of one centerline (``points`` in mm, anus first; ``lumen`` per SPACING_MM, or None)."""
    r = bend_profile(points, smoothing, chord)
    k = max(int(round(chord / SPACING_MM)), 1)
    length = float(np.linalg.norm(np.diff(np.asarray(points, dtype=np.float64), axis=0), axis=1).sum())
    return Shape(name, length, r, float((int(np.argmin(r)) + k) * SPACING_MM), shares, lumen)


def _generated_shares(c: Colon) -> dict[str, float]:
    sl = c.section_lengths
    ends = dict(zip(SECTIONS, c.section_ends()))
    dsj = ends["sigmoid"]
    sf = ends["splenic flexure"] - 0.5 * sl["splenic flexure"]
    hf = ends["hepatic flexure"] - 0.5 * sl["hepatic flexure"]
    icv = ends["ascending"]
    bounds = [0.0, dsj, sf, hf, icv, c.length]
    return {g: (b - a) / c.length for g, a, b in zip(GROUPS, bounds, bounds[1:])}


def generated_shape(seed: int, smoothing: float = SMOOTHING_MM, chord: float = CHORD_MM) -> Shape:
    """The statistics of the generated colon of ``seed`` (sampled every SPACING_MM, as bhr follows it)."""
    c = anatomical_colon(seed)
    pts, lumen, _ = c.sample(SPACING_MM)
    return shape(f"seed {seed}", pts, _generated_shares(c), lumen, smoothing, chord)


@dataclass(frozen=True)
class RealColon:
    """A shipped real colon: its name (as ``--traj gca:NAME`` takes it), points, lumen and section of each point."""

    name: str
    points: np.ndarray
    lumen: np.ndarray
    sections: list[str]

    def shares(self) -> dict[str, float]:
        """Each of GROUPS' share of the points (a colon whose rectum and sigmoid are apart counts them together)."""
        n = len(self.sections)
        group = ["rectum and sigmoid" if s in ("rectum", "sigmoid") else s for s in self.sections]
        unknown = sorted(set(group) - set(GROUPS))
        if unknown:
            raise BhrError(f"real colon {self.name}: unknown section {unknown[0]!r}; expected one of "
                           f"{', '.join(GROUPS)}")
        return {g: group.count(g) / n for g in GROUPS}

    def shape(self, smoothing: float = SMOOTHING_MM, chord: float = CHORD_MM) -> Shape:
        return shape(self.name, self.points, self.shares(), self.lumen, smoothing, chord)


def _real_dir() -> Path:
    folder = trajectory_folder()
    return (folder if folder is not None else Path("trajectories")) / "gca"


def real_colons(folder: Path | None = None) -> list[RealColon]:
    """The shipped real colons (trajectories/gca/*.csv: x, y, z, lumen, section; points 1 mm apart), by name."""
    folder = folder or _real_dir()
    files = sorted(folder.glob("*.csv")) if folder.is_dir() else []
    if not files:
        raise BhrError(f"no real colons in {folder}: give a folder of CSV files with columns x, y, z, lumen, section "
                       "(bhr ships its own as trajectories/gca/*.csv)")
    out = []
    for f in files:
        text = f.read_text(encoding="utf-8")
        rows = list(csv.DictReader(io.StringIO("".join(ln + "\n" for ln in text.splitlines()
                                                         if ln.strip() and not ln.startswith("#")))))
        try:
            pts = np.array([[float(r["x"]), float(r["y"]), float(r["z"])] for r in rows], dtype=np.float64)
            lumen = np.array([float(r["lumen"]) for r in rows], dtype=np.float64)
            sections = [str(r["section"]).strip() for r in rows]
        except (KeyError, TypeError, ValueError) as e:
            raise BhrError(f"real colon {f}: every row needs numbers x, y, z, lumen and a section name "
                           f"({type(e).__name__}: {e})") from None
        if len(pts) < 3 or not np.all(np.isfinite(pts)):
            raise BhrError(f"real colon {f}: needs at least 3 points with finite coordinates")
        out.append(RealColon(f.stem, pts, lumen, sections))
    return out


# ---------------------------------------------------------------------------------------------- the tables

def _seeds(text: str) -> range:
    try:
        first, last = (int(v) for v in text.split("-"))
    except ValueError:
        raise BhrError(f"--seeds must be FIRST-LAST (whole numbers), got {text!r}") from None
    if not 0 <= first <= last:
        raise BhrError(f"--seeds must be FIRST-LAST with 0 <= FIRST <= LAST, got {text!r}")
    return range(first, last + 1)


def _pct(v: float | np.floating) -> str:
    return f"{100 * v:.1f} %"


def calibration_table(population: Sequence[Shape], real: Sequence[Shape], seeds: range) -> list[str]:
    """The main table (markdown lines): each statistic for the population and for each real colon."""
    pooled = np.concatenate([p.radii for p in population])
    med = np.array([p.median_radius for p in population])
    tight = np.array([p.tight_share for p in population])
    tightest = np.array([p.tightest for p in population])
    worst = population[int(np.argmin(tightest))]
    length = np.array([p.length for p in population])
    head = f"| statistic | generated, seeds {seeds.start}-{seeds.stop - 1} | " + " | ".join(r.name for r in real) + \
        " | real range |"
    lines = [head, "| --- " * (3 + len(real)) + "|"]

    def row(label: str, gen: str, vals: Iterable[float], fmt) -> None:
        vals = list(vals)
        lines.append(f"| {label} | {gen} | " + " | ".join(fmt(v) for v in vals) +
                     f" | {fmt(min(vals))}-{fmt(max(vals))} |")

    row("median bend radius (mm)", f"{np.median(pooled):.1f} (per colon {np.percentile(med, 5):.1f}-"
        f"{np.percentile(med, 95):.1f})", [r.median_radius for r in real], lambda v: f"{v:.1f}")
    row(f"share of length tighter than {TIGHT_MM:g} mm", f"{_pct(np.mean(pooled < TIGHT_MM))} (per colon "
        f"{_pct(np.percentile(tight, 5))}-{_pct(np.percentile(tight, 95))})", [r.tight_share for r in real], _pct)
    row("tightest bend radius (mm)", f"{tightest.min():.2f} ({worst.name}; per colon median {np.median(tightest):.1f})",
        [r.tightest for r in real], lambda v: f"{v:.2f}")
    for g in GROUPS:
        sh = np.array([p.shares[g] for p in population])
        row(f"share: {g}", f"{_pct(sh.mean())} ({_pct(np.percentile(sh, 5))}-{_pct(np.percentile(sh, 95))})",
            [r.shares[g] for r in real], _pct)
    row("length, anus to cecum (mm)", f"{length.mean():.0f} ± {length.std(ddof=1):.0f}", [r.length for r in real],
        lambda v: f"{v:.0f}")
    lum_med = np.array([np.median(p.lumen) for p in population if p.lumen is not None])
    row("lumen, median diameter (mm)", f"{lum_med.mean():.1f} ({np.percentile(lum_med, 5):.1f}-"
        f"{np.percentile(lum_med, 95):.1f})", [float(np.median(r.lumen)) for r in real if r.lumen is not None],
        lambda v: f"{v:.1f}")
    canal = np.array([p.canal_lumen() for p in population])
    lines.append(f"| lumen, first {CANAL_MM:g} mm (mm) | {canal[:, 0].min():.1f}-{canal[:, 1].max():.1f} | " +
                 " | ".join(f"{a:.1f}-{b:.1f}" for a, b in (r.canal_lumen() for r in real)) + " | |")
    return lines


def dependence_table(population_points: Sequence[np.ndarray], real: Sequence[RealColon],
                     smoothings: Sequence[float], chords: Sequence[float]) -> list[str]:
    """How the median bend radius, the share tighter than TIGHT_MM and the tightest bend depend on the smoothing
    and the chord (markdown lines): the pooled population beside the real colons' range."""
    lines = ["| smoothing (mm) | chord (mm) | generated: median radius, tighter than 57 mm, tightest | "
             "real: median radius, tighter than 57 mm, tightest |", "| --- | --- | --- | --- |"]
    for sm in smoothings:
        for ch in chords:
            gen = [bend_profile(p, sm, ch) for p in population_points]
            pooled = np.concatenate(gen)
            re = [bend_profile(r.points, sm, ch) for r in real]
            med = [float(np.median(r)) for r in re]
            tight = [float(np.mean(r < TIGHT_MM)) for r in re]
            low = [float(r.min()) for r in re]
            lines.append(f"| {sm:g} | {ch:g} | {np.median(pooled):.1f} mm, {_pct(np.mean(pooled < TIGHT_MM))}, "
                         f"{min(float(g.min()) for g in gen):.2f} mm | {min(med):.1f}-{max(med):.1f} mm, "
                         f"{_pct(min(tight))}-{_pct(max(tight))}, {min(low):.2f} mm |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bhr.model._anatomy_stats", description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1-1000", help="the generated colons: FIRST-LAST seed (default 1-1000)")
    ap.add_argument("--smoothing", type=float, default=SMOOTHING_MM, help="Gaussian smoothing, mm (default 3)")
    ap.add_argument("--chord", type=float, default=CHORD_MM, help="chord either side of a point, mm (default 5)")
    ap.add_argument("--dependence-seeds", default="1-100",
                    help="the generated colons of the second table (smoothing and chord varied; default 1-100)")
    ap.add_argument("--real", type=Path, default=None, metavar="FOLDER",
                    help="real colons from this folder's CSV files (x, y, z, lumen, section; 1 mm apart) instead "
                         "of the shipped ones")
    args = ap.parse_args(argv)
    try:
        seeds, dep_seeds = _seeds(args.seeds), _seeds(args.dependence_seeds)
        real = real_colons(args.real)
        t0 = time.process_time()
        pop = [generated_shape(s, args.smoothing, args.chord) for s in seeds]
        cpu = time.process_time() - t0
        real_shapes = [r.shape(args.smoothing, args.chord) for r in real]
        print(f"Smoothing {args.smoothing:g} mm, chords {args.chord:g} mm; {len(pop)} generated colons "
              f"(seeds {seeds.start}-{seeds.stop - 1}, {1000 * cpu / len(pop):.1f} ms of CPU each), "
              f"{len(real)} real colons (trajectories/gca).")
        print()
        print("\n".join(calibration_table(pop, real_shapes, seeds)))
        print()
        print(f"Dependence on smoothing and chord (generated: seeds {dep_seeds.start}-{dep_seeds.stop - 1}, "
              "all points pooled; real: the range over the real colons):")
        print()
        pts = [anatomical_colon(s).sample(SPACING_MM)[0] for s in dep_seeds]
        print("\n".join(dependence_table(pts, real, (0.0, 1.0, 3.0, 5.0), (3.0, 5.0, 10.0))))
    except BhrError as e:
        print(f"Error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover - run as python -m bhr.model._anatomy_stats
    sys.exit(main())
