"""bhr import, run as a user runs it: a real colon's surface to a trajectory file, and bad input in one line."""
from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("vtk")  # noqa: E402

from bhr.model._generators import load_trajectory  # noqa: E402
from bhr.model._trajnames import real_colons  # noqa: E402


def test_the_command_writes_the_trajectory_and_its_surface_and_refuses_bad_input(tmp_path):
    out = tmp_path / "c.csv"
    src = real_colons()["gca:E90"].with_suffix(".vtp")
    r = subprocess.run([sys.executable, "-m", "bhr.cli.main", "import", str(src), "--start", "0,0,0", "--out",
                        str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "branch selection" in r.stdout and out.is_file() and out.with_suffix(".vtp").is_file()
    t = load_trajectory(out, feed=2.0)
    assert t.mesh == str(out.with_suffix(".vtp")) and t.lumen is not None
    for args, msg in ((["/no/such.stl"], "no such surface mesh"), ([str(src), "--start", "1,2"], "--start must be three"),
                      ([str(tmp_path / "x.txt")], "no such surface mesh")):
        r = subprocess.run([sys.executable, "-m", "bhr.cli.main", "import", *args], capture_output=True, text=True)
        assert r.returncode != 0 and msg in r.stderr and "Traceback" not in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("suffix", [".stl", ".vtp", ".vtk", ".ply", ".obj"])
def test_a_file_that_is_not_a_mesh_is_refused_in_one_line(tmp_path, suffix):
    """A file with a mesh's name that vtk cannot read: bhr's one line, and none of vtk's own error report."""
    bad = tmp_path / f"colon{suffix}"
    bad.write_text("not a mesh\n")
    r = subprocess.run([sys.executable, "-m", "bhr.cli.main", "import", str(bad), "--start", "0,0,0", "--out",
                        str(tmp_path / "c.csv")], capture_output=True, text=True)
    assert r.returncode == 1
    assert r.stderr.strip().splitlines() == [f"Error: {bad}: no surface read (0 triangles); give a closed surface "
                                             "mesh in mm"]
    assert r.stdout == "" and not (tmp_path / "c.csv").exists()
