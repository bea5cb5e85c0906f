"""A command in a few bytes, for links billed by the byte (Iridium SBD: a mobile-terminated
message holds at most 270 bytes, and is paid per 50).

Layout, byte-aligned, integers big-endian::

    0xC1                version 1 of the command form (0xC_: a command, _1: its version)
    uid                 16 bytes: the command's UUID, the reference its acknowledgement quotes
    kind                1 byte: the kind's number in KINDS (numbers are never reused)
    presence            one bit per parameter of the kind (first parameter: the top bit of the
                        first byte), absent only when the kind has no parameters; a clear bit
                        is a parameter left out (None)
    parameters          each present one in the kind's order, by its type (TYPES)

Resolutions: positions 1e-7° (ArduPilot's own, ~1 cm), hold 0.1 s, radius 0.1 m, speed
0.01 m/s; whole numbers and choices exactly. ``fence`` carries its fences as deflated JSON
(rare and irregular, so no table of their own). Pure and stdlib-only (the boat–shore
contract): the shore encodes (sbd/commands_wire), the boat decodes; ranges are the catalog's
to check, on both sides, after decoding.
"""

from __future__ import annotations

import json
import struct
import uuid
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from edge_client.contract.catalog import MISSION_ENDS, MISSION_ITEM_PARAMS
from edge_client.contract.kinds import ROVER_MODES

VERSION = 0xC1
MAX_BYTES = 270  # a 9602/9603's mobile-terminated limit (AT+SBDRB reads no more)
HEADER = 1 + 16 + 1
_JSON_MAX = 64 * 1024  # inflated fence JSON; more is not a fence set, it is a bomb
_VARINT_MAX_BYTES = 10
_MODE_NAMES = {number: name for name, number in ROVER_MODES.items()}


class CompactCommandError(ValueError):
    """Bytes that are not a command of this form, or a command this form cannot carry."""


@dataclass(frozen=True)
class WireCommand:
    uid: str  # the UUID in its usual text form
    kind: str
    params: dict[str, Any]


# -- field types: (encode value -> bytes, decode (data, pos) -> (value, pos)) -----------------
Encoder = Callable[[Any], bytes]
Decoder = Callable[[bytes, int], tuple[Any, int]]


def _take(data: bytes, pos: int, n: int) -> bytes:
    if pos + n > len(data):
        raise CompactCommandError("the command ends in the middle of a parameter")
    return data[pos : pos + n]


def _fixed(fmt: str, scale: float) -> tuple[Encoder, Decoder]:
    packer = struct.Struct(">" + fmt)

    def enc(value: Any) -> bytes:
        try:
            return packer.pack(round(float(value) * scale))
        except (struct.error, TypeError, ValueError, OverflowError):
            raise CompactCommandError(f"{value!r} does not fit this parameter") from None

    def dec(data: bytes, pos: int) -> tuple[Any, int]:
        (raw,) = packer.unpack(_take(data, pos, packer.size))
        return (raw / scale if scale != 1 else raw), pos + packer.size

    return enc, dec


def _varint_enc(value: Any) -> bytes:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise CompactCommandError(f"{value!r} is not a whole number 0 or more")
    out = bytearray()
    while True:
        low, value = value & 0x7F, value >> 7
        out.append(low | (0x80 if value else 0))
        if not value:
            break
    if len(out) > _VARINT_MAX_BYTES:
        raise CompactCommandError("a number too large for this form")
    return bytes(out)


