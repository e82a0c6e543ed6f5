"""Import a colon: a surface mesh with its centerline, a mesh alone, or a labelled segmentation -> a bhr trajectory.

``bhr import`` (cli/import_.py) calls :func:`import_colon` and writes what it returns as a trajectory CSV
(``x,y,z,lumen[,section]``, mm, docs/trajectories.md) and, where there is a surface, the surface beside it
(``NAME.vtp``), which bhr then measures the clearance against (docs/real_colons.md). What was done is listed in
:attr:`Imported.report` and written into the CSV's header:

* **centerline**: given (a CSV of points, with optional ``section`` names), or extracted: the mesh is voxelised
  (vtk's stencil of the closed surface) or the segmentation's label taken as a mask, the mask skeletonised
  (kimimaro, TEASAR), and the longest path through the skeleton kept (**branch selection**: every other branch is
  dropped and counted in the report);
* **direction**: the path starts at the end nearest ``start`` (the anus), or at its lower end (smallest z) when no
  start is given;
* **smoothing**: a Gaussian of ``smooth_mm`` (standard deviation, mm of arc length) along the path, ends held;
* **resampling**: every ``spacing`` mm of arc length;
* **lumen**: the diameter at each point is twice its distance to the surface (vtk's exact distance to the mesh,
  or the segmentation's Euclidean distance transform in mm);
* **surface** of a segmentation: the label's boundary by marching cubes (vtk's flying edges at 0.5 of the mask,
  Gaussian-smoothed by one voxel), in the image's world frame (mm), decimated to at most
  :data:`SURFACE_TRIANGLES` triangles, so that runs measure the clearance against it.

vtk, nibabel and kimimaro are the optional ``anatomy`` extra.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bhr._settings.errors import BhrError
from bhr._settings.inputs import check_input

__all__ = ["Imported", "import_colon", "mask_surface", "SURFACE_TRIANGLES", "longest_path", "smooth_path",
           "resample_arc", "MESH_SUFFIXES",
           "SEGMENTATION_SUFFIXES"]

MESH_SUFFIXES = (".vtp", ".vtk", ".stl", ".ply", ".obj")
#: A segmentation's surface is decimated to at most this many triangles (as the shipped colons' surfaces).
SURFACE_TRIANGLES = 20000
SEGMENTATION_SUFFIXES = (".nii", ".nii.gz")
#: A mask (a mesh voxelised, a segmentation's label and its margin) may have at most this many voxels.
MAX_MASK_VOXELS = 60_000_000
#: A segmentation may have at most this many voxels (a CT of 512 x 512 x 1024), read from its header before its data.
MAX_SEGMENTATION_VOXELS = 512 * 512 * 1024


@dataclass
class Imported:
    """A colon ready to be written: points (K, 3) mm, lumen diameters (K,), section per point, surface, report."""

    points: np.ndarray
    lumen: np.ndarray
    sections: list[str] | None
    mesh: Any  # vtkPolyData in mm, or None
    report: list[str] = field(default_factory=list)

    def csv_text(self, title: str) -> str:
        head = [f"# {title}", *(f"# {line}" for line in self.report), "# lumen_end: closed"]
        cols = "x,y,z,lumen" + (",section" if self.sections is not None else "")
        rows = []
        for k, ((x, y, z), d) in enumerate(zip(self.points, self.lumen)):
            row = f"{x:.3f},{y:.3f},{z:.3f},{d:.2f}"
            if self.sections is not None:
                row += f",{self.sections[k]}"
            rows.append(row)
        return "\n".join(head + [cols] + rows) + "\n"


def _need(module: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        from bhr._settings.extras import install_command

        raise BhrError(f"bhr import needs {module.split('.')[0]}, part of bhr's anatomy extra; install it with: "
                       f"{install_command('anatomy')}") from None


def longest_path(vertices: np.ndarray, edges: np.ndarray, start: np.ndarray | None = None
                 ) -> tuple[np.ndarray, int, int]:
    """The longest shortest path through a skeleton graph's largest connected piece: from the vertex nearest
    ``start`` (when given) to the vertex farthest from it along the graph, else between the two ends that two sweeps
    of Dijkstra find. Returns (vertex indices along it, vertices dropped, branch ends dropped)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components, dijkstra

    n = vertices.shape[0]
    if n < 2 or edges.shape[0] == 0:
        raise BhrError("the skeleton has no edges; the surface or label is too small or too thin to follow")
    w = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    g = coo_matrix((np.concatenate([w, w]), (np.concatenate([edges[:, 0], edges[:, 1]]),
                                              np.concatenate([edges[:, 1], edges[:, 0]]))), shape=(n, n)).tocsr()
    _, comp = connected_components(g, directed=False)
    biggest = np.bincount(comp).argmax()
    members = np.flatnonzero(comp == biggest)
    if start is not None:
        a = int(members[np.argmin(np.linalg.norm(vertices[members] - start, axis=1))])
    else:
        d0 = dijkstra(g, indices=int(members[0]))
        d0[~np.isfinite(d0)] = -1
        a = int(np.argmax(d0))
    da, pred = dijkstra(g, indices=a, return_predecessors=True)
    da[~np.isfinite(da)] = -1
    b = int(np.argmax(da))
    path = [b]
    while path[-1] != a:
        path.append(int(pred[path[-1]]))
    path = path[::-1]
    degree = np.bincount(edges.ravel(), minlength=n)
    ends = int(np.count_nonzero((degree == 1) & (comp == biggest))) - 2
    return np.array(path), int(n - len(path)), max(ends, 0)


