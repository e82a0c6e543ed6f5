"""The thermal model of the actuator wires (bhr/thermal.py, docs/thermal.md): the tests that run the bhr command."""
from __future__ import annotations

import subprocess
import sys

from bhr._hardware.firmware_header import HEADER, render
from tests.unit.test_thermal import REPO  # noqa: F401


def test_the_checked_in_firmware_header_is_current():
    assert HEADER.read_text() == render(), "run 'python -m bhr._hardware.firmware_header' and commit firmware/src/bhr_gen.h"
    assert subprocess.run([sys.executable, "-m", "bhr._hardware.firmware_header", "--check"], cwd=REPO).returncode == 0
