"""End-to-end: the real firmware in simavr, driven by the real `bhr` commands.

Each test starts its own simulated board (firmware/build/bhr-sim, or
`make -C firmware sim`), reads its "PTY <path>" line, talks to it through
that pseudo-terminal and reads the pin log, where every latch of the 74HC595
chain and every change of /OE is stamped with the simulated time.

The simulator build has a silence timeout of 2000 ms and 5 modules; the
wires follow the thermal model of docs/thermal.md with the default robot
file's figures (1000 ms contraction, 60 % hold duty on a 20 ms PWM period,
1100 ms relaxation, 3000 ms full-power limit). A board starts by cooling its
wires (about 1.6 s); each test waits for that.

Without avr-gcc/avr-libc/simavr these tests skip with the reason, or fail
when the CI environment variable is set.
"""
from __future__ import annotations

import contextlib
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

from tests.conftest import make_firmware

from bhr._hardware import protocol as P
from bhr._hardware.thermal import DEFAULT_THERMAL as THERMAL
from bhr.model._codes import format_codes_csv, read_codes_csv

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / "firmware"
HARNESS = FIRMWARE / "build" / "bhr-sim"
SIM_ELF = FIRMWARE / "build" / "sim" / "bhr-m5.elf"
MODULES = 5
SILENCE_MS = 2000
PERIOD_MS, HOLD_MS = THERMAL.period_ms, THERMAL.hold_ticks

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
    r = make_firmware("-C", str(FIRMWARE), "all", "sim-build")
    assert r.returncode == 0, r.stdout + r.stderr
    assert HARNESS.exists() and SIM_ELF.exists()
    return r


