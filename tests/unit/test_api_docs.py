"""The public API is documented: every public callable of ``bhr``, ``bhr.model``, ``bhr.output`` and ``bhr.solvers``
has a numpydoc docstring that names every parameter it takes and what it returns, held by numpydoc's own validator."""
from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

import pytest
from numpydoc.docscrape import get_doc_object
from numpydoc.validate import validate

#: The public namespaces; everything else in bhr is internal.
NAMESPACES = ("bhr", "bhr.model", "bhr.output", "bhr.solvers")

#: numpydoc's checks held here: a docstring exists (GL08) with a one-line summary (SS01, SS06), every parameter of the
#: signature is documented (PR01) with a type (PR04), no documented parameter is unknown (PR02), and a function that
#: returns a value has a Returns section (RT01) that says what it is (RT03).
CHECKS = {"GL08", "SS01", "SS06", "PR01", "PR02", "PR04", "RT01", "RT03"}


def _resolve(namespace: str, attr: str) -> object:
    """The object a public name stands for. A name that is also a submodule's (``bhr.output.animate``) reads as
    that submodule once it is imported; the object is then the submodule's own attribute of that name (the
    shadowing itself is held by :func:`test_a_public_name_is_the_same_object_every_time`)."""
    obj = getattr(importlib.import_module(namespace), attr)
    return getattr(obj, attr, obj) if inspect.ismodule(obj) else obj


def _public_callables() -> list[str]:
    names = []
    for namespace in NAMESPACES:
        module = importlib.import_module(namespace)
        for name in module.__all__:
            if callable(_resolve(namespace, name)):
                names.append(f"{namespace}.{name}")
    return names


def _public_methods() -> list[str]:
    """``namespace.Class.method`` for every public method (plain, class or static) a public class defines."""
    names, seen = [], set()
    for name in _public_callables():
        cls = _resolve(*name.rsplit(".", 1))
        if not inspect.isclass(cls) or cls in seen:
            continue
        seen.add(cls)
        for attr, value in vars(cls).items():
            func = value.__func__ if isinstance(value, (classmethod, staticmethod)) else value
            if not attr.startswith("_") and inspect.isfunction(func):
                names.append(f"{name}.{attr}")
    return names


def test_the_public_namespaces_list_their_callables():
    """The list below is really collected: the four namespaces offer some 55 callables, the main ones among them."""
    names = _public_callables()
    assert len(names) >= 50
    assert {"bhr.follow", "bhr.solve", "bhr.model.Robot", "bhr.solvers.get_solver", "bhr.output.error_figure"} <= set(names)
    methods = _public_methods()
    assert {"bhr.Robot.fk", "bhr.Trajectory.at_feed", "bhr.Solver.solve", "bhr.solvers.Chain.straight"} <= set(methods)


@pytest.mark.parametrize("name", _public_callables())
def test_public_callable_has_a_numpydoc_docstring(name):
    # the object itself, not its dotted name: numpydoc would load ``bhr.output.animate`` as the module of that name
    obj = _resolve(*name.rsplit(".", 1))
    errors = [f"{code}: {message}" for code, message in validate(get_doc_object(obj))["errors"] if code in CHECKS]
    assert not errors, f"{name}: " + "; ".join(errors)


@pytest.mark.parametrize("name", _public_methods())
def test_public_method_has_a_numpydoc_docstring(name):
    """The methods a user calls on the public classes (``Robot.fk``, ``Trajectory.at_feed``, ``Solver.solve``,
    ...) are documented the same way."""
    namespace, cls, attr = name.rsplit(".", 2)
    obj = getattr(_resolve(namespace, cls), attr)
    errors = [f"{code}: {message}" for code, message in validate(get_doc_object(obj))["errors"] if code in CHECKS]
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


#: Public names that are also the names of the submodules defining them: after the first access (which imports the
#: submodule), Python's import system binds the package's attribute to the submodule, and the name reads as a module.
_SHADOWED: set[str] = set()


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason="shadowed by its "
                                                                            "submodule")) if n in _SHADOWED else n
                                  for n in _public_callables()])
def test_a_public_name_is_the_same_object_every_time(name):
    """``from bhr.output import X`` gives the same object on every access, whatever was imported before."""
    namespace, attr = name.rsplit(".", 1)
    module = importlib.import_module(namespace)
    first, second = getattr(module, attr), getattr(module, attr)
    assert first is second and not inspect.ismodule(second)


def test_the_docs_name_the_public_api():
    """docs/model.md's table of the API names exactly the four namespaces and each one's ``__all__``."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "model.md").read_text(encoding="utf-8")
    section = text.split("## The Python API", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| `(bhr[a-z.]*)` \| (.+) \|$", section, flags=re.MULTILINE)
    assert sorted(ns for ns, _ in rows) == sorted(NAMESPACES)
    for namespace, names in rows:
        module = importlib.import_module(namespace)
        assert set(re.findall(r"`([A-Za-z_0-9]+)`", names)) == set(module.__all__), namespace


@pytest.mark.parametrize("namespace", NAMESPACES)
def test_dir_shows_the_api(namespace):
    """``dir()`` of a public namespace shows its API: the names of ``__all__`` (and, for ``bhr``, the three
    public subpackages), nothing internal."""
    module = importlib.import_module(namespace)
    subpackages = {"model", "output", "solvers"} if namespace == "bhr" else set()
    assert set(dir(module)) == set(module.__all__) | subpackages
