"""Wall-aware following: keep every point and module of the head inside the lumen, planning the bends ahead.

``--solver lumen`` is the exact discrete solver of :mod:`bhr.solvers._optimal`
(each module at rest or tilted by alpha about one of its local axes: codes
0, 3, 6, 12, 9) with a cost that measures the lumen instead of the distance
to the trajectory points. It needs a trajectory with a lumen (a diameter per
point: CSV ``lumen`` column, segment files, generator files).

Cost of one configuration at step ``k`` (lengths in mm)::

    J = w_wall * sum_s max(0, margin - c_s)^2      wall: steep, every sample
      + w_center * sum_s d_s^2                     centerline: weak
      + w_track * sum_j |P_j - T_j|^2              keep pace with the path: weak
      + (w_ori * 180/pi)^2 |u - t|^2               tip along the lumen
      + w_race * sum_s |p_s - Q(s*)|^2              racing line: off unless racing_weight > 0

The samples ``s`` are the base point and, on every module, its middle and its
far end; ``d_s`` is the distance from the sample to the nearest point of the
centerline and ``c_s = R - robot radius - d_s`` its clearance
(:mod:`bhr._run.clearance`), the nearest point being searched only within
``window`` mm of arc length of where the sample is expected (no aliasing
between loops). ``T_j`` is the trajectory point that point ``j`` is scored
against (bhr.follow), ``u`` the tip module's direction and ``t`` the
centerline's direction nearest the tip.
``Q(s*)`` is the point of the racing line (:mod:`bhr.model._racing`, planned
in :meth:`Lumen.prepare` when ``racing_weight`` is above 0) at the sample's
nearest centerline point: a smooth line of bounded curvature through the
lumen, which the head is pulled to instead of (or as well as) the centerline.

Exact where exhaustive: for the base module's tilt fixed, the codes of
modules 2..n are found by a depth-first branch and bound over all ``5**(n-1)``
combinations (every term is non-negative and fixed once its module is
chosen, so cutting a partial configuration whose cost reaches the best
complete one loses nothing). The base module's tilt is a steering command
(the robot advances along it), so it is planned ``lookahead`` steps ahead by
a fixed-lag beam search keeping the ``beam`` best sequences of base tilts,
each step of a sequence scored by the exact search of the other modules at
that step: that part is a heuristic (a beam, not the whole tree), which is
what lets the robot swing wide before a flexure and cut its inside. The beam
ranks its sequences first by the deepest penetration of their history (the
run is judged by it; the summed cost can prefer one deep contact to a long
shallow one), in steps of :data:`DEPTH_STEP` mm, then by their summed cost.
With ``lookahead = 0`` the solver is the exact per-step optimum over all modules.
Two shortcuts change no answer: the beam stops the search of a candidate
that it can show it will not keep (:func:`_kept_bound`), and a search
discards a module whose far end already reaches its bound before measuring
the module's middle.

The nearest-point search of the solver starts from the previous sample's
nearest point and scans outwards while it improves (capped by the window),
which is faster than the full window scan of :mod:`bhr._run.clearance`; runs are
scored by the latter. In the thesis's locomotion the body behind the head
(``--body-modules``) follows module 1's sweep (:mod:`bhr._run.body`) and is
scored, not planned. With ``locomotion="trail"`` (:mod:`bhr._run.trail`,
docs/locomotion.md) this solver plans instead the trail the whole robot
follows, clear for every module and for the motion between steps
(``trail_beam`` trails kept).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from bhr.model._racing import head_radius_mm, racing_line
from bhr.model._tube import (Tube, lumen_end_of, make_tube, nearest_numpy, point_clearance, scan_from, search_window,
                            segment_scan)
from bhr._settings.errors import BhrError
from bhr._settings.options import solver_defaults
from bhr._kinematics.frames import tilt_frame as _rot, tilt_frame_at
from bhr._kinematics.leader import advance_kernel, finish_step, stable_argsort, tip_angle
from bhr.solvers._base import Chain, FollowContext, SolveResult, register
from bhr.solvers._optimal import (CODE_OF, DEG, Optimal, beam_candidate, beam_commit, beam_keep, beam_reset, dist2,
                                 frame_of_chain, keep_best, setting_number, step_targets, write_pose)

__all__ = ["Lumen", "DEFAULTS", "head_cost", "head_search", "lumen_config_cost", "planned_line"]

#: Default settings of ``--solver lumen`` (docs/lumen.md explains each).
DEFAULTS: dict[str, Any] = solver_defaults("lumen")
#: Segments scanned at a time outwards from the guessed nearest segment while it improves.
_SCAN = 2
#: The beam ranks its members by the deepest penetration of their history in steps of this many mm, then by cost.
DEPTH_STEP = 0.5
#: The span of summed cost within one depth step of the ranking key (costs differing by more rank as this).
RANK_SPAN = 1e12
#: Two beam members closer than this (mm, and unit-vector difference of their frames) count as one.
DEDUP_MM = 1.0
DEDUP_DIR = 0.06
#: The cost of a candidate the beam's search cut (it could not have been kept).
_CUT = 1e300


# ---------------------------------------------------------------------------
# nearest point, local


@njit(cache=True, inline="always")
def _near(C, pre, w, g, e, px, py, pz):
    """Nearest centerline point of a sample expected at trajectory index ``e``: (d2, segment, t).

    The helpers of the search take and return numbers, not arrays: inlined into the search, an array passed
    between them would cost two reference-count updates at every node."""
    M = C.shape[0]
    lo, hi = search_window(M, e + pre, w)
    if g < 0:
        return segment_scan(C, lo, hi, px, py, pz)
    return scan_from(C, lo, hi, g, px, py, pz, _SCAN)


@njit(cache=True, inline="always")
def _near_from(C, pre, w, g, e, px, py, pz):
    """:func:`_near` with a guess (``g >= 0``): what the search asks at every node (a smaller body to inline)."""
    lo, hi = search_window(C.shape[0], e + pre, w)
    return scan_from(C, lo, hi, g, px, py, pz, _SCAN)


@njit(cache=True, inline="always")
def _wall(R, radius, margin, ww, d2, k, t):
    """Clearance of a sample whose nearest centerline point (:func:`_near`) is ``(d2, k, t)``, and its wall cost."""
    c = R[k] + t * (R[k + 1] - R[k]) - radius - math.sqrt(d2)
    p = margin - c
    return c, (ww * p * p if p > 0.0 else 0.0)


@njit(cache=True, inline="always")
def _race(Q, k, t, wr, px, py, pz):
    """The pull to the racing line: ``wr`` times the squared distance from the sample to the racing line's
    point at the sample's nearest centerline point (segment ``k``, position ``t`` on it)."""
    if wr <= 0.0:
        return 0.0
    qx = Q[k, 0] + t * (Q[k + 1, 0] - Q[k, 0])
    qy = Q[k, 1] + t * (Q[k + 1, 1] - Q[k, 1])
    qz = Q[k, 2] + t * (Q[k + 1, 2] - Q[k, 2])
    return wr * ((px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2)


@njit(cache=True, inline="always")
def _along(k, t, pre, e, sp):
    """How far (mm, along the centerline) the nearest point (segment ``k``, position ``t``) is from where the
    sample is expected."""
    return (float(k) + t - pre - e) * sp


@njit(cache=True, inline="always")
def _schedule(a, e, sp, w_along, w_lead, slack, end):
    """The schedule terms of a sample ``a`` mm ahead of where it is expected (trajectory index ``e``): the weak
    pull back to the schedule, ``w_along a^2``, and the lead the robot can no longer lose before the path's end,
    ``w_lead max(0, a - slack (end - e) sp)^2`` (the feeder pushes every step; a robot ahead of its schedule at
    the end pushes into the blind cecum by its lead)."""
    v = w_along * a * a
    x = a - slack * (end - e) * sp
    if x > 0.0:
        v += w_lead * x * x
    return v


@njit(cache=True, inline="always")
def _module_cost(C, Q, R, pre, w, g, e0, ef, pts, j, cA, radius, margin, ww, wc, wa, wl, slack, end, wr, sp, pre0, dR,
                 v0, bound, last, ux, uy, uz, wo):
    """Cost of the module A->B (A = ``pts[j]``, B = ``pts[j + 1]``): its far end (wall and centerline) and, where
    the wall may be near, its middle (wall only). ``cA`` is A's clearance. Returns (cost, B's clearance, the
    segment of B's nearest centerline point). ``wa, wl, slack, end``: the schedule's settings (:func:`_schedule`),
    ``wr`` the racing line's weight.

    The clearance changes by at most 1 mm per mm moved plus the change of the lumen radius (at most ``dR``
    over half a module), so the middle is skipped when both ends clear the margin by more than half a
    module plus ``dR``: its wall term is then zero.

    The caller's search discards the module when ``v0`` plus its cost (plus, for the tip module (``last``), the
    tip term of its direction ``(ux, uy, uz)`` with weight ``wo``) reaches ``bound``; as the middle's term is not
    negative, that is known before the middle is measured, and the cost of the far end alone is returned then
    (the same decision, less work).

    It is inlined into the search and takes numbers, a point's index and the lumen's arrays: an array passed to
    it, or a view made for it, would cost reference-count updates at every node of the search.
    """
    half = int(0.5 * ef)  # guesses: the centerline runs on by about half a module per half module of robot
    ax, ay, az = pts[j, 0], pts[j, 1], pts[j, 2]
    bx, by, bz = pts[j + 1, 0], pts[j + 1, 1], pts[j + 1, 2]
    dB, kB, tB = _near_from(C, pre, w, g + int(ef), e0 + ef, bx, by, bz)
    cB, cost = _wall(R, radius, margin, ww, dB, kB, tB)
    a = _along(kB, tB, pre0, e0 + ef, sp)
    cost += wc * dB + _schedule(a, e0 + ef, sp, wa, wl, slack, end) + _race(Q, kB, tB, wr, bx, by, bz)
    v = v0 + cost
    if v >= bound:
        return cost, cB, kB
    if last and v + _tip_dir_term(C, kB, ux, uy, uz, wo) >= bound:
        return cost, cB, kB
    L2 = 0.5 * math.sqrt((ax - bx) ** 2 + (ay - by) ** 2 + (az - bz) ** 2)
    if min(cA, cB) - L2 - dR <= margin:
        dM, kM, tM = _near_from(C, pre, w, g + half, e0 + 0.5 * ef, 0.5 * (ax + bx), 0.5 * (ay + by),
                                0.5 * (az + bz))
        cM, cm = _wall(R, radius, margin, ww, dM, kM, tM)
        cost += cm
    return cost, cB, kB


@njit(cache=True, inline="always")
def _tip_dir_term(C, k, ux, uy, uz, wo):
    """The tip term: ``wo`` times the squared difference of the tip module's direction ``(ux, uy, uz)`` and the
    centerline's direction on segment ``k``."""
    cx, cy, cz = C[k + 1, 0] - C[k, 0], C[k + 1, 1] - C[k, 1], C[k + 1, 2] - C[k, 2]
    nu = math.sqrt(cx * cx + cy * cy + cz * cz)
    return wo * ((ux - cx / nu) ** 2 + (uy - cy / nu) ** 2 + (uz - cz / nu) ** 2)


@njit(cache=True, inline="always")
def _tip_term(C, k, frames, lv, wo):
    """:func:`_tip_dir_term` of the module whose frame is ``frames[lv]``."""
    return _tip_dir_term(C, k, frames[lv, 2, 0], frames[lv, 2, 1], frames[lv, 2, 2], wo)


@njit(cache=True, inline="always")
def _track(pts, j, T):
    """Squared distance of point ``j`` to its trajectory point ``T[j]`` (as :func:`dist2`, without views)."""
    return (pts[j, 0] - T[j, 0]) ** 2 + (pts[j, 1] - T[j, 1]) ** 2 + (pts[j, 2] - T[j, 2]) ** 2


@njit(cache=True, inline="always")
def _place(frames, pts, lv, q, c, s, L):
    """Module ``lv`` (0-based, after module 1) tilted by search code ``q`` from the module behind it: its frame
    and its far end."""
    tilt_frame_at(frames, lv - 1, q, c, s, lv)
    for b in range(3):
        pts[lv + 1, b] = pts[lv, b] + L * frames[lv, 2, b]


@njit(cache=True)
def _head_search(C, Q, R, pre, w, step, n, f, L, c, s, T, prm, best_codes, frames, pts, part, guess, choice, cap):
    """Exact branch and bound over modules 2..n with module 1's frame in ``frames[0]`` and ``pts[0]`` the base.

    prm = (radius, margin, w_wall, w_center, w_track, w_ori). Returns the best cost; codes in best_codes[1:].
    ``cap``: only a cost below it matters to the caller; when the best is not below it, returns :data:`_CUT`
    (codes undefined) as soon as that is known.
    """
    radius, margin, ww, wc, wt, wo = prm[0], prm[1], prm[2], prm[3], prm[4], prm[5]
    e0 = float(step - n * f)
    clr = np.empty(n + 1)
    dR, sp, pre0 = prm[6], prm[8], prm[9]
    wa, wl, slack, end, wr = prm[7], prm[10], prm[11], prm[12], prm[13]
    d0, k0, t0 = _near(C, pre, w, -1, e0, pts[0, 0], pts[0, 1], pts[0, 2])
    clr[0], part[0] = _wall(R, radius, margin, ww, d0, k0, t0)
    a0 = _along(k0, t0, pre0, e0, sp)
    part[0] += wc * d0 + _schedule(a0, e0, sp, wa, wl, slack, end) + wt * _track(pts, 0, T) \
        + _race(Q, k0, t0, wr, pts[0, 0], pts[0, 1], pts[0, 2])
    guess[0] = k0
    for b in range(3):
        pts[1, b] = pts[0, b] + L * frames[0, 2, b]
    mc, clr[1], guess[1] = _module_cost(C, Q, R, pre, w, guess[0], e0, float(f), pts, 0, clr[0], radius, margin,
                                        ww, wc, wa, wl, slack, end, wr, sp, pre0, dR, 0.0, 1e300, False, 0.0, 0.0,
                                        0.0, wo)
    part[1] = part[0] + mc + wt * _track(pts, 1, T)
    best_codes[0] = 0
    if n == 1:
        return part[1] + _tip_term(C, guess[1], frames, 0, wo)
    # a greedy dive first (each module the cheapest for the points so far): a good first bound to cut with
    best = 1e300
    for lv in range(1, n):
        bv = 1e300
        bq = 0
        for q in range(5):
            _place(frames, pts, lv, q, c, s, L)
            v = part[lv] + wt * _track(pts, lv + 1, T)
            if v >= bv:
                continue
            mc, cB, kB = _module_cost(C, Q, R, pre, w, guess[lv], float(step - (n - lv) * f), float(f), pts, lv,
                                      clr[lv], radius, margin, ww, wc, wa, wl, slack, end, wr, sp, pre0, dR, v, bv,
                                      lv == n - 1, frames[lv, 2, 0], frames[lv, 2, 1], frames[lv, 2, 2], wo)
            v += mc
            if lv == n - 1:
                v += _tip_term(C, kB, frames, lv, wo)
            if v < bv:
                bv = v
                bq = q
                clr[lv + 1] = cB
                guess[lv + 1] = kB
        choice[lv] = bq
        _place(frames, pts, lv, bq, c, s, L)
        part[lv + 1] = bv
    best = part[n]
    for q in range(1, n):
        best_codes[q] = choice[q]
    best *= 1.0 + 1e-12  # the exact search below may find the same configuration again: let it
    capped = cap < best
    if capped:  # the same search with a lower bound to cut with: the same best when it is below the cap
        best = cap
    lvl = 1
    choice[1] = -1
    while lvl >= 1:
        choice[lvl] += 1
        if choice[lvl] >= 5:
            lvl -= 1
            continue
        _place(frames, pts, lvl, choice[lvl], c, s, L)
        v = part[lvl] + wt * _track(pts, lvl + 1, T)
        if v >= best:
            continue
        mc, cB, kB = _module_cost(C, Q, R, pre, w, guess[lvl], float(step - (n - lvl) * f), float(f), pts, lvl,
                                  clr[lvl], radius, margin, ww, wc, wa, wl, slack, end, wr, sp, pre0, dR, v, best,
                                  lvl == n - 1, frames[lvl, 2, 0], frames[lvl, 2, 1], frames[lvl, 2, 2], wo)
        v += mc
        if v >= best:
            continue
        clr[lvl + 1] = cB
        guess[lvl + 1] = kB
        part[lvl + 1] = v
        if lvl == n - 1:
            best = keep_best(v + _tip_term(C, guess[n], frames, n - 1, wo), best, choice, best_codes, 1, n)
        else:
            lvl += 1
            choice[lvl] = -1
    if capped and best >= cap:
        return _CUT
    return best


@njit(cache=True)
def _head_cost(C, Q, R, pre, w, P0, F1, step, n, f, L, c, s, T, prm, best_codes, frames, pts, part, guess, choice,
               cap):
    for a in range(3):
        for b in range(3):
            frames[0, a, b] = F1[a, b]
    for b in range(3):
        pts[0, b] = P0[b]
    return _head_search(C, Q, R, pre, w, step, n, f, L, c, s, T, prm, best_codes, frames, pts, part, guess, choice,
                        cap)


# ---------------------------------------------------------------------------
# the fixed-lag beam over the base tilt (as bhr.solvers._optimal, with this cost)


@njit(cache=True)
def _head_depth(C, R, pre, w, k, n, f, L, c, s, radius, F1, P0, best_codes, frames, pts):
    """How deep (mm, the negative of the smallest clearance; negative when clear) the head of ``best_codes`` at step
    ``k`` goes into the wall: its base, every module's far end and middle, module 1 along ``F1`` from ``P0``, each
    sample's nearest centerline point searched over its whole window (the search's own guided scans can stop at a
    nearer local minimum in a tight bend)."""
    for a in range(3):
        for b in range(3):
            frames[0, a, b] = F1[a, b]
    for b in range(3):
        pts[0, b] = P0[b]
        pts[1, b] = P0[b] + L * F1[2, b]
    for lv in range(1, n):
        _place(frames, pts, lv, best_codes[lv], c, s, L)
    e0 = float(k - n * f)
    worst = -1e300
    for j in range(n + 1):
        dj, kj, tj = _near(C, pre, w, -1, e0 + j * f, pts[j, 0], pts[j, 1], pts[j, 2])
        cj, _ = _wall(R, radius, 0.0, 0.0, dj, kj, tj)
        worst = max(worst, -cj)
        if j > 0:
            dj, kj, tj = _near(C, pre, w, -1, e0 + (j - 0.5) * f, 0.5 * (pts[j, 0] + pts[j - 1, 0]),
                               0.5 * (pts[j, 1] + pts[j - 1, 1]), 0.5 * (pts[j, 2] + pts[j - 1, 2]))
            cj, _ = _wall(R, radius, 0.0, 0.0, dj, kj, tj)
            worst = max(worst, -cj)
    return worst


@njit(cache=True)
def _far(cP, cF, i, j, dpos, ddir):
    """Candidates ``i`` and ``j`` are too far apart for any third one to be a near-duplicate (as :func:`beam_keep`
    counts them) of both: twice the distances, by the triangle inequality, with a rounding margin."""
    if dpos <= 0.0 or ddir <= 0.0:
        return True
    g = 4.0 * (1.0 + 1e-9)
    if dist2(cP[i], cP[j]) >= g * dpos * dpos:
        return True
    return dist2(cF[i, 1], cF[j, 1]) + dist2(cF[i, 2], cF[j, 2]) >= g * ddir * ddir


@njit(cache=True)
def _kept_bound(cC, cP, cF, done, m, B, keys, pick):
    """A key that the last member the beam keeps cannot exceed, from the candidates searched so far (``done``):
    the largest key of ``B`` of them that are pairwise :func:`_far` (chosen cheapest first, equal keys in index
    order as :func:`beam_keep`'s sort). Every one of those is either kept or the near-duplicate of a distinct kept
    candidate of no larger key, so the beam is full before any key above it. ``inf`` while there are not ``B``
    such candidates."""
    for j in range(m):
        keys[j] = cC[j] if done[j] else math.inf
    got = 0
    for r in stable_argsort(keys, m):
        if not done[r]:
            break
        ok = True
        for v in range(got):
            if not _far(cP, cF, pick[v], r, DEDUP_MM, DEDUP_DIR):
                ok = False
                break
        if ok:
            pick[got] = r
            got += 1
            if got >= B:
                return cC[r]
    return math.inf


@njit(cache=True)
def _beam_expand(bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, bM, cM, cS, C, Q, R, pre, w, path, dirs, n,
                 f, feed, L, c, s, prm, T, d, best_codes, frames, pts, part, guess, choice, F1):
    """Expand every member by the five base tilts at step ``state[1]`` and keep the best distinct ones: ranked first
    by the deepest penetration of their whole history (``bM``, in steps of :data:`DEPTH_STEP` mm), then by their
    summed cost (``bC``).

    The ranking key of a candidate is ``depth step * RANK_SPAN + min(summed cost - low, RANK_SPAN / 2)``, ``low``
    the cheapest member's summed cost (every cost is non-negative, so no candidate is below it). The members are
    searched best first; once ``B`` pairwise distant candidates are known (:func:`_kept_bound`), a candidate whose
    key must exceed theirs cannot be kept, so its search stops as soon as its cost shows it (the same beam as
    searching every candidate whole: ``prm[14] = 0`` does that, for the tests)."""
    nb = state[0]
    k = state[1]
    B = bP.shape[0]
    step_targets(path, dirs, k, n, f, feed, T, d)
    m = 5 * nb
    low = 1e300
    for q in range(nb):
        low = min(low, bC[q])
    done = np.zeros(m, dtype=np.bool_)
    keys = np.empty(m)
    pick = np.empty(B, dtype=np.int64)
    prune = prm[14] != 0.0 and m > B
    bound = math.inf
    fresh = 0  # candidates searched since the bound was last worked out
    for q in range(nb):  # the members are in the order of their keys: best first
        base = bM[q] * RANK_SPAN
        for a in range(5):
            j = 5 * q + a
            _rot(bF[q], a, c, s, F1)
            cap = 1e300
            if bound < math.inf:
                slack = 1e-9 + 1e-14 * (abs(bound) + abs(bC[q]) + abs(low))
                rest = bound - base
                if rest < -slack:
                    cap = -1.0  # a deeper history than the bound: cannot be kept, whatever this step costs
                elif rest + slack < 0.5 * RANK_SPAN:
                    cap = rest + slack - bC[q] + low
            if cap < 0.0:
                cost = _CUT
            else:
                cost = _head_cost(C, Q, R, pre, w, bP[q], F1, k, n, f, L, c, s, T, prm, best_codes, frames, pts, part,
                                  guess, choice, cap)
            beam_candidate(bP, bF, bC, q, a, F1, 0.0 if cost == _CUT else cost, feed, j, cP, cF, cC, cPar, cA)
            if cost == _CUT:
                cS[j] = _CUT
                cM[j] = bM[q]
                cC[j] = _CUT
                continue
            deep = _head_depth(C, R, pre, w, k, n, f, L, c, s, prm[0], F1, bP[q], best_codes, frames, pts)
            cM[j] = max(bM[q], math.floor(deep / DEPTH_STEP)) if deep > 0.0 else bM[q]
            cS[j] = cC[j]
            cC[j] = cM[j] * RANK_SPAN + min(cS[j] - low, 0.5 * RANK_SPAN)
            done[j] = True
            fresh += 1
            if prune and fresh >= 1 + (j >> 3):
                bound = _kept_bound(cC, cP, cF, done, m, B, keys, pick)
                fresh = 0
    beam_keep(cP, cF, cC, cPar, cA, m, order_buf, bP, bF, bC, bH, state, k, DEDUP_MM, DEDUP_DIR)
    for u in range(state[0]):
        r = order_buf[u]
        bC[u] = cS[r]
        bM[u] = cM[r]


@njit(cache=True)
def _lumen_step(P, E1, E2, i, bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, bM, cM, cS, C, Q, R, pre, w, path,
                dirs, n, f, feed, L, alpha, prm, lookahead, lagv, out_codes, tilts):
    """Solve step ``i`` in place: plan the base tilt, search the rest exactly. Returns (layers, cost)."""
    N = path.shape[0]
    c = math.cos(math.radians(alpha))
    s = math.sin(math.radians(alpha))
    F = np.empty((3, 3))
    F1 = np.empty((3, 3))
    T = np.empty((n + 1, 3))
    d = np.empty(3)
    best_codes = np.zeros(n, dtype=np.int64)
    frames = np.empty((n, 3, 3))
    pts = np.empty((n + 1, 3))
    part = np.empty(n + 1)
    guess = np.zeros(n + 1, dtype=np.int64)
    choice = np.zeros(n, dtype=np.int64)
    frame_of_chain(P, E1, E2, F)
    P0 = P[0].copy()
    if state[0] == 0 or state[2] != i:
        beam_reset(bP, bF, bC, bH, state, P0, F, i)
        bM[0] = 0.0
        lagv[0] = 0.0
    # the robot's lead along the centerline: where the base is now, searched around where it was
    e0 = float(i - n * f)
    _, kl, tl = _near(C, pre + lagv[0], w, -1, e0, P0[0], P0[1], P0[2])
    lagv[0] = float(kl) + tl - pre - e0
    pre = pre + lagv[0]
    layers = 0
    while state[1] < N and state[1] <= i + lookahead:
        _beam_expand(bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, bM, cM, cS, C, Q, R, pre, w, path, dirs,
                     n, f, feed, L, c, s, prm, T, d, best_codes, frames, pts, part, guess, choice, F1)
        layers += 1
    # the members that keep the best one's tilt at step i stay, in order (as beam_commit keeps them)
    hb = bH.shape[1]
    j = 0
    for q in range(state[0]):
        if bH[q, i % hb] == bH[0, i % hb]:
            bM[j] = bM[q]
            j += 1
    a0 = beam_commit(bP, bF, bC, bH, state, i)
    step_targets(path, dirs, i, n, f, feed, T, d)
    _rot(F, a0, c, s, F1)
    cost = _head_cost(C, Q, R, pre, w, P0, F1, i, n, f, L, c, s, T, prm, best_codes, frames, pts, part, guess, choice,
                      1e300)
    best_codes[0] = a0
    write_pose(F, best_codes, c, s, L, alpha, frames, P, E1, E2, out_codes, tilts)
    return layers, cost


@njit(cache=True)
def follow_lumen_kernel(path, dirs, P, E1, E2, bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, bM, cM, cS, C, Q,
                        R, pre, w, f, feed, L, alpha, prm, lookahead, lagv, out_points, out_iters, pe, oe, codes):
    """The whole follow-the-leader loop with the lumen solver, compiled (same arithmetic as step by step)."""
    N = path.shape[0]
    n = P.shape[0] - 1
    step_codes = np.zeros(n, dtype=np.int64)
    tilts = np.zeros(n)
    for i in range(N):
        layers, _ = _lumen_step(P, E1, E2, i, bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, bM, cM, cS, C,
                                Q, R, pre, w, path, dirs, n, f, feed, L, alpha, prm, lookahead, lagv, step_codes, tilts)
        dd = dirs[N - 2] if i == N - 1 else dirs[i]
        finish_step(i, P, E1, E2, path, dirs, f, feed, L, tip_angle(P, dd), layers, step_codes, out_points, out_iters,
                    pe, oe, codes)


# ---------------------------------------------------------------------------
# checking the search


def head_cost(tube, robot, settings: dict[str, float], path: np.ndarray, step: int, base,
              frame1, line: np.ndarray | None = None) -> tuple[list[int], float]:
    """Exact best codes of modules 2..n (and the cost) at ``step`` with module 1's frame ``frame1`` (rows x, y, z).

    ``line``: the racing line (one point per tube point) the ``racing_weight`` term pulls to (default: the
    centerline)."""
    codes, cost, _ = head_search(tube, robot, settings, path, step, base, frame1, line)
    return codes, cost


def head_search(tube, robot, settings: dict[str, float], path: np.ndarray, step: int, base,
                frame1, line: np.ndarray | None = None) -> tuple[list[int], float, float]:
    """:func:`head_cost`, and how deep the best configuration goes into the wall (mm; the negative of its samples'
    smallest clearance): what the beam ranks its sequences by."""
    n = robot.modules
    a = math.radians(robot.alpha)
    path = np.ascontiguousarray(path, dtype=np.float64)
    dirs = np.diff(path, axis=0)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    T = np.empty((n + 1, 3))
    d = np.empty(3)
    step_targets(path, dirs, step, n, robot.feed_divisor, float(robot.feed), T, d)
    prm = _prm(robot, settings, tube)
    best = np.zeros(n, dtype=np.int64)
    Q = tube.points if line is None else np.ascontiguousarray(line, dtype=np.float64)
    P0 = np.asarray(base, dtype=float)
    F1 = np.ascontiguousarray(frame1, dtype=float)
    frames, pts = np.empty((n, 3, 3)), np.empty((n + 1, 3))
    cost = _head_cost(tube.points, Q, tube.radius, float(tube.pre), float(tube.window), P0, F1, step, n,
                      robot.feed_divisor, float(robot.module_length), math.cos(a), math.sin(a), T, prm, best, frames,
                      pts, np.empty(n + 1), np.zeros(n + 1, dtype=np.int64), np.zeros(n, dtype=np.int64),
                      1e300)
    deep = _head_depth(tube.points, tube.radius, float(tube.pre), float(tube.window), step, n, robot.feed_divisor,
                       float(robot.module_length), math.cos(a), math.sin(a), float(robot.robot_radius), F1, P0, best,
                       frames, pts)
    return [int(CODE_OF[k]) for k in best[1:]], float(cost), float(deep)


def lumen_config_cost(tube, robot, settings: dict[str, float], path: np.ndarray, step: int,
                      points: np.ndarray, line: np.ndarray | None = None) -> float:
    """The cost of a configuration (points (n+1, 3)) as the module doc defines it, in numpy, for the tests.

    Uses the full-window nearest search of :func:`bhr._run.clearance.point_clearance`.
    """
    n, f = robot.modules, robot.feed_divisor
    prm = _prm(robot, settings, tube)
    radius, margin, ww, wc, wt, wo, dR, wa, sp, _, wl, slack, end, wr = prm[:14]
    Q = tube.points if line is None else np.asarray(line, dtype=float)
    path = np.asarray(path, dtype=float)
    dirs = np.diff(path, axis=0)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    T = np.empty((n + 1, 3))
    d = np.empty(3)
    step_targets(path, dirs, step, n, f, float(robot.feed), T, d)

    def wall(c: float) -> float:
        return ww * max(0.0, margin - c) ** 2

    J = 0.0
    clr = []
    for j in range(n + 1):
        e = float(step - (n - j) * f)
        c, pos = nearest_numpy(tube, radius, points[j], e + tube.pre)
        dist = _radius_near(tube, points[j], e) - radius - c
        along = (pos - tube.pre - e) * sp
        clr.append(c)
        lead = along - slack * (end - e) * sp
        J += wall(c) + wc * dist * dist + wa * along * along + (wl * lead * lead if lead > 0.0 else 0.0)
        if wr > 0.0:
            k = min(int(math.floor(pos)), Q.shape[0] - 2)
            q = Q[k] + (pos - k) * (Q[k + 1] - Q[k])
            J += wr * float(np.sum((points[j] - q) ** 2))
    for j in range(n):
        half = 0.5 * float(np.linalg.norm(points[j + 1] - points[j]))
        if min(clr[j], clr[j + 1]) - half - dR <= margin:
            e = float(step - (n - j) * f) + 0.5 * f
            J += wall(point_clearance(tube, radius, 0.5 * (points[j] + points[j + 1]), e))
    J += wt * float(np.sum((points - T) ** 2))
    k = _segment_near(tube, points[n], float(step))
    t = tube.points[k + 1] - tube.points[k]
    u = points[n] - points[n - 1]
    J += wo * float(np.sum((u / np.linalg.norm(u) - t / np.linalg.norm(t)) ** 2))
    return J


def _window_segments(tube, e: float) -> tuple[int, int]:
    M = tube.points.shape[0]
    lo = min(max(int(math.floor(e + tube.pre - tube.window)), 0), M - 2)
    hi = min(int(math.ceil(e + tube.pre + tube.window)), M - 1)
    return lo, max(hi, lo + 1)


def _segment_near(tube, p: np.ndarray, e: float) -> int:
    lo, hi = _window_segments(tube, e)
    a, b = tube.points[lo:hi], tube.points[lo + 1:hi + 1]
    u = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, u) / np.einsum("ij,ij->i", u, u), 0.0, 1.0)
    return lo + int(np.argmin(np.linalg.norm(p - (a + t[:, None] * u), axis=1)))


