"""Lumen clearance: how far the robot's surface stays from the wall of the lumen it follows.

A trajectory may carry the lumen's inner diameter at each point
(:attr:`bhr.model.generators.Trajectory.lumen`: a CSV ``lumen`` column, segment
files, generator files; the built-in colon has 30 mm in the rectum and 45 mm
elsewhere). The lumen is then a tube: the trajectory is its centerline and
the diameter varies linearly between points. The clearance of a point ``p``
of the robot (a disc of the robot's radius around its axis) is

    R(s*) - robot radius - |p - C(s*)|

in mm, where ``C(s*)`` is the point of the centerline nearest to ``p`` and
``R(s*)`` the lumen radius there: the gap between the robot's surface and the
wall. Zero or less means the wall is touched; its negative is the
penetration. The nearest point is searched **locally**: only the centerline
within ``window`` mm of arc length of where the point is expected (the
trajectory point it is scored against in :mod:`bhr.run.driver`), so that two
loops of the colon passing close to each other are never mistaken for one
another.

Not only the points count: every module is a straight segment between two
points, and its clearance is the smallest along it. It is sampled at most
``sample`` mm apart (both ends included) and the worst sample refined by a
golden-section search between its neighbours, which finds the minimum to
0.01 mm wherever the clearance has one minimum between two samples. Points
and samples expected before the start of the path (the part of the robot
still behind the lumen's entrance) are not scored. With a body
(``--body-modules``) its points and modules count too, and so does the link
between the head's base and the body.

A run's summary gets ``min_clearance_mm`` (geometric; negative = into the
wall), ``max_penetration_mm`` (>= 0), ``wall_touch_steps`` (1-based steps
where some point or module touches), ``contact_length_mm`` (per module: the
length of path the robot travelled while that module touched the wall, one
feed per step in contact) and, for comparison with older runs,
``index_matched_min_clearance_mm``: the clearance measured from each point's
own trajectory point instead of the nearest one (the figure bhr reported
before; a robot lagging behind along the path reads there as deep in the
wall).

:func:`clearance_run` is compiled with numba; :func:`clearance_run_numpy`
is the readable reference that tests hold it equal to.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from numba import njit

from bhr.settings.errors import BhrError

__all__ = ["ClearanceReport", "Tube", "make_tube", "clearance_table", "clearance_report", "clearance_run",
           "clearance_run_all", "clearance_run_numpy", "point_clearance", "locate_numpy", "brute_force_clearance",
           "left_lumen", "lumen_end_of", "run_chain", "step_ranges", "WINDOW_MM", "SAMPLE_MM", "LUMEN_ENDS",
           "LOOP_RATIO", "BLOCK"]

#: Half-width (mm of arc length) of the stretch of centerline searched for a point's nearest point.
WINDOW_MM = 40.0
#: How a lumen may end past its last centerline point: capped (a blind end, the default) or continuing straight.
LUMEN_ENDS = ("closed", "open")
#: Largest spacing (mm) of the samples along a module.
SAMPLE_MM = 1.0
#: Golden-section iterations refining the worst sample of a module.
REFINE_ITERS = 20
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0
#: The whole centerline is searched for a nearer stretch when a point's local clearance is at most this (mm).
GLOBAL_BELOW = 0.0
#: Segments of centerline per block of the global search (each block is bounded by a sphere).
BLOCK = 16
#: Two stretches of centerline are different passes of a loop when the centerline between their nearest points
#: is longer than LOOP_RATIO x (the straight distance between those points + the point's distance to each).
LOOP_RATIO = 2.0


@dataclass
class Tube:
    """The lumen as a tube: its centerline, the radius at each point, and what the global search needs.

    ``points[k]`` is trajectory point ``k - pre``; the ``pre`` points before
    the start continue the path backwards along its start direction (the
    entrance is open), with the start's radius. An open end continues the
    path forwards along its last direction for ``post`` points; a closed end
    (``post == 0``) stops at the last point, so the lumen ends in a cap (the
    half ball of the end's lumen radius around the last centerline point) and
    past it is wall. ``window`` is the local search half-width in points;
    ``arc`` the arc length (mm) at each tube point; ``block_centre`` and
    ``block_radius`` bound each run of :data:`BLOCK` segments by a sphere
    (the global search skips the blocks that cannot hold a nearer point).
    """

    points: np.ndarray  # (M, 3)
    radius: np.ndarray  # (M,) mm
    pre: int
    post: int
    window: float  # points
    spacing: float = 1.0  # mm between centerline points (median)
    arc: np.ndarray | None = None  # (M,) mm
    block_centre: np.ndarray | None = None  # (ceil((M-1)/BLOCK), 3)
    block_radius: np.ndarray | None = None  # (ceil((M-1)/BLOCK),)

    @property
    def closed(self) -> bool:
        """True when the lumen ends in a cap at the last centerline point (a blind end)."""
        return self.post == 0

    def search_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(arc, block_centre, block_radius), computed once if the tube was built without them."""
        if self.arc is None or self.block_centre is None or self.block_radius is None:
            self.arc, self.block_centre, self.block_radius = _search_arrays(self.points)
        return self.arc, self.block_centre, self.block_radius


def _search_arrays(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    nseg = pts.shape[0] - 1
    nb = (nseg + BLOCK - 1) // BLOCK
    centre = np.empty((nb, 3))
    rad = np.empty(nb)
    for j in range(nb):
        block = pts[j * BLOCK:min(j * BLOCK + BLOCK, nseg) + 1]
        c = 0.5 * (block.min(axis=0) + block.max(axis=0))
        centre[j] = c
        rad[j] = float(np.sqrt(((block - c) ** 2).sum(axis=1).max())) * (1.0 + 1e-12) + 1e-9
    return np.ascontiguousarray(arc), centre, rad


def make_tube(path: np.ndarray, lumen: np.ndarray, start_direction=None, window_mm: float = WINDOW_MM, *,
              closed_end: bool = False) -> Tube:
    """The :class:`Tube` of a trajectory whose points are ``path`` and lumen diameters ``lumen``.

    ``closed_end`` caps the lumen at the last point (a blind end, as the
    cecum: how runs are scored, :func:`clearance_report`); without it the
    lumen continues straight past the end.
    """
    P = np.ascontiguousarray(path, dtype=np.float64)
    lum = np.asarray(lumen, dtype=np.float64)
    N = P.shape[0]
    if N < 2:
        raise BhrError("a lumen needs a centerline of at least two points")
    if lum.ndim != 1 or lum.shape[0] < N:
        raise BhrError(f"the lumen has {lum.shape[0] if lum.ndim == 1 else lum.shape} diameters for {N} points; "
                       "give one diameter per trajectory point")
    if not (math.isfinite(window_mm) and window_mm > 0):
        raise BhrError(f"the clearance window must be a positive number of mm, got {window_mm!r}")
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    spacing = float(np.median(seg))
    if spacing <= 0:
        raise BhrError("the lumen's centerline has repeated points; remove the duplicates")
    w = window_mm / spacing
    pad = int(math.ceil(w)) + 2
    post = 0 if closed_end else pad
    d0 = P[1] - P[0] if start_direction is None else np.asarray(start_direction, dtype=np.float64)
    d0 = d0 / np.linalg.norm(d0)
    d1 = (P[-1] - P[-2]) / np.linalg.norm(P[-1] - P[-2])
    before = P[0] - spacing * np.arange(pad, 0, -1)[:, None] * d0
    after = P[-1] + spacing * np.arange(1, post + 1)[:, None] * d1
    pts = np.ascontiguousarray(np.vstack([before, P, after]))
    rad = np.concatenate([np.full(pad, lum[0]), lum[:N], np.full(post, lum[N - 1])]) / 2.0
    arc, centre, brad = _search_arrays(pts)
    return Tube(pts, np.ascontiguousarray(rad), pad, post, float(w), spacing, arc, centre, brad)


# ---------------------------------------------------------------------------
# compiled kernels


@njit(cache=True)
def segment_scan(C, lo, hi, px, py, pz):
    """Nearest point to (px, py, pz) on the centerline segments ``lo..hi-1`` of ``C``.

    Returns (squared distance, segment, position 0..1 along it); the first of
    equally near segments wins.
    """
    best = 1e300
    bk = lo
    bt = 0.0
    for k in range(lo, hi):
        ax, ay, az = C[k, 0], C[k, 1], C[k, 2]
        ux, uy, uz = C[k + 1, 0] - ax, C[k + 1, 1] - ay, C[k + 1, 2] - az
        uu = ux * ux + uy * uy + uz * uz
        t = ((px - ax) * ux + (py - ay) * uy + (pz - az) * uz) / uu
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        dx, dy, dz = px - (ax + t * ux), py - (ay + t * uy), pz - (az + t * uz)
        d2 = dx * dx + dy * dy + dz * dz
        if d2 < best:
            best = d2
            bk = k
            bt = t
    return best, bk, bt


@njit(cache=True)
def nearest_kernel(C, R, lo, hi, px, py, pz):
    """Nearest point to (px, py, pz) on the centerline segments ``lo..hi-1`` of ``C``.

    Returns (distance, radius there, position as a fractional index into C).
    The first of equally near segments wins.
    """
    best, bk, bt = segment_scan(C, lo, hi, px, py, pz)
    return math.sqrt(best), R[bk] + bt * (R[bk + 1] - R[bk]), bk + bt


@njit(cache=True)
def search_window(M, e, w):
    lo = int(math.floor(e - w))
    hi = int(math.ceil(e + w))
    if lo < 0:
        lo = 0
    if hi > M - 1:
        hi = M - 1
    if lo > M - 2:
        lo = M - 2
    if hi <= lo:
        hi = lo + 1
    return lo, hi


@njit(cache=True)
def local_scan(C, lo, hi, px, py, pz):
    """Nearest point on segments ``lo..hi-1``, followed on past the window's ends while it comes nearer.

    When the nearest point of the window is one of its two ends (a point
    that has run ahead of, or fallen behind, where it was looked for), the
    search goes on along the centerline a window at a time in that direction
    until it stops coming nearer: the nearest point is then a true local
    minimum of the distance along the centerline, on the stretch the search
    started from (never across a loop, which would first have to come nearer
    and then go away again). Returns (squared distance, segment, t).
    """
    M = C.shape[0]
    best, bk, bt = segment_scan(C, lo, hi, px, py, pz)
    step = hi - lo
    if step < 1:
        step = 1
    while bk == lo and bt == 0.0 and lo > 0:
        nlo = lo - step
        if nlo < 0:
            nlo = 0
        b2, k2, t2 = segment_scan(C, nlo, lo, px, py, pz)
        lo = nlo
        if b2 < best:
            best = b2
            bk = k2
            bt = t2
        else:
            break
    while bk == hi - 1 and bt == 1.0 and hi < M - 1:
        nhi = hi + step
        if nhi > M - 1:
            nhi = M - 1
        b2, k2, t2 = segment_scan(C, hi, nhi, px, py, pz)
        hi = nhi
        if b2 < best:
            best = b2
            bk = k2
            bt = t2
        else:
            break
    return best, bk, bt


@njit(cache=True)
def global_scan(C, BC, BR, px, py, pz, best):
    """Nearest point on the whole centerline if nearer than ``sqrt(best)``: (squared distance, segment, t).

    Blocks of :data:`BLOCK` segments whose bounding sphere (``BC``, ``BR``)
    lies farther than the best so far are skipped. Segment -1 when nothing
    nearer was found.
    """
    bk = -1
    bt = 0.0
    nseg = C.shape[0] - 1
    for j in range(BC.shape[0]):
        dx, dy, dz = px - BC[j, 0], py - BC[j, 1], pz - BC[j, 2]
        gap = math.sqrt(dx * dx + dy * dy + dz * dz) - BR[j]
        if gap > 0.0 and gap * gap >= best:
            continue
        lo = j * BLOCK
        hi = lo + BLOCK
        if hi > nseg:
            hi = nseg
        b2, k2, t2 = segment_scan(C, lo, hi, px, py, pz)
        if b2 < best:
            best = b2
            bk = k2
            bt = t2
    return best, bk, bt


@njit(cache=True)
def _apart(C, S, ka, ta, kb, tb, px, py, pz):
    """Whether tube positions ka+ta and kb+tb are different passes of a loop, seen from the point p."""
    ax = C[ka, 0] + ta * (C[ka + 1, 0] - C[ka, 0])
    ay = C[ka, 1] + ta * (C[ka + 1, 1] - C[ka, 1])
    az = C[ka, 2] + ta * (C[ka + 1, 2] - C[ka, 2])
    bx = C[kb, 0] + tb * (C[kb + 1, 0] - C[kb, 0])
    by = C[kb, 1] + tb * (C[kb + 1, 1] - C[kb, 1])
    bz = C[kb, 2] + tb * (C[kb + 1, 2] - C[kb, 2])
    arc = abs(S[kb] + tb * (S[kb + 1] - S[kb]) - S[ka] - ta * (S[ka + 1] - S[ka]))
    chord = math.sqrt((ax - bx) ** 2 + (ay - by) ** 2 + (az - bz) ** 2)
    da = math.sqrt((ax - px) ** 2 + (ay - py) ** 2 + (az - pz) ** 2)
    db = math.sqrt((bx - px) ** 2 + (by - py) ** 2 + (bz - pz) ** 2)
    return arc > LOOP_RATIO * (chord + da + db)


@njit(cache=True)
def locate_kernel(C, R, S, BC, BR, radius, lo, hi, ze, px, py, pz, out):
    """Where a point is in the lumen: its nearest centerline point, searched from the window ``lo..hi``.

    First :func:`local_scan`, then the whole centerline is searched
    (:func:`global_scan`, which skips what lies farther than the local
    result, so it costs little) for a nearer stretch. It is taken unless the two stretches are different
    passes of a loop (the centerline between the two nearest points is longer
    than :data:`LOOP_RATIO` times their straight distance plus the point's
    distance to each) with the point outside its own stretch's lumen: two
    passes of a loop are kept apart by the wall between them, except where
    their lumens overlap (the point inside both: the one with more room
    counts). The nearer stretch is also taken when it is not apart from where
    the point is expected (``ze``, a tube position). A point outside its own
    stretch's lumen and inside another pass of a loop has crossed the wall:
    it is scored in the lumen it is in now, and flagged (the robot left the
    lumen it was in). out = (distance, lumen radius, tube position, flag).
    """
    best, bk, bt = local_scan(C, lo, hi, px, py, pz)
    d = math.sqrt(best)
    r = R[bk] + bt * (R[bk + 1] - R[bk])
    pos = bk + bt
    flag = 0.0
    gk = -1
    if r - radius - d <= GLOBAL_BELOW:
        gb, gk, gt = global_scan(C, BC, BR, px, py, pz, best)
    if gk >= 0:
        dg = math.sqrt(gb)
        rg = R[gk] + gt * (R[gk + 1] - R[gk])
        M = C.shape[0]
        e = min(max(ze, 0.0), M - 1.0)
        ke = min(int(math.floor(e)), M - 2)
        if (not _apart(C, S, bk, bt, gk, gt, px, py, pz) or not _apart(C, S, ke, e - ke, gk, gt, px, py, pz)
                or (d <= r and rg - dg >= r - d)):
            d = dg
            r = rg
            pos = gk + gt
        elif d > r and dg < rg:  # out of its own lumen and into another pass's: it crossed the wall
            d = dg
            r = rg
            pos = gk + gt
            flag = 1.0
    out[0] = d
    out[1] = r
    out[2] = pos
    out[3] = flag


@njit(cache=True)
def _clear_at(C, R, S, BC, BR, w, radius, ax, ay, az, bx, by, bz, za, zb, ea, eb, t, out):
    """Clearance at fraction ``t`` along the segment a->b whose ends were found at tube positions za, zb and are
    expected at tube positions ea, eb."""
    px = ax + t * (bx - ax)
    py = ay + t * (by - ay)
    pz = az + t * (bz - az)
    lo, hi = search_window(C.shape[0], za + t * (zb - za), w)
    locate_kernel(C, R, S, BC, BR, radius, lo, hi, ea + t * (eb - ea), px, py, pz, out)
    return out[1] - radius - out[0]


@njit(cache=True)
def clearance_chain_kernel(C, R, S, BC, BR, pre, w, radius, Q, E, Z, sample, pt_out, mod_out, where, found):
    """Clearance of one pose: points ``Q`` (K, 3) in chain order, point ``k`` expected at trajectory index ``E[k]``.

    A point (or a sample along a module) expected before the path's start
    (index < 0) is not scored (NaN). ``Z`` (K) are the centres of the points'
    search windows (tube indices); a sample along a module is searched around
    the interpolation of where its ends were found (or of their window
    centres, for an end not scored). Writes each point's clearance into
    ``pt_out`` (K), where its nearest centerline point is into ``found`` (K,
    tube index), each module's smallest clearance into ``mod_out`` (K-1) and
    where along the module it is into ``where`` (K-1, 3). Returns 1.0 when
    some point or sample crossed into another loop (:func:`locate_kernel`),
    else 0.0.
    """
    K = Q.shape[0]
    M = C.shape[0]
    res = np.empty(4)
    crossed = 0.0
    for k in range(K):
        if E[k] < 0.0:
            pt_out[k] = np.nan
            found[k] = np.nan
        else:
            lo, hi = search_window(M, Z[k], w)
            locate_kernel(C, R, S, BC, BR, radius, lo, hi, E[k] + pre, Q[k, 0], Q[k, 1], Q[k, 2], res)
            pt_out[k] = res[1] - radius - res[0]
            found[k] = res[2]
            if res[3] > crossed:
                crossed = res[3]
    for m in range(K - 1):
        ax, ay, az = Q[m, 0], Q[m, 1], Q[m, 2]
        bx, by, bz = Q[m + 1, 0], Q[m + 1, 1], Q[m + 1, 2]
        ea, eb = E[m], E[m + 1]
        ta = Z[m] if ea < 0.0 else found[m]
        tb = Z[m + 1] if eb < 0.0 else found[m + 1]
        L = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2)
        ns = int(math.ceil(L / sample))
        if ns < 1:
            ns = 1
        # the scored part of the module: [lo_t, hi_t]
        lo_t = 0.0
        hi_t = 1.0
        if ea < 0.0 and eb < 0.0:
            lo_t = 2.0
        elif ea < 0.0:
            lo_t = -ea / (eb - ea)
        elif eb < 0.0:
            hi_t = ea / (ea - eb)
        best = 1e300
        bt = -1.0
        for q in range(ns + 1):
            t = q / ns
            if t < lo_t or t > hi_t:
                continue
            v = _clear_at(C, R, S, BC, BR, w, radius, ax, ay, az, bx, by, bz, ta, tb, ea + pre, eb + pre, t, res)
            if res[3] > crossed:
                crossed = res[3]
            if v < best:
                best = v
                bt = t
        if bt < 0.0:
            mod_out[m] = np.nan
            where[m, 0] = np.nan
            where[m, 1] = np.nan
            where[m, 2] = np.nan
            continue
        # golden-section refinement between the worst sample's neighbours (scored part only)
        a = max(bt - 1.0 / ns, lo_t)
        b = min(bt + 1.0 / ns, hi_t)
        x1 = b - _GOLD * (b - a)
        x2 = a + _GOLD * (b - a)
        f1 = _clear_at(C, R, S, BC, BR, w, radius, ax, ay, az, bx, by, bz, ta, tb, ea + pre, eb + pre, x1, res)
        f2 = _clear_at(C, R, S, BC, BR, w, radius, ax, ay, az, bx, by, bz, ta, tb, ea + pre, eb + pre, x2, res)
        for _ in range(REFINE_ITERS):
            if f1 < f2:
                b = x2
                x2 = x1
                f2 = f1
                x1 = b - _GOLD * (b - a)
                f1 = _clear_at(C, R, S, BC, BR, w, radius, ax, ay, az, bx, by, bz, ta, tb, ea + pre, eb + pre, x1, res)
            else:
                a = x1
                x1 = x2
                f1 = f2
                x2 = a + _GOLD * (b - a)
                f2 = _clear_at(C, R, S, BC, BR, w, radius, ax, ay, az, bx, by, bz, ta, tb, ea + pre, eb + pre, x2, res)
        if f1 < best:
            best = f1
            bt = x1
        if f2 < best:
            best = f2
            bt = x2
        mod_out[m] = best
        where[m, 0] = ax + bt * (bx - ax)
        where[m, 1] = ay + bt * (by - ay)
        where[m, 2] = az + bt * (bz - az)
    return crossed


@njit(cache=True)
def _run_kernel(C, R, S, BC, BR, pre, w, radius, Q, E, adv, sample, pt_out, mod_out, where, lost):
    K = Q.shape[1]
    trk = np.full(K, np.nan)
    Z = np.empty(K)
    found = np.full(K, np.nan)
    for i in range(Q.shape[0]):
        for k in range(K):
            if E[i, k] >= 0.0 and not math.isnan(trk[k]):
                Z[k] = trk[k] + adv
            else:
                Z[k] = E[i, k] + pre
        lost[i] = clearance_chain_kernel(C, R, S, BC, BR, pre, w, radius, Q[i], E[i], Z, sample, pt_out[i], mod_out[i],
                                         where[i], found)
        for k in range(K):
            trk[k] = found[k] if E[i, k] >= 0.0 else np.nan


def clearance_run_all(tube: Tube, radius: float, Q: np.ndarray, E: np.ndarray, sample: float = SAMPLE_MM,
                      advance: float = 1.0):
    """:func:`clearance_run` and, per step, whether some point crossed into another loop (N,) bool."""
    Q = np.ascontiguousarray(Q, dtype=np.float64)
    E = np.ascontiguousarray(E, dtype=np.float64)
    N, K = E.shape
    pt = np.empty((N, K))
    mod = np.empty((N, max(K - 1, 0)))
    where = np.empty((N, max(K - 1, 0), 3))
    lost = np.zeros(N)
    S, BC, BR = tube.search_arrays()
    _run_kernel(tube.points, tube.radius, S, BC, BR, float(tube.pre), float(tube.window), float(radius), Q, E,
                float(advance), float(sample), pt, mod, where, lost)
    return pt, mod, where, lost > 0.0


def clearance_run(tube: Tube, radius: float, Q: np.ndarray, E: np.ndarray, sample: float = SAMPLE_MM,
                  advance: float = 1.0):
    """Clearance of every pose of a run (compiled).

    ``Q`` (N, K, 3) are the robot's points at each step in chain order (tail
    to tip), ``E`` (N, K) the trajectory index each is expected at (the one it
    is scored against; may be negative). A point's nearest centerline point
    is searched within the window around where it was found at the step
    before, moved on by ``advance`` (the feed in centerline points); the
    first time a point is scored, around its expected point; the search
    recovers when the point has strayed (:func:`locate_kernel`). Returns
    (points (N, K), modules (N, K-1), where each module's smallest clearance
    is (N, K-1, 3)), NaN where nothing is scored.
    """
    pt, mod, where, _ = clearance_run_all(tube, radius, Q, E, sample, advance)
    return pt, mod, where


# ---------------------------------------------------------------------------
# readable reference (numpy), held equal to the kernels by the tests


def point_clearance(tube: Tube, radius: float, p: np.ndarray, expected: float, centre: float | None = None,
                    ) -> float:
    """Clearance of one point ``p`` (module doc), with numpy, searched in the window only.

    The window is centred on tube index ``centre``, by default the point's
    expected trajectory index ``expected``.
    """
    return nearest_numpy(tube, radius, p, expected + tube.pre if centre is None else centre)[0]


def _scan_numpy(C: np.ndarray, lo: int, hi: int, p: np.ndarray) -> tuple[float, int, float]:
    a, b = C[lo:hi], C[lo + 1:hi + 1]
    u = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, u) / np.einsum("ij,ij->i", u, u), 0.0, 1.0)
    d2 = ((p - (a + t[:, None] * u)) ** 2).sum(axis=1)
    k = int(np.argmin(d2))  # the first of equally near segments
    return float(d2[k]), lo + k, float(t[k])


