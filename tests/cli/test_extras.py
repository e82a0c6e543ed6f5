"""The command an error prints to install an optional part (physics, dask) runs as printed.

It used to print ``pip install 'bhr[physics]'``: no index has bhr (it is installed from its source
folder), and a bare ``pip`` may belong to another Python. The command now names this Python and
the folder bhr was installed from (PEP 610's direct_url.json), read here through real
distributions on ``sys.path`` in a subprocess.
"""
from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from bhr._settings.extras import install_command, source_folder

REPO = Path(__file__).resolve().parents[2]


def _extras_of(folder: Path) -> dict:
    return tomllib.loads((folder / "pyproject.toml").read_text())["project"]["optional-dependencies"]


@pytest.mark.parametrize("extra", ["physics", "dask"])
def test_the_command_names_this_python_and_a_folder_that_declares_the_extra(extra):
    argv = shlex.split(install_command(extra))
    assert argv[:4] == [sys.executable, "-m", "pip", "install"] and len(argv) == 5
    target = argv[4]
    assert target.endswith(f"[{extra}]")
    folder = Path(target[: -len(f"[{extra}]")])
    assert folder == source_folder()
    assert extra in _extras_of(folder)  # pip would install exactly that extra of this very project
    # the tests run from an editable install of this checkout
    assert folder.resolve() == REPO


def _command_with(tmp_path: Path, direct_url: dict | None, extra: str = "physics") -> str:
    """install_command in a fresh Python that finds a bhr distribution with this direct_url.json first."""
    site = tmp_path / "site"
    info = site / "bhr-99.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: bhr\nVersion: 99.0\n")
    if direct_url is not None:
        (info / "direct_url.json").write_text(json.dumps(direct_url))
    code = "from bhr._settings.extras import install_command; print(install_command(%r))" % extra
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(REPO)])}
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True,
                         check=True)
    return out.stdout.strip()


def _source(folder: Path) -> Path:
    folder.mkdir(parents=True)
    (folder / "pyproject.toml").write_text('[project]\nname = "bhr"\n'
                                           '[project.optional-dependencies]\nphysics = ["mujoco"]\n')
    return folder


@pytest.mark.parametrize("name", ["src", "my bhr", "it's [here]", "dollar $HOME"])
def test_a_folder_install_names_that_folder_quoted_for_the_shell(tmp_path, name):
    src = _source(tmp_path / name)
    cmd = _command_with(tmp_path, {"url": src.as_uri(), "dir_info": {}})
    assert shlex.split(cmd) == [sys.executable, "-m", "pip", "install", f"{src}[physics]"]
    # and a POSIX shell hands pip that same argument
    echoed = subprocess.run(["sh", "-c", cmd.replace(" -m pip install ", " -c 'import sys; print(sys.argv[1])' ")],
                            capture_output=True, text=True, check=True).stdout
    assert echoed == f"{src}[physics]\n"


def test_an_editable_install_names_its_folder(tmp_path):
    src = _source(tmp_path / "checkout")
    cmd = _command_with(tmp_path, {"url": src.as_uri(), "dir_info": {"editable": True}})
    assert shlex.split(cmd)[4] == f"{src}[physics]"


@pytest.mark.parametrize("direct_url", [
    None,  # installed from an index: no direct_url.json
    {"url": "https://example.org/bhr-1.0.tar.gz", "archive_info": {}},  # an archive: no folder to point at
    {"url": "file:///no/such/folder", "dir_info": {}},  # the folder was deleted since
    {"url": "file:///", "dir_info": {}},  # a folder, but not bhr's
])
def test_without_a_usable_folder_it_falls_back_to_this_copys_source_folder(tmp_path, direct_url):
    cmd = _command_with(tmp_path, direct_url)
    assert shlex.split(cmd)[4] == f"{REPO}[physics]"  # the tests import bhr from this checkout


def test_the_physics_and_dask_errors_carry_the_command():
    from bhr._studies.cluster import dask_missing
    from bhr._studies.physics import missing

    assert missing("mujoco") == f"mujoco is not installed; install the physics extra: {install_command('physics')}"
    assert dask_missing().endswith(f"install it with: {install_command('dask')}")
    assert "\n" not in missing("pinocchio") + dask_missing()
