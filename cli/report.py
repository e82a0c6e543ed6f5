"""bhr report: run a batch of follow runs and write one HTML page, summary.csv and summary.json."""
from __future__ import annotations

import os
from pathlib import Path

import click

from bhr.cli._common import guarded
from bhr.cli._options import PlainIntRange, force_option


@click.command()
@click.option("--file", "batch_path", default=None, metavar="FILE.toml",
              help="Batch file: [[run]] tables with name, traj, solver and options (see docs/report.md).")
@click.option("--batch", "batch_old", default=None, metavar="FILE.toml", hidden=True)  # the old spelling
@click.option("--out", "out_dir", default=None, metavar="DIR",
              help="Output folder [./bhr-out/<batch name>-<hash of the batch and its files>/].")
@force_option
@click.option("--jobs", "-j", type=PlainIntRange(min=1, max=1024), default=None, metavar="N",
              help="Worker processes [the number of CPUs, at most one per run].")
@click.option("--inline-images", is_flag=True,
              help="Embed the figures in index.html, so the page is one file to share.")
@click.option("--no-plots", is_flag=True, help="Skip the figures (the page has the tables only).")
@guarded
def report(batch_path, batch_old, out_dir, force, jobs, inline_images, no_plots):
    """Run every run of a batch file and write a report page.

    Writes DIR/index.html (the summary table, then each run's figures),
    DIR/summary.csv and DIR/summary.json (one row per run) and DIR/runs/NAME/
    (figures and run.json of each run). A failed run is recorded with its
    reason and the others still run; the exit status is 1 when any run failed.

        bhr report --file docs/examples/chapter7.toml --out bhr-out/chapter7
    """
    from bhr.cli._progress import announce_compiles, status
    from bhr._settings.errors import BhrError
    from bhr._studies.report import format_table, load_batch, run_batch

    if batch_path is not None and batch_old is not None:
        raise BhrError("--batch is the old name of --file; give the batch file once, with --file")
    batch_path = batch_path or batch_old
    if batch_path is None:
        raise BhrError("give the batch file: bhr report --file FILE.toml (see docs/report.md)")
    import dataclasses

    from bhr.cli._common import default_output, input_files, point_latest_if_default

    batch = load_batch(batch_path)
    inputs = input_files(batch_path, *(r.traj for r in batch.runs), *(r.robot_file for r in batch.runs))
    folder = default_output("report", Path(batch_path).stem, (dataclasses.asdict(batch), inline_images),
                            inputs, out_dir, what="report folder", force=force)  # before any work
    out = folder.final("")
    total = len(batch.runs)
    workers = min(jobs or os.cpu_count() or 1, total)
    announce_compiles()
    starting = f"(starting {workers} worker processes)" if workers > 1 else ""
    with status(f"Running {total} runs", total=total, log=True) as bar:
        bar.item = starting

        def progress(done: int, _total: int, row: dict) -> None:
            bar.update(done - bar.done, row["name"] if row["status"] == "ok" else f"{row['name']} FAILED")

        with folder:  # runs/<name>/ of an earlier report never survive beside this one
            rep = run_batch(batch, folder.stage, jobs=workers, plots=not no_plots, inline_images=inline_images,
                            progress=progress)
    point_latest_if_default(folder, out_dir)
    for line in format_table(rep.rows):
        click.echo(line)
    names = ", ".join(str(out / p.name) for p in rep.files())
    click.echo(f"Wrote {names} and {out / 'runs'}/ in {rep.wall_time_s:.1f} s")
    if rep.failed:
        click.echo(f"Error: {len(rep.failed)} of {total} runs failed; see {out / 'summary.csv'}", err=True)
        return 1
    return 0


#: What bhr report writes at the top of its folder (besides runs/).
