"""Trajectories: the thesis's generators (appendix 3) and trajectory files.

Built-in trajectories (``line``, ``curve``, ``spiral``, ``colon``) are TOML
files in the repository's ``trajectories/`` folder (installed as
``bhr.trajectories``); each names a generator and its parameters, which users
can copy and edit. Users' own paths are TOML files of segments (straight,
arc, helix) or CSV point lists such as a measured centerline, read by
:mod:`bhr.model._pathfile`. ``bhr.trajectory(name_or_path, **params)`` returns the
(N, 3) points, spaced by the feed; :func:`load_trajectory` the whole
:class:`Trajectory` (min radius, lumen, start). docs/trajectories.md describes
every format.

The generators port the printed MATLAB exactly, including its quirks (the
curve's entry straight stops one point short of ``entry``; the colon starts
one feed after the origin and its last straight reuses the descending
colon's length), because the published figures depend on them.
"""
from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Callable

import numpy as np

import bhr.model._pathfile as pathfile
from bhr._settings.options import check_number, did_you_mean, excerpt
from bhr._settings.inputs import check_input, check_keys, number, name_value, read_toml, text_value
from bhr._settings.errors import BhrError
from bhr.model._anatomy import anatomical_colon, check_seed
from bhr.model._pathfile import MAX_POINTS
from bhr.model._path import Trajectory, check_feed
import bhr.model._trajnames as trajnames

__all__ = ["Trajectory", "trajectory", "load_trajectory", "builtin_names", "GENERATORS",
           "line", "curve", "spiral", "colon", "anatomy", "anatomy_trajectory"]


def _mround(x: float) -> int:
    """MATLAB's round: halves away from zero."""
    return int(math.floor(x + 0.5)) if x >= 0 else -int(math.floor(-x + 0.5))


def line(feed: float, length: float = 70.0, azimuth: float = 0.0, elevation: float = 0.0) -> np.ndarray:
    """Straight line from the origin: ``length`` mm, ``azimuth`` (deg, from x in the
    xy-plane, counter-clockwise) and ``elevation`` (deg above the xy-plane)."""
    n = int(math.trunc(length / feed))
    if n < 1:
        raise BhrError(f"line length {length} mm is shorter than one feed ({feed} mm); make it longer")
    a1 = azimuth * 2 * math.pi / 360
    a2 = elevation * 2 * math.pi / 360
    i = np.arange(n + 1, dtype=np.float64)
    step = length / n
    x = i * (step * math.cos(a1) * math.cos(a2))
    y = np.zeros(n + 1) if a1 == 0 else i * (step * math.sin(a1) * math.cos(a2))
    z = np.zeros(n + 1) if a2 == 0 else i * (step * math.sin(a2))
    return np.stack([x, y, z], axis=1)


def spiral(feed: float, radius: float = 80.0, pitch: float = 40.0, turns: float = 2.0) -> np.ndarray:
    """Helix from the origin heading +x, turning clockwise seen from +z, rising ``pitch`` per turn."""
    ang = math.atan(pitch / (2 * math.pi * radius))
    n = int(math.trunc((turns * 2 * math.pi * radius / math.cos(ang)) / feed)) + 1
    pts = np.zeros((n, 3))
    for i in range(2, n + 1):
        t = (i - 1) / n
        pts[i - 1] = (radius * math.sin(turns * 2 * math.pi * t), radius * math.cos(turns * 2 * math.pi * t) - radius,
                      pitch * turns * t)
    return pts


