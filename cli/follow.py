"""bhr follow: follow a trajectory with follow-the-leader and write errors, plots and codes.

Parses the options, calls bhr._studies.follow_run.follow_run (which writes the run's whole output set, and
streams it with --port) and prints what it returns.
"""
from __future__ import annotations

import functools
import json

import click

from bhr.cli._common import check_writable, guarded
from bhr.cli._progress import announce_compiles, start, status, stop
from bhr.cli._link import (at_end_option, end_text, exit_interrupted, fault_printer, link_options, link_settings,
                           schedule_option, thermal_params)
from bhr.cli.replay import STRIDE_HELP, check_view_options, run_live_view
from bhr.model._trajnames import traj_help
from bhr.cli._options import (rate_type, PlainIntRange, force_option, build_robot, constraint_options, lumen_options,
                              optimal_options, pop_constraints, pop_solver_options, pop_trajectory, robot_options,
                              run_options, trajectory_options)

@click.command()
@click.option("--traj", required=True, metavar="NAME|PATH",
              help=traj_help())
@trajectory_options
@click.option("--solver", default="thesis", show_default=True,
              help="thesis (the thesis's algorithm), constrained, fabrik, ccd, optimal, lumen (keeps "
                   "the robot off the lumen wall).")
@robot_options(feed=True)
@constraint_options
@optimal_options
@lumen_options
@run_options
@click.option("--out", "out_dir", default=None, metavar="DIR",
              help="Output folder, replaced whole by this run [./bhr-out/<traj>-<solver>-<hash>/, the hash "
                   "of the trajectory, robot and solver settings].")
@force_option
@click.option("--json", "json_path", default=None, metavar="PATH|-",
              help="Where to write the run as JSON ('-': stdout) [DIR/run.json].")
@click.option("--no-plots", is_flag=True, help="Skip the PNG figures.")
@click.option("--show", is_flag=True, help="Watch the run step by step in a window (space, n/b, q).")
@click.option("--animate", "animate_path", default=None, metavar="FILE",
              help="Also write an animation: FILE.gif (Pillow) or FILE.mp4 (needs ffmpeg).")
@click.option("--stride", type=PlainIntRange(min=1, max=10**9), default=None, metavar="N", help=STRIDE_HELP)
@link_options(port_help="After solving the whole run and checking it against the wires' thermal model, stream its "
                        "codes to the actuator board on this serial device or pyserial URL (the --robot file's "
                        "[link] gives baud rate and module order).", robot=False)
@click.option("--rate", default=10.0, show_default=True, metavar="HZ", type=rate_type(),
              help="With --port: steps sent per second, at most.")
