"""bhr traverse: designs x anatomical colons, locally and on a real Dask LocalCluster, its outputs and page: the tests that run the bhr command."""
from __future__ import annotations

import json
import os
import pty
import subprocess

import pytest

from tests.conftest import REPO, bhr_exe, bhr_in_process
from tests.unit.test_traverse import PNG, follow_summary, rows_of, small_study  # noqa: F401


def test_command_answers_the_question(small_study):
    cwd, proc = small_study
    out = cwd / "study"
    assert proc.stderr == ""  # piped: no progress bar, no noise
    designs = rows_of(out / "designs.csv")
    runs = rows_of(out / "runs.csv")
    assert len(designs) == 4 and len(runs) == 8
    expected = {}
    for solver in ("seed", "lumen"):  # the calibrated colons' narrow anal canal: only the lumen solver gets through
        for alpha in (20, 30):
            passed = [len(follow_summary(seed, solver, alpha=alpha, module_length=5)["wall_touch_steps"]) == 0
                      for seed in (3, 7)]
            expected[("thesis" if solver == "seed" else solver, alpha)] = sum(passed) / 2  # shown by its one name
    got = {(d["solver"], int(d["alpha"])): float(d["pass_rate"]) for d in designs}
    assert got == expected
    assert sorted(expected.values()) == [0, 0, 0.5, 1]  # the fixture has every kind of design
    doc = json.loads((out / "study.json").read_text())
    best = next(d for d in doc["designs"] if d["design"] == doc["answer"])
    assert best["pass_rate"] == max(expected.values())
    assert f"best: design #{best['design']} (solver={best['solver']}, alpha={best['alpha']}, module_length=5)" \
        in proc.stdout
    assert "traverse at least 95% of the 2 colons" in proc.stdout
    assert doc["colons"] == [3, 7] and doc["target_pass"] == 0.95
    for name in ("passrate.png", "worst-colon.png"):
        assert (out / name).read_bytes()[:8] == PNG
    assert doc["worst_colon_figure"] == {"design": best["design"], "seed": best["worst_colon"]}
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["designs.csv", "runs.csv", "study.json", "passrate.png", "worst-colon.png", "worst-colon-view.html", "index.html",
         "manifest.json"])
    assert not [p for p in cwd.iterdir() if ".bhr-stage-" in p.name]  # no staging folder left behind
    man = json.loads((out / "manifest.json").read_text())  # written through the one output-folder mechanism
    assert man["command"] == "traverse" and set(man["files"]) == {p.name for p in out.iterdir()} - {"manifest.json"}


