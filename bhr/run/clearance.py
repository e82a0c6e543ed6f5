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

import numpy as np
from numba import njit

from bhr.settings.errors import BhrError

__all__ = ["ClearanceReport", "Tube", "make_tube", "clearance_table", "clearance_report", "clearance_run",
           "clearance_run_numpy", "point_clearance", "run_chain", "step_ranges", "WINDOW_MM", "SAMPLE_MM"]

#: Half-width (mm of arc length) of the stretch of centerline searched for a point's nearest point.
WINDOW_MM = 40.0
#: Largest spacing (mm) of the samples along a module.
SAMPLE_MM = 1.0
#: Golden-section iterations refining the worst sample of a module.
REFINE_ITERS = 20
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0


@dataclass
class Tube:
    """The lumen as a tube: its centerline extended straight past both ends, and the radius at each point.

    ``points[k]`` is trajectory point ``k - pre``; the ``pre`` points before
    the start continue the path backwards along its start direction, the
    ``post`` after the end forwards along its last direction, both with the
    end's radius. ``window`` is the search half-width in points.
    """

    points: np.ndarray  # (M, 3)
    radius: np.ndarray  # (M,) mm
    pre: int
    post: int
    window: float  # points
    spacing: float = 1.0  # mm between centerline points (median)


def make_tube(path: np.ndarray, lumen: np.ndarray, start_direction=None, window_mm: float = WINDOW_MM) -> Tube:
    """The :class:`Tube` of a trajectory whose points are ``path`` and lumen diameters ``lumen``."""
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
    d0 = P[1] - P[0] if start_direction is None else np.asarray(start_direction, dtype=np.float64)
    d0 = d0 / np.linalg.norm(d0)
    d1 = (P[-1] - P[-2]) / np.linalg.norm(P[-1] - P[-2])
    before = P[0] - spacing * np.arange(pad, 0, -1)[:, None] * d0
    after = P[-1] + spacing * np.arange(1, pad + 1)[:, None] * d1
    pts = np.ascontiguousarray(np.vstack([before, P, after]))
    rad = np.concatenate([np.full(pad, lum[0]), lum[:N], np.full(pad, lum[N - 1])]) / 2.0
    return Tube(pts, np.ascontiguousarray(rad), pad, pad, float(w), spacing)


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
def _window(M, e, w):
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
def _clear_at(C, R, w, radius, ax, ay, az, bx, by, bz, ea, eb, t):
    """Clearance at fraction ``t`` along the segment a->b whose ends are expected at tube indices ea, eb."""
    px = ax + t * (bx - ax)
    py = ay + t * (by - ay)
    pz = az + t * (bz - az)
    lo, hi = _window(C.shape[0], ea + t * (eb - ea), w)
    d, r, _ = nearest_kernel(C, R, lo, hi, px, py, pz)
    return r - radius - d