def curve(feed: float, radius: float = 70.0, angle: float = 90.0, entry: float = 30.0,
          exit: float = 30.0) -> np.ndarray:
    """Entry straight along +x, clockwise arc of ``radius`` turning ``angle`` deg, exit straight."""
    ang = angle * 2 * math.pi / 360
    total = exit + entry + ang * radius
    n = int(math.trunc(total / feed)) + 1
    n1 = _mround(n * (entry / total))
    n2 = _mround(n * (ang * radius / total))
    n3 = n - (n1 + n2)
    if n1 < 1 or n2 < 1 or n3 < 1:
        raise BhrError("curve too short for the feed: entry, arc and exit need at least one point each; "
                       "lengthen them or lower the feed")
    x = np.zeros(n)
    y = np.zeros(n)
    for i in range(1, n1 + 1):
        x[i - 1] = entry * (i - 1) / n1
    for i in range(n1 + 1, n1 + n2 + 1):
        x[i - 1] = x[n1 - 1] + radius * math.sin(ang * ((i - n1) / n2))
        y[i - 1] = radius * math.cos(ang * ((i - n1) / n2)) - radius
    for i in range(n1 + n2 + 1, n + 1):
        x[i - 1] = x[n1 + n2 - 1] + math.cos(ang) * exit * (i - n1 - n2) / n3
        y[i - 1] = y[n1 + n2 - 1] - math.sin(ang) * exit * (i - n1 - n2) / n3
    return np.stack([x, y, np.zeros(n)], axis=1)


#: Sections of the printed colon generator, in order.
COLON_SECTIONS = ("rectum", "bend 1", "sigmoid", "bend 2", "descending", "bend 3", "transverse", "bend 4", "ascending")


def colon(feed: float, section_index: list[int] | None = None) -> np.ndarray:
    """The printed planar large intestine (appendix 3, case 4).

    Straights of 40 (rectum), 155 (sigmoid), 320 (descending), 380
    (transverse) and again 320 mm (the printed code reuses the descending
    length for the ascending colon), joined by 90 deg bends of 70 mm radius.
    If ``section_index`` is a list, it receives each point's section number
    (an index into :data:`COLON_SECTIONS`).
    """
    r1 = r2 = 70.0
    lrecto, lcsig, lcdesc, lctras, lcasc = 40.0, 155.0, 320.0, 380.0, 300.0
    total = lrecto + lcsig + lcdesc + lctras + lcasc + 0.75 * 2 * math.pi * r2 + 0.25 * 2 * math.pi * r1
    n = int(math.trunc(total / feed))
    quarter2 = 0.25 * 2 * math.pi * r2
    n1 = _mround(lrecto / total * n)
    n2 = _mround(0.25 * 2 * math.pi * r1 / total * n)
    n3 = _mround(lcsig / total * n)
    n4 = _mround(quarter2 / total * n)
    n5 = _mround(lcdesc / total * n)
    n6 = _mround(quarter2 / total * n)
    n7 = _mround(lctras / total * n)
    n8 = _mround(quarter2 / total * n)
    n9 = n - n1 - n2 - n3 - n4 - n5 - n6 - n7 - n8 + 10
    m = n + 10
    x = np.zeros(m)
    y = np.zeros(m)
    sec = np.zeros(m, dtype=np.int64)
    e = np.cumsum([n1, n2, n3, n4, n5, n6, n7, n8])
    for i in range(1, n1 + 1):
        x[i - 1] = lrecto * i / n1
    s = e[0]
    for i in range(s + 1, e[1] + 1):
        t = (math.pi / 2) * ((i - s) / n2)
        x[i - 1] = x[s - 1] + r1 * math.sin(t)
        y[i - 1] = r1 * math.cos(t) - r1
    s = e[1]
    for i in range(s + 1, e[2] + 1):
        x[i - 1] = x[s - 1]
        y[i - 1] = y[s - 1] - lcsig * ((i - s) / n3)
    s = e[2]
    for i in range(s + 1, e[3] + 1):
        t = 1.5 * math.pi + (math.pi / 2) * ((i - s) / n4)
        x[i - 1] = x[s - 1] + r2 * math.sin(t) + r2
        y[i - 1] = y[s - 1] - r2 * math.cos(t)
    s = e[3]
    for i in range(s + 1, e[4] + 1):
        x[i - 1] = x[s - 1] + lcdesc * ((i - s) / n5)
        y[i - 1] = y[s - 1]
    s = e[4]
    for i in range(s + 1, e[5] + 1):
        t = (math.pi / 2) * ((i - s) / n6)
        x[i - 1] = x[s - 1] + r2 * math.sin(t)
        y[i - 1] = y[s - 1] - r2 * math.cos(t) + r2
    s = e[5]
    for i in range(s + 1, e[6] + 1):
        x[i - 1] = x[s - 1]
        y[i - 1] = y[s - 1] + lctras * ((i - s) / n7)
    s = e[6]
    for i in range(s + 1, e[7] + 1):
        t = 1.5 * math.pi + (math.pi / 2) * ((i - s) / n8)
        x[i - 1] = x[s - 1] - r2 * math.sin(t) - r2
        y[i - 1] = y[s - 1] + r2 * math.cos(t)
    s = e[7]
    for i in range(s, m + 1):
        x[i - 1] = x[s - 1] - lcdesc * ((i - s) / n9)
        y[i - 1] = y[s - 1]
    bounds = [0, *e.tolist(), m]
    for k in range(9):
        sec[bounds[k]:bounds[k + 1]] = k
    if section_index is not None:
        section_index[:] = sec.tolist()
    return np.stack([x, y, np.zeros(m)], axis=1)


