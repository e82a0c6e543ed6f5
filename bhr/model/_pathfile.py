"""Trajectory files made of segments (TOML) or of measured points (CSV).

Both are documented in docs/trajectories.md; :func:`bhr.model._generators.load_trajectory`
calls :func:`segments_trajectory` and :func:`csv_trajectory` by file type.

* A segment file lists ``[[segment]]`` tables (``straight``, ``arc``,
  ``helix``) that are joined tangent to tangent, starting at ``start`` and
  heading along ``heading``. The path is sampled every ``feed`` mm of arc
  length, so its points are spaced by the feed; ``min_radius`` is the exact
  smallest radius of curvature (an arc's radius, a helix's R + (p/2pi)^2/R).
* A CSV file lists points ``x,y,z`` (and optionally ``lumen``, a diameter in
  mm) along a centerline, e.g. from CT. The polyline through them is
  resampled so that consecutive points are one ``feed`` apart along it
  (:func:`resample_polyline`); ``min_radius`` is estimated with a cubic
  least-squares (Savitzky-Golay) fit over +-15 mm of the resampled path
  around each point, which averages measurement noise away
  (:func:`estimate_min_radius`).

In both, the remainder of the path shorter than one feed is dropped, so
every step of the robot (which advances exactly one feed) has a target.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bhr._settings.inputs import (MAX_MM, MAX_POINTS, check_keys, choice, name_value, number, read_text, text_value,
                                 type_name, vector3)
from bhr._settings.errors import BhrError
from bhr._settings.options import LIMITS, MAX_NUMBER_CHARS, MIN_MAGNITUDE, excerpt
from bhr.model._path import Trajectory, resample_polyline, runs_of

__all__ = ["segments_trajectory", "csv_trajectory", "resample_polyline", "estimate_min_radius",
           "MAX_POINTS", "CURVATURE_WINDOW_MM", "SEGMENT_KEYS"]

#: Half-width (mm of arc length) of the window over which CSV curvature is fitted.
CURVATURE_WINDOW_MM = 15.0

TOP_KEYS = ("name", "description", "start", "heading", "up", "lumen", "lumen_end", "segment")
#: How a lumen may end past its last point (docs/trajectories.md): a blind end (the default) or open.
LUMEN_ENDS = ("closed", "open")
_END_LINE = re.compile(r"^#\s*lumen_end\s*[=:]\s*\"?([A-Za-z]+)\"?\s*$")
SEGMENT_KEYS = {
    "straight": ("type", "length", "roll", "lumen"),
    "arc": ("type", "radius", "angle", "turn", "roll", "lumen"),
    "helix": ("type", "radius", "pitch", "turns", "turn", "roll", "lumen"),
}
ARC_TURNS = ("left", "right", "up", "down")
HELIX_TURNS = ("left", "right")
HINT_TOML = "see docs/trajectories.md"
HINT_CSV = "give a CSV with a header x,y,z (optional lumen) and one point per line; see docs/trajectories.md"


def unit_vector(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def rotate_about(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotate ``v`` by ``angle`` rad right-handedly about the unit ``axis`` (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * float(np.dot(axis, v)) * (1.0 - c)


@dataclass
class _Piece:
    """One sampled segment: length, a function of local arc length, radius of curvature, lumen."""

    length: float
    at: Callable[[np.ndarray], np.ndarray]
    radius: float
    lumen: float | None


def _build_pieces(segs: list[Any], start: np.ndarray, heading: np.ndarray, up: np.ndarray, default_lumen: float | None,
                  where: str) -> tuple[list[_Piece], np.ndarray]:
    """Walk the segments with a moving frame (t heading, u up); return the pieces and the end point."""
    p, t, u = start.astype(np.float64), heading.astype(np.float64), up.astype(np.float64)
    pieces: list[_Piece] = []
    for k, seg in enumerate(segs, start=1):
        w = f"{where}: segment {k}"
        if not isinstance(seg, dict):
            raise BhrError(f"{w} must be a table ([[segment]]), got {type_name(seg)}")
        if "type" not in seg:
            raise BhrError(f"{w} has no type; add type = \"straight\", \"arc\" or \"helix\"")
        kind = choice(seg["type"], f"{w}: type", SEGMENT_KEYS)
        w = f"{where}: segment {k} ({kind})"
        check_keys(seg, SEGMENT_KEYS[kind], w)
        for req in SEGMENT_KEYS[kind][1:]:
            if req not in ("roll", "lumen") and req not in seg:
                raise BhrError(f"{w} needs {req}; allowed keys: {', '.join(SEGMENT_KEYS[kind])}")
        lumen = default_lumen
        if "lumen" in seg:
            lumen = number(seg["lumen"], f"{w}: lumen", positive=True, unit="mm", maximum=MAX_MM)
        if "roll" in seg:
            roll = number(seg["roll"], f"{w}: roll", unit="deg", maximum=36000.0)
            u = rotate_about(u, t, math.radians(roll))
        p0, t0, u0 = p.copy(), t.copy(), u.copy()
        if kind == "straight":
            length = number(seg["length"], f"{w}: length", positive=True, unit="mm", maximum=MAX_MM)
            pieces.append(_Piece(length, lambda s, p0=p0, t0=t0: p0 + s[:, None] * t0, math.inf, lumen))  # type: ignore[misc]
            p = p0 + length * t0
        elif kind == "arc":
            r = number(seg["radius"], f"{w}: radius", positive=True, unit="mm", maximum=MAX_MM)
            ang = number(seg["angle"], f"{w}: angle", positive=True, unit="deg", maximum=36000.0)
            turn = choice(seg["turn"], f"{w}: turn", ARC_TURNS)
            left = np.cross(u0, t0)
            d = {"left": left, "right": -left, "up": u0, "down": -u0}[turn]
            theta = math.radians(ang)
            length = r * theta
            pieces.append(_Piece(length, lambda s, p0=p0, t0=t0, d=d, r=r:  # type: ignore[misc]
                                 p0 + (r * np.sin(s / r))[:, None] * t0 + (r * (1.0 - np.cos(s / r)))[:, None] * d,
                                 r, lumen))
            axis = unit_vector(np.cross(t0, d))
            p = p0 + r * math.sin(theta) * t0 + r * (1.0 - math.cos(theta)) * d
            t, u = unit_vector(rotate_about(t0, axis, theta)), unit_vector(rotate_about(u0, axis, theta))
        else:  # helix, tangent to the current heading, winding about an axis tilted forward from `up`
            r = number(seg["radius"], f"{w}: radius", positive=True, unit="mm", maximum=MAX_MM)
            pitch = number(seg["pitch"], f"{w}: pitch", positive=True, unit="mm per turn", maximum=MAX_MM)
            turns = number(seg["turns"], f"{w}: turns", positive=True, maximum=1000.0)
            turn = choice(seg["turn"], f"{w}: turn", HELIX_TURNS)
            sigma = 1.0 if turn == "left" else -1.0
            beta = math.atan2(pitch, 2.0 * math.pi * r)
            cb, sb = math.cos(beta), math.sin(beta)
            axis = sb * t0 + cb * u0
            h = cb * t0 - sb * u0
            n0 = -sigma * np.cross(u0, t0)
            rise = pitch / (2.0 * math.pi)
            per_rad = r / cb  # arc length per radian of winding
            phi_end = 2.0 * math.pi * turns
            length = phi_end * per_rad

            def at(s, p0=p0, n0=n0, h=h, axis=axis, r=r, rise=rise, per_rad=per_rad):
                phi = s / per_rad
                return (p0 + (r * (np.cos(phi) - 1.0))[:, None] * n0 + (r * np.sin(phi))[:, None] * h
                        + (rise * phi)[:, None] * axis)

            pieces.append(_Piece(length, at, r + rise * rise / r, lumen))
            p = at(np.array([length]))[0]
            t = unit_vector(rotate_about(t0, axis, sigma * phi_end))
            u = unit_vector(rotate_about(u0, axis, sigma * phi_end))
        u = unit_vector(u - np.dot(u, t) * t)  # keep the frame orthonormal against rounding
        if not (np.all(np.isfinite(p)) and math.isfinite(pieces[-1].length)):
            raise BhrError(f"{w}: its numbers are too large to compute; use lengths and radii in mm")
    return pieces, p


def _sample(pieces: list[_Piece], feed: float, where: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Points every ``feed`` mm along the joined pieces, and the lumen of each (None if no piece has one)."""
    lengths = np.array([pc.length for pc in pieces])
    total = float(lengths.sum())
    if not math.isfinite(total):
        raise BhrError(f"{where}: the path is too long to sample; use lengths in mm")
    count = int(math.floor(total / feed + 1e-9)) + 1
    if count < 2:
        raise BhrError(f"{where}: the path is {total:g} mm long, shorter than one feed ({feed:g} mm); make it longer")
    if count > MAX_POINTS:
        raise BhrError(f"{where}: the path is {total:g} mm long, {count} points at a feed of {feed:g} mm "
                       f"(limit {MAX_POINTS}); shorten it or raise the feed")
    s = np.arange(count, dtype=np.float64) * feed
    ends = np.cumsum(lengths)
    idx = np.minimum(np.searchsorted(ends, s, side="right"), len(pieces) - 1)
    pts = np.empty((count, 3))
    starts = ends - lengths
    for k, pc in enumerate(pieces):
        sel = idx == k
        if np.any(sel):
            pts[sel] = pc.at(np.minimum(s[sel] - starts[k], pc.length))
    have = [pc.lumen is not None for pc in pieces]
    if not any(have):
        return pts, None
    if not all(have):
        k = have.index(False) + 1
        raise BhrError(f"{where}: segment {k} has no lumen while others do; give every segment a lumen "
                       "or set a top-level lumen for the rest")
    lum = np.array([pc.lumen for pc in pieces], dtype=np.float64)[idx]
    return pts, lum


