"""A racing line through the lumen: a smooth line of bounded curvature inside the corridor (model layer).

The head of the thesis robot (modules of length ``L``, each joint turning by
at most ``alpha``) cannot bend tighter than ``L / (2 sin(alpha / 2))`` (57 mm
for 10 mm and 10 deg), while the colon's flexures bend at 10-16 mm radius.
A line through the *corridor* (the points whose distance to the centerline
is at most ``W = R(s) - robot radius - margin``) may bend much less: outside,
inside, outside through a bend. :func:`racing_line` finds such a line as
lateral offsets ``o_k`` (two numbers in the normal plane of a parallel-
transport frame at each centerline point ``C_k``), ``Q_k = C_k + o_k``,
minimising a penalty on the line's curvature above the bound, a penalty on
leaving the corridor, and small terms that keep it straight and central
where nothing else counts (:func:`racing_line` gives the terms).

It is a heuristic, and a choice: the weights trade curvature above the bound
against leaving the corridor (where no line in the corridor keeps the bound,
a bend too tight for the lumen, it does both a little), the curvature is
linearised about the line of the round before, and nothing proves the bound
(it is measured: :func:`line_curvature`; the tests check it on simple bends).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["racing_line", "transport_frames", "line_curvature", "head_radius_mm"]


def head_radius_mm(module_length: float, alpha_deg: float) -> float:
    """The tightest bend radius of a chain of modules of ``module_length`` turning by ``alpha_deg`` per joint."""
    return float(module_length) / (2.0 * math.sin(math.radians(alpha_deg) / 2.0))


def transport_frames(C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit normals per centerline point, transported along it without twist (rows of (M, 3) each)."""
    M = C.shape[0]
    T = np.empty_like(C)
    T[1:-1] = C[2:] - C[:-2]
    T[0] = C[1] - C[0]
    T[-1] = C[-1] - C[-2]
    T /= np.linalg.norm(T, axis=1)[:, None]
    N1 = np.empty_like(C)
    a = np.eye(3)[int(np.argmin(np.abs(T[0])))]
    n = a - np.dot(a, T[0]) * T[0]
    N1[0] = n / np.linalg.norm(n)
    for k in range(1, M):
        n = N1[k - 1] - np.dot(N1[k - 1], T[k]) * T[k]
        N1[k] = n / np.linalg.norm(n)
    N2 = np.cross(T, N1)
    return N1, N2


def line_curvature(Q: np.ndarray) -> np.ndarray:
    """Menger curvature (1/mm) at each interior point of a polyline (M-2 values)."""
    a = Q[1:-1] - Q[:-2]
    b = Q[2:] - Q[1:-1]
    c = Q[2:] - Q[:-2]
    cr = np.linalg.norm(np.cross(a, b), axis=1)
    den = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1) * np.linalg.norm(c, axis=1)
    return 2.0 * cr / np.maximum(den, 1e-12)


def _hinge(v: np.ndarray, bound: np.ndarray, w: float) -> tuple[float, np.ndarray, np.ndarray]:
    """sum w max(0, |v_k| - bound_k)^2 over the rows of v (K, d): value, gradient (K, d), Hessian blocks (K, d, d)."""
    n = np.linalg.norm(v, axis=1)
    ex = n - bound
    on = ex > 0.0
    val = float(w * np.sum(np.where(on, ex * ex, 0.0)))
    u = v / np.maximum(n, 1e-12)[:, None]
    grad = np.where(on[:, None], 2.0 * w * ex[:, None] * u, 0.0)
    d = v.shape[1]
    uu = u[:, :, None] * u[:, None, :]
    hess = 2.0 * w * (uu + (ex / np.maximum(n, 1e-12))[:, None, None] * (np.eye(d)[None] - uu))
    hess = np.where(on[:, None, None], hess, 0.0)
    return val, grad, hess


def _blocks(hess: np.ndarray, offset: int = 0):
    """A sparse block-diagonal matrix of the (K, d, d) blocks."""
    from scipy.sparse import csr_matrix

    K, d, _ = hess.shape
    base = offset + np.arange(K) * d
    ii = (base[:, None, None] + np.arange(d)[None, :, None] + 0 * np.arange(d)[None, None, :]).reshape(-1)
    jj = (base[:, None, None] + 0 * np.arange(d)[None, :, None] + np.arange(d)[None, None, :]).reshape(-1)
    return csr_matrix((hess.reshape(-1), (ii, jj)), shape=(offset + K * d, offset + K * d))


