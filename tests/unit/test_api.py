"""The Python API: overrides applied, typed results, to_dict/to_json, no deprecated aliases."""
import json

import numpy as np
import pytest

import bhr
from bhr._run.driver import Summary
from bhr._settings.errors import BhrError


def test_solve_applies_robot_overrides():
    r = bhr.Robot(modules=5, module_length=2.0, tol_pos=0.01)
    res = bhr.solve([3, 9, 0], robot=r, modules=7)
    assert res.points.shape == (8, 3)
    assert np.isclose(np.linalg.norm(res.points[1] - res.points[0]), 2.0)
    res = bhr.solve([3, 9, 0], robot=r, module_length=3.0)
    assert res.points.shape == (6, 3) and np.isclose(np.linalg.norm(res.points[1] - res.points[0]), 3.0)
    with pytest.raises(BhrError, match="'bogus' is not a robot setting"):
        bhr.solve([3, 9, 0], robot=r, bogus=1)


def test_solve_result_success_and_json():
    ok = bhr.solve([3, 9, 0], modules=10, tol_pos=0.01)
    assert ok.success is True and ok.position_error_mm <= 0.01
    assert ok.status == "reached" and "within tolerance" in ok.reason
    far = bhr.solve([300, 0, 0], modules=5)
    assert far.success is False and far.status == "out of reach" and "300 mm from the base" in far.reason
    short = bhr.solve([3, 9, 0], modules=10, tol_pos=1e-9, max_iter=1)
    assert short.success is False and short.status == "not reached" and "after 1 iterations" in short.reason
    doc = ok.to_dict()
    # SPEC's keys, and whether and why the target was reached
    assert set(doc) == {"bhr_version", "iterations", "position_error", "orientation_error_deg", "points", "codes",
                        "success", "status", "reason"}
    assert doc["bhr_version"] == bhr.__version__  # every JSON bhr writes says which bhr wrote it
    assert doc["position_error"] == ok.position_error_mm and doc["success"] is True and doc["status"] == "reached"
    assert json.loads(ok.to_json()) == doc
    assert far.status == "out of reach" and far.to_dict()["success"] is False


def test_solve_status_tells_a_missed_target_within_reach_from_one_out_of_reach():
    # the thesis's binary solver cannot put the tip within 0.01 of (3, 9, 0), which the chain can reach
    near = bhr.solve([3, 9, 0], modules=5, solver="thesis", tol_pos=0.01)
    assert near.success is False and near.status == "not reached"
    # just beyond the straight chain's length (5 modules of 2): out of reach
    beyond = bhr.solve([0, 10.5, 0], modules=5, tol_pos=0.01)
    assert beyond.status == "out of reach"
    inside = bhr.solve([0, 9.99, 0], modules=5, tol_pos=0.05)
    assert inside.status == "reached"


def test_follow_result_summary_is_typed():
    run = bhr.follow(bhr.trajectory("curve"), solver="thesis")
    s = run.summary
    assert isinstance(s, Summary) and s.steps == run.steps and s.tip_final_error_mm == s.to_dict()["tip_final_error_mm"]
    assert isinstance(run.to_json(), str) and json.loads(run.to_json())["summary"] == s.to_dict()
    with pytest.raises(TypeError):
        run.summary()  # a typed summary, not a function


def test_robot_fk():
    pts, frames = bhr.Robot(modules=3).fk([3, 0, 15])
    assert pts.shape == (4, 3) and frames.shape == (3, 3, 3)
    straight, _ = bhr.Robot(modules=3).fk([0, 0, 0])
    assert np.allclose(straight[-1], [30, 0, 0])


