"""Lumen clearance (bhr/clearance.py): lumen radius - robot radius - deviation, and wall touches: the tests that run the bhr command."""
from __future__ import annotations

import json

import numpy as np

from bhr._run.driver import follow


def test_follow_cli_reports_clearance(run_bhr_in_process, tmp_path):
    out = run_bhr_in_process("follow", "--traj", "colon", "--solver", "optimal", "--no-plots", "--out", tmp_path / "o")
    assert out.returncode == 0, out.stderr
    assert "Lumen clearance: minimum" in out.stdout and "Wall touched at 0 steps." in out.stdout
    doc = json.loads((tmp_path / "o" / "run.json").read_text())
    assert doc["summary"]["min_clearance_mm"] > 0 and doc["summary"]["wall_touch_steps"] == []


def test_leaving_the_lumen_is_a_verdict(tmp_path, run_bhr_in_process):
    """A lumen narrower than the robot: the summary says in words that it left the lumen, and at which step."""
    x = np.arange(0.0, 120.0, 1.0)
    lumen = np.full(len(x), 30.0)
    lumen[40:] = 4.0
    p = tmp_path / "narrow.csv"
    p.write_text("x,y,z,lumen\n" + "".join(f"{v},{0.002 * v * v},0,{d}\n" for v, d in zip(x, lumen)))
    from bhr.model._generators import load_trajectory

    run = follow(load_trajectory(str(p)), solver="thesis")
    s = run.summary.to_dict()
    assert s["left_lumen_step"] is not None and s["left_lumen_step"] >= 1
    assert s["left_lumen_reason"].startswith(f"left the lumen at step {s['left_lumen_step']}")
    assert s["max_penetration_mm"] > 5.0
    wide = tmp_path / "wide.csv"
    wide.write_text("x,y,z,lumen\n" + "".join(f"{v},0,0,30\n" for v in x))
    assert follow(load_trajectory(str(wide)), solver="thesis").summary.to_dict()["left_lumen_step"] is None
    out = run_bhr_in_process("follow", "--traj", str(p), "--no-plots", "--json", str(tmp_path / "run.json"))
    assert out.returncode == 0, out.stderr
    assert f"The robot left the lumen at step {s['left_lumen_step']}" in out.stdout
