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


@pytest.mark.parametrize("reached", [(True, True, True), (True, False, True), (False, True, False), None])
def test_force_png_marks_the_poses_whose_force_is_an_estimate(reached):
    """force.png: a cross on the wall's load at every pose whose equilibrium was not reached, counted in the legend;
    the peak in the subtitle says when it is one of them."""
    import numpy as np

    from bhr._studies.physics.replay import PhysicsReplay
    from bhr.output._physics_plot import force_figure

    P, M = 3, 2
    total = np.array([1.0, 5.0, 2.0])
    rep = PhysicsReplay(np.array([1, 2, 3]), np.arange(3.0), total, np.ones((P, M)), np.zeros(P), np.zeros(P),
                        np.full((P, 3), np.nan), np.zeros(P), np.zeros(P), np.zeros(P), np.zeros((P, M + 1, 3)),
                        [np.zeros((0, 3))] * P, None, None, np.ones(P, dtype=np.int64), {}, 0.0, 9.8,
                        None if reached is None else np.array(reached))
    top, bottom = force_figure(rep).axes
    crosses = [ln for ln in top.get_lines() if ln.get_marker() == "x"]
    missed = [] if reached is None else [i for i, ok in enumerate(reached) if not ok]
    if missed:
        (ln,) = crosses
        assert list(ln.get_xdata()) == [i + 1 for i in missed] and list(ln.get_ydata()) == list(total[missed])
        assert ln.get_label() == f"equilibrium not reached: an estimate ({len(missed)} of {P} poses)"
        assert ln.get_label() in [t.get_text() for t in top.get_legend().get_texts()]
    else:
        assert not crosses
    estimate = reached is not None and not reached[1]  # the peak is pose 2's
    assert ("5.00 N, an estimate (" in bottom.get_title()) is estimate and "peak 5.00 N" in bottom.get_title()


@pytest.mark.parametrize("replayed", ["steps", "every pose"])
def test_force_png_says_when_the_motion_between_steps_is_idealised(replayed):
    """A replay of a run's steps (its joints moved linearly between codes, not as its wires move them) is labelled
    an idealisation on force.png, as on the printed line; a replay of every pose is not."""
    import numpy as np

    from bhr._studies.physics.replay import PhysicsReplay
    from bhr.output._physics_plot import force_figure

    P, M = 2, 2
    rep = PhysicsReplay(np.array([1, 2]), np.arange(2.0), np.array([0.5, 1.0]), np.ones((P, M)), np.zeros(P),
                        np.zeros(P), np.full((P, 3), np.nan), np.zeros(P), np.zeros(P), np.zeros(P),
                        np.zeros((P, M + 1, 3)), [np.zeros((0, 3))] * P, None, None, np.ones(P, dtype=np.int64),
                        {"poses_replayed": replayed}, 0.0, 9.8)
    _, bottom = force_figure(rep).axes
    assert ("an idealisation" in bottom.get_title()) is (replayed == "steps")


def test_the_option_registry_defaults_are_the_replays_own_to_the_bit():
    """`bhr physics` passes the registry's defaults; a library call uses the replay's constants. They must be the same
    numbers: a jammed passive body settled elsewhere when its rigidity differed in the last bit (27390.0 against
    0.83 x 330 x 100 = 27389.999999999996) and read 514 N instead of 678 N."""
    import inspect

    from bhr._settings.options import BY_NAME, by_group
    from bhr._studies.physics.replay import replay_poses

    defaults = {k: v.default for k, v in inspect.signature(replay_poses).parameters.items()}
    for option in by_group("physics"):
        assert option.name in defaults, option.name
        assert option.default == defaults[option.name] and type(option.default) is type(defaults[option.name]), (
            option.name, option.default, defaults[option.name])
    assert BY_NAME["passive_rigidity"].default == 27390.0
