"""Chapter 6: each constraint of the thesis's solver can be rerun and gives the published tables.

10 modules of 2 along +Y, alpha = 10 deg, 30 iterations; tolerances as in each test.
"""
import json

import pytest
from bhr.cli.main import main
from click.testing import CliRunner

from bhr.model._robot import Robot, forward_kinematics
from bhr.solvers import Chain, solve

# target, orientation, tol_pos, solver settings, (position error, orientation error, iterations)
CASES = [
    # Table 6.1 / 6.2 / 6.4: non-binary (continuous limit), binary, binary with 10 warm-up iterations
    ((4, 19, 0), (1, 2, 0), 0.1, dict(limit="continuous", axes="free", warmup=0), (0.0188, 9.9362, 20)),
    ((4, 19, 0), (1, 2, 0), 0.1, dict(limit="binary", axes="free", warmup=0), (0.6924, 13.4349, 30)),
    ((4, 19, 0), (1, 2, 0), 0.1, dict(limit="binary", axes="free", warmup=10), (0.3458, 13.4349, 30)),
    ((12, 14, 0), (3, 1, 0), 0.1, dict(limit="continuous", axes="free", warmup=0), (0.0912, 8.4630, 14)),
    # Table 6.3 / 6.5
    ((12, 14, 0), (4, 1, 0), 0.1, dict(limit="continuous", axes="free", warmup=0), (0.0939, 4.6538, 15)),
    ((12, 14, 0), (4, 1, 0), 0.1, dict(limit="binary", axes="free", warmup=0), (0.9501, 4.0362, 30)),
    ((12, 14, 0), (4, 1, 0), 0.1, dict(limit="binary", axes="free", warmup=10), (0.6066, 4.0362, 30)),
    # Section 6.3 and Tables 6.6-6.8: restricted to the local axes (the full thesis solver)
    ((4, 19, 0), (1, 2, 0), 1.0, dict(), (0.3458, 13.4349, 30)),
    ((7, 18, 4), (1, 1, 1), 1.0, dict(), (0.5843, 7.1442, 11)),
    ((9, 16, 2), (4, 1, 1), 1.0, dict(), (1.8661, 16.3884, 30)),
    ((3, 19, 4), (1, 3, 1), 1.0, dict(), (0.7129, 11.9778, 30)),
    # Tables 6.6-6.8, free axes
    ((7, 18, 4), (1, 1, 1), 1.0, dict(axes="free"), (0.4619, 10.6380, 30)),
    ((9, 16, 2), (4, 1, 1), 1.0, dict(axes="free"), (0.0720, 6.4889, 11)),
    ((3, 19, 4), (1, 3, 1), 1.0, dict(axes="free"), (0.2308, 5.6353, 11)),
]


@pytest.mark.parametrize("target, orientation, tol, options, expected", CASES)
def test_chapter6_tables(target, orientation, tol, options, expected):
    res = solve(target, tip_direction=orientation, modules=10, module_length=2, tol_pos=tol, tol_ori=10,
                alpha=10, max_iter=30, solver="seed" if not options else "constrained", solver_options=options)
    assert (round(res.position_error_mm, 4), round(res.orientation_error_deg, 4), res.iterations) == expected


def test_seed_codes_rebuild_the_chain():
    """The codes the thesis's solver returns give back its points through forward kinematics."""
    robot = Robot(modules=10, module_length=2, tol_pos=1, tol_ori=10, alpha=10)
    res = solve((7, 18, 4), tip_direction=(1, 1, 1), solver="seed", robot=robot)
    assert res.codes == [12, 3, 12, 6, 12, 0, 12, 6, 12, 6]
    frame = Chain.straight(robot, (0, 1, 0)).base_frame()
    pts, _ = forward_kinematics(robot, res.codes, frame=frame)
    assert abs(pts - res.points).max() < 1e-9


def test_cli_seed_with_orientation_and_codes():
    res = CliRunner().invoke(main, ["solve", "--modules", "10", "--module-length", "2", "--target", "7", "18", "4",
                                    "--orientation", "1", "1", "1", "--solver", "seed", "--tol-pos", "1",
                                    "--tol-ori", "10", "--alpha", "10", "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)  # the compile notice of a cold cache goes to stderr
    assert doc["iterations"] == 11
    assert round(doc["orientation_error_deg"], 4) == 7.1442
    assert doc["codes"] == [12, 3, 12, 6, 12, 0, 12, 6, 12, 6]