@njit(cache=True)
def clearance_chain_kernel(C, R, pre, w, radius, Q, E, Z, sample, pt_out, mod_out, where, found):
    """Clearance of one pose: points ``Q`` (K, 3) in chain order, point ``k`` expected at trajectory index ``E[k]``.

    A point (or a sample along a module) expected before the path's start
    (index < 0) is not scored (NaN). ``Z`` (K) are the centres of the points'
    search windows (tube indices); a sample along a module is searched around
    the interpolation of its ends'. Writes each point's clearance into
    ``pt_out`` (K), where its nearest centerline point is into ``found`` (K,
    tube index), each module's smallest clearance into ``mod_out`` (K-1) and
    where along the module it is into ``where`` (K-1, 3).
    """
    K = Q.shape[0]
    M = C.shape[0]
    for k in range(K):
        if E[k] < 0.0:
            pt_out[k] = np.nan
        else:
            lo, hi = _window(M, Z[k], w)
            d, r, pos = nearest_kernel(C, R, lo, hi, Q[k, 0], Q[k, 1], Q[k, 2])
            pt_out[k] = r - radius - d
            found[k] = pos
    for m in range(K - 1):
        ax, ay, az = Q[m, 0], Q[m, 1], Q[m, 2]
        bx, by, bz = Q[m + 1, 0], Q[m + 1, 1], Q[m + 1, 2]
        ea, eb = E[m], E[m + 1]
        ta, tb = Z[m], Z[m + 1]
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
            v = _clear_at(C, R, w, radius, ax, ay, az, bx, by, bz, ta, tb, t)
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
        f1 = _clear_at(C, R, w, radius, ax, ay, az, bx, by, bz, ta, tb, x1)
        f2 = _clear_at(C, R, w, radius, ax, ay, az, bx, by, bz, ta, tb, x2)
        for _ in range(REFINE_ITERS):
            if f1 < f2:
                b = x2
                x2 = x1
                f2 = f1
                x1 = b - _GOLD * (b - a)
                f1 = _clear_at(C, R, w, radius, ax, ay, az, bx, by, bz, ta, tb, x1)
            else:
                a = x1
                x1 = x2
                f1 = f2
                x2 = a + _GOLD * (b - a)
                f2 = _clear_at(C, R, w, radius, ax, ay, az, bx, by, bz, ta, tb, x2)
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


@njit(cache=True)
def _run_kernel(C, R, pre, w, radius, Q, E, adv, sample, pt_out, mod_out, where):
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
        clearance_chain_kernel(C, R, pre, w, radius, Q[i], E[i], Z, sample, pt_out[i], mod_out[i], where[i], found)
        for k in range(K):
            trk[k] = found[k] if E[i, k] >= 0.0 else np.nan


def clearance_run(tube: Tube, radius: float, Q: np.ndarray, E: np.ndarray, sample: float = SAMPLE_MM,
                  advance: float = 1.0):
    """Clearance of every pose of a run (compiled).

    ``Q`` (N, K, 3) are the robot's points at each step in chain order (tail
    to tip), ``E`` (N, K) the trajectory index each is expected at (the one it
    is scored against; may be negative). A point's nearest centerline point
    is searched within the window around where it was found at the step
    before, moved on by ``advance`` (the feed in centerline points); the
    first time a point is scored, around its expected point. Returns (points (N, K), modules
    (N, K-1), where each module's smallest clearance is (N, K-1, 3)), NaN
    where nothing is scored.
    """
    Q = np.ascontiguousarray(Q, dtype=np.float64)
    E = np.ascontiguousarray(E, dtype=np.float64)
    N, K = E.shape
    pt = np.empty((N, K))
    mod = np.empty((N, max(K - 1, 0)))
    where = np.empty((N, max(K - 1, 0), 3))
    _run_kernel(tube.points, tube.radius, float(tube.pre), float(tube.window), float(radius), Q, E, float(advance),
                float(sample), pt, mod, where)
    return pt, mod, where


# ---------------------------------------------------------------------------
# readable reference (numpy), held equal to the kernels by the tests


def point_clearance(tube: Tube, radius: float, p: np.ndarray, expected: float, centre: float | None = None,
                    ) -> float:
    """Clearance of one point ``p`` (module doc), with numpy.

    The window is centred on tube index ``centre``, by default the point's
    expected trajectory index ``expected``.
    """
    return _nearest_numpy(tube, radius, p, expected + tube.pre if centre is None else centre)[0]


def _nearest_numpy(tube: Tube, radius: float, p: np.ndarray, centre: float) -> tuple[float, float]:
    C, R = tube.points, tube.radius
    lo = min(max(int(math.floor(centre - tube.window)), 0), C.shape[0] - 2)
    hi = min(int(math.ceil(centre + tube.window)), C.shape[0] - 1)
    if hi <= lo:
        hi = lo + 1
    a, b = C[lo:hi], C[lo + 1:hi + 1]
    u = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, u) / np.einsum("ij,ij->i", u, u), 0.0, 1.0)
    d = np.linalg.norm(p - (a + t[:, None] * u), axis=1)
    k = int(np.argmin(d))  # the first of equally near segments
    r = R[lo + k] + t[k] * (R[lo + k + 1] - R[lo + k])
    return float(r - radius - d[k]), float(lo + k + t[k])


