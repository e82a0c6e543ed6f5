"""The whole robot as it can be built: rigid modules whose joints are driven by their wires (docs/locomotion.md).

The trail (:mod:`bhr.solvers._trail`, the planner) gives one code per vertex. At an
insertion of ``p`` whole module lengths module ``i`` of the robot (0 = the
tail) holds the code of trail vertex ``p - M + i``, so the robot of rigid
modules lies exactly on the trail. Between ``p`` and ``p + 1`` the feeder
pushes the tail one module length along the insertion axis and every joint
switches from its code at ``p`` to its code at ``p + 1``; what happens in
between is physics, not interpolation:

* each wire's normalised temperature ``theta`` follows the board's drive
  (:mod:`bhr._hardware.thermal`: full power until theta = 1, then the hold;
  unpowered, it cools with the same time constant; a released wire is not
  energised again before it has relaxed);
* its contraction fraction follows theta through the transformation's
  hysteresis (:func:`bhr.model._wires.transform_thetas`: contraction between
  As and Af on heating, relaxation between Ms and Mf on cooling, half-cosine
  branches, a play operator between them);
* the joint's tilt is the rotation vector ``alpha * sum_k s_k d_k`` in the
  module's local axes, wire ``k`` pulling along ``d_1 = (x - y)/2``,
  ``d_2 = (x + y)/2``, ``d_3 = (-x + y)/2``, ``d_4 = (-x - y)/2``: every
  code gives exactly its tilt (wires 1+2 about +x, ...), all four none, and
  ``|tilt| <= alpha`` always;
* the modules are rigid and their full length; the tail lies in the feeder,
  straight along the insertion axis.

What the board can schedule is a :class:`Strategy`: when the feeder moves
(before, during or after the switch, or half before and half after), which
joints switch together (all at once, or in groups from the tip or from the
tail) and whether the new wires' heating is delayed so that they contract
while the old ones relax. The planner (:func:`plan_motion`) tries every
strategy of :data:`STRATEGIES` on every module length and keeps the one whose
joints stay clearest of the wall; the chosen motion is then written densely
enough that no joint moves more than :data:`MAX_JOINT_STEP_MM` between two
poses, and every pose is scored against the lumen (joints and modules,
:func:`score_kernel`; a joint or module that cannot have come nearer the wall
than its step's worst or its pose's worst since it was last scored is not
scored again), or, where the colon has a surface mesh that encloses its
centerline, against that surface (:func:`bhr.model._wallmesh.mesh_pose_kernel`,
the same rule as a head run's: :func:`bhr.model._wallmesh.wall_grid`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from bhr.model._tube import Tube, locate_inline, locate_kernel, search_window
from bhr._run.clearance import module_exact_inline
from bhr.model._wires import DEFAULT_THERMAL, ThermalParams, transform_thetas
from bhr._settings.errors import BhrError
from bhr._settings.inputs import check_step_points

__all__ = ["Strategy", "STRATEGIES", "MotionRun", "plan_motion", "wires_motion", "motion_report", "contraction",
           "joint_tilts", "chain_poses",
           "wire_states", "MAX_JOINT_STEP_MM", "FEED_MM_S", "POSES_FILE", "code_wires", "WIRE_DIRECTIONS"]

#: No joint moves more than this (mm) between two written poses (the contract is 2 mm; kept below it).
MAX_JOINT_STEP_MM = 1.9
#: The feeder's speed while it moves (mm/s).
FEED_MM_S = 5.0
#: Samples per switching window when the planner compares strategies.
PLAN_SAMPLES = 8
#: Modules whose samples come this close to the wall (mm) are refined (golden section) when scored.
NEAR_MM = 2.0
#: How fast a point's clearance can change as it moves (mm per mm): 1 for the distance to the centerline, more where
#: the lumen's radius changes along it (the nearest centerline point can run ahead of the point in a bend).
LIPSCHITZ = 2.0
#: Golden-section steps refining a module's worst sample (its bracket of two sample spacings shrinks 0.618 per step).
REFINE_STEPS = 8
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0
#: Robot points (poses x joints) a run keeps to write poses.npz (about 48 bytes each with the tilts and codes).
POSE_POINTS_LIMIT = 6_000_000
#: The file beside run.json with every pose of the whole robot.
POSES_FILE = "poses.npz"
#: Wire k's pull on the joint's tilt, in the module's local (x, y) axes (times alpha).
WIRE_DIRECTIONS = np.array([[0.5, -0.5], [0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5]])


def code_wires(code: int) -> tuple[int, int, int, int]:
    """The four wires (1 = on) of a module code (bit k-1: wire k)."""
    c = int(code)
    return (c & 1, (c >> 1) & 1, (c >> 2) & 1, (c >> 3) & 1)


# ---------------------------------------------------------------------------
# one wire: temperature and contraction in time


@njit(cache=True)
def contraction(s, th, a_s, a_f, m_s, m_f):
    """Contraction fraction after the temperature moved monotonically to ``th`` from a state of fraction ``s``
    (the play hysteresis between the heating branch As..Af and the cooling branch Mf..Ms, half cosines)."""
    if th <= a_s:
        heat = 0.0
    elif th >= a_f:
        heat = 1.0
    else:
        heat = 0.5 - 0.5 * math.cos(math.pi * (th - a_s) / (a_f - a_s))
    if th >= m_s:
        cool = 1.0
    elif th <= m_f:
        cool = 0.0
    else:
        cool = 0.5 - 0.5 * math.cos(math.pi * (th - m_f) / (m_s - m_f))
    return min(cool, max(heat, s))


@njit(cache=True)
def _wire(on_old, on_new, t_sw, t_heat, th0, s0, t, prm, out):
    """(theta, contraction) of one wire at time ``t`` (ms from the module length's start) into out."""
    tau, thf = prm[0], prm[1]
    a_s, a_f, m_s, m_f = prm[3], prm[4], prm[5], prm[6]
    if on_old and on_new:  # held through the change
        out[0] = 1.0
        out[1] = 1.0
        return
    if on_old:  # released at t_sw
        if t <= t_sw:
            out[0] = th0
            out[1] = s0
        else:
            th = th0 * math.exp(-(t - t_sw) / tau)
            out[0] = th
            out[1] = contraction(s0, th, a_s, a_f, m_s, m_f)
        return
    th = th0 * math.exp(-t / tau)
    if on_new and t > t_heat:  # energised at t_heat: full power until theta = 1, then the hold
        th1 = th0 * math.exp(-t_heat / tau)
        s1 = contraction(s0, th1, a_s, a_f, m_s, m_f)
        th = thf + (th1 - thf) * math.exp(-(t - t_heat) / tau)
        if th > 1.0:
            th = 1.0
        out[0] = th
        out[1] = contraction(s1, th, a_s, a_f, m_s, m_f)
        return
    out[0] = th
    out[1] = contraction(s0, th, a_s, a_f, m_s, m_f)


@njit(cache=True)
def _wire_s(on_old, on_new, t_sw, t_heat, th0, s0, th1, s1, c0, t, prm):
    """:func:`_wire`'s contraction (the same number) with what does not change in time computed once: ``th1``,
    ``s1`` a heating wire's theta and contraction when energised, ``c0`` an unpowered cold wire's (th0 = 0)."""
    if on_old and on_new:
        return 1.0
    tau = prm[0]
    if on_old:
        if t <= t_sw:
            return s0
        return contraction(s0, th0 * math.exp(-(t - t_sw) / tau), prm[3], prm[4], prm[5], prm[6])
    if on_new and t > t_heat:
        th = prm[1] + (th1 - prm[1]) * math.exp(-(t - t_heat) / tau)
        if th > 1.0:
            th = 1.0
        return contraction(s1, th, prm[3], prm[4], prm[5], prm[6])
    if th0 == 0.0:  # cold: theta stays 0 (0 times exp(-t/tau), t >= 0)
        return c0
    return contraction(s0, th0 * math.exp(-t / tau), prm[3], prm[4], prm[5], prm[6])


@njit(cache=True)
def _heat_start(on_old, on_new, t_sw, delay, th0, prm):
    """When a wire switched on at ``t_sw`` is energised: after the delay, and not before it has relaxed."""
    t = t_sw + delay
    if on_new and not on_old and th0 > prm[2]:
        t = max(t, prm[0] * math.log(th0 / prm[2]))
    return t


# ---------------------------------------------------------------------------
# the chain


@njit(cache=True)
def _rotate_rows_acs(F, tx, ty, a, c, s, out):
    """Frame ``F`` (rows x, y, z) turned about its own axis ``tx x + ty y`` by ``a = |(tx, ty)|`` radians, given
    ``a``, ``c = cos(a)`` and ``s = sin(a)`` (a joint that keeps its tilt turns by the same angle at every pose)."""
    if a < 1e-300:
        for r in range(3):
            for b in range(3):
                out[r, b] = F[r, b]
        return
    n0 = tx * F[0, 0] + ty * F[1, 0]
    n1 = tx * F[0, 1] + ty * F[1, 1]
    n2 = tx * F[0, 2] + ty * F[1, 2]
    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)  # the axis made unit itself: a rotation even if F has drifted
    n0 /= nn
    n1 /= nn
    n2 /= nn
    for r in range(3):
        v0, v1, v2 = F[r, 0], F[r, 1], F[r, 2]
        d = n0 * v0 + n1 * v1 + n2 * v2
        out[r, 0] = v0 * c + (n1 * v2 - n2 * v1) * s + n0 * d * (1.0 - c)
        out[r, 1] = v1 * c + (n2 * v0 - n0 * v2) * s + n1 * d * (1.0 - c)
        out[r, 2] = v2 * c + (n0 * v1 - n1 * v0) * s + n2 * d * (1.0 - c)
    # and the frame kept orthonormal (z unit, x made orthogonal to it, y = z x x): rounding cannot build up
    zn = math.sqrt(out[2, 0] ** 2 + out[2, 1] ** 2 + out[2, 2] ** 2)
    for b in range(3):
        out[2, b] /= zn
    d = out[0, 0] * out[2, 0] + out[0, 1] * out[2, 1] + out[0, 2] * out[2, 2]
    for b in range(3):
        out[0, b] -= d * out[2, b]
    xn = math.sqrt(out[0, 0] ** 2 + out[0, 1] ** 2 + out[0, 2] ** 2)
    for b in range(3):
        out[0, b] /= xn
    out[1, 0] = out[2, 1] * out[0, 2] - out[2, 2] * out[0, 1]
    out[1, 1] = out[2, 2] * out[0, 0] - out[2, 0] * out[0, 2]
    out[1, 2] = out[2, 0] * out[0, 1] - out[2, 1] * out[0, 0]


