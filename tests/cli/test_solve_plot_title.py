"""bhr solve --plot: the figure's title says whether the target was reached, as the table's status row does."""
from __future__ import annotations

import subprocess

import pytest

from bhr.model._robot import Robot
from bhr.solvers import solve
from bhr.cli.solve import plot_title
from tests.conftest import bhr_exe


@pytest.mark.parametrize("target, status", [((3.0, 9.0, 0.0), "reached"), ((0.0, 0.0, 500.0), "out of reach")])
def test_the_title_carries_the_status(target, status):
    result = solve(list(target), robot=Robot(modules=10), solver="fabrik")
    assert result.status == status
    title = plot_title("fabrik", target, result)
    assert f", {status}, " in title and "mm off" in title


def test_the_plot_is_written_with_that_title(tmp_path):
    r = subprocess.run(bhr_exe() + ["solve", "--target", "0", "0", "500", "--plot", "s.png"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "out of reach" in r.stdout and (tmp_path / "s.png").stat().st_size > 0
