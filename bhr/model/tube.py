"""The lumen as a tube, and the nearest-point search along its centerline (model layer).

A trajectory may carry the lumen's inner diameter at each point
(:attr:`bhr.model.generators.Trajectory.lumen`). The lumen is then a tube:
the trajectory is its centerline and the diameter varies linearly between
points. This module holds that tube (:class:`Tube`, :func:`make_tube`) and the
compiled kernels that find a point's nearest centerline point: within a
window of arc length (:func:`segment_scan`, :func:`search_window`,
:func:`scan_from`), followed on past the window's ends
(:func:`local_scan`), and over the whole centerline when a point reads as
touching the wall (:func:`global_scan`, :func:`locate_kernel`); with their
numpy references (:func:`nearest_numpy`, :func:`locate_numpy`). The solvers
(:mod:`bhr.solvers.lumen`) plan against it and the runs are scored with it
(:mod:`bhr.run.clearance`, which re-exports these names; docs/lumen.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from bhr._numba import njit

from bhr.settings.errors import BhrError

__all__ = ["Tube", "make_tube", "segment_scan", "nearest_kernel", "search_window", "scan_from", "local_scan",
           "global_scan", "locate_kernel", "point_clearance", "nearest_numpy", "locate_numpy", "lumen_end_of",
           "Segments", "windows_batch", "locate_batch", "WINDOW_MM", "LUMEN_ENDS", "GLOBAL_BELOW", "BLOCK",
           "LOOP_RATIO"]

#: Half-width (mm of arc length) of the stretch of centerline searched for a point's nearest point.
WINDOW_MM = 40.0
#: How a lumen may end past its last centerline point: capped (a blind end, the default) or continuing straight.
LUMEN_ENDS = ("closed", "open")
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
    M = C.shape[0]
    best, bk, bt = segment_scan(C, lo, hi, px, py, pz)
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
        cand = segment_scan(C, lo, hi, px, py, pz)
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


# ---------------------------------------------------------------------------
# readable reference (numpy)


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


# ---------------------------------------------------------------------------
# many points at once (numpy, vectorised): the kernels' results bit for bit, with nothing to compile

#: Largest number of (point, segment) pairs one vectorised scan holds in memory at once.
_BATCH_PAIRS = 1 << 18


class Segments:
    """A tube's centerline segments as :func:`segment_scan` sees them, for :func:`locate_batch`.

    Each segment's start ``(ax, ay, az)`` and direction ``(ux, uy, uz)``, ``uu`` its squared length: the same
    float64 values the kernel computes, so that the vectorised search gives the kernel's results exactly.
    """

    def __init__(self, C: np.ndarray, R: np.ndarray, S: np.ndarray, BC: np.ndarray, BR: np.ndarray) -> None:
        self.C, self.R, self.S, self.BC, self.BR = C, R, S, BC, BR
        self.M = C.shape[0]
        self.ax, self.ay, self.az = C[:-1, 0].copy(), C[:-1, 1].copy(), C[:-1, 2].copy()
        self.ux, self.uy, self.uz = C[1:, 0] - self.ax, C[1:, 1] - self.ay, C[1:, 2] - self.az
        self.uu = self.ux * self.ux + self.uy * self.uy + self.uz * self.uz

    def scan(self, lo: np.ndarray, hi: np.ndarray, px: np.ndarray, py: np.ndarray, pz: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`segment_scan` of point ``i`` over segments ``lo[i]..hi[i]-1``: (squared distance, segment, t)."""
        B = lo.shape[0]
        best = np.full(B, 1e300)
        bk = lo.astype(np.int64)
        bt = np.zeros(B)
        if B == 0:
            return best, bk, bt
        W = int(np.max(hi - lo))
        if W <= 0:
            return best, bk, bt
        rows = max(1, _BATCH_PAIRS // W)
        for s in range(0, B, rows):
            e = min(B, s + rows)
            d2, k, t = self.pairs(lo[s:e], hi[s:e], px[s:e], py[s:e], pz[s:e], W)
            j = np.argmin(d2, axis=1)  # the first of equally near segments
            r = np.arange(e - s)
            hit = d2[r, j] < np.inf
            best[s:e] = np.where(hit, d2[r, j], 1e300)
            bk[s:e] = np.where(hit, k[r, j], bk[s:e])
            bt[s:e] = np.where(hit, t[r, j], 0.0)
        return best, bk, bt

    def pairs(self, lo, hi, px, py, pz, W: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(squared distance, segment, t) of point ``i`` to segments ``lo[i] + j`` for j < W: (B, W) arrays.

        :func:`segment_scan`'s arithmetic; infinite where the segment is past ``hi[i] - 1`` or the distance is
        not below 1e300 (the kernel takes a segment only below that).
        """
        k = lo[:, None] + np.arange(W, dtype=np.int64)
        valid = k < hi[:, None]
        k = np.minimum(k, self.M - 2)
        ax, ay, az = self.ax[k], self.ay[k], self.az[k]
        ux, uy, uz, uu = self.ux[k], self.uy[k], self.uz[k], self.uu[k]
        qx, qy, qz = px[:, None], py[:, None], pz[:, None]
        dot = (qx - ax) * ux + (qy - ay) * uy + (qz - az) * uz
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(dot <= 0.0, 0.0, np.where(dot >= uu, 1.0, np.minimum(dot / uu, 1.0)))
        dx, dy, dz = qx - (ax + t * ux), qy - (ay + t * uy), qz - (az + t * uz)
        d2 = dx * dx + dy * dy + dz * dz
        return np.where(valid & (d2 < 1e300), d2, np.inf), k, t

    def scan_blocks(self, best: np.ndarray, px: np.ndarray, py: np.ndarray, pz: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`global_scan` of many points: (squared distance, segment or -1, t), nearer than ``best`` only.

        Scans the blocks whose bounding sphere is nearer than the best so far: every block the kernel scans,
        and some it skips because a block before had found a nearer point (whose segments, the sphere being
        padded, are all farther than that point: the same segment wins, the first of equally near ones).
        """
        B = best.shape[0]
        BC, BR = self.BC, self.BR
        rows = max(1, _BATCH_PAIRS // (BLOCK * max(1, BC.shape[0])))
        if B > rows:  # a bounded share of memory at a time
            parts = [self.scan_blocks(best[s:s + rows], px[s:s + rows], py[s:s + rows], pz[s:s + rows])
                     for s in range(0, B, rows)]
            return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                    np.concatenate([p[2] for p in parts]))
        dx, dy, dz = px[:, None] - BC[:, 0], py[:, None] - BC[:, 1], pz[:, None] - BC[:, 2]
        centre = np.sqrt(dx * dx + dy * dy + dz * dz)
        gap = centre - BR
        # the nearest point is no farther than the nearest point of the block nearest to the point's sphere
        # test: blocks whose sphere lies beyond that hold only farther points (the spheres are padded by 1e-9 mm,
        # far more than the rounding), so they need no scan either
        nseg = self.M - 1
        near = np.argmin(gap, axis=1) * BLOCK
        d2, _, _ = self.pairs(near, np.minimum(near + BLOCK, nseg), px, py, pz, BLOCK)
        bound = np.minimum(best, np.min(d2, axis=1))
        pi, bj = np.nonzero(~((gap > 0.0) & (gap * gap >= bound[:, None])))  # by point, then by block
        out_b, out_k, out_t = best.copy(), np.full(B, -1, dtype=np.int64), np.zeros(B)
        if pi.size == 0:
            return out_b, out_k, out_t
        lo = bj * BLOCK
        d2, k, t = self.pairs(lo, np.minimum(lo + BLOCK, nseg), px[pi], py[pi], pz[pi], BLOCK)
        # the first of the smallest per point, over its blocks in order
        d2, k, t = d2.ravel(), k.ravel(), t.ravel()
        owner = np.repeat(pi, BLOCK)
        starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
        who = owner[starts]
        low = np.minimum.reduceat(d2, starts)
        group = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, d2.size]))
        first = np.minimum.reduceat(np.where(d2 == low[group], np.arange(d2.size), d2.size), starts)
        hit = low < best[who]
        who, first = who[hit], first[hit]
        out_b[who], out_k[who], out_t[who] = d2[first], k[first], t[first]
        return out_b, out_k, out_t

    def at(self, k: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The centerline point at tube positions k + t, as :func:`_apart` computes it."""
        C = self.C
        return (C[k, 0] + t * (C[k + 1, 0] - C[k, 0]), C[k, 1] + t * (C[k + 1, 1] - C[k, 1]),
                C[k, 2] + t * (C[k + 1, 2] - C[k, 2]))

    def apart(self, ka, ta, kb, tb, px, py, pz) -> np.ndarray:
        """:func:`_apart` for many pairs of tube positions and points."""
        S = self.S
        ax, ay, az = self.at(ka, ta)
        bx, by, bz = self.at(kb, tb)
        arc = np.abs(S[kb] + tb * (S[kb + 1] - S[kb]) - S[ka] - ta * (S[ka + 1] - S[ka]))
        chord = np.sqrt((ax - bx) * (ax - bx) + (ay - by) * (ay - by) + (az - bz) * (az - bz))
        da = np.sqrt((ax - px) * (ax - px) + (ay - py) * (ay - py) + (az - pz) * (az - pz))
        db = np.sqrt((bx - px) * (bx - px) + (by - py) * (by - py) + (bz - pz) * (bz - pz))
        return arc > LOOP_RATIO * (chord + da + db)


def windows_batch(M: int, e: np.ndarray, w: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`search_window` for many window centres ``e`` (finite): (lo, hi) int64 arrays."""
    lo = np.floor(e - w).astype(np.int64)
    hi = np.ceil(e + w).astype(np.int64)
    lo = np.minimum(np.maximum(lo, 0), M - 2)
    hi = np.minimum(hi, M - 1)
    return lo, np.where(hi <= lo, lo + 1, hi)


def locate_batch(seg: Segments, radius: float, lo: np.ndarray, hi: np.ndarray, ze: np.ndarray, px: np.ndarray,
                 py: np.ndarray, pz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`locate_kernel` for many points (finite coordinates) at once: (distance, radius, position, flag).

    The same float64 operations as the kernel, vectorised: the results are the kernel's bit for bit (tests hold
    them so). The whole-centerline search looks at every segment instead of skipping the blocks that cannot hold
    a nearer point; a skipped block's segments are all farther than the best so far (its bounding sphere is
    padded), so the same segment wins.
    """
    M = seg.M
    best, bk, bt = seg.scan(lo, hi, px, py, pz)
    lo, hi = lo.copy(), hi.copy()
    step = np.maximum(hi - lo, 1)
    # followed on past the window's start while it comes nearer (local_scan), then past its end
    for back in (True, False):
        go = ((bk == lo) & (bt == 0.0) & (lo > 0)) if back else ((bk == hi - 1) & (bt == 1.0) & (hi < M - 1))
        idx = np.flatnonzero(go)
        while idx.size:
            if back:
                a, b = np.maximum(lo[idx] - step[idx], 0), lo[idx]
                lo[idx] = a
            else:
                a, b = hi[idx], np.minimum(hi[idx] + step[idx], M - 1)
                hi[idx] = b
            b2, k2, t2 = seg.scan(a, b, px[idx], py[idx], pz[idx])
            better = b2 < best[idx]
            idx = idx[better]
            best[idx], bk[idx], bt[idx] = b2[better], k2[better], t2[better]
            if back:
                idx = idx[(bk[idx] == lo[idx]) & (bt[idx] == 0.0) & (lo[idx] > 0)]
            else:
                idx = idx[(bk[idx] == hi[idx] - 1) & (bt[idx] == 1.0) & (hi[idx] < M - 1)]
    R = seg.R
    d = np.sqrt(best)
    r = R[bk] + bt * (R[bk + 1] - R[bk])
    pos = bk + bt
    flag = np.zeros(best.shape[0])
    g = np.flatnonzero(r - radius - d <= GLOBAL_BELOW)
    if g.size:
        gb, gk, gt = seg.scan_blocks(best[g], px[g], py[g], pz[g])
        nearer = gb < best[g]
        g, gb, gk, gt = g[nearer], gb[nearer], gk[nearer], gt[nearer]
    if g.size:
        dg = np.sqrt(gb)
        rg = R[gk] + gt * (R[gk + 1] - R[gk])
        e = np.minimum(np.maximum(ze[g], 0.0), M - 1.0)
        ke = np.minimum(np.floor(e).astype(np.int64), M - 2)
        qx, qy, qz = px[g], py[g], pz[g]
        dl, rl = d[g], r[g]
        take = (~seg.apart(bk[g], bt[g], gk, gt, qx, qy, qz) | ~seg.apart(ke, e - ke, gk, gt, qx, qy, qz)
                | ((dl <= rl) & (rg - dg >= rl - dl)))
        crossed = ~take & (dl > rl) & (dg < rg)
        moved = take | crossed
        g, dg, rg, gk, gt = g[moved], dg[moved], rg[moved], gk[moved], gt[moved]
        d[g], r[g], pos[g] = dg, rg, gk + gt
        flag[g] = crossed[moved].astype(np.float64)
    return d, r, pos, flag


def lumen_end_of(trajectory) -> str:
    """How a trajectory's lumen ends past its last point: ``"closed"`` (a blind end, the default) or ``"open"``.

    ``trajectory`` is a :class:`bhr.model.path.Trajectory` (its ``lumen_end``) or the word itself.
    """
    end = trajectory if isinstance(trajectory, str) else (getattr(trajectory, "lumen_end", None) or "closed")
    if end not in LUMEN_ENDS:
        raise BhrError(f"lumen end must be one of {', '.join(LUMEN_ENDS)}, got {end!r}")
    return str(end)