def _radius_near(tube, p: np.ndarray, e: float) -> float:
    k = _segment_near(tube, p, e)
    a, b = tube.points[k], tube.points[k + 1]
    t = float(np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0))
    return float(tube.radius[k] + t * (tube.radius[k + 1] - tube.radius[k]))


def _prm(robot, settings: dict[str, float], tube=None, prune: bool = True) -> np.ndarray:
    """Kernel settings: radius, margin, weights, the largest change of the lumen radius along one module, and
    whether the beam cuts the searches of candidates it cannot keep (``prune``: the same beam either way)."""
    dR = 0.0
    sp = float(robot.feed)
    pre = 0.0
    end = 1e300  # no path's end known: no lead term
    if tube is not None:
        pre = float(tube.pre)
        end = float(tube.points.shape[0] - tube.post - 1 - tube.pre)
        f = int(robot.feed_divisor)
        R = tube.radius
        dR = float(np.max(np.abs(R[f:] - R[:-f]))) if R.shape[0] > f else 0.0
        sp = tube.spacing
    return np.array([float(robot.robot_radius), settings["margin"], settings["wall_weight"], settings["center_weight"],
                     settings["track_weight"], (settings["ori_weight"] * DEG) ** 2, dR, settings["along_weight"], sp,
                     pre, settings.get("lead_weight", DEFAULTS["lead_weight"]),
                     settings.get("lead_slack", DEFAULTS["lead_slack"]), end,
                     settings.get("racing_weight", DEFAULTS["racing_weight"]), float(prune)], dtype=np.float64)


