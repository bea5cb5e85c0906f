"""Compact fixes (``application/vnd.shoreside.fixes``): a batch of fixes in a few bytes each.

For links that charge by the byte or by the message (a 3G plan, SMS, Iridium SBD's 340-byte
messages). The boat encodes, the server decodes into the same ingest as JSON; both import this
module, so the two cannot disagree.

**What survives** (each field within half its step, after rounding to the step):

=============  ===============================================  =================================
field          step                                             note
=============  ===============================================  =================================
time           1 s                                              Unix seconds, 1970 to 2106
lat, lon       180 / (2**24 - 1) and 360 / (2**25 - 1) degrees  about 1.2 m
heading_deg    1 degree                                         0 to 359
speed_mps      0.1 m/s                                          0 to 1000
battery_v      0.01 V                                           0 to 1000
readings       the channel's own step (``Channel``)             only channels in the table
=============  ===============================================  =================================

Fixes come out in time order. A field a fix does not have stays absent.

**Layout, version 1.** Seven header bytes: ``0xA1`` (the format in the high nibble, the version
in the low one), a flags byte (bit 0: some fix has readings), the channel table's id (a byte of
the CRC-32 of its names and steps: a payload whose readings were written with another table is
refused, not misread) and the first fix's time (uint32, big-endian). Then a bit stream
(bits.py), padded with zeros to a byte: the number of fixes less one, then each fix:

- 1 bit: its position is absolute (else predicted from the two fixes before it, see below);
- 1 bit: it has the same fields as the fix before it, else 4 bits saying which of heading,
  speed, battery and readings it has;
- the time: the change in the interval between fixes (a vessel reporting on a steady period
  spends one bit);
- the position: absolute, 24 + 25 bits; or the difference from where the last two fixes said
  it would be (same course and speed), a few bits for a vessel on a steady course;
- heading, speed, battery: the change from the fix before when that one had the field, else
  the value itself;
- readings: 1 bit for the same channels as the fix before, else one bit per channel of the
  table; then each channel's value in its steps, as a change when the fix before had it.

Two bytes of CRC-16/CCITT-FALSE over everything before end the payload: together with the
header byte and the stream's own checks (a code longer than any written, fields past the end,
padding that is not zero, values out of range) a corrupt or foreign payload is refused with
CompactError, never decoded into fixes.

Sizes (tests/edge_client/test_compact.py, bench.compact): an absolute fix with heading, speed
and battery is at most 12 bytes of the stream (at speeds below 19 m/s); a fix on a steady
period and course about 4 to 5; 60 such fixes fit an Iridium SBD message of 340 bytes.
"""

from __future__ import annotations

import binascii
import datetime as dt
import math
import struct
import zlib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from edge_client.contract.bits import BitReader, BitsError, BitWriter
from edge_client.contract.fix import MAX_READING_NAME, MAX_READINGS, RANGES

CONTENT_TYPE = "application/vnd.shoreside.fixes"
VERSION = 1
MARK = 0xA0 | VERSION
FLAG_READINGS = 0x01
HEADER = struct.Struct(">BBBI")
CRC_BYTES = 2
MAX_FIXES = 10_000

LAT_BITS, LON_BITS = 24, 25
LAT_MAX, LON_MAX = (1 << LAT_BITS) - 1, (1 << LON_BITS) - 1
LAT_SCALE, LON_SCALE = LAT_MAX / 180, LON_MAX / 360
HEADING_BITS = 9
SPEED_STEP, BATTERY_STEP = 0.1, 0.01
SPEED_DIVISOR, BATTERY_DIVISOR = 10, 100  # 1 / the steps, for exact decimals (_fix)
MAX_TIME = (1 << 32) - 1
# A reading is at most this many of its steps from zero: the longest code a reader takes
# (bits.MAX_PREFIX) holds it, so whatever encodes also decodes.
MAX_READING_STEPS = 1 << 36
SPEED_MAX = round(RANGES["speed_mps"][1] / SPEED_STEP)
BATTERY_MAX = round(RANGES["battery_v"][1] / BATTERY_STEP)

