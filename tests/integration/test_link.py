"""bhr._hardware.link and the `bhr stream` / `bhr status` commands over real serial I/O.

The peer is either pyserial's ``loop://`` (which answers nothing: every frame
comes back as itself) or a small board emulator on the master side of a
pseudo-terminal pair, speaking bhr._hardware.protocol. The real firmware is exercised
in test_firmware_sim.py.
"""
from __future__ import annotations

import json
import os
import select
import shlex
import shutil
import subprocess
import sys
import threading
import time
import tty
from pathlib import Path

import pytest

from tests.conftest import make_firmware

from bhr._hardware import protocol as P
from bhr._hardware.link import BoardLink, StreamInterrupted, stream_codes
from bhr._settings.errors import BhrError, LinkError

VALID = (0, 3, 6, 9, 12, 15)


def bhr_cmd() -> list[str]:
    exe = shutil.which("bhr")
    return [exe] if exe else [sys.executable, "-m", "bhr.cli.main"]


def run_bhr(*args, cwd=None, timeout=120):
    return subprocess.run(bhr_cmd() + [str(a) for a in args], capture_output=True, text=True, timeout=timeout,
                          cwd=cwd)


#: A reply timeout no busy machine reaches, for tests that count the board's frames but are not about the timeout:
#: an answer later than the default 0.25 s (the board's thread not run meanwhile) is a retry, a frame more.
#: The timeout and retries have their own tests, with short timeouts and counts that do not depend on load.
PATIENT = 10.0


class FakeBoard(threading.Thread):
    """A board emulator on a pty master: enough of the protocol to test the host side."""

    def __init__(self, modules=5, drop_first=0, nak_first=0, drop_all=False, die_after=None, lie=None):
        super().__init__(daemon=True)
        self.lie = lie  # lie(board, frame) -> bytes to send instead of the true reply (None: the truth)
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
        if self.lie is not None:
            out = self.lie(self, frame)
            if out is not None:
                return out or None
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
    assert time.monotonic() - t >= 3 * 0.05  # each of the 3 tries waited its whole timeout (a bound load cannot break)
    msg = one_line(str(err.value))
    assert "did not answer HEARTBEAT after 3 tries" in msg and "loop://" in msg
    assert link.frames_sent == 3 and link.timeouts == 3
    link.close()
    link.close()  # twice is fine


def test_opening_a_missing_port_is_one_clear_line():
    with pytest.raises(LinkError) as err:
        BoardLink("/dev/bhr-no-such-port")
    assert one_line(str(err.value)).startswith("cannot open serial port /dev/bhr-no-such-port")


@pytest.mark.parametrize("url", ["spy://loop://?file={victim}", "alt://loop://?class=Serial", "hwgrep://.*",
                                 "file://{victim}", "/tmp/../dev/null/../../{victim}", "{victim}"])
def test_the_library_refuses_ports_that_are_not_serial_ports(tmp_path, url):
    victim = tmp_path / "victim.txt"
    victim.write_text("the user's notes\n")
    with pytest.raises(LinkError) as err:
        BoardLink(url.format(victim=victim))
    line = one_line(str(err.value))
    assert "not a serial" in line and "any_url=True" in line
    assert victim.read_text() == "the user's notes\n"  # nothing opened, nothing written


def test_the_library_opens_another_url_when_asked(tmp_path, board):
    b = board()
    log = tmp_path / "traffic.txt"
    with BoardLink(f"spy://{b.path}?file={log}", any_url=True) as link:
        link.stop_all()
    assert log.stat().st_size > 0  # pyserial's logger wrote the traffic, as asked


def test_set_codes_status_stop_all_over_a_pty(board):
    b = board()
    with BoardLink(b.path, timeout=PATIENT) as link:
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
    assert elapsed >= 3 * 0.1  # each try waited its whole timeout; that it stopped is counted, not timed:
    assert "did not answer SET_CODES after 3 tries" in one_line(str(err.value))
    assert len(b.received) == 3


def test_refusals_are_reported_not_retried(board):
    b = board(modules=6)
    with BoardLink(b.path, timeout=PATIENT) as link:
        with pytest.raises(LinkError) as err:
            link.set_codes([0] * 5)
    msg = one_line(str(err.value))
    assert "drives 6 modules but 5 codes were sent" in msg and "MODULES=5" in msg
    assert len(b.received) == 1


