"""The whole robot in exact follow-the-leader: the trail model (docs/locomotion.md).

A feeder at the anus pushes the robot's tail in by one feed per step. The
tip lays a *trail*: a chain of straight pieces one module length long, each
tilted from the one before by one of the five codes (rest, +x, +y, -x, -y
by alpha about the piece's own axes). Every joint of the robot slides along
that trail, all joints one module length apart, so at insertion depth ``p``
(in module lengths) joint ``j`` (0 = tip) sits at trail position ``p - j``:

    X(q) = T[floor q] + frac(q) (T[floor q + 1] - T[floor q])

``T[m]`` being the trail's vertices (``T[0]`` the trajectory's start, the
vertices before it on the straight line the robot enters along). Each module
is the chord between two consecutive joints. At whole module lengths the
chords are the trail's pieces and each joint holds the code the trail has at
its vertex -- the code the module ahead had there (exact follow-the-leader).
Between two vertices all joints share the fraction ``u = frac(p)`` and every
joint's tilt moves from one code to the next while its wires change state;
the module across vertex ``m`` is then the chord from ``X(m - 1 + u)`` to
``X(m + u)``. Every module that reaches vertex ``m`` occupies the same
chords there: the places the whole robot ever takes are the places the tip
took, so a trail clear for the tip is clear for every module behind it.

Across one vertex the chords sweep the region between the two pieces and
the quadratic Bezier curve ``(1-u)^2 T[m-1] + 2u(1-u) T[m] + u^2 T[m+1]``
(each chord touches it at its own fraction ``u``): the motion between two
steps is scored by that region's boundary -- the joints sliding along the
pieces and the arc of the curve between the two steps' fractions -- which
holds its smallest clearance wherever the distance to the centerline is
convex over it (module doc of :func:`sweep_table`).

The trail is planned by :mod:`bhr.solvers._trail` (the planner, with the
lumen solver's weights); this module moves the robot along it and scores
every step. Kernels here are compiled with numba; ``*_numpy`` functions are
the readable references the tests hold them to.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from bhr._run.body import check_body_modules
from bhr.model._path import approach_steps
from bhr.model._tube import Tube, lumen_end_of, nearest_kernel, point_clearance, scored_span
from bhr.model._wallmesh import grid_args, mesh_segment, sdf_at, wall_grid
from bhr._run.clearance import clearance_chain_kernel, index_matched_min, robot_labels, tables_report, wall_label
from bhr._settings.errors import BhrError
from bhr._settings.inputs import check_step_points
from bhr.solvers._trail import dense_tube, plan_trail, trail_vertices

__all__ = ["TrailRun", "trail_poses", "trail_tables", "trail_poses_numpy", "chord_sweep_numpy", "sweep_bound_mm",
           "cecum_modules"]

#: Samples per mm of the Bezier arc between two steps (refined by a golden-section search).
_ARC_PER_MM = 2.0
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0


def sweep_bound_mm(module_length: float, alpha_deg: float) -> tuple[float, float]:
    """(model, rigid): how far the model's robot and a robot of rigid modules whose joints all lie on the trail
    can be from the trail, in mm: ``(L/2) sin(alpha/2)`` and ``(L/2) tan(alpha/2)`` (docs/locomotion.md)."""
    h = 0.5 * math.radians(alpha_deg)
    return 0.5 * module_length * math.sin(h), 0.5 * module_length * math.tan(h)


def cecum_modules(steps: int, feed_divisor: int, head: int) -> int:
    """Modules of a robot that reaches the cecum from the anus: the trail's length in module lengths (at least
    the head)."""
    return max(int(head), int(math.ceil((steps - 1) / feed_divisor)))


# ---------------------------------------------------------------------------
# the robot's poses along the trail (the trail itself: bhr.solvers._trail)


@njit(cache=True)
def poses_kernel(T, back, f, joints, stop, out):
    """out[i, j] = X(min(i, stop) / f - j) for every step i and joint j (0 = tip): the robot along the trail, the
    feeder stopped after step ``stop`` (the tip at the cecum)."""
    N = out.shape[0]
    for i in range(N):
        for j in range(joints):
            q = min(i, stop) - j * f
            m = q // f
            k = q - m * f
            u = k / f
            r = back + m
            for b in range(3):
                out[i, j, b] = T[r, b] + u * (T[r + 1, b] - T[r, b])


def trail_poses(T: np.ndarray, back: int, f: int, steps: int, joints: int, stop: int | None = None) -> np.ndarray:
    """(steps, joints, 3): every joint at every step, tip first (:func:`poses_kernel`)."""
    out = np.empty((steps, joints, 3))
    poses_kernel(T, int(back), int(f), int(joints), int(steps - 1 if stop is None else stop), out)
    return out


def _insertion(steps: int, stop: int | None) -> np.ndarray:
    """Each step's insertion in feeds: the step, up to ``stop``."""
    i = np.arange(steps)
    return i if stop is None else np.minimum(i, stop)


