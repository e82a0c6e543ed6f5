"""A bhr robot as a URDF or MJCF model, and the joint values that make the model take a run's poses.

Each module ``i`` (1 = base) is three joints at its rear joint, point ``i``,
applied in this order (docs/export.md):

* ``m<i>_tilt_x``: revolute about the module's local x, limits +-alpha (codes 3: +alpha, 12: -alpha);
* ``m<i>_tilt_y``: revolute about the local y, limits +-alpha (codes 6: +alpha, 9: -alpha);
* ``m<i>_lift``: prismatic along the local z, 0 ... the lift (code 15: the lift, else 0).

Module ``i``'s link ``m<i>`` then runs along its z for one module length, and
module ``i+1``'s joints sit at its far end. Between the joints are the
massless links ``m<i>_tx`` and ``m<i>_ty`` (``m<i>_ty`` is bhr's module frame
at point ``i``); a fixed frame ``tip`` marks point ``n+1``. Only one tilt of
a module is ever non-zero (the code table), so the two revolute joints in
series give exactly bhr's tilt about one signed local axis
(:func:`bhr._kinematics.frames.tilt_frame`).

The files are in SI units (metres, kilograms, radians), as URDF and MuJoCo
expect; bhr's millimetres are divided by 1000. The ``base`` link is bhr's base
frame, whose z a straight robot runs along: :func:`base_transform` gives the
4x4 transform from it to bhr's frames (``Robot.fk`` along +X, ``bhr solve``
along +Y).

Mass and inertia of a module: the robot file's ``[mass]`` table where it
gives them (``module_mass`` in grams, or ``density`` in kg/m^3), otherwise a
solid cylinder of the module's radius and length of density
:data:`DEFAULT_DENSITY` (a printed resin); the inertia is always that of a
solid cylinder of the module's mass about its centre.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from bhr.model._codes import check_codes
from bhr._settings.errors import BhrError
from bhr._kinematics.codetable import CODE_AXIS, LIFT
from bhr.model._robot import Robot

__all__ = ["FORMATS", "DEFAULT_DENSITY", "Inertia", "module_inertia", "joint_names", "joint_values", "to_urdf",
           "to_mjcf", "export_text", "MM", "BASE_DIRECTIONS", "base_transform"]

#: Export formats, by the name ``bhr export --format`` takes.
FORMATS = ("urdf", "mjcf")
#: Density (kg/m^3) of a module when the robot file gives no mass: a 3-D printed resin (PLA, about 1240).
DEFAULT_DENSITY = 1240.0
#: Metres per millimetre.
MM = 1e-3
#: Joints per module, in the exported files' order.
JOINTS_PER_MODULE = ("tilt_x", "tilt_y", "lift")


def _f(x: float) -> str:
    """A float written so it reads back bit for bit (repr), without a trailing ``.0`` on integers."""
    s = repr(float(x))
    return s[:-2] if s.endswith(".0") else s


@dataclass(frozen=True)
class Inertia:
    """A module's mass (kg), centre of mass (m, in its link frame) and principal inertia (kg m^2) about it."""

    mass: float
    com: tuple[float, float, float]
    ixx: float
    iyy: float
    izz: float


def module_inertia(robot: Robot, mass_g: float | None = None, density: float | None = None) -> Inertia:
    """Mass and inertia of one module: a solid cylinder of the robot's radius and module length.

    ``mass_g`` (grams) wins over ``density`` (kg/m^3); neither: :data:`DEFAULT_DENSITY`.
    """
    r, ln = robot.robot_radius * MM, robot.module_length * MM
    if mass_g is not None:
        if not (isinstance(mass_g, (int, float)) and math.isfinite(mass_g) and mass_g > 0):
            raise BhrError(f"module mass must be a positive number of grams, got {mass_g!r}")
        m = float(mass_g) * 1e-3
    else:
        rho = DEFAULT_DENSITY if density is None else density
        if not (isinstance(rho, (int, float)) and math.isfinite(rho) and rho > 0):
            raise BhrError(f"density must be a positive number of kg/m^3, got {rho!r}")
        m = float(rho) * math.pi * r * r * ln
    ixx = m * (3.0 * r * r + ln * ln) / 12.0
    return Inertia(m, (0.0, 0.0, ln / 2.0), ixx, ixx, m * r * r / 2.0)


