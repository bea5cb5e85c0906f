"""Typed Level 2 bodies. Pure, no I/O.

References (§ as in docs/level2.md#section-numbers-in-the-code):
* §8.1 enumerate, §8.2 enumeration reply and the 42-byte device information block,
* §8.3 request status (6-byte time, lat/lon as minutes × 10⁴, fix flag),
* §8.4 status reply and the 12-byte status block (bit 15 of ``version`` = queued message),
* §8.5 request queued message and its reply (bit 15 of the original type = more follow),
* §8.6 ACK/NAK queued message (command format, u16 response code, inner packet),
* §8.7 generic ACK/NAK, §11.1 the inner command packet, §11.2 the C&C's inner response.

The enumeration bodies (§8.1, §8.2) live in :mod:`.enumeration`, the coordinate helpers in
:mod:`.fields`; both are offered here too. Every body has ``from_bytes`` (raises
:class:`BodyError` on a short or inconsistent body) and ``__bytes__``; :func:`parse_body` picks
the class from the frame; anything unknown stays :class:`RawBody` so nothing is lost.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from datetime import UTC, datetime
from enum import IntEnum

from .codec import NO_ACK_BIT, TYPE_MASK, Frame, MessageType, crc16_arc, type_name
from .enumeration import ACFR_DEVICE_BLOCK_SIZE as ACFR_DEVICE_BLOCK_SIZE
from .enumeration import DEVICE_BLOCK_SIZE as DEVICE_BLOCK_SIZE
from .enumeration import DeviceInfo as DeviceInfo
from .enumeration import Enumerate, EnumerationReply
from .enumeration import ExtraInfo as ExtraInfo
from .errors import BodyError, LocalProtocolError
from .fields import UNITS_PER_DEGREE as UNITS_PER_DEGREE
from .fields import ascii_text as _text
from .fields import degrees_to_l2, format_l2
from .fields import l2_to_degrees as l2_to_degrees
from .fields import need_bytes as _need

# --- status (§8.3, §8.4) -------------------------------------------------------------------

NO_FIX_TIME = bytes((0xFF, 0, 0, 0, 0, 0))  # §8.3: what the C&C sends with no fix
FIX_VALID = ord("Y")  # §8.3 'Y' when valid; 0x00 observed without a fix
_STATUS_REQ = struct.Struct("<6siiB")
YEAR_BASE = 2000  # §8.3: the time's last byte is year − 2000


@dataclass(frozen=True, slots=True)
class StatusRequest:
    """Request status body: UTC time (6 bytes s,m,h,D,M,Y−2000), lat, lon, fix (§8.3)."""

    time: bytes = NO_FIX_TIME
    lat: int = 0
    lon: int = 0
    fix: int = 0

    @classmethod
    def from_bytes(cls, data: bytes) -> StatusRequest:
        _need(data, _STATUS_REQ.size, "status request")
        return cls(*_STATUS_REQ.unpack_from(data))

    def __bytes__(self) -> bytes:
        return _STATUS_REQ.pack(self.time, self.lat, self.lon, self.fix)

    @classmethod
    def with_fix(cls, when: datetime, lat_deg: float, lon_deg: float) -> StatusRequest:
        """The C&C's form with GPS: time, coordinates and 'Y' (§8.3)."""
        time = bytes(
            (when.second, when.minute, when.hour, when.day, when.month, when.year - YEAR_BASE)
        )
        return cls(
            time, degrees_to_l2(lat_deg, limit=90), degrees_to_l2(lon_deg, limit=180), FIX_VALID
        )

    @property
    def valid(self) -> bool:
        return self.fix == FIX_VALID

    @property
    def utc(self) -> datetime | None:
        """The time as a UTC datetime, or None for the no-fix pattern or impossible values."""
        sec, minute, hour, day, month, year = self.time
        try:
            return datetime(YEAR_BASE + year, month, day, hour, minute, sec, tzinfo=UTC)
        except ValueError:
            return None


QUEUED_FLAG = 0x8000  # §8.4: bit 15 of the status block version = a queued message waits
STATUS_VERSION = 0x0001
_STATUS_BLOCK = struct.Struct("<HBBHBBBBBB")