def _window_numpy(M: int, centre: float, w: float) -> tuple[int, int]:
    lo = min(max(int(math.floor(centre - w)), 0), M - 2)
    hi = min(int(math.ceil(centre + w)), M - 1)
    return lo, (lo + 1 if hi <= lo else hi)


def nearest_numpy(tube: Tube, radius: float, p: np.ndarray, centre: float) -> tuple[float, float]:
    """(clearance, tube position) of ``p``'s nearest point within the window around ``centre`` (no recovery)."""
    C, R = tube.points, tube.radius
    lo, hi = _window_numpy(C.shape[0], centre, tube.window)
    d2, k, t = _scan_numpy(C, lo, hi, p)
    r = R[k] + t * (R[k + 1] - R[k])
    return float(r - radius - math.sqrt(d2)), float(k + t)


def locate_numpy(tube: Tube, radius: float, p: np.ndarray, centre: float, expected: float | None = None
                 ) -> tuple[float, float, bool]:
    """(clearance, tube position, crossed into another loop) of ``p``: :func:`locate_kernel` in numpy.

    ``centre`` is the local window's centre, ``expected`` (default: ``centre``) where the point is expected,
    both tube positions.
    """
    C, R = tube.points, tube.radius
    S = tube.search_arrays()[0]
    M = C.shape[0]
    lo, hi = _window_numpy(M, centre, tube.window)
    best, bk, bt = _scan_numpy(C, lo, hi, p)
    step = max(hi - lo, 1)
    while bk == lo and bt == 0.0 and lo > 0:  # the nearest point is the window's first end: look further back
        nlo = max(lo - step, 0)
        b2, k2, t2 = _scan_numpy(C, nlo, lo, p)
        lo = nlo
        if not b2 < best:
            break
        best, bk, bt = b2, k2, t2
    while bk == hi - 1 and bt == 1.0 and hi < M - 1:  # ... its last end: look further on
        nhi = min(hi + step, M - 1)
        b2, k2, t2 = _scan_numpy(C, hi, nhi, p)
        hi = nhi
        if not b2 < best:
            break
        best, bk, bt = b2, k2, t2

    def at(k: int, t: float) -> tuple[float, float, np.ndarray]:
        return float(R[k] + t * (R[k + 1] - R[k])), float(S[k] + t * (S[k + 1] - S[k])), C[k] + t * (C[k + 1] - C[k])

    d = math.sqrt(best)
    r, s, c = at(bk, bt)
    pos = bk + bt
    crossed = False
    def apart(a: tuple[float, float, np.ndarray], b: tuple[float, float, np.ndarray]) -> bool:
        return abs(a[1] - b[1]) > LOOP_RATIO * float(np.linalg.norm(a[2] - b[2]) + np.linalg.norm(p - a[2])
                                                     + np.linalg.norm(p - b[2]))

    gb, gk, gt = _scan_numpy(C, 0, M - 1, p)  # is some other stretch nearer?
    if r - radius - d <= GLOBAL_BELOW and gb < best:
        dg = math.sqrt(gb)
        rg, sg, cg = at(gk, gt)
        e = min(max(centre if expected is None else expected, 0.0), M - 1.0)
        ke = min(int(math.floor(e)), M - 2)
        if (not apart((r, s, c), (rg, sg, cg)) or not apart(at(ke, e - ke), (rg, sg, cg))
                or (d <= r and rg - dg >= r - d)):
            d, r, pos = dg, rg, gk + gt
        elif d > r and dg < rg:  # out of its own lumen and into another pass's: it crossed the wall
            d, r, pos, crossed = dg, rg, gk + gt, True
    return r - radius - d, pos, crossed


