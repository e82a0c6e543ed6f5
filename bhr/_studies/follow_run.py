"""``bhr follow`` as one library call: a run (or a run streamed to the board) and its whole output set.

:func:`follow_run` loads the trajectory, solves the run (or, with a
:class:`StreamSettings`, solves it, plans its codes against the wires'
thermal model and streams them with :func:`bhr._hardware.link.run_stream`, the
one streaming loop), and writes everything it makes as one set through
:class:`bhr.output._atomic.OutputFolder`: codes.csv, run.json, steps.csv, the
figures, view.html, the manifest and an animation asked for inside the
folder. The command line (``cli/follow.py``) parses, calls it and prints
:meth:`FollowRun.lines`.
"""
from __future__ import annotations

import contextlib
import shlex
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ContextManager

from bhr.output._atomic import OutputFolder, write_json, write_text
from bhr.output._paths import check_parent_folder, input_files, json_in_folder, run_folder_name
from bhr._settings.errors import BhrError

__all__ = ["FOLLOW_NAMES", "FollowRun", "StreamSettings", "check_outputs", "follow_run", "summary_lines", "folder_stem",
           "trajectory_parts"]

#: What bhr follow writes into its folder (an existing folder holding only such files may be replaced).
FOLLOW_NAMES = ("run.json", "codes.csv", "steps.csv", "poses.npz", "*.png", "view.html", "manifest.json")

Status = Callable[[str], ContextManager[Any]]
Progress = Callable[[int, int], None]


def _no_status(label: str) -> ContextManager[Any]:
    return contextlib.nullcontext()


@dataclass
class StreamSettings:
    """Where and how ``follow_run`` streams the run's codes (``bhr follow --port``)."""

    port: str
    link_args: dict[str, Any]            # bhr._hardware.link.BoardLink's keyword arguments
    schedule: str = "auto"               # bhr._hardware.thermal.SCHEDULES
    at_end: str = "stop"                 # bhr._hardware.link.AT_END
    on_fault: Callable[[int, list[str]], None] | None = None
    progress: Progress | None = None     # (done, total) after each acknowledged row


@dataclass
class StreamOutcome:
    """What the stream did: rows sent, times, the board's faults (step, name)."""

    sent: int
    modules: int
    port: str
    how: str
    elapsed_s: float
    planned_s: float
    at_end: str
    faults: list = field(default_factory=list)


@dataclass
class FollowRun:
    """A finished ``bhr follow``: the run, its document, the files written and what to tell the user."""

    result: Any                           # bhr._run.driver.FollowResult
    doc: dict
    written: list[Path]
    folder: Path | None                   # the run's folder (None: no folder)
    procedure_s: float | None = None      # the codes at the wires' pace, at most ``rate`` (auto schedule)
    procedure_pace: str = ""              # what sets it, in words (bhr._hardware.thermal.pace)
    procedure_rate: float = 10.0          # the rate cap of that schedule (bhr plan --rate gives the same time)
    stream: StreamOutcome | None = None
    animations: list[tuple[Any, Path]] = field(default_factory=list)  # (bhr.output._animate.Animation, path shown)
    warnings: list[str] = field(default_factory=list)     # BhrWarning messages of the run, once each

    def lines(self) -> list[str]:
        """The summary table, the procedure time and what was written (the lines bhr follow prints)."""
        out = summary_lines(self.result)
        if self.procedure_s is not None and self.folder is not None:
            from bhr._hardware.thermal import format_duration

            out.append(f"Procedure time on the board: {format_duration(self.procedure_s)} {self.procedure_pace} "
                       f"(bhr plan --codes {shlex.quote(str(self.folder / 'codes.csv'))} --rate "
                       f"{self.procedure_rate:g} shows the schedule).")
        if self.written:
            out.append("Wrote " + ", ".join(str(p) for p in self.written))
        return out

    def check_stream(self) -> None:
        """Raise BhrError (one line) when the board raised faults during the stream."""
        faults = self.stream.faults if self.stream is not None else []
        if faults:
            step, name = faults[0]
            raise BhrError(f"the board raised {len(faults)} fault{'s' if len(faults) != 1 else ''} during the "
                           f"stream (first: {name} at step {step}); check the robot file's [thermal] table and "
                           "'bhr status'")


