"""What every mission file format reads into and writes from (pure).

A ``MissionFile`` holds only what a Shoreside mission holds: waypoints with their hold time,
acceptance radius and speed change, how the mission ends, and the planned home (kept as the
mission's home, never as a waypoint). ``skipped`` lists, in words, each item of the file that
was left out because the caller asked to skip unsupported items.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

from vessels.errors import MissionFileError
from vessels.missions import (
    ENDS,
    HOLD_MAX_S,
    ITEM_FIELDS,
    LAT_RANGE,
    LON_RANGE,
    RADIUS_MAX_M,
    RADIUS_MIN_M,
    SPEED_MAX_MPS,
    SPEED_MIN_MPS,
)
from vessels.text import UNSTORABLE


@dataclass(frozen=True)
class Item:
    lat: float
    lon: float
    hold_s: float = 0.0
    radius_m: float | None = None
    speed_mps: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in ITEM_FIELDS}


@dataclass(frozen=True)
class MissionFile:
    items: tuple[Item, ...]
    end: str = "stop"
    home: tuple[float, float] | None = None
    name: str = ""
    skipped: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        if self.end not in ENDS:
            raise ValueError(f"end must be one of {', '.join(ENDS)}")


def is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def finite(value: Any) -> bool:
    try:
        return is_number(value) and math.isfinite(value)
    except OverflowError:  # a JSON integer past float's range
        return False


def position(where: str, lat: Any, lon: Any) -> tuple[float, float]:
    """(lat, lon) as floats, or a MissionFileError naming ``where`` (NaN, out of range)."""
    if not (finite(lat) and finite(lon)):
        raise MissionFileError(
            f"{where}: latitude and longitude must be numbers (got {lat!r}, {lon!r})"
        )
    (lat_lo, lat_hi), (lon_lo, lon_hi) = LAT_RANGE, LON_RANGE
    if not (lat_lo <= lat <= lat_hi and lon_lo <= lon <= lon_hi):
        raise MissionFileError(
            f"{where}: position {lat}, {lon} is outside {lat_lo:g}…{lat_hi:g} latitude, "
            f"{lon_lo:g}…{lon_hi:g} longitude"
        )
    return float(lat), float(lon)


# The API's rule for text (vessels.text, as DRF's CharField): PostgreSQL cannot store NUL, and
# a lone surrogate (a valid JSON escape, but not UTF-8) breaks every page that shows it.


def checked_text(where: str, value: str) -> str:
    """``value``, a string taken from a file, if it can be stored and shown; else a
    MissionFileError naming ``where`` (the offending text is not echoed: it cannot be)."""
    found = UNSTORABLE.search(value)
    if found:
        char = "a NUL character" if found.group() == "\x00" else "a lone surrogate"
        raise MissionFileError(
            f"{where}: the text holds {char} (U+{ord(found.group()):04X}), which cannot be stored"
        )
    return value


def hold(where: str, value: Any) -> float:
    if value is None or (is_number(value) and math.isnan(value)):
        return 0.0
    if not finite(value) or not 0 <= value <= HOLD_MAX_S:
        raise MissionFileError(f"{where}: hold time {value!r} s is not within 0…{HOLD_MAX_S:g} s")
    return float(value)


def radius(where: str, value: Any) -> float | None:
    """An acceptance radius; 0 or missing means the autopilot's own (WP_RADIUS): None."""
    if value is None or (is_number(value) and math.isnan(value)) or value == 0:
        return None
    if not finite(value) or not RADIUS_MIN_M <= value <= RADIUS_MAX_M:
        raise MissionFileError(
            f"{where}: acceptance radius {value!r} m is not within "
            f"{RADIUS_MIN_M:g}…{RADIUS_MAX_M:g} m"
        )
    return float(value)


def speed(where: str, value: Any) -> float:
    if not finite(value) or not SPEED_MIN_MPS <= value <= SPEED_MAX_MPS:
        raise MissionFileError(
            f"{where}: speed {value!r} m/s is not within {SPEED_MIN_MPS:g}…{SPEED_MAX_MPS:g} m/s"
        )
    return float(value)


def finish(
    items: list[Item],
    *,
    end: str,
    home: tuple[float, float] | None,
    name: str,
    errors: list[str],
    unsupported: list[str],
    skip_unsupported: bool,
) -> MissionFile:
    """The mission read from a file, or a MissionFileError listing every invalid item and,
    unless the caller skips them, every unsupported one. Nothing is dropped silently: the
    skipped items are listed on the result."""
    if errors or (unsupported and not skip_unsupported):
        problems = errors + unsupported
        if unsupported and not errors:
            problems.append("to import the rest, import again skipping unsupported items")
        raise MissionFileError(problems[0], problems=problems)
    if not items:
        raise MissionFileError("the file has no waypoints a boat can sail to")
    return MissionFile(
        items=tuple(items), end=end, home=home, name=name, skipped=tuple(unsupported)
    )


def text(content: bytes | str) -> str:
    if isinstance(content, str):
        return content
    try:
        return content.decode("utf-8-sig")  # -sig: Windows tools write a byte-order mark
    except UnicodeDecodeError:
        raise MissionFileError("the file is not UTF-8 text") from None


def load_json(content: bytes | str, what: str) -> Any:
    try:
        return json.loads(text(content))
    except RecursionError:
        raise MissionFileError(f"not a {what} file: the JSON is nested too deeply") from None
    except ValueError as exc:
        raise MissionFileError(f"not a {what} file: invalid JSON ({exc})") from None


def known_home(lat: float, lon: float) -> tuple[float, float] | None:
    """ArduPilot reports home as 0, 0 until it has one (docs/missions.md#files);
    Shoreside writes a mission with no planned home that way too."""
    return None if lat == 0 and lon == 0 else (lat, lon)
