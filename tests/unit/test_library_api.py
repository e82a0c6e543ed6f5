"""The library as a user calls it: trajectories that carry their feed and lumen, settings checked by the option
registry wherever they enter, solver objects and plug-in solvers, results that say whether they succeeded and why,
and the docstrings' examples, run as doctests."""
from __future__ import annotations

import doctest
import importlib
import pkgutil
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import bhr
import bhr.solvers as solvers
from bhr.model._path import Trajectory, resample_polyline, spacing
from bhr._settings.errors import BhrError


def _library_modules():
    for info in pkgutil.walk_packages(bhr.__path__, "bhr."):
        if info.name.startswith(("bhr._bench", "bhr.cli")):
            continue
        yield info.name


@pytest.mark.parametrize("name", sorted(_library_modules()))
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.failed == 0


def test_the_library_doctests_are_many():
    """The examples are really collected (a typo in a docstring's prompt would make them silently vanish)."""
    total = sum(len(t.examples) for name in _library_modules()
                for t in doctest.DocTestFinder().find(importlib.import_module(name)))
    assert total >= 15


# ------------------------------------------------------------------ trajectories carry their feed
def test_trajectory_carries_points_feed_and_lumen():
    t = bhr.trajectory("curve")
    assert isinstance(t, Trajectory) and t.feed == 2.0 and t.lumen is None
    assert np.asarray(t).shape == t.shape == (len(t), 3) and np.array_equal(t[0], t.points[0])
    a = bhr.trajectory("anatomy", seed=7)
    assert a.lumen is not None and a.lumen.shape == (len(a),) and a.feed == 2.0
    assert repr(a).startswith("Trajectory('anatomy-7', ") and "with lumen" in repr(a)


def test_follow_draws_a_trajectory_again_at_the_robots_feed():
    """The library gives the command line's answer: the curve at module length 5 mm is drawn at a 1 mm feed."""
    lib = bhr.follow(bhr.trajectory("curve"), module_length=5)
    cli_like = bhr.follow(bhr.model._generators.load_trajectory("curve", feed=1.0), module_length=5)
    assert lib.trajectory.feed == 1.0 and lib.steps == cli_like.steps
    assert lib.summary.tip_max_error_mm == cli_like.summary.tip_max_error_mm
    assert lib.summary.tip_max_error_mm < 1.0  # not the 63 mm of a 2 mm path driven at a 1 mm feed


@pytest.mark.run
def test_follow_keeps_the_lumen_for_the_lumen_solver():
    run = bhr.follow(bhr.trajectory("anatomy", seed=7), solver="lumen", modules=5)
    assert run.trajectory.lumen is not None and "min_clearance_mm" in run.summary.to_dict()


def test_points_spaced_otherwise_than_the_feed_are_refused_naming_the_fix():
    pts = bhr.trajectory("curve").points
    with pytest.raises(BhrError, match=r"points are 1\.999 mm apart but the robot advances 1 mm a step.*feed=1"):
        bhr.follow(pts, module_length=5)
    run = bhr.follow(Trajectory("mine", pts).at_feed(1.0), module_length=5)
    assert run.steps > len(pts)


def test_at_feed_draws_builtins_again_exactly():
    t = bhr.trajectory("spiral").at_feed(1.0)
    assert np.array_equal(t.points, bhr.model._generators.load_trajectory("spiral", feed=1.0).points)
    assert t.at_feed(1.0) is t


@settings(max_examples=40, deadline=None)
@given(st.floats(0.3, 5.0), st.floats(20.0, 200.0), st.floats(30.0, 300.0))
def test_resampled_points_are_one_feed_apart(feed, radius, angle):
    """Resampling a polyline keeps its first point and spaces every point exactly one feed from the last."""
    th = np.radians(np.linspace(0.0, angle, 400))  # at least 10 mm of arc: more than one feed
    pts = np.stack([radius * np.sin(th), radius * (1 - np.cos(th)), np.zeros_like(th)], axis=1)
    out, _ = resample_polyline(pts, feed)
    assert np.array_equal(out[0], pts[0])
    gaps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert len(out) >= 2 and np.allclose(gaps, feed, rtol=1e-9) and spacing(out) == pytest.approx(feed)


# ------------------------------------------------------------------ settings through the registry
@pytest.mark.parametrize("call", [
    lambda: bhr.follow(bhr.trajectory("line"), modles=5),
    lambda: bhr.solve([3, 9, 0], modles=5),
])
def test_a_misspelt_robot_setting_gets_a_did_you_mean(call):
    with pytest.raises(BhrError, match="'modles' is not a robot setting; did you mean 'modules'"):
        call()


def test_robot_settings_are_checked_by_the_registry():
    with pytest.raises(BhrError, match="modules = 5000 is too large; the limit is 1000"):
        bhr.follow(bhr.trajectory("line"), modules=5000)
    with pytest.raises(BhrError, match="alpha must be a number"):
        bhr.solve([3, 9, 0], alpha="ten")
    assert bhr.follow(bhr.trajectory("line", feed=1.6), robot_radius=4, module_length=8).robot.robot_radius == 4


