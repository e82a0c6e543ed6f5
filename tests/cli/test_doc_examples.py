"""Every `bhr ...` example in README.md and docs/*.md is a command line bhr accepts as printed.

Each example (a line of a fenced code block starting with ``bhr ``, with its ``\\`` continuations joined, a
trailing ``# comment`` dropped, and cut at ``;``, ``&&`` or ``|`` where a shell line goes on with another
program) is parsed by the real click commands: every option must exist, every value must convert and be in the
registry's limits. The examples are not run here (some stream to a board or take minutes); parsing is what goes
stale when an option is renamed, removed or narrowed.
"""
from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"```[a-z]*\n(.*?)```", re.S)


def examples(path: Path) -> list[str]:
    out = []
    for block in BLOCK.findall(path.read_text(encoding="utf-8")):
        lines = block.splitlines()
        i = 0
        while i < len(lines):
            line = lines[i]
            while line.rstrip().endswith("\\") and i + 1 < len(lines):
                i += 1
                line = line.rstrip()[:-1] + " " + lines[i].strip()
            i += 1
            if re.match(r"\s*bhr [a-z]", line):
                out.append(line)
    return out


def command_of(line: str) -> list[str]:
    """The argv of the bhr command on a shell line: comment dropped, cut where another command starts."""
    argv = []
    for word in shlex.split(line, comments=True):
        if word in (";", "&&", "||", "|") or word.startswith(("|", ";")):
            break
        if word.endswith(";"):
            argv.append(word[:-1])
            break
        argv.append(word)
    assert argv[0] == "bhr"
    return argv[1:]


CASES = [(p.relative_to(ROOT).as_posix(), line.strip()) for p in DOCS for line in examples(p)]


def test_the_docs_have_examples():
    # the collection itself can fail: a change of the docs' layout must not leave this test checking nothing
    assert len(CASES) >= 40
    assert sum(f == "README.md" for f, _ in CASES) >= 10


@pytest.mark.parametrize("where,line", CASES, ids=[f"{f}:{i}" for i, (f, _) in enumerate(CASES)])
def test_example_parses(where, line):
    from bhr.cli.main import main

    argv = command_of(line)
    ctx = main.make_context("bhr", list(argv))
    sub = main.get_command(ctx, argv[0])
    assert sub is not None, f"{where}: unknown command in {line!r}"
    try:
        sub.make_context(argv[0], argv[1:], parent=ctx)
    except click.exceptions.Exit:
        pass
    except click.ClickException as exc:
        pytest.fail(f"{where}: {line!r} is refused: {exc.format_message()}")


@pytest.mark.parametrize("line,argv", [
    ("bhr fk --codes 3,0,6  # forward kinematics", ["fk", "--codes", "3,0,6"]),
    ("bhr stream --port $PTY --codes /tmp/one.csv; sleep 3", ["stream", "--port", "$PTY", "--codes", "/tmp/one.csv"]),
    ("bhr follow --traj colon --json - | python -c 'x'", ["follow", "--traj", "colon", "--json", "-"]),
])
def test_command_of_cuts_the_shell_line(line, argv):
    assert command_of(line) == argv


def test_a_stale_example_is_caught():
    from bhr.cli.main import main

    argv = command_of("bhr traverse --colons 1-20 --no-such-option")
    ctx = main.make_context("bhr", list(argv))
    with pytest.raises(click.ClickException):
        main.get_command(ctx, argv[0]).make_context(argv[0], argv[1:], parent=ctx)


# ------------------------------------------------------------------ examples bhr itself prints or ships
# The examples in each command's --help (as rendered in an 80-column terminal) and in the shipped example
# files' comments are advice a user copies as printed: each must parse, must not be wrapped over two lines,
# and, as the README's, must write under bhr-out/ rather than into the folder the user runs it from.

OUTPUT_OPTIONS = ("--out", "--animate", "--plot", "--csv", "--json")


def help_examples() -> list[tuple[str, str]]:
    from click.testing import CliRunner

    from bhr.cli.main import COMMANDS, main

    out = []
    for name in sorted(COMMANDS):
        text = CliRunner().invoke(main, [name, "--help"], terminal_width=80).output
        for line in text.split("Options:")[0].splitlines():
            m = re.search(r"(?:^\s+|Example: )(bhr [a-z].*)$", line)
            if m:
                out.append((f"bhr {name} --help", m.group(1).strip()))
    return out