def folder_stem(traj: str, seed: int | None) -> str:
    """The readable part of a run's default folder name: the trajectory's name, one folder per anatomy colon."""
    if traj == "anatomy":
        return f"anatomy-{seed if seed is not None else 1}"
    if traj.startswith("gca:"):  # a real colon: gca-VHM (no colon in a folder's name)
        return "gca-" + traj[4:]
    return traj if traj in ("line", "curve", "spiral", "colon") else Path(traj).stem


def _describe(body_modules, reach, locomotion) -> str:
    body = f", body of {body_modules} modules" if body_modules is not None else ""
    body += ", a robot reaching the cecum" if reach is not None else ""
    body += f", locomotion {locomotion}" if locomotion != "thesis" else ""
    return body


def check_outputs(traj: str, robot_file: str | None, out_dir: str | None, json_path: str | None,
                  force: bool = False) -> OutputFolder | None:
    """Refuse, before any work, outputs that cannot be written; the checked ``--out`` folder (None: the default).

    Cheap (no numba): the command line calls it before it builds the robot, :func:`follow_run` again.
    """
    from bhr.output._paths import check_output_file

    folder = None
    if out_dir is not None:
        folder = OutputFolder(out_dir, "follow", inputs=input_files(traj, robot_file),
                              force=force).check()
    else:
        check_parent_folder("bhr-out")
    if json_path not in (None, "-"):
        check_output_file(json_path, "JSON")
    return folder


