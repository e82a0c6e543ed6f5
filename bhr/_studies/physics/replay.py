"""The physical robot's replay against the colon's wall: the rigid, wire-held chain in equilibrium at every pose.

The robot moves as fast as its wires switch (about a second a code, docs/thermal.md) and the feeder feeds about
a millimetre a step: its inertial forces (a gram accelerated by mm/s^2: micronewtons) are nothing beside the wall's
and the wires', so at every pose the robot is in equilibrium (quasi-static). The replay finds that equilibrium:
the pose of the rigid chain (every module its full length, always) that minimises

    sum over joints   1/2 k_joint |tilt - target|^2             (the wires, bhr._studies.physics.joints; a passive
                                                                  body's joints: its bending stiffness, target 0)
  + sum over the axis 1/2 k_wall pen^2 ds                        (the wall, bhr._studies.physics.wall)
  + the feeder's                                                 (a stiff slide at the run's insertion that pushes
                                                                  with at most its force limit)

over the feeder's travel and every joint's two tilt components, starting from the equilibrium of the pose before
(the robot is where it was; a wall it leans on stays leaned on). The energy, its gradient and the Newton steps
that minimise it are compiled kernels over the chain (numba, :mod:`.equilibrium`). docs/physics.md describes the
model.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from bhr._settings.errors import BhrError
from bhr._studies.physics.equilibrium import MAX_ITERATIONS, global_seg, chain_points, Problem, solve_pose
from bhr._studies.physics.joints import PASSIVE_RIGIDITY_NMM2, WIRE_FORCE_N, joint_stiffness, passive_stiffness
from bhr._studies.physics.poses import Poses
from bhr._studies.physics.wall import (
    DEFAULT_MAX_WALL_FORCE,
    DEFAULT_WALL_STIFFNESS,
    FORCE_LINES_N,
    SAMPLE_MM,
    check_wall_stiffness,
    samples_per_module,
)

__all__ = ["FEEDER_STIFFNESS", "DEFAULT_FEEDER_FORCE", "MAX_MOVE_MM", "MAX_SUBSTEPS", "wall_tube", "PhysicsReplay",
           "replay_poses", "replay_physics"]

#: The feeder's stiffness along its slide, N/mm: a position-controlled slide that pushes up to its force limit.
FEEDER_STIFFNESS = 20.0
#: The feeder's force limit, N: 4.4 kg, the largest push measured on a colonoscope (Appleyard et al. 2000).
DEFAULT_FEEDER_FORCE = 4.4 * 9.80665
#: From one written pose to the next no joint moves more than this (mm): where the poses are farther apart (a run's
#: codes, switched at once) the targets move in as many equal parts as that needs, at most MAX_SUBSTEPS.
MAX_MOVE_MM = 2.0
MAX_SUBSTEPS = 1000


def wall_tube(result, behind_mm: float = 0.0):
    """The lumen the wall bounds: bhr's tube of the run (capped at the cecum, continued straight behind the
    entrance, here at least ``behind_mm`` far), as the run's clearance is scored (bhr.model._tube.make_tube)."""
    from bhr.model._tube import Tube, make_tube, search_arrays

    tr = result.trajectory
    if tr.lumen is None:
        raise BhrError("the run's trajectory has no lumen, so there is no wall to replay against; give a run of "
                       "--traj anatomy or a trajectory file with a lumen column")
    lum = np.asarray(tr.lumen, dtype=np.float64)
    if not np.all(lum > 0):
        raise BhrError(f"the run's lumen is {float(lum.min()):g} mm at its narrowest: give a lumen of positive "
                       "diameters")
    tube = make_tube(np.asarray(tr.points, dtype=np.float64), lum, tr.start_direction, closed_end=True)
    nb = int(math.ceil(max(0.0, behind_mm) / tube.spacing)) - tube.pre + 2
    if nb <= 0:
        return tube
    # behind the entrance as far as a long robot reaches: continued straight, as make_tube continues it
    C = tube.points
    d0 = (C[1] - C[0]) / np.linalg.norm(C[1] - C[0])
    pts = np.ascontiguousarray(np.vstack([C[0] - tube.spacing * np.arange(nb, 0, -1)[:, None] * d0, C]))
    rad = np.ascontiguousarray(np.concatenate([np.full(nb, tube.radius[0]), tube.radius]))
    arc, centre, brad = search_arrays(pts)
    return Tube(pts, rad, tube.pre + nb, tube.post, tube.window, tube.spacing, arc, centre, brad)


