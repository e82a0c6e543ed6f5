"""bhr stream: send a codes.csv to the actuator board over a serial port."""
from __future__ import annotations

import sys

import click

from bhr.cli._common import guarded
from bhr.cli._link import (at_end_option, end_text, exit_interrupted, fault_printer, link_options, link_settings,
                           schedule_option, thermal_params)
from bhr.cli._options import rate_type


@click.command()
@link_options()
@click.option("--codes", "codes_path", required=True, metavar="FILE",
              help="codes.csv as written by 'bhr follow' (header step,m1,...,mN).")
@click.option("--rate", default=10.0, show_default=True, metavar="HZ",
              type=rate_type(), help="Rows sent per second.")
@schedule_option()
@at_end_option("hold")
@click.option("--dry-run", is_flag=True, help="Check the stream as a real one would (thermal model, module order), "
                                              "then print the frames as hex, one per line, instead of sending them.")
@guarded
def stream(codes_path, rate, schedule, at_end, dry_run, **link_kw):
    """Send the module codes of a run to the actuator board, one row per step.

    Every code in FILE is checked before anything is sent: a file with an
    unstable code is refused whole, naming its line and column. Each row is
    one SET_CODES frame, acknowledged by the board (docs/protocol.md). Before
    the first frame the whole stream is checked against the thermal model of
    the wires (docs/thermal.md; the --robot file's [thermal] table), with or
    without --dry-run: --schedule auto (the default) stretches the steps to
    what the wires allow; at --schedule rate a stream the board would fault
    on is refused, naming the module, the step and the fix. A fault the
    board raises anyway is printed with its module and step, and the exit
    status is 1; an overheat, a board that stops answering or answers
    impossibly stops the stream (stop-all is sent where it can be). Ctrl-C
    sends stop-all. After the last row, --at-end hold (the default) leaves
    those codes on until the board's silence timeout, --at-end stop sends
    stop-all. With --robot FILE the file's [link] table gives the port, baud
    rate and module order.

    \b
        bhr stream --port /dev/ttyUSB0 --codes bhr-out/latest/codes.csv --rate 10
    """
    from bhr.model._codes import read_codes_csv
    from bhr._settings.errors import BhrError

    steps, table = read_codes_csv(codes_path)
    n_rows, n_modules = table.shape
    robot_file = link_kw.get("robot_file")

    port, link_args = link_settings(link_kw, need_port=not dry_run, hint=", or use --dry-run to print the frames")
    from bhr._hardware.thermal import format_duration, pace, plan

    # the same checks with and without --dry-run: what one board drives, then the thermal model
    from bhr._hardware.protocol import check_board_modules

    check_board_modules(n_modules, str(codes_path))
    sched = plan(thermal_params(robot_file), table, rate, schedule, name=str(codes_path), sending=not dry_run,
                 trace=False)
    if dry_run:
        from bhr._hardware.protocol import set_codes_frame

        order = link_args["module_order"]
        if order is not None and len(order) != n_modules:
            raise BhrError(f"{codes_path} has {n_modules} modules but the robot file's link.module_order lists "
                           f"{len(order)}; use codes for {len(order)} modules")
        out = sys.stdout
        for i, row in enumerate(table):
            codes = row.tolist() if order is None else [int(row[m - 1]) for m in order]
            frame = set_codes_frame(i & 0xFF, codes)
            out.write(" ".join(f"{b:02x}" for b in frame) + "\n")
        out.flush()
        how = pace(sched, counts=False)
        click.echo(f"dry run: {n_rows} SET_CODES frames for {n_modules} modules (nothing sent); the thermal model "
                   f"accepts them {how}, procedure time {format_duration(sched.total_s)}", err=True)
        return

    from bhr.cli._progress import status
    from bhr._hardware.link import BoardLink, StreamInterrupted, run_stream

    times = sched.times_ms / 1000.0 if schedule == "auto" else None
    events: list = []
    with BoardLink(port, **link_args) as link:
        try:
            with status(f"streaming to {port}", n_rows, log=True) as bar:
                printer = fault_printer(port)

                def on_fault(step: int, names: list[str]) -> None:
                    events.extend((step, n) for n in names)
                    printer(steps[step - 1], names)

                report = run_stream(link, table, rate=rate, times=times, on_fault=on_fault, wait_ready=True,
                                    wait_relaxed=schedule == "auto", at_end=at_end,
                                    progress=bar.set)
        except StreamInterrupted as exc:
            exit_interrupted(exc, n_rows, "rows")
    sent = report.sent
    how = pace(sched, counts=False)
    took = report.elapsed_s + sched.total_s - float(sched.times_ms[-1]) / 1000.0
    click.echo(f"sent {sent} row{'s' * (sent != 1)} ({n_modules} modules, steps {steps[0]}..{steps[-1]}) to {port} "
               f"{how}; procedure time {format_duration(took)} (planned {format_duration(sched.total_s)}); "
               f"{end_text(at_end)}")
    if events:
        raise BhrError(f"the board raised {len(events)} fault{'s' if len(events) != 1 else ''} during the stream "
                       f"(first: {events[0][1]} at step {steps[events[0][0] - 1]}); check the [thermal] table of "
                       "the robot file against the wires, and 'bhr status'")