def follow_run(traj: str, *, robot: Any, solver: str = "thesis", solver_options: dict | None = None,
               traj_params: dict | None = None, body_modules: int | None = None, reach: str | None = None,
               locomotion: str | None = None, stop_at_wall: bool = False, all_poses: bool = False,
               out_dir: str | None = None,
               json_path: str | None = None,
               plots: bool = True, animate_path: str | None = None, stride: int | None = None,
               rate: float = 10.0, robot_file: str | None = None, thermal: Any = None,
               stream: StreamSettings | None = None, status: Status = _no_status,
               frames_progress: Progress | None = None, notice: Callable[[str], None] | None = None,
               force: bool = False) -> FollowRun:
    """Follow ``traj`` and write the run's whole output set; see the module's docstring.

    ``out_dir`` None: ``bhr-out/<traj>-<solver>-<hash of the settings>/``
    (and ``bhr-out/latest`` pointing at it), except that with ``json_path``
    "-" and no plots standard output is the whole output (no folder).
    ``json_path``: run.json elsewhere (or "-": the caller prints
    ``FollowRun.doc``). ``animate_path``: also an animation (inside the
    folder it belongs to the set). ``thermal``: the wires
    (bhr.model._wires.ThermalParams) for the procedure time and the stream
    [the default wire]; ``rate``: steps per second at most, of the stream
    and of the procedure time's schedule. ``status(label)``: a context manager around each
    stage (a spinner); ``frames_progress(done, total)`` while an animation
    renders; ``notice(line)`` for lines to show during the run. ``stop_at_wall``: end the run where the robot
    leaves the lumen; ``all_poses``: keep and write every pose, however many (:func:`bhr._run.driver.follow`).
    """
    from bhr.output._paths import check_output_file

    solver_options = dict(solver_options or {})
    traj_params = dict(traj_params or {})
    say = notice or (lambda line: None)
    to_stdout = json_path == "-"
    use_folder = out_dir is not None or not (to_stdout and not plots)
    # the default folder is named by the run's settings, so a --robot file inside it is that same run's run.json
    # (a file bhr did not write there is refused anyway); its robot was read whole before this run: the rerun
    # replaces it with the run it makes again (`bhr follow --traj T --robot bhr-out/latest/run.json`)
    inputs = input_files(traj)
    folder = check_outputs(traj, robot_file, out_dir, json_path, force)
    if animate_path is not None:
        from bhr.output._animate import check_target

        check_target(animate_path)
        check_output_file(animate_path, "animation")
    if stream is not None and body_modules is not None:
        from bhr.model._robotfile import MAX_BOARD_MODULES

        head = "--port streams the head's run as it is solved, not a --body-modules run; drop --port"
        if body_modules > MAX_BOARD_MODULES:
            raise BhrError(f"{head}: one board drives at most {MAX_BOARD_MODULES} modules, so the whole robot's "
                           f"{body_modules} cannot be streamed to one")
        raise BhrError(f"{head}, then stream the whole robot's codes.csv (every module, rear first) to a board built "
                       f"for {body_modules} modules (make -C firmware MODULES={body_modules}): bhr stream --port PORT "
                       "--codes bhr-out/latest/codes.csv")
    if stream is not None and stop_at_wall:
        raise BhrError("--port streams every step as it is solved, so it cannot stop where the robot left the lumen "
                       "later; drop --stop-at-wall to stream, or --port to check the run first")
    if stream is not None and all_poses:
        raise BhrError("--port streams the thesis's locomotion, one pose a step; drop --all-poses to stream")
    if stream is not None and (locomotion not in (None, "thesis") or reach is not None):
        raise BhrError("--port streams the thesis's locomotion; drop --locomotion and --reach to stream")
    if thermal is None:
        from bhr._hardware.thermal import DEFAULT_THERMAL

        thermal = DEFAULT_THERMAL

    from bhr.model._generators import load_trajectory
    from bhr._run.driver import BhrWarning

    tr = load_trajectory(traj, feed=robot.feed, **traj_params)
    if locomotion is None:  # a whole robot moves by its wires (bhr._run.driver.follow's default)
        whole = (body_modules is not None or reach is not None) and getattr(tr, "lumen", None) is not None
        locomotion = "wires" if whole and solver == "lumen" else "thesis"
    extra: tuple[str | None, ...] = (reach, locomotion) if (reach, locomotion) != (None, "thesis") else ()
    extra += ("stop_at_wall",) if stop_at_wall else ()  # a run stopped at the wall is another output set
    extra += ("all_poses",) if all_poses else ()  # so is one that writes every pose
    settings_parts = (*trajectory_parts(tr), robot.to_dict(), solver, solver_options, body_modules, *extra)
    if folder is None and use_folder:
        name = run_folder_name(f"{folder_stem(traj, traj_params.get('seed'))}-{solver}", *settings_parts)
        folder = OutputFolder(Path("bhr-out") / name, "follow", inputs=inputs,
                              force=force).check()
    if folder is not None:  # what makes the results: a rerun with the same keeps what it does not redraw
        folder.settings = run_folder_name("", *settings_parts).rsplit("-", 1)[1]
    json_inside = json_in_folder(json_path, folder, FOLLOW_NAMES) if folder is not None else None
    anim_inside = None
    if folder is not None and animate_path is not None:
        taken = FOLLOW_NAMES + ((json_inside,) if json_inside else ())
        anim_inside = json_in_folder(animate_path, folder, taken, "--animate")

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BhrWarning)
        outcome = None
        if stream is None:
            from bhr._run.driver import follow

            with status(f"following {tr.name} ({len(tr.points)} steps, solver {solver}"
                        f"{_describe(body_modules, reach, locomotion)})"):
                result = follow(tr, solver=solver, robot=robot, solver_options=solver_options,
                                body_modules=body_modules, reach=reach, locomotion=locomotion,
                                stop_at_wall=stop_at_wall, all_poses=all_poses)
        else:
            result, outcome = _follow_streaming(tr, solver, robot, solver_options, thermal, rate, stream, say)
    messages = list(dict.fromkeys(str(w.message) for w in caught if issubclass(w.category, BhrWarning)))

    with status("writing run.json"):
        doc = result.to_dict()
    run = FollowRun(result, doc, [], folder.final("") if folder is not None else None, stream=outcome,
                    warnings=messages)
    written = run.written
    codes = result.board_codes  # every module the board drives: the whole robot when it has a body
    if folder is not None:
        from bhr.model._codes import format_codes_csv
        from bhr.output._steptable import STEPS_CSV, format_steps_csv

        with folder:
            stage = folder.stage
            assert stage is not None  # inside the with block
            if codes is not None:
                write_text(folder.path("codes.csv"), format_codes_csv(codes))
                written.append(folder.final("codes.csv"))
            if json_path is None or json_inside is not None:
                name = json_inside or "run.json"
                write_json(folder.path(name), doc)
                written.append(folder.final(name))
            write_text(folder.path(STEPS_CSV), format_steps_csv(result))  # the errors per step, for a spreadsheet
            written.append(folder.final(STEPS_CSV))
            if getattr(result, "motion", None) is not None and result.motion.kept:  # every pose (docs/locomotion.md)
                from bhr.output._steptable import write_poses

                write_poses(result, folder.path("poses.npz"))
                written.append(folder.final("poses.npz"))
            if plots:
                from bhr.output._run_plots import save_run_plots

                with status(f"drawing the figures into {folder.final('')}"):
                    written += [folder.final(p.name) for p in save_run_plots(result, stage)]
                from bhr.output._view import save_view

                with status("writing the 3-D view"):
                    written.append(folder.final(save_view(result, stage).name))
            if anim_inside is not None:  # an animation inside the folder belongs to its set
                run.animations.append(_animate(result, folder.path(anim_inside), stride, frames_progress,
                                               folder.final(anim_inside)))
            elif animate_path is not None:  # rendered before the folder goes in place: a Ctrl-C while it renders
                run.animations.append(_animate(result, animate_path, stride, frames_progress, None))  # leaves none
            if json_path not in (None, "-") and json_inside is None:
                write_json(json_path, doc)  # before the folder goes in place: a failure here keeps the old set
                written.append(Path(json_path))
        if out_dir is None:
            from bhr.output._atomic import point_latest

            point_latest(folder.target)  # bhr-out/latest: the run just written
    elif json_path not in (None, "-"):
        write_json(json_path, doc)
        written.append(Path(json_path))
    if codes is not None and stream is None and folder is not None:
        from bhr._hardware.thermal import auto_schedule

        from bhr._hardware.thermal import pace

        sched = auto_schedule(thermal, codes, rate, trace=False)  # memory: not per step
        run.procedure_s, run.procedure_pace, run.procedure_rate = sched.total_s, pace(sched), float(rate)
    if animate_path is not None and anim_inside is None and folder is None:
        run.animations.append(_animate(result, animate_path, stride, frames_progress, None))
    return run