def test_a_misspelt_solver_option_gets_a_did_you_mean():
    with pytest.raises(BhrError, match="does not take the option 'windw'; did you mean 'window'"):
        bhr.follow(bhr.trajectory("line"), solver="lumen", solver_options={"windw": 3})
    with pytest.raises(BhrError, match="unknown solver 'thesus'; did you mean 'thesis'"):
        bhr.follow(bhr.trajectory("line"), solver="thesus")


def test_the_defaults_are_in_the_signatures():
    import inspect
    assert inspect.signature(bhr.follow).parameters["robot"].default == bhr.Robot()
    assert inspect.signature(bhr.solve).parameters["robot"].default == bhr.Robot(modules=5, module_length=2.0,
                                                                                 tol_pos=0.01, max_iter=30)


# ------------------------------------------------------------------ solver objects and plug-ins
@pytest.mark.run
def test_a_configured_solver_object_is_accepted():
    robot = bhr.Robot(alpha=12)
    s = solvers.get_solver("lumen", robot, window=30.0)
    run = bhr.follow(bhr.trajectory("anatomy", seed=3), solver=s)
    assert run.robot == robot and run.solver == "lumen" and run.trajectory.feed == robot.feed
    with pytest.raises(BhrError, match="was built for Robot\\(alpha=12\\), not for Robot\\(module_length=6"):
        bhr.follow(bhr.trajectory("line"), solver=s, module_length=6)
    res = bhr.solve([3, 9, 0], solver=solvers.get_solver("ccd", bhr.Robot(modules=5, module_length=2.0, tol_pos=0.01)))
    assert res.iterations == 16  # Table 5.1


def test_a_solver_from_another_package_is_found_by_its_entry_point(tmp_path, monkeypatch):
    pkg = tmp_path / "bhrplug"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(textwrap.dedent('''
        from bhr.solvers import Solver, SolveResult

        class Stay(Solver):
            name = "stay"
            summary = "keeps the chain where it is"
            accepts_orientation = False

            def __init__(self, robot, patience=1):
                super().__init__(robot)
                self.patience = patience

            def solve(self, chain, target, tip_direction=None, context=None):
                import numpy as np
                return SolveResult(chain.copy(), 0, float(np.linalg.norm(chain.points[-1] - target)), None)
    '''))
    dist = tmp_path / "bhrplug-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: bhrplug\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[bhr.solvers]\nstay = bhrplug:Stay\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(solvers, "_loaded", False)
    monkeypatch.setattr(solvers, "REGISTRY", dict(solvers.REGISTRY))
    assert "stay" in solvers.available()
    res = bhr.solve([0, 10, 0], solver="stay", modules=5)  # the straight chain's tip: reached as it stands
    assert res.status == "reached" and res.iterations == 0
    with pytest.raises(BhrError, match="does not take the option 'patiense'; did you mean 'patience'"):
        solvers.get_solver("stay", bhr.Robot(), patiense=2)
    sys.modules.pop("bhrplug", None)


# ------------------------------------------------------------------ results say whether and why
def test_a_solver_called_directly_says_whether_it_succeeded():
    robot = bhr.Robot(modules=5, module_length=2.0, tol_pos=0.01)
    s = solvers.get_solver("fabrik", robot)
    res = s.solve(solvers.Chain.straight(robot, (0, 1, 0)), np.array([3.0, 9.0, 0.0]))
    assert res.success is True and res.status == "reached"
    far = s.solve(solvers.Chain.straight(robot, (0, 1, 0)), np.array([0.0, 90.0, 0.0]))
    assert far.success is False and far.status == "out of reach" and "90 mm from the base" in far.reason


def test_results_print_short():
    run = bhr.follow(bhr.trajectory("curve"))
    for obj in (run, run.summary, run.trajectory, run.robot, bhr.solve([3, 9, 0])):
        text = repr(obj)
        assert len(text) < 200 and "\n" not in text and "array(" not in text
    assert repr(run) == "FollowResult(thesis on curve, 5 modules, 85 steps: followed; tip worst 4.905 mm at step 69)"


def test_the_result_of_follow_is_public_and_documents_every_field():
    """``bhr.FollowResult`` is what ``bhr.follow`` returns, so a user can annotate with it; its docstring's
    Attributes name every field, with a shape for every array."""
    import dataclasses
    import typing

    from numpydoc.docscrape import ClassDoc

    run: bhr.FollowResult = bhr.follow(bhr.trajectory("line", length=20))
    assert type(run) is bhr.FollowResult and "FollowResult" in bhr.__all__ and "FollowResult" in dir(bhr)
    assert typing.get_type_hints(bhr.follow)["return"] is bhr.FollowResult
    attributes = {a.name: a for a in ClassDoc(bhr.FollowResult)["Attributes"]}
    fields = {f.name for f in dataclasses.fields(bhr.FollowResult)}
    assert fields <= set(attributes), sorted(fields - set(attributes))
    for name, a in attributes.items():
        if isinstance(getattr(run, name), np.ndarray):
            assert "shape (" in a.type, name  # an array's shape, e.g. (N, n+1, 3)
            assert any(u in " ".join(a.desc) for u in ("mm", "deg", "int", "no unit")), name  # and its unit


