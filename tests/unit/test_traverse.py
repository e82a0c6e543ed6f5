"""bhr traverse: designs x anatomical colons, locally and on a real Dask LocalCluster, its outputs and page."""
from __future__ import annotations

import csv
import io
import os
import statistics
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import bhr
from bhr._settings.errors import BhrError
from bhr._settings.options import LIMITS
from bhr._run.driver import BhrWarning
from bhr.model._robot import Robot
from bhr.model._generators import load_trajectory
from bhr._studies.traverse import _run_row, answer, build_study, design_rows, parse_colons, run_study
from tests.conftest import bhr_exe

PNG = b"\x89PNG\r\n\x1a\n"
# a design that gets through both colons, one that gets through one of them, and two that get through neither
# (checked against bhr.follow in tests/cli/test_traverse.py); the lumen solver at alpha 10 would cost twice as much
SMALL = ["--head-only", "--solver", "seed", "--solver", "lumen", "--grid", "alpha=20,30", "--grid", "module_length=5",
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
    ("0-200000", f"more than {LIMITS['colons']} colons"),
    ("1-5,1-10000", f"more than {LIMITS['colons']} colons"),
])
def test_bad_colons(text, msg):
    with pytest.raises(BhrError, match=msg):
        parse_colons(text)


def test_the_colon_limit_counts_the_seeds_a_step_gives_and_holds_for_a_list():
    assert len(parse_colons(f"1:{2 * LIMITS['colons']}:2")) == LIMITS["colons"]  # every other seed: at the limit
    with pytest.raises(BhrError, match=f"more than {LIMITS['colons']} colons"):
        parse_colons(list(range(LIMITS["colons"] + 1)))
    with pytest.raises(BhrError, match=f"4925000 designs is more than {LIMITS['study_runs']}"):  # before any colon is drawn
        build_study([("alpha", tuple(range(5, 30))), ("modules", tuple(range(3, 200)))], "1-1000")


@pytest.mark.parametrize("grid, kw, msg", [
    ([("seed", (1, 2))], {}, "give their seeds with --colons"),
    ([("radius", (50.0,))], {}, "is a trajectory option"),
    ([], {"target": 0.0}, "--target-pass must be a share"),
    ([], {"target": 1.5}, "--target-pass must be a share"),
    ([], {"solvers": ("nope",)}, "unknown solver 'nope'"),
    ([("alpha", (-5,))], {}, "alpha"),
    # the trail model plans inside the lumen: a run of it cannot be ended where it leaves the lumen
    ([("locomotion", ("wires", "trail")), ("stop_at_wall", (True,))], {"solvers": ("lumen",)}, "trail model is an idealisation"),
])
def test_studies_are_checked_before_running(grid, kw, msg):
    with pytest.raises(BhrError, match=msg):
        build_study(grid, "1-3", **kw)


# ---------------------------------------------------------------------------------------------- results


@pytest.mark.run
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


@pytest.mark.run
def test_the_whole_robot_counts_when_the_study_gives_its_length():
    """--grid body_modules=M: every run is bhr.follow with that body, and its contacts decide the pass."""
    study = build_study([("alpha", (25,)), ("module_length", (5,)), ("body_modules", (5, 30))], "7",
                        solvers=("thesis",))
    assert study.design_keys == ["solver", "alpha", "module_length", "body_modules"]
    res = run_study(study, jobs=1)
    assert not res.failed
    for r in res.runs:
        rb = Robot(alpha=25, module_length=5)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BhrWarning)
            s = bhr.follow(load_trajectory("anatomy", feed=rb.feed, seed=r["seed"]), solver="thesis", robot=rb,
                           body_modules=r["body_modules"]).summary.to_dict()
        assert r["traversed"] == (len(s["wall_touch_steps"]) == 0)
        assert r["max_penetration_mm"] == pytest.approx(penetration(s), abs=1e-12)
        assert r["min_clearance_mm"] == s["min_clearance_mm"]
    head = {r["seed"]: r for r in res.runs if r["body_modules"] == 5}
    whole = {r["seed"]: r for r in res.runs if r["body_modules"] == 30}
    for seed in (7,):  # a longer robot can only touch the wall more
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


