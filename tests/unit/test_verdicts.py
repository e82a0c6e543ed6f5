"""Verdicts in words: a run's verdict (followed, out of tolerance, touched the wall, left the lumen) apart from how
it finished (ran to the end, stopped at the wall), in run.json, the follow summary and every study table; a run
that left the lumen never reports reaching the cecum; stop_at_wall (one registry option) ends it there."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import bhr
from bhr._run.driver import VERDICTS
from bhr._settings.errors import BhrError
from bhr._settings.options import BY_NAME
from bhr._studies.follow_run import summary_lines
from bhr._studies.study import finished_cell, summary_row, verdict_cell, verdict_class


@pytest.fixture(scope="module")
def typical():
    """The thesis robot on the shipped typical colon: it leaves the lumen, goes on, and its tip comes to the
    path's end (where the feeder stops) through the wall."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        path = bhr.trajectory("anatomy-typical")
        return bhr.follow(path), bhr.follow(path, stop_at_wall=True)


def test_a_run_that_left_the_lumen_never_says_it_reached_the_cecum(typical):
    full, _ = typical
    s = full.summary.to_dict()
    assert s["left_lumen_step"] is not None and s.get("feeder_stop_step") and s["left_lumen_step"] < s[
        "feeder_stop_step"]
    text = "\n".join(summary_lines(full))
    assert "reached the cecum" not in text
    assert (f"after leaving the lumen at step {s['left_lumen_step']}: it did not reach the cecum" in text)
    assert full.status == "left the lumen" and s["verdict"] == "left the lumen" and s["finished"] == "ran to the end"
    assert "Finished: ran to the end. Verdict: left the lumen." in text


def test_stop_at_wall_ends_the_run_where_it_left_the_lumen(typical):
    full, stopped = typical
    k = full.summary.extra["left_lumen_step"]
    assert stopped.steps == k < full.steps
    assert np.array_equal(stopped.points, full.points[:k]) and np.array_equal(stopped.codes, full.codes[:k])
    assert np.array_equal(stopped.point_errors_mm, full.point_errors_mm[:k])
    s = stopped.summary.to_dict()
    assert s["finished"] == stopped.finished == "stopped at the wall" and s["verdict"] == "left the lumen"
    assert s["stopped_at_wall_step"] == k and s["path_steps"] == full.steps and "feeder_stop_step" not in s
    assert s["left_lumen_step"] == k  # the clearance of the steps kept finds the same step
    assert "Stopped at the wall: the run ended at step" in "\n".join(summary_lines(stopped))


@pytest.mark.run
def test_stop_at_wall_changes_nothing_for_a_run_that_stays_inside():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        path = bhr.trajectory("anatomy", seed=3)
        a = bhr.follow(path, solver="lumen", alpha=20)
        b = bhr.follow(path, solver="lumen", alpha=20, stop_at_wall=True)
    assert a.status == "touched the wall" and b.steps == a.steps and b.finished == "ran to the end"
    assert np.array_equal(a.points, b.points)
    curve = bhr.follow(bhr.trajectory("curve"), stop_at_wall=True)  # no lumen: nothing to leave
    assert curve.status == "followed" and curve.finished == "ran to the end"


def test_stop_at_wall_with_the_trail_locomotion_is_refused_with_the_fix():
    with pytest.raises(BhrError, match="drop --stop-at-wall or give --locomotion wires"):
        bhr.follow(bhr.trajectory("anatomy", seed=1), solver="lumen", locomotion="trail", stop_at_wall=True)


def test_stop_at_wall_is_one_registry_option_for_cli_batch_and_sweep():
    from bhr._studies.study import BOOL_KEYS, NUMBER_KEYS, SIM_KEYS
    from bhr._studies.report import RUN_KEYS
    from bhr._studies.sweep import parse_values

    o = BY_NAME["stop_at_wall"]
    assert o.group == "run" and o.flag == "--stop-at-wall" and "stop_at_wall" in SIM_KEYS
    assert "stop_at_wall" in BOOL_KEYS and "stop_at_wall" not in NUMBER_KEYS and "stop_at_wall" in RUN_KEYS
    assert o.check(True, "x") is True and o.check("false", "x") is False
    with pytest.raises(BhrError, match="stop_at_wall must be true or false"):
        o.check(1, "batch")
    assert parse_values("stop_at_wall", "true,false", "--grid") == (True, False)
    assert parse_values("stop_at_wall", [True], "sweep.toml") == (True,)


@settings(max_examples=40, deadline=None)
@given(touch=st.booleans(), left=st.booleans(), over=st.booleans(), failed=st.booleans())
def test_table_cells_keep_finished_and_verdict_apart(touch, left, over, failed):
    """Only a run that followed is green; the finished cell never carries a verdict, nor "ok"."""
    verdict = ("left the lumen" if left else "touched the wall" if touch else "out of tolerance" if over
               else "followed")
    row = {"status": "failed: boom" if failed else "ok", "finished": "ran to the end", "verdict": verdict}
    assert finished_cell(row) in ("ran to the end", "FAILED")
    assert (finished_cell(row) == "FAILED") == failed
    assert verdict_cell(row) == ("" if failed else verdict) and verdict_cell(row) in ("", *VERDICTS)
    assert (verdict_class(row) == "ok") == (not failed and verdict == "followed")


def test_report_table_shows_an_over_tolerance_run_as_such_not_ok():
    from bhr._studies.report import format_table

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        over = bhr.follow(bhr.trajectory("curve", radius=30))  # tighter than the robot turns: 13 mm against 8
        good = bhr.follow(bhr.trajectory("curve"))
    rows = [{"name": n, "status": "ok", "wall_time_s": 0.0, **summary_row(r.summary.to_dict())}
            for n, r in (("tight", over), ("curve", good))]
    lines = format_table(rows)
    assert lines[0].split()[:3] == ["run", "finished", "verdict"]
    tight = next(x for x in lines if x.startswith("tight"))
    assert "ran to the end" in tight and "out of tolerance" in tight and " ok " not in f" {tight} "
    assert "followed" in next(x for x in lines if x.startswith("curve"))
