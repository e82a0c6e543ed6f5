"""An exact discrete solver: search the robot's code space instead of quantizing FABRIK.

Each module is at rest or tilted by alpha about one of its local axes
(+x, +y, -x, -y: codes 0, 3, 6, 12, 9), so a head of ``n`` modules has
``5**n`` configurations. This solver searches them exactly with a
depth-first branch and bound (compiled with numba) and, when driven by
follow-the-leader, plans the base module's tilt a few steps ahead.

Cost of one configuration at one step (all lengths in mm)::

    J = sum_j w_j |P_j - T_j|^2  +  (w_ori * 180/pi)^2 |u - d|^2

``P_j`` is point ``j`` (0 = base), ``T_j`` the trajectory point it is scored
against (``(n-j) f`` steps behind the current target, as bhr.follow scores
it; before the trajectory starts, the straight line the robot starts on),
``u`` the tip module's unit direction and ``d`` the wanted one. ``|u - d|``
is ``2 sin(theta/2)``, so the last term is ``(w_ori * theta_deg)^2`` for
small angles: ``w_ori`` is "millimetres per degree". Branch and bound is
exact because every term is non-negative and the terms of points ``0..j``
are fixed once modules ``1..j`` are chosen.

Why plan ahead: the base module's tilt steers the whole robot for every later
step (the robot advances along it), so choosing it for the current step alone
lets the robot cut inside every curve and run ahead of its targets. The
planner is a fixed-lag beam search over the base module's tilt: it keeps the
``beam`` best sequences of base tilts ``lookahead`` steps ahead of the robot
(each step scored by the exact search of the other modules, plus two
steering terms), commits the first tilt of the best one, and keeps the rest
for the next step, so each step expands one layer of the beam. The steering
terms (see docs/optimal.md):

* drift: ``w_drift * (a + K r)^2`` where ``a`` is the base point's along-path
  error, ``r`` the rate at which it grows with the base's offset toward the
  centre of the curve, and ``K`` the number of steps the current curve goes
  on. A base that runs inside a curve gains on its targets, and only
  zigzagging can lose that again.
* roll: ``w_roll * sin(2 phi)^2 * (k / sin alpha)^2`` where ``phi`` is the
  angle between the path's bending axis at the head and the nearest local
  tilt axis of module 1, and ``k`` the sine of the angle between the path's
  chords one module length before and after the middle of the head. Tilts
  about two axes roll the module frames (a helix keeps turning its bending
  axis), and a head whose tilt axes sit diagonally to the bend fits it badly.

With ``lookahead=0`` and both steering weights 0 the solver is the plain
per-step optimum over all modules (the base too) for the current step's cost. Without a trajectory
(``bhr solve``) it finds the configuration whose tip is nearest the target
(and aims it, when an orientation is given), exactly.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from numba import njit

from bhr._settings.errors import BhrError
from bhr._settings.options import check_number, solver_defaults
from bhr._kinematics.frames import tilt_frame as _rot
from bhr._kinematics.codetable import SEARCH_CODES
from bhr._kinematics.leader import advance_kernel, finish_step, stable_argsort, tip_angle
from bhr.solvers._base import Chain, FollowContext, SolveResult, Solver, register
from bhr.model._robot import forward_kinematics

__all__ = ["Optimal", "CODE_OF", "search_all", "search_head", "config_cost", "path_features", "DEFAULTS"]

#: Search index -> module code: rest, +x, +y, -x, -y (the code table's search order).
CODE_OF = SEARCH_CODES
DEG = 180.0 / math.pi

#: Default settings of ``--solver optimal`` (docs/optimal.md explains each), from the option registry.
DEFAULTS: dict[str, Any] = solver_defaults("optimal")
#: Two beam states closer than this (mm, and unit-vector difference) count as one.
DEDUP_POS = 0.2
DEDUP_DIR = 0.02
#: The drift term predicts the along-path error at most this many steps ahead along one curve.
MAX_CURVE_STEPS = 40


# ---------------------------------------------------------------------------
# small kernels


@njit(cache=True)
def frame_of_chain(P, E1, E2, out):
    """Module 1's frame from a chain: axis points of joint 0 and the base module's direction (as Chain.base_frame)."""
    for b in range(3):
        out[0, b] = E1[0, b] - P[0, b]
        out[1, b] = E2[0, b] - P[0, b]
        out[2, b] = P[1, b] - P[0, b]
    for a in range(3):
        nn = math.sqrt(out[a, 0] ** 2 + out[a, 1] ** 2 + out[a, 2] ** 2)
        for b in range(3):
            out[a, b] /= nn


@njit(cache=True)
def dist2(a, b):
    return (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2


@njit(cache=True)
def keep_best(tot, best, choice, best_codes, first, n):
    """The branch and bound's leaf: a complete configuration of cost ``tot`` becomes the best one (its codes
    ``choice[first:n]`` copied into ``best_codes``) when it is cheaper than ``best``. Returns the best cost."""
    if tot < best:
        for q in range(first, n):
            best_codes[q] = choice[q]
        return tot
    return best


@njit(cache=True)
def copy_member(sP, sF, sC, i, dP, dF, dC, j):
    """Beam member ``j`` of (dP, dF, dC) becomes member ``i`` of (sP, sF, sC): base point, frame and cost."""
    for b in range(3):
        dP[j, b] = sP[i, b]
        for e in range(3):
            dF[j, e, b] = sF[i, e, b]
    dC[j] = sC[i]


@njit(cache=True)
def _search(P0, F, first, n, T, w, d, wo, L, c, s, reach, codes, best_codes, frames, pts, part, choice):
    """Exact branch and bound over the codes of modules ``first..n-1`` (0-based).

    Module ``first - 1``'s frame must be in ``frames[first - 1]`` and point
    ``first`` in ``pts[first]`` (for ``first = 0``: ``F`` is the frame the base
    module tilts from and ``pts[0] = P0``). ``part[first]`` holds the cost of
    the points already placed. Writes the best codes (search indices) into
    ``best_codes[first:]`` and returns the best total cost.
    """
    best = 1e300
    if first >= n:
        return part[n] + wo * dist2(frames[n - 1, 2], d) if n > 0 else part[0]
    lvl = first
    choice[lvl] = -1
    while lvl >= first:
        choice[lvl] += 1
        if choice[lvl] >= 5:
            lvl -= 1
            continue
        if lvl == 0:
            _rot(F, choice[0], c, s, frames[0])
        else:
            _rot(frames[lvl - 1], choice[lvl], c, s, frames[lvl])
        e = 0.0
        for b in range(3):
            pts[lvl + 1, b] = pts[lvl, b] + L * frames[lvl, 2, b]
            e += (pts[lvl + 1, b] - T[lvl + 1, b]) ** 2
        v = part[lvl] + w[lvl + 1] * e
        if v >= best:
            continue
        if reach:  # the rest of the chain moves each later point at most L per module
            lb = v
            for k in range(lvl + 2, n + 1):
                if w[k] > 0.0:
                    gap = math.sqrt(dist2(pts[lvl + 1], T[k])) - (k - lvl - 1) * L
                    if gap > 0.0:
                        lb += w[k] * gap * gap
            if lb >= best:
                continue
        part[lvl + 1] = v
        if lvl == n - 1:
            best = keep_best(v + wo * dist2(frames[n - 1, 2], d), best, choice, best_codes, first, n)
        else:
            lvl += 1
            choice[lvl] = -1
    return best


@njit(cache=True)
def _head_cost(P0, F1, n, T, w, d, wo, L, c, s, codes, best_codes, frames, pts, part, choice):
    """Cost of the best configuration whose base module has frame ``F1``: base and module 1 fixed, rest searched."""
    for a in range(3):
        for b in range(3):
            frames[0, a, b] = F1[a, b]
    e0 = 0.0
    e1 = 0.0
    for b in range(3):
        pts[0, b] = P0[b]
        pts[1, b] = P0[b] + L * F1[2, b]
        e0 += (P0[b] - T[0, b]) ** 2
        e1 += (pts[1, b] - T[1, b]) ** 2
    part[0] = w[0] * e0
    part[1] = part[0] + w[1] * e1
    return _search(P0, F1, 1, n, T, w, d, wo, L, c, s, False, codes, best_codes, frames, pts, part, choice)


@njit(cache=True)
def _target_index(path, i):
    N = path.shape[0]
    return min(max(i, 0), N - 1)


@njit(cache=True)
def step_targets(path, dirs, i, n, f, feed, T, d):
    """Targets of points 0..n at step ``i`` and the wanted tip direction (see module doc)."""
    N = path.shape[0]
    for j in range(n + 1):
        idx = i - (n - j) * f
        if idx < 0:
            for b in range(3):
                T[j, b] = path[0, b] + idx * feed * dirs[0, b]
        elif idx >= N:
            for b in range(3):
                T[j, b] = path[N - 1, b] + (idx - N + 1) * feed * dirs[N - 2, b]
        else:
            for b in range(3):
                T[j, b] = path[idx, b]
    k = N - 2 if i >= N - 1 else i
    for b in range(3):
        d[b] = dirs[k, b]


@njit(cache=True)
def _steer_cost(P0, F1, i, n, f, feed, path, dirs, T, kvec, spacing, kcurve, kbend, wdrift, wroll, inv_sin2):
    """The planner's steering terms (drift and roll, module doc) for base point ``P0`` and base frame ``F1``."""
    N = path.shape[0]
    out = 0.0
    idx = i - n * f
    if wdrift > 0.0 and 0 <= idx < N - 1:
        al = 0.0
        cn = 0.0
        for b in range(3):
            e = P0[b] - T[0, b]
            al += e * dirs[idx, b]
            cn += e * kvec[idx, b]
        r = feed * (1.0 + cn) - spacing[idx]
        pred = al + kcurve[idx] * r
        out += wdrift * pred * pred
    if wroll > 0.0:
        j = _target_index(path, i - 2 * f)
        kx = 0.0
        ky = 0.0
        for b in range(3):
            kx += kbend[j, b] * F1[0, b]
            ky += kbend[j, b] * F1[1, b]
        kk = kx * kx + ky * ky
        if kk > 1e-12:
            out += wroll * 4.0 * kx * kx * ky * ky / kk * inv_sin2
    return out