def _animate(result, path, stride, progress, shown):
    from bhr.output._animate import animate

    anim = animate(result, path, stride=stride, progress=progress)
    return anim, shown or anim.path


def _follow_streaming(tr, solver, robot, solver_options, thermal, rate, s: StreamSettings, say):
    """Solve the run, check its codes against the wires' thermal model, then stream them (``bhr follow --port``).

    The stream itself is bhr._hardware.link.run_stream, as in ``bhr stream``; after the last step one explicit
    message goes to the board (``at_end``): stop-all, or a heartbeat that holds the last codes until its silence
    timeout.
    """
    from bhr._hardware.link import BoardLink, Pacer, check_board, refuse_overheat, run_stream, with_stop_all
    from bhr._settings.errors import LinkError
    from bhr._hardware.thermal import plan
    from bhr._run.driver import follow

    order = s.link_args.get("module_order")
    if order is not None and len(order) != robot.modules:
        raise BhrError(f"the robot file's link.module_order lists {len(order)} modules but the robot has "
                       f"{robot.modules}; make them agree")
    with BoardLink(s.port, **s.link_args) as link:
        board = check_board(link, robot.modules)  # a wrong board is refused before the solve
        try:
            refuse_overheat(link, board["faults"])  # so is a board with a latched overheat
        except LinkError as exc:
            raise LinkError(with_stop_all(link, str(exc))) from None
        result = follow(tr, solver=solver, robot=robot, solver_options=solver_options)
        if result.codes is None:
            Pacer(link, rate)(1, None)  # the one-line refusal of code-less solvers
        rows = result.codes
        assert rows is not None  # refused just above
        sched = plan(thermal, rows, rate, s.schedule, name=tr.name, sending=True, trace=False)
        held = [f for f in board["faults"] if f != "silence"]  # silence: the board was idle, which is fine
        if held:
            say(f"Warning: board on {s.port} reports {', '.join(held)} before the run (latched faults stay "
                "until stop-all; a cooling module is waited for)")
        times = (sched.times_ms / 1000.0).tolist() if s.schedule == "auto" else None
        try:
            report = run_stream(link, rows, rate, times=times, on_fault=s.on_fault, known_faults=board["faults"],
                                wait_ready=True, wait_relaxed=s.schedule == "auto", at_end=s.at_end,
                                progress=s.progress)
        except KeyboardInterrupt as exc:  # bhr._hardware.link.StreamInterrupted: how many of how many
            exc.total = len(rows)  # type: ignore[attr-defined]
            raise
    from bhr._hardware.thermal import pace

    how = pace(sched, counts=False)
    settle = sched.total_s - float(sched.times_ms[-1]) / 1000.0  # the last step's contraction
    outcome = StreamOutcome(report.sent, robot.modules, s.port, how, report.elapsed_s + settle, sched.total_s,
                            s.at_end, list(report.fault_events))
    return result, outcome