@dataclass(frozen=True, slots=True)
class StatusBlock:
    """The 12-byte status block (§8.4); unsigned bytes, as in the capture."""

    version: int = STATUS_VERSION
    task: int = 0
    board: int = 1
    alarms: int = 0
    leak1: int = 0
    leak2: int = 0
    humidity_temp_c: int = 0
    humidity_pct: int = 0
    pressure_temp_c: int = 0
    pressure_kpa: int = 0

    @property
    def queued(self) -> bool:
        return bool(self.version & QUEUED_FLAG)

    @classmethod
    def from_bytes(cls, data: bytes) -> StatusBlock:
        _need(data, _STATUS_BLOCK.size, "status block")
        return cls(*_STATUS_BLOCK.unpack_from(data))

    def __bytes__(self) -> bytes:
        try:
            return _STATUS_BLOCK.pack(
                self.version,
                self.task,
                self.board,
                self.alarms,
                self.leak1,
                self.leak2,
                self.humidity_temp_c,
                self.humidity_pct,
                self.pressure_temp_c,
                self.pressure_kpa,
            )
        except struct.error as exc:
            raise LocalProtocolError(f"status block field out of range: {exc}") from exc


@dataclass(frozen=True, slots=True)
class StatusReply:
    """ACK body answering request status: orig 0x0022, 1, 1, status block (§8.4)."""

    block: StatusBlock
    total: int = 1
    count: int = 1

    @classmethod
    def from_bytes(cls, data: bytes) -> StatusReply:
        _need(data, 6 + _STATUS_BLOCK.size, "status reply")
        _orig, total, count = struct.unpack_from("<HHH", data)
        return cls(StatusBlock.from_bytes(data[6:]), total, count)

    def __bytes__(self) -> bytes:
        head = struct.pack("<HHH", MessageType.REQUEST_STATUS, self.total, self.count)
        return head + bytes(self.block)


# --- queued messages (§8.5, §11) -------------------------------------------------------------

COMMAND_FORMAT = 0x0001  # §8.6, §11.1: "command format 1"


@dataclass(frozen=True, slots=True)
class QueuedReply:
    """ACK body answering request queued: orig 0x0040 (| 0x8000 if more follow), data (§8.5).

    For the C&C command task the data is command format 1 + an inner command packet (§11.1);
    for the console and Iridium tasks it has no format field (§11.3, §11.4).
    """

    data: bytes
    more: bool = False

    @classmethod
    def from_bytes(cls, data: bytes) -> QueuedReply:
        _need(data, 2, "queued reply")
        orig = data[0] | data[1] << 8
        return cls(bytes(data[2:]), bool(orig & NO_ACK_BIT))

    def __bytes__(self) -> bytes:
        orig = MessageType.REQUEST_QUEUED | (QUEUED_FLAG if self.more else 0)
        return struct.pack("<H", orig) + self.data


INNER_COMMAND_HEADER = 0x0A  # §11.1: "command data packet"
LEVEL1_COMMAND_STRUCT = 0x10  # §11.1: Level-1 structure id
INNER_RESPONSE_TYPE = 0x10  # §11.2: the C&C's response packet type byte
PARAMS_SIZE = 5  # §11.1: Level-1 parameter bytes
_INNER_HEAD = struct.Struct("<BIH")  # type/header byte, WGMS id, data size
_LEVEL1 = struct.Struct("<BH5sii")  # structure id, command value, params, lat, lon


@dataclass(frozen=True, slots=True)
class CommandPacket:
    """The inner command packet (§11.1): 0x0A, WGMS id, size, Level-1 command, inner CRC.

    ``size_includes_crc`` and ``wgms_id`` are the open questions of §13–§14; the table's
    settings choose them (see ``inner.py``).
    """

    value: int
    params: bytes = bytes(PARAMS_SIZE)
    lat: int = 0
    lon: int = 0
    wgms_id: int = 0
    size_includes_crc: bool = False
    with_crc: bool = True

    def level1(self) -> bytes:
        return _LEVEL1.pack(LEVEL1_COMMAND_STRUCT, self.value, self.params, self.lat, self.lon)

    def __bytes__(self) -> bytes:
        level1 = self.level1()
        size = len(level1) + (2 if self.with_crc and self.size_includes_crc else 0)
        packet = _INNER_HEAD.pack(INNER_COMMAND_HEADER, self.wgms_id, size) + level1
        if self.with_crc:
            packet += crc16_arc(packet).to_bytes(2, "little")
        return packet

    @classmethod
    def from_bytes(cls, data: bytes) -> CommandPacket:
        """Parse a packet in either size convention; a present inner CRC must check."""
        _need(data, _INNER_HEAD.size + _LEVEL1.size, "inner command packet")
        head, wgms_id, size = _INNER_HEAD.unpack_from(data)
        if head != INNER_COMMAND_HEADER:
            raise BodyError(f"inner command packet starts 0x{head:02X}, not 0x0A")
        end = _INNER_HEAD.size + _LEVEL1.size
        _sid, value, params, lat, lon = _LEVEL1.unpack_from(data, _INNER_HEAD.size)
        tail = data[end:]
        with_crc = len(tail) >= 2
        if with_crc and crc16_arc(data[: end + 2]) != 0:
            raise BodyError("inner command packet CRC does not check")
        return cls(value, params, lat, lon, wgms_id, size == _LEVEL1.size + 2, with_crc)


