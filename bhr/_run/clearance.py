"""Lumen clearance: how far the robot's surface stays from the wall of the lumen it follows.

A trajectory may carry the lumen's inner diameter at each point
(:attr:`bhr.model._generators.Trajectory.lumen`: a CSV ``lumen`` column, segment
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
trajectory point it is scored against in :mod:`bhr._run.driver`), so that two
loops of the colon passing close to each other are never mistaken for one
another.

Not only the points count: every module is a straight segment between two
points, and its clearance is the smallest along it. Where the module is inside
the lumen it is found exactly (:func:`module_exact_kernel`: the clearance is
concave between the module's crossings of the planes where its nearest
centerline feature changes, so the least of those crossings and the ends is
the minimum). Otherwise (touching the wall, or a centerline too tangled there)
it is sampled at most ``sample`` mm apart (both ends included) and the worst
sample refined by a golden-section search between its neighbours, which finds
the minimum to 0.01 mm wherever the clearance has one minimum between two
samples. Points
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

:func:`clearance_run` is compiled with numba; :func:`clearance_run_numpy` is
the readable reference that tests hold it equal to.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from numba import njit

from bhr._settings.errors import BhrError
from bhr.model._path import to_steps
# the tube and its nearest-point kernels live in the model layer; their names stay importable from here
from bhr.model._tube import (BLOCK, GLOBAL_BELOW, LOOP_RATIO, LUMEN_ENDS, WINDOW_MM, Tube, scan_numpy,  # noqa: F401
                            global_scan, local_scan, locate_kernel, locate_numpy, lumen_end_of,
                            make_tube, nearest_kernel, nearest_numpy, point_clearance, scored_span, search_window,
                            segment_scan)

__all__ = ["ClearanceReport", "CecumWatch", "cecum_step", "cecum_kernel", "Tube", "make_tube", "clearance_table",
           "clearance_report",
           "clearance_run", "clearance_run_all", "clearance_run_numpy", "point_clearance", "locate_numpy",
           "brute_force_clearance", "left_lumen", "lumen_end_of", "run_chain", "step_ranges", "WINDOW_MM", "SAMPLE_MM",
           "LUMEN_ENDS", "LOOP_RATIO", "BLOCK", "tables_report", "index_matched_min", "robot_labels", "wall_label"]

#: Largest spacing (mm) of the samples along a module.
SAMPLE_MM = 1.0
#: Centerline segments a module may span for its exact minimum (:func:`module_exact_kernel`); longer: sampled.
EXACT_SPAN = 64
#: Golden-section iterations refining the worst sample of a module.
REFINE_ITERS = 20
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0


# ---------------------------------------------------------------------------
# compiled kernels


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
def module_exact_kernel(C, R, N, radius, ax, ay, az, bx, by, bz, fa, fb, ca, cb, out, below):
    """The smallest clearance along module a->b, exactly, from its ends' clearances ``ca``, ``cb`` (both inside
    the lumen) and where they were found (``fa``, ``fb``, tube positions): out = (clearance, t along the module).
    ``N`` are the centerline's mitre normals (:func:`bhr.model._tube.mitre_normals`); ``below``: a crossing
    whose clearance is at most this ends the search (:data:`GLOBAL_BELOW` for a run's clearance: the wall).

    Between the module's crossings of the planes where its nearest centerline feature changes (each vertex's
    mitre plane, between the segments before and after it; where the lumen narrows into a vertex or widens out
    of it, also the plane square to the segment there) its nearest feature is one segment or one vertex. There
    the clearance is the radius, linear along the module, minus the distance, convex: it is concave, and its
    minimum lies at an end. So the module's minimum is the least of its ends and those crossings, each scored
    against the centerline between its ends' nearest segments and one more on each side (a crossing whose
    least radius there, less its distance to the vertex, cannot beat the least so far is skipped). Returns
    False (the module is then sampled, :func:`clearance_chain_kernel`) when that stretch is longer than
    :data:`EXACT_SPAN` segments, when a crossing's nearest point lies at the stretch's outer end, when the
    centerline turns back on itself there, or when a crossing touches the wall (where another pass of a loop
    may be nearer: the full search decides).
    """
    M = C.shape[0]
    ka = min(int(fa), M - 2)
    kb = min(int(fb), M - 2)
    k0 = max(min(ka, kb) - 1, 0)
    k1 = min(max(ka, kb) + 1, M - 2)
    if k1 - k0 > EXACT_SPAN:
        return False
    best = ca
    bt = 0.0
    if cb < best:
        best = cb
        bt = 1.0
    dx, dy, dz = bx - ax, by - ay, bz - az
    # every mitre plane first (kind 0), then the planes where the lumen narrows into a vertex (kind 1: the end
    # of the segment before it) or widens out of it (kind 2: the start of the segment after it)
    for step in range((k1 - k0) + 2 * (k1 - k0 + 2)):
        if step < k1 - k0:
            kind = 0
            v = k0 + 1 + step
            nx, ny, nz = N[v, 0], N[v, 1], N[v, 2]
            if nx * nx + ny * ny + nz * nz < 1e-12:  # the centerline turns back on itself here
                return False
        else:
            v = k0 + (step - (k1 - k0)) // 2
            kind = 1 + (step - (k1 - k0)) % 2
            if kind == 1 and v - 1 >= k0 and R[v] < R[v - 1]:
                nx, ny, nz = C[v, 0] - C[v - 1, 0], C[v, 1] - C[v - 1, 1], C[v, 2] - C[v - 1, 2]
            elif kind == 2 and v <= k1 and R[v + 1] > R[v]:
                nx, ny, nz = C[v + 1, 0] - C[v, 0], C[v + 1, 1] - C[v, 1], C[v + 1, 2] - C[v, 2]
            else:
                continue
        # where the module crosses that plane, and the clearance there
        den = dx * nx + dy * ny + dz * nz
        if den == 0.0:
            continue
        t = ((C[v, 0] - ax) * nx + (C[v, 1] - ay) * ny + (C[v, 2] - az) * nz) / den
        if not (0.0 < t < 1.0):
            continue
        px, py, pz = ax + t * dx, ay + t * dy, az + t * dz
        lo = max(v - 1, k0)
        hi = min(v, k1)
        gap = min(R[lo], R[v], R[hi + 1]) - radius - best
        ex, ey, ez = px - C[v, 0], py - C[v, 1], pz - C[v, 2]
        if gap >= 0.0 and ex * ex + ey * ey + ez * ez <= gap * gap:
            continue  # its least radius less its distance to v cannot beat the least so far
        # the nearest point of the segments before and after v; on a mitre plane both are equally far, and on
        # the inner side of a bend the nearest point, and the radius with it, jumps across the plane: the least
        # of the two segments' clearances is the one approached from one side
        d2, k, u = segment_scan(C, lo, lo + 1, px, py, pz)
        c = R[lo] + u * (R[lo + 1] - R[lo]) - radius - math.sqrt(d2)
        if hi != lo:
            d2b, _, ub = segment_scan(C, hi, hi + 1, px, py, pz)
            c2 = R[hi] + ub * (R[hi + 1] - R[hi]) - radius - math.sqrt(d2b)
            if kind == 0:
                c = min(c, c2)
            if d2b < d2:
                k, u = hi, ub
                if kind != 0:
                    c = c2
        if (k == lo and u == 0.0 and lo > k0) or (k == hi and u == 1.0 and hi < k1):
            # at their outer end: all of k0..k1, and not local when the nearest is at theirs
            d2, k, u = segment_scan(C, k0, k1 + 1, px, py, pz)
            c = R[k] + u * (R[k + 1] - R[k]) - radius - math.sqrt(d2)
            if (k == k0 and u == 0.0 and k0 > 0) or (k == k1 and u == 1.0 and k1 < M - 2):
                return False
        if not c > below:  # touching
            return False
        if c < best:
            best = c
            bt = t
    out[0] = best
    out[1] = bt
    return True


#: :func:`module_exact_kernel` inlined into its caller (the whole robot's score: no reference counting per module)
module_exact_inline = njit(cache=True, inline="always")(getattr(module_exact_kernel, "py_func", module_exact_kernel))


@njit(cache=True)
def clearance_chain_kernel(C, R, S, BC, BR, N, pre, w, radius, Q, E, Z, sample, pt_out, mod_out, where, found, res):
    """Clearance of one pose: points ``Q`` (K, 3) in chain order, point ``k`` expected at trajectory index ``E[k]``.

    A point (or a sample along a module) expected before the path's start
    (index < 0) is not scored (NaN). ``Z`` (K) are the centres of the points'
    search windows (tube indices); ``N`` the centerline's mitre normals. A module
    whose ends are both scored and inside the lumen gets its exact minimum
    (:func:`module_exact_kernel`); any other is sampled, and a sample is searched around
    the interpolation of where its ends were found (or of their window
    centres, for an end not scored). Writes each point's clearance into
    ``pt_out`` (K), where its nearest centerline point is into ``found`` (K,
    tube index), each module's smallest clearance into ``mod_out`` (K-1) and
    where along the module it is into ``where`` (K-1, 3). Returns 1.0 when
    some point or sample crossed into another loop (:func:`locate_kernel`),
    else 0.0. ``res`` (4,) is work space (one array for a whole run: no allocation per pose).
    """
    K = Q.shape[0]
    M = C.shape[0]
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
        if (ea >= 0.0 and eb >= 0.0 and pt_out[m] > GLOBAL_BELOW and pt_out[m + 1] > GLOBAL_BELOW
                and module_exact_kernel(C, R, N, radius, ax, ay, az, bx, by, bz, found[m], found[m + 1], pt_out[m],
                                        pt_out[m + 1], res, GLOBAL_BELOW)):
            mod_out[m] = res[0]
            where[m, 0] = ax + res[1] * (bx - ax)
            where[m, 1] = ay + res[1] * (by - ay)
            where[m, 2] = az + res[1] * (bz - az)
            continue
        ta = Z[m] if ea < 0.0 else found[m]
        tb = Z[m + 1] if eb < 0.0 else found[m + 1]
        if ea < 0.0 <= eb and pt_out[m + 1] > GLOBAL_BELOW:
            # its rear end not yet in the colon: the exact minimum of the part that is, from where it enters
            t0 = -ea / (eb - ea)
            c0 = _clear_at(C, R, S, BC, BR, w, radius, ax, ay, az, bx, by, bz, ta, tb, ea + pre, eb + pre, t0, res)
            if res[3] > crossed:
                crossed = res[3]
            px, py, pz = ax + t0 * (bx - ax), ay + t0 * (by - ay), az + t0 * (bz - az)
            if c0 > GLOBAL_BELOW and module_exact_kernel(C, R, N, radius, px, py, pz, bx, by, bz, res[2], found[m + 1],
                                                         c0, pt_out[m + 1], res, GLOBAL_BELOW):
                t = t0 + res[1] * (1.0 - t0)
                mod_out[m] = res[0]
                where[m, 0] = ax + t * (bx - ax)
                where[m, 1] = ay + t * (by - ay)
                where[m, 2] = az + t * (bz - az)
                continue
        L = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2)
        ns = int(math.ceil(L / sample))
        if ns < 1:
            ns = 1
        lo_t, hi_t = scored_span(ea, eb)  # the scored part of the module
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
def _run_kernel(C, R, S, BC, BR, N, pre, w, radius, Q, E, adv, sample, pt_out, mod_out, where, lost):
    K = Q.shape[1]
    trk = np.full(K, np.nan)
    Z = np.empty(K)
    found = np.full(K, np.nan)
    res = np.empty(4)
    for i in range(Q.shape[0]):
        for k in range(K):
            if E[i, k] >= 0.0 and not math.isnan(trk[k]):
                Z[k] = trk[k] + adv
            else:
                Z[k] = E[i, k] + pre
        lost[i] = clearance_chain_kernel(C, R, S, BC, BR, N, pre, w, radius, Q[i], E[i], Z, sample, pt_out[i],
                                         mod_out[i], where[i], found, res)
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
    _run_kernel(tube.points, tube.radius, S, BC, BR, tube.mitre_normals(), float(tube.pre), float(tube.window),
                float(radius), Q, E, float(advance), float(sample), pt, mod, where, lost)
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

            if ea >= 0 and eb >= 0 and pt[i, m] > GLOBAL_BELOW and pt[i, m + 1] > GLOBAL_BELOW:
                exact = module_exact_numpy(tube, radius, a, b, trk[m], trk[m + 1], pt[i, m], pt[i, m + 1])
                if exact is not None:
                    mod[i, m] = exact[0]
                    where[i, m] = a + exact[1] * (b - a)
                    continue
            if ea < 0 <= eb and pt[i, m + 1] > GLOBAL_BELOW:  # the part in the colon, exactly, from its entry
                t0 = -ea / (eb - ea)
                p0 = a + t0 * (b - a)
                c0, f0, into = locate_numpy(tube, radius, p0, za + t0 * (zb - za), ea + t0 * (eb - ea) + tube.pre)
                crossed |= into
                exact = None if not c0 > GLOBAL_BELOW else module_exact_numpy(tube, radius, p0, b, f0, trk[m + 1],
                                                                               c0, pt[i, m + 1])
                if exact is not None:
                    t = t0 + exact[1] * (1.0 - t0)
                    mod[i, m] = exact[0]
                    where[i, m] = a + t * (b - a)
                    continue
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


def module_exact_numpy(tube: Tube, radius: float, a: np.ndarray, b: np.ndarray, fa: float, fb: float, ca: float,
                       cb: float) -> tuple[float, float] | None:
    """:func:`module_exact_kernel` in numpy: (smallest clearance, t along the module), or None to sample it."""
    C, R = tube.points, tube.radius
    M = C.shape[0]
    ka, kb = min(int(fa), M - 2), min(int(fb), M - 2)
    k0, k1 = max(min(ka, kb) - 1, 0), min(max(ka, kb) + 1, M - 2)
    if k1 - k0 > EXACT_SPAN:
        return None

    def clear(d2: float, k: int, t: float) -> float:
        return float(R[k] + t * (R[k + 1] - R[k]) - radius - math.sqrt(d2))

    def crossing(p: np.ndarray, v: int, mitre: bool, best: float) -> float | None:
        lo, hi = max(v - 1, k0), min(v, k1)
        gap = min(R[lo], R[v], R[hi + 1]) - radius - best
        if gap >= 0.0 and float((p - C[v]) @ (p - C[v])) <= gap * gap:
            return math.inf  # its least radius less its distance to v is not below best
        pair = [(scan_numpy(C, k, k + 1, p), k) for k in sorted({lo, hi})]
        (d2, k, t), _ = min(pair, key=lambda x: x[0][0])  # the nearer, the first on a tie
        c = min(clear(*x) for x, _ in pair) if mitre else clear(d2, k, t)
        if (k == lo and t == 0.0 and lo > k0) or (k == hi and t == 1.0 and hi < k1):
            d2, k, t = scan_numpy(C, k0, k1 + 1, p)
            c = clear(d2, k, t)
            if (k == k0 and t == 0.0 and k0 > 0) or (k == k1 and t == 1.0 and k1 < M - 2):
                return None  # the nearest point may lie past the stretch
        return c

    # the planes in the kernel's order: every mitre plane, then those where the lumen narrows or widens
    planes: list[tuple[int, np.ndarray, bool]] = []
    for v in range(k0 + 1, k1 + 1):
        n = tube.mitre_normals()[v]
        if float(n @ n) < 1e-12:  # the centerline turns back on itself here
            return None
        planes.append((v, n, True))
    for v in range(k0, k1 + 2):
        if k0 <= v - 1 and R[v] < R[v - 1]:
            planes.append((v, C[v] - C[v - 1], False))
        if v <= k1 and R[v + 1] > R[v]:
            planes.append((v, C[v + 1] - C[v], False))
    best, bt = (ca, 0.0) if not cb < ca else (cb, 1.0)
    for v, n, mitre in planes:
        den = float((b - a) @ n)
        if den == 0.0:
            continue
        t = float((C[v] - a) @ n) / den
        if not 0.0 < t < 1.0:
            continue
        c = crossing(a + t * (b - a), v, mitre, best)
        if c is None or c <= GLOBAL_BELOW:
            return None
        if c < best:
            best, bt = c, t
    return best, bt


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
    step = max(1, (1 << 20) // max(1, a.shape[0]))  # points at a time: about a million point-segment pairs
    for lo in range(0, flat.shape[0], step):
        p = flat[lo:lo + step, None, :]  # (B, 1, 3) against the segments (S, 3)
        t = np.clip(np.einsum("bsj,sj->bs", p - a, u) / uu, 0.0, 1.0)
        d2 = ((p - (a + t[..., None] * u)) ** 2).sum(axis=2)
        k = np.argmin(d2, axis=1)  # the first of equally near segments
        tk = np.take_along_axis(t, k[:, None], axis=1)[:, 0]
        dk = np.take_along_axis(d2, k[:, None], axis=1)[:, 0]
        out[lo:lo + step] = rad[k] + tk * (rad[k + 1] - rad[k]) - radius - np.sqrt(dk)
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
    contact_length_mm: list[float] = field(default_factory=list)  # mm of path travelled in contact, per module
    index_matched_min_mm: float = float("nan")  # the clearance from each point's own trajectory point
    left_lumen_step: int | None = None  # 1-based first step where the robot left the lumen (None: it never did)
    left_lumen_reason: str = ""  # why, in words
    lumen_end: str = "closed"  # how the lumen ends past the last centerline point: "closed" (a cap) or "open"
    wall: str = "tube"  # what the clearance was measured against: "tube", "mesh NAME", or "tube (why not the mesh)"

    @property
    def per_step(self) -> np.ndarray:
        """(N,) smallest clearance at each step, points and modules (NaN where nothing is scored)."""
        both = self.table if self.module_table is None else np.concatenate([self.table, self.module_table], axis=1)
        return row_min(both)

    @property
    def max_penetration_mm(self) -> float:
        """How deep the robot's surface went into the wall (0 if it never touched)."""
        return 0.0 if np.isnan(self.min_mm) else max(0.0, -float(self.min_mm))

    def touches(self) -> list[tuple[int, int]]:
        """(step, point index) of every point touching the wall, steps 1-based."""
        with np.errstate(invalid="ignore"):
            s, p = np.nonzero(self.table <= 0.0)
        return [(int(a) + 1, int(b)) for a, b in zip(s, p)]

    def contacts(self, step: int | None = None) -> np.ndarray:
        """(K, 3) where the robot touched the wall: each touching module's deepest spot, at every step (or at the
        0-based ``step`` only)."""
        if self.module_table is None or self.module_where is None:
            return np.zeros((0, 3))
        table, where = self.module_table, self.module_where
        if step is not None:
            table, where = table[step:step + 1], where[step:step + 1]
        with np.errstate(invalid="ignore"):
            hit = table <= 0.0
        return where[hit]

    def summary(self) -> dict:
        return {"min_clearance_mm": None if np.isnan(self.min_mm) else float(self.min_mm),
                "min_clearance_step": int(self.min_step), "min_clearance_point": self.min_point,
                "max_penetration_mm": float(self.max_penetration_mm),
                "wall_touch_steps": list(self.touch_steps),
                "contact_length_mm": [float(v) for v in self.contact_length_mm],
                "contact_modules": list(self.module_labels),
                "index_matched_min_clearance_mm": None if np.isnan(self.index_matched_min_mm)
                else float(self.index_matched_min_mm),
                "left_lumen_step": self.left_lumen_step, "left_lumen_reason": self.left_lumen_reason or None,
                "lumen_end": self.lumen_end, "wall": self.wall}