def anatomy(feed: float, seed: float = 1) -> np.ndarray:
    """An anatomical colon (anus to cecum) drawn from ``seed``: see :mod:`bhr.model._anatomy`."""
    return anatomical_colon(check_seed(seed)).sample(feed)[0]


@dataclass(frozen=True)
class Generator:
    func: Callable[..., np.ndarray]
    params: dict[str, float]
    min_radius: Callable[[dict[str, float]], float]
    doc: str
    #: Builds the whole Trajectory (lumen, start, exact min radius) when the points alone are not enough.
    build: Callable[[dict[str, float], float, str], "Trajectory"] | None = None


def anatomy_trajectory(seed: Any, feed: float = 2.0, where: str = "anatomy") -> "Trajectory":
    """The anatomical colon of ``seed`` (:mod:`bhr.model._anatomy`) as a Trajectory: points ``feed`` mm apart along
    the centerline from the anus, the lumen diameter at each, the exact smallest bend radius, and the start
    (the anus, heading up the anal canal)."""
    s = check_seed(seed, where)
    colon_ = anatomical_colon(s)
    pts, lumen, _ = colon_.sample(feed)
    return Trajectory(f"anatomy-{s}", pts, {"seed": s, "length": colon_.length}, colon_.min_radius, lumen, where,
                      tuple(float(v) for v in colon_.start_heading), (0.0, 0.0, 0.0))


def _anatomy_build(p: dict[str, float], feed: float, where: str) -> "Trajectory":
    return anatomy_trajectory(p["seed"], feed, where)


def _anatomy_min_radius(p: dict[str, float]) -> float:
    return anatomical_colon(check_seed(p["seed"])).min_radius


GENERATORS: dict[str, Generator] = {
    "line": Generator(line, {"length": 70.0, "azimuth": 0.0, "elevation": 0.0}, lambda p: math.inf,
                      "straight line: --length mm, --azimuth deg, --elevation deg"),
    "curve": Generator(curve, {"radius": 70.0, "angle": 90.0, "entry": 30.0, "exit": 30.0},
                       lambda p: p["radius"], "clockwise curve: --radius mm, --angle deg, --entry mm, --exit mm"),
    "spiral": Generator(spiral, {"radius": 80.0, "pitch": 40.0, "turns": 2.0},
                        lambda p: p["radius"] + (p["pitch"] / (2 * math.pi)) ** 2 / p["radius"],
                        "helix: --radius mm, --pitch mm per turn, --turns"),
    "colon": Generator(colon, {}, lambda p: 70.0, "the thesis's printed planar large intestine (no parameters)"),
    "anatomy": Generator(anatomy, {"seed": 1.0}, _anatomy_min_radius,
                         "anatomical 3-D colon, anus to cecum, with its lumen: --seed N (docs/anatomy.md)",
                         _anatomy_build),
}

_POSITIVE = {"length", "radius", "angle", "pitch", "turns"}
_NONNEG = {"entry", "exit"}
_WHOLE = {"seed"}