@schedule_option()
@at_end_option("stop", "With --port, after the last step")
@guarded
def follow(traj, solver, out_dir, json_path, no_plots, force, **kwargs):
    """Follow a trajectory with follow-the-leader and report the errors.

    Writes into DIR the position, orientation and global error figures, a
    view of the path with the final pose, codes.csv (one row of module codes
    per step) and run.json, and prints a summary table. Defaults are the
    thesis's robot: 5 modules of 10 mm, alpha 10 deg, tolerances 8 mm and
    20 deg, feed 2 mm.

        bhr follow --traj curve --radius 70 --angle 360

    With --port the run is solved first, its codes are checked against the
    thermal model of the wires (docs/thermal.md), and then streamed to the
    actuator board as fast as the wires allow, never faster than --rate
    (--schedule auto, the default) or at --rate steps per second
    (--schedule rate: refused before anything is sent where the board would
    fault); Ctrl-C sends stop-all:

        bhr follow --traj colon --port /dev/ttyUSB0
    """
    from bhr.model._trajnames import check_trajectory_name

    check_trajectory_name(traj)  # a misspelt name costs no numba import
    from bhr.solvers import check_solver_name

    solver = check_solver_name(solver)  # nor does a misspelt solver (bhr.solvers._names); an alias is shown by its name
    from bhr._settings.errors import BhrError

    from bhr._studies.follow_run import StreamSettings, check_outputs, follow_run

    check_outputs(traj, kwargs.get("robot_file"), out_dir, json_path, force)  # before any work
    check_writable(json_path, "JSON")  # and never onto an input (--traj, --robot)
    show, animate_path, stride = kwargs.pop("show"), kwargs.pop("animate_path"), kwargs.pop("stride")
    check_view_options(show, animate_path)
    if not show and animate_path is None:
        import gc

        # a run of a few seconds: its cyclic garbage (matplotlib's artists, numba's loaders) is left for the
        # process's end instead of being collected some 500 times on the way, about a tenth of its CPU
        gc.disable()
    rate, schedule, at_end = kwargs.pop("rate"), kwargs.pop("schedule"), kwargs.pop("at_end")
    link_kw = {k: kwargs.pop(k) for k in ("port", "baud", "timeout", "retries")}
    if link_kw["port"] is None and link_kw["baud"] is not None:
        raise BhrError("--baud is an option of streaming; give --port too, or drop --baud")
    if link_kw["port"] is None and at_end != "stop":
        raise BhrError("--at-end is an option of streaming; give --port too, or drop --at-end")
    robot_file = link_kw["robot_file"] = kwargs.get("robot_file")
    robot = build_robot(kwargs)
    constraints = pop_constraints(kwargs)
    optimal = pop_solver_options(kwargs, [solver]).get(solver, {})
    body_modules = kwargs.pop("body_modules")
    if body_modules is not None:
        from bhr._run.body import check_body_modules

        check_body_modules(body_modules, robot.modules, "--body-modules")
    reach, locomotion = kwargs.pop("reach"), kwargs.pop("locomotion")
    stop_at_wall = bool(kwargs.pop("stop_at_wall"))
    all_poses = bool(kwargs.pop("all_poses"))
    if reach is not None and body_modules is not None:
        raise BhrError("give either --body-modules or --reach cecum, not both (--reach cecum sets the whole robot's "
                       "modules from the path's length)")
    stream = None
    bars: list = []  # the stream's and the animation's progress bars, made at their first step
    if link_kw["port"] is not None:
        port, link_args = link_settings(link_kw, use_file_port=False)
        stream = StreamSettings(port, link_args, schedule=schedule, at_end=at_end, on_fault=fault_printer(port),
                                progress=_bar(bars, f"streaming to {port}"))
    traj_params = pop_trajectory(kwargs)
    announce_compiles()
    interrupted = ()  # nothing to catch without a stream; the board's link is loaded only for a stream (0.14 s)
    if stream is not None:
        from bhr._hardware.link import StreamInterrupted

        interrupted = (StreamInterrupted,)
    try:
        run = follow_run(traj, robot=robot, solver=solver, solver_options={**constraints, **optimal},
                         traj_params=traj_params, body_modules=body_modules, reach=reach, locomotion=locomotion,
                         stop_at_wall=stop_at_wall, all_poses=all_poses,
                         out_dir=out_dir, json_path=json_path, plots=not no_plots, animate_path=animate_path,
                         stride=stride, rate=rate, robot_file=robot_file, thermal=thermal_params(robot_file),
                         stream=stream, status=functools.partial(status, log=True),
                         frames_progress=_bar(bars, f"Rendering {animate_path}"),
                         notice=lambda line: click.echo(line, err=True), force=force)
    except interrupted as exc:
        _close(bars)
        exit_interrupted(exc, getattr(exc, "total", 0), "steps")
    finally:
        _close(bars)
    to_stdout = json_path == "-"
    if run.stream is not None:
        st = run.stream
        from bhr._hardware.thermal import format_duration

        click.echo(f"streamed {st.sent} steps ({st.modules} modules) to {st.port} {st.how}; procedure time "
                   f"{format_duration(st.elapsed_s)} (planned {format_duration(st.planned_s)}); "
                   f"{end_text(st.at_end)}", err=True)
    for w in run.warnings:
        click.echo(f"Warning: {w}", err=True)
    for anim, shown in run.animations:
        click.echo(f"Animation: {anim.frames} frames (every {anim.stride} step{'s' if anim.stride > 1 else ''} of "
                   f"{run.result.steps}), {anim.bytes / 1e6:.2f} MB -> {shown}", err=to_stdout)  # with the summary
    if to_stdout:
        click.echo(json.dumps(run.doc))
    for line in run.lines():
        click.echo(line, err=to_stdout)
    if show:
        run_live_view(run.result, stride)
    run.check_stream()


def _bar(bars: list, label: str):
    """A progress callback (done, total) showing ``label``'s status (:mod:`bhr.cli._progress`) from its first call."""
    mine: list = []

    def progress(done: int, total: int) -> None:
        if not mine:
            mine.append(start(label, total, log=True))
            bars.append(mine[0])
        mine[0].set(done, total)

    return progress


def _close(bars: list) -> None:
    while bars:
        stop(bars.pop())
