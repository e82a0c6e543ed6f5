"""The numpy references of `bhr bench` compute what bhr computes (no timing here: see tests/benchmarks)."""
import dataclasses

import numpy as np
import pytest

from bhr.bench import (CASES, OPTIMAL_PER_STEP, format_table, numpy_body, numpy_ccd, numpy_fabrik,
                       numpy_optimal_follow, numpy_seed_follow, run_case)
from bhr.body import BODY_BEAM, module1_frames, simulate_body
from bhr.follow import follow
from bhr.robot import straight_chain
from bhr.solvers.ccd import ccd_kernel
from bhr.solvers.fabrik import fabrik_kernel
from bhr.trajectory import load_trajectory


@pytest.mark.parametrize("target", [(15.0, 6.0, 0.0), (3.0, 9.0, 0.0), (-4.0, 7.0, 5.0)])
def test_fabrik_and_ccd_references(target):
    P0 = straight_chain(10, 2.0, (0, 1, 0))
    t = np.array(target)
    P = P0.copy()
    k, e, _ = fabrik_kernel(P, t, 2.0, 0.01, 30, np.zeros(3), False, 20.0)
    Pn, kn, en = numpy_fabrik(P0, t, 2.0, 0.01, 30)
    assert k == kn and abs(e - en) < 1e-12
    np.testing.assert_allclose(P, Pn, atol=1e-12)
    P = P0.copy()
    k, e = ccd_kernel(P, t, 0.01, 30)
    Pn, kn, en = numpy_ccd(P0, t, 0.01, 30)
    assert k == kn and abs(e - en) < 1e-9


@pytest.mark.parametrize("name, params", [("curve", {}), ("spiral", {"turns": 0.5}), ("colon", {})])
def test_optimal_reference_chooses_the_same_codes(name, params):
    tr = load_trajectory(name, **params)
    tr = dataclasses.replace(tr, points=tr.points[:200])
    res = follow(tr, solver="optimal", solver_options=OPTIMAL_PER_STEP)
    codes, pe = numpy_optimal_follow(np.ascontiguousarray(tr.points), tr.start_point, tr.start_direction)
    assert np.array_equal(codes, res.codes)
    np.testing.assert_allclose(pe, res.point_errors, atol=1e-9)
    assert len({tuple(c) for c in codes}) > 3  # the robot really turned


def test_seed_reference():
    tr = load_trajectory("curve")
    tip = numpy_seed_follow(tr.points)
    np.testing.assert_allclose(tip, follow(tr).point_errors[:, -1], atol=1e-9)


def test_body_reference_matches_on_a_curve_and_the_colon():
    for name in ("curve", "colon"):
        tr = load_trajectory(name)
        res = follow(dataclasses.replace(tr, points=tr.points[:150]))
        body = simulate_body(res, 20)
        start, F1s = module1_frames(res.codes, res.trajectory.start_direction, res.robot.alpha)
        r = res.robot
        pts, codes = numpy_body(np.ascontiguousarray(res.points[:, 0]), F1s, start, 15, r.feed_divisor, r.feed,
                                r.module_length, r.alpha, BODY_BEAM)
        assert np.array_equal(codes, body.codes)
        np.testing.assert_allclose(pts, body.points, atol=1e-9)


def test_every_case_is_registered_and_the_table_formats():
    assert list(CASES) == ["fabrik", "ccd", "seed-colon", "optimal", "body-60", "cli"]
    table = format_table(run_case("ccd", repeat=1))
    assert table.splitlines()[0].split()[:3] == ["case", "unit", "bhr"] and "ccd-ch5-10" in table
