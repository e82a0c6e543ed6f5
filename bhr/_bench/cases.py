"""Benchmarks: bhr's compiled kernels against plain numpy implementations of the same algorithms.

Each case times bhr and a reference in the same process, takes the least CPU
time of several repeats (the kernels' cases; the others say what they take),
checks both give the same numbers, and reports the ratio. The numpy
references live here, written the straightforward way (numpy vector maths per
point, Python loops over points and iterations), so anyone can read what is
being compared. Run with ``bhr bench``; the same
cases run under pytest-benchmark with
``pytest tests/benchmarks/bench_kernels.py --benchmark-only``.

Cases: ``fabrik`` and ``ccd`` (the 10-module chapter 5 chain), ``thesis-colon``
(the thesis's solver over the whole colon), ``optimal`` (two rows:
``optimal-step-colon``, ``--solver optimal`` with lookahead 0 and no steering
terms, which is the exact per-step optimum over all 5**5 codes, compiled
branch and bound against numpy evaluating every configuration at every step;
``optimal-default-colon``, the default solver (planner on) per solve() call
against the seed solver's call in the same driver, for the 1 ms per step asked of it),
``body-60`` (the whole-body beam search of a 60-module robot along the colon,
behind the seed solver's head) and ``cli`` (``bhr --help`` and ``bhr follow
--traj colon`` from a warm cache, whole commands). The numpy references of
the optimal and body cases are vectorized over configurations and candidates
(the natural numpy way), so their ratios are smaller than those of the
per-point loops.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

import numpy as np

from bhr._bench.commands import bhr_command
from bhr._bench.commands import plan_codes_csv, run_once
from bhr._kinematics.codetable import SEARCH_CODES, SEARCH_INVERSE

__all__ = ["CASES", "BenchResult", "run_case", "run_all", "numpy_fabrik", "numpy_ccd", "numpy_seed_follow",
           "numpy_optimal_follow", "check_optimal_reference", "numpy_body"]


@dataclass
class BenchResult:
    """Medians in seconds (per unit), their ratio, and the requirement checked."""

    case: str
    unit: str
    bhr_s: float
    reference_s: float
    reference: str
    ratio: float
    requirement: str = ""
    ok: bool | None = None
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _best_time(fn: Callable[[], Any], repeat: int, number: int = 1) -> float:
    """The least CPU seconds of this process per call of ``fn`` over ``repeat`` repeats of ``number`` calls.

    CPU time (``time.process_time``), so a busy machine's waits for a core are not counted, and the least of
    the repeats, as Python's ``timeit`` advises: what other processes add (a shared core's caches) only ever
    makes a repeat slower.
    """
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        for _ in range(number):
            fn()
        times.append((time.process_time() - t0) / number)
    return float(min(times))


# ---------------------------------------------------------------------------
# numpy references (same algorithms as bhr.solvers.*, written plainly)


def numpy_fabrik(points: np.ndarray, target: np.ndarray, length: float, tol: float, max_iter: int):
    """Unconstrained FABRIK (thesis ch. 5.1.1) with numpy vector operations."""
    P = points.copy()
    n = len(P) - 1
    base = P[0].copy()
    if np.linalg.norm(target - base) > n * length:
        for i in range(n):
            lam = length / np.linalg.norm(target - P[i])
            P[i + 1] = (1 - lam) * P[i] + lam * target
        return P, 0, float(np.linalg.norm(target - P[-1]))
    err = np.linalg.norm(P[-1] - target)
    k = 0
    while err > tol and k < max_iter:
        P[-1] = target
        for i in range(n - 1, -1, -1):  # the textbook (Aristidou) update, as the thesis writes it
            lam = length / np.linalg.norm(P[i + 1] - P[i])
            P[i] = (1 - lam) * P[i + 1] + lam * P[i]
        P[0] = base
        for i in range(n):
            lam = length / np.linalg.norm(P[i + 1] - P[i])
            P[i + 1] = (1 - lam) * P[i] + lam * P[i + 1]
        err = np.linalg.norm(P[-1] - target)
        k += 1
    return P, k, float(err)


def _np_rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Quaternion sandwich r v r* with numpy (same maths as bhr._kinematics.dualquat.k_rotate)."""
    c, s = math.cos(angle / 2), math.sin(angle / 2)
    w, q = c, s * axis
    t_w = -np.dot(q, v)
    t_v = w * v + np.cross(q, v)
    return -t_w * q + w * t_v - np.cross(t_v, q)


def numpy_ccd(points: np.ndarray, target: np.ndarray, tol: float, max_iter: int):
    """CCD, tip to base (thesis ch. 5.1.2), with numpy vector operations."""
    P = points.copy()
    n = len(P) - 1
    err = np.linalg.norm(P[-1] - target)
    k = 0
    while err > tol and k < max_iter:
        for j in range(n - 1, -1, -1):
            ve, vt = P[-1] - P[j], target - P[j]
            cr = np.cross(ve, vt)
            if np.linalg.norm(cr) == 0:
                continue
            theta = math.acos(max(-1.0, min(1.0, np.dot(ve, vt) / (np.linalg.norm(ve) * np.linalg.norm(vt)))))
            axis = cr / np.linalg.norm(cr)
            for m in range(j + 1, n + 1):
                P[m] = P[j] + _np_rotate(P[m] - P[j], axis, theta)
        err = np.linalg.norm(P[-1] - target)
        k += 1
    return P, k, float(err)


