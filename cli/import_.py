"""bhr import: a colon's surface mesh (with or without its centerline) or labelled segmentation -> a trajectory."""
from __future__ import annotations

import click

from bhr.cli._common import guarded


def _start(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    from bhr._settings.errors import BhrError

    parts = text.replace(";", ",").split(",")
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        vals = ()
    if len(vals) != 3 or not all(abs(v) < 1e6 for v in vals):
        raise BhrError(f"--start must be three numbers in mm, X,Y,Z (the anus), got {text!r}")
    return vals  # type: ignore[return-value]


@click.command(name="import")
@click.argument("source", metavar="MESH|SEGMENTATION")
@click.option("--centerline", default=None, metavar="FILE.csv",
              help="The colon's centerline (x,y,z[,section] in mm, anus first) [extracted from the surface].")
@click.option("--label", type=int, default=None, metavar="N",
              help="The colon's label in a segmentation [its only one].")
@click.option("--start", "start", default=None, metavar="X,Y,Z",
              help="Near the anus (mm): the extracted path starts at its end nearest this [its lower end].")
@click.option("--smooth", "smooth_mm", type=float, default=3.0, show_default=True, metavar="MM",
              help="Gaussian smoothing along the path (standard deviation, mm); 0: none.")
@click.option("--spacing", type=float, default=1.0, show_default=True, metavar="MM",
              help="Distance between the written points (mm).")
@click.option("--voxel", "voxel_mm", type=float, default=1.0, show_default=True, metavar="MM",
              help="Voxel size for extracting a mesh's centerline (mm).")
@click.option("--out", "out_path", default=None, metavar="FILE.csv",
              help="The trajectory file to write; the surface goes beside it as FILE.vtp [SOURCE's name .csv].")
@guarded
def import_(source, centerline, label, start, smooth_mm, spacing, voxel_mm, out_path):
    """Turn a colon's surface mesh (.vtp .vtk .stl .ply .obj), with its centerline or without, or a labelled
    segmentation (.nii, .nii.gz), into a trajectory file for --traj: the centerline with the lumen diameter at
    every point, its sections (from a given centerline's section column), and the surface beside it, which the
    clearance is then measured against. Prints what was done (centerline extraction and branch selection,
    direction, smoothing, resampling, lumen); the same lines head the CSV. Needs the anatomy extra.

    \b
        bhr import colon.stl --start 0,0,0 --out bhr-out/my-colon.csv
        bhr follow --traj bhr-out/my-colon.csv --solver lumen
    """
    from pathlib import Path

    from bhr.cli._common import check_writable
    from bhr.model._importer import SEGMENTATION_SUFFIXES, check_source, import_colon
    from bhr.output._atomic import atomic_path, write_text
    from bhr._settings.errors import BhrError

    src = Path(source)
    check_source(src, centerline)  # before --out, which is named after it (/dev/null is a device, not a name)
    stem = src.name
    for suf in (*SEGMENTATION_SUFFIXES, src.suffix):
        if suf and stem.lower().endswith(suf):
            stem = stem[: -len(suf)]
            break
    out = Path(out_path) if out_path is not None else Path(f"{stem}.csv")
    if out.suffix.lower() != ".csv":
        raise BhrError(f"--out must be a .csv trajectory file, got {out}")
    if out.resolve() == src.resolve():
        raise BhrError(f"--out {out} is the source itself; choose another file")
    check_writable(out, "trajectory file")
    res = import_colon(src, centerline=centerline, label=label, start=_start(start), smooth_mm=smooth_mm,
                       spacing=spacing, voxel_mm=voxel_mm)
    write_text(out, res.csv_text(f"Colon imported by bhr import from {src.name}."))
    written = [str(out)]
    beside = out.with_suffix(".vtp")
    if res.mesh is not None:
        from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

        with atomic_path(beside) as tmp:
            w = vtkXMLPolyDataWriter()
            w.SetFileName(str(tmp))
            w.SetInputData(res.mesh)
            w.SetDataModeToBinary()
            w.SetCompressorTypeToZLib()
            if not w.Write():
                raise BhrError(f"cannot write {beside}")
        written.append(str(beside))
    for line in res.report:
        click.echo(line)
    click.echo(f"Wrote {', '.join(written)}; follow it with: bhr follow --traj {out}")
