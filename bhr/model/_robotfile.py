"""Robot description files (TOML or JSON, one schema): the robot, its code table and its hardware link.

``bhr ... --robot FILE`` reads one; options given on the command line
override its values. The documented default, with the thesis's values, ships
as ``bhr/data/robot.toml`` (:func:`default_robot_file`); docs/robot-files.md
describes every key.

>>> rf = load_robot_file(default_robot_file())
>>> rf.robot.modules, rf.robot.alpha, rf.link.baudrate
(5, 10.0, 115200)

Every mistake is a :class:`~bhr._settings.errors.BhrError` with one line naming the
file, the key, what is wrong and what is allowed.
"""
from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Sequence

from bhr._settings.inputs import check_input, check_keys, name_value, number, read_text, read_toml, text_value
from bhr._settings.inputs import type_name
from bhr.model._codes import CODE_AXIS, LIFT, REST, VALID_CODES
from bhr._settings.errors import BhrError
from bhr._settings.options import Underflow, by_group, excerpt, file_float, has_control_char, parse_number
from bhr.model._robot import Robot
from bhr.model._wires import DEFAULT_THERMAL, ThermalParams, thermal_from_table

__all__ = ["RobotFile", "LinkSettings", "load_robot_file", "default_robot_file", "code_table", "ROBOT_KEYS",
           "LINK_KEYS"]

HINT = "see docs/robot-files.md"

#: Robot keys of a robot file (the fields of :class:`bhr.model._robot.Robot`) with their checks, from
#: :mod:`bhr._settings.options`.
#: alpha's range (0, 90) is checked with its own message.
ROBOT_KEYS: dict[str, dict[str, Any]] = {
    o.name: {"integer": o.kind is int, "positive": o.positive, "nonneg": o.nonneg, "unit": o.unit,
            "maximum": None if o.maximum is None else o.limit}
    for o in by_group("robot")
}
LINK_KEYS = ("port", "baudrate", "module_order", "on_max_ms", "cooldown_ms", "silence_ms")
TOP_KEYS = ("name", "description", *ROBOT_KEYS, "codes", "link",
            "thermal", "mass")
#: Keys of the ``[mass]`` table (docs/export.md): one module's mass in grams, or its density in kg/m^3.
MASS_KEYS = ("module_mass", "density")
#: Limits the firmware accepts for its timing settings (firmware/src/config.h), ms.
TIMING_RANGE = (10, 60000)
#: Modules one board drives at most (firmware/src/config.h).
MAX_BOARD_MODULES = 32


def code_table() -> dict[int, str]:
    """bhr's code <-> motion table (bhr/codes.py): 0 rest, 3 +x, 6 +y, 12 -x, 9 -y, 15 lift."""
    out: dict[int, str] = {}
    for code in VALID_CODES:
        if code == REST:
            out[code] = "rest"
        elif code == LIFT:
            out[code] = "lift"
        else:
            axis, sign = CODE_AXIS[code]
            out[code] = ("+" if sign > 0 else "-") + "xy"[axis]
    return out


def _table_text() -> str:
    return ", ".join(f"{c} = {m!r}" for c, m in code_table().items())


