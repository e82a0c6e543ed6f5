"""The physics replay's options are refused before any work when the replay could not be trusted."""
from __future__ import annotations

import pytest

from bhr.settings.errors import BhrError
from bhr.studies.physics import MAX_TIMESTEP_MS, SERVO_HZ, check_replay_options


@pytest.mark.parametrize("rate, substeps", [(20.0, 1), (20.0, 7), (2.5, 63), (100.0, 1)])
def test_a_time_step_too_long_for_the_servos_is_refused_with_the_substeps_it_needs(rate, substeps):
    with pytest.raises(BhrError) as e:
        check_replay_options(1.5, rate, substeps)
    msg = str(e.value)
    need = next(k for k in range(1, 10_000) if 1000.0 / (rate * k) <= MAX_TIMESTEP_MS)
    assert "\n" not in msg and f"--substeps {need} or more" in msg and "blow up" in msg
    check_replay_options(1.5, rate, need)  # what the line asks for is accepted


@pytest.mark.parametrize("rate, substeps", [(20.0, 8), (20.0, 16), (2.5, 128), (1000.0, 1)])
def test_time_steps_that_resolve_the_servos_are_accepted(rate, substeps):
    check_replay_options(1.5, rate, substeps)


def test_the_bound_resolves_the_servos_frequency():
    import math

    assert 2 * math.pi * SERVO_HZ * MAX_TIMESTEP_MS / 1000.0 < 2.0  # the explicit part's stability bound
