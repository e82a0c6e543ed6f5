"""One pose of the physical robot in equilibrium: the energy of the rigid, wire-held chain against the wall and the
feeder, its gradient, and the Newton steps that minimise it (compiled kernels over the chain, numba); docs/physics.md
describes the model and :mod:`.replay` runs it along a run."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from bhr.model._tube import segment_scan

__all__ = ["GTOL", "MAX_ITERATIONS", "STALL_FORCE_N", "solve_pose"]

#: Equilibrium reached when no joint's torque is off by more than this (N mm) nor the feeder's force (N): at the
#: wires' stiffness a tilt within about 2e-5 rad of its equilibrium.
GTOL = 1e-3
#: Iterations at most for one equilibrium; past it the best pose found is kept and counted
#: (``equilibria_not_reached`` in the summary, with the largest generalized force left).
MAX_ITERATIONS = 300
#: Where the energy has a kink (a sample at the corner between two centerline segments) the gradient cannot fall
#: below the kink's jump: the equilibrium is taken as reached when no step lowers the energy and no generalized
#: force is above this force (N), plus a thousandth of the wall's load, times the robot's length (a torque, N mm).
STALL_FORCE_N = 0.01


@njit(cache=True)
def _exp_jl(u, v, R, J):
    """R = Exp((u, v, 0)) and J its left Jacobian (angular velocity in the parent's axes per unit rate)."""
    th2 = u * u + v * v
    th = math.sqrt(th2)
    if th < 1e-6:
        a = 1.0 - th2 / 6.0
        b = 0.5 - th2 / 24.0
        c = 1.0 / 6.0 - th2 / 120.0
    else:
        a = math.sin(th) / th
        b = (1.0 - math.cos(th)) / th2
        c = (th - math.sin(th)) / (th2 * th)
    # K = [[0, 0, v], [0, 0, -u], [-v, u, 0]] for (u, v, 0); K^2 = [[-v^2, uv, 0], [uv, -u^2, 0], [0, 0, -th2]]
    K = ((0.0, 0.0, v), (0.0, 0.0, -u), (-v, u, 0.0))
    K2 = ((-v * v, u * v, 0.0), (u * v, -u * u, 0.0), (0.0, 0.0, -th2))
    for r in range(3):
        for s in range(3):
            e = 1.0 if r == s else 0.0
            R[r, s] = e + a * K[r][s] + b * K2[r][s]
            J[r, s] = e + b * K[r][s] + c * K2[r][s]


#: The centerline segments each side of where a wall sample was last found that one equilibrium measures it
#: against (:func:`_depth`): the same for every pose tried, so that the wall's energy is continuous in the pose.
WALL_SPAN = 6


@njit(cache=True)
def _depth(C, Rad, lo, hi, sx, sy, sz, radius):
    """How deep the robot's surface around axis point s is in the wall: the least over segments ``lo..hi-1`` of
    its distance to the segment, plus the robot's radius, less the lumen's radius at the segment's nearest point
    (the depth below the lumen that segment bounds). The least of continuous functions is continuous: where two
    segments are equally near and their radii differ (the inner side of a bend where the lumen narrows) the
    depth does not jump, as the nearest segment's would. Returns (depth mm, segment, t along it, distance)."""
    best = 1e300
    bk = lo
    bt = 0.0
    bd = 0.0
    for k in range(lo, hi):
        d2, _, t = segment_scan(C, k, k + 1, sx, sy, sz)
        d = math.sqrt(d2)
        pen = d + radius - (Rad[k] + t * (Rad[k + 1] - Rad[k]))
        if pen < best:
            best, bk, bt, bd = pen, k, t, d
    return best, bk, bt, bd


@njit(cache=True)
def _energy(z, target, x_target, base, d0, A0, length, radius, ns, k_wall, k_joint, k_feed, f_feed, C, Rad,
            seg, seg_out, grad, pen_out, Aprev, Jl, P, nrm, spos, dist, full=True, cap=math.inf):
    """Energy (N mm) of the chain at z = (feeder travel mm, u1, v1, ..., uM, vM) and its gradient (into grad).

    k_joint (M) is each joint's stiffness (N mm/rad) towards its target tilt. seg (M ns) holds where each wall
    sample's nearest centerline segment is searched from (the same for every evaluation of one equilibrium, so
    that the energy is a function of z alone), seg_out gets the one found;
    pen_out (M ns) gets each sample's penetration (mm, 0 when clear), nrm and spos (M ns, 3) its gradient with
    respect to the sample's position and the sample's position; Aprev, Jl (M, 3, 3) and P (M, 3) each joint's
    parent frame (columns), its tilt's left Jacobian and its position.

    Not ``full``: a sample inside the lumen its segment ``seg`` bounds is clear (the least depth over the segments
    is at most that one's), and its segments are not searched: seg_out and dist keep what they held for it
    (:func:`_settle` finds its segment). The energy, its gradient and the contact arrays are the same.

    ``cap``: every term of the energy is at least zero, so once their sum so far is above ``cap`` the energy is
    too (a line search's trial that cannot be taken): that sum is returned at once, the gradient and the contact
    arrays left part-written (the caller evaluates again before it reads them)."""
    M = target.shape[0]
    nseg = C.shape[0] - 1
    x = z[0]
    px = base[0] + x * d0[0]
    py = base[1] + x * d0[1]
    pz = base[2] + x * d0[2]
    A = A0.copy()
    Gm = np.zeros((M, 3))
    Mm = np.zeros((M, 3))
    R = np.empty((3, 3))
    J = np.empty((3, 3))
    An = np.empty((3, 3))
    w = length / ns
    E = 0.0
    for j in range(M):
        u = z[1 + 2 * j]
        v = z[2 + 2 * j]
        _exp_jl(u, v, R, J)
        Aprev[j] = A
        Jl[j] = J
        for r in range(3):
            for s in range(3):
                An[r, s] = A[r, 0] * R[0, s] + A[r, 1] * R[1, s] + A[r, 2] * R[2, s]
        A[:, :] = An
        P[j, 0], P[j, 1], P[j, 2] = px, py, pz
        ax, ay, az = A[0, 2], A[1, 2], A[2, 2]
        for k in range(ns):
            f = (k + 0.5) * w
            sx, sy, sz = px + f * ax, py + f * ay, pz + f * az
            i = j * ns + k
            spos[i, 0], spos[i, 1], spos[i, 2] = sx, sy, sz
            if not full:
                k0 = seg[i]
                d2, _, t = segment_scan(C, k0, k0 + 1, sx, sy, sz)
                if math.sqrt(d2) + radius - (Rad[k0] + t * (Rad[k0 + 1] - Rad[k0])) <= 0.0:
                    pen_out[i] = 0.0
                    continue
            pen, kk, t, d = _depth(C, Rad, max(seg[i] - WALL_SPAN, 0), min(seg[i] + WALL_SPAN + 1, nseg), sx, sy, sz,
                                   radius)
            seg_out[i] = kk
            dist[i] = d
            if pen > 0.0:
                pen_out[i] = pen
                E += 0.5 * k_wall * w * pen * pen
                if E > cap:
                    return E
                cx = C[kk, 0] + t * (C[kk + 1, 0] - C[kk, 0])
                cy = C[kk, 1] + t * (C[kk + 1, 1] - C[kk, 1])
                cz = C[kk, 2] + t * (C[kk + 1, 2] - C[kk, 2])
                if d > 1e-12:
                    nx, ny, nz = (sx - cx) / d, (sy - cy) / d, (sz - cz) / d
                else:
                    nx, ny, nz = 0.0, 0.0, 0.0
                if 0.0 < t < 1.0:  # the radius changes along the segment: the nearest point moves with the sample
                    ux, uy, uz = C[kk + 1, 0] - C[kk, 0], C[kk + 1, 1] - C[kk, 1], C[kk + 1, 2] - C[kk, 2]
                    dr = (Rad[kk + 1] - Rad[kk]) / (ux * ux + uy * uy + uz * uz)
                    nx -= dr * ux
                    ny -= dr * uy
                    nz -= dr * uz
                nrm[i, 0], nrm[i, 1], nrm[i, 2] = nx, ny, nz
                c = k_wall * w * pen
                gx, gy, gz = c * nx, c * ny, c * nz
                Gm[j, 0] += gx
                Gm[j, 1] += gy
                Gm[j, 2] += gz
                Mm[j, 0] += sy * gz - sz * gy
                Mm[j, 1] += sz * gx - sx * gz
                Mm[j, 2] += sx * gy - sy * gx
            else:
                pen_out[i] = 0.0
        px += length * ax
        py += length * ay
        pz += length * az
    # backward: the wall's force and moment beyond each joint; the joint's generalized force
    G0 = 0.0
    G1 = 0.0
    G2 = 0.0
    M0 = 0.0
    M1 = 0.0
    M2 = 0.0
    for j in range(M - 1, -1, -1):
        G0 += Gm[j, 0]
        G1 += Gm[j, 1]
        G2 += Gm[j, 2]
        M0 += Mm[j, 0]
        M1 += Mm[j, 1]
        M2 += Mm[j, 2]
        T0 = M0 - (P[j, 1] * G2 - P[j, 2] * G1)
        T1 = M1 - (P[j, 2] * G0 - P[j, 0] * G2)
        T2 = M2 - (P[j, 0] * G1 - P[j, 1] * G0)
        Ap = Aprev[j]
        l0 = Ap[0, 0] * T0 + Ap[1, 0] * T1 + Ap[2, 0] * T2  # the moment in the parent's axes
        l1 = Ap[0, 1] * T0 + Ap[1, 1] * T1 + Ap[2, 1] * T2
        l2 = Ap[0, 2] * T0 + Ap[1, 2] * T1 + Ap[2, 2] * T2
        J = Jl[j]
        du = z[1 + 2 * j] - target[j, 0]
        dv = z[2 + 2 * j] - target[j, 1]
        E += 0.5 * k_joint[j] * (du * du + dv * dv)
        grad[1 + 2 * j] = J[0, 0] * l0 + J[1, 0] * l1 + J[2, 0] * l2 + k_joint[j] * du
        grad[2 + 2 * j] = J[0, 1] * l0 + J[1, 1] * l1 + J[2, 1] * l2 + k_joint[j] * dv
    e = x - x_target
    lim = f_feed / k_feed
    if abs(e) <= lim:
        E += 0.5 * k_feed * e * e
        gf = k_feed * e
    else:
        E += f_feed * abs(e) - 0.5 * f_feed * lim
        gf = f_feed if e > 0 else -f_feed
    grad[0] = G0 * d0[0] + G1 * d0[1] + G2 * d0[2] + gf
    return E


@njit(cache=True)
def _settle(C, Rad, seg, found, spos, pen, radius):
    """The end of an equilibrium: every sample's segment found (those :func:`_energy` left clear without searching
    theirs: found as a full evaluation finds it) becomes where the next equilibrium searches from."""
    nseg = C.shape[0] - 1
    for i in range(seg.shape[0]):
        if not pen[i] > 0.0:
            found[i] = _depth(C, Rad, max(seg[i] - WALL_SPAN, 0), min(seg[i] + WALL_SPAN + 1, nseg), spos[i, 0],
                              spos[i, 1], spos[i, 2], radius)[1]
    seg[:] = found


@njit(cache=True)
def _newton_step(z, grad, x_target, d0, ns, k_wall, length, k_joint, k_feed, f_feed, pen, Aprev, Jl, P, nrm, spos,
                 dist, out):
    """The Gauss-Newton step: out = -H^-1 grad, H = the joints' and the feeder's stiffness + the wall's
    sum c n n^T over the samples in contact, in the chain's coordinates. H is a chain's "mass matrix" whose
    bodies have the spatial inertias sum c w w^T (w = (s x n, n), each sample's unit wrench) and whose joints
    have the stiffness as armature, so Featherstone's articulated-body recursion solves it in O(M)."""
    M = Jl.shape[0]
    c = k_wall * length / ns
    IA = np.zeros((M + 1, 6, 6))  # body 0: the sled on the feeder's slide
    pA = np.zeros((M + 1, 6))
    G = np.zeros((3, 6))  # a sample's motion from the spatial motion (omega, v): v + omega x s
    G[0, 3], G[1, 4], G[2, 5] = 1.0, 1.0, 1.0
    K3 = np.zeros((3, 3))
    KG = np.zeros((3, 6))
    for j in range(M):
        for k in range(ns):
            i = j * ns + k
            if pen[i] > 0.0:
                n0, n1, n2 = nrm[i, 0], nrm[i, 1], nrm[i, 2]
                s0, s1, s2 = spos[i, 0], spos[i, 1], spos[i, 2]
                wv = (s1 * n2 - s2 * n1, s2 * n0 - s0 * n2, s0 * n1 - s1 * n0, n0, n1, n2)
                for a in range(6):
                    for b in range(6):
                        IA[j + 1, a, b] += c * wv[a] * wv[b]
                # the wall's curvature across the lumen: pen grows as |s - centre|, whose Hessian is
                # (I - m m^T) / d (m the unit direction from the centre); c pen (I - m m^T) / d, PSD
                if dist[i] > 1e-9 and (n0 != 0.0 or n1 != 0.0 or n2 != 0.0):
                    kt = c * pen[i] / dist[i]
                    G[0, 1], G[0, 2] = s2, -s1
                    G[1, 0], G[1, 2] = -s2, s0
                    G[2, 0], G[2, 1] = s1, -s0
                    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)  # nrm carries the radius's slope: unit here
                    for e in range(3):
                        for f in range(3):
                            K3[e, f] = kt * ((1.0 if e == f else 0.0) - nrm[i, e] * nrm[i, f] / (nn * nn))
                    for e in range(3):
                        for bb in range(6):
                            KG[e, bb] = K3[e, 0] * G[0, bb] + K3[e, 1] * G[1, bb] + K3[e, 2] * G[2, bb]
                    for aa in range(6):
                        for bb in range(6):
                            IA[j + 1, aa, bb] += G[0, aa] * KG[0, bb] + G[1, aa] * KG[1, bb] + G[2, aa] * KG[2, bb]
    S = np.zeros((M, 6, 2))
    U = np.zeros((M, 6, 2))
    Dm = np.zeros((M, 2, 2))
    u = np.zeros((M, 2))
    B = np.empty((3, 2))  # each joint's, every entry written before it is read
    for j in range(M):
        for r in range(3):
            for q in range(2):
                B[r, q] = Aprev[j, r, 0] * Jl[j, 0, q] + Aprev[j, r, 1] * Jl[j, 1, q] + Aprev[j, r, 2] * Jl[j, 2, q]
        px, py, pz = P[j, 0], P[j, 1], P[j, 2]
        for q in range(2):
            bx, by, bz = B[0, q], B[1, q], B[2, q]
            S[j, 0, q], S[j, 1, q], S[j, 2, q] = bx, by, bz
            S[j, 3, q], S[j, 4, q], S[j, 5, q] = py * bz - pz * by, pz * bx - px * bz, px * by - py * bx
    for j in range(M - 1, -1, -1):
        b = j + 1
        for a in range(6):
            for q in range(2):
                acc = 0.0
                for r in range(6):
                    acc += IA[b, a, r] * S[j, r, q]
                U[j, a, q] = acc
        for q in range(2):
            for t in range(2):
                acc = 0.0
                for r in range(6):
                    acc += S[j, r, q] * U[j, r, t]
                Dm[j, q, t] = acc + (k_joint[j] if q == t else 0.0)
            acc = 0.0
            for r in range(6):
                acc += S[j, r, q] * pA[b, r]
            u[j, q] = -grad[1 + 2 * j + q] - acc
        # the parent's articulated inertia and bias
        det = Dm[j, 0, 0] * Dm[j, 1, 1] - Dm[j, 0, 1] * Dm[j, 1, 0]
        if not det > 1e-300:  # rounding lost the articulated inertia's definiteness: the wires' stiffness alone
            Dm[j, 0, 0], Dm[j, 0, 1], Dm[j, 1, 0], Dm[j, 1, 1] = k_joint[j], 0.0, 0.0, k_joint[j]
            det = k_joint[j] * k_joint[j]
        i00, i01, i10, i11 = Dm[j, 1, 1] / det, -Dm[j, 0, 1] / det, -Dm[j, 1, 0] / det, Dm[j, 0, 0] / det
        du0 = i00 * u[j, 0] + i01 * u[j, 1]
        du1 = i10 * u[j, 0] + i11 * u[j, 1]
        for a in range(6):
            ua0 = U[j, a, 0] * i00 + U[j, a, 1] * i10
            ua1 = U[j, a, 0] * i01 + U[j, a, 1] * i11
            for r in range(6):
                IA[j, a, r] += IA[b, a, r] - (ua0 * U[j, r, 0] + ua1 * U[j, r, 1])
            pA[j, a] += pA[b, a] + U[j, a, 0] * du0 + U[j, a, 1] * du1
    # the slide: motion (0, d0)
    e = z[0] - x_target
    kf = k_feed if abs(e) <= f_feed / k_feed else k_feed * 1e-6
    U0 = np.zeros(6)
    for a in range(6):
        U0[a] = IA[0, a, 3] * d0[0] + IA[0, a, 4] * d0[1] + IA[0, a, 5] * d0[2]
    D0 = U0[3] * d0[0] + U0[4] * d0[1] + U0[5] * d0[2] + kf
    u0 = -grad[0] - (pA[0, 3] * d0[0] + pA[0, 4] * d0[1] + pA[0, 5] * d0[2])
    if not D0 > 0.0:
        D0 = kf
    q0 = u0 / D0
    out[0] = q0
    acc6 = np.zeros(6)
    acc6[3], acc6[4], acc6[5] = d0[0] * q0, d0[1] * q0, d0[2] * q0
    for j in range(M):
        t0 = u[j, 0]
        t1 = u[j, 1]
        for r in range(6):
            t0 -= U[j, r, 0] * acc6[r]
            t1 -= U[j, r, 1] * acc6[r]
        det = Dm[j, 0, 0] * Dm[j, 1, 1] - Dm[j, 0, 1] * Dm[j, 1, 0]
        q1 = (Dm[j, 1, 1] * t0 - Dm[j, 0, 1] * t1) / det
        q2 = (Dm[j, 0, 0] * t1 - Dm[j, 1, 0] * t0) / det
        out[1 + 2 * j] = q1
        out[2 + 2 * j] = q2
        for r in range(6):
            acc6[r] += S[j, r, 0] * q1 + S[j, r, 1] * q2


