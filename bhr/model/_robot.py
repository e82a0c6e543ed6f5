"""The robot model: module geometry, actuator angle, and forward kinematics.

A BHR robot is a chain of ``n`` disc modules of length ``l``. Point 1 is the
base, point ``n+1`` the tip; module ``i`` joins points ``i`` and ``i+1``.
Between module ``i-1`` and module ``i`` the actuators of module ``i`` set a
tilt of 0 or alpha about one of two local axes (or a lift); see
:mod:`bhr.model._codes` for the code table and docs/conventions.md for the frames.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any, Sequence

from bhr._settings.inputs import did_you_mean
from bhr._settings.options import by_group, check_number, robot_limits
from bhr._settings.errors import BhrError

if TYPE_CHECKING:  # numpy and the kernels load when a pose is computed: a robot's settings are checked without them
    import numpy as np

__all__ = ["Robot", "THESIS_ROBOT", "CHAPTER5_ROBOT", "robot_with", "alpha_from_stroke", "min_turn_radius",
           "base_frame", "forward_kinematics", "straight_chain"]


def alpha_from_stroke(stroke: float, lever: float) -> float:
    """Actuator angle alpha in degrees from stroke h and lever L: asin(h/L) (Ec. 4.1).

    Parameters
    ----------
    stroke : float
        The wire's contraction h, mm (> 0).
    lever : float
        The lever L the wire pulls on, mm (> ``stroke``).

    Returns
    -------
    float
        The tilt alpha of one actuator pair, deg.

    Raises
    ------
    BhrError
        A length that is not positive, or a stroke not shorter than the lever.

    Examples
    --------
    >>> round(alpha_from_stroke(1.0, 5.76), 2)
    10.0
    """
    if not (stroke > 0 and lever > 0):
        raise BhrError("stroke and lever must both be positive lengths in mm")
    if stroke >= lever:
        raise BhrError(f"stroke {stroke} mm must be shorter than lever {lever} mm (alpha = asin(stroke/lever))")
    return math.degrees(math.asin(stroke / lever))


def min_turn_radius(module_length: float, alpha_deg: float) -> float:
    """Smallest radius the robot can follow: l / (2 tan(alpha/2)) (Ec. 7.1).

    Parameters
    ----------
    module_length : float
        The length l of one module, mm.
    alpha_deg : float
        The tilt alpha of one actuator pair, deg.

    Returns
    -------
    float
        The minimum turn radius, mm.

    Examples
    --------
    >>> round(min_turn_radius(10, 10), 2)
    57.15
    """
    return module_length / (2.0 * math.tan(math.radians(alpha_deg) / 2.0))


def _positive(name: str, value: Any, *, integer: bool = False) -> None:
    """The registry's one number check (:func:`bhr._settings.options.check_number`), greater than 0."""
    check_number(value, name, integer=integer, limit=1e300, positive=True)


