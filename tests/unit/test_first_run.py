"""A first run on a cold cache: kernels interpreted where that costs less than compiling (bhr._numba.call_cold).

The interpreted code must give the compiled kernel's results exactly (the same statements on the same float64
values), so that a first run and every later run write the same files: checked bit for bit on random cases of
each kernel that may run interpreted. And the choice itself: interpreted only while allowed, cold, and within
what compiling costs.
"""
from __future__ import annotations

import contextlib
import importlib.util

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import bhr
from bhr import _numba
from bhr.model.codes import VALID_CODES


@contextlib.contextmanager
def running(module, interpreted: bool):
    """``module``'s call_cold runs its kernel interpreted (as on a cold cache) or compiled; yields the kernels run."""
    ran: list[str] = []

    def call(kernel, interpreted_s, compile_s, *args, instead=None):
        func = kernel.py_func
        ran.append(func.__name__)
        if not interpreted:
            return kernel(*args)
        return (instead if instead is not None else _numba.interpreted(kernel))(*args)

    saved = module.call_cold
    module.call_cold = call
    try:
        yield ran
    finally:
        module.call_cold = saved


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)


@settings(max_examples=12, deadline=None)
@given(angle=st.floats(5, 150), modules=st.integers(2, 6), alpha=st.sampled_from([5.0, 10.0, 17.5, 25.0]),
       feed_divisor=st.integers(1, 5), solver=st.sampled_from(["thesis", "constrained"]))
def test_the_thesis_loop_interpreted_gives_the_compiled_results_bit_for_bit(angle, modules, alpha, feed_divisor,
                                                                            solver):
    from bhr.solvers import thesis

    traj = bhr.trajectory("curve", angle=angle, entry=10, exit=10)
    kw = dict(solver=solver, modules=modules, alpha=alpha, feed_divisor=feed_divisor)
    with running(thesis, interpreted=True) as ran:
        slow = bhr.follow(traj, **kw)
    assert ran == ["follow_constrained_kernel"]
    with running(thesis, interpreted=False):
        fast = bhr.follow(traj, **kw)
    for name in ("points", "iterations", "point_errors_mm", "orientation_errors_deg", "codes"):
        assert _same(getattr(slow, name), getattr(fast, name)), name


@settings(max_examples=25, deadline=None)
@given(rows=st.integers(1, 4).flatmap(lambda m: st.lists(
           st.lists(st.sampled_from(sorted(VALID_CODES)), min_size=m, max_size=m), min_size=1, max_size=30)),
       rate=st.floats(0.2, 20.0), auto=st.booleans())
def test_the_drive_model_interpreted_gives_the_compiled_results_bit_for_bit(rows, rate, auto):
    from bhr.hardware import thermal

    table = np.array(rows, dtype=np.int64)
    plan = thermal.auto_schedule if auto else thermal.check_schedule
    with running(thermal, interpreted=True) as ran:
        slow = plan(thermal.DEFAULT_THERMAL, table, rate)
    assert ran == ["_kernel_py"]
    with running(thermal, interpreted=False):
        fast = plan(thermal.DEFAULT_THERMAL, table, rate)
    assert _same(slow.times_ms, fast.times_ms)
    for name in ("theta", "early", "overheat_ms", "max_on_ms", "max_theta", "on_ms"):
        assert _same(getattr(slow.sim, name), getattr(fast.sim, name)), name
    assert (slow.sim.done_ms, slow.sim.end_ms, slow.faults) == (fast.sim.done_ms, fast.sim.end_ms, fast.faults)


def test_the_clearance_in_numpy_gives_the_compiled_results_bit_for_bit():
    from bhr.run import clearance

    from bhr.bench.lumen import tight_colon

    tr = tight_colon(4)  # contacts, a body, the robot entering: every branch of the search
    r = bhr.follow(tr, solver="seed", body_modules=9)
    Q, E, _ = clearance.run_chain(r)
    Q, E = Q[:150], E[:150]
    tube = clearance.make_tube(tr.points, tr.lumen, tr.start_direction)
    with running(clearance, interpreted=True) as ran:
        slow = clearance.clearance_run_all(tube, 5.0, Q, E)
    assert ran == ["_run_kernel"]
    with running(clearance, interpreted=False):
        fast = clearance.clearance_run_all(tube, 5.0, Q, E)
    for a, b in zip(slow, fast):
        assert _same(a, b)
    assert np.nanmin(fast[1]) < 0  # the case has contacts



def _both(tube, radius, Q, E, advance=1.0, sample=1.0):
    """The compiled run and the numpy run of the clearance: (points, modules, where, lost) each."""
    from bhr.run import clearance

    S, BC, BR = tube.search_arrays()
    N, K = E.shape
    out = []
    for run in (clearance._run_kernel, clearance._run_vectorised):
        res = (np.empty((N, K)), np.empty((N, K - 1)), np.empty((N, K - 1, 3)), np.zeros(N))
        run(tube.points, tube.radius, S, BC, BR, float(tube.pre), float(tube.window), float(radius),
            np.ascontiguousarray(Q, dtype=float), np.ascontiguousarray(E, dtype=float), float(advance),
            float(sample), *res)
        out.append(res)
    return out


