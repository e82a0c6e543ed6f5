"""bhr follow: follow a trajectory with follow-the-leader and write errors, plots and codes."""
from __future__ import annotations

import json
import warnings
from pathlib import Path

import click

from bhr.cli._common import (check_parent_folder, check_writable, guarded, input_files, json_in_folder,
                             run_folder_name)
from bhr.cli._progress import announce_compiles, status
from bhr.cli._link import (at_end_option, end_text, exit_interrupted, fault_printer, link_options, link_settings,
                           schedule_option, stop_on_signals, thermal_params)
from bhr.cli.replay import STRIDE_HELP, check_view_options, render_animation, run_live_view
from bhr.cli._options import (MIN_RATE, FiniteRange, PlainIntRange, build_robot, constraint_options, lumen_options,
                              optimal_options, pop_constraints, pop_solver_options, pop_trajectory, robot_options,
                              run_options, trajectory_options)


def summary_lines(result) -> list[str]:
    """The summary table the thesis's script prints: per point and module, max/mean/median/final."""
    s = result.summary.to_dict()
    r = result.robot
    lines = [
        f"{s['trajectory']}: {s['steps']} steps, solver {s['solver']}, {r.modules} modules x {r.module_length:g} mm, "
        f"alpha {r.alpha:g} deg, feed {r.feed:g} mm",
    ]
    head = f"{'':<22}{'max':>9}{'at step':>9}{'mean':>9}{'median':>9}{'rmse':>9}{'final':>9}"

    def block(title: str, rows: list[dict], label: str, count: int) -> None:
        lines.append("")
        lines.append(title)
        lines.append(head)
        for j, st in enumerate(rows):
            name = f"{label} {j + 1}" + (" (base)" if j == 0 else "") + (" (tip)" if j == count - 1 else "")
            lines.append(f"  {name:<20}{st['max']:>9.3f}{st['worst_step']:>9d}{st['mean']:>9.3f}"
                         f"{st['median']:>9.3f}{st['rmse']:>9.3f}{st['final']:>9.3f}")

    block("Position error (mm)", s["points"], "point", len(s["points"]))
    block("Orientation error (deg)", s["modules"], "module", len(s["modules"]))
    block("Global error (1 = at tolerance)", s["global"], "module", len(s["global"]))
    lines.append("")
    lines.append(f"Worst step: {s['points_worst_step']} (largest point error {s['points_max_error_mm']:.3f} mm); "
                 f"tip ends {s['tip_final_error_mm']:.4f} mm and {s['tip_orientation_final_deg']:.3f} deg off.")
    lines += tolerance_lines(s, r)
    lines += body_clearance_lines(s)
    return lines


def tolerance_lines(s: dict, robot) -> list[str]:
    """One line when the run went over its tolerances (summary key tolerance_exceeded); none otherwise."""
    if not s.get("tolerance_exceeded"):
        return []
    parts = []
    if s["over_tol_pos_steps"]:
        k = s["over_tol_pos_steps"]
        parts.append(f"a point was more than {robot.tol_pos:g} mm off at {k} step{'s' * (k != 1)} "
                     f"(worst {s['points_max_error_mm']:.3f} mm at step {s['points_worst_step']})")
    if s["over_tol_ori_steps"]:
        k = s["over_tol_ori_steps"]
        parts.append(f"the tip's orientation was more than {robot.tol_ori:g} deg off at {k} step{'s' * (k != 1)} "
                     f"(worst {s['tip_orientation_max_deg']:.3f} deg)")
    return ["Over tolerance: " + "; ".join(parts) + "."]


