"""bhr.hardware.link and the `bhr stream` / `bhr status` commands over real serial I/O.

The peer is either pyserial's ``loop://`` (which answers nothing: every frame
comes back as itself) or a small board emulator on the master side of a
pseudo-terminal pair, speaking bhr.hardware.protocol. The real firmware is exercised
in test_firmware_sim.py.
"""
from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import sys
import threading
import time
import tty
from pathlib import Path

import pytest

from bhr.hardware import protocol as P
from bhr.settings.errors import BhrError, LinkError
from bhr.hardware.link import BoardLink, StreamInterrupted, stream_codes

VALID = (0, 3, 6, 9, 12, 15)


def bhr_cmd() -> list[str]:
    exe = shutil.which("bhr")
    return [exe] if exe else [sys.executable, "-c", "from bhr.cli.main import main; main()"]


def run_bhr(*args, cwd=None, timeout=120):
    return subprocess.run(bhr_cmd() + [str(a) for a in args], capture_output=True, text=True, timeout=timeout,
                          cwd=cwd)


class FakeBoard(threading.Thread):
    """A board emulator on a pty master: enough of the protocol to test the host side."""

    def __init__(self, modules=5, drop_first=0, nak_first=0, drop_all=False, die_after=None):
        super().__init__(daemon=True)
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.modules = modules
        self.drop_first = drop_first
        self.nak_first = nak_first
        self.drop_all = drop_all
        self.die_after = die_after
        self.codes = [0] * modules
        self.received: list[P.Frame] = []
        self._halt = threading.Event()
        self._decoder = P.StreamDecoder()
        self.start()

    def reply(self, frame: P.Frame) -> bytes | None:
        n = len(self.received)
        if self.drop_all or n <= self.drop_first:
            return None
        if n <= self.drop_first + self.nak_first:
            return P.encode_frame(P.Msg.NAK, frame.seq, bytes([frame.type, P.Nak.BAD_CRC, 0]))
        if frame.type == P.Msg.SET_CODES:
            count, codes = frame.payload[0], list(frame.payload[1:])
            if count != self.modules:
                return P.encode_frame(P.Msg.NAK, frame.seq, bytes([frame.type, P.Nak.BAD_COUNT, self.modules]))
            for i, c in enumerate(codes, start=1):
                if c not in VALID:
                    return P.encode_frame(P.Msg.NAK, frame.seq, bytes([frame.type, P.Nak.BAD_CODE, i]))
            self.codes = codes
        elif frame.type == P.Msg.STOP_ALL:
            self.codes = [0] * self.modules
        elif frame.type == P.Msg.STATUS:
            return P.encode_frame(P.Msg.STATUS_REPLY, frame.seq, bytes([0, 1, self.modules] + self.codes))
        return P.encode_frame(P.Msg.ACK, frame.seq, bytes([frame.type, 0]))

    def run(self) -> None:
        while not self._halt.is_set():
            r, _, _ = select.select([self.master], [], [], 0.02)
            if not r:
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            for frame in self._decoder.feed(data):
                self.received.append(frame)
                if self.die_after is not None and len(self.received) > self.die_after:
                    os.close(self.master)
                    os.close(self.slave)
                    return
                out = self.reply(frame)
                if out:
                    os.write(self.master, out)

    def types(self) -> list[str]:
        return [f.type_name for f in self.received]

    def close(self) -> None:
        self._halt.set()
        self.join(2)
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


@pytest.fixture
def board():
    boards = []

    def make(**kw):
        b = FakeBoard(**kw)
        boards.append(b)
        return b

    yield make
    for b in boards:
        b.close()


def one_line(text: str) -> str:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert len(lines) == 1, text
    assert "Traceback" not in text
    return lines[0]


# -------------------------------------------------------------- BoardLink


def test_loop_url_gets_no_answer_and_gives_up_after_bounded_retries():
    link = BoardLink("loop://", timeout=0.05, retries=2)
    t = time.monotonic()
    with pytest.raises(LinkError) as err:
        link.heartbeat()
    assert time.monotonic() - t < 2
    msg = one_line(str(err.value))
    assert "did not answer HEARTBEAT after 3 tries" in msg and "loop://" in msg
    assert link.frames_sent == 3 and link.timeouts == 3
    link.close()
    link.close()  # twice is fine


def test_opening_a_missing_port_is_one_clear_line():
    with pytest.raises(LinkError) as err:
        BoardLink("/dev/bhr-no-such-port")
    assert one_line(str(err.value)).startswith("cannot open serial port /dev/bhr-no-such-port")


