"""The numpy references of `bhr bench` compute what bhr computes (no timing here: see tests/benchmarks)."""
import dataclasses

import numpy as np
import pytest

from bhr._bench.cases import (
    CASES,
    OPTIMAL_PER_STEP,
    check_optimal_reference,
    format_table,
    numpy_body,
    numpy_ccd,
    numpy_fabrik,
    numpy_optimal_follow,
    numpy_seed_follow,
    run_case,
)
from bhr.model._generators import load_trajectory
from bhr.model._robot import straight_chain
from bhr._run.body import BODY_BEAM, module1_frames, simulate_body
from bhr._run.driver import follow
from bhr.solvers._ccd import ccd_kernel
from bhr.solvers._fabrik import fabrik_kernel


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
    path = np.ascontiguousarray(tr.points)
    codes, pe, costs = numpy_optimal_follow(path, tr.start_point, tr.start_direction, return_costs=True)
    assert np.array_equal(codes, res.codes)
    np.testing.assert_allclose(pe, res.point_errors_mm, atol=1e-9)
    assert len({tuple(c) for c in codes}) > 3  # the robot really turned
    agree = check_optimal_reference(res, path, codes, pe, costs)
    assert agree["steps_compared"] == len(path) and agree["tie_at_step"] is None


def test_optimal_reference_cost_is_the_solvers():
    """The reference's minimum cost at a step is the cost the solver's own search finds from the same chain."""
    from bhr.model._robot import Robot
    from bhr.solvers import Chain
    from bhr.solvers._optimal import search_all

    tr = load_trajectory("curve")
    path = np.ascontiguousarray(tr.points[:40])
    _, _, costs = numpy_optimal_follow(path, tr.start_point, tr.start_direction, return_costs=True)
    chain = Chain.straight(Robot(), tr.start_direction, tr.start_point, tip_at_origin=True)
    # step 0: targets on the straight line behind the start, except the tip's
    T = np.array([path[0] + (-(5 - j) * 5) * 2.0 * (path[1] - path[0]) / np.linalg.norm(path[1] - path[0])
                  for j in range(6)])
    d = (path[1] - path[0]) / np.linalg.norm(path[1] - path[0])
    _, cost = search_all(chain.points[0], chain.base_frame(), T, np.ones(6), 10.0, 10.0, d, 0.2, reach=False)
    assert abs(cost - costs[0]) < 1e-9 * max(1.0, cost)


def test_optimal_check_rejects_a_different_choice():
    tr = load_trajectory("curve")
    tr = dataclasses.replace(tr, points=tr.points[:60])
    path = np.ascontiguousarray(tr.points)
    res = follow(tr, solver="optimal", solver_options=OPTIMAL_PER_STEP)
    codes, pe, costs = numpy_optimal_follow(path, tr.start_point, tr.start_direction, return_costs=True)
    bad = codes.copy()
    bad[30, 0] = 3 if bad[30, 0] != 3 else 6
    # same cost there: a tie, compared up to it
    tie = check_optimal_reference(res, path, bad, pe, costs)
    assert tie["steps_compared"] == 30 and tie["tie_at_step"] == 31 and tie["max_point_error_difference_mm"] < 1e-9
    dearer = costs.copy()
    dearer[30] += 1e-3
    with pytest.raises(AssertionError, match="different codes at step 31"):
        check_optimal_reference(res, path, bad, pe, dearer)
    pe2 = pe.copy()
    pe2[10, 5] += 1e-3
    with pytest.raises(AssertionError, match="point errors differ"):
        check_optimal_reference(res, path, codes, pe2, costs)


def test_seed_reference():
    tr = load_trajectory("curve")
    tip = numpy_seed_follow(tr.points)
    np.testing.assert_allclose(tip, follow(tr).point_errors_mm[:, -1], atol=1e-9)


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
    assert list(CASES) == ["fabrik", "ccd", "thesis-colon", "optimal", "body-60", "lumen", "trail-300", "wires-300",
                           "study-100",
                           "physics-300", "cli", "first-run"]
    table = format_table(run_case("ccd", repeat=1))
    assert table.splitlines()[0].split()[:3] == ["case", "unit", "bhr"] and "ccd-ch5-10" in table


def test_cli_json_to_stdout_is_parseable():
    import json

    from bhr.cli.main import main
    from click.testing import CliRunner

    result = CliRunner().invoke(main, ["bench", "--case", "ccd", "--repeat", "1", "--json", "-"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert [r["case"] for r in doc] == ["ccd-ch5-10"] and doc[0]["ratio"] > 0
    assert "ccd-ch5-10" in result.stderr  # the table
