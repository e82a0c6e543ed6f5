"""Write the shipped real colons, trajectories/gca/*, from the GCA-Models large intestines (docs/real_colons.md).

    python docs/examples/make_gca.py [GCA-Models folder]      (needs vtk: the anatomy extra)

The folder is a copy of the public repository Comparative-Pathology/GCA-Models (CC BY 4.0; Burger et al.,
BMC Med Inform Decis Mak 2023, doi 10.1186/s12911-023-02111-9), default ../shared/data/GCA-Models. For each
model it reads the large intestine's midline path (Paths/large_intestine_path.jsn) and its closed surface
(Surfaces/, or the union of the landmark-bounded SegmentedSurfaces where the whole surface is absent), and writes

* NAME.csv: the centerline from the anus to the appendix orifice, points 1 mm apart, in mm, the anus at the
  origin; the lumen diameter at each point (twice the distance from the point to the surface); the section
  of each point, bounded by the model's landmarks;
* NAME.vtp: the surface, decimated, in the same frame (mm), for the clearance against the real wall.

Landmark positions (indices into the path's points) and voxel sizes are those of each model's configuration
file in that repository (EdinGCA_3D_00020_1_14.json and so on), copied here as LANDMARKS and VOXEL_MM.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent.parent.parent
OUT = HERE / "trajectories" / "gca"

#: short name -> (model folder, what it is)
MODELS = {
    "E20": ("EdinGCA_3D_00020", "CT of an inflated colon with contrast agent (Edinburgh GCA model 20)"),
    "E60": ("EdinGCA_3D_00060", "CT of a colon neither inflated nor contrasted (Edinburgh GCA model 60)"),
    "E90": ("EdinGCA_3D_00090", "CT of a colon not inflated, contrast in the small intestine, diverticular "
                                "disease (Edinburgh GCA model 90)"),
    "VHF": ("HuBMAPVHF_3D_00080", "the Visible Human female's large intestine (HuBMAP model, GCA model 80)"),
    "VHM": ("HuBMAPVHM_3D_00070", "the Visible Human male's large intestine (HuBMAP model, GCA model 70)"),
}
#: mm per unit of the path and surface coordinates along x, y, z ("voxel_size" of each configuration file;
#: the CT models are in voxels, the HuBMAP models in mm)
VOXEL_MM = {"E20": (0.808594, 0.808594, 0.7), "E60": (0.835938, 0.835938, 1.0), "E90": (0.832031, 0.832031, 1.0),
            "VHF": (1.0, 1.0, 1.0), "VHM": (1.0, 1.0, 1.0)}
#: landmark -> index of the path point ("landmarks" of each configuration file, large-intestine path)
LANDMARKS = {
    "E20": {"anus": 0, "DSJ": 1367, "SF": 2441, "HF": 3666, "ICVc": 4139, "AO": 4274, "AT": 4337},
    "E60": {"anus": 0, "DSJ": 910, "SF": 1247, "HF": 1381, "ICVc": 1549, "AO": 1606, "AT": 1624},
    "E90": {"anus": 0, "RSJ": 84, "DSJ": 323, "SF": 771, "HF": 1154, "CCJ": 1278, "ICVc": 1314, "AO": 1352,
            "AT": 1374},
    "VHF": {"anus": 0, "DSJ": 237, "SF": 500, "HF": 734, "ICVc": 832, "AO": 881, "AT": 903},
    "VHM": {"anus": 0, "DSJ": 423, "SF": 742, "HF": 1105, "ICVc": 1354, "AO": 1403, "AT": 1463},
}
#: the sections between landmarks (the path is cut at the appendix orifice: a robot goes no further)
SECTION_BOUNDS = [("rectum", "anus", "RSJ"), ("sigmoid", "RSJ", "DSJ"), ("rectum and sigmoid", "anus", "DSJ"),
                  ("descending", "DSJ", "SF"), ("transverse", "SF", "HF"), ("ascending", "HF", "ICVc"),
                  ("cecum", "ICVc", "AO")]
SPACING = 1.0  # mm between the shipped points
TARGET_TRIANGLES = 20000  # per decimated surface


def read_polydata(path: Path):
    import vtk

    r = vtk.vtkPolyDataReader()
    r.SetFileName(str(path))
    r.Update()
    return r.GetOutput()


def surface(folder: Path):
    """The large intestine's closed surface: Surfaces/, else the union of its segmented surfaces."""
    import vtk

    whole = sorted((folder / "Surfaces").glob("large*intestine*.vtk")) if (folder / "Surfaces").is_dir() else []
    if whole:
        pd = read_polydata(min(whole, key=lambda p: p.stat().st_size))  # the 20k-triangle one where two are given
        return pd, f"Surfaces/{whole[0].name if len(whole) == 1 else min(whole, key=lambda p: p.stat().st_size).name}"
    parts = sorted(p for p in (folder / "SegmentedSurfaces").glob("large*intestine*.vtk")
                   if "AO-TA" not in p.name and "AO-AT" not in p.name)
    app = vtk.vtkAppendPolyData()
    for p in parts:
        app.AddInputData(read_polydata(p))
    clean = vtk.vtkCleanPolyData()
    clean.SetInputConnection(app.GetOutputPort())
    clean.Update()
    return clean.GetOutput(), "SegmentedSurfaces/ (union of " + ", ".join(p.name for p in parts) + ")"