# ---------------------------------------------------------------------------
# the fixed-lag beam over the base module's tilt


@njit(cache=True)
def beam_reset(bP, bF, bC, bH, state, P0, F, step):
    """Start a beam of one state (P0, F) whose next step to expand is ``step``."""
    for b in range(3):
        bP[0, b] = P0[b]
        for a in range(3):
            bF[0, a, b] = F[a, b]
    bC[0] = 0.0
    state[0] = 1  # members
    state[1] = step  # next step to expand
    state[2] = step  # first step not committed yet


@njit(cache=True)
def beam_keep(cP, cF, cC, cPar, cA, m, order_buf, bP, bF, bC, bH, state, k, dpos, ddir):
    """Keep the ``B`` cheapest of the ``m`` candidates of step ``k`` as the new beam, skipping near-duplicates: a
    candidate within ``dpos`` mm and ``ddir`` (unit-vector difference of its frame's y and z axes) of one kept."""
    B = bP.shape[0]
    R = bH.shape[1]
    order = stable_argsort(cC, m)
    # keep the cheapest candidates, skipping near-duplicates of those already kept (their indices in order_buf)
    kept = 0
    for qq in range(m):
        if kept >= B:
            break
        r = order[qq]
        dup = False
        for u in range(kept):
            o = order_buf[u]
            if dist2(cP[o], cP[r]) < dpos * dpos:
                dz = dist2(cF[o, 1], cF[r, 1]) + dist2(cF[o, 2], cF[r, 2])
                if dz < ddir * ddir:
                    dup = True
                    break
        if dup:
            continue
        order_buf[kept] = r
        kept += 1
    # histories: copy parents' rows first (a parent may feed several children)
    hist = np.empty((kept, R), dtype=np.int64)
    for u in range(kept):
        r = order_buf[u]
        for t in range(R):
            hist[u, t] = bH[cPar[r], t]
        hist[u, k % R] = cA[r]
    for u in range(kept):
        copy_member(cP, cF, cC, order_buf[u], bP, bF, bC, u)
        for t in range(R):
            bH[u, t] = hist[u, t]
    state[0] = kept
    state[1] = k + 1


