"""Anatomical colons: random but realistic 3-D human large intestines, anus to cecum.

``anatomical_colon(seed)`` draws one colon from the ranges in :data:`RANGES`
(segment lengths, lumen diameters, flexure angles and bend radii, each
taken from the anatomy and CT-colonography literature cited in
docs/anatomy.md) and builds its centerline as straights joined tangent to
tangent by circular arcs, so the path has no kinks and its smallest radius
of curvature is exactly the smallest arc radius drawn. The robot enters at
the anus (the origin) and the path ends at the cecum. Sections, in order:

    rectum, sigmoid (with its loop), descending colon, splenic flexure,
    transverse colon (sagging), hepatic flexure, ascending colon, cecum

Frame: x toward the patient's left, y anterior, z cranial (head-wards).

Every draw comes from ``numpy.random.default_rng(seed)`` (PCG64), so a seed
gives the same colon on every machine. A colon is drawn and sampled in a few
milliseconds. The lumen diameter is drawn per section and interpolated
linearly along the arc length between section midpoints.

``bhr.trajectory("anatomy", seed=N)`` and ``bhr follow --traj anatomy --seed N``
give the same colon as a :class:`~bhr.model.generators.Trajectory` (points spaced
by the feed, lumen diameter per point; :func:`bhr.model.generators.anatomy_trajectory`).
This module imports nothing of bhr but its errors.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bhr.settings.errors import BhrError
from bhr.model.pathfile import _rotate, _unit

__all__ = ["SECTIONS", "RANGES", "SEED_MAX", "SHIPPED", "Colon", "anatomical_colon", "check_seed",
           "anatomy_csv_text"]

#: Sections of an anatomical colon, from the anus to the cecum.
SECTIONS = ("rectum", "sigmoid", "descending", "splenic flexure", "transverse", "hepatic flexure", "ascending",
            "cecum")

#: Largest seed accepted (seeds are whole numbers 0 ... SEED_MAX).
SEED_MAX = 2**32 - 1

#: Ranges every colon is drawn from (uniformly), low and high. Lengths and radii in mm, angles in degrees.
#: docs/anatomy.md gives the source of each figure.
RANGES: dict[str, tuple[float, float]] = {
    # centerline length of each section (for the flexures: arc length = radius x angle, not drawn directly)
    "length.rectum": (120.0, 160.0),
    "length.sigmoid": (230.0, 420.0),
    "length.descending": (150.0, 250.0),
    "length.transverse": (400.0, 520.0),
    "length.ascending": (150.0, 250.0),
    "length.cecum": (60.0, 80.0),
    # inner (lumen) diameter of each section
    "lumen.rectum": (30.0, 45.0),
    "lumen.sigmoid": (24.0, 32.0),
    "lumen.descending": (25.0, 35.0),
    "lumen.splenic flexure": (30.0, 40.0),
    "lumen.transverse": (35.0, 50.0),
    "lumen.hepatic flexure": (38.0, 50.0),
    "lumen.ascending": (40.0, 55.0),
    "lumen.cecum": (50.0, 60.0),
    # bends: angle turned (deg) and radius of curvature of the centerline (mm)
    "angle.sacral": (30.0, 60.0),  # the rectum following the sacrum
    "radius.sacral": (80.0, 150.0),
    "angle.rectosigmoid": (60.0, 100.0),
    "radius.rectosigmoid": (15.0, 30.0),
    "angle.sigmoid apex": (120.0, 170.0),  # the top of the sigmoid loop
    "radius.sigmoid apex": (12.0, 30.0),
    "radius.sigmoid-descending": (15.0, 40.0),
    "angle.splenic flexure": (100.0, 150.0),
    "radius.splenic flexure": (10.0, 20.0),
    "rise.transverse": (10.0, 40.0),  # after sagging, the transverse colon climbs at this angle (deg)
    "radius.transverse sag": (50.0, 120.0),
    "radius.hepatic flexure": (10.0, 25.0),
    "roll": (-20.0, 20.0),  # each bend's plane is turned about the heading by this much (3-D shape)
    "tilt": (0.0, 15.0),  # a colon's descending and ascending limbs lean this far off the vertical
    # redundant folds: pairs of acute bends (the second turns back by the same angle) in the sigmoid and
    # transverse colon, so that a colon has about as many acute flexures as CT colonography counts
    "angle.fold": (90.0, 140.0),
    "radius.fold": (10.0, 25.0),
}
#: Fold pairs per section (sigmoid, transverse): a whole number drawn from this range, ends included.
FOLD_PAIRS = (1, 3)
#: Straight between the two bends of a fold (mm).
FOLD_GAP = (15.0, 40.0)

#: Where each bend aims (it turns the heading toward this direction by its drawn angle), in the body frame.
_AIM = {
    "sacral": (0.0, -0.45, 0.9),  # rectum bends back along the sacrum
    "rectosigmoid": (-0.25, 0.85, 0.45),  # sigmoid heads forward, a little right and up
    "sigmoid apex": (0.75, -0.45, -0.5),  # loop over to the left, back and down
    "sigmoid-descending": (0.1, -0.15, 1.0),  # up the left side
    "splenic flexure": (-0.6, 0.35, -0.7),  # sharply round to the right, forward and down
    "transverse sag": (-0.6, -0.2, 0.75),  # climb again toward the liver
    "hepatic flexure": (0.05, -0.1, -1.0),  # down the right side
}
_START_HEADING = (0.0, 0.25, 1.0)  # the anal canal and lower rectum point up and a little forward


def check_seed(seed: Any, where: str = "anatomy") -> int:
    """A seed as a Python int, or a one-line BhrError."""
    if isinstance(seed, bool) or not isinstance(seed, (int, float, np.integer, np.floating)):
        raise BhrError(f"{where}: seed must be a whole number from 0 to {SEED_MAX}, got {seed!r}")
    v = float(seed)
    if not math.isfinite(v) or v != math.floor(v) or v < 0 or v > SEED_MAX:
        raise BhrError(f"{where}: seed must be a whole number from 0 to {SEED_MAX}, got {seed!r}")
    return int(v)


@dataclass
class Colon:
    """One drawn colon: its pieces (straights and arcs) and what was drawn."""

    seed: int
    #: (kind, length mm, radius mm or inf, start point, start heading, bend direction or None, section)
    pieces: list[tuple[str, float, float, np.ndarray, np.ndarray, np.ndarray | None, str]]
    section_lengths: dict[str, float]
    lumen_knots: tuple[np.ndarray, np.ndarray]  # (arc length mm, diameter mm)
    bends: dict[str, tuple[float, float]]  # name -> (angle deg, radius mm)
    draws: dict[str, float] = field(default_factory=dict)

    @property
    def length(self) -> float:
        return float(sum(p[1] for p in self.pieces))

    @property
    def min_radius(self) -> float:
        return min(r for _, r in self.bends.values())

    @property
    def acute_flexures(self) -> int:
        """Bends that turn the heading by more than 90 deg (limbs meeting at an acute angle)."""
        return sum(1 for kind, length, r, *_ in self.pieces if kind == "arc" and length / r > math.pi / 2 + 1e-12)

    @property
    def start_heading(self) -> np.ndarray:
        return self.pieces[0][4]

    def section_ends(self) -> np.ndarray:
        """Arc length (mm) at which each of :data:`SECTIONS` ends."""
        return np.cumsum([self.section_lengths[s] for s in SECTIONS])

    def sample(self, feed: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points every ``feed`` mm of arc length, the lumen diameter at each, and each one's section index."""
        total = self.length
        count = int(math.floor(total / feed + 1e-9)) + 1
        s = np.arange(count, dtype=np.float64) * feed
        lengths = np.array([p[1] for p in self.pieces])
        ends = np.cumsum(lengths)
        idx = np.minimum(np.searchsorted(ends, s, side="right"), len(self.pieces) - 1)
        local = s - (ends - lengths)[idx]
        pts = np.empty((count, 3))
        for k, (kind, length, r, p0, t0, d, _) in enumerate(self.pieces):
            sel = idx == k
            if not np.any(sel):
                continue
            u = np.minimum(local[sel], length)
            if kind == "straight":
                pts[sel] = p0 + u[:, None] * t0
            else:
                pts[sel] = p0 + (r * np.sin(u / r))[:, None] * t0 + (r * (1.0 - np.cos(u / r)))[:, None] * d
        lumen = np.interp(s, *self.lumen_knots)
        section = np.minimum(np.searchsorted(self.section_ends(), s, side="right"), len(SECTIONS) - 1)
        return pts, lumen, section


