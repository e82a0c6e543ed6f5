"""run.json carries where the robot started (trajectory start_direction and start_point), so a run read back
has the tube behind the entrance, the body's frames and the physics replay's insertion of the run itself."""
from __future__ import annotations

import functools
import json
import warnings

import numpy as np
import pytest

import bhr
from bhr.model._generators import load_trajectory
from bhr._run.driver import BhrWarning, FollowResult


@functools.cache  # one run of each path for the module: the tests read it (through run.json) and never change it
def _run(name: str, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        return bhr.follow(load_trajectory(name, **kw), solver="thesis")


@pytest.mark.parametrize("name,kw", [("anatomy", {"seed": 3}), ("colon", {}), ("example_centerline", {})])
def test_start_round_trips_through_run_json(name, kw):
    run = _run(name, **kw)
    doc = json.loads(run.to_json())
    back = FollowResult.from_json(doc)
    assert np.allclose(back.trajectory.start_direction, run.trajectory.start_direction, atol=0, rtol=0)
    assert np.allclose(back.trajectory.start_point, run.trajectory.start_point, atol=0, rtol=0)


@pytest.mark.run
def test_a_read_back_anatomy_run_has_the_clearance_and_view_of_the_run():
    """The tube behind the entrance goes along the start direction (not +x): the body's clearance behind the
    entrance and the view's tube of the run read back are the run's."""
    from bhr.output._view import view_figure

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BhrWarning)
        run = bhr.follow(load_trajectory("anatomy", seed=3), solver="thesis", body_modules=30)
    assert not np.allclose(run.trajectory.start_direction, (1, 0, 0))
    back = FollowResult.from_json(json.loads(run.to_json()))
    np.testing.assert_allclose(back.clearance.module_table, run.clearance.module_table, atol=1e-9)
    tube, tube_back = view_figure(run)["data"][0], view_figure(back)["data"][0]
    assert tube["type"] == "mesh3d" and all(tube[k] == tube_back[k] for k in "xyz")


def test_older_run_json_without_start_recovers_it_from_the_first_base():
    run = _run("anatomy", seed=3)
    doc = json.loads(run.to_json())
    del doc["trajectory"]["start_direction"], doc["trajectory"]["start_point"]
    back = FollowResult.from_json(doc)
    assert np.allclose(back.trajectory.start_direction, run.trajectory.start_direction, atol=1e-12)


@pytest.mark.parametrize("value", [[0, 0, 0], [1, 2], ["x", 0, 0]])
def test_bad_start_direction_is_one_named_error(value):
    run = _run("line", length=10)
    doc = json.loads(run.to_json())
    doc["trajectory"]["start_direction"] = value
    with pytest.raises(bhr.BhrError, match="start_direction"):
        FollowResult.from_json(doc)


@pytest.mark.parametrize("value, words", [(float("nan"), "must be finite numbers"), ("3.5", "must be numbers, not text"),
                                          (True, "must be numbers, not true/false"), ([1.0, 2.0], "must be one number, got shape 2"),
                                          (1e9, "must lie within")])
def test_a_steps_clearance_is_checked_as_the_other_numbers_are(tmp_path, value, words):
    """run.json's per-step clearance_mm (a path with a lumen): NaN, text, true or a list was accepted."""
    from bhr._run.driver import load_run
    from bhr._settings.errors import BhrError

    doc = json.loads(_run("example_centerline").to_json())
    assert "clearance_mm" in doc["steps"][3]
    load_run(_write(tmp_path / "ok.json", doc))  # as written: fine, null where nothing is scored included
    doc["steps"][3]["clearance_mm"] = value
    with pytest.raises(BhrError) as e:
        load_run(_write(tmp_path / "r.json", doc))
    assert str(e.value).startswith(f"{tmp_path / 'r.json'}: step 4 clearance_mm ") and words in str(e.value)


def _write(path, doc):
    path.write_text(json.dumps(doc))  # NaN written as JSON's NaN literal, which json reads back
    return path
