"""bhr replay: a saved run comes back exactly, is redrawn and re-animated without solving, and a wrong
file gets one clear line."""
from __future__ import annotations

import json
import os
import subprocess

import numpy as np
import pytest
from PIL import Image

from bhr.model._generators import load_trajectory
from bhr.output._animate import frame_steps, frame_view
from bhr.output._atomic import write_json
from bhr._run.driver import FollowResult, follow, load_run
from bhr._settings.errors import BhrError
from tests.cli.test_animate import check_frame, gif_frame
from tests.conftest import bhr_exe, snapshot


@pytest.fixture(scope="module")
def curve_run():
    return follow(load_trajectory("curve", angle=180.0))


def assert_same_run(a: FollowResult, b: FollowResult) -> None:
    assert a.steps == b.steps and a.solver == b.solver and a.robot == b.robot
    assert a.trajectory.name == b.trajectory.name and a.trajectory.params == b.trajectory.params
    np.testing.assert_array_equal(a.trajectory.points, b.trajectory.points)
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.point_errors_mm, b.point_errors_mm)
    np.testing.assert_array_equal(a.orientation_errors_deg, b.orientation_errors_deg)
    np.testing.assert_array_equal(a.iterations, b.iterations)
    if a.codes is None:
        assert b.codes is None
    else:
        np.testing.assert_array_equal(a.codes, b.codes)
    assert a.warnings == b.warnings


@pytest.mark.parametrize("solver", ["seed", "fabrik"])
def test_json_round_trip_is_exact(tmp_path, solver):
    run = follow(load_trajectory("spiral", turns=0.5), solver=solver, modules=4, alpha=12.0)
    write_json(tmp_path / "run.json", run.to_dict())
    back = load_run(tmp_path / "run.json")
    assert_same_run(run, back)
    assert back.to_dict() == json.loads((tmp_path / "run.json").read_text())
    assert back.summary.to_dict() == run.summary.to_dict()


def test_tight_curve_keeps_its_warning(tmp_path):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = follow(load_trajectory("curve", radius=40.0))
    assert run.warnings
    assert FollowResult.from_json(run.to_dict()).warnings == run.warnings


def test_replay_redraws_the_figures_of_follow(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "curve", "--out", "run")
    assert res.returncode == 0, res.stderr
    res = run_bhr_in_process("replay", "run/run.json", "--out", "again")
    assert res.returncode == 0, res.stderr
    for name in ("position_errors.png", "orientation_errors.png", "global_errors.png", "path.png"):
        a = np.asarray(Image.open(tmp_path / "run" / name).convert("RGB"))
        b = np.asarray(Image.open(tmp_path / "again" / name).convert("RGB"))
        assert a.shape == b.shape and np.array_equal(a, b), name
    assert "Wrote again/position_errors.png" in res.stdout


def test_replay_restores_everything_a_run_wrote(run_bhr_in_process, tmp_path):
    """A body run along a path with a lumen: replay draws clearance.png and body_errors.png too, the same."""
    res = run_bhr_in_process("follow", "--traj", "colon", "--body-modules", "20", "--out", "run")
    assert res.returncode == 0, res.stderr
    drawn = sorted(p.name for p in (tmp_path / "run").glob("*.png"))
    assert "clearance.png" in drawn and "body_errors.png" in drawn
    back = load_run(tmp_path / "run" / "run.json")
    assert back.body is not None and back.body.modules == 15 and back.trajectory.lumen is not None
    doc = json.loads((tmp_path / "run" / "run.json").read_text())
    assert back.to_dict()["steps"] == doc["steps"]
    for key in ("body_points_max_error_mm", "min_clearance_mm", "wall_touch_steps", "rmse_point_mm"):
        assert back.summary.to_dict()[key] == doc["summary"][key], key
    res = run_bhr_in_process("replay", "run/run.json", "--out", "again")
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in (tmp_path / "again").glob("*.png")) == drawn
    for name in drawn:
        a = np.asarray(Image.open(tmp_path / "run" / name).convert("RGB"))
        b = np.asarray(Image.open(tmp_path / "again" / name).convert("RGB"))
        assert a.shape == b.shape and np.array_equal(a, b), name


