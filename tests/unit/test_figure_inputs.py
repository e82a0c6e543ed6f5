"""The public figure calls refuse a run they cannot draw with the library's one-line error, not an assert.

An assert vanishes under ``python -O`` (the figure then fails later with an AttributeError) and a bare
ValueError is not the error bhr documents: each is a :class:`bhr.BhrError` naming what to give instead.
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402

import bhr  # noqa: E402
from bhr.output import body_figure, clearance_figure, error_figure  # noqa: E402


@pytest.fixture(scope="module")
def line_run():
    return bhr.follow(bhr.trajectory("line", length=20))  # the head alone, and no lumen


@pytest.mark.parametrize("kind", ["speed", "Position", "", 3, None])
def test_an_unknown_error_kind_is_a_bhr_error_naming_the_kinds(line_run, kind):
    with pytest.raises(bhr.BhrError) as exc:
        error_figure(line_run, kind)
    msg = str(exc.value)
    assert "\n" not in msg and "give one of position, orientation, global" in msg, msg


def test_a_run_without_a_lumen_has_no_clearance_figure(line_run):
    with pytest.raises(bhr.BhrError) as exc:
        clearance_figure(line_run)
    msg = str(exc.value)
    assert "\n" not in msg and "has none" in msg and "bhr.trajectory(\"colon\")" in msg, msg


def test_a_run_without_a_body_has_no_body_figure(line_run):
    with pytest.raises(bhr.BhrError) as exc:
        body_figure(line_run)
    msg = str(exc.value)
    assert "\n" not in msg and "body_modules=M" in msg, msg
