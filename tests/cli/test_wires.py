"""bhr follow with a whole robot: the wires' motion by default, every pose in poses.npz beside run.json."""
from __future__ import annotations

import json

import numpy as np


def test_a_whole_robot_writes_its_poses(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen", "--alpha", "25",
                  "--module-length", "5", "--body-modules", "12", "--no-plots", "--out", "run")
    assert res.returncode == 0, res.stderr
    assert "Wires: rigid modules driven by their wires" in res.stdout and "poses.npz" in res.stdout
    # one procedure time in the summary: the board's schedule of codes.csv, as bhr plan gives it
    timed = [ln for ln in res.stdout.splitlines() if "pace" in ln or "procedure" in ln.lower()]
    assert len(timed) == 1 and timed[0].startswith("Procedure time on the board:"), timed
    doc = json.loads((tmp_path / "run" / "run.json").read_text())
    s = doc["summary"]
    assert s["locomotion"] == "wires" and s["poses_file"] == "poses.npz"
    d = np.load(tmp_path / "run" / "poses.npz")
    assert d["points_mm"].shape == (s["poses"], 13, 3) and d["tilts_rad"].shape == (s["poses"], 12, 2)
    assert d["step"].max() <= len(doc["steps"]) and np.all(np.diff(d["t_s"]) > 0)
    seg = np.linalg.norm(np.diff(d["points_mm"], axis=1), axis=2)
    assert np.max(np.abs(seg - 5.0)) <= 1e-6


def test_the_trail_model_is_still_there_and_labelled(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "anatomy", "--seed", "3", "--solver", "lumen", "--alpha", "25",
                  "--module-length", "5", "--body-modules", "12", "--locomotion", "trail", "--no-plots", "--out",
                  "run")
    assert res.returncode == 0, res.stderr
    assert not (tmp_path / "run" / "poses.npz").exists()
    assert json.loads((tmp_path / "run" / "run.json").read_text())["summary"]["locomotion"] == "trail"
