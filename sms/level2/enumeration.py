"""Level 2 enumeration bodies (§8.1 enumerate, §8.2 its reply and the 42-byte device
information block; docs/level2.md). Pure, no I/O; offered by :mod:`.bodies` too.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from .codec import MessageType
from .errors import BodyError, LocalProtocolError
from .fields import need_bytes

# --- enumerate (§8.1, §8.2) -----------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Enumerate:
    """Request ID / enumerate body: protocols and command formats bit masks, both 1 (§8.1)."""

    protocols: int = 1
    formats: int = 1

    @classmethod
    def from_bytes(cls, data: bytes) -> Enumerate:
        need_bytes(data, 4, "enumerate")
        return cls(*struct.unpack_from("<HH", data))

    def __bytes__(self) -> bytes:
        return struct.pack("<HH", self.protocols, self.formats)


DEVICE_BLOCK_SIZE = 42  # §8.2 [CAP, GOBY]; ACFR's 50 adds 8 zero bytes, tolerated on input
ACFR_DEVICE_BLOCK_SIZE = 50
_DEVICE = struct.Struct("<HHBB6sBIBBBH20s")
assert _DEVICE.size == DEVICE_BLOCK_SIZE


class ExtraInfo:
    """Extra-info flag bits of the device block (§8.2, [SRC:GOBY; SRC:PC notes])."""

    TELEMETRY = 0x01
    POWER = 0x02
    EVENTS = 0x04
    COMMAND_ACK = 0x08


@dataclass(frozen=True, slots=True)
class DeviceInfo:
    """The 42-byte device information block (§8.2); defaults are the real PIB's values."""

    version: int = 1
    device_type: int = 0x0001
    task: int = 0x00
    board: int = 0x01
    serial: bytes = b"123456"
    location: int = 0
    poll_period_s: int = 20
    flags: int = 0
    fw_major: int = 2
    fw_minor: int = 1
    fw_revision: int = 0x0180
    description: bytes = b"Full PIB".ljust(20)
    extra: bytes = b""  # ACFR's 8 trailing bytes, kept so the block round-trips

    @classmethod
    def from_bytes(cls, data: bytes) -> DeviceInfo:
        need_bytes(data, DEVICE_BLOCK_SIZE, "device block")
        return cls(*_DEVICE.unpack_from(data), extra=bytes(data[DEVICE_BLOCK_SIZE:]))

    def __bytes__(self) -> bytes:
        if len(self.serial) != 6 or len(self.description) != 20:
            raise LocalProtocolError("serial must be 6 bytes and description 20 bytes (§8.2)")
        try:
            return (
                _DEVICE.pack(
                    self.version,
                    self.device_type,
                    self.task,
                    self.board,
                    self.serial,
                    self.location,
                    self.poll_period_s,
                    self.flags,
                    self.fw_major,
                    self.fw_minor,
                    self.fw_revision,
                    self.description,
                )
                + self.extra
            )
        except struct.error as exc:
            raise LocalProtocolError(f"device block field out of range: {exc}") from exc

    @staticmethod
    def pad_description(text: str) -> bytes:
        """ASCII, padded with spaces to 20 bytes as the real PIB does (§8.2, §13)."""
        raw = text.encode("ascii")
        if len(raw) > 20:
            raise LocalProtocolError("description is longer than 20 characters")
        return raw.ljust(20)


@dataclass(frozen=True, slots=True)
class EnumerationReply:
    """ACK body answering enumerate: orig type 0x0010, counts, device blocks (§8.2)."""

    devices: tuple[DeviceInfo, ...]
    total: int = 1

    @classmethod
    def from_bytes(cls, data: bytes) -> EnumerationReply:
        need_bytes(data, 6, "enumeration reply")
        orig, total, count = struct.unpack_from("<HHH", data)
        rest = data[6:]
        if count == 0 or len(rest) % count:
            raise BodyError(f"enumeration reply: {len(rest)} bytes for {count} device blocks")
        size = len(rest) // count
        if size not in (DEVICE_BLOCK_SIZE, ACFR_DEVICE_BLOCK_SIZE):
            raise BodyError(f"enumeration reply: device blocks of {size} bytes")
        blocks = tuple(DeviceInfo.from_bytes(rest[i : i + size]) for i in range(0, len(rest), size))
        return cls(blocks, total)

    def __bytes__(self) -> bytes:
        head = struct.pack("<HHH", MessageType.ENUMERATE, self.total, len(self.devices))
        return head + b"".join(bytes(d) for d in self.devices)
