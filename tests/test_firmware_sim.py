"""End-to-end: the real firmware in simavr, driven by the real `bhr` commands.

Each test starts its own simulated board (firmware/build/bhr-sim, or
`make -C firmware sim`), reads its "PTY <path>" line, talks to it through
that pseudo-terminal and reads the pin log, where every latch of the 74HC595
chain and every change of /OE is stamped with the simulated time.

The simulator build uses short limits (firmware/Makefile): silence timeout
2000 ms, on-time limit 3000 ms, cool-down 1500 ms, 5 modules.

Without avr-gcc/avr-libc/simavr these tests skip with the reason, or fail
when the CI environment variable is set.
"""
from __future__ import annotations

import json
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bhr import protocol as P
from bhr.codes import format_codes_csv, read_codes_csv

REPO = Path(__file__).resolve().parent.parent
FIRMWARE = REPO / "firmware"
HARNESS = FIRMWARE / "build" / "bhr-sim"
SIM_ELF = FIRMWARE / "build" / "sim" / "bhr-m5.elf"
MODULES = 5
SILENCE_MS, ON_MAX_MS, COOLDOWN_MS = 2000, 3000, 1500

pytestmark = pytest.mark.slow


def missing_tools() -> list[str]:
    missing = [t for t in ("make", "cc", "avr-gcc", "avr-objcopy", "avr-size") if shutil.which(t) is None]
    if not Path("/usr/lib/avr/include/avr/io.h").exists():
        missing.append("avr-libc")
    if not Path("/usr/include/simavr/sim_avr.h").exists() or not Path("/usr/include/simavr/parts/hc595.h").exists():
        missing.append("libsimavr-dev")
    if not Path("/usr/include/libelf.h").exists() and not Path("/usr/include/libelf/libelf.h").exists():
        missing.append("libelf-dev")
    return missing


@pytest.fixture(scope="module")
def built():
    missing = missing_tools()
    if missing:
        msg = (f"firmware simulation tests need {', '.join(missing)}; run 'bash tests/run' (it installs gcc-avr "
               "avr-libc simavr libsimavr-dev libelf-dev) or apt-get install them")
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    r = subprocess.run(["make", "-C", str(FIRMWARE), "all", "sim-build"], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert HARNESS.exists() and SIM_ELF.exists()
    return r


def bhr_cmd() -> list[str]:
    exe = shutil.which("bhr")
    return [exe] if exe else [sys.executable, "-c", "from bhr.cli.main import main; main()"]


def run_bhr(*args, timeout=120):
    return subprocess.run(bhr_cmd() + [str(a) for a in args], capture_output=True, text=True, timeout=timeout)


def one_line(text: str) -> str:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert len(lines) == 1, text
    assert "Traceback" not in text
    return lines[0]


def read_line(proc: subprocess.Popen, timeout: float) -> str:
    """One line from proc.stdout, or '' at timeout/EOF (the pipe is unbuffered bytes)."""
    buf = b""
    end = time.monotonic() + timeout
    fd = proc.stdout.fileno()
    while time.monotonic() < end:
        r, _, _ = select.select([fd], [], [], 0.05)
        if r:
            ch = os.read(fd, 1)
            if not ch:
                break
            if ch == b"\n":
                return buf.decode()
            buf += ch
    return buf.decode()


class Sim:
    """A running simulated board: .pty, .log_path, events(), stop()."""

    def __init__(self, tmp_path: Path, via_make: bool = False) -> None:
        self.log_path = tmp_path / f"pins-{time.monotonic_ns()}.log"
        self.err_path = tmp_path / "sim-stderr.txt"
        self.err = open(self.err_path, "wb")
        if via_make:
            cmd = ["make", "-C", str(FIRMWARE), "sim", f"SIM_LOG={self.log_path}"]
        else:
            cmd = [str(HARNESS), "-m", str(MODULES), "-l", str(self.log_path), str(SIM_ELF)]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=self.err, start_new_session=True,
                                     bufsize=0)
        self.preamble = []
        self.pty = None
        end = time.monotonic() + 60
        while time.monotonic() < end:
            line = read_line(self.proc, end - time.monotonic())
            if line.startswith("PTY "):
                self.pty = line.split(" ", 1)[1].strip()
                break
            if line == "" and self.proc.poll() is not None:
                break
            self.preamble.append(line)
        if self.pty is None:
            self.stop()
            raise AssertionError(f"no PTY line from {cmd}: {self.preamble} {self.err_path.read_text()}")
        self.wait_for(lambda ev: ev[-1]["ev"] == "latch", 5)  # firmware booted and cleared the chain

    def events(self) -> list[dict]:
        out = []
        if not self.log_path.exists():
            return out
        for line in self.log_path.read_text().splitlines():
            assert not line.startswith("ALERT"), line
            if not line.startswith("t_us="):
                continue
            ev = dict(kv.split("=", 1) for kv in line.split())
            ev["t_us"] = int(ev["t_us"])
            for k in ("latched", "codes"):
                if k in ev:
                    ev[k] = [int(c) for c in ev[k].split(",")]
            out.append(ev)
        return out

    def wait_for(self, pred, timeout: float) -> list[dict]:
        end = time.monotonic() + timeout
        while True:
            evs = self.events()
            if evs and pred(evs):
                return evs
            if time.monotonic() > end:
                raise AssertionError(f"pin log never matched; last events: {evs[-5:]}")
            time.sleep(0.05)

    def stop(self, sig=signal.SIGTERM) -> int:
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, sig)
            except ProcessLookupError:
                pass
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)
        self.err.close()
        return self.proc.returncode