@pytest.mark.run
def test_a_run_says_when_it_touched_the_wall():
    run = bhr.follow(bhr.trajectory("anatomy", seed=3), solver="lumen", alpha=20)
    assert run.summary.extra["left_lumen_step"] is None and run.summary.extra["wall_touch_steps"]
    assert run.success is False and run.status == "touched the wall" and "touches the wall at" in run.reason
    assert bhr.follow(bhr.trajectory("curve")).success is True


def test_a_run_that_left_the_lumen_says_so_before_touching_and_tolerance():
    """The gravest verdict wins: the thesis robot on colon 3 goes through the wall (and touches it, and is out of
    tolerance); its verdict is that it left the lumen, with the step and the depth."""
    run = bhr.follow(bhr.trajectory("anatomy", seed=3))
    x = run.summary.extra
    assert x["wall_touch_steps"] and run.summary.tolerance_exceeded and x["left_lumen_step"] is not None
    assert run.status == "left the lumen" and f"left the lumen at step {x['left_lumen_step']}" in run.reason
    assert run.summary.to_dict()["verdict"] == "left the lumen" and run.finished == "ran to the end"


def test_every_quantity_has_its_unit_in_its_name_and_the_old_names_are_gone():
    run = bhr.follow(bhr.trajectory("anatomy", seed=2), body_modules=7)
    assert run.point_errors_mm.shape == (run.steps, run.modules + 1)
    assert run.orientation_errors_deg.shape == (run.steps, run.modules)
    assert run.body is not None and run.clearance is not None
    for obj, old in ((run, "point_errors"), (run, "orientation_errors"), (run.body, "point_errors"),
                     (run.body, "orientation_errors"), (run.clearance, "contact_length"),
                     (bhr.solve([3, 9, 0]), "position_error")):
        assert not hasattr(obj, old), (type(obj).__name__, old)


def test_dir_shows_the_supported_api():
    names = dir(bhr)
    for name in ("follow", "trajectory", "solve", "Robot", "Trajectory", "Solver", "model", "solvers", "output"):
        assert name in names
    assert not [n for n in names if n.startswith("_") and n not in ("__version__",)]


def test_solve_iterates_with_the_command_lines_defaults():
    """bhr.solve's chain and tolerance are bhr solve's: 3.16 mm off is not reached after 0 iterations."""
    res = bhr.solve([3, 9, 0])
    assert res.status == "reached" and res.position_error_mm <= 0.01 and res.iterations > 0
    from bhr.model._robot import CHAPTER5_ROBOT

    assert (CHAPTER5_ROBOT.modules, CHAPTER5_ROBOT.module_length, CHAPTER5_ROBOT.tol_pos, CHAPTER5_ROBOT.max_iter) == \
        (5, 2.0, 0.01, 30)


def test_a_source_checkout_finds_its_shipped_trajectories(monkeypatch):
    """Imported from a checkout (no installed bhr.trajectories package), the repository's trajectories/ is used."""
    from importlib import resources
    from pathlib import Path

    from bhr.model import _trajnames as trajnames

    real = resources.files

    def files(name):
        if name == "bhr.trajectories":
            raise ModuleNotFoundError(name)
        return real(name)

    monkeypatch.setattr(trajnames.resources, "files", files)
    folder = trajnames.trajectory_folder()
    assert folder == Path(__file__).resolve().parents[2] / "trajectories"
    assert "anatomy-typical" in trajnames.shipped_csvs()


@pytest.mark.parametrize("package", ["bhr", "bhr.model", "bhr.output", "bhr.solvers"])
def test_each_public_package_lists_what_it_supports_and_every_name_is_there(package):
    mod = importlib.import_module(package)
    assert mod.__all__ and len(set(mod.__all__)) == len(mod.__all__)
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name
    if package != "bhr.solvers":
        assert set(dir(mod)) >= set(mod.__all__) and not [n for n in dir(mod) if n.startswith("_") and
                                                          n != "__version__"]


@pytest.mark.parametrize("feed", [10 ** 400, -(10 ** 400), float("nan"), 1e-320, "2", True])
def test_a_feed_that_is_no_positive_number_is_one_bhr_error(feed):
    """bhr.trajectory(..., feed=10**400) and Trajectory.at_feed: a BhrError naming the feed, never an OverflowError
    from converting an integer of 401 digits to a float."""
    with pytest.raises(BhrError, match="feed must be a positive number of mm, got"):
        bhr.trajectory("line", feed=feed)
    with pytest.raises(BhrError, match="feed must be a positive number of mm, got"):
        bhr.trajectory("curve").at_feed(feed)


@pytest.mark.parametrize("codes", [None, 5, "30600", b"\x03\x00"])
def test_codes_that_are_no_sequence_of_codes_are_one_bhr_error(codes):
    """Robot.fk(None) or fk(5) raised "TypeError: 'NoneType' object is not iterable", and fk("30600") took the text's
    characters for five codes: each is a BhrError saying what codes are."""
    with pytest.raises(BhrError, match="codes must be a sequence of whole numbers, one per module"):
        bhr.Robot().fk(codes)
