"""bhr traverse: designs x anatomical colons, locally and on a real Dask LocalCluster, its outputs and page."""
from __future__ import annotations

import csv
import io
import json
import os
import pty
import statistics
import subprocess
import warnings
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

import bhr
from bhr.settings.errors import BhrError
from bhr.run.driver import BhrWarning
from bhr.model.robot import Robot
from bhr.model.generators import load_trajectory
from bhr.studies.traverse import answer, build_study, design_rows, parse_colons, run_study
from tests.conftest import bhr_exe
from tests.test_sweep import dask_cluster  # noqa: F401 - the real LocalCluster fixture

PNG = b"\x89PNG\r\n\x1a\n"
# one design that gets through these colons and one that does not (checked against bhr.follow below)
SMALL = ["--solver", "seed", "--solver", "optimal", "--grid", "alpha=10,30", "--grid", "module_length=5",
         "--colons", "3,7"]


def run_cli(*args, cwd: Path, timeout: float = 900, **kw):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run(bhr_exe() + [str(a) for a in args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=env, **kw)


def rows_of(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


def follow_summary(seed: int, solver: str, **robot) -> dict:
    rb = Robot(**robot)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        return bhr.follow(load_trajectory("anatomy", feed=rb.feed, seed=seed), solver=solver, robot=rb).summary.to_dict()


def penetration(summary: dict) -> float:
    if summary.get("max_penetration_mm") is not None:
        return summary["max_penetration_mm"]
    return max(0.0, -summary["min_clearance_mm"])


# ---------------------------------------------------------------------------------------------- population


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 5000), st.integers(0, 40)), min_size=1, max_size=5))
def test_colons_ranges_and_lists(parts):
    seeds: list[int] = []
    text = []
    for a, n in parts:
        if any(s in seeds for s in range(a, a + n + 1)):
            continue
        seeds.extend(range(a, a + n + 1))
        text.append(f"{a}-{a + n}" if n else f"{a}")
    assert parse_colons(",".join(text)) == tuple(seeds)


@pytest.mark.parametrize("text, msg", [
    ("", "--colons is empty"),
    ("5-1", "runs backwards"),
    ("1-3,2", "lists seed 2 twice"),
    ("a-b", "is not a seed or a range"),
    ("-4", "is not a seed or a range"),
    ("1.5", "is not a seed or a range"),
    ("4294967296", "seeds go from 0 to 4294967295"),
    ("0-200000", "more than 100000 colons"),
])
def test_bad_colons(text, msg):
    with pytest.raises(BhrError, match=msg):
        parse_colons(text)


@pytest.mark.parametrize("grid, kw, msg", [
    ([("seed", (1, 2))], {}, "give their seeds with --colons"),
    ([("radius", (50.0,))], {}, "is a trajectory option"),
    ([], {"target": 0.0}, "--target-pass must be a share"),
    ([], {"target": 1.5}, "--target-pass must be a share"),
    ([], {"solvers": ("nope",)}, "unknown solver 'nope'"),
    ([("alpha", (-5,))], {}, "alpha"),
])
def test_studies_are_checked_before_running(grid, kw, msg):
    with pytest.raises(BhrError, match=msg):
        build_study(grid, "1-3", **kw)


# ---------------------------------------------------------------------------------------------- results