def trail_poses_numpy(T: np.ndarray, back: int, f: int, steps: int, joints: int, stop: int | None = None
                      ) -> np.ndarray:
    """:func:`trail_poses` in numpy (the reference)."""
    q = _insertion(steps, stop)[:, None] - np.arange(joints)[None, :] * f
    m = np.floor_divide(q, f)
    u = ((q - m * f) / f)[..., None]
    r = back + m
    return T[r] + u * (T[r + 1] - T[r])


def step_codes(codes: np.ndarray, f: int, steps: int, joints: int, stop: int | None = None) -> np.ndarray:
    """(steps, joints) the code each joint (0 = tip) is driven to: at vertex m it holds the trail's code there;
    once it has left it, the next vertex's (its wires change state on the way)."""
    q = _insertion(steps, stop)[:, None] - np.arange(joints)[None, :] * f
    m = np.floor_divide(q, f)
    k = q - m * f
    v = np.where(k == 0, m, m + 1)
    out = np.zeros(q.shape, dtype=np.int64)
    ok = (v >= 0) & (v < len(codes))
    out[ok] = np.asarray(codes, dtype=np.int64)[v[ok]]
    return out


# ---------------------------------------------------------------------------
# clearance of every chord and of the motion between steps, once per place along the trail


@njit(cache=True)
def _hints_kernel(C, R, w, pre, sp, T, back, L, out):
    """Where along the centerline (tube index) each trail vertex is: tracked from the start, the window moved on
    by one module length per vertex (straight behind the start)."""
    M = C.shape[0]
    for r in range(T.shape[0]):
        m = r - back
        if m <= 0:
            out[r] = pre + m * L / sp
        else:
            z = out[r - 1] + L / sp
            lo = max(0, int(math.floor(z - w)))
            hi = min(M - 1, int(math.ceil(z + w)))
            if hi <= lo:
                hi = lo + 1
            _, _, pos = nearest_kernel(C, R, lo, hi, T[r, 0], T[r, 1], T[r, 2])
            out[r] = pos


@njit(cache=True)
def _arc_clear(C, R, w, radius, T, r, z, u):
    """Clearance of the Bezier point at fraction u across vertex row r (its window around the interpolated hint)."""
    a0 = (1 - u) * (1 - u)
    a1 = 2 * u * (1 - u)
    a2 = u * u
    px = a0 * T[r - 1, 0] + a1 * T[r, 0] + a2 * T[r + 1, 0]
    py = a0 * T[r - 1, 1] + a1 * T[r, 1] + a2 * T[r + 1, 1]
    pz = a0 * T[r - 1, 2] + a1 * T[r, 2] + a2 * T[r + 1, 2]
    x = 2.0 * u  # position from vertex r-1, in pieces
    if x <= 1.0:
        g = z[r - 1] + x * (z[r] - z[r - 1])
    else:
        g = z[r] + (x - 1.0) * (z[r + 1] - z[r])
    M = C.shape[0]
    lo = max(0, int(math.floor(g - w)))
    hi = min(M - 1, int(math.ceil(g + w)))
    if hi <= lo:
        hi = lo + 1
    d, rad, _ = nearest_kernel(C, R, lo, hi, px, py, pz)
    return rad - radius - d, px, py, pz