def test_unstable_codes_never_leave_the_host(board):
    b = board()
    with BoardLink(b.path, timeout=PATIENT) as link:
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
    with BoardLink(b.path, timeout=PATIENT) as link:
        t = time.monotonic()
        sent = stream_codes(link, rows, rate=40, progress=lambda done, total: seen.append((done, total)))
        elapsed = time.monotonic() - t
    assert sent == 10 and seen == [(i, 10) for i in range(1, 11)]
    assert elapsed >= 9 / 40 - 0.01
    assert [list(f.payload[1:]) for f in b.received] == rows


def test_each_row_waits_its_gap_after_the_board_acknowledged_the_row_before(board):
    # a row the board acknowledges late (a retry after a lost frame, a late answer on a busy machine) reached it
    # late: the next row waits its whole gap after that ACK, else the board sees two rows closer together than
    # the schedule allows (a wire asked to contract again before it relaxed)
    got, answered = [], []

    def slow_first_ack(b, f):
        if f.type == P.Msg.SET_CODES:
            got.append(time.monotonic())
            if len(got) == 1:
                time.sleep(0.3)
            answered.append(time.monotonic())
        return None  # the true answer, once the lie has returned

    b = board(lie=slow_first_ack)
    with BoardLink(b.path, timeout=PATIENT) as link:
        assert stream_codes(link, [[3, 0, 0, 0, 0], [0, 3, 0, 0, 0], [0, 0, 3, 0, 0]], rate=10) == 3
    assert len(got) == 3
    assert all(got[k + 1] - answered[k] >= 0.1 for k in range(2)), (got, answered)


def test_a_reply_that_came_while_the_host_did_not_run_is_taken_not_asked_for_again(board):
    # on a busy machine the host may not run for longer than its timeout while the board answers at once: when the
    # host runs again past its deadline, the reply is waiting in the port, and it answers this frame (its sequence
    # number says so)
    b = board()
    with BoardLink(b.path, timeout=0.05, retries=0) as link:
        link._write(P.heartbeat_frame(7))
        ack = P.encode_frame(P.Msg.ACK, 7, bytes([P.Msg.HEARTBEAT, 0]))
        deadline = time.monotonic() + 30
        while link._ser.in_waiting < len(ack) and time.monotonic() < deadline:  # the board answered
            time.sleep(0.01)
        reply = link._await(7, time.monotonic() - 1.0)  # the host runs again, a second past its deadline
    assert reply is not None and (reply.seq, reply.type) == (7, P.Msg.ACK)


def test_slow_rates_send_heartbeats_between_rows(board):
    b = board()
    with BoardLink(b.path, timeout=PATIENT) as link:
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

    with BoardLink(b.path, timeout=PATIENT) as link:
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
    from bhr.model._codes import format_codes_csv

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
    r = run_bhr("stream", "--port", b.path, "--codes", f, "--rate", "50", "--timeout", PATIENT)
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # no progress bar when stderr is not a terminal
    assert "sent 3 rows" in r.stdout
    # before the rows: status requests (is any wire still cooling or relaxing?), then the rows in order (with
    # status requests before a row that energises a wire released just before, heartbeats while the auto
    # schedule waits for the wires), then the heartbeat of --at-end hold (the default of bhr stream)
    kinds = [fr.type for fr in b.received]
    assert kinds[0] == P.Msg.STATUS and kinds[-1] == P.Msg.HEARTBEAT
    assert set(kinds) == {P.Msg.STATUS, P.Msg.SET_CODES, P.Msg.HEARTBEAT}
    assert kinds.index(P.Msg.SET_CODES) > 0 and kinds.count(P.Msg.SET_CODES) == 3
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


# -------------------------------------------------------------- boards that lie or go quiet


def status_reply(seq, faults, enabled, count, modules):
    return P.encode_frame(P.Msg.STATUS_REPLY, seq, bytes([faults, enabled, count] + list(modules)))