def joint_names(modules: int) -> list[str]:
    """The exported joints in order: ``m1_tilt_x, m1_tilt_y, m1_lift, m2_tilt_x, ...`` (1 = base).

    Parameters
    ----------
    modules : int
        The number of modules n.

    Returns
    -------
    list of str, length 3 n
        Each module's tilt about x, tilt about y (revolute, rad) and lift (prismatic, m), base first.

    Examples
    --------
    >>> joint_names(2)
    ['m1_tilt_x', 'm1_tilt_y', 'm1_lift', 'm2_tilt_x', 'm2_tilt_y', 'm2_lift']
    """
    return [f"m{i}_{j}" for i in range(1, modules + 1) for j in JOINTS_PER_MODULE]


def joint_values(codes: Any, robot: Robot | None = None) -> np.ndarray:
    """Joint values of the exported model for module codes, in :func:`joint_names` order (rad, m).

    Code 3 sets
    ``tilt_x`` to +alpha, 12 to -alpha; 6 sets ``tilt_y`` to +alpha, 9 to -alpha;
    15 sets ``lift`` to the robot's lift (:attr:`bhr.model._robot.Robot.lift`); 0 leaves
    all three at 0.

    Parameters
    ----------
    codes : array_like of int, shape (n,) or (steps, n)
        One code per module (base first), or one row per step (a codes.csv's rows).
    robot : Robot, optional
        Gives alpha and the lift (default: the thesis robot); the number of modules is the number of codes.

    Returns
    -------
    ndarray, shape (3 n,) or (steps, 3 n)
        ``tilt_x`` and ``tilt_y`` in rad and ``lift`` in m for each module, in :func:`joint_names` order.

    Raises
    ------
    BhrError
        Codes that are not one per module (or one row per step), or not valid codes.

    Examples
    --------
    >>> joint_values([3, 0, 15], Robot(modules=3)).round(6).tolist()
    [0.174533, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.001736]
    """
    robot = Robot() if robot is None else robot
    arr = np.asarray(codes)
    if arr.ndim not in (1, 2) or arr.size == 0:
        raise BhrError("codes must be one code per module, or one row of codes per step")
    rows = arr.reshape(1, -1) if arr.ndim == 1 else arr
    a = math.radians(robot.alpha)
    lift = robot.lift * MM
    out = np.zeros((rows.shape[0], rows.shape[1], 3))
    for s, row in enumerate(rows):
        for i, code in enumerate(check_codes(list(row))):
            if code == LIFT:
                out[s, i, 2] = lift
            elif code in CODE_AXIS:
                axis, sign = CODE_AXIS[code]
                out[s, i, axis] = sign * a
    flat = out.reshape(rows.shape[0], -1)
    return flat[0] if arr.ndim == 1 else flat


#: bhr's named base frames: the direction a straight robot runs along in each (docs/model.md, "Frames").
BASE_DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "follow": (1.0, 0.0, 0.0),  # Robot.fk, bhr fk, bhr follow: the thesis's ch. 7 robot along +X
    "solve": (0.0, 1.0, 0.0),  # bhr solve, bhr.solve: the thesis's ch. 5/6 chain along +Y
    "model": (0.0, 0.0, 1.0),  # the exported URDF/MJCF: the base link's z
}


