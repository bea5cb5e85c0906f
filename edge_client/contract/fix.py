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