def _varint_dec(data: bytes, pos: int) -> tuple[int, int]:
    value = shift = 0
    for i in range(_VARINT_MAX_BYTES):
        byte = _take(data, pos + i, 1)[0]
        value |= (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            if i and not byte:
                raise CompactCommandError("a number written longer than it needs")
            return value, pos + i + 1
    raise CompactCommandError("a number too large for this form")


def _scaled_varint(scale: int) -> tuple[Encoder, Decoder]:
    def enc(value: Any) -> bytes:
        try:
            return _varint_enc(round(float(value) * scale))
        except (TypeError, ValueError, OverflowError):
            raise CompactCommandError(f"{value!r} is not a number") from None

    def dec(data: bytes, pos: int) -> tuple[Any, int]:
        raw, pos = _varint_dec(data, pos)
        return raw / scale, pos

    return enc, dec


def _choice(choices: tuple[str, ...]) -> tuple[Encoder, Decoder]:
    def enc(value: Any) -> bytes:
        if value not in choices:
            raise CompactCommandError(f"{value!r} is not one of {', '.join(choices)}")
        return bytes([choices.index(value)])

    def dec(data: bytes, pos: int) -> tuple[Any, int]:
        index = _take(data, pos, 1)[0]
        if index >= len(choices):
            raise CompactCommandError("a choice this form does not have")
        return choices[index], pos + 1

    return enc, dec


def _mode_enc(value: Any) -> bytes:
    if value not in ROVER_MODES:
        raise CompactCommandError(f"{value!r} is not a Rover mode")
    return bytes([ROVER_MODES[value]])


def _mode_dec(data: bytes, pos: int) -> tuple[Any, int]:
    number = _take(data, pos, 1)[0]
    if number not in _MODE_NAMES:
        raise CompactCommandError(f"{number} is not a Rover mode an operator may ask for")
    return _MODE_NAMES[number], pos + 1


def _bool_enc(value: Any) -> bytes:
    if not isinstance(value, bool):
        raise CompactCommandError(f"{value!r} is not true or false")
    return b"\x01" if value else b"\x00"


def _bool_dec(data: bytes, pos: int) -> tuple[Any, int]:
    byte = _take(data, pos, 1)[0]
    if byte > 1:
        raise CompactCommandError("a flag that is neither 0 nor 1")
    return bool(byte), pos + 1


def _json_enc(value: Any) -> bytes:
    try:
        text = json.dumps(value, separators=(",", ":"), allow_nan=False).encode()
    except (TypeError, ValueError):
        raise CompactCommandError("a parameter JSON cannot carry") from None
    packer = zlib.compressobj(9, zlib.DEFLATED, -15)
    packed = packer.compress(text) + packer.flush()
    return _varint_enc(len(packed)) + packed


def _json_dec(data: bytes, pos: int) -> tuple[Any, int]:
    size, pos = _varint_dec(data, pos)
    packed = _take(data, pos, size)
    inflater = zlib.decompressobj(-15)
    try:
        text = inflater.decompress(packed, _JSON_MAX)
        if inflater.unconsumed_tail or not inflater.eof:
            raise CompactCommandError("the packed parameter is cut short or too large")
        return json.loads(text), pos + size
    except CompactCommandError:
        raise
    except (zlib.error, ValueError, RecursionError):
        raise CompactCommandError("the packed parameter is not deflated JSON") from None


def _list(item: tuple[Encoder, Decoder]) -> tuple[Encoder, Decoder]:
    enc_item, dec_item = item

    def enc(value: Any) -> bytes:
        if not isinstance(value, list | tuple):
            raise CompactCommandError(f"{value!r} is not a list")
        return _varint_enc(len(value)) + b"".join(enc_item(v) for v in value)

    def dec(data: bytes, pos: int) -> tuple[Any, int]:
        count, pos = _varint_dec(data, pos)
        if count > len(data) - pos:  # every entry takes a byte at least
            raise CompactCommandError("a list longer than the command")
        out = []
        for _ in range(count):
            value, pos = dec_item(data, pos)
            out.append(value)
        return out, pos

    return enc, dec


TYPES: dict[str, tuple[Encoder, Decoder]] = {
    "lat": _fixed("i", 1e7),
    "lon": _fixed("i", 1e7),
    "u8": _fixed("B", 1),
    "i8": _fixed("b", 1),
    "u16": _fixed("H", 1),
    "uvar": (_varint_enc, _varint_dec),
    "decis": _scaled_varint(10),  # a hold in 0.1 s
    "dm": _fixed("H", 10),  # a radius in 0.1 m, to 6,553 m
    "cmps": _fixed("H", 100),  # a speed in 0.01 m/s, to 655 m/s
    "bool": (_bool_enc, _bool_dec),
    "rover_mode": (_mode_enc, _mode_dec),
    "mission_end": _choice(MISSION_ENDS),
    "on_off": _choice(("on", "off")),
    "loop_hold": _choice(("LOOP", "HOLD")),
    "u8_list": _list(_fixed("B", 1)),
    "json": (_json_enc, _json_dec),
}
ITEM_TYPES = {"lat": "lat", "lon": "lon", "hold_s": "decis", "radius_m": "dm", "speed_mps": "cmps"}
ITEM_FIELDS = tuple((name, ITEM_TYPES[name]) for name in MISSION_ITEM_PARAMS)
Fields = tuple[tuple[str, str], ...]


def _record(fields: Fields) -> tuple[Encoder, Decoder]:
    """A dict of ``fields``: a presence bitmap, then each present field (None: absent)."""
    width = (len(fields) + 7) // 8

    def enc(value: Any) -> bytes:
        if not isinstance(value, Mapping):
            raise CompactCommandError(f"{value!r} is not an object")
        unknown = set(value) - {name for name, _ in fields}
        if unknown:
            raise CompactCommandError(f"no place for {sorted(unknown)[0]!r} in this form")
        bits, body = 0, bytearray()
        for i, (name, kind) in enumerate(fields):
            if value.get(name) is not None:
                bits |= 1 << (8 * width - 1 - i)
                body += TYPES[kind][0](value[name])
        return (bits.to_bytes(width, "big") if width else b"") + bytes(body)

    def dec(data: bytes, pos: int) -> tuple[Any, int]:
        bits = int.from_bytes(_take(data, pos, width), "big")
        pos += width
        if bits & ((1 << (8 * width - len(fields))) - 1):
            raise CompactCommandError("a parameter this kind does not have")
        out: dict[str, Any] = {}
        for i, (name, kind) in enumerate(fields):
            if bits >> (8 * width - 1 - i) & 1:
                out[name], pos = TYPES[kind][1](data, pos)
            else:
                out[name] = None
        return out, pos

    return enc, dec


TYPES["items"] = _list(_record(ITEM_FIELDS))

# Every kind by its wire number: append new kinds, never renumber or reuse one.
KINDS: tuple[tuple[str, Fields], ...] = (
    ("move_to", (("lat", "lat"), ("lon", "lon"))),
    ("hold", ()),
    ("resume", ()),
    ("return_home", ()),
    ("set_mode", (("mode", "rover_mode"),)),
    ("arm", ()),
    ("disarm", ()),
    (
        "mission",
        (("mission_id", "uvar"), ("items", "items"), ("loop", "bool"), ("end", "mission_end")),
    ),
    ("fence", (("fences", "json"),)),
    # The Wave Glider's (commands/catalog.py).
    ("fhead", (("bearing", "u16"),)),
    ("light", (("state", "on_off"),)),
    ("ir", (("state", "on_off"),)),
    ("waypoint", (("index", "u8"), ("lat", "lat"), ("lon", "lon"))),
    ("holdwp", (("index", "u8"),)),
    ("fseq", (("target", "u8"), ("begin", "u8"), ("end", "u8"))),
    ("rudder", (("angle", "i8"),)),
    ("fcourse", (("mode", "loop_hold"), ("indices", "u8_list"))),
)
_NUMBER = {name: number for number, (name, _) in enumerate(KINDS)}
_RECORDS = [_record(fields) for _, fields in KINDS]


def encode(uid: str | uuid.UUID, kind: str, params: Mapping[str, Any]) -> bytes:
    """The command in this form; CompactCommandError if it has no place here or is over
    MAX_BYTES (a long mission: send it over a link that takes it)."""
    if kind not in _NUMBER:
        raise CompactCommandError(f"the compact form has no kind {kind!r}")
    try:
        uid_bytes = uuid.UUID(str(uid)).bytes
    except ValueError:
        raise CompactCommandError(f"{uid!r} is not a UUID") from None
    number = _NUMBER[kind]
    body = _RECORDS[number][0](params) if KINDS[number][1] else b""
    if params and not KINDS[number][1]:
        raise CompactCommandError(f"{kind} takes no parameters")
    out = bytes([VERSION]) + uid_bytes + bytes([number]) + body
    if len(out) > MAX_BYTES:
        raise CompactCommandError(f"{kind} takes {len(out)} bytes here; at most {MAX_BYTES}")
    return out


def decode(data: bytes) -> WireCommand:
    """The command ``data`` holds; CompactCommandError on anything else."""
    if len(data) < HEADER:
        raise CompactCommandError("too short for a command")
    if data[0] != VERSION:
        raise CompactCommandError(f"not a command of this form (first byte {data[0]:#04x})")
    number = data[17]
    if number >= len(KINDS):
        raise CompactCommandError(f"kind number {number} is unknown here")
    kind, fields = KINDS[number]
    params: dict[str, Any] = {}
    pos = HEADER
    if fields:
        params, pos = _RECORDS[number][1](data, pos)
    if pos != len(data):
        raise CompactCommandError("bytes left over after the command")
    return WireCommand(uid=str(uuid.UUID(bytes=bytes(data[1:17]))), kind=kind, params=params)
