"""Anatomical colons: random but realistic 3-D human large intestines, anus to cecum.

``anatomical_colon(seed)`` draws one colon from the ranges in :data:`RANGES`
(lumen diameters, flexure angles and bend radii, from the anatomy and
CT-colonography literature cited in docs/anatomy.md) and the shares in
:data:`SHARES` (calibrated on the real colons' landmarks), builds its course
as straights joined tangent to tangent by circular arcs, and its centerline
as a cubic spline through the course plus a smooth random wiggle, calibrated
so that the population bends as the real colons do
(:mod:`bhr.model._anatomy_stats`) and damped wherever the centerline would bend
tighter than :data:`MIN_RADIUS_MM`. The robot enters at the anus (the origin)
and the path ends at the cecum. Sections, in order:

    rectum (from its anal canal and anorectal flexure), sigmoid (with its loop),
    descending colon, splenic flexure, transverse colon (sagging), hepatic flexure,
    ascending colon, cecum

Frame: x toward the patient's left, y anterior, z cranial (head-wards).

Every draw comes from ``numpy.random.default_rng(seed)`` (PCG64), so a seed
gives the same colon on every machine. A colon is drawn and sampled in a few
milliseconds. The lumen diameter is drawn per section and interpolated
linearly along the arc length between section midpoints.

``bhr.trajectory("anatomy", seed=N)`` and ``bhr follow --traj anatomy --seed N``
give the same colon as a :class:`~bhr.model._generators.Trajectory` (points spaced
by the feed, lumen diameter per point; :func:`bhr.model._generators.anatomy_trajectory`).
This module imports nothing of bhr but its errors.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bhr._settings.errors import BhrError
from bhr._settings.options import excerpt
from bhr.model._pathfile import rotate_about, unit_vector

__all__ = ["SECTIONS", "RANGES", "SEED_MAX", "SHIPPED", "POPULATION", "SHARES", "LENGTH_LIMITS", "Colon",
           "anatomical_colon", "check_seed", "anatomy_csv_text", "acute_flexures", "bend_radii", "MIN_RADIUS_MM",
           "WIGGLE_MM", "WIGGLE_KNOT_MM", "WIGGLE_RAMP_MM", "CONTROL_MM", "path_sections",
           "path_section_ranges"]

#: Sections of an anatomical colon, from the anus to the cecum.
SECTIONS = ("rectum", "sigmoid", "descending", "splenic flexure", "transverse", "hepatic flexure", "ascending",
            "cecum")

#: Largest seed accepted (seeds are whole numbers 0 ... SEED_MAX).
SEED_MAX = 2**32 - 1

#: Ranges every colon is drawn from (uniformly), low and high. Lengths and radii in mm, angles in degrees.
#: docs/anatomy.md gives the source of each figure.
RANGES: dict[str, tuple[float, float]] = {
    # inner (lumen) diameter of each section
    "lumen.anal canal": (13.0, 16.0),  # the first stretch of the rectum section: anal canal and anorectal flexure
    "lumen.rectum": (30.0, 45.0),
    "lumen.sigmoid": (24.0, 32.0),
    "lumen.descending": (25.0, 35.0),
    "lumen.splenic flexure": (30.0, 40.0),
    "lumen.transverse": (35.0, 50.0),
    "lumen.hepatic flexure": (38.0, 50.0),
    "lumen.ascending": (40.0, 55.0),
    "lumen.cecum": (50.0, 60.0),
    # the anal canal: a narrow straight from the anus, then the anorectal flexure (mm)
    "length.anal canal": (32.0, 38.0),
    # bends: angle turned (deg) and radius of curvature of the centerline (mm)
    "angle.anorectal": (60.0, 90.0),  # from the anal canal back into the rectum
    "radius.anorectal": (8.0, 11.0),
    "angle.sacral": (30.0, 60.0),  # the rectum following the sacrum
    "radius.sacral": (50.0, 120.0),
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
#: Fold pairs per section: a whole number drawn from this range, ends included.
FOLD_PAIRS = {"sigmoid": (1, 3), "transverse": (1, 3)}
#: The CT population the whole length is drawn from: mean and standard deviation (mm), Khashab et al. 2009
#: (505 adults; women 193.3 cm, men 185.4 cm; the study's pooled SD is used for both).
POPULATION = {"any": (1895.0, 263.0), "female": (1933.0, 263.0), "male": (1854.0, 263.0)}
#: The drawn length is clipped to this (mm): about 3 standard deviations either side.
LENGTH_LIMITS = (1100.0, 2700.0)
#: Each section's share of the whole length (the flexures' arcs aside) and its spread (sigma of a log-normal
#: factor): the sigmoid carries most of the variability of colon length (docs/anatomy.md).
SHARES = {"rectum": (0.085, 0.12), "sigmoid": (0.22, 0.30), "descending": (0.27, 0.12), "transverse": (0.28, 0.18),
          "ascending": (0.12, 0.15), "cecum": (0.045, 0.12)}
#: Control points of the spline: one every CONTROL_MM of the course, dense enough that the spline follows the
#: course's tightest arcs (a 90 deg arc of 8 mm radius holds 6 of them).
CONTROL_MM = 2.0
#: The wiggle: a smooth random offset added to the course, a cubic B-spline in the course's arc length whose
#: coefficients, one every WIGGLE_KNOT_MM, are normal with WIGGLE_MM standard deviation per axis. It is zero over
#: the anal canal and the anorectal flexure and grows to its full size over the next WIGGLE_RAMP_MM.
WIGGLE_MM = 5.0
WIGGLE_KNOT_MM = 15.0
WIGGLE_RAMP_MM = 40.0
#: No point of a centerline bends tighter than this radius (mm): where the wiggle would, it is damped there
#: (the course's own arcs are wider). The tightest bend of the real colons measured the same way is 4.6 mm
#: (docs/anatomy.md).
MIN_RADIUS_MM = 5.0
#: Spacing (mm) of the dense samples used for arc length and curvature.
DENSE_MM = 0.25
#: How far (mm) either side of a point the headings are compared when acute flexures are counted.
FLEXURE_REACH_MM = 25.0
#: Straight between the two bends of a fold (mm).
FOLD_GAP = (15.0, 40.0)

#: Where each bend aims (it turns the heading toward this direction by its drawn angle), in the body frame.
_AIM = {
    "anorectal": (0.0, -0.5, 0.87),  # from the anal canal up and back into the rectum
    "sacral": (0.0, 0.3, 1.0),  # the rectum follows the sacrum's hollow, up and forward again
    "rectosigmoid": (-0.25, 0.85, 0.45),  # sigmoid heads forward, a little right and up
    "sigmoid apex": (0.75, -0.45, -0.5),  # loop over to the left, back and down
    "sigmoid-descending": (0.1, -0.15, 1.0),  # up the left side
    "splenic flexure": (-0.6, 0.35, -0.7),  # sharply round to the right, forward and down
    "transverse sag": (-0.6, -0.2, 0.75),  # climb again toward the liver
    "hepatic flexure": (0.05, -0.1, -1.0),  # down the right side
}
_START_HEADING = (0.0, 0.7, 0.7)  # the anal canal points up and forward, toward the umbilicus


def check_seed(seed: Any, where: str = "anatomy") -> int:
    """A seed as a Python int, or a one-line BhrError."""
    if isinstance(seed, bool) or not isinstance(seed, (int, float, np.integer, np.floating)):
        raise BhrError(f"{where}: seed must be a whole number from 0 to {SEED_MAX}, got {excerpt(seed)}")
    v = float(seed)
    if not math.isfinite(v) or v != math.floor(v) or v < 0 or v > SEED_MAX:
        raise BhrError(f"{where}: seed must be a whole number from 0 to {SEED_MAX}, got {excerpt(seed)}")
    return int(v)


class _Wiggle:
    """A smooth random offset (mm) as a function of the course's arc length: a cubic B-spline, damped near the anus
    and wherever :meth:`damp` was asked to."""

    def __init__(self, seed: int, ramp_start: float) -> None:
        n = int(math.ceil(2.0 * LENGTH_LIMITS[1] / WIGGLE_KNOT_MM)) + 8  # enough for any course
        self.coef = np.random.default_rng(seed).normal(0.0, WIGGLE_MM, size=(n, 3))
        self.knots = (np.arange(n + 4) - 3.0) * WIGGLE_KNOT_MM
        self.ramp_start = ramp_start
        self.dips: list[float] = []  # course arc lengths where the wiggle is halved (as often as listed)

    def damp(self, s: float) -> None:
        self.dips.append(float(s))

    def __call__(self, s: np.ndarray) -> np.ndarray:
        from scipy.interpolate import BSpline

        off = BSpline(self.knots, self.coef, 3, extrapolate=False)(s)
        x = np.clip((s - self.ramp_start) / WIGGLE_RAMP_MM, 0.0, 1.0)
        env = x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)  # smootherstep: from 0 with zero slope and curvature
        for d in self.dips:
            env = env * (1.0 - 0.5 * np.exp(-0.5 * ((s - d) / WIGGLE_KNOT_MM) ** 2))
        return off * env[:, None]


class _Smooth:
    """The centerline: a cubic spline through control points of the course (straights and arcs) plus its wiggle."""

    def __init__(self, pieces: list, wiggle: _Wiggle) -> None:
        from scipy.interpolate import make_interp_spline

        lengths = np.array([p[1] for p in pieces])
        course_len = float(lengths.sum())
        n = max(int(math.ceil(course_len / CONTROL_MM)), 4)
        sc = np.linspace(0.0, course_len, n + 1)  # course arc length of each control point
        ctrl = _course_points(pieces, sc) + wiggle(sc)
        ctrl[0] = 0.0  # the anus stays at the origin
        u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ctrl, axis=0), axis=1))])
        t0 = pieces[0][4]
        spline = make_interp_spline(u, ctrl, k=3, bc_type=([(1, t0)], [(2, np.zeros(3))]))
        # dense samples, for arc length
        m = int(math.ceil(u[-1] / DENSE_MM)) + 1
        uu = np.linspace(0.0, u[-1], m)
        dense = spline(uu)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
        self.spline, self.u, self.uu, self.arc, self.sc = spline, u, uu, arc, sc
        self.length = float(arc[-1])

    def arc_of(self, course_s: np.ndarray) -> np.ndarray:
        """Arc length along the centerline of the points at ``course_s`` of the course (by control point)."""
        return np.interp(np.interp(course_s, self.sc, self.u), self.uu, self.arc)

    def course_of(self, s: np.ndarray) -> np.ndarray:
        """The course's arc length at the centerline's arc lengths ``s`` (the inverse of :meth:`arc_of`)."""
        return np.interp(np.interp(s, self.arc, self.uu), self.u, self.sc)

    def at(self, s: np.ndarray) -> np.ndarray:
        """Points at arc lengths ``s`` (mm from the anus)."""
        return self.spline(np.interp(s, self.arc, self.uu))

    def curvature(self, s: np.ndarray) -> np.ndarray:
        """Curvature (1/mm) at arc lengths ``s``."""
        u = np.interp(s, self.arc, self.uu)
        d1, d2 = self.spline(u, 1), self.spline(u, 2)
        sp = np.linalg.norm(d1, axis=1)
        return np.linalg.norm(np.cross(d1, d2), axis=1) / sp ** 3


def _bounded(pieces: list, wiggle: _Wiggle) -> _Smooth:
    """The centerline of ``pieces`` plus ``wiggle``, the wiggle damped where it bent tighter than MIN_RADIUS_MM.

    Each round halves the wiggle around the tightest point of every stretch under the limit (by the
    course's arc length, so the same places on every machine); the course's own arcs are never that tight.
    """
    for _ in range(40):
        smooth = _Smooth(pieces, wiggle)
        s = np.arange(0.0, smooth.length, DENSE_MM)
        kappa = smooth.curvature(s)
        over = kappa > 1.0 / MIN_RADIUS_MM
        if not over.any():
            return smooth
        edges = np.flatnonzero(np.diff(np.concatenate([[0], over.astype(np.int8), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            wiggle.damp(float(smooth.course_of(s[a + int(np.argmax(kappa[a:b]))])))
    raise BhrError("anatomy: the centerline still bends tighter than its limit after 40 rounds")  # pragma: no cover


def _course_points(pieces: list, s: np.ndarray) -> np.ndarray:
    lengths = np.array([p[1] for p in pieces])
    ends = np.cumsum(lengths)
    idx = np.minimum(np.searchsorted(ends, s, side="right"), len(pieces) - 1)
    local = s - (ends - lengths)[idx]
    pts = np.empty((len(s), 3))
    for k, (kind, length, r, p0, t0, d, _) in enumerate(pieces):
        sel = idx == k
        if not np.any(sel):
            continue
        u = np.minimum(local[sel], length)
        if kind == "straight":
            pts[sel] = p0 + u[:, None] * t0
        else:
            pts[sel] = p0 + (r * np.sin(u / r))[:, None] * t0 + (r * (1.0 - np.cos(u / r)))[:, None] * d
    return pts


def bend_radii(pts: np.ndarray, spacing: float, chord: float = 5.0) -> np.ndarray:
    """Radius (mm) of the circle through each point and the points ``chord`` mm of arc before and after it.

    ``pts`` are spaced ``spacing`` mm along the path; inf where the three are in line.
    """
    k = max(int(round(chord / spacing)), 1)
    a, b, c = pts[:-2 * k], pts[k:-k], pts[2 * k:]
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1))
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(area2 > 1e-12, ab * bc * ca / (2.0 * area2), np.inf)


def acute_flexures(pts: np.ndarray, spacing: float, reach: float = FLEXURE_REACH_MM) -> int:
    """Acute flexures of a path: the places where it turns by more than 90 deg within ``reach`` mm either side.

    The heading ``reach`` mm before a point against the heading ``reach`` mm
    after it: each stretch where they differ by more than 90 deg (the limbs
    meet at an acute angle) is one flexure.
    """
    k = max(int(round(reach / spacing)), 1)
    if len(pts) < 2 * k + 3:
        return 0
    v = np.diff(pts, axis=0)
    v /= np.linalg.norm(v, axis=1)[:, None]
    before, after = v[:-2 * k], v[2 * k:]
    acute = np.sum(before * after, axis=1) < 0.0
    return int(np.count_nonzero(acute[1:] & ~acute[:-1]) + int(acute[0]))


@dataclass
class Colon:
    """One drawn colon: its course (straights and arcs), its smooth centerline, and what was drawn.

    Built by :func:`anatomical_colon`; :meth:`sample` gives its centerline points and lumen at a feed,
    ``length`` and ``min_radius`` its length and tightest bend (mm).

    Parameters
    ----------
    seed : int
        The seed it was drawn from (0 ... :data:`SEED_MAX`).
    pieces : list of tuple
        The course, anus first: (kind ``"straight"`` or ``"arc"``, length mm, radius mm or inf, start point
        (3,) mm, start heading (3,) unit vector, bend direction (3,) unit vector or None, section name).
    section_lengths : dict of str to float
        Each of :data:`SECTIONS` to its length along the smooth centerline, mm.
    lumen_knots : tuple of (numpy.ndarray, numpy.ndarray), each shape (K,)
        The lumen's diameter profile: arc lengths from the anus, mm, and the diameter there, mm.
    bends : dict of str to tuple of (float, float)
        The course's named bends (``"anorectal"``, ``"sacral"``, ...) to (angle deg, radius mm).
    draws : dict of str to float, optional
        Every random number drawn, by name (``"length"`` mm, ``"lumen.rectum"`` mm, ``"folds.sigmoid"``
        a count, ...), for the record.
    smooth : object, optional
        The centerline spline (internal); None only while the colon is being built.
    sex : {"any", "female", "male"}, default "any"
        The CT population the total length was drawn from.

    Examples
    --------
    >>> colon = anatomical_colon(7)
    >>> points, lumen, section = colon.sample(2.0)
    >>> points.shape[1], lumen.shape == section.shape == points.shape[:1]
    (3, True)
    """

    seed: int
    #: the course: (kind, length mm, radius mm or inf, start point, start heading, bend direction or None, section)
    pieces: list[tuple[str, float, float, np.ndarray, np.ndarray, np.ndarray | None, str]]
    section_lengths: dict[str, float]  # along the smooth centerline
    lumen_knots: tuple[np.ndarray, np.ndarray]  # (arc length mm, diameter mm)
    bends: dict[str, tuple[float, float]]  # the course's bends: name -> (angle deg, radius mm)
    draws: dict[str, float] = field(default_factory=dict)
    smooth: _Smooth | None = None
    sex: str = "any"

    @property
    def length(self) -> float:
        """Length of the centerline, anus to cecum (mm)."""
        assert self.smooth is not None
        return self.smooth.length

    @property
    def min_radius(self) -> float:
        """Smallest radius of curvature of the centerline (mm), from the spline's derivatives every 0.25 mm."""
        assert self.smooth is not None
        s = np.arange(0.0, self.length, DENSE_MM)
        return float(1.0 / self.smooth.curvature(s).max())

    @property
    def acute_flexures(self) -> int:
        """Acute flexures of the centerline (:func:`acute_flexures`, points 1 mm apart)."""
        return acute_flexures(self.sample(1.0)[0], 1.0)

    @property
    def start_heading(self) -> np.ndarray:
        return self.pieces[0][4]

    def section_ends(self) -> np.ndarray:
        """Arc length (mm) at which each of :data:`SECTIONS` ends.

        Returns
        -------
        numpy.ndarray, shape (8,)
            The arc length from the anus where each section ends, mm, in the order of :data:`SECTIONS`.
        """
        return np.cumsum([self.section_lengths[s] for s in SECTIONS])

    def sample(self, feed: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points every ``feed`` mm of arc length, the lumen diameter at each, and each one's section index.

        Parameters
        ----------
        feed : float
            The spacing along the centerline, mm.

        Returns
        -------
        points : numpy.ndarray, shape (N, 3)
            The centerline from the anus (the origin), mm.
        lumen : numpy.ndarray, shape (N,)
            The lumen's diameter at each point, mm.
        section : numpy.ndarray of int, shape (N,)
            Each point's index in :data:`SECTIONS`.
        """
        assert self.smooth is not None
        total = self.length
        count = int(math.floor(total / feed + 1e-9)) + 1
        s = np.arange(count, dtype=np.float64) * feed
        pts = self.smooth.at(s)
        pts[0] = 0.0
        lumen = np.interp(s, *self.lumen_knots)
        section = np.minimum(np.searchsorted(self.section_ends(), s, side="right"), len(SECTIONS) - 1)
        return pts, lumen, section


def anatomical_colon(seed: int, sex: str = "any") -> Colon:
    """Draw the colon of ``seed`` (a whole number 0 ... :data:`SEED_MAX`); ``sex``: any, female or male.

    The total length is drawn from the CT population of :data:`POPULATION`
    (normal, clipped to :data:`LENGTH_LIMITS`), shared out between the
    sections by drawn shares (:data:`SHARES`); the course (straights and
    arcs through the anatomical bends and redundant folds, :data:`RANGES`)
    is built from it, and the centerline is the cubic spline through control
    points every :data:`CONTROL_MM` along the course, each moved by a random
    offset (:data:`JITTER_MM`): a smooth curve whose curvature varies
    continuously. The course is rebuilt once so that the spline's length is
    the drawn total.

    Parameters
    ----------
    seed : int
        Which colon: a whole number 0 ... :data:`SEED_MAX`; one seed always gives the same colon.
    sex : {"any", "female", "male"}, default "any"
        The CT population whose length distribution is drawn from.

    Returns
    -------
    Colon
        The colon: its course, centerline, lumen profile (mm) and the numbers drawn.

    Raises
    ------
    BhrError
        A seed that is not a whole number in range, or an unknown ``sex``.

    Examples
    --------
    >>> colon = anatomical_colon(7)
    >>> LENGTH_LIMITS[0] <= colon.length <= LENGTH_LIMITS[1]   # mm, anus to cecum
    True
    """
    seed = check_seed(seed)
    if sex not in POPULATION:
        raise BhrError(f"anatomy: sex must be one of {', '.join(POPULATION)}, got {sex!r}")
    rng = np.random.default_rng(seed)
    draws: dict[str, float] = {}

    def draw(key: str) -> float:
        lo, hi = RANGES[key]
        v = float(rng.uniform(lo, hi))
        draws[key] = v
        return v

    # Everything is drawn up front, in a fixed order, so one seed always gives the same numbers.
    mean, sd = POPULATION[sex]
    total = float(np.clip(mean + sd * rng.standard_normal(), *LENGTH_LIMITS))
    draws["length"] = total
    share = {s_: SHARES[s_][0] * math.exp(SHARES[s_][1] * float(rng.standard_normal())) for s_ in SHARES}
    norm = sum(share.values())
    share = {k: v / norm for k, v in share.items()}
    lumen = {s_: draw(f"lumen.{s_}") for s_ in SECTIONS}
    canal_d, canal_len = draw("lumen.anal canal"), draw("length.anal canal")
    bend_names = ("anorectal", "sacral", "rectosigmoid", "sigmoid apex", "sigmoid-descending", "splenic flexure",
                  "transverse sag", "hepatic flexure")
    # Bends that set the course turn exactly onto their (tilted) aim: their angle is what that takes; the
    # angle booked here is an upper bound, and what it does not use goes to the straight after the bend.
    booked = {"sigmoid-descending": 180.0, "transverse sag": 120.0, "hepatic flexure": 180.0}
    bends0: dict[str, tuple[float, float]] = {
        b: (booked[b] if b in booked else draw(f"angle.{b}"), draw(f"radius.{b}")) for b in bend_names}
    rolls = {b: math.radians(draw("roll")) for b in bend_names}
    aims = {}
    for b in ("sigmoid-descending", "hepatic flexure"):
        a = unit_vector(np.array(_AIM[b]))
        axis = rotate_about(unit_vector(np.cross(a, np.array([1.0, 0.0, 0.0]))), a, float(rng.uniform(0, 2 * math.pi)))
        aims[b] = rotate_about(a, axis, math.radians(draw("tilt")))
    rise = math.radians(draw("rise.transverse"))
    # Redundant folds (pairs of acute bends, the second undoing the first) in the sigmoid and transverse colon.
    folds: dict[str, list[str]] = {}
    for sec in ("sigmoid", "transverse"):
        count = int(rng.integers(FOLD_PAIRS[sec][0], FOLD_PAIRS[sec][1] + 1))
        draws[f"folds.{sec}"] = float(count)
        folds[sec] = []
        for k in range(count):
            name = f"{sec} fold {k + 1}"
            bends0[name] = (draw("angle.fold"), draw("radius.fold"))
            rolls[name] = float(rng.uniform(0.0, 2.0 * math.pi))  # a fold may turn any way
            draws[f"gap.{name}"] = float(rng.uniform(*FOLD_GAP))
            folds[sec].append(name)
    # Where the anatomical bends and the folds sit inside each section: its straight length is shared out
    # between the gaps by weights drawn here.
    layout0 = {"rectum": ["anorectal", "sacral"],
               "sigmoid": ["rectosigmoid", "sigmoid apex", "sigmoid-descending"],
               "transverse": ["transverse sag"]}
    for sec, items in layout0.items():
        for name in folds.get(sec, []):
            # sigmoid folds sit before its last bend, transverse folds before or after its sag
            items.insert(int(rng.integers(1, len(items))) if sec == "sigmoid" else int(rng.integers(0, 2)), name)
    gaps = {sec: rng.uniform(0.5, 1.5, size=len(items) + 1) for sec, items in layout0.items()}
    wiggle_seed = int(rng.integers(0, 2**63 - 1))

    def build(seg_len: dict[str, float]):
        bends = dict(bends0)
        layout = {k: list(v) for k, v in layout0.items()}
        fold_count = {sec: draws[f"folds.{sec}"] for sec in folds}
        def arc_len(name: str) -> float:
            return math.radians(bends[name][0]) * bends[name][1]

        def fixed_len(sec: str) -> float:
            """Length of a section taken by its bends and the straights inside its folds."""
            total = canal_len if sec == "rectum" else 0.0  # the anal canal is a straight of its own length
            for b in layout[sec]:
                total += 2 * arc_len(b) + draws[f"gap.{b}"] if "fold" in b else arc_len(b)
            return total

        # A rectum too short for its anal canal and its bends (at their smallest angles and radii) takes the length it
        # lacks from the sigmoid.
        least = (canal_len + sum(math.radians(RANGES[f"angle.{b}"][0]) * RANGES[f"radius.{b}"][0]
                                 for b in ("anorectal", "sacral"))) / 0.85
        if seg_len["rectum"] < least:
            seg_len = dict(seg_len, rectum=least, sigmoid=seg_len["sigmoid"] - (least - seg_len["rectum"]))
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
                fold_count[sec] -= 1
            if fixed_len(sec) > seg_len[sec]:
                # a very short section (a short rectum, seed 5987) whose bends are too long even at their smallest
                # radius and with no fold left: its drawn bends turn less, so that they fit the 85 % again (every
                # other colon is drawn as before)
                free = sum(arc_len(b) for b in layout[sec] if b not in booked)
                excess = fixed_len(sec) - budget
                if free > excess:
                    for b in layout[sec]:
                        if b not in booked:
                            bends[b] = (max(RANGES[f"angle.{b}"][0], bends[b][0] * (free - excess) / free), bends[b][1])
            if fixed_len(sec) > seg_len[sec]:  # pragma: no cover - the ranges make this impossible
                raise BhrError(f"anatomy seed {seed}: the {sec}'s bends are longer than the section")

        pieces: list[tuple[str, float, float, np.ndarray, np.ndarray, np.ndarray | None, str]] = []
        state: dict[str, Any] = {"p": np.zeros(3), "t": unit_vector(np.array(_START_HEADING)), "d": None, "slack": 0.0}

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
                    aim = unit_vector(unit_vector(h) * math.cos(rise) + np.array([0.0, 0.0, math.sin(rise)]))
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
                    aim = unit_vector(np.array(_AIM[name]))
                    n = aim - float(np.dot(aim, t)) * t
                    if np.linalg.norm(n) < 1e-6:  # pragma: no cover - aims are never along the heading
                        n = np.cross(t, np.array([1.0, 0.0, 0.0]))
                d = rotate_about(unit_vector(n), t, rolls[name])  # the bend's plane, turned about the heading
            d = unit_vector(d - float(np.dot(d, t)) * t)
            length = r * theta
            pieces.append(("arc", length, r, p.copy(), t.copy(), d.copy(), section))
            state["p"] = p + r * math.sin(theta) * t + r * (1.0 - math.cos(theta)) * d
            new_t = unit_vector(math.cos(theta) * t + math.sin(theta) * d)
            # where the bend was pulling, at its end
            state["d"] = unit_vector(math.cos(theta) * d - math.sin(theta) * t)
            state["t"] = new_t

        def section(sec: str) -> None:
            items = layout[sec]
            free = seg_len[sec] - fixed_len(sec)
            g = gaps[sec][:len(items) + 1]
            if sec == "rectum":  # the anal canal, then straight into the anorectal flexure
                g = np.concatenate([[0.0], g[1:]])
            w = g / g.sum()
            for k, name in enumerate(items):
                straight(w[k] * free + (canal_len if sec == "rectum" and k == 0 else 0.0), sec)
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

        return pieces, bends, fold_count

    def seg_lengths(scale: float) -> dict[str, float]:
        return {k: v * total * scale for k, v in share.items()}

    def centerline(pieces: list) -> _Smooth:
        canal_end = canal_len + pieces[1][1]  # the anal canal's straight and the anorectal flexure
        return _bounded(pieces, _Wiggle(wiggle_seed, canal_end))

    pieces, bends, fold_count = build(seg_lengths(1.0))
    course_len = sum(p[1] for p in pieces)
    smooth = centerline(pieces)
    # the spline is longer than its course by the factor rho; the flexures' arcs are not in the shares
    rho = smooth.length / course_len
    pieces, bends, fold_count = build(seg_lengths((total / rho - (course_len - total)) / total))
    smooth = centerline(pieces)
    for sec, n in fold_count.items():
        draws[f"folds.{sec}"] = float(n)
    course_lengths = {s_: 0.0 for s_ in SECTIONS}
    for pc in pieces:
        course_lengths[pc[6]] += pc[1]
    course_ends = np.cumsum([course_lengths[s_] for s_ in SECTIONS])
    ends = smooth.arc_of(course_ends)
    section_lengths = dict(zip(SECTIONS, np.diff(np.concatenate([[0.0], ends])).tolist()))
    mids = ends - 0.5 * np.array([section_lengths[s_] for s_ in SECTIONS])
    # the anal canal keeps its narrow lumen through the anorectal flexure, then widens into the rectum
    narrow_end = float(smooth.arc_of(np.array([canal_len + pieces[1][1]]))[0])
    mids[0] = max(mids[0], narrow_end + 0.5 * (ends[0] - narrow_end))
    knots_s = np.concatenate([[0.0, narrow_end], mids, [ends[-1]]])
    diam = [lumen[s_] for s_ in SECTIONS]
    knots_d = np.array([canal_d, canal_d, *diam, diam[-1]])
    draws["lumen.anal canal"], draws["length.anal canal"] = canal_d, canal_len
    return Colon(seed, pieces, section_lengths, (knots_s, knots_d), bends, draws, smooth, sex)


#: The colons shipped as editable point files (trajectories/NAME.csv): name -> (seed, what it shows).
SHIPPED: dict[str, tuple[int, str]] = {
    "anatomy-short": (92, "the shortest colon of seeds 1-100"),
    "anatomy-typical": (97, "the median length of seeds 1-100"),
    "anatomy-tortuous": (14, "the most acute flexures of seeds 1-100"),
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


def _section_arcs(traj: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """A generated anatomical colon's path (``--traj anatomy --seed N``): the arc length at each of its points and
    where each section ends along it (mm); None for any other path."""
    seed = (getattr(traj, "params", None) or {}).get("seed")
    if seed is None or not str(getattr(traj, "name", "")).startswith("anatomy"):
        return None
    pts = np.asarray(traj.points, dtype=np.float64)
    return (np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]),
            anatomical_colon(int(seed)).section_ends())


def path_sections(traj: Any) -> list[tuple[str, int]] | None:
    """The anatomical sections along an anatomical colon's path (``--traj anatomy --seed N``): each section's name
    and the index of the path point in its middle (for the figures' labels); None for any other path."""
    if (arcs := _section_arcs(traj)) is None:
        return None
    s, ends = arcs
    starts = np.concatenate([[0.0], ends[:-1]])
    return [(name, int(np.clip(np.searchsorted(s, (a + b) / 2.0), 0, len(s) - 1)))
            for name, a, b in zip(SECTIONS, starts, ends)]


def path_section_ranges(traj: Any) -> list[tuple[str, int, int]]:
    """The anatomical sections along a path as ``(name, first point, one past the last)``: a real colon's own
    (``traj.sections``), a generated anatomical colon's from its section ends; [] for any other path."""
    if getattr(traj, "sections", None):
        return [(n, int(a), int(b)) for n, a, b in traj.sections]
    if (arcs := _section_arcs(traj)) is None:
        return []
    s, ends = arcs
    cuts = [0, *np.searchsorted(s, ends[:-1]).tolist(), len(s)]
    return [(name, int(a), int(b)) for name, a, b in zip(SECTIONS, cuts[:-1], cuts[1:]) if b > a]
