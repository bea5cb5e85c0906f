"""Normalise one telemetry record into a FixData, or say what is wrong with it. Pure.

Two wire shapes (docs/api.md): the v1 boat API (`time`, `lat`, `lon`, optional `heading_deg`,
`speed_mps`, `battery_v`, `readings`) and the original, legacy SPAB shape (`timestamp`, `latitude`,
`longitude` and any other numeric keys as readings; docs/api.md#legacy-spab-endpoints).
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field
from typing import Any

# The plausibility rule is shared with the other uploads (reported commands, the SMS log).
from edge_client.contract import fix as fix_shape
from vessels.clock import PLAUSIBLE_FROM as PLAUSIBLE_FROM  # re-exported
from vessels.clock import check_plausible
from vessels.text import unstorable

UTC = dt.UTC
# The old Shoreside server counted time in units of 10 µs since 2015-01-01 (docs/api.md).
LEGACY_EPOCH = dt.datetime(2015, 1, 1, tzinfo=UTC)
LEGACY_TICKS_PER_S = 100_000
# v1's fields, ranges and readings limits are the boat–shore contract's.
MAX_READINGS, MAX_READING_NAME = fix_shape.MAX_READINGS, fix_shape.MAX_READING_NAME

LEGACY_FIELDS = frozenset({"timestamp", "latitude", "longitude"})
V1_FIELDS = frozenset(fix_shape.FIELDS)


@dataclass(frozen=True, slots=True)
class FixData:
    recorded_at: dt.datetime
    lat: float
    lon: float
    heading_deg: float | None = None
    speed_mps: float | None = None
    battery_v: float | None = None
    readings: dict[str, float] = field(default_factory=dict)


class FixErrors(Exception):
    """A record that cannot become a fix; ``errors`` maps field names to messages."""

    def __init__(self, errors: dict[str, str]) -> None:
        super().__init__("; ".join(f"{k}: {v}" for k, v in errors.items()))
        self.errors = errors


def _shown(name: str) -> str:
    """``name`` fit to echo in a JSON reply: a lone surrogate (a valid JSON escape, but not
    Unicode) becomes its ``\\udXXX`` spelling instead of failing the reply's UTF-8 encoding."""
    return name.encode("utf-8", "backslashreplace").decode("utf-8")


def _storable(name: str) -> bool:
    """PostgreSQL's jsonb refuses NUL and lone surrogates (a whole INSERT fails with them);
    SQLite would keep a surrogate and then every page showing the fix would fail to render."""
    return "\x00" not in name and _shown(name) == name


def _number(value: Any) -> float | None:
    """A finite float, or None when ``value`` is not a JSON number (bools are not numbers)."""
    # Exact type checks: the JSON decoder makes only these, `type(True)` is bool, not int,
    # and this runs eight times per fix in the ingest's hot loop.
    kind = type(value)
    if kind is float:
        return value if math.isfinite(value) else None
    if kind is not int:
        return None
    try:
        return float(value)
    except OverflowError:  # JSON integers have no size limit; 10**400 is no coordinate
        return None


def parse_time(value: Any, *, now: dt.datetime, max_future_s: float) -> dt.datetime:
    """ISO 8601 with an offset, or Unix seconds; within [PLAUSIBLE_FROM, now + max_future_s]."""
    if isinstance(value, str):
        if problem := unstorable(value):  # fromisoformat stops at a NUL: "...Z\x00junk" parsed
            raise ValueError(problem)
        try:
            when = dt.datetime.fromisoformat(value)
        except ValueError:
            raise ValueError("must be ISO 8601 (with offset) or Unix seconds") from None
        if when.tzinfo is None:
            raise ValueError("needs a UTC offset, e.g. 2026-11-23T10:00:00Z")
    else:
        seconds = _number(value)
        if seconds is None:
            raise ValueError("must be ISO 8601 (with offset) or Unix seconds")
        try:
            when = dt.datetime.fromtimestamp(seconds, UTC)
        except (OverflowError, OSError, ValueError):
            raise ValueError("is out of range") from None
    check_plausible(when, now=now, max_future_s=max_future_s)
    return when.astimezone(UTC)


def _optional(
    record: dict[str, Any],
    name: str,
    lo: float,
    hi: float,
    errors: dict[str, str],
    *,
    hi_open: bool = False,
) -> float | None:
    value = record.get(name)
    if value is None:
        return None
    number = _number(value)
    if number is None:
        errors[name] = "must be a number"
        return None
    if number < lo or number > hi or (hi_open and number == hi):
        errors[name] = f"must be between {lo:g} and {hi:g}"
        return None
    return number


def _position(
    lat_raw: Any, lon_raw: Any, errors: dict[str, str], names: tuple[str, str] = ("lat", "lon")
) -> tuple[float, float]:
    lat, lon = _number(lat_raw), _number(lon_raw)
    for name, raw, value, (lo, hi) in (
        (names[0], lat_raw, lat, fix_shape.RANGES["lat"]),
        (names[1], lon_raw, lon, fix_shape.RANGES["lon"]),
    ):
        if raw is None:
            errors[name] = "is required"
        elif value is None:
            errors[name] = "must be a number"
        elif not lo <= value <= hi:
            errors[name] = f"must be between {lo:g} and {hi:g}"
    return lat or 0.0, lon or 0.0


