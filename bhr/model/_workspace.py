"""The workspace of a binary robot: its reachable tips, exactly or sampled, and performance indices.

A binary robot of ``n`` modules whose modules each take ``K`` codes (the rest
and the four tilts, K = 5, and the lift, K = 6) reaches exactly ``K**n`` poses:
a finite cloud of tip points, the classic figure of binary manipulators. Up to
:data:`EXACT_LIMIT` poses :func:`workspace` computes every one
(:func:`bhr._kinematics.reach.enumerate_tips`); beyond, it draws codes at random,
every code equally likely (Monte Carlo), and says so.

The indices are those of manipulator performance evaluation that make sense
for a chain of binary joints (no Jacobian, no velocity: the joints only switch):
how many distinct tips and tip directions, the reach, the volume the tips
occupy (voxels holding at least one tip), the resolution (the distance from a
tip to its nearest other reachable tip: how finely the robot can place its
tip) and the density (poses per occupied voxel).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bhr.model._robot import Robot, base_frame
from bhr._settings.errors import BhrError
from bhr._settings.options import check_number

__all__ = ["Workspace", "workspace", "EXACT_LIMIT", "TILT_CHOICES", "LIFT_CHOICES"]

#: Most poses :func:`workspace` enumerates exactly (6**8 = 1,679,616 and 5**9 = 1,953,125 are under it).
EXACT_LIMIT = 2_000_000
#: Codes of a module without the lift: rest and the four tilts; with it, and the lift.
TILT_CHOICES = (0, 3, 6, 12, 9)
LIFT_CHOICES = (0, 3, 6, 12, 9, 15)
#: Most tips a workspace holds when sampled (the sampled poses: memory of 48 bytes each).
SAMPLE_LIMIT = 20_000_000
#: Tips closer than this (mm) are one point (rounding of the same pose reached by two code sequences).
SAME_TIP_MM = 1e-6


def _snap(a: np.ndarray) -> np.ndarray:
    """Points on a grid of :data:`SAME_TIP_MM` (+ 0.0: -0.0 becomes 0.0, which np.unique compares by bytes)."""
    return np.round(a / SAME_TIP_MM) * SAME_TIP_MM + 0.0


@dataclass(frozen=True)
class Workspace:
    """Reachable tips of ``robot``'s first ``modules`` modules (base at the origin, straight along +X).

    ``tips`` and ``directions`` (S, 3): one row per pose evaluated; ``exact``: every pose (S = K**n) or a
    Monte Carlo sample of S poses. ``voxel``: the edge (mm) of the cells of the volume and density.
    """

    robot: Robot
    modules: int
    choices: tuple[int, ...]
    exact: bool
    tips: np.ndarray
    directions: np.ndarray
    voxel: float
    seed: int | None = None
    _cache: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def poses(self) -> int:
        """Poses of the robot: K**n (all of them, whether enumerated or sampled)."""
        return len(self.choices) ** self.modules

    @property
    def evaluated(self) -> int:
        return int(self.tips.shape[0])

    def distinct_tips(self) -> np.ndarray:
        """The distinct tip points (within :data:`SAME_TIP_MM`), sorted."""
        if "distinct" not in self._cache:
            self._cache["distinct"] = np.unique(_snap(self.tips), axis=0)
        return self._cache["distinct"]

    def voxels(self) -> tuple[np.ndarray, np.ndarray]:
        """Occupied voxels (their integer indices, (V, 3)) and the poses whose tip falls in each (V,)."""
        if "voxels" not in self._cache:
            idx = np.floor(self.tips / self.voxel).astype(np.int64)
            cells, counts = np.unique(idx, axis=0, return_counts=True)
            self._cache["voxels"] = (cells, counts)
        return self._cache["voxels"]

    def resolution(self) -> tuple[float, float]:
        """Median and largest distance (mm) from a distinct tip to its nearest other distinct tip."""
        if "resolution" not in self._cache:
            from scipy.spatial import cKDTree

            pts = self.distinct_tips()
            if len(pts) < 2:
                self._cache["resolution"] = (math.nan, math.nan)
            else:
                d, _ = cKDTree(pts).query(pts, k=2)
                self._cache["resolution"] = (float(np.median(d[:, 1])), float(d[:, 1].max()))
        return self._cache["resolution"]

    def indices(self) -> dict[str, Any]:
        """The performance indices, as ``bhr workspace --json`` writes them (mm, mm^3, deg)."""
        r = np.linalg.norm(self.tips, axis=1)
        cells, counts = self.voxels()
        med, worst = self.resolution()
        dirs = np.unique(_snap(self.directions), axis=0)
        bend = np.degrees(np.arccos(np.clip(self.directions[:, 0], -1.0, 1.0)))
        return {
            "modules": self.modules,
            "codes_per_module": list(self.choices),
            "poses": self.poses,
            "method": "exact" if self.exact else "monte carlo",
            "evaluated_poses": self.evaluated,
            "seed": self.seed,
            "distinct_tips": int(self.distinct_tips().shape[0]),
            "distinct_tip_directions": int(dirs.shape[0]),
            "reach_max_mm": float(r.max()),
            "reach_min_mm": float(r.min()),
            "voxel_mm": self.voxel,
            "occupied_voxels": int(cells.shape[0]),
            "volume_mm3": float(cells.shape[0] * self.voxel ** 3),
            "poses_per_voxel_mean": float(counts.mean()),
            "poses_per_voxel_max": int(counts.max()),
            "resolution_median_mm": med,
            "resolution_worst_mm": worst,
            "tip_bend_max_deg": float(bend.max()),
        }


def workspace(robot: Robot | None = None, modules: int | None = None, *, lift: bool = True,
              exact: bool | None = None, samples: int = 1_000_000, seed: int = 0,
              voxel: float | None = None) -> Workspace:
    """Every reachable tip of ``robot``'s first ``modules`` modules (default all its modules), or a sample.

    ``lift``: modules may also lift (code 15), K = 6 codes per module; else K = 5.
    ``exact``: enumerate all K**n poses (default: when they are at most :data:`EXACT_LIMIT`); False: draw
    ``samples`` poses at random (every code equally likely, numpy's generator seeded by ``seed``). ``voxel``: the
    edge of the volume's cells in mm (default a fifth of a module length, the feed of the thesis's robot).

    Two code sequences can reach one tip (a tilt of module 1 undone by module 2 puts the tip where a tilt
    of module 2 alone does): 2 modules without the lift have 25 poses and 21 distinct tips.

    >>> ws = workspace(Robot(modules=2), lift=False)
    >>> ws.poses, ws.indices()["distinct_tips"]
    (25, 21)
    """
    from bhr._kinematics.reach import enumerate_tips, tips_of_codes

    robot = Robot() if robot is None else robot
    if not isinstance(robot, Robot):
        raise BhrError(f"robot must be a bhr.Robot, got {type(robot).__name__}")
    n = robot.modules if modules is None else int(check_number(modules, "modules", integer=True, limit=10_000,
                                                               positive=True))
    choices = LIFT_CHOICES if lift else TILT_CHOICES
    poses = len(choices) ** n
    if exact is None:
        exact = poses <= EXACT_LIMIT
    if exact and poses > EXACT_LIMIT:
        raise BhrError(f"{n} modules have {poses:.3g} poses, more than the {EXACT_LIMIT:,} bhr enumerates exactly; "
                       f"sample them instead (exact=False, bhr workspace --samples N)")
    if voxel is None:
        voxel = robot.module_length / 5.0
    check_number(voxel, "voxel", limit=1e6, positive=True)
    frame = base_frame((1, 0, 0))
    base = np.zeros(3)
    lift_mm = float(robot.lift)
    if exact:
        count = poses
        tips, dirs = np.empty((count, 3)), np.empty((count, 3))
        enumerate_tips(np.array(choices, dtype=np.int64), n, base, frame, float(robot.module_length), lift_mm,
                       float(robot.alpha), tips, dirs)
        return Workspace(robot, n, choices, True, tips, dirs, float(voxel))
    samples = int(check_number(samples, "samples", integer=True, limit=SAMPLE_LIMIT, positive=True))
    rng = np.random.default_rng(seed)
    tips, dirs = np.empty((samples, 3)), np.empty((samples, 3))
    chunk = max(1, 4_000_000 // n)  # rows of codes at a time: at most 32 MB of codes
    for start in range(0, samples, chunk):
        stop = min(samples, start + chunk)
        codes = np.asarray(choices, dtype=np.int64)[rng.integers(0, len(choices), size=(stop - start, n))]
        tips_of_codes(codes, base, frame, float(robot.module_length), lift_mm, float(robot.alpha),
                      tips[start:stop], dirs[start:stop])
    return Workspace(robot, n, choices, False, tips, dirs, float(voxel), seed=int(seed))