def test_replay_names_the_animation_once(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", "run")
    assert res.returncode == 0, res.stderr
    res = run_bhr_in_process("replay", "run/run.json", "--animate", "a.gif")
    assert res.returncode == 0, res.stderr
    assert (res.stdout + res.stderr).count("a.gif") == 1  # the one Animation line (piped: no progress label)
    assert "Wrote" not in res.stdout


def test_replay_uses_the_saved_poses_not_a_new_solve(tmp_path, curve_run):
    """A run whose poses were edited by hand is drawn as edited: replay never solves."""
    doc = curve_run.to_dict()
    doc["solver"] = "no-such-solver"  # solving again would fail on this name
    for st in doc["steps"]:
        st["points"] = [[x, y + 25.0, z] for x, y, z in st["points"]]
    write_json(tmp_path / "edited.json", doc)
    edited = load_run(tmp_path / "edited.json")
    res = subprocess.run(bhr_exe() + ["replay", "edited.json", "--animate", "edited.gif", "--stride", "9"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, MPLBACKEND="Agg"))
    assert res.returncode == 0, res.stderr
    steps = frame_steps(edited.steps, 9)
    view = frame_view(edited)
    with Image.open(tmp_path / "edited.gif") as im:
        assert im.n_frames == len(steps)
        for k in (0, len(steps) // 2, len(steps) - 1):
            check_frame(gif_frame(im, k), edited, view, steps[k])
    assert not (tmp_path / "edited").exists() and sorted(p.name for p in tmp_path.iterdir()) == [
        "edited.gif", "edited.json"]  # --animate alone writes no figures


def test_replay_animation_matches_follow_animation(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "line", "--length", "40", "--no-plots", "--out", "run", "--animate", "a.gif")
    assert res.returncode == 0, res.stderr
    res = run_bhr_in_process("replay", "run/run.json", "--animate", "b.gif")
    assert res.returncode == 0, res.stderr
    with Image.open(tmp_path / "a.gif") as a, Image.open(tmp_path / "b.gif") as b:
        assert a.n_frames == b.n_frames == 21
        for k in range(a.n_frames):
            assert np.array_equal(gif_frame(a, k), gif_frame(b, k)), k


def test_replay_reads_standard_input_and_draws_a_chosen_step(tmp_path, curve_run):
    text = json.dumps(curve_run.to_dict())
    res = subprocess.run(bhr_exe() + ["replay", "-", "--out", "figs", "--step", "40"], input=text, cwd=tmp_path,
                         capture_output=True, text=True, timeout=300, env=dict(os.environ, MPLBACKEND="Agg"))
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == [
        "global_errors.png", "manifest.json", "orientation_errors.png", "path-step40.png", "position_errors.png",
        "view.html"]
    from bhr.output._path_plot import path_figure

    img = np.asarray(Image.open(tmp_path / "figs" / "path-step40.png").convert("RGB"))
    fig = path_figure(curve_run, 39)
    fig.set_dpi(110)  # save_figure's dpi
    fig.canvas.draw()
    assert img.shape[1::-1] == fig.canvas.get_width_height()
    check_frame(img, curve_run, _Still(fig), 39)


class _Still:
    """A drawn path figure seen as the frame checks see a view (one pose, nothing to redraw)."""

    planar = True

    def __init__(self, fig) -> None:
        self.fig, self.ax = fig, fig.axes[0]

    def draw(self, step: int) -> None:
        pass


def _doc(run) -> dict:
    return run.to_dict()


def _corrupt(kind: str, doc: dict) -> str:
    if kind == "truncated":
        return json.dumps(doc)[:5000]
    if kind == "list":
        return "[1, 2, 3]"
    if kind == "no steps":
        doc = dict(doc)
        del doc["steps"]
    elif kind == "short points":
        doc["steps"][2]["points"] = doc["steps"][2]["points"][:-1]
    elif kind == "nan":
        doc["steps"][4]["points"][1][0] = float("nan")
    elif kind == "text point":
        doc["steps"][4]["points"][1][0] = "x"
    elif kind == "robot":
        doc["robot"]["modules"] = 0
    elif kind == "iterations":
        doc["steps"][0]["iterations"] = 2.5
    elif kind == "codes":
        doc["steps"][7]["codes"] = [3, 6]
    elif kind == "too many steps":
        doc["trajectory"]["points"] = doc["trajectory"]["points"][:10]
    return json.dumps(doc)


@pytest.mark.parametrize("kind, message", [
    ("truncated", "run.json: not valid JSON (line 1"),
    ("list", "run.json: not a bhr run"),
    ("no steps", "run.json: not a bhr run (it needs 'trajectory', 'robot', 'solver' and 'steps')"),
    ("short points", "run.json: step 3 points must be 6 x 3 numbers, got shape 5 x 3"),
    ("nan", "run.json: step 5 points must be finite numbers"),
    ("text point", "run.json: step 5 points must be numbers"),
    ("robot", "run.json: robot: modules must be greater than 0"),
    ("iterations", "iterations must be a whole number"),
    ("codes", "run.json: step 8 codes must be 5 of the stable codes"),
    ("too many steps", "run.json: 140 steps but only 10 trajectory points"),
])
def test_wrong_run_file_gets_one_line(run_bhr_in_process, tmp_path, curve_run, kind, message):
    bad = tmp_path / "run.json"
    bad.write_text(_corrupt(kind, _doc(curve_run)))
    before = snapshot(tmp_path)
    res = run_bhr_in_process("replay", "run.json", "--animate", "out.gif")
    assert res.returncode != 0
    assert message in res.stderr, res.stderr
    assert "give a run.json written by 'bhr follow'" in res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert snapshot(tmp_path) == before
    with pytest.raises(BhrError, match="give a run.json"):
        load_run(bad)


@pytest.mark.parametrize("args, message", [
    (["nothing.json"], "no such run file nothing.json"),
    (["."], "is a folder; give the run.json inside it"),
    (["run.json", "--animate", "x.webm"], "give a file ending in .gif"),
    (["run.json", "--step", "500"], "step 500 is past the end of the run (140 steps)"),
])
def test_replay_refusals(run_bhr_in_process, tmp_path, curve_run, args, message):
    write_json(tmp_path / "run.json", curve_run.to_dict())
    before = snapshot(tmp_path)
    res = run_bhr_in_process("replay", *args)
    assert res.returncode != 0
    assert message in res.stderr, res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert snapshot(tmp_path) == before