def _check_params(gen_name: str, params: dict[str, Any], where: str) -> dict[str, float]:
    gen = GENERATORS[gen_name]
    out = dict(gen.params)
    for key, value in params.items():
        if value is None:
            continue
        if key not in gen.params:
            allowed = ", ".join(gen.params) or "none"
            raise BhrError(f"{where}: the {gen_name} trajectory has no parameter {excerpt(key)}; "
                           f"{did_you_mean(key, gen.params)}allowed: {allowed}")
        if key in _WHOLE:
            check_seed(value, where)
        out[key] = float(check_number(value, f"{where}: {key}", limit=2.0**32 if key in _WHOLE else 1e6,
                                      positive=key in _POSITIVE, nonneg=key in _NONNEG))  # the one checker
    return out


def _generator_length(gen_name: str, p: dict[str, float]) -> float:
    """Length (mm) of the path a generator will draw, to refuse absurd sizes before drawing it."""
    if gen_name == "line":
        return p["length"]
    if gen_name == "curve":
        return p["entry"] + p["exit"] + math.radians(p["angle"]) * p["radius"]
    if gen_name == "spiral":
        return p["turns"] * math.hypot(2 * math.pi * p["radius"], p["pitch"])
    return 2000.0


def builtin_names() -> list[str]:
    """Names ``load_trajectory`` knows: the generators, then the shipped point files (trajectories/NAME.csv).

    Returns
    -------
    list of str
        The generators' names (``"line"``, ``"curve"``, ...), then the shipped files' names.

    Examples
    --------
    >>> builtin_names()[:3]
    ['line', 'curve', 'spiral']
    """
    return trajnames.builtin_names()


def _builtin_csvs() -> dict[str, Path]:
    return trajnames.shipped_csvs()


def _builtin_file(name: str) -> Path | None:
    try:
        res = resources.files("bhr.trajectories").joinpath(f"{name}.toml")
    except ModuleNotFoundError:
        res = None
    if res is not None and res.is_file():
        return Path(str(res))
    repo = Path(__file__).resolve().parents[2] / "trajectories" / f"{name}.toml"
    return repo if repo.is_file() else None


def load_trajectory(name_or_path: str | os.PathLike[str], feed: float = 2.0, **params: Any) -> Trajectory:
    """A built-in trajectory by name, or a trajectory file (.toml or .csv), with ``params`` overriding its values.

    ``params`` (the generator parameters, e.g. ``radius``) apply to built-ins
    and generator files only; segment and CSV files refuse them. Raises
    :class:`BhrError` with one line naming the file and the problem.

    Parameters
    ----------
    name_or_path : str or os.PathLike
        A built-in's name (:func:`builtin_names`) or the path of a trajectory file (.toml or .csv).
    feed : float, default 2.0
        The spacing of the points, mm (the robot's ``module_length / feed_divisor``).
    **params
        The generator's parameters (e.g. ``radius`` mm, ``angle`` deg, ``seed``); also ``lumen_end``
        (``"closed"`` or ``"open"``) and ``lumen_model`` (``"ct"`` or ``"insufflated"``) for any path with a
        lumen.

    Returns
    -------
    Trajectory
        Points (N, 3) mm, ``feed`` mm apart, with the path's lumen (N,) mm when it has one; it can be drawn
        again at another feed (:meth:`Trajectory.at_feed`).

    Raises
    ------
    BhrError
        An unknown name, a file that cannot be read, a parameter the path does not take or out of range, a
        feed that is not a positive number.

    Examples
    --------
    >>> load_trajectory("curve", feed=1.0, radius=70)
    Trajectory('curve', 170 points, feed 1 mm, 169 mm long)
    """
    feed = check_feed(feed)
    end = params.pop("lumen_end", None)
    if end is not None and end not in ("closed", "open"):
        raise BhrError(f"lumen_end must be closed or open, got {excerpt(end)}")
    model = params.pop("lumen_model", None)
    if model is not None and model not in ("ct", "insufflated"):
        raise BhrError(f"lumen_model must be ct or insufflated, got {excerpt(model)}")
    traj = _load(name_or_path, float(feed), params)
    if end is not None:
        traj.lumen_end = str(end)
    if model == "insufflated":
        from bhr.model._insufflation import insufflated_lumen

        if traj.lumen is None:
            raise BhrError(f"trajectory {excerpt(str(name_or_path))} has no lumen to insufflate; use --lumen-model ct")
        traj.lumen, k = insufflated_lumen(traj.lumen, traj.sections, float(feed))
        traj.lumen_model = "insufflated"
        traj.params = {**traj.params, "lumen_model": "insufflated", "insufflation_scale": k}
        traj.mesh = None  # the CT surface is not the insufflated wall
    traj.feed = float(feed)
    traj.redraw = functools.partial(load_trajectory, name_or_path, **params,
                                    **({} if end is None else {"lumen_end": end}),
                                    **({} if model is None else {"lumen_model": model}))
    return traj