def _u_turn(gap: float) -> np.ndarray:
    """Out along x for 150 mm, a half circle, back 150 mm: limbs whose centerlines are ``gap`` mm apart."""
    out = np.stack([np.arange(0, 150, 1.0), np.zeros(150), np.zeros(150)], axis=1)
    t = np.linspace(0, np.pi, int(gap * 1.6) + 2)[1:-1]
    turn = np.stack([149 + gap / 2 * np.sin(t), gap / 2 - gap / 2 * np.cos(t), np.zeros_like(t)], axis=1)
    back = np.stack([np.arange(149, -1, -1.0), np.full(150, gap), np.zeros(150)], axis=1)
    return np.vstack([out, turn, back])


@settings(max_examples=40, deadline=None)
@given(gap=st.floats(12.0, 60.0), diameter=st.floats(8.0, 50.0), closed=st.booleans(),
       radius=st.floats(0.5, 9.0), K=st.integers(1, 9), N=st.integers(1, 40), start=st.floats(-30.0, 300.0),
       lag=st.floats(-40.0, 40.0), wobble=st.floats(0.0, 40.0), spacing=st.floats(0.5, 3.0),
       link=st.floats(2.0, 25.0), sample=st.sampled_from([0.3, 1.0, 4.0]), seed=st.integers(0, 2**32 - 1))
def test_the_clearance_in_numpy_is_the_kernels_bit_for_bit_on_any_chain(gap, diameter, closed, radius, K, N, start,
                                                                          lag, wobble, spacing, link, sample, seed):
    """Random chains in a U-turn whose limbs' lumens are apart, touch or overlap: points behind the entrance,
    points strayed from where they are expected, deep in the wall, across into the other limb: the numpy run
    (a first run's) writes what the compiled kernels write, bit for bit."""
    from bhr.run import clearance

    rng = np.random.default_rng(seed)
    path = _u_turn(gap)[:: max(1, int(round(spacing)))]
    tube = clearance.make_tube(path, np.full(len(path), diameter), closed_end=closed)
    n = len(path)
    E = start + np.arange(N)[:, None] * 1.5 - np.arange(K)[None, :] * link / spacing  # tail to tip: tip first
    E = E[:, ::-1].copy()
    at = np.clip(E + lag * rng.uniform(-1, 1, E.shape), 0, n - 1)
    Q = path[np.floor(at).astype(int)] + wobble * rng.uniform(-1, 1, (N, K, 3))
    fast, slow = _both(tube, radius, Q, E, advance=1.5, sample=sample)
    for a, b in zip(fast, slow):
        assert _same(a, b)


@pytest.mark.parametrize("small", [False, True])
def test_the_clearance_in_numpy_finds_a_crossing_as_the_kernel_does(small, monkeypatch):
    """A point that left its limb's lumen for the other limb's is flagged (lost) by both, on the same steps; and
    the same when the numpy version works a few points and modules at a time (its memory bound)."""
    from bhr.model import tube as tube_module
    from bhr.run import clearance

    if small:
        monkeypatch.setattr(tube_module, "_BATCH_PAIRS", 40)
        monkeypatch.setattr(clearance, "_MODULES_AT_ONCE", 3)

    path = _u_turn(35.0)
    tube = clearance.make_tube(path, np.full(len(path), 30.0), closed_end=True)
    along = np.arange(20.0, 120.0, 2.0)
    y = np.linspace(0.0, 35.0, along.size)  # from the outgoing limb's axis to the other limb's
    Q = np.stack([np.stack([along, np.zeros_like(along), np.zeros_like(along)], 1),
                  np.stack([along + 8.0, y, np.zeros_like(along)], 1)], axis=1)
    E = np.stack([along, along + 8.0], axis=1)
    fast, slow = _both(tube, 5.0, Q, E)
    for a, b in zip(fast, slow):
        assert _same(a, b)
    assert fast[3].any() and not fast[3].all()