def trajectory_parts(tr: Any) -> tuple[Any, ...]:
    """What of a trajectory makes a run's results, for its folder's settings hash: the points, the lumen, and how
    the lumen ends when it is open (a closed end, the default, adds nothing, so earlier folders keep their names)."""
    parts: tuple[Any, ...] = (tr.points, tr.lumen if tr.lumen is not None else 0)
    end = getattr(tr, "lumen_end", "closed")
    return parts + (("lumen_end", end),) if tr.lumen is not None and end != "closed" else parts


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
    lines += section_lines(result, s)
    # the verdict's reason is one of the lines above, except for a run that followed
    why = f" ({s['verdict_reason']})" if s["verdict"] == "followed" else ""
    lines.append(f"Finished: {s['finished']}. Verdict: {s['verdict']}{why}.")
    return lines


def section_lines(result, s: dict) -> list[str]:
    """Where the trajectory has anatomical sections: the steps touching the wall in each (a step targets the
    trajectory point of its number)."""
    sections = getattr(result.trajectory, "sections", ())
    touch = s.get("wall_touch_steps")
    if not sections or touch is None:
        return []
    parts = []
    for name, a, b in sections:
        lo, hi = a + 1, min(b, result.steps)
        if lo > hi:
            continue
        k = sum(1 for t in touch if lo <= t <= hi)
        parts.append(f"{name} {k} of {hi - lo + 1}")
    return ["Wall touched by section (steps): " + ", ".join(parts) + "."] if parts else []


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


