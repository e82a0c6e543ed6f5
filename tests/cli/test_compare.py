"""bhr compare: several solvers on one trajectory, printed and plotted together."""
from __future__ import annotations

import json

import numpy as np
import pytest

from bhr.model._generators import load_trajectory
from bhr.model._robot import Robot
from bhr._run.driver import follow
from bhr._settings.errors import BhrError
from bhr._studies.compare import compare_rows, compare_runs, format_table


def test_rows_are_the_runs_numbers():
    tr = load_trajectory("curve")
    runs = compare_runs(tr, ["seed", "optimal"], Robot(), solver_options={"optimal": {"lookahead": 3}})
    rows = compare_rows(runs)
    seed = follow(tr, solver="seed").point_errors_mm.max()
    opt = follow(tr, solver="optimal", solver_options={"lookahead": 3}).point_errors_mm.max()
    assert rows[0]["ratio_to_first"] == 1.0
    assert rows[0]["points_max_error_mm"] == pytest.approx(seed)
    assert rows[1]["points_max_error_mm"] == pytest.approx(opt)
    assert rows[1]["ratio_to_first"] == pytest.approx(opt / seed)
    text = "\n".join(format_table(runs))
    assert "x thesis" in text and "seed" not in text and f"{opt / seed:.3f}" in text


def test_bad_solver_lists():
    tr = load_trajectory("curve")
    with pytest.raises(BhrError, match="at least two"):
        compare_runs(tr, ["seed"], Robot())
    with pytest.raises(BhrError, match="twice"):
        compare_runs(tr, ["seed", "seed"], Robot())
    with pytest.raises(BhrError, match="unknown solver"):
        compare_runs(tr, ["seed", "nope"], Robot())


def test_every_solver_is_checked_before_the_first_run(monkeypatch):
    # a solver that cannot run this trajectory (lumen on a path without one) is refused before the others run
    import bhr._studies.compare as cmp

    ran = []
    monkeypatch.setattr(cmp, "follow", lambda *a, **k: ran.append(k.get("solver")))
    with pytest.raises(BhrError, match="lumen needs a trajectory with a lumen"):
        cmp.compare_runs(load_trajectory("curve"), ["seed", "lumen"], Robot())
    with pytest.raises(BhrError, match="lookahead"):
        cmp.compare_runs(load_trajectory("curve"), ["seed", "optimal"], Robot(),
                         solver_options={"optimal": {"lookahead": -1}})
    assert ran == []


def test_cli_prints_and_plots(run_bhr_in_process, tmp_path):
    out = run_bhr_in_process("compare", "--traj", "curve", "--angle", "180", "--solver", "seed", "--solver", "optimal",
                  "--out", tmp_path / "c", "--json", tmp_path / "c.json")
    assert out.returncode == 0, out.stderr
    # the thesis's solver given by its old name is shown by its one name
    assert "thesis" in out.stdout and "optimal" in out.stdout and "x thesis" in out.stdout
    assert "seed" not in out.stdout
    png = tmp_path / "c" / "compare.png"
    assert png.read_bytes()[:4] == b"\x89PNG"
    doc = json.loads((tmp_path / "c.json").read_text())
    assert [r["solver"] for r in doc["rows"]] == ["thesis", "optimal"]
    assert doc["bhr_version"] == __import__("bhr").__version__
    # each solver's run is kept as bhr follow writes it, replayable and streamable
    for name in ("thesis", "optimal"):
        run = json.loads((tmp_path / "c" / name / "run.json").read_text())
        assert run["solver"] == name and len(run["steps"]) == len(doc["runs"][0]["points_max_error_mm"])
        codes = (tmp_path / "c" / name / "codes.csv").read_text().splitlines()
        assert len(codes) == len(run["steps"]) + 1
    replay = run_bhr_in_process("replay", tmp_path / "c" / "optimal" / "run.json", "--out", tmp_path / "again")
    assert replay.returncode == 0, replay.stderr
    tr = load_trajectory("curve", angle=180.0)
    seed = follow(tr, solver="seed")
    np.testing.assert_allclose(doc["runs"][0]["points_max_error_mm"], seed.point_errors_mm.max(axis=1))
    assert doc["rows"][1]["ratio_to_first"] == pytest.approx(
        max(doc["runs"][1]["points_max_error_mm"]) / max(doc["runs"][0]["points_max_error_mm"]))


def test_cli_with_lumen_and_body(run_bhr_in_process, tmp_path):
    out = run_bhr_in_process("compare", "--traj", "colon", "--body-modules", "20", "--no-plots", "--json", "-")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert all("min_clearance_mm" in r and "body_points_max_error_mm" in r for r in doc["rows"])
    assert "clear mm" in out.stderr  # the table goes to stderr when the JSON is on stdout
    assert not (tmp_path / "bhr-out").exists()  # --json - --no-plots: standard output is the whole output


