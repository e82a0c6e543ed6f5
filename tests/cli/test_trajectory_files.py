"""Trajectory files: generator files with lumen, segment files (TOML) and point lists (CSV): the tests that run the bhr command."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bhr.model._generators import load_trajectory
from tests.unit.test_trajectory_files import _distance_to, centerline, write  # noqa: F401


def test_ten_thousand_point_centerline_is_resampled_and_followed(tmp_path, run_bhr_in_process):
    rng = np.random.default_rng(12345)
    # irregular spacing: random gaps whose density also varies tenfold along the curve
    gaps = rng.exponential(1.0, 9999) * (0.2 + 1.8 * rng.random(9999)) * (1 + 9 * (np.arange(9999) % 2000 < 700))
    t = np.concatenate([[0.0], np.cumsum(gaps)])
    t /= t[-1]
    r, d1, d2 = centerline(t)
    f = write(tmp_path / "centerline.csv", "x,y,z\n" + "\n".join(f"{x:.10f},{y:.10f},{z:.10f}" for x, y, z in r) + "\n")
    assert len(f.read_text().splitlines()) == 10001
    spacing = np.linalg.norm(np.diff(r, axis=0), axis=1)
    assert spacing.max() / spacing.min() > 100  # really irregular

    tr = load_trajectory(f, feed=2.0)
    # resampled: one feed apart, on the true curve (within the polyline's chord error), start to end
    assert np.allclose(np.linalg.norm(np.diff(tr.points, axis=0), axis=1), 2.0)
    tt = np.linspace(0, 1, 400001)
    dense, dd1, dd2 = centerline(tt)
    dist = _distance_to(dense, tr.points)
    assert dist.max() < 0.05
    length = np.linalg.norm(np.diff(dense, axis=0), axis=1).sum()
    assert tr.points.shape[0] == pytest.approx(length / 2.0, abs=2)
    kappa = np.linalg.norm(np.cross(dd1, dd2), axis=1) / np.linalg.norm(dd1, axis=1) ** 3
    true_rmin = 1 / kappa.max()
    assert tr.min_radius == pytest.approx(true_rmin, rel=0.05)

    res = run_bhr_in_process("follow", "--traj", f, "--no-plots", "--out", "run")
    assert res.returncode == 0, res.stderr
    assert "Warning" not in res.stderr  # the curve is gentler than the robot's 57.15 mm
    doc = json.loads((tmp_path / "run" / "run.json").read_text())
    assert len(doc["steps"]) == tr.points.shape[0]
    assert doc["steps"][-1]["target"] == pytest.approx(tr.points[-1].tolist())
    assert doc["steps"][0]["points"][-1] == pytest.approx(r[0].tolist())  # the tip starts on the first point
    tip = [s["point_errors_mm"][-1] for s in doc["steps"]]
    assert max(tip) < doc["robot"]["tol_pos"]  # the tip stays within tolerance all the way
    assert (tmp_path / "run" / "codes.csv").read_text().count("\n") == len(doc["steps"]) + 1


def test_example_files_load_and_the_centerline_script_reproduces_its_csv(tmp_path):
    import subprocess
    import sys

    from tests.conftest import REPO

    seg = load_trajectory(REPO / "trajectories" / "example_segments.toml")
    assert seg.min_radius == 70.0 and set(np.unique(seg.lumen)) == {30.0, 45.0}
    assert np.ptp(seg.points[:, 2]) > 50  # it really leaves the plane
    cl = load_trajectory(REPO / "trajectories" / "example_centerline.csv")
    assert cl.lumen[0] == pytest.approx(30.0) and cl.lumen[-1] == pytest.approx(45.0)
    assert 57.15 < cl.min_radius < 75  # its tightest bend is 70 mm, seen through 0.05 mm of noise
    out = tmp_path / "c.csv"
    subprocess.run([sys.executable, str(REPO / "docs" / "examples" / "make_centerline.py"), str(out)], check=True,
                   capture_output=True, cwd=REPO)
    assert out.read_text() == (REPO / "trajectories" / "example_centerline.csv").read_text()


def test_follow_warns_about_a_centerline_tighter_than_the_robot_turns(tmp_path, run_bhr_in_process):
    s = np.arange(0.0, 150.0, 0.7)
    a = np.clip((s - 50) / 30.0, 0, math.pi / 2)
    rest = np.clip(s - 50 - 30 * math.pi / 2, 0, None)
    pts = np.stack([np.minimum(s, 50) + 30 * np.sin(a), 30 * (1 - np.cos(a)) + rest, 0 * s], axis=1)
    write(tmp_path / "tight.csv", "x,y,z\n" + "\n".join(",".join(f"{v:.9f}" for v in p) for p in pts) + "\n")
    res = run_bhr_in_process("follow", "--traj", "tight.csv", "--no-plots", "--out", "o")
    assert res.returncode == 0, res.stderr
    warn = [line for line in res.stderr.splitlines() if line.startswith("Warning")]
    assert len(warn) == 1 and "tighter than the robot's minimum turn radius 57.15 mm" in warn[0]
    radius = float(warn[0].split("turns with radius ")[1].split(" mm")[0])
    assert radius == pytest.approx(30.0, rel=0.05)