@dataclass
class PhysicsReplay:
    """What the replay measured at every pose (0-based arrays) and in summary (docs/physics.md)."""

    step: np.ndarray  # (P,) the run's 1-based step of each pose
    t_s: np.ndarray  # (P,)
    total_force_n: np.ndarray  # (P,) the wall's load: the total normal force on the wall
    module_force_n: np.ndarray  # (P, M) per module
    max_pressure_kpa: np.ndarray  # (P,) largest force per unit of wall area
    stretch_mm: np.ndarray  # (P,) the wall's largest displacement (how far the colon is pushed out of place)
    where_mm: np.ndarray  # (P, 3) where the wall is pushed out most (NaN without contact)
    feeder_force_n: np.ndarray  # (P,) the feeder's push on the rear end
    feeder_lag_mm: np.ndarray  # (P,) how far the rear end is behind the run's insertion
    deviation_mm: np.ndarray  # (P,) the largest distance of a joint from the pose's written position
    points_mm: np.ndarray  # (P, M+1, 3) the replayed robot
    contacts: list[np.ndarray]  # per pose, the points of the axis in contact (K, 3)
    reached_cecum_step: int | None  # 1-based step at which the tip reaches the cecum, None if never
    model_reached_cecum_step: int | None  # the same for the written poses
    iterations: np.ndarray  # (P,) solver iterations
    settings: dict[str, Any]
    cpu_s: float
    max_wall_force_n: float = DEFAULT_MAX_WALL_FORCE
    #: (P,) whether each pose's own equilibrium (its last) was reached within the iteration limit; None: all were
    equilibrium_reached: np.ndarray | None = None

    def contacts_by_step(self, steps: int) -> list[np.ndarray]:
        """Per step of the run (``steps`` of them), the points of the axis in contact at any of its poses (K, 3);
        none for a step no pose replayed. (A run moved by its wires has many poses a step.)"""
        out: list[list[np.ndarray]] = [[] for _ in range(steps)]
        for s, c in zip(self.step, self.contacts):
            if 1 <= s <= steps and len(c):
                out[int(s) - 1].append(c)
        return [np.vstack(c) if c else np.zeros((0, 3)) for c in out]

    @property
    def contact_steps(self) -> list[int]:
        return sorted({int(s) for s in self.step[self.total_force_n > 0]})

    def summary(self) -> dict[str, Any]:
        f = self.total_force_n
        k = int(np.argmax(f)) if f.size else 0
        peak = float(f.max(initial=0.0))
        reached = self.reached_cecum_step is not None
        peak_reached = self.equilibrium_reached is None or not f.size or bool(self.equilibrium_reached[k])
        return {"poses": int(f.size), "steps": int(len(set(self.step.tolist()))),
                "max_total_force_n": peak, "max_total_force_step": int(self.step[k]) if peak > 0 else 0,
                "max_total_force_equilibrium_reached": peak_reached,
                "max_module_force_n": float(self.module_force_n.max(initial=0.0)),
                "max_pressure_kpa": float(self.max_pressure_kpa.max(initial=0.0)),
                "max_stretch_mm": float(self.stretch_mm.max(initial=0.0)),
                "contact_steps": self.contact_steps,
                "steps_over_9_8_n": len({int(s) for s in self.step[f > FORCE_LINES_N[0]]}),
                "steps_over_14_1_n": len({int(s) for s in self.step[f > FORCE_LINES_N[1]]}),
                "max_feeder_force_n": float(np.abs(self.feeder_force_n).max(initial=0.0)),
                "max_feeder_lag_mm": float(self.feeder_lag_mm.max(initial=0.0)),
                "max_deviation_mm": float(self.deviation_mm.max(initial=0.0)),
                "reached_cecum_step": self.reached_cecum_step,
                "written_poses_reach_cecum_step": self.model_reached_cecum_step,
                "max_wall_force_n": self.max_wall_force_n,
                "traversed": bool(reached and peak <= self.max_wall_force_n),
                "cpu_s": round(self.cpu_s, 2), **self.settings}

    def to_dict(self) -> dict[str, Any]:
        from bhr import __version__

        rows = []
        for i in range(self.total_force_n.size):
            hit = self.total_force_n[i] > 0
            rows.append({"step": int(self.step[i]), "t_s": float(self.t_s[i]),
                         "total_force_n": float(self.total_force_n[i]),
                         "max_module_force_n": float(self.module_force_n[i].max(initial=0.0)),
                         "module": int(np.argmax(self.module_force_n[i])) + 1 if hit else 0,
                         "max_pressure_kpa": float(self.max_pressure_kpa[i]),
                         "stretch_mm": float(self.stretch_mm[i]),
                         "where_mm": [float(v) for v in self.where_mm[i]] if hit else None,
                         "contacts": int(len(self.contacts[i])),
                         "feeder_force_n": float(self.feeder_force_n[i]),
                         "deviation_mm": float(self.deviation_mm[i]),
                         "equilibrium_reached": (True if self.equilibrium_reached is None
                                                         else bool(self.equilibrium_reached[i]))})
        return {"bhr_version": __version__, "steps": rows, "summary": self.summary()}