def planned_line(tube: Tube, robot, margin: float) -> np.ndarray:
    """The racing line through the tube's corridor (R - robot radius - margin), curvature bounded by the head's
    tightest bend where the corridor allows it (:func:`bhr.model._racing.racing_line`)."""
    kmax = 1.0 / head_radius_mm(float(robot.module_length), float(robot.alpha))
    return np.ascontiguousarray(racing_line(tube.points, tube.radius - float(robot.robot_radius) - margin, kmax))


# ---------------------------------------------------------------------------
# the solver


@register
class Lumen(Optimal):
    """The exact code search with a wall-penetration cost, the base tilt planned ahead through the bends."""

    name = "lumen"
    summary = "keeps every point and module inside the lumen: exact code search, bends planned ahead (docs/lumen.md)"
    binary = True

    def __init__(self, robot, lookahead: int | None = None, beam: int | None = None,
                 wall_weight: float | None = None, margin: float | None = None, center_weight: float | None = None,
                 track_weight: float | None = None, along_weight: float | None = None,
                 ori_weight: float | None = None, window: float | None = None,
                 trail_beam: int | None = None, lead_weight: float | None = None,
                 lead_slack: float | None = None, racing_weight: float | None = None,
                 trail_center_weight: float | None = None) -> None:
        opt = {k: v for k, v in dict(lookahead=lookahead, beam=beam, wall_weight=wall_weight, margin=margin,
                                     center_weight=center_weight, track_weight=track_weight,
                                     along_weight=along_weight, ori_weight=ori_weight,
                                     window=window, trail_beam=trail_beam, lead_weight=lead_weight,
                                     lead_slack=lead_slack, racing_weight=racing_weight,
                                     trail_center_weight=trail_center_weight).items() if v is not None}
        cfg = {**DEFAULTS, **opt}
        super().__init__(robot, lookahead=cfg["lookahead"], beam=cfg["beam"], ori_weight=cfg["ori_weight"])
        self.wall_weight = setting_number("wall-weight", cfg["wall_weight"])
        self.margin = setting_number("margin", cfg["margin"], minimum=-1e6)
        self.center_weight = setting_number("center-weight", cfg["center_weight"])
        self.trail_center_weight = setting_number("trail-center-weight", cfg["trail_center_weight"])
        self.track_weight = setting_number("track-weight", cfg["track_weight"])
        self.along_weight = setting_number("along-weight", cfg["along_weight"])
        self.lead_weight = setting_number("lead-weight", cfg["lead_weight"])
        self.lead_slack = setting_number("lead-slack", cfg["lead_slack"])
        self.racing_weight = setting_number("racing-weight", cfg["racing_weight"])
        self.window = setting_number("window", cfg["window"])
        if self.window <= 0 or self.window > 1e4:
            raise BhrError(f"window must be more than 0 and at most 10000 mm, got {self.window:g}")
        tb = cfg["trail_beam"]
        if isinstance(tb, bool) or not isinstance(tb, (int, np.integer)) or not 1 <= int(tb) <= 4096:
            raise BhrError(f"trail-beam must be a whole number from 1 to 4096, got {tb!r}")
        self.trail_beam = int(tb)
        self._tube: Tube | None = None
        self._tube_path: np.ndarray | None = None  # the points the tube was made from (held)
        self._checked_path: np.ndarray | None = None
        self._prm_cache = np.zeros(15)
        self._prune_beam = True  # False: the beam searches every candidate whole (the same beam; for the tests)
        self._line: np.ndarray | None = None  # the racing line, one point per tube point (None: the centerline)
        self._lag = np.zeros(1)

    @property
    def settings(self) -> dict[str, Any]:
        return {"lookahead": self.lookahead, "beam": self.beam, "wall_weight": self.wall_weight,
                "margin": self.margin, "center_weight": self.center_weight, "track_weight": self.track_weight,
                "along_weight": self.along_weight, "lead_weight": self.lead_weight, "lead_slack": self.lead_slack,
                "ori_weight": self.ori_weight, "window": self.window, "racing_weight": self.racing_weight,
                "trail_center_weight": self.trail_center_weight}

    def prepare(self, trajectory) -> None:
        """Take the lumen of the trajectory about to be followed (called by bhr.follow)."""
        if trajectory.lumen is None:
            raise BhrError(f"--solver lumen needs a trajectory with a lumen; {trajectory.name} has none "
                           "(give a CSV with a lumen column, or lumen = ... in a trajectory file)")
        # the lumen ends as the trajectory says (a blind cecum by default), as the run is scored
        self._tube = make_tube(trajectory.points, trajectory.lumen, trajectory.start_direction, self.window,
                               closed_end=lumen_end_of(trajectory) == "closed")
        self._tube_path = trajectory.points
        self._checked_path = None
        self._line = None  # planned when the head solver first needs it (a trail run never does)

    def _tube_args(self, path: np.ndarray) -> tuple:
        """(centerline, racing line, radius, pre, window) of the tube, checked against ``path``."""
        t = self._tube
        if t is None:
            raise BhrError("--solver lumen was not given the path's lumen; run it through bhr.follow with a "
                           "trajectory that has a lumen")
        if path is not self._checked_path:
            if t.points.shape[0] != path.shape[0] + t.pre + t.post or \
                    not np.array_equal(t.points[t.pre:t.pre + path.shape[0]], path):
                raise BhrError("--solver lumen was not given this path's lumen; run it through bhr.follow with a "
                               "trajectory that has a lumen")
            self._checked_path = path
            self._prm_cache = _prm(self.robot, self.settings, t, self._prune_beam)
            if self.racing_weight > 0.0 and self._line is None:
                self._line = planned_line(t, self.robot, self.margin)
        return t.points, (t.points if self._line is None else self._line), t.radius, float(t.pre), float(t.window)

    def reset(self) -> None:
        super().reset()
        self._lag = np.zeros(1)
        B = self.beam
        self._bM = np.zeros(B)  # each member's deepest penetration so far, in DEPTH_STEP steps
        self._cM = np.zeros(5 * B)
        self._cS = np.zeros(5 * B)

    def _beam_args(self) -> tuple:
        return super()._beam_args() + (self._bM, self._cM, self._cS)

    def _prm(self) -> np.ndarray:
        return self._prm_cache

    def solve(self, chain: Chain, target: np.ndarray, tip_direction: np.ndarray | None = None,
              context: FollowContext | None = None) -> SolveResult:
        if context is None:
            return self._solve_target(chain, target, tip_direction)
        r = self.robot
        n = chain.modules
        path = np.ascontiguousarray(context.path, dtype=np.float64)
        dirs = np.ascontiguousarray(context.directions, dtype=np.float64)
        C, Q, R, pre, w = self._tube_args(path)
        P = np.ascontiguousarray(chain.points.copy())
        E1 = np.ascontiguousarray(chain.axes[0].copy())
        E2 = np.ascontiguousarray(chain.axes[1].copy())
        i = int(context.step)
        if self._expect is not None:
            key, step, eP, e1, e2 = self._expect
            if not (key is self._tube_path and step == i and np.array_equal(eP, P) and np.array_equal(e1, E1)
                    and np.array_equal(e2, E2)):
                self._state[:] = 0
        codes = np.zeros(n, dtype=np.int64)
        tilts = np.zeros(n)
        layers, cost = _lumen_step(P, E1, E2, i, *self._beam_args(), C, Q, R, pre, w, path, dirs, n,
                                   int(r.feed_divisor), float(r.feed), float(r.module_length), float(r.alpha),
                                   self._prm(), int(self.lookahead), self._lag, codes, tilts)
        out = Chain(P, np.stack([E1, E2]))
        nxt = out.copy()
        advance_kernel(nxt.points, nxt.axes[0], nxt.axes[1], float(r.feed), float(r.module_length))
        self._expect = (self._tube_path, i + 1, nxt.points, np.ascontiguousarray(nxt.axes[0]),
                        np.ascontiguousarray(nxt.axes[1]))
        err = float(np.linalg.norm(P[-1] - np.asarray(target, dtype=np.float64)))
        ang = None if tip_direction is None else float(tip_angle(P, np.asarray(tip_direction, dtype=np.float64)))
        return SolveResult(out, int(layers), err, ang, [int(c) for c in codes],
                           {"cost": float(cost), "tilts_deg": [float(v) for v in tilts]})

    def follow_kernel(self, path: np.ndarray, dirs: np.ndarray, chain: Chain, out_points: np.ndarray,
                      out_iters: np.ndarray, pe: np.ndarray, oe: np.ndarray, codes: np.ndarray) -> bool:
        self.reset()
        path = np.ascontiguousarray(path, dtype=np.float64)
        dirs = np.ascontiguousarray(dirs, dtype=np.float64)
        C, Q, R, pre, w = self._tube_args(path)
        c = chain.copy()
        r = self.robot
        follow_lumen_kernel(path, dirs, np.ascontiguousarray(c.points), np.ascontiguousarray(c.axes[0]),
                            np.ascontiguousarray(c.axes[1]), *self._beam_args(), C, Q, R, pre, w, int(r.feed_divisor),
                            float(r.feed), float(r.module_length), float(r.alpha), self._prm(),
                            int(self.lookahead), self._lag, out_points, out_iters, pe, oe, codes)
        self.reset()
        return True