def base_transform(frame: str | Sequence[float] = "follow", base: Sequence[float] = (0.0, 0.0, 0.0), *,
                   units: str = "m") -> np.ndarray:
    """The 4x4 homogeneous transform from the exported model's ``base`` link to one of bhr's frames.

    A point ``p`` of the URDF/MJCF model (its world when the base is fixed at the origin, as
    ``bhr export`` writes it) is ``T @ [p, 1]`` in bhr's frame, where the same codes give
    :func:`bhr.model.forward_kinematics`'s points; a module frame ``F`` (rows x, y, z) of the
    model is ``F @ T[:3, :3].T`` there. The inverse, ``numpy.linalg.inv(T)``, places bhr's pose in
    the model's frame; in MuJoCo, ``<body name="base" pos=... quat=...>`` carries it (pos
    ``T[:3, 3]``, quat of ``T[:3, :3]``).

    Parameters
    ----------
    frame : str or sequence of 3 floats, default "follow"
        bhr's frame: ``"follow"`` (``Robot.fk``, ``bhr fk``, ``bhr follow``: a straight robot along
        +X), ``"solve"`` (``bhr solve``: along +Y), ``"model"`` (the identity rotation: along +Z), or
        any direction (3,) a straight robot runs along.
    base : sequence of 3 floats, default (0, 0, 0)
        The base point in bhr's frame, mm.
    units : {"m", "mm"}, default "m"
        ``"m"``: the model's metres (translation in metres); ``"mm"``: bhr's millimetres (scale the
        model's points by 1000 before applying ``T``).

    Returns
    -------
    numpy.ndarray
        (4, 4) homogeneous transform, float64.

    Examples
    --------
    >>> base_transform("follow").round(6).tolist()
    [[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    """
    from bhr.model._robot import base_frame

    if units not in ("m", "mm"):
        raise BhrError(f"units must be 'm' (the exported model's metres) or 'mm' (bhr's), got {units!r}")
    if isinstance(frame, str):
        if frame not in BASE_DIRECTIONS:
            raise BhrError(f"unknown frame {frame!r}; give one of {', '.join(BASE_DIRECTIONS)} or a direction X Y Z")
        direction: Sequence[float] = BASE_DIRECTIONS[frame]
    else:
        direction = frame
    d = np.asarray(direction, dtype=np.float64)
    if d.shape != (3,):
        raise BhrError(f"a frame's direction is 3 numbers X Y Z, got {list(np.ravel(d))}")
    b = np.asarray(base, dtype=np.float64)
    if b.shape != (3,) or not np.isfinite(b).all():
        raise BhrError(f"base must be 3 finite numbers X Y Z in mm, got {list(np.ravel(b))}")
    T = np.eye(4)
    T[:3, :3] = base_frame(d).T  # columns: bhr's base frame's x, y, z (the model's base link axes)
    T[:3, 3] = b * (MM if units == "m" else 1.0)
    return T


def _rgba(i: int) -> str:
    return "0.20 0.45 0.80 1" if i % 2 else "0.85 0.55 0.15 1"


