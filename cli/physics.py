"""bhr physics: replay a run in MuJoCo against the colon wall (contact forces, deviation from bhr's pose)."""
from __future__ import annotations

from pathlib import Path

import click

from bhr.cli._common import guarded
from bhr.cli._options import force_option, physics_options

#: What bhr physics writes into its folder.
PHYSICS_NAMES = ("physics.json", "force.png", "view.html", "manifest.json")


@click.command()
@click.argument("run", metavar="RUN.json")
@click.option("--out", "out_dir", default=None, metavar="DIR",
              help="Folder for physics.json, force.png, view.html [./bhr-out/physics-<run's folder>-<hash of the run "
                   "and the options>/; needed when RUN.json is '-'].")
@force_option
@physics_options
@guarded
def physics(run, out_dir, force, wall_stiffness, physics_rate, substeps):
    """Replay a run (run.json of `bhr follow`, with a lumen and codes) in MuJoCo against the colon wall.

    Writes DIR/physics.json (per step the largest contact force in N, where, and the deviation from bhr's
    pose in mm; a summary), DIR/force.png and DIR/view.html. Example:

    \b
        bhr physics bhr-out/latest/run.json
    """
    from bhr.output.atomic import write_json
    from bhr.cli._progress import status
    from bhr.run.driver import load_run
    from bhr.settings.errors import BhrError
    from bhr.settings.options import BY_NAME

    if run != "-" and not Path(run).exists():  # a folder, FIFO or device is load_run's to name
        from bhr.settings.inputs import latest_note

        raise BhrError(f"{run}: no such run file{latest_note(Path(run))}; give the run.json that 'bhr follow' wrote")
    opts = {"wall_stiffness": BY_NAME["wall_stiffness"].default if wall_stiffness is None else wall_stiffness,
            "rate": BY_NAME["physics_rate"].default if physics_rate is None else physics_rate,
            "substeps": BY_NAME["substeps"].default if substeps is None else substeps}
    if out_dir is None and run == "-":
        raise BhrError("give --out DIR for a run read from standard input (the default folder is named by the run's "
                       "file)")
    from bhr.cli._common import default_output, input_files, point_latest_if_default

    # as every command's: --out, or bhr-out/physics-<the run's folder>-<hash of the run's file and the options>
    source = Path(run).resolve()
    readable = f"physics-{source.parent.name if source.name == 'run.json' else source.stem}"
    folder = default_output("physics", readable, (sorted(opts.items()),), input_files(run), PHYSICS_NAMES, out_dir,
                            force=force)
    from bhr.studies.physics import check_replay_options, force_figure, replay_physics, require

    check_replay_options(**opts)
    result = load_run(run)

    require("mujoco")
    with status(f"replaying {result.steps} steps in MuJoCo", log=True):
        rep = replay_physics(result, **opts)
    from bhr.output.plots import save_figure
    from bhr.output.view import save_view

    with folder:
        write_json(folder.path("physics.json"), rep.to_dict())
        save_figure(force_figure(rep, f"{result.trajectory.name}: {result.solver} solver, MuJoCo replay"),
                    folder.path("force.png"))
        save_view(result, folder.stage, contacts=rep.contacts)
    point_latest_if_default(folder, out_dir)
    s = rep.summary()
    out = folder.final("")
    where = f" at step {s['max_force_step']}" if s["max_force_step"] else ""
    click.echo(f"largest contact force {s['max_force_n']:.2f} N{where}; contact at {len(s['contact_steps'])} of "
               f"{s['steps']} steps; largest deviation from bhr's pose {s['max_deviation_mm']:.3f} mm; "
               f"{s['cpu_s']:.1f} s CPU")
    click.echo(f"Wrote {out / 'physics.json'}, {out / 'force.png'}, {out / 'view.html'}")
