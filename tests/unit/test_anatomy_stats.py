"""The generated colons calibrated on the real ones (bhr.model._anatomy_stats): the measure, and the calibration's
criteria (docs/anatomy.md, "Calibration on real colons"). The full check over seeds 1-1000 is the script
`python -m bhr.model._anatomy_stats`; these tests afford fewer seeds."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr.model._anatomy import MIN_RADIUS_MM, SEED_MAX, anatomical_colon
from bhr.model._anatomy_stats import (
    CHORD_MM,
    GROUPS,
    SMOOTHING_MM,
    TIGHT_MM,
    RealColon,
    bend_profile,
    generated_shape,
    main,
    real_colons,
)
from bhr._settings.errors import BhrError

SETTINGS = settings(max_examples=20, deadline=None)  # each example draws a whole colon (about 25 ms of CPU)


@pytest.fixture(scope="module")
def real():
    return [r.shape() for r in real_colons()]


@pytest.fixture(scope="module")
def population():
    return [generated_shape(s) for s in range(1, 151)]


def test_the_shipped_real_colons_are_read():
    colons = real_colons()
    assert [c.name for c in colons] == ["E20", "E60", "E90", "VHF", "VHM"]
    for c in colons:
        assert len(c.points) == len(c.lumen) == len(c.sections) > 900
        steps = np.linalg.norm(np.diff(c.points, axis=0), axis=1)
        # 1 mm of the source's path apart, in mm (a chord across a bend of it is shorter)
        assert steps.max() <= 1.002 and np.median(steps) == pytest.approx(1.0, abs=1e-3)
        shares = c.shares()
        assert sum(shares.values()) == pytest.approx(1.0) and all(shares[g] > 0 for g in GROUPS)


@pytest.mark.run
def test_population_median_bend_and_tight_share_within_the_real_range(population, real):
    """At 3 mm smoothing and 5 mm chords, the pooled population's median bend radius and share of length tighter
    than 57 mm lie within the range of the shipped real colons."""
    assert (SMOOTHING_MM, CHORD_MM, TIGHT_MM) == (3.0, 5.0, 57.0)
    pooled = np.concatenate([p.radii for p in population])
    med = [r.median_radius for r in real]
    tight = [r.tight_share for r in real]
    assert min(med) <= np.median(pooled) <= max(med)
    assert min(tight) <= np.mean(pooled < TIGHT_MM) <= max(tight)
    # and so does most every colon of the population on its own
    assert np.mean([min(med) <= p.median_radius <= max(med) for p in population]) >= 0.95
    assert np.mean([min(tight) <= p.tight_share <= max(tight) for p in population]) >= 0.95


@pytest.mark.run
def test_segment_shares_match_the_real_landmarks(population, real):
    for g in GROUPS:
        gen = np.mean([p.shares[g] for p in population])
        lo, hi = min(r.shares[g] for r in real), max(r.shares[g] for r in real)
        assert lo <= gen <= hi, g
    # the descending colon: 22-33 % of the real colons' length
    desc = np.array([p.shares["descending"] for p in population])
    assert 0.21 <= np.percentile(desc, 5) and np.percentile(desc, 95) <= 0.33


@pytest.mark.run
def test_no_generated_bend_tighter_than_the_tightest_real_one(population, real):
    tightest_real = min(r.tightest for r in real)
    assert 4.0 < tightest_real < MIN_RADIUS_MM  # what the generator's limit was set against
    assert min(p.tightest for p in population) > tightest_real
    for s in range(151, 301):
        assert generated_shape(s).tightest > tightest_real, s


@SETTINGS
@given(st.integers(min_value=0, max_value=SEED_MAX))
def test_no_centerline_bends_tighter_than_its_limit(seed):
    c = anatomical_colon(seed)
    assert c.min_radius >= MIN_RADIUS_MM * (1 - 1e-9)
    assert bend_profile(c.sample(1.0)[0]).min() > MIN_RADIUS_MM * 0.9


def test_the_anal_canal_is_narrow_and_bent_as_a_real_one():
    """The first 40 mm of a real CT colonography centerline: 13-16 mm across, bending at 8-11 mm radius."""
    for seed in range(1, 41):
        c = anatomical_colon(seed)
        pts, lumen, _ = c.sample(1.0)
        assert 13.0 <= lumen[:41].min() and lumen[:41].max() <= 16.0
        assert 8.0 <= c.bends["anorectal"][1] <= 11.0
        r = bend_profile(pts[:80], 0.0, 2.0)  # entry k: 2 + k mm from the anus
        assert 7.0 <= r[:50].min() <= 12.0, seed


@SETTINGS
@given(st.floats(min_value=5.0, max_value=500.0), st.floats(min_value=0.3, max_value=2.0))
def test_bend_profile_reads_a_circle_as_its_radius(radius, spacing):
    u = np.arange(0.0, 1.5 * math.pi * radius, 0.1) / radius
    pts = np.column_stack([radius * np.cos(u), radius * np.sin(u), 0 * u])
    r = bend_profile(pts, 0.0, 5.0, spacing)
    # the circle through three points of a circle is that circle (the resampled chords sag by < 1e-4 relatively)
    assert np.allclose(r, radius, rtol=2e-3)
    # smoothing pulls the points inward: it never reads the circle wider, and by less than sigma^2 / (2 r)
    cut = int(15.0 / spacing)  # the ends, where the smoothing pads the path with its end points
    rs = bend_profile(pts, 3.0, 5.0, spacing)[cut:-cut]
    assert np.all(rs <= radius * (1 + 2e-3)) and np.all(rs >= radius - 9.0 / radius - 2e-3 * radius)


def test_bad_input_is_one_line(tmp_path):
    with pytest.raises(BhrError, match="too short for 5 mm chords"):
        bend_profile(np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]]))
    with pytest.raises(BhrError, match="smoothing must be >= 0"):
        bend_profile(np.zeros((5, 3)), -1.0)
    with pytest.raises(BhrError, match="no real colons in"):
        real_colons(tmp_path)
    (tmp_path / "c.csv").write_text("# a colon without its sections\nx,y,z,lumen\n0,0,0,10\n1,0,0,10\n2,0,0,10\n")
    with pytest.raises(BhrError, match="c.csv: every row needs numbers x, y, z, lumen and a section name"):
        real_colons(tmp_path)
    bad = RealColon("X", np.zeros((3, 3)), np.ones(3), ["rectum", "ileum", "cecum"])
    with pytest.raises(BhrError, match="real colon X: unknown section 'ileum'"):
        bad.shares()


def test_the_script_prints_both_tables(capsys):
    assert main(["--seeds", "1-3", "--dependence-seeds", "1-2"]) == 0
    out = capsys.readouterr().out
    assert "| median bend radius (mm) |" in out and "| share: descending |" in out
    assert "| 3 | 5 |" in out and "E90" in out
    assert main(["--seeds", "5-1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Error: --seeds must be FIRST-LAST" in err
