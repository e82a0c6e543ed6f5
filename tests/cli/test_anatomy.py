"""Anatomical colons (bhr.model._anatomy): determinism, spacing, published ranges, continuity, files, command line: the tests that run the bhr command."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bhr.model._generators import anatomy_trajectory


def test_follow_an_anatomical_colon_from_the_command_line(run_bhr_in_process, tmp_path):
    r = run_bhr_in_process("follow", "--traj", "anatomy", "--seed", "12", "--no-plots", "--json", "run.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "run.json").read_text())
    tr = anatomy_trajectory(12, 2.0)
    assert doc["trajectory"]["name"] == "anatomy-12" and doc["trajectory"]["params"]["seed"] == 12
    assert np.allclose(doc["trajectory"]["points"], tr.points) and np.allclose(doc["trajectory"]["lumen"], tr.lumen)
    assert len(doc["steps"]) == len(tr.points)
    assert "min_clearance_mm" in doc["summary"]
    (folder,) = (tmp_path / "bhr-out").glob("anatomy-12-thesis-*")  # named for the colon, robot and solver
    assert (folder / "codes.csv").is_file()
    assert "tighter than the robot's minimum turn radius" in r.stderr


@pytest.mark.parametrize("args, msg", [
    (["--seed", "-3"], "seed must be a whole number from 0 to 4294967295, got -3"),
    (["--seed", "2.5"], "must be a whole number written with digits only (no point or exponent), got '2.5'"),
    (["--seed", "5000000000"], "too large"),
    # a seed is written as digits: 1e3 and 3.0 are not guessed at, nor are "_" separators or full-width digits
    (["--seed", "1e3"], "must be a whole number written with digits only (no point or exponent), got '1e3'"),
    (["--seed", "3.0"], "must be a whole number written with digits only (no point or exponent), got '3.0'"),
    (["--seed", "1_000"], "written with plain digits (0-9), got '1_000'"),
    (["--seed", "\uff13"], "written with plain digits (0-9), got '\uff13'"),
    (["--seed", "9" * 400], "must be a whole number of at most 40 characters, got 400 characters"),
    (["--seed", ""], "written with plain digits (0-9), got ''"),
])
def test_bad_seed_on_the_command_line_is_one_line(run_bhr_in_process, args, msg):
    r = run_bhr_in_process("follow", "--traj", "anatomy", *args, "--no-plots")
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ") and msg in lines[0], r.stderr