def _reached(tube, tips: np.ndarray) -> int | None:
    from bhr._run.clearance import cecum_step

    k = cecum_step(tube, tips)
    return None if k is None else k


def replay_poses(poses: Poses, result, *, wall_stiffness: float = DEFAULT_WALL_STIFFNESS,
                 wire_force: float = WIRE_FORCE_N, feeder_force: float = DEFAULT_FEEDER_FORCE, substeps: int = 1,
                 sample_mm: float = SAMPLE_MM, max_wall_force: float = DEFAULT_MAX_WALL_FORCE,
                 progress: Callable[[int, int], None] | None = None,
                 max_iterations: int = MAX_ITERATIONS, passive_modules: int = 0,
                 passive_rigidity: float = PASSIVE_RIGIDITY_NMM2) -> PhysicsReplay:
    """Replay ``poses`` (the contract's arrays) against ``result``'s colon wall; see the module docstring.

    ``substeps``: equilibria solved from one pose to the next, the targets moved linearly between them (the
    last is the pose's own); ``max_iterations``: of one equilibrium, past which its best pose is kept and counted
    as not reached; ``passive_modules``: the robot's rear modules that have no wires, a passive body held towards
    straight by its flexural rigidity ``passive_rigidity`` (N mm^2; a colonoscope's by default,
    :data:`bhr._studies.physics.joints.PASSIVE_RIGIDITY_NMM2`); the run's codes drive the modules in front of it.
    Reported at every pose: the wall's load (total and per module), the largest
    pressure, the stretch, the feeder's push, the deviation from the written joint positions.
    """
    check_wall_stiffness(float(wall_stiffness))
    for name, v in (("--wire-force", wire_force), ("--feeder-force", feeder_force), ("--substeps", substeps),
                    ("max_iterations", max_iterations),
                    ("sample spacing", sample_mm), ("--max-wall-force", max_wall_force),
                    ("--passive-rigidity", passive_rigidity)):
        if not (math.isfinite(float(v)) and float(v) > 0):
            raise BhrError(f"{name} must be a positive number, got {v!r}")
    poses.check()
    P, M = poses.tilts_rad.shape[:2]
    passive = int(passive_modules)
    if passive != passive_modules or not 0 <= passive < M:
        raise BhrError(f"--passive-modules must be a whole number from 0 to {M - 1} (the run's robot has {M} modules "
                       f"and its head is driven), got {passive_modules!r}")
    r = result.robot
    tube = wall_tube(result, float(-np.min(poses.insertion_mm)) + 2 * float(r.module_length))
    L = float(poses.module_length)
    if abs(L - float(r.module_length)) > 1e-9:
        raise BhrError(f"the poses' modules are {L:g} mm and the run's {r.module_length:g} mm; give the run's poses")
    ns = samples_per_module(L, sample_mm)
    robot_radius = float(r.robot_radius)
    k_joint = joint_stiffness(r, wire_force)
    k_passive = passive_stiffness(L, passive_rigidity)
    stiffness = np.full(M, k_joint)
    stiffness[:passive] = k_passive  # joint j tilts module j + 1 (1 = the rear) on the one behind, or the feeder
    tilts = poses.tilts_rad
    if passive:
        tilts = tilts.copy()
        tilts[:, :passive] = 0.0  # a passive body's joints are pulled towards straight, whatever the run's codes
    pb = Problem(np.ascontiguousarray(poses.entrance, dtype=np.float64), np.ascontiguousarray(poses.frame[2]),
                  np.ascontiguousarray(poses.frame.T), L, robot_radius, ns, float(wall_stiffness), stiffness,
                  FEEDER_STIFFNESS, float(feeder_force), np.ascontiguousarray(tube.points),
                  np.ascontiguousarray(tube.radius), np.zeros(M * ns, dtype=np.int64), np.zeros(M * ns))
    t0 = time.process_time()
    z = np.concatenate([[poses.insertion_mm[0]], tilts[0].reshape(-1)])
    pts = np.empty((M + 1, 3))
    chain_points(z, pb.base, pb.d0, pb.A0, L, pts)
    mids = 0.5 * (pts[:-1] + pts[1:])
    global_seg(pb.C, np.repeat(mids, ns, axis=0), pb.seg)
    out_pts = np.empty((P, M + 1, 3))
    total = np.zeros(P)
    per_module = np.zeros((P, M))
    pressure = np.zeros(P)
    stretch = np.zeros(P)
    where = np.full((P, 3), np.nan)
    feed_f = np.zeros(P)
    lag = np.zeros(P)
    dev = np.zeros(P)
    iters = np.zeros(P, dtype=np.int64)
    subs = np.zeros(P, dtype=np.int64)
    final = np.ones(P, dtype=bool)  # each pose's own equilibrium reached
    unconverged, worst_left = 0, 0.0
    contacts: list[np.ndarray] = []
    w = L / ns
    offs = (np.arange(ns) + 0.5) * w
    prev_t, prev_x = tilts[0], float(poses.insertion_mm[0])
    zt_prev, x_prev = prev_t, prev_x
    for i in range(P):
        tgt, xt = tilts[i], float(poses.insertion_mm[i])
        n_it = 0
        # the wires switch gradually: from one written pose to the next no joint moves more than MAX_MOVE_MM
        move = float(np.linalg.norm(poses.points_mm[i] - poses.points_mm[max(i - 1, 0)], axis=1).max())
        n_sub = max(int(substeps), min(MAX_SUBSTEPS, int(math.ceil(move / MAX_MOVE_MM - 1e-9))))
        subs[i] = n_sub
        for s in range(1, n_sub + 1):
            f = s / n_sub
            t_s = np.ascontiguousarray(prev_t + f * (tgt - prev_t))
            x_s = prev_x + f * (xt - prev_x)
            # start where the robot is: the last equilibrium's deflection from its targets carried over
            z0 = z.copy()
            z0[1:] += (t_s - zt_prev).reshape(-1)
            z0[0] += x_s - x_prev
            z, k, left = solve_pose(pb, z0, t_s, x_s, max_iterations)
            if not np.all(np.isfinite(z)):
                raise BhrError(f"the replay lost the robot at step {int(poses.step[i])} (a pose that is not a number); "
                               "give more --substeps")
            n_it += min(k, max_iterations)
            if k > max_iterations:
                unconverged += 1
                worst_left = max(worst_left, left)
            final[i] = k <= max_iterations  # the last substep is the pose's own
            zt_prev, x_prev = t_s, x_s
        prev_t, prev_x = tgt, xt
        iters[i] = n_it
        chain_points(z, pb.base, pb.d0, pb.A0, L, pts)
        out_pts[i] = pts
        pen = pb.pen.reshape(M, ns)
        line = float(wall_stiffness) * pen  # N per mm of robot
        per_module[i] = line.sum(axis=1) * w
        total[i] = float(per_module[i].sum())
        pressure[i] = float(line.max()) / (2.0 * robot_radius) * 1000.0  # N/mm^2 -> kPa, over the robot's width
        stretch[i] = float(pen.max())
        hit = np.nonzero(pen > 0)
        axis = pts[:-1, None, :] + offs[None, :, None] * (np.diff(pts, axis=0) / L)[:, None, :]
        contacts.append(axis[hit])
        if hit[0].size:
            jj, kk = np.unravel_index(int(np.argmax(pen)), pen.shape)
            where[i] = axis[jj, kk]
        e = z[0] - xt
        feed_f[i] = float(np.clip(-FEEDER_STIFFNESS * e, -feeder_force, feeder_force))
        lag[i] = float(-e)
        dev[i] = float(np.linalg.norm(pts - poses.points_mm[i], axis=1).max())
        if progress is not None:
            progress(i + 1, P)
    cpu = time.process_time() - t0
    reached = _reached(tube, out_pts[:, -1])
    model = _reached(tube, poses.points_mm[:, -1])
    settings = {"wall_stiffness_n_per_mm2": float(wall_stiffness), "joint_stiffness_nmm_per_rad": k_joint,
                "passive_modules": passive, "passive_rigidity_nmm2": float(passive_rigidity),
                "passive_joint_stiffness_nmm_per_rad": k_passive if passive else None,
                "wire_force_n": float(wire_force), "feeder_force_limit_n": float(feeder_force),
                "feeder_stiffness_n_per_mm": FEEDER_STIFFNESS, "substeps": int(substeps),
                "wall_samples_per_module": ns, "modules": M, "module_length_mm": L, "robot_radius_mm": robot_radius,
                "solver_iterations": int(iters.sum()), "equilibria": int(subs.sum()),
                "max_move_mm": MAX_MOVE_MM, "equilibria_not_reached": unconverged,
                "poses_replayed": "every pose" if poses.every_pose else "steps",
                "largest_force_left_n_mm": worst_left}
    return PhysicsReplay(np.asarray(poses.step), np.asarray(poses.t_s), total, per_module, pressure, stretch, where,
                         feed_f, lag, dev, out_pts, contacts,
                         None if reached is None else int(poses.step[reached]),
                         None if model is None else int(poses.step[model]), iters, settings, cpu,
                         float(max_wall_force), final)


def replay_physics(result, run_path: Any = None, **options: Any) -> PhysicsReplay:
    """Replay a run: every pose its wires moved it through (its ``poses.npz`` when ``run_path``'s folder has one,
    else its motion in memory), else its written steps (:func:`bhr._studies.physics.poses.poses_from_run`: between
    them the joints move linearly, an idealisation the summary names)."""
    from bhr._studies.physics.poses import load_poses, poses_from_motion, poses_from_run

    poses = load_poses(run_path, result) if run_path is not None else None
    if poses is None:
        poses = poses_from_motion(result)
    if poses is None:
        poses = poses_from_run(result)
    return replay_poses(poses, result, **options)
