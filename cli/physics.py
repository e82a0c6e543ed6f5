"""bhr physics: the physical robot of a run against the colon wall (the wall's load, stretch, reaching the cecum)."""
from __future__ import annotations

from pathlib import Path

import click

from bhr.cli._common import guarded
from bhr.cli._options import force_option, physics_options

#: What bhr physics writes into its folder.


@click.command()
@click.argument("run", metavar="RUN.json")
@click.option("--out", "out_dir", default=None, metavar="DIR",
              help="Folder for physics.json, force.png, view.html [./bhr-out/physics-<run's folder>-<hash of the run "
                   "and the options>/; needed when RUN.json is '-'].")
@force_option
@physics_options
@guarded
def physics(run, out_dir, force, wall_stiffness, wire_force, feeder_force, substeps, max_wall_force, passive_modules,
            passive_rigidity):
    """Replay a run (run.json of `bhr follow`, with a lumen and codes) as the physical robot: rigid modules, joints
    held by their wires, the feeder pushing the rear end, against the colon's wall.

    Reads poses.npz beside RUN.json when there is one, else the run's codes at every step. Writes DIR/physics.json
    (per step the wall's load in N, per module, the largest pressure, the stretch; a summary), DIR/force.png and
    DIR/view.html. Example:

    \b
        bhr physics bhr-out/latest/run.json
    """
    from bhr.output._atomic import write_json
    from bhr.cli._progress import status
    from bhr._run.driver import load_run
    from bhr._settings.errors import BhrError
    from bhr._settings.options import BY_NAME

    if run != "-" and not Path(run).exists():  # a folder, FIFO or device is load_run's to name
        from bhr._settings.inputs import latest_note

        raise BhrError(f"{run}: no such run file{latest_note(Path(run))}; give the run.json that 'bhr follow' wrote")
    given = {"wall_stiffness": wall_stiffness, "wire_force": wire_force, "feeder_force": feeder_force,
             "substeps": substeps, "max_wall_force": max_wall_force, "passive_modules": passive_modules,
             "passive_rigidity": passive_rigidity}
    opts = {k: BY_NAME[k].default if v is None else BY_NAME[k].check(v, "physics") for k, v in given.items()}
    for k, v in opts.items():
        if not (v >= 0 if BY_NAME[k].nonneg else v > 0):
            raise BhrError(f"--{k.replace('_', '-')} must be {'0 or more' if BY_NAME[k].nonneg else 'greater than 0'}, "
                           f"got {v:g}")
    from bhr._studies.physics import check_wall_stiffness

    check_wall_stiffness(float(opts["wall_stiffness"]))
    if out_dir is None and run == "-":
        raise BhrError("give --out DIR for a run read from standard input (the default folder is named by the run's "
                       "file)")
    from bhr.cli._common import default_output, input_files, point_latest_if_default

    source = Path(run).resolve()
    readable = f"physics-{source.parent.name if source.name == 'run.json' else source.stem}"
    folder = default_output("physics", readable, (sorted(opts.items()),), input_files(run), out_dir,
                            force=force)
    from bhr._studies.physics import replay_physics

    result = load_run(run)
    from bhr.cli._progress import announce_compiles

    announce_compiles()  # the run is read: a first compile says so
    with status(f"replaying the poses of {result.steps} steps against the wall (poses done/all)", log=True) as bar:
        rep = replay_physics(result, None if run == "-" else run, progress=bar.set, **opts)
    from bhr.output._physics_plot import force_figure
    from bhr.output._figure import save_figure
    from bhr.output._view import save_view

    with folder:
        write_json(folder.path("physics.json"), rep.to_dict())
        save_figure(force_figure(rep, f"{result.trajectory.name}: {result.solver} solver, the physical robot"),
                    folder.path("force.png"))
        save_view(result, folder.stage, contacts=rep.contacts_by_step(result.steps))
    point_latest_if_default(folder, out_dir)
    s = rep.summary()
    out = folder.final("")
    where = f" at step {s['max_total_force_step']}" if s["max_total_force_step"] else ""
    if not s["max_total_force_equilibrium_reached"]:
        where += (" (an estimate: that pose's equilibrium was not reached within the iteration limit; "
                  f"{s['equilibria_not_reached']} of {s['equilibria']} were not)")
    reach = (f"tip at the cecum from step {s['reached_cecum_step']}" if s["reached_cecum_step"] else
             "tip never at the cecum")
    click.echo(f"wall load at most {s['max_total_force_n']:.2f} N{where} (one module {s['max_module_force_n']:.2f} N, "
               f"{s['max_pressure_kpa']:.0f} kPa); wall pushed out {s['max_stretch_mm']:.1f} mm at most; {reach}; "
               f"{'traversed' if s['traversed'] else 'not traversed'} (at most {s['max_wall_force_n']:g} N); "
               f"{s['cpu_s']:.1f} s CPU{_idealised(s)}")
    click.echo(f"Wrote {out / 'physics.json'}, {out / 'force.png'}, {out / 'view.html'}")


def _idealised(summary: dict) -> str:
    """What the line must say when the replay did not follow every pose of the robot's motion."""
    from bhr.output._physics_plot import STEPS_IDEALISATION

    if summary.get("poses_replayed") != "steps":
        return ""
    return (f"; {STEPS_IDEALISATION} (its {summary['steps']} steps; the wires' own motion between them is not kept: "
            "bhr follow --all-poses keeps it)")