def _acosd(c: float) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _numpy_seed_solve(T, D, E1, E2, P0, h, tol_pos, tol_ori, alpha, max_iter, warmup=10):
    """The thesis's constrained FABRIK (binary, local axes) with numpy, as the MATLAB reads."""
    P = P0.copy()
    n = len(P) - 1
    before = P[0] - h * _unit(P[1] - P[0])
    base = P[0].copy()
    ep = np.linalg.norm(T - P[-1])
    eo = _acosd(np.dot(D, _unit(P[-1] - P[-2])))
    A1, A2 = E1.copy(), E2.copy()
    k = 0
    while ep > tol_pos or eo > tol_ori or k < warmup + 1:
        P[-1] = T
        P[-2] = T - h * D
        for i in range(n - 2, -1, -1):
            lam = h / np.linalg.norm(P[i + 1] - P[i])
            P[i] = (1 - lam) * P[i + 1] + lam * P[i]
        P[0] = base
        A1, A2 = E1.copy(), E2.copy()
        for i in range(n):
            if k < warmup:
                lam = h / np.linalg.norm(P[i + 1] - P[i])
                P[i + 1] = (1 - lam) * P[i] + lam * P[i + 1]
                continue
            A1[i:] -= P[i]
            A2[i:] -= P[i]
            g = [_unit(A1[i]), _unit(A2[i])]
            g += [-g[0], -g[1]]
            lam = h / np.linalg.norm(P[i + 1] - P[i])
            v2 = (1 - lam) * P[i] + lam * P[i + 1] - P[i]
            v1 = (before if i == 0 else P[i - 1]) - P[i]
            cr = np.cross(v2, v1)
            theta = 180 - _acosd(np.dot(v2, v1) / (np.linalg.norm(v2) * np.linalg.norm(v1)))
            if np.linalg.norm(cr) == 0:
                axis = g[0]
            else:
                vr = cr / np.linalg.norm(cr)
                axis = g[int(np.argmin([_acosd(np.dot(vr, a)) for a in g]))]
            theta = alpha if theta > alpha / 2 else 0.0
            rad = math.radians(theta)
            P[i + 1] = _np_rotate(-v1, axis, rad) + P[i]
            for j in range(i, n):
                A1[j] = _np_rotate(A1[j], axis, rad) + P[i]
            for j in range(i, n):
                A2[j] = _np_rotate(A2[j], axis, rad) + P[i]
        ep = np.linalg.norm(T - P[n])
        eo = _acosd(np.dot(D, _unit(P[-1] - P[-2])))
        k += 1
        if k >= max_iter:
            break
    return P, A1, A2, ep, eo


def numpy_seed_follow(path: np.ndarray, n: int = 5, h: float = 10.0, alpha: float = 10.0, tol_pos: float = 8.0,
                      tol_ori: float = 20.0, max_iter: int = 30, f: int = 5) -> np.ndarray:
    """The thesis's trajectory loop with the numpy solver; returns the tip error of each step."""
    feed = h / f
    P = np.zeros((n + 1, 3))
    for i in range(n - 1, -1, -1):
        P[i] = P[i + 1] - [h, 0, 0]
    E1, E2 = P[:n] + [0, 1, 0], P[:n] + [0, 0, 1]
    dirs = np.array([_unit(path[i + 1] - path[i]) for i in range(len(path) - 1)])
    tip = np.zeros(len(path))
    for i in range(len(path)):
        d = dirs[-1] if i == len(path) - 1 else dirs[i]
        P, E1, E2, ep, _ = _numpy_seed_solve(path[i], d, E1, E2, P, h, tol_pos, tol_ori, alpha, max_iter)
        tip[i] = ep
        ob = _unit(P[1] - P[0])
        P, E1, E2 = P + feed * ob, E1 + feed * ob, E2 + feed * ob
        for E in (E1, E2):
            d0 = _unit(E[0] - P[0])
            for j in range(1, n):
                E[j] = P[0] + ob * h * j + d0
    return tip


def _np_tilt(F: np.ndarray, k: int, c: float, s: float) -> np.ndarray:
    """Frames ``F`` (..., 3, 3), rows x, y, z, tilted by alpha about their own +x, +y, -x, -y (k = 1..4)."""
    if k == 0:
        return F.copy()
    ss = s if k <= 2 else -s
    out = np.empty_like(F)
    x, y, z = F[..., 0, :], F[..., 1, :], F[..., 2, :]
    if k in (1, 3):
        out[..., 0, :] = x
        out[..., 1, :] = c * y + ss * z
        out[..., 2, :] = c * z - ss * y
    else:
        out[..., 0, :] = c * x - ss * z
        out[..., 1, :] = y
        out[..., 2, :] = c * z + ss * x
    return out