@njit(cache=True)
def _rotate_rows(F, tx, ty, out):
    """Frame ``F`` (rows x, y, z) turned about its own axis ``tx x + ty y`` by ``|(tx, ty)|`` radians."""
    a = math.sqrt(tx * tx + ty * ty)
    _rotate_rows_acs(F, tx, ty, a, math.cos(a), math.sin(a), out)


@njit(cache=True)
def chain_kernel(tail, frame, L, tilts, pts):
    """Points (M + 1, 3) of a chain of M rigid modules of length L from the tail, module i turned by tilts[i]
    (a rotation vector in the local axes of the module behind it; the tail module's relative to ``frame``)."""
    M = tilts.shape[0]
    F = frame.copy()
    G = np.empty((3, 3))
    for b in range(3):
        pts[0, b] = tail[b]
    for i in range(M):
        _rotate_rows(F, tilts[i, 0], tilts[i, 1], G)
        for r in range(3):
            for b in range(3):
                F[r, b] = G[r, b]
        for b in range(3):
            pts[i + 1, b] = pts[i, b] + L * F[2, b]


@njit(cache=True)
def ordered_moves(first, pts, order, out):
    """out[k] (K,): the largest distance a joint moves from pose k - 1 to pose k of ``pts[order]`` (``pts`` (>= K,
    J, 3), ``order`` (K,) the rows in time order; not gathered), pose -1 being ``first`` (J, 3)."""
    for k in range(order.shape[0]):
        best = 0.0
        for i in range(pts.shape[1]):
            d = 0.0
            for b in range(3):
                e = pts[order[k], i, b] - (first[i, b] if k == 0 else pts[order[k - 1], i, b])
                d += e * e
            if d > best:
                best = d
        out[k] = math.sqrt(best)


@njit(cache=True)
def _trail_at(T, back, q, out):
    """The trail's point at trail position q (module lengths; vertex m is row back + m)."""
    m = math.floor(q)
    u = q - m
    r = back + int(m)
    if r < 0:
        r = 0
        u = q + back
    if r >= T.shape[0] - 1:
        r = T.shape[0] - 2
        u = q - (r - back)
    for b in range(3):
        out[b] = T[r, b] + u * (T[r + 1, b] - T[r, b])


@njit(cache=True, inline="always")
def _hint_at(z, back, q):
    m = math.floor(q)
    u = q - m
    r = back + int(m)
    if r < 0:
        return z[0] + (q + back) * (z[1] - z[0])
    if r >= z.shape[0] - 1:
        r = z.shape[0] - 2
        u = q - (r - back)
    return z[r] + u * (z[r + 1] - z[r])


