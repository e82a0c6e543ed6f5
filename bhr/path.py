"""A trajectory as the solvers and the follow-the-leader driver see it: points and what is known about them.

:class:`Trajectory` is what :func:`bhr.generators.load_trajectory` returns for a
built-in generator or a trajectory file (:mod:`bhr.pathfile`);
:func:`path_directions` gives the unit vectors between its points that the
follow-the-leader loop aims the tip along (thesis ch. 7).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bhr.errors import BhrError

__all__ = ["Trajectory", "path_directions"]


@dataclass
class Trajectory:
    """Points (N, 3) spaced by the feed, plus what is known about the path."""

    name: str
    points: np.ndarray
    params: dict[str, Any] = field(default_factory=dict)
    min_radius: float = math.inf
    lumen: np.ndarray | None = None  # lumen diameter (mm) at each point, if known
    source: str = ""
    start_direction: tuple[float, ...] = (1.0, 0.0, 0.0)  # x, y, z
    start_point: tuple[float, ...] = (0.0, 0.0, 0.0)
    #: How the lumen ends past the last point: "closed" (a blind end, as the cecum: past it is wall) or "open"
    #: (it goes on straight). The entrance (the first point) is always open: the robot comes in there.
    lumen_end: str = "closed"

    @property
    def planar(self) -> bool:
        """True when every point has the same z (drawn from the top)."""
        z = self.points[:, 2]
        return bool(np.ptp(z) <= 1e-9 * max(1.0, float(np.abs(self.points).max())))


def path_directions(path: np.ndarray) -> np.ndarray:
    """Unit vectors from each trajectory point to the next, (N-1, 3)."""
    diff = np.diff(path, axis=0)
    norms = np.linalg.norm(diff, axis=1)
    if np.any(norms == 0):
        k = int(np.argmin(norms))
        raise BhrError(f"trajectory points {k + 1} and {k + 2} are the same point; remove the duplicate")
    return diff / norms[:, None]