def row_min(table: np.ndarray) -> np.ndarray:
    """(N,) the least of each row of ``table`` (N, P) that is not NaN; NaN for a row of NaNs (as ``np.nanmin``,
    without its copies and warnings)."""
    if table.shape[1] == 0:
        return np.full(table.shape[0], np.nan)
    return np.fmin.reduce(table, axis=1)


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
    table = np.full(pe.shape, np.nan)
    for p, o in enumerate(np.asarray(offsets, dtype=np.int64).tolist()):  # point p at step i: trajectory point i - o
        if o < N:
            a = max(o, 0)
            table[a:, p] = lum[a - o:N - o] / 2.0 - radius - pe[a:, p]
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
    # past the path's end (a whole robot pushed on to the cecum, FollowResult.targets) the target is the path's end
    E = np.minimum(E, float(result.trajectory.points.shape[0] - 1))
    return np.ascontiguousarray(Q, dtype=np.float64), np.ascontiguousarray(E, dtype=np.float64), B


@njit(cache=True)
def cecum_kernel(C, R, S, BC, BR, w, pos, end, direction, tips):
    """Track ``tips`` (N, 3) step by step from tube position ``pos``: (first step at the blind end or -1, position).

    Each step's nearest centerline point is searched locally, in the window around the step before's
    (:func:`locate_kernel`, as :func:`bhr.model._tube.locate_numpy` does it: never across a loop); the tip is at
    the blind end when that point is the last one and the tip is at or past its cross-section (``end``, the unit
    ``direction`` of the last segment).
    """
    M = C.shape[0]
    res = np.empty(4)
    for i in range(tips.shape[0]):
        x, y, z = tips[i, 0], tips[i, 1], tips[i, 2]
        lo, hi = search_window(M, pos, w)
        locate_kernel(C, R, S, BC, BR, 0.0, lo, hi, pos, x, y, z, res)
        pos = res[2]
        if pos >= M - 1 - 1e-9 and ((x - end[0]) * direction[0] + (y - end[1]) * direction[1]
                                    + (z - end[2]) * direction[2]) >= -1e-9:
            return i, pos
    return -1, pos


