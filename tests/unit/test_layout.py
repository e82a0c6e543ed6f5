"""The tests' own layout: one folder per layer, and a fast layer that stays in-process (README, "Tests")."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import FOLDERS, pytest_collection_modifyitems

TESTS = Path(__file__).resolve().parents[1]
# what only a command, a browser, a cluster or a physics engine needs: never inside tests/unit
OUTSIDE = {"run_bhr", "bhr_exe", "dask_cluster", "Browser", "need_chromium", "LocalCluster", "mujoco", "pinocchio",
           "fk_cross_check", "subprocess"}


def test_every_test_file_lives_in_a_layer_folder():
    assert not sorted(p.name for p in TESTS.glob("test_*.py"))
    folders = {p.parent.name for p in TESTS.rglob("test_*.py") if "benchmarks" not in p.parts and "data" not in p.parts}
    assert folders == set(FOLDERS)


def _names(node: ast.AST) -> set[str]:
    """The names a function uses: variables, arguments (fixtures) and what it imports."""
    used = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
    used |= {a.arg for n in ast.walk(node) if isinstance(n, ast.arguments) for a in n.args + n.kwonlyargs}
    used |= {a.name.split(".")[0] for n in ast.walk(node) if isinstance(n, (ast.Import, ast.ImportFrom))
             for a in n.names}
    return used


@pytest.mark.parametrize("path", sorted((TESTS / "unit").glob("test_*.py")), ids=lambda p: p.name)
def test_unit_tests_stay_in_process(path):
    tree = ast.parse(path.read_text())
    helpers = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("test")}

    def reach(node: ast.AST, seen: set[str]) -> set[str]:  # through the file's own helpers and fixtures
        used = _names(node)
        for name in used & set(helpers) - seen:
            seen.add(name)
            used |= reach(helpers[name], seen)
        return used

    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name.startswith("test"):
            used = reach(node, set())
            assert not used & OUTSIDE, f"{path.name}::{node.name} uses {sorted(used & OUTSIDE)}: not a unit test"


class _Item:
    def __init__(self, path: Path, fixtures=(), marks=()):
        self.path, self.fixturenames, self.nodeid, self.markers = path, list(fixtures), path.name + "::t", list(marks)

    def add_marker(self, mark):
        self.markers.append(mark.name)

    def get_closest_marker(self, name):
        return getattr(pytest.mark, name) if name in self.markers else None


@pytest.mark.parametrize("layer", FOLDERS)
def test_the_marker_is_the_folder(layer):
    item = _Item(TESTS / layer / "test_x.py")
    pytest_collection_modifyitems(None, [item])
    assert item.markers == [layer]


def test_a_whole_run_in_tests_unit_is_the_run_layer_not_unit():
    item = _Item(TESTS / "unit" / "test_x.py", marks=["run"])
    pytest_collection_modifyitems(None, [item])
    assert item.markers == ["run"]
    with pytest.raises(pytest.UsageError, match="the run marker is for in-process tests in tests/unit/"):
        pytest_collection_modifyitems(None, [_Item(TESTS / "cli" / "test_x.py", marks=["run"])])


@pytest.mark.parametrize("where, fixtures, says", [
    (TESTS / "test_x.py", (), "a test lives in one of tests/{unit,thesis,cli,integration}/"),
    (TESTS / "data" / "test_x.py", (), "a test lives in one of"),
    (TESTS / "unit" / "test_x.py", ("run_bhr",), "uses run_bhr: move it to tests/cli/"),
    (TESTS / "unit" / "test_x.py", ("dask_cluster",), "uses dask_cluster: move it to tests/integration/"),
])
def test_a_test_in_the_wrong_place_stops_the_collection(where, fixtures, says):
    with pytest.raises(pytest.UsageError, match=says.replace("{", r"\{").replace("}", r"\}")):
        pytest_collection_modifyitems(None, [_Item(where, fixtures)])


def test_every_package_of_the_library_is_installed():
    """pyproject's explicit package list names every folder with an __init__.py: a package left out is missing
    from an installed (non-editable) bhr, as bhr._studies.physics was."""
    import tomllib

    root = TESTS.parent
    listed = set(tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(p.parent.relative_to(root).parts) for p in (root / "bhr").rglob("__init__.py")}
    found |= {"bhr.cli" if p.parent.name == "cli" and p.parent.parent == root else "" for p in (root / "cli").rglob("__init__.py")} - {""}
    assert found - listed == set()
