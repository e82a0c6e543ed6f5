"""bhr report: run a batch of follow runs and write one HTML page, summary.csv and summary.json."""
from __future__ import annotations

import os
from pathlib import Path

import click

from bhr.cli._common import guarded
from bhr.cli._options import PlainIntRange


@click.command()
@click.option("--batch", "batch_path", required=True, metavar="FILE.toml",
              help="Batch file: [[run]] tables with name, traj, solver and options (see docs/report.md).")
@click.option("--out", "out_dir", default=None, metavar="DIR", help="Output folder [./bhr-out/<batch name>/].")
@click.option("--jobs", "-j", type=PlainIntRange(min=1, max=1024), default=None, metavar="N",
              help="Worker processes [the number of CPUs, at most one per run].")
@click.option("--inline-images", is_flag=True,
              help="Embed the figures in index.html, so the page is one file to share.")
@guarded
def report(batch_path, out_dir, jobs, inline_images):
    """Run every run of a batch file and write a report page.

    Writes DIR/index.html (the summary table, then each run's figures),
    DIR/summary.csv and DIR/summary.json (one row per run) and DIR/runs/NAME/
    (figures and run.json of each run). A failed run is recorded with its
    reason and the others still run; the exit status is 1 when any run failed.

        bhr report --batch docs/examples/chapter7.toml --out chapter7
    """
    from bhr.report import format_table, load_batch, run_batch

    from bhr.atomic import OutputFolder

    batch = load_batch(batch_path)
    out = Path(out_dir) if out_dir else Path("bhr-out") / Path(batch_path).stem
    folder = OutputFolder(out, "report", names=REPORT_NAMES, what="report folder").check()  # before any work
    total = len(batch.runs)
    workers = min(jobs or os.cpu_count() or 1, total)
    err = click.get_text_stream("stderr")
    with click.progressbar(length=total, label=f"Running {total} runs", file=err, show_pos=True,
                           item_show_func=lambda s: s) as bar:
        last = [0]

        def progress(done: int, _total: int, row: dict) -> None:
            bar.current_item = row["name"] if row["status"] == "ok" else f"{row['name']} FAILED"
            bar.update(done - last[0])
            last[0] = done

        with folder:  # runs/<name>/ of an earlier report never survive beside this one
            rep = run_batch(batch, folder.stage, jobs=workers, inline_images=inline_images, progress=progress)
    for line in format_table(rep.rows):
        click.echo(line)
    names = ", ".join(str(out / p.name) for p in rep.files())
    click.echo(f"Wrote {names} and {out / 'runs'}/ in {rep.wall_time_s:.1f} s")
    if rep.failed:
        click.echo(f"Error: {len(rep.failed)} of {total} runs failed; see {out / 'summary.csv'}", err=True)
        return 1
    return 0


#: What bhr report writes at the top of its folder (besides runs/).
REPORT_NAMES = ("index.html", "summary.csv", "summary.json", "manifest.json")
