"""bhr robots in pinocchio and MuJoCo: the exported models cross-checked, a run replayed against the colon wall.

Needs the ``physics`` extra (``python3 -m pip install '.[physics]'`` in bhr's source folder:
pinocchio and MuJoCo; the errors print the exact command, :func:`bhr.settings.extras.install_command`);
both are imported only inside the functions here, so ``import bhr`` never loads them.
docs/export.md and docs/physics.md describe what is computed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from bhr.settings.errors import BhrError
from bhr.model.export import MM, joint_names, joint_values, to_mjcf, to_urdf
from bhr.model.robot import Robot, forward_kinematics

__all__ = ["missing", "FkAgreement", "fk_cross_check", "pinocchio_model", "pinocchio_points", "mujoco_model",
           "mujoco_points", "require", "check_installed", "whole_chain", "start_direction", "PhysicsReplay",
           "replay_physics",
           "scene_xml", "replay_chain", "ReplayChain", "insertion", "WALL_STIFFNESS_RANGE", "DEFAULT_WALL_STIFFNESS",
           "FORCE_LINES_N"]


def missing(module: str) -> str:
    """The one-line error for ``module`` (``mujoco``, ``pinocchio``) missing, with the command that installs it."""
    from bhr.settings.extras import install_command

    return f"{module} is not installed; install the physics extra: {install_command('physics')}"


def require(module: str) -> Any:
    """Import ``pinocchio`` or ``mujoco``; a BhrError naming the extra to install when it is missing."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise BhrError(missing(module)) from None


def check_installed(module: str) -> None:
    """Refuse, before any work, an option that needs ``module`` (``mujoco``, ``pinocchio``) when it is missing."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise BhrError(missing(module))


def pinocchio_model(robot: Robot, modules: int | None = None) -> Any:
    """The exported URDF loaded by pinocchio (a ``pinocchio.Model``)."""
    pin = require("pinocchio")
    return pin.buildModelFromXML(to_urdf(robot, modules))


def pinocchio_points(model: Any, q: np.ndarray, full: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Module points (n+1, 3) in mm and module frames (n, 3, 3, rows x y z) of a pinocchio model at ``q``.

    The points are the frames ``m<i>_ty`` (the module's rear joint) and ``tip``. With ``full``, pinocchio's
    own ``framesForwardKinematics`` on a ``pinocchio.Data``; otherwise the same composition
    (``oMi = oMi[parent] * jointPlacement * joint.calc(q)``, pinocchio's joint models and SE(3)
    algebra) without a ``Data``: pinocchio 3's ``Data`` allocates second-order derivative tensors
    of nv^3 entries (900 joints: 5.8 GB each), too much for a long robot.
    """
    pin = require("pinocchio")
    names = [n for n in model.names]
    n = (len(names) - 1) // 3
    if full:
        data = model.createData()
        pin.framesForwardKinematics(model, data, q)
        oMf = [data.oMf[model.getFrameId(f"m{i}_ty")] for i in range(1, n + 1)] + [data.oMf[model.getFrameId("tip")]]
    else:
        oMi = [pin.SE3.Identity()]
        for j in range(1, model.njoints):
            jm = model.joints[j]
            jd = jm.createData()
            jm.calc(jd, q)
            oMi.append(oMi[model.parents[j]] * model.jointPlacements[j] * jd.M)
        oMf = []
        for name in [f"m{i}_ty" for i in range(1, n + 1)] + ["tip"]:
            fr = model.frames[model.getFrameId(name)]
            oMf.append(oMi[fr.parentJoint] * fr.placement)
    pts = np.array([m.translation for m in oMf]) / MM
    frames = np.array([m.rotation.T for m in oMf[:-1]])
    return pts, frames


def pinocchio_q(model: Any, values: np.ndarray) -> np.ndarray:
    """A pinocchio configuration from joint values in :func:`bhr.model.export.joint_names` order (by joint name)."""
    q = np.zeros(model.nq)
    n = len(values) // 3
    for name, v in zip(joint_names(n), values):
        q[model.joints[model.getJointId(name)].idx_q] = v
    return q


def mujoco_model(robot: Robot, modules: int | None = None) -> Any:
    """The exported MJCF loaded by MuJoCo (a ``mujoco.MjModel``)."""
    mujoco = require("mujoco")
    return mujoco.MjModel.from_xml_string(to_mjcf(robot, modules))


def mujoco_points(model: Any, data: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Module points (n+1, 3) in mm (the tilt_x joints' anchors and the ``tip`` site) and module frames."""
    import mujoco

    jx = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"m{i}_tilt_x") for i in range(1, n + 1)]
    bodies = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"m{i}") for i in range(1, n + 1)]
    tip = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tip")
    pts = np.vstack([data.xanchor[jx], data.site_xpos[tip][None]]) / MM
    frames = data.xmat[bodies].reshape(n, 3, 3).transpose(0, 2, 1)
    return pts, frames


@dataclass(frozen=True)
class FkAgreement:
    """The largest differences between bhr's forward kinematics and an engine's over random code sets."""

    modules: int
    sets: int
    pinocchio_mm: float  # largest point difference, mm
    mujoco_mm: float
    pinocchio_frame: float  # largest difference of a frame matrix entry
    mujoco_frame: float


def fk_cross_check(modules: int, sets: int = 1000, seed: int = 0, robot: Robot | None = None,
                   full_pinocchio: bool | None = None) -> FkAgreement:
    """Export a robot of ``modules`` modules, load it in pinocchio and MuJoCo, and compare every module
    point and frame with bhr's forward kinematics for ``sets`` random code sets (every code equally likely).

    bhr's chain is computed from the base frame (identity: the exported ``base`` link). ``full_pinocchio``:
    use pinocchio's ``framesForwardKinematics`` (default up to 60 modules; see :func:`pinocchio_points`).
    """
    import mujoco

    from bhr.model.codes import VALID_CODES

    robot = Robot(modules=modules) if robot is None else robot.replace(modules=modules)
    full = modules <= 60 if full_pinocchio is None else full_pinocchio
    pmodel = pinocchio_model(robot)
    mmodel = mujoco_model(robot)
    mdata = mujoco.MjData(mmodel)
    rng = np.random.default_rng(seed)
    worst = np.zeros(4)
    for _ in range(sets):
        codes = rng.choice(np.array(VALID_CODES), size=modules)
        pts, frames = forward_kinematics(robot, codes.tolist(), frame=np.eye(3))
        values = joint_values(codes, robot)
        pp, pf = pinocchio_points(pmodel, pinocchio_q(pmodel, values), full)
        mdata.qpos[:] = values
        mujoco.mj_kinematics(mmodel, mdata)
        mp, mf = mujoco_points(mmodel, mdata, modules)
        worst = np.maximum(worst, [np.abs(pp - pts).max(), np.abs(mp - pts).max(), np.abs(pf - frames).max(),
                                   np.abs(mf - frames).max()])
    return FkAgreement(modules, sets, *map(float, worst))