def test_no_plots_keeps_every_solver_run_as_follow_does(run_bhr_in_process, tmp_path):
    """The documented `bhr compare ... --no-plots` keeps each solver's run (for replay, plan, stream), as
    `bhr follow --no-plots` keeps its run: it wrote nothing at all."""
    out = run_bhr_in_process("compare", "--traj", "curve", "--solver", "thesis", "--solver", "optimal", "--no-plots")
    assert out.returncode == 0, out.stderr
    (folder,) = (tmp_path / "bhr-out").glob("compare-curve-*")
    assert (tmp_path / "bhr-out" / "latest").resolve() == folder.resolve()
    for name in ("thesis", "optimal"):
        assert (folder / name / "run.json").is_file() and (folder / name / "codes.csv").is_file()
    assert not (folder / "compare.png").exists()
    assert f"Wrote bhr-out/{folder.name}/thesis" in out.stdout
    plan = run_bhr_in_process("plan", "--codes", f"bhr-out/{folder.name}/optimal/codes.csv", "--no-plots")
    assert plan.returncode == 0, plan.stderr



def test_after_compare_the_latest_hints_lead_to_its_runs(run_bhr_in_process, tmp_path):
    """`bhr plan --codes bhr-out/latest/codes.csv` (bhr plan --help's example) after a compare: latest is the
    compare's folder, whose runs are one folder down; the refusal names them, and the file it names runs."""
    out = run_bhr_in_process("compare", "--traj", "line", "--solver", "thesis", "--solver", "fabrik", "--no-plots")
    assert out.returncode == 0, out.stderr
    folder = (tmp_path / "bhr-out" / "latest").resolve().name
    plan = run_bhr_in_process("plan", "--codes", "bhr-out/latest/codes.csv", "--no-plots")
    assert plan.returncode == 1
    assert (f"(bhr-out/latest points to {folder}, which has none; its runs have bhr-out/latest/thesis/codes.csv)"
            in plan.stderr), plan.stderr  # fabrik gives no codes
    assert run_bhr_in_process("plan", "--codes", "bhr-out/latest/thesis/codes.csv", "--no-plots").returncode == 0
    replay = run_bhr_in_process("replay", "bhr-out/latest/run.json", "--out", "r")
    assert replay.returncode == 1
    assert ("its runs have bhr-out/latest/fabrik/run.json, bhr-out/latest/thesis/run.json)" in replay.stderr), \
        replay.stderr


def test_plan_and_replay_of_a_compared_run_keep_the_compare_folder_whole(run_bhr_in_process, tmp_path):
    """`bhr plan --codes bhr-out/latest/thesis/codes.csv` after a compare wrote thermal.png into the compare's
    folder unlisted, and the compare's own rerun then refused it ('holds thesis/thermal-auto-10hz.png, which no bhr run
    wrote'). The figures of plan and replay join that folder, listed, and its rerun keeps them."""
    args = ("compare", "--traj", "line", "--solver", "thesis", "--solver", "fabrik", "--no-plots")
    assert run_bhr_in_process(*args).returncode == 0
    folder = (tmp_path / "bhr-out" / "latest").resolve()
    plan = run_bhr_in_process("plan", "--codes", "bhr-out/latest/thesis/codes.csv")
    assert plan.returncode == 0 and plan.stderr == "Wrote bhr-out/latest/thesis/thermal-auto-10hz.png\n", plan.stderr
    replay = run_bhr_in_process("replay", "bhr-out/latest/fabrik/run.json")
    assert replay.returncode == 0, replay.stderr
    assert "Wrote bhr-out/latest/fabrik/position_errors.png" in replay.stdout
    man = json.loads((folder / "manifest.json").read_text())
    assert {"thesis/thermal-auto-10hz.png", "fabrik/path.png", "fabrik/view.html"} <= set(man["files"])
    assert man["made_by"] == "compare"
    again = run_bhr_in_process(*args)
    assert again.returncode == 0, again.stderr
    assert (folder / "thesis" / "thermal-auto-10hz.png").is_file() and (folder / "fabrik" / "path.png").is_file()


def test_an_anatomical_colon_names_the_folder_as_follow_does(run_bhr_in_process, tmp_path):
    out = run_bhr_in_process("compare", "--traj", "anatomy", "--seed", "4", "--solver", "thesis", "--solver", "fabrik",
                  "--no-plots", "--modules", "3")
    assert out.returncode == 0, out.stderr
    assert [p.name.rsplit("-", 1)[0] for p in (tmp_path / "bhr-out").glob("compare-*")] == ["compare-anatomy-4"]


@pytest.mark.parametrize("args,word", [
    (["--solver", "seed"], "at least two"),
    (["--solver", "seed", "--solver", "seed"], "twice"),
    (["--solver", "seed", "--solver", "bogus"], "unknown solver"),
    (["--solver", "seed", "--solver", "fabrik", "--lookahead", "3"], "optimal"),
])
def test_cli_bad_input_is_one_line(run_bhr_in_process, tmp_path, args, word):
    out = run_bhr_in_process("compare", "--traj", "curve", *args, "--out", tmp_path / "c")
    assert out.returncode != 0
    assert len(out.stderr.strip().splitlines()) == 1 and word in out.stderr
    assert not (tmp_path / "c").exists()


def test_cli_checks_the_output_folder_first(run_bhr_in_process, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("keep")
    out = run_bhr_in_process("compare", "--traj", "colon", "--out", blocker / "sub")
    assert out.returncode != 0 and len(out.stderr.strip().splitlines()) == 1
    assert blocker.read_text() == "keep"