def test_every_run_is_what_follow_gives_and_designs_aggregate_them():
    study = build_study([("alpha", (10, 30)), ("module_length", (5, 10))], "3-5", solvers=("seed",))
    assert study.designs == 4 and len(study) == 12 and study.design_keys == ["solver", "alpha", "module_length"]
    res = run_study(study, jobs=1)
    assert res.clearance_kind in ("geometric", "index-matched") and not res.failed
    for r in res.runs:
        s = follow_summary(r["seed"], "seed", alpha=r["alpha"], module_length=r["module_length"])
        assert r["traversed"] == (len(s["wall_touch_steps"]) == 0)
        assert r["touch_steps"] == len(s["wall_touch_steps"])
        assert r["max_penetration_mm"] == pytest.approx(penetration(s), abs=1e-12)
        assert r["min_clearance_mm"] == s["min_clearance_mm"] and r["steps"] == s["steps"]
    for d in res.designs:
        mine = [r for r in res.runs if (r["alpha"], r["module_length"]) == (d["alpha"], d["module_length"])]
        assert [r["seed"] for r in mine] == [3, 4, 5] and d["colons"] == 3
        assert d["pass_rate"] == sum(r["traversed"] for r in mine) / 3
        pens = [r["max_penetration_mm"] for r in mine]
        assert d["worst_penetration_mm"] == max(pens) and d["median_penetration_mm"] == statistics.median(pens)
        worst = max(mine, key=lambda r: (r["max_penetration_mm"], -r["min_clearance_mm"], -r["seed"]))
        assert d["worst_colon"] == worst["seed"]
        assert d["worst_clearance_mm"] == min(r["min_clearance_mm"] for r in mine)
        assert d["min_turn_radius_mm"] == Robot(alpha=d["alpha"], module_length=d["module_length"]).min_turn_radius
    assert [d["design"] for d in res.designs] == [1, 2, 3, 4]


def test_the_whole_robot_counts_when_the_study_gives_its_length():
    """--grid body_modules=M: every run is bhr.follow with that body, and its contacts decide the pass."""
    study = build_study([("alpha", (25,)), ("module_length", (5,)), ("body_modules", (5, 60))], "2,7",
                        solvers=("lumen",))
    assert study.design_keys == ["solver", "alpha", "module_length", "body_modules"]
    res = run_study(study, jobs=1)
    assert not res.failed
    for r in res.runs:
        rb = Robot(alpha=25, module_length=5)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            s = bhr.follow(load_trajectory("anatomy", feed=rb.feed, seed=r["seed"]), solver="lumen", robot=rb,
                           body_modules=r["body_modules"]).summary.to_dict()
        assert r["traversed"] == (len(s["wall_touch_steps"]) == 0)
        assert r["max_penetration_mm"] == pytest.approx(penetration(s), abs=1e-12)
        assert r["min_clearance_mm"] == s["min_clearance_mm"]
    head = {r["seed"]: r for r in res.runs if r["body_modules"] == 5}
    whole = {r["seed"]: r for r in res.runs if r["body_modules"] == 60}
    for seed in (2, 7):  # a longer robot can only touch the wall more
        assert whole[seed]["min_clearance_mm"] <= head[seed]["min_clearance_mm"] + 1e-9
        assert whole[seed]["touch_steps"] >= head[seed]["touch_steps"]
    with pytest.raises(BhrError, match="body_modules 4 is fewer than the 6 head modules"):
        build_study([("modules", (5, 6)), ("body_modules", (4, 60))], "1")


def test_pass_rates_contact_and_answer_from_lumen_keys():
    """Rows carrying the lumen keys (geometric penetration, contact per module) are read as given."""
    study = build_study([("alpha", (10, 20))], "1-4")
    runs = []
    for alpha, touches in ((10, [[], [3], [], []]), (20, [[], [], [], []])):
        for seed, t in zip(range(1, 5), touches):
            runs.append({"solver": "seed", "alpha": alpha, "seed": seed, "status": "ok", "steps": 10,
                         "traversed": not t, "max_penetration_mm": 0.5 * len(t) + seed / 10,
                         "touch_steps": len(t), "contact_length_mm": 2.0 * seed})
    designs = design_rows(study, runs, {})
    assert [d["pass_rate"] for d in designs] == [0.75, 1.0]
    assert designs[0]["worst_penetration_mm"] == 0.7 and designs[0]["worst_colon"] == 2
    assert designs[0]["worst_clearance_mm"] is None  # these rows carry no clearance
    assert designs[1]["median_contact_length_mm"] == 5.0 and designs[1]["worst_contact_length_mm"] == 8.0

    class R:  # a StudyResult's fields, as plain data
        pass

    r = R()
    r.study, r.designs = study, designs
    best, meeting = answer(r)
    assert best["alpha"] == 20 and [d["alpha"] for d in meeting] == [20]
    r.study = build_study([("alpha", (10, 20))], "1-4", target=0.75)
    best, meeting = answer(r)
    assert best["alpha"] == 20 and [d["alpha"] for d in meeting] == [20, 10]