@dataclass(frozen=True)
class LinkSettings:
    """The hardware link of a robot file's ``[link]`` table.

    ``port``: serial device or pyserial URL (None: not given; pass --port).
    ``baudrate``: UART speed (the firmware's ``BAUD``).
    ``module_order``: ``module_order[k-1]`` is the module (1 = base) wired to
    position ``k`` of the 74HC595 chain (position 1 = the low nibble of the chip
    nearest the microcontroller); the firmware's default wiring is 1, 2, ..., n.
    ``on_max_ms`` / ``cooldown_ms``: accepted for older files; the wires'
    limits are the robot file's ``[thermal]`` table (docs/thermal.md).
    ``silence_ms``: the board switches everything off when the host is silent
    this long (the firmware's ``SILENCE_MS``, docs/firmware.md).
    """

    port: str | None = None
    baudrate: int = 115200
    module_order: tuple[int, ...] = (1, 2, 3, 4, 5)
    on_max_ms: int = 5000
    cooldown_ms: int = 10000
    silence_ms: int = 1000

    @property
    def modules(self) -> int:
        """Modules the board drives (the length of the chain order)."""
        return len(self.module_order)

    def to_chain(self, codes: Sequence[int]) -> list[int]:
        """Codes in module order (base first) rearranged into chain order (position 1 first)."""
        if len(codes) != len(self.module_order):
            raise BhrError(f"expected {len(self.module_order)} codes (one per module), got {len(codes)}")
        return [int(codes[m - 1]) for m in self.module_order]

    def from_chain(self, chain: Sequence[int]) -> list[int]:
        """The inverse of :meth:`to_chain`: chain-order codes back in module order."""
        if len(chain) != len(self.module_order):
            raise BhrError(f"expected {len(self.module_order)} codes (one per chain position), got {len(chain)}")
        out = [0] * len(chain)
        for pos, m in enumerate(self.module_order):
            out[m - 1] = int(chain[pos])
        return out

    def firmware_make_args(self) -> list[str]:
        """``make`` variables that build firmware matching these settings (docs/firmware.md)."""
        return [f"MODULES={self.modules}", f"BAUD={self.baudrate}", f"SILENCE_MS={self.silence_ms}"]


@dataclass(frozen=True)
class RobotFile:
    """A parsed robot file: ``robot`` (:class:`bhr.model._robot.Robot`), ``link``, the code table, ``thermal``.

    ``thermal`` (:class:`bhr.model.ThermalParams`) is the actuator wire's
    thermal model from the ``[thermal]`` table (docs/thermal.md).
    Built by :func:`load_robot_file`.

    Parameters
    ----------
    robot : Robot
        The robot: modules, module length (mm), alpha (deg), disc radius (mm), tolerances (mm, deg).
    link : LinkSettings, optional
        The ``[link]`` table: serial port, baud rate, the order the modules are wired in, the board's
        silence timeout (ms).
    codes : dict of int to str, optional
        The ``[codes]`` table, code to motion: 0 ``"rest"``, 3 ``"+x"``, 6 ``"+y"``, 12 ``"-x"``, 9 ``"-y"``,
        15 ``"lift"`` (bhr's table, the default).
    name : str, optional
        The robot's name (the file's stem when not given).
    description : str, optional
        Free text about the robot.
    path : pathlib.Path, optional
        The file it was read from; None when built in Python.
    thermal : ThermalParams, optional
        The ``[thermal]`` table: the wire's figures (ms, duty); default the thesis's wires.
    mass : dict of str to float, optional
        The ``[mass]`` table (docs/export.md): ``module_mass`` (g) and/or ``density`` (kg/m^3), as given.
    """

    robot: Robot
    link: LinkSettings = field(default_factory=LinkSettings)
    codes: dict[int, str] = field(default_factory=code_table)
    name: str = ""
    description: str = ""
    path: Path | None = None
    thermal: ThermalParams = DEFAULT_THERMAL
    #: The ``[mass]`` table (docs/export.md): ``module_mass`` (g) and/or ``density`` (kg/m^3), as given.
    mass: dict[str, float] = field(default_factory=dict)


def default_robot_file() -> Path:
    """The documented default robot file shipped with bhr (the thesis's robot).

    Returns
    -------
    pathlib.Path
        The path of the shipped ``robot.toml``; copy it and edit it (docs/robot-files.md).
    """
    try:
        res = resources.files("bhr").joinpath("data", "robot.toml")
        if res.is_file():
            return Path(str(res))
    except (ModuleNotFoundError, FileNotFoundError):  # pragma: no cover
        pass
    here = Path(__file__).resolve().parents[1] / "data" / "robot.toml"
    if not here.is_file():  # pragma: no cover - broken installation
        raise BhrError("the default robot file bhr/data/robot.toml is missing; reinstall bhr")
    return here


