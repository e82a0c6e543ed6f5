"""pytest-benchmark versions of the `bhr bench` cases (not part of the default test run).

Run them with:  python3 -m pytest tests/benchmarks/bench_kernels.py --benchmark-only
(files here are named bench_*.py, which pytest's default python_files pattern, test_*.py, does not match, so
neither the default run nor `pytest tests/benchmarks` collects them; name the file, or pass
`-o python_files='bench_*.py'`). The numbers to compare are each group's medians: bhr against numpy.
"""
import numpy as np
import pytest

from bhr._bench.cases import numpy_ccd, numpy_fabrik, numpy_seed_follow
from bhr._run.driver import follow
from bhr.model._robot import straight_chain
from bhr.solvers._ccd import ccd_kernel
from bhr.solvers._fabrik import fabrik_kernel
from bhr.model._generators import load_trajectory

P0 = straight_chain(10, 2.0, (0, 1, 0))
T = np.array([15.0, 6.0, 0.0])
ZERO = np.zeros(3)


@pytest.mark.benchmark(group="fabrik-ch5-10")
def test_fabrik_bhr(benchmark):
    k, err, _ = benchmark(lambda: fabrik_kernel(P0.copy(), T, 2.0, 0.01, 30, ZERO, False, 20.0))
    assert k == 12


@pytest.mark.benchmark(group="fabrik-ch5-10")
def test_fabrik_numpy(benchmark):
    assert benchmark(numpy_fabrik, P0, T, 2.0, 0.01, 30)[1] == 12


@pytest.mark.benchmark(group="ccd-ch5-10")
def test_ccd_bhr(benchmark):
    assert benchmark(lambda: ccd_kernel(P0.copy(), T, 0.01, 30))[0] == 12


@pytest.mark.benchmark(group="ccd-ch5-10")
def test_ccd_numpy(benchmark):
    assert benchmark(numpy_ccd, P0, T, 0.01, 30)[1] == 12


COLON = load_trajectory("colon")


@pytest.mark.benchmark(group="seed-colon")
def test_seed_colon_bhr(benchmark):
    assert benchmark(follow, COLON).steps == len(COLON.points)


@pytest.mark.benchmark(group="seed-colon")
def test_seed_colon_numpy(benchmark):
    benchmark.pedantic(numpy_seed_follow, args=(COLON.points,), rounds=2)


# the clearance of the colon run's first 100 steps to the lumen wall: compiled (local search from a guess) and numpy
def _colon_clearance_inputs():
    from bhr._run.clearance import make_tube, run_chain

    run = follow(COLON)
    tube = make_tube(COLON.points, COLON.lumen, COLON.start_direction, closed_end=True)
    Q, E, _ = run_chain(run)
    return tube, run.robot.robot_radius, Q[:100], E[:100], run.robot.feed / tube.spacing


@pytest.mark.benchmark(group="clearance-colon")
def test_clearance_colon_bhr(benchmark):
    from bhr._run.clearance import clearance_run

    tube, radius, Q, E, adv = _colon_clearance_inputs()
    assert benchmark(clearance_run, tube, radius, Q, E, advance=adv)[1].shape == (100, Q.shape[1] - 1)


@pytest.mark.benchmark(group="clearance-colon")
def test_clearance_colon_numpy(benchmark):
    from bhr._run.clearance import clearance_run_numpy

    tube, radius, Q, E, adv = _colon_clearance_inputs()
    benchmark.pedantic(clearance_run_numpy, args=(tube, radius, Q, E), kwargs={"advance": adv}, rounds=2)


# --solver optimal without its planner (the exact per-step search) and the 60-module body
from bhr._bench.cases import OPTIMAL_PER_STEP, numpy_body, numpy_optimal_follow  # noqa: E402
from bhr._run.body import BODY_BEAM, module1_frames, simulate_body  # noqa: E402

PATH = np.ascontiguousarray(COLON.points)


@pytest.mark.benchmark(group="optimal-step-colon")
def test_optimal_step_colon_bhr(benchmark):
    benchmark(follow, COLON, solver="optimal", solver_options=OPTIMAL_PER_STEP)


@pytest.mark.benchmark(group="optimal-step-colon")
def test_optimal_step_colon_numpy(benchmark):
    benchmark.pedantic(numpy_optimal_follow, args=(PATH, COLON.start_point, COLON.start_direction), rounds=3)


# the default --solver optimal (planner on) and the seed solver, one solve() call per step driven from Python
# (bhr._bench.optimal): whole colon per round; divide by the 827 steps for a mean per step (`bhr bench` gives medians)
from bhr._bench.optimal import _step_times  # noqa: E402
from bhr.model._robot import Robot  # noqa: E402


@pytest.mark.benchmark(group="optimal-default-colon")
@pytest.mark.parametrize("solver", ["optimal", "seed"])
def test_default_solve_driver(benchmark, solver):
    _step_times(COLON, solver, Robot(), None)  # load the kernels
    times = benchmark.pedantic(_step_times, args=(COLON, solver, Robot(), None), rounds=3)
    assert times.shape == (len(COLON.points),)


SEED_RUN = follow(COLON)
START, F1S = module1_frames(SEED_RUN.codes, COLON.start_direction, SEED_RUN.robot.alpha)


@pytest.mark.benchmark(group="body-60-colon")
def test_body_60_bhr(benchmark):
    benchmark(simulate_body, SEED_RUN, 60)


@pytest.mark.benchmark(group="body-60-colon")
def test_body_60_numpy(benchmark):
    r = SEED_RUN.robot
    benchmark.pedantic(numpy_body, args=(np.ascontiguousarray(SEED_RUN.points[:, 0]), F1S, START, 55, r.feed_divisor,
                                         r.feed, r.module_length, r.alpha, BODY_BEAM), rounds=2)
