"""The ``bhr`` console script: a click group whose commands load lazily."""
from __future__ import annotations

import errno
import importlib
import io
import os
import sys
from typing import NoReturn

import click

from bhr.cli._interrupt import end_interrupted, install, settle
from bhr._settings.errors import INTERRUPTED

# command name -> "module:attribute", imported only when the command runs.
COMMANDS: dict[str, tuple[str, str]] = {
    "solve": ("bhr.cli.solve:solve", "Solve one target (fabrik, ccd, thesis, constrained, optimal, lumen)."),
    "follow": ("bhr.cli.follow:follow", "Follow a trajectory; write error plots, codes.csv and JSON."),
    "fk": ("bhr.cli.fk:fk", "Forward kinematics: chain points from module codes."),
    "workspace": ("bhr.cli.workspace:workspace", "Every reachable tip of a binary robot: figure and indices."),
    "bench": ("bhr.cli.bench:bench", "Time bhr against numpy implementations of the same algorithms."),
    "replay": ("bhr.cli.replay:replay", "Redraw or re-animate a saved run without solving again."),
    "compare": ("bhr.cli.compare:compare", "Run one trajectory with several solvers; print and plot their errors."),
    "stream": ("bhr.cli.stream:stream", "Send a codes.csv to the actuator board over a serial port."),
    "status": ("bhr.cli.status:status", "Ask the actuator board for its current codes and faults."),
    "plan": ("bhr.cli.plan:plan", "Plan a codes.csv against the wires' thermal model: schedule and procedure time."),
    "report": ("bhr.cli.report:report", "Run a batch file of follow runs; write an HTML report, CSV and JSON."),
    "sweep": ("bhr.cli.sweep:sweep", "Sweep robot designs over trajectories, locally or on a Dask cluster."),
    "traverse": ("bhr.cli.traverse:traverse", "Which robot designs get through a population of anatomical colons."),
    "export": ("bhr.cli.export:export", "Write the robot as a URDF or MJCF model (pinocchio, MuJoCo)."),
    "import": ("bhr.cli.import_:import_", "Import a colon (surface mesh, centerline, segmentation) as a trajectory."),
    "physics": ("bhr.cli.physics:physics", "Replay a run in MuJoCo against the colon wall: contact forces."),
    "warmup": ("bhr.cli.warmup:warmup", "Compile every command's kernels now (otherwise each compiles on first use)."),
}


class LazyGroup(click.Group):
    """A group that imports a command's module only when it is needed.

    Usage errors are reported as one line (``Error: ... (see 'bhr CMD --help')``)
    instead of click's usage block, so every bad input costs one line.
    """

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            self._run(args, prog_name, complete_var, **extra)
        finally:  # the command has ended (outputs written or not): a Ctrl-C from now on changes nothing
            settle()

    def _run(self, args, prog_name, complete_var, **extra):
        try:
            rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.UsageError as exc:
            if type(exc).__name__ == "NoArgsIsHelpError":  # `bhr` alone (click >= 8.2): the help, not an error line
                exc.show()
                sys.exit(exc.exit_code)
            where = exc.ctx.command_path if exc.ctx is not None else "bhr"
            if where == "bhr":  # an error while parsing a command's options: point to that command's help
                words = list(sys.argv[1:] if args is None else args)
                cmd = next((w for w in words if not w.startswith("-")), None)
                if cmd in COMMANDS:
                    where = f"bhr {cmd}"
            click.echo(f"Error: {exc.format_message()} (see '{where} --help')", err=True)
            sys.exit(exc.exit_code)
        except click.ClickException as exc:
            exc.show()
            sys.exit(exc.exit_code)
        except click.Abort as exc:
            if INTERRUPTED.is_set() or isinstance(exc.__cause__, KeyboardInterrupt):  # click's Abort of a Ctrl-C
                end_interrupted()
            click.echo("Aborted.", err=True)
            sys.exit(1)
        except (EOFError, KeyboardInterrupt):
            end_interrupted()
        except Exception:
            # a signal's KeyboardInterrupt raised inside a library's callback can come back as that library's
            # error (matplotlib's renderer: "ValueError: Invalid bounding box"): the interrupt is what happened
            if INTERRUPTED.is_set():
                end_interrupted()
            raise
        if INTERRUPTED.is_set():  # a Ctrl-C that something caught on the way: still honoured
            end_interrupted()
        sys.exit(rv if isinstance(rv, int) else 0)

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:  # before click's main turns it into Abort (and an empty line)
            end_interrupted()

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in COMMANDS:
            return None
        target, _ = COMMANDS[name]
        module_name, attr = target.split(":")
        module = importlib.import_module(module_name)
        return getattr(module, attr)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        # Short help from the table, so --help imports no command module.
        rows = [(name, COMMANDS[name][1]) for name in self.list_commands(ctx)]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="bhr")