# ---------------------------------------------------------------------------
# a run replayed in MuJoCo against the colon wall

#: Published wall stiffness of porcine colon, N/mm (Johnson et al. 2019): the range and the default (its middle).
WALL_STIFFNESS_RANGE = (0.7, 2.4)
DEFAULT_WALL_STIFFNESS = 1.5
#: Published force levels, N: forces above 1 kg occur 5 % of the time in colonoscopy (Appleyard et al. 2000);
#: a porcine colon perforates at 14.1 N (Johnson et al. 2019).
FORCE_LINES_N = (9.8, 14.1)
SOLIMP = 0.99
#: Each wall piece rides three springs (normal, along the centerline, around the ring); False: the normal only.
WALL_ALL_DIRECTIONS = True
#: MuJoCo's integrator: semi-implicit Euler, with the servos' damping moved onto their joints (integrated
#: implicitly). MuJoCo's Euler factorises M and M + h D at every time step; with DAMPING_IN_ARMATURE only
#: M + h D where no contact acts (_Stepper).
INTEGRATOR = "Euler"
#: With Euler: at time steps without a contact the implicit damping is folded into the mass matrix (every joint's
#: armature + h * damping, MuJoCo's own implicit damping off: mjDSBL_EULERDAMP), so MuJoCo factorises it once a time
#: step instead of twice, for the same step (_Stepper; docs/physics.md, "Speed"); False: MuJoCo's at every one.
DAMPING_IN_ARMATURE = True
#: The damping stays folded at time steps where a joint limit (but no contact) acts: the limit is then solved with
#: M + h D instead of M (a head module's tilt at its limit, as the trail model puts it, touches its stop at about
#: half the time steps); False: any constraint unfolds it, and the replay is MuJoCo's Euler's to rounding.
FOLD_AT_JOINT_LIMITS = True
#: A wall piece whose inner face lies this much (mm) inside the lumen of another centerline point is left out.
FOLD_TOLERANCE_MM = 0.5
#: The targets move over the first 1 / RAMP_FRACTION of a step.
RAMP_FRACTION = 4
#: The trail model's targets (its own robot between two steps, with the servos' feedforward) move over the first
#: 1 / TRAIL_RAMP_FRACTION of a step: over a quarter, the rear module turning into the colon swung the robot
#: beyond it into the wall within the step (docs/physics.md).
TRAIL_RAMP_FRACTION = 2


def check_wall_stiffness(value: float) -> float:
    """``value`` (N/mm) if within ten times the published range 0.7-2.4 N/mm either way; BhrError otherwise."""
    lo, hi = WALL_STIFFNESS_RANGE[0] / 10, WALL_STIFFNESS_RANGE[1] * 10
    if not (lo <= value <= hi):
        raise BhrError(f"--wall-stiffness {value:g} N/mm is far outside the published 0.7-2.4 N/mm; give a value "
                       f"between {lo:g} and {hi:g}")
    return value


#: The servos' and the wall's natural frequency (Hz): both settle within a step, critically damped (docs/physics.md).
SERVO_HZ = 50.0
#: The longest MuJoCo time step the replay takes: 6.25 ms (8 substeps at 20 Hz), where 50 Hz is still resolved
#: (omega dt = 1.96, below the explicit part's stability bound of 2); a longer one blows up.
MAX_TIMESTEP_MS = 6.25


def check_replay_options(wall_stiffness: Any, rate: Any, substeps: Any) -> None:
    """The replay's own options through the option registry (finite, within their limits, above 0) and the wall's
    stiffness within ten times its published range; a one-line BhrError naming the option otherwise. Before any
    work: a rate or substeps of 0 divided the time step by zero."""
    from bhr.settings.options import BY_NAME

    for name, flag, value in (("physics_rate", "--rate", rate), ("substeps", "--substeps", substeps),
                              ("wall_stiffness", "--wall-stiffness", wall_stiffness)):
        v = BY_NAME[name].check(value, "physics")
        if v <= 0:
            raise BhrError(f"{flag} must be greater than 0, got {v:g}")
    check_wall_stiffness(wall_stiffness)
    dt_ms = 1000.0 / (float(rate) * int(substeps))
    if dt_ms > MAX_TIMESTEP_MS:
        need = math.ceil(1000.0 / (float(rate) * MAX_TIMESTEP_MS) - 1e-9)
        most = int(BY_NAME["substeps"].maximum or 1000)
        fix = (f"give --substeps {need} or more at --rate {float(rate):g}" if need <= most else
               f"give --rate {1000.0 / (most * MAX_TIMESTEP_MS):g} or more (--substeps is at most {most})")
        raise BhrError(f"a time step of {dt_ms:.3g} ms (1 / --rate / --substeps) is too long for the servos' and the "
                       f"wall's {SERVO_HZ:g} Hz, and the replay would blow up; {fix} (a time step of at most "
                       f"{MAX_TIMESTEP_MS:g} ms)")