def clearance_run_numpy(tube: Tube, radius: float, Q: np.ndarray, E: np.ndarray, sample: float = SAMPLE_MM,
                        advance: float = 1.0, lost: np.ndarray | None = None):
    """The same as :func:`clearance_run`, step by step in numpy (the reference).

    ``lost`` (N,), if given, gets :func:`clearance_run_all`'s crossed flags.
    """
    N, K = E.shape
    pt = np.full((N, K), np.nan)
    mod = np.full((N, max(K - 1, 0)), np.nan)
    where = np.full((N, max(K - 1, 0), 3), np.nan)
    trk = np.full(K, np.nan)
    for i in range(N):
        crossed = False
        Z = np.where((E[i] >= 0) & ~np.isnan(trk), trk + advance, E[i] + tube.pre)
        for k in range(K):
            if E[i, k] >= 0:
                pt[i, k], trk[k], c = locate_numpy(tube, radius, Q[i, k], Z[k], E[i, k] + tube.pre)
                crossed |= c
            else:
                trk[k] = np.nan
        for m in range(K - 1):
            a, b, ea, eb = Q[i, m], Q[i, m + 1], E[i, m], E[i, m + 1]
            za = Z[m] if ea < 0 else trk[m]
            zb = Z[m + 1] if eb < 0 else trk[m + 1]
            flags: list[bool] = []

            def at(t: float, a=a, b=b, za=za, zb=zb, ea=ea, eb=eb, flags=flags) -> float:
                c, _, x = locate_numpy(tube, radius, a + t * (b - a), za + t * (zb - za),
                                       ea + t * (eb - ea) + tube.pre)
                flags.append(x)
                return c

            ns = max(int(math.ceil(float(np.linalg.norm(b - a)) / sample)), 1)
            lo_t, hi_t = 0.0, 1.0
            if ea < 0 and eb < 0:
                continue
            if ea < 0:
                lo_t = -ea / (eb - ea)
            elif eb < 0:
                hi_t = ea / (ea - eb)
            ts = [q / ns for q in range(ns + 1) if lo_t <= q / ns <= hi_t]
            if not ts:
                continue
            vals = [at(t) for t in ts]
            j = int(np.argmin(vals))
            best, bt = vals[j], ts[j]
            lo, hi = max(bt - 1.0 / ns, lo_t), min(bt + 1.0 / ns, hi_t)
            x1, x2 = hi - _GOLD * (hi - lo), lo + _GOLD * (hi - lo)
            f1, f2 = at(x1), at(x2)
            for _ in range(REFINE_ITERS):
                if f1 < f2:
                    hi, x2, f2 = x2, x1, f1
                    x1 = hi - _GOLD * (hi - lo)
                    f1 = at(x1)
                else:
                    lo, x1, f1 = x1, x2, f2
                    x2 = lo + _GOLD * (hi - lo)
                    f2 = at(x2)
            for x, fx in ((x1, f1), (x2, f2)):
                if fx < best:
                    best, bt = fx, x
            mod[i, m] = best
            where[i, m] = a + bt * (b - a)
            crossed |= any(flags)
        if lost is not None:
            lost[i] = crossed
    return pt, mod, where