@njit(cache=True)
def tables_kernel(C, R, S, BC, BR, N, pre, w, radius, T, z, back, f, m_lo, m_hi, L, sample, pc, mc, mwhere, sw,
                  swhere):
    """Per vertex m (m_lo <= m < m_hi, row m - m_lo) and fraction k/f (k < f):

    * pc: the clearance of the point X(m + k/f) (NaN behind the start, trail position < 0);
    * mc, mwhere: the smallest clearance along the chord X(m - 1 + k/f) -> X(m + k/f), and where;
    * sw, swhere: the smallest clearance of the motion from fraction k/f to (k+1)/f across vertex m: the two
      joints sliding along their pieces and the arc of the Bezier curve between (the boundary of what the chord
      sweeps; chords at both ends are mc's).
    """
    Q = np.empty((2, 3))
    E = np.empty(2)
    Z = np.empty(2)
    pt = np.empty(2)
    mo = np.empty(1)
    wh = np.empty((1, 3))
    fd = np.empty(2)
    res = np.empty(4)
    for m in range(m_lo, m_hi):
        i = m - m_lo
        r = back + m
        for k in range(f):
            u = k / f
            u1 = (k + 1) / f
            # the chord (the module across vertex m at fraction u)
            for b in range(3):
                Q[0, b] = T[r - 1, b] + u * (T[r, b] - T[r - 1, b])
                Q[1, b] = T[r, b] + u * (T[r + 1, b] - T[r, b])
            E[0] = m - 1 + u
            E[1] = m + u
            Z[0] = z[r - 1] + u * (z[r] - z[r - 1])
            Z[1] = z[r] + u * (z[r + 1] - z[r])
            clearance_chain_kernel(C, R, S, BC, BR, N, pre, w, radius, Q, E, Z, sample, pt, mo, wh, fd, res)
            pc[i, k] = pt[1]
            mc[i, k] = mo[0]
            for b in range(3):
                mwhere[i, k, b] = wh[0, b]
            best = 1e300
            bx = np.nan
            by = np.nan
            bz = np.nan
            # the two joints sliding from u to u1 along their pieces
            for side in range(2):
                rr = r - 1 + side
                for b in range(3):
                    Q[0, b] = T[rr, b] + u * (T[rr + 1, b] - T[rr, b])
                    Q[1, b] = T[rr, b] + u1 * (T[rr + 1, b] - T[rr, b])
                E[0] = m - 1 + side + u
                E[1] = m - 1 + side + u1
                Z[0] = z[rr] + u * (z[rr + 1] - z[rr])
                Z[1] = z[rr] + u1 * (z[rr + 1] - z[rr])
                clearance_chain_kernel(C, R, S, BC, BR, N, pre, w, radius, Q, E, Z, sample, pt, mo, wh, fd, res)
                if not math.isnan(mo[0]) and mo[0] < best:
                    best = mo[0]
                    bx, by, bz = wh[0, 0], wh[0, 1], wh[0, 2]
            # the arc of the envelope between u and u1 (parts behind the start not scored)
            lo_u = u
            if m - 1 + 2 * lo_u < 0.0:
                lo_u = 0.5 * (1.0 - m)
            if lo_u < u1:
                ns = int(math.ceil(_ARC_PER_MM * 2.0 * L * (u1 - lo_u) / sample)) + 1
                ba = 1e300
                bu = lo_u
                for q in range(ns + 1):
                    uu = lo_u + (u1 - lo_u) * q / ns
                    v, px, py, pz = _arc_clear(C, R, w, radius, T, r, z, uu)
                    if v < ba:
                        ba = v
                        bu = uu
                a = max(lo_u, bu - (u1 - lo_u) / ns)
                b2 = min(u1, bu + (u1 - lo_u) / ns)
                for _ in range(20):
                    x1 = b2 - _GOLD * (b2 - a)
                    x2 = a + _GOLD * (b2 - a)
                    f1 = _arc_clear(C, R, w, radius, T, r, z, x1)[0]
                    f2 = _arc_clear(C, R, w, radius, T, r, z, x2)[0]
                    if f1 < f2:
                        b2 = x2
                    else:
                        a = x1
                v, px, py, pz = _arc_clear(C, R, w, radius, T, r, z, 0.5 * (a + b2))
                if v < ba:
                    ba = v
                    bu = 0.5 * (a + b2)
                v, px, py, pz = _arc_clear(C, R, w, radius, T, r, z, bu)
                if ba < best:
                    best = ba
                    bx, by, bz = px, py, pz
            sw[i, k] = best if best < 1e299 else np.nan
            swhere[i, k, 0] = bx
            swhere[i, k, 1] = by
            swhere[i, k, 2] = bz


