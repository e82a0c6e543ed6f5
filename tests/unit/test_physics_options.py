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
