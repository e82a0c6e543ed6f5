"""Runs replayed in MuJoCo against the colon wall (bhr.studies.physics, bhr physics): real MuJoCo scenes.

A run whose geometric clearance stays >= 1 mm never touches the simulated wall and the simulated robot
stays within 0.5 mm of bhr's poses; the thesis solver's run into the wall of an anatomical colon touches
it in MuJoCo at the steps bhr reports (within one step).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

import bhr
from bhr.model.generators import load_trajectory
from bhr.model.path import Trajectory
from bhr.model.robot import Robot, forward_kinematics
from bhr.run.body import whole_robot
from bhr.run.driver import BhrWarning
from bhr.studies.physics import replay_physics, scene_xml, whole_chain


def _head(steps: int, solver: str, body_modules=None, seed: int = 7, robot=None):
    tr = load_trajectory("anatomy", seed=seed, feed=robot.feed if robot is not None else 2.0)
    cut = Trajectory(tr.name, tr.points[: steps + 10], dict(tr.params), tr.min_radius, tr.lumen[: steps + 10],
                     tr.source, tr.start_direction, tr.start_point)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)  # the colon turns tighter than the robot can
        run = bhr.follow(cut, solver=solver, body_modules=body_modules, **({"robot": robot} if robot else {}))
    run.points, run.codes = run.points[:steps], run.codes[:steps]
    run.iterations, run.point_errors_mm, run.orientation_errors_deg = (run.iterations[:steps], run.point_errors_mm[:steps],
                                                                run.orientation_errors_deg[:steps])
    if run.body is not None:
        b = run.body
        b.points, b.codes, b.point_errors_mm, b.orientation_errors_deg, b.scored = (
            b.points[:steps], b.codes[:steps], b.point_errors_mm[:steps], b.orientation_errors_deg[:steps], b.scored[:steps])
    return run


def test_whole_chain_reproduces_the_whole_robot():
    run = _head(60, "thesis", body_modules=25)
    roots, frames, codes = whole_chain(run)
    assert codes.shape == (60, 25)
    robot = run.robot.replace(modules=25)
    for i in range(60):
        pts, _ = forward_kinematics(robot, codes[i], roots[i], frames[i])
        assert np.abs(pts - whole_robot(run, i)).max() < 1e-9
    # what codes.csv holds for a run with a body: these codes, every module of the whole robot, rear first
    assert np.array_equal(run.board_codes, codes)


def test_clear_run_never_touches_and_tracks_bhr():
    # through the anal canal (15-16 mm across) and the anorectal flexure: a robot of 5 mm modules and 25 deg tilts
    # that keeps at least 1 mm off the wall there (colon 34; the thesis robot cannot, in any colon)
    run = _head(90, "lumen", seed=34, robot=Robot(alpha=25, module_length=5))
    assert run.clearance.min_mm >= 1.0
    rep = replay_physics(run)
    assert rep.contact_steps == []
    assert rep.max_force_n.max() == 0.0
    assert rep.deviation_mm.max() <= 0.5


def test_run_into_the_wall_touches_at_bhrs_steps():
    run = _head(130, "thesis", seed=4)  # the thesis solver goes into this colon's wall from step 21 (its anorectal flexure)
    touched = run.clearance.touch_steps
    assert touched, "the thesis solver's run should go into this colon's wall"
    rep = replay_physics(run)
    sim = rep.contact_steps
    assert sim
    assert abs(sim[0] - touched[0]) <= 1
    assert all(any(abs(a - b) <= 1 for b in sim) for a in touched)
    assert all(any(abs(a - b) <= 1 for b in touched) for a in sim)
    assert rep.max_force_n.max() > 1.0  # several mm into a 0.7-2.4 N/mm wall


def test_largest_force_converges_in_the_time_step():
    """The run into the wall at the default 16 substeps and at 32: the largest force within 10 % (the wall's
    springs set it, not the contact's softness, which stiffens with the time step), the same contact steps."""
    run = _head(130, "thesis", seed=4)
    fine, finer = replay_physics(run, substeps=16), replay_physics(run, substeps=32)
    a, b = float(fine.max_force_n.max()), float(finer.max_force_n.max())
    assert a > 1.0
    assert abs(a - b) <= 0.1 * b
    assert fine.contact_steps == finer.contact_steps


def test_folded_damping_replays_the_run_into_the_wall_as_mujocos_euler(monkeypatch):
    """The replay with the implicit damping folded into the mass matrix where no contact acts (the default) and with
    MuJoCo's own at every time step: the same contact steps, forces and deviations (to rounding where any
    constraint unfolds it; within 1e-6 N and 1e-4 mm where a joint limit alone is solved with M + h D: 1e-8 N and
    4e-6 mm measured), folded at most time steps and unfolded where a contact starts."""
    from bhr.studies import physics

    run = _head(130, "thesis", seed=4)
    folded = replay_physics(run)
    monkeypatch.setattr(physics, "FOLD_AT_JOINT_LIMITS", False)
    exact = replay_physics(run)
    monkeypatch.setattr(physics, "DAMPING_IN_ARMATURE", False)
    old = replay_physics(run)
    total = 130 * folded.settings["substeps"]
    assert old.settings["time_steps_unfolded"] == total and old.settings["time_steps_redone"] == 0
    assert folded.settings["time_steps_unfolded"] < total / 2 and folded.settings["time_steps_redone"] >= 1
    assert exact.settings["time_steps_unfolded"] < total
    for rep, tol_n, tol_mm in ((exact, 1e-9, 1e-9), (folded, 1e-6, 1e-4)):
        assert rep.contact_steps == old.contact_steps
        assert np.abs(rep.max_force_n - old.max_force_n).max() <= tol_n
        assert np.abs(rep.deviation_mm - old.deviation_mm).max() <= tol_mm


def test_wall_pieces_are_outside_the_lumen():
    """Every box's inner face is at the lumen radius or farther from its ring's centerline point."""
    run = _head(20, "thesis")
    xml, st = scene_xml(run, pieces=8)
    assert st["pieces_per_ring"] == 8 and (st["wall_pieces"] + st["folded_pieces_left_out"]) % 8 == 0
    # each piece on three springs (its normal, along the centerline, around the ring), of the same stiffness
    assert xml.count("<joint type=\"slide\"") == 3 * st["wall_pieces"]
    for axis in ("1 0 0", "0 1 0", "0 0 1"):
        assert xml.count(f"<joint type=\"slide\" axis=\"{axis}\" stiffness=") == st["wall_pieces"]


def test_physics_command_writes_its_set(run_bhr, tmp_path):
    run = _head(40, "thesis")
    (tmp_path / "run.json").write_text(run.to_json())
    r = run_bhr("physics", "run.json", "--out", "phys")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "phys" / "physics.json").read_text())
    assert len(doc["steps"]) == 40 and doc["bhr_version"] == __import__("bhr").__version__
    assert {"max_force_n", "deviation_mm"} <= set(doc["steps"][0])
    assert {"max_force_n", "contact_steps", "max_deviation_mm"} <= set(doc["summary"])
    assert (tmp_path / "phys" / "force.png").stat().st_size > 10000
    assert (tmp_path / "phys" / "view.html").stat().st_size > 1e6