def _check_codes(table: Any, where: str) -> dict[int, str]:
    w = f"{where}: codes"
    if not isinstance(table, dict):
        raise BhrError(f"{w} must be a table ([codes]) of code = \"motion\", got {type_name(table)}; "
                       f"bhr's table is {_table_text()}")
    ours = code_table()
    seen: dict[int, str] = {}
    for key, motion in table.items():
        try:
            code = int(parse_number(str(key), "code", integer=True))
        except BhrError:
            raise BhrError(f"{w}: key {excerpt(key)} is not a code number; bhr's table is {_table_text()}") from None
        if code not in ours:
            raise BhrError(f"{w}: {excerpt(code)} is not a stable code (only {', '.join(map(str, VALID_CODES))}); "
                           f"bhr's table is {_table_text()}")
        if not isinstance(motion, str):
            raise BhrError(f"{w}.{key} must be text such as {ours[code]!r}, got {type_name(motion)}")
        m = motion.strip().lower()
        if m != ours[code]:
            raise BhrError(f"{w}: code {code} is {excerpt(m)} in this file but {ours[code]!r} in bhr, which "
                           f"supports only its documented table ({_table_text()}; docs/conventions.md); fix the file "
                           "or the wiring")
        seen[code] = m
    missing = [c for c in ours if c not in seen]
    if missing:
        raise BhrError(f"{w}: code {missing[0]} is missing; a [codes] table must list all six: {_table_text()}")
    return ours


#: The pyserial URL schemes a robot file may name: they open nothing but the link itself. Other handlers
#: (spy://, hwgrep://, alt://, rfc2217://, cp2110://) write log files, search devices or load other
#: backends, so a file that names them would make bhr act rather than connect.
SAFE_PORT_SCHEMES = ("loop://", "socket://")
_COM_PORT = re.compile(r"^(\\\\\.\\)?COM[1-9][0-9]{0,2}$", re.IGNORECASE)


def check_file_port(port: str, where: str = "link.port") -> str:
    """A robot file's port: a serial device (``/dev/...``, ``COM3``) or a safe URL (loop://, socket://host:port).

    Anything else (pyserial's ``spy://`` logger, which writes to any file it is
    given, and the other URL handlers) is refused in one line. The command
    line's ``--port`` goes through the same check: a port names a wire, not an action.
    """
    if has_control_char(port):
        raise BhrError(f"{where} contains a control character; give a serial device such as /dev/ttyUSB0")
    if "://" in port:
        scheme = port.split("://", 1)[0].lower() + "://"
        rest = port.split("://", 1)[1]
        if scheme == "loop://" and rest in ("", "/"):
            return port
        if scheme == "socket://" and re.fullmatch(r"[A-Za-z0-9.\-]+:[0-9]{1,5}|\[[0-9A-Fa-f:]+\]:[0-9]{1,5}", rest):
            return port
        shown = port if len(port) <= 40 else port[:37] + "..."
        raise BhrError(f"{where} {shown!r} is not a serial port: give a device (/dev/ttyUSB0, COM3), loop:// or "
                       f"socket://host:port (URL handlers that log to files, scan or load backends are refused)")
    if _COM_PORT.match(port):
        return port
    norm = os.path.normpath(port)
    if port.startswith("/dev/") and norm.startswith("/dev/") and ".." not in port.split("/"):
        return port
    shown = port if len(port) <= 40 else port[:37] + "..."
    raise BhrError(f"{where} {shown!r} is not a serial device: give a path under /dev (/dev/ttyUSB0, /dev/pts/3), "
                   f"COM3, loop:// or socket://host:port")


