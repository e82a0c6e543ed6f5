"""bhr import: a shipped real colon's surface back to its centerline and lumen (the round trip), a labelled
segmentation, a mesh with its centerline and sections, and one-line errors."""
from __future__ import annotations

import numpy as np
import pytest

from bhr.model._generators import load_trajectory
from bhr.model._importer import import_colon, longest_path
from bhr.model._trajnames import real_colons


@pytest.mark.run
def test_mesh_alone_round_trip_on_a_shipped_colon():
    """The closed surface of gca:E90 alone gives back a centerline of about its length and its lumen (the skeleton
    runs on into the appendix, which the shipped path leaves out, and takes shortcuts where loops touch)."""
    shipped = load_trajectory("gca:E90", feed=1.0)
    res = import_colon(real_colons()["gca:E90"].with_suffix(".vtp"), start=(0.0, 0.0, 0.0))
    length = float(np.linalg.norm(np.diff(res.points, axis=0), axis=1).sum())
    assert abs(length - shipped.length_mm) < 0.1 * shipped.length_mm
    assert abs(float(np.median(res.lumen)) - float(np.median(shipped.lumen))) < 0.1 * float(np.median(shipped.lumen))
    # the path starts at the anus and, point for point, lies within the shipped colon's lumen of its centerline
    assert np.linalg.norm(res.points[0]) < 10.0
    from scipy.spatial import cKDTree

    d, k = cKDTree(shipped.points).query(res.points)
    assert np.median(d / (shipped.lumen[k] / 2)) < 0.5
    assert any(line.startswith("centerline: skeleton") and "branch selection" in line for line in res.report)


def test_mesh_with_its_centerline_keeps_the_sections_and_measures_the_lumen():
    path = real_colons()["gca:E60"]
    res = import_colon(path.with_suffix(".vtp"), centerline=path, smooth_mm=0.0)
    shipped = load_trajectory("gca:E60", feed=1.0)
    assert res.sections is not None and res.sections[0] == "rectum and sigmoid" and res.sections[-1] == "cecum"
    n = min(len(res.lumen), len(shipped.lumen))
    # the same points and the same surface (decimated to what is shipped): the same lumen within a millimetre
    assert np.median(np.abs(res.lumen[:n] - shipped.lumen[:n])) < 1.0


def test_a_surface_that_does_not_enclose_its_centerline_is_said_to_be_measured_against_the_tube():
    """The Visible Human female's surface is of the wall's tissue: its path runs in the hollow the surface does not
    enclose. The import says so, as the runs of the imported colon will (wall_grid); E60's encloses its path."""
    from bhr.model._wallmesh import wall_grid

    vhf = real_colons()["gca:VHF"]
    res = import_colon(vhf.with_suffix(".vtp"), centerline=vhf, smooth_mm=0.0)
    wall = [line for line in res.report if line.startswith("wall: ")]
    assert len(wall) == 1 and "runs measure it against the tube of the lumen diameters" in wall[0]
    share = float(wall[0].split("encloses ")[1].split(" %")[0])
    assert share < 95.0
    assert wall_grid(load_trajectory("gca:VHF"))[1].startswith("tube (the mesh encloses")
    e60 = real_colons()["gca:E60"]
    res = import_colon(e60.with_suffix(".vtp"), centerline=e60, smooth_mm=0.0)
    assert "wall: the surface encloses 100 % of the centerline; runs measure the clearance against it" in res.report


def test_a_labelled_segmentation(tmp_path):
    """A bent tube of radius 8 mm (a quarter circle of radius 60 mm) in 1 x 1 x 2 mm voxels, label 3 among others."""
    shape = (100, 100, 30)
    i, j, k = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij")
    x, y, z = i * 1.0, j * 1.0, k * 2.0
    # distance to the arc of radius 60 about (10, 10) in the plane z = 30, quarter from +x to +y
    r = np.hypot(x - 10, y - 10)
    ang = np.arctan2(y - 10, x - 10)
    on_arc = (ang >= 0) & (ang <= np.pi / 2)
    dist = np.where(on_arc, np.hypot(r - 60, z - 30), np.inf)
    data = np.zeros(shape, dtype=np.uint8)
    data[dist <= 8.0] = 3
    data[:5, :5, :5] = 1  # another organ
    import nibabel as nib

    f = tmp_path / "seg.nii.gz"
    nib.save(nib.Nifti1Image(data, np.diag([1.0, 1.0, 2.0, 1.0])), str(f))
    with pytest.raises(Exception, match="choose the colon's with --label"):
        import_colon(f)
    res = import_colon(f, label=3, start=(70.0, 10.0, 30.0))
    length = float(np.linalg.norm(np.diff(res.points, axis=0), axis=1).sum())
    # a skeleton may end short of a flat end or run out to its rim (at most the tube's radius, 8 mm, either end)
    assert 60 * np.pi / 2 - 20 < length < 60 * np.pi / 2 + 16
    off = np.abs(np.hypot(res.points[:, 0] - 10, res.points[:, 1] - 10) - 60)
    assert np.median(off) < 1.0 and np.max(off) <= 8.0
    assert abs(float(np.median(res.lumen)) - 16.0) < 2.0
    assert res.points[0, 1] < res.points[-1, 1]  # from the start point's end
    # its surface (marching cubes of the label, in the image's world frame): closed around the centerline, 8 mm away
    from bhr.model._path import Trajectory
    from bhr.model._wallmesh import exact_distance, wall_grid

    assert res.mesh is not None and 100 < res.mesh.GetNumberOfCells() <= 20000
    inner = res.points[10:-10]  # away from the flat ends
    d = exact_distance(res.mesh, inner)
    # the voxelised tube's boundary is within one voxel (2 mm along z) of the 8 mm tube's
    assert np.all(d < 0.0) and abs(float(np.median(d)) + 8.0) < 2.0
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    w = vtkXMLPolyDataWriter()
    w.SetFileName(str(tmp_path / "seg.vtp"))
    w.SetInputData(res.mesh)
    assert w.Write()
    grid, wall = wall_grid(Trajectory("seg", res.points, lumen=res.lumen, mesh=str(tmp_path / "seg.vtp")))
    assert grid is not None and wall == "mesh seg.vtp"


def test_longest_path_drops_the_side_branch():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [2, 1, 0]], dtype=float)
    e = np.array([[0, 1], [1, 2], [2, 3], [2, 4]])
    path, dropped, branches = longest_path(v, e)
    assert sorted(path.tolist()) == [0, 1, 2, 3] and dropped == 1 and branches == 1