LIES = {
    "zero modules": lambda b, f: status_reply(f.seq, 0, 1, 0, []) if f.type == P.Msg.STATUS else None,
    "unstable code 5": lambda b, f: status_reply(f.seq, 0, 1, 5, [5, 0, 0, 0, 0]) if f.type == P.Msg.STATUS else None,
    "unstable code 7": lambda b, f: status_reply(f.seq, 0, 1, 5, [0, 7, 0, 0, 0]) if f.type == P.Msg.STATUS else None,
    "unstable code 13": lambda b, f: status_reply(f.seq, 0, 1, 5, [0, 0, 13, 0, 0]) if f.type == P.Msg.STATUS
    else None,
    "count and length disagree": lambda b, f: status_reply(f.seq, 0, 1, 5, [0, 0, 0, 0]) if f.type == P.Msg.STATUS
    else None,
    "codes while disabled": lambda b, f: status_reply(f.seq, 0, 0, 5, [3, 0, 0, 0, 0]) if f.type == P.Msg.STATUS
    else None,
    "flag without fault": lambda b, f: status_reply(f.seq, 0, 1, 5, [P.MODULE_OVERHEAT, 0, 0, 0, 0])
    if f.type == P.Msg.STATUS else None,
    "unknown fault bit": lambda b, f: status_reply(f.seq, 0x80, 1, 5, [0] * 5) if f.type == P.Msg.STATUS else None,
    "ACK to STATUS": lambda b, f: P.encode_frame(P.Msg.ACK, f.seq, bytes([f.type, 0])) if f.type == P.Msg.STATUS
    else None,
    # the firmware drives 1 ... 32 modules (BHR_MODULES); 33 fits in a frame but no board sends it
    "33 modules": lambda b, f: status_reply(f.seq, 0, 1, 33, [0] * 33) if f.type == P.Msg.STATUS else None,
}


@pytest.mark.parametrize("lie", list(LIES), ids=list(LIES))
def test_an_impossible_status_is_refused_whole_and_stop_all_sent(board, lie):
    b = board(lie=LIES[lie])
    with BoardLink(b.path, timeout=PATIENT) as link:
        with pytest.raises(LinkError) as err:
            link.status()
    msg = one_line(str(err.value))
    assert "impossible reply" in msg and "sent stop-all" in msg, msg
    assert b.types() == ["STATUS", "STOP_ALL"]


def test_an_ack_for_another_message_type_is_refused(board):
    def lie(b, f):
        if f.type == P.Msg.SET_CODES:
            return P.encode_frame(P.Msg.ACK, f.seq, bytes([P.Msg.HEARTBEAT, 0]))
        return None

    b = board(lie=lie)
    with BoardLink(b.path, timeout=PATIENT) as link:
        with pytest.raises(LinkError, match="an ACK for message type 0x04, not the SET_CODES sent"):
            link.set_codes([3, 0, 0, 0, 0])
    assert b.types() == ["SET_CODES", "STOP_ALL"]


def test_a_status_with_another_module_count_than_before_is_a_lie(board):
    def lie(b, f):
        if f.type == P.Msg.STATUS and len([x for x in b.received if x.type == P.Msg.STATUS]) == 2:
            return status_reply(f.seq, 0, 1, 4, [0] * 4)
        return None

    b = board(lie=lie)
    with BoardLink(b.path, timeout=PATIENT) as link:
        assert len(link.status()["codes"]) == 5
        with pytest.raises(LinkError, match="for 4 modules from a board that drives 5"):
            link.status()


@pytest.mark.parametrize("lie", ["zero modules", "unstable code 7", "ACK to STATUS"])
def test_status_command_on_a_lying_board_is_one_line_and_exit_1(board, lie):
    b = board(lie=LIES[lie])
    r = run_bhr("status", "--port", b.path, "--json", "-")
    assert r.returncode == 1 and r.stdout == ""
    msg = one_line(r.stderr)
    assert msg.startswith("Error: board on") and "impossible reply" in msg


@pytest.mark.parametrize("count", [1, 6])
def test_stream_refuses_codes_for_another_count_than_the_board_reports(board, tmp_path, count):
    # the board says it drives COUNT modules and acknowledges anything: every 5-code row was sent (exit 0)
    def lie(b, f):
        if f.type == P.Msg.STATUS:
            return status_reply(f.seq, 0, 1, count, [0] * count)
        return P.encode_frame(P.Msg.ACK, f.seq, bytes([f.type, 0]))

    b = board(lie=lie)
    f = write_codes(tmp_path / "codes.csv", [[0, 3, 0, 0, 0], [0, 3, 6, 0, 0]])
    r = run_bhr("stream", "--port", b.path, "--codes", f, "--rate", "20", "--timeout", "0.2")
    assert r.returncode == 1 and r.stdout == ""
    msg = one_line(r.stderr)
    assert f"drives {count} modules but the codes have 5 per row" in msg and "sent stop-all" in msg, msg
    assert "SET_CODES" not in b.types() and b.types()[-1] == "STOP_ALL"


