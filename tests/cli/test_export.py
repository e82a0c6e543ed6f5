"""bhr's robot in pinocchio and MuJoCo: the exported URDF/MJCF reproduce bhr's forward kinematics: the tests that run the bhr command."""
from __future__ import annotations

import pytest


@pytest.mark.parametrize("args,word", [
    (("--format", "sdf", "--out", "x"), "--format"),
    (("--format", "urdf", "--out", "x", "--robot", "missing.toml"), "missing.toml"),
    (("--format", "urdf", "--out", "x", "--modules", "5", "--body-modules", "3"), "body-modules"),
    # a model has no path: the run's --reach and --locomotion are not options of export (never silently ignored)
    (("--format", "urdf", "--out", "x", "--reach", "cecum"), "--reach"),
    (("--format", "mjcf", "--out", "x", "--locomotion", "trail"), "--locomotion"),
])
def test_export_bad_input_one_line(run_bhr_in_process, args, word):
    r = run_bhr_in_process("export", *args)
    assert r.returncode != 0
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0] and "Traceback" not in r.stderr
