"""The wire shape of one fix (boat API v1, ``POST /api/v1/telemetry/``): its fields and ranges.

The boat writes fixes in this shape (``edge_client/vehicle.py``), the server's parser checks
them against it (``telemetry/parsing.py``) and the API schema describes it (``telemetry/api``):
one list, so the schema cannot drift from what the parser accepts.
"""

from __future__ import annotations

# Every field of a v1 fix, in the order the exports write them; time, lat and lon are required.
FIELDS: tuple[str, ...] = (
    "time",
    "lat",
    "lon",
    "heading_deg",
    "speed_mps",
    "battery_v",
    "readings",
)
REQUIRED: tuple[str, ...] = ("time", "lat", "lon")
# (minimum, maximum) of every number field, both inclusive (a heading of 360 is kept as 0).
RANGES: dict[str, tuple[float, float]] = {
    "lat": (-90, 90),
    "lon": (-180, 180),
    "heading_deg": (0, 360),
    "speed_mps": (0, 1000),
    "battery_v": (0, 1000),
}
# The number fields, in FIELDS' order (the exports' columns between time and readings).
NUMBERS: tuple[str, ...] = tuple(name for name in FIELDS if name in RANGES)
MAX_READINGS = 64  # name: number pairs in one fix's readings
MAX_READING_NAME = 50  # characters
# Readings the boat names itself from its autopilot, beside the sensors its configuration maps
# (edge_client/vehicle.py): armed 0/1, the Rover mode number, the mission item and the
# operator's waypoint of waypoints, and the autopilot's fence: breached 0/1 (FENCE_STATUS
# breach_status, or a breach begun since the previous fix) and its breach_count; only while a
# fence is on, as ArduPilot reports it then.
FENCE_BREACHED = "fence_breached"
FENCE_BREACH_COUNT = "fence_breach_count"
AUTOPILOT_READINGS: tuple[str, ...] = (
    "armed",
    "mode_number",
    "mission_item",
    "waypoint",
    "waypoints",
    FENCE_BREACHED,
    FENCE_BREACH_COUNT,
)