def resample_arc(points: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``spacing`` mm of arc length along the polyline, and the arc length of each input point."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep = np.concatenate([[True], seg > 1e-9])
    points = points[keep]
    arc = np.concatenate([[0.0], np.cumsum(seg[seg > 1e-9])])
    s = np.arange(0.0, arc[-1] + 1e-9, spacing)
    return np.stack([np.interp(s, arc, points[:, k]) for k in range(3)], axis=1), arc


def smooth_path(points: np.ndarray, spacing: float, sigma_mm: float) -> np.ndarray:
    """A Gaussian of ``sigma_mm`` along a path of points ``spacing`` apart, its two ends held where they are."""
    if sigma_mm <= 0:
        return points
    from scipy.ndimage import gaussian_filter1d

    out = gaussian_filter1d(points, sigma_mm / spacing, axis=0, mode="nearest")
    out[0], out[-1] = points[0], points[-1]
    return out


def _orient(points: np.ndarray, start: np.ndarray | None, report: list[str]) -> np.ndarray:
    if start is not None:
        if np.linalg.norm(points[-1] - start) < np.linalg.norm(points[0] - start):
            points = points[::-1]
        report.append(f"direction: from the end nearest the start point ({', '.join(f'{v:g}' for v in start)}) mm, "
                      f"{np.linalg.norm(points[0] - start):.1f} mm from it")
    else:
        if points[-1, 2] < points[0, 2]:
            points = points[::-1]
        report.append("direction: from the path's lower end (smallest z; give --start X,Y,Z for the anus)")
    return points


def _mesh_distance(mesh: Any, pts: np.ndarray) -> np.ndarray:
    from bhr.model._wallmesh import exact_distance

    return np.abs(exact_distance(mesh, pts))


def _mask_skeleton(mask: np.ndarray, voxel: tuple[float, float, float], report: list[str],
                   start: np.ndarray | None = None) -> np.ndarray:
    """The longest path of the mask's skeleton (from the vertex nearest ``start``, given in the same frame), in mm of
    the mask's index frame (index x voxel size)."""
    kimimaro = _need("kimimaro")
    labels = mask.astype(np.uint32)
    skels = kimimaro.skeletonize(labels, anisotropy=voxel, fix_branching=True, progress=False, parallel=1,
                                 teasar_params={"scale": 1.5, "const": 20, "pdrf_scale": 100000,
                                                "pdrf_exponent": 4})
    if 1 not in skels:
        raise BhrError("no skeleton found: the surface or label encloses no volume at this voxel size")
    sk = skels[1]
    idx, dropped, branches = longest_path(np.asarray(sk.vertices, dtype=np.float64), np.asarray(sk.edges), start)
    pts = np.asarray(sk.vertices, dtype=np.float64)[idx]
    report.append(f"centerline: skeleton of the volume (kimimaro TEASAR, voxels {' x '.join(f'{v:g}' for v in voxel)} "
                  f"mm), {len(sk.vertices)} vertices; branch selection: the longest path"
                  + (" from the vertex nearest the start point" if start is not None else "")
                  + f" kept ({len(idx)} vertices), "
                  f"{branches} side branch{'es' if branches != 1 else ''} and {dropped} vertices dropped")
    return pts


def _voxelise(mesh: Any, voxel: float) -> tuple[np.ndarray, np.ndarray]:
    """The closed surface's inside as a boolean mask (x, y, z) of ``voxel`` mm, and the mask's origin (mm)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkImagingStencil import vtkImageStencil, vtkPolyDataToImageStencil

    b = np.array(mesh.GetBounds())
    lo = b[0::2] - 2 * voxel
    span = np.ceil((b[1::2] + 2 * voxel - lo) / voxel) + 1
    if not np.isfinite(span).all() or math.prod(float(v) for v in span) > MAX_MASK_VOXELS:  # floats: no int overflow
        raise BhrError(f"the mesh spans {' x '.join(f'{v:.0f}' for v in b[1::2] - b[0::2])} units: too large to "
                       f"voxelise at {voxel:g} mm (is it in mm?); give --voxel larger or a centerline")
    dims = span.astype(int)
    img = vtkImageData()
    img.SetSpacing(voxel, voxel, voxel)
    img.SetOrigin(*lo)
    img.SetDimensions(*(int(v) for v in dims))
    img.AllocateScalars(3, 1)  # VTK_UNSIGNED_CHAR
    img.GetPointData().GetScalars().Fill(1)
    st = vtkPolyDataToImageStencil()
    st.SetInputData(mesh)
    st.SetOutputOrigin(*lo)
    st.SetOutputSpacing(voxel, voxel, voxel)
    st.SetOutputWholeExtent(img.GetExtent())
    cut = vtkImageStencil()
    cut.SetInputData(img)
    cut.SetStencilConnection(st.GetOutputPort())
    cut.ReverseStencilOff()
    cut.SetBackgroundValue(0)
    cut.Update()
    arr = vtk_to_numpy(cut.GetOutput().GetPointData().GetScalars()).reshape(dims[2], dims[1], dims[0])
    return np.ascontiguousarray(arr.transpose(2, 1, 0) > 0), lo


def mask_surface(mask: np.ndarray, affine: np.ndarray, report: list[str], sigma_voxels: float = 1.0,
                 target: int = SURFACE_TRIANGLES) -> Any:
    """The closed surface (vtkPolyData, world mm) of a boolean ``mask`` (i, j, k) whose voxel indices map to the world
    by ``affine`` (4 x 4): marching cubes (vtkFlyingEdges3D) at 0.5 of the mask Gaussian-smoothed by
    ``sigma_voxels``, padded by one empty voxel so that it is closed, decimated (vtkQuadricDecimation, volume
    preserved) to at most ``target`` triangles."""
    from scipy.ndimage import gaussian_filter
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkCommonMath import vtkMatrix4x4
    from vtkmodules.vtkCommonTransforms import vtkTransform
    from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D, vtkQuadricDecimation, vtkTriangleFilter
    from vtkmodules.vtkFiltersGeneral import vtkTransformFilter

    field_ = gaussian_filter(np.pad(mask.astype(np.float32), 2), sigma_voxels) if sigma_voxels > 0 else \
        np.pad(mask.astype(np.float32), 2)
    img = vtkImageData()
    img.SetDimensions(*field_.shape)
    img.SetOrigin(-2.0, -2.0, -2.0)
    img.SetSpacing(1.0, 1.0, 1.0)
    img.GetPointData().SetScalars(numpy_to_vtk(np.ravel(field_, order="F"), deep=True))
    fe = vtkFlyingEdges3D()
    fe.SetInputData(img)
    fe.SetValue(0, 0.5)
    fe.ComputeNormalsOff()
    fe.Update()
    m = vtkMatrix4x4()
    for a in range(4):
        for b in range(4):
            m.SetElement(a, b, float(affine[a, b]))
    t = vtkTransform()
    t.SetMatrix(m)
    tf = vtkTransformFilter()
    tf.SetInputConnection(fe.GetOutputPort())
    tf.SetTransform(t)
    tri = vtkTriangleFilter()
    tri.SetInputConnection(tf.GetOutputPort())
    tri.Update()
    out = tri.GetOutput()
    n = out.GetNumberOfCells()
    if n > target:
        d = vtkQuadricDecimation()
        d.SetInputData(out)
        d.SetTargetReduction(1.0 - target / n)
        d.VolumePreservationOn()
        d.Update()
        out = d.GetOutput()
    report.append(f"surface: the label's boundary by marching cubes (vtk flying edges at 0.5 of the mask smoothed by "
                  f"a Gaussian of {sigma_voxels:g} voxel), {n} triangles"
                  + (f" decimated to {out.GetNumberOfCells()}" if n > target else ""))
    return out


def check_source(source: str | Path, centerline: str | Path | None = None) -> None:
    """Refuse a ``source`` (or a ``centerline``) that is not a readable, non-empty file (missing, a folder, a device,
    a FIFO) in one line naming what it is and what to give instead, before anything is read."""
    check_input(source, "surface mesh or segmentation", f"give a surface mesh ({', '.join(MESH_SUFFIXES)}) or a "
                f"segmentation ({', '.join(SEGMENTATION_SUFFIXES)})")
    if centerline is not None:
        check_input(centerline, "centerline CSV", "give the colon's centerline as a CSV of x,y,z[,section] in mm, "
                    "anus first, or leave --centerline out to extract it from the surface")


def import_colon(source: str | Path, *, centerline: str | Path | None = None, label: int | None = None,
                 start: tuple[float, float, float] | None = None, smooth_mm: float = 3.0, spacing: float = 1.0,
                 voxel_mm: float = 1.0) -> Imported:
    """Import ``source`` (a surface mesh or a NIfTI segmentation) as a colon; see the module's docstring."""
    src = Path(source)
    name = src.name.lower()
    report: list[str] = []
    st = None if start is None else np.asarray(start, dtype=np.float64)
    if not (spacing > 0 and smooth_mm >= 0 and voxel_mm > 0):
        raise BhrError("--spacing and --voxel must be greater than 0 mm and --smooth at least 0 mm")
    check_source(src, centerline)
    sections_raw: list[str] | None = None
    mesh = None
    dist_fn: Any = None
    if name.endswith(SEGMENTATION_SUFFIXES):
        nib = _need("nibabel")
        try:
            img = nib.load(str(src))
            shape = tuple(int(v) for v in img.shape)
            aff = np.asarray(img.affine, dtype=np.float64)
        except Exception as exc:  # nibabel raises many kinds for a file that is not NIfTI
            raise BhrError(f"{src}: not a readable NIfTI image ({(str(exc).splitlines() or ['?'])[0][:120]})") from None
        if len(shape) != 3:
            raise BhrError(f"{src}: a segmentation must be a 3-D label image, got {len(shape)} dimensions")
        # the header's size, before any voxel is read: a few kB of .nii.gz can claim gigabytes of voxels
        if math.prod(shape) > MAX_SEGMENTATION_VOXELS:
            raise BhrError(f"{src}: {' x '.join(map(str, shape))} voxels, more than the {MAX_SEGMENTATION_VOXELS:,} a "
                           "segmentation may have; crop it to the colon")
        if not np.isfinite(aff).all() or abs(float(np.linalg.det(aff[:3, :3]))) < 1e-12 or \
                np.abs(aff[:3]).max() > 1e6:
            raise BhrError(f"{src}: the image's voxel-to-mm transform (its affine) is not a finite, invertible one "
                           "within +-1e6 mm; fix the NIfTI header's sform/qform and pixdim")
        try:
            data = np.asarray(img.dataobj)
        except Exception as exc:  # a truncated or damaged image
            raise BhrError(f"{src}: not a readable NIfTI image ({(str(exc).splitlines() or ['?'])[0][:120]})") from None
        if data.dtype.kind not in "biuf" or data.shape != shape:
            raise BhrError(f"{src}: a segmentation must hold whole-number labels, got {data.dtype} values")
        if label is None:
            present = sorted(int(v) for v in np.unique(data) if v != 0 and v == v)
            if len(present) != 1:
                raise BhrError(f"{src}: labels {', '.join(map(str, present[:10]))} present; choose the colon's "
                               "with --label N")
            label = present[0]
        mask = data == label
        if not mask.any():
            present = sorted(int(v) for v in np.unique(data) if v != 0 and v == v)
            raise BhrError(f"{src}: no voxel has label {label}; labels present: {', '.join(map(str, present[:10]))}")
        # only the label's box is worked on (skeleton, distances, surface): a small colon in a large image is fast
        used = [np.flatnonzero(mask.any(axis=tuple(b for b in range(3) if b != a))) for a in range(3)]
        lo_i, hi_i = np.array([u[0] for u in used]), np.array([u[-1] for u in used])
        box = hi_i - lo_i + 1
        if math.prod(int(v) for v in box) > MAX_MASK_VOXELS:
            raise BhrError(f"{src}: label {label} spans {' x '.join(map(str, box))} voxels, too many to skeletonise "
                           f"(at most {MAX_MASK_VOXELS:,}); resample the segmentation to larger voxels")
        # a margin of background kept around it: the distances and the smoothed surface are those of the whole image
        lo_i = np.maximum(lo_i - 6, 0)
        hi_i = np.minimum(hi_i + 6, np.array(shape) - 1)
        mask = np.ascontiguousarray(mask[lo_i[0]:hi_i[0] + 1, lo_i[1]:hi_i[1] + 1, lo_i[2]:hi_i[2] + 1])
        del data
        shift = np.eye(4)
        shift[:3, 3] = lo_i
        aff = aff @ shift  # the box's voxel indices to mm
        vx, vy, vz = (float(v) for v in np.linalg.norm(aff[:3, :3], axis=0))
        voxel = (vx, vy, vz)
        report.append(f"segmentation: {src.name}, label {label}, {int(mask.sum())} voxels of "
                      f"{' x '.join(f'{v:g}' for v in voxel)} mm")

        def to_world(p_mm: np.ndarray) -> np.ndarray:
            ijk = p_mm / np.array(voxel)
            return ijk @ aff[:3, :3].T + aff[:3, 3]

        inv = np.linalg.inv(aff)
        st_idx = None if st is None else (st @ inv[:3, :3].T + inv[:3, 3]) * np.array(voxel)
        raw = to_world(_mask_skeleton(mask, voxel, report, st_idx))
        from scipy.ndimage import distance_transform_edt

        edt = distance_transform_edt(mask, sampling=voxel)

        def dist_fn(pts: np.ndarray) -> np.ndarray:
            from scipy.ndimage import map_coordinates

            ijk = (pts @ inv[:3, :3].T + inv[:3, 3]).T
            return map_coordinates(edt, ijk, order=1, mode="nearest")

        from bhr.model._wallmesh import have_vtk

        if have_vtk():
            mesh = mask_surface(mask, aff, report)
        else:
            from bhr._settings.extras import install_command

            report.append(f"surface: none (needs vtk: {install_command('anatomy')}); runs use the tube")

        how = "twice the distance from each point to the label's boundary (Euclidean distance transform, mm)"
    elif name.endswith(MESH_SUFFIXES):
        _need("vtk")
        from bhr.model._wallmesh import read_mesh

        mesh = read_mesh(src)
        report.append(f"surface: {src.name}, {mesh.GetNumberOfCells()} triangles, read as mm")
        if centerline is not None:
            from bhr.model._pathfile import check_points, read_points_csv

            raw, _, lines, sections_raw = read_points_csv(Path(centerline))
            check_points(raw, lines, str(centerline))
            report.append(f"centerline: given, {Path(centerline).name}, {len(raw)} points"
                          + (", with sections" if sections_raw is not None else ""))
        else:
            mask, lo = _voxelise(mesh, voxel_mm)
            if not mask.any():
                raise BhrError(f"{src}: the surface encloses no voxel of {voxel_mm:g} mm; is it a closed surface "
                               "in mm?")
            raw = _mask_skeleton(mask, (voxel_mm,) * 3, report, None if st is None else st - lo) + lo
        dist_fn = None
        how = "twice the distance from each point to the surface (vtk's exact distance)"
    else:
        raise BhrError(f"{src}: give a surface mesh ({', '.join(MESH_SUFFIXES)}) or a segmentation "
                       f"({', '.join(SEGMENTATION_SUFFIXES)})")
    if sections_raw is None:
        raw = _orient(raw, st, report)
    dense, arc = resample_arc(raw, spacing)
    sections = None
    if sections_raw is not None:
        lab = np.array(sections_raw, dtype=object)
        s = np.arange(dense.shape[0]) * spacing
        keep = np.concatenate([[True], np.linalg.norm(np.diff(raw, axis=0), axis=1) > 1e-9])
        sections = list(lab[keep][np.clip(np.searchsorted(arc, s, side="right") - 1, 0, len(arc) - 1)])
    pts = smooth_path(dense, spacing, smooth_mm)
    report.append(f"smoothing: Gaussian of {smooth_mm:g} mm along the path, ends held; resampling: every "
                  f"{spacing:g} mm, {len(pts)} points, {float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()):.1f} "
                  "mm long")
    d = _mesh_distance(mesh, pts) if dist_fn is None else dist_fn(pts)
    lumen = np.maximum(2.0 * d, 0.01)
    report.append(f"lumen: {how}; {lumen.min():.1f}-{lumen.max():.1f} mm, median {float(np.median(lumen)):.1f} mm")
    if len(pts) < 2:
        raise BhrError(f"{src}: the centerline is shorter than {spacing:g} mm; nothing to follow")
    if not math.isfinite(float(lumen.sum())):
        raise BhrError(f"{src}: the lumen could not be measured")
    if mesh is not None:
        from bhr.model._wallmesh import MIN_INSIDE, enclosed_share

        share = enclosed_share(mesh, pts)
        report.append(f"wall: the surface encloses {100 * share:.0f} % of the centerline; " + (
            "runs measure the clearance against it" if share >= MIN_INSIDE else
            f"under the {100 * MIN_INSIDE:.0f} % of a surface around the lumen (a surface of the wall's tissue, or an "
            "open one), runs measure it against the tube of the lumen diameters"))
    return Imported(pts, lumen, sections, mesh, report)