@njit(cache=True)
def motion_kernel(times, xs, tsw, delay, th0, s0, on_old, on_new, code_old, code_new, prm, start, axis, frame, L,
                  alpha, T, back, z, tube_c, tube_r, S, BC, BR, pre, w, radius, out_pts, out_tilt, out_code,
                  out_dev, out_clear):
    """Poses of the whole robot at ``times`` (ms) while the feeder is at insertions ``xs`` (mm) and module i
    switches at ``tsw[i]`` (its old wires released; the new ones energised ``delay`` later): points (K, M+1, 3)
    tail first, tilts (K, M, 2), codes commanded (K, M), each pose's largest distance of a joint from the trail
    (K,) and, when ``radius >= 0``, its joints' smallest clearance (K,) (NaN when none is in the lumen)."""
    K = times.shape[0]
    M = tsw.shape[0]
    tilt = np.empty((M, 2))
    tail = np.empty(3)
    tp = np.empty(3)
    res = np.empty(4)
    steady = np.empty((M, 2))
    moving = np.zeros(M, dtype=np.bool_)
    theat = np.empty((M, 4))
    exact = np.ones(M, dtype=np.bool_)
    # what does not change in time, computed once (the same numbers as computing it at every pose): each wire's
    # state when energised (th1, s1) and cold (c0) (_wire_s); each steady joint's turn (its angle, cos, sin)
    th1 = np.empty((M, 4))
    s1 = np.empty((M, 4))
    c0 = np.empty((M, 4))
    acs = np.empty((M, 3))
    for i in range(M):
        for k in range(4):
            if on_old[i, k] != on_new[i, k]:
                moving[i] = True
            theat[i, k] = _heat_start(on_old[i, k], on_new[i, k], tsw[i], delay, th0[i, k], prm)
            th1[i, k] = th0[i, k] * math.exp(-theat[i, k] / prm[0])
            s1[i, k] = contraction(s0[i, k], th1[i, k], prm[3], prm[4], prm[5], prm[6])
            c0[i, k] = contraction(s0[i, k], 0.0, prm[3], prm[4], prm[5], prm[6])
        steady[i, 0] = 0.0
        steady[i, 1] = 0.0
        for k in range(4):
            if s0[i, k] != (1.0 if on_old[i, k] else 0.0):
                exact[i] = False
            if on_old[i, k]:
                steady[i, 0] += alpha * WIRE_DIRECTIONS[k, 0]
                steady[i, 1] += alpha * WIRE_DIRECTIONS[k, 1]
        a = math.sqrt(steady[i, 0] * steady[i, 0] + steady[i, 1] * steady[i, 1])
        acs[i, 0], acs[i, 1], acs[i, 2] = a, math.cos(a), math.sin(a)
    # chain_kernel's frames (Fs[i + 1]: module i's), kept from pose to pose: behind the first joint whose tilt is not
    # the one it had at the pose before, they are the same (and the steady joints' tilts are the same throughout)
    Fs = np.empty((M + 1, 3, 3))
    Fs[0] = frame
    tilt_prev = np.full((M, 2), np.nan)
    for j in range(K):
        t = times[j]
        for i in range(M):
            if not moving[i] and exact[i]:
                tilt[i, 0] = steady[i, 0]
                tilt[i, 1] = steady[i, 1]
            else:
                tx = 0.0
                ty = 0.0
                for k in range(4):
                    sk = _wire_s(on_old[i, k], on_new[i, k], tsw[i], theat[i, k], th0[i, k], s0[i, k], th1[i, k],
                                 s1[i, k], c0[i, k], t, prm)
                    tx += WIRE_DIRECTIONS[k, 0] * sk
                    ty += WIRE_DIRECTIONS[k, 1] * sk
                tilt[i, 0] = alpha * tx
                tilt[i, 1] = alpha * ty
            out_tilt[j, i, 0] = tilt[i, 0]
            out_tilt[j, i, 1] = tilt[i, 1]
            out_code[j, i] = code_new[i] if t > tsw[i] else code_old[i]
        for b in range(3):
            tail[b] = start[b] + (xs[j] - M * L) * axis[b]
        # chain_kernel, the same numbers: the frames behind the first joint that turned since the pose before kept,
        # the steady joints' turns known
        i1 = M
        for i in range(M):
            if not (tilt[i, 0] == tilt_prev[i, 0] and tilt[i, 1] == tilt_prev[i, 1]):
                i1 = i
                break
        for i in range(i1, M):
            if not moving[i] and exact[i]:
                _rotate_rows_acs(Fs[i], tilt[i, 0], tilt[i, 1], acs[i, 0], acs[i, 1], acs[i, 2], Fs[i + 1])
            else:
                a = math.sqrt(tilt[i, 0] * tilt[i, 0] + tilt[i, 1] * tilt[i, 1])
                _rotate_rows_acs(Fs[i], tilt[i, 0], tilt[i, 1], a, math.cos(a), math.sin(a), Fs[i + 1])
            tilt_prev[i, 0] = tilt[i, 0]
            tilt_prev[i, 1] = tilt[i, 1]
        P = out_pts[j]
        for b in range(3):
            P[0, b] = tail[b]
        for i in range(M):
            for b in range(3):
                P[i + 1, b] = P[i, b] + L * Fs[i + 1, 2, b]
        dev = 0.0
        best = np.inf
        for i in range(M + 1):
            q = xs[j] / L - M + i
            _trail_at(T, back, q, tp)
            d = 0.0
            for b in range(3):
                d += (out_pts[j, i, b] - tp[b]) ** 2
            if d > dev:
                dev = d
            if radius >= 0.0 and q >= 0.0:
                zz = _hint_at(z, back, q)
                lo, hi = search_window(tube_c.shape[0], zz, w)
                locate_kernel(tube_c, tube_r, S, BC, BR, radius, lo, hi, zz, out_pts[j, i, 0], out_pts[j, i, 1],
                              out_pts[j, i, 2], res)
                c = res[1] - radius - res[0]
                if c < best:
                    best = c
        out_dev[j] = math.sqrt(dev)
        out_clear[j] = best if best < np.inf else np.nan


@njit(cache=True)
def end_state(t, tsw, delay, th0, s0, on_old, on_new, prm, th_out, s_out):
    """Every wire's (theta, contraction) at time t of the module length: the next one's start."""
    wst = np.empty(2)
    for i in range(tsw.shape[0]):
        for k in range(4):
            th = _heat_start(on_old[i, k], on_new[i, k], tsw[i], delay, th0[i, k], prm)
            _wire(on_old[i, k], on_new[i, k], tsw[i], th, th0[i, k], s0[i, k], t, prm, wst)
            th_out[i, k] = wst[0]
            s_out[i, k] = wst[1]


@njit(cache=True)
def _clear_along(pts, j, m, Z, fj, t, tube_c, tube_r, S, BC, BR, w, radius, res, whole):
    """Clearance of the point at fraction t along module m of pose j (searched around where its ends were found)."""
    px = pts[j, m, 0] + t * (pts[j, m + 1, 0] - pts[j, m, 0])
    py = pts[j, m, 1] + t * (pts[j, m + 1, 1] - pts[j, m, 1])
    pz = pts[j, m, 2] + t * (pts[j, m + 1, 2] - pts[j, m, 2])
    lo, hi = search_window(tube_c.shape[0], fj[m] + t * (fj[m + 1] - fj[m]), w)
    locate_kernel(tube_c, tube_r, S, BC, BR, radius, lo, hi, Z[m] + t * (Z[m + 1] - Z[m]), px, py, pz, res, whole)
    return res[1] - radius - res[0]


@njit(cache=True)
def _sample_module(pts, j, m, E, Z, fj, cj, L, tube_c, tube_r, S, BC, BR, w, radius, sample, near, res, whole):
    """Module m of pose j sampled at most ``sample`` mm apart (ends and middle when both ends are far from the
    wall), its ends' clearances ``cj`` (scored as joints): (smallest clearance, where along it (0..1), the
    samples' spacing (0..1), where its scored part starts (0..1), crossed flag); inf when no part of it is in the
    colon."""
    ns = int(math.ceil(L / sample))
    if E[m] >= 0.0 and min(cj[m], cj[m + 1]) - 0.5 * L > near + 1.0:
        ns = 2  # both ends far from the wall: so is all of it (the clearance is 1-Lipschitz); ends and middle
    lo_t = 0.0 if E[m] >= 0.0 else (-E[m]) / (E[m + 1] - E[m])
    v = np.inf
    bt = 0.0
    crossed = 0.0
    for k in range(ns + 1):
        t = k / ns
        if t < lo_t:
            continue
        if k == 0:
            c = cj[m]
        elif k == ns:
            c = cj[m + 1]
        else:
            c = _clear_along(pts, j, m, Z, fj, t, tube_c, tube_r, S, BC, BR, w, radius, res, whole)
            if res[3] > crossed:
                crossed = res[3]
        if c < v:
            v = c
            bt = t
    return v, bt, 1.0 / ns, lo_t, crossed


