"""Lumen clearance: how far the robot's surface stays from the wall of the lumen it follows.

A trajectory may carry the lumen's inner diameter at each point
(:attr:`bhr.trajectory.Trajectory.lumen`, from trajectory files; the
built-in colon has 30 mm in the rectum and 45 mm elsewhere). Each robot point
is scored against one trajectory point (bhr.follow); its clearance there is

    lumen diameter / 2  -  robot radius  -  distance from that trajectory point

in mm: the gap left between the robot's disc and the wall if the lumen is a
tube of that diameter around the path. Zero or less means the wall is
touched. Points whose trajectory point does not exist yet (the part of the
robot still behind the start of the path) have no clearance. With a body
(``--body-modules``) its points count too.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bhr.errors import BhrError

__all__ = ["ClearanceReport", "clearance_table", "clearance_report", "step_ranges"]


@dataclass
class ClearanceReport:
    """Clearance of every scored point at every step, and where it is smallest."""

    table: np.ndarray  # (N, P) mm, NaN where a point is not scored
    labels: list[str]  # name of each of the P points
    min_mm: float  # smallest clearance (NaN if nothing was scored)
    min_step: int  # 1-based step of the smallest clearance (0 if none)
    min_point: str  # which point
    touch_steps: list[int] = field(default_factory=list)  # 1-based steps where some point touches the wall

    @property
    def per_step(self) -> np.ndarray:
        """(N,) smallest clearance at each step (NaN where no point is scored)."""
        out = np.full(self.table.shape[0], np.nan)
        ok = ~np.all(np.isnan(self.table), axis=1)
        out[ok] = np.nanmin(self.table[ok], axis=1)
        return out

    def touches(self) -> list[tuple[int, int]]:
        """(step, point index) of every point touching the wall, steps 1-based."""
        with np.errstate(invalid="ignore"):
            s, p = np.nonzero(self.table <= 0.0)
        return [(int(a) + 1, int(b)) for a, b in zip(s, p)]

    def summary(self) -> dict:
        return {"min_clearance_mm": None if np.isnan(self.min_mm) else float(self.min_mm),
                "min_clearance_step": int(self.min_step), "min_clearance_point": self.min_point,
                "wall_touch_steps": list(self.touch_steps)}


def clearance_table(point_errors: np.ndarray, offsets: np.ndarray, lumen: np.ndarray, radius: float) -> np.ndarray:
    """(N, P) clearance in mm of points scored ``offsets[p]`` steps behind each step's target.

    ``point_errors`` (N, P) are the distances to those trajectory points,
    ``lumen`` the diameter at each trajectory point. NaN where the point's
    trajectory point does not exist (before the start).
    """
    pe = np.asarray(point_errors, dtype=np.float64)
    lum = np.asarray(lumen, dtype=np.float64)
    N = pe.shape[0]
    if lum.ndim != 1 or lum.shape[0] < N:
        raise BhrError(f"the lumen has {lum.shape[0] if lum.ndim == 1 else lum.shape} diameters for {N} steps; "
                       "give one diameter per trajectory point")
    idx = np.arange(N)[:, None] - np.asarray(offsets, dtype=np.int64)[None, :]
    ok = idx >= 0
    table = np.full(pe.shape, np.nan)
    table[ok] = lum[idx[ok]] / 2.0 - radius - pe[ok]
    return table


def clearance_report(result) -> ClearanceReport | None:
    """The clearance of a run (:class:`bhr.follow.FollowResult`) whose trajectory has a lumen, else None."""
    lumen = result.trajectory.lumen
    if lumen is None:
        return None
    r = result.robot
    n, f = r.modules, r.feed_divisor
    offsets = [(n - j) * f for j in range(n + 1)]
    labels = [f"point {j + 1}" + (" (base)" if j == 0 else "") + (" (tip)" if j == n else "") for j in range(n + 1)]
    errors = result.point_errors
    body = getattr(result, "body", None)
    if body is not None and body.modules:
        offsets += [(n + k) * f for k in range(1, body.modules + 1)]
        labels += [f"body point {k}" for k in range(1, body.modules + 1)]
        errors = np.concatenate([errors, body.point_errors], axis=1)
    table = clearance_table(errors, np.array(offsets), lumen, r.radius)
    if np.all(np.isnan(table)):
        return ClearanceReport(table, labels, float("nan"), 0, "", [])
    flat = int(np.nanargmin(table))
    s, p = divmod(flat, table.shape[1])
    with np.errstate(invalid="ignore"):
        touch = np.nonzero(np.any(table <= 0.0, axis=1))[0]
    return ClearanceReport(table, labels, float(table[s, p]), s + 1, labels[p], [int(t) + 1 for t in touch])


def step_ranges(steps: list[int]) -> str:
    """``[3, 4, 5, 9]`` -> ``"3-5, 9"`` for printing."""
    if not steps:
        return "none"
    out = []
    start = prev = steps[0]
    for s in steps[1:]:
        if s == prev + 1:
            prev = s
            continue
        out.append(f"{start}-{prev}" if prev > start else f"{start}")
        start = prev = s
    out.append(f"{start}-{prev}" if prev > start else f"{start}")
    return ", ".join(out)
