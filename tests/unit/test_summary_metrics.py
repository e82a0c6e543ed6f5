"""RMSE and the over-tolerance flag: in the summary, the printed table, report rows and sweep rows."""
from __future__ import annotations

import numpy as np

from bhr.model._generators import load_trajectory
from bhr._run.driver import follow
from bhr._studies.report import summary_row
from bhr._studies.sweep import METRICS


def scored_rmse(values: np.ndarray, first: int) -> float:
    v = values[first:]
    return float(np.sqrt(np.sum(v * v) / len(v)))


def test_rmse_of_every_point_and_module_over_its_scored_steps():
    run = follow(load_trajectory("curve", angle=360))
    s = run.summary.to_dict()
    n, f = run.modules, run.robot.feed_divisor
    want_pts = [scored_rmse(run.point_errors_mm[:, j], (n - j) * f) for j in range(n + 1)]
    want_mods = [scored_rmse(run.orientation_errors_deg[:, j], (n - j - 1) * f) for j in range(n)]
    np.testing.assert_allclose(s["rmse_point_mm"], want_pts, rtol=1e-12)
    np.testing.assert_allclose(s["rmse_module_deg"], want_mods, rtol=1e-12)
    assert s["tip_rmse_mm"] == s["rmse_point_mm"][-1] and s["tip_orientation_rmse_deg"] == s["rmse_module_deg"][-1]
    # the RMSE lies between the mean and the maximum of the same values
    for st in s["points"] + s["modules"]:
        assert st["mean"] - 1e-12 <= st["rmse"] <= st["max"] + 1e-12


def test_a_run_over_its_tolerance_is_flagged_and_counted():
    tr = load_trajectory("curve", angle=360)
    ok = follow(tr, tol_pos=8.0, tol_ori=90.0).summary.to_dict()
    assert ok["points_max_error_mm"] < 8.0 and not ok["tolerance_exceeded"]
    assert ok["over_tol_pos_steps"] == ok["over_tol_ori_steps"] == 0
    tight = follow(tr, tol_pos=4.0, tol_ori=90.0)
    s = tight.summary.to_dict()
    assert s["tolerance_exceeded"]
    # the solve's tolerance changes the solution too: count against this run's own errors
    assert s["over_tol_pos_steps"] == int(np.count_nonzero(tight.point_errors_mm.max(axis=1) > 4.0)) > 0
    row = summary_row(s)
    assert row["tolerance_exceeded"] is True and row["tip_rmse_mm"] == s["tip_rmse_mm"]
    assert {"tip_rmse_mm", "tip_orientation_rmse_deg", "tolerance_exceeded"} <= set(METRICS)


