"""RMSE and the over-tolerance flag: in the summary, the printed table, report rows and sweep rows: the tests that run the bhr command."""
from __future__ import annotations

import json


def test_follow_prints_rmse_and_the_flag_and_exits_0(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "curve", "--angle", "360", "--tol-pos", "4", "--no-plots", "--out", "o")
    assert res.returncode == 0, res.stderr
    doc = json.loads((tmp_path / "o" / "run.json").read_text())
    assert "rmse" in res.stdout.splitlines()[3]
    line = next(ln for ln in res.stdout.splitlines() if ln.startswith("Over tolerance:"))
    assert f"more than 4 mm off at {doc['summary']['over_tol_pos_steps']} steps" in line
    tip = res.stdout.splitlines()[3 + len(doc["summary"]["points"])]  # title, blank, heading, columns, points
    assert tip.startswith("  point 6 (tip)")
    assert f"{doc['summary']['tip_rmse_mm']:.3f}" in tip