# ---------------------------------------------------------------------------------------------- Dask


# ---------------------------------------------------------------------------------------------- page


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
    from bhr._studies.traverse import parse_colons

    assert parse_colons("1:3") == parse_colons("1-3") == (1, 2, 3)
    assert parse_colons("1:9:4,20") == (1, 5, 9, 20)
    with pytest.raises(BhrError, match="mixes - and :"):
        parse_colons("1-9:2")


def test_the_table_says_when_designs_are_left_out():
    from bhr._studies.traverse import format_study

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


def _tied_result(clearances):
    """A study whose designs all traverse every colon: only the clearance left tells them apart."""
    study = build_study([("alpha", (20, 25, 30)), ("module_length", (5, 6))], "1-2")
    runs = [{"solver": "thesis", "alpha": a, "module_length": ml, "seed": s, "status": "ok", "steps": 5,
             "traversed": True, "max_penetration_mm": 0.0, "touch_steps": 0, "contact_length_mm": 0.0,
             "min_clearance_mm": clearances[(a, ml)] + 0.1 * s}
            for a in (20, 25, 30) for ml in (5, 6) for s in (1, 2)]

    class R:
        runner, wall_time_s, clearance_kind, failed = "in-process", 1.0, "geometric", []

    r = R()
    r.study, r.designs, r.runs = study, design_rows(study, runs, {}), runs
    return r


CLEAR = {(20, 5): 0.9, (20, 6): 0.5, (25, 5): 1.3, (25, 6): 0.7, (30, 5): 0.4, (30, 6): 1.1}


def test_the_ranking_metric_and_the_robot_judged_are_in_the_table_and_the_answer():
    from bhr._studies.traverse import DESIGN_COLUMNS, answer_line, format_study

    r = _tied_result(CLEAR)
    best = min(r.designs, key=lambda d: d["rank"])
    assert (best["alpha"], best["module_length"]) == (25, 5) and best["ranked_by"] == "worst clearance"
    assert {"robot_judged", "rank", "ranked_by"} <= set(DESIGN_COLUMNS)
    assert {d["robot_judged"] for d in r.designs} == {"head only (5 modules)"}
    assert sorted(d["rank"] for d in r.designs) == [1, 2, 3, 4, 5, 6]
    line = answer_line(r)
    assert "head only (5 modules)" in line
    assert "ahead of design #6 by its worst clearance, 1.40 mm against 1.20 mm; a tie-break at the same pass rate" \
        in line
    lines = format_study(r)
    assert any(x.startswith("Robot judged: head only (5 modules)") for x in lines)
    assert any(x.startswith("Ranked by pass rate, then worst penetration, then worst clearance") for x in lines)
    assert lines[3].rstrip().endswith("ranked by") and lines[4].endswith("worst clearance")


def test_a_whole_robot_is_labelled_as_one():
    from bhr._studies.traverse import robot_judged

    study = build_study([("alpha", (25,)), ("body_modules", (5, 300))], "1")
    assert robot_judged(study, {"alpha": 25, "body_modules": 300}) == "whole robot (300 modules)"
    assert robot_judged(study, {"alpha": 25, "reach": "cecum"}) == "whole robot (to the cecum)"
    assert robot_judged(study, {"alpha": 25, "modules": 7}) == "head only (7 modules)"


