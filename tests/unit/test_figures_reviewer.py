"""Figures a reviewer accepts: the robot drawn with its radius (the capsule the clearance scores), a figure of one
step shows that step's wall contacts only, and an anatomical colon carries its section labels and the direction
of travel."""
from __future__ import annotations

import warnings

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import bhr  # noqa: E402
from bhr.model._anatomy import SECTIONS  # noqa: E402
from bhr.output._path_plot import path_figure  # noqa: E402
from bhr.output._scene import capsule_outline


@pytest.fixture(scope="module")
def touching():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return bhr.follow(bhr.trajectory("anatomy", seed=3))


def _lines(fig, label):
    return [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label() == label]


@settings(max_examples=50, deadline=None)
@given(a=st.tuples(st.floats(-100, 100), st.floats(-100, 100)),
       d=st.tuples(*[st.floats(-20, 20).filter(lambda v: v == 0 or abs(v) > 1e-6)] * 2), r=st.floats(0.5, 10))
def test_the_capsule_is_the_segment_widened_by_the_radius(a, d, r):
    a, b = np.array(a), np.array(a) + np.array(d)
    out = capsule_outline(a, b, r)
    if np.hypot(*(b - a)) == 0:  # a module of no length (as stored: a + d may equal a)
        assert out is None
        return
    ab = b - a
    t = np.clip(((out - a) @ ab) / (ab @ ab), 0, 1)
    dist = np.linalg.norm(out - (a + t[:, None] * ab), axis=1)
    assert np.allclose(dist, r)  # every outline point exactly one radius from the module's axis


def test_a_planar_path_figure_draws_each_module_with_its_radius():
    run = bhr.follow(bhr.trajectory("colon"))
    fig = path_figure(run)
    ax = fig.axes[0]
    filled = [p for p in ax.patches if p.get_label() == "robot (radius 5 mm)"]
    assert len(filled) == 1  # labelled once; one capsule per module
    polys = [p for p in ax.patches if type(p).__name__ == "Polygon" and np.allclose(p.get_facecolor()[:3],
                                                                                      filled[0].get_facecolor()[:3])]
    assert len(polys) >= run.modules


def test_a_figure_of_one_step_shows_that_steps_contacts_only(touching):
    cl = touching.clearance
    k = cl.touch_steps[len(cl.touch_steps) // 2] - 1  # a 0-based step in contact
    at_k = cl.contacts(k)
    assert 0 < len(at_k) < len(cl.contacts())
    one = path_figure(touching, k)
    dots = _lines(one, f"wall contact at step {k + 1}")
    assert dots and all(len(d.get_xdata()) == len(at_k) for d in dots)
    assert not _lines(one, "wall contact (every step)")
    whole = path_figure(touching)
    every = _lines(whole, "wall contact (every step)")
    assert every and len(every[0].get_xdata()) == len(cl.contacts())


def test_an_anatomical_colon_carries_its_sections_and_the_direction_of_travel(touching):
    fig = path_figure(touching)
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert set(SECTIONS) <= set(texts)
    assert "direction of travel" not in " ".join(texts)  # named in the legend, where it covers nothing
    assert "direction of travel" in [t.get_text() for t in fig.legends[0].get_texts()]
    assert any(type(c).__name__ == "Line3DCollection" for c in fig.axes[0].collections)  # the arrow (quiver)


def test_the_3d_view_names_the_sections_and_shows_the_direction_of_travel(touching):
    from bhr.output._view import view_figure

    fig = view_figure(touching)
    names = {t.get("name"): t for t in fig["data"]}
    assert names["sections"]["text"] == list(SECTIONS)
    cone = names["direction of travel"]
    d = np.array([cone["u"][0], cone["v"][0], cone["w"][0]])
    start = np.asarray(touching.trajectory.points[:10])
    assert d @ (start[-1] - start[0]) > 0  # it points along the path, away from the anus
    # the robot and the step's contacts are still the traces the frames update
    assert all(fig["data"][i]["name"] in ("robot (head orange)", "contact at this step")
               for i in fig["frames"][0]["traces"])


def test_a_generated_colons_clearance_figure_bands_its_sections_in_path_order(touching):
    # a generated colon has no landmarks file: its sections come from its own section ends, as its path's labels
    from bhr.model._anatomy import path_section_ranges, path_sections
    from bhr.output._clearance_plot import clearance_figure

    ranges = path_section_ranges(touching.trajectory)
    assert [n for n, _, _ in ranges] == list(SECTIONS)
    assert ranges[0][1] == 0 and ranges[-1][2] == len(touching.trajectory.points)
    assert all(b > a and b == a2 for (_, a, b), (_, a2, _) in zip(ranges, ranges[1:]))
    assert all(a <= k < b for (_, a, b), (_, k) in zip(ranges, path_sections(touching.trajectory)))
    ax = clearance_figure(touching).axes[0]
    named = [t.get_text().replace("\n", " ") for t in ax.texts]
    assert [n for n in named if n in SECTIONS] == list(SECTIONS)
    assert path_section_ranges(bhr.trajectory("curve")) == []