# ---------------------------------------------------------------------------------------------- command


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("traverse")
    proc = run_cli("traverse", *SMALL, "--out", "study", cwd=cwd)
    assert proc.returncode == 0, proc.stderr
    return cwd, proc


def test_command_answers_the_question(small_study):
    cwd, proc = small_study
    out = cwd / "study"
    assert proc.stderr == ""  # piped: no progress bar, no noise
    designs = rows_of(out / "designs.csv")
    runs = rows_of(out / "runs.csv")
    assert len(designs) == 4 and len(runs) == 8
    expected = {}
    for solver in ("seed", "optimal"):
        for alpha in (10, 30):
            passed = [len(follow_summary(seed, solver, alpha=alpha, module_length=5)["wall_touch_steps"]) == 0
                      for seed in (3, 7)]
            expected[("thesis" if solver == "seed" else solver, alpha)] = sum(passed) / 2  # shown by its one name
    got = {(d["solver"], int(d["alpha"])): float(d["pass_rate"]) for d in designs}
    assert got == expected
    assert max(expected.values()) >= 0.95 > min(expected.values())  # the fixture has both kinds of design
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
    proc = run_cli("traverse", "--grid", "alpha=10", "--colons", "3", "--no-plots", "--out", "o", cwd=tmp_path)
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
        proc = subprocess.run(bhr_exe() + ["traverse", "--grid", "alpha=10", "--colons", "1-2", "--no-plots",
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
    (["--colons", "1", "--grid", "alpha=10", "--x", "modules"], "is not an axis of this sweep"),
    (["--colons", "1", "--grid", "wings=2"], "is not a parameter a sweep can vary"),
    (["--colons", "1", "--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], "exclude each other"),
    (["--colons", "1", "--scheduler", "tcp://127.0.0.1:1"], "cannot connect to the Dask scheduler"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, msg):
    proc = run_cli("traverse", *args, "--out", "o", cwd=tmp_path, timeout=120)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ") and msg in lines[0], proc.stderr
    assert not (tmp_path / "o").exists()


def test_output_folder_that_is_a_file_fails_before_running(tmp_path):
    (tmp_path / "o").write_text("not a folder")
    proc = run_cli("traverse", "--colons", "1", "--out", "o", cwd=tmp_path, timeout=120)
    assert proc.returncode != 0 and proc.stderr.startswith("Error: ") and len(proc.stderr.strip().splitlines()) == 1
    assert (tmp_path / "o").read_text() == "not a folder"


# ---------------------------------------------------------------------------------------------- Dask


def test_dask_cluster_gives_the_local_study(dask_cluster, small_study):  # noqa: F811
    cwd, _ = small_study
    proc = run_cli("traverse", *SMALL, "--no-plots", "--out", "dask", "--scheduler", dask_cluster.scheduler_address,
                   cwd=cwd)
    assert proc.returncode == 0, proc.stderr
    assert f"on dask {dask_cluster.scheduler_address}" in proc.stdout
    for name in ("designs.csv", "runs.csv"):
        assert (cwd / "dask" / name).read_bytes() == (cwd / "study" / name).read_bytes()
    doc = json.loads((cwd / "dask" / "study.json").read_text())
    assert doc["runner"] == f"dask {dask_cluster.scheduler_address}" and doc["workers"] == 2


def test_library_study_on_dask_equals_local(dask_cluster):  # noqa: F811
    study = build_study([("module_length", (6, 8))], "1-3")
    seen = []
    remote = run_study(study, scheduler=dask_cluster.scheduler_address, progress=lambda d, t: seen.append(d))
    local = run_study(study, jobs=1)
    assert remote.runs == local.runs and remote.designs == local.designs
    assert seen[-1] == 6


# ---------------------------------------------------------------------------------------------- page


def test_page_loads_in_chromium_without_console_errors(small_study, tmp_path):
    from tests.test_report_browser import Browser, need_chromium

    cwd, _ = small_study
    b = Browser(need_chromium())
    try:
        b.load((cwd / "study" / "index.html").as_uri())
        assert b.console_errors() == []
        assert b.evaluate("document.querySelector('h1').textContent") == "bhr traverse"
        assert "best: design #" in b.evaluate("document.querySelector('#answer').textContent")
        sizes = b.evaluate("Promise.all([...document.images].map(i => i.decode().then(() => "
                           "[i.naturalWidth, i.naturalHeight])))")
        assert len(sizes) == 2 and all(w > 300 and h > 200 for w, h in sizes)
        assert b.evaluate("document.querySelectorAll('#designs tbody tr').length") == 4
        assert b.evaluate("document.querySelectorAll('#designs tbody tr.meets').length") >= 1
        from tests.test_report_browser import check_fits

        check_fits(b)  # the page fits a 1280 px window (tables scroll inside it)
        assert b.screenshot(tmp_path / "page.png")[:8] == PNG
    finally:
        b.close()


def test_ties_are_broken_by_the_clearance_left():
    study = build_study([("alpha", (25, 30))], "1-2")
    runs = [{"solver": "seed", "alpha": a, "seed": s, "status": "ok", "steps": 5, "traversed": True,
             "max_penetration_mm": 0.0, "touch_steps": 0, "contact_length_mm": 0.0, "min_clearance_mm": c}
            for a, s, c in ((25, 1, 0.4), (25, 2, 1.0), (30, 1, 2.0), (30, 2, 0.9))]
    designs = design_rows(study, runs, {})
    assert [d["worst_clearance_mm"] for d in designs] == [0.4, 0.9]
    assert [d["worst_colon"] for d in designs] == [1, 2]  # no penetration: the colon with the least clearance

    class R:
        pass

    r = R()
    r.study, r.designs = study, designs
    best, meeting = answer(r)
    assert best["alpha"] == 30 and [d["alpha"] for d in meeting] == [30, 25]


def test_colons_take_the_grid_range_syntax_too():
    from bhr.studies.traverse import parse_colons

    assert parse_colons("1:3") == parse_colons("1-3") == (1, 2, 3)
    assert parse_colons("1:9:4,20") == (1, 5, 9, 20)
    with pytest.raises(BhrError, match="mixes - and :"):
        parse_colons("1-9:2")


def test_the_table_says_when_designs_are_left_out():
    from bhr.studies.traverse import format_study

    study = build_study([("alpha", tuple(range(10, 19)))], "1-2")
    runs = [{"solver": "thesis", "alpha": a, "seed": s, "status": "ok", "steps": 5, "traversed": a > 10,
             "max_penetration_mm": 0.0 if a > 10 else 1.0, "touch_steps": 0, "contact_length_mm": 0.0,
             "min_clearance_mm": float(a)} for a in range(10, 19) for s in (1, 2)]

    class R:
        runner, wall_time_s, clearance_kind, failed = "in-process", 1.0, "geometric", []

    r = R()
    r.study, r.designs, r.runs = study, design_rows(study, runs, {}), runs
    lines = format_study(r)
    assert lines[0].startswith("18 runs (9 designs x 2 colons)")
    shown = [ln for ln in lines[2:] if ln[:5].strip().isdigit()]
    assert len(shown) == 8
    assert "the best 8 of 9 designs shown; 1 more (down to design #1, 0% traversed) are in designs.csv" in lines[-2]
    assert len([ln for ln in format_study(r, count=9)[2:] if ln[:5].strip().isdigit()]) == 9
