"""`--solver thesis` is the thesis's algorithm; `seed`, its former name, gives the same results bit for bit."""
import json

import numpy as np
import pytest

import bhr
from bhr.solvers import available, canonical, get_solver
from bhr.model.robot import Robot


def test_seed_is_an_alias_of_thesis():
    assert canonical("seed") == "thesis" and canonical("thesis") == "thesis"
    assert "thesis" in available() and "seed" not in available()
    assert type(get_solver("seed", Robot())) is type(get_solver("thesis", Robot()))


@pytest.mark.parametrize("traj", ["curve", "spiral"])
def test_follow_thesis_equals_seed_bit_for_bit(traj):
    pts = bhr.trajectory(traj)
    a, b = bhr.follow(pts, solver="thesis"), bhr.follow(pts, solver="seed")
    assert np.array_equal(a.points, b.points) and np.array_equal(a.point_errors, b.point_errors)
    assert np.array_equal(a.orientation_errors, b.orientation_errors) and np.array_equal(a.codes, b.codes)


def test_cli_follow_thesis_equals_seed(tmp_path, run_bhr):
    docs = []
    for name in ("thesis", "seed"):
        r = run_bhr("follow", "--traj", "curve", "--solver", name, "--no-plots", "--json", str(tmp_path / f"{name}.json"),
                    "--out", str(tmp_path / name))
        assert r.returncode == 0, r.stderr
        docs.append(json.loads((tmp_path / f"{name}.json").read_text()))
    assert docs[0]["steps"] == docs[1]["steps"]
    assert docs[0]["summary"]["tip_final_error_mm"] == docs[1]["summary"]["tip_final_error_mm"]
