"""A trajectory as the solvers and the follow-the-leader driver see it: points and what is known about them.

:class:`Trajectory` is what :func:`bhr.model._generators.load_trajectory` returns for a
built-in generator or a trajectory file (:mod:`bhr.model._pathfile`);
:func:`path_directions` gives the unit vectors between its points that the
follow-the-leader loop aims the tip along (thesis ch. 7).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numba import njit

from bhr._settings.inputs import MAX_POINTS
from bhr._settings.options import check_number, excerpt
from bhr._settings.errors import BhrError
from bhr._kinematics.polyline import median_spacing, segment_direction, unit_tangents, walk_kernel

__all__ = ["Trajectory", "check_feed", "path_directions", "spacing", "resample_polyline", "unfollowable_bends",
           "BEND_WINDOWS_MM"]


def check_feed(feed: object) -> float:
    """``feed`` as mm, or a BhrError: a positive finite number (an int of 400 digits is refused, never converted)."""
    try:
        return check_number(feed, "feed", positive=True, unit="mm")
    except BhrError:
        raise BhrError(f"feed must be a positive number of mm, got {excerpt(feed)}") from None


@dataclass
class Trajectory:
    """Points (N, 3) spaced by the feed, plus what is known about the path.

    ``feed`` is the spacing (mm) the points were sampled at, ``None`` when
    unknown (points given as an array); ``lumen`` the lumen diameter (mm) at
    each point, if known. A trajectory reads as its points wherever numpy
    expects an array (``np.asarray(traj)``, ``traj.shape``, ``traj[i]``).
    :meth:`at_feed` gives the same path sampled at another feed: built-ins and
    trajectory files are drawn again at that feed, exactly as ``bhr follow``
    draws them; other points are resampled along their polyline.

    Parameters
    ----------
    name : str
        The path's name: a generator (``"curve"``), ``"anatomy-SEED"``, a file's stem or ``"points"``.
    points : numpy.ndarray, shape (N, 3)
        The path's points x, y, z, mm, float64, one feed apart when ``feed`` is known.
    params : dict of str to object, optional
        The generator's or file's parameters (e.g. ``{"radius": 70.0, "angle": 90.0}``, mm and deg).
    min_radius : float, default inf
        The path's tightest bend radius, mm (exact for the generators, estimated for points); inf when it
        does not bend.
    lumen : numpy.ndarray, shape (N,), optional
        The lumen's diameter at each point, mm; None when not known (no wall).
    source : str, optional
        Where the path came from (a generator, a file's path), named in error messages.
    start_direction : tuple of float, shape (3,), default (1, 0, 0)
        The direction x, y, z the robot enters the path along (unit vector, world frame).
    start_point : tuple of float, shape (3,), default (0, 0, 0)
        The point the robot's base starts at, mm.
    feed : float, optional
        The spacing the points were sampled at, mm; None when not known (points given as an array).
    redraw : callable ``redraw(feed) -> Trajectory``, optional
        Draws the same path again at another feed (set by :func:`bhr.model.load_trajectory`); picklable.
    lumen_end : {"closed", "open"}, default "closed"
        How the lumen ends past the last point: a blind end as the cecum (past it is wall), or going on
        straight. The entrance (the first point) is always open: the robot comes in there.
    sections : tuple of (str, int, int), optional
        Named anatomical sections along the path: (name, first point, one past the last point), in order,
        covering the points (a real colon's landmarks bound them); empty when the path has none.
    mesh : str, optional
        A surface mesh of the lumen's wall in the same frame (a .vtp file), where one is known; the
        clearance is then measured against it (docs/real_colons.md).
    lumen_model : {"ct", "insufflated"}, default "ct"
        Which lumen the diameters are: as given (measured, drawn or written), or the insufflation model of
        :mod:`bhr.model._insufflation` (an idealisation).

    Examples
    --------
    >>> import bhr
    >>> t = bhr.trajectory("line", length=10)
    >>> t
    Trajectory('line', 6 points, feed 2 mm, 10 mm long)
    >>> t.at_feed(1.0).shape
    (11, 3)
    """

    name: str
    points: np.ndarray
    params: dict[str, Any] = field(default_factory=dict)
    min_radius: float = math.inf
    lumen: np.ndarray | None = None  # lumen diameter (mm) at each point, if known
    source: str = ""
    start_direction: tuple[float, ...] = (1.0, 0.0, 0.0)  # x, y, z
    start_point: tuple[float, ...] = (0.0, 0.0, 0.0)
    #: the spacing (mm) the points were sampled at; None: not known
    feed: float | None = None
    #: draws the same trajectory at another feed (set by bhr.model._generators.load_trajectory); picklable
    redraw: Callable[[float], "Trajectory"] | None = field(default=None, repr=False, compare=False)
    #: How the lumen ends past the last point: "closed" (a blind end, as the cecum: past it is wall) or "open"
    #: (it goes on straight). The entrance (the first point) is always open: the robot comes in there.
    lumen_end: str = "closed"
    #: Named anatomical sections along the path: (name, first point, one past the last point), in order, covering
    #: the points (a real colon's landmarks bound them); empty when the path has none.
    sections: tuple[tuple[str, int, int], ...] = ()
    #: A surface mesh of the lumen's wall in the same frame (a .vtp file), where one is known; the clearance is
    #: then measured against it (docs/real_colons.md).
    mesh: str | None = None
    #: Which lumen the diameters are: "ct" (as given: measured, drawn or written) or "insufflated" (the model of
    #: bhr.model._insufflation, an idealisation).
    lumen_model: str = "ct"

    def section_at(self, i: int) -> str | None:
        """The name of the section point ``i`` lies in, or None.

        Parameters
        ----------
        i : int
            A 0-based point index.

        Returns
        -------
        str or None
            The section's name (``"sigmoid"``, ...), or None when the path has no section there.
        """
        for name, a, b in self.sections:
            if a <= i < b:
                return name
        return None

    @property
    def planar(self) -> bool:
        """True when every point has the same z (drawn from the top)."""
        z = self.points[:, 2]
        return bool(np.ptp(z) <= 1e-9 * max(1.0, float(np.abs(self.points).max())))

    @property
    def length_mm(self) -> float:
        """Length of the polyline through the points (mm)."""
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).sum())

    # read as the (N, 3) points where numpy expects an array
    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        return np.asarray(self.points, dtype=dtype) if copy is None or copy is False else \
            np.array(self.points, dtype=dtype, copy=True)

    def __len__(self) -> int:
        return int(self.points.shape[0])

    def __getitem__(self, index: Any) -> Any:
        return self.points[index]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self.points.shape)

    def __repr__(self) -> str:
        feed = "feed unknown" if self.feed is None else f"feed {self.feed:g} mm"
        lumen = "" if self.lumen is None else ", with lumen"
        return f"Trajectory({self.name!r}, {len(self)} points, {feed}, {self.length_mm:.4g} mm long{lumen})"

    def at_feed(self, feed: float) -> "Trajectory":
        """This trajectory sampled every ``feed`` mm (itself when it already is).

        Built-ins and trajectory files are drawn again at ``feed``; other points
        are resampled along the polyline (:func:`resample_polyline`), the lumen
        with them.

        Parameters
        ----------
        feed : float
            The new spacing, mm (> 0).

        Returns
        -------
        Trajectory
            The path with points ``feed`` mm apart (and its lumen and sections with them).

        Raises
        ------
        BhrError
            A feed that is not a positive number, or longer than the path.
        """
        feed = check_feed(feed)
        if self.feed is not None and math.isclose(self.feed, feed, rel_tol=1e-12):
            return self
        if self.redraw is not None:
            return self.redraw(float(feed))
        if self.length_mm < feed:
            raise BhrError(f"the trajectory is {self.length_mm:g} mm long, shorter than one feed ({feed:g} mm); "
                           "give a longer path or a smaller feed")
        pts, lumen = resample_polyline(self.points, float(feed), self.lumen)
        sections: tuple[tuple[str, int, int], ...] = ()
        if self.sections:  # each new point keeps the section of the old point it falls after
            _, idx = resample_polyline(self.points, float(feed), np.arange(len(self.points), dtype=np.float64))
            assert idx is not None
            sections = runs_of(labels_of(self.sections, len(self.points))[np.floor(idx + 1e-9).astype(int)])
        return Trajectory(self.name, pts, dict(self.params), self.min_radius, lumen, self.source,
                          self.start_direction, self.start_point, float(feed), lumen_end=self.lumen_end,
                          sections=sections, mesh=self.mesh, lumen_model=self.lumen_model)


def labels_of(sections: tuple[tuple[str, int, int], ...], count: int) -> np.ndarray:
    """One label per point ("" outside every section) from (name, first, one past last) runs."""
    out = np.full(count, "", dtype=object)
    for name, a, b in sections:
        out[a:b] = name
    return out


def runs_of(labels: np.ndarray) -> tuple[tuple[str, int, int], ...]:
    """(name, first point, one past the last point) for each run of equal, non-empty labels."""
    runs: list[tuple[str, int, int]] = []
    start = 0
    for i in range(1, len(labels) + 1):
        if i == len(labels) or labels[i] != labels[start]:
            if labels[start]:
                runs.append((str(labels[start]), start, i))
            start = i
    return tuple(runs)


def spacing(points: np.ndarray) -> float:
    """Median distance between consecutive points (mm); 0 for fewer than two points."""
    pts = np.ascontiguousarray(points, dtype=np.float64)
    if pts.shape[0] < 2:
        return 0.0
    return float(median_spacing(pts))


def resample_polyline(pts: np.ndarray, feed: float, values: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray | None]:
    """Points exactly ``feed`` mm apart, walking along the polyline ``pts`` (first point kept).

    Each next point is where the polyline, followed from the previous point,
    first leaves the sphere of radius ``feed`` around it. On a smooth curve
    this is resampling by arc length (chord and arc of one feed differ by
    feed^2 / (24 R^2), relatively: 5e-5 at 2 mm on a 57 mm radius); on a
    densely measured noisy centerline it does not count the zigzag of the
    raw points as length, as summing the raw segment lengths would.
    ``values`` (one per input point, e.g. lumen diameters) are interpolated
    linearly along the segment where each new point falls. The remainder
    shorter than one feed is dropped.
    """
    pts = np.ascontiguousarray(pts, dtype=np.float64)
    vals = np.zeros(pts.shape[0]) if values is None else np.ascontiguousarray(values, dtype=np.float64)
    length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    cap = min(MAX_POINTS, int(length / feed) + 2)  # chords are never longer than the arcs they span
    out = np.empty((cap, 3))
    out_vals = np.empty(cap)
    count = walk_kernel(pts, vals, float(feed), out, out_vals)
    if count < 0:
        raise BhrError(f"the path gives more than {MAX_POINTS} points at a feed of {feed:g} mm; raise the feed")
    return out[:count].copy(), (None if values is None else out_vals[:count].copy())


#: How much further than the path's length the feeder may push a whole robot to bring its tip to the cecum, as a
#: fraction of the path: a binary chain weaves about a smooth centerline, so its trail covers a little less of
#: the colon than the robot's insertion (28-52 mm, 1.4-2.7 % of the path, on colons 1-10 at α 25° and 5 mm modules).
CECUM_APPROACH = 0.25


def approach_steps(path_steps: int) -> int:
    """The most steps a run of a path of ``path_steps`` may take past its end to bring the tip to the cecum."""
    return int(math.ceil(CECUM_APPROACH * (int(path_steps) - 1)))


def to_steps(a: np.ndarray, steps: int) -> np.ndarray:
    """The first ``steps`` rows of ``a`` (a path's points, lumen, ...), its last row repeated past its end: a whole
    robot pushed on to the cecum after the path's end has the path's end as its target (docs/locomotion.md)."""
    A = np.asarray(a)
    extra = int(steps) - A.shape[0]
    return A[:steps] if extra <= 0 else np.concatenate([A, np.repeat(A[-1:], extra, axis=0)])


def path_directions(path: np.ndarray) -> np.ndarray:
    """Unit vectors from each trajectory point to the next, (N-1, 3)."""
    P = np.ascontiguousarray(path, dtype=np.float64)
    out = np.empty((max(P.shape[0] - 1, 0), 3))
    k = _directions_kernel(P, out)
    if k >= 0:
        raise BhrError(f"trajectory points {k + 1} and {k + 2} are the same point; remove the duplicate")
    return out


@njit(cache=True)
def _directions_kernel(P, out):
    """:func:`path_directions` into ``out``; the first segment of no length (its index), else -1."""
    for k in range(out.shape[0]):
        out[k, 0], out[k, 1], out[k, 2], n = segment_direction(P, k)
        if n == 0.0:
            return k
    return -1


#: Half-lengths (mm of arc) of the stretches :func:`unfollowable_bends` judges a bend over: from 2.5 mm to
#: 160 mm, each about 8 % longer than the last (and at least one point longer).
BEND_WINDOWS_MM = tuple(float(v) for v in np.geomspace(2.5, 160.0, 55))
_BEND_WINDOWS = np.array(BEND_WINDOWS_MM)


def unfollowable_bends(points: np.ndarray, lumen: np.ndarray, turn_radius: float, robot_radius: float
                       ) -> list[tuple[int, int, float, float]]:
    """The stretches of a centerline where a robot of ``turn_radius`` cannot follow the bend inside its lumen.

    The rule (docs/lumen.md, "Which bends a robot can follow"): a robot of radius a may leave the
    centerline by up to e = lumen/2 - a either way. Take a stretch of centerline 2w long around a point that
    turns by theta (between the headings at its ends): as a bend it has the mean radius r = 2w / theta.
    A robot turning at radius R >= r can still take it by swinging wide: riding the outer wall before
    and after and the inner wall at the apex, a circle of radius R, tangent to the stretch's limbs, fits
    in the tube when R - r <= e (1 + c) / (1 - c), c = cos(theta / 2) (a U-turn, theta = 180 deg: R <= r + e;
    a gentle turn: ever more room). A point is unfollowable when some stretch around it, of half-length
    w in :data:`BEND_WINDOWS_MM` (rounded to whole points), fails that; e is the narrowest over the
    stretch. A path that bends nowhere tighter than R has none (r >= R on every stretch).

    Parameters
    ----------
    points : numpy.ndarray, shape (N, 3)
        The centerline, mm, evenly spaced.
    lumen : numpy.ndarray, shape (N,)
        The lumen's diameter at each point, mm.
    turn_radius : float
        The robot's minimum turn radius R, mm (:func:`min_turn_radius`).
    robot_radius : float
        The robot's disc radius a, mm.

    Returns
    -------
    list of tuple of (int, int, float, float)
        One tuple per stretch of unfollowable points: (first index, last index, the mean radius r of its
        tightest failing stretch in mm, the narrowest lumen diameter there in mm); empty when the robot
        can follow every bend (and for fewer than 3 points).

    Examples
    --------
    >>> import bhr
    >>> from bhr.model import min_turn_radius
    >>> t = bhr.trajectory("curve", radius=30, angle=90)   # tighter than the thesis robot's 57.15 mm
    >>> R = min_turn_radius(10, 10)
    >>> [(a, b, round(r, 1), d) for a, b, r, d in unfollowable_bends(t.points, np.full(len(t), 12.0), R, 5.0)]
    [(19, 34, 30.6, 12.0)]
    >>> unfollowable_bends(t.points, np.full(len(t), 40.0), R, 5.0)   # a wide lumen: it swings wide
    []
    """
    pts = np.asarray(points, dtype=np.float64)
    lum = np.ascontiguousarray(lumen, dtype=np.float64)
    n = pts.shape[0]
    h = spacing(pts)
    if n < 3 or h <= 0 or not math.isfinite(turn_radius) or turn_radius <= 0:
        return []
    bad = np.zeros(n, dtype=np.bool_)
    worst_r = np.full(n, np.inf)
    worst_d = np.full(n, np.inf)
    _bends_kernel(_tangents(pts), np.maximum(0.5 * lum - robot_radius, 0.0), lum, h, float(turn_radius),
                  _windows(h), bad, worst_r, worst_d)
    return _stretches(bad, worst_r, worst_d)


def _tangents(pts: np.ndarray) -> np.ndarray:
    t = np.empty((pts.shape[0], 3))
    unit_tangents(np.ascontiguousarray(pts, dtype=np.float64), t)
    return t


def _windows(h: float) -> np.ndarray:
    """The stretches' half-lengths in whole points, shortest first."""
    return np.unique(np.maximum(np.rint(_BEND_WINDOWS / h), 1.0)).astype(np.int64)  # rint: round half to even


def _stretches(bad: np.ndarray, worst_r: np.ndarray, worst_d: np.ndarray) -> list[tuple[int, int, float, float]]:
    out = []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], bad.astype(np.int8), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):
        j = a + int(np.argmin(worst_r[a:b]))
        out.append((int(a), int(b - 1), float(worst_r[j]), float(worst_d[j])))
    return out


@njit(cache=True)
def _range_min_table(v):
    """Sparse table of ``v``'s minima: row j holds the minimum of ``v[i : i + 2**j]``."""
    n = v.shape[0]
    levels = 1
    while (1 << levels) <= n:
        levels += 1
    tab = np.empty((levels, n))
    tab[0] = v
    for j in range(1, levels):
        half = 1 << (j - 1)
        for i in range(n - (1 << j) + 1):
            tab[j, i] = min(tab[j - 1, i], tab[j - 1, i + half])
    return tab


@njit(cache=True)
def _range_min(tab, a, b):
    """The minimum of ``v[a : b + 1]`` from its sparse table."""
    j = 0
    while (1 << (j + 1)) <= b - a + 1:
        j += 1
    return min(tab[j, a], tab[j, b - (1 << j) + 1])


@njit(cache=True)
def _bends_kernel(t, free, lum, h, big_r, ks, bad, worst_r, worst_d):
    """:func:`unfollowable_bends_numpy`'s rule, point by point: ``bad``, ``worst_r`` and ``worst_d`` filled."""
    n = t.shape[0]
    tf = _range_min_table(free)
    tl = _range_min_table(lum)
    for k in ks:
        if 2 * k >= n:
            break
        # a turn theta <= 2 k h / R is never unfollowable (r >= R): its cosine is at least this, and then the
        # arc cosine is not taken (with a margin that rounding cannot cross)
        x = 2.0 * k * h / big_r
        if x > math.pi * (1.0 + 1e-12):  # no turn (theta <= pi) makes a stretch this long tighter than R
            continue
        gentle = math.cos(x) + 1e-12 if x < math.pi else 2.0
        for i in range(k, n - k):
            dot = t[i - k, 0] * t[i + k, 0] + t[i - k, 1] * t[i + k, 1] + t[i - k, 2] * t[i + k, 2]
            if dot >= gentle:
                continue
            theta = math.acos(min(1.0, max(-1.0, dot)))
            if theta <= 1e-9:
                continue
            r = 2.0 * k * h / theta
            if big_r <= r:  # the room below is never negative
                continue
            c = math.cos(0.5 * theta)
            room = _range_min(tf, i - k, i + k) * (1.0 + c) / (1.0 - c) if c < 1.0 else np.inf
            if big_r > r + room:
                bad[i] = True
                if r < worst_r[i]:
                    worst_r[i] = r
                    worst_d[i] = _range_min(tl, i - k, i + k)


def unfollowable_bends_numpy(points: np.ndarray, lumen: np.ndarray, turn_radius: float, robot_radius: float
                             ) -> list[tuple[int, int, float, float]]:
    """The numpy reference of :func:`unfollowable_bends` (the same rule, window by window)."""
    from scipy.ndimage import minimum_filter1d

    pts = np.asarray(points, dtype=np.float64)
    lum = np.asarray(lumen, dtype=np.float64)
    n = pts.shape[0]
    h = spacing(pts)
    if n < 3 or h <= 0 or not math.isfinite(turn_radius) or turn_radius <= 0:
        return []
    t = _tangents(pts)
    free = np.maximum(0.5 * lum - robot_radius, 0.0)
    bad = np.zeros(n, dtype=bool)
    worst_r = np.full(n, np.inf)
    worst_d = np.full(n, np.inf)
    for k in _windows(h):
        if 2 * k >= n:
            break
        i = np.arange(k, n - k)
        theta = np.arccos(np.clip(np.einsum("ij,ij->i", t[i - k], t[i + k]), -1.0, 1.0))
        with np.errstate(divide="ignore"):
            r = np.where(theta > 1e-9, 2.0 * k * h / theta, np.inf)
        c = np.cos(0.5 * theta)
        e = minimum_filter1d(free, 2 * k + 1, mode="nearest")[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(c < 1.0, e * (1.0 + c) / (1.0 - c), np.inf)
        fail = turn_radius > r + room
        sel = i[fail]
        bad[sel] = True
        better = r[fail] < worst_r[sel]
        worst_r[sel[better]] = r[fail][better]
        worst_d[sel[better]] = (minimum_filter1d(lum, 2 * k + 1, mode="nearest")[i])[fail][better]
    return _stretches(bad, worst_r, worst_d)