def _objective(x: np.ndarray, A, g0: np.ndarray, AtA, reg, W: np.ndarray, cw: float,
               eps: float) -> tuple[float, np.ndarray, Any]:
    """Value, gradient and (generalised) Hessian of :func:`racing_line`'s objective at offsets ``x``."""
    K = A.shape[0] // 3
    v = (A @ x + g0).reshape(K, 3)
    fk, gk, hk = _hinge(v, np.ones(K), cw)
    o = x.reshape(-1, 2)
    fo, go, ho = _hinge(o, W, 1.0)
    val = fk + fo + eps * float(np.sum(v * v)) + eps / 64.0 * float(x @ x)
    grad = A.T @ gk.reshape(-1) + go.reshape(-1) + 2.0 * eps * (A.T @ v.reshape(-1)) + 2.0 * eps / 64.0 * x
    hess = A.T @ _blocks(hk) @ A + _blocks(ho) + 2.0 * eps * AtA + reg
    return val, grad, hess


def racing_line(C: np.ndarray, half_width: np.ndarray, max_curvature: float, rounds: int = 4, newton: int = 15,
                curvature_weight: float = 10.0, eps: float = 1e-3,
                fold: float = 0.7) -> np.ndarray:
    """The racing line (M, 3) through the corridor of half-width ``half_width`` (M,) around the centerline ``C``.

    Minimises, over lateral offsets ``o_k`` in the normal plane of each centerline point,

        curvature_weight sum_k max(0, |kappa_k| / max_curvature - 1)^2     the head cannot bend more
      + sum_k max(0, |o_k| - W_k)^2                                        out of the corridor, mm^2
      + eps sum_k (|kappa_k| / max_curvature)^2 + eps sum_k (|o_k| / 8 mm)^2   straight and central where free

    ``kappa_k`` the line's curvature vector, linearised about the line of the round before (its segment lengths
    held), so each round is a convex problem solved by damped Newton steps (sparse solves).
    """
    from scipy.sparse import csr_matrix, diags, identity, kron
    from scipy.sparse.linalg import spsolve

    C = np.ascontiguousarray(C, dtype=np.float64)
    M = C.shape[0]
    W = np.asarray(half_width, dtype=np.float64)
    if M < 5:
        return C.copy()
    # the offsets are taken in the normal planes of the centerline, which cross at its centre of curvature:
    # keep them within a share of the centerline's local bend radius, so the line does not fold over
    rc = np.full(M, np.inf)
    rc[1:-1] = 1.0 / np.maximum(line_curvature(C), 1e-12)
    k = 5
    pad = np.pad(rc, k, mode="edge")
    rc = np.min(np.stack([pad[j:j + M] for j in range(2 * k + 1)]), axis=0)
    W = np.minimum(W, fold * rc)
    h = float(np.median(np.linalg.norm(np.diff(C, axis=0), axis=1)))
    N1, N2 = transport_frames(C)
    # unknowns x = (o1_0, o2_0, o1_1, o2_1, ...): Q = C + B x, B block-diagonal (3 x 2 per point)
    rows = np.repeat(np.arange(3 * M), 2)
    cols = np.tile(np.array([0, 1]), 3 * M) + 2 * np.repeat(np.arange(M), 6)
    B = csr_matrix((np.stack([N1, N2], axis=2).reshape(-1), (rows, cols)), shape=(3 * M, 2 * M))
    reg = identity(2 * M, format="csr") * (2.0 * eps / 64.0)
    x = np.zeros(2 * M)
    Q = C.copy()
    for _ in range(rounds):
        # the curvature vector at each interior point, linearised about the line so far (its segment lengths
        # a, b held): 2 / (a + b) ((Q+ - Q) / b - (Q - Q-) / a), in units of the bound
        seg = np.maximum(np.linalg.norm(np.diff(Q, axis=0), axis=1), 1e-3 * h)
        a, b = seg[:-1], seg[1:]
        f = 2.0 / ((a + b) * max_curvature)
        D2 = diags([f / a, -f * (1.0 / a + 1.0 / b), f / b], [0, 1, 2], shape=(M - 2, M))
        D2x = kron(D2, identity(3), format="csr")
        A = (D2x @ B).tocsr()
        g0 = D2x @ C.reshape(-1)
        AtA = (A.T @ A).tocsr()

        for _ in range(newton):
            f0, grad, hess = _objective(x, A, g0, AtA, reg, W, curvature_weight, eps)
            dx = spsolve(hess.tocsc(), -grad)
            dec = float(-grad @ dx)
            if not dec > 1e-10 * max(1.0, f0):
                break
            t = 1.0
            while t > 1e-6 and _objective(x + t * dx, A, g0, AtA, reg, W, curvature_weight, eps)[0] > \
                    f0 - 0.25 * t * dec:
                t *= 0.5
            x = x + t * dx
        Q = C + (B @ x).reshape(M, 3)
    return Q
