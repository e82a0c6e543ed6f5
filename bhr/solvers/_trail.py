"""The trail planner: the codes of the trail a whole robot's tip lays, one per vertex (docs/locomotion.md).

A whole robot moved in follow-the-leader (``--locomotion trail``) or by its
wires (``--locomotion wires``) goes along a *trail*: a chain of straight
pieces one module length long, each tilted from the one before by one of the
five codes (rest, +x, +y, -x, -y by alpha about the piece's own axes).
:func:`plan_trail` chooses those codes by a beam search scored on everything
the robot will occupy -- the pieces, the joints sliding along them and the
arc swept across each vertex -- with the lumen solver's weights (margin,
wall, centre, along); :func:`trail_vertices` turns codes into the trail's
vertices. The run layer (:mod:`bhr._run.trail`, :mod:`bhr._run.motion`) moves
the robot along the planned trail and scores it.

The planner is compiled with numba (:func:`plan_kernel`);
:func:`plan_trail_numpy` is the readable reference the tests hold it to.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from bhr._kinematics.codetable import SEARCH_CODES
from bhr._kinematics.frames import tilt_frame
from bhr._kinematics.leader import stable_argsort
from bhr.model._robot import base_frame
from bhr.model._tube import Tube, make_tube, scan_from

__all__ = ["plan_trail", "plan_trail_numpy", "trail_vertices", "dense_tube", "TRAIL_DEDUP", "PLAN_SAMPLE_MM",
           "TUBE_SPACING_MM"]


#: Two planned trails whose last vertex lies closer than this (mm), with frames this close, count as one.
TRAIL_DEDUP = (0.2, 0.02)


#: Spacing (mm) of the samples the planner scores along a trail piece and across a vertex.
PLAN_SAMPLE_MM = 1.0


#: Largest spacing (mm) of the centerline the trail is planned and scored against (denser paths are kept).
TUBE_SPACING_MM = 1.0


def dense_tube(path: np.ndarray, lumen: np.ndarray, start_direction, window_mm: float, closed_end: bool = True
               ) -> Tube:
    """The lumen's :class:`~bhr._run.clearance.Tube`, its centerline refined to at most TUBE_SPACING_MM between points
    (a Catmull-Rom spline through the path's points, the diameter interpolated linearly), so that a path sampled
    at a coarse feed gives nearly the same tube as one sampled finely. ``closed_end``: the lumen ends in a cap at
    the last point (the cecum, :func:`bhr._run.clearance.make_tube`)."""
    P = np.asarray(path, dtype=np.float64)
    lum = np.asarray(lumen, dtype=np.float64)[:P.shape[0]]
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    k = int(math.ceil(float(np.median(seg)) / TUBE_SPACING_MM - 1e-9)) if P.shape[0] > 1 else 1
    if k <= 1 or P.shape[0] < 3:
        return make_tube(P, lum, start_direction, window_mm, closed_end=closed_end)
    ext = np.vstack([2 * P[0] - P[1], P, 2 * P[-1] - P[-2]])
    t = np.arange(k) / k
    t2, t3 = t * t, t * t * t
    w0 = -0.5 * t3 + t2 - 0.5 * t
    w1 = 1.5 * t3 - 2.5 * t2 + 1.0
    w2 = -1.5 * t3 + 2.0 * t2 + 0.5 * t
    w3 = 0.5 * t3 - 0.5 * t2
    a, b, c, d = ext[:-3], ext[1:-2], ext[2:-1], ext[3:]
    out = (w0[None, :, None] * a[:, None] + w1[None, :, None] * b[:, None] + w2[None, :, None] * c[:, None]
           + w3[None, :, None] * d[:, None]).reshape(-1, 3)
    out = np.vstack([out, P[-1:]])
    lo = np.concatenate([np.repeat(lum[:-1], k) * (1 - np.tile(t, len(lum) - 1))
                         + np.repeat(lum[1:], k) * np.tile(t, len(lum) - 1), lum[-1:]])
    return make_tube(out, lo, start_direction, window_mm, closed_end=closed_end)


@njit(cache=True)
def _sample_cost(C, R, w, g, px, py, pz, radius, margin, ww):
    """(wall cost, clearance, squared distance, nearest position) of one sample, searched around index ``g``."""
    M = C.shape[0]
    lo = max(0, int(g - w))
    hi = min(M - 1, int(g + w) + 1)
    if hi <= lo:
        hi = lo + 1
    d2, k, t = scan_from(C, lo, hi, int(g), px, py, pz, 3)
    c = R[k] + t * (R[k + 1] - R[k]) - radius - math.sqrt(d2)
    p = margin - c
    return (ww * p * p if p > 0.0 else 0.0), c, d2, k + t


@njit(cache=True)
def _extend_cost(C, R, w, A, T, Tn, g, L, sp, radius, margin, ww, wc, wa, ns, out):
    """Cost of laying the piece T -> Tn after the piece A -> T: the piece's samples, the Bezier curve across T
    (the inner boundary of what the chords sweep there), the new vertex's distance to the centerline and how far
    it advances along it (``wa (advance - L)^2``). out = (nearest position of Tn, smallest clearance)."""
    cost = 0.0
    cmin = 1e300
    h = g
    for q in range(1, ns + 1):
        t = q / ns
        px = T[0] + t * (Tn[0] - T[0])
        py = T[1] + t * (Tn[1] - T[1])
        pz = T[2] + t * (Tn[2] - T[2])
        wcost, c, d2, pos = _sample_cost(C, R, w, h, px, py, pz, radius, margin, ww)
        cost += wcost
        cmin = min(cmin, c)
        h = pos
        if q == ns:
            cost += wc * d2
            adv = (pos - g) * sp - L
            cost += wa * adv * adv
            out[0] = pos
    # the Bezier curve across T, from A's side to Tn's (its end points are A and Tn, both scored as pieces)
    hb = g - 0.5 * L / sp
    nb = 2 * ns
    for q in range(1, nb):
        u = q / nb
        a0 = (1 - u) * (1 - u)
        a1 = 2 * u * (1 - u)
        a2 = u * u
        px = a0 * A[0] + a1 * T[0] + a2 * Tn[0]
        py = a0 * A[1] + a1 * T[1] + a2 * Tn[1]
        pz = a0 * A[2] + a1 * T[2] + a2 * Tn[2]
        wcost, c, d2, pos = _sample_cost(C, R, w, hb, px, py, pz, radius, margin, ww)
        cost += wcost
        cmin = min(cmin, c)
        hb = pos
    out[1] = cmin
    return cost


@njit(cache=True)
def plan_kernel(C, R, w, sp, start, T0, g0, V, L, c, s, prm, beam, dpos, ddir, codes_out, pos_out, clr_out):
    """Codes of the trail's ``V`` vertices (search indices), planned by a beam search over all of them.

    prm = (radius, margin, w_wall, w_center, w_along, samples per piece). Each
    member of the beam is a trail so far (its last two vertices, the last
    piece's frame, its cost, where along the centerline its last vertex is);
    each is extended by the five codes, scored by :func:`_extend_cost`, and the
    ``beam`` cheapest distinct trails are kept (two trails whose last vertex and
    frame are within ``dpos`` mm and ``ddir`` are one). The cheapest trail at
    the end is returned, with each vertex's nearest centerline position and the
    smallest clearance of what was scored when it was laid.
    """
    radius, margin, ww, wc, wa = prm[0], prm[1], prm[2], prm[3], prm[4]
    ns = int(prm[5])
    B = beam
    bT = np.empty((B, 3))
    bA = np.empty((B, 3))
    bG = np.empty((B, 3, 3))
    bC = np.empty(B)
    bH = np.empty(B)
    cT = np.empty((5 * B, 3))
    cA = np.empty((5 * B, 3))
    cG = np.empty((5 * B, 3, 3))
    cC = np.empty(5 * B)
    cH = np.empty(5 * B)
    cM = np.empty(5 * B)
    cPar = np.zeros(5 * B, dtype=np.int64)
    cAct = np.zeros(5 * B, dtype=np.int64)
    par = np.zeros((V, B), dtype=np.int64)
    act = np.zeros((V, B), dtype=np.int64)
    hpos = np.zeros((V, B))
    hclr = np.zeros((V, B))
    keep = np.zeros(5 * B, dtype=np.int64)
    G = np.empty((3, 3))
    Tn = np.empty(3)
    out = np.empty(2)
    for b in range(3):
        bT[0, b] = T0[b]
        bA[0, b] = T0[b] - L * start[2, b]
        for a in range(3):
            bG[0, a, b] = start[a, b]
    bC[0] = 0.0
    bH[0] = g0
    nm = 1
    for m in range(V):
        k = 0
        for q in range(nm):
            for a in range(5):
                tilt_frame(bG[q], a, c, s, G)
                for b in range(3):
                    Tn[b] = bT[q, b] + L * G[2, b]
                cost = bC[q] + _extend_cost(C, R, w, bA[q], bT[q], Tn, bH[q], L, sp, radius, margin, ww, wc, wa,
                                            ns, out)
                for b in range(3):
                    cT[k, b] = Tn[b]
                    cA[k, b] = bT[q, b]
                    for e in range(3):
                        cG[k, e, b] = G[e, b]
                cC[k] = cost
                cH[k] = out[0]
                cM[k] = out[1]
                cPar[k] = q
                cAct[k] = a
                k += 1
        order = stable_argsort(cC, k)
        nk = 0
        for r in range(k):
            i = order[r]
            dup = False
            for u in range(nk):
                j = keep[u]
                dp = 0.0
                dd = 0.0
                for b in range(3):
                    dp += (cT[i, b] - cT[j, b]) ** 2
                    for e in range(3):
                        dd += (cG[i, e, b] - cG[j, e, b]) ** 2
                if dp < dpos * dpos and dd < ddir * ddir:
                    dup = True
                    break
            if not dup:
                keep[nk] = i
                nk += 1
                if nk == B:
                    break
        for u in range(nk):
            i = keep[u]
            for b in range(3):
                bT[u, b] = cT[i, b]
                bA[u, b] = cA[i, b]
                for e in range(3):
                    bG[u, e, b] = cG[i, e, b]
            bC[u] = cC[i]
            bH[u] = cH[i]
            par[m, u] = cPar[i]
            act[m, u] = cAct[i]
            hpos[m, u] = cH[i]
            hclr[m, u] = cM[i]
        nm = nk
    q = 0
    for m in range(V - 1, -1, -1):
        codes_out[m] = act[m, q]
        pos_out[m] = hpos[m, q]
        clr_out[m] = hclr[m, q]
        q = par[m, q]
    return bC[0]


def _plan_args(tube: Tube, robot, settings: dict) -> tuple:
    L = float(robot.module_length)
    ns = max(1, int(math.ceil(L / PLAN_SAMPLE_MM)))
    prm = np.array([float(robot.robot_radius), float(settings["margin"]), float(settings["wall_weight"]),
                    float(settings["center_weight"]), float(settings["along_weight"]), float(ns)])
    return L, prm


def plan_trail(tube: Tube, robot, settings: dict, vertices: int, start_direction, start_point) -> np.ndarray:
    """The trail's codes (module codes 0, 3, 6, 12, 9), one per vertex, planned by :func:`plan_kernel`.

    ``settings``: ``margin``, ``wall_weight``, ``center_weight``, ``along_weight`` (as ``--solver lumen``'s) and
    ``trail_beam``.
    """
    L, prm = _plan_args(tube, robot, settings)
    a = math.radians(robot.alpha)
    start = base_frame(start_direction)
    idx = np.zeros(vertices, dtype=np.int64)
    pos = np.zeros(vertices)
    clr = np.zeros(vertices)
    plan_kernel(tube.points, tube.radius, float(tube.window), float(tube.spacing), start,
                np.asarray(start_point, dtype=np.float64), float(tube.pre), int(vertices), L, math.cos(a),
                math.sin(a), prm, int(settings["trail_beam"]), TRAIL_DEDUP[0], TRAIL_DEDUP[1], idx, pos, clr)
    return SEARCH_CODES[idx]


def plan_trail_numpy(tube: Tube, robot, settings: dict, vertices: int, start_direction, start_point) -> np.ndarray:
    """:func:`plan_trail` in numpy (the reference): the same beam, the same samples, the same ties."""
    L, prm = _plan_args(tube, robot, settings)
    radius, margin, ww, wc, wa, nsf = prm
    ns = int(nsf)
    a = math.radians(robot.alpha)
    ca, sa = math.cos(a), math.sin(a)
    C, Rr, w, sp = tube.points, tube.radius, float(tube.window), float(tube.spacing)
    M = C.shape[0]

    def near(g: float, p: np.ndarray) -> tuple[float, float, float]:
        lo, hi = max(0, int(g - w)), min(M - 1, int(g + w) + 1)
        hi = max(hi, lo + 1)
        gi = min(max(int(g), lo), hi - 1)
        A, U = C[lo:hi], C[lo + 1:hi + 1] - C[lo:hi]
        t = np.clip(np.einsum("ij,ij->i", p - A, U) / np.einsum("ij,ij->i", U, U), 0.0, 1.0)
        d2 = np.sum((p - (A + t[:, None] * U)) ** 2, axis=1)
        # the kernel's outward scan from gi stops at the first local minimum on each side
        a_, b_ = max(0, gi - lo - 2), min(hi - lo, gi - lo + 3)
        while True:
            k = a_ + int(np.argmin(d2[a_:b_]))
            grown = False
            if k == a_ and a_ > 0:
                na = max(0, a_ - 3)
                if np.min(d2[na:a_]) < d2[k]:
                    a_, grown = na, True
                else:
                    a_ = na
            if not grown and k == b_ - 1 and b_ < hi - lo:
                nb = min(hi - lo, b_ + 3)
                if np.min(d2[b_:nb]) < d2[k]:
                    b_, grown = nb, True
                else:
                    b_ = nb
            if not grown:
                break
        k = a_ + int(np.argmin(d2[a_:b_]))
        c = Rr[lo + k] + t[k] * (Rr[lo + k + 1] - Rr[lo + k]) - radius - math.sqrt(d2[k])
        return c, float(d2[k]), lo + k + float(t[k])

    def wallc(c: float) -> float:
        return ww * (margin - c) ** 2 if margin - c > 0 else 0.0

    def tilt(F: np.ndarray, k: int) -> np.ndarray:
        out = np.empty((3, 3))
        tilt_frame(F, k, ca, sa, out)
        return out

    start = base_frame(start_direction)
    T0 = np.asarray(start_point, dtype=np.float64)
    beam: list[Any] = [(0.0, T0 - L * start[2], T0, start, float(tube.pre), [])]
    for _ in range(vertices):
        cands = []
        for cost, A, T, F, g, hist in beam:
            for k in range(5):
                G = tilt(F, k)
                Tn = T + L * G[2]
                j, h = cost, g
                for q in range(1, ns + 1):
                    c, d2, h = near(h, T + q / ns * (Tn - T))
                    j += wallc(c)
                    if q == ns:
                        j += wc * d2 + wa * ((h - g) * sp - L) ** 2
                hn = h
                hb = g - 0.5 * L / sp
                for q in range(1, 2 * ns):
                    u = q / (2 * ns)
                    c, d2, hb = near(hb, (1 - u) ** 2 * A + 2 * u * (1 - u) * T + u * u * Tn)
                    j += wallc(c)
                cands.append((j, T, Tn, G, hn, hist + [k]))
        order = sorted(range(len(cands)), key=lambda i: cands[i][0])
        kept: list = []
        for i in order:
            cd = cands[i]
            if any(np.sum((cd[2] - o[2]) ** 2) < TRAIL_DEDUP[0] ** 2 and np.sum((cd[3] - o[3]) ** 2)
                   < TRAIL_DEDUP[1] ** 2 for o in kept):
                continue
            kept.append(cd)
            if len(kept) == int(settings["trail_beam"]):
                break
        beam = [(j, T, Tn, G, h, hist) for j, T, Tn, G, h, hist in kept]
    return SEARCH_CODES[np.array(beam[0][5], dtype=np.int64)]


@njit(cache=True)
def _vertices_kernel(T0, start, idx, back, L, c, s, T):
    """T[back + m] for m = -back .. V: straight behind T0 along start's z, then the codes' pieces."""
    V = idx.shape[0]
    for m in range(back + 1):
        for b in range(3):
            T[back - m, b] = T0[b] - m * L * start[2, b]
    F = start.copy()
    G = np.empty((3, 3))
    for m in range(V):
        tilt_frame(F, idx[m], c, s, G)
        for b in range(3):
            T[back + m + 1, b] = T[back + m, b] + L * G[2, b]
            for a in range(3):
                F[a, b] = G[a, b]


_IDX = {int(code): k for k, code in enumerate(SEARCH_CODES)}


def trail_vertices(codes: np.ndarray, start_direction, start_point, module_length: float, alpha: float,
                   back: int) -> np.ndarray:
    """(back + V + 1, 3): the trail's vertices, row ``back + m`` being vertex ``m`` (m = -back .. V)."""
    idx = np.array([_IDX[int(c)] for c in codes], dtype=np.int64)
    a = math.radians(alpha)
    T = np.empty((back + len(idx) + 1, 3))
    _vertices_kernel(np.asarray(start_point, dtype=np.float64), base_frame(start_direction), idx, int(back),
                     float(module_length), math.cos(a), math.sin(a), T)
    return T