def scaled(pd, scale, origin):
    import vtk

    t = vtk.vtkTransform()
    t.PostMultiply()
    t.Scale(*scale)
    t.Translate(*(-origin))
    f = vtk.vtkTransformFilter()
    f.SetInputData(pd)
    f.SetTransform(t)
    f.Update()
    return f.GetOutput()


def decimate(pd, target):
    import vtk

    tri = vtk.vtkTriangleFilter()
    tri.SetInputData(pd)
    tri.Update()
    n = tri.GetOutput().GetNumberOfCells()
    if n <= target:
        return tri.GetOutput()
    d = vtk.vtkQuadricDecimation()
    d.SetInputData(tri.GetOutput())
    d.SetTargetReduction(1.0 - target / n)
    d.VolumePreservationOn()
    d.Update()
    return d.GetOutput()


def resample(pts: np.ndarray, spacing: float):
    """Points every ``spacing`` mm of arc length along the polyline, and each one's arc length."""
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    s = np.arange(0.0, arc[-1] + 1e-9, spacing)
    return np.stack([np.interp(s, arc, pts[:, k]) for k in range(3)], axis=1), s, arc


def distances(pd, pts: np.ndarray) -> np.ndarray:
    import vtk

    f = vtk.vtkImplicitPolyDataDistance()
    f.SetInput(pd)
    return np.array([f.EvaluateFunction(*map(float, p)) for p in pts])


def build(short: str, root: Path) -> dict:
    import vtk

    folder_name, what = MODELS[short]
    folder = root / folder_name
    raw = np.array(json.loads((folder / "Paths" / "large_intestine_path.jsn").read_text())["points"], dtype=float)
    scale = np.array(VOXEL_MM[short])
    lm = LANDMARKS[short]
    if lm["AT"] != len(raw) - 1:
        raise SystemExit(f"{short}: the path has {len(raw)} points, the landmarks end at {lm['AT']}")
    path_mm = raw * scale
    origin = path_mm[0].copy()
    path_mm = path_mm - origin
    cut = path_mm[:lm["AO"] + 1]
    pts, s, arc = resample(cut, SPACING)
    where = {k: float(arc[v]) for k, v in lm.items() if v <= lm["AO"]}
    sec = np.empty(len(pts), dtype=object)
    bounds = [(name, a, b) for name, a, b in SECTION_BOUNDS if a in where and b in where
              and not (name == "rectum and sigmoid" and "RSJ" in where)]
    for name, a, b in bounds:
        sec[(s >= where[a]) & (s <= where[b] + 1e-9)] = name
    surf0, surf_from = surface(folder)
    surf = scaled(surf0, scale, origin)
    dist = distances(surf, pts)
    small = decimate(surf, TARGET_TRIANGLES)
    dist_small = distances(small, pts)
    normals = vtk.vtkPolyDataNormals()
    normals.SetInputData(small)
    normals.ConsistencyOn()
    normals.AutoOrientNormalsOn()
    normals.SplittingOff()
    normals.ComputeCellNormalsOff()
    normals.Update()
    mesh = normals.GetOutput()
    lumen = 2.0 * np.abs(dist)
    outside = int(np.count_nonzero(dist > 0))
    OUT.mkdir(parents=True, exist_ok=True)
    w = vtk.vtkXMLPolyDataWriter()
    w.SetFileName(str(OUT / f"{short}.vtp"))
    w.SetInputData(mesh)
    w.SetDataModeToBinary()
    w.SetCompressorTypeToZLib()
    w.Write()
    length = float(s[-1])
    shares = {name: (where[b] - where[a]) / where["AO"] for name, a, b in bounds}
    head = [
        f"# Real colon gca:{short}: {what}.",
        "# From GCA-Models (Comparative-Pathology/GCA-Models, CC BY 4.0; Burger et al., BMC Med Inform Decis Mak "
        f"2023, doi 10.1186/s12911-023-02111-9), model {folder_name};",
        "# trajectories/gca/README.md says what was changed.",
        f"# Centerline anus (first point) to appendix orifice, {length:.1f} mm, points {SPACING:g} mm apart; "
        f"coordinates in mm ({' x '.join(f'{v:g}' for v in scale)} mm per source unit), the anus at the origin, "
        "axes as in the source.",
        f"# lumen = inner diameter (mm): twice the distance from the point to the surface {surf_from}; "
        f"{lumen.min():.1f}-{lumen.max():.1f} mm.",
        "# section: the anatomical section between the model's landmarks. Edit freely.",
        "# lumen_end: closed",
        "x,y,z,lumen,section",
    ]
    lines = [f"{x:.3f},{y:.3f},{z:.3f},{d:.2f},{n}" for (x, y, z), d, n in zip(pts, lumen, sec)]
    (OUT / f"{short}.csv").write_text("\n".join(head + lines) + "\n", encoding="utf-8")
    return {"name": short, "length": length, "lumen": (float(lumen.min()), float(np.median(lumen)), float(lumen.max())),
            "outside": outside, "shares": shares, "triangles": (surf.GetNumberOfCells(), mesh.GetNumberOfCells()),
            "decimation_change_mm": float(np.max(np.abs(dist_small - dist))), "surface": surf_from}


def main() -> None:
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent / "shared" / "data" / "GCA-Models"
    if not root.is_dir():
        root = Path("/work/shared/data/GCA-Models")
    for short in MODELS:
        info = build(short, root)
        print(json.dumps(info))


if __name__ == "__main__":
    main()
