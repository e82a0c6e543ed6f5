"""Whole-body follow-the-leader: the modules behind the solved head.

The solvers move a head of ``n`` modules; the rest of a robot of ``M``
modules follows it (thesis 5.1.3: the other modules repeat, as they pass each
point of the path, the configuration the leading modules had there). In the
thesis's model the robot advances by one feed (a fifth of a module) per step
and module 1, the head's rearmost module, tilts by 0 or alpha at every step
relative to its own previous direction (the "virtual module" behind it). So
module 1 has swept the path behind the head: the stretch of path that body
module ``k`` (``k = 1`` right behind module 1) occupies at step ``i`` is the
stretch module 1 occupied ``k f`` steps earlier, with its base joint at
``P_0`` of that step and its frame ``F1`` of that step.

Each step the body is laid along that sweep with binary joints, from the
head backwards:

* body module 1 is the thesis's virtual module: module 1's frame before this
  step's tilt, so the joint between it and module 1 is exactly the code the
  solver gave module 1;
* the joints behind it (each rest or a tilt by alpha about one of the
  module's local axes) are chosen together so that the rear end of body
  module ``k`` lies as near as possible to where module 1's base joint was
  ``k f`` steps ago, and its direction to module 1's direction then (a
  quarter of the module length squared per unit of squared direction
  difference): a beam search along the body keeping the ``BODY_BEAM`` best
  partial bodies, summing the squared misses.

Module 1 can retilt every feed (five times per module length) while a body
joint holds one tilt, so copying module 1's codes one module length later,
joint by joint, would drop most of its tilts; fitting the joints to the
swept path reproduces module 1's pose at each arc length as closely as
binary joints can. On planar paths that is within a few mm; along a helix a
chain of x/y tilts cannot keep its tilt axes aligned with the turning
bending plane, and the body strays further (docs/optimal.md gives figures).

Before the run started the robot lay straight along the trajectory's start
direction, so that is "where module 1 was" for steps before the first. Body
point ``k`` (the rear end of body module ``k``) is scored, like the head's
points, against the trajectory point ``(n + k) f`` steps behind the current
target, and body module ``k`` against the path direction there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from bhr._settings.errors import BhrError
from bhr._kinematics.codetable import SEARCH_CODES, SEARCH_INVERSE
from bhr._kinematics.frames import tilt_frame as _rot
from bhr._kinematics.leader import stable_argsort
from bhr._settings.options import BY_NAME
from bhr.model._path import path_directions
from bhr.model._robot import base_frame

__all__ = ["BodyRun", "simulate_body", "check_body_modules", "module1_frames", "whole_robot", "whole_robot_codes",
           "score_body"]

_CODE = SEARCH_CODES  # search index (rest, +x, +y, -x, -y) -> code
_IDX = {int(code): k for k, code in enumerate(SEARCH_CODES)}
_INVERSE = SEARCH_INVERSE  # +x <-> -x, +y <-> -y
#: Joint-code sequences kept while fitting the body to the trail, module by module.
BODY_BEAM = 16


@dataclass
class BodyRun:
    """The modules behind the head, at every step: index 0 is the module right behind module 1."""

    modules: int  # body modules (M - n)
    points: np.ndarray  # (N, B, 3) rear end of each body module
    codes: np.ndarray  # (N, B) each body module's tilt relative to the one behind it (0 for the last)
    point_errors_mm: np.ndarray  # (N, B) mm, 0 where not scored yet
    orientation_errors_deg: np.ndarray  # (N, B) degrees, 0 where not scored yet
    scored: np.ndarray  # (N, B) bool: the trajectory point this body point is scored against exists


@njit(cache=True)
def _frames_kernel(start, idx1, c, s, out):
    """Module 1's frame after each step's tilt, replayed from the start frame."""
    F = start.copy()
    for i in range(idx1.shape[0]):
        _rot(F, idx1[i], c, s, out[i])
        for a in range(3):
            for b in range(3):
                F[a, b] = out[i, a, b]


@njit(cache=True)
def _body_kernel(P0s, F1s, start, nb, f, feed, L, c, s, beam, pts, codes):
    """Rear ends and codes of the body modules at every step (module doc): a beam search along the body."""
    N = P0s.shape[0]
    B = beam
    bG = np.empty((nb + 1, B, 3, 3))  # member frames per depth
    bQ = np.empty((nb + 1, B, 3))  # member rear ends per depth
    bC = np.empty(B)
    par = np.zeros((nb + 1, B), dtype=np.int64)
    act = np.zeros((nb + 1, B), dtype=np.int64)
    cG = np.empty((5 * B, 3, 3))
    cQ = np.empty((5 * B, 3))
    cC = np.empty(5 * B)
    cPar = np.zeros(5 * B, dtype=np.int64)
    cA = np.zeros(5 * B, dtype=np.int64)
    R = np.empty(3)
    Ft = np.empty((3, 3))
    for i in range(N):
        # body module 1: the frame module 1 had before this step's tilt (the joint is module 1's own code)
        # element loops throughout, not array-slice assignment: that compiles numba's
        # string formatting and cost seconds on a machine's first run
        for a in range(3):
            for b in range(3):
                bG[1, 0, a, b] = start[a, b] if i == 0 else F1s[i - 1, a, b]
        for b in range(3):
            bQ[1, 0, b] = P0s[i, b] - L * bG[1, 0, 2, b]
        bC[0] = 0.0
        nm = 1
        for k in range(2, nb + 1):
            j = i - k * f
            if j >= 0:
                for b in range(3):
                    R[b] = P0s[j, b]
                for a in range(3):
                    for b in range(3):
                        Ft[a, b] = F1s[j, a, b]
            else:
                for b in range(3):
                    R[b] = P0s[0, b] + j * feed * start[2, b]
                for a in range(3):
                    for b in range(3):
                        Ft[a, b] = start[a, b]
            m = 0
            for q in range(nm):
                for a in range(5):
                    _rot(bG[k - 1, q], _INVERSE[a], c, s, cG[m])
                    e = 0.0
                    dz = 0.0
                    for b in range(3):
                        cQ[m, b] = bQ[k - 1, q, b] - L * cG[m, 2, b]
                        e += (cQ[m, b] - R[b]) ** 2
                        dz += (cG[m, 2, b] - Ft[2, b]) ** 2
                    cC[m] = bC[q] + e + 0.25 * L * L * dz
                    cPar[m] = q
                    cA[m] = a
                    m += 1
            order = stable_argsort(cC, m)
            nm = min(B, m)
            for u in range(nm):
                r = order[u]
                for a in range(3):
                    bQ[k, u, a] = cQ[r, a]
                    for b in range(3):
                        bG[k, u, a, b] = cG[r, a, b]
                bC[u] = cC[r]
                par[k, u] = cPar[r]
                act[k, u] = cA[r]
        # the best member, traced back to body module 1
        q = 0
        for k in range(nb, 0, -1):
            for b in range(3):
                pts[i, k - 1, b] = bQ[k, q, b]
            if k >= 2:
                codes[i, k - 2] = _CODE[act[k, q]]  # body module k-1 tilts by this relative to body module k
                q = par[k, q]
        codes[i, nb - 1] = 0


def module1_frames(codes: np.ndarray, start_direction, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """(start frame, module 1's frame after each step's tilt) replayed from the base codes (column 0)."""
    start = base_frame(start_direction)
    try:
        idx = np.array([_IDX[int(c)] for c in codes[:, 0]], dtype=np.int64)
    except KeyError:
        bad = next(int(c) for c in codes[:, 0] if int(c) not in _IDX)
        shapes = ", ".join(map(str, sorted(_IDX)))
        raise BhrError(f"module 1 has code {bad} in the run; the body follows tilts only (codes {shapes})") from None
    out = np.empty((len(idx), 3, 3))
    a = math.radians(alpha)
    _frames_kernel(start, idx, math.cos(a), math.sin(a), out)
    return start, out


def check_body_modules(body_modules: Any, head: int, name: str = "body_modules") -> int:
    """``body_modules`` (the whole robot's modules) as an int, at least the ``head`` modules; else BhrError
    naming it as the user gave it (``name``: ``--body-modules`` on the command line)."""
    if isinstance(body_modules, bool) or not isinstance(body_modules, (int, np.integer)):
        raise BhrError(f"{name} must be a whole number of modules, got {body_modules!r}")
    M = int(body_modules)
    if M < head:
        raise BhrError(f"{name} {M} is fewer than the {head} head modules; give at least {head} (the whole robot)")
    most = BY_NAME["body_modules"].limit
    if M > most:
        raise BhrError(f"{name} {M} is more than {most:g}; give a smaller robot")
    return M


def simulate_body(result, body_modules: int) -> BodyRun:
    """The ``body_modules - n`` modules behind the head of ``result`` (a :class:`bhr._run.driver.FollowResult`).

    ``body_modules`` is the whole robot's module count M (head included).
    Needs a run whose solver returns codes (binary tilts about local axes).
    """
    r = result.robot
    n = r.modules
    M = check_body_modules(body_modules, n)
    if result.codes is None:
        raise BhrError(f"the {result.solver} solver gives no module codes, so no body can repeat them; "
                       "use --solver thesis or --solver optimal with --body-modules")
    nb = M - n
    N = result.steps
    path = np.ascontiguousarray(result.trajectory.points[:N], dtype=np.float64)
    start, F1s = module1_frames(result.codes, result.trajectory.start_direction, r.alpha)
    # the replayed frames must be the run's: module 1's direction at every step
    d1 = result.points[:, 1] - result.points[:, 0]
    d1 /= np.linalg.norm(d1, axis=1)[:, None]
    if np.max(np.abs(d1 - F1s[:, 2])) > 1e-6:
        raise BhrError(f"the {result.solver} run's module 1 does not follow its codes; the body needs a binary "
                       "solver (thesis or optimal)")
    pts = np.zeros((N, nb, 3))
    codes = np.zeros((N, nb), dtype=np.int64)
    pe = np.zeros((N, nb))
    oe = np.zeros((N, nb))
    scored = np.zeros((N, nb), dtype=bool)
    if nb:
        a = math.radians(r.alpha)
        P0s = np.ascontiguousarray(result.points[:, 0])
        dirs = path_directions(path) if N > 1 else np.zeros((1, 3))
        _body_kernel(P0s, F1s, start, nb, int(r.feed_divisor), float(r.feed), float(r.module_length),
                     math.cos(a), math.sin(a), BODY_BEAM, pts, codes)
        score_body(result, pts, path, dirs, pe, oe, scored)
    return BodyRun(nb, pts, codes, pe, oe, scored)


def score_body(result, pts: np.ndarray, path: np.ndarray, dirs: np.ndarray, pe: np.ndarray, oe: np.ndarray,
                scored: np.ndarray) -> None:
    """Body point k against the trajectory point (n + k) f steps behind; body module k against the direction there."""
    r = result.robot
    n, f = r.modules, r.feed_divisor
    N, nb = pts.shape[0], pts.shape[1]
    steps = np.arange(N)[:, None]
    k = np.arange(1, nb + 1)[None, :]
    idx = steps - (n + k) * f
    ok = idx >= 0
    scored[:] = ok
    safe = np.where(ok, idx, 0)
    err = np.linalg.norm(pts - path[safe], axis=2)
    pe[:] = np.where(ok, err, 0.0)
    # body module k runs from body point k to the point in front of it (body point k-1, or the head's base)
    front = np.concatenate([result.points[:, :1], pts[:, :-1]], axis=1)
    u = front - pts
    u /= np.linalg.norm(u, axis=2)[..., None]
    dd = dirs[np.minimum(safe, max(len(dirs) - 1, 0))] if len(dirs) else np.zeros_like(u)
    cosang = np.clip(np.sum(u * dd, axis=2), -1.0, 1.0)
    oe[:] = np.where(ok, np.degrees(np.arccos(cosang)), 0.0)


def whole_robot_codes(head_codes: np.ndarray, body: BodyRun | None) -> np.ndarray:
    """The codes of every module of the whole robot at every step, rear module first: ``(N, B + n)``.

    Each module's code tilts it relative to the module behind it, as on the board that drives every module's
    wires: the rear module's own 0 (nothing behind it but the feeder), the body's joints from the rear forwards
    (``body.codes`` holds them front to back), then the head's codes (module 1 = the head's base). Without a body
    these are the head's codes.
    """
    head = np.asarray(head_codes, dtype=np.int64)
    if body is None or body.modules == 0:
        return head
    out = np.zeros((head.shape[0], body.modules + head.shape[1]), dtype=np.int64)
    out[:, 1:body.modules] = np.asarray(body.codes)[:, :-1][:, ::-1]
    out[:, body.modules:] = head
    return out


def whole_robot(result, step: int) -> np.ndarray:
    """Points of the whole robot at ``step`` (0-based), tail first: the body's rear ends, then the head's points."""
    body = getattr(result, "body", None)
    head = result.points[step]
    if body is None or body.modules == 0:
        return head
    return np.concatenate([body.points[step][::-1], head], axis=0)