def default_sigint() -> None:
    """In a child before exec: Ctrl-C, SIGTERM and SIGHUP back to their defaults, as a shell's foreground job has
    them, even when the test suite itself was started with some ignored (nohup, a background job of a
    non-interactive shell), which a child inherits."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def bhr_cmd() -> list[str]:
    exe = shutil.which("bhr")
    return [exe] if exe else [sys.executable, "-m", "bhr.cli.main"]


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
                                     bufsize=0, preexec_fn=default_sigint)
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
        from bhr._hardware.link import BoardLink, wait_until_ready

        with BoardLink(self.pty) as link:  # a powered-up board cools its wires first
            self.cooled_s = wait_until_ready(link, timeout=10)

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


STABLE = (0, 3, 6, 9, 12, 15)


def driven(events: list[dict]) -> list[dict]:
    """The events with the PWM hold's off-times filled in: the code each module is driven with.

    Each wire is driven on its own: while holding, it is on for HOLD_MS of every PWM_MS period and off in
    between, while a wire of the same code still contracting stays on. An off-time of a wire no longer than
    the hold's, followed by that wire on again (or by the end of the log), is the wire on. A module pattern
    that is 0 or not a stable code, shorter than an off-time and inside the code before it, is the code
    before it (its wires in their off-time when the host changed the code).
    """
    out = [dict(e, codes=list(e["codes"])) for e in events]
    gap_us = (PERIOD_MS - HOLD_MS + 2) * 1000
    for m in range(MODULES):
        for bit in range(4):
            i = 0
            while i < len(out):
                on = (out[i]["codes"][m] >> bit) & 1
                if not on and i > 0 and (out[i - 1]["codes"][m] >> bit) & 1:
                    j = i
                    while j < len(out) and not (out[j]["codes"][m] >> bit) & 1:
                        j += 1
                    tail = j == len(out) and out[-1]["t_us"] - out[i]["t_us"] <= gap_us  # log ends mid-period
                    if tail or j < len(out) and out[j]["t_us"] - out[i]["t_us"] <= gap_us:
                        for k in range(i, j):
                            out[k]["codes"][m] |= 1 << bit
                    i = j
                else:
                    i += 1
        for i in range(1, len(out)):
            c, prev = out[i]["codes"][m], out[i - 1]["codes"][m]
            if c == 0 and prev != 0:  # the old code's wires in their off-time when the next code came
                j = i
                while j < len(out) and out[j]["codes"][m] == 0:
                    j += 1
                if j < len(out) and out[j]["t_us"] - out[i]["t_us"] <= gap_us:
                    for k in range(i, j):
                        out[k]["codes"][m] = prev
            elif c not in STABLE and c & ~prev == 0:
                j = i
                while j < len(out) and out[j]["codes"][m] == c:
                    j += 1
                end_t = out[j]["t_us"] if j < len(out) else out[-1]["t_us"]
                if end_t - out[i]["t_us"] <= gap_us:
                    for k in range(i, j):
                        out[k]["codes"][m] = prev
    return out


def on_intervals(events: list[dict], module: int, bit: int) -> list[tuple[int, int]]:
    """(start, end) in microseconds of each interval the pins show wire `bit` of `module` on."""
    out, start = [], None
    for e in events:
        on = (e["codes"][module - 1] >> bit) & 1
        if on and start is None:
            start = e["t_us"]
        elif not on and start is not None:
            out.append((start, e["t_us"]))
            start = None
    if start is not None:
        out.append((start, events[-1]["t_us"]))
    return out


def outputs_while_streaming(events: list[dict]) -> list[list[int]]:
    """Driven output codes in order, from boot until /OE goes off again (stop-all or silence)."""
    seq, was_on = [], False
    for ev in driven(events):
        if ev["ev"] == "oe" and ev["oe"] == "off" and was_on:
            break
        was_on = was_on or ev["oe"] == "on"
        seq.append(ev["codes"])
    return collapse(seq)


def assert_last_row_on_the_pins(s: Sim, codes: list[int]) -> None:
    """The board drove the last row until the host fell silent (read from the pin log: a `bhr status`
    started after a command on a busy machine can come later than the silence timeout)."""
    evs = s.wait_for(lambda evs: any(e["ev"] == "oe" and e["oe"] == "off" for e in evs[1:]), SILENCE_MS / 1000 + 10)
    i_off = max(i for i, e in enumerate(evs) if e["ev"] == "oe" and e["oe"] == "off")
    last = driven(evs[:i_off])[-1]
    assert last["codes"] == codes and last["oe"] == "on", last


def check_stream_reached_the_pins(s: Sim, rows) -> None:
    evs = s.events()
    assert [e["t_us"] for e in evs] == sorted(e["t_us"] for e in evs)
    driven_rows = outputs_while_streaming(evs)
    # module by module (a module in its PWM off-phase when a row arrives changes a little later on the
    # pins than one at full power): every module went through its codes in order
    for m in range(MODULES):
        assert collapse([[r[m]] for r in driven_rows]) == collapse([[0]] + [[r[m]] for r in rows]), m + 1
    check_patterns(evs)


def check_patterns(evs: list[dict]) -> None:
    """Every driven code is a stable one, and the outputs only ever show wires of it (or of the code before)."""
    dr = driven(evs)
    for k, (e, d) in enumerate(zip(evs, dr)):
        before = dr[k - 1]["codes"] if k else [0] * MODULES
        for m in range(MODULES):
            assert d["codes"][m] in STABLE, (e, d)
            assert e["codes"][m] & ~(d["codes"][m] | before[m]) == 0, (e, d)


# -------------------------------------------------------------- builds


def test_firmware_builds_for_the_atmega328p(built):
    assert (FIRMWARE / "build" / "bhr.hex").exists()
    size = subprocess.run(["avr-size", str(FIRMWARE / "build" / "bhr.elf")], capture_output=True, text=True,
                          check=True).stdout.splitlines()[1].split()
    text, data, bss = int(size[0]), int(size[1]), int(size[2])
    assert text + data < 32 * 1024 - 2048  # leaves room for a bootloader
    assert data + bss < 1024  # of 2048 bytes of RAM: the rest is stack


def test_the_firmware_sizes_in_the_docs_are_the_build_s(built):
    """docs/firmware.md quotes avr-size of the 5-module build: flash, RAM and the board's state in .noinit."""
    sections = {}
    for line in subprocess.run(["avr-size", "-A", str(FIRMWARE / "build" / "bhr.elf")], capture_output=True,
                               text=True, check=True).stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sections[parts[0]] = int(parts[1])
    flash = sections[".text"] + sections.get(".data", 0)
    ram = sections.get(".data", 0) + sections.get(".bss", 0)
    doc = " ".join((Path(__file__).parents[2] / "docs" / "firmware.md").read_text(encoding="utf-8").split())
    m = re.search(r"(\d+) bytes of flash and (\d+) bytes of RAM \(plus the board's state, (\d+) bytes in `\.noinit`\)",
                  doc)
    assert m, "docs/firmware.md no longer quotes the firmware's size"
    assert (int(m[1]), int(m[2]), int(m[3])) == (flash, ram, sections[".noinit"]), \
        f"docs/firmware.md quotes {m[0]!r}; avr-size measures {flash} flash, {ram} RAM, {sections['.noinit']} .noinit"


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