def brute_force_clearance(path: np.ndarray, lumen: np.ndarray, radius: float, points: np.ndarray) -> np.ndarray:
    """Clearance of ``points`` (..., 3) against the whole centerline, its end closed: the independent check.

    Every segment of ``path`` is searched (no window, no tracking, no
    extension past either end): lumen radius at the nearest point - robot
    radius - distance. Slow; for tests and checks.
    """
    P = np.asarray(path, dtype=np.float64)
    rad = np.asarray(lumen, dtype=np.float64)[:P.shape[0]] / 2.0
    a, u = P[:-1], np.diff(P, axis=0)
    uu = np.einsum("ij,ij->i", u, u)
    flat = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.empty(flat.shape[0])
    for j, p in enumerate(flat):
        t = np.clip(np.einsum("ij,ij->i", p - a, u) / uu, 0.0, 1.0)
        d2 = ((p - (a + t[:, None] * u)) ** 2).sum(axis=1)
        k = int(np.argmin(d2))
        out[j] = rad[k] + t[k] * (rad[k + 1] - rad[k]) - radius - math.sqrt(float(d2[k]))
    return out.reshape(np.asarray(points).shape[:-1])


# ---------------------------------------------------------------------------
# a run's clearance


@dataclass
class ClearanceReport:
    """Geometric clearance of every scored point and module at every step, and where it is smallest.

    Points are listed head base to tip, then body points 1..B; modules head
    module 1 (base) to n (tip), then body modules 1..B (body module 1 right
    behind the head).
    """

    table: np.ndarray  # (N, P) mm per point, NaN where not scored
    labels: list[str]  # name of each of the P points
    min_mm: float  # smallest clearance over points and modules (NaN if nothing was scored)
    min_step: int  # 1-based step of the smallest clearance (0 if none)
    min_point: str  # which point or module
    touch_steps: list[int] = field(default_factory=list)  # 1-based steps where some point or module touches
    module_table: np.ndarray | None = None  # (N, Mo) mm per module: smallest along it
    module_labels: list[str] = field(default_factory=list)
    module_where: np.ndarray | None = None  # (N, Mo, 3) where along each module its clearance is smallest
    contact_length: list[float] = field(default_factory=list)  # mm of path travelled in contact, per module
    index_matched_min_mm: float = float("nan")  # the clearance from each point's own trajectory point
    left_lumen_step: int | None = None  # 1-based first step where the robot left the lumen (None: it never did)
    left_lumen_reason: str = ""  # why, in words
    lumen_end: str = "closed"  # how the lumen ends past the last centerline point: "closed" (a cap) or "open"

    @property
    def per_step(self) -> np.ndarray:
        """(N,) smallest clearance at each step, points and modules (NaN where nothing is scored)."""
        both = self.table if self.module_table is None else np.concatenate([self.table, self.module_table], axis=1)
        out = np.full(both.shape[0], np.nan)
        ok = ~np.all(np.isnan(both), axis=1)
        out[ok] = np.nanmin(both[ok], axis=1)
        return out

    @property
    def max_penetration_mm(self) -> float:
        """How deep the robot's surface went into the wall (0 if it never touched)."""
        return 0.0 if np.isnan(self.min_mm) else max(0.0, -float(self.min_mm))

    def touches(self) -> list[tuple[int, int]]:
        """(step, point index) of every point touching the wall, steps 1-based."""
        with np.errstate(invalid="ignore"):
            s, p = np.nonzero(self.table <= 0.0)
        return [(int(a) + 1, int(b)) for a, b in zip(s, p)]

    def contacts(self) -> np.ndarray:
        """(K, 3) where the robot touched the wall: each touching module's deepest spot, at every step."""
        if self.module_table is None or self.module_where is None:
            return np.zeros((0, 3))
        with np.errstate(invalid="ignore"):
            hit = self.module_table <= 0.0
        return self.module_where[hit]

    def summary(self) -> dict:
        return {"min_clearance_mm": None if np.isnan(self.min_mm) else float(self.min_mm),
                "min_clearance_step": int(self.min_step), "min_clearance_point": self.min_point,
                "max_penetration_mm": float(self.max_penetration_mm),
                "wall_touch_steps": list(self.touch_steps),
                "contact_length_mm": [float(v) for v in self.contact_length],
                "contact_modules": list(self.module_labels),
                "index_matched_min_clearance_mm": None if np.isnan(self.index_matched_min_mm)
                else float(self.index_matched_min_mm),
                "left_lumen_step": self.left_lumen_step, "left_lumen_reason": self.left_lumen_reason or None,
                "lumen_end": self.lumen_end}


