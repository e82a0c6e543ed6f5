"""bhr warmup: compile every kernel bhr's commands run, once."""
from __future__ import annotations

import click

from bhr.cli._common import guarded


@click.command()
@guarded
def warmup():
    """Compile every command's kernels now (numba caches them), so that no later command compiles.

    Not needed: each command compiles the kernels it runs the first time it runs them.
    """
    from bhr import _numba
    from bhr.cli._progress import announce_compiles, status
    from bhr._warmup import compile_all

    announce_compiles()
    with status("compiling kernels"):
        compile_all()
    click.echo(f"bhr's kernels are compiled and cached in {_numba.configure_cache()}")
