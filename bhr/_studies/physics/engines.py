"""bhr robots in pinocchio and MuJoCo: the exported models cross-checked against bhr's forward kinematics.

Needs the ``physics`` extra (``python3 -m pip install '.[physics]'`` in bhr's source folder:
pinocchio and MuJoCo; the errors print the exact command, :func:`bhr._settings.extras.install_command`);
both are imported only inside the functions here, so ``import bhr`` never loads them.
docs/export.md describes what is computed.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from bhr._settings.errors import BhrError
from bhr.model._export import MM, joint_names, joint_values, to_mjcf, to_urdf
from bhr.model._robot import Robot, forward_kinematics

__all__ = ["missing", "FkAgreement", "fk_cross_check", "pinocchio_model", "pinocchio_points", "pinocchio_q",
           "mujoco_model", "mujoco_points", "require", "check_installed"]


def missing(module: str) -> str:
    """The one-line error for ``module`` (``mujoco``, ``pinocchio``) missing, with the command that installs it."""
    from bhr._settings.extras import install_command

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
    """A pinocchio configuration from joint values in :func:`bhr.model._export.joint_names` order (by joint name)."""
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

    from bhr.model._codes import VALID_CODES

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