def clearance_table(point_errors: np.ndarray, offsets: np.ndarray, lumen: np.ndarray, radius: float) -> np.ndarray:
    """(N, P) *index-matched* clearance in mm of points scored ``offsets[p]`` steps behind each step's target.

    ``point_errors`` (N, P) are the distances to those trajectory points,
    ``lumen`` the diameter at each trajectory point: lumen radius - robot
    radius - that distance. NaN where the point's trajectory point does not
    exist (before the start). Kept for ``index_matched_min_clearance_mm``;
    the geometric clearance is :func:`clearance_report`'s.
    """
    pe = np.asarray(point_errors, dtype=np.float64)
    lum = np.asarray(lumen, dtype=np.float64)
    N = pe.shape[0]
    if lum.ndim != 1 or lum.shape[0] < N:
        raise BhrError(f"the lumen has {lum.shape[0] if lum.ndim == 1 else lum.shape} diameters for {N} steps; "
                       "give one diameter per trajectory point")
    idx = np.arange(N)[:, None] - np.asarray(offsets, dtype=np.int64)[None, :]
    ok = idx >= 0
    table = np.full(pe.shape, np.nan)
    table[ok] = lum[idx[ok]] / 2.0 - radius - pe[ok]
    return table


def run_chain(result) -> tuple[np.ndarray, np.ndarray, int]:
    """The whole robot of a run in chain order (tail to tip) and each point's expected trajectory index.

    Returns (Q (N, K, 3), E (N, K), B) with B the body modules; chain index
    ``B + j`` is head point ``j``, chain index ``B - k`` body point ``k``.
    """
    r = result.robot
    n, f = r.modules, r.feed_divisor
    N = result.steps
    head = result.points
    body = getattr(result, "body", None)
    B = body.modules if body is not None else 0
    steps = np.arange(N, dtype=np.float64)[:, None]
    e_head = steps - (n - np.arange(n + 1))[None, :] * f
    if body is not None and B:
        Q = np.concatenate([body.points[:, ::-1], head], axis=1)
        e_body = steps - (n + np.arange(1, B + 1))[None, :] * f
        E = np.concatenate([e_body[:, ::-1], e_head], axis=1)
    else:
        Q, E = head, e_head
    return np.ascontiguousarray(Q, dtype=np.float64), np.ascontiguousarray(E, dtype=np.float64), B