def anatomical_colon(seed: int) -> Colon:
    """Draw the colon of ``seed`` (a whole number 0 ... :data:`SEED_MAX`)."""
    seed = check_seed(seed)
    rng = np.random.default_rng(seed)
    draws: dict[str, float] = {}

    def draw(key: str) -> float:
        lo, hi = RANGES[key]
        v = float(rng.uniform(lo, hi))
        draws[key] = v
        return v

    # Everything is drawn up front, in a fixed order, so one seed always gives the same numbers.
    seg_len = {s: draw(f"length.{s}") for s in ("rectum", "sigmoid", "descending", "transverse", "ascending", "cecum")}
    lumen = {s: draw(f"lumen.{s}") for s in SECTIONS}
    bend_names = ("sacral", "rectosigmoid", "sigmoid apex", "sigmoid-descending", "splenic flexure",
                  "transverse sag", "hepatic flexure")
    # Bends that set the course turn exactly onto their (tilted) aim: their angle is what that takes; the
    # angle booked here is an upper bound, and what it does not use goes to the straight after the bend.
    booked = {"sigmoid-descending": 180.0, "transverse sag": 120.0, "hepatic flexure": 180.0}
    bends: dict[str, tuple[float, float]] = {
        b: (booked[b] if b in booked else draw(f"angle.{b}"), draw(f"radius.{b}")) for b in bend_names}
    rolls = {b: math.radians(draw("roll")) for b in bend_names}
    aims = {}
    for b in ("sigmoid-descending", "hepatic flexure"):
        a = _unit(np.array(_AIM[b]))
        axis = _rotate(_unit(np.cross(a, np.array([1.0, 0.0, 0.0]))), a, float(rng.uniform(0, 2 * math.pi)))
        aims[b] = _rotate(a, axis, math.radians(draw("tilt")))
    rise = math.radians(draw("rise.transverse"))
    # Redundant folds (pairs of acute bends, the second undoing the first) in the sigmoid and transverse colon.
    folds: dict[str, list[str]] = {}
    for sec in ("sigmoid", "transverse"):
        count = int(rng.integers(FOLD_PAIRS[0], FOLD_PAIRS[1] + 1))
        draws[f"folds.{sec}"] = float(count)
        folds[sec] = []
        for k in range(count):
            name = f"{sec} fold {k + 1}"
            bends[name] = (draw("angle.fold"), draw("radius.fold"))
            rolls[name] = float(rng.uniform(0.0, 2.0 * math.pi))  # a fold may turn any way
            draws[f"gap.{name}"] = float(rng.uniform(*FOLD_GAP))
            folds[sec].append(name)
    # Where the anatomical bends and the folds sit inside each section: its straight length is shared out
    # between the gaps by weights drawn here.
    layout = {"rectum": ["sacral"],
              "sigmoid": ["rectosigmoid", "sigmoid apex", "sigmoid-descending"],
              "transverse": ["transverse sag"]}
    for sec, items in layout.items():
        for name in folds.get(sec, []):
            # sigmoid folds sit before its last bend, transverse folds before or after its sag
            items.insert(int(rng.integers(1, len(items))) if sec == "sigmoid" else int(rng.integers(0, 2)), name)
    gaps = {sec: rng.uniform(0.5, 1.5, size=len(items) + 1) for sec, items in layout.items()}

    def arc_len(name: str) -> float:
        return math.radians(bends[name][0]) * bends[name][1]

    def fixed_len(sec: str) -> float:
        """Length of a section taken by its bends and the straights inside its folds."""
        total = 0.0
        for b in layout[sec]:
            total += 2 * arc_len(b) + draws[f"gap.{b}"] if "fold" in b else arc_len(b)
        return total

    # Bends and folds may take at most 85 % of a section's length: when a short section was drawn with
    # many folds, tighten its bends (never below the smallest radius of their range), then drop folds.
    for sec in layout:
        budget = 0.85 * seg_len[sec]
        used = fixed_len(sec)
        if used > budget:
            scale = budget / used
            for b in layout[sec]:
                key = "radius.fold" if "fold" in b else f"radius.{b}"
                bends[b] = (bends[b][0], max(RANGES[key][0], bends[b][1] * scale))
        while fixed_len(sec) > budget and any("fold" in b for b in layout[sec]):
            last = [b for b in layout[sec] if "fold" in b][-1]
            layout[sec].remove(last)
            del bends[last]
            draws[f"folds.{sec}"] -= 1
        if fixed_len(sec) > seg_len[sec]:  # pragma: no cover - the ranges make this impossible
            raise BhrError(f"anatomy seed {seed}: the {sec}'s bends are longer than the section")

    pieces: list[tuple[str, float, float, np.ndarray, np.ndarray, np.ndarray | None, str]] = []
    state: dict[str, Any] = {"p": np.zeros(3), "t": _unit(np.array(_START_HEADING)), "d": None, "slack": 0.0}

    def straight(length: float, section: str) -> None:
        length += state["slack"]
        state["slack"] = 0.0
        if length <= 0:
            return
        p, t = state["p"], state["t"]
        pieces.append(("straight", length, math.inf, p.copy(), t.copy(), None, section))
        state["p"] = p + length * t

    def bend(name: str, section: str, d: np.ndarray | None = None) -> None:
        ang_deg, r = bends[name]
        theta = math.radians(ang_deg)
        p, t = state["p"], state["t"]
        if name in booked:
            if name == "transverse sag":  # level out and climb at the drawn angle, same horizontal course
                h = np.array([t[0], t[1], 0.0])
                aim = _unit(_unit(h) * math.cos(rise) + np.array([0.0, 0.0, math.sin(rise)]))
            else:
                aim = aims[name]
            actual = math.acos(max(-1.0, min(1.0, float(np.dot(aim, t)))))
            d = aim - float(np.dot(aim, t)) * t
            if name != "hepatic flexure":  # a section of its own: nothing to hand on
                state["slack"] += r * (theta - actual)
            theta = actual
            bends[name] = (math.degrees(actual), r)
        elif d is None:
            if "fold" in name:
                n = np.cross(t, np.array([0.0, 0.0, 1.0]))
                if np.linalg.norm(n) < 1e-6:
                    n = np.cross(t, np.array([1.0, 0.0, 0.0]))
            else:
                aim = _unit(np.array(_AIM[name]))
                n = aim - float(np.dot(aim, t)) * t
                if np.linalg.norm(n) < 1e-6:  # pragma: no cover - aims are never along the heading
                    n = np.cross(t, np.array([1.0, 0.0, 0.0]))
            d = _rotate(_unit(n), t, rolls[name])  # the bend's plane, turned about the heading
        d = _unit(d - float(np.dot(d, t)) * t)
        length = r * theta
        pieces.append(("arc", length, r, p.copy(), t.copy(), d.copy(), section))
        state["p"] = p + r * math.sin(theta) * t + r * (1.0 - math.cos(theta)) * d
        new_t = _unit(math.cos(theta) * t + math.sin(theta) * d)
        state["d"] = _unit(math.cos(theta) * d - math.sin(theta) * t)  # where the bend was pulling, at its end
        state["t"] = new_t

    def section(sec: str) -> None:
        items = layout[sec]
        free = seg_len[sec] - fixed_len(sec)
        g = gaps[sec][:len(items) + 1]
        w = g / g.sum()
        for k, name in enumerate(items):
            straight(w[k] * free, sec)
            if "fold" in name:
                bend(name, sec)
                straight(draws[f"gap.{name}"], sec)
                bend(name, sec, d=-state["d"])  # the same bend back: the heading is restored
            else:
                bend(name, sec)
        straight(w[-1] * free, sec)

    section("rectum")
    section("sigmoid")
    straight(seg_len["descending"], "descending")
    bend("splenic flexure", "splenic flexure")
    section("transverse")
    bend("hepatic flexure", "hepatic flexure")
    straight(seg_len["ascending"], "ascending")
    straight(seg_len["cecum"], "cecum")

    section_lengths = {s: 0.0 for s in SECTIONS}
    for pc in pieces:
        section_lengths[pc[6]] += pc[1]
    ends = np.cumsum([section_lengths[s] for s in SECTIONS])
    mids = ends - 0.5 * np.array([section_lengths[s] for s in SECTIONS])
    knots_s = np.concatenate([[0.0], mids, [ends[-1]]])
    diam = [lumen[s] for s in SECTIONS]
    knots_d = np.array([diam[0], *diam, diam[-1]])
    return Colon(seed, pieces, section_lengths, (knots_s, knots_d), bends, draws)


