"""The physical robot's poses, as the replay reads them: the arrays of ``poses.npz`` (docs/physics.md).

``t_s`` (P,) time in s, ``insertion_mm`` (P,) the feeder's insertion (how far the rear end is past the
entrance along the insertion axis), ``points_mm`` (P, M+1, 3) the joints' positions rear first (the tip last),
``tilts_rad`` (P, M, 2) each joint's tilt as a rotation vector's two components in the axes of the module
behind it (joint 1 turns the rear module from the feeder's frame; the code table's axes,
bhr._kinematics.codetable), ``codes`` (P, M) and ``step`` (P,) the run's 1-based step of each pose.

A run that wrote ``poses.npz`` beside its ``run.json`` is read from it (:func:`load_poses`). Any other run is
converted by :func:`poses_from_run`: every written step's whole-robot codes, each code's tilt (``alpha`` about
its signed axis, 0 at rest), the rear end on the insertion axis at the run's insertion.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bhr._settings.errors import BhrError

__all__ = ["Poses", "POSE_KEYS", "poses_from_run", "poses_from_motion", "load_poses", "code_tilts", "chain_points",
           "start_direction"]

POSE_KEYS = ("t_s", "insertion_mm", "points_mm", "tilts_rad", "codes", "step")


@dataclass
class Poses:
    """The contract's arrays, and the frame they live in (the entrance and the feeder's frame)."""

    t_s: np.ndarray
    insertion_mm: np.ndarray
    points_mm: np.ndarray
    tilts_rad: np.ndarray
    codes: np.ndarray
    step: np.ndarray
    entrance: np.ndarray  # (3,) the lumen's entrance (the trajectory's first point)
    frame: np.ndarray  # (3, 3) the feeder's frame, rows x y z; z is the insertion axis
    module_length: float
    #: True: every pose the wires moved the robot through (poses.npz, or the run's motion in memory); False: the
    #: run's written steps only (:func:`poses_from_run`), between which the replay moves the joints linearly
    every_pose: bool = True

    @property
    def modules(self) -> int:
        return int(self.tilts_rad.shape[1])

    def check(self) -> None:
        if self.tilts_rad.ndim != 3:
            raise BhrError(f"poses: tilts_rad has shape {self.tilts_rad.shape}, expected (poses, modules, 2); "
                           "write the arrays of docs/physics.md")
        P, M = self.tilts_rad.shape[:2]
        shapes = {"t_s": (P,), "insertion_mm": (P,), "points_mm": (P, M + 1, 3), "tilts_rad": (P, M, 2),
                  "codes": (P, M), "step": (P,)}
        for k, shape in shapes.items():
            a = getattr(self, k)
            if a.shape != shape:
                raise BhrError(f"poses: {k} has shape {a.shape}, expected {shape}; write the arrays of docs/physics.md")
            if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                raise BhrError(f"poses: {k} holds a value that is not a finite number")
        if P == 0 or M == 0:
            raise BhrError("poses: no pose or no module to replay")
        from bhr._settings.inputs import MAX_MM
        from bhr.model._codes import VALID_CODES

        for k, top in (("points_mm", MAX_MM), ("insertion_mm", MAX_MM), ("tilts_rad", math.pi)):
            a = getattr(self, k)
            if np.abs(a).max() > top:
                raise BhrError(f"poses: {k} holds {float(a.flat[np.abs(a).argmax()]):g}, beyond +-{top:g}; write the "
                               "arrays of docs/physics.md")
        bad = ~np.isin(self.codes, list(VALID_CODES))
        if bad.any():
            raise BhrError(f"poses: codes holds {int(self.codes[bad][0])}, not a stable code "
                           f"({', '.join(map(str, sorted(VALID_CODES)))}); write the arrays of docs/physics.md")
        if self.step.min() < 1:
            raise BhrError(f"poses: step holds {int(self.step.min())}; steps count from 1 (docs/physics.md)")


def start_direction(result) -> np.ndarray:
    """The direction the robot lay along before the run (the trajectory's start direction, a unit vector)."""
    d = np.asarray(result.trajectory.start_direction, dtype=np.float64)
    return d / np.linalg.norm(d)


def code_tilts(codes: np.ndarray, alpha_rad: float) -> np.ndarray:
    """Each code's tilt (..., 2) as a rotation vector's x and y components: alpha about its signed axis."""
    from bhr._kinematics.codetable import SEARCH_AXIS, SEARCH_INDEX, SEARCH_SIGN

    c = np.asarray(codes, dtype=np.int64)
    k = SEARCH_INDEX[c]
    if np.any(k < 0):
        raise BhrError(f"poses: code {int(c[k < 0].flat[0])} is not a stable code (thesis Table 4.2)")
    out = np.zeros(c.shape + (2,))
    axis, sign = SEARCH_AXIS[k], SEARCH_SIGN[k]
    tilt = axis >= 0
    out[tilt, axis[tilt]] = sign[tilt] * alpha_rad
    return out


def _rotations(tilts: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of the rotation vectors (u, v, 0) given as ``tilts`` (..., 2)."""
    u, v = tilts[..., 0], tilts[..., 1]
    th = np.hypot(u, v)
    safe = np.where(th > 0.0, th, 1.0)
    kx, ky, s, c = u / safe, v / safe, np.sin(th), 1.0 - np.cos(th)
    # I + sin(th) K + (1 - cos(th)) K^2, K the cross-product matrix of the unit axis (kx, ky, 0)
    return np.stack([np.stack([1.0 - c * ky * ky, c * kx * ky, s * ky], -1),
                     np.stack([c * kx * ky, 1.0 - c * kx * kx, -s * kx], -1),
                     np.stack([-s * ky, s * kx, 1.0 - c], -1)], -2)


def chain_points(base: np.ndarray, frame: np.ndarray, tilts: np.ndarray, length: float) -> np.ndarray:
    """Joint positions (..., M+1, 3) of rigid chains from ``base`` (..., 3) and the feeder's ``frame`` (rows x y
    z), each module turned by its tilt (``tilts`` (..., M, 2): a rotation vector in the axes of the module behind)
    and ``length`` long; leading axes are chains (poses) computed together."""
    tilts = np.asarray(tilts, dtype=np.float64)
    M = tilts.shape[-2]
    A = np.broadcast_to(np.asarray(frame, dtype=np.float64).T, tilts.shape[:-2] + (3, 3))  # columns: the local axes
    pts = np.empty(tilts.shape[:-2] + (M + 1, 3))
    pts[..., 0, :] = base
    for j in range(M):
        A = A @ _rotations(tilts[..., j, :])
        pts[..., j + 1, :] = pts[..., j, :] + length * A[..., :, 2]
    return pts


def poses_from_run(result, step_s: float = 1.0) -> Poses:
    """A run's written steps as the contract's arrays: the whole robot's codes at every step (rear first), their
    tilts, and the rear end where the feeder puts it, on the insertion axis (the entrance's start direction) at the
    run's insertion depth. ``t_s`` is one ``step_s`` a step (a code switch takes about a second: the wire's
    contraction time, docs/thermal.md). A run that lifts (code 15) is refused: its modules change length."""
    from bhr.model._robot import base_frame
    from bhr._run.body import whole_robot, whole_robot_codes

    if result.codes is None:
        raise BhrError(f"the {result.solver} run has no module codes, so no joint tilts to replay; use a run of "
                       "--solver thesis, optimal or lumen")
    codes = np.asarray(whole_robot_codes(result.codes, result.body), dtype=np.int64)
    lifts = np.nonzero(np.any(codes == 15, axis=1))[0]
    if lifts.size:
        raise BhrError(f"the run lifts (code 15) at {lifts.size} steps, from step {int(lifts[0]) + 1}: bhr physics "
                       "replays rigid modules, whose lengths never change; use a run that never lifts")
    N, M = codes.shape
    r = result.robot
    d0 = start_direction(result)
    E = np.asarray(result.trajectory.points[0], dtype=np.float64)
    rear = np.stack([whole_robot(result, i)[0] for i in range(N)])
    depth = (rear - E) @ d0
    frame = base_frame(d0)
    tilts = code_tilts(codes, math.radians(r.alpha))
    pts = chain_points(E + depth[:, None] * d0, frame, tilts, r.module_length)
    return Poses(np.arange(N) * float(step_s), depth, pts, tilts, codes, np.arange(1, N + 1), E, frame,
                 float(r.module_length), every_pose=False)


def poses_from_motion(result) -> Poses | None:
    """The poses a run moved by its wires went through, from its motion in memory (what ``poses.npz`` holds), or
    None when the run kept none (a run of other locomotion, or too many poses to keep)."""
    mo = getattr(result, "motion", None)
    if mo is None or not mo.kept or not len(mo.t_s):
        return None
    return _poses_of(mo.npz(), result)


def _poses_of(arrays: dict[str, np.ndarray], result) -> Poses:
    """The contract's arrays (``poses.npz``'s) as checked :class:`Poses` in ``result``'s frame."""
    from bhr.model._robot import base_frame

    a = {k: np.asarray(arrays[k], dtype=np.int64 if k in ("codes", "step") else np.float64) for k in POSE_KEYS}
    p = Poses(a["t_s"], a["insertion_mm"], a["points_mm"], a["tilts_rad"], a["codes"], a["step"],
              np.asarray(result.trajectory.points[0], dtype=np.float64), base_frame(start_direction(result)),
              float(result.robot.module_length))
    p.check()
    return p


