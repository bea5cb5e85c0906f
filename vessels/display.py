"""How an operator reads a time, a position, a speed and a reading: one format, everywhere.

Pure (stdlib only). The admin pages format with these functions; the map pages' scripts use
the same rules in ``vessels/static/vessels/mapkit.js`` (``Shoreside.fmt*``), and a browser test
compares the two. Times are UTC with seconds and say so (fixes come every few seconds, so a
minutes-only time makes neighbours look identical); positions are decimal degrees with the
degrees-and-decimal-minutes form beside them for a hover; speeds carry m/s and knots.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping
from decimal import ROUND_HALF_UP, Decimal
from typing import Any

from edge_client.contract.kinds import ROVER_MODE_NAMES

KNOTS_PER_MPS = 3600 / 1852  # one knot is one nautical mile (1852 m) an hour
POSITION_DECIMALS = 5  # about 1 m of latitude
DDM_MINUTE_DECIMALS = 3
NONE = "–"
# Battery voltage is a Fix column, not a reading, but pages label it as one.
BATTERY = {"label": "Battery", "unit": "V"}

# Readings that hold a state, not a quantity: named values, plotted as steps, never averaged.
# The autopilot's mode number is named from Rover's mode table (the catalog's), `armed` as a
# word. `alone`: the value's name says it all ("armed"), so compact lists drop the label.
STATE_CHANNELS: dict[str, dict[str, Any]] = {
    "mode_number": {
        "label": "Mode",
        "states": ROVER_MODE_NAMES,
        "alone": False,
    },
    "armed": {"label": "Armed", "states": {0: "disarmed", 1: "armed"}, "alone": True},
}


def fixed(value: float, digits: int) -> str:
    """``value`` to ``digits`` decimals, ties away from zero as JavaScript's toFixed rounds
    (Python's format rounds them to even: 0.25 would be 0.2 here and 0.3 on the page)."""
    exact = Decimal(value).quantize(Decimal(1).scaleb(-digits), rounding=ROUND_HALF_UP)
    return f"{exact:.{digits}f}"


def fmt_time(value: dt.datetime | None) -> str:
    """``2026-11-25 14:03:27 UTC``. A naive datetime is taken as UTC (the database's own)."""
    if value is None:
        return NONE
    if value.tzinfo is None:
        value = value.replace(tzinfo=dt.UTC)
    return value.astimezone(dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC")


def fmt_position(lat: float | None, lon: float | None) -> str:
    """Decimal degrees at a fixed precision: ``-32.03800°, 115.33250°``."""
    if lat is None or lon is None:
        return NONE
    return f"{fixed(lat, POSITION_DECIMALS)}°, {fixed(lon, POSITION_DECIMALS)}°"


def _ddm_part(value: float, positive: str, negative: str) -> str:
    # Round the minutes first so 59.9996′ carries into the degrees, never shows as 60.000′;
    # halves up, as the pages' Math.round does (round() would take them to even).
    thousandths = math.floor(abs(value) * 60 * 10**DDM_MINUTE_DECIMALS + 0.5)
    degrees, minutes = divmod(thousandths, 60 * 10**DDM_MINUTE_DECIMALS)
    hemisphere = positive if value >= 0 else negative
    return f"{degrees}°{minutes / 10**DDM_MINUTE_DECIMALS:06.{DDM_MINUTE_DECIMALS}f}′{hemisphere}"


def fmt_ddm(lat: float | None, lon: float | None) -> str:
    """Degrees and decimal minutes, as on a chart: ``32°02.280′S 115°19.950′E``."""
    if lat is None or lon is None:
        return NONE
    return f"{_ddm_part(lat, 'N', 'S')} {_ddm_part(lon, 'E', 'W')}"


def fmt_speed(mps: float | None) -> str:
    """``1.5 m/s (2.9 kn)``."""
    if mps is None:
        return NONE
    return f"{fixed(mps, 1)} m/s ({fixed(mps * KNOTS_PER_MPS, 1)} kn)"


def fmt_heading(degrees: float | None) -> str:
    """Three digits, as a compass course is said: ``090°``."""
    if degrees is None:
        return NONE
    return f"{math.floor(degrees + 0.5) % 360:03d}°"


def fmt_number(value: Any) -> str:
    """A reading's number: at most 2 decimals (1 from 100 up), no trailing zeros: 12.4, 41."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return str(value)
    if isinstance(value, int) or (math.isfinite(value) and value.is_integer()):
        return str(int(value))
    text = fixed(value, 1) if abs(value) >= 100 else fixed(value, 2)
    text = text.rstrip("0").rstrip(".") if "." in text else text
    return "0" if text == "-0" else text


def state_name(key: str, value: Any) -> str | None:
    """The name of a state channel's value (``HOLD``, ``armed``), None if it has none."""
    channel = STATE_CHANNELS.get(key)
    if channel is None or isinstance(value, bool) or not isinstance(value, int | float):
        return None
    if not math.isfinite(value) or not float(value).is_integer():
        return None
    return channel["states"].get(int(value))


def fmt_reading(key: str, value: Any, channels: Mapping[str, Mapping[str, Any]]) -> str:
    """One reading for a compact list: ``humidity 41 %``, ``Mode HOLD``, ``disarmed``.

    ``channels`` is {key: {label, unit}} (SensorChannel rows); a key without one shows as is.
    """
    known = channels.get(key) or {}
    state = STATE_CHANNELS.get(key)
    label = known.get("label") or (state and state["label"]) or key
    name = state_name(key, value)
    if name is not None:
        return name if state and state["alone"] else f"{label} {name}"
    unit = known.get("unit") or ""
    return f"{label} {fmt_number(value)}" + (f" {unit}" if unit else "")


def fmt_readings(
    readings: Mapping[str, Any], channels: Mapping[str, Mapping[str, Any]]
) -> list[str]:
    """Every reading as :func:`fmt_reading` writes it: the states first (mode, armed), then
    the rest by key."""
    states = [key for key in STATE_CHANNELS if key in readings]
    rest = sorted(key for key in readings if key not in STATE_CHANNELS)
    return [fmt_reading(key, readings[key], channels) for key in [*states, *rest]]


def state_channels_config() -> dict[str, dict[str, Any]]:
    """STATE_CHANNELS for a page's JSON config (keys as strings, as JSON has them)."""
    return {
        key: {
            "label": c["label"],
            "states": {str(n): name for n, name in sorted(c["states"].items())},
            "alone": c["alone"],
        }
        for key, c in STATE_CHANNELS.items()
    }
