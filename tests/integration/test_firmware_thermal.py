"""The firmware's thermal drive and bhr._hardware.thermal compute the same thing, tick for tick.

The portable core of the firmware (firmware/src/board.c) is built for this
machine (`firmware/build/host/test_host_m5 trace`) and driven with the same
schedules as bhr._hardware.thermal.simulate: a fixed one and 1,000 random ones. Every
wire's temperature at every PWM period end, the rows held off as early, the
overheat times and each wire's on-time on the pins must agree.
"""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import make_firmware

from bhr._hardware import thermal as T

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / "firmware"
P = T.DEFAULT_THERMAL
VALID = (0, 3, 6, 9, 12, 15)


@pytest.fixture(scope="module")
def host_exe():
    if shutil.which("make") is None or shutil.which("cc") is None:
        pytest.fail("the firmware's host build needs make and cc (Debian: build-essential)")
    r = make_firmware("-s", "-C", str(FIRMWARE), "build/host/test_host_m5", timeout=300)
    assert r.returncode == 0, r.stderr
    return FIRMWARE / "build" / "host" / "test_host_m5"


def run_firmware_traces(host_exe, schedules):
    """The firmware's C drive on each (times, rows, end, theta0) schedule: a list of
    (theta per period (periods x 1+4m), early {(row, module)}, overheat {module: t}, on_ms)."""
    text = []
    for times, rows, end, theta0 in schedules:
        text.append(f"end {end}\n")
        if theta0 is not None:
            text.append("theta " + " ".join(str(int(v)) for v in np.ravel(theta0)) + "\n")
        text += [f"{t} {' '.join(map(str, r))}\n" for t, r in zip(times, rows)]
        text.append(".\n")
    out = subprocess.run([str(host_exe), "trace"], input="".join(text), capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    results, cur = [], None
    for line in out.stdout.splitlines():
        if cur is None:
            cur = {"theta": [], "early": set(), "overheat": {}, "on": None}
        if line == ".":
            results.append((np.array(cur["theta"]), cur["early"], cur["overheat"], cur["on"]))
            cur = None
        elif line.startswith("early"):
            _, r, m = line.split()
            cur["early"].add((int(r), int(m)))
        elif line.startswith("overheat"):
            _, m, t = line.split()
            cur["overheat"][int(m)] = int(t)
        elif line.startswith("on"):
            cur["on"] = np.array([int(v) for v in line.split()[1:]])
        else:
            cur["theta"].append([int(v) for v in line.split()])
    assert len(results) == len(schedules)
    return results


def assert_host_equals_firmware(schedule, fw):
    times, rows, end, theta0 = schedule
    c_theta, c_early, c_over, c_on = fw
    sim = T.simulate(P, times, rows, end_ms=end, theta0=theta0)
    py = np.rint(sim.theta.reshape(sim.theta.shape[0], -1) * T.ONE).astype(np.int64)
    assert c_theta.shape == (end // 20 + 1, 21)
    assert np.array_equal(c_theta[:, 0], np.arange(0, end + 1, 20))
    bad = np.argwhere(c_theta[:, 1:] != py)
    assert bad.size == 0, (schedule, bad[:5])
    assert {(int(r) + 1, int(m) + 1) for r, m in zip(*np.nonzero(sim.early))} == c_early, schedule
    assert {j + 1: int(t) for j, t in enumerate(sim.overheat_ms) if t >= 0} == c_over, schedule
    assert np.array_equal(sim.on_ms.reshape(-1), c_on), schedule


def random_schedule(rng):
    """Rows of stable codes at random gaps (short ones re-energise wires early, codes that share a
    wire alternate), a random end, and in a third of the schedules hot starting wires (some past the limit)."""
    n = int(rng.integers(1, 14))
    gaps = rng.choice([20, 150, 400, 900, 1200, 1500, 2500, 4000], size=n) + rng.integers(0, 60, size=n)
    times = np.cumsum(np.concatenate([[int(rng.integers(0, 100))], gaps[1:]])).astype(int).tolist()
    rows = []
    for _ in range(n):
        if rows and rng.random() < 0.3:  # a neighbour tilt: one wire stays on across the change
            rows.append([{3: 6, 6: 3, 12: 9, 9: 12, 0: 15, 15: 3}[c] for c in rows[-1]])
        else:
            rows.append([int(rng.choice(VALID)) for _ in range(5)])
    end = times[-1] + int(rng.integers(0, 4000))
    theta0 = None
    if rng.random() < 1 / 3:
        theta0 = rng.integers(0, T.model_constants(P)["THETA_LIMIT"] + 2000, size=20)
    return times, rows, end, theta0


def test_the_firmware_runs_the_same_model_tick_for_tick(host_exe):
    # a fixed scenario with early re-energising, then 1,000 random schedules: every wire's temperature at
    # every PWM period end, the rows refused as early, the overheat times and each wire's on-time agree
    rng = np.random.default_rng(7)
    times = [0, 400, 1500, 1700, 2600, 4000, 5200, 5210, 7000, 9000]
    rows = [[3, 0, 6, 0, 15], [3, 12, 6, 0, 15], [6, 12, 6, 9, 0], [3, 12, 6, 9, 0], [12, 12, 0, 9, 3],
            [0, 0, 0, 0, 0], [12, 9, 3, 6, 15], [12, 9, 3, 6, 15], [9, 0, 15, 6, 0], [0, 0, 0, 0, 0]]
    for _ in range(6):
        times.append(times[-1] + int(rng.integers(30, 1500)))
        rows.append([int(rng.choice(VALID)) for _ in range(5)])
    fixed = (times, rows, times[-1] + 3000, None)
    schedules = [fixed] + [random_schedule(rng) for _ in range(1000)]
    results = run_firmware_traces(host_exe, schedules)
    for sched, fw in zip(schedules, results):
        assert_host_equals_firmware(sched, fw)
    assert results[0][1]  # the fixed scenario includes early re-energising, as the C board saw it too
    assert sum(bool(r[1]) for r in results) > 100 and sum(bool(r[2]) for r in results) > 20  # both paths ran


def test_a_wire_that_stays_on_across_code_changes_keeps_its_hold(host_exe):
    # 3 <-> 6 every 1.2 s for 120 s: wire 2 is in both codes; it contracts once, then holds at the hold duty
    # (the full-power phase belongs to each wire, not to the module)
    times = list(range(0, 120_000, 1200))
    rows = [[3 if k % 2 == 0 else 6, 0, 0, 0, 0] for k in range(len(times))]
    sched = (times, rows, 120_000, None)
    fw = run_firmware_traces(host_exe, [sched])[0]
    assert_host_equals_firmware(sched, fw)
    sim = T.simulate(P, times, rows, end_ms=120_000)
    duty = sim.on_ms[0] / 120_000
    assert duty[1] <= P.duty + P.contract_ms / 120_000 + 0.01, duty   # wire 2: ~0.61, not the module's ~0.85
    assert sim.max_theta[0, 1] < 1.02
    assert sim.faults == []
    with_on = T.simulate(P, times, rows, end_ms=120_000, on_trace=True)
    assert with_on.max_window_duty().max() <= T.duty_limit(P) == pytest.approx(0.7)