@dataclass(frozen=True)
class Robot:
    """Geometry, actuator and tolerance settings of one robot design (frozen; :meth:`replace` makes a copy).

    Defaults are the thesis's trajectory-following robot (ch. 7): 5 head
    modules of 10 mm, radius 5 mm, alpha 10 deg, tolerances 8 mm and 20 deg,
    at most 30 iterations per point, feed = length / 5.

    Parameters
    ----------
    modules : int, default 5
        Modules the solver places (the head).
    module_length : float, default 10.0
        Length of one module in mm.
    robot_radius : float, default 5.0
        Disc radius in mm (``--robot-radius`` on the command line, ``robot_radius`` in files).
    alpha : float, default 10.0
        Tilt of one actuated joint in degrees (0 < alpha < 90); derived as asin(stroke / lever) when both are given.
    stroke, lever : float, optional
        Actuator stroke and lever in mm (Ec. 4.1).
    tol_pos, tol_ori : float, default 8.0 and 20.0
        Position (mm) and tip orientation (degrees) tolerances.
    max_iter : int, default 30
        Iterations per target.
    feed_divisor : int, default 5
        Steps per module length: the feed is ``module_length / feed_divisor`` mm.
    weight_pos, weight_ori : float, default 0.7 and 0.3
        Weights of the global error (ch. 5.2.3).
    """

    modules: int = 5
    module_length: float = 10.0
    robot_radius: float = 5.0
    alpha: float = 10.0
    stroke: float | None = None
    lever: float | None = None
    tol_pos: float = 8.0
    tol_ori: float = 20.0
    max_iter: int = 30
    feed_divisor: int = 5
    weight_pos: float = 0.7
    weight_ori: float = 0.3

    def __post_init__(self) -> None:
        _positive("modules", self.modules, integer=True)
        _positive("module length", self.module_length)
        _positive("robot radius", self.robot_radius)
        _positive("tol-pos", self.tol_pos)
        _positive("tol-ori", self.tol_ori)
        _positive("max-iter", self.max_iter, integer=True)
        _positive("feed divisor", self.feed_divisor, integer=True)
        if self.stroke is not None or self.lever is not None:
            if self.stroke is None or self.lever is None:
                raise BhrError("give both stroke and lever to derive alpha, or give alpha alone")
            _positive("stroke", self.stroke)
            _positive("lever", self.lever)
            object.__setattr__(self, "alpha", alpha_from_stroke(self.stroke, self.lever))
        _positive("alpha", self.alpha)
        if not 0.0 < self.alpha < 90.0:
            raise BhrError(f"alpha must be between 0 and 90 degrees (exclusive), got {self.alpha}")
        for name in ("weight_pos", "weight_ori"):
            check_number(getattr(self, name), name.replace("_", "-"), limit=1e300, nonneg=True)
        for key, (top, unit) in robot_limits().items():  # the registry's upper limits, wherever a robot comes from
            value = getattr(self, key, None)
            if value is not None and top is not None and value > top:
                u = f" {unit}" if unit else ""
                raise BhrError(f"{key.replace('_', ' ')} {value:g}{u} is too large; the limit is {top:g}{u}")
        object.__setattr__(self, "modules", int(self.modules))
        object.__setattr__(self, "max_iter", int(self.max_iter))
        object.__setattr__(self, "feed_divisor", int(self.feed_divisor))

    @property
    def feed(self) -> float:
        """Advance per trajectory step, module length / feed divisor (mm)."""
        return self.module_length / self.feed_divisor

    @property
    def min_turn_radius(self) -> float:
        """Smallest curve radius the robot can follow (mm), Ec. 7.1."""
        return min_turn_radius(self.module_length, self.alpha)

    @property
    def lift(self) -> float:
        """Extra length of a module whose next module is lifted (code 15), in mm.

        The actuator stroke when given; otherwise derived from alpha with a
        lever of one module diameter (``2 * robot_radius * sin(alpha)``).
        """
        if self.stroke is not None:
            return float(self.stroke)
        return 2.0 * self.robot_radius * math.sin(math.radians(self.alpha))

    def replace(self, **changes: Any) -> "Robot":
        """A copy with some fields changed (validated again).

        Giving ``alpha`` alone drops the stroke and lever it replaces.

        Parameters
        ----------
        **changes
            New values of the robot's fields (``modules``, ``module_length`` mm, ``alpha`` deg, ...).

        Returns
        -------
        Robot
            The changed robot (this one is frozen and left as it is).

        Raises
        ------
        BhrError
            An unknown field, or a value of the wrong type or out of range.

        Examples
        --------
        >>> Robot(modules=3).replace(modules=4)
        Robot(modules=4)
        """
        data = {f.name: getattr(self, f.name) for f in fields(self)}
        if "alpha" in changes and "stroke" not in changes:
            data["stroke"] = data["lever"] = None
        data.update(changes)
        return Robot(**data)

    def fk(self, codes: Sequence[int], base: Sequence[float] = (0, 0, 0),
           frame: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Points and module frames for one code per module (see :func:`forward_kinematics`).

        Parameters
        ----------
        codes : sequence of int, length n
            One valid code per module, base first (0, 3, 6, 9, 12, 15).
        base : sequence of 3 floats, default (0, 0, 0)
            The base point in mm.
        frame : ndarray, shape (3, 3), optional
            The base frame, rows x, y, z (z the direction of a straight chain); default along +X.

        Returns
        -------
        points : ndarray, shape (n+1, 3)
            Joint positions in mm, base first.
        frames : ndarray, shape (n, 3, 3)
            Each module's frame, rows x, y, z.

        Examples
        --------
        >>> pts, frames = Robot(modules=2).fk([0, 0])
        >>> pts[-1].tolist()
        [20.0, 0.0, 0.0]
        """
        return forward_kinematics(self, codes, base, frame)

    def to_dict(self) -> dict[str, Any]:
        """The robot as run.json, the report and the sweeps write it.

        Its fields (the option names of the registry, as on the command line and in robot files), then
        ``feed`` and ``min_turn_radius``.

        Returns
        -------
        dict of str to object
            Each field's name to its value (lengths mm, angles deg), then ``feed`` (mm) and
            ``min_turn_radius`` (mm).

        Examples
        --------
        >>> d = Robot().to_dict()
        >>> d["modules"], d["feed"], round(d["min_turn_radius"], 2)
        (5, 2.0, 57.15)
        """
        d = asdict(self)
        d["feed"] = self.feed
        d["min_turn_radius"] = self.min_turn_radius
        return d

    def __repr__(self) -> str:
        changed = [f"{f.name}={getattr(self, f.name)!r}" for f in fields(self)
                   if getattr(self, f.name) != f.default]
        return f"Robot({', '.join(changed)})"


#: The thesis's trajectory-following robot (ch. 7): 5 modules of 10 mm, alpha 10 deg; :func:`bhr.follow`'s default.
THESIS_ROBOT = Robot()
#: The chapter 5 chain: 5 modules of 2 mm, straight along +Y, position tolerance 0.01 mm, 30 iterations;
#: :func:`bhr.solve`'s and ``bhr solve``'s default.
CHAPTER5_ROBOT = Robot(modules=5, module_length=2.0, tol_pos=0.01, max_iter=30)

#: The registry's robot options by name (the Robot's fields).
_ROBOT_OPTIONS = {o.name: o for o in by_group("robot")}


def robot_with(robot: Robot | None, options: dict[str, Any], default: Robot = THESIS_ROBOT) -> Robot:
    """``robot`` (``default`` when None) with ``options`` changed, each checked by the option registry.

    An unknown name gets a did-you-mean; a value of the wrong type or out of
    range the registry's message (:class:`bhr._settings.errors.BhrError`).

    >>> robot_with(None, {"modules": 7}).modules
    7
    >>> robot_with(None, {"modles": 7})
    Traceback (most recent call last):
    ...
    bhr._settings.errors.BhrError: 'modles' is not a robot setting; did you mean 'modules'? robot settings: modules, \
module_length, robot_radius, alpha, stroke, lever, tol_pos, tol_ori, max_iter, feed_divisor, weight_pos, weight_ori
    """
    if robot is None:
        robot = default
    elif not isinstance(robot, Robot):
        raise BhrError(f"robot must be a bhr.Robot, got {type(robot).__name__}")
    if not options:
        return robot
    changes: dict[str, Any] = {}
    for name, value in options.items():
        opt = _ROBOT_OPTIONS.get(name)
        if opt is None:
            names = [o.name for o in by_group("robot")]
            raise BhrError(f"{name!r} is not a robot setting; {did_you_mean(name, list(_ROBOT_OPTIONS))}"
                           f"robot settings: {', '.join(names)}")
        changes[opt.name] = value if value is None else opt.check(value, "robot")
    return robot.replace(**changes)


def straight_chain(n: int, length: float, direction: Sequence[float] | np.ndarray,
                   origin: Sequence[float] | np.ndarray = (0, 0, 0),
                   tip_at_origin: bool = False) -> np.ndarray:
    """Points (n+1, 3) of a straight chain along ``direction``, base first.

    With ``tip_at_origin`` the tip sits at ``origin`` (the trajectory-following
    start); otherwise the base does (the chapter 5 experiments).
    """
    import numpy as np

    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    o = np.asarray(origin, dtype=np.float64)
    steps = np.arange(n + 1, dtype=np.float64)[:, None] * length
    if tip_at_origin:
        return o - (n * length) * d + steps * d
    return o + steps * d


def base_frame(direction: Sequence[float] | np.ndarray) -> np.ndarray:
    """A right-handed frame (rows x, y, z) whose z is ``direction``.

    For an axis-aligned direction the frame is the cyclic permutation of the
    world axes (z = +X gives x = +Y, y = +Z, as the thesis's robot along +X;
    z = +Y gives x = +Z, y = +X). In general x is the next world axis after the
    dominant one, made orthogonal to z.
    """
    import numpy as np

    z = np.asarray(direction, dtype=np.float64)
    nz = np.linalg.norm(z)
    if nz == 0 or not np.isfinite(nz):
        raise BhrError("direction must be a finite non-zero vector")
    z = z / nz
    k = int(np.argmax(np.abs(z)))
    ref = np.zeros(3)
    ref[(k + 1) % 3] = 1.0
    x = ref - np.dot(ref, z) * z
    x /= np.linalg.norm(x)
    y = [z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]]  # z x x, as np.cross
    return np.array([x, y, z])


def forward_kinematics(robot: Robot, codes: Sequence[int], base: Sequence[float] = (0, 0, 0),
                       frame: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points (n+1, 3) and module frames (n, 3, 3) of the chain for ``codes``.

    ``frame`` is the base frame (rows x, y, z; z the direction of a straight
    chain), default :func:`base_frame` of +X. Module ``i``'s frame is module
    ``i-1``'s (the base frame for ``i = 1``) rotated by alpha about its own
    local axis chosen by code ``i`` (3: +x, 6: +y, 12: -x, 9: -y); code 0 keeps
    it, code 15 keeps it and lengthens the module by :attr:`Robot.lift`.
    Module ``i`` runs from point ``i`` along its frame's z.

    Parameters
    ----------
    robot : Robot
        The robot: its ``modules`` n, ``module_length`` mm, ``alpha`` deg and lift mm.
    codes : sequence of int, shape (n,)
        One code per module, base first, each of :data:`bhr.model.VALID_CODES` (``docs/conventions.md``).
    base : sequence of float, shape (3,), default (0, 0, 0)
        The base point, mm.
    frame : numpy.ndarray, shape (3, 3), optional
        The base frame, rows x, y, z (unit vectors); default :func:`base_frame` of +X.

    Returns
    -------
    points : numpy.ndarray, shape (n+1, 3)
        The joints, base first, mm.
    frames : numpy.ndarray, shape (n, 3, 3)
        Each module's frame, rows x, y, z (unit vectors).

    Raises
    ------
    BhrError
        A code that is not valid, or not one code per module.

    Examples
    --------
    >>> points, frames = forward_kinematics(THESIS_ROBOT, [0, 0, 0, 0, 0])
    >>> points[-1].tolist(), frames.shape   # 5 straight modules of 10 mm along +X
    ([50.0, 0.0, 0.0], (5, 3, 3))
    """
    import numpy as np

    from bhr._kinematics.frames import fk_kernel
    from bhr.model._codes import check_codes

    codes_arr = np.asarray(check_codes(codes), dtype=np.int64)
    if codes_arr.shape[0] != robot.modules:
        raise BhrError(f"expected {robot.modules} codes (one per module), got {codes_arr.shape[0]}")
    fr = base_frame((1, 0, 0)) if frame is None else np.asarray(frame, dtype=np.float64)
    points = np.empty((robot.modules + 1, 3))
    frames = np.empty((robot.modules, 3, 3))
    fk_kernel(codes_arr, np.asarray(base, dtype=np.float64), fr, float(robot.module_length),
               float(robot.lift), float(robot.alpha), points, frames)
    return points, frames

