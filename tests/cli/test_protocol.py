"""bhr._hardware.protocol: frames, CRC, status parsing and the resynchronizing stream decoder: the tests that run the bhr command."""
from __future__ import annotations


def test_protocol_imports_without_click():
    import subprocess
    import sys

    code = ("import sys; sys.modules['click'] = None; import bhr._hardware.protocol, bhr._hardware.link; "
            "print(bhr._hardware.protocol.crc16(b'123456789'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == str(0x29B1)


def test_a_dry_run_takes_what_one_board_drives_and_no_more(run_bhr_in_process, tmp_path):
    """A dry run of a 60-module body run said the thermal model accepts it; no board drives more than 32 modules,
    so the real stream is refused: the dry run now refuses it too, and 32 modules still pass."""
    for n, ok in ((32, True), (60, False)):
        (tmp_path / "c.csv").write_text("step," + ",".join(f"m{i}" for i in range(1, n + 1)) + "\n"
                                        + "".join(f"{s}" + ",0" * n + "\n" for s in (1, 2)))
        res = run_bhr_in_process("stream", "--codes", "c.csv", "--dry-run")
        assert (res.returncode == 0) == ok, res.stderr
        if not ok:
            assert res.stderr == ("Error: c.csv has 60 modules, and one board drives at most 32; stream the codes of a "
                                  "robot of at most 32 modules (a run without --body-modules)\n")
            assert res.stdout == ""