def clearance_run_numpy(tube: Tube, radius: float, Q: np.ndarray, E: np.ndarray, sample: float = SAMPLE_MM,
                        advance: float = 1.0):
    """The same as :func:`clearance_run`, step by step in numpy (the reference)."""
    N, K = E.shape
    pt = np.full((N, K), np.nan)
    mod = np.full((N, max(K - 1, 0)), np.nan)
    where = np.full((N, max(K - 1, 0), 3), np.nan)
    trk = np.full(K, np.nan)
    for i in range(N):
        Z = np.where((E[i] >= 0) & ~np.isnan(trk), trk + advance, E[i] + tube.pre)
        for k in range(K):
            if E[i, k] >= 0:
                pt[i, k], trk[k] = _nearest_numpy(tube, radius, Q[i, k], Z[k])
            else:
                trk[k] = np.nan
        for m in range(K - 1):
            a, b, ea, eb = Q[i, m], Q[i, m + 1], E[i, m], E[i, m + 1]
            za, zb = Z[m], Z[m + 1]

            def at(t: float, a=a, b=b, za=za, zb=zb) -> float:
                return _nearest_numpy(tube, radius, a + t * (b - a), za + t * (zb - za))[0]

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
    return pt, mod, where


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
                else float(self.index_matched_min_mm)}


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


def clearance_report(result, window_mm: float = WINDOW_MM, sample_mm: float = SAMPLE_MM) -> ClearanceReport | None:
    """The geometric clearance of a run (:class:`bhr.run.driver.FollowResult`) whose trajectory has a lumen, else
    None."""
    tr = result.trajectory
    if tr.lumen is None:
        return None
    r = result.robot
    n, f = r.modules, r.feed_divisor
    tube = make_tube(tr.points, tr.lumen, tr.start_direction, window_mm)
    Q, E, B = run_chain(result)
    pt, mod, where = clearance_run(tube, r.radius, Q, E, sample_mm, float(r.feed) / tube.spacing)
    # reorder: points head 0..n then body 1..B; modules head 1..n then body 1..B
    p_order = list(range(B, B + n + 1)) + list(range(B - 1, -1, -1))
    m_order = list(range(B, B + n)) + list(range(B - 1, -1, -1))
    table, mtable, mwhere = pt[:, p_order], mod[:, m_order], where[:, m_order]
    labels = [f"point {j + 1}" + (" (base)" if j == 0 else "") + (" (tip)" if j == n else "") for j in range(n + 1)]
    labels += [f"body point {k}" for k in range(1, B + 1)]
    mlabels = [f"module {j + 1}" + (" (base)" if j == 0 else "") + (" (tip)" if j == n - 1 else "")
               for j in range(n)]
    mlabels += [f"body module {k}" for k in range(1, B + 1)]
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
        return ClearanceReport(table, labels, float("nan"), 0, "", [], mtable, mlabels, mwhere, contact, im_min)
    flat = int(np.nanargmin(both))
    s, p = divmod(flat, both.shape[1])
    # name the point if a point is as low as the worst module (a module's minimum at its end is the point)
    row_pts = table[s]
    if not np.all(np.isnan(row_pts)) and np.nanmin(row_pts) <= both[s, p]:
        p = int(np.nanargmin(row_pts))
    name = (labels + mlabels)[p]
    return ClearanceReport(table, labels, float(both[s, p]), s + 1, name, [int(t) + 1 for t in touch], mtable,
                           mlabels, mwhere, contact, im_min)


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