def _readings(raw: Any, errors: dict[str, str]) -> dict[str, float]:
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        errors["readings"] = "must be an object of name: number"
        return {}
    if len(raw) > MAX_READINGS:
        errors["readings"] = f"has more than {MAX_READINGS} values"
        return {}
    clean: dict[str, float] = {}
    for name, value in raw.items():
        number = _number(value)
        if len(name) > MAX_READING_NAME or not name:
            errors["readings"] = f"name {name[:20]!r} must be 1-{MAX_READING_NAME} characters"
        elif not _storable(name):
            errors["readings"] = f"name {name[:20]!r} holds a character that cannot be stored"
        elif number is None:
            errors["readings"] = f"{_shown(name)} must be a number"
        else:
            clean[name] = number
    return clean


def parse_fix(record: Any, *, now: dt.datetime, max_future_s: float = 300) -> FixData:
    """Validate one v1 telemetry record; raise FixErrors naming every problem found."""
    if not isinstance(record, dict):
        raise FixErrors({"non_field_errors": "each fix must be a JSON object"})
    errors: dict[str, str] = {}
    unknown = sorted(set(record) - V1_FIELDS)
    if unknown:
        errors[_shown(unknown[0])] = f"unknown field (allowed: {', '.join(sorted(V1_FIELDS))})"
    recorded_at = now
    if "time" not in record:
        errors["time"] = "is required"
    else:
        try:
            recorded_at = parse_time(record["time"], now=now, max_future_s=max_future_s)
        except ValueError as exc:
            errors["time"] = str(exc)
    lat, lon = _position(record.get("lat"), record.get("lon"), errors)
    heading = _optional(record, "heading_deg", *fix_shape.RANGES["heading_deg"], errors)
    speed = _optional(record, "speed_mps", *fix_shape.RANGES["speed_mps"], errors)
    battery = _optional(record, "battery_v", *fix_shape.RANGES["battery_v"], errors)
    readings = _readings(record.get("readings"), errors)
    if errors:
        raise FixErrors(errors)
    return FixData(
        recorded_at=recorded_at,
        lat=lat,
        lon=lon,
        # 360 and 0 are the same bearing; the database keeps [0, 360).
        heading_deg=None if heading is None else heading % 360,
        speed_mps=speed,
        battery_v=battery,
        readings=readings,
    )


def legacy_time(raw: Any, *, now: dt.datetime, max_future_s: float) -> dt.datetime | None:
    """Legacy `timestamp`: Unix seconds, else 10 µs ticks since 2015, else None (implausible)."""
    value = _legacy_number(raw)
    if value is None:
        return None
    for interpret in (_from_unix_seconds, _from_legacy_ticks):
        try:
            when = interpret(value)
            check_plausible(when, now=now, max_future_s=max_future_s)
        except (OverflowError, OSError, ValueError):
            continue
        return when
    return None


def _legacy_number(value: Any) -> float | None:
    """A number, or a string holding one: the old clients built their JSON by hand."""
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            return None
    return _number(value)


def _from_unix_seconds(value: float) -> dt.datetime:
    return dt.datetime.fromtimestamp(value, UTC)


def _from_legacy_ticks(value: float) -> dt.datetime:
    return LEGACY_EPOCH + dt.timedelta(seconds=value / LEGACY_TICKS_PER_S)


def parse_legacy_fix(
    record: Any, *, now: dt.datetime, index: int = 0, max_future_s: float = 300
) -> FixData:
    """Validate one legacy SPAB record (docs/api.md#legacy-spab-endpoints).

    A timestamp in neither known unit (e.g. the old client's milliseconds since boot) gets the
    receive time, offset by ``index`` microseconds so fixes of one batch stay distinct, and the
    raw value is kept as reading `timestamp_raw`. Every other key is a reading: at most
    MAX_READINGS of them, each name at most MAX_READING_NAME characters (v1's limits), or the
    record is rejected saying which.
    """
    if not isinstance(record, dict):
        raise FixErrors({"non_field_errors": "each record must be a JSON object"})
    errors: dict[str, str] = {}
    lat, lon = _position(
        record.get("latitude"), record.get("longitude"), errors, names=("latitude", "longitude")
    )
    readings: dict[str, float] = {}
    names = [name for name in record if name not in LEGACY_FIELDS]
    if len(names) > MAX_READINGS:
        # v1's cap: a record of thousands made every page and fleet poll carry them all.
        errors["readings"] = f"has {len(names)} values (at most {MAX_READINGS})"
        names = []
    for name in names:
        number = _number(record[name])
        if not _storable(name):
            errors[_shown(name)] = "name holds a character that cannot be stored"
        elif len(name) > MAX_READING_NAME:
            errors[name[:20] + "…"] = f"name is longer than {MAX_READING_NAME} characters"
        elif number is None:
            errors[name] = "must be a number"
        else:
            readings[name] = number
    recorded_at = legacy_time(record.get("timestamp"), now=now, max_future_s=max_future_s)
    if recorded_at is None:
        recorded_at = now + dt.timedelta(microseconds=index)
        raw = _legacy_number(record.get("timestamp"))
        if raw is not None:
            readings["timestamp_raw"] = raw
    if errors:
        raise FixErrors(errors)
    return FixData(recorded_at=recorded_at, lat=lat, lon=lon, readings=readings)
