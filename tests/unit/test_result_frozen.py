"""A run is one frozen state, scored once: its clearance and summary are computed the first time they are read and
kept; a changed run is another run (dataclasses.replace), scored afresh."""
import dataclasses

import numpy as np
import pytest

import bhr
from bhr._run.driver import FollowResult


@pytest.fixture(scope="module")
def tube_run():
    """The thesis's robot along the thesis's curve."""
    return bhr.follow(bhr.trajectory("curve"))


def test_a_run_cannot_be_changed_in_place(tube_run):
    with pytest.raises(dataclasses.FrozenInstanceError):
        tube_run.points = tube_run.points[:3]  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        tube_run.body = None  # type: ignore[misc]


def test_summary_and_clearance_are_scored_once():
    run = bhr.follow(bhr.trajectory("anatomy", seed=1, feed=2.0), body_modules=8)
    assert run.clearance is not None
    assert run.clearance is run.clearance and run.summary is run.summary  # the same objects: computed once
    assert run.summary.extra["min_clearance_mm"] == run.clearance.min_mm
    assert run.feeder_stop_step == run.summary.extra.get("feeder_stop_step")
    assert run.feeder_stop_step is None or 1 <= run.feeder_stop_step < run.steps


def test_a_replaced_run_is_scored_afresh(tube_run):
    k = tube_run.steps // 2
    part = dataclasses.replace(tube_run, points=tube_run.points[:k], iterations=tube_run.iterations[:k],
                               point_errors_mm=tube_run.point_errors_mm[:k],
                               orientation_errors_deg=tube_run.orientation_errors_deg[:k],
                               codes=tube_run.codes[:k])
    assert isinstance(part, FollowResult) and part.steps == k and tube_run.steps > k
    assert part.summary.steps == k and tube_run.summary.steps == tube_run.steps
    assert part.summary.points_max_error_mm == pytest.approx(float(np.max(tube_run.point_errors_mm[:k])))
