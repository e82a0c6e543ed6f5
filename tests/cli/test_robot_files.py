"""Robot description files: the shipped default, keys, overrides, the code table and the link: the tests that run the bhr command."""
from __future__ import annotations

import json
import math

import pytest

from bhr.model._robotfile import (
    default_robot_file,
)
from tests.unit.test_robot_files import write  # noqa: F401


def test_follow_with_the_default_file_reproduces_the_thesis(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "curve", "--robot", default_robot_file(), "--no-plots", "--json", "-")
    assert res.returncode == 0, res.stderr
    assert round(json.loads(res.stdout)["summary"]["tip_final_error_mm"], 4) == 0.9099


def test_file_values_apply_and_options_override_them(run_bhr_in_process, tmp_path):
    write(tmp_path / "r.toml", "modules = 3\nmodule_length = 4.0\nalpha = 20\n")
    res = run_bhr_in_process("fk", "--codes", "0,0,3", "--robot", "r.toml", "--json", "-")
    assert res.returncode == 0, res.stderr
    pts = json.loads(res.stdout)["points"]
    assert len(pts) == 4 and pts[3][0] == pytest.approx(8 + 4 * math.cos(math.radians(20)))
    res = run_bhr_in_process("fk", "--codes", "0,0,3", "--robot", "r.toml", "--module-length", "5", "--alpha", "10",
                  "--json", "-")
    pts = json.loads(res.stdout)["points"]
    assert pts[3][0] == pytest.approx(10 + 5 * math.cos(math.radians(10)))
    res = run_bhr_in_process("solve", "--target", "3", "4", "0", "--robot", "r.toml", "--modules", "2", "--json", "-")
    assert res.returncode == 0, res.stderr
    assert len(json.loads(res.stdout)["points"]) == 3
    # the file's module count is kept when the codes disagree with it: one clear line
    res = run_bhr_in_process("fk", "--codes", "0,3", "--robot", "r.toml")
    assert res.returncode != 0 and "expected 3 codes" in res.stderr and len(res.stderr.splitlines()) == 1


def test_stroke_and_lever_in_the_file_and_alpha_on_the_command_line(run_bhr_in_process, tmp_path):
    write(tmp_path / "r.toml", "stroke = 1.0\nlever = 4.0\n")
    res = run_bhr_in_process("fk", "--codes", "3,0,0,0,0", "--robot", "r.toml", "--json", "-")
    a = math.asin(0.25)
    assert json.loads(res.stdout)["points"][2][0] == pytest.approx(20 * math.cos(a))  # module 1 tilts by alpha
    res = run_bhr_in_process("fk", "--codes", "3,0,0,0,0", "--robot", "r.toml", "--alpha", "30", "--json", "-")
    assert json.loads(res.stdout)["points"][2][0] == pytest.approx(20 * math.cos(math.radians(30)))


def test_a_run_json_reused_as_robot_on_its_own_trajectory_reruns_in_place(run_bhr_in_process, tmp_path):
    """`bhr follow --traj T --robot bhr-out/latest/run.json` right after `bhr follow --traj T ...`: the same settings
    name the same folder, which holds that run.json; it was refused as 'an input of this run'. The rerun makes the
    same run again; an explicit --out onto the input's folder is still refused."""
    first = run_bhr_in_process("follow", "--traj", "curve", "--modules", "6", "--alpha", "12", "--no-plots")
    assert first.returncode == 0, first.stderr
    (folder,) = (tmp_path / "bhr-out").glob("curve-thesis-*")
    before = json.loads((folder / "run.json").read_text())
    again = run_bhr_in_process("follow", "--traj", "curve", "--robot", "bhr-out/latest/run.json", "--no-plots")
    assert again.returncode == 0, again.stderr
    assert [p.name for p in (tmp_path / "bhr-out").glob("curve-thesis-*")] == [folder.name]  # the same settings
    after = json.loads((folder / "run.json").read_text())
    assert after["robot"] == before["robot"] and after["summary"] == before["summary"]
    out = run_bhr_in_process("follow", "--traj", "line", "--robot", f"bhr-out/{folder.name}/run.json", "--out",
                  f"bhr-out/{folder.name}")
    assert out.returncode == 1 and "an input of this run" in out.stderr