def shipped_file_examples() -> list[tuple[str, str]]:
    out = []
    for path in sorted([*(ROOT / "docs" / "examples").glob("*.toml"), *(ROOT / "trajectories").glob("*.toml")]):
        for line in path.read_text(encoding="utf-8").splitlines():
            m = re.match(r"#\s+(bhr [a-z].*)$", line)
            if m:
                out.append((path.relative_to(ROOT).as_posix(), m.group(1).strip()))
    return out


def outputs_of(argv: list[str]) -> list[str]:
    return [argv[i + 1] for i, w in enumerate(argv[:-1]) if w in OUTPUT_OPTIONS and argv[i + 1] != "-"]


def test_every_command_help_has_an_example_and_the_shipped_files_too():
    cmds = {where for where, _ in help_examples()}
    assert len(cmds) >= 14, sorted(cmds)
    assert len(shipped_file_examples()) >= 4


@pytest.mark.parametrize("where,line", help_examples() + shipped_file_examples())
def test_printed_example_parses_as_printed(where, line):
    test_example_parses(where, line)


USER_FACING = CASES  # README.md and every page of docs/: a reader copies any of them


@pytest.mark.parametrize("where,line", USER_FACING + help_examples() + shipped_file_examples())
def test_printed_example_writes_under_bhr_out(where, line):
    for path in outputs_of(command_of(line)):
        assert path.startswith("bhr-out/"), f"{where}: {line!r} writes {path}, outside bhr-out/"


# ------------------------------------------------------------------ one name per solver
# The thesis's solver is `thesis` wherever bhr shows it; `seed`, its old name, is accepted but never shown.
ALIAS_SHOWN = re.compile(r"--solver seed\b|solver=seed\b|\bseed solver\b|^\s*\d+\s+seed\s", re.M)
@pytest.mark.parametrize("page", DOCS, ids=lambda p: p.name)
def test_the_docs_show_the_thesis_solver_by_its_one_name(page):
    shown = [m.group(0) for m in ALIAS_SHOWN.finditer(page.read_text(encoding="utf-8"))]
    assert not shown, f"{page.name} shows the thesis's solver as 'seed': {shown[:3]}"


def test_the_optimal_benchmark_report_names_the_thesis_solver_thesis():
    from bhr._bench.optimal import format_report

    per = {"median_solve_s": 1e-3, "p90_solve_s": 2e-3, "compiled_loop_per_step_s": 1e-4}
    body = {"case": "colon", "modules": 60, "head_worst_mm": 1.0, "body_worst_mm": 2.0, "body_worst_step": 3,
            "min_clearance_mm": None}
    doc = {"ratios": [{"case": "curve", "steps": 85, "seed_worst_mm": 4.9, "optimal_worst_mm": 2.8, "ratio": 0.57,
                       "target": 0.6, "ok": True}],
           "times": {"case": "colon", "steps": 827, "modules": 5, "repeat": 3, "optimal": per, "seed": per,
                     "median_ratio_optimal_to_seed": 1.0, "loop_ratio_optimal_to_seed": 1.0},
           "body": [{**body, "solver": "optimal"}, {**body, "solver": "seed"}]}
    text = "\n".join(format_report(doc))
    assert "seed" not in text and "thesis" in text, text


def test_the_readme_wall_example_keeps_off_the_wall(run_bhr):
    """The README's `--solver lumen` example says it keeps off the wall of an anatomical colon; with the thesis's
    robot it went 29.6 mm into it (too stiff a robot for colon 7): the example names a design that gets through."""
    (line,) = [line for f, line in CASES if f == "README.md" and "keep off the wall" in line]
    argv = command_of(line)
    res = run_bhr(*argv, "--no-plots", "--json", "-", timeout=600)
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)["summary"]
    assert summary["wall_touch_steps"] == [] and summary["min_clearance_mm"] > 0, summary["min_clearance_mm"]


def test_bhr_help_names_every_solver_solve_takes():
    """`bhr --help` said solve uses 'FABRIK, CCD or the thesis's solver'; `bhr solve --help` lists six."""
    from click.testing import CliRunner

    from bhr.cli.main import main
    from bhr.solvers._names import BUILTIN

    text = " ".join(CliRunner().invoke(main, ["--help"], terminal_width=200).output.split())
    line = text[text.index("solve Solve"):text.index(" status ")]
    assert all(name in line for name in BUILTIN) and "seed" not in line, line
