"""Trajectory files: generator files with lumen, segment files (TOML) and point lists (CSV)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from bhr.model._generators import COLON_SECTIONS, GENERATORS, colon, load_trajectory
from bhr.model._pathfile import estimate_min_radius, resample_polyline
from bhr._settings.errors import BhrError

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def write(path, text):
    path.write_text(text, encoding="utf-8")
    return path


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else ("-inf" if v == -math.inf else repr(v)))
    return str(v)


def segment_file(segs, **top):
    lines = [f"{k} = {toml_value(v)}" for k, v in top.items()]
    for seg in segs:
        lines.append("[[segment]]")
        lines += [f"{k} = {toml_value(v)}" for k, v in seg.items()]
    return "\n".join(lines) + "\n"


def turn_angles(pts):
    d = np.diff(pts, axis=0)
    u = d / np.linalg.norm(d, axis=1)[:, None]
    return np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1.0, 1.0))


# --- built-ins and generator files ------------------------------------------------------------------------------

def test_colon_lumen_is_30_mm_in_the_rectum_and_45_elsewhere():
    tr = load_trajectory("colon")
    sections = []
    pts = colon(2.0, section_index=sections)
    assert np.array_equal(tr.points, pts)  # the printed generator, untouched
    assert tr.lumen is not None and tr.lumen.shape == (pts.shape[0],)
    sec = np.asarray(sections)
    assert set(np.unique(sec)) == set(range(len(COLON_SECTIONS)))
    assert np.all(tr.lumen[sec == COLON_SECTIONS.index("rectum")] == 30.0)
    assert np.all(tr.lumen[sec != COLON_SECTIONS.index("rectum")] == 45.0)
    assert tr.lumen[0] == 30.0 and tr.lumen[-1] == 45.0


@pytest.mark.parametrize("name", ["line", "curve", "spiral"])
def test_other_builtins_have_no_lumen_and_keep_the_thesis_start(name):
    tr = load_trajectory(name)
    gen = GENERATORS[name]
    assert np.array_equal(tr.points, gen.func(2.0, **gen.params))
    assert tr.lumen is None
    assert tr.start_point == (0.0, 0.0, 0.0) and tr.start_direction == (1.0, 0.0, 0.0)


def test_generator_file_lumen_number_and_section_table(tmp_path):
    f = write(tmp_path / "c.toml", 'generator = "curve"\nlumen = 40\n[params]\nradius = 80.0\n')
    tr = load_trajectory(f)
    assert tr.params["radius"] == 80.0 and np.all(tr.lumen == 40.0) and tr.lumen.shape == (tr.points.shape[0],)
    table = "\n".join(f'"{s}" = {20 + k}' for k, s in enumerate(COLON_SECTIONS))
    f = write(tmp_path / "col.toml", f'generator = "colon"\n[lumen]\n{table}\n')
    sections = []
    colon(2.0, section_index=sections)
    assert np.array_equal(load_trajectory(f).lumen, 20.0 + np.asarray(sections))


@pytest.mark.parametrize("text, message", [
    ('generator = "curve"\nlumen = -1\n', "lumen must be greater than 0"),
    ('generator = "curve"\n[lumen]\nrectum = 30\n', "must be one diameter"),
    ('generator = "colon"\n[lumen]\nrectum = 30\n', "no diameter for section 'bend 1'"),
    ('generator = "colon"\n[lumen]\nstomach = 30\n', "unknown section 'stomach'"),
    ('generator = "curve"\nradius = 3\n', "unknown key 'radius'"),
    ('generator = "helix"\n', "generator must be one of"),
    ('generator = "curve"\n[params]\nradius = nan\n', "radius must be a finite number"),
    ('generator = "line"\n[params]\nlength = ' + "9" * 400 + "\n", "length = a 400-digit whole number is too large"),
    ('generator = "curve"\n[params]\nangle = -90\n', "angle must be greater than 0"),
    ('generator = "spiral"\n[params]\nturns = 0\n', "turns must be greater than 0"),
    ('generator = "curve"\n[params]\nradius = "big"\n', "radius must be a number"),
    ('generator = "curve"\nname = 3\n', "name must be text"),
    ('generator = "curve"\n[[segment]]\ntype = "straight"\nlength = 3\n', "not both"),
    ('name = "x"\n', "neither generator"),
])
def test_generator_file_errors(tmp_path, text, message):
    f = write(tmp_path / "t.toml", text)
    with pytest.raises(BhrError) as exc:
        load_trajectory(f)
    assert message in str(exc.value) and str(f) in str(exc.value) and "\n" not in str(exc.value)


# --- segment files ----------------------------------------------------------------------------------------------

def test_segment_file_geometry(tmp_path):
    f = write(tmp_path / "s.toml", segment_file([
        {"type": "straight", "length": 40.0},
        {"type": "arc", "radius": 70.0, "angle": 90.0, "turn": "left"},
        {"type": "arc", "radius": 60.0, "angle": 90.0, "turn": "up"},
    ], start=[1.0, 2.0, 3.0]))
    tr = load_trajectory(f, feed=0.5)
    p = tr.points
    assert tr.start_point == (1.0, 2.0, 3.0) and tr.start_direction == (1.0, 0.0, 0.0)
    assert np.allclose(p[0], [1, 2, 3]) and np.allclose(p[80], [41, 2, 3])
    # the left arc ends 70 mm ahead and 70 mm to the left (+y), heading +y
    k = int(round((40 + 70 * math.pi / 2) / 0.5))  # the sample nearest the arc's end (within half a feed)
    assert np.linalg.norm(p[k] - [41 + 70, 2 + 70, 3]) < 0.25
    assert np.allclose(_unit(p[k + 1] - p[k]), [0, 1, 0], atol=0.5 / 60)
    # then it climbs: the up arc ends 60 mm further along +y and 60 mm up, heading +z
    assert np.allclose(p[-1], [111, 72 + 60, 63], atol=0.6)
    assert tr.min_radius == 60.0
    assert np.allclose(np.linalg.norm(np.diff(p, axis=0), axis=1), 0.5, atol=0.5 ** 3 / (24 * 60 ** 2) + 1e-12)
    assert turn_angles(p).max() <= 0.5 / 60 + 1e-9  # tangent-continuous: no kink at the joins


def _unit(v):
    return v / np.linalg.norm(v)


def test_helix_segment_radius_of_curvature_and_closing_heading(tmp_path):
    r, pitch = 50.0, 30.0
    f = write(tmp_path / "h.toml", segment_file([
        {"type": "straight", "length": 20.0},
        {"type": "helix", "radius": r, "pitch": pitch, "turns": 2.0, "turn": "right"},
        {"type": "straight", "length": 20.0},
    ]))
    tr = load_trajectory(f, feed=0.25)
    rho = r + (pitch / (2 * math.pi)) ** 2 / r
    assert tr.min_radius == pytest.approx(rho, rel=1e-12)
    ang = turn_angles(tr.points)
    inner = ang[100:-100]
    inner = inner[inner > 1e-9]
    assert np.allclose(0.25 / inner, rho, rtol=1e-3)  # discrete radius of curvature inside the helix
    assert ang.max() <= 0.25 / rho * (1 + 1e-3)
    # after two whole turns it heads +x again, two pitches further along its axis, which leans forward from +z
    # by the pitch angle so that the helix starts along the heading; clockwise seen from +z (y < 0 on the way)
    beta = math.atan2(pitch, 2 * math.pi * r)
    end = tr.points[-1]
    assert np.allclose(_unit(end - tr.points[-2]), [1, 0, 0], atol=1e-9)
    assert end[2] == pytest.approx(2 * pitch * math.cos(beta), abs=1e-9) and abs(end[1]) < 1e-9
    assert 0 <= 20 + 2 * pitch * math.sin(beta) + 20 - end[0] < 0.25
    assert tr.points[:, 1].min() < -r


def test_roll_turns_the_plane_of_later_turns(tmp_path):
    f = write(tmp_path / "r.toml", segment_file([
        {"type": "straight", "length": 10.0, "roll": 90.0},
        {"type": "arc", "radius": 50.0, "angle": 90.0, "turn": "left"},
    ]))
    p = load_trajectory(f, feed=1.0).points
    # up was +z; rolled 90 deg about +x it is -y, so "left" = up x heading = -y x +x = +z
    assert np.allclose(p[-1], [10 + 50, 0, 50], atol=1.0)
    assert abs(p[:, 1]).max() < 1e-9


def test_segment_lumen_per_point(tmp_path):
    f = write(tmp_path / "l.toml", segment_file([
        {"type": "straight", "length": 10.0, "lumen": 30.0},
        {"type": "straight", "length": 10.0},
    ], lumen=45.0))
    tr = load_trajectory(f, feed=2.0)
    assert tr.lumen.tolist() == [30.0] * 5 + [45.0] * 6


@pytest.mark.parametrize("segs, top, message", [
    ([{"type": "straight", "length": 0.0}], {}, "length must be greater than 0"),
    ([{"type": "straight", "length": -4.0}], {}, "length must be greater than 0"),
    ([{"type": "straight", "length": math.nan}], {}, "must be a finite number"),
    ([{"type": "straight", "length": math.inf}], {}, "must be a finite number"),
    ([{"type": "straight", "length": "10"}], {}, "must be a number, got the text '10'"),
    ([{"type": "straight", "length": True}], {}, "must be a number, got a boolean"),
    ([{"type": "straight", "lenght": 10.0}], {}, "did you mean 'length'"),
    ([{"type": "arc", "radius": 70.0, "angle": 90.0}], {}, "needs turn"),
    ([{"type": "arc", "radius": 70.0, "angle": 90.0, "turn": "sideways"}], {}, "turn must be one of"),
    ([{"type": "arc", "radius": 0.0, "angle": 90.0, "turn": "left"}], {}, "radius must be greater than 0"),
    ([{"type": "arc", "radius": 70.0, "angle": -90.0, "turn": "left"}], {}, "angle must be greater than 0"),
    ([{"type": "helix", "radius": 70.0, "pitch": 10.0, "turns": 0.0, "turn": "left"}], {}, "turns must be greater"),
    ([{"type": "helix", "radius": 70.0, "pitch": 10.0, "turns": -1.0, "turn": "left"}], {}, "turns must be greater"),
    ([{"type": "helix", "radius": 70.0, "pitch": 10.0, "turns": 1.0, "turn": "up"}], {}, "turn must be one of"),
    ([{"type": "spline"}], {}, "type must be one of"),
    ([{"length": 3.0}], {}, "has no type"),
    ([{"type": "straight", "length": 1.0}], {}, "shorter than one feed"),
    ([{"type": "straight", "length": 5e5}] * 10, {}, "limit 500000"),
    ([{"type": "straight", "length": 2e6}], {}, "must be at most"),
    ([{"type": "straight", "length": 10.0}], {"heading": [0, 0, 0]}, "must not be [0, 0, 0]"),
    ([{"type": "straight", "length": 10.0}], {"heading": [0, 0, 1]}, "heading is vertical"),
    ([{"type": "straight", "length": 10.0}], {"heading": [1, 0, 0], "up": [2, 0, 0]}, "must not point along"),
    ([{"type": "straight", "length": 10.0}], {"start": [0, 0]}, "list of three numbers"),
    ([{"type": "straight", "length": 10.0}], {"start": [0, 0, math.nan]}, "must be a finite number"),
    ([{"type": "straight", "length": 10.0}], {"colour": "red"}, "unknown key 'colour'"),
    ([{"type": "straight", "length": 10.0}, {"type": "straight", "length": 10.0, "lumen": 3.0}], {},
     "segment 1 has no lumen"),
])
def test_segment_file_errors(tmp_path, segs, top, message):
    f = write(tmp_path / "bad.toml", segment_file(segs, **top))
    with pytest.raises(BhrError) as exc:
        load_trajectory(f)
    msg = str(exc.value)
    assert message in msg and msg.startswith(str(f)) and "\n" not in msg


def test_trajectory_options_are_refused_for_files(tmp_path):
    f = write(tmp_path / "s.toml", segment_file([{"type": "straight", "length": 10.0}]))
    with pytest.raises(BhrError, match="applies to generator trajectories only"):
        load_trajectory(f, radius=5.0)
    g = write(tmp_path / "p.csv", "x,y,z\n0,0,0\n10,0,0\n")
    with pytest.raises(BhrError, match="applies to generator trajectories only"):
        load_trajectory(g, turns=2.0)


straight = st.fixed_dictionaries({"type": st.just("straight"), "length": st.floats(0.5, 80.0)})
arc = st.fixed_dictionaries({"type": st.just("arc"), "radius": st.floats(5.0, 200.0), "angle": st.floats(1.0, 270.0),
                             "turn": st.sampled_from(["left", "right", "up", "down"])},
                            optional={"roll": st.floats(-180.0, 180.0, allow_subnormal=False)})
helix = st.fixed_dictionaries({"type": st.just("helix"), "radius": st.floats(5.0, 150.0), "pitch": st.floats(1.0, 100.0),
                               "turns": st.floats(0.05, 2.0), "turn": st.sampled_from(["left", "right"])})


def analytic(seg):
    if seg["type"] == "straight":
        return seg["length"], math.inf
    if seg["type"] == "arc":
        return seg["radius"] * math.radians(seg["angle"]), seg["radius"]
    r, p = seg["radius"], seg["pitch"]
    return seg["turns"] * math.hypot(2 * math.pi * r, p), r + (p / (2 * math.pi)) ** 2 / r


@FAST
@given(segs=st.lists(st.one_of(straight, arc, helix), min_size=1, max_size=5), feed=st.sampled_from([0.5, 2.0, 3.0]),
       start=st.tuples(*[st.floats(-100, 100, allow_subnormal=False)] * 3))
def test_segment_paths_hold_their_invariants(tmp_path, segs, feed, start):
    total = sum(analytic(s)[0] for s in segs)
    assume(total >= feed and total / feed < 20000)
    f = write(tmp_path / "h.toml", segment_file(segs, start=list(start)))
    tr = load_trajectory(f, feed=feed)
    p = tr.points
    assert p.shape == (int(math.floor(total / feed + 1e-9)) + 1, 3)
    assert np.allclose(p[0], start)
    rmin = min(analytic(s)[1] for s in segs)
    assert tr.min_radius == pytest.approx(rmin, rel=1e-12) if math.isfinite(rmin) else tr.min_radius == math.inf
    step = np.linalg.norm(np.diff(p, axis=0), axis=1)
    # consecutive points are one feed apart along the path: the chord is at most one feed, and no shorter
    # than the chord of a feed-long arc of the tightest radius
    low = 2 * rmin * math.sin(min(feed / (2 * rmin), math.pi / 2)) if math.isfinite(rmin) else feed
    assert np.all(step <= feed * (1 + 1e-9)) and np.all(step >= low * (1 - 1e-9))
    if p.shape[0] > 2 and math.isfinite(rmin):
        assert turn_angles(p).max() <= 2 * math.asin(min(1.0, feed / (2 * rmin))) + 1e-7  # no kinks
    assert tr.lumen is None and np.all(np.isfinite(p))


# --- CSV point lists --------------------------------------------------------------------------------------------

def test_csv_resampling_spacing_lumen_and_start(tmp_path):
    f = write(tmp_path / "c.csv", "# a comment\n\nX, Y, Z, Lumen\n0,0,0,30\n4,0,0,40\n4,3,0,40\n4,3,10,20\n")
    tr = load_trajectory(f, feed=1.0)
    p = tr.points
    assert tr.start_point == (0.0, 0.0, 0.0) and tr.start_direction == (1.0, 0.0, 0.0)
    assert np.allclose(np.linalg.norm(np.diff(p, axis=0), axis=1), 1.0)
    assert np.allclose(p[:5], [[k, 0, 0] for k in range(5)])
    assert tr.lumen[:5].tolist() == pytest.approx([30.0, 32.5, 35.0, 37.5, 40.0])
    # every resampled point lies on the polyline
    assert np.all((np.isclose(p[:, 1], 0) & np.isclose(p[:, 2], 0)) | (np.isclose(p[:, 0], 4) &
                                                                         (np.isclose(p[:, 2], 0) | np.isclose(p[:, 1], 3))))
    assert p[-1][2] > 9.0 and tr.params["points_in_file"] == 4


def test_csv_semicolons_and_column_order(tmp_path):
    f = write(tmp_path / "c.csv", "z;x;y\n0;0;0\n0;10;0\n")
    tr = load_trajectory(f, feed=2.0)
    assert np.allclose(tr.points[-1], [10, 0, 0]) and tr.points.shape == (6, 3) and tr.lumen is None


@pytest.mark.parametrize("text, message", [
    ("x,y,z\n0,0,0\n", "1 point; a path needs at least two distinct points"),
    ("x,y,z\n", "0 points"),
    ("", "bad.csv is empty (0 bytes), not a trajectory file"),
    ("x,y,z\n1,1,1\n1,1,1\n1,1,1\n", "every point is the same"),
    ("x,y,z\n0,0,0\n5,0,0\n5,0,0\n9,0,0\n", "line 4: repeats the point of line 3"),
    ("x,y,z\n0,0,0\n5,nan,0\n", "line 3: y = nan is not a finite number"),
    ("x,y,z\n0,0,0\n5,inf,0\n", "line 3: y = inf is not a finite number"),
    ("x,y,z\n0,0,0\n5,five,0\n", "line 3: y = 'five' is not a number"),
    ("x,y,z\n0,0,0\n5,0\n", "line 3: 2 fields where the header has 3"),
    ("x,y\n0,0\n", "line 1: the header lacks z"),
    ("x,y,z,w\n0,0,0,1\n", "unknown column 'w'"),
    ("x,y,z,x\n0,0,0,1\n", "column 'x' appears twice"),
    ("0,0,0\n1,1,1\n", "the first line must be the header"),
    ("x,y,z,lumen\n0,0,0,30\n5,0,0,0\n", "lumen = 0 must be a diameter greater than 0"),
    ("x,y,z\n0,0,0\n1,0,0\n", "shorter than one feed"),
    ("x,y,z\n0,0,0\n1e7,0,0\n", "beyond +-1e+06 mm"),
    ("x,y,z\n0,0,\x000\n", "binary data"),
])
def test_csv_errors(tmp_path, text, message):
    f = write(tmp_path / "bad.csv", text)
    with pytest.raises(BhrError) as exc:
        load_trajectory(f, feed=2.0)
    msg = str(exc.value)
    assert message in msg and msg.startswith(str(f)) and "\n" not in msg


def test_unreadable_files(tmp_path):
    (tmp_path / "latin1.csv").write_bytes("x,y,z\n0,0,0\n1,0,0 # \xe9\n".encode("latin-1"))
    with pytest.raises(BhrError, match=r"line 3: not UTF-8"):
        load_trajectory(tmp_path / "latin1.csv")
    (tmp_path / "folder.csv").mkdir()
    with pytest.raises(BhrError, match="is a folder"):
        load_trajectory(tmp_path / "folder.csv")
    write(tmp_path / "path.txt", "x,y,z\n")
    with pytest.raises(BhrError, match=r"\.toml .* or \.csv"):
        load_trajectory(tmp_path / "path.txt")
    with pytest.raises(BhrError, match="unknown trajectory"):
        load_trajectory(tmp_path / "nowhere.csv")
    write(tmp_path / "broken.toml", "[[segment]\n")
    with pytest.raises(BhrError, match=r"not valid TOML .*line 1"):
        load_trajectory(tmp_path / "broken.toml")


points3 = st.tuples(*[st.floats(-200, 200, allow_nan=False, allow_subnormal=False)] * 3)


@FAST
@given(pts=st.lists(points3, min_size=2, max_size=40), feed=st.sampled_from([0.5, 2.0, 7.0]))
def test_csv_resampling_invariants(tmp_path, pts, feed):
    arr = np.array(pts)
    f = write(tmp_path / "p.csv", "x,y,z\n" + "\n".join(f"{x!r},{y!r},{z!r}" for x, y, z in pts) + "\n")
    try:
        tr = load_trajectory(f, feed=feed)
    except BhrError as exc:
        msg = str(exc)
        assert msg.startswith(str(f)) and "\n" not in msg
        step = np.linalg.norm(np.diff(arr, axis=0), axis=1)
        assert np.any(step == 0) or step.sum() < feed
        return
    p = tr.points
    assert np.array_equal(p[0], arr[0])
    assert np.allclose(np.linalg.norm(np.diff(p, axis=0), axis=1), feed, rtol=1e-9, atol=1e-9)
    assert p.shape[0] - 1 <= np.linalg.norm(np.diff(arr, axis=0), axis=1).sum() / feed + 1e-9
    # each resampled point lies on some segment of the polyline (4,096 points at a time against every segment)
    a, d = arr[:-1], arr[1:] - arr[:-1]
    dd, tol = np.einsum("ij,ij->i", d, d), 1e-7 * max(1.0, np.abs(arr).max())
    for lo in range(0, p.shape[0], 4096):
        q = p[lo:lo + 4096, None, :]  # (points, 1, 3) against the segments' (segments, 3)
        t = np.clip(np.einsum("pij,ij->pi", q - a, d) / dd, 0, 1)
        nearest = np.min(np.linalg.norm(a + t[..., None] * d - q, axis=2), axis=1)
        assert np.all(nearest < tol), lo + int(np.argmax(nearest))


@FAST
@given(text=st.text(max_size=300))
def test_any_text_is_a_trajectory_or_one_clear_line(tmp_path, text):
    for name in ("t.csv", "t.toml"):
        f = tmp_path / name
        f.write_text(text, encoding="utf-8")
        try:
            tr = load_trajectory(f)
        except BhrError as exc:
            assert str(exc).strip() and "\n" not in str(exc)
        else:
            assert tr.points.shape[0] >= 2 and np.all(np.isfinite(tr.points))


def test_min_radius_estimate_on_circles_and_lines():
    s = np.arange(0, 300, 2.0)
    for r in (20.0, 57.15, 100.0):
        a = s / r
        pts = np.stack([r * np.sin(a), r * (1 - np.cos(a)), 0 * s], axis=1)
        assert estimate_min_radius(pts, 2.0) == pytest.approx(r, rel=0.02)
    assert estimate_min_radius(np.stack([s, 2 * s, 0 * s], axis=1), 2.0) == math.inf
    assert estimate_min_radius(np.array([[0.0, 0, 0], [1, 0, 0]]), 1.0) == math.inf


def test_resample_polyline_does_not_count_noise_as_length():
    rng = np.random.default_rng(3)
    s = np.sort(rng.uniform(0, 600, 10000))
    noisy = np.stack([s, 0 * s, 0 * s], axis=1) + rng.normal(0, 0.1, (10000, 3))
    assert np.linalg.norm(np.diff(noisy, axis=0), axis=1).sum() > 2 * 600  # the raw zig-zag is far too long
    out, _ = resample_polyline(noisy, 2.0)
    assert 295 <= out.shape[0] <= 301  # about 600 mm / 2 mm, not 3 or 4 times that


# --- a measured centerline with 10,000 irregularly spaced points, followed end to end --------------------------

def centerline(t):
    """A smooth 3D curve (mm) and its first and second derivatives in t in [0, 1]."""
    w1, w2 = 2 * math.pi * 1.5, 2 * math.pi
    r = np.stack([600 * t, 40 * np.sin(w1 * t), 25 * (1 - np.cos(w2 * t))], axis=-1)
    d1 = np.stack([600 + 0 * t, 40 * w1 * np.cos(w1 * t), 25 * w2 * np.sin(w2 * t)], axis=-1)
    d2 = np.stack([0 * t, -40 * w1 ** 2 * np.sin(w1 * t), 25 * w2 ** 2 * np.cos(w2 * t)], axis=-1)
    return r, d1, d2


def _distance_to(curve, pts, chunk=200):
    out = []
    for k in range(0, len(pts), chunk):
        q = pts[k:k + chunk]
        d2 = ((q[:, None, :] - curve[None, ::40, :]) ** 2).sum(-1)
        near = np.argmin(d2, axis=1) * 40
        best = []
        for qq, i in zip(q, near):
            seg = curve[max(0, i - 60):i + 60]
            best.append(np.sqrt(((seg - qq) ** 2).sum(-1).min()))
        out += best
    return np.array(out)


# --- the shipped examples ---------------------------------------------------------------------------------------




def test_the_segment_limit_of_the_registry_holds(tmp_path):
    from bhr._settings.options import LIMITS

    at = tmp_path / "at.toml"
    at.write_text(segment_file([{"type": "straight", "length": 0.5}] * LIMITS["segments"]))
    assert load_trajectory(str(at), feed=2.0).params["segments"] == LIMITS["segments"]
    past = tmp_path / "past.toml"
    past.write_text(segment_file([{"type": "straight", "length": 0.5}] * (LIMITS["segments"] + 1)))
    with pytest.raises(BhrError, match=f"{LIMITS['segments'] + 1} segments, more than the {LIMITS['segments']:,}"):
        load_trajectory(str(past), feed=2.0)


@pytest.mark.parametrize("first, shown", [("password=hunter2,x", "unknown column 1 of the header"),
                                          ("x,y,z,AKIAIOSFODNN7", "unknown column 4 of the header"),
                                          ("x,y,z,w", "unknown column 'w'")])
def test_a_header_cell_is_quoted_only_when_it_looks_like_a_column_name(tmp_path, first, shown):
    # the first line of any .csv a batch names must not reach the report's shareable files through this message
    f = tmp_path / "secret.csv"
    f.write_text(first + "\n0,0,0,0\n")
    with pytest.raises(BhrError) as err:
        load_trajectory(str(f), feed=2.0)
    assert shown in str(err.value) and "hunter2" not in str(err.value) and "AKIA" not in str(err.value)


@pytest.mark.parametrize("name, params", [("colon", {}), ("line", {"length": 1e6}), ("curve", {"radius": 1e4,
                                                                                                "angle": 360})])
def test_a_path_of_too_many_points_names_a_feed_that_fits(name, params):
    """The refusal said only "make it shorter", which a built-in colon cannot be; it names the feed that fits,
    and a path drawn at that feed is accepted (the limit is a count of points, so the feed is rounded up)."""
    import re

    from bhr.model._generators import load_trajectory
    from bhr._settings.errors import BhrError

    with pytest.raises(BhrError) as err:
        load_trajectory(name, feed=0.00016, **params)
    message = str(err.value)
    assert "\n" not in message and "(limit 500000); make it shorter, or raise the feed" in message
    least = float(re.search(r"to at least ([0-9.e+-]+) mm$", message).group(1))
    assert load_trajectory(name, feed=least, **params).points.shape[0] <= 500_001
    with pytest.raises(BhrError, match="limit 500000"):
        load_trajectory(name, feed=least * 0.99, **params)
