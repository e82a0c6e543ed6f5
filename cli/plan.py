"""bhr plan: the schedule the actuator board can sustain for a codes.csv, and its procedure time."""
from __future__ import annotations

import sys
from pathlib import Path

import click

from bhr.cli._common import check_writable, guarded, refuse_replacing_beside
from bhr.cli._link import schedule_option, thermal_params
from bhr.cli._options import rate_type


@click.command()
@click.option("--codes", "codes_path", required=True, metavar="FILE",
              help="codes.csv as written by 'bhr follow' (header step,m1,...,mN).")
@click.option("--rate", default=10.0, show_default=True, metavar="HZ",
              type=rate_type(),
              help="Rows per second: the fixed rate to check, or the fastest an auto schedule may go.")
@schedule_option()
@click.option("--robot", "robot_file", default=None, metavar="FILE",
              help="Robot file whose [thermal] table describes the wires (docs/thermal.md) [the default wire].")
@click.option("--plot", "plot_path", default=None, metavar="FILE.png",
              help="Figure of each wire's temperature over the schedule [thermal-<schedule>-<rate>hz.png beside "
                   "FILE, named by its settings: thermal-auto-10hz.png].")
@click.option("--no-plots", "no_plot", is_flag=True, help="Skip the figure.")
@click.option("--csv", "csv_path", default=None, metavar="FILE",
              help="Write the whole schedule: step, send time (s), codes.")
@guarded
def plan(codes_path, rate, schedule, robot_file, plot_path, no_plot, csv_path):
    """Plan a stream of module codes against the thermal model of the wires.

    Prints the steps where the codes change with the time each is sent, and
    the total procedure time. With --schedule auto (the default) it stretches
    each step to what the wires allow (full-power contraction, relaxation
    before a wire contracts again), never faster than --rate; with --schedule
    rate it checks that the board can take the rows at --rate and, where it
    cannot, names the module, the step and the fix. The figure shows each wire's normalised temperature.

    \b
        bhr plan --codes bhr-out/latest/codes.csv
    """
    from bhr.model._codes import read_codes_csv

    steps, table = read_codes_csv(codes_path)  # a missing or bad file is refused before the thermal model loads
    from bhr._hardware.thermal import format_duration, plan as make_plan, summarize

    from bhr._settings.options import LIMITS

    shown = plot_path
    figure_name = f"thermal-{schedule}-{rate:g}hz.png"  # a plan at another rate or schedule keeps this one
    if not no_plot and table.shape[1] > LIMITS["figure_modules"]:
        if plot_path is not None:
            from bhr._settings.errors import BhrError

            raise BhrError(f"--plot draws the wires of at most {LIMITS['figure_modules']} modules and "
                           f"{codes_path} has {table.shape[1]}; drop --plot (the schedule is printed) or use --csv")
        click.echo(f"Note: no {figure_name} for {table.shape[1]} modules (the figure shows at most "
                   f"{LIMITS['figure_modules']}); the schedule follows.", err=True)
        no_plot = True
    if not no_plot:
        if plot_path is None:
            from bhr.output._atomic import owning_folder

            plot_path = str(Path(codes_path).resolve().parent / figure_name)
            shown = str(Path(codes_path).parent / figure_name)  # named as the user named the codes
            if owning_folder(codes_path) is None:  # a loose codes.csv: the figure goes beside it
                refuse_replacing_beside(Path(codes_path).parent, [figure_name], codes_path,  # as the user named it
                                        "move it away, or give --plot FILE.png or --no-plots")
        check_writable(plot_path, "figure")
        owner = _figure_owner(plot_path)
        if owner is not None:  # a folder bhr cannot replace is refused before the schedule is printed
            from bhr.output._atomic import OutputFolder

            OutputFolder(owner[0], "plan", keep=True).check()
    check_writable(csv_path, "CSV")
    params = thermal_params(robot_file)
    name = Path(codes_path).resolve().parent.name or Path(codes_path).stem
    sched = make_plan(params, table, rate, schedule, name=str(codes_path), trace=not no_plot)
    out = sys.stdout
    out.write(f"wires: {params.describe()}\n")
    out.write(f"{'step':>6} {'sent at':>10}  codes\n")
    prev = None
    for i, row in enumerate(table):
        if prev is None or (row != prev).any() or i == len(table) - 1:
            out.write(f"{steps[i]:>6} {format_duration(sched.times_ms[i] / 1000.0):>10}  "
                      f"{','.join(str(int(c)) for c in row)}\n")
        prev = row
    out.write(summarize(sched, name) + "\n")
    out.flush()
    from bhr.output._atomic import together

    with together():  # the CSV and the figure: both or neither
        written = _write_outputs(sched, table, steps, name, csv_path, plot_path, no_plot)
    if written:
        click.echo("Wrote " + ", ".join(shown if p == plot_path else str(p) for p in written), err=True)


def _write_outputs(sched, table, steps, name, csv_path, plot_path, no_plot) -> list:
    from bhr.output._atomic import write_text

    written = []
    if csv_path:
        lines = ["step,time_s," + ",".join(f"m{j + 1}" for j in range(table.shape[1]))]
        lines += [f"{s},{t / 1000.0:.3f}," + ",".join(str(int(c)) for c in row)
                  for s, t, row in zip(steps, sched.times_ms, table)]
        write_text(Path(csv_path), "\n".join(lines) + "\n")
        written.append(csv_path)
    if not no_plot:
        from bhr.output._atomic import OutputFolder
        from bhr.output._thermal_plot import save_schedule_figure

        owner = _figure_owner(plot_path)
        if owner is not None:
            rel = (Path(owner[1]).parent / Path(plot_path).name).as_posix()
            with OutputFolder(owner[0], "plan", keep=True) as folder:
                save_schedule_figure(sched, folder.path(rel), title=name)
        else:
            save_schedule_figure(sched, plot_path, title=name)
        written.append(plot_path)
    return written


def _figure_owner(plot_path):
    """The folder bhr wrote that the figure goes into, and the codes' place in it (None: a loose figure).

    A run's own folder, or a compare's or report's holding the run one or two levels down: that folder is put
    back whole with the figure added, so its manifest lists every file.
    """
    from bhr.output._atomic import MANIFEST, owning_folder

    plot_dir = Path(plot_path).resolve().parent
    owner = owning_folder(plot_dir / "codes.csv")
    if owner is None and (plot_dir / MANIFEST).is_file():
        owner = (plot_dir, "codes.csv")
    return owner
