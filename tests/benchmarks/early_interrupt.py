"""How a Ctrl-C in the bhr command's first milliseconds ends: a SIGINT to the process group (a terminal's Ctrl-C)
DELAY after the command was started, REPEAT times per delay; prints per delay how many ended in "Interrupted." and
exit status 130, and how many by the signal (docs/commands.md, Ctrl-C).

    python tests/benchmarks/early_interrupt.py [REPEAT]
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from tests.conftest import bhr_exe  # noqa: E402

DELAYS_MS = (0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0)


def main() -> None:
    repeat = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    with tempfile.TemporaryDirectory() as cwd:
        for ms in DELAYS_MS:
            ends: Counter[str] = Counter()
            for _ in range(repeat):
                p = subprocess.Popen(bhr_exe() + ["fk", "--codes", "0,3"], cwd=cwd, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True, start_new_session=True)
                time.sleep(ms / 1000)
                os.killpg(p.pid, signal.SIGINT)
                _, err = p.communicate(timeout=60)
                if p.returncode == 130 and err == "Interrupted.\n":
                    ends["Interrupted."] += 1
                elif p.returncode < 0:
                    ends[f"signal {-p.returncode}"] += 1
                else:
                    ends[f"exit {p.returncode}"] += 1
            print(f"{ms:5.1f} ms: " + ", ".join(f"{v} {k}" for k, v in sorted(ends.items())))


if __name__ == "__main__":
    main()
