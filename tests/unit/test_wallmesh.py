"""The wall as a real surface (bhr.model._wallmesh): the signed-distance grid against vtk's exact distance and the
analytic one, the clearance against a mesh against the tube's, and the fallbacks."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import bhr
from bhr.model._generators import load_trajectory
from bhr.model._path import Trajectory
from bhr.model._wallmesh import GRID_MM, SdfGrid, exact_distance, sdf_values, wall_grid
from bhr._run.clearance import clearance_report
from bhr._run.driver import BhrWarning

BOUND = math.sqrt(3.0) * GRID_MM  # the signed distance changes by at most 1 mm per mm


def _write(poly, path):
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    w = vtkXMLPolyDataWriter()
    w.SetFileName(str(path))
    w.SetInputData(poly)
    w.Write()
    return path


def _sphere(r=20.0, res=96):
    from vtkmodules.vtkFiltersSources import vtkSphereSource

    s = vtkSphereSource()
    s.SetRadius(r)
    s.SetThetaResolution(res)
    s.SetPhiResolution(res)
    s.Update()
    return s.GetOutput()


def _cylinder(radius=15.0, length=200.0, res=96):
    """A closed cylinder along +x from x = -20 to length - 20 (a straight lumen)."""
    from vtkmodules.vtkCommonTransforms import vtkTransform
    from vtkmodules.vtkFiltersCore import vtkTriangleFilter
    from vtkmodules.vtkFiltersGeneral import vtkTransformFilter
    from vtkmodules.vtkFiltersSources import vtkCylinderSource

    c = vtkCylinderSource()
    c.SetRadius(radius)
    c.SetHeight(length)
    c.SetResolution(res)
    c.CappingOn()
    t = vtkTransform()
    t.PostMultiply()
    t.RotateZ(-90.0)  # the source's axis is y: along x
    t.Translate(length / 2 - 20.0, 0.0, 0.0)
    f = vtkTransformFilter()
    f.SetInputConnection(c.GetOutputPort())
    f.SetTransform(t)
    tri = vtkTriangleFilter()
    tri.SetInputConnection(f.GetOutputPort())
    tri.Update()
    return tri.GetOutput()


@pytest.fixture(scope="module")
def sphere_grid():
    mesh = _sphere()
    return mesh, sdf_values(mesh, np.zeros((1, 3)), 40.0)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-30.0, 30.0)] * 3), min_size=1, max_size=20))
def test_the_grid_is_within_its_bound_of_vtks_exact_distance(sphere_grid, pts):
    mesh, grid = sphere_grid
    p = np.array(pts, dtype=np.float64)
    p = p[np.linalg.norm(p, axis=1) <= 40.0 - BOUND]  # within the band (40 mm of the centre) by a cell's reach
    exact = exact_distance(mesh, p)
    assert np.all(np.abs(grid.at(p) - exact) <= BOUND + 1e-9)
    # and of the analytic distance to the sphere (the mesh's facets are within 0.03 mm of it)
    assert np.all(np.abs(grid.at(p) - (np.linalg.norm(p, axis=1) - 20.0)) <= BOUND + 0.05)


def test_the_grid_is_negative_inside_and_a_far_node_is_wall(sphere_grid):
    _, grid = sphere_grid
    assert grid.at(np.zeros(3)) == pytest.approx(-20.0, abs=0.1)
    assert grid.at(np.array([100.0, 0.0, 0.0])) > 0.0  # beyond the grid: wall


#: How much more than the exact distance a node beyond vtk's band reads (sdf_values), and the facets' own gap
FAR = (1.0 + math.sqrt(3.0) / 2.0) * GRID_MM


@pytest.fixture(scope="module")
def narrow_band_grid():
    """The sphere's grid when its centerline's band (10 mm) falls short of its wall (20 mm): a lumen wider than
    its listed diameters, as a real colon's pockets are."""
    return sdf_values(_sphere(), np.zeros((1, 3)), 10.0)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-32.0, 32.0)] * 3), min_size=1, max_size=20))
def test_beyond_the_band_the_grid_reads_each_points_own_distance(narrow_band_grid, pts):
    """Anywhere on the grid (the sphere's bounds and 12 mm more): inside the lumen beyond the band, deep in the
    wall, the analytic distance within the grid's bound and the far nodes' (not one value for all of them, nor
    wall inside the lumen)."""
    p = np.array(pts, dtype=np.float64)
    exact = np.linalg.norm(p, axis=1) - 20.0
    assert np.all(np.abs(narrow_band_grid.at(p) - exact) <= BOUND + FAR + 0.05)


