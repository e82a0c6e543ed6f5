"""The serial protocol between bhr and the actuator board (docs/protocol.md).

Pure Python: frames, CRC, message types, NAK reasons and a streaming decoder
that resynchronizes after noise. The same layout is implemented in C by
``firmware/src/proto.c``; both are tested against the same vectors.

Frame (all fields one byte unless noted)::

    A5 5A | version | type | seq | len | payload (len bytes) | CRC (2 bytes, high first)

The CRC is CRC-16/CCITT-FALSE (polynomial 0x1021, initial value 0xFFFF, no
reflection, no final XOR) over ``version .. payload``;
``crc16(b"123456789") == 0x29B1``.
"""
from __future__ import annotations

import binascii
import enum
from dataclasses import dataclass, field
from typing import Iterable, Sequence

from bhr._settings.errors import BhrError
from bhr.model._codes import check_codes
from bhr.model._robotfile import MAX_BOARD_MODULES

__all__ = [
    "SYNC", "VERSION", "HEADER_LEN", "CRC_LEN", "MAX_PAYLOAD", "MAX_FRAME",
    "Msg", "Nak", "Fault", "MODULE_OVERHEAT", "MODULE_COOLING", "MODULE_EARLY", "MODULE_RELAXING", "relaxing_modules",
    "ProtocolError", "Frame", "crc16", "encode_frame", "decode_frame",
    "set_codes_frame", "status_frame", "stop_all_frame", "heartbeat_frame",
    "parse_ack", "parse_nak", "parse_status", "check_reply", "describe", "StreamDecoder",
]

SYNC = b"\xA5\x5A"
VERSION = 1
HEADER_LEN = 6
CRC_LEN = 2
MAX_PAYLOAD = 64
MAX_FRAME = HEADER_LEN + MAX_PAYLOAD + CRC_LEN


class Msg(enum.IntEnum):
    """Message types. Host to board below 0x80, board to host from 0x80."""

    SET_CODES = 0x01
    STATUS = 0x02
    STOP_ALL = 0x03
    HEARTBEAT = 0x04
    ACK = 0x81
    NAK = 0x82
    STATUS_REPLY = 0x83


class Nak(enum.IntEnum):
    """NAK reason codes (second payload byte of a NAK)."""

    BAD_CRC = 0x01
    BAD_VERSION = 0x02
    BAD_TYPE = 0x03
    BAD_LENGTH = 0x04
    BAD_COUNT = 0x05
    BAD_CODE = 0x06
    INCOMPLETE = 0x07


#: What each reason means, for error messages.
NAK_TEXT: dict[int, str] = {
    Nak.BAD_CRC: "the frame arrived corrupted (CRC mismatch)",
    Nak.BAD_VERSION: "the board speaks protocol version {detail}",
    Nak.BAD_TYPE: "the board does not know this message type",
    Nak.BAD_LENGTH: "the payload length is wrong for this message",
    Nak.BAD_COUNT: "the board drives {detail} modules",
    Nak.BAD_CODE: "module {detail} got an unstable code",
    Nak.INCOMPLETE: "the frame stopped short (line idle mid-frame)",
}

#: NAK reasons worth a retry: the frame was damaged on the way.
RETRYABLE = frozenset({Nak.BAD_CRC, Nak.INCOMPLETE})


class Fault(enum.IntFlag):
    """Fault flags: first payload byte of a status reply, second of an ACK."""

    SILENCE = 0x01   # outputs were switched off because the host fell silent
    OVERHEAT = 0x02  # a wire reached the thermal model's limit (latched until stop-all)
    COOLING = 0x04   # a module is held off while it cools down
    EARLY = 0x08     # a module was asked to energise a wire still relaxing, and held off (latched)
    RESET = 0x10     # the board restarted (watchdog, brown-out, reset pin) keeping its thermal state (latched)
    FLOOD = 0x20     # replies were dropped: requests came faster than the line could answer (latched)


