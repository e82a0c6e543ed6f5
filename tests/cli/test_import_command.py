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


def _import(tmp_path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "bhr.cli.main", "import", *args, "--out", str(tmp_path / "c.csv")],
                          capture_output=True, text=True, cwd=tmp_path, timeout=300)


def _one_line(r: subprocess.CompletedProcess) -> str:
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip() and not ln.startswith("Compiling bhr's")]
    assert r.returncode == 1 and len(lines) == 1 and "Traceback" not in r.stderr, (r.returncode, r.stderr[-2000:])
    return lines[0]


def test_a_mesh_that_crashes_vtks_reader_is_one_line(tmp_path):
    """A PLY whose header counts more vertices and faces than it holds ends vtk's reader with a segmentation fault;
    vtk reads in a child process, so bhr says so in one line instead of dying with it."""
    bad = tmp_path / "colon.ply"
    bad.write_text("ply\nformat ascii 1.0\nelement vertex 999999999999\nproperty float x\nproperty float y\n"
                   "property float z\nelement face 9999999999\nproperty list uchar int vertex_indices\nend_header\n"
                   "0 0 0\n")
    line = _one_line(_import(tmp_path, str(bad), "--start", "0,0,0"))
    assert line.startswith(f"Error: {bad}: not a readable .ply surface mesh") and "give a surface mesh" in line
    assert not (tmp_path / "c.csv").exists() and not (tmp_path / "c.vtp").exists()


def test_a_mesh_point_beyond_the_limit_is_named(tmp_path):
    """A vertex at 1e300 mm (or inf, nan) is refused by its number, not by vtk overflowing a grid's int."""
    bad = tmp_path / "colon.obj"
    bad.write_text("v 1e300 0 0\nv 0 10 0\nv 0 0 10\nv 10 10 10\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    line = _one_line(_import(tmp_path, str(bad), "--start", "0,0,0"))
    assert "point 1 is [1e+300, 0.0, 0.0], not a finite coordinate within +-1e+06 mm" in line


def _nifti_gz(path, shape, affine=None, voxels: bytes = b""):
    """A .nii.gz of ``shape`` uint8 voxels (``voxels``, then zeros), written without holding them in memory."""
    import gzip

    import nibabel as nib
    import numpy as np

    hdr = nib.Nifti1Header()
    hdr.set_data_dtype(np.uint8)
    hdr.set_data_shape(shape)
    hdr.set_sform(np.eye(4) if affine is None else affine, code=1)
    hdr.set_qform(None, code=0)
    hdr["vox_offset"] = 352
    left = int(np.prod(shape)) - len(voxels)
    with gzip.open(path, "wb", compresslevel=1) as fh:
        fh.write(hdr.binaryblock + b"\0" * 4 + voxels)
        zeros = b"\0" * (1 << 24)
        while left > 0:
            fh.write(zeros[:min(left, len(zeros))])
            left -= len(zeros)


def test_a_segmentation_claiming_too_many_voxels_is_refused_from_its_header(tmp_path):
    """1.2 MB of .nii.gz holding 269 million voxels: refused by its header's size before a voxel is read."""
    pytest.importorskip("nibabel")
    bomb = tmp_path / "seg.nii.gz"
    _nifti_gz(bomb, (1024, 1024, 257))
    line = _one_line(_import(tmp_path, str(bomb), "--label", "3"))
    assert line == (f"Error: {bomb}: 1024 x 1024 x 257 voxels, more than the 268,435,456 a segmentation may have; "
                    "crop it to the colon")


@pytest.mark.parametrize("broken", ["singular", "nan"])
def test_a_segmentation_whose_affine_maps_no_volume_is_refused(tmp_path, broken):
    """A voxel-to-mm transform with a zero or NaN column cannot place a voxel: one line naming the header."""
    pytest.importorskip("nibabel")
    import numpy as np

    vol = np.zeros((24, 24, 24), np.uint8)
    vol[2:22, 6:18, 6:18] = 3
    aff = np.eye(4)
    aff[0, 0] = 0.0 if broken == "singular" else float("nan")
    seg = tmp_path / "seg.nii.gz"
    _nifti_gz(seg, vol.shape, aff, vol.tobytes(order="F"))
    line = _one_line(_import(tmp_path, str(seg), "--label", "3"))
    assert "voxel-to-mm transform (its affine) is not a finite, invertible one" in line


def test_a_surface_beside_a_trajectory_too_large_for_the_wall_grid_is_named(tmp_path):
    """A .vtp beside a trajectory CSV that spans 100 m: refused by the grid's size, naming the mesh, not "out of
    memory" after trying to allocate it."""
    from vtkmodules.vtkFiltersCore import vtkTriangleFilter
    from vtkmodules.vtkFiltersSources import vtkCubeSource
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    (tmp_path / "t.csv").write_text("x,y,z,lumen\n" + "".join(f"{2 * k},0,0,30\n" for k in range(20)))
    cube = vtkCubeSource()
    for axis in ("X", "Y", "Z"):
        getattr(cube, f"Set{axis}Length")(100000.0)
    tri = vtkTriangleFilter()
    tri.SetInputConnection(cube.GetOutputPort())
    w = vtkXMLPolyDataWriter()
    w.SetFileName(str(tmp_path / "t.vtp"))
    w.SetInputConnection(tri.GetOutputPort())
    w.Write()
    r = subprocess.run([sys.executable, "-m", "bhr.cli.main", "follow", "--traj", "t.csv", "--no-plots", "--out",
                        "o"], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    line = _one_line(r)
    assert line.startswith("Error: t.vtp: the mesh spans 100000 x 100000 x 100000 mm, too large for the wall's grid")
    assert not (tmp_path / "o").exists()


def test_a_mesh_with_an_edge_shared_by_thousands_of_triangles_is_refused_at_once(tmp_path):
    """One face of a real colon's surface written 20,000 times more (a 3 MB file): vtk's orientation of its normals
    walked the copies pairwise for minutes; such a file is not a surface, and is refused in one line."""
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader, vtkXMLPolyDataWriter

    src = real_colons()["gca:E90"]
    r = vtkXMLPolyDataReader()
    r.SetFileName(str(src.with_suffix(".vtp")))
    r.Update()
    mesh = r.GetOutput()
    face = mesh.GetCell(0).GetPointIds()
    for _ in range(20000):
        mesh.GetPolys().InsertNextCell(face)
    w = vtkXMLPolyDataWriter()
    w.SetFileName(str(tmp_path / "colon.vtp"))
    w.SetInputData(mesh)
    w.Write()
    line = _one_line(_import(tmp_path, str(tmp_path / "colon.vtp"), "--centerline", str(src)))
    assert "an edge is shared by 20002 triangles (a surface's edge has 2, at most 16 are accepted)" in line
