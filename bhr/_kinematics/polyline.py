"""Polylines: a segment's direction and length, and walking a polyline at a fixed step (the kernel behind
:func:`bhr.model._path.resample_polyline`)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["segment_direction", "walk_kernel"]


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
