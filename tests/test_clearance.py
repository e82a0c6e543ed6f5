"""Lumen clearance (bhr/clearance.py): lumen radius - robot radius - deviation, and wall touches."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bhr.clearance import clearance_table, step_ranges
from bhr.follow import follow
from bhr.trajectory import COLON_SECTIONS, colon, load_trajectory


def with_lumen(tr, diameter):
    tr.lumen = np.full(tr.points.shape[0], float(diameter)) if np.isscalar(diameter) else np.asarray(diameter, float)
    return tr


def test_table_arithmetic():
    pe = np.array([[1.0, 2.0], [0.5, 3.0], [0.0, 1.0]])
    lumen = np.array([30.0, 20.0, 40.0])
    t = clearance_table(pe, np.array([1, 0]), lumen, 5.0)
    assert np.isnan(t[0, 0])  # scored one step behind: nothing at step 1
    assert t[0, 1] == pytest.approx(15 - 5 - 2)
    assert t[1, 0] == pytest.approx(15 - 5 - 0.5) and t[1, 1] == pytest.approx(10 - 5 - 3)
    assert t[2, 0] == pytest.approx(10 - 5 - 0) and t[2, 1] == pytest.approx(20 - 5 - 1)


def test_no_lumen_no_clearance():
    r = follow(load_trajectory("curve"), solver="optimal")
    assert r.clearance is None
    s = r.summary.to_dict()
    assert "min_clearance_mm" not in s and "wall_touch_steps" not in s
    assert "clearance_mm" not in r.to_dict()["steps"][0]


def test_touches_are_the_steps_where_some_point_reaches_the_wall():
    tr = load_trajectory("curve", angle=180.0)
    base = follow(tr, solver="seed")
    pe = base.point_errors
    # a lumen whose wall sits at 3 mm from the path (plus the robot's radius)
    r = follow(with_lumen(tr, 2 * (5.0 + 3.0)), solver="seed")
    n, f = r.robot.modules, r.robot.feed_divisor
    scored = np.array([[i - (n - j) * f >= 0 for j in range(n + 1)] for i in range(r.steps)])
    want = [i + 1 for i in range(r.steps) if np.any(scored[i] & (pe[i] >= 3.0))]
    assert want  # the seed solver strays 3 mm on this curve
    s = r.summary.to_dict()
    assert s["wall_touch_steps"] == want
    assert s["min_clearance_mm"] == pytest.approx(3.0 - pe[scored].max())
    i = s["min_clearance_step"] - 1
    per = r.clearance.per_step
    assert per[i] == pytest.approx(s["min_clearance_mm"])
    doc = r.to_dict()
    assert doc["steps"][i]["clearance_mm"] == pytest.approx(s["min_clearance_mm"])
    assert doc["trajectory"]["lumen"][0] == pytest.approx(16.0)
    # the same robot in a wider lumen touches nothing
    wide = follow(with_lumen(load_trajectory("curve", angle=180.0), 2 * (5.0 + pe.max() + 0.01)), solver="seed")
    assert wide.summary.to_dict()["wall_touch_steps"] == []


def test_exactly_at_the_wall_counts_as_touching():
    tr = with_lumen(load_trajectory("line", length=40.0), 10.0)  # lumen radius = robot radius
    r = follow(tr, solver="optimal")
    assert r.point_errors.max() < 1e-9
    assert r.summary.to_dict()["min_clearance_mm"] == pytest.approx(0.0, abs=1e-9)
    assert r.summary.to_dict()["wall_touch_steps"] == list(range(1, r.steps + 1))


def test_colon_lumen_comes_from_the_trajectory_file():
    tr = load_trajectory("colon")
    sec: list[int] = []
    colon(tr.points[1, 0] - tr.points[0, 0], sec)
    sec = np.array(sec[:tr.points.shape[0]])
    rectum = sec == COLON_SECTIONS.index("rectum")
    assert np.all(tr.lumen[rectum] == 30.0) and np.all(tr.lumen[~rectum] == 45.0)
    r = follow(tr, solver="optimal")
    t = r.clearance.table
    n = r.robot.modules
    i = 15  # the tip (scored against point 15) is in the rectum's 30 mm
    assert rectum[i] and t[i, n] == pytest.approx(15.0 - 5.0 - r.point_errors[i, n])
    j = 400
    assert not rectum[j] and t[j, n] == pytest.approx(22.5 - 5.0 - r.point_errors[j, n])


def test_step_ranges():
    assert step_ranges([]) == "none"
    assert step_ranges([4]) == "4"
    assert step_ranges([1, 2, 3, 7, 9, 10]) == "1-3, 7, 9-10"


def test_plots_mark_the_touches(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from bhr.plots import clearance_figure, error_figure, path_figure, save_run_plots

    r = follow(with_lumen(load_trajectory("curve", angle=180.0), 16.0), solver="seed", body_modules=8)
    assert r.summary.to_dict()["wall_touch_steps"]
    fig = error_figure(r, "position")
    labels = [p.get_label() for ax in fig.axes for p in ax.patches]
    assert "wall touched" in labels
    fig = path_figure(r)
    assert "wall touched" in [ln.get_label() for ln in fig.axes[0].lines]
    fig = clearance_figure(r)
    assert any(ln.get_label().startswith("minimum") for ln in fig.axes[0].lines)
    files = save_run_plots(r, tmp_path)
    assert {p.name for p in files} >= {"clearance.png", "body_errors.png", "position_errors.png", "path.png"}
    clean = follow(load_trajectory("curve"), solver="seed")
    fig = error_figure(clean, "position")
    assert "wall touched" not in [p.get_label() for ax in fig.axes for p in ax.patches]


def test_follow_cli_reports_clearance(run_bhr, tmp_path):
    out = run_bhr("follow", "--traj", "colon", "--solver", "optimal", "--no-plots", "--out", tmp_path / "o")
    assert out.returncode == 0, out.stderr
    assert "Lumen clearance: minimum" in out.stdout and "Wall touched at 0 steps." in out.stdout
    doc = json.loads((tmp_path / "o" / "run.json").read_text())
    assert doc["summary"]["min_clearance_mm"] > 0 and doc["summary"]["wall_touch_steps"] == []