def body_clearance_lines(s: dict) -> list[str]:
    """The whole body's errors and the lumen clearance, when the run has them (summary keys)."""
    from bhr.run.clearance import step_ranges

    out = []
    if s.get("locomotion") == "trail":
        from bhr.hardware.thermal import format_duration

        out.append(f"Trail: {s['trail_vertices']} vertices, every module along it (exact follow-the-leader, within "
                   f"{s['trail_offset_bound_mm']:.2f} mm of the trail); the feeder pushes until step "
                   f"{s['feeder_stop_step']}, the tip {s['cecum_shortfall_mm']:.1f} mm short of the path's end; "
                   f"{format_duration(s['procedure_time_s'])} at the wires' pace, the whole robot.")
    if "body_modules" in s:
        out.append(f"Whole body: {s['body_modules']} modules; the body behind the head is off the path by at most "
                   f"{s['body_points_max_error_mm']:.3f} mm (step {s['body_worst_step']}).")
    if "min_clearance_mm" in s:
        if s["min_clearance_mm"] is None:
            out.append("Lumen clearance: no point of the robot reached the path yet.")
        else:
            out.append(f"Lumen clearance: minimum {s['min_clearance_mm']:.3f} mm at step {s['min_clearance_step']}, "
                       f"{s['min_clearance_point']}.")
        touch = s["wall_touch_steps"]
        out.append(f"Wall touched at {len(touch)} step{'s' if len(touch) != 1 else ''}"
                   + (f": {step_ranges(touch)}." if touch else "."))
        if s.get("left_lumen_reason"):
            out.append(f"The robot {s['left_lumen_reason']}.")
    return out


@click.command()
@click.option("--traj", required=True, metavar="NAME|PATH",
              help="line, curve, spiral, colon, anatomy (--seed N), a shipped anatomy-* colon, or a trajectory file: "
                   ".toml (segments) or .csv (points).")
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
@click.option("--rate", default=10.0, show_default=True, metavar="HZ", type=FiniteRange(min=MIN_RATE, max=1000),
              help="With --port: steps sent per second, at most.")