@pytest.fixture
def sim(built, tmp_path):
    sims = []

    def start(**kw) -> Sim:
        s = Sim(tmp_path, **kw)
        sims.append(s)
        return s

    yield start
    for s in sims:
        s.stop()


def collapse(seq):
    out = []
    for x in seq:
        x = list(x)
        if not out or out[-1] != x:
            out.append(x)
    return out


def outputs_while_streaming(events: list[dict]) -> list[list[int]]:
    """Effective output codes in order, from boot until /OE goes off again (stop-all or silence)."""
    seq, was_on = [], False
    for ev in events:
        if ev["ev"] == "oe" and ev["oe"] == "off" and was_on:
            break
        was_on = was_on or ev["oe"] == "on"
        seq.append(ev["codes"])
    return collapse(seq)


def check_stream_reached_the_pins(s: Sim, rows) -> None:
    evs = s.events()
    assert [e["t_us"] for e in evs] == sorted(e["t_us"] for e in evs)
    assert outputs_while_streaming(evs) == collapse([[0] * MODULES] + [list(r) for r in rows])
    for e in evs:  # every code on an output is a stable one
        assert all(c in (0, 3, 6, 9, 12, 15) for c in e["codes"] + e["latched"])


# -------------------------------------------------------------- builds


def test_firmware_builds_for_the_atmega328p(built):
    assert (FIRMWARE / "build" / "bhr.hex").exists()
    size = subprocess.run(["avr-size", str(FIRMWARE / "build" / "bhr.elf")], capture_output=True, text=True,
                          check=True).stdout.splitlines()[1].split()
    text, data, bss = int(size[0]), int(size[1]), int(size[2])
    assert text + data < 32 * 1024 - 2048  # leaves room for a bootloader
    assert data + bss < 1024  # of 2048 bytes of RAM: the rest is stack


def test_make_sim_prints_the_pty_first_and_stops_cleanly(sim):
    s = sim(via_make=True)
    # GNU make prints its own "Entering directory" line first when run with -C; nothing else may come first
    assert all(line.startswith("make") for line in s.preamble), s.preamble
    assert s.pty.startswith("/dev/")
    r = run_bhr("status", "--port", s.pty, "--json", "-")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == {"codes": [0] * MODULES, "faults": []}
    s.stop(signal.SIGINT)
    assert s.events() and "ev=exit" in s.log_path.read_text()


def test_harness_stops_on_sigterm_with_status_zero(sim):
    s = sim()
    assert s.preamble == []  # the PTY line is the very first line
    assert s.stop(signal.SIGTERM) == 0
    text = s.log_path.read_text()
    assert text.startswith("# bhr-sim pin log")
    assert re.search(r"ev=exit latches=\d+ alerts=0", text)


# -------------------------------------------------------------- end to end