def _load(name_or_path: str | os.PathLike[str], feed: float, params: dict[str, Any]) -> Trajectory:
    key = str(name_or_path)
    if not key:  # Path("") is the current folder: "--traj ''" was named "."
        raise BhrError(f"the trajectory name is empty; give a built-in ({', '.join(trajnames.builtin_names())}) "
                       "or a .toml/.csv file")
    if key in GENERATORS:
        path = _builtin_file(key)
        if path is None:  # the data file is missing: fall back to the generator's defaults
            return _from_generator(key, {}, params, feed, f"built-in {key}")
        return _from_file(path, feed, params, builtin=True)
    p = Path(key)
    if not p.exists():
        shipped = _builtin_csvs().get(key) or trajnames.real_colons().get(key)
        if shipped is not None:
            traj = _from_file(shipped, feed, params, builtin=True)
            traj.name = key
            return traj
        trajnames.check_trajectory_name(key)
    return _from_file(p, feed, params, builtin=False)


def _from_generator(gen_name: str, file_params: dict[str, Any], cli_params: dict[str, Any], feed: float,
                    where: str) -> Trajectory:
    merged = dict(file_params)
    merged.update({k: v for k, v in cli_params.items() if v is not None})
    p = _check_params(gen_name, merged, where)
    gen = GENERATORS[gen_name]
    count = _generator_length(gen_name, p) / feed
    if count > MAX_POINTS:
        least = math.ceil(count * feed / MAX_POINTS * 1e4) / 1e4  # rounded up: the feed that fits
        raise BhrError(f"{where}: the {gen_name} is {count * feed:g} mm long, {count:.0f} points at a feed of "
                       f"{feed:g} mm (limit {MAX_POINTS}); make it shorter, or raise the feed (the module length "
                       f"divided by the feed divisor) to at least {least:g} mm")
    if gen.build is not None:
        return gen.build(p, feed, where)
    pts = gen.func(feed, **p)
    return Trajectory(gen_name, pts, p, gen.min_radius(p), None, where)


#: Generators whose points fall into named sections (a generator file's [lumen] table may name them).
SECTIONS: dict[str, tuple[str, ...]] = {"colon": COLON_SECTIONS}
_GENERATOR_KEYS = ("name", "description", "generator", "params", "lumen")
_HINT = "see docs/trajectories.md"


def _generator_lumen(spec: Any, gen_name: str, traj: Trajectory, feed: float, where: str) -> np.ndarray:
    """Lumen diameter per point from a generator file's ``lumen``: one number, or a table per section."""
    n = traj.points.shape[0]
    if not isinstance(spec, dict):
        return np.full(n, number(spec, f"{where}: lumen", positive=True, unit="mm", maximum=1e6))
    names = SECTIONS.get(gen_name)
    if names is None:
        raise BhrError(f"{where}: lumen of the {gen_name} trajectory must be one diameter in mm, got a table "
                       f"(only {', '.join(SECTIONS)} has sections)")
    for key in spec:
        if key not in names:
            raise BhrError(f"{where}: lumen: unknown section {excerpt(key)}; sections: {', '.join(names)}")
    missing = [k for k in names if k not in spec]
    if missing:
        raise BhrError(f"{where}: lumen: no diameter for section {excerpt(missing[0])}; "
                       f"give every section: {', '.join(names)}")
    per = np.array([number(spec[k], f"{where}: lumen.{k!r}" if " " in k else f"{where}: lumen.{k}",
                           positive=True, unit="mm", maximum=1e6) for k in names])
    index: list[int] = []
    if gen_name == "colon":
        colon(feed, section_index=index)
    if len(index) != n:  # pragma: no cover - the generators keep these in step
        raise BhrError(f"{where}: internal error: {len(index)} section labels for {n} points")
    return per[np.asarray(index, dtype=np.int64)]