@njit(cache=True)
def _beam_expand(bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, path, dirs, n, f, feed, L, c, s, w, wo,
                 kvec, spacing, kcurve, kbend, wdrift, wroll, inv_sin2, T, d, codes, best_codes, frames, pts, part,
                 choice, F1):
    """Expand every member by the five base tilts at step ``state[1]``; keep the best distinct ones."""
    nb = state[0]
    k = state[1]
    step_targets(path, dirs, k, n, f, feed, T, d)
    m = 0
    for q in range(nb):
        for a in range(5):
            _rot(bF[q], a, c, s, F1)
            cost = _head_cost(bP[q], F1, n, T, w, d, wo, L, c, s, codes, best_codes, frames, pts, part, choice)
            cost += _steer_cost(bP[q], F1, k, n, f, feed, path, dirs, T, kvec, spacing, kcurve, kbend, wdrift, wroll,
                                inv_sin2)
            beam_candidate(bP, bF, bC, q, a, F1, cost, feed, m, cP, cF, cC, cPar, cA)
            m += 1
    beam_keep(cP, cF, cC, cPar, cA, m, order_buf, bP, bF, bC, bH, state, k, DEDUP_POS, DEDUP_DIR)


@njit(cache=True)
def beam_candidate(bP, bF, bC, q, a, F1, cost, feed, m, cP, cF, cC, cPar, cA):
    """Candidate ``m``: beam member ``q`` with base tilt ``a`` (frame ``F1``), one feed on, its cost plus ``cost``."""
    cC[m] = bC[q] + cost
    for b in range(3):
        cP[m, b] = bP[q, b] + feed * F1[2, b]
        for e in range(3):
            cF[m, e, b] = F1[e, b]
    cPar[m] = q
    cA[m] = a


