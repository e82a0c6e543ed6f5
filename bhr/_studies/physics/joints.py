"""How stiffly the wires hold a joint: a rotational stiffness from the nitinol wire's datasheet and the lever.

A tilt is made by two neighbouring wires of a module contracting (bhr._kinematics.codetable). Each pulls with its
recovery force ``F`` at the lever ``L`` from the module's axis; over its stroke ``h`` (``alpha = asin(h / L)``,
thesis Ec. 4.1) that pull is what brings the next module from straight to ``alpha``. Pushed back from its tilt by
the wall, a contracted wire is stretched and its pull grows by what it would have lost over the stroke: taken
linear, two wires give a torque ``2 F L`` over the angle ``alpha``, a rotational stiffness
``k = 2 F L / alpha`` (N mm / rad) about both tilt axes. docs/physics.md gives the figures and their sources.

A passive body (the rear modules without wires, ``--passive-modules``) is a compliant tube held straight by its own
bending stiffness: a beam of flexural rigidity ``EI`` bent through ``theta`` over one module length ``l`` carries
the moment ``EI theta / l``, so each of its joints holds its tilt towards straight with ``k = EI / l``.
"""
from __future__ import annotations

import math

__all__ = ["WIRE_FORCE_N", "WIRES_PER_TILT", "PASSIVE_RIGIDITY_NMM2", "lever_mm", "joint_stiffness",
           "passive_stiffness"]

#: Recovery force of a 0.100 mm (0.004 in) Flexinol nitinol wire: 150 g, 1.47 N (Dynalloy, "Technical
#: characteristics of Flexinol actuator wires", table of wire sizes); the robot file's [thermal] figures are
#: this wire's.
WIRE_FORCE_N = 0.150 * 9.80665
#: Wires that pull together in a tilt (two neighbouring actuators, thesis Table 4.2).
WIRES_PER_TILT = 2
#: Flexural rigidity of a colonoscope's insertion tube, N mm^2, the default passive body: an Olympus CF-140S measured
#: 260-400 N cm^2 along its length at room temperature, and 17 % less on average at 37 degrees C ("Flexural and
#: torsional rigidity of colonoscopes at room and body temperatures", Proc Inst Mech Eng H): the middle of the
#: range at body temperature, 0.83 x 330 N cm^2 (the option registry's default, to the bit).
PASSIVE_RIGIDITY_NMM2 = float(round(0.83 * 330.0 * 100.0))


def lever_mm(robot) -> float:
    """The wires' lever: the robot file's ``lever``, else one module diameter (as ``Robot.lift`` takes it)."""
    if getattr(robot, "lever", None):
        return float(robot.lever)
    return 2.0 * float(robot.robot_radius)


def joint_stiffness(robot, wire_force_n: float = WIRE_FORCE_N) -> float:
    """Rotational stiffness (N mm / rad) with which a joint's wires hold its tilt: ``2 F L / alpha``."""
    return WIRES_PER_TILT * float(wire_force_n) * lever_mm(robot) / math.radians(float(robot.alpha))


def passive_stiffness(module_length_mm: float, rigidity_nmm2: float = PASSIVE_RIGIDITY_NMM2) -> float:
    """Rotational stiffness (N mm / rad) of one joint of a passive body of flexural rigidity ``rigidity_nmm2``
    whose joints are ``module_length_mm`` apart: ``EI / l``."""
    return float(rigidity_nmm2) / float(module_length_mm)
