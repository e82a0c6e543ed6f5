"""The thermal model of the actuator wires (bhr/thermal.py, docs/thermal.md).

The same integer model runs in the firmware (firmware/src/board.c):
tests/integration/test_firmware_thermal.py holds the two equal tick for tick. The compiled kernel equals its numpy reference, the
generated firmware header is current, and schedules are checked and
stretched as the docs say.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr._hardware import thermal as T
from bhr._settings.errors import BhrError

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / "firmware"
P = T.DEFAULT_THERMAL
VALID = (0, 3, 6, 9, 12, 15)


def test_default_figures_follow_from_the_datasheet_values():
    # docs/thermal.md: 1000 ms contraction, 60 % hold duty, 1100 ms relaxation, 3000 ms full-power limit
    assert (P.contract_ms, P.hold_duty, P.relax_ms, P.max_full_ms, P.period_ms) == (1000, 0.6, 1100, 3000, 20)
    assert round(P.tau_ms) == 1091
    assert round(P.theta_relax, 3) == 0.365 and round(P.theta_limit, 3) == 1.560
    # the equations: theta(contract) = 1 at full power; hold duty holds 1; cooling 1 -> relax in relax_ms
    assert P.theta_full * (1 - math.exp(-P.contract_ms / P.tau_ms)) == pytest.approx(1.0)
    assert P.duty * P.theta_full == pytest.approx(1.0)
    assert math.exp(-P.relax_ms / P.tau_ms) == pytest.approx(P.theta_relax)


def test_a_single_tilt_contracts_holds_and_relaxes_in_the_integer_model():
    rows = [[3, 0, 0, 0, 0], [0, 0, 0, 0, 0]]
    sim = T.simulate(P, [0, 16000], rows, end_ms=20000)
    assert 1000 <= sim.max_on_ms[0, 0] <= 1040           # one full-power pulse of the contraction time
    assert sim.max_on_ms[0, 2] == 0
    held = sim.theta[1000 // 20 + 5: 16000 // 20, 0, 0]
    assert np.all(np.abs(held - 1.0) < 0.02)               # held at theta = 1 for 15 s
    assert sim.on_ms[0, 0] == pytest.approx(1000 + 15000 * 0.6, abs=60)
    assert not sim.faults
    after = sim.theta[16000 // 20:, 0, 0]
    relaxed_ms = int(np.argmax(after <= P.theta_relax)) * 20
    assert abs(relaxed_ms - P.relax_ms) <= 40


def test_re_energising_a_wire_before_it_relaxed_is_a_fault():
    rows = [[3, 0, 0, 0, 0], [6, 0, 0, 0, 0], [3, 0, 0, 0, 0]]
    sim = T.simulate(P, [0, 1500, 1700], rows)
    assert sim.faults == [("early", 1, 3)]
    ok = T.simulate(P, [0, 1500, 1500 + 1300], rows)
    assert ok.faults == []


@settings(max_examples=20, deadline=None)  # each example runs the numpy reference tick by tick (about 0.1 s of CPU)
@given(st.lists(st.tuples(st.integers(0, 900), st.lists(st.sampled_from(VALID), min_size=3, max_size=3)),
                min_size=1, max_size=12), st.booleans(),
       st.none() | st.lists(st.integers(0, 28000), min_size=12, max_size=12))
def test_the_compiled_kernel_equals_the_numpy_reference(steps, auto, theta0):
    gaps = [g for g, _ in steps]
    times = np.cumsum([0] + gaps[1:])
    rows = [c for _, c in steps]
    a = T.simulate(P, times, rows, auto=auto, min_gap_ms=50, theta0=theta0, on_trace=True)
    b = T.simulate(P, times, rows, auto=auto, min_gap_ms=50, reference=True, theta0=theta0, on_trace=True)
    assert np.array_equal(a.on_cum, b.on_cum)
    assert np.array_equal(a.theta, b.theta) and np.array_equal(a.times_ms, b.times_ms)
    assert np.array_equal(a.early, b.early) and np.array_equal(a.overheat_ms, b.overheat_ms)
    assert np.array_equal(a.max_on_ms, b.max_on_ms) and np.array_equal(a.on_ms, b.on_ms)
    assert a.done_ms == b.done_ms and a.end_ms == b.end_ms
    if auto and (theta0 is None or max(theta0) < T.model_constants(P)["THETA_LIMIT"]):
        assert a.faults == []  # a wire past the limit at the start overheats whatever is sent


def test_no_code_sequence_drives_a_wire_past_the_duty_limit():
    # the model's bound: a wire is at full power only below theta = 1, so its on-time over any window W is at
    # most (W + tau) * max_theta / theta_full; the documented limit (docs/thermal.md) is checked on hostile
    # sequences: alternating neighbours, all-on held, and rows as fast as the board takes them
    rng = np.random.default_rng(3)
    w = T.DUTY_WINDOW_MS
    for kind in ("alternate", "all-on", "flood", "random"):
        if kind == "alternate":
            times = list(range(0, 60_000, 1100))
            rows = [[(3, 6)[k % 2], (6, 12)[k % 2], (12, 9)[k % 2], (9, 3)[k % 2], (15, 3)[k % 2]]
                    for k in range(len(times))]
        elif kind == "all-on":
            times, rows = [0], [[15] * 5]
        elif kind == "flood":
            times = list(range(0, 60_000, 20))
            rows = [[int(rng.choice(VALID)) for _ in range(5)] for _ in times]
        else:
            times = np.cumsum(rng.integers(20, 2000, size=60)).tolist()
            rows = [[int(rng.choice(VALID)) for _ in range(5)] for _ in times]
        sim = T.simulate(P, times, rows, end_ms=60_000, on_trace=True)
        assert (sim.faults == []) == (kind == "all-on"), kind  # the others re-energise wires early, refused
        assert sim.max_theta.max() <= 1.02, kind
        assert sim.max_window_duty(w).max() <= T.duty_limit(P), (kind, sim.max_window_duty(w).max())


def test_fixed_rate_schedules_are_checked_and_auto_schedules_fit():
    rows = np.array([[0, 0, 0]] + [[3, 0, 0]] * 40 + [[6, 3, 0]] * 5 + [[3, 3, 0], [3, 6, 15], [0, 0, 0], [3, 0, 0]])
    fixed = T.check_schedule(P, rows, 20)
    assert fixed.faults and fixed.faults[0][0] == "early"
    auto = T.auto_schedule(P, rows, 20)
    assert auto.faults == []
    assert np.all(np.diff(auto.times_ms) >= 50)
    assert auto.sim.max_on_ms.max() < P.max_full_ms
    # and the auto schedule, replayed as fixed times (with the link margin), is still accepted
    again = T.simulate(P, auto.times_ms, rows)
    assert again.faults == []
    assert "steps" in T.summarize(auto, "x") and "at the wires' pace, at most " in T.summarize(auto)


def test_bad_thermal_tables_are_one_line():
    with pytest.raises(BhrError, match="hold_duty"):
        T.thermal_from_table({"hold_duty": 1.5})
    with pytest.raises(BhrError, match="unknown key 'x'"):
        T.thermal_from_table({"x": 1})
    with pytest.raises(BhrError, match="max_full_ms"):
        T.thermal_from_table({"max_full_ms": 1000})
    with pytest.raises(BhrError, match="must be a number"):
        T.thermal_from_table({"relax_ms": "fast"})


def test_the_plan_figure_draws_wires_that_move_together_as_one_named_line():
    import os

    os.environ.setdefault("MPLBACKEND", "Agg")
    from bhr.output._thermal_plot import schedule_figure, wire_groups

    # module 1 tilts with code 3 (wires 1+2) then 12 (wires 3+4); module 2 with code 6 only, then rests
    rows = np.array([[3, 6], [0, 6], [12, 0], [0, 0]])
    sched = T.auto_schedule(T.DEFAULT_THERMAL, rows, 10.0)
    assert wire_groups(sched.sim.theta[:, 0, :]) == [(0, 1), (2, 3)]
    assert wire_groups(sched.sim.theta[:, 1, :]) == [(0, 3), (1, 2)]  # wires 1 and 4 never on: equal too
    fig = schedule_figure(sched)
    try:
        lines = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label().startswith("actuator")]
        assert [ln.get_label() for ln in lines] == ["actuators 1+2", "actuators 3+4", "actuators 1+4", "actuators 2+3"]
        for ax in fig.axes:  # no two wire lines of a panel lie on each other
            ys = [tuple(ln.get_ydata()) for ln in ax.get_lines() if ln.get_label().startswith("actuator")]
            assert len(set(ys)) == len(ys)
        legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert legend[:4] == ["actuators 1+2", "actuators 1+4", "actuators 2+3", "actuators 3+4"]
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)


def _fix_rate(rows, rate):
    """The rate a refused fixed-rate plan names as its fix, or None when it is accepted or names none."""
    import re

    try:
        T.plan(T.DEFAULT_THERMAL, rows, rate, "rate", trace=False)
    except BhrError as exc:
        m = re.search(r"use --rate ([0-9.]+) or", str(exc))
        return float(m.group(1)) if m else None
    return None


def test_the_rate_a_refusal_names_is_accepted_when_acceptance_is_not_monotonic():
    """A file (found by a tester's random codes) refused at 2 Hz was told "use --rate 0.9", which was refused in
    turn ("use --rate 0.8"): a slower rate is not always accepted, so the bisection's answer is checked itself."""
    from bhr.model._codes import read_codes_csv

    _, rows = read_codes_csv(Path(__file__).resolve().parents[1] / "data" / "rate-hint-not-monotonic.csv")
    assert T.check_schedule(T.DEFAULT_THERMAL, rows, 0.9, trace=False).faults  # the old advice: refused
    fix = _fix_rate(rows, 2.0)
    assert fix is not None and not T.check_schedule(T.DEFAULT_THERMAL, rows, fix, trace=False).faults


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.sampled_from(VALID), min_size=3, max_size=3), min_size=2, max_size=40),
       st.sampled_from([1.0, 2.0, 5.0, 10.0, 20.0]))
def test_a_refused_rate_names_a_rate_the_model_accepts(rows, rate):
    fix = _fix_rate(np.asarray(rows, dtype=np.int64), rate)
    if fix is not None:
        assert 0.1 <= fix <= rate
        assert not T.check_schedule(T.DEFAULT_THERMAL, np.asarray(rows, dtype=np.int64), fix, trace=False).faults