@njit(cache=True)
def beam_commit(bP, bF, bC, bH, state, step):
    """The best member's base tilt at ``step``; drop the members that chose otherwise."""
    R = bH.shape[1]
    a0 = bH[0, step % R]
    kept = 0
    for q in range(state[0]):
        if bH[q, step % R] == a0:
            if kept != q:
                copy_member(bP, bF, bC, q, bP, bF, bC, kept)
                for t in range(R):
                    bH[kept, t] = bH[q, t]
            kept += 1
    state[0] = kept
    state[2] = step + 1
    return a0


@njit(cache=True)
def write_pose(F, best_codes, c, s, L, alpha, frames, P, E1, E2, out_codes, tilts):
    """Put the chain in the pose of ``best_codes`` (search indices, module 1 first) from the base frame ``F``.

    Writes the module frames, the points ``P[1:]`` and the axis points ``E1``,
    ``E2`` (each module's x and y from its rear point), the codes and the
    tilts (degrees) of the pose.
    """
    n = best_codes.shape[0]
    _rot(F, best_codes[0], c, s, frames[0])
    for m in range(1, n):
        _rot(frames[m - 1], best_codes[m], c, s, frames[m])
    for m in range(n):
        out_codes[m] = CODE_OF[best_codes[m]]
        tilts[m] = 0.0 if best_codes[m] == 0 else alpha
        for b in range(3):
            P[m + 1, b] = P[m, b] + L * frames[m, 2, b]
    for m in range(n):
        for b in range(3):
            E1[m, b] = P[m, b] + frames[m, 0, b]
            E2[m, b] = P[m, b] + frames[m, 1, b]