def test_set_codes_status_stop_all_over_a_pty(board):
    b = board()
    with BoardLink(b.path) as link:
        assert link.set_codes([3, 0, 6, 0, 0]) == []
        assert link.status() == {"codes": [3, 0, 6, 0, 0], "faults": []}
        link.heartbeat()
        link.stop_all()
        assert link.status()["codes"] == [0] * 5
    assert b.types() == ["SET_CODES", "STATUS", "HEARTBEAT", "STOP_ALL", "STATUS"]
    assert [f.seq for f in b.received] == [0, 1, 2, 3, 4]


def test_lost_and_damaged_frames_are_retried(board):
    b = board(drop_first=2, nak_first=1)
    with BoardLink(b.path, timeout=0.1, retries=3) as link:
        link.set_codes([15, 0, 0, 0, 0])
        assert (link.timeouts, link.damaged) == (2, 1)
    assert b.types() == ["SET_CODES"] * 4
    assert len({f.seq for f in b.received}) == 4  # every try has its own sequence number
    assert b.codes == [15, 0, 0, 0, 0]


def test_a_silent_board_costs_retries_plus_one_tries_then_one_line(board):
    b = board(drop_all=True)
    link = BoardLink(b.path, timeout=0.1, retries=2)
    t = time.monotonic()
    with pytest.raises(LinkError) as err:
        link.set_codes([0] * 5)
    elapsed = time.monotonic() - t
    link.close()
    assert 0.25 < elapsed < 2.0
    assert "did not answer SET_CODES after 3 tries" in one_line(str(err.value))
    assert len(b.received) == 3


def test_refusals_are_reported_not_retried(board):
    b = board(modules=6)
    with BoardLink(b.path) as link:
        with pytest.raises(LinkError) as err:
            link.set_codes([0] * 5)
    msg = one_line(str(err.value))
    assert "drives 6 modules but 5 codes were sent" in msg and "MODULES=5" in msg
    assert len(b.received) == 1


def test_unstable_codes_never_leave_the_host(board):
    b = board()
    with BoardLink(b.path) as link:
        with pytest.raises(BhrError, match="code 5 for module 2"):
            link.set_codes([0, 5, 0, 0, 0])
        table = [[0] * 5, [3] * 5, [0, 7, 0, 0, 0], [6] * 5]
        with pytest.raises(BhrError, match="row 3 module m2"):
            stream_codes(link, table, rate=100)
    assert b.received == []


def test_stream_keeps_the_rate_and_reports_progress(board):
    b = board()
    rows = [[VALID[(i + j) % 6] for j in range(5)] for i in range(10)]
    seen = []
    with BoardLink(b.path) as link:
        t = time.monotonic()
        sent = stream_codes(link, rows, rate=40, progress=lambda done, total: seen.append((done, total)))
        elapsed = time.monotonic() - t
    assert sent == 10 and seen == [(i, 10) for i in range(1, 11)]
    assert elapsed >= 9 / 40 - 0.01
    assert [list(f.payload[1:]) for f in b.received] == rows


def test_slow_rates_send_heartbeats_between_rows(board):
    b = board()
    with BoardLink(b.path) as link:
        stream_codes(link, [[3, 0, 0, 0, 0], [0, 0, 0, 0, 0]], rate=1.5, heartbeat=0.2)
    kinds = b.types()
    assert kinds[0] == "SET_CODES" and kinds[-1] == "SET_CODES"
    assert kinds.count("HEARTBEAT") >= 2


def test_ctrl_c_while_streaming_sends_stop_all(board):
    b = board()
    rows = [[3, 0, 6, 0, 0]] * 20

    def progress(done, total):
        if done == 3:
            raise KeyboardInterrupt

    with BoardLink(b.path) as link:
        with pytest.raises(StreamInterrupted) as err:
            stream_codes(link, rows, rate=200, progress=progress)
    assert isinstance(err.value, KeyboardInterrupt)
    assert err.value.stopped and err.value.sent == 3
    assert b.types() == ["SET_CODES"] * 3 + ["STOP_ALL"]
    assert b.codes == [0] * 5


def test_port_vanishing_mid_stream_is_one_line(board):
    b = board(die_after=5)
    with BoardLink(b.path, timeout=0.1, retries=1) as link:
        with pytest.raises(LinkError) as err:
            stream_codes(link, [[0] * 5] * 50, rate=200)
    msg = one_line(str(err.value))
    assert "lost the serial link" in msg or "did not answer" in msg