# Exp-Golomb orders (bits.py), fitted to boats and gliders reporting every 2 s to 10 min:
K_COUNT = 4
K_TIME = 0  # the change in interval: 0 on a steady period
K_POSITION = 2  # metres off the predicted position, in steps of about 1.2 m
K_HEADING = 2
K_SPEED, K_SPEED_FIRST = 1, 5
K_BATTERY, K_BATTERY_FIRST = 1, 10
K_READING, K_READING_FIRST = 2, 8

# Which optional fields a fix has, in the order of the 4 bits that say so.
OPTIONAL = ("heading_deg", "speed_mps", "battery_v", "readings")


class CompactError(ValueError):
    """Fixes that cannot be encoded, or bytes that are not a compact payload (says why)."""


@dataclass(frozen=True)
class Channel:
    """A reading in a vessel's channel table: its name, and the step its values are kept to."""

    name: str
    step: float = 0.01

    def __post_init__(self) -> None:
        if not self.name or len(self.name) > MAX_READING_NAME:
            raise CompactError(f"a channel name must be 1 to {MAX_READING_NAME} characters")
        if not (isinstance(self.step, int | float) and math.isfinite(self.step) and self.step > 0):
            raise CompactError(f"channel {self.name}: the step must be a positive number")


def table_id(channels: Sequence[Channel]) -> int:
    """One byte that differs, almost always, between two different channel tables."""
    # float(): a step of 1 in one side's JSON and 1.0 in the other's TOML are one table.
    text = "\n".join(f"{c.name}={float(c.step)!r}" for c in channels)
    return zlib.crc32(text.encode()) & 0xFF


