"""The lumen as a tube, and the nearest-point search along its centerline (model layer).

A trajectory may carry the lumen's inner diameter at each point
(:attr:`bhr.model._generators.Trajectory.lumen`). The lumen is then a tube:
the trajectory is its centerline and the diameter varies linearly between
points. This module holds that tube (:class:`Tube`, :func:`make_tube`) and the
compiled kernels that find a point's nearest centerline point: within a
window of arc length (:func:`segment_scan`, :func:`search_window`,
:func:`scan_from`), followed on past the window's ends
(:func:`local_scan`), and over the whole centerline when a point reads as
touching the wall (:func:`global_scan`, :func:`locate_kernel`); with their
numpy references (:func:`nearest_numpy`, :func:`locate_numpy`). The solvers
(:mod:`bhr.solvers._lumen`) plan against it and the runs are scored with it
(:mod:`bhr._run.clearance`, which re-exports these names; docs/lumen.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from bhr._kinematics.polyline import median_spacing, segment_direction
from bhr._settings.errors import BhrError

__all__ = ["Tube", "make_tube", "segment_scan", "nearest_kernel", "search_window", "scan_from", "local_scan",
           "local_scan_from", "window_scan", "past_the_window", "search_arrays",
           "global_scan", "locate_kernel", "locate_inline",
           "mitre_normals", "scan_numpy", "point_clearance", "nearest_numpy", "locate_numpy", "lumen_end_of",
           "scored_span", "WINDOW_MM", "LUMEN_ENDS", "GLOBAL_BELOW", "BLOCK", "GROUP", "LOOP_RATIO"]

#: Half-width (mm of arc length) of the stretch of centerline searched for a point's nearest point.
WINDOW_MM = 40.0
#: How a lumen may end past its last centerline point: capped (a blind end, the default) or continuing straight.
LUMEN_ENDS = ("closed", "open")
#: The whole centerline is searched for a nearer stretch when a point's local clearance is at most this (mm).
GLOBAL_BELOW = 0.0
#: Segments of centerline per block of the global search (each block is bounded by a sphere).
BLOCK = 16
#: Segments per group of the local search (each bounded by a sphere; GROUP divides BLOCK).
GROUP = 4
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
    (the global search skips the blocks that cannot hold a nearer point),
    then each run of :data:`GROUP` segments (the local search's bounds).
    """

    points: np.ndarray  # (M, 3)
    radius: np.ndarray  # (M,) mm
    pre: int
    post: int
    window: float  # points
    spacing: float = 1.0  # mm between centerline points (median)
    arc: np.ndarray | None = None  # (M,) mm
    block_centre: np.ndarray | None = None  # (ceil((M-1)/BLOCK) + ceil((M-1)/GROUP), 3)
    block_radius: np.ndarray | None = None  # (ceil((M-1)/BLOCK) + ceil((M-1)/GROUP),)
    mitre: np.ndarray | None = None  # (M, 3): :func:`mitre_normals`

    @property
    def closed(self) -> bool:
        """True when the lumen ends in a cap at the last centerline point (a blind end)."""
        return self.post == 0

    def search_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(arc, block_centre, block_radius), computed once if the tube was built without them."""
        if self.arc is None or self.block_centre is None or self.block_radius is None:
            self.arc, self.block_centre, self.block_radius = search_arrays(self.points)
        return self.arc, self.block_centre, self.block_radius

    def mitre_normals(self) -> np.ndarray:
        """:func:`mitre_normals` of the centerline, computed once."""
        if self.mitre is None:
            self.mitre = mitre_normals(self.points)
        return self.mitre


def mitre_normals(pts: np.ndarray) -> np.ndarray:
    """(M, 3): at each inner vertex of the polyline ``pts`` (M, 3) the normal of its mitre plane, the sum of the unit
    directions of the segments before and after it (every point of that plane is as far from the one segment's
    line as from the other's); zero at both ends, near zero where the line turns back on itself, and the other
    segment's direction beside a segment of no length."""
    P = np.ascontiguousarray(pts, dtype=np.float64)
    out = np.zeros((P.shape[0], 3))
    _mitre_kernel(P, out)
    return out


@njit(cache=True)
def _mitre_kernel(P, out):
    """:func:`mitre_normals` into ``out`` (zeroed): the unit directions of the segments on either side, summed."""
    for v in range(1, P.shape[0] - 1):
        ax, ay, az, _ = segment_direction(P, v - 1)
        bx, by, bz, _ = segment_direction(P, v)
        out[v, 0] = ax + bx
        out[v, 1] = ay + by
        out[v, 2] = az + bz


def _spheres(pts: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Bounding spheres (centres, radii) of the runs of ``size`` segments of the polyline ``pts``."""
    n = (pts.shape[0] - 1 + size - 1) // size
    centre = np.empty((n, 3))
    rad = np.empty(n)
    _spheres_kernel(np.ascontiguousarray(pts, dtype=np.float64), size, centre, rad)
    return centre, rad


@njit(cache=True)
def scored_span(ea, eb):
    """The scored part [lo_t, hi_t] of a segment whose ends are expected at path positions ``ea``, ``eb``: the part
    expected before the path's start (position < 0, the robot still behind the lumen's entrance) is not scored;
    ``lo_t`` = 2.0 when none of it is."""
    if ea < 0.0 and eb < 0.0:
        return 2.0, 1.0
    if ea < 0.0:
        return -ea / (eb - ea), 1.0
    if eb < 0.0:
        return 0.0, ea / (ea - eb)
    return 0.0, 1.0


@njit(cache=True)
def _spheres_kernel(pts, size, centre, rad):
    """Run ``j``'s points ``pts[j*size .. min(j*size + size, M-1)]``: the middle of their bounding box, and the
    largest distance from it, widened by a relative 1e-12 and 1e-9 mm (a bound however it rounds)."""
    nseg = pts.shape[0] - 1
    for j in range(centre.shape[0]):
        a = j * size
        b = min(a + size, nseg)
        for d in range(3):
            lo = pts[a, d]
            hi = pts[a, d]
            for k in range(a + 1, b + 1):
                lo = min(lo, pts[k, d])
                hi = max(hi, pts[k, d])
            centre[j, d] = 0.5 * (lo + hi)
        r2 = 0.0
        for k in range(a, b + 1):
            dx, dy, dz = pts[k, 0] - centre[j, 0], pts[k, 1] - centre[j, 1], pts[k, 2] - centre[j, 2]
            r2 = max(r2, dx * dx + dy * dy + dz * dz)
        rad[j] = math.sqrt(r2) * (1.0 + 1e-12) + 1e-9


def search_arrays(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(arc, centres, radii): the spheres of the blocks of BLOCK segments, then of the groups of GROUP segments."""
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    bc, br = _spheres(pts, BLOCK)
    gc, gr = _spheres(pts, GROUP)
    return (np.ascontiguousarray(arc), np.ascontiguousarray(np.concatenate([bc, gc])),
            np.ascontiguousarray(np.concatenate([br, gr])))


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
    spacing = float(median_spacing(P))
    if spacing <= 0:
        raise BhrError("the lumen's centerline has repeated points; remove the duplicates")
    w = window_mm / spacing
    pad = int(math.ceil(w)) + 2
    post = 0 if closed_end else pad
    d0 = P[1] - P[0] if start_direction is None else np.asarray(start_direction, dtype=np.float64)
    d0 = d0 / np.linalg.norm(d0)
    d1 = (P[-1] - P[-2]) / np.linalg.norm(P[-1] - P[-2])
    pts = np.empty((pad + N + post, 3))
    rad = np.empty(pad + N + post)
    arc = np.empty(pad + N + post)
    _tube_kernel(P, np.ascontiguousarray(lum[:N]), spacing, d0, d1, pad, post, pts, rad, arc)
    bc, br = _spheres(pts, BLOCK)
    gc, gr = _spheres(pts, GROUP)
    return Tube(pts, rad, pad, post, float(w), spacing, arc, np.concatenate([bc, gc]), np.concatenate([br, gr]))


@njit(cache=True)
def _tube_kernel(P, lum, spacing, d0, d1, pad, post, pts, rad, arc):
    """:func:`make_tube`'s centerline ``pts`` (``pad`` points straight back from the first along ``d0``, the path,
    ``post`` points on past the last along ``d1``), its radii ``rad`` (the end diameters carried on, halved) and the
    arc length ``arc`` at each point, as :func:`search_arrays` sums it."""
    N = P.shape[0]
    for j in range(pad):
        s = spacing * float(pad - j)
        for c in range(3):
            pts[j, c] = P[0, c] - s * d0[c]
        rad[j] = lum[0] / 2.0
    for i in range(N):
        for c in range(3):
            pts[pad + i, c] = P[i, c]
        rad[pad + i] = lum[i] / 2.0
    for j in range(post):
        s = spacing * float(j + 1)
        for c in range(3):
            pts[pad + N + j, c] = P[N - 1, c] + s * d1[c]
        rad[pad + N + j] = lum[N - 1] / 2.0
    arc[0] = 0.0
    for k in range(pts.shape[0] - 1):
        arc[k + 1] = arc[k] + segment_direction(pts, k)[3]


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
        dot = (px - ax) * ux + (py - ay) * uy + (pz - az) * uz
        if dot <= 0.0:  # the division only where it decides: the same t (clamped to 0..1) with less work
            t = 0.0
        elif dot >= uu:
            t = 1.0
        else:
            t = dot / uu
            if t > 1.0:
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


@njit(cache=True, inline="always")
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


@njit(cache=True, inline="always")
def scan_from(C, lo, hi, g, px, py, pz, step):
    """Nearest point on segments ``lo..hi-1``, scanning from segment ``g`` outwards while it improves.

    The five segments around ``g`` first; then, while the nearest point is on
    the first (last) segment scanned, ``step`` more segments behind (ahead),
    as long as they hold a nearer point. Cheaper than a whole window when a
    good guess is known (the solvers' searches). Returns (squared distance,
    segment, t).
    """
    g = min(max(g, lo), hi - 1)
    a = max(lo, g - 2)
    b = min(hi, g + 3)
    best, bk, bt = segment_scan(C, a, b, px, py, pz)
    for side in range(2):  # behind the scanned stretch, then ahead of it
        while (bk == a and a > lo) if side == 0 else (bk == b - 1 and b < hi):
            if side == 0:
                s0, s1 = max(lo, a - step), a
                a = s0
            else:
                s0, s1 = b, min(hi, b + step)
                b = s1
            d2, k, t = segment_scan(C, s0, s1, px, py, pz)
            if d2 < best:
                best, bk, bt = d2, k, t
            else:
                break
    return best, bk, bt


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
    best, bk, bt = segment_scan(C, lo, hi, px, py, pz)
    return past_the_window(C, lo, hi, best, bk, bt, px, py, pz)


# the local search is inlined into its callers (locate_kernel, the solvers): a call passing the centerline's arrays
# costs their atomic reference counts, some 30 a point located
@njit(cache=True, inline="always")
def local_scan_from(C, BC, BR, lo, hi, g, px, py, pz):
    """:func:`local_scan`, the same result, its window searched from segment ``g`` (:func:`window_scan`)."""
    best, bk, bt = window_scan(C, BC, BR, lo, hi, g, px, py, pz)
    return past_the_window(C, lo, hi, best, bk, bt, px, py, pz)


@njit(cache=True, inline="always")
def past_the_window(C, lo, hi, best, bk, bt, px, py, pz):
    """:func:`local_scan`'s search past the window's ends, from the window's nearest point (best, bk, bt)."""
    M = C.shape[0]
    step = hi - lo
    if step < 1:
        step = 1
    for back in (True, False):  # behind the window's start, then past its end
        while True:
            if back:
                if not (bk == lo and bt == 0.0 and lo > 0):
                    break
                a, b = max(lo - step, 0), lo
                lo = a
            else:
                if not (bk == hi - 1 and bt == 1.0 and hi < M - 1):
                    break
                a, b = hi, min(hi + step, M - 1)
                hi = b
            b2, k2, t2 = segment_scan(C, a, b, px, py, pz)
            if b2 < best:
                best = b2
                bk = k2
                bt = t2
            else:
                break
    return best, bk, bt



@njit(cache=True, inline="always")
def window_scan(C, BC, BR, lo, hi, g, px, py, pz):
    """:func:`segment_scan` of segments ``lo..hi-1``, bit for bit, searched from segment ``g`` (a guess) outwards.

    The segments around ``g`` first, walking on along the centerline while
    the nearest point is at an end of the stretch scanned; then the rest of
    the window, except the blocks and groups of segments whose bounding
    sphere (``BC``, ``BR``: :func:`make_tube`) lies farther than the nearest
    point found: no segment there can be as near. Among equally near
    segments the first wins, as in :func:`segment_scan`. When the guess is
    good (a point's place at the step before, a sample's neighbour along a
    module) only a few segments and spheres are looked at.
    """
    nb = (C.shape[0] - 1 + BLOCK - 1) // BLOCK
    g = min(max(g, lo), hi - 1)
    a = max(lo, g - 2)
    b = min(hi, g + 3)
    best, bk, bt = segment_scan(C, a, b, px, py, pz)
    while bk == a and a > lo:  # nearest at the stretch's start: walk back
        a2 = max(lo, a - GROUP)
        d2, k, t = segment_scan(C, a2, a, px, py, pz)
        a = a2
        if d2 <= best:  # an equally near segment before wins
            best, bk, bt = d2, k, t
        else:
            break
    while bk == b - 1 and b < hi:  # at its end: walk on
        b2 = min(hi, b + GROUP)
        d2, k, t = segment_scan(C, b, b2, px, py, pz)
        b = b2
        if d2 < best:
            best, bk, bt = d2, k, t
        else:
            break
    reach = math.sqrt(best)
    for side in range(2):  # the window's rest before the stretch, then after it
        k = lo if side == 0 else b
        end = a if side == 0 else hi
        while k < end:
            blk = k // BLOCK
            stop = min(end, (blk + 1) * BLOCK)
            if _farther(BC, BR, blk, px, py, pz, reach):
                k = stop
                continue
            while k < stop:
                grp = k // GROUP
                gstop = min(stop, (grp + 1) * GROUP)
                if not _farther(BC, BR, nb + grp, px, py, pz, reach):
                    d2, kk, t = segment_scan(C, k, gstop, px, py, pz)
                    if d2 < best or (d2 == best and kk < bk):
                        best, bk, bt = d2, kk, t
                        reach = math.sqrt(best)
                k = gstop
    return best, bk, bt


@njit(cache=True)
def _farther(BC, BR, j, px, py, pz, reach):
    """Whether every point in sphere ``j`` is farther from p than ``reach`` (strictly): no square root taken."""
    dx, dy, dz = px - BC[j, 0], py - BC[j, 1], pz - BC[j, 2]
    far = BR[j] + reach
    return dx * dx + dy * dy + dz * dz > far * far * (1.0 + 1e-12)


@njit(cache=True)
def global_scan(C, BC, BR, px, py, pz, best):
    """Nearest point on the whole centerline if nearer than ``sqrt(best)``: (squared distance, segment, t).

    Blocks of :data:`BLOCK` segments, and in the others groups of :data:`GROUP`, whose bounding sphere (``BC``,
    ``BR``) lies farther than the best so far are skipped. Segment -1 when nothing nearer was found.
    """
    bk = -1
    bt = 0.0
    nseg = C.shape[0] - 1
    nb = (nseg + BLOCK - 1) // BLOCK
    for j in range(nb):  # the blocks (the groups follow them in BC, BR)
        dx, dy, dz = px - BC[j, 0], py - BC[j, 1], pz - BC[j, 2]
        gap = math.sqrt(dx * dx + dy * dy + dz * dz) - BR[j]
        if gap > 0.0 and gap * gap >= best:
            continue
        hi = min(j * BLOCK + BLOCK, nseg)
        for k in range(j * BLOCK, hi, GROUP):  # its groups, each skipped as the blocks are
            grp = nb + k // GROUP
            dx, dy, dz = px - BC[grp, 0], py - BC[grp, 1], pz - BC[grp, 2]
            gap = math.sqrt(dx * dx + dy * dy + dz * dz) - BR[grp]
            if gap > 0.0 and gap * gap >= best:
                continue
            cand = segment_scan(C, k, min(k + GROUP, hi), px, py, pz)
            if cand[0] < best:
                best, bk, bt = cand
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
def locate_kernel(C, R, S, BC, BR, radius, lo, hi, ze, px, py, pz, out, whole=True, g=-1):
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
    lumen it was in). out = (distance, lumen radius, tube position, flag). With ``whole`` False the whole
    centerline is not searched: the point is measured against the stretch it is in (a robot that has already
    left the lumen, :func:`bhr._run.motion.score_kernel`). ``g``: a segment to search the window from (where the
    point was found before), else its middle; the result is the same, found sooner.
    """
    best, bk, bt = local_scan_from(C, BC, BR, lo, hi, (lo + hi) // 2 if g < 0 else g, px, py, pz)
    d = math.sqrt(best)
    r = R[bk] + bt * (R[bk + 1] - R[bk])
    pos = bk + bt
    flag = 0.0
    gk = -1
    if whole and r - radius - d <= GLOBAL_BELOW:
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


#: :func:`locate_kernel` inlined into its caller (no reference counting of the centerline's arrays per point;
#: under NUMBA_DISABLE_JIT both are the Python function)
locate_inline = njit(cache=True, inline="always")(getattr(locate_kernel, "py_func", locate_kernel))


# ---------------------------------------------------------------------------
# readable reference (numpy)


def point_clearance(tube: Tube, radius: float, p: np.ndarray, expected: float, centre: float | None = None,
                    ) -> float:
    """Clearance of one point ``p`` (module doc), with numpy, searched in the window only.

    The window is centred on tube index ``centre``, by default the point's
    expected trajectory index ``expected``.
    """
    return nearest_numpy(tube, radius, p, expected + tube.pre if centre is None else centre)[0]


def scan_numpy(C: np.ndarray, lo: int, hi: int, p: np.ndarray) -> tuple[float, int, float]:
    """:func:`segment_scan` in numpy: (squared distance, segment, t) of p's nearest point on segments ``lo..hi-1``."""
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
    d2, k, t = scan_numpy(C, lo, hi, p)
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
    best, bk, bt = scan_numpy(C, lo, hi, p)
    step = max(hi - lo, 1)
    while bk == lo and bt == 0.0 and lo > 0:  # the nearest point is the window's first end: look further back
        nlo = max(lo - step, 0)
        b2, k2, t2 = scan_numpy(C, nlo, lo, p)
        lo = nlo
        if not b2 < best:
            break
        best, bk, bt = b2, k2, t2
    while bk == hi - 1 and bt == 1.0 and hi < M - 1:  # ... its last end: look further on
        nhi = min(hi + step, M - 1)
        b2, k2, t2 = scan_numpy(C, hi, nhi, p)
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

    gb, gk, gt = scan_numpy(C, 0, M - 1, p)  # is some other stretch nearer?
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


def lumen_end_of(trajectory) -> str:
    """How a trajectory's lumen ends past its last point: ``"closed"`` (a blind end, the default) or ``"open"``.

    ``trajectory`` is a :class:`bhr.model._path.Trajectory` (its ``lumen_end``) or the word itself.
    """
    end = trajectory if isinstance(trajectory, str) else (getattr(trajectory, "lumen_end", None) or "closed")
    if end not in LUMEN_ENDS:
        raise BhrError(f"lumen end must be one of {', '.join(LUMEN_ENDS)}, got {end!r}")
    return str(end)