def test_make_sim_keeps_the_pin_log_off_the_terminal_unless_asked(built, tmp_path):
    # `make -s -C firmware sim` prints the PTY line and nothing else on stdout during a stream: the pin
    # log goes to build/sim/pins.log (SIM_LOG=- asks for it on stdout)
    from bhr._hardware.link import BoardLink, run_stream

    log = FIRMWARE / "build" / "sim" / "pins.log"
    out_path, err_path = tmp_path / "out.txt", tmp_path / "err.txt"
    with open(out_path, "wb") as out, open(err_path, "wb") as err:
        proc = subprocess.Popen(["make", "-s", "-C", str(FIRMWARE), "sim"], stdout=out, stderr=err,
                                start_new_session=True, preexec_fn=default_sigint)
        try:
            end = time.monotonic() + 60
            while time.monotonic() < end and not out_path.read_text().strip():
                time.sleep(0.1)
            pty = out_path.read_text().split()[1]
            with BoardLink(pty) as link:
                run_stream(link, [[3, 6, 9, 12, 15], [0, 0, 0, 0, 0]], rate=2, wait_ready=True, at_end="stop")
        finally:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(10)
    assert out_path.read_text().splitlines() == [f"PTY {pty}"]
    assert f"pin log in {Path('build/sim/pins.log')}" in err_path.read_text()
    text = log.read_text()
    assert "codes=3,6,9,12,15" in text and text.rstrip().splitlines()[-1].startswith("t_us=")


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
    rows = rows[:50]
    assert rows.shape[1] == MODULES and len(collapse(rows.tolist())) > 5
    part = tmp_path / "part.csv"
    part.write_text(format_codes_csv(rows))
    s = sim()
    # at 50 rows/s the wires could not follow: refused before anything is sent
    r = run_bhr("stream", "--port", s.pty, "--codes", part, "--rate", "50", "--schedule", "rate")
    assert r.returncode == 1
    msg = one_line(r.stderr)
    assert re.search(r"module m\d, step \d+: .* nothing was sent; use --rate [\d.]+ or --schedule auto", msg), msg
    assert not any(e["oe"] == "on" for e in s.events())
    r = run_bhr("stream", "--port", s.pty, "--codes", part, "--rate", "50", "--schedule", "auto")
    assert r.returncode == 0, r.stderr
    assert f"sent {len(rows)} rows" in r.stdout and "at the wires' pace, at most " in r.stdout and "; procedure time" in r.stdout
    assert_last_row_on_the_pins(s, rows[-1].tolist())
    check_stream_reached_the_pins(s, rows.tolist())


def test_every_code_on_every_module_reaches_the_outputs_in_order(sim, tmp_path):
    valid = (0, 3, 6, 9, 12, 15)
    rows = [[valid[(i + j) % 6] for j in range(MODULES)] for i in range(7)]
    rows += [[0] * MODULES, [15] * MODULES, [3, 6, 12, 9, 0]]
    f = tmp_path / "codes.csv"
    f.write_text(format_codes_csv(rows))
    s = sim()
    r = run_bhr("stream", "--port", s.pty, "--codes", f, "--rate", "20", "--schedule", "auto", timeout=300)
    assert r.returncode == 0, r.stderr
    assert_last_row_on_the_pins(s, rows[-1])
    check_stream_reached_the_pins(s, rows)
    from bhr._hardware.link import BoardLink

    with BoardLink(s.pty) as link:
        link.stop_all()  # a state that does not change with time, for the command below
    out = tmp_path / "status.json"
    st = run_bhr("status", "--port", s.pty, "--json", out)
    assert st.returncode == 0, st.stderr
    assert json.loads(out.read_text()) == {"codes": [0] * MODULES, "faults": []}
    # each row was held until its wires had contracted (full power, about the contraction time):
    # every module's code changes at least that far apart on the pins
    evs = [e for e in driven(s.events()) if e["oe"] == "on"]
    for m in range(MODULES):
        changes = [e["t_us"] for a, e in zip(evs, evs[1:]) if e["codes"][m] != a["codes"][m]]
        gaps_ms = [(b - a) / 1000 for a, b in zip(changes, changes[1:])]
        assert gaps_ms and min(gaps_ms) >= 0.9 * THERMAL.contract_ms, (m + 1, gaps_ms)


