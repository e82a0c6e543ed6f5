"""The ten-line example solver of docs/model.md runs as printed: a new solver is one file plus its registration."""
import re
from pathlib import Path

import numpy as np
import pytest

import bhr
from bhr.solvers import available
from bhr.solvers._base import REGISTRY

DOC = Path(__file__).resolve().parents[2] / "docs" / "model.md"


@pytest.fixture
def example_solver():
    text = DOC.read_text(encoding="utf-8")
    code = re.search(r"A complete example.*?```python\n(.*?)```", text, re.S).group(1)
    body = [ln for ln in code.splitlines() if ln.strip() and not ln.startswith(("import", "from", "@"))]
    assert len(body) <= 10, "the docs promise a ten-line solver"
    exec(compile(code, str(DOC), "exec"), {})
    yield REGISTRY["pointer"]
    REGISTRY.pop("pointer")


def test_example_solver_solves_and_follows(example_solver):
    assert "pointer" in available()
    res = bhr.solve([3, 9, 0], modules=5, module_length=2.0, tol_pos=0.01, solver="pointer")
    d = res.points[-1] - res.points[0]
    assert np.allclose(np.cross(d, [3, 9, 0]), 0, atol=1e-9) and np.isclose(np.linalg.norm(d), 10.0)
    assert res.success is False and np.isclose(res.position_error_mm, 10.0 - np.linalg.norm([3, 9, 0]))
    assert bhr.solve([3, 9, 0], modules=5, module_length=2.0, tol_pos=1.0, solver="pointer").success is True
    run = bhr.follow(bhr.trajectory("line", length=30), solver="pointer")
    assert run.steps == 16 and run.codes is None and run.point_errors_mm.shape == (16, 6)