def test_the_default_robot_is_the_whole_robot_to_the_cecum_moved_by_its_wires():
    """bhr traverse judges an endoscope: the whole robot reaching the cecum, with the lumen solver (whose whole robot
    is moved by its wires); the head alone only when asked, and labelled."""
    from bhr._studies.traverse import robot_axes, robot_judged

    axes, solvers, per_run = robot_axes([("alpha", (20, 25))], ())
    assert axes == [("alpha", (20, 25)), ("reach", ("cecum",)), ("stop_at_wall", (True,))] and solvers == ("lumen",)
    assert not per_run
    # every run whole when each is to be replayed against the wall (--max-wall-force)
    assert robot_axes([("alpha", (20, 25))], (), stop_at_wall=False)[0] == [("alpha", (20, 25)), ("reach", ("cecum",))]
    assert robot_axes([("alpha", (20, 25))], (), stop_at_wall=False)[2] is False
    study = build_study(axes, "1", solvers=solvers)
    assert {robot_judged(study, d) for d in ({"alpha": 20, "reach": "cecum"},)} == {"whole robot (to the cecum)"}
    # a grid that sizes the robot is kept, its runs ending at the wall too (unless the grid says otherwise); the
    # trail model (an idealisation) plans inside the lumen and runs to the end; the head alone when asked, with the
    # thesis's solver
    assert robot_axes([("body_modules", (60,))], ("lumen",)) == (
        [("body_modules", (60,)), ("stop_at_wall", (True,))], ("lumen",), False)
    assert robot_axes([("body_modules", (60,)), ("stop_at_wall", (False,))], ("lumen",))[::2] == (
        [("body_modules", (60,)), ("stop_at_wall", (False,))], False)
    assert robot_axes([("locomotion", ("trail",))], ())[::2] == (
        [("locomotion", ("trail",)), ("reach", ("cecum",))], True)
    assert robot_judged(study, {"reach": "cecum", "locomotion": "trail"}) == (
        "whole robot (to the cecum), the trail model: ideal follow-the-leader, not buildable")
    assert robot_axes([("alpha", (10,))], (), head_only=True) == ([("alpha", (10,))], ("thesis",), False)
    assert robot_judged(build_study([("alpha", (10,))], "1"), {"alpha": 10}) == "head only (5 modules)"
    with pytest.raises(BhrError, match="--head-only judges the head alone"):
        robot_axes([("reach", ("cecum",))], (), head_only=True)


def test_a_grid_with_the_trail_model_still_stops_its_buildable_runs_at_the_wall():
    """The trail model (an idealisation) runs to the end; every other design of the same grid still ends where its
    robot leaves the lumen, so no pose a robot cannot take is scored."""
    from bhr._studies.traverse import robot_axes

    axes, solvers, per_run = robot_axes([("locomotion", ("trail", "wires"))], ())
    study = build_study(axes, "1-2", solvers=solvers, stop_at_wall=per_run)
    designs = study.sweep.designs()
    assert {(d["locomotion"], d["stop_at_wall"]) for d in designs} == {("trail", False), ("wires", True)}
    assert len(designs) == 4
    # the trail model alone: no run ends at the wall
    axes, solvers, per_run = robot_axes([("locomotion", ("trail",))], ())
    assert not any(d["stop_at_wall"] for d in build_study(axes, "1", solvers=solvers,
                                                          stop_at_wall=per_run).sweep.designs())
    # without the rule (a replay of every run against the wall) nothing stops
    axes, solvers, per_run = robot_axes([("locomotion", ("trail", "wires"))], (), stop_at_wall=False)
    assert all("stop_at_wall" not in d for d in build_study(axes, "1", solvers=solvers,
                                                            stop_at_wall=per_run).sweep.designs())
    # a grid that says it itself keeps it (and the refusal of trail with stop_at_wall stays the grid's)
    with pytest.raises(BhrError, match="locomotion = trail, stop_at_wall = True"):
        build_study(robot_axes([("locomotion", ("trail", "wires")), ("stop_at_wall", (True,))], ())[0], "1")


