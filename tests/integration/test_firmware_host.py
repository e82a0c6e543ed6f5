"""The firmware's portable core (parser + state machine) built and tested on the host.

Runs `make -C firmware host-test`: C unit tests and a fuzzer that feeds at
least 100,000 random and mutated frames per build (5, 16 and 32 modules)
through the parser into the board model, under AddressSanitizer and
UndefinedBehaviorSanitizer, failing if an unstable code ever reaches the
output model. Then checks that the C and Python encoders agree byte for byte.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.conftest import make_firmware

from bhr._hardware import protocol as P

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / "firmware"


def need(tools: list[str]) -> None:
    missing = [t for t in tools if shutil.which(t) is None]
    if missing:
        msg = (f"firmware host tests need {', '.join(missing)}; install them (Debian: apt-get install "
               "build-essential make) or run 'bash tests/run'")
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)


@pytest.fixture(scope="module")
def host_test_run():
    need(["make", "cc"])
    r = make_firmware("-C", str(FIRMWARE), "host-test")
    return r


def test_host_unit_tests_and_fuzz_pass(host_test_run):
    r = host_test_run
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    runs = re.findall(r"fuzz: (\d+) random or mutated frames \((\d+) mutated, (\d+) random blobs\)", r.stdout)
    assert len(runs) == 3, r.stdout
    for total, mutated, blobs in runs:
        assert int(total) >= 100_000
        assert int(mutated) > 50_000 and int(blobs) > 10_000
    assert len(re.findall(r"^OK: \d+ checks passed", r.stdout, flags=re.M)) == 3
    for modules in ("5", "16", "32"):
        assert f"BHR_MODULES={modules} " in r.stdout


def test_c_and_python_frames_agree(host_test_run):
    assert host_test_run.returncode == 0
    exe = FIRMWARE / "build" / "host" / "test_host_m5"
    out = subprocess.run([str(exe), "vectors"], capture_output=True, text=True, timeout=60, check=True).stdout
    vec = dict(line.split(" ", 1) for line in out.splitlines())
    assert vec["crc16_123456789"] == f"{P.crc16(b'123456789'):04x}" == "29b1"

    def hx(b: bytes) -> str:
        return " ".join(f"{x:02x}" for x in b)

    assert vec["set_codes_seq0_3,0,6,0,0"] == hx(P.set_codes_frame(0, [3, 0, 6, 0, 0]))
    assert vec["status_seq1"] == hx(P.status_frame(1))
    assert vec["stop_all_seq2"] == hx(P.stop_all_frame(2))
    assert vec["heartbeat_seq7"] == hx(P.heartbeat_frame(7))
    ack = P.decode_frame(bytes.fromhex(vec["ack_seq0"].replace(" ", "")))
    assert P.parse_ack(ack) == (P.Msg.SET_CODES, 0)
    st = P.decode_frame(bytes.fromhex(vec["status_reply_seq1"].replace(" ", "")))
    assert P.parse_status(st) == {"codes": [3, 0, 6, 0, 0], "faults": []}
    nak = P.decode_frame(bytes.fromhex(vec["nak_bad_code_seq2"].replace(" ", "")))
    assert P.parse_nak(nak) == (P.Msg.SET_CODES, P.Nak.BAD_CODE, 4)
    # the same bytes are quoted in tests/unit/test_protocol.py and docs/protocol.md
    from tests.unit.test_protocol import DOC_VECTORS

    assert {k: v for k, v in vec.items() if k in DOC_VECTORS} == DOC_VECTORS
    doc = (REPO / "docs" / "protocol.md").read_text()
    for v in DOC_VECTORS.values():
        assert v in doc