#: Bits of a module byte in a status reply (the low nibble is the code on the outputs).
MODULE_OVERHEAT = 0x10
MODULE_COOLING = 0x20
MODULE_EARLY = 0x40     # this module was asked to energise a wire still relaxing (latched until stop-all)
MODULE_RELAXING = 0x80  # a released wire of this module has not relaxed yet (a state, not a fault)
#: Every fault bit this version knows.
FAULT_MASK = 0x3F


class ProtocolError(BhrError):
    """A byte string is not a well-formed frame."""


def crc16(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (``crc16(b"123456789") == 0x29B1``).

    The standard library's ``binascii.crc_hqx`` is this CRC (polynomial
    0x1021, MSB first, no final XOR) from the initial value given; the board
    computes it bit by bit in C (firmware/src/proto.c), and a test holds the
    two equal on random data.
    """
    return binascii.crc_hqx(bytes(data), crc)


@dataclass(frozen=True)
class Frame:
    """One frame: its type, sequence number and payload (version 1 unless told)."""

    type: int
    seq: int
    payload: bytes = b""
    version: int = VERSION
    crc_ok: bool = field(default=True, compare=False)

    def encode(self) -> bytes:
        return encode_frame(self.type, self.seq, self.payload, version=self.version)

    @property
    def type_name(self) -> str:
        try:
            return Msg(self.type).name
        except ValueError:
            return f"0x{self.type:02x}"


def encode_frame(msg_type: int, seq: int, payload: bytes | Sequence[int] = b"", *, version: int = VERSION) -> bytes:
    """The bytes of a frame (sync, header, payload, CRC high byte first)."""
    payload = bytes(payload)
    if len(payload) > MAX_PAYLOAD:
        raise ProtocolError(f"payload of {len(payload)} bytes is longer than the protocol's {MAX_PAYLOAD}")
    for name, value in (("type", msg_type), ("seq", seq), ("version", version)):
        if not 0 <= int(value) <= 255:
            raise ProtocolError(f"frame {name} {value} does not fit in a byte")
    body = bytes((version, msg_type, seq, len(payload))) + payload
    crc = crc16(body)
    return SYNC + body + bytes((crc >> 8, crc & 0xFF))


def decode_frame(data: bytes | bytearray) -> Frame:
    """Decode exactly one frame; raise ProtocolError naming what is wrong."""
    data = bytes(data)
    if len(data) < HEADER_LEN + CRC_LEN:
        raise ProtocolError(f"frame of {len(data)} bytes is shorter than the minimum {HEADER_LEN + CRC_LEN}")
    if data[:2] != SYNC:
        raise ProtocolError(f"frame starts with {data[:2].hex()}, not the sync bytes a55a")
    length = data[5]
    if len(data) != HEADER_LEN + length + CRC_LEN:
        raise ProtocolError(f"frame length field says {length} payload bytes but the frame has {len(data) - 8}")
    want = crc16(data[2:HEADER_LEN + length])
    got = (data[-2] << 8) | data[-1]
    if want != got:
        raise ProtocolError(f"frame CRC is {got:04x}, expected {want:04x}")
    return Frame(type=data[3], seq=data[4], payload=data[HEADER_LEN:HEADER_LEN + length], version=data[2])


def set_codes_frame(seq: int, codes: Iterable[int]) -> bytes:
    """SET_CODES: payload = module count, then one code per module (module 1 = base first).

    The codes are checked here too: an unstable code is never encoded.
    """
    values = check_codes(list(codes))
    if not values:
        raise ProtocolError("SET_CODES needs at least one module code")
    if len(values) > MAX_PAYLOAD - 1:
        raise ProtocolError(f"{len(values)} modules do not fit in one frame (at most {MAX_PAYLOAD - 1})")
    return encode_frame(Msg.SET_CODES, seq, bytes([len(values)] + values))


def check_board_modules(count: int, where: str) -> None:
    """Refuse codes for more modules than one board drives (its firmware's BHR_MODULES is 1 ... 32).

    A stream is checked before its first row, with or without ``--dry-run``: a dry run that accepted
    60 modules promised a stream no board takes (the board reports its own count, at most 32).
    """
    if count > MAX_BOARD_MODULES:
        raise BhrError(f"{where} has {count} modules, and one board drives at most {MAX_BOARD_MODULES}; stream the "
                       f"codes of a robot of at most {MAX_BOARD_MODULES} modules (a run without --body-modules)")


def status_frame(seq: int) -> bytes:
    return encode_frame(Msg.STATUS, seq)


def stop_all_frame(seq: int) -> bytes:
    return encode_frame(Msg.STOP_ALL, seq)


def heartbeat_frame(seq: int) -> bytes:
    return encode_frame(Msg.HEARTBEAT, seq)


def parse_ack(frame: Frame) -> tuple[int, Fault]:
    """(acknowledged type, fault flags) of an ACK."""
    if frame.type != Msg.ACK or len(frame.payload) != 2:
        raise ProtocolError(f"not an ACK: {_raw(frame)}")
    return frame.payload[0], Fault(frame.payload[1] & FAULT_MASK)


def parse_nak(frame: Frame) -> tuple[int, int, int]:
    """(refused type, reason, detail) of a NAK."""
    if frame.type != Msg.NAK or len(frame.payload) != 3:
        raise ProtocolError(f"not a NAK: {_raw(frame)}")
    return frame.payload[0], frame.payload[1], frame.payload[2]


def nak_text(reason: int, detail: int = 0) -> str:
    """A short explanation of a NAK reason."""
    text = NAK_TEXT.get(reason)
    if text is None:
        return f"unknown reason 0x{reason:02x}"
    return text.format(detail=detail)


def fault_names(faults: int, module_bytes: Sequence[int] = ()) -> list[str]:
    """Fault flags (and per-module bytes of a status reply) as the names ``bhr status`` prints.

    ``silence``; ``overheat:mK`` for each module whose wire reached the
    thermal limit since the last stop-all; ``cooling:mK`` for each module held
    off while it cools down; ``early:mK`` for each module asked to energise a
    wire that had not relaxed yet; ``reset`` after the board restarted;
    ``flood`` when replies were dropped. Flags without module detail appear bare.
    """
    names = []
    if faults & Fault.SILENCE:
        names.append("silence")
    for flag, bit, name in ((Fault.OVERHEAT, MODULE_OVERHEAT, "overheat"), (Fault.COOLING, MODULE_COOLING, "cooling"),
                            (Fault.EARLY, MODULE_EARLY, "early")):
        mods = [i for i, b in enumerate(module_bytes, start=1) if b & bit]
        if faults & flag and not mods:
            names.append(name)
        names += [f"{name}:m{i}" for i in mods]
    if faults & Fault.RESET:
        names.append("reset")
    if faults & Fault.FLOOD:
        names.append("flood")
    return names


def relaxing_modules(frame: "Frame") -> list[int]:
    """Modules (1-based) of a STATUS_REPLY with a released wire that has not relaxed yet."""
    p = frame.payload
    return [i for i, b in enumerate(p[3:], start=1) if b & MODULE_RELAXING]


def parse_status(frame: Frame) -> dict:
    """A STATUS_REPLY as ``{"codes": [...], "faults": [...]}`` (see fault_names).

    ``codes`` are what the outputs show now, module 1 (the base) first: 0 for
    every module after a stop-all or the silence timeout, and for modules
    held off while cooling.
    """
    p = frame.payload
    if frame.type != Msg.STATUS_REPLY or len(p) < 3 or len(p) != 3 + p[2]:
        raise ProtocolError(f"not a status reply: {_raw(frame)}")
    modules = list(p[3:])
    return {"codes": [b & 0x0F for b in modules], "faults": fault_names(p[0], modules)}


#: What each request is answered with.
REPLY_TYPE = {Msg.SET_CODES: Msg.ACK, Msg.STATUS: Msg.STATUS_REPLY, Msg.STOP_ALL: Msg.ACK, Msg.HEARTBEAT: Msg.ACK}
_STABLE = frozenset({0, 3, 6, 9, 12, 15})


def check_reply(frame: Frame, request: int, modules: int | None = None) -> None:
    """Raise ProtocolError unless ``frame`` is a well-formed answer to a ``request`` (a Msg).

    Checked: version; type (the request's ACK or STATUS_REPLY, or a NAK);
    length; the type an ACK or NAK names; a NAK's reason; fault bits this
    version knows; and in a status reply the module count (at least 1,
    at most MAX_BOARD_MODULES, ``modules`` when given), the enabled byte, a stable code on every module
    (never 5, 7, 13 ...), nothing on the outputs while they are disabled, and
    per-module flags that agree with the fault byte.
    """
    p = frame.payload
    if frame.version != VERSION:
        raise ProtocolError(f"protocol version {frame.version} (bhr speaks {VERSION})")
    if frame.type == Msg.NAK:
        if len(p) != 3:
            raise ProtocolError(f"a NAK of {len(p)} bytes (a NAK has 3)")
        if p[0] != request:
            raise ProtocolError(f"a NAK for message type 0x{p[0]:02x}, not the {Msg(request).name} sent")
        if p[1] not in Nak._value2member_map_:
            raise ProtocolError(f"a NAK with unknown reason 0x{p[1]:02x}")
        return
    want = REPLY_TYPE[Msg(request)]
    if frame.type != want:
        raise ProtocolError(f"{frame.type_name} to {Msg(request).name} (expected {want.name})")
    if want == Msg.ACK:
        if len(p) != 2:
            raise ProtocolError(f"an ACK of {len(p)} bytes (an ACK has 2)")
        if p[0] != request:
            raise ProtocolError(f"an ACK for message type 0x{p[0]:02x}, not the {Msg(request).name} sent")
        if p[1] & ~FAULT_MASK:
            raise ProtocolError(f"unknown fault bits 0x{p[1] & ~FAULT_MASK:02x} in an ACK")
        return
    if len(p) < 3 or len(p) != 3 + p[2]:
        raise ProtocolError(f"a status reply of {len(p)} bytes that does not match its module count")
    count, enabled, faults = p[2], p[1], p[0]
    if count < 1:
        raise ProtocolError("a status reply with 0 modules")
    if count > MAX_BOARD_MODULES:  # the firmware's BHR_MODULES is 1 ... 32 (firmware/src/config.h)
        raise ProtocolError(f"a status reply for {count} modules (a board drives at most {MAX_BOARD_MODULES})")
    if modules is not None and count != modules:
        raise ProtocolError(f"a status reply for {count} modules from a board that drives {modules}")
    if enabled not in (0, 1):
        raise ProtocolError(f"a status reply with output-enable byte {enabled} (0 or 1)")
    if faults & ~FAULT_MASK:
        raise ProtocolError(f"unknown fault bits 0x{faults & ~FAULT_MASK:02x} in a status reply")
    for i, b in enumerate(p[3:], start=1):
        code = b & 0x0F
        if code not in _STABLE:
            raise ProtocolError(f"module {i} reported with the unstable code {code}")
        if code and not enabled:
            raise ProtocolError(f"module {i} reported driving code {code} with the outputs disabled")
        for bit, flag, name in ((MODULE_OVERHEAT, Fault.OVERHEAT, "overheat"), (MODULE_COOLING, Fault.COOLING,
                                                                                  "cooling"),
                                (MODULE_EARLY, Fault.EARLY, "early")):
            if b & bit and not faults & flag:
                raise ProtocolError(f"module {i} flagged {name} but the fault byte does not say {name}")
    for flag, bit, name in ((Fault.OVERHEAT, MODULE_OVERHEAT, "overheat"), (Fault.COOLING, MODULE_COOLING, "cooling"),
                            (Fault.EARLY, MODULE_EARLY, "early")):
        if faults & flag and not any(b & bit for b in p[3:]):
            raise ProtocolError(f"the fault byte says {name} but no module is flagged {name}")


def _raw(frame: Frame) -> str:
    return f"{frame.type_name} seq={frame.seq} payload={frame.payload.hex() or '-'}"


def describe(frame: Frame) -> str:
    """One line naming a frame's type, sequence number and content."""
    p = frame.payload
    head = f"{frame.type_name} seq={frame.seq}"
    if frame.version != VERSION:
        head += f" version={frame.version}"
    try:
        if frame.type == Msg.SET_CODES and p and len(p) == 1 + p[0]:
            return f"{head} modules={p[0]} codes={','.join(str(c) for c in p[1:])}"
        if frame.type == Msg.ACK and len(p) == 2:
            t, faults = parse_ack(frame)
            return f"{head} of {Frame(t, 0).type_name} faults={','.join(fault_names(faults)) or 'none'}"
        if frame.type == Msg.NAK and len(p) == 3:
            t, reason, detail = parse_nak(frame)
            name = Nak(reason).name if reason in Nak._value2member_map_ else f"0x{reason:02x}"
            return f"{head} of {Frame(t, 0).type_name} reason={name} ({nak_text(reason, detail)})"
        if frame.type == Msg.STATUS_REPLY:
            st = parse_status(frame)
            return f"{head} codes={','.join(map(str, st['codes']))} faults={','.join(st['faults']) or 'none'}"
    except ProtocolError:
        pass
    return f"{head} payload={p.hex() or '-'}"


class StreamDecoder:
    """Turn a byte stream into frames, resynchronizing after noise.

    ``feed(data)`` returns the frames completed by ``data``. Bytes before a
    sync pattern are discarded; a candidate whose length field exceeds
    MAX_PAYLOAD is dropped silently; a candidate with a bad CRC is reported
    (``bad_crc`` counter, and in ``feed(..., with_errors=True)`` as a Frame
    with ``crc_ok=False``) and the search restarts one byte after its sync,
    so a real frame that starts inside garbage is still found. This is the
    same algorithm as the firmware's parser.
    """

    def __init__(self) -> None:
        self.buffer = bytearray()
        self.dropped = 0
        self.bad_crc = 0

    def feed(self, data: bytes | bytearray, with_errors: bool = False) -> list[Frame]:
        self.buffer += data
        out: list[Frame] = []
        buf = self.buffer
        while buf:
            if buf[0] != SYNC[0]:
                k = buf.find(SYNC[0], 1)
                k = len(buf) if k < 0 else k
                del buf[:k]
                self.dropped += k
                continue
            if len(buf) < 2:
                break
            if buf[1] != SYNC[1]:
                del buf[:1]
                self.dropped += 1
                continue
            if len(buf) < HEADER_LEN:
                break
            length = buf[5]
            if length > MAX_PAYLOAD:
                del buf[:1]
                self.dropped += 1
                continue
            total = HEADER_LEN + length + CRC_LEN
            if len(buf) < total:
                break
            want = crc16(buf[2:HEADER_LEN + length])
            got = (buf[total - 2] << 8) | buf[total - 1]
            frame = Frame(type=buf[3], seq=buf[4], payload=bytes(buf[HEADER_LEN:HEADER_LEN + length]),
                          version=buf[2], crc_ok=want == got)
            if want == got:
                out.append(frame)
                del buf[:total]
            else:
                self.bad_crc += 1
                if with_errors:
                    out.append(frame)
                del buf[:1]
                self.dropped += 1
        return out

    @property
    def pending(self) -> bool:
        """True while bytes of an unfinished frame are buffered."""
        return bool(self.buffer)

    def reset(self) -> None:
        """Forget buffered bytes (after a timeout: they are stale)."""
        self.dropped += len(self.buffer)
        self.buffer.clear()