@dataclass(frozen=True, slots=True)
class InnerResponse:
    """The C&C's inner response packet (§11.2): type byte, id u32, size u16, data."""

    kind: int
    ident: int
    data: bytes

    @classmethod
    def from_bytes(cls, data: bytes) -> InnerResponse:
        _need(data, _INNER_HEAD.size, "inner response")
        kind, ident, size = _INNER_HEAD.unpack_from(data)
        rest = bytes(data[_INNER_HEAD.size :])
        if size > len(rest):
            raise BodyError(f"inner response says {size} bytes, has {len(rest)}")
        return cls(kind, ident, rest[:size])

    def __bytes__(self) -> bytes:
        return _INNER_HEAD.pack(self.kind, self.ident, len(self.data)) + self.data

    def waypoint(self) -> tuple[int, int] | None:
        """(lat, lon) from a read-waypoint response: its last 8 bytes (§11.2, one real frame)."""
        if len(self.data) < 8:
            return None
        lat, lon = struct.unpack_from("<ii", self.data, len(self.data) - 8)
        return lat, lon


class ResponseCode(IntEnum):
    """Response codes of the ACK/NAK queued message (§8.6, [SRC:ACFR])."""

    ACK = 0
    UNKNOWN_COMMAND = 1
    INVALID_DATA = 2
    UNABLE_TO_COMPLETE = 3
    UNKNOWN_FORMAT = 4


RESPONSE_MEANINGS = {
    ResponseCode.ACK: "accepted",
    ResponseCode.UNKNOWN_COMMAND: "unknown command",
    ResponseCode.INVALID_DATA: "invalid data",
    ResponseCode.UNABLE_TO_COMPLETE: "unable to complete",
    ResponseCode.UNKNOWN_FORMAT: "unknown format",
}


def response_meaning(code: int) -> str:
    """Readable meaning of a 0x0041 response code; unknown codes say so with the number."""
    try:
        return RESPONSE_MEANINGS[ResponseCode(code)]
    except ValueError:
        return f"unknown response code {code}"


@dataclass(frozen=True, slots=True)
class AckNakQueued:
    """ACK/NAK queued message body (§8.6): format u16 = 1, code u16, inner response packet."""

    code: int
    packet: bytes = b""
    format: int = COMMAND_FORMAT

    @classmethod
    def from_bytes(cls, data: bytes) -> AckNakQueued:
        _need(data, 4, "ACK/NAK queued")
        fmt, code = struct.unpack_from("<HH", data)
        return cls(code, bytes(data[4:]), fmt)

    def __bytes__(self) -> bytes:
        return struct.pack("<HH", self.format, self.code) + self.packet

    @property
    def ok(self) -> bool:
        return self.code == ResponseCode.ACK

    @property
    def response(self) -> InnerResponse | None:
        """The inner response packet if one is present and parses, else None."""
        if not self.packet:
            return None
        try:
            return InnerResponse.from_bytes(self.packet)
        except BodyError:
            return None


@dataclass(frozen=True, slots=True)
class Ack:
    """Generic ACK / reply (§8.7): original type (with its bit 15), then details."""

    orig_type: int
    data: bytes = b""

    @classmethod
    def from_bytes(cls, data: bytes) -> Ack:
        _need(data, 2, "ACK")
        return cls(data[0] | data[1] << 8, bytes(data[2:]))

    def __bytes__(self) -> bytes:
        return struct.pack("<H", self.orig_type) + self.data


NAK_INVALID = 0x02  # §8.5: ACFR's "invalid" flag for "nothing queued"


@dataclass(frozen=True, slots=True)
class Nak:
    """Generic NAK (§8.7): original type u16, code u8, details."""

    orig_type: int
    code: int
    details: bytes = b""

    @classmethod
    def from_bytes(cls, data: bytes) -> Nak:
        _need(data, 3, "NAK")
        return cls(data[0] | data[1] << 8, data[2], bytes(data[3:]))

    def __bytes__(self) -> bytes:
        return struct.pack("<HB", self.orig_type, self.code) + self.details