def segments_trajectory(data: dict[str, Any], path: Path, feed: float):
    """A :class:`~bhr.model._generators.Trajectory` from a parsed segment file."""

    where = str(path)
    check_keys(data, TOP_KEYS, where)
    name = name_value(data.get("name", path.stem), f"{where}: name")
    if "description" in data:
        text_value(data["description"], f"{where}: description")
    start = np.array(vector3(data.get("start", [0.0, 0.0, 0.0]), f"{where}: start"))
    heading = unit_vector(np.array(vector3(data.get("heading", [1.0, 0.0, 0.0]), f"{where}: heading", nonzero=True)))
    if "up" in data:
        up = np.array(vector3(data["up"], f"{where}: up", nonzero=True))
    else:
        up = np.array([0.0, 0.0, 1.0])
        if abs(float(np.dot(up, heading))) > 0.999:
            raise BhrError(f"{where}: heading is vertical, so 'left' and 'right' need a reference; "
                           "add up = [0, 1, 0] (any direction not along the heading)")
    up = up / np.linalg.norm(up)
    if abs(float(np.dot(up, heading))) > 0.999:
        raise BhrError(f"{where}: up must not point along the heading; give a direction across it")
    up = unit_vector(up - np.dot(up, heading) * heading)
    default_lumen = None
    if "lumen" in data:
        default_lumen = number(data["lumen"], f"{where}: lumen", positive=True, unit="mm", maximum=MAX_MM)
    segs = data.get("segment")
    if segs is None or segs == []:
        raise BhrError(f"{where}: no segments; add [[segment]] tables (type = \"straight\", \"arc\" or \"helix\")")
    if not isinstance(segs, list):
        raise BhrError(f"{where}: segment must be a list of [[segment]] tables, got {type_name(segs)}")
    if len(segs) > LIMITS["segments"]:  # before any segment is walked
        raise BhrError(f"{where}: {len(segs)} segments, more than the {LIMITS['segments']:,} a trajectory file may "
                       "have; join straight runs into longer segments or give the points as a CSV")
    pieces, _ = _build_pieces(segs, start, heading, up, default_lumen, where)
    pts, lumen = _sample(pieces, feed, where)
    params = {"segments": len(pieces), "length": float(sum(pc.length for pc in pieces))}
    end = choice(data.get("lumen_end", "closed"), f"{where}: lumen_end", LUMEN_ENDS)
    return Trajectory(name, pts, params, min(pc.radius for pc in pieces), lumen, where,
                      tuple(float(v) for v in heading), tuple(float(v) for v in start), lumen_end=end)