def whole_chain(result) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The whole robot of a run as a chain from its rear end: (roots (N, 3) mm, frames (N, 3, 3), codes (N, M)).

    Root ``i`` is the rear end of the robot at step ``i`` (the last body module's rear end, or the head's
    base without a body) and its frame (rows x, y, z) that of the rear module; codes are one per module of
    the whole robot, rear first: the rear module's own 0, the body's joints (bhr.run.body: each body module's
    tilt relative to the one behind it) and the head's codes. ``forward_kinematics`` of these from the root
    gives :func:`bhr.run.body.whole_robot`'s points (a test holds them equal).
    """
    from bhr.run.body import module1_frames, whole_robot_codes
    from bhr.kinematics.codetable import SEARCH_INDEX, SEARCH_INVERSE
    from bhr.kinematics.frames import tilt_reference

    if result.codes is None:
        raise BhrError(f"the {result.solver} run has no module codes, so no joint values to replay; "
                       "use a run of --solver thesis, optimal or lumen")
    r = result.robot
    N = result.steps
    start, F1s = module1_frames(result.codes, start_direction(result), r.alpha)
    body = result.body
    B = body.modules if body is not None else 0
    a = math.radians(r.alpha)
    roots = np.empty((N, 3))
    frames = np.empty((N, 3, 3))
    codes = whole_robot_codes(result.codes, body)
    for i in range(N):
        F = start if i == 0 else F1s[i - 1]
        if B:
            bc = body.codes[i]
            for c in bc[:-1]:
                F = tilt_reference(F, int(SEARCH_INVERSE[SEARCH_INDEX[int(c)]]), a)
            roots[i] = body.points[i][-1]
        else:
            roots[i] = result.points[i][0]
        frames[i] = F
    return roots, frames, codes


@dataclass
class ReplayChain:
    """What the replay drives, per step: the whole robot's rear pose, its joint values and bhr's points."""

    roots: np.ndarray  # (N, 3) mm, the rear end
    frames: np.ndarray  # (N, 3, 3) the rear module's frame (rows x, y, z)
    values: np.ndarray  # (N, 3 M) joint values in bhr.model.export.joint_names order (radians, m)
    points: np.ndarray  # (N, M + 1, 3) mm, bhr's whole robot (bhr.run.body.whole_robot), rear first
    lift: bool  # some module lifts at some step
    from_codes: bool  # values are the codes' (bhr.joint_values); else the tilts that put each module on bhr's
    chords: np.ndarray | None = None  # (N, M) mm, each module's chord minus a module length (<= 0: the trail
    # model's modules across a vertex), driven by the scene's chord joints; None: every module is full length


def _tilts_from_points(points: np.ndarray, frames: np.ndarray, length: float) -> np.ndarray:
    """Joint values (N, 3 M) that turn every module of a chain along bhr's chord of ``points`` (N, M + 1, 3),
    from rear frames ``frames``: module j's frame is module j-1's turned about its x then its y (the exported
    joints' order), so its chord d (in module j-1's frame) gives tilt_y = asin(d_x), tilt_x = atan2(-d_y, d_z).
    Each module turns from the one behind by its chord's turn (at most the robot's tilt); a chord shorter
    than ``length`` (the trail model's modules across a vertex) is given its length by the replay
    (:func:`replay_physics` sets each module's length to its chord at every step; a chain of full-length
    modules would move the modules beyond it along the chain by its shortfall). (Aiming each module at bhr's
    next joint from where the modules behind put it instead asks for turns beyond the joints' limits and
    jumps from step to step.)"""
    N, J = points.shape[0], points.shape[1]
    M = J - 1
    out = np.zeros((N, M, 3))
    R = np.ascontiguousarray(frames.transpose(0, 2, 1))  # columns x, y, z
    for j in range(M):
        d = points[:, j + 1] - points[:, j]
        d /= np.linalg.norm(d, axis=1)[:, None]
        dl = np.einsum("nki,nk->ni", R, d)  # in the frame of the module behind
        ty = np.arcsin(np.clip(dl[:, 0], -1.0, 1.0))
        tx = np.arctan2(-dl[:, 1], dl[:, 2])
        out[:, j, 0], out[:, j, 1] = tx, ty
        cx, sx, cy, sy = np.cos(tx), np.sin(tx), np.cos(ty), np.sin(ty)
        T = np.zeros((N, 3, 3))
        T[:, 0, 0], T[:, 0, 2] = cy, sy
        T[:, 1, 0], T[:, 1, 1], T[:, 1, 2] = sx * sy, cx, -sx * cy
        T[:, 2, 0], T[:, 2, 1], T[:, 2, 2] = -cx * sy, sx, cx * cy
        R = R @ T
    return out.reshape(N, -1)


def _turned(F: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Frames ``F`` (K, 3, 3, rows x y z) turned about z_F x z by the angle between them (the least turn that
    brings their z onto the directions ``z`` (K, 3), which need not be unit)."""
    z = z / np.linalg.norm(z, axis=1)[:, None]
    zp = F[:, 2]
    ax = np.cross(zp, z)
    sn = np.linalg.norm(ax, axis=1)
    cs = np.einsum("ki,ki->k", zp, z)
    k = np.where(sn[:, None] > 1e-12, ax / np.maximum(sn, 1e-300)[:, None], 0.0)
    K = np.zeros((len(F), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    Rm = np.eye(3) + sn[:, None, None] * K + (1 - cs)[:, None, None] * K @ K
    out = np.einsum("kab,kcb->kca", Rm, F)  # each row (axis) of F turned by Rm
    out[:, 2] = z
    return out


def trail_substeps(chain: "ReplayChain", fracs: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray,
                                                                                     np.ndarray, np.ndarray]:
    """The trail model's whole robot between two steps, as the replay drives it: for every step i (N) and
    fraction s of ``fracs`` (R) of the way from step i - 1 to step i, the rear end (N, R, 3), the rear
    module's frame (N, R, 3, 3), the joint values (N, R, 3 M) and each module's chord minus ``length``
    (N, R, M; <= 0).

    In the trail model every joint slides along one straight piece of the trail from one step to the next
    (a step is one feed, and the joints reach a vertex only at whole module lengths: docs/locomotion.md), so
    at fraction s each joint is exactly s of the way from its place at step i - 1 to its place at step i; the
    modules are the chords between those joints. Step 0's "previous" step is itself. The rear frame turns
    from step i - 1's as little as it can (as :func:`replay_chain`'s from step to step, so s = 1 gives step i's
    frame); the joint values are :func:`_tilts_from_points` of that chain.
    """
    P = chain.points
    N, J = P.shape[0], P.shape[1]
    prev = np.concatenate([[0], np.arange(N - 1)])
    s = np.asarray(fracs, dtype=np.float64)[None, :, None, None]
    Q = P[prev][:, None] + s * (P[:, None] - P[prev][:, None])  # (N, R, J, 3)
    R = Q.shape[1]
    Qf = Q.reshape(N * R, J, 3)
    F = _turned(np.repeat(chain.frames[prev], R, axis=0), Qf[:, 1] - Qf[:, 0])
    values = _tilts_from_points(Qf, F, length)
    chords = np.minimum(np.linalg.norm(np.diff(Qf, axis=1), axis=2) - length, 0.0)
    return (Q[:, :, 0], F.reshape(N, R, 3, 3), values.reshape(N, R, -1), chords.reshape(N, R, J - 1))


def replay_chain(result) -> ReplayChain:
    """The whole robot of a run as the physics replay drives it (:class:`ReplayChain`).

    For the thesis's locomotion the joint values are the codes' (:func:`whole_chain`, ``bhr.joint_values``).
    The trail model (docs/locomotion.md) moves modules between vertices through intermediate tilts that no
    code gives: there (and wherever the codes do not reproduce bhr's whole robot) the values are the tilts that
    put each module on bhr's chord (:func:`_tilts_from_points`), from a rear frame along the rear module that
    turns as little as it can from step to step.
    """
    from bhr.run.body import whole_robot

    roots, frames, codes = whole_chain(result)
    N, M = codes.shape
    points = np.stack([whole_robot(result, i) for i in range(N)])
    r = result.robot.replace(modules=M)
    sample = sorted({0, N - 1, *range(0, N, max(1, N // 20))})
    if all(np.abs(forward_kinematics(r, codes[i], roots[i], frames[i])[0] - points[i]).max() <= 1e-6
           for i in sample):
        return ReplayChain(roots, frames, joint_values(codes, r), points, bool(np.any(codes == 15)), True)
    if np.any(codes == 15):
        raise BhrError("the run's whole robot does not follow its codes and lifts; bhr physics replays lifting "
                       "runs of the thesis's locomotion only")
    from bhr.model.robot import base_frame

    roots = points[:, 0].copy()
    frames = np.empty((N, 3, 3))
    for i in range(N):
        z = points[i, 1] - points[i, 0]
        if i == 0:
            frames[0] = base_frame(z / np.linalg.norm(z))
        else:  # the previous frame turned about z_prev x z, by the angle between them
            frames[i] = _turned(frames[i - 1][None], z[None])[0]
    chords = np.linalg.norm(np.diff(points, axis=1), axis=2) - r.module_length
    return ReplayChain(roots, frames, _tilts_from_points(points, frames, r.module_length), points, False,
                       False, np.minimum(chords, 0.0))


def start_direction(result) -> np.ndarray:
    """The direction the robot lay along before the run (the trajectory's start direction, a unit vector).

    ``run.json`` carries it (``trajectory.start_direction``); :func:`bhr.run.driver.load_run` recovers it from
    step 1's base for runs written before it did.
    """
    d = np.asarray(result.trajectory.start_direction, dtype=np.float64)
    return d / np.linalg.norm(d)


@dataclass
class PhysicsReplay:
    """What a physics replay measured, per step (0-based arrays) and in summary."""

    max_force_n: np.ndarray  # (N,) largest contact force on the wall at the end of each step, N
    where_mm: np.ndarray  # (N, 3) where it acts (NaN without contact)
    arc_mm: np.ndarray  # (N,) where along the centerline, mm from the entrance (NaN without contact)
    module: list[int]  # (N,) which module (1 = rear of the whole robot; 0 without contact)
    deviation_mm: np.ndarray  # (N,) largest distance of a simulated module point from bhr's pose, mm
    contacts: list[np.ndarray]  # per step, every contact point (K, 3) mm
    settings: dict[str, Any]
    cpu_s: float

    @property
    def contact_steps(self) -> list[int]:
        return [int(i) + 1 for i in np.nonzero(self.max_force_n > 0)[0]]

    def summary(self) -> dict[str, Any]:
        k = int(np.argmax(self.max_force_n)) if len(self.max_force_n) else 0
        return {"steps": int(len(self.max_force_n)), "max_force_n": float(self.max_force_n.max(initial=0.0)),
                "max_force_step": k + 1 if self.max_force_n.size and self.max_force_n[k] > 0 else 0,
                "contact_steps": self.contact_steps, "max_deviation_mm": float(self.deviation_mm.max(initial=0.0)),
                "steps_over_9_8_n": int(np.count_nonzero(self.max_force_n > FORCE_LINES_N[0])),
                "steps_over_14_1_n": int(np.count_nonzero(self.max_force_n > FORCE_LINES_N[1])),
                "cpu_s": round(self.cpu_s, 2), **self.settings}

    def to_dict(self) -> dict[str, Any]:
        steps = []
        for i in range(len(self.max_force_n)):
            hit = self.max_force_n[i] > 0
            steps.append({"step": i + 1, "max_force_n": float(self.max_force_n[i]),
                          "where_mm": [float(v) for v in self.where_mm[i]] if hit else None,
                          "arc_mm": float(self.arc_mm[i]) if hit else None,
                          "module": int(self.module[i]), "contacts": int(len(self.contacts[i])),
                          "deviation_mm": float(self.deviation_mm[i])})
        from bhr import __version__

        return {"bhr_version": __version__, "steps": steps, "summary": self.summary()}


def _quat(R: np.ndarray) -> np.ndarray:
    import mujoco

    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=np.float64).reshape(9))
    return q


def wall_centerline(result, reach_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lumen's centerline (mm), its diameters and arc lengths from the entrance, continued straight
    behind the entrance by ``reach_mm`` (as bhr's clearance continues it) and past the end by 20 mm.

    A run that stops short of the trajectory's end (fewer steps than points) gets the lumen only as far as
    its last target and two modules and a lumen diameter more: the robot's tip never gets farther, and the
    wall beyond (thousands of pieces on a long colon) would only cost time.
    """
    tr = result.trajectory
    P = np.asarray(tr.points, dtype=np.float64)
    D = np.asarray(tr.lumen, dtype=np.float64)[: len(P)]
    sp = float(np.median(np.linalg.norm(np.diff(P, axis=0), axis=1)))
    margin = 2 * result.robot.module_length + float(np.max(D))
    keep = min(len(P), result.steps + 2 + int(math.ceil(margin / sp)))
    P, D = P[:keep], D[:keep]
    d0 = start_direction(result)
    d1 = (P[-1] - P[-2]) / np.linalg.norm(P[-1] - P[-2])
    nb = int(math.ceil(reach_mm / sp)) + 2
    before = P[0] - sp * np.arange(nb, 0, -1)[:, None] * d0
    after = P[-1] + sp * np.arange(1, int(20 / sp) + 2)[:, None] * d1
    C = np.vstack([before, P, after])
    dia = np.concatenate([np.full(nb, D[0]), D, np.full(len(after), D[-1])])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(C, axis=0), axis=1))]) - nb * sp
    return C, dia, arc


def insertion(result, roots: np.ndarray, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                      np.ndarray]:
    """How the scene inserts the robot: per step the slide joint's travel (mm), the carriage's position (mm)
    and orientation (MuJoCo quaternion), and whether the carriage had to move.

    The slide runs along the rear module's axis; its travel is how far bhr's rear end is past the entrance
    along the start direction (negative: behind it). The carriage sits at the entrance and stays there while
    bhr's rear end is on the entrance line with the start frame (a straight insertion); where bhr's rear end
    leaves that line (its body model lets it drift, or a short robot's rear goes into the colon) the carriage
    is put where the slide's travel brings the rear end onto bhr's (``moved``).
    """
    E = np.asarray(result.trajectory.points[0], dtype=np.float64)
    d0 = start_direction(result)
    depth = (roots - E) @ d0
    cpos = roots - depth[:, None] * frames[:, 2, :]
    moved = (np.linalg.norm(cpos - E, axis=1) > 1e-6) | (np.abs(frames - frames[:1]).reshape(len(frames), -1)
                                                         .max(axis=1) > 1e-9)
    cpos[~moved] = E
    cquat = np.array([_quat(F.T) for F in frames])
    return depth, cpos, cquat, moved


def scene_xml(result, *, wall_stiffness: float = DEFAULT_WALL_STIFFNESS, ring_spacing: float = 4.0,
              pieces: int = 10, thickness: float = 4.0, rate: float | None = None, substeps: int | None = None,
              servo_hz: float = SERVO_HZ, stiff_ratio: float = 100.0, chain: "ReplayChain | None" = None
              ) -> tuple[str, dict[str, Any]]:
    """The MuJoCo scene of a run (MJCF text) and its settings: the wall, the whole robot, its servos.

    The wall is ``pieces`` boxes per ring, rings every ``ring_spacing`` mm of centerline, their inner faces
    tangent to the lumen; each box rides a radial slide joint with a spring of ``wall_stiffness`` N/mm per
    module length of wall (docs/physics.md). The robot is inserted by a servoed slide joint (``insert``)
    along its rear module's axis, on a carriage at the entrance (a mocap body, moved only at steps where
    bhr's rear end leaves the entrance line: :func:`insertion`); each joint has a position servo of natural
    frequency ``servo_hz`` (critically damped).
    """
    from bhr.model.export import mjcf_robot_body

    from bhr.settings.options import BY_NAME

    rate = BY_NAME["physics_rate"].default if rate is None else rate
    substeps = BY_NAME["substeps"].default if substeps is None else substeps
    check_replay_options(wall_stiffness, rate, substeps)
    rate, substeps = float(rate), int(substeps)
    tr = result.trajectory
    if tr.lumen is None:
        raise BhrError("the run's trajectory has no lumen, so there is no wall to replay against; give a run of "
                       "--traj anatomy or a trajectory file with a lumen column")
    r = result.robot
    chain = replay_chain(result) if chain is None else chain
    roots, frames, lift = chain.roots, chain.frames, chain.lift
    M = chain.points.shape[1] - 1
    d0 = start_direction(result)
    behind = -(roots - np.asarray(tr.points[0], dtype=np.float64)) @ (d0 / np.linalg.norm(d0))
    reach = max(0.0, float(np.max(behind))) + r.module_length  # how far behind the entrance the robot reaches
    C, dia, arc = wall_centerline(result, reach)
    # rings every ring_spacing mm of arc; behind the entrance, where the tube is straight, five times as
    # long (longer boxes, the same wall), the first one ending where the entrance's ring begins
    nb = max(0, int(math.ceil((-arc[0] - ring_spacing / 2) / (5 * ring_spacing))))
    back = (-ring_spacing / 2 - 2.5 * ring_spacing - 5 * ring_spacing * np.arange(nb))[::-1]
    ring_at = np.concatenate([back, np.arange(0.0, arc[-1], ring_spacing)])
    ring_len = np.where(ring_at < 0, 5 * ring_spacing, ring_spacing)
    idx = np.clip(np.searchsorted(arc, ring_at), 1, len(C) - 1)
    dt = 1.0 / rate / substeps
    w = 2 * math.pi * servo_hz
    # wall: per ring, the boxes' spring shares the stiffness of one module length of wall
    k_unit = float(wall_stiffness) * 1e3 / r.module_length  # N/m per mm of ring length
    lines = ['<mujoco model="bhr-physics">', '  <compiler angle="radian" autolimits="true"/>',
             f'  <option timestep="{dt!r}" gravity="0 0 0" integrator="{INTEGRATOR}" cone="pyramidal"/>',
             f'  <size memory="{200 + len(ring_at) * pieces // 10}M"/>',
             # contacts far stiffer than the wall's springs (timeconst 2 dt, impedance 0.99): the springs set the force
             f'  <default><geom solref="{2 * dt!r} 1" solimp="{SOLIMP} {SOLIMP} 0.001"/></default>',
             "  <worldbody>"]
    depth, cpos, cquat, _moved = insertion(result, roots, frames)
    lines.append(f'    <body name="carriage" mocap="true" pos="{" ".join(repr(float(x)) for x in cpos[0] * MM)}" '
                 f'quat="{" ".join(repr(float(x)) for x in cquat[0])}">')
    from bhr.model.export import module_inertia

    inert = module_inertia(r)
    # the slide's own body (a sled of one module's mass) carries the robot's base
    lines += ['      <body name="sled"><joint name="insert" type="slide" axis="0 0 1"/>',
              f'        <inertial pos="0 0 0" mass="{inert.mass!r}" diaginertia="{inert.ixx!r} {inert.iyy!r} '
              f'{inert.izz!r}"/>']
    lines += mjcf_robot_body(r, M, indent="        ", lift=lift, geom_attrs='contype="2" conaffinity="1"')
    lines += ["      </body>", "    </body>"]
    u_prev = None
    half = math.pi / pieces
    # each piece yields to a push from any side: springs along its outward normal, along the centerline and
    # around the ring (a robot pressing a piece's side, where the tube folds on the inside of a tight bend,
    # meets the wall's stiffness too, not only the contact's softness, which depends on the time step)
    axes = ("1 0 0", "0 1 0", "0 0 1") if WALL_ALL_DIRECTIONS else ("0 0 1",)
    # where the colon turns tighter than its own radius, the inner side of the bend folds: a ring's piece
    # there stands inside the lumen of the centerline beside it (bhr's lumen is every point nearer a
    # centerline point than its radius); such pieces are left out, so the wall is where bhr's lumen ends
    from scipy.spatial import cKDTree

    tree = cKDTree(C)
    rad = dia / 2.0
    dropped = 0
    for k, (s, j) in enumerate(zip(ring_at, idx)):
        k_piece = float(k_unit * ring_len[k])
        m_piece = k_piece / w ** 2  # the piece moves as fast as the servos
        b_piece = 2 * math.sqrt(k_piece * m_piece)
        f = (s - arc[j - 1]) / (arc[j] - arc[j - 1])
        c = C[j - 1] + f * (C[j] - C[j - 1])
        t = C[j] - C[j - 1]
        t /= np.linalg.norm(t)
        R0 = (dia[j - 1] + f * (dia[j] - dia[j - 1])) / 2.0
        if u_prev is None:
            ref = np.array([0.0, 0.0, 1.0]) if abs(t[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            u_prev = np.cross(t, ref)
        u = u_prev - np.dot(u_prev, t) * t
        u /= np.linalg.norm(u)
        u_prev = u
        v = np.cross(t, u)
        for p in range(pieces):
            ang = 2 * math.pi * p / pieces
            n_out = math.cos(ang) * u + math.sin(ang) * v  # outward normal, the box's z
            tang = np.cross(t, n_out)  # around the ring, the box's y; t is its x
            face = c + R0 * n_out  # the middle of the piece's inner face
            near = tree.query_ball_point(face, float(rad.max()))
            if near and np.any(np.linalg.norm(C[near] - face, axis=1) < rad[near] - FOLD_TOLERANCE_MM):
                dropped += 1
                continue
            pos = (c + (R0 + thickness / 2) * n_out) * MM
            q = _quat(np.stack([t, tang, n_out]).T)
            hx = float(ring_len[k] / 2 * 1.02)
            hy = float(R0 * math.tan(half) * 1.02)
            lines.append(f'    <body name="w{k}_{p}" pos="{" ".join(repr(float(x)) for x in pos)}" '
                         f'quat="{" ".join(repr(float(x)) for x in q)}">'
                         + "".join(f'<joint type="slide" axis="{ax}" stiffness="{k_piece!r}" damping="{b_piece!r}"/>'
                                   for ax in axes) +
                         f'<geom type="box" size="{hx * MM!r} {hy * MM!r} {thickness / 2 * MM!r}" contype="1" '
                         f'conaffinity="2" rgba="0.8 0.5 0.5 0.3" mass="{m_piece!r}"/></body>')
    lines.append("  </worldbody>")
    # servos: a joint holds its tilt as a spring kp stiff enough that a force at the robot's far end deflects
    # the robot 1/stiff_ratio as much as the wall (kp = ratio K L^2, L the length beyond the joint), and at
    # least I w^2 (I the inertia beyond it); a rotor inertia (armature, set by replay_physics) brings the
    # joint's inertia to kp / w^2 so every servo settles at w, critically damped (kv = 2 kp / w)
    L = r.module_length * MM
    K = wall_stiffness * 1e3
    lines.append("  <actuator>")
    # the insertion: the whole robot's mass on the slide, as stiff as a lift servo
    kp_in = max(inert.mass * (M + 1) * w * w, stiff_ratio * K)
    lines.append(f'    <position name="s_insert" joint="insert" kp="{kp_in!r}" kv="{2 * kp_in / w!r}"/>')
    names = ("tilt_x", "tilt_y", "lift") if lift else ("tilt_x", "tilt_y")
    for i in range(1, M + 1):
        q = np.arange(M - i + 1)
        I_rot = inert.mass * float(np.sum(((q + 0.5) * L) ** 2)) + (M - i + 1) * inert.ixx
        m_lin = inert.mass * (M - i + 1)
        span = (M - i + 1) * L
        for nm in names:
            load = m_lin if nm == "lift" else I_rot
            kp = max(load * w * w, stiff_ratio * K * (1.0 if nm == "lift" else span * span))
            lines.append(f'    <position name="s{i}_{nm}" joint="m{i}_{nm}" kp="{kp!r}" kv="{2 * kp / w!r}"/>')
    lines.append("  </actuator>")
    lines.append("</mujoco>")
    settings = {"wall_stiffness_n_per_mm": wall_stiffness, "ring_spacing_mm": ring_spacing, "pieces_per_ring": pieces,
                "wall_pieces": int(len(ring_at) * pieces - dropped), "folded_pieces_left_out": dropped,
                "rate_hz": rate, "substeps": substeps,
                "servo_hz": servo_hz, "stiff_ratio": stiff_ratio, "modules": M, "timestep_s": dt,
                "carriage_moved_steps": int(np.count_nonzero(_moved)),
                "joint_values": "codes" if chain.from_codes else "tilts and chords onto bhr's modules",
                "shortest_chord_mm": float(r.module_length + (chain.chords.min() if chain.chords is not None else 0.0))}
    return "\n".join(lines) + "\n", settings


class _Stepper:
    """MuJoCo's time steps of a replay, with the implicit damping folded into the mass matrix where no contact acts.

    Semi-implicit Euler with implicit damping (MuJoCo's ``mj_EulerSkip``) solves the constraints with M, then
    advances the velocity by ``h (M + h D)^-1 (f + J' lambda)`` (f every smooth force, the damping's ``-D qvel``
    among them): it factorises M (for the constraints) and M + h D at every time step. Without a constraint
    (lambda = 0) a mass matrix of M + h D (each joint's armature + h D) with the damping explicit advances it by
    the same ``h (M + h D)^-1 f`` with one factorisation. ``folded`` steps so wherever no contact acts: a time
    step that finds a contact is undone and stepped again with MuJoCo's own implicit damping, and so are the
    ones after it until a time step finds none, so every contact force is MuJoCo's Euler's. A joint limit alone
    (:data:`FOLD_AT_JOINT_LIMITS`) is solved with M + h D (docs/physics.md, "Speed"). Contacts solved with
    M + h D too read a smaller largest force at 16 substeps (3.64 N against 4.22 N; 4.65 N at 32)."""

    def __init__(self, mujoco: Any, model: Any, data: Any, folded: bool) -> None:
        self.mj, self.model, self.data, self.enabled = mujoco, model, data, folded
        self.folded = False
        self.unfolded = self.redone = 0  # time steps with MuJoCo's implicit damping; of them, undone ones
        if not folded:
            return
        hd = model.opt.timestep * model.dof_damping
        self.arm = (model.dof_armature.copy(), model.dof_armature + hd)
        # a simple body's (a wall piece's) mass matrix is not made at each time step but copied from dof_M0, its
        # diagonal with the armature that mj_setConst made: it takes h D too
        simple = model.dof_simplenum > 0
        m0 = model.dof_M0.copy()
        m0[simple] += hd[simple]
        self.m0 = (model.dof_M0.copy(), m0)
        flag = int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
        self.flags = (int(model.opt.disableflags) & ~flag, int(model.opt.disableflags) | flag)
        self.spec = mujoco.mjtState.mjSTATE_INTEGRATION
        self.state = np.empty(mujoco.mj_stateSize(model, self.spec))
        self._mode(True)

    def _mode(self, folded: bool) -> None:
        k = int(folded)
        self.model.dof_armature[:] = self.arm[k]
        self.model.dof_M0[:] = self.m0[k]
        self.model.opt.disableflags = self.flags[k]
        self.folded = folded

    def _constrained(self) -> bool:
        """The last time step had a contact (or, unless FOLD_AT_JOINT_LIMITS, any constraint)."""
        return bool(self.data.ncon if FOLD_AT_JOINT_LIMITS else self.data.nefc)

    def __call__(self, n: int = 1) -> None:
        mj, model, data = self.mj, self.model, self.data
        if not self.enabled:
            mj.mj_step(model, data, nstep=n)
            return
        for _ in range(n):
            if self.folded:
                mj.mj_getState(model, data, self.state, self.spec)
                mj.mj_step(model, data)
                if self._constrained():  # undone, and stepped again with MuJoCo's implicit damping
                    mj.mj_setState(model, data, self.state, self.spec)
                    self._mode(False)
                    self.redone += 1
                    self.unfolded += 1
                    mj.mj_step(model, data)
            else:
                self.unfolded += 1
                mj.mj_step(model, data)
                if not self._constrained():
                    self._mode(True)


def replay_physics(result, progress: Any = None, **options: Any) -> PhysicsReplay:
    """Replay ``result`` (a run with codes and a lumen) in MuJoCo; see :func:`scene_xml` for ``options``.

    Per step: the insertion slide's target becomes the run's insertion depth (:func:`insertion`; the
    carriage moves only where bhr's rear end leaves the entrance line), the servos' targets become the step's
    joint values (:func:`bhr.model.export.joint_values` of the whole robot's codes, or :func:`replay_chain`'s
    tilts for the trail model, whose modules are also given their chords' lengths), the scene runs for one
    step period (``1 / rate``) and the contacts between robot and wall are read: the largest normal force,
    where, and how far every module point is from bhr's pose.
    """
    import time

    mujoco = require("mujoco")
    chain = replay_chain(result)
    xml, settings = scene_xml(result, chain=chain, **options)
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:  # a scene MuJoCo cannot simulate: a lumen of 1e-6 mm makes wall pieces of no inertia
        why = str(exc).splitlines()[0].removeprefix("Error: ")[:120]
        narrowest = float(min(result.trajectory.lumen)) if result.trajectory.lumen is not None else float("nan")
        raise BhrError(f"MuJoCo cannot build this run's scene ({why}); its lumen is {narrowest:g} mm at its "
                       "narrowest: replay a run whose lumen is a colon's, a few mm at least") from None
    w = 2 * math.pi * float(settings["servo_hz"])
    mujoco.mj_setConst(model, mujoco.MjData(model))
    for a in range(model.nu):  # rotor inertia: the joint's inertia becomes kp / w^2, so every servo settles at w
        dof = model.jnt_dofadr[model.actuator_trnid[a, 0]]
        model.dof_armature[dof] = model.actuator_gainprm[a, 0] / w ** 2
        if INTEGRATOR == "Euler":  # the servo's damping as the joint's, which Euler integrates implicitly
            model.dof_damping[dof] = -model.actuator_biasprm[a, 2]
            model.actuator_biasprm[a, 2] = 0.0
    data = mujoco.MjData(model)
    advance = _Stepper(mujoco, model, data, INTEGRATOR == "Euler" and DAMPING_IN_ARMATURE)
    roots, frames, values = chain.roots, chain.frames, chain.values
    depth, cpos, cquat, moved = insertion(result, roots, frames)
    N, M = chain.points.shape[0], chain.points.shape[1] - 1
    lift = chain.lift
    if not lift:
        values = values.reshape(N, M, 3)[:, :, :2].reshape(N, -1)
    ctrl = np.hstack([depth[:, None] * MM, values])  # the actuators' order: the insertion, then the joints
    # the trail model's modules are chords, shorter than a module across a vertex: at every step each module's
    # length (where the next module's body, or the tip, sits on its axis) is set to its chord
    tip = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tip")
    chord_at = None
    if chain.chords is not None:
        chord_at = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"m{i}") for i in range(2, M + 1)],
                            dtype=np.int64)
        lengths = float(model.site_pos[tip, 2]) + chain.chords * MM
    geom_module = np.zeros(model.ngeom, dtype=np.int64)  # module of a robot geom (1 = rear), 0 for the wall
    for i in range(1, M + 1):
        geom_module[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"m{i}")] = i
    qadr = model.jnt_qposadr[model.actuator_trnid[:, 0]]
    jx = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"m{i}_tilt_x") for i in range(1, M + 1)])
    C, _dia, arc = wall_centerline(result, 0.0)
    steps = int(settings["substeps"])
    force = np.zeros(N)
    where = np.full((N, 3), np.nan)
    arc_at = np.full(N, np.nan)
    module = [0] * N
    dev = np.zeros(N)
    contacts: list[np.ndarray] = []
    f6 = np.zeros(6)
    t0 = time.process_time()
    data.qpos[qadr] = ctrl[0]
    # the step's targets (the servos', the carriage's, the chords') move from the last step's to this step's
    # over the first quarter of the step (the trail model's: half), one time step at a time, and hold for the
    # rest: the robot moves as bhr's does, by a feed, instead of jumping (a carriage that jumps turns the whole
    # robot about its rear at once, and a long robot's far end then swings across the colon)
    trail = chain.chords is not None
    ramp = max(1, steps // (TRAIL_RAMP_FRACTION if trail else RAMP_FRACTION))
    fracs = np.arange(1, ramp + 1) / ramp
    tip_len = float(model.site_pos[tip, 2])

    def trail_targets(i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The trail model's targets at every time step of step i's ramp: the model's own robot at that
        fraction of the feed (trail_substeps), not a straight line in joint space between two steps' poses;
        the carriage, whose pose is then the model's too, turns with the rear module as the model turns it.
        Made one step at a time: the whole run's would take steps x ramp x joints of memory."""
        two = np.array([max(i - 1, 0), i])
        s_roots, s_frames, s_values, s_chords = trail_substeps(
            replace(chain, points=chain.points[two], frames=chain.frames[two]), fracs, result.robot.module_length)
        s_depth, s_cpos, s_cquat, _ = insertion(result, s_roots[1], s_frames[1])
        vals = s_values[1] if lift else s_values[1].reshape(ramp, M, 3)[..., :2].reshape(ramp, -1)
        return (np.concatenate([s_depth[:, None] * MM, vals], axis=1), s_cpos * MM, s_cquat,
                tip_len + s_chords[1] * MM)

    dt = float(model.opt.timestep)
    for i in range(N):
        j = max(i - 1, 0)
        p0, q0 = data.mocap_pos[0].copy(), data.mocap_quat[0].copy()
        p1, q1 = (cpos[i] * MM, cquat[i] * (1.0 if np.dot(cquat[i], q0) >= 0 else -1.0)) if moved[i] else (p0, q0)
        sub = trail_targets(i) if trail else None
        if sub is not None:
            # servos with feedforward along the model's motion: each one's target leads by its damping's lag
            # (2 / w times the target's speed) and its rotor's inertia (the target's acceleration / w^2), so the
            # joints turn with the carriage instead of lagging it (a lagging joint behind a turning carriage
            # swings the whole robot beyond it about the rear)
            y = np.vstack([ctrl[j][None], sub[0], sub[0][-1:]])
            v = np.diff(y, axis=0) / dt
            v[-1] = 0.0
            ff = y[1:] + (2.0 / w) * v + np.diff(np.vstack([np.zeros((1, v.shape[1])), v]), axis=0) / (w * w * dt)
        for r in range(1, ramp + 1):
            frac = r / ramp
            if sub is not None:
                data.ctrl[:] = ff[r - 1]
                data.mocap_pos[0], data.mocap_quat[0] = sub[1][r - 1], sub[2][r - 1]
                model.body_pos[chord_at, 2] = sub[3][r - 1, :-1]
                model.site_pos[tip, 2] = sub[3][r - 1, -1]
                advance()
                continue
            data.ctrl[:] = ctrl[j] + frac * (ctrl[i] - ctrl[j])
            if moved[i]:
                data.mocap_pos[0] = p0 + frac * (p1 - p0)
                q = q0 + frac * (q1 - q0)
                data.mocap_quat[0] = q / np.linalg.norm(q)
            if chord_at is not None:
                ln = lengths[j] + frac * (lengths[i] - lengths[j])
                model.body_pos[chord_at, 2] = ln[:-1]
                model.site_pos[tip, 2] = ln[-1]
            advance()
        if sub is not None and steps > ramp:
            data.ctrl[:] = ff[ramp]  # the ramp's end: the target held, its speed taken off
            advance()
            data.ctrl[:] = sub[0][-1]
            if steps > ramp + 1:
                advance(steps - ramp - 1)
        elif steps > ramp:
            advance(steps - ramp)
        pts = []
        best = 0.0
        nc = data.ncon
        if nc:
            g1, g2 = data.contact.geom1[:nc], data.contact.geom2[:nc]
            mod = np.maximum(geom_module[g1], geom_module[g2])
            for c in np.nonzero((mod > 0) & (data.contact.dist[:nc] <= 0))[0]:
                mujoco.mj_contactForce(model, data, int(c), f6)
                fn = abs(float(f6[0]))
                pos = data.contact.pos[c] / MM
                pts.append(pos)
                if fn > best:
                    best, where[i], module[i] = fn, pos, int(mod[c])
        if pts and best == 0.0:
            best = 1e-12  # touching with no force yet still counts as contact
            where[i] = pts[0]
        force[i] = best
        contacts.append(np.array(pts).reshape(-1, 3))
        if pts:
            k = int(np.argmin(np.linalg.norm(C - where[i], axis=1)))
            arc_at[i] = arc[k]
        sim = np.vstack([data.xanchor[jx], data.site_xpos[tip][None]]) / MM
        dev[i] = float(np.max(np.linalg.norm(sim - chain.points[i], axis=1)))
        if progress is not None:
            progress(i + 1, N)
    cpu = time.process_time() - t0
    settings = {**settings, "damping_folded": advance.enabled, "time_steps_unfolded": advance.unfolded
                if advance.enabled else N * steps, "time_steps_redone": advance.redone}
    return PhysicsReplay(force, where, arc_at, module, dev, contacts, settings, cpu)


def force_figure(rep: PhysicsReplay, title: str = "") -> Any:
    """Largest contact force per step and along the colon, with the 9.8 N and 14.1 N lines (a matplotlib figure)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6.5), constrained_layout=True)
    steps = np.arange(1, len(rep.max_force_n) + 1)
    a1.plot(steps, rep.max_force_n, color="tab:red", lw=1.2, label="largest contact force")
    hit = rep.max_force_n > 0
    a2.scatter(rep.arc_mm[hit], rep.max_force_n[hit], s=8, color="tab:red", label="largest force of a step, where")
    for ax in (a1, a2):
        ax.axhline(FORCE_LINES_N[0], color="tab:orange", ls="--", lw=1,
                   label="9.8 N: exceeded 5 % of the time in colonoscopy (Appleyard 2000)")
        ax.axhline(FORCE_LINES_N[1], color="black", ls="--", lw=1,
                   label="14.1 N: porcine colon perforates (Johnson 2019)")
        ax.set_ylabel("force on the wall (N)")
        ax.set_ylim(0, max(16.0, float(rep.max_force_n.max(initial=0.0)) * 1.1))
        ax.grid(alpha=0.3)
    a1.set_xlabel("step")
    a2.set_xlabel("where along the colon (mm of centerline from the entrance; < 0: behind it)")
    a1.legend(loc="upper left", fontsize=8)
    a1.set_title(title or "MuJoCo replay: contact force on the colon wall")
    s = rep.summary()
    a2.set_title(f"max {s['max_force_n']:.2f} N at step {s['max_force_step']}; contact at "
                 f"{len(s['contact_steps'])} steps; max deviation from bhr's pose {s['max_deviation_mm']:.3f} mm",
                 fontsize=9)
    return fig


def worst_colon_extras(run, folder: Any, physics: bool = False) -> list[str]:
    """For ``bhr traverse``: the worst colon's 3-D view and, with ``physics``, its MuJoCo replay; the file names."""
    from pathlib import Path

    from bhr.output.atomic import write_json
    from bhr.output.plots import save_figure
    from bhr.output.view import save_view

    folder = Path(folder)
    names = []
    contacts = None
    if physics and run.codes is not None and run.trajectory.lumen is not None:
        rep = replay_physics(run)
        write_json(folder / "worst-colon-physics.json", rep.to_dict())
        save_figure(force_figure(rep, f"{run.trajectory.name}: the worst colon replayed in MuJoCo"),
                    folder / "worst-colon-force.png")
        names += ["worst-colon-physics.json", "worst-colon-force.png"]
        contacts = rep.contacts
    names.append(save_view(run, folder, contacts=contacts, name="worst-colon-view.html").name)
    return names
