"""Anatomical colons (bhr.model._anatomy): determinism, spacing, published ranges, continuity, files, command line."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import bhr
from bhr.model._anatomy import (
    LENGTH_LIMITS,
    POPULATION,
    RANGES,
    SECTIONS,
    SEED_MAX,
    SHIPPED,
    acute_flexures,
    anatomical_colon,
    anatomy_csv_text,
    bend_radii,
    check_seed,
)
from bhr.model._generators import anatomy_trajectory, builtin_names, colon, load_trajectory
from bhr._settings.errors import BhrError
from tests.conftest import REPO

seeds = st.integers(min_value=0, max_value=SEED_MAX)
feeds = st.floats(min_value=0.5, max_value=5.0)
SETTINGS = settings(max_examples=20, deadline=None)  # each example draws a whole colon (about 25 ms of CPU)


@settings(max_examples=20, deadline=None)  # three whole colons an example
@given(seeds, feeds)
def test_one_seed_one_colon(seed, feed):
    a, b = anatomy_trajectory(seed, feed), anatomy_trajectory(seed, feed)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.lumen, b.lumen)
    assert a.min_radius == b.min_radius and a.start_direction == b.start_direction
    other = anatomy_trajectory(seed + 1 if seed < SEED_MAX else seed - 1, feed)
    n = min(len(a.points), len(other.points))
    assert not np.array_equal(a.points[:n], other.points[:n])


@SETTINGS
@given(seeds, feeds)
@example(5987, 2.0)
def test_points_are_one_feed_apart_along_the_path(seed, feed):
    c = anatomical_colon(seed)
    pts, lumen, section = c.sample(feed)
    assert np.array_equal(pts[0], [0.0, 0.0, 0.0])  # the anus
    assert len(pts) == math.floor(c.length / feed + 1e-9) + 1
    chord = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    # a chord of one feed on the tightest bend is shorter than the arc by at most feed^3 / (24 r^2); the arc length
    # is measured along the spline sampled every DENSE_MM (points placed to about 1e-3 of a feed)
    short = feed ** 3 / (24 * c.min_radius ** 2)
    assert np.all(chord <= feed * (1 + 1e-3)) and np.all(chord >= feed - short - 1e-3 * feed)


@SETTINGS
@given(seeds)
def test_lumen_within_the_published_ranges(seed):
    c = anatomical_colon(seed)
    pts, lumen, section = c.sample(2.0)
    lo = min(v[0] for k, v in RANGES.items() if k.startswith("lumen."))
    hi = max(v[1] for k, v in RANGES.items() if k.startswith("lumen."))
    assert lumen.min() >= lo and lumen.max() <= hi
    assert 13.0 <= lumen.min() and lumen.max() <= 60.0  # wall radius 6.5-30 mm
    # the anal canal and anorectal flexure: as narrow as a real CT colonography's first 40 mm (13-16 mm across)
    canal = lumen[: 40 // 2 + 1]
    assert np.all(canal >= 13.0) and np.all(canal <= 16.0) and np.ptp(canal) == 0.0
    assert np.all(lumen[section > 0] >= 24.0)  # past the rectum, 24-60 mm
    # each section's diameter lies between its own drawn value and its neighbours' (the rectum's: or the canal's)
    for k, name in enumerate(SECTIONS):
        near = [RANGES[f"lumen.{SECTIONS[j]}"] for j in range(max(0, k - 1), min(len(SECTIONS), k + 2))]
        near += [RANGES["lumen.anal canal"]] if k == 0 else []
        sel = lumen[section == k]
        assert sel.size == 0 or (sel.min() >= min(v[0] for v in near) and sel.max() <= max(v[1] for v in near))


@SETTINGS
@given(seeds)
@example(5987)  # a short rectum whose sacral bend did not fit even at its smallest radius: it turns less
def test_sections_add_up_and_bends_within_their_ranges(seed):
    c = anatomical_colon(seed)
    assert sum(c.section_lengths.values()) == pytest.approx(c.length, rel=1e-9)
    assert all(v > 0 for v in c.section_lengths.values())
    lo, hi = LENGTH_LIMITS
    assert 0.95 * lo <= c.length <= 1.05 * hi
    for name, (angle, radius) in c.bends.items():
        key = "fold" if "fold" in name else name
        rlo, rhi = RANGES[f"radius.{key}"]
        assert rlo - 1e-9 <= radius <= rhi + 1e-9, name
        if f"angle.{key}" in RANGES:
            alo, ahi = RANGES[f"angle.{key}"]
            assert alo - 1e-9 <= angle <= ahi + 1e-9, name
    # the named flexures and the top of the sigmoid loop are acute (turn by more than 90 deg)
    for name in ("splenic flexure", "hepatic flexure", "sigmoid apex"):
        assert c.bends[name][0] > 90.0


@SETTINGS
@given(seeds, feeds)
def test_a_smooth_centerline_without_kinks(seed, feed):
    c = anatomical_colon(seed)
    # the course's pieces join end to start, tangent to tangent
    for a, b in zip(c.pieces, c.pieces[1:]):
        kind, length, r, p0, t0, d, _ = a
        if kind == "straight":
            end, tend = p0 + length * t0, t0
        else:
            th = length / r
            end = p0 + r * math.sin(th) * t0 + r * (1 - math.cos(th)) * d
            tend = math.cos(th) * t0 + math.sin(th) * d
        assert np.allclose(end, b[3], atol=1e-9) and np.allclose(tend, b[4], atol=1e-12)
    # the spline through them turns no faster than its smallest radius allows, and bends almost everywhere
    pts, _, _ = c.sample(feed)
    v = np.diff(pts, axis=0)
    v /= np.linalg.norm(v, axis=1)[:, None]
    turn = np.arccos(np.clip(np.sum(v[1:] * v[:-1], axis=1), -1, 1))
    assert turn.max() <= 1.05 * feed / c.min_radius + 1e-9
    r = bend_radii(c.sample(1.0)[0], 1.0, 5.0)  # entry k: k + 5 mm from the anus
    canal = int(c.draws["length.anal canal"])  # the anal canal is straight
    assert np.all(r[:canal - 10] > 1e3)  # straight to a metre's radius (the spline rings a little before the bend)
    assert np.mean(r[canal:] > 1e4) < 0.01  # past it, not straight lines joined by arcs: hardly any length is straight


@pytest.mark.run
def test_the_population_has_the_published_spread():
    """Seeds 1-200 against Khashab 2009 (189.5 +- 26.3 cm, 10.9 +- 2.4 acute flexures); the curvature is held to the
    real colons in test_anatomy_stats.py."""
    colons = [anatomical_colon(s) for s in range(1, 201)]
    length = np.array([c.length for c in colons])
    mean, sd = POPULATION["any"]
    assert abs(length.mean() - mean) <= 0.1 * mean and abs(length.std(ddof=1) - sd) <= 0.1 * sd
    flex = [acute_flexures(c.sample(1.0)[0], 1.0) for c in colons]
    assert abs(np.mean(flex) - 10.9) <= 1.0
    # women's colons are longer (193.3 against 185.4 cm)
    women = np.mean([anatomical_colon(s, "female").length for s in range(1, 101)])
    men = np.mean([anatomical_colon(s, "male").length for s in range(1, 101)])
    assert women - men == pytest.approx(POPULATION["female"][0] - POPULATION["male"][0], rel=0.25)


def test_acute_flexures_are_counted_where_the_path_turns_back():
    # a straight, a U-turn of radius 10 mm, a straight back: one acute flexure; a 60 deg bend: none
    s = np.arange(0.0, 100.0, 1.0)
    u = np.linspace(0, np.pi, 32)
    up = np.vstack([np.stack([s, 0 * s, 0 * s], 1), np.stack([100 + 10 * np.sin(u), 10 - 10 * np.cos(u), 0 * u], 1)[1:],
                    np.stack([100 - s[1:], 0 * s[1:] + 20, 0 * s[1:]], 1)])
    from bhr.model._pathfile import resample_polyline
    pts, _ = resample_polyline(up, 1.0)
    assert acute_flexures(pts, 1.0) == 1
    ang = np.radians(60)
    bend = np.vstack([np.stack([s, 0 * s, 0 * s], 1), 99 * np.array([1, 0, 0]) + s[1:, None] * [np.cos(ang), np.sin(ang), 0]])
    assert acute_flexures(bend, 1.0) == 0


def test_bad_sex_is_one_line():
    with pytest.raises(BhrError, match="sex must be one of any, female, male"):
        anatomical_colon(1, "x")


def test_one_colon_is_fast():
    import time

    anatomical_colon(3)
    t = time.process_time()
    for s in range(10):
        anatomical_colon(s).sample(1.0)
    assert (time.process_time() - t) / 10 < 0.1  # well under a second


def test_trajectory_api_and_builtin_file():
    tr = load_trajectory("anatomy", seed=5)
    assert tr.name == "anatomy-5" and tr.params["seed"] == 5
    pts, lumen, _ = anatomical_colon(5).sample(2.0)
    assert np.array_equal(tr.points, pts) and np.array_equal(tr.lumen, lumen)
    assert np.array_equal(bhr.trajectory("anatomy", seed=5), pts)
    assert np.array_equal(load_trajectory("anatomy").points, anatomical_colon(1).sample(2.0)[0])  # file's seed 1
    assert tr.min_radius == anatomical_colon(5).min_radius
    assert tr.start_point == (0.0, 0.0, 0.0)
    # the centerline leaves the anus along the start direction (the spline's first derivative is clamped to it); the
    # first chord of 2 mm deviates from it by about half a chord's turn
    assert np.allclose(tr.start_direction, (pts[1] - pts[0]) / np.linalg.norm(pts[1] - pts[0]), atol=2.0 / (
        2 * anatomical_colon(5).min_radius))
    # the thesis's planar colon is untouched
    assert np.array_equal(load_trajectory("colon").points, colon(2.0))


@pytest.mark.parametrize("seed", [-1, 1.5, SEED_MAX + 1, math.nan, "7", True, None])
def test_bad_seeds_are_one_line(seed):
    with pytest.raises(BhrError, match=r"seed must be a whole number from 0 to 4294967295") as exc:
        check_seed(seed)
    assert "\n" not in str(exc.value)
    if seed is not None:  # None means "the file's seed"
        with pytest.raises(BhrError, match=r"seed must be (a whole number from 0|finite|a number)"):
            load_trajectory("anatomy", seed=seed)


def test_seed_is_refused_by_other_trajectories():
    with pytest.raises(BhrError, match="has no parameter 'seed'"):
        load_trajectory("curve", seed=3)


@pytest.mark.parametrize("name", list(SHIPPED))
def test_shipped_anatomies_are_their_seeds_and_load_by_name(name):
    seed, note = SHIPPED[name]
    path = REPO / "trajectories" / f"{name}.csv"
    assert path.read_text(encoding="utf-8") == anatomy_csv_text(seed, note=note)  # regenerate: make_anatomies.py
    assert name in builtin_names()
    tr = load_trajectory(name)
    c = anatomical_colon(seed)
    assert tr.name == name and tr.lumen is not None
    assert tr.params["length"] == pytest.approx(c.length, rel=2e-3)
    # every point of the resampled 1 mm polyline lies on the colon's centerline (to the file's rounding and the
    # chords' sag, < 0.02 mm at 1 mm chords on a 10 mm bend), with the lumen there
    ref, lum, _ = c.sample(0.05)
    window = np.clip(np.round(np.arange(len(tr.points)) * 2.0 / 0.05).astype(int)[:, None] + np.arange(-100, 101),
                     0, len(ref) - 1)  # +-5 mm of arc length around where each point should be
    d = np.linalg.norm(tr.points[:, None, :] - ref[window], axis=2)
    near = window[np.arange(len(window)), d.argmin(axis=1)]
    assert d.min(axis=1).max() < 0.05
    assert np.abs(tr.lumen - lum[near]).max() < 0.02


