"""The model: the robot, its codes, trajectories (the thesis's generators, files, anatomical colons), robot files.

The supported names are listed in ``__all__`` and loaded on first use (PEP 562), so ``import bhr.model`` stays
cheap; the modules inside this package are not part of the API. Lengths are in mm, angles in degrees.

>>> from bhr.model import Robot, trajectory
>>> Robot(modules=3).fk([3, 0, 15])[0].shape
(4, 3)
>>> trajectory("curve", radius=70, angle=90).points.shape[1]
3

Imports the settings and the kernels below it, nothing above.
"""
from __future__ import annotations

import importlib
from typing import Any

#: Public name -> the module of this package that defines it.
_API = {
    "Robot": "_robot", "THESIS_ROBOT": "_robot", "CHAPTER5_ROBOT": "_robot", "forward_kinematics": "_robot",
    "min_turn_radius": "_robot", "alpha_from_stroke": "_robot",
    "Trajectory": "_path", "unfollowable_bends": "_path",
    "trajectory": "_generators", "load_trajectory": "_generators", "builtin_names": "_generators",
    "Colon": "_anatomy", "anatomical_colon": "_anatomy",
    "VALID_CODES": "_codes", "check_codes": "_codes", "read_codes_csv": "_codes", "format_codes_csv": "_codes",
    "RobotFile": "_robotfile", "load_robot_file": "_robotfile", "default_robot_file": "_robotfile",
    "joint_names": "_export", "joint_values": "_export", "to_urdf": "_export", "to_mjcf": "_export",
    "base_transform": "_export",
    "ThermalParams": "_wires",
}

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module(f"{__name__}.{_API[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return list(__all__)
