"""The reachable tips of a binary robot: every code combination (exact), or given rows of codes (sampled).

A binary robot of ``n`` modules with ``K`` codes per module has ``K**n`` poses.
:func:`enumerate_tips` visits all of them in mixed-radix order (the tip
module's code changes fastest) and recomputes only the modules from the first
one whose code changed, so a pose costs about ``K / (K - 1)`` module tilts
instead of ``n``. :func:`tips_of_codes` computes the tips of given code rows
(Monte Carlo samples). Both chain :func:`bhr._kinematics.frames.tilt_frame`,
the one tilt of every kernel; :func:`tips_reference` is the same in numpy
(:func:`bhr._kinematics.frames.fk_reference` per pose), which the tests hold them
equal to.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
from numba import njit

from bhr._kinematics.codetable import LIFT_OF, SEARCH_INDEX
from bhr._kinematics.frames import fk_reference, tilt_frame

__all__ = ["enumerate_tips", "tips_of_codes", "tips_reference"]


@njit(cache=True)
def enumerate_tips(choices: np.ndarray, n: int, base: np.ndarray, frame: np.ndarray, length: float, lift: float,
                   alpha_deg: float, tips: np.ndarray, directions: np.ndarray) -> None:
    """Tip point and tip direction (the last module's z) of every pose of ``n`` modules, each module taking
    one of the codes ``choices`` (K of them): pose ``p`` has module ``i``'s code ``choices[d_i]`` where
    ``p = sum(d_i K**(n-1-i))`` (module 1 = base = most significant). ``tips`` and ``directions`` are
    (K**n, 3)."""
    K = choices.shape[0]
    a = math.radians(alpha_deg)
    c, s = math.cos(a), math.sin(a)
    F = np.empty((n + 1, 3, 3))  # F[i]: the frame before module i+1 (F[0] the base frame)
    P = np.empty((n + 1, 3))  # P[i]: point i+1 (P[0] the base)
    kidx = np.empty(K, dtype=np.int64)
    extra = np.empty(K)
    for k in range(K):
        kidx[k] = SEARCH_INDEX[choices[k]]
        extra[k] = lift * LIFT_OF[choices[k]]
    for r in range(3):
        P[0, r] = base[r]
        for b in range(3):
            F[0, r, b] = frame[r, b]
    digits = np.zeros(n, dtype=np.int64)
    total = tips.shape[0]
    first = 0  # the first module whose code changed since the last pose
    for p in range(total):
        for i in range(first, n):
            d = digits[i]
            tilt_frame(F[i], kidx[d], c, s, F[i + 1])
            step = length + extra[d]
            for b in range(3):
                P[i + 1, b] = P[i, b] + step * F[i + 1, 2, b]
        for b in range(3):
            tips[p, b] = P[n, b]
            directions[p, b] = F[n, 2, b]
        # the next pose: add one to the last digit, carrying towards the base
        i = n - 1
        while i >= 0:
            digits[i] += 1
            if digits[i] < K:
                break
            digits[i] = 0
            i -= 1
        first = i if i >= 0 else 0


@njit(cache=True)
def tips_of_codes(codes: np.ndarray, base: np.ndarray, frame: np.ndarray, length: float, lift: float,
                  alpha_deg: float, tips: np.ndarray, directions: np.ndarray) -> None:
    """Tip point and tip direction of each row of ``codes`` (S, n), module 1 first, into ``tips`` and
    ``directions`` (S, 3)."""
    S, n = codes.shape
    a = math.radians(alpha_deg)
    c, s = math.cos(a), math.sin(a)
    F = np.empty((3, 3))
    G = np.empty((3, 3))
    for row in range(S):
        for r in range(3):
            tips[row, r] = base[r]
            for b in range(3):
                F[r, b] = frame[r, b]
        for i in range(n):
            code = codes[row, i]
            tilt_frame(F, SEARCH_INDEX[code], c, s, G)
            step = length + lift * LIFT_OF[code]
            for r in range(3):
                for b in range(3):
                    F[r, b] = G[r, b]
            for b in range(3):
                tips[row, b] += step * F[2, b]
        for b in range(3):
            directions[row, b] = F[2, b]


def tips_reference(choices: np.ndarray, n: int, base: np.ndarray, frame: np.ndarray, length: float, lift: float,
                   alpha_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """numpy reference of :func:`enumerate_tips`: :func:`fk_reference` of every pose, in the same order."""
    tips, dirs = [], []
    for combo in itertools.product([int(c) for c in choices], repeat=n):
        pts, frames = fk_reference(np.array(combo), base, frame, length, lift, alpha_deg)
        tips.append(pts[-1])
        dirs.append(frames[-1][2])
    return np.array(tips), np.array(dirs)