def _feeder(s: dict) -> str:
    """Where a whole robot on a trail stopped: the feeder's last step, past the path's end (the trail weaves
    about the centerline, so the tip needs more insertion than the path's length), and the tip's shortfall."""
    past = int(s.get("cecum_approach_steps") or 0)
    beyond = f" ({past} past the path's end: the trail weaves about the centerline)" if past else ""
    short = float(s["cecum_shortfall_mm"])
    tip = "the tip at the cecum" if short == 0.0 else f"the tip {short:.1f} mm short of the path's end"
    return f"the feeder pushes until step {s['feeder_stop_step']}{beyond}, {tip}"


def body_clearance_lines(s: dict) -> list[str]:
    """The whole body's errors and the lumen clearance, when the run has them (summary keys)."""
    from bhr._run.clearance import step_ranges

    out = []
    if s.get("locomotion") == "trail":
        # the procedure time is the one line bhr follow prints for the board's schedule of codes.csv (as bhr plan
        # computes it), not a second estimate here
        out.append(f"Trail: {s['trail_vertices']} vertices, every module along it (exact follow-the-leader, within "
                   f"{s['trail_offset_bound_mm']:.2f} mm of the trail); {_feeder(s)}.")
    if s.get("locomotion") == "wires":
        # as for the trail: the procedure time is the one line bhr follow prints for the board's schedule of
        # codes.csv (as bhr plan computes it); the motion's own duration is run.json's procedure_time_s
        where = f" in {s['poses_file']}" if s["poses_file"] else " (too many to keep: each scored, none written; " \
            "--all-poses writes them)"
        ways = ", ".join(f"{k} {v}" for k, v in sorted(s["switching"].items(), key=lambda kv: -kv[1]))
        feeder = _feeder(s) if s.get("feeder_stop_step") else "the feeder pushing"
        if s.get("too_short_for_cecum"):
            feeder += (": the robot is too short to reach the cecum (its tail reached the anus), so it cannot "
                       "traverse this colon; give more --body-modules or --reach cecum")
        out.append(f"Wires: rigid modules driven by their wires along a trail of {s['trail_vertices']} vertices; "
                   f"{s['poses']} poses{where}, the robot up to {s['max_trail_offset_mm']:.1f} mm off "
                   f"the trail between module lengths (switching: {ways}); {feeder}.")
    if s.get("locomotion") not in ("trail", "wires") and s.get("feeder_stop_step"):
        if s.get("left_lumen_step") is not None and s["left_lumen_step"] <= s["feeder_stop_step"]:
            # a robot outside the colon reached no cecum: its tip only came to the path's end through the wall
            out.append(f"The tip came to the end of the path at step {s['feeder_stop_step']} of {s['steps']} after "
                       f"leaving the lumen at step {s['left_lumen_step']}: it did not reach the cecum.")
        else:
            out.append(f"The tip reached the cecum at step {s['feeder_stop_step']} of {s['steps']}: the feeder "
                       "stopped there and the robot holds its pose.")
    if "body_modules" in s:
        out.append(f"Whole body: {s['body_modules']} modules; the body behind the head is off the path by at most "
                   f"{s['body_points_max_error_mm']:.3f} mm (step {s['body_worst_step']}).")
    if "min_clearance_mm" in s:
        if s["min_clearance_mm"] is None:
            out.append("Lumen clearance: no point of the robot reached the path yet.")
        else:
            out.append(f"Lumen clearance: minimum {s['min_clearance_mm']:.3f} mm at step {s['min_clearance_step']}, "
                       f"{s['min_clearance_point']}; wall: {s.get('wall', 'tube')}.")
        touch = s["wall_touch_steps"]
        out.append(f"Wall touched at {len(touch)} step{'s' if len(touch) != 1 else ''}"
                   + (f": {step_ranges(touch)}." if touch else "."))
        if s.get("left_lumen_reason"):
            out.append(f"The robot {s['left_lumen_reason']}.")
    if s.get("stopped_at_wall_step"):
        out.append(f"Stopped at the wall: the run ended at step {s['stopped_at_wall_step']} of the path's "
                   f"{s['path_steps']}, where the robot left the lumen (--stop-at-wall).")
    return out
