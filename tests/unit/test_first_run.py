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

    def call(kernel, interpreted_s, compile_s, *args, shallow=False):
        func = kernel.py_func
        ran.append(func.__name__)
        if not interpreted:
            return kernel(*args)
        return (func if shallow else _numba.interpreted(kernel))(*args)

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


def test_the_clearance_loop_in_python_gives_the_compiled_results_bit_for_bit():
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