def load_poses(run_path: str | Path, result) -> Poses | None:
    """``poses.npz`` beside ``run_path`` (a run.json) as :class:`Poses`, or None when there is none."""
    if str(run_path) == "-":
        return None
    f = Path(run_path).with_name("poses.npz")
    if not f.is_file():
        return None
    import zipfile
    import zlib

    try:
        with np.load(f, allow_pickle=False) as z:
            arrays = {k: np.asarray(z[k]) for k in POSE_KEYS}
    except (OSError, ValueError, KeyError, EOFError, NotImplementedError, zipfile.BadZipFile, zlib.error) as exc:
        # a damaged archive (zipfile's BadZipFile, a CRC or inflate error) is as unreadable as a missing key
        why = (str(exc).splitlines() or [type(exc).__name__])[0][:80]
        raise BhrError(f"{f}: not a poses file with {', '.join(POSE_KEYS)} ({why}); write it again with bhr follow "
                       "--all-poses, or move it away to replay the run's steps") from None
    for k, a in arrays.items():
        if a.dtype.kind not in "biuf":
            raise BhrError(f"{f}: {k} holds {a.dtype} values, not numbers; write it again with bhr follow "
                           "--all-poses, or move it away to replay the run's steps")
        if k in ("codes", "step") and a.dtype.kind in "fu" and \
                not np.all(np.isfinite(a) & (a == np.round(a)) & (np.abs(a) < 2 ** 31)):
            raise BhrError(f"{f}: {k} holds a value that is not a whole number within +-2**31; write it again with "
                           "bhr follow --all-poses, or move it away to replay the run's steps")
    return _poses_of(arrays, result)