def _from_file(path: Path, feed: float, params: dict[str, Any], builtin: bool) -> Trajectory:
    """A trajectory file: TOML (a generator and its parameters, or segments) or CSV (points)."""
    suffix = path.suffix.lower()
    # a folder or a device is named as one, whatever its extension
    check_input(path, "trajectory file", f"give a .toml (a generator or segments) or .csv (points) file; {_HINT}")
    if suffix not in (".toml", ".csv"):
        raise BhrError(f"{path}: trajectory files are .toml (a generator or segments) or .csv (points); {_HINT}")
    given = {k: v for k, v in params.items() if v is not None}
    if suffix == ".csv":
        if given:
            raise BhrError(f"{path}: --{next(iter(given))} applies to generator trajectories only; "
                           "a CSV's points are used as they are")
        return pathfile.csv_trajectory(path, feed)
    data = read_toml(path, "trajectory file", _HINT)
    if "generator" not in data:
        if "segment" in data:
            if given:
                raise BhrError(f"{path}: --{next(iter(given))} applies to generator trajectories only; "
                               "edit the segments in the file instead")
            return pathfile.segments_trajectory(data, path, feed)
        raise BhrError(f"{path}: neither generator = \"NAME\" nor [[segment]] tables; give one of them ({_HINT})")
    if "segment" in data:
        raise BhrError(f"{path}: give either generator = ... or [[segment]] tables, not both")
    check_keys(data, _GENERATOR_KEYS, str(path))
    gen_name = data.get("generator")
    if not isinstance(gen_name, str) or gen_name not in GENERATORS:
        raise BhrError(f"{path}: generator must be one of {', '.join(repr(g) for g in GENERATORS)}, "
                       f"got {excerpt(gen_name)}")
    file_params = data.get("params", {})
    if not isinstance(file_params, dict):
        raise BhrError(f"{path}: params must be a table ([params]) of numbers")
    traj = _from_generator(gen_name, file_params, params, feed, f"trajectory {path.stem}" if builtin else str(path))
    traj.name = name_value(data.get("name", path.stem), f"{path}: name")
    if gen_name == "anatomy":  # one file, many colons: the name says which
        traj.name = f"{traj.name}-{traj.params['seed']}"
    if "description" in data:
        text_value(data["description"], f"{path}: description")
    traj.source = str(path)
    if "lumen" in data:
        traj.lumen = _generator_lumen(data["lumen"], gen_name, traj, feed, str(path))
    return traj


def trajectory(name_or_path: str | os.PathLike[str], feed: float = 2.0, **params: Any) -> Trajectory:
    """A built-in trajectory or trajectory file, its points spaced by ``feed`` mm (the thesis robot's feed).

    Parameters
    ----------
    name_or_path : str or path
        A generator (``line``, ``curve``, ``spiral``, ``colon``, ``anatomy``), a shipped colon, or a trajectory
        file (``.toml`` segments or ``.csv`` points, docs/trajectories.md).
    feed : float, default 2.0
        Spacing of the points in mm (the robot's advance per step; the thesis robot's is 2 mm).
    **params
        The generator's parameters (``length``, ``radius``, ``angle``, ``seed`` ...; docs/trajectories.md), or
        ``lumen_end`` (``closed``, ``open``).

    Returns
    -------
    Trajectory
        ``points`` (N, 3) in mm, start first; ``feed`` in mm; ``lumen`` (N,) diameters in mm, or None. It reads as
        the (N, 3) points wherever numpy expects an array. :func:`bhr.follow` draws it again at the robot's feed when
        that differs.

    Examples
    --------
    >>> t = trajectory("line", length=10)
    >>> t.shape, t.feed
    ((6, 3), 2.0)
    >>> trajectory("anatomy", seed=7).lumen is not None
    True
    """
    return load_trajectory(name_or_path, feed=feed, **params)