@dataclass(frozen=True, slots=True)
class RawBody:
    """A body this library has no layout for (power 0x0030, telemetry 0x0015, unknown types)."""

    data: bytes = field(default=b"")

    @classmethod
    def from_bytes(cls, data: bytes) -> RawBody:
        return cls(bytes(data))

    def __bytes__(self) -> bytes:
        return self.data


Body = (
    Enumerate
    | EnumerationReply
    | StatusRequest
    | StatusReply
    | QueuedReply
    | AckNakQueued
    | Ack
    | Nak
    | RawBody
)

_REQUESTS: dict[int, type] = {
    MessageType.ENUMERATE: Enumerate,
    MessageType.REQUEST_STATUS: StatusRequest,
    MessageType.ACK_NAK_QUEUED: AckNakQueued,
    MessageType.NAK: Nak,
}
_REPLIES: dict[int, type] = {
    MessageType.ENUMERATE: EnumerationReply,
    MessageType.REQUEST_STATUS: StatusReply,
    MessageType.REQUEST_QUEUED: QueuedReply,
}


def parse_body(frame: Frame) -> Body:
    """The typed body of ``frame`` (raises BodyError if it does not fit its type's layout).

    Replies (type 0x0001) are dispatched on their original type; unknown ones stay ``Ack``.
    Empty bodies of request queued and types without a known layout stay ``RawBody``.
    """
    if frame.msg_type == MessageType.ACK:
        ack = Ack.from_bytes(frame.body)
        cls = _REPLIES.get(ack.orig_type & TYPE_MASK)
        return cls.from_bytes(frame.body) if cls else ack
    cls = _REQUESTS.get(frame.msg_type, RawBody)
    return cls.from_bytes(frame.body)


def summarize(frame: Frame) -> str:
    """One readable line: type, addresses, tid, and a short summary of the body."""
    head = (
        f"{type_name(frame.msg_type)}{' noack' if frame.no_ack else ''} "
        f"{frame.src}->{frame.dest} tid=0x{frame.tid:04X}"
    )
    try:
        body = parse_body(frame)
    except BodyError as exc:
        return f"{head} body-error={exc} raw={frame.body.hex()}"
    return f"{head} {_describe(body)}"


def _describe(body: Body) -> str:
    match body:
        case Enumerate():
            return f"protocols={body.protocols} formats={body.formats}"
        case EnumerationReply(devices=devices):
            d = devices[0]
            return (
                f"enum-reply task/board={d.task:02X}/{d.board:02X} period={d.poll_period_s}s "
                f"flags=0x{d.flags:02X} serial={_text(d.serial)!r} "
                f"desc={_text(d.description).rstrip()!r} block={len(bytes(d))}B"
            )
        case StatusRequest():
            if body.valid:
                where = f"{format_l2(body.lat, 'N', 'S')} {format_l2(body.lon, 'E', 'W')}"
                return f"status-request {body.utc} {where} fix=Y"
            return "status-request no-fix"
        case StatusReply(block=b):
            return (
                f"status-reply version=0x{b.version:04X}{' QUEUED' if b.queued else ''} "
                f"leak={b.leak1}/{b.leak2} T={b.humidity_temp_c}/{b.pressure_temp_c}C "
                f"RH={b.humidity_pct}% P={b.pressure_kpa}kPa"
            )
        case QueuedReply():
            return f"queued-reply{' MORE' if body.more else ''} {_describe_queued(body.data)}"
        case AckNakQueued():
            inner = body.response
            extra = f" inner=0x{inner.kind:02X}/{len(inner.data)}B" if inner else ""
            return f"command-result code={body.code} ({response_meaning(body.code)}){extra}"
        case Ack():
            return f"ack orig={type_name(body.orig_type & TYPE_MASK)} data={len(body.data)}B"
        case Nak():
            return f"nak orig={type_name(body.orig_type & TYPE_MASK)} code={body.code}"
        case RawBody(data=b""):
            return "empty"
        case RawBody():
            return f"raw={body.data[:24].hex()}{'…' if len(body.data) > 24 else ''}"
    return ""  # pragma: no cover - exhaustive above


def _describe_queued(data: bytes) -> str:
    if len(data) >= 3 and data[0] == 0x01 and data[2] == INNER_COMMAND_HEADER:
        try:
            packet = CommandPacket.from_bytes(data[2:])
        except BodyError as exc:
            return f"command ({exc})"
        return (
            f"command value=0x{packet.value:04X} params={packet.params.hex()} "
            f"lat={packet.lat} lon={packet.lon}"
        )
    if len(data) >= 4 and data[:2] == b"\x00\x05":
        text = _text(data[4:]).strip()
        return f"console {text[:48]!r}"
    return f"data={len(data)}B"