@njit(cache=True)
def _optimal_step(P, E1, E2, i, bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, path, dirs, n, f, feed, L,
                  alpha, w, wo, lookahead, kvec, spacing, kcurve, kbend, wdrift, wroll, out_codes, tilts):
    """Solve step ``i`` in place: plan the base tilt, search the rest exactly, write the pose into P, E1, E2.

    Returns (layers expanded, base-and-head cost of the pose).
    """
    N = path.shape[0]
    c = math.cos(math.radians(alpha))
    s = math.sin(math.radians(alpha))
    inv_sin2 = 1.0 / (s * s)
    F = np.empty((3, 3))
    F1 = np.empty((3, 3))
    T = np.empty((n + 1, 3))
    d = np.empty(3)
    codes = np.zeros(n, dtype=np.int64)
    best_codes = np.zeros(n, dtype=np.int64)
    frames = np.empty((n, 3, 3))
    pts = np.empty((n + 1, 3))
    part = np.empty(n + 1)
    choice = np.zeros(n, dtype=np.int64)
    frame_of_chain(P, E1, E2, F)
    P0 = P[0].copy()
    if state[0] == 0 or state[2] != i:
        beam_reset(bP, bF, bC, bH, state, P0, F, i)
    layers = 0
    while state[1] < N and state[1] <= i + lookahead:
        _beam_expand(bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, path, dirs, n, f, feed, L, c, s, w, wo,
                     kvec, spacing, kcurve, kbend, wdrift, wroll, inv_sin2, T, d, codes, best_codes, frames, pts, part,
                     choice, F1)
        layers += 1
    a0 = beam_commit(bP, bF, bC, bH, state, i)
    # the pose: base tilt a0, the other modules searched exactly for this step's cost
    step_targets(path, dirs, i, n, f, feed, T, d)
    _rot(F, a0, c, s, F1)
    cost = _head_cost(P0, F1, n, T, w, d, wo, L, c, s, codes, best_codes, frames, pts, part, choice)
    best_codes[0] = a0
    write_pose(F, best_codes, c, s, L, alpha, frames, P, E1, E2, out_codes, tilts)
    return layers, cost


@njit(cache=True)
def follow_optimal_kernel(path, dirs, P, E1, E2, bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, f, feed, L,
                          alpha, w, wo, lookahead, kvec, spacing, kcurve, kbend, wdrift, wroll, out_points, out_iters,
                          pe, oe, codes):
    """The whole follow-the-leader loop with the optimal solver, compiled (same arithmetic as step by step)."""
    N = path.shape[0]
    n = P.shape[0] - 1
    step_codes = np.zeros(n, dtype=np.int64)
    tilts = np.zeros(n)
    for i in range(N):
        layers, _ = _optimal_step(P, E1, E2, i, bP, bF, bC, bH, state, cP, cF, cC, cPar, cA, order_buf, path, dirs,
                                  n, f, feed, L, alpha, w, wo, lookahead, kvec, spacing, kcurve, kbend, wdrift, wroll,
                                  step_codes, tilts)
        d = dirs[N - 2] if i == N - 1 else dirs[i]
        finish_step(i, P, E1, E2, path, dirs, f, feed, L, tip_angle(P, d), layers, step_codes, out_points, out_iters,
                    pe, oe, codes)


# ---------------------------------------------------------------------------
# path features for the steering terms


