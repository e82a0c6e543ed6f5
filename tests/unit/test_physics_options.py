"""The physics replay's wall stiffness is refused far outside its published range, in one line naming the range."""
from __future__ import annotations

import pytest

from bhr._settings.errors import BhrError
from bhr._studies.physics import DEFAULT_WALL_STIFFNESS, WALL_STIFFNESS_RANGE, check_wall_stiffness


@pytest.mark.parametrize("value", [0.001, 5.0, float("nan"), float("inf")])
def test_a_wall_far_from_the_published_range_is_refused(value):
    with pytest.raises(BhrError) as e:
        check_wall_stiffness(value)
    assert "\n" not in str(e.value) and "published" in str(e.value)


def test_the_default_is_the_middle_of_the_published_range():
    lo, hi = WALL_STIFFNESS_RANGE
    assert DEFAULT_WALL_STIFFNESS == pytest.approx((lo + hi) / 2, rel=1e-3)
    assert check_wall_stiffness(lo) == lo and check_wall_stiffness(hi) == hi


@pytest.mark.parametrize("reached, flagged", [((True, True, True), True), ((True, False, True), False),
                                              ((False, True, False), True)])
def test_a_peak_load_from_an_equilibrium_not_reached_is_said_to_be_one(reached, flagged):
    """The wall's peak load is only as good as the equilibrium it was read from: the summary says whether that pose's
    own equilibrium was reached, and each pose in physics.json says so too."""
    import numpy as np

    from bhr._studies.physics.replay import PhysicsReplay

    P, M = 3, 2
    rep = PhysicsReplay(np.array([1, 2, 3]), np.arange(3.0), np.array([1.0, 5.0, 2.0]), np.ones((P, M)),
                        np.zeros(P), np.zeros(P), np.full((P, 3), np.nan), np.zeros(P), np.zeros(P), np.zeros(P),
                        np.zeros((P, M + 1, 3)), [np.zeros((0, 3))] * P, None, None, np.ones(P, dtype=np.int64), {},
                        0.0, 9.8, np.array(reached))
    assert rep.summary()["max_total_force_equilibrium_reached"] is flagged
    assert [s["equilibrium_reached"] for s in rep.to_dict()["steps"]] == list(reached)
