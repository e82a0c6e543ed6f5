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
    "Robot": "robot", "THESIS_ROBOT": "robot", "CHAPTER5_ROBOT": "robot", "forward_kinematics": "robot",
    "min_turn_radius": "robot", "alpha_from_stroke": "robot",
    "Trajectory": "path", "unfollowable_bends": "path",
    "trajectory": "generators", "load_trajectory": "generators", "builtin_names": "generators",
    "Colon": "anatomy", "anatomical_colon": "anatomy",
    "VALID_CODES": "codes", "check_codes": "codes", "read_codes_csv": "codes", "format_codes_csv": "codes",
    "RobotFile": "robotfile", "load_robot_file": "robotfile",
    "joint_names": "export", "joint_values": "export", "to_urdf": "export", "to_mjcf": "export",
    "ThermalParams": "wires",
}

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module(f"{__name__}.{_API[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return list(__all__)
