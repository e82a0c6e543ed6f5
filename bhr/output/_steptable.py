"""``steps.csv``: one row per step of a run, its errors and clearances, for a spreadsheet.

Columns: ``step``, the target ``target_x_mm`` ``target_y_mm`` ``target_z_mm``,
``iterations``, ``tip_error_mm``, ``max_point_error_mm``, ``tip_orientation_error_deg``,
``max_global_error`` (1 = at tolerance), each point's position error ``p1_error_mm`` (base)
... ``pN_error_mm`` (tip), each module's orientation error ``m1_orientation_error_deg`` ...,
and when the path has a lumen ``min_clearance_mm`` (empty where nothing is scored yet)
and ``wall_touched`` (0/1). A whole-body run adds ``body_max_error_mm``; a path with anatomical
sections (a real colon's landmarks) adds ``section``, the section of the step's target. Numbers are
the run's own (run.json's), written with 6 decimals.
"""
from __future__ import annotations

import csv
import io
import math
import os
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult

__all__ = ["STEPS_CSV", "format_steps_csv", "write_run_files"]

#: The file name bhr follow writes next to run.json.
STEPS_CSV = "steps.csv"


def _num(v: float) -> str:
    return f"{v:.6f}" if math.isfinite(v) else ""


def format_steps_csv(result: "FollowResult") -> str:
    """The text of ``steps.csv`` for ``result`` (see the module's docstring for the columns)."""
    n = result.robot.modules
    head = ["step", "target_x_mm", "target_y_mm", "target_z_mm", "iterations", "tip_error_mm",
            "max_point_error_mm", "tip_orientation_error_deg", "max_global_error"]
    head += [f"p{j}_error_mm" for j in range(1, n + 2)]
    head += [f"m{j}_orientation_error_deg" for j in range(1, n + 1)]
    cl = result.clearance
    per = cl.per_step if cl is not None else None
    touched = set(cl.touch_steps) if cl is not None else set()
    if per is not None:
        head += ["min_clearance_mm", "wall_touched"]
    body = result.body if result.body is not None and result.body.modules else None
    if body is not None:
        head.append("body_max_error_mm")
    sections = getattr(result.trajectory, "sections", ())
    if sections:
        head.append("section")
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(head)
    steps = result.steps
    pe, oe, ge = result.point_errors_mm[:steps], result.orientation_errors_deg[:steps], result.global_errors[:steps]
    # each column formatted from Python floats (one tolist per array), the row maxima taken by numpy as before
    targets = _texts(result.targets[:steps])
    iterations = [str(v) for v in np.asarray(result.iterations[:steps]).astype(np.int64).tolist()]
    pe_text, oe_text = _texts(pe), _texts(oe)
    pe_max, ge_max = _texts(pe.max(axis=1)), _texts(ge.max(axis=1))
    per_text = _texts(per[:steps]) if per is not None else None
    body_max = _texts(body.point_errors_mm[:steps].max(axis=1)) if body is not None else None
    for i in range(steps):
        pe_i, oe_i = pe_text[i], oe_text[i]
        row = [str(i + 1), *targets[i], iterations[i], pe_i[-1], pe_max[i], oe_i[-1], ge_max[i], *pe_i, *oe_i]
        if per_text is not None:
            row += [per_text[i], "1" if i + 1 in touched else "0"]
        if body_max is not None:
            row.append(body_max[i])
        if sections:
            row.append(result.trajectory.section_at(i) or "")
        w.writerow(row)
    return buf.getvalue()


def _texts(a: np.ndarray) -> list:
    """:func:`_num` of every value of ``a``, nested as ``a`` is (one conversion to Python floats)."""
    values = np.asarray(a, dtype=np.float64).tolist()
    if np.ndim(a) == 1:
        return [_num(v) for v in values]
    return [[_num(v) for v in row] for row in values]


def write_run_files(result: "FollowResult", out_dir: "str | os.PathLike[str]") -> None:
    """Write a run's files into ``out_dir``, as ``bhr follow`` does.

    ``run.json`` (``bhr replay``), the per-step table ``steps.csv`` and, for binary solvers,
    ``codes.csv`` (``bhr plan``, ``bhr stream``).

    A robot moved by its wires also gets ``poses.npz``, every pose it went through (docs/locomotion.md).
    Each file appears whole or not at all.

    Parameters
    ----------
    result : FollowResult
        A run, as :func:`bhr.follow` returns it.
    out_dir : str or os.PathLike
        An existing folder to write the files into.
    """
    from pathlib import Path

    from bhr.model._codes import format_codes_csv
    from bhr.output._atomic import write_json, write_text

    out = Path(out_dir)
    write_json(out / "run.json", result.to_dict())
    write_text(out / STEPS_CSV, format_steps_csv(result))
    codes = result.board_codes
    if codes is not None:
        write_text(out / "codes.csv", format_codes_csv(codes))
    if getattr(result, "motion", None) is not None and result.motion.kept:
        write_poses(result, out / "poses.npz")


def write_poses(result: "FollowResult", path: "str | os.PathLike[str]") -> None:
    """``poses.npz``: every pose of a whole robot moved by its wires (docs/locomotion.md, "Every pose"): ``t_s``,
    ``insertion_mm``, ``points_mm`` (tail first), ``tilts_rad``, ``codes``, ``step`` (1-based), as float64/int64."""
    import numpy as np

    with open(path, "wb") as fh:
        np.savez_compressed(fh, **result.motion.npz())
