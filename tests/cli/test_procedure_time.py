"""One procedure time, named by what sets it: bhr follow and bhr plan agree on it for the same codes and rate, a
fixed rate and the wires' pace are told apart, and a plan's figure is named by its settings."""
from __future__ import annotations

import re

import numpy as np

from bhr._hardware.thermal import DEFAULT_THERMAL, LINK_MARGIN_MS, auto_schedule, check_schedule, pace


def _time(text: str, what: str) -> str:
    m = re.search(what + r" (\d+ min \d+ s|[\d.]+ s) (at [^(\n]*)", text)
    assert m, text
    return m.group(1) + " " + m.group(2).strip()


def test_follow_and_plan_give_one_procedure_time_and_say_what_sets_it(run_bhr_in_process, tmp_path):
    res = run_bhr_in_process("follow", "--traj", "curve", "--angle", "360", "--no-plots", "--out", "run")
    assert res.returncode == 0, res.stderr
    line = next(x for x in res.stdout.splitlines() if x.startswith("Procedure time on the board:"))
    assert "board's limits" not in res.stdout and "--rate 10 shows the schedule" in line
    follow_time = _time(line, "board:")
    plan = run_bhr_in_process("plan", "--codes", "run/codes.csv", "--rate", "10")
    assert plan.returncode == 0, plan.stderr
    assert _time(plan.stdout.splitlines()[-1], "steps,") == follow_time
    assert "at the wires' pace, at most 10 Hz: the wires set" in follow_time
    fast = run_bhr_in_process("plan", "--codes", "run/codes.csv", "--rate", "20")
    assert "at most 20 Hz" in fast.stdout.splitlines()[-1]
    # a second plan at another rate keeps the first's figure: each is named by its settings
    assert (tmp_path / "run" / "thermal-auto-10hz.png").is_file() and (tmp_path / "run" / "thermal-auto-20hz.png").is_file()
    assert "Wrote run/thermal-auto-20hz.png" in fast.stderr


def test_pace_counts_the_steps_each_limit_sets():
    rows = np.zeros((40, 3), dtype=np.int64)
    rows[::4, 0] = 3  # a wire pair switched on and off: it must cool before it contracts again
    auto = auto_schedule(DEFAULT_THERMAL, rows, 10.0, trace=False)
    gaps = np.diff(auto.times_ms)
    capped = int(np.count_nonzero(gaps <= 100 + LINK_MARGIN_MS))
    assert 0 < capped < len(gaps)  # both limits act in this stream
    assert pace(auto) == (f"at the wires' pace, at most 10 Hz: the wires set {len(gaps) - capped} of the {len(gaps)} "
                          f"step times, the 10 Hz cap the other {capped}")
    assert pace(check_schedule(DEFAULT_THERMAL, np.zeros((5, 2), dtype=np.int64), 4.0)) == "at a fixed 4 Hz"