@njit(cache=True)
def _refine_module(pts, j, m, Z, fj, tube_c, tube_r, S, BC, BR, w, radius, v, bt, dt, lo_t, res, whole):
    """The worst sample ``v`` at ``bt`` of module m refined by a golden-section search between its neighbours
    (``dt`` apart): (the smallest clearance found, where along the module (0..1), crossed flag)."""
    a = max(bt - dt, lo_t)
    b = min(bt + dt, 1.0)
    crossed = 0.0
    x1 = b - _GOLD * (b - a)
    x2 = a + _GOLD * (b - a)
    f1 = _clear_along(pts, j, m, Z, fj, x1, tube_c, tube_r, S, BC, BR, w, radius, res, whole)
    crossed = max(crossed, res[3])
    f2 = _clear_along(pts, j, m, Z, fj, x2, tube_c, tube_r, S, BC, BR, w, radius, res, whole)
    crossed = max(crossed, res[3])
    for _ in range(REFINE_STEPS):
        if f1 < f2:
            b = x2
            x2 = x1
            f2 = f1
            x1 = b - _GOLD * (b - a)
            f1 = _clear_along(pts, j, m, Z, fj, x1, tube_c, tube_r, S, BC, BR, w, radius, res, whole)
        else:
            a = x1
            x1 = x2
            f1 = f2
            x2 = a + _GOLD * (b - a)
            f2 = _clear_along(pts, j, m, Z, fj, x2, tube_c, tube_r, S, BC, BR, w, radius, res, whole)
        crossed = max(crossed, res[3])
    if f1 < v:
        v = f1
        bt = x1
    if f2 < v:
        v = f2
        bt = x2
    return v, bt, crossed


@njit(cache=True, inline="always")
def _dist(pts, j, i, ref):
    return math.sqrt((pts[j, i, 0] - ref[i, 0]) ** 2 + (pts[j, i, 1] - ref[i, 1]) ** 2
                     + (pts[j, i, 2] - ref[i, 2]) ** 2)


@njit(cache=True, inline="always")
def _joint(pts, j, i, st, Z, w, tube_c, tube_r, S, BC, BR, radius, res, cj, fj, pc, jref, jref_c, jref_f, jhave,
           whole):
    """Joint i of pose j scored: its clearance into cj (where it was found into fj), its step's table and its
    reference for the bound; returns the crossed flag."""
    lo, hi = search_window(tube_c.shape[0], Z[i], w)
    locate_inline(tube_c, tube_r, S, BC, BR, radius, lo, hi, Z[i], pts[j, i, 0], pts[j, i, 1], pts[j, i, 2], res,
                  whole, int(jref_f[i]) if jhave[i] else -1)
    cj[i] = res[1] - radius - res[0]
    fj[i] = res[2]
    if not (pc[st, i] <= cj[i]):
        pc[st, i] = cj[i]
    jhave[i] = True
    jref_c[i] = cj[i]
    jref_f[i] = fj[i]
    for b in range(3):
        jref[i, b] = pts[j, i, b]
    return res[3]


@njit(cache=True)
def score_kernel(pts, xs, steps, L, z, back, tube_c, tube_r, S, BC, BR, N, pre, w, radius, sample, near, pc, mc,
                 mwhere, low, left, bound=True):
    """Clearance of poses (points (K, M+1, 3) tail first at insertions xs, of 0-based path steps ``steps``),
    folded into the steps' tables: each joint's smallest (N, M+1) and each module's smallest along it (N, M), and
    where (N, M, 3); ``low`` (K) each pose's smallest. A module is sampled at most ``sample`` mm apart (at its
    ends and middle when both ends are more than half its length plus ``near`` + 1 mm from the wall); the worst
    sample of one that comes within ``near`` mm of the wall is refined by a golden-section search between its
    neighbours. Points outside the anus are not scored. Returns 1.0 when a point crossed into another pass of a
    loop (:func:`bhr.model._tube.locate_kernel`).

    The clearance is 1-Lipschitz: a joint (module) that moved ``d`` mm since it was last scored is at least its
    clearance then minus ``d`` (a module: minus the larger of its ends' moves). A joint or module whose bound
    cannot lower its step's table entry nor the pose's smallest is not scored again (nor one that might have
    crossed into another pass: deeper than the robot's radius). The tables and ``low`` are those of scoring
    everything (``bound`` False: the reference), at a fraction of the cost while the joints switch and the
    feeder waits.

    ``left`` (1,) is 1.0 once the robot has left the lumen (a pose's smallest below minus the radius), kept
    from call to call. From then on the run's verdict is set: a point is measured against the
    stretch of lumen it is in, the whole centerline no longer searched for another pass of a loop it might be
    nearer to (:func:`bhr.model._tube.locate_kernel`'s ``whole``), and a module gets its exact minimum against
    that stretch where it can (:func:`bhr._run.clearance.module_exact_kernel`; ``N`` the centerline's mitre
    normals) instead of being sampled and refined."""
    K = pts.shape[0]
    J = pts.shape[1]
    M = J - 1
    E = np.empty(J)
    Z = np.empty(J)
    cj = np.empty(J)
    fj = np.empty(J)
    res = np.empty(4)
    # the last scoring of each joint (where, its clearance, where it was found) and module (its ends, a lower bound)
    jref = np.empty((J, 3))
    jref_c = np.empty(J)
    jref_f = np.empty(J)
    jhave = np.zeros(J, dtype=np.bool_)
    mref_b = np.empty((J, 3))  # row m + 1: module m's front end at its last scoring
    mref_a = np.empty((M, 3))
    mref_c = np.empty(M)
    mhave = np.zeros(M, dtype=np.bool_)
    jlb = np.empty(J)  # this pose: a joint's lower bound when it was not scored (inf: scored)
    mlb = np.empty(M)  # a module's lower bound when not scored or not refined (inf: done)
    mv = np.empty(M)  # a sampled but unrefined module: its worst sample, where, the spacing, its scored part
    mt = np.empty(M)
    mdt = np.empty(M)
    mlo = np.empty(M)
    crossed = 0.0
    gone = left[0] > 0.0
    for j in range(K):
        st = steps[j]
        best = np.inf
        for i in range(J):
            jlb[i] = np.inf
            q = xs[j] / L - M + i
            Z[i] = _hint_at(z, back, q)
            if q < 0.0:
                E[i] = -1.0
                cj[i] = np.nan
                fj[i] = Z[i]
                jhave[i] = False
                continue
            E[i] = Z[i] - pre
            if bound and jhave[i]:
                lb = jref_c[i] - LIPSCHITZ * _dist(pts, j, i, jref)
                if pc[st, i] <= lb and (lb > -radius):
                    jlb[i] = lb
                    cj[i] = lb
                    fj[i] = jref_f[i]
                    continue
            crossed = max(crossed, _joint(pts, j, i, st, Z, w, tube_c, tube_r, S, BC, BR, radius, res, cj, fj, pc,
                                          jref, jref_c, jref_f, jhave, not gone))
            best = min(best, cj[i])
        for phase in range(2):
            for m in range(M):
                if phase == 0:
                    mlb[m] = np.inf
                    if E[m] < 0.0 and E[m + 1] < 0.0:
                        continue
                    if bound and E[m] >= 0.0 and mhave[m]:
                        lb = mref_c[m] - LIPSCHITZ * max(_dist(pts, j, m, mref_a), _dist(pts, j, m + 1, mref_b))
                        if mc[st, m] <= lb and (lb > -radius):
                            mlb[m] = lb
                            mv[m] = np.nan
                            continue
                    v = np.nan
                elif not (mlb[m] < best):  # what was not scored, or not refined, and could be this pose's smallest
                    continue
                else:
                    v = mv[m]
                if np.isnan(v):
                    for i in range(m, m + 2):  # its ends scored as joints
                        if jlb[i] < np.inf:
                            crossed = max(crossed, _joint(pts, j, i, st, Z, w, tube_c, tube_r, S, BC, BR, radius,
                                                          res, cj, fj, pc, jref, jref_c, jref_f, jhave, not gone))
                            jlb[i] = np.inf
                            best = min(best, cj[i])
                    if gone and E[m] >= 0.0 and module_exact_inline(
                            tube_c, tube_r, N, radius, pts[j, m, 0], pts[j, m, 1], pts[j, m, 2], pts[j, m + 1, 0],
                            pts[j, m + 1, 1], pts[j, m + 1, 2], fj[m], fj[m + 1], cj[m], cj[m + 1], res, -np.inf):
                        v, bt, dt, lo_t = res[0], res[1], 0.0, 0.0  # its exact minimum, in the stretch it is in
                    else:
                        v, bt, dt, lo_t, c = _sample_module(pts, j, m, E, Z, fj, cj, L, tube_c, tube_r, S, BC, BR, w,
                                                            radius, sample, near, res, not gone)
                        crossed = max(crossed, c)
                    if v == np.inf:
                        continue
                    if bound and v <= near and phase == 0 and mc[st, m] <= v - 0.5 * dt * L and (
                            v - 0.5 * dt * L > -radius):
                        # its refinement cannot lower the table: only, perhaps, this pose's smallest
                        mlb[m] = v - 0.5 * dt * L
                        mv[m], mt[m], mdt[m], mlo[m] = v, bt, dt, lo_t
                        best = min(best, v)
                        continue
                else:
                    bt, dt, lo_t = mt[m], mdt[m], mlo[m]
                if v <= near and dt > 0.0:
                    v, bt, c = _refine_module(pts, j, m, Z, fj, tube_c, tube_r, S, BC, BR, w, radius, v, bt, dt, lo_t,
                                              res, not gone)
                    crossed = max(crossed, c)
                mlb[m] = np.inf
                best = min(best, v)
                if not (mc[st, m] <= v):
                    mc[st, m] = v
                    for b in range(3):
                        mwhere[st, m, b] = pts[j, m, b] + bt * (pts[j, m + 1, b] - pts[j, m, b])
                mhave[m] = E[m] >= 0.0
                mref_c[m] = v - 0.5 * dt * L  # the module's least clearance (at most half a spacing from a sample)
                for b in range(3):
                    mref_a[m, b] = pts[j, m, b]
                    mref_b[m + 1, b] = pts[j, m + 1, b]
            if phase == 0:
                for i in range(J):
                    if jlb[i] < best:
                        crossed = max(crossed, _joint(pts, j, i, st, Z, w, tube_c, tube_r, S, BC, BR, radius, res,
                                                      cj, fj, pc, jref, jref_c, jref_f, jhave, not gone))
                        jlb[i] = np.inf
                        best = min(best, cj[i])
        low[j] = best if best < np.inf else np.nan
        if best < -radius:
            gone = True
    if gone:
        left[0] = 1.0
    return crossed


