"""Solver names are known without the solvers (bad input is refused before numba loads); a small kernel."""
from __future__ import annotations

import types

import pytest

from bhr._settings.errors import BhrError


def test_solver_index_lists_every_solver_class_of_bhr_as_it_registers():
    import bhr.solvers as solvers
    from bhr.solvers._base import REGISTRY
    from bhr.solvers._names import BUILTIN

    solvers.available()  # every solver module loaded
    ours = {cls for cls in REGISTRY.values() if cls.__module__.startswith("bhr.solvers.")}
    assert {cls.name: (cls.__module__.rsplit(".", 1)[1], tuple(cls.aliases)) for cls in ours} == BUILTIN


def test_register_refuses_a_bhr_solver_missing_from_the_index():
    from bhr.solvers._base import Solver, register

    cls = types.new_class("Fresh", (Solver,), {}, lambda ns: ns.update(name="fresh", __module__="bhr.solvers.fresh"))
    with pytest.raises(TypeError, match="bhr/solvers/_names.py"):
        register(cls)


def test_solver_names_are_checked_without_loading_a_solver_module(monkeypatch):
    import bhr.solvers as solvers

    full = solvers.available()  # the message the full registry gives, for comparison
    monkeypatch.setattr(solvers, "_loaded", False)
    monkeypatch.setattr(solvers, "_plugins", lambda: False)

    def refuse() -> None:
        raise AssertionError("a solver module was loaded to check a name")

    monkeypatch.setattr(solvers, "_load_all", refuse)
    assert solvers.check_solver_name("seed") == "thesis" and solvers.canonical("seed") == "thesis"
    assert solvers.check_solver_name("lumen") == "lumen"
    with pytest.raises(BhrError) as err:
        solvers.check_solver_name("thesus", "sweep")
    assert str(err.value) == (f"sweep: unknown solver 'thesus'; did you mean 'thesis'? choose from "
                              f"{', '.join(full)}")


def test_a_solver_another_package_adds_is_looked_up_in_the_full_registry(monkeypatch):
    import bhr.solvers as solvers

    calls = []
    monkeypatch.setattr(solvers, "_loaded", False)
    monkeypatch.setattr(solvers, "_plugins", lambda: True)
    monkeypatch.setattr(solvers, "_load_all", lambda: calls.append(1))
    with pytest.raises(BhrError, match="unknown solver 'plugged'"):
        solvers.check_solver_name("plugged")
    assert calls  # not refused from bhr's own names alone


def test_the_stable_argsort_kernel_is_numpys_mergesort():
    import numpy as np

    from bhr._kinematics.leader import stable_argsort

    rng = np.random.default_rng(5)
    for m in (0, 1, 2, 3, 7, 16, 80, 81, 200):
        keys = rng.integers(0, 6, size=m + 3).astype(np.float64)  # many ties: the order among equals matters
        if m > 4:
            keys[[1, 4]] = np.nan
            keys[2] = np.inf
        assert stable_argsort(keys, m).tolist() == np.argsort(keys[:m], kind="mergesort").tolist()
        smooth = rng.normal(size=m)
        assert stable_argsort(smooth, m).tolist() == np.argsort(smooth, kind="mergesort").tolist()
