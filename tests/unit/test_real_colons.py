"""Real colons (trajectories/gca): names, units, sections, lumen, and the CSV section column."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import bhr
from bhr.model._generators import load_trajectory
from bhr.model._path import Trajectory, labels_of, runs_of
from bhr.model._trajnames import builtin_names, check_trajectory_name, real_colons
from bhr._settings.errors import BhrError

REAL = ("gca:E20", "gca:E60", "gca:E90", "gca:VHF", "gca:VHM")
ORDER = ("rectum and sigmoid", "rectum", "sigmoid", "descending", "transverse", "ascending", "cecum")


def test_the_five_real_colons_are_built_ins():
    assert tuple(real_colons()) == REAL
    assert set(REAL) <= set(builtin_names())
    for name in REAL:
        check_trajectory_name(name)
    with pytest.raises(BhrError, match="unknown trajectory"):
        check_trajectory_name("gca:XYZ")


@pytest.mark.parametrize("name", REAL)
def test_a_real_colon_loads_in_mm_with_its_sections_and_mesh(name):
    t = load_trajectory(name, feed=2.0)
    assert t.name == name and t.feed == 2.0 and t.lumen_end == "closed"
    steps = np.linalg.norm(np.diff(t.points, axis=0), axis=1)
    assert np.allclose(steps, 2.0, atol=1e-9)
    # in mm: a human large intestine, anus to appendix orifice, is about a metre or two long
    assert 900.0 < t.length_mm < 2500.0
    assert np.allclose(t.points[0], 0.0, atol=1e-6)  # the anus at the origin
    # lumen diameters of a human colon (mm), collapsed or inflated
    assert t.lumen is not None and t.lumen.shape == (len(t),)
    assert 10.0 < float(np.median(t.lumen)) < 40.0 and float(t.lumen.max()) < 60.0
    # sections in anatomical order, covering every point, from the anus to the cecum
    names = [s[0] for s in t.sections]
    assert names[-4:] == ["descending", "transverse", "ascending", "cecum"]
    assert [ORDER.index(n) for n in names] == sorted(ORDER.index(n) for n in names)
    assert t.sections[0][1] == 0 and t.sections[-1][2] == len(t)
    assert all(a[2] == b[1] for a, b in zip(t.sections, t.sections[1:]))
    assert t.section_at(0) == names[0] and t.section_at(len(t) - 1) == "cecum"
    assert t.mesh is not None and t.mesh.endswith(name.split(":")[1] + ".vtp")


def test_bhr_trajectory_names_a_real_colon():
    pts = bhr.trajectory("gca:VHM")
    assert pts.shape[1] == 3 and len(pts) > 600


def test_sections_follow_a_change_of_feed():
    t = load_trajectory("gca:E90", feed=2.0)
    u = Trajectory(t.name, t.points, lumen=t.lumen, sections=t.sections, feed=2.0).at_feed(1.0)
    assert [s[0] for s in u.sections] == [s[0] for s in t.sections]
    for (_, a, b), (_, c, d) in zip(t.sections, u.sections):
        assert abs(2 * a - c) <= 2 and abs(2 * b - d) <= 2


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["", "a", "b"]), min_size=1, max_size=40))
def test_runs_of_and_labels_of_are_inverse(labels):
    arr = np.array(labels, dtype=object)
    runs = runs_of(arr)
    assert list(labels_of(runs, len(arr))) == labels
    assert all(a < b for _, a, b in runs)


def test_csv_section_column(tmp_path):
    f = tmp_path / "c.csv"
    rows = ["x,y,z,lumen,section"] + [f"{i}.0,0,0,30,{'rectum' if i < 10 else 'sigmoid'}" for i in range(21)]
    f.write_text("\n".join(rows) + "\n")
    t = load_trajectory(f, feed=2.0)
    assert t.sections == (("rectum", 0, 5), ("sigmoid", 5, 11))
    assert t.mesh is None
    f.write_text("x,y,z,section\n0,0,0,rec;tum\n1,0,0,a\n")
    with pytest.raises(BhrError, match="line 2: section"):
        load_trajectory(f, feed=0.5)


def _sectioned_csv(tmp_path):
    """A short bent path in two named sections with a 30 mm lumen."""
    f = tmp_path / "two.csv"
    a = np.linspace(0.0, np.pi / 2, 40)
    pts = np.concatenate([np.stack([np.linspace(0, 60, 31)[:-1], np.zeros(30), np.zeros(30)], axis=1),
                          np.stack([60 + 80 * np.sin(a), 80 * (1 - np.cos(a)), np.zeros(40)], axis=1)])
    rows = ["x,y,z,lumen,section"] + [f"{x:.4f},{y:.4f},{z:.4f},30,{'rectum' if i < 30 else 'sigmoid'}"
                                      for i, (x, y, z) in enumerate(pts)]
    f.write_text("\n".join(rows) + "\n")
    return f


def test_a_run_names_its_sections_in_steps_csv_run_json_summary_and_figures(tmp_path):
    from bhr.output._clearance_plot import clearance_figure
    from bhr.output._path_plot import path_figure
    from bhr.output._steptable import format_steps_csv
    from bhr._run.driver import FollowResult
    from bhr._studies.follow_run import summary_lines

    t = load_trajectory(_sectioned_csv(tmp_path), feed=2.0)
    assert [s[0] for s in t.sections] == ["rectum", "sigmoid"]
    r = bhr.follow(t, "lumen")
    rows = format_steps_csv(r).splitlines()
    assert rows[0].endswith(",section")
    labels = [row.rsplit(",", 1)[1] for row in rows[1:]]
    assert labels[0] == "rectum" and labels[-1] == "sigmoid"
    assert labels == [t.section_at(i) for i in range(r.steps)]
    doc = r.to_dict()
    assert doc["trajectory"]["sections"] == [[n, a, b] for n, a, b in t.sections]
    back = FollowResult.from_json(doc)
    assert back.trajectory.sections == t.sections
    line = [ln for ln in summary_lines(r) if ln.startswith("Wall touched by section")]
    assert len(line) == 1 and "rectum" in line[0] and "sigmoid" in line[0]
    for fig in (clearance_figure(r), path_figure(r)):
        texts = [t_.get_text() for ax in fig.axes for t_ in ax.texts]
        assert any("rectum" in x for x in texts) and any("sigmoid" in x for x in texts)
    bad = dict(doc)
    bad["trajectory"] = dict(doc["trajectory"], sections=[["rectum", 5, 2]])
    with pytest.raises(BhrError, match="section 1"):
        FollowResult.from_json(bad)


def test_traverse_takes_real_colons_by_name_all_together_and_mixed_with_seeds():
    from bhr._studies.traverse import build_study, colons_phrase, parse_colons

    assert parse_colons("real") == REAL
    assert parse_colons("gca:VHM,1-3") == ("gca:VHM", 1, 2, 3)
    assert parse_colons(["gca:E20", 4]) == ("gca:E20", 4)
    with pytest.raises(BhrError, match="not a shipped real colon"):
        parse_colons("gca:NOPE")
    with pytest.raises(BhrError, match="twice"):
        parse_colons("real,gca:VHM")
    assert colons_phrase(("gca:VHM", 1, 2, 3)) == "3 anatomical colons (seeds 1-3) and 1 real colon (gca:VHM)"
    study = build_study([("alpha", (25.0,))], "gca:VHF,2", solvers=("lumen",))
    assert study.colons == ("gca:VHF", 2) and len(study) == 2


@pytest.mark.run
def test_a_study_runs_a_real_colon_as_that_colon():
    from bhr._studies.sweep import colon_source, run_design

    assert colon_source("anatomy", {"seed": "gca:VHF"}) == ("gca:VHF", {})
    assert colon_source("anatomy", {"seed": 3}) == ("anatomy", {"seed": 3})
    row = run_design({"traj": "anatomy", "solver": "lumen", "alpha": 25.0, "seed": "gca:VHF"}, "anatomy",
                     None, ("wall_touch_steps",))
    assert row["status"] == "ok"
    assert row["steps"] == len(load_trajectory("gca:VHF", feed=2.0))


@pytest.mark.run
def test_the_insufflated_lumen_model():
    from bhr.model._insufflation import AREA_MM2, CALIBRE_MM, insufflated_lumen

    ct = load_trajectory("gca:E90", feed=2.0)
    ins = load_trajectory("gca:E90", feed=2.0, lumen_model="insufflated")
    assert ct.lumen_model == "ct" and ins.lumen_model == "insufflated" and ins.mesh is None
    assert np.all(ins.lumen >= ct.lumen) and np.array_equal(ins.points, ct.points)
    # where the model sets the lumen, its mean cross-section over the colon is the CT colonography figure
    model, k = insufflated_lumen(np.zeros(len(ct)), ct.sections, 2.0)
    assert float(np.mean(np.pi * model ** 2 / 4)) == pytest.approx(AREA_MM2, rel=1e-9)
    # the cecum wider than the sigmoid, as the calibres say
    sec = {n: (a, b) for n, a, b in ct.sections}
    assert np.median(model[slice(*sec["cecum"])]) > np.median(model[slice(*sec["sigmoid"])])
    assert k * CALIBRE_MM["cecum"] == pytest.approx(float(model[sec["cecum"][1] - 1]), rel=0.05)
    # it follows the trajectory to another feed, and a path without sections is refused in one line
    assert ins.at_feed(1.0).lumen_model == "insufflated"
    with pytest.raises(BhrError, match="named section"):
        load_trajectory("anatomy-typical", feed=2.0, lumen_model="insufflated")
    r = bhr.follow(load_trajectory("gca:VHF", feed=2.0, lumen_model="insufflated"), "lumen")
    assert "insufflated" in r.summary.to_dict()["wall"]
    from bhr._run.driver import FollowResult

    assert FollowResult.from_json(r.to_dict()).trajectory.lumen_model == "insufflated"


@pytest.mark.run
def test_a_studys_worst_colon_is_followed_again_with_the_designs_lumen_model():
    from bhr._studies.traverse import StudyResult, build_study, worst_colon_run

    study = build_study([("alpha", (25.0,)), ("lumen_model", ("insufflated",))], "gca:VHF", solvers=("lumen",))
    design = {"design": 1, "solver": "lumen", "alpha": 25.0, "lumen_model": "insufflated", "worst_colon": "gca:VHF"}
    result = StudyResult(study, [], [design], 0.0, "in-process", 1, "geometric")
    run = worst_colon_run(result, design)
    assert run.trajectory.lumen_model == "insufflated" and "insufflated" in run.summary.to_dict()["wall"]