# ---------------------------------------------------------------------------
# what the board can schedule


@dataclass(frozen=True)
class Strategy:
    """How one module length of insertion is done.

    ``order``: ``together`` (every joint that changes switches at once), ``tip-first`` or ``tail-first`` (the
    changing joints in ``groups`` waves along the robot, one after the other). ``feed``: the share of the
    module length the feeder pushes before the switch (0 switch then feed, 1 feed then switch), or ``-1`` to
    push while the joints switch. ``delay``: the new wires are energised this share of the way into the old
    ones' relaxation (0: both at once; ``1``: so that the new wires contract while the old ones relax).
    """

    name: str
    order: str = "together"
    groups: int = 1
    feed: float = 0.5
    delay: float = 0.0


STRATEGIES: tuple[Strategy, ...] = (
    Strategy("switch-then-feed", feed=0.0),
    Strategy("feed-then-switch", feed=1.0),
    Strategy("half-feed", feed=0.5),
    Strategy("feed-while-switching", feed=-1.0),
    Strategy("half-feed-aligned", feed=0.5, delay=1.0),
    Strategy("feed-while-switching-aligned", feed=-1.0, delay=1.0),
    Strategy("tip-first-4", order="tip-first", groups=4, feed=0.5, delay=1.0),
    Strategy("tail-first-4", order="tail-first", groups=4, feed=0.5, delay=1.0),
)


def wire_prm(params: ThermalParams) -> np.ndarray:
    """(tau ms, theta_full, theta_relax, As, Af, Ms, Mf) of the wire (the kernels' constants)."""
    a_s, a_f, m_s, m_f = transform_thetas(params)
    return np.array([params.tau_ms, params.theta_full, params.theta_relax, a_s, a_f, m_s, m_f])


def switch_times(params: ThermalParams) -> tuple[float, float]:
    """(window, aligned delay) in ms: how long a group of joints takes to switch (the old wires relaxed, the new
    ones contracted from cold) and the heating delay that puts the new wires' contraction mid-way onto the old
    wires' relaxation."""
    prm = wire_prm(params)
    tau, thf, tr, a_s, a_f, m_s, m_f = prm
    relax = tau * math.log(1.0 / m_f)
    contract = tau * math.log(thf / (thf - 1.0))  # from ambient (theta 0): contract_ms
    mid_cool = tau * math.log(1.0 / (0.5 * (m_s + m_f)))
    mid_heat = tau * math.log((thf - tr) / (thf - 0.5 * (a_s + a_f)))
    delay = max(0.0, mid_cool - mid_heat)
    return max(relax, delay + contract), delay


def schedule(strategy: Strategy, changing: np.ndarray, L: float, feed: float, window: float, delay_ms: float,
             samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, float]:
    """(times ms, the feeder's curve (times ms, insertions mm within the module length), switch time per module ms,
    heating delay ms, end ms)."""
    M = changing.shape[0]
    idx = np.flatnonzero(changing)
    G = min(max(1, strategy.groups), max(1, idx.size)) if idx.size else 0
    tsw = np.full(M, np.inf)
    t_feed = 1000.0 * L / FEED_MM_S
    phase = strategy.feed
    t0 = 0.0 if phase < 0 else phase * t_feed
    if G:
        parts = np.array_split(idx[::-1] if strategy.order == "tip-first" else idx, G)
        for g, part in enumerate(parts):
            tsw[part] = t0 + g * window
    t1 = t0 + G * window
    if phase < 0:
        end = max(t1, t_feed)
        bt, bx = np.array([0.0, end]), np.array([0.0, L])
    else:
        end = t1 + (1.0 - phase) * t_feed
        bt = np.array([0.0, t0, t1, end])
        bx = np.array([0.0, phase * L, phase * L, L])
    # the feed sampled at every step of the path (and finer when a step is longer than a joint may move)
    sub = int(math.ceil(feed / MAX_JOINT_STEP_MM - 1e-9))
    dx = feed / max(1, sub)
    nx = int(round(L / dx))
    xs_feed = np.arange(nx + 1) * dx
    tf = np.interp(xs_feed, bx, bt) if phase < 0 else np.concatenate([
        np.interp(xs_feed[xs_feed <= phase * L + 1e-12], bx[:2], bt[:2]),
        np.interp(xs_feed[xs_feed >= phase * L - 1e-12], bx[2:], bt[2:])])
    tw = [tf]
    for g in range(G):
        a = t0 + g * window
        tw.append(a + window * np.arange(1, samples + 1) / samples)
    times = np.unique(np.concatenate(tw))
    return times, bt, bx, tsw, delay_ms * strategy.delay, float(end)