def _sq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared distances along the last axis, summed x, then y, then z (the kernels' order)."""
    d = (a - b) ** 2
    return (d[..., 0] + d[..., 1]) + d[..., 2]


def _np_head_costs(P0: np.ndarray, F1: np.ndarray, T: np.ndarray, w: np.ndarray, d: np.ndarray, wo: float,
                   L: float, c: float, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Every configuration of modules 2..n behind a base module with frame(s) ``F1`` (..., 3, 3): their costs.

    Returns (costs, last frames), configurations in lexicographic order of
    the codes (module 2 most significant), as the exact search visits them.
    """
    n = T.shape[0] - 1
    F = F1[..., None, :, :]  # (..., 1, 3, 3)
    p = P0 + L * F1[..., 2, :]
    part = w[0] * _sq(P0, T[0]) + w[1] * _sq(p, T[1])
    p = p[..., None, :]
    part = part[..., None]
    for lvl in range(1, n):
        F = np.stack([_np_tilt(F, k, c, s) for k in range(5)], axis=-3)  # (..., m, 5, 3, 3)
        F = F.reshape(F.shape[:-4] + (-1, 3, 3))
        p = np.repeat(p, 5, axis=-2) + L * F[..., 2, :]
        part = np.repeat(part, 5, axis=-1) + w[lvl + 1] * _sq(p, T[lvl + 1])
    return part + wo * _sq(F[..., 2, :], d), F


def _np_step_targets(path: np.ndarray, dirs: np.ndarray, i: int, n: int, f: int, feed: float):
    """Step ``i``: trajectory index of each point 0..n, its target (n+1, 3) and the wanted tip direction.

    Point ``j`` is scored against trajectory point ``i - (n-j) f`` (bhr.follow);
    before the trajectory starts the target is on the straight line the robot
    started on, ``path[0] + idx * feed * dirs[0]`` (bhr.solvers._optimal).
    """
    N = path.shape[0]
    idx = i - (n - np.arange(n + 1)) * f
    T = np.where((idx < 0)[:, None], path[0] + (idx * feed)[:, None] * dirs[0], path[np.clip(idx, 0, N - 1)])
    d = dirs[N - 2] if i >= N - 1 else dirs[i]
    return idx, T, d


def numpy_optimal_follow(path: np.ndarray, start_point: np.ndarray, start_direction: np.ndarray, n: int = 5,
                         L: float = 10.0, alpha: float = 10.0, f: int = 5, weights: float = 1.0,
                         ori_weight: float = 0.2, return_costs: bool = False):
    """``--solver optimal`` with no lookahead and no steering terms, in numpy: exhaustive per-step search.

    The robot starts straight with its tip on the trajectory's start, along
    its start direction (bhr.follow). At each step the targets are the ones
    bhr.follow scores against (point ``j`` against trajectory point
    ``i - (n-j) f``; before the trajectory starts, the straight line the robot
    started on), and every one of the 5**n code combinations is evaluated at
    once (numpy arrays over the configurations, built from the base frame of
    the actual chain: module 1's local axes and direction) with the solver's
    cost (bhr.solvers._optimal module doc)::

        J = sum_j w |P_j - T_j|^2 + (ori_weight * 180/pi)^2 |u - d|^2

    The argmin (the first in lexicographic order of the codes, module 1 most
    significant, as the branch and bound keeps it on ties) is the pose; then
    the robot advances by the feed along its base module and modules 2..n get
    straight axes again (bhr._kinematics.leader.advance_kernel).

    Returns (codes (N, n), point errors (N, n+1)) and, with ``return_costs``,
    the minimum cost of each step (N,).
    """
    from bhr.model._path import path_directions
    from bhr.model._robot import Robot
    from bhr.solvers import Chain

    DEG = 180.0 / math.pi
    feed = L / f
    N = path.shape[0]
    dirs = path_directions(path)
    a = math.radians(alpha)
    c, s = math.cos(a), math.sin(a)
    w = np.full(n + 1, float(weights))
    wo = (ori_weight * DEG) ** 2
    chain = Chain.straight(Robot(modules=n, module_length=L, alpha=alpha, feed_divisor=f), start_direction,
                           start_point, tip_at_origin=True)
    P, E1, E2 = chain.points.copy(), chain.axes[0].copy(), chain.axes[1].copy()
    codes_of = SEARCH_CODES
    codes = np.zeros((N, n), dtype=np.int64)
    pe = np.zeros((N, n + 1))
    costs = np.zeros(N)
    for i in range(N):
        # module 1's frame (rows: local x axis, local y axis, direction), as Chain.base_frame
        F = np.stack([E1[0] - P[0], E2[0] - P[0], P[1] - P[0]])
        F = F / np.sqrt((F[:, 0] ** 2 + F[:, 1] ** 2) + F[:, 2] ** 2)[:, None]
        idx, T, d = _np_step_targets(path, dirs, i, n, f, feed)
        # all 5**n configurations: (5 base tilts) x (5**(n-1) for the rest), flattened lexicographically
        F1s = np.stack([_np_tilt(F, k, c, s) for k in range(5)])
        J = _np_head_costs(P[0], F1s, T, w, d, wo, L, c, s)[0].ravel()
        best = int(np.argmin(J))
        costs[i] = J[best]
        ks = [(best // 5 ** (n - 1 - m)) % 5 for m in range(n)]
        frames = [F1s[ks[0]]]
        for k in ks[1:]:
            frames.append(_np_tilt(frames[-1], k, c, s))
        fr = np.stack(frames)
        for m in range(n):
            P[m + 1] = P[m] + L * fr[m, 2]
        E1 = P[:-1] + fr[:, 0]
        E2 = P[:-1] + fr[:, 1]
        codes[i] = codes_of[ks]
        pe[i] = np.where(idx >= 0, np.sqrt(_sq(P, path[np.clip(idx, 0, N - 1)])), 0.0)
        # advance by the feed along the base module; modules 2..n get straight axes again (bhr.follow)
        o = P[1] - P[0]
        ob = o / math.sqrt((o[0] ** 2 + o[1] ** 2) + o[2] ** 2)
        P = P + feed * ob
        E1 = E1 + feed * ob
        E2 = E2 + feed * ob
        for E in (E1, E2):
            e = E[0] - P[0]
            dd = e / math.sqrt((e[0] ** 2 + e[1] ** 2) + e[2] ** 2)
            E[1:] = P[0] + ob * L * np.arange(1, n)[:, None] + dd
    return (codes, pe, costs) if return_costs else (codes, pe)


def numpy_body(P0s: np.ndarray, F1s: np.ndarray, start: np.ndarray, nb: int, f: int, feed: float, L: float,
               alpha: float, beam: int = 16):
    """The body's beam search (bhr._run.body) in numpy: rear ends (N, nb, 3) and codes (N, nb) at every step."""
    a = math.radians(alpha)
    c, s = math.cos(a), math.sin(a)
    inverse = SEARCH_INVERSE
    code = SEARCH_CODES
    N = P0s.shape[0]
    pts = np.zeros((N, nb, 3))
    codes = np.zeros((N, nb), dtype=np.int64)
    for i in range(N):
        G = (start if i == 0 else F1s[i - 1])[None]
        Q = P0s[i][None] - L * G[:, 2]
        C = np.zeros(1)
        hist_q, hist_a, hist_Q = [], [], [Q]
        for k in range(2, nb + 1):
            j = i - k * f
            R, Ft = (P0s[j], F1s[j]) if j >= 0 else (P0s[0] + j * feed * start[2], start)
            cG = np.stack([_np_tilt(G, inverse[q], c, s) for q in range(5)], axis=1).reshape(-1, 3, 3)
            cQ = np.repeat(Q, 5, axis=0) - L * cG[:, 2]
            cC = np.repeat(C, 5) + _sq(cQ, R) + 0.25 * L * L * _sq(cG[:, 2], Ft[2])
            order = np.argsort(cC, kind="mergesort")[:beam]
            G, Q, C = cG[order], cQ[order], cC[order]
            hist_q.append(order // 5)
            hist_a.append(order % 5)
            hist_Q.append(Q)
        q = 0
        for k in range(nb, 0, -1):
            pts[i, k - 1] = hist_Q[k - 1][q]
            if k >= 2:
                codes[i, k - 2] = code[hist_a[k - 2][q]]
                q = hist_q[k - 2][q]
    return pts, codes


# ---------------------------------------------------------------------------
# cases


def case_fabrik(repeat: int = 7) -> BenchResult:
    """Unconstrained FABRIK, 10-module chapter 5 chain, target (15, 6, 0) (Table 5.7)."""
    from bhr.model._robot import straight_chain
    from bhr.solvers._fabrik import fabrik_kernel

    P0 = straight_chain(10, 2.0, (0, 1, 0))
    t = np.array([15.0, 6.0, 0.0])
    zero = np.zeros(3)

    def run_bhr():
        P = P0.copy()
        return P, fabrik_kernel(P, t, 2.0, 0.01, 30, zero, False, 20.0)

    P_b, (k_b, e_b, _) = run_bhr()
    P_n, k_n, e_n = numpy_fabrik(P0, t, 2.0, 0.01, 30)
    assert k_b == k_n == 12 and abs(e_b - e_n) < 1e-12, "bhr and numpy FABRIK disagree"
    tb = _best_time(run_bhr, repeat, 2000)
    tn = _best_time(lambda: numpy_fabrik(P0, t, 2.0, 0.01, 30), repeat, 20)
    return BenchResult("fabrik-ch5-10", "per solve", tb, tn, "numpy FABRIK", tn / tb,
                       ">= 200x faster than numpy", tn / tb >= 200, {"iterations": int(k_b)})


def case_ccd(repeat: int = 7) -> BenchResult:
    """CCD, 10-module chapter 5 chain, target (15, 6, 0) (Table 5.7)."""
    from bhr.model._robot import straight_chain
    from bhr.solvers._ccd import ccd_kernel

    P0 = straight_chain(10, 2.0, (0, 1, 0))
    t = np.array([15.0, 6.0, 0.0])

    def run_bhr():
        P = P0.copy()
        return ccd_kernel(P, t, 0.01, 30)

    k_b, e_b = run_bhr()
    _, k_n, e_n = numpy_ccd(P0, t, 0.01, 30)
    assert k_b == k_n == 12 and abs(e_b - e_n) < 1e-9, "bhr and numpy CCD disagree"
    tb = _best_time(run_bhr, repeat, 500)
    tn = _best_time(lambda: numpy_ccd(P0, t, 0.01, 30), repeat, 3)
    return BenchResult("ccd-ch5-10", "per solve", tb, tn, "numpy CCD", tn / tb, "", None, {"iterations": int(k_b)})


def case_seed_colon(repeat: int = 5) -> list[BenchResult]:
    """The thesis's solver over the whole colon with its lumen, per step: the follower with its lumen clearance
    (``bhr.follow``: the compiled loop and the feeder's cecum watch, then the run's clearance to the lumen wall,
    every point and module of every step, :func:`bhr._run.clearance.clearance_report`) against the numpy loop
    and the numpy clearance reference; then each part alone. The clearance reference is timed on the first 100
    steps."""
    from bhr._run.clearance import clearance_report, clearance_run_numpy, make_tube, run_chain
    from bhr._run.driver import follow
    from bhr.model._generators import load_trajectory

    tr = load_trajectory("colon")
    steps = len(tr.points)
    res = follow(tr)  # compiles on a cold cache: not timed
    ref_tip = numpy_seed_follow(tr.points)
    diff = float(np.abs(ref_tip - res.point_errors_mm[:, -1]).max())
    assert diff < 1e-6, f"bhr and numpy seed disagree by {diff} mm"
    report = clearance_report(res)
    assert tr.lumen is not None and report is not None and report.module_table is not None, "the colon has a lumen"
    tube = make_tube(tr.points, tr.lumen, tr.start_direction, closed_end=True)
    Q, E, _ = run_chain(res)
    part = 100
    want = np.nanmin(report.module_table[:part], axis=1)
    got: list[np.ndarray] = []

    def reference():
        got[:] = [clearance_run_numpy(tube, res.robot.robot_radius, Q[:part], E[:part],
                                      advance=res.robot.feed / tube.spacing)[1]]

    tr_ref = _best_time(reference, 1) / part
    gap = float(np.nanmax(np.abs(np.nanmin(got[0], axis=1) - want)))
    assert gap < 1e-6, f"bhr's and numpy's clearance disagree by {gap} mm"
    # a compiled run of the colon takes a few ms: the least of many repeats (each of them cheap) is the time a
    # busy machine leaves undisturbed, as timeit advises; the repeats are spread over rounds, the three timings
    # taking turns, so that a spell of a shared machine running slow (seconds long) does not hold all of them
    quick = max(5 * repeat, 25)
    rounds = [(_best_time(lambda: follow(tr).clearance, quick), _best_time(lambda: follow(tr), quick),
               _best_time(lambda: clearance_report(res), quick)) for _ in range(4)]
    tall, tb, tc = (min(times) / steps for times in zip(*rounds))
    tn = _best_time(lambda: numpy_seed_follow(tr.points), max(1, repeat // 2)) / steps
    ok = tall <= 5e-6 and (tn + tr_ref) / tall >= 300
    return [BenchResult("thesis-colon", "per step", tall, tn + tr_ref, "numpy thesis loop and clearance",
                        (tn + tr_ref) / tall, "<= 5 us/step and >= 300x faster than numpy", ok,
                        {"steps": steps, "reference_clearance_steps": part}),
            BenchResult("thesis-colon-follower", "per step", tb, tn, "numpy thesis loop", tn / tb,
                        details={"steps": steps}),
            BenchResult("clearance-colon", "per step", tc, tr_ref, "numpy clearance reference", tr_ref / tc,
                        details={"steps": steps, "reference_steps": part})]


#: The optimal solver without its planner: the exact per-step optimum (docs/optimal.md).
OPTIMAL_PER_STEP = {"lookahead": 0, "drift_weight": 0.0, "roll_weight": 0.0}


def check_optimal_reference(res, path: np.ndarray, ref_codes: np.ndarray, ref_pe: np.ndarray,
                            ref_costs: np.ndarray, tol_pe: float = 1e-6, tol_cost: float = 1e-9) -> dict[str, Any]:
    """Assert that bhr's per-step optimum (``res``, a FollowResult) and :func:`numpy_optimal_follow` agree.

    Same codes at every step and the same point errors to ``tol_pe`` mm. If
    the codes first differ at a step where both configurations cost the same
    (to ``tol_cost``: a tie, which the two break differently), the runs are
    compared up to that step only, and the tie is reported in the result. The
    reference has no blind cecum: a run whose feeder stopped there (the robot
    held from then on) is compared up to that step.
    """
    from bhr.model._path import path_directions
    from bhr.solvers._optimal import config_cost

    n = res.modules
    r = res.robot
    held = res.extra.get("summary", {}).get("feeder_stop_step") or res.steps  # 1-based: the last step solved
    diff = np.flatnonzero(np.any(ref_codes[:held] != res.codes[:held], axis=1))
    upto = int(diff[0]) if diff.size else held
    out: dict[str, Any] = {"steps_compared": upto, "tie_at_step": None}
    if diff.size:
        k = upto
        _, T, d = _np_step_targets(path, path_directions(path), k, n, r.feed_divisor, r.feed)
        jb = config_cost(res.points[k], T, np.ones(n + 1), d, 0.2)
        if abs(jb - ref_costs[k]) > tol_cost * max(1.0, abs(jb)):
            raise AssertionError(f"bhr and numpy optimal chose different codes at step {k + 1}: "
                                 f"{res.codes[k].tolist()} (cost {jb:.12g}) against {ref_codes[k].tolist()} "
                                 f"(cost {ref_costs[k]:.12g})")
        out["tie_at_step"] = k + 1
    gap = float(np.abs(ref_pe[:upto] - res.point_errors_mm[:upto]).max()) if upto else 0.0
    assert gap <= tol_pe, f"bhr and numpy optimal point errors differ by {gap} mm"
    out["max_point_error_difference_mm"] = gap
    return out


def case_optimal(repeat: int = 5) -> list[BenchResult]:
    """--solver optimal over the colon: the exact per-step search against numpy; the default's solve time."""
    from bhr._bench.optimal import solve_times
    from bhr._run.driver import follow
    from bhr.model._generators import load_trajectory

    tr = load_trajectory("colon")
    steps = len(tr.points)
    path = np.ascontiguousarray(tr.points)

    def ref():
        return numpy_optimal_follow(path, tr.start_point, tr.start_direction, return_costs=True)

    res = follow(tr, solver="optimal", solver_options=OPTIMAL_PER_STEP)
    agree = check_optimal_reference(res, path, *ref())
    tb = _best_time(lambda: follow(tr, solver="optimal", solver_options=OPTIMAL_PER_STEP), repeat) / steps
    tn = _best_time(ref, max(1, repeat // 2)) / steps
    out = [BenchResult("optimal-step-colon", "per step", tb, tn, "numpy exhaustive 5^5 search", tn / tb, "", None,
                       {"steps": steps, "settings": OPTIMAL_PER_STEP, "configurations_per_step": 5 ** 5, **agree})]
    # the default settings (planner on), one solve() call per step driven from Python, seed in the same driver
    st = solve_times("colon", repeat=max(1, repeat // 2))
    to, ts = st["optimal"]["median_solve_s"], st["seed"]["median_solve_s"]
    out.append(BenchResult("optimal-default-colon", "per step", to, ts, "thesis solve (same driver)", ts / to,
                           "<= 1 ms median per step", to <= 1e-3,
                           {"steps": steps, "measured": "median of one Solver.solve() call per step, driven step "
                            "by step as bhr.follow does without its compiled loop",
                            "p90_s": st["optimal"]["p90_solve_s"], "max_s": st["optimal"]["max_solve_s"],
                            "compiled_loop_per_step_s": st["optimal"]["compiled_loop_per_step_s"]}))
    return out


def case_body(repeat: int = 5) -> BenchResult:
    """Whole-body follow-the-leader, 60 modules (5 head + 55 body) along the colon, per step."""
    from bhr._run.body import BODY_BEAM, module1_frames, simulate_body
    from bhr._run.driver import follow
    from bhr.model._generators import load_trajectory

    tr = load_trajectory("colon")
    res = follow(tr)
    r = res.robot
    steps, nb = res.steps, 60 - r.modules
    body = simulate_body(res, 60)
    assert res.codes is not None
    start, F1s = module1_frames(res.codes, tr.start_direction, r.alpha)
    P0s = np.ascontiguousarray(res.points[:, 0])

    def ref():
        return numpy_body(P0s, F1s, start, nb, r.feed_divisor, r.feed, r.module_length, r.alpha, BODY_BEAM)

    pts, codes = ref()
    assert np.array_equal(codes, body.codes), \
        f"bhr and numpy body chose different codes (first at step {int(np.argmax(np.any(codes != body.codes, 1))) + 1})"
    gap = float(np.abs(pts - body.points).max())
    assert gap < 1e-9, f"bhr and numpy body points differ by {gap} mm"
    tb = _best_time(lambda: simulate_body(res, 60), repeat) / steps
    tn = _best_time(ref, max(1, repeat // 2)) / steps
    return BenchResult("body-60-colon", "per step", tb, tn, "numpy beam search", tn / tb, "", None,
                       {"steps": steps, "head": "thesis", "body_modules": nb, "beam": BODY_BEAM,
                        "max_point_difference_mm": gap,
                        "timed": "bhr: simulate_body (module 1's frames, beam search, scoring); "
                                 "numpy: the beam search alone, whole colon"})


def case_lumen(repeat: int = 3) -> BenchResult:
    """--solver lumen (default settings, 5-module head) along anatomical colon 1: median solve() time per step."""
    from bhr._bench.lumen import solve_times

    st = solve_times(1, repeats=max(1, repeat))
    tl, ts = st["lumen_ms"] / 1e3, st["thesis_ms"] / 1e3
    return BenchResult("lumen-default-anatomy", "per step", tl, ts, "thesis solve (same driver)", ts / tl,
                       "<= 2 ms median per step", tl <= 2e-3,
                       {"colon": st["colon"], "steps": st["steps"],
                        "measured": "median of one Solver.solve() call per step, driven step by step as bhr.follow "
                                    "does without its compiled loop; median over runs"})


def _cpu_time(fn: Callable[[], Any], repeat: int) -> float:
    """Median CPU seconds (user + sys of this process) of ``fn()`` over ``repeat`` calls."""
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return float(np.median(times))


def case_trail(repeat: int = 3) -> BenchResult:
    """A 300-module whole robot with --solver lumen in the trail model (docs/locomotion.md) along anatomical colon
    1 (alpha 25 deg, 5 mm modules, feed divisor 5): CPU time per step of the whole run (planning, the robot at
    every step, the clearance of every module and of the motion between steps, the summary with the procedure
    time), against the thesis's model of the same robot in the same run (the head solved by --solver lumen, the
    body fitted behind it and scored)."""
    import warnings

    from bhr._run.driver import BhrWarning, follow
    from bhr.model._generators import load_trajectory
    from bhr.model._robot import Robot

    r = Robot(alpha=25.0, module_length=5.0)
    tr = load_trajectory("anatomy", feed=r.feed, seed=1)

    def run(locomotion: str):
        def go():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BhrWarning)
                res = follow(tr, solver="lumen", robot=r, body_modules=300, locomotion=locomotion)
                return res.summary.to_dict()
        return go

    trail, thesis = run("trail"), run("thesis")
    s = trail()  # compiles
    thesis()
    steps = tr.points.shape[0]
    tb = _cpu_time(trail, repeat) / steps
    tn = _cpu_time(thesis, max(1, repeat // 2)) / steps
    return BenchResult("trail-300-anatomy", "per step", tb, tn, "thesis's model, same robot (same run)", tn / tb,
                       "<= 2 ms median per step", tb <= 2e-3,
                       {"colon": 1, "steps": steps, "modules": 300, "max_penetration_mm": s["max_penetration_mm"],
                        "procedure_time_s": s["procedure_time_s"], "measured": "CPU seconds of one whole run, "
                        "median over repeats, divided by the steps"})


def case_wires(repeat: int = 1, modules: int = 300) -> BenchResult:
    """The robot as it can be built (docs/locomotion.md, "The wires"): a ``modules``-module robot of 5 mm modules
    (1.5 m at 300), alpha 25 deg, along anatomical colon 1 by --locomotion wires (the trail planned, every module
    length's switching planned, every pose written and scored), CPU seconds of the whole run; against the trail
    model's run of the same robot in the same process."""
    import warnings

    from bhr.model._generators import load_trajectory
    from bhr.model._robot import Robot
    from bhr._run.driver import BhrWarning, follow

    r = Robot(alpha=25.0, module_length=5.0)
    tr = load_trajectory("anatomy", feed=r.feed, seed=1)

    def run(locomotion: str, m: int = modules):
        def go():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BhrWarning)
                return follow(tr, solver="lumen", robot=r, body_modules=m, locomotion=locomotion)
        return go

    run("wires", 20)()  # compiles
    run("trail", 20)()
    out = []
    tb = _cpu_time(lambda: out.append(run("wires")()), repeat)
    tt = _cpu_time(run("trail"), repeat)
    s = out[0].summary.to_dict()
    return BenchResult(f"wires-{modules}", "per run (CPU)", tb, tt, "the trail model, same robot (same run)",
                       tt / tb, "<= 60 s", tb <= 60.0,
                       {"colon": 1, "modules": modules, "poses": s["poses"], "kept": out[0].motion.kept,
                        "max_trail_offset_mm": s["max_trail_offset_mm"], "min_clearance_mm": s["min_clearance_mm"],
                        "switching": s["switching"], "procedure_time_s": s["procedure_time_s"],
                        "measured": "CPU seconds (user + sys) of one whole run, median over repeats"})


def case_study(repeat: int = 1, colons: int = 100) -> BenchResult:
    """A whole-length study (docs/locomotion.md): ``colons`` anatomical colons x 1 design (--solver lumen, alpha 25
    deg, 5 mm modules, reach cecum, trail locomotion) on every CPU, wall time; against the thesis's solver on the
    same colons, head only, in the same run."""
    from bhr._studies.traverse import build_study, run_study

    seeds = f"1-{colons}"
    whole = build_study([("alpha", (25,)), ("module_length", (5,)), ("reach", ("cecum",)),
                         ("locomotion", ("trail",))], seeds, solvers=["lumen"])
    head = build_study([], seeds, solvers=["thesis"])
    t0 = time.perf_counter()
    res = run_study(whole)
    tb = time.perf_counter() - t0
    t0 = time.perf_counter()
    run_study(head)
    tn = time.perf_counter() - t0
    d = res.designs[0]
    return BenchResult(f"study-{colons}-cecum", "per study", tb, tn, "thesis's solver, head only, same colons",
                       tn / tb, "<= 5 min", tb <= 300.0,
                       {"colons": colons, "workers": res.workers, "traversed": d["traversed"],
                        "worst_penetration_mm": d["worst_penetration_mm"],
                        "median_procedure_time_s": d["median_procedure_time_s"], "measured": "wall seconds"})


def case_physics(repeat: int = 1) -> BenchResult:
    """A 1.5 m physical traversal of one colon (docs/physics.md): the robot as it can be built, 300 modules of
    5 mm (alpha 25 deg), driven by its wires through anatomical colon 1 (``bhr.follow``, --solver lumen, its
    default locomotion for a whole robot), then replayed against the colon's wall (bhr._studies.physics.
    replay_physics), in the same process, compiled beforehand; CPU seconds of the two together (the least of
    ``repeat``), against the run alone."""
    import warnings

    from bhr._run.driver import BhrWarning, follow
    from bhr.model._generators import load_trajectory
    from bhr.model._robot import Robot
    from bhr._studies.physics import replay_physics

    r = Robot(alpha=25.0, module_length=5.0)
    tr = load_trajectory("anatomy", feed=r.feed, seed=1)
    # compiled first, not timed: the same kinds of run and replay, a short robot ending where it leaves the lumen
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        replay_physics(follow(tr, solver="lumen", robot=r, body_modules=20, stop_at_wall=True))
    best: tuple[float, float, Any] | None = None
    for _ in range(max(1, repeat)):
        t0 = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            run = follow(tr, solver="lumen", robot=r, body_modules=300)
        t1 = time.process_time()
        rep = replay_physics(run)
        t2 = time.process_time()
        if best is None or (t2 - t0) < best[0] + best[1]:
            best = (t1 - t0, t2 - t1, rep)
    assert best is not None
    tf, tb, rep = best
    s = rep.summary()
    return BenchResult("physics-300", "per traversal (CPU)", tf + tb, tf, "the run alone (bhr.follow, CPU)",
                       tf / (tf + tb), "<= 60 s", tf + tb <= 60.0,
                       {"colon": 1, "modules": 300, "steps": run.steps, "locomotion": "wires", "run_s": tf,
                        "replay_s": tb, "equilibria": s["equilibria"],
                        "equilibria_not_reached": s["equilibria_not_reached"],
                        "max_total_force_n": s["max_total_force_n"], "max_stretch_mm": s["max_stretch_mm"],
                        "reached_cecum_step": s["reached_cecum_step"],
                        "measured": "CPU seconds (user + sys of this process) of the run and its whole replay"})


def _cpu(cmd: list[str], repeat: int, cwd: str, check: bool = True) -> float:
    """Median CPU time (user + system, seconds) of a command run ``repeat`` times: steadier than wall time on
    a shared machine, where waiting for a core is not the command's cost."""
    import resource

    times = []
    env = dict(os.environ, MPLBACKEND="Agg")
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc = subprocess.run(cmd, cwd=cwd, capture_output=True, env=env)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if check and proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed: {proc.stderr.decode(errors='replace')[-300:]}")
        times.append((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))
    return float(np.median(times))


def case_cli(repeat: int = 5) -> list[BenchResult]:
    """CPU time (user + system) of whole commands as a user runs them, warm cache, against a bare interpreter."""
    out = []
    bhr = bhr_command()
    with tempfile.TemporaryDirectory() as tmp:
        base = _cpu([sys.executable, "-c", "pass"], repeat, tmp)
        subprocess.run(bhr + ["follow", "--traj", "colon", "--out", "w"], cwd=tmp, capture_output=True)
        help_t = _cpu(bhr + ["--help"], repeat, tmp)
        bad = _cpu(bhr + ["follow", "--traj", "colonn"], repeat, tmp, check=False)
        bad_solver = _cpu(bhr + ["follow", "--traj", "colon", "--solver", "thesiss"], repeat, tmp, check=False)
        bad_modules = _cpu(bhr + ["follow", "--traj", "colon", "--modules", "-3"], repeat, tmp, check=False)
        bad_codes = _cpu(bhr + ["fk", "--codes", "3,0,7"], repeat, tmp, check=False)
        bad_file = _cpu(bhr + ["plan", "--codes", "missing.csv"], repeat, tmp, check=False)
        nop = _cpu(bhr + ["follow", "--traj", "colon", "--no-plots", "--out", "a"], repeat, tmp)
        plots = _cpu(bhr + ["follow", "--traj", "colon", "--out", "b"], max(3, repeat // 2), tmp)
        plan_codes_csv(os.path.join(tmp, "long.csv"))
        plan = _cpu(bhr + ["plan", "--codes", "long.csv", "--schedule", "auto", "--no-plots"], 1, tmp,
                    check=False)
    out.append(BenchResult("cli-help", "per command (CPU)", help_t, base, "python -c pass", help_t / base,
                           "<= 0.3 s", help_t <= 0.3))
    out.append(BenchResult("cli-bad-traj", "per command (CPU)", bad, base, "python -c pass", bad / base,
                           "<= 0.3 s", bad <= 0.3))
    out.append(BenchResult("cli-bad-solver", "per command (CPU)", bad_solver, base, "python -c pass",
                           bad_solver / base, "<= 0.3 s", bad_solver <= 0.3))
    out.append(BenchResult("cli-bad-modules", "per command (CPU)", bad_modules, base, "python -c pass",
                           bad_modules / base, "<= 0.3 s", bad_modules <= 0.3))
    out.append(BenchResult("cli-bad-codes", "per command (CPU)", bad_codes, base, "python -c pass",
                           bad_codes / base, "<= 0.3 s", bad_codes <= 0.3))
    out.append(BenchResult("cli-bad-plan-file", "per command (CPU)", bad_file, base, "python -c pass",
                           bad_file / base, "<= 0.3 s", bad_file <= 0.3))
    out.append(BenchResult("cli-follow-colon-noplots", "per command (CPU)", nop, base, "python -c pass", nop / base,
                           "<= 1 s", nop <= 1.0))
    out.append(BenchResult("cli-follow-colon-plots", "per command (CPU)", plots, base, "python -c pass",
                           plots / base, "<= 2 s", plots <= 2.0))
    out.append(BenchResult("cli-plan-300x1500", "per command (CPU)", plan, base, "python -c pass", plan / base,
                           "<= 2 s", plan <= 2.0))
    return out


def case_first_run(repeat: int = 3) -> BenchResult:
    """`bhr follow --traj colon` on an empty numba cache (it compiles every kernel it runs) against the same
    command on the cache it left (nothing compiled), alternating in one run: CPU seconds, medians."""
    args = ["follow", "--traj", "colon", "--out", "o"]
    cold: list[float] = []
    warm: list[float] = []
    for _ in range(max(1, repeat)):
        with tempfile.TemporaryDirectory() as tmp:
            for into in (cold, warm):
                cpu, _, code = run_once(args, Path(tmp), cold=True)
                if code != 0:
                    raise RuntimeError(f"bhr {' '.join(args)} failed (exit {code})")
                into.append(cpu)
    a, b = float(np.median(cold)), float(np.median(warm))
    return BenchResult("first-run", "per command (CPU)", a, b, "the same command, warm cache", a / b,
                       details={"cold_s": sorted(cold), "warm_s": sorted(warm)})


CASES: dict[str, Callable[..., BenchResult | list[BenchResult]]] = {
    "fabrik": case_fabrik,
    "ccd": case_ccd,
    "thesis-colon": case_seed_colon,
    "optimal": case_optimal,
    "body-60": case_body,
    "lumen": case_lumen,
    "trail-300": case_trail,
    "wires-300": case_wires,
    "study-100": case_study,
    "physics-300": case_physics,
    "cli": case_cli,
    "first-run": case_first_run,
}


#: Former case names, still accepted.
CASE_ALIASES = {"seed-colon": "thesis-colon"}


def run_case(name: str, repeat: int | None = None) -> list[BenchResult]:
    fn = CASES[name]
    res = fn() if repeat is None else fn(repeat)
    return res if isinstance(res, list) else [res]


def run_all(names: list[str] | None = None, repeat: int | None = None,
            progress: Callable[[str], None] | None = None) -> list[BenchResult]:
    results: list[BenchResult] = []
    for name in names or list(CASES):
        if progress:
            progress(name)
        results += run_case(name, repeat)
    return results


def format_table(results: list[BenchResult]) -> str:
    def t(s: float) -> str:
        return f"{s * 1e6:.2f} us" if s < 1e-3 else (f"{s * 1e3:.2f} ms" if s < 1 else f"{s:.3f} s")

    rows = [("case", "unit", "bhr", "reference", "ref", "ratio", "requirement", "ok")]
    for r in results:
        ratio = f"{r.ratio:.1f}x" if r.ratio >= 1 else f"{r.ratio:.3f}x"
        rows.append((r.case, r.unit, t(r.bhr_s), r.reference, t(r.reference_s), ratio,
                     r.requirement or "-", "-" if r.ok is None else ("yes" if r.ok else "NO")))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows)


if __name__ == "__main__":  # pragma: no cover
    print(format_table(run_all()))