def test_a_run_from_bhr_follow_reaches_the_outputs_in_order(sim, tmp_path):
    out = tmp_path / "run"
    r = run_bhr("follow", "--traj", "curve", "--radius", "70", "--angle", "90", "--no-plots", "--out", out,
                timeout=600)
    assert r.returncode == 0, r.stderr
    steps, rows = read_codes_csv(out / "codes.csv")
    assert rows.shape[1] == MODULES and len(collapse(rows.tolist())) > 5
    s = sim()
    r = run_bhr("stream", "--port", s.pty, "--codes", out / "codes.csv", "--rate", "50")
    assert r.returncode == 0, r.stderr
    assert f"sent {len(rows)} rows" in r.stdout
    st = run_bhr("status", "--port", s.pty, "--json", "-")
    assert st.returncode == 0, st.stderr
    assert json.loads(st.stdout) == {"codes": rows[-1].tolist(), "faults": []}
    check_stream_reached_the_pins(s, rows.tolist())


def test_every_code_on_every_module_reaches_the_outputs_in_order(sim, tmp_path):
    valid = (0, 3, 6, 9, 12, 15)
    rows = [[valid[(i + 2 * j) % 6] for j in range(MODULES)] for i in range(12)]
    rows += [[0] * MODULES, [15] * MODULES, [3, 6, 12, 9, 0]]
    f = tmp_path / "codes.csv"
    f.write_text(format_codes_csv(rows))
    s = sim()
    r = run_bhr("stream", "--port", s.pty, "--codes", f, "--rate", "20")
    assert r.returncode == 0, r.stderr
    out = tmp_path / "status.json"
    st = run_bhr("status", "--port", s.pty, "--json", out)
    assert st.returncode == 0, st.stderr
    assert json.loads(out.read_text()) == {"codes": rows[-1], "faults": []}
    check_stream_reached_the_pins(s, rows)
    # rows were latched about 1/20 s apart in simulated time
    latches = [e for e in s.events() if e["ev"] == "latch" and e["oe"] == "on"]
    gaps = [(b["t_us"] - a["t_us"]) / 1e6 for a, b in zip(latches, latches[1:])]
    assert len(latches) >= len(rows) - 1
    assert 0.03 < sorted(gaps)[len(gaps) // 2] < 0.2


def test_a_fast_stream_needs_no_retry(sim):
    from bhr.link import BoardLink, stream_codes

    valid = (0, 3, 6, 9, 12, 15)
    rows = [[valid[(i * 7 + j * 5) % 6] for j in range(MODULES)] for i in range(500)]
    s = sim()
    with BoardLink(s.pty) as link:
        t = time.monotonic()
        assert stream_codes(link, rows, rate=1000) == 500
        elapsed = time.monotonic() - t
        assert (link.timeouts, link.damaged) == (0, 0)
        assert link.status() == {"codes": rows[-1], "faults": []}
    assert elapsed < 20
    check_stream_reached_the_pins(s, rows)


# -------------------------------------------------------------- faults


def raw_port(path: str):
    import serial

    return serial.serial_for_url(path, baudrate=115200, timeout=0.05)


def exchange(port, frame: bytes, seq: int, timeout: float = 1.0) -> P.Frame:
    dec = P.StreamDecoder()
    port.write(frame)
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        for f in dec.feed(port.read(64)):
            if f.seq == seq and f.type >= 0x80:
                return f
    raise AssertionError(f"no answer to {frame.hex()}")


def test_a_corrupted_frame_is_naked_and_changes_nothing(sim):
    s = sim()
    with raw_port(s.pty) as port:
        ack = exchange(port, P.set_codes_frame(1, [3, 0, 6, 0, 15]), 1)
        assert ack.type == P.Msg.ACK
        s.wait_for(lambda evs: evs[-1]["codes"] == [3, 0, 6, 0, 15], 5)
        before = len(s.events())
        good = P.set_codes_frame(2, [12, 12, 12, 12, 12])
        for i in (3, 6, 8, len(good) - 1):  # corrupt the type, the count, a code, the CRC
            bad = bytearray(good)
            bad[i] ^= 0x01
            nak = exchange(port, bytes(bad), 2)
            assert nak.type == P.Msg.NAK and P.parse_nak(nak)[1] == P.Nak.BAD_CRC
        # a well-formed frame carrying an unstable code: NAKed naming the module
        nak = exchange(port, P.encode_frame(P.Msg.SET_CODES, 3, bytes([5, 3, 0, 5, 0, 0])), 3)
        assert P.parse_nak(nak) == (P.Msg.SET_CODES, P.Nak.BAD_CODE, 3)
        # the wrong module count
        nak = exchange(port, P.encode_frame(P.Msg.SET_CODES, 4, bytes([6, 0, 0, 0, 0, 0, 0])), 4)
        assert P.parse_nak(nak) == (P.Msg.SET_CODES, P.Nak.BAD_COUNT, MODULES)
        # noise, then a good status request still gets through
        port.write(b"\xa5\x5a\x01\xa5\x00\xff\x13")
        st = exchange(port, P.status_frame(5), 5)
        assert P.parse_status(st) == {"codes": [3, 0, 6, 0, 15], "faults": []}
    time.sleep(0.2)
    assert len(s.events()) == before  # no latch, no /OE change
    r = run_bhr("status", "--port", s.pty, "--json", "-")
    assert json.loads(r.stdout)["codes"] == [3, 0, 6, 0, 15]


def test_a_silent_host_gets_everything_switched_off_within_the_timeout(sim, tmp_path):
    s = sim()
    f = tmp_path / "codes.csv"
    f.write_text(format_codes_csv([[3, 6, 9, 12, 15]]))
    r = run_bhr("stream", "--port", s.pty, "--codes", f)
    assert r.returncode == 0, r.stderr
    def switched_off(evs):
        on = [i for i, e in enumerate(evs) if e["ev"] == "oe" and e["oe"] == "on"]
        return on and any(e["ev"] == "oe" and e["oe"] == "off" for e in evs[on[0]:])

    evs = s.wait_for(switched_off, SILENCE_MS / 1000 + 5)
    i_on = next(i for i, e in enumerate(evs) if e["ev"] == "oe" and e["oe"] == "on")
    on = evs[i_on]
    off = next(e for e in evs[i_on:] if e["ev"] == "oe" and e["oe"] == "off")
    assert on["codes"] == [3, 6, 9, 12, 15] and off["codes"] == [0] * MODULES
    # the board counts whole 1 ms ticks after the last frame and switches off in the tick after the
    # timeout; the outputs came on up to a few tenths of a millisecond after the frame was accepted
    silent_ms = (off["t_us"] - on["t_us"]) / 1000
    assert SILENCE_MS - 1 <= silent_ms <= SILENCE_MS + 20, silent_ms
    assert s.wait_for(lambda evs: evs[-1]["latched"] == [0] * MODULES, 2)  # and the chain is cleared
    r = run_bhr("status", "--port", s.pty, "--json", "-")
    assert json.loads(r.stdout) == {"codes": [0] * MODULES, "faults": ["silence"]}


def test_an_actuator_held_on_past_its_limit_is_switched_off_and_reported(sim):
    from bhr.link import BoardLink

    s = sim()

    def m1_tripped(evs):
        return any(e["codes"][0] == 0 and e["codes"][2] == 6 for e in evs)

    with BoardLink(s.pty) as link:
        link.set_codes([3, 0, 0, 0, 0])
        time.sleep(1.0)
        link.set_codes([3, 0, 6, 0, 0])  # module 3 comes on a second later, so it trips a second later
        t0 = time.monotonic()
        while time.monotonic() - t0 < ON_MAX_MS / 1000 + 2 and not m1_tripped(s.events()):
            time.sleep(0.1)
            link.heartbeat()  # the host stays alive, asking for nothing new
        status = link.status()
        assert status == {"codes": [0, 0, 6, 0, 0], "faults": ["overheat:m1", "cooling:m1"]}
        evs = s.events()
        on = next(e for e in evs if e["codes"][0] == 3)
        off = next(e for e in evs if e["t_us"] > on["t_us"] and e["codes"][0] == 0)
        assert off["codes"] == [0, 0, 6, 0, 0] and off["oe"] == "on"  # only that module goes off
        held_ms = (off["t_us"] - on["t_us"]) / 1000
        assert ON_MAX_MS - 1.5 <= held_ms <= ON_MAX_MS + 20, held_ms
        # after the cool-down module 1 follows the host again; the fault stays latched until stop-all
        link.set_codes([3, 0, 0, 0, 0])
        time.sleep(COOLDOWN_MS / 1000 + 0.3)
        status = link.status()
        assert status == {"codes": [3, 0, 0, 0, 0], "faults": ["overheat:m1", "overheat:m3"]} or \
            status == {"codes": [3, 0, 0, 0, 0], "faults": ["overheat:m1"]}
    # the command line sees the latched fault too; stop-all clears it
    r = run_bhr("status", "--port", s.pty, "--json", "-")
    doc = json.loads(r.stdout)
    assert "overheat:m1" in doc["faults"] and doc["codes"][0] == 3
    with BoardLink(s.pty) as link:
        link.stop_all()
        assert link.status() == {"codes": [0] * MODULES, "faults": []}


def test_killing_the_simulator_mid_stream_is_one_clear_line(sim, tmp_path):
    s = sim()
    rows = [[(0, 3, 6)[(i + j) % 3] for j in range(MODULES)] for i in range(400)]
    f = tmp_path / "codes.csv"
    f.write_text(format_codes_csv(rows))
    proc = subprocess.Popen(bhr_cmd() + ["stream", "--port", s.pty, "--codes", str(f), "--rate", "40"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    s.wait_for(lambda evs: sum(e["ev"] == "latch" for e in evs) > 10, 20)
    os.killpg(s.proc.pid, signal.SIGKILL)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 1
    msg = one_line(err)
    assert msg.startswith("Error: ") and s.pty in msg
    assert "lost the serial link" in msg or "did not answer" in msg


def test_ctrl_c_sends_stop_all(sim, tmp_path):
    s = sim()
    rows = [[3, 6, 9, 12, 15] if i % 2 else [6, 9, 12, 15, 3] for i in range(400)]
    f = tmp_path / "codes.csv"
    f.write_text(format_codes_csv(rows))
    proc = subprocess.Popen(bhr_cmd() + ["stream", "--port", s.pty, "--codes", str(f), "--rate", "40"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    s.wait_for(lambda evs: sum(e["ev"] == "latch" for e in evs) > 10, 20)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 130
    assert "sent stop-all" in one_line(err)
    evs = s.wait_for(lambda evs: evs[-1]["codes"] == [0] * MODULES and evs[-1]["latched"] == [0] * MODULES, 5)
    assert any(e["ev"] == "oe" and e["oe"] == "off" for e in evs)
    r = run_bhr("status", "--port", s.pty, "--json", "-")
    assert json.loads(r.stdout) == {"codes": [0] * MODULES, "faults": []}


def test_bad_files_never_reach_the_board(sim, tmp_path):
    s = sim()
    bad = tmp_path / "bad.csv"
    bad.write_text("step,m1,m2,m3,m4,m5\n1,3,0,0,0,0\n2,6,0,0,0,0\n3,0,0,0,11,0\n")
    r = run_bhr("stream", "--port", s.pty, "--codes", bad)
    assert r.returncode == 1 and r.stdout == ""
    msg = one_line(r.stderr)
    assert f"{bad}:4" in msg and "column m4" in msg
    wrong = tmp_path / "six.csv"
    wrong.write_text(format_codes_csv([[3, 0, 0, 0, 0, 0]]))
    r = run_bhr("stream", "--port", s.pty, "--codes", wrong)
    assert r.returncode == 1
    assert "drives 5 modules but 6 codes were sent" in one_line(r.stderr)
    time.sleep(0.2)
    assert not any(e["oe"] == "on" for e in s.events())
    assert all(e["latched"] == [0] * MODULES for e in s.events())


def test_follow_streams_each_step_while_it_solves(sim, tmp_path):
    s = sim()
    out = tmp_path / "run"
    r = run_bhr("follow", "--traj", "curve", "--radius", "70", "--angle", "90", "--no-plots", "--out", out,
                "--port", s.pty, "--rate", "100", timeout=600)
    assert r.returncode == 0, r.stderr
    steps, rows = read_codes_csv(out / "codes.csv")
    assert f"streamed {len(rows)} steps (5 modules) to {s.pty}" in r.stderr
    # streaming does not change the run: same codes as without --port
    plain = tmp_path / "plain"
    assert run_bhr("follow", "--traj", "curve", "--radius", "70", "--angle", "90", "--no-plots",
                   "--out", plain).returncode == 0
    assert (plain / "codes.csv").read_text() == (out / "codes.csv").read_text()
    st = run_bhr("status", "--port", s.pty, "--json", "-")
    assert json.loads(st.stdout) == {"codes": rows[-1].tolist(), "faults": []}
    check_stream_reached_the_pins(s, rows.tolist())


def test_follow_refuses_a_board_of_another_size_before_sending(sim, tmp_path):
    s = sim()
    r = run_bhr("follow", "--traj", "line", "--no-plots", "--out", tmp_path / "o", "--port", s.pty, "--modules", "6")
    assert r.returncode == 1
    assert "drives 5 modules but the robot has 6" in one_line(r.stderr)
    assert not (tmp_path / "o").exists()
    r = run_bhr("follow", "--traj", "line", "--no-plots", "--out", tmp_path / "o", "--port", s.pty, "--solver", "ccd")
    assert r.returncode == 1 and "gives no module codes" in one_line(r.stderr)
    time.sleep(0.2)
    assert not any(e["oe"] == "on" for e in s.events())


def test_ctrl_c_during_follow_sends_stop_all(sim, tmp_path):
    s = sim()
    proc = subprocess.Popen(bhr_cmd() + ["follow", "--traj", "colon", "--no-plots", "--out", str(tmp_path / "o"),
                                         "--port", s.pty, "--rate", "40"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    s.wait_for(lambda evs: sum(e["ev"] == "latch" for e in evs) > 10, 60)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 130
    assert "sent stop-all" in one_line(err)
    s.wait_for(lambda evs: evs[-1]["codes"] == [0] * MODULES and evs[-1]["latched"] == [0] * MODULES, 5)
    assert not (tmp_path / "o" / "run.json").exists()  # an interrupted run writes nothing


def test_robot_file_link_gives_port_and_module_order(sim, tmp_path):
    s = sim()
    robot = tmp_path / "robot.toml"
    robot.write_text(f'[link]\nport = "{s.pty}"\nmodule_order = [5, 4, 3, 2, 1]\n')
    f = tmp_path / "codes.csv"
    f.write_text(format_codes_csv([[3, 6, 0, 0, 15]]))
    r = run_bhr("stream", "--robot", robot, "--codes", f, "--rate", "20")
    assert r.returncode == 0, r.stderr
    # the board's chain is wired in reverse: position 1 drives module 5
    assert json.loads(run_bhr("status", "--port", s.pty, "--json", "-").stdout)["codes"] == [15, 0, 0, 6, 3]
    st = run_bhr("status", "--robot", robot, "--json", "-")
    assert json.loads(st.stdout) == {"codes": [3, 6, 0, 0, 15], "faults": []}


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
@pytest.mark.parametrize("command", ["stream", "follow"])
def test_sigterm_and_sighup_send_stop_all_like_ctrl_c(sim, tmp_path, sig, command):
    """kill (SIGTERM) or a closed terminal (SIGHUP) mid-stream: stop-all reaches the pins, exit 130, one line."""
    s = sim()
    if command == "stream":
        rows = [[3, 6, 9, 12, 15] if i % 2 else [6, 9, 12, 15, 3] for i in range(400)]
        f = tmp_path / "codes.csv"
        f.write_text(format_codes_csv(rows))
        args = ["stream", "--port", s.pty, "--codes", str(f), "--rate", "40"]
    else:
        args = ["follow", "--traj", "colon", "--no-plots", "--out", str(tmp_path / "o"), "--port", s.pty,
                "--rate", "40"]
    proc = subprocess.Popen(bhr_cmd() + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    s.wait_for(lambda evs: sum(e["ev"] == "latch" for e in evs) > 10, 60)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, err
    assert "sent stop-all" in one_line(err)
    s.wait_for(lambda evs: evs[-1]["codes"] == [0] * MODULES and evs[-1]["latched"] == [0] * MODULES, 5)
    assert not (tmp_path / "o").exists()  # an interrupted run writes no folder


def test_status_to_a_full_device_is_one_line(sim, tmp_path):
    """The board answers, but the --json target (a real full device) cannot take it: one line, the device kept."""
    import stat

    s = sim()
    full = tmp_path / "full"
    os.mknod(full, 0o666 | stat.S_IFCHR, os.makedev(1, 7))  # the suite runs as root
    r = run_bhr("status", "--port", s.pty, "--json", str(full))
    assert r.returncode == 1 and "No space left on device" in one_line(r.stderr)
    assert stat.S_ISCHR(full.lstat().st_mode)
