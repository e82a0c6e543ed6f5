"""bhr._hardware.protocol: frames, CRC, status parsing and the resynchronizing stream decoder."""
from __future__ import annotations

import random

import pytest

from bhr._hardware import protocol as P
from bhr._settings.errors import BhrError

P_VALID = (0, 3, 6, 9, 12, 15)

# The frames printed in docs/protocol.md (also produced by the C side: test_firmware_host.py).
DOC_VECTORS = {
    "set_codes_seq0_3,0,6,0,0": "a5 5a 01 01 00 06 05 03 00 06 00 00 db 09",
    "status_seq1": "a5 5a 01 02 01 00 af 25",
    "stop_all_seq2": "a5 5a 01 03 02 00 cd 46",
    "heartbeat_seq7": "a5 5a 01 04 07 00 b7 23",
    "ack_seq0": "a5 5a 01 81 00 02 01 00 9e 60",
    "status_reply_seq1": "a5 5a 01 83 01 08 00 01 05 03 00 06 00 00 97 74",
    "nak_bad_code_seq2": "a5 5a 01 82 02 03 01 06 04 14 82",
}


def hexbytes(s: str) -> bytes:
    return bytes.fromhex(s.replace(" ", ""))


def test_crc_is_ccitt_false_with_its_check_value():
    assert P.crc16(b"123456789") == 0x29B1
    assert P.crc16(b"") == 0xFFFF


def test_host_frames_match_the_documented_vectors():
    assert P.set_codes_frame(0, [3, 0, 6, 0, 0]) == hexbytes(DOC_VECTORS["set_codes_seq0_3,0,6,0,0"])
    assert P.status_frame(1) == hexbytes(DOC_VECTORS["status_seq1"])
    assert P.stop_all_frame(2) == hexbytes(DOC_VECTORS["stop_all_seq2"])
    assert P.heartbeat_frame(7) == hexbytes(DOC_VECTORS["heartbeat_seq7"])


def test_board_replies_decode():
    ack = P.decode_frame(hexbytes(DOC_VECTORS["ack_seq0"]))
    assert ack.type == P.Msg.ACK and ack.seq == 0
    assert P.parse_ack(ack) == (P.Msg.SET_CODES, P.Fault(0))
    st = P.decode_frame(hexbytes(DOC_VECTORS["status_reply_seq1"]))
    assert P.parse_status(st) == {"codes": [3, 0, 6, 0, 0], "faults": []}
    nak = P.decode_frame(hexbytes(DOC_VECTORS["nak_bad_code_seq2"]))
    assert P.parse_nak(nak) == (P.Msg.SET_CODES, P.Nak.BAD_CODE, 4)
    assert "module 4" in P.describe(nak)


def test_round_trip_every_type_and_seq():
    for t in list(P.Msg):
        for seq in (0, 1, 127, 255):
            payload = bytes(range(t % 7))
            f = P.decode_frame(P.encode_frame(t, seq, payload))
            assert (f.type, f.seq, f.payload, f.version) == (t, seq, payload, P.VERSION)


def test_decode_names_what_is_wrong():
    good = P.heartbeat_frame(3)
    with pytest.raises(P.ProtocolError, match="CRC"):
        P.decode_frame(good[:-1] + bytes([good[-1] ^ 1]))
    with pytest.raises(P.ProtocolError, match="sync"):
        P.decode_frame(b"\x00" + good[1:])
    with pytest.raises(P.ProtocolError, match="length"):
        P.decode_frame(good + b"\x00")
    with pytest.raises(P.ProtocolError, match="shorter"):
        P.decode_frame(good[:5])
    with pytest.raises(P.ProtocolError, match="longer"):
        P.encode_frame(P.Msg.SET_CODES, 0, bytes(P.MAX_PAYLOAD + 1))
    assert issubclass(P.ProtocolError, BhrError)


def test_set_codes_frame_refuses_unstable_codes():
    for bad in (1, 2, 4, 5, 7, 8, 10, 11, 13, 14, 16, -1):
        with pytest.raises(BhrError, match="module 2"):
            P.set_codes_frame(0, [0, bad, 0])
    with pytest.raises(BhrError):
        P.set_codes_frame(0, [])


def test_status_faults_are_named_per_module():
    payload = bytes([P.Fault.SILENCE | P.Fault.OVERHEAT | P.Fault.COOLING, 1, 3,
                     0 | P.MODULE_OVERHEAT | P.MODULE_COOLING, 6, 0 | P.MODULE_OVERHEAT])
    st = P.parse_status(P.Frame(P.Msg.STATUS_REPLY, 0, payload))
    assert st == {"codes": [0, 6, 0], "faults": ["silence", "overheat:m1", "overheat:m3", "cooling:m1"]}
    with pytest.raises(P.ProtocolError):
        P.parse_status(P.Frame(P.Msg.STATUS_REPLY, 0, bytes([0, 1, 4, 0])))


def test_decoder_handles_frames_split_at_every_byte():
    frames = [P.set_codes_frame(i, [3, 6, 9, 12, 15]) for i in range(3)] + [P.status_frame(9)]
    stream = b"".join(frames)
    d = P.StreamDecoder()
    got = []
    for b in stream:
        got += d.feed(bytes([b]))
    assert [f.encode() for f in got] == frames
    assert not d.pending and d.dropped == 0


def test_decoder_resynchronizes_after_noise_and_corruption():
    d = P.StreamDecoder()
    good = P.set_codes_frame(5, [3, 0, 6, 0, 0])
    bad = bytearray(P.set_codes_frame(6, [15, 0, 0, 0, 0]))
    bad[8] ^= 0x10
    # noise with sync bytes and a false header whose length is impossible
    noise = b"\x00\xa5\xa5\x13\x5a\xa5\x5a\x01\x01\x09\xff"
    got = d.feed(noise + bytes(bad) + good, with_errors=True)
    assert [f.crc_ok for f in got] == [False, True]
    assert got[1].encode() == good
    assert d.bad_crc == 1 and d.dropped > 0


def test_decoder_finds_a_frame_inside_a_truncated_one():
    d = P.StreamDecoder()
    first = P.set_codes_frame(1, [3, 0, 6, 0, 0])
    second = P.set_codes_frame(2, [0, 0, 0, 0, 15])
    got = d.feed(first[:-4] + second + bytes(P.MAX_FRAME))  # zeros: the line goes on idling
    assert [f.seq for f in got] == [2]


def test_decoder_recovers_every_frame_from_random_noise():
    rng = random.Random(1234)
    d = P.StreamDecoder()
    sent, stream = [], bytearray()
    for i in range(400):
        noise = bytes(rng.choice([0xA5, 0x5A, rng.randrange(256)]) for _ in range(rng.randrange(0, 40)))
        frame = P.set_codes_frame(i & 0xFF, [rng.choice(P_VALID) for _ in range(5)])
        stream += noise + frame
        sent.append(frame)
    stream += bytes(P.MAX_FRAME)
    got = []
    pos = 0
    while pos < len(stream):  # arbitrary chunking
        n = rng.randrange(1, 50)
        got += d.feed(bytes(stream[pos:pos + n]))
        pos += n
    assert [f.encode() for f in got if f.type == P.Msg.SET_CODES and f.encode() in sent] == sent


def test_describe_is_one_line():
    for frame in (P.set_codes_frame(1, [3, 0]), P.status_frame(2), P.encode_frame(0x42, 3, b"\x01")):
        text = P.describe(P.decode_frame(frame))
        assert "\n" not in text and "seq=" in text