def path_features(path: np.ndarray, dirs: np.ndarray, f: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per trajectory point: curvature vector (1/mm, toward the centre), spacing to the next point (mm),
    steps the curve goes on with the same bending direction, and the bending vector over +-f points
    (cross product of the unit chords one module length back and ahead: |.| = sine of the angle between them)."""
    N = path.shape[0]
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    spacing = np.empty(N)
    spacing[:-1] = seg
    spacing[-1] = seg[-1]
    kvec = np.zeros((N, 3))
    if N > 2:
        kvec[1:-1] = (dirs[1:] - dirs[:-1]) / (0.5 * (seg[1:] + seg[:-1]))[:, None]
    k2 = np.einsum("ij,ij->i", kvec, kvec)
    kcurve = np.zeros(N)
    run_end = N
    # scan backwards: a point's run continues while the curvature keeps its direction
    for i in range(N - 1, -1, -1):
        if k2[i] < 1e-10:
            run_end = i
            continue
        if i + 1 < N and k2[i + 1] >= 1e-10 and float(kvec[i] @ kvec[i + 1]) > 0.5 * k2[i]:
            pass
        else:
            run_end = i + 1
        kcurve[i] = min(run_end - i, MAX_CURVE_STEPS)
    kbend = np.zeros((N, 3))
    for i in range(N):
        a, b = max(0, i - f), min(N - 1, i + f)
        if i - a < 1 or b - i < 1:
            continue
        u, v = path[i] - path[a], path[b] - path[i]
        kbend[i] = np.cross(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))
    return kvec, spacing, kcurve, kbend


# ---------------------------------------------------------------------------
# the exact search on its own (bhr solve, tests)


def config_cost(points: np.ndarray, targets: np.ndarray, weights: np.ndarray, tip_dir: np.ndarray | None,
                ori_weight: float) -> float:
    """The cost of a configuration as the solver scores it (module doc), for checking the search."""
    j = float(np.sum(weights * np.sum((points - targets) ** 2, axis=1)))
    if tip_dir is not None and ori_weight > 0:
        u = points[-1] - points[-2]
        u = u / np.linalg.norm(u)
        j += (ori_weight * DEG) ** 2 * float(np.sum((u - tip_dir) ** 2))
    return j


def _search_arrays(n: int):
    return (np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), np.empty((n, 3, 3)), np.empty((n + 1, 3)),
            np.empty(n + 1), np.zeros(n, dtype=np.int64))


def _search_inputs(targets, weights, tip_dir, ori_weight: float) -> tuple:
    """(targets, n, weights, tip direction, orientation weight, work arrays) of a search called from Python."""
    T = np.ascontiguousarray(targets, dtype=np.float64)
    n = T.shape[0] - 1
    w = np.ascontiguousarray(weights, dtype=np.float64)
    d = np.zeros(3) if tip_dir is None else np.asarray(tip_dir, dtype=np.float64)
    wo = 0.0 if tip_dir is None else (ori_weight * DEG) ** 2
    return T, n, w, d, wo, _search_arrays(n)


def search_all(base: Sequence[float] | np.ndarray, frame: np.ndarray, targets: np.ndarray,
               weights: Sequence[float] | np.ndarray, length: float, alpha: float,
               tip_dir: Sequence[float] | np.ndarray | None = None, ori_weight: float = 0.0,
               reach: bool = True) -> tuple[list[int], float]:
    """Exact best codes of all ``n`` modules from ``base`` and base ``frame`` (rows x, y, z).

    ``targets`` (n+1, 3) and ``weights`` (n+1) as in the module doc; returns
    (codes, cost). ``reach`` adds a reachability bound that helps when most
    weights are zero (only the tip scored).
    """
    T, n, w, d, wo, (codes, best, frames, pts, part, choice) = _search_inputs(targets, weights, tip_dir, ori_weight)
    P0 = np.asarray(base, dtype=np.float64)
    pts[0] = P0
    part[0] = w[0] * float(np.sum((P0 - T[0]) ** 2))
    a = math.radians(alpha)
    cost = _search(P0, np.ascontiguousarray(frame, dtype=np.float64), 0, n, T, w, d, wo, float(length), math.cos(a),
                   math.sin(a), reach, codes, best, frames, pts, part, choice)
    return [int(CODE_OF[k]) for k in best], float(cost)


def search_head(base: Sequence[float], frame1: np.ndarray, targets: np.ndarray, weights: Sequence[float],
                length: float, alpha: float, tip_dir: Sequence[float] | None = None,
                ori_weight: float = 0.0) -> tuple[list[int], float]:
    """Exact best codes of modules 2..n when module 1's frame is ``frame1``; returns (codes 2..n, cost)."""
    T, n, w, d, wo, (codes, best, frames, pts, part, choice) = _search_inputs(targets, weights, tip_dir, ori_weight)
    a = math.radians(alpha)
    cost = _head_cost(np.asarray(base, dtype=np.float64), np.ascontiguousarray(frame1, dtype=np.float64), n, T, w, d,
                      wo, float(length), math.cos(a), math.sin(a), codes, best, frames, pts, part, choice)
    return [int(CODE_OF[k]) for k in best[1:]], float(cost)


# ---------------------------------------------------------------------------
# the solver


def setting_number(name: str, value: Any, *, minimum: float = 0.0, integer: bool = False) -> float:
    """A solver setting through the one number checker (:func:`bhr._settings.options.check_number`), as a float."""
    return float(check_number(value, name, integer=integer, minimum=minimum, limit=1e300))


@register
class Optimal(Solver):
    """Exact search of the binary code space, with a beam planned ahead for the base module's tilt."""

    name = "optimal"
    summary = "exact search of the 5^n codes (branch and bound), base tilt planned ahead (docs/optimal.md)"

    def __init__(self, robot, lookahead: int | None = None, beam: int | None = None,
                 point_weights: float | Sequence[float] | None = None, ori_weight: float | None = None,
                 drift_weight: float | None = None, roll_weight: float | None = None) -> None:
        super().__init__(robot)
        n = robot.modules
        opt = {k: v for k, v in dict(lookahead=lookahead, beam=beam, point_weights=point_weights,
                                     ori_weight=ori_weight, drift_weight=drift_weight,
                                     roll_weight=roll_weight).items() if v is not None}
        cfg = {**DEFAULTS, **opt}
        self.lookahead = int(setting_number("lookahead", cfg["lookahead"], integer=True))
        self.beam = int(setting_number("beam", cfg["beam"], minimum=1, integer=True))
        if self.lookahead > 200:
            raise BhrError(f"lookahead {self.lookahead} is more than 200 steps; use a smaller --lookahead")
        if self.beam > 500:
            raise BhrError(f"beam {self.beam} is more than 500 states; use a smaller --beam")
        pw = cfg["point_weights"]
        if isinstance(pw, (list, tuple, np.ndarray)):
            vals = [setting_number("point weight", v) for v in pw]
            if len(vals) != n + 1:
                raise BhrError(f"give {n + 1} point weights (base to tip) for {n} modules, or one for all; "
                               f"got {len(vals)}")
        else:
            vals = [setting_number("point weight", pw)] * (n + 1)
        if not any(v > 0 for v in vals):
            raise BhrError("at least one point weight must be positive")
        self.point_weights = np.array(vals, dtype=np.float64)
        self.ori_weight = setting_number("ori-weight", cfg["ori_weight"])
        self.drift_weight = setting_number("drift-weight", cfg["drift_weight"])
        self.roll_weight = setting_number("roll-weight", cfg["roll_weight"])
        if n > 12:
            raise BhrError(f"the optimal solver searches 5^n codes; {n} modules is too many (at most 12), "
                           "use --solver thesis for long heads")
        self._features_path: np.ndarray | None = None  # the path the features were computed for (held)
        self._features: tuple | None = None
        self.reset()

    @property
    def settings(self) -> dict[str, Any]:
        """The solver's settings as documented (JSON-friendly)."""
        return {"lookahead": self.lookahead, "beam": self.beam,
                "point_weights": [float(v) for v in self.point_weights], "ori_weight": self.ori_weight,
                "drift_weight": self.drift_weight, "roll_weight": self.roll_weight}

    def reset(self) -> None:
        B, R = self.beam, self.lookahead + 2
        self._bP = np.zeros((B, 3))
        self._bF = np.zeros((B, 3, 3))
        self._bC = np.zeros(B)
        self._bH = np.zeros((B, R), dtype=np.int64)
        self._state = np.zeros(3, dtype=np.int64)
        self._cP = np.zeros((5 * B, 3))
        self._cF = np.zeros((5 * B, 3, 3))
        self._cC = np.zeros(5 * B)
        self._cPar = np.zeros(5 * B, dtype=np.int64)
        self._cA = np.zeros(5 * B, dtype=np.int64)
        self._order = np.zeros(5 * B, dtype=np.int64)
        self._expect: tuple | None = None

    def _path_features(self, path: np.ndarray, dirs: np.ndarray) -> tuple:
        known = self._features_path
        if known is None or not (path is known or (path.shape == known.shape and np.array_equal(path, known))):
            self._features = path_features(path, dirs, self.robot.feed_divisor)
            self._features_path = path
        assert self._features is not None
        return self._features

    def _beam_args(self) -> tuple:
        return (self._bP, self._bF, self._bC, self._bH, self._state, self._cP, self._cF, self._cC, self._cPar,
                self._cA, self._order)

    def _kernel_settings(self) -> tuple:
        r = self.robot
        wo = (self.ori_weight * DEG) ** 2
        return (int(r.feed_divisor), float(r.feed), float(r.module_length), float(r.alpha), self.point_weights,
                float(wo), int(self.lookahead))

    def solve(self, chain: Chain, target: np.ndarray, tip_direction: np.ndarray | None = None,
              context: FollowContext | None = None) -> SolveResult:
        if context is None:
            return self._solve_target(chain, target, tip_direction)
        r = self.robot
        n = chain.modules
        if n != r.modules:
            raise BhrError(f"the chain has {n} modules but the robot {r.modules}")
        path = np.ascontiguousarray(context.path, dtype=np.float64)
        dirs = np.ascontiguousarray(context.directions, dtype=np.float64)
        kvec, spacing, kcurve, kbend = self._path_features(path, dirs)
        out = chain.copy()
        P = np.ascontiguousarray(out.points)
        E1 = np.ascontiguousarray(out.axes[0])
        E2 = np.ascontiguousarray(out.axes[1])
        i = int(context.step)
        # keep the beam only when this is the state and step it expects
        if self._expect is not None:
            key, step, eP, e1, e2 = self._expect
            if not (key is self._features_path and step == i and np.array_equal(eP, P) and np.array_equal(e1, E1)
                    and np.array_equal(e2, E2)):
                self._state[:] = 0
        f, feed, L, alpha, w, wo, look = self._kernel_settings()
        codes = np.zeros(n, dtype=np.int64)
        tilts = np.zeros(n)
        layers, cost = _optimal_step(P, E1, E2, i, *self._beam_args(), path, dirs, n, f, feed, L, alpha, w, wo, look,
                                     kvec, spacing, kcurve, kbend, self.drift_weight, self.roll_weight, codes, tilts)
        out = Chain(P, np.stack([E1, E2]))
        nxt = out.copy()
        advance_kernel(nxt.points, nxt.axes[0], nxt.axes[1], feed, L)
        self._expect = (self._features_path, i + 1, nxt.points, np.ascontiguousarray(nxt.axes[0]),
                        np.ascontiguousarray(nxt.axes[1]))
        t = np.asarray(target, dtype=np.float64)
        err = float(np.linalg.norm(P[-1] - t))
        ang = None if tip_direction is None else float(tip_angle(P, np.asarray(tip_direction, dtype=np.float64)))
        return SolveResult(out, int(layers), err, ang, [int(c) for c in codes],
                           {"cost": float(cost), "tilts_deg": [float(v) for v in tilts]})

    def _solve_target(self, chain: Chain, target: np.ndarray, tip_direction: np.ndarray | None) -> SolveResult:
        """One target, no trajectory: the tip nearest the target (and aimed, with an orientation), exactly."""
        r = self.robot
        n = chain.modules
        t = np.asarray(target, dtype=np.float64)
        T = np.zeros((n + 1, 3))
        T[n] = t
        w = np.zeros(n + 1)
        w[n] = 1.0
        frame = chain.base_frame()
        codes, cost = search_all(chain.points[0], frame, T, w, r.module_length, r.alpha, tip_direction,
                                 self.ori_weight, reach=True)
        pts, frames = forward_kinematics(r.replace(modules=n), codes, chain.points[0], frame)
        axes = np.stack([pts[:-1] + frames[:, 0], pts[:-1] + frames[:, 1]])
        err = float(np.linalg.norm(pts[-1] - t))
        ang = None if tip_direction is None else float(tip_angle(pts, np.asarray(tip_direction, dtype=np.float64)))
        return SolveResult(Chain(pts, axes), 1, err, ang, codes,
                           {"cost": cost, "tilts_deg": [0.0 if c == 0 else float(r.alpha) for c in codes]})

    def follow_kernel(self, path: np.ndarray, dirs: np.ndarray, chain: Chain, out_points: np.ndarray,
                      out_iters: np.ndarray, pe: np.ndarray, oe: np.ndarray, codes: np.ndarray) -> bool:
        """Run the whole follow-the-leader loop compiled (see :mod:`bhr._run.driver`). Codes are always valid."""
        self.reset()
        path = np.ascontiguousarray(path, dtype=np.float64)
        dirs = np.ascontiguousarray(dirs, dtype=np.float64)
        kvec, spacing, kcurve, kbend = self._path_features(path, dirs)
        c = chain.copy()
        f, feed, L, alpha, w, wo, look = self._kernel_settings()
        follow_optimal_kernel(path, dirs, np.ascontiguousarray(c.points), np.ascontiguousarray(c.axes[0]),
                              np.ascontiguousarray(c.axes[1]), *self._beam_args(), f, feed, L, alpha, w, wo, look,
                              kvec, spacing, kcurve, kbend, self.drift_weight, self.roll_weight, out_points,
                              out_iters, pe, oe, codes)
        self.reset()
        return True