# ---------------------------------------------------------------------------
# a run


@dataclass
class MotionRun:
    """A run of the robot as it can be built: every pose (``poses.npz``, docs/locomotion.md) and the steps' tables.

    The poses are kept when there are at most :data:`POSE_POINTS_LIMIT` robot points in all (``kept``); the
    tables always.
    """

    t_s: np.ndarray  # (P,) s from the start
    insertion_mm: np.ndarray  # (P,) the tip's insertion along the trail (the rear end is M module lengths behind)
    points_mm: np.ndarray  # (P, M+1, 3) tail first (empty when not kept)
    tilts_rad: np.ndarray  # (P, M, 2)
    codes: np.ndarray  # (P, M) tail first
    step: np.ndarray  # (P,) 1-based path step
    strategies: list[str]  # per module length, the strategy the planner chose
    pose_clear: np.ndarray  # (P,) mm each pose's smallest clearance (NaN: nothing in the lumen)
    trail_offset_mm: np.ndarray  # (P,) the largest distance of a joint from the trail
    ends: np.ndarray  # (V,) index of each module length's last pose
    step_joints: np.ndarray  # (N, M+1, 3) each step's last pose (held once the feeder stopped), tail first
    step_codes: np.ndarray  # (N, M)
    joint_clear: np.ndarray  # (N, M+1) mm, the smallest over the step's poses, NaN outside the lumen
    module_clear: np.ndarray  # (N, M)
    module_where: np.ndarray  # (N, M, 3)
    kept: bool = True
    crossed: bool = False
    wall: str = "tube"  # what the poses were scored against (bhr.model._wallmesh.wall_grid)
    stopped_step: int | None = None  # 0-based step where ``stop_below`` ended the motion (the tables end there)
    module_length_mm: float = 0.0
    planned_steps: int = 0  # the run's steps had it not stopped at the wall: the path's and those to the cecum

    def npz(self) -> dict[str, np.ndarray]:
        """The arrays of ``poses.npz`` (docs/physics.md): ``insertion_mm`` is the feeder's, how far the rear end
        is past the entrance along the insertion axis (the feeder stops before the rear end enters)."""
        rear = self.insertion_mm - self.tilts_rad.shape[1] * self.module_length_mm
        return {"t_s": self.t_s, "insertion_mm": rear, "points_mm": self.points_mm,
                "tilts_rad": self.tilts_rad, "codes": self.codes, "step": self.step}