@pytest.mark.parametrize("how", ["mute", "closes"])
def test_a_board_that_goes_quiet_after_3_frames_is_one_line_and_exit_1(board, tmp_path, how):
    kw = {"die_after": 3} if how == "closes" else {"lie": lambda b, f: b"" if len(b.received) > 3 else None}
    b = board(**kw)
    f = write_codes(tmp_path / "codes.csv", [[0, 3, 0, 0, 0], [0, 3, 6, 0, 0], [0, 0, 6, 0, 0]] * 10)
    r = run_bhr("stream", "--port", b.path, "--codes", f, "--rate", "10", "--timeout", "0.1", "--retries", "1")
    # it stopped at the first row the board did not answer (tried once and retried once), not at the end of the 30
    assert b.types().count("SET_CODES") <= 3 + 2, b.types()
    assert r.returncode == 1
    msg = one_line(r.stderr)
    assert ("did not answer" in msg or "lost the serial link" in msg) and "rows)" in msg, msg
    if how == "mute":  # the port still works: stop-all was tried (and not acknowledged: the board is mute)
        assert "stop-all was not acknowledged" in msg and b.types()[-1] == "STOP_ALL"
    # and bhr status on the same boards
    b2 = board(**kw)
    for _ in range(3 if how == "closes" else 4):
        with BoardLink(b2.path) as link:
            try:
                link.heartbeat()
            except LinkError:
                pass
    r = run_bhr("status", "--port", b2.path, "--timeout", "0.1", "--retries", "1")
    assert r.returncode == 1 and r.stdout == ""
    msg = one_line(r.stderr)
    assert "did not answer STATUS" in msg or "lost the serial link" in msg or "cannot open" in msg, msg


def test_an_overheat_mid_stream_stops_the_stream_with_stop_all(board, tmp_path):
    def lie(b, f):
        n_rows = sum(x.type == P.Msg.SET_CODES for x in b.received)
        hot = n_rows >= 3
        if f.type == P.Msg.SET_CODES and hot:
            b.codes = list(f.payload[1:])
            return P.encode_frame(P.Msg.ACK, f.seq, bytes([f.type, P.Fault.OVERHEAT | P.Fault.COOLING]))
        if f.type == P.Msg.STATUS and hot and not any(x.type == P.Msg.STOP_ALL for x in b.received):
            mods = [c for c in b.codes]
            mods[1] = P.MODULE_OVERHEAT | P.MODULE_COOLING
            return status_reply(f.seq, P.Fault.OVERHEAT | P.Fault.COOLING, 1, 5, mods)
        return None

    b = board(lie=lie)
    f = write_codes(tmp_path / "codes.csv", [[0, 0, 0, 0, 0], [3, 0, 0, 0, 0]] + [[3, 3, 0, 0, 0]] * 20)
    r = run_bhr("stream", "--port", b.path, "--codes", f, "--rate", "20", "--timeout", PATIENT)
    assert r.returncode == 1
    msg = one_line(r.stderr)
    assert msg.startswith("Error: board on") and "overheat:m2 at step 3" in msg and "sent stop-all" in msg, msg
    assert sum(x.type == P.Msg.SET_CODES for x in b.received) == 3  # nothing after the overheat
    assert b.types()[-1] == "STOP_ALL"