@njit(cache=True)
def _mesh_arc_clear(V, o, h, radius, T, r, u):
    """Clearance against the mesh of the Bezier point at fraction u across vertex row r, and the point."""
    a0 = (1 - u) * (1 - u)
    a1 = 2 * u * (1 - u)
    a2 = u * u
    px = a0 * T[r - 1, 0] + a1 * T[r, 0] + a2 * T[r + 1, 0]
    py = a0 * T[r - 1, 1] + a1 * T[r, 1] + a2 * T[r + 1, 1]
    pz = a0 * T[r - 1, 2] + a1 * T[r, 2] + a2 * T[r + 1, 2]
    return -sdf_at(V, o[0], o[1], o[2], h, px, py, pz) - radius, px, py, pz


@njit(cache=True)
def _mesh_piece(V, o, h, radius, Q, ea, eb, sample, res):
    """The smallest clearance against the mesh along Q[0] -> Q[1] whose ends are at trail positions ea, eb (the part
    behind the start, position < 0, not scored): res = (clearance or NaN, t)."""
    lo_t, hi_t = scored_span(ea, eb)
    mesh_segment(V, o, h, radius, Q[0, 0], Q[0, 1], Q[0, 2], Q[1, 0], Q[1, 1], Q[1, 2], lo_t, hi_t, sample, res)


@njit(cache=True)
def mesh_tables_kernel(V, o, h, radius, T, back, f, m_lo, m_hi, L, sample, pc, mc, mwhere, sw, swhere):
    """:func:`tables_kernel` against the signed-distance grid ``V`` (origin ``o``, spacing ``h``) of the colon's
    surface: the same places (chords, joints sliding along their pieces, the Bezier arc between two steps), each
    clearance ``-phi - radius``."""
    Q = np.empty((2, 3))
    res = np.empty(2)
    for m in range(m_lo, m_hi):
        i = m - m_lo
        r = back + m
        for k in range(f):
            u = k / f
            u1 = (k + 1) / f
            for b in range(3):
                Q[0, b] = T[r - 1, b] + u * (T[r, b] - T[r - 1, b])
                Q[1, b] = T[r, b] + u * (T[r + 1, b] - T[r, b])
            pc[i, k] = np.nan if m + u < 0.0 else -sdf_at(V, o[0], o[1], o[2], h, Q[1, 0], Q[1, 1], Q[1, 2]) - radius
            _mesh_piece(V, o, h, radius, Q, m - 1 + u, m + u, sample, res)
            mc[i, k] = res[0]
            for b in range(3):
                mwhere[i, k, b] = np.nan if res[1] < 0.0 else Q[0, b] + res[1] * (Q[1, b] - Q[0, b])
            best = 1e300
            bx = np.nan
            by = np.nan
            bz = np.nan
            for side in range(2):
                rr = r - 1 + side
                for b in range(3):
                    Q[0, b] = T[rr, b] + u * (T[rr + 1, b] - T[rr, b])
                    Q[1, b] = T[rr, b] + u1 * (T[rr + 1, b] - T[rr, b])
                _mesh_piece(V, o, h, radius, Q, m - 1 + side + u, m - 1 + side + u1, sample, res)
                if res[1] >= 0.0 and res[0] < best:
                    best = res[0]
                    bx = Q[0, 0] + res[1] * (Q[1, 0] - Q[0, 0])
                    by = Q[0, 1] + res[1] * (Q[1, 1] - Q[0, 1])
                    bz = Q[0, 2] + res[1] * (Q[1, 2] - Q[0, 2])
            lo_u = u
            if m - 1 + 2 * lo_u < 0.0:
                lo_u = 0.5 * (1.0 - m)
            if lo_u < u1:
                ns = int(math.ceil(_ARC_PER_MM * 2.0 * L * (u1 - lo_u) / sample)) + 1
                ba = 1e300
                bu = lo_u
                for q in range(ns + 1):
                    uu = lo_u + (u1 - lo_u) * q / ns
                    v = _mesh_arc_clear(V, o, h, radius, T, r, uu)[0]
                    if v < ba:
                        ba = v
                        bu = uu
                a = max(lo_u, bu - (u1 - lo_u) / ns)
                b2 = min(u1, bu + (u1 - lo_u) / ns)
                for _ in range(20):
                    x1 = b2 - _GOLD * (b2 - a)
                    x2 = a + _GOLD * (b2 - a)
                    if _mesh_arc_clear(V, o, h, radius, T, r, x1)[0] < _mesh_arc_clear(V, o, h, radius, T, r, x2)[0]:
                        b2 = x2
                    else:
                        a = x1
                v = _mesh_arc_clear(V, o, h, radius, T, r, 0.5 * (a + b2))[0]
                if v < ba:
                    ba = v
                    bu = 0.5 * (a + b2)
                v, px, py, pz = _mesh_arc_clear(V, o, h, radius, T, r, bu)
                if ba < best:
                    best = ba
                    bx, by, bz = px, py, pz
            sw[i, k] = best if best < 1e299 else np.nan
            swhere[i, k, 0] = bx
            swhere[i, k, 1] = by
            swhere[i, k, 2] = bz