# --- CSV point lists ---------------------------------------------------------------------------------------------

CSV_COLUMNS = ("x", "y", "z", "lumen", "section")
#: A section's name in a CSV (letters, digits, blanks and - ' ( ), at most 40 characters).
_SECTION_NAME = re.compile(r"[A-Za-z][A-Za-z0-9 '()-]{0,39}", re.ASCII)
#: A header cell quoted back in a message: a short name (letters, digits, underscore), as a column's is.
_COLUMN_LIKE = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,7}", re.ASCII)


def _split(line: str) -> list[str]:
    sep = "," if "," in line else (";" if ";" in line else None)
    return [f.strip() for f in (line.split(sep) if sep else line.split())]


def read_points_csv(path: Path) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, list[str] | None]:
    """Points (N, 3), lumen (N,) or None, each point's line number, and each point's section or None.

    The first line that is not blank or a ``#`` comment is the header: ``x``,
    ``y``, ``z`` and optionally ``lumen`` and ``section``, in any order (case
    does not matter). Fields are separated by commas (or semicolons, or blanks;
    a section name with blanks needs commas or semicolons).
    """
    where = str(path)
    text = read_text(path, "trajectory CSV", HINT_CSV)
    header: list[str] | None = None
    cols: dict[str, int] = {}
    rows: list[list[float]] = []
    lines: list[int] = []
    sections: list[str] = []
    for no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = _split(line)
        if header is None:
            header = [f.lower() for f in fields]
            for i, h in enumerate(header):
                if h not in CSV_COLUMNS:
                    hint = " (the first line must be the header)" if _is_number(h) else ""
                    # a column's name is quoted only when it looks like one: the first line of any .csv a batch
                    # names ("password=hunter2") would otherwise reach the report's shareable files
                    shown = repr(fields[i]) if _COLUMN_LIKE.fullmatch(fields[i]) else f"{i + 1} of the header"
                    raise BhrError(f"{where}, line {no}: unknown column {shown}{hint}; "
                                   f"allowed columns: x, y, z, lumen, section")
                if h in cols:
                    raise BhrError(f"{where}, line {no}: column {excerpt(h)} appears twice; give each column once")
                cols[h] = i
            missing = [c for c in "xyz" if c not in cols]
            if missing:
                raise BhrError(f"{where}, line {no}: the header lacks {', '.join(missing)}; "
                               "it must name x, y, z (and optionally lumen, section)")
            continue
        if len(fields) != len(header):
            raise BhrError(f"{where}, line {no}: {len(fields)} fields where the header has {len(header)} "
                           f"({', '.join(header)})")
        vals = []
        for name in ("x", "y", "z", "lumen"):
            if name not in cols:
                continue
            f = fields[cols[name]]
            if len(f) > MAX_NUMBER_CHARS:  # a 400-digit integer was quoted whole, and read as "not finite"
                raise BhrError(f"{where}, line {no}: {name} = {excerpt(f)} is {len(f)} characters, longer than "
                               f"any number ({MAX_NUMBER_CHARS}); give mm as plain numbers such as 12.5")
            try:
                if not (f.isascii() and "_" not in f):  # no "1_5", full-width or Arabic-Indic digits
                    raise ValueError(f)
                v = float(f)
            except ValueError:
                raise BhrError(f"{where}, line {no}: {name} = {f!r} is not a number; give mm as plain numbers "
                               "such as 12.5") from None
            if not math.isfinite(v):
                raise BhrError(f"{where}, line {no}: {name} = {f} is not a finite number; give mm as plain numbers")
            if abs(v) > MAX_MM:
                raise BhrError(f"{where}, line {no}: {name} = {f} is beyond +-{MAX_MM:g} mm; give mm as plain numbers")
            if v != 0.0 and abs(v) < MIN_MAGNITUDE:  # 1e-320, a denormal: out, as the one checker has it
                raise BhrError(f"{where}, line {no}: {name} = {f} is too small to mean anything (a denormal, under "
                               f"{MIN_MAGNITUDE:g}); give mm as plain numbers such as 12.5")
            if name == "lumen" and v <= 0:
                raise BhrError(f"{where}, line {no}: lumen = {f} must be a diameter greater than 0 mm")
            vals.append(v)
        if "section" in cols:
            name = fields[cols["section"]]
            if name and not _SECTION_NAME.fullmatch(name):
                raise BhrError(f"{where}, line {no}: section {excerpt(name)} is not a section name; give letters, "
                               "digits, blanks and - ' ( ), starting with a letter, at most 40 characters "
                               "(or leave it empty)")
            sections.append(name)
        rows.append(vals)
        lines.append(no)
        if len(rows) > MAX_POINTS:
            raise BhrError(f"{where}: more than {MAX_POINTS} points; thin the centerline first")
    if header is None:
        raise BhrError(f"{where}: no header and no points; {HINT_CSV}")
    numeric = len(cols) - ("section" in cols)
    arr = np.array(rows, dtype=np.float64).reshape(len(rows), numeric)
    pts = arr[:, :3]
    lumen = arr[:, 3].copy() if "lumen" in cols else None
    return pts, lumen, np.array(lines, dtype=np.int64), (sections if "section" in cols else None)


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def check_points(pts: np.ndarray, lines: np.ndarray, where: str) -> None:
    """At least two distinct points and no point repeating the one before it."""
    if pts.shape[0] < 2:
        raise BhrError(f"{where}: {pts.shape[0]} point{'s' if pts.shape[0] != 1 else ''}; a path needs at least "
                       "two distinct points")
    if np.all(np.all(pts == pts[0], axis=1)):
        raise BhrError(f"{where}: every point is the same; a path needs at least two distinct points")
    step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    dup = np.flatnonzero(step == 0.0)
    if dup.size:
        k = int(dup[0])
        raise BhrError(f"{where}, line {int(lines[k + 1])}: repeats the point of line {int(lines[k])}; "
                       "remove the duplicate")
    if not np.isfinite(step).all():
        raise BhrError(f"{where}: coordinates too large to measure; give mm as plain numbers")


