"""The lumen's wall as a real surface: a signed-distance grid of a mesh, and the clearance against it.

A trajectory may name a surface mesh of its lumen (:attr:`bhr.model._path.Trajectory.mesh`: the
shipped real colons' ``trajectories/gca/NAME.vtp``, or the ``.vtp`` beside a CSV of the same name).
The clearance of a point ``p`` of the robot is then

    -phi(p) - robot radius

where ``phi`` is the signed distance to the surface (negative inside the lumen): the gap between the
robot's surface and the real wall, whatever the lumen's cross-section. Computing ``phi`` exactly
needs the mesh's triangles; here it is read from a grid: vtk evaluates the signed distance
(``vtkImplicitPolyDataDistance``) once per mesh at the nodes of a regular grid ``GRID_MM`` apart over
the mesh's bounds (plus a margin) that are near the lumen or the surface (:func:`sdf_values` says how the
others are filled in), the grid is cached on disk (``$XDG_CACHE_HOME/bhr/sdf/``, keyed by
the mesh file's bytes and the grid's spacing, written atomically), and runs interpolate it
trilinearly in compiled kernels. As the signed distance changes by at most 1 mm per mm, the
interpolated value is within ``sqrt(3) x GRID_MM`` of the exact one wherever the mesh is a closed,
consistently oriented surface near the point, and within ``(1 + sqrt(3) / 2) x GRID_MM`` more farther out
(tests/unit/test_wallmesh.py checks it against vtk's exact distance at random points and along a run).
A mesh is the wall only when it encloses the trajectory (:data:`MIN_INSIDE`) by ray parity: a surface of
the wall's tissue (an inner and an outer surface, as the Visible Human models are) is not the lumen's.

vtk is an optional part (the ``anatomy`` extra); without it, or for a run without a mesh, the
clearance is measured against the tube of the trajectory's lumen diameters (:mod:`bhr.model._tube`).
"""
from __future__ import annotations

import contextlib
import hashlib
import math
import os
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit

from bhr._settings.errors import BhrError
from bhr._settings.inputs import check_input
from bhr.model._tube import scored_span

__all__ = ["SdfGrid", "MIN_INSIDE", "wall_grid", "GRID_MM", "MARGIN_MM", "have_vtk", "load_sdf", "sdf_values",
           "mesh_clearance_run", "read_mesh", "exact_distance", "mesh_segment", "mesh_pose_kernel",
           "mesh_joints_kernel", "grid_args", "enclosed_share"]

#: Spacing (mm) of the signed-distance grid.
GRID_MM = 2.0
#: vtk evaluates the grid within (the largest lumen radius + BAND_MM) of the centerline, and near the surface.
BAND_MM = 15.0
#: Margin (mm) of the grid around the mesh's bounds.
MARGIN_MM = 12.0
#: A mesh edge may be shared by at most this many triangles (a closed surface's by 2; real colons' have up to 4).
MAX_EDGE_TRIANGLES = 16
#: The grid may have at most this many nodes (a colon's surface at 2 mm: a few million).
MAX_GRID_NODES = 60_000_000
#: At most this many points sample the mesh's surface for the grid (1 mm apart: a surface of about 9 m^2).
MAX_SURFACE_SAMPLES = 20_000_000
#: A mesh is the wall only when at least this share of its trajectory's points lie inside it (else the tube is).
MIN_INSIDE = 0.95
#: Golden-section iterations refining the worst sample of a module.
REFINE_ITERS = 20
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0


@dataclass
class SdfGrid:
    """Signed distance (mm, negative inside the lumen) at the nodes of a regular grid."""

    origin: np.ndarray  # (3,) mm, node (0, 0, 0)
    spacing: float  # mm
    values: np.ndarray  # (nx, ny, nz) float64
    encloses: float = 1.0  # the share of the centerline inside the surface by ray parity, whatever its normals

    def at(self, points: np.ndarray) -> np.ndarray:
        """The interpolated signed distance at ``points`` (..., 3)."""
        p = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        out = np.empty(p.shape[0])
        sdf_batch(self.values, self.origin, self.spacing, p, out)
        return out.reshape(np.asarray(points).shape[:-1])


