"""The physical robot against the colon's wall, and the exported models in pinocchio and MuJoCo.

- :mod:`.poses`: the physical robot's poses as the replay reads them (``poses.npz``; a run's codes converted);
- :mod:`.wall`: the colon's wall (a foundation around bhr's lumen, its stiffness from the literature);
- :mod:`.joints`: how stiffly the nitinol wires hold a joint;
- :mod:`.equilibrium`: one pose of the rigid, wire-held robot in equilibrium (the compiled energy and its minimisation);
- :mod:`.replay`: that equilibrium at every pose of a run, the wall's load;
- :mod:`.engines`: bhr's robot exported to pinocchio and MuJoCo and cross-checked (needs the ``physics`` extra).

docs/physics.md describes the replay, docs/export.md the export.
"""
from __future__ import annotations

from bhr._studies.physics.engines import (FkAgreement, check_installed, fk_cross_check, missing, mujoco_model,
                                         mujoco_points, pinocchio_model, pinocchio_points, pinocchio_q, require)
from bhr._studies.physics.joints import WIRE_FORCE_N, joint_stiffness
from bhr._studies.physics.poses import Poses, load_poses, poses_from_run, start_direction
from bhr._studies.physics.replay import (DEFAULT_FEEDER_FORCE, PhysicsReplay, replay_physics, replay_poses)
from bhr._studies.physics.wall import (DEFAULT_MAX_WALL_FORCE, DEFAULT_WALL_STIFFNESS, FORCE_LINES_N,
                                      WALL_STIFFNESS_RANGE, check_wall_stiffness)

__all__ = ["FkAgreement", "check_installed", "fk_cross_check", "missing", "mujoco_model", "mujoco_points",
           "pinocchio_model", "pinocchio_points", "pinocchio_q", "require", "WIRE_FORCE_N", "joint_stiffness", "Poses",
           "load_poses", "poses_from_run", "start_direction", "DEFAULT_FEEDER_FORCE", "PhysicsReplay", "replay_physics",
           "replay_poses", "DEFAULT_MAX_WALL_FORCE", "DEFAULT_WALL_STIFFNESS", "FORCE_LINES_N", "WALL_STIFFNESS_RANGE",
           "check_wall_stiffness"]
