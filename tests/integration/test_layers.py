"""bhr's layers import downwards only, checked by import-linter against pyproject.toml's contract; the contract
catches an upward import when one is added; and no private name is imported from another module."""
from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
LINT = [sys.executable, "-c", "import sys; from importlinter.cli import lint_imports_command; "
        "sys.exit(lint_imports_command())", "--no-cache"]


def _lint(root: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(root)}
    return subprocess.run(LINT, cwd=root, env=env, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def copy(tmp_path_factory):
    root = tmp_path_factory.mktemp("layers")
    shutil.copytree(REPO / "bhr", root / "bhr", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "pyproject.toml", root / "pyproject.toml")
    return root


def test_the_layers_contract_is_kept():
    res = _lint(REPO)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "KEPT" in res.stdout and "BROKEN" not in res.stdout


@pytest.mark.parametrize("module, upward", [
    ("model/_robot.py", "import bhr._run.driver"),
    ("_kinematics/frames.py", "from bhr._settings import errors"),
    ("solvers/_fabrik.py", "from bhr._studies.report import load_batch"),
    ("_hardware/link.py", "import bhr._run.driver"),
])
def test_an_upward_import_breaks_the_contract(copy, module, upward):
    f = copy / "bhr" / module
    original = f.read_text()
    try:
        f.write_text(original + f"\n{upward}  # deliberately upward\n")
        res = _lint(copy)
        assert res.returncode != 0 and "BROKEN" in res.stdout, res.stdout
        importer = "bhr." + module[:-3].replace("/", ".")
        assert importer in res.stdout
    finally:
        f.write_text(original)


def _private_imports():
    """(file, line, module, name) of every ``from bhr.x import _name`` between two different modules."""
    out = []
    for root, pkg in ((REPO / "bhr", "bhr"), (REPO / "cli", "bhr.cli")):
        for f in sorted(root.rglob("*.py")):
            tree = ast.parse(f.read_text())
            for node in ast.walk(tree):
                if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("bhr"):
                    for alias in node.names:
                        # a private module of bhr (``from bhr.solvers import _base``) is bhr's own to import;
                        # a private name inside a module is not
                        submodule = REPO / Path(*node.module.split(".")) / alias.name
                        if node.module.startswith("bhr.cli"):
                            submodule = REPO / "cli" / Path(*node.module.split(".")[2:]) / alias.name
                        if submodule.with_suffix(".py").is_file() or (submodule / "__init__.py").is_file():
                            continue
                        if alias.name.startswith("_") and not alias.name.startswith("__"):
                            out.append((str(f.relative_to(REPO)), node.lineno, node.module, alias.name))
    return out


def test_no_private_name_crosses_a_module():
    found = _private_imports()
    # bhr._numba is the package's start-up module (numba's cache folder), imported for its side effect only
    found = [x for x in found if x[3] != "_numba"]
    assert not found, "\n".join(f"{f}:{n}: from {m} import {name}" for f, n, m, name in found)