def have_vtk() -> bool:
    """Whether vtk (the anatomy extra) can be imported."""
    try:
        import vtkmodules.vtkFiltersCore  # noqa: F401
    except ImportError:
        return False
    return True


def _need_vtk(what: str) -> None:
    if not have_vtk():
        from bhr._settings.extras import install_command

        raise BhrError(f"{what} needs vtk, part of bhr's anatomy extra; install it with: "
                       f"{install_command('anatomy')}")


#: A mesh is read by vtk in a child process (``python -c`` this), which hands back its points and triangles: vtk's
#: readers end the process on a damaged file (a segmentation fault on a count larger than the data, an abort on an
#: allocation it cannot make), which then costs one line instead of bhr itself.
_READER = r"""
import os
import sys
import numpy as np
sink = os.fdopen(os.dup(1), "wb")  # the arrays' own channel: whatever a library prints goes to stderr
os.dup2(2, 1)
from vtkmodules.vtkCommonCore import vtkObject
from vtkmodules.vtkFiltersCore import vtkTriangleFilter
vtkObject.GlobalWarningDisplayOff()
suffix, path = sys.argv[1], sys.argv[2]
if suffix == ".vtp":
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader as R
elif suffix == ".vtk":
    from vtkmodules.vtkIOLegacy import vtkPolyDataReader as R
elif suffix == ".stl":
    from vtkmodules.vtkIOGeometry import vtkSTLReader as R
elif suffix == ".ply":
    from vtkmodules.vtkIOPLY import vtkPLYReader as R
else:
    from vtkmodules.vtkIOGeometry import vtkOBJReader as R
from vtkmodules.util.numpy_support import vtk_to_numpy
r = R()
r.SetFileName(path)
tri = vtkTriangleFilter()
tri.SetInputConnection(r.GetOutputPort())
tri.PassLinesOff()
tri.PassVertsOff()
tri.Update()
out = tri.GetOutput()
pts = out.GetPoints()
points = np.zeros((0, 3)) if pts is None else np.asarray(vtk_to_numpy(pts.GetData()), dtype=np.float64)
polys = out.GetPolys()
off = np.asarray(vtk_to_numpy(polys.GetOffsetsArray()), dtype=np.int64)
conn = np.asarray(vtk_to_numpy(polys.GetConnectivityArray()), dtype=np.int64)
np.savez(sink, points=points, offsets=off, conn=conn)
sink.close()
"""


