"""bhr workspace: every reachable tip of a binary robot (or a Monte Carlo sample), a figure and the indices."""
from __future__ import annotations

import json

import click

from bhr.cli._common import check_writable, guarded
from bhr.cli._options import build_robot, robot_options


@click.command()
@robot_options(feed=False, solving=False)
@click.option("--no-lift", "no_lift", is_flag=True, help="Modules only rest or tilt (5 codes each, not 6).")
@click.option("--samples", type=int, default=None, metavar="N",
              help="Draw N random poses (Monte Carlo) instead of all of them; the default when there are more "
                   "than 2,000,000 poses (then 1,000,000 samples).")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the random poses.")
@click.option("--voxel", type=float, default=None, metavar="MM",
              help="Edge of the cells of the volume and density, mm (default a fifth of a module length).")
@click.option("--plot", "plot_path", default=None, metavar="PATH",
              help="The figure (.png, .svg or .pdf): the reachable tips and their density. Default "
                   "bhr-out/workspace-<modules>x<length>mm-<alpha>deg[-nolift].png, named by its settings.")
@click.option("--no-plot", "no_plot", is_flag=True, help="Print the indices only.")
@click.option("--json", "json_path", default=None, metavar="PATH|-", help="Write the indices as JSON.")
@guarded
def workspace(no_lift, samples, seed, voxel, plot_path, no_plot, json_path, **kwargs):
    """Every reachable tip of a binary robot of a few modules, exactly, or a density estimate for longer ones.

    Each module rests, tilts by alpha about one of its two axes (either sign) or lifts: 6**n poses
    (5**n with --no-lift), all computed up to 2,000,000; beyond, a Monte Carlo sample. Prints the
    indices (distinct tips, reach, volume, resolution, density) and draws the figure.

    Example: bhr workspace --modules 6 --alpha 20 --plot bhr-out/workspace6.png
    """
    from bhr.cli._progress import announce_compiles
    from bhr.model._workspace import EXACT_LIMIT, workspace as compute
    from bhr.output._atomic import write_json

    check_writable(json_path, "JSON")
    robot = build_robot(kwargs)
    if not no_plot and plot_path is None:
        from pathlib import Path

        plot_path = (f"bhr-out/workspace-{robot.modules}x{robot.module_length:g}mm-{robot.alpha:g}deg"
                     f"{'-nolift' if no_lift else ''}{'' if samples is None else f'-{samples}samples-seed{seed}'}.png")
        Path(plot_path).parent.mkdir(parents=True, exist_ok=True)
    if not no_plot:
        check_writable(plot_path, "plot")
        from bhr.output._workspace_plot import check_path

        check_path(plot_path)
    lift = not no_lift
    poses = (5 if no_lift else 6) ** robot.modules
    exact = samples is None and poses <= EXACT_LIMIT
    announce_compiles()
    ws = compute(robot, lift=lift, exact=exact, samples=1_000_000 if samples is None else samples, seed=seed,
                 voxel=voxel)
    ix = ws.indices()
    if json_path == "-":
        click.echo(json.dumps(ix, indent=1))
    else:
        if json_path:
            write_json(json_path, ix)
        how = (f"all {ix['poses']:,} poses" if ws.exact
               else f"{ix['evaluated_poses']:,} random poses of {ix['poses']:.4g} (Monte Carlo, seed {seed})")
        rows = [
            ("poses", how),
            ("distinct tips", f"{ix['distinct_tips']:,}"),
            ("distinct tip directions", f"{ix['distinct_tip_directions']:,}"),
            ("reach (base to tip)", f"{ix['reach_min_mm']:.4g} to {ix['reach_max_mm']:.4g} mm"),
            ("largest tip bend", f"{ix['tip_bend_max_deg']:.4g} deg"),
            ("volume (cells holding a tip)", f"{ix['volume_mm3']:.4g} mm^3 ({ix['occupied_voxels']:,} cells of "
                                             f"{ix['voxel_mm']:g} mm)"),
            ("poses per occupied cell", f"{ix['poses_per_voxel_mean']:.4g} on average, at most "
                                        f"{ix['poses_per_voxel_max']:,}"),
            ("resolution (gap to the nearest other tip)", f"median {ix['resolution_median_mm']:.3g} mm, worst "
                                                          f"{ix['resolution_worst_mm']:.3g} mm"),
        ]
        click.echo(f"Workspace of {ws.modules} modules of {robot.module_length:g} mm, alpha {robot.alpha:g} deg "
                   f"({'with' if lift else 'without'} the lift):")
        width = max(len(k) for k, _ in rows)
        for k, v in rows:
            click.echo(f"  {k:<{width}}  {v}")
        if not ws.exact:
            click.echo("  (sampled: the robot's volume is at least this, its resolution at most this gap)")
    if not no_plot:
        from bhr.output._workspace_plot import save, workspace_figure

        save(workspace_figure(ws), plot_path)
        if json_path != "-":
            click.echo(f"Figure: {plot_path}")