def test_a_whole_robot_too_short_for_the_colon_does_not_traverse_it():
    """A whole robot that stays inside the lumen but whose feeder stopped it short of the cecum (shorter than the
    colon) has not traversed the colon: its reach is where the feeder stopped, and the answer says why."""
    from bhr._studies.traverse import StudyResult, answer_line

    study = build_study([("body_modules", (5, 400)), ("stop_at_wall", (True,))], "1", solvers=("lumen",))
    keys = study.design_keys
    base = {"solver": "lumen", "seed": 1, "status": "ok", "steps": 101, "path_steps": 101, "wall_touch_steps": [],
            "left_lumen_step": None, "stop_at_wall": True, "max_penetration_mm": 0.0, "min_clearance_mm": 1.5}
    short = _run_row({**base, "body_modules": 5, "cecum_shortfall_mm": 1180.4, "too_short_for_cecum": True,
                      "feeder_stop_step": 11}, keys)
    # a robot long enough is pushed on past the path's end until its tip is at the cecum (docs/locomotion.md)
    whole = _run_row({**base, "body_modules": 400, "cecum_shortfall_mm": 0.0, "too_short_for_cecum": False}, keys)
    # ... unless its trail could not get there even so: then it has not traversed the colon either
    stuck = _run_row({**base, "body_modules": 400, "cecum_shortfall_mm": 31.2, "too_short_for_cecum": False}, keys)
    assert not stuck["traversed"] and stuck["failure"] == "its tip stopped 31 mm short of the cecum"
    assert not short["traversed"] and short["reach_pct"] == pytest.approx(10.0)
    assert short["failure"] == "the robot is too short to reach the cecum: its tip stopped 1180 mm short"
    assert whole["traversed"] and whole["reach_pct"] == 100.0 and whole["failure"] == ""
    designs = design_rows(study, [short, whole], {})
    assert [d["traversed"] for d in designs] == [0, 1]
    res = StudyResult(study, [short, whole], designs, 0.0, "in-process", 1, "geometric")
    assert "design #2" in answer_line(res) and answer(res)[0]["body_modules"] == 400


def _stopped_result(lefts):
    """A whole-robot study whose runs end where the robot leaves the lumen: ``lefts[(alpha, seed)]`` is that step
    (None: it stayed inside) of a 101-step path; every run touched the wall."""
    study = build_study([("alpha", (20, 25, 30)), ("reach", ("cecum",)), ("stop_at_wall", (True,))], "1-3",
                        solvers=("lumen",))
    runs = [_run_row({"solver": "lumen", "alpha": a, "reach": "cecum", "stop_at_wall": True, "seed": s,
                      "status": "ok", "steps": 101 if lefts[(a, s)] is None else lefts[(a, s)], "path_steps": 101,
                      "wall_touch_steps": [2], "left_lumen_step": lefts[(a, s)],
                      "max_penetration_mm": 0.2 * a / 10 + s / 100, "min_clearance_mm": -0.2 * a / 10 - s / 100},
                     study.design_keys)
            for a in (20, 25, 30) for s in (1, 2, 3)]

    class R:
        runner, wall_time_s, clearance_kind, failed = "in-process", 1.0, "geometric", []

    r = R()
    r.study, r.designs, r.runs = study, design_rows(study, runs, {}), runs
    return r


