"""bhr replay: redraw, watch or animate a saved run (run.json) without solving again.

Also home of the helpers that ``bhr follow --show/--animate`` share with it.
"""
from __future__ import annotations

import sys
from pathlib import Path

import click

from bhr.cli._common import check_writable, guarded, refuse_replacing_beside
from bhr.cli._options import PlainIntRange, force_option

STRIDE_HELP = ("Draw every Nth step (the last step always): frames of --animate [default: N keeping it at "
               "300 frames or fewer] and of --show [default: 1].")


def check_view_options(show: bool, animate_path: str | None) -> None:
    """Refuse, before any work, an animation that cannot be written or a window that cannot open."""
    if animate_path is not None:
        from bhr.output._animate import check_target

        check_target(animate_path)
        check_writable(animate_path, "animation")
    if show:
        from bhr.output._liveview import check_display

        check_display()


def render_animation(result, animate_path: str, stride: int | None, shown: Path | None = None) -> Path:
    """Render ``result`` to ``animate_path`` with a progress bar on stderr; print what was written."""
    from bhr.output._animate import animate, default_stride, frame_steps

    total = len(frame_steps(result.steps, stride or default_stride(result.steps)))
    from bhr.cli._progress import status

    with status(f"Rendering {animate_path}", total) as bar:
        anim = animate(result, animate_path, stride=stride, progress=bar.set)
    click.echo(f"Animation: {anim.frames} frames (every {anim.stride} step{'s' if anim.stride > 1 else ''} of "
               f"{result.steps}), {anim.bytes / 1e6:.2f} MB -> {shown or anim.path}")  # the summary: standard output
    return anim.path


def run_live_view(result, stride: int | None) -> None:
    """Open the live view (blocks until the user quits) and print what it showed. What the command wrote goes in
    place first, with the summary printed (a full standard output still leaves nothing), so that its folder is
    there while the window is open."""
    from bhr.output._atomic import place_now
    from bhr.output._liveview import keys_help, show

    place_now(check=sys.stdout.flush)
    click.echo(f"Live view: {keys_help()}", err=True)
    report = show(result, stride=stride or 1)
    click.echo(report.line(), err=True)


@click.command()
@click.argument("run", metavar="RUN.json")
@click.option("--show", is_flag=True, help="Watch the run step by step in a window (space, n/b, q).")
@click.option("--animate", "animate_path", default=None, metavar="FILE",
              help="Write an animation: FILE.gif (Pillow) or FILE.mp4 (needs ffmpeg).")
@click.option("--stride", type=PlainIntRange(min=1, max=10**9), default=None, metavar="N", help=STRIDE_HELP)
@click.option("--out", "out_dir", default=None, metavar="DIR",
              help="Write the error figures and path.png here [the run's folder, unless --show/--animate].")
@force_option
@click.option("--step", type=PlainIntRange(min=1, max=10**9), default=None, metavar="K",
              help="Draw the robot at step K in the path figure (path-stepK.png) [last step: path.png].")
@guarded
def replay(run, show, animate_path, stride, out_dir, force, step):
    """Redraw, watch or animate a run saved by `bhr follow`, without solving again.

    RUN.json is the run.json that `bhr follow` wrote ('-' reads it from
    standard input). With neither --show nor --animate it redraws the
    figures (errors, and the path with the robot) into --out.

        bhr replay bhr-out/latest/run.json --animate bhr-out/colon.gif
    """
    from bhr._run.driver import load_run

    import os

    from bhr.output._atomic import MANIFEST, OutputFolder, owning_folder

    write_plots = out_dir is not None or not (show or animate_path)
    out = Path(out_dir) if out_dir else (Path(run).parent if run != "-" else Path("bhr-out") / "replay")
    path_name = "path.png" if step is None else f"path-step{step}.png"
    folder = None
    inner = Path()  # where the figures go inside the folder put in place: a compare's or report's run is a level down
    if write_plots:
        # Into the run's own folder: the run's files are kept and the folder is replaced whole, figures redrawn.
        same = run != "-" and os.path.realpath(out) == os.path.realpath(Path(run).parent)
        owner = owning_folder(run) if same and not (out / MANIFEST).is_file() else None
        if owner is not None:  # a run inside a compare's or report's folder: that folder is put back whole
            inner = Path(owner[1]).parent
            folder = OutputFolder(owner[0], "replay", inputs=[run], keep=True).check()
        elif same and not (out / MANIFEST).is_file():
            check_writable(out / path_name, "output folder")  # a loose run.json: figures written beside it
        else:
            folder = OutputFolder(out, "replay", inputs=[run], keep=same, force=force).check()
    check_view_options(show, animate_path)
    result = load_run(run)
    if step is not None and step > result.steps:
        raise click.BadParameter(f"step {step} is past the end of the run ({result.steps} steps)",
                                 param_hint="'--step'")
    written: list[Path] = []
    if write_plots:
        from bhr.cli._progress import status
        from bhr.output._run_plots import run_plot_names, save_run_plots
        from bhr.output._view import VIEW_NAME, save_view

        if folder is None:
            refuse_replacing_beside(out, [*run_plot_names(result, step), VIEW_NAME], run,
                                    "move it away, or give --out DIR for the figures")

        drawing = f"drawing the figures into {out}"  # everything `bhr follow` drew
        if folder is None:  # a loose run.json: the figures are written beside it, each whole
            with status(drawing):
                written += save_run_plots(result, out, step)
                written.append(save_view(result, out))
        else:
            with folder:
                with status(drawing):
                    stage = folder.stage / inner
                    stage.mkdir(parents=True, exist_ok=True)
                    written += [out / p.name for p in save_run_plots(result, stage, step)]
                    written.append(out / save_view(result, stage).name)
                if animate_path:  # before the folder goes in place: a Ctrl-C while it renders leaves none
                    render_animation(result, animate_path, stride)
    if animate_path and folder is None:
        render_animation(result, animate_path, stride)  # prints its own line
    if written:
        click.echo("Wrote " + ", ".join(str(p) for p in written))
    if show:
        run_live_view(result, stride)