def test_a_fast_stream_needs_no_retry(sim):
    from bhr._hardware.link import BoardLink, stream_codes

    # wires only ever come on (a wire released and energised again within its relaxation time would be
    # held off by the board): 500 rows, one module more every 100
    order = (3, 6, 12, 9, 15)
    rows = [[order[j] if j < i // 100 else 0 for j in range(MODULES)] for i in range(500)]
    s = sim()
    # every frame answered, none lost or damaged: a timeout no busy machine reaches (the simulator, another
    # process, may not run for longer than the default 0.25 s; a retry's own test is in test_link.py)
    with BoardLink(s.pty, timeout=10.0) as link:
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
        # nothing changed on the pins: the same codes, driven (full power, then the PWM hold), /OE on
        assert all(e["codes"] == [3, 0, 6, 0, 15] and e["oe"] == "on" for e in driven(s.events())[before:])
        # and the board still says so (asked at once: a new command on a busy machine can start after the
        # silence timeout)
        st = exchange(port, P.status_frame(6), 6)
        assert P.parse_status(st)["codes"] == [3, 0, 6, 0, 15]


def test_a_silent_host_gets_everything_switched_off_within_the_timeout(sim, tmp_path):
    from bhr._hardware.link import BoardLink

    s = sim()
    with BoardLink(s.pty) as link:  # one row, then nothing more from the host
        link.set_codes([3, 6, 9, 12, 15])

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


def test_a_tilt_held_15_s_stays_held_with_the_model_s_hold_duty(sim):
    from bhr._hardware.link import BoardLink

    s = sim()
    time.sleep(4.0)  # let the wires cool from the power-up cool-down to ambient (theta 0.009)
    with BoardLink(s.pty) as link:
        link.set_codes([3, 0, 0, 0, 0])  # codes set once
        t0 = time.monotonic()
        while time.monotonic() - t0 < 15.0:
            time.sleep(0.2)
            link.heartbeat()  # heartbeats only
        assert link.status() == {"codes": [3, 0, 0, 0, 0], "faults": []}
    evs = s.events()
    for bit in (0, 1):  # actuators 1 and 2
        runs = on_intervals(evs, 1, bit)
        first_ms = (runs[0][1] - runs[0][0]) / 1000
        # one full-power pulse of the contraction time (to the 20 ms model step), then PWM
        assert THERMAL.contract_ms <= first_ms <= THERMAL.contract_ms + 2 * PERIOD_MS, first_ms
        assert first_ms < THERMAL.max_full_ms
        hold = runs[1:]
        span = (hold[-1][1] - hold[0][0]) / 1e6
        assert span > 13.5
        pulses = [(b - a) / 1000 for a, b in hold[:-1]]
        assert max(pulses) <= HOLD_MS + 0.5
        duty = sum(b - a for a, b in hold[:-1]) / (hold[-1][0] - hold[0][0])
        # the model's duty (12/20); the pins show a little less: each period's model update delays its on-edge
        assert THERMAL.duty - 0.03 <= duty <= THERMAL.duty, duty
        periods = [(b[0] - a[0]) / 1000 for a, b in zip(hold, hold[1:])]
        assert abs(sorted(periods)[len(periods) // 2] - PERIOD_MS) < 0.1
    assert all(e["codes"][1:] == [0] * (MODULES - 1) for e in evs)


def test_a_hot_wire_is_not_re_energised_before_it_relaxed(sim):
    from bhr._hardware.link import BoardLink

    s = sim()
    with BoardLink(s.pty) as link:
        link.set_codes([3, 0, 0, 0, 0])
        time.sleep(1.5)
        link.set_codes([6, 0, 0, 0, 0])  # actuator 1 released
        time.sleep(0.2)
        faults = link.set_codes([3, 0, 0, 0, 0])  # ... and asked for again 0.2 s later
        assert "early" in faults
        t_ask = s.events()[-1]["t_us"]
        assert link.status(detail=True) == {"codes": [0, 0, 0, 0, 0], "faults": ["early:m1"], "relaxing": [1]}
        t0 = time.monotonic()
        while time.monotonic() - t0 < 5 and link.status()["codes"][0] != 3:
            time.sleep(0.1)
            link.heartbeat()
        assert link.status() == {"codes": [3, 0, 0, 0, 0], "faults": ["early:m1"]}
        link.stop_all()
        assert link.status()["faults"] == []
    evs = s.events()
    back = next(e for e in evs if e["t_us"] > t_ask and e["codes"][0] == 3)
    held_ms = (back["t_us"] - t_ask) / 1000
    # the module is off whole while its hottest wire (actuator 2, held through a second contraction) relaxes
    assert THERMAL.relax_ms * 0.8 <= held_ms <= THERMAL.relax_ms * 1.6, held_ms
    assert all(not (e["codes"][0] & 1) for e in evs if t_ask < e["t_us"] < back["t_us"])


def test_a_stream_right_after_one_that_held_its_codes_is_accepted(sim, tmp_path):
    """`bhr stream A` (--at-end hold, the default), then at once `bhr stream B` whose first row switches off a wire
    A holds and whose second switches it on again: B's default schedule treated the wire as cold and the board
    raised early:m1. The pacer now counts the held codes, so it waits for the board to say the wire relaxed."""
    s = sim()
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text(format_codes_csv([[0, 0, 0, 0, 0], [15, 0, 0, 0, 0], [15, 0, 0, 0, 0]]))
    b.write_text(format_codes_csv([[0, 0, 0, 0, 0], [15, 0, 0, 0, 0]]))
    for _ in range(2):
        first = run_bhr("stream", "--port", s.pty, "--codes", a)
        assert first.returncode == 0, first.stderr
        second = run_bhr("stream", "--port", s.pty, "--codes", b)
        assert second.returncode == 0 and "fault" not in second.stderr.lower(), second.stderr
        st = run_bhr("status", "--port", s.pty, "--json", "-")
        assert json.loads(st.stdout)["faults"] in ([], ["silence"]), st.stdout
    assert "Board fault" not in first.stderr + second.stderr


def test_floods_of_every_frame_type_leave_on_time_and_duty_within_limits(sim):
    """The attack: all-on codes, heartbeats every 0.2 s, bursts of 500 HEARTBEAT, STATUS or bad-CRC frames."""
    s = sim()
    time.sleep(2.0)
    import serial

    all_on = [15] * MODULES
    with serial.serial_for_url(s.pty, baudrate=115200, timeout=0.05) as port:
        seq = 0
        t0 = time.monotonic()
        bursts = 0
        while time.monotonic() - t0 < 15.0:
            port.write(P.set_codes_frame(seq & 0xFF, all_on))
            seq += 1
            for _ in range(5):
                time.sleep(0.2)
                port.write(P.heartbeat_frame(seq & 0xFF))
                seq += 1
            kind = bursts % 3
            if kind == 0:
                burst = b"".join(P.heartbeat_frame(i & 0xFF) for i in range(500))
            elif kind == 1:
                burst = b"".join(P.status_frame(i & 0xFF) for i in range(500))
            else:  # 6-byte bad-CRC candidates, each answered by an 11-byte NAK
                burst = b"".join(bytes([0xA5, 0x5A, 0x01, 0x04, i & 0xFF, 0x00, 0x00, 0x00]) for i in range(500))
            port.write(burst)
            bursts += 1
            port.reset_input_buffer()
        t_end = time.monotonic()
        time.sleep(1.0)  # the board answers the last burst's backlog (replies whose seq numbers a new link would reuse)
    from bhr._hardware.link import BoardLink

    with BoardLink(s.pty) as link:
        doc = link.status()
    assert "reset" not in doc["faults"] and not any(f.startswith(("overheat", "cooling")) for f in doc["faults"])
    evs = s.events()
    i_on = next(i for i, e in enumerate(evs) if e["oe"] == "on")
    attack = evs[i_on:]
    # the board never restarted: /OE stayed on (a reset raises it) until the end
    assert all(e["oe"] == "on" for e in attack), [e for e in attack if e["oe"] != "on"][:3]
    t_start, t_stop = attack[0]["t_us"], attack[-1]["t_us"]
    assert (t_stop - t_start) / 1e6 > 0.8 * (t_end - t0)
    for m in range(1, MODULES + 1):
        for bit in range(4):
            runs = on_intervals(attack, m, bit)
            longest = max(b - a for a, b in runs) / 1000
            assert longest <= THERMAL.contract_ms + 2 * PERIOD_MS < THERMAL.max_full_ms, (m, bit, longest)
            on = sum(b - a for a, b in runs)
            span = t_stop - t_start
            allowed = (THERMAL.contract_ms * 1000 + 2 * PERIOD_MS * 1000 + (span - THERMAL.contract_ms * 1000)
                       * THERMAL.duty) / span
            assert on / span <= allowed, (m, bit, on / span, allowed)


def test_killing_the_simulator_mid_stream_is_one_clear_line(sim, tmp_path):
    s = sim()
    rows = [[(0, 3, 6)[(i + j) % 3] for j in range(MODULES)] for i in range(400)]
    f = tmp_path / "codes.csv"
    f.write_text(format_codes_csv(rows))
    proc = subprocess.Popen(bhr_cmd() + ["stream", "--port", s.pty, "--codes", str(f), "--rate", "40",
                                         "--schedule", "auto"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=default_sigint)
    s.wait_for(lambda evs: sum(e["ev"] == "latch" for e in evs) > 10, 90)  # a busy machine starts bhr slowly
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
    proc = subprocess.Popen(bhr_cmd() + ["stream", "--port", s.pty, "--codes", str(f), "--rate", "40",
                                         "--schedule", "auto"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=default_sigint)
    s.wait_for(lambda evs: sum(e["ev"] == "latch" for e in evs) > 10, 90)  # a busy machine starts bhr slowly
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 130
    assert "sent stop-all" in one_line(err)
    evs = s.wait_for(lambda evs: evs[-1]["codes"] == [0] * MODULES and evs[-1]["latched"] == [0] * MODULES, 5)
    assert any(e["ev"] == "oe" and e["oe"] == "off" for e in evs)
    r = run_bhr("status", "--port", s.pty, "--json", "-")
    assert json.loads(r.stdout) == {"codes": [0] * MODULES, "faults": []}
    time.sleep(0.3)
    assert s.events()[-1]["oe"] == "off"  # nothing switched on again after stop-all


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
    assert "drives 5 modules but the codes have 6 per row" in one_line(r.stderr)
    time.sleep(0.2)
    assert not any(e["oe"] == "on" for e in s.events())
    assert all(e["latched"] == [0] * MODULES for e in s.events())


def test_follow_solves_checks_then_streams_the_run(sim, tmp_path):
    s = sim()
    out = tmp_path / "run"
    r = run_bhr("follow", "--traj", "curve", "--radius", "70", "--angle", "90", "--no-plots", "--out", out,
                "--port", s.pty, "--rate", "100", "--schedule", "rate", timeout=600)
    assert r.returncode == 1 and not out.exists()
    assert "nothing was sent; use --rate" in one_line(r.stderr)
    assert not any(e["oe"] == "on" for e in s.events())
    r = run_bhr("follow", "--traj", "curve", "--radius", "70", "--angle", "90", "--no-plots", "--out", out,
                "--port", s.pty, "--rate", "100", "--schedule", "auto", timeout=600)
    assert r.returncode == 0, r.stderr
    steps, rows = read_codes_csv(out / "codes.csv")
    m = re.search(rf"streamed {len(rows)} steps \(5 modules\) to {re.escape(s.pty)} at the wires' pace, at most [0-9.]+ Hz; "
                  r"procedure time ([\d.]+) s \(planned [\d.]+ s\)", r.stderr)
    assert m and 10 < float(m.group(1)) < 120, r.stderr
    assert "Board fault" not in r.stderr
    assert_last_row_on_the_pins(s, rows[-1].tolist())
    check_stream_reached_the_pins(s, rows.tolist())
    # streaming does not change the run: same codes as without --port
    plain = tmp_path / "plain"
    assert run_bhr("follow", "--traj", "curve", "--radius", "70", "--angle", "90", "--no-plots",
                   "--out", plain).returncode == 0
    assert (plain / "codes.csv").read_text() == (out / "codes.csv").read_text()


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
                                         "--port", s.pty, "--rate", "40", "--schedule", "auto"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=default_sigint)
    s.wait_for(lambda evs: sum(e["ev"] == "latch" for e in evs) > 10, 180)
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
    # the board's chain is wired in reverse: position 1 drives module 5 (read from the pin log, which does
    # not depend on how soon after the stream anything else runs)
    assert any(e["codes"] == [15, 0, 0, 6, 3] for e in driven(s.events()))
    from bhr._hardware.link import BoardLink, wait_until_ready

    # and status answers in module order: codes set and read back at once, in this process (a status
    # run as a new command on a busy machine may start after the silence timeout has switched them off)
    with BoardLink(s.pty, module_order=(5, 4, 3, 2, 1)) as link:
        wait_until_ready(link)
        link.set_codes([12, 9, 0, 0, 3])
        assert link.status() == {"codes": [12, 9, 0, 0, 3], "faults": []}
        link.stop_all()


def test_follow_port_ends_with_stop_all_by_default(sim, tmp_path):
    s = sim()
    r = run_bhr("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", tmp_path / "run", "--port", s.pty,
                "--schedule", "auto", timeout=600)
    assert r.returncode == 0, r.stderr
    assert "sent stop-all at the end (--at-end stop): every actuator is off" in r.stderr
    st = run_bhr("status", "--port", s.pty, "--json", "-")
    assert json.loads(st.stdout)["codes"] == [0] * MODULES


def test_status_explains_silence(sim, tmp_path):
    s = sim()  # silence timeout 2 s
    f = tmp_path / "codes.csv"
    f.write_text(format_codes_csv([[3, 0, 0, 0, 0]]))
    assert run_bhr("stream", "--port", s.pty, "--codes", f, "--schedule", "auto").returncode == 0
    s.wait_for(lambda evs: evs[-1]["codes"] == [0] * MODULES and any(e["ev"] == "oe" and e["oe"] == "off"
                                                                      for e in evs[1:]), 30)
    st = run_bhr("status", "--port", s.pty)
    assert st.returncode == 0, st.stderr
    assert "silence" in st.stdout
    assert "the host fell silent for longer than the board's silence timeout" in st.stdout


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
@pytest.mark.parametrize("command", ["stream", "follow"])
def test_sigterm_and_sighup_send_stop_all_like_ctrl_c(sim, tmp_path, sig, command):
    """kill (SIGTERM) or a closed terminal (SIGHUP) mid-stream: stop-all reaches the pins, exit 128 + the signal
    (143, 129: docs/commands.md), one line."""
    s = sim()
    if command == "stream":
        rows = [[3, 6, 9, 12, 15] if i % 2 else [6, 9, 12, 15, 3] for i in range(400)]
        f = tmp_path / "codes.csv"
        f.write_text(format_codes_csv(rows))
        args = ["stream", "--port", s.pty, "--codes", str(f), "--rate", "40", "--schedule", "auto"]
    else:
        args = ["follow", "--traj", "colon", "--no-plots", "--out", str(tmp_path / "o"), "--port", s.pty,
                "--rate", "40", "--schedule", "auto"]  # at the wires' pace: the stream starts, then is cut
    proc = subprocess.Popen(bhr_cmd() + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_sigint)
    s.wait_for(lambda evs: sum(e["ev"] == "latch" for e in evs) > 10, 60)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 128 + sig, err
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


def max_window_duty(evs: list[dict], module: int, bit: int, window_us: int) -> float:
    """The highest on-time fraction of one wire over any window of window_us inside the log (pin log)."""
    runs = on_intervals(evs, module, bit)
    t0, t1 = evs[0]["t_us"], evs[-1]["t_us"]
    w = min(window_us, t1 - t0)
    # the maximum over windows is reached with a window edge on an edge of a run
    starts = {t0, t1 - w} | {a for a, _ in runs} | {b - w for _, b in runs}
    best = 0.0
    for s0 in (x for x in starts if t0 <= x <= t1 - w):
        on = sum(max(0, min(b, s0 + w) - max(a, s0)) for a, b in runs)
        best = max(best, on / w)
    return best


def streaming_part(evs: list[dict]) -> list[dict]:
    """From the first event with the outputs on to the end of the log."""
    i = next(i for i, e in enumerate(evs) if e["oe"] == "on")
    return evs[i:]


def assert_duty_within_limit(evs: list[dict]) -> float:
    from bhr._hardware.thermal import DUTY_WINDOW_MS, duty_limit

    limit = duty_limit(THERMAL)
    worst = 0.0
    for m in range(1, MODULES + 1):
        for bit in range(4):
            d = max_window_duty(evs, m, bit, DUTY_WINDOW_MS * 1000)
            assert d <= limit, (m, bit + 1, d, limit)
            worst = max(worst, d)
    return worst


def test_alternating_codes_that_share_a_wire_keep_it_at_its_hold(sim):
    # 3 <-> 6 every 1.2 s with heartbeats: wire 2 is in both codes. Driven per wire, it contracts once and then
    # holds at the hold duty; it is never pulsed at full power again (module 2 alternates 6 <-> 12, wire 3)
    from bhr._hardware.link import BoardLink

    s = sim()
    with BoardLink(s.pty) as link:
        t_end = time.monotonic() + 24
        k = 0
        while time.monotonic() < t_end:
            link.set_codes([(3, 6)[k % 2], (6, 12)[k % 2], 0, 0, 15])
            k += 1
            for _ in range(4):
                time.sleep(0.3)
                link.heartbeat()
        faults = link.status()["faults"]
        link.stop_all()
    evs = streaming_part(s.events())
    check_patterns(evs)
    worst = assert_duty_within_limit(evs)
    # wire 2 of module 1 after its first contraction: the hold duty, no full-power run past one period
    runs = on_intervals(evs, 1, 1)
    later = [(a, b) for a, b in runs if a > runs[0][1]]
    assert later and max(b - a for a, b in later) / 1000 <= 2 * PERIOD_MS, max(b - a for a, b in later)
    span = later[-1][1] - later[0][0]
    duty = sum(b - a for a, b in later) / span
    assert duty <= THERMAL.duty + 0.02, duty
    assert worst <= 0.7 and not any(f.startswith("overheat") for f in faults), (worst, faults)


def test_all_on_held_with_heartbeats_stays_within_the_duty_limit(sim):
    from bhr._hardware.link import BoardLink

    s = sim()
    with BoardLink(s.pty) as link:
        link.set_codes([15] * MODULES)
        t_end = time.monotonic() + 15
        while time.monotonic() < t_end:
            time.sleep(0.3)
            link.heartbeat()
        assert link.status()["faults"] == []
        link.stop_all()
    evs = streaming_part(s.events())
    check_patterns(evs)
    assert_duty_within_limit(evs)


def test_a_flood_of_random_codes_stays_within_the_duty_limit(sim):
    # rows as fast as the link takes them, random stable codes: the board holds modules off rather than
    # re-energise a wire early, and no wire passes the limit
    import random

    from bhr._hardware.link import BoardLink

    rnd = random.Random(5)
    s = sim()
    with BoardLink(s.pty, timeout=1.0, retries=5) as link:  # patient: a busy machine slows the simulator
        t_end = time.monotonic() + 15
        while time.monotonic() < t_end:
            link.set_codes([rnd.choice(STABLE) for _ in range(MODULES)])
        link.stop_all()
    evs = streaming_part(s.events())
    assert sum(e["ev"] == "latch" for e in evs) > 500  # the outputs really changed, many times
    assert_duty_within_limit(evs)


@contextlib.contextmanager
def machine_load(n: int = 10, seconds: float = 90.0):
    """n busy Python loops (a load of n), each ending by itself after `seconds`, and stopped on exit."""
    code = f"import time\nt = time.monotonic() + {seconds}\nwhile time.monotonic() < t:\n    pass\n"
    procs = [subprocess.Popen([sys.executable, "-c", code]) for _ in range(n)]
    try:
        time.sleep(1.0)
        yield procs
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait(10)


def test_the_silence_timeout_and_the_stream_hold_under_load_10(sim, tmp_path):
    # a load of 10 on this machine: a stream keeps the board alive (heartbeats), the last codes stay on
    # after it, and the silence timeout still switches them off after SILENCE_MS of board time, never sooner
    from bhr._hardware.link import BoardLink, run_stream

    s = sim()
    rows = [[3, 0, 0, 0, 0], [3, 6, 0, 0, 0], [3, 6, 12, 0, 0], [3, 6, 12, 9, 15]]
    with machine_load(10, 90):
        with BoardLink(s.pty) as link:
            report = run_stream(link, rows, rate=0.5, wait_ready=True, at_end="hold")  # 2 s gaps: heartbeats
            assert report.sent == 4 and report.fault_events == []
            assert link.status()["codes"] == [3, 6, 12, 9, 15]
        evs = s.wait_for(lambda evs: any(e["ev"] == "oe" and e["oe"] == "off" for e in evs[1:]),
                         SILENCE_MS / 1000 + 30)
    i_on = next(i for i, e in enumerate(evs) if e["ev"] == "oe" and e["oe"] == "on")
    i_off = next(i for i, e in enumerate(evs) if i > i_on and e["ev"] == "oe" and e["oe"] == "off")
    streaming = driven(evs[i_on:i_off])
    # the outputs stayed on through the whole stream (no silence under load), and went off by the timeout
    assert collapse([e["codes"] for e in streaming])[-1] == [3, 6, 12, 9, 15]
    t_last_row = next(e["t_us"] for e in streaming if e["codes"] == [3, 6, 12, 9, 15])
    assert evs[i_off]["t_us"] - t_last_row >= SILENCE_MS * 1000  # never sooner than the timeout (board time)
    with BoardLink(s.pty) as link:
        assert link.status()["faults"] == ["silence"]


def test_a_board_that_switched_off_mid_stream_stops_the_stream(sim):
    """The host falls silent mid-stream longer than the board's silence timeout (heartbeats every 2.6 s, the
    simulator's timeout 2 s): the real firmware switches every wire off and says "silence" in the next ACK. The
    procedure did not happen: the stream stops there with one line, sends stop-all, and the board is off."""
    from bhr._hardware.link import BoardLink, StreamStopped, run_stream

    s = sim()
    with BoardLink(s.pty) as link:
        with pytest.raises(StreamStopped) as e:
            run_stream(link, [[3, 0, 0, 0, 0], [6, 0, 0, 0, 0]], rate=1 / 8, heartbeat=2.6, at_end="stop")
        assert link.status()["codes"] == [0] * MODULES
    msg = str(e.value)
    assert "reports silence before step 2: it switched every wire off" in msg and "sent stop-all" in msg, msg
    assert "(after 1 of 2 rows)" in msg, msg
    latched = [ev["latched"] for ev in s.events() if ev["ev"] == "latch"]
    assert not any(row[0] & 6 == 6 for row in latched)  # the second row never reached the pins