def main() -> None:
    """Make a binary hyper-redundant endoscope robot follow a path.

    Start with `bhr follow --traj colon`; `bhr COMMAND --help` explains each command.
    """


def run() -> NoReturn:
    """The ``bhr`` program (its ``[project.scripts]`` entry point, and ``python -m bhr.cli.main``; tests that call
    :func:`main` in-process are unaffected): Ctrl-C, SIGTERM and SIGHUP raise KeyboardInterrupt (unless the caller
    ignored them), then the command, then the end of the process.

    Once a command has ended, its outputs written and closed, what is left of a normal exit is Python freeing
    every object the command made and collecting the cycles of its figures: about 0.4 s of CPU after
    ``bhr follow --traj colon``, a fifth of the command (docs/performance.md). So the process ends as Python's
    exit would, without that tidy-up: the exit handlers run (``atexit``: multiprocessing's and
    weakref.finalize's clean-ups, logging's flush), standard output and
    standard error are flushed, then ``os._exit`` with the command's exit status. Where anything else may still
    need Python's own exit (a thread still running, unless a signal ended the command; an exit status that is not
    a number; a stream that cannot be flushed), Python's exit is used, as before.
    """
    install()
    _hold_closed_streams()
    try:
        main()
        code: str | int | None = 0
    except SystemExit as exc:
        code = exc.code
    if code is None:
        code = 0
    if not isinstance(code, int) or isinstance(code, bool) or not -2**31 <= code < 2**31:
        sys.exit(code)
    _leave(code)


class _ClosedStream(io.TextIOBase):
    """A standard stream the caller closed (``bhr ... >&-``, ``<&-``): every read or write fails with one OSError
    naming the stream, which the command's guard turns into its one line (Python itself would have left it None:
    a traceback at the first print, or a summary silently dropped while the folder is written)."""

    def __init__(self, name: str) -> None:
        super().__init__()
        self._name = name

    @property
    def encoding(self) -> str:  # type: ignore[override]
        return "utf-8"

    @property
    def errors(self) -> str:  # type: ignore[override]
        return "strict"

    @property
    def buffer(self) -> "_ClosedStream":
        return self

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def _fail(self, *args: object) -> NoReturn:
        raise OSError(errno.EBADF, "closed by the caller", self._name)

    read = readline = write = _fail  # type: ignore[assignment]

    def flush(self) -> None:
        pass


def _hold_closed_streams() -> None:
    """Standard input, output or error closed by the caller: the descriptor is held by /dev/null, so that no file
    bhr opens takes its number (a library writing to descriptor 2 would write into it, a worker would inherit it),
    and the stream fails in one line when the command reads or writes it (standard error, which nothing can then
    show, goes to /dev/null: the exit status still tells)."""
    for fd, name in ((0, "stdin"), (1, "stdout"), (2, "stderr")):
        try:
            os.fstat(fd)
            continue
        except OSError:
            pass
        try:
            held = os.open(os.devnull, os.O_RDWR)
            if held != fd:
                os.dup2(held, fd)
                os.close(held)
        except OSError:
            continue
        if name == "stderr":
            sys.stderr = open(fd, "w", closefd=False)  # noqa: SIM115 - the process's own stream
        else:
            setattr(sys, name, _ClosedStream("standard input" if fd == 0 else "standard output"))


def _leave(code: int) -> NoReturn:
    """End the process with ``code`` after the exit handlers and the flush of the standard streams (see :func:`run`)."""
    import atexit
    import threading

    # Python's exit waits for the other threads; a command ended by a signal (128 + its number) has discarded
    # its outputs and stopped its workers, and waits for no thread (one blocked on a killed worker's pipe would
    # never end)
    interrupted = code > 128
    if threading.active_count() > 1 and not interrupted:
        sys.exit(code)
    atexit._run_exitfuncs()
    if threading.active_count() > 1 and not interrupted:
        sys.exit(code)
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # a closed pipe, a full disk: Python's exit says so, as before
            sys.exit(code)
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
