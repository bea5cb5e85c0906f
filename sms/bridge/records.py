"""The payload board's UDP data records → readings, through a record-layout table. Pure.

References: docs/wave-glider.md#sensors (the payload board has a UDP data server for each
type of data it produces; the sensor manager decodes their binary records of the
most recent sensor readings); §8.4 of docs/level2.md (the status block the readings
feed: leak 1/2, humidity sensor temperature and humidity, pressure sensor temperature and
pressure).

The layouts are the board's own and are not public, so they are data (``sensor_layouts.toml``),
like the inner command table: each record type names its UDP port, an optional header (fixed
leading bytes that tell a record from garbage), its size and its fields (offset, struct type,
scale, offset, unit, the reading key, an optional plausible range). Every entry says where it
comes from and is ``sourced`` or ``provisional``. Whoever learns the real layout corrects the
file, not the code.

No I/O here but reading the table through ``importlib.resources``: ``sms.bridge.sensors`` does
the sockets.
"""

from __future__ import annotations

import math
import re
import struct
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from telemetry.parsing import MAX_READING_NAME

TABLE_RESOURCE = "sensor_layouts.toml"
SOURCED = "sourced"
PROVISIONAL = "provisional"
_TYPES = {"u8": "B", "i8": "b", "u16": "H", "i16": "h", "u32": "I", "i32": "i", "f32": "f"}
_BYTE_ORDERS = {"little": "<", "big": ">"}
_READING_KEY = re.compile(rf"^[a-z][a-z0-9_]{{0,{MAX_READING_NAME - 1}}}$")
MAX_RECORD_SIZE = 65_507  # the largest UDP payload over IPv4


class SensorError(Exception):
    """Base class of the sensor record errors."""


class LayoutError(SensorError, ValueError):
    """The record-layout table is inconsistent (a mistake by whoever edited it)."""