class CecumWatch:
    """Watches a tip move along a lumen with a blind end and says when it has reached the cecum.

    The tip has reached it when its nearest centerline point, tracked from step to step from the path's start
    (:func:`cecum_kernel`: never across a loop), is the path's last point and the tip is at or past that point's
    cross-section. In the thesis's model the feeder stops there (docs/locomotion.md): a robot ahead of its
    schedule is not pushed on into the wall at the blind end.
    """

    def __init__(self, tube: Tube) -> None:
        self.tube = tube
        C = tube.points
        d = C[-1] - C[-2]
        self._end = np.ascontiguousarray(C[-1])
        self._dir = d / float(np.linalg.norm(d))
        self._pos = float(tube.pre)  # the tip starts at the path's start

    def first(self, tips: np.ndarray) -> int | None:
        """Track the tip through ``tips`` (N, 3); the index of the first at or past the blind end, or None."""
        t = self.tube
        if not t.closed:
            return None
        S, BC, BR = t.search_arrays()
        i, self._pos = cecum_kernel(t.points, t.radius, S, BC, BR, float(t.window), self._pos, self._end,
                                    self._dir, np.ascontiguousarray(tips, dtype=np.float64).reshape(-1, 3))
        return None if i < 0 else int(i)

    def reached(self, tip: np.ndarray) -> bool:
        """Track the tip to its next position; True once it is at or past the blind end."""
        return self.first(tip) is not None


