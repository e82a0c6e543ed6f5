"""--traj's help names every trajectory name bhr accepts, and bhr accepts every name it names."""
from __future__ import annotations

import re

import pytest
from click.testing import CliRunner

from bhr.cli.main import main
from bhr.model._trajnames import builtin_names, check_trajectory_name, traj_help


@pytest.mark.parametrize("command", ["follow", "compare"])
def test_the_help_lists_every_accepted_name(command):
    out = CliRunner().invoke(main, [command, "--help"], terminal_width=400).output
    text = " ".join(out.split())
    assert "example_centerline" in builtin_names()
    for name in builtin_names():
        assert re.search(rf"\b{re.escape(name)}\b", text), (name, command)


def test_every_name_in_the_help_is_accepted():
    named = re.findall(r"[a-z][A-Za-z0-9_:-]*[A-Za-z0-9]", traj_help().split("or a trajectory file")[0])
    names = set(named) - {"seed", "shipped", "point", "file", "real"}
    assert "example_centerline" in names and "line" in names and "gca:VHM" in names
    for name in names:
        check_trajectory_name(name)  # raises for a name bhr does not know