def _check_link(table: Any, modules: int, where: str) -> LinkSettings:
    w = f"{where}: link"
    if not isinstance(table, dict):
        raise BhrError(f"{w} must be a table ([link]), got {type_name(table)}; {HINT}")
    check_keys(table, LINK_KEYS, w)
    out: dict[str, Any] = {}
    if "port" in table:
        port = text_value(table["port"], f"{w}.port").strip()
        out["port"] = port or None  # what it names is checked last (check_file_port)
    if "baudrate" in table:
        baud = number(table["baudrate"], f"{w}.baudrate", integer=True, positive=True)
        if not 50 <= baud <= 4_000_000:
            raise BhrError(f"{w}.baudrate must be between 50 and 4000000, got {baud}; the firmware uses 115200")
        out["baudrate"] = baud
    for key in ("on_max_ms", "cooldown_ms", "silence_ms"):
        if key in table:
            v = number(table[key], f"{w}.{key}", integer=True, positive=True, unit="ms")
            lo, hi = TIMING_RANGE
            if not lo <= v <= hi:
                raise BhrError(f"{w}.{key} must be between {lo} and {hi} ms (what the firmware accepts), got {v}")
            out[key] = v
    if "module_order" in table:
        order = table["module_order"]
        if not isinstance(order, list) or not order:
            raise BhrError(f"{w}.module_order must be a list of module numbers such as "
                           f"{list(range(1, modules + 1))}, got {type_name(order)}")
        vals = [number(v, f"{w}.module_order[{i}]", integer=True, positive=True) for i, v in enumerate(order)]
        if len(vals) != modules:
            raise BhrError(f"{w}.module_order lists {len(vals)} modules but the robot has {modules}; "
                           f"list each of 1..{modules} once")
        if sorted(vals) != list(range(1, modules + 1)):
            bad = next((v for v in vals if not 1 <= v <= modules), None)
            if bad is None:
                bad = next(v for v in vals if vals.count(v) > 1)
                what = f"module {bad} appears twice"
            else:
                what = f"there is no module {bad}"
            raise BhrError(f"{w}.module_order: {what}; list each of 1..{modules} once")
        out["module_order"] = tuple(vals)
    else:
        out["module_order"] = tuple(range(1, modules + 1))
    if len(out["module_order"]) > MAX_BOARD_MODULES:
        raise BhrError(f"{w}.module_order: one board drives at most {MAX_BOARD_MODULES} modules, "
                       f"got {len(out['module_order'])}")
    if out.get("port"):
        check_file_port(out["port"], f"{w}.port")
    return LinkSettings(**out)


#: Keys of a run.json's robot that follow from the others (not robot-file keys).
RUN_DERIVED_KEYS = ("feed", "min_turn_radius")