def estimate_min_radius(pts: np.ndarray, spacing: float, window: float = CURVATURE_WINDOW_MM) -> float:
    """Smallest radius of curvature of evenly spaced points, robust to noise.

    Around each point a cubic is fitted by least squares to the 2m+1 points
    within +-``window`` mm of arc length (a Savitzky-Golay filter,
    m = round(window / spacing), at least 2); its first and second derivatives
    give the curvature |p' x p''| / |p'|^3. The result is 1 / the largest
    curvature over the points whose window lies inside the path (infinite for
    a straight path). Paths shorter than the window use the widest window that
    fits (a parabola through 3 points when there are only 3 or 4).
    The fit flattens a bend that fills much of its window a little; the
    largest curvature is corrected for that by inverting the fit's reading on
    an exact circle (:func:`_unbias`). The effect of noise is measured in
    docs/trajectories.md.
    """
    n = pts.shape[0]
    m = min(max(2, int(round(window / spacing))), (n - 1) // 2)
    if m < 1:
        return math.inf
    degree = 3 if m >= 2 else 2
    j = np.arange(-m, m + 1, dtype=np.float64)
    coef = np.linalg.pinv(np.stack([j ** k for k in range(degree + 1)], axis=1))  # rows: weights of a0, a1, a2...
    w1 = coef[1] / spacing
    w2 = 2.0 * coef[2] / spacing ** 2
    from numpy.lib.stride_tricks import sliding_window_view

    win = sliding_window_view(np.ascontiguousarray(pts, dtype=np.float64), 2 * m + 1, axis=0)  # (n-2m, 3, 2m+1)
    d1 = win @ w1
    d2 = win @ w2
    speed = np.linalg.norm(d1, axis=1)
    ok = speed > 1e-9
    if not np.any(ok):
        return math.inf
    kappa = np.linalg.norm(np.cross(d1[ok], d2[ok]), axis=1) / speed[ok] ** 3
    kmax = float(kappa.max())
    if not kmax > 1e-12:
        return math.inf
    return 1.0 / _unbias(kmax, spacing, m, w1, w2)


def _circle_response(kappa: float, spacing: float, m: int, w1: np.ndarray, w2: np.ndarray) -> float:
    """What the fit of :func:`estimate_min_radius` reads on a circle of curvature ``kappa``, points ``spacing``
    apart."""
    step = 2.0 * math.asin(min(1.0, 0.5 * spacing * kappa))  # angle between points one chord apart
    a = np.arange(-m, m + 1, dtype=np.float64) * step
    x, y = np.sin(a) / kappa, (1.0 - np.cos(a)) / kappa
    x1, y1, x2, y2 = float(x @ w1), float(y @ w1), float(x @ w2), float(y @ w2)
    return abs(x1 * y2 - y1 * x2) / math.hypot(x1, y1) ** 3


def _unbias(k_est: float, spacing: float, m: int, w1: np.ndarray, w2: np.ndarray) -> float:
    """The curvature of the circle on which the fit reads ``k_est``.

    A cubic fitted over a window that spans a good part of a tight bend
    flattens it a little (5 % at a 20 mm radius with +-15 mm); inverting the
    fit's response on an exact circle undoes that without shrinking the
    window, so noise is averaged as much as before. Bisection over circles
    whose window spans at most a quarter turn each side; readings beyond that
    are returned as they are.
    """
    hi = min(math.pi / (2.0 * m * spacing), 2.0 / spacing)
    if k_est >= hi or _circle_response(hi, spacing, m, w1, w2) < k_est:
        return k_est
    lo = k_est
    if _circle_response(lo, spacing, m, w1, w2) >= k_est:
        return k_est
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _circle_response(mid, spacing, m, w1, w2) < k_est:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def csv_trajectory(path: Path, feed: float):
    """A :class:`~bhr.model._generators.Trajectory` resampled from a CSV point list."""

    where = str(path)
    raw, lumen_raw, lines, section_raw = read_points_csv(path)
    check_points(raw, lines, where)
    length = float(np.linalg.norm(np.diff(raw, axis=0), axis=1).sum())
    if length < feed * (1 - 1e-9):
        raise BhrError(f"{where}: the path is {length:g} mm long, shorter than one feed ({feed:g} mm); "
                       "coordinates are read in millimetres (a centerline in metres needs multiplying by 1000), "
                       "so give a longer centerline")
    try:
        pts, lumen = resample_polyline(raw, feed, lumen_raw)
    except BhrError as exc:
        raise BhrError(f"{where}: {exc}") from None
    if pts.shape[0] < 2:
        raise BhrError(f"{where}: the path zig-zags within one feed ({feed:g} mm) of its first point and never "
                       "gets farther; give a centerline that moves forward")
    d0 = pts[1] - pts[0]
    heading = tuple(float(v) for v in d0 / np.linalg.norm(d0))
    params = {"points_in_file": int(raw.shape[0]), "length": length}
    sections: tuple[tuple[str, int, int], ...] = ()
    if section_raw is not None:  # each resampled point keeps the section of the file's point it falls after
        _, idx = resample_polyline(raw, feed, np.arange(raw.shape[0], dtype=np.float64))
        assert idx is not None
        labels = np.array(section_raw, dtype=object)[np.floor(idx[:pts.shape[0]] + 1e-9).astype(int)]
        sections = runs_of(labels)
    mesh = path.with_suffix(".vtp")
    return Trajectory(path.stem, pts, params, estimate_min_radius(pts, feed), lumen, where, heading,
                      tuple(float(v) for v in pts[0]), lumen_end=csv_lumen_end(path), sections=sections,
                      mesh=str(mesh) if mesh.is_file() else None)


def csv_lumen_end(path: Path) -> str:
    """How a CSV centerline's lumen ends: ``closed`` unless a comment line says ``# lumen_end: open``."""
    end = "closed"
    for no, raw in enumerate(read_text(path, "trajectory CSV", HINT_CSV).splitlines(), start=1):
        line = raw.strip()
        if line.startswith("#") and "lumen_end" in line:
            m = _END_LINE.match(line)
            if m is None or m.group(1).lower() not in LUMEN_ENDS:
                raise BhrError(f"{path}, line {no}: write the lumen's end as '# lumen_end: closed' or "
                               "'# lumen_end: open'")
            end = m.group(1).lower()
    return end