def to_urdf(robot: Robot, modules: int | None = None, *, mass_g: float | None = None, density: float | None = None,
            name: str = "bhr") -> str:
    """The robot as URDF text (SI units): ``modules`` modules (default ``robot.modules``).

    Each module is three joints at its rear (tilt about x and y, revolute within +-alpha; a prismatic lift)
    and a link with the mass and inertia of a solid cylinder; the ``base`` link is the robot's base frame,
    z along the straight robot (docs/export.md). Load it in pinocchio or any URDF tool.

    Parameters
    ----------
    robot : Robot
        The robot: module length (mm), disc radius (mm), alpha (deg) and lift (mm), written in m and rad.
    modules : int, optional
        How many modules to write, at least 1; default ``robot.modules``.
    mass_g : float, optional
        The mass of one module, g; wins over ``density``.
    density : float, optional
        The modules' density, kg/m^3, for a solid cylinder of the disc radius and module length; neither
        given: :data:`DEFAULT_DENSITY`.
    name : str, default "bhr"
        The model's name.

    Returns
    -------
    str
        The URDF document.

    Raises
    ------
    BhrError
        Fewer than one module, or a mass or density that is not a positive number.

    Examples
    --------
    >>> text = to_urdf(Robot(modules=2))
    >>> text.count('type="revolute"'), text.count('type="prismatic"')
    (4, 2)
    """
    n = robot.modules if modules is None else int(modules)
    if n < 1:
        raise BhrError(f"a robot needs at least one module, got {n}")
    a, r, ln, lift = math.radians(robot.alpha), robot.robot_radius * MM, robot.module_length * MM, robot.lift * MM
    inert = module_inertia(robot, mass_g, density)
    out = ['<?xml version="1.0"?>',
           f"<!-- bhr robot: {n} modules of {robot.module_length:g} mm, radius {robot.robot_radius:g} mm, "
           f"alpha {robot.alpha:g} deg, lift {robot.lift:g} mm; SI units; joints per docs/export.md -->",
           f'<robot name="{name}">',
           '  <link name="base"/>']
    for i in range(1, n + 1):
        parent = "base" if i == 1 else f"m{i - 1}"
        z = 0.0 if i == 1 else ln
        out += [f'  <joint name="m{i}_tilt_x" type="revolute">',
                f'    <parent link="{parent}"/><child link="m{i}_tx"/>',
                f'    <origin xyz="0 0 {_f(z)}" rpy="0 0 0"/><axis xyz="1 0 0"/>',
                f'    <limit lower="{_f(-a)}" upper="{_f(a)}" effort="1" velocity="10"/>',
                "  </joint>",
                f'  <link name="m{i}_tx"/>',
                f'  <joint name="m{i}_tilt_y" type="revolute">',
                f'    <parent link="m{i}_tx"/><child link="m{i}_ty"/>',
                '    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>',
                f'    <limit lower="{_f(-a)}" upper="{_f(a)}" effort="1" velocity="10"/>',
                "  </joint>",
                f'  <link name="m{i}_ty"/>',
                f'  <joint name="m{i}_lift" type="prismatic">',
                f'    <parent link="m{i}_ty"/><child link="m{i}"/>',
                '    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>',
                f'    <limit lower="0" upper="{_f(lift)}" effort="1" velocity="1"/>',
                "  </joint>",
                f'  <link name="m{i}">',
                "    <inertial>",
                f'      <origin xyz="0 0 {_f(inert.com[2])}" rpy="0 0 0"/><mass value="{_f(inert.mass)}"/>',
                f'      <inertia ixx="{_f(inert.ixx)}" ixy="0" ixz="0" iyy="{_f(inert.iyy)}" iyz="0" '
                f'izz="{_f(inert.izz)}"/>',
                "    </inertial>",
                f'    <visual><origin xyz="0 0 {_f(ln / 2)}" rpy="0 0 0"/>'
                f'<geometry><cylinder radius="{_f(r)}" length="{_f(ln)}"/></geometry>'
                f'<material name="module{i % 2}"><color rgba="{_rgba(i)}"/></material></visual>',
                f'    <collision><origin xyz="0 0 {_f(ln / 2)}" rpy="0 0 0"/>'
                f'<geometry><cylinder radius="{_f(r)}" length="{_f(ln)}"/></geometry></collision>',
                "  </link>"]
    out += ['  <joint name="tip_fixed" type="fixed">',
            f'    <parent link="m{n}"/><child link="tip"/><origin xyz="0 0 {_f(ln)}" rpy="0 0 0"/>',
            "  </joint>",
            '  <link name="tip"/>',
            "</robot>", ""]
    return "\n".join(out)