def lumen_end_of(trajectory) -> str:
    """How a trajectory's lumen ends past its last point: ``"closed"`` (a blind end, the default) or ``"open"``.

    ``trajectory`` is a :class:`bhr.model.path.Trajectory` (its ``lumen_end``) or the word itself.
    """
    end = trajectory if isinstance(trajectory, str) else (getattr(trajectory, "lumen_end", None) or "closed")
    if end not in LUMEN_ENDS:
        raise BhrError(f"lumen end must be one of {', '.join(LUMEN_ENDS)}, got {end!r}")
    return str(end)


def left_lumen(per_step: np.ndarray, lost: np.ndarray, radius: float, where: Callable[[int], str] | None = None
               ) -> tuple[int | None, str]:
    """(1-based first step where the robot left the lumen or None, the reason in words).

    The robot has left the lumen when some point or module of it is outside
    the tube by more than its own radius (clearance below minus the robot's
    radius: its axis is outside the wall), or when a point crossed the wall
    into another loop of the lumen (``lost``: the tracking is lost).
    """
    with np.errstate(invalid="ignore"):
        deep = per_step < -float(radius)
    hit = np.nonzero(deep | np.asarray(lost, dtype=bool))[0]
    if hit.size == 0:
        return None, ""
    i = int(hit[0])
    name = where(i) if where is not None else ""
    who = f" ({name})" if name else ""
    if deep[i]:
        return i + 1, (f"left the lumen at step {i + 1}: {-float(per_step[i]):.1f} mm into the wall{who}, more than "
                       f"the robot's radius ({float(radius):g} mm)")
    return i + 1, f"left the lumen at step {i + 1}: a point crossed the wall into another loop of the lumen{who}"


