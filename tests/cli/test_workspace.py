"""bhr workspace and bhr fk --plot, run as a user runs them."""
from __future__ import annotations

import json

import pytest

from tests.conftest import snapshot


def test_workspace_of_a_few_modules_is_exact(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("workspace", "--modules", "3", "--alpha", "20", "--json", "w.json", "--plot", "w.png")
    assert res.returncode == 0, res.stderr
    assert "all 216 poses" in res.stdout and "Figure: w.png" in res.stdout
    doc = json.loads((tmp_path / "w.json").read_text())
    assert doc["method"] == "exact" and doc["poses"] == doc["evaluated_poses"] == 216
    assert doc["reach_max_mm"] == pytest.approx(3 * (10 + 2 * 5 * 0.3420201433256687))  # the all-lift pose
    assert (tmp_path / "w.png").stat().st_size > 10_000


def test_workspace_of_a_long_robot_is_sampled_and_says_so(run_bhr_in_process):
    res = run_bhr_in_process("workspace", "--modules", "40", "--samples", "2000", "--no-plot")
    assert res.returncode == 0, res.stderr
    assert "2,000 random poses of" in res.stdout and "Monte Carlo, seed 0" in res.stdout
    assert "sampled: the robot's volume is at least this" in res.stdout
    doc = json.loads(run_bhr_in_process("workspace", "--modules", "5", "--no-lift", "--no-plot", "--json", "-").stdout)
    assert doc["poses"] == 5 ** 5 and doc["codes_per_module"] == [0, 3, 6, 12, 9]


@pytest.mark.parametrize("args, message", [
    (["workspace", "--modules", "12", "--samples", "0", "--no-plot"], "samples must be greater than 0"),
    (["workspace", "--modules", "3", "--plot", "w.jpg"], "give a file ending in .png, .svg or .pdf"),
    (["workspace", "--modules", "3", "--voxel", "-1", "--no-plot"], "voxel must be greater than 0"),
    (["fk", "--codes", "3,0", "--plot", "pose.gif"], "give a file ending in .png, .svg or .pdf"),
])
def test_bad_input_is_one_line_and_writes_nothing(run_bhr_in_process, tmp_path, args, message):
    before = snapshot(tmp_path)
    res = run_bhr_in_process(*args)
    assert res.returncode != 0 and message in res.stderr and "Traceback" not in res.stderr
    assert snapshot(tmp_path) == before


def test_fk_plot_draws_the_pose(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("fk", "--codes", "3,0,6,0,15", "--plot", "pose.png")
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "pose.png").stat().st_size > 10_000