@pytest.mark.parametrize("command", ["stream", "follow"])
def test_a_board_with_a_latched_overheat_is_not_streamed_to(board, tmp_path, command):
    # the board says before the first row that m2 overheated and latched: no row is sent, stop-all is
    def lie(b, f):
        if f.type == P.Msg.STATUS and not any(x.type == P.Msg.STOP_ALL for x in b.received):
            return status_reply(f.seq, P.Fault.OVERHEAT, 1, 5, [0, P.MODULE_OVERHEAT, 0, 0, 0])
        return None

    b = board(lie=lie)
    if command == "stream":
        f = write_codes(tmp_path / "codes.csv", [[3, 0, 0, 0, 0], [3, 3, 0, 0, 0]])
        r = run_bhr("stream", "--port", b.path, "--codes", f, "--rate", "20")
    else:
        r = run_bhr("follow", "--traj", "line", "--length", "20", "--no-plots", "--out", tmp_path / "o",
                    "--port", b.path, "--rate", "20")
    assert r.returncode == 1
    msg = one_line(r.stderr)
    assert msg.startswith("Error: board on") and "overheat:m2" in msg and "stop-all" in msg, msg
    assert not any(x.type == P.Msg.SET_CODES for x in b.received), b.types()
    assert "STOP_ALL" in b.types() and not (tmp_path / "o").exists()


def test_a_board_cooling_forever_is_not_waited_on_past_the_timeout(board):
    from bhr._hardware.link import READY_TIMEOUT, wait_until_ready

    assert READY_TIMEOUT == 30  # docs/protocol.md: "at most 30 s"

    def lie(b, f):
        if f.type == P.Msg.STATUS:
            return status_reply(f.seq, P.Fault.COOLING, 0, 5, [P.MODULE_COOLING, 0, 0, 0, 0])
        return None

    b = board(lie=lie)
    with BoardLink(b.path) as link:
        t = time.monotonic()
        with pytest.raises(LinkError, match="still cooling:m1 after 1.5 s"):
            wait_until_ready(link, timeout=1.5)
        assert time.monotonic() - t >= 1.5 - 0.1
    # a poll every 0.1 s at most, and none once the next would end past the timeout: a wait that ran on (to the
    # default 30 s) would have polled about 300 times. Counted, not timed, so that a busy machine cannot change it.
    assert 1 <= b.types().count("STATUS") <= 1.5 / 0.1 + 1, b.types()


def test_a_cooling_board_stops_bhr_stream_after_30_s(board, tmp_path):
    def lie(b, f):
        if f.type == P.Msg.STATUS:
            return status_reply(f.seq, P.Fault.COOLING, 0, 5, [P.MODULE_COOLING, 0, 0, 0, 0])
        return None

    b = board(lie=lie)
    f = write_codes(tmp_path / "codes.csv", [[3, 0, 0, 0, 0]])
    t = time.monotonic()
    r = run_bhr("stream", "--port", b.path, "--codes", f)
    took = time.monotonic() - t
    assert r.returncode == 1 and took >= 30 - 0.1, took
    assert "still cooling:m1 after 30 s" in one_line(r.stderr)
    assert b.types().count("STATUS") <= 30 / 0.1 + 2, len(b.received)  # polled until 30 s, not past (counted)
    assert "SET_CODES" not in b.types()


