"""The command line: help, bad input for solve/fk gets one clear line and a non-zero exit."""
import json

import pytest

from tests.conftest import snapshot


def test_help_lists_commands(run_bhr_in_process):
    res = run_bhr_in_process("--help")
    assert res.returncode == 0
    for cmd in ("solve", "follow", "fk"):
        assert cmd in res.stdout


def test_bhr_alone_shows_the_help_not_an_error(run_bhr_in_process):
    """`bhr` with nothing after it printed "Error: Usage: ..." and "(see 'bhr --help')" after the whole help."""
    res = run_bhr_in_process()
    assert res.returncode != 0 and res.stdout == ""
    assert res.stderr == run_bhr_in_process("--help").stdout  # the help itself, as `bhr --help` prints it


@pytest.mark.parametrize("args, message", [
    (["solve", "--modules", "0", "--target", "1", "2", "3"], "modules must be greater than 0"),
    (["solve", "--module-length", "-2", "--target", "1", "2", "3"], "module length must be greater than 0"),
    (["solve", "--target", "1", "x", "3"], "must be a number written with plain digits"),
    (["solve", "--target", "1", "2", "3", "--solver", "nope"], "unknown solver 'nope'"),
    (["solve", "--target", "1", "2", "3", "--solver", "ccd", "--orientation", "1", "0", "0"], "cannot aim the tip"),
    (["solve", "--target", "1", "2", "3", "--orientation", "0", "0", "0"], "non-zero vector"),
    (["solve", "--target", "1", "2", "3", "--solver", "seed", "--max-iter", "5"], "raise --max-iter"),
    (["fk", "--codes", "3,5,0"], "code 5 for module 2 is not a stable actuator code"),
    (["fk", "--codes", "3,a"], "not a whole number"),
    (["follow", "--traj", "nowhere"], "unknown trajectory 'nowhere'"),
    (["follow", "--traj", "curve", "--pitch", "3"], "no parameter 'pitch'"),
    (["follow", "--traj", "curve", "--radius", "-5"], "radius must be greater than 0"),
])
def test_bad_input_one_line(run_bhr_in_process, tmp_path, args, message):
    before = snapshot(tmp_path)
    res = run_bhr_in_process(*args)
    assert res.returncode != 0
    assert message in res.stderr
    assert "Traceback" not in res.stderr
    assert len(res.stderr.strip().splitlines()) <= 3
    assert snapshot(tmp_path) == before


def test_solve_says_out_of_reach_in_text_and_json(run_bhr_in_process):
    res = run_bhr_in_process("solve", "--target", "100", "100", "100")
    assert res.returncode == 0, res.stderr
    assert "out of reach: the target is 173.2 mm from the base but the chain is 10 mm long" in res.stdout
    res = run_bhr_in_process("solve", "--target", "100", "100", "100", "--json", "-")
    doc = json.loads(res.stdout)
    assert doc["success"] is False and doc["status"] == "out of reach"


def test_solve_help_lists_every_solver_by_its_one_name(run_bhr_in_process):
    from bhr.solvers import available

    text = " ".join(run_bhr_in_process("solve", "--help").stdout.split())
    for name in available():
        assert name in text
    assert "seed" not in text