@schedule_option()
@at_end_option("stop", "With --port, after the last step")
@guarded
def follow(traj, solver, out_dir, json_path, no_plots, **kwargs):
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
    from bhr.model.trajnames import check_trajectory_name

    check_trajectory_name(traj)  # a misspelt name costs no numba import
    from bhr.output.atomic import OutputFolder, write_json, write_text
    from bhr.run.body import check_body_modules
    from bhr.model.codes import format_codes_csv
    from bhr.run.driver import BhrWarning, follow as run_follow
    from bhr.model.generators import load_trajectory
    from bhr.output.steptable import STEPS_CSV, format_steps_csv

    show, animate_path, stride = kwargs.pop("show"), kwargs.pop("animate_path"), kwargs.pop("stride")
    stem = Path(traj).stem if traj not in ("line", "curve", "spiral", "colon") else traj
    if traj == "anatomy":  # one folder per colon
        stem = f"anatomy-{kwargs['seed'] if kwargs.get('seed') is not None else 1}"
    # The folder: as given, or bhr-out/<traj>-<solver>-<hash of what makes the run different>.
    # With --json - and --no-plots and no --out, standard output is the whole output: no folder at all.
    to_stdout = json_path == "-"
    use_folder = out_dir is not None or not (to_stdout and no_plots)
    if out_dir is not None:
        folder = OutputFolder(out_dir, "follow", names=FOLLOW_NAMES,  # checked before any work
                              inputs=input_files(traj, kwargs.get("robot_file"))).check()
    else:
        check_parent_folder("bhr-out")
        folder = None
    check_writable(json_path, "JSON")
    check_view_options(show, animate_path)
    rate = kwargs.pop("rate")
    schedule = kwargs.pop("schedule")
    at_end = kwargs.pop("at_end")
    link_kw = {k: kwargs.pop(k) for k in ("port", "baud", "timeout", "retries")}
    if link_kw["port"] is None and link_kw["baud"] is not None:
        from bhr.settings.errors import BhrError

        raise BhrError("--baud is an option of streaming; give --port too, or drop --baud")
    if link_kw["port"] is None and at_end != "stop":
        from bhr.settings.errors import BhrError

        raise BhrError("--at-end is an option of streaming; give --port too, or drop --at-end")
    robot_file = link_kw["robot_file"] = kwargs.get("robot_file")
    streaming = link_kw["port"] is not None
    robot = build_robot(kwargs)
    constraints = pop_constraints(kwargs)
    optimal = pop_solver_options(kwargs, [solver]).get(solver, {})
    body_modules = kwargs.pop("body_modules")
    if body_modules is not None:
        check_body_modules(body_modules, robot.modules, "--body-modules")
    reach, locomotion = kwargs.pop("reach"), kwargs.pop("locomotion") or "thesis"
    if reach is not None and body_modules is not None:
        from bhr.settings.errors import BhrError

        raise BhrError("give either --body-modules or --reach cecum, not both (--reach cecum sets the whole robot's "
                       "modules from the path's length)")
    if streaming and (locomotion != "thesis" or reach is not None):
        from bhr.settings.errors import BhrError

        raise BhrError("--port streams the thesis's locomotion; drop --locomotion and --reach to stream")
    traj_params = pop_trajectory(kwargs)
    announce_compiles()
    tr = load_trajectory(traj, feed=robot.feed, **traj_params)
    if folder is None and use_folder:
        name = run_folder_name(f"{stem}-{solver}", tr.points, tr.lumen if tr.lumen is not None else 0,
                               robot.to_dict(), solver, constraints, optimal, body_modules,
                               *((reach, locomotion) if (reach, locomotion) != (None, "thesis") else ()))
        folder = OutputFolder(Path("bhr-out") / name, "follow", names=FOLLOW_NAMES,
                              inputs=input_files(traj, robot_file)).check()
    if folder is not None:  # what makes the results: a rerun with the same keeps what it does not redraw
        folder.settings = name.rsplit("-", 1)[1] if out_dir is None else run_folder_name(
            "", tr.points, tr.lumen if tr.lumen is not None else 0, robot.to_dict(), solver, constraints, optimal,
            body_modules, *((reach, locomotion) if (reach, locomotion) != (None, "thesis") else ())).rsplit("-", 1)[1]
    json_inside = json_in_folder(json_path, folder, FOLLOW_NAMES) if folder is not None else None
    anim_inside = None
    if folder is not None and animate_path is not None:
        taken = FOLLOW_NAMES + ((json_inside,) if json_inside else ())
        anim_inside = json_in_folder(animate_path, folder, taken, "--animate")
    out = folder.final("") if folder is not None else Path(".")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BhrWarning)
        stream_faults: list = []
        if link_kw["port"] is None:
            body = f", body of {body_modules} modules" if body_modules is not None else ""
            body += ", a robot reaching the cecum" if reach is not None else ""
            body += f", locomotion {locomotion}" if locomotion != "thesis" else ""
            with status(f"following {tr.name} ({len(tr.points)} steps, solver {solver}{body})"):
                result = run_follow(tr, solver=solver, robot=robot, solver_options={**constraints, **optimal},
                                    body_modules=body_modules, reach=reach, locomotion=locomotion)
        else:
            result, stream_faults = follow_streaming(tr, solver, robot, {**constraints, **optimal}, body_modules,
                                                     rate, link_kw, schedule, at_end)
    for w in dict.fromkeys(str(w.message) for w in caught if issubclass(w.category, BhrWarning)):
        click.echo(f"Warning: {w}", err=True)
    with status("writing run.json"):
        doc = result.to_dict()
    written: list[Path] = []
    if folder is not None:
        with folder:
            if result.codes is not None:
                write_text(folder.path("codes.csv"), format_codes_csv(result.codes))
                written.append(folder.final("codes.csv"))
            if json_path is None or json_inside is not None:
                name = json_inside or "run.json"
                write_json(folder.path(name), doc)
                written.append(folder.final(name))
            write_text(folder.path(STEPS_CSV), format_steps_csv(result))  # the errors per step, for a spreadsheet
            written.append(folder.final(STEPS_CSV))
            if not no_plots:
                from bhr.output.plots import save_run_plots

                with status(f"drawing the figures into {out}"):
                    written += [folder.final(p.name) for p in save_run_plots(result, folder.stage)]
                from bhr.output.view import save_view

                with status("writing the 3-D view"):
                    written.append(folder.final(save_view(result, folder.stage).name))
            if anim_inside is not None:  # an animation inside the folder belongs to its set
                render_animation(result, str(folder.path(anim_inside)), stride, folder.final(anim_inside))
            if json_path not in (None, "-") and json_inside is None:
                write_json(json_path, doc)  # before the folder goes in place: a failure here keeps the old set
                written.append(Path(json_path))
        if out_dir is None:
            from bhr.output.atomic import point_latest

            point_latest(folder.target)  # bhr-out/latest: the run just written
    if to_stdout:
        click.echo(json.dumps(doc))
    elif json_path is not None and folder is None:
        write_json(json_path, doc)
        written.append(Path(json_path))
    stream = to_stdout
    for line in summary_lines(result):
        click.echo(line, err=stream)
    if result.codes is not None and not streaming and folder is not None:
        from bhr.cli._link import thermal_params
        from bhr.hardware.thermal import auto_schedule, format_duration

        sched = auto_schedule(thermal_params(robot_file), result.codes, rate, trace=False)  # memory: not per step
        click.echo(f"Procedure time on the board: {format_duration(sched.total_s)} at the board's limits "
                   f"(bhr plan --codes {out / 'codes.csv'} shows the schedule).", err=stream)
    if written:
        click.echo("Wrote " + ", ".join(str(p) for p in written), err=stream)
    if animate_path and anim_inside is None:
        render_animation(result, animate_path, stride)
    if show:
        run_live_view(result, stride)
    if stream_faults:
        from bhr.settings.errors import BhrError

        step, name = stream_faults[0]
        raise BhrError(f"the board raised {len(stream_faults)} fault{'s' if len(stream_faults) != 1 else ''} during "
                       f"the stream (first: {name} at step {step}); check the robot file's [thermal] table and "
                       "'bhr status'")


