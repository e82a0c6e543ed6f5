"""bhr follow: follow a trajectory with follow-the-leader and write errors, plots and codes."""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import click

from bhr.cli._common import check_writable, guarded
from bhr.cli._options import (build_robot, constraint_options, pop_constraints, pop_trajectory, robot_options,
                              trajectory_options)


def summary_lines(result) -> list[str]:
    """The summary table the thesis's script prints: per point and module, max/mean/median/final."""
    s = result.summary()
    r = result.robot
    lines = [
        f"{s['trajectory']}: {s['steps']} steps, solver {s['solver']}, {r.modules} modules x {r.module_length:g} mm, "
        f"alpha {r.alpha:g} deg, feed {r.feed:g} mm",
    ]
    head = f"{'':<22}{'max':>9}{'at step':>9}{'mean':>9}{'median':>9}{'final':>9}"

    def block(title: str, rows: list[dict], label: str, count: int) -> None:
        lines.append("")
        lines.append(title)
        lines.append(head)
        for j, st in enumerate(rows):
            name = f"{label} {j + 1}" + (" (base)" if j == 0 else "") + (" (tip)" if j == count - 1 else "")
            lines.append(f"  {name:<20}{st['max']:>9.3f}{st['worst_step']:>9d}{st['mean']:>9.3f}"
                         f"{st['median']:>9.3f}{st['final']:>9.3f}")

    block("Position error (mm)", s["points"], "point", len(s["points"]))
    block("Orientation error (deg)", s["modules"], "module", len(s["modules"]))
    block("Global error (1 = at tolerance)", s["global"], "module", len(s["global"]))
    lines.append("")
    lines.append(f"Worst step: {s['points_worst_step']} (largest point error {s['points_max_error_mm']:.3f} mm); "
                 f"tip ends {s['tip_final_error_mm']:.4f} mm and {s['tip_orientation_final_deg']:.3f} deg off.")
    return lines


@click.command()
@click.option("--traj", required=True, metavar="NAME|PATH",
              help="line, curve, spiral, colon, or a trajectory file (.toml).")
@trajectory_options
@click.option("--solver", default="seed", show_default=True, help="seed, constrained, fabrik, ccd, optimal.")
@robot_options(feed=True)
@constraint_options
@click.option("--out", "out_dir", default=None, metavar="DIR",
              help="Output folder [./bhr-out/<traj>-<solver>/].")
@click.option("--json", "json_path", default=None, metavar="PATH|-",
              help="Where to write the run as JSON ('-': stdout) [DIR/run.json].")
@click.option("--no-plots", is_flag=True, help="Skip the PNG figures.")
@guarded
def follow(traj, solver, out_dir, json_path, no_plots, **kwargs):
    """Follow a trajectory with follow-the-leader and report the errors.

    Writes into DIR the position, orientation and global error figures, a
    view of the path with the final pose, codes.csv (one row of module codes
    per step) and run.json, and prints a summary table. Defaults are the
    thesis's robot: 5 modules of 10 mm, alpha 10 deg, tolerances 8 mm and
    20 deg, feed 2 mm.

        bhr follow --traj curve --radius 70 --angle 360
    """
    from bhr.atomic import write_json, write_text
    from bhr.codes import format_codes_csv
    from bhr.follow import BhrWarning, follow as run_follow
    from bhr.trajectory import load_trajectory

    robot = build_robot(kwargs)
    constraints = pop_constraints(kwargs)
    traj_params = pop_trajectory(kwargs)
    tr = load_trajectory(traj, feed=robot.feed, **traj_params)
    stem = Path(traj).stem if traj not in ("line", "curve", "spiral", "colon") else traj
    out = Path(out_dir) if out_dir else Path("bhr-out") / f"{stem}-{solver}"
    check_writable(out / "run.json", "output folder")
    check_writable(json_path, "JSON")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BhrWarning)
        result = run_follow(tr, solver=solver, robot=robot, solver_options=constraints)
    for w in caught:
        if issubclass(w.category, BhrWarning):
            click.echo(f"Warning: {w.message}", err=True)
    doc = result.to_json()
    written = []
    if result.codes is not None:
        write_text(out / "codes.csv", format_codes_csv(result.codes))
        written.append(out / "codes.csv")
    if json_path == "-":
        click.echo(json.dumps(doc))
    else:
        jp = Path(json_path) if json_path else out / "run.json"
        write_json(jp, doc)
        written.append(jp)
    if not no_plots:
        from bhr.plots import save_run_plots

        written += save_run_plots(result, out)
    stream = json_path == "-"
    for line in summary_lines(result):
        click.echo(line, err=stream)
    click.echo("Wrote " + ", ".join(str(p) for p in written), err=stream)
