"""Level 2 frame codec: checksum, escaping, header, message types. Pure, no I/O.

References (§ as in docs/level2.md#section-numbers-in-the-code):
* §3 CRC-16/ARC, appended little-endian, residue 0 over the frame after the SOF;
* §4 SOF 0x7E, escaping of 0x7E/0x7D after the SOF, the length field;
* §5 the 11-byte header, bit 15 of the message type meaning "no ACK requested";
* §6 addresses, §7 message types, §12 maximum sizes.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum
from typing import NamedTuple

from .errors import ChecksumError, FrameError, LocalProtocolError

SOF = 0x7E  # §4: start of frame, never escaped
ESC = 0x7D  # §4: escape byte; the next byte is XORed with ESC_XOR
ESC_XOR = 0x20  # §4: 7E -> 7D 5E, 7D -> 7D 5D
ESCAPED_SOF = bytes((ESC, SOF ^ ESC_XOR))  # 7D 5E
ESCAPED_ESC = bytes((ESC, ESC ^ ESC_XOR))  # 7D 5D

HEADER_SIZE = 11  # §5: SOF, length, 4 address bytes, tid, type
CRC_SIZE = 2  # §3
MIN_LENGTH = 12  # §4: length counts itself, header and CRC, not the SOF: 2 + 8 + 2
MAX_LENGTH = 558  # §12: accept L <= 558 (557 "before escaping", the SOF question unresolved)
MAX_BODY = MAX_LENGTH - MIN_LENGTH
NO_ACK_BIT = 0x8000  # §5: bit 15 of the message type set = no ACK requested
TYPE_MASK = 0x7FFF

# SOF, L, dest task, dest board, src task, src board, tid, type (§5)
_HEADER = struct.Struct("<BHBBBBHH")


def _make_crc_table() -> tuple[int, ...]:
    """256-entry table for the reflected CRC-16/ARC polynomial 0xA001 (§3, docs/level2.md)."""
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
        table.append(crc)
    return tuple(table)


_CRC_TABLE = _make_crc_table()


def crc16_arc(data: bytes, crc: int = 0) -> int:
    """CRC-16/ARC of ``data`` (poly 0x8005 reflected, init 0, xorout 0; §3, docs/level2.md).

    Check value: ``crc16_arc(b"123456789") == 0xBB3D``. Not ``binascii.crc_hqx`` (XMODEM).
    """
    table = _CRC_TABLE
    for byte in data:
        crc = (crc >> 8) ^ table[(crc ^ byte) & 0xFF]
    return crc


def escape(data: bytes) -> bytes:
    """Escape 0x7D then 0x7E (order matters, so 7E's escape is not escaped again; §4)."""
    if ESC in data:
        data = data.replace(b"\x7d", ESCAPED_ESC)
    if SOF in data:
        data = data.replace(b"\x7e", ESCAPED_SOF)
    return data


def unescape(data: bytes) -> bytes:
    """Undo :func:`escape`. ``7D`` followed by anything but 5D/5E, or at the end, is a FrameError.

    A raw 0x7E inside ``data`` is also an error: it can only start a new frame (§4).
    """
    if SOF in data:
        raise FrameError("raw 0x7E inside a frame", bytes(data))
    if ESC not in data:
        return bytes(data)
    parts = bytes(data).split(b"\x7d")
    out = [parts[0]]
    for part in parts[1:]:
        if not part:
            raise FrameError("0x7D escape at the end of a frame or doubled", bytes(data))
        first = part[0]
        if first not in (0x5D, 0x5E):
            raise FrameError(f"bad escape 7D {first:02X}", bytes(data))
        out.append(bytes((first ^ ESC_XOR,)))
        out.append(part[1:])
    return b"".join(out)


class MessageType(IntEnum):
    """Message types, bits 0–14 of the type field (§7, docs/level2.md)."""

    NAK = 0x0000
    ACK = 0x0001  # also "reply": the body starts with the original type
    ENUMERATE = 0x0010
    CC_TELEMETRY = 0x0015
    REQUEST_STATUS = 0x0022
    SEND_FORWARD = 0x0024
    POWER = 0x0030
    REQUEST_QUEUED = 0x0040
    ACK_NAK_QUEUED = 0x0041


def type_name(msg_type: int) -> str:
    """Readable name of a 15-bit message type; unknown types as hex."""
    try:
        return MessageType(msg_type).name
    except ValueError:
        return f"0x{msg_type:04X}"


class Address(NamedTuple):
    """A (task id, board id) pair (§6, docs/level2.md)."""

    task: int
    board: int

    def __str__(self) -> str:
        return f"{self.task:02X}/{self.board:02X}"


CC_BOARD = 0x00  # §6: the C&C box is board 0
CC_MAIN = Address(0x00, CC_BOARD)  # §6: main process; source of requests, dest of replies
CC_COMMAND = Address(0x01, CC_BOARD)  # §6: destination of encapsulated commands
CC_IRIDIUM = Address(0x02, CC_BOARD)  # §6
CC_CONSOLE = Address(0x03, CC_BOARD)  # §6
BROADCAST = Address(0xFF, 0xFF)  # §6: enumeration goes to FF/FF


@dataclass(frozen=True, slots=True)
class Frame:
    """One Level 2 frame (§5, docs/level2.md). ``msg_type`` is bits 0–14; ``no_ack`` is bit 15.

    ``bytes(frame)`` gives the escaped wire bytes with SOF, length and CRC.
    """

    msg_type: int
    body: bytes = b""
    tid: int = 0
    dest_task: int = 0
    dest_board: int = 0
    src_task: int = 0
    src_board: int = 0
    no_ack: bool = False

    @property
    def dest(self) -> Address:
        return Address(self.dest_task, self.dest_board)

    @property
    def src(self) -> Address:
        return Address(self.src_task, self.src_board)

    @property
    def type_word(self) -> int:
        """The type field as on the wire, bit 15 included."""
        return self.msg_type | (NO_ACK_BIT if self.no_ack else 0)

    @classmethod
    def make(
        cls,
        msg_type: int,
        body: bytes = b"",
        *,
        tid: int,
        dest: Address,
        src: Address,
        no_ack: bool = False,
    ) -> Frame:
        """Build a frame from addresses; raises LocalProtocolError if a field is out of range."""
        frame = cls(
            int(msg_type), bytes(body), tid, dest.task, dest.board, src.task, src.board, no_ack
        )
        frame.validate()
        return frame

    def validate(self) -> None:
        """Raise LocalProtocolError if a field cannot be encoded (§5, §12)."""
        for name in ("dest_task", "dest_board", "src_task", "src_board"):
            value = getattr(self, name)
            if not 0 <= value <= 0xFF:
                raise LocalProtocolError(f"{name}={value} is not a byte")
        if not 0 <= self.tid <= 0xFFFF:
            raise LocalProtocolError(f"tid={self.tid} is not a u16")
        if not 0 <= self.msg_type <= TYPE_MASK:
            raise LocalProtocolError(f"msg_type=0x{self.msg_type:X} does not fit 15 bits")
        if len(self.body) > MAX_BODY:
            raise LocalProtocolError(f"body of {len(self.body)} bytes exceeds {MAX_BODY} (§12)")

    def to_unescaped(self) -> bytes:
        """SOF + length + header + body + CRC, before escaping (§16 "Encoding")."""
        self.validate()
        head = _HEADER.pack(
            SOF,
            MIN_LENGTH + len(self.body),
            self.dest_task,
            self.dest_board,
            self.src_task,
            self.src_board,
            self.tid,
            self.type_word,
        )
        unescaped = head + self.body
        return unescaped + crc16_arc(unescaped[1:]).to_bytes(2, "little")

    def __bytes__(self) -> bytes:
        unescaped = self.to_unescaped()
        return unescaped[:1] + escape(unescaped[1:])

    @classmethod
    def from_unescaped(cls, frame: bytes) -> Frame:
        """Parse a whole unescaped frame (SOF first). Raises FrameError or ChecksumError."""
        if len(frame) < MIN_LENGTH + 1 or frame[0] != SOF:
            raise FrameError("too short or no SOF", bytes(frame))
        sof, length, dt, db, st, sb, tid, word = _HEADER.unpack_from(frame)
        if length != len(frame) - 1:
            raise FrameError(f"length field {length} != {len(frame) - 1} bytes", bytes(frame))
        if crc16_arc(frame[1:]) != 0:
            raise ChecksumError("CRC-16/ARC residue is not zero", bytes(frame), bytes(frame))
        return cls(
            word & TYPE_MASK,
            bytes(frame[HEADER_SIZE:-CRC_SIZE]),
            tid,
            dt,
            db,
            st,
            sb,
            bool(word & NO_ACK_BIT),
        )

    @classmethod
    def from_bytes(cls, wire: bytes) -> Frame:
        """Parse exactly one escaped wire frame (SOF first, nothing after the CRC)."""
        if not wire or wire[0] != SOF:
            raise FrameError("frame does not start with 0x7E", bytes(wire))
        return cls.from_unescaped(wire[:1] + unescape(wire[1:]))

    def reply(
        self, msg_type: int, body: bytes, *, src: Address, dest: Address | None = None
    ) -> Frame:
        """A reply to this frame: tid echoed, sent to this frame's source unless ``dest`` given."""
        return Frame.make(msg_type, body, tid=self.tid, dest=dest or self.src, src=src)


def peek_header(unescaped: bytes) -> tuple[int, Address, Address, int, int] | None:
    """(length, dest, src, tid, type word) of an unescaped frame with at least a header, else None.

    Used to describe frames whose checksum failed (the ``decode`` command prints them).
    """
    if len(unescaped) < HEADER_SIZE:
        return None
    _sof, length, dt, db, st, sb, tid, word = _HEADER.unpack_from(unescaped)
    return length, Address(dt, db), Address(st, sb), tid, word