# -------------------------------------------------------------- commands


def write_codes(path: Path, rows) -> Path:
    from bhr.model.codes import format_codes_csv

    path.write_text(format_codes_csv(rows))
    return path


def test_stream_dry_run_prints_one_decodable_frame_per_row(tmp_path):
    rows = [[0, 3, 6, 9, 12], [15, 0, 0, 0, 0], [0, 0, 0, 0, 0]]
    f = write_codes(tmp_path / "codes.csv", rows)
    r = run_bhr("stream", "--codes", f, "--dry-run")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 3
    for i, (line, row) in enumerate(zip(lines, rows)):
        frame = P.decode_frame(bytes.fromhex(line.replace(" ", "")))
        assert (frame.type, frame.seq, list(frame.payload)) == (P.Msg.SET_CODES, i, [5] + row)
    assert "nothing sent" in r.stderr


def test_stream_refuses_a_file_with_an_unstable_code_before_the_first_frame(tmp_path, board):
    b = board()
    f = tmp_path / "codes.csv"
    f.write_text("step,m1,m2,m3\n1,0,0,0\n2,3,6,9\n3,12,5,0\n4,0,0,0\n")
    for extra in (["--dry-run"], ["--port", b.path]):
        r = run_bhr("stream", "--codes", f, *extra)
        assert r.returncode == 1 and r.stdout == ""
        msg = one_line(r.stderr)
        assert f"{f}:4" in msg and "column m2" in msg and "code 5" in msg
    assert b.received == []


def test_stream_needs_a_port_unless_dry_run(tmp_path):
    f = write_codes(tmp_path / "codes.csv", [[0] * 5])
    r = run_bhr("stream", "--codes", f)
    assert r.returncode != 0
    assert "--port is required" in one_line(r.stderr)
    r = run_bhr("stream", "--codes", tmp_path / "missing.csv", "--port", "loop://")
    assert r.returncode != 0 and "does not exist" in one_line(r.stderr)
    r = run_bhr("stream", "--codes", f, "--port", "loop://", "--rate", "0")
    assert r.returncode != 0 and "--rate" in one_line(r.stderr)


def test_stream_and_status_commands_over_a_pty(tmp_path, board):
    b = board()
    rows = [[0, 3, 6, 9, 12], [15, 0, 0, 0, 3], [6, 6, 6, 6, 6]]
    f = write_codes(tmp_path / "codes.csv", rows)
    r = run_bhr("stream", "--port", b.path, "--codes", f, "--rate", "50")
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # no progress bar when stderr is not a terminal
    assert "sent 3 rows" in r.stdout
    # before the rows: status requests (is any wire still cooling or relaxing?), then the rows in order
    kinds = [fr.type for fr in b.received]
    assert kinds[-3:] == [P.Msg.SET_CODES] * 3 and set(kinds[:-3]) == {P.Msg.STATUS}
    assert [list(fr.payload[1:]) for fr in b.received if fr.type == P.Msg.SET_CODES] == rows

    r = run_bhr("status", "--port", b.path, "--json", "-")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == {"codes": [6, 6, 6, 6, 6], "faults": []}

    out = tmp_path / "sub" / "status.json"
    r = run_bhr("status", "--port", b.path, "--json", out)
    assert r.returncode == 0, r.stderr
    assert json.loads(out.read_text()) == {"codes": [6, 6, 6, 6, 6], "faults": []}
    assert sorted(p.name for p in out.parent.iterdir()) == ["status.json"]  # no temporary left behind
    assert "m5" in r.stdout and "tilt +y" in r.stdout


def test_status_checks_the_output_path_before_talking_to_the_board(tmp_path, board):
    b = board()
    r = run_bhr("status", "--port", b.path, "--json", tmp_path)
    assert r.returncode == 1 and "is a directory" in one_line(r.stderr)
    assert b.received == []


def test_status_without_a_board_is_one_line(tmp_path):
    r = run_bhr("status", "--port", "/dev/bhr-no-such-port")
    assert r.returncode == 1 and one_line(r.stderr).startswith("Error: cannot open serial port")
    r = run_bhr("status", "--port", "loop://", "--timeout", "0.05", "--retries", "1", "--json", tmp_path / "s.json")
    assert r.returncode == 1 and "did not answer STATUS after 2 tries" in one_line(r.stderr)
    assert not (tmp_path / "s.json").exists()