def robot_labels(n: int, body: int) -> tuple[list[str], list[str]]:
    """Names of a robot's points and modules in the clearance's tables: the head's n+1 points and n modules (base
    and tip named), then the ``body`` modules behind it."""
    labels = [f"point {j + 1}" + (" (base)" if j == 0 else "") + (" (tip)" if j == n else "") for j in range(n + 1)]
    labels += [f"body point {k}" for k in range(1, body + 1)]
    mlabels = [f"module {j + 1}" + (" (base)" if j == 0 else "") + (" (tip)" if j == n - 1 else "")
               for j in range(n)]
    mlabels += [f"body module {k}" for k in range(1, body + 1)]
    return labels, mlabels


def clearance_report(result, window_mm: float = WINDOW_MM, sample_mm: float = SAMPLE_MM,
                     lumen_end: str | None = None) -> ClearanceReport | None:
    """The geometric clearance of a run (:class:`bhr.run.driver.FollowResult`) whose trajectory has a lumen, else None.

    ``lumen_end`` (default: the trajectory's, else ``"closed"``) says whether
    the lumen is capped at the last centerline point (``"closed"``: past it is
    wall) or continues straight (``"open"``). The entrance is always open.
    """
    tr = result.trajectory
    if tr.lumen is None:
        return None
    end = lumen_end_of(tr if lumen_end is None else lumen_end)
    r = result.robot
    n, f = r.modules, r.feed_divisor
    tube = make_tube(tr.points, tr.lumen, tr.start_direction, window_mm, closed_end=end == "closed")
    Q, E, B = run_chain(result)
    pt, mod, where, lost = clearance_run_all(tube, r.radius, Q, E, sample_mm, float(r.feed) / tube.spacing)
    # reorder: points head 0..n then body 1..B; modules head 1..n then body 1..B
    p_order = list(range(B, B + n + 1)) + list(range(B - 1, -1, -1))
    m_order = list(range(B, B + n)) + list(range(B - 1, -1, -1))
    table, mtable, mwhere = pt[:, p_order], mod[:, m_order], where[:, m_order]
    labels, mlabels = robot_labels(n, B)
    # the old, index-matched figure
    offsets = [(n - j) * f for j in range(n + 1)]
    errors = result.point_errors
    if B:
        offsets += [(n + k) * f for k in range(1, B + 1)]
        errors = np.concatenate([errors, body_errors(result)], axis=1)
    im = clearance_table(errors, np.array(offsets), tr.lumen, r.radius)
    im_min = float(np.nanmin(im)) if not np.all(np.isnan(im)) else float("nan")
    with np.errstate(invalid="ignore"):
        mtouch = mtable <= 0.0
        touch = np.nonzero(np.any(table <= 0.0, axis=1) | np.any(mtouch, axis=1))[0]
    contact = (np.sum(mtouch, axis=0) * float(r.feed)).tolist()
    both = np.concatenate([table, mtable], axis=1)
    if np.all(np.isnan(both)):
        return ClearanceReport(table, labels, float("nan"), 0, "", [], mtable, mlabels, mwhere, contact, im_min,
                               lumen_end=end)
    flat = int(np.nanargmin(both))
    s, p = divmod(flat, both.shape[1])
    # name the point if a point is as low as the worst module (a module's minimum at its end is the point)
    row_pts = table[s]
    if not np.all(np.isnan(row_pts)) and np.nanmin(row_pts) <= both[s, p]:
        p = int(np.nanargmin(row_pts))
    name = (labels + mlabels)[p]
    rep = ClearanceReport(table, labels, float(both[s, p]), s + 1, name, [int(t) + 1 for t in touch], mtable,
                          mlabels, mwhere, contact, im_min, lumen_end=end)

    def worst_at(i: int) -> str:
        return "" if np.all(np.isnan(both[i])) else (labels + mlabels)[int(np.nanargmin(both[i]))]

    rep.left_lumen_step, rep.left_lumen_reason = left_lumen(rep.per_step, lost, r.radius, worst_at)
    return rep


def body_errors(result) -> np.ndarray:
    """(N, B) the body points' errors as scored (distance to their own trajectory point)."""
    return result.body.point_errors


def step_ranges(steps: list[int]) -> str:
    """``[3, 4, 5, 9]`` -> ``"3-5, 9"`` for printing."""
    if not steps:
        return "none"
    out = []
    start = prev = steps[0]
    for s in steps[1:]:
        if s == prev + 1:
            prev = s
            continue
        out.append(f"{start}-{prev}" if prev > start else f"{start}")
        start = prev = s
    out.append(f"{start}-{prev}" if prev > start else f"{start}")
    return ", ".join(out)