def channels_from(table: Iterable[Mapping[str, Any]]) -> list[Channel]:
    """A channel table from its JSON form ``[{"name": ..., "step": ...}, ...]``."""
    try:
        channels = [Channel(str(c["name"]), float(c.get("step", 0.01))) for c in table]
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise CompactError(f"a channel table is a list of {{name, step}}: {exc}") from None
    if len({c.name for c in channels}) != len(channels):
        raise CompactError("a channel table names each channel once")
    return channels


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF): catches every burst of up to 16 bits."""
    return binascii.crc_hqx(data, 0xFFFF)


# --- encoding ----------------------------------------------------------------------------------


@dataclass(slots=True)
class _Quantised:
    t: int
    lat: int
    lon: int
    heading: int | None
    speed: int | None
    battery: int | None
    readings: dict[int, int] | None


def encode(
    fixes: Sequence[Mapping[str, Any]],
    channels: Sequence[Channel] = (),
    *,
    drop_unknown: bool = False,
) -> bytes:
    """The fixes (the v1 API's shape: time as ISO 8601 with an offset or Unix seconds) as one
    payload. Readings must be in ``channels`` (else CompactError, or left out when
    ``drop_unknown``)."""
    if not fixes:
        raise CompactError("no fixes to encode")
    if len(fixes) > MAX_FIXES:
        raise CompactError(f"at most {MAX_FIXES} fixes per payload")
    index = {c.name: i for i, c in enumerate(channels)}
    quantised = [_quantise(i, f, channels, index, drop_unknown) for i, f in enumerate(fixes)]
    quantised.sort(key=lambda q: q.t)  # stable: payload_order's order
    has_readings = any(q.readings for q in quantised)
    base = quantised[0].t
    w = BitWriter()
    w.exp_golomb(len(quantised) - 1, K_COUNT)
    _Stream(channels).write_all(w, quantised)
    head = HEADER.pack(MARK, FLAG_READINGS if has_readings else 0, table_id(channels), base)
    body = head + w.bytes()
    return body + crc16(body).to_bytes(CRC_BYTES, "big")


def payload_order(fixes: Sequence[Mapping[str, Any]]) -> list[int]:
    """The indices of ``fixes`` in the order a payload holds them (by time to the second,
    stable), which is the order of the answer's ``rejected`` indices: a sender that wants
    them to be its own sorts its batch so first. CompactError for a fix without a time."""
    times = [round(_seconds(i, f.get("time") if isinstance(f, Mapping) else None))
             for i, f in enumerate(fixes)]  # fmt: skip
    return sorted(range(len(fixes)), key=times.__getitem__)


def _quantise(
    i: int,
    fix: Mapping[str, Any],
    channels: Sequence[Channel],
    index: Mapping[str, int],
    drop_unknown: bool,
) -> _Quantised:
    if not isinstance(fix, Mapping):
        raise CompactError(f"fix {i}: not an object")
    t = round(_seconds(i, fix.get("time")))
    if not 0 <= t <= MAX_TIME:
        raise CompactError(f"fix {i}: time out of range (1970 to 2106)")
    lat, lon = _number(i, fix, "lat", required=True), _number(i, fix, "lon", required=True)
    heading = _number(i, fix, "heading_deg")
    speed, battery = _number(i, fix, "speed_mps"), _number(i, fix, "battery_v")
    return _Quantised(
        t=t,
        lat=round((lat + 90) * LAT_SCALE),  # type: ignore[operator]
        lon=round((lon + 180) * LON_SCALE),  # type: ignore[operator]
        heading=None if heading is None else round(heading) % 360,
        speed=None if speed is None else round(speed / SPEED_STEP),
        battery=None if battery is None else round(battery / BATTERY_STEP),
        readings=_readings(i, fix.get("readings"), channels, index, drop_unknown),
    )


def _seconds(i: int, value: Any) -> float:
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    if isinstance(value, str):
        try:
            when = dt.datetime.fromisoformat(value)
        except ValueError:
            when = None
        if when is not None and when.tzinfo is not None:
            return when.timestamp()
    raise CompactError(f"fix {i}: time must be ISO 8601 with a UTC offset, or Unix seconds")


def _number(i: int, fix: Mapping[str, Any], name: str, required: bool = False) -> float | None:
    value = fix.get(name)
    if value is None:
        if required:
            raise CompactError(f"fix {i}: {name} is required")
        return None
    low, high = RANGES[name]
    kind = type(value)
    # A plain float or int in range (NaN fails the comparison, the ranges are finite): the
    # everyday case, checked in one step; anything else the long way.
    if (kind is float or kind is int) and low <= value <= high:
        return float(value)
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if not ok or not math.isfinite(value) or not low <= value <= high:
        raise CompactError(f"fix {i}: {name} must be a number from {low} to {high}")
    return float(value)


def _readings(
    i: int,
    readings: Any,
    channels: Sequence[Channel],
    index: Mapping[str, int],
    drop_unknown: bool,
) -> dict[int, int] | None:
    if not readings:
        return None
    if not isinstance(readings, Mapping) or len(readings) > MAX_READINGS:
        raise CompactError(f"fix {i}: readings must be an object of at most {MAX_READINGS}")
    out = {}
    unknown = []
    for name, value in readings.items():
        at = index.get(name)
        if at is None:
            unknown.append(str(name))
            continue
        kind = type(value)
        # A plain finite float or an int, the everyday case, skips the long checks.
        if not (kind is int or (kind is float and math.isfinite(value))):
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if not ok or not math.isfinite(value):
                raise CompactError(f"fix {i}: reading {name} must be a number")
        steps = value / channels[at].step
        if not abs(steps) < MAX_READING_STEPS:  # also inf: 1e308 / 0.01
            raise CompactError(f"fix {i}: reading {name} is too large for its step")
        out[at] = round(steps)
    if unknown and not drop_unknown:
        unknown.sort()
        raise CompactError(f"fix {i}: readings not in the channel table: {', '.join(unknown)}")
    return out or None


def _eg_bits(value: int, k: int) -> int:
    """Bits of ``value`` (signed, zigzagged) as an order-k Exp-Golomb code."""
    z = (value << 1) if value >= 0 else (-value << 1) - 1
    return 2 * (z + (1 << k)).bit_length() - k - 1


class _Stream:
    """The state both ends keep while walking the fixes: the fix before, and the one before
    that, for the predictions. One class writes and reads, so the two walks cannot differ."""

    def __init__(self, channels: Sequence[Channel]) -> None:
        self.channels = channels
        self.prev: _Quantised | None = None
        self.shape: tuple[bool, ...] = (False, False, False, False)
        self.interval = 0
        self.step_lat = self.step_lon = 0

    def expected(self, t: int) -> tuple[int, int]:
        """Where a steady course puts the fix at ``t``: the last step, scaled to this interval
        and rounded half up. Integer arithmetic: the boat and the server must get the same
        number."""
        prev = self.prev
        assert prev is not None
        before = self.interval
        if before <= 0:
            return prev.lat, prev.lon
        dt2, half = 2 * (t - prev.t), 2 * before
        return (
            prev.lat + (self.step_lat * dt2 + before) // half,
            prev.lon + (self.step_lon * dt2 + before) // half,
        )

    def moved(self, q: _Quantised, shape: tuple[bool, ...]) -> None:
        """``q`` is now the fix before; ``shape`` is ``_shape(q)``, which the caller has."""
        prev = self.prev
        if prev is not None:
            self.interval = q.t - prev.t
            self.step_lat, self.step_lon = q.lat - prev.lat, q.lon - prev.lon
        self.prev = q
        self.shape = shape

    # writing

    def write_all(self, w: BitWriter, fixes: list[_Quantised]) -> None:
        for q in fixes:
            self.moved(q, self.write(w, q))

    def write(self, w: BitWriter, q: _Quantised) -> tuple[bool, ...]:
        """Write ``q``; its shape."""
        prev = self.prev
        dt_now = q.t - prev.t if prev else 0
        exp_lat, exp_lon = self.expected(q.t) if prev else (0, 0)
        relative = prev is not None and (
            _eg_bits(q.lat - exp_lat, K_POSITION) + _eg_bits(q.lon - exp_lon, K_POSITION)
            < LAT_BITS + LON_BITS
        )
        shape = _shape(q)
        # Two flags in one write: absolute position?, the shape of the fix before?
        same = shape == self.shape
        w.write((0 if relative else 2) | same, 2)
        if not same:
            w.write(sum(bit << (3 - i) for i, bit in enumerate(shape)), 4)
        w.signed(dt_now - self.interval if prev else 0, K_TIME)
        if relative:
            w.signed(q.lat - exp_lat, K_POSITION)
            w.signed(q.lon - exp_lon, K_POSITION)
        else:
            w.write(q.lat, LAT_BITS)
            w.write(q.lon, LON_BITS)
        if q.heading is not None:
            if prev is not None and prev.heading is not None:
                w.signed((q.heading - prev.heading + 180) % 360 - 180, K_HEADING)
            else:
                w.write(q.heading, HEADING_BITS)
        if q.speed is not None:
            _write_value(w, q.speed, prev.speed if prev else None, K_SPEED, K_SPEED_FIRST)
        if q.battery is not None:
            before = prev.battery if prev else None
            _write_value(w, q.battery, before, K_BATTERY, K_BATTERY_FIRST)
        if q.readings is not None:
            self.write_readings(w, q.readings, prev.readings if prev else None)
        return shape

    def write_readings(
        self, w: BitWriter, readings: dict[int, int], before: dict[int, int] | None
    ) -> None:
        present = sorted(readings)
        if before is not None and sorted(before) == present:
            w.write(1, 1)
        else:
            w.write(0, 1)
            for i in range(len(self.channels)):
                w.write(1 if i in readings else 0, 1)
        for i in present:
            old = before.get(i) if before else None
            if old is None:
                w.signed(readings[i], K_READING_FIRST)
            else:
                w.signed(readings[i] - old, K_READING)

    # reading

    def read(self, r: BitReader, base: int, readings_allowed: bool) -> _Quantised:
        prev = self.prev
        flags = r.read(2)  # absolute position?, the shape of the fix before?
        if prev is None and not flags & 2:
            raise CompactError("the first fix of a payload must have an absolute position")
        if flags & 1:
            shape = self.shape
        else:
            bits = r.read(4)
            shape = (bool(bits & 8), bool(bits & 4), bool(bits & 2), bool(bits & 1))
        change = r.signed(K_TIME)
        t = prev.t + self.interval + change if prev else base + change
        if not 0 <= t <= MAX_TIME or (prev is None and change):
            raise CompactError("a fix's time is out of range")
        if flags & 2:
            lat, lon = r.read(LAT_BITS), r.read(LON_BITS)
        else:
            exp_lat, exp_lon = self.expected(t)
            lat, lon = exp_lat + r.signed(K_POSITION), exp_lon + r.signed(K_POSITION)
        if not (0 <= lat <= LAT_MAX and 0 <= lon <= LON_MAX):
            raise CompactError("a fix's position is out of range")
        heading = speed = battery = None
        if shape[0]:
            if prev is not None and prev.heading is not None:
                heading = (prev.heading + r.signed(K_HEADING)) % 360
            else:
                heading = r.read(HEADING_BITS)
                if heading >= 360:
                    raise CompactError("a heading is out of range")
        if shape[1]:
            speed = _read_value(r, prev.speed if prev else None, K_SPEED, K_SPEED_FIRST)
            if not 0 <= speed <= SPEED_MAX:
                raise CompactError("a speed is out of range")
        if shape[2]:
            battery = _read_value(r, prev.battery if prev else None, K_BATTERY, K_BATTERY_FIRST)
            if not 0 <= battery <= BATTERY_MAX:
                raise CompactError("a battery voltage is out of range")
        readings = None
        if shape[3]:
            if not readings_allowed:
                raise CompactError("a fix has readings the header does not announce")
            readings = self.read_readings(r, prev.readings if prev else None)
        q = _Quantised(t, lat, lon, heading, speed, battery, readings)
        self.moved(q, shape)
        return q

    def read_readings(self, r: BitReader, before: dict[int, int] | None) -> dict[int, int]:
        if r.read(1):
            if before is None:
                raise CompactError("a fix repeats channels the fix before it does not have")
            present = sorted(before)
        else:
            present = [i for i in range(len(self.channels)) if r.read(1)]
        if not present or len(present) > MAX_READINGS:
            raise CompactError(f"a fix's readings must name 1 to {MAX_READINGS} channels")
        out = {}
        for i in present:
            old = before.get(i) if before else None
            out[i] = r.signed(K_READING_FIRST) if old is None else old + r.signed(K_READING)
        return out


def _shape(q: _Quantised) -> tuple[bool, ...]:
    return (q.heading is not None, q.speed is not None, q.battery is not None, bool(q.readings))


def _write_value(w: BitWriter, value: int, before: int | None, k: int, k_first: int) -> None:
    if before is None:
        w.exp_golomb(value, k_first)
    else:
        w.signed(value - before, k)


def _read_value(r: BitReader, before: int | None, k: int, k_first: int) -> int:
    return r.exp_golomb(k_first) if before is None else before + r.signed(k)


# --- decoding ----------------------------------------------------------------------------------


def decode(payload: bytes, channels: Sequence[Channel] = ()) -> list[dict[str, Any]]:
    """The fixes of a payload, in the v1 API's fix shape (time as ISO 8601 UTC), or
    CompactError saying why these bytes are not one."""
    if not isinstance(payload, bytes | bytearray | memoryview):
        raise CompactError("a compact payload is bytes")
    payload = bytes(payload)
    if len(payload) < HEADER.size + 1 + CRC_BYTES:
        raise CompactError("too short for a compact payload")
    if payload[0] != MARK:
        if payload[0] >> 4 == MARK >> 4:
            raise CompactError(f"compact payload version {payload[0] & 0x0F}; this reads {VERSION}")
        raise CompactError("not a compact payload (its first byte)")
    body, crc = payload[:-CRC_BYTES], int.from_bytes(payload[-CRC_BYTES:], "big")
    if crc16(body) != crc:
        raise CompactError("the payload's checksum does not match: damaged in transit")
    _, flags, table, base = HEADER.unpack_from(body)
    if flags & ~FLAG_READINGS:
        raise CompactError("unknown flags in the payload's header")
    readings_allowed = bool(flags & FLAG_READINGS)
    if readings_allowed and table != table_id(channels):
        raise CompactError(
            f"the payload's readings follow channel table {table:#04x}; this vessel's is "
            f"{table_id(channels):#04x} (the boat and the server must list the same channels)"
        )
    r = BitReader(body[HEADER.size :])
    try:
        count = r.exp_golomb(K_COUNT) + 1
        if count > MAX_FIXES:
            raise CompactError(f"more than {MAX_FIXES} fixes")
        stream = _Stream(channels)
        fixes = []
        for _ in range(count):
            fixes.append(stream.read(r, base, readings_allowed))
        if r.remaining >= 8 or r.read(r.remaining):
            raise CompactError("bytes after the last fix")
    except BitsError as exc:
        raise CompactError(str(exc)) from None
    days: dict[int, str] = {}
    readers = [(c.name, _divisor(c.step), c.step) for c in channels]
    return [_fix(q, readers, days) for q in fixes]


def _divisor(step: float) -> int | None:
    """``n`` when ``step`` is ``1/n`` (0.1, 0.01…): a value is then ``steps / n``, which is the
    double nearest its decimal (``181 / 10`` is 18.1; ``181 * 0.1`` is 18.100000000000001)."""
    n = round(1 / step)
    return n if n >= 1 and abs(n * step - 1) < 1e-12 else None


# Per channel: its name, and how its steps become a value (_divisor, else the step).
_Readers = list[tuple[str, int | None, float]]


def _fix(q: _Quantised, readers: _Readers, days: dict[int, str]) -> dict[str, Any]:
    day, second = divmod(q.t, 86400)
    if day not in days:  # a batch mostly shares a day or two: format each once
        days[day] = dt.datetime.fromtimestamp(day * 86400, dt.UTC).strftime("%Y-%m-%dT")
    hours, second = divmod(second, 3600)
    # round(x * 1e7) / 1e7, not round(x, 7): the same tidy number (to 1e-7°, a hundredth of a
    # step), and round() with digits formats a decimal string: most of a decode's time.
    fix: dict[str, Any] = {
        "time": f"{days[day]}{hours:02d}:{second // 60:02d}:{second % 60:02d}Z",
        "lat": round((q.lat / LAT_SCALE - 90) * 1e7) / 1e7,
        "lon": round((q.lon / LON_SCALE - 180) * 1e7) / 1e7,
    }
    if q.heading is not None:
        fix["heading_deg"] = float(q.heading)
    if q.speed is not None:
        fix["speed_mps"] = q.speed / SPEED_DIVISOR
    if q.battery is not None:
        fix["battery_v"] = q.battery / BATTERY_DIVISOR
    if q.readings:
        readings = {}
        for i, v in sorted(q.readings.items()):
            name, n, step = readers[i]
            readings[name] = v / n if n else round(v * step, 9)
        fix["readings"] = readings
    return fix