def read_json_robot(path: Path) -> dict[str, Any]:
    """The table of a JSON robot file, or the robot of a run (a ``run.json`` written by ``bhr follow``).

    A JSON robot file has the keys of a TOML one (the same checks follow). A run's robot is its
    ``robot`` object less what follows from the rest (``feed``, ``min_turn_radius``, an empty
    ``stroke``/``lever``, and ``alpha`` when stroke and lever give it).
    """
    import json

    hint = f"give a robot description such as {default_robot_file()} or a run.json written by 'bhr follow'"
    text = read_text(path, "robot file", hint)
    try:
        data = json.loads(text, parse_float=file_float)
    except Underflow as exc:
        raise BhrError(f"{path}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise BhrError(f"{path}: not valid JSON (line {exc.lineno}: {exc.msg}); {hint}") from None
    except (RecursionError, ValueError):
        raise BhrError(f"{path}: unreadable JSON; {hint}") from None
    if not isinstance(data, dict):
        raise BhrError(f"{path}: a robot file is a JSON object of keys such as modules and alpha, got "
                       f"{type_name(data)}; {HINT}")
    if "steps" in data and "trajectory" in data:  # a run: take its robot
        rb = data.get("robot")
        if not isinstance(rb, dict):
            raise BhrError(f"{path}: the run has no robot object; {hint}")
        rb = {k: v for k, v in rb.items() if k not in RUN_DERIVED_KEYS and v is not None}
        if "stroke" in rb and "lever" in rb:
            rb.pop("alpha", None)
        return rb
    return data


def load_robot_file(path: str | os.PathLike[str]) -> RobotFile:
    """Read and check a robot description file (TOML or JSON, one schema) or a run's robot (run.json).

    See docs/robot-files.md for the keys; every value is checked, and the first problem is one line naming
    the file and the key.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.toml`` or ``.json`` robot file, a run's ``run.json``, or a run's folder.

    Returns
    -------
    RobotFile
        The robot, its link, code table, thermal and mass tables, name and path.

    Raises
    ------
    BhrError
        A missing or unreadable file, an unknown key, or a value of the wrong type or out of range.

    Examples
    --------
    >>> from bhr.model._robotfile import default_robot_file
    >>> spec = load_robot_file(default_robot_file())   # the thesis's robot
    >>> spec.name, spec.robot.modules, spec.robot.module_length
    ('thesis', 5, 10.0)
    """
    p = Path(path)
    where = str(p)
    suffix = p.suffix.lower()
    hint = f"give a robot description such as {default_robot_file()}"
    # a folder, a device, a FIFO or an unreadable file is named as what it is, before its extension is judged;
    # an empty TOML file is the thesis's robot (every key has a default)
    check_input(p, "robot file", hint, empty_ok=True)
    if suffix not in (".toml", ".json"):
        raise BhrError(f"{where}: robot files are TOML (.toml) or JSON (.json), or a run.json; {HINT}")
    if suffix == ".json":
        data = read_json_robot(p)
    else:
        data = read_toml(p, "robot file", hint, empty_ok=True)
    check_keys(data, TOP_KEYS, where)
    name = name_value(data.get("name", p.stem), f"{where}: name")
    description = text_value(data.get("description", ""), f"{where}: description")
    fields_: dict[str, Any] = {}
    for key, rules in ROBOT_KEYS.items():
        if key in data:
            fields_[key] = number(data[key], f"{where}: {key}", **rules)
    has_sl = "stroke" in fields_ or "lever" in fields_
    if has_sl and "alpha" in fields_:
        raise BhrError(f"{where}: give alpha, or stroke and lever (alpha = asin(stroke/lever)), not both")
    if has_sl and not ("stroke" in fields_ and "lever" in fields_):
        missing = "lever" if "stroke" in fields_ else "stroke"
        raise BhrError(f"{where}: {missing} is missing; stroke and lever go together (alpha = asin(stroke/lever))")
    if "alpha" in fields_ and not 0.0 < fields_["alpha"] < 90.0:
        raise BhrError(f"{where}: alpha = {fields_['alpha']:g} deg is outside (0, 90); give an angle between "
                       "0 and 90 degrees, exclusive")
    if has_sl and fields_["stroke"] >= fields_["lever"]:
        raise BhrError(f"{where}: stroke {fields_['stroke']:g} mm must be shorter than lever {fields_['lever']:g} mm "
                       "(alpha = asin(stroke/lever))")
    try:
        robot = Robot(**fields_)
    except BhrError as exc:
        raise BhrError(f"{where}: {str(exc).splitlines()[0]}") from None
    if not math.isfinite(robot.min_turn_radius):  # pragma: no cover - alpha is checked above
        raise BhrError(f"{where}: alpha {robot.alpha} gives no turn radius; {HINT}")
    codes = _check_codes(data["codes"], where) if "codes" in data else code_table()
    if "link" in data:
        link = _check_link(data["link"], robot.modules, where)
    else:
        link = LinkSettings(module_order=tuple(range(1, robot.modules + 1)))
    thermal = thermal_from_table(data["thermal"], f"{where}: thermal") if "thermal" in data else DEFAULT_THERMAL
    mass: dict[str, float] = {}
    if "mass" in data:
        if not isinstance(data["mass"], dict):
            raise BhrError(f"{where}: mass must be a table ([mass]) with module_mass (g) or density (kg/m^3)")
        check_keys(data["mass"], MASS_KEYS, f"{where}: mass")
        mass = {k: float(number(v, f"{where}: mass.{k}", positive=True, maximum=1e6)) for k, v in data["mass"].items()}
    return RobotFile(robot, link, codes, name, description, p, thermal, mass)