def test_no_design_meets_a_target_nothing_reaches(tmp_path):
    proc = bhr_in_process("traverse", "--head-only", "--grid", "alpha=10", "--colons", "3", "--no-plots", "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    s = follow_summary(3, "seed")
    assert s["wall_touch_steps"]  # the thesis robot touches this colon's wall
    assert "No design traverses 95% of the 1 colons; the best, design #1 (solver=thesis, alpha=10), " \
           "traverses 0/1 (0%)" in proc.stdout
    assert json.loads((tmp_path / "o" / "study.json").read_text())["answer"] is None
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["designs.csv", "index.html", "manifest.json",
                                                                  "runs.csv", "study.json"]


def test_progress_bar_on_a_terminal(tmp_path):
    master, slave = pty.openpty()
    try:
        proc = subprocess.run(bhr_exe() + ["traverse", "--head-only", "--grid", "alpha=10", "--colons", "1-2", "--no-plots",
                                           "--jobs", "1", "--out", "o"], cwd=tmp_path, stdout=subprocess.PIPE,
                              stderr=slave, text=True, timeout=600, env=dict(os.environ, MPLBACKEND="Agg"))
        os.close(slave)
        slave = -1
        chunks = []
        while True:
            try:
                data = os.read(master, 65536)
            except OSError:
                break
            if not data:
                break
            chunks.append(data)
    finally:
        if slave >= 0:
            os.close(slave)
        os.close(master)
    err = b"".join(chunks).decode(errors="replace")
    assert proc.returncode == 0
    assert "2 runs (1 designs x 2 colons)" in err and "2/2" in err


@pytest.mark.parametrize("args, msg", [
    (["--colons", "9-2"], "Error: --colons: range 9-2 runs backwards"),
    (["--colons", "1", "--grid", "seed=1,2"], "give their seeds with --colons"),
    (["--colons", "1", "--target-pass", "2"], "--target-pass must be a share"),
    (["--colons", "1", "--grid", "alpha=10", "--x", "seed"], "is not a design axis"),
    (["--colons", "1", "--grid", "alpha=10", "--x", "modules"], "is not a design axis of this study; give --x one"),
    (["--colons", "1", "--grid", "alpha=10", "--head-only", "--y", "reach"],
     "is not a design axis of this study; give --y one"),
    (["--colons", "1", "--grid", "wings=2"], "is not a parameter a sweep can vary"),
    (["--colons", "1", "--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], "exclude each other"),
    (["--colons", "1", "--scheduler", "tcp://127.0.0.1:1"], "cannot connect to the Dask scheduler"),
    # --physics with --no-plots was silently skipped after the whole study ran
    (["--colons", "1", "--physics", "--no-plots"], "--physics replays the worst colon beside its figures"),
    (["--colons", "1", "--head-only", "--grid", "body_modules=60"], "--head-only judges the head alone"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, msg):
    proc = bhr_in_process("traverse", *args, "--out", "o", cwd=tmp_path, timeout=120)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ") and msg in lines[0], proc.stderr
    assert not (tmp_path / "o").exists()


def test_output_folder_that_is_a_file_fails_before_running(tmp_path):
    (tmp_path / "o").write_text("not a folder")
    proc = bhr_in_process("traverse", "--colons", "1", "--out", "o", cwd=tmp_path, timeout=120)
    assert proc.returncode != 0 and proc.stderr.startswith("Error: ") and len(proc.stderr.strip().splitlines()) == 1
    assert (tmp_path / "o").read_text() == "not a folder"


def test_physics_needs_mujoco_before_the_study_runs():
    """`bhr traverse --physics` without MuJoCo ran the whole study, then refused; the check is now made first
    (bhr._studies.physics.check_installed, named by the module; here for a module no machine has)."""
    from bhr._settings.errors import BhrError
    from bhr._studies.physics import check_installed

    check_installed("json")
    from bhr._settings.extras import install_command

    with pytest.raises(BhrError) as err:
        check_installed("bhr_no_such_module")
    assert str(err.value) == ("bhr_no_such_module is not installed; install the physics extra: "
                              + install_command("physics"))


def test_target_pass_help_shows_the_range_a_share_has():
    """The help said 0<=x<=1000000.0, though anything above 1 is refused."""
    proc = bhr_in_process("traverse", "--help", cwd=REPO)
    assert "[default: 0.95; 0<x<=1]" in " ".join(proc.stdout.split())


def test_max_wall_force_judges_each_colon_by_the_physical_replay(tmp_path):
    """--max-wall-force replays every run as the physical robot: runs.csv gets its peak wall force, stretch and
    cecum step, and a colon counts as traversed exactly when the replay says so (tip at the cecum, the wall's load
    never above the threshold) -- whatever the geometric verdict."""
    import csv

    proc = bhr_in_process("traverse", "--grid", "alpha=25", "--grid", "body_modules=12", "--colons", "1", "--solver",
                   "lumen", "--max-wall-force", "9.8", "--no-plots", "--jobs", "1", "--out", "tv", cwd=tmp_path,
                   timeout=1800)
    assert proc.returncode == 0, proc.stderr
    (row,) = list(csv.DictReader((tmp_path / "tv" / "runs.csv").open()))
    assert {"peak_wall_force_n", "wall_stretch_mm", "physical_cecum_step", "physically_traversed"} <= set(row)
    assert row["traversed"] == row["physically_traversed"]
    peak = float(row["peak_wall_force_n"])
    assert peak >= 0.0
    assert (row["traversed"] == "True") == (row["physical_cecum_step"] != "" and peak <= 9.8)


def test_a_study_judged_by_the_replay_varies_the_passive_body(tmp_path):
    """--grid passive_modules=... (and the replay's other options) are design axes of a study judged by the physical
    replay: each design's runs are replayed with its value, and a colonoscope-stiff passive body pressed along the
    same colon loads its wall more than wires that give way; without --max-wall-force, or in a sweep, they are
    refused in one line, as is a passive body with no driven module left."""
    import csv

    proc = bhr_in_process("traverse", "--grid", "alpha=25", "--grid", "module_length=5", "--grid", "body_modules=30",
                          "--grid", "passive_modules=0,25", "--colons", "1", "--solver", "lumen", "--max-wall-force",
                          "9.8", "--no-plots", "--jobs", "1", "--out", "tv", cwd=tmp_path, timeout=1800)
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader((tmp_path / "tv" / "runs.csv").open()))
    assert [r["passive_modules"] for r in rows] == ["0", "25"]
    assert float(rows[1]["peak_wall_force_n"]) > float(rows[0]["peak_wall_force_n"])
    for args, words in [
            (("traverse", "--grid", "body_modules=30", "--grid", "passive_modules=10", "--colons", "1", "--solver",
              "lumen", "--no-plots"), "--max-wall-force"),
            (("traverse", "--grid", "body_modules=30", "--grid", "passive_modules=30", "--colons", "1", "--solver",
              "lumen", "--max-wall-force", "9.8", "--no-plots"), "no driven module"),
            (("sweep", "--traj", "anatomy", "--solver", "lumen", "--grid", "passive_modules=1,2", "--no-plots"),
             "physical replay")]:
        p = bhr_in_process(*args, cwd=tmp_path)
        assert p.returncode != 0 and words in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert "Traceback" not in p.stderr