def test_a_robot_file_port_cannot_name_a_url_handler_that_writes_files(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    for port in (f"spy://loop://?file={victim}", f"spy://{victim}", "hwgrep://.*", "alt:///dev/null?class=Serial",
                 "rfc2217://localhost:1?logging=debug", f"/dev/../{victim}", str(victim), "loop://?logging=debug",
                 "socket://localhost:7000/x"):
        robot = tmp_path / "r.toml"
        robot.write_text(f'[link]\nport = "{port}"\n')
        r = run_bhr("status", "--robot", robot)
        assert r.returncode == 1 and r.stdout == ""
        msg = one_line(r.stderr)
        assert "link.port" in msg and ("is not a serial" in msg), (port, msg)
        assert victim.read_text() == "precious\n"


def test_the_command_line_port_takes_the_same_allow_list(tmp_path):
    # --port names a wire too: spy:// would write the traffic into the victim, rfc2217/hwgrep open sockets or scan
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    codes = tmp_path / "c.csv"
    codes.write_text("step,m1\n0,3\n")
    for port in (f"spy://loop://?file={victim}", "hwgrep://.*", "rfc2217://localhost:1", f"/dev/../{victim}",
                 "loop://?logging=debug"):
        for args in (["status", "--port", port], ["stream", "--codes", codes, "--port", port],
                     ["follow", "--traj", "line", "--no-plots", "--out", tmp_path / "o", "--port", port]):
            r = run_bhr(*args, cwd=tmp_path)
            assert r.returncode == 1 and r.stdout == "", (args, r.stdout)
            msg = one_line(r.stderr)
            assert "--port" in msg and "is not a serial" in msg and "loop:// or socket://host:port" in msg, msg
            assert victim.read_text() == "precious\n" and not (tmp_path / "o").exists()


def test_robot_file_ports_that_are_serial_devices_or_safe_urls_are_kept():
    from bhr.model._robotfile import check_file_port

    for port in ("/dev/ttyUSB0", "/dev/pts/3", "/dev/serial/by-id/usb-FTDI-if00", "COM3", "loop://",
                 "socket://localhost:7000", "socket://192.168.1.20:4000"):
        assert check_file_port(port) == port


def test_host_crc_is_binascii_crc_hqx_and_agrees_with_the_firmware(tmp_path):
    import binascii
    import random

    exe = Path(__file__).resolve().parents[2] / "firmware" / "build" / "host" / "test_host_m5"
    r = make_firmware("-s", "-C", str(exe.parents[2]), "build/host/test_host_m5", timeout=300)
    assert r.returncode == 0, r.stderr
    rnd = random.Random(11)
    blobs = [b"", b"123456789"] + [bytes(rnd.randrange(256) for _ in range(rnd.randrange(1, 200)))
                                   for _ in range(300)]
    out = subprocess.run([str(exe), "crc"], input="".join(b.hex() + "\n" for b in blobs), capture_output=True,
                         text=True, timeout=60, check=True).stdout.split()
    assert out == [f"{P.crc16(b):04x}" for b in blobs]
    assert all(P.crc16(b) == binascii.crc_hqx(b, 0xFFFF) for b in blobs)
    assert out[1] == "29b1"


def test_dry_run_checks_what_a_real_stream_checks(tmp_path, board):
    # a wire released at step 2 and energised again at step 3, 50 ms later: the board would hold it off
    rows = [[3, 0, 0, 0, 0]] * 15 + [[6, 0, 0, 0, 0], [3, 0, 0, 0, 0]]
    f = write_codes(tmp_path / "codes.csv", rows)
    dry = run_bhr("stream", "--codes", f, "--rate", "20", "--schedule", "rate", "--dry-run")
    b = board()
    real = run_bhr("stream", "--codes", f, "--rate", "20", "--schedule", "rate", "--port", b.path)
    assert dry.returncode == real.returncode == 1 and dry.stdout == ""
    assert "module m1, step 17" in one_line(dry.stderr) and "module m1, step 17" in one_line(real.stderr)
    assert "use --rate" in one_line(dry.stderr) and b.received == []
    # the default schedule is one the board accepts, with and without --dry-run
    dry = run_bhr("stream", "--codes", f, "--rate", "20", "--dry-run")
    assert dry.returncode == 0 and len(dry.stdout.splitlines()) == len(rows)
    assert "the thermal model accepts them at the wires' pace, at most " in dry.stderr


def test_the_hints_bhr_prints_run_as_printed(tmp_path):
    import re
    import shlex

    r = run_bhr("follow", "--traj", "curve", "--angle", "90", "--no-plots", cwd=tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    m = re.search(r"\((bhr plan --codes \S+ --rate \S+) shows the schedule\)", r.stdout + r.stderr)
    assert m, r.stdout + r.stderr
    hint = shlex.split(m.group(1))
    r = run_bhr(*hint[1:], "--no-plots", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = run_bhr(*hint[1:], cwd=tmp_path)  # as printed, figure included
    assert r.returncode == 0, r.stderr
    # bhr stream's own example (--help), with the simulated port replaced by --dry-run
    help_text = run_bhr("stream", "--help").stdout
    ex = next(ln.strip() for ln in help_text.splitlines() if ln.strip().startswith("bhr stream --port"))
    args = shlex.split(ex)[1:]
    i = args.index("--port")
    args[i:i + 2] = ["--dry-run"]
    latest = tmp_path / "bhr-out" / "latest" / "codes.csv"
    assert latest.exists()
    r = run_bhr(*args, cwd=tmp_path)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("folder", ["bhr-out/my run", "bhr-out/it's $HOME"])
def test_the_plan_hint_runs_as_printed_in_a_shell_when_the_folder_has_spaces_or_quotes(tmp_path, folder):
    """The hint printed the folder unquoted: with `--out "bhr-out/my run"`, pasting it gave the shell two words."""
    import re

    r = run_bhr("follow", "--traj", "curve", "--angle", "90", "--no-plots", "--out", folder, cwd=tmp_path,
                timeout=600)
    assert r.returncode == 0, r.stderr
    hint = re.search(r"\((bhr plan --codes .+) shows the schedule\)\.$", r.stdout, re.M).group(1)
    exe = " ".join(shlex.quote(w) for w in bhr_cmd())
    shell = subprocess.run(["sh", "-c", exe + hint[len("bhr"):] + " --no-plots"], cwd=tmp_path, capture_output=True,
                           text=True, timeout=120)
    assert shell.returncode == 0, shell.stderr
    assert re.search(r": 85 steps, [0-9.]+ s at the wires' pace, at most [0-9.]+ Hz: the wires set \d+ of the \d+ step times", shell.stdout, re.M), shell.stdout


def test_status_help_names_every_fault_the_board_can_report():
    text = " ".join(run_bhr("status", "--help").stdout.split())
    names = P.fault_names(P.FAULT_MASK, [P.MODULE_OVERHEAT | P.MODULE_COOLING | P.MODULE_EARLY])
    assert len(names) == len(P.Fault)
    for name in names:
        assert name.replace(":m1", ":mK") in text, name


@pytest.mark.parametrize("fault", ["reset", "flood", "early"])
def test_an_ack_with_a_latched_fault_its_status_denies_is_a_lie(board, tmp_path, fault):
    # round seven: an ACK saying reset (flood, early) mid-stream, and the status asked for its detail saying no
    # fault at all: the stream went on and ended with exit 0, as if nothing was said. A latched fault stays until
    # stop-all, so the two replies cannot both be true.
    flag = {"reset": P.Fault.RESET, "flood": P.Fault.FLOOD, "early": P.Fault.EARLY}[fault]

    def lie(b, f):
        if f.type == P.Msg.SET_CODES and sum(x.type == P.Msg.SET_CODES for x in b.received) >= 3:
            b.codes = list(f.payload[1:])
            return P.encode_frame(P.Msg.ACK, f.seq, bytes([f.type, flag]))
        return None  # the status: the truth as the board keeps it, no fault

    b = board(lie=lie)
    f = write_codes(tmp_path / "codes.csv", [[0, 3, 0, 0, 0], [0, 3, 6, 0, 0], [0, 0, 6, 0, 0]] * 4)
    r = run_bhr("stream", "--port", b.path, "--codes", f, "--rate", "20", "--timeout", "0.2")
    assert r.returncode == 1 and r.stdout == ""
    msg = one_line(r.stderr)
    assert "impossible reply" in msg and f"the ACK of step 3 said {fault}, the status right after does not" in msg, msg
    assert "sent stop-all" in msg and b.types()[-1] == "STOP_ALL"
    assert sum(x.type == P.Msg.SET_CODES for x in b.received) == 3  # nothing after the lie


@pytest.mark.parametrize("after", [1, 2])
def test_a_board_reporting_silence_mid_stream_stops_the_stream(board, tmp_path, after):
    """A board whose ACK of a row carries "silence" (every output switched off) once the stream is under way: the
    firmware clears that flag on every row it accepts, so this board did not do the procedure. bhr stream exited
    0 and printed "sent 3 rows"; now it stops with one line, sends stop-all and exits 1."""
    def silent_after(b, frame):
        rows = sum(fr.type == P.Msg.SET_CODES for fr in b.received)
        if frame.type == P.Msg.SET_CODES and rows > after:
            return P.encode_frame(P.Msg.ACK, frame.seq, bytes([frame.type, P.Fault.SILENCE]))
        return None

    b = board(lie=silent_after)
    f = write_codes(tmp_path / "codes.csv", [[0, 3, 0, 0, 0], [0, 3, 6, 0, 0], [0, 0, 6, 0, 0]])
    r = run_bhr("stream", "--port", b.path, "--codes", f, "--rate", "50")
    assert r.returncode == 1 and "sent 3 rows" not in r.stdout, r.stdout
    msg = one_line(r.stderr)
    assert f"reports silence at step {after + 1}: it switched every wire off" in msg, msg
    assert "sent stop-all" in msg and f"(after {after + 1} of 3 rows)" in msg, msg
    assert b.types()[-1] == "STOP_ALL"
