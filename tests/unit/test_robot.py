"""Robot model: alpha from stroke and lever, minimum turn radius, validation."""
import math

import pytest

from bhr.model._robot import Robot, alpha_from_stroke, min_turn_radius
from bhr._settings.errors import BhrError


def test_minimum_turn_radius_ec_7_1():
    assert round(min_turn_radius(10, 10), 2) == 57.15
    assert round(Robot().min_turn_radius, 2) == 57.15


def test_alpha_from_stroke_and_lever_ec_4_1():
    assert alpha_from_stroke(1, 2) == pytest.approx(30.0)
    r = Robot(stroke=1.7365, lever=10)
    assert r.alpha == pytest.approx(10.0, abs=1e-3)
    assert r.lift == 1.7365
    assert Robot().feed == 2.0


@pytest.mark.parametrize("kwargs, match", [
    ({"modules": 0}, "modules must be greater than 0"),
    ({"modules": 2.5}, "whole number"),
    ({"module_length": -1}, "module length must be greater than 0"),
    ({"alpha": 90}, "between 0 and 90"),
    ({"alpha": 0}, "alpha must be greater than 0"),
    ({"alpha": math.nan}, "finite"),
    ({"stroke": 1}, "give both stroke and lever"),
    ({"stroke": 3, "lever": 2}, "shorter than lever"),
    ({"tol_pos": 0}, "tol-pos must be greater than 0"),
    ({"weight_pos": -1}, "weight-pos must be 0 or more, got -1"),
])
def test_bad_robot_values(kwargs, match):
    with pytest.raises(BhrError, match=match):
        Robot(**kwargs)