def vertex_hints(tube: Tube, T: np.ndarray, back: int, L: float) -> np.ndarray:
    """Where along the centerline (tube index) each vertex row of ``T`` is (:func:`_hints_kernel`)."""
    z = np.empty(T.shape[0])
    _hints_kernel(tube.points, tube.radius, float(tube.window), float(tube.pre), float(tube.spacing), T, int(back),
                  float(L), z)
    return z


def _first_at_end(tube: Tube, z: np.ndarray, back: int, f: int, steps: int) -> int | None:
    """The first step (0-based) of ``steps`` at which the tip's centerline hint reaches the path's end, or None."""
    end = float(tube.points.shape[0] - tube.post - 1)
    q = np.arange(steps)
    m = q // f
    u = (q - m * f) / f
    r = back + m
    zt = z[r] + u * (z[r + 1] - z[r])
    hit = np.nonzero(zt >= end)[0]
    return int(hit[0]) if hit.size else None


def plan_to_cecum(tube: Tube, robot, settings: dict, path_steps: int, start_direction, start_point
                  ) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The trail a whole robot follows to the cecum: (its codes, one per vertex; their centerline hints with 2 rows
    before vertex 0, :func:`vertex_hints`; the run's steps; the step, 0-based, at which the tip reaches the path's
    end along the centerline, where the feeder stops).

    The feeder inserts one feed a step. A trail that weaves about the centerline covers less of the colon than
    its length, so after the path's ``path_steps`` insertions its tip can still be short of the cecum: the feeder
    then pushes on, the trail planned on, until the tip gets there (at most :func:`bhr.model._path.approach_steps`
    further; the run has those steps too, their target the path's end). A tip that does not get there even so
    stops where the path's length takes it, short of the cecum.
    """
    f, L = int(robot.feed_divisor), float(robot.module_length)
    N = int(path_steps)
    codes = plan_trail(tube, robot, settings, (N - 1) // f + 1, start_direction, start_point)
    z = vertex_hints(tube, trail_vertices(codes, start_direction, start_point, L, robot.alpha, 2), 2, L)
    hit = _first_at_end(tube, z, 2, f, N)
    if hit is not None:
        return codes, z, N, hit
    longer = N + approach_steps(N)
    more = plan_trail(tube, robot, settings, (longer - 1) // f + 1, start_direction, start_point)
    zm = vertex_hints(tube, trail_vertices(more, start_direction, start_point, L, robot.alpha, 2), 2, L)
    hit = _first_at_end(tube, zm, 2, f, longer)
    if hit is None:
        return codes, z, N, N - 1
    steps = max(N, hit + 1)
    V = (steps - 1) // f + 1  # a vertex's hint depends only on the vertices before it: the hints of these are zm's
    return np.ascontiguousarray(more[:V]), np.ascontiguousarray(zm[:2 + V + 1]), steps, hit


def trail_tables(tube: Tube, radius: float, T: np.ndarray, back: int, f: int, m_lo: int, m_hi: int, L: float,
                 sample: float = 1.0, grid=None) -> dict[str, np.ndarray]:
    """:func:`tables_kernel` over vertices m_lo .. m_hi - 1: pc, mc, mwhere, sw, swhere, and the vertex hints;
    with ``grid`` (the colon surface's :class:`bhr.model._wallmesh.SdfGrid`) :func:`mesh_tables_kernel`."""
    z = vertex_hints(tube, T, back, L)
    n = m_hi - m_lo
    out = {"pc": np.empty((n, f)), "mc": np.empty((n, f)), "mwhere": np.empty((n, f, 3)), "sw": np.empty((n, f)),
           "swhere": np.empty((n, f, 3)), "z": z}
    if grid is not None:
        mesh_tables_kernel(*grid_args(grid), float(radius), np.ascontiguousarray(T, dtype=np.float64), int(back),
                           int(f), int(m_lo), int(m_hi), float(L), float(sample), out["pc"], out["mc"], out["mwhere"],
                           out["sw"], out["swhere"])
        return out
    S, BC, BR = tube.search_arrays()
    tables_kernel(tube.points, tube.radius, S, BC, BR, tube.mitre_normals(), float(tube.pre), float(tube.window),
                  float(radius), T, z, int(back), int(f), int(m_lo), int(m_hi), float(L), float(sample), out["pc"],
                  out["mc"], out["mwhere"], out["sw"], out["swhere"])
    return out


def chord_sweep_numpy(tube: Tube, radius: float, T: np.ndarray, z: np.ndarray, r: int, u0: float, u1: float,
                      chords: int = 41, samples: int = 41) -> float:
    """The smallest clearance over every chord across vertex row ``r`` at fractions u0..u1, sampled on a grid
    (``chords`` fractions x ``samples`` points along each chord): the brute-force reference of the motion."""
    best = math.inf
    for u in np.linspace(u0, u1, chords):
        A = T[r - 1] + u * (T[r] - T[r - 1])
        B = T[r] + u * (T[r + 1] - T[r])
        za = z[r - 1] + u * (z[r] - z[r - 1])
        zb = z[r] + u * (z[r + 1] - z[r])
        for t in np.linspace(0.0, 1.0, samples):
            best = min(best, point_clearance(tube, radius, A + t * (B - A), 0.0, za + t * (zb - za)))
    return best


# ---------------------------------------------------------------------------
# a run


@dataclass
class TrailRun:
    """A run in the trail model: the trail, the whole robot at every step, and the clearance tables."""

    codes: np.ndarray  # (V,) the trail's code at each vertex 0 .. V-1
    vertices: np.ndarray  # (back + V + 1, 3)
    back: int
    joints: np.ndarray  # (N, M + 1, 3) every joint, tip first
    joint_codes: np.ndarray  # (N, M + 1) the code each joint is driven to
    tables: dict[str, np.ndarray]
    m_lo: int
    modules: int  # M, the whole robot
    stop: int  # the last step the feeder pushes (0-based): the tip has reached the end of the path (the cecum)
    shortfall_mm: float = 0.0  # how far along the centerline the tip ends short of the path's end (0: reached)
    wall: str = "tube"  # what the tables were measured against (bhr.model._wallmesh.wall_grid)

    def module_clearance(self, f: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N, M+1) joints' clearance; (N, M) modules' smallest clearance over their pose and their motion from
        the step before, tip module first; (N, M, 3) where."""
        N, J = self.joints.shape[0], self.joints.shape[1]
        q = _insertion(N, self.stop)[:, None] - np.arange(J)[None, :] * f
        m = np.floor_divide(q, f)
        k = q - m * f
        tb = self.tables
        pts = tb["pc"][m - self.m_lo, k]
        # module j (front joint j): the chord with its front at q
        qm, mm, km = q[:, :-1], m[:, :-1], k[:, :-1]
        pose = tb["mc"][mm - self.m_lo, km]
        where = tb["mwhere"][mm - self.m_lo, km]
        qp = qm - 1
        mp = np.floor_divide(qp, f)
        kp = qp - mp * f
        motion = tb["sw"][mp - self.m_lo, kp]
        mwh = tb["swhere"][mp - self.m_lo, kp]
        motion[0] = np.nan  # no motion into the first step, nor once the feeder has stopped
        motion[self.stop + 1:] = np.nan
        with np.errstate(invalid="ignore"):
            use = np.isfinite(motion) & ~(pose <= motion)
        mods = np.where(use, motion, pose)
        where = np.where(use[..., None], mwh, where)
        return pts, mods, where


def run_trail(traj, robot, settings: dict, window_mm: float, modules: int | None, reach: bool = False) -> TrailRun:
    """Plan the trail along ``traj`` (which needs a lumen) and move the whole robot of ``modules`` modules (or,
    ``reach``, of as many as reach the cecum) along it, one feed per step until the tip reaches the path's end;
    the clearance tables of every place it takes."""
    if traj.lumen is None:
        raise BhrError(f"locomotion trail plans the trail against the lumen; {traj.name} has none (give a "
                       "trajectory with a lumen, e.g. --traj anatomy)")
    N = int(traj.points.shape[0])
    f = int(robot.feed_divisor)
    L = float(robot.module_length)
    tube = dense_tube(traj.points, traj.lumen, traj.start_direction, window_mm,
                      closed_end=getattr(traj, "lumen_end", "closed") == "closed")
    codes, z, N, stop = plan_to_cecum(tube, robot, settings, N, traj.start_direction, traj.start_point)
    V = codes.shape[0]
    m, k = divmod(stop, f)
    ztip = z[2 + m] + (k / f) * (z[3 + m] - z[2 + m])
    short = max(0.0, float(tube.points.shape[0] - tube.post - 1 - ztip) * float(tube.spacing))
    if reach:
        modules = check_body_modules(cecum_modules(stop + 1, f, robot.modules), robot.modules, "reach cecum")
    M = int(robot.modules if modules is None else modules)
    check_step_points(N, M + 1)  # the steps to the cecum, now known, before the poses are kept
    back = M + 2
    T = trail_vertices(codes, traj.start_direction, traj.start_point, L, robot.alpha, back)
    joints = trail_poses(T, back, f, N, M + 1, stop)
    jc = step_codes(codes, f, N, M + 1, stop)
    m_lo = -M - 1
    grid, wall = wall_grid(traj)
    tables = trail_tables(tube, float(robot.robot_radius), T, back, f, m_lo, V, L, grid=grid)
    return TrailRun(codes, T, back, joints, jc, tables, m_lo, M, stop, short, wall)


def trail_report(result):
    """The :class:`~bhr._run.clearance.ClearanceReport` of a trail run: every joint and module at every step, a module's
    clearance the smaller of its pose's and its motion's from the step before."""
    tr = result.trail
    r = result.robot
    n, f = r.modules, r.feed_divisor
    M = tr.modules
    B = M - n
    jp, jm, jw = tr.module_clearance(f)
    p_idx = [n - jj for jj in range(n + 1)] + [n + k for k in range(1, B + 1)]
    m_idx = [n - 1 - jj for jj in range(n)] + [n + k - 1 for k in range(1, B + 1)]
    table, mtable, mwhere = jp[:, p_idx], jm[:, m_idx], jw[:, m_idx]
    labels, mlabels = robot_labels(n, B)
    rep = tables_report(table, labels, mtable, mlabels, mwhere, float(r.feed), index_matched_min(result, B),
                        lumen_end_of(result.trajectory), tr.stop + 1)[0]
    rep.wall = wall_label(result.trajectory, getattr(tr, "wall", "tube"))
    return rep