class RecordError(SensorError):
    """A datagram that is not a record of its type; ``reason`` is a short word for counters."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


@dataclass(frozen=True, slots=True)
class FieldLayout:
    reading: str
    at: int
    type: str
    scale: float = 1.0
    offset: float = 0.0
    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None

    @property
    def size(self) -> int:
        return struct.calcsize("<" + _TYPES[self.type])


@dataclass(frozen=True, slots=True)
class Decoded:
    """What one record gave: the readings, and the fields dropped with the reason."""

    readings: dict[str, float]
    dropped: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class RecordLayout:
    """One record type: where it comes from and how to read it."""

    name: str
    status: str
    source: str
    port: int
    size: int
    fields: tuple[FieldLayout, ...]
    header: bytes = b""
    subscribe: bytes = b"\x00"
    byte_order: str = "little"

    @property
    def provisional(self) -> bool:
        return self.status == PROVISIONAL

    def decode(self, data: bytes) -> Decoded:
        """The readings in ``data``; raises RecordError for a datagram that is not this record.

        1. Shorter than ``size``, or not starting with ``header``: not a record (RecordError).
           Longer is accepted: a newer board may append fields.
        2. Each field is unpacked, scaled (raw × scale + offset) and checked: a NaN, an infinity
           or a value outside the field's plausible range drops that reading, not the record.
        """
        if len(data) < self.size:
            raise RecordError("short", f"{self.name}: {len(data)} bytes, need {self.size}")
        if not data.startswith(self.header):
            raise RecordError("header", f"{self.name}: header {data[: len(self.header)].hex()}")
        readings: dict[str, float] = {}
        dropped: dict[str, str] = {}
        order = _BYTE_ORDERS[self.byte_order]
        for f in self.fields:
            (raw,) = struct.unpack_from(order + _TYPES[f.type], data, f.at)
            value = raw * f.scale + f.offset
            if not math.isfinite(value):
                dropped[f.reading] = "not a number"
            elif (f.minimum is not None and value < f.minimum) or (
                f.maximum is not None and value > f.maximum
            ):
                dropped[f.reading] = f"{value:g} outside {f.minimum:g}–{f.maximum:g}"
            else:
                readings[f.reading] = round(value, 6)  # no 21.000000000000004 in the readings
        return Decoded(readings, dropped)

    def encode(self, values: Mapping[str, float]) -> bytes:
        """A record holding ``values`` (the UDP stand-in's side; missing readings are 0)."""
        data = bytearray(self.size)
        data[: len(self.header)] = self.header
        order = _BYTE_ORDERS[self.byte_order]
        for f in self.fields:
            raw: float = (values.get(f.reading, f.offset) - f.offset) / f.scale
            if f.type != "f32":
                raw = round(raw)
            try:
                struct.pack_into(order + _TYPES[f.type], data, f.at, raw)
            except struct.error as exc:
                raise ValueError(f"{f.reading}={values.get(f.reading)} does not fit") from exc
        return bytes(data)


class RecordTable:
    """The loaded and checked layouts, by name and by UDP port."""

    def __init__(self, records: Mapping[str, RecordLayout]) -> None:
        self.records = dict(records)
        self.by_port = {r.port: r for r in self.records.values()}

    @classmethod
    def load(cls, path: str | Path | None = None) -> RecordTable:
        """The shipped table, or ``path``; raises LayoutError if it is inconsistent."""
        if path is None:
            text = resources.files(__package__).joinpath(TABLE_RESOURCE).read_text("utf-8")
        else:
            text = Path(path).read_text("utf-8")
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise LayoutError(f"sensor layout table is not valid TOML: {exc}") from exc
        return cls.from_dict(data)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RecordTable:
        records = {name: _load_record(name, raw) for name, raw in data.get("records", {}).items()}
        seen_ports: dict[int, str] = {}
        seen_keys: dict[str, str] = {}
        for record in records.values():
            if record.port in seen_ports:
                raise LayoutError(f"{record.name} and {seen_ports[record.port]} share a port")
            seen_ports[record.port] = record.name
            for f in record.fields:
                if f.reading in seen_keys:
                    raise LayoutError(f"reading {f.reading!r} comes from two fields")
                seen_keys[f.reading] = record.name
        return cls(records)


def _load_record(name: str, raw: Mapping[str, Any]) -> RecordLayout:
    """Build one record type and check it; every mistake is a LayoutError naming it."""

    def fail(reason: str) -> LayoutError:
        return LayoutError(f"sensor layout table, [records.{name}]: {reason}")

    if raw.get("status") not in (SOURCED, PROVISIONAL):
        raise fail(f'status must be "{SOURCED}" or "{PROVISIONAL}"')
    if not raw.get("source"):
        raise fail("every record needs a source")
    try:
        fields = tuple(_load_field(f) for f in raw.get("fields", []))
        record = RecordLayout(
            name=name,
            status=raw["status"],
            source=raw["source"],
            port=int(raw["port"]),
            size=int(raw["size"]),
            fields=fields,
            header=bytes.fromhex(raw.get("header", "")),
            subscribe=bytes.fromhex(raw.get("subscribe", "00")),
            byte_order=raw.get("byte_order", "little"),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise fail(f"malformed entry: {exc!r}") from exc
    _check_record(record, fail)
    return record


def _load_field(raw: Mapping[str, Any]) -> FieldLayout:
    return FieldLayout(
        reading=raw["reading"],
        at=int(raw["at"]),
        type=raw["type"],
        scale=float(raw.get("scale", 1.0)),
        offset=float(raw.get("offset", 0.0)),
        unit=str(raw.get("unit", "")),
        minimum=None if raw.get("min") is None else float(raw["min"]),
        maximum=None if raw.get("max") is None else float(raw["max"]),
    )


def _check_record(record: RecordLayout, fail: Any) -> None:
    if not 1 <= record.port <= 0xFFFF:
        raise fail(f"port {record.port} is not a UDP port")
    if record.byte_order not in _BYTE_ORDERS:
        raise fail(f"byte_order must be one of {sorted(_BYTE_ORDERS)}")
    if not len(record.header) <= record.size <= MAX_RECORD_SIZE:
        raise fail("size must hold the header and fit a datagram")
    if not record.fields:
        raise fail("a record needs at least one field")
    occupied = set(range(len(record.header)))
    for f in record.fields:
        if not _READING_KEY.match(f.reading):
            raise fail(f"reading key {f.reading!r}: lower case, digits, _; ≤ {MAX_READING_NAME}")
        if f.type not in _TYPES:
            raise fail(f"{f.reading}: type {f.type!r} unknown (known: {', '.join(_TYPES)})")
        if not math.isfinite(f.scale) or f.scale == 0 or not math.isfinite(f.offset):
            raise fail(f"{f.reading}: scale must be finite and non-zero, offset finite")
        if (f.minimum is None) != (f.maximum is None) or (
            f.minimum is not None and f.maximum is not None and f.minimum > f.maximum
        ):
            raise fail(f"{f.reading}: give both min and max, min ≤ max, or neither")
        span = set(range(f.at, f.at + f.size))
        if f.at < 0 or f.at + f.size > record.size or span & occupied:
            raise fail(f"{f.reading}: overlaps the header or another field, or leaves the record")
        occupied |= span