def test_a_study_stopped_where_the_robot_leaves_the_lumen_ranks_by_how_far_it_got():
    """No design traverses: the one that gets furthest along the colons inside the lumen is ahead, and the table, the
    answer and the map say so with the figures."""
    from bhr._studies.traverse import answer_line, format_study, passrate_figure

    r = _stopped_result({(20, 1): 11, (20, 2): 31, (20, 3): 51, (25, 1): 21, (25, 2): 41, (25, 3): None,
                         (30, 1): 6, (30, 2): 41, (30, 3): 81})
    by = {d["alpha"]: d for d in r.designs}
    assert [by[a]["median_reach_pct"] for a in (20, 25, 30)] == [30.0, 40.0, 40.0]
    assert [by[a]["worst_reach_pct"] for a in (20, 25, 30)] == [10.0, 20.0, 5.0]
    assert [by[a]["rank"] for a in (25, 30, 20)] == [1, 2, 3]
    assert by[25]["ranked_by"] == "worst reach" and by[30]["ranked_by"] == "median reach"
    assert by[20]["worst_colon"] == 1 and by[30]["worst_colon"] == 1  # the colon it got least far in
    assert by[20]["worst_penetration_mm"] == pytest.approx(0.43)  # the deepest of its runs (colon 3)
    assert [run["reach_pct"] for run in r.runs[:3]] == [10.0, 30.0, 50.0]
    line = answer_line(r)
    assert "the best, design #2 (solver=lumen, alpha=25, reach=cecum, stop_at_wall=True), traverses 0/3 (0%)" in line
    assert "gets 40.0% of the way along the median colon before it leaves the lumen (worst 20.0%)" in line
    assert "ahead of design #3 by its worst reach, 20.0% against 5.0%" in line
    close = _stopped_result({(a, s): None for a in (20, 25, 30) for s in (1, 2, 3)})
    close.designs[0]["worst_penetration_mm"], close.designs[1]["worst_penetration_mm"] = 0.4312, 0.4338
    assert "by its worst penetration, 0.4312 mm against 0.4338 mm" in answer_line(close)  # not "0.43 against 0.43"
    inside = _stopped_result({(a, s): None for a in (20, 25, 30) for s in (1, 2, 3)})
    assert "traverses 0/3 (0%), it stays inside the lumen on every colon, worst penetration 0.43 mm" in \
        answer_line(inside)  # touched, never left: no reach to speak of
    lines = format_study(r)
    assert any(x.startswith("Ranked by pass rate, then median reach, then worst reach, then worst penetration")
               for x in lines)
    assert "median reach" in lines[3] and lines[4].split()[:7] == ["2", "lumen", "25", "cecum", "True", "0%",
                                                                 "40.0%"]
    fig = passrate_figure(r, "alpha", None)
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert any("reach 40% (worst 20%)" in t for t in texts), texts
    assert "then median reach (how far along the colon, %, before the robot left the lumen)" in \
        fig.axes[0].get_title()
    # every design at 0 %: the colour is the reach that ranks them
    assert fig.axes[1].get_ylabel().startswith("median reach inside the lumen (% of the colon)")
    assert list(np.asarray(fig.axes[0].images[0].get_array()).ravel()) == [30.0, 40.0, 40.0]


def test_designs_apart_only_by_rounding_are_a_tie_listed_in_design_order():
    """Whole robots of different lengths that leave the lumen at the same place read the same figures up to the
    last bits of a float: they tie, and the design listed first is ahead, not the one rounding favoured."""
    from bhr._studies.traverse import answer_line

    r = _stopped_result({(a, s): None for a in (20, 25, 30) for s in (1, 2, 3)})
    for k, d in enumerate(r.designs):
        d["worst_penetration_mm"] = 9.481300000001 - k * 1e-12  # the last design "deepest" by rounding alone
    line = answer_line(r)
    assert "the best, design #1 (" in line and "(tied with design #2 on every measure; listed first)" in line