def cecum_step(tube: Tube, tips: np.ndarray) -> int | None:
    """0-based first step at which ``tips[i]`` has reached the blind end of ``tube`` (:class:`CecumWatch`); None
    when it never does or the lumen's end is open."""
    return CecumWatch(tube).first(tips)


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


def index_matched_min(result, body: int) -> float:
    """The smallest *index-matched* clearance of a run (:func:`clearance_table`) of the head and ``body`` body
    modules, NaN if nothing is scored: ``index_matched_min_clearance_mm``."""
    r = result.robot
    n, f = r.modules, r.feed_divisor
    offsets = [(n - j) * f for j in range(n + 1)]
    errors = result.point_errors_mm
    if body:
        offsets += [(n + k) * f for k in range(1, body + 1)]
        errors = np.concatenate([errors, body_errors(result)], axis=1)
    im = clearance_table(errors, np.array(offsets), to_steps(result.trajectory.lumen, result.steps), r.robot_radius)
    return float(np.fmin.reduce(im, axis=None)) if im.size else float("nan")  # NaN when nothing is scored


@njit(cache=True)
def _tables_kernel(both, modules, moved, per, touching):
    """One pass over a run's clearances ``both`` (N, P + Mo: points, then the last ``modules`` columns the modules):
    each step's least clearance into ``per`` (N, NaN where nothing is scored, as ``np.nanmin``), the steps each
    module touched the wall among the first ``moved`` into ``touching`` (Mo); returns (step, column) of the
    run's least clearance, the first of equals in row order (as ``np.nanargmin``), or (-1, -1) when nothing is
    scored."""
    N, W = both.shape
    best = np.nan
    bs = -1
    bp = -1
    for i in range(N):
        m = np.nan
        mp = -1
        for j in range(W):
            v = both[i, j]
            if v == v and (mp < 0 or v < m):
                m = v
                mp = j
            if j >= W - modules and i < moved and v <= 0.0:
                touching[j - (W - modules)] += 1.0
        per[i] = m
        if mp >= 0 and (bs < 0 or m < best):
            best = m
            bs = i
            bp = mp
    return bs, bp