def test_a_pocket_of_the_lumen_beyond_the_band_is_lumen_and_the_deep_wall_is_deep(narrow_band_grid):
    assert narrow_band_grid.at(np.array([15.0, 0.0, 0.0])) < -2.0  # inside, 5 mm from the wall and 15 from the centre
    assert narrow_band_grid.at(np.array([0.0, 0.0, -18.0])) < 0.0
    deep = narrow_band_grid.at(np.array([[30.0, 30.0, 30.0], [0.0, 45.0, 0.0]]))  # 32 and 25 mm into the wall
    assert deep == pytest.approx([30.0 * math.sqrt(3.0) - 20.0, 25.0], abs=BOUND + FAR)


def test_clearance_against_a_straight_mesh_matches_the_tube(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    mesh = _write(_cylinder(), tmp_path / "straight.vtp")
    x = np.arange(0.0, 150.0 + 1e-9, 2.0)
    pts = np.stack([x, 3.0 * np.sin(x / 25.0), np.zeros_like(x)], axis=1)  # a gentle wave inside the tube
    traj = Trajectory("straight", pts, lumen=np.full(len(x), 30.0), feed=2.0, mesh=str(mesh))
    grid, wall = wall_grid(traj)
    assert grid is not None and wall == "mesh straight.vtp"
    assert (tmp_path / "cache" / "bhr" / "sdf").is_dir()  # cached
    r = bhr.follow(traj, "lumen")
    m = clearance_report(r)
    t = clearance_report(r, mesh=False)
    assert m.wall.startswith("mesh") and t.wall == "tube"
    # the tube is the cylinder around the wave's own axis, not the mesh's: they differ by the wave (3 mm) at most,
    # and by the grid's bound
    diff = np.abs(m.per_step - t.per_step)
    ok = np.isfinite(diff)
    assert ok.sum() > 50 and np.max(diff[ok]) <= 3.0 + BOUND


def test_no_mesh_or_a_mesh_that_does_not_enclose_the_path_is_the_tube(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    pts = np.stack([np.arange(0.0, 100.0, 2.0), np.zeros(50), np.zeros(50)], axis=1)
    assert wall_grid(Trajectory("p", pts, lumen=np.full(50, 30.0)))[0] is None
    far = _write(_sphere(10.0, 24), tmp_path / "far.vtp")  # encloses 5 of the 50 points
    grid, wall = wall_grid(Trajectory("p", pts, lumen=np.full(50, 30.0), mesh=str(far)))
    assert grid is None and wall.startswith("tube (the mesh encloses 10 % of the centerline")


def test_a_surface_of_the_walls_tissue_is_not_taken_for_the_lumens(tmp_path, monkeypatch):
    """A wall 8 mm thick as a closed solid (its inner and outer surface, as the Visible Human models have it): the
    path runs in its hollow, which the surface does not enclose; its outside would read as lumen once the signs are
    turned for the lumen. The run measures against the tube, and says why."""
    from vtkmodules.vtkFiltersCore import vtkAppendPolyData

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    both = vtkAppendPolyData()
    both.AddInputData(_cylinder(radius=20.0))
    both.AddInputData(_cylinder(radius=12.0))
    both.Update()
    wall = _write(both.GetOutput(), tmp_path / "tissue.vtp")
    x = np.arange(0.0, 150.0 + 1e-9, 2.0)
    pts = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    grid, why = wall_grid(Trajectory("hollow", pts, lumen=np.full(len(x), 24.0), feed=2.0, mesh=str(wall)))
    assert grid is None
    assert why == "tube (the mesh encloses 0 % of the centerline; it is not a closed surface around the lumen)"


@pytest.mark.run  # the whole colon's signed-distance grid, computed with vtk on a fresh cache (6.5 s of CPU)
def test_a_real_colon_is_measured_against_its_mesh_where_it_encloses_the_path():
    t = load_trajectory("gca:E90", feed=2.0)
    grid, wall = wall_grid(t)
    assert isinstance(grid, SdfGrid) and wall == "mesh E90.vtp"
    d = grid.at(t.points)
    assert np.all(d < 0.0)  # every centerline point inside the colon's surface
    # the lumen column is twice the exact distance: the grid reads the same within its bound
    assert np.all(np.abs(-d - t.lumen / 2) <= BOUND + 1e-6)


def _grid_reference(grid: SdfGrid):
    """The grid's trilinear interpolation by scipy: the independent reference of bhr's compiled lookup."""
    from scipy.interpolate import RegularGridInterpolator

    axes = [grid.origin[a] + grid.spacing * np.arange(grid.values.shape[a]) for a in range(3)]
    f = RegularGridInterpolator(axes, grid.values, method="linear", bounds_error=True)
    lo = np.array([a[0] for a in axes])
    hi = np.array([a[-1] for a in axes])

    def at(p: np.ndarray) -> np.ndarray:  # beyond the grid: its nearest point's value plus the distance to it
        c = np.clip(p, lo, hi)
        return f(c) + np.linalg.norm(p - c, axis=-1)

    return at


@pytest.fixture(scope="module")
def e60_wires():
    t = load_trajectory("gca:E60", feed=1.0)
    return t, bhr.follow(t, solver="lumen", alpha=30, module_length=5, body_modules=30)


@pytest.mark.run
def test_the_whole_robots_written_poses_are_scored_against_the_mesh(e60_wires):
    """Every written pose of the wires' motion: dense samples (0.25 mm) along its modules inside the anus, their
    clearance against the colon's surface read independently (scipy's trilinear interpolation of the same grid):
    bhr's smallest within 0.5 mm of it, and within the grid's bound of vtk's exact distance to the surface."""
    t, run = e60_wires
    mo = run.motion
    assert mo.wall == "mesh E60.vtp" and run.clearance.wall == "mesh E60.vtp"
    assert run.summary.to_dict()["wall"] == "mesh E60.vtp"
    assert mo.kept and not mo.crossed
    grid, _ = wall_grid(t)
    ref = _grid_reference(grid)
    from bhr.model._wallmesh import read_mesh

    mesh = read_mesh(t.mesh)
    radius = run.robot.robot_radius
    L = run.robot.module_length
    rng = np.random.default_rng(0)
    worst = np.argsort(np.where(np.isnan(mo.pose_clear), np.inf, mo.pose_clear))[:40]
    pick = np.unique(np.concatenate([worst, rng.choice(len(mo.t_s), 40, replace=False)]))
    f = np.linspace(0.0, 1.0, 21)
    checked = 0
    for p in pick:
        P = mo.points_mm[p]
        q = mo.insertion_mm[p] / L - (P.shape[0] - 1) + np.arange(P.shape[0])  # module lengths inside the anus
        ok = q[1:] >= 0.0  # a module whose front joint is inside: its part inside the anus
        lo = np.clip(-q[:-1][ok], 0.0, 1.0)
        u = lo[:, None] + f[None, :] * (1.0 - lo[:, None])
        samples = (P[:-1][ok][:, None] + u[:, :, None] * (P[1:] - P[:-1])[ok][:, None]).reshape(-1, 3)
        if not samples.size:
            continue
        mine = float(np.min(-ref(samples) - radius))
        assert abs(mine - mo.pose_clear[p]) <= 0.5, (p, mine, mo.pose_clear[p])
        exact = float(np.min(-exact_distance(mesh, samples) - radius))
        assert abs(exact - mo.pose_clear[p]) <= BOUND + 0.5, (p, exact, mo.pose_clear[p])
        checked += 1
    assert checked >= 60
    # the steps' tables fold the poses: a step's smallest is its poses' smallest
    s = run.summary.to_dict()
    assert s["min_clearance_mm"] == pytest.approx(float(np.nanmin(mo.pose_clear)))


@pytest.mark.run
def test_a_trail_run_is_scored_against_the_mesh_and_an_open_mesh_falls_back_to_the_tube(e60_wires):
    t, _ = e60_wires
    run = bhr.follow(t, solver="lumen", alpha=30, module_length=5, body_modules=30, locomotion="trail")
    assert run.trail.wall == "mesh E60.vtp" and run.clearance.wall == "mesh E60.vtp"
    grid, _ = wall_grid(t)
    ref = _grid_reference(grid)
    J = run.trail.joints  # (N, M + 1, 3) tip first
    pts = run.clearance.table[:, :run.robot.modules + 1]  # the head's points, base first
    head = J[:, run.robot.modules::-1]
    scored = np.isfinite(pts)
    assert scored.sum() > 1000
    mine = -ref(head[scored]) - run.robot.robot_radius
    assert np.max(np.abs(mine - pts[scored])) <= 1e-6  # the same grid, the same points: the same clearance
    vhm = load_trajectory("gca:VHM", feed=1.0)
    r2 = bhr.follow(vhm, solver="lumen", alpha=30, module_length=5, body_modules=10, locomotion="trail")
    assert r2.clearance.wall.startswith("tube (the mesh encloses 4 % of the centerline")


@pytest.mark.run
def test_a_robot_deep_in_a_real_colons_wall_reads_its_own_depth():
    """The thesis's head in colon E60 leaves the lumen far (steps 166-178 up to 30 mm into the wall, farther from the
    centerline than the grid's band): every point's clearance is vtk's exact one within the grid's bound, and the
    run's deepest is not one value shared by many steps."""
    from bhr.model._wallmesh import read_mesh

    t = load_trajectory("gca:E60")
    with pytest.warns(BhrWarning):  # tighter bends than the robot turns, and a narrow lumen
        run = bhr.follow(t)
    table = run.clearance.table[:, :run.robot.modules + 1]
    scored = np.isfinite(table)
    assert run.clearance.wall == "mesh E60.vtp" and scored.sum() > 3000
    exact = -exact_distance(read_mesh(t.mesh), run.points[scored]) - run.robot.robot_radius
    assert np.max(np.abs(table[scored] - exact)) <= BOUND + FAR
    assert exact.min() < -30.0
    worst = np.nanmin(run.clearance.table, axis=1)
    assert np.sum(worst == worst.min()) == 1