#: What bhr follow writes into its folder (an existing folder holding only such files may be replaced).
FOLLOW_NAMES = ("run.json", "codes.csv", "steps.csv", "*.png", "view.html", "manifest.json")


def follow_streaming(tr, solver, robot, solver_options, body_modules, rate, link_kw, schedule="auto", at_end="stop"):
    """Solve the run, check its codes against the wires' thermal model, then stream them (the --port path).

    The stream itself is bhr.hardware.link.run_stream, as in ``bhr stream``; after the last step one explicit message
    goes to the board (``at_end``): stop-all, or a heartbeat that holds the last codes until its silence timeout.
    """
    import contextlib
    import sys

    from bhr.settings.errors import BhrError
    from bhr.run.driver import follow as run_follow
    from bhr.hardware.link import BoardLink, Pacer, StreamInterrupted, check_board, run_stream
    from bhr.hardware.thermal import format_duration, plan

    if body_modules is not None:
        raise BhrError("--port streams the head's codes and cannot stream a --body-modules run; drop one of the two")
    params = thermal_params(link_kw.get("robot_file"))
    port, link_args = link_settings(link_kw, use_file_port=False)
    order = link_args["module_order"]
    if order is not None and len(order) != robot.modules:
        raise BhrError(f"the robot file's link.module_order lists {len(order)} modules but the robot has "
                       f"{robot.modules}; make them agree")
    with BoardLink(port, **link_args) as link, stop_on_signals():
        board = check_board(link, robot.modules)  # a wrong board is refused before the solve
        result = run_follow(tr, solver=solver, robot=robot, solver_options=solver_options)
        if result.codes is None:
            Pacer(link, rate)(1, None)  # the one-line refusal of code-less solvers
        rows = result.codes
        sched = plan(params, rows, rate, schedule, name=tr.name, sending=True, trace=False)
        held = [f for f in board["faults"] if f != "silence"]  # silence: the board was idle, which is fine
        if held:
            click.echo(f"Warning: board on {port} reports {', '.join(held)} before the run (latched faults stay "
                       "until stop-all; a cooling module is waited for)", err=True)
        steps = len(rows)
        times = sched.times_ms / 1000.0 if schedule == "auto" else None
        show_bar = sys.stderr.isatty()
        try:
            with (click.progressbar(length=steps, label=f"streaming to {port}", file=sys.stderr,
                                    show_pos=True) if show_bar else contextlib.nullcontext()) as bar:
                report = run_stream(link, rows, rate, times=times, on_fault=fault_printer(port),
                                    known_faults=board["faults"], wait_ready=True, wait_relaxed=schedule == "auto",
                                    at_end=at_end,
                                    progress=(lambda done, total: bar.update(1)) if bar is not None else None)
        except StreamInterrupted as exc:
            exit_interrupted(exc, steps, "steps")
    how = f"at {rate:g} Hz" if schedule == "rate" else "at the board's limits"
    settle = sched.total_s - float(sched.times_ms[-1]) / 1000.0  # the last step's contraction
    click.echo(f"streamed {report.sent} steps ({robot.modules} modules) to {port} {how}; procedure time "
               f"{format_duration(report.elapsed_s + settle)} (planned {format_duration(sched.total_s)}); "
               f"{end_text(at_end)}", err=True)
    return result, report.fault_events