def plan_motion(tube: Tube, radius: float, codes: np.ndarray, T: np.ndarray, back: int, z: np.ndarray, M: int,
                L: float, feed: float, alpha_deg: float, start_point, start_direction, stop_mm: float, steps: int,
                params: ThermalParams = DEFAULT_THERMAL, strategies: tuple[Strategy, ...] | None = None,
                sample: float = 1.0, bound: bool = True, grid=None, stop_below: float | None = None,
                pose_limit: float = POSE_POINTS_LIMIT) -> MotionRun:
    """The whole robot of M rigid modules driven along the trail (``codes`` per vertex, vertices ``T`` with
    ``back`` rows before vertex 0 and their centerline hints ``z``) up to an insertion of ``stop_mm``.

    Each module length's switch is done by the strategy of ``strategies`` (default :data:`STRATEGIES`) that
    keeps the joints clearest of the wall (the first on a tie); one strategy alone is that strategy throughout.
    ``bound`` False scores every joint and module of every pose (:func:`score_kernel`'s reference).
    ``grid``: the signed-distance grid of the colon's surface (:class:`bhr.model._wallmesh.SdfGrid`) the joints'
    clearance and the poses are measured against, else (None) the ``tube``. ``stop_below`` (mm): the motion ends with
    the step in which a pose's clearance first falls below it (minus the radius: the robot left the lumen); the
    steps' tables then end there too (``stopped_step``), and are those of the whole run's first steps (a pose
    depends only on the poses before it). ``pose_limit``: the robot points (poses x joints) kept at most, the
    poses dropped (``kept`` False) past it; ``math.inf`` keeps them all.
    """
    from bhr.model._robot import base_frame

    strategies = STRATEGIES if strategies is None else strategies
    if not strategies:
        raise BhrError("give at least one switching strategy")
    a = math.radians(alpha_deg)
    prm = wire_prm(params)
    window, delay_ms = switch_times(params)
    axis = np.asarray(start_direction, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    frame = base_frame(axis)
    start = np.asarray(start_point, dtype=np.float64)
    S, BC, BR = tube.search_arrays()
    C, R, pre, w = tube.points, tube.radius, float(tube.pre), float(tube.window)
    V = codes.shape[0]
    wires = np.array([code_wires(c) for c in range(16)], dtype=np.bool_)

    def module_codes(p: int) -> np.ndarray:
        v = p - M + np.arange(M)
        out = np.zeros(M, dtype=np.int64)
        ok = (v >= 0) & (v < V)
        out[ok] = codes[v[ok]]
        out[0] = 0  # the tail module: nothing behind it but the feeder
        return out

    whole = int(math.floor(stop_mm / L + 1e-9))
    whole = min(whole, M)  # the tail reaches the anus: a feeder cannot push further
    cur = module_codes(0)
    th = np.where(wires[cur], 1.0, 0.0)
    s = th.copy()
    chunks: list[tuple] = []
    chosen: list[str] = []
    ends: list[int] = []
    clock = 0.0
    count = 0
    kept = True
    N = int(steps)
    pc = np.full((N, M + 1), np.nan)
    mc = np.full((N, M), np.nan)
    mw = np.full((N, M, 3), np.nan)
    sj = np.empty((N, M + 1, 3))
    scd = np.empty((N, M), dtype=np.int64)
    filled = -1
    crossed = 0.0
    left = np.zeros(1)  # score_kernel's: the robot has left the lumen
    prev: np.ndarray | None = None
    stopped: int | None = None

    def poses(times, bt, bx, tsw, dly, on_old, on_new, cur, nxt, p, rad):
        K = times.shape[0]
        xs = np.interp(times, bt, bx) + p * L
        out = (np.empty((K, M + 1, 3)), np.empty((K, M, 2)), np.empty((K, M), dtype=np.int64), np.empty(K),
               np.empty(K))
        motion_kernel(times, xs, tsw, dly, th, s, on_old, on_new, cur, nxt, prm, start, axis, frame, L, a, T, back,
                      z, C, R, S, BC, BR, pre, w, rad, *out)
        return (xs,) + out

    for p in range(whole + 1):
        last = p == whole
        span = L if not last else stop_mm - whole * L
        if last and span <= 1e-9:
            break
        nxt = cur if last else module_codes(p + 1)
        on_old, on_new = wires[cur], wires[nxt]
        changing = nxt != cur
        cands = (Strategy("feed", feed=1.0),) if last else strategies
        best = None
        for st in cands:
            times, bt, bx, tsw, dly, end = schedule(st, changing, L, feed, window, delay_ms, PLAN_SAMPLES)
            if last:  # the feeder stops part-way through a module length (the cecum): no joint switches
                t_feed = 1000.0 * L / FEED_MM_S
                bt, bx = np.array([0.0, t_feed]), np.array([0.0, L])
                end = t_feed * span / L
                times = np.unique(np.append(times[times < end - 1e-9], end))
            if len(cands) == 1:
                best = ((0.0, 0.0), st, times, bt, bx, tsw, dly, end)
                break
            xs, pts, tl, cd, dev, clr = poses(times, bt, bx, tsw, dly, on_old, on_new, cur, nxt, p,
                                              float(radius) if grid is None else -1.0)
            if grid is not None:
                clr = mesh_joint_clearance(grid, float(radius), pts, xs, L)
            lowest = float(np.nanmin(clr)) if np.any(np.isfinite(clr)) else math.inf
            key = (round(lowest, 3), -round(float(np.max(dev)), 3))
            if best is None or key > best[0]:
                best = (key, st, times, bt, bx, tsw, dly, end)
        assert best is not None
        _, st, times, bt, bx, tsw, dly, end = best
        if prev is not None:
            times = times[times > 0.0]  # t = 0 is the last pose of the module length before
        # dense: refine until no joint moves more than MAX_JOINT_STEP_MM between two written poses (a pose is a
        # function of its time alone: only the added times' poses are computed, then merged in time order)
        made = list(poses(times, bt, bx, tsw, dly, on_old, on_new, cur, nxt, p, -1.0))
        # the poses kept in the order they were computed, in buffers that grow by doubling (no copy of all of
        # them per round), with their time order ``order``; put in time order once, when done
        n_made = times.shape[0]
        all_times = times
        order = np.arange(n_made)
        for _ in range(24):
            tt = times if prev is None else np.concatenate([[0.0], times])
            move = np.empty(n_made)
            ordered_moves(made[1][order[0]] if prev is None else prev, made[1], order, move)
            move = move if prev is not None else move[1:]
            bad = np.flatnonzero(move > MAX_JOINT_STEP_MM)
            if not bad.size:
                break
            more = np.setdiff1d(np.concatenate([
                tt[b] + (tt[b + 1] - tt[b]) * np.arange(1, n) / n
                for b, n in zip(bad, np.ceil(move[bad] / MAX_JOINT_STEP_MM * 1.25).astype(int) + 1)]), times)
            added = poses(more, bt, bx, tsw, dly, on_old, on_new, cur, nxt, p, -1.0)
            if n_made + more.shape[0] > made[0].shape[0]:
                cap = max(2 * made[0].shape[0], n_made + more.shape[0])
                grown = []
                for arr in [all_times] + made:
                    g = np.empty((cap,) + arr.shape[1:], dtype=arr.dtype)
                    g[:n_made] = arr[:n_made]
                    grown.append(g)
                all_times, made = grown[0], grown[1:]
            all_times[n_made:n_made + more.shape[0]] = more
            for arr, new in zip(made, added):
                arr[n_made:n_made + more.shape[0]] = new
            n_made += more.shape[0]
            order = np.argsort(all_times[:n_made], kind="stable")  # the times are distinct: their one order
            times = all_times[:n_made][order]
        else:
            i = int(np.argmax(move))
            raise BhrError(f"the robot's motion could not be sampled finely enough (module length {p}, {st.name}, "
                           f"{move[i]:.3g} mm at t = {tt[i]:.6g} ms); report this run")
        if n_made != made[0].shape[0] or np.any(order != np.arange(n_made)):
            made = [arr[:n_made][order] for arr in made]
        xs, pts, tl, cd, dev, _c = made
        steps0 = np.minimum(np.floor(xs / feed + 1e-6).astype(np.int64), N - 1)
        low = np.empty(times.shape[0])
        if grid is None:
            c = score_kernel(pts, xs, steps0, L, z, back, C, R, S, BC, BR, tube.mitre_normals(), pre, w,
                             float(radius), float(sample), NEAR_MM, pc, mc, mw, low, left, bound)
            crossed = max(crossed, c)
        else:
            mesh_score(grid, float(radius), pts, xs, steps0, L, float(sample), pc, mc, mw, low)
        with np.errstate(invalid="ignore"):  # NaN: nothing in the lumen yet
            below = low < stop_below if stop_below is not None else None
        if below is not None and np.any(below):
            stopped = int(steps0[int(np.argmax(below))])
            keep = steps0 <= stopped  # that step's poses, whole: its row of the tables holds all of them
            times, xs, pts, tl, cd, dev, low, steps0 = (a[keep] for a in (times, xs, pts, tl, cd, dev, low, steps0))
        # each step's last pose
        last_of = np.flatnonzero(np.diff(np.append(steps0, -1)) != 0)
        sj[steps0[last_of]] = pts[last_of]
        scd[steps0[last_of]] = cd[last_of]
        filled = max(filled, int(steps0[-1]))
        count += pts.shape[0] * (M + 1)
        if count > pose_limit:
            kept = False
        chunks.append((clock + times, xs, pts if kept else None, tl if kept else None,
                       cd.astype(np.int8) if kept else None, dev, low, steps0))
        prev = pts[-1].copy()
        chosen.append(st.name)
        ends.append(sum(ch[0].shape[0] for ch in chunks) - 1)
        end_th = np.empty_like(th)
        end_s = np.empty_like(s)
        end_state(end, tsw, dly, th, s, on_old, on_new, prm, end_th, end_s)
        th, s = end_th, end_s
        clock += end
        cur = nxt
        if stopped is not None:
            N = stopped + 1
            sj, scd, pc, mc, mw = sj[:N], scd[:N], pc[:N], mc[:N], mw[:N]
            break
    if filled < N - 1:  # the feeder stopped: the robot holds its last pose
        sj[filled + 1:] = sj[filled]
        scd[filled + 1:] = scd[filled]
        pc[filled + 1:] = pc[filled]
        mc[filled + 1:] = mc[filled]
        mw[filled + 1:] = mw[filled]
    t = np.concatenate([ch[0] for ch in chunks]) / 1000.0
    x = np.concatenate([ch[1] for ch in chunks])
    if kept:
        pts = np.concatenate([ch[2] for ch in chunks])
        tl = np.concatenate([ch[3] for ch in chunks])
        cd = np.concatenate([ch[4] for ch in chunks])
    else:
        pts, tl, cd = np.zeros((0, M + 1, 3)), np.zeros((0, M, 2)), np.zeros((0, M), np.int8)
    dev = np.concatenate([ch[5] for ch in chunks])
    low = np.concatenate([ch[6] for ch in chunks])
    step = np.concatenate([ch[7] for ch in chunks]) + 1
    return MotionRun(t, x, pts, tl, cd, step, chosen, low, dev, np.array(ends, dtype=np.int64), sj, scd, pc, mc, mw,
                     kept, bool(crossed > 0.0), stopped_step=stopped, module_length_mm=float(L),
                     planned_steps=int(steps))


def mesh_joint_clearance(grid, radius: float, pts: np.ndarray, xs: np.ndarray, L: float) -> np.ndarray:
    """(K,) each pose's smallest joint clearance against the surface of ``grid`` (the planner's comparison of the
    switching strategies; NaN when no joint is inside the entrance)."""
    from bhr.model._wallmesh import grid_args, mesh_joints_kernel

    out = np.empty(pts.shape[0])
    mesh_joints_kernel(*grid_args(grid), float(radius), np.ascontiguousarray(pts, dtype=np.float64),
                       np.ascontiguousarray(xs, dtype=np.float64), float(L), out)
    return out


def mesh_score(grid, radius: float, pts: np.ndarray, xs: np.ndarray, steps: np.ndarray, L: float, sample: float,
               pc: np.ndarray, mc: np.ndarray, mw: np.ndarray, low: np.ndarray) -> None:
    """:func:`score_kernel` against the surface of ``grid`` (:func:`bhr.model._wallmesh.mesh_pose_kernel`): the poses
    folded into the steps' tables ``pc``, ``mc``, ``mw`` in place, each pose's smallest into ``low``."""
    from bhr.model._wallmesh import grid_args, mesh_pose_kernel

    mesh_pose_kernel(*grid_args(grid), float(radius), np.ascontiguousarray(pts, dtype=np.float64),
                     np.ascontiguousarray(xs, dtype=np.float64), np.ascontiguousarray(steps, dtype=np.int64), float(L),
                     float(sample), NEAR_MM, pc, mc, mw, low)


def wires_motion(traj, robot, solver, body_modules: int | None = None, reach: bool = False,
                 strategies: tuple[Strategy, ...] | None = None, params: ThermalParams = DEFAULT_THERMAL,
                 bound: bool = True, stop_below: float | None = None, all_poses: bool = False
                 ) -> tuple[MotionRun, np.ndarray, int, int, float, bool]:
    """The whole robot of ``body_modules`` (or, ``reach``, as many as reach the cecum) along ``traj`` (with a lumen)
    moved by its wires: (the motion, the trail's codes, the modules M, the 0-based step where the feeder stops, how
    far short of the path's end the tip stops in mm, whether the robot is too short to reach the cecum: its tail
    reached the anus first). ``solver``: the configured lumen solver (its planner settings); ``stop_below``:
    :func:`plan_motion`'s; ``all_poses``: every pose kept, however many (else at most :data:`POSE_POINTS_LIMIT`
    robot points)."""
    from bhr.model._wallmesh import wall_grid
    from bhr._run.body import check_body_modules
    from bhr._run.trail import cecum_modules, plan_to_cecum, vertex_hints
    from bhr.solvers._trail import dense_tube, trail_vertices

    if traj.lumen is None:
        raise BhrError(f"locomotion wires plans the trail against the lumen; {traj.name} has none (give a "
                       "trajectory with a lumen, e.g. --traj anatomy)")
    n, f = robot.modules, robot.feed_divisor
    N = traj.points.shape[0]
    L = float(robot.module_length)
    settings = {**solver.settings, "trail_beam": solver.trail_beam, "center_weight": solver.trail_center_weight}
    tube = dense_tube(traj.points, traj.lumen, traj.start_direction, solver.window,
                      closed_end=getattr(traj, "lumen_end", "closed") == "closed")
    tcodes, _, steps, stop = plan_to_cecum(tube, robot, settings, N, traj.start_direction, traj.start_point)
    if reach:
        body_modules = check_body_modules(cecum_modules(stop + 1, f, n), n, "reach cecum")
    M = int(n if body_modules is None else body_modules)
    too_short = M * f < stop
    stop = min(stop, M * f)  # a feeder at the anus pushes the tail in no further than the robot's length
    # the run goes on past the path's steps only while the feeder pushes the tip on to the cecum
    N = max(N, min(steps, stop + 1))
    check_step_points(N, M + 1)  # the steps to the cecum, now known, before the poses are kept
    tcodes = np.ascontiguousarray(tcodes[:(N - 1) // f + 1])
    back = M + 2
    T = trail_vertices(tcodes, traj.start_direction, traj.start_point, L, robot.alpha, back)
    z = vertex_hints(tube, T, back, L)
    m, k = divmod(stop, f)
    ztip = z[back + m] + (k / f) * (z[back + m + 1] - z[back + m])
    short = max(0.0, float(tube.points.shape[0] - tube.post - 1 - ztip) * float(tube.spacing))
    grid, wall = wall_grid(traj)
    mo = plan_motion(tube, float(robot.robot_radius), tcodes, T, back, z, M, L, float(robot.feed),
                     float(robot.alpha), traj.start_point, traj.start_direction, stop * float(robot.feed), N, params,
                     strategies, bound=bound, grid=grid, stop_below=stop_below,
                     pose_limit=math.inf if all_poses else POSE_POINTS_LIMIT)
    mo.wall = wall
    return mo, tcodes, M, stop, short, too_short


# ---------------------------------------------------------------------------
# references for the tests


def wire_states(codes_old, codes_new, t: float, t_sw: float, params: ThermalParams = DEFAULT_THERMAL,
                delay: float = 0.0) -> np.ndarray:
    """(M, 4) contraction of every wire of modules switching from ``codes_old`` to ``codes_new`` at ``t_sw``,
    from steady codes, at time t (ms): :func:`_wire` in a loop."""
    prm = wire_prm(params)
    out = np.empty((len(codes_old), 4))
    wst = np.empty(2)
    for i, (a, b) in enumerate(zip(codes_old, codes_new)):
        wa, wb = code_wires(a), code_wires(b)
        for k in range(4):
            th0 = 1.0 if wa[k] else 0.0
            th = _heat_start(bool(wa[k]), bool(wb[k]), t_sw, delay, th0, prm)
            _wire(bool(wa[k]), bool(wb[k]), t_sw, th, th0, th0, t, prm, wst)
            out[i, k] = wst[1]
    return out


def joint_tilts(s: np.ndarray, alpha_deg: float) -> np.ndarray:
    """(..., 2) the tilt rotation vectors of joints whose wires contract by ``s`` (..., 4)."""
    return math.radians(alpha_deg) * np.asarray(s, dtype=np.float64) @ WIRE_DIRECTIONS


def chain_poses(tail, frame, L: float, tilts: np.ndarray) -> np.ndarray:
    """(M + 1, 3) points of a chain of rigid modules (:func:`chain_kernel`)."""
    tl = np.ascontiguousarray(tilts, dtype=np.float64)
    out = np.empty((tl.shape[0] + 1, 3))
    chain_kernel(np.asarray(tail, dtype=np.float64), np.ascontiguousarray(frame, dtype=np.float64), float(L), tl, out)
    return out


# ---------------------------------------------------------------------------
# a run's steps and its clearance, from the poses


def motion_report(result):
    """The :class:`~bhr._run.clearance.ClearanceReport` of a run of the wires' motion: every joint and module of the
    whole robot, the smallest over every pose written in each step."""
    from bhr.model._tube import lumen_end_of
    from bhr._run.clearance import index_matched_min, left_lumen, robot_labels, tables_report, wall_label

    mo = result.motion
    r = result.robot
    n = r.modules
    M = mo.points_mm.shape[1] - 1
    B = M - n
    jp, jm, jw = mo.joint_clear[:, ::-1], mo.module_clear[:, ::-1], mo.module_where[:, ::-1]  # tip first
    p_idx = [n - jj for jj in range(n + 1)] + [n + k for k in range(1, B + 1)]
    m_idx = [n - 1 - jj for jj in range(n)] + [n + k - 1 for k in range(1, B + 1)]
    labels, mlabels = robot_labels(n, B)
    stop = result.extra.get("summary", {}).get("feeder_stop_step", result.steps)
    rep, both = tables_report(jp[:, p_idx], labels, jm[:, m_idx], mlabels, jw[:, m_idx], float(r.feed),
                              index_matched_min(result, B), lumen_end_of(result.trajectory), stop)
    rep.wall = wall_label(result.trajectory, getattr(mo, "wall", "tube"))
    if rep.min_step == 0:
        return rep

    def worst_at(i: int) -> str:
        return "" if np.all(np.isnan(both[i])) else (labels + mlabels)[int(np.nanargmin(both[i]))]

    # out of the lumen when some joint or module is deeper in the wall than the robot's radius, as for the other
    # models (a point crossing into another loop is known for the whole run only: MotionRun.crossed)
    rep.left_lumen_step, rep.left_lumen_reason = left_lumen(rep.per_step, np.zeros(rep.per_step.shape[0], dtype=bool),
                                                            r.robot_radius, worst_at)
    return rep