def tables_report(table: np.ndarray, labels: list[str], mtable: np.ndarray, mlabels: list[str], mwhere: np.ndarray,
                  feed: float, im_min: float, lumen_end: str, moved: int | None = None
                  ) -> tuple[ClearanceReport, np.ndarray]:
    """The :class:`ClearanceReport` of a run's tables (points (N, P), modules (N, Mo) and where (N, Mo, 3), in
    report order), with the steps in contact, the contact length per module (``feed`` per step the robot moved:
    the first ``moved`` steps, every step by default) and the smallest clearance named; and the tables side by
    side (N, P + Mo). ``min_step`` is 0 when nothing is scored."""
    both = np.concatenate([table, mtable], axis=1)
    per = np.empty(both.shape[0])
    touching = np.zeros(mtable.shape[1])
    s, p = _tables_kernel(both, mtable.shape[1], both.shape[0] if moved is None else int(moved), per, touching)
    with np.errstate(invalid="ignore"):
        touch = np.nonzero(per <= 0.0)[0]  # a step where some point or module touches: its least clearance does
    contact = (touching * feed).tolist()
    if s < 0:
        return ClearanceReport(table, labels, float("nan"), 0, "", [], mtable, mlabels, mwhere, contact, im_min,
                               lumen_end=lumen_end), both
    # name the point if a point is as low as the worst module (a module's minimum at its end is the point)
    row_pts = table[s]
    if not np.all(np.isnan(row_pts)) and np.nanmin(row_pts) <= both[s, p]:
        p = int(np.nanargmin(row_pts))
    return ClearanceReport(table, labels, float(both[s, p]), s + 1, (labels + mlabels)[p],
                           [int(t) + 1 for t in touch], mtable, mlabels, mwhere, contact, im_min,
                           lumen_end=lumen_end), both