def test_a_numpy_run_past_its_deadline_gives_way_to_the_compiled_kernel(monkeypatch):
    """The numpy run stops at its deadline (TooSlow) and call_cold runs the kernel: the same results."""
    from bhr.run import clearance

    path = _u_turn(35.0)
    tube = clearance.make_tube(path, np.full(len(path), 30.0), closed_end=True)
    E = np.tile(np.arange(3.0) * 10 + 20, (200, 1)) + np.arange(200.0)[:, None] * 0.5
    Q = path[E.astype(int)] + 3.0
    with pytest.raises(_numba.TooSlow):
        S, BC, BR = tube.search_arrays()
        clearance._run_vectorised(tube.points, tube.radius, S, BC, BR, float(tube.pre), float(tube.window), 5.0, Q,
                                  E, 1.0, 1.0, np.empty((200, 3)), np.empty((200, 2)), np.empty((200, 2, 3)),
                                  np.zeros(200), deadline=0.0)
    tried = []

    def slow(*args, deadline):
        tried.append(deadline)
        raise _numba.TooSlow("test")

    monkeypatch.setattr(_numba, "_interpreting", True)
    monkeypatch.setattr(_numba, "_spent", {})
    monkeypatch.setattr(_numba, "is_ready", lambda kernel: False)
    monkeypatch.setattr(clearance, "_run_vectorised", slow)
    got = clearance.clearance_run_all(tube, 5.0, Q, E)
    assert len(tried) == 1
    monkeypatch.setattr(_numba, "_interpreting", False)
    want = clearance.clearance_run_all(tube, 5.0, Q, E)
    for a, b in zip(got, want):
        assert _same(a, b)
    clearance.clearance_run_all(tube, 5.0, Q, E)  # compiled from now on: the numpy run is not tried again
    monkeypatch.setattr(_numba, "_interpreting", True)
    clearance.clearance_run_all(tube, 5.0, Q, E)
    assert len(tried) == 1


def test_the_warmup_leaves_a_cache_to_the_compile_already_at_work(tmp_path, monkeypatch):
    """bhr.warmup.run_once: while another process holds the cache's lock it ends at once, compiling nothing."""
    import fcntl

    from bhr import warmup

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    ran = []
    monkeypatch.setattr(warmup, "compile_all", lambda: ran.append(1))
    with open(tmp_path / ".bhr-warmup.lock", "a") as held:  # another compile at work (flock: per open file)
        fcntl.flock(held.fileno(), fcntl.LOCK_EX)
        assert warmup.run_once() == 0 and ran == []
    assert warmup.run_once() == 0 and ran == [1]  # free again: it compiles


# --- the choice: interpreted only while allowed, cold and within what compiling costs --------------------------

KERNEL = '''
from bhr._numba import njit


@njit(cache=True)
def twice(x):
    out = 0.0
    for i in range(x.shape[0]):
        out += 2.0 * x[i]
    return out
'''


def _fresh_kernel(tmp_path, name: str):
    """A kernel of its own (a module file of its own: no cache entry anywhere yet)."""
    path = tmp_path / f"{name}.py"
    path.write_text(KERNEL)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.twice


@pytest.fixture
def choice(monkeypatch):
    monkeypatch.setattr(_numba, "_interpreting", False)
    monkeypatch.setattr(_numba, "_spent", {})
    return _numba


def test_a_cold_kernel_runs_interpreted_only_where_allowed(tmp_path, choice):
    k = _fresh_kernel(tmp_path, "cold_a")
    x = np.arange(4.0)
    assert choice.call_cold(k, 0.1, 1.0, x) == 12.0  # not allowed (a library program): compiled
    assert k.overloads and not choice.interpreted_any()

    k = _fresh_kernel(tmp_path, "cold_b")
    choice.allow_interpreting()
    assert not choice.is_ready(k)
    assert choice.call_cold(k, 0.1, 1.0, x) == 12.0
    assert not k.overloads and choice.interpreted_any()  # interpreted: nothing compiled


def test_a_call_that_would_cost_more_than_compiling_compiles(tmp_path, choice):
    choice.allow_interpreting()
    k = _fresh_kernel(tmp_path, "cold_c")
    x = np.arange(3.0)
    choice.call_cold(k, 0.6, 1.0, x)
    assert not k.overloads  # 0.6 s of the 1 s: interpreted
    choice.call_cold(k, 0.6, 1.0, x)
    assert k.overloads  # 1.2 s in all would pass what compiling costs: compiled
    k2 = _fresh_kernel(tmp_path, "cold_d")
    choice.call_cold(k2, 2.0, 1.0, x)
    assert k2.overloads  # one large call: compiled at once


def test_interpreted_code_calls_no_compiled_kernel():
    """Every kernel an interpreted kernel calls, however deep, is itself interpreted (no compile hides there)."""
    import types

    from bhr.hardware import thermal
    from bhr.solvers import thesis

    seen: set = set()

    def walk(func) -> None:
        assert isinstance(func, types.FunctionType) and not _numba._is_kernel(func)
        if func in seen:
            return
        seen.add(func)
        for name in func.__code__.co_names:
            value = func.__globals__.get(name)
            assert not _numba._is_kernel(value), (func.__name__, name)
            if isinstance(value, types.FunctionType) and value.__code__.co_filename.startswith(bhr.__path__[0]):
                walk(value)

    for kernel in (thesis.follow_constrained_kernel, thermal._compiled()):
        walk(_numba.interpreted(kernel))
    assert len(seen) > 8  # the loop, the constrained kernel, the leader's step, dual quaternions, the drive's helpers