@njit(cache=True)
def _equilibrium(z, target, x_target, base, d0, A0, length, radius, ns, k_wall, k_joint, k_feed, f_feed, C, Rad,
                 seg, pen, gtol, stall, span, maxit):
    """Gauss-Newton (:func:`_newton_step`) with a backtracking line search on the energy, from z (changed in
    place) until no generalized force is above gtol, or the Newton step would lower the energy by less than its
    rounding (a step that would not, while the joints are still pushed, is damped until it does); the iterations
    taken (maxit + 1: not converged)."""
    M = target.shape[0]
    n = z.shape[0]
    grad = np.zeros(n)
    Aprev = np.empty((M, 3, 3))
    Jl = np.empty((M, 3, 3))
    P = np.empty((M, 3))
    nrm = np.zeros((M * ns, 3))
    spos = np.zeros((M * ns, 3))
    dist = np.zeros(M * ns)
    step = np.zeros(n)
    zn = np.empty(n)
    found = seg.copy()
    E = _energy(z, target, x_target, base, d0, A0, length, radius, ns, k_wall, k_joint, k_feed, f_feed, C, Rad,
                seg, found, grad, pen, Aprev, Jl, P, nrm, spos, dist, False)
    w = k_wall * length / ns
    descend = False  # the next step goes down the gradient (the Newton step just failed)
    for it in range(maxit + 1):
        g = 0.0
        for i in range(n):
            if abs(grad[i]) > g:
                g = abs(grad[i])
        ftot = 0.0
        for i in range(pen.shape[0]):
            ftot += w * pen[i]
        # the kinks' jumps grow with the wall's load: a thousandth of it, or STALL_FORCE_N, at the robot's length
        lim = (stall + 1e-3 * ftot) * span
        if g <= gtol:
            _settle(C, Rad, seg, found, spos, pen, radius)
            return it
        if it == maxit:
            break
        if not descend:
            _newton_step(z, grad, x_target, d0, ns, k_wall, length, k_joint, k_feed, f_feed, pen, Aprev, Jl, P, nrm,
                         spos, dist, step)
        finite = not descend
        for i in range(n):
            if not math.isfinite(step[i]):
                finite = False
        if not finite:  # the Newton step just failed, or its recursion lost itself in rounding: a step down the
            # gradient, scaled by the wires' stiffness
            for i in range(n):
                step[i] = -grad[i] / (k_feed if i == 0 else k_joint[(i - 1) // 2])
        slope = 0.0
        for i in range(n):
            slope += grad[i] * step[i]
        damp = 1.0
        while not descend and -slope <= 1e-13 * (abs(E) + 1.0) and g > lim and damp < 1e12:
            # a Newton step uphill, or huge, while the joints are still pushed: the long chain's recursion lost
            # itself in rounding. The joints' stiffness scaled up (Levenberg-Marquardt) shortens it towards
            # the gradient's direction until it goes down
            damp *= 10.0
            _newton_step(z, grad, x_target, d0, ns, k_wall, length, k_joint * damp, k_feed, f_feed, pen, Aprev, Jl,
                         P, nrm, spos, dist, step)
            slope = 0.0
            for i in range(n):
                if not math.isfinite(step[i]):
                    step[i] = 0.0
                slope += grad[i] * step[i]
        if -slope <= 1e-13 * (abs(E) + 1.0):  # the step would gain less than rounding: at the minimum
            _settle(C, Rad, seg, found, spos, pen, radius)
            return it if g <= lim else maxit + 1
        t = 1.0
        while True:
            for i in range(n):
                zn[i] = z[i] + t * step[i]
            enough = E + 1e-4 * t * slope
            # a trial whose energy so far is above what it must reach is left at once (_energy's cap); a trial
            # taken was evaluated whole
            En = _energy(zn, target, x_target, base, d0, A0, length, radius, ns, k_wall, k_joint, k_feed, f_feed,
                         C, Rad, seg, found, grad, pen, Aprev, Jl, P, nrm, spos, dist, False, enough)
            if En <= enough:
                break
            if t < 1e-12:
                break
            t *= 0.5
        if not En <= E + 1e-4 * t * slope:  # no descent left along the step: the energy's kinks (a sample's
            # least depth passing from one segment to the next) hold the gradient up; z stays
            _energy(z, target, x_target, base, d0, A0, length, radius, ns, k_wall, k_joint, k_feed, f_feed, C, Rad,
                    seg, found, grad, pen, Aprev, Jl, P, nrm, spos, dist, False)
            if g > lim and not descend:  # the Newton step failed: a step down the gradient next
                descend = True
                continue
            _settle(C, Rad, seg, found, spos, pen, radius)
            return it + 1 if g <= lim else maxit + 1
        descend = False
        z[:] = zn
        E = En
    _settle(C, Rad, seg, found, spos, pen, radius)
    return maxit + 1


@njit(cache=True)
def chain_points(z, base, d0, A0, length, out):
    """Joint positions (M+1, 3) of the chain at z."""
    M = out.shape[0] - 1
    R = np.empty((3, 3))
    J = np.empty((3, 3))
    A = A0.copy()
    An = np.empty((3, 3))
    out[0, 0] = base[0] + z[0] * d0[0]
    out[0, 1] = base[1] + z[0] * d0[1]
    out[0, 2] = base[2] + z[0] * d0[2]
    for j in range(M):
        _exp_jl(z[1 + 2 * j], z[2 + 2 * j], R, J)
        for r in range(3):
            for s in range(3):
                An[r, s] = A[r, 0] * R[0, s] + A[r, 1] * R[1, s] + A[r, 2] * R[2, s]
        A[:, :] = An
        for r in range(3):
            out[j + 1, r] = out[j, r] + length * A[r, 2]


@njit(cache=True)
def global_seg(C, pts, seg):
    for i in range(pts.shape[0]):
        _, k, _ = segment_scan(C, 0, C.shape[0] - 1, pts[i, 0], pts[i, 1], pts[i, 2])
        seg[i] = k


@dataclass
class Problem:
    base: np.ndarray
    d0: np.ndarray
    A0: np.ndarray
    length: float
    radius: float
    ns: int
    k_wall: float
    k_joint: np.ndarray  # (M,) each joint's stiffness, N mm/rad (the wires', or a passive body's)
    k_feed: float
    f_feed: float
    C: np.ndarray
    R: np.ndarray
    seg: np.ndarray
    pen: np.ndarray


def solve_pose(pb: Problem, z0: np.ndarray, target: np.ndarray, x_target: float, maxit: int = MAX_ITERATIONS
               ) -> tuple[np.ndarray, int, float]:
    """The equilibrium nearest ``z0`` with joint targets ``target`` (M, 2) and the feeder at ``x_target``:
    (z, iterations, the largest generalized force left: N mm, N for the feeder). Iterations ``maxit + 1``: the
    equilibrium was not reached within ``maxit`` (z is the best found)."""
    z = np.ascontiguousarray(z0, dtype=np.float64).copy()
    target = np.ascontiguousarray(target)
    for _ in range(4):  # again, from there, while a sample ended at the edge of the segments it was measured on
        start = pb.seg.copy()
        it = _equilibrium(z, target, float(x_target), pb.base, pb.d0, pb.A0, pb.length,
                          pb.radius, pb.ns, pb.k_wall, pb.k_joint, pb.k_feed, pb.f_feed, pb.C, pb.R, pb.seg, pb.pen,
                          GTOL, STALL_FORCE_N, max(1.0, pb.length * target.shape[0]), maxit)
        if np.abs(pb.seg - start).max() < WALL_SPAN:
            break
    left = 0.0
    if it > maxit:
        M = target.shape[0]
        g = np.zeros_like(z)
        ws = (np.empty((M, 3, 3)), np.empty((M, 3, 3)), np.empty((M, 3)), np.zeros((M * pb.ns, 3)),
              np.zeros((M * pb.ns, 3)), np.zeros(M * pb.ns))
        _energy(z, target, float(x_target), pb.base, pb.d0, pb.A0, pb.length, pb.radius, pb.ns, pb.k_wall,
                pb.k_joint, pb.k_feed, pb.f_feed, pb.C, pb.R, pb.seg, pb.seg.copy(), g, pb.pen, *ws)
        left = float(np.abs(g).max())
    return z, it, left
