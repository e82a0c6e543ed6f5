"""Polylines: a segment's direction and length, and walking a polyline at a fixed step (the kernel behind
:func:`bhr.model._path.resample_polyline`)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["segment_direction", "walk_kernel", "median_spacing", "unit_tangents"]


@njit(cache=True)
def segment_direction(P: np.ndarray, k: int) -> tuple[float, float, float, float]:
    """Segment ``k`` of the polyline ``P`` (M, 3): its unit direction (0, 0, 0 for a segment of no length) and its
    length."""
    dx, dy, dz = P[k + 1, 0] - P[k, 0], P[k + 1, 1] - P[k, 1], P[k + 1, 2] - P[k, 2]
    n = math.sqrt(dx * dx + dy * dy + dz * dz)
    if n == 0.0:
        return 0.0, 0.0, 0.0, n
    return dx / n, dy / n, dz / n, n


@njit(cache=True)
def median_spacing(P: np.ndarray) -> float:
    """The median length of the segments of the polyline ``P`` (M >= 2, 3): the same number, to the bit, as
    ``np.median(np.linalg.norm(np.diff(P, axis=0), axis=1))`` (each length summed x, y, z in order; the mean of the
    two middle ones for an even count; NaN if a length is)."""
    seg = np.empty(P.shape[0] - 1)
    for k in range(seg.shape[0]):
        dx, dy, dz = P[k + 1, 0] - P[k, 0], P[k + 1, 1] - P[k, 1], P[k + 1, 2] - P[k, 2]
        seg[k] = math.sqrt(dx * dx + dy * dy + dz * dz)
        if seg[k] != seg[k]:
            return np.nan  # as numpy's median of anything holding a NaN
    return np.median(seg)


@njit(cache=True)
def unit_tangents(P: np.ndarray, out: np.ndarray) -> None:
    """Into ``out`` (M, 3): the unit tangent at each point of the polyline ``P`` (M >= 2, 3), the central
    difference inside and the end segments' directions at its ends (a zero difference stays zero)."""
    M = P.shape[0]
    for i in range(M):
        a = i - 1 if i > 0 else 0
        b = i + 1 if i < M - 1 else M - 1
        dx, dy, dz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
        n = max(math.sqrt(dx * dx + dy * dy + dz * dz), 1e-300)
        out[i, 0] = dx / n
        out[i, 1] = dy / n
        out[i, 2] = dz / n


@njit(cache=True)
def walk_kernel(pts: np.ndarray, vals: np.ndarray, feed: float, out: np.ndarray, out_vals: np.ndarray) -> int:
    """Sphere-intersection walk (see :func:`bhr.model._path.resample_polyline`); returns the points written."""
    n = pts.shape[0]
    f2 = feed * feed
    cx, cy, cz = pts[0, 0], pts[0, 1], pts[0, 2]
    out[0, 0], out[0, 1], out[0, 2] = cx, cy, cz
    out_vals[0] = vals[0]
    count = 1
    j = 0
    t = 0.0
    cap = out.shape[0]
    while j < n - 1:
        ax, ay, az = pts[j, 0], pts[j, 1], pts[j, 2]
        dx, dy, dz = pts[j + 1, 0] - ax, pts[j + 1, 1] - ay, pts[j + 1, 2] - az
        ex, ey, ez = ax - cx, ay - cy, az - cz
        a = dx * dx + dy * dy + dz * dz
        b = 2.0 * (ex * dx + ey * dy + ez * dz)
        c = ex * ex + ey * ey + ez * ez - f2
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            disc = 0.0
        t2 = (-b + math.sqrt(disc)) / (2.0 * a)  # where the segment leaves the sphere around the last point
        if t2 <= 1.0 and t2 >= t:
            if count == cap:
                return -1
            cx, cy, cz = ax + t2 * dx, ay + t2 * dy, az + t2 * dz
            out[count, 0], out[count, 1], out[count, 2] = cx, cy, cz
            out_vals[count] = vals[j] + t2 * (vals[j + 1] - vals[j])
            count += 1
            t = t2
        else:
            j += 1
            t = 0.0
    return count
