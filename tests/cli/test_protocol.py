"""bhr.hardware.protocol: frames, CRC, status parsing and the resynchronizing stream decoder: the tests that run the bhr command."""
from __future__ import annotations


def test_protocol_imports_without_click():
    import subprocess
    import sys

    code = ("import sys; sys.modules['click'] = None; import bhr.hardware.protocol, bhr.hardware.link; "
            "print(bhr.hardware.protocol.crc16(b'123456789'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == str(0x29B1)