def test_physics_without_out_writes_a_default_folder_named_by_the_run(run_bhr, tmp_path):
    """As every command's, physics's output has a default folder (--out was required: 'Missing option')."""
    run = _head(20, "thesis")
    (tmp_path / "th").mkdir()
    (tmp_path / "th" / "run.json").write_text(run.to_json())
    r = run_bhr("physics", "th/run.json")
    assert r.returncode == 0, r.stderr
    (folder,) = (tmp_path / "bhr-out").glob("physics-th-*")
    assert (tmp_path / "bhr-out" / "latest").resolve() == folder.resolve()
    assert {p.name for p in folder.iterdir()} == {"physics.json", "force.png", "view.html", "manifest.json"}
    assert f"Wrote bhr-out/{folder.name}/physics.json" in r.stdout
    r = run_bhr("physics", "th/run.json", "--wall-stiffness", "0.5")  # other options: another folder
    assert r.returncode == 0, r.stderr
    assert len(list((tmp_path / "bhr-out").glob("physics-th-*"))) == 2
    r = run_bhr("physics", "-", input=run.to_json())
    assert r.returncode == 1 and r.stderr.startswith("Error: give --out DIR for a run read from standard input")


@pytest.mark.parametrize("args,word", [
    (("missing.json", "--out", "p"), "missing.json"),
    (("run.json", "--out", "p", "--wall-stiffness", "0"), "wall"),
    (("run.json", "--out", "p", "--substeps", "x"), "substeps"),
])
def test_physics_bad_input_one_line(run_bhr, tmp_path, args, word):
    (tmp_path / "run.json").write_text("{}")
    r = run_bhr("physics", *args)
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0] and "Traceback" not in r.stderr


def test_run_without_lumen_is_refused(run_bhr, tmp_path):
    run = bhr.follow(bhr.trajectory("line", length=20), solver="thesis")
    (tmp_path / "run.json").write_text(run.to_json())
    r = run_bhr("physics", "run.json", "--out", "p")
    assert r.returncode != 0 and "lumen" in r.stderr and len(r.stderr.strip().splitlines()) == 1
