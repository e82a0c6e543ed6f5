"""Every package bhr's code imports is one bhr declares (pyproject.toml): a plain install has what the
commands need, and an optional part names its extra."""
from __future__ import annotations

import ast
import re
import sys
import tomllib
from importlib.metadata import packages_distributions
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]


def _names(reqs: list[str]) -> set[str]:
    """The distributions ``reqs`` bring: each name, and the extras named in brackets (dask[distributed])."""
    out = set()
    for r in reqs:
        m = re.match(r"\s*([A-Za-z0-9_.-]+)(?:\[([^\]]*)\])?", r)
        assert m, r
        out.add(m.group(1).lower().replace("_", "-"))
        out |= {e.strip().lower() for e in (m.group(2) or "").split(",") if e.strip()}
    return out


def _imports(where: str) -> dict[str, list[str]]:
    """Top-level modules imported under ``where``, with the files that import them."""
    out: dict[str, list[str]] = {}
    for path in sorted((REPO / where).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                mods = [node.module]
            else:
                continue
            for m in mods:
                out.setdefault(m.split(".")[0], []).append(str(path.relative_to(REPO)))
    return out


def test_every_imported_package_is_declared():
    base = _names(PROJECT["dependencies"])
    extras = {k: _names(v) for k, v in PROJECT["optional-dependencies"].items() if k != "test"}
    declared = base.union(*extras.values())
    dists = packages_distributions()
    missing = {}
    for where in ("bhr", "cli"):
        for mod, files in _imports(where).items():
            if mod in sys.stdlib_module_names or mod in ("bhr", "__future__"):
                continue
            names = {d.lower().replace("_", "-") for d in dists.get(mod, [mod])}
            if not names & declared:
                missing[mod] = files[:2]
    assert not missing, f"imported but not declared in pyproject.toml: {missing}"


def test_scipy_is_a_dependency_of_the_anatomical_colons():
    assert "scipy" in _names(PROJECT["dependencies"])