#: The colons shipped as editable point files (trajectories/NAME.csv): name -> (seed, what it shows).
SHIPPED: dict[str, tuple[int, str]] = {
    "anatomy-short": (25, "the shortest colon of seeds 1-100"),
    "anatomy-typical": (37, "the median length of seeds 1-100"),
    "anatomy-tortuous": (8, "the most acute flexures of seeds 1-100"),
}


def anatomy_csv_text(seed: int, spacing: float = 1.0, note: str = "") -> str:
    """The colon of ``seed`` as a trajectory CSV (x, y, z, lumen; mm), points ``spacing`` mm apart."""
    colon = anatomical_colon(seed)
    pts, lumen, _ = colon.sample(spacing)
    lines = [f"# Anatomical colon, anus (first point) to cecum, drawn by bhr.model.anatomy from seed {seed} "
             "(docs/anatomy.md)" + (f": {note}" if note else "") + ".",
             f"# Centerline {colon.length:.1f} mm, smallest bend radius {colon.min_radius:.2f} mm, "
             f"{colon.acute_flexures} acute flexures, lumen {lumen.min():.1f}-{lumen.max():.1f} mm.",
             "# x toward the patient's left, y anterior, z cranial (mm); lumen = inner diameter (mm). Edit freely.",
             "x,y,z,lumen"]
    lines += [f"{x:.3f},{y:.3f},{z:.3f},{d:.2f}" for (x, y, z), d in zip(pts, lumen)]
    return "\n".join(lines) + "\n"