def _mixed_result(trail_left, wires_left):
    """A whole-robot study of one design under both models: the trail model's (ideal, not buildable) and the wires'
    (the robot as it can be built), each run ending where the robot leaves the lumen (None: it stays inside) of a
    101-step path."""
    study = build_study([("alpha", (25,)), ("reach", ("cecum",)), ("locomotion", ("trail", "wires"))], "1-3",
                        solvers=("lumen",))
    runs = []
    for loco, lefts in (("trail", trail_left), ("wires", wires_left)):
        for s, left in zip((1, 2, 3), lefts):
            runs.append(_run_row({"solver": "lumen", "alpha": 25, "reach": "cecum", "locomotion": loco, "seed": s,
                                  "status": "ok", "steps": 101 if left is None else left, "path_steps": 101,
                                  "wall_touch_steps": [] if left is None else [left],
                                  "left_lumen_step": left, "max_penetration_mm": 0.0 if left is None else 6.0,
                                  "min_clearance_mm": 0.5 if left is None else -6.0}, study.design_keys))

    class R:
        runner, wall_time_s, clearance_kind, failed = "in-process", 1.0, "geometric", []

    r = R()
    r.study, r.designs, r.runs = study, design_rows(study, runs, {}), runs
    return r


@pytest.mark.parametrize("wires_left", [(None, None, None), (11, 21, None), (11, 21, 31)])
def test_the_trail_model_is_never_the_answer_beside_a_robot_that_can_be_built(wires_left):
    """The trail model traverses every colon, the robot driven by its wires all, one or none of them: the buildable
    design is ranked first and is the answer (or the best of no answer); the trail model is named after it as the
    idealisation it is."""
    from bhr._studies.traverse import answer_line, format_study, passrate_figure

    r = _mixed_result((None, None, None), wires_left)
    by = {d["locomotion"]: d for d in r.designs}
    assert by["trail"]["pass_rate"] == 1.0 and by["wires"]["rank"] == 1 and by["trail"]["rank"] == 2
    assert by["wires"]["ranked_by"] == "buildable first" == by["trail"]["ranked_by"]
    best, meeting = answer(r)
    assert all(d["locomotion"] == "wires" for d in meeting)
    assert (best is None) == (by["wires"]["pass_rate"] < r.study.target)
    line = answer_line(r)
    assert "best: design #1 " not in line and "the best, design #1 " not in line and line.count("design #1") == 1
    assert ("best: design #2 (" if best is not None else "the best, design #2 (") + \
        "solver=lumen, alpha=25, reach=cecum, locomotion=wires" in line
    assert "(the only buildable design; the trail model's rank after it)" in line
    assert line.endswith("; the trail model (ideal follow-the-leader, not buildable) at best: design #1, 3/3 "
                         "traversed")
    assert any(x.startswith("Ranked by every buildable design before the trail model's (ideal follow-the-leader, "
                            "not buildable), then pass rate") for x in format_study(r))
    # the map (alpha across, the model down) marks the buildable design's cell as the best (dashed red)
    ax = passrate_figure(r, "alpha", "locomotion").axes[0]
    assert "ranked by every buildable design before the trail model's (ideal, not buildable),\nthen by pass rate" \
        in ax.get_title()
    marked = [p for p in ax.patches if p.get_edgecolor()[:3] == pytest.approx((0xe8 / 255, 0x11 / 255, 0x2d / 255))]
    assert len(marked) == 1 and round(marked[0].get_y() + marked[0].get_height() / 2) == 1  # row 1: wires
    # a study of the trail model alone is answered by it, labelled (nothing buildable to prefer)
    alone = _mixed_result((None, None, None), (None, None, None))
    alone.designs = [d for d in alone.designs if d["locomotion"] == "trail"]
    assert answer(alone)[0]["locomotion"] == "trail"


def test_the_pass_rate_map_shows_ties_by_their_tie_break_and_marks_the_best():
    """Every design at 100 %: one colour of pass rate would hide the ranking; the map colours the worst clearance,
    says so, writes each cell's rank and marks the best cell."""
    from matplotlib.patches import Rectangle

    from bhr._studies.traverse import passrate_figure

    r = _tied_result(CLEAR)
    fig = passrate_figure(r, "alpha", "module_length")
    ax = fig.axes[0]
    image = ax.images[0].get_array()
    assert np.ptp(np.asarray(image)) > 0  # not one colour
    assert "tie-break" in fig.axes[1].get_ylabel()
    texts = [t.get_text() for t in ax.texts]
    assert any(t.startswith("rank 1: 100%") and "clear 1.40 mm" in t for t in texts) and "best" in texts
    dashed = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_linestyle() == "--"]
    assert len(dashed) == 1 and dashed[0].get_xy() == pytest.approx((1 - 0.46, 0 - 0.46))  # alpha 25, length 5
    assert "robot judged: head only (5 modules)" in ax.get_title()