#: The column of a whole robot's run on a trail, read back from run.json, that holds the smallest clearance of the
#: poses it moved through between two written steps (each step's ``clearance_mm``), where lower than the step's own.
BETWEEN_STEPS = "moving between written steps"


def clearance_report(result, window_mm: float = WINDOW_MM, sample_mm: float = SAMPLE_MM,
                     lumen_end: str | None = None, mesh: bool = True,
                     between_steps: np.ndarray | None = None) -> ClearanceReport | None:
    """The geometric clearance of a run (:class:`bhr._run.driver.FollowResult`) whose trajectory has a lumen, else None.

    Where the trajectory has a surface mesh of its lumen (and ``mesh`` is true) the clearance is measured against
    that surface (:func:`bhr.model._wallmesh.wall_grid`); else, and always with ``mesh=False``, against the tube.

    ``lumen_end`` (default: the trajectory's, else ``"closed"``) says whether
    the lumen is capped at the last centerline point (``"closed"``: past it is
    wall) or continues straight (``"open"``). The entrance is always open.

    ``between_steps`` (N,) mm: a whole robot's run on a trail (moved by its wires, or the trail model's) read back
    from its run.json, whose written steps are only some of its poses: each step's smallest clearance over all its
    poses (run.json's ``clearance_mm``, NaN where none). Where it is below the written step's own, it is the
    step's clearance, named :data:`BETWEEN_STEPS`, and counts for the touches and for leaving the lumen.
    """
    tr = result.trajectory
    if tr.lumen is None:
        return None
    end = lumen_end_of(tr if lumen_end is None else lumen_end)
    r = result.robot
    n = r.modules
    Q, E, B = run_chain(result)
    grid, wall = None, "tube"
    if mesh and getattr(tr, "mesh", None):  # a surface mesh (its module, 7 kernels, loads only then)
        from bhr.model._wallmesh import wall_grid

        grid, wall = wall_grid(tr)
    if grid is not None:  # the real surface: its signed distance (docs/real_colons.md)
        from bhr.model._wallmesh import mesh_clearance_run

        pt, mod, where = mesh_clearance_run(grid, r.robot_radius, Q, E, sample_mm)
        lost = np.zeros(Q.shape[0])
    else:
        tube = getattr(result, "_tube", None)  # the run's own, when it built one (a blind end, the default window)
        if tube is None or end != "closed" or window_mm != WINDOW_MM:
            tube = make_tube(tr.points, tr.lumen, tr.start_direction, window_mm, closed_end=end == "closed")
        pt, mod, where, lost = clearance_run_all(tube, r.robot_radius, Q, E, sample_mm, float(r.feed) / tube.spacing)
    # reorder: points head 0..n then body 1..B; modules head 1..n then body 1..B (a head alone is in that order)
    table, mtable, mwhere = pt, mod, where
    if B:
        p_order = list(range(B, B + n + 1)) + list(range(B - 1, -1, -1))
        m_order = list(range(B, B + n)) + list(range(B - 1, -1, -1))
        table, mtable, mwhere = pt[:, p_order], mod[:, m_order], where[:, m_order]
    labels, mlabels = robot_labels(n, B)
    if between_steps is not None:
        floor = np.asarray(between_steps, dtype=np.float64)[:mtable.shape[0]]
        own = row_min(np.concatenate([table, mtable], axis=1))
        with np.errstate(invalid="ignore"):
            lower = (floor < own - 1e-9) | (np.isnan(own) & ~np.isnan(floor))
        mtable = np.concatenate([mtable, np.where(lower, floor, np.nan)[:, None]], axis=1)
        mwhere = np.concatenate([mwhere, np.full((mwhere.shape[0], 1, 3), np.nan)], axis=1)
        mlabels = mlabels + [BETWEEN_STEPS]
    # once the feeder has stopped at the cecum (bhr._run.driver) the robot travels no further: no contact length
    moved = result.extra.get("summary", {}).get("feeder_stop_step")
    rep, both = tables_report(table, labels, mtable, mlabels, mwhere, float(r.feed), index_matched_min(result, B),
                              end, moved)
    rep.wall = wall_label(tr, wall)
    if rep.min_step == 0:
        return rep

    def worst_at(i: int) -> str:
        return "" if np.all(np.isnan(both[i])) else (labels + mlabels)[int(np.nanargmin(both[i]))]

    rep.left_lumen_step, rep.left_lumen_reason = left_lumen(row_min(both), lost, r.robot_radius, worst_at)
    return rep


def wall_label(traj, wall: str) -> str:
    """What a run's clearance was measured against, in words: ``wall`` (:func:`bhr.model._wallmesh.wall_grid`'s
    "mesh NAME", "tube" or "tube (why)") and, for the insufflated lumen model, that it is one."""
    return wall if getattr(traj, "lumen_model", "ct") == "ct" else f"{wall}, insufflated lumen (a model)"


def body_errors(result) -> np.ndarray:
    """(N, B) the body points' errors as scored (distance to their own trajectory point)."""
    return result.body.point_errors_mm


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
