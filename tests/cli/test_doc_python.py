"""The Python examples of README.md and docs/*.md use the public API only, and the study pages' examples run as printed.

bhr's public API is ``bhr``, ``bhr.model``, ``bhr.solvers`` and ``bhr.output``; the studies (report, sweep, traverse)
are commands. An example that imports ``bhr._...`` teaches users a name that may change without notice.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
PYTHON = re.compile(r"```python\n(.*?)```", re.S)
PRIVATE = re.compile(r"^\s*(from|import)\s+bhr\._|\bbhr\._[a-z]", re.M)


def blocks(path: Path) -> list[str]:
    return PYTHON.findall(path.read_text(encoding="utf-8"))


def test_the_docs_have_python_examples():
    assert sum(len(blocks(p)) for p in DOCS) >= 10  # the collection itself can fail


@pytest.mark.parametrize("path", DOCS, ids=[p.name for p in DOCS])
def test_no_python_example_uses_a_private_module(path):
    bad = [m.group(0).strip() for b in blocks(path) for m in PRIVATE.finditer(b)]
    assert not bad, f"{path.name}'s Python examples use private modules: {bad}"


@pytest.mark.parametrize("page", ["report.md", "sweep.md", "traverse.md"])
def test_the_study_pages_python_example_runs_as_printed(tmp_path, page):
    (code,) = blocks(ROOT / "docs" / page)
    (tmp_path / "docs").symlink_to(ROOT / "docs")  # the examples name docs/examples/... from the repository's root
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}  # this venv's bhr
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "Traceback" not in r.stderr and r.stdout.strip(), (r.stdout[-500:], r.stderr[-500:])