def read_mesh(path: str | os.PathLike[str]):
    """A surface mesh (.vtp, .vtk, .stl, .ply, .obj) as vtkPolyData of triangles; a one-line error if unreadable.

    vtk reads the file in a child process (:data:`_READER`), so that a damaged file that crashes vtk's reader costs
    one line; its triangles are checked (finite coordinates within the limit, indices of its own points) before
    the mesh is built here from them."""
    _need_vtk("reading a surface mesh")
    import io
    import signal
    import subprocess
    import sys

    from bhr._settings.inputs import MAX_FILE_BYTES, MAX_MM

    p = Path(path)
    kinds = (".vtp", ".vtk", ".stl", ".ply", ".obj")
    suffix = p.suffix.lower()
    if suffix not in kinds:
        raise BhrError(f"{p}: a surface mesh must be .vtp, .vtk, .stl, .ply or .obj, got {p.suffix or 'no extension'}")
    hint = "give a surface mesh (.vtp, .vtk, .stl, .ply or .obj) in mm"
    check_input(p, "surface mesh", hint)
    if os.stat(p).st_size > MAX_FILE_BYTES:
        raise BhrError(f"{p} is larger than {MAX_FILE_BYTES // (1024 * 1024)} MiB, too large for a surface mesh; "
                       "decimate it or " + hint)
    proc = subprocess.run([sys.executable, "-c", _READER, suffix, os.path.abspath(p)], stdin=subprocess.DEVNULL,
                          capture_output=True, check=False)
    if proc.returncode != 0:
        if proc.returncode < 0:
            try:
                why = f"vtk's reader crashed on it ({signal.Signals(-proc.returncode).name})"
            except ValueError:
                why = f"vtk's reader crashed on it (signal {-proc.returncode})"
        else:
            last = (proc.stderr.decode("utf-8", "replace").strip().splitlines() or ["?"])[-1]
            why = f"vtk could not read it ({last[:120]})"
        raise BhrError(f"{p}: not a readable {suffix} surface mesh: {why}; {hint}")
    try:
        with np.load(io.BytesIO(proc.stdout), allow_pickle=False) as z:
            points, off, conn = z["points"], z["offsets"], z["conn"]
    except (OSError, ValueError, KeyError) as exc:
        raise BhrError(f"{p}: not a readable {suffix} surface mesh ({str(exc)[:80]}); {hint}") from None
    sizes = np.diff(off)
    tris = conn[off[:-1][sizes == 3][:, None] + np.arange(3)] if off.size > 1 else np.zeros((0, 3), np.int64)
    if tris.shape[0] < 4:
        raise BhrError(f"{p}: no surface read ({tris.shape[0]} triangles); give a closed surface mesh in mm")
    if tris.min() < 0 or tris.max() >= points.shape[0]:
        raise BhrError(f"{p}: a triangle names a point the file does not have (point {int(tris.max()) + 1} of "
                       f"{points.shape[0]}); the file is damaged; {hint}")
    bad = ~np.isfinite(points).all(axis=1) | (np.abs(points) > MAX_MM).any(axis=1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise BhrError(f"{p}: point {k + 1} is {points[k].tolist()}, not a finite coordinate within +-{MAX_MM:g} mm; "
                       f"{hint}")
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    _, shared = np.unique(edges, axis=0, return_counts=True)
    if shared.max() > MAX_EDGE_TRIANGLES:  # vtk's normal orientation walks them pairwise: minutes on a 400 kB file
        raise BhrError(f"{p}: an edge is shared by {int(shared.max())} triangles (a surface's edge has 2, at most "
                       f"{MAX_EDGE_TRIANGLES} are accepted): not a surface (duplicated faces?); {hint}")
    return _polydata(points, tris)


def _polydata(points: np.ndarray, tris: np.ndarray):
    """vtkPolyData of ``points`` (N, 3) and triangles ``tris`` (M, 3) of point indices."""
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

    vp = vtkPoints()
    vp.SetData(numpy_to_vtk(np.ascontiguousarray(points, dtype=np.float64), deep=True))
    cells = vtkCellArray()
    offsets = np.arange(0, 3 * tris.shape[0] + 1, 3, dtype=np.int64)
    cells.SetData(numpy_to_vtkIdTypeArray(offsets, deep=True),
                  numpy_to_vtkIdTypeArray(np.ascontiguousarray(tris.ravel(), dtype=np.int64), deep=True))
    out = vtkPolyData()
    out.SetPoints(vp)
    out.SetPolys(cells)
    return out


def _oriented(mesh):
    from vtkmodules.vtkFiltersCore import vtkPolyDataNormals

    n = vtkPolyDataNormals()
    n.SetInputData(mesh)
    n.ConsistencyOn()
    n.AutoOrientNormalsOn()
    n.SplittingOff()
    n.Update()
    return n.GetOutput()


def exact_distance(mesh, points: np.ndarray) -> np.ndarray:
    """vtk's signed distance from ``points`` (K, 3) to ``mesh`` (its normals oriented outward): the reference."""
    from vtkmodules.vtkFiltersCore import vtkImplicitPolyDataDistance

    f = vtkImplicitPolyDataDistance()
    f.SetInput(_oriented(mesh))
    return np.array([f.EvaluateFunction(float(x), float(y), float(z)) for x, y, z in np.asarray(points)])


def _surface_samples(mesh, gap: float) -> np.ndarray:
    """Points on the triangles of ``mesh`` (vtkPolyData of triangles), every point of its surface within ``gap`` of
    one: each triangle's points ``a + (i (b - a) + j (c - a)) / k`` (i + j <= k), k its longest edge / ``gap``."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    pts = np.asarray(vtk_to_numpy(mesh.GetPoints().GetData()), dtype=np.float64)
    tris = np.asarray(vtk_to_numpy(mesh.GetPolys().GetConnectivityArray()), dtype=np.int64).reshape(-1, 3)
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1)],
                     axis=0)
    k = np.maximum(1, np.ceil(longest / gap)).astype(np.int64)
    if float(np.sum((k + 1) * (k + 2) // 2)) > MAX_SURFACE_SAMPLES:
        raise BhrError(f"the mesh's surface is too large for the wall's grid (triangles of up to {longest.max():.0f} "
                       f"mm, more than {MAX_SURFACE_SAMPLES:,} points {gap:g} mm apart on them); give the lumen's "
                       "surface in mm")
    out = [pts]
    for n in np.unique(k):
        i, j = np.nonzero(np.add.outer(np.arange(n + 1), np.arange(n + 1)) <= n)  # the lattice i + j <= n
        i, j = i / n, j / n
        sel = k == n
        out.append((a[sel, None] + i[None, :, None] * (b - a)[sel, None] + j[None, :, None] * (c - a)[sel, None])
                   .reshape(-1, 3))
    return np.concatenate(out)


def sdf_values(mesh, centerline: np.ndarray, band: float, spacing: float = GRID_MM,
               margin: float = MARGIN_MM) -> SdfGrid:
    """The signed-distance grid of ``mesh`` (vtkPolyData) over its bounds plus ``margin``, ``spacing`` apart.

    vtk evaluates the signed distance at the nodes near the lumen or its wall: within ``band`` mm of the
    ``centerline`` (K, 3), or within two spacings of the surface. Every other node is farther from the surface than
    that. Its distance is that to the nearest node at the wall (one whose distance is at most a spacing) plus that
    node's: the exact distance, or more by at most (1 + sqrt(3) / 2) spacings. It is wall where its region of such
    nodes reaches the grid's edge, lumen where the surface encloses the region (vtk's sign is not used there: far
    from a real colon's surface it is often wrong; only its orientation is, positive outside unless the normals
    point in, which :func:`wall_grid` turns). So a point deep in the wall, or in a pocket of the lumen beyond
    ``band``, reads its own distance, not a value shared by all of them. ``encloses``: the share of the
    ``centerline`` inside the surface by ray parity."""
    from scipy import ndimage
    from scipy.spatial import cKDTree
    from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkDoubleArray
    from vtkmodules.vtkFiltersCore import vtkImplicitPolyDataDistance

    oriented = _oriented(mesh)
    b = np.array(oriented.GetBounds(), dtype=np.float64)
    lo = b[0::2] - margin
    hi = b[1::2] + margin
    dims = tuple(int(d) for d in np.ceil((hi - lo) / spacing).astype(int) + 1)
    axes = [lo[a] + spacing * np.arange(dims[a]) for a in range(3)]
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    gap = 0.5 * spacing
    lumen, _ = cKDTree(np.asarray(centerline, dtype=np.float64)).query(nodes, distance_upper_bound=band + spacing)
    # the nodes within two spacings of the surface, and more: those within that (plus a sample's reach to its
    # surface point and its nearest node) of a node nearest to a point on the surface
    cell = np.clip(np.rint((_surface_samples(oriented, gap) - lo) / spacing).astype(np.int64), 0, np.array(dims) - 1)
    on_surface = np.zeros(dims, dtype=bool)
    on_surface[tuple(cell.T)] = True
    wall = ndimage.distance_transform_edt(~on_surface, sampling=spacing) <= (2.0 + math.sqrt(3.0) / 2.0) * spacing + gap
    near = np.isfinite(lumen) | wall.ravel()
    del lumen, wall, on_surface
    vals = np.zeros(nodes.shape[0])
    f = vtkImplicitPolyDataDistance()
    f.SetInput(oriented)
    pts = np.ascontiguousarray(nodes[near])
    del nodes
    out = vtkDoubleArray()
    out.SetNumberOfTuples(pts.shape[0])
    f.FunctionValue(numpy_to_vtk(pts, deep=True), out)
    vals[near] = vtk_to_numpy(out)
    far = ~near
    if far.any():  # every node within a spacing of the surface is evaluated: the nodes "at the wall"
        at_wall = near & (np.abs(vals) <= spacing)
        depth, nearest = ndimage.distance_transform_edt(~at_wall.reshape(dims), sampling=spacing, return_indices=True)
        size = depth.ravel() + np.abs(vals[np.ravel_multi_index(tuple(nearest), dims).ravel()])
        del nearest, depth
        # the sign: a region of such nodes reaching the grid's edge is outside, the wall; one the surface encloses
        # is inside the lumen (vtk's sign is not used: far from a real colon's surface it is often wrong). The wall's
        # sign is vtk's next to the outside (negative for a surface whose normals point in: wall_grid turns it)
        regions, _ = ndimage.label(far.reshape(dims))
        edge = np.unique(np.concatenate([regions[[0, -1]].ravel(), regions[:, [0, -1]].ravel(),
                                         regions[:, :, [0, -1]].ravel()]))  # the regions on the grid's faces
        outside = np.isin(regions, edge[edge > 0])
        beside = ndimage.binary_dilation(outside).ravel() & near
        wall_sign = 1.0 if np.sum(np.sign(vals[beside])) >= 0.0 else -1.0
        vals[far] = (wall_sign * np.where(outside.ravel(), size, -size))[far]
    return SdfGrid(lo, float(spacing), vals.reshape(*dims).copy(), enclosed_share(oriented, centerline))


def enclosed_share(mesh, points: np.ndarray) -> float:
    """The share of ``points`` (K, 3) inside the closed surface ``mesh`` by ray parity (vtkSelectEnclosedPoints),
    whatever the orientation of its normals: a surface of the lumen encloses its centerline; one of the wall's
    tissue (inner and outer surface, as the Visible Human models are) does not."""
    from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkPolyData
    from vtkmodules.vtkFiltersModeling import vtkSelectEnclosedPoints

    vp = vtkPoints()
    vp.SetData(numpy_to_vtk(np.ascontiguousarray(points, dtype=np.float64), deep=True))
    cloud = vtkPolyData()
    cloud.SetPoints(vp)
    select = vtkSelectEnclosedPoints()
    select.SetInputData(cloud)
    select.SetSurfaceData(mesh)
    select.CheckSurfaceOff()  # a surface with small holes (the shipped CT colons have a few) is still tested
    select.Update()
    return float(np.mean(vtk_to_numpy(select.GetOutput().GetPointData().GetArray("SelectedPoints"))))


def _cache_folder() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "bhr" / "sdf"


def load_sdf(path: str | os.PathLike[str], centerline: np.ndarray, band: float, spacing: float = GRID_MM) -> SdfGrid:
    """The signed-distance grid of the mesh file ``path`` within ``band`` mm of ``centerline``: from the cache, else
    computed (vtk) and cached."""
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise BhrError(f"{p}: cannot read the mesh ({exc.strerror or exc}); give the lumen's surface mesh") from None
    h = hashlib.sha256(data)
    h.update(np.ascontiguousarray(centerline, dtype=np.float64).tobytes())
    h.update(f"|{band!r}|{spacing!r}|{MARGIN_MM!r}|v5".encode())
    key = h.hexdigest()[:32]
    folder = _cache_folder()
    cached = folder / f"{key}.npz"
    if cached.is_file():
        try:
            with np.load(cached) as z:
                return SdfGrid(z["origin"], float(z["spacing"]), np.ascontiguousarray(z["values"], dtype=np.float64),
                               float(z["encloses"]))
        except (OSError, ValueError, KeyError):
            pass  # a damaged cache file: computed again and replaced
    mesh = read_mesh(p)
    b = np.array(mesh.GetBounds(), dtype=np.float64)
    nodes = math.prod(float(np.ceil((b[2 * a + 1] - b[2 * a] + 2 * MARGIN_MM) / spacing) + 1) for a in range(3))
    if nodes > MAX_GRID_NODES:
        raise BhrError(f"{p}: the mesh spans {' x '.join(f'{v:.0f}' for v in b[1::2] - b[0::2])} mm, too large for "
                       f"the wall's grid of {spacing:g} mm ({nodes:.3g} nodes, at most {MAX_GRID_NODES:,}); give the "
                       "lumen's surface in mm, or move the mesh away to measure against the tube")
    try:
        grid = sdf_values(mesh, centerline, band, spacing)
    except BhrError as exc:
        raise BhrError(f"{p}: {exc}") from None
    tmp = folder / f".sdf-{uuid.uuid4().hex[:8]}.npz"  # named first: a Ctrl-C at any moment leaves no file behind
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with open(tmp, "xb") as fh:
            np.savez_compressed(fh, origin=grid.origin, spacing=grid.spacing, values=grid.values.astype(np.float32),
                                encloses=grid.encloses)
        os.replace(tmp, cached)  # atomic: a concurrent reader sees the whole file or none
    except OSError:
        pass  # no cache: computed again next time
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()
    return SdfGrid(grid.origin, grid.spacing, grid.values.astype(np.float32).astype(np.float64), grid.encloses)


def wall_grid(traj) -> tuple[SdfGrid | None, str]:
    """The signed-distance grid a run of ``traj`` measures its clearance against, and why: (grid, "mesh ...") when
    the trajectory has a mesh that vtk can read and that encloses the trajectory, else (None, "tube: why")."""
    mesh = getattr(traj, "mesh", None)
    if not mesh:
        return None, "tube"
    if not have_vtk():
        from bhr._settings.extras import install_command

        return None, f"tube (the mesh needs vtk: {install_command('anatomy')})"
    pts = np.asarray(traj.points, dtype=np.float64)
    band = BAND_MM + (0.5 * float(np.max(traj.lumen)) if traj.lumen is not None else 30.0)
    grid = load_sdf(mesh, pts, band)
    if grid.encloses < MIN_INSIDE:
        return None, (f"tube (the mesh encloses {100 * grid.encloses:.0f} % of the centerline; it is not a closed "
                      "surface around the lumen)")
    inside = float(np.mean(grid.at(pts) < 0.0))
    if inside < 0.5:  # the mesh's normals point inward: the other sign
        grid = SdfGrid(grid.origin, grid.spacing, -grid.values, grid.encloses)
        inside = 1.0 - inside
    if inside < MIN_INSIDE:
        return None, (f"tube (the mesh leaves {100 * (1 - inside):.0f} % of the centerline outside; it is not a "
                      "closed surface around the lumen)")
    return grid, f"mesh {Path(mesh).name}"


# ---------------------------------------------------------------------------
# compiled kernels


@njit(cache=True)
def sdf_at(V, ox, oy, oz, h, x, y, z):
    """Trilinear interpolation of the grid ``V`` at (x, y, z); outside the grid, its nearest point's value plus the
    distance to it (the signed distance grows by at most that much)."""
    nx, ny, nz = V.shape[0], V.shape[1], V.shape[2]
    gx = (x - ox) / h
    gy = (y - oy) / h
    gz = (z - oz) / h
    cx = min(max(gx, 0.0), nx - 1.0)
    cy = min(max(gy, 0.0), ny - 1.0)
    cz = min(max(gz, 0.0), nz - 1.0)
    out = h * math.sqrt((gx - cx) ** 2 + (gy - cy) ** 2 + (gz - cz) ** 2)
    i = min(int(cx), nx - 2)
    j = min(int(cy), ny - 2)
    k = min(int(cz), nz - 2)
    fx = cx - i
    fy = cy - j
    fz = cz - k
    c00 = V[i, j, k] * (1 - fx) + V[i + 1, j, k] * fx
    c10 = V[i, j + 1, k] * (1 - fx) + V[i + 1, j + 1, k] * fx
    c01 = V[i, j, k + 1] * (1 - fx) + V[i + 1, j, k + 1] * fx
    c11 = V[i, j + 1, k + 1] * (1 - fx) + V[i + 1, j + 1, k + 1] * fx
    c0 = c00 * (1 - fy) + c10 * fy
    c1 = c01 * (1 - fy) + c11 * fy
    return out + c0 * (1 - fz) + c1 * fz


@njit(cache=True)
def sdf_batch(V, origin, h, P, out):
    for q in range(P.shape[0]):
        out[q] = sdf_at(V, origin[0], origin[1], origin[2], h, P[q, 0], P[q, 1], P[q, 2])


@njit(cache=True)
def _clear(V, o, h, radius, ax, ay, az, bx, by, bz, t):
    return -sdf_at(V, o[0], o[1], o[2], h, ax + t * (bx - ax), ay + t * (by - ay), az + t * (bz - az)) - radius


@njit(cache=True)
def mesh_segment(V, o, h, radius, ax, ay, az, bx, by, bz, lo_t, hi_t, sample, out):
    """The smallest clearance against the mesh along the part ``lo_t <= t <= hi_t`` of the segment a->b: sampled at
    most ``sample`` mm apart (both ends included) and the worst sample refined by a golden-section search between
    its neighbours. ``out`` gets (clearance, t); (NaN, -1) when no sample lies in the part."""
    L = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2)
    ns = max(int(math.ceil(L / sample)), 1)
    best = 1e300
    bt = -1.0
    for q in range(ns + 1):
        t = q / ns
        if t < lo_t or t > hi_t:
            continue
        v = _clear(V, o, h, radius, ax, ay, az, bx, by, bz, t)
        if v < best:
            best = v
            bt = t
    if bt < 0.0:
        out[0] = np.nan
        out[1] = -1.0
        return
    a = max(bt - 1.0 / ns, lo_t)
    b = min(bt + 1.0 / ns, hi_t)
    x1 = b - _GOLD * (b - a)
    x2 = a + _GOLD * (b - a)
    f1 = _clear(V, o, h, radius, ax, ay, az, bx, by, bz, x1)
    f2 = _clear(V, o, h, radius, ax, ay, az, bx, by, bz, x2)
    for _ in range(REFINE_ITERS):
        if f1 < f2:
            b = x2
            x2 = x1
            f2 = f1
            x1 = b - _GOLD * (b - a)
            f1 = _clear(V, o, h, radius, ax, ay, az, bx, by, bz, x1)
        else:
            a = x1
            x1 = x2
            f1 = f2
            x2 = a + _GOLD * (b - a)
            f2 = _clear(V, o, h, radius, ax, ay, az, bx, by, bz, x2)
    if f1 < best:
        best = f1
        bt = x1
    if f2 < best:
        best = f2
        bt = x2
    out[0] = best
    out[1] = bt


@njit(cache=True)
def mesh_clearance_kernel(V, o, h, radius, Q, E, sample, pt_out, mod_out, where):
    """Clearance against the mesh of every step's points ``Q`` (N, K, 3) in chain order; a point (or the part of a
    module) expected before the path's start (``E`` < 0) is not scored (NaN). Modules are sampled at most
    ``sample`` mm apart and their worst sample refined by a golden-section search, as against the tube."""
    N, K = Q.shape[0], Q.shape[1]
    res = np.empty(2)
    for i in range(N):
        for k in range(K):
            if E[i, k] < 0.0:
                pt_out[i, k] = np.nan
            else:
                pt_out[i, k] = _clear(V, o, h, radius, Q[i, k, 0], Q[i, k, 1], Q[i, k, 2], 0.0, 0.0, 0.0, 0.0)
        for m in range(K - 1):
            ax, ay, az = Q[i, m, 0], Q[i, m, 1], Q[i, m, 2]
            bx, by, bz = Q[i, m + 1, 0], Q[i, m + 1, 1], Q[i, m + 1, 2]
            ea, eb = E[i, m], E[i, m + 1]
            lo_t, hi_t = scored_span(ea, eb)
            mesh_segment(V, o, h, radius, ax, ay, az, bx, by, bz, lo_t, hi_t, sample, res)
            mod_out[i, m] = res[0]
            bt = res[1]
            if bt < 0.0:
                where[i, m, 0] = np.nan
                where[i, m, 1] = np.nan
                where[i, m, 2] = np.nan
            else:
                where[i, m, 0] = ax + bt * (bx - ax)
                where[i, m, 1] = ay + bt * (by - ay)
                where[i, m, 2] = az + bt * (bz - az)


@njit(cache=True)
def mesh_pose_kernel(V, o, h, radius, pts, xs, steps, L, sample, near, pc, mc, mwhere, low):
    """Clearance against the mesh of poses of a chain of rigid modules (points (K, M+1, 3) tail first, the tail
    ``xs`` mm past the entrance minus M module lengths ``L``; joint i at ``xs / L - M + i`` module lengths along),
    folded into the 0-based path ``steps``' tables: each joint's smallest (N, M+1), each module's smallest along
    it (N, M) and where (N, M, 3); ``low`` (K) each pose's smallest. Joints (and parts of modules) still outside
    the entrance are not scored. A module whose ends are both farther than ``sqrt(3) L / 2 + near`` mm from the
    wall is scored at its ends and middle (the interpolated distance changes by at most sqrt(3) mm per mm: it is
    clear all along), any other sampled at most ``sample`` mm apart and refined (:func:`mesh_segment`)."""
    K = pts.shape[0]
    J = pts.shape[1]
    M = J - 1
    cj = np.empty(J)
    qs = np.empty(J)
    res = np.empty(2)
    far = 0.5 * math.sqrt(3.0) * L + near
    for j in range(K):
        st = steps[j]
        best = np.inf
        for i in range(J):
            q = xs[j] / L - M + i
            qs[i] = q
            if q < 0.0:
                cj[i] = np.nan
                continue
            c = _clear(V, o, h, radius, pts[j, i, 0], pts[j, i, 1], pts[j, i, 2], 0.0, 0.0, 0.0, 0.0)
            cj[i] = c
            if c < best:
                best = c
            if not (pc[st, i] <= c):
                pc[st, i] = c
        for m in range(M):
            if qs[m + 1] < 0.0:
                continue
            ax, ay, az = pts[j, m, 0], pts[j, m, 1], pts[j, m, 2]
            bx, by, bz = pts[j, m + 1, 0], pts[j, m + 1, 1], pts[j, m + 1, 2]
            lo_t = 0.0 if qs[m] >= 0.0 else -qs[m] / (qs[m + 1] - qs[m])
            if qs[m] >= 0.0 and min(cj[m], cj[m + 1]) > far:  # ends and middle: all of it is clear
                v = _clear(V, o, h, radius, ax, ay, az, bx, by, bz, 0.5)
                bt = 0.5
                if cj[m] < v:
                    v = cj[m]
                    bt = 0.0
                if cj[m + 1] < v:
                    v = cj[m + 1]
                    bt = 1.0
            else:
                mesh_segment(V, o, h, radius, ax, ay, az, bx, by, bz, lo_t, 1.0, sample, res)
                v = res[0]
                bt = res[1]
            if bt < 0.0:
                continue
            if v < best:
                best = v
            if not (mc[st, m] <= v):
                mc[st, m] = v
                mwhere[st, m, 0] = ax + bt * (bx - ax)
                mwhere[st, m, 1] = ay + bt * (by - ay)
                mwhere[st, m, 2] = az + bt * (bz - az)
        low[j] = best if best < np.inf else np.nan


@njit(cache=True)
def mesh_joints_kernel(V, o, h, radius, pts, xs, L, out):
    """Each pose's smallest clearance of its joints inside the entrance (K,) against the mesh (NaN: none inside)."""
    J = pts.shape[1]
    M = J - 1
    for j in range(pts.shape[0]):
        best = np.inf
        for i in range(J):
            if xs[j] / L - M + i < 0.0:
                continue
            c = _clear(V, o, h, radius, pts[j, i, 0], pts[j, i, 1], pts[j, i, 2], 0.0, 0.0, 0.0, 0.0)
            if c < best:
                best = c
        out[j] = best if best < np.inf else np.nan


def grid_args(grid: SdfGrid) -> tuple[np.ndarray, np.ndarray, float]:
    """(values, origin, spacing) of ``grid`` as the kernels take them (contiguous float64)."""
    return (np.ascontiguousarray(grid.values, dtype=np.float64), np.ascontiguousarray(grid.origin, dtype=np.float64),
            float(grid.spacing))


def mesh_clearance_run(grid: SdfGrid, radius: float, Q: np.ndarray, E: np.ndarray, sample: float
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (N, K), modules (N, K-1), where (N, K-1, 3)): the clearance of a run's chain against the mesh."""
    N, K = E.shape
    pt = np.empty((N, K))
    mod = np.empty((N, max(K - 1, 0)))
    where = np.empty((N, max(K - 1, 0), 3))
    mesh_clearance_kernel(np.ascontiguousarray(grid.values), np.ascontiguousarray(grid.origin, dtype=np.float64),
                          float(grid.spacing), float(radius), np.ascontiguousarray(Q, dtype=np.float64),
                          np.ascontiguousarray(E, dtype=np.float64), float(sample), pt, mod, where)
    return pt, mod, where
