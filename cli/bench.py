"""bhr bench: time bhr against plain numpy implementations of the same algorithms."""
from __future__ import annotations

import json

import click

from bhr.cli._common import check_writable, guarded
from bhr.cli._options import PlainIntRange


@click.command()
@click.option("--case", "cases", multiple=True, metavar="NAME",
              help="Case to run (repeatable): fabrik, ccd, thesis-colon, optimal, body-60, lumen, trail-300, "
                   "study-100, physics-300, cli, first-run [all].")
@click.option("--repeat", type=PlainIntRange(1, 100), default=None, help="Repeats per timing (median taken).")
@click.option("--json", "json_path", default=None, metavar="PATH|-",
              help="Write the results as JSON ('-': stdout, the table then goes to stderr).")
@click.option("--check", is_flag=True, help="Exit with status 1 when a stated requirement is not met.")
@guarded
def bench(cases, repeat, json_path, check):
    """Time bhr's compiled code against numpy references, in the same process.

    Every figure is a median over repeats; the ratio is reference time / bhr
    time measured in the same run. Results depend on the machine: quote them
    with the machine and this command.

    \b
        bhr bench --case thesis-colon --repeat 9
    """
    from bhr._bench import cases as b
    from bhr.cli._progress import announce_compiles, status
    from bhr._settings.errors import BhrError

    check_writable(json_path, "JSON")
    names = [b.CASE_ALIASES.get(c, c) for c in cases] or list(b.CASES)
    unknown = [c for c in names if c not in b.CASES]
    if unknown:
        raise BhrError(f"unknown benchmark case {unknown[0]!r}; choose from {', '.join(b.CASES)}")
    announce_compiles()
    with status(f"timing {len(names)} case{'s' * (len(names) != 1)}", total=len(names)) as bar:
        def progress(name: str) -> None:
            if bar.item:
                bar.update(1)
            bar.item = name

        results = b.run_all(names, repeat, progress=progress)
    # with --json - the JSON alone goes to stdout (parseable), the table to stderr
    click.echo(b.format_table(results), err=json_path == "-")
    doc = [r.to_dict() for r in results]
    if json_path == "-":
        click.echo(json.dumps(doc, indent=1))
    elif json_path:
        from bhr.output._atomic import write_json

        write_json(json_path, doc)
    if check and any(r.ok is False for r in results):
        raise BhrError("some benchmark requirements were not met (see the 'ok' column)")
