"""The optimal solver: exact search (against plain enumeration), follow-the-leader runs, options, CLI: the tests that run the bhr command."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bhr.model._generators import load_trajectory
from bhr.model._robot import Robot, base_frame
from bhr._run.driver import follow
from bhr.solvers import get_solver
from tests.unit.test_optimal import enumerate_best  # noqa: F401


def test_solve_one_target_is_exact(run_bhr_in_process):
    robot = Robot(modules=3, module_length=2.0)
    target = np.array([1.5, 4.0, 2.0])
    res = get_solver("optimal", robot).solve(
        __import__("bhr.solvers", fromlist=["Chain"]).Chain.straight(robot, (0, 1, 0)), target)
    frame = base_frame((0, 1, 0))
    T = np.zeros((4, 3))
    T[3] = target
    best, args = enumerate_best(robot, np.zeros(3), frame, T, np.array([0, 0, 0, 1.0]), None, 0.0)
    assert tuple(res.codes) in args
    assert res.position_error_mm == pytest.approx(math.sqrt(best))
    out = run_bhr_in_process("solve", "--solver", "optimal", "--modules", "3", "--module-length", "2", "--target", "1.5", "4",
                  "2", "--json", "-")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert doc["codes"] == list(res.codes)
    assert doc["position_error"] == pytest.approx(res.position_error_mm)


def test_follow_cli_takes_the_optimal_options(run_bhr_in_process, tmp_path):
    out = run_bhr_in_process("follow", "--traj", "curve", "--solver", "optimal", "--lookahead", "2", "--beam", "3",
                  "--ori-weight", "0.1", "--point-weights", "1,1,1,1,1,2", "--no-plots", "--json", "-")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    direct = follow(load_trajectory("curve"), solver="optimal",
                    solver_options={"lookahead": 2, "beam": 3, "ori_weight": 0.1,
                                    "point_weights": [1, 1, 1, 1, 1, 2]})
    assert [s["codes"] for s in doc["steps"]] == direct.codes.tolist()
    bad = run_bhr_in_process("follow", "--traj", "curve", "--solver", "seed", "--lookahead", "2", "--no-plots")
    assert bad.returncode != 0
    assert len(bad.stderr.strip().splitlines()) == 1 and "optimal" in bad.stderr
    bad = run_bhr_in_process("follow", "--traj", "curve", "--solver", "optimal", "--point-weights", "1,x", "--no-plots")
    assert bad.returncode != 0 and len(bad.stderr.strip().splitlines()) == 1