def test_the_reach_of_a_robot_pushed_on_to_the_cecum_is_a_share_of_the_path():
    """A whole robot pushed past the path's end to the cecum has steps the path has not (docs/locomotion.md): how far
    along the colon it went is a share of the path's own steps, at most all of it."""
    study = build_study([("reach", ("cecum",))], "1", solvers=("lumen",))
    base = {"solver": "lumen", "reach": "cecum", "seed": 1, "status": "ok", "steps": 2026, "cecum_approach_steps": 52,
            "wall_touch_steps": [988], "max_penetration_mm": 6.0, "min_clearance_mm": -6.0}
    half = _run_row({**base, "left_lumen_step": 988}, study.design_keys)
    assert half["reach_pct"] == pytest.approx(100.0 * 987 / 1973)
    late = _run_row({**base, "left_lumen_step": 2000}, study.design_keys)  # in the approach, past the path's end
    assert late["reach_pct"] == 100.0 and not late["traversed"]
    stopped = _run_row({**base, "steps": 988, "path_steps": 1974, "left_lumen_step": 988}, study.design_keys)
    assert stopped["reach_pct"] == half["reach_pct"]


def test_a_study_judged_by_the_replay_says_so_and_names_the_replays_of_steps_an_idealisation():
    """Beside --max-wall-force the answer is the replay's: the tables say how a colon is counted, the wall's load
    at most, and how many colons were replayed from their steps only (joints moved linearly between codes)."""
    from bhr._studies.traverse import StudyResult, answer_line, design_columns, format_study, judged_by_replay

    study = build_study([("reach", ("cecum",))], "1-3", solvers=("lumen",), max_wall_force=9.8)
    keys = study.design_keys
    base = {"solver": "lumen", "reach": "cecum", "status": "ok", "steps": 2026, "wall_touch_steps": [148],
            "left_lumen_step": 148, "max_penetration_mm": 446.9, "min_clearance_mm": -446.9, "path_steps": None,
            "wall_stretch_mm": 0.8, "physical_cecum_step": 2023, "physically_traversed": True}
    runs = [_run_row({**base, "seed": k, "peak_wall_force_n": f, "poses_replayed": how}, keys)
            for k, f, how in ((1, 0.75, "steps"), (2, 1.05, "steps"), (3, 0.35, "every pose"))]
    designs = design_rows(study, runs, {})
    assert designs[0]["traversed"] == 3 and designs[0]["worst_wall_force_n"] == 1.05
    assert designs[0]["colons_replayed_from_steps"] == 2
    assert design_columns(study)[-2:] == ["worst_wall_force_n", "colons_replayed_from_steps"]
    res = StudyResult(study, runs, designs, 0.0, "in-process", 1, "geometric")
    said = judged_by_replay(res)
    assert "traversed when the replayed tip reaches the cecum with the wall's load never above 9.8 N" in said
    assert "2 of 3 runs replayed from their steps only" in said and "an idealisation" in said
    line = answer_line(res)
    assert "3/3 traversed by the physical replay (the wall's load at most 1.05 N; 2 of its 3 colons replayed from " \
           "their steps: an idealisation), the written poses' worst penetration 446.90 mm" in line
    assert said in format_study(res)
    geometric = StudyResult(build_study([("reach", ("cecum",))], "1", solvers=("lumen",)), runs[:1], designs, 0.0,
                            "in-process", 1, "geometric")
    assert judged_by_replay(geometric) == "" and "physical" not in answer_line(geometric)