def mjcf_robot_body(robot: Robot, modules: int, *, mass_g: float | None = None, density: float | None = None,
                    indent: str = "    ", base_pos: Sequence[float] = (0, 0, 0),
                    base_quat: Sequence[float] = (1, 0, 0, 0), base_joint: str = "",
                    geom_attrs: str = "", lift: bool = True, mocap: bool = False) -> list[str]:
    """The ``<body name="base">`` element of the robot (lines), for :func:`to_mjcf` and the physics scene.

    ``base_joint`` is inserted as the base body's joint (e.g. the insertion slide); ``geom_attrs`` is added
    to every module's collision capsule (contact classes, friction). ``lift=False`` leaves out the lift
    joints (a run that never lifts); ``mocap`` makes the base a MuJoCo mocap body (moved by the scene).
    """
    a, r, ln, stroke = math.radians(robot.alpha), robot.robot_radius * MM, robot.module_length * MM, robot.lift * MM
    inert = module_inertia(robot, mass_g, density)
    pos = " ".join(_f(v) for v in base_pos)
    quat = " ".join(_f(v) for v in base_quat)
    mc = ' mocap="true"' if mocap else ""
    out = [f'{indent}<body name="base" pos="{pos}" quat="{quat}"{mc}>']
    if base_joint:
        out.append(f"{indent}  {base_joint}")
    depth = 1
    for i in range(1, modules + 1):
        ind = indent + "  " * depth
        z = 0.0 if i == 1 else ln
        out += [f'{ind}<body name="m{i}" pos="0 0 {_f(z)}">',
                f'{ind}  <joint name="m{i}_tilt_x" type="hinge" axis="1 0 0" range="{_f(-a)} {_f(a)}"/>',
                f'{ind}  <joint name="m{i}_tilt_y" type="hinge" axis="0 1 0" range="{_f(-a)} {_f(a)}"/>',
                *([f'{ind}  <joint name="m{i}_lift" type="slide" axis="0 0 1" range="0 {_f(stroke)}"/>']
                  if lift else []),
                f'{ind}  <inertial pos="0 0 {_f(inert.com[2])}" mass="{_f(inert.mass)}" '
                f'diaginertia="{_f(inert.ixx)} {_f(inert.iyy)} {_f(inert.izz)}"/>',
                f'{ind}  <geom name="m{i}" type="capsule" fromto="0 0 0 0 0 {_f(ln)}" size="{_f(r)}" '
                f'rgba="{_rgba(i)}" mass="0"{(" " + geom_attrs) if geom_attrs else ""}/>']
        if i == modules:
            out.append(f'{ind}  <site name="tip" pos="0 0 {_f(ln)}" size="{_f(r / 2)}"/>')
        depth += 1
    for d in range(depth - 1, 0, -1):
        out.append(f"{indent}{'  ' * d}</body>")
    out.append(f"{indent}</body>")
    return out


def to_mjcf(robot: Robot, modules: int | None = None, *, mass_g: float | None = None, density: float | None = None,
            name: str = "bhr") -> str:
    """The robot as MJCF text (MuJoCo; SI units, radians): ``modules`` modules (default ``robot.modules``).

    Each module is one body ``m<i>`` carrying its three joints (in order, at its
    rear joint) and a capsule of the disc radius along its length; the base body
    is fixed to the world, gravity is off (docs/export.md).

    Parameters
    ----------
    robot : Robot
        The robot: module length (mm), disc radius (mm), alpha (deg) and lift (mm), written in m and rad.
    modules : int, optional
        How many modules to write, at least 1; default ``robot.modules``.
    mass_g : float, optional
        The mass of one module, g; wins over ``density``.
    density : float, optional
        The modules' density, kg/m^3, for a solid cylinder of the disc radius and module length; neither
        given: :data:`DEFAULT_DENSITY`.
    name : str, default "bhr"
        The model's name.

    Returns
    -------
    str
        The MJCF document.

    Raises
    ------
    BhrError
        Fewer than one module, or a mass or density that is not a positive number.

    Examples
    --------
    >>> text = to_mjcf(Robot(modules=2))
    >>> text.startswith('<mujoco model="bhr">'), text.count("<joint ")
    (True, 6)
    """
    n = robot.modules if modules is None else int(modules)
    if n < 1:
        raise BhrError(f"a robot needs at least one module, got {n}")
    out = [f'<mujoco model="{name}">',
           f"  <!-- bhr robot: {n} modules of {robot.module_length:g} mm, radius {robot.robot_radius:g} mm, "
           f"alpha {robot.alpha:g} deg, lift {robot.lift:g} mm; SI units; joints per docs/export.md -->",
           '  <compiler angle="radian" autolimits="true"/>',
           '  <option gravity="0 0 0"/>',
           "  <worldbody>"]
    out += mjcf_robot_body(robot, n, mass_g=mass_g, density=density)
    out += ["  </worldbody>", "</mujoco>", ""]
    return "\n".join(out)


def export_text(fmt: str, robot: Robot, modules: int | None = None, **mass: Any) -> str:
    """The robot in format ``fmt`` (``urdf`` or ``mjcf``)."""
    if fmt not in FORMATS:
        raise BhrError(f"unknown export format {fmt!r}; give one of {', '.join(FORMATS)}")
    return (to_urdf if fmt == "urdf" else to_mjcf)(robot, modules, **mass)
